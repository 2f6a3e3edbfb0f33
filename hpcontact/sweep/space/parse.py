"""Sweep job spec: a TOML file → axes, fixed scene fields and settings, checked before any work.

A spec has four tables (docs/design.md §1, §4.2; every key is optional except one axis or a fixed scene)::

    [sweep]                          # how the sweep runs
    title = "Li 2017, Fig. 7"
    output = "results/aspect.nc"     # relative to the working directory; --output overrides (default: beside the spec)
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

Axis names are the fields the schema marks as axes (``hpcontact.fields.axis_names``: those of
docs/design.md §1, ``shape angle nu aspect anisotropy orientation``; ``material``, library crystal
names, a string coordinate: ``material = ["Cu", "Al", "W"]``; a string field's choices; ``n``,
``tol`` and ``accuracy`` for accuracy studies; a slip scene's) and ``pair``. Crystal scenes::

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
scene of the sweep, except in a spec of more than ``SCENE_CHECK_POINTS`` points (in every
rank's share of it too) along its last axis when that axis is a field whose valid values form
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

import json
import math
import numbers
import os
import re
import stat
import tomllib
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from hpcontact import fields
from hpcontact.errors import InputError, Option, did_you_mean
from hpcontact.numerics.backend import require_gpu
from hpcontact.problems.kinds import kind_of
from hpcontact.scene import ACCURACY_RANGE
from hpcontact.sweep.run.options import ACCURACY
from hpcontact.sweep.space.adaptive_settings import parse_settings
from hpcontact.sweep.space.axes import (
    AXIS_NAMES,
    LABEL_AXES,
    MAX_POINTS,
    MAX_TASK_POINTS,
    PATH_FIELDS,
    Axis,
    axis_length,
    normalize,
    parse_axis,
    with_paths,
)
from hpcontact.sweep.space.enumeration import scene_runs
from hpcontact.sweep.space.spec import (
    ANGLE_FIELD,
    ANGLE_MODES,
    DICT_SPEC_PATH,
    NUMERIC_KEYS,
    SWEEP_KEYS,
    TABLES,
    Spec,
    Validator,
    default_output,
    default_title,
)

#: The largest spec file read (bytes): the shipped specs are a few kB, and an explicit axis of
#: 10**6 values (a tenth of ``MAX_POINTS``) is ~10 MB of TOML; a larger file, or one that is not
#: a regular file (/dev/zero, a FIFO, a folder), is refused before it is read.
MAX_SPEC_BYTES = 16 * 2**20


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
    return spec_of_tables(data, text, path, output, validate, check_scenes, accuracy)


#: The deepest nesting of a spec given as a dict (tables, inline tables, lists): a spec uses 3
#: or 4 levels ([axes] → label table → list of tables → fields); deeper is a mistake, and far
#: deeper (thousands) would exhaust Python's recursion before anything could name it.
MAX_SPEC_DEPTH = 64


def parse_spec_dict(
    spec: Mapping[str, Any],
    path: str | Path = DICT_SPEC_PATH,
    output: str | Path | None = None,
    validate: Validator | None = None,
    check_scenes: bool = True,
    accuracy: float | None = None,
) -> Spec:
    """A spec given as a dict of its tables (``hpcontact.run_sweep``), checked as its TOML file
    would be (``parse_spec``) but read directly: its points are counted from its axes'
    descriptions first (``check_points``: nothing is expanded or copied before), then its values
    are taken as TOML's types (``plain_tables``); its ``text``, the data set's record of the
    spec, is the TOML that states it (``toml_text``), written, never read back."""
    axes = spec.get("axes") if isinstance(spec, Mapping) else None
    if isinstance(axes, Mapping):
        check_points(axes)
    tables = plain_tables(spec)
    return spec_of_tables(tables, toml_text(tables), path, output, validate, check_scenes, accuracy)


def check_points(axes: Mapping[str, Any]) -> None:
    """``InputError`` naming ``axes`` when the product of the lengths of the axes described by
    ``axes`` (a spec's ``[axes]`` table) exceeds ``MAX_POINTS``; each length is read from the
    description (``axes.axis_length``), so no axis is made first."""
    lengths = [axis_length(str(name), raw) for name, raw in axes.items()]
    total = math.prod(lengths)
    if total > MAX_POINTS:
        raise InputError(
            "axes",
            f"at most {MAX_POINTS} points, the product of the axes' lengths (this spec has "
            f"{' x '.join(map(str, lengths))} = {total}); split it or coarsen an axis",
        )


TOML_VALUE = "a TOML value: a string, number, boolean, list or table (leave a key out for the default)"


def plain_tables(spec: Mapping[str, Any]) -> dict[str, Any]:
    """A spec given as a dict in TOML's types, as ``tomllib`` would return its TOML text: string
    keys, bools (numpy's too), ints (any ``numbers.Integral``), floats (any other
    ``numbers.Real``), strings (``os.PathLike`` as its path), lists (tuples, numpy arrays) and
    dicts (any ``Mapping``). Anything else (None, another object), a key that is not a string,
    nesting deeper than ``MAX_SPEC_DEPTH`` and a value that contains itself are refused with an
    ``InputError`` naming the key."""
    return _plain(spec, "", 0, ())


def _plain(value: Any, where: str, depth: int, ancestors: tuple[int, ...]) -> Any:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        return float(value)
    if isinstance(value, (str, os.PathLike)):
        return os.fspath(value)
    if isinstance(value, np.ndarray):
        return _plain(value.tolist(), where, depth, ancestors)
    if not isinstance(value, (Mapping, list, tuple)):
        raise InputError(where or "spec", TOML_VALUE, value)
    if id(value) in ancestors:
        raise InputError(where or "spec", "a spec without cycles: this value contains itself")
    if depth >= MAX_SPEC_DEPTH:
        raise InputError(
            f"{where[:200]}..." if len(where) > 200 else where,
            f"a spec nested at most {MAX_SPEC_DEPTH} levels deep (tables, lists)",
        )
    inner = (*ancestors, id(value))
    if isinstance(value, Mapping):
        for key in value:
            if not isinstance(key, str):
                raise InputError("spec", "string keys (a spec as a dict has the structure of its TOML file)", key)
        return {k: _plain(v, f"{where}.{k}" if where else k, depth + 1, inner) for k, v in value.items()}
    if all(type(v) is float for v in value):  # a long axis of floats: already TOML's (a copy)
        return list(value)
    return [_plain(v, where, depth + 1, inner) for v in value]


def toml_text(tables: Mapping[str, Any]) -> str:
    """The TOML text of a spec given as a dict: its tables of ``key = value`` (nested mappings
    inline), in TOML's types (``plain_tables``, which refuses what TOML cannot hold), so that
    ``tomllib`` reads back ``plain_tables(tables)``."""
    tables = plain_tables(tables)
    lines = [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in tables.items() if not isinstance(v, dict)]
    for table, values in tables.items():
        if isinstance(values, dict):
            lines.append(f"[{_toml_key(table)}]")
            lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in values.items()]
    return "\n".join(lines) + "\n"


def _toml_key(key: str) -> str:
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else _toml_string(key)


def _toml_string(text: str) -> str:
    return json.dumps(text, ensure_ascii=False).replace("\x7f", "\\u007f")


def _toml_value(value: Any) -> str:
    """One value of ``plain_tables``'s types as TOML."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else "nan" if math.isnan(value) else "inf" if value > 0 else "-inf"
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, dict):
        items = ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items())
        return f"{{ {items} }}" if items else "{}"
    return "[" + ", ".join(map(_toml_value, value)) + "]"


def spec_of_tables(
    data: Mapping[str, Any],
    text: str,
    path: str | Path = "<string>",
    output: str | Path | None = None,
    validate: Validator | None = None,
    check_scenes: bool = True,
    accuracy: float | None = None,
) -> Spec:
    """The ``Spec`` of the tables ``data`` (TOML's types: ``tomllib``'s or ``plain_tables``'s)
    whose text is ``text`` (``parse_spec``, ``parse_spec_dict``)."""
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
    _fixed_fields_off_the_axes(axes_table)
    _known_keys("axes.", axes_table, AXIS_NAMES)
    check_points(axes_table)  # counted before any axis is made
    for key in NUMERIC_KEYS:
        if key in scene:
            raise InputError(f"scene.{key}", "a numerical setting: put it in [numerics]", scene[key])

    fixed = {key: normalize(f"scene.{key}", key, value) for key, value in scene.items()}
    fixed.update({key: normalize(f"numerics.{key}", key, value) for key, value in numerics.items()})
    if accuracy is not None:  # the command line's request replaces the spec's grid and accuracy
        for key in ("n", "n_across"):
            fixed.pop(key, None)
        fixed["accuracy"] = normalize(ACCURACY, "accuracy", accuracy)
        if not 1e-9 <= fixed["accuracy"] < 1.0:
            raise InputError(ACCURACY, ACCURACY_RANGE, accuracy)
    kind = kind_of(fixed)
    if fixed.get("device") == "gpu":
        require_gpu()  # where CuPy or a CUDA device is missing, refused before anything runs
    tensor = kind.angle_mode_refused is None and sweep.get("angle_mode", "tensor") == "tensor"
    _check_task_points(axes_table, tensor)  # counted before any axis is made, as the points
    axes = tuple(parse_axis(name, value) for name, value in axes_table.items())
    base = Path(path).parent.absolute()
    fixed = with_paths(fixed, base)
    axes = tuple(
        replace(a, fields=tuple(with_paths(f, base) for f in a.fields))
        if a.name in LABEL_AXES or a.name in PATH_FIELDS
        else a
        for a in axes
    )
    for axis in axes:
        section = "numerics" if axis.name in numerics else "scene"
        if axis.name in fixed:
            raise InputError(f"axes.{axis.name}", f"an axis or a fixed [{section}] field, not both")

    accuracy_key = ACCURACY if accuracy is not None else "numerics.accuracy"
    _refuse_grid_with_accuracy(fixed, axes, accuracy_key)
    if not kind.accuracy_applies and ("accuracy" in fixed or any(a.name == "accuracy" for a in axes)):
        raise InputError(
            accuracy_key,
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
    title = sweep.get("title", default_title(path, axes))
    if not isinstance(title, str):
        raise InputError("sweep.title", "a string", title)
    out = (
        Path(output)
        if output is not None
        else Path(_string("sweep.output", sweep["output"]))
        if "output" in sweep
        else default_output(path, title, text)
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
    if "adaptive" in data:  # the solved subset of the grid (hpcontact.sweep.maps)
        spec = replace(spec, adaptive=parse_settings(adaptive, axes, axes_table, spec.task_axes))
    if check_scenes:
        for _ in scene_runs(spec, validate):
            pass
    return spec


def _check_task_points(axes: Mapping[str, Any], tensor: bool) -> None:
    """``InputError`` naming ``axes`` when the points that each need a solve (the product of the
    lengths of the axes described by the ``[axes]`` table ``axes``, but ``angle`` where
    ``tensor``: the angles of a tensor need no solve, ``Spec.task_axes``) exceed
    ``MAX_TASK_POINTS``; lengths read from the descriptions (``axes.axis_length``)."""
    lengths = [axis_length(name, raw) for name, raw in axes.items() if not (tensor and name == "angle")]
    total = math.prod(lengths)
    if total > MAX_TASK_POINTS:
        raise InputError(
            "axes",
            f"at most {MAX_TASK_POINTS} points that each need a solve, the product of the lengths of the "
            f"axes but a tensor's angle (this spec has {' x '.join(map(str, lengths))} = {total}); split it "
            f"or coarsen an axis",
        )


def _refuse_grid_with_accuracy(fixed: Mapping[str, Any], axes: tuple[Axis, ...], key: str | Option) -> None:
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


def _fixed_fields_off_the_axes(axes_table: Mapping[str, Any]) -> None:
    """A scene field that no axis runs over (``hpcontact.fields``: ``axis`` False) under [axes]:
    refused saying where it goes: in [scene] (a numerical setting in [numerics]), or in the labelled entries (``LABEL_AXES``) of
    ``shape`` for a field a shape reads (``{ label = "triangle", shape = "polygon", sides = 3 }``)
    and of ``pair`` for a slip scene's own."""
    for key in axes_table:
        if key in AXIS_NAMES or key not in fields.names():
            continue
        declared = fields.field(key)
        if declared.read_by is not None and declared.read_by[0] == "shape":
            entries = (
                f' or per entry of axes.shape ({{ label = "...", shape = "{declared.read_by[1][0]}", {key} = ... }})'
            )
        elif fields.CONTACT not in declared.kinds:
            entries = ' or per entry of axes.pair ({ label = "...", ' + key + " = ... })"
        else:
            entries = ""
        table = "[numerics]" if key in NUMERIC_KEYS else "[scene]"
        raise InputError(f"axes.{key}", f"not a sweep axis: fix it in {table}{entries}")


def _known_keys(prefix: str, table: Mapping[str, Any], allowed: tuple[str, ...]) -> None:
    for key in table:
        if key not in allowed:
            raise InputError(
                f"{prefix}{key}", f"unknown key; allowed: {', '.join(allowed)}{did_you_mean(key, allowed)}"
            )


def _string(key: str, value: Any) -> str:
    if not isinstance(value, str) or not value:
        raise InputError(key, "a non-empty string", value)
    return value
