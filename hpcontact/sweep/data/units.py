"""Units of the data set as CF/UDUNITS strings: scaled quantities are stored as dimensionless ratios.

The attribute tables of ``dataset`` write a unit as the engine means it: SI units (``N m-1``,
``m2``, ``Pa``, ``s``, ``degree``, ``GPa``), ``1``, or products with the scales of a scene that
has no physical units: ``G`` (the shear modulus), ``a`` (the punch's semi-major extent, 1 on
the grid), ``L`` (the length unit of a sphere's radius and depth, or of a slip scene's input)
and ``F`` (a slip scene's force unit). UDUNITS reads those symbols as something else (``a`` is
the are, 100 m², ``L`` the litre, ``F`` the farad, ``G a`` gauss·are) and pint reads ``a`` as
a year, so no unit string can carry the scale: G and a are parameters of the scene, not units.

The convention (``CONVENTION``, also the data set's global ``comment``): a value in units of a
scale is stored as the dimensionless ratio it is,

* ``units = "1"``: valid CF and UDUNITS, so every checker and unit library reads it, and
  xarray's plot label reads "<long_name> [1]";
* ``long_name`` ending "(in units of G a)": the label says what the ratio is taken to
  ("stiffness K_xx: force along x per unit displacement along x (in units of G a) [1]");
* ``comment`` (a standard CF attribute) saying it in words: "dimensionless: the quantity
  divided by G a (G: ..., a: ...); multiply by G a for the quantity";
* ``scale = "G a"``: the same, machine-readable (symbols with UDUNITS exponents, ``G L2``,
  ``F L-1``); value × scale = the quantity. ``dimensional`` applies it: given G and a in SI it
  returns the quantity with a UDUNITS unit (``dimensional(ds.K_xx, G=80e9, a=1e-3)``: N/m as
  ``Pa m``).

CF's ``units_metadata`` (CF-1.11) is for temperatures and leap seconds only, so it is not used.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from typing import Any

SCALE_SYMBOLS = frozenset({"G", "a", "L", "F"})
#: What each scale symbol stands for (``comment`` and the global note).
SCALE_MEANINGS: Mapping[str, str] = {
    "G": "G: the shear modulus of the scene, (C11 - C12)/2 of a cubic crystal",
    "a": "a: the semi-major extent of the punch (for a mask, half the long side of the contact)",
    "L": "L: the length unit of the input (a sphere's radius and depth, a slip scene's lengths)",
    "F": "F: the force unit of the input",
}
#: The SI unit of each scale symbol (``dimensional`` with values in SI).
SI: Mapping[str, str] = {"G": "Pa", "a": "m", "L": "m", "F": "N"}
CONVENTION = (
    "Units convention (hpcontact.sweep.data.units): a quantity in units of a scale of the scene ({symbols}) is stored "
    'as the dimensionless ratio to that scale: units = "1", long_name ending "(in units of <scale>)", a comment '
    'saying so, and the attribute scale = "<scale>" (the symbols with UDUNITS exponents); value times the scale '
    "is the quantity (hpcontact.sweep.data.units.dimensional). {meanings}. Every other units attribute is a UDUNITS "
    "unit (SI, degree, GPa)."
)
_TOKEN = re.compile(r"^([A-Za-z]+)(-?\d+)?$")


def scale_symbols(unit: str) -> set[str]:
    """The scale symbols (``SCALE_SYMBOLS``) in a unit string such as ``"G L2"`` or ``"F L-1"``."""
    return {symbol for symbol, _ in factors(unit) if symbol in SCALE_SYMBOLS}


def factors(unit: str) -> list[tuple[str, int]]:
    """``"G L2"`` → [("G", 1), ("L", 2)], ``"N m-1"`` → [("N", 1), ("m", -1)]: the symbols of a
    product of powers (UDUNITS syntax) and their exponents."""
    out = []
    for token in unit.split():
        match = _TOKEN.match(token)
        if match:
            out.append((match.group(1), int(match.group(2) or 1)))
    return out


def comment(unit: str) -> str:
    """The ``comment`` of a value stored in units of the scale ``unit`` (``"G a"``)."""
    meanings = "; ".join(SCALE_MEANINGS[s] for s in sorted(scale_symbols(unit), key="GaLF".index))
    return f"dimensionless: the quantity divided by {unit} ({meanings}); multiply by {unit} for the quantity"


def convention(symbols: Iterable[str]) -> str:
    """The global note on the units convention for a data set whose scales use ``symbols``."""
    used = sorted(set(symbols) & SCALE_SYMBOLS, key="GaLF".index)
    return CONVENTION.format(
        symbols=", ".join(used) or "none in this data set",
        meanings="; ".join(SCALE_MEANINGS[s] for s in used) or "No value is scaled",
    )


def cf_attributes(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """``attrs`` (``long_name`` and an engine ``units``) with CF units: a unit that names a scene
    scale becomes ``units = "1"``, ``scale = <unit>``, "(in units of <unit>)" at the end of the
    long name and a ``comment`` (module docstring); other units are kept (they are UDUNITS
    strings already)."""
    out = dict(attrs)
    unit = out.get("units")
    if isinstance(unit, str) and scale_symbols(unit):
        out["units"] = "1"
        out["scale"] = unit
        out["comment"] = comment(unit)
        if "long_name" in out:
            out["long_name"] = f"{out['long_name']} (in units of {unit})"
    return out


def dimensional(da: Any, units: str | None = None, **scales: float) -> Any:
    """The quantity a variable stored in units of a scene scale (attribute ``scale``) stands for:
    ``da`` times the scale, each symbol's value given in ``scales`` (in SI unless ``units`` names
    the result's unit), e.g. ``dimensional(ds.K_xx, G=80e9, a=1e-3)``: K in N/m, ``units = "Pa
    m"``. The long name loses "(in units of ...)"; ``scale`` and ``comment`` are dropped.
    Variables without a ``scale`` are returned unchanged."""
    scale = da.attrs.get("scale")
    if not scale:
        return da
    powers = factors(scale)
    missing = sorted({s for s, _ in powers} - set(scales))
    if missing:
        raise ValueError(f"{da.name}: in units of {scale}: give {', '.join(missing)} (e.g. {missing[0]}=1.0)")
    factor = 1.0
    for symbol, power in powers:
        factor *= float(scales[symbol]) ** power
    out = da * factor
    attrs = {k: v for k, v in da.attrs.items() if k not in ("scale", "comment")}
    suffix = f" (in units of {scale})"
    if attrs.get("long_name", "").endswith(suffix):
        attrs["long_name"] = attrs["long_name"][: -len(suffix)]
    attrs["units"] = units or " ".join(SI[s] + ("" if p == 1 else str(p)) for s, p in powers)
    out.attrs = attrs
    return out
