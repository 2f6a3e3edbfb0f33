"""Do the dry-run's estimates hold for tasks that ask for an accuracy? Per task and in total.

    python benchmarks/accuracy_cost_estimates.py [--sweeps ellipses demo exact square] [--no-memory] [--json PATH]
    python benchmarks/accuracy_cost_estimates.py --grid-counts     # where the sequences stop
    python benchmarks/accuracy_cost_estimates.py --strips          # strip cells' seconds and their fit

Four small sweeps, their specs below (``SWEEPS``), costed as ``hpcontact run SPEC --dry-run``
costs them (``tasks.enumerate_tasks``, ``cost``: the grids ``accuracy.solve_to_accuracy`` is
predicted to solve, ``cost.grids.accuracy_plan``) and run with the sweep's task function:

* ``ellipses``: ellipses b/a = 0.3 and 0.01 × A = 1 (isotropic) and 3 (cubic, ψ = 60°), nu = 0.3,
  accuracy 1e-4: each one exact cell (``galin``: ``accuracy.exact_solve``, no grid; estimated
  as one task term, measured as the whole task, a crystal's kernel build included);
* ``demo``: the scene types of jobs/demo.toml (ellipse and rectangle at b/a = 1, 1e-2, 1e-4,
  1e-8, a triangle, a 5-lobed star; isotropic and cubic A = 2, ψ = 20°), nu = 0.25, tol 1e-10,
  accuracy 1e-3: exact cells (the ellipses), coverage-weighted cells, strips (the rectangle 1e-8);
* ``exact``: 36 crystal ellipses (b/a 0.5, 1e-3 × nu 0.05, 0.45 × A 0.5, 2, 3 × ψ 0°, 35.26°,
  70°) at accuracy 1e-6 on their exact cell, in an order where no task finds its material's
  kernel cached (18 materials, the cache keeps 8): what the scenes of
  ``jobs/adaptive_orientation_map.toml`` cost, the kernel's build (``cost.rates.Rate.exact_s``)
  nearly all of it;
* ``square``: the tasks of the most grids and the largest arrays a sweep's ``auto`` now
  solves: a square at accuracy 1e-5 and 1e-6 (coverage-weighted cells, six grids to
  1024 × 1024 predicted, the plan's end), nu = 0 and 0.5 (it replaced the circle's singular
  cells, which ``auto`` no longer takes; ~5.5 min with memory).

In fresh child processes, one thread each:

* **time**: the sweep's tasks in sweep order with the real task function under the sweep's BLAS
  limit (``numerics.blas.limited_blas``), each task's CPU seconds (``time.process_time``) and
  the CPU seconds of each grid it solved; the cost model calibrated in that process just before
  and after the tasks (``cost.calibration.calibrate``, under the same load: ``benchmarks/cost_estimates.py``
  says why), the mean of the two estimates per task against the measured seconds;
* **memory**: each task alone after a run's imports (``cost.rates.base_memory_bytes``), its
  process's peak resident set against the estimate (that base + ``cost.rates.task_array_bytes``).

The table: per task the boundary cells and the grids predicted and solved, estimated and measured
CPU seconds and peak MiB with their ratios (estimate / measured); per sweep and overall the
total seconds and the largest peak (the dry run's ``estimated_peak_memory_bytes`` against the
largest measured).
``--json`` writes every number, the per-grid seconds included.

``--grid-counts``: the evidence of ``cost.grids.predicted_grid_count``. Each case of ``COUNT_CASES``
(shapes that take a sequence of grids: not ellipses or circles, whose exact cell takes none) is solved once at a tight request (a fresh process; ``solve_to_accuracy``, strategy auto, not
strict) and ``accuracy.refine`` replayed on its grids for the requests 1e-3 … 1e-6 whose boundary
cells are the same (``accuracy.first_grid``): the grids each request takes, against the
prediction, and where it stopped.

``--strips``: CPU seconds of one grid of strip cells (``boundary_cells.covered_solve``, strategy
strip, warm, BLAS limited) for rectangles b/a 1e-6 … 1e-12 on 32 … 1024 strips (the only strips
``auto`` takes; fewer where a grid took over 30 s), against ``cost.task_cost.strip_units`` at this
process's calibrated ``strip_s``, and the two constants of ``cost.task_cost.strip_units`` fitted anew to
these seconds (least squares on the log of model over measured).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

import harness

SWEEPS = {
    "ellipses": """
[sweep]
title = "accuracy cost: ellipses at 1e-4"
output = "results/accuracy_cost_estimates_ellipses.nc"
[scene]
shape = "ellipse"
quantities = ["tangential", "normal"]
nu = 0.3
orientation = 60.0
[numerics]
accuracy = 1e-4
[axes]
aspect = [0.3, 0.01]
anisotropy = [1.0, 3.0]
""",
    "demo": """
[sweep]
title = "accuracy cost: the demo's scene types at 1e-3"
output = "results/accuracy_cost_estimates_demo.nc"
[scene]
quantities = ["tangential", "normal"]
nu = 0.25
orientation = 20.0
[numerics]
tol = 1e-10
accuracy = 1e-3
[axes]
shape = [
    "ellipse",
    "rectangle",
    { label = "triangle", shape = "polygon", sides = 3 },
    { label = "star", shape = "star", sides = 5, amplitude = 0.3 },
]
aspect = [1.0, 1e-2, 1e-4, 1e-8]
anisotropy = [1.0, 2.0]
""",
    "exact": """
[sweep]
title = "accuracy cost: crystal ellipses on their exact cell, each kernel built cold (as in an adaptive map)"
output = "results/accuracy_cost_estimates_exact.nc"
[scene]
shape = "ellipse"
quantities = ["tangential", "normal"]
[numerics]
accuracy = 1e-6
[axes]
aspect = [0.5, 1e-3]
nu = [0.05, 0.45]
anisotropy = [0.5, 2.0, 3.0]
orientation = [0.0, 35.26438968275465, 70.0]
""",
    "square": """
[sweep]
title = "accuracy cost: a square at 1e-5 and 1e-6 (six grids to 1024 x 1024 predicted)"
output = "results/accuracy_cost_estimates_square.nc"
[scene]
shape = "rectangle"
aspect = 1.0
quantities = ["tangential", "normal"]
[axes]
accuracy = [1e-5, 1e-6]
nu = [0.0, 0.5]
""",
}


def load_tasks(name: str):
    """The tasks of the sweep ``name`` as the dry run makes them."""
    from hpcontact.sweep.space.parse import load_spec
    from hpcontact.sweep.work.tasks import enumerate_tasks

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{name}.toml"
        path.write_text(SWEEPS[name], encoding="utf-8")
        spec = load_spec(path)
    return spec, enumerate_tasks(spec)[0]


def describe(params) -> str:
    """A short name of a task's scene."""
    shape = params.get("shape", "circle")
    what = {"polygon": f"polygon {params.get('sides')}", "star": f"star {params.get('sides')}", "circle": "circle"}.get(
        shape, f"{shape} {params.get('aspect', 1.0):g}"
    )
    a = float(params.get("anisotropy", 1.0))
    material = "iso" if a == 1.0 else f"A {a:g}"
    return f"{what}, {material}, nu {params.get('nu', 0.3):g}, {params.get('accuracy'):g}"


def measure_time(name: str) -> dict:
    """In this process: calibrate, run the sweep's tasks (CPU seconds per task and per grid),
    calibrate again; the estimates of both calibrations per task."""
    from hpcontact import accuracy
    from hpcontact.numerics.blas import limited_blas
    from hpcontact.sweep.cost.calibration import calibrate
    from hpcontact.sweep.cost.grids import accuracy_plan

    spec, tasks = load_tasks(name)
    before = calibrate()
    function = accuracy.task_function(spec.kind)
    solve = accuracy.covered_solve
    grids: list[dict] = []

    def timed_grid(scene, strategy):  # each grid's CPU seconds, as solve_to_accuracy calls it
        started = time.process_time()
        record = solve(scene, strategy)
        grids.append({"n": scene.n, "n_across": scene.n_across, "cpu_s": time.process_time() - started})
        return record

    accuracy.covered_solve = timed_grid
    rows = []
    try:
        with limited_blas():
            for task in tasks:
                grids.clear()
                started, wall = time.process_time(), time.perf_counter()
                try:
                    record = function(dict(task.params))
                except Exception as exc:  # noqa: BLE001 - a failed task still took its time, as in a sweep
                    print(f"{describe(task.params)}: {type(exc).__name__}: {exc}", file=sys.stderr)
                    record = {}
                plan = accuracy_plan(task.params)
                rows.append(
                    {
                        "task": describe(task.params),
                        "params": dict(task.params),
                        "boundary": plan.strategy,
                        "predicted": [n for n, _ in plan.grids],  # an exact cell: [1], as its record's grids
                        "solved": [g["n"] for g in grids] or list(record.get("grids") or []),
                        "stopped_by": record.get("stopped_by"),
                        "estimated_error": record.get("estimated_error"),
                        "measured_s": time.process_time() - started,
                        "wall_s": time.perf_counter() - wall,
                        "grids": list(grids),
                    }
                )
    finally:
        accuracy.covered_solve = solve
    after = calibrate()
    for row, task in zip(rows, tasks):
        estimates = [c.task_seconds(task.params, task.cost) for c in (before, after)]
        row["estimated_s"] = 0.5 * (estimates[0] + estimates[1])
        row["drift"] = estimates[1] / estimates[0]
    rates = [{kind: asdict(rate) for kind, rate in c.rates.items()} for c in (before, after)]
    return {"sweep": name, "rows": rows, "calibration_s": after.seconds, "rates": rates}


def measure_memory(name: str, index: int) -> dict:
    """In this process: task ``index`` of the sweep alone after a run's imports; estimated and
    measured peak resident bytes."""
    from hpcontact.accuracy import task_function
    from hpcontact.numerics.blas import limited_blas
    from hpcontact.numerics.memory import resident_bytes
    from hpcontact.sweep.cost.rates import base_memory_bytes, task_array_bytes

    spec, tasks = load_tasks(name)
    base = base_memory_bytes()
    task = tasks[index]
    with limited_blas():
        task_function(spec.kind)(dict(task.params))
    return {
        "estimated_peak_bytes": base + task_array_bytes(task.params),
        "measured_peak_bytes": resident_bytes(),
    }


BASE = {"nu": 0.25, "quantities": ["tangential", "normal"], "tol": 1e-10}
CUBIC = {"anisotropy": 2.0, "orientation": 20.0}
# (scene, tight request): every request above it is replayed on the same grids
# (scene, tight request): every request above it is replayed on the same grids. Shapes that take
# grids only: an ellipse or circle takes its one exact cell (galin) at every request.
COUNT_CASES = [
    ({**BASE, "shape": "rectangle", "aspect": 1.0}, 1e-7),
    ({**BASE, "shape": "rectangle", "aspect": 1.0, "nu": 0.0}, 1e-7),
    ({**BASE, "shape": "rectangle", "aspect": 0.3}, 1e-7),
    ({**BASE, "shape": "rectangle", "aspect": 1e-2}, 1e-7),
    ({**BASE, "shape": "rectangle", "aspect": 1e-4}, 1e-4),
    ({**BASE, "shape": "polygon", "sides": 3}, 1e-7),
    ({**BASE, "shape": "star", "sides": 5, "amplitude": 0.3}, 1e-7),
    ({**BASE, "shape": "rectangle", "aspect": 1.0, **CUBIC}, 1e-7),
    ({**BASE, "shape": "rectangle", "aspect": 0.3, **CUBIC}, 1e-5),
    ({**BASE, "shape": "rectangle", "aspect": 0.3, "nu": 0.3, "anisotropy": 3.0, "orientation": 60.0}, 1e-7),
    ({**BASE, "shape": "rectangle", "aspect": 1e-8, **CUBIC}, 1e-7),
    ({**BASE, "shape": "polygon", "sides": 3, **CUBIC}, 1e-4),
    ({**BASE, "shape": "rectangle", "aspect": 1e-6}, 1e-9),
    ({**BASE, "shape": "rectangle", "aspect": 1e-8}, 1e-8),
]
COUNT_REQUESTS = (1e-3, 1e-4, 1e-5, 1e-6)
STRIP_CASES = [("rectangle", a, (32, 64, 128, 256, 512, 1024)) for a in (1e-6, 1e-8, 1e-12)]


def measure_counts(params: dict, tight: float) -> dict:
    """In this process: ``params`` solved at ``tight``, then ``accuracy.refine`` replayed on its
    grids for each of ``COUNT_REQUESTS`` with the same boundary cells: grids taken, stop, estimate."""
    from hpcontact import accuracy
    from hpcontact.discretizations import strip_cells
    from hpcontact.numerics.blas import limited_blas
    from hpcontact.scene import Scene

    levels = []
    solve = accuracy.covered_solve
    accuracy.covered_solve = lambda scene, strategy: levels.append(solve(scene, strategy)) or levels[-1]
    with limited_blas():
        record = accuracy.solve_to_accuracy(
            Scene.from_params({**params, "accuracy": tight}), tight, strategy="auto", strict=False
        )
    accuracy.covered_solve = solve
    strategy = record["boundary"]
    model = strip_cells.model_error(Scene.from_params(params).shape) if strategy == "strip" else 0.0
    grids = list(zip(record["grids"], record["grids_across"]))
    replays = {}
    for request in COUNT_REQUESTS:
        first = accuracy.first_grid(Scene.from_params({**params, "accuracy": request}), accuracy=request)
        if request < tight or first[0] != strategy or first[1] != grids[0][0]:
            continue
        found = iter(levels)
        done = accuracy.refine(
            grids[:4] if model >= request else grids, lambda n, na: next(found), request, model_error=model
        )
        stopped = done.stopped_by or (record["stopped_by"] if len(done.levels) == len(grids) else "model")
        replays[f"{request:g}"] = [len(done.levels), stopped, max(done.relative.values())]
    return {"strategy": strategy, "grids": record["grids"], "stopped_by": record["stopped_by"], "replays": replays}


def grid_counts() -> None:
    """``--grid-counts``: the table of grids taken against ``cost.grids.predicted_grid_count``."""
    from hpcontact.accuracy import first_grid, plan_grids
    from hpcontact.scene import Scene
    from hpcontact.sweep.cost.grids import predicted_grid_count

    print(f"{'scene':44s} {'cells':8s} " + " ".join(f"{f'{r:g}':>22s}" for r in COUNT_REQUESTS))
    for params, tight in COUNT_CASES:
        child = harness.call_in_child(__file__, "measure_counts", params, tight)
        label = describe({**params, "accuracy": tight})
        if child.error:
            print(f"{label:44s} {child.error}", flush=True)
            continue
        r = child.result
        cells = []
        for request in COUNT_REQUESTS:
            got = r["replays"].get(f"{request:g}")
            if got is None:
                cells.append(f"{'-':>22s}")
                continue
            scene = Scene.from_params({**params, "accuracy": request})
            strategy, n0, na0 = first_grid(scene, accuracy=request)
            planned = len(plan_grids(scene, n0, na0, 2**22, math.inf, strategy).grids)
            predicted = predicted_grid_count(strategy, request, planned)
            cells.append(f"{f'{got[0]} ({predicted}) {got[1][:5]} {got[2]:.2g}':>22s}")
        print(f"{label:44s} {r['strategy']:8s} " + " ".join(cells), flush=True)
    print(
        "each: grids taken (predicted) what stopped it, estimate; -: another boundary cells' or first grid's request,"
        " or beyond the run"
    )


def measure_strips(cap_s: float = 30.0) -> dict:
    """In this process: CPU seconds of one strip grid per case of ``STRIP_CASES`` (warm, BLAS
    limited), the calibrated ``strip_s`` and each grid's ``cost.task_cost.strip_units``."""
    from hpcontact.discretizations.boundary_cells import covered_solve
    from hpcontact.numerics.blas import limited_blas
    from hpcontact.scene import Scene
    from hpcontact.sweep.cost.calibration import calibrate
    from hpcontact.sweep.cost.engine import strip_pairs
    from hpcontact.sweep.cost.task_cost import strip_units

    rate = calibrate().rates["contact"]
    rows = []
    with limited_blas():
        for shape, aspect, ns in STRIP_CASES:
            for n in ns:
                params = {**BASE, "shape": shape, "aspect": aspect, "n": n, "n_across": 1}
                scene = Scene.from_params(params)
                if not rows:
                    covered_solve(scene, "strip")  # tables built once per process, as in a sweep
                started = time.process_time()
                covered_solve(scene, "strip")
                seconds = time.process_time() - started
                near, far = strip_pairs(shape, aspect, n)
                rows.append(
                    {
                        "shape": shape,
                        "aspect": aspect,
                        "n": n,
                        "cpu_s": seconds,
                        "near": near,
                        "far": far,
                        "estimated_s": rate.strip_s * strip_units(params) + rate.task_s,
                    }
                )
                if seconds > cap_s:
                    break
    return {"rows": rows, "strip_s": rate.strip_s}


def strips() -> None:
    """``--strips``: strip grids' seconds against the model, and the model's constants fitted anew."""
    import numpy as np
    from scipy.optimize import least_squares

    from hpcontact.sweep.work import tasks

    result = harness.call_in_child(__file__, "measure_strips", check=True).result
    rows = result["rows"]
    print(
        f"strip_s {result['strip_s']:.3g} s per strip unit\n{'shape':10s} {'b/a':>7s} {'n':>5s} {'meas. s':>8s} {'est. s':>7s} {'ratio':>5s}"
    )
    for r in rows:
        print(
            f"{r['shape']:10s} {r['aspect']:7.0e} {r['n']:5d} {r['cpu_s']:8.3f} {r['estimated_s']:7.3f} {ratio(r['estimated_s'], r['cpu_s']):5.2f}"
        )

    def model(x, r):
        per_strip, far = np.exp(x)
        return per_strip * r["n"] + far * r["far"]

    fit = least_squares(lambda x: [math.log(model(x, r) / r["cpu_s"]) for r in rows], np.log([3e-4, 2e-6]))
    names = ("STRIP_SECONDS_PER_STRIP", "STRIP_SECONDS_PER_FAR_PAIR")
    scale = result["strip_s"] / tasks.STRIP_UNIT_SECONDS  # this machine's seconds against the development machine's
    print("fitted (this machine's seconds / the calibrated strip_s in development-machine units):")
    for name, value in zip(names, np.exp(fit.x)):
        print(f"  {name} = {value / scale:.3g} (shipped {getattr(tasks, name):.3g})")


def ratio(a: float, b: float) -> float:
    return a / b if b > 0 else math.nan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sweeps", nargs="*", default=list(SWEEPS), choices=list(SWEEPS))
    parser.add_argument("--no-memory", action="store_true", help="time only (no process per task)")
    parser.add_argument("--json", help="write every number here")
    parser.add_argument("--grid-counts", action="store_true", help="only: where the sequences stop")
    parser.add_argument("--strips", action="store_true", help="only: strip cells' seconds and their fit")
    args = parser.parse_args()
    print(f"accuracy_cost_estimates: {harness.machine_line(1)}")
    if args.grid_counts or args.strips:
        if args.grid_counts:
            grid_counts()
        if args.strips:
            strips()
        return
    header = (
        f"{'task':38s} {'cells':8s} {'grids (predicted/solved)':>30s} {'est. s':>7s} {'meas. s':>7s} {'ratio':>5s} "
        f"{'est. MiB':>8s} {'meas. MiB':>9s} {'ratio':>5s}"
    )
    results, overall = [], {"estimated_s": 0.0, "measured_s": 0.0, "estimated_b": 0.0, "measured_b": 0.0}
    for name in args.sweeps:
        timing = harness.call_in_child(__file__, "measure_time", name, check=True).result
        print(f"\n{name} (calibration {timing['calibration_s']:.0f} s)\n{header}", flush=True)
        totals = {"estimated_s": 0.0, "measured_s": 0.0, "estimated_b": 0.0, "measured_b": 0.0}
        for i, row in enumerate(timing["rows"]):
            if not args.no_memory:
                row.update(harness.call_in_child(__file__, "measure_memory", name, i, check=True).result)
            est_b, meas_b = row.get("estimated_peak_bytes", math.nan), row.get("measured_peak_bytes", math.nan)
            last = row["solved"][-1] if row["solved"] else "-"
            grids = f"{len(row['predicted'])}/{len(row['solved'])} to {row['predicted'][-1]}/{last}"
            if row["boundary"] == "galin":
                grids = "one exact cell"
            print(
                f"{row['task']:38s} {row['boundary']:8s} {grids:>30s} {row['estimated_s']:7.3f} "
                f"{row['measured_s']:7.3f} {ratio(row['estimated_s'], row['measured_s']):5.2f} "
                f"{est_b / 2**20:8.0f} {meas_b / 2**20:9.0f} {ratio(est_b, meas_b):5.2f}",
                flush=True,
            )
            for target in (totals, overall):  # seconds add up; memory: the largest task's, as the dry run's peak
                target["estimated_s"] += row["estimated_s"]
                target["measured_s"] += row["measured_s"]
                target["estimated_b"] = max(target["estimated_b"], est_b)
                target["measured_b"] = max(target["measured_b"], meas_b)
        print(
            f"{'total ' + name:38s} {'':8s} {'':>30s} {totals['estimated_s']:7.3f} {totals['measured_s']:7.3f} "
            f"{ratio(totals['estimated_s'], totals['measured_s']):5.2f} {totals['estimated_b'] / 2**20:8.0f} "
            f"{totals['measured_b'] / 2**20:9.0f} {ratio(totals['estimated_b'], totals['measured_b']):5.2f}",
            flush=True,
        )
        results.append({**timing, "totals": totals})
    if len(results) > 1:
        print(
            f"\n{'total':38s} {'':8s} {'':>30s} {overall['estimated_s']:7.3f} {overall['measured_s']:7.3f} "
            f"{ratio(overall['estimated_s'], overall['measured_s']):5.2f} {overall['estimated_b'] / 2**20:8.0f} "
            f"{overall['measured_b'] / 2**20:9.0f} {ratio(overall['estimated_b'], overall['measured_b']):5.2f}"
        )
    if args.json:
        harness.write_json(args.json, {"sweeps": results, "totals": overall})


if __name__ == "__main__":
    harness.entry(main)
