"""Thin ellipses: which first-grid shape (n₀ along, na₀ across) buys ``--accuracy`` the most accuracy per CPU second.

    python benchmarks/thin_grids.py [--collect] [--cache results/thin_grids.jsonl]
        [--aspects 1e-3 1e-6 0.05 0.1] [--nus 0.3 0.5] [--max-cells 2097152] [--max-cpu 60]
        [--levels] [--split]

Cases: Mindlin's bonded ellipse b/a = 1e-3, 1e-6 (thin) and 0.05, 0.1 (for comparison), nu = 0.3
and 0.5, against the closed forms (``benchmarks.accuracy_sharpness.references``: K_xx, K_yy from
``analytic.mindlin_ellipse_stiffness``, K_zz from ``elliptical_punch_normal_stiffness``, K_a/K_b).
Sequences: first grid (n₀, na₀) ∈ {16, 32, 64} × {4, 8, 16, 32} (cells along the major axis ×
across), refined by ``accuracy.RATIO`` = 2 in both (fixed cell aspect, as ``grid_sequence``).
The twelve starts lie on six families of one cell aspect na/n ∈ {1/16 … 2}, so a grid is solved
once and shared by every start on its family.

``--collect`` solves every grid not yet cached with ``covered_solve(scene, strategy="coverage")``
(tangential and normal, CG tol 1e-10), each in a fresh child process (its own FFTW planning, as
one grid of an ``--accuracy`` run), one at a time, smallest grids first over all cases, thin
aspects first; it skips a grid above ``--max-cells`` or whose CPU time, extrapolated linearly in
the cells from the case's largest solved grid, would exceed ``--max-cpu`` seconds. Each line of the
cache (JSON, key: aspect, nu, n, n_across, strategy) holds the stiffnesses, the child's CPU seconds
(``time.process_time``: the time on a core, not inflated by the machine's other work), its wall
seconds and the load average (``os.getloadavg``) when it started.

The report (always printed, from the cache):

* ``--levels``: per case and start, per grid: cumulative CPU s, raw relative error of K_xx, K_yy,
  K_zz, K_a/K_b, and from the fourth grid on what ``accuracy.extrapolate`` (default
  ``EXPANSIONS``) reports on the levels so far: the estimate (``estimated_error``, largest over
  every quantity) and the largest true error of the extrapolated K_xx, K_yy, K_zz, K_a/K_b, with
  the quantities whose own estimate is below their true error (dishonest);
* per case and request 1e-4, 1e-5, 1e-6: every start's cost when ``accuracy.refine`` (the loop of
  ``--accuracy``) meets it on the cached grids (CPU s of the sequence up to its stopping grid),
  true / estimate, honesty, and the cheapest start;
* ``--split``: the raw error at fixed n against n_across and at fixed n_across against n, and a
  least-squares fit e ≈ A/n + B/na per quantity over grids with n ≥ 128 and na ≥ 16 (the along-x
  and across-y parts; with |errors| adding, the cells n·na are best spent at na/n = B/A).

Measured (2026-11-23, 2-core machine with other work, load 1–2.5; 344 solves, 2M-cell grids only
where the case's 1M-cell grids predicted ≤ 60 s): the family of today's 32 × 8 (na/n = 1/4; 16 × 4
and 64 × 16 share it) is the cheapest to 1e-4 in all eight cases (1.2–2.5 s) and the only one
whose records are honest everywhere (worst true/estimate 0.89; four per-quantity pairs, K_yy and
K_zz at b/a = 1e-3 on 2048 × 512, up to 3.0× below their own estimate); it meets 1e-5 at 1e-6 in
11–12 s and at 1e-3 in 42–43 s, not at 0.05 and 0.1 within 2M cells. na/n = 1/8 (32 × 4) meets
1e-5 at 0.1 in 13–14 s but is 1.77× dishonest at 1e-3; na/n ≥ 1/2 is dishonest up to 4.4×. No
start meets 1e-6. Thin shapes: the raw error is ≈ −0.1/na (doubling na at fixed n halves it,
doubling n at fixed na changes it by 5–15 %); at 0.05 and 0.1 it depends on the cell aspect and
is not a sum of an along and an across part.
"""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import harness
import numpy as np
from accuracy_sharpness import references

from hpcontact import accuracy as acc

ASPECTS = (1e-3, 1e-6, 0.05, 0.1)
NUS = (0.3, 0.5)
ALONG = (16, 32, 64)
ACROSS = (4, 8, 16, 32)
REQUESTS = (1e-4, 1e-5, 1e-6)
QUANTITIES = ("K_xx", "K_yy", "K_zz", "K_a_over_K_b")
STRATEGY = "coverage"
TOL = 1e-10
Grid = tuple[int, int]


# ------------------------------------------------------------------------------------------
# grids and cache
# ------------------------------------------------------------------------------------------
def sequence(n0: int, na0: int, max_cells: int) -> list[Grid]:
    """(n₀ 2ᵏ, na₀ 2ᵏ) with at most ``max_cells`` cells."""
    out, n, na = [], n0, na0
    while n * na <= max_cells:
        out.append((n, na))
        n, na = n * 2, na * 2
    return out


def all_grids(max_cells: int) -> list[Grid]:
    """Every grid of every start, smallest first."""
    grids = {g for n0 in ALONG for na0 in ACROSS for g in sequence(n0, na0, max_cells)}
    return sorted(grids, key=lambda g: (g[0] * g[1], g))


def params_of(aspect: float, nu: float, n: int, na: int) -> dict[str, Any]:
    return {
        "shape": "ellipse",
        "aspect": aspect,
        "nu": nu,
        "n": n,
        "n_across": na,
        "quantities": ["tangential", "normal"],
        "tol": TOL,
    }


def key_of(aspect: float, nu: float, n: int, na: int, strategy: str = STRATEGY) -> str:
    return json.dumps([aspect, nu, n, na, strategy])


def load(cache: Path) -> dict[str, dict[str, Any]]:
    """The cached solves by key (a later line replaces an earlier one)."""
    return {key_of(r["aspect"], r["nu"], r["n"], r["n_across"], r["strategy"]): r for r in harness.read_jsonl(cache)}


def solve_one(aspect: float, nu: float, n: int, na: int) -> dict[str, Any]:
    """One coverage-weighted solve with its CPU and wall seconds (run in a child process)."""
    from hpcontact.discretizations.boundary_cells import covered_solve
    from hpcontact.scene import Scene

    load1 = os.getloadavg()[0]
    scene = Scene.from_params(params_of(aspect, nu, n, na))
    solved = harness.timed(lambda: covered_solve(scene, strategy=STRATEGY))
    r = solved.value
    return {
        "aspect": aspect,
        "nu": nu,
        "n": n,
        "n_across": na,
        "strategy": STRATEGY,
        "tol": TOL,
        "cpu_s": solved.cpu_s,
        "wall_s": solved.wall_s,
        "load": load1,
        "iterations": r["iterations"],
        **{k: r[k] for k in acc.TENSOR_KEYS if k in r},
    }


def solve_in_child(aspect: float, nu: float, n: int, na: int) -> dict[str, Any]:
    """``solve_one`` in a fresh interpreter (one thread): no FFTW plans from earlier solves."""
    return harness.call_in_child(__file__, "solve_one", aspect, nu, n, na, threads=1, check=True).result


def predicted_cpu(cached: dict[str, dict[str, Any]], aspect: float, nu: float, cells: int) -> float:
    """CPU seconds of a grid of ``cells`` cells, linear in the cells from the case's largest solved grid."""
    rows = [r for r in cached.values() if r["aspect"] == aspect and r["nu"] == nu]
    if not rows:
        return 0.0
    big = max(rows, key=lambda r: r["n"] * r["n_across"])
    return big["cpu_s"] * cells / (big["n"] * big["n_across"])


def collect(cache: Path, aspects: Iterable[float], nus: Iterable[float], max_cells: int, max_cpu: float) -> None:
    """Solve and append every missing grid (module docstring for the order and the limits)."""
    cached = load(cache)
    for n, na in all_grids(max_cells):
        for aspect in aspects:
            for nu in nus:
                if key_of(aspect, nu, n, na) in cached or predicted_cpu(cached, aspect, nu, n * na) > max_cpu:
                    continue
                row = solve_in_child(aspect, nu, n, na)
                cached[key_of(aspect, nu, n, na)] = row
                harness.append_jsonl(cache, row)
                print(
                    f"  solved b/a={aspect:g} nu={nu} {n} x {na}: {row['cpu_s']:.2f} s CPU, "
                    f"{row['wall_s']:.2f} s wall, load {row['load']:.2f}",
                    flush=True,
                )


# ------------------------------------------------------------------------------------------
# replay
# ------------------------------------------------------------------------------------------
def with_ratios(values: dict[str, float]) -> dict[str, float]:
    return {**values, "K_a_over_K_b": values["K_xx"] / values["K_yy"]}


def errors(values: dict[str, float], ref: dict[str, float]) -> dict[str, float]:
    """Signed relative errors of K_xx, K_yy, K_zz, K_a/K_b."""
    v = with_ratios(values)
    return {k: v[k] / ref[k] - 1.0 for k in QUANTITIES}


def cached_sequence(
    cached: dict[str, dict[str, Any]], aspect: float, nu: float, n0: int, na0: int, max_cells: int
) -> list[dict[str, Any]]:
    """The start's levels in order, up to the first grid not cached."""
    levels = []
    for n, na in sequence(n0, na0, max_cells):
        row = cached.get(key_of(aspect, nu, n, na))
        if row is None:
            break
        levels.append(row)
    return levels


def level_table(levels: list[dict[str, Any]], ref: dict[str, float]) -> list[str]:
    """Per grid: cumulative CPU, raw errors and what the estimator says after it."""
    lines, cpu = [], 0.0
    for k, row in enumerate(levels):
        cpu += row["cpu_s"]
        raw = errors(row, ref)
        line = f"    {row['n']:5d} x {row['n_across']:4d} {cpu:7.1f} s  raw " + " ".join(
            f"{raw[q]:+.1e}" for q in QUANTITIES
        )
        if k + 1 >= acc.MIN_GRIDS:
            values, relative, _, _ = acc.extrapolate(levels[: k + 1])
            true = {q: abs(e) for q, e in errors(values, ref).items()}
            bad = [q for q in QUANTITIES if true[q] > relative[q]]
            line += f" | est {max(relative.values()):.1e} true {max(true.values()):.1e}" + (
                f" DISHONEST {','.join(bad)}" if bad else ""
            )
        lines.append(line)
    return lines


def outcome(levels: list[dict[str, Any]], ref: dict[str, float], request: float) -> dict[str, Any]:
    """``accuracy.refine`` on the cached levels: stop, CPU s up to it, true and estimated error."""
    by_grid = {(r["n"], r["n_across"]): r for r in levels}
    done = acc.refine(list(by_grid), lambda n, na: by_grid[(n, na)], request)
    true = {q: abs(e) for q, e in errors(done.values, ref).items()} if done.values else {}
    last = done.levels[-1]
    return {
        "stopped_by": done.stopped_by or "cache",
        "cpu_s": sum(r["cpu_s"] for r in done.levels),
        "grid": (last["n"], last["n_across"]),
        "true": max(true.values()) if true else float("nan"),
        "estimate": max(done.relative.values()) if done.relative else float("nan"),
        "dishonest": [q for q in QUANTITIES if true and true[q] > done.relative[q]],
    }


def fmt_outcome(o: dict[str, Any]) -> str:
    n, na = o["grid"]
    head = f"{o['cpu_s']:.1f} s" if o["stopped_by"] == "met" else f"no ({o['stopped_by']})"
    honest = "honest" if not o["dishonest"] else "DISHONEST " + ",".join(o["dishonest"])
    return f"{head} {n}x{na} {o['true']:.1e}/{o['estimate']:.1e} {honest}"


def report_case(cached: dict[str, dict[str, Any]], aspect: float, nu: float, max_cells: int, show_levels: bool) -> None:
    ref = references("ellipse", aspect, nu)
    print(f"\n## b/a = {aspect:g}, nu = {nu}")
    starts = [(n0, na0) for n0 in ALONG for na0 in ACROSS]
    sequences = {s: cached_sequence(cached, aspect, nu, *s, max_cells) for s in starts}
    if show_levels:
        for (n0, na0), levels in sequences.items():
            if levels:
                print(f"  start {n0} x {na0} (raw: {', '.join(QUANTITIES)})")
                print("\n".join(level_table(levels, ref)))
    for request in REQUESTS:
        print(f"  request {request:.0e}:")
        met = []
        for start, levels in sequences.items():
            if len(levels) < acc.MIN_GRIDS:
                continue
            o = outcome(levels, ref, request)
            print(f"    {start[0]:3d} x {start[1]:2d}: {fmt_outcome(o)}")
            if o["stopped_by"] == "met":
                met.append((o["cpu_s"], start, o))
        if met:
            _, start, o = min(met)
            print(f"    cheapest: {start[0]} x {start[1]}: {fmt_outcome(o)}")
            honest = [m for m in met if not m[2]["dishonest"]]
            if honest and min(honest)[1] != start:
                _, start, o = min(honest)
                print(f"    cheapest honest: {start[0]} x {start[1]}: {fmt_outcome(o)}")


# ------------------------------------------------------------------------------------------
# along-x and across-y parts
# ------------------------------------------------------------------------------------------
def split_fit(rows: list[dict[str, Any]], ref: dict[str, float], quantity: str) -> tuple[float, float, float]:
    """Least squares e ≈ A/n + B/na (relative to e) over ``rows``: A, B and the worst misfit over |e|."""
    e = np.array([errors(r, ref)[quantity] for r in rows])
    M = np.array([[1.0 / r["n"], 1.0 / r["n_across"]] for r in rows]) / np.abs(e)[:, None]
    (A, B), *_ = np.linalg.lstsq(M, e / np.abs(e), rcond=None)
    fit = np.array([A / r["n"] + B / r["n_across"] for r in rows])
    return float(A), float(B), float(np.max(np.abs(fit - e) / np.abs(e)))


def report_split(cached: dict[str, dict[str, Any]], aspect: float, nu: float) -> None:
    ref = references("ellipse", aspect, nu)
    rows = [r for r in cached.values() if r["aspect"] == aspect and r["nu"] == nu]
    if not rows:
        return
    print(f"\n## split b/a = {aspect:g}, nu = {nu} (raw errors {', '.join(QUANTITIES)})")
    n_fix = max({r["n"] for r in rows}, key=lambda n: (sum(r["n"] == n for r in rows), n))
    print(f"  fixed n = {n_fix}:")
    for r in sorted((r for r in rows if r["n"] == n_fix), key=lambda r: r["n_across"]):
        print(f"    na {r['n_across']:5d}: " + " ".join(f"{e:+.2e}" for e in errors(r, ref).values()))
    na_fix = max({r["n_across"] for r in rows}, key=lambda na: (sum(r["n_across"] == na for r in rows), na))
    print(f"  fixed na = {na_fix}:")
    for r in sorted((r for r in rows if r["n_across"] == na_fix), key=lambda r: r["n"]):
        print(f"    n {r['n']:5d}: " + " ".join(f"{e:+.2e}" for e in errors(r, ref).values()))
    fine = [r for r in rows if r["n"] >= 128 and r["n_across"] >= 16]
    if len(fine) >= 3:
        for quantity in QUANTITIES:
            A, B, misfit = split_fit(fine, ref, quantity)
            print(
                f"  fit {quantity:13s}: A = {A:+.3e} (along), B = {B:+.3e} (across), best na/n = |B/A| = "
                f"{abs(B / A):.3g}, worst misfit {misfit:.0%} over {len(fine)} grids"
            )


def honesty(
    cached: dict[str, dict[str, Any]], aspects: Iterable[float], nus: Iterable[float], start: Grid, max_cells: int
) -> tuple[int, float, int, float]:
    """Over every case and every grid from the fourth on of ``start``'s sequence: records, worst
    true/estimate of the record (largest true error of K_xx, K_yy, K_zz, K_a/K_b against
    ``estimated_error``), per-quantity pairs above their own estimate, worst per-quantity ratio."""
    records, worst, bad, worst_q = 0, 0.0, 0, 0.0
    for aspect in aspects:
        for nu in nus:
            ref = references("ellipse", aspect, nu)
            levels = cached_sequence(cached, aspect, nu, *start, max_cells)
            for k in range(acc.MIN_GRIDS, len(levels) + 1):
                values, relative, _, _ = acc.extrapolate(levels[:k])
                true = {q: abs(e) for q, e in errors(values, ref).items()}
                records += 1
                worst = max(worst, max(true.values()) / max(relative.values()))
                bad += sum(true[q] > relative[q] for q in QUANTITIES)
                worst_q = max(worst_q, max(true[q] / relative[q] for q in QUANTITIES))
    return records, worst, bad, worst_q


def report_summary(cached: dict[str, dict[str, Any]], aspects: list[float], nus: list[float], max_cells: int) -> None:
    """Per start: honesty over all its records, and per request and case the CPU s to meet it."""
    cases = [(a, nu) for a in aspects for nu in nus]
    print("\n## summary per start: honesty over every grid from the 4th (all cases); CPU s to meet each request")
    print("  cases: " + ", ".join(f"{a:g}/{nu}" for a, nu in cases) + "  ('-': not met on the cached grids)")
    for start in [(n0, na0) for n0 in ALONG for na0 in ACROSS]:
        records, worst, bad, worst_q = honesty(cached, aspects, nus, start, max_cells)
        cells = []
        for request in REQUESTS:
            costs = []
            for aspect, nu in cases:
                levels = cached_sequence(cached, aspect, nu, *start, max_cells)
                o = (
                    outcome(levels, references("ellipse", aspect, nu), request)
                    if len(levels) >= acc.MIN_GRIDS
                    else None
                )
                ok = o is not None and o["stopped_by"] == "met"
                costs.append(f"{o['cpu_s']:.1f}{'!' if o['dishonest'] else ''}" if ok else "-")
            cells.append(f"{request:.0e}: " + " ".join(costs))
        print(
            f"  {start[0]:2d} x {start[1]:2d}: records {records:3d} worst true/est {worst:.2f}, "
            f"quantities above own estimate {bad} (worst {worst_q:.2f}) | " + " | ".join(cells)
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cache", type=Path, default=harness.RESULTS / "thin_grids.jsonl")
    parser.add_argument("--collect", action="store_true")
    parser.add_argument("--aspects", type=float, nargs="+", default=list(ASPECTS))
    parser.add_argument("--nus", type=float, nargs="+", default=list(NUS))
    parser.add_argument("--max-cells", type=int, default=2**21)
    parser.add_argument("--max-cpu", type=float, default=60.0)
    parser.add_argument("--levels", action="store_true", help="print every sequence grid by grid")
    parser.add_argument("--split", action="store_true", help="print the along-x / across-y split")
    parser.add_argument("--no-cases", action="store_true", help="print the summary only")
    args = parser.parse_args()
    print(f"thin_grids: {harness.machine_line(1)}")
    if args.collect:
        collect(args.cache, args.aspects, args.nus, args.max_cells, args.max_cpu)
    cached = load(args.cache)
    print(f"load average now {os.getloadavg()}; cached solves {len(cached)}")
    report_summary(cached, args.aspects, args.nus, args.max_cells)
    for aspect in [] if args.no_cases else args.aspects:
        for nu in args.nus:
            report_case(cached, aspect, nu, args.max_cells, args.levels)
            if args.split:
                report_split(cached, aspect, nu)


if __name__ == "__main__":
    harness.entry(main)
