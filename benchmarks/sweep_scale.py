"""Parallel efficiency of the sweep scheduler on 2 … 4096 ranks, replayed from measured task costs.

    python benchmarks/sweep_scale.py [--specs JOB.toml ...] [--ranks 2 16 64 256 1024 4096] [--keep DIR]

What it does, in order:

1. **Task costs, measured.** Runs three small real sweeps in this process (one core, the real
   solver): thin shapes (ellipse, rectangle, polygons, b/a 1 … 1e-8), cubic crystals (A, ψ) and
   Coulomb partial slip (sphere pairs). Each journal entry gives a measured wall time; the
   spec's tasks give the estimated cost (``cost.task_cost.estimated_cost``, the units the scheduler
   orders by) and kernel group. Real jobs already run (``--specs jobs/demo.toml ...``: their
   journals) are added to these.
2. **Overheads, measured.** Under ``mpiexec -n 2``, the real ``ServedCounter``: a worker's claim
   round trip while rank 0 computes in pure Python (holding the GIL: the worst case) and the
   server's time per message on a full queue; from the small sweeps, the driver's own time per
   task (journal write, progress, scheduling). On the six-axis job itself (48 132 tasks, below),
   with the driver's own functions in this process as 64 ranks would run them: the setup spread
   over the ranks (each share of the points enumerated with every distinct scene validated,
   ``tasks.enumerate_part``, as the driver's share does: the sum over shares) and the setup on the
   critical path (every rank unpickles and joins all shares, ``tasks.join_parts``; rank 0 checks
   the journals and decides, ``run.resume.prepare``; the decision pickled
   and unpickled as its broadcast does; every rank makes the chunks for 1024 ranks); the gather spread over the ranks (synthetic solver-like outcomes,
   ``dataset_scale.record``, turned into columns, ``columns.to_columns``) and rank 0's serial
   gather (the columns unpickled and joined, the data set built and written). Best of
   ``--repeats`` (the machine is shared).
3. **Replay.** For each distribution — each small sweep copied to a job of 10^5 tasks (copy r of
   a task is a new task in kernel group "group#r"), and a six-axis job: 10 shapes × 37 angles ×
   6 nu × 17 b/a × 11 A × 19 ψ (the load angle derived; isotropic points share their
   orientation-free scene, polygons ignore b/a: 48 132 distinct tasks) — the tasks are chunked and
   ordered by the real ``make_chunks`` for R ranks (kernel groups included) and run by the
   discrete-event model of the scheduler, ``sweep.cost.replay.replay`` (the one the
   dry-run uses): every rank computes; a worker's claim waits for the server (FIFO, measured service
   time) plus the measured wake-up latency; rank 0 claims without messages; the ranks share the
   enumeration and the columns, rank 0 alone joins them (serial setup and gather) while the
   others wait. The six-axis
   job's task seconds are its estimated costs times the seconds per cost unit measured for its
   kind (isotropic contact, crystal), times a residual drawn from the measured ones — so the
   estimate's scatter is replayed too.

Efficiency = Σ task seconds / (R × makespan). Printed per distribution and R, with the share
lost to the tail (last rank to finish vs mean), to claims, and to setup + gather; with
``--before``, the same replay with the setup and gather all on rank 0 at the per-task times the
driver of commit ab7d7f9 was measured at (docs/explanation/sweeps.md: 0.24 and 0.35 ms), side by side.
"""

from __future__ import annotations

import argparse
import math
import os
import pickle
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass, fields, replace
from pathlib import Path

import harness
import numpy as np

from hpcontact.problems.footprint import task_kind
from hpcontact.sweep.data.journal import OK, read_journals
from hpcontact.sweep.space.parse import load_spec, parse_spec
from hpcontact.sweep.space.spec import Spec
from hpcontact.sweep.work.replay import Overheads, replay
from hpcontact.sweep.work.tasks import Task, enumerate_part, enumerate_tasks, join_parts, make_chunks, points

SMALL_SWEEPS = {
    "thin shapes": """
[sweep]
title = "scale benchmark: thin shapes"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 64
tol = 1e-10
[axes]
shape = ["ellipse", "rectangle", { label = "hexagon", shape = "polygon", sides = 6 }]
aspect = { logspace = [0, -8, 9] }
nu = [0.0, 0.25, 0.5]
""",
    "crystals": """
[sweep]
title = "scale benchmark: crystals"
[scene]
quantities = ["tangential"]
shape = "ellipse"
nu = 0.3
[numerics]
n = 32
tol = 1e-10
[axes]
aspect = [1.0, 0.5]
anisotropy = [0.5, 1.0, 2.0, 4.0]
orientation = [0.0, 35.26438968275465, 60.0, 90.0]
""",
    "slip": """
[sweep]
title = "scale benchmark: partial slip"
[scene]
quantities = "slip"
radius = 8e-3
radius2 = 9e-3
steps = 3
[numerics]
n = 32
tol = 1e-8
[axes]
pair = [
    { label = "Cu-Cu", material = "Cu", material2 = "Cu" },
    { label = "Cu-Fe", material = "Cu", material2 = "Fe" },
]
load = [10.0, 100.0]
mu = [0.3]
q_ratio = [0.3, 0.6, 0.9]
""",
}
SIX_AXIS = """
[sweep]
title = "six-axis job"
[scene]
quantities = ["tangential"]
[numerics]
n = 64
tol = 1e-10
[axes]
shape = ["circle", "ellipse", "rectangle", { label = "triangle", shape = "polygon", sides = 3 },
         { label = "square", shape = "polygon", sides = 4 }, { label = "pentagon", shape = "polygon", sides = 5 },
         { label = "hexagon", shape = "polygon", sides = 6 }, { label = "octagon", shape = "polygon", sides = 8 },
         { label = "star3", shape = "star", sides = 3, amplitude = 0.2 }, { label = "star5", shape = "star", sides = 5, amplitude = 0.3 }]
angle = { linspace = [0, 180, 37] }
nu = [0.0, 0.1, 0.2, 0.3, 0.4, 0.45]   # crystals need nu < 0.5
aspect = { logspace = [0, -8, 17] }
anisotropy = [0.25, 0.3536, 0.5, 0.7071, 1.0, 1.414, 2.0, 2.828, 4.0, 5.657, 8.0]
orientation = { linspace = [0, 90, 19] }
"""
REPLICATED_TASKS = 100_000  # each measured distribution is replayed as a job of this many tasks


@dataclass(frozen=True)
class Distribution:
    """The journaled tasks of one sweep: ``tasks`` (estimated cost, kernel group) and the measured
    ``seconds`` of each."""

    tasks: list[Task]
    seconds: np.ndarray


def measured(spec: Spec) -> Distribution:
    """The tasks of ``spec`` that its journals hold as successful, with their measured time."""
    tasks, _ = enumerate_tasks(spec)
    entries = read_journals(spec.journal)
    done = [t for t in tasks if t.key in entries and entries[t.key].status == OK]
    return Distribution(done, np.array([entries[t.key].wall_time_s for t in done]))


def run_small_sweeps(folder: Path) -> tuple[dict[str, Distribution], dict[str, float]]:
    """Run the small sweeps in this process; their measured tasks and driver overheads per task."""
    import xarray as xr

    from hpcontact.sweep.driver import run_sweep
    from hpcontact.sweep.run.schedule import SerialTeam

    out: dict[str, Distribution] = {}
    overhead = {"driver_s": []}
    for name, text in SMALL_SWEEPS.items():
        spec = folder / f"{name.replace(' ', '_')}.toml"
        spec.write_text(text)
        output = folder / f"{spec.stem}.nc"
        started = time.perf_counter()
        path = run_sweep(spec, output=output, team=SerialTeam(), stream=open(os.devnull, "w"))
        with xr.open_dataset(path) as ds:
            attrs = dict(ds.attrs)
        out[name] = measured(load_spec(spec, output=output))
        n = len(out[name].tasks)
        overhead["driver_s"].append((attrs["sweep_journal_time_s"] + attrs["sweep_schedule_time_s"]) / n)
        print(
            f"  {name:12s} {n:4d} tasks, {out[name].seconds.sum():7.1f} s of solves "
            f"({time.perf_counter() - started:.1f} s with the driver)",
            flush=True,
        )
    return out, {k: statistics.median(v) for k, v in overhead.items()}


PROBE = r"""
import time
from hpcontact.sweep.run import schedule
from hpcontact.sweep.run.schedule import SLOTS, MPITeam, world
team = world()
counter = team.counter(SLOTS)  # as the driver runs it: rank 0 serves from a thread
if team.rank == 1:
    samples = []
    for i in range(400):
        t = time.perf_counter(); counter.fetch_add(1, 0); samples.append(time.perf_counter() - t)
    samples.sort()
    print("claim", samples[len(samples) // 2], samples[-1], flush=True)
else:
    end = time.perf_counter() + 4.0
    while time.perf_counter() < end:  # rank 0 computes in pure Python: holds the GIL
        sum(range(1000))
counter.close()
schedule.ADD_EVERY_S = 0.0  # every add its own message
counter = MPITeam(team.comm, threaded=False).counter(SLOTS)
if team.rank == 1:
    for i in range(3000):
        counter.add(1, [1])
else:
    time.sleep(2.0)  # let every message arrive, then time the server on a full queue
    t = time.perf_counter(); served = 0
    while counter.serve_one():
        served += 1
    print("service", (time.perf_counter() - t) / max(served, 1), served, flush=True)
counter.close()
"""


def measure_latency() -> dict[str, float]:
    """A worker's claim round trip while rank 0 computes (median, worst) and the server's time per
    message on a full queue, from the real scheduler under the mpiexec beside this Python."""
    mpiexec = Path(sys.executable).with_name("mpiexec")
    done = harness.run_child([str(mpiexec), "-n", "2", sys.executable, "-c", PROBE], timeout=120)
    if done.returncode or done.timed_out:
        raise RuntimeError(f"latency probe failed: {done.error}\n{done.stderr[-2000:]}")
    values: dict[str, float] = {}
    for line in done.stdout.splitlines():
        word, *numbers = line.split()
        if word == "claim":
            values["claim_busy_s"], values["claim_worst_s"] = map(float, numbers)
        elif word == "service":
            values["service_s"] = float(numbers[0])
    return values


def replicated(case: Distribution, count: int) -> Distribution:
    """``case`` copied until it has at least ``count`` tasks (copies share no kernels)."""
    copies = math.ceil(count / len(case.tasks))
    tasks = [t._replace(key=f"{t.key}#{r}", group=f"{t.group}#{r}") for r in range(copies) for t in case.tasks]
    return Distribution(tasks, np.tile(case.seconds, copies))


BEFORE = {"setup_s": 0.24e-3, "gather_s": 0.35e-3}  # rank 0 alone, per task, ab7d7f9 (docs/explanation/sweeps.md)
SHARES = 64  # ranks the six-axis setup and gather are split over when measured


def best(function, repeats: int) -> tuple[float, object]:
    """The least wall time of ``repeats`` calls of ``function`` and its last value."""
    timing = harness.repeat_timing(function, repeats)
    return timing.best, timing.value


def setup_and_gather(folder: Path, repeats: int) -> dict[str, float]:
    """Per task of the six-axis job: the setup and gather spread over the ranks (summed over
    ``SHARES`` shares) and rank 0's serial setup and gather (module docstring, point 2)."""
    from dataset_scale import record

    from hpcontact.sweep.data.columns import join, to_columns
    from hpcontact.sweep.data.dataset import FIXED_VARIABLES, dataset_of, write_netcdf
    from hpcontact.sweep.data.journal import Entry
    from hpcontact.sweep.run.records import Decision, Kept, Options
    from hpcontact.sweep.run.resume import prepare as resume_prepare

    spec = parse_spec(SIX_AXIS, folder / "six_axis.toml", output=folder / "six_axis.nc", check_scenes=False)
    options = Options(restart=True)
    total = points(spec)

    def share(rank: int):
        """Rank ``rank``'s share of the points, every distinct scene validated (the driver's share
        without a memory limit)."""
        return enumerate_part(spec, total * rank // SHARES, total * (rank + 1) // SHARES, None, check=True)

    spread_setup, shares = best(lambda: [share(r) for r in range(SHARES)], repeats)
    sent = [pickle.dumps(part, protocol=pickle.HIGHEST_PROTOCOL) for part in shares]

    def prepare() -> tuple[list[Task], Decision, Kept]:
        tasks, task_of = join_parts(spec, [pickle.loads(b) for b in sent])  # every rank
        decision, kept = resume_prepare(spec, tasks, task_of, False, options, 1024)  # rank 0
        kept.lock.release()
        decision = pickle.loads(pickle.dumps(decision, protocol=pickle.HIGHEST_PROTOCOL))  # its broadcast
        make_chunks([tasks[i] for i in decision.shared], 1024)  # every rank
        return tasks, decision, kept

    serial_setup, (tasks, decision, kept) = best(prepare, repeats)
    n = len(tasks)
    entries = [
        Entry(
            key=t.key,
            params=t.params,
            status=OK,
            message="",
            record=record(t.key, dict(t.params)),
            wall_time_s=1.0,
            finished=0.0,
            rank=i % SHARES,
            provenance=decision.provenance,
        )
        for i, t in enumerate(tasks)
    ]
    spread_gather, columns = best(
        lambda: [to_columns(entries[r::SHARES], list(range(r, n, SHARES))) for r in range(SHARES)], repeats
    )
    sent = [pickle.dumps(c, protocol=pickle.HIGHEST_PROTOCOL) for c in columns]

    def gather() -> None:
        joined = join([to_columns([], [])] + [pickle.loads(b) for b in sent], n, FIXED_VARIABLES)
        write_netcdf(dataset_of(spec, kept.task_of, joined, {"mpi_size": 1024}, derive=False), spec.output)

    serial_gather, _ = best(gather, repeats)
    return {
        "spread_setup_s": spread_setup / n,
        "setup_s": serial_setup / n,
        "spread_gather_s": spread_gather / n,
        "gather_s": serial_gather / n,
        "six_axis_tasks": n,
    }


def six_axis(calibration: dict[str, tuple[float, np.ndarray]], rng: np.random.Generator) -> Distribution:
    """The six-axis job's tasks with modelled seconds: estimated cost × the measured seconds per
    cost unit of the task's kind × a measured residual of that kind drawn at random."""
    spec = parse_spec(SIX_AXIS, Path("six_axis.toml"), check_scenes=False)
    tasks, _ = enumerate_tasks(spec)
    seconds = np.empty(len(tasks))
    for i, task in enumerate(tasks):
        rate, residuals = calibration[task_kind(task.params)]
        seconds[i] = task.cost * rate * residuals[rng.integers(len(residuals))]
    return Distribution(tasks, seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--specs", nargs="*", default=[], help="specs of real jobs already run: replay their journals too"
    )
    parser.add_argument("--ranks", nargs="*", type=int, default=[2, 16, 64, 256, 1024, 4096])
    parser.add_argument("--keep", help="keep the small sweeps' outputs in this folder")
    parser.add_argument("--repeats", type=int, default=2, help="best of this many timings of setup and gather")
    parser.add_argument(
        "--before", action="store_true", help="also replay with setup and gather all on rank 0 (ab7d7f9)"
    )
    args = parser.parse_args()
    print(f"sweep_scale: {harness.machine_line(1)}")
    folder = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="hpcontact-scale-"))
    folder.mkdir(parents=True, exist_ok=True)
    print("measured task costs (one core, real solver):")
    distributions, overhead = run_small_sweeps(folder)
    for path in args.specs:
        distributions[Path(path).stem] = measured(load_spec(path))
    overhead.update(measure_latency())
    overhead.update(setup_and_gather(folder, args.repeats))
    overhead["wake_s"] = max(overhead["claim_busy_s"] - overhead["service_s"], 0.0)
    print(
        "measured overheads: claim round trip with rank 0 computing {:.2f} ms (median; worst {:.2f} ms), "
        "server time per message {:.3f} ms; driver {:.2f} ms/task; six-axis job ({} tasks), per task: setup "
        "spread over the ranks {:.3f} ms, on rank 0 alone {:.4f} ms; gather spread {:.4f} ms, on rank 0 alone "
        "{:.4f} ms".format(
            overhead["claim_busy_s"] * 1e3,
            overhead["claim_worst_s"] * 1e3,
            overhead["service_s"] * 1e3,
            overhead["driver_s"] * 1e3,
            overhead["six_axis_tasks"],
            overhead["spread_setup_s"] * 1e3,
            overhead["setup_s"] * 1e3,
            overhead["spread_gather_s"] * 1e3,
            overhead["gather_s"] * 1e3,
        )
    )

    calibration: dict[str, tuple[float, np.ndarray]] = {}
    pooled = [
        (task_kind(t.params), s / t.cost) for case in distributions.values() for t, s in zip(case.tasks, case.seconds)
    ]
    for kind in ("contact", "crystal", "slip"):
        ratios = np.array([ratio for k, ratio in pooled if k == kind])
        rate = float(np.median(ratios))
        calibration[kind] = (rate, ratios / rate)
        print(
            f"  {kind:8s}: {len(ratios):4d} tasks, {rate * 1e6:.3g} µs per cost unit; measured/estimated "
            f"spread (5-95 %) {np.percentile(ratios / rate, 5):.2f} … {np.percentile(ratios / rate, 95):.2f}"
        )

    big = six_axis(calibration, np.random.default_rng(1))
    print(f"six-axis job: {len(big.tasks)} tasks, {big.seconds.sum() / 3600:.1f} core-hours modelled")

    cases = {
        f"{name} x{math.ceil(REPLICATED_TASKS / len(case.tasks))}": replicated(case, REPLICATED_TASKS)
        for name, case in distributions.items()
    }
    cases["six-axis job"] = big
    print(
        f"\n{'distribution':22s} {'tasks':>7s} {'ranks':>6s} {'chunks':>7s} {'wall s':>9s} {'efficiency':>10s}"
        f" {'tail':>6s} {'claims':>7s} {'setup+gather':>12s}" + (f" {'before':>7s}" if args.before else "")
    )
    model = Overheads(**{f.name: overhead[f.name] for f in fields(Overheads)})
    before = replace(model, spread_setup_s=0.0, spread_gather_s=0.0, **BEFORE)
    for name, case in cases.items():
        seconds = dict(zip((t.key for t in case.tasks), case.seconds))
        for ranks in args.ranks:
            r = replay(case.tasks, seconds, ranks, model)
            old = f" {replay(case.tasks, seconds, ranks, before)['efficiency']:7.3f}" if args.before else ""
            print(
                f"{name:22s} {len(case.tasks):7d} {ranks:6d} {r['chunks']:7d} {r['makespan_s']:9.2f} {r['efficiency']:10.3f}"
                f" {r['tail']:6.3f} {r['claims']:7.4f} {r['setup_gather']:12.3f}{old}",
                flush=True,
            )


if __name__ == "__main__":
    harness.entry(main)
