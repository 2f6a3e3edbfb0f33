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
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import pickle
import sys
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from hpcontact import accuracy
from hpcontact.errors import ConvergenceError, InputError
from hpcontact.numerics.blas import limited_blas
from hpcontact.numerics.convolution import expect_applications, load_wisdom, save_wisdom
from hpcontact.numerics.memory import default_memory_per_rank, parse_memory
from hpcontact.problems.footprint import fft_applications
from hpcontact.sweep import costmodel, faults, provenance
from hpcontact.sweep.arguments import (
    EXIT_FAILED_TASKS,
    EXIT_OK,
    EXIT_REFUSED,
    EXIT_STOPPED,
    EXIT_UNEXPECTED,
    add_run_arguments,
)
from hpcontact.sweep.columns import NOT_COMPUTED, join, to_columns
from hpcontact.sweep.costmodel import check_memory, start_estimate
from hpcontact.sweep.guard import Refused, RunLock, apart, usable_folder, usable_output
from hpcontact.sweep.journal import (
    BAD_INPUT,
    ERROR,
    NOT_CONVERGED,
    OK,
    RETRIED,
    Entry,
    History,
    Journal,
    clear_journals,
    journal_files,
    legacy_journals,
    read_history,
    session_name,
    to_json,
)
from hpcontact.sweep.progress import Progress, Summary
from hpcontact.sweep.schedule import (
    SLOTS,
    LaunchError,
    Team,
    claimed_chunks,
    cost_units,
    report_done,
    totals_done,
    world,
)
from hpcontact.sweep.signals import ALIVE_PREFIX, DEFAULT_GRACE_S, DEFAULT_STALL_S, STOP_NAME, Abandoned, StopControl
from hpcontact.sweep.spec import Spec, Validator, load_spec
from hpcontact.sweep.tasks import (
    Part,
    Task,
    changed_inputs,
    enumerate_part,
    join_parts,
    make_chunks,
    points,
    progress_lines,
)

TaskFunction = Callable[[Mapping[str, Any]], Mapping[str, Any]]
SHOWN_FAILURES = 5


class Stopped(Exception):
    """The run ended without a data set on every rank: stopped by a signal (``status`` 4), or a
    journal or the data set could not be written (a full disk; ``status`` 1); journals intact."""

    def __init__(self, message: str, status: int) -> None:
        super().__init__(message)
        self.status = status


@dataclass(frozen=True)
class Options:
    """How a run treats existing journals and locks (``hpcontact run`` flags)."""

    resume: bool = False
    restart: bool = False
    accept_stale: bool = False
    retry_crashed: bool = False
    break_lock: bool = False
    mem_per_rank: tuple[int, str] | None = None  # bytes a rank may use and where that comes from: checked if set
    up_to_date: bool = (
        False  # journals without resume/restart: a data set that is ``up_to_date`` is left as is, not refused
    )


@dataclass(frozen=True)
class Outcome:
    """What a finished run produced: the data set and its failed tasks (crashed included);
    ``up_to_date``: nothing was run or written (``up_to_date``)."""

    path: Path
    failures: int
    up_to_date: bool = False


@dataclass
class RoundTally:
    """The summary's sums over the rounds of an adaptive run (``adaptive.run_rounds``): each
    round is a run of its own, and the data set's summary is of them all (tasks run and reused,
    task, set-up, scheduling and journal seconds); ``begun`` counts the rounds begun (every
    rank), the sums are rank 0's."""

    begun: int = 0
    run: int = 0
    reused: int = 0
    task_s: float = 0.0
    setup_s: float = 0.0
    schedule_s: float = 0.0
    journal_s: float = 0.0

    def add(self, run: int, reused: int, task_s: float, setup_s: float, schedule_s: float, journal_s: float) -> None:
        """Count one more round."""
        self.run += run
        self.reused += reused
        self.task_s += task_s
        self.setup_s += setup_s
        self.schedule_s += schedule_s
        self.journal_s += journal_s


@dataclass(frozen=True)
class Decision:
    """Rank 0's decisions, broadcast to every rank: tasks by position (0-based, task order)."""

    isolated: list[int]  # suspects, run by rank 0 alone
    shared: list[int]  # the rest of the work, in chunks for every rank
    reused: int
    crashed: int
    session: str
    provenance: dict[str, Any]
    faults: dict[int, str]
    up_to_date: bool = False  # the data set is the one this run would write: nothing to do


@dataclass(frozen=True)
class Plan:
    """The work of every rank: the spec, its tasks (every rank joins them from the ranks'
    shares) and rank 0's decisions, with the suspects (run by rank 0 alone) and the rest of the
    work (in chunks for every rank) as tasks."""

    spec: Spec
    tasks: list[Task]
    decision: Decision
    isolated: list[Task]
    shared: list[Task]

    @classmethod
    def of(cls, spec: Spec, tasks: list[Task], decision: Decision) -> Plan:
        """The plan of ``decision``, its task positions turned into tasks."""
        return cls(spec, tasks, decision, [tasks[i] for i in decision.isolated], [tasks[i] for i in decision.shared])


def run_task(
    function: TaskFunction, task: Task, rank: int, stop: StopControl | None = None, fault: str | None = None
) -> Entry:
    """Call ``function`` on the task's parameters; any exception becomes a failed entry.
    ``Abandoned`` (a stop request's grace is over) and other BaseExceptions propagate."""
    started = time.perf_counter()
    status, message, record = OK, "", {}
    try:
        if stop is not None:
            stop.running = True
        faults.before_task(fault)
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
    finally:
        if stop is not None:
            stop.running = False
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


def _decide(
    spec: Spec, tasks: list[Task], history: History, options: Options, now: Mapping[str, Any]
) -> tuple[list[int], list[int], set[str], set[str]]:
    """Suspects to isolate and the rest to share (positions), the reused keys, and the
    quarantined keys."""
    keys = {t.key for t in tasks}
    reused = []
    for task in tasks:
        entry = history.entries.get(task.key)
        if (
            entry is not None
            and entry.status not in RETRIED
            and entry.resolved == provenance.resolved_scene(task.params)
        ):
            reused.append(entry)
    if not options.accept_stale:
        mismatch = provenance.first_mismatch(reused, now)
        if mismatch is not None:
            raise Refused(
                f"stale journals in {spec.journal}: {mismatch}; pass --accept-stale to reuse such "
                f"results or --restart to discard them"
            )
    done = {e.key for e in reused}
    suspects = {k: s for k, s in history.suspects().items() if k in keys and k not in done}
    crashed = set() if options.retry_crashed else {k for k in history.crashed() if k in suspects}
    todo = [i for i, t in enumerate(tasks) if t.key not in done and t.key not in crashed]
    isolated = [i for i in todo if tasks[i].key in suspects]
    shared = [i for i in todo if tasks[i].key not in suspects]
    return isolated, shared, done, crashed


Share = tuple[Part | None, bool, tuple[str, Any] | None]  # a rank's tasks, over memory, its error


def _share(spec: Spec, rank: int, ranks: int, validate: Validator | None, options: Options) -> Share:
    """This rank's share of the points (a contiguous 1/ranks of them in C order): its tasks with
    every distinct scene validated, whether one exceeds the memory per rank, or the error."""
    total = points(spec)
    try:
        part = enumerate_part(spec, total * rank // ranks, total * (rank + 1) // ranks, validate, check=True)
        over = False
        if options.mem_per_rank is not None:
            try:
                check_memory([Task(*row) for row in part.rows], *options.mem_per_rank)
            except InputError:
                over = True  # rank 0 checks every task again and names the largest
        return part, over, None
    except InputError as exc:
        return None, False, ("input", (exc.field, exc.allowed, exc.value))
    except Exception as exc:  # noqa: BLE001 - raised by rank 0 on every rank
        return None, False, ("other", f"{type(exc).__name__} on rank {rank}: {exc}")


def _joined(spec: Spec, shares: list[Share]) -> tuple[list[Task], Any, bool]:
    """Every rank: the tasks and each point's task from every rank's ``_share`` (in rank order:
    the first bad scene in point order is the one raised, on every rank alike), and whether a
    task may exceed the memory per rank."""
    for _, _, error in shares:
        if error is not None:
            kind, detail = error
            raise InputError(*detail) if kind == "input" else RuntimeError(detail)
    tasks, task_of = join_parts(spec, [part for part, _, _ in shares])
    return tasks, task_of, any(over for _, over, _ in shares)


def prepare(
    spec: Spec, tasks: list[Task], task_of: Any, over: bool, options: Options, ranks: int, keep: dict[str, Any]
) -> Decision:
    """Rank 0's preparation (see the module docstring); ``keep`` receives what stays on rank 0
    (each point's task, the lock, the history, the reused and quarantined keys)."""
    apart(spec)  # the output is not the spec, a mask or the journal folder (a dry run checks the same)
    if over:
        check_memory(tasks, *options.mem_per_rank)
    injected = faults.faults_from_environment()
    usable_output(Path(spec.output))
    usable_folder(spec.journal, "journal folder")
    lock = RunLock(spec.journal, ranks)
    note = lock.acquire(options.break_lock)
    try:
        (spec.journal / STOP_NAME).unlink(missing_ok=True)
        for beat in spec.journal.glob(f"{ALIVE_PREFIX}*"):  # an earlier run's heartbeats
            beat.unlink(missing_ok=True)
        history = read_history(spec.journal)
        faults.slow_phase("setup")
        if history.files and not (options.resume or options.restart):
            now = provenance.current()
            if options.up_to_date and up_to_date(spec, tasks, history, now):
                reused = {t.key for t in tasks if t.key in history.entries}  # an adaptive map's: a subset
                keep.update(task_of=task_of, lock=lock, history=history, reused=reused, crashed=set(), note=note)
                return Decision([], [], len(reused), 0, session_name(), now, injected, up_to_date=True)
            raise Refused(
                f"{len(history.entries)} finished tasks in {spec.journal}; pass --resume to continue or "
                f"--restart to discard them"
            )
        if options.restart:
            clear_journals(spec.journal)
            history = History()
        elif legacy_journals(spec.journal):
            raise Refused(
                f"{spec.journal} holds HDF5 journals of an earlier hpcontact (rank*.h5), which carry no "
                f"provenance and cannot be reused; pass --restart to discard them"
            )
        now = provenance.current()
        isolated, shared, reused, crashed = _decide(spec, tasks, history, options, now)
        carried: set[str] = set()
        if keep.get("select") is not None:  # an adaptive round: its tasks alone
            isolated = [i for i in isolated if i in keep["select"]]
            shared = [i for i in shared if i in keep["select"]]
            # the earlier rounds' failures are not run again, but stay in the data set as they failed
            carried = {
                tasks[i].key
                for i in keep.get("earlier", ())
                if tasks[i].key in history.entries and tasks[i].key not in reused and tasks[i].key not in crashed
            }
    except BaseException:
        lock.release()
        raise
    keep.update(task_of=task_of, lock=lock, history=history, reused=reused, crashed=crashed, carried=carried, note=note)
    return Decision(isolated, shared, len(reused), len(crashed), session_name(), now, injected)


def up_to_date(spec: Spec, tasks: list[Task], history: History, now: Mapping[str, Any]) -> bool:
    """Whether the data set of ``spec`` is the one a run would write now, so that a run without
    ``resume`` or ``restart`` has nothing to do (``Options.up_to_date``; the README's command run
    twice): the data set exists; every task of the spec is in the journals, its last outcome ok,
    for the same resolved scene and computed by this code (version, git revision, numerics: what
    ``resume`` would reuse), so none would run; no journal line was dropped and no HDF5 journal
    of an earlier hpcontact is there; the data set was written from this very spec (its ``spec``
    attribute), holds as many tasks, none failed, and no journal changed after it was written (a
    later run that stopped before writing its own). An adaptive map (``spec.adaptive``) solves a
    subset of the tasks: every task its journals hold must be so, and the data set's
    ``sweep_solves`` as many (its rounds are decided by those values alone). Anything else: False
    (the run is refused as before). Reads the data set's attributes only; changes nothing."""
    output = Path(spec.output)
    if not tasks or not output.is_file() or history.dropped or legacy_journals(spec.journal):
        return False
    adaptive = spec.adaptive is not None
    journaled = [t for t in tasks if t.key in history.entries] if adaptive else tasks
    entries = [history.entries.get(task.key) for task in journaled]
    if not entries or any(
        e is None or e.status != OK or e.resolved != provenance.resolved_scene(t.params)
        for e, t in zip(entries, journaled)
    ):
        return False
    if provenance.first_mismatch(entries, now) is not None:
        return False
    written = output.stat().st_mtime_ns
    if any(path.stat().st_mtime_ns > written for path in journal_files(spec.journal)):
        return False
    try:
        import netCDF4

        with netCDF4.Dataset(output, "r") as nc:
            attrs = {
                name: nc.getncattr(name)
                for name in ("spec", "sweep_tasks", "sweep_failures", "sweep_solves")
                if name in nc.ncattrs()
            }
    except (OSError, RuntimeError, ValueError):  # not a readable netCDF file: a run writes it again
        return False
    return (
        attrs.get("spec") == spec.text
        and attrs.get("sweep_tasks") == len(tasks)
        and attrs.get("sweep_failures") == 0
        and (not adaptive or attrs.get("sweep_solves") == len(entries))
    )


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
    options: Options | None = None,
    stop: StopControl | None = None,
    accuracy: float | None = None,
) -> Path:
    """Run the sweep of ``spec_path`` on ``team`` (default: MPI world, or one process) and return
    the path of the data set written (see ``execute``)."""
    return execute(
        spec_path,
        output,
        task_function,
        team=team,
        validate=validate,
        stream=stream,
        options=options if options is not None else Options(resume=resume),
        stop=stop,
        accuracy=accuracy,
    ).path


def execute(
    spec_path: str | Path | Spec,
    output: str | Path | None = None,
    task_function: TaskFunction | None = None,
    *,
    team: Team | None = None,
    validate: Validator | None = None,
    stream: TextIO | None = None,
    options: Options = Options(),
    stop: StopControl | None = None,
    accuracy: float | None = None,
) -> Outcome:
    """Run the sweep of ``spec_path`` on ``team`` (default: MPI world, or one process).

    ``options`` say what to do with existing journals and locks (module docstring); ``output``
    overrides the spec's output path and ``accuracy`` its [numerics] accuracy, n and n_across
    (``hpcontact run --accuracy``); ``task_function`` solves one scene and ``validate`` checks
    one scene's parameters (defaults: those of the spec's scene kind, ``accuracy.task_function``); rank 0 prints
    progress and the summary to ``stream`` (default stdout); ``stop`` is this rank's stop
    control (default: one without signal handlers, which still stops with the other ranks).
    Spec errors and refusals raise ``InputError`` (``Refused``) on every rank before any work
    starts; a stopped run raises ``Stopped`` on every rank. ``spec_path`` may be a ``Spec``
    already parsed (``spec.parse_spec`` with ``check_scenes=False``; ``output`` None): a spec
    given as a dict (``hpcontact.run_sweep``). With ``options.up_to_date``, a sweep whose data
    set is ``up_to_date`` prints one line and returns it (``Outcome.up_to_date``): nothing is
    run or written.
    """
    team = team if team is not None else world()
    started = time.perf_counter()  # after the imports and MPI start-up
    stream = stream if stream is not None else sys.stdout
    stop = stop if stop is not None else StopControl()
    spec = _shared(
        team,
        lambda: (
            spec_path
            if isinstance(spec_path, Spec) and output is None and accuracy is None
            else load_spec(spec_path, output=output, validate=validate, check_scenes=False, accuracy=accuracy)
        ),
    )
    mine = pickle.dumps(_share(spec, team.rank, team.size, validate, options), protocol=pickle.HIGHEST_PROTOCOL)
    tasks, task_of, over = _joined(spec, [pickle.loads(b) for b in team.bcast(team.gather(mine))])

    tally = RoundTally() if spec.adaptive is not None else None

    def run_round(
        options: Options,
        select: frozenset[int] | None = None,
        finish: Callable | None = None,
        earlier: frozenset[int] = frozenset(),
    ) -> Outcome:
        return _round(
            team,
            spec,
            tasks,
            task_of,
            over,
            options,
            task_function,
            stream,
            stop,
            started,
            select,
            finish,
            tally,
            earlier,
        )

    if spec.adaptive is not None:  # rounds of runs over subsets of the tasks (hpcontact.sweep.adaptive)
        from hpcontact.sweep.adaptive import run_rounds

        return run_rounds(team, spec, task_of, options, stream, run_round)
    return run_round(options)


def _round(
    team: Team,
    spec: Spec,
    tasks: list[Task],
    task_of: Any,
    over: bool,
    options: Options,
    task_function: TaskFunction | None,
    stream: TextIO,
    stop: StopControl,
    started: float,
    select: frozenset[int] | None = None,
    finish: Callable | None = None,
    tally: RoundTally | None = None,
    earlier: frozenset[int] = frozenset(),
) -> Outcome:
    """Every rank: rank 0 prepares, the ranks run the plan (see ``execute``). An adaptive round
    (``adaptive.run_rounds``) runs the tasks of ``select`` (positions) alone, and rank 0 gives
    the data set to ``finish(dataset, joined)`` and writes what it returns (None: nothing); its
    set-up runs from the round's start (the first's from the run's), ``tally`` sums the rounds
    for the summary, and the outcomes of ``earlier`` (the rounds before) that are not reused
    (failures) are carried into the data set as they are."""
    round_started = started
    if tally is not None:
        round_started = started if tally.begun == 0 else time.perf_counter()
        tally.begun += 1
    keep: dict[str, Any] = {"select": select, "finish": finish, "tally": tally, "earlier": earlier}  # rank 0 only
    d: Decision = _shared(team, lambda: prepare(spec, tasks, task_of, over, options, team.size, keep))
    plan = Plan.of(spec, tasks, d)
    try:
        if d.up_to_date:
            if team.rank == 0:
                print(
                    f"hpcontact: {spec.output} is up to date ({d.reused} tasks from journals); nothing to do",
                    file=stream,
                    flush=True,
                )
            return Outcome(Path(spec.output), 0, up_to_date=True)
        with limited_blas():  # HPCONTACT_BLAS_THREADS while the tasks run (numerics.blas)
            return _run(team, plan, keep, task_function, stream, stop, options, started, round_started)
    finally:
        stop.close()
        if team.rank == 0:
            keep["lock"].release()


def _run(
    team: Team,
    plan: Plan,
    keep: dict[str, Any],
    task_function: TaskFunction | None,
    stream: TextIO,
    stop: StopControl,
    options: Options,
    started: float,
    round_started: float,
) -> Outcome:
    """Every rank: the work of ``plan``, then rank 0 assembles the data set (see ``execute``);
    the set-up runs from ``round_started``, the wall time from ``started``."""
    spec, tasks = plan.spec, plan.tasks
    if task_function is None:
        task_function = accuracy.task_function(spec.kind)
    chunks = make_chunks(plan.shared, team.size)
    # this rank's share of the FFT applications per grid, estimated from every R-th task (the
    # work stays 1/R of the tasks per rank): grids the sweep uses often get measured FFTW plans
    # at their first application, not after ~40-80 (hpcontact.numerics.convolution)
    todo = plan.isolated + plan.shared
    expect_applications(fft_applications(t.params for t in todo[team.rank :: team.size]))
    setup_s = time.perf_counter() - round_started

    progress = None
    if team.rank == 0:
        if keep["note"]:
            print(f"hpcontact: {keep['note']}", file=stream)
        if keep["history"].dropped:
            print(f"hpcontact: warning: {keep['history'].dropped_note(spec.journal)}", file=stream)
        changed = changed_inputs(tasks, keep["history"].entries)  # a mask replaced under its path
        if changed:
            print(f"hpcontact: {changed}", file=stream)
        print(
            f"hpcontact: {spec.title}: {len(tasks)} tasks, {len(todo)} to run"
            f"{f' ({plan.decision.reused} from journals)' if plan.decision.reused else ''}"
            f"{f', {len(plan.isolated)} alone on rank 0 (their last run died)' if plan.isolated else ''}"
            f"{f', {plan.decision.crashed} quarantined (--retry-crashed runs them)' if plan.decision.crashed else ''}"
            f", {len(chunks)} chunks on {team.size} rank(s)",
            file=stream,
            flush=True,
        )
        line, seconds = start_estimate(todo, team.size)
        tally: RoundTally | None = keep.get("tally")
        if tally is None or tally.begun == 1:  # an adaptive map's later rounds: said once, in its first
            print(line, file=stream, flush=True)
        handed = [t for chunk in chunks for t in chunk]  # what the ranks report, in hand-out order
        estimated = None if seconds is None else dict(zip((t.key for t in todo), seconds.tolist()))
        progress = Progress(
            len(tasks),
            plan.decision.reused,
            [cost_units(t.cost) for t in handed],
            None if estimated is None else [estimated[t.key] for t in handed],
            spec.progress_interval,
            stream,
        )

    index = {t.key: i for i, t in enumerate(tasks)}
    task_s = schedule_s = journal_s = 0.0
    run = 0
    failure: str | None = None
    stop.watch(spec.journal, team.rank, team.size)
    counter = team.counter(SLOTS)
    journal = Journal(
        _journal_path(spec, team.rank, plan.decision.session),
        team.rank,
        {"session": plan.decision.session, "spec_path": str(spec.path), **plan.decision.provenance},
    )
    done: list[Entry] = []  # this rank's outcomes, and their tasks' positions
    done_at: list[int] = []

    def run_one(task: Task) -> None:
        nonlocal task_s, journal_s, run
        fault = plan.decision.faults.get(index[task.key])
        mark = time.perf_counter()
        journal.started(task.key)
        journal_s += time.perf_counter() - mark
        try:
            entry = run_task(task_function, task, team.rank, stop, fault)
        except Abandoned as exc:
            journal.interrupted(task.key, str(exc))
            return
        except BaseException:
            journal.interrupted(task.key, "the run was interrupted")
            raise
        entry = replace(entry, resolved=provenance.resolved_scene(task.params), provenance=plan.decision.provenance)
        task_s += entry.wall_time_s
        run += 1
        mark = time.perf_counter()
        faults.tear(fault, journal.line(entry), journal.write_raw)
        journal.append(entry)
        journal_s += time.perf_counter() - mark
        done.append(entry)
        done_at.append(index[task.key])

    try:
        try:
            if team.rank == 0:
                for task in plan.isolated:
                    if stop.stopping:
                        break
                    run_one(task)
            claim = time.perf_counter()
            for chunk in claimed_chunks(chunks, counter):
                schedule_s += time.perf_counter() - claim
                if stop.stopping:
                    break
                for task in chunk:
                    if stop.stopping:
                        break
                    run_one(task)
                    mark = time.perf_counter()
                    report_done(counter, task.cost)
                    schedule_s += time.perf_counter() - mark
                    if progress is not None and progress.due():
                        progress.report(*totals_done(counter))
                claim = time.perf_counter()
            schedule_s += time.perf_counter() - claim
        finally:
            journal.close()
    except OSError as exc:  # the journal cannot be written: stop this rank cleanly, and the others
        failure = f"cannot write {exc.filename or spec.journal}: {exc.strerror or exc}"
        stop.request(f"rank {team.rank}: {failure}", failed=True)
    counter.close()
    stop.enter("finish")
    totals = team.gather(
        (
            task_s,
            run,
            schedule_s,
            journal_s,
            journal.sync_s,
            stop.reason,
            stop.failed,
            failure,
            None if stop.reason is not None else to_columns(done, done_at),
        )
    )

    def finish() -> tuple[Outcome | None, str, int]:
        reasons = [t for t in totals if t[5] is not None]
        if reasons:
            failed = [t[7] for t in totals if t[7]]
            ran = sum(t[1] for t in totals)
            status = EXIT_UNEXPECTED if any(t[6] for t in reasons) else EXIT_STOPPED
            what = f"stopped ({'; '.join(failed) if failed else reasons[0][5]})"
            return (
                None,
                (
                    f"hpcontact: {what}: {ran} tasks finished in this run; journals intact in "
                    f"{spec.journal}; run again with --resume"
                ),
                status,
            )
        try:
            outcome = _assemble(spec, plan, keep, team.size, totals, started, setup_s, options, stream)
            stop.enter("done")  # the data set is written: a stop request changes nothing now
            faults.slow_phase("done")
            return outcome, "", EXIT_OK
        except OSError as exc:  # a full disk at the end: the journals hold everything
            return (
                None,
                (
                    f"hpcontact: cannot write the data set {exc.filename or spec.output}: {exc.strerror or exc}; "
                    f"journals intact in {spec.journal}; free space and run again with --resume"
                ),
                EXIT_UNEXPECTED,
            )

    outcome, message, status = _shared(team, finish)
    stop.enter("done")
    if outcome is None:
        raise Stopped(message, status)
    return outcome


def _journal_path(spec: Spec, rank: int, session: str) -> Path:
    """The journal of ``rank`` in the run ``session``."""
    return spec.journal / f"rank{rank:05d}-{session}.jsonl"


def _assemble(
    spec: Spec,
    plan: Plan,
    keep: Mapping[str, Any],
    ranks: int,
    totals: list,
    started: float,
    setup_s: float,
    options: Options,
    stream: TextIO,
) -> Outcome:
    """Rank 0: the data set from the ranks' columns of this run and the outcomes reused from
    earlier journals, its summary, and the netCDF file (xarray is imported here: the other
    ranks, and runs that stop, never need it)."""
    from hpcontact.sweep.dataset import FIXED_VARIABLES, dataset_of, write_netcdf

    gather_started = time.perf_counter()
    history: History = keep["history"]
    earlier = [
        (history.crashed_entry(t.key, t.params) if t.key in keep["crashed"] else history.entries[t.key], i)
        for i, t in enumerate(plan.tasks)
        if t.key in keep["crashed"] or t.key in keep["reused"] or t.key in keep.get("carried", ())
    ]
    parts = [to_columns([e for e, _ in earlier], [i for _, i in earlier])] + [t[8] for t in totals]
    joined = join(parts, len(plan.tasks), FIXED_VARIABLES)
    failed = [int(i) for i in np.flatnonzero((joined.status != OK) & (joined.status != NOT_COMPUTED))]
    dataset = dataset_of(
        spec,
        keep["task_of"],
        joined,
        {
            "hpcontact_version": plan.decision.provenance["hpcontact_version"],
            "git_revision": plan.decision.provenance["git_revision"],
            "numerics": json.dumps(provenance.numerics(), sort_keys=True),
            "sweep_contributors": joined.provenance,
            "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "mpi_size": ranks,
            "history": f"hpcontact run {spec.path}{' --resume' if options.resume else ''}",
            "sweep_journal_sync_time_s": sum(t[4] for t in totals),
        },
        derive=False,  # write_netcdf stores K_nn and normalized_nn (it derives them once, there)
    )
    sums = RoundTally(
        run=sum(t[1] for t in totals),
        reused=plan.decision.reused,
        task_s=sum(t[0] for t in totals),
        setup_s=setup_s,
        schedule_s=sum(t[2] for t in totals),
        journal_s=sum(t[3] for t in totals),
    )
    tally: RoundTally | None = keep.get("tally")
    if tally is not None:  # an adaptive round: the summary counts this run's rounds so far
        selected = keep["select"] if keep["select"] is not None else range(len(plan.tasks))
        reused = sum(1 for i in selected if plan.tasks[i].key in keep["reused"])  # this round's, from journals
        tally.add(sums.run, reused, sums.task_s, sums.setup_s, sums.schedule_s, sums.journal_s)
        sums = tally
    if keep.get("finish") is not None:  # an adaptive round (adaptive.run_rounds)
        dataset = keep["finish"](dataset, joined)
        if dataset is None:  # not the last round: nothing to write
            return Outcome(Path(spec.output), len(failed))
    now = time.perf_counter()
    summary = Summary(
        tasks=len(plan.tasks),
        points=math.prod(len(a) for a in spec.axes),
        run=sums.run,
        reused=sums.reused,
        failures=len(failed),
        ranks=ranks,
        wall_s=now - started,
        task_s=sums.task_s,
        setup_s=sums.setup_s,
        schedule_s=sums.schedule_s,
        journal_s=sums.journal_s,
        gather_s=now - gather_started,
    )
    dataset.attrs.update(summary.attrs())
    faults.slow_phase("write")
    path = write_netcdf(dataset, spec.output)
    shown = [
        f"{json.dumps(dict(plan.tasks[i].params), sort_keys=True)}: {joined.message[i]}"
        for i in failed[:SHOWN_FAILURES]
    ]
    print(summary.text(shown), file=stream)
    unseen = [r for r, t in enumerate(totals) if t[1] and not _journal_path(spec, r, plan.decision.session).exists()]
    if unseen:
        print(
            f"hpcontact: warning: rank 0 does not see the journals of rank(s) {', '.join(map(str, unseen[:10]))} in "
            f"{spec.journal} (a --resume would compute their tasks again); is it on a file system every node shares?",
            file=stream,
        )
    print(f"hpcontact: wrote {path} in {time.perf_counter() - now:.2f}s", file=stream, flush=True)
    return Outcome(path, len(failed))


#: A dry run lists a sample of the tasks, after its summary: the first ``LISTED_HEAD`` and the last
#: ``LISTED_TAIL``, and a line saying how many it left out between them (``--list-all``: every task;
#: ``--json`` always lists every task). Mindlin's adaptive map has 861 tasks, a large sweep 10^6:
#: lines nobody reads, and printing them takes longer than the estimate.
LISTED_HEAD = 10
LISTED_TAIL = 5


def listed_tasks(count: int, list_all: bool = False) -> Sequence[int | None]:
    """The indices of the tasks a text dry run of ``count`` tasks lists, in order, with None where
    it says how many it left out: every task when ``list_all`` or when there are no more than
    ``LISTED_HEAD + LISTED_TAIL``, else the first ``LISTED_HEAD`` and the last ``LISTED_TAIL``."""
    if list_all or count <= LISTED_HEAD + LISTED_TAIL:
        return range(count)
    return [*range(LISTED_HEAD), None, *range(count - LISTED_TAIL, count)]


def dry_run(
    spec_path: str | Path,
    output: str | Path | None = None,
    stream: TextIO | None = None,
    *,
    as_json: bool = False,
    mem_per_rank: int | None = None,
    calibration: Any = None,
    list_all: bool = False,
    accuracy: float | None = None,
) -> int:
    """``hpcontact run SPEC --dry-run``: a line with the title, the number of tasks and the output;
    the summary: the distinct grids and kernel sets, the totals (core-seconds, core-hours, peak
    memory), the wall time on 1, 64 and 1024 ranks (``costmodel``) and an adaptive spec's first
    round and bound; then the tasks with their 0-based indices (the order ``HPCONTACT_FAULTS``
    counts in), relative cost, estimated seconds and peak memory and parameters: a sample
    (``listed_tasks``) unless ``list_all``. A warning on stderr for tasks over ``mem_per_rank`` bytes (default:
    ``numerics.memory.default_memory_per_rank``). With ``as_json``, one JSON object instead,
    every task in its ``tasks_list`` (written as it goes, not built in memory). Nothing is
    computed but the cost model's calibration (once per host and version,
    ``costmodel.load_calibration``)."""
    stream = stream if stream is not None else sys.stdout
    spec = load_spec(
        spec_path, output=output, check_scenes=False, accuracy=accuracy
    )  # checked once, while enumerating:
    apart(spec)  # refused as the run refuses it (guard.apart), before the enumeration
    progress = progress_lines(sys.stderr, points(spec))
    tasks, task_of = join_parts(spec, [enumerate_part(spec, check=True, progress=progress, lean=True)])
    limit, source = (mem_per_rank, "--mem-per-rank") if mem_per_rank is not None else default_memory_per_rank()
    if calibration is None:
        calibration = costmodel.load_calibration(stream=sys.stderr)
    est = costmodel.estimate(tasks, calibration)
    over = est.over(limit)
    peak_task = int(np.argmax(est.bytes)) if tasks else None  # the first of the largest
    if over:
        shown = ", ".join(map(str, over[:SHOWN_FAILURES])) + (", ..." if len(over) > SHOWN_FAILURES else "")
        print(
            f"hpcontact: warning: {len(over)} task(s) need more memory than {limit / 2**20:.0f} MiB per rank "
            f"({source}): {shown}; hpcontact run refuses this spec",
            file=sys.stderr,
        )
    if as_json:
        head = json.dumps(
            {
                "title": spec.title,
                "output": str(spec.output),
                "tasks": len(tasks),
                "estimated_task_seconds": est.total_seconds,
                "estimated_core_hours": est.total_seconds / 3600.0,
                "estimated_peak_memory_bytes": est.peak_bytes,
                "peak_memory_task": peak_task,
                "wall_time_s": {str(r): w for r, w in est.wall_s.items()},
                "efficiency": {str(r): e for r, e in est.efficiency.items()},
                "grids": est.grids(),
                "kernel_sets": est.kernel_sets(),
                "mem_per_rank_bytes": limit,
                "mem_per_rank_source": source,
                "tasks_over_memory": over,
                "calibration": {"host": calibration.host, "version": calibration.version},
            }
        )
        # the object json.dumps writes with "tasks_list" last, one entry per task, written in blocks
        stream.write(head[:-1] + ', "tasks_list": [')
        for begin in range(0, len(tasks), 10_000):
            stream.write(
                ", ".join(
                    f'{{"index": {i}, "key": {_json_text(t.key)}, "cost": {_json_number(t.cost)}, '
                    f'"estimated_seconds": {_json_number(s)}, "estimated_peak_memory_bytes": {_json_number(b)}}}'
                    for i, t, s, b in zip(
                        range(begin, begin + 10_000),
                        tasks[begin : begin + 10_000],
                        est.seconds[begin : begin + 10_000].tolist(),
                        est.bytes[begin : begin + 10_000].tolist(),
                    )
                )
                + (", " if begin + 10_000 < len(tasks) else "")
            )
        stream.write("]}\n")
        stream.flush()
        return EXIT_OK
    print(
        f"# {spec.title}: {len(tasks)} tasks -> {spec.output} (index, key, relative cost, estimated seconds, "
        f"estimated peak MiB, scene)",
        file=stream,
    )
    counts = est.grids()  # once: a label per task
    grids = "; ".join(f"{label}: {count} tasks" for label, count in counts.items())
    print(f"# {len(counts)} grid(s) ({grids}); {est.kernel_sets()} kernel set(s)", file=stream)
    print(
        f"# estimated: {est.total_seconds:.4g} core-seconds = {est.total_seconds / 3600.0:.3g} core-hours; peak memory "
        f"{est.peak_bytes / 2**20:.0f} MiB (task {peak_task}); limit {limit / 2**20:.0f} MiB per rank ({source})",
        file=stream,
    )
    walls = ", ".join(f"{r} rank(s) {_duration(w)} (efficiency {est.efficiency[r]:.2f})" for r, w in est.wall_s.items())
    print(
        f"# wall time: {walls}; cost model calibrated on {calibration.host} by hpcontact {calibration.version}",
        file=stream,
    )
    if calibration.contended():
        print(f"# warning: cost model {calibration.contended()}", file=stream)
    if spec.adaptive is not None:  # all the tasks are the bound; the first round solves fewer
        from hpcontact.sweep.adaptive import dry_run_text

        print(dry_run_text(spec, task_of), file=stream)
    shown = json.JSONEncoder(sort_keys=True).encode  # json.dumps(..., sort_keys=True) without an encoder per line
    listed = listed_tasks(len(tasks), list_all)
    left_out = len(tasks) - LISTED_HEAD - LISTED_TAIL
    for begin in range(0, len(listed), 10_000):
        stream.write(
            "".join(
                f"# ... {left_out} more tasks ({LISTED_HEAD} ... {len(tasks) - LISTED_TAIL - 1}; "
                f"--list-all lists every task)\n"
                if i is None
                else f"{i:6d}  {tasks[i].key[:12]}  {tasks[i].cost:10.3g}  {float(est.seconds[i]):9.3g}  "
                f"{float(est.bytes[i]) / 2**20:7.0f}  {shown(dict(tasks[i].params))}\n"
                for i in listed[begin : begin + 10_000]
            )
        )
    return EXIT_OK


def _json_text(text: str) -> str:
    """``text`` as ``json.dumps`` writes it (a task key, hex, as it is)."""
    return f'"{text}"' if text.isalnum() and text.isascii() else json.dumps(text)


def _json_number(value: float) -> str:
    """``value`` as ``json.dumps`` writes it: ``repr`` of a finite number, else NaN / Infinity."""
    return repr(value) if math.isfinite(value) else json.dumps(value)


def _duration(seconds: float) -> str:
    """``seconds`` as the dry-run prints a wall time: s below 2 minutes, else min, else h."""
    if seconds < 120.0:
        return f"{seconds:.3g} s"
    return f"{seconds / 60.0:.3g} min" if seconds < 7200.0 else f"{seconds / 3600.0:.3g} h"


def run_command(
    spec: str | Path,
    options: Options = Options(),
    output: str | Path | None = None,
    grace_s: float | None = None,
    task_function: TaskFunction | None = None,
    prog: str = "hpcontact run",
    stall_s: float | None = None,
    accuracy: float | None = None,
) -> int:
    """``hpcontact run`` on every rank: the exit status (``EXIT_STATUS``). Refusals and bad
    input print one line on stderr from rank 0, prefixed ``prog``; any other error prints its
    traceback and, under MPI, aborts every rank (a rank left waiting in a collective would hang
    the job). ``task_function`` replaces the scene kind's solver (``python -m hpcontact.sweep.accuracy_study``)."""
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
        outcome = execute(spec, output, task_function, team=team, options=options, stop=stop, accuracy=accuracy)
        if not outcome.up_to_date:  # an up-to-date sweep planned nothing new
            _keep_wisdom()  # every rank: save_wisdom merges the ranks' plans into one file
        return EXIT_FAILED_TASKS if outcome.failures else EXIT_OK
    except InputError as exc:
        if team.rank == 0:
            print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_REFUSED
    except Stopped as exc:
        if team.rank == 0:
            print(exc, file=sys.stderr)
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


def run_from_arguments(
    args: argparse.Namespace, task_function: TaskFunction | None = None, prog: str = "hpcontact run"
) -> int:
    """Run what ``add_run_arguments`` parsed (``task_function``, ``prog``: see ``run_command``)."""
    memory = (parse_memory(args.mem_per_rank), "--mem-per-rank") if args.mem_per_rank is not None else None
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
    )
    return run_command(
        args.spec, options, args.output, args.grace, task_function, prog, args.stall_timeout, args.accuracy
    )


def main(
    argv: Sequence[str] | None = None,
    prog: str = "hpcontact run",
    description: str = "Run a parameter sweep (under mpiexec or alone).",
    task_function: TaskFunction | None = None,
) -> int:
    """``python -m hpcontact.sweep SPEC [options]`` (see ``add_run_arguments``); another
    ``task_function`` makes another command with the same options and exit statuses
    (``python -m hpcontact.sweep.accuracy_study``)."""
    parser = argparse.ArgumentParser(prog=prog, description=description)
    add_run_arguments(parser)
    try:
        return run_from_arguments(parser.parse_args(argv), task_function, prog)
    except InputError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return EXIT_REFUSED
