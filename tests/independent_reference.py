"""Independent references for the crystal tests: the surface Green's function of an anisotropic
half-space from Stroh's sextic eigenproblem, and Willis' elliptical Hertz contact of a rigid
sphere computed from it.

Nothing here imports hpcontact: the stiffness tensor is built from (C11, C12, C44), turned into
the lab frame by rotations written out here, and the Green's function comes from numpy's
eigen-decomposition of the Stroh matrix (Ting, Anisotropic Elasticity, 1996, §5.3), not from the
Barnett–Lothe integrals of ``hpcontact.kernels.anisotropic``. Angular integrals use composite
Gauss–Legendre rules (the code uses the trapezoidal rule).

Conventions (those the engine documents, restated so they can be checked): a surface traction
t̂(k) produces the surface displacement û(k) = H(φ) t̂(k)/|k|, k = |k| (cos φ, sin φ); for an
isotropic body H_zz = (1 − ν)/G. H = i A B⁻¹ with A, B the displacement and traction halves of
the three Stroh eigenvectors with Im p > 0. Willis (1966, J. Mech. Phys. Solids 14, 163): the
Hertz pressure p0 √(1 − x²/a² − y²/b²) gives, inside the ellipse, the deflection

    u_z(x) = (a b p0 / 8) ∫_0^{2π} H_zz(φ)/s(φ) [1 − (m·x)²/s(φ)²] dφ,   s² = a² cos²φ + b² sin²φ,

so matching d − r²/(2R) with e = b/a, σ² = cos²φ + e² sin²φ, I_c = ∫ H cos²φ/σ³,
I_s = ∫ H sin²φ/σ³, I_0 = ∫ H/σ: I_c = I_s fixes e, a² = 2 R d I_c/I_0, p0 = 4a/(R e I_c),
P = (2π/3) a b p0. The contact axes are the lab x and y where H_zz(φ) = H_zz(−φ) (a mirror
plane normal to x), which ``willis_contact`` checks.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

#: (C11, C12, C44) in GPa of the README's indentation table: the values hpcontact.materials.crystal
#: cites (Simmons & Wang 1971; Hirth & Lothe 1982), typed here again so that a changed library
#: constant shows up as a failing comparison, not as a silently moved reference.
CUBIC_GPA = {
    "Cu": (168.4, 121.4, 75.4),
    "Al": (108.2, 61.3, 28.5),
    "Fe": (231.4, 134.7, 116.4),
    "Ni": (246.5, 147.3, 124.7),
    "W": (522.4, 204.4, 160.6),
    "Si": (165.7, 63.9, 79.6),
}


def cubic_tensor(C11: float, C12: float, C44: float) -> np.ndarray:
    """C_ijkl of a cubic crystal in its cube axes."""
    d = np.eye(3)
    C = C12 * np.einsum("ij,kl->ijkl", d, d) + C44 * (np.einsum("ik,jl->ijkl", d, d) + np.einsum("il,jk->ijkl", d, d))
    for i in range(3):
        C[i, i, i, i] += C11 - C12 - 2.0 * C44
    return C


def cubic_from_nu_A(nu: float, A: float) -> np.ndarray:
    """The engine's (nu, A) parametrization (README "Cubic crystals"): (C11 − C12)/2 = 1,
    C12/(C11 + C12) = nu, C44 = A."""
    return cubic_tensor(2.0 * (1.0 - nu) / (1.0 - 2.0 * nu), 2.0 * nu / (1.0 - 2.0 * nu), A)


def lab_frame(normal, x_hint) -> np.ndarray:
    """Rows: lab x, y, z in crystal coordinates; z along ``normal``, x the part of ``x_hint``
    normal to it."""
    z = np.asarray(normal, dtype=float)
    z = z / np.linalg.norm(z)
    x = np.asarray(x_hint, dtype=float)
    x = x - (x @ z) * z
    x = x / np.linalg.norm(x)
    return np.array([x, np.cross(z, x), z])


def orientation_frame(psi_deg: float) -> np.ndarray:
    """The README's orientation path: normal cos ψ [110]/√2 + sin ψ [001], x = [1̄10]/√2 (normal
    to a mirror plane of the cubic crystal for every ψ)."""
    psi = math.radians(psi_deg)
    return lab_frame((math.cos(psi) / math.sqrt(2.0), math.cos(psi) / math.sqrt(2.0), math.sin(psi)), (-1.0, 1.0, 0.0))


def rotate(C: np.ndarray, frame: np.ndarray) -> np.ndarray:
    return np.einsum("ai,bj,ck,dl,ijkl->abcd", frame, frame, frame, frame, C)


def green_stroh(C: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """H(φ) = i A B⁻¹ from the eigenvectors of Stroh's N with Im p > 0 (Ting 1996, §5.3), for
    every φ of the array ``phi`` (shape phi.shape + (3, 3))."""
    phi = np.asarray(phi, dtype=float)
    m = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=-1)
    n = np.array([0.0, 0.0, 1.0])
    Q = np.einsum("...j,ijkl,...l->...ik", m, C, m)
    R = np.einsum("...j,ijkl,l->...ik", m, C, n)
    T = np.einsum("j,ijkl,l->ik", n, C, n)
    Ti = np.linalg.inv(T)
    Rt = np.swapaxes(R, -1, -2)
    N = np.zeros(phi.shape + (6, 6))
    N[..., :3, :3] = -Ti @ Rt
    N[..., :3, 3:] = Ti
    N[..., 3:, :3] = R @ Ti @ Rt - Q
    N[..., 3:, 3:] = -R @ Ti
    p, V = np.linalg.eig(N)
    upper = p.imag > 0.0
    if not np.all(upper.sum(axis=-1) == 3):
        raise ArithmeticError("Stroh eigenvalues not split 3/3 (degenerate material?)")
    order = np.argsort(~upper, axis=-1, kind="stable")[..., :3]  # the three with Im p > 0
    V = np.take_along_axis(V, order[..., None, :], axis=-1)
    return 1j * V[..., :3, :] @ np.linalg.inv(V[..., 3:, :])


def gauss_on_circle(panels: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of a composite Gauss–Legendre rule on [0, 2π)."""
    x, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(0.0, 2.0 * math.pi, panels + 1)
    half = 0.5 * np.diff(edges)
    nodes = (edges[:-1, None] + half[:, None] * (x[None, :] + 1.0)).ravel()
    weights = (half[:, None] * w[None, :]).ravel()
    return nodes, weights


def compliance_zz(C: np.ndarray, phi: np.ndarray) -> np.ndarray:
    return green_stroh(C, phi)[..., 2, 2].real


def vlassak_nix_modulus(C: np.ndarray, panels: int = 8, order: int = 32) -> float:
    """M = 2/⟨H_zz⟩ (Vlassak & Nix 1994): the circular-contact indentation modulus."""
    phi, w = gauss_on_circle(panels, order)
    return 2.0 * 2.0 * math.pi / float(np.sum(w * compliance_zz(C, phi)))


def willis_contact(C: np.ndarray, R: float = 1.0, d: float = 1e-4, panels: int = 8, order: int = 32) -> dict:
    """Willis' elliptical contact of a rigid sphere (radius R, approach d) on the body C (lab
    frame): a, b, b/a ≤ 1, load P and the indentation modulus M = 3P/(4 √R d^{3/2})."""
    phi, w = gauss_on_circle(panels, order)
    h = compliance_zz(C, phi)
    mirrored = compliance_zz(C, -phi)
    if np.max(np.abs(h - mirrored)) > 1e-12 * np.max(np.abs(h)):
        raise ValueError("H_zz(φ) ≠ H_zz(−φ): the contact axes are not the lab axes")
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2

    def moments(e: float) -> tuple[float, float, float]:
        sigma2 = c2 + e * e * s2
        return (
            float(np.sum(w * h * c2 / sigma2**1.5)),
            float(np.sum(w * h * s2 / sigma2**1.5)),
            float(np.sum(w * h / np.sqrt(sigma2))),
        )

    e = math.exp(
        brentq(
            lambda t: moments(math.exp(t))[0] - moments(math.exp(t))[1],
            math.log(0.1),
            math.log(10.0),
            xtol=1e-15,
            rtol=1e-15,
        )
    )
    i_c, _, i_0 = moments(e)
    a = math.sqrt(2.0 * R * d * i_c / i_0)
    p0 = 4.0 * a / (R * e * i_c)
    load = 2.0 * math.pi / 3.0 * a * a * e * p0
    return {
        "a": a,
        "b": e * a,
        "b_over_a": min(e, 1.0 / e),
        "load": load,
        "modulus": 3.0 * load / (4.0 * math.sqrt(R) * d**1.5),
    }
