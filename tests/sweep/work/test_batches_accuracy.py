"""Grid sequences of ``--accuracy`` refined level by level in a batch (``accuracy.solve_to_accuracy_batch``,
``sweep.work.batches``; issue 41 item 2) against each scene solved alone (``solve_to_accuracy``).

On the CPU a batch's levels are solved one scene at a time (``solve_levels_one_by_one``), so each
record must be the one the scene gets alone bitwise (every float ``==``): the batch changes only the
order in which levels are solved. Left aside: ``wall_time_s`` (a clock) and ``estimated_peak_bytes``
(it counts this process's peak resident set when the grids are planned).

The scenes are issue 41's (tests/numerics/device_agreement.py): the circle, the crystal ellipse on
grids (coverage-weighted cells, a crystal), the rectangle b/a = 1e-4, the star and the L-shaped mask,
plus an ellipse's one exact cell (solved per scene in the batch), on small first grids so that a
sequence takes seconds.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from hpcontact import accuracy
from hpcontact.accuracy import AccuracyNotMet, solve_levels_one_by_one, solve_to_accuracy, solve_to_accuracy_batch
from hpcontact.accuracy.memory import coverage_bytes
from hpcontact.accuracy.refinement import AccuracyRun
from hpcontact.accuracy.strategies import MAX_CELLS
from hpcontact.errors import InputError
from hpcontact.scene import Scene
from hpcontact.sweep.data.journal import OK
from hpcontact.sweep.run.rounds import run_task
from hpcontact.sweep.work import batches
from hpcontact.sweep.work.batches import SEQUENCE, batch_bytes, batch_group, plan_batches, run_batch
from hpcontact.sweep.work.tasks import Task, task_key

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "numerics"))
from device_agreement import scene_params  # noqa: E402

#: (scene of device_agreement.SCENES, request of solve_to_accuracy): refined over different grids and
#: stopped at different levels (the exact cell after none; 4 by the grids allowed; 4 and 5 met).
REQUESTS = [
    ("circle", {"accuracy": 1e-3, "n0": 8, "strategy": "coverage"}),
    ("crystal_ellipse", {"accuracy": 1e-2, "n0": 8, "strategy": "coverage"}),
    ("rectangle_1e-4", {"accuracy": 1e-3, "strategy": "auto"}),
    ("star", {"accuracy": 1e-2, "n0": 8, "strategy": "coverage"}),
    ("mask", {"accuracy": 1e-3, "strategy": "auto"}),
    ("circle", {"accuracy": 1e-5, "n0": 8, "max_grids": 4, "strategy": "coverage", "strict": False}),
    ("crystal_ellipse", {"accuracy": 1e-4, "strategy": "auto"}),  # the one exact cell
]


def scenes_of(requests: list[tuple[str, dict]], folder: Path) -> list[Scene]:
    """The scenes of ``requests``: device_agreement's fields without their grid and tolerance."""
    scenes = []
    for name, _ in requests:
        params = {k: v for k, v in scene_params(name, folder).items() if k not in ("n", "n_across", "tol")}
        scenes.append(Scene.from_params(params))
    return scenes


def without_clocks(record: Any) -> Any:
    """``record`` without its wall times (at every depth) and ``estimated_peak_bytes``."""
    if isinstance(record, dict):
        return {k: without_clocks(v) for k, v in record.items() if k not in ("wall_time_s", "estimated_peak_bytes")}
    if isinstance(record, list):
        return [without_clocks(v) for v in record]
    return record


def alone(scene: Scene, request: dict) -> Any:
    """``solve_to_accuracy`` of ``scene`` alone: its record or the exception it raises."""
    options = dict(request)
    try:
        return solve_to_accuracy(scene, options.pop("accuracy"), **options)
    except Exception as error:  # noqa: BLE001 - compared with the batch's
        return error


def test_a_batch_refines_level_by_level_and_each_record_is_the_scenes_alone_bitwise(tmp_path):
    scenes, requests = scenes_of(REQUESTS, tmp_path), [r for _, r in REQUESTS]
    rounds: list[list[tuple[int, int, int]]] = []  # per round: (scene, n, n_across) of each level solved

    def recorded(levels):
        rounds.append([([id(s) for s in scenes].index(id(run.scene)), n, na) for run, n, na in levels])
        return solve_levels_one_by_one(levels)

    batched = solve_to_accuracy_batch(scenes, requests, recorded)
    singles = [alone(scene, request) for scene, request in zip(scenes, requests)]
    for index, (record, single) in enumerate(zip(batched, singles)):
        assert isinstance(record, dict) and isinstance(single, dict), (index, record, single)
        assert without_clocks(record) == without_clocks(single), REQUESTS[index]
    depth = [len(r["levels"]) for r in batched]
    assert set(depth) == {0, 4, 5}, depth  # the premise: scenes stop at different levels, by different limits
    assert batched[5]["stopped_by"] == "grids" and batched[0]["stopped_by"] == "met"
    assert batched[6]["boundary"] == "galin" and all(6 not in {i for i, _, _ in level} for level in rounds)
    # round k solved level k of exactly the scenes still refining, on the grids of their records
    for k, level in enumerate(rounds):
        expected = [(i, r["grids"][k], r["grids_across"][k]) for i, r in enumerate(batched) if len(r["levels"]) > k]
        assert level == expected, k
    assert len(rounds) == max(depth)


def test_a_failing_scene_stops_alone_and_the_others_are_kept(tmp_path):
    """A scene refused when planned (InputError), one whose level 2 fails its solve, one that does not
    meet its request with ``strict`` (AccuracyNotMet): each the exception it gives alone, in its
    place; the others refined to the end, each its record alone."""
    requests = [
        ("rectangle_1e-4", {"accuracy": 1e-3, "strategy": "auto"}),
        ("star", {"accuracy": 2.0, "n0": 8}),
        ("circle", {"accuracy": 1e-2, "n0": 8, "strategy": "coverage"}),
        ("circle", {"accuracy": 1e-6, "n0": 8, "max_grids": 4, "strategy": "coverage"}),
    ]
    scenes, options = scenes_of(requests, tmp_path), [r for _, r in requests]
    failing = FloatingPointError("K_xx is not finite (nan)")

    def second_level_fails(levels):
        results = solve_levels_one_by_one(levels)
        return [
            failing if run.scene is scenes[2] and len(run.state.levels) == 1 else r
            for (run, _, _), r in zip(levels, results)
        ]

    batched = solve_to_accuracy_batch(scenes, options, second_level_fails)
    refused, not_met = alone(scenes[1], options[1]), alone(scenes[3], options[3])
    assert isinstance(refused, InputError) and type(batched[1]) is InputError and str(batched[1]) == str(refused)
    assert batched[2] is failing
    assert isinstance(not_met, AccuracyNotMet) and type(batched[3]) is AccuracyNotMet
    assert str(batched[3]) == str(not_met) and without_clocks(batched[3].record) == without_clocks(not_met.record)
    assert without_clocks(batched[0]) == without_clocks(alone(scenes[0], options[0]))


#: Tasks of a sweep solved over grid sequences: two rectangles b/a = 1e-4 (``accuracy``: one group of
#: cells and first grid), and a circle's one exact cell, which runs alone.
TASKS = [
    {"shape": "rectangle", "aspect": 1e-4, "nu": nu, "quantities": "tangential", "accuracy": 1e-3} for nu in (0.3, 0.45)
] + [{"shape": "circle", "nu": 0.3, "accuracy": 1e-3}]


def tasks_of(fields: list[dict]) -> list[Task]:
    return [Task(task_key(f), f, 1.0, "g") for f in fields]


def run_alone(task: Task):
    return run_task(batches.solve_contact_fields, task, 3)


def test_grid_sequences_batch_by_cells_and_first_grid_sized_by_their_largest_grid():
    tasks = tasks_of(TASKS)
    group = batch_group(TASKS[0], batches.solve_contact_fields)
    assert group == ("cpu", SEQUENCE, "coverage", (16, 4), ("tangential",), True)
    assert batch_group(TASKS[1], batches.solve_contact_fields) == group
    assert batch_group(TASKS[2], batches.solve_contact_fields) is None  # the exact cell
    assert batch_group({"shape": "circle", "nu": 0.2}, batches.solve_contact_fields) is None  # the default: exact
    extrapolated = batch_group({"shape": "star", "amplitude": 0.0, "nu": 0.2}, batches.solve_contact_fields)
    assert extrapolated == ("cpu", SEQUENCE, "coverage", (16, 16), ("tangential",), True)  # the default, no n
    # a sequence's bytes are those of the largest grid it may reach: the cell limit's, n = 1024 here
    scene = Scene.from_params(TASKS[0])
    largest = accuracy.plan_grids(scene, 16, 4, MAX_CELLS, None, "coverage").grids[-1]
    assert largest[0] == 1024 and batch_bytes(TASKS[0], "cpu") == coverage_bytes(scene, *largest)
    need = batch_bytes(TASKS[0], "cpu")
    assert [len(b) for b in plan_batches(tasks, batches.solve_contact_fields, memory=int(2.5 * need))] == [2, 1]
    assert [len(b) for b in plan_batches(tasks, batches.solve_contact_fields, memory=int(1.5 * need))] == [1, 1, 1]


def test_a_batch_of_grid_sequences_gives_the_entries_of_its_tasks_run_alone_bitwise():
    tasks = tasks_of(TASKS[:2])
    (batch,) = plan_batches(tasks, batches.solve_contact_fields, memory=10**12)
    ran_alone: list[str] = []
    entries = run_batch(batch, 3, lambda task: ran_alone.append(task.key) or run_alone(task))
    assert ran_alone == []
    for task, entry in zip(tasks, entries):
        single = run_alone(task)
        assert (entry.key, entry.params, entry.status, entry.message, entry.rank) == (task.key, task.params, OK, "", 3)
        assert without_clocks(entry.record) == without_clocks(single.record)
        assert entry.record["grids"] == [16, 32, 64, 128] and entry.record["stopped_by"] == "met"


def test_a_task_that_fails_in_a_batch_of_grid_sequences_is_run_alone_and_the_others_kept(monkeypatch):
    tasks = tasks_of(TASKS[:2])
    solve_level = AccuracyRun.solve_level

    def fails_for_nu_045(run: AccuracyRun, n: int, n_across: int):
        if run.scene.material.nu == 0.45 and n == 32:
            raise FloatingPointError("K_xx is not finite (nan)")
        return solve_level(run, n, n_across)

    monkeypatch.setattr(AccuracyRun, "solve_level", fails_for_nu_045)
    ran_alone: list[str] = []
    entries = run_batch(tuple(tasks), 3, lambda task: ran_alone.append(task.key) or run_alone(task))
    assert ran_alone == [tasks[1].key]  # the failing one alone, recorded as alone; the other kept
    failed = run_alone(tasks[1])
    assert (entries[1].status, entries[1].message) == (failed.status, failed.message) != (OK, "")
    assert entries[0].status == OK and without_clocks(entries[0].record) == without_clocks(run_alone(tasks[0]).record)
