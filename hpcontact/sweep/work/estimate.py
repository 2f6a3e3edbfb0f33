"""A sweep's estimate before it runs (``--dry-run``): every task's core-seconds and peak memory, and the wall time on R ranks.

**At scale.** ``estimate`` reads each task's cost and ``tasks.Sizing`` (kind, padded cells, array
bytes: made once per distinct value while the tasks are enumerated) and computes seconds and
bytes for all tasks at once (numpy, the same operations in the same order as ``task_seconds``,
so the same numbers, but that a crystal kernel is built once per kernel group,
``shared_kernel_builds``); the tasks are put in chunk order once (``tasks.chunk_order``) and cut for
each number of ranks replayed (``tasks.chunk_bounds``): a dry run of 10^6 tasks estimates in
seconds (``benchmarks/dry_run_points.py``).

``hpcontact run`` prints the estimate of the tasks it will compute before it starts
(``start_estimate``), from the cached or named calibration, else from the shipped prior scaled
by a probe of this machine (``cost.prior.run_calibration``): never without an
estimate, never waiting for a calibration.

``check_memory`` refuses a run whose largest task would not fit in ``--mem-per-rank``, and one
whose largest GPU task would not fit in its GPU's free memory.

**GPU tasks** (``device = "gpu"``) are estimated with the cost model of the GPU this process sees
(``GpuCosts``: ``cost.calibration_file.gpu_calibration``, a file per kind of GPU), never with a
CPU's: without one their seconds are not estimated (NaN in ``Estimate.seconds``, left out of the
totals and said so; no wall time is replayed). Their memory is the host's as a CPU task's (each
scene is built on the host) and, on the device, ``footprint.array_bytes`` a scene, times the
scenes of a batch (``gpu_batches``: ``sweep.work.batches``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hpcontact.errors import InputError
from hpcontact.numerics.memory import MIB, GpuMemory, gpu_memory, resident_bytes
from hpcontact.problems.footprint import BODY_TABLE_GROUPS, task_kind
from hpcontact.sweep.cost.calibration import other_running
from hpcontact.sweep.cost.calibration_file import gpu_calibration
from hpcontact.sweep.cost.engine import omega_nodes
from hpcontact.sweep.cost.grids import asks_accuracy, padded_cells
from hpcontact.sweep.cost.prior import probe_pending, run_calibration
from hpcontact.sweep.cost.rates import (
    IMPORTS_BYTES,
    Calibration,
    base_memory_bytes,
    load_note,
    node_type,
    work_seconds,
)
from hpcontact.sweep.cost.task_cost import Sizing, sizing
from hpcontact.sweep.run.options import MEM_PER_RANK
from hpcontact.sweep.work.replay import DEFAULT_OVERHEADS, Overheads, replay_chunks
from hpcontact.sweep.work.tasks import ChunkOrder, Task, chunk_order, group_ids, paused_gc


@dataclass
class Estimate:
    """A sweep's estimate: per task (in sweep order) seconds and bytes (float64 arrays: 16 B a
    task, not the 64 of two lists of floats); totals; wall time by ranks; the distinct grids
    (padded cells → tasks) and kernel sets; tasks over the limit. ``sizing_of`` gives each
    task's position in ``sizings`` (distinct ``tasks.Sizing`` values, in first-appearance
    order)."""

    tasks: list[Task]
    seconds: np.ndarray
    bytes: np.ndarray
    wall_s: dict[int, float] = field(default_factory=dict)
    efficiency: dict[int, float] = field(default_factory=dict)
    sizing_of: np.ndarray | None = None
    sizings: list[Sizing] = field(default_factory=list)
    chunks: ChunkOrder | None = None  # the tasks in chunk order (``tasks.chunk_order``), when replayed
    on_gpu: np.ndarray | None = None  # which tasks run on a GPU (``device_of``); None: none
    gpu: GpuCosts | None = None  # what the GPU tasks are estimated with, when there are any

    @property
    def not_estimated(self) -> int:
        """Tasks whose seconds are not estimated (GPU tasks without a calibration for their GPU)."""
        return int(np.count_nonzero(np.isnan(self.seconds)))

    @property
    def total_seconds(self) -> float:
        """Seconds of the estimated tasks (``not_estimated`` says how many are left out)."""
        seconds = np.asarray(self.seconds, dtype=np.float64)
        return float(sum(seconds[~np.isnan(seconds)].tolist()))  # in task order, as sum() adds

    @property
    def peak_bytes(self) -> float:
        return float(np.max(self.bytes)) if len(self.bytes) else 0.0

    def grids(self) -> dict[str, int]:
        """Distinct grids: label → number of tasks (labels in first-appearance order)."""
        if self.sizing_of is None:
            self.sizing_of, self.sizings = _sizings(self.tasks)
        counts: dict[str, int] = {}
        for size, count in zip(self.sizings, np.bincount(self.sizing_of, minlength=len(self.sizings)).tolist()):
            label = sizing_label(size)
            counts[label] = counts.get(label, 0) + count
        return counts

    def kernel_sets(self) -> int:
        """Distinct kernel sets (the tasks' kernel groups)."""
        if self.chunks is not None:
            return len(self.chunks.groups) - 1  # where each group starts, and the end
        return len({t.group for t in self.tasks})

    def over(self, limit: float) -> list[int]:
        """Indices of the tasks whose memory exceeds ``limit`` bytes."""
        return np.flatnonzero(np.asarray(self.bytes, dtype=np.float64) > limit).tolist()


@dataclass(frozen=True)
class GpuCosts:
    """What a sweep's GPU tasks are estimated with: this process's GPU (``numerics.memory.gpu_memory``),
    its cost model (``cost.calibration_file.gpu_calibration``; None: no calibration for this GPU,
    their seconds are not estimated) and, in words, whose it is or that there is none."""

    gpu: GpuMemory
    calibration: Calibration | None
    note: str

    @classmethod
    def here(cls) -> GpuCosts:
        """Those of the GPU this process sees (``InputError`` on ``device`` where it sees none)."""
        gpu = gpu_memory()
        return cls(gpu, *gpu_calibration(gpu))


def device_of(tasks: Sequence[Task]) -> np.ndarray | None:
    """Which of ``tasks`` ask for a GPU (``device = "gpu"``); None when none does (found by a set of
    the devices first: the CPU sweep's case, 0.4 s per 10^6 tasks on the 2-core development
    machine at load ~7, 2026-11-29 02:18 UTC)."""
    if "gpu" not in {t.params.get("device") for t in tasks}:
        return None
    return np.fromiter((t.params.get("device") == "gpu" for t in tasks), dtype=bool, count=len(tasks))


def gpu_batches(est: Estimate) -> list[tuple[str, float, int]]:
    """The GPU tasks' grids (``sizing_label``, first-appearance order): the device bytes of one
    scene (``footprint.array_bytes``) and how many scenes one batch holds on this GPU
    (``sweep.work.batches.batch_memory``; 1 for a task that asks for an accuracy: its grid
    sequence is solved alone)."""
    if est.on_gpu is None:
        return []
    from hpcontact.sweep.work.batches import batch_memory  # the solvers' modules: only for GPU tasks

    if est.sizing_of is None:
        est.sizing_of, est.sizings = _sizings(est.tasks)
    room = batch_memory("gpu")
    out: dict[str, tuple[float, int]] = {}
    for k in dict.fromkeys(est.sizing_of[est.on_gpu].tolist()):
        size = est.sizings[k]
        scenes = 1 if size.work is not None else max(1, int(room // size.array_bytes))
        out.setdefault(sizing_label(size), (size.array_bytes, scenes))
    return [(label, nbytes, scenes) for label, (nbytes, scenes) in out.items()]


def grid_label(params: Mapping[str, Any]) -> str:
    """A grid, as the dry-run names it: the kind's FFT grid in padded cells (a task that asks for
    an accuracy: its boundary cells and finest predicted grid, ``tasks.sizing``)."""
    if asks_accuracy(params):
        return sizing_label(sizing(params))
    return f"{task_kind(params)} {padded_cells(params):.0f} padded cells"


def sizing_label(size: Sizing) -> str:
    """``grid_label`` of a task of this ``tasks.Sizing``."""
    if size.label is not None:
        return size.label
    return f"{size.kind} {size.cells:.0f} padded cells"


def _sizings(tasks: Sequence[Task]) -> tuple[np.ndarray, list[Sizing]]:
    """Each task's position in the list of distinct sizings (first-appearance order), and that
    list; a task without one (``Task.sizing`` None) gets ``tasks.sizing`` of its parameters.
    Tasks share a few sizing objects: they are told apart by ``id`` with numpy, then by value."""
    objects = [t.sizing for t in tasks]
    ids = np.fromiter(map(id, objects), dtype=np.int64, count=len(objects))
    for i in np.flatnonzero(ids == id(None)).tolist():
        objects[i] = sizing(tasks[i].params)
        ids[i] = id(objects[i])
    unique, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
    slot = np.empty(len(unique), dtype=np.intp)
    position: dict[Sizing, int] = {}
    for k in np.argsort(first, kind="stable").tolist():  # distinct objects in first-appearance order
        slot[k] = position.setdefault(objects[first[k]], len(position))  # equal values share a slot
    return slot[inverse.reshape(-1)], list(position)


def task_arrays(
    tasks: Sequence[Task], calibration: Calibration
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[Sizing]]:
    """``Calibration.task_seconds`` and ``task_bytes`` of every task at once, from its cost and
    sizing (the same operations in the same order: the same floats), with ``_sizings``' map; a
    crystal kernel that a kernel group builds once is counted once (``shared_kernel_builds``)."""
    which, sizes = _sizings(tasks)
    cost = np.array([t.cost for t in tasks], dtype=np.float64)
    seconds = np.empty(len(tasks), dtype=np.float64)
    for k, size in enumerate(sizes):  # a few distinct sizings: each a vector operation
        if size.work is not None:  # an accuracy task: its work, whatever its cost
            seconds[which == k] = work_seconds(calibration.rates, size.work)
            continue
        rate, at = calibration.rates[size.kind], np.flatnonzero(which == k)
        c = cost[at]
        nodes = 0.0
        if size.kind in BODY_TABLE_GROUPS:
            nodes = np.array([omega_nodes(dict(tasks[i].params)) for i in at.tolist()], dtype=np.float64)
        seconds[at] = (
            rate.rate_s * c
            + rate.solve_s * (c / (size.cells * math.log2(size.cells)))
            + rate.cell_s * size.cells
            + rate.node_s * nodes
            + rate.task_s
        )
    shared = shared_kernel_builds(tasks, sizes, which)
    if shared is not None:
        seconds -= calibration.rates["contact"].exact_s * shared
    nbytes = calibration.base_bytes + np.array([s.array_bytes for s in sizes], dtype=np.float64)[which]
    return seconds, nbytes, which, sizes


def shared_kernel_builds(tasks: Sequence[Task], sizes: Sequence[Sizing], which: np.ndarray) -> np.ndarray | None:
    """The crystal kernel builds (``tasks.Work.kernel_builds``) that each of ``tasks`` (sizings
    ``sizes``, ``which`` its position there) finds done: all of them for every task of a kernel
    group but the one handed out first (the largest cost, ties first appearance: ``chunk_order``).
    A kernel group's tasks share one material and run one after another on a rank, whose kernel
    cache (``kernels.anisotropic.kernel_for``) keeps what the first built: on the main job at
    accuracy 1e-3 a crystal ellipse after the rectangle of its material and b/a took 1-20 ms, its
    kernel's build ~60 ms (``benchmarks/cost_estimates.py --journals``). A group cut into several chunks counts
    one build too: its later chunks are the smallest, handed out last, warm where the rank that
    built the kernel takes them, cold (underestimated by one build each) where another does. None
    when no task builds one."""
    builds = np.array([0.0 if s.work is None else s.work.kernel_builds for s in sizes], dtype=np.float64)[which]
    at = np.flatnonzero(builds > 0.0)
    if not at.size:
        return None
    group = group_ids([tasks[i] for i in at.tolist()])
    order = np.lexsort((-np.array([tasks[i].cost for i in at.tolist()], dtype=np.float64), group))  # stable
    later = at[order[1:][group[order][1:] == group[order][:-1]]]  # not its group's first in hand-out order
    shared = np.zeros(len(tasks), dtype=np.float64)
    shared[later] = builds[later]
    return shared


def estimate(
    tasks: Sequence[Task],
    calibration: Calibration,
    ranks: Sequence[int] = (1, 64, 1024),
    overheads: Overheads = DEFAULT_OVERHEADS,
    gpu: GpuCosts | None = None,
) -> Estimate:
    """Seconds and bytes of every task (``task_arrays``; GPU tasks' seconds by ``gpu``, default
    ``GpuCosts.here()``, NaN without its calibration), and the replayed wall time on each of
    ``ranks`` (the tasks put in chunk order once, ``tasks.chunk_order``; none while a task has
    no seconds)."""
    tasks = tasks if isinstance(tasks, list) else list(tasks)
    with paused_gc():
        seconds, nbytes, which, sizes = task_arrays(tasks, calibration)
        on_gpu = device_of(tasks)
        if on_gpu is not None:
            gpu = gpu if gpu is not None else GpuCosts.here()
            seconds[on_gpu] = (
                np.nan
                if gpu.calibration is None
                else task_arrays([t for t, g in zip(tasks, on_gpu.tolist()) if g], gpu.calibration)[0]
            )
        result = Estimate(tasks, seconds, nbytes, sizing_of=which, sizings=sizes, on_gpu=on_gpu, gpu=gpu)
        chunks = result.chunks = chunk_order(tasks) if tasks else None
        for r in ranks if not result.not_estimated else ():  # no wall time of tasks without seconds
            replayed = replay_chunks(chunks, seconds, r, overheads) if tasks else {"makespan_s": 0.0, "efficiency": 1.0}
            result.wall_s[r], result.efficiency[r] = replayed["makespan_s"], replayed["efficiency"]
    return result


def check_memory(tasks: Sequence[Task], limit: float, source: str) -> None:
    """``InputError`` (field ``options.MEM_PER_RANK``) when a task's estimated peak memory exceeds
    ``limit`` bytes; the base memory is this process's (no calibration needed). Importing what
    a run imports to measure it costs rank 0 ~1 s while every rank waits, so that is done only
    for a task within IMPORTS_BYTES of the limit; a task whose arrays exceed the limit already
    beside what this process holds now is refused without it (the need stated is then that
    lower bound). A GPU task's arrays must also fit, alone, in the free memory of the GPU this
    process sees (``_check_gpu_memory``)."""
    if not tasks:
        return
    which, sizes = _sizings(tasks)
    arrays = np.array([s.array_bytes for s in sizes], dtype=np.float64)[which]  # task_array_bytes of each
    on_gpu = device_of(tasks)
    if on_gpu is not None:
        _check_gpu_memory(arrays, on_gpu)
    worst = int(np.argmax(arrays))
    resident = resident_bytes()
    if resident + IMPORTS_BYTES + float(arrays[worst]) <= limit:
        return
    base = resident if resident + float(arrays[worst]) > limit else base_memory_bytes()
    need = base + float(arrays[worst])
    if need > limit:
        over = int(np.count_nonzero(base + arrays > limit))
        raise InputError(
            MEM_PER_RANK,
            f"at least the largest task's estimated peak memory {need / MIB:.0f} MiB (task {worst}; {over} task(s) "
            f"over the limit; see hpcontact run SPEC --dry-run)",
            f"{limit / MIB:.0f} MiB ({source})",
        )


def _check_gpu_memory(arrays: np.ndarray, on_gpu: np.ndarray) -> None:
    """``InputError`` (field device) when the largest GPU task's arrays (``arrays``, bytes per task;
    ``on_gpu`` says which tasks) exceed the free memory of this process's GPU: a batch holds at
    least one scene."""
    gpu = gpu_memory()
    need = float(np.max(arrays[on_gpu]))
    if need > gpu.free:
        over = int(np.count_nonzero(arrays[on_gpu] > gpu.free))
        raise InputError(
            "device",
            f"the largest GPU task's estimated device memory {need / MIB:.0f} MiB over the free {gpu.free / MIB:.0f} "
            f"MiB of {gpu.label} ({over} GPU task(s) over it; see hpcontact run SPEC --dry-run)",
            "gpu",
        )


def start_estimate(
    tasks: Sequence[Task], ranks: int, node_ranks: int = 1, probe_cover_s: float = 0.0
) -> tuple[str, np.ndarray]:
    """The line ``hpcontact run`` prints on rank 0 before work starts — the estimated core-seconds
    of ``tasks`` (those this run computes) and the replayed wall time on ``ranks`` ranks, and
    whose cost model they come from — and each task's estimated seconds (for the progress lines'
    ETA). The cost model is ``prior.run_calibration``'s: the cached or named
    calibration, else the shipped prior scaled by a probe of this machine (0.4-0.5 CPU-seconds;
    beside the run's ``node_ranks`` - 1 other ranks on this node, not counted as contention),
    never a calibration a run would wait for. It warns where the calibration shared its cores
    (``Calibration.contended``: its seconds are high) and where the run shares them now
    (``rates.load_note``: the run will take longer). GPU tasks take their GPU's cost model
    (``GpuCosts``); without one the line says so and states the CPU tasks' seconds alone, and
    the seconds returned for the GPU tasks are their CPU estimates, weights of the ETA only
    (which scales them by the measured wall seconds per estimated second). Where the probe is
    still to come (``prior.probe_pending``) and the tasks' seconds a rank by the shipped prior as
    it is fall short of ``probe_cover_s`` (an adaptive round too short to cover the probe, which
    the other ranks would wait for), the line is the prior's, unscaled, and says so."""
    pending = probe_cover_s > 0.0 and probe_pending()
    calibration, origin = run_calibration(own=node_ranks - 1, probe_now=not pending)
    tasks = list(tasks)
    seconds = task_arrays(tasks, calibration)[0]
    if pending and sum(seconds.tolist()) / ranks >= probe_cover_s:  # the round covers the probe
        calibration, origin = run_calibration(own=node_ranks - 1)
        seconds = task_arrays(tasks, calibration)[0]
    on_gpu = device_of(tasks)
    if on_gpu is not None:
        gpu = GpuCosts.here()
        if gpu.calibration is None:  # their CPU seconds stay the progress ETA's weights; none is printed
            shown = seconds[~on_gpu]
            line = (
                f"hpcontact: {int(on_gpu.sum())} GPU task(s) not estimated: {gpu.note}; the {len(shown)} CPU task(s): "
                f"estimated {sum(shown.tolist()):.4g} core-seconds ({origin})"
            )
            return line, seconds
        seconds[on_gpu] = task_arrays([t for t, g in zip(tasks, on_gpu.tolist()) if g], gpu.calibration)[0]
        origin = f"{origin}; GPU tasks: {gpu.note}"
    wall = replay_chunks(chunk_order(tasks), seconds, ranks, DEFAULT_OVERHEADS)["makespan_s"] if tasks else 0.0
    others = other_running()
    notes = (calibration.contended(), load_note(None if others is None else others + 1.0, node_type()[1]))
    line = (
        f"hpcontact: estimated {sum(seconds.tolist()):.4g} core-seconds, {wall:.3g} s on {ranks} rank(s) "
        f"({origin}; --dry-run for each task{''.join(f'; {note}' for note in notes if note)})"
    )
    return line, seconds
