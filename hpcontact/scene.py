"""A scene: geometry, material, numerical settings and the quantities wanted; validated.

``Scene.from_params`` takes the command-line fields (docs/design.md §4.1, with underscores) as a
mapping, fills defaults, and refuses bad input with an ``InputError`` naming the field and the
allowed range. ``hpcontact.plan`` decides what to build and run for it. A scene is a value: its
identity is the canonical JSON of its fields (``Scene.key``, ``canonical_json``: a sweep task's
key hashes it), from which ``Scene.from_key`` builds it once and shares it after.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from hpcontact.errors import InputError, finite_number, integer, unused_field
from hpcontact.fields import ACCURACY_RANGE as ACCURACY_RANGE  # the sweep's spec reads it here, for now
from hpcontact.fields import (
    CONTACT,
    DEPTH_RANGE,
    MIN_DEPTH,
    RADIUS_RANGE,
    defaults,
    field,
    read_by,
)
from hpcontact.geometry import SHAPES, Shape, mask_pixels
from hpcontact.materials.crystal import Crystal, crystal, cubic_from_nu_A
from hpcontact.materials.elastic_constants import FAMILIES, FIXED_BY_CONSTANTS, constants_material
from hpcontact.materials.isotropic import Isotropic
from hpcontact.quantities import in_si_units, names_where

Material = Isotropic | Crystal

#: The quantities a contact scene may ask for (``hpcontact.quantities.QUANTITIES``, the registry).
QUANTITIES = names_where()
#: Quantities whose discretization follows the contact's edge, so that grids can be refined and
#: extrapolated (``Quantity.refinable``; ``hpcontact.discretizations.boundary_cells``, ``hpcontact.accuracy``).
REFINABLE_QUANTITIES = names_where(lambda q: q.refinable)
#: Fields whose valid values form one interval while every other field is held: ``from_params``
#: checks a range of each (its limits are the ones above and in the checks below, nowhere else),
#: and nothing else it does with the value fails inside that range, except at the branch values
#: listed (A = 1: the body is isotropic, where nu = 0.5 is allowed and the crystal's limits do
#: not apply). Where a crystal stiffness stops being positive definite (nu near -1 or 0.5 with an
#: extreme A) the interval's ends are those of the eigenvalue test, exact up to its rounding. A
#: sweep checks a long axis of such a field by validating its extreme and branch values, and
#: bisecting only when one is refused (``hpcontact.sweep.space.enumeration.scene_runs``), not every value.
INTERVAL_FIELDS: dict[str, tuple[float, ...]] = {
    "nu": (),
    "aspect": (),
    "anisotropy": (1.0,),
    "orientation": (),
    "shape_angle": (),
    "tol": (),
    "n": (),
    "accuracy": (),
}
#: Fields that give the body's whole stiffness, in GPa: constants (``cubic``, ``orthotropic``,
#: ``voigt``: ``elastic_constants.FAMILIES``) or a library crystal (``material``). Without one
#: the body is isotropic (nu, G) or, at A != 1, the cubic crystal from (nu, A) with
#: (C11 − C12)/2 = G (``_built_material``).
BODY_FIELDS = (*FAMILIES, "material")
#: The one table of the fields that only some scenes read: field -> (the setting that decides,
#: its values whose scenes read the field, why the others do not; None: "only ... read it"),
#: from the schema (``hpcontact.fields.Field.read_by``). A field given (not None) for any other
#: scene is refused (``_refuse_unused``) with one message (``errors.unused_field``), never
#: silently ignored. The settings: ``shape``; ``quantities`` (read when one of the values is
#: asked); ``body``, the field of ``BODY_FIELDS`` given (None: none is, nu, G and A describe the
#: body; why: ``FIXED_BY_CONSTANTS``). A shape's field at its default value changes nothing and
#: is accepted (a loop over shapes may pass aspect = 1 to each); a body's field is refused at
#: any value (nu = 0.3 beside material = 'Cu' would read as copper's Poisson ratio). The
#: orientation fields (``orientation``, ``miller``, ``azimuth``) are read by every crystal, the
#: library's and the constants' included, and accepted on an isotropic body, where they change
#: nothing: a sweep over A that contains 1 gives them to every scene (and leaves them out of its
#: isotropic scenes, ``hpcontact.sweep.space``).
UNUSED_FIELDS: dict[str, tuple[str, tuple[str | None, ...], str | None]] = {
    name: (setting, readers, FIXED_BY_CONSTANTS[name] if setting == "body" else why)
    for name, (setting, readers, why) in read_by().items()
}
#: The engine's default of every contact field (``hpcontact.fields``; a test may patch one here).
DEFAULTS: dict[str, Any] = defaults(CONTACT)


def _quantities(value: Any) -> tuple[str, ...]:
    items = value.split(",") if isinstance(value, str) else list(value)
    items = [str(item).strip() for item in items if str(item).strip()]
    allowed = f"a non-empty list from {', '.join(QUANTITIES)}"
    if not items:
        raise InputError("quantities", allowed, value)
    for item in items:
        if item not in QUANTITIES:
            raise InputError("quantities", allowed, item)
    return tuple(dict.fromkeys(items))


# json.dumps(params, sort_keys=True, separators=(",", ":")) builds an encoder per call; this one
# is built once (same output; a third of the time on a sweep's small scenes).
_CANONICAL = json.JSONEncoder(sort_keys=True, separators=(",", ":"))


def canonical_json(params: Mapping[str, Any]) -> str:
    """A scene's fields as canonical JSON (sorted keys, exact floats): its identity (``Scene.key``;
    a sweep task's key hashes it, ``hpcontact.sweep.work.tasks.task_key``)."""
    return _CANONICAL.encode(params)


@dataclass(frozen=True)
class Scene:
    """One point of the parameter space: what to solve and how finely."""

    shape: Shape
    material: Material
    quantities: tuple[str, ...]
    n: int
    n_across: int | None
    tol: float
    accuracy: float | None = None
    threads: int = 1
    precondition: bool = True
    device: str = "cpu"
    normal_held: str = "approach"
    radius: float | None = None
    depth: float | None = None
    a: float | None = None
    params: dict = dataclasses.field(default_factory=dict, compare=False)

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> Scene:
        """Validate ``params`` (unknown fields, ranges, NaN/inf) and build the scene."""
        unknown = sorted(set(params) - set(DEFAULTS))
        if unknown:
            raise InputError(unknown[0], f"a known field ({', '.join(sorted(DEFAULTS))})", params[unknown[0]])
        p = {**DEFAULTS, **{k: v for k, v in params.items() if v is not None}}
        if p["shape"] not in SHAPES:
            raise InputError("shape", f"one of {', '.join(SHAPES)}", p["shape"])
        quantities = _quantities(p["quantities"])
        _refuse_unused(params, p["shape"], quantities)
        nu = field("nu").check(p["nu"])
        G = field("G").check(p["G"])
        material = _turned_with_shape(constants_material(params) or _material(p, G, nu), p["shape_angle"])
        aspect = field("aspect").check(p["aspect"])
        n = field("n").check(p["n"])
        n_across = None if p["n_across"] is None else field("n_across").check(p["n_across"])
        if n * (n_across or n) > 2**26:
            raise InputError("n", "a grid of at most 2**26 cells", f"{n} x {n_across or n}")
        tol = field("tol").check(p["tol"])
        accuracy = None if p["accuracy"] is None else _accuracy(p["accuracy"], quantities, p["shape"])
        radius = None if p["radius"] is None else finite_number("radius", p["radius"], RADIUS_RANGE)
        depth = None if p["depth"] is None else finite_number("depth", p["depth"], DEPTH_RANGE)
        if "indentation" in quantities and radius is None:
            raise InputError("radius", f"{RADIUS_RANGE} (needed for indentation)", None)
        if "indentation" in quantities and depth is None:
            raise InputError("depth", f"{DEPTH_RANGE} (needed for indentation)", None)
        if radius is not None:
            field("radius").check(p["radius"])
        if depth is not None and not (radius is not None and MIN_DEPTH * radius <= depth < radius):
            raise InputError("depth", DEPTH_RANGE, p["depth"])
        a = None if p["a"] is None else _contact_size(params, p["a"])
        shape = Shape(
            name=p["shape"],
            aspect=aspect,
            **{
                attribute: field(name).check(p[name])
                for attribute, name in (
                    ("sides", "sides"),
                    ("angle_deg", "shape_angle"),
                    ("amplitude", "amplitude"),
                    ("seed", "seed"),
                    ("hurst", "hurst"),
                    ("rms", "rms"),
                )
            },
            mask_path=p["mask"],
        )
        cpus = usable_cpus()
        threads = integer("threads", p["threads"], 1, field("threads").message.format(cpus), cpus)
        return cls(
            shape=shape,
            material=material,
            quantities=quantities,
            n=n,
            n_across=n_across,
            tol=tol,
            accuracy=accuracy,
            threads=threads,
            precondition=_boolean("precondition", p["precondition"]),
            device=_choice("device", p["device"]),
            normal_held=_choice("normal_held", p["normal_held"]),
            radius=radius,
            depth=depth,
            a=a,
            params=dict(params),
        )

    @property
    def newtons_per_metre(self) -> float | None:
        """What one unit of a record's stiffness is in N/m, when the scene gives its contact
        size ``a`` in metres: K = k G a with G in Pa (an isotropic body's ``G``) or in GPa (a
        library crystal's or elastic constants', 1e9 Pa), so a × 1e9 or a; None without ``a``
        (the record stays in units of G·a)."""
        if self.a is None:
            return None
        return self.a * (GPA if _body_in_gpa(self.params) else 1.0)

    def in_si_units(self, record: Mapping[str, Any]) -> dict[str, Any]:
        """``record``, this scene's, in N/m, m and m² where the scene gives its contact size
        (``quantities.in_si_units``: its stiffnesses times ``newtons_per_metre``, its lengths and
        areas in units of a times a and a²); unchanged without it."""
        return in_si_units(record, self.newtons_per_metre, self.a)

    @property
    def grid_given(self) -> bool:
        """Whether the fields named a grid (``n``): without one, the default solve may
        extrapolate over grids (``hpcontact.accuracy.default_solve``)."""
        return self.params.get("n") is not None

    def key(self) -> str:
        """The scene's identity: the canonical JSON of its fields (``fields``, ``canonical_json``),
        the same whatever their order; ``Scene.from_key`` builds the scene of a key."""
        return canonical_json(self.fields())

    @staticmethod
    def from_key(key: str) -> Scene:
        """The scene of the canonical JSON ``key`` (``Scene.key``, ``canonical_json`` of its
        fields): validated and built on the first call, the same value after (cached per key:
        the sweep's cost model asks for the scenes of its cost keys task after task). A shared
        value: its ``params`` are not to be changed (``fields`` gives a copy)."""
        return _scene_of_key(key)

    def fields(self, **changes: Any) -> dict[str, Any]:
        """The fields this scene was built from, with ``changes`` applied (``None`` removes a
        field: its default applies) — the record of a task and the key of its cost."""
        merged = {**self.params, **changes}
        return {k: v for k, v in merged.items() if v is not None}

    def on_grid(self, n: int, n_across: int | None, tol: float | None = None) -> Scene:
        """This scene on another grid (n cells along the long side, ``n_across`` across) and,
        where given, another CG tolerance: a grid of the accuracy study's sequence. The material
        and the shape are this scene's, validated once at the edge."""
        changes: dict[str, Any] = (
            {"n": n, "n_across": n_across} if tol is None else {"n": n, "n_across": n_across, "tol": tol}
        )
        return dataclasses.replace(self, **changes, params=self.fields(**changes))


@functools.lru_cache(maxsize=4096)
def _scene_of_key(key: str) -> Scene:
    """``Scene.from_key``: the scene of the canonical JSON ``key``."""
    return Scene.from_params(json.loads(key))


#: Pa per GPa: the stress unit of library crystals and elastic constants.
GPA = 1e9


def _body_in_gpa(params: Mapping[str, Any]) -> bool:
    """Whether the body's stiffness is given in GPa: a library crystal or elastic constants
    (``BODY_FIELDS``), not nu, G and A."""
    return any(params.get(name) is not None for name in BODY_FIELDS)


def _contact_size(params: Mapping[str, Any], value: Any) -> float:
    """The contact size ``a`` in metres, for a body whose modulus has a unit: G given (in Pa)
    or a body in GPa (``_body_in_gpa``). Without either, G is the unit 1 of the results and a
    size in metres would give a stiffness in no unit."""
    a = field("a").check(value)
    if params.get("G") is None and not _body_in_gpa(params):
        raise InputError(
            "a",
            "a contact size in metres with the body's modulus: G in Pa, or a library crystal or elastic "
            "constants (material, cubic, orthotropic, voigt) in GPa",
            value,
        )
    return a


def usable_cpus() -> int:
    """The CPUs this process may run on: its affinity mask where the OS has one, else
    ``os.cpu_count()`` (the upper limit of ``threads``: more threads than CPUs only contend)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _accuracy(value: Any, quantities: tuple[str, ...], shape: str) -> float:
    """A requested accuracy, for a scene whose grids can be refined: an outline (not a rough
    patch) and quantities in ``REFINABLE_QUANTITIES``."""
    accuracy = field("accuracy").check(value)
    if shape == "rough":
        raise InputError("accuracy", "not for shape rough (its patch comes from one grid and cannot be refined)", value)
    other = [x for x in quantities if x not in REFINABLE_QUANTITIES]
    if other:
        raise InputError(
            "accuracy", f"only for quantities {', '.join(REFINABLE_QUANTITIES)} (not {', '.join(other)})", value
        )
    return accuracy


def _choice(name: str, value: Any) -> str:
    """One of the field's choices (``hpcontact.fields``), exactly (a spec's "Load" is refused,
    not guessed)."""
    choices = field(name).choices
    if isinstance(value, str) and value in choices:
        return value
    raise InputError(name, f"one of {', '.join(choices)}", value)


def _boolean(field_name: str, value: Any) -> bool:
    """A true boolean only: the string "false" is not False (a spec's typo must not flip it)."""
    if isinstance(value, bool):
        return value
    raise InputError(field_name, "true or false (a boolean, not a string or number)", value)


def _refuse_unused(params: Mapping[str, Any], shape: str, quantities: tuple[str, ...]) -> None:
    """Refuse a field given (``params``: as the caller gave them, before defaults) for a scene
    that does not read it (``UNUSED_FIELDS``: one table, one message), before any range is
    checked: ``nu = 0.7`` beside ``material = 'Cu'`` is unused, whatever its range. A ``mask``
    file is checked by its header (``geometry.mask_pixels``: a .npy or .png within the grid
    limit), so a bad or oversized file is refused before anything is decoded.
    """
    body = next((name for name in BODY_FIELDS if params.get(name) is not None), None)
    settings: dict[str, tuple[Any, Any]] = {  # setting -> (what UNUSED_FIELDS compares, what a message shows)
        "shape": (shape, shape),
        "quantities": (quantities, ",".join(quantities)),
        "body": (body, None if body is None else params[body]),
    }
    for name, (setting, readers, why) in UNUSED_FIELDS.items():
        value = params.get(name)
        if value is None:
            continue
        current, shown = settings[setting]
        read = any(q in readers for q in current) if setting == "quantities" else current in readers
        if read or (setting == "shape" and _at_default(name, value)):
            continue
        if why is None:
            why = f"only {' or '.join(str(r) for r in readers)} read{'s' if len(readers) == 1 else ''} it"
        raise unused_field(name, value, body if setting == "body" else setting, shown, why)
    if shape == "mask" and params.get("mask") is not None:  # the file's header: type, shape, the grid limit
        mask_pixels(str(params["mask"]))


def _at_default(name: str, value: Any) -> bool:
    """Whether ``value`` is the field's default (a number compared as a number: shape_angle
    -0.0 or 0 is 0.0)."""
    default = DEFAULTS[name]
    if default is None:  # a mask: given is not the default
        return False
    if isinstance(default, float) and not isinstance(value, bool):
        try:
            return float(value) == default
        except (TypeError, ValueError):
            return False
    return bool(value == default)


def _miller(value: Any) -> tuple[int, int, int]:
    allowed = field("miller").message
    try:
        items = value.replace(",", " ").split() if isinstance(value, str) else list(value)
        hkl = tuple(int(item) for item in items)
    except (TypeError, ValueError):
        raise InputError("miller", allowed, value) from None
    if len(hkl) != 3 or not any(hkl):
        raise InputError("miller", allowed, value)
    return hkl  # type: ignore[return-value]


MATERIAL_FIELDS = ("material", "anisotropy", "azimuth", "orientation", "miller")


def _material(p: Mapping[str, Any], G: float, nu: float) -> Material:
    """``_built_material`` of these fields, built once per distinct value (a sweep validates
    every scene, and its crystals repeat across shapes, b/a and grids: rotating one costs ~1 ms).
    Materials are immutable, so scenes may share one."""
    fields = [(name, p[name]) for name in MATERIAL_FIELDS] + [("G", G), ("nu", nu)]
    try:  # the type is part of the key: True == 1, but a bool is no anisotropy factor
        key = tuple((name, type(v).__name__, tuple(v) if isinstance(v, list) else v) for name, v in fields)
        hash(key)
    except TypeError:  # an unhashable value: the builder names the field
        return _built_material(p, G, nu)
    return _cached_material(key)


@functools.lru_cache(maxsize=4096)
def _cached_material(key: tuple) -> Material:
    fields = {name: list(v) if type_name == "list" else v for name, type_name, v in key}
    return _built_material(fields, fields["G"], fields["nu"])


def _built_material(p: Mapping[str, Any], G: float, nu: float) -> Material:
    """The half-space: isotropic (closed-form kernels) unless a crystal or A ≠ 1 is asked.

    ``material`` names a library crystal (GPa; nu, G and A given beside it are refused,
    ``UNUSED_FIELDS``, so their defaults here are not read); otherwise a cubic crystal from
    (nu, A) with (C11 − C12)/2 = G (docs/design.md §2.5; nu < 0.5: ``CRYSTAL_NU_RANGE``). A crystal is turned so that the
    surface normal is ``miller`` (h k l) or the path angle ``orientation`` ψ, default [001],
    then by ``azimuth`` degrees in plane. At A = 1 without a named crystal the body is
    isotropic whatever the orientation, and stays on the closed-form path.
    """
    anisotropy = field("anisotropy").check(p["anisotropy"])
    azimuth = field("azimuth").check(p["azimuth"])
    orientation = None if p["orientation"] is None else field("orientation").check(p["orientation"])
    miller = None if p["miller"] is None else _miller(p["miller"])
    if orientation is not None and miller is not None:
        raise InputError("miller", "either miller or orientation, not both", p["miller"])
    if p["material"] is None and anisotropy == 1.0:
        return Isotropic(G=G, nu=nu)
    if p["material"] is not None:
        base = crystal(str(p["material"]))
    else:
        base = cubic_from_nu_A(nu, anisotropy, scale=G)  # refuses nu = 0.5 (CRYSTAL_NU_RANGE)
    if orientation is not None:
        return base.oriented(psi_deg=orientation, azimuth_deg=azimuth)
    return base.oriented(miller=miller or (0, 0, 1), azimuth_deg=azimuth)


def _turned_with_shape(material: Material, shape_angle: Any) -> Material:
    """A crystal turns with the shape: ``shape_angle`` β turns the whole contact (shape and
    lattice) by β counter-clockwise on the grid, so the physical problem is the same and the
    tensor transforms as K(β) = R(β) K(0) R(β)ᵀ — what Li's rotated-shape check (a sweep's
    ``angle_mode = "rotated"``) relies on. The lattice relative to the shape is set by
    ``azimuth`` (or the orientation fields). The frame turned by −β has axes (rows of R)
    (cos β, −sin β, 0) and (sin β, cos β, 0) in the current one (``Crystal.rotated``).
    """
    beta = math.radians(field("shape_angle").check(shape_angle))
    if isinstance(material, Isotropic) or beta == 0.0:
        return material
    c, s = math.cos(beta), math.sin(beta)
    return material.rotated(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))


def validate(params: Mapping[str, Any]) -> None:
    """Raise ``InputError`` on the first bad field of ``params``; cheap (no grid is built)."""
    Scene.from_params(params)
