"""Edge-following pair quadrature of singular cells (``hpcontact.discretizations.singular_pairs``) against closed forms.

Closed forms, none of them taken from the module: Galin's uniform displacement under the punch
traction w = (1 − x²/a² − y²/b²)^(−½) (Johnson 1985 §3.4 and §3.7, Mindlin 1949): Σᵢ V₁(x) = π² a
and Σᵢ V_xx(x) = π² a / 2 on a disc, Σᵢ V₁(x) = 2π b K(1 − b²/a²) (a ≥ b) on an ellipse, constant
for every x inside; the energies Σ I₁ = (Σ W) V₁ that follow; the cell weights W in closed form
(``singular_cells.sphere_area``). Every tolerance below states the error measured at q = 6 and at
q = 8 (the module's default q is 6) and the margin taken, on singular_pairs.py as of 2026-11-23
07:21 UTC.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipk

from hpcontact.discretizations import singular_cells as sc
from hpcontact.discretizations import singular_pairs as sp

pytestmark = pytest.mark.filterwarnings("error")

ELLIPSE_B = 0.7  # semi-axes (1, 0.7) for the ellipse cases


def _grid(n: int, a: float, b: float) -> tuple[np.ndarray, ...]:
    """The n × n cells of [−a, a] × [−b, b] that meet the ellipse: X1, X2, Y1, Y2, column, row, W."""
    xs, ys = np.linspace(-a, a, n + 1), np.linspace(-b, b, n + 1)
    X1, Y1 = (Z.ravel() for Z in np.meshgrid(xs[:-1], ys[:-1], indexing="ij"))
    X2, Y2 = (Z.ravel() for Z in np.meshgrid(xs[1:], ys[1:], indexing="ij"))
    I, J = (Z.ravel() for Z in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    W = a * b * sc._rect(sc.sphere_area, X1 / a, X2 / a, Y1 / b, Y2 / b)
    keep = W > 0.0
    return X1[keep], X2[keep], Y1[keep], Y2[keep], I[keep], J[keep], W[keep]


def _potential_sum(a: float, b: float, points, q: int, n: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Σ over every cell of an n × n grid of (V₁, V_xx) at the given points."""
    X1, X2, Y1, Y2, _, _, _ = _grid(n, a, b)
    P = np.broadcast_to(np.asarray(points, dtype=float)[None], (len(X1), len(points), 2)).copy()
    V1, Vxx = sp.ray_potential(P, X1, X2, Y1, Y2, a, b, q)
    return V1.sum(0), Vxx.sum(0)


# points inside: the centre (a cell corner), a cell corner (0.25, 0.5), 0.999 of each semi-axis,
# 0.999 of the way to the edge in an oblique direction, and generic interior points
DISC_POINTS = [
    (0.0, 0.0),
    (0.3, -0.2),
    (0.5, 0.5),
    (0.25, 0.5),
    (0.999, 0.0),
    (0.0, 0.999),
    (-0.6, 0.7),
    (0.999 * math.cos(1.0), 0.999 * math.sin(1.0)),
]
ELLIPSE_POINTS = [
    (0.0, 0.0),
    (0.3, -0.2),
    (0.5, 0.35),
    (0.999, 0.0),
    (0.0, 0.999 * ELLIPSE_B),
    (0.25, 0.175),
    (-0.6, 0.5 * ELLIPSE_B),
    (0.999 * math.cos(1.0), 0.999 * ELLIPSE_B * math.sin(1.0)),
]  # (0.25, 0.175): a corner


@pytest.mark.parametrize("q, bound_1, bound_xx", [(6, 1e-5, 1e-5), (8, 1.5e-6, 1.5e-6)])
def test_disc_potential_is_galins_uniform_displacement(q: int, bound_1: float, bound_xx: float) -> None:
    """Σᵢ V₁ = π² and Σᵢ V_xx = π²/2 at 8 points of the unit disc, 8 × 8 grid (relative).
    Measured max: V₁ 3.8e-6 (q = 6), 4.4e-7 (q = 8); V_xx 3.3e-6, 4.0e-7. Bounds ~2.5-3.5×."""
    V1, Vxx = _potential_sum(1.0, 1.0, DISC_POINTS, q)
    assert np.max(np.abs(V1 / math.pi**2 - 1.0)) < bound_1
    assert np.max(np.abs(Vxx / (0.5 * math.pi**2) - 1.0)) < bound_xx


@pytest.mark.parametrize("q, bound_1, bound_xx", [(6, 2e-5, 4e-5), (8, 1e-6, 1.5e-6)])
def test_ellipse_potential_is_constant(q: int, bound_1: float, bound_xx: float) -> None:
    """Σᵢ V₁ and Σᵢ V_xx over an 8 × 8 grid of the ellipse (1, 0.7) are the same at 8 points inside
    (relative spread max − min over mean) and Σᵢ V₁ = 2π b K(m), m = 1 − b²/a² (Galin; a = 1).
    Measured spread: V₁ 8.2e-6 (q = 6), 3.9e-7 (q = 8); V_xx 1.5e-5, 6.0e-7 (1.8e-9, 1.8e-9 at
    q = 16). Measured mean against 2π b K: 9.2e-7 (q = 6), 4.4e-8 (q = 8), 1.2e-9 (q = 16). Bounds:
    ~2.5× the spread; the mean against the same bound_1."""
    V1, Vxx = _potential_sum(1.0, ELLIPSE_B, ELLIPSE_POINTS, q)
    assert (V1.max() - V1.min()) / V1.mean() < bound_1
    assert (Vxx.max() - Vxx.min()) / Vxx.mean() < bound_xx
    assert V1.mean() == pytest.approx(2.0 * math.pi * ELLIPSE_B * ellipk(1.0 - ELLIPSE_B**2), rel=bound_1)


# (X1, X2, Y1, Y2, b, measured relative error of Σ weights at q = 6, at q = 8)
WEIGHT_CELLS = {
    "full": (0.1, 0.3, 0.2, 0.5, 1.0, 1.0e-5, 6.5e-8),
    "cut": (0.6, 0.9, 0.3, 0.9, 1.0, 2.4e-6, 5.5e-8),
    "cut, side tangent at x = 1": (0.5, 1.2, -0.3, 0.4, 1.0, 6.8e-6, 2.1e-8),
    "corner only, W = 1.0e-4": (0.6 - 1e-3, 0.9, 0.8 - 1e-3, 1.0, 1.0, 2.5e-8, 6.3e-12),
    "ellipse cut": (0.5, 0.75, 0.25, 0.5, ELLIPSE_B, 9.7e-8, 2.5e-8),
    "ellipse cut at x = 1": (0.75, 1.0, 0.0, 0.175, ELLIPSE_B, 2.5e-6, 7.0e-9),
    "ellipse, corner at the centre": (-0.25, 0.0, -0.175, 0.0, ELLIPSE_B, 1.7e-5, 3.6e-7),
    "containing the centre": (-0.2, 0.1, -0.15, 0.3, 1.0, 1.5e-4, 1.1e-5),
    "whole ellipse": (-1.05, 1.05, -0.8, 0.8, ELLIPSE_B, 3.3e-5, 2.5e-7),
}


@pytest.mark.parametrize("q", [6, 8])
@pytest.mark.parametrize("name", list(WEIGHT_CELLS))
def test_node_weights_sum_to_the_cell_weight(name: str, q: int) -> None:
    """Σ_k weights = W (closed form, a b F over the rectangle) per cell, relative. Bound: 3× the
    error measured for that cell at that q (WEIGHT_CELLS). The cells containing the centre converge
    slowest (1.5e-4 at q = 6, 1.1e-5 at q = 8, 2.2e-10 at q = 16)."""
    X1, X2, Y1, Y2, b, at6, at8 = WEIGHT_CELLS[name]
    _, weights = sp.cell_nodes(np.array([X1]), np.array([X2]), np.array([Y1]), np.array([Y2]), 1.0, b, q)
    W = b * float(sc._rect(sc.sphere_area, X1, X2, Y1 / b, Y2 / b))
    assert abs(weights.sum() / W - 1.0) < 3.0 * (at6 if q == 6 else at8)


def test_node_weights_of_a_corner_touch() -> None:
    """A cell meeting the disc in a sliver at its corner (W = 3.3e-9): Σ weights against W to 1e-13
    absolute. The closed form itself is a difference of four O(1) values of F: the nodes at q = 6, 8
    and 16 all give W − 1.26e-14 (converged), so the bound is the closed form's rounding, ~8×."""
    X1, X2, Y1, Y2 = 0.6 - 1e-6, 0.9, 0.8 - 1e-6, 1.0
    W = float(sc._rect(sc.sphere_area, X1, X2, Y1, Y2))
    for q in (6, 8):
        _, weights = sp.cell_nodes(np.array([X1]), np.array([X2]), np.array([Y1]), np.array([Y2]), 1.0, 1.0, q)
        assert abs(weights.sum() - W) < 1e-13


def _energy(a: float, b: float, q: int, n: int = 8, p: int = 6) -> tuple[float, float, float]:
    """Σ over all ordered cell pairs of (I₁, I_xx), and Σ W: touching_integrals for pairs whose
    cells are at most one cell apart (Chebyshev), separated_integrals with interpolatory_rule(p)
    nodes for the others."""
    X1, X2, Y1, Y2, I, J, W = _grid(n, a, b)
    points, weights = sp.cell_nodes(X1, X2, Y1, Y2, a, b, q)
    t, s = (Z.ravel() for Z in np.meshgrid(np.arange(len(X1)), np.arange(len(X1)), indexing="ij"))
    touch = np.maximum(np.abs(I[t] - I[s]), np.abs(J[t] - J[s])) <= 1
    T1, Txx = sp.touching_integrals(
        points[t[touch]], weights[t[touch]], X1[s[touch]], X2[s[touch]], Y1[s[touch]], Y2[s[touch]], a, b, q
    )
    rp, rw = sp.interpolatory_rule(X1, X2, Y1, Y2, points, weights, p)
    far_t, far_s = t[~touch], s[~touch]
    S1, Sxx = sp.separated_integrals(rp[far_t], rw[far_t], rp[far_s], rw[far_s])
    return T1.sum() + S1.sum(), Txx.sum() + Sxx.sum(), W.sum()


@pytest.mark.parametrize("q, bound", [(6, 1e-5), (8, 1.5e-7)])
def test_disc_energy(q: int, bound: float) -> None:
    """Σ I₁ = 2π³ and Σ I_xx = π³ over every ordered pair of cells of an 8 × 8 disc (relative).
    Measured: I₁ 4.0e-6, I_xx 4.0e-6 (q = 6); 4.2e-8, 4.2e-8 (q = 8). Bounds ~2.5-3.5×."""
    I1, Ixx, _ = _energy(1.0, 1.0, q)
    assert I1 / (2.0 * math.pi**3) == pytest.approx(1.0, abs=bound)
    assert Ixx / math.pi**3 == pytest.approx(1.0, abs=bound)


@pytest.mark.parametrize("q, bound", [(6, 1e-5), (8, 1.5e-7)])
def test_ellipse_energy(q: int, bound: float) -> None:
    """Σ I₁ = (Σ W) V with V the constant Σᵢ V₁ of the ellipse (1, 0.7), taken from the potential
    check at q = 16 (where its spread is 1.8e-9). Measured: 4.1e-6 (q = 6), 5.6e-8 (q = 8). Bounds ~2.5×."""
    V1, _ = _potential_sum(1.0, ELLIPSE_B, ELLIPSE_POINTS, 16)
    I1, _, W = _energy(1.0, ELLIPSE_B, q)
    assert I1 / (W * V1.mean()) == pytest.approx(1.0, abs=bound)


@pytest.mark.parametrize("b, q", [(1.0, 6), (1.0, 8), (ELLIPSE_B, 6), (ELLIPSE_B, 8)])
def test_interpolatory_rule_is_exact_for_polynomials(b: float, q: int) -> None:
    """The p × p rule integrates xⁱ yʲ (i, j < p), global and cell-centred, as the fine nodes do:
    bound 1e-12 relative to Σ|terms| (measured ≤ 4.0e-15 for p = 4 and 6 on every cell of the
    8 × 8 disc and ellipse, q = 6 and 8)."""
    X1, X2, Y1, Y2, _, _, _ = _grid(8, 1.0, b)
    points, weights = sp.cell_nodes(X1, X2, Y1, Y2, 1.0, b, q)
    for p in (4, 6):
        rp, rw = sp.interpolatory_rule(X1, X2, Y1, Y2, points, weights, p)
        for centred in (False, True):
            cx = 0.5 * (X1 + X2)[:, None] if centred else 0.0
            cy = 0.5 * (Y1 + Y2)[:, None] if centred else 0.0
            for i in range(p):
                for j in range(p):
                    fine = weights * (points[..., 0] - cx) ** i * (points[..., 1] - cy) ** j
                    rule = (rw * (rp[..., 0] - cx) ** i * (rp[..., 1] - cy) ** j).sum(1)
                    scale = np.abs(fine).sum(1)
                    assert np.all(np.abs(rule - fine.sum(1)) <= 1e-12 * scale)


# cell pairs (column, row) two apart on the 8 × 8 disc: inner, cut-and-full, cut diagonal, cut pair
TWO_APART = [((3, 3), (5, 3)), ((6, 2), (6, 4)), ((7, 3), (5, 5)), ((1, 6), (3, 7))]


@pytest.mark.parametrize("q, bound_1, bound_xx", [(6, 3e-5, 6e-4), (8, 1e-6, 1e-5)])
def test_separated_agrees_with_touching_two_cells_apart(q: int, bound_1: float, bound_xx: float) -> None:
    """For pairs two cells apart, touching_integrals (ray potential) and separated_integrals
    (node against node) are two quadratures of the same integral (relative, each of I₁, I_xx), with
    the fine cell_nodes and with interpolatory_rule(p = 6) nodes. Measured, fine / rule: I₁ 1.1e-5 /
    1.1e-5 (q = 6), 2.1e-7 / 3.5e-7 (q = 8); I_xx 2.9e-4 / 2.3e-4 (q = 6), 4.7e-6 / 4.0e-6 (q = 8),
    largest for the vertically offset pair (6, 2)-(6, 4) whose I_xx is small (cos²ψ ≈ 0). At q = 16
    the fine nodes agree to 1.8e-9. Bounds ~2-3×."""
    X1, X2, Y1, Y2, I, J, _ = _grid(8, 1.0, 1.0)

    def index(column: int, row: int) -> int:
        return int(np.flatnonzero((I == column) & (J == row))[0])

    t = np.array([index(*target) for target, _ in TWO_APART])
    s = np.array([index(*source) for _, source in TWO_APART])
    points, weights = sp.cell_nodes(X1, X2, Y1, Y2, 1.0, 1.0, q)
    T1, Txx = sp.touching_integrals(points[t], weights[t], X1[s], X2[s], Y1[s], Y2[s], 1.0, 1.0, q)
    F1, Fxx = sp.separated_integrals(points[t], weights[t], points[s], weights[s])
    assert np.max(np.abs(F1 / T1 - 1.0)) < bound_1
    assert np.max(np.abs(Fxx / Txx - 1.0)) < bound_xx
    rp, rw = sp.interpolatory_rule(X1, X2, Y1, Y2, points, weights, 6)
    S1, Sxx = sp.separated_integrals(rp[t], rw[t], rp[s], rw[s])
    assert np.max(np.abs(S1 / T1 - 1.0)) < bound_1
    assert np.max(np.abs(Sxx / Txx - 1.0)) < bound_xx
