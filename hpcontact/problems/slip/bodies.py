r"""Two contacting bodies: materials by name, principal curvatures, Hertz ellipse, combined compliance.

A contact pair is two bodies, each an isotropic elastic solid (or rigid) whose surface near the
first point of contact is a paraboloid with principal radii of curvature (R_a, R_b) turned by an
angle in the contact plane: a sphere (R, R), a cylinder (R, ∞), an ellipsoid (R_a, R_b), a flat
(∞, ∞). Everything a boundary-element solve of the pair needs follows from them.

Separation (Johnson 1985, §4.1). Each surface is z_i = ½ xᵀ C_i x with C_i = Rot(θ_i)
diag(1/R_a, 1/R_b) Rot(θ_i)ᵀ, so the initial gap is h = ½ xᵀ (C_1 + C_2) x = A x'² + B y'² in the
principal axes of C_1 + C_2 (0 < A ≤ B; x' is the major axis of the contact ellipse).

Combined compliance (docs/design.md §2; Johnson 1985, §5.3 and §7.1). Body 1 is the half-space z > 0 of
the engine and carries the traction t = (t_x, t_y, p); body 2 carries −t. The relative surface
displacement u_1 − u_2 that enters the contact conditions is

    tangential and normal blocks (xx, xy, yy, zz):  A_1 + A_2,
    coupling blocks (xz, yz, zx, zy):               A_1 − A_2,

because both surfaces move radially inward under a pressure and the normal displacements that
tangential tractions cause have opposite signs on the two sides. Every non-coupling block of an
isotropic body is a combination of 1/G and nu/G, so the sum is *exactly* the block of one
equivalent body (`Pair.equivalent`) with

    1/G_eq = 1/G_1 + 1/G_2,    nu_eq = G_eq (nu_1/G_1 + nu_2/G_2),

hence E* = 2 G_eq/(1 − nu_eq) (1/E* = Σ (1 − nu_i²)/E_i) and (2 − nu_eq)/G_eq = Σ (2 − nu_i)/G_i,
the combination in the Cattaneo–Mindlin compliance (Johnson 1985, eq. 7.41). The coupling blocks
scale with (1 − 2nu_1)/G_1 − (1 − 2nu_2)/G_2, which vanishes for *elastically similar* pairs
(Johnson 1985, §5.4); its size is Dundurs' parameter

    β = ½ [(1 − 2nu_1)/G_1 − (1 − 2nu_2)/G_2] / [(1 − nu_1)/G_1 + (1 − nu_2)/G_2]

(|β| ≤ ½; a rigid body has 1/G = 0). Goodman (1962) neglected the effect of the coupling on the
normal pressure; that "decoupled" approximation is exact when β = 0.

Hertz ellipse (Johnson 1985, §4.2, eqs. 3.49 and 4.39–4.41). Pressure p0 (1 − x²/a² − y²/b²)^½
on an ellipse with b = k a ≤ a gives, with the thin-safe integrals K, D = (K − E)/m, B = K − D of
m = 1 − k² (``analytic.mindlin_ellipse_integrals``),

    B/A = B(k)/(k² D(k)),   a³ = 3 P D(k)/(2π A E*),   d = p0 b K(k)/E*,   p0 = 3P/(2π a b),

and the normal contact stiffness dP/dd = 3P/(2d) (= 2 a E* for a circle).

Materials (room temperature, polycrystalline; E and nu from N. E. Dowling, *Mechanical Behavior
of Materials*, 4th ed., Pearson 2013, Table 5.2): copper E = 130 GPa, nu = 0.343; iron / mild
steel E = 212 GPa, nu = 0.293; aluminium E = 70.3 GPa, nu = 0.345. These are the three metals
of the seed paper's sphere pairs (Cu, Fe, Al; radii 8 and 9 mm), whose own table of moduli did
not survive text extraction. Friction coefficients are inputs, never library values.

References
----------
- K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985.
- L. M. Goodman, "Contact stress analysis of normally loaded rough spheres", J. Appl. Mech. 29
  (1962) 515–522.
- J. Dundurs, discussion, J. Appl. Mech. 36 (1969) 650–652.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from hpcontact.analytic import mindlin_ellipse_integrals
from hpcontact.errors import InputError
from hpcontact.fields import SLIP, field
from hpcontact.materials.isotropic import NU_RANGE, Isotropic, modulus, modulus_range

#: name → (Young's modulus E [Pa], Poisson ratio nu, source). Dowling 2013, Table 5.2.
MATERIALS: Mapping[str, tuple[float, float, str]] = {
    "Cu": (130.0e9, 0.343, "copper; Dowling, Mechanical Behavior of Materials, 4th ed. 2013, Table 5.2"),
    "Fe": (212.0e9, 0.293, "iron / mild steel; Dowling, Mechanical Behavior of Materials, 4th ed. 2013, Table 5.2"),
    "Al": (70.3e9, 0.345, "aluminium; Dowling, Mechanical Behavior of Materials, 4th ed. 2013, Table 5.2"),
}
ALIASES: Mapping[str, str] = {
    "cu": "Cu",
    "copper": "Cu",
    "fe": "Fe",
    "iron": "Fe",
    "steel": "Fe",
    "al": "Al",
    "aluminium": "Al",
    "aluminum": "Al",
}
RIGID = "rigid"
MATERIAL_NAMES = tuple(MATERIALS) + ("steel", RIGID)

#: Pairs whose coupling modulus |(1−2nu1)/G1 − (1−2nu2)/G2| is below this fraction of
#: (1−nu1)/G1 + (1−nu2)/G2 (i.e. |β| < 5e-13) are treated as elastically similar: the
#: coupling is then a rounding residue of equal numbers, not physics.
SIMILARITY_TOL = 1e-12


def _number(field: str, value: Any, allowed: str) -> float:
    if isinstance(value, bool):
        raise InputError(field, allowed, value)
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(field, allowed, value) from None
    if math.isnan(x):
        raise InputError(field, allowed, value)
    return x


def material_by_name(name: Any, field: str = "material") -> Isotropic | None:
    """The library material called ``name`` (case-insensitive; None for ``"rigid"``).

    G = E/(2(1 + nu)) in pascals. Unknown names raise ``InputError(field, ...)``.
    """
    allowed = f"one of {', '.join(MATERIAL_NAMES)} (or give E and nu)"
    if not isinstance(name, str):
        raise InputError(field, allowed, name)
    key = name.strip()
    if key.lower() == RIGID:
        return None
    key = ALIASES.get(key.lower(), key)
    if key not in MATERIALS:
        raise InputError(field, allowed, name)
    E, nu, _ = MATERIALS[key]
    return Isotropic(G=E / (2.0 * (1.0 + nu)), nu=nu)


def material_from_moduli(E: Any = None, G: Any = None, nu: Any = None, suffix: str = "") -> Isotropic:
    """An isotropic material from (E, nu) or (G, nu); fields are named ``E{suffix}`` etc.

    nu defaults to 0.3 and G to 1 (the engine's dimensionless default) when neither E nor G is
    given; giving both E and G over-determines nu and is refused.
    """
    nu_value = 0.3 if nu is None else _number(f"nu{suffix}", nu, NU_RANGE)
    if not (-1.0 < nu_value <= 0.5) or not math.isfinite(nu_value):
        raise InputError(f"nu{suffix}", NU_RANGE, nu)
    if E is not None and G is not None:
        raise InputError(f"G{suffix}", f"either E{suffix} or G{suffix}, not both", G)
    if E is not None:
        e = modulus(f"E{suffix}", _number(f"E{suffix}", E, modulus_range("Young's modulus")), "Young's modulus")
        return Isotropic(G=e / (2.0 * (1.0 + nu_value)), nu=nu_value)
    g = 1.0 if G is None else _number(f"G{suffix}", G, modulus_range("shear modulus"))
    return Isotropic(G=modulus(f"G{suffix}", g, "shear modulus"), nu=nu_value)


def _radius(field: str, value: Any) -> float:
    """A principal radius of curvature: > 0, or ∞ (None, "inf", "flat") for a flat direction."""
    allowed = "a radius of curvature > 0 (or inf for a flat direction)"
    if value is None or (isinstance(value, str) and value.strip().lower() in ("inf", "infinity", "flat")):
        return math.inf
    r = _number(field, value, allowed)
    if not r > 0.0:
        raise InputError(field, allowed, value)
    return r


@dataclass(frozen=True)
class Body:
    """One body: material (None = rigid), principal radii (R_a, R_b) and their angle (degrees).

    R_a lies along the direction ``angle_deg`` from x, R_b across it; math.inf is a flat
    direction. Curvatures are 1/R (0 when flat).
    """

    material: Isotropic | None
    radius_a: float = math.inf
    radius_b: float = math.inf
    angle_deg: float = 0.0

    def __post_init__(self) -> None:
        for name, r in (("radius_a", self.radius_a), ("radius_b", self.radius_b)):
            if not (r > 0.0) or math.isnan(r):
                raise InputError(name, "a radius of curvature > 0 (or inf)", r)
        if not math.isfinite(self.angle_deg):
            raise InputError("angle", field("angle", SLIP).message, self.angle_deg)

    @classmethod
    def sphere(cls, material: Isotropic | None, radius: float) -> Body:
        return cls(material, radius, radius)

    @classmethod
    def cylinder(cls, material: Isotropic | None, radius: float, axis_deg: float = 0.0) -> Body:
        """A cylinder whose axis lies along ``axis_deg`` (flat along the axis)."""
        return cls(material, math.inf, radius, axis_deg)

    @classmethod
    def flat(cls, material: Isotropic | None) -> Body:
        return cls(material)

    def curvature(self) -> np.ndarray:
        """C = Rot(θ) diag(1/R_a, 1/R_b) Rot(θ)ᵀ (1/length), the Hessian of the surface height."""
        t = math.radians(self.angle_deg)
        R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
        return R @ np.diag([1.0 / self.radius_a, 1.0 / self.radius_b]) @ R.T

    @property
    def compliance(self) -> tuple[float, float, float]:
        """((1 − nu)/G, nu/G, (1 − 2nu)/G) (1/stress); zeros for a rigid body."""
        if self.material is None:
            return 0.0, 0.0, 0.0
        G, nu = self.material.G, self.material.nu
        return (1.0 - nu) / G, nu / G, (1.0 - 2.0 * nu) / G


@dataclass(frozen=True)
class HertzEllipse:
    """Hertz solution of the pair at load P: semi-axes a ≥ b, approach, peak pressure, axes angle.

    ``angle_deg``: direction of the major axis a from the scene's x axis (body 1's frame).
    ``A``, ``B``: gap coefficients h = A x'² + B y'² in the principal frame (1/length).
    """

    load: float
    a: float
    b: float
    depth: float
    p0: float
    angle_deg: float
    A: float
    B: float
    E_star: float

    @property
    def aspect(self) -> float:
        return self.b / self.a

    @property
    def area(self) -> float:
        return math.pi * self.a * self.b

    @property
    def normal_stiffness(self) -> float:
        """dP/dd = 3P/(2d) (P ∝ d^{3/2} at fixed shape; 2aE* for a circle) [force/length]."""
        return 1.5 * self.load / self.depth


@dataclass(frozen=True)
class Pair:
    """Two bodies in contact; body 1 carries the traction t, body 2 carries −t."""

    body1: Body
    body2: Body

    def __post_init__(self) -> None:
        if self.body1.material is None and self.body2.material is None:
            raise InputError("material", "at least one elastic body (both are rigid)", RIGID)

    # -- compliance --------------------------------------------------------------------------
    def _sums(self) -> tuple[float, float, float, float]:
        c1, c2 = self.body1.compliance, self.body2.compliance
        inv_g = sum(1.0 / b.material.G for b in (self.body1, self.body2) if b.material is not None)
        return inv_g, c1[1] + c2[1], c1[0] + c2[0], c1[2] - c2[2]

    @property
    def equivalent(self) -> Isotropic:
        """One body with exactly the pair's non-coupling blocks: 1/G_eq = Σ1/G_i, nu_eq = G_eq Σ nu_i/G_i."""
        inv_g, nu_over_g, _, _ = self._sums()
        G = 1.0 / inv_g
        return Isotropic(G=G, nu=min(0.5, G * nu_over_g))  # min: rounding of nu_eq = 0.5 pairs

    @property
    def coupling_modulus(self) -> float:
        """(1 − 2nu_1)/G_1 − (1 − 2nu_2)/G_2 (1/stress): the coupling blocks' factor."""
        return self._sums()[3]

    @property
    def dundurs_beta(self) -> float:
        """Dundurs' β = ½[(1−2nu1)/G1 − (1−2nu2)/G2]/[(1−nu1)/G1 + (1−nu2)/G2] (Johnson 1985, §5.4)."""
        _, _, one_minus_nu_over_g, c = self._sums()
        return 0.5 * c / one_minus_nu_over_g

    @property
    def similar(self) -> bool:
        """Elastically similar: the coupling blocks cancel (|β| below rounding, SIMILARITY_TOL)."""
        _, _, one_minus_nu_over_g, c = self._sums()
        return abs(c) <= SIMILARITY_TOL * one_minus_nu_over_g

    @property
    def E_star(self) -> float:
        """1/E* = Σ (1 − nu_i)/(2G_i) = Σ (1 − nu_i²)/E_i (Johnson 1985, eq. 4.22)."""
        return self.equivalent.E_star

    @property
    def G_star(self) -> float:
        """4/G* = Σ (2 − nu_i)/G_i: bonded circle K = 2aG* (Johnson 1985, eq. 7.41)."""
        return self.equivalent.G_star

    def coupling_material(self, body: int) -> Isotropic | None:
        """Body ``body``'s material (1 or 2), or None when rigid."""
        return (self.body1 if body == 1 else self.body2).material

    # -- geometry ----------------------------------------------------------------------------
    def relative_curvature(self) -> tuple[float, float, float]:
        """(A, B, angle_deg): gap h = A x'² + B y'², 0 < A ≤ B, x' at angle_deg from x (1/length)."""
        C = self.body1.curvature() + self.body2.curvature()
        values, vectors = np.linalg.eigh(0.5 * (C + C.T))
        kappa_a, kappa_b = float(values[0]), float(values[1])
        if not kappa_a > 0.0:
            raise InputError(
                "radius2",
                "relative curvature > 0 in every direction (parallel cylinders or flats give a "
                "line or plane contact, not an ellipse)",
                kappa_a,
            )
        angle = math.degrees(math.atan2(vectors[1, 0], vectors[0, 0])) % 180.0
        if kappa_b - kappa_a <= 1e-14 * kappa_b:  # a circle has no axes: keep the scene frame
            angle = 0.0
        return 0.5 * kappa_a, 0.5 * kappa_b, angle

    def hertz(self, load: float) -> HertzEllipse:
        """Hertz contact ellipse of the pair at normal load ``load`` (Johnson 1985, §4.2)."""
        if not (math.isfinite(load) and load > 0.0):
            raise InputError("load", field("load", SLIP).message, load)
        A, B, angle = self.relative_curvature()
        k = hertz_aspect(B / A)
        K, D, _ = (float(v) for v in mindlin_ellipse_integrals(k))
        E_star = self.E_star
        a = (3.0 * load * D / (2.0 * math.pi * A * E_star)) ** (1.0 / 3.0)
        b = k * a
        p0 = 3.0 * load / (2.0 * math.pi * a * b)
        depth = p0 * b * K / E_star
        return HertzEllipse(load=load, a=a, b=b, depth=depth, p0=p0, angle_deg=angle, A=A, B=B, E_star=E_star)


def hertz_aspect(curvature_ratio: float) -> float:
    """b/a of the Hertz ellipse for a gap ratio B/A ≥ 1: the root of B(k)/(k² D(k)) = B/A.

    Johnson 1985, eq. 4.39, rewritten with D = (K − E)/m and B = K − D so that it stays exact
    at k → 1 (where K − E → 0). The left side rises monotonically from 1 (k = 1) as k falls.
    """
    if not (math.isfinite(curvature_ratio) and curvature_ratio >= 1.0):
        raise InputError("radius_b", "a curvature ratio B/A >= 1", curvature_ratio)
    if curvature_ratio - 1.0 <= 4e-15:
        return 1.0

    def f(log_k: float) -> float:
        k = math.exp(log_k)
        _, D, Bk = (float(v) for v in mindlin_ellipse_integrals(k))
        return math.log(Bk / (k * k * D)) - math.log(curvature_ratio)

    lo = -1.0
    while f(lo) < 0.0:
        lo *= 2.0
        if lo < -80.0:
            raise InputError("radius_b", "a contact ellipse with b/a > 1e-30", curvature_ratio)
    from scipy.optimize import brentq  # on first use, not at import (strip_cells' docstring)

    return math.exp(brentq(f, lo, 0.0, xtol=1e-15, rtol=1e-15, maxiter=200))


def isotropic_pair(p: Mapping[str, Any]) -> Pair:
    """The pair of isotropic (or rigid) bodies named by solver fields (the names of
    ``hpcontact solve``); crystals: ``crystal_pair.pair_from_params``.

    Body 1: ``material`` (library name) or ``E``/``G`` with ``nu``; radii ``radius`` and
    ``radius_b`` (default: a sphere). Body 2: ``material2`` or ``E2``/``G2``/``nu2`` (default:
    rigid, docs/design.md §2: one elastic body against a rigid one unless a scene names two bodies);
    radii ``radius2`` and ``radius2_b`` (default: flat), turned by ``body2_angle`` degrees.
    """
    if p.get("material") is not None:
        if any(p.get(k) is not None for k in ("E", "G", "nu")):
            key = next(k for k in ("E", "G", "nu") if p.get(k) is not None)
            raise InputError(key, "either material or E/G/nu for body 1, not both", p[key])
        m1 = material_by_name(p["material"], "material")
    else:
        m1 = material_from_moduli(p.get("E"), p.get("G"), p.get("nu"))
    if p.get("material2") is not None:
        if any(p.get(k) is not None for k in ("E2", "G2", "nu2")):
            key = next(k for k in ("E2", "G2", "nu2") if p.get(k) is not None)
            raise InputError(key, "either material2 or E2/G2/nu2 for body 2, not both", p[key])
        m2 = material_by_name(p["material2"], "material2")
    elif any(p.get(k) is not None for k in ("E2", "G2", "nu2")):
        m2 = material_from_moduli(p.get("E2"), p.get("G2"), p.get("nu2"), suffix="2")
    else:
        m2 = None
    if p.get("radius") is None:
        raise InputError("radius", "a radius of curvature > 0 (body 1)", None)
    r1 = _radius("radius", p["radius"])
    if math.isinf(r1):
        raise InputError("radius", "a finite radius of curvature > 0 (body 1)", p["radius"])
    r1b = r1 if p.get("radius_b") is None else _radius("radius_b", p["radius_b"])
    r2 = _radius("radius2", p.get("radius2"))
    r2b = r2 if p.get("radius2_b") is None else _radius("radius2_b", p["radius2_b"])
    angle2 = (
        0.0 if p.get("body2_angle") is None else _number("body2_angle", p["body2_angle"], "a finite angle in degrees")
    )
    if not math.isfinite(angle2):
        raise InputError("body2_angle", "a finite angle in degrees", p["body2_angle"])
    return Pair(Body(m1, r1, r1b, 0.0), Body(m2, r2, r2b, angle2))
