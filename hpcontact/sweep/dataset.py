"""Journal entries → labelled xarray Dataset (docs/design.md §4.2, docs/reference/dataset.md) → netCDF4.

Dimensions are the spec's axes in spec order, each a coordinate with CF ``units`` and
``long_name``; fixed scalar fields of the spec become scalar coordinates. Data variables are the
keys of the task records (float64, NaN where a task failed; non-numeric values such as ``plan``
as JSON text), plus ``status`` (0 ok; ``flag_values``/``flag_meanings``), ``message`` and
``wall_time_s`` per task. Values are gathered once per task and spread to every point the task
serves (points that share a scene share its record). A record key
that names a coordinate (a slip record's ``load`` on a ``load`` axis, say) is left out where it
equals the coordinate at every point, and kept as ``record_<key>`` where it does not (a label
table overrode the field). ``material``, ``normal_held`` and ``pair`` axes are string coordinates. A field that
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
means (the convention: ``hpcontact.sweep.units``, and the data set's global ``comment``).

A contact spec without ``n`` (neither fixed nor an axis) is solved by ``hpcontact solve``'s
extrapolated default (``accuracy.default_solve``, ``kinds``) wherever it applies: the data set
then has no ``n`` coordinate; ``nx``, ``ny``, ``dx``, ``dy`` are the *finest* grid's (256 cells
along the long side, ``grid_sequence``'s across: 256 × 128 for b/a = 0.5), ``grids`` and
``grids_across`` the JSON lists of every grid solved, ``estimated_error`` the estimated relative
error of the extrapolated K (NaN for tasks solved on one grid), ``accuracy_met`` whether it is
≤ 1e-4 and ``stopped_by`` why the sequence ended. A task the default does not extrapolate (a
rough patch, a mask, a crystal) is one grid of n = 128 as before.

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
import inspect
import json
import numbers
import os
import re
import shlex
import sys
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from hpcontact import __version__
from hpcontact.materials.elastic_constants import FAMILIES
from hpcontact.problems.kinds import CONTACT, SLIP
from hpcontact.quantities import ERROR_SUFFIX, ESTIMATED, directional_error, directional_stiffness
from hpcontact.sweep import netcdf
from hpcontact.sweep.columns import NOT_COMPUTED, Joined, join, task_positions, to_columns
from hpcontact.sweep.columns import is_number as _is_number
from hpcontact.sweep.journal import BAD_INPUT, CRASHED, ERROR, NOT_CONVERGED, OK, Entry, to_json
from hpcontact.sweep.space.axes import LABEL_AXES
from hpcontact.sweep.space.spec import Spec
from hpcontact.sweep.units import cf_attributes, convention, scale_symbols

FIXED_VARIABLES = ("status", "message", "wall_time_s")  # per task, whatever its record holds
STATUS_MEANINGS = {
    OK: "ok",
    BAD_INPUT: "bad_input",
    NOT_CONVERGED: "not_converged",
    ERROR: "error",
    CRASHED: "crashed",
    NOT_COMPUTED: "not_computed",
}

#: ``error_status``: 0 estimated and within the accuracy asked (``accuracy_met``), 1 estimated
#: but above it (the estimate stands: the grids ran out first, ``stopped_by``), 2 no estimate
#: (one grid, or a failed task): its ``<name>_error`` is NaN.
ERROR_MET, ERROR_NOT_MET, NO_ESTIMATE = 0, 1, 2
ERROR_STATUS_MEANINGS = {ERROR_MET: "met", ERROR_NOT_MET: "not_met", NO_ESTIMATE: "no_estimate"}

TENSOR = ("K_xx", "K_xy", "K_yx", "K_yy")
DIRECTIONAL = ("K_nn", "normalized_nn")  # derived from the tensor (stored in the file)
STIFFNESS = "G a"  # forces per unit displacement in units of G times the semi-major extent a
AXIS_ATTRS: Mapping[str, Mapping[str, str]] = {
    "shape": {"long_name": "contact shape"},
    "angle": {"long_name": "direction of the tangential load from the x axis", "units": "degree"},
    "nu": {"long_name": "Poisson ratio", "units": "1"},
    "aspect": {"long_name": "aspect ratio b/a of the contact", "units": "1"},
    "anisotropy": {"long_name": "cubic anisotropy factor A = 2 C44 / (C11 - C12)", "units": "1"},
    "orientation": {"long_name": "surface normal along [110] -> [111] -> [001]", "units": "degree"},
    "material": {"long_name": "library crystal (elastic constants in GPa)"},
    "normal_held": {
        "long_name": "what the tangential stiffness holds in the normal direction: approach (u_z = 0) or load (F_z = 0)"
    },
    "miller": {"long_name": "surface normal (h k l) of the crystal"},
    "azimuth": {"long_name": "in-plane turn of the crystal about the surface normal", "units": "degree"},
    "radius": {"long_name": "radius R of the rigid sphere", "units": "L"},
    "depth": {"long_name": "approach d of the rigid sphere", "units": "L"},
    "n": {"long_name": "grid cells along the long side", "units": "1"},
    "n_across": {"long_name": "grid cells across the short side", "units": "1"},
    "tol": {"long_name": "conjugate-gradient relative residual tolerance", "units": "1"},
    "accuracy": {"long_name": "requested relative accuracy of every stiffness (grid extrapolation)", "units": "1"},
    "G": {"long_name": "shear modulus G: the stress unit of the scene", "units": "1"},
    "amplitude": {"long_name": "relative lobe amplitude of the star", "units": "1"},
    "sides": {"long_name": "polygon sides or star lobes", "units": "1"},
    "shape_angle": {"long_name": "rotation of the shape on the grid", "units": "degree"},
    "seed": {"long_name": "random seed of the rough surface", "units": "1"},
    "hurst": {"long_name": "Hurst exponent of the rough surface", "units": "1"},
    "rms": {"long_name": "rms height of the rough surface", "units": "a"},
    "mask": {"long_name": "contact mask image (path)"},
    "threads": {"long_name": "FFTW threads per solve", "units": "1"},
    "quantities": {"long_name": "quantities solved for"},
}
VARIABLE_ATTRS: dict[str, Mapping[str, str]] = {
    **{
        f"K_{i}{j}": {
            "long_name": f"stiffness K_{i}{j}: force along {i} per unit displacement along {j}",
            "units": STIFFNESS,
        }
        for i in "xyz"
        for j in "xyz"
    },
    **{
        f"proxy_K_{i}{j}": {
            "long_name": f"uniform-traction compliance proxy (J^-1)_{i}{j}, Li 2017 sec. 3.2",
            "units": STIFFNESS,
        }
        for i in "xy"
        for j in "xy"
    },
    "K_max": {"long_name": "largest principal tangential stiffness", "units": STIFFNESS},
    "K_min": {"long_name": "smallest principal tangential stiffness", "units": STIFFNESS},
    "principal_angle_deg": {"long_name": "direction of K_max from the x axis", "units": "degree"},
    "principal_angle_note": {"long_name": "why principal_angle_deg is missing (text)"},
    "K_min_over_K_max": {"long_name": "K_min/K_max: principal stiffness ratio (frame-free anisotropy)", "units": "1"},
    "K_a_over_K_b": {
        "long_name": "K_a/K_b = K_xx/K_yy in the lab frame (a: major axis along x, b: across)",
        "units": "1",
    },
    "normalized_xx": {"long_name": "Li's normalized stiffness K_xx E*/(K_zz G*)", "units": "1"},
    "normalized_yy": {"long_name": "Li's normalized stiffness K_yy E*/(K_zz G*)", "units": "1"},
    "K_nn": {"long_name": "tangential stiffness along the load direction K_nn(angle)", "units": STIFFNESS},
    "normalized_nn": {"long_name": "Li's normalized stiffness K_nn E*/(K_zz G*)", "units": "1"},
    "asymmetry": {"long_name": "|K_xy - K_yx| / max |K_ij| (accuracy diagnostic)", "units": "1"},
    "iterations": {"long_name": "conjugate-gradient iterations, all solves", "units": "1"},
    "residual": {"long_name": "largest relative residual of the solves", "units": "1"},
    "estimated_error": {"long_name": "estimated relative error (grid extrapolation)", "units": "1"},
    "error_status": {
        "long_name": "error estimate of the point's stiffnesses (their <name>_error variables)",
        "flag_values": np.array(sorted(ERROR_STATUS_MEANINGS), dtype=np.int32),
        "flag_meanings": " ".join(ERROR_STATUS_MEANINGS[k] for k in sorted(ERROR_STATUS_MEANINGS)),
    },
    "nx": {"long_name": "grid cells along x", "units": "1"},
    "ny": {"long_name": "grid cells along y", "units": "1"},
    "dx": {"long_name": "cell size along x", "units": "a"},
    "dy": {"long_name": "cell size along y", "units": "a"},
    "K_zz_bonded": {"long_name": "normal stiffness K_zz of the bonded (coupled) punch", "units": STIFFNESS},
    "contact_cells": {"long_name": "grid cells in the contact", "units": "1"},
    "load": {"long_name": "normal load on the rigid sphere", "units": "G L2"},
    "contact_area": {"long_name": "contact area under the sphere", "units": "L2"},
    "max_pressure": {"long_name": "largest contact pressure under the sphere", "units": "G"},
    "ellipse_b_over_a": {
        "long_name": "aspect ratio b/a of the ellipse fitted to the contact (pressure moments)",
        "units": "1",
    },
    "ellipse_angle_deg": {"long_name": "major axis of the fitted ellipse from x", "units": "degree"},
    "plan": {"long_name": "kernels built and solves run (JSON)"},
    "message": {"long_name": "error message of a failed task"},
    "wall_time_s": {"long_name": "wall time of the task", "units": "s"},
    "status": {
        "long_name": "task status",
        "flag_values": np.array(sorted(STATUS_MEANINGS), dtype=np.int32),
        "flag_meanings": " ".join(STATUS_MEANINGS[k] for k in sorted(STATUS_MEANINGS)),
    },
}


# Slip scenes (hpcontact.problems.slip.partial_slip.solve_slip): (long_name, unit) with F the force and L the length unit
# (N and m for library materials); the end of the loading path unless said otherwise.
SLIP_MODE_ATTRS: Mapping[str, tuple[str, str]] = {
    "tangential_force": ("tangential force Q along the load direction", "F"),
    "tangential_displacement": ("tangential displacement delta of body 2 relative to body 1 along the load", "L"),
    "tangential_stiffness": (
        "incremental tangential stiffness k_t = dQ/d delta along the load (consistent tangent)",
        "F L-1",
    ),
    "stick_area_stiffness": ("no-slip stiffness of the stick area along the load (frozen slip zone)", "F L-1"),
    "stick_area": ("area of the stick zone", "L2"),
    "contact_area": ("area in contact (grid cells)", "L2"),
}
SLIP_ATTRS: Mapping[str, tuple[str, str]] = {
    **SLIP_MODE_ATTRS,
    **{
        f"decoupled_{k}": (f"{name}, decoupled (Goodman: pressure of the normal contact)", unit)
        for k, (name, unit) in SLIP_MODE_ATTRS.items()
    },
    **{
        f"tangential_stiffness_{i}{j}": (
            f"incremental tangential stiffness tensor, force along {i} per displacement along {j}",
            "F L-1",
        )
        for i in "xy"
        for j in "xy"
    },
    "load": ("normal load P", "F"),
    "no_slip_stiffness": ("tangential stiffness k_t at Q = 0 on the grid", "F L-1"),
    "stiffness_ratio": ("k_t / k_t(Q = 0)", "1"),
    "force_ratio": ("Q/(mu P) reached", "1"),
    "stick_radius": ("sqrt(stick_area / pi)", "L"),
    "hertz_a": ("semi-major axis of the Hertz contact ellipse", "L"),
    "hertz_b": ("semi-minor axis of the Hertz contact ellipse", "L"),
    "contact_angle_deg": ("major axis of the Hertz ellipse from x", "degree"),
    "normal_stiffness": ("Hertz normal stiffness k_n = dP/dd = 3P/(2d)", "F L-1"),
    "dundurs_beta": ("Dundurs' parameter beta of the pair", "1"),
    "mindlin_no_slip_stiffness": ("Mindlin's bonded-ellipse tangential stiffness along the load", "F L-1"),
    "mindlin_stiffness": ("Cattaneo-Mindlin / Mindlin-Deresiewicz k_t at Q (circular contact)", "F L-1"),
    "mindlin_displacement": ("Cattaneo-Mindlin / Mindlin-Deresiewicz delta at Q (circular contact)", "L"),
    "mindlin_stick_radius": ("Cattaneo's stick radius c = a (1 - Q/(mu P))^(1/3)", "L"),
    "coupling_effect_stiffness": ("coupled / decoupled k_t - 1", "1"),
    "coupling_effect_displacement": ("coupled / decoupled delta - 1", "1"),
    "coupling_effect_stick_area": ("coupled / decoupled stick area - 1", "1"),
    "coupling_size": ("size of the pair's normal-tangential coupling (|Dundurs beta| for isotropic bodies)", "1"),
    "iterations": ("operator applications (slip solver, CG, Polonsky-Keer), all paths", "1"),
    "residual": ("largest final relative KKT residual", "1"),
    "dx": ("cell size along the contact ellipse's major axis", "L"),
    "dy": ("cell size along the contact ellipse's minor axis", "L"),
    "history": ("every load step of the path (JSON)", ""),
    "decoupled_history": ("every load step of the decoupled path (JSON)", ""),
    # coordinates (axes and fixed fields)
    "pair": ("contact pair", ""),
    "mu": ("friction coefficient", "1"),
    "q_ratio": ("tangential load at the end of the path Q/(mu P)", "1"),
    "angle": ("direction of the tangential load from x", "degree"),
    "radius": ("radius of curvature of body 1", "L"),
    "radius_b": ("second principal radius of curvature of body 1", "L"),
    "radius2": ("radius of curvature of body 2 (inf: flat)", "L"),
    "radius2_b": ("second principal radius of curvature of body 2", "L"),
    "body2_angle": ("angle between the principal axes of the bodies", "degree"),
    "material": ("material of body 1 (hpcontact.problems.slip.bodies library, or crystal:NAME)", ""),
    "material2": ("material of body 2 (hpcontact.problems.slip.bodies library, or crystal:NAME)", ""),
    "orthotropic": ("orthotropic engineering constants of body 1", ""),
    "orthotropic2": ("orthotropic engineering constants of body 2", ""),
    "orientation": ("surface normal of the crystal along [110] -> [111] -> [001]", "degree"),
    "azimuth": ("in-plane turn of the crystal about the surface normal", "degree"),
    "miller": ("surface normal (h k l) of the crystal", ""),
    "E": ("Young's modulus of body 1", "F L-2"),
    "G": ("shear modulus of body 1", "F L-2"),
    "nu": ("Poisson ratio of body 1", "1"),
    "E2": ("Young's modulus of body 2", "F L-2"),
    "G2": ("shear modulus of body 2", "F L-2"),
    "nu2": ("Poisson ratio of body 2", "1"),
    "displacement": ("final tangential displacement (displacement control)", "L"),
    "n": ("grid cells across the contact's major diameter", "1"),
    "steps": ("tangential load steps", "1"),
    "control": ("tangential load control: force or displacement", ""),
    "path": ("tangential loading path: load, or loop (load, unload, reload)", ""),
    "coupling": ("coupling of the normal and tangential problems: auto, both, coupled or decoupled", ""),
}
SI_UNITS = {"F": "N", "L": "m"}


def build_dataset(
    spec: Spec, where: Mapping[tuple[int, ...], str], entries: Mapping[str, Entry], attrs: Mapping[str, Any]
) -> xr.Dataset:
    """The data set of ``spec`` from the journal ``entries``; ``where`` maps each point of the
    task axes to its task key (``tasks.enumerate_tasks``); ``attrs`` are global attributes."""
    keys, task_of = task_positions(where, tuple(len(a) for a in spec.task_axes))
    found = [(entries[key], at) for at, key in enumerate(keys) if key in entries]
    parts = [to_columns([e for e, _ in found], [at for _, at in found])] if found else []
    return dataset_of(spec, task_of, join(parts, len(keys), FIXED_VARIABLES), attrs)


def dataset_of(
    spec: Spec, task_of: np.ndarray, joined: Joined, attrs: Mapping[str, Any], derive: bool = True
) -> xr.Dataset:
    """The data set of ``spec`` from the per-task arrays ``joined`` (``columns.join``);
    ``task_of`` gives each point of the task axes its task (0-based position), ``attrs`` are
    global attributes; with ``derive``, K_nn and normalized_nn (``derive_directional``; without,
    ``write_netcdf`` derives them). Values are spread from tasks to points by index."""
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
    table = _attribute_table(spec)
    for name in ds.variables:
        variable_attrs = dict(table.get(renamed.get(name, name), {}))
        if name in renamed and "long_name" in variable_attrs:
            variable_attrs["long_name"] = f"{variable_attrs['long_name']} (task record; differs from the coordinate)"
        ds[name].attrs.update(variable_attrs)
    ds = link_errors(ds, spec.kind_record.estimated)
    scales = {s for name in ds.variables for s in scale_symbols(str(ds[name].attrs.get("scale", "")))}
    ds.attrs.update(_global_attrs(spec, attrs, scales))
    return derive_directional(ds) if derive else ds


def error_attributes(name: str) -> dict[str, str]:
    """CF attributes of ``<name>_error``, the estimated relative error of the stiffness ``name``."""
    relative_to = (
        "the largest diagonal entry |K_ii|" if re.fullmatch(r"K_(xy|yx|xz|zx|yz|zy)(_coupled)?", name) else f"|{name}|"
    )
    return {
        "long_name": f"estimated relative error of {name} (grid extrapolation), relative to {relative_to}; "
        "NaN: no estimate (error_status)",
        "units": "1",
    }


def link_errors(ds: xr.Dataset, stiffnesses: re.Pattern[str] = ESTIMATED) -> xr.Dataset:
    """``ds`` with an estimated relative error ``<name>_error`` beside every stiffness it stores
    (the names ``stiffnesses`` matches: ``ESTIMATED`` for contact sweeps, ``SLIP_ESTIMATED``
    for slip sweeps; NaN where a task has none: one grid, a slip scene, a failed task), linked
    from it by CF ``ancillary_variables`` = "<name>_error error_status", and the flag variable
    ``error_status`` (``ERROR_STATUS_MEANINGS``) over the task axes."""
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
    for name in dict.fromkeys(k for a in label_axes for fields in a.fields for k in fields):
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


def _attribute_table(spec: Spec) -> dict[str, dict[str, Any]]:
    """Attributes (units, long_name) of every variable and coordinate name for the spec's
    scene kind (``ATTRIBUTE_TABLES``)."""
    return ATTRIBUTE_TABLES[spec.kind](spec)


def _contact_attribute_table(spec: Spec) -> dict[str, dict[str, Any]]:
    """Contact attributes (``AXIS_ATTRS``, ``VARIABLE_ATTRS``): stresses in G, or GPa when the
    scenes name library crystals; an indentation's grid in L."""
    gpa = _names_crystals(spec)
    table = {name: _with_stress_unit(attrs, gpa) for name, attrs in {**AXIS_ATTRS, **VARIABLE_ATTRS}.items()}
    if _indentation_only(spec):  # the record's grid is the sphere's
        for name in ("dx", "dy"):
            table[name]["units"] = "L"
    return {name: cf_attributes(attrs) for name, attrs in table.items()}


def _slip_attribute_table(spec: Spec) -> dict[str, dict[str, Any]]:
    """Slip attributes (``SLIP_ATTRS``) in SI units when the scenes name library materials,
    else in the input's force and length units F and L; the kind-neutral ones from the
    contact tables (status, message, wall time, grid counts, tol)."""
    units = SI_UNITS if _names_materials(spec) else {"F": "F", "L": "L"}
    table = {
        name: dict(VARIABLE_ATTRS.get(name, AXIS_ATTRS.get(name, {})))
        for name in ("status", "message", "wall_time_s", "nx", "ny", "tol", "plan", "threads", "quantities")
    }
    for name, (long_name, unit) in SLIP_ATTRS.items():
        attrs: dict[str, Any] = {"long_name": long_name}
        if unit:
            attrs["units"] = re.sub(r"\b([FL])(?=-?\d*\b)", lambda m: units[m.group(1)], unit).replace("N m-2", "Pa")
        table[name] = cf_attributes(attrs)
    return table


ATTRIBUTE_TABLES: Mapping[str, Callable[[Spec], dict[str, dict[str, Any]]]] = {
    CONTACT: _contact_attribute_table,
    SLIP: _slip_attribute_table,
}


def _names_materials(spec: Spec) -> bool:
    """Whether a slip sweep gives an elastic body by library name or by elastic constants (GPa):
    moduli then have units, and the sweep's inputs and results are SI."""
    tables = [spec.fixed] + [fields for axis in spec.axes for fields in axis.fields]
    named = any(
        isinstance(t.get(key), str) and t[key].strip().lower() != "rigid"
        for t in tables
        for key in ("material", "material2")
    )
    constants = any(
        t.get(f"{family}{suffix}") is not None for t in tables for family in FAMILIES for suffix in ("", "2")
    )
    return named or constants


def _names_crystals(spec: Spec) -> bool:
    """Whether the (contact) scenes name library crystals (stresses in GPa, not in units of G)."""
    return spec.fixed.get("material") is not None or spec.axis("material") is not None


def _indentation_only(spec: Spec) -> bool:
    """Whether every scene asks for indentation alone (the record's grid is the sphere's)."""
    quantities = spec.fixed.get("quantities")
    if isinstance(quantities, str):
        quantities = quantities.split(",")
    return quantities is not None and {str(q).strip() for q in quantities} == {"indentation"}


def _with_stress_unit(attrs: Mapping[str, Any], gpa: bool) -> dict[str, Any]:
    """``attrs`` with the stress unit G replaced by GPa for library crystals."""
    out = dict(attrs)
    units = out.get("units")
    if gpa and isinstance(units, str) and units.split(" ")[0] == "G":
        out["units"] = "GPa" + units[1:]
    return out


def _coordinate(name: str, values: tuple) -> np.ndarray:
    if name in LABEL_AXES or name in ("material", "normal_held"):
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


SOFTWARE = (
    "hpcontact {version}: anisotropy of contact stiffness with FFT-accelerated half-space boundary elements "
    "(cite as in its CITATION.cff; method: its docs/design.md)"
)
METHODS = {
    CONTACT: "rigid flat punch or sphere bonded to / pressed on an elastic half-space (isotropic or cubic crystal): "
    "FFT-accelerated boundary elements, conjugate gradients (punch) or Polonsky-Keer (sphere)",
    SLIP: "two elastic bodies in partial-slip contact under a tangential load path with Coulomb friction: "
    "FFT-accelerated boundary elements",
}
REFERENCES = {
    CONTACT: (
        "Q. Li (2017) On the tensor of tangential stiffness in contact problems (K_nn = n K n, normalized stiffness)",
        "R. D. Mindlin (1949) J. Appl. Mech. 16, 259 (bonded ellipse)",
        "D. M. Barnett, J. Lothe (1973) Phys. Norv. 7, 13; (1985) Proc. R. Soc. A 402, 135 (anisotropic half-space)",
        "I. A. Polonsky, L. M. Keer (1999) Wear 231, 206 (sphere contact)",
        "K. L. Johnson (1985) Contact Mechanics, Cambridge UP",
    ),
    SLIP: (
        "R. D. Mindlin (1949) J. Appl. Mech. 16, 259; R. D. Mindlin, H. Deresiewicz (1953) J. Appl. Mech. 20, 327",
        "I. A. Polonsky, L. M. Keer (1999) Wear 231, 206",
        "L. Rodriguez-Tembleque, F. C. Buroni, R. Abascal, A. Saez (2011) Eur. J. Mech. A/Solids 30, 95",
        "D. M. Barnett, J. Lothe (1973) Phys. Norv. 7, 13; (1985) Proc. R. Soc. A 402, 135 (anisotropic bodies)",
        "K. L. Johnson (1985) Contact Mechanics, Cambridge UP",
    ),
}


def _global_attrs(spec: Spec, attrs: Mapping[str, Any], scales: set[str] = frozenset()) -> dict[str, Any]:
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
    out["history"] = _history(spec, attrs)
    return {k: v for k, v in out.items() if v is not None}


def _contact_units(spec: Spec) -> dict[str, str]:
    """The global unit attributes of a contact sweep: stresses in G or GPa, lengths in a or L."""
    gpa = _names_crystals(spec)
    stress = (
        "GPa (library crystal constants)"
        if gpa
        else "G (shear modulus; (C11 - C12)/2 for a cubic crystal from nu and A)"
    )
    return {
        "stiffness_units": f"forces per unit displacement in units of {'GPa' if gpa else 'G'} a (a semi-major extent of the punch = 1)",
        "stress_units": stress,
        "length_units": "a: semi-major extent of the punch (= 1 on the grid; for a mask, half the long side of the contact); "
        "L: unit of the sphere's radius and depth",
    }


def _slip_units(spec: Spec) -> dict[str, str]:
    """The global unit attribute of a slip sweep: SI for library materials, else the input's F and L."""
    if _names_materials(spec):
        return {"units": "SI: forces in N, lengths in m, stiffnesses in N/m, areas in m2 (library materials, Pa)"}
    return {"units": "F and L: the force and length units of the input (moduli in F/L2, radii in L)"}


UNIT_ATTRIBUTES: Mapping[str, Callable[[Spec], dict[str, str]]] = {CONTACT: _contact_units, SLIP: _slip_units}


def _attribute_value(value: Any) -> Any:
    """A provenance value as a netCDF attribute: a list (the code versions and revisions whose
    journal entries the data set holds, say) as one line per item, a mapping as JSON."""
    if isinstance(value, (list, tuple)):
        return "\n".join(v if isinstance(v, str) else json.dumps(v, sort_keys=True) for v in value)
    if isinstance(value, Mapping):
        return json.dumps(value, sort_keys=True)
    return value


def _history(spec: Spec, attrs: Mapping[str, Any]) -> str | None:
    """The CF ``history``: one line per run, "<created>: <command>" (``attrs["created"]`` and
    the command as given, ``invocation``, else ``attrs["history"]``); a ``--resume`` run (its
    ``attrs["history"]`` names ``--resume``) appends its line to the history of the data set it
    replaces (``spec.output``), a fresh run starts a new one."""
    command = attrs.get("history")
    if not command:
        return None
    given = invocation() or command
    line = f"{attrs['created']}: {given}" if attrs.get("created") else str(given)
    if "--resume" not in str(command).split():
        return line
    try:
        with xr.open_dataset(spec.output, engine="netcdf4") as old:
            previous = old.attrs.get("history")
    except (OSError, ValueError):
        previous = None
    return f"{previous}\n{line}" if previous else line


# The entry points whose call is the command a data set's history records: (module, function) →
# how it is shown. Python calls as calls, command-line mains as their argv.
_CALLS = {
    ("hpcontact.api", "run_sweep"): "hpcontact.run_sweep",
    ("hpcontact.sweep.driver", "run_sweep"): "hpcontact.sweep.driver.run_sweep",
}
_MAINS = {("hpcontact.cli", "main"): "hpcontact", ("hpcontact.sweep.driver", "main"): None}


def invocation() -> str | None:
    """The command that runs the sweep being written, as it was given: the outermost of
    ``hpcontact.run_sweep(...)`` (its arguments that differ from the defaults:
    "hpcontact.run_sweep('jobs/demo.toml', resume=True)") and the command-line entry points
    (``hpcontact run ...``, ``python -m hpcontact.sweep ...``: the process's command line, or
    the ``argv`` a caller passed to ``main``) on the call stack; None when neither is (a data
    set built directly)."""
    found = None
    frame = sys._getframe(1)
    while frame is not None:
        key = (frame.f_globals.get("__name__"), frame.f_code.co_name)
        if key in _CALLS or key in _MAINS:
            found = (key, frame)
        frame = frame.f_back
    if found is None:
        return None
    key, frame = found
    if key in _CALLS:
        return _call_text(_CALLS[key], frame.f_globals[key[1]], frame.f_locals)
    argv = frame.f_locals.get("argv")
    args = list(sys.argv[1:] if argv is None else argv)
    program = _MAINS[key] or (frame.f_locals.get("prog") if argv is not None else None) or "hpcontact run"
    if argv is None and sys.argv and sys.argv[0]:
        program = _program(sys.argv[0], program)
    return " ".join([program, shlex.join(map(str, args))]).strip()


def _program(argv0: str, default: str) -> str:
    """How the process was started: ``python -m <module>`` for a module of this package run as
    a script, else the name of the script (``hpcontact``: the console command)."""
    path = Path(argv0).resolve()
    package = Path(__file__).resolve().parents[1]
    if path.suffix == ".py" and path.is_relative_to(package):
        parts = path.relative_to(package.parent).with_suffix("").parts
        return "python -m " + ".".join(parts[:-1] if parts[-1] == "__main__" else parts)
    return Path(argv0).name or default


def _call_text(name: str, function: Any, values: Mapping[str, Any]) -> str:
    """``name(arguments)``: the arguments of a call of ``function`` (``values``: its frame's
    locals) that differ from their defaults, positional ones first; streams left out."""
    shown = []
    for parameter in inspect.signature(function).parameters.values():
        if parameter.name not in values or parameter.name == "stream":
            continue
        value = values[parameter.name]
        if parameter.default is not inspect.Parameter.empty and value is parameter.default:
            continue
        if (
            parameter.default is not inspect.Parameter.empty
            and isinstance(value, (bool, int, float, str))
            and value == parameter.default
        ):
            continue
        text = _argument_text(value)
        no_default = parameter.default is inspect.Parameter.empty
        shown.append(
            text if no_default and parameter.kind is parameter.POSITIONAL_OR_KEYWORD else f"{parameter.name}={text}"
        )
    return f"{name}({', '.join(shown)})"


def _argument_text(value: Any) -> str:
    """An argument as it reads in a call: paths as strings, functions by name, a spec dict
    in full (its JSON), other objects by their type."""
    if isinstance(value, os.PathLike):
        return repr(os.fspath(value))
    if value is None or isinstance(value, (bool, int, float, str)):
        return repr(value)
    if isinstance(value, Mapping):
        return json.dumps(value, sort_keys=True, default=str)
    if callable(value) and hasattr(value, "__qualname__"):
        return value.__qualname__
    return f"{type(value).__name__}(...)"
