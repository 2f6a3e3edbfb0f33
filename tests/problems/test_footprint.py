"""The cost model's grid and iteration factor (``hpcontact.problems.footprint``)."""

from __future__ import annotations

import math

import pytest

from hpcontact.geometry import grid_for
from hpcontact.problems.footprint import ITERATIONS_PER_DOUBLING, contact_grid, iteration_factor
from hpcontact.scene import Scene

SCENES = [
    {"shape": "rectangle", "aspect": 0.2, "shape_angle": -90.0, "n": 128},  # turned: 128 x 640, not 128 x 26
    {"shape": "rectangle", "aspect": 0.2, "shape_angle": -30.0, "n": 64},
    {"shape": "ellipse", "aspect": 1e-8, "n": 128},
    {"shape": "polygon", "sides": 3, "n": 64},
    {"shape": "star", "sides": 2, "amplitude": 0.3, "shape_angle": 30.0},
    {"shape": "ellipse", "aspect": 1e-4, "n": 512, "n_across": 32},
    {"shape": "circle"},
]


@pytest.mark.parametrize("params", SCENES)
def test_the_grid_is_the_engines(params):
    # the engine's own path: the validated scene's shape through geometry.grid_for (exact integers)
    scene = Scene.from_params({**params, "quantities": ["tangential"]})
    grid = grid_for(scene.shape, scene.n, scene.n_across)
    assert contact_grid(params) == (grid.nx, grid.ny)


def test_an_indentation_scene_is_solved_on_n_by_n_cells():
    assert contact_grid({"quantities": ["indentation"], "n": 96, "shape": "ellipse", "aspect": 0.1}) == (96, 96)


def test_iterations_grow_with_the_aspect_in_cells_not_with_the_shape_alone():
    # a square contact of 256 cells a side is the reference: 512 x 512 = 2^18 padded cells
    assert iteration_factor({"shape": "circle", "n": 256}) == 1.0
    # a square on 512 x 32 cells and a 1e-8 strip on the same cells: the same index-space aspect
    # 16 and the same 2^16 padded cells
    square = iteration_factor({"shape": "rectangle", "aspect": 1.0, "n": 512, "n_across": 32})
    strip = iteration_factor({"shape": "rectangle", "aspect": 1e-8, "n": 512, "n_across": 32})
    assert square == strip == pytest.approx((1.0 + ITERATIONS_PER_DOUBLING * math.log2(16.0)) * 16 / 18, rel=1e-15)
    # a turned thin rectangle (128 x 640 cells) iterates more than the same one along x (128 x 26)
    assert iteration_factor(SCENES[0]) > iteration_factor({**SCENES[0], "shape_angle": 0.0}) > 1.0


def test_iterations_grow_as_log2_of_the_padded_cells():
    # module docstring: 56 iterations at n = 256, 68 at n = 1024 (ellipse 0.5), i.e. log2 S 17 -> 21
    ratio = iteration_factor({"shape": "circle", "n": 1024}) / iteration_factor({"shape": "circle", "n": 256})
    assert ratio == pytest.approx(22 / 18, rel=1e-15)


def test_fft_applications_count_a_ranks_share_per_layout():
    from hpcontact.numerics.convolution import padded_shape
    from hpcontact.problems.footprint import ITERATIONS_PER_DIGIT, fft_applications

    circle = {"shape": "circle", "n": 64, "nu": 0.3, "quantities": ["tangential", "normal"], "tol": 1e-8}
    shape = padded_shape(64, 64)
    per_solve = ITERATIONS_PER_DIGIT * 8 * iteration_factor(circle)
    # tangential: x and y solves on the two-component operator; normal: one solve on z
    assert fft_applications([circle] * 2) == pytest.approx(
        {(2, shape): 4 * per_solve, (1, shape): 2 * per_solve}, rel=1e-15
    )
    # nu = 0: the tangential solves are one-component and the normal one is theirs (plan.plan_for)
    assert fft_applications([{**circle, "nu": 0.0}]) == pytest.approx({(1, shape): 2 * per_solve}, rel=1e-15)
    # an indentation scene: one Polonsky-Keer solve on z (its radius is needed to make the plan)
    sphere = {"quantities": ["indentation"], "n": 64, "nu": 0.3, "radius": 1.0, "depth": 1e-4, "tol": 1e-8}
    assert fft_applications([sphere]) == pytest.approx({(1, shape): per_solve}, rel=1e-15)
    # not counted: crystals, slip scenes, scenes whose grids are chosen per task (no n)
    assert fft_applications([{**circle, "anisotropy": 2.0}, {**circle, "n": None}]) == {}
