"""The axes of a sweep's parameter space: the spec's field type tables, an axis's values
(explicit, ``linspace``/``logspace``, label tables) checked and normalized, and input files made
absolute (the spec's format: ``hpcontact.sweep.space.parse``)."""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hpcontact import fields
from hpcontact.errors import InputError

#: The axes a spec may name: the fields the schema marks as axes (``hpcontact.fields.axis_names``)
#: and ``pair`` (a table of both bodies of a slip scene, ``LABEL_AXES``).
AXIS_NAMES = (*fields.axis_names(), "pair")
# Axes whose values may be tables with a ``label`` (the coordinate) and scene fields, and the
# field a plain string value sets (None: tables only).
LABEL_AXES: Mapping[str, str | None] = {"shape": "shape", "pair": None}
# The spec's type tables, queries of the field schema (``hpcontact.fields``): numbers (floats,
# integers), strings with what they are in words, radii that may be infinite (a flat direction:
# inf, or the strings "inf" / "flat"), and input files (a relative path is taken relative to the
# spec file's folder, not the working directory, and stored absolute, so a spec means the same
# files wherever it is run from; the file's content is part of the task key, ``tasks.task_key``).
FLOAT_FIELDS = fields.of_type(float)
INT_FIELDS = fields.of_type(int)
STRING_FIELDS: Mapping[str, str] = fields.string_texts()
FLAT_FIELDS = fields.flat_fields()
PATH_FIELDS = fields.path_fields()
# Geometry fields and the shapes they apply to (docs/design.md §4.1, hpcontact.geometry.Shape): a field a
# shape ignores is dropped from its scene, so e.g. a circle on an aspect axis is solved once.
SHAPE_ONLY_FIELDS: Mapping[str, frozenset[str]] = {
    name: frozenset(shapes) for name, (_, shapes, why) in fields.read_by("shape").items() if why is None
}
#: Points of a spec at most (the product of its axes' lengths, the data set's size), refused
#: before any axis is made (``parse.check_points``). Measured end to end (``hpcontact.run_sweep``
#: of a dict spec, a stand-in task function, 2026-11-28 on the 2-core VM at load average ~10):
#: 10**7 points of which 10 need a solve (a tensor-mode angle axis of 10**6) in 50 s wall and
#: 0.53 GiB peak RSS, a data set of 30 MiB.
MAX_POINTS = 10**7
#: Points of the task axes at most (each needs a solve: every axis but ``angle`` in tensor mode).
#: Each task is held by every rank from the set-up on (its parameters, key and cost: ~0.5 kB)
#: and journaled, so tasks, not points, bound a run's memory and its driver time. Measured as
#: ``MAX_POINTS``: 10**5 tasks end to end in 310 s wall (2.9 ms of driver time per task) and
#: 0.69 GiB peak RSS; the set-up of 10**6 tasks (to the first task) in 542 s wall (154 CPU-s)
#: and 1.25 GiB (the rest of such a run was not measured: ~50 min of driver time at that load).
#: 10**7 tasks did not hold (issue 43: MemoryError after 3 min and 6.6 GB while setting up).
MAX_TASK_POINTS = 10**6


@dataclass(frozen=True)
class Axis:
    """One axis of the parameter space.

    ``values`` are the coordinates (float64, int64 for ``n``, labels for ``shape`` and ``pair``);
    ``fields[i]`` the scene fields that coordinate ``values[i]`` sets (``{"nu": 0.3}``, or the
    fields of a label table).
    """

    name: str
    values: tuple
    fields: Sequence[Mapping[str, Any]]

    def __len__(self) -> int:
        return len(self.values)


class PlainFields(Sequence):
    """The scene fields of a plain axis' coordinates, ``{name: values[i]}``, made when asked
    for (a dict per coordinate held would take ~0.2 kB: 0.2 GB for an axis of 10^6 values)."""

    __slots__ = ("name", "values")

    def __init__(self, name: str, values: tuple) -> None:
        self.name = name
        self.values = values

    def __len__(self) -> int:
        return len(self.values)

    def __getitem__(self, i: Any) -> Any:
        if isinstance(i, slice):
            return tuple({self.name: v} for v in self.values[i])
        return {self.name: self.values[i]}

    def __eq__(self, other: object) -> bool:
        if isinstance(other, PlainFields):
            return self.name == other.name and self.values == other.values
        return tuple(self) == other if isinstance(other, tuple) else NotImplemented

    def __hash__(self) -> int:
        return hash((self.name, self.values))

    def __repr__(self) -> str:
        return f"PlainFields({self.name!r}, {len(self.values)} values)"


def with_paths(fields: Mapping[str, Any], base: Path) -> Mapping[str, Any]:
    """``fields`` with every input file (``PATH_FIELDS``) made absolute: a relative path joined
    to ``base`` (the spec's folder), an absolute one unchanged."""
    if not any(name in fields for name in PATH_FIELDS):
        return fields
    return {k: str(base / v) if k in PATH_FIELDS and not Path(v).is_absolute() else v for k, v in fields.items()}


def normalize(key: str, name: str, value: Any) -> Any:
    """``value`` as float64 (float fields; inf, "inf" or "flat" for the radii that may be
    flat), int (integer fields) or a non-empty string (string fields); others unchanged."""
    if name in STRING_FIELDS:
        if not isinstance(value, str) or not value.strip():
            raise InputError(key, f"a non-empty string ({STRING_FIELDS[name]})", value)
        return value.strip()
    if name in FLAT_FIELDS:
        if isinstance(value, str) and value.strip().lower() in ("inf", "infinity", "flat"):
            return math.inf
        if isinstance(value, float) and value == math.inf:
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(key, 'a finite radius, or inf / "flat" for a flat direction', value)
        return float(value)
    if name in FLOAT_FIELDS or name in INT_FIELDS:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputError(key, "a finite number", value)
        if name in INT_FIELDS:
            if value != int(value):
                raise InputError(key, "an integer", value)
            return int(value)
        return float(value)
    return value


#: What an axis may be (its refusal's words).
AXIS_FORMS = "a list of values or a table {linspace = [start, stop, num]} / {logspace = ...}"


def axis_length(name: str, raw: Any) -> int:
    """The number of values of the axis ``name`` whose description (a value of a spec's
    ``[axes]``) is ``raw``, counted without making them: a list's length (a tuple's or a 1-D
    array's in a spec given as a dict), a ``linspace``/``logspace`` table's ``num``, checked as
    ``parse_axis`` checks it; ``InputError`` naming the key for anything else."""
    key = f"axes.{name}"
    if isinstance(raw, Mapping):
        return _generator(key, raw)[3]
    if isinstance(raw, (list, tuple)) or (isinstance(raw, np.ndarray) and raw.ndim == 1):
        return len(raw)
    raise InputError(key, AXIS_FORMS, _shown(raw))


def parse_axis(name: str, raw: Any) -> Axis:
    """The axis ``name`` of the spec's ``[axes]`` value ``raw`` (TOML's types: a list, or a table
    of one generator), its values checked and normalized (``normalize``)."""
    key = f"axes.{name}"
    if isinstance(raw, dict):
        values = _generated(key, raw)
    elif isinstance(raw, list):
        values = list(raw)
    else:
        raise InputError(key, AXIS_FORMS, raw)
    if not values:
        raise InputError(key, "at least one value (the axis is empty)")
    if name in LABEL_AXES:
        coords, fields = _label_values(key, name, values)
    else:
        if isinstance(raw, dict) and name in FLOAT_FIELDS and name not in FLAT_FIELDS:
            coords = tuple(values)  # floats already: _normalize has only finiteness to check
            finite = np.isfinite(np.array(coords, dtype=np.float64))
            if not finite.all():
                normalize(key, name, coords[int(np.argmin(finite))])  # raises, as for a list
        else:
            coords = tuple(normalize(key, name, v) for v in values)
        fields = PlainFields(name, coords)
    if len(set(coords)) != len(coords):
        raise InputError(key, "distinct values (a coordinate appears twice)", list(coords))
    return Axis(name=name, values=coords, fields=fields)


def _generator(key: str, raw: Mapping[str, Any]) -> tuple[str, float, float, int]:
    """The generator of an axis table ``raw``: (``"linspace"`` or ``"logspace"``, start, stop,
    num), checked: finite numbers, an integer 1 <= num <= ``MAX_POINTS``."""
    if len(raw) != 1 or next(iter(raw)) not in ("linspace", "logspace"):
        raise InputError(key, "a table with one key: linspace or logspace", _shown(raw))
    kind, args = next(iter(raw.items()))
    ok = (
        isinstance(args, (list, tuple, np.ndarray))
        and len(args) == 3
        and all(isinstance(a, numbers.Real) and not isinstance(a, (bool, np.bool_)) and math.isfinite(a) for a in args)
        and isinstance(args[2], numbers.Integral)
    )
    if not ok:
        raise InputError(f"{key}.{kind}", "[start, stop, num] with finite numbers and an integer num", _shown(args))
    start, stop, num = float(args[0]), float(args[1]), int(args[2])
    if num < 1:
        raise InputError(f"{key}.{kind}", "num >= 1 (the axis is empty)", _shown(args))
    if num > MAX_POINTS:
        raise InputError(f"{key}.{kind}", f"num <= {MAX_POINTS} (the most points a spec may have)", _shown(args))
    return kind, start, stop, num


def _shown(value: Any) -> Any:
    """``value`` as a refusal shows it: a sequence of more than 8 items by its type and length
    (its text could be gigabytes)."""
    if isinstance(value, (list, tuple, np.ndarray)) and len(value) > 8:
        return f"<{type(value).__name__} of {len(value)} values>"
    return list(value) if isinstance(value, np.ndarray) else value


def _generated(key: str, raw: dict) -> list[float]:
    kind, start, stop, num = _generator(key, raw)
    make = np.linspace if kind == "linspace" else np.logspace
    # 15 significant digits drop the generator's last-bit error (0.30000000000000004 -> 0.3,
    # 9.999999999999999e-05 -> 1e-4) so that labels select exactly: ds.sel(nu=0.3)
    return list(map(float, map("{:.15g}".format, make(start, stop, num, dtype=np.float64).tolist())))


def _label_values(key: str, name: str, values: list) -> tuple[tuple[str, ...], tuple[Mapping[str, Any], ...]]:
    """Coordinates (labels) of a label axis (``LABEL_AXES``) and the scene fields each one sets.

    A value is a table ``{label = ..., field = ..., ...}`` (a ``shape`` table must name its
    shape) or, where the axis has a plain field (``shape``), a string setting that field."""
    plain = LABEL_AXES[name]
    if plain is not None:
        expected = f"a {plain} name or a table {{label = ..., {plain} = ..., ...}}"
    else:
        expected = (
            'a table {label = ..., field = value, ...} (e.g. {label = "Cu-Fe", material = "Cu", material2 = "Fe"})'
        )
    coords, fields = [], []
    for i, value in enumerate(values):
        if plain is not None and isinstance(value, str):
            coords.append(value)
            fields.append({plain: value})
            continue
        where = f"{key}[{i}]"
        if not isinstance(value, dict):
            raise InputError(where, expected, value)
        if not isinstance(value.get("label"), str) or not value["label"]:
            raise InputError(
                f"{where}.label", f"a non-empty string naming the {name} in the data set", value.get("label")
            )
        if plain is not None and plain not in value:
            raise InputError(f"{where}.{plain}", f"the {plain} name (circle, polygon, ...)")
        if name == "shape" and "angle" in value:
            raise InputError(f"{where}.angle", "not a shape field (shape_angle turns the shape)")
        if len(value) == 1:
            raise InputError(where, "a label and at least one scene field", value)
        coords.append(value["label"])
        fields.append({k: normalize(f"{where}.{k}", k, v) for k, v in value.items() if k != "label"})
    return tuple(coords), tuple(fields)
