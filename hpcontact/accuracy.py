r"""Extrapolated answers with an honest error estimate (``hpcontact solve --accuracy REL``).

Why the plain grid sequence cannot be extrapolated
--------------------------------------------------
The engine puts a cell in the contact when its centre lies inside the shape (docs/design.md §2.2). The
staircase area of a curved shape then fluctuates with n (the Gauss circle problem): the error
is not a smooth function of the cell size h, and the fluctuation survives an area correction
K·(A/A_n)^½ (the edge's sensitivity is not uniform), so a Richardson extrapolation on
consecutive grids can land anywhere within that band, and a difference of two extrapolants can
be small by accident, ten times below the true error. Neither is honest (docs/validation.md
§"Why the centre-in-cell sequence cannot be extrapolated").

The grid sequence is solved on coverage-weighted boundary cells (``hpcontact.discretizations.boundary_cells``):
the discrete edge moves continuously with the true one and the error is a smooth expansion
c₁ h + c₂ h^q + … with q ≈ 1.5–3, which Richardson extrapolation can use.

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
1e-3 and 0.05). K_max and K_min get the spectral norm of the entries' error bounds (Weyl; see
:func:`principal_error`).
``estimated_error`` is the largest of all.

Calibration (``benchmarks/accuracy_sharpness.py``; SAFETY, the guard 16 and ρ^1.5 were chosen
on it): 24 cases with closed forms (circle and Mindlin ellipses b/a = 0.7 … 1e-8, nu = 0, 0.3,
0.5), requests 1e-3 … 1e-6, sequences from n₀ = 16 and 32 up to n = 1024: the reported
estimate is above the largest true error of K_xx, K_yy, K_zz, K_a/K_b, K_xx/K_zz, K_yy/K_zz in
all 336 records and within 30× of it in most (docs/validation.md §"Calibration on
coverage-weighted cells"). Singular cells' sequences get their own candidates and factor
(below).

``hpcontact solve --accuracy`` uses strategy ``auto``. Unturned rectangles of b/a ≤ 1e-6 and
unturned ellipses, isotropic — ellipses wider than ``STRIP_WIDE_ASPECT`` = 1e-2 for requests
below ``SINGULAR_BELOW`` only — take strip cells (``hpcontact.discretizations.strip_cells``): n = 32, 64, …
strips (``STRIP_N0``; ellipses, whose strips contain the exact traction, from
``STRIP_ELLIPSE_N0`` = 16) up to ``STRIP_MAX_N`` = 1024 (ellipses wider than 1e-2:
``STRIP_WIDE_MAX_N`` = 256), the estimator of coverage-weighted cells (``EXPANSIONS``,
``SAFETY``) plus the bound ``strip_cells.model_error`` (where that bound is not below the
request, ``stopped_by`` "model" after four grids; coverage-weighted cells on ellipses of b/a
0.002 … 0.04 add a measured bias bound likewise, :func:`model_error`). Replayed on every grid of those sequences
(``benchmarks/strip_calibration.py``: rectangles b/a = 1e-6 … 1e-12 against the strip model's
limit from 2048 and 4096 strips, ellipses b/a = 1 … 1e-10 against Mindlin and Galin; nu 0, 0.3,
0.5; n₀ = 32, 64 and 16, 32; requests 1e-3 … 1e-7): honest on every record
(docs/validation.md §"Calibration on strip cells"). Otherwise, for requests below 1e-4 (``SINGULAR_BELOW``)
singular cells where they apply, on
sequences from :func:`singular_start` (near-square cells; b/a = 0.05 starts at 160 × 8), with
the candidates led by order 1 only (``SINGULAR_EXPANSIONS``) and the spread times
``SINGULAR_SAFETY`` = 6, on grids up to ``SINGULAR_MAX_CELLS`` = 2^20 cells. Replayed on every
grid of those sequences up to 2^20 cells (b/a = 1, 0.7, 0.5, 0.3, 0.2, 0.1, 0.05; nu = 0, 0.3,
0.5; n₀ = 16 and 32; requests 1e-3 … 1e-6; ``benchmarks/edge_order.py --singular-calibration``):
honest on every record and every per-quantity pair. Their factor is larger than coverage-weighted
cells' 3 because singular cells' error levels off at a few 1e-7 without a steady sign, which
no difference of grids shows (docs/validation.md §"Calibration on singular cells").

The refinement stops when the request is met, when the planned grids run out (``max_cells``
cells, or the memory budget: :func:`plan_grids` counts this process's peak resident set plus the
sweep cost model's arrays of the next grid, ``hpcontact.sweep.costmodel``), or when the estimate
has not fallen over two refinements (stagnation); the grids also stop where the estimator's
calibration ends (``calibration``: n = 1024 along the long side for coverage-weighted cells,
``COVERAGE_MAX_N``; 2^20 cells for singular cells, ``SINGULAR_MAX_CELLS``; 1024 strips,
``STRIP_MAX_N``; masks unlimited); the
record says which (``stopped_by``).

References: L. F. Richardson, Phil. Trans. R. Soc. A 210, 307–357 (1911); P. J. Roache,
*Verification and Validation in Computational Science and Engineering*, Hermosa, 1998.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from hpcontact import quantities as q
from hpcontact.discretizations import galin_ellipse, singular_cells, strip_cells
from hpcontact.discretizations.boundary_cells import (
    SINGULAR_SUPPORTED,
    SUPPORTED,
    covered_solve,
    mask_cells,
    strip_applies,
)
from hpcontact.errors import ConvergenceError, InputError
from hpcontact.geometry import Shape, grid_for
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.convolution import clear_cache
from hpcontact.numerics.memory import default_memory_per_rank, resident_bytes
from hpcontact.problems import footprint
from hpcontact.problems.contact import solve
from hpcontact.problems.kinds import SLIP
from hpcontact.problems.slip.partial_slip import solve_slip
from hpcontact.scene import Scene

__all__ = [
    "RATIO",
    "SAFETY",
    "EXPANSIONS",
    "SINGULAR_EXPANSIONS",
    "SINGULAR_MAX_CELLS",
    "COVERAGE_MAX_N",
    "calibrated",
    "SINGULAR_SAFETY",
    "singular_start",
    "grid_sequence",
    "plan_grids",
    "extrapolant",
    "observed_order",
    "spread",
    "estimate",
    "extrapolate",
    "principal_error",
    "refine",
    "first_grid",
    "coverage_n0",
    "model_error",
    "solve_to_accuracy",
    "default_solve",
    "default_scene_solve",
    "default_grids",
    "extrapolates_by_default",
    "AccuracyNotMet",
    "error_columns",
]

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
#: The candidates for singular cells (``hpcontact.discretizations.singular_cells``): those led by order 1. Their
#: error is led by C/n with a constant that need not be steady (cut-cell quadrature); on the
#: sequences of :func:`singular_start` leads 1.5 and 2 extrapolated past the true value, leads
#: of 1 did not (docs/validation.md §"Calibration on singular cells").
SINGULAR_EXPANSIONS: tuple[tuple[float, ...], ...] = tuple(e for e in EXPANSIONS if not e or e[0] <= 1.0)
LEAD_SLACK = 0.5  # an expansion may lead with an exponent up to the raw sequence's observed order + 0.5
SAFETY = 3.0  # estimate = SAFETY × the spread of the chosen extrapolant (calibrated, module docstring)
SAFETY_TWO_GRID = 3.0  # Roache's F_s when only two grids are trustworthy (no expansion fits)
FASTEST_FALL = 16.0  # an extrapolant's error falls at most this much per level unless it shows more twice
GUARD_EXPONENT = 1.5  # a fall ρ shown twice lets the previous difference over ρ^1.5 bound the error
OSCILLATION_FALL = 4.0  # an oscillating extrapolant's swing shrinks at most this much per level
SLOWEST_FALL = 2.0**0.5  # an extrapolant whose differences fall slower than this does not converge
STAGNATION_LEVELS = 2  # no fall of the estimate over this many refinements: the extrapolants stagnate
N0 = 32  # cells along the long side on the first grid
#: Requests at least this loose start coverage-weighted cells at ``LOOSE_N0`` where that grid's
#: cell is no wider than the outline's smallest bend (:func:`coverage_n0`). From ``N0`` their
#: four grids overshoot such requests: over the main job's 396 tasks at 1e-3 every coverage
#: sequence stopped at its fourth grid (n = 256) with estimates of 1e-4 … 4e-4 (docs/performance.md
#: §"The first grid of loose requests"). Sequences from 16 are inside the estimator's calibration
#: (the module docstring's 336 records).
LOOSE_REQUEST = 1e-3
LOOSE_N0 = 16
MIN_ACROSS = 8  # never fewer cells across than 8 at n = N0 (thin shapes; 4 at n = 16, and so on)
MAX_CELLS = 2**22  # largest grid (nx · ny) the sequence may reach by default
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
#: strategy "auto": singular cells when their square-cell sequence starts at most this many cells
#: along x (b/a ≥ 8/256 with ``MIN_ACROSS`` = 8 across); thinner ellipses would need ≥ 8 b/a-square
#: cells across on every grid (1e-3: 8000 × 8 cells first, tens of CPU seconds for that one
#: grid: docs/performance.md §"Cost and memory of `--accuracy`").
SINGULAR_MAX_N0 = 256
#: strategy "auto" takes singular cells only for requests below this: at 1e-3 and 1e-4
#: coverage-weighted cells meet the request sooner than singular cells' four grids; below 1e-4
#: coverage misses within n = 1024 where singular cells meet 1e-5 in seconds
#: (``benchmarks/accuracy_sharpness.py --cost`` and the replay of :data:`SINGULAR_EXPANSIONS`;
#: docs/performance.md §"Cost and memory of `--accuracy`").
SINGULAR_BELOW = 1e-4
#: Singular cells' grids stop at this many cells: the largest of their calibration
#: (``benchmarks/edge_order.py --singular-calibration``: every grid of :func:`singular_start`'s
#: sequences up to 2^20 cells — circle 1024², b/a 0.2 to 2048 × 512). Their error is a sum of
#: first-order terms of opposite sign (far field and sub-cell quadrature) that cancel to a few
#: 1e-7, not a steady expansion, and beyond these grids the estimate fell below the true error,
#: so the estimator is trusted only where it was checked (docs/validation.md §"Calibration on
#: singular cells").
SINGULAR_MAX_CELLS = 2**20
#: Coverage-weighted grids stop at this many cells along the long side (x): the finest grid of
#: their calibration (``benchmarks/accuracy_sharpness.py``, n ≤ 1024); one grid beyond, a thin
#: ellipse's estimate fell below its true error (``benchmarks/thin_grids.py``; docs/validation.md
#: §"Coverage-weighted grids beyond n = 1024"). Masks, refined by splitting their pixels, are not limited.
COVERAGE_MAX_N = 1024
#: The factor on the spread for singular cells' sequences (``SAFETY`` for coverage-weighted
#: cells). Their error levels off at a few 1e-7 without a steady sign, which no difference of
#: grids shows: over every grid up to ``SINGULAR_MAX_CELLS`` the factor 3 left records below
#: their true error, 5.5 is the least that is honest on all, and 6 leaves a margin
#: (docs/validation.md §"Calibration on singular cells").
SINGULAR_SAFETY = 6.0
#: Strip cells' grids (``hpcontact.discretizations.strip_cells``: n strips, one across) start at this many
#: strips and stop at ``STRIP_MAX_N``, the finest grid of their calibration
#: (``benchmarks/strip_calibration.py``); their estimate is that of coverage-weighted cells
#: (``EXPANSIONS``, ``SAFETY``) plus the model's own bound ``strip_cells.MODEL_ERROR`` · b/a.
STRIP_N0 = 32
STRIP_MAX_N = 1024
#: An ellipse's strips contain its exact traction whatever their number (``strip_cells``
#: docstring), so its sequence starts at ``STRIP_ELLIPSE_N0``; wider than
#: ``STRIP_WIDE_ASPECT`` nearly every point of its near pairs takes the exact two-width average
#: (``strip_cells.width_difference``), whose cost roughly doubles with each doubling of n, so
#: its sequence stops at ``STRIP_WIDE_MAX_N`` (docs/performance.md §"Cost and memory of `--accuracy`").
STRIP_ELLIPSE_N0 = 16
STRIP_WIDE_ASPECT = 1e-2
STRIP_WIDE_MAX_N = 256
#: Bytes of one strip solve on n strips: ``STRIP_BYTES_PER_PAIR`` · n² (the pair indices, the
#: two integral matrices, the system and its Cholesky factor; an ellipse's near pairs, which
#: reach 100 b) + ``STRIP_BYTES_BASE`` (one batch of ``strip_cells.FAR_CHUNK`` far pairs or
#: width corrections' points, ``strip_cells.TWO_WIDTH_CHUNK`` rows of the two-width averages).
#: It bounds the ``tracemalloc`` peaks of ``covered_solve`` on rectangles and ellipses
#: (docs/performance.md §"Cost and memory of `--accuracy`").
STRIP_BYTES_PER_PAIR = 160.0
STRIP_BYTES_BASE = 128.0 * 2**20
#: A rectangle's strips (no two-width averages): ``STRIP_BYTES_PER_PAIR`` · n² +
#: ``STRIP_FAR_BYTES`` per far pair of one batch (min(n(n + 1)/2, ``strip_cells.FAR_CHUNK``) pairs:
#: the Gauss product rule's arrays) + ``STRIP_RECTANGLE_BASE``. It bounds the ``tracemalloc``
#: peaks of ``covered_solve`` on rectangles b/a 1e-6, 1e-8, 1e-12 at n = 32 … 1024: 3.7, 7.6,
#: 15.3, 53.2, 126.7, 157.7 MiB against 7.0, 9.8, 21.1, 66.2, 146, 266 (2026-11-26; the batch
#: dominates below ~360 strips, where ``STRIP_BYTES_BASE`` over-counted 2.4–35×;
#: docs/performance.md §"Cost and memory of `--accuracy`").
STRIP_FAR_BYTES = 1600.0
STRIP_RECTANGLE_BASE = 6.0 * 2**20


# ------------------------------------------------------------------------------------------
# extrapolation
# ------------------------------------------------------------------------------------------
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


def singular_start(scene: Scene, n0: int, n_across0: int | None) -> tuple[int, int] | None:
    """First grid (n, n_across) of a sequence on singular cells (``hpcontact.discretizations.singular_cells``)
    with near-square cells, or None where they do not apply or would need more than
    ``SINGULAR_MAX_N0`` cells along x on the first grid.

    The first grid is ``grid_sequence``'s (n₀ along x, n_across₀ or as many across as square
    cells allow but at least ``MIN_ACROSS`` · n₀/``N0``). Singular cells need dy/dx within
    [1/2, 2] (``singular_cells.supports``): where that grid's cells are more elongated (b/a
    below 1/4 from n₀ = 32), the cells across stay and x takes as many as square cells need
    (b/a = 0.05: 160 × 8). The sequence then refines both by ``RATIO`` (fixed cell aspect).
    """
    shape = scene.shape
    if shape.name not in ("circle", "ellipse") or not set(scene.quantities) <= set(SINGULAR_SUPPORTED):
        return None
    aspect = shape.aspect if shape.name == "ellipse" else 1.0
    na = n_across0 if n_across0 is not None else max(int(round(MIN_ACROSS * n0 / N0)), int(round(n0 * aspect)), 1)
    n = int(n0)
    if not singular_cells.supports(shape, scene.material, grid_for(shape, n, na)):
        n = max(n, int(round(na / aspect)))  # as many along x as square cells need
    if n > SINGULAR_MAX_N0 or not singular_cells.supports(shape, scene.material, grid_for(shape, n, na)):
        return None
    return n, na


def grid_sequence(
    shape: Shape, n0: int = N0, n_across0: int | None = None, max_cells: int = MAX_CELLS
) -> list[tuple[int, int]]:
    """Grids (n, n_across) = (n₀ rᵏ, n_across₀ rᵏ) with at most ``max_cells`` cells (k = 0, 1, …).

    The first grid has n₀ cells along x and, unless given, as many across as square cells
    allow but at least ``MIN_ACROSS`` · n₀/``N0`` (thin shapes: elongated cells whose aspect is
    the same whatever the start, and fixed along the sequence).
    """
    if shape.name == "mask":  # pixels split 2^k ways: n0 is the contact's long side in pixels
        pixels, _ = mask_cells(shape.mask_path)
        n0, n_across0 = max(pixels.shape), min(pixels.shape)
        X, Y = 1.0, 1.0
    else:
        X, Y = shape.half_extents()
    if n_across0 is None:
        n_across0 = max(int(round(MIN_ACROSS * n0 / N0)), int(round(n0 * Y / X)), 1)
    out = []
    n, na = int(n0), int(n_across0)
    while n * na <= max_cells:
        out.append((n, na))
        n, na = int(round(n * RATIO)), int(round(na * RATIO))
    return out


#: Bytes per contact cell that a coverage-weighted solve adds to the engine's arrays (coverage,
#: damping and preconditioner weights; bounds the ``tracemalloc`` peaks: docs/performance.md
#: §"Cost and memory of `--accuracy`").
COVERAGE_BYTES_PER_CELL = 128.0
#: Singular cells' near set (``singular_cells``: cells within BAND + NEAR of a cut cell) per cell
#: along both sides, n + n_across: the boundary crosses ~2(n + n_across) cells, dilated by BAND
#: and NEAR on both sides (counted just below 8 on circles and ellipses b/a 0.7 … 0.05:
#: docs/performance.md §"Cost and memory of `--accuracy`").
SINGULAR_NEAR_CELLS_PER_SIDE_CELL = 8.0
#: Bytes per near-set cell that singular cells add to the coverage-weighted count (sub-cell
#: weights, the near-field pairs' gathers and sparse corrections): bounds the ``tracemalloc``
#: peaks of one solve less :func:`grid_bytes` (docs/performance.md §"Cost and memory of
#: `--accuracy`").
SINGULAR_BYTES_PER_NEAR_CELL = 9.0 * 1024


def grid_bytes(scene: Scene, n: int, n_across: int, strategy: str = "coverage") -> float:
    """Peak bytes of the arrays of one solve of ``scene`` on an n × n_across grid with
    ``strategy``'s cells: coverage-weighted, the sweep's cost model
    (``hpcontact.problems.footprint.array_bytes``) plus ``COVERAGE_BYTES_PER_CELL`` per cell;
    singular, plus ``SINGULAR_BYTES_PER_NEAR_CELL`` per cell of the near set
    (``SINGULAR_NEAR_CELLS_PER_SIDE_CELL`` × (n + n_across) cells); strip (n strips),
    ``STRIP_BYTES_PER_PAIR`` n² + ``STRIP_BYTES_BASE``, a rectangle's with its far-pair batch
    instead (``STRIP_FAR_BYTES``, ``STRIP_RECTANGLE_BASE``)."""
    if strategy == "strip" and scene.shape.name == "rectangle":
        batch = min(n * (n + 1) // 2, strip_cells.FAR_CHUNK)
        return STRIP_BYTES_PER_PAIR * n * n + STRIP_FAR_BYTES * batch + STRIP_RECTANGLE_BASE
    if strategy == "strip":
        return STRIP_BYTES_PER_PAIR * n * n + STRIP_BYTES_BASE
    near = (
        SINGULAR_BYTES_PER_NEAR_CELL * SINGULAR_NEAR_CELLS_PER_SIDE_CELL * (n + n_across)
        if strategy == "singular"
        else 0.0
    )
    return footprint.array_bytes(scene.fields(n=n, n_across=n_across)) + COVERAGE_BYTES_PER_CELL * n * n_across + near


@dataclasses.dataclass(frozen=True)
class GridPlan:
    """The grids an accuracy request may use, and what stops the sequence after them:
    ``limit`` is ``"cells"`` (more than ``max_cells``), ``"memory budget"`` or, set by
    ``"calibration"`` (beyond the estimator's calibrated range, :func:`calibrated`);
    ``next_grid`` the first grid refused, ``next_bytes`` its estimated peak (``base_bytes``, this process's
    peak resident set when planned, + arrays), ``budget`` the budget in bytes and
    ``budget_source`` where it comes from."""

    grids: list[tuple[int, int]]
    limit: str
    next_grid: tuple[int, int]
    next_bytes: float
    base_bytes: float
    budget: float
    budget_source: str
    max_cells: int


def strip_max_n(shape: Shape) -> int:
    """The finest strip grid of ``shape``'s calibration: ``STRIP_WIDE_MAX_N`` for ellipses wider
    than ``STRIP_WIDE_ASPECT``, else ``STRIP_MAX_N``."""
    return STRIP_WIDE_MAX_N if shape.name == "ellipse" and shape.aspect > STRIP_WIDE_ASPECT else STRIP_MAX_N


def strip_n0(shape: Shape) -> int:
    """The first strip grid: ``STRIP_ELLIPSE_N0`` for ellipses, ``STRIP_N0`` for rectangles."""
    return STRIP_ELLIPSE_N0 if shape.name == "ellipse" else STRIP_N0


def calibrated(strategy: str, shape: Shape) -> Callable[[int, int], bool]:
    """Whether the estimator of ``strategy``'s cells was calibrated on a grid (n, n_across):
    singular cells up to ``SINGULAR_MAX_CELLS`` cells, strip cells up to ``STRIP_MAX_N`` strips,
    coverage-weighted cells up to
    ``COVERAGE_MAX_N`` along the long side, masks on any grid (no closed form to calibrate on)."""
    if strategy == "singular":
        return lambda n, na: n * na <= SINGULAR_MAX_CELLS
    if strategy == "strip":
        finest = strip_max_n(shape)
        return lambda n, na: n <= finest
    if shape.name == "mask":
        return lambda n, na: True
    return lambda n, na: max(n, na) <= COVERAGE_MAX_N


def plan_grids(
    scene: Scene,
    n0: int,
    n_across0: int | None,
    max_cells: int,
    memory_budget: float | None,
    strategy: str = "coverage",
) -> GridPlan:
    """The grid sequence within ``max_cells`` cells, the estimator's calibrated range
    (:func:`calibrated`) and the memory budget (bytes; default the machine's memory per core,
    ``numerics.memory.default_memory_per_rank``): a grid is used only if this process's peak resident
    set so far plus :func:`grid_bytes` of ``strategy``'s cells fits the budget. Strip cells'
    grids are n₀ 2ᵏ strips, one across."""
    if memory_budget is None:
        budget, source = default_memory_per_rank()
    else:
        budget, source = float(memory_budget), "given"
    shape = scene.shape
    everything = (
        [(n0 * 2**k, 1) for k in range(62)] if strategy == "strip" else grid_sequence(shape, n0, n_across0, 2**62)
    )
    base = resident_bytes()
    within = calibrated(strategy, shape)
    grids: list[tuple[int, int]] = []
    for n, na in everything:
        need = base + grid_bytes(scene, n, na, strategy)
        limit = (
            "cells"
            if n * na > max_cells
            else "calibration"
            if not within(n, na)
            else "memory budget"
            if need > budget
            else None
        )
        if limit is not None:
            return GridPlan(grids, limit, (n, na), need, base, float(budget), source, max_cells)
        grids.append((n, na))
    raise AssertionError("the grid sequence is unbounded")  # pragma: no cover - 2**62 cells never fit


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
    0.05 (``benchmarks/accuracy_sharpness.py``), hence the floor."""
    ratio = values[top] / values[bottom]
    own = estimate([r[top] / r[bottom] for r in levels], expansions=expansions, safety=safety)
    return max((own.error + abs(own.value - ratio)) / abs(ratio), RATIO_SHARE * (relative[top] + relative[bottom]))


def stagnates(history: Sequence[float], levels: int = STAGNATION_LEVELS) -> bool:
    """True when the estimate has not fallen over the last ``levels`` refinements."""
    return len(history) > levels and history[-1] >= history[-1 - levels]


@dataclasses.dataclass(frozen=True)
class Refinement:
    """What :func:`refine` found: the per-grid records, the extrapolated values, their estimated
    relative errors, observed orders and expansions (as :func:`extrapolate`), and what stopped
    it (``met``, ``stagnation``, or None when the grids ran out)."""

    levels: list[dict[str, Any]]
    values: dict[str, float]
    relative: dict[str, float]
    orders: dict[str, float]
    expansions: dict[str, list[float]]
    stopped_by: str | None


def refine(
    grids: Sequence[tuple[int, int]],
    solve_level: Any,
    accuracy: float,
    expansions: Sequence[tuple[float, ...]] | None = None,
    safety: float | None = None,
    model_error: float = 0.0,
) -> Refinement:
    """Solve ``solve_level(n, n_across)`` on ``grids`` in turn, extrapolating from the
    ``MIN_GRIDS``-th on, until the largest estimated relative error is ≤ ``accuracy`` (``met``)
    or has not fallen over ``STAGNATION_LEVELS`` refinements (``stagnation``). The one loop of
    ``solve_to_accuracy`` and of the replays of ``benchmarks/accuracy_sharpness.py``;
    ``expansions`` and ``safety`` as :func:`estimate`; ``model_error``, a relative bound on what
    the discretization itself leaves whatever the grid (strip cells' profile), is added to every
    estimate."""
    levels: list[dict[str, Any]] = []
    history: list[float] = []
    found: tuple[dict[str, float], dict[str, float], dict[str, float], dict[str, list[float]]] = ({}, {}, {}, {})
    for n, na in grids:
        levels.append(solve_level(n, na))
        if len(levels) < MIN_GRIDS:
            continue
        found = extrapolate(levels, expansions, safety)
        if model_error:
            found = (found[0], {k: v + model_error for k, v in found[1].items()}, found[2], found[3])
        history.append(max(found[1].values()))
        if history[-1] <= accuracy:
            return Refinement(levels, *found, stopped_by="met")
        if stagnates(history):
            return Refinement(levels, *found, stopped_by="stagnation")
    return Refinement(levels, *found, stopped_by=None)


#: Coverage-weighted cells on ellipses of b/a in ``COVERAGE_THIN_BAND`` (open interval): their
#: sequences from 32 × 8 look converged on five grids (up to 512 × 128) while the extrapolated
#: K is 2.5–4.7e-5 too high, up to 23× the estimate (the tips, of radius b²/a, are not resolved
#: there); ``benchmarks/thin_ellipse_bias.py`` measured b/a 0.2 … 1e-4, nu 0, 0.3, 0.5, requests
#: 1e-4 and 1e-5 against Mindlin: the excess of the true error over the estimate is ≤ 0 outside
#: the band and at most 3.3e-5 inside (flat from b/a 0.03 to 0.007); a cubic crystal (A = 3,
#: ψ = 60°) at b/a 0.01 showed the same 3.2–3.5e-5 against Galin's exact Re H solution
#: (tests/sweep/test_accuracy_sweep.py). ``COVERAGE_THIN_BIAS`` = 2.1× the worst excess is
#: added to every estimate there (:func:`model_error`), as strips add theirs.
COVERAGE_THIN_BAND = (0.002, 0.04)
COVERAGE_THIN_BIAS = 7e-5


def model_error(scene: Scene, strategy: str) -> float:
    """A relative bound on what ``strategy``'s cells leave on ``scene`` whatever the grids of the
    sequence, added to every estimate: strips' profile bound (``strip_cells.model_error``), and
    ``COVERAGE_THIN_BIAS`` for coverage-weighted cells on ellipses (any turn) with b/a in
    ``COVERAGE_THIN_BAND``; 0 elsewhere."""
    if strategy == "strip":
        return strip_cells.model_error(scene.shape)
    low, high = COVERAGE_THIN_BAND
    if strategy == "coverage" and scene.shape.name == "ellipse" and low < scene.shape.aspect < high:
        return COVERAGE_THIN_BIAS
    return 0.0


def coverage_n0(shape: Shape, accuracy: float | None) -> int:
    """The first grid (cells along the long side) of coverage-weighted cells for a request of
    ``accuracy``: ``LOOSE_N0`` for requests ≥ ``LOOSE_REQUEST`` whose outline bends no tighter
    than that grid's cell (2X/``LOOSE_N0`` ≤ ``Shape.smallest_bend_radius``: straight-sided shapes,
    circles, ellipses of b/a ≥ 0.354), ``N0`` otherwise. A bend narrower than the first grid's cell
    leaves that grid outside the sequence's asymptotic range: a five-lobed star of ε = 0.3 (bend
    radius 0.055) from 16 stops on five grids with estimates 5.6–5.7e-4 where from 32 it stops on
    four with 2.0–2.9e-4, at 1.09–1.11× the CPU (``benchmarks/first_grid.py``)."""
    bend = shape.smallest_bend_radius()  # 0 for a mask, whose sequence splits its pixels instead
    if accuracy is None or accuracy < LOOSE_REQUEST or bend == 0.0:
        return N0
    X, _ = shape.half_extents()
    return LOOSE_N0 if 2.0 * X / LOOSE_N0 <= bend else N0


def first_grid(
    scene: Scene,
    strategy: str = "auto",
    n0: int | None = None,
    n_across0: int | None = None,
    accuracy: float | None = None,
) -> tuple[str, int, int | None]:
    """The boundary cells :func:`solve_to_accuracy` uses for ``scene`` and the
    first grid of its sequence: (strategy, n₀, n_across₀), with ``strategy`` ``auto`` resolved:
    the one exact cell of an elliptical contact (``hpcontact.discretizations.galin_ellipse``:
    circles and ellipses, turned or not, any material, tangential and normal; ("galin", 1, 1),
    no grid sequence); strips for slender rectangles (:func:`strip_applies`) from
    :func:`strip_n0` strips, one across; coverage-weighted cells from ``n0`` (default
    :func:`coverage_n0` of the request ``accuracy``) otherwise. Singular cells are taken only
    when asked for (``strategy="singular"``): every contact they apply to is an ellipse. The
    request changes only coverage-weighted cells' first grid, never the choice of cells. The
    sweep's cost model plans the same grids (``hpcontact.sweep.tasks``)."""
    if strategy in ("auto", "galin") and galin_ellipse.applies(scene):
        return "galin", 1, 1
    if strategy == "galin":
        raise InputError("strategy", "galin only for circles and ellipses, quantities tangential/normal", strategy)
    if strategy in ("auto", "strip") and strip_applies(scene):
        return "strip", n0 or strip_n0(scene.shape), 1
    if strategy == "strip":
        raise InputError("strategy", strip_cells.SUPPORTED_TEXT, strategy)
    if strategy in ("auto", "coverage"):
        return "coverage", n0 or coverage_n0(scene.shape, accuracy), n_across0
    return strategy, n0 or N0, n_across0


def solve_to_accuracy(
    scene: Scene,
    accuracy: float,
    *,
    n0: int | None = None,
    n_across0: int | None = None,
    max_cells: int = MAX_CELLS,
    memory_budget: float | None = None,
    max_grids: int | None = None,
    strategy: str = "coverage",
    strict: bool = True,
) -> dict[str, Any]:
    """Solve ``scene`` on refined coverage-weighted grids until the estimated relative error
    of every reported stiffness is ≤ ``accuracy``; return the extrapolated record.

    The grids are planned before the first solve (:func:`plan_grids`): none exceeds
    ``max_cells`` cells or the memory budget (bytes; default the machine's memory per core).
    The refinement stops at the first of: the request met; the planned grids used up (limit
    ``cells`` or ``memory budget``); ``max_grids`` grids; the estimate not falling over
    ``STAGNATION_LEVELS`` refinements (``stagnation``: the extrapolants stagnate, finer grids
    would not help). A request not met follows the rule of every solver here (docs/howto/accuracy.md:
    a missed tolerance is an error, exit status 1): :class:`AccuracyNotMet` names the finest grid and the
    limit that stopped it; ``strict=False`` returns the record instead (``accuracy_met`` False).

    The record has the keys of ``hpcontact.problems.contact.solve`` (extrapolated ``K_*`` and the
    quantities derived from them; ``nx ny dx dy`` of the finest grid), and

    * ``estimated_error``: the largest estimated relative error (K_xx, K_yy, K_zz and
      K_a/K_b relative to themselves, off-diagonal entries relative to the largest diagonal);
    * ``estimated_errors``: the same per quantity; ``convergence_order``: the observed order
      of each raw sequence; ``expansion``: the exponents of the expansion each value comes
      from; ``accuracy_met``: whether ``estimated_error`` ≤ ``accuracy``;
    * ``stopped_by``: ``met``, ``cells``, ``memory budget``, ``calibration`` (the next grid is
      beyond the estimator's calibrated range, :func:`calibrated`), ``grids``, ``stagnation`` or
      ``model`` (cells whose own bound, :func:`model_error`, is not below the request);
      ``memory_budget_bytes``, ``memory_budget_source``, ``estimated_peak_bytes`` (of the finest
      grid used);
    * ``grids``: the n of every grid used, ``grids_across``: their n_across, ``levels``: the
      per-grid stiffnesses, wall times and iterations; ``wall_time_s``: the total.

    The scene's ``n`` and ``n_across`` are ignored (the sequence
    starts at ``n0`` (default 32) and ``n_across0``). ``strategy`` is the boundary treatment of
    ``covered_solve`` (coverage, singular, strip) or galin or auto; ``auto`` (what ``hpcontact solve
    --accuracy`` uses) takes the one exact cell of circles and ellipses (galin, :func:`exact_solve`:
    no grids, errors at round-off), strips (``STRIP_N0`` = 32 strips first, one across) for slender
    rectangles (:func:`strip_applies`; where their model bound is not below the
    request, four grids and ``stopped_by`` "model"), and coverage-weighted cells elsewhere
    (:func:`first_grid`); the record's ``boundary`` says which ran, and with strips
    ``model_error`` the bound included in every estimate. The memory plan counts the arrays of
    the cells used (:func:`grid_bytes`, with singular cells' near field, strips' dense matrices). The CG tolerance is tightened to at most
    accuracy/100 so that it never limits the answer. A mask is refined by splitting its pixels
    (the sequence starts at the contact's long side in pixels); a rough patch cannot be refined
    and is refused (InputError), as are quantities other than tangential, normal, coupled.
    """
    started = time.perf_counter()
    if not (isinstance(accuracy, (int, float)) and math.isfinite(accuracy) and 1e-9 <= accuracy < 1.0):
        raise InputError("accuracy", "a relative error in [1e-9, 1)", accuracy)
    if memory_budget is not None and not (math.isfinite(memory_budget) and memory_budget > 0):
        raise InputError("memory", "a memory budget > 0 bytes", memory_budget)
    tol = max(min(scene.tol, accuracy * 1e-2), 1e-14)
    strategy, n0, n_across0 = first_grid(scene, strategy, n0, n_across0, accuracy)
    if strategy == "galin":
        return exact_solve(scene, accuracy, strict, started)
    plan = plan_grids(scene, n0, n_across0, max_cells, memory_budget, strategy)
    sequence = plan.grids[:max_grids] if max_grids is not None else plan.grids
    if len(sequence) < MIN_GRIDS:
        within = "the estimator's calibrated range" if plan.limit == "calibration" else f"{max_cells} cells"
        field, limit = (
            ("memory", f"a memory budget above {plan.next_bytes / 2**20:.0f} MiB")
            if plan.limit == "memory budget"
            else ("accuracy", f"a first grid small enough for {MIN_GRIDS} levels within {within}")
        )
        raise InputError(
            field,
            f"{limit} ({MIN_GRIDS} grids are the fewest an estimate needs)",
            plan.budget if plan.limit == "memory budget" else sequence[:1],
        )

    def solve_level(n: int, na: int) -> dict[str, Any]:
        level = covered_solve(scene.on_grid(n, na, tol), strategy)
        clear_cache()  # this grid's kernels serve no other grid: the budget counts one grid's
        return level

    singular = strategy == "singular"
    model = model_error(scene, strategy)
    if model >= accuracy:  # no grid can bring the estimate below the cells' own bound
        sequence = sequence[:MIN_GRIDS]
    done = refine(
        sequence,
        solve_level,
        accuracy,
        SINGULAR_EXPANSIONS if singular else None,
        SINGULAR_SAFETY if singular else None,
        model_error=model,
    )
    levels, values, relative, orders, expansions = done.levels, done.values, done.relative, done.orders, done.expansions
    stopped_by = done.stopped_by or (
        "model"
        if model >= accuracy
        else "grids"
        if max_grids is not None and max_grids < len(plan.grids)
        else plan.limit
    )
    finest = levels[-1]
    record: dict[str, Any] = {
        k: finest[k] for k in ("nx", "ny", "dx", "dy", "contact_cells", "contact_area", "normal_held") if k in finest
    }
    record.update(values)
    worst = max(relative.values())
    record.update(q.derived_quantities(values, scene.material, noise=worst))
    record["estimated_error"] = worst
    record["estimated_errors"] = dict(relative)
    record["convergence_order"] = {k: (v if math.isfinite(v) else None) for k, v in orders.items()}  # JSON-safe
    record["expansion"] = expansions
    record["accuracy"] = float(accuracy)
    record["accuracy_met"] = bool(worst <= accuracy)
    record["stopped_by"] = stopped_by
    record["boundary"] = strategy
    record["grids"] = [n for n, _ in sequence[: len(levels)]]
    record["grids_across"] = [na for _, na in sequence[: len(levels)]]
    record["memory_budget_bytes"] = plan.budget
    record["memory_budget_source"] = plan.budget_source
    record["estimated_peak_bytes"] = plan.base_bytes + grid_bytes(scene, *sequence[len(levels) - 1], strategy)
    record["model_error"] = model
    record["levels"] = [
        {k: r[k] for k in (*TENSOR_KEYS, "K_a_over_K_b", "wall_time_s", "iterations", "contact_area") if k in r}
        for r in levels
    ]
    record["iterations"] = int(sum(r["iterations"] for r in levels))
    record["residual"] = max(r["residual"] for r in levels)
    record["plan"] = {
        **finest["plan"],
        "extrapolation": "generalized Richardson over grids ratio 2, expansion of least spread",
    }
    record["wall_time_s"] = time.perf_counter() - started
    if strict and not record["accuracy_met"]:
        raise AccuracyNotMet(record, plan)
    return record


def exact_solve(scene: Scene, accuracy: float, strict: bool, started: float) -> dict[str, Any]:
    """:func:`solve_to_accuracy` of an elliptical contact on its one exact cell
    (``galin_ellipse.solve``): the same record keys, with ``grids`` [1], no ``levels``,
    ``stopped_by`` "met" or, where the integral's own bound is not below the request, "model"
    (``model_error`` is that bound); the estimates per quantity come from :func:`exact_errors`."""
    record = galin_ellipse.solve(scene)
    relative = exact_errors(record, record.pop("absolute_errors"))
    worst = max(relative.values())
    record.update(
        {
            "estimated_error": worst,
            "estimated_errors": relative,
            "convergence_order": {},
            "expansion": {},
            "accuracy": float(accuracy),
            "accuracy_met": bool(worst <= accuracy),
            "stopped_by": "met" if worst <= accuracy else "model",
            "grids": [1],
            "grids_across": [1],
            "levels": [],
            "model_error": worst,
            "estimated_peak_bytes": resident_bytes(),
            "wall_time_s": time.perf_counter() - started,
        }
    )
    if strict and not record["accuracy_met"]:
        raise AccuracyNotMet(record, GridPlan([(1, 1)], "model", (1, 1), 0.0, 0.0, math.inf, "none", 1))
    return record


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


#: Without ``n``: one scene (``hpcontact solve``, ``hpcontact.solve``) is solved as ``--accuracy
#: DEFAULT_ACCURACY`` (:func:`default_scene_solve`); a sweep whose spec gives none on grids
#: 16 … 256 along the long side (``DEFAULT_N0``, ``DEFAULT_GRIDS``), extrapolated, stopping once
#: the estimate is ≤ 1e-4 (:func:`default_solve`).
DEFAULT_ACCURACY = 1e-4
DEFAULT_N0 = 16
DEFAULT_GRIDS = 5


def extrapolates_by_default(scene: Scene) -> bool:
    """Whether ``scene`` without ``n`` gets the extrapolated default (:func:`default_solve`):
    an isotropic body, a shape with a refinable outline (not rough, not a mask) and
    quantities that coverage-weighted cells solve (tangential, normal, coupled)."""
    if scene.grid_given:
        return False
    return (
        isinstance(scene.material, Isotropic)
        and scene.shape.name not in ("rough", "mask")
        and all(x in SUPPORTED for x in scene.quantities)
    )


def default_grids(scene: Scene) -> list[tuple[int, int]]:
    """The grids (n, n_across) :func:`default_solve` solves ``scene`` on at most: grids 16, 32,
    … (``DEFAULT_N0``, ``DEFAULT_GRIDS`` of them, ``grid_sequence``'s cells across), or [] when
    ``scene`` gives ``n`` or does not :func:`extrapolate by default <extrapolates_by_default>`.
    It stops earlier when the estimate is met on fewer (never before ``MIN_GRIDS``); the memory
    plan never cuts grids this small. The sweep's cost model sums its tasks' cost over these
    (``hpcontact.sweep.tasks.solved_grids``)."""
    if not extrapolates_by_default(scene):
        return []
    return grid_sequence(scene.shape, DEFAULT_N0)[:DEFAULT_GRIDS]


def default_solve(scene: Scene) -> dict[str, Any]:
    """A sweep's scene with the default discretization (one scene from ``hpcontact solve`` or
    ``hpcontact.solve``: :func:`default_scene_solve`): ``hpcontact.problems.contact.solve`` when ``scene`` gives
    ``n`` (one grid, centre-in-cell, as always) or the scene is not one that
    :func:`extrapolates_by_default`; else ``solve_to_accuracy`` on grids 16, 32, … , 256
    (``DEFAULT_GRIDS``), stopping once the estimate is ≤ ``DEFAULT_ACCURACY`` = 1e-4, never an
    error: the record's ``estimated_error`` says what was reached (docs/howto/accuracy.md,
    "Without ``--n``: the default": 0.3–1.1 s CPU, true errors ≤ 9e-5 on ellipses b/a 1 … 1e-8).
    Its ``nx``, ``ny``, ``dx``, ``dy`` are the finest grid's, ``grids`` and ``grids_across`` list every grid.

    A scene with an ``accuracy`` field (a sweep's ``[numerics] accuracy``, ``hpcontact run
    --accuracy``) is solved as ``hpcontact solve --accuracy`` solves it: :func:`solve_to_accuracy`
    with strategy ``auto``, its ``n`` ignored, a request not met returned with ``accuracy_met``
    False and ``stopped_by`` the limit (not an error: the record's estimates say what was reached).

    A sweep's contact tasks run this too (:func:`task_function`): a spec
    without ``n`` gets the extrapolated default and its data set ``estimated_error``."""
    if scene.accuracy is not None:
        return solve_to_accuracy(scene, scene.accuracy, strategy="auto", strict=False)
    if not extrapolates_by_default(scene):
        return solve(scene)
    return solve_to_accuracy(scene, DEFAULT_ACCURACY, n0=DEFAULT_N0, max_grids=DEFAULT_GRIDS, strict=False)


def default_scene_solve(scene: Scene) -> dict[str, Any]:
    """One scene without ``n`` and without ``accuracy`` (``hpcontact solve``, ``hpcontact.solve``):
    where the scene :func:`extrapolates_by_default`, exactly ``hpcontact solve --accuracy``
    with ``DEFAULT_ACCURACY`` = 1e-4 (:func:`solve_to_accuracy`, strategy ``auto``: the one exact
    cell of circles and ellipses, strips for slender rectangles, coverage-weighted grids from
    :func:`coverage_n0` until the estimate is met or a limit stops them), so the default takes the
    best cells for the shape. A request not met raises :class:`AccuracyNotMet` (its ``record``
    is the extrapolated record; ``hpcontact.api.solve_fields`` returns it with an
    ``errors.AccuracyWarning``). Other scenes: :func:`default_solve` (one grid).

    A sweep's task keeps :func:`default_solve`'s five fixed grids 16 … 256 (its cost model
    plans them, ``hpcontact.sweep.tasks.solved_grids``)."""
    if scene.accuracy is not None or not extrapolates_by_default(scene):
        return default_solve(scene)
    return solve_to_accuracy(scene, DEFAULT_ACCURACY, strategy="auto")


class AccuracyNotMet(ConvergenceError):
    """``--accuracy`` stopped before its request: the estimate on the finest grid is above it.

    ``record`` is the extrapolated record (``accuracy_met`` False, ``stopped_by`` the limit)."""

    def __init__(self, record: Mapping[str, Any], plan: GridPlan) -> None:
        self.record = dict(record)
        finest = f"{record['grids'][-1]} x {record['grids_across'][-1]}"
        nxt = f"{plan.next_grid[0]} x {plan.next_grid[1]}"
        why = {
            "cells": f"the next grid, {nxt}, exceeds the {plan.max_cells} cells allowed",
            "memory budget": f"the next grid, {nxt}, needs an estimated {plan.next_bytes / 2**20:.0f} MiB, above the memory "
            f"budget of {plan.budget / 2**20:.0f} MiB ({plan.budget_source})",
            "calibration": f"the next grid, {nxt}, is beyond those on which the error estimate of "
            f"{record['boundary']} cells is calibrated ("
            + (
                f"{SINGULAR_MAX_CELLS} cells, accuracy.SINGULAR_MAX_CELLS)"
                if record["boundary"] == "singular"
                else f"{COVERAGE_MAX_N} cells along the long side, accuracy.COVERAGE_MAX_N)"
            ),
            "grids": "the number of grids allowed is used up",
            "model": f"the {record['boundary']} cells' own error bound, {record.get('model_error', 0.0):.2g} "
            "(accuracy.model_error: what they leave at this b/a on the grids of their sequence), is not below the request",
            "stagnation": f"the estimate did not fall over the last {STAGNATION_LEVELS} refinements (the extrapolants stagnate)",
        }[record["stopped_by"]]
        super().__init__(
            f"accuracy {record['accuracy']:g} not met: estimated error {record['estimated_error']:.3g} on the finest "
            f"grid {finest}; stopped by {record['stopped_by']}: {why}",
            int(record["iterations"]),
            float(record["residual"]),
        )


TaskFunction = Callable[[Mapping[str, Any]], Mapping[str, Any]]


def task_function(kind: str) -> TaskFunction:
    """The function that solves one scene of ``kind`` (``problems.kinds``): parameters → record.
    A slip scene: ``problems.slip.partial_slip.solve_slip``; a contact scene: :func:`default_solve`."""
    return solve_slip if kind == SLIP else solve_contact_fields


def solve_contact_fields(fields: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`default_solve` of the contact scene of ``fields`` (a sweep's task, a journal's
    entry: the edge where fields become a ``Scene``), its per-quantity estimates as numbers
    (:func:`error_columns`)."""
    return error_columns(default_solve(Scene.from_params(fields)))


def error_columns(record: Mapping[str, Any]) -> dict[str, Any]:
    """``record`` with its ``estimated_errors`` (a mapping per quantity) as one number per
    quantity, ``<quantity>_error`` (``quantities.ERROR_SUFFIX``): what a sweep's journals and data set store
    (docs/reference/dataset.md §"Error estimates"). A record without estimates (one grid) is
    returned as it is."""
    out = dict(record)
    errors = out.pop("estimated_errors", None)
    if not errors:
        return out
    out.update({f"{name}{q.ERROR_SUFFIX}": float(value) for name, value in errors.items()})
    return out
