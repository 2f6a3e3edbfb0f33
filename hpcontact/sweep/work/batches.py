"""A rank's claimed tasks as batches of scenes (issue 41 item 2): which tasks go together, how many
fit in the device's memory, and the entries of a batch, each as the task alone would have made it.

**Which tasks batch.** A task of the default contact solver (``accuracy.defaults.solve_contact_fields``)
whose scene ``problems.contact.solve`` solves on its one grid (``n`` given, no ``accuracy``: the
path ``default_solve`` takes) can be solved with others by ``problems.contact.solve_batch``, which
groups their punch solves exactly by ``contact.batch_key`` (device, components, grid shape,
preconditioner grid). The plan here puts together the tasks of one ``batch_group``: one device,
one contact grid before cropping (``footprint.contact_grid``), one set of quantities and one
preconditioner choice, the fields that decide ``batch_key`` before any scene is rasterized.

A task solved over a grid sequence (an ``accuracy``, or the extrapolated default without ``n``:
``accuracy.defaults.accuracy_request``) batches with the tasks of the same device, cells
(``boundary``, ``auto`` resolved), first grid, quantities and preconditioner choice, so that their
sequences run over the same grids: ``accuracy.solve_to_accuracy_batch`` refines them level by
level together, each scene stopping by its own estimate, a failing one stopped alone; on a GPU the
coverage-weighted solves of a level that share a cropped grid are one batched CG
(``accuracy.level_batches``), on the CPU the levels are solved one at a time. The one exact
cell of an ellipse (``galin``) runs alone: one integral (its compliance J) on the host, no grid to
batch, 0.5-26 ms of CPU a scene (``solve_to_accuracy`` at 1e-6 of the circle, a Cu ellipse b/a 0.5,
an ellipse b/a 1e-4 at nu 0.45; best of 5, measured 2026-11-29 on 2 shared cores, load ~10).
Every other task (a slip scene, another task function) runs alone.

**How many.** A batch of B scenes holds B scenes' arrays at once: B × ``batch_bytes``, a one-grid
scene's ``footprint.array_bytes`` (the memory model of one solve, bytes fitted to host peaks,
docs/performance.md §"Memory per task"; the same arrays on a GPU, not measured there), a grid
sequence's the arrays of the largest grid it may reach (``AccuracyRun.peak_bytes``, the memory
model of ``hpcontact.accuracy.memory``). A batch takes as many scenes of one group as
fit in ``batch_memory(device)``: on a GPU ``BATCH_MEMORY_FRACTION`` of the device's free memory
(``numerics.memory.gpu_memory``), and never more than the rank's host budget left
(the scenes' kernels and masks are built on the host first). On the CPU one scene per batch:
benchmarks/batched_scenes.py measured a batch 2-3.7x slower per scene there, so a CPU rank keeps
one scene per task unless ``memory`` is given (the tests force the batched path on the CPU so).

**Entries.** ``run_batch`` solves a batch (``solve_contact_batch``) and makes one ``journal.Entry``
per task with the fields ``rounds.run_task`` gives a task run alone (its record through the same
JSON round trip, status OK, the batch's wall time shared equally). If a one-grid batch raises (a
scene that fails its solve or its input), each of its tasks is run alone by ``run_alone``
(``run_task``): the failing scene is recorded with the error it gives alone and the others are
solved again, one at a time. In a batch of grid sequences a failing scene stops alone: it is run
alone by ``run_alone`` (recorded with the error it gives alone) and the others' records are kept. Journals, resume and per-scene records are those of tasks run one at a time; a rank
marks every task of a batch started before the batch solves, so a process that dies in a batch
leaves all of them quarantined, and ``--retry-crashed`` runs them alone on rank 0.

**Where.** A rank batches within the tasks it is handed at once (``plan_batches`` of a claim:
``sweep.run.rounds``). A chunk holds one kernel group, so a claim of one chunk batches little; a
GPU rank claims with ``batch_fill`` (``schedule.claimed_chunks``' ``fill``): at least the
consecutive chunks of one group that fill a batch, within the bound that keeps one fast rank from
taking the tail, handed as one tuple of their tasks.

**Which device.** A task's device is the one this rank solves it on (``backend.resolved_device``):
"cpu" and "gpu" as they say, "auto" this rank's own GPU where it has one and its CPU elsewhere, so
one job of "auto" scenes runs GPU and CPU ranks side by side, each batching as its device wants.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from hpcontact.accuracy.defaults import accuracy_request, default_solve_batch, error_columns, solve_contact_fields
from hpcontact.accuracy.level_batches import solve_levels_batched
from hpcontact.accuracy.refinement import AccuracyRun, plan_accuracy, solve_levels_one_by_one
from hpcontact.errors import InputError
from hpcontact.numerics.backend import resolved_device
from hpcontact.numerics.memory import default_memory_per_rank, gpu_memory, resident_bytes
from hpcontact.problems.contact import solve_batch
from hpcontact.problems.footprint import array_bytes, contact_grid
from hpcontact.problems.kinds import kind_of
from hpcontact.scene import DEFAULTS, Scene
from hpcontact.sweep.data.journal import OK, Entry, to_json
from hpcontact.sweep.work.tasks import Task

#: The share of a GPU's free memory one batch may fill: the bytes per scene are the host's memory
#: model (``footprint.array_bytes``), not measured on a GPU; the rest is left to cuFFT's plans and
#: work areas and to what the model misses.
BATCH_MEMORY_FRACTION = 0.5


def batch_group(params: Mapping[str, Any], task_function: Callable | None, device: str | None = None) -> tuple | None:
    """The group of the task ``params`` among tasks that ``run_batch`` solves together (module
    docstring), or None when it runs alone: another task function than the default contact
    solver's, a slip scene, an ellipse's one exact cell, a scene its checks refuse. A one-grid
    scene's group is (device, contact grid, quantities, preconditioning); a grid sequence's
    (device, "grid sequence", cells, first grid, quantities, preconditioning). The group's device
    is the one this rank solves the scene on (``device``, else the scene's device as
    ``backend.resolved_device`` resolves it: "auto" is this rank's GPU or its CPU)."""
    if task_function is not solve_contact_fields or not kind_of(params).planned:
        return None
    if device is None:
        device = resolved_device(params.get("device", DEFAULTS["device"]))
    try:
        scene = Scene.from_params({**params, "device": device})
        run = _sequence_of(scene)
    except InputError:  # alone: run_task records the refusal as the task's entry
        return None
    if run is None:
        return (device, contact_grid(params), tuple(scene.quantities), scene.precondition)
    if run.state is None:  # the one exact cell
        return None
    return (device, SEQUENCE, run.strategy, run.state.grids[0], tuple(scene.quantities), scene.precondition)


#: The mark of a grid sequence's ``batch_group``.
SEQUENCE = "grid sequence"


def _sequence_of(scene: Scene) -> AccuracyRun | None:
    """The planned grid sequence of ``scene`` as ``default_solve`` would refine it
    (``accuracy.plan_accuracy`` of its ``accuracy_request``), None for a one-grid scene."""
    request = accuracy_request(scene)
    if request is None:
        return None
    options = {k: v for k, v in request.items() if k != "strict"}
    return plan_accuracy(scene, options.pop("accuracy"), **options)


def batch_bytes(params: Mapping[str, Any], device: str) -> float:
    """The bytes the task ``params`` holds in a batch on ``device`` (the one this rank solves it on): a
    grid sequence's largest grid's arrays (``AccuracyRun.peak_bytes``), else ``footprint.array_bytes``
    (a scene its checks refuse too: it runs alone)."""
    try:
        scene = Scene.from_params({**params, "device": device})
        run = _sequence_of(scene)
    except InputError:
        return array_bytes(params)
    return array_bytes(params) if run is None else run.peak_bytes()


def batch_memory(device: str) -> int:
    """Bytes one batch of scenes may hold on ``device``: on a GPU ``BATCH_MEMORY_FRACTION`` of its
    free memory (``numerics.memory.gpu_memory``), at most the rank's host budget less this process's peak
    resident set; on the CPU 0 (one scene per batch, module docstring)."""
    if resolved_device(device) == "cpu":
        return 0
    free = gpu_memory().free
    host = default_memory_per_rank()[0] - resident_bytes()
    return int(max(0.0, min(BATCH_MEMORY_FRACTION * free, host)))


class _Devices(dict):
    """The device this rank solves each ``device`` value on (``backend.resolved_device``), each
    value resolved once: "auto" asks CuPy for the devices (~0.1 ms), not once per task."""

    def __missing__(self, device: str) -> str:
        self[device] = resolved_device(device)
        return self[device]


def plan_batches(
    tasks: Sequence[Task],
    task_function: Callable | None,
    memory: int | None = None,
    alone: Callable[[Task], bool] | None = None,
) -> list[tuple[Task, ...]]:
    """``tasks`` (a rank's claimed chunk) cut into batches: the tasks of one ``batch_group``, in
    their order, as many to a batch as their ``footprint.array_bytes`` sum fits in ``memory``
    bytes (``batch_bytes``; None: ``batch_memory`` of their device; at least one task a batch); a task without a
    group, or for which ``alone`` is true (a task with an injected fault), is a batch of its own.
    Batches in the order of their first task; every task in exactly one."""
    open_batch: dict[tuple, list[Task]] = {}
    room: dict[tuple, float] = {}  # bytes a batch of the group may hold, and its open batch's
    held: dict[tuple, float] = {}
    batches: list[list[Task]] = []
    devices = _Devices()
    for task in tasks:
        group = None
        device = devices[task.params.get("device", DEFAULTS["device"])]
        # a CPU task's batch is itself unless memory is given: no scene made (~0.3 ms a task)
        if (memory is not None or device != "cpu") and not (alone is not None and alone(task)):
            group = batch_group(task.params, task_function, device)
        if group is None:
            batches.append([task])
            continue
        need = batch_bytes(task.params, device)
        if group not in room:
            room[group] = float(batch_memory(group[0]) if memory is None else memory)
        batch = open_batch.get(group)
        if batch is None or held[group] + need > room[group]:
            batch = open_batch[group] = []
            held[group] = 0.0
            batches.append(batch)
        batch.append(task)
        held[group] += need
    return [tuple(batch) for batch in batches]


def batch_fill(
    chunks: Sequence[Sequence[Task]], task_function: Callable | None, memory: int | None = None
) -> Callable[[int, int], int] | None:
    """For ``schedule.claimed_chunks``: fill(i, most), how many chunks from index i (at most
    ``most``, at least 1) fill one of this rank's batches (issue 41 item 2); None where no task of
    ``chunks`` runs on this rank's GPU and no ``memory`` is given (a CPU rank: claims as before).
    The chunks counted are consecutive, their first tasks of the ``batch_group`` of chunk i's
    first task, their tasks' ``batch_bytes`` summed within ``memory`` (None:
    ``batch_memory`` of the group's device). Chunks hold one kernel group each, so a chunk's
    first task stands for it; a chunk whose first task gives n has the group of the first chunk of
    the same device, contact grid, quantities, preconditioning and accuracy (a Scene a grid, not a
    chunk; a scene its checks would refuse is then counted in: ``plan_batches`` groups the claimed
    tasks exactly, so a miscount changes a batch's size, never a result)."""
    devices = _Devices()
    if memory is None and "gpu" not in {devices[t.params.get("device", DEFAULTS["device"])] for c in chunks for t in c}:
        return None
    groups: dict[int, tuple | None] = {}
    by_fields: dict[tuple, tuple | None] = {}  # the group of the fields that decide it (n given)

    def group_of(index: int) -> tuple | None:
        if index not in groups:
            params = chunks[index][0].params
            device = devices[params.get("device", DEFAULTS["device"])]
            if memory is None and device == "cpu":
                groups[index] = None
            elif params.get("n") is None:  # the extrapolated default or not: the body decides (a Scene)
                groups[index] = batch_group(params, task_function, device)
            else:  # a sweep's chunks on one grid: one Scene made (~0.1-0.4 ms), not one a chunk
                get = params.get
                fields = (device, get("quantities"), get("precondition"), get("accuracy"))
                key = (*map(repr, fields), contact_grid(params))
                if key not in by_fields:
                    by_fields[key] = batch_group(params, task_function, device)
                groups[index] = by_fields[key]
        return groups[index]

    def fill(start: int, most: int) -> int:
        if start >= len(chunks) or (group := group_of(start)) is None:
            return 1
        room = float(batch_memory(group[0]) if memory is None else memory)
        count, held = 0, 0.0
        for index in range(start, min(start + most, len(chunks))):
            need = sum(batch_bytes(t.params, group[0]) for t in chunks[index])
            if count and (held + need > room or group_of(index) != group):
                break
            count, held = count + 1, held + need
        return max(count, 1)

    return fill


def solve_contact_batch(fields: Sequence[Mapping[str, Any]]) -> list[Any]:
    """``solve_contact_fields`` of each of ``fields`` (the tasks of one ``batch_group``, not None), in
    order. One-grid scenes: their punch solves batched by ``problems.contact.solve_batch``, each
    record that of the task alone up to rounding (tests/problems/test_contact_batch.py bounds it);
    a failing scene fails the batch (raises). Grid sequences: refined level by level together
    (``accuracy.defaults.default_solve_batch``), on a GPU each level's coverage-weighted solves as
    one batch (``accuracy.level_batches``: each record the task's alone up to rounding), on the CPU
    one level at a time (each record the task's alone, bitwise), a failing scene's place holding the
    ``Exception`` it raised."""
    scenes = [Scene.from_params(f) for f in fields]
    sequences = [accuracy_request(s) is not None for s in scenes]
    if any(sequences) and not all(sequences):
        raise ValueError("a batch is of one-grid scenes or of grid sequences, not both")
    if all(sequences):  # on a GPU a level's coverage-weighted solves batched; on the CPU one by one
        on_gpu = resolved_device(scenes[0].device) == "gpu"
        results = default_solve_batch(scenes, solve_levels_batched if on_gpu else solve_levels_one_by_one)
    else:
        results = solve_batch(scenes)
    return [r if isinstance(r, Exception) else error_columns(s.in_si_units(r)) for s, r in zip(scenes, results)]


def run_batch(batch: Sequence[Task], rank: int, run_alone: Callable[[Task], Entry], stop: Any = None) -> list[Entry]:
    """The entries of ``batch`` (``plan_batches``), in order: one task by ``run_alone`` (the rank's
    ``run_task``); several by ``solve_contact_batch``, each entry with the fields ``run_task`` gives
    (the record through the journal's JSON, status OK, an equal share of the batch's wall time,
    this ``rank``), or, if the batch raises an ``Exception``, each task by ``run_alone``; a grid
    sequence that failed in its batch by ``run_alone`` alone (module docstring). ``stop`` (``signals.StopControl``) is marked running while the batch solves, so a
    stop request's grace covers it; ``Abandoned`` and other BaseExceptions propagate."""
    if len(batch) == 1:
        return [run_alone(batch[0])]
    fields = [dict(t.params) for t in batch]
    started = time.perf_counter()
    try:
        if stop is not None:
            stop.running = True
        results = [r if isinstance(r, Exception) else json.loads(to_json(r)) for r in solve_contact_batch(fields)]
    except Exception:  # noqa: BLE001 - each task alone: the failing one recorded as alone, the others solved
        return [run_alone(task) for task in batch]
    finally:
        if stop is not None:
            stop.running = False
    share, finished = (time.perf_counter() - started) / len(batch), time.time()
    return [
        run_alone(task)  # a grid sequence that failed in the batch: its entry as alone
        if isinstance(record, Exception)
        else Entry(
            key=task.key,
            params=task.params,
            status=OK,
            message="",
            record=record,
            wall_time_s=share,
            finished=finished,
            rank=rank,
        )
        for task, record in zip(batch, results)
    ]
