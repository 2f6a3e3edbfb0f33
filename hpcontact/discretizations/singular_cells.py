r"""Boundary cells that carry the square-root edge singularity of the bonded punch (Galerkin).

Why
---
Piecewise-constant tractions on coverage-weighted cells (``hpcontact.discretizations.boundary_cells``) converge
at first order: the bonded punch's traction is t = g(x) w(x) with w ∝ d^(−1/2) at distance d from
the edge, which no constant per cell resolves (relative K error ≈ −0.1 h for an ellipse, h the
cell size over the semi-axis a). Here the edge behaviour is built into the basis, as in the
singular (quarter-point) elements of fracture mechanics (Henshell & Shaw, IJNME 9, 495, 1975;
Barsoum, IJNME 10, 25, 1976) and the augmented Galerkin method for screen and crack problems
(Stephan & Wendland, Applicable Analysis 18, 183, 1984), where singular functions of the edge
added to the trial space restore the convergence rate of smooth solutions.

Discretization (circle and ellipse x²/a² + y²/b² ≤ 1, unturned; isotropic half-space)
-------------------------------------------------------------------------------------
Trial and test functions on cell i are w(x) restricted to the covered part Ωᵢ = cellᵢ ∩ Ω,

    w(x, y) = (1 − x²/a² − y²/b²)^(−1/2),        t(x) = Σᵢ gᵢ w(x) 1_Ωᵢ(x),

the traction of Mindlin's (1949) and Boussinesq/Galin's elliptical punch (Johnson 1985 §3.7,
§7.2): g is constant there, so the exact solution lies in the trial space. The Galerkin equations

    Σᵢ Bⱼᵢ gᵢ = u₀ Wⱼ,    Bⱼᵢ = ∫_Ωⱼ ∫_Ωᵢ w(x) G(x − y) w(y) dy dx,    Wⱼ = ∫_Ωⱼ w dA,

(G the half-space Green's function of the block, Johnson 1985 eq. 3.19–3.20) are symmetric
positive definite; the stiffness is K = Σ gᵢ Wᵢ / u₀. In the unknowns sᵢ = gᵢ Wᵢ/(dx dy)
(force per cell area) the system is Ã s = u₀ with Ãⱼᵢ = dx dy Bⱼᵢ/(Wⱼ Wᵢ), split as in the
precorrected-FFT method (Phillips & White 1997, IEEE TCAD 16, 1059):

* far field Pᵀ K* P: K* is the uniform-cell kernel averaged over the target cell as well
  (the Galerkin double average; Love's rectangle integral averaged by graded Gauss–Legendre
  within ``EXACT_OFFSETS`` cells, by its Taylor series through fourth differences beyond), applied
  by the engine's FFT convolution; P spreads each cell's w-distribution onto the 3 × 3 cell
  centres around it so that its moments through second order are matched (weights from the
  closed-form W and centroid, second moments from the sub-cells below; quadratic Lagrange
  weights where those are not computed);
* near field: for cell pairs within ``NEAR`` cells (Chebyshev) of each other, one of them within
  ``BAND`` cells of a cut cell, Ã − Pᵀ K* P is added as a sparse correction, B from m × m
  sub-cells with exact ∫w (a closed form, :func:`sphere_area`) and Love's sub-cell integral,
  extrapolated in m (2 B_m − B_{m/2}).
  (``near_field="subcells"``, what ``covered_solve`` and ``--accuracy`` use); or
  ``near_field="edge"``: by quadrature that follows the edge (``hpcontact.discretizations.singular_pairs``:
  nodes in the hemisphere variables, where w dA is smooth; for touching pairs the source's
  potential along rays from each node, whose w-integral is an arcsine), P's second moments
  from the same nodes — below, "Edge quadrature", for what it gives and why it is not used.

Closed forms: ∫∫ (1 − u² − v²)^(−1/2) du dv over [0, U] × [0, V] is the area of the unit
hemisphere above it, F = U asin(V/√(1−U²)) + V asin(U/√(1−V²)) − atan(UV/√(1−U²−V²)) inside
the disc, π(U + V − 1)/2 beyond; first moments through ∫ √(c² − v²) dv.

Error (``benchmarks/edge_order.py``; docs/validation.md §"Singular cells")
--------------------------------------------------------------------------
Not a clean power series in h. What is left is the sub-cell quadrature of the cut cells, a
first-order term with a small, geometry-dependent constant that changes sign, so order-1
Richardson does not apply and the difference of two grids can be small by accident. The bound
for an estimator is

    |K/K_exact − 1| ≤ C / n_across,        C = ``ERROR_CONSTANT`` = 1.03e-3,

n_across the cells across the minor axis 2b: the largest |n_across·error| over K_xx, K_yy,
K_zz, nu = 0, 0.3, 0.5, the circle and ellipses 0.7, 0.5 on n = 32 … 256 and 0.05 on 8 … 32
cells across (``benchmarks/edge_order.py --bound``); coverage weighting errs by 0.2/n … 1.4/n on the same
grids, with a clean first-order expansion. Raising ``SUBCELLS`` does not help reliably: the cut
sub-cells are first order in their own size, and their extrapolation in m is not smooth.

What the remaining error is made of: two first-order parts of opposite sign, the far field
beyond ``NEAR`` (the 3 × 3 moment-matched spreading) and the adjacent pairs' edge layer, first
order in the sub-cell size h/m (a uniform sub-cell stands for w ∝ d^(−1/2) there). With
``NEAR`` = 2 and ``SUBCELLS`` = 16 they cancel to a few 1e-7, but what is left does not fall
steadily with n, which is why ``accuracy`` gives singular cells a larger factor on the spread
and stops them at the grids it was calibrated on (``accuracy.SINGULAR_SAFETY``,
``accuracy.SINGULAR_MAX_CELLS``).

Edge quadrature (``near_field="edge"``)
---------------------------------------
The exact solution g = const lies in the trial space, so K's error is that of B alone: to first
order −δE/E with E = Σ B (the energy of Galin's and Mindlin's traction), plus a positive part
second order in δB from the Galerkin solution's departure from g = const. With the near field
by the edge quadrature the second-order part is gone and what is left is the far field beyond
``NEAR``: first order and nearly steady (n_across·error ≈ −5e-4 … −7e-4 on b/a 0.7), and the
estimator needs the same factor 6 on these sequences (``benchmarks/edge_order.py
--singular-calibration CACHE --near-field edge``). It is not the default: its setup costs
10–20× that of sub-cells, so per CPU second it is worse; and with ``NEAR`` = 3 its error is
again two first-order terms of opposite sign, no longer steady, so ``NEAR`` stays 2. The
measurements, and the experiments on wider spreading stencils and bands that point to the
band's pairs by a cheaper exact quadrature as the next step: docs/validation.md §"Singular
cells".
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from hpcontact.discretizations import singular_pairs
from hpcontact.errors import InputError
from hpcontact.geometry import Grid, Shape, grid_for
from hpcontact.kernels.cell_integrals import cell_integrals
from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.convolution import ConvolutionOperator, kernel_spectrum, padded_shape

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = [
    "BAND",
    "ERROR_CONSTANT",
    "EXACT_OFFSETS",
    "MAX_CELL_ASPECT",
    "NEAR",
    "NEAR_FIELDS",
    "SUBCELLS",
    "BlockSystem",
    "SingularCells",
    "double_average_kernel",
    "sphere_area",
    "supports",
]

NEAR = 2  # pairs within this many cells (Chebyshev) get the exact near-field integral
BAND = 1  # ... when one of the two lies within this many cells of a cut cell (2: same errors ± 5e-5/n_across, 30 % more setup)
EXACT_OFFSETS = 6  # K* by quadrature within this many cells, by its Taylor series beyond
SUBCELLS = (16, 16)  # sub-cells per side for adjacent pairs (|offset| ≤ 1) and farther pairs
GRADED_LEVELS, GRADED_POINTS = 10, 6  # graded Gauss–Legendre for K* (error ≲ 1e-9 relative)
BLOCKS = ("xx", "yy", "zz")
MAX_CELL_ASPECT = 2.0  # dy/dx within [1/2, 2]
ERROR_CONSTANT = 1.03e-3  # |relative K error| ≤ this / (cells across the minor axis): largest of edge_order.py --bound
NEAR_FIELDS = ("subcells", "edge")  # the near field's quadrature (``SingularCells``)
MIN_WEIGHT = 1e-9  # cells with W below this fraction of their area are left out (W is a difference of O(1) closed forms: ~1e-16 absolute)


def supports(shape: Shape, material: object, grid: Grid) -> bool:
    """Whether the singular treatment applies: an unturned circle or ellipse (w is known in
    closed form there) on an isotropic half-space, on cells no more elongated than
    ``MAX_CELL_ASPECT`` (the near field and K*'s exact table are sized in cells; elongated cells
    would need them over ~6/aspect cells across)."""
    aspect = grid.dy / grid.dx
    shaped = shape.name in ("circle", "ellipse") and shape.angle_deg == 0.0
    return isinstance(material, Isotropic) and shaped and 1.0 / MAX_CELL_ASPECT <= aspect <= MAX_CELL_ASPECT


# ------------------------------------------------------------------------------------------
# closed-form integrals of w over rectangles (coordinates scaled by the semi-axes)
# ------------------------------------------------------------------------------------------
def _hemisphere(U: np.ndarray, V: np.ndarray) -> np.ndarray:
    U = np.minimum(np.abs(U), 1.0)
    V = np.minimum(np.abs(V), 1.0)
    s2 = 1.0 - U * U - V * V
    cu = np.sqrt(np.maximum(1.0 - U * U, 1e-300))
    cv = np.sqrt(np.maximum(1.0 - V * V, 1e-300))
    inside = U * np.arcsin(np.minimum(V / cu, 1.0)) + V * np.arcsin(np.minimum(U / cv, 1.0))
    inside -= np.arctan2(U * V, np.sqrt(np.maximum(s2, 0.0)))
    return np.where(s2 > 0.0, inside, 0.5 * math.pi * (U + V - 1.0))


def sphere_area(U: np.ndarray, V: np.ndarray) -> np.ndarray:
    """F(U, V) = ∫₀^U ∫₀^V (1 − u² − v²)^(−1/2) 1[u² + v² < 1] dv du (odd in U and in V).

    The area of the unit hemisphere above the rectangle (dA_sphere = dA/z); closed form in the
    module docstring, derived by integrating asin(V/√(1 − u²)) by parts. Dimensionless.
    """
    return np.sign(U) * np.sign(V) * _hemisphere(np.asarray(U, float), np.asarray(V, float))


def _rect(F: Callable[[np.ndarray, np.ndarray], np.ndarray], u1, u2, v1, v2) -> np.ndarray:
    return F(u2, v2) - F(u1, v2) - F(u2, v1) + F(u1, v1)


def _half_disc(t: np.ndarray) -> np.ndarray:
    t = np.clip(t, -1.0, 1.0)
    return 0.5 * (t * np.sqrt((1.0 - t) * (1.0 + t)) + np.arcsin(t))


def _column(u: np.ndarray, v1: np.ndarray, v2: np.ndarray) -> np.ndarray:
    """∫_{v1}^{v2} √(max(0, 1 − u² − v²)) dv."""
    c2 = np.maximum(1.0 - u * u, 0.0)
    c = np.sqrt(c2)
    safe = np.where(c > 0.0, c, 1.0)
    return np.where(c > 0.0, c2 * (_half_disc(v2 / safe) - _half_disc(v1 / safe)), 0.0)


def _first_moment(u1, u2, v1, v2) -> np.ndarray:
    """∫∫ u (1 − u² − v²)^(−1/2) over [u1, u2] × [v1, v2] ∩ disc (∂/∂u of −√(1 − u² − v²))."""
    return _column(u1, v1, v2) - _column(u2, v1, v2)


# ------------------------------------------------------------------------------------------
# kernels: the uniform-cell kernel averaged over the target cell (Galerkin double average)
# ------------------------------------------------------------------------------------------
#: Love's integrals every block is made of (``_combine``): K*'s exact table and the near field's
#: sub-cell sums (formed once per grid for all blocks) use these two.
BASE_INTEGRALS = ("one_over_r", "xx_over_r3")


def _combine(nu: float, block: str, one_over_r, xx_over_r3):
    """A block's Green's function integral from those of 1/r and x²/r³ (Johnson 1985 eq.
    3.19–3.20 with G = 1): zz (1 − ν) I₁/2π, xx ((1 − ν) I₁ + ν I_xx)/2π, yy ((1 − ν) I₁ +
    ν I_yy)/2π with I_yy = I₁ − I_xx (x² + y² = r²). Works on arrays or on sparse sums alike."""
    if block == "zz":
        return (1.0 - nu) / (2.0 * math.pi) * one_over_r
    if block == "xx":
        return ((1.0 - nu) * one_over_r + nu * xx_over_r3) / (2.0 * math.pi)
    return (one_over_r - nu * xx_over_r3) / (2.0 * math.pi)


def _block_integral(nu: float, block: str, x: np.ndarray, y: np.ndarray, hx: float, hy: float) -> np.ndarray:
    """Love's integral of block's Green's function (G = 1) over [−hx, hx] × [−hy, hy] at (x, y)."""
    I = cell_integrals(x, y, hx, hy, BASE_INTEGRALS)
    return _combine(nu, block, *(I[kind] for kind in BASE_INTEGRALS))


def _graded_rule(levels: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre on [−½, ½] with intervals halving toward both ends (the
    x log x behaviour of Love's integral on the source cell's edge lines)."""
    t, w = np.polynomial.legendre.leggauss(points)
    b = np.concatenate([0.5 - 0.5 ** np.arange(1, levels + 1), [0.5]])
    b = np.concatenate([-b[::-1], b[1:]])
    lo, hi = b[:-1], b[1:]
    return ((0.5 * (lo + hi))[:, None] + 0.5 * (hi - lo)[:, None] * t).ravel(), (0.5 * (hi - lo)[:, None] * w).ravel()


def _cell_average_stencil() -> np.ndarray:
    """The 5 × 5 weights of K* = K + (δ²ₓ + δ²ᵧ)K/24 − 17(δ⁴ₓ + δ⁴ᵧ)K/5760 + δ²ₓδ²ᵧK/576 on the
    collocation kernel K (``double_average_kernel``), δ² = (1, −2, 1), δ⁴ = (1, −4, 6, −4, 1)."""
    d2, d4 = np.array([1.0, -2.0, 1.0]), np.array([1.0, -4.0, 6.0, -4.0, 1.0])
    w = np.zeros((5, 5))
    w[2, 2] = 1.0
    w[1:4, 2] += d2 / 24.0
    w[2, 1:4] += d2 / 24.0
    w[:, 2] -= 17.0 * d4 / 5760.0
    w[2, :] -= 17.0 * d4 / 5760.0
    w[1:4, 1:4] += np.outer(d2, d2) / 576.0
    w.setflags(write=False)
    return w


_CELL_AVERAGE = _cell_average_stencil()


@lru_cache(maxsize=32)
def _exact_table(nu: float, block: str, ratio: float, reach: int) -> np.ndarray:
    """K* at offsets (P, Q), 0 ≤ P, Q ≤ reach, for dx = 1, dy = ratio and G = 1 (read-only)."""
    graded = _graded_rule(GRADED_LEVELS, GRADED_POINTS)
    t, w = np.polynomial.legendre.leggauss(10)
    plain = (0.5 * t, 0.5 * w)
    out = np.empty((reach + 1, reach + 1))
    for P in range(reach + 1):
        ux, wx = graded if P <= 1 else plain
        for Q in range(reach + 1):
            uy, wy = graded if Q <= 1 else plain
            k = _block_integral(nu, block, P + ux[:, None], ratio * (Q + uy[None, :]), 0.5, 0.5 * ratio)
            out[P, Q] = wx @ k @ wy
    out.setflags(write=False)
    return out


def double_average_kernel(material: Isotropic, nx: int, ny: int, dx: float, dy: float, block: str) -> np.ndarray:
    """K*(p dx, q dy): displacement averaged over the target cell per unit uniform traction on
    the source cell, centred offset grid (2nx−1, 2ny−1) as ``isotropic_block`` [length/stress].

    K* = K + (δ²ₓ + δ²ᵧ)K/24 − 17(δ⁴ₓ + δ⁴ᵧ)K/5760 + δ²ₓδ²ᵧK/576 (the cell average of the Taylor
    series in central differences δ of the collocation kernel K; one 5 × 5 correlation,
    ``_CELL_AVERAGE``), replaced within
    ``EXACT_OFFSETS`` cells by graded Gauss–Legendre quadrature of Love's integral.
    """
    from scipy.ndimage import correlate  # on first use, not at import (strip_cells' docstring)

    Kb = isotropic_block(material, nx + 2, ny + 2, dx, dy, block)
    K = correlate(Kb, _CELL_AVERAGE, mode="constant")[2:-2, 2:-2]
    rx, ry = min(EXACT_OFFSETS, nx - 1), min(EXACT_OFFSETS, ny - 1)
    table = dx / material.G * _exact_table(material.nu, block, dy / dx, max(rx, ry))[: rx + 1, : ry + 1]
    full = np.concatenate([table[:0:-1], table], 0)
    K[nx - 1 - rx : nx + rx, ny - 1 - ry : ny + ry] = np.concatenate([full[:, :0:-1], full], 1)
    return K


@lru_cache(maxsize=64)
def _subcell_block(kind: str, ratio: float, m: int, P: int, Q: int) -> np.ndarray:
    """M[s, s'] = (Love integral of ``kind`` (``BASE_INTEGRALS``) over sub-cell s' at the centre of
    sub-cell s) / sub-cell area, for the target cell at offset (P, Q) from the source, m × m
    sub-cells, dx = 1, dy = ratio (read-only)."""
    k = np.arange(1 - m, m)  # distinct sub-cell offsets (the matrix is Toeplitz-block-Toeplitz)
    table = cell_integrals(P + k[:, None] / m, ratio * (Q + k[None, :] / m), 0.5 / m, 0.5 * ratio / m, [kind])[kind]
    sa, sb = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    sa, sb = sa.ravel(), sb.ravel()
    M = table[m - 1 + sa[:, None] - sa[None, :], m - 1 + sb[:, None] - sb[None, :]] * (m * m / ratio)
    M.setflags(write=False)
    return M


# ------------------------------------------------------------------------------------------
# one grid: weights, moment-matched spreading, near-field correction, operator
# ------------------------------------------------------------------------------------------
class SingularCells:
    """The cells of one (shape, grid, material): weights, spreading, sub-cells (module docstring).

    ``grid`` is the cropped grid padded by one cell on every side (room for the 3 × 3 spreading),
    ``mask`` the cells with W > 0, ``W`` their ∫w dA [area], ``beta`` the spreading weights P
    per stencil offset (``beta_near``: at the near set's cells), ``spreading()`` P and Pᵀ as
    sparse matrices shared by the blocks; ``system(block)`` the Galerkin system of one block
    (``BlockSystem``); ``force(s)`` = Σ s dx dy.
    """

    def __init__(
        self, shape: Shape, n: int, n_across: int | None, material: Isotropic, near_field: str = "subcells"
    ) -> None:
        if near_field not in NEAR_FIELDS:
            raise InputError("near_field", f"one of {', '.join(NEAR_FIELDS)}", near_field)
        self.near_field = near_field
        full = grid_for(shape, n, n_across)
        if not supports(shape, material, full):
            raise InputError(
                "shape",
                f"an unturned circle or ellipse, isotropic, cells dy/dx within 1/{MAX_CELL_ASPECT:g} … {MAX_CELL_ASPECT:g}",
                shape.name,
            )
        a, b = 1.0, (shape.aspect if shape.name == "ellipse" else 1.0)
        dx, dy = full.dx, full.dy
        # cells any part of which is inside: |x| < a + dx/2 etc.; crop to them, pad by one
        ix = np.flatnonzero(np.abs(full.x) - 0.5 * dx < a)
        jy = np.flatnonzero(np.abs(full.y) - 0.5 * dy < b)
        x = full.x[ix[0]] + (np.arange(ix.size + 2) - 1) * dx
        y = full.y[jy[0]] + (np.arange(jy.size + 2) - 1) * dy
        nx, ny = x.size, y.size
        self.grid = Grid(nx=nx, ny=ny, dx=dx, dy=dy)
        u1, u2 = ((x - 0.5 * dx) / a)[:, None], ((x + 0.5 * dx) / a)[:, None]
        v1, v2 = ((y - 0.5 * dy) / b)[None, :], ((y + 0.5 * dy) / b)[None, :]
        Wuv = _rect(sphere_area, u1, u2, v1, v2)
        full_cell = (u1**2 + v1**2 < 1) & (u1**2 + v2**2 < 1) & (u2**2 + v1**2 < 1) & (u2**2 + v2**2 < 1)
        mask = Wuv > MIN_WEIGHT * dx * dy / (a * b)  # barely touched cells (W ~ rounding) are left out
        safe = np.where(mask, Wuv, 1.0)
        xi = np.where(mask, (a * _first_moment(u1, u2, v1, v2) / safe - x[:, None]) / dx, 0.0)
        eta = np.where(mask, (b * _first_moment(v1.T, v2.T, u1.T, u2.T).T / safe - y[None, :]) / dy, 0.0)
        self.mask = mask
        self.W = np.where(mask, a * b * Wuv, 0.0)
        self.material = material

        # near set: cells within BAND of a cut cell (band), and cells within NEAR of the band
        cut = mask & ~full_cell
        square = np.ones((3, 3), dtype=bool)
        from scipy.ndimage import binary_dilation  # on first use, not at import (strip_cells' docstring)

        band = binary_dilation(cut, square, iterations=BAND) & mask
        near = binary_dilation(band, square, iterations=NEAR) & mask
        cells = np.argwhere(near)
        index = -np.ones((nx, ny), dtype=np.int64)
        index[near] = np.arange(len(cells))
        in_band = band[cells[:, 0], cells[:, 1]]

        self.cells, self.index, self.in_band = cells, index, in_band
        self._x, self._y, self._axes = x, y, (a, b)
        self._sub: dict[int, np.ndarray] = {}

        # second moments about the cell centre (units dx², dy², dx dy): uniform-cell values
        # where w is smooth; on the near set sub-cell sums extrapolated in m ("subcells") or the
        # edge quadrature's nodes ("edge", which its pair integrals use as well)
        mxx, myy, mxy = 1.0 / 12.0 + xi**2, 1.0 / 12.0 + eta**2, xi * eta
        Wn = self.Wn = self.W[cells[:, 0], cells[:, 1]]
        if near_field == "edge":
            X, Y = x[cells[:, 0]], y[cells[:, 1]]
            self.rects = np.stack([X - 0.5 * dx, X + 0.5 * dx, Y - 0.5 * dy, Y + 0.5 * dy])
            self.nodes, self.node_weights = singular_pairs.cell_nodes(*self.rects, a, b)
            self.separated_rule = singular_pairs.interpolatory_rule(*self.rects, self.nodes, self.node_weights)
            ex, ey = (self.nodes[..., 0] - X[:, None]) / dx, (self.nodes[..., 1] - Y[:, None]) / dy
            total = self.node_weights.sum(1)
            moments = np.stack([(self.node_weights * p).sum(1) / total for p in (ex * ex, ey * ey, ex * ey)])
        else:
            m = SUBCELLS[0]
            moments = np.zeros((3, len(cells)))
            for mm, weight in ((m, 2.0), (m // 2, -1.0)):
                ex = np.repeat((np.arange(mm) + 0.5) / mm - 0.5, mm)
                ey = np.tile((np.arange(mm) + 0.5) / mm - 0.5, mm)
                Ws = self.subcells(mm)
                moments += (
                    weight
                    * np.stack(
                        [Ws @ (ex**2 + 1.0 / (12 * mm * mm)), Ws @ (ey**2 + 1.0 / (12 * mm * mm)), Ws @ (ex * ey)]
                    )
                    / Wn
                )
        mxx[near], myy[near], mxy[near] = moments
        sx, sy = mxx - 1.0 / 12.0, myy - 1.0 / 12.0
        bx = ((sx - xi) / 2.0, 1.0 - sx, (sx + xi) / 2.0)
        by = ((sy - eta) / 2.0, 1.0 - sy, (sy + eta) / 2.0)
        corner = (mxy - xi * eta) / 4.0
        self.beta = {}
        for p in (-1, 0, 1):
            for q in (-1, 0, 1):
                weight = bx[p + 1] * by[q + 1] + (p * q * corner if p and q else 0.0)
                self.beta[(p, q)] = np.where(mask, weight, 0.0)
        # the weights of the near set's cells, one row per stencil offset in ``beta``'s order
        self.beta_near = np.stack([bw[cells[:, 0], cells[:, 1]] for bw in self.beta.values()])
        self._spreading: tuple[sp.csr_matrix, sp.csr_matrix] | None = None
        self._near: list[tuple[tuple[int, int], np.ndarray, np.ndarray, tuple[np.ndarray, ...]]] | None = None

    def spreading(self) -> tuple[sp.csr_matrix, sp.csr_matrix]:
        """P and Pᵀ on the flattened grid (built once, shared by the blocks): row t of P holds the
        weights of the cells that spread onto cell t, row i of Pᵀ cell i's nine weights, both in
        ``beta``'s order, so that a product sums the terms in the order of a loop over ``beta``
        of shifted-array products (the same arithmetic, bitwise). Contact cells lie at least one
        cell inside the padded grid, so flat offsets p·ny + q never wrap a row."""
        import scipy.sparse as sp  # on first use, not at import (strip_cells' docstring)

        if self._spreading is None:
            nx, ny = self.grid.nx, self.grid.ny
            size = nx * ny
            shift = np.array([p * ny + q for p, q in self.beta])
            flat_mask = self.mask.ravel()
            cell = np.flatnonzero(flat_mask)
            weights = np.stack([bw.ravel()[cell] for bw in self.beta.values()], 1)  # (cells, 9)
            indptr = np.zeros(size + 1, dtype=np.int64)
            indptr[1:] = np.cumsum(np.where(flat_mask, len(shift), 0))
            gather = sp.csr_matrix((weights.ravel(), (cell[:, None] + shift).ravel(), indptr), shape=(size, size))
            # row t of P: column k the cell t − shift[k] (padded flat arrays sliced, no wrap)
            pad = ny + 1
            padded_mask = np.concatenate([np.zeros(pad, bool), flat_mask, np.zeros(pad, bool)])
            padded = [np.concatenate([np.zeros(pad), bw.ravel(), np.zeros(pad)]) for bw in self.beta.values()]
            window = [slice(pad - d, pad - d + size) for d in shift]
            valid = np.stack([padded_mask[w] for w in window], 1)  # (size, 9)
            values = np.stack([b[w] for b, w in zip(padded, window)], 1)[valid]
            target, k = np.nonzero(valid)
            indptr = np.zeros(size + 1, dtype=np.int64)
            indptr[1:] = np.cumsum(valid.sum(1))
            spread = sp.csr_matrix((values, target - shift[k], indptr), shape=(size, size))
            self._spreading = (spread, gather)
        return self._spreading

    def subcells(self, m: int) -> np.ndarray:
        """Sub-cell weights ∫w dA of the near set's cells on m × m sub-cells, shape (cells, m²)."""
        if m not in self._sub:
            (a, b), cells, g = self._axes, self.cells, self.grid
            if 2 * m in self._sub:  # sums of 2 × 2 blocks of the finer sub-cells (exact, cheaper)
                fine = self._sub[2 * m].reshape(len(cells), m, 2, m, 2)
                self._sub[m] = fine.sum(axis=(2, 4)).reshape(len(cells), m * m)
            else:
                e = np.arange(m + 1) / m - 0.5
                u = ((self._x[cells[:, 0], None] + e * g.dx) / a)[:, :, None]
                F = sphere_area(u, ((self._y[cells[:, 1], None] + e * g.dy) / b)[:, None, :])
                self._sub[m] = (a * b * (F[:, 1:, 1:] - F[:, :-1, 1:] - F[:, 1:, :-1] + F[:, :-1, :-1])).reshape(
                    len(cells), m * m
                )
        return self._sub[m]

    def near_pairs(self) -> list[tuple[tuple[int, int], np.ndarray, np.ndarray, tuple[np.ndarray, ...]]]:
        """The near field's cell pairs and their exact Galerkin integrals, for every block at once.

        Per offset (P, Q) ≥ (0, 0) within ``NEAR`` (the pair at (−P, −Q) is the transpose): the
        source and target indices into the near set (pairs with one cell in the band) and the
        integrals ∫∫ w k w of the kernels of ``BASE_INTEGRALS`` [length³, G = 1; a block's B is
        ``_combine`` of them / G]: "subcells", Σ_s Σ_s' W_s M_ss' W_s' on m × m sub-cells
        extrapolated in m (2 B_m − B_{m/2}); "edge", ``hpcontact.discretizations.singular_pairs`` (touching pairs
        through the source's ray potential, the others node against node). Computed once per
        grid and shared by the blocks."""
        if self._near is None:
            nx, ny = self.grid.nx, self.grid.ny
            index, in_band, near_cells = self.index, self.in_band, self.cells
            self._near = []
            for P in range(-NEAR, NEAR + 1):
                for Q in range(-NEAR, NEAR + 1):
                    if (P, Q) < (0, 0):
                        continue  # the transpose of (−P, −Q)
                    target = near_cells + (P, Q)
                    ok = (target[:, 0] >= 0) & (target[:, 0] < nx) & (target[:, 1] >= 0) & (target[:, 1] < ny)
                    src = np.flatnonzero(ok)
                    tgt = index[target[src, 0], target[src, 1]]
                    keep = tgt >= 0
                    src, tgt = src[keep], tgt[keep]
                    keep = in_band[src] | in_band[tgt]
                    src, tgt = src[keep], tgt[keep]
                    if src.size:
                        integrals = (
                            self._edge_pairs(P, Q, src, tgt)
                            if self.near_field == "edge"
                            else self._subcell_pairs(P, Q, src, tgt)
                        )
                        self._near.append(((P, Q), src, tgt, integrals))
        return self._near

    def _subcell_pairs(self, P: int, Q: int, src: np.ndarray, tgt: np.ndarray) -> tuple[np.ndarray, ...]:
        """``near_pairs``' integrals on sub-cells (2 B_m − B_{m/2}) [length³]."""
        ratio = self.grid.dy / self.grid.dx
        mm = SUBCELLS[0] if max(abs(P), abs(Q)) <= 1 else SUBCELLS[1]
        B = {kind: np.zeros(src.size) for kind in BASE_INTEGRALS}
        for level, weight in ((mm, 2.0), (mm // 2, -1.0)):
            Ws = self.subcells(level)
            Wt, Wsrc = Ws[tgt], Ws[src]
            for kind in BASE_INTEGRALS:
                B[kind] += weight * np.einsum("pa,pa->p", Wt @ _subcell_block(kind, ratio, level, P, Q), Wsrc)
        return tuple(B[kind] / self.grid.dx for kind in BASE_INTEGRALS)  # M is in units dx = 1

    def _edge_pairs(self, P: int, Q: int, src: np.ndarray, tgt: np.ndarray) -> tuple[np.ndarray, ...]:
        """``near_pairs``' integrals by the edge quadrature (``hpcontact.discretizations.singular_pairs``) [length³]."""
        if max(abs(P), abs(Q)) <= 1:
            return singular_pairs.touching_integrals(
                self.nodes[tgt], self.node_weights[tgt], *self.rects[:, src], *self._axes
            )
        nodes, rule = self.separated_rule
        return singular_pairs.separated_integrals(nodes[tgt], rule[tgt], nodes[src], rule[src])

    def system(self, block: str) -> BlockSystem:
        """The Galerkin system Ã s = u₀ of ``block`` ("xx", "yy" or "zz") on these cells."""
        if block not in BLOCKS:
            raise InputError("block", f"one of {BLOCKS}", block)
        return BlockSystem(self, block)

    def force(self, s: np.ndarray) -> float:
        """Resultant Σ gᵢ Wᵢ = Σ sᵢ dx dy of the solution s (force per unit displacement u₀ = 1)."""
        return float(s.sum() * self.grid.cell_area)


class BlockSystem:
    """Ã = Pᵀ K* P + N for one block: ``apply(s)`` on arrays (1, nx, ny), ``diagonal`` of Ã
    (for the preconditioner), ``mask`` the unknowns."""

    def __init__(self, cells: SingularCells, block: str) -> None:
        import scipy.sparse as sp  # on first use, not at import (strip_cells' docstring)

        self.cells, self.grid, self.mask, self.beta = cells, cells.grid, cells.mask, cells.beta
        material, mask = cells.material, cells.mask
        nx, ny, dx, dy = self.grid.nx, self.grid.ny, self.grid.dx, self.grid.dy
        nu, Wn, near_cells = material.nu, cells.Wn, cells.cells

        Kstar = double_average_kernel(material, nx, ny, dx, dy, block)
        self.operator = ConvolutionOperator(nx, ny, block[0], {block: kernel_spectrum(Kstar, padded_shape(nx, ny))})

        # near-field correction: exact Galerkin entries minus what the far field gives them
        rows, cols, vals = [], [], []
        for (P, Q), src, tgt, integrals in cells.near_pairs():
            B = _combine(nu, block, *integrals) / material.G
            cs, ct = near_cells[src], near_cells[tgt]
            exact = dx * dy * B / (Wn[tgt] * Wn[src])
            far = self._far(Kstar, P, Q, cells.beta_near[:, tgt], cells.beta_near[:, src])
            flat_s, flat_t = cs[:, 0] * ny + cs[:, 1], ct[:, 0] * ny + ct[:, 1]
            rows.append(flat_t)
            cols.append(flat_s)
            vals.append(exact - far)
            if (P, Q) != (0, 0):
                rows.append(flat_s)
                cols.append(flat_t)
                vals.append(exact - far)
        self.near = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nx * ny, nx * ny)
        )
        # far part of the diagonal: βᵀ K₉ β per cell, K₉ the far kernel between the 3 × 3 stencil offsets
        stencil = list(self.beta)
        K9 = np.array([[Kstar[nx - 1 + p - pp, ny - 1 + q - qq] for pp, qq in stencil] for p, q in stencil])
        beta = np.stack([bw[mask] for bw in self.beta.values()])  # (9, contact cells)
        self.diagonal = np.zeros((nx, ny))
        self.diagonal[mask] = np.einsum("ac,ac->c", K9 @ beta, beta) + self.near.diagonal().reshape(nx, ny)[mask]

    def _far(self, Kstar: np.ndarray, P: int, Q: int, bt: np.ndarray, bs: np.ndarray) -> np.ndarray:
        """(Pᵀ K* P) between target cells (stencil weights ``bt``, shape (9, pairs)) and source
        cells (``bs``) at offset (P, Q): Σ over both stencils of bt · bs · K*, summed in the
        order of the stencil loops (the same arithmetic as a loop over pairs of ``beta``)."""
        g = self.grid
        stencil = list(self.beta)
        far = np.zeros(bt.shape[1])
        for a, (p, q) in enumerate(stencil):
            wt = bt[a]
            for b, (pp, qq) in enumerate(stencil):
                far += wt * bs[b] * Kstar[g.nx - 1 + P + p - pp, g.ny - 1 + Q + q - qq]
        return far

    def spread(self, s: np.ndarray) -> np.ndarray:
        """Grid tractions P s: each cell's share on the 3 × 3 cell centres around it."""
        return (self.cells.spreading()[0] @ s.ravel()).reshape(s.shape)

    def gather(self, u: np.ndarray) -> np.ndarray:
        """Pᵀ u: each cell's w-weighted mean of the grid displacements (moments matched)."""
        return (self.cells.spreading()[1] @ u.ravel()).reshape(u.shape)

    def apply(self, s: np.ndarray) -> np.ndarray:
        """Ã s for s of shape (1, nx, ny) supported on ``mask``."""
        nx, ny = self.grid.nx, self.grid.ny
        far = self.gather(self.operator.apply(self.spread(s[0])[None])[0])
        return (far + (self.near @ s[0].ravel()).reshape(nx, ny))[None]
