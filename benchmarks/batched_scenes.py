"""Batched scenes against one scene at a time (issue 41 item 2): time per scene-iteration.

For each device, n and batch size B: B circles on one grid (nu spread over 0.05 … 0.45, so every
scene has its own kernel spectra and preconditioner symbol), ``--quantity`` (normal: one
component, the zz block; tangential: x and y), the project's preconditioned CG (``--plain``:
unpreconditioned) at tol ``--tol``:

- one at a time: each scene's ``conjugate_gradient`` on its own operator and preconditioner, as
  ``problems.contact._run_solve`` runs them (on the CPU: pyFFTW's ``ConvolutionOperator`` and
  pocketfft's preconditioner; on a GPU: ``ArrayConvolutionOperator`` on CuPy);
- batched: ``problems.contact.batch_system(...).solve()``, one ``conjugate_gradient_batch`` with
  one batched ``xp.fft`` per operator and preconditioner application (numpy's pocketfft on the CPU,
  cuFFT on a GPU).

Only the iterations are timed (operators, preconditioners and device copies are built before);
each time is the best of ``--repeat`` after one warm-up call (FFT plans made). Per scene-iteration
= time / Σ of the scenes' iterations: a batch's converged scenes still ride along until the last
one stops, and that cost is counted. ``ratio`` = batched / one at a time (> 1: batching is slower
per scene). The forces of the two paths are compared as a check (largest relative difference).

The CPU clock (``--clock cpu``, the default on the CPU: process time, robust on a shared machine;
FFTW, BLAS and numpy on one thread) or wall time (``--clock wall``; always on a GPU, after
``cupy.cuda.Device().synchronize()``). Nothing is estimated.

    .venv/bin/python benchmarks/batched_scenes.py --n 64 --batch 16                  # ~30 s on 2 cores
    .venv/bin/python benchmarks/batched_scenes.py                                      # n 64, 128; B 16, 64
    source .device/on-device.sh && python benchmarks/batched_scenes.py --device cpu gpu --clock wall \\
        --json $OUT/batched_scenes.json                                                # on a GPU machine
"""

from __future__ import annotations

import argparse
import os

for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "HPCONTACT_BLAS_THREADS"):
    os.environ.setdefault(variable, "1")

import harness  # noqa: E402
import numpy as np  # noqa: E402

from hpcontact.kernels.engine import Engine  # noqa: E402
from hpcontact.numerics.backend import array_namespace, to_device, to_host  # noqa: E402
from hpcontact.numerics.conjugate_gradient import conjugate_gradient  # noqa: E402
from hpcontact.plan import make_plan  # noqa: E402
from hpcontact.problems.contact import (  # noqa: E402
    _force,
    _preconditioner_of,
    batch_system,
    discretize,
    scene_namespace,
)
from hpcontact.scene import Scene  # noqa: E402


def scenes_on_one_grid(n: int, count: int, quantity: str, device: str, precondition: bool, tol: float) -> list:
    """(scene, engine, mask, solve) of ``count`` circles on one grid, nu from 0.05 to 0.45: the
    first solve of each scene's plan (normal_z or tangential_x)."""
    solves = []
    for nu in np.linspace(0.05, 0.45, count):
        scene = Scene.from_params(
            {
                "shape": "circle",
                "n": n,
                "nu": float(nu),
                "quantities": quantity,
                "device": device,
                "precondition": precondition,
                "tol": tol,
            }
        )
        grid, mask = discretize(scene)
        plan = make_plan(scene, mask, grid)
        engine = Engine(scene.material, grid, plan.kernels, xp=scene_namespace(scene))
        solves.append((scene, engine, mask, plan.solves[0]))
    return solves


def one_at_a_time(solves: list):
    """A function solving each scene by ``conjugate_gradient`` on its own operator (built here)."""
    systems = []
    for scene, engine, mask, s in solves:
        rhs = np.zeros((len(s.components),) + mask.shape)
        rhs[s.components.index(s.load)] = 1.0
        pre = _preconditioner_of(scene, engine, s)
        systems.append(
            (
                engine.operator(s.components, s.green).apply,
                to_device(rhs, engine.xp),
                to_device(mask, engine.xp),
                scene.tol,
                None if pre is None else pre.apply,
            )
        )
    return lambda: [conjugate_gradient(op, rhs, mask, tol=tol, precondition=pre) for op, rhs, mask, tol, pre in systems]


def measure(device: str, n: int, count: int, args, clock, synchronize) -> dict:
    solves = scenes_on_one_grid(n, count, args.quantity, device, not args.plain, args.tol)
    single = one_at_a_time(solves)
    system = batch_system(solves, [_preconditioner_of(scene, engine, s) for scene, engine, _, s in solves])

    def timed(function):
        def synchronized():
            value = function()
            synchronize()
            return value

        return harness.repeat_timing(synchronized, args.repeat, warmup=True, clock=clock)

    one, batched = timed(single), timed(system.solve)
    iterations_one = [solution.iterations for solution in one.value]
    iterations_batch = batched.value.iterations
    tractions = to_host(batched.value.traction)
    forces_batch = [_force(tractions[k], s.components, e.grid) for k, (_, e, _, s) in enumerate(solves)]
    forces_one = [_force(to_host(sol.traction), s.components, e.grid) for sol, (_, e, _, s) in zip(one.value, solves)]
    difference = max(float(np.max(np.abs(a - b)) / np.max(np.abs(a))) for a, b in zip(forces_one, forces_batch))
    per_one = one.best / sum(iterations_one)
    per_batch = batched.best / sum(iterations_batch)
    row = {
        "device": device,
        "n": n,
        "grid": list(solves[0][2].shape),
        "scenes": count,
        "iterations_one": sum(iterations_one),
        "iterations_batch": sum(iterations_batch),
        "iterations_batch_max": max(iterations_batch),
        "one_s": one.best,
        "batch_s": batched.best,
        "one_us_per_scene_iteration": 1e6 * per_one,
        "batch_us_per_scene_iteration": 1e6 * per_batch,
        "ratio": per_batch / per_one,
        "force_relative_difference": difference,
    }
    if device == "gpu":
        row["gpu_pool_bytes"] = int(array_namespace("gpu").get_default_memory_pool().total_bytes())
    return row


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, nargs="+", default=[64, 128], help="cells across (default 64 128)")
    p.add_argument("--batch", type=int, nargs="+", default=[16, 64], help="scenes per batch (default 16 64)")
    p.add_argument("--device", nargs="+", choices=["cpu", "gpu"], default=["cpu"])
    p.add_argument("--quantity", choices=["normal", "tangential"], default="normal")
    p.add_argument("--plain", action="store_true", help="unpreconditioned CG")
    p.add_argument("--tol", type=float, default=1e-8)
    p.add_argument("--repeat", type=int, default=1, help="timed calls per measurement, the best kept (default 1)")
    p.add_argument("--clock", choices=sorted(harness.CLOCKS), default="cpu", help="cpu (default) or wall")
    p.add_argument("--json", help="also write the rows to this file")
    args = p.parse_args(argv)
    print(harness.machine_line(threads=1), flush=True)
    header = f"{'device':>6} {'n':>4} {'grid':>9} {'B':>3} {'it one':>7} {'it bat':>7} {'max':>4}"
    header += f" {'one us/sc-it':>12} {'bat us/sc-it':>12} {'ratio':>6} {'dF':>8}"
    print(header, flush=True)
    rows = []
    for device in args.device:
        synchronize, clock = (lambda: None), harness.CLOCKS[args.clock]
        if device == "gpu":
            cupy = array_namespace("gpu")
            synchronize, clock = cupy.cuda.Device().synchronize, harness.CLOCKS["wall"]
        for n in args.n:
            for count in args.batch:
                row = measure(device, n, count, args, clock, synchronize)
                rows.append(row)
                print(
                    f"{device:>6} {n:>4} {'x'.join(map(str, row['grid'])):>9} {count:>3} {row['iterations_one']:>7}"
                    f" {row['iterations_batch']:>7} {row['iterations_batch_max']:>4}"
                    f" {row['one_us_per_scene_iteration']:>12.1f} {row['batch_us_per_scene_iteration']:>12.1f}"
                    f" {row['ratio']:>6.2f} {row['force_relative_difference']:>8.1e}",
                    flush=True,
                )
    if args.json:
        harness.write_json(args.json, {"machine": harness.machine_line(threads=1), "clock": args.clock, "rows": rows})
    return 0


if __name__ == "__main__":
    harness.entry(main)
