"""The sweep driver: spec → tasks → ranks → journals → data set (``hpcontact run``).

``run_sweep`` is collective: every rank of the team calls it. Rank 0 reads and checks the spec
(every distinct scene is validated before any rank starts work), enumerates the tasks and
reads the journals of earlier runs (``resume``) or clears them (fresh run); the ranks then take
chunks of tasks from a shared counter (``schedule``) and journal each finished task; finally
rank 0 assembles the data set from all journals and writes it atomically. A task that raises is
journaled with its status and message and the sweep goes on. The spec's scene kind (``kinds``:
contact, or slip for ``quantities = "slip"``) picks the task function and the scene validator.

``run_command(spec, resume, output)`` is ``hpcontact run SPEC [--resume] [--output PATH]`` (exit
status, errors reported once, MPI abort on an unexpected error); ``main(argv)`` parses those
arguments (``python -m hpcontact.sweep``). Both run on every rank under ``mpiexec``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import subprocess
import sys
import time
import traceback
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence, TextIO

from .. import __version__
from ..errors import ConvergenceError, InputError
from ..operator import load_wisdom, save_wisdom
from . import kinds
from .dataset import NOT_COMPUTED, build_dataset, write_netcdf
from .journal import (
    BAD_INPUT,
    ERROR,
    NOT_CONVERGED,
    OK,
    Entry,
    Journal,
    clear_journals,
    read_journals,
    session_name,
    to_json,
)
from .progress import Progress, Summary
from .schedule import SLOTS, Team, claimed_chunks, report_done, totals_done, world
from .spec import Spec, Validator, load_spec
from .tasks import Task, enumerate_tasks, make_chunks

TaskFunction = Callable[[Mapping[str, Any]], Mapping[str, Any]]
SHOWN_FAILURES = 5


def run_task(function: TaskFunction, task: Task, rank: int) -> Entry:
    """Call ``function`` on the task's parameters; any exception becomes a failed entry."""
    started = time.perf_counter()
    status, message, record = OK, "", {}
    try:
        result = function(dict(task.params))
        if not isinstance(result, Mapping):
            raise TypeError(f"the task function returned {type(result).__name__}, not a mapping")
        record = json.loads(to_json(result))  # exactly what the journal will hold
    except InputError as exc:
        status, message = BAD_INPUT, f"InputError: {exc}"
    except ConvergenceError as exc:
        status, message = NOT_CONVERGED, f"ConvergenceError: {exc}"
    except Exception as exc:  # noqa: BLE001 - any failure of one scene is recorded, the sweep goes on
        status, message = ERROR, f"{type(exc).__name__}: {exc}"
    return Entry(
        key=task.key,
        params=task.params,
        status=status,
        message=message,
        record=record,
        wall_time_s=time.perf_counter() - started,
        finished=time.time(),
        rank=rank,
    )


def git_revision() -> str | None:
    """The commit of the source checkout hpcontact runs from, if it is one."""
    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists():
        return None
    try:
        done = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10, check=True
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() or None


def _setup(
    spec_path: str | Path, resume: bool, output: str | Path | None, validate: Validator | None
) -> tuple[Spec, list[Task], dict[tuple[int, ...], str], set[str], str]:
    """Rank 0's preparation: checked spec, tasks, point → task map, keys already journaled, session."""
    spec = load_spec(spec_path, output=output, validate=validate)
    tasks, where = enumerate_tasks(spec)
    if resume:
        keys = {t.key for t in tasks}
        done = {key for key in read_journals(spec.journal) if key in keys}
    else:
        clear_journals(spec.journal)
        done = set()
    return spec, tasks, where, done, session_name()


def _shared(team: Team, make: Callable[[], Any]) -> Any:
    """``make()`` on rank 0, its value (or its exception) on every rank."""
    value, error = None, None
    if team.rank == 0:
        try:
            value = make()
        except InputError as exc:
            error = ("input", (exc.field, exc.allowed, exc.value), exc)
        except Exception as exc:  # noqa: BLE001 - re-raised on every rank below
            error = ("other", f"{type(exc).__name__} on rank 0: {exc}", exc)
    value, shared_error = team.bcast((value, None if error is None else error[:2]))
    if shared_error is not None:
        if team.rank == 0:
            raise error[2]
        kind, detail = shared_error
        raise InputError(*detail) if kind == "input" else RuntimeError(detail)
    return value


def run_sweep(
    spec_path: str | Path,
    resume: bool = False,
    output: str | Path | None = None,
    task_function: TaskFunction | None = None,
    *,
    team: Team | None = None,
    validate: Validator | None = None,
    stream: TextIO | None = None,
) -> Path:
    """Run the sweep of ``spec_path`` on ``team`` (default: MPI world, or one process) and return
    the path of the data set written.

    ``resume`` skips every task any journal of this output holds (else the journals are
    cleared); ``output`` overrides the spec's output path; ``task_function`` solves one scene
    and ``validate`` checks one scene's parameters (defaults: those of the spec's scene kind,
    ``kinds``: ``hpcontact.solve.solve`` and ``hpcontact.scene.validate``, or
    ``hpcontact.slip.solve_slip`` and ``hpcontact.slip.validate`` for ``quantities = "slip"``);
    rank 0 prints progress and the summary to ``stream`` (default stdout). Spec errors raise
    ``InputError`` on every rank before any work starts.
    """
    team = team if team is not None else world()
    started = time.perf_counter()  # after the imports and MPI start-up
    stream = stream if stream is not None else sys.stdout
    where: dict[tuple[int, ...], str] = {}  # point -> task key, on rank 0 only

    def prepare() -> tuple[Spec, list[Task], set[str], str]:
        spec, tasks, points, done, session = _setup(spec_path, resume, output, validate)
        where.update(points)
        return spec, tasks, done, session

    spec, tasks, done, session = _shared(team, prepare)
    if task_function is None:
        task_function = kinds.task_function(spec.kind)
    todo = [t for t in tasks if t.key not in done]
    chunks = make_chunks(todo, team.size)
    setup_s = time.perf_counter() - started

    progress = None
    if team.rank == 0:
        print(
            f"hpcontact: {spec.title}: {len(tasks)} tasks, {len(todo)} to run"
            f"{f' ({len(done)} from journals)' if done else ''}, {len(chunks)} chunks on {team.size} rank(s)",
            file=stream,
            flush=True,
        )
        progress = Progress(len(tasks), len(done), sum(t.cost for t in todo), spec.progress_interval, stream)

    task_s = schedule_s = journal_s = 0.0
    run = 0
    counter = team.counter(SLOTS)
    journal = Journal(
        spec.journal / f"rank{team.rank:05d}-{session}.h5",
        team.rank,
        {"session": session, "spec_path": str(spec.path), "hpcontact_version": __version__, "pid": os.getpid()},
    )
    try:
        claim = time.perf_counter()
        for chunk in claimed_chunks(chunks, counter):
            schedule_s += time.perf_counter() - claim
            for task in chunk:
                entry = run_task(task_function, task, team.rank)
                task_s += entry.wall_time_s
                run += 1
                mark = time.perf_counter()
                journal.append(entry)
                journal_s += time.perf_counter() - mark
                mark = time.perf_counter()
                report_done(counter, task.cost)
                schedule_s += time.perf_counter() - mark
                if progress is not None and progress.due():
                    progress.report(*totals_done(counter))
            claim = time.perf_counter()
        schedule_s += time.perf_counter() - claim
    finally:
        journal.close()
    counter.close()
    totals = team.gather((task_s, run, schedule_s, journal_s))

    def assemble() -> Path:
        gather_started = time.perf_counter()
        entries = read_journals(spec.journal)
        keys = {t.key for t in tasks}
        failures = [e for key, e in entries.items() if key in keys and e.status != OK]
        dataset = build_dataset(
            spec,
            where,
            entries,
            {
                "hpcontact_version": __version__,
                "git_revision": git_revision(),
                "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                "mpi_size": team.size,
                "history": f"hpcontact run {spec.path}{' --resume' if resume else ''}",
            },
        )
        now = time.perf_counter()
        summary = Summary(
            tasks=len(tasks),
            points=math.prod(len(a) for a in spec.axes),
            run=sum(t[1] for t in totals),
            reused=len(done),
            failures=len(failures),
            ranks=team.size,
            wall_s=now - started,
            task_s=sum(t[0] for t in totals),
            setup_s=setup_s,
            schedule_s=sum(t[2] for t in totals),
            journal_s=sum(t[3] for t in totals),
            gather_s=now - gather_started,
        )
        dataset.attrs.update(summary.attrs())
        path = write_netcdf(dataset, spec.output)
        shown = [f"{json.dumps(dict(e.params), sort_keys=True)}: {e.message}" for e in failures[:SHOWN_FAILURES]]
        print(summary.text(shown), file=stream)
        missing = len(keys - entries.keys())
        if missing:
            print(
                f"hpcontact: warning: {missing} tasks are in no journal (status {NOT_COMPUTED} in the data set); "
                f"is {spec.journal} on a file system every node shares?",
                file=stream,
            )
        print(f"hpcontact: wrote {path} in {time.perf_counter() - now:.2f}s", file=stream, flush=True)
        return path

    return _shared(team, assemble)


def run_command(spec: str | Path, resume: bool = False, output: str | Path | None = None) -> int:
    """``hpcontact run`` on every rank: the exit status, 0 or 2 on a bad spec (one line on
    stderr from rank 0, naming the key). Any other error prints its traceback and, under MPI,
    aborts every rank (a rank left waiting in a collective would hang the job)."""
    team = world()
    load_wisdom()  # FFTW plans of earlier runs: measured plans in milliseconds
    try:
        run_sweep(spec, resume=resume, output=output, team=team)
    except InputError as exc:
        if team.rank == 0:
            print(f"hpcontact run: error: {exc}", file=sys.stderr)
        return 2
    except Exception:  # noqa: BLE001 - reported, then every rank is ended
        traceback.print_exc()
        team.abort(1)
        return 1
    if team.rank == 0:
        _keep_wisdom()
    return 0


def _keep_wisdom() -> None:
    """Save FFTW wisdom for the next run; a read-only home is no reason to fail a finished run."""
    try:
        save_wisdom()
    except OSError as exc:
        print(f"hpcontact: FFTW wisdom not saved ({exc})", file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m hpcontact.sweep SPEC [--resume] [--output PATH]`` (see ``run_command``)."""
    parser = argparse.ArgumentParser(prog="hpcontact run", description="Run a parameter sweep (under mpiexec or alone).")
    parser.add_argument("spec", help="sweep spec (TOML), e.g. jobs/demo.toml")
    parser.add_argument("--resume", action="store_true", help="skip every task the journals of this output hold")
    parser.add_argument("--output", help="data set path (.nc), instead of the spec's [sweep].output")
    args = parser.parse_args(argv)
    return run_command(args.spec, resume=args.resume, output=args.output)
