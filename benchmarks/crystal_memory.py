"""Peak memory of single crystal solves against ``footprint.array_bytes`` (the crystal fits of
docs/performance.md §"Memory per task").

    python benchmarks/crystal_memory.py [--n 32 64 128 256 512 1024] [--aspect 1.0]
                                        [--quantities tangential,normal] [--covered]

Each grid in a fresh process (``--child``): the kernel and spectrum caches cleared
(``kernels.anisotropic.clear_cache``, ``numerics.convolution.clear_cache``), then the
``tracemalloc`` peak of one ``hpcontact.solve`` of a cubic A = 2, nu = 0.25 ellipse (tol 1e-8;
indentation: radius 10, depth 0.01) or, with ``--covered``, of one coverage-weighted solve
(``accuracy.covered_solve``, model + ``accuracy.COVERAGE_BYTES_PER_CELL`` per contact cell).
Prints per grid the padded cells, the traced peak, the model and model / peak.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tracemalloc


def child(n: int, aspect: float, quantities: str, covered: bool) -> dict:
    from hpcontact import accuracy, api
    from hpcontact.kernels import anisotropic
    from hpcontact.numerics import convolution
    from hpcontact.problems import footprint
    from hpcontact.scene import Scene

    p = {"shape": "ellipse", "aspect": aspect, "nu": 0.25, "anisotropy": 2.0, "quantities": quantities.split(",")}
    if quantities == "indentation":
        p.update(radius=10.0, depth=0.01)
    fields = {**p, "n": n}
    anisotropic.clear_cache()
    convolution.clear_cache()
    tracemalloc.start()
    if covered:
        scene = Scene.from_params(p)
        accuracy.covered_solve(scene.on_grid(n, footprint.contact_grid(fields)[1], 1e-5), "coverage")
    else:
        api.solve(**fields, tol=1e-8)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    nx, ny = footprint.contact_grid(fields)
    model = footprint.array_bytes(fields) + (accuracy.COVERAGE_BYTES_PER_CELL * nx * ny if covered else 0.0)
    return {"n": n, "grid": [nx, ny], "padded_cells": footprint.padded_cells(fields), "peak": peak, "model": model}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, nargs="+", default=[32, 64, 128, 256, 512, 1024])
    ap.add_argument("--aspect", type=float, default=1.0)
    ap.add_argument("--quantities", default="tangential,normal")
    ap.add_argument("--covered", action="store_true", help="one coverage-weighted solve (accuracy.covered_solve)")
    ap.add_argument("--child", type=int, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child is not None:
        print(json.dumps(child(a.child, a.aspect, a.quantities, a.covered)))
        return
    print(f"cubic A = 2, nu = 0.25, ellipse b/a {a.aspect}, {a.quantities}, {'covered' if a.covered else 'solve'}")
    print(f"{'n':>5} {'grid':>11} {'padded cells':>13} {'peak MiB':>9} {'model MiB':>10} {'model/peak':>10}")
    for n in a.n:
        cmd = [sys.executable, __file__, "--child", str(n), "--aspect", str(a.aspect), "--quantities", a.quantities]
        out = subprocess.run(cmd + (["--covered"] if a.covered else []), capture_output=True, text=True, check=True)
        r = json.loads(out.stdout.strip().splitlines()[-1])
        grid = f"{r['grid'][0]} x {r['grid'][1]}"
        print(
            f"{n:>5} {grid:>11} {r['padded_cells']:>13.0f} {r['peak'] / 2**20:>9.1f} {r['model'] / 2**20:>10.1f}"
            f" {r['model'] / r['peak']:>10.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
