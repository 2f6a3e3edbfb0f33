"""Singular boundary cells (``hpcontact.discretizations.singular_cells``) and ``covered_solve(strategy=...)``.

Closed forms: the hemisphere area behind ∫∫ (1 − u² − v²)^(−½) (checked against adaptive
quadrature), Mindlin's ellipse K_a, K_b (1949), the elliptical punch K_zz (Galin/Johnson §3.7).
Every tolerance states where it comes from.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate

from hpcontact import analytic
from hpcontact.discretizations import boundary_cells as bc
from hpcontact.discretizations import singular_cells as sc
from hpcontact.errors import InputError
from hpcontact.geometry import Shape
from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.scene import Scene

pytestmark = pytest.mark.filterwarnings("error")


@pytest.mark.parametrize(
    "u1, u2, v1, v2",
    [(0.1, 0.3, 0.2, 0.5), (0.5, 0.9, 0.3, 0.7), (-0.2, 0.1, 0.9, 1.2), (0.6, 1.1, -0.1, 0.5), (-1.5, 1.5, -0.3, 0.2)],
)
def test_sphere_area_is_the_integral_of_w(u1: float, u2: float, v1: float, v2: float) -> None:
    """F's rectangle sums against scipy's adaptive quadrature of (1 − u² − v²)^(−½) over the
    rectangle ∩ disc, integrated in v analytically-free form (inner limits at the circle so the
    singularity sits on an endpoint). Bound 1e-7: quad's tolerance (epsabs 1e-10) with room."""

    def inner(u: float) -> float:
        c2 = 1.0 - u * u
        if c2 <= 0.0:
            return 0.0
        c = math.sqrt(c2)
        lo, hi = max(v1, -c), min(v2, c)
        if hi <= lo:
            return 0.0
        return math.asin(hi / c) - math.asin(lo / c)  # ∫ (c² − v²)^(−½) dv, exact

    expected = integrate.quad(inner, u1, u2, epsabs=1e-12, limit=200, points=[-1.0, 1.0] if u1 < -1 < 1 < u2 else None)[
        0
    ]
    got = float(sc.sphere_area(u2, v2) - sc.sphere_area(u1, v2) - sc.sphere_area(u2, v1) + sc.sphere_area(u1, v1))
    assert got == pytest.approx(expected, abs=1e-7)


def test_cell_weights_sum_to_the_hemisphere() -> None:
    """Σ W over the cells of an ellipse is 2π a b (the whole hemisphere, telescoping sums;
    bound 1e-12 relative: each W is a difference of O(1) closed forms, ~n²·eps) and the
    spreading weights keep every cell's force (Σ β = 1 on the contact, 1e-12)."""
    cells = sc.SingularCells(Shape("ellipse", 0.7), 32, 22, Isotropic(1.0, 0.3))
    system = cells.system("xx")
    assert cells.W.sum() == pytest.approx(2.0 * math.pi * 0.7, rel=1e-12)
    total = sum(cells.beta.values())
    assert np.max(np.abs(total - cells.mask)) < 1e-12
    assert abs(system.near - system.near.T).max() == 0.0  # the near correction is symmetric (built so)


def test_sparse_spreading_is_the_shifted_array_loop_bitwise() -> None:
    """P s and Pᵀ u as sparse products (``SingularCells.spreading``) against the loop over the
    3 × 3 stencil of shifted-array products they replaced: equal bit for bit (the terms are the
    same products summed in the same order), also the near-field's far part (``_far``) against
    the per-pair loop over ``beta``."""
    cells = sc.SingularCells(Shape("ellipse", 0.5), 32, 16, Isotropic(1.0, 0.3))
    system = cells.system("yy")
    rng = np.random.default_rng(3)
    s, u = rng.standard_normal(cells.mask.shape) * cells.mask, rng.standard_normal(cells.mask.shape)
    nx, ny = s.shape
    spread, gather = np.zeros_like(s), np.zeros_like(u)
    for (p, q), bw in cells.beta.items():
        spread[max(p, 0) : nx + min(p, 0), max(q, 0) : ny + min(q, 0)] += (bw * s)[
            max(-p, 0) : nx - max(p, 0), max(-q, 0) : ny - max(q, 0)
        ]
        gather[max(-p, 0) : nx - max(p, 0), max(-q, 0) : ny - max(q, 0)] += (
            bw[max(-p, 0) : nx - max(p, 0), max(-q, 0) : ny - max(q, 0)]
            * u[max(p, 0) : nx + min(p, 0), max(q, 0) : ny + min(q, 0)]
        )
    assert np.array_equal(system.spread(s), spread)
    assert np.array_equal(system.gather(u), gather)
    Kstar = sc.double_average_kernel(cells.material, nx, ny, cells.grid.dx, cells.grid.dy, "yy")
    pairs = rng.integers(0, len(cells.cells), (2, 50))
    ct, cs = cells.cells[pairs[0]], cells.cells[pairs[1]]
    expected = np.zeros(50)
    for (p, q), bt in cells.beta.items():
        for (pp, qq), bs in cells.beta.items():
            expected += (
                bt[ct[:, 0], ct[:, 1]] * bs[cs[:, 0], cs[:, 1]] * Kstar[nx - 1 + 1 + p - pp, ny - 1 - 2 + q - qq]
            )
    assert np.array_equal(
        system._far(Kstar, 1, -2, cells.beta_near[:, pairs[0]], cells.beta_near[:, pairs[1]]), expected
    )


def test_double_average_kernel_series_meets_the_quadrature() -> None:
    """Beyond ``EXACT_OFFSETS`` K* comes from the Taylor series in central differences; at the
    first offset past the table it must agree with the graded quadrature of the table (computed
    here with a larger reach). Bound 2e-6 relative: the series' first neglected (sixth-order)
    term, measured 7.6e-7 at offset 7 along x (1e-7 on the diagonal), falling as offset^(−7)."""
    material = Isotropic(1.0, 0.3)
    n, d = 16, sc.EXACT_OFFSETS + 1
    series = sc.double_average_kernel(material, n, n, 1.0, 1.0, "xx")[n - 1 + d, n - 1]
    exact = sc._exact_table(0.3, "xx", 1.0, d)[d, 0]
    assert series == pytest.approx(exact, rel=2e-6)
    collocation = isotropic_block(material, n, n, 1.0, 1.0, "xx")[n - 1 + d, n - 1]
    assert abs(collocation / exact - 1.0) > 1e-4  # the average differs from the centre value


@pytest.mark.parametrize("aspect", [1.0, 0.7])
def test_singular_cells_against_mindlin_and_galin(aspect: float) -> None:
    """n = 64: K_xx, K_yy, K_zz against the closed forms. Bound ``ERROR_CONSTANT``/n_across: the
    convergence study (``benchmarks/edge_order.py --bound``, the singular_cells docstring)
    measured |error| ≤ 1.03e-3/n_across, i.e. ≤ 2.3e-5 on 44 cells across (ellipse 0.7), ≤ 1.6e-5
    on 64 (circle) (measured: circle 6.6e-6, ellipse K_xx 8.4e-6); coverage weighting on the same
    grid errs by 3.3e-3 … 4.1e-3 — asserted ≥ 100× worse."""
    shape = "circle" if aspect == 1.0 else "ellipse"
    na = 64 if aspect == 1.0 else 44
    params = {
        "shape": shape,
        "aspect": aspect,
        "nu": 0.3,
        "n": 64,
        "n_across": na,
        "tol": 1e-12,
        "quantities": "tangential,normal",
    }
    singular = bc.covered_solve(Scene.from_params(params), strategy="singular")
    coverage = bc.covered_solve(Scene.from_params(params), strategy="coverage")
    K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, 0.3)
    exact = {"K_xx": K_a, "K_yy": K_b, "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, 0.3)}
    assert singular["boundary"] == "singular" and coverage["boundary"] == "coverage"
    for key, value in exact.items():
        error = abs(singular[key] / value - 1.0)
        assert error < sc.ERROR_CONSTANT / na, (key, error)
        assert abs(coverage[key] / value - 1.0) > 100.0 * error, key
    assert singular["K_xy"] == 0.0 and singular["K_yx"] == 0.0  # exact for the ellipse (Mindlin)
    assert singular["contact_area"] == pytest.approx(math.pi * aspect, rel=1e-12)


def test_strategy_choice_and_refusals() -> None:
    """``auto`` takes singular cells only where they apply; ``singular`` elsewhere is refused."""
    square = {"shape": "polygon", "sides": 4, "n": 16, "quantities": "tangential"}
    assert bc.covered_solve(Scene.from_params(square), strategy="auto")["boundary"] == "coverage"
    with pytest.raises(InputError):
        bc.covered_solve(Scene.from_params(square), strategy="singular")
    with pytest.raises(InputError):  # elongated cells (dy/dx = 1/4): the near field is sized in cells
        bc.covered_solve(
            Scene.from_params({"shape": "ellipse", "aspect": 0.25, "n": 32, "n_across": 32}), strategy="singular"
        )
    with pytest.raises(InputError):
        bc.covered_solve(Scene.from_params({"shape": "circle", "n": 16, "quantities": "coupled"}), strategy="singular")
    with pytest.raises(InputError):
        bc.covered_solve(Scene.from_params({"shape": "circle", "n": 16}), strategy="exact")


def test_auto_accuracy_starts_on_square_cells_where_singular_cells_apply() -> None:
    """``solve_to_accuracy(strategy="auto")`` (``hpcontact solve --accuracy``): singular cells from
    ``accuracy.singular_start`` — ``grid_sequence``'s first grid where its cells are within
    dy/dx ∈ [1/2, 2], else as many cells along x as square cells need for ``MIN_ACROSS`` across
    (b/a = 0.05: 160 × 8); none beyond ``SINGULAR_MAX_N0`` along x (b/a = 1e-3 would need 8000 × 8),
    nor for shapes, quantities or turns the singular cells do not carry."""
    from hpcontact import accuracy as acc
    from hpcontact.scene import Scene

    def start(params: dict, n0: int = 32):
        return acc.singular_start(Scene.from_params(params), n0, None)

    assert start({"shape": "circle"}) == (32, 32) and start({"shape": "circle"}, 16) == (16, 16)
    assert start({"shape": "ellipse", "aspect": 0.7}) == (32, 22)
    assert start({"shape": "ellipse", "aspect": 0.2}) == (32, 8)
    assert start({"shape": "ellipse", "aspect": 0.05}) == (160, 8)
    assert start({"shape": "ellipse", "aspect": 1e-3}) is None
    assert start({"shape": "polygon", "sides": 4}) is None
    assert start({"shape": "ellipse", "aspect": 0.7, "shape_angle": 30.0}) is None
    assert start({"shape": "circle", "quantities": "coupled"}) is None


def test_auto_accuracy_is_honest_per_quantity_on_singular_cells() -> None:
    """Ellipse b/a = 0.2, nu = 0.3, request 3e-5 from n₀ = 16 (grids 16 × 4 … 256 × 64, ~2 s) on
    singular cells: met, and every quantity's true error (Mindlin, Galin) below its own estimate.
    This is a case where expansions led by 1.5 and 2 put K_xx's estimate below its true error
    (1.27e-6 against 1.46e-6 at 128 × 32, measured), hence ``SINGULAR_EXPANSIONS``. ``auto`` takes
    neither for an ellipse: its one exact cell (``hpcontact.discretizations.galin_ellipse``)."""
    from hpcontact import accuracy as acc

    params = {"shape": "ellipse", "aspect": 0.2, "nu": 0.3, "quantities": "tangential,normal"}
    r = acc.solve_to_accuracy(Scene.from_params(params), 3e-5, n0=16, strategy="singular")
    assert r["boundary"] == "singular" and r["accuracy_met"] and r["stopped_by"] == "met"
    assert (r["grids"][0], r["grids_across"][0]) == (16, 4)
    K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, 0.2, 1.0, 0.3)
    exact = {
        "K_xx": K_a,
        "K_yy": K_b,
        "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, 0.2, 1.0, 0.3),
        "K_a_over_K_b": K_a / K_b,
    }
    for key, value in exact.items():
        true = abs(r[key] / value - 1.0)
        assert true <= r["estimated_errors"][key], (key, true, r["estimated_errors"][key])
    assert all(e[0] <= 1.0 for e in r["expansion"].values() if e)
    for aspect, request in ((0.2, 1e-2), (0.2, 3e-5), (1e-3, 3e-5)):
        auto = acc.solve_to_accuracy(Scene.from_params({**params, "aspect": aspect}), request, strategy="auto")
        assert auto["boundary"] == "galin" and auto["grids"] == [1]


def test_edge_near_field_leaves_a_clean_first_order_error() -> None:
    """``near_field="edge"`` (``hpcontact.discretizations.singular_pairs``): on the ellipse 0.7 (nu = 0.3) at
    32 × 22 and 64 × 44 the error of K_xx, K_yy, K_zz is the far field's first-order term alone:
    n·error within [−1.0e-3, −7.0e-4] on both grids (measured −8.6e-4 … −9.5e-4 at 32 × 22,
    −7.7e-4 … −9.5e-4 at 64 × 44, the calibration cache of ``benchmarks/edge_order.py
    --singular-calibration --near-field edge``; the bounds lie 5–9 % outside them), where
    sub-cells err by +4e-5 at 32 × 22, with the other sign. An unknown near field is an InputError naming it."""
    K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, 0.7, 1.0, 0.3)
    exact = {"xx": K_a, "yy": K_b, "zz": analytic.elliptical_punch_normal_stiffness(1.0, 0.7, 1.0, 0.3)}
    for n, na in ((32, 22), (64, 44)):
        cells = sc.SingularCells(Shape("ellipse", 0.7), n, na, Isotropic(1.0, 0.3), near_field="edge")
        for block, value in exact.items():
            error = cells.force(bc.singular_block_solve(cells, block, 1e-10).traction) / value - 1.0
            assert -1.0e-3 < n * error < -7.0e-4, (n, block, n * error)
    with pytest.raises(InputError, match="near_field"):
        sc.SingularCells(Shape("circle"), 16, 16, Isotropic(1.0, 0.3), near_field="exact")
