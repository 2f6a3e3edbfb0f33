"""Closed-form references (hpcontact.analytic) against independent mpmath computations.

The references are checked against the physics, not against their own formulas: each compliance
is recomputed as the surface displacement produced by the known contact traction, integrating
the isotropic point-force solutions of docs/design.md §2.1 (Johnson 1985, §3.2, §3.6) with mpmath
quadrature in 30–40 digits. The closed forms are then double-precision evaluations of results
that the quadrature knows to ~1e-25 or better, so a correct implementation agrees to a few ulp;
the tolerances below leave a margin over that and say where they come from.
"""

from __future__ import annotations

import math

import mpmath as mp
import numpy as np
import pytest

from hpcontact import analytic as an
from hpcontact.errors import InputError

GAMMAS = [1.0, 0.5, 0.1, 1e-3, 1e-6, 1e-9, 1e-12]
NUS = [0.0, 0.3, 0.5]

# Closed forms vs quadrature: the double-precision evaluation (scipy ellipkm1 / elliprd, a few
# flops) is good to ~5e-16 relative; the quadrature to < 1e-25. docs/design.md §2.4 asks 1e-12
# of the references; the README quotes what they achieve, "≤ 6e-16" against these quadratures
# (measured 2026-11-23, worst over this file's quadrature checks: 5.6e-16, the Cattaneo–Mindlin
# stiffness against mpmath.diff; 4.4e-16 Mindlin's ellipse at b/a = 1e-3). Bound 1.5e-15: 2.7×
# for scipy's special functions, which differ by an ulp or two between builds.
REL_CLOSED_FORM = 1.5e-15


def _mpf(x: float) -> mp.mpf:
    """The exact value of a double as an mpf (so reference and code see the same input)."""
    return mp.mpf(float(x))


# ------------------------------------------------------------------------------------------
# 1, 2. Mindlin's ellipse and the elliptical punch, centre displacement by quadrature
# ------------------------------------------------------------------------------------------
def _centre_integrals(gamma: float) -> tuple[mp.mpf, mp.mpf, mp.mpf]:
    """Angular integrals of the centre displacement of an ellipse with a = 1, b = gamma.

    With elliptic polar coordinates x = aρ cosφ, y = bρ sinφ, dA = abρ dρ dφ and
    r = ρ a S, S(φ) = sqrt(cos²φ + γ² sin²φ), a traction F/(2πab)(1 − ρ²)^(−1/2) gives a
    ρ-integral ∫₀¹(1 − ρ²)^(−1/2) dρ = π/2 and (docs/design.md §2.1)
        u_x(0) = F/(2πG a) [(1 − nu) I1 + nu Ix],  u_y(0) = F/(2πG a) [(1 − nu) I1 + nu Iy],
        u_z(0) = (1 − nu) P/(2πG a) I1   (normal punch),
    I1 = ∫₀^{π/2} dφ/S, Ix = ∫ cos²φ/S³ dφ (x²/r² = cos²φ/S²), Iy = ∫ γ² sin²φ/S³ dφ.
    Written in ψ = π/2 − φ, the integrands peak in a layer ψ ≲ γ, so the interval is split at
    γ, 10γ, 100γ, … , 1 (tanh–sinh then converges on every piece).
    """
    g = _mpf(gamma)
    pts = [mp.mpf(0)]
    t = g
    while t < 1:
        pts.append(t)
        t *= 10
    pts += [mp.mpf(1), mp.pi / 2]

    def S(s: mp.mpf) -> mp.mpf:
        return mp.sqrt(mp.sin(s) ** 2 + g**2 * mp.cos(s) ** 2)

    out = []
    for f in (
        lambda s: 1 / S(s),
        lambda s: mp.sin(s) ** 2 / S(s) ** 3,
        lambda s: g**2 * mp.cos(s) ** 2 / S(s) ** 3,
    ):
        val, err = mp.quad(f, pts, error=True)
        assert err < mp.mpf(10) ** -25 * abs(val)  # quadrature itself converged (see REL_*)
        out.append(val)
    return out[0], out[1], out[2]


@pytest.fixture(scope="module")
def centre_integrals() -> dict[float, tuple[mp.mpf, mp.mpf, mp.mpf]]:
    with mp.workdps(40):
        return {g: _centre_integrals(g) for g in GAMMAS}


def _rel(x: float, ref: mp.mpf) -> float:
    return float(abs(mp.mpf(x) / ref - 1))


@pytest.mark.parametrize("gamma", GAMMAS)
def test_mindlin_ellipse_compliance_against_quadrature(gamma, centre_integrals):
    I1, Ix, Iy = centre_integrals[gamma]
    a, G = 2.5, 3.0e10  # arbitrary units: checks the 1/(G a) scaling too
    worst = 0.0
    with mp.workdps(40):
        for nu in NUS:
            n = _mpf(nu)
            scale = 2 * mp.pi * _mpf(G) * _mpf(a)
            Ja_ref = ((1 - n) * I1 + n * Ix) / scale
            Jb_ref = ((1 - n) * I1 + n * Iy) / scale
            Ja, Jb = an.mindlin_ellipse_compliance(a, gamma * a, G, nu)
            Ka, Kb = an.mindlin_ellipse_stiffness(a, gamma * a, G, nu)
            errs = [
                _rel(Ja, Ja_ref),
                _rel(Jb, Jb_ref),
                _rel(Ka, 1 / Ja_ref),
                _rel(Kb, 1 / Jb_ref),
                _rel(an.mindlin_ellipse_stiffness_ratio(gamma, nu), Jb_ref / Ja_ref),
            ]
            worst = max(worst, *errs)
    print(f"gamma={gamma:g}: max rel error of J_a, J_b, K_a, K_b, K_a/K_b = {worst:.2e}")
    assert worst < REL_CLOSED_FORM


@pytest.mark.parametrize("gamma", GAMMAS)
def test_elliptical_punch_normal_stiffness_against_quadrature(gamma, centre_integrals):
    I1 = centre_integrals[gamma][0]
    a, G = 0.7, 2.0
    worst = 0.0
    with mp.workdps(40):
        for nu in NUS:
            n = _mpf(nu)
            Kzz_ref = 2 * mp.pi * _mpf(G) * _mpf(a) / ((1 - n) * I1)
            worst = max(worst, _rel(an.elliptical_punch_normal_stiffness(a, gamma * a, G, nu), Kzz_ref))
    print(f"gamma={gamma:g}: max rel error of K_zz = {worst:.2e}")
    assert worst < REL_CLOSED_FORM


def _ray_integrals(a: float, b: float, x0: float, y0: float) -> dict[str, mp.mpf]:
    """Angular integrals for the displacement at an interior point (x0, y0) of the ellipse.

    Polar coordinates (s, θ) centred on the field point cancel the 1/r of the point-force
    solution (dA/r = ds dθ), and along each ray 1 − x²/a² − y²/b² = A (s1 − s)(s − s2), so the
    radial integral of (1 − …)^(−1/2) is exact: L(θ) = arccos(B/sqrt(B² + A(1 − C)))/sqrt(A),
    A = cos²θ/a² + sin²θ/b², B = x0 cosθ/a² + y0 sinθ/b², C = x0²/a² + y0²/b².
    Returns ∫₀^{2π} w(θ) L(θ) dθ for w = 1, cos²θ, sin²θ, cosθ sinθ (the angular factors of
    docs/design.md §2.1; the vector from source to field point is −s e_θ, signs cancel in all four).
    """
    a, b, x0, y0 = map(_mpf, (a, b, x0, y0))
    C = x0**2 / a**2 + y0**2 / b**2

    def L(th: mp.mpf) -> mp.mpf:
        c, s = mp.cos(th), mp.sin(th)
        A = c**2 / a**2 + s**2 / b**2
        B = x0 * c / a**2 + y0 * s / b**2
        return mp.acos(B / mp.sqrt(B**2 + A * (1 - C))) / mp.sqrt(A)

    pts = [0, mp.pi / 2, mp.pi, 3 * mp.pi / 2, 2 * mp.pi]
    weights = {
        "1": lambda t: 1,
        "cc": lambda t: mp.cos(t) ** 2,
        "ss": lambda t: mp.sin(t) ** 2,
        "cs": lambda t: mp.cos(t) * mp.sin(t),
    }
    out = {}
    for key, w in weights.items():
        val, err = mp.quad(lambda t: w(t) * L(t), pts, error=True)
        assert err < mp.mpf(10) ** -25  # converged (all values here are O(1) to O(10))
        out[key] = val
    return out


@pytest.mark.parametrize("gamma,x0,y0", [(0.3, 0.55, 0.2), (0.05, 0.7, 0.03)])
def test_mindlin_traction_gives_uniform_displacement_off_centre(gamma, x0, y0):
    """The Mindlin traction displaces an off-centre point exactly as much as the centre.

    The smooth periodic θ-integral converges to ~1e-30 (estimated error asserted in
    _ray_integrals), so the closed-form tolerance REL_CLOSED_FORM applies; measured ≤ 2.2e-16.
    """
    a, G, nu = 1.0, 1.0, 0.3
    b = gamma * a
    with mp.workdps(30):
        I = _ray_integrals(a, b, x0, y0)
        n = _mpf(nu)
        pref = 1 / (2 * mp.pi * _mpf(a) * _mpf(b)) / (2 * mp.pi * _mpf(G))  # unit force
        ux = pref * ((1 - n) * I["1"] + n * I["cc"])  # from a force along x
        uy = pref * ((1 - n) * I["1"] + n * I["ss"])  # from a force along y
        uy_from_x = pref * n * I["cs"]  # cross term, must vanish ("no cross term")
        uz = pref * (1 - n) * I["1"]  # normal punch
    Ja, Jb = an.mindlin_ellipse_compliance(a, b, G, nu)
    Kzz = an.elliptical_punch_normal_stiffness(a, b, G, nu)
    errs = [_rel(Ja, ux), _rel(Jb, uy), float(abs(uz * Kzz - 1)), float(abs(uy_from_x) / Ja)]
    print(
        f"off-centre ({x0}, {y0}) gamma={gamma}: rel errors u_x, u_y, u_z, |u_y|/u_x from Q_x: "
        + ", ".join(f"{e:.1e}" for e in errs)
    )
    assert max(errs) < REL_CLOSED_FORM


# ------------------------------------------------------------------------------------------
# 3. circle
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("nu", [-1.0, -0.3, 0.0, 0.3, 0.5])
def test_circle_limits(nu):
    a, G = 1.7, 4.0
    Ja, Jb = an.mindlin_ellipse_compliance(a, a, G, nu)
    Kt = an.circle_tangential_stiffness(a, G, nu)
    Kn = an.circle_normal_stiffness(a, G, nu)
    # exact rationals in the closed forms; the elliptic integrals at m = 0 are π/2, π/4, π/4 to
    # an ulp, so agreement to 1e-14 (a few ulp through 2π, divisions) is expected
    assert Kt == pytest.approx(8 * G * a / (2 - nu), rel=1e-14)
    assert Kt == pytest.approx(2 * a * an.effective_shear_modulus(G, nu), rel=1e-14)
    assert 1 / Ja == pytest.approx(Kt, rel=1e-14) and 1 / Jb == pytest.approx(Kt, rel=1e-14)
    assert Kn == pytest.approx(2 * a * an.effective_modulus(G, nu), rel=1e-14)
    assert an.elliptical_punch_normal_stiffness(a, a, G, nu) == pytest.approx(Kn, rel=1e-14)
    assert an.mindlin_ellipse_stiffness_ratio(1.0, nu) == pytest.approx(1.0, rel=1e-15)
    na, nb = an.mindlin_ellipse_normalized_stiffness(1.0, nu)
    assert na == pytest.approx(1.0, rel=1e-15) and nb == pytest.approx(1.0, rel=1e-15)


def test_nu_zero_is_isotropic():
    for g in [0.5, 1e-6, 1e-12]:
        assert an.mindlin_ellipse_stiffness_ratio(g, 0.0) == 1.0


# ------------------------------------------------------------------------------------------
# 4. thin-ellipse asymptote
# ------------------------------------------------------------------------------------------
def test_thin_asymptote_error_is_order_gamma2_lambda():
    """|ratio − asymptote| = O(γ² Λ), checked with a 60-digit reference and in float64.

    The 60-digit reference (K, E from mpmath at m = 1 − γ², exact for γ ≥ 1e-12 at this
    precision) shows |ratio − asymptote|/(γ² Λ) ≈ 0.01–0.06 over 1e-4 … 1e-12 for nu = 0.3,
    0.5, hence the bound 0.1 γ² Λ. In float64 the difference of two O(1) numbers also carries
    rounding, ~2 ulp = 4.4e-16, added to the bound.
    """
    bound = 0.1
    with mp.workdps(60):
        for nu in (0.3, 0.5):
            n = _mpf(nu)
            prev = None
            for g in [1e-4, 1e-5, 1e-6, 1e-8, 1e-10, 1e-12]:
                gm = _mpf(g)
                m = 1 - gm**2
                K, E = mp.ellipk(m), mp.ellipe(m)
                D = (K - E) / m
                B = K - D
                ratio = (K - n * D) / (K - n * B)
                lam = mp.log(4 / gm)
                asym = (1 - n) + n * (2 - n) / (lam - n)
                scaled = abs(ratio - asym) / (gm**2 * lam)
                assert scaled < bound
                if prev is not None:  # really shrinking like γ²Λ: the scaled error stays O(1)
                    assert abs(ratio - asym) < prev
                prev = abs(ratio - asym)
                # the float64 functions follow the reference to rounding
                r64 = an.mindlin_ellipse_stiffness_ratio(g, nu)
                a64 = an.thin_ellipse_ratio_asymptote(g, nu)
                assert _rel(r64, ratio) < 1e-15  # measured ≤ 5e-16 (2 ulp)
                assert _rel(a64, asym) < 1e-15
                assert abs(r64 - a64) <= bound * g * g * math.log(4 / g) + 4.4e-16


def test_thin_ratio_reported_value():
    """The reported K_a/K_b of the Mindlin ellipse at b/a = 1e-8, nu = 0.5 (0.538846) against
    (K − nu D)/(K − nu B) in mpmath at 60 digits (docs/design.md "Mindlin ellipse"): within
    ``REL_CLOSED_FORM``, this file's bound for the float64 closed forms (a few flops on scipy's
    special functions). Between the thin limit 1 − nu and 1, as it must be."""
    r = an.mindlin_ellipse_stiffness_ratio(1e-8, 0.5)
    print(
        f"Mindlin ellipse K_a/K_b at b/a = 1e-8, nu = 0.5: {r:.6f} "
        "(Li 2017: 0.5390 for a rectangle; thin limit 1 - nu = 0.5)"
    )
    with mp.workdps(60):
        m = 1 - _mpf(1e-8) ** 2
        K, E = mp.ellipk(m), mp.ellipe(m)
        D = (K - E) / m
        exact = (K - _mpf(0.5) * D) / (K - _mpf(0.5) * (K - D))
        assert _rel(r, exact) < REL_CLOSED_FORM
    assert 0.5 < r < 1.0


def test_thin_switch_is_continuous():
    """Below b/a = 1e-18 the integrals switch to K = Λ, D = Λ − 1, B = 1 (error < 1e-34).

    On either side of the switch both routes agree with each other to rounding (2 ulp of Λ).
    """
    for g in [2e-18, 1e-18, 0.999999e-18, 1e-30, 1e-200, 5e-324]:
        K, D, B = an.mindlin_ellipse_integrals(g)
        lam = math.log(4.0) - math.log(g)
        assert K == pytest.approx(lam, rel=5e-16)
        assert D == pytest.approx(lam - 1.0, rel=5e-16)
        assert B == pytest.approx(1.0, rel=5e-16)
        assert np.isfinite(an.mindlin_ellipse_stiffness_ratio(g, 0.5))
    # identity K = B + D (B is computed by its own Carlson form, not as K − D)
    for g in GAMMAS:
        K, D, B = an.mindlin_ellipse_integrals(g)
        assert B + D == pytest.approx(K, rel=4e-16)  # one addition and two Carlson R_D: ~2 ulp


def test_vectorized_matches_scalar():
    g = np.array([1.0, 0.3, 1e-6, 1e-20])
    nu = np.array([[0.0], [0.5]])
    r = an.mindlin_ellipse_stiffness_ratio(g, nu)
    assert isinstance(r, np.ndarray) and r.shape == (2, 4)
    for i in range(2):
        for j in range(4):
            assert r[i, j] == an.mindlin_ellipse_stiffness_ratio(float(g[j]), float(nu[i, 0]))
    assert isinstance(an.mindlin_ellipse_stiffness_ratio(0.3, 0.3), float)
    Ja, Jb = an.mindlin_ellipse_compliance(1.0, g, 1.0, 0.3)
    assert Ja.shape == Jb.shape == (4,) and np.all(Jb <= Ja)


# ------------------------------------------------------------------------------------------
# 5. Hertz, Cattaneo–Mindlin, Mindlin–Deresiewicz
# ------------------------------------------------------------------------------------------
def test_hertz_load_and_displacement_from_pressure():
    """Hertz pressure integrates to P and produces the sphere's profile d − r²/(2R) in the contact.

    Load: ∫₀^a 2πr p dr. Displacement at a point (x0, 0): polar coordinates around it cancel
    the 1/r of u_z = (1 − nu) p/(2πG r) (docs/design.md §2.1); the ray integral of p ∝ sqrt(1 − |x|²/a²)
    ends at the contact edge s1(θ) with a square-root zero that tanh–sinh handles. Quadrature
    at 30 digits converges to ~1e-20; tolerance REL_CLOSED_FORM (measured 7.9e-17).
    """
    R, d, G, nu = 0.01, 2e-6, 80e9, 0.3
    a, P = an.hertz_sphere(R, d, G, nu)
    assert a == pytest.approx(math.sqrt(R * d), rel=1e-15)
    with mp.workdps(30):
        am, Pm = _mpf(a), _mpf(P)
        p0 = 3 * Pm / (2 * mp.pi * am**2)
        load = mp.quad(lambda r: 2 * mp.pi * r * _mpf(an.hertz_pressure(float(r), a, P)), [0, am])
        # float64 pressure inside the quadrature: ~1e-16 relative per point
        assert float(abs(load / Pm - 1)) < 1e-13
        load_exact = mp.quad(lambda r: 2 * mp.pi * r * p0 * mp.sqrt(1 - (r / am) ** 2), [0, am])
        assert float(abs(load_exact / Pm - 1)) < 1e-25
        assert an.hertz_peak_pressure(a, P) == pytest.approx(float(p0), rel=1e-15)

        coef = (1 - _mpf(nu)) / (2 * mp.pi * _mpf(G)) * p0 / am  # p = p0/a · sqrt(a² − |x|²)
        worst = 0.0
        for x0 in [mp.mpf(0), am / 3, am * 3 / 4]:

            def ray(th: mp.mpf, x0=x0) -> mp.mpf:
                c = mp.cos(th)
                s1 = -x0 * c + mp.sqrt(x0**2 * c**2 + am**2 - x0**2)
                return mp.quad(lambda s: mp.sqrt(am**2 - x0**2 - 2 * x0 * s * c - s**2), [0, s1])

            uz = coef * 2 * mp.quad(ray, [0, mp.pi / 2, mp.pi])  # symmetric in θ → −θ
            target = _mpf(d) - x0**2 / (2 * _mpf(R))
            worst = max(worst, float(abs(uz / target - 1)))
    print(f"Hertz: displacement from the pressure vs d − r²/2R: max rel error {worst:.1e}")
    assert worst < REL_CLOSED_FORM


def _cattaneo_traction(r: mp.mpf, a: mp.mpf, c: mp.mpf, limit: mp.mpf) -> mp.mpf:
    """μ p0 sqrt(1 − r²/a²) − (c/a) μ p0 sqrt(1 − r²/c²) (second term for r < c), μ p0 = limit."""
    q = limit * mp.sqrt(1 - (r / a) ** 2) if r < a else mp.mpf(0)
    if r < c:
        q -= c / a * limit * mp.sqrt(1 - (r / c) ** 2)
    return q


def _force_and_centre_displacement(traction, a: mp.mpf, G: mp.mpf, nu: mp.mpf, brk):
    """Q = ∫ 2πr q dr and δ = u_x(0) = ∫∫ q/(2πG r)[(1 − nu) + nu cos²θ] r dr dθ (docs/design.md §2.1)."""
    Q = mp.quad(lambda r: 2 * mp.pi * r * traction(r), brk)
    ang = mp.quad(lambda t: (1 - nu) + nu * mp.cos(t) ** 2, [0, mp.pi, 2 * mp.pi])
    delta = ang / (2 * mp.pi * G) * mp.quad(traction, brk)
    return Q, delta


MU, PLOAD, A, GMOD, NU = 0.4, 3.0, 0.02, 30.0e9, 0.25


def test_cattaneo_mindlin_against_traction_quadrature():
    """δ(Q) and the stick radius from the Cattaneo traction, integrated independently.

    For Q/(μP) in (0, 1]: with c = a(1 − Q/μP)^(1/3) (in 30 digits; stick_radius is compared
    with it to 1e-15, i.e. a few ulp of a cube root), ∫ 2πr q dr must return Q (checks c(Q)),
    and the centre displacement of that traction must equal the closed form δ(Q) (checks the
    factor 3μP(2 − nu)/(16Ga) and the exponent 2/3). 30-digit quadrature with a break at r = c
    converges to ~1e-25; tolerance REL_CLOSED_FORM (measured 8.3e-17).
    (c is not taken from the float64 stick_radius for the quadrature: Q = μP(1 − c³/a³) is
    ill-conditioned in c when Q ≪ μP, an ulp of c would show up as 3e-10 in Q at Q = 1e-6 μP.)
    """
    limit = MU * PLOAD
    worst = 0.0
    with mp.workdps(30):
        a, G, nu, lim = _mpf(A), _mpf(GMOD), _mpf(NU), _mpf(limit)
        p0mu = 3 * lim / (2 * mp.pi * a**2)
        for x in [1e-6, 0.1, 0.5, 0.9, 1.0]:
            Q = x * limit
            c = a * mp.cbrt(1 - _mpf(Q) / lim)
            worst = max(worst, float(abs(_mpf(an.stick_radius(Q, PLOAD, MU, A)) - c) / a))
            Qq, dq = _force_and_centre_displacement(
                lambda r: _cattaneo_traction(r, a, c, p0mu), a, G, nu, [0, c, a] if c > 0 else [0, a]
            )
            d = an.cattaneo_mindlin_displacement(Q, PLOAD, MU, A, GMOD, NU)
            worst = max(worst, _rel(Q, Qq), _rel(d, dq))
            # odd in Q
            assert an.cattaneo_mindlin_displacement(-Q, PLOAD, MU, A, GMOD, NU) == -d
    print(f"Cattaneo–Mindlin: max rel error of Q(c), δ(Q) vs quadrature {worst:.1e}")
    assert worst < REL_CLOSED_FORM
    # full slip and the small-load limit (bonded circle compliance)
    full = 3 * limit * (2 - NU) / (16 * GMOD * A)
    assert an.cattaneo_mindlin_displacement(limit, PLOAD, MU, A, GMOD, NU) == pytest.approx(full, rel=1e-15)
    small = 1e-9 * limit
    assert an.cattaneo_mindlin_displacement(small, PLOAD, MU, A, GMOD, NU) == pytest.approx(
        small / an.circle_tangential_stiffness(A, GMOD, NU), rel=1e-8
    )  # O(Q/μP) correction
    assert an.stick_radius(limit, PLOAD, MU, A) == 0.0
    assert an.cattaneo_mindlin_stiffness(limit, PLOAD, MU, A, GMOD, NU) == 0.0


def test_cattaneo_mindlin_stiffness_is_derivative_of_displacement():
    """dQ/dδ equals 1/(dδ/dQ), differentiating the quadrature-based δ(Q) with mpmath.diff.

    δ(Q) here is the centre displacement of the Cattaneo traction (independent of the closed
    form; c(Q) = a(1 − Q/μP)^(1/3) checked in the test above). mpmath.diff raises the working
    precision itself, so the derivative is good to ~1e-20; tolerance REL_CLOSED_FORM (measured 5.6e-16).
    """
    limit = MU * PLOAD
    worst = 0.0
    with mp.workdps(25):
        a, G, nu, lim = _mpf(A), _mpf(GMOD), _mpf(NU), _mpf(limit)

        def delta(Q: mp.mpf) -> mp.mpf:
            p0mu = 3 * lim / (2 * mp.pi * a**2)
            c = a * mp.cbrt(1 - Q / lim)
            return _force_and_centre_displacement(lambda r: _cattaneo_traction(r, a, c, p0mu), a, G, nu, [0, c, a])[1]

        for x in [0.0, 0.3, 0.8, 0.99]:
            Q = x * limit
            dd = mp.diff(delta, _mpf(Q))
            k = an.cattaneo_mindlin_stiffness(Q, PLOAD, MU, A, GMOD, NU)
            worst = max(worst, _rel(k, 1 / dd))
    print(f"Cattaneo–Mindlin stiffness vs mpmath.diff of δ(Q): max rel error {worst:.1e}")
    assert worst < REL_CLOSED_FORM


def test_mindlin_deresiewicz_unloading_against_traction_quadrature():
    """Unloading from Q* = 0.7 μP: traction, force, displacement and the closing of the loop.

    Unloading traction (Mindlin & Deresiewicz 1953): the Cattaneo traction at Q* minus twice a
    Cattaneo distribution of radius c' = a(1 − (Q* − Q)/(2μP))^(1/3). The test checks that
    it satisfies Coulomb's law (|q| ≤ μp everywhere, = −μp on c' < r < a), carries the force Q,
    and that its centre displacement is the closed form; then δ(Q*) = δ_L(Q*) and
    δ(−Q*) = −δ_L(Q*). Tolerances: 1e-12 for quadrature vs closed form (as above); 1e-15 for
    the branch meeting points (identical algebra, a few ulp).
    """
    limit = MU * PLOAD
    Qs = 0.7 * limit
    worst = 0.0
    with mp.workdps(30):
        a, G, nu, lim = _mpf(A), _mpf(GMOD), _mpf(NU), _mpf(limit)
        p0mu = 3 * lim / (2 * mp.pi * a**2)
        cs = a * mp.cbrt(1 - _mpf(Qs) / lim)
        for x in [1.0, 0.5, 0.0, -0.4, -1.0]:
            Q = x * Qs
            cp = a * mp.cbrt(1 - (_mpf(Qs) - _mpf(Q)) / (2 * lim))

            def q(r: mp.mpf, cp=cp) -> mp.mpf:
                return _cattaneo_traction(r, a, cs, p0mu) - 2 * _cattaneo_traction(r, a, cp, p0mu)

            for r in mp.linspace(0, a * (1 - mp.mpf(10) ** -6), 41):  # Coulomb's law
                mup = p0mu * mp.sqrt(1 - (r / a) ** 2)
                assert abs(q(r)) <= mup * (1 + mp.mpf(10) ** -20)
                if r > cp:
                    assert abs(q(r) + mup) <= mup * mp.mpf(10) ** -20
            Qq, dq = _force_and_centre_displacement(q, a, G, nu, sorted({mp.mpf(0), cs, cp, a}))
            d = an.mindlin_deresiewicz_unloading_displacement(Q, Qs, PLOAD, MU, A, GMOD, NU)
            worst = max(worst, float(abs(Qq - Q) / Qs), float(abs(dq - _mpf(d)) / abs(dq) if x != 0 else 0))
            if x == 0:  # δ(0) on unloading is not zero (residual displacement): absolute check
                worst = max(
                    worst, float(abs(dq - _mpf(d)) / _mpf(an.cattaneo_mindlin_displacement(Qs, PLOAD, MU, A, GMOD, NU)))
                )
    print(f"Mindlin–Deresiewicz unloading vs traction quadrature: max rel error {worst:.1e}")
    assert worst < REL_CLOSED_FORM

    dL = an.cattaneo_mindlin_displacement(Qs, PLOAD, MU, A, GMOD, NU)
    unl = lambda Q: an.mindlin_deresiewicz_unloading_displacement(Q, Qs, PLOAD, MU, A, GMOD, NU)  # noqa: E731
    rel = lambda Q: an.mindlin_deresiewicz_reloading_displacement(Q, Qs, PLOAD, MU, A, GMOD, NU)  # noqa: E731
    assert unl(Qs) == pytest.approx(dL, rel=1e-15)
    assert unl(-Qs) == pytest.approx(-dL, rel=1e-15)  # meets the mirrored loading curve
    assert rel(-Qs) == pytest.approx(-dL, rel=1e-15) and rel(Qs) == pytest.approx(dL, rel=1e-15)
    # initial unloading stiffness is the bonded value; stiffness is the derivative (mpmath.diff
    # of the float64 branch with step 1e-4·Q*: truncation ~1e-8·h², rounding ~1e-16/1e-4 → 1e-9)
    kb = an.circle_tangential_stiffness(A, GMOD, NU)
    assert an.mindlin_deresiewicz_unloading_stiffness(Qs, Qs, PLOAD, MU, A, GMOD, NU) == pytest.approx(kb, rel=1e-15)
    for Q in [0.5 * Qs, -0.9 * Qs]:
        dd = mp.diff(lambda t: mp.mpf(unl(float(t))), Q, h=1e-4 * Qs)
        k = an.mindlin_deresiewicz_unloading_stiffness(Q, Qs, PLOAD, MU, A, GMOD, NU)
        assert k * float(dd) == pytest.approx(1.0, rel=1e-9)


def test_hysteresis_small_loop_accuracy():
    """Tiny loops keep their accuracy relative to the loop amplitude δ_L(Q*).

    f(x) = 1 − (1 − x)^(2/3) is evaluated as −expm1(⅔ log1p(−x)), so the branch is accurate to
    a few ulp of δ_L(Q*) however small Q*/(μP) is; written as 2(1 − x')^⅔ − (1 − x*)^⅔ − 1 it
    would lose log10(μP/Q*) digits (1e-6 relative to the amplitude here). Near the zero
    crossing of δ only this absolute accuracy is meaningful. Tolerance: 1e-14 of the amplitude
    (measured ~4e-18 at Q* = 1e-10 μP, ~1e-16 at Q* = 0.5 μP).
    """
    limit = MU * PLOAD
    worst = 0.0
    for xs_f in [1e-10, 1e-4, 0.5]:
        Qs = xs_f * limit
        amp = an.cattaneo_mindlin_displacement(Qs, PLOAD, MU, A, GMOD, NU)
        for xq in [1.0, 0.3, 0.0, -0.5, -1.0]:
            d = an.mindlin_deresiewicz_unloading_displacement(xq * Qs, Qs, PLOAD, MU, A, GMOD, NU)
            with mp.workdps(40):
                C = 3 * _mpf(limit) * (2 - _mpf(NU)) / (16 * _mpf(GMOD) * _mpf(A))
                xs = _mpf(Qs) / _mpf(limit)
                xr = (_mpf(Qs) - _mpf(xq * Qs)) / (2 * _mpf(limit))
                two3 = mp.mpf(2) / 3
                ref = C * (2 * (1 - xr) ** two3 - (1 - xs) ** two3 - 1)
                worst = max(worst, float(abs(_mpf(d) - ref) / _mpf(amp)))
    print(f"Mindlin–Deresiewicz branch, error relative to the loop amplitude: {worst:.1e}")
    assert worst < 1e-14


# ------------------------------------------------------------------------------------------
# argument checking
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "call,field",
    [
        (lambda: an.effective_modulus(0.0, 0.3), "G"),
        (lambda: an.effective_modulus(1.0, 0.51), "nu"),
        (lambda: an.effective_shear_modulus(1.0, -1.01), "nu"),
        (lambda: an.circle_tangential_stiffness(-1.0, 1.0, 0.3), "a"),
        (lambda: an.circle_normal_stiffness(1.0, float("nan"), 0.3), "G"),
        (lambda: an.mindlin_ellipse_compliance(1.0, 2.0, 1.0, 0.3), "b"),
        (lambda: an.mindlin_ellipse_compliance(1.0, 0.0, 1.0, 0.3), "b"),
        (lambda: an.mindlin_ellipse_stiffness(np.array([1.0, 1.0]), np.array([0.5, 1.5]), 1.0, 0.3), "b"),
        (lambda: an.mindlin_ellipse_stiffness_ratio(0.0, 0.3), "aspect"),
        (lambda: an.mindlin_ellipse_stiffness_ratio(1.0000001, 0.3), "aspect"),
        (lambda: an.thin_ellipse_ratio_asymptote(np.array([0.5, -1.0]), 0.3), "aspect"),
        (lambda: an.elliptical_punch_normal_stiffness(1.0, 0.5, 1.0, np.inf), "nu"),
        (lambda: an.hertz_sphere(1.0, -1e-3, 1.0, 0.3), "depth"),
        (lambda: an.hertz_pressure(0.0, 1.0, 0.0), "P"),
        (lambda: an.hertz_pressure("x", 1.0, 1.0), "r"),
        (lambda: an.cattaneo_mindlin_displacement(1.3, 1.0, 1.2, 1.0, 1.0, 0.3), "Q"),
        (lambda: an.cattaneo_mindlin_stiffness(0.1, 1.0, 0.0, 1.0, 1.0, 0.3), "mu"),
        (lambda: an.stick_radius(0.1, 1.0, 0.5, 1j), "a"),
        (lambda: an.mindlin_deresiewicz_unloading_displacement(0.1, 0.6, 1.0, 0.5, 1.0, 1.0, 0.3), "Q_star"),
        (lambda: an.mindlin_deresiewicz_unloading_displacement(-0.3, 0.2, 1.0, 0.5, 1.0, 1.0, 0.3), "Q"),
    ],
)
def test_bad_arguments_raise_input_error(call, field):
    with pytest.raises(InputError) as info:
        call()
    assert info.value.field == field
    assert isinstance(info.value, ValueError)
