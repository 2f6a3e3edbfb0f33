"""Tasks of a sweep: the distinct scenes of the spec's parameter space, keyed, costed, chunked.

A task is one call of the task function (``accuracy.task_function``: ``hpcontact.problems.contact.solve`` on
one grid for a contact scene with ``n``; without ``n``, an elliptical contact's exact cell or
a slender rectangle's strips, elsewhere the extrapolated default over grids 16 … 256,
``accuracy.default_solve``; with an ``accuracy``,
``solve_to_accuracy`` with strategy auto) on one scene, costed by the cost model
(``hpcontact.sweep.cost.task_cost``: over every grid it solves). Points of the
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
it (``cost.task_cost.COST_NEUTRAL_FIELDS``, ``COST_BRANCH_FIELDS``) or once per distinct grid
when it changes the grid alone (``GRID_ONLY_FIELDS``); each task carries the sizes the cost
model reads (``cost.task_cost.Sizing``), so the dry run estimates 10^6 tasks without looking at
their parameters again.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import hashlib
import math
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, NamedTuple, TextIO

import numpy as np

from hpcontact import fields
from hpcontact.geometry import file_sha256
from hpcontact.problems import footprint
from hpcontact.problems.kinds import scene_kind
from hpcontact.scene import canonical_json
from hpcontact.sweep.cost.task_cost import (
    COST_BRANCH_FIELDS,
    COST_NEUTRAL_FIELDS,
    GRID_ONLY_FIELDS,
    Sizing,
    costed,
)
from hpcontact.sweep.space.axes import PATH_FIELDS
from hpcontact.sweep.space.enumeration import Run, run_field, scene_runs, text_template
from hpcontact.sweep.space.spec import Spec, Validator

# A chunk costs at most 1/(CHUNKS_PER_RANK · ranks) of the whole sweep.
CHUNKS_PER_RANK = 4


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


def as_task(row: tuple) -> Task:
    """The ``Task`` of a plain 5-tuple ``row`` (key, params, cost, group, sizing), made without
    ``Task.__new__``'s Python call: what a share's rows become again on the receiving rank."""
    return _task(row)


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
    task dry run). On the way out, where no caller has frozen objects, every tracked object is
    moved to the oldest generation (``gc.freeze`` then ``gc.unfreeze``: two list merges, the
    generations' counts reset): the young generation no longer holds what was made meanwhile,
    so the first allocation after the pause does not traverse it all (the 4-D map's enumeration
    in one process: one gen-0 collection of 0.08 CPU s, 2026-11-30). Anything cyclic made
    meanwhile is collected at the next full collection."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            if gc.get_freeze_count() == 0:
                gc.freeze()
                gc.unfreeze()
            gc.enable()


@contextlib.contextmanager
def frozen_heap() -> Iterator[None]:
    """Every object alive on entry kept out of the cyclic garbage collector's traversals until
    the exit (``gc.freeze``, ``gc.unfreeze``), for one round of a run: the grid's tasks (every
    task on every rank: the 4-D map's 139 725), the spec, the modules and the journals read so
    far live to the run's end, and each full collection traversed them all again (the 4-D map
    in one process: a gen-1 and a gen-2 collection right after the set-up, 0.1 and 0.2 s, what
    ``paused_gc`` had left to the collector; two more full ones of 0.09-0.28 s, one while rank 0
    read the journals ahead with every rank waiting on it). A round's own objects are collected
    as before; refcounting frees a frozen object as before; cyclic garbage alive on entry waits
    for the exit. A caller that froze objects itself (``gc.get_freeze_count()`` > 0 on entry:
    before forking, say) keeps its heap frozen on exit, these objects too. The collector's
    seconds on the 4-D map's recorded solves: one process 0.71-0.78 -> 0.23-0.30, rank 0 of 2
    ranks 0.59-0.72 -> 0.23-0.34 CPU s (3 alternating pairs each, 2026-11-30, ``gc.callbacks``;
    docs/performance.md § Adaptive rounds on many ranks)."""
    ours = gc.get_freeze_count() == 0
    gc.freeze()
    try:
        yield
    finally:
        if ours:
            gc.unfreeze()


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
        # fields that change neither a scene's kernels nor its grid spacing (a contact scene's
        # outline or solves; a slip scene's loading): tasks differing only in these share kernels
        self.ignored = frozenset(fields.names(spec.kind, neutral_to="kernel"))
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
        if any(base.get(n) is not None for n in PATH_FIELDS):
            return each
        kind = scene_kind(base)
        branches = COST_BRANCH_FIELDS[kind].get(name)
        if name in COST_NEUTRAL_FIELDS[kind] or (branches is not None and not any(v in branches for v in run.values)):
            return None
        if name in GRID_ONLY_FIELDS[kind] and base.get("n") is not None and base.get("accuracy") is None:
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
    """``join_parts`` of several parts: the tasks by key, and each part's points' tasks. A row
    is taken as it is (a ``Task``) unless its group's text is held by another object already:
    then with that one (one string object per distinct group)."""
    position: dict[str, int] = {}
    groups: dict[str, str] = {}
    tasks: list[Task] = []
    joined = []
    for part in parts:
        rows = part.rows
        found = list(map(position.get, [row[0] for row in rows]))  # the keys of the parts before
        local = np.empty(len(rows), dtype=np.intp)
        for j, (row, at) in enumerate(zip(rows, found)):
            if at is None:
                at = position[row[0]] = len(tasks)
                group = row[3]
                held = groups.setdefault(group, group)
                tasks.append(row if held is group else row._replace(group=held))
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
