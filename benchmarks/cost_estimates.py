"""Do the dry-run's estimates hold? Estimated against measured task time and peak memory per job.

    python benchmarks/cost_estimates.py [JOB.toml ...] [--budget SECONDS]

For each job (default: every jobs/*.toml), in a fresh child process (so that its peak resident
memory is the job's alone): the base memory after a run's imports; then the job's tasks are solved
in sweep order in that process, with the real task function and the kernel cache as a sweep's rank
keeps it; the process's peak resident set (``resource.getrusage``) is read; then the cost model is
calibrated in that same process (``costmodel.calibrate``: timed under the same load as the tasks,
which matters on a shared machine) and the estimate of exactly the tasks that ran is compared with
their measured wall time. A job whose estimated total exceeds ``--budget`` seconds is cut: every
k-th task in sweep order runs (k chosen to fit the budget), plus the task of largest estimated
memory — the table says so.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def measure(job: Path, budget_s: float) -> dict:
    """In this process: run (a cut of) ``job`` and compare with the cost model (module docstring)."""
    from hpcontact.sweep import costmodel
    from hpcontact.sweep.kinds import task_function
    from hpcontact.sweep.spec import load_spec
    from hpcontact.sweep.tasks import enumerate_tasks

    spec = load_spec(job)
    tasks, _ = enumerate_tasks(spec)
    base = costmodel.base_memory_bytes()
    cached = costmodel.load_calibration()  # only to choose the cut; the comparison uses a fresh one
    guess = [cached.task_seconds(t.params, t.cost) for t in tasks]
    step = max(1, math.ceil(sum(guess) / budget_s))
    chosen = sorted(set(range(0, len(tasks), step)) | {max(range(len(tasks)),
                                                           key=lambda i: costmodel.task_array_bytes(tasks[i].params))})
    function = task_function(spec.kind)
    measured = 0.0
    for i in chosen:
        started = time.perf_counter()
        try:
            function(dict(tasks[i].params))
        except Exception as exc:  # noqa: BLE001 - a failed task still took its time, as in a sweep
            print(f"task {i}: {type(exc).__name__}: {exc}", file=sys.stderr)
        measured += time.perf_counter() - started
    scale = 1 if sys.platform == "darwin" else 1024
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale
    fresh = costmodel.calibrate()
    calibration = costmodel.Calibration(fresh.host, fresh.version, fresh.rates, base, fresh.seconds)
    return {
        "job": job.stem,
        "tasks": len(tasks),
        "ran": len(chosen),
        "estimated_s": sum(calibration.task_seconds(tasks[i].params, tasks[i].cost) for i in chosen),
        "measured_s": measured,
        "estimated_peak_bytes": max(calibration.task_bytes(tasks[i].params) for i in chosen),
        "measured_peak_bytes": peak,
        "calibration_s": fresh.seconds,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("jobs", nargs="*", default=sorted(str(p) for p in (ROOT / "jobs").glob("*.toml")))
    parser.add_argument("--budget", type=float, default=60.0, help="estimated seconds of tasks per job (default 60)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    if args.child:
        print(json.dumps(measure(Path(args.jobs[0]), args.budget)), flush=True)
        return
    print(f"{'job':26s} {'tasks run':>11s} {'estimated s':>11s} {'measured s':>10s} {'ratio':>6s} "
          f"{'est. MiB':>8s} {'meas. MiB':>9s} {'ratio':>6s}", flush=True)
    for job in args.jobs:
        done = subprocess.run([sys.executable, __file__, "--child", "--budget", str(args.budget), job],
                              capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
        if done.returncode:
            print(f"{Path(job).stem:26s} failed: {done.stderr.strip().splitlines()[-1:]}", flush=True)
            continue
        r = json.loads(done.stdout.strip().splitlines()[-1])
        print(f"{r['job']:26s} {r['ran']:5d}/{r['tasks']:<5d} {r['estimated_s']:11.1f} {r['measured_s']:10.1f} "
              f"{r['estimated_s'] / r['measured_s']:6.2f} {r['estimated_peak_bytes'] / 2**20:8.0f} "
              f"{r['measured_peak_bytes'] / 2**20:9.0f} {r['estimated_peak_bytes'] / r['measured_peak_bytes']:6.2f}",
              flush=True)


if __name__ == "__main__":
    main()
