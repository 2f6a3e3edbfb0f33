"""The same non-periodic flat punch through hpcontact, Tamaas and ContactMechanics.

Problem: a rigid circular flat punch of radius 0.4, centred in the unit square, pressed
(frictionless, normal only) on an elastic half-space with E = 1, nu = 0.3. The unit square is
meshed with n × n square cells; a cell is in contact when its centre lies in the circle
(centre-in-circle), and the same boolean mask is given to every code. A rigid displacement is
prescribed on the circle; each code's total force per unit displacement is printed (they must
agree to discretization accuracy: all three use uniform-pressure square cells, so they agree to
the solvers' tolerance) with its iterations and times, and the time ratios to ours.

- hpcontact: the engine (``kernels.engine.Engine``) on the mask cropped to its support
  (``geometry.crop_to_support``, as ``problems.contact.solve`` does), CG on the mask with the Fourier
  preconditioner ("PCG"), and plain CG ("CG") for the before/after. Total time = kernel
  construction + spectrum + FFTW planning (no saved wisdom) + preconditioner + solve.
- Tamaas (``tamaas``): ``PolonskyKeerRey`` on a ``basic_2d`` model of the unit square with the
  non-periodic DC-FFT operator (``ModelFactory.registerNonPeriodic``), load controlled (Tamaas
  solves for a mean pressure); the indenter is 0 on the circle and −1 elsewhere (never
  touched). Force per unit displacement = load / (mean displacement over the punch, from the same
  DC-FFT operator applied to the pressure). Total = model + operator + solver construction + solve.
- ContactMechanics: ``FreeFFTElasticHalfSpace`` (E* = E / (1 − nu²)) with the same indenter,
  ``NonSmoothContactSystem.minimize_proxy`` (Polonsky–Keer constrained CG) at a prescribed
  offset, pentol = tol × offset. Total = substrate + system construction + solve.

Each (code, n) runs in a child process with FFTW/BLAS/OpenMP threads set to ``--threads``; a code
that is not installed (``pip install -e .[bench]``) or fails is reported and the rest still runs.

    python benchmarks/vs_peers.py                 # n = 256, 512, 1024; 1 thread
    python benchmarks/vs_peers.py --n 1024 --codes ours tamaas
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import harness

E, NU, RADIUS = 1.0, 0.3, 0.4
CLOCK = time.perf_counter  # the child switches to time.process_time with --clock cpu
CODES = ("ours", "tamaas", "contactmechanics")


def unit_square_mask(n: int):
    """Centre-in-circle mask of the n × n cells of the unit square (circle radius 0.4, centred)."""
    import numpy as np

    x = (np.arange(n) + 0.5) / n - 0.5
    X, Y = np.meshgrid(x, x, indexing="ij")
    return X * X + Y * Y <= RADIUS * RADIUS


def _best(fn, repeat: int) -> float:
    """Best time of ``repeat`` calls of ``fn()`` on ``CLOCK``, after a warm-up call."""
    return harness.repeat_timing(fn, repeat, warmup=True, clock=CLOCK).best


# ---------------------------------------------------------------------------------------------
# children
# ---------------------------------------------------------------------------------------------
def run_ours(n: int, tol: float, threads: int, precondition: bool) -> dict:
    import numpy as np
    import scipy.fft

    from hpcontact.geometry import Grid, crop_to_support
    from hpcontact.materials.isotropic import Isotropic
    from hpcontact.numerics.conjugate_gradient import conjugate_gradient
    from hpcontact.numerics.preconditioner import FourierPreconditioner
    from hpcontact.problems.contact import Engine

    full_mask = unit_square_mask(n)
    t0 = CLOCK()
    mask, grid = crop_to_support(full_mask, Grid(n, n, 1.0 / n, 1.0 / n))
    material = Isotropic(G=E / (2.0 * (1.0 + NU)), nu=NU)
    engine = Engine(material, grid, ("zz",), threads)
    op = engine.operator("z")
    pc = FourierPreconditioner(grid, engine.surface_green, "z") if precondition else None
    t1 = CLOCK()
    rhs = np.ones((1,) + mask.shape)
    solution = conjugate_gradient(op.apply, rhs, mask, tol=tol, precondition=pc.apply if pc else None)
    t2 = CLOCK()
    force = float(solution.traction.sum() * grid.cell_area)
    # steady state per iteration (best of the cold solve and two more), like the floor below
    best_solve = t2 - t1
    for _ in range(2):
        t3 = CLOCK()
        conjugate_gradient(op.apply, rhs, mask, tol=tol, precondition=pc.apply if pc else None)
        best_solve = min(best_solve, CLOCK() - t3)
    fft_s = _best(op.fft_only, 10)
    pc_fft_s = 0.0
    if pc is not None:
        if hasattr(pc, "fft_only"):
            pc_fft_s = _best(pc.fft_only, 10)
        else:  # the preconditioner's own rfft2 / irfft2 on its grid
            r = np.random.default_rng(0).random((1,) + mask.shape)
            spec = scipy.fft.rfft2(r, s=pc.shape, axes=(1, 2))
            pc_fft_s = _best(lambda: scipy.fft.rfft2(r, s=pc.shape, axes=(1, 2)), 10) + _best(
                lambda: scipy.fft.irfft2(spec, s=pc.shape, axes=(1, 2)), 10
            )
    per_iter = best_solve / solution.iterations
    return {
        "iterations": solution.iterations,
        "setup_s": t1 - t0,
        "solve_s": t2 - t1,
        "total_s": t2 - t0,
        "force": force,
        "contact_cells": int(mask.sum()),
        "detail": f"grid {grid.nx}x{grid.ny}, FFT {op.shape[0]}x{op.shape[1]}, planning {op.planning_time_s:.2f} s "
        f"({getattr(op, 'plan_effort', '?')} plans at the end)",
        "per_iter_ms": 1e3 * (t2 - t1) / solution.iterations,
        "steady_per_iter_ms": 1e3 * per_iter,
        "floor_ms": 1e3 * (fft_s + pc_fft_s),
        "floor_ratio": per_iter / (fft_s + pc_fft_s),
    }


def _capture_output(fn):
    """Run fn() with the C-level stdout and stderr (fds 1, 2) sent to a file; return (fn(), text)."""
    import ctypes

    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    sys.stderr.flush()
    libc.fflush(None)
    saved = {fd: os.dup(fd) for fd in (1, 2)}
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        for fd in saved:
            os.dup2(tmp.fileno(), fd)
        try:
            result = fn()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            libc.fflush(None)  # C stdio (and C++ iostreams synced with it) buffer their writes
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
        tmp.seek(0)
        text = tmp.read().decode(errors="replace")
    return result, text


def run_tamaas(n: int, tol: float, threads: int) -> dict:
    import numpy as np
    import tamaas as tm

    mask = unit_square_mask(n)
    surface = np.where(mask, 0.0, -1.0)
    mean_pressure = 1e-3  # load control; the answer is linear in the load
    t0 = CLOCK()
    model = tm.Model(tm.model_type.basic_2d, [1.0, 1.0], [n, n])
    model.E, model.nu = E, NU
    tm.ModelFactory.registerNonPeriodic(model, "dcfft")
    solver = tm.PolonskyKeerRey(model, surface, tol)
    solver.setIntegralOperator("dcfft")
    solver.max_iter = 100000
    t1 = CLOCK()
    _, log = _capture_output(lambda: solver.solve(mean_pressure))  # Tamaas logs to stderr
    t2 = CLOCK()
    iterations = None
    for line in log.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[0].isdigit():
            iterations = int(parts[0])
    p = np.array(model.traction, copy=True)
    u = np.zeros_like(p)
    model.operators["dcfft"](p, u)  # displacement of the pressure alone (no rigid offset)
    load = float(p.sum()) / (n * n)  # mean pressure × unit area
    displacement = float(u[mask].mean())
    spread = float(u[mask].std() / displacement)
    return {
        "iterations": iterations,
        "setup_s": t1 - t0,
        "solve_s": t2 - t1,
        "total_s": t2 - t0,
        "force": load / displacement,
        "contact_cells": int((p > 0).sum()),
        "detail": f"tamaas {tm.__version__}, PolonskyKeerRey + DC-FFT, tol {tol:g}, "
        f"punch displacement spread {spread:.1e}",
        "per_iter_ms": 1e3 * (t2 - t1) / iterations if iterations else float("nan"),
    }


def run_contactmechanics(n: int, tol: float, threads: int) -> dict:
    from importlib.metadata import version

    import numpy as np
    from ContactMechanics import FreeFFTElasticHalfSpace, make_system
    from SurfaceTopography import Topography

    mask = unit_square_mask(n)
    heights = np.where(mask, 0.0, -1.0)
    offset = 1e-3
    t0 = CLOCK()
    substrate = FreeFFTElasticHalfSpace((n, n), E / (1.0 - NU * NU), physical_sizes=(1.0, 1.0))
    topography = Topography(heights, physical_sizes=(1.0, 1.0))
    system = make_system(surface=topography, substrate=substrate)
    t1 = CLOCK()
    result = system.minimize_proxy(offset=offset, pentol=tol * offset, maxiter=100000)
    t2 = CLOCK()
    if not result.success:
        raise RuntimeError(f"ContactMechanics did not converge: {getattr(result, 'message', '')}")
    forces = np.asarray(result.jac)
    return {
        "iterations": int(result.nit),
        "setup_s": t1 - t0,
        "solve_s": t2 - t1,
        "total_s": t2 - t0,
        "force": float(forces.sum()) / offset,
        "contact_cells": int((forces > 0).sum()),
        "detail": f"ContactMechanics {version('ContactMechanics')}, constrained CG, pentol {tol:g} x offset",
        "per_iter_ms": 1e3 * (t2 - t1) / int(result.nit),
    }


def child(spec: dict) -> dict:
    """One (code, n) run in this fresh process (``harness.call_in_child``)."""
    global CLOCK
    CLOCK = harness.CLOCKS[spec.get("clock", "wall")]
    code, n, tol, threads = spec["code"], spec["n"], spec["tol"], spec["threads"]
    try:
        if code == "ours_pcg":
            out = run_ours(n, tol, threads, True)
        elif code == "ours_cg":
            out = run_ours(n, tol, threads, False)
        elif code == "tamaas":
            out = run_tamaas(n, tol, threads)
        elif code == "contactmechanics":
            out = run_contactmechanics(n, tol, threads)
        else:
            raise ValueError(code)
    except ImportError as exc:
        return {**spec, "error": f"not installed ({exc}); pip install -e .[bench]"}
    return {**spec, **out}


# ---------------------------------------------------------------------------------------------
# parent
# ---------------------------------------------------------------------------------------------
LABELS = {
    "ours_pcg": "hpcontact PCG",
    "ours_cg": "hpcontact CG",
    "tamaas": "Tamaas",
    "contactmechanics": "ContactMechanics",
}


def analytic_force() -> float:
    """Continuum stiffness of a rigid flat punch: 2 a E / (1 − nu²) (Boussinesq)."""
    return 2.0 * RADIUS * E / (1.0 - NU * NU)


def print_table(rows: list[dict], n_values: list[int]) -> None:
    print(
        f"\nFlat punch, radius {RADIUS} in the unit square, E = {E:g}, nu = {NU:g}; "
        f"continuum force per unit displacement 2aE/(1-nu^2) = {analytic_force():.6f}"
    )
    head = (
        f"{'n':>5s} {'code':18s} {'iters':>6s} {'setup s':>8s} {'solve s':>8s} {'total s':>8s} {'ms/iter':>8s}"
        f" {'force/disp':>11s} {'rel.diff':>9s} {'total/ours':>10s}"
    )
    print(head)
    for n in n_values:
        at_n = [r for r in rows if r["n"] == n]
        ours = next((r for r in at_n if r["code"] == "ours_pcg" and "error" not in r), None)
        for r in at_n:
            label = LABELS[r["code"]]
            if "error" in r:
                print(f"{n:5d} {label:18s} {r['error']}")
                continue
            rel = abs(r["force"] / ours["force"] - 1.0) if ours else float("nan")
            ratio = r["total_s"] / ours["total_s"] if ours else float("nan")
            iters = r["iterations"] if r["iterations"] is not None else -1
            print(
                f"{n:5d} {label:18s} {iters:6d} {r['setup_s']:8.2f} {r['solve_s']:8.2f} {r['total_s']:8.2f}"
                f" {r['per_iter_ms']:8.2f} {r['force']:11.6f} {rel:9.1e} {ratio:10.1f}"
            )
    print(
        "\nrel.diff: |force/force(hpcontact PCG) - 1|; total/ours: total time / hpcontact PCG total time;"
        "\nms/iter: solve / iterations of the (cold) timed solve; every code runs once, cold, in a fresh process."
    )
    for r in rows:
        if "error" not in r:
            print(f"  n={r['n']:<5d} {LABELS[r['code']]:18s} {r['detail']}; contact cells {r['contact_cells']}")
    print("\nhpcontact per iteration against its FFT floor (op.fft_only + the preconditioner's FFTs):")
    for r in rows:
        if r["code"].startswith("ours") and "error" not in r:
            print(
                f"  n={r['n']:<5d} {LABELS[r['code']]:14s} {r['steady_per_iter_ms']:8.2f} ms/iter (best of 3 solves; "
                f"cold solve {r['per_iter_ms']:.2f}), floor {r['floor_ms']:7.2f} ms, ratio {r['floor_ratio']:.2f}"
            )
    n_top = max(n_values)
    at = {r["code"]: r for r in rows if r["n"] == n_top and "error" not in r}
    if "ours_pcg" in at:
        print(f"\nTargets at n = {n_top}:")
        o = at["ours_pcg"]
        if "tamaas" in at:
            ratio = at["tamaas"]["total_s"] / o["total_s"]
            print(f"  faster than Tamaas by >= 8x:          {ratio:6.1f}x  {'PASS' if ratio >= 8 else 'FAIL'}")
        print(
            f"  time per iteration <= 1.3x FFT floor: {o['floor_ratio']:6.2f}   {'PASS' if o['floor_ratio'] <= 1.3 else 'FAIL'}"
        )
        if "ours_cg" in at:
            a, b = at["ours_cg"]["iterations"], o["iterations"]
            print(f"  preconditioner: iterations CG -> PCG: {a} -> {b}  {'PASS' if b < a else 'FAIL'}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, nargs="+", default=[256, 512, 1024], help="cells across the unit square")
    p.add_argument("--threads", type=int, default=1, help="FFTW/BLAS/OpenMP threads for every code (default 1)")
    p.add_argument("--codes", nargs="+", choices=["ours", "tamaas", "contactmechanics"], default=list(CODES))
    p.add_argument("--tol", type=float, default=1e-8, help="solver tolerance for every code (default 1e-8)")
    harness.add_run_options(p, timeout=900.0)
    args = p.parse_args(argv)
    print(f"vs_peers: {harness.machine_line(args.threads)}; tol {args.tol:g}; {args.clock} clock")
    codes = []
    for code in args.codes:
        codes.extend(["ours_pcg", "ours_cg"] if code == "ours" else [code])
    rows = []
    for n in args.n:
        for code in codes:
            spec = {"code": code, "n": n, "tol": args.tol, "threads": args.threads, "clock": args.clock}
            r = harness.call_in_child(__file__, "child", spec, threads=args.threads, timeout=args.timeout).or_error(
                spec
            )
            rows.append(r)
            if "error" in r:
                print(f"  n={n} {LABELS[code]}: {r['error']}", file=sys.stderr, flush=True)
            else:
                print(
                    f"  n={n} {LABELS[code]}: {r['iterations']} iterations, total {r['total_s']:.2f} s, "
                    f"force {r['force']:.6f}",
                    file=sys.stderr,
                    flush=True,
                )
    print_table(rows, args.n)
    if args.json:
        harness.write_json(
            args.json, {"machine": harness.machine_line(args.threads), "clock": args.clock, "rows": rows}
        )
    return 0


if __name__ == "__main__":
    harness.entry(main)
