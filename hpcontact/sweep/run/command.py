"""``hpcontact run`` on every rank: the arguments checked, the run, its exit status, and FFTW
wisdom kept for the next run."""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from pathlib import Path

from hpcontact.errors import Front, InputError, rendered
from hpcontact.numerics.convolution import load_wisdom, save_wisdom
from hpcontact.numerics.memory import default_memory_per_rank, parse_memory
from hpcontact.sweep.cost.calibration_file import read_calibration
from hpcontact.sweep.run.arguments import EXIT_FAILED_TASKS, EXIT_OK, EXIT_REFUSED, EXIT_UNEXPECTED
from hpcontact.sweep.run.dry_run import dry_run
from hpcontact.sweep.run.options import MEM_PER_RANK
from hpcontact.sweep.run.records import NO_FLAGS, Options, Stopped, TaskFunction, runner_name
from hpcontact.sweep.run.rounds import execute
from hpcontact.sweep.run.schedule import LaunchError, world
from hpcontact.sweep.run.signals import DEFAULT_GRACE_S, DEFAULT_STALL_S, StopControl


def run_command(
    spec: str | Path,
    options: Options = NO_FLAGS,
    output: str | Path | None = None,
    grace_s: float | None = None,
    task_function: TaskFunction | None = None,
    prog: str = "hpcontact run",
    stall_s: float | None = None,
    accuracy: float | None = None,
    command: str | None = None,
) -> int:
    """``hpcontact run`` on every rank: the exit status (``EXIT_STATUS``). Refusals and bad
    input print one line on stderr from rank 0, prefixed ``prog``; any other error prints its
    traceback and, under MPI, aborts every rank (a rank left waiting in a collective would hang
    the job). ``task_function`` replaces the scene kind's solver (``python -m hpcontact.sweep.accuracy_study``);
    ``command`` is the command as its user typed it, for the data set's history."""
    try:
        team = world()
    except LaunchError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    stop = StopControl(
        DEFAULT_GRACE_S if grace_s is None else grace_s, DEFAULT_STALL_S if stall_s is None else stall_s
    ).install(team.rank)
    try:
        load_wisdom()  # FFTW plans of earlier runs: measured plans in milliseconds
        outcome = execute(
            spec, output, task_function, team=team, options=options, stop=stop, accuracy=accuracy, command=command
        )
        if not outcome.up_to_date:  # an up-to-date sweep planned nothing new
            _keep_wisdom()  # every rank: save_wisdom merges the ranks' plans into one file
        return EXIT_FAILED_TASKS if outcome.failures else EXIT_OK
    except InputError as exc:  # options in the command line's words ("pass --resume")
        if team.rank == 0:
            print(f"{prog}: error: {exc.worded(Front.COMMAND_LINE)}", file=sys.stderr)
        return EXIT_REFUSED
    except Stopped as exc:
        if team.rank == 0:
            print(rendered(exc.args[0], Front.COMMAND_LINE), file=sys.stderr)
        return exc.status
    except Exception:  # noqa: BLE001 - reported, then every rank is ended
        traceback.print_exc()
        team.abort(EXIT_UNEXPECTED)
        return EXIT_UNEXPECTED
    finally:
        stop.close()
        stop.uninstall()


def _keep_wisdom() -> None:
    """Save FFTW wisdom for the next run; a read-only home is no reason to fail a finished run."""
    try:
        save_wisdom()
    except OSError as exc:
        print(f"hpcontact: FFTW wisdom not saved ({exc})", file=sys.stderr)


def use_costmodel(path: str, dry_run: bool) -> None:
    """``--costmodel FILE``: the calibration the run and the dry run estimate with, as
    $HPCONTACT_COSTMODEL names it (set here, for this process: each rank parses the command
    line). A file that cannot be read as a calibration is refused (exit 2) with why; a missing
    one is where a dry run calibrates into, and refused for a run."""
    if not (dry_run and not os.path.lexists(path)):
        try:
            read_calibration(Path(path))
        except (OSError, ValueError, UnicodeDecodeError) as exc:
            why = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
            hint = "; hpcontact run SPEC --dry-run --costmodel FILE calibrates into it" if not dry_run else ""
            raise InputError("--costmodel", f"a cost-model calibration file ({why}{hint})", path) from None
    os.environ["HPCONTACT_COSTMODEL"] = str(Path(path).absolute())


def run_from_arguments(
    args: argparse.Namespace,
    task_function: TaskFunction | None = None,
    prog: str = "hpcontact run",
    command: str | None = None,
    runner: str | None = None,
) -> int:
    """Run what ``add_run_arguments`` parsed (``task_function``, ``prog``, ``command``: see
    ``run_command``; ``runner``: see ``Options.runner``, default ``records.runner_name`` of
    ``task_function``, so that a resume never reuses another task function's entries)."""
    memory = (
        (parse_memory(args.mem_per_rank, MEM_PER_RANK.flag), MEM_PER_RANK.flag)
        if args.mem_per_rank is not None
        else None
    )
    if args.costmodel is not None:
        use_costmodel(args.costmodel, args.dry_run)
    if args.dry_run:
        return dry_run(
            args.spec,
            args.output,
            as_json=args.json,
            mem_per_rank=None if memory is None else memory[0],
            list_all=args.list_all,
            accuracy=args.accuracy,
        )
    if args.json:
        raise InputError("--json", "only with --dry-run", True)
    if args.list_all:
        raise InputError("--list-all", "only with --dry-run", True)
    if args.grace is not None and not args.grace >= 0.0:
        raise InputError("--grace", "seconds >= 0", args.grace)
    if args.stall_timeout is not None and not args.stall_timeout >= 0.0:
        raise InputError("--stall-timeout", "seconds >= 0 (0: off)", args.stall_timeout)
    # up to date: a finished sweep run again exits 0 (the journals identify the code, not a task
    # function that replaces the spec's solver, so only the spec's own solver qualifies)
    options = Options(
        resume=args.resume,
        restart=args.restart,
        accept_stale=args.accept_stale,
        retry_crashed=args.retry_crashed,
        break_lock=args.break_lock,
        mem_per_rank=memory if memory is not None else default_memory_per_rank(),
        up_to_date=task_function is None,
        runner=runner if runner is not None else runner_name(task_function),
    )
    return run_command(
        args.spec, options, args.output, args.grace, task_function, prog, args.stall_timeout, args.accuracy, command
    )
