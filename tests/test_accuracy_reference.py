"""``--accuracy`` is honest on the square: its answer at a loose request is within its own
estimate of a reference extrapolated from finer grids than it used (issue 12; the full study,
requests 1e-3 … 1e-6 and the 1e-8 rectangle: ``benchmarks/accuracy_reference.py``).

That finer-grid reference comes from the same solver (coverage-weighted cells), so it is a
self-consistency check, not an independent one. The independent check beside it: the square's
normal stiffness K_zz is, by the analogy between the frictionless flat punch and electrostatics
(Boussinesq's u_z = P/(π E* r) against φ = q/(4πε0 r)), K_zz = π E* C̃ with C̃ the capacitance of
the square plate in units of 4πε0 (a disc of radius a: C̃ = 2a/π, K_zz = 2aE*). The unit
square's C̃ = 0.3667874 is the value quoted in the literature on the capacitance of the unit
square and cube (see Hwang & Mascagni, "Electrical capacitance of the unit cube", J. Appl. Phys.
95 (2004) 3798, and the references therein for the square); here the square has side 2a, so
C̃ = 2 × 0.3667874, taken with an uncertainty of ±5e-7 on 0.3667874 (1.4e-6 relative, 5× its
last digit). Corroborated here: the finer-grid extrapolation of K_zz meets π E* C̃ within 2.0e-6,
inside its own 3.2e-6 spread. At nu = 0 the tangential kernel is Boussinesq's, so
K_xx = K_yy = K_zz as well.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hpcontact.accuracy import solve_to_accuracy
from hpcontact.discretizations.boundary_cells import covered_solve
from hpcontact.scene import Scene

SQUARE = {"shape": "rectangle", "aspect": 1.0, "nu": 0.3, "quantities": "tangential,normal"}
#: Least-squares fits Q = Q* + Σ c_i t_i(h) over the reference grids (t = h^p, or h ln h for
#: "L1"): the reference is Q* of (1, 1.5), the three-parameter fit of least residual on the
#: square (benchmarks/accuracy_reference.py: 5e-11 against 2e-10 and 3e-10 for (1, 2) and
#: (1, L1) on n = 1280 … 2048); its uncertainty the largest distance of the others' Q* from it.
FITS = ((1.0, 1.5), (1.0, 2.0), (1.0, "L1"), (1.0, 1.5, 2.0), (1.0, 1.5, 2.5), (1.0, "L1", 1.5))
REFERENCE_GRIDS = (288, 320, 352, 384)  # all finer than the 128 that --accuracy 1e-3 stops at (16 … 128)


#: C/(4πε0) of the unit square plate (module docstring) and its relative uncertainty here.
UNIT_SQUARE_CAPACITANCE = 0.3667874
CAPACITANCE_UNCERTAINTY = 5e-7 / 0.3667874


def square_normal_stiffness(nu: float, G: float = 1.0) -> float:
    """K_zz of the rigid square punch of half-side a = 1: π E* C̃, E* = 2G/(1 − nu), side 2."""
    return math.pi * 2.0 * G / (1.0 - nu) * 2.0 * UNIT_SQUARE_CAPACITANCE


def extrapolant(n: np.ndarray, values: np.ndarray, exponents: tuple) -> float:
    h = n[0] / n
    A = np.column_stack([np.ones_like(h)] + [h * np.log(h) if p == "L1" else h**p for p in exponents])
    return float(np.linalg.lstsq(A, values, rcond=None)[0][0])


def test_accuracy_on_the_square_is_within_its_estimate_of_a_finer_reference():
    record = solve_to_accuracy(Scene.from_params(SQUARE), 1e-3)
    assert record["grids"][-1] < REFERENCE_GRIDS[0] and record["accuracy_met"]
    levels = [covered_solve(Scene.from_params({**SQUARE, "n": n, "tol": 1e-10})) for n in REFERENCE_GRIDS]
    n = np.array(REFERENCE_GRIDS, dtype=np.float64)
    for key in ("K_xx", "K_yy", "K_zz"):
        values = np.array([level[key] for level in levels])
        fits = [extrapolant(n, values, exponents) for exponents in FITS]
        reference = fits[0]
        uncertainty = max(abs(f - reference) for f in fits) / abs(reference)  # measured 3.3e-6
        estimate = record["estimated_errors"][key]  # measured 2.89e-4 (grids 16 … 128, accuracy.coverage_n0)
        assert uncertainty <= estimate / 10.0  # the reference can judge the estimate
        # honest even if the reference is off by its whole uncertainty (true error measured 4.87e-5)
        assert abs(record[key] / reference - 1.0) + uncertainty <= estimate
        assert estimate <= record["estimated_error"] <= 1e-3
        if key == "K_zz":  # the finer-grid reference itself, against the capacitance: measured 2.0e-6
            assert abs(reference / square_normal_stiffness(0.3) - 1.0) <= uncertainty + CAPACITANCE_UNCERTAINTY


def test_accuracy_on_the_square_against_the_capacitance_of_the_square_plate():
    """The independent reference of the module docstring: ``--accuracy 1e-3`` on the square,
    K_zz (and at nu = 0, where the kernels coincide, K_xx and K_yy) against π E* C̃, on the grids
    16 … 128 that a request of 1e-3 takes on the square (``accuracy.coverage_n0``). Measured:
    true error −4.606e-5 against the estimate 2.89e-4 (on the grids 32 … 256 it took before,
    −1.420e-5 against 9.56e-5). Asserted: honest with the reference's uncertainty added, and the
    true error below 4.65e-5 (the measured 4.606e-5: deterministic, CG at its tolerance)."""
    for nu, keys in ((0.3, ("K_zz",)), (0.0, ("K_xx", "K_yy", "K_zz"))):
        record = solve_to_accuracy(Scene.from_params({**SQUARE, "nu": nu}), 1e-3)
        assert record["accuracy_met"] and record["grids"] == [16, 32, 64, 128]
        exact = square_normal_stiffness(nu)
        for key in keys:
            error = abs(record[key] / exact - 1.0)
            assert error + CAPACITANCE_UNCERTAINTY <= record["estimated_errors"][key], (nu, key)
            assert error < 4.65e-5, (nu, key)


#: The regular triangle (corners of 60°) and hexagon (120°), nu 0.3, at ``--accuracy 1e-3``
#: (grids 16 × 14 … 128 × 112, ``accuracy.coverage_n0``, as the square 16 … 128): its estimate
#: against a reference from the finer grids n = 288 … 384, n_across = 7n/8 (the cell aspect of its
#: sequence: ``accuracy.grid_sequence`` on the polygon's bounding box). The fits are the square's
#: (``FITS``, reference Q* of (1, 1.5)); the polygons need no other exponents: on these grids no
#: three-parameter fit is best throughout ((1, 1.5) leaves residuals 5e-11 … 1e-10, (1, 2)
#: 3e-11 … 9e-10, (1, h ln h) 1e-10 … 9e-10), which is why the uncertainty is the spread of all
#: the fits' Q*. On the benchmark's n = 1280 … 2560 (benchmarks/accuracy_reference.py --cases
#: triangle,hexagon --nu 0.3,0.5) a free leading exponent comes out 0.99 … 1.00 and a free
#: second one after h 1.28 … 1.71 (triangle) and 1.61 … 1.80 (hexagon): the corners add no
#: exponent these grids resolve beyond the square's mix of 1.5 and 2. Measured (2026-11-26), per quantity K_xx, K_yy,
#: K_zz, K_a/K_b:
#: triangle: estimates 3.32e-4, 1.89e-4, 2.88e-4, 2.60e-4; true errors 5.84e-5, 3.81e-5, 5.39e-5,
#: 2.02e-5; reference uncertainties 4.1e-6, 3.0e-6, 4.0e-6, 8.6e-7 (the margin of
#: ``uncertainty <= estimate / 10``: 6.4 … 30×);
#: hexagon: estimates 2.75e-5, 1.62e-4, 6.46e-5, 1.77e-4; true errors 5.7e-6, 2.59e-5, 9.9e-6,
#: 3.15e-5; reference uncertainties 4.3e-7, 1.7e-6, 6.1e-7, 2.0e-6 (margin 6.4 … 10.6×).
#: (From 32 × 28 to 256 × 224, the grids of a 1e-3 request before: estimates 7.2e-5 … 1.14e-4 and
#: 1.07e-5 … 6.0e-5, true errors 5.9e-6 … 2.03e-5 and 2.1e-6 … 1.05e-5.) Cost: the four reference
#: grids dominate; 10.3 s (triangle) and 11.2 s (hexagon) CPU for a pytest process running that
#: test alone with the earlier, finer 1e-3 grids (2026-11-26, 2-core VM, load 2).
POLYGON_REFERENCE_GRIDS = tuple((n, 7 * n // 8) for n in (288, 320, 352, 384))


@pytest.mark.parametrize("sides", [3, 6], ids=["triangle", "hexagon"])
def test_accuracy_on_regular_polygons_is_within_its_estimate_of_a_finer_reference(sides):
    polygon = {"shape": "polygon", "sides": sides, "nu": 0.3, "quantities": "tangential,normal"}
    record = solve_to_accuracy(Scene.from_params(polygon), 1e-3)
    assert record["accuracy_met"] and record["grids"][-1] < POLYGON_REFERENCE_GRIDS[0][0]
    levels = [
        covered_solve(Scene.from_params({**polygon, "n": n, "n_across": na, "tol": 1e-10}))
        for n, na in POLYGON_REFERENCE_GRIDS
    ]
    n = np.array([g[0] for g in POLYGON_REFERENCE_GRIDS], dtype=np.float64)
    for key in ("K_xx", "K_yy", "K_zz", "K_a_over_K_b"):
        if key == "K_a_over_K_b":
            values = np.array([level["K_xx"] / level["K_yy"] for level in levels])
        else:
            values = np.array([level[key] for level in levels])
        fits = [extrapolant(n, values, exponents) for exponents in FITS]
        reference = fits[0]
        uncertainty = max(abs(f - reference) for f in fits) / abs(reference)
        estimate = record["estimated_errors"][key]
        assert uncertainty <= estimate / 10.0, key  # the reference can judge the estimate
        # honest even if the reference is off by its whole uncertainty (measured above)
        assert abs(record[key] / reference - 1.0) + uncertainty <= estimate, key
        assert estimate <= record["estimated_error"] <= 1e-3
        if key == "K_a_over_K_b":
            # independent of any fit: a regular polygon's in-plane tensor is isotropic (a
            # symmetric 2-tensor invariant under a rotation by 2π/m, m ≥ 3, is a multiple of the
            # identity), so K_a/K_b = 1 exactly. The finer-grid reference meets it within its
            # uncertainty (measured 5.7e-7 against 8.6e-7, 2.9e-7 against 2.0e-6), and
            # --accuracy's K_a/K_b within its estimate (measured 5.3e-6 against 9.3e-5, 1.02e-5
            # against 6.0e-5).
            assert abs(reference - 1.0) <= uncertainty
            assert abs(record[key] - 1.0) <= estimate
