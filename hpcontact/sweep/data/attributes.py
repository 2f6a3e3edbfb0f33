"""A sweep data set's attributes: CF ``long_name`` and ``units`` of every coordinate and
variable for the spec's scene kind (contact: scales G, a, L; slip: SI or the input's F and L),
the status flags, and the global attributes naming the method and its references (the data
set: ``hpcontact.sweep.data.dataset``)."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from hpcontact import fields
from hpcontact.materials.elastic_constants import FAMILIES
from hpcontact.problems.kinds import CONTACT, SLIP, quantity_names, scene_kind
from hpcontact.quantities import ERROR_SUFFIX
from hpcontact.scene import BODY_FIELDS, DEFAULTS
from hpcontact.sweep.data.columns import NOT_COMPUTED
from hpcontact.sweep.data.journal import BAD_INPUT, CRASHED, ERROR, NOT_CONVERGED, OK
from hpcontact.sweep.data.units import cf_attributes
from hpcontact.sweep.space.spec import Spec

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

STIFFNESS = "G a"  # forces per unit displacement in units of G times the semi-major extent a
AXIS_ATTRS: Mapping[str, Mapping[str, str]] = fields.axis_attrs(CONTACT)  # the coordinates of contact sweeps
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


#: ``contact_area``'s long_name in a sweep without an indentation (``ContactUnits.sphere_area``
#: False): the area of the bonded punch, in a2.
PUNCH_AREA_NAME = "contact area of the bonded punch (its outline)"


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
    "no_slip_stiffness": ("tangential stiffness k_t at Q = 0 on the grid", "F L-1"),
    "stiffness_ratio": ("k_t / k_t(Q = 0)", "1"),
    "force_ratio": ("Q/(mu P) reached", "1"),
    "stick_radius": ("sqrt(stick_area / pi)", "L"),
    "stick_centroid_x": ("x of the stick zone's centroid", "L"),
    "stick_centroid_y": ("y of the stick zone's centroid", "L"),
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
    # coordinates: the contact pair, and every slip field (axes and fixed fields) as fields.py declares it
    "pair": ("contact pair", ""),
    **{name: (attrs["long_name"], attrs.get("units", "")) for name, attrs in fields.axis_attrs(SLIP).items()},
}
SI_UNITS = {"F": "N", "L": "m"}


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


def attribute_table(spec: Spec) -> dict[str, dict[str, Any]]:
    """Attributes (units, long_name) of every variable and coordinate name for the spec's
    scene kind (``ATTRIBUTE_TABLES``)."""
    return ATTRIBUTE_TABLES[spec.kind](spec)


#: What a length or area in units of the contact size a reads where the scene gives a in m
#: (``ContactUnits.newtons``; ``quantities.in_metres`` scales the values).
SIZED_UNITS: Mapping[str, str] = {"a": "m", "a2": "m2"}


@dataclasses.dataclass(frozen=True)
class ContactUnits:
    """How the engine units of ``VARIABLE_ATTRS`` and ``AXIS_ATTRS`` read for contact scenes: the
    one place that decides it, for a solve's record (:func:`record_units`) and a sweep's data set
    (:func:`attribute_table`) alike.

    ``gpa``: the body's constants are in GPa (a library crystal, cubic, orthotropic or Voigt
    constants, ``scene.BODY_FIELDS``): stresses in GPa, stiffnesses in GPa a, not in units of G.
    ``newtons``: the contact size ``a`` is given in metres: stiffnesses (G a) in N m-1, the value
    times ``Scene.newtons_per_metre`` (``quantities.in_newtons_per_metre``), lengths (a) in m and
    areas (a2) in m2 (``SIZED_UNITS``, ``quantities.in_metres``). ``sphere_grid``: every
    scene asks for an indentation alone, so the grid's ``dx``, ``dy`` are the sphere's, in L.
    ``sphere_area``: an indentation is asked, so ``contact_area`` is the sphere's (L2), else the
    punch's (a2)."""

    gpa: bool = False
    newtons: bool = False
    sphere_grid: bool = False
    sphere_area: bool = False

    @classmethod
    def of_fields(cls, tables: list[Mapping[str, Any]], quantities: set[str]) -> ContactUnits:
        """The units of scenes whose fields are among ``tables`` (a scene's, or a spec's fixed
        fields and axis points) and whose quantities are ``quantities``."""
        return cls(
            gpa=any(t.get(name) is not None for t in tables for name in BODY_FIELDS),
            newtons=any(t.get("a") is not None for t in tables),
            sphere_grid=quantities == {"indentation"},
            sphere_area="indentation" in quantities,
        )

    def unit(self, name: str, unit: str) -> str:
        """The unit of the value ``name`` whose engine unit (its table's) is ``unit``."""
        if unit == STIFFNESS and self.newtons:
            return "N m-1"
        if name in ("dx", "dy") and self.sphere_grid:
            return "L"
        if name == "contact_area" and not self.sphere_area:
            unit = "a2"
        if self.newtons and unit in SIZED_UNITS:
            return SIZED_UNITS[unit]
        if self.gpa and unit.split(" ")[0] == "G":
            return "GPa" + unit[1:]
        return unit


def _contact_attribute_table(spec: Spec) -> dict[str, dict[str, Any]]:
    """Contact attributes (``AXIS_ATTRS``, ``VARIABLE_ATTRS``) in the units of the spec's scenes
    (``ContactUnits``: stresses in G or GPa, stiffnesses in N/m when the spec gives the contact
    size ``a`` in metres, an indentation's grid in L), scaled quantities as CF ratios
    (``units.cf_attributes``). Coordinates keep their units: they are the fields as given."""
    units = _spec_units(spec)
    table = {name: dict(attrs) for name, attrs in AXIS_ATTRS.items()}
    for name, attrs in VARIABLE_ATTRS.items():
        unit = attrs.get("units")
        table[name] = {**attrs, "units": units.unit(name, unit)} if unit else dict(attrs)
    if not units.sphere_area:  # no indentation asked: the area is the bonded punch's, its outline
        table["contact_area"]["long_name"] = PUNCH_AREA_NAME
    return {name: cf_attributes(attrs) for name, attrs in table.items()}


def _spec_units(spec: Spec) -> ContactUnits:
    """The ``ContactUnits`` of a contact spec's scenes."""
    quantities = {q for value in _spec_values(spec, "quantities") for q in quantity_names(value)}
    return ContactUnits.of_fields(_spec_tables(spec), quantities or set(DEFAULTS["quantities"]))


def _spec_tables(spec: Spec) -> list[Mapping[str, Any]]:
    """The spec's fixed fields and the fields of every point of its axes."""
    return [spec.fixed] + [fields for axis in spec.axes for fields in axis.fields]


def _spec_values(spec: Spec, name: str) -> list[Any]:
    """The values the spec gives the field ``name`` (fixed or along an axis; none: [])."""
    return [t[name] for t in _spec_tables(spec) if t.get(name) is not None]


def slip_unit(unit: str, si: bool) -> str:
    """A slip quantity's unit (``SLIP_ATTRS``: in the input's force and length units F and L)
    in N and m (moduli in Pa) when ``si``: the scenes name library materials or give constants
    in GPa (``names_materials``)."""
    if not si:
        return unit
    return re.sub(r"\b([FL])(?=-?\d*\b)", lambda m: SI_UNITS[m.group(1)], unit).replace("N m-2", "Pa")


def _slip_attribute_table(spec: Spec) -> dict[str, dict[str, Any]]:
    """Slip attributes (``SLIP_ATTRS``) in SI units when the scenes name library materials,
    else in the input's force and length units F and L (``slip_unit``); the kind-neutral ones
    from the contact tables (status, message, wall time, grid counts, tol)."""
    si = names_materials(spec)
    table = {
        name: dict(VARIABLE_ATTRS.get(name, AXIS_ATTRS.get(name, {})))
        for name in ("status", "message", "wall_time_s", "nx", "ny", "tol", "plan", "threads", "quantities")
    }
    for name, (long_name, unit) in SLIP_ATTRS.items():
        attrs: dict[str, Any] = {"long_name": long_name}
        if unit:
            attrs["units"] = slip_unit(unit, si)
        table[name] = cf_attributes(attrs)
    return table


#: Engine units of a solve's record values that a sweep's data set does not store as they are
#: (``hpcontact.accuracy.solve_to_accuracy``: per-quantity mappings of relative errors and orders,
#: the memory plan).
RECORD_UNITS: Mapping[str, str] = {
    "estimated_errors": "1",
    "convergence_order": "1",
    "model_error": "1",
    "memory_budget_bytes": "byte",
    "estimated_peak_bytes": "byte",
}


def record_units(record: Mapping[str, Any], params: Mapping[str, Any]) -> dict[str, str]:
    """The unit of each number in ``record``, the record of the scene of fields ``params``: as
    the data set's ``units`` of the same name reads before a scale becomes a CF ratio
    (``ContactUnits``, ``slip_unit``): a UDUNITS unit ("N m-1", "m2", "Pa", "degree", "s",
    "byte", "1" for ratios and counts) or a product of the scene's scales, which are parameters,
    not units ("G a", "GPa a", "G L2", "F L-1"; ``units.SCALE_MEANINGS``). A mapping of numbers
    (``estimated_errors``) has its values' unit; text, flags and the per-grid ``levels`` (in the
    units of the keys they repeat) have none."""
    unit_of = _UNIT_OF[scene_kind(params)](params)
    return {
        name: unit
        for name, value in record.items()
        if _numbers(value) and (unit := unit_of(name)) is not None and unit != ""
    }


def _slip_units(params: Mapping[str, Any]) -> Callable[[str], str | None]:
    """The unit of a slip record's key (``record_units``): its force and length scales, or SI
    units where the scene's bodies are named materials (``slip_unit``)."""
    si = materials_named([params])

    def unit_of(name: str) -> str | None:
        unit = SLIP_ATTRS[name][1] if name in SLIP_ATTRS else VARIABLE_ATTRS.get(name, {}).get("units")
        return slip_unit(unit, si) if unit else None

    return unit_of


def _contact_units(params: Mapping[str, Any]) -> Callable[[str], str | None]:
    """The unit of a contact record's key (``record_units``): as its data set's variable,
    coordinate or error column of the same name reads (``ContactUnits``)."""
    quantities = set(quantity_names(params.get("quantities"))) or set(DEFAULTS["quantities"])
    units = ContactUnits.of_fields([params], quantities)

    def unit_of(name: str) -> str | None:
        stem = name.removesuffix(ERROR_SUFFIX)
        if name != stem and stem in VARIABLE_ATTRS:
            return error_attributes(stem)["units"]
        attrs = VARIABLE_ATTRS.get(name) or AXIS_ATTRS.get(name) or {}
        unit = attrs.get("units", RECORD_UNITS.get(name))
        return units.unit(name, unit) if unit else None

    return unit_of


#: The unit of a record's key for a scene of each kind (``problems.kinds.Kind.name``): params ->
#: key -> unit (``record_units``), a lookup per kind rather than a branch on it.
_UNIT_OF: Mapping[str, Callable[[Mapping[str, Any]], Callable[[str], str | None]]] = {
    CONTACT: _contact_units,
    SLIP: _slip_units,
}


def _numbers(value: Any) -> bool:
    """Whether a record value is a number (or None: a number not defined here) or a mapping of
    them: what has a unit."""
    if isinstance(value, Mapping):
        return all(_numbers(v) for v in value.values())
    return value is None or (isinstance(value, (int, float)) and not isinstance(value, bool))


ATTRIBUTE_TABLES: Mapping[str, Callable[[Spec], dict[str, dict[str, Any]]]] = {
    CONTACT: _contact_attribute_table,
    SLIP: _slip_attribute_table,
}


def names_materials(spec: Spec) -> bool:
    """Whether a slip sweep gives an elastic body by library name or by elastic constants (GPa):
    moduli then have units, and the sweep's inputs and results are SI (``materials_named``)."""
    return materials_named(_spec_tables(spec))


def materials_named(tables: list[Mapping[str, Any]]) -> bool:
    """Whether slip fields (a scene's, or a spec's fixed fields and axis points) give an elastic
    body by library name or by elastic constants (GPa): its quantities are then SI."""
    named = any(
        isinstance(t.get(key), str) and t[key].strip().lower() != "rigid"
        for t in tables
        for key in ("material", "material2")
    )
    constants = any(
        t.get(f"{family}{suffix}") is not None for t in tables for family in FAMILIES for suffix in ("", "2")
    )
    return named or constants


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


def _contact_units(spec: Spec) -> dict[str, str]:
    """The global unit attributes of a contact sweep: stresses in G or GPa, lengths in a or L."""
    gpa = _spec_units(spec).gpa
    stress = (
        "GPa (library crystal constants)"
        if gpa
        else "G (shear modulus; (C11 - C12)/2 for a cubic crystal from nu and A)"
    )
    a = spec.fixed.get("a")
    stiffness = (
        f"N/m (the contact size a = {a} m given)"
        if a is not None
        else f"forces per unit displacement in units of {'GPa' if gpa else 'G'} a (a semi-major extent of the punch = 1)"
    )
    lengths = (
        f"m, areas m2 (the contact size a = {a} m given)"
        if a is not None
        else "a: semi-major extent of the punch (= 1 on the grid; for a mask, half the long side of the contact); "
        "L: unit of the sphere's radius and depth"
    )
    return {"stiffness_units": stiffness, "stress_units": stress, "length_units": lengths}


def _slip_units(spec: Spec) -> dict[str, str]:
    """The global unit attribute of a slip sweep: SI for library materials, else the input's F and L."""
    if names_materials(spec):
        return {"units": "SI: forces in N, lengths in m, stiffnesses in N/m, areas in m2 (library materials, Pa)"}
    return {"units": "F and L: the force and length units of the input (moduli in F/L2, radii in L)"}


UNIT_ATTRIBUTES: Mapping[str, Callable[[Spec], dict[str, str]]] = {CONTACT: _contact_units, SLIP: _slip_units}
