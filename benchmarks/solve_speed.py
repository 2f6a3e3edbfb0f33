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

Cold, as users run it (``--cold also|only|no``; circle_tangential, PCG): for each n and each
source tree of ``--code`` (e.g. ``git worktree add /tmp/before <commit>`` and this checkout, to
compare before and after in one run), the best-plan CG ms/iteration (FFTW_MEASURE plans made
before the solves, best of ``--repeat``; with the planning time and the applications after
which it pays) side by side with the CG ms/iteration of fresh processes running the CLI as a
user does: one ``hpcontact solve`` without FFTW wisdom, a ``hpcontact run`` sweep of
``--scenes`` scenes on one grid (nu = 0 … 0.45) without wisdom, and that sweep again with the
wisdom the first one saved. Use ``--clock cpu`` on a shared machine.

Warm starts (``--warm-start N``, alone): CG iterations of neighbouring scenes of a continuation
(nu on a circle, orientation ψ of a crystal) started from zero and from the previous scene's
traction, and how far the two results differ.

BLAS threads (OpenBLAS/MKL/OMP) are set to ``--threads`` in the child before numpy loads: the
CG's dot products and norms call BLAS, and a multi-threaded BLAS on a loaded machine costs more
than the FFTs (see docs/explanation/speed.md, "The engine").

    python benchmarks/solve_speed.py                    # 256, 512, 1024; 1 thread
    python benchmarks/solve_speed.py --n 256 512 --threads 2 --json out.json
    python benchmarks/solve_speed.py --cold only --clock cpu --n 512 1024 --code /tmp/before .
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import harness

CASES = {
    "circle_tangential": {"shape": "circle", "nu": 0.3, "quantities": "tangential"},
    "punch_normal": {"shape": "circle", "nu": 0.3, "quantities": "normal"},
}
CLOCK = time.perf_counter  # the child switches to time.process_time with --clock cpu


# ---------------------------------------------------------------------------------------------
# child: one (case, n, solver) measurement, returned to the parent as JSON (harness.call_in_child)
# ---------------------------------------------------------------------------------------------
def _best(fn, repeat: int, min_time: float = 0.2) -> float:
    """Best time of ``fn()`` on ``CLOCK`` after a warm-up call: ``repeat`` calls, and more until
    ``min_time`` s are spent (at most 200)."""
    return harness.repeat_timing(fn, repeat, warmup=True, min_time=min_time, clock=CLOCK).best


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


def code_environment(spec: dict) -> dict[str, str]:
    """The child's ``PYTHONPATH``: the source tree ``spec["code"]`` (another checkout, e.g. a
    ``git worktree`` of an older commit) comes before the installed hpcontact, if given."""
    return {"PYTHONPATH": os.path.abspath(spec["code"])} if spec.get("code") else {}


def child(spec: dict) -> dict:
    """One (case, n, solver) measurement in this fresh process (module docstring)."""
    import numpy as np

    from hpcontact.numerics import convolution as opm
    from hpcontact.numerics.conjugate_gradient import conjugate_gradient
    from hpcontact.numerics.preconditioner import FourierPreconditioner
    from hpcontact.plan import make_plan
    from hpcontact.problems.contact import Engine, discretize
    from hpcontact.scene import Scene

    global CLOCK
    CLOCK = harness.CLOCKS[spec["clock"]]
    case, n, solver, threads = spec["case"], spec["n"], spec["solver"], spec["threads"]
    repeat, tol = spec["repeat"], spec["tol"]
    if spec["wisdom"]:
        opm.load_wisdom()
    scene = Scene.from_params({**CASES[case], "n": n, "tol": tol, "threads": threads, "precondition": solver == "PCG"})
    grid, mask = discretize(scene)
    plan = make_plan(scene, mask, grid)
    solve = [s for s in plan.solves if s.name != "indentation_polonsky_keer"][0]
    comps, m = solve.components, scene.material
    rss0 = harness.peak_rss_mb()

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
    rss1 = harness.peak_rss_mb()
    solve_s = min(times)
    force = float(solution.traction[comps.index(solve.load)].sum() * grid.cell_area)

    t = np.random.default_rng(0).random((len(comps),) + mask.shape)
    # time the stages with the plans the solves ended with (no re-planning while timing: the
    # layout's automatic FFTW_MEASURE upgrade is switched off)
    if hasattr(op, "transforms"):
        op.transforms.auto = False
    fft_s, apply_s = _best(op.fft_only, 10), _best(lambda: op.apply(t), 10)
    pc_fft_s = _pc_fft_seconds(pc, len(comps), grid.nx, grid.ny, 10) if pc is not None else 0.0
    pc_s = _best(lambda: pc.apply(t), 10) if pc is not None else 0.0
    # with FFTW_MEASURE plans (no wisdom: plan_s is the planning), what ESTIMATE plans cost per
    # application: the applications after which measuring pays for itself
    estimate_ms = break_even = float("nan")
    if spec.get("planner") == "FFTW_MEASURE" and not spec["wisdom"]:
        import pyfftw

        pyfftw.forget_wisdom()  # else FFTW_ESTIMATE planning would reuse the measured plans' wisdom
        rough = opm.ConvolutionOperator(
            grid.nx, grid.ny, comps, spectra, threads=threads, planner_effort="FFTW_ESTIMATE"
        )
        estimate_ms = 1e3 * _best(lambda: rough.apply(t), 10)
        del rough
        gain = 1e-3 * estimate_ms - apply_s
        break_even = setup["plan_s"] / gain if gain > 0.0 else float("inf")
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
        "apply_estimate_ms": estimate_ms,
        "break_even": break_even,
        "pc_apply_ms": 1e3 * pc_s,
        "cg_other_ms": 1e3 * (per_iter - apply_s - pc_s),
        "full_fft_ms": 1e3 * full_fft_s,
        "peak_rss_mb": rss1 - rss0,
        "op_mb": _array_mb(op),
        "force": force,
    }


SWEEP_SPEC = """[sweep]
title = "solve_speed: {scenes} scenes on one grid (nu axis)"
output = "{output}"

[scene]
shape = "circle"
quantities = ["{quantities}"]
threads = {threads}

[numerics]
n = {n}
tol = {tol!r}

[axes]
nu = {nu}
"""


def cold_child(spec: dict) -> dict:
    """A user's run in this fresh process: ``hpcontact solve`` of the case, or ``hpcontact run``
    of a sweep of ``scenes`` values of nu (0 … 0.45) on the case's grid, through the CLI's own
    entry point, FFTW wisdom from ``spec["wisdom_file"]`` (absent: a machine without wisdom).
    The CG calls are timed where ``hpcontact.solve`` makes them (setup, kernels and the data set
    are outside): ms/iteration = CG time / CG iterations, plans upgraded inside the CG included."""
    import contextlib
    import io
    import tempfile

    os.environ["HPCONTACT_WISDOM"] = spec["wisdom_file"]
    import hpcontact.problems.contact as solve_module
    from hpcontact import cli
    from hpcontact.numerics import convolution as opm

    global CLOCK
    CLOCK = harness.CLOCKS[spec["clock"]]
    cg = {"s": 0.0, "iterations": 0, "solves": 0}
    conjugate_gradient = solve_module.conjugate_gradient

    def timed(*args, **kwargs):
        t0 = CLOCK()
        solution = conjugate_gradient(*args, **kwargs)
        cg["s"] += CLOCK() - t0
        cg["iterations"] += solution.iterations
        cg["solves"] += 1
        return solution

    solve_module.conjugate_gradient = timed
    # FFTW planning, wherever it happens: per layout (Transforms.plan)
    plan = opm.Transforms.plan
    planning = [0.0]

    def timed_plan(*args, **kwargs):
        t0 = CLOCK()
        effort = plan(*args, **kwargs)
        planning[0] += CLOCK() - t0
        return effort

    opm.Transforms.plan = timed_plan
    params = CASES[spec["case"]]
    with tempfile.TemporaryDirectory() as work:
        if spec["mode"] == "solve":
            argv = [
                "solve",
                "--shape",
                params["shape"],
                "--nu",
                str(params["nu"]),
                "--quantities",
                params["quantities"],
                "--n",
                str(spec["n"]),
                "--tol",
                repr(spec["tol"]),
                "--threads",
                str(spec["threads"]),
            ]
        else:
            nus = [round(0.45 * i / max(spec["scenes"] - 1, 1), 6) for i in range(spec["scenes"])]
            path = os.path.join(work, "sweep.toml")
            with open(path, "w") as fh:
                fh.write(
                    SWEEP_SPEC.format(
                        scenes=spec["scenes"],
                        output=os.path.join(work, "out.nc"),
                        n=spec["n"],
                        quantities=params["quantities"],
                        threads=spec["threads"],
                        tol=spec["tol"],
                        nu=json.dumps(nus),
                    )
                )
            argv = ["run", path]
        t0 = CLOCK()
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            status = cli.main(argv)
        wall = CLOCK() - t0
    if status != 0:
        raise RuntimeError(f"hpcontact {' '.join(argv)} exited with {status}")
    return {
        **spec,
        "status": status,
        "cg_s": cg["s"],
        "iterations": cg["iterations"],
        "solves": cg["solves"],
        "per_iter_ms": 1e3 * cg["s"] / max(cg["iterations"], 1),
        "wall_s": wall,
        "planning_s": planning[0],
    }


WARM_CHAINS = (  # (label, scene, axis, values): neighbouring scenes of a continuation
    ("circle, nu", {"shape": "circle", "quantities": "tangential"}, "nu", [0.05 * i for i in range(1, 11)]),
    (
        "ellipse b/a = 0.3, A = 2, psi",
        {"shape": "ellipse", "aspect": 0.3, "quantities": "tangential", "anisotropy": 2.0},
        "orientation",
        [0.0, 10.0, 20.0, 30.0, 40.0],
    ),
)


def warm_start(n: int, tol: float) -> None:
    """CG iterations of each scene of a continuation from zero and from the previous scene's
    traction (the correction d of A d = b − A x0 by the same preconditioned CG, to the same
    ‖r‖ ≤ tol ‖b‖), and how far the warm result's force is from the cold one's."""
    import numpy as np

    from hpcontact.numerics.conjugate_gradient import conjugate_gradient
    from hpcontact.numerics.preconditioner import FourierPreconditioner
    from hpcontact.plan import make_plan
    from hpcontact.problems.contact import Engine, discretize
    from hpcontact.scene import Scene

    print(f"\nWarm starts (n = {n}, tol {tol:g}, preconditioned CG, tangential x solve): iterations cold -> warm")
    for label, base, axis, values in WARM_CHAINS:
        previous, cold_total, warm_total, worst = None, 0, 0, 0.0
        for value in values:
            scene = Scene.from_params({**base, "n": n, "tol": tol, axis: value})
            grid, mask = discretize(scene)
            plan = make_plan(scene, mask, grid)
            solve = [s for s in plan.solves if s.name.startswith("tangential")][0]
            engine = Engine(scene.material, grid, plan.kernels, 1)
            op = engine.operator(solve.components, solve.green)
            pc = FourierPreconditioner(grid, engine.green_function(solve.green), solve.components).apply
            b = np.zeros((len(solve.components),) + mask.shape)
            b[solve.components.index(solve.load)] = 1.0
            cold = conjugate_gradient(op.apply, b, mask, tol=tol, precondition=pc)
            if previous is not None and previous.shape == cold.traction.shape:
                x0 = previous * mask
                r0 = (b - op.apply(x0)) * mask
                d = conjugate_gradient(
                    op.apply, r0, mask, tol=tol * np.linalg.norm(b * mask) / np.linalg.norm(r0), precondition=pc
                )
                load = solve.components.index(solve.load)
                worst = max(worst, abs((x0 + d.traction)[load].sum() / cold.traction[load].sum() - 1.0))
                cold_total, warm_total = cold_total + cold.iterations, warm_total + d.iterations
            previous = cold.traction
        print(
            f"  {label} {values[0]:g} … {values[-1]:g}: {cold_total} -> {warm_total} iterations "
            f"({warm_total / cold_total:.2f}); force differs by up to {worst:.1e} relative"
        )


# ---------------------------------------------------------------------------------------------
# parent: run the children, print the tables
# ---------------------------------------------------------------------------------------------
def print_tables(rows: list[dict]) -> None:
    ok = [r for r in rows if "error" not in r]
    print("\nSetup (s): kernel construction + spectra + FFTW planning (+ preconditioner for PCG)")
    print(
        f"{'case':18s} {'n':>5s} {'grid':>10s} {'FFT grid':>10s} {'kernels':>8s} {'spectra':>8s} {'plan':>7s} {'pc':>6s} {'setup':>7s} {'op MB':>7s}"
    )
    for r in ok:
        if r["solver"] != "PCG" and any(
            o["solver"] == "PCG" and o["case"] == r["case"] and o["n"] == r["n"] for o in ok
        ):
            continue
        print(
            f"{r['case']:18s} {r['n']:5d} {'x'.join(map(str, r['grid'])):>10s} {'x'.join(map(str, r['fft_shape'])):>10s}"
            f" {r['kernels_s']:8.2f} {r['spectra_s']:8.2f} {r['plan_s']:7.2f} {r['pc_s']:6.3f} {r['setup_s']:7.2f} {r['op_mb']:7.0f}"
        )
    print(
        "\nSolve: per iteration against the FFT floor (op.fft_only [+ preconditioner FFTs]); times are best of repeats"
    )
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
    p.add_argument(
        "--planner",
        choices=["FFTW_ESTIMATE", "FFTW_MEASURE", "FFTW_PATIENT"],
        help="planner effort for the operator (default: ConvolutionOperator's default)",
    )
    p.add_argument("--wisdom", action="store_true", help="load and save FFTW wisdom (planning then takes ms)")
    p.add_argument("--no-full-fft", dest="full_fft", action="store_false", help="skip the unpruned 2-D FFT reference")
    p.add_argument(
        "--cold",
        choices=["also", "only", "no"],
        default="also",
        help="the cold-versus-best-plan table (circle_tangential, PCG): also (default), only, no",
    )
    p.add_argument("--scenes", type=int, default=10, help="scenes of the cold sweep (default 10)")
    p.add_argument("--rounds", type=int, default=1, help="cold table: repeat it, keep each run's fastest (default 1)")
    p.add_argument(
        "--warm-start",
        type=int,
        metavar="N",
        help="only the warm-start experiment on N cells across (CG from the previous scene's traction)",
    )
    p.add_argument(
        "--code",
        nargs="+",
        default=[os.path.dirname(os.path.dirname(os.path.abspath(__file__)))],
        help="source trees to compare in the cold table, e.g. a `git worktree` of an older commit and "
        "this checkout (default: this checkout)",
    )
    harness.add_run_options(p, timeout=1800.0)
    args = p.parse_args(argv)
    print(f"solve_speed: {harness.machine_line(args.threads)}")
    if args.warm_start:
        warm_start(args.warm_start, args.tol)
        return 0

    print(
        f"tol {args.tol:g}; {args.clock} clock; "
        f"FFTW planning: {args.planner or 'default effort'}, {'with' if args.wisdom else 'without'} saved wisdom"
    )
    rows = []
    for n in args.n if args.cold != "only" else []:
        for case in args.cases:
            for solver in args.solvers:
                spec = {
                    "case": case,
                    "n": n,
                    "solver": solver,
                    "threads": args.threads,
                    "tol": args.tol,
                    "repeat": args.repeat,
                    "wisdom": args.wisdom,
                    "full_fft": args.full_fft,
                    "clock": args.clock,
                    "planner": args.planner,
                }
                r = harness.call_in_child(__file__, "child", spec, threads=args.threads, timeout=args.timeout).or_error(
                    spec
                )
                rows.append(r)
                if "error" in r:
                    print(f"  {case} n={n} {solver}: FAILED: {r['error']}", file=sys.stderr, flush=True)
                else:
                    print(
                        f"  {case} n={n} {solver}: {r['iterations']} iterations, {r['per_iter_ms']:.2f} ms/iter "
                        f"(floor {r['fft_floor_ms']:.2f}), setup {r['setup_s']:.2f} s, solve {r['solve_s']:.3f} s",
                        file=sys.stderr,
                        flush=True,
                    )
    if rows:
        print_tables(rows)
    cold = cold_table(args) if args.cold != "no" else []
    if args.json:
        harness.write_json(
            args.json, {"machine": harness.machine_line(args.threads), "clock": args.clock, "rows": rows, "cold": cold}
        )
    return 0 if all("error" not in r for r in rows + cold) else 1


def cold_table(args: argparse.Namespace) -> list[dict]:
    """For each n and source tree, side by side: the best-plan CG ms/iteration (FFTW_MEASURE
    plans made before the solves, best of ``--repeat``) and the ms/iteration users get in fresh
    processes: one ``hpcontact solve`` and a ``--scenes``-scene sweep on one grid, both without
    FFTW wisdom, and the same sweep again with the wisdom the first one saved."""
    import tempfile

    case, results = "circle_tangential", {}

    def measure(spec: dict, function: str) -> dict:
        """``function(spec)`` in a fresh process that imports hpcontact from ``spec["code"]``."""
        return harness.call_in_child(
            __file__, function, spec, threads=args.threads, timeout=args.timeout, env=code_environment(spec)
        ).or_error(spec)

    for round_ in range(args.rounds):
        with tempfile.TemporaryDirectory() as work:
            for n in args.n:
                for index, code in enumerate(args.code):
                    common = {
                        "case": case,
                        "n": n,
                        "threads": args.threads,
                        "tol": args.tol,
                        "clock": args.clock,
                        "code": code,
                        "scenes": args.scenes,
                    }
                    best = measure(
                        {
                            **common,
                            "solver": "PCG",
                            "repeat": args.repeat,
                            "wisdom": False,
                            "full_fft": False,
                            "planner": "FFTW_MEASURE",
                        },
                        "child",
                    )
                    wisdom = os.path.join(work, f"wisdom-{n}-{index}")
                    runs = {
                        "solve": {"mode": "solve", "wisdom_file": os.path.join(work, f"none-{n}-{index}")},
                        "sweep": {"mode": "sweep", "wisdom_file": wisdom},
                        "again": {"mode": "sweep", "wisdom_file": wisdom},
                    }
                    row = {"n": n, "code": code, "best": best}
                    for name, extra in runs.items():
                        row[name] = measure({**common, **extra}, "cold_child")
                    errors = "; ".join(f"{k}: {row[k]['error']}" for k in ("best", *runs) if "error" in row[k])
                    if errors:
                        row["error"] = errors
                    print(
                        f"  round {round_ + 1} n={n} {code}: "
                        + ", ".join(
                            f"{k} {row[k].get('per_iter_ms', float('nan')):.1f} ms/iter" for k in ("best", *runs)
                        ),
                        file=sys.stderr,
                        flush=True,
                    )
                    kept = results.get((n, code))
                    if kept is None or "error" in row:
                        results[(n, code)] = row if kept is None or "error" not in kept else kept
                    else:  # each run the fastest of the rounds: a shared machine only ever slows a run down
                        for name in ("best", *runs):
                            if row[name]["per_iter_ms"] < kept[name]["per_iter_ms"]:
                                kept[name] = row[name]
    print(
        f"\nCold, as users run it ({case}, PCG, tol {args.tol:g}): CG ms per iteration in fresh processes, "
        f"against the best plans; fastest of {args.rounds} round(s)"
    )
    print(
        f"{'code':>24s} {'n':>5s} {'best':>7s} {'plan s':>6s} {'b-even':>6s} | {'solve':>7s} {'ratio':>5s} | "
        f"{'sweep':>7s} {'ratio':>5s} {'iters':>5s} {'plan s':>6s} | {'again':>7s} {'ratio':>5s}"
    )
    for row in results.values():
        b = row["best"]
        if "error" in row:
            print(f"{row['code'][-24:]:>24s} {row['n']:5d} FAILED: {row['error']}")
            continue

        def cell(name: str, row: dict = row, b: dict = b) -> str:
            r = row[name]
            return f"{r['per_iter_ms']:7.1f} {r['per_iter_ms'] / b['per_iter_ms']:5.2f}"

        print(
            f"{row['code'][-24:]:>24s} {row['n']:5d} {b['per_iter_ms']:7.1f} {b['plan_s']:6.2f} {b['break_even']:6.0f} | "
            f"{cell('solve')} | {cell('sweep')} {row['sweep']['iterations']:5d} {row['sweep']['planning_s']:6.2f} | "
            f"{cell('again')}"
        )
    print(
        "best = CG ms/iteration with FFTW_MEASURE plans made before the solves (best of the repeats); plan s = that"
        "\nplanning; b-even = applications after which it pays (plan s / (ESTIMATE − MEASURE time per application));"
        "\nsolve = one `hpcontact solve` on a machine without FFTW wisdom; sweep = `hpcontact run` of"
        f" {args.scenes} scenes (nu 0 … 0.45)"
        "\non one grid, no wisdom (plan s: all FFTW planning of that process, inside the CG or not);"
        "\nagain = the same sweep with the wisdom the first saved; ratio = / best; each in its own fresh process."
    )
    return list(results.values())


if __name__ == "__main__":
    harness.entry(main)
