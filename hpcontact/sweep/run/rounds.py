"""The MPI rounds of a run: every rank's share joined into the tasks, rank 0's decision
(``resume.prepare``) broadcast, the tasks run in claims from the shared counter and journaled,
and rank 0's data set (``assembly.assemble``); see ``hpcontact.sweep.driver``.

A rank takes several consecutive chunks (``tasks.make_chunks``) with one request to the counter
when its chunks are cheap against the request's round trip (``schedule.claimed_chunks``,
``replay.claim_size``): exact cells (one task, one kernel group, one chunk each) no longer pay a
round trip a task. Claims change only which rank runs a task and when: every task is journaled
and recorded as it would be alone.

Rank 0 of an adaptive map reads the journals the ranks append while it takes claims
(``journal.HistoryReader.advance``, at most ``READ_AHEAD_SHARE`` of its time in the round): the
next round's decision parses only the lines written after its last claim, not the whole round's
(issue 40 item 5: parsing a round's lines took rank 0 alone up to seconds, the other ranks
waiting; during the round the other ranks take the claims rank 0 does not).
While rank 0 decides the next round, the other ranks compute parts of its map-error estimate
with it (``maps.spread``: the leaves' parts, or the sparse grid's slabs; bitwise the estimate of
one process) instead of waiting.

Rank 0 takes its first claim, then announces the round (its line and estimate: the cost model's
probe of the machine, 0.3 CPU s, and ``scipy.fft`` for its solves, 0.3) and, where the round's
work covers it, imports what its data set needs (``dataset.import_array_modules``: xarray and
dask where installed, 0.4-0.6 CPU s on the 2-core development VM), before its first task: the
other ranks claim meanwhile (served by rank 0's thread), not wait for it in the set-up or a
decision. Done before its first claim it left a small sweep's every task to the other ranks;
done between two of its tasks it stalled its claims past the cluster check's bound. An adaptive
map decides without xarray (``maps.rounds``), so rank 0 imports it in the first round with work
enough for the others (``imports_array_modules``), not in a short first round the others would
finish first (the 4-D map's 136 solves on 16 ranks, ~0.5 s a rank, waited for 0.9-1.4 CPU s of
announcement and imports)."""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from itertools import chain, islice
from pathlib import Path
from typing import Any, TextIO

from hpcontact import accuracy
from hpcontact.errors import ConvergenceError, Front, InputError, Message, rendered
from hpcontact.numerics.blas import limited_blas
from hpcontact.numerics.convolution import expect_applications
from hpcontact.problems.footprint import fft_applications
from hpcontact.sweep import faults
from hpcontact.sweep.data import provenance
from hpcontact.sweep.data.columns import to_columns
from hpcontact.sweep.data.journal import BAD_INPUT, ERROR, NOT_CONVERGED, OK, Entry, Journal, to_json
from hpcontact.sweep.run.arguments import EXIT_OK, EXIT_STOPPED, EXIT_UNEXPECTED
from hpcontact.sweep.run.assembly import assemble
from hpcontact.sweep.run.options import RESUME, RETRY_CRASHED
from hpcontact.sweep.run.progress import Progress
from hpcontact.sweep.run.records import (
    EVERY_TASK,
    NO_FLAGS,
    Decision,
    Kept,
    Options,
    Outcome,
    Plan,
    RankTotals,
    RoundMemory,
    RoundScope,
    RoundTally,
    Stopped,
    TaskFunction,
)
from hpcontact.sweep.run.resume import journal_path, prepare
from hpcontact.sweep.run.schedule import SLOTS, Team, claimed_chunks, cost_units, report_done, totals_done, world
from hpcontact.sweep.run.shares import from_rank_zero, joined, packed, share, unpacked
from hpcontact.sweep.run.signals import Abandoned, StopControl
from hpcontact.sweep.space.parse import load_spec
from hpcontact.sweep.space.spec import Spec, Validator
from hpcontact.sweep.work.batches import batch_fill, plan_batches, run_batch
from hpcontact.sweep.work.estimate import start_estimate
from hpcontact.sweep.work.tasks import Task, changed_inputs, frozen_heap, make_chunks

# Rank 0 of an adaptive map reads the journals ahead while the round runs for at most this share
# of its time in the round (module docstring); the rest it computes tasks.
READ_AHEAD_SHARE = 0.25
#: Rank 0 of an adaptive map imports its data set's modules in the first round whose estimated
#: task seconds per rank reach this (``imports_array_modules``): about twice the imports' 0.4-0.6
#: CPU s after a run's own imports (``benchmarks/adaptive_scaling.py``, 2-core development VM,
#: 2026-11-29). A round that covers them only in part loses the rest; no round at all, the whole
#: of them, every rank waiting for the data set: a low bound errs the cheaper way.
ARRAY_IMPORTS_COVER_S = 1.0
#: An adaptive round probes the machine for its start estimate (where no calibration is cached,
#: ``cost.prior.probe_pending``) only when its estimated task seconds per rank by the shipped
#: prior reach this: about twice the probe's 0.85-0.90 CPU s with its scipy.fft import (2-core
#: development VM, 2026-11-29); a shorter round's line is the prior's, unscaled, and says so.
#: Probing in the 4-D map's first round on 16 ranks (~0.5 s a rank) kept the other 15 waiting.
PROBE_COVER_S = 2.0


def imports_array_modules(scope: RoundScope, per_rank_s: float) -> bool:
    """Whether rank 0 imports its data set's modules (``dataset.import_array_modules``) during a
    round of ``scope`` whose tasks are estimated at ``per_rank_s`` seconds a rank: a plain run's
    one round always (its data set follows it), an adaptive round where ``per_rank_s`` reaches
    ``ARRAY_IMPORTS_COVER_S`` (the other ranks' claims cover the imports); otherwise rank 0
    imports them with its data set, after the map's last round."""
    return scope.tally is None or per_rank_s >= ARRAY_IMPORTS_COVER_S


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


@dataclass(frozen=True)
class Run:
    """What every round of one run shares: the team, the spec and its tasks (joined from the
    ranks' shares, each point's task, whether one may exceed the memory per rank), the task
    function (None: the spec's scene kind's), rank 0's stream, this rank's stop control, the
    run's start (``time.perf_counter``), and the command as its user gave it (the data set's
    history; None: the spec's ``hpcontact run`` line, ``run.assembly``)."""

    team: Team
    spec: Spec
    tasks: list[Task]
    task_of: Any
    over: bool
    task_function: TaskFunction | None
    stream: TextIO
    stop: StopControl
    started: float
    command: str | None


def execute(
    spec_path: str | Path | Spec,
    output: str | Path | None = None,
    task_function: TaskFunction | None = None,
    *,
    team: Team | None = None,
    validate: Validator | None = None,
    stream: TextIO | None = None,
    options: Options = NO_FLAGS,
    stop: StopControl | None = None,
    accuracy: float | None = None,
    command: str | None = None,
) -> Outcome:
    """Run the sweep of ``spec_path`` on ``team`` (default: MPI world, or one process).

    ``options`` say what to do with existing journals and locks (``hpcontact.sweep.driver``);
    ``output`` overrides the spec's output path and ``accuracy`` its [numerics] accuracy, n and
    n_across (``hpcontact run --accuracy``); ``task_function`` solves one scene and ``validate``
    checks one scene's parameters (defaults: those of the spec's scene kind,
    ``accuracy.task_function``); rank 0 prints progress and the summary to ``stream`` (default
    stdout); ``stop`` is this rank's stop control (default: one without signal handlers, which
    still stops with the other ranks). Spec errors and refusals raise ``InputError``
    (``Refused``) on every rank before any work starts; a stopped run raises ``Stopped`` on
    every rank. ``spec_path`` may be a ``Spec`` already parsed (``space.parse.parse_spec`` with
    ``check_scenes=False``; ``output`` None): a spec given as a dict (``hpcontact.run_sweep``).
    With ``options.up_to_date``, a sweep whose data set is ``up_to_date`` prints one line and
    returns it (``Outcome.up_to_date``): nothing is run or written. ``command`` is the command
    as its user gave it, for the data set's history (``provenance.call_text`` or
    ``provenance.command_line``; None: "hpcontact run SPEC").
    """
    team = team if team is not None else world()
    started = time.perf_counter()  # after the imports and MPI start-up
    stream = stream if stream is not None else sys.stdout
    stop = stop if stop is not None else StopControl()
    spec = from_rank_zero(
        team,
        lambda: (
            spec_path
            if isinstance(spec_path, Spec) and output is None and accuracy is None
            else load_spec(spec_path, output=output, validate=validate, check_scenes=False, accuracy=accuracy)
        ),
    )
    # every rank needs every task (chunks are claimed from one shared counter); each rank keeps
    # its own share as it is and unpacks the others' (shares.packed, unpacked: rows as plain
    # tuples, unpacked with the collector off); one process sends nothing
    mine = share(spec, team.rank, team.size, validate, options)
    sent = [None] if team.size == 1 else team.bcast(team.gather(packed(mine)))
    shares = [mine if r == team.rank else unpacked(b) for r, b in enumerate(sent)]
    tasks, task_of, over = joined(spec, shares)
    run = Run(team, spec, tasks, task_of, over, task_function, stream, stop, started, command)
    # each round with what is alive at its start frozen (the grid's tasks, the journals so far)
    if spec.adaptive is None:
        with frozen_heap():
            return _round(run, options, EVERY_TASK)
    tally, memory = RoundTally(), RoundMemory()

    def run_round(
        options: Options,
        select: frozenset[int] | None = None,
        finish: Callable | None = None,
        earlier: frozenset[int] = frozenset(),
    ) -> Outcome:
        with frozen_heap():
            return _round(run, options, RoundScope(select, finish, tally, earlier, memory))

    # rounds of runs over subsets of the tasks (hpcontact.sweep.maps)
    from hpcontact.sweep.maps.rounds import run_rounds

    return run_rounds(team, spec, task_of, options, stream, run_round)


def _round(run: Run, options: Options, scope: RoundScope) -> Outcome:
    """Every rank: rank 0 prepares, the ranks run the plan (see ``execute``) over the tasks of
    ``scope``; the set-up runs from the round's start (the first's from the run's)."""
    team, spec = run.team, run.spec
    round_started = run.started
    if scope.tally is not None:
        round_started = run.started if scope.tally.begun == 0 else time.perf_counter()
        scope.tally.begun += 1
    kept: Kept | None = None  # rank 0's

    def decide() -> Decision:
        nonlocal kept
        decision, kept = prepare(spec, run.tasks, run.task_of, run.over, options, team.size, scope)
        return decision

    decision: Decision = from_rank_zero(team, decide)
    plan = Plan.of(spec, run.tasks, decision)
    try:
        if decision.up_to_date:
            if team.rank == 0:
                print(
                    f"hpcontact: {spec.output} is up to date ({decision.reused} tasks from journals); nothing to do",
                    file=run.stream,
                    flush=True,
                )
            return Outcome(Path(spec.output), 0, up_to_date=True)
        with limited_blas():  # HPCONTACT_BLAS_THREADS while the tasks run (numerics.blas)
            return _run(run, plan, kept, scope, options, round_started)
    finally:
        run.stop.close()
        if kept is not None:
            kept.lock.release()


def _announce(
    run: Run,
    plan: Plan,
    kept: Kept,
    scope: RoundScope,
    todo: list[Task],
    chunks: list[tuple[Task, ...]],
    front: Front,
) -> tuple[Progress, float]:
    """Rank 0 before the tasks run: the lock's note, dropped journal lines, changed inputs, the
    round's line (tasks to run, reused, alone on rank 0, quarantined, chunks) and its estimate
    (an adaptive map's in its first round alone), options in ``front``'s words; the progress
    report of the tasks handed out, and the tasks' estimated seconds a rank."""
    spec, stream, decision = run.spec, run.stream, plan.decision
    if kept.note:
        print(f"hpcontact: {rendered(kept.note, front)}", file=stream)
    if kept.history.dropped:
        print(f"hpcontact: warning: {kept.history.dropped_note(spec.journal)}", file=stream)
    # a mask replaced under its path; the tasks this round runs, not the whole grid (an adaptive
    # map's 139 725 tasks took rank 0 ~1 s a round, every other rank waiting)
    changed = changed_inputs(todo, kept.history.entries)
    if changed:
        print(f"hpcontact: {changed}", file=stream)
    print(
        f"hpcontact: {spec.title}: {len(run.tasks)} tasks, {len(todo)} to run"
        f"{f' ({decision.reused} from journals)' if decision.reused else ''}"
        f"{f', {len(plan.isolated)} alone on rank 0 (their last run died)' if plan.isolated else ''}"
        f"{f', {decision.crashed} quarantined ({RETRY_CRASHED.advised(front)} runs them)' if decision.crashed else ''}"
        f", {len(chunks)} chunks on {run.team.size} rank(s); writes {spec.output}",
        file=stream,
        flush=True,
    )
    line, seconds = start_estimate(
        todo, run.team.size, run.team.node_size, 0.0 if scope.tally is None else PROBE_COVER_S
    )
    if scope.tally is None or scope.tally.begun == 1:  # an adaptive map's later rounds: said once, in its first
        print(line, file=stream, flush=True)
    handed = [t for chunk in chunks for t in chunk]  # what the ranks report, in hand-out order
    estimated = dict(zip((t.key for t in todo), seconds.tolist()))
    # an adaptive round counts its own tasks: "14/61" of a round of 25 read as the whole map's
    adaptive = scope.tally is not None
    progress = Progress(
        decision.reused + len(todo) if adaptive else len(run.tasks),
        decision.reused,
        [cost_units(t.cost) for t in handed],
        [estimated[t.key] for t in handed],
        spec.progress_interval,
        stream,
        run.team.size,
        [len(chunk) for chunk in chunks],
        f"adaptive round {scope.tally.begun}: " if adaptive else "",
    )
    return progress, sum(seconds.tolist()) / run.team.size


def _run(run: Run, plan: Plan, kept: Kept | None, scope: RoundScope, options: Options, round_started: float) -> Outcome:
    """Every rank: the work of ``plan``, then rank 0 assembles the data set (see ``execute``)
    from what it ``kept`` (None on the other ranks); the set-up runs from ``round_started``,
    the wall time from the run's start."""
    team, spec, tasks, stop, decision = run.team, plan.spec, plan.tasks, run.stop, plan.decision
    task_function = run.task_function if run.task_function is not None else accuracy.task_function(spec.kind)
    chunks = make_chunks(plan.shared, team.size)
    # this rank's share of the FFT applications per grid, estimated from every R-th task (the
    # work stays 1/R of the tasks per rank): grids the sweep uses often get measured FFTW plans
    # at their first application, not after ~40-80 (hpcontact.numerics.convolution)
    todo = plan.isolated + plan.shared
    expect_applications(fft_applications(t.params for t in todo[team.rank :: team.size]))
    setup_s = time.perf_counter() - round_started

    # the position of each task this round runs (not of every task of the grid: on the 4-D map's
    # 139 725, 0.08 CPU s a round on every rank, before its first claim)
    index = {tasks[i].key: i for i in (*decision.isolated, *decision.shared)}
    task_s = schedule_s = journal_s = 0.0
    ran = 0
    failure: str | None = None
    stop.watch(spec.journal, team.rank, team.size, session=decision.session)
    counter = team.counter(SLOTS)
    journal = Journal(
        journal_path(spec, team.rank, decision.session),
        team.rank,
        {"session": decision.session, "spec_path": str(spec.path), **decision.provenance},
    )
    done: list[Entry] = []  # this rank's outcomes, and their tasks' positions
    done_at: list[int] = []
    # rank 0 of an adaptive map: the journals' reader its next round's decision reads from
    reader = scope.memory.reader if team.rank == 0 and scope.memory is not None else None
    # a GPU rank claims the chunks that fill a batch, handed as one tuple (work.batches.batch_fill)
    claim = time.perf_counter()
    claims = claimed_chunks(chunks, counter, team.size, fill=batch_fill(chunks, task_function))
    progress: Progress | None = None
    taken: list[tuple[Task, ...]] = []
    if team.rank == 0:  # its first claim, then the round's line and its data set's imports: the others claim meanwhile
        taken = list(islice(claims, 1))
        schedule_s += time.perf_counter() - claim
        progress, per_rank_s = _announce(run, plan, kept, scope, todo, chunks, options.front)
        if imports_array_modules(scope, per_rank_s):
            from hpcontact.sweep.data.dataset import import_array_modules  # rank 0's alone (assembly)

            import_array_modules()
    read_s, claims_started = 0.0, time.perf_counter()

    def run_alone(task: Task) -> Entry:
        return run_task(task_function, task, team.rank, stop, decision.faults.get(index[task.key]))

    def run_tasks(batch: tuple[Task, ...]) -> None:
        """One task, or a batch of scenes a GPU rank solves together (``work.batches``)."""
        nonlocal task_s, journal_s, ran
        mark = time.perf_counter()
        for task in batch:
            journal.started(task.key)
        journal_s += time.perf_counter() - mark
        try:
            entries = run_batch(batch, team.rank, run_alone, stop)
        except Abandoned as exc:
            for task in batch:
                journal.interrupted(task.key, str(exc))
            return
        except BaseException:
            for task in batch:
                journal.interrupted(task.key, "the run was interrupted")
            raise
        for task, entry in zip(batch, entries):
            entry = replace(entry, resolved=provenance.resolved_scene(task.params), provenance=decision.provenance)
            task_s += entry.wall_time_s
            ran += 1
            mark = time.perf_counter()
            faults.tear(decision.faults.get(index[task.key]), journal.line(entry), journal.write_raw)
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
                    run_tasks((task,))
            claim = time.perf_counter()
            for chunk in chain(taken, claims):
                schedule_s += time.perf_counter() - claim
                if stop.stopping:
                    break
                for batch in plan_batches(chunk, task_function, alone=lambda t: index[t.key] in decision.faults):
                    if stop.stopping:
                        break
                    run_tasks(batch)
                    mark = time.perf_counter()
                    for task in batch:
                        report_done(counter, task.cost)
                    schedule_s += time.perf_counter() - mark
                    if progress is not None and progress.due():
                        progress.report(*totals_done(counter))
                mark = time.perf_counter()
                if reader is not None and read_s < READ_AHEAD_SHARE * (mark - claims_started):
                    reader.advance()
                    read_s += time.perf_counter() - mark
                    journal_s += time.perf_counter() - mark
                claim = time.perf_counter()
            schedule_s += time.perf_counter() - claim
        finally:
            journal.close()
    except OSError as exc:  # the journal cannot be written: stop this rank cleanly, and the others
        failure = f"cannot write {exc.filename or spec.journal}: {exc.strerror or exc}"
        stop.request(f"rank {team.rank}: {failure}", failed=True)
    counter.close()
    stop.enter("finish")
    totals: list[RankTotals] = team.gather(
        RankTotals(
            task_s=task_s,
            run=ran,
            schedule_s=schedule_s,
            journal_s=journal_s,
            sync_s=journal.sync_s,
            reason=stop.reason,
            failed=stop.failed,
            failure=failure,
            columns=None if stop.reason is not None else to_columns(done, done_at),
        )
    )

    # an adaptive round: the other ranks compute rank 0's estimate with it while it decides (maps.spread)
    shared = scope.finish is not None and team.size > 1
    if shared and team.rank != 0:
        from hpcontact.sweep.maps.spread import serve

        serve(team)

    def finish() -> tuple[Outcome | None, str, int]:
        if not shared:
            return concluded()
        from hpcontact.sweep.maps.spread import shared_estimates

        with shared_estimates(team):
            return concluded()

    def concluded() -> tuple[Outcome | None, str, int]:
        stopped = [t for t in totals if t.reason is not None]
        if stopped:
            failed = [t.failure for t in totals if t.failure]
            ran = sum(t.run for t in totals)
            status = EXIT_UNEXPECTED if any(t.failed for t in stopped) else EXIT_STOPPED
            what = f"stopped ({'; '.join(failed) if failed else stopped[0].reason})"
            return (
                None,
                Message(
                    f"hpcontact: {what}: {ran} tasks finished in this run; journals intact in "
                    f"{spec.journal}; run again with ",
                    RESUME,
                ),
                status,
            )
        try:
            outcome = assemble(
                plan, kept, scope, team.size, totals, run.started, setup_s, options, run.stream, run.command
            )
            stop.enter("done")  # the data set is written: a stop request changes nothing now
            faults.slow_phase("done")
            return outcome, "", EXIT_OK
        except OSError as exc:  # a full disk at the end: the journals hold everything
            return (
                None,
                Message(
                    f"hpcontact: cannot write the data set {exc.filename or spec.output}: {exc.strerror or exc}; "
                    f"journals intact in {spec.journal}; free space and run again with ",
                    RESUME,
                ),
                EXIT_UNEXPECTED,
            )

    outcome, message, status = from_rank_zero(team, finish)
    stop.enter("done")
    if outcome is None:
        raise Stopped(message, status)
    return outcome
