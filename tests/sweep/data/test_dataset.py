"""Entries → xarray data set → netCDF4 and back: schema of docs/design.md §4.2, derived K_nn, CF units,
exact labels, compact storage, history, atomic write; the CF checkers where they are installed."""

from __future__ import annotations

import functools
import importlib
import importlib.resources
import io
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import h5py
import netCDF4
import numpy as np
import pytest
import xarray as xr

import hpcontact
from hpcontact.accuracy import error_columns
from hpcontact.quantities import rotated_tensor
from hpcontact.scene import Scene
from hpcontact.sweep.data import netcdf
from hpcontact.sweep.data.attributes import SLIP_ATTRS, VARIABLE_ATTRS
from hpcontact.sweep.data.columns import NOT_COMPUTED
from hpcontact.sweep.data.dataset import build_dataset, open_dataset, write_netcdf
from hpcontact.sweep.data.journal import ERROR, OK, Entry
from hpcontact.sweep.data.netcdf import INT_FILL, chunk_shape
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_tasks

ROOT = Path(__file__).resolve().parents[3]
CI = os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")


def required(module: str, what: str):
    """``module``, imported. The `test` extra installs every module these tests need, so a
    missing one fails the test under CI (``CI=true``), where nothing may be skipped silently;
    elsewhere the test skips, naming the install."""
    try:
        return importlib.import_module(module)
    except ImportError:
        message = f"{what} is not installed: pip install -e '.[test]'"
        if CI:
            pytest.fail(f"{message} (CI=true: this test must run)", pytrace=False)
        pytest.skip(message)


SPEC = """
[sweep]
title = "test"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 16
[axes]
shape = ["circle", "ellipse"]
aspect = [1.0, 0.1]
nu = [0.0, 0.5]
angle = { linspace = [0, 180, 7] }
"""


def entries_of(spec, solve, fail=None, missing=None):
    """Journal entries of every task of ``spec`` (``solve`` gives the records), and the point → key map."""
    tasks, where = enumerate_tasks(spec)
    entries = {}
    for t in tasks:
        if t.params == missing:
            continue
        failed = t.params == fail
        entries[t.key] = Entry(
            key=t.key,
            params=t.params,
            status=ERROR if failed else OK,
            message="RuntimeError: x" if failed else "",
            record={} if failed else solve(t.params),
            wall_time_s=0.5,
            finished=0.0,
            rank=0,
        )
    return entries, where


def build(fake_solve, text=SPEC, fail=None, missing=None, attrs=None):
    spec = parse_spec(text, validate=lambda params: None)
    entries, where = entries_of(spec, fake_solve, fail, missing)
    return spec, build_dataset(spec, where, entries, attrs or {"mpi_size": 2, "hpcontact_version": "0.1.0"})


def test_schema(fake_solve):
    spec, ds = build(fake_solve)
    assert dict(ds.sizes) == {"shape": 2, "aspect": 2, "nu": 2, "angle": 7}
    assert ds["shape"].values.tolist() == ["circle", "ellipse"]
    assert ds["nu"].dtype == np.float64 and ds["nu"].attrs == {"long_name": "Poisson ratio", "units": "1"}
    assert ds["angle"].attrs["units"] == "degree"
    assert int(ds["n"]) == 16 and ds["n"].dims == ()  # fixed fields are scalar coordinates
    for name in ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz", "K_a_over_K_b", "normalized_xx", "iterations", "wall_time_s"):
        assert ds[name].dims == ("shape", "aspect", "nu") and ds[name].dtype == np.float64, name
        assert "long_name" in ds[name].attrs and "units" in ds[name].attrs, name
    assert ds["K_xx"].attrs["units"] == "1" and ds["K_xx"].attrs["scale"] == "G a"
    assert ds["K_xx"].attrs["long_name"].endswith("(in units of G a)")
    assert ds["status"].dtype == np.int32 and (ds["status"] == OK).all()
    assert ds["plan"].dims == ("shape", "aspect", "nu") and '"solves": 2' in str(ds["plan"].values[0, 0, 0])
    assert ds.attrs["spec"] == SPEC and ds.attrs["title"] == "test" and ds.attrs["mpi_size"] == 2
    assert ds.attrs["scene_quantities"] == '["tangential", "normal"]'
    # the circle ignores aspect: one solve, the same record at both aspects
    assert float(ds.K_yy.sel(shape="circle", aspect=0.1, nu=0.5)) == float(
        ds.K_yy.sel(shape="circle", aspect=1, nu=0.5)
    )
    assert float(ds.K_yy.sel(shape="ellipse", aspect=0.1, nu=0.5)) != float(
        ds.K_yy.sel(shape="ellipse", aspect=1, nu=0.5)
    )


def test_directional_stiffness_is_derived_from_the_tensor(fake_solve):
    _, ds = build(fake_solve)
    point = ds.sel(shape="ellipse", aspect=0.1, nu=0.5)
    K = np.array([[point.K_xx, point.K_xy], [point.K_yx, point.K_yy]], dtype=np.float64)
    expected = [rotated_tensor(K, a)[0, 0] for a in ds.angle.values]
    np.testing.assert_allclose(point.K_nn.values, expected, rtol=1e-14)
    assert ds.K_nn.dims == ("shape", "aspect", "nu", "angle")
    np.testing.assert_allclose(ds.normalized_nn.isel(angle=0), ds.normalized_xx, rtol=1e-14)


def test_rotated_mode_reads_K_nn_from_K_xx(fake_solve):
    text = SPEC.replace('title = "test"', 'title = "test"\nangle_mode = "rotated"')
    _, ds = build(fake_solve, text)
    assert ds.K_xx.dims == ("shape", "aspect", "nu", "angle")
    assert (ds.K_nn == ds.K_xx).all() and ds.attrs["angle_mode"] == "rotated"


def test_failed_and_missing_tasks(fake_solve):
    bad = {"n": 16, "quantities": ["tangential", "normal"], "shape": "ellipse", "aspect": 0.1, "nu": 0.5}
    lost = {"n": 16, "quantities": ["tangential", "normal"], "shape": "ellipse", "aspect": 1.0, "nu": 0.0}
    _, ds = build(fake_solve, fail=bad, missing=lost)
    failed = ds.sel(shape="ellipse", aspect=0.1, nu=0.5)
    assert int(failed.status) == ERROR and str(failed.message.values) == "RuntimeError: x"
    assert np.isnan(failed.K_xx) and np.isnan(failed.K_nn).all() and float(failed.wall_time_s) == 0.5
    assert int(ds.status.sel(shape="ellipse", aspect=1.0, nu=0.0)) == NOT_COMPUTED
    assert int((ds.status == OK).sum()) == 6


def test_netcdf_round_trip_and_atomic_replace(fake_solve, tmp_path, monkeypatch):
    _, ds = build(fake_solve)
    path = write_netcdf(ds, tmp_path / "sub" / "out.nc")
    with open_dataset(path) as back:
        xr.testing.assert_identical(back.load(), ds)
    before = path.read_bytes()

    def broken(self, *args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", broken)
    with pytest.raises(OSError):
        write_netcdf(ds, path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in path.parent.iterdir()) == ["out.nc"]


LABELS = """
[sweep]
title = "labels"
[scene]
quantities = ["tangential", "normal"]
[axes]
shape = ["ellipse", "rectangle", { label = "hexagon", shape = "polygon", sides = 6 }]
aspect = { logspace = [0, -8, 17] }
nu = { linspace = [0.0, 0.5, 6] }
angle = { linspace = [0, 180, 37] }
"""


def test_the_hypercube_comes_back_point_by_point_from_the_file(fake_solve, tmp_path):
    """Every point of the opened file holds the record of its task (read from the entries, not
    from the data set): labels select exactly, failed tasks are NaN, plans are their JSON."""
    spec = parse_spec(LABELS, validate=lambda params: None)
    bad = spec.scene_params((0, 3, 2))
    entries, where = entries_of(spec, fake_solve, fail=bad)
    path = write_netcdf(build_dataset(spec, where, entries, {}), tmp_path / "labels.nc")
    with hpcontact.open_dataset(path) as ds:
        point = ds.sel(nu=0.3, aspect=1e-4, shape="rectangle")  # linspace/logspace values select exactly
        assert float(point.K_xx) == fake_solve({"shape": "rectangle", "aspect": 1e-4, "nu": 0.3})["K_xx"]
        ds = ds.load()
    labels = [spec.axis(name).values for name in ("shape", "aspect", "nu")]
    assert [ds[name].values.tolist() for name in ("shape", "aspect", "nu")] == [list(v) for v in labels]
    for index, key in where.items():
        entry = entries[key]
        at = {name: i for name, i in zip(("shape", "aspect", "nu"), index)}
        for name in ("K_xx", "K_yy", "K_zz", "iterations"):
            value = float(ds[name].isel(at))
            assert (np.isnan(value) and entry.status != OK) or value == entry.record[name], (name, index)
        assert str(ds["plan"].isel(at).values) == (
            "" if entry.status != OK else '{"kernels": ["xx", "yy"], "solves": 2}'
        )
        assert int(ds["status"].isel(at)) == entry.status
    # K_nn from the stored tensor: n K n at every angle (Li 2017, eq. 6); rounding only
    K = ds[["K_xx", "K_xy", "K_yx", "K_yy"]].sel(shape="hexagon", aspect=1.0, nu=0.5)
    tensor = np.array([[K.K_xx, K.K_xy], [K.K_yx, K.K_yy]], dtype=np.float64)
    expected = [rotated_tensor(tensor, a)[0, 0] for a in ds.angle.values]
    np.testing.assert_allclose(ds.K_nn.sel(shape="hexagon", aspect=1.0, nu=0.5), expected, rtol=1e-14)


def test_open_dataset_is_lazy_with_dask(fake_solve, tmp_path):
    required("dask", "dask (xarray's chunks={} needs it)")
    _, ds = build(fake_solve, LABELS)
    path = write_netcdf(ds, tmp_path / "lazy.nc")
    with hpcontact.open_dataset(path, chunks={}) as lazy:
        assert lazy.K_xx.chunks is not None and lazy.K_nn.chunks is not None  # dask arrays, not read yet
        xr.testing.assert_identical(lazy.load(), ds)


def test_storage_is_compact_and_typed(fake_solve, tmp_path):
    spec = parse_spec(LABELS, validate=lambda params: None)
    entries, where = entries_of(spec, fake_solve)
    ds = build_dataset(spec, where, entries, {})
    path = write_netcdf(ds, tmp_path / "x.nc")
    with netCDF4.Dataset(path) as raw:
        raw.set_auto_mask(False)
        for name in ("shape", "aspect", "nu", "angle", "n" if "n" in raw.variables else "aspect"):
            assert "_FillValue" not in raw[name].ncattrs(), name  # coordinates carry no fill value
        for name in ("iterations", "status"):
            assert raw[name].dtype == np.int32, name
        assert raw["iterations"].getncattr("_FillValue") == INT_FILL
        # plan: text (issue 28 item 7; was int32 codes into a plan_table attribute), compressed
        assert raw["plan"].dtype == "S1" and "plan_table" not in raw["plan"].ncattrs()
        assert raw["plan"].dimensions[:3] == ("shape", "aspect", "nu")
        # K_nn and normalized_nn are stored over angle (issue 28 item 7; were derived on open only)
        for name in ("K_nn", "normalized_nn"):
            assert raw[name].dimensions == ("shape", "aspect", "nu", "angle"), name
        for name in ("message", "plan"):
            filters = raw[name].filters()
            assert filters["zlib"] and filters["shuffle"] and filters["fletcher32"], name
        for name in ("K_xx", "K_nn"):  # floats: compressed where zlib pays (netcdf._compresses), checksummed
            assert raw[name].filters()["zlib"] == netcdf._compresses(np.ma.filled(raw[name][:], np.nan)), name
            assert raw[name].filters()["fletcher32"], name
        assert raw["K_xx"].chunking() == list(raw["K_xx"].shape)  # small: one chunk
        assert raw["plan"].chunking() == list(raw["plan"].shape)
        assert raw["shape"].dtype == "S1"  # labels as char arrays (CF checkers read them)
    with h5py.File(path, "r") as raw:  # the one distinct plan repeats over the points: stored for almost nothing
        plan = raw["plan"]
        assert plan.id.get_storage_size() < 0.02 * plan.size, (plan.id.get_storage_size(), plan.size)
    # a 5 x 20 x 10^4 float64 array (8 MB): ≤ 4 MiB chunks, split along the first axis only
    assert chunk_shape((5, 20, 10_000), 8) == (2, 20, 10_000)
    assert chunk_shape((3, 2), 8) == (3, 2)


def test_history_gains_a_line_per_resumed_run(fake_solve, tmp_path):
    text = LABELS.replace('title = "labels"', f'title = "labels"\noutput = "{tmp_path / "h.nc"}"')
    run = {"created": "2026-01-01T00:00:00+00:00", "history": "hpcontact run labels.toml"}
    _, first = build(fake_solve, text, attrs=run)
    write_netcdf(first, tmp_path / "h.nc")
    resumed = {"created": "2026-01-02T00:00:00+00:00", "history": "hpcontact run labels.toml --resume"}
    _, second = build(fake_solve, text, attrs=resumed)
    assert second.attrs["history"].splitlines() == [
        "2026-01-01T00:00:00+00:00: hpcontact run labels.toml",
        "2026-01-02T00:00:00+00:00: hpcontact run labels.toml --resume",
    ]
    _, fresh = build(fake_solve, text, attrs=run)
    assert fresh.attrs["history"] == "2026-01-01T00:00:00+00:00: hpcontact run labels.toml"


def test_plain_xarray_reads_K_nn_over_angle_and_the_plan_as_text(fake_solve, tmp_path):
    """Any netCDF reader, not only hpcontact.open_dataset, sees what the sweep computed: K_nn and
    normalized_nn over angle, the plan as text, CF attributes that say what the numbers are."""
    spec = parse_spec(LABELS, validate=lambda params: None)
    entries, where = entries_of(spec, fake_solve)
    built = build_dataset(spec, where, entries, {"hpcontact_version": "0.1.0", "git_revision": "abc123"})
    path = write_netcdf(built.drop_vars(["K_nn", "normalized_nn"]), tmp_path / "plain.nc")  # as the driver hands it
    with xr.open_dataset(path) as ds:  # plain xarray: no hpcontact decoding
        assert ds.K_nn.dims == ("shape", "aspect", "nu", "angle") and ds.normalized_nn.dims == ds.K_nn.dims
        K = ds.sel(shape="hexagon", aspect=1.0, nu=0.5)
        tensor = np.array([[K.K_xx, K.K_xy], [K.K_yx, K.K_yy]], dtype=np.float64)
        expected = [rotated_tensor(tensor, a)[0, 0] for a in ds.angle.values]
        np.testing.assert_allclose(K.K_nn, expected, rtol=1e-14)
        np.testing.assert_allclose(ds.normalized_nn.isel(angle=0), ds.normalized_xx, rtol=1e-14)
        plans = ds.plan.values
        assert plans.dtype == object and {str(p) for p in plans.ravel()} == {'{"kernels": ["xx", "yy"], "solves": 2}'}
        assert json.loads(plans[0, 0, 0]) == {"kernels": ["xx", "yy"], "solves": 2}
        # units: the dimensionless ratio to G a, said in long_name, comment and scale; a readable plot label
        attrs = ds.K_nn.attrs
        assert attrs["units"] == "1" and attrs["scale"] == "G a" and attrs["long_name"].endswith("(in units of G a)")
        assert "multiply by G a for the quantity" in attrs["comment"] and "shear modulus" in attrs["comment"]
        label = " ".join(xr.plot.utils.label_from_attrs(ds.K_nn).split())
        assert label == "tangential stiffness along the load direction K_nn(angle) (in units of G a) [1]"
        assert ds.plan.attrs["long_name"] == "kernels built and solves run (JSON)" and "units" not in ds.plan.attrs
        # global CF attributes: source, references, the units convention
        assert ds.attrs["source"].startswith("hpcontact 0.1.0 (git abc123): rigid flat punch")
        assert ds.attrs["references"].splitlines()[0].startswith("hpcontact 0.1.0: ")
        assert any(line.startswith("Q. Li (2017)") for line in ds.attrs["references"].splitlines())
        assert ds.attrs["comment"].startswith("Units convention (hpcontact.sweep.data.units)")
        assert "(G, a)" in ds.attrs["comment"] and 'units = "1"' in ds.attrs["comment"]
    with netCDF4.Dataset(path) as raw:  # what ncdump shows: the variables and their text
        assert raw["K_nn"].dimensions == ("shape", "aspect", "nu", "angle")
        assert raw["plan"].dimensions[:3] == ("shape", "aspect", "nu") and raw["plan"].dtype == "S1"
        assert str(raw["plan"][0, 0, 0]) == '{"kernels": ["xx", "yy"], "solves": 2}'  # chartostring via _Encoding
    with open_dataset(path) as back:  # and hpcontact's reader gives the data set as built
        xr.testing.assert_identical(back.load(), built)


def test_open_dataset_reads_the_stored_K_nn_and_does_not_derive_it_again(fake_solve, tmp_path):
    _, ds = build(fake_solve)
    path = write_netcdf(ds, tmp_path / "stored.nc")
    with netCDF4.Dataset(path, "a") as raw:  # a stored K_nn that the tensor does not give
        raw["K_nn"][:] = 42.0
    with open_dataset(path) as back:
        assert (back.K_nn == 42.0).all() and back.K_nn.attrs == ds.K_nn.attrs
        np.testing.assert_allclose(back.normalized_nn, ds.normalized_nn, rtol=0)  # untouched: as stored


def test_files_without_K_nn_and_with_plan_codes_still_open(fake_solve, tmp_path):
    """A data set written before K_nn and the plan text were stored (K_nn left out, plan as codes
    into the attribute plan_table) opens as the data set built: K_nn derived, plan text."""
    _, ds = build(fake_solve, LABELS)
    text = ds["plan"]
    distinct = list(dict.fromkeys(v for v in text.values.ravel() if v))
    codes = np.array([distinct.index(v) if v else np.nan for v in text.values.ravel()]).reshape(text.shape)
    old = ds.drop_vars(["K_nn", "normalized_nn"]).assign(
        plan=xr.Variable(
            text.dims,
            codes,
            {
                "long_name": "plan of the task: position in the JSON list plan_table of the distinct plans",
                "units": "1",
                "plan_table": json.dumps(distinct),
                "text_attributes": json.dumps(text.attrs),
            },
        )
    )
    path = tmp_path / "old.nc"
    old.to_netcdf(path, engine="netcdf4", encoding={"plan": {"dtype": "int32", "_FillValue": INT_FILL}})
    with open_dataset(path) as back:
        xr.testing.assert_identical(back.load(), ds)


def test_history_is_the_command_as_given(fake_solve, write_spec, tmp_path, monkeypatch):
    """history names the command a user ran: the run_sweep call from Python, the command line
    from a shell (the process's argv, or the argv a caller hands to main)."""
    import hpcontact.cli
    from hpcontact.sweep import driver

    spec = write_spec(SPEC)
    out = hpcontact.run_sweep(spec, output=tmp_path / "python.nc", task_function=fake_solve, stream=io.StringIO())
    with xr.open_dataset(out) as ds:  # the driver's file: K_nn and the plan text for any reader
        created, command = ds.attrs["history"].split(": ", 1)
        assert ds.K_nn.dims == ("shape", "aspect", "nu", "angle") and ds.plan.dtype == object
        assert json.loads(str(ds.plan.values[0, 0, 0])) == {"kernels": ["xx", "yy"], "solves": 2}
    assert (
        command
        == f"hpcontact.run_sweep({str(spec)!r}, output={str(tmp_path / 'python.nc')!r}, task_function=_fake_solve)"
    )
    assert created == ds.attrs["created"]
    # python -m hpcontact.sweep SPEC --output X: main's argv as given
    assert driver.main([str(spec), "--output", str(tmp_path / "cli.nc")], task_function=fake_solve) == 0
    with xr.open_dataset(tmp_path / "cli.nc") as ds:
        assert ds.attrs["history"].split(": ", 1)[1] == f"hpcontact run {spec} --output {tmp_path / 'cli.nc'}"
    # the console command: sys.argv as the shell passed it, --resume appending a line
    from hpcontact.sweep.run import command as run_command

    monkeypatch.setattr(
        run_command, "run_from_arguments", functools.partial(run_command.run_from_arguments, task_function=fake_solve)
    )
    monkeypatch.setattr(
        "sys.argv", ["/somewhere/bin/hpcontact", "run", str(spec), "--output", str(tmp_path / "cli.nc"), "--resume"]
    )
    assert hpcontact.cli.main() == 0
    with xr.open_dataset(tmp_path / "cli.nc") as ds:
        lines = [line.split(": ", 1)[1] for line in ds.attrs["history"].splitlines()]
    assert lines == [
        f"hpcontact run {spec} --output {tmp_path / 'cli.nc'}",
        f"hpcontact run {spec} --output {tmp_path / 'cli.nc'} --resume",
    ]
    # python -m hpcontact.sweep: the module, then the arguments
    monkeypatch.undo()
    monkeypatch.setattr(
        "sys.argv",
        [str(ROOT / "hpcontact" / "sweep" / "__main__.py"), str(spec), "--output", str(tmp_path / "module.nc")],
    )
    assert driver.main(task_function=fake_solve) == 0
    with xr.open_dataset(tmp_path / "module.nc") as ds:
        assert (
            ds.attrs["history"].split(": ", 1)[1]
            == f"python -m hpcontact.sweep {spec} --output {tmp_path / 'module.nc'}"
        )


def test_dimensional_applies_the_scale(fake_solve):
    cf_units = required("cf_units", "cf-units (UDUNITS)")
    from hpcontact.sweep.data.units import dimensional

    _, ds = build(fake_solve)
    K = dimensional(ds.K_xx, G=80e9, a=1e-3)  # a steel-like shear modulus, a 1 mm punch
    np.testing.assert_allclose(K, ds.K_xx * 8e7, rtol=1e-15)
    assert K.attrs["units"] == "Pa m" and cf_units.Unit(K.attrs["units"]).is_convertible(cf_units.Unit("N m-1"))
    assert K.attrs["long_name"] == "stiffness K_xx: force along x per unit displacement along x"
    assert "scale" not in K.attrs and "comment" not in K.attrs
    assert dimensional(ds.K_xx, units="N mm-1", G=80e3, a=1.0).attrs["units"] == "N mm-1"  # MPa mm = N/mm
    with pytest.raises(ValueError, match="give a"):
        dimensional(ds.K_xx, G=80e9)
    nu = ds.nu
    assert dimensional(nu, G=1.0) is nu  # not scaled: unchanged


@pytest.fixture(scope="module")
def job_datasets() -> list[tuple[str, xr.Dataset]]:
    """The data set of every shipped job, built from synthetic records that hold every key the
    job's scene kind can record (each 1.0): every variable the job can write. The tasks are
    enumerated, and costed, as a run enumerates them."""
    out = []
    for path in sorted((ROOT / "jobs").glob("*.toml")):
        spec = parse_spec(path.read_text(), path=path, validate=lambda params: None)
        if spec.kind == "slip":
            names = [name for name, (_, unit) in SLIP_ATTRS.items() if unit]
        else:
            names = [name for name, attrs in VARIABLE_ATTRS.items() if "units" in attrs]
        record = {name: 1.0 for name in names if name != "wall_time_s"}
        entries, where = entries_of(spec, lambda params: dict(record, plan={"solves": 1}))
        out.append((path.name, build_dataset(spec, where, entries, {})))
    return out


@pytest.fixture(scope="module")
def job_files(job_datasets, tmp_path_factory) -> list[tuple[xr.Dataset, Path]]:
    """Every shipped job's synthetic data set with the history line a run gives it (the driver's
    provenance), and the file written of it: what the round trip and the CF checkers read."""
    folder = tmp_path_factory.mktemp("jobs")
    run = {"history": "2026-01-01T00:00:00+00:00: hpcontact run"}
    with_history = [(Path(job).stem, ds.assign_attrs(run)) for job, ds in job_datasets]
    return [(ds, write_netcdf(ds, folder / f"{stem}.nc")) for stem, ds in with_history]


def test_every_shipped_job_round_trips_through_the_file(job_files):
    for ds, path in job_files:
        with open_dataset(path) as back:
            xr.testing.assert_identical(back.load(), ds)


# The physical dimension of each kind of quantity (an independent statement, not the code's tables).
DIMENSIONS = {
    "K_xx": "N m-1",
    "K_nn": "N m-1",
    "dx": "m",
    "load": "N",
    "contact_area": "m2",
    "angle": "radian",
    "orientation": "radian",
    "wall_time_s": "s",
    "tangential_stiffness": "N m-1",
    "stick_area": "m2",
    "tangential_force": "N",
    "E": "Pa",
    "radius2": "m",
    "nu": "1",
    "iterations": "1",
    "max_pressure": "Pa",
}
# A scene's scales in SI, to check the dimension of a ``scale``: G a shear modulus, a and L lengths, F a force.
SCALES_SI = {"G": "Pa", "a": "m", "L": "m", "F": "N"}


def test_every_unit_of_every_shipped_job_parses_to_its_dimension(job_datasets):
    cf_units = required("cf_units", "cf-units (UDUNITS)")
    checked = set()
    for job, ds in job_datasets:
        for name, var in ds.variables.items():
            assert "long_name" in var.attrs, (job, name)
            if var.dtype.kind in "OU":
                continue  # text: labels, messages, JSON
            assert "units" in var.attrs or "flag_values" in var.attrs, (job, name)
            if "units" not in var.attrs:
                continue
            unit = cf_units.Unit(var.attrs["units"])  # raises on a string UDUNITS cannot read
            assert not unit.is_unknown(), (job, name)
            if "scale" in var.attrs:  # a ratio to the scene's scale: dimensionless, the scale in the name
                assert var.attrs["units"] == "1" and var.attrs["scale"] in var.attrs["long_name"], (job, name)
                unit = cf_units.Unit(
                    re.sub(r"\b([GaLF])(?=-?\d*\b)", lambda m: SCALES_SI[m.group(1)], var.attrs["scale"])
                )
            if name in DIMENSIONS:
                assert unit.is_convertible(cf_units.Unit(DIMENSIONS[name])), (job, name, var.attrs)
                checked.add(name)
    assert checked == set(DIMENSIONS)


def test_every_unit_parses_with_pint_as_udunits_reads_it(job_datasets):
    """pint (cf_xarray's UDUNITS-syntax registry) reads every unit as the same amount of the
    same base units as UDUNITS, and pint-xarray quantifies every data set."""
    units = required("cf_xarray.units", "cf_xarray and pint").units
    required("pint_xarray", "pint-xarray")
    cf_units = required("cf_units", "cf-units (UDUNITS)")
    for job, ds in job_datasets:
        ds.drop_vars([name for name in ds.variables if ds[name].dtype.kind in "OU"]).pint.quantify(unit_registry=units)
        for name, var in ds.variables.items():
            if "units" in var.attrs:
                base = units.Quantity(1.0, var.attrs["units"]).to_base_units()
                udunits = cf_units.Unit(var.attrs["units"]).convert(1.0, cf_units.Unit(f"{base.units:cf}" or "1"))
                assert udunits == pytest.approx(base.magnitude, rel=1e-12), (job, name)  # rounding of pi/180


def _stub_tables(folder: Path) -> list[str]:
    """cfchecks' area-type and region tables as empty stubs (the data sets use neither), so the
    checker runs offline (it downloads them otherwise; the standard names: ``cfchecks``)."""
    tables = {"-a": ("standard_area_type_table", "a.xml"), "-r": ("standardized_region_list", "r.xml")}
    args = []
    for flag, (root, name) in tables.items():
        (folder / name).write_text(
            f'<?xml version="1.0"?>\n<{root}><version_number>0</version_number>'
            f"<date>none</date><last_modified>none</last_modified></{root}>\n"
        )
        args += [flag, str(folder / name)]
    return args


@pytest.fixture(scope="module")
def real_demo(tmp_path_factory) -> Path:
    """The demo job's shapes at two b/a, two nu, A = 1 and 2, one ψ and n = 16 (instead of its
    accuracy), solved by the engine (~3 s)."""
    folder = tmp_path_factory.mktemp("demo")
    text = (ROOT / "jobs" / "demo.toml").read_text()
    for key, line in (
        ("accuracy", "n = 16"),
        ("tol", "tol = 1e-8"),
        ("aspect", "aspect = [1.0, 1e-4]"),
        ("nu", "nu = [0.0, 0.3]"),
        ("anisotropy", "anisotropy = [1.0, 2.0]"),
        ("orientation", "orientation = [20.0]"),
    ):
        text, count = re.subn(rf"(?m)^{key} = .*$", line, text)
        assert count == 1, key
    spec = parse_spec(text, path=ROOT / "jobs" / "demo.toml", validate=lambda params: None)
    entries, where = entries_of(spec, lambda fields: hpcontact.problems.contact.solve(Scene.from_params(fields)))
    attrs = {"created": "2026-01-01T00:00:00+00:00", "history": "hpcontact run jobs/demo.toml", "mpi_size": 1}
    return write_netcdf(build_dataset(spec, where, entries, attrs), folder / "demo.nc")


def test_the_engine_records_have_names_and_units(real_demo):
    with hpcontact.open_dataset(real_demo) as ds:
        for name, var in ds.variables.items():
            assert "long_name" in var.attrs, name
            assert var.dtype == object or "units" in var.attrs or "flag_values" in var.attrs, name


@pytest.fixture(scope="module")
def checked(real_demo, job_files) -> list[Path]:
    """The files the CF checkers read: the real demo and every shipped job's synthetic data set."""
    return [real_demo, *(path for _, path in job_files)]


# cfchecker reads units through cfunits, which loads the UDUNITS-2 C library with
# ctypes.util.find_library("udunits2") and its XML database from UDUNITS2_XML_PATH (else the
# path compiled into the library). No system package (Debian libudunits2-0) or root is needed:
# the cf-units wheel of the `test` extra bundles both (cf_units.libs/libudunits2-*.so* on Linux,
# cf_units/.dylibs on macOS; cf_units/etc/share/udunits2.xml). CFCHECKS runs cfchecks' own
# main() with find_library pointed at that copy; where cf-units was built against a system
# UDUNITS (no bundled copy), the system's is found as before.
CFCHECKS = """
import ctypes.util, os, sys
from pathlib import Path
import cf_units
root = Path(cf_units.__file__).resolve().parent
bundled = sorted(root.parent.glob("cf_units.libs/libudunits2*")) + sorted(root.glob(".dylibs/libudunits2*"))
if bundled:
    system = ctypes.util.find_library
    ctypes.util.find_library = lambda name: str(bundled[0]) if name == "udunits2" else system(name)
if (root / "etc" / "share" / "udunits2.xml").is_file():
    os.environ.setdefault("UDUNITS2_XML_PATH", str(root / "etc" / "share" / "udunits2.xml"))
from cfchecker.cfchecks import main
sys.argv[0] = "cfchecks"
sys.exit(main())
"""


@pytest.fixture(scope="module")
def cfchecks(tmp_path_factory) -> list[str]:
    """The cfchecks command, offline: the CF standard-name table that compliance-checker ships
    (4.5 MB, CF's own table; the data sets use no standard names, but a wrong one would be
    caught), empty area-type and region tables (the data sets use neither)."""
    required("cfchecker", "cfchecker")
    required("cf_units", "cf-units (its wheel bundles the UDUNITS library cfchecker needs)")
    table = (
        importlib.resources.files(required("compliance_checker", "compliance-checker"))
        / "data"
        / "cf-standard-name-table.xml"
    )
    folder = tmp_path_factory.mktemp("cftables")
    return [sys.executable, "-c", CFCHECKS, "-v", "1.8", "-s", str(table), *_stub_tables(folder)]


@pytest.fixture(scope="module")
def compliance_checker() -> list[str]:
    """The compliance-checker command of this interpreter's environment (``.venv/bin``: PATH
    need not hold it), else the one on PATH."""
    required("compliance_checker", "compliance-checker")
    script = Path(sysconfig.get_path("scripts")) / "compliance-checker"
    found = str(script) if script.is_file() else shutil.which("compliance-checker")
    if found is None:
        pytest.fail("compliance_checker is importable but its compliance-checker command is not installed")
    return [found]


@pytest.fixture(scope="module")
def broken(real_demo, tmp_path_factory) -> Path:
    """The real demo's K_xx and K_yy (their coordinates and ancillary variables with them) with an
    invalid unit and an invalid standard name: each checker must report both, and nothing else (it
    reads UDUNITS and the standard-name table, rather than passing blind). Two stiffnesses, not the
    demo's every variable: the claim is about the checkers, which ``checked`` gives the whole files
    (compliance-checker's time grows with the square of the variable count: ~1 s here, ~10 s for
    the whole demo)."""
    path = tmp_path_factory.mktemp("broken") / "broken.nc"
    with open_dataset(real_demo) as ds:
        kept = ["K_xx", "K_yy"]
        kept += sorted({name for k in kept for name in ds[k].attrs["ancillary_variables"].split()})
        write_netcdf(ds[kept].load(), path)
    with netCDF4.Dataset(path, "a") as raw:
        raw["K_xx"].units = "bananas"
        raw["K_yy"].standard_name = "no_such_standard_name"
    return path


def test_cfchecks_reports_no_error(cfchecks, checked, broken):
    done = subprocess.run([*cfchecks, *map(str, checked)], capture_output=True, text=True, timeout=300)
    assert done.stdout.count("ERRORS detected: 0") == len(checked), done.stdout + done.stderr
    done = subprocess.run([*cfchecks, str(broken)], capture_output=True, text=True, timeout=300)
    assert "ERRORS detected: 2" in done.stdout, done.stdout + done.stderr
    assert "Invalid units: bananas" in done.stdout and "Invalid standard_name: no_such_standard_name" in done.stdout


def test_compliance_checker_cf_suite_has_no_failure(compliance_checker, checked, broken):
    # ~10 s a file: the real demo and one job of each kind (slip in SI, crystal slip, sphere indentation)
    files = [
        checked[0],
        *(p for p in checked[1:] if p.stem in ("sphere_pairs", "crystal_friction_map", "tembleque2011_sphere")),
    ]
    done = subprocess.run(
        [*compliance_checker, "--test=cf:1.8", "--criteria=strict", *map(str, files)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0 and done.stdout.count("All tests passed!") == len(files), done.stdout + done.stderr
    done = subprocess.run(
        [*compliance_checker, "--test=cf:1.8", "--criteria=strict", str(broken)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode != 0 and '"bananas" are not recognized by UDUNITS' in done.stdout, done.stdout + done.stderr
    assert "broken.nc has 2 potential issues" in done.stdout
    assert "standard_name no_such_standard_name is not defined" in done.stdout


def test_error_bars_are_linked_from_every_stiffness_and_propagated_to_K_nn(fake_solve, tmp_path):
    """docs/reference/dataset.md §"Error estimates": ``<name>_error`` beside every stored
    stiffness (NaN where a task has no estimate), linked by CF ``ancillary_variables``,
    ``error_status`` per point, K_nn's and normalized_nn's bounds derived from the tensor's."""
    errors = {"K_xx": 1e-4, "K_xy": 2e-6, "K_yx": 3e-6, "K_yy": 2e-4, "K_zz": 5e-5, "K_a_over_K_b": 1.5e-4}

    def solve(params):  # the ellipse extrapolated (met at nu = 0, not at 0.5), the circle on one grid
        record = {**fake_solve(params), "K_xy": 0.01, "K_yx": 0.02}
        if params["shape"] == "ellipse":
            worst = max(errors.values())
            met = float(params["nu"]) == 0.0
            record.update(estimated_error=worst, accuracy_met=met, estimated_errors=errors)
        return error_columns(record)

    _, ds = build(solve)
    for name in ("K_xx", "K_xy", "K_yy", "K_zz", "K_a_over_K_b", "normalized_xx", "K_nn", "normalized_nn"):
        assert ds[name].attrs["ancillary_variables"] == f"{name}_error error_status", name
        assert ds[f"{name}_error"].attrs["units"] == "1", name
        assert np.isnan(ds[f"{name}_error"].sel(shape="circle")).all(), name  # one grid: no estimate
    assert "largest diagonal" in ds["K_xy_error"].attrs["long_name"]
    assert np.isnan(ds["normalized_xx_error"].sel(shape="ellipse")).all()  # the record had none
    status = ds["error_status"]
    assert status.dtype == np.int32 and status.attrs["flag_meanings"] == "met not_met no_estimate"
    assert (status.sel(shape="circle") == 2).all()
    assert (status.sel(shape="ellipse", nu=0.0) == 0).all() and (status.sel(shape="ellipse", nu=0.5) == 1).all()

    point = ds.sel(shape="ellipse", aspect=0.1, nu=0.5)
    scale = max(abs(float(point.K_xx)), abs(float(point.K_yy)), abs(float(point.K_zz)))
    bounds = np.array(
        [
            [errors["K_xx"] * float(point.K_xx), errors["K_xy"] * scale],
            [errors["K_yx"] * scale, errors["K_yy"] * float(point.K_yy)],
        ]
    )
    t = np.radians(ds.angle.values)
    c, s = np.cos(t), np.sin(t)
    by_hand = c * c * bounds[0, 0] + np.abs(c * s) * (bounds[0, 1] + bounds[1, 0]) + s * s * bounds[1, 1]
    np.testing.assert_allclose(point.K_nn_error.values, by_hand / np.abs(point.K_nn.values), rtol=1e-14)
    np.testing.assert_allclose(point.normalized_nn_error.values, point.K_nn_error.values + errors["K_zz"], rtol=1e-14)

    path = write_netcdf(ds, tmp_path / "errors.nc")
    with open_dataset(path) as back:
        assert back["error_status"].dtype == np.int32
        assert back["K_nn"].attrs["ancillary_variables"] == "K_nn_error error_status"
        np.testing.assert_array_equal(back["K_nn_error"].values, ds["K_nn_error"].values)


def test_a_contact_size_stores_stiffnesses_in_newtons_per_metre(tmp_path):
    """A spec with the contact size ``a`` (m) stores every stiffness in N/m (CF "N m-1", no scale
    symbol left): the same sweep without it, in GPa·a for a library crystal, times a × 1e9."""
    spec = {"scene": {"shape": "ellipse", "material": "Cu"}, "numerics": {"n": 8}, "axes": {"aspect": [0.5, 1.0]}}
    sized = {**spec, "scene": {**spec["scene"], "a": 2e-3}}
    plain = hpcontact.run_sweep(spec, output=tmp_path / "plain.nc", stream=io.StringIO())
    newtons = hpcontact.run_sweep(sized, output=tmp_path / "sized.nc", stream=io.StringIO())
    with hpcontact.open_dataset(plain) as ds, hpcontact.open_dataset(newtons) as dn:
        for name in ("K_xx", "K_yy", "K_max"):
            assert dn[name].attrs["units"] == "N m-1" and "scale" not in dn[name].attrs
            np.testing.assert_array_equal(dn[name].values, ds[name].values * (2e-3 * 1e9))
        assert ds.K_xx.attrs["units"] != "N m-1" and dn.attrs["stiffness_units"].startswith("N/m")
