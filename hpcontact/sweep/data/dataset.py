"""Journal entries → labelled xarray Dataset (docs/design.md §4.2, docs/reference/dataset.md) → netCDF4.

Dimensions are the spec's axes in spec order, each a coordinate with CF ``units`` and
``long_name``; fixed scalar fields of the spec become scalar coordinates. Data variables are the
keys of the task records (float64, NaN where a task failed; non-numeric values such as ``plan``
as JSON text), plus ``status`` (0 ok; ``flag_values``/``flag_meanings``), ``message`` and
``wall_time_s`` per task. Values are gathered once per task and spread to every point the task
serves (points that share a scene share its record). A record key
that names a coordinate (a slip record's ``load`` on a ``load`` axis, say) is left out where it
equals the coordinate at every point, and kept as ``record_<key>`` where it does not (a label
table overrode the field). String fields (``material``, ...: ``fields.of_type(str)``) and label axes (``pair``) are string coordinates. A field that
label tables set (``radius2`` of a ``pair`` table, ``sides`` of a ``shape`` table) is a
coordinate along the label axes that set it (the table's value, else the fixed one, else NaN or
""), not a scalar: a fixed value a table overrides is never reported for every point. Attributes
follow the spec's scene kind (``kinds``). Contact scenes: stresses in G (the shear modulus,
(C11 − C12)/2 of a cubic crystal from (nu, A)), or GPa when the scenes name library crystals;
punch lengths in a (the semi-major extent, 1 on the grid); indentation lengths in L, the unit
the spec gives the sphere's radius and depth in. Slip scenes (``hpcontact.problems.slip.partial_slip``): forces in N,
lengths in m, stiffnesses in N/m, areas in m² when the scenes name library materials (SI), else
in the force and length units of the input (F, L). The tables below write units that way;
``units.cf_attributes`` turns a unit in scene scales (G, a, L, F) into ``units = "1"`` with the
scale in ``scale``, ``comment`` and ``long_name``, so every unit parses with UDUNITS as what it
means (the convention: ``hpcontact.sweep.data.units``, and the data set's global ``comment``).

A contact spec without ``n`` (neither fixed nor an axis) is solved as ``accuracy.default_solve``
says (``kinds``): an elliptical contact on its exact cell, a slender rectangle on strips,
elsewhere the extrapolated default
wherever it applies: the data set
then has no ``n`` coordinate; ``nx``, ``ny``, ``dx``, ``dy`` are the *finest* grid's (256 cells
along the long side, ``grid_sequence``'s across: 256 × 128 for b/a = 0.5), ``grids`` and
``grids_across`` the JSON lists of every grid solved, ``estimated_error`` the estimated relative
error of the extrapolated K (NaN for tasks solved on one grid), ``accuracy_met`` whether it is
≤ 1e-4 and ``stopped_by`` why the sequence ended. A task the default does not extrapolate (a
rough patch, a mask) is one grid of n = 128 as before; a crystal's outline extrapolates as an
isotropic one's (until 2026-11-30 it was one grid).

With an ``angle`` axis and a tangential tensor, ``derive_directional`` adds the stiffness along
the load direction ``K_nn`` (and Li's ``normalized_nn``): K_nn = nᵀ K n in tensor mode, K_xx of
the shape turned by −angle in rotated mode. ``write_netcdf`` stores them with the rest
(``netcdf.write``: compressed, typed, atomic; derived there when the data set lacks them), so
plain ``xarray.open_dataset`` and ``ncdump`` show K_nn over ``angle`` and ``plan`` as text;
``open_dataset`` reads the file back as the data set ``build_dataset`` made (and derives K_nn
only for files written before it was stored).

Global attributes: CF's ``title``, ``Conventions``, ``source`` (the code and its method),
``references`` (the code and the papers its method follows), ``comment`` (the units
convention) and ``history``: one line per run, "<created>: <command>", the command as it was
given (``invocation``: the process's command line for ``hpcontact run``, the call for
``hpcontact.run_sweep(...)``); a ``--resume`` run appends its line to the history of the data
set it replaces.
"""

from __future__ import annotations

import functools
import json
import numbers
import re
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hpcontact import __version__, fields
from hpcontact.quantities import ERROR_SUFFIX, ESTIMATED, directional_error, directional_stiffness
from hpcontact.sweep.data import netcdf
from hpcontact.sweep.data.attributes import (
    ERROR_MET,
    ERROR_NOT_MET,
    ERROR_STATUS_MEANINGS,
    METHODS,
    NO_ESTIMATE,
    REFERENCES,
    SLIP_ATTRS,
    SOFTWARE,
    STATUS_MEANINGS,
    UNIT_ATTRIBUTES,
    VARIABLE_ATTRS,
    attribute_table,
    error_attributes,
)
from hpcontact.sweep.data.columns import NOT_COMPUTED, Joined, join, task_positions, to_columns
from hpcontact.sweep.data.columns import is_number as _is_number
from hpcontact.sweep.data.journal import Entry, to_json
from hpcontact.sweep.data.units import cf_attributes, convention, scale_symbols
from hpcontact.sweep.run.options import RESUME
from hpcontact.sweep.space.axes import LABEL_AXES
from hpcontact.sweep.space.spec import Spec

if TYPE_CHECKING:  # xarray is imported where a data set is made: a rank that never makes one never imports it
    import xarray as xr

__all__ = [  # the attribute tables are hpcontact.sweep.data.attributes'; importers may take them from here
    "DIRECTIONAL",
    "ERROR_MET",
    "ERROR_STATUS_MEANINGS",
    "FIXED_VARIABLES",
    "NOT_COMPUTED",
    "SLIP_ATTRS",
    "STATUS_MEANINGS",
    "TENSOR",
    "VARIABLE_ATTRS",
    "DamagedFile",
    "build_dataset",
    "dataset_of",
    "derive_directional",
    "directional_errors",
    "error_attributes",
    "import_array_modules",
    "link_errors",
    "open_dataset",
    "stiffness_record",
    "stored_stiffnesses",
    "write_netcdf",
]

FIXED_VARIABLES = ("status", "message", "wall_time_s")  # per task, whatever its record holds

TENSOR = ("K_xx", "K_xy", "K_yx", "K_yy")
DIRECTIONAL = ("K_nn", "normalized_nn")  # derived from the tensor (stored in the file)


def build_dataset(
    spec: Spec,
    where: Mapping[tuple[int, ...], str],
    entries: Mapping[str, Entry],
    attrs: Mapping[str, Any],
    command: str | None = None,
) -> xr.Dataset:
    """The data set of ``spec`` from the journal ``entries``; ``where`` maps each point of the
    task axes to its task key (``tasks.enumerate_tasks``); ``attrs`` are global attributes,
    ``command`` the command as its user gave it (``history_attribute``)."""
    keys, task_of = task_positions(where, tuple(len(a) for a in spec.task_axes))
    found = [(entries[key], at) for at, key in enumerate(keys) if key in entries]
    parts = [to_columns([e for e, _ in found], [at for _, at in found])] if found else []
    return dataset_of(spec, task_of, join(parts, len(keys), FIXED_VARIABLES), attrs, command=command)


def dataset_of(
    spec: Spec,
    task_of: np.ndarray,
    joined: Joined,
    attrs: Mapping[str, Any],
    derive: bool = True,
    command: str | None = None,
) -> xr.Dataset:
    """The data set of ``spec`` from the per-task arrays ``joined`` (``columns.join``);
    ``task_of`` gives each point of the task axes its task (0-based position), ``attrs`` are
    global attributes; with ``derive``, K_nn and normalized_nn (``derive_directional``; without,
    ``write_netcdf`` derives them). Values are spread from tasks to points by index."""
    import xarray as xr

    axes = spec.task_axes
    dims = tuple(a.name for a in axes)
    shape = tuple(len(a) for a in axes)

    def spread(values: np.ndarray) -> np.ndarray:
        return values[task_of]

    variables: dict[str, tuple[tuple[str, ...], np.ndarray]] = {
        "status": (dims, spread(joined.status)),
        "message": (dims, spread(joined.message)),
        "wall_time_s": (dims, spread(joined.wall_time_s)),
    }
    coords: dict[str, Any] = {a.name: (a.name, _coordinate(a.name, a.values)) for a in spec.axes}
    for name, value in spec.fixed.items():
        if _is_number(value) or isinstance(value, str):
            coords[name] = ((), np.int32(value) if isinstance(value, numbers.Integral) else value)
    coords.update(_label_coordinates(spec))
    renamed: dict[str, str] = {}
    for name, values in joined.records.items():
        array = spread(values)
        if name in coords:
            if _equals_coordinate(array, _coordinate_grid(coords[name], dims, shape)):
                continue  # the coordinate already says it
            renamed[f"record_{name}"] = name
            name = f"record_{name}"
        variables[name] = (dims, array)

    ds = xr.Dataset(variables, coords=coords)
    table = attribute_table(spec)
    for name in ds.variables:
        variable_attrs = dict(table.get(renamed.get(name, name), {}))
        if name in renamed and "long_name" in variable_attrs:
            variable_attrs["long_name"] = f"{variable_attrs['long_name']} (task record; differs from the coordinate)"
        ds[name].attrs.update(variable_attrs)
    ds = link_errors(ds, spec.kind_record.estimated)
    scales = {s for name in ds.variables for s in scale_symbols(str(ds[name].attrs.get("scale", "")))}
    ds.attrs.update(_global_attrs(spec, attrs, scales, command))
    return derive_directional(ds) if derive else ds


def stored_stiffnesses(spec: Spec, task_of: np.ndarray, joined: Joined) -> dict[str, np.ndarray]:
    """The stiffnesses of ``dataset_of(spec, task_of, joined)`` alone, as float64 arrays over the
    task axes by name: the record variables the scene kind's estimated pattern matches and their
    ``<name>_error`` (NaN where no record carries it, as ``link_errors`` adds it), the same values
    in the same order, and nothing else. An adaptive round decides from these (``maps.rounds``)
    without xarray, which rank 0 imports during a round with work enough to cover it
    (``run.rounds``); only the map's last round builds the whole data set (146 475 points, ~60
    variables on the 4-D map, rank 0 alone while the other ranks wait)."""
    out = {
        name: np.asarray(values[task_of], dtype=np.float64)
        for name, values in joined.records.items()
        if stiffness_record(spec, name)
    }
    pattern = spec.kind_record.estimated
    for name in [n for n in out if pattern.match(n) and not n.endswith(ERROR_SUFFIX)]:
        if f"{name}{ERROR_SUFFIX}" not in out:
            out[f"{name}{ERROR_SUFFIX}"] = np.full(task_of.shape, np.nan)
    return out


def import_array_modules() -> None:
    """Import now xarray and what it imports at the first data set a process makes: the array
    libraries it knows at the first variable, dask.array where it is installed (xarray 0.5-0.6
    and dask 0.2-0.4 CPU s on the 2-core development VM), and those it looks for at the first
    coordinate's index, pint where it is installed (0.08-0.15 s), once a process. Rank 0 calls
    it during a round whose work covers it (``run.rounds``), so that its data set, made while
    every other rank waits, does not import them."""
    import xarray as xr

    xr.Dataset({"value": ("point", np.zeros(1))}, coords={"point": np.zeros(1)})


def stiffness_record(spec: Spec, name: str) -> bool:
    """Whether the record key ``name`` is one of ``stored_stiffnesses``': a stiffness of the
    spec's scene kind (``Kind.estimated``) or its ``<name>_error``."""
    pattern = spec.kind_record.estimated
    return bool(pattern.match(name) or pattern.match(name.removesuffix(ERROR_SUFFIX)))


def link_errors(ds: xr.Dataset, stiffnesses: re.Pattern[str] = ESTIMATED) -> xr.Dataset:
    """``ds`` with an estimated relative error ``<name>_error`` beside every stiffness it stores
    (the names ``stiffnesses`` matches: ``ESTIMATED`` for contact sweeps, ``SLIP_ESTIMATED``
    for slip sweeps; NaN where a task has none: one grid, a slip scene, a failed task), linked
    from it by CF ``ancillary_variables`` = "<name>_error error_status", and the flag variable
    ``error_status`` (``ERROR_STATUS_MEANINGS``) over the task axes."""
    import xarray as xr

    names = [v for v in ds.data_vars if stiffnesses.match(str(v)) and not str(v).endswith(ERROR_SUFFIX)]
    if not names:
        return ds
    estimated = (
        np.isfinite(ds["estimated_error"].values) if "estimated_error" in ds else np.zeros(ds["status"].shape, bool)
    )
    met = ds["accuracy_met"].values == "true" if "accuracy_met" in ds else np.zeros_like(estimated)
    status = np.where(estimated, np.where(met, ERROR_MET, ERROR_NOT_MET), NO_ESTIMATE).astype(np.int32)
    out = ds.assign(error_status=(ds["status"].dims, status))
    out["error_status"].attrs.update(VARIABLE_ATTRS["error_status"])
    for name in names:
        error = f"{name}{ERROR_SUFFIX}"
        if error not in out:
            out[error] = xr.full_like(out[name], np.nan, dtype=np.float64)
        out[error].attrs = error_attributes(name)
        out[name].attrs["ancillary_variables"] = f"{error} error_status"
    return out


def _label_coordinates(spec: Spec) -> dict[str, tuple[tuple[str, ...], np.ndarray]]:
    """Fields set by label tables (``LABEL_AXES``; not axis names) as coordinates over the label
    axes that set them: the value of the last table setting it (the order of
    ``Spec.scene_params``), else the fixed value, else missing (NaN, or "" for text)."""
    label_axes = [a for a in spec.task_axes if a.name in LABEL_AXES]
    axis_names = {a.name for a in spec.axes}
    out: dict[str, tuple[tuple[str, ...], np.ndarray]] = {}
    for name in dict.fromkeys(k for a in label_axes for table in a.fields for k in table):
        if name in axis_names:
            continue  # the axis coordinate stands (a shape table's shape)
        setting = [a for a in label_axes if any(name in fields for fields in a.fields)]
        shape = tuple(len(a) for a in setting)
        values = []
        for index in np.ndindex(*shape):
            value = spec.fixed.get(name)
            for axis, i in zip(setting, index):
                value = axis.fields[i].get(name, value)
            values.append(value)
        present = [v for v in values if v is not None]
        if present and all(_is_number(v) for v in present):
            exact = all(isinstance(v, numbers.Integral) for v in present) and len(present) == len(values)
            array = np.array([np.nan if v is None else v for v in values], dtype=np.int32 if exact else np.float64)
        else:
            array = _texts(values)
        out[name] = (tuple(a.name for a in setting), array.reshape(shape))
    return out


def _texts(values: list[Any]) -> np.ndarray:
    """Text values (JSON for non-strings, "" for missing) as an object array in which equal
    texts are one string object (a sweep's plans: a few distinct texts over 10^5 points)."""
    shared: dict[str, str] = {}
    texts = ("" if v is None else v if isinstance(v, str) else to_json(v) for v in values)
    out = np.empty(len(values), dtype=object)
    out[:] = [shared.setdefault(t, t) for t in texts]
    return out


def _coordinate_grid(coordinate: Any, dims: tuple[str, ...], shape: tuple[int, ...]) -> np.ndarray | None:
    """The coordinate ``(dims, values)`` at every point of the task axes ``dims`` (None when it
    runs along another axis, e.g. the angle of tensor mode)."""
    cdims, values = coordinate
    cdims = (cdims,) if isinstance(cdims, str) else tuple(cdims)
    values = np.asarray(values)
    if not set(cdims) <= set(dims):
        return None
    order = [d for d in dims if d in cdims]
    values = np.transpose(values, [cdims.index(d) for d in order]) if values.ndim else values
    return np.broadcast_to(values.reshape([shape[k] if d in cdims else 1 for k, d in enumerate(dims)]), shape)


def _equals_coordinate(array: np.ndarray, grid: np.ndarray | None) -> bool:
    """Whether the record values ``array`` equal the coordinate ``grid`` wherever they exist."""
    if grid is None:
        return False
    if array.dtype == object or grid.dtype == object:
        return bool(np.all((array == "") | (array == grid)))
    if grid.dtype.kind not in "fiu":
        return False
    with np.errstate(invalid="ignore"):
        same = np.isclose(array, grid.astype(np.float64), rtol=1e-12, atol=0.0, equal_nan=False)
    return bool(np.all(same | np.isnan(array)))


def _coordinate(name: str, values: tuple) -> np.ndarray:
    if name in LABEL_AXES or name in fields.of_type(str):
        return np.array(values, dtype=object)
    if name == "n":
        return np.array(values, dtype=np.int32)
    return np.array(values, dtype=np.float64)


def derive_directional(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with K_nn(angle) and normalized_nn (``DIRECTIONAL``) when it has an angle axis
    and a tangential tensor: K_nn = nᵀ K n, n = (cos angle, sin angle) (Li 2017, eq. 6) in
    tensor mode, K_xx of the shape turned by −angle in rotated mode; normalized_nn =
    K_nn · normalized_xx / K_xx. Dimensions in the spec's axis order (the ``sweep_axes``
    attribute); units those of K_xx. Lazy on dask arrays. Variables ``ds`` has already (read
    from a file that stores them) are kept, not derived again."""
    import xarray as xr

    if not _directional(ds) or all(name in ds for name in DIRECTIONAL):
        return ds
    order = ds.attrs.get("sweep_axes", " ".join(map(str, ds.dims))).split()  # files before sweep_axes: as read
    kxx = ds["K_xx"]
    out = ds
    if "K_nn" not in ds:
        if "angle" in kxx.dims:  # rotated mode: one solve per angle
            knn = kxx.copy()
        else:
            knn = xr.apply_ufunc(
                _turned, *(ds[name] for name in TENSOR), ds["angle"], dask="parallelized", output_dtypes=[np.float64]
            )
        unit = kxx.attrs.get("scale", kxx.attrs.get("units"))
        knn.attrs = cf_attributes({"long_name": VARIABLE_ATTRS["K_nn"]["long_name"], "units": unit})
        out = ds.assign(K_nn=knn.transpose(*[d for d in order if d in knn.dims]))
    if "normalized_xx" in ds and "normalized_nn" not in ds:
        normalized = out["K_nn"] * (ds["normalized_xx"] / kxx)
        normalized.attrs = dict(VARIABLE_ATTRS["normalized_nn"])
        out["normalized_nn"] = normalized.transpose(*[d for d in order if d in normalized.dims])
    return directional_errors(out, order)


def directional_errors(ds: xr.Dataset, order: list[str]) -> xr.Dataset:
    """``ds`` with ``K_nn_error`` and ``normalized_nn_error`` where the tensor carries errors
    (``link_errors``), derived where they are not stored yet: the bound |nᵀ δK n| of
    ``quantities.directional_error`` on the entries' absolute errors (K_xy's and K_yx's relative
    to the largest diagonal entry) over |K_nn| in tensor mode, K_xx's in rotated mode;
    normalized_nn = K_nn E*/(K_zz G*) adds K_zz's relative error. K_nn and normalized_nn link
    them (``ancillary_variables``)."""
    import xarray as xr

    errors = [f"{name}{ERROR_SUFFIX}" for name in TENSOR]
    if not set(errors) <= set(ds.data_vars):
        return ds
    out = ds
    if f"K_nn{ERROR_SUFFIX}" not in out:
        if "angle" in ds["K_xx"].dims:  # rotated mode: K_nn is K_xx of the turned shape
            knn_error = ds[errors[0]].copy()
        else:
            scale = functools.reduce(np.fmax, [abs(ds[k]) for k in ("K_xx", "K_yy", "K_zz") if k in ds])
            bounds = [
                ds[errors[0]] * abs(ds["K_xx"]),
                ds[errors[1]] * scale,
                ds[errors[2]] * scale,
                ds[errors[3]] * abs(ds["K_yy"]),
            ]
            turned = xr.apply_ufunc(
                _turned_error, *bounds, ds["angle"], dask="parallelized", output_dtypes=[np.float64]
            )
            knn_error = turned / abs(ds["K_nn"])
        knn_error.attrs = error_attributes("K_nn")
        out = out.assign({f"K_nn{ERROR_SUFFIX}": knn_error.transpose(*[d for d in order if d in knn_error.dims])})
    normalized = f"normalized_nn{ERROR_SUFFIX}"
    if "normalized_nn" in out and normalized not in out and f"K_zz{ERROR_SUFFIX}" in out:
        bound = out[f"K_nn{ERROR_SUFFIX}"] + out[f"K_zz{ERROR_SUFFIX}"]
        bound.attrs = error_attributes("normalized_nn")
        out[normalized] = bound.transpose(*[d for d in order if d in bound.dims])
    for name in DIRECTIONAL:
        if name in out and f"{name}{ERROR_SUFFIX}" in out:
            linked = str(out[name].attrs.get("ancillary_variables", "")).split()  # kept: an adaptive map's
            out[name].attrs["ancillary_variables"] = " ".join(
                dict.fromkeys([f"{name}{ERROR_SUFFIX}", "error_status", *linked])
            )
    return out


def _turned_error(bxx: np.ndarray, bxy: np.ndarray, byx: np.ndarray, byy: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``directional_error`` on the four broadcast absolute error bounds."""
    bounds = np.stack([np.stack([bxx, bxy], axis=-1), np.stack([byx, byy], axis=-1)], axis=-2)
    return directional_error(bounds, angle)


def _directional(ds: xr.Dataset) -> bool:
    """Whether ``ds`` has an angle axis and a tangential tensor (``derive_directional`` applies)."""
    return "angle" in ds.dims and set(TENSOR) <= set(ds.data_vars)


def _turned(kxx: np.ndarray, kxy: np.ndarray, kyx: np.ndarray, kyy: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``directional_stiffness`` on the four broadcast tensor components."""
    tensor = np.stack([np.stack([kxx, kxy], axis=-1), np.stack([kyx, kyy], axis=-1)], axis=-2)
    return directional_stiffness(tensor, angle)


def write_netcdf(ds: xr.Dataset, path: Path) -> Path:
    """Write the data set ``ds`` to ``path`` (``netcdf.write``: compact, atomic) with K_nn and
    normalized_nn (``derive_directional``, derived here if ``ds`` lacks them), so that every
    netCDF reader sees them; returns ``path``."""
    return netcdf.write(derive_directional(ds), path)


def open_dataset(path: str | Path, verify: bool = True, **options: Any) -> xr.Dataset:
    """The sweep data set at ``path``: the labelled hypercube over the spec's axes as
    ``build_dataset`` made it, lazily (``options`` go to ``xarray.open_dataset``, e.g.
    ``chunks={}`` for dask arrays), K_nn(angle) and normalized_nn as stored (derived from the
    tensor for a file written before they were stored), ``plan`` as text.

    With ``verify`` (the default) the file is read once first and every chunk's checksum
    checked (``netcdf.verify``): a damaged file raises ``DamagedFile`` (an ``OSError``) naming
    the file and the first damaged variable, rather than giving wrong numbers later. That read
    takes about as long as loading the whole file (measured: 3.7 s to verify, 4.2 s to load a
    140 MB file of 207 MB of float64 on a shared 2-core machine; milliseconds for the demo's
    220 kB); ``verify=False`` skips it, for a large file opened lazily again and again (a
    damaged chunk then fails when it is read, with the netCDF library's "NetCDF: HDF error",
    which names no variable)."""
    if verify:
        netcdf.verify(path)
    return derive_directional(netcdf.read(path, **options))


DamagedFile = netcdf.DamagedFile


def _global_attrs(
    spec: Spec, attrs: Mapping[str, Any], scales: set[str] = frozenset(), command: str | None = None
) -> dict[str, Any]:
    version = attrs.get("hpcontact_version") or __version__
    revision = attrs.get("git_revision")
    out: dict[str, Any] = {
        "title": spec.title,
        "Conventions": "CF-1.8",
        "source": f"hpcontact {version}{f' (git {revision})' if revision else ''}: {METHODS.get(spec.kind, spec.kind)}",
        "references": "\n".join([SOFTWARE.format(version=version), *REFERENCES.get(spec.kind, ())]),
        "comment": convention(scales),
        "scene_kind": spec.kind,
        "angle_mode": spec.angle_mode,
        "sweep_axes": " ".join(a.name for a in spec.axes),
        "spec_path": str(spec.path),
        "spec": spec.text,
    }
    out.update(UNIT_ATTRIBUTES[spec.kind](spec))
    if spec.fixed.get("accuracy") is not None:
        out["requested_accuracy"] = float(spec.fixed["accuracy"])  # every point's error_status says whether it is met
    for name, value in spec.fixed.items():
        if not (_is_number(value) or isinstance(value, str)):
            out[f"scene_{name}"] = json.dumps(value)
    out.update({k: _attribute_value(v) for k, v in attrs.items() if v is not None})
    out["history"] = history_attribute(spec, attrs, command)
    return {k: v for k, v in out.items() if v is not None}


def _attribute_value(value: Any) -> Any:
    """A provenance value as a netCDF attribute: a list (the code versions and revisions whose
    journal entries the data set holds, say) as one line per item, a mapping as JSON."""
    if isinstance(value, (list, tuple)):
        return "\n".join(v if isinstance(v, str) else json.dumps(v, sort_keys=True) for v in value)
    if isinstance(value, Mapping):
        return json.dumps(value, sort_keys=True)
    return value


def history_attribute(spec: Spec, attrs: Mapping[str, Any], given: str | None = None) -> str | None:
    """The CF ``history``: one line per run, "<created>: <command>" (``attrs["created"]`` and
    the command as given: ``given``, from the entry point that ran the sweep,
    ``provenance.command_line`` or ``provenance.call_text``; else ``attrs["history"]``); a ``--resume`` run (its
    ``attrs["history"]`` names ``--resume``) appends its line to the history of the data set it
    replaces (``spec.output``), a fresh run starts a new one."""
    import xarray as xr

    command = attrs.get("history")
    if not command:
        return None
    given = given or command
    line = f"{attrs['created']}: {given}" if attrs.get("created") else str(given)
    if RESUME.flag not in str(command).split():  # the history assembly wrote: the command line's words
        return line
    try:
        with xr.open_dataset(spec.output, engine="netcdf4") as old:
            previous = old.attrs.get("history")
    except (OSError, ValueError):
        previous = None
    return f"{previous}\n{line}" if previous else line
