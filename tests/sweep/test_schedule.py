"""Scheduling without MPI: the serial team, the local counter and the claim loop."""

from __future__ import annotations

from hpcontact.sweep import schedule
from hpcontact.sweep.schedule import (
    COST_DONE,
    NEXT_CHUNK,
    SLOTS,
    LocalCounter,
    SerialTeam,
    claimed_chunks,
    launched_by_mpi,
    report_done,
    totals_done,
    world,
)


def test_one_process_takes_every_chunk_in_order():
    counter = LocalCounter(SLOTS)
    chunks = [("a",), ("b", "c"), ("d",)]
    assert list(claimed_chunks(chunks, counter)) == chunks
    assert list(claimed_chunks(chunks, counter)) == []  # the counter stays past the end
    assert counter.fetch_add(NEXT_CHUNK, 0) == 5  # one claim per call past the end


def test_report_done_counts_tasks_and_cost():
    counter = LocalCounter(SLOTS)
    report_done(counter, 10.4)
    report_done(counter, 0.01)  # every task counts at least one unit
    assert totals_done(counter) == (2, 11)
    assert counter.fetch_add(COST_DONE, 0) == 11


def test_serial_team_collectives_are_identities():
    team = SerialTeam()
    assert (team.rank, team.size) == (0, 1)
    assert team.bcast({"x": 1}) == {"x": 1}
    assert team.gather(3) == [3]
    team.barrier()
    team.abort(1)


def test_world_is_serial_without_a_launcher(monkeypatch):
    for name in schedule.LAUNCHER_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.delenv("HPCONTACT_MPI", raising=False)
    assert not launched_by_mpi()
    assert isinstance(world(), SerialTeam)
    monkeypatch.setenv("PMI_RANK", "0")
    assert launched_by_mpi()
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    assert not launched_by_mpi()
