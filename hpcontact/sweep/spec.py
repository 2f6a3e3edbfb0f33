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
    n = 128
    n_across = 16
    tol = 1e-10

    [axes]                           # the parameter space: a Cartesian product
    shape = ["ellipse", "rectangle", { label = "hexagon", shape = "polygon", sides = 6 }]
    aspect = { logspace = [0, -8, 9] }      # numpy.logspace(start, stop, num): 1 … 1e-8
    nu = [0.1, 0.3, 0.5]
    angle = { linspace = [0, 180, 37] }     # numpy.linspace(start, stop, num)

Axis names are those of docs/design.md §1 (``shape angle nu aspect anisotropy orientation``), ``material``
(library crystal names, a string coordinate: ``material = ["Cu", "Al", "W"]``), plus ``n`` and
``tol`` for accuracy studies. Crystal scenes::

    [scene]                          # Rodríguez-Tembleque et al. 2011: sphere on a cubic crystal
    quantities = ["indentation"]
    radius = 1.0                     # rigid sphere radius R and approach d (fixed fields)
    depth = 1e-4
    [axes]
    anisotropy = [0.5, 1, 2]         # cubic from (nu, A), (C11 - C12)/2 = G
    orientation = { linspace = [0, 90, 19] }   # psi along [110] -> [111] -> [001]

A field the scene ignores is left out of its parameters, so equal scenes are solved once: at
A = 1 without a named crystal the body is isotropic and ``orientation``, ``miller`` and
``azimuth`` are dropped; with a named ``material`` its library constants hold and ``nu``,
``G`` and ``anisotropy`` are dropped (both after validation, so a bad value is still refused). A ``shape`` value is a shape name or a table with a ``label``
(its coordinate in the data set) and scene fields (``shape``, ``sides``, ``aspect``, …); fields
of such a table win over the other axes. Anything unknown, empty, duplicated or impossible is
refused with an ``InputError`` naming the key (``axes.nu``, ``scene.G``, …), so a bad spec never
reaches a rank's work loop. Values are checked by the scene's own validator for every distinct
scene of the sweep.

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
import tomllib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from hpcontact.errors import InputError
from hpcontact.materials.elastic_constants import FAMILIES as CONSTANT_FAMILIES
from hpcontact.problems.kinds import CONTACT, SLIP, scene_kind, validator

TABLES = ("sweep", "scene", "numerics", "axes")
SWEEP_KEYS = ("title", "output", "journal", "angle_mode", "progress_interval")
NUMERIC_KEYS = ("n", "n_across", "tol")
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
    "pair",
    "load",
    "mu",
    "q_ratio",
    "orientation2",
    "anisotropy2",
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
#: and checking a point costs ~10-30 µs and its task ~0.5 kB (a dry run of 10^6 points: see
#: ``scene_texts``), so 10^7 points take minutes and gigabytes; a larger spec is refused before
#: anything is enumerated (split it, or coarsen an axis).
MAX_POINTS = 10**7
PROGRESS_POINTS = 100_000  # points between calls of scene_texts' progress callback
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
    fields: tuple[Mapping[str, Any], ...]

    def __len__(self) -> int:
        return len(self.values)


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
        for table in tables:
            params.update(table)
        if angle is not None:
            params["shape_angle"] = float(params.get("shape_angle", 0.0)) - angle
        if self.kind == CONTACT:
            if "shape" in params:
                for name, shapes in SHAPE_ONLY_FIELDS.items():
                    if name in params and params["shape"] not in shapes:
                        del params[name]
            if reduce_material:
                _drop_ignored_material_fields(params)
        return params


def _drop_ignored_material_fields(params: dict[str, Any]) -> None:
    """Leave out the material fields ``hpcontact.scene`` ignores for these parameters: nu, G
    and A of a body given otherwise (a library crystal or elastic constants), the orientation
    of an isotropic body (A = 1 and neither a library crystal nor constants)."""
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
    path: str | Path, output: str | Path | None = None, validate: Validator | None = None, check_scenes: bool = True
) -> Spec:
    """Read and check the spec at ``path``; ``output`` overrides [sweep].output.

    ``validate`` checks one scene's parameters (default: the validator of the spec's scene kind,
    ``kinds.validator``); it runs on every distinct scene of the sweep, so impossible values are
    refused up front. With ``check_scenes`` false the scenes are left to the caller (``scenes``:
    the driver spreads them over the ranks and checks them while it enumerates the tasks).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError("spec", f"a readable TOML file ({exc.strerror})", str(path)) from None
    except UnicodeDecodeError as exc:
        raise InputError("spec", f"a TOML file in UTF-8 (byte {exc.start} is not UTF-8)", str(path)) from None
    if not any(line.strip() and not line.lstrip().startswith("#") for line in text.splitlines()):
        raise InputError("spec", "a TOML spec with content (this file is empty or holds only comments)", str(path))
    return parse_spec(text, path=path, output=output, validate=validate, check_scenes=check_scenes)


def parse_spec(
    text: str,
    path: str | Path = "<string>",
    output: str | Path | None = None,
    validate: Validator | None = None,
    check_scenes: bool = True,
) -> Spec:
    """Check the TOML ``text`` of a spec and build the ``Spec`` (see the module docstring and
    ``load_spec``)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError("spec", f"valid TOML ({exc})", str(path)) from None
    _known_keys("", data, TABLES)
    tables = {}
    for name in TABLES:
        table = data.get(name, {})
        if not isinstance(table, dict):
            raise InputError(name, "a TOML table", table)
        tables[name] = table
    sweep, scene, numerics, axes_table = (tables[name] for name in TABLES)
    _known_keys("sweep.", sweep, SWEEP_KEYS)
    _known_keys("numerics.", numerics, NUMERIC_KEYS)
    _known_keys("axes.", axes_table, AXIS_NAMES)
    for key in NUMERIC_KEYS:
        if key in scene:
            raise InputError(f"scene.{key}", "a numerical setting: put it in [numerics]", scene[key])

    fixed = {key: _normalize(f"scene.{key}", key, value) for key, value in scene.items()}
    fixed.update({key: _normalize(f"numerics.{key}", key, value) for key, value in numerics.items()})
    axes = tuple(_axis(name, value) for name, value in axes_table.items())
    base = Path(path).parent.absolute()
    fixed = _with_paths(fixed, base)
    axes = tuple(replace(a, fields=tuple(_with_paths(f, base) for f in a.fields)) for a in axes)
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

    kind = scene_kind(fixed)
    if kind == SLIP:
        if "angle_mode" in sweep:
            raise InputError(
                "sweep.angle_mode",
                "not used by slip scenes (angle is the load direction, solved per value)",
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
        kind=kind,
    )
    if check_scenes:
        for _ in scenes(spec, validate):
            pass
    return spec


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
        coords = tuple(_normalize(key, name, v) for v in values)
        fields = tuple({name: v} for v in coords)
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
    return [float(f"{v:.15g}") for v in make(float(start), float(stop), num, dtype=np.float64)]


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


def scenes(
    spec: Spec, validate: Validator | None = None, start: int = 0, stop: int | None = None, check: bool = True
) -> Iterator[tuple[tuple[int, ...], dict[str, Any]]]:
    """The points ``start`` … ``stop - 1`` of the task axes (0-based positions in the C order of
    ``Spec.points``) with their scene parameters (``Spec.scene_params``); with ``check``, the
    validator (``validate``, default: the scene kind's) runs once per distinct scene of the range
    first, and a bad field raises ``InputError`` naming the spec key it came from.

    Scenes are validated before ignored material fields are dropped, so an impossible
    orientation is refused even at A = 1."""
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
    task key's text), made once per point; ``progress(done)`` is called every
    ``PROGRESS_POINTS`` points of the range. The validator runs once per distinct scene of
    the range (distinct before ignored material fields are dropped, as ``scenes``)."""
    if check and validate is None:
        validate = validator(spec.kind)
    seen: set[str] = set()
    contact = spec.kind == CONTACT
    for done, index in enumerate(itertools.islice(spec.points(), start, stop)):
        if progress is not None and done and not done % PROGRESS_POINTS:
            progress(done)
        params = spec.scene_params(index, reduce_material=False)
        text = canonical_json(params)
        if check and text not in seen:
            seen.add(text)
            try:
                validate(dict(params))
            except InputError as exc:
                hint = _did_you_mean(exc.field, exc.allowed)  # an unknown [scene] field: the closest known one
                raise InputError(_locate(spec, index, exc.field), exc.allowed + hint, exc.value) from None
        if contact:
            fields = len(params)
            _drop_ignored_material_fields(params)
            if len(params) != fields:
                text = canonical_json(params)
        yield index, params, text


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
