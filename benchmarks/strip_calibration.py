"""Strip cells' error estimate against references, and what 1e-3 … 1e-7 cost (issue 12).

    python benchmarks/strip_calibration.py [--rectangles 1e-6,...] [--ellipses 1e-3,...]
        [--cache results/strip_calibration.jsonl] [--cost rectangle:1e-8,ellipse:1e-6,...]

Strip cells (``hpcontact.discretizations.strip_cells``) discretize a contact along x only. For each case the
Galerkin integrals are formed once per grid (they do not depend on nu) and K_xx, K_yy, K_zz
solved for nu = 0, 0.3, 0.5, on n = 16, 32, …, 4096 strips for rectangles and up to
``accuracy.strip_max_n`` for ellipses (1024; 256 for b/a > 1e-2). Records carry ``VERSION``;
ellipse records of other versions (integrals before ``strip_cells.width_corrections``) are
recomputed.

* Rectangles: the reference is the strip model's own limit, the order-2 Richardson extrapolant
  of n = 2048 and 4096 (successive differences fall 3.7-5x per halving), its uncertainty the
  distance to the extrapolant of 1024 and 2048 — finer than any grid ``--accuracy`` uses for
  strips (``accuracy.STRIP_MAX_N`` = 1024). The model's own error (``strip_cells.MODEL_ERROR``
  · b/a, the ends) is left out of estimate and truth alike: no grid sequence shows it, and it is
  checked against coverage-weighted cells (``strip_cells`` docstring).
* Ellipses, b/a = 1 … 1e-10: the reference is Mindlin's and Galin's closed form
  (``hpcontact.analytic``) and the estimate is the one ``--accuracy`` reports, with
  ``strip_cells.model_error``.

Replay: ``accuracy.refine`` on the cached grids from n0 = 32 (``accuracy.STRIP_N0``) and 64
for rectangles, 16 (``accuracy.STRIP_ELLIPSE_N0``) and 32 for ellipses, requests 1e-3, 3e-4,
…, 1e-7 (9). A record is honest when the reported estimate is at least the largest true error of K_xx, K_yy, K_zz, K_a/K_b, K_xx/K_zz, K_yy/K_zz; the tables give the
worst true/estimate, the share within 30x, and the same per quantity.

``--cost``: ``hpcontact solve --accuracy`` (``solve_to_accuracy``, strategy auto) of those
cases for requests 1e-3 … 1e-7 and nu 0.3, 0.5, each in a fresh ``python -c`` process: CPU s
of the solve (imports excluded), peak resident MiB of the process, grids, estimate and error
against the reference.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import harness
import numpy as np

from hpcontact import accuracy as acc
from hpcontact import analytic
from hpcontact.discretizations import strip_cells as sc
from hpcontact.geometry import Shape
from hpcontact.materials.isotropic import Isotropic
from hpcontact.scene import Scene

RECTANGLES = (1e-6, 3e-7, 1e-7, 1e-8, 1e-9, 1e-10, 1e-12)
ELLIPSES = (1.0, 0.7, 0.5, 0.3, 0.1, 0.05, 0.02, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 1e-5, 1e-6, 1e-8, 1e-10)
NUS = (0.0, 0.3, 0.5)
STARTS = {"rectangle": (32, 64), "ellipse": (16, 32)}
REQUESTS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6, 3e-7, 1e-7)
KEYS = {"K_xx": "xx", "K_yy": "yy", "K_zz": "zz"}
VERSION = (
    2  # records of earlier integrals (before the widths' corrections, ``strip_cells.width_corrections``) are not reused
)


def grids_of(shape: str, aspect: float) -> tuple[int, ...]:
    """Rectangles 16 … 4096 strips; ellipses 16 … ``accuracy.strip_max_n`` (1024, 256 where wide)."""
    finest = 4096 if shape == "rectangle" else acc.strip_max_n(Shape(shape, aspect=aspect))
    return tuple(16 * 2**k for k in range(int(np.log2(finest // 16)) + 1))


def solve_grid(shape: str, aspect: float, n: int) -> list[dict[str, Any]]:
    """K_xx, K_yy, K_zz for every nu on n strips, and the CPU seconds of the integrals."""
    cpu = time.process_time()
    edges = sc.graded_edges(n)
    one, xx = sc.galerkin_integrals(edges, sc.Outline(shape, aspect))
    formed = time.process_time() - cpu
    out = []
    for nu in NUS:
        material = Isotropic(1.0, nu)
        K = {
            key: sc.stiffness(sc.galerkin_matrix(one, xx, block, material), np.diff(edges))[0]
            for key, block in KEYS.items()
        }
        out.append(
            {"shape": shape, "aspect": aspect, "n": n, "nu": nu, **K, "integrals_cpu_s": formed, "version": VERSION}
        )
    return out


def load(cache: Path, cases: list[tuple[str, float]]) -> dict[tuple[str, float, float, int], dict[str, Any]]:
    have: dict[tuple[str, float, float, int], dict[str, Any]] = {}
    for r in harness.read_jsonl(cache):
        if r["shape"] == "rectangle" or r.get("version") == VERSION:  # rectangles' integrals are unchanged
            have[(r["shape"], r["aspect"], r["nu"], r["n"])] = r
    for shape, aspect in cases:
        for n in grids_of(shape, aspect):
            if all((shape, aspect, nu, n) in have for nu in NUS):
                continue
            rows = solve_grid(shape, aspect, n)
            print(
                f"  {shape} b/a {aspect:g}, n = {n}: integrals {rows[0]['integrals_cpu_s']:.2f} s CPU",
                file=sys.stderr,
                flush=True,
            )
            for r in rows:
                harness.append_jsonl(cache, r)
                have[(shape, aspect, r["nu"], n)] = r
    return have


def with_ratios(K: dict[str, float]) -> dict[str, float]:
    return {
        **K,
        "K_a_over_K_b": K["K_xx"] / K["K_yy"],
        "normalized_xx": K["K_xx"] / K["K_zz"],
        "normalized_yy": K["K_yy"] / K["K_zz"],
    }


def reference(have: dict, shape: str, aspect: float, nu: float) -> tuple[dict[str, float], dict[str, float]]:
    """Per quantity the reference and its relative uncertainty: Mindlin's and Galin's closed
    form for an ellipse (uncertainty 0), the order-2 Richardson of n = 2048, 4096 for a rectangle."""
    if shape == "ellipse":
        K_xx, K_yy = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
        exact = with_ratios(
            {"K_xx": K_xx, "K_yy": K_yy, "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu)}
        )
        return exact, {k: 0.0 for k in exact}

    def rich(n1: int, n2: int) -> dict[str, float]:
        a, b = have[(shape, aspect, nu, n1)], have[(shape, aspect, nu, n2)]
        return {k: b[k] + (b[k] - a[k]) / 3.0 for k in KEYS}

    best, before = with_ratios(rich(2048, 4096)), with_ratios(rich(1024, 2048))
    return best, {k: abs(best[k] - before[k]) / abs(best[k]) for k in best}


def replay(have: dict, cases: list[tuple[str, float]]) -> list[dict[str, Any]]:
    records = []
    for shape, aspect in cases:
        model = sc.model_error(Shape(shape, aspect=aspect)) if shape == "ellipse" else 0.0
        for nu in NUS:
            ref, unc = reference(have, shape, aspect, nu)
            for n0 in STARTS[shape]:
                grids = [(n, 1) for n in grids_of(shape, aspect) if n0 <= n <= acc.STRIP_MAX_N]
                for request in REQUESTS:

                    def level(
                        n: int, na: int, shape: str = shape, aspect: float = aspect, nu: float = nu
                    ) -> dict[str, Any]:
                        r = have[(shape, aspect, nu, n)]
                        return {**{k: r[k] for k in KEYS}, "K_xy": 0.0, "K_yx": 0.0}

                    done = acc.refine(grids, level, request, model_error=model)
                    values = with_ratios({k: done.values[k] for k in KEYS})
                    true = {k: abs(values[k] - ref[k]) / abs(ref[k]) for k in ref}
                    estimate = max(done.relative.values())
                    records.append(
                        {
                            "shape": shape,
                            "aspect": aspect,
                            "nu": nu,
                            "n0": n0,
                            "request": request,
                            "estimate": estimate,
                            "estimates": {k: done.relative[k] for k in true},
                            "true": true,
                            "reference_uncertainty": max(unc.values()),
                            "grids": len(done.levels),
                            "finest": grids[len(done.levels) - 1][0],
                            "met": estimate <= request,
                        }
                    )
    return records


def convergence(have: dict, shape: str, aspect: float, nu: float = 0.3) -> list[tuple[float, float, float]]:
    """(CPU s of the integrals so far, estimated error, largest true error) after every grid from
    the ``MIN_GRIDS``-th of the sequence ``--accuracy`` runs from ``accuracy.strip_n0``: what it
    would report if it stopped there (``benchmarks/accuracy_sharpness.py --figure``)."""
    shape_of = Shape(shape, aspect=aspect)
    grids = [n for n in grids_of(shape, aspect) if n >= acc.strip_n0(shape_of) and (shape, aspect, nu, n) in have]
    levels = [have[(shape, aspect, nu, n)] for n in grids]
    ref, _ = reference(have, shape, aspect, nu)
    model = sc.model_error(shape_of)
    out = []
    for k in range(acc.MIN_GRIDS, len(levels) + 1):
        values, relative, _, _ = acc.extrapolate(
            [{**{q: r[q] for q in KEYS}, "K_xy": 0.0, "K_yx": 0.0} for r in levels[:k]]
        )
        true = with_ratios({q: values[q] for q in KEYS})
        out.append(
            (
                sum(r["integrals_cpu_s"] for r in levels[:k]),
                max(relative.values()) + model,
                max(abs(true[q] / ref[q] - 1.0) for q in ref),
            )
        )
    return out


def summary(records: list[dict[str, Any]]) -> None:
    for shape in ("rectangle", "ellipse"):
        rs = [r for r in records if r["shape"] == shape]
        if not rs:
            continue
        ratios = [max(r["true"].values()) / r["estimate"] for r in rs]
        pairs = [(r["true"][k] / r["estimates"][k], k, r) for r in rs for k in r["true"]]
        print(
            f"\n{shape}s: {len(rs)} records; honest (true <= estimate): {sum(x <= 1.0 for x in ratios)}; "
            f"worst true/estimate {max(ratios):.3g}; within 30x: {100.0 * np.mean([x >= 1 / 30 for x in ratios]):.1f} %; "
            f"median true/estimate {np.median(ratios):.3g}"
        )
        worst = max(pairs, key=lambda p: p[0])
        print(
            f"per quantity: {len(pairs)} pairs, {sum(p[0] > 1.0 for p in pairs)} below their true error; worst {worst[0]:.3g} "
            f"({worst[1]}, b/a {worst[2]['aspect']:g}, nu {worst[2]['nu']}, n0 {worst[2]['n0']}, request {worst[2]['request']:g})"
        )
        print(
            f"largest reference uncertainty: {max(r['reference_uncertainty'] for r in rs):.2e}; records whose reference "
            f"uncertainty exceeds a tenth of the estimate: {sum(r['reference_uncertainty'] > r['estimate'] / 10 for r in rs)}"
        )
        print("\n| b/a | records | worst true/estimate | within 30x | met | finest n |")
        print("|---|---|---|---|---|---|")
        for aspect in sorted({r["aspect"] for r in rs}, reverse=True):
            sel = [r for r in rs if r["aspect"] == aspect]
            x = [max(r["true"].values()) / r["estimate"] for r in sel]
            print(
                f"| {aspect:g} | {len(sel)} | {max(x):.3g} | {100.0 * np.mean([v >= 1 / 30 for v in x]):.0f} % | "
                f"{sum(r['met'] for r in sel)} | {max(r['finest'] for r in sel)} |"
            )


def one_cost(shape: str, aspect: float, nu: float, request: float) -> dict[str, Any]:
    """One ``--accuracy`` run (strategy auto), in a fresh process (``cost``)."""
    scene = Scene.from_params({"shape": shape, "aspect": aspect, "nu": nu, "quantities": "tangential,normal"})
    solved = harness.timed(lambda: acc.solve_to_accuracy(scene, request, strategy="auto", strict=False))
    record = solved.value
    return {
        "cpu_s": solved.cpu_s,
        "peak_mib": harness.peak_rss_mb(),
        "values": with_ratios({k: record[k] for k in KEYS}),
        "estimate": record["estimated_error"],
        "met": record["accuracy_met"],
        "stopped_by": record["stopped_by"],
        "grids": record["grids"],
        "boundary": record["boundary"],
    }


def cost(have: dict, cases: list[tuple[str, float]]) -> None:
    print("\n`--accuracy` (strategy auto), each run in a fresh process (CPU s of one core, peak MiB):\n")
    print("| case | nu | request | cells | estimate | true error | true/estimate | strips | CPU s | MiB |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for shape, aspect in cases:
        for nu in (0.3, 0.5):
            ref, _ = reference(have, shape, aspect, nu)
            for request in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7):
                r = harness.call_in_child(__file__, "one_cost", shape, aspect, nu, request, check=True).result
                true = max(abs(r["values"][k] - ref[k]) / abs(ref[k]) for k in ref)
                met = "" if r["met"] else f" (not met: {r['stopped_by']})"
                print(
                    f"| {shape} {aspect:g} | {nu} | {request:g}{met} | {r['boundary']} | {r['estimate']:.2e} | {true:.2e} | "
                    f"{true / r['estimate']:.3f} | {r['grids'][0]} … {r['grids'][-1]} | {r['cpu_s']:.2f} | {r['peak_mib']:.0f} |"
                )


def cases_of(text: str, shape: str) -> list[tuple[str, float]]:
    return [(shape, float(a)) for a in text.split(",") if a]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rectangles", default=",".join(f"{a:g}" for a in RECTANGLES))
    ap.add_argument("--ellipses", default=",".join(f"{a:g}" for a in ELLIPSES))
    ap.add_argument("--cache", type=Path, default=harness.RESULTS / "strip_calibration.jsonl")
    ap.add_argument("--cost", default="", help="cases to time, e.g. rectangle:1e-8,ellipse:1e-6")
    args = ap.parse_args(argv)
    print(f"strip_calibration: {harness.machine_line(1)}")
    cases = cases_of(args.rectangles, "rectangle") + cases_of(args.ellipses, "ellipse")
    timed = [(c.split(":")[0], float(c.split(":")[1])) for c in args.cost.split(",") if c]
    have = load(args.cache, cases + [c for c in timed if c not in cases])
    summary(replay(have, cases))
    if timed:
        cost(have, timed)
    return 0


if __name__ == "__main__":
    harness.entry(main)
