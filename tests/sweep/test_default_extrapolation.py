"""A sweep whose spec gives no n solves each task as ``accuracy.default_solve`` does: an
elliptical contact on its one exact cell and a slender rectangle on strips, as ``hpcontact
solve`` without ``--n``; coverage-weighted cells on grids 16 … 256 extrapolated (issue 12), the
record's ``estimated_error`` in the data set and the cost of every grid in the cost model."""

from __future__ import annotations

import io

import pytest
import xarray as xr

from hpcontact import analytic
from hpcontact.accuracy import (
    DEFAULT_ACCURACY,
    DEFAULT_GRIDS,
    DEFAULT_N0,
    default_grids,
    default_scene_solve,
    default_solve,
)
from hpcontact.scene import Scene
from hpcontact.sweep.cost.grids import padded_cells, solved_grids
from hpcontact.sweep.cost.task_cost import EXTRAPOLATION_WORK, estimated_cost
from hpcontact.sweep.driver import main, run_sweep
from hpcontact.sweep.run.schedule import SerialTeam

NU = 0.3
ELLIPSES = f"""
[scene]
shape = "ellipse"
quantities = ["tangential", "normal"]
nu = {NU}
[axes]
aspect = [0.5, 0.05]
"""
# A star without lobes is the circle, on coverage-weighted cells: Mindlin's closed form holds
STARS = """
[scene]
shape = "star"
amplitude = 0.0
quantities = ["tangential", "normal"]
[axes]
nu = [0.0, 0.3]
"""


def test_a_sweep_without_n_solves_an_elliptical_contact_on_its_exact_cell(write_spec, capsys):
    spec = write_spec(ELLIPSES)
    path = run_sweep(spec, team=SerialTeam(), stream=io.StringIO())  # the real task function
    scene = {"shape": "ellipse", "nu": NU, "quantities": ["tangential", "normal"]}
    with xr.open_dataset(path) as ds:
        for aspect in (0.5, 0.05):
            point = ds.sel(aspect=aspect)
            estimate = float(point["estimated_error"])
            K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, NU)
            # the estimate bounds the true error (the claim under test), so no other tolerance
            assert abs(float(point["K_xx"]) / K_a - 1.0) <= estimate <= 1e-12
            assert abs(float(point["K_yy"]) / K_b - 1.0) <= estimate
            assert str(point["boundary"].values) == "galin" and str(point["accuracy_met"].values) == "true"
            # one scene's default (hpcontact solve without --n), bitwise
            alone = default_scene_solve(Scene.from_params({**scene, "aspect": aspect}))
            assert float(point["K_xx"]) == alone["K_xx"] and float(point["K_zz"]) == alone["K_zz"]
        assert (ds["status"] == 0).all()
    # the dry run and the scheduler plan it as a request of the default accuracy: the exact cell
    asked = {**scene, "aspect": 0.5, "accuracy": DEFAULT_ACCURACY}
    plain = {**scene, "aspect": 0.5}
    assert solved_grids(plain) == solved_grids(asked) and len(solved_grids(plain)) == 1
    assert estimated_cost(plain) == estimated_cost(asked)
    assert main([str(spec), "--dry-run"]) == 0
    assert "contact accuracy: one exact cell (galin): 2 tasks" in capsys.readouterr().out
    # with n, one grid as before
    assert solved_grids({**plain, "n": 64}) == [{**plain, "n": 64}]


def test_a_sweep_without_n_solves_a_slender_rectangle_on_its_strips(write_spec):
    spec = write_spec('[scene]\nshape = "rectangle"\naspect = 1e-6\nquantities = ["tangential"]\n[axes]\nnu = [0.3]\n')
    path = run_sweep(spec, team=SerialTeam(), stream=io.StringIO())
    scene = {"shape": "rectangle", "aspect": 1e-6, "nu": 0.3, "quantities": ["tangential"]}
    alone = default_scene_solve(Scene.from_params(scene))  # one scene's default, bitwise
    with xr.open_dataset(path) as ds:
        point = ds.sel(nu=0.3)
        assert str(point["boundary"].values) == "strip" and float(point["K_xx"]) == alone["K_xx"]
        assert float(point["estimated_error"]) == alone["estimated_error"] <= DEFAULT_ACCURACY
    assert solved_grids(scene) == solved_grids({**scene, "accuracy": DEFAULT_ACCURACY})
    assert estimated_cost(scene) == estimated_cost({**scene, "accuracy": DEFAULT_ACCURACY})


def test_a_sweep_without_n_extrapolates_another_outline_with_its_estimate(write_spec, capsys):
    spec = write_spec(STARS)
    path = run_sweep(spec, team=SerialTeam(), stream=io.StringIO())  # the real task function
    with xr.open_dataset(path) as ds:
        for nu in (0.0, 0.3):
            point = ds.sel(nu=nu)
            estimate = float(point["estimated_error"])
            K = analytic.circle_tangential_stiffness(1.0, 1.0, nu)
            assert abs(float(point["K_xx"]) / K - 1.0) <= estimate
            assert abs(float(point["K_yy"]) / K - 1.0) <= estimate
            # nx, ny: the finest grid of the sequence 16 … 256 along the long side
            assert int(point["nx"]) == DEFAULT_N0 * 2 ** (DEFAULT_GRIDS - 1)
            assert str(point["grids"].values) == "[16, 32, 64, 128, 256]"
            assert str(point["boundary"].values) == "coverage"
            # the default's estimate stops at 256 above its 1e-4 (measured 1.2e-4, 1.3e-4), never an error
            assert 0.0 < estimate < 10 * DEFAULT_ACCURACY
        assert (ds["status"] == 0).all()
    # the dry run and the scheduler see every grid: cost summed over the sequence, memory of the finest
    scene = {"shape": "star", "amplitude": 0.0, "nu": NU, "quantities": ["tangential", "normal"]}
    levels = solved_grids(scene)
    assert (
        [(p["n"], p["n_across"]) for p in levels]
        == default_grids(Scene.from_params(scene))
        == [(16, 16), (32, 32), (64, 64), (128, 128), (256, 256)]
    )
    assert estimated_cost(scene) == pytest.approx(EXTRAPOLATION_WORK * sum(estimated_cost(p) for p in levels))
    assert padded_cells(scene) == 4 * 256 * 256
    assert main([str(spec), "--dry-run"]) == 0
    assert "contact 262144 padded cells: 2 tasks" in capsys.readouterr().out
    # with n, or a scene the default does not extrapolate, one grid as before
    assert solved_grids({**scene, "n": 64}) == [{**scene, "n": 64}]
    rough = {"shape": "rough", "nu": NU}
    assert solved_grids(rough) == [rough]


def test_a_sweep_without_n_extrapolates_a_crystal_outline_with_its_estimate(write_spec):
    """A crystal's polygon without n: the grids 16 … 256 with their estimate (one grid of n = 128
    without one until 2026-11-30), the record ``accuracy.default_solve``'s bitwise, and the cost
    model planning every grid."""
    spec = write_spec('[scene]\nshape = "polygon"\nsides = 6\nnu = 0.3\n[axes]\nanisotropy = [2.0]\n')
    path = run_sweep(spec, team=SerialTeam(), stream=io.StringIO())
    scene = {"shape": "polygon", "sides": 6, "nu": 0.3, "anisotropy": 2.0}
    alone = default_solve(Scene.from_params(scene))
    with xr.open_dataset(path) as ds:
        point = ds.sel(anisotropy=2.0)
        assert str(point["boundary"].values) == "coverage" and str(point["grids"].values).startswith("[16, 32")
        assert float(point["K_xx"]) == alone["K_xx"] and float(point["estimated_error"]) == alone["estimated_error"]
        assert 0.0 < float(point["estimated_error"]) < 10 * DEFAULT_ACCURACY
    levels = solved_grids(scene)
    assert [(p["n"], p["n_across"]) for p in levels] == default_grids(Scene.from_params(scene)) and len(levels) == 5
