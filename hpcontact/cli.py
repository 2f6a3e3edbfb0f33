"""Command line: ``hpcontact solve``, ``hpcontact run``, ``hpcontact info`` (docs/design.md §4.1).

Bad input exits with status 2 and one line on stderr naming the field and the allowed range; an
unknown option or command names the closest known one ("did you mean --aspect?"). ``hpcontact
solve`` and ``hpcontact.solve`` share one dispatch (``api.solve_fields``); ``hpcontact solve
--help`` shows each option's default, grouped (scene, material, numerics, output, partial slip),
and examples.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import re
import signal
import sys
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy

from hpcontact import __version__
from hpcontact.accuracy.refinement import LevelProgress, reporting_levels
from hpcontact.api import solve_fields
from hpcontact.errors import AccuracyWarning, ConvergenceError, Front, InputError, did_you_mean
from hpcontact.fields import CONTACT, Field, cli_fields, cli_help, names
from hpcontact.numerics.convolution import load_wisdom, pyfftw, save_wisdom, wisdom_path
from hpcontact.sweep.data.show import add_show_arguments, show_command
from hpcontact.sweep.data.units import factors
from hpcontact.sweep.run.arguments import add_run_arguments

#: The scene fields of ``hpcontact solve`` (``--no-precondition`` for ``precondition``;
#: ``--accuracy`` goes to the solve beside them) and its partial-slip options, as
#: ``hpcontact.solve`` takes them: the field schema's (``hpcontact.fields``).
FIELDS = tuple(name for name in names(CONTACT) if name != "accuracy")
SLIP_OPTIONS = tuple(f.name for f in cli_fields("slip"))

EXAMPLES = """examples:
  hpcontact solve --shape ellipse --aspect 0.3 --nu 0.3      one scene: K of an ellipse to 1e-4 or better
  hpcontact solve --help                                     its options, defaults and examples
  mpiexec -n 2 hpcontact run jobs/demo.toml                  a sweep (run again: up to date, nothing to do)
  hpcontact run jobs/demo.toml --dry-run                     its tasks and cost; nothing computed
  hpcontact info                                             versions, MPI library, FFTW wisdom"""

SOLVE_EXAMPLES = """examples:
  hpcontact solve --shape ellipse --aspect 0.3 --nu 0.3
      tangential stiffness of an ellipse b/a = 0.3, as --accuracy 1e-4 (its one exact cell: round-off)
  hpcontact solve --shape ellipse --aspect 0.1 --accuracy 1e-6 --json
      to an estimated relative error of 1e-6, one JSON object
  hpcontact solve --shape rectangle --aspect 1e-4 --n 512 --n-across 16 --quantities tangential,normal
      one grid: 512 cells along, 16 across; with K_zz and Li's normalization
  hpcontact solve --material Cu --miller "1 1 0" --quantities tangential,normal
      a copper crystal with its (110) plane in contact (K in GPa a)
  hpcontact solve --quantities indentation --radius 1 --depth 0.01 --n 64
      rigid sphere on the half-space (load in G L2, L the unit of the radius)
  hpcontact solve --quantities slip --radius 0.01 --load 100 --mu 0.3 --q-ratio 0.5 --material steel
      partial slip of a steel sphere on a rigid flat (SI units: N, m)

units: K in G a (G the shear modulus, a the semi-major extent of the contact, 1 on the grid);
GPa a when the material is a library crystal or constants in GPa; the text output names each
value's unit."""


class _Parser(argparse.ArgumentParser):
    """argparse that reports a bad option in one line (exit status 2), as the contract asks, and
    names the closest known option or command."""

    def error(self, message: str) -> None:  # type: ignore[override]
        choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if choice:
            message += did_you_mean(choice.group(1), re.findall(r"'([^']*)'", choice.group(2)))
        self.exit(2, f"hpcontact: {message}\n")

    def parse_args(self, args: Sequence[str] | None = None, namespace: Any = None) -> argparse.Namespace:  # type: ignore[override]
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}{self._suggestion(extras, parsed)}")
        return parsed

    def _suggestion(self, extras: Sequence[str], parsed: argparse.Namespace) -> str:
        """ "; did you mean --aspect?" for the first unknown option, among the options of the
        command given (else of this parser)."""
        parser: argparse.ArgumentParser = self
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction) and getattr(parsed, "command", None) in action.choices:
                parser = action.choices[parsed.command]
        known = [option for action in parser._actions for option in action.option_strings if option.startswith("--")]
        for extra in extras:
            if extra.startswith("--"):
                return did_you_mean(extra.split("=", 1)[0], known)
        return ""


def _option(name: str) -> str:
    return f"--{name.replace('_', '-')}"


def _add_field(group: argparse._ArgumentGroup, f: Field) -> None:
    """The option of the field ``f`` (``hpcontact.fields``): a number parsed as its type, a
    boolean as a flag that sets the value other than its default (``--no-precondition``), any
    other value as text."""
    if f.type is bool:
        group.add_argument(
            f.cli_option, dest=f.name, action="store_const", const=not f.default, default=None, help=cli_help(f.name)
        )
    else:
        numeric = {"type": f.type} if f.type in (int, float) else {}
        group.add_argument(f.cli_option, **numeric, metavar=f.metavar, help=cli_help(f.name))


def _solve_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "solve",
        help="solve one scene",
        description="Solve one scene: the stiffness of a bonded punch (or a rigid "
        "sphere,\nor partial slip of two bodies) on an elastic half-space.",
        epilog=SOLVE_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    groups = {
        "scene": p.add_argument_group("scene (lengths in units of a, the semi-major extent of the contact)"),
        "material": p.add_argument_group(
            "material (isotropic unless a crystal is named or A != 1)",
            "--nu, --G and --anisotropy describe the body only without --material, --cubic,\n"
            "--orthotropic or --voigt (beside one of them they are refused); --orientation,\n"
            "--miller and --azimuth turn any crystal",
        ),
        "numerics": p.add_argument_group("numerics"),
    }
    for group, arguments in groups.items():
        for f in cli_fields(group):
            _add_field(arguments, f)

    output = p.add_argument_group("output")
    output.add_argument(
        "--json", action="store_true", help="print one JSON object (default: one value per line, with its unit)"
    )
    output.add_argument(
        "--verbose",
        action="store_true",
        help="text output: also the per-grid diagnostics (levels; --json always has them)",
    )

    slip = p.add_argument_group("partial slip (--quantities slip; see hpcontact.problems.slip.partial_slip)")
    for f in cli_fields("slip"):
        _add_field(slip, f)


def _params(args: argparse.Namespace) -> dict[str, Any]:
    return {name: getattr(args, name) for name in FIELDS if getattr(args, name) is not None}


#: Exponents as the text output writes them (a² rather than UDUNITS' a2).
_SUPERSCRIPTS = str.maketrans("0123456789-", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻")


def _shown_unit(unit: str) -> str:
    """A record's unit (``record["units"]``, UDUNITS syntax) as the text output writes it: "G a"
    → "G·a", "N m-1" → "N/m", "G L2" → "G·L²", "degree" → "deg"; "1" (ratios, counts) → ""."""
    if unit == "1":
        return ""
    if unit == "degree":
        return "deg"
    over = [(symbol, power) for symbol, power in factors(unit) if power < 0]
    shown = "·".join(
        symbol + (str(power).translate(_SUPERSCRIPTS) if power != 1 else "")
        for symbol, power in factors(unit)
        if power > 0
    )
    return shown + "".join(
        f"/{symbol}" + (str(-power).translate(_SUPERSCRIPTS) if power != -1 else "") for symbol, power in over
    )


def _shown(value: Any) -> str:
    """A value as the text output shows it: a float to 10 digits, a list joined by commas."""
    if isinstance(value, float):
        return f"{value:.10g}"
    if isinstance(value, (list, tuple)):
        return ", ".join(f"[{_shown(v)}]" if isinstance(v, (list, tuple)) else _shown(v) for v in value) or "-"
    return str(value)


#: Record keys shown in text only with ``--verbose`` (``--json`` always has them).
DIAGNOSTICS = ("levels",)


def _diagnostic(key: str, value: Any) -> bool:
    """Whether a record value is a raw diagnostic (``DIAGNOSTICS``: the per-grid ``levels`` of
    an extrapolated solve; any list of mappings or lists), shown in text only with ``--verbose``."""
    nested = isinstance(value, (list, tuple)) and any(isinstance(v, (Mapping, list, tuple)) for v in value)
    return key in DIAGNOSTICS or nested


def _print_record(record: dict[str, Any], verbose: bool = False) -> None:
    """The record as text, one value per line with its unit (the record's ``units``, as
    ``_shown_unit`` writes it), then what the unit symbols mean. Raw diagnostics
    (``_diagnostic``: ``levels``) only when ``verbose``, one line per item."""
    units = {key: _shown_unit(unit) for key, unit in record.get("units", {}).items()}
    units = {key: unit for key, unit in units.items() if unit}
    for key, value in record.items():
        if key == "units":
            continue
        unit = f"  {units[key]}" if units.get(key) else ""
        if _diagnostic(key, value):
            if verbose and not value:
                print(f"{key:>22s}  -")
            for i, item in enumerate(value if verbose else ()):
                items = item.items() if isinstance(item, Mapping) else enumerate(item)
                print(f"{f'{key}[{i}]':>22s}  {', '.join(f'{k} {_shown(v)}' for k, v in items)}")
        elif isinstance(value, float):
            print(f"{key:>22s}  {value:.10g}{unit}")
        elif isinstance(value, dict):
            for sub, items in value.items():
                shown = _shown(items)
                print(f"{key + '.' + sub:>22s}  {shown if shown != '' else '-'}")
        elif isinstance(value, (list, tuple)):
            print(f"{key:>22s}  {_shown(value)}{unit}")
        else:
            print(f"{key:>22s}  {value}{unit}")
    symbols = " ".join(units.values())
    legend = [
        text
        for symbol, text in (
            ("G", "G: shear modulus"),
            ("GPa", "GPa: the crystal's constants"),
            ("a", "a: semi-major extent of the contact (1 on the grid)"),
            ("L", "L: the unit of the radius"),
            ("F", "F: the force unit of the input"),
        )
        if re.search(rf"(?<![\w]){symbol}(?![a-zA-Z])", symbols)
    ]
    if legend:
        print(f"{'units':>22s}  {'; '.join(legend)}")


def _cmd_solve(args: argparse.Namespace) -> int:
    load_wisdom()  # FFTW plans measured by earlier runs come back in milliseconds
    params = _params(args)
    slip = {name: getattr(args, name) for name in SLIP_OPTIONS}
    # a refinement past a few seconds: a line per grid on a terminal's stderr (a log or a pipe gets the result only)
    levels = reporting_levels(LevelProgress()) if sys.stderr.isatty() else contextlib.nullcontext()
    with warnings.catch_warnings(record=True) as caught, levels:  # a missed default accuracy: one line, exit 1
        warnings.simplefilter("always", AccuracyWarning)
        record = solve_fields(params, slip, accuracy=args.accuracy, memory=args.memory, name=_option)
    missed = [str(w.message) for w in caught if issubclass(w.category, AccuracyWarning)]
    for w in caught:
        if not issubclass(w.category, AccuracyWarning):
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    if args.json:
        print(json.dumps(record))
    else:
        _print_record(record, verbose=args.verbose)
    try:
        save_wisdom()
    except OSError as exc:  # a read-only home is no reason to fail a finished solve
        print(f"hpcontact: FFTW wisdom not saved ({exc})", file=sys.stderr)
    for message in missed:  # the record above is what was reached; a missed tolerance exits 1
        print(f"hpcontact: {message}", file=sys.stderr)
    return 1 if missed else 0


def _cmd_run(args: argparse.Namespace) -> int:
    # Imported here: the sweep imports mpi4py.MPI, which initializes MPI — ``hpcontact solve``
    # and ``hpcontact info`` must run where no MPI launcher is set up.
    from hpcontact.sweep.data.provenance import command_line
    from hpcontact.sweep.run.command import run_from_arguments

    return run_from_arguments(args, command=command_line("hpcontact", args.argv))


def _cmd_info(args: argparse.Namespace) -> int:
    """What a support ticket needs: versions (hpcontact, numpy, scipy, pyFFTW, mpi4py and the MPI
    library), the CPU and its cores, the devices a solve can use (CuPy and its GPUs, if any), FFTW
    wisdom's file."""
    import scipy

    from hpcontact.numerics.backend import gpu_description
    from hpcontact.scene import usable_cpus
    from hpcontact.sweep.cost.rates import cpu_model

    info = {
        "hpcontact": __version__,
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "pyfftw": pyfftw.__version__,
    }
    try:  # imported here: importing mpi4py.MPI initializes MPI
        import mpi4py
        from mpi4py import MPI

        info["mpi4py"] = mpi4py.__version__
        info["mpi_library"] = MPI.Get_library_version().splitlines()[0].strip()
    except ImportError as exc:  # mpi4py is a dependency, but report rather than crash
        info["mpi4py"] = f"unavailable ({exc})"
    info["cpu"] = cpu_model()  # as calibrations are matched by it
    info["cores"] = f"{os.cpu_count()} ({usable_cpus()} usable by this process)"
    devices, *details = gpu_description()
    info["devices"] = devices
    info["fftw_wisdom"] = str(wisdom_path())
    for key, value in info.items():
        print(f"{key:>12s}  {value}")
    for line in details:
        print(f"{'':>12s}  {line}")
    return 0


RUN_EXAMPLES = """examples:
  mpiexec -n 2 hpcontact run jobs/demo.toml            run the sweep; run again: up to date, nothing to do
  hpcontact run jobs/demo.toml --dry-run               the tasks and their estimated cost; nothing computed
  mpiexec -n 64 hpcontact run jobs/x.toml --resume     continue after a stop (exit 4) or a failure
  hpcontact run jobs/demo.toml --output /tmp/d.nc      another data set (and journal folder)"""


def parser() -> argparse.ArgumentParser:
    """The ``hpcontact`` argument parser."""
    top = _Parser(
        prog="hpcontact",
        description="Anisotropy of contact stiffness (FFT-BEM).",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    top.add_argument("--version", action="version", version=f"hpcontact {__version__}")
    sub = top.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _solve_parser(sub)
    run = sub.add_parser("run", help="run a sweep spec (under mpiexec or alone)")
    add_run_arguments(run)
    run.epilog = f"{RUN_EXAMPLES}\n\n{run.epilog}" if run.epilog else RUN_EXAMPLES
    run.formatter_class = argparse.RawDescriptionHelpFormatter
    sub.add_parser("info", help="versions, MPI library, FFTW wisdom location")
    add_show_arguments(sub.add_parser("show", help="summarize a sweep's data set (axes, failures, errors, provenance)"))
    return top


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)
    args.argv = argv  # as given: a sweep's history records the command (None: this process's)
    command = {"solve": _cmd_solve, "run": _cmd_run, "info": _cmd_info, "show": show_command}[args.command]
    try:
        return command(args)
    except InputError as exc:
        print(f"hpcontact: error: {exc.worded(Front.COMMAND_LINE)}", file=sys.stderr)
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
    except KeyboardInterrupt:  # Ctrl-C in `hpcontact solve` (a sweep handles SIGINT as a stop request)
        print("hpcontact: interrupted", file=sys.stderr)
        return 130  # 128 + SIGINT


def console_main() -> None:
    """The ``hpcontact`` command (and ``python -m hpcontact``): ``main``, then exit with its
    status. A stop request that arrives once the work is done (a batch system's SIGTERM at the
    end of a job, a late Ctrl-C) is ignored: it must not turn a finished run into a death by
    signal."""
    status = main()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, signal.SIG_IGN)
    sys.exit(status)


if __name__ == "__main__":
    console_main()
