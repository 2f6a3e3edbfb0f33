"""A scene: geometry, material, numerical settings and the quantities wanted; validated.

``Scene.from_params`` takes the command-line fields (DESIGN §4.1, with underscores) as a
mapping, fills defaults, and refuses bad input with an ``InputError`` naming the field and the
allowed range. ``hpcontact.plan`` decides what to build and run for it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

from .crystal import Crystal, crystal, cubic_from_nu_A
from .errors import InputError, finite_number, integer
from .geometry import SHAPES, Shape
from .materials import Isotropic

Material = Isotropic | Crystal

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
    "orientation": None,
    "miller": None,
    "azimuth": 0.0,
    "material": None,
    "n": 128,
    "n_across": None,
    "tol": 1e-8,
    "quantities": ("tangential",),
    "radius": None,
    "depth": None,
    "threads": 1,
    "precondition": True,
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
        nu = finite_number("nu", p["nu"], "Poisson ratio in [-1, 0.5]")
        if not -1.0 <= nu <= 0.5:
            raise InputError("nu", "Poisson ratio in [-1, 0.5]", p["nu"])
        if nu == -1.0:
            raise InputError("nu", "Poisson ratio in (-1, 0.5] (nu = -1 has zero bulk modulus)", p["nu"])
        G = finite_number("G", p["G"], "shear modulus, finite and > 0")
        if G <= 0.0:
            raise InputError("G", "shear modulus, finite and > 0", p["G"])
        material = _material(p, G, nu)
        aspect = finite_number("aspect", p["aspect"], "b/a in (0, 1]")
        if not 0.0 < aspect <= 1.0:
            raise InputError("aspect", "b/a in (0, 1]", p["aspect"])
        n = integer("n", p["n"], 2, "an integer >= 2 (cells along the long side)")
        n_across = None if p["n_across"] is None else integer(
            "n_across", p["n_across"], 1, "an integer >= 1 (cells across the short side)"
        )
        if n * (n_across or n) > 2**26:
            raise InputError("n", "a grid of at most 2**26 cells", f"{n} x {n_across or n}")
        tol = finite_number("tol", p["tol"], "CG tolerance in [1e-14, 1e-2]")
        if not 1e-14 <= tol <= 1e-2:
            raise InputError("tol", "CG tolerance in [1e-14, 1e-2]", p["tol"])
        quantities = _quantities(p["quantities"])
        radius = None if p["radius"] is None else finite_number("radius", p["radius"], "sphere radius, finite and > 0")
        depth = None if p["depth"] is None else finite_number("depth", p["depth"], "approach in (0, radius)")
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
            sides=integer("sides", p["sides"], 2, "an integer >= 2"),
            angle_deg=finite_number("shape_angle", p["shape_angle"], "a finite angle in degrees"),
            amplitude=finite_number("amplitude", p["amplitude"], "star modulation in [0, 1)"),
            seed=integer("seed", p["seed"], 0, "an integer >= 0"),
            hurst=finite_number("hurst", p["hurst"], "Hurst exponent in (0, 1)"),
            rms=finite_number("rms", p["rms"], "roughness rms in (0, 1]"),
            mask_path=p["mask"],
        )
        threads = integer("threads", p["threads"], 1, "an integer >= 1")
        return cls(
            shape=shape,
            material=material,
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


def _material(p: Mapping[str, Any], G: float, nu: float) -> Material:
    """The half-space: isotropic (closed-form kernels) unless a crystal or A ≠ 1 is asked.

    ``material`` names a library crystal (GPa; G and nu are then ignored); otherwise a cubic
    crystal from (nu, A) with (C11 − C12)/2 = G (DESIGN §2.5). A crystal is turned so that the
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
            raise InputError("orientation", "path angle psi in [0, 90] degrees ([110] -> [111] -> [001])", p["orientation"])
    miller = None if p["miller"] is None else _miller(p["miller"])
    if orientation is not None and miller is not None:
        raise InputError("miller", "either miller or orientation, not both", p["miller"])
    if p["material"] is None and anisotropy == 1.0:
        return Isotropic(G=G, nu=nu)
    if p["material"] is not None:
        base = crystal(str(p["material"]))
    else:
        if nu == 0.5:
            raise InputError("nu", "Poisson ratio in (-1, 0.5) for a cubic crystal (A != 1)", nu)
        base = cubic_from_nu_A(nu, anisotropy, scale=G)
    if orientation is not None:
        return base.oriented(psi_deg=orientation, azimuth_deg=azimuth)
    return base.oriented(miller=miller or (0, 0, 1), azimuth_deg=azimuth)


def validate(params: Mapping[str, Any]) -> None:
    """Raise ``InputError`` on the first bad field of ``params``; cheap (no grid is built)."""
    Scene.from_params(params)
