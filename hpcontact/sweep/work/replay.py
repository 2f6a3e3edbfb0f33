"""Wall time of a sweep on R ranks, replayed before it runs.

**Wall time on R ranks** (``replay``): a discrete-event model of the scheduler
(``hpcontact.sweep.run.schedule``): the tasks are chunked and ordered by the real ``make_chunks`` for R
ranks; every rank computes; a worker's claim of the next chunks (``claim_size``) waits for the
server (FIFO, ``Overheads.service_s`` per message) plus the wake-up latency ``wake_s``; rank 0
claims without messages; every task pays ``driver_s`` (journal, progress, scheduling) and
``spread_gather_s`` (its outcome turned into columns by the rank that ran it); before any rank computes, every rank
enumerates and validates 1/R of the parameter space (``spread_setup_s`` per task, divided by R)
and rank 0 alone joins the shares, decides what to run and broadcasts the plan (``setup_s`` per
task); at the end rank 0 alone joins the ranks' columns and writes the data set (``gather_s``
per task) while the others wait. Wall time = makespan; efficiency = Σ task seconds / (R ×
makespan).
``benchmarks/sweep_scale.py`` measures the overheads and replays real task costs with this model.

**Claims** (``claim_size``). One request to rank 0's counter costs a worker a round trip
(``wake_s + service_s`` when the server is free, ~2.5 ms on the development machine; 5.5 ms a
task on a loaded 16-core node, issue 40). A chunk of one cheap task (an exact-cell solve of
10-65 ms is its own kernel group: one task, one chunk) would pay it every task, so a rank asks
for k consecutive chunks at once (``schedule.claimed_chunks``): enough that its mean round trip
so far is at most ``CLAIM_OVERHEAD_SHARE`` (2 %) of k of its chunks' mean measured seconds, and
at most the remaining chunks / (``CHUNKS_PER_RANK`` R), the bound of guided self-scheduling
(Polychronopoulos and Kuck, IEEE Trans. Comput. C-36, 1987): claims shrink as the work runs out
and the last ones are single chunks (the tail as without claims). The first claim is one
chunk (nothing measured yet); rank 0 claims without messages (its round trip, a lock's
microseconds, asks for one chunk at a time but for chunks of microseconds; the replay gives it
one). Measured, not
estimated: the rule needs no cost model and follows the machine's load. The replay applies the
same rule to its own round trips and chunk seconds.

**Adaptive rounds** (``replay_rounds``): an adaptive map runs synchronized rounds
(``hpcontact.sweep.maps.rounds``): every rank enumerates its share of the whole grid once, then
each round's tasks run as one replayed sweep (without setup or gather of their own), and between
rounds rank 0 alone decides the next round (the journal lines not read ahead, the outcomes
joined, the stored stiffnesses of every journaled task, ``dataset.stored_stiffnesses``, the
refinement; after the last round the whole data set made, filled and written: ``between_s``,
measured) while every other rank waits. Rank 0's own work during a round (``rank0_busy_s``:
its announcement, its reading ahead) delays its first chunk, the other ranks taking the claims
meanwhile: it costs about its seconds / R where the round has work enough for the others, and
up to all of it where it does not (the 4-D map's first round on 16 ranks: 136 solves of ~65 ms,
~0.6 s a rank, against an announcement of 0.7-1.0 s). The estimates rank 0 shares out
over the ranks while it decides (``leaf_calls``, ``maps.spread``) cost each the seconds of the
rank with the most (its leaves' parts, as ``assign`` gives them to R ranks: a leaf is
not split, so never less than the largest) plus the call's own overhead (jobs sent, parts
gathered and merged); the sparse grid's decisions shared out by slabs of the grid's first axis
(``SlabCall``) the seconds of the largest of min(R, rows) slabs, each its fixed part plus its
rows at the measured seconds a row, plus the overhead. Makespan = setup + Σ rounds (their makespan + ``between_s`` + the shared
estimates); efficiency = Σ task seconds / (R × makespan).

"""

from __future__ import annotations

import heapq
import math
import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from hpcontact.errors import InputError
from hpcontact.sweep.work.tasks import CHUNKS_PER_RANK, ChunkOrder, Task, chunk_bounds, chunk_order


@dataclass(frozen=True)
class Overheads:
    """Seconds the scheduler and driver add (module docstring). Defaults measured on the 2-core
    development machine (docs/performance.md §"Scheduler and driver overheads"): the claim round
    trip and the server's time per message as ``benchmarks/sweep_scale.py``'s probe measures
    them, the driver's per-task time (scheduling + journal) by ``benchmarks/sweep_scaling.py``,
    rank 0's setup and gather and their shares spread over the ranks by
    ``benchmarks/sweep_scale.py`` on the six-axis job (48 132 tasks)."""

    driver_s: float = 4.3e-3
    service_s: float = 4.5e-5  # server time per message on a full queue
    wake_s: float = 2.5e-3  # claim round trip while rank 0 computes in Python, less service_s
    setup_s: float = 3.2e-5  # rank 0 alone: join the shares, decide, broadcast the plan, chunk
    gather_s: float = 3.4e-5  # rank 0 alone: join the ranks' columns, build and write the data set
    spread_setup_s: float = 6.7e-4  # enumeration and validation, 1/R of it on each rank
    spread_gather_s: float = 1.2e-4  # an outcome turned into columns, on the rank that ran it


# The overheads measured on the development machine (``Overheads``' defaults): the default of every replay.
DEFAULT_OVERHEADS = Overheads()
# A claim's round trip may cost at most this share of the seconds of the chunks it takes (``claim_size``).
CLAIM_OVERHEAD_SHARE = 0.02


def claim_size(round_trip_s: float, chunk_s: float, remaining: int, ranks: int) -> int:
    """How many chunks a rank asks for with its next request (module docstring): ceil(round trip
    / (CLAIM_OVERHEAD_SHARE × chunk seconds)), at most ``remaining`` // (CHUNKS_PER_RANK ×
    ``ranks``), at least 1; 1 while nothing is measured (``round_trip_s`` or ``chunk_s`` not
    positive: a first claim, or rank 0's own)."""
    if round_trip_s <= 0.0 or chunk_s <= 0.0:
        return 1
    wanted = math.ceil(round_trip_s / (CLAIM_OVERHEAD_SHARE * chunk_s))
    return max(1, min(wanted, remaining // (CHUNKS_PER_RANK * ranks)))


def replay(
    tasks: Sequence[Task], seconds: Mapping[str, float], ranks: int, overheads: Overheads = DEFAULT_OVERHEADS
) -> dict[str, float]:
    """Discrete-event model of one sweep of ``tasks`` (their one-core ``seconds`` by key) on
    ``ranks`` ranks (module docstring): makespan, efficiency and where the time goes (shares of
    the makespan lost to the tail, to claims, and to setup + gather)."""
    if ranks < 1:
        raise InputError("ranks", "an integer >= 1", ranks)
    tasks = list(tasks)
    times = np.array([seconds[t.key] for t in tasks], dtype=np.float64)
    return replay_chunks(chunk_order(tasks), times, ranks, overheads)


def _chunk_sums(values: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """Each chunk's sum of ``values`` (in chunk order), summed in order as ``make_chunks``' tuples are."""
    sums = np.empty(len(starts), dtype=np.float64)
    single = stops - starts == 1
    sums[single] = values[starts[single]]
    for k in np.flatnonzero(~single).tolist():
        sums[k] = sum(values[starts[k] : stops[k]].tolist())
    return sums


def replay_chunks(
    chunks: ChunkOrder, seconds: np.ndarray, ranks: int, overheads: Overheads, rank0_busy_s: float = 0.0
) -> dict[str, float]:
    """``replay`` of the tasks in ``chunks`` (``tasks.chunk_order``) with ``seconds`` in task
    order: the chunks ``make_chunks`` makes for ``ranks`` (``tasks.chunk_bounds``), each chunk's
    work summed in its order as ``make_chunks``' tuples would be, then taken by the ranks in
    claims (``claim_size``, from each rank's own round trips and chunk seconds so far).
    ``rank0_busy_s``: rank 0's own work after its first claim, before that claim's chunk (its
    announcement and reading ahead, ``run.rounds``), the other ranks claiming meanwhile."""
    if ranks < 1:
        raise InputError("ranks", "an integer >= 1", ranks)
    starts, stops = chunk_bounds(chunks, ranks)
    per_task = overheads.driver_s + overheads.spread_gather_s
    work = _chunk_sums(seconds[chunks.order] + per_task, starts, stops)  # with the per-task overheads
    n = len(seconds)
    setup = overheads.setup_s * n + overheads.spread_setup_s * n / ranks
    claim_wait, claims = 0.0, 0
    if ranks == 1:  # rank 0 alone: each chunk starts when the last one ends
        last = setup + rank0_busy_s
        for chunk in work.tolist():
            last = last + chunk
        finish, claims = [last], len(work)
    else:
        free = [(setup, r) for r in range(ranks)]  # every rank starts after the setup
        heapq.heapify(free)
        server_free = setup
        finish = [setup] * ranks
        # each rank's claims, round trips and chunks so far, and where its last claim ended
        asked, waited, taken, busy, seen = [0] * ranks, [0.0] * ranks, [0] * ranks, [0.0] * ranks, [0] * ranks
        chunk_list, count, at = work.tolist(), len(work), 0
        service_s, wake_s, replace_first = overheads.service_s, overheads.wake_s, heapq.heapreplace
        while at < count:
            t, rank = free[0]
            if rank == 0:
                start, k = t, 1
            else:
                k = (
                    claim_size(waited[rank] / asked[rank], busy[rank] / taken[rank], count - seen[rank], ranks)
                    if asked[rank]
                    else 1
                )
                served = (t if t > server_free else server_free) + service_s  # max(t, server_free)
                server_free = served
                start = served + wake_s
                claim_wait += start - t
                asked[rank] += 1
                waited[rank] += start - t
            got = chunk_list[at : at + k]
            at += len(got)
            seen[rank] = at
            end = start + rank0_busy_s if rank == 0 and not taken[0] else start
            for chunk in got:
                end = end + chunk
            taken[rank] += len(got)
            busy[rank] += end - start
            finish[rank] = end
            claims += 1
            replace_first(free, (end, rank))
        last = max(finish)
    makespan = last + overheads.gather_s * n
    work_total = float(sum(seconds.tolist()))
    return {
        "chunks": len(starts),
        "claims_taken": claims,
        "makespan_s": makespan,
        "efficiency": work_total / (ranks * makespan) if makespan > 0 else 1.0,
        "tail": (last - statistics.fmean(finish)) / makespan if makespan > 0 else 0.0,
        "claims": claim_wait / (ranks * makespan) if makespan > 0 else 0.0,
        "setup_gather": (setup + overheads.gather_s * n) / makespan if makespan > 0 else 0.0,
    }


@dataclass(frozen=True)
class LeafCall:
    """One estimate rank 0 shared out over the ranks (``maps.spread.LeafPool.map``): each leaf's
    box points and the CPU seconds its part took, and what the call cost beyond its parts
    (sending the jobs, gathering and merging the parts), in seconds."""

    points: tuple[int, ...]
    seconds: tuple[float, ...]
    overhead_s: float


@dataclass(frozen=True)
class SlabCall:
    """One sparse-grid decision rank 0 shared out by slabs (``maps.spread.LeafPool.slabs``):
    each slab's rows of the grid's first axis and the CPU seconds it took, rank 0's own seconds
    beyond its slab (sending the job, combining what the slabs yield, unpickling their results)
    and the seconds of a slab that do not shrink with its rows (``fixed_s``: its grid of the
    nodes' values, the contractions before the first axis', the bookkeeping per index)."""

    rows: tuple[int, ...]
    seconds: tuple[float, ...]
    overhead_s: float
    fixed_s: float = 0.0


def slab_call_seconds(call: SlabCall, ranks: int) -> float:
    """The seconds ``call`` takes on ``ranks`` ranks: one slab a rank, at most one a row
    (``sparse_grid.slab_rows``), each ``call.fixed_s`` plus its rows at the measured seconds a
    row beyond that ((Σ seconds − slabs × fixed_s) / Σ rows): the largest slab's, plus
    ``call.overhead_s``."""
    rows = sum(call.rows)
    if not rows:
        return call.overhead_s
    largest = -(-rows // max(1, min(ranks, rows)))
    rate = max(sum(call.seconds) - len(call.rows) * call.fixed_s, 0.0) / rows
    return call.fixed_s + rate * largest + call.overhead_s


def call_seconds(call: LeafCall | SlabCall, ranks: int) -> float:
    """``leaf_call_seconds`` or ``slab_call_seconds``, by the kind of ``call``."""
    return leaf_call_seconds(call, ranks) if isinstance(call, LeafCall) else slab_call_seconds(call, ranks)


def assign(points: Sequence[int], ranks: int) -> list[list[int]]:
    """The jobs (positions in ``points``, each a leaf's box points) each of ``ranks`` ranks
    computes (``hpcontact.sweep.maps.spread``: each job a leaf's part of the map-error estimate): the largest first (ties: the earlier) to the rank with the
    fewest points so far (ties: the lower rank)."""
    load = [0] * ranks
    out: list[list[int]] = [[] for _ in range(ranks)]
    for job in sorted(range(len(points)), key=lambda j: (-points[j], j)):
        rank = min(range(ranks), key=lambda r: (load[r], r))
        out[rank].append(job)
        load[rank] += points[job]
    return out


def leaf_call_seconds(call: LeafCall, ranks: int) -> float:
    """The seconds ``call`` takes on ``ranks`` ranks: the parts assigned as ``spread`` assigns
    them (``assign``), the largest rank's sum, plus ``call.overhead_s``."""
    shares = assign(list(call.points), ranks)
    return max((sum(call.seconds[j] for j in share) for share in shares), default=0.0) + call.overhead_s


def replay_rounds(
    rounds: Sequence[tuple[ChunkOrder, np.ndarray]],
    ranks: int,
    between_s: Sequence[float],
    tasks: int,
    overheads: Overheads = DEFAULT_OVERHEADS,
    rank0_busy_s: Sequence[float] | None = None,
    leaf_calls: Sequence[Sequence[LeafCall | SlabCall]] | None = None,
) -> dict[str, float]:
    """Discrete-event model of an adaptive map's synchronized rounds (module docstring): each
    round's tasks (``tasks.chunk_order`` of them and their one-core seconds in task order) run
    as one ``replay_chunks`` without setup or gather, then rank 0 alone spends the round's
    ``between_s`` (journals, stored stiffnesses, refinement; after the last round: the data set
    made, filled and written)
    while the other ranks wait; before the first round every rank enumerates its share of the
    whole grid's ``tasks`` and rank 0 joins them (``spread_setup_s``, ``setup_s`` per task, as
    ``replay_chunks``); ``rank0_busy_s`` (None: none), per round, rank 0's own work during it
    (its announcement, its reading ahead: ``replay_chunks``' ``rank0_busy_s``), the other
    ranks taking the claims meanwhile. Makespan, efficiency, and the shares of the makespan
    lost between rounds (rank 0 alone and the shared estimates) and to the rounds' own tails
    (rank 0's work during a round that the other ranks' claims do not cover among them) and claims.
    ``leaf_calls`` (None: none), per round, the estimates rank 0 shares out over the ranks after
    it (``maps.spread``): each ``LeafCall``'s parts go to the ranks as ``assign`` gives
    them for ``ranks``, and the call takes the largest rank's seconds plus its ``overhead_s``
    (``leaf_call_seconds``; a ``SlabCall``: ``slab_call_seconds``), every other rank waiting."""
    if ranks < 1:
        raise InputError("ranks", "an integer >= 1", ranks)
    if len(between_s) != len(rounds):
        raise InputError("between_s", f"one time per round ({len(rounds)})", len(between_s))
    busy = [0.0] * len(rounds) if rank0_busy_s is None else list(rank0_busy_s)
    if len(busy) != len(rounds):
        raise InputError("rank0_busy_s", f"one time per round ({len(rounds)})", len(busy))
    calls = [[] for _ in rounds] if leaf_calls is None else [list(c) for c in leaf_calls]
    if len(calls) != len(rounds):
        raise InputError("leaf_calls", f"one list per round ({len(rounds)})", len(calls))
    between_s = [b + sum(call_seconds(c, ranks) for c in round_calls) for b, round_calls in zip(between_s, calls)]
    within = Overheads(
        driver_s=overheads.driver_s,
        service_s=overheads.service_s,
        wake_s=overheads.wake_s,
        setup_s=0.0,
        gather_s=0.0,
        spread_setup_s=0.0,
        spread_gather_s=overheads.spread_gather_s,
    )
    setup = overheads.setup_s * tasks + overheads.spread_setup_s * tasks / ranks
    makespan, work, lost_tail, lost_claims = setup, 0.0, 0.0, 0.0
    between_total = float(sum(between_s))
    for (chunks, seconds), between, own in zip(rounds, between_s, busy):
        one = replay_chunks(chunks, seconds, ranks, within, own)
        makespan += one["makespan_s"] + between
        work += float(sum(seconds.tolist()))
        lost_tail += one["tail"] * one["makespan_s"]
        lost_claims += one["claims"] * one["makespan_s"]
    return {
        "rounds": len(rounds),
        "makespan_s": makespan,
        "efficiency": work / (ranks * makespan) if makespan > 0 else 1.0,
        "between": between_total / makespan if makespan > 0 else 0.0,
        "tail": lost_tail / makespan if makespan > 0 else 0.0,
        "claims": lost_claims / makespan if makespan > 0 else 0.0,
        "setup": setup / makespan if makespan > 0 else 0.0,
    }
