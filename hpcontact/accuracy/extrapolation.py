r"""Richardson extrapolation over a grid sequence and its error estimate (the estimator of
``hpcontact.accuracy``; which cells and grids it runs on: ``hpcontact.accuracy.strategies``).

Extrapolation and the estimate
------------------------------
Grids n_k = n₀ 2^k (and n_across likewise, so every cell keeps its aspect ratio; refinement
ratio r = 2, Roache's recommendation r ≥ 1.3 with room to spare), at least four of them. The
estimator assumes no particular discretization: it asks the sequence which expansion it follows.
For each tensor entry Q (K_xx, K_xy, K_yx, K_yy, K_zz, …) and each candidate expansion

    Q_k = Q* + Σ_i c_i h_k^(p_i),     p ∈ {}, {1}, {1, 2}, {1, 1.5}, {1, 2, 3}, {1.5}, {2}, {1.5, 2}, {2, 3}

(``EXPANSIONS``: order-1 leads for coverage-weighted cells, whose edge layer of the square-root
traction gives c₁ h; 1.5 and 2 leads for a treatment that resolves the edge; {} for an error
without a steady sign, the finest value as it is) whose leading exponent is at most the raw
sequence's observed order + 0.5,

    p_obs = ln(|Q_{k−1} − Q_{k−2}| / |Q_k − Q_{k−1}|) / ln r,

the generalized Richardson extrapolant E_j (Richardson 1911; Roache 1998 §5.4) of every window
of m + 1 consecutive grids is computed. How E_j moves from window to window is the evidence
(:func:`spread`): with d_j = E_j − E_{j−1},

* d_k, d_{k−1} of opposite sign (oscillation): s = max(|d_k|, |d_{k−1}|/4);
* else the fall ρ = |d_{k−1}/d_k| is credited only when it shows twice and no more than its
  trend predicts (ρ = min(ρ₁, ρ₂, ρ₂²/ρ₁) of the last two ratios, within [2, 16]; 2 otherwise),
  and s = max(|d_k|/(ρ − 1), |d_{k−1}|/max(16, ρ^1.5)):
  the geometric tail of a sequence falling by ρ per level, guarded against a last difference
  small by accident (a zero crossing).

The expansion of least s wins: value = its last E, error = 3 s (``SAFETY``). No expansion fits
(a raw sequence that does not converge): the finest value with Roache's two-grid bound 3 |ΔQ|.

Off-diagonal entries are relative to the largest diagonal entry. Ratios (K_a/K_b = K_xx/K_yy,
Li's normalized stiffnesses ∝ K_xx/K_zz, K_yy/K_zz, K_min/K_max) get the estimate of their own sequence
plus its distance from the ratio of the extrapolated entries, and at least half the sum of the
entries' relative estimates (``RATIO_SHARE``: the errors share their sign and cancel in part, so
the sum is pessimistic, but the ratio's own sequence alone fell below its true error at b/a =
1e-3 and 0.05), and at most (e_top + e_bottom)/(1 − e_bottom), the most the entries' estimates
allow. K_max and K_min get the spectral norm of the entries' error bounds (Weyl; see
:func:`principal_error`).
``estimated_error`` is the largest of all.

Calibration (``benchmarks/accuracy_sharpness.py``; SAFETY, the guard 16 and ρ^1.5 were chosen
on it): 24 cases with closed forms (circle and Mindlin ellipses b/a = 0.7 … 1e-8, nu = 0, 0.3,
0.5), requests 1e-3 … 1e-6, sequences from n₀ = 16 and 32 up to n = 1024: the reported
estimate is above the largest true error of K_xx, K_yy, K_zz, K_a/K_b, K_xx/K_zz, K_yy/K_zz in
all 336 records and within 30× of it in most (docs/validation.md §"Calibration on
coverage-weighted cells"). Singular cells' sequences get their own candidates and factor
(below).

References: L. F. Richardson, Phil. Trans. R. Soc. A 210, 307–357 (1911); P. J. Roache,
*Verification and Validation in Computational Science and Engineering*, Hermosa, 1998.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from hpcontact import quantities as q

MIN_GRIDS = 4  # three extrapolants of the leading order, so that their own convergence can be checked
RATIO = 2.0  # grid refinement ratio r (Roache 1998 recommends r ≥ 1.3; 2 keeps h-levels apart)
#: Candidate error expansions Q_k = Q* + Σ c_i h_k^(p_i): the exponents p_i of each. Order-1
#: sets describe coverage-weighted cells (edge layer of the square-root traction); the 1.5 and 2
#: leads a treatment that resolves the edge; the empty set takes the finest grid's value as it
#: is (an error without a steady sign, as ``hpcontact.discretizations.singular_cells`` measures for its cells).
#: Which one the data follow is decided per sequence (``estimate``), never assumed.
EXPANSIONS: tuple[tuple[float, ...], ...] = (
    (),
    (1.0,),
    (1.0, 2.0),
    (1.0, 1.5),
    (1.0, 2.0, 3.0),
    (1.5,),
    (2.0,),
    (1.5, 2.0),
    (2.0, 3.0),
)
LEAD_SLACK = 0.5  # an expansion may lead with an exponent up to the raw sequence's observed order + 0.5
SAFETY = 3.0  # estimate = SAFETY × the spread of the chosen extrapolant (calibrated, module docstring)
SAFETY_TWO_GRID = 3.0  # Roache's F_s when only two grids are trustworthy (no expansion fits)
FASTEST_FALL = 16.0  # an extrapolant's error falls at most this much per level unless it shows more twice
GUARD_EXPONENT = 1.5  # a fall ρ shown twice lets the previous difference over ρ^1.5 bound the error
OSCILLATION_FALL = 4.0  # an oscillating extrapolant's swing shrinks at most this much per level
TENSOR_KEYS = (
    "K_xx",
    "K_xy",
    "K_yx",
    "K_yy",
    "K_zz",
    "K_xz",
    "K_yz",
    "K_zx",
    "K_zy",
    "K_zz_bonded",
    "K_xx_coupled",
    "K_xy_coupled",
    "K_yx_coupled",
    "K_yy_coupled",
)
RATIO_SHARE = 0.5  # K_a/K_b: at least half the sum of K_xx's and K_yy's estimates (module docstring)


def extrapolant(values: Sequence[float], exponents: Sequence[float], ratio: float = RATIO) -> float:
    """Q* of the expansion Q_j = Q* + Σ_i c_i h_j^(p_i) through the m + 1 values on grids
    h_j = r^(−j) (j = 0 … m, m = len(exponents)): generalized Richardson extrapolation
    (Richardson 1911; Roache 1998 §5.4), exact for that expansion."""
    if len(values) != len(exponents) + 1:
        raise ValueError("an expansion with m exponents takes m + 1 values")
    return float(
        np.dot(_weights(tuple(float(p) for p in exponents), float(ratio)), np.asarray(values, dtype=np.float64))
    )


@functools.lru_cache(maxsize=64)
def _weights(exponents: tuple[float, ...], ratio: float) -> np.ndarray:
    """Row of the inverse of [1, h_j^p_1, …, h_j^p_m] that gives Q* (the same for every window)."""
    h = ratio ** -np.arange(len(exponents) + 1, dtype=np.float64)
    A = np.column_stack([np.ones_like(h)] + [h**p for p in exponents])
    return np.linalg.solve(A.T, np.eye(len(h))[0])


def observed_order(q0: float, q1: float, q2: float, ratio: float = RATIO) -> float:
    """Observed order ln(|q1 − q0| / |q2 − q1|)/ln r of three grids h, h/r, h/r² (NaN if flat)."""
    d0, d1 = abs(q1 - q0), abs(q2 - q1)
    if d0 == 0.0 or d1 == 0.0:
        return math.nan
    return math.log(d0 / d1) / math.log(ratio)


def spread(extrapolants: Sequence[float]) -> float:
    """Estimated error of the last of a sequence of extrapolants E_j on successive windows.

    With the differences d_j = E_j − E_{j−1} (the last three at most): if the last two have
    opposite signs, the swing max(|d_k|, |d_{k−1}|/``OSCILLATION_FALL``); else the fall
    ρ = |d_{k−1}/d_k| is credited only when it shows twice and no more than its trend predicts
    for the next level (with ρ₁ = |d_{k−2}/d_{k−1}|, ρ₂ = |d_{k−1}/d_k|: ρ = min(ρ₁, ρ₂, ρ₂²/ρ₁)
    within [2, ``FASTEST_FALL``]; 2 with fewer than three differences), and the error is

        max(|d_k| / (ρ − 1),  |d_{k−1}| / max(FASTEST_FALL, 2ρ)):

    the geometric tail of a sequence that falls by ρ per level, guarded against a last
    difference that is small by accident (a zero crossing).
    """
    d = np.diff(np.asarray(extrapolants, dtype=np.float64))[-3:]
    last, before = float(d[-1]), float(d[-2])
    if last * before < 0.0:
        return max(abs(last), abs(before) / OSCILLATION_FALL)
    fall = 2.0
    if len(d) == 3 and d[0] * d[1] > 0.0 and last != 0.0:
        early, late = abs(d[0] / d[1]), abs(before / last)
        fall = max(2.0, min(early, late, late * late / early, FASTEST_FALL))
    return max(abs(last) / (fall - 1.0), abs(before) / max(FASTEST_FALL, fall**GUARD_EXPONENT))


@dataclasses.dataclass(frozen=True)
class Estimate:
    """Extrapolated ``value`` of one quantity, its estimated absolute ``error``, the observed
    order of the raw sequence and the expansion (exponents) the value comes from (empty when
    no expansion fits and the finest grid's value is given with a two-grid bound)."""

    value: float
    error: float
    order: float
    expansion: tuple[float, ...]


def estimate(
    values: Sequence[float],
    ratio: float = RATIO,
    expansions: Sequence[tuple[float, ...]] | None = None,
    safety: float | None = None,
) -> Estimate:
    """Extrapolated value and error estimate from a sequence on grids h, h/r, h/r², ….

    Needs ``MIN_GRIDS`` values. For every candidate expansion of ``EXPANSIONS`` (m exponents)
    whose leading exponent is at most the raw sequence's observed order + ``LEAD_SLACK`` and
    for which the grids give three windows of m + 1 values, the extrapolants E_j of the
    successive windows and their :func:`spread` are computed; the expansion of least spread
    wins, value = its last extrapolant, error = ``SAFETY`` × its spread (module docstring).
    No fitting expansion (a raw sequence that does not converge): the finest value with
    Roache's two-grid bound 3 |Q_k − Q_{k−1}|. ``expansions``: the candidates (default
    ``EXPANSIONS``; ``SINGULAR_EXPANSIONS`` for singular cells) and ``safety`` (default ``SAFETY``;
    ``SINGULAR_SAFETY`` for singular cells) the factor on the spread.
    """
    Q = [float(v) for v in values]
    if len(Q) < MIN_GRIDS:
        raise ValueError(f"an estimate needs at least {MIN_GRIDS} grids")
    p = observed_order(Q[-3], Q[-2], Q[-1], ratio)
    floor = 8.0 * np.finfo(float).eps
    best: Estimate | None = None
    for exponents in EXPANSIONS if expansions is None else expansions:
        m = len(exponents)
        if len(Q) < m + 3 or (exponents and math.isfinite(p) and exponents[0] > p + LEAD_SLACK):
            continue
        E = [extrapolant(Q[j - m : j + 1], exponents, ratio) for j in range(m, len(Q))]
        error = max((SAFETY if safety is None else safety) * spread(E), floor * abs(E[-1]))
        if best is None or error < best.error:
            best = Estimate(value=E[-1], error=error, order=p, expansion=tuple(exponents))
    if best is None:
        best = Estimate(
            value=Q[-1], error=max(SAFETY_TWO_GRID * abs(Q[-1] - Q[-2]), floor * abs(Q[-1])), order=p, expansion=()
        )
    return best


def extrapolate(
    levels: Sequence[Mapping[str, Any]],
    expansions: Sequence[tuple[float, ...]] | None = None,
    safety: float | None = None,
) -> tuple[dict[str, float], dict[str, float], dict[str, float], dict[str, list[float]]]:
    """Extrapolated tensor entries, their estimated relative errors, observed orders and the
    expansion each value comes from.

    Tensor entries (``TENSOR_KEYS`` present in the records) are extrapolated one by one
    (:func:`estimate`); K_xx, K_yy, K_zz relative to themselves, off-diagonal entries relative to
    the largest diagonal entry. K_a/K_b = K_xx/K_yy of the extrapolated entries; its estimate is
    that of its own sequence (K_xx/K_yy per grid) plus the distance between its extrapolant and
    the ratio of extrapolants, and at least ``RATIO_SHARE`` (e_xx + e_yy) (:func:`ratio_error`;
    Li's K_xx E*/(K_zz G*) and K_yy E*/(K_zz G*) likewise with K_zz); K_max and K_min get
    :func:`principal_error` / K (Weyl: an eigenvalue moves by at most the perturbation's norm),
    and K_min/K_max the ratio rule on K_min and K_max per grid.
    """
    estimates = {
        k: estimate([r[k] for r in levels], expansions=expansions, safety=safety)
        for k in TENSOR_KEYS
        if k in levels[-1]
    }
    values = {k: e.value for k, e in estimates.items()}
    diagonal = [abs(values[k]) for k in ("K_xx", "K_yy", "K_zz") if k in values]
    scale = max(diagonal) if diagonal else 1.0
    relative: dict[str, float] = {}
    for key, e in estimates.items():
        own = key in ("K_xx", "K_yy", "K_zz")
        relative[key] = e.error / max(abs(e.value) if own else scale, 1e-300)
    if "K_xx" in relative and "K_yy" in relative:
        relative["K_a_over_K_b"] = ratio_error(levels, "K_xx", "K_yy", values, relative, expansions, safety)
        bound = principal_error(*(estimates[k].error for k in ("K_xx", "K_xy", "K_yx", "K_yy")))
        K2 = np.array([[values["K_xx"], values["K_xy"]], [values["K_yx"], values["K_yy"]]])
        k_max, k_min, _ = q.principal_stiffness(K2)
        relative["K_max"] = bound / max(abs(k_max), 1e-300)
        relative["K_min"] = bound / max(abs(k_min), 1e-300)
        principal = {**values, "K_max": k_max, "K_min": k_min}
        relative["K_min_over_K_max"] = ratio_error(levels, "K_min", "K_max", principal, relative, expansions, safety)
        if "K_zz" in relative:
            relative["normalized_xx"] = ratio_error(levels, "K_xx", "K_zz", values, relative, expansions, safety)
            relative["normalized_yy"] = ratio_error(levels, "K_yy", "K_zz", values, relative, expansions, safety)
    orders = {k: e.order for k, e in estimates.items()}
    expansions = {k: list(e.expansion) for k, e in estimates.items()}
    return values, relative, orders, expansions


def principal_error(e_xx: float, e_xy: float, e_yx: float, e_yy: float) -> float:
    """Bound on the error of K_max and K_min (the eigenvalues of the symmetric part of the
    in-plane tensor, ``quantities.principal_stiffness``) from bounds on its entries' errors.

    The symmetric part's error E = (δK + δKᵀ)/2 is symmetric with |E| ≤ B entrywise,
    B = [[e_xx, c], [c, e_yy]], c = (e_xy + e_yx)/2. Weyl's inequality (Horn & Johnson, Matrix
    Analysis, 2nd ed., Thm 4.3.1): |λᵢ(K + E) − λᵢ(K)| ≤ ‖E‖₂ for symmetric K and E. For symmetric
    E, ‖E‖₂ = ρ(E) ≤ ρ(|E|) ≤ ρ(B) (Perron–Frobenius monotonicity, Horn & Johnson Thm 8.1.18), and
    ρ(B) = (e_xx + e_yy)/2 + √(((e_xx − e_yy)/2)² + c²), which is at most both
    √(‖B‖₁ ‖B‖∞) = max(e_xx, e_yy) + c (Golub & Van Loan, Matrix Computations, Cor. 2.3.2) and the
    Frobenius norm √(e_xx² + e_yy² + 2c²) ≤ √(e_xx² + e_xy² + e_yx² + e_yy²) used before. With
    K_xy = K_yx = 0 exactly (circle, unturned ellipse: c = 0) it is max(e_xx, e_yy), a factor up
    to √2 below the Frobenius norm."""
    c = 0.5 * (abs(e_xy) + abs(e_yx))
    a, b = abs(e_xx), abs(e_yy)
    return 0.5 * (a + b) + math.hypot(0.5 * (a - b), c)


def ratio_error(
    levels: Sequence[Mapping[str, Any]],
    top: str,
    bottom: str,
    values: Mapping[str, float],
    relative: Mapping[str, float],
    expansions: Sequence[tuple[float, ...]] | None = None,
    safety: float | None = None,
) -> float:
    """Estimated relative error of values[top]/values[bottom]: the estimate of the ratio's own
    sequence (top/bottom per grid) plus the distance of its extrapolant from the ratio of the
    extrapolated entries, and at least ``RATIO_SHARE`` × (e_top + e_bottom). The entries' errors
    share their sign and largely cancel in the ratio (same edge layer), so e_top + e_bottom is
    pessimistic; their own sequence alone was below the true error of K_a/K_b at b/a = 1e-3 and
    0.05 (``benchmarks/accuracy_sharpness.py``), hence the floor.

    And at most what the entries' estimates allow: with |δ_top| ≤ e_top and |δ_bottom| ≤
    e_bottom < 1, |(1 + δ_top)/(1 + δ_bottom) − 1| = |δ_top − δ_bottom| / |1 + δ_bottom| ≤
    (e_top + e_bottom)/(1 − e_bottom). The ratio's own sequence can exceed it many times where
    it is not smooth in the grid: K_min/K_max of a nearly isotropic tensor whose principal axes
    swap between grids (a hexagon on a cubic crystal's {001} face, A = 0.75: 8.2e-4 where K_min's
    and K_max's estimates allow 1.8e-5, and a true error of ~1e-6; that estimate also made the
    tensor "isotropic within its accuracy", its 4.5e-4 split taken for noise)."""
    ratio = values[top] / values[bottom]
    own = estimate([r[top] / r[bottom] for r in levels], expansions=expansions, safety=safety)
    parts = relative[top] + relative[bottom]
    estimated = max((own.error + abs(own.value - ratio)) / abs(ratio), RATIO_SHARE * parts)
    return min(estimated, parts / (1.0 - relative[bottom])) if relative[bottom] < 1.0 else estimated


def exact_errors(values: Mapping[str, float], absolute: Mapping[str, float]) -> dict[str, float]:
    """Relative error bounds per reported quantity of an exact discretization from absolute
    bounds on its tensor entries (K_xx … K_zz): diagonal entries relative to themselves,
    off-diagonal ones to the largest diagonal entry (as :func:`extrapolate`), a ratio the sum of
    its parts' (K_a/K_b, K_min/K_max, normalized_xx and _yy), K_max and K_min Weyl's bound
    (:func:`principal_error`) relative to themselves."""
    scale = max(abs(values[k]) for k in ("K_xx", "K_yy", "K_zz") if k in values)
    rel = {k: e / max(abs(values[k]) if k in ("K_xx", "K_yy", "K_zz") else scale, 1e-300) for k, e in absolute.items()}
    if "K_xx" in rel:
        bound = principal_error(*(absolute[k] for k in ("K_xx", "K_xy", "K_yx", "K_yy")))
        rel["K_a_over_K_b"] = rel["K_xx"] + rel["K_yy"]
        rel["K_max"] = bound / abs(values["K_max"])
        rel["K_min"] = bound / abs(values["K_min"])
        rel["K_min_over_K_max"] = rel["K_max"] + rel["K_min"]
        if "K_zz" in rel:
            rel["normalized_xx"] = rel["K_xx"] + rel["K_zz"]
            rel["normalized_yy"] = rel["K_yy"] + rel["K_zz"]
    return rel
