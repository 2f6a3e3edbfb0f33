"""Tasks of a sweep: the distinct scenes of the spec's parameter space, keyed, costed, chunked.

A task is one call of the task function (``accuracy.task_function``: ``hpcontact.problems.contact.solve`` on
one grid for a contact scene with ``n``; without ``n``, ``hpcontact solve``'s extrapolated
default over grids 16 … 256, ``accuracy.default_solve``, costed over every grid it solves:
``solved_grids``; with an ``accuracy``, ``solve_to_accuracy`` with strategy auto, costed over
the grids it is predicted to solve with their boundary cells: ``accuracy_plan``, ``Work``) on
one scene. Points of the
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

Enumeration goes by the spec's runs (``spec.scene_runs``): the points of a long last axis of a
number differ in that field alone, so a run's canonical JSON, kernel group and cost key are
written around the value once, and its cost is computed once when the field does not change
it (``COST_NEUTRAL_FIELDS``, ``COST_BRANCH_FIELDS``) or once per distinct grid when it changes
the grid alone (``GRID_ONLY_FIELDS``); each task carries the sizes the cost model reads
(``Sizing``), so the dry run estimates 10^6 tasks without looking at their parameters again.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import hashlib
import json
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, NamedTuple, TextIO

import numpy as np

from hpcontact.accuracy import (
    DEFAULT_ACCURACY,
    MAX_CELLS,
    MIN_GRIDS,
    default_grids,
    first_grid,
    grid_bytes,
    plan_grids,
)
from hpcontact.discretizations import strip_cells
from hpcontact.geometry import file_sha256
from hpcontact.problems import footprint
from hpcontact.problems.footprint import iteration_factor, task_kind
from hpcontact.problems.kinds import CONTACT, SLIP, quantity_names, scene_kind
from hpcontact.problems.slip.crystal_pair import pair_from_params
from hpcontact.scene import Scene
from hpcontact.sweep.spec import (
    PATH_FIELDS,
    Run,
    Spec,
    Validator,
    canonical_json,
    run_field,
    scene_runs,
    text_template,
)

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
    "normal_held",
)
# Fields that do not change the grids ``accuracy.default_grids`` picks (it reads the shape, the
# quantities and whether the body is isotropic, not its constants or the solver's settings):
# left out of ``solved_grids``' cache key, so an axis over nu builds one Scene for its grids.
GRID_NEUTRAL_FIELDS = frozenset(
    {"nu", "G", "tol", "threads", "precondition", "orientation", "miller", "azimuth", "normal_held"}
)
# Fields that do not change a contact scene's estimated cost (it reads the grid, the solves, the
# tolerance and whether the body is a crystal: not an isotropic body's constants, nor how a
# crystal is oriented).
COST_NEUTRAL_FIELDS = frozenset({"nu", "G", "threads", "precondition", "orientation", "miller", "azimuth"})
# Fields that change a contact scene's cost, grid and memory only where they cross these values
# (A = 1: an isotropic body, else a crystal): a run away from them has one cost.
COST_BRANCH_FIELDS: Mapping[str, tuple[float, ...]] = {"anisotropy": (1.0,)}
# Fields that change a contact scene with ``n`` (one grid) only through its contact grid
# (``footprint.contact_grid``: the cost reads the padded cells and the grid's iteration factor):
# a run over one of them is costed once per distinct grid.
GRID_ONLY_FIELDS = frozenset(footprint.GRID_FIELDS) - {"quantities"}
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
# A task that asks for an accuracy (``accuracy.default_solve`` of a scene with ``accuracy``:
# ``solve_to_accuracy(scene, accuracy, strategy="auto")``) is costed over the grids it is
# predicted to solve (``accuracy_levels``), each a one-grid scene tagged with its boundary cells
# under ``BOUNDARY_TAG`` ("galin", "coverage" or "strip": never a scene field, ``level_fields``
# drops it). An ellipse or circle takes its one exact cell (galin: no grid, one task term); the
# singular cells and the ellipses' strips that ``auto`` took before are no longer reached by it.
# The evidence behind every constant below: docs/performance.md §"Accuracy tasks".
BOUNDARY_TAG = "boundary"
# Where the sequence stops (``predicted_grid_count``): coverage-weighted cells met every request
# of 1e-3 on ``MIN_GRIDS`` grids (20 scene types of the demo, isotropic and cubic) and took one
# more grid per full decade below it (the most frequent count at 1e-4 and 1e-5); strips met every request down to
# ``STRIP_FOUR_GRIDS_TO`` on four grids (or stop there on their own bound, ``strip_cells.model_error``).
COVERAGE_FOUR_GRIDS_TO = 1e-3
STRIP_FOUR_GRIDS_TO = 1e-7
# Below 1e-3 the count of coverage-weighted cells is the most frequent one, not the only one: 2 of
# 12 requests of 1e-4 took a grid more, 2 one fewer; 3 of 8 of 1e-5 one fewer. A grid costs 4-5
# times the one before, so the time counts ``ONE_MORE_SHARE`` of the next planned grid and takes
# off ``ONE_FEWER_SHARE`` of the last predicted one (beyond ``MIN_GRIDS``): the expected time of
# many such tasks, not the time of the most frequent count (``accuracy_work``).
ONE_MORE_SHARE = 0.2
ONE_FEWER_SHARE = 0.25
# A grid of coverage-weighted cells costs the one-grid FFT model of that grid (every
# term of ``costmodel``, the contact kind's rates: ``level_work``) times a factor: isotropic
# coverage-weighted cells ``COVERAGE_WORK`` × (1 + ``COVERAGE_ASPECT_WORK`` log2 ρ), ρ the grid's
# aspect in cells (coverage, damping and preconditioner weights; their CG iterations grow faster
# with ρ than the one-grid model's); a crystal's ``CRYSTAL_COVERAGE_WORK``. An outline that is
# not an ellipse, circle or rectangle (polygons, stars, masks) builds its coverage by clipping:
# ``OUTLINE_COVERAGE_WORK`` cost units per cell along both sides and grid.
COVERAGE_WORK = 1.05
COVERAGE_ASPECT_WORK = 0.37
CRYSTAL_COVERAGE_WORK = 0.9
OUTLINE_COVERAGE_WORK = 2.1e5
ANALYTIC_OUTLINES = ("circle", "ellipse", "rectangle")
# Strip cells (``strip_cells``: dense Galerkin integrals, then Cholesky; ``auto`` takes them for
# slender rectangles only, b/a ≤ ``strip_cells.MAX_ASPECT``: ellipses take their exact cell) cost,
# per grid of n strips (``strip_units``), ``STRIP_SECONDS_PER_FAR_PAIR`` per far pair (Gauss
# product rule on the moment series) and ``STRIP_SECONDS_PER_STRIP`` per strip: CPU seconds on the
# development machine (fitted to two runs, 77 and 80 grids, rectangles b/a 1e-6 … 1e-12 on
# 32 … 1024 strips among them), counted in units of ``STRIP_UNIT_SECONDS`` (its contact rate_s,
# so that a strip unit weighs as an FFT grid's cost unit in a task's cost); ``costmodel``
# calibrates the seconds of a strip unit on each host (``Rate.strip_s``).
STRIP_UNIT_SECONDS = 2.4e-9
STRIP_SECONDS_PER_FAR_PAIR = 2.6e-6
STRIP_SECONDS_PER_STRIP = 1.9e-4


class Work(NamedTuple):
    """The work of an accuracy task summed over its predicted grids (``accuracy_work``), one
    number per term of the cost model's seconds (``costmodel.Rate``): ``fft`` cost units
    (× rate_s), ``solves`` solve units (× solve_s), ``cells`` padded cells whose kernels are built
    (× cell_s), ``grids`` (× task_s), ``strips`` strip units (× strip_s) and ``exact`` crystal
    exact cells whose kernel is built (× exact_s); the FFT terms of a grid carry its boundary
    cells' factor."""

    fft: float
    solves: float
    cells: float
    grids: float
    strips: float
    exact: float


class Sizing(NamedTuple):
    """What the cost model reads of a task besides its cost (``sizing``): the calibration
    ``kind`` (``footprint.task_kind``), the padded ``cells`` of the finest grid it solves
    (``padded_cells``) and that grid's ``array_bytes`` (``footprint.array_bytes``). Few distinct
    values in a sweep: tasks share one object per value. A task that asks for an accuracy also
    has its ``work`` (``Work``: its seconds are those terms, not the cost's) and the ``label``
    the dry run lists its grids under; its ``array_bytes`` are ``accuracy.grid_bytes`` of its
    finest predicted grid with its boundary cells."""

    kind: str
    cells: float
    array_bytes: float
    work: Work | None = None
    label: str | None = None


class Task(NamedTuple):
    """One scene to solve: ``key`` (SHA-1 of its canonical JSON), ``params``, estimated ``cost``
    (arbitrary units, for ordering only), kernel ``group`` and ``sizing`` (``Sizing``; None:
    the cost model computes it from ``params``). A named tuple: every rank makes 10^5 of them at
    start: a tuple is cheaper to make and to pickle than a frozen dataclass."""

    key: str
    params: Mapping[str, Any]
    cost: float
    group: str
    sizing: Sizing | None = None


_task = functools.partial(tuple.__new__, Task)  # Task from a 5-tuple, without NamedTuple's Python __new__


def task_key(params: Mapping[str, Any], text: str | None = None) -> str:
    """The key of the scene ``params``: SHA-1 (hex) of its canonical JSON (``text``, when the
    caller has it) and, for a scene that reads input files (``spec.PATH_FIELDS``: a mask), of
    the SHA-256 of each file's content (``geometry.file_sha256``, cached per file and
    modification): a file replaced under the same path gives its tasks new keys, so
    ``--resume`` computes them again instead of reusing results of the old content."""
    text = canonical_json(params) if text is None else text
    for name in PATH_FIELDS:  # one field: a loop costs less than building an empty dict per task
        if params.get(name) is not None:
            files = {name: params[name] for name in PATH_FIELDS if params.get(name) is not None}
            text += "\n" + canonical_json({name: file_sha256(path, name) for name, path in files.items()})
            break
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
    """The tasks of a range of points (``enumerate_part``): ``rows``, the ``Task`` of each
    distinct scene in first-appearance order within the range, and ``task_of``, each point's
    row. Tuples, one string object per distinct group and one ``Sizing`` per distinct value:
    cheap to send between ranks."""

    rows: list[Task]
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
    lean: bool = False,
) -> Part:
    """The tasks of the points ``start`` … ``stop - 1`` (``spec.scene_runs``; with ``check``
    every distinct scene of the range validated first, a long run of an interval field at its
    extreme values; ``progress`` sees the points done every ``spec.PROGRESS_POINTS``): each
    distinct scene once, its key, estimated cost, kernel group and sizing, each made once per
    distinct scene (points are told apart by their canonical JSON; along a run by the value of
    its field). Ranges are independent: the driver gives each rank one and joins them with
    ``join_parts``. ``lean``: the parameters of a run's tasks are ``RunScene`` mappings, not
    dicts (a dry run's 10^6 tasks in ~0.35 GB less; nothing it does needs a dict of each)."""
    stop = points(spec) if stop is None else stop
    task_of = np.empty(max(stop - start, 0), dtype=np.intp)
    table = _Table(spec, lean)
    with paused_gc():
        for run in scene_runs(spec, validate, start, stop, check, progress):
            task_of[run.start - start : run.stop - start] = table.rows_of(run)
    return Part(table.rows, task_of)


@contextlib.contextmanager
def paused_gc() -> Iterator[None]:
    """The cyclic garbage collector off while a sweep's tasks are made or estimated: they are
    dicts, tuples and strings without cycles, and 10^6 tasks are ~3·10^6 tracked objects that
    every full collection would traverse again as they pile up (a third of the time of a 10^6
    task dry run). Anything cyclic made meanwhile is collected once it is back on."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


class _Family:
    """Rows of scenes that differ in the run field alone (one text around its value):
    ``segments`` of consecutive new rows (their values and the row of the first), looked up
    by the values' float64 bits (equal bits, equal repr) with numpy while every value is a
    float, else by a dict of the values' reprs (``rows``, made once needed)."""

    __slots__ = ("segments", "rows")

    def __init__(self) -> None:
        self.segments: list[list[Any]] = []  # [values, first row, sorted bits or None, their order]
        self.rows: dict[str, int] | None = None

    def add(self, values: Sequence[Any], first: int) -> None:
        """Rows ``first``, ``first + 1``, … hold the scenes of ``values``."""
        if self.rows is None:
            self.segments.append([values, first, None, None])
        else:
            for j, value in enumerate(values):
                self.rows.setdefault(repr(value), first + j)

    def find(self, values: Sequence[Any]) -> np.ndarray:
        """The row of each of ``values`` (-1: no row yet)."""
        found = np.full(len(values), -1, dtype=np.intp)
        bits = _float_bits(values)
        if self.rows is None and bits is not None:
            for segment in self.segments:
                if segment[2] is None:
                    held = _float_bits(segment[0])
                    if held is None:
                        break
                    segment[3] = np.argsort(held, kind="stable")
                    segment[2] = held[segment[3]]
                held, order = segment[2], segment[3]
                at = np.minimum(np.searchsorted(held, bits), len(held) - 1)
                hit = (held[at] == bits) & (found < 0)
                found[hit] = segment[1] + order[at[hit]]
            else:
                return found
        if self.rows is None:
            self.rows = {}
            for values_held, first, _, _ in self.segments:
                for j, value in enumerate(values_held):
                    self.rows.setdefault(repr(value), first + j)
            self.segments = []
        get = self.rows.get
        for j, value in enumerate(values):
            found[j] = get(repr(value), -1)
        return found


def _float_bits(values: Sequence[Any]) -> np.ndarray | None:
    """The float64 bit patterns of ``values`` when every one is a float, else None."""
    if not values or set(map(type, values)) != {float}:
        return None
    return np.array(values, dtype=np.float64).view(np.int64)


class RunScene(Mapping):
    """The parameters of one point of a run (``spec.Run``): the run's parameters with its field
    set to ``value``, read through (~60 B, where a dict of them takes ~270 B); ``dict(...)``
    gives the dict, in the same key order (``enumerate_part(lean=True)``)."""

    __slots__ = ("base", "name", "value")

    def __init__(self, base: dict[str, Any], name: str, value: Any) -> None:
        self.base, self.name, self.value = base, name, value

    def __getitem__(self, key: str) -> Any:
        return self.value if key == self.name else self.base[key]

    def get(self, key: str, default: Any = None) -> Any:
        return self.value if key == self.name else self.base.get(key, default)

    def __contains__(self, key: object) -> bool:
        return key in self.base

    def __iter__(self) -> Iterator[str]:
        return iter(self.base)

    def __len__(self) -> int:
        return len(self.base)

    def __repr__(self) -> str:
        return repr(self.as_dict())

    def as_dict(self) -> dict[str, Any]:
        """The parameters as a dict (``dict(self)`` without a call per key)."""
        params = self.base.copy()
        params[self.name] = self.value
        return params


class _Table:
    """The distinct scenes of a range and their tasks (``enumerate_part``): scenes without the
    spec's run field by canonical JSON (``texts``), scenes with it by the text around its value
    and the value (``families``), so a run of new scenes needs no lookup per point."""

    def __init__(self, spec: Spec, lean: bool = False) -> None:
        self.lean = lean
        self.field = run_field(spec)
        self.ignored = SLIP_KERNEL_NEUTRAL_FIELDS if spec.kind == SLIP else KERNEL_NEUTRAL_FIELDS
        self.rows: list[Task] = []
        self.texts: dict[str, int] = {}
        self.families: dict[tuple[str, str], _Family] = {}
        self.groups: dict[str, str] = {}

    def rows_of(self, run: Run) -> int | np.ndarray:
        """The row of every point of ``run`` (one row for a run without a field): new scenes
        made by ``_new_rows``, those seen before (an earlier run of the same family: the same
        fields but this one) found by ``_Family.find``."""
        if run.name is None:
            return self.scene(run.params, run.text)
        family = self.families.get((run.text, run.suffix))
        if family is None:
            family = self.families[(run.text, run.suffix)] = _Family()
            found = None
        else:
            found = family.find(run.values)
            if (found >= 0).all():
                return found
        values = run.values if found is None else [run.values[j] for j in np.flatnonzero(found < 0).tolist()]
        reprs = list(map(repr, values))
        # coordinates of an axis are distinct; angles subtracted from a turned shape's may not be
        if run.name == "shape_angle" and len(set(reprs)) != len(reprs):
            rows = np.empty(len(reprs), dtype=np.intp)
            first, made, kept = len(self.rows), {}, []
            for j, (value, r) in enumerate(zip(values, reprs)):
                held = made.get(r)
                if held is None:
                    held = made[r] = self._row({**run.params, run.name: value}, run.text + r + run.suffix)
                    kept.append(value)
                rows[j] = held
            family.add(kept, first)
        else:
            first = len(self.rows)
            self._new_rows(replace(run, values=values), reprs)
            family.add(values, first)
            rows = np.arange(first, len(self.rows), dtype=np.intp)
        if found is None:
            return rows
        found[found < 0] = rows
        return found

    def scene(self, params: dict[str, Any], text: str) -> int:
        """The row of the scene ``params`` (canonical JSON ``text``), made if new."""
        value = params.get(self.field) if self.field is not None else None
        template = None
        if type(value) in (float, int) and math.isfinite(value):
            template = text_template(params, self.field)
        if template is None:
            at = self.texts.get(text)
            if at is None:
                at = self.texts[text] = self._row(params, text)
            return at
        family = self.families.get(template)
        if family is None:
            family = self.families[template] = _Family()
        at = int(family.find([value])[0])
        if at < 0:
            at = self._row(params, text)
            family.add([value], at)
        return at

    def _row(self, params: dict[str, Any], text: str) -> int:
        """A new row for the scene ``params`` (canonical JSON ``text``): its position."""
        ignored = self.ignored
        neutral = any(k in ignored for k in params)
        group = canonical_json({k: v for k, v in params.items() if k not in ignored}) if neutral else text
        cost, size = costed(params)
        self.rows.append(_task((task_key(params, text), params, cost, self.groups.setdefault(group, group), size)))
        return len(self.rows) - 1

    def _new_rows(self, run: Run, reprs: list[str]) -> None:
        """Rows for every point of ``run`` (all new scenes; ``reprs``: its values' reprs): the
        text and the group written around each value, the cost and sizing made once per run or
        per grid where the field allows it (``_coster``); one loop, no call per row but the
        key's and those the run needs."""
        name, base, prefix, suffix = run.name, run.params, run.text, run.suffix
        cost_of, cost_once = self._coster(run), None
        group_once, group_around, group_of = self._grouper(run)
        groups, append, key_of, new, lean = self.groups, self.rows.append, task_key, _task, self.lean
        for value, r in zip(run.values, reprs):
            text = prefix + r + suffix
            if lean:
                params = RunScene(base, name, value)
            else:
                params = base.copy()  # the field keeps its place among the keys
                params[name] = value
            if cost_of is not None:
                cost_once = cost_of(params)
            elif cost_once is None:
                cost_once = costed(params.as_dict() if lean else params)
            if group_once is not None:
                group = group_once
            elif group_around is not None:  # one per value: nothing to share (an index of them: 50 MB per 10^6)
                group = group_around[0] + r + group_around[1]
            elif group_of is not None:
                group = group_of(params)
                group = groups.setdefault(group, group)
            else:
                group = text
            append(new((key_of(params, text), params, cost_once[0], group, cost_once[1])))

    def _coster(self, run: Run) -> Callable[[dict[str, Any]], tuple[float, Sizing]] | None:
        """How ``_new_rows`` costs the scenes of ``run`` (``costed``): None, once from its first
        scene, when its field does not change the cost (``COST_NEUTRAL_FIELDS``, or a
        ``COST_BRANCH_FIELDS`` run away from its branch values); else a function of the scene:
        once per distinct contact grid when the field changes the grid alone
        (``GRID_ONLY_FIELDS`` with ``n`` given), else ``costed`` (cached by the cost key)."""
        name, base = run.name, run.params
        each = (lambda params: costed(params.as_dict())) if self.lean else costed  # a dict for every cost function
        if scene_kind(base) != CONTACT or any(base.get(n) is not None for n in PATH_FIELDS):
            return each
        branches = COST_BRANCH_FIELDS.get(name)
        if name in COST_NEUTRAL_FIELDS or (branches is not None and not any(v in branches for v in run.values)):
            return None
        if name in GRID_ONLY_FIELDS and base.get("n") is not None and base.get("accuracy") is None:
            by_grid: dict[tuple[int, int], tuple[float, Sizing]] = {}

            def per_grid(params: dict[str, Any] | RunScene) -> tuple[float, Sizing]:
                if type(params) is RunScene:
                    params = params.as_dict()
                grid = footprint.contact_grid(params)
                got = by_grid.get(grid)
                if got is None:
                    got = by_grid[grid] = costed(params)
                return got

            return per_grid
        return each

    def _grouper(self, run: Run) -> tuple[str | None, tuple[str, str] | None, Callable[[dict[str, Any]], str] | None]:
        """How ``_new_rows`` writes the kernel group of a scene of ``run`` (the canonical JSON of
        its fields that are not kernel-neutral; its text when all are): (group, None, None) one
        group for the run (its field is neutral); (None, (prefix, suffix), None) written around
        the value; (None, None, f) f of the scene's parameters; (None, None, None) the text."""
        ignored, name = self.ignored, run.name
        if not any(k in ignored for k in run.params):
            return None, None, None
        kept = {k: v for k, v in run.params.items() if k not in ignored}
        if name in ignored:
            group = canonical_json(kept)
            return self.groups.setdefault(group, group), None, None
        template = text_template(kept, name)
        if template is None:
            return None, None, lambda params: canonical_json({k: v for k, v in params.items() if k not in ignored})
        return None, template, None


def join_parts(spec: Spec, parts: Sequence[Part]) -> tuple[list[Task], np.ndarray]:
    """The tasks of consecutive ``parts`` covering every point, in first-appearance order (C
    order over the task axes), and the task (0-based position) of every point, an integer
    array shaped like the task axes. One part's rows are its tasks as they are (distinct
    scenes); more parts are joined by key."""
    shape = tuple(len(a) for a in spec.task_axes)
    if len(parts) == 1:
        return list(parts[0].rows), parts[0].task_of.reshape(shape)
    with paused_gc():
        tasks, joined = _joined_rows(parts)
    task_of = np.concatenate(joined) if joined else np.empty(0, dtype=np.intp)
    return tasks, task_of.reshape(shape)


def _joined_rows(parts: Sequence[Part]) -> tuple[list[Task], list[np.ndarray]]:
    """``join_parts`` of several parts: the tasks by key, and each part's points' tasks."""
    position: dict[str, int] = {}
    groups: dict[str, str] = {}
    tasks: list[Task] = []
    joined = []
    for part in parts:
        local = np.empty(len(part.rows), dtype=np.intp)
        for j, row in enumerate(part.rows):
            at = position.get(row[0])
            if at is None:
                at = position[row[0]] = len(tasks)
                key, params, cost, group, *size = row
                tasks.append(Task(key, params, cost, groups.setdefault(group, group), *size))
            local[j] = at
        joined.append(local[part.task_of])
    return tasks, joined


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
    that asks for an accuracy, the grids it is predicted to solve (``accuracy_levels``, each
    tagged with its boundary cells); for a contact scene
    without ``n`` that extrapolates by default (``accuracy.default_solve``, which the sweep's
    task function runs), one scene per grid of ``accuracy.default_grids`` (16 … 256 along the
    long side, five grids) with that grid's ``n``, ``n_across`` and the CG tolerance
    ``solve_to_accuracy`` uses (at most the default accuracy / 100). Cached per scene, the
    fields that do not change its grids (``GRID_NEUTRAL_FIELDS``) aside."""
    if scene_kind(params) == SLIP:
        return [params]
    if params.get("accuracy") is not None:  # before n: solve_to_accuracy ignores the scene's grid
        return accuracy_levels(params)
    if params.get("n") is not None:
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


def asks_accuracy(params: Mapping[str, Any]) -> bool:
    """Whether ``params`` is a contact scene that asks for an accuracy (a sweep's ``[numerics]
    accuracy``, ``hpcontact run --accuracy``): ``accuracy.default_solve`` solves it as
    ``hpcontact solve --accuracy`` does."""
    return params.get("accuracy") is not None and scene_kind(params) != SLIP


class AccuracyPlan(NamedTuple):
    """What ``solve_to_accuracy(scene, accuracy, strategy="auto")`` is predicted to do
    (``accuracy_plan``): its boundary cells (``strategy``), the grids (n, n_across) it solves,
    how many grids it could have planned (``planned``), the planned grid after the last one
    predicted (``next_grid``, None at the end of the plan) and the peak bytes of its finest
    grid's arrays (``accuracy.grid_bytes``)."""

    strategy: str
    grids: tuple[tuple[int, int], ...]
    planned: int
    next_grid: tuple[int, int] | None
    finest_bytes: float


def predicted_grid_count(strategy: str, accuracy: float, planned: int, model_error: float = 0.0) -> int:
    """How many of its ``planned`` grids ``solve_to_accuracy`` is predicted to solve at
    ``accuracy`` with ``strategy``'s cells (docs/performance.md §"Accuracy tasks"): coverage-weighted
    cells ``MIN_GRIDS`` at requests ≥ ``COVERAGE_FOUR_GRIDS_TO`` (1e-3) and one more per full
    decade below (1e-4: 5, 1e-5: 6); strips ``MIN_GRIDS`` down to
    ``STRIP_FOUR_GRIDS_TO`` or where their own bound ``model_error`` is not below the request
    (``solve_to_accuracy`` stops there), every planned grid below. Never more than planned."""
    if strategy == "strip":
        count = MIN_GRIDS if accuracy >= STRIP_FOUR_GRIDS_TO or model_error >= accuracy else planned
    else:  # the 1e-9 keeps 1e-4 at one decade whatever the rounding of the quotient
        count = MIN_GRIDS + max(0, math.floor(math.log10(COVERAGE_FOUR_GRIDS_TO / accuracy) + 1e-9))
    return max(1, min(count, planned))


def accuracy_plan(params: Mapping[str, Any]) -> AccuracyPlan:
    """The ``AccuracyPlan`` of the contact scene ``params`` with ``accuracy``: the boundary cells
    and first grid of ``accuracy.first_grid``, the grids of ``accuracy.plan_grids`` (at most
    ``accuracy.MAX_CELLS`` cells, within the estimator's calibrated range; no memory budget, so
    that the estimate never depends on this process's resident set: a finest grid over a rank's
    memory shows in the task's memory, which ``--mem-per-rank`` checks), the first
    ``predicted_grid_count`` of them (a plan of no grid: its first one). Cached per scene, the
    fields that do not change its grids (``GRID_NEUTRAL_FIELDS``) aside."""
    return _accuracy_plan(canonical_json({k: v for k, v in params.items() if k not in GRID_NEUTRAL_FIELDS}))


@functools.lru_cache(maxsize=4096)
def _accuracy_plan(text: str) -> AccuracyPlan:
    """``accuracy_plan`` of the scene ``text`` (canonical JSON, ``GRID_NEUTRAL_FIELDS`` left out)."""
    scene = Scene.from_params(json.loads(text))
    accuracy = float(scene.accuracy)
    strategy, n0, n_across0 = first_grid(scene, "auto", accuracy=accuracy)
    if strategy == "galin":  # one exact cell: the kernel's tables, no grid
        return AccuracyPlan(strategy, ((1, 1),), 1, None, footprint.tables_bytes(scene.params))
    plan = plan_grids(scene, n0, n_across0, MAX_CELLS, math.inf, strategy)
    model = strip_cells.model_error(scene.shape) if strategy == "strip" else 0.0
    count = predicted_grid_count(strategy, accuracy, len(plan.grids), model)
    grids = tuple(plan.grids[:count]) or (plan.next_grid,)
    following = tuple(plan.grids[count]) if count < len(plan.grids) else None
    return AccuracyPlan(strategy, grids, len(plan.grids), following, grid_bytes(scene, *grids[-1], strategy))


def accuracy_levels(params: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The one-grid scenes of the accuracy task ``params`` (``accuracy_plan``): ``params``
    without ``accuracy``, with each grid's ``n``, ``n_across``, the CG tolerance
    ``solve_to_accuracy`` uses (at most accuracy / 100) and ``BOUNDARY_TAG`` the grid's
    boundary cells (``level_fields`` gives the scene's fields without it)."""
    plan = accuracy_plan(params)
    tol = max(min(float(params.get("tol", DEFAULT_TOL)), float(params["accuracy"]) * 1e-2), 1e-14)
    fields = {k: v for k, v in params.items() if k not in ("accuracy", BOUNDARY_TAG)}
    if plan.strategy == "galin":  # one exact cell, on no grid: the scene's own n stays (unused)
        return [{**fields, BOUNDARY_TAG: plan.strategy}]
    return [{**fields, "n": n, "n_across": na, "tol": tol, BOUNDARY_TAG: plan.strategy} for n, na in plan.grids]


def level_fields(level: Mapping[str, Any]) -> dict[str, Any]:
    """The scene fields of a level of ``accuracy_levels`` (its ``BOUNDARY_TAG`` dropped): what
    ``Scene.from_params`` accepts."""
    return {k: v for k, v in level.items() if k != BOUNDARY_TAG}


def strip_pairs(shape: str, aspect: float, n: int) -> tuple[int, int]:
    """(near, far) pairs i ≤ j of n strips of an unturned ``shape`` (rectangle, ellipse) of
    ``aspect``: the split of ``strip_cells.galerkin_integrals`` (near: closer than
    ``NEAR_GAP`` strip lengths or ``SERIES_REACH`` half-widths). Cached."""
    return _strip_pairs(str(shape), float(aspect), int(n))


@functools.lru_cache(maxsize=1024)
def _strip_pairs(shape: str, aspect: float, n: int) -> tuple[int, int]:
    outline = strip_cells.Outline(shape, aspect)
    edges = strip_cells.graded_edges(n)
    lo, hi = edges[:-1], edges[1:]
    size = hi - lo
    i, j = np.triu_indices(n)
    gap = np.maximum(np.maximum(lo[j] - hi[i], lo[i] - hi[j]), 0.0)
    widest = np.maximum(outline.widest(lo[i], hi[i]), outline.widest(lo[j], hi[j]))
    near = int(
        np.count_nonzero(
            (gap < strip_cells.NEAR_GAP * np.maximum(size[i], size[j])) | (gap < strip_cells.SERIES_REACH * widest)
        )
    )
    return near, int(i.size) - near


def strip_units(level: Mapping[str, Any]) -> float:
    """Strip units (``STRIP_UNIT_SECONDS`` each on the development machine) of one grid of strip
    cells of a rectangle, the level ``level`` (n strips): its far pairs (``strip_pairs``) and
    strips at their seconds. Rectangles only: an ellipse's strips (its near pairs' width
    corrections) are not modelled, as ``auto`` never gives an ellipse strips."""
    shape, aspect, n = str(level.get("shape")), float(level.get("aspect", 1.0)), int(level["n"])
    if shape != "rectangle":
        raise ValueError(f"strip units are modelled for rectangles only, not {shape}")
    _, far = strip_pairs(shape, aspect, n)
    return (STRIP_SECONDS_PER_FAR_PAIR * far + STRIP_SECONDS_PER_STRIP * n) / STRIP_UNIT_SECONDS


def level_work(level: Mapping[str, Any]) -> Work:
    """``Work`` of one level of ``accuracy_levels``: the one exact cell of an ellipse (galin) one
    task term, and for a crystal one build of its kernel's Fourier series (the Barnett–Lothe
    integrals at 128–256 directions: nearly all of such a task's time); a strip grid its ``strip_units``; a grid of coverage-weighted cells its one-grid
    FFT model (``_contact_cost``: cost units, solve units cost / (S log2 S), S padded cells, one
    task term) times its cells' factor (``COVERAGE_WORK`` × (1 + ``COVERAGE_ASPECT_WORK`` log2 ρ),
    ``CRYSTAL_COVERAGE_WORK`` for a crystal), plus, for an outline that is not an ellipse, circle
    or rectangle, its clipping: ``OUTLINE_COVERAGE_WORK`` per cell along both sides (n + n_across)."""
    boundary = level.get(BOUNDARY_TAG, "coverage")
    if boundary == "galin":  # a contour integral over the kernel's Fourier series: one task term
        return Work(0.0, 0.0, 0.0, 1.0, 0.0, 1.0 if task_kind(level) == "crystal" else 0.0)
    if boundary == "strip":
        return Work(0.0, 0.0, 0.0, 1.0, strip_units(level), 0.0)
    cost = _contact_cost(level)
    cells = footprint.padded_cells(level)
    if task_kind(level) != "contact":
        factor = CRYSTAL_COVERAGE_WORK
    else:
        nx, ny = footprint.contact_grid(level)
        factor = COVERAGE_WORK * (1.0 + COVERAGE_ASPECT_WORK * math.log2(max(nx, ny) / min(nx, ny)))
    fft = factor * cost
    if level.get("shape", "circle") not in ANALYTIC_OUTLINES:
        fft += OUTLINE_COVERAGE_WORK * (int(level["n"]) + int(level["n_across"]))
    return Work(fft, factor * cost / (cells * math.log2(cells)), factor * cells, factor, 0.0, 0.0)


def accuracy_work(params: Mapping[str, Any]) -> Work:
    """``Work`` of the accuracy task ``params``: the sum of its levels' (``level_work``); for
    coverage-weighted cells below ``COVERAGE_FOUR_GRIDS_TO``, plus ``ONE_MORE_SHARE`` of the next
    planned grid's and less ``ONE_FEWER_SHARE`` of the last predicted grid's beyond
    ``MIN_GRIDS`` (the expected time of a count that varies by one: docs/performance.md
    §"Accuracy tasks")."""
    plan, levels = accuracy_plan(params), accuracy_levels(params)
    parts = [(1.0, level_work(level)) for level in levels]
    if plan.strategy == "coverage" and float(params["accuracy"]) < COVERAGE_FOUR_GRIDS_TO:
        if plan.next_grid is not None:
            n, na = plan.next_grid
            parts.append((ONE_MORE_SHARE, level_work({**levels[-1], "n": n, "n_across": na})))
        if len(levels) > MIN_GRIDS:
            parts.append((-ONE_FEWER_SHARE, parts[len(levels) - 1][1]))
    return Work(*(math.fsum(w * part[k] for w, part in parts) for k in range(len(Work._fields))))


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
    return costed(params)[0]


def costed(params: Mapping[str, Any]) -> tuple[float, Sizing]:
    """``estimated_cost`` and ``sizing`` of the scene ``params``, cached as ``estimated_cost``
    (the sizes depend on the grid, the kind and the solves, which the cost key holds)."""
    if scene_kind(params) == SLIP:
        return slip_cost(params), sizing(params)
    if any(params.get(name) is not None for name in PATH_FIELDS):
        return _contact_cost(params), sizing(params)
    return _cached_contact_cost(canonical_json({k: v for k, v in params.items() if k not in COST_NEUTRAL_FIELDS}))


@functools.lru_cache(maxsize=4096)
def _cached_contact_cost(text: str) -> tuple[float, Sizing]:
    """``_contact_cost`` and ``sizing`` of the scene ``text`` (canonical JSON)."""
    params = json.loads(text)
    return _contact_cost(params), sizing(params)


_SIZINGS: dict[Sizing, Sizing] = {}  # one object per distinct value


def sizing(params: Mapping[str, Any]) -> Sizing:
    """The ``Sizing`` of the scene ``params``: its kind, and the padded cells and array bytes of
    the finest grid it solves (``solved_grids``); for a scene that asks for an accuracy, the
    bytes of ``accuracy.grid_bytes`` on that grid with its boundary cells, the ``Work`` of its
    grids and the label of its grids."""
    levels = solved_grids(params)
    finest = levels[-1]
    if asks_accuracy(params):
        plan = accuracy_plan(params)
        n, na = plan.grids[-1]
        kind = task_kind(params)
        if plan.strategy == "galin":
            label, cells = f"{kind} accuracy: one exact cell (galin)", 0.0
        else:
            where = f"{n} strips" if plan.strategy == "strip" else f"{n} x {na}"
            label, cells = f"{kind} accuracy: {plan.strategy} cells to {where}", footprint.padded_cells(finest)
        size = Sizing(kind, cells, plan.finest_bytes, accuracy_work(params), label)
    else:
        size = Sizing(task_kind(params), footprint.padded_cells(finest), footprint.array_bytes(finest))
    return _SIZINGS.setdefault(size, size)


def _contact_cost(params: Mapping[str, Any]) -> float:
    """``estimated_cost`` of the contact scene ``params``; of one that asks for an accuracy, its
    FFT cost units and strip units (``accuracy_work``: comparable on the development machine)."""
    levels = solved_grids(params)
    if asks_accuracy(params):
        work = accuracy_work(params)
        return work.fft + work.strips
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


class ChunkOrder(NamedTuple):
    """Tasks in the order ``make_chunks`` cuts them into chunks (``chunk_order``): ``order``, task
    positions by kernel group (groups in first-appearance order), largest cost first within a
    group (ties: first appearance); ``costs``, their costs in that order; ``groups``, where each
    group starts in ``order`` (and its length last); ``total``, the sum of the costs in task
    order. The same for any number of ranks: only the cap of a chunk depends on it."""

    order: np.ndarray
    costs: np.ndarray
    groups: np.ndarray
    total: float


def chunk_order(tasks: Sequence[Task]) -> ChunkOrder:
    """The ``ChunkOrder`` of ``tasks``."""
    group = group_ids(tasks)
    costs = [t.cost for t in tasks]
    order = np.lexsort((-np.array(costs, dtype=np.float64), group))  # stable
    ordered = group[order]
    starts = np.flatnonzero(np.concatenate(([True], ordered[1:] != ordered[:-1]))) if len(tasks) else order
    return ChunkOrder(order, np.array(costs, dtype=np.float64)[order], np.append(starts, len(tasks)), sum(costs))


def group_ids(tasks: Sequence[Task]) -> np.ndarray:
    """Each task's kernel group as 0, 1, … in first-appearance order. Groups are told apart by
    their strings' hashes with numpy (no dict of 10^6 strings: ~80 MB), then checked string by
    string; a hash shared by two different groups (never seen) falls back to a dict."""
    groups = [t.group for t in tasks]
    hashes = np.fromiter(map(hash, groups), dtype=np.int64, count=len(groups))
    _, first, inverse = np.unique(hashes, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    later = np.flatnonzero(first[inverse] != np.arange(len(groups)))  # not its group's first task
    if not all(groups[i] == groups[j] for i, j in zip(later.tolist(), first[inverse[later]].tolist())):
        ids: dict[str, int] = {}
        return np.array([ids.setdefault(g, len(ids)) for g in groups], dtype=np.intp)
    rank = np.empty(len(first), dtype=np.intp)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first), dtype=np.intp)
    return rank[inverse]


def chunk_bounds(chunks: ChunkOrder, ranks: int) -> tuple[np.ndarray, np.ndarray]:
    """Where the chunks for ``ranks`` ranks start and stop in ``chunks.order``, in the order the
    ranks take them (``make_chunks``). A group of one task is one chunk (numpy, no loop per
    task: a sweep whose every task has its own kernels, over nu or A, is all such groups);
    larger groups are walked task by task, the chunk closing before the task that would take
    it over the cap. Sums are sequential (0.0 + c1 + c2 ...), the floats ``make_chunks`` adds."""
    starts, costs = chunks.groups[:-1], chunks.costs
    if not len(starts):
        return starts, starts
    cap = chunks.total / (CHUNKS_PER_RANK * ranks)
    sizes = np.diff(chunks.groups)
    cut: dict[int, list[tuple[int, int, float]]] = {}
    for g in np.flatnonzero(sizes > 1).tolist():
        first, stop = int(chunks.groups[g]), int(chunks.groups[g + 1])
        pieces, begin, total = [], first, 0.0
        for i, cost in enumerate(costs[first:stop].tolist(), first):
            if i > begin and total + cost > cap:
                pieces.append((begin, i, total))
                begin, total = i, 0.0
            total += cost
        pieces.append((begin, stop, total))
        cut[g] = pieces
    counts = np.ones(len(starts), dtype=np.intp)
    for g, pieces in cut.items():
        counts[g] = len(pieces)
    at = np.concatenate(([0], np.cumsum(counts)[:-1]))
    chunk_start = np.empty(int(counts.sum()), dtype=np.intp)
    chunk_stop = np.empty_like(chunk_start)
    chunk_cost = np.empty(len(chunk_start), dtype=np.float64)
    single = sizes == 1
    chunk_start[at[single]] = starts[single]
    chunk_stop[at[single]] = starts[single] + 1
    chunk_cost[at[single]] = costs[starts[single]]  # 0.0 + cost
    for g, pieces in cut.items():
        for k, (begin, stop, total) in enumerate(pieces):
            chunk_start[at[g] + k], chunk_stop[at[g] + k], chunk_cost[at[g] + k] = begin, stop, total
    taken = np.argsort(-chunk_cost, kind="stable")
    return chunk_start[taken], chunk_stop[taken]


def make_chunks(tasks: list[Task], ranks: int) -> list[tuple[Task, ...]]:
    """Tasks grouped by kernel and split at 1/(CHUNKS_PER_RANK·ranks) of the total cost; chunks
    in decreasing cost (ties: first appearance), the order the ranks take them in. Within a
    group (groups in first-appearance order) tasks go largest first (ties: first appearance)
    and a chunk closes before the task that would take it over the cap (``chunk_order``,
    ``chunk_bounds``)."""
    if not tasks:
        return []
    chunks = chunk_order(tasks)
    order = chunks.order.tolist()
    starts, stops = chunk_bounds(chunks, ranks)
    return [tuple(tasks[i] for i in order[a:b]) for a, b in zip(starts.tolist(), stops.tolist())]
