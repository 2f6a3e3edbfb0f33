r"""Galerkin integrals of singular cells' near field, by quadrature that follows the edge.

For cells Ωᵢ = cellᵢ ∩ Ω of the ellipse Ω: x²/a² + y²/b² ≤ 1 with the weight
w = (1 − x²/a² − y²/b²)^(−1/2) (``hpcontact.discretizations.singular_cells``), the pair integrals

    I_k(j, i) = ∫_Ωⱼ ∫_Ωᵢ w(x) k(x − y) w(y) dy dx,     k = 1/r  or  (x₁ − y₁)²/r³

(Love's two base kernels, Johnson 1985 eq. 3.19–3.20) [length³]. Two quadratures, both without
sub-cells, so that nothing in them is first order in a sub-cell size:

Outer (every cell): the hemisphere variables. With u = x/a, v = y/b = ρ(cos φ, sin φ) and
ρ = sin θ, w dA = a b sin θ dθ dφ: the edge singularity becomes the smooth end θ = π/2 (the
area element of the unit hemisphere over the disc; Galin 1953, Johnson 1985 §3.7). The cell is
cut by the rays from the centre at its corners and at the points where its sides cross the
edge; on each piece, Gauss–Legendre in φ after φ = φ₀ + Δ(1 − cos πs)/2 (the edge crossings
make θ's limits go as √(φ − φ₀): the map makes them smooth) and in θ between the cell's sides, with the same map (the potential's x log x at shared sides).
The node weights sum to W = ∫_Ωᵢ w dA (closed form ``singular_cells.sphere_area``) within
2.5e-8 … 1.5e-4 relative at q = 6 Gauss points, 6e-12 … 1.1e-5 at q = 8; the worst is a cell
with the centre inside (every direction φ; near sets do not reach the centre on the grids
``accuracy`` uses), an ordinary full cell 1e-5 at q = 6.

Inner, for touching pairs (offset ≤ 1 cell, where k is singular on the closure of both): the
source's potential at each outer node x in polar coordinates about x,

    V_k(x) = ∫ κ(ψ) R(x, ψ) dψ,     κ = 1 or cos²ψ,     R = ∫ w(x + r e_ψ) dr over the ray's chord in Ωᵢ,

(r dr dψ / r: the 1/r singularity cancels), where the chord integral is in closed form: along
the ray 1 − u² − v² = A − 2Br − Cr², so ∫ dr (A − 2Br − Cr²)^(−1/2) = arcsin((B + Cr)/√D)/√C,
D = B² + AC. ψ is cut at the directions of the source's corners and edge crossings (√ ends, the
same cosine map) and graded around the two directions tangent to the level curve of w through
x (B = 0), where the chord to the edge changes over an angle ~√(AC)/|∇B|. Checks: Σᵢ V(x) over
every cell of a disc is π² (1/r) and π²/2 (x²/r³) at every x inside (Galin's uniform
displacement), met to 3.8e-6 at q = 6 and 4.4e-7 at q = 8 on an 8 × 8 grid (points down to
0.999 of the radius); an ellipse's sum is 2π b K(1 − b²/a²) everywhere, to 8e-6 and 4e-7.

Separated pairs (offset ≥ 2 cells; k smooth over both): outer nodes against the source's outer
nodes.

Error: the pair sums over every cell pair of an 8 × 8 disc, Σ I₁ = 2π³ and Σ I_xx = π³ (the
energy of Galin's and Mindlin's traction), are met to 4.0e-6 at q = 6 and 4.2e-8 at q = 8, the
ellipse 0.7's to 4.1e-6 and 5.6e-8 (``tests/discretizations/test_singular_pairs.py``); in K on singular cells,
q = 6 → 8 moved K_xx by 8e-8 at b/a 0.5, 256 × 128. Separated pairs' interpolatory rule
(``SEPARATED_POINTS`` = 6) against the ray quadrature: 1e-5 (I₁) at q = 6 on cells two apart.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "POINTS",
    "SEPARATED_POINTS",
    "cell_nodes",
    "interpolatory_rule",
    "ray_potential",
    "separated_integrals",
    "touching_integrals",
]

POINTS = 6  # Gauss points per piece and direction (q) of the cells' nodes: the module docstring's error figures
RAY_POINTS = 6  # Gauss points per piece of the directions ψ about a node
SEPARATED_POINTS = 6  # Gauss points per side of the interpolatory rule of pairs at least one cell apart
_GRADING = (2.0, 8.0)  # tangent-direction breakpoints at these multiples of the transition width
_CHUNK_ELEMENTS = 250_000  # rays per vectorized block (~30 arrays of this many float64: ~60 MB)
_ROWS = 20_000  # points whose direction pieces are formed at once (~25 arrays of 23 pieces each: ~90 MB)


def _cosine_gauss(lo: np.ndarray, hi: np.ndarray, q: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of q-point Gauss–Legendre on [lo, hi] after x = lo + (hi − lo)(1 − cos πs)/2
    (s ∈ [0, 1]): integrands with square-root ends become smooth."""
    t, w = np.polynomial.legendre.leggauss(q)
    s = 0.5 * (t + 1.0)
    d = (hi - lo)[..., None]
    return lo[..., None] + d * (0.5 * (1.0 - np.cos(math.pi * s))), d * (0.25 * math.pi * np.sin(math.pi * s) * w)


def _compact(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pieces of zero length last along the final axis; columns that no row needs dropped."""
    empty = hi <= lo
    order = np.argsort(empty, axis=-1, kind="stable")
    keep = max(int((~empty).sum(-1).max(initial=0)), 1)
    return np.take_along_axis(lo, order, -1)[..., :keep], np.take_along_axis(hi, order, -1)[..., :keep]


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _corners(X1, X2, Y1, Y2) -> np.ndarray:
    return np.stack(
        [np.stack([X1, Y1], -1), np.stack([X2, Y1], -1), np.stack([X2, Y2], -1), np.stack([X1, Y2], -1)], -2
    )


def _edge_crossings(X1, X2, Y1, Y2, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """The points where the sides of rectangles [X1, X2] × [Y1, Y2] cross the ellipse: (…, 8, 2)
    and whether each lies on its side (…, 8). Sides x = X (y = Y the same with the axes swapped)
    meet it at y = ±b √(1 − X²/a²)."""
    points, valid = [], []
    for sides, (lo, hi), (along, across), swap in (
        ((X1, X2), (Y1, Y2), (a, b), False),
        ((Y1, Y2), (X1, X2), (b, a), True),
    ):
        for side in sides:
            u = side / along
            half = across * np.sqrt(np.maximum(1.0 - u * u, 0.0))
            for other in (-half, half):
                points.append(np.stack([other, side] if swap else [side, other], -1))
                valid.append((np.abs(u) < 1.0) & (other > lo) & (other < hi))
    return np.stack(points, -2), np.stack(valid, -1)


def _slab(px, py, ex, ey, X1, X2, Y1, Y2) -> tuple[np.ndarray, np.ndarray]:
    """The parameter range [t_lo, t_hi] of the line p + t e inside the rectangle (broadcast). A
    direction component that is exactly zero is replaced by 1e-300: the bounds become ±1e300 times
    the side distances, which is what the parallel line's inside/outside test gives."""
    lo_t, hi_t = None, None
    for p, e, lo, hi in ((px, ex, X1, X2), (py, ey, Y1, Y2)):
        inverse = 1.0 / np.where(e == 0.0, 1e-300, e)
        t1, t2 = (lo - p) * inverse, (hi - p) * inverse
        low, high = np.minimum(t1, t2), np.maximum(t1, t2)
        lo_t = low if lo_t is None else np.maximum(lo_t, low)
        hi_t = high if hi_t is None else np.minimum(hi_t, high)
    return lo_t, hi_t


def cell_nodes(
    X1: np.ndarray, X2: np.ndarray, Y1: np.ndarray, Y2: np.ndarray, a: float, b: float, q: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature nodes of ∫_Ωᵢ f w dA for cells [X1, X2] × [Y1, Y2] (arrays (N,)) of the ellipse with semi-axes a, b: points (N, K, 2) [length] and weights (N, K)
    [area], zero-weight padding where a cell needs fewer nodes (module docstring, "Outer")."""
    q = POINTS if q is None else q
    X1, X2, Y1, Y2 = (np.asarray(Z, dtype=float) for Z in (X1, X2, Y1, Y2))
    corners = _corners(X1, X2, Y1, Y2)
    crossings, valid = _edge_crossings(X1, X2, Y1, Y2, a, b)
    reference = np.arctan2((Y1 + Y2) / b, (X1 + X2) / a)

    def angle(P: np.ndarray) -> np.ndarray:
        return _wrap(np.arctan2(P[..., 1] / b, P[..., 0] / a) - reference[:, None])

    at_corners = angle(corners)
    centred = (X1 <= 0.0) & (X2 >= 0.0) & (Y1 <= 0.0) & (Y2 >= 0.0)  # the cell sees every direction
    first = np.where(centred, -math.pi, at_corners.min(-1))
    last = np.where(centred, math.pi, at_corners.max(-1))
    breaks = np.concatenate([at_corners, np.where(valid, angle(crossings), first[:, None])], -1)
    breaks = np.clip(breaks, first[:, None], last[:, None])
    breaks = np.sort(np.concatenate([breaks, first[:, None], last[:, None]], -1), -1)
    lo, hi = _compact(breaks[:, :-1], breaks[:, 1:])
    phi, w_phi = _cosine_gauss(lo, hi, q)
    phi = phi + reference[:, None, None]
    du, dv = np.cos(phi), np.sin(phi)
    t_in, t_out = _slab(0.0, 0.0, du, dv, *(Z[:, None, None] / s for Z, s in ((X1, a), (X2, a), (Y1, b), (Y2, b))))
    rho_in, rho_out = np.clip(t_in, 0.0, 1.0), np.clip(t_out, 0.0, 1.0)
    theta_in = np.arcsin(rho_in)
    theta_out = np.arcsin(np.maximum(rho_out, rho_in))
    theta, w_theta = _cosine_gauss(theta_in, theta_out, q)
    rho = np.sin(theta)
    points = np.stack([a * rho * du[..., None], b * rho * dv[..., None]], -1)
    weights = a * b * rho * w_theta * w_phi[..., None]
    N = X1.shape[0]
    points, weights = points.reshape(N, -1, 2), weights.reshape(N, -1)
    used = weights.any(0)
    return points[:, used], weights[:, used]


def _direction_pieces(
    px: np.ndarray, py: np.ndarray, X1: np.ndarray, X2: np.ndarray, Y1: np.ndarray, Y2: np.ndarray, a: float, b: float
) -> tuple[np.ndarray, np.ndarray]:
    """The pieces [lo, hi] of the directions ψ about points (px, py) (R,) over which the chord
    through the source cell (R,) is smooth (module docstring, "Inner"): (R, M), unused pieces
    empty (lo = hi) and last."""
    inside = (px >= X1) & (px <= X2) & (py >= Y1) & (py <= Y2)
    reference = np.arctan2(0.5 * (Y1 + Y2) - py, 0.5 * (X1 + X2) - px)

    def angle(P: np.ndarray) -> np.ndarray:  # P (R, M, 2) → (R, M)
        return _wrap(np.arctan2(P[..., 1] - py[:, None], P[..., 0] - px[:, None]) - reference[:, None])

    at_corners = angle(_corners(X1, X2, Y1, Y2))
    first = np.where(inside, -math.pi, at_corners.min(-1))
    last = np.where(inside, math.pi, at_corners.max(-1))
    crossings, valid = _edge_crossings(X1, X2, Y1, Y2, a, b)
    at_crossings = np.where(valid, angle(crossings), first[:, None])
    # directions tangent to the level curve of w through x (B(ψ) = 0), graded by the transition
    # width, where the edge is nearer than the source cell's size (elsewhere the chord is smooth)
    gu, gv = px / a**2, py / b**2
    A = np.maximum(1.0 - (px / a) ** 2 - (py / b) ** 2, 0.0)
    near_edge_of = 2.0 * np.hypot(X2 - X1, Y2 - Y1)
    tangents = []
    for base in (np.arctan2(gu, -gv), np.arctan2(-gu, gv)):
        C = np.cos(base) ** 2 / a**2 + np.sin(base) ** 2 / b**2
        graded = np.sqrt(A / C) < near_edge_of
        width = np.where(graded, np.sqrt(A * C) / np.maximum(np.hypot(gu, gv), 1e-300), 0.0)
        tangents += [np.where(graded, base, first + reference)]
        tangents += [base + sign * g * width for g in _GRADING for sign in (-1.0, 1.0)]
    at_tangents = _wrap(np.stack(tangents, -1) - reference[:, None])
    breaks = np.concatenate([at_corners, at_crossings, at_tangents], -1)
    breaks = np.clip(breaks, first[:, None], last[:, None])
    breaks = np.sort(np.concatenate([breaks, first[:, None], last[:, None]], -1), -1)
    lo, hi = breaks[:, :-1] + reference[:, None], breaks[:, 1:] + reference[:, None]
    order = np.argsort(hi <= lo, axis=-1, kind="stable")
    return np.take_along_axis(lo, order, -1), np.take_along_axis(hi, order, -1)


def _chords(
    px: np.ndarray,
    py: np.ndarray,
    X1: np.ndarray,
    X2: np.ndarray,
    Y1: np.ndarray,
    Y2: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    a: float,
    b: float,
    q: int,
) -> tuple[np.ndarray, np.ndarray]:
    """(V₁, V_xx) at rows of points (R,) from their direction pieces (R, M): the chord integrals of
    w in closed form (module docstring), Gauss in ψ after the cosine map."""
    psi, w_psi = _cosine_gauss(lo, hi, q)  # (R, M, q)
    ex, ey = np.cos(psi), np.sin(psi)
    col = (slice(None), None, None)
    px, py = px[col], py[col]
    t_lo, t_hi = _slab(px, py, ex, ey, X1[col], X2[col], Y1[col], Y2[col])
    B = px * ex / a**2 + py * ey / b**2
    C = ex**2 / a**2 + ey**2 / b**2
    D = B * B + (1.0 - (px / a) ** 2 - (py / b) ** 2) * C
    root = np.sqrt(np.maximum(D, 0.0))
    lo_r = np.maximum(np.maximum(t_lo, 0.0), (-B - root) / C)
    hi_r = np.minimum(t_hi, (-B + root) / C)
    chord = (hi_r > lo_r) & (D > 0.0)
    safe = np.where(root > 0.0, root, 1.0)
    R = (
        np.where(
            chord,
            (
                np.arcsin(np.clip((B + C * hi_r) / safe, -1.0, 1.0))
                - np.arcsin(np.clip((B + C * lo_r) / safe, -1.0, 1.0))
            )
            / np.sqrt(C),
            0.0,
        )
        * w_psi
    )
    return R.sum((-1, -2)), (R * ex**2).sum((-1, -2))


def _potential_rows(
    px: np.ndarray,
    py: np.ndarray,
    X1: np.ndarray,
    X2: np.ndarray,
    Y1: np.ndarray,
    Y2: np.ndarray,
    a: float,
    b: float,
    q: int,
) -> tuple[np.ndarray, np.ndarray]:
    """(V₁, V_xx) at rows (R,), ``_ROWS`` at a time: within each, rows sorted by their number of
    direction pieces and taken in blocks only as wide as their widest row (most rows need half
    the widest)."""
    V1, Vxx = np.zeros(px.shape), np.zeros(px.shape)
    for outer in range(0, px.size, _ROWS):
        rows_here = np.arange(outer, min(outer + _ROWS, px.size))
        lo, hi = _direction_pieces(
            px[rows_here], py[rows_here], X1[rows_here], X2[rows_here], Y1[rows_here], Y2[rows_here], a, b
        )
        count = (hi > lo).sum(-1)
        order = np.argsort(count, kind="stable")
        block = _rows_per_block(lo.shape[1] * q)
        for start in range(0, order.size, block):
            part = order[start : start + block]
            width = max(int(count[part].max(initial=0)), 1)
            rows = rows_here[part]
            V1[rows], Vxx[rows] = _chords(
                px[rows], py[rows], X1[rows], X2[rows], Y1[rows], Y2[rows], lo[part, :width], hi[part, :width], a, b, q
            )
    return V1, Vxx


def ray_potential(
    points: np.ndarray,
    X1: np.ndarray,
    X2: np.ndarray,
    Y1: np.ndarray,
    Y2: np.ndarray,
    a: float,
    b: float,
    q: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(V₁, V_xx)(x) = ∫_Ωᵢ w(y) (1, (x₁ − y₁)²/r²)/r dy at points (N, K, 2) inside the ellipse,
    source cell i = [X1, X2] × [Y1, Y2] per row (N,): two arrays (N, K) [length] (module
    docstring, "Inner")."""
    q = RAY_POINTS if q is None else q
    N, K = points.shape[:2]
    rect = [np.repeat(np.asarray(Z, dtype=float), K) for Z in (X1, X2, Y1, Y2)]
    V1, Vxx = _potential_rows(points[..., 0].ravel(), points[..., 1].ravel(), *rect, a, b, q)
    return V1.reshape(N, K), Vxx.reshape(N, K)


def _rows_per_block(per_row: int) -> int:
    return max(1, _CHUNK_ELEMENTS // max(per_row, 1))


def touching_integrals(
    points: np.ndarray,
    weights: np.ndarray,
    X1: np.ndarray,
    X2: np.ndarray,
    Y1: np.ndarray,
    Y2: np.ndarray,
    a: float,
    b: float,
    q: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(I₁, I_xx) of pairs whose target nodes are ``points``/``weights`` (N, K, 2)/(N, K) and whose
    source cells are [X1, X2] × [Y1, Y2] (N,): Σ weights · V (``ray_potential``) over the nodes
    of non-zero weight [length³]."""
    q = RAY_POINTS if q is None else q
    pair, node = np.nonzero(weights)
    V1, Vxx = _potential_rows(
        points[pair, node, 0],
        points[pair, node, 1],
        *(np.asarray(Z, dtype=float)[pair] for Z in (X1, X2, Y1, Y2)),
        a,
        b,
        q,
    )
    w = weights[pair, node]
    N = weights.shape[0]
    return np.bincount(pair, w * V1, minlength=N), np.bincount(pair, w * Vxx, minlength=N)


def separated_integrals(
    target_points: np.ndarray, target_weights: np.ndarray, source_points: np.ndarray, source_weights: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(I₁, I_xx) of pairs of cells at least one cell apart: both cells' outer nodes (N, K, 2),
    weights (N, K) [length³]."""
    N = target_points.shape[0]
    I1, Ixx = np.zeros(N), np.zeros(N)
    rows = _rows_per_block(target_points.shape[1] * source_points.shape[1])
    for start in range(0, N, rows):
        part = slice(start, start + rows)
        d = target_points[part, :, None, :] - source_points[part, None, :, :]
        r2 = (d * d).sum(-1)
        inv = 1.0 / np.sqrt(np.where(r2 > 0.0, r2, 1.0))
        ww = target_weights[part, :, None] * source_weights[part, None, :]
        I1[part] = (ww * inv).sum((1, 2))
        Ixx[part] = (ww * d[..., 0] ** 2 * inv**3).sum((1, 2))
    return I1, Ixx


def interpolatory_rule(
    X1: np.ndarray,
    X2: np.ndarray,
    Y1: np.ndarray,
    Y2: np.ndarray,
    points: np.ndarray,
    weights: np.ndarray,
    p: int = SEPARATED_POINTS,
) -> tuple[np.ndarray, np.ndarray]:
    """A p × p rule per cell for ∫_Ωᵢ f w dA with f smooth over the whole rectangle: nodes the tensor
    Gauss points of [X1, X2] × [Y1, Y2], weights ∫ w ℓ_k dA of their Lagrange polynomials ℓ_k
    (from the fine ``cell_nodes`` ``points``/``weights``), so that it is exact for polynomials of
    degree < p in each coordinate. Returns points (N, p², 2), weights (N, p²)."""
    t = np.polynomial.legendre.leggauss(p)[0]
    basis = []
    for lo, hi, coordinate in ((X1, X2, points[..., 0]), (Y1, Y2, points[..., 1])):
        s = (2.0 * coordinate - (lo + hi)[:, None]) / (hi - lo)[:, None]  # node in [−1, 1]
        ell = np.ones(s.shape + (p,))
        for k in range(p):
            for m in range(p):
                if m != k:
                    ell[..., k] *= (s - t[m]) / (t[k] - t[m])
        basis.append(ell)
    rule = np.einsum("nk,nki,nkj->nij", weights, basis[0], basis[1]).reshape(len(X1), p * p)
    gx = 0.5 * (X1 + X2)[:, None] + 0.5 * (X2 - X1)[:, None] * t
    gy = 0.5 * (Y1 + Y2)[:, None] + 0.5 * (Y2 - Y1)[:, None] * t
    nodes = np.stack(np.broadcast_arrays(gx[:, :, None], gy[:, None, :]), -1).reshape(len(X1), p * p, 2)
    return nodes, rule
