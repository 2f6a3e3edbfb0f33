"""The resume policy of a run (rank 0): which tasks of the journals of earlier runs are reused,
run again, quarantined or run alone, whether a data set is already up to date, and the lock
held while the run writes (see ``hpcontact.sweep.driver``).

An entry is reused only if this run's runner computed it: its provenance names the task function
(``RUNNER``, ``records.runner_name``), beside the code's version, revision and fingerprint. The
accuracy study (cold kernel caches, one grid) and ``hpcontact run`` (the scene kind's own solver,
extrapolated over grids) give different numbers and timings for the same scene, so an entry of
another runner is run again, and the run says how many in one line; the code fields, by
contrast, refuse the run (stale journals, ``--accept-stale``). An entry without a runner (journals
written before runners were recorded) was computed by the scene kind's own solver."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from itertools import chain
from pathlib import Path
from typing import Any

from hpcontact import accuracy
from hpcontact.errors import Message
from hpcontact.sweep import faults
from hpcontact.sweep.data import provenance
from hpcontact.sweep.data.journal import (
    OK,
    RETRIED,
    Entry,
    History,
    clear_journals,
    journal_files,
    legacy_journals,
    session_name,
)
from hpcontact.sweep.run.guard import Refused, RunLock, apart, usable_folder, usable_output
from hpcontact.sweep.run.options import ACCEPT_STALE, RESTART, RESUME
from hpcontact.sweep.run.records import EVERY_TASK, Decision, Kept, Options, RoundMemory, RoundScope, runner_name
from hpcontact.sweep.run.signals import ALIVE_PREFIX, STOP_NAME
from hpcontact.sweep.space.spec import Spec
from hpcontact.sweep.work.estimate import check_memory
from hpcontact.sweep.work.tasks import Task

RUNNER = "runner"  # the provenance field naming the task function that computed an entry


def current(spec: Spec, options: Options) -> dict[str, Any]:
    """This run's provenance: the code's (``provenance.current``) and its runner, the task
    function of ``options`` or else the spec's scene kind's own solver; every entry the run
    journals carries it."""
    own = runner_name(accuracy.task_function(spec.kind))
    return {**provenance.current(), RUNNER: options.runner or own}


def runner_of(entry: Entry, spec: Spec) -> str:
    """The runner that computed ``entry`` (see the module docstring): its provenance's, or the
    spec's scene kind's own solver for an entry that names none."""
    return entry.provenance.get(RUNNER) or runner_name(accuracy.task_function(spec.kind))


def round_memory(scope: RoundScope) -> RoundMemory:
    """Rank 0's ``RoundMemory`` of the run ``scope`` is a round of: the one its adaptive run's
    rounds share (``scope.memory``), a fresh one for a plain run's one round."""
    return scope.memory if scope.memory is not None else RoundMemory()


def prepare(
    spec: Spec,
    tasks: list[Task],
    task_of: Any,
    over: bool,
    options: Options,
    ranks: int,
    scope: RoundScope = EVERY_TASK,
) -> tuple[Decision, Kept]:
    """Rank 0's preparation of a round of ``scope`` (see ``hpcontact.sweep.driver``): the
    decision every rank follows and what stays on rank 0 (``Kept``). An adaptive round decides
    over its own tasks and its earlier rounds' (``scope.select``, ``scope.earlier``), not the
    whole grid: the entries it would reuse are those checked against stale code, and counted
    when another runner computed them; the journals are read from where the last round left
    them (``RoundMemory``)."""
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
        memory = round_memory(scope)
        if memory.first_options is None:
            memory.first_options = options
        history = memory.history(spec.journal)
        faults.slow_phase("setup")
        if history.files and not (options.resume or options.restart):
            now = current(spec, options)
            if options.up_to_date and up_to_date(spec, tasks, history, now):
                reused = {t.key for t in tasks if t.key in history.entries}  # an adaptive map's: a subset
                return (
                    Decision([], [], len(reused), 0, session_name(), now, injected, up_to_date=True),
                    Kept(task_of, lock, history, reused, set(), note),
                )
            raise Refused(
                Message(
                    f"{len(history.entries)} finished tasks in {spec.journal}; pass ",
                    RESUME,
                    " to continue or ",
                    RESTART,
                    " to discard them",
                )
            )
        if options.restart:
            clear_journals(spec.journal)
            history = History()
        elif legacy_journals(spec.journal):
            raise Refused(
                Message(
                    f"{spec.journal} holds HDF5 journals of an earlier hpcontact (rank*.h5), which carry no "
                    "provenance and cannot be reused; pass ",
                    RESTART,
                    " to discard them",
                )
            )
        now = current(spec, options)
        covered = None if scope.select is None else sorted(scope.select | scope.earlier)
        isolated, shared, reused, crashed, foreign = _decide(spec, tasks, covered, history, options, now, memory)
        if foreign is not None:  # the lock's note (a Message: it may name an option) and this one
            note = foreign if note is None else note + f"; {foreign}"
        carried: set[str] = set()
        counted = len(reused)  # the round's tasks from journals
        if scope.select is not None:  # an adaptive round: its tasks alone
            isolated = [i for i in isolated if i in scope.select]
            shared = [i for i in shared if i in scope.select]
            # the earlier rounds' failures are not run again, but stay in the data set as they failed
            carried = {
                tasks[i].key
                for i in scope.earlier
                if tasks[i].key in history.entries and tasks[i].key not in reused and tasks[i].key not in crashed
            }
            counted = sum(1 for i in scope.select if tasks[i].key in reused)  # not the other rounds'
        memory.handed_out.update(tasks[i].key for i in chain(isolated, shared))
    except BaseException:
        lock.release()
        raise
    return (
        Decision(isolated, shared, counted, len(crashed), session_name(), now, injected),
        Kept(task_of, lock, history, reused, crashed, note, carried),
    )


def up_to_date(spec: Spec, tasks: list[Task], history: History, now: Mapping[str, Any]) -> bool:
    """Whether the data set of ``spec`` is the one a run would write now, so that a run without
    ``resume`` or ``restart`` has nothing to do (``Options.up_to_date``; the README's command run
    twice): the data set exists; every task of the spec is in the journals, its last outcome ok,
    for the same resolved scene and computed by this code (version, git revision, numerics) and
    runner (``now``: ``current``): what ``resume`` would reuse, so none would run; no journal line was dropped and no HDF5 journal
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
        e is None
        or e.status != OK
        or e.resolved != provenance.resolved_scene(t.params)
        or runner_of(e, spec) != now[RUNNER]
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


def _decide(
    spec: Spec,
    tasks: list[Task],
    covered: Iterable[int] | None,
    history: History,
    options: Options,
    now: Mapping[str, Any],
    memory: RoundMemory,
) -> tuple[list[int], list[int], set[str], set[str], str | None]:
    """Over the tasks at ``covered`` (positions, in order; None: every task): suspects to isolate
    and the rest to share (positions), the reused keys, the quarantined keys, and the line that
    says how many entries another runner computed (run again), if any. Each journaled task's
    verdict is kept in ``memory`` while its entry is the same object (an adaptive map's earlier
    rounds are not resolved again each round), and the entry of a task the run handed out
    itself (``RoundMemory.handed_out``) is not checked against the scene resolved again."""
    positions = range(len(tasks)) if covered is None else covered
    reused = []
    foreign: dict[str, int] = {}  # entries that would be reused but for their runner, per runner
    for i in positions:
        task = tasks[i]
        entry = history.entries.get(task.key)
        if entry is None:
            continue
        known = memory.verdicts.get(task.key)
        if known is None or known[0] is not entry:
            usable = entry.status not in RETRIED and (
                task.key in memory.handed_out or entry.resolved == provenance.resolved_scene(task.params)
            )
            known = (entry, runner_of(entry, spec) if usable else None)
            memory.verdicts[task.key] = known
        runner = known[1]
        if runner == now[RUNNER]:
            reused.append(entry)
        elif runner is not None:
            foreign[runner] = foreign.get(runner, 0) + 1
    if not options.accept_stale:
        mismatch = provenance.first_mismatch(reused, now)
        if mismatch is not None:
            raise Refused(
                Message(
                    f"stale journals in {spec.journal}: {mismatch}; pass ",
                    ACCEPT_STALE,
                    " to reuse such results or ",
                    RESTART,
                    " to discard them",
                )
            )
    done = {e.key for e in reused}
    suspected = history.suspects()
    suspects = {tasks[i].key for i in positions if tasks[i].key in suspected and tasks[i].key not in done}
    crashed = set() if options.retry_crashed else {k for k in history.crashed() if k in suspects}
    todo = [i for i in positions if tasks[i].key not in done and tasks[i].key not in crashed]
    isolated = [i for i in todo if tasks[i].key in suspects]
    shared = [i for i in todo if tasks[i].key not in suspects]
    return isolated, shared, done, crashed, _foreign_note(foreign)


def _foreign_note(foreign: Mapping[str, int]) -> str | None:
    """ "2 journal entries were computed by hpcontact.sweep.accuracy_study.cold_solve, not
    reused" (one clause per runner, most entries first); None when ``foreign`` is empty."""
    clauses = [
        f"{n} journal {'entry was' if n == 1 else 'entries were'} computed by {runner}"
        for runner, n in sorted(foreign.items(), key=lambda item: (-item[1], item[0]))
    ]
    return f"{', '.join(clauses)}, not reused" if clauses else None


def journal_path(spec: Spec, rank: int, session: str) -> Path:
    """The journal of ``rank`` in the run ``session``."""
    return spec.journal / f"rank{rank:05d}-{session}.jsonl"
