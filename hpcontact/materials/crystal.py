"""Elastic stiffness of anisotropic crystals: Voigt matrices, constructors, rotations, a library.

Conventions
-----------
* Voigt order 11, 22, 33, 23, 13, 12 (indices 0..5) with *no* factors of 2 in the stiffness
  matrix: sigma_I = C_IJ eps_J with engineering shear strains eps_4 = 2 eps_23 etc.
  (Nye, *Physical Properties of Crystals*, 1957, ch. VIII; Ting, *Anisotropic Elasticity*, 1996,
  §2.3).  ``voigt_to_tensor``/``tensor_to_voigt`` convert to the full C_ijkl (3 × 3 × 3 × 3).
* Units: any consistent stress unit.  Constructors with no unit stated are dimensionless
  (``cubic_from_nu_A`` scales so that (C11 − C12)/2 = ``scale``); the crystal library is in GPa.
* Every stiffness is float64, symmetric and positive definite; anything else is refused with an
  :class:`~hpcontact.errors.InputError` naming the field.
* Frames.  A *crystal frame* (cube axes for cubic crystals, orthotropy axes for orthotropic
  materials) and a *lab frame*: x, y in the contact plane, z the surface normal pointing INTO the
  half-space z > 0 (the convention of the isotropic engine, docs/design.md §2).  A rotation is stored as
  the 3 × 3 proper orthogonal matrix ``R`` whose rows are the lab axes written in crystal
  coordinates, so v_lab = R v_crystal and

      C_lab_ijkl = R_ia R_jb R_kc R_ld C_crystal_abcd.

Orientations
------------
* ``rotation_from_orientation(psi_deg, azimuth_deg)`` follows docs/design.md §2.5 (Rodríguez-Tembleque et
  al. 2011, §6.3): normal n(psi) = (cos psi/√2, cos psi/√2, sin psi) (psi = 0 → [110],
  35.26° → [111], 90° → [001]) and reference in-plane x axis [1̄10]/√2, which is normal to every
  n(psi), so the frame is continuous along the path; y = z × x.
* ``rotation_from_miller((h, k, l), azimuth_deg)``: z = [hkl]/|[hkl]| (for cubic crystals the
  direction [hkl] is also the normal of the plane (hkl)).  Reference x axis (documented,
  deterministic): x = normalize([001] × z); if z is parallel to [001] (h = k = 0),
  x = [1̄10]/√2.  For every direction [h h l] with h > 0 this is exactly the frame of
  ``rotation_from_orientation`` at tan psi = l/(h√2) (both give x = [1̄10]/√2).
* The azimuth alpha turns the in-plane axes about +z: x = cos α x0 + sin α y0,
  y = −sin α x0 + cos α y0 (the lab x axis lies at angle α from the reference x0, towards y0).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hpcontact.errors import InputError, finite_number
from hpcontact.materials.isotropic import MAX_MODULUS, MIN_MODULUS, modulus, modulus_range

__all__ = [
    "CRYSTAL_NU_RANGE",
    "Crystal",
    "VOIGT_PAIRS",
    "voigt_to_tensor",
    "tensor_to_voigt",
    "check_stiffness",
    "cubic",
    "cubic_from_nu_A",
    "isotropic",
    "orthotropic",
    "zener_ratio",
    "rotate_voigt",
    "rotation_from_orientation",
    "rotation_from_miller",
    "rotation_from_normal",
    "CRYSTALS",
    "crystal",
]

#: Voigt index I ↔ tensor index pair (i, j).
VOIGT_PAIRS: tuple[tuple[int, int], ...] = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
_VOIGT_INDEX = np.array([[0, 5, 4], [5, 1, 3], [4, 3, 2]])

#: Relative asymmetry |C − Cᵀ| / max|C| tolerated before refusing: round-off of a matrix typed or
#: computed in double precision is ~1e-16; 1e-12 leaves room for constants computed by inversion.
_SYMMETRY_RTOL = 1e-12
#: Smallest eigenvalue / largest eigenvalue accepted.  Below ~1e-13 the Barnett–Lothe integrals of
#: the surface Green's function cancel to no significant digits (nearly incompressible limit:
#: the ratio is ~ (1 − 2 nu) for an isotropic body, so nu = 0.4999999999 is still accepted).
_CONDITION_MIN = 1e-13
#: The Poisson ratio of a stiffness built from it (``cubic_from_nu_A``, ``isotropic``; a cubic
#: crystal from (nu, A != 1) in ``hpcontact.scene`` and ``elastic_constants``), stated once: open
#: at 0.5, which an isotropic body allows (``isotropic.NU_RANGE``: its closed forms take it) but
#: where no finite stiffness exists (C11 = 2 G (1 − nu)/(1 − 2 nu)).
CRYSTAL_NU_RANGE = "Poisson ratio in (-1, 0.5) for a crystal (nu = 0.5 has no finite stiffness)"


# --------------------------------------------------------------------------------------------
# Voigt ↔ tensor
# --------------------------------------------------------------------------------------------
def voigt_to_tensor(C6: ArrayLike) -> NDArray[np.float64]:
    """Full stiffness tensor C_ijkl (shape (3, 3, 3, 3), float64) from a 6 × 6 Voigt matrix."""
    C6 = np.asarray(C6, dtype=np.float64)
    if C6.shape != (6, 6):
        raise InputError("stiffness", "a 6 x 6 Voigt matrix", C6.shape)
    idx = _VOIGT_INDEX
    return C6[idx[:, :, None, None], idx[None, None, :, :]].copy()


def tensor_to_voigt(C: ArrayLike) -> NDArray[np.float64]:
    """6 × 6 Voigt matrix from a full tensor C_ijkl (minor symmetries assumed; averaged)."""
    C = np.asarray(C, dtype=np.float64)
    if C.shape != (3, 3, 3, 3):
        raise InputError("stiffness", "a 3 x 3 x 3 x 3 tensor", C.shape)
    # Average the minor-symmetric partners so tiny round-off asymmetries do not leak.
    C = 0.25 * (C + C.transpose(1, 0, 2, 3) + C.transpose(0, 1, 3, 2) + C.transpose(1, 0, 3, 2))
    out = np.empty((6, 6))
    for I, (i, j) in enumerate(VOIGT_PAIRS):
        for J, (k, l) in enumerate(VOIGT_PAIRS):
            out[I, J] = C[i, j, k, l]
    return out


# --------------------------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------------------------
def check_stiffness(C6: ArrayLike, field_name: str = "stiffness") -> NDArray[np.float64]:
    """Return ``C6`` as a read-only, exactly symmetric float64 6 × 6 array, or raise InputError.

    Refused: wrong shape, non-finite entries, relative asymmetry above 1e-12, and matrices that
    are not positive definite (smallest eigenvalue ≤ 1e-13 × largest; a stiffness must give
    positive strain energy for every strain, Nye 1957 ch. VIII §4).
    """
    try:
        C = np.array(C6, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(field_name, "a 6 x 6 real Voigt stiffness matrix", C6) from None
    if C.shape != (6, 6):
        raise InputError(field_name, "a 6 x 6 Voigt stiffness matrix", C.shape)
    if not np.all(np.isfinite(C)):
        raise InputError(field_name, "finite entries", "non-finite entry")
    scale = float(np.max(np.abs(C)))
    if scale == 0.0:
        raise InputError(field_name, "a positive definite stiffness (got all zeros)", 0.0)
    if not MIN_MODULUS <= scale <= MAX_MODULUS:  # isotropic.MIN_MODULUS: finite arithmetic
        raise InputError(field_name, modulus_range("largest entry |C_IJ|"), f"largest entry {scale:.6g}")
    asym = float(np.max(np.abs(C - C.T))) / scale
    if asym > _SYMMETRY_RTOL:
        raise InputError(field_name, "a symmetric matrix, C_IJ = C_JI", f"relative asymmetry {asym:.3e}")
    C = 0.5 * (C + C.T)
    eig = np.linalg.eigvalsh(C)
    if not eig[0] > _CONDITION_MIN * eig[-1]:
        raise InputError(
            field_name,
            "a positive definite stiffness (smallest eigenvalue > 1e-13 x largest)",
            f"eigenvalues {eig[0]:.6g} ... {eig[-1]:.6g}",
        )
    C.setflags(write=False)
    return C


def _positive(name: str, value: float) -> float:
    v = finite_number(name, value, "a finite number > 0")
    if not v > 0.0:
        raise InputError(name, "a finite number > 0", value)
    return v


# --------------------------------------------------------------------------------------------
# The Crystal value object
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Crystal:
    """A linear elastic stiffness (Voigt 6 × 6, float64) with a name and a citation.

    ``voigt`` is in the frame the object was built in (crystal frame for constructors, lab frame
    after :meth:`rotated`/:meth:`oriented`); ``rotation`` records the accumulated rotation
    (rows: lab axes in crystal coordinates, identity for an unrotated crystal).
    """

    voigt: NDArray[np.float64]
    name: str = ""
    citation: str = ""
    rotation: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))

    def __post_init__(self) -> None:
        object.__setattr__(self, "voigt", check_stiffness(self.voigt, "stiffness"))
        R = np.array(self.rotation, dtype=np.float64)
        R.setflags(write=False)
        object.__setattr__(self, "rotation", R)

    # Identity / hashing by value so kernel caches can key on the oriented stiffness.
    @property
    def key(self) -> tuple:
        """Hashable identity (the exact float64 Voigt entries) for kernel caches."""
        return ("anisotropic", self.voigt.tobytes())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Crystal) and np.array_equal(self.voigt, other.voigt)

    def __hash__(self) -> int:
        return hash(self.key)

    @property
    def tensor(self) -> NDArray[np.float64]:
        """Full stiffness C_ijkl, shape (3, 3, 3, 3)."""
        return voigt_to_tensor(self.voigt)

    @property
    def compliance(self) -> NDArray[np.float64]:
        """Voigt compliance S = C⁻¹ (engineering shear strains)."""
        return np.linalg.inv(self.voigt)

    def rotated(self, R: ArrayLike) -> Crystal:
        """This stiffness seen in a frame whose axes (rows of ``R``) are given in the current frame."""
        R = np.asarray(R, dtype=np.float64)
        return Crystal(rotate_voigt(self.voigt, R), self.name, self.citation, R @ self.rotation)

    def oriented(
        self,
        *,
        miller: Sequence[int] | None = None,
        psi_deg: float | None = None,
        normal: Sequence[float] | None = None,
        azimuth_deg: float = 0.0,
    ) -> Crystal:
        """Lab-frame stiffness with the surface normal (+z, into the body) along a crystal direction.

        Give exactly one of ``miller`` (h, k, l), ``psi_deg`` (docs/design.md §2.5 path) or ``normal``
        (any real vector, same in-plane rule as Miller input).  Must be called on a crystal in its
        crystal frame (``rotation`` = identity).
        """
        given = [x is not None for x in (miller, psi_deg, normal)]
        if sum(given) != 1:
            raise InputError("orientation", "exactly one of miller, psi_deg, normal", None)
        if not np.allclose(self.rotation, np.eye(3), atol=0.0, rtol=0.0):
            raise InputError("orientation", "orient a crystal given in its crystal frame", "already rotated")
        if miller is not None:
            R = rotation_from_miller(miller, azimuth_deg)
        elif psi_deg is not None:
            R = rotation_from_orientation(psi_deg, azimuth_deg)
        else:
            R = rotation_from_normal(normal, azimuth_deg)  # type: ignore[arg-type]
        return self.rotated(R)

    def zener_ratio(self) -> float:
        """A = 2 C44/(C11 − C12) of the stored matrix (meaningful for cubic, crystal frame)."""
        return zener_ratio(self.voigt)


# --------------------------------------------------------------------------------------------
# Constructors
# --------------------------------------------------------------------------------------------
def cubic(C11: float, C12: float, C44: float, *, name: str = "", citation: str = "") -> Crystal:
    """Cubic stiffness from C11, C12, C44 (any consistent unit).

    Positive definite iff C44 > 0, C11 − C12 > 0, C11 + 2 C12 > 0 (Born stability; Nye 1957).
    """
    C11 = finite_number("C11", C11, "a finite stiffness")
    C12 = finite_number("C12", C12, "a finite stiffness")
    C44 = finite_number("C44", C44, "a finite stiffness")
    for constant, value in (("C11", C11), ("C12", C12), ("C44", C44)):
        if abs(value) > MAX_MODULUS:  # the smallest: check_stiffness, on the largest entry
            raise InputError(constant, modulus_range(f"|{constant}|"), value)
    if not C44 > 0.0:
        raise InputError("C44", "C44 > 0 (positive definite cubic stiffness)", C44)
    if not C11 - C12 > 0.0:
        raise InputError("C12", f"C12 < C11 = {C11!r} (positive definite cubic stiffness)", C12)
    if not C11 + 2.0 * C12 > 0.0:
        raise InputError("C12", f"C12 > -C11/2 = {-C11 / 2!r} (positive definite cubic stiffness)", C12)
    C = np.zeros((6, 6))
    C[:3, :3] = C12
    C[[0, 1, 2], [0, 1, 2]] = C11
    C[[3, 4, 5], [3, 4, 5]] = C44
    return Crystal(C, name, citation)


def cubic_from_nu_A(nu: float, A: float, scale: float = 1.0) -> Crystal:
    """Cubic stiffness from a Poisson ratio ``nu`` and the Zener ratio ``A`` (docs/design.md §2.5).

    C12 = C11 nu/(1 − nu), C44 = A (C11 − C12)/2, (C11 − C12)/2 = ``scale``, hence
    C11 = 2 scale (1 − nu)/(1 − 2 nu).  At A = 1 this is the isotropic body with shear modulus
    G = scale and Poisson ratio nu.  Allowed: −1 < nu < 0.5 (nu = 0.5 has no finite stiffness;
    the isotropic closed form covers it), A > 0, scale > 0.
    """
    nu = finite_number("nu", nu, CRYSTAL_NU_RANGE)
    if not -1.0 < nu < 0.5:
        raise InputError("nu", CRYSTAL_NU_RANGE, nu)
    A = _positive("anisotropy", A)
    scale = _positive("scale", scale)
    C11 = 2.0 * scale * (1.0 - nu) / (1.0 - 2.0 * nu)
    C12 = 2.0 * scale * nu / (1.0 - 2.0 * nu)
    C44 = A * scale
    return cubic(C11, C12, C44, name=f"cubic(nu={nu!r}, A={A!r})")


def isotropic(G: float, nu: float) -> Crystal:
    """Isotropic stiffness: C11 = λ + 2G, C12 = λ, C44 = G, λ = 2 G nu/(1 − 2 nu); −1 < nu < 0.5."""
    G = _positive("G", G)
    nu = finite_number("nu", nu, CRYSTAL_NU_RANGE)
    if not -1.0 < nu < 0.5:
        raise InputError("nu", CRYSTAL_NU_RANGE, nu)
    lam = 2.0 * G * nu / (1.0 - 2.0 * nu)
    return cubic(lam + 2.0 * G, lam, G, name=f"isotropic(G={G!r}, nu={nu!r})")


def orthotropic(
    E1: float,
    E2: float,
    E3: float,
    nu12: float,
    nu13: float,
    nu23: float,
    G12: float,
    G13: float,
    G23: float,
    *,
    name: str = "",
    citation: str = "",
) -> Crystal:
    """Orthotropic stiffness from engineering constants in the orthotropy axes.

    Compliance (Voigt, engineering shear strains; Ting 1996 §2.6, Lekhnitskii 1963 §3):
    S11 = 1/E1, S22 = 1/E2, S33 = 1/E3, S12 = −nu12/E1, S13 = −nu13/E1, S23 = −nu23/E2,
    S44 = 1/G23, S55 = 1/G13, S66 = 1/G12; C = S⁻¹.  nu_ij is the contraction along j for a
    tension along i (nu_ij/E_i = nu_ji/E_j).  Positive definiteness is checked.
    """
    E1, E2, E3 = (modulus(n, _positive(n, v)) for n, v in (("E1", E1), ("E2", E2), ("E3", E3)))
    G12, G13, G23 = (modulus(n, _positive(n, v)) for n, v in (("G12", G12), ("G13", G13), ("G23", G23)))
    nu12, nu13, nu23 = (
        finite_number(n, v, "a finite Poisson ratio") for n, v in (("nu12", nu12), ("nu13", nu13), ("nu23", nu23))
    )
    S = np.zeros((6, 6))
    S[0, 0], S[1, 1], S[2, 2] = 1.0 / E1, 1.0 / E2, 1.0 / E3
    S[0, 1] = S[1, 0] = -nu12 / E1
    S[0, 2] = S[2, 0] = -nu13 / E1
    S[1, 2] = S[2, 1] = -nu23 / E2
    S[3, 3], S[4, 4], S[5, 5] = 1.0 / G23, 1.0 / G13, 1.0 / G12
    eig = np.linalg.eigvalsh(S)
    if not eig[0] > _CONDITION_MIN * eig[-1]:
        raise InputError(
            "orthotropic constants",
            "a positive definite compliance (e.g. |nu12| < sqrt(E1/E2))",
            f"compliance eigenvalues {eig[0]:.6g} ... {eig[-1]:.6g}",
        )
    C = np.linalg.inv(S)
    return Crystal(0.5 * (C + C.T), name or "orthotropic", citation)


def zener_ratio(C6: ArrayLike) -> float:
    """Zener anisotropy ratio A = 2 C44/(C11 − C12) of a Voigt matrix (cubic, crystal frame)."""
    C6 = np.asarray(C6, dtype=np.float64)
    return float(2.0 * C6[3, 3] / (C6[0, 0] - C6[0, 1]))


# --------------------------------------------------------------------------------------------
# Rotations
# --------------------------------------------------------------------------------------------
_ROTATION = "ia,jb,kc,ld,abcd->ijkl"
#: The contraction order ``optimize=True`` finds for ``_ROTATION`` (it depends on the operands'
#: shapes alone): found once, not at every rotation (einsum_path took 80 of 170 µs a call, and
#: a crystal sweep's set-up turns a material for every distinct orientation it checks).
_ROTATION_PATH = np.einsum_path(_ROTATION, *[np.eye(3)] * 4, np.zeros((3, 3, 3, 3)), optimize=True)[0]


def rotate_voigt(C6: ArrayLike, R: ArrayLike) -> NDArray[np.float64]:
    """Voigt stiffness in the frame whose axes are the rows of ``R`` (proper orthogonal).

    C'_ijkl = R_ia R_jb R_kc R_ld C_abcd (Ting 1996 §2.4).  ``R`` is checked: RᵀR = I to
    1e-12 (round-off of a matrix built from unit vectors is ~1e-16) and det R = +1.
    """
    R = np.asarray(R, dtype=np.float64)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise InputError("rotation", "a finite 3 x 3 matrix", getattr(R, "shape", R))
    if np.max(np.abs(R @ R.T - np.eye(3))) > 1e-12 or np.linalg.det(R) < 0.0:
        raise InputError("rotation", "a proper orthogonal matrix (R Rᵀ = I, det R = +1)", R.tolist())
    C = voigt_to_tensor(C6)
    Cr = np.einsum(_ROTATION, R, R, R, R, C, optimize=_ROTATION_PATH)
    out = tensor_to_voigt(Cr)
    return 0.5 * (out + out.T)


def _in_plane(x0: NDArray[np.float64], z: NDArray[np.float64], azimuth_deg: float) -> NDArray[np.float64]:
    azimuth = math.radians(finite_number("azimuth", azimuth_deg, "a finite angle in degrees"))
    y0 = np.cross(z, x0)
    ca, sa = math.cos(azimuth), math.sin(azimuth)
    x = ca * x0 + sa * y0
    y = -sa * x0 + ca * y0
    R = np.array([x, y, z])
    # Re-orthonormalize against round-off (QR keeps the orientation of a proper rotation).
    q, r = np.linalg.qr(R.T)
    q = q * np.sign(np.diag(r))
    return q.T


def rotation_from_orientation(psi_deg: float, azimuth_deg: float = 0.0) -> NDArray[np.float64]:
    """Rotation for the docs/design.md §2.5 orientation path (rows: lab x, y, z in crystal coordinates).

    z = n(psi) = (cos psi/√2, cos psi/√2, sin psi), x0 = [1̄10]/√2, y0 = z × x0
    = (−sin psi/√2, −sin psi/√2, cos psi); then the azimuth turn.  psi in degrees, any finite
    value (the path is periodic; 0 … 90 is the physical range [110] → [111] → [001]).
    """
    psi = math.radians(finite_number("orientation", psi_deg, "a finite angle in degrees"))
    s2 = math.sqrt(0.5)
    z = np.array([math.cos(psi) * s2, math.cos(psi) * s2, math.sin(psi)])
    x0 = np.array([-s2, s2, 0.0])
    return _in_plane(x0, z, azimuth_deg)


def rotation_from_normal(normal: Sequence[float], azimuth_deg: float = 0.0) -> NDArray[np.float64]:
    """Rotation with lab z along ``normal`` (crystal coordinates), x0 = normalize([001] × z).

    If the normal is parallel to [001] (|[001] × z| < 1e-12, i.e. exactly for integer [00l]),
    x0 = [1̄10]/√2.
    """
    try:
        n = np.array(normal, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise InputError("normal", "three finite numbers, not all zero", normal) from None
    norm = float(np.linalg.norm(n))
    if not (np.all(np.isfinite(n)) and norm > 0.0):
        raise InputError("normal", "three finite numbers, not all zero", list(normal))
    z = n / norm
    c = np.cross(np.array([0.0, 0.0, 1.0]), z)
    cn = float(np.linalg.norm(c))
    if cn < 1e-12:
        x0 = np.array([-math.sqrt(0.5), math.sqrt(0.5), 0.0])
    else:
        x0 = c / cn
    return _in_plane(x0, z, azimuth_deg)


def rotation_from_miller(hkl: Sequence[int] | str, azimuth_deg: float = 0.0) -> NDArray[np.float64]:
    """Rotation with the surface normal along the crystal direction [hkl] (``"h k l"`` accepted).

    Indices must be integers, not all zero.  In-plane rule of :func:`rotation_from_normal`.
    """
    if isinstance(hkl, str):
        parts = hkl.replace(",", " ").split()
    else:
        parts = list(hkl)
    try:
        vals = [float(p) for p in parts]
    except (TypeError, ValueError):
        raise InputError("miller", "three integers h k l, not all zero", hkl) from None
    if len(vals) != 3 or not all(math.isfinite(v) and v == int(v) for v in vals) or not any(vals):
        raise InputError("miller", "three integers h k l, not all zero", hkl)
    return rotation_from_normal(vals, azimuth_deg)


# --------------------------------------------------------------------------------------------
# Library of real cubic crystals (room temperature, GPa)
# --------------------------------------------------------------------------------------------
_SW = (
    "G. Simmons and H. Wang, Single Crystal Elastic Constants and Calculated Aggregate "
    "Properties: A Handbook, 2nd ed., MIT Press (1971)"
)

#: name → (C11, C12, C44) in GPa, citation.  Room temperature (~295–300 K) values as commonly
#: quoted from the compilations of Simmons & Wang (1971) and Hirth & Lothe (Theory of
#: Dislocations, 2nd ed., Wiley 1982, Table 13-1); the original measurement is named.
_LIBRARY: dict[str, tuple[tuple[float, float, float], str]] = {
    "Cu": ((168.4, 121.4, 75.4), f"Overton & Gaffney, Phys. Rev. 98 (1955) 969; via {_SW}"),
    "Al": ((108.2, 61.3, 28.5), "Hirth & Lothe, Theory of Dislocations, 2nd ed. (1982), Table 13-1"),
    "Fe": ((231.4, 134.7, 116.4), f"alpha-Fe; Rayne & Chandrasekhar, Phys. Rev. 122 (1961) 1714; via {_SW}"),
    "Ni": ((246.5, 147.3, 124.7), f"Alers, Neighbours & Sato, J. Phys. Chem. Solids 13 (1960) 40; via {_SW}"),
    "W": ((522.4, 204.4, 160.6), f"Featherston & Neighbours, Phys. Rev. 130 (1963) 1324; via {_SW}"),
    "Si": ((165.7, 63.9, 79.6), "McSkimin, J. Appl. Phys. 24 (1953) 988; Hirth & Lothe (1982) Table 13-1"),
    "Ag": ((124.0, 93.4, 46.1), f"Neighbours & Alers, Phys. Rev. 111 (1958) 707; via {_SW}"),
    "Au": ((192.3, 163.1, 42.0), f"Neighbours & Alers, Phys. Rev. 111 (1958) 707; via {_SW}"),
}

#: Read-only view of the library: name → ((C11, C12, C44) GPa, citation).
CRYSTALS: dict[str, tuple[tuple[float, float, float], str]] = dict(_LIBRARY)

_ALIASES = {
    "alpha-fe": "Fe",
    "fe-alpha": "Fe",
    "α-fe": "Fe",
    "copper": "Cu",
    "aluminium": "Al",
    "aluminum": "Al",
    "iron": "Fe",
    "nickel": "Ni",
    "tungsten": "W",
    "silicon": "Si",
    "silver": "Ag",
    "gold": "Au",
}


def crystal(name: str) -> Crystal:
    """A library crystal by symbol or English name (case-insensitive), stiffness in GPa."""
    key = str(name).strip()
    lookup = {k.lower(): k for k in _LIBRARY}
    canonical = lookup.get(key.lower()) or _ALIASES.get(key.lower())
    if canonical is None:
        raise InputError("material", "one of " + ", ".join(sorted(_LIBRARY)), name)
    (c11, c12, c44), cite = _LIBRARY[canonical]
    return cubic(c11, c12, c44, name=canonical, citation=cite)


def library_names() -> list[str]:
    """Names of the library crystals."""
    return sorted(_LIBRARY)
