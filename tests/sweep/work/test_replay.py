"""The replay (``hpcontact.sweep.work.replay``): its schedule, overheads, claims and adaptive
rounds against schedules computed by hand (the claims' and rounds' numbers are dyadic
fractions, so their floats are exact)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.sweep.work.replay import (
    CLAIM_OVERHEAD_SHARE,
    LeafCall,
    Overheads,
    claim_size,
    leaf_call_seconds,
    replay,
    replay_rounds,
)
from hpcontact.sweep.work.tasks import Task, chunk_order

NONE = Overheads(
    driver_s=0.0, service_s=0.0, wake_s=0.0, setup_s=0.0, gather_s=0.0, spread_setup_s=0.0, spread_gather_s=0.0
)


def toy(seconds: list[float]) -> tuple[list[Task], dict[str, float]]:
    """Tasks costed as their seconds, each its own kernel group (one task a chunk)."""
    tasks = [Task(key=f"t{i}", params={}, cost=s, group=f"g{i}") for i, s in enumerate(seconds)]
    return tasks, {t.key: s for t, s in zip(tasks, seconds)}


def test_claim_size_is_the_round_trip_over_its_share_bounded_by_the_remaining_work():
    assert CLAIM_OVERHEAD_SHARE == 0.02
    # 2.5 ms of round trip against 10 ms chunks: 2.5 / (0.02 x 10) = 12.5 -> 13 chunks
    assert claim_size(2.5e-3, 1e-2, 1000, 2) == 13
    # at most remaining // (CHUNKS_PER_RANK = 4 x 2 ranks): 40 // 8 = 5, and 7 // 8 = 0 -> one
    assert claim_size(2.5e-3, 1e-2, 40, 2) == 5 and claim_size(2.5e-3, 1e-2, 7, 2) == 1
    # chunks long against the round trip: one at a time; nothing measured yet: one
    assert claim_size(2.5e-3, 1.0, 1000, 2) == 1
    assert claim_size(0.0, 1e-2, 1000, 2) == claim_size(2.5e-3, 0.0, 1000, 2) == 1


def test_a_worker_claims_several_cheap_chunks_while_rank_0_runs_a_long_one():
    """One task of 100 s and 64 of 1/8 s on 2 ranks, a round trip of 1/64 s. Rank 0 takes the
    100 s chunk at 0. Rank 1's first claim is one chunk: served at 0, starts 1/64, ends 9/64.
    Its next claims: ceil((1/64) / (0.02 x 1/8)) = ceil(6.25) = 7 chunks, at most remaining // 8:
    63 // 8 = 7, 56 // 8 = 7, 49 // 8 = 6, 43 -> 5, 38 -> 4, 34 -> 4, 30 -> 3, 27 -> 3, 24 -> 3,
    21 -> 2, 19 -> 2, 17 -> 2, then 15 claims of one: 1 + 12 + 15 = 28 claims for 64 chunks,
    each 1/64 s of waiting; rank 1 ends at 64/8 + 28/64 = 8.4375 s, rank 0 at 100 s."""
    tasks, seconds = toy([100.0] + [0.125] * 64)
    overheads = Overheads(
        driver_s=0.0, service_s=0.0, wake_s=1 / 64, setup_s=0.0, gather_s=0.0, spread_setup_s=0.0, spread_gather_s=0.0
    )
    r = replay(tasks, seconds, 2, overheads)
    assert r["chunks"] == 65 and r["claims_taken"] == 1 + 28
    assert r["makespan_s"] == 100.0 and r["efficiency"] == 108.0 / 200.0
    assert r["claims"] == (28 / 64) / 200.0
    assert r["tail"] == (100.0 - (100.0 + 8.4375) / 2) / 100.0
    # one chunk a claim (no round trip to amortize): 64 claims by rank 1, 1 by rank 0
    assert replay(tasks, seconds, 2, NONE)["claims_taken"] == 65


def test_synchronized_rounds_add_their_makespans_and_rank_0s_time_between():
    """Round 1: four tasks of 1 s on 2 ranks (2 s); rank 0 alone 0.5 s. Round 2: one task of
    2 s (2 s; the other rank idles); rank 0 alone 0.25 s. Setup: 8 tasks x (0.125 + 0.25 / 2).
    Makespan 2 + 2 + 0.5 + 2 + 0.25 = 6.75 s; efficiency 6 / (2 x 6.75)."""
    first, _ = toy([1.0] * 4)
    second, _ = toy([2.0])
    rounds = [
        (chunk_order(first), np.array([1.0] * 4)),
        (chunk_order(second), np.array([2.0])),
    ]
    o = Overheads(
        driver_s=0.0, service_s=0.0, wake_s=0.0, setup_s=0.125, gather_s=1.0, spread_setup_s=0.25, spread_gather_s=0.0
    )
    r = replay_rounds(rounds, 2, [0.5, 0.25], 8, o)  # gather_s: within rank 0's measured time between rounds
    assert r["rounds"] == 2 and r["makespan_s"] == 6.75
    assert r["efficiency"] == 6.0 / (2 * 6.75)
    assert r["between"] == 0.75 / 6.75 and r["setup"] == 2.0 / 6.75
    # the second round's idle rank: its tail is (2 - 1) / 2 of that round's makespan
    assert r["tail"] == (0.5 * 2.0) / 6.75
    # on one rank: setup 1 + 2 (the enumeration not divided), then 4 + 0.5 and 2 + 0.25
    assert replay_rounds(rounds, 1, [0.5, 0.25], 8, o)["makespan_s"] == 1.0 + 2.0 + 4.0 + 0.5 + 2.0 + 0.25


def test_rank_0s_work_during_a_round_delays_its_first_chunk_while_the_others_claim():
    """The rounds of the test above without set-up, rank 0 alone 0.5 and 0.25 s between them,
    and busy 1 s during the first round and 3 s during the second (its announcement, its reading
    ahead). On 2 ranks: round 1, rank 0 claims a task of 1 s, works 1 s, solves it and then the
    fourth (3 s), rank 1 the second and third (2 s); round 2, rank 0 claims the one task, works
    3 s, solves it (5 s): makespan 3 + 0.5 + 5 + 0.25 = 8.75 s. On 4 ranks: 2 + 0.5 + 5 + 0.25 =
    7.75 s (the others' claims cover none of the second round's 3 s: it has no other task). On
    one rank: 1 + 4 + 0.5 + 3 + 2 + 0.25 = 10.75 s. None is zeros."""
    first, _ = toy([1.0] * 4)
    second, _ = toy([2.0])
    rounds = [(chunk_order(first), np.array([1.0] * 4)), (chunk_order(second), np.array([2.0]))]
    two = replay_rounds(rounds, 2, [0.5, 0.25], 8, NONE, [1.0, 3.0])
    assert two["makespan_s"] == 8.75 and two["between"] == 0.75 / 8.75
    assert replay_rounds(rounds, 4, [0.5, 0.25], 8, NONE, [1.0, 3.0])["makespan_s"] == 7.75
    assert replay_rounds(rounds, 1, [0.5, 0.25], 8, NONE, [1.0, 3.0])["makespan_s"] == 10.75
    assert replay_rounds(rounds, 2, [0.5, 0.25], 8, NONE, None) == replay_rounds(
        rounds, 2, [0.5, 0.25], 8, NONE, [0.0, 0.0]
    )
    with pytest.raises(InputError, match="rank0_busy_s"):
        replay_rounds(rounds, 2, [0.5, 0.25], 8, NONE, [1.0])


def test_estimates_shared_over_the_ranks_take_their_busiest_rank_plus_their_overhead():
    """An estimate of leaves of 8, 4, 2, 2 points whose parts took 2, 1, 0.5, 0.5 s, overhead
    0.25 s (``maps.spread``: the largest leaf first to the least loaded rank): on 1 rank all
    4 s; on 2 ranks {8} and {4, 2, 2}, 2 s; on 4 ranks each its own, the largest 2 s; on 3
    ranks {8}, {4}, {2, 2}: 2 s; + 0.25 each. In the rounds above (on 2 ranks, rank 0 alone
    0.5 and 0.25 s), one such call after the first round adds 2.25 s: makespan 2 + 0.5 + 2.25 +
    2 + 0.25 = 7 s; none (None) is empty lists."""
    call = LeafCall((8, 4, 2, 2), (2.0, 1.0, 0.5, 0.5), 0.25)
    assert [leaf_call_seconds(call, r) for r in (1, 2, 3, 4)] == [4.25, 2.25, 2.25, 2.25]
    uneven = LeafCall((8, 4, 2, 2), (0.5, 1.0, 2.0, 0.5), 0.0)  # cost is assigned by points, not seconds
    assert leaf_call_seconds(uneven, 2) == 3.5  # {8} 0.5 s, {4, 2, 2} 3.5 s
    first, _ = toy([1.0] * 4)
    second, _ = toy([2.0])
    rounds = [(chunk_order(first), np.array([1.0] * 4)), (chunk_order(second), np.array([2.0]))]
    r = replay_rounds(rounds, 2, [0.5, 0.25], 8, NONE, None, [[call], []])
    assert r["makespan_s"] == 7.0 and r["between"] == (0.75 + 2.25) / 7.0
    assert replay_rounds(rounds, 2, [0.5, 0.25], 8, NONE, None, None) == replay_rounds(
        rounds, 2, [0.5, 0.25], 8, NONE, None, [[], []]
    )
    with pytest.raises(InputError, match="leaf_calls"):
        replay_rounds(rounds, 2, [0.5, 0.25], 8, NONE, None, [[call]])


def test_rounds_need_one_time_between_each():
    tasks, _ = toy([1.0])
    with pytest.raises(InputError, match="between_s"):
        replay_rounds([(chunk_order(tasks), np.array([1.0]))], 2, [], 1)


def test_four_equal_tasks_on_two_ranks_take_two_tasks_time():
    tasks, seconds = toy([1.0] * 4)
    r = replay(tasks, seconds, 2, NONE)
    assert r["chunks"] == 4 and r["makespan_s"] == 2.0 and r["efficiency"] == 1.0
    assert replay(tasks, seconds, 1, NONE)["makespan_s"] == 4.0


def test_replay_with_overheads_matches_a_hand_computation():
    tasks, seconds = toy([1.0] * 4)
    o = Overheads(
        driver_s=0.1, service_s=0.01, wake_s=0.02, setup_s=0.05, gather_s=0.025, spread_setup_s=0.0, spread_gather_s=0.0
    )
    # setup 4 x 0.05 = 0.2. Rank 0 takes chunk 1 at 0.2, ends 1.3. Rank 1 is served at 0.21,
    # starts 0.23, ends 1.33. Rank 0 claims at 1.3 (no message), ends 2.4; rank 1 is served at
    # 1.34, starts 1.36, ends 2.46. Gather 4 x 0.025 = 0.1: makespan 2.56.
    r = replay(tasks, seconds, 2, o)
    assert r["makespan_s"] == pytest.approx(2.56, rel=1e-12)  # float sums of the numbers above
    assert r["efficiency"] == pytest.approx(4.0 / (2 * 2.56), rel=1e-12)
    assert r["claims"] == pytest.approx((0.03 + 0.03) / (2 * 2.56), rel=1e-12)


def test_spread_setup_is_divided_over_the_ranks_and_spread_gather_paid_per_task():
    tasks, seconds = toy([1.0] * 4)
    o = replace(NONE, spread_setup_s=0.4, spread_gather_s=0.05)
    # setup 4 x 0.4 / 2 ranks = 0.8; each rank runs 2 tasks of 1 + 0.05 s: makespan 0.8 + 2.1 = 2.9
    assert replay(tasks, seconds, 2, o)["makespan_s"] == pytest.approx(2.9, rel=1e-12)  # float sums
    assert replay(tasks, seconds, 1, o)["makespan_s"] == pytest.approx(1.6 + 4.2, rel=1e-12)


def test_longest_first_order_bounds_the_tail():
    # 3, 2, 2, 1 on 2 ranks, largest first: rank 0 takes 3, rank 1 takes 2 then 2, rank 0 takes 1 → 4.
    tasks, seconds = toy([1.0, 2.0, 3.0, 2.0])
    assert replay(tasks, seconds, 2, NONE)["makespan_s"] == 4.0
