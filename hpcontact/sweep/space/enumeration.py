"""The points of a spec's task axes with their scenes, in runs along the last axis, each
distinct scene checked by its kind's validator (``scene_runs``; the spec's format:
``hpcontact.sweep.space.parse``)."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hpcontact.errors import InputError, did_you_mean
from hpcontact.scene import canonical_json
from hpcontact.sweep.space.axes import LABEL_AXES
from hpcontact.sweep.space.spec import (
    ANGLE_FIELD,
    NUMERIC_KEYS,
    REDUCTION_BRANCHES,
    Spec,
    Validator,
    drop_ignored_material_fields,
)

PROGRESS_POINTS = 100_000  # points between calls of scene_runs' progress callback
#: A spec of at most this many points is checked scene by scene (every distinct scene
#: validated: ~0.5 s for isotropic scenes, ~6 s for turned crystals, whose validation builds the
#: rotated stiffness: ~0.6 ms a scene); in a larger one, each run of three or more points along
#: the last task axis (one value of every other axis) whose field has an interval of valid values
#: (``kinds.interval_fields``) is checked at its extreme and branch values (``scene_runs``), in
#: whatever range of it a rank checks. Another validator than the kind's always sees every scene.
SCENE_CHECK_POINTS = 10_000


class _Placeholder:
    """Stands for the value of a run's field in ``Run.params`` (equal to no value)."""

    __slots__ = ()

    def __repr__(self) -> str:
        return "<value of the run>"


PLACEHOLDER = _Placeholder()
_MARKED = canonical_json("\x00")  # a string no scene field holds alone, as canonical JSON writes it


def text_template(params: Mapping[str, Any], name: str) -> tuple[str, str] | None:
    """(prefix, suffix) such that the canonical JSON of ``params`` with ``name`` set to a finite
    number x is ``prefix + repr(x) + suffix`` (JSON writes finite floats and ints as ``repr``;
    keys are sorted, so the value's place does not depend on it); None if the marker used to
    find that place is ambiguous (a field holding the string "\\x00")."""
    marked = dict(params)
    marked[name] = "\x00"
    text = canonical_json(marked)
    at = text.find(_MARKED)
    if at < 0 or text.find(_MARKED, at + 1) >= 0:
        return None
    return text[:at], text[at + len(_MARKED) :]


@dataclass(frozen=True)
class Run:
    """Consecutive points ``start`` … ``stop - 1`` of a spec (positions in the C order of
    ``Spec.points``; ``index``: the first one's index over the task axes) whose scenes differ
    in one field at most (``scene_runs``).

    Without ``name`` every point is the scene ``params`` (ignored material fields dropped) with
    the canonical JSON ``text``. With ``name``, point ``start + j`` is ``params`` with ``name`` set
    to ``values[j]`` (a finite float or an int; in ``params`` the field holds ``PLACEHOLDER``, in
    its place among the keys), and its canonical JSON is ``text + repr(values[j]) + suffix``."""

    start: int
    stop: int
    index: tuple[int, ...]
    params: dict[str, Any]
    text: str
    name: str | None = None
    values: Sequence[Any] = ()
    suffix: str = ""

    def __len__(self) -> int:
        return self.stop - self.start

    def scene(self, j: int) -> dict[str, Any]:
        """The parameters of point ``start + j`` (a new dict)."""
        params = dict(self.params)
        if self.name is not None:
            params[self.name] = self.values[j]
        return params

    def scene_text(self, j: int) -> str:
        """The canonical JSON of point ``start + j``."""
        return self.text if self.name is None else self.text + repr(self.values[j]) + self.suffix

    def point(self, j: int) -> tuple[int, ...]:
        """The index over the task axes of point ``start + j``."""
        return self.index[:-1] + (self.index[-1] + j,) if self.index else ()


def scene_runs(
    spec: Spec,
    validate: Validator | None = None,
    start: int = 0,
    stop: int | None = None,
    check: bool = True,
    progress: Callable[[int], None] | None = None,
) -> Iterator[Run]:
    """The points ``start`` … ``stop - 1`` of the task axes (0-based positions in the C order of
    ``Spec.points``) with their scenes (``Spec.scene_params``), as ``Run``s: along the last task
    axis, the points of one value of every other axis are one run when that axis sets a number
    (``shape_angle`` for the angle in rotated mode): their scenes differ in that field alone, so
    a run carries its scene and the canonical JSON around the value once, not per point. Points
    of a label axis (``shape``, ``pair``) last, and points whose value changes which material
    fields are dropped (``REDUCTION_BRANCHES``: A = 1), are runs of one point. ``progress(done)``
    is called every ``PROGRESS_POINTS`` points of the range (runs end there).

    With ``check``, the validator (``validate``, default: the scene kind's) sees every distinct
    scene of the range, before ignored material fields are dropped (an impossible orientation
    is refused even at A = 1), and a bad field raises ``InputError`` naming the spec key it came
    from, at the first bad point in C order. In a spec of more than ``SCENE_CHECK_POINTS``
    points (in every range of it: a rank's share of the 4-D map, 146 475 points on 16 ranks,
    is 9 155 points, and checked scene by scene it took 5-8 CPU s a rank instead of 0.3-0.5,
    2026-11-30), the kind's own validator sees a run of three or more points of a field whose valid
    values form an interval (``kinds.interval_fields``) at its extreme values and branch values
    only: both valid, every value between is; one refused, a bisection from a valid value finds
    the interval's ends and the first point outside it is validated, raising the same error as a
    check of every scene (``_first_refused``)."""
    axes = spec.task_axes
    total = math.prod(len(a) for a in axes)
    stop = total if stop is None else min(stop, total)
    checker = _Check(spec, validate, total > SCENE_CHECK_POINTS) if check else None
    field = run_field(spec)
    width = len(axes[-1]) if axes else 1
    outer_shape = tuple(len(a) for a in axes[:-1])
    at = start
    while at < stop:
        context, first = divmod(at, width)
        end = min(stop, at - first + width)
        if progress is not None:
            end = min(end, start + ((at - start) // PROGRESS_POINTS + 1) * PROGRESS_POINTS)
        outer = tuple(int(i) for i in np.unravel_index(context, outer_shape)) if outer_shape else ()
        yield from _context_runs(spec, field, outer, first, first + end - at, at, checker)
        at = end
        if progress is not None and at < stop and not (at - start) % PROGRESS_POINTS:
            progress(at - start)


def scenes(
    spec: Spec, validate: Validator | None = None, start: int = 0, stop: int | None = None, check: bool = True
) -> Iterator[tuple[tuple[int, ...], dict[str, Any]]]:
    """The points ``start`` … ``stop - 1`` of the task axes (0-based positions in the C order of
    ``Spec.points``) with their scene parameters (``Spec.scene_params``), one by one; with
    ``check``, validated as ``scene_runs`` does (a bad field raises ``InputError`` naming the spec
    key it came from)."""
    for index, params, _ in scene_texts(spec, validate, start, stop, check):
        yield index, params


def scene_texts(
    spec: Spec,
    validate: Validator | None = None,
    start: int = 0,
    stop: int | None = None,
    check: bool = True,
    progress: Callable[[int], None] | None = None,
) -> Iterator[tuple[tuple[int, ...], dict[str, Any], str]]:
    """``scenes`` with the canonical JSON of each point's parameters (``canonical_json``: the
    task key's text): ``scene_runs`` point by point (a run is checked before its points come)."""
    for run in scene_runs(spec, validate, start, stop, check, progress):
        for j in range(len(run)):
            yield run.point(j), run.scene(j), run.scene_text(j)


def run_field(spec: Spec) -> str | None:
    """The field the last task axis sets, when its values are finite numbers (``shape_angle``
    for the angle in rotated mode); None for a label axis (or none): runs of one point."""
    if not spec.task_axes:
        return None
    axis = spec.task_axes[-1]
    if axis.name in LABEL_AXES or not {type(v) for v in axis.values} <= {float, int}:
        return None
    if not np.isfinite(np.asarray(axis.values, dtype=np.float64)).all():
        return None
    return "shape_angle" if axis.name == "angle" and spec.angle_mode != ANGLE_FIELD else axis.name


def _context_runs(
    spec: Spec,
    field: str | None,
    outer: tuple[int, ...],
    first: int,
    last: int,
    at: int,
    checker: _Check | None,
) -> Iterator[Run]:
    """The runs of the points ``outer + (i,)``, i = ``first`` … ``last - 1`` (the first at
    position ``at``), with ``field`` the one the last axis sets (``run_field``)."""
    opened = None if field is None else _run_params(spec, outer, field, first, last)
    if opened is None:  # point by point
        indices = [outer + (i,) for i in range(first, last)] if spec.task_axes else [()]
        for k, index in enumerate(indices):
            yield _point_run(spec, index, spec.scene_params(index, reduce_material=False), at + k, checker)
        return
    base, values = opened
    index = outer + (first,)
    if base.get(field) is not PLACEHOLDER:  # a label table sets the field, or the shape ignores it
        yield _point_run(spec, index, base, at, checker, at + last - first)
        return
    if checker is not None:
        checker.run(index, base, field, values)
    reduces = spec.kind_record.reduces_fields
    branches = REDUCTION_BRANCHES.get(field, ()) if reduces else ()
    reduced = dict(base)
    if reduces:
        drop_ignored_material_fields(reduced)
    template = None
    if reduced.get(field) is PLACEHOLDER:
        template = text_template(reduced, field)
        if template is not None:  # the guard of the template: its first point written in full
            check_params = dict(reduced)
            check_params[field] = values[0]
            if canonical_json(check_params) != template[0] + repr(values[0]) + template[1]:
                template = None
        if template is None:  # point by point
            for j, value in enumerate(values):
                params = dict(base)
                params[field] = value
                yield _point_run(spec, index[:-1] + (first + j,), params, at + j, None)
            return
    text = canonical_json(reduced) if template is None else ""  # no template: the field is dropped
    j = 0
    while j < len(values):
        if values[j] in branches:
            params = dict(base)
            params[field] = values[j]
            yield _point_run(spec, index[:-1] + (first + j,), params, at + j, None)
            j += 1
            continue
        k = j + 1
        while k < len(values) and values[k] not in branches:
            k += 1
        if template is None:
            yield Run(at + j, at + k, index[:-1] + (first + j,), reduced, text)
        else:
            yield Run(at + j, at + k, index[:-1] + (first + j,), reduced, template[0], field, values[j:k], template[1])
        j = k


def _run_params(
    spec: Spec, outer: tuple[int, ...], field: str, first: int, last: int
) -> tuple[dict[str, Any], Sequence[Any]] | None:
    """The parameters of the points ``outer + (i,)`` before material fields are dropped, with
    ``field`` holding ``PLACEHOLDER`` (absent when a label table sets it or the shape ignores
    it), and the field's values at i = ``first`` … ``last - 1`` (``Spec.scene_params`` with the
    last axis' value left open); None when a turned shape's angle overflows (point by point)."""
    axis = spec.task_axes[-1]
    params, tables, angle = spec._merged(outer)
    if axis.name == "angle" and field == "shape_angle":  # rotated mode: the shape turned by −angle
        params = spec._finished(params, tables, angle)
        turned = float(params.get("shape_angle", 0.0))
        params["shape_angle"] = PLACEHOLDER
        values = [turned - a for a in axis.values[first:last]]
        return (params, values) if all(map(math.isfinite, values)) else None
    params[field] = PLACEHOLDER
    return spec._finished(params, tables, angle), axis.values[first:last]


def _point_run(
    spec: Spec, index: tuple[int, ...], params: dict[str, Any], at: int, checker: _Check | None, stop: int | None = None
) -> Run:
    """A run of the one scene ``params`` (before material fields are dropped) of the point
    ``index`` at position ``at`` (to ``stop``: points of the same scene), checked first."""
    text = canonical_json(params)
    if checker is not None:
        checker.scene(index, params, text)
    if spec.kind_record.reduces_fields:
        fields = len(params)
        drop_ignored_material_fields(params)
        if len(params) != fields:
            text = canonical_json(params)
    return Run(at, at + 1 if stop is None else stop, index, params, text)


class _Check:
    """The validator over the runs of a spec (``scene_runs``): each distinct scene once, its
    error located in the spec (``scene``); with ``intervals``, a run of an interval field at its
    extreme and branch values (``run``)."""

    def __init__(self, spec: Spec, validate: Validator | None, intervals: bool = True) -> None:
        self.spec = spec
        self.validate = spec.kind_record.validate if validate is None else validate
        self.intervals = spec.kind_record.interval_fields if validate is None and intervals else {}
        self.seen: set[str] = set()  # texts of the scenes validated

    def scene(self, index: tuple[int, ...], params: Mapping[str, Any], text: str | None = None) -> None:
        """Validate the scene ``params`` of the point ``index`` unless seen: ``InputError``
        naming the spec key the bad field came from."""
        text = canonical_json(params) if text is None else text
        if text in self.seen:
            return
        self.seen.add(text)
        try:
            self.validate(dict(params))
        except InputError as exc:
            hint = did_you_mean(
                exc.field, _known_fields(exc.allowed)
            )  # an unknown [scene] field: the closest known one
            raise InputError(_locate(self.spec, index, exc.field), exc.allowed + hint, exc.value) from None

    def run(self, index: tuple[int, ...], base: Mapping[str, Any], field: str, values: Sequence[Any]) -> None:
        """Validate the run of the points ``index`` on whose scenes are ``base`` with ``field``
        set to each of ``values``: every distinct scene, or for a run of three or more points of
        an interval field its extreme and branch values (``_first_refused``); the first bad
        point raises."""

        def scene(j: int) -> dict[str, Any]:
            params = dict(base)
            params[field] = values[j]
            return params

        def point(j: int) -> tuple[int, ...]:
            return index[:-1] + (index[-1] + j,)

        if field not in self.intervals or len(values) < 3:
            for j in range(len(values)):
                self.scene(point(j), scene(j))
            return
        verdicts: dict[int, bool] = {}

        def refused(j: int) -> bool:
            if j not in verdicts:
                params = scene(j)
                text = canonical_json(params)
                verdicts[j] = False
                if text not in self.seen:
                    try:
                        self.validate(dict(params))
                        self.seen.add(text)
                    except InputError:
                        verdicts[j] = True
            return verdicts[j]

        bad = _first_refused(values, self.intervals[field], refused)
        if bad is not None:
            self.scene(point(bad), scene(bad))  # raises its error, located


def _first_refused(values: Sequence[Any], branches: Sequence[float], refused: Callable[[int], bool]) -> int | None:
    """The first position (in run order) of ``values`` of an interval field whose scene is
    refused (``refused(j)`` validates position j), or None: the valid values form an interval
    apart from the branch values (``kinds.interval_fields``), so branch values are validated
    each, and the others at the smallest and the largest value; when one of those is refused and
    the run's first regular value is valid, bisections between them find the interval's ends in
    the sorted values (a few validations), and the first point outside it is the one."""
    v = np.asarray(values, dtype=np.float64)
    at_branch = np.isin(v, branches) if branches else np.zeros(v.size, dtype=bool)
    bad = []
    for j in np.flatnonzero(at_branch).tolist():
        if refused(j):
            bad.append(j)
            break
    regular = np.flatnonzero(~at_branch)
    if regular.size:
        order = regular[np.argsort(v[regular], kind="stable")]
        if refused(int(order[0])) or refused(int(order[-1])):
            first = int(regular[0])
            if refused(first):
                bad.append(first)
            else:
                k = int(np.flatnonzero(order == first)[0])
                low, high = 0, len(order) - 1
                if refused(int(order[0])):  # the lowest valid position in the sorted values
                    bad_end, good = 0, k
                    while good - bad_end > 1:
                        mid = (bad_end + good) // 2
                        bad_end, good = (mid, good) if refused(int(order[mid])) else (bad_end, mid)
                    low = good
                if refused(int(order[-1])):  # the highest one
                    good, bad_end = k, len(order) - 1
                    while bad_end - good > 1:
                        mid = (good + bad_end) // 2
                        good, bad_end = (good, mid) if refused(int(order[mid])) else (mid, bad_end)
                    high = good
                bad.append(int(np.concatenate((order[:low], order[high + 1 :])).min()))
    return min(bad) if bad else None


def _locate(spec: Spec, index: tuple[int, ...], name: str) -> str:
    """Where in the spec the field ``name`` of the scene at ``index`` came from (label tables
    first, the last one setting it: their fields win)."""
    for axis, i in reversed(list(zip(spec.task_axes, index))):
        if axis.name in LABEL_AXES and name in axis.fields[i]:
            return f"axes.{axis.name}[{i}].{name}"
    for axis in spec.task_axes:
        if axis.name == name:
            return f"axes.{name}"
    if name == "shape_angle" and spec.angle_mode == "rotated":
        return "axes.angle"
    if name in spec.fixed:
        return f"numerics.{name}" if name in NUMERIC_KEYS else f"scene.{name}"
    return f"scene.{name}"


def _known_fields(allowed: Any) -> list[str]:
    """The names listed by a validator's unknown-field message ("a known field (a, b, ...)"),
    else none; ``allowed`` given as names: those."""
    if not isinstance(allowed, str):
        return list(allowed)
    return allowed[allowed.index("(") + 1 : -1].split(", ") if "field" in allowed and allowed.endswith(")") else []
