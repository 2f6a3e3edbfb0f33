"""Do the dry-run's estimates hold? Estimated against measured task time and peak memory per job.

    python benchmarks/cost_estimates.py [JOB.toml ...] [--budget SECONDS] [--accuracy REL]

For each job (default: every jobs/*.toml), two fresh child processes:

* **time**: the job's tasks are solved in sweep order with the real task function (the kernel
  cache kept as a sweep's rank keeps it) and their CPU time summed (``time.process_time``, one
  thread: a core's time, as the estimate is; their wall time is printed beside it); the cost model is
  calibrated in that same process just before and just after the tasks (``cost.calibration.calibrate``,
  timed under the same load as the tasks, which matters on a shared machine: a load that comes or
  goes between the tasks and one calibration moved a job's ratio by 1.5-2x) and the mean of the
  two estimates of exactly the tasks that ran is compared with their measured time; the ratio of
  the two estimates (after/before) is printed as "drift". A job whose estimated total exceeds ``--budget`` seconds is
  cut: every k-th task in sweep order runs (k chosen to fit the budget) — the table says so. The
  process's peak resident set after these tasks is printed too (a rank that ran many tasks).
* **memory**: the task of largest estimated memory alone, after a run's imports; its process's
  peak resident set (``resource.getrusage``) against the estimate (base + that task's arrays).

``--accuracy REL`` runs the jobs as ``hpcontact run JOB --accuracy REL`` does (their grids
replaced by the request: every contact task solves ``accuracy.solve_to_accuracy``, costed over
the grids it is predicted to solve, ``cost.grids.accuracy_plan``), e.g. ``jobs/demo.toml --accuracy
1e-3 --budget 60``; ``benchmarks/accuracy_cost_estimates.py`` gives the same per task.

    python benchmarks/cost_estimates.py JOB.toml --journals RESULTS.nc.journal --costmodel FILE

solves nothing: a finished run's measured seconds (each task's ``wall_time_s`` in its journals)
against the seconds the cost model estimates for the same tasks at the calibration ``FILE``
(``estimate.task_arrays``, as the run's start line and ETA use them), by kind of task (its
calibration kind, shape and boundary cells) and in total. The first-hour run of the main job
(issue 42) at its machine's idle calibration: ``jobs/demo.toml --journals
results/demo.nc.journal --costmodel costmodel-intel-xeon-processor-2c.json``.
"""

from __future__ import annotations

import argparse
import math
import sys
from functools import partial
from pathlib import Path

import harness


def measure_time(job: str, budget_s: float, accuracy: float | None = None) -> dict:
    """In this process: run (a cut of) ``job`` (at ``accuracy``, as ``hpcontact run --accuracy``),
    then calibrate; estimated and measured seconds."""
    from hpcontact.accuracy import task_function
    from hpcontact.numerics.memory import resident_bytes
    from hpcontact.sweep.cost.calibration import calibrate
    from hpcontact.sweep.space.parse import load_spec
    from hpcontact.sweep.work.tasks import enumerate_tasks

    spec = load_spec(job, accuracy=accuracy)
    tasks, _ = enumerate_tasks(spec)
    before = calibrate()
    step = max(1, math.ceil(sum(before.task_seconds(t.params, t.cost) for t in tasks) / budget_s))
    chosen = list(range(0, len(tasks), step))
    function = task_function(spec.kind)
    measured = 0.0
    wall = 0.0
    for i in chosen:
        t = harness.timed(partial(run_task, function, i, tasks[i].params))
        measured += t.cpu_s
        wall += t.wall_s
    rss = resident_bytes()
    after = calibrate()
    estimates = [sum(c.task_seconds(tasks[i].params, tasks[i].cost) for i in chosen) for c in (before, after)]
    return {
        "job": Path(job).stem,
        "tasks": len(tasks),
        "ran": len(chosen),
        "estimated_s": 0.5 * (estimates[0] + estimates[1]),
        "drift": estimates[1] / estimates[0],
        "measured_s": measured,
        "measured_wall_s": wall,
        "run_peak_bytes": rss,
        "calibration_s": after.seconds,
    }


def run_task(function, index: int, params) -> None:
    """One task as a sweep runs it: a failure is reported and still took its time."""
    try:
        function(dict(params))
    except Exception as exc:  # noqa: BLE001 - a failed task still took its time, as in a sweep
        print(f"task {index}: {type(exc).__name__}: {exc}", file=sys.stderr)


def measure_memory(job: str, accuracy: float | None = None) -> dict:
    """In this process: the largest task alone (at ``accuracy``); estimated and measured peak
    resident bytes."""
    from hpcontact.accuracy import task_function
    from hpcontact.numerics.memory import resident_bytes
    from hpcontact.sweep.cost.rates import base_memory_bytes, task_array_bytes
    from hpcontact.sweep.space.parse import load_spec
    from hpcontact.sweep.work.tasks import enumerate_tasks

    spec = load_spec(job, accuracy=accuracy)
    tasks, _ = enumerate_tasks(spec)
    base = base_memory_bytes()
    largest = max(tasks, key=lambda t: task_array_bytes(t.params))
    task_function(spec.kind)(dict(largest.params))
    return {
        "estimated_peak_bytes": base + task_array_bytes(largest.params),
        "measured_peak_bytes": resident_bytes(),
    }


def measured_against_estimated(job: str, journals: str, costmodel: str) -> None:
    """Print the measured ÷ estimated seconds of a finished run of ``job`` (its ``journals``) per
    kind of task and in total, then per grid (``grids_against_levels``), at the calibration file
    ``costmodel`` (module docstring)."""
    from hpcontact.problems.footprint import task_kind
    from hpcontact.sweep.cost.calibration_file import read_calibration
    from hpcontact.sweep.cost.grids import accuracy_plan, asks_accuracy
    from hpcontact.sweep.data.journal import journal_files, read_file
    from hpcontact.sweep.space.parse import load_spec
    from hpcontact.sweep.work.estimate import task_arrays
    from hpcontact.sweep.work.tasks import enumerate_tasks

    records = {
        event["key"]: event["record"]
        for path in journal_files(Path(journals))
        for event in read_file(path)[1]
        if event.get("event") == "finished" and "wall_time_s" in event.get("record", {})
    }
    calibration = read_calibration(Path(costmodel))
    tasks, _ = enumerate_tasks(load_spec(job))
    ran = [t for t in tasks if t.key in records]
    seconds = task_arrays(ran, calibration)[0].tolist()
    kinds: dict[str, list[float]] = {}
    for task, estimated in zip(ran, seconds):
        cells = accuracy_plan(task.params).strategy if asks_accuracy(task.params) else "one grid"
        row = kinds.setdefault(f"{task_kind(task.params)} {task.params.get('shape', '')} {cells}", [0, 0.0, 0.0])
        row[0] += 1
        row[1] += float(records[task.key]["wall_time_s"])
        row[2] += estimated
    print(f"{Path(job).stem}: {len(ran)} of {len(tasks)} tasks in the journals; cost model {costmodel}")
    print(f"{'kind of task':36s} {'tasks':>5s} {'measured s':>10s} {'estimated s':>11s} {'ratio':>6s}")
    for kind, (count, wall, estimated) in sorted(kinds.items()):
        print(f"{kind:36s} {count:5d} {wall:10.2f} {estimated:11.2f} {wall / estimated:6.2f}")
    wall = sum(float(records[t.key]["wall_time_s"]) for t in ran)
    print(f"{'total':36s} {len(ran):5d} {wall:10.2f} {sum(seconds):11.2f} {wall / sum(seconds):6.2f}")
    grids_against_levels(ran, records, calibration)


def grids_against_levels(tasks: list, records: dict, calibration) -> None:
    """Print, per grid (calibration kind, shape, n × n_across; a task's first grid apart), the
    median of its measured seconds in the tasks' ``records`` (each ``levels`` entry's
    ``wall_time_s``, on the grid of ``grids``, ``grids_across``) against the cost model's seconds
    of that grid (``task_cost.level_work``; a crystal's kernel build is the task's: its first grid
    measures it, no grid's estimate holds it)."""
    import statistics

    from hpcontact.problems.footprint import task_kind
    from hpcontact.sweep.cost.grids import BOUNDARY_TAG, accuracy_levels, asks_accuracy
    from hpcontact.sweep.cost.rates import work_seconds
    from hpcontact.sweep.cost.task_cost import level_work

    grids: dict[tuple[str, int, int, bool], tuple[list[float], float]] = {}
    for task in tasks:
        record = records[task.key]
        if not asks_accuracy(task.params) or not record.get("levels") or not record.get("grids"):
            continue
        first = accuracy_levels(task.params)[0]
        if first.get(BOUNDARY_TAG) != record.get("boundary"):
            continue  # cells other than the predicted ones: not the grids the model costs
        kind = f"{task_kind(task.params)} {task.params.get('shape', '')}"
        for index, (level, n, across) in enumerate(zip(record["levels"], record["grids"], record["grids_across"])):
            estimated = work_seconds(calibration.rates, level_work({**first, "n": n, "n_across": across}))
            grids.setdefault((kind, n, across, index == 0), ([], estimated))[0].append(float(level["wall_time_s"]))
    print(f"{'grid':30s} {'first':>5s} {'grids':>5s} {'measured s':>10s} {'estimated s':>11s} {'ratio':>6s}")
    for (kind, n, across, first), (walls, estimated) in sorted(
        grids.items(), key=lambda kv: (kv[0][0], kv[0][1] * kv[0][2])
    ):
        median = statistics.median(walls)
        label = f"{kind} {n} x {across}"
        print(
            f"{label:30s} {'yes' if first else '':>5s} {len(walls):5d} {median:10.3f} {estimated:11.3f} {median / estimated:6.2f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("jobs", nargs="*", default=sorted(str(p) for p in (harness.ROOT / "jobs").glob("*.toml")))
    parser.add_argument("--budget", type=float, default=60.0, help="estimated seconds of tasks per job (default 60)")
    parser.add_argument("--accuracy", type=float, help="run every job at this accuracy (as hpcontact run --accuracy)")
    parser.add_argument("--journals", help="a finished run's journal folder: its measured seconds, nothing solved")
    parser.add_argument("--costmodel", help="with --journals: the calibration file to estimate at")
    args = parser.parse_args()
    if args.journals:
        for job in args.jobs:
            measured_against_estimated(job, args.journals, args.costmodel)
        return
    print(f"cost_estimates: {harness.machine_line(1)}")
    print(
        f"{'job':24s} {'tasks run':>11s} {'estimated s':>11s} {'measured s':>10s} {'ratio':>6s} "
        f"{'est. MiB':>8s} {'meas. MiB':>9s} {'ratio':>6s} {'run MiB':>8s} {'wall s':>7s} {'drift':>6s}",
        flush=True,
    )
    for job in args.jobs:
        try:  # each in a fresh process, one thread
            r = {
                **harness.call_in_child(__file__, "measure_time", job, args.budget, args.accuracy, check=True).result,
                **harness.call_in_child(__file__, "measure_memory", job, args.accuracy, check=True).result,
            }
        except RuntimeError as exc:
            print(f"{Path(job).stem:24s} failed: {exc}", flush=True)
            continue
        print(
            f"{r['job']:24s} {r['ran']:5d}/{r['tasks']:<5d} {r['estimated_s']:11.1f} {r['measured_s']:10.1f} "
            f"{r['estimated_s'] / r['measured_s']:6.2f} {r['estimated_peak_bytes'] / 2**20:8.0f} "
            f"{r['measured_peak_bytes'] / 2**20:9.0f} {r['estimated_peak_bytes'] / r['measured_peak_bytes']:6.2f} "
            f"{r['run_peak_bytes'] / 2**20:8.0f} {r['measured_wall_s']:7.1f} {r['drift']:6.2f}",
            flush=True,
        )


if __name__ == "__main__":
    harness.entry(main)
