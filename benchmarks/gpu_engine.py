"""The GPU engine through hpcontact itself (issue 41's table, re-measured): run on a machine with a GPU.

In one run, on one machine, float64, nu = 0.3, tol 1e-8 (the default), FFTW and BLAS on one thread:

- ``solve``: the circle, normal stiffness, per solve — ``hpcontact.solve(device="cpu")`` (one CPU
  core) against ``device="gpu"``, each the best of ``--repeat`` solves after one warm-up solve
  (cold first solve reported too), at ``--n`` (default 1024; the issue asks ≥ 50×), with
  K_zz, iterations and the relative difference of K_zz between the devices;
- ``large``: the GPU alone at ``--large`` (default 4096; the issue asks ≤ 1 s per solve);
- ``accuracy``: square, triangle and hexagon at ``--accuracy`` (default 1e-6; nu 0.3 and 0.5),
  each one ``hpcontact.solve(..., accuracy=..., device="gpu")`` (the issue asks ≤ 5 s each), with
  its grids, whether the request was met, the estimate and what stopped it (the grids stop where
  the estimator's calibration ends, n = 1024, on either device): its grids are coverage-weighted
  cells (``discretizations/boundary_cells.py``) iterating on the device, one grid at a time;
- ``accuracy_batch``: the same six scenes as one GPU rank's batch: their grid sequences refined level
  by level together (``accuracy.default_solve_batch``, as ``sweep.work.batches`` runs a batch of
  accuracy tasks), the batch's seconds and per scene, each scene's grids and stop, and the largest
  relative difference of its stiffnesses from its ``accuracy`` row (the scene alone);
- ``main``: the main job's task time (``--main-job``, default jobs/demo.toml, at its accuracy):
  every ``--main-every``-th of its tasks (in enumeration order) solved on the GPU as a GPU rank
  solves its claim (``batches.plan_batches`` sized by the device's free memory, ``run_batch``: the
  grid sequences of one group refined together), then each alone by the sweep's task function on
  the GPU, then on one CPU core (``main_job_table``: the order errs against the GPU's batches), each
  task's seconds and the sums (the issue asks a GPU rank ≤ 1/30 of one core: judged on the batched
  pass), and each task's largest relative difference of its stiffnesses between the devices;
- ``iteration``: one operator application + one preconditioner application (what a PCG iteration
  costs beyond a few vector updates) on both devices for ``--iteration-n`` (default 64 … 2048);
- ``slip``: a slip scene (two iron bodies, partial slip, n = 32) on one CPU core and on the GPU:
  seconds and the largest relative difference of its stiffnesses and forces (issue 41: ≤ 1e-12);
- memory: CuPy's memory pool after each GPU measurement (bytes held), as memory per device.

``done_when`` sets each of the issue's speed points the run measured against its bound (None where
the run measured it at other sizes than the issue's). The agreement points (≤ 1e-12 against the
CPU on the test suite's scenes) are tests/gpu (``python -m pytest -q tests/gpu``); batched
scenes per scene-iteration are benchmarks/batched_scenes.py ``--device cpu gpu``.

GPU times are taken after ``cupy.cuda.Device().synchronize()``; CPU times with ``time.perf_counter``.
Nothing is estimated: a measurement that fails is reported as failed. With ``--json`` the file is
written after each table, so a run cut short keeps what it measured.

    source .device/on-device.sh && python benchmarks/gpu_engine.py --json $OUT/gpu_engine.json
    python benchmarks/gpu_engine.py --n 256 --large 1024 --iteration-n 64 256 --repeat 1   # quick

tests/gpu/test_gpu_engine_script.py runs it on a stand-in GPU (array-api-strict's arrays, a stub
CuPy's device calls) at small sizes, so it cannot fail on the device for want of being run.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(variable, "1")

import numpy as np  # noqa: E402

import hpcontact  # noqa: E402
from hpcontact.errors import InputError  # noqa: E402
from hpcontact.numerics.backend import array_namespace, gpu_description, to_device  # noqa: E402


def _timed(function, synchronize) -> tuple[float, object]:
    synchronize()
    start = time.perf_counter()
    value = function()
    synchronize()
    return time.perf_counter() - start, value


def _pool_bytes(cupy) -> int:
    return int(cupy.get_default_memory_pool().total_bytes())


def solve_table(n: int, repeat: int, cupy) -> dict:
    """The circle's normal stiffness at ``n`` on one CPU core and on the GPU."""
    row: dict = {"n": n}
    for device, sync in (("cpu", lambda: None), ("gpu", cupy.cuda.Device().synchronize)):

        def one(d=device):
            return hpcontact.solve(shape="circle", n=n, quantities="normal", device=d)

        cold, record = _timed(one, sync)
        times = [_timed(one, sync)[0] for _ in range(repeat)]
        row[device] = {"cold_s": cold, "best_s": min(times), "K_zz": record["K_zz"], "iterations": record["iterations"]}
    row["speedup"] = row["cpu"]["best_s"] / row["gpu"]["best_s"]
    row["K_zz_relative_difference"] = abs(row["gpu"]["K_zz"] - row["cpu"]["K_zz"]) / abs(row["cpu"]["K_zz"])
    row["gpu_pool_bytes"] = _pool_bytes(cupy)
    return row


def large_table(n: int, repeat: int, cupy) -> dict:
    sync = cupy.cuda.Device().synchronize
    cold, record = _timed(lambda: hpcontact.solve(shape="circle", n=n, quantities="normal", device="gpu"), sync)
    best = min(
        _timed(lambda: hpcontact.solve(shape="circle", n=n, quantities="normal", device="gpu"), sync)[0]
        for _ in range(repeat)
    )
    return {
        "n": n,
        "cold_s": cold,
        "best_s": best,
        "K_zz": record["K_zz"],
        "iterations": record["iterations"],
        "gpu_pool_bytes": _pool_bytes(cupy),
    }


def iteration_table(sizes: list[int], repeat: int, cupy) -> list[dict]:
    """Operator + preconditioner application per device (the cost of a PCG iteration's transforms)."""
    from hpcontact.geometry import Grid
    from hpcontact.kernels.engine import Engine
    from hpcontact.materials.isotropic import Isotropic
    from hpcontact.numerics.preconditioner import FourierPreconditioner

    rows = []
    for n in sizes:
        grid, row = Grid(n, n, 2.0 / n, 2.0 / n), {"n": n}
        for device, xp, sync in (("cpu", np, lambda: None), ("gpu", cupy, cupy.cuda.Device().synchronize)):
            engine = Engine(Isotropic(nu=0.3), grid, ("zz",), xp=xp)
            op = engine.operator("z")
            pre = FourierPreconditioner(grid, engine.green_function("H"), "z", xp=xp)
            t = to_device(np.random.default_rng(0).standard_normal((1, n, n)), xp)
            _timed(lambda op=op, pre=pre, t=t: pre.apply(op.apply(t)), sync)  # plans, caches
            row[f"{device}_ms"] = 1e3 * min(
                _timed(lambda op=op, pre=pre, t=t: pre.apply(op.apply(t)), sync)[0] for _ in range(repeat)
            )
        row["ratio"] = row["cpu_ms"] / row["gpu_ms"]
        rows.append(row)
        print(f"  iteration n={n}: cpu {row['cpu_ms']:.2f} ms, gpu {row['gpu_ms']:.3f} ms", file=sys.stderr, flush=True)
    return rows


#: The accuracy table's scenes: square, triangle, hexagon; nu 0.3 and 0.5 (issue 41's done-when).
ACCURACY_SHAPES = (("rectangle", {"aspect": 1.0}), ("polygon", {"sides": 3}), ("polygon", {"sides": 6}))
ACCURACY_NUS = (0.3, 0.5)


def accuracy_params(accuracy: float) -> list[dict]:
    """The fields of the accuracy table's scenes at ``accuracy``."""
    return [
        {"shape": shape, "nu": nu, "quantities": "tangential,normal", "accuracy": accuracy, **extra}
        for shape, extra in ACCURACY_SHAPES
        for nu in ACCURACY_NUS
    ]


def accuracy_table(accuracy: float, cupy) -> list[dict]:
    rows = []
    sync = cupy.cuda.Device().synchronize
    for params in accuracy_params(accuracy):
        try:
            seconds, record = _timed(lambda p=params: hpcontact.solve(**p, device="gpu"), sync)
            reached = {k: record.get(k) for k in ("nx", "grids", "accuracy_met", "estimated_error", "stopped_by")}
            rows.append({**params, "seconds": seconds, **reached, "gpu_pool_bytes": _pool_bytes(cupy)})
            rows[-1]["record"] = {k: v for k, v in record.items() if k.startswith("K_") and isinstance(v, float)}
        except Exception as exc:  # reported, not hidden: the table says which failed and why
            rows.append({**params, "error": f"{type(exc).__name__}: {exc}"})
        print(f"  accuracy {rows[-1]}", file=sys.stderr, flush=True)
    return rows


def accuracy_batch_table(accuracy: float, cupy, alone: list[dict] | None) -> dict:
    """The accuracy table's scenes on the GPU as one batch (``accuracy.default_solve_batch``):
    seconds in all and per scene, each scene's grids, stop and estimate, and the largest relative
    difference of its stiffnesses from ``alone`` (the ``accuracy`` table's rows, when it ran)."""
    from hpcontact.accuracy import default_solve_batch
    from hpcontact.scene import Scene

    params = accuracy_params(accuracy)
    scenes = [Scene.from_params({**p, "device": "gpu"}) for p in params]
    seconds, results = _timed(lambda: default_solve_batch(scenes), cupy.cuda.Device().synchronize)
    rows = []
    for index, (p, result) in enumerate(zip(params, results)):
        if isinstance(result, Exception):
            rows.append({**p, "error": f"{type(result).__name__}: {result}"})
            continue
        row = {**p, **{k: result.get(k) for k in ("nx", "grids", "accuracy_met", "estimated_error", "stopped_by")}}
        single = alone[index] if alone else None
        if single is not None and "record" in single:
            row["relative_difference_from_alone"] = _largest_difference(single["record"], result)
        rows.append(row)
    return {
        "seconds": seconds,
        "seconds_per_scene": seconds / len(scenes),
        "failed": sum("error" in r for r in rows),
        "gpu_pool_bytes": _pool_bytes(cupy),
        "rows": rows,
    }


def _largest_difference(cpu: dict, gpu: dict) -> float:
    """The largest difference of the records' stiffnesses (K_ entries) relative to the largest."""
    names = [k for k, v in cpu.items() if k.startswith("K_") and isinstance(v, float)]
    scale = max(abs(cpu[k]) for k in names)
    return max(abs(gpu[k] - cpu[k]) for k in names) / scale


def main_job_table(spec_path: str, every: int, cupy) -> dict:
    """Every ``every``-th task of the sweep ``spec_path`` on the GPU as a GPU rank solves a claim
    (``plan_batches`` by the device's free memory, ``run_batch``), then each alone on the GPU, then
    on one CPU core: each pass over the tasks as a rank's (caches built by its first tasks serve the
    later), the batched GPU pass first and cold, the others on the caches it left (kernels, exact
    cells): the ratio of the batched pass errs against the GPU."""
    from hpcontact.accuracy import task_function
    from hpcontact.sweep.data.journal import OK
    from hpcontact.sweep.run.rounds import run_task
    from hpcontact.sweep.space.parse import load_spec
    from hpcontact.sweep.work.batches import plan_batches, run_batch
    from hpcontact.sweep.work.tasks import Task, enumerate_part, points

    spec = load_spec(spec_path, check_scenes=False)
    tasks = [Task(*row) for row in enumerate_part(spec, 0, points(spec)).rows][::every]
    solve = task_function(spec.kind)
    on_gpu = [task._replace(params={**task.params, "device": "gpu"}) for task in tasks]
    sync = cupy.cuda.Device().synchronize

    def gpu_rank() -> list:
        entries = []
        for batch in plan_batches(on_gpu, solve):
            entries += run_batch(batch, 0, lambda task: run_task(solve, task, 0))
        return entries

    batched_s, entries = _timed(gpu_rank, sync)
    batch_sizes = [len(b) for b in plan_batches(on_gpu, solve)]
    rows: list[dict] = [{"key": task.key} for task in tasks]
    records: list[dict] = [{} for _ in tasks]
    for row, record, entry in zip(rows, records, entries):
        if entry.status != OK:
            row["error"] = f"gpu batch: {entry.status}: {entry.message}"
        record["gpu_batched"] = entry.record
    for device, sync_ in (("gpu", sync), ("cpu", lambda: None)):
        for task, row, record in zip(tasks, rows, records):
            if "error" in row:
                continue
            try:
                row[f"{device}_s"], record[device] = _timed(lambda t=task: solve({**t.params, "device": device}), sync_)
            except Exception as exc:  # reported, not hidden
                row["error"] = f"{device}: {type(exc).__name__}: {exc}"
    for row, record in zip(rows, records):
        if "error" not in row:
            row["relative_difference"] = _largest_difference(record["cpu"], record["gpu"])
            row["batched_relative_difference"] = _largest_difference(record["cpu"], record["gpu_batched"])
    timed = [r for r in rows if "error" not in r]
    cpu_s, gpu_s = sum(r["cpu_s"] for r in timed), sum(r["gpu_s"] for r in timed)
    return {
        "spec": spec_path,
        "every": every,
        "tasks": len(tasks),
        "failed": len(rows) - len(timed),
        "batch_sizes": batch_sizes,
        "gpu_batched_s": batched_s,
        "cpu_s": cpu_s,
        "gpu_s": gpu_s,
        "gpu_batched_over_cpu": batched_s / cpu_s if cpu_s > 0.0 and len(timed) == len(rows) else None,
        "gpu_over_cpu": gpu_s / cpu_s if cpu_s > 0.0 else None,
        "largest_relative_difference": max(
            (max(r["relative_difference"], r["batched_relative_difference"]) for r in timed), default=None
        ),
        "gpu_pool_bytes": _pool_bytes(cupy),
        "rows": rows,
    }


#: A slip scene of the test suite's kind (tests/problems/slip/test_slip_device.py): two iron bodies,
#: partial slip under a tangential load half of mu P, one load step.
SLIP_SCENE = {
    "quantities": "slip",
    "radius": 8e-3,
    "load": 100.0,
    "mu": 0.3,
    "q_ratio": 0.5,
    "n": 32,
    "steps": 1,
    "tol": 1e-14,
    "material": "Fe",
    "material2": "Fe",
}
SLIP_KEYS = ("tangential_force", "tangential_displacement", "tangential_stiffness", "stick_area_stiffness")


def slip_table(cupy) -> dict:
    """A slip scene (``SLIP_SCENE``) on one CPU core and on the GPU: seconds and the largest relative
    difference of its stiffnesses and forces between the devices (issue 41: ≤ 1e-12)."""
    cpu_s, cpu = _timed(lambda: hpcontact.solve(**SLIP_SCENE), lambda: None)
    gpu_s, gpu = _timed(lambda: hpcontact.solve(**SLIP_SCENE, device="gpu"), cupy.cuda.Device().synchronize)
    difference = max(abs(gpu[k] / cpu[k] - 1.0) for k in SLIP_KEYS)
    return {
        **{k: v for k, v in SLIP_SCENE.items() if k in ("n", "material", "q_ratio")},
        "cpu_s": cpu_s,
        "gpu_s": gpu_s,
        "largest_relative_difference": difference,
        "same_stick_area": gpu["stick_area"] == cpu["stick_area"],
        "pool_bytes": _pool_bytes(cupy),
    }


def done_when(results: dict, args: argparse.Namespace) -> dict:
    """The issue's speed points this run measured, each against its bound (None: not at its size)."""
    solve, large, accuracy, main = (results.get(k) for k in ("solve", "large", "accuracy", "main"))
    return {
        "n1024_circle_speedup_at_least_50": None if not solve or args.n != 1024 else solve["speedup"] >= 50.0,
        "n4096_at_most_1_s": None if not large or args.large != 4096 else large["best_s"] <= 1.0,
        "accuracy_1e-6_shapes_at_most_5_s_each": (
            None
            if not accuracy or args.accuracy != 1e-6
            else all("error" not in r and r["accuracy_met"] and r["seconds"] <= 5.0 for r in accuracy)
        ),
        "main_job_gpu_at_most_1_30_of_one_core": (
            None
            if not main or main["gpu_batched_over_cpu"] is None or main["failed"]
            else main["gpu_batched_over_cpu"] <= 1.0 / 30.0
        ),
    }


TABLES = ("solve", "large", "accuracy", "accuracy_batch", "main", "iteration", "slip")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--tables", nargs="+", choices=TABLES, default=list(TABLES), help="default: all, in this order")
    p.add_argument("--n", type=int, default=1024, help="the CPU-against-GPU solve (default 1024)")
    p.add_argument("--large", type=int, default=4096, help="the GPU-only solve (default 4096)")
    p.add_argument("--iteration-n", type=int, nargs="+", default=[64, 128, 256, 512, 1024, 2048])
    p.add_argument("--accuracy", type=float, default=1e-6)
    p.add_argument("--main-job", default="jobs/demo.toml", help="the sweep of the main table (default jobs/demo.toml)")
    p.add_argument("--main-every", type=int, default=8, help="every k-th of its tasks (default 8)")
    p.add_argument("--repeat", type=int, default=3, help="timings per measurement; the best is kept (default 3)")
    p.add_argument("--json", help="write the results to this file (after each table)")
    args = p.parse_args(argv)
    try:
        cupy = array_namespace("gpu")
    except InputError as exc:  # no GPU here: one line saying which is missing
        print(f"gpu_engine: {exc}", file=sys.stderr)
        return 2
    machine = {"python": platform.python_version(), "cpu": platform.processor(), "devices": gpu_description()}
    print(json.dumps(machine), file=sys.stderr, flush=True)
    results: dict = {"machine": machine}
    measure = {
        "solve": lambda: solve_table(args.n, args.repeat, cupy),
        "large": lambda: large_table(args.large, args.repeat, cupy),
        "accuracy": lambda: accuracy_table(args.accuracy, cupy),
        "accuracy_batch": lambda: accuracy_batch_table(args.accuracy, cupy, results.get("accuracy")),
        "main": lambda: main_job_table(args.main_job, args.main_every, cupy),
        "iteration": lambda: iteration_table(args.iteration_n, args.repeat, cupy),
        "slip": lambda: slip_table(cupy),
    }
    for table in [t for t in TABLES if t in args.tables]:
        results[table] = measure[table]()
        results["done_when"] = done_when(results, args)
        print(f"  {table} {json.dumps(results[table])[:2000]}", file=sys.stderr, flush=True)
        if args.json:
            with open(args.json, "w", encoding="utf-8") as fh:
                json.dump(results, fh, indent=1)
    print(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
