"""Entries → xarray data set → netCDF4 and back: schema of docs/design.md §4.2, derived K_nn, CF units,
exact labels, compact storage, history, atomic write; the CF checkers where they are installed."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

import hpcontact
from hpcontact.quantities import rotated_tensor
from hpcontact.scene import Scene
from hpcontact.sweep import tasks as tasks_module
from hpcontact.sweep.dataset import NOT_COMPUTED, SLIP_ATTRS, VARIABLE_ATTRS, build_dataset, open_dataset, write_netcdf
from hpcontact.sweep.journal import ERROR, OK, Entry
from hpcontact.sweep.netcdf import INT_FILL, chunk_shape
from hpcontact.sweep.spec import parse_spec
from hpcontact.sweep.tasks import enumerate_tasks

ROOT = Path(__file__).resolve().parents[2]

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
            key=t.key, params=t.params, status=ERROR if failed else OK, message="RuntimeError: x" if failed else "",
            record={} if failed else solve(t.params), wall_time_s=0.5, finished=0.0, rank=0,
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
    assert float(ds.K_yy.sel(shape="circle", aspect=0.1, nu=0.5)) == float(ds.K_yy.sel(shape="circle", aspect=1, nu=0.5))
    assert float(ds.K_yy.sel(shape="ellipse", aspect=0.1, nu=0.5)) != float(ds.K_yy.sel(shape="ellipse", aspect=1, nu=0.5))


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
        assert str(ds["plan"].isel(at).values) == ("" if entry.status != OK else
                                                   '{"kernels": ["xx", "yy"], "solves": 2}')
        assert int(ds["status"].isel(at)) == entry.status
    # K_nn from the stored tensor: n K n at every angle (Li 2017, eq. 6); rounding only
    K = ds[["K_xx", "K_xy", "K_yx", "K_yy"]].sel(shape="hexagon", aspect=1.0, nu=0.5)
    tensor = np.array([[K.K_xx, K.K_xy], [K.K_yx, K.K_yy]], dtype=np.float64)
    expected = [rotated_tensor(tensor, a)[0, 0] for a in ds.angle.values]
    np.testing.assert_allclose(ds.K_nn.sel(shape="hexagon", aspect=1.0, nu=0.5), expected, rtol=1e-14)


def test_open_dataset_is_lazy_with_dask(fake_solve, tmp_path):
    pytest.importorskip("dask", reason="dask is not installed (xarray's chunks={} needs it)")
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
        for name in ("iterations", "status", "plan"):
            assert raw[name].dtype == np.int32, name
        assert raw["iterations"].getncattr("_FillValue") == INT_FILL
        assert json.loads(raw["plan"].getncattr("plan_table")) == ['{"kernels": ["xx", "yy"], "solves": 2}']
        assert "K_nn" not in raw.variables and "normalized_nn" not in raw.variables  # derived on open
        for name in ("K_xx", "message", "plan"):
            filters = raw[name].filters()
            assert filters["zlib"] and filters["shuffle"], name
        assert raw["K_xx"].chunking() == list(raw["K_xx"].shape)  # small: one chunk
        assert raw["shape"].dtype == "S1"  # labels as char arrays (CF checkers read them)
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


@pytest.fixture(scope="module")
def job_datasets() -> list[tuple[str, xr.Dataset]]:
    """The data set of every shipped job, built from synthetic records that hold every key the
    job's scene kind can record (each 1.0): every variable the job can write. (Task costs do
    not enter a data set: not estimated here, a slip pair's costs a kernel setup each.)"""
    out = []
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(tasks_module, "estimated_cost", lambda params: 1.0)
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


def test_every_shipped_job_round_trips_through_the_file(job_datasets, tmp_path):
    for job, ds in job_datasets:
        with open_dataset(write_netcdf(ds, tmp_path / f"{job}.nc")) as back:
            xr.testing.assert_identical(back.load(), ds)


# The physical dimension of each kind of quantity (an independent statement, not the code's tables).
DIMENSIONS = {
    "K_xx": "N m-1", "K_nn": "N m-1", "dx": "m", "load": "N", "contact_area": "m2", "angle": "radian",
    "orientation": "radian", "wall_time_s": "s", "tangential_stiffness": "N m-1", "stick_area": "m2",
    "tangential_force": "N", "E": "Pa", "radius2": "m", "nu": "1", "iterations": "1", "max_pressure": "Pa",
}
# A scene's scales in SI, to check the dimension of a ``scale``: G a shear modulus, a and L lengths, F a force.
SCALES_SI = {"G": "Pa", "a": "m", "L": "m", "F": "N"}


def test_every_unit_of_every_shipped_job_parses_to_its_dimension(job_datasets):
    cf_units = pytest.importorskip("cf_units", reason="cf-units (UDUNITS) is not installed: pip install cf-units")
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
                unit = cf_units.Unit(re.sub(r"\b([GaLF])(?=-?\d*\b)", lambda m: SCALES_SI[m.group(1)], var.attrs["scale"]))
            if name in DIMENSIONS:
                assert unit.is_convertible(cf_units.Unit(DIMENSIONS[name])), (job, name, var.attrs)
                checked.add(name)
    assert checked == set(DIMENSIONS)


def test_every_unit_parses_with_pint_as_udunits_reads_it(job_datasets):
    """pint (cf_xarray's UDUNITS-syntax registry) reads every unit as the same amount of the
    same base units as UDUNITS, and pint-xarray quantifies every data set."""
    units = pytest.importorskip("cf_xarray.units", reason="cf_xarray and pint are not installed").units
    pytest.importorskip("pint_xarray", reason="pint-xarray is not installed")
    cf_units = pytest.importorskip("cf_units", reason="cf-units (UDUNITS) is not installed")
    for job, ds in job_datasets:
        ds.drop_vars([name for name in ds.variables if ds[name].dtype.kind in "OU"]).pint.quantify(unit_registry=units)
        for name, var in ds.variables.items():
            if "units" in var.attrs:
                base = units.Quantity(1.0, var.attrs["units"]).to_base_units()
                udunits = cf_units.Unit(var.attrs["units"]).convert(1.0, cf_units.Unit(f"{base.units:cf}" or "1"))
                assert udunits == pytest.approx(base.magnitude, rel=1e-12), (job, name)  # rounding of pi/180


def _stub_tables(folder: Path) -> list[str]:
    """cfchecks' three XML tables as empty stubs (the data sets use no standard names, area
    types or regions), so the checker runs offline."""
    tables = {"-s": ("standard_name_table", "s.xml"), "-a": ("standard_area_type_table", "a.xml"),
              "-r": ("standardized_region_list", "r.xml")}
    args = []
    for flag, (root, name) in tables.items():
        (folder / name).write_text(f'<?xml version="1.0"?>\n<{root}><version_number>0</version_number>'
                                   f"<date>none</date><last_modified>none</last_modified></{root}>\n")
        args += [flag, str(folder / name)]
    return args


@pytest.fixture(scope="module")
def real_demo(tmp_path_factory) -> Path:
    """The demo job's shapes at two b/a, two nu, A = 1 and 2, one ψ and n = 16, solved by the
    engine (~3 s)."""
    folder = tmp_path_factory.mktemp("demo")
    text = (ROOT / "jobs" / "demo.toml").read_text()
    for key, value in (("n", "16"), ("tol", "1e-8"), ("aspect", "[1.0, 1e-4]"), ("nu", "[0.0, 0.3]"),
                       ("anisotropy", "[1.0, 2.0]"), ("orientation", "[20.0]")):
        text, count = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
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
def checked(real_demo, job_datasets, tmp_path_factory) -> list[Path]:
    """The files the CF checkers read: the real demo and every shipped job's synthetic data set."""
    folder = tmp_path_factory.mktemp("jobs")
    run = {"history": "2026-01-01T00:00:00+00:00: hpcontact run"}  # as the driver's provenance gives it
    return [real_demo, *(write_netcdf(ds.assign_attrs(run), folder / f"{Path(job).stem}.nc") for job, ds in job_datasets)]


@pytest.fixture(scope="module")
def cfchecks() -> str:
    path = shutil.which("cfchecks")
    if path is None:
        pytest.skip("cfchecks is not installed (pip install cfchecker; needs the UDUNITS C library, "
                    "Debian: libudunits2-0)")
    return path


@pytest.fixture(scope="module")
def compliance_checker() -> str:
    path = shutil.which("compliance-checker")
    if path is None:
        pytest.skip("compliance-checker is not installed (pip install compliance-checker)")
    return path


def test_cfchecks_reports_no_error(cfchecks, checked, tmp_path):
    done = subprocess.run([cfchecks, "-v", "1.8", *_stub_tables(tmp_path), *map(str, checked)],
                          capture_output=True, text=True, timeout=300)
    assert done.stdout.count("ERRORS detected: 0") == len(checked), done.stdout + done.stderr


def test_compliance_checker_cf_suite_has_no_failure(compliance_checker, checked):
    # ~10 s a file: the real demo and one job of each kind (slip in SI, crystal slip, sphere indentation)
    files = [checked[0], *(p for p in checked[1:] if p.stem in ("sphere_pairs", "crystal_friction_map", "tembleque2011_sphere"))]
    done = subprocess.run([compliance_checker, "--test=cf:1.8", "--criteria=strict", *map(str, files)],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0 and done.stdout.count("All tests passed!") == len(files), done.stdout + done.stderr
