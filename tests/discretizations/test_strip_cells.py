"""Strip cells (``hpcontact.discretizations.strip_cells``) against closed forms and independent quadratures.

Nothing here is taken from the module's own numbers. The references: the moments of t = y − y'
of two independent arcsine laws on [−b, b] (⟨y^2k⟩ = C(2k, k) b^2k / 4^k) and the logarithmic
capacity b/2 of a segment of half-length b; 2-D mpmath quadratures over y = b sin θ,
y' = b sin θ' (θ, θ' uniform) of the kernels and of F_1; the binomial series' remainders;
scipy's adaptive quadrature of the Galerkin double integrals; the variational bound of a
Galerkin solve; the b/a = 1e-8 rectangle's stiffnesses extrapolated from 2-D
coverage-weighted grids (``results/accuracy_reference.json``: regression values of this
package's own 2-D solver, ``COVERAGE_REFERENCE``) and, computed inside the test, a
coverage-weighted ``solve_to_accuracy`` run with its own error estimate. Every tolerance states the error
measured on strip_cells.py as of this commit and the margin taken (2.5-3×), or the analytic
bound it comes from.

The 2-D mpmath quadratures are taken in the rotated variables θ = u + v, θ' = u − v (Jacobian 2):
sin θ − sin θ' = 2 cos u sin v, so the ridge θ = θ' of the integrand is the edge v = 0 of the
domain |u| + |v| < π/2, where tanh-sinh is at its best; the integrand is even in u and in v, so

    (1/π²) ∫∫ g(b |sin θ − sin θ'|) dθ dθ'
        = (8/π²) ∫_0^{π/2} du ∫_0^{π/2 − u} g(2b cos u sin v) dv.
"""

from __future__ import annotations

import functools
import itertools
import math
import sys
from pathlib import Path

import mpmath as mp
import numpy as np
import pytest
from scipy import integrate

from hpcontact.discretizations import strip_cells as sc
from hpcontact.materials.isotropic import Isotropic

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import roundoff as ro  # noqa: E402

pytestmark = pytest.mark.filterwarnings("error")

EPS = np.finfo(np.float64).eps
#: REGRESSION VALUES, not an independent reference: the b/a = 1e-8 rectangle's K (G = 1, a = 1)
#: and its uncertainty (absolute) from this package's own 2-D coverage-weighted grids 2560 x 640
#: … 5120 x 1280, least-squares extrapolated (``python benchmarks/accuracy_reference.py``,
#: results/accuracy_reference.json, 2026-11-22; the grids are too large for a test to recompute).
#: They cross-check two discretizations of one code at the 1e-7 level; the accuracy of the strips
#: is asserted independently, against closed forms (the ellipse tests below) and against a
#: coverage-weighted convergence study run inside the test
#: (test_rectangle_against_an_in_test_coverage_extrapolation).
COVERAGE_REFERENCE = {
    0.3: {
        "xx": (0.3274333289178115, 6.20164701814474e-08),
        "yy": (0.4506409707096752, 7.937657481305038e-08),
        "zz": (0.46055678765988745, 7.529578865961284e-08),
    },
    0.5: {
        "xx": (0.3308843445837561, 6.349206416178532e-08),
        "yy": (0.613292177099599, 8.414726793137817e-08),
        "zz": (0.6447796106264224, 1.2782253544507682e-07),
    },
}


def _rotated_quad(integrand, q: float, scales: tuple[int, ...], method: str) -> mp.mpf:
    """(8/π²) ∫_0^{π/2} du ∫_0^{π/2−u} integrand(2 cos u sin v) dv at b = 1 (module docstring),
    the inner range split at ``scales`` × the kernels' width q/(2 cos u), the outer where that
    width meets the inner range's length (u = π/2 − k q); ``method`` of the outer quadrature:
    Gauss-Legendre where the outer integrand is analytic up to u = π/2 (the kernels), tanh-sinh
    where it has (π/2 − u) ln(π/2 − u) there (F_1, whose log singularity covers the whole
    shrinking inner range)."""
    s = mp.mpf(q)

    def inner(u):
        c = 2 * mp.cos(u)
        top = mp.pi / 2 - u
        width = s / c
        points = [0] + [k * width for k in scales if k * width < top / 2] + [top]
        return mp.quad(lambda v: integrand(c * mp.sin(v)), points)

    half = mp.pi / 2
    outer = [0] + [half - k * s for k in sorted(scales, reverse=True) if half - k * s > 0] + [half]
    return 8 * mp.quad(inner, outer, method=method) / mp.pi**2


@functools.cache
def _mp_profile_averages(q: float) -> tuple[float, float]:
    """⟨1/r⟩ and ⟨s²/r³⟩ at s = q, b = 1 by the 2-D mpmath quadrature (20 digits)."""
    with mp.workdps(20):
        s2 = mp.mpf(q) ** 2
        one = _rotated_quad(lambda t: 1 / mp.sqrt(s2 + t * t), q, (1, 8), "gauss-legendre")
        xx = _rotated_quad(lambda t: s2 / (s2 + t * t) ** mp.mpf(1.5), q, (1, 8), "gauss-legendre")
        return float(one), float(xx)


@functools.cache
def _mp_A1(q: float) -> float:
    """A_1 = ⟨F_1(s, |t|)⟩, F_1(s, t) = s asinh(s/t) − √(s² + t²) + t, at s = q, b = 1 (the log
    singularity at t = 0 lies on the edge v = 0)."""
    with mp.workdps(20):
        s = mp.mpf(q)
        F1 = lambda t: s * mp.asinh(s / t) - mp.sqrt(s * s + t * t) + t
        return float(_rotated_quad(F1, q, (1,), "tanh-sinh"))


# ------------------------------------------------------------------------------------------
# 1. the difference rule: moments and the logarithmic capacity
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("b", [1.0, 1e-8, 3.7])
def test_difference_rule_moments(b: float) -> None:
    """⟨1⟩ = 1, ⟨t²⟩ = b², ⟨t⁴⟩ = 9b⁴/4, ⟨t⁶⟩ = 25b⁶/4, ⟨t⁸⟩ = 1225b⁸/64 (⟨t^2n⟩ =
    Σ_k C(2n, 2k) m_2k m_(2n−2k), m_2k = b^2k C(2k, k)/4^k the arcsine moments) and
    ⟨ln|t|⟩ = ln(b/2). Measured (b = 1, 1e-8, 3.7):
    2.2e-16 (sum), ≤ 8.9e-16 (t² … t⁶), ≤ 1.44e-15 (t⁸), ≤ 9.0e-16 (log, relative); bounds
    7e-16, 4.3e-15 and 2.7e-15 (3 × each)."""
    t, w = sc.difference_rule(b)
    assert t.min() > 0.0 and t.max() <= 2.0 * b and np.all(w > 0.0)
    assert abs(w.sum() - 1.0) < 7e-16
    for power, moment in ((2, 1.0), (4, 9.0 / 4.0), (6, 25.0 / 4.0), (8, 1225.0 / 64.0)):
        assert abs((w @ t**power) / (moment * b**power) - 1.0) < 4.3e-15, power
    log_mean = math.log(b / 2.0)
    assert abs(w @ np.log(t) - log_mean) < 2.7e-15 * abs(log_mean)


# ------------------------------------------------------------------------------------------
# 2. the averaged kernels against a 2-D mpmath quadrature
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("q", [0.05, 0.5, 2.0, 20.0])
@pytest.mark.parametrize("b", [1.0, 1e-8, 3.7])
def test_profile_averages_against_mpmath(q: float, b: float) -> None:
    """⟨1/r⟩ and ⟨s²/r³⟩ at s = ±q b: b × (the averages) depends on q alone, so one 20-digit
    reference at b = 1 serves every b. Measured ≤ 1.67e-15 relative (⟨s²/r³⟩ at q = 0.05,
    b = 3.7: the rule's rounding; ≤ 8.9e-16 elsewhere); bound 5e-15 (3 × 1.67e-15)."""
    ref_one, ref_xx = _mp_profile_averages(q)
    one, xx = sc.profile_averages(np.array([q * b, -q * b]), b)
    assert np.all(np.abs(one * b / ref_one - 1.0) < 5e-15)
    assert np.all(np.abs(xx * b / ref_xx - 1.0) < 5e-15)


# ------------------------------------------------------------------------------------------
# 3. the moment series (5) against the rule
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("q", [100.0, 300.0, 1e4, 1e8])
@pytest.mark.parametrize("b", [1.0, 1e-8])
def test_series_averages_against_rule(q: float, b: float) -> None:
    """(5) against the rule for |s| = q b ≥ 100 b. The series' first omitted terms are
    (35/128, 315/128) ⟨t⁸⟩/s⁸ with ⟨t⁸⟩ = 1225 b⁸/64 (test 1): 5.2e-16 and 4.7e-15 at q = 100.
    Measured at q = 100: ≤ 2.2e-16 and ≤ 4.4e-15 (the truncation); elsewhere ≤ 1.1e-15
    (rounding). Bound: the truncation bound + 3.3e-15 (3 × the rounding measured)."""
    s = np.array([q * b, -q * b])
    one, xx = sc.series_averages(s, b)
    ref_one, ref_xx = sc.profile_averages(s, b)
    t8 = 1225.0 / 64.0
    assert np.all(np.abs(one / ref_one - 1.0) < 35.0 / 128.0 * t8 / q**8 + 3.3e-15)
    assert np.all(np.abs(xx / ref_xx - 1.0) < 315.0 / 128.0 * t8 / q**8 + 3.3e-15)


# ------------------------------------------------------------------------------------------
# 4. the double antiderivatives (4)
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("b", [1.0, 1e-8, 3.7])
def test_double_antiderivatives_vanish_at_zero(b: float) -> None:
    """A(0) = 0 (F_1 = F_x = 0 at s = 0 for every t > 0): exactly, as computed."""
    A1, Ax = sc.double_antiderivatives(np.array([0.0, -0.0]), b)
    assert np.all(A1 == 0.0) and np.all(Ax == 0.0)


@pytest.mark.parametrize("q", [1e-3, 0.05, 0.3, 3.0, 30.0, 1e3])
@pytest.mark.parametrize("b", [1.0, 1e-8])
def test_double_antiderivatives_second_difference(q: float, b: float) -> None:
    """(A(s + d) − 2A(s) + A(s − d))/d² = A''(ξ) + the rounding, d = 1e-3 s. Truncation:
    (d²/12) A''''(ξ), |ξ − s| ≤ d. Pointwise in t, with x = s²/r² ∈ [0, 1]: (1/r)'' =
    (2x − (1 − x))/r³, so |(1/r)''| ≤ 2/(s² r); (s²/r³)'' = (2 − 15x + 15x²)/r³, so
    |(s²/r³)''| ≤ 2 (s²/r³)/s². Hence |A''''(ξ)| ≤ 2 A''(ξ)/ξ², and since r(ξ)/r(s) lies between
    ξ/s and 1, A''(ξ) ≤ A''(s) max(s/ξ, ξ²/s²): relative bound d² s/(6 (s − d)³) = 1.67e-7 (the
    end ξ = s − d). Rounding: each A to 16 eps, over d² A''. Measured
    6.9e-9 … 1.7e-7 (the truncation, 1.667e-7 for s ≫ b, plus ≤ 5e-9 of rounding)."""
    s = q * b
    d = 1e-3 * s
    A1, Ax = sc.double_antiderivatives(np.array([s - d, s, s + d]), b)
    H = sc.profile_averages(np.array(s), b)
    truncation = d * d * s / (6.0 * (s - d) ** 3)
    for A, h in zip((A1, Ax), H):
        second = (A[2] - 2.0 * A[1] + A[0]) / (d * d)
        rounding = 16.0 * EPS * np.abs(A).sum() / (d * d * h)
        assert abs(second / h - 1.0) < truncation + rounding


@pytest.mark.parametrize("q", [1e4, 1e6])
@pytest.mark.parametrize("b", [1.0, 1e-8])
def test_double_antiderivatives_far_slope(q: float, b: float) -> None:
    """A_1'(s) = ⟨asinh(s/|t|)⟩ = ln(2s) − ⟨ln|t|⟩ + ⟨t²⟩/(4s²) + O(b⁴/s⁴) = ln(4s/b) + 1/(4q²)
    (test 1's ln(b/2)), and the central difference adds (d²/6) A_1''' = −d²/(6s²)(1 + O(q⁻²)),
    d = 1e-3 s: −1.667e-7. Remainders: (d⁴/120)|A_1⁽⁵⁾| ≈ d⁴/(20 s⁴) = 5e-14, (3/32)⟨t⁴⟩/s⁴
    < 3e-17. Measured after the two terms: ≤ 7.8e-13 (rounding: eps |A_1|/d ~ 2e-12); bound
    2.5e-12 (3 × 7.8e-13 + the remainders, rounded up)."""
    s = q * b
    d = 1e-3 * s
    A1 = sc.double_antiderivatives(np.array([s - d, s + d]), b)[0]
    slope = (A1[1] - A1[0]) / (2.0 * d)
    expected = math.log(4.0 * q) + 1.0 / (4.0 * q * q) - (d / s) ** 2 / 6.0
    assert abs(slope - expected) < 2.5e-12
    # the limit itself, ln(4 s/b), to within the two terms (measured 1.642e-7 and 1.667e-7 off;
    # 1.7e-7 covers d²/(6 s²) = 1.667e-7 and the rounding): a wrong constant (ln 2) would show
    assert abs(slope - math.log(4.0 * q)) < 1.7e-7 + 1.0 / (4.0 * q * q)


@pytest.mark.parametrize("q", [0.3, 3.0])
@pytest.mark.parametrize("b", [1.0, 1e-8])
def test_double_antiderivative_against_mpmath(q: float, b: float) -> None:
    """A_1(q b) = b × (the 20-digit 2-D quadrature at b = 1) (A_1 is homogeneous of degree 1 in
    (s, t)). Measured ≤ 6.7e-16 relative; bound 2e-15 (3 × 6.7e-16)."""
    A1 = sc.double_antiderivatives(np.array([q * b, -q * b]), b)[0]
    assert np.all(np.abs(A1 / (b * _mp_A1(q)) - 1.0) < 2e-15)


# ------------------------------------------------------------------------------------------
# 5. the Galerkin integrals against scipy's adaptive quadrature
# ------------------------------------------------------------------------------------------
#: Accuracy of the τ rule's averages ⟨1/r⟩, ⟨s²/r³⟩ that the reference integrates: what
#: test_profile_averages_against_mpmath asserts against 20-digit quadratures (relative).
RULE_ACCURACY = 5e-15
#: Per evaluation of the reference's integrand, relative: a term w/r or w s²/(r r r) (hypot,
#: products, division: ≤ 8u), math.fsum of the terms (correctly rounded: u), the profile weight
#: (its own 2 operations) and the product (u); then the 21-point Gauss–Kronrod sum (γ₂₂) and
#: the node's position (local coordinates from an exact break: ≤ 2u of the piece): 36u.
REFERENCE_ROUNDING = 36


@functools.cache
def _rule(b: float) -> tuple[np.ndarray, np.ndarray]:
    return sc.difference_rule(b)


def _average(s: float, b: float, entry: int) -> float:
    """⟨1/r⟩ (entry 0) or ⟨s²/r³⟩ (entry 1) at s by the τ rule, summed exactly (math.fsum)."""
    t, weight = _rule(b)
    r = np.hypot(s, t)
    terms = weight / r if entry == 0 else weight * (s * s) / (r * r * r)
    return math.fsum(terms)


def _galerkin_reference(
    I: tuple[float, float], J: tuple[float, float], b: float
) -> tuple[tuple[float, float], tuple[float, float]]:
    """∫_I ∫_J ⟨k⟩(x − x') dx' dx = ∫ ⟨k⟩(s) w(s) ds with x' = x − s: w(s) = |I ∩ (J + s)| =
    max(0, min(|I|, |J|, s − lo, hi − s)), lo = a1 − c2, hi = a2 − c1 (the overlap trapezoid),
    by scipy's quad between its corners, at s = 0 (the log² singularity of ⟨k⟩) and at ±b·10^k
    around it, each piece in its own coordinate σ = s − (its start) so that a node's rounding is
    u of the piece, not of |s|, and w's small values are differences of exact numbers (the
    corners of ``graded_edges(16)`` are dyadic: exact). Returns (value, bound on its error) for
    ⟨1/r⟩ and ⟨s²/r³⟩: the pieces' error estimates (quad's abserr), ``RULE_ACCURACY`` and the
    rounding (``REFERENCE_ROUNDING`` u + γ of the most subintervals of a piece, quad's sum over
    them; the pieces are summed by math.fsum), relative."""
    (a1, a2), (c1, c2) = I, J
    lo, hi = a1 - c2, a2 - c1
    flat = min(a2 - a1, c2 - c1)
    breaks = {lo, hi, lo + flat, hi - flat}
    if lo <= 0.0 <= hi:
        breaks |= {0.0} | {sign * b * 10.0**k for k in range(-2, 12) for sign in (-1.0, 1.0)}
    breaks = sorted(x for x in breaks if lo <= x <= hi)
    pieces = list(itertools.pairwise(breaks))

    out = []
    for entry in (0, 1):

        def integrand(sigma: float, start: float, entry: int = entry) -> float:
            return _average(start + sigma, b, entry) * max(0.0, min(flat, (start - lo) + sigma, (hi - start) - sigma))

        # a rough total first, so that the pieces near s = 0 (tiny, where w ~ |s|) are asked for
        # 1e-16 of the total rather than 1e-13 of themselves
        rough = sum(integrate.quad(integrand, 0.0, v - u, args=(u,), epsrel=1e-6, limit=200)[0] for u, v in pieces)
        values, estimate, most = [], 0.0, 1
        for u, v in pieces:
            value, abserr, info = integrate.quad(
                integrand, 0.0, v - u, args=(u,), epsabs=1e-16 * abs(rough), epsrel=1e-13, limit=200, full_output=1
            )[:3]
            values.append(value)
            estimate += abserr
            most = max(most, int(info["last"]))
        total = math.fsum(values)
        rounding = (REFERENCE_ROUNDING * ro.U + ro.gamma(most) + RULE_ACCURACY) * abs(total)
        out.append((total, estimate + rounding))
    return out[0], out[1]


def _gauss_error(size_i: float, size_j: float, gap: float, centres: float, b: float) -> float:
    """Bound on the error of the ``FAR_POINTS``² Gauss product rule for a far pair (absolute):
    per strip k, ⟨k⟩ is analytic in x off the set |x − x'| ≤ 2b (x' on the other strip), so on
    the Bernstein ellipse of semi-major axis a = 1 + (gap − 2b)/size_k (half-way to it, in the
    strip's [−1, 1]) |s ± it| ≥ d = (gap − 2b)/2 and |⟨1/r⟩|, |⟨s²/r³⟩| ≤ (1 + 0.1)/d · max(1, |s|²/d²)
    (|t| ≤ 2b ≪ d: the series (5) within 1 %); Gauss–Legendre's error is then ≤ (64/15) M
    ρ^(−2n)/(ρ² − 1) × size_k/2 (Trefethen, *Approximation Theory and Approximation Practice*,
    Thm 19.3), ρ = a + √(a² − 1), and the product rule's ≤ size_j E_i + size_i E_j."""
    n = sc.FAR_POINTS
    d = 0.5 * (gap - 2.0 * b)
    errors = []
    for own in (size_i, size_j):
        a = 1.0 + (gap - 2.0 * b) / own
        rho = a + math.sqrt(a * a - 1.0)
        reach = centres + 0.5 * (size_i + size_j) + a * own  # ≥ |s| on the ellipse
        M = 1.1 / d * max(1.0, (reach / d) ** 2)
        errors.append(64.0 / 15.0 * M * rho ** (-2 * n) / (rho * rho - 1.0) * 0.5 * own)
    return size_j * errors[0] + size_i * errors[1]


def _module_error(i: int, j: int, edges: np.ndarray, b: float, entries: tuple[float, float]) -> tuple[float, float]:
    """Bound on the rounding (and, far apart, the truncation) of ``galerkin_integrals``' entry
    (i, j) (absolute), for ⟨1/r⟩ and ⟨s²/r³⟩.

    Near pairs: −A(c₁) + A(c₂) + A(c₃) − A(c₄) over the corners c (exact here: dyadic edges).
    Each A(c) = b [L + σ ln 2 − k R] (``double_antiderivatives``, |c| ≥ b: σ = |c|/b, L and R the
    m-point (``COMPACT_POINTS``) compact-rule sums of σ ln(σ + r) and σ²/(r + 2τ), k = 1, 2) is
    within (m + 13) u b P, P = L + σ ln 2 + k R: the two dot products of m positive terms (γ_m,
    ≤ 5u a term: hypot, the sum, log, products), σ's rounding (u, amplified by σA'/A ≤ P/A),
    the assembly (3 operations) and the factor b; the signed sum of the four adds 3u Σ|A|.
    Relative to the entry that is (m + 13) u Σ b P/|B_ij| + 3u Σ|A|/|B_ij|: the cancellation
    ratio of the four terms (≤ 400 for the pairs here, 1.6e5 for the tiny end strip beside the
    long middle one) times the operations.

    Far pairs: the ``FAR_POINTS``² product rule on the series (5) (``series_averages``): a term
    within ≤ 8u (the series' few operations) + u (the product with its weight, itself ≤ 5u off)
    + the separation's rounding (x = lo + size (ξ + 1)/2: 2u of |x| ≤ 1 each, so ≤ 4u/gap
    relative to s ≥ gap, and ⟨k⟩'s sensitivity |s k'/k| ≤ 1), then the sum of 16 positive terms
    (γ₁₅): (30 + 4/gap) u of the entry; plus ``_gauss_error`` and the series' truncation,
    (35/128, 315/128) ⟨t⁸⟩/s⁸ with ⟨t⁸⟩ = 1225 b⁸/64 (test 1) at s ≥ gap."""
    lo, hi = edges[:-1], edges[1:]
    size = hi - lo
    gap = max(lo[j] - hi[i], lo[i] - hi[j], 0.0)
    if gap < sc.NEAR_GAP * max(size[i], size[j]) or gap < sc.SERIES_REACH * b:
        corners = np.array([hi[i] - hi[j], hi[i] - lo[j], lo[i] - hi[j], lo[i] - lo[j]])
        A1, Ax = sc.double_antiderivatives(corners, b)
        sigma = np.abs(corners[corners != 0.0]) / b
        assert np.all(sigma >= 1.0)  # the compact rule's branch (A(0) = 0 exactly)
        tau, weight = sc._compact_rule()
        r = np.hypot(sigma[:, None], 2.0 * tau)
        L = (sigma[:, None] * np.log(sigma[:, None] + r)) @ weight
        R = (sigma[:, None] ** 2 / (r + 2.0 * tau)) @ weight
        m = sc.COMPACT_POINTS
        return tuple(
            (m + 13) * ro.U * b * float(np.sum(L + sigma * math.log(2.0) + k * R)) + 3.0 * ro.U * float(np.abs(A).sum())
            for k, A in ((1, A1), (2, Ax))
        )
    centres = abs(0.5 * (lo[i] + hi[i]) - 0.5 * (lo[j] + hi[j]))
    gauss = _gauss_error(size[i], size[j], gap, centres, b)
    t8 = 1225.0 / 64.0 * (b / gap) ** 8
    return tuple(
        (30.0 + 4.0 / gap) * ro.U * abs(value) + gauss + c * t8 * abs(value)
        for c, value in zip((35.0 / 128.0, 315.0 / 128.0), entries)
    )


#: (i, j) of graded_edges(16) (strips 0.002 at the ends … 0.33 in the middle): self pairs, touching
#: pairs, one strip between, far apart (the series (5)), and unequal sizes 1.33 apart, still "near".
GALERKIN_PAIRS = [(0, 0), (7, 7), (0, 1), (7, 8), (1, 3), (3, 5), (0, 15), (2, 12), (0, 8)]


@pytest.mark.parametrize("i, j", GALERKIN_PAIRS)
@pytest.mark.parametrize("b", [1e-3, 1e-8])
def test_galerkin_integrals_against_quadrature(i: int, j: int, b: float) -> None:
    """Entries of galerkin_integrals(graded_edges(16), b) against ``_galerkin_reference``, each
    within the sum of the two computations' derived error bounds (``_module_error``: the
    near pairs' cancellation ratio Σ|A(corner)|/|B_ij| times the operations of an A, the far
    pairs' few u and Gauss truncation; ``_galerkin_reference``: quad's estimate, the τ rule's
    tested accuracy and the rounding) — no longer 3 × the error measured on one machine
    (4e-15 for the touching pair (0, 1), which a Xeon exceeded: 5.4e-15 at b = 1e-8).
    Derived bounds (relative, b = 1e-3 … 1e-8): self and far pairs 2.4e-14 … 4.3e-14 (the
    reference's floor), touching 1.2e-13 … 4.2e-13, one strip between 5.7e-13 … 1.8e-12, the
    tiny end strip beside the long middle one (0, 8) 3.1e-10 … 7.2e-10 (the module's "~1e-10 of
    the entry" there). Measured: ≤ 4.4e-16 (self, far), 2.2e-16 … 1.7e-14 (touching),
    7.8e-16 … 4.8e-14 (one between), 3.9e-12 … 1.5e-11 (0, 8): every one ≥ 15 × below its
    bound. A wrong term of an antiderivative or of the series is O(1) of the entry."""
    edges = sc.graded_edges(16)
    assert np.array_equal(edges * 512.0, np.round(edges * 512.0))  # dyadic: exact corner differences
    P1, Px = sc.galerkin_integrals(edges, b)
    (ref_one, err_one), (ref_xx, err_xx) = _galerkin_reference((edges[i], edges[i + 1]), (edges[j], edges[j + 1]), b)
    mod_one, mod_xx = _module_error(i, j, edges, b, (P1[i, j], Px[i, j]))
    for value, ref, bound in ((P1[i, j], ref_one, mod_one + err_one), (Px[i, j], ref_xx, mod_xx + err_xx)):
        assert bound <= 1e-8 * abs(ref), bound  # the integrals' own claim (~1e-10 of an entry at worst)
        assert abs(value - ref) <= bound, (abs(value / ref - 1.0), bound / abs(ref))


@pytest.mark.parametrize("b", [1e-3, 1e-8])
def test_galerkin_integrals_symmetries(b: float) -> None:
    """B_ij = B_ji (exactly: the upper triangle is mirrored) and, the mesh being symmetric about
    x = 0, B_ij = B_{n−1−i, n−1−j} (the corners' differences round differently on the two
    sides, and the near pairs' cancellation (``GALERKIN_PAIRS``) magnifies that: measured ≤ 4.1e-11
    relative, n = 33, b = 1e-8; bound 1.2e-10 = 3 ×). Every entry positive (⟨k⟩ > 0)."""
    for n in (16, 33):
        P1, Px = sc.galerkin_integrals(sc.graded_edges(n), b)
        for P in (P1, Px):
            assert np.array_equal(P, P.T)
            assert np.all(P > 0.0)
            assert np.max(np.abs(P[::-1, ::-1] / P - 1.0)) < 1.2e-10


# ------------------------------------------------------------------------------------------
# 6. the Galerkin systems and their solves
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
@pytest.mark.parametrize("aspect, n", [(1e-8, 64), (1e-6, 48), (1e-3, 32)])
def test_strip_systems(aspect: float, n: int, nu: float) -> None:
    """For xx, yy, zz: B symmetric (exactly) and positive definite (eigvalsh > 0: measured
    smallest 1.3e-5 … 1.1e-4, 4.5e-5 … 2.4e-4 of the largest); relative residual ≤ 8e-16
    (measured ≤ 2.6e-16, 3 ×); every line load positive (a flat punch pushes everywhere:
    measured ≥ 0.16); K ∝ G (G = 1e-9 and 1e12, divided by G, against G = 1: measured
    ≤ 2.3e-16, bound 7e-16 = 3 ×);
    at nu = 0 the three kernels coincide, so K_xx = K_yy = K_zz exactly; K_zz (1 − nu) is the
    nu = 0 value (Boussinesq's (1 − nu)/r: measured ≤ 2.3e-16, bound 7e-16)."""
    strips = sc.StripCells(aspect, n, Isotropic(1.0, nu))
    small = sc.StripCells(aspect, n, Isotropic(1e-9, nu))
    large = sc.StripCells(aspect, n, Isotropic(1e12, nu))
    K = {}
    for block in sc.BLOCKS:
        B = strips.matrix(block)
        assert np.array_equal(B, B.T)
        assert np.linalg.eigvalsh(B).min() > 0.0
        K[block], f, residual = strips.solve(block)
        assert residual < 8e-16
        assert f.shape == (n,) and np.all(f > 0.0)
        assert abs(small.solve(block)[0] / 1e-9 / K[block] - 1.0) < 7e-16
        assert abs(large.solve(block)[0] / 1e12 / K[block] - 1.0) < 7e-16
    if nu == 0.0:
        assert K["xx"] == K["yy"] == K["zz"]
    K0 = sc.StripCells(aspect, n, Isotropic(1.0, 0.0)).solve("zz")[0]
    assert abs(K["zz"] * (1.0 - nu) / K0 - 1.0) < 7e-16


# ------------------------------------------------------------------------------------------
# 7. against the 2-D coverage-weighted reference of the b/a = 1e-8 rectangle
# ------------------------------------------------------------------------------------------
@functools.cache
def _strip_stiffness(nu: float, n: int) -> dict[str, float]:
    strips = sc.StripCells(1e-8, n, Isotropic(1.0, nu))
    return {block: strips.solve(block)[0] for block in sc.BLOCKS}


@pytest.mark.parametrize("nu, block", [(nu, block) for nu in (0.3, 0.5) for block in sc.BLOCKS])
def test_rectangle_against_coverage_reference(nu: float, block: str) -> None:
    """K_αα of the b/a = 1e-8 rectangle (G = 1, a = 1) on n = 256 and 512 strips, Richardson-
    extrapolated with order 2, against the 2-D coverage-weighted reference. The meshes are nested
    (ξ on 2/256 and 2/512 steps: exact) and the Galerkin K is the maximum of the complementary
    energy over the trial space, so K_256 ≤ K_512 ≤ the true K; the differences must fall ≥ 3×
    per doubling (measured 3.91-3.99 from n = 128). Measured |extrapolation − reference|
    (absolute): nu 0.3: xx 4.47e-8, yy 4.57e-8, zz 1.258e-7; nu 0.5: xx 5.23e-8, yy 1.304e-7,
    zz 6.82e-8 — all with the strips above. For zz at 0.3 and yy at 0.5, K_512 alone, a lower
    bound of the true K, lies above the reference + its stated uncertainty (by 1.17e-7 and
    1.20e-7 against 7.53e-8 and 8.41e-8): that uncertainty (the spread of the 2-D fits) is
    understated, by up to 1.67× here. The bound is twice the stated uncertainty."""
    K128, K256, K512 = (_strip_stiffness(nu, n)[block] for n in (128, 256, 512))
    assert K128 < K256 < K512  # nested Galerkin spaces: K rises with n
    assert (K256 - K128) >= 3.0 * (K512 - K256)
    extrapolated = K512 + (K512 - K256) / 3.0
    value, uncertainty = COVERAGE_REFERENCE[nu][block]
    assert abs(extrapolated - value) <= 2.0 * uncertainty


@pytest.mark.parametrize("nu, request_", [(0.3, 1e-5), (0.5, 1e-4)])
def test_rectangle_against_an_in_test_coverage_extrapolation(nu: float, request_: float) -> None:
    """The b/a = 1e-8 rectangle on 512 strips against a different discretization with its own
    convergence study, run here: ``solve_to_accuracy`` on coverage-weighted 2-D grids (32 × 8 …
    512 × 128 for 1e-5, … 256 × 64 for 1e-4), whose extrapolated K carries an estimated error.
    The strips' K must lie within that estimate of it, and above it (measured +3.5e-6, +3.1e-6,
    +3.4e-6 for K_xx, K_yy, K_zz at nu 0.3 against estimates 8.1e-6, 7.2e-6, 7.7e-6; +1.1e-5,
    +9.0e-6, +1.05e-5 at nu 0.5 against 2.7e-5, 2.2e-5, 2.5e-5): the coverage sequence rises
    towards the limit from below, and the strips' K is itself a lower bound of the true K
    (complementary energy over a subspace) within the strip model's 0.1 b/a = 1e-9."""
    from hpcontact.accuracy import solve_to_accuracy
    from hpcontact.scene import Scene

    record = solve_to_accuracy(
        Scene.from_params({"shape": "rectangle", "aspect": 1e-8, "nu": nu, "quantities": "tangential,normal"}),
        request_,
        strategy="coverage",
    )
    assert record["accuracy_met"]
    for block in sc.BLOCKS:
        key = f"K_{block}"
        difference = _strip_stiffness(nu, 512)[block] / record[key] - 1.0
        assert 0.0 < difference <= record["estimated_errors"][key], key


# ------------------------------------------------------------------------------------------
# ellipses: a width that varies along x (Galin's and Mindlin's traction is in the trial space)
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "aspect, n", [(0.7, 128), (0.05, 128), (1e-2, 128), (1e-3, 256), (1e-4, 256), (1e-6, 256), (1e-8, 256)]
)
def test_ellipse_against_mindlin_and_galin(aspect: float, n: int) -> None:
    """Strips of an ellipse contain its exact traction (f constant) at every aspect, so K's error
    is that of the integrals; where it has settled with n (here 128 strips for b/a ≥ 1e-2, 256
    below) it is within ``model_error`` — min(8e-7 b/a, 5e-8) + 5e-12, three times the level
    measured against Mindlin's K_xx, K_yy and Galin's K_zz (``benchmarks/strip_calibration.py``:
    1.5e-8 … 1.7e-8 for b/a ≥ 0.3, 2.2e-9 at 1e-2, 3.2e-11 at 1e-3, 1.2e-12 … 1.6e-12 at 1e-4 and
    1e-5 on 1024 strips; 1.9e-11 and 4.4e-12 there on 256) —
    for nu 0, 0.3, 0.5 (the integrals do not depend on nu). Coarser grids are the estimator's
    business (``tests/test_accuracy.py``)."""
    from hpcontact import analytic
    from hpcontact.geometry import Shape

    edges = sc.graded_edges(n)
    one, xx = sc.galerkin_integrals(edges, sc.Outline("ellipse", aspect))
    bound = sc.model_error(Shape("ellipse", aspect=aspect))
    for nu in (0.0, 0.3, 0.5):
        K_xx, K_yy = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
        exact = {"xx": K_xx, "yy": K_yy, "zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu)}
        for block in sc.BLOCKS:
            K = sc.stiffness(sc.galerkin_matrix(one, xx, block, Isotropic(1.0, nu)), np.diff(edges))[0]
            assert abs(K / exact[block] - 1.0) <= bound


def test_self_integrals_of_a_constant_width_are_the_closed_form() -> None:
    """``self_integrals`` (the m-integral of 2A'(L; b(m)) used where b varies) equals the exact
    2A(h) of (4) when b is constant (measured ≤ 3.5e-12 for b = 1e-8, 1e-3, 0.3 on 32 graded
    strips; bound 3x)."""
    edges = sc.graded_edges(32)
    for b in (1e-8, 1e-3, 0.3):
        one, xx = sc.self_integrals(edges[:-1], edges[1:], sc.Outline("rectangle", b))
        A1, Ax = sc.double_antiderivatives(np.diff(edges), b)
        assert np.max(np.abs(one / (2.0 * A1) - 1.0)) <= 1.1e-11
        assert np.max(np.abs(xx / (2.0 * Ax) - 1.0)) <= 1.1e-11


def test_narrow_table_matches_the_graded_rule() -> None:
    """A_1'(σ), A_x'(σ) for 1e-20 ≤ σ < 1 from the piecewise Chebyshev table against the graded
    rule on 5000 log-uniform σ (measured 5.0e-14 and 6.0e-13; bound 3x), and the first
    antiderivative's derivative is ⟨1/r⟩ (central difference, d = 1e-4 s: O(d²) ≤ 1e-7)."""
    sigma = np.exp(np.random.default_rng(2).uniform(np.log(1e-20), 0.0, 5000))
    one, xx = sc._first_by_rule(sigma)
    fast_one, fast_xx = sc._narrow(sigma)
    assert np.max(np.abs(fast_one / one - 1.0)) <= 1.5e-13
    assert np.max(np.abs(fast_xx / xx - 1.0)) <= 1.8e-12
    for s in (0.3, 3.0, 300.0):
        d = 1e-4 * s
        up, down = sc.first_antiderivatives(np.array([s + d, s - d]), 1.0)[0]
        assert abs((up - down) / (2.0 * d) / sc.profile_averages(np.array([s]), 1.0)[0][0] - 1.0) <= 1e-7
