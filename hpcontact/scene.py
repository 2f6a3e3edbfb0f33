"""A scene: geometry, material, numerical settings and the quantities wanted; validated.

``Scene.from_params`` takes the command-line fields (docs/design.md §4.1, with underscores) as a
mapping, fills defaults, and refuses bad input with an ``InputError`` naming the field and the
allowed range. ``hpcontact.plan`` decides what to build and run for it.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hpcontact.errors import InputError, finite_number, integer, unused_field
from hpcontact.geometry import SHAPES, Shape, mask_pixels
from hpcontact.materials.crystal import Crystal, crystal, cubic_from_nu_A
from hpcontact.materials.elastic_constants import FAMILIES, FIXED_BY_CONSTANTS, constants_material
from hpcontact.materials.isotropic import NU_RANGE, Isotropic, modulus, modulus_range

Material = Isotropic | Crystal

QUANTITIES = ("tangential", "normal", "compliance", "coupled", "indentation")
#: Quantities whose discretization follows the contact's edge, so that grids can be refined and
#: extrapolated (``hpcontact.discretizations.boundary_cells``, ``hpcontact.accuracy``).
REFINABLE_QUANTITIES = ("tangential", "normal", "coupled")
#: A requested accuracy (``accuracy``: the estimated relative error every reported stiffness
#: must reach, ``hpcontact.accuracy.solve_to_accuracy``).
ACCURACY_RANGE = "a relative error in [1e-9, 1)"
#: What the ``tangential`` stiffness holds fixed in the normal direction (``normal_held``,
#: ``hpcontact.plan``, ``hpcontact.quantities.load_held_stiffness``): the normal approach
#: (u_z = 0, the default: Li 2017 and the existing data sets) or the normal load (F_z = 0,
#: Mindlin 1949 / Cattaneo's experiment). The two coincide for isotropic bodies; any scene
#: accepts the field, and only ``tangential`` reads it.
NORMAL_HELD = ("approach", "load")

#: b/a below 1e-12 is refused: the cell integrals are verified for cell aspect 1e-10 … 1e10
#: (tests/kernels) and K_a/K_b for b/a down to 1e-12 (tests/test_hard_cases.py); by 1e-160 the
#: cell integrals overflow and by 1e-200 the cell height underflows.
MIN_ASPECT = 1e-12
ASPECT_RANGE = "b/a in [1e-12, 1]"
#: Sphere radius and approach: lengths, loads (~ E* R^1/2 d^3/2) and cell areas (~ R d) stay
#: far from overflow and underflow for radius in [1e-30, 1e30] and d/R in [1e-15, 1).
MIN_RADIUS = 1e-30
MIN_DEPTH = 1e-15
RADIUS_RANGE = "sphere radius in [1e-30, 1e30]"
DEPTH_RANGE = "approach d with d/radius in [1e-15, 1)"
#: Fields whose valid values form one interval while every other field is held: ``from_params``
#: checks a range of each (its limits are the ones above and in the checks below, nowhere else),
#: and nothing else it does with the value fails inside that range, except at the branch values
#: listed (A = 1: the body is isotropic, where nu = 0.5 is allowed and the crystal's limits do
#: not apply). Where a crystal stiffness stops being positive definite (nu near -1 or 0.5 with an
#: extreme A) the interval's ends are those of the eigenvalue test, exact up to its rounding. A
#: sweep checks a long axis of such a field by validating its extreme and branch values, and
#: bisecting only when one is refused (``hpcontact.sweep.spec.scene_runs``), not every value.
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
#: its values whose scenes read the field, why the others do not; None: "only ... read it").
#: A field given (not None) for any other scene is refused (``_refuse_unused``) with one message
#: (``errors.unused_field``), never silently ignored. The settings: ``shape``; ``quantities``
#: (read when one of the values is asked); ``body``, the field of ``BODY_FIELDS`` given (None:
#: none is, nu, G and A describe the body). A shape's field at its default value changes nothing
#: and is accepted (a loop over shapes may pass aspect = 1 to each); a body's field is refused
#: at any value (nu = 0.3 beside material = 'Cu' would read as copper's Poisson ratio). The
#: orientation fields (``orientation``, ``miller``, ``azimuth``) are read by every crystal, the
#: library's and the constants' included, and accepted on an isotropic body, where they change
#: nothing: a sweep over A that contains 1 gives them to every scene (and leaves them out of its
#: isotropic scenes, ``hpcontact.sweep.spec``).
UNUSED_FIELDS: dict[str, tuple[str, tuple[str | None, ...], str | None]] = {
    "aspect": ("shape", ("ellipse", "rectangle"), None),
    "sides": ("shape", ("polygon", "star"), None),
    "amplitude": ("shape", ("star",), None),
    "seed": ("shape", ("rough",), None),
    "hurst": ("shape", ("rough",), None),
    "rms": ("shape", ("rough",), None),
    "mask": ("shape", ("mask",), None),
    "shape_angle": (
        "shape",
        tuple(name for name in SHAPES if name not in ("mask", "rough")),
        "a mask or a rough patch is not turned",
    ),
    "radius": ("quantities", ("indentation",), None),
    "depth": ("quantities", ("indentation",), None),
    "nu": ("body", (None,), FIXED_BY_CONSTANTS["nu"]),
    "G": ("body", (None,), FIXED_BY_CONSTANTS["G"]),
    "anisotropy": ("body", (None,), FIXED_BY_CONSTANTS["anisotropy"]),
}

DEFAULTS: dict[str, Any] = {
    "shape": "circle",
    "aspect": 1.0,
    "sides": 5,
    "shape_angle": 0.0,
    "amplitude": 0.2,
    "seed": 0,
    "hurst": 0.8,
    "rms": 0.02,
    "mask": None,
    "nu": 0.3,
    "G": 1.0,
    "anisotropy": 1.0,
    "orientation": None,
    "miller": None,
    "azimuth": 0.0,
    "material": None,
    "cubic": None,
    "orthotropic": None,
    "voigt": None,
    "n": 128,
    "n_across": None,
    "tol": 1e-8,
    "accuracy": None,
    "quantities": ("tangential",),
    "radius": None,
    "depth": None,
    "threads": 1,
    "precondition": True,
    "normal_held": "approach",
}


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
    normal_held: str = "approach"
    radius: float | None = None
    depth: float | None = None
    params: dict = field(default_factory=dict, compare=False)

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
        nu = finite_number("nu", p["nu"], NU_RANGE)
        if not -1.0 < nu <= 0.5:
            raise InputError("nu", NU_RANGE, p["nu"])
        G = finite_number("G", p["G"], modulus_range("shear modulus"))
        modulus("G", G, "shear modulus")
        material = _turned_with_shape(constants_material(params) or _material(p, G, nu), p["shape_angle"])
        aspect = finite_number("aspect", p["aspect"], ASPECT_RANGE)
        if not MIN_ASPECT <= aspect <= 1.0:
            raise InputError("aspect", ASPECT_RANGE, p["aspect"])
        n = integer("n", p["n"], 2, "an integer >= 2 (cells along the long side)")
        n_across = (
            None
            if p["n_across"] is None
            else integer("n_across", p["n_across"], 1, "an integer >= 1 (cells across the short side)")
        )
        if n * (n_across or n) > 2**26:
            raise InputError("n", "a grid of at most 2**26 cells", f"{n} x {n_across or n}")
        tol = finite_number("tol", p["tol"], "CG tolerance in [1e-14, 1e-2]")
        if not 1e-14 <= tol <= 1e-2:
            raise InputError("tol", "CG tolerance in [1e-14, 1e-2]", p["tol"])
        accuracy = None if p["accuracy"] is None else _accuracy(p["accuracy"], quantities, p["shape"])
        radius = None if p["radius"] is None else finite_number("radius", p["radius"], RADIUS_RANGE)
        depth = None if p["depth"] is None else finite_number("depth", p["depth"], DEPTH_RANGE)
        if "indentation" in quantities and radius is None:
            raise InputError("radius", f"{RADIUS_RANGE} (needed for indentation)", None)
        if "indentation" in quantities and depth is None:
            raise InputError("depth", f"{DEPTH_RANGE} (needed for indentation)", None)
        if radius is not None and not MIN_RADIUS <= radius <= 1.0 / MIN_RADIUS:
            raise InputError("radius", RADIUS_RANGE, p["radius"])
        if depth is not None and not (radius is not None and MIN_DEPTH * radius <= depth < radius):
            raise InputError("depth", DEPTH_RANGE, p["depth"])
        shape = Shape(
            name=p["shape"],
            aspect=aspect,
            sides=integer("sides", p["sides"], 2, "an integer >= 2"),
            angle_deg=finite_number("shape_angle", p["shape_angle"], "a finite angle in degrees"),
            amplitude=finite_number("amplitude", p["amplitude"], "star modulation in [0, 1)"),
            seed=integer("seed", p["seed"], 0, "an integer >= 0"),
            hurst=finite_number("hurst", p["hurst"], "Hurst exponent in (0, 1)"),
            rms=finite_number("rms", p["rms"], "roughness rms in (0, 1]"),
            mask_path=p["mask"],
        )
        cpus = usable_cpus()
        threads = integer("threads", p["threads"], 1, f"an integer in [1, {cpus}] (this machine's CPUs)", cpus)
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
            normal_held=_normal_held(p["normal_held"]),
            radius=radius,
            depth=depth,
            params=dict(params),
        )

    @property
    def grid_given(self) -> bool:
        """Whether the fields named a grid (``n``): without one, the default solve may
        extrapolate over grids (``hpcontact.accuracy.default_solve``)."""
        return self.params.get("n") is not None

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
    accuracy = finite_number("accuracy", value, ACCURACY_RANGE)
    if not 1e-9 <= accuracy < 1.0:
        raise InputError("accuracy", ACCURACY_RANGE, value)
    if shape == "rough":
        raise InputError("accuracy", "not for shape rough (its patch comes from one grid and cannot be refined)", value)
    other = [x for x in quantities if x not in REFINABLE_QUANTITIES]
    if other:
        raise InputError(
            "accuracy", f"only for quantities {', '.join(REFINABLE_QUANTITIES)} (not {', '.join(other)})", value
        )
    return accuracy


def _normal_held(value: Any) -> str:
    """One of ``NORMAL_HELD``, exactly (a spec's "Load" is refused, not guessed)."""
    if isinstance(value, str) and value in NORMAL_HELD:
        return value
    raise InputError("normal_held", f"one of {', '.join(NORMAL_HELD)}", value)


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
    allowed = 'three integers "h k l", not all zero'
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
    anisotropy = finite_number("anisotropy", p["anisotropy"], "cubic anisotropy factor A in [0.01, 100]")
    if not 0.01 <= anisotropy <= 100.0:
        raise InputError("anisotropy", "cubic anisotropy factor A in [0.01, 100]", p["anisotropy"])
    azimuth = finite_number("azimuth", p["azimuth"], "a finite in-plane angle in degrees")
    orientation = p["orientation"]
    if orientation is not None:
        orientation = finite_number("orientation", orientation, "path angle psi in [0, 90] degrees")
        if not 0.0 <= orientation <= 90.0:
            raise InputError(
                "orientation", "path angle psi in [0, 90] degrees ([110] -> [111] -> [001])", p["orientation"]
            )
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
    beta = math.radians(finite_number("shape_angle", shape_angle, "a finite angle in degrees"))
    if isinstance(material, Isotropic) or beta == 0.0:
        return material
    c, s = math.cos(beta), math.sin(beta)
    return material.rotated(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))


def validate(params: Mapping[str, Any]) -> None:
    """Raise ``InputError`` on the first bad field of ``params``; cheap (no grid is built)."""
    Scene.from_params(params)
