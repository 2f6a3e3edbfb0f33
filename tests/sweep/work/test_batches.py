"""A rank's claimed tasks as batches (``sweep.work.batches``, issue 41 item 2) against the tasks run one at a time.

The batched path is forced on the CPU by ``plan_batches``' ``memory`` parameter (on the CPU a rank
keeps one scene per batch by default). Its entries are compared with ``rounds.run_task``'s of each
task alone: the same fields, status and message, and each stiffness within 1e-12 relative, the
agreement tests/problems/test_contact_batch.py bounds by κ(A_mask)·(ρ₁ + ρ₂) at tol 1e-14.
"""

from __future__ import annotations

import functools

import pytest

from hpcontact.accuracy.defaults import solve_contact_fields
from hpcontact.numerics import memory
from hpcontact.problems.footprint import array_bytes
from hpcontact.sweep.data.journal import BAD_INPUT, OK
from hpcontact.sweep.run.rounds import run_task
from hpcontact.sweep.run.schedule import SLOTS, LocalCounter, claimed_chunks
from hpcontact.sweep.work import batches
from hpcontact.sweep.work.batches import batch_fill, batch_group, batch_memory, plan_batches, run_batch
from hpcontact.sweep.work.tasks import Task, make_chunks, task_key

#: Circles on one grid (three materials, tangential and normal): one batch group.
CIRCLES = [
    {"shape": "circle", "n": 20, "nu": nu, "quantities": "tangential,normal", "tol": 1e-14} for nu in (0.1, 0.3, 0.45)
]
#: Scenes that are no batch's: an ellipse's one exact cell (a circle's and an ellipse's accuracy), a slip
#: scene. (Grid sequences batch: tests/sweep/work/test_batches_accuracy.py.)
ALONE = [
    {"shape": "circle", "accuracy": 1e-3},
    {"shape": "ellipse", "aspect": 0.5, "accuracy": 1e-4},
    {"shape": "circle", "n": 16, "quantities": "slip", "mu": 0.3, "q_ratio": 0.5},
]
#: Passes the scene's checks, fails its solve: no cell of a 4-cell grid in the star (InputError on n).
FAILING = {"shape": "star", "amplitude": 0.9, "sides": 12, "n": 4, "tol": 1e-14}


def tasks_of(fields: list[dict]) -> list[Task]:
    return [Task(task_key(f), f, 1.0, "g") for f in fields]


def alone(task: Task):
    return run_task(solve_contact_fields, task, 3)


def assert_same_records(batched: dict, single: dict) -> None:
    """The same fields; the stiffness tensor's entries within 1e-12 of its largest entry (an entry
    zero by symmetry is round-off of that size), other numbers (ratios, normalized stiffnesses: of
    order one) within 1e-12 relative or absolute, residuals both below the tolerance, wall times
    aside; everything else equal."""
    assert batched.keys() == single.keys()
    entries = [name for name, v in single.items() if name.startswith("K_") and "_over_" not in name]
    tensor = max(abs(single[name]) for name in entries)
    for name, value in single.items():
        if name == "wall_time_s":
            continue
        if name == "residual":
            assert max(value, batched[name]) <= 1e-14
        elif isinstance(value, float):
            scale = max(abs(value), tensor if name in entries else 1.0)
            assert abs(batched[name] - value) <= 1e-12 * scale, name
        elif name != "iterations":  # the batch's scenes stop at their own tolerance, checked above
            assert batched[name] == value, name


def test_a_cpu_rank_keeps_one_scene_a_batch():
    tasks = tasks_of(CIRCLES)
    assert batch_memory("cpu") == 0
    assert plan_batches(tasks, solve_contact_fields) == [(t,) for t in tasks]


def test_tasks_of_one_grid_batch_as_many_as_the_memory_holds():
    tasks = tasks_of(CIRCLES + [{**CIRCLES[0], "n": 24}] + CIRCLES)
    scene = array_bytes(CIRCLES[0])
    batches_ = plan_batches(tasks, solve_contact_fields, memory=int(2.5 * scene))
    assert [len(b) for b in batches_] == [2, 2, 1, 2]  # n = 24 is a group of its own
    assert [t for b in batches_ for t in b] == [tasks[i] for i in (0, 1, 2, 4, 3, 5, 6)]
    assert plan_batches(tasks, solve_contact_fields, memory=10**12) == [
        tuple(tasks[i] for i in (0, 1, 2, 4, 5, 6)),
        (tasks[3],),
    ]
    assert [len(b) for b in plan_batches(tasks, solve_contact_fields, memory=int(0.5 * scene))] == [1] * 7


def test_tasks_without_a_group_and_faulted_ones_run_alone():
    tasks = tasks_of(ALONE + CIRCLES)
    for task in tasks[:3]:
        assert batch_group(task.params, solve_contact_fields) is None
    assert batch_group(CIRCLES[0], lambda params: {}) is None  # another task function
    assert batch_group({**CIRCLES[0], "aspect": 0.5}, solve_contact_fields) is None  # refused: run_task records it
    assert batch_group(CIRCLES[0], solve_contact_fields) != batch_group(
        {**CIRCLES[0], "precondition": False}, solve_contact_fields
    )
    assert plan_batches(tasks, solve_contact_fields, memory=10**12) == [(t,) for t in tasks[:3]] + [tuple(tasks[3:])]
    faulted = tasks[4].key
    assert plan_batches(tasks[3:], solve_contact_fields, memory=10**12, alone=lambda t: t.key == faulted) == [
        (tasks[3], tasks[5]),
        (tasks[4],),
    ]


def test_a_batch_gives_the_entries_of_its_tasks_run_alone():
    tasks = tasks_of(CIRCLES + [{**CIRCLES[0], "quantities": "normal", "precondition": False}])
    (batch,) = plan_batches(tasks[:3], solve_contact_fields, memory=10**12)
    entries = run_batch(batch, 3, alone) + run_batch(tasks[3:], 3, alone)
    for task, entry in zip(tasks, entries):
        single = alone(task)
        assert (entry.key, entry.params, entry.status, entry.message, entry.rank) == (
            single.key,
            single.params,
            OK,
            "",
            3,
        )
        assert entry.wall_time_s > 0.0 and entry.finished > 0.0
        assert_same_records(entry.record, single.record)


def test_a_failing_scene_is_recorded_alone_and_the_others_are_solved():
    tasks = tasks_of([CIRCLES[0], FAILING, CIRCLES[1]])
    ran_alone = []

    def counted(task: Task):
        ran_alone.append(task.key)
        return alone(task)

    entries = run_batch(tasks, 3, counted)
    assert ran_alone == [t.key for t in tasks]  # the batch raised: each task alone
    failed = alone(tasks[1])
    assert (entries[1].status, entries[1].message) == (BAD_INPUT, failed.message)
    assert failed.message.startswith("InputError: n = 4")
    for i in (0, 2):
        assert entries[i].status == OK
        assert_same_records(entries[i].record, alone(tasks[i]).record)


def test_the_stop_control_covers_the_batch_and_a_stop_propagates():
    class Stop:
        running = False
        seen: list[bool] = []

    stop = Stop()
    tasks = tasks_of(CIRCLES[:2])

    def solve_seen(fields):
        stop.seen.append(stop.running)
        raise KeyboardInterrupt  # a BaseException, as signals.Abandoned: not solved again one at a time

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(batches, "solve_contact_batch", solve_seen)
        with pytest.raises(KeyboardInterrupt):
            run_batch(tasks, 0, functools.partial(pytest.fail, "run alone"), stop)
    assert stop.seen == [True] and stop.running is False


def test_a_gpu_batch_fits_half_the_free_device_memory_and_the_hosts_budget(monkeypatch):
    monkeypatch.setattr(batches, "gpu_memory", lambda: memory.GpuMemory(8 * 2**30, 16 * 2**30, 0, "stub"))
    monkeypatch.setattr(batches, "resident_bytes", lambda: 2**30)
    monkeypatch.setattr(batches, "default_memory_per_rank", lambda: (64 * 2**30, "stub"))
    assert batch_memory("gpu") == 4 * 2**30  # BATCH_MEMORY_FRACTION of the free 8 GiB
    monkeypatch.setattr(batches, "default_memory_per_rank", lambda: (3 * 2**30, "stub"))
    assert batch_memory("gpu") == 2 * 2**30  # the host's 3 GiB less the 1 GiB held
    tasks = tasks_of([{**c, "device": "gpu"} for c in CIRCLES])
    monkeypatch.setattr(batches, "default_memory_per_rank", lambda: (2**30 + int(2.5 * array_bytes(CIRCLES[0])), "s"))
    assert [len(b) for b in plan_batches(tasks, solve_contact_fields)] == [2, 1]


def test_a_rank_fills_a_batch_with_the_chunks_of_its_group_that_fit():
    """``batch_fill`` (forced on the CPU by ``memory``): from chunk i, the consecutive chunks whose
    first task is of chunk i's group, as many as fit (their tasks' array_bytes summed), at most
    ``most``, at least one; a chunk that batches with none fills alone."""
    scene = array_bytes(CIRCLES[0])
    circles = tasks_of(CIRCLES)
    other_grid = tasks_of([{**CIRCLES[0], "n": 24}])
    chunks = [tuple(circles[:2]), (circles[2],), tuple(circles), tuple(other_grid), tuple(tasks_of(ALONE[:1]))]
    made = []
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(batches, "batch_group", lambda *args: made.append(args[0]) or batch_group(*args))
        fill = batch_fill(chunks, solve_contact_fields, memory=int(6.5 * scene))
        assert [fill(0, 10), fill(1, 10), fill(0, 1), fill(3, 10), fill(4, 10), fill(5, 10)] == [3, 2, 1, 1, 1, 1]
    assert made == [circles[0].params, other_grid[0].params, ALONE[0]]  # one Scene a grid, not one a chunk
    assert batch_fill(chunks, solve_contact_fields, memory=int(2.5 * scene))(0, 10) == 1  # the first chunk alone
    assert batch_fill(chunks, solve_contact_fields, memory=int(3.5 * scene))(0, 10) == 2


def test_a_cpu_rank_fills_no_batch_and_a_gpu_rank_fills_its_memory(monkeypatch):
    """Without ``memory``: None where no task runs on this rank's GPU (claims as before), else
    ``batch_memory`` of the GPU (a stand-in's 8 GiB free, half of it a batch)."""
    tasks = tasks_of([{**c, "device": "gpu"} for c in CIRCLES])
    assert batch_fill([(t,) for t in tasks_of(CIRCLES)], solve_contact_fields) is None
    monkeypatch.setattr(batches, "gpu_memory", lambda: memory.GpuMemory(8 * 2**30, 16 * 2**30, 0, "stub"))
    monkeypatch.setattr(batches, "resident_bytes", lambda: 0)
    monkeypatch.setattr(batches, "default_memory_per_rank", lambda: (64 * 2**30, "stub"))
    fill = batch_fill([(t,) for t in tasks], solve_contact_fields)
    assert fill(0, 10) == 3 and fill(1, 1) == 1
    monkeypatch.setattr(batches, "gpu_memory", lambda: memory.GpuMemory(int(4.5 * array_bytes(CIRCLES[0])), 0, 0, "s"))
    assert fill(0, 10) == 2  # half of 4.5 scenes' bytes


def test_a_rank_that_fills_claims_one_batch_of_chunks_and_records_each_task_as_alone():
    """Chunks of one task each (a kernel group per nu, ``make_chunks``) claimed with ``batch_fill``
    (forced on the CPU by ``memory``): one claim holds them all, ``plan_batches`` makes it one
    batch, and ``run_batch`` records each task as run alone."""
    tasks = [Task(task_key(f), f, 1.0, f"nu {f['nu']}") for f in CIRCLES]
    chunks = make_chunks(tasks, 1)
    assert [len(c) for c in chunks] == [1, 1, 1]
    counter = LocalCounter(SLOTS)
    claims = list(claimed_chunks(chunks, counter, fill=batch_fill(chunks, solve_contact_fields, memory=10**12)))
    assert claims == [tuple(t for c in chunks for t in c)]
    (batch,) = plan_batches(claims[0], solve_contact_fields, memory=10**12)
    for task, entry in zip(batch, run_batch(batch, 3, alone)):
        assert entry.status == OK and entry.key == task.key
        assert_same_records(entry.record, alone(task).record)
