"""Sharpness and honesty of ``--accuracy``'s error estimate over (case, request) pairs.

    python benchmarks/accuracy_sharpness.py [--cache results/accuracy_sharpness.jsonl]
        [--max-n 1024] [--collect] [--strategy coverage|singular] [--set SAFETY=3 ...]
        [--table] [--cost] [--defaults] [--figure PNG [--singular-cache CACHE] [--strip-cache CACHE]]

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


def load(cache: Path) -> dict[str, dict[str, Any]]:
    return {key_of(r["treatment"], r["aspect"], r["nu"], r["n"], r["n_across"]): r for r in harness.read_jsonl(cache)}


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
                r = solved.value
                row = {
                    "treatment": treatment,
                    "aspect": aspect,
                    "nu": nu,
                    "n": n,
                    "n_across": na,
                    "wall_time_s": solved.wall_s,
                    "cpu_s": solved.cpu_s,
                    "iterations": r["iterations"],
                    **{k: r[k] for k in acc.TENSOR_KEYS if k in r},
                }
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


def figure(cache: Path, singular_cache: Path | None, path: Path, strip_cache: Path | None = None) -> None:
    """Left: true against estimated error of every replayed record, coverage-weighted cells (this
    cache), singular cells (``benchmarks/edge_order.py``'s calibration cache) and strips (the
    ellipses of ``benchmarks/strip_calibration.py``'s cache), when given; honest below the
    diagonal, sharp above the 1/30 line. Right: what ``--accuracy`` reports after each grid
    against the CPU seconds of the sequence so far (nu = 0.3, from n = 32; strips from 16):
    estimate solid, true error dashed, for every treatment that applies."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.6))
    sets = [("coverage-weighted", "C0", "o", [(r[4], r[3]) for r in replay(cache, "coverage")[0]])]
    if singular_cache is not None:
        from edge_order import singular_records

        sets.append(("singular cells", "C3", "^", [(e, t) for _, t, e in singular_records(singular_cache)[0]]))
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
    for label, colour, marker, points in sets:
        estimate, true = np.array(points).T
        left.loglog(
            estimate,
            np.maximum(true, 1e-14),
            marker,
            color=colour,
            ms=3.5,
            alpha=0.6,
            ls="none",
            label=f"{label}: {len(points)} records, worst true/estimate {np.max(true / estimate):.2f}",
        )
    line = np.array([1e-12, 1e-2])
    left.loglog(line, line, "k-", lw=1, label="true = estimate (honest below)")
    left.loglog(line, line / 30, "k:", lw=1, label="true = estimate / 30 (sharp above)")
    left.set(
        xlabel="estimated relative error (--accuracy)",
        ylabel="true relative error (closed forms)",
        title="Honesty and sharpness of the estimate",
        ylim=(1e-14, 1e-2),
    )
    left.legend(fontsize=7, loc="upper left")
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
    right.set(
        xlabel="CPU seconds of the grid sequence so far (one core, cached solve times)",
        ylabel="relative error: estimate (solid), true (dashed)",
        title="What --accuracy reports, per second",
    )
    right.legend(fontsize=7)
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
    args = parser.parse_args()
    print(f"accuracy_sharpness: {harness.machine_line(1)}")
    for item in args.set:
        name, value = item.split("=")
        if not hasattr(acc, name):
            raise SystemExit(f"hpcontact.accuracy has no constant {name}")
        setattr(acc, name, float(value))
    if args.collect:
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
    if args.figure is not None:
        figure(args.cache, args.singular_cache, args.figure, args.strip_cache)
    if args.table:
        print(
            f"{'case':28s} {'n0':>3s} {'request':>8s} {'true':>9s} {'estimate':>9s} {'ratio':>6s} {'stopped':>11s} {'n':>5s}"
        )
        for case, n0, request, true, est, stopped, n in records:
            print(f"{case:28s} {n0:3d} {request:8.0e} {true:9.2e} {est:9.2e} {est / true:6.1f} {stopped:>11s} {n:5d}")


if __name__ == "__main__":
    harness.entry(main)
