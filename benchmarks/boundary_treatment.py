"""Boundary treatment, before and after: centre-in-cell masks versus coverage-weighted cells.

    python benchmarks/boundary_treatment.py [--out results/boundary_treatment.json]
                                            [--figure results/boundary_treatment.png] [--full]

Before (the engine, ``hpcontact.solve``): a cell is in the contact when its centre is inside
the shape. After (``hpcontact.discretizations.boundary_cells.covered_solve``): every cell that the shape touches is
in, with its exact covered fraction f, and its self-compliance raised to A_ii/f (diagonal
D_ii = A_ii (1 − f)/f; the FFT operator, CG and preconditioner are unchanged).

Printed, per case (circle; ellipses b/a = 0.1, 1e-3, 1e-6; nu = 0.3) and grid:

1. the relative error of K_xx and K_zz on single grids (powers of two and the points between),
   n·error (a constant for a clean first-order method) and its spread, and the time;
2. Richardson on consecutive grids (ratio 2): the true error of the extrapolant R_k for both
   treatments — with centre-in-cell masks it jumps about with the staircase, with coverage it
   falls steadily;
3. ``solve_to_accuracy`` for requested accuracies 1e-2, 1e-3 (and 1e-4 with ``--full``): the
   estimate next to the true error (honest when true < estimate) and the time of the whole grid
   sequence.

The JSON (``--out``) holds every number, and ``accuracy_runs`` for
``postprocess/accuracy_cost.py --extrapolated``; the figure shows error against time for the
four ways (centre and coverage, single grid and extrapolated).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import harness
import numpy as np

from hpcontact import analytic
from hpcontact.accuracy import solve_to_accuracy
from hpcontact.discretizations.boundary_cells import covered_solve
from hpcontact.problems.contact import solve
from hpcontact.scene import Scene

NU = 0.3
CASES = {
    # label: (shape, aspect, first grid (n, n_across), levels); n_across None: square cells
    "circle": ("circle", 1.0, (32, None), 5),
    "ellipse b/a=0.1": ("ellipse", 0.1, (32, 8), 5),
    "ellipse b/a=1e-3": ("ellipse", 1e-3, (32, 8), 5),
    "ellipse b/a=1e-6": ("ellipse", 1e-6, (32, 8), 5),
}
QUANTITIES = ("K_xx", "K_yy", "K_a_over_K_b", "K_zz")


def references(shape: str, aspect: float) -> dict[str, float]:
    if shape == "circle":
        k = analytic.circle_tangential_stiffness(1.0, 1.0, NU)
        return {"K_xx": k, "K_yy": k, "K_a_over_K_b": 1.0, "K_zz": analytic.circle_normal_stiffness(1.0, 1.0, NU)}
    K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, NU)
    return {
        "K_xx": K_a,
        "K_yy": K_b,
        "K_a_over_K_b": analytic.mindlin_ellipse_stiffness_ratio(aspect, NU),
        "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, NU),
    }


def grids(first: tuple[int, int | None], levels: int) -> list[tuple[int, int | None]]:
    """Powers of two from the first grid, and 1.25×, 1.5× between (same cell aspect)."""
    n0, na0 = first
    out = []
    for k in range(levels):
        for f in (1.0, 1.25, 1.5) if k < levels - 1 else (1.0,):
            n = int(round(n0 * 2**k * f))
            na = None if na0 is None else int(round(na0 * 2**k * f))
            out.append((n, na))
    return out


def run_grid(function, shape: str, aspect: float, n: int, na: int | None) -> dict:
    params = {"shape": shape, "aspect": aspect, "nu": NU, "n": n, "quantities": "tangential,normal"}
    if na is not None:
        params["n_across"] = na
    scene = Scene.from_params(params)
    solved = harness.timed(lambda: function(scene))
    record = solved.value
    return {
        "n": n,
        "na": record["ny"],
        "time": solved.wall_s,
        "iterations": record["iterations"],
        **{q: record[q] for q in QUANTITIES},
    }


def errors(row: dict, ref: dict) -> dict:
    return {f"err_{q}": abs(row[q] / ref[q] - 1.0) for q in QUANTITIES}


def single_grids(label: str, results: dict) -> None:
    shape, aspect, first, levels = CASES[label]
    ref = references(shape, aspect)
    print(f"\n=== {label} (nu = {NU}) ===")
    print(
        f"{'grid':>11} | {'centre: K_xx err':>16} {'n·err':>8} {'time':>6} | {'coverage: K_xx err':>18} {'n·err':>8} {'time':>6}"
    )
    rows = {"centre": [], "coverage": []}
    for n, na in grids(first, levels):
        line = []
        for name, function in (("centre", solve), ("coverage", covered_solve)):
            row = run_grid(function, shape, aspect, n, na)
            row.update(errors(row, ref))
            rows[name].append(row)
            signed = row["K_xx"] / ref["K_xx"] - 1.0
            line.append(f"{signed:+16.3e} {n * signed:+8.4f} {row['time']:6.2f}")
        print(f"{n:>5}×{rows['centre'][-1]['na']:<5} | {line[0]} | {'':2}{line[1]}")
    for name in rows:
        scaled = [r["n"] * (r["K_xx"] / ref["K_xx"] - 1.0) for r in rows[name]]
        spread = (max(scaled) - min(scaled)) / abs(float(np.mean(scaled)))
        print(f"  {name:>8}: n·(K_xx error) spread over all grids = {spread:.1%} of its mean")
    results[label] = {"single": rows}


def richardson_table(label: str, results: dict) -> None:
    shape, aspect, first, levels = CASES[label]
    ref = references(shape, aspect)
    print(
        f"  Richardson R_k = 2 Q_k − Q_(k−1) on grids ratio 2, true relative error (worst of {', '.join(QUANTITIES)}):"
    )
    out = {}
    for name in ("centre", "coverage"):
        rows = [
            r
            for r in results[label]["single"][name]
            if (r["n"] // first[0]) & ((r["n"] // first[0]) - 1) == 0 and r["n"] % first[0] == 0
        ]
        seq = []
        cumulative = 0.0
        for k, row in enumerate(rows):
            cumulative += row["time"]
            if k == 0:
                continue
            prev = rows[k - 1]
            err = max(abs((2 * row[q] - prev[q]) / ref[q] - 1.0) for q in QUANTITIES if q != "K_a_over_K_b")
            seq.append(
                {"n": row["n"], "err": err, "time": cumulative, "fine_err": max(row[f"err_{q}"] for q in QUANTITIES)}
            )
        out[name] = seq
        print(f"  {name:>8}: " + "  ".join(f"n={s['n']}: {s['err']:.1e}" for s in seq))
    results[label]["richardson"] = out


def accuracy_runs(targets: tuple[float, ...], results: dict) -> list[dict]:
    print("\n=== solve --accuracy (coverage-weighted cells, Richardson, Roache-style estimate) ===")
    print(f"{'case':>18} {'request':>8} {'estimate':>9} {'true':>9} {'honest':>6} {'time':>7}  grids")
    runs = []
    for label, (shape, aspect, _, _) in CASES.items():
        ref = references(shape, aspect)
        for target in targets:
            scene = Scene.from_params({"shape": shape, "aspect": aspect, "nu": NU, "quantities": "tangential,normal"})
            r = solve_to_accuracy(scene, target, strict=False)
            errs = {f"err_{q}": abs(r[q] / ref[q] - 1.0) for q in QUANTITIES}
            honest = all(errs[f"err_{q}"] <= r["estimated_errors"][q] for q in QUANTITIES)
            true = max(errs.values())
            run = {
                "case": label,
                "accuracy": target,
                "estimated_error": r["estimated_error"],
                "err": true,
                **errs,
                "estimated_errors": r["estimated_errors"],
                "honest": honest,
                "accuracy_met": r["accuracy_met"],
                "wall_time_s": r["wall_time_s"],
                "grids": r["grids"],
                "grids_across": r["grids_across"],
            }
            runs.append(run)
            grid_text = ", ".join(f"{a}×{b}" for a, b in zip(r["grids"], r["grids_across"]))
            print(
                f"{label:>18} {target:8.0e} {r['estimated_error']:9.2e} {true:9.2e} {str(honest):>6} {r['wall_time_s']:6.2f}s  {grid_text}"
                f"{'' if r['accuracy_met'] else '  (not met within the grid budget)'}"
            )
    results["accuracy_runs"] = runs
    return runs


def figure(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = list(CASES)
    fig, axes = plt.subplots(1, len(labels), figsize=(4.2 * len(labels), 3.8), layout="constrained")
    for ax, label in zip(axes, labels):
        single = results[label]["single"]
        for name, colour in (("centre", "tab:red"), ("coverage", "tab:blue")):
            rows = single[name]
            worst = [max(r[f"err_{q}"] for q in QUANTITIES) for r in rows]
            ax.loglog([r["time"] for r in rows], worst, "o", color=colour, ms=3, alpha=0.6, label=f"{name}, one grid")
            seq = results[label]["richardson"][name]
            ax.loglog(
                [s["time"] for s in seq],
                [max(s["err"], 1e-16) for s in seq],
                "-s",
                color=colour,
                ms=4,
                label=f"{name}, Richardson (cumulative time)",
            )
        runs = [r for r in results.get("accuracy_runs", []) if r["case"] == label]
        if runs:
            ax.loglog(
                [r["wall_time_s"] for r in runs],
                [r["err"] for r in runs],
                "*",
                color="k",
                ms=10,
                label="solve --accuracy: true",
            )
            ax.loglog(
                [r["wall_time_s"] for r in runs],
                [r["estimated_error"] for r in runs],
                "x",
                color="k",
                ms=7,
                label="solve --accuracy: estimate",
            )
        ax.set_title(label, fontsize=10)
        ax.set_xlabel("wall time [s]")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("largest relative error (K_xx, K_yy, K_a/K_b, K_zz)")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"Boundary treatment: centre-in-cell (engine) versus coverage-weighted cells, nu = {NU}", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=150)
    print(f"wrote {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=harness.RESULTS / "boundary_treatment.json")
    parser.add_argument("--figure", type=Path, default=harness.RESULTS / "boundary_treatment.png")
    parser.add_argument(
        "--full", action="store_true", help="also request 1e-4 (minutes with the current preconditioner)"
    )
    args = parser.parse_args()
    print(f"boundary_treatment: {harness.machine_line(1)}")
    results: dict = {"machine": harness.machine_line(1), "nu": NU}
    for label in CASES:
        single_grids(label, results)
        richardson_table(label, results)
    accuracy_runs((1e-2, 1e-3, 1e-4) if args.full else (1e-2, 1e-3), results)
    harness.write_json(args.out, results)
    print(f"wrote {args.out}")
    figure(results, args.figure)


if __name__ == "__main__":
    harness.entry(main)
