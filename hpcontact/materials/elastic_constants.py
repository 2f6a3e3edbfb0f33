r"""A body's elastic material from the fields of a scene: library names, constants, orientation.

One reader for every front end (command line, sweep spec, Python API) and both bodies of a
pair: ``body_material(params, suffix)`` reads the fields named ``<field><suffix>`` (suffix ""
for body 1, "2" for body 2 of a slip scene) and returns an isotropic material, a lab-frame
:class:`~hpcontact.materials.crystal.Crystal`, or None when the body is not described by constants.

Families (at most one per body; each checked, ``InputError`` naming the constant):

* ``cubic``: "C11=… C12=… C44=…" (or a mapping, or three numbers in that order), GPa.
  Positive definite iff C44 > 0, C11 > C12, C11 + 2 C12 > 0 (Born; Nye 1957).
* ``anisotropy`` A with ``nu`` and the modulus scale ``G`` (or ``E``, read as the Young's
  modulus of the A = 1 body, G = E/(2(1 + nu))): cubic with C12 = C11 nu/(1 − nu),
  C44 = A (C11 − C12)/2, (C11 − C12)/2 = G (docs/design.md §2.5); in the scene's stress unit.
  A = 1 exactly is the isotropic body (closed-form kernels), as in punch scenes.
* ``orthotropic``: "E1=… E2=… E3=… G12=… G13=… G23=… nu12=… nu13=… nu23=…" (or a mapping, or
  nine numbers in that order), moduli in GPa; nu_ij is the contraction along j under tension
  along i (nu_ij/E_i = nu_ji/E_j). Checked: moduli > 0, |nu_ij| < sqrt(E_i/E_j) for each pair,
  and Δ = 1 − nu12 nu21 − nu23 nu32 − nu13 nu31 − 2 nu21 nu32 nu13 > 0 (positive definite
  compliance; Lekhnitskii 1963 §3; Ting 1996 §2.6).
* ``voigt``: a general 6 × 6 Voigt stiffness (36 numbers, row by row, or a nested list), GPa,
  Voigt order 11 22 33 23 13 12 (``hpcontact.materials.crystal``); symmetric and positive definite.
* ``material`` naming a library crystal (``crystal.CRYSTALS``, GPa).

``gpa`` is the number of scene stress units in one GPa: 1 for punch scenes (whose crystal
results are in the crystal's unit, GPa), 1e9 for slip scenes (SI, like their library metals).

Orientation (``orientation`` ψ, ``miller`` "h k l", ``azimuth``; docs/design.md §2.5 and
``hpcontact.materials.crystal``): a cubic body defaults to the [001] normal with x along [1̄10]; an
orthotropic or general body defaults to its material axes on the lab axes (1 → x, 2 → y,
3 → z, the normal into the body), turned by ``azimuth`` degrees about z. Orientation fields of
an isotropic body are ignored (as in punch scenes).

Both bodies of a pair are described in the lab frame (``hpcontact.problems.slip.crystal_pair``): the same
fields give body 2 the same lattice orientation as body 1 (one crystal cut along the interface;
body 2's surface normal into itself is then −[hkl], elastically the same direction).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from hpcontact.errors import InputError, finite_number, unused_field
from hpcontact.fields import field
from hpcontact.materials.crystal import (
    CRYSTAL_NU_RANGE,
    Crystal,
    crystal,
    cubic,
    cubic_from_nu_A,
    orthotropic,
    rotation_from_miller,
)

CUBIC = ("C11", "C12", "C44")
ORTHOTROPIC = ("E1", "E2", "E3", "G12", "G13", "G23", "nu12", "nu13", "nu23")
FAMILIES = ("cubic", "orthotropic", "voigt")
ORIENTATION = ("orientation", "miller", "azimuth")
#: Fields of one body beyond the isotropic E, G, nu and the library ``material``.
CONSTANT_FIELDS = ("anisotropy",) + FAMILIES + ORIENTATION
CRYSTAL_PREFIX = "crystal:"
#: Why a field of the isotropic or (nu, A) description is not used beside constants or a library
#: crystal, which give the whole stiffness (``errors.unused_field``; ``hpcontact.scene.UNUSED_FIELDS``).
FIXED_BY_CONSTANTS = {
    "nu": "its elastic constants fix the Poisson ratio",
    "G": "its elastic constants fix the moduli, in GPa",
    "E": "its elastic constants fix the moduli, in GPa",
    "anisotropy": "its elastic constants fix the anisotropy",
}


def crystal_name(name: Any) -> str | None:
    """The library crystal a ``material`` value names explicitly ("crystal:Cu"), else None."""
    if isinstance(name, str) and name.strip().lower().startswith(CRYSTAL_PREFIX):
        return name.strip()[len(CRYSTAL_PREFIX) :].strip()
    return None


def _renamed(error: InputError, prefix: str) -> InputError:
    return InputError(f"{prefix}.{error.field}", error.allowed, error.value)


def _named_values(field: str, value: Any, names: tuple[str, ...]) -> dict[str, float]:
    """ "A=1 B=2", a mapping or len(names) numbers in order → {name: float}; every name required."""
    allowed = f"{' '.join(n + '=...' for n in names)} (or {len(names)} numbers in that order)"
    if isinstance(value, Mapping):
        items = dict(value)
    elif isinstance(value, str):
        tokens = [t for t in re.split(r"[\s,;]+", value.strip()) if t]
        if tokens and all("=" in t for t in tokens):
            items = dict(t.split("=", 1) for t in tokens)
        elif len(tokens) == len(names) and not any("=" in t for t in tokens):
            items = dict(zip(names, tokens))
        else:
            raise InputError(field, allowed, value)
    elif isinstance(value, (list, tuple, np.ndarray)) and len(value) == len(names):
        items = dict(zip(names, value))
    else:
        raise InputError(field, allowed, value)
    unknown = sorted(set(items) - set(names))
    if unknown:
        raise InputError(f"{field}.{unknown[0]}", f"one of {', '.join(names)}", items[unknown[0]])
    missing = [n for n in names if n not in items]
    if missing:
        raise InputError(f"{field}.{missing[0]}", "required: " + allowed, None)
    return {n: finite_number(f"{field}.{n}", items[n], "a finite number") for n in names}


def cubic_from_field(field: str, value: Any, gpa: float) -> Crystal:
    """Cubic stiffness from "C11=… C12=… C44=…" in GPa (× ``gpa``), checked (``crystal.cubic``)."""
    c = _named_values(field, value, CUBIC)
    try:
        base = cubic(*(c[n] for n in CUBIC), name="cubic")  # checked in the unit the user typed
    except InputError as exc:
        raise _renamed(exc, field) from None
    return _in_unit(base, gpa)


def orthotropic_from_field(field: str, value: Any, gpa: float) -> Crystal:
    """Orthotropic stiffness from engineering constants (moduli in GPa × ``gpa``), checked."""
    c = _named_values(field, value, ORTHOTROPIC)
    for n in ("E1", "E2", "E3", "G12", "G13", "G23"):
        if not c[n] > 0.0:
            raise InputError(f"{field}.{n}", "a modulus > 0 (GPa)", c[n])
    E = {1: c["E1"], 2: c["E2"], 3: c["E3"]}
    nu = {(1, 2): c["nu12"], (1, 3): c["nu13"], (2, 3): c["nu23"]}
    for (i, j), v in nu.items():
        bound = math.sqrt(E[i] / E[j])
        if not abs(v) < bound:
            raise InputError(f"{field}.nu{i}{j}", f"|nu{i}{j}| < sqrt(E{i}/E{j}) = {bound:.6g} (positive definite)", v)
    r = {(j, i): v * E[j] / E[i] for (i, j), v in nu.items()}  # nu_ji = nu_ij E_j/E_i
    delta = 1.0 - nu[1, 2] * r[2, 1] - nu[2, 3] * r[3, 2] - nu[1, 3] * r[3, 1] - 2.0 * r[2, 1] * r[3, 2] * nu[1, 3]
    if not delta > 0.0:
        raise InputError(
            f"{field}.nu12,nu13,nu23",
            "1 - nu12 nu21 - nu23 nu32 - nu13 nu31 - 2 nu21 nu32 nu13 > 0 (positive definite)",
            delta,
        )
    try:
        base = orthotropic(
            *(c[n] for n in ORTHOTROPIC[:3]),
            c["nu12"],
            c["nu13"],
            c["nu23"],
            *(c[n] for n in ORTHOTROPIC[3:6]),
            name="orthotropic",
        )
    except InputError as exc:
        raise _renamed(exc, field) from None
    return _in_unit(base, gpa)


def voigt_from_field(field: str, value: Any, gpa: float) -> Crystal:
    """General stiffness from 36 numbers (row by row) or a 6 × 6 nested list, GPa × ``gpa``."""
    allowed = "a 6 x 6 Voigt stiffness in GPa: 36 numbers row by row (order 11 22 33 23 13 12)"
    try:
        if isinstance(value, str):
            numbers = [float(t) for t in re.split(r"[\s,;\[\]]+", value.strip()) if t]
        else:
            numbers = [float(x) for x in np.asarray(value, dtype=np.float64).ravel()]
    except (TypeError, ValueError):
        raise InputError(field, allowed, value) from None
    if len(numbers) != 36:
        raise InputError(field, allowed, f"{len(numbers)} numbers")
    try:
        base = Crystal(np.array(numbers).reshape(6, 6), name="voigt")
    except InputError as exc:
        raise InputError(field, exc.allowed, exc.value) from None
    return _in_unit(base, gpa)


def _in_unit(base: Crystal, gpa: float) -> Crystal:
    """``base`` (GPa) in the scene's stress unit (``gpa`` units per GPa)."""
    return base if gpa == 1.0 else Crystal(base.voigt * gpa, base.name, base.citation)


def _orient(base: Crystal, p: Mapping[str, Any], suffix: str, cubic_frame: bool) -> Crystal:
    """Turn ``base`` (material frame) into the lab frame by the body's orientation fields."""
    names = {n: f"{n}{suffix}" for n in ORIENTATION}
    azimuth = finite_number(names["azimuth"], p.get(names["azimuth"], 0.0), field("azimuth").message)
    orientation, miller = p.get(names["orientation"]), p.get(names["miller"])
    if orientation is not None and miller is not None:
        raise InputError(names["miller"], f"either {names['miller']} or {names['orientation']}, not both", miller)
    if orientation is not None:
        psi = finite_number(names["orientation"], orientation, field("orientation").message)
        if not 0.0 <= psi <= 90.0:
            raise InputError(names["orientation"], field("orientation").message, orientation)
        return base.oriented(psi_deg=psi, azimuth_deg=azimuth)
    if miller is not None:
        try:
            R = rotation_from_miller(miller, azimuth)
        except InputError as exc:
            raise InputError(names["miller"], exc.allowed, miller) from None
        return base.rotated(R)
    if cubic_frame:
        return base.oriented(miller=(0, 0, 1), azimuth_deg=azimuth)
    a = math.radians(azimuth)
    R = np.array([[math.cos(a), math.sin(a), 0.0], [-math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]])
    return base.rotated(R)


def anisotropic_material(
    p: Mapping[str, Any], suffix: str = "", gpa: float = 1.0, library: bool = True
) -> Crystal | None:
    """The body's lab-frame crystal if its fields describe one, else None (isotropic or named).

    ``library``: a plain ``material`` name is a library crystal (punch scenes); otherwise only
    "crystal:NAME" is (slip scenes, whose plain names are isotropic metals).
    """
    f = {n: f"{n}{suffix}" for n in ("material", "anisotropy", "nu", "G", "E") + FAMILIES}
    given = [n for n in FAMILIES if p.get(f[n]) is not None]
    name = p.get(f["material"])
    named = crystal_name(name) if name is not None else None
    if library and name is not None and named is None:
        named = str(name)
    anisotropy = p.get(f["anisotropy"])
    if anisotropy is not None:
        anisotropy = finite_number(f["anisotropy"], anisotropy, field("anisotropy").message)
        if not 0.01 <= anisotropy <= 100.0:
            raise InputError(f["anisotropy"], field("anisotropy").message, p[f["anisotropy"]])
        if anisotropy != 1.0 or given:
            given.append("anisotropy")
    if named is not None:
        given.append("material")
    if len(given) > 1:
        raise InputError(f[given[1]], f"one description of the body: {f[given[0]]} is given too", p.get(f[given[1]]))
    if not given:
        return None
    family = given[0]
    if family != "anisotropy":  # constants or a library crystal: the whole stiffness
        for other in ("nu", "G", "E", "anisotropy"):
            if p.get(f[other]) is not None:
                raise unused_field(f[other], p[f[other]], f[family], p[f[family]], FIXED_BY_CONSTANTS[other])
    if family == "cubic":
        base = cubic_from_field(f["cubic"], p[f["cubic"]], gpa)
    elif family == "orthotropic":
        base = orthotropic_from_field(f["orthotropic"], p[f["orthotropic"]], gpa)
    elif family == "voigt":
        base = voigt_from_field(f["voigt"], p[f["voigt"]], gpa)
    elif family == "material":
        try:
            base = crystal(named)
        except InputError as exc:
            raise InputError(f["material"], exc.allowed, name) from None
        base = _in_unit(base, gpa)
    else:
        base = _nu_A(p, f, anisotropy)
    return _orient(base, p, suffix, cubic_frame=family in ("cubic", "material", "anisotropy"))


def _nu_A(p: Mapping[str, Any], f: Mapping[str, str], anisotropy: float) -> Crystal:
    """Cubic from (nu, A) with the modulus scale G (or E of the A = 1 body)."""
    nu = finite_number(f["nu"], p.get(f["nu"], 0.3), CRYSTAL_NU_RANGE)
    if not -1.0 < nu < 0.5:
        raise InputError(f["nu"], CRYSTAL_NU_RANGE, p.get(f["nu"]))
    if p.get(f["E"]) is not None and p.get(f["G"]) is not None:
        raise InputError(f["G"], f"either {f['E']} or {f['G']} (the modulus scale), not both", p[f["G"]])
    if p.get(f["E"]) is not None:
        E = finite_number(f["E"], p[f["E"]], "Young's modulus of the A = 1 body, finite and > 0")
        if not E > 0.0:
            raise InputError(f["E"], "Young's modulus of the A = 1 body, finite and > 0", p[f["E"]])
        scale = E / (2.0 * (1.0 + nu))
    else:
        scale = finite_number(f["G"], p.get(f["G"], 1.0), "modulus scale (C11 - C12)/2, finite and > 0")
        if not scale > 0.0:
            raise InputError(f["G"], "modulus scale (C11 - C12)/2, finite and > 0", p[f["G"]])
    return cubic_from_nu_A(nu, anisotropy, scale)


def constants_material(params: Mapping[str, Any]) -> Crystal | None:
    """Body 1 of a punch scene when ``cubic``, ``orthotropic`` or ``voigt`` is given (GPa, like the
    library crystals of punch scenes), else None (``scene`` reads the other descriptions)."""
    p = {k: v for k, v in params.items() if v is not None}
    if not any(name in p for name in FAMILIES):
        return None
    return anisotropic_material(p, "", 1.0, library=True)


def describes_crystal(p: Mapping[str, Any]) -> bool:
    """Whether slip-scene fields ``p`` make either body a crystal (``anisotropic_material`` with
    ``library=False``): a crystal family or A ≠ 1, with or without the suffix 2, or "crystal:NAME"."""
    for suffix in ("", "2"):
        if any(p.get(f"{name}{suffix}") is not None for name in FAMILIES):
            return True
        if crystal_name(p.get(f"material{suffix}")) is not None:
            return True
        a = p.get(f"anisotropy{suffix}")
        if a is not None and a != 1.0 and a != 1:
            return True
    return False
