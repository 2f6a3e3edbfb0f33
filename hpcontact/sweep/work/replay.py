"""Wall time of a sweep on R ranks, replayed before it runs.

**Wall time on R ranks** (``replay``): a discrete-event model of the scheduler
(``hpcontact.sweep.run.schedule``): the tasks are chunked and ordered by the real ``make_chunks`` for R
ranks; every rank computes; a worker's claim of the next chunk waits for the server (FIFO,
``Overheads.service_s`` per message) plus the wake-up latency ``wake_s``; rank 0 claims without
messages; every task pays ``driver_s`` (journal, progress, scheduling) and ``spread_gather_s``
(its outcome turned into columns by the rank that ran it); before any rank computes, every rank
enumerates and validates 1/R of the parameter space (``spread_setup_s`` per task, divided by R)
and rank 0 alone joins the shares, decides what to run and broadcasts the plan (``setup_s`` per
task); at the end rank 0 alone joins the ranks' columns and writes the data set (``gather_s``
per task) while the others wait. Wall time = makespan; efficiency = Σ task seconds / (R ×
makespan).
``benchmarks/sweep_scale.py`` measures the overheads and replays real task costs with this model.

"""

from __future__ import annotations

import heapq
import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from hpcontact.errors import InputError
from hpcontact.sweep.work.tasks import ChunkOrder, Task, chunk_bounds, chunk_order


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


def replay_chunks(chunks: ChunkOrder, seconds: np.ndarray, ranks: int, overheads: Overheads) -> dict[str, float]:
    """``replay`` of the tasks in ``chunks`` (``tasks.chunk_order``) with ``seconds`` in task
    order: the chunks ``make_chunks`` makes for ``ranks`` (``tasks.chunk_bounds``), each chunk's
    work summed in its order as ``make_chunks``' tuples would be, then taken by the ranks."""
    if ranks < 1:
        raise InputError("ranks", "an integer >= 1", ranks)
    starts, stops = chunk_bounds(chunks, ranks)
    per_task = overheads.driver_s + overheads.spread_gather_s
    work = seconds[chunks.order] + per_task  # each task's seconds and overheads, in chunk order
    single = stops - starts == 1
    chunk_seconds = np.empty(len(starts), dtype=np.float64)
    chunk_seconds[single] = work[starts[single]]
    for k in np.flatnonzero(~single).tolist():
        chunk_seconds[k] = sum(work[starts[k] : stops[k]].tolist())
    n = len(seconds)
    setup = overheads.setup_s * n + overheads.spread_setup_s * n / ranks
    claim_wait = 0.0
    if ranks == 1:  # rank 0 alone: each chunk starts when the last one ends
        last = setup
        for chunk in chunk_seconds.tolist():
            last = last + chunk
        finish = [last]
    else:
        free = [(setup, r) for r in range(ranks)]  # every rank starts after the setup
        heapq.heapify(free)
        server_free = setup
        finish = [setup] * ranks
        service_s, wake_s, replace_first = overheads.service_s, overheads.wake_s, heapq.heapreplace
        for chunk in chunk_seconds.tolist():
            t, rank = free[0]
            if rank == 0:
                start = t
            else:
                served = (t if t > server_free else server_free) + service_s  # max(t, server_free)
                server_free = served
                start = served + wake_s
                claim_wait += start - t
            end = finish[rank] = start + chunk
            replace_first(free, (end, rank))
        last = max(finish)
    makespan = last + overheads.gather_s * n
    work_total = float(sum(seconds.tolist()))
    return {
        "chunks": len(starts),
        "makespan_s": makespan,
        "efficiency": work_total / (ranks * makespan) if makespan > 0 else 1.0,
        "tail": (last - statistics.fmean(finish)) / makespan if makespan > 0 else 0.0,
        "claims": claim_wait / (ranks * makespan) if makespan > 0 else 0.0,
        "setup_gather": (setup + overheads.gather_s * n) / makespan if makespan > 0 else 0.0,
    }
