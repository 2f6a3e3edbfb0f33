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


def test_sparse_grid_slabs_shared_over_ranks_give_bitwise_the_estimates_and_decisions_of_one():
    """Every decision of the sparse map of test_sparse_grid.py (refinement, check rounds) with a
    failed node in one of them, and the estimate of each state on the refined quantity and on
    every stored one (the principal stiffnesses derived from the tensor): bitwise equal with
    the slabs computed by three ranks (threads) and by one; each call's slabs are one a rank,
    in order, and cover the first axis."""
    from test_sparse_grid import record, spec_text

    from hpcontact.sweep.maps.sparse_grid import set_nodes

    spec = parse_spec(spec_text(nu=9, a=9, psi=17), check_scenes=False)
    layout = Layout.of(spec)
    tasks, task_of = join_parts(spec, [enumerate_part(spec)])
    records = [record(task.params) for task in tasks]
    every = {n: np.array([r[n] for r in records])[task_of] for n in records[0] if n.startswith("K_")}
    stored = [n for n in every if not n.endswith("_error")]
    state, checks, decisions = initial_state(layout, spec.adaptive), Checks(), 0
    while True:
        solved = np.isin(task_of, state_tasks(layout, state, task_of, checks))
        seen = {n: np.where(solved, v, np.nan) for n, v in every.items()}
        if decisions == 1:  # a failed solve at a node of the set: NaN in every stiffness there
            nodes = np.flatnonzero(set_nodes(tuple(len(x) for x in layout.xs), state[0][1].indices))
            for values in seen.values():
                values.flat[nodes[len(nodes) // 2]] = np.nan
        alone = next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], stored, task_of)
        estimates_alone = [estimate(layout, (), state[0][1], names, seen) for names in (["K_xx"], stored)]
        teams = ThreadTeam.of(3)
        helpers = [served(team) for team in teams[1:]]
        with spread.shared_estimates(teams[0]) as pool:
            shared = next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], stored, task_of)
            estimates_shared = [estimate(layout, (), state[0][1], names, seen) for names in (["K_xx"], stored)]
        for helper in helpers:
            helper.join(WAIT_S)
            assert not helper.is_alive()  # the ranks left serving when rank 0 had decided
        assert shared == alone
        for a, b in zip(estimates_alone, estimates_shared):
            for x, y in zip(
                [a.values, a.solve, a.scale, a.owner, *a.axes], [b.values, b.solve, b.scale, b.owner, *b.axes]
            ):
                assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True)
        assert pool.slab_seconds and all([rows for rows, _ in call] == [3, 3, 3] for call in pool.slab_seconds)
        decisions += 1
        if not isinstance(alone, tuple):
            break
        state, checks = alone
    assert decisions >= 4


def test_a_slab_that_fails_on_another_rank_is_raised_on_rank_0_and_no_rank_waits():
    """A slab raising on rank 1 between its steps: rank 0's estimate raises it (naming the
    rank), after which rank 1 leaves serving."""
    from test_sparse_grid import record, spec_text

    from hpcontact.sweep.maps import sparse_grid

    spec = parse_spec(spec_text(nu=9, a=9, psi=17), check_scenes=False)
    layout = Layout.of(spec)
    tasks, task_of = join_parts(spec, [enumerate_part(spec)])
    records = [record(task.params) for task in tasks]
    every = {n: np.array([r[n] for r in records])[task_of] for n in records[0] if n.startswith("K_")}
    state = initial_state(layout, spec.adaptive)
    original = sparse_grid.next_terms_of

    def failing(*args):
        if threading.current_thread().name == "rank1":
            raise ValueError("a broken slab")
        return original(*args)

    zero, one = ThreadTeam.of(2)
    sparse_grid.next_terms_of = failing
    try:
        helper = served(one)
        with pytest.raises(RuntimeError, match="ValueError on rank 1: a broken slab"):
            with spread.shared_estimates(zero):
                estimate(layout, (), state[0][1], ["K_xx"], every)
        helper.join(WAIT_S)
        assert not helper.is_alive()
    finally:
        sparse_grid.next_terms_of = original


def test_a_slab_call_is_replayed_as_its_largest_slab_at_the_measured_seconds_a_row():
    """``replay.slab_call_seconds``: 25 rows measured as 13 + 12 taking 2.6 + 2.4 s (0.2 s a
    row) and 0.1 s of overhead: 5.1 s on one rank, 2.7 on two (13 rows), 0.3 on 25 or more (a
    row each: a slab is not split below a row); with a fixed part of 0.5 s a slab, the rows
    take (5.0 − 2 × 0.5) / 25 = 0.16 s each: 4.6 s on one rank, 2.68 on two, 0.76 on 25."""
    from hpcontact.sweep.work.replay import SlabCall, call_seconds

    call = SlabCall((13, 12), (2.6, 2.4), 0.1)
    assert [call_seconds(call, r) for r in (1, 2, 25, 64)] == pytest.approx([5.1, 2.7, 0.3, 0.3], rel=1e-12)
    fixed = SlabCall((13, 12), (2.6, 2.4), 0.1, 0.5)
    assert [call_seconds(fixed, r) for r in (1, 2, 25, 64)] == pytest.approx([4.6, 2.68, 0.76, 0.76], rel=1e-12)
