"""Solve speed of the engine: setup, time per CG iteration against the FFT floor, memory.

Two scenes of the engine at n = 256, 512, 1024 cells across (nu = 0.3, tol 1e-8):

- ``circle_tangential``: bonded circular punch, tangential load, the two-component (x, y)
  operator (blocks xx, xy, yx, yy); one solve (the y solve is the mirror image).
- ``punch_normal``: frictionless circular flat punch, the one-component (z) operator.

Each (scene, n, solver) runs in a fresh child process, so that FFTW planning starts without
in-memory wisdom and the peak resident set size belongs to that run alone. Solvers: plain CG
("CG") and CG with the Fourier preconditioner ("PCG"), so the effect of the preconditioner is
visible side by side.

Measured, per run:

- setup: kernel construction (cell integrals), kernel spectra (rfft2 of the padded blocks), the
  operator's FFTW planning (the operator's default effort unless ``--planner``; no saved wisdom
  unless ``--wisdom``), and for PCG the preconditioner's symbol;
- iterations, time per solve (best of ``--repeat``), time per iteration = solve / iterations;
  total = setup + the first solve (a cold run end to end);
- the FFT floor per iteration: ``op.fft_only()`` (the operator's own forward and inverse
  transforms, nothing else), plus for PCG the preconditioner's two FFTs, each the best of
  repeated timings; ratio = time per iteration / floor;
- the stages on their own: one ``op.apply`` and one preconditioner application;
- a full (unpruned) pyFFTW 2-D r2c + c2r pair on the padded grid for reference (what a plain
  FFT convolution without pruning costs);
- peak memory: growth of the process's peak resident set size (``getrusage(RUSAGE_SELF)
  .ru_maxrss``) from after the imports to after the solves. This sees the FFTW buffers,
  spectra, kernel blocks and CG vectors alike (tracemalloc would miss the FFTW allocations);
  the operator's own arrays are also counted from their ``nbytes`` ("op MB").

BLAS threads (OpenBLAS/MKL/OMP) are set to ``--threads`` in the child before numpy loads: the
CG's dot products and norms call BLAS, and a multi-threaded BLAS on a loaded machine costs more
than the FFTs (see README).

    python benchmarks/solve_speed.py                    # 256, 512, 1024; 1 thread
    python benchmarks/solve_speed.py --n 256 512 --threads 2 --json out.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time

from children import add_run_options, run_child

CASES = {
    "circle_tangential": {"shape": "circle", "nu": 0.3, "quantities": "tangential"},
    "punch_normal": {"shape": "circle", "nu": 0.3, "quantities": "normal"},
}
CLOCK = time.perf_counter  # the child switches to time.process_time with --clock cpu


# ---------------------------------------------------------------------------------------------
# child: one (case, n, solver) measurement, printed as one JSON line
# ---------------------------------------------------------------------------------------------
def _best(fn, repeat: int, min_time: float = 0.2) -> float:
    """Best wall time of ``fn()`` over ``repeat`` calls (at least ``min_time`` s in all)."""
    fn()
    best, spent, count = float("inf"), 0.0, 0
    while count < repeat or spent < min_time:
        t0 = CLOCK()
        fn()
        dt = CLOCK() - t0
        best, spent, count = min(best, dt), spent + dt, count + 1
        if count >= 200:
            break
    return best


def _maxrss_mb() -> float:
    import resource

    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return rss / 1024.0 if sys.platform != "darwin" else rss / 2**20  # Linux: KiB, macOS: bytes


def _array_mb(*objects) -> float:
    """Bytes of the distinct numpy buffers held by ``objects`` (attributes, lists, tuples, dicts)."""
    import numpy as np

    seen: dict[int, int] = {}

    def visit(obj, depth=0):
        if depth > 4:
            return
        if isinstance(obj, np.ndarray):
            base = obj
            while isinstance(base.base, np.ndarray):
                base = base.base
            seen[id(base)] = base.nbytes
        elif isinstance(obj, dict):
            for v in obj.values():
                visit(v, depth + 1)
        elif isinstance(obj, (list, tuple)):
            for v in obj:
                visit(v, depth + 1)
        elif hasattr(obj, "__dict__") and not isinstance(obj, type):
            for v in vars(obj).values():
                visit(v, depth + 1)

    for obj in objects:
        visit(obj)
    return sum(seen.values()) / 2**20


def _pc_fft_seconds(pc, c: int, nx: int, ny: int, repeat: int) -> float:
    """The preconditioner's own transforms (forward and inverse on its grid), best time."""
    import numpy as np
    import scipy.fft

    if hasattr(pc, "fft_only"):
        return _best(pc.fft_only, repeat)
    r = np.random.default_rng(1).random((c, nx, ny))
    spectra = scipy.fft.rfft2(r, s=pc.shape, axes=(1, 2))
    return _best(lambda: scipy.fft.rfft2(r, s=pc.shape, axes=(1, 2)), repeat) + _best(
        lambda: scipy.fft.irfft2(spectra, s=pc.shape, axes=(1, 2)), repeat
    )


def _full_fft_seconds(c: int, shape: tuple[int, int], threads: int, repeat: int) -> float:
    """An unpruned pyFFTW 2-D r2c + c2r pair on (c, N1, N2): the plain FFT-convolution cost."""
    import numpy as np
    import pyfftw

    n1, n2 = shape
    real = pyfftw.zeros_aligned((c, n1, n2))
    spec = pyfftw.zeros_aligned((c, n1, n2 // 2 + 1), dtype=np.complex128)
    fwd = pyfftw.FFTW(real, spec, axes=(1, 2), flags=("FFTW_MEASURE",), threads=threads)
    inv = pyfftw.FFTW(spec, real, axes=(1, 2), direction="FFTW_BACKWARD", flags=("FFTW_MEASURE",), threads=threads)
    real[...] = 0.0
    spec[...] = 0.0
    return _best(lambda: (fwd.execute(), inv.execute()), repeat)


def child(spec: dict) -> dict:
    import numpy as np

    from hpcontact import operator as opm
    from hpcontact.plan import make_plan
    from hpcontact.preconditioner import FourierPreconditioner
    from hpcontact.scene import Scene
    from hpcontact.solve import Engine, discretize
    from hpcontact.solvers import conjugate_gradient

    global CLOCK
    CLOCK = time.process_time if spec["clock"] == "cpu" else time.perf_counter
    case, n, solver, threads = spec["case"], spec["n"], spec["solver"], spec["threads"]
    repeat, tol = spec["repeat"], spec["tol"]
    if spec["wisdom"]:
        opm.load_wisdom()
    scene = Scene.from_params({**CASES[case], "n": n, "tol": tol, "threads": threads, "precondition": solver == "PCG"})
    grid, mask = discretize(scene)
    plan = make_plan(scene, mask, grid)
    solve = [s for s in plan.solves if s.name != "indentation_polonsky_keer"][0]
    comps, m = solve.components, scene.material
    rss0 = _maxrss_mb()

    # setup, stage by stage (what Engine.operator does, without its spectrum cache)
    blocks_needed = [a + b for a in comps for b in comps if a + b in plan.kernels]
    t0 = CLOCK()
    engine = Engine(m, grid, plan.kernels, threads)
    blocks = {b: engine.centred_block(b) for b in blocks_needed}
    t1 = CLOCK()
    shape = opm.padded_shape(grid.nx, grid.ny)
    spectra = {b: opm.kernel_spectrum(K, shape) for b, K in blocks.items()}
    del blocks
    t2 = CLOCK()
    planner = {"planner_effort": spec["planner"]} if spec.get("planner") else {}
    op = opm.ConvolutionOperator(grid.nx, grid.ny, comps, spectra, threads=threads, **planner)
    t3 = CLOCK()
    pc = FourierPreconditioner(grid, engine.surface_green, comps) if solver == "PCG" else None
    t4 = CLOCK()
    setup = {"kernels_s": t1 - t0, "spectra_s": t2 - t1, "plan_s": t3 - t2, "pc_s": t4 - t3, "setup_s": t4 - t0}
    if spec["wisdom"]:
        opm.save_wisdom()

    rhs = np.zeros((len(comps),) + mask.shape)
    rhs[comps.index(solve.load)] = 1.0
    precondition = pc.apply if pc is not None else None
    effort0 = getattr(op, "plan_effort", "?")
    times = []
    for _ in range(repeat):
        start = CLOCK()
        solution = conjugate_gradient(op.apply, rhs, mask, tol=tol, precondition=precondition)
        times.append(CLOCK() - start)
    rss1 = _maxrss_mb()
    solve_s = min(times)
    force = float(solution.traction[comps.index(solve.load)].sum() * grid.cell_area)

    t = np.random.default_rng(0).random((len(comps),) + mask.shape)
    # time the stages with the plans the solves ended with (no re-planning while timing)
    if hasattr(op, "_measure_at"):
        op._measure_at = None
    fft_s, apply_s = _best(op.fft_only, 10), _best(lambda: op.apply(t), 10)
    pc_fft_s = _pc_fft_seconds(pc, len(comps), grid.nx, grid.ny, 10) if pc is not None else 0.0
    pc_s = _best(lambda: pc.apply(t), 10) if pc is not None else 0.0
    full_fft_s = _full_fft_seconds(len(comps), shape, threads, 5) if spec["full_fft"] else float("nan")
    per_iter = solve_s / solution.iterations
    return {
        **spec,
        "components": comps,
        "grid": [grid.nx, grid.ny],
        "fft_shape": list(shape),
        "contact_cells": int(mask.sum()),
        **setup,
        "iterations": solution.iterations,
        "residual": solution.residual,
        "solve_s": solve_s,
        "solve_all_s": times,
        "total_s": setup["setup_s"] + times[0],
        "plan_effort": effort0 if getattr(op, "plan_effort", "?") == effort0 else f"{effort0}->{op.plan_effort}",
        "planning_total_s": op.planning_time_s,
        "per_iter_ms": 1e3 * per_iter,
        "fft_floor_ms": 1e3 * (fft_s + pc_fft_s),
        "op_fft_ms": 1e3 * fft_s,
        "pc_fft_ms": 1e3 * pc_fft_s,
        "ratio": per_iter / (fft_s + pc_fft_s),
        "apply_ms": 1e3 * apply_s,
        "pc_apply_ms": 1e3 * pc_s,
        "cg_other_ms": 1e3 * (per_iter - apply_s - pc_s),
        "full_fft_ms": 1e3 * full_fft_s,
        "peak_rss_mb": rss1 - rss0,
        "op_mb": _array_mb(op),
        "force": force,
    }


# ---------------------------------------------------------------------------------------------
# parent: run the children, print the tables
# ---------------------------------------------------------------------------------------------
def host_line(threads: int) -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            names = [line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")]
        cpu = names[0] if names else cpu
    except OSError:
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{cpu}, {os.cpu_count()} cores, load average {load:.1f}; {threads} thread(s)"


def print_tables(rows: list[dict]) -> None:
    ok = [r for r in rows if "error" not in r]
    print("\nSetup (s): kernel construction + spectra + FFTW planning (+ preconditioner for PCG)")
    print(f"{'case':18s} {'n':>5s} {'grid':>10s} {'FFT grid':>10s} {'kernels':>8s} {'spectra':>8s} {'plan':>7s} {'pc':>6s} {'setup':>7s} {'op MB':>7s}")
    for r in ok:
        if r["solver"] != "PCG" and any(o["solver"] == "PCG" and o["case"] == r["case"] and o["n"] == r["n"] for o in ok):
            continue
        print(
            f"{r['case']:18s} {r['n']:5d} {'x'.join(map(str, r['grid'])):>10s} {'x'.join(map(str, r['fft_shape'])):>10s}"
            f" {r['kernels_s']:8.2f} {r['spectra_s']:8.2f} {r['plan_s']:7.2f} {r['pc_s']:6.3f} {r['setup_s']:7.2f} {r['op_mb']:7.0f}"
        )
    print("\nSolve: per iteration against the FFT floor (op.fft_only [+ preconditioner FFTs]); times are best of repeats")
    print(
        f"{'case':18s} {'n':>5s} {'solver':>6s} {'iters':>5s} {'ms/iter':>8s} {'floor ms':>8s} {'ratio':>6s}"
        f" {'apply ms':>8s} {'pc ms':>6s} {'other ms':>8s} {'2D FFT ms':>9s} {'solve s':>8s} {'total s':>8s} {'peak MB':>8s} {'force':>10s} plans"
    )
    for r in ok:
        print(
            f"{r['case']:18s} {r['n']:5d} {r['solver']:>6s} {r['iterations']:5d} {r['per_iter_ms']:8.2f} {r['fft_floor_ms']:8.2f}"
            f" {r['ratio']:6.2f} {r['apply_ms']:8.2f} {r['pc_apply_ms']:6.2f} {r['cg_other_ms']:8.2f} {r['full_fft_ms']:9.2f}"
            f" {r['solve_s']:8.3f} {r['total_s']:8.2f} {r['peak_rss_mb']:8.0f} {r['force']:10.6f} {r['plan_effort'].replace('FFTW_', '')}"
        )
    pairs = {}
    for r in ok:
        pairs.setdefault((r["case"], r["n"]), {})[r["solver"]] = r
    lines = []
    for (case, n), d in pairs.items():
        if "CG" in d and "PCG" in d:
            a, b = d["CG"], d["PCG"]
            lines.append(
                f"  {case:18s} n={n:<5d} iterations {a['iterations']:4d} -> {b['iterations']:3d}, "
                f"solve {a['solve_s']:.3f} -> {b['solve_s']:.3f} s ({a['solve_s'] / b['solve_s']:.1f}x), "
                f"total {a['total_s']:.2f} -> {b['total_s']:.2f} s, force rel. diff {abs(a['force'] / b['force'] - 1):.1e}"
            )
    if lines:
        print("\nPreconditioner, before -> after (CG -> PCG):")
        print("\n".join(lines))
    for r in rows:
        if "error" in r:
            print(f"\n{r['case']} n={r['n']} {r['solver']}: FAILED: {r['error']}")
    print(
        "\nms/iter = solve time / iterations; floor = op.fft_only() (+ the preconditioner's rfft2/irfft2 for PCG);"
        "\nother = ms/iter - apply - pc (the CG's own vector work); 2D FFT = unpruned pyFFTW r2c+c2r pair on the FFT grid"
        "\n(FFTW_MEASURE); solve = best of the repeats; total = setup + first solve; plans = the operator's FFTW plans"
        "\nin the solves (default: ESTIMATE unless there is wisdom, re-planned MEASURE after 100 applications);"
        "\npeak MB = growth of ru_maxrss from after the imports; op MB = the operator's arrays (nbytes);"
        "\nforce = resultant along the load for a unit prescribed displacement (G = 1, radius 1)."
    )


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, nargs="+", default=[256, 512, 1024], help="cells across (default 256 512 1024)")
    p.add_argument("--threads", type=int, default=1, help="FFTW and BLAS threads (default 1)")
    p.add_argument("--cases", nargs="+", choices=sorted(CASES), default=list(CASES))
    p.add_argument("--solvers", nargs="+", choices=["CG", "PCG"], default=["CG", "PCG"])
    p.add_argument("--tol", type=float, default=1e-8, help="CG relative residual (default 1e-8)")
    p.add_argument("--repeat", type=int, default=3, help="solves per run; the best is kept (default 3)")
    p.add_argument("--planner", choices=["FFTW_ESTIMATE", "FFTW_MEASURE", "FFTW_PATIENT"],
                   help="planner effort for the operator (default: ConvolutionOperator's default)")
    p.add_argument("--wisdom", action="store_true", help="load and save FFTW wisdom (planning then takes ms)")
    p.add_argument("--no-full-fft", dest="full_fft", action="store_false", help="skip the unpruned 2-D FFT reference")
    add_run_options(p, timeout=1800.0)
    args = p.parse_args(argv)
    if args.child:
        print(json.dumps(child(json.loads(args.child))))
        return 0

    print(f"hpcontact solve_speed: {host_line(args.threads)}; tol {args.tol:g}; {args.clock} clock; "
          f"FFTW planning: {args.planner or 'default effort'}, {'with' if args.wisdom else 'without'} saved wisdom")
    rows = []
    for n in args.n:
        for case in args.cases:
            for solver in args.solvers:
                spec = {"case": case, "n": n, "solver": solver, "threads": args.threads, "tol": args.tol,
                        "repeat": args.repeat, "wisdom": args.wisdom, "full_fft": args.full_fft, "clock": args.clock,
                        "planner": args.planner}
                r = run_child(__file__, spec, args.timeout)
                rows.append(r)
                if "error" in r:
                    print(f"  {case} n={n} {solver}: FAILED: {r['error']}", file=sys.stderr, flush=True)
                else:
                    print(f"  {case} n={n} {solver}: {r['iterations']} iterations, {r['per_iter_ms']:.2f} ms/iter "
                          f"(floor {r['fft_floor_ms']:.2f}), setup {r['setup_s']:.2f} s, solve {r['solve_s']:.3f} s",
                          file=sys.stderr, flush=True)
    print_tables(rows)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"host": host_line(args.threads), "clock": args.clock, "rows": rows}, fh, indent=1)
    return 0 if all("error" not in r for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
