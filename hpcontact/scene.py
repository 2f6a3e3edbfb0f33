"""A scene: geometry, material, numerical settings and the quantities wanted; validated.

``Scene.from_params`` takes the command-line fields (DESIGN §4.1, with underscores) as a
mapping, fills defaults, and refuses bad input with an ``InputError`` naming the field and the
allowed range. ``hpcontact.plan`` decides what to build and run for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

from .errors import InputError
from .geometry import SHAPES, Shape
from .materials import Isotropic

QUANTITIES = ("tangential", "normal", "compliance", "coupled", "indentation")

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
    "n": 128,
    "n_across": None,
    "tol": 1e-8,
    "quantities": ("tangential",),
    "radius": None,
    "depth": None,
    "threads": 1,
    "precondition": True,
}


def _finite(name: str, value: Any, allowed: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(name, allowed, value) from None
    if not math.isfinite(number):
        raise InputError(name, allowed, value)
    return number


def _integer(name: str, value: Any, low: int, allowed: str) -> int:
    number = _finite(name, value, allowed)
    if number != int(number) or number < low:
        raise InputError(name, allowed, value)
    return int(number)


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
    material: Isotropic
    quantities: tuple[str, ...]
    n: int
    n_across: int | None
    tol: float
    threads: int = 1
    precondition: bool = True
    radius: float | None = None
    depth: float | None = None
    params: dict = field(default_factory=dict, compare=False)

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> "Scene":
        """Validate ``params`` (unknown fields, ranges, NaN/inf) and build the scene."""
        unknown = sorted(set(params) - set(DEFAULTS))
        if unknown:
            raise InputError(unknown[0], f"a known field ({', '.join(sorted(DEFAULTS))})", params[unknown[0]])
        p = {**DEFAULTS, **{k: v for k, v in params.items() if v is not None}}
        if p["shape"] not in SHAPES:
            raise InputError("shape", f"one of {', '.join(SHAPES)}", p["shape"])
        nu = _finite("nu", p["nu"], "Poisson ratio in [-1, 0.5]")
        if not -1.0 <= nu <= 0.5:
            raise InputError("nu", "Poisson ratio in [-1, 0.5]", p["nu"])
        if nu == -1.0:
            raise InputError("nu", "Poisson ratio in (-1, 0.5] (nu = -1 has zero bulk modulus)", p["nu"])
        G = _finite("G", p["G"], "shear modulus, finite and > 0")
        if G <= 0.0:
            raise InputError("G", "shear modulus, finite and > 0", p["G"])
        anisotropy = _finite("anisotropy", p["anisotropy"], "cubic anisotropy factor A > 0")
        if anisotropy != 1.0:
            raise InputError("anisotropy", "1 (anisotropic half-spaces are not in this build)", p["anisotropy"])
        aspect = _finite("aspect", p["aspect"], "b/a in (0, 1]")
        if not 0.0 < aspect <= 1.0:
            raise InputError("aspect", "b/a in (0, 1]", p["aspect"])
        n = _integer("n", p["n"], 2, "an integer >= 2 (cells along the long side)")
        n_across = None if p["n_across"] is None else _integer(
            "n_across", p["n_across"], 1, "an integer >= 1 (cells across the short side)"
        )
        if n * (n_across or n) > 2**26:
            raise InputError("n", "a grid of at most 2**26 cells", f"{n} x {n_across or n}")
        tol = _finite("tol", p["tol"], "CG tolerance in [1e-14, 1e-2]")
        if not 1e-14 <= tol <= 1e-2:
            raise InputError("tol", "CG tolerance in [1e-14, 1e-2]", p["tol"])
        quantities = _quantities(p["quantities"])
        radius = None if p["radius"] is None else _finite("radius", p["radius"], "sphere radius, finite and > 0")
        depth = None if p["depth"] is None else _finite("depth", p["depth"], "approach in (0, radius)")
        if "indentation" in quantities and radius is None:
            raise InputError("radius", "sphere radius, finite and > 0 (needed for indentation)", None)
        if "indentation" in quantities and depth is None:
            raise InputError("depth", "approach in (0, radius) (needed for indentation)", None)
        if radius is not None and radius <= 0.0:
            raise InputError("radius", "sphere radius, finite and > 0", p["radius"])
        if depth is not None and (depth <= 0.0 or (radius is not None and depth >= radius)):
            raise InputError("depth", "approach in (0, radius)", p["depth"])
        shape = Shape(
            name=p["shape"],
            aspect=aspect,
            sides=_integer("sides", p["sides"], 2, "an integer >= 2"),
            angle_deg=_finite("shape_angle", p["shape_angle"], "a finite angle in degrees"),
            amplitude=_finite("amplitude", p["amplitude"], "star modulation in [0, 1)"),
            seed=_integer("seed", p["seed"], 0, "an integer >= 0"),
            hurst=_finite("hurst", p["hurst"], "Hurst exponent in (0, 1)"),
            rms=_finite("rms", p["rms"], "roughness rms in (0, 1]"),
            mask_path=p["mask"],
        )
        threads = _integer("threads", p["threads"], 1, "an integer >= 1")
        return cls(
            shape=shape,
            material=Isotropic(G=G, nu=nu),
            quantities=quantities,
            n=n,
            n_across=n_across,
            tol=tol,
            threads=threads,
            precondition=bool(p["precondition"]),
            radius=radius,
            depth=depth,
            params=dict(params),
        )


def validate(params: Mapping[str, Any]) -> None:
    """Raise ``InputError`` on the first bad field of ``params``; cheap (no grid is built)."""
    Scene.from_params(params)
