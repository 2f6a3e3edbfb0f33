"""Scheduling without MPI: the serial team, the local counter, the claim loop and the launch
check (the served counter on 2 ranks: ``tests/mpi/test_served_counter.py``)."""

from __future__ import annotations

import threading

import pytest

from hpcontact.sweep.run import schedule
from hpcontact.sweep.run.schedule import (
    COST_DONE,
    NEXT_CHUNK,
    SLOTS,
    LaunchError,
    LocalCounter,
    SerialTeam,
    check_launch,
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


def test_local_counter_hands_out_each_value_once_across_threads():
    # rank 0's server thread and its main thread share one LocalCounter
    counter = LocalCounter(SLOTS)
    taken: list[list[int]] = [[] for _ in range(4)]

    def claim(mine: list[int]) -> None:
        for _ in range(2000):
            mine.append(counter.fetch_add(NEXT_CHUNK, 1))

    threads = [threading.Thread(target=claim, args=(mine,)) for mine in taken]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(v for mine in taken for v in mine) == list(range(8000))


@pytest.mark.parametrize(
    "environ, launcher",
    [
        ({"SLURM_PROCID": "1", "SLURM_NTASKS": "2", "SLURM_STEP_NUM_TASKS": "2"}, "Slurm"),  # srun --mpi=none
        ({"SLURM_PROCID": "0", "SLURM_NTASKS": "64", "SLURM_STEP_NUM_TASKS": "64(x2)"}, "Slurm"),
        ({"FLUX_TASK_RANK": "0", "FLUX_JOB_SIZE": "4"}, "Flux"),
        ({"JSM_NAMESPACE_RANK": "3", "JSM_NAMESPACE_SIZE": "8"}, "LSF jsrun"),
        ({"LSF_PM_TASKID": "1", "LSB_DJOB_NUMPROC": "8"}, "LSF blaunch"),
        ({"PBS_TASKNUM": "2", "PBS_NP": "4"}, "PBS pbsdsh"),
    ],
)
def test_batch_tasks_without_process_management_are_refused(environ, launcher):
    with pytest.raises(LaunchError) as caught:
        check_launch(environ)
    message = str(caught.value)
    assert message.startswith(launcher) and "srun --mpi=pmix" in message and "mpirun" in message
    assert "\n" not in message


@pytest.mark.parametrize(
    "environ",
    [
        {},
        {"SLURM_PROCID": "0", "SLURM_STEP_NUM_TASKS": "1"},  # a one-task job step
        {"SLURM_PROCID": "0", "SLURM_STEP_NUM_TASKS": "2", "PMIX_RANK": "0"},  # srun --mpi=pmix
        {"SLURM_PROCID": "1", "SLURM_STEP_NUM_TASKS": "2", "PMI_RANK": "1"},  # srun --mpi=pmi2
        {"SLURM_PROCID": "0", "SLURM_NTASKS": "2", "OMPI_COMM_WORLD_SIZE": "2"},  # mpirun in an allocation
        {"SLURM_PROCID": "0", "SLURM_STEP_NUM_TASKS": "2", "HPCONTACT_MPI": "0"},  # one process on purpose
        {"SLURM_PROCID": "0", "SLURM_NTASKS": "8"},  # the batch script itself, outside srun
    ],
)
def test_launches_with_process_management_or_one_task_pass(environ):
    check_launch(environ)
