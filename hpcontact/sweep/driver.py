"""The sweep driver: spec → tasks → ranks → journals → data set (``hpcontact run``).

``run_sweep`` is collective: every rank of the team calls it. Rank 0 reads and checks the spec;
every rank enumerates the tasks of its share of the parameter space and validates each distinct
scene of it, and rank 0 joins the shares (``tasks.join_parts``), so a bad scene is refused, naming
its spec key, before any rank starts work, at a cost spread over the ranks. Rank 0 refuses an unusable output
(``guard``), takes the output's lock, reads the journals of earlier runs and decides what to
run: a task whose last outcome is ok or bad input (deterministic) is reused, one that failed
(error, non-convergence) is run again, one started in ``journal.CRASH_RUNS`` runs that died
while running it is quarantined (status crashed; ``retry_crashed`` runs it again), and one
started in a single such run (a suspect) is run by rank 0 alone before it joins the shared
chunks, so that a second death names the culprit and not the tasks that happened to run beside
it. Existing journals need ``resume`` (continue) or ``restart`` (discard them), unless the
data set is ``up_to_date`` and the caller allows that (``hpcontact run``, ``hpcontact.run_sweep``:
one line, nothing run or written); entries computed
by another package version, git revision or numerics fingerprint are refused unless
``accept_stale`` (``provenance``). The ranks then take chunks of tasks from a shared counter
(``schedule``), journal each task as started before it runs and its outcome after (``journal``;
synced every few seconds), and stop together on a signal (``signals``); finally every rank turns
the outcomes it journaled into columns (``columns``) and rank 0 joins them with the outcomes
reused from earlier journals into the data set (the last outcome of each task, and the
provenance of every code that contributed) and writes it atomically. A task that raises is journaled with its status and
message and the sweep goes on. The spec's scene kind (``problems.kinds``; its solver ``accuracy.task_function``) picks the task function and the
scene validator. ``HPCONTACT_FAULTS`` injects faults for tests (``faults``).

``run_command`` is ``hpcontact run`` (exit status, see ``EXIT_STATUS``; errors reported once;
MPI abort on an unexpected error); ``dry_run`` is ``hpcontact run SPEC --dry-run``; ``main(argv)``
parses the arguments (``python -m hpcontact.sweep``). All run on every rank under ``mpiexec``.

This module is the public face of the run; its roles are the modules of ``hpcontact.sweep.run``:
``records`` (options, decision, outcome), ``shares`` (the ranks' shares joined), ``resume``
(rank 0's decision from the journals, ``prepare``), ``rounds`` (``execute``: the MPI rounds),
``assembly`` and ``summary`` (rank 0's data set and its summary), ``dry_run`` and ``command``.
``run_sweep`` and ``main`` are defined here; each passes the command as its user gave it to
the data set's history (``provenance.call_text``, ``provenance.command_line``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import TextIO

from hpcontact.errors import InputError
from hpcontact.sweep.data.provenance import call_text, command_line
from hpcontact.sweep.run.arguments import EXIT_REFUSED, add_run_arguments
from hpcontact.sweep.run.command import run_from_arguments
from hpcontact.sweep.run.records import Options, TaskFunction, runner_name
from hpcontact.sweep.run.rounds import execute
from hpcontact.sweep.run.schedule import Team
from hpcontact.sweep.run.signals import StopControl
from hpcontact.sweep.space.spec import Validator


def run_sweep(
    spec_path: str | Path,
    resume: bool = False,
    output: str | Path | None = None,
    task_function: TaskFunction | None = None,
    *,
    team: Team | None = None,
    validate: Validator | None = None,
    stream: TextIO | None = None,
    options: Options | None = None,
    stop: StopControl | None = None,
    accuracy: float | None = None,
) -> Path:
    """Run the sweep of ``spec_path`` on ``team`` (default: MPI world, or one process) and return
    the path of the data set written (see ``execute``). Its journal entries name the runner of
    ``options`` (``Options.runner``; default: ``records.runner_name`` of ``task_function``, its
    module and qualified name, or the spec's scene kind's own solver), and a resume reuses only
    the entries of that runner: two task functions are one runner only where the caller names
    them so."""
    command = call_text("hpcontact.sweep.driver.run_sweep", run_sweep, locals())
    options = options if options is not None else Options(resume=resume)
    if options.runner is None:
        options = replace(options, runner=runner_name(task_function))
    return execute(
        spec_path,
        output,
        task_function,
        team=team,
        validate=validate,
        stream=stream,
        options=options,
        stop=stop,
        accuracy=accuracy,
        command=command,
    ).path


def main(
    argv: Sequence[str] | None = None,
    prog: str = "hpcontact run",
    description: str = "Run a parameter sweep (under mpiexec or alone).",
    task_function: TaskFunction | None = None,
    default_output: Callable[[str], str | None] | None = None,
    runner: str | None = None,
) -> int:
    """``python -m hpcontact.sweep SPEC [options]`` (see ``add_run_arguments``); another
    ``task_function`` makes another command with the same options and exit statuses
    (``python -m hpcontact.sweep.accuracy_study``), ``runner`` the name its journal entries give
    their results (``Options.runner``) and ``default_output(SPEC)`` its output when ``--output``
    is not given (None: the spec's)."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    add_run_arguments(parser)
    command = command_line(prog if argv is not None else "hpcontact run", argv)
    args = parser.parse_args(argv)
    try:
        if args.output is None and default_output is not None:
            args.output = default_output(args.spec)
        return run_from_arguments(args, task_function, prog, command, runner)
    except InputError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_REFUSED
