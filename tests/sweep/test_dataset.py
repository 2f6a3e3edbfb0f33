"""Entries → xarray data set → netCDF4: schema of DESIGN §4.2, derived K_nn, atomic write."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from hpcontact.quantities import rotated_tensor
from hpcontact.sweep.dataset import NOT_COMPUTED, build_dataset, write_netcdf
from hpcontact.sweep.journal import ERROR, OK, Entry
from hpcontact.sweep.spec import parse_spec
from hpcontact.sweep.tasks import enumerate_tasks

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


def build(fake_solve, text=SPEC, fail=None, missing=None):
    spec = parse_spec(text, validate=lambda params: None)
    tasks, where = enumerate_tasks(spec)
    entries = {}
    for t in tasks:
        if t.params == missing:
            continue
        failed = t.params == fail
        entries[t.key] = Entry(
            key=t.key, params=t.params, status=ERROR if failed else OK, message="RuntimeError: x" if failed else "",
            record={} if failed else fake_solve(t.params), wall_time_s=0.5, finished=0.0, rank=0,
        )
    return spec, build_dataset(spec, where, entries, {"mpi_size": 2, "hpcontact_version": "0.1.0"})


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
    assert ds["K_xx"].attrs["units"] == "G a"
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
    with xr.open_dataset(path) as back:
        xr.testing.assert_identical(back.load(), ds)
    before = path.read_bytes()

    def broken(self, *args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", broken)
    with pytest.raises(OSError):
        write_netcdf(ds, path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in path.parent.iterdir()) == ["out.nc"]
