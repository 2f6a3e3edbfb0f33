"""Sharpness and honesty of ``--accuracy``'s error estimate over (case, request) pairs.

    python benchmarks/accuracy_sharpness.py [--cache results/accuracy_sharpness.jsonl]
        [--max-n 1024] [--collect] [--strategy coverage|singular] [--set SAFETY=3 ...]
        [--table] [--cost] [--defaults] [--figure PNG [--singular-cache CACHE] [--strip-cache CACHE]]
        [--exact-cases [--exact-cache results/accuracy_sharpness_exact.jsonl]] [--polygons [--runs R --levels L]]

Cases with closed forms (``hpcontact.analytic``): the circle (8Ga/(2 − nu), 2aE*) and Mindlin's
bonded ellipse with the elliptical punch (K_a, K_b, K_zz, K_a/K_b) for b/a = 0.7, 0.5, 0.1,
0.05, 1e-3, 1e-6, 1e-8; nu = 0, 0.3, 0.5 (24 cases). Requests 1e-3, 3e-4, …, 1e-6 (7); grid
sequences starting at n₀ = 16 and 32 (2): 336 (case, request) pairs.

``--collect`` solves every (case, grid) once with ``covered_solve`` (tangential and normal,
CG tol 1e-12) up to ``--max-n`` and appends the raw stiffnesses and the solve's CPU seconds
(``time.process_time``, one thread: the time on a core of its own, not inflated by whatever
else shares the machine) to the cache (JSON lines, keyed by the boundary treatment named in the
record's plan, so a new treatment gets its own sequences); grids cached with their CPU time
are skipped (a later line for the same grid replaces an earlier one). The replay then runs the loop of
``solve_to_accuracy`` itself (``hpcontact.accuracy.refine``) on the cached levels: the grid
limit is the cache's finest grid. Printed:

* per record: the reported ``estimated_error`` against the largest true error of K_xx, K_yy,
  K_zz, K_a/K_b — worst true/estimate (honest when ≤ 1), worst estimate/true, and the
  fraction with true ≥ estimate/30 (sharp);
* per quantity: the same for each quantity's own estimate (true errors below 1e-13 are exact by
  symmetry — K_a/K_b of a circle or at nu = 0 — and left out);
* with ``--table``: every pair;
* with ``--cost``: per case (nu = 0.3, 0.5) and treatment (coverage-weighted cells, singular
  cells where they apply), the time ``--accuracy`` 1e-3 … 1e-6 takes from n₀ = 32 (sum of the
  cached solve times), true / estimated error, or the limit that stopped it;
* with ``--figure``: true against estimated error of every record (and of the singular cells'
  calibration, ``benchmarks/edge_order.py --singular-calibration``'s cache, with
  ``--singular-cache``; of the strips' ellipses, ``benchmarks/strip_calibration.py``'s cache, with
  ``--strip-cache``), and what ``--accuracy`` reports after each grid against CPU seconds;
* with ``--exact-cases``: the same records for ellipses whose reference is Galin's one exact
  cell (``EXACT_CASES``: a cubic crystal ellipse, A = 3, ψ = 60°, b/a 0.3; a turned ellipse,
  40°, b/a 0.5; both, b/a 0.5; nu = 0.3): ``--accuracy`` with coverage-weighted cells
  (``strategy="coverage"``: on ellipses ``auto`` takes the exact cell itself) for requests
  1e-3 … 1e-5 from n₀ = 16 and 32, replayed with ``accuracy.refine`` on the grids
  ``solve_to_accuracy`` plans (``accuracy.plan_grids``), each solved once with ``covered_solve``
  and cached (``--exact-cache``); true errors against ``hpcontact.accuracy.exact_solve``; one
  request (the crystal, 1e-3 from n₀ = 32) is also run live and printed beside its replay. The
  figure shows them as their own series (and their per-second convergence from n₀ = 32);
* with ``--polygons`` (figure only): the triangle's and hexagon's ``--accuracy`` runs of
  ``benchmarks/accuracy_reference.py`` (its run and level caches) against its references from
  finer grids, where those caches hold them;
* with ``--defaults``: ``hpcontact solve`` without n (``accuracy.default_solve``) on every
  ellipse b/a, the square and the hexagon, worst over nu: true and estimated error, CPU time.

``--set NAME=VALUE`` overrides a constant of ``hpcontact.accuracy`` (SAFETY, FASTEST_FALL,
OSCILLATION_FALL, RATIO_SHARE, LEAD_SLACK …) for the replay: the calibration's trade-off.
"""

from __future__ import annotations

import argparse
import json
import math
from functools import partial
from pathlib import Path
from typing import Any

import harness
import numpy as np

from hpcontact import accuracy as acc
from hpcontact import analytic
from hpcontact.discretizations.boundary_cells import covered_solve
from hpcontact.scene import Scene

NUS = (0.0, 0.3, 0.5)
ASPECTS = (1.0, 0.7, 0.5, 0.1, 0.05, 1e-3, 1e-6, 1e-8)
REQUESTS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6)
STARTS = (16, 32)
QUANTITIES = ("K_xx", "K_yy", "K_zz", "K_a_over_K_b", "normalized_xx", "normalized_yy")
SYMMETRY = 1e-13  # true errors below this are exact by symmetry, not discretization


def references(shape: str, aspect: float, nu: float) -> dict[str, float]:
    """Closed-form K_xx, K_yy, K_zz, K_a/K_b and K_xx/K_zz, K_yy/K_zz (G = 1, semi-major axis 1;
    Li's normalized stiffnesses are these ratios times E*/G*)."""
    if shape == "circle":
        k = analytic.circle_tangential_stiffness(1.0, 1.0, nu)
        out = {"K_xx": k, "K_yy": k, "K_zz": analytic.circle_normal_stiffness(1.0, 1.0, nu), "K_a_over_K_b": 1.0}
    else:
        K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
        out = {
            "K_xx": K_a,
            "K_yy": K_b,
            "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu),
            "K_a_over_K_b": analytic.mindlin_ellipse_stiffness_ratio(aspect, nu),
        }
    return {**out, "normalized_xx": out["K_xx"] / out["K_zz"], "normalized_yy": out["K_yy"] / out["K_zz"]}


def case_params(aspect: float, nu: float) -> dict[str, Any]:
    params: dict[str, Any] = {
        "shape": "circle" if aspect == 1.0 else "ellipse",
        "nu": nu,
        "tol": 1e-12,
        "quantities": ["tangential", "normal"],
    }
    if aspect != 1.0:
        params["aspect"] = aspect
    return params


def grids(aspect: float, n0: int, max_n: int) -> list[tuple[int, int]]:
    """The grid sequence of ``solve_to_accuracy`` from n₀ (cells across: those of n₀ = 32 scaled,
    so that both starts share one cell aspect and one cache)."""
    shape = case_params(aspect, 0.0)
    from hpcontact.geometry import Shape

    across32 = acc.grid_sequence(Shape(shape["shape"], aspect=aspect), 32, None, 2**40)[0][1]
    return [(n, round(across32 * n / 32)) for n in (n0 * 2**k for k in range(20)) if n <= max_n]


def key_of(treatment: str, aspect: float, nu: float, n: int, na: int) -> str:
    return json.dumps([treatment, aspect, nu, n, na])


def solved_row(solved: Any, **keys: Any) -> dict[str, Any]:
    """The cache row of one solved grid (``harness.timed`` of ``covered_solve``): ``keys``, its
    wall and CPU seconds, CG iterations and stiffnesses."""
    r = solved.value
    return {
        **keys,
        "wall_time_s": solved.wall_s,
        "cpu_s": solved.cpu_s,
        "iterations": r["iterations"],
        **{k: r[k] for k in (*acc.TENSOR_KEYS, "K_max", "K_min") if k in r},
    }


def load(cache: Path) -> dict[str, dict[str, Any]]:
    return {
        key_of(r["treatment"], r["aspect"], r["nu"], r["n"], r["n_across"]): harness.with_principal(r)
        for r in harness.read_jsonl(cache)
    }


def estimator(strategy: str) -> tuple:
    """What ``--accuracy`` estimates a treatment's sequences with: (candidate expansions, spread
    factor) for ``accuracy.refine``; None takes the module's defaults (coverage-weighted cells)."""
    return (acc.SINGULAR_EXPANSIONS, acc.SINGULAR_SAFETY) if strategy == "singular" else (None, None)


def treatment_name(strategy: str) -> str:
    """The boundary treatment ``covered_solve`` uses with ``strategy`` (its plan's ``boundary``)."""
    return covered_solve(Scene.from_params({**case_params(1.0, 0.3), "n": 16, "tol": 1e-6}), strategy)["plan"].get(
        "boundary", ""
    )


def collect(cache: Path, max_n: int, strategy: str) -> None:
    """Solve every (case, grid) not yet cached that ``strategy`` supports (singular cells: cells
    dy/dx within [1/2, 2], so not the thin ellipses) and append it to ``cache``."""
    from hpcontact.errors import InputError

    cached = load(cache)
    treatment = treatment_name(strategy)
    for n, _ in grids(1.0, min(STARTS), max_n):
        for aspect in ASPECTS:
            na = dict(grids(aspect, min(STARTS), max_n))[n]
            for nu in NUS:
                if "cpu_s" in cached.get(key_of(treatment, aspect, nu, n, na), {}):
                    continue
                try:
                    scene = Scene.from_params({**case_params(aspect, nu), "n": n, "n_across": na})
                    solved = harness.timed(partial(covered_solve, scene, strategy))
                except InputError:  # the strategy does not apply to this case
                    continue
                row = solved_row(solved, treatment=treatment, aspect=aspect, nu=nu, n=n, n_across=na)
                harness.append_jsonl(cache, row)
                print(f"  solved b/a={aspect:g} nu={nu} {n} x {na}: {row['cpu_s']:.2f} s", flush=True)


def replay(cache: Path, strategy: str) -> tuple[list[tuple], list[tuple]]:
    """Records (case, n0, request, worst true, estimate, stopped_by, finest n) and per-quantity
    pairs (case, n0, request, quantity, true, estimate) of ``strategy``'s cached sequences."""
    cached = load(cache)
    treatment = treatment_name(strategy)
    records, pairs = [], []
    for aspect in ASPECTS:
        for nu in NUS:
            ref = references(case_params(aspect, nu)["shape"], aspect, nu)
            for n0 in STARTS:
                sequence = [g for g in grids(aspect, n0, 2**20) if key_of(treatment, aspect, nu, *g) in cached]
                if len(sequence) < acc.MIN_GRIDS:
                    continue
                for request in REQUESTS:
                    done = acc.refine(
                        sequence,
                        lambda n, na, t=treatment, a=aspect, v=nu: cached[key_of(t, a, v, n, na)],
                        request,
                        *estimator(strategy),
                    )
                    v = done.values
                    values = {
                        **v,
                        "K_a_over_K_b": v["K_xx"] / v["K_yy"],
                        "normalized_xx": v["K_xx"] / v["K_zz"],
                        "normalized_yy": v["K_yy"] / v["K_zz"],
                    }
                    true = {k: abs(values[k] / ref[k] - 1.0) for k in QUANTITIES}
                    case = f"{'circle' if aspect == 1.0 else f'ellipse b/a={aspect:g}'} nu={nu:g}"
                    records.append(
                        (
                            case,
                            n0,
                            request,
                            max(true.values()),
                            max(done.relative.values()),
                            done.stopped_by or "cache",
                            done.levels and sequence[len(done.levels) - 1][0],
                        )
                    )
                    pairs.extend(
                        (case, n0, request, k, true[k], done.relative[k]) for k in QUANTITIES if true[k] >= SYMMETRY
                    )
    return records, pairs


def cost_table(cache: Path, strategies: tuple[str, ...] = ("coverage", "singular"), n0: int = 32) -> None:
    """Markdown: per case and boundary treatment, what ``--accuracy`` 1e-3 … 1e-6 costs from the
    default start (the sum of the cached grids' CPU seconds up to where it stops; ``*``: a grid
    cached with its wall time only), the true against the estimated error, and what stopped it
    ("cache": the finest cached grid)."""
    cached = load(cache)
    print("| case | cells | 1e-3 | 1e-4 | 1e-5 | 1e-6 |")
    print("|---|---|---|---|---|---|")
    for strategy in strategies:
        treatment = treatment_name(strategy)
        for aspect in ASPECTS:
            for nu in (0.3, 0.5):
                sequence = [g for g in grids(aspect, n0, 2**20) if key_of(treatment, aspect, nu, *g) in cached]
                if len(sequence) < acc.MIN_GRIDS:
                    continue
                ref = references(case_params(aspect, nu)["shape"], aspect, nu)
                cells = []
                for request in (1e-3, 1e-4, 1e-5, 1e-6):
                    done = acc.refine(
                        sequence,
                        lambda n, na, t=treatment, a=aspect, v=nu: cached[key_of(t, a, v, n, na)],
                        request,
                        *estimator(strategy),
                    )
                    v = done.values
                    values = {
                        **v,
                        "K_a_over_K_b": v["K_xx"] / v["K_yy"],
                        "normalized_xx": v["K_xx"] / v["K_zz"],
                        "normalized_yy": v["K_yy"] / v["K_zz"],
                    }
                    true = max(abs(values[k] / ref[k] - 1.0) for k in QUANTITIES)
                    seconds = sum(level.get("cpu_s", level["wall_time_s"]) for level in done.levels)
                    wall = "" if all("cpu_s" in level for level in done.levels) else "*"  # a wall time of the cache
                    n = sequence[len(done.levels) - 1][0]
                    status = (
                        f"{seconds:.1f}{wall} s, n={n}"
                        if done.stopped_by == "met"
                        else f"not met ({done.stopped_by or 'cache'}, n={n})"
                    )
                    cells.append(f"{status}: {true:.1e} / {max(done.relative.values()):.1e}")
                name = "circle" if aspect == 1.0 else f"ellipse {aspect:g}"
                print(f"| {name}, nu {nu} | {strategy} | " + " | ".join(cells) + " |")


def defaults_table() -> None:
    """Markdown: ``hpcontact solve`` without n (``accuracy.default_solve``) on ellipses b/a = 1 …
    1e-8, the square and the hexagon, each at nu = 0, 0.3, 0.5 — the largest over nu of the true
    relative error of K_a/K_b and of K_xx, K_yy (closed forms: circle and ellipses only), of
    ``estimated_error``, and of the CPU seconds of the call (one thread), with the finest grid."""
    print("| shape | K_a/K_b true | K_xx, K_yy true | estimated_error | finest grid | CPU time |")
    print("|---|---|---|---|---|---|")
    shapes = [{"shape": "circle"}] + [{"shape": "ellipse", "aspect": a} for a in ASPECTS if a != 1.0]
    for params in shapes + [{"shape": "rectangle", "aspect": 1.0}, {"shape": "polygon", "sides": 6}]:
        rows = []
        for nu in NUS:
            solved = harness.timed(partial(acc.default_solve, Scene.from_params({**params, "nu": nu})))
            r, seconds = solved.value, solved.cpu_s
            ratio = both = math.nan
            if params["shape"] in ("circle", "ellipse"):
                ref = references(params["shape"], params.get("aspect", 1.0), nu)
                ratio = abs(r["K_a_over_K_b"] / ref["K_a_over_K_b"] - 1.0)
                both = max(abs(r[k] / ref[k] - 1.0) for k in ("K_xx", "K_yy"))
            rows.append((ratio, both, r["estimated_error"], r["nx"], r["ny"], seconds))
        name = {"circle": "circle", "rectangle": "square", "polygon": "hexagon"}.get(params["shape"])
        name = name or f"ellipse b/a = {params['aspect']:g}"
        true = "—" if math.isnan(rows[0][0]) else f"{max(x[0] for x in rows):.1e}"
        both = "—" if math.isnan(rows[0][1]) else f"{max(x[1] for x in rows):.1e}"
        finest = max(rows, key=lambda x: x[3] * x[4])
        print(
            f"| {name} | {true} | {both} | {max(x[2] for x in rows):.1e} | {finest[3]} × {finest[4]} | "
            f"{max(x[5] for x in rows):.2f} s |"
        )


#: Ellipses whose reference is Galin's exact cell (``hpcontact.accuracy.exact_solve``), nu = 0.3.
EXACT_CASES: dict[str, dict[str, Any]] = {
    "crystal ellipse b/a=0.3": {"shape": "ellipse", "aspect": 0.3, "anisotropy": 3.0, "orientation": 60.0},
    "turned ellipse b/a=0.5": {"shape": "ellipse", "aspect": 0.5, "shape_angle": 40.0},
    "turned crystal ellipse b/a=0.5": {
        "shape": "ellipse",
        "aspect": 0.5,
        "shape_angle": 40.0,
        "anisotropy": 3.0,
        "orientation": 60.0,
    },
}
EXACT_REQUESTS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5)
EXACT_NU = 0.3
#: True errors of the exact cases: these, and K_max, K_min (the turned ellipses' principal values).
EXACT_QUANTITIES = (*QUANTITIES, "K_max", "K_min")


def exact_scene(case: str, n: int | None = None, n_across: int | None = None) -> Scene:
    params = {**EXACT_CASES[case], "nu": EXACT_NU, "tol": 1e-12, "quantities": ["tangential", "normal"]}
    if n is not None:
        params.update(n=n, n_across=n_across)
    return Scene.from_params(params)


def exact_sequence(case: str, n0: int) -> list[tuple[int, int]]:
    """The grids ``solve_to_accuracy(strategy="coverage", n0=n0)`` plans for ``case`` (up to the
    estimator's calibration, n = 1024)."""
    scene = exact_scene(case)
    strategy, n0, na0 = acc.first_grid(scene, "coverage", n0, None)
    return acc.plan_grids(scene, n0, na0, acc.MAX_CELLS, None, strategy).grids


def exact_key(case: str, n: int, na: int) -> str:
    return json.dumps([case, n, na])


def load_exact(cache: Path) -> dict[str, dict[str, Any]]:
    return {exact_key(r["case"], r["n"], r["n_across"]): harness.with_principal(r) for r in harness.read_jsonl(cache)}


def collect_exact(cache: Path) -> None:
    """Solve every grid of ``EXACT_CASES``' sequences (n₀ = 16, 32) not yet cached, coverage-weighted
    cells at CG tol 1e-12, one thread, and append it with its CPU seconds to ``cache``."""
    cached = load_exact(cache)
    for case in EXACT_CASES:
        for n0 in STARTS:
            for n, na in exact_sequence(case, n0):
                if exact_key(case, n, na) in cached:
                    continue
                solved = harness.timed(partial(covered_solve, exact_scene(case, n, na), "coverage"))
                row = solved_row(solved, case=case, n=n, n_across=na)
                harness.append_jsonl(cache, row)
                cached[exact_key(case, n, na)] = row
                print(f"  solved {case} {n} x {na}: {row['cpu_s']:.2f} s", flush=True)


def exact_reference(case: str) -> dict[str, float]:
    """The exact cell's values (``accuracy.exact_solve``; its own bound ~1e-14) of ``EXACT_QUANTITIES``."""
    record = acc.exact_solve(exact_scene(case), 1e-9, False, 0.0)
    return {
        **{k: record[k] for k in ("K_xx", "K_yy", "K_zz", "K_max", "K_min")},
        "K_a_over_K_b": record["K_xx"] / record["K_yy"],
        "normalized_xx": record["K_xx"] / record["K_zz"],
        "normalized_yy": record["K_yy"] / record["K_zz"],
    }


def _derived(v: dict[str, float]) -> dict[str, float]:
    """K_xx/K_yy, K_xx/K_zz, K_yy/K_zz and the principal values of extrapolated entries."""
    from hpcontact.quantities import principal_stiffness

    k_max, k_min, _ = principal_stiffness(np.array([[v["K_xx"], v["K_xy"]], [v["K_yx"], v["K_yy"]]]))
    return {
        **v,
        "K_a_over_K_b": v["K_xx"] / v["K_yy"],
        "normalized_xx": v["K_xx"] / v["K_zz"],
        "normalized_yy": v["K_yy"] / v["K_zz"],
        "K_max": k_max,
        "K_min": k_min,
    }


def exact_replay(cache: Path) -> list[tuple]:
    """Records (case, n0, request, worst true, estimate, stopped_by, finest n) of ``EXACT_CASES``'
    cached sequences, replayed as :func:`replay` does, true errors against the exact cell."""
    cached = load_exact(cache)
    records = []
    for case in EXACT_CASES:
        ref = exact_reference(case)
        model = acc.model_error(exact_scene(case), "coverage")
        for n0 in STARTS:
            planned = exact_sequence(case, n0)
            sequence = [g for g in planned if exact_key(case, *g) in cached]
            if len(sequence) < acc.MIN_GRIDS:
                continue
            end = "calibration" if sequence == planned else "cache"  # the plan ends at the calibration's n
            for request in EXACT_REQUESTS:
                done = acc.refine(
                    sequence, lambda n, na, c=case: cached[exact_key(c, n, na)], request, model_error=model
                )
                values = _derived(done.values)
                true = max(abs(values[k] / ref[k] - 1.0) for k in EXACT_QUANTITIES)
                records.append(
                    (
                        case,
                        n0,
                        request,
                        true,
                        max(done.relative.values()),
                        done.stopped_by or end,
                        sequence[len(done.levels) - 1][0],
                    )
                )
    return records


def exact_convergence(cache: Path, case: str, n0: int = 32) -> list[tuple[float, float, float]]:
    """As :func:`convergence`, for an ``EXACT_CASES`` case against the exact cell."""
    cached = load_exact(cache)
    levels = [cached[exact_key(case, *g)] for g in exact_sequence(case, n0) if exact_key(case, *g) in cached]
    ref = exact_reference(case)
    model = acc.model_error(exact_scene(case), "coverage")
    out = []
    for k in range(acc.MIN_GRIDS, len(levels) + 1):
        values, relative, _, _ = acc.extrapolate(levels[:k])
        values = _derived(values)
        seconds = sum(level["cpu_s"] for level in levels[:k])
        out.append(
            (seconds, max(relative.values()) + model, max(abs(values[q] / ref[q] - 1.0) for q in EXACT_QUANTITIES))
        )
    return out


def singular_calibration_records(cache: Path, solve: bool = True) -> list[tuple[float, float]]:
    """(estimate, true) of the singular cells' calibration replay, ``benchmarks/edge_order.py
    --singular-calibration``'s (``edge_order.singular_records``: missing grids solved and
    appended, or with ``solve=False`` each sequence cut where its cached grids end)."""
    import edge_order as eo

    records, _ = eo.singular_records(cache, solve=solve)
    return [(estimate, true) for _, true, estimate in records]


POLYGONS = ("triangle", "hexagon")


def polygon_records(runs: Path, levels: Path) -> list[tuple[float, float]]:
    """(estimate, true) of ``benchmarks/accuracy_reference.py``'s triangle and hexagon runs (its
    run cache) against its references from finer grids (its level cache, fitted by its
    ``reference``), for every (case, nu) whose reference grids are all cached; [] otherwise
    (nothing is solved here)."""
    if not (runs.exists() and levels.exists()):
        return []
    import accuracy_reference as ar

    have = {(r["case"], r["nu"], r["n"], r["na"]): r for r in harness.read_jsonl(levels)}
    rows = [r for r in harness.read_jsonl(runs) if r.get("case") in POLYGONS and isinstance(r.get("request"), float)]
    out = []
    for case in POLYGONS:
        for nu in sorted({r["nu"] for r in rows if r["case"] == case}):
            grid = [have.get((case, nu, n, na)) for n, na in ar.REFERENCE_GRIDS.get(case, [])]
            if not grid or None in grid:
                continue
            reference = {q: v["value"] for q, v in ar.reference(grid).items()}
            for r in (r for r in rows if r["case"] == case and r["nu"] == nu):
                true = max(abs(r["values"][q] / reference[q] - 1.0) for q in reference if q in r["values"])
                out.append((r["estimated_error"], true))
    return out


FIGURE_CASES = ((1.0, "circle"), (0.7, "ellipse 0.7"), (1e-3, "ellipse 1e-3"))


def convergence(
    cached: dict[str, dict[str, Any]], strategy: str, aspect: float, nu: float = 0.3, n0: int = 32
) -> list[tuple[float, float, float]]:
    """(CPU s so far, estimated error, true error) after every grid from the ``MIN_GRIDS``-th of
    ``strategy``'s sequence from n₀ in the ``cached`` levels (``load``): what ``--accuracy`` would
    report if it stopped there."""
    treatment = treatment_name(strategy)
    sequence = [g for g in grids(aspect, n0, 2**20) if key_of(treatment, aspect, nu, *g) in cached]
    levels = [cached[key_of(treatment, aspect, nu, *g)] for g in sequence]
    ref = references(case_params(aspect, nu)["shape"], aspect, nu)
    out = []
    for k in range(acc.MIN_GRIDS, len(levels) + 1):
        values, relative, _, _ = acc.extrapolate(levels[:k], *estimator(strategy))
        values = {
            **values,
            "K_a_over_K_b": values["K_xx"] / values["K_yy"],
            "normalized_xx": values["K_xx"] / values["K_zz"],
            "normalized_yy": values["K_yy"] / values["K_zz"],
        }
        seconds = sum(level.get("cpu_s", level["wall_time_s"]) for level in levels[:k])
        out.append((seconds, max(relative.values()), max(abs(values[q] / ref[q] - 1.0) for q in QUANTITIES)))
    return out


EXACT_STYLE = {  # colour and marker of each exact case's series
    "crystal ellipse b/a=0.3": ("C4", "D"),
    "turned ellipse b/a=0.5": ("C5", "v"),
    "turned crystal ellipse b/a=0.5": ("C6", "P"),
}


def figure(
    cache: Path,
    singular_cache: Path | None,
    path: Path,
    strip_cache: Path | None = None,
    exact_cache: Path | None = None,
    polygon_caches: tuple[Path, Path] | None = None,
) -> None:
    """Left: true against estimated error of every replayed record, coverage-weighted cells (this
    cache), singular cells (``benchmarks/edge_order.py``'s calibration cache) and strips (the
    ellipses of ``benchmarks/strip_calibration.py``'s cache), when given; honest below the
    diagonal, sharp above the 1/30 line. Right: what ``--accuracy`` reports after each grid
    against the CPU seconds of the sequence so far (nu = 0.3, from n = 32; strips from 16):
    estimate solid, true error dashed, for every treatment that applies. With ``exact_cache``:
    the crystal and turned ellipses (``EXACT_CASES``, coverage-weighted cells, true errors against
    the exact cell) as series of their own on both sides; with ``polygon_caches`` (the run and
    level caches of ``benchmarks/accuracy_reference.py``) the triangle's and hexagon's records
    against its finer-grid references, where they are there."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.6))
    sets = [("coverage-weighted", "C0", "o", [(r[4], r[3]) for r in replay(cache, "coverage")[0]])]
    if singular_cache is not None:
        sets.append(("singular cells", "C3", "^", singular_calibration_records(singular_cache, solve=False)))
    strips = None
    if strip_cache is not None:
        import strip_calibration as strip

        strips = strip.load(strip_cache, [])  # cached grids only
        ellipses = sorted({(s, a) for s, a, _, _ in strips if s == "ellipse"})
        sets.append(
            (
                "strips (ellipses)",
                "C2",
                "s",
                [(r["estimate"], max(r["true"].values())) for r in strip.replay(strips, ellipses)],
            )
        )
    exact = exact_replay(exact_cache) if exact_cache is not None else []
    exact_sets = []
    for case, (colour, marker) in EXACT_STYLE.items():
        points = [(r[4], r[3]) for r in exact if r[0] == case]
        if points:
            exact_sets.append((f"{case}, coverage (exact-cell ref.)", colour, marker, points))
    polygons = polygon_records(*polygon_caches) if polygon_caches is not None else []
    if polygons:
        exact_sets.append(("triangle, hexagon, coverage (finer-grid ref.)", "C7", "*", polygons))
    sets += exact_sets
    low = 1e-2
    for index, (label, colour, marker, points) in enumerate(sets):
        estimate, true = np.array(points).T
        own = index >= len(sets) - len(exact_sets)  # the exact cell's and the polygons' series: on top
        low = min(low, float(np.min(estimate)), float(np.min(np.maximum(true, 1e-14))))
        left.loglog(
            estimate,
            np.maximum(true, 1e-14),
            marker,
            color=colour,
            ms=5.5 if own else 3.5,
            mec="k" if own else colour,
            mew=0.4,
            alpha=0.9 if own else 0.6,
            ls="none",
            zorder=3 if own else 2,
            label=f"{label}: {len(points)} records, worst true/estimate {np.max(true / estimate):.2f}",
        )
    low = max(10 ** np.floor(np.log10(low / 3)), 1e-14)  # the records' range (strips reach 1e-12)
    line = np.array([low, 1e-2])
    left.loglog(line, line, "k-", lw=1, label="true = estimate (honest below)")
    left.loglog(line, line / 30, "k:", lw=1, label="true = estimate / 30 (sharp above)")
    left.set(
        xlabel="estimated relative error (--accuracy)",
        ylabel="true relative error (closed forms, exact cell, finer grids)",
        title="Honesty and sharpness of the estimate",
        xlim=(low, 1e-2),
        ylim=(low, 1e-2),
    )
    left.legend(fontsize=6.5, loc="upper left")
    cached = load(cache)
    for (aspect, name), colour in zip(FIGURE_CASES, ("C0", "C1", "C2")):
        for strategy, marker in (("coverage", "o"), ("singular", "^")):
            points = convergence(cached, strategy, aspect)
            if not points:
                continue
            seconds, estimate, true = np.array(points).T
            right.loglog(seconds, estimate, "-" + marker, color=colour, ms=4, label=f"{name}, {strategy}")
            right.loglog(seconds, true, "--" + marker, color=colour, ms=3, alpha=0.6)
        if strips is not None and aspect < 1.0:
            seconds, estimate, true = np.array(strip.convergence(strips, "ellipse", aspect)).T
            right.loglog(seconds, estimate, "-s", color=colour, ms=4, label=f"{name}, strips")
            right.loglog(seconds, np.maximum(true, 1e-12), "--s", color=colour, ms=3, alpha=0.6)
    for case, (colour, marker) in EXACT_STYLE.items():
        points = exact_convergence(exact_cache, case) if exact_cache is not None else []
        if not points:
            continue
        seconds, estimate, true = np.array(points).T
        right.loglog(seconds, estimate, "-" + marker, color=colour, ms=4, label=f"{case}, coverage")
        right.loglog(seconds, true, "--" + marker, color=colour, ms=3, alpha=0.6)
    right.set(
        xlabel="CPU seconds of the grid sequence so far (one core)",
        ylabel="relative error: estimate (solid), true (dashed)",
        title="What --accuracy reports, per second",
    )
    right.legend(fontsize=6.5, ncol=2)
    from matplotlib.ticker import NullFormatter

    right.xaxis.set_minor_formatter(NullFormatter())
    for axis in (left, right):
        axis.grid(True, which="major", alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def summary(label: str, true: np.ndarray, estimated: np.ndarray) -> str:
    if len(true) == 0:
        return f"{label}: 0 (the cache holds no sequence long enough: fill it with --collect)"
    ratio = true / estimated
    return (
        f"{label}: {len(ratio)}; worst true/estimate {ratio.max():.2f} (honest when <= 1; "
        f"{int((ratio > 1).sum())} above 1); worst estimate/true {1 / ratio.min():.0f}; "
        f"true >= estimate/30 in {100 * (ratio >= 1 / 30).mean():.1f} %"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cache", type=Path, default=harness.RESULTS / "accuracy_sharpness.jsonl")
    parser.add_argument("--max-n", type=int, default=1024)
    parser.add_argument("--collect", action="store_true")
    parser.add_argument("--table", action="store_true")
    parser.add_argument("--cost", action="store_true", help="print the time-to-accuracy table (both treatments)")
    parser.add_argument("--defaults", action="store_true", help="run and print the default discretization's table")
    parser.add_argument(
        "--strategy", default="coverage", help="covered_solve's boundary treatment: coverage or singular"
    )
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("--figure", type=Path, default=None, help="write the honesty and error-per-second figure here")
    parser.add_argument(
        "--singular-cache",
        type=Path,
        default=None,
        help="benchmarks/edge_order.py --singular-calibration's cache, for the figure's singular records",
    )
    parser.add_argument(
        "--strip-cache",
        type=Path,
        default=None,
        help="benchmarks/strip_calibration.py's cache, for the figure's strip records (ellipses)",
    )
    parser.add_argument(
        "--exact-cases",
        action="store_true",
        help="collect (with --collect) and replay the crystal and turned ellipses against the exact cell",
    )
    parser.add_argument("--exact-cache", type=Path, default=harness.RESULTS / "accuracy_sharpness_exact.jsonl")
    parser.add_argument(
        "--polygons",
        action="store_true",
        help="the figure's triangle and hexagon records, from benchmarks/accuracy_reference.py's caches",
    )
    parser.add_argument("--runs", type=Path, default=harness.RESULTS / "accuracy_reference_runs.jsonl")
    parser.add_argument("--levels", type=Path, default=harness.RESULTS / "accuracy_reference_levels.jsonl")
    args = parser.parse_args()
    print(f"accuracy_sharpness: {harness.machine_line(1)}")
    for item in args.set:
        name, value = item.split("=")
        if not hasattr(acc, name):
            raise SystemExit(f"hpcontact.accuracy has no constant {name}")
        setattr(acc, name, float(value))
    if args.collect and args.exact_cases:
        collect_exact(args.exact_cache)
    elif args.collect:
        collect(args.cache, args.max_n, args.strategy)
    records, pairs = replay(args.cache, args.strategy)
    print(f"boundary treatment: {treatment_name(args.strategy)}")
    print(
        summary(
            "records (case, request, start grid)", np.array([r[3] for r in records]), np.array([r[4] for r in records])
        )
    )
    print(summary("quantities", np.array([p[4] for p in pairs]), np.array([p[5] for p in pairs])))
    met = [r for r in records if r[5] == "met"]
    print(
        f"requests met: {len(met)} of {len(records)}; stopped by: "
        + ", ".join(f"{s} {sum(r[5] == s for r in records)}" for s in sorted({r[5] for r in records}))
    )
    if args.cost:
        cost_table(args.cache)
    if args.defaults:
        defaults_table()
    if args.exact_cases:
        exact = exact_replay(args.exact_cache)
        print(
            summary(
                "exact-cell cases (crystal, turned; coverage-weighted cells)",
                np.array([r[3] for r in exact]),
                np.array([r[4] for r in exact]),
            )
        )
        for case in EXACT_CASES:
            mine = [r for r in exact if r[0] == case]
            if mine:
                worst = max(mine, key=lambda r: r[3] / r[4])
                print(
                    f"  {case}: {len(mine)} records, worst true/estimate {worst[3] / worst[4]:.2f} "
                    f"(request {worst[2]:.0e} from n0 = {worst[1]}: true {worst[3]:.2e}, estimate {worst[4]:.2e}, "
                    f"n = {worst[6]}); met {sum(r[5] == 'met' for r in mine)}"
                )
        case = next(iter(EXACT_CASES))  # the replay is the live loop: one request checked against a live call
        live = acc.solve_to_accuracy(exact_scene(case), 1e-3, n0=32, strategy="coverage", strict=False)
        ref = exact_reference(case)
        values = _derived({k: live[k] for k in ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz")})
        replayed = next(r for r in exact if r[0] == case and r[1] == 32 and r[2] == 1e-3)
        print(
            f"  live solve_to_accuracy({case}, 1e-3, n0=32, coverage): estimate {live['estimated_error']:.3e}, "
            f"true {max(abs(values[q] / ref[q] - 1.0) for q in EXACT_QUANTITIES):.3e}, grids {live['grids']}; "
            f"replayed: estimate {replayed[4]:.3e}, true {replayed[3]:.3e}"
        )
        if args.table:
            for case, n0, request, true, est, stopped, n in exact:
                print(
                    f"{case:32s} {n0:3d} {request:8.0e} {true:9.2e} {est:9.2e} {est / true:6.1f} {stopped:>11s} {n:5d}"
                )
    if args.polygons:
        polygons = polygon_records(args.runs, args.levels)
        print(
            summary(
                "polygons (triangle, hexagon; accuracy_reference.py)",
                np.array([t for _, t in polygons]),
                np.array([e for e, _ in polygons]),
            )
        )
    if args.figure is not None:
        figure(
            args.cache,
            args.singular_cache,
            args.figure,
            args.strip_cache,
            args.exact_cache if args.exact_cases else None,
            (args.runs, args.levels) if args.polygons else None,
        )
    if args.table:
        print(
            f"{'case':28s} {'n0':>3s} {'request':>8s} {'true':>9s} {'estimate':>9s} {'ratio':>6s} {'stopped':>11s} {'n':>5s}"
        )
        for case, n0, request, true, est, stopped, n in records:
            print(f"{case:28s} {n0:3d} {request:8.0e} {true:9.2e} {est:9.2e} {est / true:6.1f} {stopped:>11s} {n:5d}")


if __name__ == "__main__":
    harness.entry(main)
