"""Units of the data set as CF/UDUNITS strings: scaled quantities become dimensionless.

The attribute tables of ``dataset`` write a unit as the engine means it: SI units (``N m-1``,
``m2``, ``Pa``, ``s``, ``degree``, ``GPa``), ``1``, or products with the scales of a scene that
has no physical units: ``G`` (the shear modulus), ``a`` (the punch's semi-major extent, 1 on
the grid), ``L`` (the length unit of a sphere's radius and depth, or of a slip scene's input)
and ``F`` (a slip scene's force unit). UDUNITS reads those symbols as something else (``a`` is
the are, 100 m², ``L`` the litre, ``F`` the farad, ``G a`` gauss·are) and pint reads ``a`` as
a year, so a value in units of a scale is stored as the dimensionless ratio it is: ``units =
"1"``, the scale in ``long_name`` ("... in units of G a") and in the machine-readable attribute
``scale`` (the value times the scale is the quantity: K = value · G · a).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

SCALE_SYMBOLS = frozenset({"G", "a", "L", "F"})
_TOKEN = re.compile(r"^([A-Za-z]+)(-?\d+)?$")


def scale_symbols(unit: str) -> set[str]:
    """The scale symbols (``SCALE_SYMBOLS``) in a unit string such as ``"G L2"`` or ``"F L-1"``."""
    found = set()
    for token in unit.split():
        match = _TOKEN.match(token)
        if match and match.group(1) in SCALE_SYMBOLS:
            found.add(match.group(1))
    return found


def cf_attributes(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """``attrs`` (``long_name`` and an engine ``units``) with CF units: a unit that names a scene
    scale becomes ``units = "1"``, ``scale = <unit>`` and "(in units of <unit>)" in the long
    name; other units are kept (they are UDUNITS strings already)."""
    out = dict(attrs)
    unit = out.get("units")
    if isinstance(unit, str) and scale_symbols(unit):
        out["units"] = "1"
        out["scale"] = unit
        if "long_name" in out:
            out["long_name"] = f"{out['long_name']} (in units of {unit})"
    return out
