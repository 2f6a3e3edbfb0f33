"""Parallel efficiency and driver overhead of the sweep on 1 and 2 ranks (or more), of a
built-in 64-task sweep or of a job as users run it.

    python benchmarks/sweep_scaling.py [--ranks 1 2] [--tasks solve sleep] [--keep DIR] [--json FILE]
    python benchmarks/sweep_scaling.py --job JOB.toml --ranks 2 16 2 16 [--json FILE]

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

``--job JOB.toml`` runs that job instead, as users run it: ``mpiexec -n R python -m hpcontact run
JOB --output DIR/…`` (its own task function; ``--tasks`` does not apply), one run for each entry
of ``--ranks`` in the order given (``2 16 2 16`` alternates, so that a drift of the machine's
speed shows). After the runs every run is judged against the machine's own run on the fewest
ranks R₀ (how the project judges ranks):

    E_R = (R₀ T_R₀) / (R T_R),

T_R₀ the shortest of the runs on R₀ ranks, for T both the sweep's wall time (the data set's
``sweep_wall_time_s``: the driver's start to the data set assembled; ``sweep_parallel_efficiency``
is Σ task time / (R × it), the measure of issue 40) and the command's (interpreter to netCDF
written). Every run's data set is compared with the first run's of its kind: the data variables
that differ are listed (the timings ``wall_time_s``, ``levels`` and ``estimated_peak_bytes``
where the library is deterministic across rank counts). ``--json FILE`` is written after each run,
so a run cut short keeps what it measured.

Issue 40's bar, the 4-D adaptive map on 16 ranks, on a 16-core machine (the device machine has 16
CPU cores; ``.device``: ``../shared/device/prepare.sh``): on 2 ranks ~3 min a run where a solve
takes ~65 ms, on 16 ranks ~30 s (not measured there yet):

    source .device/on-device.sh && python benchmarks/sweep_scaling.py --job jobs/adaptive_orientation_map.toml --ranks 16 2 16 --json $OUT/node_scaling.json
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Mapping
from dataclasses import dataclass
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


TIMINGS = ("wall_time_s", "levels", "estimated_peak_bytes")  # a run's own timings and base memory


@dataclass(frozen=True)
class Run:
    """One run: its task kind (``job`` for a job), ranks, the data set's attributes, the command's
    wall seconds, and the data variables that differ from the first run's of its kind."""

    tasks: str
    ranks: int
    attrs: dict[str, Any]
    command_wall_s: float
    differs: list[str]


def run(ranks: int, spec: Path, output: Path, tasks: str) -> tuple[dict, float]:
    """The sweep on ``ranks`` ranks (``tasks``: ``job``, ``hpcontact run`` itself, or the
    benchmark's ``worker``): the data set's attributes and the command's wall time."""
    mpiexec = shutil.which("mpiexec", path=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
    if mpiexec is None:
        raise SystemExit("mpiexec not found")
    if tasks == "job":
        rank_command = [sys.executable, "-m", "hpcontact", "run", str(spec), "--output", str(output)]
    else:
        rank_command = harness.child_command(__file__, "worker", str(spec), str(output), tasks)
    done = harness.run_child([mpiexec, "-n", str(ranks), *rank_command], threads=1, check=True)
    with xr.open_dataset(output) as ds:
        return dict(ds.attrs), done.wall_s


def differing(output: Path, first: Path) -> list[str]:
    """The data variables of ``output`` not equal (NaN equal to NaN) to ``first``'s, or absent from
    one of them."""
    with xr.open_dataset(output) as ds, xr.open_dataset(first) as reference:
        names = sorted(set(ds.data_vars) | set(reference.data_vars))
        return [n for n in names if n not in ds or n not in reference or not ds[n].equals(reference[n])]


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


def against_fewest(runs: list[Run]) -> list[str]:
    """Each run judged against the machine's own run on the fewest ranks R₀ of its kind:
    E_R = R₀ T_R₀ / (R T_R), T_R₀ the shortest run on R₀ ranks, of the sweep and of the command."""
    lines = []
    for kind in dict.fromkeys(r.tasks for r in runs):
        mine = [r for r in runs if r.tasks == kind]
        fewest = min(r.ranks for r in mine)
        base = [r for r in mine if r.ranks == fewest]
        sweep = fewest * min(r.attrs["sweep_wall_time_s"] for r in base)
        command = fewest * min(r.command_wall_s for r in base)
        lines.append(
            f"{kind}: against the shortest run on {fewest} rank(s) (sweep {sweep / fewest:.2f} s, command "
            f"{command / fewest:.2f} s), E_R = R0 T_R0 / (R T_R):"
        )
        for r in mine:
            lines.append(
                f"  {r.ranks:>5} ranks: sweep {sweep / (r.ranks * r.attrs['sweep_wall_time_s']):.3f}, command "
                f"{command / (r.ranks * r.command_wall_s):.3f}; its own sweep_parallel_efficiency "
                f"{r.attrs['sweep_parallel_efficiency']:.3f}; data variables differing from the first run's "
                f"beyond its timings ({', '.join(TIMINGS)}): {', '.join(n for n in r.differs if n not in TIMINGS) or 'none'}"
            )
    return lines


def record(path: Path | None, runs: list[Run]) -> None:
    """``--json``: the machine and every run so far."""
    if path is not None:
        keep = ("sweep_", "adaptive_", "mpi_size")
        harness.write_json(
            path,
            {
                "machine": harness.machine_line(1),
                "runs": [
                    {
                        "tasks": r.tasks,
                        "ranks": r.ranks,
                        "command_wall_s": r.command_wall_s,
                        "differs": r.differs,
                        "attrs": {k: v for k, v in r.attrs.items() if k.startswith(keep)},
                    }
                    for r in runs
                ],
            },
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 2], help="one run each, in this order")
    parser.add_argument("--tasks", nargs="+", choices=("solve", "sleep"), default=["solve", "sleep"])
    parser.add_argument("--job", type=Path, help="run this job (hpcontact run JOB) instead of the 64-task sweep")
    parser.add_argument("--keep", type=Path, help="keep spec, data sets and journals in this folder")
    parser.add_argument("--json", type=Path, help="write every run to this JSON file (after each run)")
    args = parser.parse_args()
    if args.job is not None and not args.job.is_file():
        parser.error(f"--job {args.job}: no such file")
    folder = args.keep or Path(tempfile.mkdtemp(prefix="hpcontact-scaling-"))
    folder.mkdir(parents=True, exist_ok=True)
    if args.job is not None:
        spec, kinds = args.job.resolve(), ["job"]
    else:
        spec, kinds = folder / "scaling.toml", args.tasks
        spec.write_text(SPEC, encoding="utf-8")
    print(f"sweep_scaling: {harness.machine_line(1)}")
    print(
        f"{'tasks':>5} {'ranks':>5} {'count':>5} {'wall s':>7} {'command s':>9} {'task s':>7} {'mean s':>9} "
        f"{'efficiency':>10} {'driver ms':>9} {'driver/task':>12}   setup / schedule / journal / gather ms per task"
    )
    runs: list[Run] = []
    try:
        for tasks in kinds:
            first = None
            for i, ranks in enumerate(args.ranks):
                output = folder / f"scaling-{tasks}-{ranks}-{i}.nc"
                attrs, command_wall = run(ranks, spec, output, tasks)
                first = first or output
                runs.append(Run(tasks, ranks, attrs, command_wall, differing(output, first)))
                print(report(tasks, ranks, attrs, command_wall), flush=True)
                record(args.json, runs)
        print("\n".join(against_fewest(runs)))
    finally:
        if args.keep is None:
            shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    harness.entry(main)
