"""Tasks of a sweep: the distinct scenes of the spec's parameter space, keyed, costed, chunked.

A task is one call of the task function (``hpcontact.solve.solve``) on one scene. Points of the
parameter space whose scenes are equal (a circle on an aspect axis, the load angle in tensor
mode) share a task. A task's key is the SHA-1 of its canonical parameter JSON: it names the
scene itself, not its place in the spec, so ``--resume`` after an edit of the spec reuses exactly
the scenes that did not change and recomputes those that did (a changed ``tol``, say).

Tasks are handed out in chunks, largest estimated cost first (longest-processing-time order
keeps the tail short). A chunk holds tasks that can share kernels: same material, ``n``,
``n_across`` and b/a, differing only in the contact's outline or the solve (``tol``,
``quantities``); the engine caches kernel spectra per (material, grid) in each process, so on
one rank, e.g., the ellipse and the rectangle of one b/a, or the ``tol`` values of an accuracy
study, build their kernels once. No chunk costs more than 1/(4·ranks) of the whole sweep, so
grouping never costs more balance than it saves. A slip scene's kernels depend on the pair's
equivalent body and the grid (n and the contact ellipse's b/a), not on the loads, the friction
coefficient or the loading path: its tasks group by pair, radii and grid.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
from typing import Any, Mapping

from .kinds import SLIP, quantity_names, scene_kind
from .spec import Spec, canonical_json
from .taskgrid import contact_grid, iteration_factor

# Fields that change a scene's outline or its solves but not its material or grid spacing:
# tasks differing only in these may share kernels (when their bounding boxes match).
KERNEL_NEUTRAL_FIELDS = (
    "shape", "sides", "amplitude", "shape_angle", "seed", "hurst", "rms", "mask",
    "tol", "quantities", "threads", "precondition",
)
# Fields of a slip scene that set its loading, not its kernels (hpcontact.slip: lengths are
# scaled by the Hertz radius, so the grid depends on n and b/a only, the kernel on nu_eq).
SLIP_KERNEL_NEUTRAL_FIELDS = (
    "load", "mu", "q_ratio", "angle", "steps", "control", "displacement", "path", "coupling",
    "tensor", "history", "tol", "quantities", "threads", "precondition",
)
# Relative number of operator solves per requested quantity (tangential: x and y loads).
SOLVES_PER_QUANTITY = {"tangential": 2.0, "normal": 1.0, "compliance": 0.1, "coupled": 3.0, "indentation": 3.0}
# Engine defaults used when a spec leaves them out; only ratios of costs matter.
DEFAULT_N = 128
DEFAULT_TOL = 1e-8
DEFAULT_QUANTITIES = ("tangential",)
CHUNKS_PER_RANK = 4
# A crystal scene (named material or A != 1): the tangential tensor comes from the coupled 3 x 3
# bonded punch (three solves, nine kernel blocks per operator application instead of four), and
# its kernels are integrated by quadrature (measured: ~10x an isotropic scene at n = 64).
CRYSTAL_TANGENTIAL_SOLVES = 3.0 * 9.0 / 4.0
CRYSTAL_FACTOR = 2.0
# A slip scene (hpcontact.slip): one Polonsky–Keer normal solve, then ~8 CG-sized solves per load
# step (semismooth Newton steps and the tangent tensor), on the padded grid of ±1.1 Hertz radii
# (≈ 1.1 n cells a side). A dissimilar pair solved coupled (Panagiotopoulos passes) costs ~3x
# the decoupled path, and "auto" runs both (measured ~4x a similar pair at n = 64).
SLIP_SOLVES_PER_STEP = 8.0
SLIP_TENSOR_SOLVES_PER_STEP = 2.0  # a step without tangential load: the 2 x 2 tangent tensor only
SLIP_GRID_MARGIN = 1.1
SLIP_COUPLED_FACTOR = 3.0
SLIP_DEFAULT_N = 64
SLIP_DEFAULT_STEPS = 10


@dataclass(frozen=True)
class Task:
    """One scene to solve: ``key`` (SHA-1 of its canonical JSON), ``params``, estimated ``cost``
    (arbitrary units, for ordering only) and kernel ``group``."""

    key: str
    params: Mapping[str, Any]
    cost: float
    group: str


def task_key(params: Mapping[str, Any]) -> str:
    """The key of the scene ``params``: SHA-1 (hex) of its canonical JSON."""
    return hashlib.sha1(canonical_json(params).encode("utf-8")).hexdigest()


def enumerate_tasks(spec: Spec) -> tuple[list[Task], dict[tuple[int, ...], str]]:
    """The distinct tasks of ``spec`` in first-appearance order (C order over the task axes),
    and the task key of every point (index tuple over ``spec.task_axes``)."""
    tasks: dict[str, Task] = {}
    where: dict[tuple[int, ...], str] = {}
    for index in spec.points():
        params = spec.scene_params(index)
        key = task_key(params)
        if key not in tasks:
            ignored = SLIP_KERNEL_NEUTRAL_FIELDS if spec.kind == SLIP else KERNEL_NEUTRAL_FIELDS
            neutral = {k: v for k, v in params.items() if k not in ignored}
            tasks[key] = Task(key=key, params=params, cost=estimated_cost(params), group=canonical_json(neutral))
        where[index] = key
    return list(tasks.values()), where


def estimated_cost(params: Mapping[str, Any]) -> float:
    """Relative cost of a scene: padded FFT size · log (per operator application) × solves ×
    digits of tolerance × the iteration factor of the grid's aspect in cells (CG iterations:
    ``taskgrid.iteration_factor``, 1 + 0.3 log2 ρ). The grid is ``taskgrid.contact_grid``'s
    (the rule of ``geometry.grid_for`` on the turned shape); crystal scenes cost more
    (``CRYSTAL_FACTOR``, coupled tangential solves); slip scenes see ``slip_cost``."""
    if scene_kind(params) == SLIP:
        return slip_cost(params)
    quantities = quantity_names(params.get("quantities", DEFAULT_QUANTITIES))
    size = padded_cells(params)
    crystal = params.get("material") is not None or float(params.get("anisotropy", 1.0)) != 1.0
    solves = sum(
        CRYSTAL_TANGENTIAL_SOLVES if crystal and q == "tangential" else SOLVES_PER_QUANTITY.get(q, 1.0)
        for q in quantities
    )
    if params.get("shape") == "rough":
        solves += 1.0  # the contact patch comes from a normal contact solve
    digits = max(1.0, -math.log10(float(params.get("tol", DEFAULT_TOL))))
    iterations = digits * iteration_factor(params)
    return size * math.log2(size) * max(solves, 0.1) * iterations * (CRYSTAL_FACTOR if crystal else 1.0)


def padded_cells(params: Mapping[str, Any]) -> float:
    """Cells of the scene's padded FFT grid (twice the contact grid each way): 4 nx × ny for a
    contact scene (``taskgrid.contact_grid``: the turned shape's bounding box, n × n for an
    indentation-only scene), (2 × 1.1 n)² for a slip scene."""
    if scene_kind(params) == SLIP:
        side = 2.0 * SLIP_GRID_MARGIN * int(params.get("n", SLIP_DEFAULT_N))
        return side * side
    nx, ny = contact_grid(params)
    return 4.0 * nx * ny


def slip_cost(params: Mapping[str, Any]) -> float:
    """Relative cost of a slip scene: padded FFT size · log × (1 + solves per step × steps ×
    passes) × digits of tolerance, on the n × n contact grid with its margin. A step under a
    tangential load (q_ratio > 0, or displacement control) costs ~8 CG-sized solves (semismooth
    Newton steps and the tangent tensor); without one (q_ratio = 0 under force control) only the
    tangent tensor's 2 (measured: 0.64 s against 2.5 s for q_ratio = 0.5, Cu crystal, n = 32);
    a loop path has 5 × steps steps. A dissimilar pair pays for its coupled path (3 passes; and
    the decoupled one with coupling auto/both); with ``normal_friction`` the normal load too is
    applied in ``steps`` coupled steps, so the coupled path's work doubles (measured iterations
    with/without: 3182/1614 … 4206/1733 for the orthotropic pairs of Rodríguez-Tembleque et al.
    2011). Same units as ``estimated_cost``; the Barnett–Lothe cost of anisotropic bodies is
    a per-task term of the cost model (``costmodel``)."""
    from ..bodies import pair_from_params

    size = padded_cells(params)
    steps = int(params.get("steps", SLIP_DEFAULT_STEPS)) * (5 if params.get("path") == "loop" else 1)
    loaded = float(params.get("q_ratio", 0.0)) > 0.0 or params.get("control") == "displacement"
    per_step = SLIP_SOLVES_PER_STEP if loaded else SLIP_TENSOR_SOLVES_PER_STEP
    tangential = per_step * steps if float(params.get("mu", 1.0)) > 0.0 else 0.0
    coupling = params.get("coupling", "auto")
    coupled = SLIP_COUPLED_FACTOR * (2.0 if params.get("normal_friction") else 1.0)
    if coupling == "decoupled" or pair_from_params(params).similar:
        passes = 1.0
    elif coupling == "coupled":
        passes = coupled
    else:
        passes = 1.0 + coupled
    digits = max(1.0, -math.log10(float(params.get("tol", DEFAULT_TOL))))
    return size * math.log2(size) * (1.0 + tangential * passes) * digits


def make_chunks(tasks: list[Task], ranks: int) -> list[tuple[Task, ...]]:
    """Tasks grouped by kernel and split at 1/(CHUNKS_PER_RANK·ranks) of the total cost; chunks
    in decreasing cost (ties: first appearance), the order the ranks take them in."""
    if not tasks:
        return []
    cap = sum(t.cost for t in tasks) / (CHUNKS_PER_RANK * ranks)
    groups: dict[str, list[Task]] = {}
    for task in tasks:
        groups.setdefault(task.group, []).append(task)
    chunks: list[tuple[Task, ...]] = []
    for members in groups.values():
        members = sorted(members, key=lambda t: -t.cost)
        current: list[Task] = []
        for task in members:
            if current and sum(t.cost for t in current) + task.cost > cap:
                chunks.append(tuple(current))
                current = []
            current.append(task)
        chunks.append(tuple(current))
    order = sorted(range(len(chunks)), key=lambda i: (-sum(t.cost for t in chunks[i]), i))
    return [chunks[i] for i in order]
