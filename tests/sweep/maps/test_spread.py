"""Rank 0's estimate shared out over the ranks while it decides (hpcontact.sweep.maps.spread):
the leaves' parts computed by two ranks (threads standing for them, every message pickled as MPI
sends it) give bitwise the estimates and decisions of one process; a rank's failure reaches
rank 0 and no rank is left waiting; the leaves are assigned longest first."""

from __future__ import annotations

import itertools
import pickle
import queue
import threading

import numpy as np
import pytest
from test_local_refinement import BUMP, bumped

from hpcontact.sweep.maps import spread
from hpcontact.sweep.maps.estimates import Checks, Layout
from hpcontact.sweep.maps.rounds import next_step
from hpcontact.sweep.maps.state import estimate, initial_state, state_tasks
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_part, join_parts

WAIT_S = 60.0


class ThreadTeam:
    """One rank of a team of threads: ``bcast`` and ``gather`` as MPI's, through queues, each
    object pickled on its way (as mpi4py's lower-case collectives do)."""

    def __init__(self, rank: int, size: int, down: list[queue.Queue], up: queue.Queue) -> None:
        self.rank, self.size, self.down, self.up = rank, size, down, up

    @classmethod
    def of(cls, size: int) -> list[ThreadTeam]:
        down, up = [queue.Queue() for _ in range(size)], queue.Queue()
        return [cls(rank, size, down, up) for rank in range(size)]

    def bcast(self, obj):
        if self.rank == 0:
            for q in self.down[1:]:
                q.put(pickle.dumps(obj))
            return obj
        return pickle.loads(self.down[self.rank].get(timeout=WAIT_S))

    def gather(self, obj):
        if self.rank != 0:
            self.up.put((self.rank, pickle.dumps(obj)))
            return None
        got = {0: obj}
        for _ in range(self.size - 1):
            rank, data = self.up.get(timeout=WAIT_S)
            got[rank] = pickle.loads(data)
        return [got[r] for r in range(self.size)]


def served(team: ThreadTeam) -> threading.Thread:
    """A thread that ``serve``s as rank ``team.rank`` (started)."""
    thread = threading.Thread(target=spread.serve, args=(team,), name=f"rank{team.rank}", daemon=True)
    thread.start()
    return thread


def bump_map():
    """The bump map of test_local_refinement (one local feature: refined, cut into leaves), every
    grid point's values, and its sub-problem's decisions one after the other."""
    spec = parse_spec(BUMP, check_scenes=False)
    layout = Layout.of(spec)
    tasks, task_of = join_parts(spec, [enumerate_part(spec)])
    records = [bumped(task.params) for task in tasks]
    every = {n: np.array([r[n] for r in records])[task_of] for n in records[0] if n.startswith("K_")}
    stored = [n for n in every if not n.endswith("_error")]
    return spec, layout, task_of, every, stored


def test_leaves_shared_over_two_ranks_give_bitwise_the_estimates_and_decisions_of_one():
    """Every decision of the bump map (refinement, check rounds) and the estimate of each state,
    on the refined quantity and on every stored one (the principal stiffnesses derived from the
    tensor): bitwise equal with the leaves' parts computed by two ranks and by one; rank 1
    computed some of them, and the larger leaves first."""
    spec, layout, task_of, every, stored = bump_map()
    state, checks, decisions, multi = initial_state(layout, spec.adaptive), Checks(), 0, 0
    computed_by_1: list[int] = []
    original = spread.leaf_estimate

    def counted(job):
        if threading.current_thread().name == "rank1":
            computed_by_1.append(job.points)
        return original(job)

    spread.leaf_estimate = counted
    try:
        while True:
            solved = np.isin(task_of, state_tasks(layout, state, task_of, checks))
            seen = {n: np.where(solved, v, np.nan) for n, v in every.items()}
            alone = next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], stored, task_of)
            estimates_alone = [
                estimate(layout, cat, leaves, names, seen) for cat, leaves in state for names in (["K_xx"], stored)
            ]
            zero, one = ThreadTeam.of(2)
            helper = served(one)
            with spread.shared_estimates(zero) as pool:
                shared = next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], stored, task_of)
                estimates_shared = [
                    estimate(layout, cat, leaves, names, seen) for cat, leaves in state for names in (["K_xx"], stored)
                ]
            helper.join(WAIT_S)
            assert not helper.is_alive()  # rank 1 left serving when rank 0 had decided
            assert shared == alone
            for a, b in zip(estimates_alone, estimates_shared):
                for x, y in zip(
                    [a.values, a.solve, a.scale, a.owner, *a.axes], [b.values, b.solve, b.scale, b.owner, *b.axes]
                ):
                    assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)
            assert pool.seconds and all(len(call) == len(state[0][1]) for call in pool.seconds)
            multi += len(state[0][1]) > 1
            decisions += 1
            if not isinstance(alone, tuple):
                break
            state, checks = alone
    finally:
        spread.leaf_estimate = original
    assert decisions >= 4 and multi >= 2  # several decisions with several leaves
    assert computed_by_1  # rank 1 computed parts


def test_a_part_that_fails_on_another_rank_is_raised_on_rank_0_and_no_rank_waits():
    """A leaf's part raising on rank 1: rank 0's estimate raises it (naming the rank), after
    which rank 1 leaves serving (rank 0 told it so on leaving ``shared_estimates``)."""
    spec, layout, task_of, every, stored = bump_map()
    state = initial_state(layout, spec.adaptive)
    original = spread.leaf_estimate

    def failing(job):
        if threading.current_thread().name == "rank1":
            raise ValueError("a broken part")
        return original(job)

    zero, one = ThreadTeam.of(2)
    spread.leaf_estimate = failing
    try:
        helper = served(one)
        with pytest.raises(RuntimeError, match="ValueError on rank 1: a broken part"):
            with spread.shared_estimates(zero):
                estimate(layout, state[0][0], state[0][1] * 2, ["K_xx"], every)  # two leaves: one each
        helper.join(WAIT_S)
        assert not helper.is_alive()
    finally:
        spread.leaf_estimate = original


@pytest.mark.parametrize("ranks", [1, 2, 3])
def test_leaves_are_assigned_longest_first_within_grahams_bound(ranks):
    """Every leaf to exactly one rank; the largest loads first to the least loaded rank (the
    worked case), and on every instance of up to 7 leaves the largest load is within Graham's
    bound (4/3 − 1/(3R)) of the best assignment, found by trying them all."""
    assert spread.assign([5, 4, 3, 3, 3], 2) == [[0, 3], [1, 2, 4]]
    rng = np.random.default_rng(40)
    for _ in range(30):
        points = rng.integers(1, 100, size=int(rng.integers(1, 8))).tolist()
        shares = spread.assign(points, ranks)
        assert sorted(j for share in shares for j in share) == list(range(len(points)))
        worst = max(sum(points[j] for j in share) for share in shares)
        best = min(
            max(sum(p for p, r in zip(points, owners) if r == rank) for rank in range(ranks))
            for owners in itertools.product(range(ranks), repeat=len(points))
        )
        assert worst <= (4 / 3 - 1 / (3 * ranks)) * best + 1e-12
