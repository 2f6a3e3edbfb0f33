"""Coverage-weighted boundary cells (``hpcontact.discretizations.boundary_cells``): exact covered fractions and
the solve on them. Closed forms: areas of circles, ellipses, rectangles, polygons and stars;
Mindlin's circle (8Ga/(2 − nu)). Every tolerance states where it comes from.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hpcontact import analytic
from hpcontact.discretizations import boundary_cells as bc
from hpcontact.errors import InputError
from hpcontact.geometry import Shape, grid_for
from hpcontact.problems.contact import solve
from hpcontact.scene import Scene

pytestmark = pytest.mark.filterwarnings("error")


# ------------------------------------------------------------------------------------------
# coverage
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "shape, aspect, n, n_across, area",
    [
        ("circle", 1.0, 64, None, math.pi),
        ("circle", 1.0, 1024, None, math.pi),
        ("ellipse", 0.3, 100, 30, math.pi * 0.3),
        ("ellipse", 1e-8, 64, 16, math.pi * 1e-8),
        ("ellipse", 1e-12, 256, 32, math.pi * 1e-12),
        ("rectangle", 1e-8, 32, 4, 4e-8),
    ],
)
def test_closed_form_coverage_is_exact(shape: str, aspect: float, n: int, n_across: int | None, area: float) -> None:
    """Σ f dA equals the exact area; bound 1e-12 relative (measured ≤ 1.1e-16: the column
    integrals telescope; each cell's f is good to ~n²·eps, 6e-11 at n = 1024)."""
    s = Shape(shape, aspect)
    grid = grid_for(s, n, n_across)
    f = bc.coverage(s, grid)
    assert f.min() >= 0.0 and f.max() <= 1.0
    assert abs(f.sum() * grid.cell_area / area - 1.0) < 1e-12
    x, y = grid.centres()
    inside = np.ones(f.shape, dtype=bool)
    for a in (-0.5, 0.5):
        for b in (-0.5, 0.5):
            inside &= s.contains(x + a * grid.dx, y + b * grid.dy)
    assert np.all(f[inside] >= 1.0 - 1e-9)  # a convex shape holding all four corners holds the cell


@pytest.mark.parametrize(
    "params, area",
    [
        ({"name": "polygon", "sides": 5}, 2.5 * math.sin(2 * math.pi / 5)),
        ({"name": "star", "sides": 5, "amplitude": 0.3}, math.pi * (1 + 0.3**2 / 2) / 1.3**2),
        ({"name": "ellipse", "aspect": 0.5, "angle_deg": 30.0}, math.pi * 0.5),
    ],
)
def test_sampled_coverage_area(params: dict, area: float) -> None:
    """Shapes without a closed-form coverage: 32 × 32 samples per boundary cell. The area is
    right to 1e-4 at n = 128 (midpoint sampling errs ≲ 1/32 of a cell per boundary cell, with
    random signs: measured 3.1e-7 … 3.2e-5)."""
    s = Shape(**params)
    grid = grid_for(s, 128)
    f = bc.coverage(s, grid)
    assert f.min() >= 0.0 and f.max() <= 1.0
    assert abs(f.sum() * grid.cell_area / area - 1.0) < 1e-4


def test_coverage_refuses_unrefinable_shapes() -> None:
    with pytest.raises(InputError):
        bc.coverage(Shape("rough"), grid_for(Shape("rough"), 16))


# ------------------------------------------------------------------------------------------
# coverage-weighted solves
# ------------------------------------------------------------------------------------------
def test_covered_solve_equals_engine_where_the_mesh_is_exact() -> None:
    """A rectangle's edges are cell faces: every f = 1, D = 0, so the coverage-weighted solve
    is the engine's solve (bound 1e-10: CG tol 1e-12 on both; measured 0, bit for bit)."""
    params = {"shape": "rectangle", "aspect": 0.5, "nu": 0.3, "n": 64, "quantities": "tangential,normal", "tol": 1e-12}
    a, b = bc.covered_solve(Scene.from_params(params)), solve(Scene.from_params(params))
    for key in ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz"):
        assert abs(a[key] - b[key]) <= 1e-10 * b["K_xx"], key
    assert a["contact_area"] == pytest.approx(2.0, rel=1e-15)


def test_coverage_removes_the_staircase_fluctuation() -> None:
    """Circle, nu = 0.3: n·(K_xx error) with centre-in-cell masks jumps about (Gauss circle
    problem: −0.110 … −0.273 for n = 64, 80, 96, 128, 160, measured); with coverage weights it is
    a smooth function of n (−0.2084 … −0.2034, monotone, measured). Asserted: spread > 20 %
    versus < 3 % of the mean (measured 84 % and 2.5 %)."""
    exact = analytic.circle_tangential_stiffness(1.0, 1.0, 0.3)
    spreads = {}
    for name, function in (
        ("centre", lambda p: solve(Scene.from_params(p))),
        ("coverage", lambda p: bc.covered_solve(Scene.from_params(p), strategy="coverage")),
    ):
        scaled = [
            n * (function({"shape": "circle", "nu": 0.3, "n": n})["K_xx"] / exact - 1.0) for n in (64, 80, 96, 128, 160)
        ]
        spreads[name] = (max(scaled) - min(scaled)) / abs(np.mean(scaled))
    assert spreads["centre"] > 0.2
    assert spreads["coverage"] < 0.03


def test_covered_solve_refuses_other_quantities() -> None:
    with pytest.raises(InputError):
        bc.covered_solve(Scene.from_params({"shape": "circle", "n": 16, "quantities": "compliance"}))


def test_strip_cells_build_only_what_the_scene_asks() -> None:
    """Strip cells form the ⟨s²/r³⟩ integrals only for tangential solves at nu ≠ 0, and run
    one solve per load direction asked (the record's plan says which): normal alone is one
    kernel and one solve; at nu = 0 the tangential blocks need no second kernel (G_x = G_y = G_z)."""
    base = {"shape": "rectangle", "aspect": 1e-8, "n": 32}
    normal = bc.covered_solve(Scene.from_params({**base, "nu": 0.3, "quantities": "normal"}), "strip")
    assert normal["plan"]["kernels"] == ["<1/r>"] and normal["plan"]["solves"] == ["normal_z[z]"]
    assert "K_xx" not in normal and normal["boundary"] == "strip"
    both = bc.covered_solve(Scene.from_params({**base, "nu": 0.3, "quantities": "tangential,normal"}), "auto")
    assert both["boundary"] == "strip" and both["plan"]["kernels"] == ["<1/r>", "<s^2/r^3>"]
    assert both["plan"]["solves"] == ["tangential_x[x]", "tangential_y[y]", "normal_z[z]"]
    assert both["K_xy"] == both["K_yx"] == 0.0 and both["K_zz"] == normal["K_zz"]
    zero = bc.covered_solve(Scene.from_params({**base, "nu": 0.0, "quantities": "tangential,normal"}), "strip")
    assert zero["plan"]["kernels"] == ["<1/r>"] and zero["K_xx"] == zero["K_yy"] == zero["K_zz"]
    assert both["contact_area"] == pytest.approx(4e-8, rel=1e-15) and (both["nx"], both["ny"]) == (32, 1)
