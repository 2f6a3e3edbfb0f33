"""A checked sweep spec (``Spec``): its axes, fixed fields and settings, and the parameters of
each point of its task axes; the canonical JSON that is a scene's identity."""

from __future__ import annotations

import hashlib
import itertools
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hpcontact.materials.elastic_constants import FAMILIES as CONSTANT_FAMILIES
from hpcontact.problems.kinds import CONTACT, KINDS, Kind
from hpcontact.sweep.space.axes import LABEL_AXES, SHAPE_ONLY_FIELDS, Axis

TABLES = ("sweep", "scene", "numerics", "axes", "adaptive")  # [adaptive]: hpcontact.sweep.maps
SWEEP_KEYS = ("title", "output", "journal", "angle_mode", "progress_interval")
NUMERIC_KEYS = ("n", "n_across", "tol", "accuracy")
ANGLE_MODES = ("tensor", "rotated")
ANGLE_FIELD = "field"  # slip sweeps: angle is the load direction of each scene (no angle_mode)
# Values at which dropping the material fields a scene ignores depends on the value of the field
# (``drop_ignored_material_fields``: A = 1 drops the orientation); points of a run at these
# values are enumerated one by one.
REDUCTION_BRANCHES: Mapping[str, tuple[float, ...]] = {"anisotropy": (1.0,)}
ORIENTATION_FIELDS = ("orientation", "miller", "azimuth")
ISOTROPIC_CONSTANTS = ("nu", "G", "anisotropy")

Validator = Callable[[Mapping[str, Any]], None]

#: The spec path a spec given as a dict is recorded under (journals, the data set's ``spec_path``).
DICT_SPEC_PATH = "<dict>"
#: Where a spec given as a dict that names no output writes, relative to the working folder
#: (``default_output``; git-ignored in a clone of hpcontact).
DICT_OUTPUT_FOLDER = Path("results")


def default_title(path: str | Path, axes: Sequence[Axis]) -> str:
    """A spec's title when its ``[sweep]`` names none: its file's stem; for a spec given as a
    dict (``DICT_SPEC_PATH``), one built from its axes: "sweep over shape × nu (2 × 3 points)"
    ("one scene" without axes)."""
    if str(path) != DICT_SPEC_PATH:
        return Path(path).stem
    if not axes:
        return "one scene"
    names = " × ".join(a.name for a in axes)
    return f"sweep over {names} ({' × '.join(str(len(a)) for a in axes)} points)"


def default_output(path: str | Path, title: str = "", text: str = "") -> Path:
    """Where a spec that names no ``[sweep] output`` writes: beside its file,
    ``FOLDER/STEM.nc`` (never the working folder unless the spec lies there); a spec given as a
    dict (``DICT_SPEC_PATH``, whose ``text`` is its TOML): ``DICT_OUTPUT_FOLDER/SLUG-HASH.nc``,
    SLUG its ``title`` in letters, digits and dashes, HASH the first 8 hex digits of the SHA-256
    of its text, so the same dict finds its output (and its journals: ``resume``) again
    (``title`` and ``text`` are read for a dict only)."""
    if str(path) != DICT_SPEC_PATH:
        return Path(path).with_name(f"{Path(path).stem}.nc")
    slug = re.sub(r"[^A-Za-z0-9]+", "-", title).strip("-").lower()[:48] or "sweep"
    return DICT_OUTPUT_FOLDER / f"{slug}-{hashlib.sha256(text.encode()).hexdigest()[:8]}.nc"


@dataclass(frozen=True)
class Spec:
    """A checked sweep spec. ``fixed`` holds the [scene] and [numerics] fields of every task;
    ``kind`` is the scene kind (``kinds``: contact or slip)."""

    path: Path
    text: str
    title: str
    output: Path
    journal: Path
    angle_mode: str
    progress_interval: float
    fixed: Mapping[str, Any]
    axes: tuple[Axis, ...]
    kind: str = CONTACT
    adaptive: Any = None  # [adaptive]: adaptive.Settings (None: every point is solved)

    @property
    def kind_record(self) -> Kind:
        """The registry's record of the spec's scene kind (``kinds.KINDS``)."""
        return KINDS[self.kind]

    @property
    def task_axes(self) -> tuple[Axis, ...]:
        """Axes that need a solve per value: all but ``angle`` in tensor mode."""
        if self.angle_mode == "tensor":
            return tuple(a for a in self.axes if a.name != "angle")
        return self.axes

    def axis(self, name: str) -> Axis | None:
        """The axis called ``name``, or None."""
        return next((a for a in self.axes if a.name == name), None)

    def points(self) -> itertools.product:
        """Index tuples of every point of the task axes, in C order (last axis fastest)."""
        return itertools.product(*(range(len(a)) for a in self.task_axes))

    def scene_params(self, index: tuple[int, ...], reduce_material: bool = True) -> dict[str, Any]:
        """Solver parameters of the task-axes point ``index``.

        Fixed fields, then the axis values in spec order, then label tables (``shape``, ``pair``:
        they win); in rotated mode the shape is turned by −angle on top of its own
        ``shape_angle`` (in a slip sweep ``angle`` is a field like any other). For contact
        scenes, geometry fields the shape ignores are left out (``SHAPE_ONLY_FIELDS``), and so
        (unless ``reduce_material`` is false) are material fields the body ignores (orientation
        of an isotropic body, nu/G/A of a named crystal), so equal scenes compare equal.
        """
        params, tables, angle = self._merged(index)
        params = self._finished(params, tables, angle)
        if reduce_material and self.kind_record.reduces_fields:
            drop_ignored_material_fields(params)
        return params

    def _merged(self, index: tuple[int, ...]) -> tuple[dict[str, Any], list[Mapping[str, Any]], float | None]:
        """Fixed fields and the fields of the axes ``index`` covers (the first ``len(index)``
        task axes), in spec order; the label tables and the rotated angle apart."""
        params = dict(self.fixed)
        tables: list[Mapping[str, Any]] = []
        angle = None
        for axis, i in zip(self.task_axes, index):
            if axis.name in LABEL_AXES:
                tables.append(axis.fields[i])
            elif axis.name == "angle" and self.angle_mode != ANGLE_FIELD:
                angle = axis.values[i]
            else:
                params.update(axis.fields[i])
        return params, tables, angle

    def _finished(self, params: dict[str, Any], tables: list[Mapping[str, Any]], angle: float | None) -> dict[str, Any]:
        """``params`` with the label tables on top, the shape turned by −angle (rotated mode)
        and the geometry fields the shape ignores left out (contact scenes)."""
        for table in tables:
            params.update(table)
        if angle is not None:
            params["shape_angle"] = float(params.get("shape_angle", 0.0)) - angle
        if self.kind_record.reduces_fields and "shape" in params:
            for name, shapes in SHAPE_ONLY_FIELDS.items():
                if name in params and params["shape"] not in shapes:
                    del params[name]
        return params


def drop_ignored_material_fields(params: dict[str, Any]) -> None:
    """Leave out the material fields ``hpcontact.scene`` ignores for these parameters: the
    orientation of an isotropic body (A = 1 and neither a library crystal nor constants), and
    nu, G and A of a body given otherwise (a library crystal or elastic constants), which the
    scene's validator refuses (a spec checked by another validator may still hold them)."""
    if any(params.get(name) is not None for name in ("material", *CONSTANT_FAMILIES)):
        for name in ISOTROPIC_CONSTANTS:
            params.pop(name, None)
    elif params.get("anisotropy", 1.0) == 1.0:
        for name in ORIENTATION_FIELDS:
            params.pop(name, None)
