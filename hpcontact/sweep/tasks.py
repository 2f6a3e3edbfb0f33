"""Tasks of a sweep: the distinct scenes of the spec's parameter space, keyed, costed, chunked.

A task is one call of the task function (``accuracy.task_function``: ``hpcontact.problems.contact.solve`` on
one grid for a contact scene with ``n``; without ``n``, ``hpcontact solve``'s extrapolated
default over grids 16 … 256, ``accuracy.default_solve``, costed over every grid it solves:
``solved_grids``) on one scene. Points of the
parameter space whose scenes are equal (a circle on an aspect axis, the load angle in tensor
mode) share a task. A task's key is the SHA-1 of its canonical parameter JSON: it names the
scene itself, not its place in the spec, so ``--resume`` after an edit of the spec reuses exactly
the scenes that did not change and recomputes those that did (a changed ``tol``, say). The key of
a scene that reads a file (a mask) also hashes the file's content (``task_key``), so a file
replaced under the same path is computed again too, and ``changed_inputs`` says so.

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

import functools
import hashlib
import json
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple, TextIO

import numpy as np

from hpcontact.accuracy import DEFAULT_ACCURACY, default_grids
from hpcontact.geometry import file_sha256
from hpcontact.problems import footprint
from hpcontact.problems.footprint import iteration_factor
from hpcontact.problems.kinds import SLIP, quantity_names, scene_kind
from hpcontact.problems.slip.crystal_pair import pair_from_params
from hpcontact.scene import Scene
from hpcontact.sweep.spec import PATH_FIELDS, Spec, Validator, canonical_json, scene_texts

# Fields that change a scene's outline or its solves but not its material or grid spacing:
# tasks differing only in these may share kernels (when their bounding boxes match).
KERNEL_NEUTRAL_FIELDS = (
    "shape",
    "sides",
    "amplitude",
    "shape_angle",
    "seed",
    "hurst",
    "rms",
    "mask",
    "tol",
    "quantities",
    "threads",
    "precondition",
)
# Fields that do not change the grids ``accuracy.default_grids`` picks (it reads the shape, the
# quantities and whether the body is isotropic, not its constants or the solver's settings):
# left out of ``solved_grids``' cache key, so an axis over nu builds one Scene for its grids.
GRID_NEUTRAL_FIELDS = frozenset({"nu", "G", "tol", "threads", "precondition"})
# Fields that do not change a contact scene's estimated cost (it reads the grid, the solves, the
# tolerance and whether the body is a crystal: not an isotropic body's constants).
COST_NEUTRAL_FIELDS = frozenset({"nu", "G", "threads", "precondition"})
# Fields of a slip scene that set its loading, not its kernels (hpcontact.problems.slip.partial_slip: lengths are
# scaled by the Hertz radius, so the grid depends on n and b/a only, the kernel on nu_eq).
SLIP_KERNEL_NEUTRAL_FIELDS = (
    "load",
    "mu",
    "q_ratio",
    "angle",
    "steps",
    "control",
    "displacement",
    "path",
    "coupling",
    "tensor",
    "history",
    "tol",
    "quantities",
    "threads",
    "precondition",
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
# its kernels are integrated by quadrature (~10x an isotropic scene: docs/performance.md §"Task
# cost constants").
CRYSTAL_TANGENTIAL_SOLVES = 3.0 * 9.0 / 4.0
CRYSTAL_FACTOR = 2.0
# A slip scene (hpcontact.problems.slip.partial_slip): one Polonsky–Keer normal solve, then ~8 CG-sized solves per load
# step (semismooth Newton steps and the tangent tensor), on the padded grid of ±1.1 Hertz radii
# (≈ 1.1 n cells a side). A dissimilar pair solved coupled alternates normal and tangential
# solves (Panagiotopoulos passes) until they agree to the tolerance: the passes converge at the
# rate of the coupling size β, so a step takes digits / (−log10 β) of them, each at ~0.5 of a
# decoupled step's work (warm started; ``SLIP_PASS_WORK``, docs/performance.md §"Task cost
# constants").
SLIP_SOLVES_PER_STEP = 8.0
SLIP_TENSOR_SOLVES_PER_STEP = 2.0  # a step without tangential load: the 2 x 2 tangent tensor only
SLIP_PASS_WORK = 0.5
SLIP_DEFAULT_STEPS = 10
# A scene extrapolated by default (``solved_grids``) costs this many times the one-grid solves of
# its grids: coverage-weighted cells take 2-18 % more CG iterations and build their coverage,
# and every grid from the fourth on is extrapolated; default_solve took 1.27-1.60x the sum of
# solve() on its five grids (docs/performance.md §"Task cost constants").
EXTRAPOLATION_WORK = 1.4


class Task(NamedTuple):
    """One scene to solve: ``key`` (SHA-1 of its canonical JSON), ``params``, estimated ``cost``
    (arbitrary units, for ordering only) and kernel ``group``. A named tuple: every rank makes
    10^5 of them at start: a tuple is cheaper to make and to pickle than a frozen dataclass."""

    key: str
    params: Mapping[str, Any]
    cost: float
    group: str


def task_key(params: Mapping[str, Any], text: str | None = None) -> str:
    """The key of the scene ``params``: SHA-1 (hex) of its canonical JSON (``text``, when the
    caller has it) and, for a scene that reads input files (``spec.PATH_FIELDS``: a mask), of
    the SHA-256 of each file's content (``geometry.file_sha256``, cached per file and
    modification): a file replaced under the same path gives its tasks new keys, so
    ``--resume`` computes them again instead of reusing results of the old content."""
    text = canonical_json(params) if text is None else text
    files = {name: params[name] for name in PATH_FIELDS if params.get(name) is not None}
    if files:
        text += "\n" + canonical_json({name: file_sha256(path, name) for name, path in files.items()})
    return hashlib.sha1(text.encode("utf-8")).hexdigest()


def changed_inputs(tasks: Sequence[Task], entries: Mapping[str, Any]) -> str:
    """One line on the ``tasks`` that run again because an input file changed: tasks reading a
    file (``spec.PATH_FIELDS``) whose key has no entry in the journals (``entries``, by key:
    ``journal.Entry``) while an entry has the same parameters under another key (computed on
    other file content); "" when there are none."""
    readers = [t for t in tasks if t.key not in entries and any(t.params.get(n) is not None for n in PATH_FIELDS)]
    if not readers:
        return ""
    earlier = {
        canonical_json(e.params) for e in entries.values() if any(e.params.get(n) is not None for n in PATH_FIELDS)
    }
    changed = [t for t in readers if canonical_json(t.params) in earlier]
    if not changed:
        return ""
    files = sorted({f"{n} {t.params[n]}" for t in changed for n in PATH_FIELDS if t.params.get(n) is not None})
    shown = ", ".join(files[:3]) + (f", ... ({len(files)} files)" if len(files) > 3 else "")
    return f"{len(changed)} task(s) recomputed: their input file changed since the journals' run ({shown})"


@dataclass(frozen=True)
class Part:
    """The tasks of a range of points (``enumerate_part``): ``rows`` (key, params, cost, group)
    of the tasks in first-appearance order within the range, and ``task_of``, each point's row.
    Plain tuples and one string object per distinct group: cheap to send between ranks."""

    rows: list[tuple[str, dict[str, Any], float, str]]
    task_of: np.ndarray


def points(spec: Spec) -> int:
    """Number of points of the task axes."""
    return math.prod(len(a) for a in spec.task_axes)


def progress_lines(stream: TextIO, total: int, what: str = "points checked") -> Callable[[int], None]:
    """A ``progress`` callback for ``enumerate_part`` that prints one line per call on
    ``stream``: ``hpcontact: 300000 of 1000000 points checked (30 %, 9.1 s)`` (a call comes every
    ``spec.PROGRESS_POINTS`` points, so only long enumerations print)."""
    started = time.perf_counter()

    def report(done: int) -> None:
        print(
            f"hpcontact: {done} of {total} {what} ({100.0 * done / max(total, 1):.0f} %, "
            f"{time.perf_counter() - started:.1f} s)",
            file=stream,
            flush=True,
        )

    return report


def enumerate_part(
    spec: Spec,
    start: int = 0,
    stop: int | None = None,
    validate: Validator | None = None,
    check: bool = False,
    progress: Callable[[int], None] | None = None,
) -> Part:
    """The tasks of the points ``start`` … ``stop - 1`` (``spec.scene_texts``; with ``check``
    every distinct scene of the range validated first; ``progress`` sees the points done every
    ``spec.PROGRESS_POINTS``): each distinct scene once, its key, estimated cost and kernel
    group, each made once per distinct scene (points are told apart by their canonical JSON).
    Ranges are independent: the driver gives each rank one and joins them with ``join_parts``."""
    ignored = SLIP_KERNEL_NEUTRAL_FIELDS if spec.kind == SLIP else KERNEL_NEUTRAL_FIELDS
    rows: list[tuple[str, dict[str, Any], float, str]] = []
    row_of: dict[str, int] = {}
    groups: dict[str, str] = {}
    stop = points(spec) if stop is None else stop
    task_of = np.empty(max(stop - start, 0), dtype=np.intp)
    for i, (_, params, text) in enumerate(scene_texts(spec, validate, start, stop, check, progress)):
        at = row_of.get(text)
        if at is None:
            neutral = [k for k in params if k in ignored]
            group = canonical_json({k: v for k, v in params.items() if k not in ignored}) if neutral else text
            at = row_of[text] = len(rows)
            rows.append((task_key(params, text), params, estimated_cost(params), groups.setdefault(group, group)))
        task_of[i] = at
    return Part(rows, task_of)


def join_parts(spec: Spec, parts: Sequence[Part]) -> tuple[list[Task], np.ndarray]:
    """The tasks of consecutive ``parts`` covering every point, in first-appearance order (C
    order over the task axes), and the task (0-based position) of every point, an integer
    array shaped like the task axes."""
    position: dict[str, int] = {}
    groups: dict[str, str] = {}
    tasks: list[Task] = []
    joined = []
    for part in parts:
        local = np.empty(len(part.rows), dtype=np.intp)
        for j, (key, params, cost, group) in enumerate(part.rows):
            at = position.get(key)
            if at is None:
                at = position[key] = len(tasks)
                tasks.append(Task(key, params, cost, groups.setdefault(group, group)))
            local[j] = at
        joined.append(local[part.task_of])
    task_of = np.concatenate(joined) if joined else np.empty(0, dtype=np.intp)
    return tasks, task_of.reshape(tuple(len(a) for a in spec.task_axes))


def enumerate_tasks(
    spec: Spec, validate: Validator | None = None, check: bool = False, progress: Callable[[int], None] | None = None
) -> tuple[list[Task], dict[tuple[int, ...], str]]:
    """The distinct tasks of ``spec`` in first-appearance order (C order over the task axes),
    and the task key of every point (index tuple over ``spec.task_axes``); ``validate``,
    ``check`` and ``progress`` as for ``enumerate_part``."""
    tasks, task_of = join_parts(spec, [enumerate_part(spec, validate=validate, check=check, progress=progress)])
    return tasks, {index: tasks[task_of[index]].key for index in np.ndindex(task_of.shape)}


def solved_grids(params: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The one-grid scenes a task of ``params`` solves: ``[params]`` for a scene with ``n`` (or
    one that ``accuracy.extrapolates_by_default`` refuses, or a slip scene); for a contact scene
    without ``n`` that extrapolates by default (``accuracy.default_solve``, which the sweep's
    task function runs), one scene per grid of ``accuracy.default_grids`` (16 … 256 along the
    long side, five grids) with that grid's ``n``, ``n_across`` and the CG tolerance
    ``solve_to_accuracy`` uses (at most the default accuracy / 100). Cached per scene, the
    fields that do not change its grids (``GRID_NEUTRAL_FIELDS``) aside."""
    if scene_kind(params) == SLIP or params.get("n") is not None:
        return [params]
    grids = _default_grids(canonical_json({k: v for k, v in params.items() if k not in GRID_NEUTRAL_FIELDS}))
    if not grids:
        return [params]
    tol = max(min(float(params.get("tol", DEFAULT_TOL)), DEFAULT_ACCURACY * 1e-2), 1e-14)
    return [{**params, "n": n, "n_across": na, "tol": tol} for n, na in grids]


@functools.lru_cache(maxsize=4096)
def _default_grids(text: str) -> tuple[tuple[int, int], ...]:
    """(n, n_across) of every grid ``accuracy.default_solve`` solves the scene ``text``
    (canonical JSON, ``GRID_NEUTRAL_FIELDS`` left out) on; () when it solves one grid."""
    return tuple(default_grids(Scene.from_params(json.loads(text))))


def estimated_cost(params: Mapping[str, Any]) -> float:
    """Relative cost of a scene: padded FFT size · log (per operator application) × solves ×
    digits of tolerance × the iteration factor of the grid's aspect in cells (CG iterations:
    ``footprint.iteration_factor``, (1 + 0.3 log2 ρ) log2 S / 18). The grid is ``footprint.contact_grid``'s
    (the rule of ``geometry.grid_for`` on the turned shape); crystal scenes cost more
    (``CRYSTAL_FACTOR``, coupled tangential solves); slip scenes see ``slip_cost``. A contact
    scene without ``n`` that is extrapolated by default costs ``EXTRAPOLATION_WORK`` × the sum
    over the grids it solves (``solved_grids``). Cached per scene, the fields that do not
    change the cost (``COST_NEUTRAL_FIELDS``) aside, except for scenes reading a file (a mask:
    its grid is the file's)."""
    if scene_kind(params) == SLIP:
        return slip_cost(params)
    if any(params.get(name) is not None for name in PATH_FIELDS):
        return _contact_cost(params)
    return _cached_contact_cost(canonical_json({k: v for k, v in params.items() if k not in COST_NEUTRAL_FIELDS}))


@functools.lru_cache(maxsize=4096)
def _cached_contact_cost(text: str) -> float:
    """``_contact_cost`` of the scene ``text`` (canonical JSON)."""
    return _contact_cost(json.loads(text))


def _contact_cost(params: Mapping[str, Any]) -> float:
    """``estimated_cost`` of the contact scene ``params``."""
    levels = solved_grids(params)
    if len(levels) > 1:
        return EXTRAPOLATION_WORK * sum(_contact_cost(level) for level in levels)
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
    """Cells of the scene's padded FFT grid (``footprint.padded_cells``; for a scene extrapolated
    by default, the finest of ``solved_grids``)."""
    return footprint.padded_cells(solved_grids(params)[-1])


def slip_cost(params: Mapping[str, Any]) -> float:
    """Relative cost of a slip scene: padded FFT size · log × (1 + solves per step × steps ×
    passes) × digits of tolerance, on the n × n contact grid with its margin. A step under a
    tangential load (q_ratio > 0, or displacement control) costs ~8 CG-sized solves (semismooth
    Newton steps and the tangent tensor); without one (q_ratio = 0 under force control) only the
    tangent tensor's 2; a loop path has 5 × steps steps. A dissimilar pair pays for its coupled
    path (0.5 × digits / (−log10 β) decoupled steps per step, β the pair's coupling size:
    ``SLIP_PASS_WORK``; and the decoupled one with coupling auto/both); with ``normal_friction``
    the normal load too is applied in ``steps`` coupled steps, so the coupled path's work
    doubles. The counts behind these factors: docs/performance.md §"Task cost constants".
    Same units as ``estimated_cost``; the Barnett–Lothe cost of anisotropic bodies is
    a per-task term of the cost model (``costmodel``)."""
    size = padded_cells(params)
    steps = int(params.get("steps", SLIP_DEFAULT_STEPS)) * (5 if params.get("path") == "loop" else 1)
    loaded = float(params.get("q_ratio", 0.0)) > 0.0 or params.get("control") == "displacement"
    per_step = SLIP_SOLVES_PER_STEP if loaded else SLIP_TENSOR_SOLVES_PER_STEP
    tangential = per_step * steps if float(params.get("mu", 1.0)) > 0.0 else 0.0
    coupling = params.get("coupling", "auto")
    digits = max(1.0, -math.log10(float(params.get("tol", DEFAULT_TOL))))
    pair = pair_from_params(params) if coupling != "decoupled" else None
    if pair is None or pair.similar:
        passes = 1.0
    else:
        beta = min(getattr(pair, "coupling_size", None) or abs(pair.dundurs_beta), 0.9)
        coupled = max(1.0, SLIP_PASS_WORK * digits / -math.log10(beta))
        coupled *= 2.0 if params.get("normal_friction") else 1.0
        passes = coupled if coupling == "coupled" else 1.0 + coupled
    return size * math.log2(size) * (1.0 + tangential * passes) * digits


def make_chunks(tasks: list[Task], ranks: int) -> list[tuple[Task, ...]]:
    """Tasks grouped by kernel and split at 1/(CHUNKS_PER_RANK·ranks) of the total cost; chunks
    in decreasing cost (ties: first appearance), the order the ranks take them in. Within a
    group (groups in first-appearance order) tasks go largest first (ties: first appearance)
    and a chunk closes before the task that would take it over the cap."""
    if not tasks:
        return []
    cap = sum(t.cost for t in tasks) / (CHUNKS_PER_RANK * ranks)
    ids: dict[str, int] = {}
    group = [ids.setdefault(t.group, len(ids)) for t in tasks]
    order = np.lexsort((-np.array([t.cost for t in tasks], dtype=np.float64), np.array(group)))  # stable
    chunks: list[tuple[Task, ...]] = []
    costs: list[float] = []
    current: list[Task] = []
    total, last = 0.0, -1
    for i in order.tolist():
        task = tasks[i]
        if current and (group[i] != last or total + task.cost > cap):
            chunks.append(tuple(current))
            costs.append(total)
            current, total = [], 0.0
        current.append(task)
        total += task.cost
        last = group[i]
    chunks.append(tuple(current))
    costs.append(total)
    return [chunks[i] for i in np.argsort(-np.array(costs), kind="stable").tolist()]
