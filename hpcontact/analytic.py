"""Closed-form references for isotropic contact stiffness (docs/design.md §2.4).

Every function here is a textbook result that the numerical solvers are checked against.
Conventions (one elastic half-space against a rigid body unless stated):

* ``G`` shear modulus [Pa], ``nu`` Poisson ratio (allowed range [-1, 0.5]);
* ``E* = 2G/(1 - nu)`` the contact (plane-strain indentation) modulus [Pa];
* ``G* = 4G/(2 - nu)`` the tangential contact modulus [Pa];
* lengths in any consistent unit [m]; stiffness = force / displacement [N/m];
  compliance = displacement / force [m/N].

All functions take scalars or numpy arrays (broadcast together) in float64 and return a Python
``float`` when every argument is a scalar, else an ``ndarray``. Invalid arguments raise
:class:`hpcontact.errors.InputError` naming the argument.

Thin ellipses: the Mindlin functions stay accurate (a few ulp) down to ``b/a = 1e-12`` and
beyond. ``m = 1 - (b/a)**2`` rounds to 1 in double precision once b/a < 1e-8, so the complete
elliptic integrals are never evaluated from ``m``; they are evaluated from the complementary
parameter ``p = (b/a)**2`` with ``scipy.special.ellipkm1`` and Carlson's symmetric integral
``elliprd`` (DLMF 19.25.1), and for b/a < 1e-18 from their logarithmic leading terms, whose
relative error there is below 1e-34.

References
----------
- K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985 (§3.2 and §3.6 point
  forces; §3.5 elliptical punch; §4.2 Hertz; §7.2 Cattaneo–Mindlin; §7.4 oscillating forces).
- R. D. Mindlin, "Compliance of elastic bodies in contact", J. Appl. Mech. 16, 259–268 (1949).
- R. D. Mindlin and H. Deresiewicz, "Elastic spheres in contact under varying oblique forces",
  J. Appl. Mech. 20, 327–344 (1953).
- Q. Li, "On the tensor of tangential stiffness in contact problems", 2017 (ellipse/rectangle
  stiffness anisotropy, normalization K E*/(K_zz G*)).
- DLMF §19.25(i) (Legendre integrals in terms of Carlson's R_F, R_D).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from hpcontact.errors import InputError

__all__ = [
    "effective_modulus",
    "effective_shear_modulus",
    "circle_tangential_stiffness",
    "circle_normal_stiffness",
    "mindlin_ellipse_integrals",
    "mindlin_ellipse_compliance",
    "mindlin_ellipse_stiffness",
    "mindlin_ellipse_stiffness_ratio",
    "mindlin_ellipse_normalized_stiffness",
    "thin_ellipse_ratio_asymptote",
    "elliptical_punch_normal_stiffness",
    "hertz_sphere",
    "hertz_peak_pressure",
    "hertz_pressure",
    "stick_radius",
    "cattaneo_mindlin_displacement",
    "cattaneo_mindlin_stiffness",
    "mindlin_deresiewicz_unloading_displacement",
    "mindlin_deresiewicz_reloading_displacement",
    "mindlin_deresiewicz_unloading_stiffness",
]

ArrayLike = Any  # float | np.ndarray | anything np.asarray turns into a real float64 array

#: Below this aspect ratio the elliptic integrals are replaced by their leading logarithmic
#: terms K = Λ, D = Λ - 1, B = 1 (Λ = ln(4/γ)); the neglected terms are O(γ² Λ) < 1e-34 here,
#: and p = γ² would otherwise approach the underflow range of elliprd.
_THIN_SWITCH = 1e-18


# --------------------------------------------------------------------------------------------
# argument checking and output shaping
# --------------------------------------------------------------------------------------------
def _real(name: str, value: ArrayLike) -> np.ndarray:
    allowed = "a real number or an array of real numbers"
    try:
        raw = np.asarray(value)
        if np.iscomplexobj(raw) or raw.dtype.kind not in "biuf":
            raise TypeError
        arr = raw.astype(np.float64)
    except (TypeError, ValueError):
        raise InputError(name, allowed, value) from None
    if not np.all(np.isfinite(arr)):
        raise InputError(name, "finite", _first(arr, ~np.isfinite(arr)))
    return arr


def _first(arr: np.ndarray, bad: np.ndarray) -> float:
    """The first offending element (keeps the one-line error message short)."""
    return float(np.asarray(arr)[np.asarray(bad)].flat[0]) if np.ndim(arr) else float(arr)


def _positive(name: str, value: ArrayLike) -> np.ndarray:
    arr = _real(name, value)
    bad = arr <= 0
    if np.any(bad):
        raise InputError(name, "must be > 0", _first(arr, bad))
    return arr


def _nonnegative(name: str, value: ArrayLike) -> np.ndarray:
    arr = _real(name, value)
    bad = arr < 0
    if np.any(bad):
        raise InputError(name, "must be >= 0", _first(arr, bad))
    return arr


def _poisson(value: ArrayLike) -> np.ndarray:
    arr = _real("nu", value)
    bad = (arr < -1.0) | (arr > 0.5)
    if np.any(bad):
        raise InputError("nu", "Poisson ratio must lie in [-1, 0.5]", _first(arr, bad))
    return arr


def _aspect(value: ArrayLike, name: str = "aspect") -> np.ndarray:
    arr = _real(name, value)
    bad = (arr <= 0) | (arr > 1)
    if np.any(bad):
        raise InputError(name, "aspect ratio b/a must lie in (0, 1]", _first(arr, bad))
    return arr


def _one_minus_pow23(x: np.ndarray) -> np.ndarray:
    """1 − (1 − x)^(2/3) for 0 ≤ x ≤ 1, as −expm1(⅔ log1p(−x)): no cancellation at small x."""
    with np.errstate(divide="ignore"):  # x = 1: log1p(−1) = −inf, expm1(−inf) = −1, exact
        return -np.expm1((2.0 / 3.0) * np.log1p(-x))


def _out(x: np.ndarray) -> float | np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    return float(x) if x.ndim == 0 else x


# --------------------------------------------------------------------------------------------
# moduli and the circle
# --------------------------------------------------------------------------------------------
def effective_modulus(G: ArrayLike, nu: ArrayLike) -> float | np.ndarray:
    """Contact modulus E* = 2G/(1 − nu) of one elastic half-space on a rigid body [Pa].

    Equals E/(1 − nu²) (Johnson 1985, §4.2, with the rigid body's 1/E term zero); at
    nu = 0.5 it is 4G. For two bodies 1/E* = (1 − nu1)/(2 G1) + (1 − nu2)/(2 G2).
    """
    G = _positive("G", G)
    nu = _poisson(nu)
    return _out(2.0 * G / (1.0 - nu))


def effective_shear_modulus(G: ArrayLike, nu: ArrayLike) -> float | np.ndarray:
    """Tangential contact modulus G* = 4G/(2 − nu) of one elastic body on a rigid one [Pa].

    Chosen so that a bonded circle of radius a has K_xx = 2 a G* (Johnson 1985, §7.2;
    Li 2017 uses the same normalization).
    """
    G = _positive("G", G)
    nu = _poisson(nu)
    return _out(4.0 * G / (2.0 - nu))


def circle_tangential_stiffness(a: ArrayLike, G: ArrayLike, nu: ArrayLike) -> float | np.ndarray:
    """Tangential stiffness K_xx = K_yy = 8Ga/(2 − nu) = 2 a G* of a bonded circular punch [N/m].

    Rigid circular flat punch of radius ``a`` bonded (no slip) to the half-space, loaded
    tangentially: traction Q/(2πa²)(1 − r²/a²)^(−1/2), uniform displacement
    δ = Q(2 − nu)/(8Ga) (Johnson 1985, §3.7 and §7.2; Mindlin 1949). Normal–tangential
    coupling is neglected (exact for elastically similar bodies).
    """
    a = _positive("a", a)
    G = _positive("G", G)
    nu = _poisson(nu)
    return _out(8.0 * G * a / (2.0 - nu))


def circle_normal_stiffness(a: ArrayLike, G: ArrayLike, nu: ArrayLike) -> float | np.ndarray:
    """Normal stiffness K_zz = 2 a E* = 4Ga/(1 − nu) of a rigid frictionless circular punch [N/m].

    Boussinesq's flat punch, pressure P/(2πa²)(1 − r²/a²)^(−1/2) (Johnson 1985, §3.4).
    """
    a = _positive("a", a)
    G = _positive("G", G)
    nu = _poisson(nu)
    return _out(4.0 * G * a / (1.0 - nu))


# --------------------------------------------------------------------------------------------
# Mindlin's bonded ellipse and the elliptical punch
# --------------------------------------------------------------------------------------------
def _kdb(gamma: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """K(m), D(m) = (K − E)/m, B(m) = (E − (1 − m)K)/m for m = 1 − γ², without forming m.

    K = ellipkm1(p), D = R_D(0, p, 1)/3, B = p R_D(0, 1, p)/3 with p = γ² (DLMF 19.25.1);
    B is taken from its own Carlson form rather than K − D so that it keeps full relative
    accuracy when K ≈ D ≫ B (thin ellipses). K = B + D holds to rounding.
    """
    thin = gamma < _THIN_SWITCH
    g = np.where(thin, 1.0, gamma)  # placeholder value where the asymptotic form is used
    p = g * g
    from scipy.special import ellipkm1, elliprd  # on first use, not at import (strip_cells' docstring)

    K = ellipkm1(p)
    D = elliprd(0.0, p, 1.0) / 3.0
    B = p * elliprd(0.0, 1.0, p) / 3.0
    if np.any(thin):
        lam = np.log(4.0) - np.log(np.where(thin, gamma, 1.0))
        K = np.where(thin, lam, K)
        D = np.where(thin, lam - 1.0, D)
        B = np.where(thin, 1.0, B)
    return K, D, B


def mindlin_ellipse_integrals(aspect: ArrayLike) -> tuple[float | np.ndarray, ...]:
    """Complete elliptic integrals (K, D, B) of parameter m = 1 − aspect², thin-safe.

    K(m) = ∫₀^{π/2} (1 − m sin²θ)^(−1/2) dθ, D = (K − E)/m, B = K − D = (E − (1 − m)K)/m,
    E(m) the complete integral of the second kind; D = B = π/4 at aspect = 1 and
    K ≈ Λ, D ≈ Λ − 1, B ≈ 1 as aspect → 0, Λ = ln(4/aspect). Dimensionless.
    """
    g = _aspect(aspect)
    K, D, B = _kdb(g)
    return _out(K), _out(D), _out(B)


def _ellipse_axes(a: ArrayLike, b: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    a = _positive("a", a)
    b = _positive("b", b)
    bad = b > a
    if np.any(bad):
        raise InputError(
            "b",
            "semi-minor axis must satisfy 0 < b <= a (pass the longer semi-axis as a)",
            _first(np.broadcast_to(b, np.broadcast_shapes(a.shape, b.shape)), bad),
        )
    return a, b


def mindlin_ellipse_compliance(
    a: ArrayLike, b: ArrayLike, G: ArrayLike, nu: ArrayLike
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Tangential compliances (J_a, J_b) of a bonded rigid elliptical flat punch [m/N].

    Semi-axes a ≥ b (``b > a`` raises InputError naming ``b``: no silent swap, since the
    order of the returned pair depends on it). With γ = b/a, m = 1 − γ²,

        J_a = (K − nu·B)/(2πGa)   (force along the major axis a),
        J_b = (K − nu·D)/(2πGa)   (force along the minor axis b),

    and no cross term. The no-slip traction is t = F/(2πab)(1 − x²/a² − y²/b²)^(−1/2), which
    gives a uniform surface displacement over the ellipse (Mindlin 1949; Johnson 1985, §3.8
    and §7.2). Normal–tangential coupling (the (1 − 2nu) terms) is neglected, as in Mindlin
    and Li 2017: exact for elastically similar bodies or nu = 0.5. γ = 1 gives (2 − nu)/(8Ga).
    """
    a, b = _ellipse_axes(a, b)
    G = _positive("G", G)
    nu = _poisson(nu)
    K, D, B = _kdb(b / a)
    scale = 2.0 * np.pi * G * a
    return _out((K - nu * B) / scale), _out((K - nu * D) / scale)


def mindlin_ellipse_stiffness(
    a: ArrayLike, b: ArrayLike, G: ArrayLike, nu: ArrayLike
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Tangential stiffnesses (K_a, K_b) = (1/J_a, 1/J_b) of a bonded elliptical punch [N/m].

    See :func:`mindlin_ellipse_compliance` (Mindlin 1949). K_b ≥ K_a: stiffer across the
    ellipse than along it for nu > 0.
    """
    a, b = _ellipse_axes(a, b)
    G = _positive("G", G)
    nu = _poisson(nu)
    K, D, B = _kdb(b / a)
    scale = 2.0 * np.pi * G * a
    return _out(scale / (K - nu * B)), _out(scale / (K - nu * D))


def mindlin_ellipse_stiffness_ratio(aspect: ArrayLike, nu: ArrayLike) -> float | np.ndarray:
    """K_a/K_b = (K − nu·D)/(K − nu·B) of the bonded ellipse, aspect = b/a ∈ (0, 1] [-].

    Mindlin 1949 (ratio of the compliances J_b/J_a). 1 at aspect = 1 or nu = 0; tends to
    1 − nu only logarithmically as aspect → 0 (see :func:`thin_ellipse_ratio_asymptote`).
    """
    g = _aspect(aspect)
    nu = _poisson(nu)
    K, D, B = _kdb(g)
    return _out((K - nu * D) / (K - nu * B))


def mindlin_ellipse_normalized_stiffness(
    aspect: ArrayLike, nu: ArrayLike
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Li's normalized stiffnesses (K_a E*/(K_zz G*), K_b E*/(K_zz G*)) of the ellipse [-].

    K_zz is the frictionless elliptical punch (:func:`elliptical_punch_normal_stiffness`);
    substituting the closed forms gives K(2 − nu)/(2(K − nu·B)) and K(2 − nu)/(2(K − nu·D)).
    Both equal 1 for a circle (Li 2017, §3.1 normalization; Mindlin 1949).
    """
    g = _aspect(aspect)
    nu = _poisson(nu)
    K, D, B = _kdb(g)
    f = K * (2.0 - nu) / 2.0
    return _out(f / (K - nu * B)), _out(f / (K - nu * D))


def thin_ellipse_ratio_asymptote(aspect: ArrayLike, nu: ArrayLike) -> float | np.ndarray:
    """Leading terms of K_a/K_b as aspect γ → 0: (1 − nu) + nu(2 − nu)/(Λ − nu), Λ = ln(4/γ).

    Obtained from K = Λ + O(γ²Λ), D = Λ − 1 + O(γ²Λ), B = 1 + O(γ²Λ) in
    :func:`mindlin_ellipse_stiffness_ratio`; the error is O(γ² Λ). Dimensionless.
    """
    g = _aspect(aspect)
    nu = _poisson(nu)
    lam = np.log(4.0) - np.log(g)
    return _out((1.0 - nu) + nu * (2.0 - nu) / (lam - nu))


def elliptical_punch_normal_stiffness(a: ArrayLike, b: ArrayLike, G: ArrayLike, nu: ArrayLike) -> float | np.ndarray:
    """Normal stiffness K_zz = π a E*/K(m) of a rigid frictionless elliptical flat punch [N/m].

    Semi-axes a ≥ b, m = 1 − (b/a)², E* = 2G/(1 − nu). Pressure
    P/(2πab)(1 − x²/a² − y²/b²)^(−1/2), uniform indentation δ = P K(m)/(π a E*)
    (Johnson 1985, §3.5; Galin 1953). aspect = 1 gives 2aE*.
    """
    a, b = _ellipse_axes(a, b)
    G = _positive("G", G)
    nu = _poisson(nu)
    K, _, _ = _kdb(b / a)
    return _out(np.pi * a * (2.0 * G / (1.0 - nu)) / K)


# --------------------------------------------------------------------------------------------
# Hertz
# --------------------------------------------------------------------------------------------
def hertz_sphere(
    R: ArrayLike, depth: ArrayLike, G: ArrayLike, nu: ArrayLike
) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Rigid sphere of radius R pressed to approach ``depth`` d: (contact radius a [m], load P [N]).

    a = sqrt(R d), P = (4/3) E* R^(1/2) d^(3/2), E* = 2G/(1 − nu) (Johnson 1985, §4.2).
    The sphere is rigid; for two elastic spheres use the combined E* and relative radius.
    """
    R = _positive("R", R)
    d = _positive("depth", depth)
    G = _positive("G", G)
    nu = _poisson(nu)
    estar = 2.0 * G / (1.0 - nu)
    return _out(np.sqrt(R * d)), _out(4.0 / 3.0 * estar * np.sqrt(R) * d * np.sqrt(d))


def hertz_peak_pressure(a: ArrayLike, P: ArrayLike) -> float | np.ndarray:
    """Hertz peak pressure p0 = 3P/(2πa²) [Pa] (Johnson 1985, §4.2)."""
    a = _positive("a", a)
    P = _positive("P", P)
    return _out(1.5 * P / (np.pi * a * a))


def hertz_pressure(r: ArrayLike, a: ArrayLike, P: ArrayLike) -> float | np.ndarray:
    """Hertz pressure p(r) = p0 sqrt(1 − r²/a²) for |r| < a, 0 outside [Pa].

    p0 = 3P/(2πa²) (Johnson 1985, §4.2). ``r`` is the distance from the centre; only r²
    enters, so a signed coordinate along a diameter may be passed as well.
    """
    r = _real("r", r)
    a = _positive("a", a)
    P = _positive("P", P)
    s = 1.0 - (r / a) ** 2
    return _out(np.where(s > 0, 1.5 * P / (np.pi * a * a) * np.sqrt(np.maximum(s, 0.0)), 0.0))


# --------------------------------------------------------------------------------------------
# Cattaneo–Mindlin and Mindlin–Deresiewicz (sphere, constant normal load P)
# --------------------------------------------------------------------------------------------
def _friction_limit(P: ArrayLike, mu: ArrayLike) -> np.ndarray:
    return _positive("P", P) * _positive("mu", mu)


def _load_ratio(name: str, Q: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """|Q|/limit, checked to lie in [0, 1]."""
    ratio = np.abs(Q) / limit
    bad = ratio > 1.0
    if np.any(bad):
        full = np.broadcast_to(Q, ratio.shape)
        raise InputError(name, "tangential load must satisfy |Q| <= mu*P (no gross sliding)", _first(full, bad))
    return ratio


def stick_radius(Q: ArrayLike, P: ArrayLike, mu: ArrayLike, a: ArrayLike) -> float | np.ndarray:
    """Radius of the stick zone c = a (1 − |Q|/(μP))^(1/3) under monotonic loading Q [m].

    Cattaneo (1938), Mindlin (1949); Johnson 1985, §7.2. The traction is
    μ p0 [sqrt(1 − r²/a²) − (c/a) sqrt(1 − r²/c²)] (second term only for r < c),
    p0 = 3P/(2πa²). |Q| = μP gives c = 0 (sliding starts).
    """
    Q = _real("Q", Q)
    limit = _friction_limit(P, mu)
    a = _positive("a", a)
    return _out(a * np.cbrt(1.0 - _load_ratio("Q", Q, limit)))


def cattaneo_mindlin_displacement(
    Q: ArrayLike, P: ArrayLike, mu: ArrayLike, a: ArrayLike, G: ArrayLike, nu: ArrayLike
) -> float | np.ndarray:
    """Tangential displacement of a sphere under P then monotonic Q, |Q| ≤ μP [m].

        δ(Q) = 3μP(2 − nu)/(16 G a) · [1 − (1 − Q/(μP))^(2/3)]      (Q ≥ 0; odd in Q)

    Johnson 1985, §7.2 (Cattaneo–Mindlin), one elastic body on a rigid one (for two bodies
    replace (2 − nu)/G by (2 − nu1)/G1 + (2 − nu2)/G2). Follows from the displacement at the
    centre of the traction in :func:`stick_radius`: δ = 3μP(2 − nu)(a² − c²)/(16 G a³).
    Small Q: δ ≈ Q(2 − nu)/(8Ga); δ(μP) = 3μP(2 − nu)/(16Ga) (onset of sliding).
    ``a`` is the Hertz contact radius (:func:`hertz_sphere`).
    """
    Q = _real("Q", Q)
    limit = _friction_limit(P, mu)
    a = _positive("a", a)
    G = _positive("G", G)
    nu = _poisson(nu)
    shape = _one_minus_pow23(_load_ratio("Q", Q, limit))
    return _out(np.sign(Q) * 3.0 * limit * (2.0 - nu) / (16.0 * G * a) * shape)


def cattaneo_mindlin_stiffness(
    Q: ArrayLike, P: ArrayLike, mu: ArrayLike, a: ArrayLike, G: ArrayLike, nu: ArrayLike
) -> float | np.ndarray:
    """Tangential tangent stiffness dQ/dδ = 8Ga/(2 − nu) · (1 − |Q|/(μP))^(1/3) [N/m].

    Derivative of :func:`cattaneo_mindlin_displacement` (Johnson 1985, §7.2;
    Mindlin & Deresiewicz 1953): the bonded-circle value at Q = 0, zero at |Q| = μP.
    """
    Q = _real("Q", Q)
    limit = _friction_limit(P, mu)
    a = _positive("a", a)
    G = _positive("G", G)
    nu = _poisson(nu)
    ratio = _load_ratio("Q", Q, limit)
    return _out(8.0 * G * a / (2.0 - nu) * np.cbrt(1.0 - ratio))


def _unloading_args(
    Q: ArrayLike, Q_star: ArrayLike, P: ArrayLike, mu: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    Q = _real("Q", Q)
    Qs = _nonnegative("Q_star", Q_star)
    limit = _friction_limit(P, mu)
    bad = Qs > limit
    if np.any(bad):
        full = np.broadcast_to(Qs, np.broadcast_shapes(Qs.shape, limit.shape))
        raise InputError("Q_star", "turning load must satisfy 0 <= Q_star <= mu*P", _first(full, bad))
    bad = np.abs(Q) > Qs
    if np.any(bad):
        full = np.broadcast_to(Q, np.broadcast_shapes(Q.shape, Qs.shape))
        raise InputError("Q", "load must satisfy -Q_star <= Q <= Q_star on the hysteresis loop", _first(full, bad))
    return Q, Qs, limit


def mindlin_deresiewicz_unloading_displacement(
    Q: ArrayLike,
    Q_star: ArrayLike,
    P: ArrayLike,
    mu: ArrayLike,
    a: ArrayLike,
    G: ArrayLike,
    nu: ArrayLike,
) -> float | np.ndarray:
    """Displacement on the unloading branch from +Q* down to Q ∈ [−Q*, Q*] [m].

        δ(Q) = δ_L(Q*) − 2 δ_L((Q* − Q)/2)      [= δ_L(Q*) − δ_L(Q* − Q; friction 2μ)]
             = 3μP(2 − nu)/(16Ga) · [2(1 − (Q* − Q)/(2μP))^(2/3) − (1 − Q*/(μP))^(2/3) − 1]

    with δ_L the Cattaneo–Mindlin loading curve (Mindlin & Deresiewicz 1953; Johnson 1985,
    §7.4). Reversed slip spreads inward from the edge over c' < r < a,
    c' = a(1 − (Q* − Q)/(2μP))^(1/3); the traction is the loading traction at Q* minus twice a
    Cattaneo distribution of radius c' with limit 2μp. δ(Q*) = δ_L(Q*) and
    δ(−Q*) = −δ_L(Q*): the loop closes on the mirrored loading curve.
    """
    Q, Qs, limit = _unloading_args(Q, Q_star, P, mu)
    a = _positive("a", a)
    G = _positive("G", G)
    nu = _poisson(nu)
    # [2(1 − x_rev)^⅔ − (1 − x*)^⅔ − 1] = f(x*) − 2 f(x_rev), f(x) = 1 − (1 − x)^⅔: accurate to
    # a few ulp of the loop amplitude δ_L(Q*) even for Q* ≪ μP (the plain form loses
    # log10(μP/Q*) digits); near the zero crossing of δ only that absolute accuracy is meaningful
    f_star = _one_minus_pow23(Qs / limit)
    f_rev = _one_minus_pow23((Qs - Q) / (2.0 * limit))
    return _out(3.0 * limit * (2.0 - nu) / (16.0 * G * a) * (f_star - 2.0 * f_rev))


def mindlin_deresiewicz_reloading_displacement(
    Q: ArrayLike,
    Q_star: ArrayLike,
    P: ArrayLike,
    mu: ArrayLike,
    a: ArrayLike,
    G: ArrayLike,
    nu: ArrayLike,
) -> float | np.ndarray:
    """Displacement on the reloading branch from −Q* up to Q ∈ [−Q*, Q*] [m].

    By symmetry δ_reload(Q) = −δ_unload(−Q) (Mindlin & Deresiewicz 1953; Johnson 1985, §7.4).
    """
    Q = _real("Q", Q)
    return _out(-np.asarray(mindlin_deresiewicz_unloading_displacement(-Q, Q_star, P, mu, a, G, nu)))


def mindlin_deresiewicz_unloading_stiffness(
    Q: ArrayLike,
    Q_star: ArrayLike,
    P: ArrayLike,
    mu: ArrayLike,
    a: ArrayLike,
    G: ArrayLike,
    nu: ArrayLike,
) -> float | np.ndarray:
    """Tangent stiffness dQ/dδ = 8Ga/(2 − nu) · (1 − (Q* − Q)/(2μP))^(1/3) on unloading [N/m].

    Derivative of :func:`mindlin_deresiewicz_unloading_displacement`: the full bonded value
    8Ga/(2 − nu) right after reversal (Mindlin & Deresiewicz 1953).
    """
    Q, Qs, limit = _unloading_args(Q, Q_star, P, mu)
    a = _positive("a", a)
    G = _positive("G", G)
    nu = _poisson(nu)
    return _out(8.0 * G * a / (2.0 - nu) * np.cbrt(1.0 - (Qs - Q) / (2.0 * limit)))


def willis_sphere_contact(
    compliance_zz: Callable[[np.ndarray], np.ndarray], R: float, depth: float, n_phi: int = 4096
) -> dict[str, float]:
    """Rigid sphere on an anisotropic half-space: Willis' elliptical Hertzian contact.

    Willis (1966, J. Mech. Phys. Solids 14, 163) showed that the Hertz pressure
    p = p0 sqrt(1 − x²/a² − y²/b²) on an ellipse produces, inside it, a surface deflection that
    is quadratic in x and y for any anisotropic half-space (used by Swadener & Pharr 2001 for
    indentation of cubic crystals). With û_z = H_zz(φ) p̂ / |k| and the transform of the Hertz
    pressure, p̂(k) = 2π a b p0 (sin κ − κ cos κ)/κ³, κ = |k| s(φ), s² = a² cos²φ + b² sin²φ,
    and ∫_0^∞ (sin κ − κ cos κ)/κ³ cos(κ t) dκ = (π/4)(1 − t²) for |t| ≤ 1, one finds

        u_z(x) = (a b p0 / 8) ∫_0^{2π} H_zz(φ)/s(φ) [1 − (m·x)²/s(φ)²] dφ,   m = (cos φ, sin φ).

    Matching u_z = d − (x² + y²)/(2R) (and no xy term: the contact axes are taken along x and
    y, true when H_zz(φ) = H_zz(−φ), e.g. a cubic crystal on {001}, {111} or {110} in the
    frames of ``hpcontact.materials.crystal``) gives, with e = b/a, I_c = ∫ H cos²φ/σ³, I_s = ∫ H sin²φ/σ³,
    I_0 = ∫ H/σ, σ² = cos²φ + e² sin²φ: I_c(e) = I_s(e) fixes e; a = sqrt(2 R d I_c/I_0);
    p0 = 4 a/(R e I_c); load P = (2π/3) a b p0. ``compliance_zz(φ)`` is H_zz in 1/stress; φ
    integrals by the trapezoidal rule (periodic, smooth: exponential convergence; the
    stiffest case, e ≈ 0.9, converges far below 1e-12 at 4096 points).
    Returns a, b, b_over_a, p0, load (units of R, d and stress).
    """
    if not (R > 0.0 and math.isfinite(R)):
        raise InputError("radius", "finite and > 0", R)
    if not (0.0 < depth < R):
        raise InputError("depth", "in (0, radius)", depth)
    phi = 2.0 * np.pi * np.arange(n_phi) / n_phi
    h = np.asarray(compliance_zz(phi), dtype=np.float64)
    c2, s2 = np.cos(phi) ** 2, np.sin(phi) ** 2
    weight = 2.0 * np.pi / n_phi

    def moments(e: float) -> tuple[float, float, float]:
        sigma2 = c2 + e * e * s2
        return (
            weight * float(np.sum(h * c2 / sigma2**1.5)),
            weight * float(np.sum(h * s2 / sigma2**1.5)),
            weight * float(np.sum(h / np.sqrt(sigma2))),
        )

    def mismatch(log_e: float) -> float:
        i_c, i_s, _ = moments(math.exp(log_e))
        return i_c - i_s

    low, high = math.log(1e-3), math.log(1e3)
    if mismatch(low) * mismatch(high) > 0.0:
        raise FloatingPointError("no elliptical contact found for this compliance")
    from scipy.optimize import brentq  # on first use, not at import (strip_cells' docstring)

    e = math.exp(brentq(mismatch, low, high, xtol=1e-15, rtol=1e-15))
    i_c, _, i_0 = moments(e)
    a = math.sqrt(2.0 * R * depth * i_c / i_0)
    p0 = 4.0 * a / (R * e * i_c)
    return {"a": a, "b": e * a, "b_over_a": e, "p0": p0, "load": 2.0 * math.pi / 3.0 * a * a * e * p0}
