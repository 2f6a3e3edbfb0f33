"""What `--accuracy` costs on ellipses now that they take their one exact cell
(``hpcontact.discretizations.galin_ellipse``), against the grids they took before.

Issue 26's crystal cases — cubic, nu 0.3, A ∈ {0.5, 2, 3}, ψ ∈ {20°, 35.26°, 60°},
b/a ∈ {0.3, 0.05, 1e-2, 1e-3} — plus turned ellipses (isotropic and A = 3, ψ = 60°, turned by
40°), each as a user runs it: ``hpcontact solve ... --accuracy 1e-6 --quantities tangential
--json`` in a fresh process (wall time with the imports, and the child's peak resident set),
then the true error against the independent reference (``tests/independent_reference.py``:
Stroh's H, graded Gauss–Legendre) where it applies. ``--before N`` also solves the first N
crystal cases on coverage-weighted grids at 1e-4 and 1e-5 (``strategy="coverage"``, what
``auto`` took before), in this process: CPU seconds and whether the request was met.

    python benchmarks/exact_ellipse_cost.py              # 40 cases, ~1.5 min
    python benchmarks/exact_ellipse_cost.py --before 4   # + grids at 1e-4 and 1e-5, ~3 more min
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

import harness
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import independent_reference as ref  # noqa: E402

PSI_111 = 35.26438968275465
CRYSTALS = [(A, psi, e) for A in (0.5, 2.0, 3.0) for psi in (20.0, PSI_111, 60.0) for e in (0.3, 0.05, 1e-2, 1e-3)]
TURNED = [(1.0, None, 0.3, 40.0), (3.0, 60.0, 0.3, 40.0), (3.0, 60.0, 1e-3, 40.0)]


def arguments(A: float, psi: float | None, aspect: float, turn: float = 0.0) -> list[str]:
    args = ["--shape", "ellipse", "--aspect", repr(aspect), "--nu", "0.3", "--quantities", "tangential"]
    if A != 1.0:
        args += ["--anisotropy", repr(A), "--orientation", repr(psi)]
    if turn:
        args += ["--shape-angle", repr(turn)]
    return args


def run_cli(args: list[str], request: float) -> tuple[dict, float, float]:
    """The record, the wall seconds and the child's peak resident MiB of one ``hpcontact solve``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    started = time.perf_counter()
    out = subprocess.run(
        [str(Path(sys.executable).with_name("hpcontact")), "solve", *args, "--accuracy", repr(request), "--json"],
        capture_output=True,
        text=True,
        check=True,
    )
    wall = time.perf_counter() - started
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return json.loads(out.stdout), wall, max(peak, before) / 1024.0


def true_error(record: dict, A: float, psi: float | None, aspect: float) -> float:
    """Largest relative error of K_xx, K_yy (own), K_xy (to the largest diagonal) against the
    independent reference (an unturned ellipse)."""
    C = ref.rotate(ref.cubic_from_nu_A(0.3, A), ref.orientation_frame(psi)) if A != 1.0 else None
    if C is None:
        from hpcontact import analytic

        K_xx, K_yy = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, 0.3)
        exact = np.diag([K_xx, K_yy])
    else:
        exact = ref.galin_ellipse_stiffness(C, aspect)["approach_held"]
    scale = max(exact[0, 0], exact[1, 1])
    found = np.array([[record["K_xx"], record["K_xy"]], [record["K_yx"], record["K_yy"]]])
    rel = np.abs(found - exact) / np.where(np.eye(2) > 0, np.abs(exact), scale)
    return float(rel.max())


def grids_before(A: float, psi: float, aspect: float, request: float) -> tuple[float, bool, float, list[int]]:
    from hpcontact.accuracy import solve_to_accuracy
    from hpcontact.numerics.convolution import clear_cache
    from hpcontact.scene import Scene

    clear_cache()
    scene = Scene.from_params(
        {
            "shape": "ellipse",
            "aspect": aspect,
            "nu": 0.3,
            "anisotropy": A,
            "orientation": psi,
            "quantities": "tangential",
        }
    )
    started = time.process_time()
    r = solve_to_accuracy(scene, request, strategy="coverage", strict=False)
    return time.process_time() - started, bool(r["accuracy_met"]), float(r["estimated_error"]), r["grids"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--before", type=int, default=0, help="also solve this many crystal cases on grids (1e-4, 1e-5)"
    )
    parser.add_argument("--json", type=Path, help="write every row here")
    options = parser.parse_args()
    print(harness.machine_line(threads=1))
    rows = []
    print(
        f"{'A':>4} {'psi':>6} {'b/a':>7} {'turn':>5} | {'wall s':>6} {'MiB':>5} {'solve ms':>8} {'estimate':>8} {'true':>8}"
    )
    for A, psi, aspect, turn in [(*c, 0.0) for c in CRYSTALS] + TURNED:
        record, wall, mib = run_cli(arguments(A, psi, aspect, turn), 1e-6)
        true = true_error(record, A, psi, aspect) if turn == 0.0 else math.nan
        row = {
            "A": A,
            "psi": psi,
            "aspect": aspect,
            "turn": turn,
            "boundary": record["boundary"],
            "met": record["accuracy_met"],
            "wall_s": wall,
            "peak_mib": mib,
            "solve_s": record["wall_time_s"],
            "estimate": record["estimated_error"],
            "true": true,
        }
        rows.append(row)
        psi_text = "-" if psi is None else f"{psi:.2f}"
        print(
            f"{A:>4g} {psi_text:>6} {aspect:>7g} {turn:>5g} | {wall:6.2f} {mib:5.0f} {1e3 * row['solve_s']:8.1f} "
            f"{row['estimate']:8.1e} {true:8.1e}"
        )
    honest = [r for r in rows if not math.isnan(r["true"])]
    print(
        f"\n{len(rows)} cases at --accuracy 1e-6: all met: {all(r['met'] for r in rows)}; "
        f"wall {min(r['wall_s'] for r in rows):.2f}-{max(r['wall_s'] for r in rows):.2f} s (fresh process, imports included); "
        f"peak {max(r['peak_mib'] for r in rows):.0f} MiB; true <= estimate in {sum(r['true'] <= r['estimate'] for r in honest)}"
        f"/{len(honest)}; worst true {max(r['true'] for r in honest):.1e}, worst estimate {max(r['estimate'] for r in rows):.1e}"
    )
    if options.before:
        print("\nbefore: coverage-weighted grids (what auto took), CPU seconds in this process")
        for A, psi, aspect in CRYSTALS[: options.before]:
            for request in (1e-4, 1e-5):
                cpu, met, estimate, grids = grids_before(A, psi, aspect, request)
                rows.append({"A": A, "psi": psi, "aspect": aspect, "request": request, "grids_cpu_s": cpu, "met": met})
                print(
                    f"{A:>4g} {psi:>6.2f} {aspect:>7g} {request:>7g}: {cpu:6.1f} s, met {met}, "
                    f"estimate {estimate:.1e}, grids {grids}"
                )
    if options.json:
        options.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
