"""The served counter on every rank of the team (2 under ``mpiexec -n 2``): each chunk claimed
exactly once, progress counts delivered, a rank may leave early, and — the property the RMA
counter lacked on multi-node transports — a worker gets work while rank 0 computes without
entering MPI. In one plain process the team is serial and the tests check the serial path."""

from __future__ import annotations

import socket
import sys
import time

import pytest

from hpcontact.sweep.run.schedule import NEXT_CHUNK, SLOTS, MPITeam, Team, claimed_chunks, report_done, totals_done

pytestmark = pytest.mark.mpi

CHUNKS = [(i,) for i in range(40)]


def _team(team: Team, threaded: bool) -> Team:
    """The same ranks, with rank 0 serving from a thread or between its own chunks."""
    return MPITeam(team.comm, threaded) if isinstance(team, MPITeam) else team


def _hold_the_interpreter(seconds: float) -> None:
    """A task of rank 0 that never enters MPI and holds the GIL except at switch intervals."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        sum(range(1000))


@pytest.mark.parametrize("threaded", [True, False])
def test_every_chunk_is_claimed_once_and_counted(team: Team, threaded: bool) -> None:
    team = _team(team, threaded)
    counter = team.counter(SLOTS)
    mine = []
    for chunk in claimed_chunks(CHUNKS, counter):
        mine.append(chunk[0])
        time.sleep(0.005)
        report_done(counter, 2.4)
    counter.close()
    claimed = team.gather(mine)
    if team.rank == 0:
        assert sorted(i for ranks in claimed for i in ranks) == list(range(len(CHUNKS)))
        assert totals_done(counter) == (len(CHUNKS), 2 * len(CHUNKS))  # every add arrived before the close
        assert counter.fetch_add(NEXT_CHUNK, 0) == len(CHUNKS) + team.size  # one claim past the end per rank
        if team.size > 1:
            assert all(claimed), "a rank computed nothing"


def test_a_worker_gets_work_while_rank_0_computes(team: Team) -> None:
    """Rank 0 takes the first chunk and spends 4 s in it without any MPI call; every other chunk
    (10 ms each) must be served to the other ranks meanwhile: 39 claims in 4 s leave ~100 ms per
    claim, ~20x the server's worst latency (4 ms poll + one 1 ms GIL switch interval)."""
    if team.size == 1:
        pytest.skip("needs 2 ranks")
    team = _team(team, True)
    counter = team.counter(SLOTS)
    mine = []
    if team.rank != 0:
        time.sleep(0.5)  # let rank 0 claim chunk 0 first
    for chunk in claimed_chunks(CHUNKS, counter):
        mine.append(chunk[0])
        if team.rank == 0:
            _hold_the_interpreter(4.0)
        else:
            time.sleep(0.01)
    counter.close()
    claimed = team.gather(mine)
    if team.rank == 0:
        assert claimed[0] == [0], f"rank 0 had to take chunks {claimed[0][1:]} itself: the workers starved"


def _wait_for_the_first_claim(counter, timeout: float = 60.0) -> None:
    """Until some rank has claimed a chunk (the counter's next chunk is past 0)."""
    deadline = time.monotonic() + timeout
    while counter.fetch_add(NEXT_CHUNK, 0) == 0:
        assert time.monotonic() < deadline, f"no rank claimed a chunk in {timeout:g} s"
        time.sleep(0.001)


def test_a_rank_that_leaves_early_does_not_block_the_others(team: Team) -> None:
    """The last rank claims one chunk and leaves; the others take the rest and close. They start
    claiming only after its claim: under load (a 2-rank job beside the test, 2 cores) rank 0
    once claimed all 40 chunks before the last rank's first request arrived, and the scenario
    did not happen (the leaving rank held none)."""
    team = _team(team, True)
    interval = sys.getswitchinterval()
    counter = team.counter(SLOTS)
    mine = []
    if team.rank != team.size - 1:
        _wait_for_the_first_claim(counter)
    for chunk in claimed_chunks(CHUNKS, counter):
        mine.append(chunk[0])
        if team.rank == team.size - 1 and team.size > 1:
            break  # e.g. stopped by a signal: claims nothing more, then closes
        time.sleep(0.002)
    counter.close()
    assert sys.getswitchinterval() == interval  # rank 0's shorter interval lasts only while it serves
    claimed = team.gather(mine)
    if team.rank == 0:
        assert sorted(i for ranks in claimed for i in ranks) == list(range(len(CHUNKS)))
        if team.size > 1:
            assert len(claimed[-1]) == 1


def test_the_team_counts_its_ranks_on_each_node(team: Team) -> None:
    """``node_size``: the team's ranks that share this rank's node (the probe of a run's estimate
    does not count them as other work), summed over one rank per node the team's size; every rank
    of a node agrees. CI's ranks share one machine."""
    hosts = team.gather((socket.gethostname(), team.node_size))
    if team.rank == 0:
        per_host: dict[str, list[int]] = {}
        for host, size in hosts:
            per_host.setdefault(host, []).append(size)
        assert all(sizes == [len(sizes)] * len(sizes) for sizes in per_host.values()), per_host
        assert sum(len(sizes) for sizes in per_host.values()) == team.size
