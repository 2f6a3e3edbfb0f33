"""A sweep whose spec gives no n gets ``hpcontact solve``'s extrapolated default (issue 12):
grids 16 … 256, the record's ``estimated_error`` in the data set, the cost of every grid."""

from __future__ import annotations

import io

import pytest
import xarray as xr

from hpcontact import analytic
from hpcontact.accuracy import DEFAULT_ACCURACY, DEFAULT_GRIDS, DEFAULT_N0, default_grids
from hpcontact.scene import Scene
from hpcontact.sweep.cost.grids import padded_cells, solved_grids
from hpcontact.sweep.cost.task_cost import EXTRAPOLATION_WORK, estimated_cost
from hpcontact.sweep.driver import main, run_sweep
from hpcontact.sweep.run.schedule import SerialTeam

NU = 0.3
SPEC = f"""
[scene]
shape = "ellipse"
quantities = ["tangential", "normal"]
nu = {NU}
[axes]
aspect = [0.5, 0.05]
"""


def test_a_sweep_without_n_is_extrapolated_with_its_estimate(write_spec, capsys):
    spec = write_spec(SPEC)
    path = run_sweep(spec, team=SerialTeam(), stream=io.StringIO())  # the real task function
    with xr.open_dataset(path) as ds:
        for aspect in (0.5, 0.05):
            point = ds.sel(aspect=aspect)
            estimate = float(point["estimated_error"])
            K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, NU)
            # the estimate bounds the true error (the claim under test), so no other tolerance
            assert abs(float(point["K_xx"]) / K_a - 1.0) <= estimate
            assert abs(float(point["K_yy"]) / K_b - 1.0) <= estimate
            assert (
                abs(float(point["K_a_over_K_b"]) / analytic.mindlin_ellipse_stiffness_ratio(aspect, NU) - 1.0)
                <= estimate
            )
            # nx, ny: the finest grid of the sequence 16 … 256 along the long side
            assert int(point["nx"]) == DEFAULT_N0 * 2 ** (DEFAULT_GRIDS - 1)
            assert str(point["grids"].values) == "[16, 32, 64, 128, 256]"
        # b/a = 0.5 reaches the default's 1e-4 (measured 7.4e-5 at nu = 0.3); 0.05 stops at 256
        # with its estimate above it (measured 2.4e-4), never an error
        assert float(ds["estimated_error"].sel(aspect=0.5)) <= DEFAULT_ACCURACY
        assert (ds["status"] == 0).all()
    # the dry run and the scheduler see every grid: cost summed over the sequence, memory of the finest
    scene = {"shape": "ellipse", "aspect": 0.5, "nu": NU, "quantities": ["tangential", "normal"]}
    levels = solved_grids(scene)
    assert (
        [(p["n"], p["n_across"]) for p in levels]
        == default_grids(Scene.from_params(scene))
        == [(16, 8), (32, 16), (64, 32), (128, 64), (256, 128)]
    )
    assert estimated_cost(scene) == pytest.approx(EXTRAPOLATION_WORK * sum(estimated_cost(p) for p in levels))
    assert padded_cells(scene) == 4 * 256 * 128
    assert main([str(spec), "--dry-run"]) == 0
    assert "contact 131072 padded cells: 1 tasks" in capsys.readouterr().out
    # with n, or a scene the default does not extrapolate, one grid as before
    assert solved_grids({**scene, "n": 64}) == [{**scene, "n": 64}]
    rough = {"shape": "rough", "nu": NU}
    assert solved_grids(rough) == [rough]
