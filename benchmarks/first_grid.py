"""What the first grid of coverage-weighted cells costs at a loose request: ``N0`` = 32 against
``accuracy.coverage_n0`` (16 where that grid's cell is no wider than the outline's smallest bend).

The cases are the scene types of the README's main job (``jobs/demo.toml``) that take
coverage-weighted cells at ``--accuracy 1e-3``: rectangles at b/a 1 … 1e-8 (isotropic ones thinner
than 1e-6 take strips and are left out), the triangle and the five-lobed star, isotropic and cubic
(nu 0.25). Each is solved as the sweep solves it, ``solve_to_accuracy(scene, REQUEST,
strategy="auto", strict=False)``, once with ``n0=32`` and once with the first grid of
``n0=16`` (``accuracy.LOOSE_N0``), in this process with one BLAS thread and cold kernel caches (a sweep task of a
new material): CPU seconds (``time.process_time``), grids, what stopped the refinement, the
estimate; ``*`` marks the first grid ``coverage_n0`` chooses, and the total sums those. Whether those estimates are honest is ``benchmarks/demo_accuracy_check.py``'s question.

    python benchmarks/first_grid.py [--request 1e-3] [--json FILE]     # ~1 min
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import harness

from hpcontact import accuracy
from hpcontact.kernels import anisotropic
from hpcontact.numerics import convolution
from hpcontact.numerics.blas import limited_blas
from hpcontact.scene import Scene

CRYSTAL = {"anisotropy": 2.0, "orientation": 20.0}
SOFT_CRYSTAL = {"anisotropy": 0.5, "orientation": 90.0}
CASES: list[tuple[str, dict[str, Any]]] = [
    *[(f"rectangle {b:g} A=2", {"shape": "rectangle", "aspect": b, **CRYSTAL}) for b in (1.0, 1e-2, 1e-4, 1e-6, 1e-8)],
    *[(f"rectangle {b:g} A=1", {"shape": "rectangle", "aspect": b}) for b in (1.0, 1e-2, 1e-4)],
    ("triangle A=1", {"shape": "polygon", "sides": 3}),
    ("triangle A=2", {"shape": "polygon", "sides": 3, **CRYSTAL}),
    ("star A=1", {"shape": "star", "sides": 5, "amplitude": 0.3}),
    ("star A=2", {"shape": "star", "sides": 5, "amplitude": 0.3, **CRYSTAL}),
    ("star A=0.5", {"shape": "star", "sides": 5, "amplitude": 0.3, **SOFT_CRYSTAL}),
]


def solve(scene: Scene, request: float, n0: int) -> dict[str, Any]:
    """One cold solve from the first grid ``n0``: its record's grids, stop, estimate and CPU s."""
    convolution.clear_cache()
    anisotropic.clear_cache()
    started = time.process_time()
    with limited_blas():
        record = accuracy.solve_to_accuracy(scene, request, n0=n0, strategy="auto", strict=False)
    return {
        "n0": n0,
        "cpu_s": time.process_time() - started,
        "grids": record["grids"],
        "stopped_by": record["stopped_by"],
        "estimated_error": record["estimated_error"],
        "boundary": record["boundary"],
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--request", type=float, default=accuracy.LOOSE_REQUEST, help="the accuracy asked for")
    parser.add_argument("--json", help="also write the rows to this JSON file")
    args = parser.parse_args()
    print(harness.machine_line(threads=1))
    solve(Scene.from_params({"shape": "polygon", "sides": 3, "n": 16, **CRYSTAL}), 1e-2, 16)  # imports, plans
    rows = []
    total = {"32": 0.0, "chosen": 0.0}
    print(f"{'case':20s} {'n0':>4s} {'grids':26s} {'stop':5s} {'estimate':>9s} {'CPU s':>6s}  /32")
    for label, params in CASES:
        scene = Scene.from_params({**params, "nu": 0.25, "quantities": ["tangential", "normal"]})
        chosen = accuracy.coverage_n0(scene.shape, args.request)
        runs = [solve(scene, args.request, n0) for n0 in (accuracy.N0, accuracy.LOOSE_N0)]
        total["32"] += runs[0]["cpu_s"]
        total["chosen"] += next(run["cpu_s"] for run in runs if run["n0"] == chosen)
        for run in runs:
            mark = "*" if run["n0"] == chosen else " "
            ratio = f"{run['cpu_s'] / runs[0]['cpu_s']:.2f}" if run is not runs[0] else ""
            print(
                f"{label:20s} {run['n0']:3d}{mark} {str(run['grids']):26s} {run['stopped_by']:5s} "
                f"{run['estimated_error']:9.2e} {run['cpu_s']:6.2f}  {ratio}",
                flush=True,
            )
        rows.append({"case": label, "params": params, "request": args.request, "chosen_n0": chosen, "runs": runs})
    print(
        f"total CPU: from {accuracy.N0} {total['32']:.2f} s, from coverage_n0's first grids (*) "
        f"{total['chosen']:.2f} s ({total['chosen'] / total['32']:.2f})"
    )
    if args.json:
        harness.write_json(args.json, {"machine": harness.machine_line(threads=1), "rows": rows})
    return 0


if __name__ == "__main__":
    harness.entry(main)
