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
"""

from __future__ import annotations

import pickle
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from hpcontact.sweep.maps.refinement import LeafJob, LeafPart, leaf_estimate, spread_leaves
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
    which the replay has from ``seconds``)."""

    def __init__(self, team: Any) -> None:
        self.team = team
        self.seconds: list[list[tuple[int, float]]] = []
        self.overhead_s: list[float] = []

    def map(self, jobs: Sequence[LeafJob]) -> list[LeafPart]:
        """The ``LeafPart`` of every job, in order, computed by the ranks ``assign`` names."""
        jobs = list(jobs)
        points = [job.points for job in jobs]
        shares = assign(points, self.team.size)
        started = time.process_time()
        self.team.bcast((jobs, shares))
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


def serve(team: Any) -> None:
    """A rank other than 0 after a round's tasks: compute the parts rank 0 broadcasts (its own
    share, ``assign``) and send them back, until rank 0 broadcasts None (it has decided)."""
    while True:
        message = team.bcast(None)
        if message is None:
            return
        jobs, shares = message
        team.gather(pickle.dumps(_computed(jobs, shares[team.rank], team.rank), protocol=pickle.HIGHEST_PROTOCOL))


@contextmanager
def shared_estimates(team: Any) -> Iterator[LeafPool]:
    """Rank 0 while it decides (module docstring): every ``refinement.estimate`` inside shares
    its leaves out over ``team``, whose other ranks ``serve``; leaving (whatever happened) it
    tells them to stop."""
    pool = LeafPool(team)
    try:
        with spread_leaves(pool.map):
            yield pool
    finally:
        team.bcast(None)
