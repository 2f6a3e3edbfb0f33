"""Journal entries → labelled xarray Dataset (DESIGN §4.2) → netCDF4, written atomically.

Dimensions are the spec's axes in spec order, each a coordinate with CF ``units`` and
``long_name``; fixed scalar fields of the spec become scalar coordinates. Data variables are the
keys of the task records (float64, NaN where a task failed; non-numeric values such as ``plan``
as JSON text), plus ``status`` (0 ok), ``message`` and ``wall_time_s`` per task. A ``material``
axis is a string coordinate (library crystal names). Units: stresses in G (the shear modulus,
(C11 − C12)/2 of a cubic crystal from (nu, A)), or GPa when the scenes name library crystals;
punch lengths in a (the semi-major extent, 1 on the grid); indentation lengths in L, the unit
the spec gives the sphere's radius and depth in. Points that
share a scene share its record. With an ``angle`` axis the stiffness along the load direction
``K_nn`` (and Li's normalized ``normalized_nn``) is derived from the tensor, K_nn = nᵀ K n, in
tensor mode, and is K_xx of the shape turned by −angle in rotated mode.
"""

from __future__ import annotations

import json
import numbers
import os
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import xarray as xr

from ..quantities import directional_stiffness
from .journal import BAD_INPUT, ERROR, NOT_CONVERGED, OK, Entry, to_json
from .spec import Spec

NOT_COMPUTED = -1
STATUS_MEANINGS = {OK: "ok", BAD_INPUT: "bad_input", NOT_CONVERGED: "not_converged", ERROR: "error", NOT_COMPUTED: "not_computed"}

STIFFNESS = "G a"  # forces per unit displacement in units of G times the semi-major extent a
AXIS_ATTRS: Mapping[str, Mapping[str, str]] = {
    "shape": {"long_name": "contact shape"},
    "angle": {"long_name": "direction of the tangential load from the x axis", "units": "degree"},
    "nu": {"long_name": "Poisson ratio", "units": "1"},
    "aspect": {"long_name": "aspect ratio b/a of the contact", "units": "1"},
    "anisotropy": {"long_name": "cubic anisotropy factor A = 2 C44 / (C11 - C12)", "units": "1"},
    "orientation": {"long_name": "surface normal along [110] -> [111] -> [001]", "units": "degree"},
    "material": {"long_name": "library crystal (elastic constants in GPa)"},
    "miller": {"long_name": "surface normal (h k l) of the crystal"},
    "azimuth": {"long_name": "in-plane turn of the crystal about the surface normal", "units": "degree"},
    "radius": {"long_name": "radius R of the rigid sphere", "units": "L"},
    "depth": {"long_name": "approach d of the rigid sphere", "units": "L"},
    "n": {"long_name": "grid cells along the long side", "units": "1"},
    "n_across": {"long_name": "grid cells across the short side", "units": "1"},
    "tol": {"long_name": "conjugate-gradient relative residual tolerance", "units": "1"},
    "G": {"long_name": "shear modulus", "units": "G"},
    "sides": {"long_name": "polygon sides or star lobes", "units": "1"},
    "shape_angle": {"long_name": "rotation of the shape on the grid", "units": "degree"},
}
VARIABLE_ATTRS: dict[str, Mapping[str, str]] = {
    **{
        f"K_{i}{j}": {"long_name": f"stiffness K_{i}{j}: force along {i} per unit displacement along {j}", "units": STIFFNESS}
        for i in "xyz"
        for j in "xyz"
    },
    **{
        f"proxy_K_{i}{j}": {"long_name": f"uniform-traction compliance proxy (J^-1)_{i}{j}, Li 2017 sec. 3.2", "units": STIFFNESS}
        for i in "xy"
        for j in "xy"
    },
    "K_max": {"long_name": "largest principal tangential stiffness", "units": STIFFNESS},
    "K_min": {"long_name": "smallest principal tangential stiffness", "units": STIFFNESS},
    "principal_angle_deg": {"long_name": "direction of K_max from the x axis", "units": "degree"},
    "K_a_over_K_b": {"long_name": "K_a/K_b = K_xx/K_yy (a: major axis along x, b: across)", "units": "1"},
    "normalized_xx": {"long_name": "Li's normalized stiffness K_xx E*/(K_zz G*)", "units": "1"},
    "normalized_yy": {"long_name": "Li's normalized stiffness K_yy E*/(K_zz G*)", "units": "1"},
    "K_nn": {"long_name": "tangential stiffness along the load direction K_nn(angle)", "units": STIFFNESS},
    "normalized_nn": {"long_name": "Li's normalized stiffness K_nn E*/(K_zz G*)", "units": "1"},
    "asymmetry": {"long_name": "|K_xy - K_yx| / max |K_ij| (accuracy diagnostic)", "units": "1"},
    "iterations": {"long_name": "conjugate-gradient iterations, all solves", "units": "1"},
    "residual": {"long_name": "largest relative residual of the solves", "units": "1"},
    "estimated_error": {"long_name": "estimated relative error (grid extrapolation)", "units": "1"},
    "nx": {"long_name": "grid cells along x", "units": "1"},
    "ny": {"long_name": "grid cells along y", "units": "1"},
    "dx": {"long_name": "cell size along x", "units": "a"},
    "dy": {"long_name": "cell size along y", "units": "a"},
    "K_zz_bonded": {"long_name": "normal stiffness K_zz of the bonded (coupled) punch", "units": STIFFNESS},
    "contact_cells": {"long_name": "grid cells in the contact", "units": "1"},
    "load": {"long_name": "normal load on the rigid sphere", "units": "G L2"},
    "contact_area": {"long_name": "contact area under the sphere", "units": "L2"},
    "max_pressure": {"long_name": "largest contact pressure under the sphere", "units": "G"},
    "ellipse_b_over_a": {"long_name": "aspect ratio b/a of the ellipse fitted to the contact (pressure moments)", "units": "1"},
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


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def build_dataset(
    spec: Spec, where: Mapping[tuple[int, ...], str], entries: Mapping[str, Entry], attrs: Mapping[str, Any]
) -> xr.Dataset:
    """The data set of ``spec`` from the journal ``entries``; ``where`` maps each point of the
    task axes to its task key (``tasks.enumerate_tasks``); ``attrs`` are global attributes."""
    axes = spec.task_axes
    dims = tuple(a.name for a in axes)
    shape = tuple(len(a) for a in axes)
    keys = np.empty(shape, dtype=object)
    for index, key in where.items():
        keys[index] = key
    flat = keys.ravel()
    found = [entries.get(key) for key in flat]

    status = np.array([NOT_COMPUTED if e is None else e.status for e in found], dtype=np.int32)
    message = np.array(["not computed" if e is None else e.message for e in found], dtype=object)
    wall = np.array([np.nan if e is None else e.wall_time_s for e in found], dtype=np.float64)
    variables: dict[str, tuple[tuple[str, ...], np.ndarray]] = {
        "status": (dims, status.reshape(shape)),
        "message": (dims, message.reshape(shape)),
        "wall_time_s": (dims, wall.reshape(shape)),
    }
    names: dict[str, None] = {}
    for e in found:
        if e is not None and e.status == OK:
            names.update(dict.fromkeys(k for k in e.record if k not in variables))
    for name in names:
        values = [None if e is None or e.status != OK else e.record.get(name) for e in found]
        present = [v for v in values if v is not None]
        if all(_is_number(v) for v in present):
            array = np.array([np.nan if v is None else float(v) for v in values], dtype=np.float64)
        else:
            array = np.array(["" if v is None else v if isinstance(v, str) else to_json(v) for v in values], dtype=object)
        variables[name] = (dims, array.reshape(shape))

    coords: dict[str, Any] = {a.name: (a.name, _coordinate(a.name, a.values)) for a in spec.axes}
    for name, value in spec.fixed.items():
        if _is_number(value) or isinstance(value, str):
            coords[name] = ((), value)
    ds = xr.Dataset(variables, coords=coords)
    _derive_directional(ds, spec)
    gpa = _names_crystals(spec)
    sphere_grid = _indentation_only(spec)
    for name in ds.variables:
        variable_attrs = _with_stress_unit(VARIABLE_ATTRS.get(name, AXIS_ATTRS.get(name, {})), gpa)
        if sphere_grid and name in ("dx", "dy"):  # the record's grid is the sphere's
            variable_attrs["units"] = "L"
        ds[name].attrs.update(variable_attrs)
    ds.attrs.update(_global_attrs(spec, attrs, gpa))
    return ds


def _names_crystals(spec: Spec) -> bool:
    """Whether the scenes name library crystals (stresses in GPa, not in units of G)."""
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
    if name in ("shape", "material"):
        return np.array(values, dtype=object)
    if name == "n":
        return np.array(values, dtype=np.int64)
    return np.array(values, dtype=np.float64)


def _derive_directional(ds: xr.Dataset, spec: Spec) -> None:
    """K_nn(angle) and normalized_nn, when there is an angle axis and a tangential tensor."""
    if spec.axis("angle") is None or not {"K_xx", "K_xy", "K_yx", "K_yy"} <= set(ds.data_vars):
        return
    order = [a.name for a in spec.axes]
    if spec.angle_mode == "rotated":
        ds["K_nn"] = ds["K_xx"]
    else:
        tensor = xr.concat(
            [xr.concat([ds["K_xx"], ds["K_xy"]], "j"), xr.concat([ds["K_yx"], ds["K_yy"]], "j")], "i"
        ).transpose(..., "i", "j")
        angle = ds["angle"]
        values = directional_stiffness(tensor.values[..., None, :, :], angle.values)
        ds["K_nn"] = (tensor.dims[:-2] + ("angle",), values)
        ds["K_nn"] = ds["K_nn"].transpose(*order)
    if "normalized_xx" in ds:
        ds["normalized_nn"] = (ds["K_nn"] * (ds["normalized_xx"] / ds["K_xx"])).transpose(*order)


def _global_attrs(spec: Spec, attrs: Mapping[str, Any], gpa: bool = False) -> dict[str, Any]:
    stress = "GPa (library crystal constants)" if gpa else "G (shear modulus; (C11 - C12)/2 for a cubic crystal from nu and A)"
    out: dict[str, Any] = {
        "title": spec.title,
        "Conventions": "CF-1.8",
        "angle_mode": spec.angle_mode,
        "spec_path": str(spec.path),
        "spec": spec.text,
        "stiffness_units": f"forces per unit displacement in units of {'GPa' if gpa else 'G'} a (a semi-major extent of the punch = 1)",
        "stress_units": stress,
        "length_units": "a: semi-major extent of the punch (= 1 on the grid); L: unit of the sphere's radius and depth",
    }
    for name, value in spec.fixed.items():
        if not (_is_number(value) or isinstance(value, str)):
            out[f"scene_{name}"] = json.dumps(value)
    out.update(attrs)
    return {k: v for k, v in out.items() if v is not None}


def write_netcdf(ds: xr.Dataset, path: Path) -> Path:
    """Write ``ds`` to ``path`` as netCDF4: to a temporary file in the same folder, then an atomic
    rename, so ``path`` is always either the old file or the complete new one."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        ds.to_netcdf(tmp, engine="netcdf4", format="NETCDF4")
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path
