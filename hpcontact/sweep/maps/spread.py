"""Rank 0's estimate between an adaptive map's rounds, shared out over the ranks (issue 40 item 5).

After each round rank 0 decides the next from the values at the nodes (``maps.rounds``): the
refinement, the check rounds and the last round's fill estimate the map error of every leaf
(``refinement.estimate``), which was half of rank 0's time between rounds while every other
rank waited (the refinement 4.9 and the fill 1.8 of 13.4 CPU s between rounds on the 4-D
stand-in map before this: ``benchmarks/adaptive_scaling.py``, 2026-11-29; docs/performance.md).
Each leaf's part of an estimate is a function of a small job alone (``refinement.LeafJob``: its
coordinates, nodes and the values there), so the ranks compute the parts while rank 0 decides:

* every rank but 0 ``serve``\\ s after a round's tasks, until rank 0 has decided;
* rank 0 decides inside ``shared_estimates``: each ``estimate`` broadcasts its leaves' jobs and
  who computes which (``assign``), every rank computes its own (rank 0 too) and rank 0 gathers
  the parts, merges them in leaf order (``refinement.estimate``) and goes on; leaving, it tells
  the ranks to stop serving.

What it guarantees: a part is ``refinement.leaf_estimate(job)`` on whichever rank computes it
(the same code on the same numbers, float64), and the merge takes the parts in leaf order, so
the estimate, the next round's nodes, the map and its errors are bitwise those of one process
(``tests/mpi/test_adaptive_spread.py``; ``tests/sweep/maps/test_spread.py``). Only when the
parts are computed changes. A rank's failure in a part is raised on rank 0 after the gather
(every rank takes part in each collective, so none waits forever); a decision that fails
still tells the ranks to stop serving before its error reaches them (``rounds._run``).

Assignment (``assign``): longest processing time first (Graham, SIAM J. Appl. Math. 17, 1969),
by the points of each leaf's box: the largest leaf to the rank with the least so far. A leaf's
part cannot be split further, so an estimate's time on R ranks is its largest leaf's at least
(``replay.replay_rounds`` replays it so, from the parts' measured seconds).

The sparse grid (``maps.sparse_grid``) has no independent parts: its estimate at a point sums
every active index's surplus there, scaled by maxima over the whole grid. It is shared out by
slabs instead (``LeafPool.slabs``): each rank computes the points of a range of the grid's
first axis (``sparse_grid.slab_rows``: as many slabs as ranks, at most one a row) in step with
the others (``_slab_steps``): where a slab needs the whole grid (the surpluses' maxima, the
scale's fallback) every rank sends its part to rank 0, which combines them exactly
(``sparse_grid.reduce_slabs``: maxima, whatever the order) and broadcasts the whole; rank 0
gathers the slabs' results in order (the estimate's arrays, joined along the first axis, or
each index's score, of which the refinement takes the largest). Every number at a point is
computed as one process computes it (``sparse_grid._along``), so the decisions, the map and its
errors are again bitwise those of one process (``tests/mpi/test_adaptive_spread.py``).
"""

from __future__ import annotations

import pickle
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from hpcontact.sweep.maps.refinement import LeafJob, LeafPart, leaf_estimate, spread_leaves
from hpcontact.sweep.maps.sparse_grid import Slab, SparseJob, reduce_slabs, slab_rows, spread_slabs
from hpcontact.sweep.run.shares import SharedError
from hpcontact.sweep.work.replay import assign


def _computed(
    jobs: Sequence[LeafJob], mine: Sequence[int], rank: int
) -> list[tuple[int, LeafPart, float]] | SharedError:
    """This rank's parts: (job position, part, its CPU seconds), or the error that stopped it."""
    out = []
    try:
        for j in mine:
            started = time.process_time()
            part = leaf_estimate(jobs[j])
            out.append((j, part, time.process_time() - started))
    except Exception as exc:  # noqa: BLE001 - raised on rank 0 after the gather, every rank in step
        return SharedError.of(exc, rank)
    return out


class LeafPool:
    """Rank 0's side (module docstring): ``map`` computes the parts of one ``estimate`` over the
    team. For the replay (``benchmarks/adaptive_scaling.py``) it keeps, for each call, every
    job's (box points, CPU seconds) in job order (``seconds``) and rank 0's CPU seconds spent
    sending the jobs and unpickling the parts (``overhead_s``; not its wait for the slowest rank,
    which the replay has from ``seconds``); ``slabs`` alike for the sparse grid's slabs: each
    call's slabs' (rows, CPU seconds) in order (``slab_seconds``) and rank 0's CPU seconds
    sending the job, combining what the slabs yield and unpickling their results
    (``slab_overhead_s``)."""

    def __init__(self, team: Any) -> None:
        self.team = team
        self.seconds: list[list[tuple[int, float]]] = []
        self.overhead_s: list[float] = []
        self.slab_seconds: list[list[tuple[int, float]]] = []
        self.slab_overhead_s: list[float] = []

    def map(self, jobs: Sequence[LeafJob]) -> list[LeafPart]:
        """The ``LeafPart`` of every job, in order, computed by the ranks ``assign`` names."""
        jobs = list(jobs)
        points = [job.points for job in jobs]
        shares = assign(points, self.team.size)
        started = time.process_time()
        self.team.bcast(("leaves", jobs, shares))
        overhead = time.process_time() - started
        mine = _computed(jobs, shares[0], 0)
        gathered = self.team.gather(None)  # the other ranks' results, pickled (``serve``)
        started = time.process_time()
        results = [mine, *(pickle.loads(data) for data in gathered[1:])]
        self.overhead_s.append(overhead + time.process_time() - started)
        parts: list[LeafPart | None] = [None] * len(jobs)
        seconds = [0.0] * len(jobs)
        for result in results:
            if isinstance(result, SharedError):
                raise result.exception()
            for j, part, spent in result:
                parts[j], seconds[j] = part, spent
        self.seconds.append(list(zip(points, seconds)))
        missing = [j for j, part in enumerate(parts) if part is None]
        if missing:  # every job is in one share (``assign``): a rank that answered without it
            raise RuntimeError(f"no part came back for the leaves {missing} of an estimate")
        return [part for part in parts if part is not None]

    def slabs(self, function: Callable[[SparseJob, slice], Slab], job: SparseJob) -> list[Any]:
        """The results of ``function``'s slabs of ``job`` in order, one slab a rank
        (``sparse_grid.slab_rows``), run in step (``_slab_steps``)."""
        pieces = slab_rows(job.rows, self.team.size)
        started = time.process_time()
        self.team.bcast(("slabs", function, job, pieces))
        overhead = time.process_time() - started
        results, seconds, combining = _slab_steps(self.team, function, job, pieces)
        self.slab_overhead_s.append(overhead + combining)
        self.slab_seconds.append([(piece.stop - piece.start, spent) for piece, spent in zip(pieces, seconds)])
        return results


def _slab_steps(
    team: Any, function: Callable[[SparseJob, slice], Slab], job: SparseJob, pieces: Sequence[slice]
) -> tuple[list[Any], list[float], float]:
    """Every rank: its slab of ``job`` (``pieces[rank]``; none beyond them) run in step with the
    others'. At each step every rank sends rank 0 what its slab yielded (its part of what needs
    the whole grid), its result (pickled, with its CPU seconds) or its error; while every slab
    yields, rank 0 broadcasts the whole (``sparse_grid.reduce_slabs``) and each slab goes on with
    it, else it broadcasts the end. On rank 0: the results in order, each slab's CPU seconds,
    and its own CPU seconds combining and unpickling; it raises a rank's error (after the end:
    every rank takes part in each collective, so none waits forever)."""
    rank = team.rank
    slab = function(job, pieces[rank]) if rank < len(pieces) else None
    message: Any = None
    spent, combining = 0.0, 0.0
    while True:
        started = time.process_time()
        out: tuple[str, Any] = ("idle", None)
        if slab is not None:
            try:
                out = ("step", slab.send(message))
            except StopIteration as stop:
                out = ("done", stop.value)
            except Exception as exc:  # noqa: BLE001 - raised on rank 0 after the end, every rank in step
                out = ("error", SharedError.of(exc, rank))
        spent += time.process_time() - started
        if out[0] == "done":
            out = ("done", (out[1] if rank == 0 else pickle.dumps(out[1], protocol=pickle.HIGHEST_PROTOCOL), spent))
        gathered = team.gather(out)
        reply: tuple[str, Any] | None = None
        failure: Exception | None = None
        if rank == 0:
            started = time.process_time()
            reply = ("end", None)
            if {kind for kind, _ in gathered} <= {"step", "idle"}:
                try:
                    reply = ("go", reduce_slabs([value for kind, value in gathered if kind == "step"]))
                except Exception as exc:  # noqa: BLE001 - raised after the end is broadcast
                    failure = exc
            combining += time.process_time() - started
        reply = team.bcast(reply)
        if failure is not None:
            raise failure
        if reply[0] == "go":
            message = reply[1]
            continue
        if rank != 0:
            return [], [], 0.0
        for kind, value in gathered:
            if kind == "error":
                raise value.exception()
        if any(kind != "done" for kind, _ in gathered[: len(pieces)]):
            raise RuntimeError("the slabs of one decision ended at different steps")
        started = time.process_time()
        results = [
            value[0] if r == 0 else pickle.loads(value[0]) for r, (_, value) in enumerate(gathered[: len(pieces)])
        ]
        combining += time.process_time() - started
        return results, [value[1] for _, value in gathered[: len(pieces)]], combining


def serve(team: Any) -> None:
    """A rank other than 0 after a round's tasks: compute the parts rank 0 broadcasts (its own
    share, ``assign``) and send them back, or take part in its slabs (``_slab_steps``), until
    rank 0 broadcasts None (it has decided)."""
    while True:
        message = team.bcast(None)
        if message is None:
            return
        if message[0] == "slabs":
            _slab_steps(team, *message[1:])
            continue
        _, jobs, shares = message
        team.gather(pickle.dumps(_computed(jobs, shares[team.rank], team.rank), protocol=pickle.HIGHEST_PROTOCOL))


@contextmanager
def shared_estimates(team: Any) -> Iterator[LeafPool]:
    """Rank 0 while it decides (module docstring): every ``refinement.estimate`` inside shares
    its leaves out over ``team``, and every sparse grid's decision its slabs, whose other ranks
    ``serve``; leaving (whatever happened) it tells them to stop."""
    pool = LeafPool(team)
    try:
        with spread_leaves(pool.map), spread_slabs(pool.slabs):
            yield pool
    finally:
        team.bcast(None)
