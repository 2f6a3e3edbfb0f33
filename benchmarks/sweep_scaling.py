"""Parallel efficiency and driver overhead of the sweep on 1 and 2 ranks (or more).

    python benchmarks/sweep_scaling.py [--ranks 1 2] [--tasks solve sleep] [--keep DIR]

Runs one 64-task heterogeneous sweep (ellipses and rectangles, b/a from 1 to 1e-6, n from 64
to 256 cells: task costs spread over ~50×) under ``mpiexec -n R`` for each R, with two task
functions:

* ``solve`` — the real solver (one thread per rank);
* ``sleep`` — sleeps for the task's estimated cost (mean 0.15 s): the driver's scheduling and
  overhead alone, unaffected by other load on the machine or by memory bandwidth.

For each run it prints, from the data set's ``sweep_*`` attributes:

* parallel efficiency Σ task time / (ranks × wall), wall from the driver's start to the data set
  assembled (target ≥ 0.9 on 2 ranks);
* the driver's own time per task — setup (spec check, task list, journal scan), scheduling
  (atomic counter), journal appends, gather (journals → data set) — relative to the mean task;
* the wall time of the whole command (interpreter start, imports, netCDF write included).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import harness
import xarray as xr

SPEC = """
[sweep]
title = "sweep scaling benchmark: 64 heterogeneous tasks"
progress_interval = 3600.0

[scene]
quantities = ["tangential", "normal"]

[numerics]
tol = 1e-10

[axes]
shape = ["ellipse", "rectangle"]
aspect = [1.0, 0.1, 1e-3, 1e-6]
nu = [0.25, 0.5]
n = [64, 128, 192, 256]
"""
MEAN_SLEEP_S = 0.15


def worker(spec: str, output: str, tasks: str) -> None:
    """One rank of a benchmark run (started by ``run`` under mpiexec)."""
    from hpcontact.sweep.cost.task_cost import estimated_cost
    from hpcontact.sweep.driver import run_sweep
    from hpcontact.sweep.space.parse import load_spec
    from hpcontact.sweep.work.tasks import enumerate_tasks

    if tasks == "solve":
        from hpcontact.problems.contact import solve
        from hpcontact.scene import Scene

        def function(params: Mapping[str, Any]) -> dict[str, Any]:
            return solve(Scene.from_params(params))
    else:
        costs = [t.cost for t in enumerate_tasks(load_spec(spec))[0]]
        scale = MEAN_SLEEP_S * len(costs) / sum(costs)

        def function(params: Mapping[str, Any]) -> dict[str, float]:
            seconds = scale * estimated_cost(params)
            time.sleep(seconds)
            return {"slept_s": seconds}

    with open(os.devnull, "w", encoding="utf-8") as sink:
        run_sweep(spec, output=output, task_function=function, stream=sink)


def run(ranks: int, spec: Path, output: Path, tasks: str) -> tuple[dict, float]:
    """The sweep on ``ranks`` ranks: the data set's attributes and the command's wall time."""
    mpiexec = shutil.which("mpiexec", path=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    if mpiexec is None:
        raise SystemExit("mpiexec not found")
    command = [mpiexec, "-n", str(ranks), *harness.child_command(__file__, "worker", str(spec), str(output), tasks)]
    done = harness.run_child(command, threads=1, check=True)
    with xr.open_dataset(output) as ds:
        return dict(ds.attrs), done.wall_s


def report(tasks: str, ranks: int, attrs: dict, command_wall: float) -> str:
    """One line of the table."""
    count = int(attrs["sweep_tasks_run"])
    mean_task = attrs["sweep_task_time_s"] / count
    parts = [attrs[f"sweep_{k}_time_s"] for k in ("setup", "schedule", "journal", "gather")]
    # setup and gather run on rank 0 while the others wait: they cost every rank
    driver = (ranks * (parts[0] + parts[3]) + parts[1] + parts[2]) / count
    return (
        f"{tasks:>5} {ranks:>5} {count:>5} {attrs['sweep_wall_time_s']:>7.2f} {command_wall:>9.2f} "
        f"{attrs['sweep_task_time_s']:>7.2f} {mean_task:>9.3f} {attrs['sweep_parallel_efficiency']:>10.3f} "
        f"{1e3 * driver:>9.2f} {driver / mean_task:>12.2%}   " + " / ".join(f"{1e3 * p / count:.2f}" for p in parts)
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--tasks", nargs="+", choices=("solve", "sleep"), default=["solve", "sleep"])
    parser.add_argument("--keep", type=Path, help="keep spec, data sets and journals in this folder")
    args = parser.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="hpcontact-scaling-"))
    folder.mkdir(parents=True, exist_ok=True)
    spec = folder / "scaling.toml"
    spec.write_text(SPEC, encoding="utf-8")
    print(f"sweep_scaling: {harness.machine_line(1)}")
    print(
        f"{'tasks':>5} {'ranks':>5} {'count':>5} {'wall s':>7} {'command s':>9} {'task s':>7} {'mean s':>9} "
        f"{'efficiency':>10} {'driver ms':>9} {'driver/task':>12}   setup / schedule / journal / gather ms per task"
    )
    try:
        for tasks in args.tasks:
            for ranks in args.ranks:
                attrs, command_wall = run(ranks, spec, folder / f"scaling-{tasks}-{ranks}.nc", tasks)
                print(report(tasks, ranks, attrs, command_wall), flush=True)
    finally:
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    harness.entry(main)
