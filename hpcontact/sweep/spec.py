"""Sweep job spec: a TOML file → axes, fixed scene fields and settings, checked before any work.

A spec has four tables (docs/design.md §1, §4.2; every key is optional except one axis or a fixed scene)::

    [sweep]                          # how the sweep runs
    title = "Li 2017, Fig. 7"
    output = "results/aspect.nc"     # relative to the working directory; --output overrides
    journal = "results/aspect.nc.journal"   # per-rank HDF5 journals (default: output + ".journal")
    angle_mode = "tensor"            # "tensor": K_nn(angle) from the tensor, no solve per angle;
                                     # "rotated": Li's check, one solve per angle, shape_angle −= angle
    progress_interval = 10.0         # seconds between progress lines on rank 0

    [scene]                          # fixed fields of every scene (names of `hpcontact solve`)
    quantities = ["tangential", "normal"]

    [numerics]                       # accuracy settings of every scene
    n = 128                          # one grid ... (or accuracy = 1e-4 instead of n, n_across:
    n_across = 16                    # a grid sequence to that estimated relative error)
    tol = 1e-10

    [axes]                           # the parameter space: a Cartesian product
    shape = ["ellipse", "rectangle", { label = "hexagon", shape = "polygon", sides = 6 }]
    aspect = { logspace = [0, -8, 9] }      # numpy.logspace(start, stop, num): 1 … 1e-8
    nu = [0.1, 0.3, 0.5]
    angle = { linspace = [0, 180, 37] }     # numpy.linspace(start, stop, num)

Axis names are those of docs/design.md §1 (``shape angle nu aspect anisotropy orientation``), ``material``
(library crystal names, a string coordinate: ``material = ["Cu", "Al", "W"]``), ``normal_held``
(``["approach", "load"]``, a string coordinate: what ``tangential`` holds normally), plus ``n``,
``tol`` and ``accuracy`` for accuracy studies. Crystal scenes::

    [scene]                          # Rodríguez-Tembleque et al. 2011: sphere on a cubic crystal
    quantities = ["indentation"]
    radius = 1.0                     # rigid sphere radius R and approach d (fixed fields)
    depth = 1e-4
    [axes]
    anisotropy = [0.5, 1, 2]         # cubic from (nu, A), (C11 - C12)/2 = G
    orientation = { linspace = [0, 90, 19] }   # psi along [110] -> [111] -> [001]

A field the scene ignores is left out of its parameters, so equal scenes are solved once: at
A = 1 without a named crystal the body is isotropic and ``orientation``, ``miller`` and
``azimuth`` are dropped (after validation, so a bad value is still refused). ``nu``, ``G`` or
``anisotropy`` in a scene whose body is a named ``material`` or elastic constants (``cubic``,
``orthotropic``, ``voigt``) is refused, as by ``hpcontact solve`` (``hpcontact.scene.UNUSED_FIELDS``),
naming the key it came from (``axes.nu``, ``scene.G``). A ``shape`` value is a shape name or a table with a ``label``
(its coordinate in the data set) and scene fields (``shape``, ``sides``, ``aspect``, …); fields
of such a table win over the other axes. Anything unknown, empty, duplicated or impossible is
refused with an ``InputError`` naming the key (``axes.nu``, ``scene.G``, …), so a bad spec never
reaches a rank's work loop. Values are checked by the scene's own validator: every distinct
scene of the sweep, except in a range of more than ``SCENE_CHECK_POINTS`` points (a large spec,
or a rank's share of one) along its last axis when that axis is a field whose valid values form
an interval (``kinds.interval_fields``: nu, b/a, A, ψ, …): there the validator checks each run's
extreme and branch values (a bisection finds the first refused point when one is refused:
``scene_runs``), with the same error, naming the same key, as a check of every scene.

A ``mask`` file (``shape = "mask"``, a .npy or .png contact mask; in [scene] or a shape table)
given by a relative path is found relative to the spec file's folder, not the working directory
(an absolute path stays as is); scenes hold it absolute. Its header is read when the spec is
checked (``geometry.mask_pixels``: a wrong type or a mask over the grid limit is refused before
anything is decoded), and its content is part of the task key (``tasks.task_key``): ``--resume``
after the file changed computes its tasks again.

Partial-slip scenes (``quantities = "slip"``: ``hpcontact.problems.slip.partial_slip``, two bodies pressed by a load P
and loaded tangentially to Q = q_ratio mu P; the scene kind, ``kinds``) take the axes ``load``,
``mu``, ``q_ratio`` and ``pair``; a ``pair`` value is a table with a ``label`` and body fields
(``material material2 radius radius_b radius2 radius2_b body2_angle E G nu E2 G2 nu2``, or any
other scene field; its fields win over the other axes)::

    [scene]
    quantities = "slip"
    radius = 8e-3                    # body 1 and body 2, metres (library materials: SI units)
    radius2 = 9e-3
    steps = 5                        # force-controlled load steps up to q_ratio mu P
    [axes]
    pair = [
        { label = "Cu-Fe", material = "Cu", material2 = "Fe" },
        { label = "Fe-flat", material = "Fe", material2 = "Fe", radius2 = "flat" },
    ]
    load = [10.0, 100.0]             # newtons
    mu = [0.3]
    q_ratio = { linspace = [0, 0.9, 10] }

In a slip sweep ``angle`` is the direction of the tangential load, an ordinary field solved per
value (``angle_mode`` is for punch tensors and is refused). Radii of body 2 and the second radii
(``radius_b radius2 radius2_b``) may be ``inf`` or ``"flat"`` (a flat direction).
"""

from __future__ import annotations

import itertools
import json
import math
import os
import stat
import tomllib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from hpcontact.errors import InputError
from hpcontact.materials.elastic_constants import FAMILIES as CONSTANT_FAMILIES
from hpcontact.problems.kinds import CONTACT, KINDS, Kind, kind_of
from hpcontact.scene import ACCURACY_RANGE
from hpcontact.sweep.adaptive_settings import parse_settings

TABLES = ("sweep", "scene", "numerics", "axes", "adaptive")  # [adaptive]: hpcontact.sweep.adaptive
SWEEP_KEYS = ("title", "output", "journal", "angle_mode", "progress_interval")
NUMERIC_KEYS = ("n", "n_across", "tol", "accuracy")
AXIS_NAMES = (
    "shape",
    "angle",
    "nu",
    "aspect",
    "anisotropy",
    "orientation",
    "material",
    "n",
    "tol",
    "accuracy",
    "pair",
    "load",
    "mu",
    "q_ratio",
    "orientation2",
    "anisotropy2",
    "normal_held",
)
# Axes whose values may be tables with a ``label`` (the coordinate) and scene fields, and the
# field a plain string value sets (None: tables only).
LABEL_AXES: Mapping[str, str | None] = {"shape": "shape", "pair": None}
ANGLE_MODES = ("tensor", "rotated")
ANGLE_FIELD = "field"  # slip sweeps: angle is the load direction of each scene (no angle_mode)
FLOAT_FIELDS = frozenset(
    {
        "angle",
        "nu",
        "aspect",
        "anisotropy",
        "orientation",
        "tol",
        "accuracy",
        "G",
        "shape_angle",
        "amplitude",
        "hurst",
        "rms",
        "radius",
        "depth",
        "azimuth",
        "load",
        "mu",
        "q_ratio",
        "radius_b",
        "radius2",
        "radius2_b",
        "body2_angle",
        "E",
        "E2",
        "G2",
        "nu2",
        "displacement",
        "anisotropy2",
        "orientation2",
        "azimuth2",
    }
)
# Radii that may be infinite (a flat direction): inf, or the strings "inf" / "flat".
FLAT_FIELDS = frozenset({"radius_b", "radius2", "radius2_b"})
STRING_FIELDS: Mapping[str, str] = {
    "material": "a library material name (crystals: Cu, Al, Fe, ...; slip bodies: Cu, Fe, Al, rigid)",
    "material2": "a library material name of body 2 (Cu, Fe, Al, rigid)",
    "control": "force or displacement",
    "path": "load or loop",
    "coupling": "auto, both, coupled or decoupled",
    "mask": "a .npy or .png mask file; a relative path is relative to the spec's folder",
    "normal_held": "approach or load: what the tangential stiffness holds in the normal direction",
}
# Fields naming an input file: a relative path is taken relative to the spec file's folder (not
# the working directory) and stored absolute, so a spec means the same files wherever it is run
# from; the file's content is part of the task key (``tasks.task_key``).
PATH_FIELDS = frozenset({"mask"})
INT_FIELDS = frozenset({"n", "n_across", "sides", "seed", "threads", "steps"})
# Geometry fields and the shapes they apply to (docs/design.md §4.1, hpcontact.geometry.Shape): a field a
# shape ignores is dropped from its scene, so e.g. a circle on an aspect axis is solved once.
SHAPE_ONLY_FIELDS: Mapping[str, frozenset[str]] = {
    "aspect": frozenset({"ellipse", "rectangle"}),
    "sides": frozenset({"polygon", "star"}),
    "amplitude": frozenset({"star"}),
    "seed": frozenset({"rough"}),
    "hurst": frozenset({"rough"}),
    "rms": frozenset({"rough"}),
    "mask": frozenset({"mask"}),
}
# Material fields a scene ignores (hpcontact.scene._material): orientation fields of an isotropic
# body (no named crystal, A = 1), isotropic constants when a library crystal is named.
#: Points of a spec at most (the product of its axes' lengths, the data set's size): enumerating
#: a point costs ~1-10 µs along a long last axis (``scene_runs``; ~10-30 µs point by point) and
#: its task ~0.5 kB (``benchmarks/dry_run_points.py``: a dry run of 10^6 points in seconds), so
#: 10^7 points take minutes and gigabytes; a larger spec is refused before anything is
#: enumerated (split it, or coarsen an axis).
MAX_POINTS = 10**7
#: The largest spec file read (bytes): the shipped specs are a few kB, and an explicit axis of
#: 10**6 values (a tenth of ``MAX_POINTS``) is ~10 MB of TOML; a larger file, or one that is not
#: a regular file (/dev/zero, a FIFO, a folder), is refused before it is read.
MAX_SPEC_BYTES = 16 * 2**20
PROGRESS_POINTS = 100_000  # points between calls of scene_runs' progress callback
#: A range of at most this many points is checked scene by scene (every distinct scene
#: validated: at most ~0.5 s); in a larger one, each run of three or more points along the last
#: task axis (one value of every other axis) whose field has an interval of valid values
#: (``kinds.interval_fields``) is checked at its extreme and branch values (``scene_runs``).
#: Another validator than the kind's always sees every scene.
SCENE_CHECK_POINTS = 10_000
# Values at which dropping the material fields a scene ignores depends on the value of the field
# (``_drop_ignored_material_fields``: A = 1 drops the orientation); points of a run at these
# values are enumerated one by one.
REDUCTION_BRANCHES: Mapping[str, tuple[float, ...]] = {"anisotropy": (1.0,)}
ORIENTATION_FIELDS = ("orientation", "miller", "azimuth")
ISOTROPIC_CONSTANTS = ("nu", "G", "anisotropy")

Validator = Callable[[Mapping[str, Any]], None]


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
            _drop_ignored_material_fields(params)
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


def _drop_ignored_material_fields(params: dict[str, Any]) -> None:
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


# json.dumps(params, sort_keys=True, separators=(",", ":")) builds an encoder per call; this one
# is built once (same output; a third of the time on a sweep's small scenes).
_CANONICAL = json.JSONEncoder(sort_keys=True, separators=(",", ":"))


def canonical_json(params: Mapping[str, Any]) -> str:
    """A scene's parameters as canonical JSON (sorted keys, exact floats): its identity."""
    return _CANONICAL.encode(params)


def load_spec(
    path: str | Path,
    output: str | Path | None = None,
    validate: Validator | None = None,
    check_scenes: bool = True,
    accuracy: float | None = None,
) -> Spec:
    """Read and check the spec at ``path``; ``output`` overrides [sweep].output, ``accuracy``
    (``hpcontact run --accuracy``) the spec's [numerics] accuracy, n and n_across.

    ``validate`` checks one scene's parameters (default: the validator of the spec's scene kind,
    ``kinds.validator``); it runs on every distinct scene of the sweep, so impossible values are
    refused up front. With ``check_scenes`` false the scenes are left to the caller (``scenes``:
    the driver spreads them over the ranks and checks them while it enumerates the tasks).
    """
    path = Path(path)
    try:
        text = _read_spec(path).decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")  # as read_text
    except UnicodeDecodeError as exc:
        raise InputError("spec", f"a TOML file in UTF-8 (byte {exc.start} is not UTF-8)", str(path)) from None
    if not any(line.strip() and not line.lstrip().startswith("#") for line in text.splitlines()):
        raise InputError("spec", "a TOML spec with content (this file is empty or holds only comments)", str(path))
    return parse_spec(text, path=path, output=output, validate=validate, check_scenes=check_scenes, accuracy=accuracy)


def _read_spec(path: Path) -> bytes:
    """The bytes of the spec file ``path``: a regular file of at most ``MAX_SPEC_BYTES``, else
    ``InputError`` naming the file and the limit. Opened without blocking (a FIFO), checked by
    ``fstat`` on the open file, read no further than the limit."""
    limit = f"a regular TOML file of at most {MAX_SPEC_BYTES // 2**20} MiB ({MAX_SPEC_BYTES} bytes)"
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the path
        why = exc.strerror if isinstance(exc, OSError) else "a path without NUL characters"
        raise InputError("spec", f"a readable TOML file ({why})", str(path)) from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        what = (
            "a folder"
            if stat.S_ISDIR(mode)
            else "a FIFO"
            if stat.S_ISFIFO(mode)
            else "a device"
            if stat.S_ISCHR(mode) or stat.S_ISBLK(mode)
            else "not a regular file"
        )
        raise InputError("spec", f"{limit}; this is {what}", str(path))
    with os.fdopen(fd, "rb") as fh:
        try:
            data = fh.read(MAX_SPEC_BYTES + 1)
        except OSError as exc:
            raise InputError("spec", f"a readable TOML file ({exc.strerror})", str(path)) from None
    if len(data) > MAX_SPEC_BYTES:
        raise InputError("spec", f"{limit}; this file is larger", str(path))
    return data


def parse_spec(
    text: str,
    path: str | Path = "<string>",
    output: str | Path | None = None,
    validate: Validator | None = None,
    check_scenes: bool = True,
    accuracy: float | None = None,
) -> Spec:
    """Check the TOML ``text`` of a spec and build the ``Spec`` (see the module docstring and
    ``load_spec``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError("spec", f"valid TOML ({exc})", str(path)) from None
    except RecursionError:  # arrays or inline tables nested thousands deep
        raise InputError("spec", "TOML nested at most a few hundred levels deep", str(path)) from None
    _known_keys("", data, TABLES)
    tables = {}
    for name in TABLES:
        table = data.get(name, {})
        if not isinstance(table, dict):
            raise InputError(name, "a TOML table", table)
        tables[name] = table
    sweep, scene, numerics, axes_table, adaptive = (tables[name] for name in TABLES)
    _known_keys("sweep.", sweep, SWEEP_KEYS)
    _known_keys("numerics.", numerics, NUMERIC_KEYS)
    _known_keys("axes.", axes_table, AXIS_NAMES)
    for key in NUMERIC_KEYS:
        if key in scene:
            raise InputError(f"scene.{key}", "a numerical setting: put it in [numerics]", scene[key])

    fixed = {key: _normalize(f"scene.{key}", key, value) for key, value in scene.items()}
    fixed.update({key: _normalize(f"numerics.{key}", key, value) for key, value in numerics.items()})
    if accuracy is not None:  # the command line's request replaces the spec's grid and accuracy
        for key in ("n", "n_across"):
            fixed.pop(key, None)
        fixed["accuracy"] = _normalize("--accuracy", "accuracy", accuracy)
        if not 1e-9 <= fixed["accuracy"] < 1.0:
            raise InputError("--accuracy", ACCURACY_RANGE, accuracy)
    axes = tuple(_axis(name, value) for name, value in axes_table.items())
    base = Path(path).parent.absolute()
    fixed = _with_paths(fixed, base)
    axes = tuple(
        replace(a, fields=tuple(_with_paths(f, base) for f in a.fields))
        if a.name in LABEL_AXES or a.name in PATH_FIELDS
        else a
        for a in axes
    )
    total = math.prod(len(a) for a in axes)
    if total > MAX_POINTS:
        raise InputError(
            "axes",
            f"at most {MAX_POINTS} points, the product of the axes' lengths (this spec has "
            f"{' x '.join(str(len(a)) for a in axes)} = {total}); split it or coarsen an axis",
        )
    for axis in axes:
        section = "numerics" if axis.name in numerics else "scene"
        if axis.name in fixed:
            raise InputError(f"axes.{axis.name}", f"an axis or a fixed [{section}] field, not both")

    _refuse_grid_with_accuracy(fixed, axes, "--accuracy" if accuracy is not None else "numerics.accuracy")
    kind = kind_of(fixed)
    if not kind.accuracy_applies and ("accuracy" in fixed or any(a.name == "accuracy" for a in axes)):
        raise InputError(
            "--accuracy" if accuracy is not None else "numerics.accuracy",
            f"not with {kind.name} scenes ({kind.accuracy_refused})",
            fixed.get("accuracy"),
        )
    if kind.angle_mode_refused is not None:
        if "angle_mode" in sweep:
            raise InputError(
                "sweep.angle_mode",
                f"not used by {kind.name} scenes ({kind.angle_mode_refused})",
                sweep["angle_mode"],
            )
        angle_mode = ANGLE_FIELD
    else:
        angle_mode = sweep.get("angle_mode", "tensor")
        if angle_mode not in ANGLE_MODES:
            raise InputError("sweep.angle_mode", f"one of {', '.join(ANGLE_MODES)}", angle_mode)
        if angle_mode == "rotated" and not any(a.name == "angle" for a in axes):
            raise InputError("sweep.angle_mode", "'rotated' needs an angle axis in [axes]", angle_mode)
    interval = sweep.get("progress_interval", 10.0)
    if isinstance(interval, bool) or not isinstance(interval, (int, float)) or not interval > 0:
        raise InputError("sweep.progress_interval", "a number of seconds > 0", interval)
    title = sweep.get("title", Path(path).stem)
    if not isinstance(title, str):
        raise InputError("sweep.title", "a string", title)
    out = (
        Path(output)
        if output is not None
        else Path(_string("sweep.output", sweep.get("output", f"{Path(path).stem}.nc")))
    )
    if out.suffix != ".nc":
        raise InputError("output" if output is not None else "sweep.output", "a path ending in .nc", str(out))
    journal = (
        Path(_string("sweep.journal", sweep["journal"])) if "journal" in sweep else out.with_name(out.name + ".journal")
    )

    spec = Spec(
        path=Path(path),
        text=text,
        title=title,
        output=out,
        journal=journal,
        angle_mode=angle_mode,
        progress_interval=float(interval),
        fixed=fixed,
        axes=axes,
        kind=kind.name,
    )
    if "adaptive" in data:  # the solved subset of the grid (hpcontact.sweep.adaptive)
        spec = replace(spec, adaptive=parse_settings(adaptive, axes, axes_table, spec.task_axes))
    if check_scenes:
        for _ in scene_runs(spec, validate):
            pass
    return spec


def _refuse_grid_with_accuracy(fixed: Mapping[str, Any], axes: tuple[Axis, ...], key: str) -> None:
    """A requested accuracy picks its own grids (``hpcontact.accuracy.solve_to_accuracy``): a
    fixed grid beside it (``n``, ``n_across``, fixed or an axis) would be ignored, so it is
    refused."""
    names = set(fixed) | {a.name for a in axes}
    if "accuracy" not in names:
        return
    for grid in ("n", "n_across"):
        if grid in names:
            where = f"axes.{grid}" if grid not in fixed else f"numerics.{grid}"
            raise InputError(key, f"an accuracy or a grid ({where}), not both: an accuracy picks its own grids")


def _known_keys(prefix: str, table: Mapping[str, Any], allowed: tuple[str, ...]) -> None:
    for key in table:
        if key not in allowed:
            raise InputError(
                f"{prefix}{key}", f"unknown key; allowed: {', '.join(allowed)}{_did_you_mean(key, allowed)}"
            )


def _did_you_mean(key: Any, allowed: Any) -> str:
    """ "; did you mean X?" with the known name closest to an unknown ``key`` (difflib), else "".
    ``allowed``: the names, or a validator's "a known field (a, b, ...)" text."""
    import difflib

    if isinstance(allowed, str):  # the field list of an unknown-field message, else nothing to suggest
        allowed = (
            allowed[allowed.index("(") + 1 : -1].split(", ") if "field" in allowed and allowed.endswith(")") else []
        )
    close = difflib.get_close_matches(str(key), list(allowed), n=1, cutoff=0.6)
    return f"; did you mean {close[0]}?" if close and close[0] != key else ""


def _with_paths(fields: Mapping[str, Any], base: Path) -> Mapping[str, Any]:
    """``fields`` with every input file (``PATH_FIELDS``) made absolute: a relative path joined
    to ``base`` (the spec's folder), an absolute one unchanged."""
    if not any(name in fields for name in PATH_FIELDS):
        return fields
    return {k: str(base / v) if k in PATH_FIELDS and not Path(v).is_absolute() else v for k, v in fields.items()}


def _string(key: str, value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise InputError(key, "a non-empty string", value)
    return value


def _normalize(key: str, name: str, value: Any) -> Any:
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


def _axis(name: str, raw: Any) -> Axis:
    key = f"axes.{name}"
    if isinstance(raw, dict):
        values = _generated(key, raw)
    elif isinstance(raw, list):
        values = list(raw)
    else:
        raise InputError(key, "a list of values or a table {linspace = [start, stop, num]} / {logspace = ...}", raw)
    if not values:
        raise InputError(key, "at least one value (the axis is empty)")
    if name in LABEL_AXES:
        coords, fields = _label_values(key, name, values)
    else:
        if isinstance(raw, dict) and name in FLOAT_FIELDS and name not in FLAT_FIELDS:
            coords = tuple(values)  # floats already: _normalize has only finiteness to check
            finite = np.isfinite(np.array(coords, dtype=np.float64))
            if not finite.all():
                _normalize(key, name, coords[int(np.argmin(finite))])  # raises, as for a list
        else:
            coords = tuple(_normalize(key, name, v) for v in values)
        fields = PlainFields(name, coords)
    if len(set(coords)) != len(coords):
        raise InputError(key, "distinct values (a coordinate appears twice)", list(coords))
    return Axis(name=name, values=coords, fields=fields)


def _generated(key: str, raw: dict) -> list[float]:
    if len(raw) != 1 or next(iter(raw)) not in ("linspace", "logspace"):
        raise InputError(key, "a table with one key: linspace or logspace", raw)
    kind, args = next(iter(raw.items()))
    ok = (
        isinstance(args, list)
        and len(args) == 3
        and all(isinstance(a, (int, float)) and not isinstance(a, bool) and math.isfinite(a) for a in args)
        and isinstance(args[2], int)
    )
    if not ok:
        raise InputError(f"{key}.{kind}", "[start, stop, num] with finite numbers and an integer num", args)
    start, stop, num = args
    if num < 1:
        raise InputError(f"{key}.{kind}", "num >= 1 (the axis is empty)", args)
    if num > MAX_POINTS:
        raise InputError(f"{key}.{kind}", f"num <= {MAX_POINTS} (the most points a spec may have)", args)
    make = np.linspace if kind == "linspace" else np.logspace
    # 15 significant digits drop the generator's last-bit error (0.30000000000000004 -> 0.3,
    # 9.999999999999999e-05 -> 1e-4) so that labels select exactly: ds.sel(nu=0.3)
    return list(map(float, map("{:.15g}".format, make(float(start), float(stop), num, dtype=np.float64).tolist())))


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
        fields.append({k: _normalize(f"{where}.{k}", k, v) for k, v in value.items() if k != "label"})
    return tuple(coords), tuple(fields)


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
    from, at the first bad point in C order. In a range of more than ``SCENE_CHECK_POINTS``
    points, the kind's own validator sees a run of three or more points of a field whose valid
    values form an interval (``kinds.interval_fields``) at its extreme values and branch values
    only: both valid, every value between is; one refused, a bisection from a valid value finds
    the interval's ends and the first point outside it is validated, raising the same error as a
    check of every scene (``_first_refused``)."""
    axes = spec.task_axes
    total = math.prod(len(a) for a in axes)
    stop = total if stop is None else min(stop, total)
    checker = _Check(spec, validate, stop - start > SCENE_CHECK_POINTS) if check else None
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
        _drop_ignored_material_fields(reduced)
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
        _drop_ignored_material_fields(params)
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
            hint = _did_you_mean(exc.field, exc.allowed)  # an unknown [scene] field: the closest known one
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
