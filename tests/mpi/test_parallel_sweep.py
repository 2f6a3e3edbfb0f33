"""A sweep on every rank of the team (2 under ``mpiexec -n 2``) with the real solver on tiny
grids: equal to the 1-rank sweep to 1e-12, failures recorded, data set schema of docs/design.md §4.2."""

from __future__ import annotations

import io
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hpcontact import __version__, open_dataset
from hpcontact.errors import ConvergenceError
from hpcontact.problems.contact import solve
from hpcontact.scene import Scene
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.journal import NOT_CONVERGED, OK
from hpcontact.sweep.schedule import SerialTeam, Team

pytestmark = pytest.mark.mpi

SPEC = """
[sweep]
title = "2-rank test"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 20
tol = 1e-12
[axes]
shape = ["circle", "ellipse", "rectangle", { label = "hexagon", shape = "polygon", sides = 6 }]
aspect = [1.0, 0.1, 1e-4]
nu = [0.0, 0.3, 0.5]
angle = { linspace = [0, 180, 13] }
"""
FAILING = {"shape": "rectangle", "aspect": 0.1, "nu": 0.3}


def task(params: Mapping[str, Any]) -> dict[str, Any]:
    """The solver, except for one scene that fails to converge."""
    if all(params.get(k) == v for k, v in FAILING.items()):
        raise ConvergenceError("test failure", 7, 0.5)
    return solve(Scene.from_params(params))


@pytest.fixture(scope="module")
def runs(team: Team, shared_dir: Path) -> tuple[Path, Path]:
    """The sweep on the whole team and, on rank 0, on one rank."""
    spec = shared_dir / "spec.toml"
    if team.rank == 0:
        spec.write_text(SPEC, encoding="utf-8")
    team.barrier()
    parallel = run_sweep(spec, output=shared_dir / "parallel.nc", task_function=task, team=team, stream=io.StringIO())
    serial = shared_dir / "serial.nc"
    if team.rank == 0:
        run_sweep(spec, output=serial, task_function=task, team=SerialTeam(), stream=io.StringIO())
    team.barrier()
    return parallel, serial


def test_parallel_sweep_equals_one_rank(runs, team, assert_same_results):
    parallel, serial = runs
    if team.rank != 0:
        return
    with open_dataset(parallel) as a, open_dataset(serial) as b:
        assert a.attrs["mpi_size"] == team.size and b.attrs["mpi_size"] == 1
        assert_same_results(a, b)


def test_failing_task_is_recorded_and_the_others_complete(runs, team):
    parallel, _ = runs
    if team.rank != 0:
        return
    with open_dataset(parallel) as ds:
        bad = ds.sel(**FAILING)
        assert int(bad.status) == NOT_CONVERGED and "test failure" in str(bad.message.values)
        assert np.isnan(bad.K_xx) and np.isnan(bad.K_nn).all()
        ok = ds.status == OK
        assert int(ok.sum()) == ds.status.size - 1
        assert bool(np.isfinite(ds.K_xx.where(ok)).sum() == ok.sum())


def test_data_set_schema(runs, team):
    parallel, _ = runs
    if team.rank != 0:
        return
    with open_dataset(parallel) as ds:
        assert dict(ds.sizes) == {"shape": 4, "aspect": 3, "nu": 3, "angle": 13}
        for axis in ("aspect", "nu", "angle"):
            assert ds[axis].dtype == np.float64 and {"units", "long_name"} <= set(ds[axis].attrs)
        assert ds["shape"].values.tolist() == ["circle", "ellipse", "rectangle", "hexagon"]
        for name in (
            "K_xx",
            "K_xy",
            "K_yx",
            "K_yy",
            "K_zz",
            "K_max",
            "K_min",
            "principal_angle_deg",
            "K_a_over_K_b",
            "normalized_xx",
            "normalized_yy",
            "iterations",
            "residual",
            "nx",
            "ny",
            "dx",
            "dy",
            "wall_time_s",
        ):
            assert ds[name].dims == ("shape", "aspect", "nu"), name
            assert ds[name].dtype == np.float64 and {"units", "long_name"} <= set(ds[name].attrs), name
        assert ds["status"].dtype == np.int32 and ds["message"].dims == ("shape", "aspect", "nu")
        assert ds["plan"].dims == ("shape", "aspect", "nu") and "kernels" in str(ds["plan"].values[0, 0, 0])
        assert ds["K_nn"].dims == ("shape", "aspect", "nu", "angle")
        assert ds["normalized_nn"].attrs["units"] == "1"
        attrs = ds.attrs
        assert attrs["hpcontact_version"] == __version__ and attrs["spec"] == SPEC
        assert attrs["mpi_size"] == team.size and attrs["Conventions"] == "CF-1.8"
        assert "created" in attrs and "sweep_parallel_efficiency" in attrs
        # a circle is isotropic: K_nn is the same in every direction
        circle = ds.K_nn.sel(shape="circle", aspect=1.0, nu=0.5)
        np.testing.assert_allclose(circle, circle[0], rtol=1e-6)
