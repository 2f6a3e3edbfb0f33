"""Observed convergence orders and error against time: coverage-weighted cells versus singular cells.

    python benchmarks/edge_order.py [--quick] [--nmax 512] [--out results/edge_order.json]

Before: ``covered_solve(..., strategy="coverage")`` (piecewise-constant traction, covered
fraction f per cell, self-compliance A_ii/f). After: ``strategy="auto"`` — singular cells
(``hpcontact.discretizations.singular_cells``: Galerkin on w = (1 − x²/a² − y²/b²)^(−½) per cell) where they
apply (unturned circles and ellipses on cells with dy/dx in [1/2, 2]), coverage otherwise; the
``boundary`` column says which ran.

Per case (nu = 0.3, K_xx; grids n = 32·2^k with ``accuracy.grid_sequence``'s n_across) it prints
for every grid: the relative error of the raw value, n·error (a constant for a clean first-order
method), the observed order of the raw sequence p = log2(|Q_{k−1} − Q_{k−2}| / |Q_k − Q_{k−1}|),
the error of the order-1 Richardson extrapolant R_k = 2 Q_k − Q_{k−1} and its observed order,
the solve's time and the time of the sequence so far (the cost of the extrapolant). "ellipse 0.05
sq" starts at 128 × 8 cells (dy/dx = 0.8, where singular cells apply) instead of 32 × 8 (dy/dx =
0.2, where they do not) and runs to 4 × 128 along x. Errors are
against Mindlin's closed form (circle, ellipses); for the square (polygon, 4 sides, turned 45°),
the hexagon and the 1e-8 rectangle against a reference: the order-1 Richardson extrapolant of
coverage-weighted solves at n = 2·nmax and 4·nmax (finer than any grid of the sequence), whose
own uncertainty |R(4 nmax) − R(2 nmax)| is printed with it (``--quick`` leaves these out).

``--done-when REQUEST``: issue 12's table — ``solve_to_accuracy`` at REQUEST for ellipses b/a =
0.7, 0.05, 1e-3, 1e-6, nu = 0.3, 0.5, with coverage-weighted cells and with ``auto`` (singular
cells from ``accuracy.singular_start`` where they apply), grids up to ``--max-cells`` (default
1024² − 1: the n = 1024 of the issue's coverage figures): estimate, true error, CPU s, peak MiB.
``--strategies auto`` runs one treatment only (e.g. to time ``auto`` against an older commit:
``PYTHONPATH=<worktree of it> python benchmarks/edge_order.py --done-when 1e-6 --strategies auto``).

``--singular-calibration CACHE``: the replay behind ``accuracy.SINGULAR_EXPANSIONS``' figures
(b/a = 1 … 0.05, nu = 0, 0.3, 0.5, sequences of ``accuracy.singular_start`` from n₀ = 16 and 32,
requests 1e-3 … 1e-6; ~5 min CPU to fill the cache, seconds to replay), then per case what
1e-5 and 1e-6 cost from n₀ = 32. With ``--near-field edge`` the same for singular cells whose
near field follows the edge (``singular_cells.NEAR_FIELDS``; grids up to 2^18 cells, ~15 min
CPU to fill; use a cache of its own).

``--bound``: the singular cells' error over K_xx, K_yy, K_zz for the circle and the ellipses 0.7
and 0.5 (n = 32 … 256) and 0.05 (128 × 8 … 512 × 32) at nu = 0, 0.3, 0.5; prints n_across·error
per entry (n_across: cells across the minor axis) and the largest |n_across·error| (the
constant C of the bound |error| ≤ C/n_across in ``hpcontact.discretizations.singular_cells``).

Timings are wall-clock on whatever machine runs it, both strategies in the same process, one
after the other per case: compare them as ratios.
"""

from __future__ import annotations

import argparse
import math
import time
from functools import partial
from pathlib import Path

import harness

from hpcontact import analytic
from hpcontact.accuracy import grid_sequence
from hpcontact.discretizations.boundary_cells import covered_solve
from hpcontact.geometry import Shape
from hpcontact.scene import Scene

NU = 0.3
CASES = {
    # label: (params, Shape for the grid sequence, closed form K_xx or None)
    "circle": ({"shape": "circle"}, Shape("circle"), analytic.circle_tangential_stiffness(1.0, 1.0, NU)),
    "ellipse 0.7": (
        {"shape": "ellipse", "aspect": 0.7},
        Shape("ellipse", 0.7),
        analytic.mindlin_ellipse_stiffness(1.0, 0.7, 1.0, NU)[0],
    ),
    "ellipse 0.5": (
        {"shape": "ellipse", "aspect": 0.5},
        Shape("ellipse", 0.5),
        analytic.mindlin_ellipse_stiffness(1.0, 0.5, 1.0, NU)[0],
    ),
    "ellipse 0.05": (
        {"shape": "ellipse", "aspect": 0.05},
        Shape("ellipse", 0.05),
        analytic.mindlin_ellipse_stiffness(1.0, 0.05, 1.0, NU)[0],
    ),
    "ellipse 0.05 sq": (
        {"shape": "ellipse", "aspect": 0.05},
        Shape("ellipse", 0.05),
        analytic.mindlin_ellipse_stiffness(1.0, 0.05, 1.0, NU)[0],
    ),
    "ellipse 1e-3": (
        {"shape": "ellipse", "aspect": 1e-3},
        Shape("ellipse", 1e-3),
        analytic.mindlin_ellipse_stiffness(1.0, 1e-3, 1.0, NU)[0],
    ),
    "ellipse 1e-6": (
        {"shape": "ellipse", "aspect": 1e-6},
        Shape("ellipse", 1e-6),
        analytic.mindlin_ellipse_stiffness(1.0, 1e-6, 1.0, NU)[0],
    ),
    "square": ({"shape": "polygon", "sides": 4, "shape_angle": 45.0}, Shape("polygon", sides=4, angle_deg=45.0), None),
    "hexagon": ({"shape": "polygon", "sides": 6}, Shape("polygon", sides=6), None),
    "rectangle 1e-8": ({"shape": "rectangle", "aspect": 1e-8}, Shape("rectangle", 1e-8), None),
}
QUICK = ("circle", "ellipse 0.7")
FIRST_GRID = {"ellipse 0.05 sq": (128, 8)}  # cells dy/dx = 0.8 (singular cells need 1/2 … 2); default (32, 8)


def run(params: dict, n: int, n_across: int, strategy: str) -> dict:
    scene = Scene.from_params(
        {**params, "nu": NU, "n": n, "n_across": n_across, "tol": 1e-12, "quantities": "tangential"}
    )
    record = covered_solve(scene, strategy)
    return {
        "n": n,
        "n_across": n_across,
        "K_xx": record["K_xx"],
        "time_s": record["wall_time_s"],
        "boundary": record["boundary"],
    }


def reference(params: dict, shape: Shape, nmax: int) -> tuple[float, float]:
    """Order-1 Richardson of coverage-weighted solves on grids 2·nmax and 4·nmax (and the
    difference to the one on nmax and 2·nmax as its uncertainty)."""
    grids = grid_sequence(shape, 32, max_cells=2**40)
    chosen = [g for g in grids if g[0] in (nmax, 2 * nmax, 4 * nmax)]
    K = [run(params, n, na, "coverage")["K_xx"] for n, na in chosen]
    r1, r2 = 2 * K[1] - K[0], 2 * K[2] - K[1]
    return r2, abs(r2 - r1)


def order(q0: float, q1: float, q2: float) -> float:
    d1, d2 = abs(q1 - q0), abs(q2 - q1)
    return math.log2(d1 / d2) if d1 > 0 and d2 > 0 else float("nan")


def table(label: str, levels: list[dict], exact: float) -> list[dict]:
    rows, total = [], 0.0
    for k, level in enumerate(levels):
        total += level["time_s"]
        Q = [lv["K_xx"] for lv in levels[: k + 1]]
        R = [2 * Q[i] - Q[i - 1] for i in range(1, len(Q))]
        row = {
            **level,
            "error": Q[-1] / exact - 1.0,
            "order": order(*Q[-3:]) if k >= 2 else float("nan"),
            "richardson_error": R[-1] / exact - 1.0 if R else float("nan"),
            "richardson_order": order(*R[-3:]) if len(R) >= 3 else float("nan"),
            "sequence_time_s": total,
        }
        rows.append(row)
        print(
            f"{label:15s} {level['boundary']:9s} {level['n']:5d} {level['n_across']:5d} {row['error']:+10.2e} "
            f"{level['n'] * row['error']:+9.5f} {row['order']:6.2f} {row['richardson_error']:+10.2e} "
            f"{row['richardson_order']:6.2f} {level['time_s']:7.2f} {total:7.2f}",
            flush=True,
        )
    return rows


def bound() -> None:
    """n_across·error of singular cells over shapes, nu and tensor entries (module docstring)."""
    worst = 0.0
    cases = (
        ("circle", 1.0, 32, 32, 4),
        ("ellipse", 0.7, 32, 22, 4),
        ("ellipse", 0.5, 32, 16, 4),
        ("ellipse", 0.05, 128, 8, 3),
    )
    for shape, aspect, n0, na0, levels in cases:
        for nu in (0.0, 0.3, 0.5):
            K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
            exact = {"K_xx": K_a, "K_yy": K_b, "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu)}
            for k in range(levels):
                n, na = n0 * 2**k, na0 * 2**k
                params = {
                    "shape": shape,
                    "aspect": aspect,
                    "nu": nu,
                    "n": n,
                    "n_across": na,
                    "tol": 1e-12,
                    "quantities": "tangential,normal",
                }
                record = covered_solve(Scene.from_params(params), "singular")
                scaled = {key: na * (record[key] / value - 1.0) for key, value in exact.items()}
                worst = max(worst, *(abs(v) for v in scaled.values()))
                print(
                    f"{shape:8s} {aspect:4.2f} nu {nu:3.1f} n {n:4d} x {na:4d} "
                    + " ".join(f"{k} {v:+.5f}" for k, v in scaled.items())
                    + f"  {record['wall_time_s']:.2f} s",
                    flush=True,
                )
    print(f"largest |n_across·error| = {worst:.5f}")


DONE_WHEN = [(aspect, nu) for aspect in (0.7, 0.05, 1e-3, 1e-6) for nu in (0.3, 0.5)]


def done_when_case(aspect: float, nu: float, request: float, strategy: str, max_cells: int) -> dict:
    """One ``solve_to_accuracy`` (tangential and normal) in this process (a fresh one: ``done_when``):
    estimate, largest true error of K_xx, K_yy, K_zz, K_a/K_b (Mindlin, Galin), CPU seconds
    (``time.process_time``) and this process's peak resident set."""
    from hpcontact.accuracy import solve_to_accuracy

    scene = Scene.from_params({"shape": "ellipse", "aspect": aspect, "nu": nu, "quantities": "tangential,normal"})
    solved = harness.timed(
        lambda: solve_to_accuracy(scene, request, strategy=strategy, max_cells=max_cells, strict=False)
    )
    r, cpu = solved.value, solved.cpu_s
    K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
    exact = {
        "K_xx": K_a,
        "K_yy": K_b,
        "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu),
        "K_a_over_K_b": K_a / K_b,
    }
    true = {k: abs(r[k] / v - 1.0) for k, v in exact.items()}
    return {
        "aspect": aspect,
        "nu": nu,
        "strategy": r["boundary"],
        "estimate": r["estimated_error"],
        "true": max(true.values()),
        "honest_per_quantity": all(true[k] <= r["estimated_errors"][k] for k in true),
        "cpu_s": cpu,
        "peak_mib": harness.peak_rss_mb(),
        "finest": [r["grids"][-1], r["grids_across"][-1]],
        "stopped_by": r["stopped_by"],
    }


def done_when(request: float, max_cells: int, strategies: tuple[str, ...] = ("coverage", "auto")) -> None:
    """Issue 12's first "Done when" line: --accuracy REQUEST for ellipses b/a = 0.7, 0.05, 1e-3,
    1e-6 at nu = 0.3, 0.5, with coverage-weighted cells (before) and ``auto`` (what ``hpcontact
    solve --accuracy`` uses), each case in a fresh process (peak memory its own)."""
    print(f"request {request:g}, at most {max_cells} cells per grid")
    print("| b/a | nu | cells | estimate | true | honest per quantity | CPU s | peak MiB | finest grid | stopped by |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for strategy in strategies:
        for aspect, nu in DONE_WHEN:
            r = harness.call_in_child(
                __file__, "done_when_case", aspect, nu, request, strategy, max_cells, check=True
            ).result
            print(
                f"| {aspect:g} | {nu:g} | {r['strategy']} | {r['estimate']:.2e} | {r['true']:.2e} | {r['honest_per_quantity']} | "
                f"{r['cpu_s']:.1f} | {r['peak_mib']:.0f} | {r['finest'][0]} × {r['finest'][1]} | {r['stopped_by']} |",
                flush=True,
            )


CALIBRATION_ASPECTS = (1.0, 0.7, 0.5, 0.3, 0.2, 0.1, 0.05)


#: The edge quadrature's replay ends at 2^18 cells (circle 512², b/a 0.7 512 × 352): its setup is
#: 10–20x that of sub-cells (``--singular-calibration CACHE --near-field edge``; ~15 min CPU to fill).
EDGE_CALIBRATION_CELLS = 2**18


def calibration_grids(aspect: float, nu: float, n0: int, max_cells: int | None = None) -> list[tuple[int, int]]:
    """The sequence ``--accuracy`` (strategy auto) solves from n₀: ``accuracy.singular_start``'s
    first grid refined by 2, every grid up to ``max_cells`` (``accuracy.SINGULAR_MAX_CELLS``)."""
    from hpcontact.accuracy import RATIO, SINGULAR_MAX_CELLS, singular_start
    from hpcontact.scene import Scene

    max_cells = SINGULAR_MAX_CELLS if max_cells is None else max_cells
    params = {"shape": "circle"} if aspect == 1.0 else {"shape": "ellipse", "aspect": aspect}
    n, na = singular_start(Scene.from_params({**params, "nu": nu, "quantities": "tangential,normal"}), n0, None)
    grids = []
    while n * na <= max_cells:
        grids.append((n, na))
        n, na = int(n * RATIO), int(na * RATIO)
    return grids


def singular_rows(
    aspect: float, n: int, na: int, near_field: str = "subcells", nus: tuple[float, ...] = (0.0, 0.3, 0.5)
) -> list[dict]:
    """K_xx, K_yy, K_zz of singular cells (``near_field``) on one grid for each nu, as
    ``covered_solve(..., "singular")`` gives them (``boundary_cells.singular_block_solve``, CG to
    1e-10): the near field's integrals do not depend on nu, so one ``SingularCells`` serves every
    nu (its material replaced on a copy). ``cpu_s``: the shared setup plus the nu's own solves."""
    import copy

    from hpcontact.discretizations import singular_cells
    from hpcontact.discretizations.boundary_cells import singular_block_solve
    from hpcontact.materials.isotropic import Isotropic

    started = time.process_time()
    shape = Shape("circle") if aspect == 1.0 else Shape("ellipse", aspect)
    base = singular_cells.SingularCells(shape, n, na, Isotropic(1.0, nus[0]), near_field)
    base.near_pairs()
    setup = time.process_time() - started
    rows = []
    for nu in nus:
        started = time.process_time()
        cells = copy.copy(base)
        cells.material = Isotropic(1.0, nu)
        row = {"aspect": aspect, "nu": nu, "n": n, "n_across": na, "K_xy": 0.0, "K_yx": 0.0}
        for block in ("xx", "yy", "zz"):
            row[f"K_{block}"] = cells.force(singular_block_solve(cells, block, 1e-10).traction)
        rows.append({**row, "cpu_s": setup + time.process_time() - started})
    return rows


def singular_records(
    cache: Path, near_field: str = "subcells", solve: bool = True
) -> tuple[list[tuple[float, float, float]], list[tuple[float, float]]]:
    """The replay behind ``accuracy.SINGULAR_SAFETY``: every grid of :func:`calibration_grids`
    (b/a in ``CALIBRATION_ASPECTS``, nu = 0, 0.3, 0.5, n₀ = 16 and 32) solved once and cached
    (JSON lines, CPU seconds; solved here when missing), then ``accuracy.refine`` with the
    singular cells' estimator replayed on the cache for requests 1e-3 … 1e-6. Returns the records
    (request, largest true error of K_xx, K_yy, K_zz, K_a/K_b, K_xx/K_zz, K_yy/K_zz,
    ``estimated_error``) and the per-quantity pairs (true, estimate). With ``solve=False`` nothing
    is solved: each sequence is cut where its cached grids end (and left out below
    ``accuracy.MIN_GRIDS``). Cached rows get K_max and K_min (``harness.with_principal``)."""
    from hpcontact import accuracy as acc

    requests = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6)
    cached = {
        (r["aspect"], r["nu"], r["n"], r["n_across"]): harness.with_principal(r) for r in harness.read_jsonl(cache)
    }
    records, pairs = [], []
    for aspect in CALIBRATION_ASPECTS:
        for nu in (0.0, 0.3, 0.5):
            K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
            K_z = analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu)
            exact = {
                "K_xx": K_a,
                "K_yy": K_b,
                "K_zz": K_z,
                "K_a_over_K_b": K_a / K_b,
                "normalized_xx": K_a / K_z,
                "normalized_yy": K_b / K_z,
            }
            for n0 in (16, 32):
                grids = calibration_grids(aspect, nu, n0, EDGE_CALIBRATION_CELLS if near_field == "edge" else None)
                for n, na in grids:
                    if (aspect, nu, n, na) not in cached and solve:
                        for row in singular_rows(aspect, n, na, near_field):
                            cached[(aspect, row["nu"], n, na)] = harness.with_principal(row)
                            harness.append_jsonl(cache, row)
                have = [(aspect, nu, *g) in cached for g in grids] + [False]
                grids = grids[: have.index(False)]
                if len(grids) < acc.MIN_GRIDS:
                    continue
                levels = {g: cached[(aspect, nu, *g)] for g in grids}
                for request in requests:
                    done = acc.refine(
                        grids,
                        lambda n, na, levels=levels: levels[(n, na)],
                        request,
                        acc.SINGULAR_EXPANSIONS,
                        acc.SINGULAR_SAFETY,
                    )
                    v = done.values
                    values = {
                        **v,
                        "K_a_over_K_b": v["K_xx"] / v["K_yy"],
                        "normalized_xx": v["K_xx"] / v["K_zz"],
                        "normalized_yy": v["K_yy"] / v["K_zz"],
                    }
                    true = {k: abs(values[k] / exact[k] - 1.0) for k in exact}
                    records.append((request, max(true.values()), max(done.relative.values())))
                    pairs += [
                        (true[k], done.relative[k]) for k in exact if true[k] >= 1e-13
                    ]  # below: exact by symmetry
    return records, pairs


def singular_calibration(cache: Path, near_field: str = "subcells") -> None:
    """Print :func:`singular_records`' honesty and sharpness (all records, those with requests
    below ``accuracy.SINGULAR_BELOW`` — the ones ``--accuracy`` gives singular cells —, the
    pairs), then per case (nu 0.3, 0.5; from n₀ = 32) what requests 1e-5 and 1e-6 cost: the grid
    the replay stopped at, estimate / true error (largest over K_xx, K_yy, K_zz, K_a/K_b) and the
    CPU seconds of the sequence's solves (cached: each the grid's setup plus one nu's solves)."""
    import numpy as np

    from hpcontact import accuracy as acc

    records, pairs = singular_records(cache, near_field)
    for label, rows in (
        ("records", records),
        ("records, requests below SINGULAR_BELOW", [r for r in records if r[0] < acc.SINGULAR_BELOW]),
    ):
        ratio = np.array([t / e for _, t, e in rows])
        print(
            f"{label}: {len(ratio)}; worst true/estimate {ratio.max():.2f}; above 1: {int((ratio > 1).sum())}; "
            f"within 30x: {100 * (ratio >= 1 / 30).mean():.1f} %; worst estimate/true {1.0 / ratio.min():.0f}"
        )
    ratio = np.array([t / e for t, e in pairs])
    print(f"per-quantity pairs: {len(ratio)}; worst true/estimate {ratio.max():.2f}; above 1: {int((ratio > 1).sum())}")
    cached = {
        (r["aspect"], r["nu"], r["n"], r["n_across"]): harness.with_principal(r) for r in harness.read_jsonl(cache)
    }
    print("| b/a | nu | 1e-5: grid, estimate / true, CPU s | 1e-6: grid, estimate / true, CPU s |")
    print("|---|---|---|---|")
    for aspect in CALIBRATION_ASPECTS:
        for nu in (0.3, 0.5):
            K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
            K_z = analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu)
            grids = calibration_grids(aspect, nu, 32, EDGE_CALIBRATION_CELLS if near_field == "edge" else None)
            levels = {g: cached[(aspect, nu, *g)] for g in grids}
            cells = []
            for request in (1e-5, 1e-6):
                done = acc.refine(
                    grids,
                    lambda n, na, levels=levels: levels[(n, na)],
                    request,
                    acc.SINGULAR_EXPANSIONS,
                    acc.SINGULAR_SAFETY,
                )
                v = done.values
                true = max(
                    abs(v["K_xx"] / K_a - 1),
                    abs(v["K_yy"] / K_b - 1),
                    abs(v["K_zz"] / K_z - 1),
                    abs(v["K_xx"] / v["K_yy"] / (K_a / K_b) - 1),
                )
                last = done.levels[-1]
                met = "met" if done.stopped_by == "met" else "not met"
                cells.append(
                    f"{met}, {last['n']} × {last['n_across']}, {max(done.relative.values()):.2e} / {true:.2e}, "
                    f"{sum(level['cpu_s'] for level in done.levels):.1f}"
                )
            print(f"| {aspect:g} | {nu:g} | {cells[0]} | {cells[1]} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="circle and ellipse 0.7 only, up to n = 256")
    parser.add_argument("--nmax", type=int, default=512, help="finest grid of the sequence (power of two ≥ 128)")
    parser.add_argument("--out", type=Path, default=None, help="JSON with every number")
    parser.add_argument("--bound", action="store_true", help="the singular cells' error bound study instead")
    parser.add_argument(
        "--done-when",
        type=float,
        default=None,
        metavar="REQUEST",
        help="issue 12's --accuracy table (b/a 0.7, 0.05, 1e-3, 1e-6; nu 0.3, 0.5), coverage and auto",
    )
    parser.add_argument("--max-cells", type=int, default=1024 * 1024 - 1, help="largest grid of --done-when (cells)")
    parser.add_argument(
        "--strategies", default="coverage,auto", help="--done-when's cell treatments, comma-separated (coverage, auto)"
    )
    parser.add_argument(
        "--singular-calibration",
        type=Path,
        default=None,
        metavar="CACHE",
        help="honesty of --accuracy on singular cells (solves what CACHE lacks, then replays)",
    )
    parser.add_argument(
        "--near-field",
        choices=("subcells", "edge"),
        default="subcells",
        help="--singular-calibration's near-field quadrature (singular_cells.NEAR_FIELDS)",
    )
    args = parser.parse_args()
    print(f"edge_order: {harness.machine_line(1)}")
    if args.singular_calibration is not None:
        singular_calibration(args.singular_calibration, args.near_field)
        return
    if args.done_when is not None:
        done_when(args.done_when, args.max_cells, tuple(args.strategies.split(",")))
        return
    if args.bound:
        bound()
        return
    nmax = 256 if args.quick else args.nmax
    labels = QUICK if args.quick else tuple(CASES)
    print(f"nu = {NU}, K_xx; order: observed order of the raw sequence; R: order-1 Richardson on consecutive grids")
    print(
        f"{'case':15s} {'boundary':9s} {'n':>5s} {'ny':>5s} {'error':>10s} {'n*error':>9s} {'order':>6s} {'R error':>10s} {'R ord':>6s} {'time':>7s} {'seq.':>7s}"
    )
    out = {}
    for label in labels:
        params, shape, exact = CASES[label]
        note = "closed form"
        if exact is None:
            solved = harness.timed(partial(reference, params, shape, nmax))
            exact, spread = solved.value
            note = f"reference {exact:.12g} ± {spread:.1e} (coverage, Richardson on n = {2 * nmax}, {4 * nmax}; {solved.wall_s:.0f} s)"
        print(f"# {label}: {note}")
        n0, na0 = FIRST_GRID.get(label, (32, None))
        grids = [g for g in grid_sequence(shape, n0, na0, max_cells=2**40) if g[0] <= max(nmax, 4 * n0)]
        out[label] = {"reference": exact, "note": note}
        for strategy in ("coverage", "auto"):
            levels = [run(params, n, na, strategy) for n, na in grids]
            out[label][strategy] = table(label, levels, exact)
    if args.out:
        harness.write_json(args.out, {"machine": harness.machine_line(1), "cases": out})


if __name__ == "__main__":
    harness.entry(main)
