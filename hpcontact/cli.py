"""Command line: ``hpcontact solve``, ``hpcontact run``, ``hpcontact info`` (docs/design.md §4.1).

Bad input exits with status 2 and one line on stderr naming the field and the allowed range.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from typing import Any

import numpy
import pyfftw

from hpcontact import __version__
from hpcontact.accuracy import default_solve, solve_to_accuracy, task_function
from hpcontact.errors import ConvergenceError, InputError
from hpcontact.numerics.convolution import load_wisdom, save_wisdom, wisdom_path
from hpcontact.numerics.memory import parse_memory
from hpcontact.problems.kinds import SLIP, scene_kind
from hpcontact.scene import Scene
from hpcontact.sweep.arguments import add_run_arguments


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad option in one line (exit status 2), as the contract asks."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"hpcontact: {message}\n")


def _solve_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("solve", help="solve one scene")
    p.add_argument("--shape", default="circle", help="circle, ellipse, rectangle, polygon, star, rough, mask")
    p.add_argument("--aspect", type=float, help="b/a of ellipse or rectangle, in (0, 1]")
    p.add_argument("--sides", type=int, help="polygon sides or star lobes")
    p.add_argument("--shape-angle", type=float, help="turn the shape by this angle (degrees)")
    p.add_argument("--amplitude", type=float, help="star modulation epsilon of r = 1 + eps cos(k phi)")
    p.add_argument("--seed", type=int, help="seed of the rough surface")
    p.add_argument("--mask", help="contact mask file (.npy or .png) for --shape mask")
    p.add_argument("--nu", type=float, help="Poisson ratio, in [-1, 0.5]")
    p.add_argument("--G", type=float, help="shear modulus (default 1)")
    p.add_argument("--anisotropy", type=float, help="cubic anisotropy factor A (1 = isotropic)")
    p.add_argument("--orientation", type=float, help="surface normal along [110] -> [111] -> [001], psi in degrees")
    p.add_argument("--miller", help='surface normal as Miller indices "h k l"')
    p.add_argument("--azimuth", type=float, help="in-plane turn of the crystal (degrees)")
    p.add_argument(
        "--material",
        help="library crystal by name (Cu, Al, Fe, Ni, W, Si, ...); with --quantities slip: the isotropic "
        "body 1 (Cu, Fe/steel, Al, rigid) or a crystal as crystal:NAME",
    )
    p.add_argument("--cubic", help='cubic crystal "C11=... C12=... C44=..." (GPa)')
    p.add_argument("--orthotropic", help='orthotropic "E1=.. E2=.. E3=.. G12=.. G13=.. G23=.. nu12=.. nu13=.. nu23=.." (GPa)')
    p.add_argument("--voigt", help="general 6 x 6 Voigt stiffness, 36 numbers row by row (GPa)")
    p.add_argument("--n", type=int, help="cells along the long side")
    p.add_argument("--n-across", type=int, help="cells across the short side (thin shapes)")
    p.add_argument("--tol", type=float, help="CG relative residual tolerance")
    p.add_argument("--accuracy", type=float, help="extrapolate over grids until the estimated relative error <= REL")
    p.add_argument("--memory", help="memory budget of --accuracy, e.g. 2G (default: this machine's memory per core)")
    p.add_argument("--quantities", help="comma list: tangential, normal, compliance, coupled, indentation; or slip")
    p.add_argument("--radius", type=float, help="rigid sphere radius (indentation)")
    p.add_argument("--depth", type=float, help="rigid sphere approach (indentation)")
    p.add_argument("--threads", type=int, help="FFTW threads")
    p.add_argument("--no-precondition", action="store_true", help="plain CG (for comparison)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    slip = p.add_argument_group("partial slip (--quantities slip; see hpcontact.problems.slip.partial_slip)")
    for name, kind, text in SLIP_OPTIONS:
        if kind is bool:
            slip.add_argument(f"--{name.replace('_', '-')}", action="store_true", default=None, help=text)
        else:
            slip.add_argument(f"--{name.replace('_', '-')}", type=kind, help=text)


SLIP_OPTIONS = (
    ("radius_b", float, "second principal radius of body 1 (ellipsoid)"),
    ("radius2", float, "radius of body 2 (default: a flat)"),
    ("radius2_b", float, "second principal radius of body 2"),
    ("body2_angle", float, "angle between the principal axes of the bodies (degrees)"),
    ("material2", str, "body 2 by name (Cu, Fe/steel, Al, rigid)"),
    ("E", float, "Young's modulus of body 1"),
    ("E2", float, "Young's modulus of body 2"),
    ("G2", float, "shear modulus of body 2"),
    ("nu2", float, "Poisson ratio of body 2"),
    ("load", float, "normal load P (> 0)"),
    ("mu", float, "friction coefficient (>= 0)"),
    ("q_ratio", float, "tangential load Q/(mu P) in [0, 1)"),
    ("angle", float, "direction of the tangential load (degrees from x)"),
    ("steps", int, "tangential load steps"),
    ("control", str, "force or displacement"),
    ("displacement", float, "final tangential displacement (with --control displacement)"),
    ("path", str, "load (monotonic), loop (load, unload, reload) or proportional (normal load with the displacement)"),
    ("coupling", str, "auto, both, coupled or decoupled"),
    ("tensor", bool, "add the incremental 2 x 2 tangential stiffness tensor"),
    ("history", bool, "add every load step"),
    ("normal_friction", bool, "apply the normal load in steps with friction (Spence; coupled path)"),
    ("anisotropy2", float, "body 2: cubic anisotropy factor A (with --nu2 and --G2 or --E2)"),
    ("orientation2", float, "body 2: normal along [110] -> [111] -> [001], psi in degrees (lab frame)"),
    ("miller2", str, 'body 2: lattice direction "h k l" along the lab normal'),
    ("azimuth2", float, "body 2: in-plane turn of the crystal (degrees)"),
    ("cubic2", str, 'body 2: cubic crystal "C11=... C12=... C44=..." (GPa)'),
    ("orthotropic2", str, "body 2: orthotropic engineering constants (GPa), as --orthotropic"),
    ("voigt2", str, "body 2: general 6 x 6 Voigt stiffness, 36 numbers (GPa)"),
)


def _params(args: argparse.Namespace) -> dict[str, Any]:
    names = (
        "shape aspect sides shape_angle amplitude seed mask nu G anisotropy orientation miller azimuth "
        "material cubic orthotropic voigt n n_across tol quantities radius depth threads"
    ).split()
    params = {name: getattr(args, name) for name in names if getattr(args, name) is not None}
    if args.no_precondition:
        params["precondition"] = False
    return params


def _print_record(record: dict[str, Any]) -> None:
    for key, value in record.items():
        if isinstance(value, float):
            print(f"{key:>22s}  {value:.10g}")
        elif isinstance(value, dict):
            for sub, items in value.items():
                shown = ", ".join(map(str, items)) if isinstance(items, (list, tuple)) else items
                print(f"{key + '.' + sub:>22s}  {shown if shown != '' else '-'}")
        else:
            print(f"{key:>22s}  {value}")


def _cmd_solve(args: argparse.Namespace) -> int:
    load_wisdom()  # FFTW plans measured by earlier runs come back in milliseconds
    params = _params(args)
    slip_given = {name: getattr(args, name) for name, _, _ in SLIP_OPTIONS if getattr(args, name) is not None}
    kind = scene_kind(params)
    if kind == SLIP:  # the same dispatch as a sweep's (hpcontact.problems.kinds)
        params.pop("shape", None)
        params.update(slip_given)
    elif slip_given:
        field = next(iter(slip_given))
        raise InputError(field, "only with --quantities slip", slip_given[field])
    if args.memory is not None and args.accuracy is None:
        raise InputError("--memory", "only with --accuracy", args.memory)
    if args.accuracy is not None and kind != SLIP:
        budget = None if args.memory is None else parse_memory(args.memory, "--memory")
        record = solve_to_accuracy(Scene.from_params(params), args.accuracy, memory_budget=budget, strategy="auto")
    elif kind != SLIP:  # no --n: the extrapolated default where it applies (hpcontact.accuracy)
        record = default_solve(Scene.from_params(params))
    else:
        record = task_function(kind)(params)
    if args.json:
        print(json.dumps(record))
    else:
        _print_record(record)
    try:
        save_wisdom()
    except OSError as exc:  # a read-only home is no reason to fail a finished solve
        print(f"hpcontact: FFTW wisdom not saved ({exc})", file=sys.stderr)
    return 0


def _cmd_run(args: argparse.Namespace) -> int:
    # Imported here: the sweep imports mpi4py.MPI, which initializes MPI — ``hpcontact solve``
    # and ``hpcontact info`` must run where no MPI launcher is set up.
    from hpcontact.sweep.driver import run_from_arguments

    return run_from_arguments(args)


def _cmd_info(args: argparse.Namespace) -> int:
    info = {"hpcontact": __version__, "numpy": numpy.__version__, "pyfftw": pyfftw.__version__}
    try:  # imported here: importing mpi4py.MPI initializes MPI
        import mpi4py
        from mpi4py import MPI

        info["mpi4py"] = mpi4py.__version__
        info["mpi_library"] = MPI.Get_library_version().splitlines()[0].strip()
    except ImportError as exc:  # mpi4py is a dependency, but report rather than crash
        info["mpi4py"] = f"unavailable ({exc})"
    info["fftw_wisdom"] = str(wisdom_path())
    for key, value in info.items():
        print(f"{key:>12s}  {value}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = _Parser(prog="hpcontact", description="Anisotropy of contact stiffness (FFT-BEM).")
    parser.add_argument("--version", action="version", version=f"hpcontact {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _solve_parser(sub)
    add_run_arguments(sub.add_parser("run", help="run a sweep spec (under mpiexec or alone)"))
    sub.add_parser("info", help="versions, MPI library, FFTW wisdom location")
    args = parser.parse_args(argv)
    command = {"solve": _cmd_solve, "run": _cmd_run, "info": _cmd_info}[args.command]
    try:
        return command(args)
    except InputError as exc:
        print(f"hpcontact: error: {exc}", file=sys.stderr)
        return 2
    except ConvergenceError as exc:
        print(f"hpcontact: did not converge: {exc}", file=sys.stderr)
        return 1
    except FloatingPointError as exc:
        print(f"hpcontact: numerical failure: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # `hpcontact run SPEC --dry-run | head`: the reader has enough
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return 141  # 128 + SIGPIPE, what a shell reports for a command ended by a closed pipe


if __name__ == "__main__":
    sys.exit(main())
