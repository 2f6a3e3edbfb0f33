"""Two widths on strip cells: the corrections (7) of ``hpcontact.discretizations.strip_cells`` for a width that varies.

A near pair of strips of an ellipse is integrated with one width; ``width_corrections`` adds
∫∫ [⟨k⟩(s; b₁, b₂) − ⟨k⟩(s; b)] back (``width_difference``), where ⟨k⟩(s; b₁, b₂) averages
k = 1/r and s²/r³ (r² = s² + (y − y')²) over y, y' drawn independently from the arcsine laws of
half-widths b₁ = b(x), b₂ = b(x') (``two_width_averages``, the closed-form density (6)).

The references here are not the module's numbers: scipy's two-dimensional adaptive quadrature
in the profiles' angles (y = b₁ cos θ, y' = b₂ cos φ: the arcsine weights become the uniform
1/π² dθ dφ); the one-width rule ``profile_averages`` (itself checked against 20-digit mpmath in
``tests/discretizations/test_strip_cells.py``); the binomial series of the kernels with the exact moments of
the arcsine laws (⟨y²ᵏ⟩ = C(2k, k) b²ᵏ/4ᵏ, as rationals); Richardson finite differences of the
fine two-width average; brute-force tensor Gauss rules graded toward the singular edges and
corners of the pair integrals; and Mindlin's and Galin's closed-form stiffnesses of the
ellipse, whose exact traction the strips contain. Every tolerance states the error measured on
strip_cells.py as of this writing and the margin taken (2.5–3×).
"""

from __future__ import annotations

import functools
import math
from fractions import Fraction

import numpy as np
import pytest
from scipy import integrate

from hpcontact import analytic
from hpcontact.discretizations import strip_cells as sc
from hpcontact.materials.isotropic import Isotropic

pytestmark = pytest.mark.filterwarnings("error")


def _kernels(s: float, t: float) -> tuple[float, float]:
    r2 = s * s + t * t
    return 1.0 / math.sqrt(r2), s * s / r2**1.5


def _angle_quadrature(s: float, b1: float, b2: float, kernel: int) -> float:
    """(1/π²) ∫₀^π ∫₀^π k(s, b₁ cos θ − b₂ cos φ) dφ dθ by scipy's nested adaptive quadrature
    (``nquad``, QUADPACK), the inner range split where t = 0 (φ = arccos(b₁ cos θ / b₂): the
    kernels' peak of width ~s), the outer one where that point meets an end of the inner range
    (b₁ cos θ = ±b₂). At b₁ = b₂ it agrees with ``profile_averages`` to ≤ 3.3e-15 (s = 0.01,
    0.05; measured while writing this test)."""

    def integrand(phi: float, theta: float) -> float:
        return _kernels(s, b1 * math.cos(theta) - b2 * math.cos(phi))[kernel]

    def inner(theta: float) -> dict:
        c = b1 * math.cos(theta)
        opts = {"epsabs": 1e-14, "epsrel": 1e-12, "limit": 200}
        if abs(c) < b2:
            opts["points"] = [math.acos(c / b2)]
        return opts

    outer = {"epsabs": 1e-14, "epsrel": 1e-12, "limit": 200}
    if b1 > b2:
        outer["points"] = [math.acos(b2 / b1), math.acos(-b2 / b1)]
    value, _ = integrate.nquad(integrand, [(0.0, math.pi), (0.0, math.pi)], opts=[inner, outer])
    return value / math.pi**2


# ------------------------------------------------------------------------------------------
# 1. the two-width average (6) against scipy's 2-D quadrature in the profiles' angles
# ------------------------------------------------------------------------------------------
ANGLE_CASES = [
    (0.05, 1.0, 1.0),  # equal widths
    (0.01, 1.0, 1.001),  # b1/b2 = 1/1.001, s = 1e-2 b
    (0.1, 1.001, 1.0),
    (0.037, 3.7, 3.7 / 1.001),  # another scale
    (0.02, 2.0, 1.0),  # b1/b2 = 2, s = 1e-2 b1
    (10.0, 1.0, 2.0),  # s = 5 b2 = 10 b1
    (0.05, 1000.0, 1.0),  # b1/b2 = 1000, s = 0.05 b2
    (20.0, 1000.0, 1.0),  # s = 0.02 b1
    (5.0, 1.0, 1000.0),  # s = 5 b1 = 0.005 b2
]


@pytest.mark.parametrize("s, b1, b2", ANGLE_CASES)
def test_two_width_averages_against_angle_quadrature(s: float, b1: float, b2: float) -> None:
    """``two_width_averages`` (fine) against ``_angle_quadrature`` for ⟨1/r⟩ and ⟨s²/r³⟩, ±s.
    Measured over ``ANGLE_CASES``: ≤ 2.7e-12 (⟨1/r⟩, at b1/b2 = 1000, s = 0.05) and ≤ 1.1e-11
    (⟨s²/r³⟩, at b1/b2 = 1/1000, s = 5) relative — the fine rule, not the reference (which
    keeps 3e-15 where ``profile_averages`` can check it). Bounds 8e-12 and 3e-11 (3× and 2.7×).
    (The module docstring's "≤ 3e-12" holds for ⟨1/r⟩ only.)"""
    one, xx = sc.two_width_averages(np.array([s, -s]), b1, b2)
    ref_one, ref_xx = (_angle_quadrature(s, b1, b2, kernel) for kernel in (0, 1))
    assert np.all(np.abs(one / ref_one - 1.0) < 8e-12)
    assert np.all(np.abs(xx / ref_xx - 1.0) < 3e-11)


# ------------------------------------------------------------------------------------------
# 2. equal widths: the one-width rule; the lean rule against the fine one
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("b", [1.0, 1e-8, 3.7])
def test_two_width_averages_equal_widths(b: float) -> None:
    """At b1 = b2 = b the density (6) is (3): ``two_width_averages(s, b, b)`` (fine) against
    ``profile_averages(s, b)`` on 200 log-spaced s/b in [1e-6, 100]. Measured ≤ 4.8e-12
    (⟨1/r⟩) and ≤ 1.2e-11 (⟨s²/r³⟩, at s/b ≈ 3e-6 … 0.05; ≤ 8e-16 beyond s = 10 b) relative;
    bounds 1.2e-11 and 3e-11 (2.5×)."""
    s = b * np.exp(np.linspace(math.log(1e-6), math.log(100.0), 200))
    one, xx = sc.two_width_averages(s, b, b)
    ref_one, ref_xx = sc.profile_averages(s, b)
    assert np.max(np.abs(one / ref_one - 1.0)) < 1.2e-11
    assert np.max(np.abs(xx / ref_xx - 1.0)) < 3e-11


def test_two_width_averages_lean_against_fine() -> None:
    """The lean rule (``width_difference``'s exact average) against the fine one on 2000 random
    (s, b1, b2): b1 log-uniform in [1e-3, 1], b2/b1 in [1e-3, 1e3], s/max(b1, b2) in [1e-6, 10].
    Measured ≤ 2.0e-7 (⟨1/r⟩) and ≤ 5.8e-7 (⟨s²/r³⟩) relative; bound 1.5e-6 (2.6×). (At exactly
    equal widths and s ≲ 1e-5 b, which ``width_difference`` never sends it, the lean rule is
    off by up to 2.6e-6.)"""
    rng = np.random.default_rng(3)
    n = 2000
    b1 = np.exp(rng.uniform(math.log(1e-3), 0.0, n))
    b2 = b1 * np.exp(rng.uniform(math.log(1e-3), math.log(1e3), n))
    s = np.maximum(b1, b2) * np.exp(rng.uniform(math.log(1e-6), math.log(10.0), n))
    fine = sc.two_width_averages(s, b1, b2)
    lean = sc.two_width_averages(s, b1, b2, fine=False)
    for f, g in zip(fine, lean):
        assert np.max(np.abs(g / f - 1.0)) < 1.5e-6


# ------------------------------------------------------------------------------------------
# 3. the density's moments through the far series (5) with two widths
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("b1, b2", [(1.0, 1.0), (1.0, 1.001), (2.0, 1.0), (1.0, 1000.0), (3.7, 0.37), (1e-8, 3e-8)])
def test_two_width_averages_far_series(b1: float, b2: float) -> None:
    """At |s| = 200 max(b1, b2) ``two_width_averages`` (fine) equals ``series_averages(s, b1,
    b2)`` (⟨t²⟩ = (b1² + b2²)/2 and the higher moments of two arcsine laws; the series'
    truncation there is < 2e-17): measured ≤ 4.4e-16 relative, bound 1.3e-15 (3×). The
    deviations from the leading 1/|s| (s⟨k⟩ − 1, ≈ −⟨t²⟩/(2s²) and −3⟨t²⟩/(2s²), which test
    ⟨t²⟩ itself) agree to ≤ 5.3e-11 relative (the rounding of s⟨k⟩ − 1 ≈ 1e-5); bound 1.6e-10
    (3×)."""
    s = 200.0 * max(b1, b2) * np.array([1.0, -1.0])
    averages = sc.two_width_averages(s, b1, b2)
    series = sc.series_averages(s, b1, b2)
    for a, f in zip(averages, series):
        assert np.max(np.abs(a / f - 1.0)) < 1.3e-15
        assert np.max(np.abs((a * np.abs(s) - 1.0) / (f * np.abs(s) - 1.0) - 1.0)) < 1.6e-10


# ------------------------------------------------------------------------------------------
# 4. the spread table σ² q(σ), q = ½ ∂²⟨k⟩/∂ε² at half-widths 1 ± ε
# ------------------------------------------------------------------------------------------
def _moment_eps2(n: int) -> Fraction:
    """The ε² coefficient of ⟨t²ⁿ⟩, t = y − y', y and y' arcsine on [−(1 + ε), 1 + ε] and
    [−(1 − ε), 1 − ε]: ⟨t²ⁿ⟩ = Σ_k C(2n, 2k) m_2k m_(2n−2k) (1 + ε)^2k (1 − ε)^(2n−2k),
    m_2k = C(2k, k)/4ᵏ, and the ε² coefficient of (1 + ε)^a (1 − ε)^c is C(a, 2) + C(c, 2) − ac."""
    total = Fraction(0)
    for k in range(n + 1):
        a, c = 2 * k, 2 * n - 2 * k
        m = Fraction(math.comb(a, k), 4**k) * Fraction(math.comb(c, n - k), 4 ** (n - k))
        total += math.comb(2 * n, a) * m * (math.comb(a, 2) + math.comb(c, 2) - a * c)
    return total


def _binomial(alpha: Fraction, n: int) -> Fraction:
    out = Fraction(1)
    for j in range(n):
        out *= (alpha - j) / Fraction(j + 1)
    return out


def _q_series(sigma: float, terms: int) -> list[float]:
    """q(σ) for 1/r and s²/r³ from the binomial series of (1 + t²/σ²)^(−1/2) and ^(−3/2) over
    σ: Σ_n C(α, n) [ε²]⟨t²ⁿ⟩ / σ^(2n+1), n = 1 … ``terms`` (at σ = 10, |t| < 2: the terms fall
    by ≥ 25×)."""
    return [
        sum(float(_binomial(alpha, n) * _moment_eps2(n)) / sigma ** (2 * n + 1) for n in range(1, terms + 1))
        for alpha in (Fraction(-1, 2), Fraction(-3, 2))
    ]


def test_spread_table_at_the_series_end() -> None:
    """At σ = ``SPREAD_REACH`` = 10 the table's σ² q equals the series' ε² coefficient.

    The three terms (5) carry: [ε²]⟨t²⟩, ⟨t⁴⟩, ⟨t⁶⟩ = 1, 3/2, 15/4 (exact, ``_moment_eps2``),
    so q = −1/(2σ³) + 0.5625/σ⁵ − 1.171875/σ⁷ (1/r) and −3/(2σ³) + 2.8125/σ⁵ − 8.203125/σ⁷
    (s²/r³); ``series_averages(s, 1 + ε, 1 − ε)`` is a cubic in ε², whose ε² coefficient (solved
    exactly from ε = 0, 0.1, 0.2, 0.3) matches them: measured 5.1e-12 and 2.7e-13 (the solve's
    rounding), bound 1.5e-11 (3×). The
    table against the converged series (13 terms): measured 1.4e-10 and 2.2e-10 relative,
    bound 6e-10 (2.7×) (13 or 20 terms: the same to the last bit); the three-term q differs
    from it by the truncation, 5.9e-6 and 1.77e-5 (bound 2e-5: exact arithmetic, no margin needed)."""
    assert [_moment_eps2(n) for n in (1, 2, 3)] == [1, Fraction(3, 2), Fraction(15, 4)]
    three_coefficients = [
        [float(_binomial(alpha, n) * _moment_eps2(n)) for n in (1, 2, 3)]
        for alpha in (Fraction(-1, 2), Fraction(-3, 2))
    ]
    assert three_coefficients == [[-0.5, 0.5625, -1.171875], [-1.5, 2.8125, -8.203125]]
    sigma = sc.SPREAD_REACH
    three = [c[0] / sigma**3 + c[1] / sigma**5 + c[2] / sigma**7 for c in three_coefficients]
    # series_averages' own ε² coefficient: a cubic in e = ε² through four points
    eps = np.array([0.0, 0.1, 0.2, 0.3])
    values = np.array(sc.series_averages(np.full(4, sigma), 1.0 + eps, 1.0 - eps))
    vandermonde = np.vander(eps**2, 4, increasing=True)
    for k in (0, 1):
        coefficient = np.linalg.solve(vandermonde, values[k])[1]
        assert abs(coefficient / three[k] - 1.0) < 1.5e-11
    table = sc._log_chebyshev_sum(sc._spread_table(), np.array([sigma]))
    converged = _q_series(sigma, 13)
    for k in (0, 1):
        assert abs(table[k][0] / sigma**2 / converged[k] - 1.0) < 6e-10
        assert abs(three[k] / converged[k] - 1.0) < 2e-5


def test_spread_table_against_finite_differences() -> None:
    """The table's σ² q at 60 log-uniform σ in [1e-4, 10] (and the ends) against a Richardson
    difference of ``two_width_averages`` (fine) at ε = σ/40 and σ/80 (the table used
    ε = min(0.01, σ/20) and 2ε): q ≈ (4 D(σ/80) − D(σ/40))/3, D(ε) = (⟨k⟩(1 ± ε) − ⟨k⟩(1))/ε².
    This reference is converged to its rounding: ε = σ/60, σ/120 moves it by ≤ 3.0e-7 and
    7.1e-7 of q.

    Measured: for σ ≥ 1, ≤ 3.8e-7 (⟨1/r⟩) and ≤ 8.9e-7 (⟨s²/r³⟩) relative (the reference's
    level), bounds 1e-6 and 2.5e-6 (2.6×, 2.8×); for σ < 1, ≤ 7.0e-5 and ≤ 2.0e-4, bounds 1.8e-4
    and 5.2e-4 (2.6×) — the
    table's own Richardson step at ε = σ/20, 2ε = σ/10 (below σ = 0.2) leaves that much: its
    O(ε⁴) remainder, the same at every small σ since it depends on ε/σ alone. (It reaches
    ``width_difference`` only through ε² q, at most 2.5e-5 σ² q of ⟨k⟩: ≤ 3e-9 of ⟨k⟩.)"""
    rng = np.random.default_rng(4)
    sigma = np.concatenate([np.exp(rng.uniform(math.log(1e-4), math.log(10.0), 60)), [1e-4, 0.2, 1.0, 10.0]])
    ones = np.ones_like(sigma)
    base = np.array(sc.two_width_averages(sigma, ones, ones))

    def D(eps: np.ndarray) -> np.ndarray:
        return (np.array(sc.two_width_averages(sigma, 1.0 + eps, 1.0 - eps)) - base) / eps**2

    q = (4.0 * D(sigma / 80.0) - D(sigma / 40.0)) / 3.0
    table = sc._log_chebyshev_sum(sc._spread_table(), sigma)
    wide = sigma >= 1.0
    for k, (bound_wide, bound_narrow) in enumerate(((1e-6, 1.8e-4), (2.5e-6, 5.2e-4))):
        error = np.abs(table[k] / (q[k] * sigma**2) - 1.0)
        assert np.max(error[wide]) < bound_wide
        assert np.max(error[~wide]) < bound_narrow


# ------------------------------------------------------------------------------------------
# 5. width_difference in its three regimes against the exact difference
# ------------------------------------------------------------------------------------------
def _exact_difference(s: np.ndarray, b1: np.ndarray, b2: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """⟨k⟩(s; b1, b2) − ⟨k⟩(s; b, b) by ``two_width_averages`` (fine), and ⟨k⟩(s; b, b)."""
    both = np.array(sc.two_width_averages(s, b1, b2))
    one = np.array(sc.two_width_averages(s, b, b))
    return both - one, one


def _regime_errors(s: np.ndarray, b1: np.ndarray, b2: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, ...]:
    """|width_difference − exact| for both kernels, the exact differences and ⟨k⟩(b)."""
    got = np.array(sc.width_difference(s, b1, b2, b))
    exact, one = _exact_difference(s, b1, b2, b)
    return np.abs(got - exact), exact, one


def _widths(rng: np.random.Generator, n: int, spread: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """b log-uniform in [1e-3, 1]; b1, b2 = b (1 ± up to ``spread``), independent."""
    b = np.exp(rng.uniform(math.log(1e-3), 0.0, n))
    return b, b * (1.0 + rng.uniform(-spread, spread, n)), b * (1.0 + rng.uniform(-spread, spread, n))


def test_width_difference_far() -> None:
    """|s| ≥ ``SPREAD_REACH`` max(b1, b2, b): the series (5) with two widths less that with one.
    3000 points, b1, b2 within ±30 % of b, |s|/max in [10, 1000] (half of them in [10, 11]).
    Error relative to ⟨k⟩: measured ≤ 4.5e-8 and ≤ 4.0e-7 (the series' truncation at σ ≈ 10),
    bounds 1.2e-7 and 1.1e-6 (2.7×); relative to the difference where it is ≥ 1e-4 ⟨k⟩ (56 %
    and 64 % of the points): ≤ 3.8e-5 and ≤ 1.6e-4, bounds 1e-4 and 4e-4 (2.6×, 2.5×)."""
    rng = np.random.default_rng(7)
    n = 1500
    b, b1, b2 = (np.concatenate(pair) for pair in zip(_widths(rng, n, 0.3), _widths(rng, n, 0.3)))
    top = np.maximum(np.maximum(b1, b2), b)
    reach = np.concatenate([np.exp(rng.uniform(math.log(10.0), math.log(1000.0), n)), rng.uniform(10.0, 11.0, n)])
    s = top * reach * rng.choice([-1.0, 1.0], 2 * n)
    assert np.all(np.abs(s) >= sc.SPREAD_REACH * top)
    error, exact, one = _regime_errors(s, b1, b2, b)
    for k, (to_k, to_difference) in enumerate(((1.2e-7, 1e-4), (1.1e-6, 4e-4))):
        assert np.max(error[k] / one[k]) < to_k
        large = np.abs(exact[k]) >= 1e-4 * one[k]
        assert large.mean() > 0.5
        assert np.max(error[k][large] / np.abs(exact[k][large])) < to_difference


def test_width_difference_expansion() -> None:
    """|b1 − b2| ≤ 2 ``SLOPE_LIMIT`` |s| (below the reach): ⟨k⟩(b̄) − ⟨k⟩(b) + ε² q(σ)/b̄³.

    With b = b̄ (the difference is the ε² term alone) and |ε|/|s| in [0.0025, 0.0049]: for
    σ = |s|/b̄ in [1, 9.5], where the table q is good to 1e-6, the error relative to the
    difference is the expansion's, measured ≤ 1.7 (ε/s)² and ≤ 2.8 (ε/s)² (the module's
    "≈ 2(ε/s)²"; with the converged q on a σ grid: 1.3 … 1.7 and 2.5 … 2.8 (ε/s)²), bound
    7 (ε/s)² (2.5× the larger);
    for σ in [1e-4, 1) measured ≤ 6.2e-5 and ≤ 1.9e-4 (the table's q, test above), bounds
    1.6e-4 and 4.8e-4 (2.5×). With b within ±1 % of b̄ (⟨k⟩(b̄) − ⟨k⟩(b) dominates) the error
    relative to ⟨k⟩: measured ≤ 4.8e-10 and ≤ 3.0e-9, bounds 1.3e-9 and 8e-9 (2.7×)."""
    rng = np.random.default_rng(8)
    n = 1500
    b = np.exp(rng.uniform(math.log(1e-3), 0.0, 3 * n))
    sigma = np.concatenate(
        [
            np.exp(rng.uniform(0.0, math.log(9.5), n)),
            np.exp(rng.uniform(math.log(1e-4), 0.0, n)),
            np.exp(rng.uniform(math.log(1e-4), math.log(9.5), n)),
        ]
    )
    slope = rng.uniform(0.0025, 0.0049, 3 * n) * rng.choice([-1.0, 1.0], 3 * n)
    s = sigma * b * rng.choice([-1.0, 1.0], 3 * n)
    eps = slope * np.abs(s)
    b1, b2 = b + eps, b - eps
    single = b.copy()
    single[2 * n :] *= 1.0 + rng.uniform(-1e-2, 1e-2, n)
    assert np.all(np.abs(b1 - b2) <= 2.0 * sc.SLOPE_LIMIT * np.abs(s))
    assert np.all(np.abs(s) < sc.SPREAD_REACH * np.maximum(np.maximum(b1, b2), single))
    error, exact, one = _regime_errors(s, b1, b2, single)
    wide, narrow, shifted = slice(0, n), slice(n, 2 * n), slice(2 * n, 3 * n)
    for k, narrow_bound, to_k in ((0, 1.6e-4, 1.3e-9), (1, 4.8e-4, 8e-9)):
        relative = error[k] / np.abs(exact[k])
        assert np.max(relative[wide] / slope[wide] ** 2) < 7.0
        assert np.max(relative[narrow]) < narrow_bound
        assert np.max(error[k][shifted] / one[k][shifted]) < to_k


def test_width_difference_steep() -> None:
    """|b1 − b2| > 2 ``SLOPE_LIMIT`` |s| (near an ellipse's tips): the lean exact average less
    ⟨k⟩(b). 3000 points, b1, b2 within ±50 % of b, |s| from 1e-3 to 1 × the smaller of
    |b1 − b2|/(2 ``SLOPE_LIMIT``) and ``SPREAD_REACH`` max(b1, b2, b) (|ε|/|s| from 0.005 to
    30). Error relative to ⟨k⟩: measured ≤ 2.9e-7 and ≤ 5.1e-7 (the lean rule), bound 1.3e-6
    (2.5×); relative to the difference (here ≥ 1e-4 ⟨k⟩ at every point): ≤ 2.4e-4 and ≤ 7.2e-4,
    bounds 6e-4 and 1.8e-3 (2.5×).

    Just past the limit with b = b̄ the difference is the small ε² term alone: 1000 points with
    |ε|/|s| in (0.005, 0.01], σ in [1e-4, 9]: relative to ⟨k⟩ measured ≤ 2.4e-7 and ≤ 5.4e-7
    (bound 1.3e-6 as above), but that is up to 30 % of the difference of ⟨1/r⟩ and 5.6 % of
    ⟨s²/r³⟩'s (at σ ≈ 1e-4; not asserted: the lean rule's floor against a difference of ~7e-7 ⟨k⟩;
    the expansion would leave 2.8 (ε/s)² ≤ 3e-4 there)."""
    rng = np.random.default_rng(9)
    n = 3000
    b, b1, b2 = _widths(rng, n, 0.5)
    top = np.maximum(np.maximum(b1, b2), b)
    reach = np.minimum(np.abs(b1 - b2) / (2.0 * sc.SLOPE_LIMIT), sc.SPREAD_REACH * top)
    s = reach * np.exp(rng.uniform(math.log(1e-3), -1e-9, n))
    assert np.all(0.5 * np.abs(b1 - b2) > sc.SLOPE_LIMIT * s)
    assert np.all(s < sc.SPREAD_REACH * top)
    error, exact, one = _regime_errors(s, b1, b2, b)
    for k, to_difference in ((0, 6e-4), (1, 1.8e-3)):
        assert np.max(error[k] / one[k]) < 1.3e-6
        large = np.abs(exact[k]) >= 1e-4 * one[k]
        assert large.mean() > 0.9
        assert np.max(error[k][large] / np.abs(exact[k][large])) < to_difference
    m = 1000
    b = np.exp(rng.uniform(math.log(1e-3), 0.0, m))
    s = b * np.exp(rng.uniform(math.log(1e-4), math.log(9.0), m))
    eps = s * rng.uniform(0.00501, 0.01, m) * rng.choice([-1.0, 1.0], m)
    assert np.all(np.abs(eps) > sc.SLOPE_LIMIT * s)
    error, exact, one = _regime_errors(s, b + eps, b - eps, b)
    for k in (0, 1):
        assert np.max(error[k] / one[k]) < 1.3e-6


# ------------------------------------------------------------------------------------------
# 6. width_corrections of an ellipse's near pairs against brute-force double integrals
# ------------------------------------------------------------------------------------------
ELLIPSE_B0 = 0.01


def _width(lo: float, offset: np.ndarray) -> np.ndarray:
    """b(x) = b₀ √((1 − x)(1 + x)) at x = lo + ``offset``, 1 + x formed as (1 + lo) + offset
    (at the tip lo = −1 it keeps its digits)."""
    return ELLIPSE_B0 * np.sqrt(np.maximum((1.0 - lo - offset) * ((1.0 + lo) + offset), 0.0))


def _graded(ratio: float, panels: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre on (0, 1) on panels [ratio^(k+1), ratio^k], k < ``panels``, and
    [0, ratio^panels]."""
    x, w = np.polynomial.legendre.leggauss(points)
    edges = np.concatenate([[0.0], ratio ** np.arange(panels, -1, -1, dtype=np.float64)])
    lo, hi = edges[:-1, None], edges[1:, None]
    return (lo + 0.5 * (hi - lo) * (x + 1.0)).ravel(), (0.5 * (hi - lo) * w).ravel()


def _graded_both(ratio: float, panels: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """``_graded`` on each half of (0, 1), toward 0 and toward 1."""
    u, w = _graded(ratio, panels, points)
    return np.concatenate([0.5 * u, 1.0 - 0.5 * u[::-1]]), np.concatenate([0.5 * w, 0.5 * w[::-1]])


def _brute_difference(s: np.ndarray, b1: np.ndarray, b2: np.ndarray, b: np.ndarray) -> np.ndarray:
    """⟨k⟩(s; b1, b2) (``two_width_averages``, fine) − ⟨k⟩(s; b) (``profile_averages``, scaled)."""
    return np.array(sc.two_width_averages(s, b1, b2)) - np.array(sc.profile_averages(s / b, 1.0)) / b


RULE = (0.25, 8, 6)  # brute force: panel ratio, panels, Gauss points per panel


def _brute_self(lo: float, h: float) -> np.ndarray:
    """∫_I∫_I [⟨k⟩(x − x'; b(x), b(x')) − ⟨k⟩(x − x'; b(m))] dx' dx, m = (x + x')/2, I = [lo,
    lo + h]: twice the half x > x', in s = x − x' ∈ (0, h) (graded toward s = 0) and
    x' = lo + (h − s) v, v ∈ (0, 1) (graded toward both ends: the tip's √ at v = 0). ``RULE``
    against one with 14 and 18 panels of 10 points: ≤ 1.9e-6 of the corrections below; the
    (m, s) parametrization of the code gives the same to ≤ 3.4e-10 (measured)."""
    ratio, panels, points = RULE
    s, ws = _graded(ratio, panels, points)
    v, wv = _graded_both(ratio, panels, points)
    S = h * s[:, None] * np.ones_like(v)
    A = (h - S) * v
    W = 2.0 * (h * ws)[:, None] * (h - S) * wv
    D = _brute_difference(S.ravel(), _width(lo, A + S).ravel(), _width(lo, A).ravel(), _width(lo, A + 0.5 * S).ravel())
    return (D * W.ravel()).sum(axis=1)


def _brute_touching(lo: float, corner: float, h_next: float) -> np.ndarray:
    """The same for I = [lo, c], J = [c, c + h'] with the single width b(c): x = c − p,
    x' = c + q, a tensor rule in p and q graded toward both ends of each (the corner and, for
    the tip strip, the tip). ``RULE`` against the finer one: ≤ 2.7e-6 (measured)."""
    ratio, panels, points = RULE
    h = corner - lo
    u, w = _graded_both(ratio, panels, points)
    P, Q = np.meshgrid(h * u, h_next * u, indexing="ij")
    W = np.outer(h * w, h_next * w).ravel()
    b = np.full(P.size, _width(lo, np.array(h)))
    D = _brute_difference((P + Q).ravel(), _width(lo, h - P).ravel(), _width(corner, Q).ravel(), b)
    return (D * W).sum(axis=1)


# (i, j, bound ⟨1/r⟩, bound ⟨s²/r³⟩): 2.5× the relative error of width_corrections measured
# against the brute force [in brackets; the correction's size relative to the entry B_ij after
# the brackets, and what the error is of B_ij]. graded_edges(16): strip 0 = [−1, −0.998] (the
# tip), 7 = [−0.330, 0].
CORRECTION_PAIRS = [
    (0, 0, 5.5e-3, 2.2e-2),  # [2.2e-3, 8.8e-3]; 4.9e-3, 2.0e-2 of B_00; 1.1e-5, 1.8e-4 of B_00
    (0, 1, 3.1e-4, 3.7e-4),  # [1.25e-4, 1.47e-4]; 3.4e-3, 1.1e-2; 4.2e-7, 1.6e-6
    (7, 7, 2.3e-3, 7e-4),  # [9.2e-4, 2.8e-4]; 6.2e-6, 2.1e-5; 5.7e-9, 5.8e-9
    (7, 8, 5.3e-6, 1.7e-5),  # [2.1e-6, 6.6e-6]; 1.5e-5, 4.5e-5; 3e-11, 3e-10
]


@functools.cache
def _ellipse_corrections() -> tuple[np.ndarray, np.ndarray]:
    edges = sc.graded_edges(16)
    i, j = (np.array([p[k] for p in CORRECTION_PAIRS]) for k in (0, 1))
    return np.array(sc.width_corrections(edges, sc.Outline("ellipse", ELLIPSE_B0), (i, j))), edges


@pytest.mark.parametrize("index", range(len(CORRECTION_PAIRS)))
def test_width_corrections_against_brute_force(index: int) -> None:
    """``width_corrections`` for the b/a = 0.01 ellipse on ``graded_edges(16)`` against
    ``_brute_self`` / ``_brute_touching`` (the bounds: ``CORRECTION_PAIRS``). The self pair of
    the tip strip is the loosest (0.9 % of its ⟨s²/r³⟩ correction, 1.8e-4 of B_00): the code's
    6 ungraded points in m along a strip on which b has its √ at the tip (grading them, tried,
    took it to 5.1e-6 and the first grids' K errors from ≤ 9.4e-8 to ≤ 2.3e-8; not kept: its
    recalibration was not finished)."""
    i, j, bound_one, bound_xx = CORRECTION_PAIRS[index]
    corrections, edges = _ellipse_corrections()
    lo, hi = edges[:-1], edges[1:]
    reference = _brute_self(lo[i], hi[i] - lo[i]) if i == j else _brute_touching(lo[i], hi[i], hi[j] - lo[j])
    assert abs(corrections[0][index] / reference[0] - 1.0) < bound_one
    assert abs(corrections[1][index] / reference[1] - 1.0) < bound_xx


# ------------------------------------------------------------------------------------------
# 7. end to end: the ellipse's K against Mindlin and Galin, and without the corrections
# ------------------------------------------------------------------------------------------
def _exact_stiffness(aspect: float, nu: float) -> dict[str, float]:
    K_xx, K_yy = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
    return {"xx": K_xx, "yy": K_yy, "zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu)}


#: n: the bound on |K/K_exact − 1| over aspect 0.7, 0.05, 1e-2, nu 0 and 0.5, xx, yy, zz:
#: measured ≤ 5.85e-8 (n = 16: 0.05, xx, nu 0.5) and ≤ 1.73e-8 (n = 32: 0.7, xx, nu 0.5);
#: bounds 2.6×. ``model_error`` (the level settled with n: 5e-8, 4e-8, 8e-9 at these aspects)
#: is not a bound at n = 16 (it is below the measured 5.7e-8 at 0.05 and 5.8e-8 at 1e-2).
ELLIPSE_BOUND = {16: 1.5e-7, 32: 4.5e-8}


@pytest.mark.parametrize("n", [16, 32])
@pytest.mark.parametrize("aspect", [0.7, 0.05, 1e-2])
def test_ellipse_strips_against_mindlin_and_galin(aspect: float, n: int) -> None:
    """The strips contain Galin's and Mindlin's traction (f constant), so K is theirs up to the
    integrals: ``StripCells(..., shape="ellipse")`` K_xx, K_yy (Mindlin) and K_zz (Galin) for
    nu 0 and 0.5 within ``ELLIPSE_BOUND[n]``."""
    for nu in (0.0, 0.5):
        strips = sc.StripCells(aspect, n, Isotropic(1.0, nu), shape="ellipse")
        exact = _exact_stiffness(aspect, nu)
        for block in sc.BLOCKS:
            assert abs(strips.solve(block)[0] / exact[block] - 1.0) < ELLIPSE_BOUND[n], (nu, block)


def test_ellipse_needs_the_width_corrections(monkeypatch: pytest.MonkeyPatch) -> None:
    """Without (7) (``width_corrections`` returning zeros) the b/a = 0.05 ellipse on 32 strips,
    nu 0.5, is off by −3.90e-4 (K_xx), +6.07e-5 (K_yy), −2.12e-4 (K_zz) (measured; −2.12e-4 for
    all three at nu 0): assert > 2e-5 (3× below the smallest), against ≤ 1.5e-8 with them."""
    monkeypatch.setattr(
        sc, "width_corrections", lambda edges, outline, pairs: (np.zeros(pairs[0].size), np.zeros(pairs[0].size))
    )
    strips = sc.StripCells(0.05, 32, Isotropic(1.0, 0.5), shape="ellipse")
    exact = _exact_stiffness(0.05, 0.5)
    for block in sc.BLOCKS:
        assert abs(strips.solve(block)[0] / exact[block] - 1.0) > 2e-5, block
