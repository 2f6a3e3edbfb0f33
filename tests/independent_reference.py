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

Galin's bonded elliptical punch (``galin_ellipse_compliance``, ``galin_ellipse_stiffness``): the
traction c (1 − x²/a² − y²/b²)^{−1/2}/(2π a b) displaces the ellipse uniformly by u = J c,
J = (1/8π) ∮ Re H(φ)/s(φ) dφ, for the kernel Re H (the engine's ``tangential``; Galin 1948,
Willis 1966), so J⁻¹ gives the exact stiffnesses. The integral is taken after the substitution
φ = π/2 + θ, tan θ = (b/a) sinh v, smooth in v however thin the ellipse. Units: a = 1, the stress
unit of C (G = (C11 − C12)/2 = 1 for ``cubic_from_nu_A``). At isotropy the Stroh eigenvalue
p = i is defective, so isotropic checks use the closed form ``green_isotropic``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import lapack, lu_factor, lu_solve
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


# --------------------------------------------------------------------------------------------
# Galin's bonded elliptical punch on the Re H kernel
# --------------------------------------------------------------------------------------------
#: Voigt index I ↔ tensor pair (i, j), the engine's order 11, 22, 33, 23, 13, 12 (no factors
#: of 2 in the stiffness; README "Cubic crystals"), typed here again.
_VOIGT_PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))

#: Relative bound on what the truncation of the v-axis leaves out (see :func:`galin_truncation`).
GALIN_TRUNCATION = 1e-17


def stiffness_tensor(C) -> np.ndarray:
    """C_ijkl (3 × 3 × 3 × 3, float64) from a full tensor or a 6 × 6 Voigt matrix (order 11, 22,
    33, 23, 13, 12, no factors of 2)."""
    C = np.asarray(C, dtype=float)
    if C.shape == (3, 3, 3, 3):
        return C
    if C.shape != (6, 6):
        raise ValueError(f"stiffness: expected (3, 3, 3, 3) or (6, 6), got {C.shape}")
    T = np.empty((3, 3, 3, 3))
    for I, (i, j) in enumerate(_VOIGT_PAIRS):
        for K, (k, l) in enumerate(_VOIGT_PAIRS):
            T[i, j, k, l] = T[j, i, k, l] = T[i, j, l, k] = T[j, i, l, k] = C[I, K]
    return T


def green_isotropic(phi, nu: float, G: float = 1.0) -> np.ndarray:
    """Closed-form H(φ) of the isotropic half-space (Johnson 1985, §3.2, §3.6; the engine's
    convention, hpcontact/kernels/anisotropic.py):

        H = [(I − ν m mᵀ)/G, +i(1 − 2ν) m/(2G); −i(1 − 2ν) mᵀ/(2G), (1 − ν)/G],  m = (cos φ, sin φ).

    Needed because :func:`green_stroh` is not usable at isotropy: there N has the triple,
    defective eigenvalue p = i, and numpy's eigenvectors leave H wrong by ~1.7e-8 (measured at
    A = 1, ν = 0.3). Units: 1/G."""
    phi = np.asarray(phi, dtype=float)
    c, s = np.cos(phi), np.sin(phi)
    H = np.zeros(phi.shape + (3, 3), dtype=complex)
    H[..., 0, 0] = (1.0 - nu * c * c) / G
    H[..., 1, 1] = (1.0 - nu * s * s) / G
    H[..., 0, 1] = H[..., 1, 0] = -nu * c * s / G
    H[..., 0, 2] = 0.5j * (1.0 - 2.0 * nu) * c / G
    H[..., 1, 2] = 0.5j * (1.0 - 2.0 * nu) * s / G
    H[..., 2, 0] = -H[..., 0, 2]
    H[..., 2, 1] = -H[..., 1, 2]
    H[..., 2, 2] = (1.0 - nu) / G
    return H


def _green_of(C):
    """H(φ) as a function of the array φ: C itself if callable, else Stroh's H of the stiffness."""
    if callable(C):
        return C
    T = stiffness_tensor(C)
    return lambda phi: green_stroh(T, phi)


def _positive_aspect(aspect: float) -> float:
    e = float(aspect)
    if not (e > 0.0 and math.isfinite(e)):
        raise ValueError(f"aspect: expected a positive finite b/a, got {aspect!r}")
    return e


def galin_truncation(C, aspect: float, tol: float = GALIN_TRUNCATION) -> float:
    """The half-length V of the v-interval [−V, V] of :func:`galin_ellipse_rule`, such that the
    two tails drop less than ``tol`` relative of the smallest eigenvalue of ∫_0^π Re H/s dφ.

    Bound (e = b/a, a = 1): the v-integrand is Re H/√(1 + e² sinh² v), of norm ≤ h/(e sinh|v|)
    with h = max_φ ‖Re H(φ)‖₂, so the two tails are ≤ (2h/e) ln coth(V/2) ≤ (4h/e) e^{−V}/(1 − e^{−2V}).
    The integral is ≥ λ ∫_0^π dφ/s ≥ λ π/max(1, e) (λ = min_φ of the smallest eigenvalue of
    Re H, which is positive definite: H is the Hermitian positive definite inverse of the
    surface impedance). Hence V = ln(4 h max(1, e)/(tol π λ e)), with h and λ from 64
    equispaced directions and a factor 2 added for what that sampling may miss."""
    e = _positive_aspect(aspect)
    H = _green_of(C)(np.linspace(0.0, math.pi, 64, endpoint=False)).real
    H = 0.5 * (H + np.swapaxes(H, -1, -2))
    eig = np.linalg.eigvalsh(H)
    lam, h = float(eig[:, 0].min()), float(np.abs(eig).max())
    if not lam > 0.0:
        raise ArithmeticError(f"Re H(φ) not positive definite (smallest eigenvalue {lam})")
    return math.log(2.0 * 4.0 * h * max(1.0, e) / (tol * math.pi * lam * e))


def galin_ellipse_rule(C, aspect: float, panels: int, order: int = 16, v_max: float | None = None) -> np.ndarray:
    """J = (1/8π) ∮ Re H(φ)/s(φ) dφ for a = 1, b = ``aspect``, by one fixed rule: ``panels``
    composite Gauss–Legendre panels of ``order`` nodes on v ∈ [−V, V] (V from
    :func:`galin_truncation` unless given) after the substitution

        φ = π/2 + θ,  tan θ = e sinh v  (e = b/a):  dθ/s = dv/(a √(1 + e² sinh² v)),

    [s = b cosh v cos θ and dθ = e cosh v cos²θ dv], which maps θ ∈ (−π/2, π/2) to the real v
    axis and spreads the peak of 1/s at φ = π/2 (height 1/b, width ~e) over O(1) in v: the
    integrand is analytic in a strip around the real v axis, its only nearby singularities
    those of √(1 + e² sinh² v) at ±acosh(1/e) ± iπ/2 and those of H (at a distance set by the
    material). Re H and s are π-periodic, so ∮ = 2 ∫_0^π. ``C``: stiffness (tensor or Voigt,
    any units) or a callable φ ↦ H(φ); J in 1/(stress unit of C × a)."""
    e = _positive_aspect(aspect)
    green = _green_of(C)
    if v_max is None:
        v_max = galin_truncation(green, e)
    x, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(-v_max, v_max, panels + 1)
    half = 0.5 * np.diff(edges)
    v = (edges[:-1, None] + half[:, None] * (x[None, :] + 1.0)).ravel()
    wv = (half[:, None] * w[None, :]).ravel()
    t = e * np.sinh(v)
    H = green(0.5 * math.pi + np.arctan(t)).real
    return np.einsum("n,nij->ij", wv / np.hypot(1.0, t), H) / (4.0 * math.pi)


def galin_ellipse_quadrature(
    C, aspect: float, tol: float = 1e-13, order: int = 16, panels: int = 8, max_panels: int = 1 << 14
) -> dict:
    """:func:`galin_ellipse_rule` with the panel count doubled (from ``panels``) until two
    successive J agree to ``tol``, measured as max|ΔJ_ij|/max|J_ij|. Returns J (the finer of the
    two), ``error`` (that difference, the reference's own error estimate), ``panels``, ``nodes``
    (of the final rule), ``evaluations`` (all H evaluations, the truncation's 64 included) and
    ``v_max``."""
    e = _positive_aspect(aspect)
    green = _green_of(C)
    v_max = galin_truncation(green, e)
    previous = galin_ellipse_rule(green, e, panels, order, v_max)
    evaluations = 64 + panels * order
    while True:
        panels *= 2
        J = galin_ellipse_rule(green, e, panels, order, v_max)
        evaluations += panels * order
        error = float(np.max(np.abs(J - previous)) / np.max(np.abs(J)))
        if error <= tol:
            return {
                "J": J,
                "error": error,
                "panels": panels,
                "nodes": panels * order,
                "evaluations": evaluations,
                "v_max": v_max,
            }
        if panels >= max_panels:
            raise ArithmeticError(f"Galin quadrature not converged: {error:.2e} at {panels} panels")
        previous = J


def galin_ellipse_compliance(C, aspect: float, tol: float = 1e-13, order: int = 16) -> tuple[np.ndarray, float]:
    """Compliance J (3 × 3, float64, symmetric to round-off) of a rigid bonded elliptical punch,
    semi-axes a = 1 along x and b = ``aspect`` along y, on the half-space whose surface Green's
    function is Re H (``C``: lab-frame stiffness, tensor or Voigt, or a callable φ ↦ H(φ)),
    and the quadrature's error estimate (relative, see :func:`galin_ellipse_quadrature`).

    The traction p = c (1 − x²/a² − y²/b²)^{−1/2}/(2π a b) (total force c) has the transform
    c sin κ/κ, κ² = a²k_x² + b²k_y²; with ∫_0^∞ sin(ks)/(ks) dk = π/(2s) the displacement at the
    centre is u = J c,

        J = (1/8π) ∮ H(φ)/s(φ) dφ = (1/8π) ∮ Re H(φ)/s(φ) dφ,   s² = a² cos²φ + b² sin²φ

    (H(φ + π) = conj H(φ), s(φ + π) = s(φ)), and by Galin's theorem (L. A. Galin 1948, Contact
    Problems in the Theory of Elasticity, 1961; J. R. Willis 1966, J. Mech. Phys. Solids 14,
    163: any even kernel homogeneous of degree −1) the displacement under this traction is
    uniform over the ellipse for the kernel Re H, so J is the exact compliance of the punch.
    Units: 1/(stress unit of C × a); with :func:`cubic_from_nu_A` (G = (C11 − C12)/2 = 1) J·G·a."""
    q = galin_ellipse_quadrature(C, aspect, tol=tol, order=order)
    return q["J"], q["error"]


def galin_ellipse_stiffness(C, aspect: float, tol: float = 1e-13, order: int = 16) -> dict:
    """The engine's stiffnesses (hpcontact/plan.py) of the elliptical punch a = 1, b = ``aspect``
    from the exact compliance J of :func:`galin_ellipse_compliance`:

    - ``tangential`` (kernel Re H, normal approach held, u_z = 0): K_xx, K_xy, K_yx, K_yy, the
      tangential 2 × 2 block of J⁻¹ (also as the array ``approach_held``);
    - ``normal`` (frictionless punch; H_zz is real and even, so Galin applies to it alone):
      K_zz = 1/J_zz;
    - ``load_held``: the tangential stiffness with the normal load held (F_z = 0), J_tt⁻¹ for the
      2 × 2 tangential block J_tt of J. Equal to ``approach_held`` when Re H_xz = Re H_yz = 0
      (isotropic bodies, and crystals with that symmetry).

    Also ``J``, ``error`` (relative quadrature error estimate of J), ``panels``, ``nodes``.
    Units: stress unit of C × a (K/(G a) for :func:`cubic_from_nu_A`)."""
    q = galin_ellipse_quadrature(C, aspect, tol=tol, order=order)
    J = q["J"]
    Kt = np.linalg.inv(J)[:2, :2]
    return {
        "K_xx": float(Kt[0, 0]),
        "K_xy": float(Kt[0, 1]),
        "K_yx": float(Kt[1, 0]),
        "K_yy": float(Kt[1, 1]),
        "K_zz": float(1.0 / J[2, 2]),
        "approach_held": Kt,
        "load_held": np.linalg.inv(J[:2, :2]),
        "J": J,
        "error": q["error"],
        "panels": q["panels"],
        "nodes": q["nodes"],
    }


# --------------------------------------------------------------------------------------------
# A dense (non-FFT) collocation BEM of a bonded patch of a pair of isotropic half-spaces
# --------------------------------------------------------------------------------------------
def _cell_primitives(u: np.ndarray, v: np.ndarray) -> dict[str, np.ndarray]:
    """F with ∂²F/∂u∂v = the kernel, for the kernels of Boussinesq and Cerruti (r² = u² + v²):
    1/r: u asinh(v/|u|) + v asinh(u/|v|) (= u ln(v + r) + v ln(u + r) up to u ln|u| + v ln|v|);
    u²/r³: v asinh(u/|v|); v²/r³: u asinh(v/|u|); uv/r³: −r;
    u/r²: u atan(v/u) + (v/2) ln r²; v/r²: the same with u, v swapped (each checked by
    differentiation; terms depending on u or v alone cancel in a rectangle's four corners).
    Corners never lie on u = 0 or v = 0 here (collocation at cell centres)."""
    r2 = u * u + v * v
    au, av = u * np.arcsinh(v / np.abs(u)), v * np.arcsinh(u / np.abs(v))
    return {
        "1": au + av,
        "xx": av,
        "yy": au,
        "xy": -np.sqrt(r2),
        "x": u * np.arctan(v / u) + 0.5 * v * np.log(r2),
        "y": v * np.arctan(u / v) + 0.5 * u * np.log(r2),
    }


def cell_integrals(X: np.ndarray, Y: np.ndarray, dx: float, dy: float) -> dict[str, np.ndarray]:
    """∫∫ k(X − x', Y − y') dx' dy' over the cell |x'| ≤ dx/2, |y'| ≤ dy/2 for the kernels of
    :func:`_cell_primitives` (X, Y: field point relative to the cell centre): the primitive's
    four-corner difference."""
    hx, hy = 0.5 * dx, 0.5 * dy
    corners = [(X + hx, Y + hy, 1.0), (X - hx, Y + hy, -1.0), (X + hx, Y - hy, -1.0), (X - hx, Y - hy, 1.0)]
    total: dict[str, np.ndarray] = {}
    for u, v, sign in corners:
        for name, value in _cell_primitives(u, v).items():
            total[name] = total.get(name, 0.0) + sign * value
    return total


def pair_constants(E1: float, nu1: float, E2: float | None = None, nu2: float | None = None) -> dict[str, float]:
    """The compliances of the relative surface displacement of two isotropic half-spaces pressed
    together (body 2 rigid when E2 is None), Johnson (1985) §3.2, §3.6, §5.1:
    N = Σ (1 − νᵢ)/Gᵢ (normal and the 1/r part of the tangential kernel), T = Σ νᵢ/Gᵢ (the x²/r³
    part), and Dundurs' β = [(1 − 2ν₁)/G₁ − (1 − 2ν₂)/G₂] / (2N) (the normal–tangential
    coupling, of size β N/(2π) · x/r²). Units: 1/(unit of E)."""
    G1 = E1 / (2.0 * (1.0 + nu1))
    N, T, C = (1.0 - nu1) / G1, nu1 / G1, (1.0 - 2.0 * nu1) / G1
    if E2 is not None:
        G2 = E2 / (2.0 * (1.0 + nu2))
        N, T, C = N + (1.0 - nu2) / G2, T + nu2 / G2, C - (1.0 - 2.0 * nu2) / G2
    return {"N": N, "T": T, "beta": C / (2.0 * N)}


def dense_compliance(mask: np.ndarray, dx: float, dy: float, N: float, T: float, beta: float) -> np.ndarray:
    """The collocation matrix (3m × 3m, m = cells of ``mask``; unknowns t_x, t_y, p cell by
    cell, piecewise constant; displacements at the cell centres) of the relative surface
    displacement, built entry by entry from the closed-form cell integrals (no FFT):

        u_x = (1/2π) ∫ [(N/r + T x²/r³) t_x + T xy/r³ t_y] − (β N/2π) ∫ x/r² p,
        u_z = (1/2π) ∫ N/r p + (β N/2π) ∫ (x t_x + y t_y)/r²,

    and u_y likewise (x ↔ y); x the field point minus the source point. The coupling kernels
    are odd, with opposite signs in the two blocks, so the matrix is symmetric (Betti's
    reciprocity); which block carries the minus sign is a convention of the body's z axis and
    does not change any stiffness (every one is even in β)."""
    i, j = np.nonzero(mask)
    di, dj = i[:, None] - i[None, :], j[:, None] - j[None, :]  # field cell minus source cell
    oi, oj = np.arange(-mask.shape[0] + 1, mask.shape[0]), np.arange(-mask.shape[1] + 1, mask.shape[1])
    table = cell_integrals(oi[:, None] * dx, oj[None, :] * dy, dx, dy)  # each offset once
    c = {name: value[di + mask.shape[0] - 1, dj + mask.shape[1] - 1] for name, value in table.items()}
    s = 1.0 / (2.0 * math.pi)
    A_xx, A_yy, A_xy = s * (N * c["1"] + T * c["xx"]), s * (N * c["1"] + T * c["yy"]), s * T * c["xy"]
    B_x, B_y = s * beta * N * c["x"], s * beta * N * c["y"]
    return np.block([[A_xx, A_xy, -B_x], [A_xy, A_yy, -B_y], [B_x, B_y, s * N * c["1"]]])


def dense_bonded_stiffness(
    mask: np.ndarray, dx: float, dy: float, N: float, T: float, beta: float, coupled: bool = True
) -> dict:
    """Stiffnesses of a rigid bonded patch (the cells of ``mask``) by dense LU solves of
    :func:`dense_compliance` for unit rigid displacements δ_x, δ_y, d (K_ij = cell area × the
    sum of component i of solution j):

    - ``tangential`` (2 × 2): tangential tractions only (p = 0: Goodman's decoupled contact);
    - ``coupled`` (2 × 2, when ``coupled``): all three components, then the approach condensed
      out at zero normal force change, K_tt − K_tz K_zz⁻¹ K_zt;
    - ``K_zz``: the frictionless punch (normal block alone).

    Also ``symmetry`` (max |M − Mᵀ|/max |M|: 0 up to rounding), ``unknowns`` (of the largest
    system) and ``condition`` (LAPACK's 1-norm condition estimate, dgecon, of the largest
    system: the κ of the round-off bounds)."""
    M = dense_compliance(mask, dx, dy, N, T, beta)
    m = int(mask.sum())
    area = dx * dy
    condition = 0.0

    def stiffness(block: np.ndarray, comps: int) -> np.ndarray:
        nonlocal condition
        lu, piv = lu_factor(block)
        rcond, info = lapack.dgecon(lu, float(np.abs(block).sum(axis=0).max()), norm="1")
        if info != 0 or not rcond > 0.0:
            raise ArithmeticError(f"dgecon failed (info {info}, rcond {rcond})")
        condition = max(condition, 1.0 / rcond)
        rhs = np.kron(np.eye(comps), np.ones((m, 1)))
        return area * rhs.T @ lu_solve((lu, piv), rhs)

    out = {
        "tangential": stiffness(M[: 2 * m, : 2 * m], 2),
        "K_zz": float(stiffness(M[2 * m :, 2 * m :], 1)[0, 0]),
        "symmetry": float(np.max(np.abs(M - M.T)) / np.max(np.abs(M))),
        "unknowns": (3 if coupled else 2) * m,
    }
    if coupled:
        K3 = stiffness(M, 3)
        out["coupled"] = K3[:2, :2] - np.outer(K3[:2, 2], K3[2, :2]) / K3[2, 2]
    out["condition"] = condition
    return out
