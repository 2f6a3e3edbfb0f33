r"""Strip cells: a slender contact as strips across which the traction has its slender-body profile.

Why
---
A rectangle of aspect b/a = 1e-8 on coverage-weighted cells (``hpcontact.discretizations.boundary_cells``) needs
cells 10⁸ times longer than wide and converges as h + h ln h: at 1024 × 256, the end of the
estimator's calibration, ``--accuracy`` estimates 5.6e-6 … 6.9e-6 (docs/explanation/accuracy.md,
"Square and rectangle b/a = 1e-8, against finer grids"); thin ellipses stall there at 2.7e-6 …
1.3e-5. Across such a contact nothing varies but the edge singularity, so the traction's shape across is known and only its size along x is
unknown.

The discretization
------------------
The contact |x| ≤ a, |y| ≤ b(x) (a rectangle: b constant; an ellipse: b(x) = b₀ √(1 − x²/a²))
is cut across its length into n strips I_i = [x_{i−1}, x_i]. On strip i the traction along the
load direction α (x, y or z) is

    p_α(x, y) = f_i / (π √(b(x)² − y²)),                                                  (1)

a line load f_i [N/m] spread across the width as the rigid flat punch's plane-strain traction
(Johnson 1985, ch. 2): the slender-body (strip-theory) limit of the bonded punch, in which every
section far from the ends is a plane problem across the width, and the exact section of
Galin's and Mindlin's ellipse traction (p ∝ (b(x)² − y²)^(−½) at every x). Testing with the same
functions and a rigid displacement δ along α gives the symmetric positive definite Galerkin
system

    Σ_j B_ij f_j = δ |I_i|,        B_ij = ∫_{I_i} ∫_{I_j} H_α(x − x') dx' dx,             (2)
    K_αα = Σ_i f_i |I_i| / δ,

with H_α = ⟨G_α(s, y − y')⟩ the point-force displacement averaged over y and y' drawn
independently from the profile (1) at x and x'; s = x − x'. For an ellipse, Galin's and
Mindlin's traction is (1) with f constant, which the strips contain: there K's error is that of
the integrals B_ij alone (below) (Boussinesq and Cerruti, Johnson 1985 §3.2; r² = s² + t²):

    G_z = (1 − ν)/(2πG r),   G_x = [(1 − ν)/r + ν s²/r³]/(2πG),   G_y = [1/r − ν s²/r³]/(2πG);

the cross terms (ν s t/r³) average to zero, t being symmetric. K is in N/m for G in Pa and
lengths in the shape's unit (a = 1).

The averages
------------
t = y − y' has the density (two arcsine laws on [−b, b]; the integral between the middle roots
of (1 − u²)(1 − (u − τ)²), Byrd & Friedman 1971, 256.00)

    ρ(t) = K(m) / (π² b),   m = 1 − t²/(4b²),   |t| < 2b,                                 (3)

with K the complete elliptic integral of the first kind (``scipy.special.ellipkm1`` of 1 − m);
its moments are ⟨t²⟩ = b², ⟨t⁴⟩ = 9b⁴/4, ⟨t⁶⟩ = 25b⁶/4, and ⟨ln|t|⟩ = ln(b/2) (the segment's
logarithmic capacity b/2). Averages are Gauss–Legendre sums over τ = |t|/(2b) ∈ (0, 1] on
panels graded geometrically toward τ = 0 (``TAU_RATIO``, ``TAU_POINTS``, ``TAU_PANELS``: K's
logarithm there and the kernels' scale |s| are both resolved; ⟨1⟩ = 1 and the moments to
≤ 3e-15, ``tests/discretizations/test_strip_cells.py``).

B_ij is exact through double antiderivatives in s (F'' = the kernel, F = F' = 0 at s = 0):

    F_1(s, t) = s asinh(s/|t|) − r + |t|,         F_1'' = 1/r,
    F_x(s, t) = s asinh(s/|t|) − 2r + 2|t|,       F_x'' = s²/r³,                          (4)
    ∫_{I_i}∫_{I_j} ⟨k⟩ = −[A(x_i − x'_j) − A(x_i − x'_{j−1}) − A(x_{i−1} − x'_j) + A(x_{i−1} − x'_{j−1})],

A(s) = ⟨F(|s|, t)⟩ — used for every pair closer than ``NEAR_GAP`` strip lengths or
``SERIES_REACH`` half-widths (the four terms are O(s ln s) and their sum O(h²/s), so far pairs
would lose digits; a tiny end strip near a long one still loses some, ~1e-10 of the entry:
docs/validation.md §"Strip cells"). Farther
pairs use a ``FAR_POINTS`` × ``FAR_POINTS`` Gauss product rule on the moment series::

    ⟨1/r⟩ = |s|⁻¹ [1 − ⟨t²⟩/(2s²) + 3⟨t⁴⟩/(8s⁴) − 5⟨t⁶⟩/(16s⁶)],
    ⟨s²/r³⟩ = |s|⁻¹ [1 − 3⟨t²⟩/(2s²) + 15⟨t⁴⟩/(8s⁴) − 35⟨t⁶⟩/(16s⁶)]                     (5)

(binomial series of (1 + t²/s²)^(−½) and ^(−3/2); the next terms are below 5e-15 of the first
where |s| ≥ ``SERIES_REACH`` b: (315/128)·⟨t⁸⟩/s⁸ ≤ 5e-15, ⟨t⁸⟩ = 19.1 b⁸), with the moments of
the two widths b(x), b(x') at the Gauss points.

A width that varies (the ellipse)
---------------------------------
(4) needs one width for the four corners of a pair (their O(s ln(s/b)) terms cancel only then):
a near pair of separate or touching strips takes b at the middle of its gap, and a strip with
itself is integrated in m = (x + x')/2 with b(m) (``self_integrals``; one width for a whole self
pair left 3 % of the tip strip's entry). What one width leaves out is added back: with b₁ = b(x),
b₂ = b(x') and the pair's single width b,

    ΔB_ij = ∫_{I_i}∫_{I_j} [⟨k⟩(s; b₁, b₂) − ⟨k⟩(s; b)] dx' dx                              (7)

(``width_corrections``), where ⟨k⟩(s; b₁, b₂) averages over y, y' from the profiles of two
widths, exactly by the density (6) (``two_width_averages``). Where the widths differ little on
the scale of s (|b₁ − b₂| ≤ 2 ``SLOPE_LIMIT`` |s|) the bracket is expanded to second order in
ε = (b₁ − b₂)/2 about b̄ = (b₁ + b₂)/2: ⟨k⟩(s; b̄) − ⟨k⟩(s; b) + ε² q(|s|/b̄)/b̄³ with
q = ½ ∂²⟨k⟩/∂ε² tabulated once (``_spread_table``: σ² q → −0.405, −0.810 for σ → 0, the series'
−1/(2σ³), −3/(2σ³) for σ → ∞), and the expansion leaves ≈ 2(ε/s)² of the bracket; elsewhere
(near the tips, where b' → ∞, and nearly everywhere on a wide ellipse) the exact average is
used, and beyond |s| = ``SPREAD_REACH`` b̄ the series (5) with both widths
(``width_difference``).

Why: the exact f is constant, so to first order δK/K = −Σ δB_ij / Σ B_ij, the single widths' error
summed over the plane; a single width per pair leaves an error of order (b/a)² ln(a/b), which
fails where the strips are not slender. With (7) the strips of an ellipse are exact but for
their integrals at every aspect, slender or not — they contain Galin's and Mindlin's traction
whatever b/a, and nothing of the slender-body limit is used — and what is left is measured
against the closed forms (``benchmarks/strip_calibration.py``; docs/validation.md §"Ellipses
against Mindlin and Galin"): at most 1.7e-8 relative in K_xx, K_yy, K_zz and K_a/K_b from
n = 64 on, falling with b/a to ~1e-12. The first grids' larger errors (the corrections'
quadrature on long strips) fall with n, where ``--accuracy``'s estimator sees them; the level
they settle at (the lean two-width rule, the expansion's remainder, the quadratures' floor) does
not, and ``model_error`` bounds it: min(``INTEGRALS_SLOPE`` · b/a, ``INTEGRALS_CAP``) +
``QUADRATURE_FLOOR``, three times the level. The exact two-width averages are the costly part
where nearly every near point needs them (wide ellipses: docs/performance.md §"Cost and memory
of `--accuracy`").

The mesh
--------
The line load varies fastest at the rectangle's ends (slowly, as 1/ln of the distance from the
end over b), so the strips are graded toward both ends, x_i = a sgn ξ (1 − (1 − |ξ|)^γ) with ξ
uniform on [−1, 1] and γ = ``GRADING`` (graded meshes for boundary elements at edges:
T. von Petersdorff and E. P. Stephan, Math. Methods Appl. Sci. 12 (1990) 229–249). With γ = 3
the differences of successive grids fall ~4× per halving of the strips (order 2), against
order ≈ 0.85 on a uniform mesh (docs/validation.md §"The mesh").

The model's own error
---------------------
(1) is exact only far from the ends: within a few b of an end the traction is that of the
3-D corner. Restricting the traction to (1) can only lower K: the Galerkin solution minimizes
the complementary energy ½⟨p, Gp⟩ − δ∫p over a subspace, so with exact integrals every strip
value is a lower bound of the true K (the model's limit too). Against coverage-weighted cells
the model's error is −(0.010 … 0.037) b/a at b/a = 0.01 and 0.003 and within their estimate
below (docs/validation.md §"The model's own error"). ``MODEL_ERROR`` = 0.1 b/a bounds it with a
margin of 2.7 over the largest, also for a slow growth in ln(a/b) down to b/a = 1e-12;
``--accuracy`` adds it to every estimate, and strips are used only where it is ≤ 1e-7
(``MAX_ASPECT`` = 1e-6). The 1e-8 rectangle's strip limit lies above every fit of the 2-D
reference of ``benchmarks/accuracy_reference.py``, as a lower bound must, so that reference is
low by at least that much.

scipy's ``special`` and ``linalg`` are imported where they are used, not with the module: every
``hpcontact`` process imports this module (each MPI rank, each command), most never build a strip
cell, and scipy's submodules beyond ``fft`` cost a process ~0.3 s of CPU to import (measured with
the same change in ``galin_ellipse``, ``singular_cells``, ``analytic`` and ``problems.slip.bodies``:
``python -c "import hpcontact.cli"``, 2026-11-29, 2-core VM under load 5).

References: K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985; P. F. Byrd and
M. D. Friedman, *Handbook of Elliptic Integrals for Engineers and Scientists*, 2nd ed., Springer,
1971; von Petersdorff and Stephan (above).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from hpcontact.errors import ConvergenceError
from hpcontact.geometry import Shape
from hpcontact.materials.isotropic import Isotropic

__all__ = [
    "BLOCKS",
    "GRADING",
    "MAX_ASPECT",
    "SUPPORTED_TEXT",
    "Outline",
    "StripCells",
    "difference_rule",
    "double_antiderivatives",
    "galerkin_integrals",
    "galerkin_matrix",
    "graded_edges",
    "model_error",
    "profile_averages",
    "series_averages",
    "stiffness",
    "supports",
    "two_width_averages",
    "width_corrections",
    "width_difference",
]

BLOCKS = ("xx", "yy", "zz")
GRADING = 3.0  # γ of the mesh x = a sgn ξ (1 − (1 − |ξ|)^γ) (order 2: docs/validation.md §"The mesh")
NEAR_GAP = 8.0  # pairs closer than this many strip lengths use the exact antiderivatives (4)
SERIES_REACH = 100.0  # … or closer than this many half-widths b: the series' next terms, (35/128, 315/128)·⟨t⁸⟩/s⁸ with ⟨t⁸⟩ = 19.1 b⁸, are ≤ 5e-15 beyond
FAR_POINTS = 4  # Gauss points per strip for far pairs: error ≤ (1/(2·NEAR_GAP))^(2·4) ≈ 2e-10 of an entry
TAU_RATIO, TAU_POINTS, TAU_PANELS = 0.3, 14, 36  # τ panels [0.3^(k+1), 0.3^k], 14 points each, down to 1.5e-19
COMPACT_POINTS = 20  # Gauss points of the measure (3) for |s| ≥ b (``double_antiderivatives``)
END_RATIO, END_POINTS, END_PANELS = 0.25, 10, 27  # self pairs: panels toward the strip ends, down to 0.25^27 = 5e-17
NARROW_LOW, NARROW_PANEL, NARROW_DEGREE = 1e-20, 2.0, 20  # the table of A' for σ = |s|/b < 1 (``_narrow_table``)
SPREAD_REACH = 10.0  # σ = |s|/b beyond which ``width_difference`` is the series (5) with both widths less that with one (its truncation there: ≤ 5e-8 of ⟨k⟩, of which a width difference keeps ~8 Δb/b)
SPREAD_LOW = 1e-6  # σ below which σ² q(σ) is held at its value there (already at its limits −0.405, −0.810: docs/validation.md §"Strip cells")
SLOPE_LIMIT = 0.005  # |b1 − b2| ≤ 2·this·|s|: the second-order expansion (7); beyond, the exact average (the expansion leaves ≈ 2(|b1 − b2|/2s)² of the difference; larger limits raised the settled error: docs/validation.md §"A width that varies")
TWO_WIDTH_FINE, TWO_WIDTH_LEAN = (
    (0.25, 24, 12),
    (0.2, 12, 8),
)  # ``two_width_averages``' rules (ratio, panels per half, points)
#: Rows per batch of ``two_width_averages`` and of the graded rule in ``double_antiderivatives``:
#: arrays of ≤ 1 MB that stay in cache (each row on its own, so the results do not depend on it;
#: 2048 rows took 10–20 % more CPU, measured 2026-11-29 on the 2-core VM under load 11).
TWO_WIDTH_CHUNK = 256
CORRECTION_RULE = (
    12,
    6,
    6,
    6,
)  # ``width_corrections``: geometric panels toward s = 0, Gauss points on each, points along (m; the shorter side of touching pairs), points per side of separated pairs
APART_CLOSE = 3.0  # separated pairs closer than this many strip lengths take CORRECTION_RULE's last entry, farther ones ``FAR_POINTS`` (Gauss' error ~ (3 + √8)^(−2·points) at a gap of one length, ~13^(−8) at three)
CORRECTION_FLOOR = 1e-4  # … graded toward s = 0 down to this many b (below, the difference is O(s²) ⟨k⟩)
FAR_CHUNK = 2**16  # far pairs per batch of the Gauss product rule (its arrays: ~800 B a pair, ~52 MB a batch)
#: Largest b/a of a rectangle on strips (``supports``); see ``MODEL_ERROR``.
MAX_ASPECT = 1e-6
#: Bound on the model's relative error in K_xx, K_yy, K_zz as a multiple of b/a (module docstring;
#: 2.7 times the largest against coverage-weighted cells, docs/validation.md §"The model's own error").
MODEL_ERROR = 0.1
#: Bound on what an ellipse's integrals leave of K (relative), ``INTEGRALS_SLOPE`` · b/a up to
#: ``INTEGRALS_CAP``: the level the error settles at with n, against Mindlin and Galin
#: (``benchmarks/strip_calibration.py``, module docstring), times 3.
INTEGRALS_SLOPE = 8e-7
INTEGRALS_CAP = 5e-8
#: What the quadratures leave of an ellipse's K where the widths' error vanishes (b/a ≤ 1e-6,
#: against Mindlin and Galin: docs/validation.md §"Ellipses against Mindlin and Galin"), times 3.
QUADRATURE_FLOOR = 5e-12


def supports(shape: Shape, material: object) -> bool:
    """Whether strip cells apply: an unturned rectangle of aspect b/a ≤ ``MAX_ASPECT`` or an
    unturned ellipse of any aspect on an isotropic half-space (H_α of (2) is the isotropic
    point-force solution averaged; an ellipse's strips contain its exact traction, module
    docstring)."""
    limit = {"rectangle": MAX_ASPECT, "ellipse": 1.0}.get(shape.name)
    return isinstance(material, Isotropic) and limit is not None and shape.angle_deg == 0.0 and shape.aspect <= limit


def model_error(shape: Shape) -> float:
    """Relative bound on what strips leave whatever their number: ``MODEL_ERROR`` · b/a for a
    rectangle (its ends); for an ellipse, whose strips contain the exact traction, what the
    integrals leave: min(``INTEGRALS_SLOPE`` · b/a, ``INTEGRALS_CAP``) + ``QUADRATURE_FLOOR``
    (module docstring)."""
    if shape.name == "rectangle":
        return MODEL_ERROR * shape.aspect
    return min(INTEGRALS_SLOPE * shape.aspect, INTEGRALS_CAP) + QUADRATURE_FLOOR


SUPPORTED_TEXT = (
    f"strip only for unturned ellipses and unturned rectangles of aspect <= {MAX_ASPECT:g}, isotropic, "
    "quantities tangential/normal"
)


@functools.lru_cache(maxsize=1)
def _tau_rule() -> tuple[np.ndarray, np.ndarray]:
    """Nodes τ ∈ (0, 1] and weights of ⟨g⟩ = (4/π²) ∫₀¹ K(1 − τ²) g(2bτ) dτ (density (3))."""
    from scipy.special import ellipkm1  # on first use, not at import (module docstring)

    x, w = np.polynomial.legendre.leggauss(TAU_POINTS)
    edges = TAU_RATIO ** np.arange(TAU_PANELS + 1, dtype=np.float64)
    lo, hi = edges[1:], edges[:-1]
    tau = (lo[:, None] + 0.5 * (hi - lo)[:, None] * (x + 1.0)).ravel()
    weight = (0.5 * (hi - lo)[:, None] * w).ravel()
    return tau, weight * (4.0 / math.pi**2) * ellipkm1(tau * tau)


def difference_rule(b: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes |t| and weights of ⟨g(|t|)⟩ over t = y − y', y and y' independent with the
    profile (1) on [−b, b] (density (3)); the weights sum to 1 − 2e-16."""
    tau, weight = _tau_rule()
    return 2.0 * b * tau, weight


def profile_averages(s: np.ndarray, b: float) -> tuple[np.ndarray, np.ndarray]:
    """⟨1/r⟩ and ⟨s²/r³⟩ at separations ``s`` along x [1/m] by the rule of (3) (every s)."""
    t, weight = difference_rule(b)
    s = np.abs(np.asarray(s, dtype=np.float64))[..., None]
    r = np.hypot(s, t)
    return (1.0 / r) @ weight, (s * s / r**3) @ weight


def series_averages(
    s: np.ndarray, b: np.ndarray | float, b2: np.ndarray | float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """⟨1/r⟩ and ⟨s²/r³⟩ from the moment series (5), for |s| ≥ ``SERIES_REACH`` max(b, b2), y and
    y' of half-widths b and b2 (default b): with P = b², Q = b2², ⟨t²⟩ = (P + Q)/2,
    ⟨t⁴⟩ = 3(P² + Q²)/8 + 3PQ/2, ⟨t⁶⟩ = 5(P³ + Q³)/16 + 45(P²Q + PQ²)/16 (⟨y²ᵏ⟩ = C(2k, k) b²ᵏ/4ᵏ)."""
    s = np.abs(np.asarray(s, dtype=np.float64))
    P = np.asarray(b, dtype=np.float64) ** 2
    Q = P if b2 is None else np.asarray(b2, dtype=np.float64) ** 2
    inv = 1.0 / (s * s)
    t2 = 0.5 * (P + Q) * inv
    t4 = (0.375 * (P * P + Q * Q) + 1.5 * P * Q) * inv * inv
    t6 = (0.3125 * (P**3 + Q**3) + 2.8125 * (P * P * Q + P * Q * Q)) * inv**3
    one = (1.0 - 0.5 * t2 + 0.375 * t4 - 0.3125 * t6) / s
    xx = (1.0 - 1.5 * t2 + 1.875 * t4 - 2.1875 * t6) / s
    return one, xx


def _antiderivatives(s: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """F_1 and F_x of (4) at s ≥ 0, t > 0, without cancellation: r − t = s²/(r + t), and F_x
    by its series t(x⁴/12 − x⁶/20 + 15x⁸/448 − 7x¹⁰/288), x = s/t, where x < 0.01 (there the
    closed form loses ~12 eps/x² to cancellation; the series' truncation is < x⁸ of it)."""
    r = np.hypot(s, t)
    lift = s * np.arcsinh(s / t)
    rise = s * s / (r + t)
    x = s / t
    x2 = x * x
    small = t * x2 * x2 * (1.0 / 12.0 + x2 * (-1.0 / 20.0 + x2 * (15.0 / 448.0 - x2 * 7.0 / 288.0)))
    return lift - rise, np.where(x < 0.01, small, lift - 2.0 * rise)


@functools.lru_cache(maxsize=1)
def _compact_rule() -> tuple[np.ndarray, np.ndarray]:
    """The ``COMPACT_POINTS``-point Gauss rule of the measure (4/π²) K(1 − τ²) dτ on [0, 1]
    (Stieltjes' procedure on the graded rule, which holds the measure to ≤ 3e-16; Gautschi,
    *Orthogonal Polynomials: Computation and Approximation*, 2004, §2.2.3)."""
    tau, weight = _tau_rule()
    alpha, beta = np.zeros(COMPACT_POINTS), np.zeros(COMPACT_POINTS)
    p_before, p = np.zeros_like(tau), np.ones_like(tau)
    norm_before = 1.0
    for k in range(COMPACT_POINTS):
        norm = float(weight @ (p * p))
        alpha[k] = float(weight @ (tau * p * p)) / norm
        beta[k] = norm / norm_before if k else 0.0
        p_before, p, norm_before = p, (tau - alpha[k]) * p - beta[k] * p_before, norm
    off = np.sqrt(beta[1:])
    nodes, vectors = np.linalg.eigh(np.diag(alpha) + np.diag(off, 1) + np.diag(off, -1))
    return nodes, vectors[0] ** 2 * float(weight.sum())


def double_antiderivatives(s: np.ndarray, b: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """A_1(s) = ⟨F_1(|s|, t)⟩ and A_x(s) = ⟨F_x(|s|, t)⟩ of (4) [m]: A'' = ⟨1/r⟩, ⟨s²/r³⟩, for
    half-widths ``b`` (a number, or an array broadcast with ``s``).

    F is homogeneous of degree one, so A(s; b) = b A(s/b; 1). Where |s| ≥ b, with
    F = s ln(s + r) − s ln t − (1 or 2) s²/(r + t) and ⟨ln t⟩ = ln(b/2): the rest is analytic in
    τ at distance ≥ 1/2 from [0, 1] and ``_compact_rule`` holds it to ~1e-16 of A (against the
    graded rule). Closer, the graded rule on (4)."""
    b = np.asarray(b, dtype=np.float64)
    s, b = np.broadcast_arrays(np.abs(np.asarray(s, dtype=np.float64)), b)
    sigma = s / b
    one, xx = np.empty_like(sigma), np.empty_like(sigma)
    wide = sigma >= 1.0
    tau, weight = _compact_rule()
    sw = sigma[wide][:, None]
    r = np.hypot(sw, 2.0 * tau)
    logs = (sw * np.log(sw + r)) @ weight - sigma[wide] * math.log(0.5)
    rise = (sw * sw / (r + 2.0 * tau)) @ weight
    one[wide], xx[wide] = logs - rise, logs - 2.0 * rise
    t, weight = difference_rule(1.0)
    close, flat_one, flat_xx = np.flatnonzero(~wide), one.reshape(-1), xx.reshape(-1)
    for start in range(0, close.size, TWO_WIDTH_CHUNK):  # the graded rule's rows in batches (~1 MB each)
        rows = close[start : start + TWO_WIDTH_CHUNK]
        F1, Fx = _antiderivatives(sigma.reshape(-1)[rows][:, None], t)
        flat_one[rows], flat_xx[rows] = F1 @ weight, Fx @ weight
    return b * one, b * xx


def _first_by_rule(sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A_1'(σ), A_x'(σ) at unit width by the graded rule: asinh(x) and asinh(x) − x/√(1 + x²),
    x = σ/t, the latter by its series x³/3 − 3x⁵/10 + 15x⁷/56 where x < 0.01 (cancellation)."""
    t, weight = difference_rule(1.0)
    x = sigma[:, None] / t
    lift = np.arcsinh(x)
    x2 = x * x
    small = x * x2 * (1.0 / 3.0 + x2 * (-0.3 + x2 * 15.0 / 56.0))
    return lift @ weight, np.where(x < 0.01, small, lift - x / np.sqrt(1.0 + x2)) @ weight


def _log_chebyshev_fit(
    function: object, low: float, high: float, panel: float, degree: int
) -> tuple[np.ndarray, list[np.ndarray]]:
    """Piecewise Chebyshev fits in v = ln σ of the arrays ``function``(σ) returns, for
    ``low`` ≤ σ ≤ ``high``: panels of width ``panel`` in v (the last one shorter), ``degree``
    on each. Returns the panel edges in v and one coefficient array per fitted function."""
    count = math.ceil((math.log(high) - math.log(low)) / panel)
    edges = math.log(low) + panel * np.arange(count + 1, dtype=np.float64)
    edges[-1] = math.log(high)
    nodes = np.cos(np.pi * (np.arange(degree + 1) + 0.5) / (degree + 1))
    v = edges[:-1, None] + 0.5 * (nodes + 1.0) * np.diff(edges)[:, None]
    fit = np.polynomial.chebyshev.chebfit
    return edges, [
        np.array([fit(nodes, f.reshape(v.shape)[k], degree) for k in range(count)]) for f in function(np.exp(v.ravel()))
    ]


def _log_chebyshev_sum(table: tuple[np.ndarray, list[np.ndarray]], sigma: np.ndarray) -> list[np.ndarray]:
    """The fits of :func:`_log_chebyshev_fit` at ``sigma`` (Clenshaw's recurrence; σ outside the
    table takes its nearest panel)."""
    edges, coefficients = table
    v = np.log(sigma)
    panel = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, edges.size - 2)
    u = 2.0 * (v - edges[panel]) / (edges[panel + 1] - edges[panel]) - 1.0
    twice = 2.0 * u
    out = []
    for c in coefficients:
        c = np.take(c.T, panel, axis=1)  # c[j] the j-th coefficient at every σ, contiguous
        b1, b2 = np.zeros_like(u), np.zeros_like(u)
        for j in range(c.shape[0] - 1, 0, -1):
            b1, b2 = c[j] + twice * b1 - b2, b1
        out.append(c[0] + u * b1 - b2)
    return out


@functools.lru_cache(maxsize=1)
def _narrow_table() -> tuple[np.ndarray, list[np.ndarray]]:
    """Fits of ln A_1'(σ) and ln A_x'(σ) for ``NARROW_LOW`` ≤ σ < 1 (both are positive and
    smooth in ln σ; against the graded rule ≤ 5e-14 relative on 5000 random σ,
    ``tests/discretizations/test_strip_cells.py``)."""
    return _log_chebyshev_fit(
        lambda sigma: [np.log(f) for f in _first_by_rule(sigma)], NARROW_LOW, 1.0, NARROW_PANEL, NARROW_DEGREE
    )


def _narrow(sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A_1'(σ), A_x'(σ) for ``NARROW_LOW`` ≤ σ < 1 from ``_narrow_table``."""
    one, xx = _log_chebyshev_sum(_narrow_table(), sigma)
    return np.exp(one), np.exp(xx)


def first_antiderivatives(s: np.ndarray, b: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """A_1'(s) = ⟨asinh(|s|/t)⟩ and A_x'(s) = ⟨asinh(|s|/t) − |s|/r⟩ [1]: the integrals of
    ⟨1/r⟩ and ⟨s²/r³⟩ from 0 to |s|, for half-widths ``b`` (broadcast with ``s``). Of degree
    zero in (s, b): with σ = |s|/b, where σ ≥ 1 asinh(σ/t) = ln(σ + r) − ln t with
    ⟨ln t⟩ = ln(1/2) and ``_compact_rule`` (as :func:`double_antiderivatives`); for
    ``NARROW_LOW`` ≤ σ < 1 the table ``_narrow_table``; below, the graded rule."""
    b = np.asarray(b, dtype=np.float64)
    s, b = np.broadcast_arrays(np.abs(np.asarray(s, dtype=np.float64)), b)
    sigma = (s / b).ravel()
    one, xx = np.empty_like(sigma), np.empty_like(sigma)
    wide, narrow = sigma >= 1.0, (sigma >= NARROW_LOW) & (sigma < 1.0)
    tiny = ~(wide | narrow)
    tau, weight = _compact_rule()
    sw = sigma[wide][:, None]
    r = np.hypot(sw, 2.0 * tau)
    one[wide] = np.log(sw + r) @ weight - math.log(0.5)
    xx[wide] = one[wide] - (sw / r) @ weight
    one[narrow], xx[narrow] = _narrow(sigma[narrow])
    one[tiny], xx[tiny] = _first_by_rule(sigma[tiny])
    return one.reshape(s.shape), xx.reshape(s.shape)


@functools.lru_cache(maxsize=1)
def _end_rule() -> tuple[np.ndarray, np.ndarray]:
    """Nodes u ∈ (0, 1] and weights of ∫₀¹ g(u) du for g with a logarithm at u = 0:
    ``END_POINTS`` Gauss–Legendre points on panels [``END_RATIO``^(k+1), ``END_RATIO``^k],
    k < ``END_PANELS`` (down to 1e-16 of the half strip: the self pair's scale b is ≥ that)."""
    x, w = np.polynomial.legendre.leggauss(END_POINTS)
    edges = END_RATIO ** np.arange(END_PANELS + 1, dtype=np.float64)
    lo, hi = edges[1:], edges[:-1]
    return (lo[:, None] + 0.5 * (hi - lo)[:, None] * (x + 1.0)).ravel(), (0.5 * (hi - lo)[:, None] * w).ravel()


def self_integrals(lo: np.ndarray, hi: np.ndarray, outline: Outline) -> tuple[np.ndarray, np.ndarray]:
    """∫_I∫_I ⟨1/r⟩ and ⟨s²/r³⟩ of strips I = [lo, hi] of an outline whose width varies [m].

    In m = (x + x')/2, s = x − x' the pair is ∫_I dm ∫_{−L}^{L} H(m + s/2, m − s/2) ds with
    L = 2 min(m − lo, hi − m). The width is taken as b(m) at each m (the dependence on b sits
    at |s| ≲ b, where b(m ± s/2) = b(m)(1 + O(b' s/b)); the tail |s| ≫ b sees ⟨t²⟩ =
    b(m)² + (b'² + b b'') s²/4, for the ellipse b(m)² − b₀² s²/4, a relative change of
    b₀²/8 of the pair), so the inner integral is 2 A'(L; b(m)) (:func:`first_antiderivatives`)
    and the outer one a Gauss sum on each half of I, graded toward the strip's ends
    (``_end_rule``), where A' has its logarithm at L ~ b (and at the contact's tips, b → 0)."""
    u, w = _end_rule()
    half = 0.5 * (hi - lo)
    step = half[:, None] * u
    ahead = np.concatenate([(1.0 - lo)[:, None] - step, (1.0 - hi)[:, None] + step], axis=1)  # 1 − m
    behind = np.concatenate([(1.0 + lo)[:, None] + step, (1.0 + hi)[:, None] - step], axis=1)  # 1 + m
    L = 2.0 * np.concatenate([step, step], axis=1)
    one, xx = first_antiderivatives(L, outline.width_at_distances(ahead, behind))
    weight = half[:, None] * np.concatenate([w, w])
    return 2.0 * (one * weight).sum(axis=1), 2.0 * (xx * weight).sum(axis=1)


def _two_sided_rule(ratio: float, panels: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes u ∈ (0, 1) and weights of ∫₀¹ g(u) du for g with logarithms at both ends:
    Gauss–Legendre on panels graded geometrically (``ratio``, ``panels`` per half) toward 0 and 1."""
    x, w = np.polynomial.legendre.leggauss(points)
    half = np.concatenate([[0.0], ratio ** np.arange(panels, -1, -1, dtype=np.float64)]) * 0.5
    edges = np.unique(np.concatenate([half, 1.0 - half]))
    lo, hi = edges[:-1], edges[1:]
    return (lo[:, None] + 0.5 * (hi - lo)[:, None] * (x + 1.0)).ravel(), (0.5 * (hi - lo)[:, None] * w).ravel()


@functools.lru_cache(maxsize=2)
def _two_width_rule(fine: bool) -> tuple[np.ndarray, np.ndarray]:
    """``TWO_WIDTH_FINE`` (the tables) or ``TWO_WIDTH_LEAN`` (the points of
    :func:`width_difference` that need the exact average) as a :func:`_two_sided_rule`."""
    return _two_sided_rule(*(TWO_WIDTH_FINE if fine else TWO_WIDTH_LEAN))


def two_width_averages(
    s: np.ndarray, b1: np.ndarray | float, b2: np.ndarray | float, fine: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """⟨1/r⟩ and ⟨s²/r³⟩ [1/m] at separations ``s`` for y and y' drawn from the profile (1) of
    half-widths ``b1`` and ``b2`` (arrays broadcast together).

    t = y − y' has, for b₁ ≥ b₂ (d = b₁ − b₂, S = b₁ + b₂, 0 ≤ |t| < S), the density

        ρ(t) = 2 K(k) / (π² √D),   1 − k² = |t² − d²| / D,   D = S² − t² (|t| ≤ d), 4b₁b₂ (|t| > d)   (6)

    (the integral between the middle roots of (b₁² − y²)(b₂² − (y − t)²), Byrd & Friedman 1971,
    256.00; for b₁ = b₂ it is (3)). Its logarithms at |t| = d and t = 0 (when d = 0) sit at the
    ends of the two pieces [0, d] and [d, S], each integrated by a :func:`_two_sided_rule` in the
    distance from d (so 1 − k² keeps its digits); the averages are divided by the rule's mass.
    ``fine``: ≤ 2.6e-12 (1/r) and 1.1e-11 (s²/r³) relative to scipy's two-dimensional
    quadrature in the profiles' angles; lean: ≤ 5.8e-7 of the fine average on 2000 random
    (s, b₁, b₂), but 2.6e-6 at equal widths and |s| ≲ 1e-5 b, where :func:`width_difference`
    does not use it (``tests/discretizations/test_strip_cells_widths.py``)."""
    from scipy.special import ellipkm1  # on first use, not at import (module docstring)

    s, b1, b2 = np.broadcast_arrays(
        np.abs(np.asarray(s, dtype=np.float64)), np.asarray(b1, dtype=np.float64), np.asarray(b2, dtype=np.float64)
    )
    shape = s.shape
    u, weight = _two_width_rule(fine)
    wide, narrow = np.maximum(b1, b2).ravel(), np.minimum(b1, b2).ravel()
    s = s.ravel()
    one, xx = np.empty(s.size), np.empty(s.size)
    for start in range(0, s.size, TWO_WIDTH_CHUNK):
        rows = slice(start, start + TWO_WIDTH_CHUNK)
        P, Q, sk = wide[rows, None], narrow[rows, None], s[rows, None]
        d, S = P - Q, P + Q
        mass = one_sum = xx_sum = 0.0
        for inner in (True, False):
            length = d if inner else S - d
            gap, w = length * u, length * weight
            t = d - gap if inner else d + gap
            D = (S - t) * (S + t) if inner else 4.0 * P * Q
            with np.errstate(divide="ignore", invalid="ignore"):
                density = np.where(w > 0.0, w * 2.0 * ellipkm1(gap * (t + d) / D) / (math.pi**2 * np.sqrt(D)), 0.0)
            r = np.hypot(sk, t)
            mass = mass + density.sum(axis=1)
            one_sum = one_sum + (density / r).sum(axis=1)
            xx_sum = xx_sum + (density * (sk / r) ** 2 / r).sum(axis=1)
        one[rows], xx[rows] = one_sum / mass, xx_sum / mass
    return one.reshape(shape), xx.reshape(shape)


@functools.lru_cache(maxsize=1)
def _profile_table() -> tuple[np.ndarray, list[np.ndarray]]:
    """Fits of ln⟨1/r⟩ and ln⟨s²/r³⟩ at unit width (:func:`profile_averages`) for
    ``NARROW_LOW`` ≤ σ ≤ ``SPREAD_REACH``."""
    return _log_chebyshev_fit(
        lambda sigma: [np.log(f) for f in profile_averages(sigma, 1.0)],
        NARROW_LOW,
        SPREAD_REACH,
        NARROW_PANEL,
        NARROW_DEGREE,
    )


@functools.lru_cache(maxsize=1)
def _spread_table() -> tuple[np.ndarray, list[np.ndarray]]:
    """Fits of σ² q(σ) for both kernels, q = ½ ∂²⟨k⟩/∂ε² at half-widths 1 ± ε, ε = 0 (7), for
    ``SPREAD_LOW`` ≤ σ ≤ ``SPREAD_REACH``: Richardson's extrapolation of the differences of
    :func:`two_width_averages` at ε and 2ε, ε = min(0.01, σ/20) (the averages are even in ε).
    Against finer differences (ε = σ/40, σ/80): ≤ 8.9e-7 for σ ≥ 1, ≤ 2.0e-4 below (the
    remainder of these steps, ≲ 3e-9 of ⟨k⟩ where the expansion applies)."""

    def spread(sigma: np.ndarray) -> list[np.ndarray]:
        eps, ones = np.minimum(0.01, sigma / 20.0), np.ones_like(sigma)
        base = np.array(two_width_averages(sigma, ones, ones))
        near = np.array(two_width_averages(sigma, 1.0 + eps, 1.0 - eps))
        far = np.array(two_width_averages(sigma, 1.0 + 2.0 * eps, 1.0 - 2.0 * eps))
        q = (4.0 * (near - base) - 0.25 * (far - base)) / (3.0 * eps * eps)
        return [q[0] * sigma**2, q[1] * sigma**2]

    return _log_chebyshev_fit(spread, SPREAD_LOW, SPREAD_REACH, NARROW_PANEL, NARROW_DEGREE)


def _unit_profile(sigma: np.ndarray) -> list[np.ndarray]:
    """⟨1/r⟩ and ⟨s²/r³⟩ at unit half-width and separation σ > 0: ``_profile_table`` up to
    ``SPREAD_REACH`` (σ below ``NARROW_LOW`` taken there: the averages' log² growth is
    resolved to ``NARROW_LOW``), the series (5) beyond."""
    inside = sigma <= SPREAD_REACH
    out = [np.empty(sigma.shape), np.empty(sigma.shape)]
    fitted = _log_chebyshev_sum(_profile_table(), np.maximum(sigma[inside], NARROW_LOW))
    series = series_averages(sigma[~inside], 1.0)
    for o, f, g in zip(out, fitted, series):
        o[inside], o[~inside] = np.exp(f), g
    return out


def width_difference(s: np.ndarray, b1: np.ndarray, b2: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """⟨k⟩ at half-widths b1, b2 minus ⟨k⟩ at one half-width b, for k = 1/r and s²/r³ [1/m]
    (arrays of one shape): what a near pair's single width leaves out (module docstring, (7)).

    With b̄ = (b1 + b2)/2, ε = (b1 − b2)/2, σ = |s|/b̄: where σ ≥ ``SPREAD_REACH`` the series (5)
    with both widths less the series with one; where |ε| ≤ ``SLOPE_LIMIT`` |s|,
    ⟨k⟩(b̄) − ⟨k⟩(b) + ε² q(σ)/b̄³ (the tables ``_profile_table``, ``_spread_table``); elsewhere
    (widths that differ by more than 2 ``SLOPE_LIMIT`` |s|: near an ellipse's tips)
    :func:`two_width_averages` (lean) less ⟨k⟩(b)."""
    shape = np.shape(s)
    s, b1, b2, b = (np.ravel(v) for v in (np.abs(s), b1, b2, b))
    mean, half_difference = 0.5 * (b1 + b2), 0.5 * (b1 - b2)
    one, xx = np.empty(s.shape), np.empty(s.shape)
    far = s >= SPREAD_REACH * np.maximum(np.maximum(b1, b2), b)
    both, single = series_averages(s[far], b1[far], b2[far]), series_averages(s[far], b[far])
    one[far], xx[far] = both[0] - single[0], both[1] - single[1]
    near = ~far
    reference = [f / b[near] for f in _unit_profile(s[near] / b[near])]
    steep = np.abs(half_difference[near]) > SLOPE_LIMIT * s[near]
    exact = np.flatnonzero(near)[steep]
    averages = two_width_averages(s[exact], b1[exact], b2[exact], fine=False)
    close = np.flatnonzero(near)[~steep]
    sigma = s[close] / mean[close]
    centred = _unit_profile(sigma)
    spread = _log_chebyshev_sum(_spread_table(), np.clip(sigma, SPREAD_LOW, SPREAD_REACH))
    scale = (half_difference[close] / sigma) ** 2 / mean[close] ** 3
    for out, average, c, q, ref in zip((one, xx), averages, centred, spread, reference):
        out[exact] = average - ref[steep]
        out[close] = c / mean[close] + scale * q - ref[~steep]
    return one.reshape(shape), xx.reshape(shape)


def _graded_from_zero(length: np.ndarray, floor: np.ndarray, panels: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights on (0, ``length``) (rows), Gauss–Legendre on [0, f] and on ``panels``
    panels geometric from f = min(``floor``, ``length``) to ``length``."""
    x, w = np.polynomial.legendre.leggauss(points)
    f = np.minimum(floor, length)[:, None]
    edges = np.concatenate([np.zeros_like(f), f * (length[:, None] / f) ** (np.arange(panels + 1) / panels)], axis=1)
    lo, hi = edges[:, :-1, None], edges[:, 1:, None]
    return (lo + 0.5 * (hi - lo) * (x + 1.0)).reshape(f.size, -1), (0.5 * (hi - lo) * w).reshape(f.size, -1)


def _self_points(lo: np.ndarray, hi: np.ndarray, outline: Outline) -> tuple[np.ndarray, ...]:
    """Points (s, b₁, b₂, b) and weights of (7) for strips with themselves (rows): m on each half
    of the strip, s ∈ (0, L), L = 2 × the distance to the nearer end, graded toward s = 0; the
    weights count ±s."""
    panels, points, along, _ = CORRECTION_RULE
    u, w = np.polynomial.legendre.leggauss(along)
    u, w = 0.5 * (u + 1.0), 0.5 * w
    half = 0.5 * (hi - lo)[:, None]
    m = np.concatenate([lo[:, None] + half * u, hi[:, None] - half * u], axis=1).ravel()
    L = (2.0 * half * np.concatenate([u, u])).ravel()
    b = outline.width(m)
    s, ws = _graded_from_zero(L, CORRECTION_FLOOR * b, panels, points)
    weight = 2.0 * (half * np.concatenate([w, w])).ravel()[:, None] * ws
    rows = lo.size
    return tuple(
        v.reshape(rows, -1)
        for v in (
            s,
            outline.width(m[:, None] + 0.5 * s),
            outline.width(m[:, None] - 0.5 * s),
            np.broadcast_to(b[:, None], s.shape),
            weight,
        )
    )


def _touching_points(
    size_i: np.ndarray, size_j: np.ndarray, corner: np.ndarray, outline: Outline
) -> tuple[np.ndarray, ...]:
    """Points and weights of (7) for touching strips (x = c − p in I_i, x' = c + q in I_j): the
    square p, q < ℓ = min(|I_i|, |I_j|) as two triangles (the longer of p, q graded toward the
    corner, the shorter a fraction of it) and the rest, [ℓ, ℓ + ||I_i| − |I_j||] × [0, ℓ], by a
    Gauss product rule."""
    panels, points, along, far_points = CORRECTION_RULE
    u, w = np.polynomial.legendre.leggauss(along)
    u, w = 0.5 * (u + 1.0), 0.5 * w
    rows, ell = corner.size, np.minimum(size_i, size_j)
    b = outline.width(corner)
    r, wr = _graded_from_zero(ell, CORRECTION_FLOOR * b, panels, points)
    longer, shorter = np.tile(r, 2)[:, :, None] * np.ones_like(u), np.tile(r, 2)[:, :, None] * u
    p_longer = np.concatenate([np.ones_like(r), np.zeros_like(r)], axis=1)[:, :, None] > 0
    y, wy = np.polynomial.legendre.leggauss(far_points)
    y, wy = 0.5 * (y + 1.0), 0.5 * wy
    extra = np.abs(size_i - size_j)
    along_rest = (ell[:, None] + extra[:, None] * y)[:, :, None] * np.ones(far_points)
    across_rest = (ell[:, None] * y)[:, None, :] * np.ones((1, far_points, 1))
    i_longer = (size_i >= size_j)[:, None, None]
    P = np.concatenate(
        [
            np.where(p_longer, longer, shorter).reshape(rows, -1),
            np.where(i_longer, along_rest, across_rest).reshape(rows, -1),
        ],
        axis=1,
    )
    Q = np.concatenate(
        [
            np.where(p_longer, shorter, longer).reshape(rows, -1),
            np.where(i_longer, across_rest, along_rest).reshape(rows, -1),
        ],
        axis=1,
    )
    weight = np.concatenate(
        [
            (np.tile(wr * r, 2)[:, :, None] * w).reshape(rows, -1),
            ((extra[:, None] * wy)[:, :, None] * (ell[:, None] * wy)[:, None, :]).reshape(rows, -1),
        ],
        axis=1,
    )
    return (
        P + Q,
        outline.width(corner[:, None] - P),
        outline.width(corner[:, None] + Q),
        np.broadcast_to(b[:, None], P.shape),
        weight,
    )


def _product_points(
    lo_i: np.ndarray, size_i: np.ndarray, lo_j: np.ndarray, size_j: np.ndarray, outline: Outline, count: int
) -> tuple[np.ndarray, ...]:
    """A ``count``² Gauss product rule on pairs of strips (rows): separations s = x' − x, the
    widths b(x), b(x') and the weights (far pairs of (5), separated pairs of (7))."""
    x, w = np.polynomial.legendre.leggauss(count)
    xi = lo_i[:, None] + 0.5 * size_i[:, None] * (x + 1.0)
    xj = lo_j[:, None] + 0.5 * size_j[:, None] * (x + 1.0)
    shape = (lo_i.size, count * count)
    weight = ((0.5 * size_i[:, None] * w)[:, :, None] * (0.5 * size_j[:, None] * w)[:, None, :]).reshape(shape)
    return (
        (xj[:, None, :] - xi[:, :, None]).reshape(shape),
        np.repeat(outline.width(xi), count, axis=1),
        np.tile(outline.width(xj), count),
        weight,
    )


def _apart_points(
    lo_i: np.ndarray,
    size_i: np.ndarray,
    lo_j: np.ndarray,
    size_j: np.ndarray,
    gap_middle: np.ndarray,
    outline: Outline,
    count: int,
) -> tuple[np.ndarray, ...]:
    """Points and weights of (7) for separated strips: :func:`_product_points` and the single
    width b at the middle of the gap."""
    s, b1, b2, weight = _product_points(lo_i, size_i, lo_j, size_j, outline, count)
    return s, b1, b2, np.broadcast_to(outline.width(gap_middle)[:, None], s.shape), weight


def width_corrections(
    edges: np.ndarray, outline: Outline, pairs: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """∫_{I_i}∫_{I_j} :func:`width_difference` for the near pairs ``pairs`` (i ≤ j) of an
    outline whose width varies, against the single width those pairs were integrated with
    (b(m) along a strip's own diagonal, b at the middle of the gap otherwise) [m]: (7).

    Quadrature (``CORRECTION_RULE``): a strip with itself in m and s (``_self_points``);
    touching strips in the distances from their common edge (``_touching_points``); separated
    ones by Gauss product rules, finer within ``APART_CLOSE`` strip lengths (``_apart_points``);
    in batches of about ``FAR_CHUNK`` points."""
    lo, hi = edges[:-1], edges[1:]
    size = hi - lo
    i, j = pairs
    one, xx = np.zeros(i.size), np.zeros(i.size)
    apart = j > i + 1
    close = apart & (lo[j] - hi[i] < APART_CLOSE * np.maximum(size[i], size[j]))
    groups = (
        (np.flatnonzero(i == j), lambda a, c: _self_points(lo[a], hi[a], outline)),
        (np.flatnonzero(j == i + 1), lambda a, c: _touching_points(size[a], size[c], hi[a], outline)),
        (
            np.flatnonzero(close),
            lambda a, c: _apart_points(
                lo[a], size[a], lo[c], size[c], 0.5 * (hi[a] + lo[c]), outline, CORRECTION_RULE[3]
            ),
        ),
        (
            np.flatnonzero(apart & ~close),
            lambda a, c: _apart_points(lo[a], size[a], lo[c], size[c], 0.5 * (hi[a] + lo[c]), outline, FAR_POINTS),
        ),
    )
    for selected, points_of in groups:
        if not selected.size:
            continue
        per_pair = points_of(i[selected[:1]], j[selected[:1]])[0].shape[1]
        step = max(1, FAR_CHUNK // per_pair)
        for start in range(0, selected.size, step):
            batch = selected[start : start + step]
            s, b1, b2, b, weight = points_of(i[batch], j[batch])
            D1, Dx = width_difference(s, b1, b2, b)
            one[batch], xx[batch] = (D1 * weight).sum(axis=1), (Dx * weight).sum(axis=1)
    return one, xx


def graded_edges(n: int, grading: float = GRADING, half_length: float = 1.0) -> np.ndarray:
    """The n + 1 strip edges x_i = a sgn ξ (1 − (1 − |ξ|)^γ), ξ uniform on [−1, 1] (module docstring)."""
    xi = np.linspace(-1.0, 1.0, n + 1)
    edges = half_length * np.sign(xi) * (1.0 - (1.0 - np.abs(xi)) ** grading)
    edges[0], edges[-1] = -half_length, half_length
    return edges


@dataclasses.dataclass(frozen=True)
class Outline:
    """A slender contact |x| ≤ 1, |y| ≤ b(x): ``rectangle`` b = b₀, ``ellipse`` b = b₀ √(1 − x²)."""

    name: str
    b0: float

    def width(self, x: np.ndarray) -> np.ndarray:
        """b(x) [m]."""
        x = np.asarray(x, dtype=np.float64)
        if self.name == "rectangle":
            return np.full_like(x, self.b0)
        return self.b0 * np.sqrt(np.maximum(1.0 - x * x, 0.0))

    def width_at_distances(self, ahead: np.ndarray, behind: np.ndarray) -> np.ndarray:
        """b at the point 1 − ``ahead`` = ``behind`` − 1 (distances to the tips x = 1 and −1,
        passed separately so that b near a tip keeps its digits)."""
        if self.name == "rectangle":
            return np.full_like(ahead, self.b0)
        return self.b0 * np.sqrt(ahead * behind)

    def widest(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """max of b over [lo, hi]: at the point nearest x = 0."""
        return self.width(np.clip(0.0, lo, hi))


def galerkin_integrals(
    edges: np.ndarray, b: float | Outline, with_xx: bool = True
) -> tuple[np.ndarray, np.ndarray | None]:
    """∫_{I_i}∫_{I_j} ⟨1/r⟩ and (``with_xx``, else None) ⟨s²/r³⟩ for every pair of strips [m]
    of a rectangle of half-width ``b`` or an :class:`Outline`: (4) for near pairs (one width, at
    the middle of their gap), :func:`self_integrals` for a strip with itself where the width
    varies, (5) with a Gauss product rule for far pairs, in batches of ``FAR_CHUNK`` (module
    docstring)."""
    outline = b if isinstance(b, Outline) else Outline("rectangle", float(b))
    lo, hi = edges[:-1], edges[1:]
    size = hi - lo
    n = size.size
    i, j = np.triu_indices(n)
    gap = np.maximum(np.maximum(lo[j] - hi[i], lo[i] - hi[j]), 0.0)
    widest = np.maximum(outline.widest(lo[i], hi[i]), outline.widest(lo[j], hi[j]))
    near = (gap < NEAR_GAP * np.maximum(size[i], size[j])) | (gap < SERIES_REACH * widest)
    one, xx = np.empty(i.size), np.empty(i.size)
    varying = outline.name != "rectangle"
    exact = near & (i != j) if varying else near  # where b varies, a strip with itself: self_integrals
    a, c = i[exact], j[exact]
    middle = np.where(a == c, 0.5 * (lo[a] + hi[a]), 0.5 * (np.minimum(hi[a], hi[c]) + np.maximum(lo[a], lo[c])))
    corners = np.stack([hi[a] - hi[c], hi[a] - lo[c], lo[a] - hi[c], lo[a] - lo[c]])
    A1, Ax = double_antiderivatives(corners, outline.width(middle)[None, :])
    sign = np.array([-1.0, 1.0, 1.0, -1.0])[:, None]
    one[exact], xx[exact] = (sign * A1).sum(axis=0), (sign * Ax).sum(axis=0)
    if varying:
        own = i == j
        one[own], xx[own] = self_integrals(lo, hi, outline)
        corrected = np.flatnonzero(near)
        extra_one, extra_xx = width_corrections(edges, outline, (i[corrected], j[corrected]))
        one[corrected] += extra_one
        xx[corrected] += extra_xx
    far = np.flatnonzero(~near)
    for start in range(0, far.size, FAR_CHUNK):
        batch = far[start : start + FAR_CHUNK]
        s, b1, b2, weight = _product_points(
            lo[i[batch]], size[i[batch]], lo[j[batch]], size[j[batch]], outline, FAR_POINTS
        )
        h1, hx = series_averages(s, b1, b2)
        one[batch], xx[batch] = (h1 * weight).sum(axis=1), (hx * weight).sum(axis=1)
    matrices = []
    for upper in (one, xx) if with_xx else (one,):
        P = np.empty((n, n))
        P[i, j] = upper
        P[j, i] = upper
        matrices.append(P)
    return matrices[0], matrices[1] if with_xx else None


def galerkin_matrix(one: np.ndarray, xx: np.ndarray | None, block: str, material: Isotropic) -> np.ndarray:
    """B of (2) [m/Pa] for ``block`` (xx, yy, zz) from the integrals of :func:`galerkin_integrals`
    (``xx`` may be None for zz and at nu = 0, where G_x = G_y = G_z = 1/(2πG r))."""
    nu = material.nu
    if block == "zz" or (nu == 0.0 and block in ("xx", "yy")):
        B = (1.0 - nu) * one
    elif xx is None:
        raise ValueError(f"block {block} at nu = {nu} needs the <s^2/r^3> integrals")
    elif block == "xx":
        B = (1.0 - nu) * one + nu * xx
    else:
        B = one - nu * xx
    return B / (2.0 * math.pi * material.G)


def stiffness(B: np.ndarray, sizes: np.ndarray) -> tuple[float, np.ndarray, float]:
    """K = Σ f_i |I_i| [N/m] of (2) for a unit displacement, the line loads f [N/m] and the
    relative residual ‖B f − |I|‖/‖|I|‖ of the Cholesky solve (B must be positive definite: a
    failed factorization is a ConvergenceError)."""
    from scipy.linalg import cho_factor, cho_solve  # on first use, not at import (module docstring)

    try:
        factor = cho_factor(B, lower=True)
    except np.linalg.LinAlgError as exc:
        raise ConvergenceError(
            f"strip cells: the Galerkin matrix is not positive definite ({exc})", 0, math.inf
        ) from exc
    f = cho_solve(factor, sizes)
    residual = float(np.linalg.norm(B @ f - sizes) / np.linalg.norm(sizes))
    return float(f @ sizes), f, residual


class StripCells:
    """The Galerkin systems (2) of an unturned rectangle (half-sides 1 and ``aspect``) on n
    strips graded toward its ends, for an isotropic half-space ``material``, for the load
    directions ``blocks`` (the ⟨s²/r³⟩ integrals are formed only where a tangential block
    needs them, nu ≠ 0: ``kernels`` lists what was formed)."""

    def __init__(
        self,
        aspect: float,
        n: int,
        material: Isotropic,
        blocks: tuple[str, ...] = BLOCKS,
        grading: float = GRADING,
        shape: str = "rectangle",
    ) -> None:
        self.outline = Outline(shape, float(aspect))
        self.material = material
        self.blocks = tuple(blocks)
        self.edges = graded_edges(int(n), grading)
        self.sizes = np.diff(self.edges)
        with_xx = material.nu != 0.0 and bool({"xx", "yy"} & set(self.blocks))
        self.kernels = ("<1/r>", "<s^2/r^3>") if with_xx else ("<1/r>",)
        self._one, self._xx = galerkin_integrals(self.edges, self.outline, with_xx)

    def matrix(self, block: str) -> np.ndarray:
        """B of (2) for ``block`` (xx, yy, zz) [m/Pa]."""
        if block not in self.blocks:
            raise ValueError(f"block {block} was not formed (blocks {self.blocks})")
        return galerkin_matrix(self._one, self._xx, block, self.material)

    def solve(self, block: str) -> tuple[float, np.ndarray, float]:
        """K_αα [N/m] for a unit displacement along ``block``, the line loads f_i [N/m] and the
        residual of the solve (:func:`stiffness`)."""
        return stiffness(self.matrix(block), self.sizes)
