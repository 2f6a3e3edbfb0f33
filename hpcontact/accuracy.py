r"""Extrapolated answers with an honest error estimate (``hpcontact solve --accuracy REL``).

Why the plain grid sequence cannot be extrapolated
--------------------------------------------------
The engine puts a cell in the contact when its centre lies inside the shape (DESIGN §2.2). The
staircase area of a curved shape then fluctuates with n (the Gauss circle problem): the circle's
K_xx error is 1.8e-3 at n = 64, 2.8e-3 at 96, 8.6e-4 at 128, 9.2e-4 at 192, 4.3e-4 at 512 — not
a smooth function of the cell size h. For an ellipse b/a = 0.1 the fluctuation is ±15 % of the
O(h) error itself and survives an area correction (the edge's sensitivity is not uniform), so a
Richardson extrapolation on consecutive grids can land anywhere within that band, and a
difference of two extrapolants can be small by accident: measured on area-corrected values
(K·(A/A_n)^½, exact for a circle), |R_k − R_{k−1}| was 6e-5 where the true error was 6e-4.
Neither is honest.

The grid sequence is solved on coverage-weighted boundary cells (``hpcontact.boundary_cells``):
the discrete edge moves continuously with the true one and the error is a smooth expansion
c₁ h + c₂ h^q + … with q ≈ 1.5–3, which Richardson extrapolation can use.

Extrapolation and the estimate
------------------------------
Grids n_k = n₀ 2^k (and n_across likewise, so every cell keeps its aspect ratio; refinement
ratio r = 2, Roache's recommendation r ≥ 1.3 with room to spare), at least four of them. For
each tensor entry Q (K_xx, K_xy, K_yx, K_yy, K_zz, …) the Richardson (1911) extrapolant of the
theoretical order p = 1 (the edge layer of the square-root traction singularity) is

    R_k = Q_k + (Q_k − Q_{k−1}) / (r^p − 1),

the observed order of the raw sequence over its last three grids is

    p_obs = ln(|Q_{k−1} − Q_{k−2}| / |Q_k − Q_{k−1}|) / ln r,

and the error of R_k is estimated in the spirit of Roache's grid convergence index (Roache 1998,
§5.6: GCI = F_s |ε| / (r^p − 1), F_s = 1.25 with three or more grids, 3 with two), applied to
the extrapolants themselves, whose own observed order is q = ln(|ΔR_{k−1}|/|ΔR_k|)/ln r:

* p_obs outside [0.5, 1.7] (not asymptotic): E = 3 |Q_k − Q_{k−1}|, the two-grid GCI of the
  fine value (and at least |R_k − Q_k|);
* ΔR_k and ΔR_{k−1} of opposite sign (oscillatory convergence): E = 1.25 max(|ΔR_k|, |ΔR_{k−1}|);
* q < 0.5 (the extrapolants stagnate): the two-grid GCI of the fine value, as above;
* 0.5 ≤ q < 1: E = 1.25 |ΔR_k| / (r^q − 1);
* q ≥ 1: E = 1.25 max(|ΔR_k|, |ΔR_{k−1}|/r²) — |ΔR_k| bounds the error when R converges at
  order ≥ 1; the second term stops a difference that is small by accident (measured: a circle
  started at n = 32 has ΔR falling 11× in one step while its error falls 1.6×);
* always E ≥ 5 % of the correction |R_k − Q_k|: Richardson is never credited with more than a
  factor 20 (worst measured need 2.1 %: a thin ellipse b/a = 1e-3 on cells 250 times longer
  than wide, whose extrapolants level off at 1e-5 where the raw error is 5e-4).

Off-diagonal entries are relative to the largest diagonal entry. Quantities derived from the
tensor get first-order bounds that do not rely on cancellation: K_a/K_b and Li's normalized
stiffnesses the sum of their factors' relative errors, K_max and K_min the Frobenius norm of
the entries' errors (Weyl). ``estimated_error`` is the largest of all.

Measured on 18 sequences with closed forms (circle nu = 0, 0.3, 0.5; Mindlin ellipses b/a = 0.5,
0.1, 1e-3, 1e-6, nu = 0.3, 0.5; four start grids each; n up to 1024): at every level the true
error of every quantity is below its estimate (308 of 308, worst true/estimate 0.59, typical
0.1–0.5). ``tests/test_accuracy.py`` and ``benchmarks/boundary_treatment.py`` repeat the check.

References: L. F. Richardson, Phil. Trans. R. Soc. A 210, 307–357 (1911); P. J. Roache,
*Verification and Validation in Computational Science and Engineering*, Hermosa, 1998.
"""
from __future__ import annotations

import dataclasses
import math
import time
from typing import Any, Mapping, Sequence

import numpy as np

from . import quantities as q
from .boundary_cells import covered_solve, mask_cells
from .errors import ConvergenceError, InputError
from .geometry import Shape
from .scene import Scene

__all__ = [
    "RATIO",
    "SAFETY",
    "grid_sequence",
    "richardson",
    "observed_order",
    "estimate",
    "extrapolate",
    "solve_to_accuracy",
]

MIN_GRIDS = 4  # three Richardson extrapolants, so that their own convergence can be checked
RATIO = 2.0  # grid refinement ratio r (Roache 1998 recommends r ≥ 1.3; 2 keeps h-levels apart)
ORDER = 1.0  # leading order of the coverage-weighted error (edge layer, measured 0.98–1.03)
SAFETY = 1.25  # Roache's F_s for three or more grids with an observed order
SAFETY_TWO_GRID = 3.0  # Roache's F_s when only two grids are trustworthy
ORDER_RANGE = (0.5, 1.7)  # observed orders accepted as "asymptotic" around ORDER = 1
CORRECTION_FRACTION = 0.05  # estimate ≥ 5 % of the correction R_k − Q_k (worst need measured: 2.1 %)
MIN_NEXT_ORDER = 0.5  # R converging slower than this is not in its asymptotic range
FASTEST_NEXT_ORDER = 2.0  # R_k converges no faster than r^-2 per level (guard against a zero crossing)
N0 = 32  # cells along the long side on the first grid
MIN_ACROSS = 8  # never fewer cells across on the first grid (thin shapes)
MAX_CELLS = 2**22  # largest grid (nx · ny) the sequence may reach by default
TENSOR_KEYS = ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz", "K_xz", "K_yz", "K_zx", "K_zy", "K_zz_bonded",
               "K_xx_coupled", "K_xy_coupled", "K_yx_coupled", "K_yy_coupled")


# ------------------------------------------------------------------------------------------
# extrapolation
# ------------------------------------------------------------------------------------------
def richardson(coarse: float, fine: float, ratio: float = RATIO, order: float = ORDER) -> float:
    """Richardson (1911) extrapolant fine + (fine − coarse)/(ratio^order − 1)."""
    return fine + (fine - coarse) / (ratio**order - 1.0)


def observed_order(q0: float, q1: float, q2: float, ratio: float = RATIO) -> float:
    """Observed order ln(|q1 − q0| / |q2 − q1|)/ln r of three grids h, h/r, h/r² (NaN if flat)."""
    d0, d1 = abs(q1 - q0), abs(q2 - q1)
    if d0 == 0.0 or d1 == 0.0:
        return math.nan
    return math.log(d0 / d1) / math.log(ratio)


@dataclasses.dataclass(frozen=True)
class Estimate:
    """Extrapolated ``value`` of one quantity, its estimated absolute ``error``, the observed
    order of the raw sequence and whether the grids looked asymptotic."""

    value: float
    error: float
    order: float
    asymptotic: bool


def estimate(values: Sequence[float], ratio: float = RATIO) -> Estimate:
    """Extrapolated value and honest error estimate from a sequence on grids h, h/r, h/r², ….

    Needs ``MIN_GRIDS`` = 4 values. ``value`` is the last order-1 extrapolant R_k, ``error`` the
    estimate of |R_k − Q*| described in the module docstring (Richardson 1911; Roache 1998).
    """
    Q = [float(v) for v in values]
    if len(Q) < MIN_GRIDS:
        raise ValueError(f"an estimate needs at least {MIN_GRIDS} grids")
    R = [richardson(a, b, ratio) for a, b in zip(Q, Q[1:])]
    p = observed_order(Q[-3], Q[-2], Q[-1], ratio)
    scale = max(abs(Q[-1]), 1e-300)
    flat = abs(Q[-1] - Q[-2]) <= 4.0 * np.finfo(float).eps * scale and abs(Q[-2] - Q[-3]) <= 4.0 * np.finfo(float).eps * scale
    asymptotic = flat or (math.isfinite(p) and ORDER_RANGE[0] <= p <= ORDER_RANGE[1])
    value = R[-1]
    fallback = max(SAFETY_TWO_GRID * abs(Q[-1] - Q[-2]) / (ratio**ORDER - 1.0), abs(R[-1] - Q[-1]))
    if not asymptotic:
        error = fallback
    else:  # three or more extrapolants: a three-grid study of R with its observed order q
        last, before = abs(R[-1] - R[-2]), abs(R[-2] - R[-3])
        q_R = observed_order(R[-3], R[-2], R[-1], ratio)
        if (R[-1] - R[-2]) * (R[-2] - R[-3]) < 0.0:  # R oscillates: bound by the swing
            error = SAFETY * max(last, before)
        elif math.isfinite(q_R) and q_R < MIN_NEXT_ORDER:  # R stagnates: not asymptotic
            error = fallback
        elif math.isfinite(q_R) and q_R < ORDER:  # slower than first order: GCI with q_R
            error = SAFETY * last / (ratio**q_R - 1.0)
        else:  # first order or faster: |ΔR| bounds the error, guarded against a lucky zero
            error = SAFETY * max(last, before / ratio**FASTEST_NEXT_ORDER)
    error = max(error, CORRECTION_FRACTION * abs(R[-1] - Q[-1]))  # Richardson's gain is capped
    error = max(error, 8.0 * np.finfo(float).eps * abs(value))  # rounding floor
    return Estimate(value=value, error=error, order=p, asymptotic=asymptotic)


def grid_sequence(shape: Shape, n0: int = N0, n_across0: int | None = None, max_cells: int = MAX_CELLS) -> list[tuple[int, int]]:
    """Grids (n, n_across) = (n₀ rᵏ, n_across₀ rᵏ) up to ``max_cells`` cells (k = 0, 1, …).

    The first grid has n₀ cells along x and, unless given, as many across as square cells
    allow but at least ``MIN_ACROSS`` (thin shapes: elongated cells, their aspect then fixed).
    """
    if shape.name == "mask":  # pixels split 2^k ways: n0 is the contact's long side in pixels
        pixels, _ = mask_cells(shape.mask_path)
        n0, n_across0 = max(pixels.shape), min(pixels.shape)
        X, Y = 1.0, 1.0
    else:
        X, Y = shape.half_extents()
    if n_across0 is None:
        n_across0 = max(MIN_ACROSS, int(round(n0 * Y / X)))
    out = []
    n, na = int(n0), int(n_across0)
    while n * na <= max_cells:
        out.append((n, na))
        n, na = int(round(n * RATIO)), int(round(na * RATIO))
    if len(out) < MIN_GRIDS:
        raise InputError("accuracy", f"a first grid small enough for {MIN_GRIDS} levels within {max_cells} cells", (n0, n_across0))
    return out


def extrapolate(levels: Sequence[Mapping[str, Any]]) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
    """Extrapolated tensor entries, their estimated relative errors, and observed orders.

    Tensor entries (``TENSOR_KEYS`` present in the records) are extrapolated one by one
    (:func:`estimate`); K_xx, K_yy, K_zz relative to themselves, off-diagonal entries relative to
    the largest diagonal entry. Quantities derived from the tensor get first-order bounds from
    the entries' estimates, which do not rely on errors cancelling: K_a/K_b = K_xx/K_yy and
    Li's K_xx E*/(K_zz G*) get e_xx + e_yy and e_xx + e_zz; K_max and K_min get
    ‖δK‖_F / K (Weyl: an eigenvalue moves by at most the norm of the perturbation).
    """
    estimates = {k: estimate([r[k] for r in levels]) for k in TENSOR_KEYS if k in levels[-1]}
    values = {k: e.value for k, e in estimates.items()}
    diagonal = [abs(values[k]) for k in ("K_xx", "K_yy", "K_zz") if k in values]
    scale = max(diagonal) if diagonal else 1.0
    relative: dict[str, float] = {}
    for key, e in estimates.items():
        own = key in ("K_xx", "K_yy", "K_zz")
        relative[key] = e.error / max(abs(e.value) if own else scale, 1e-300)
    if "K_xx" in relative and "K_yy" in relative:
        relative["K_a_over_K_b"] = relative["K_xx"] + relative["K_yy"]
        frobenius = math.sqrt(sum(estimates[k].error ** 2 for k in ("K_xx", "K_xy", "K_yx", "K_yy")))
        K2 = np.array([[values["K_xx"], values["K_xy"]], [values["K_yx"], values["K_yy"]]])
        k_max, k_min, _ = q.principal_stiffness(K2)
        relative["K_max"] = frobenius / max(abs(k_max), 1e-300)
        relative["K_min"] = frobenius / max(abs(k_min), 1e-300)
        if "K_zz" in relative:
            relative["normalized_xx"] = relative["K_xx"] + relative["K_zz"]
            relative["normalized_yy"] = relative["K_yy"] + relative["K_zz"]
    orders = {k: e.order for k, e in estimates.items()}
    return values, relative, orders


def solve_to_accuracy(
    params: Mapping[str, Any],
    accuracy: float,
    *,
    n0: int | None = None,
    n_across0: int | None = None,
    max_cells: int = MAX_CELLS,
    strict: bool = True,
) -> dict[str, Any]:
    """Solve ``params`` on refined coverage-weighted grids until the estimated relative error
    of every reported stiffness is ≤ ``accuracy``; return the extrapolated record.

    A request the grids cannot meet follows the rule of every solver here (README: a missed
    tolerance is an error, exit status 1): :class:`AccuracyNotMet` names the finest grid and
    the one that would exceed ``max_cells``; ``strict=False`` returns the record instead
    (``accuracy_met`` False), for studies that chart the miss.

    The record has the keys of ``hpcontact.solve.solve`` (extrapolated ``K_*`` and the
    quantities derived from them; ``nx ny dx dy`` of the finest grid), and

    * ``estimated_error``: the largest estimated relative error (K_xx, K_yy, K_zz and
      K_a/K_b relative to themselves, off-diagonal entries relative to the largest diagonal);
    * ``estimated_errors``: the same per quantity; ``convergence_order``: the observed order
      of each raw sequence (≈ 1); ``accuracy_met``: whether ``estimated_error`` ≤ ``accuracy``
      (False only when ``max_cells`` stopped the refinement);
    * ``grids``: the n of every grid used, ``grids_across``: their n_across, ``levels``: the
      per-grid stiffnesses, wall times and iterations; ``wall_time_s``: the total.

    ``params`` are those of ``solve``; ``n`` and ``n_across`` there are ignored (the sequence
    starts at ``n0`` (default 32) and ``n_across0``). The CG tolerance is tightened to at most
    accuracy/100 so that it never limits the answer. A mask is refined by splitting its pixels
    (the sequence starts at the contact's long side in pixels); a rough patch cannot be refined
    and is refused (InputError), as are quantities other than tangential, normal, coupled.
    """
    started = time.perf_counter()
    if not (isinstance(accuracy, (int, float)) and math.isfinite(accuracy) and 1e-9 <= accuracy < 1.0):
        raise InputError("accuracy", "a relative error in [1e-9, 1)", accuracy)
    base = {k: v for k, v in params.items() if k not in ("n", "n_across")}
    scene = Scene.from_params(base)
    tol = min(scene.tol, accuracy * 1e-2)
    base["tol"] = max(tol, 1e-14)
    sequence = grid_sequence(scene.shape, n0 or N0, n_across0, max_cells)
    levels: list[dict[str, Any]] = []
    values: dict[str, float] = {}
    relative: dict[str, float] = {}
    orders: dict[str, float] = {}
    for n, na in sequence:
        levels.append(covered_solve({**base, "n": n, "n_across": na}))
        if len(levels) < MIN_GRIDS:
            continue
        values, relative, orders = extrapolate(levels)
        if max(relative.values()) <= accuracy:
            break
    finest = levels[-1]
    record: dict[str, Any] = {k: finest[k] for k in ("nx", "ny", "dx", "dy", "contact_cells", "contact_area")}
    record.update(values)
    worst = max(relative.values())
    record.update(q.derived_quantities(values, scene.material, noise=worst))
    record["estimated_error"] = worst
    record["estimated_errors"] = dict(relative)
    record["convergence_order"] = {k: (v if math.isfinite(v) else None) for k, v in orders.items()}  # JSON-safe
    record["accuracy"] = float(accuracy)
    record["accuracy_met"] = bool(worst <= accuracy)
    record["grids"] = [n for n, _ in sequence[: len(levels)]]
    record["grids_across"] = [na for _, na in sequence[: len(levels)]]
    record["levels"] = [
        {k: r[k] for k in (*TENSOR_KEYS, "K_a_over_K_b", "wall_time_s", "iterations", "contact_area") if k in r}
        for r in levels
    ]
    record["iterations"] = int(sum(r["iterations"] for r in levels))
    record["residual"] = max(r["residual"] for r in levels)
    record["plan"] = {**finest["plan"], "extrapolation": "Richardson p=1 over grids ratio 2, Roache GCI Fs=1.25"}
    record["wall_time_s"] = time.perf_counter() - started
    if strict and not record["accuracy_met"]:
        raise AccuracyNotMet(record, max_cells)
    return record


class AccuracyNotMet(ConvergenceError):
    """``--accuracy`` ran out of grids: the estimate on the finest grid is above the request.

    ``record`` is the extrapolated record (``accuracy_met`` False)."""

    def __init__(self, record: Mapping[str, Any], max_cells: int) -> None:
        self.record = dict(record)
        finest = f"{record['grids'][-1]} x {record['grids_across'][-1]}"
        super().__init__(
            f"accuracy {record['accuracy']:g} not met: estimated error {record['estimated_error']:.3g} on the finest "
            f"grid {finest} (the next grid, twice as fine, exceeds the {max_cells} cells allowed)",
            int(record["iterations"]),
            float(record["residual"]),
        )


# ------------------------------------------------------------------------------------------
# the accuracy-versus-cost study: every scene timed on its own
# ------------------------------------------------------------------------------------------
def cold_solve(params: Mapping[str, Any]) -> dict[str, Any]:
    """``hpcontact.solve.solve`` with the kernel caches emptied first.

    A sweep's process keeps kernel spectra per (material, grid), so in an accuracy study the
    tasks that differ only in ``tol`` would reuse the first one's kernels and time only their
    CG. The study wants what one scene costs on its own: influence coefficients, spectra, FFT
    operator and solves (FFTW wisdom stays warm, as in any long-running sweep).
    """
    from .kernels import isotropic
    from .operator import clear_cache
    from .solve import solve

    clear_cache()
    cached = getattr(isotropic, "_centred_integral", None)
    if cached is not None and hasattr(cached, "cache_clear"):
        cached.cache_clear()
    return solve(params)


def run_study(argv: Sequence[str] | None = None) -> int:
    """``[mpiexec -n N] python -m hpcontact.accuracy SPEC [hpcontact run options]``.

    ``hpcontact run`` with :func:`cold_solve` as the task function (MPI, locks, resumable
    journals, signals, exit statuses and the data set of ``hpcontact run``); used for
    ``jobs/accuracy_cost.toml``.
    """
    from .sweep.driver import main

    return main(argv, prog="python -m hpcontact.accuracy", task_function=cold_solve,
                description="Run an accuracy-versus-cost sweep, every scene timed with cold kernel caches.")


if __name__ == "__main__":
    raise SystemExit(run_study())
