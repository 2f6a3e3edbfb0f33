"""The Galin reference of ``tests/independent_reference.py``: the exact compliance of a rigid
bonded elliptical punch on the half-space with the Green's function Re H (the engine's
``tangential``, and ``normal`` from H_zz), checked against what does not share its quadrature.

- Isotropic bodies: Mindlin's (1949) ellipse and the elliptical punch, closed forms of
  ``hpcontact.analytic`` (good to ~1.5e-15, tests/test_analytic.py). H from the closed form
  (``green_isotropic``): Stroh's eigenvectors are defective at isotropy.
- Cubic crystals (Stroh's H): an independent adaptive quadrature (scipy.integrate.quad on φ, a
  break point at the peak φ = π/2), the symmetry and definiteness J must have, the mirror plane
  normal to x of the README's orientation path, and the convergence of the rule itself.

Only the closed forms come from hpcontact; the reference module imports nothing of it.
"""

from __future__ import annotations

import functools
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import dblquad, quad

from hpcontact import analytic as an

sys.path.insert(0, str(Path(__file__).resolve().parent))
import independent_reference as ref  # noqa: E402

pytestmark = pytest.mark.filterwarnings("error")

ASPECTS = [1.0, 0.3, 0.01, 1e-3]
NUS = [0.0, 0.25, 0.45, 0.5]

#: (nu, A, psi in degrees) of the tilted crystals: lab frame of ``orientation_frame``.
CRYSTALS = {"A3_psi60": (0.3, 3.0, 60.0), "A0.5_psi20": (0.3, 0.5, 20.0)}

# The rule stops when two successive panel doublings agree to 1e-13 (max |ΔJ_ij| / max |J_ij|);
# measured estimates 6e-16 … 7e-14, closed forms ~1.5e-15. The stiffnesses are J⁻¹ entries, so
# their error is that times cond(J) (≤ 3 here). Bound 1e-12: 1e-13 × cond × 3 for margin
# (measured worst 2.2e-15, nu = 0 at b/a = 0.01).
REL_CLOSED_FORM = 1e-12
# Round-off: the rule sums ~2000 terms of size ≤ max |Re H| / (4π) with weights ~1; what is zero
# by symmetry comes out at ~1e-16 of max |J| (measured ≤ 1.3e-16 for K_xy, ≤ 8.5e-17 for J − Jᵀ).
ROUND_OFF = 1e-14


def _crystal(name: str) -> np.ndarray:
    nu, A, psi = CRYSTALS[name]
    return ref.rotate(ref.cubic_from_nu_A(nu, A), ref.orientation_frame(psi))


@functools.cache
def _crystal_stiffness(name: str, aspect: float) -> dict:
    return ref.galin_ellipse_stiffness(_crystal(name), aspect)


# ------------------------------------------------------------------------------------------
# 1. Isotropic: Mindlin's ellipse and the frictionless elliptical punch
@pytest.mark.parametrize("nu", NUS)
@pytest.mark.parametrize("aspect", ASPECTS)
def test_isotropic_is_mindlin_and_the_elliptical_punch(nu: float, aspect: float) -> None:
    """K_xx, K_yy = Mindlin's (K_a, K_b) and K_zz = π a E*/K(m) (G = 1, a = 1); K_xy = 0 and
    approach held = load held (isotropic Re H has no xz, yz coupling) to round-off."""
    K = ref.galin_ellipse_stiffness(lambda phi: ref.green_isotropic(phi, nu), aspect)
    assert K["error"] <= 1e-13
    K_a, K_b = an.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
    K_zz = an.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu)
    assert K["K_xx"] == pytest.approx(K_a, rel=REL_CLOSED_FORM, abs=0.0)
    assert K["K_yy"] == pytest.approx(K_b, rel=REL_CLOSED_FORM, abs=0.0)
    assert K["K_zz"] == pytest.approx(K_zz, rel=REL_CLOSED_FORM, abs=0.0)
    assert abs(K["K_xy"]) <= ROUND_OFF * K["K_xx"] and abs(K["K_yx"]) <= ROUND_OFF * K["K_xx"]
    assert np.max(np.abs(K["load_held"] - K["approach_held"])) <= ROUND_OFF * K["K_yy"]


def test_isotropic_units_and_circle() -> None:
    """Units: J ∝ 1/(G a), so K ∝ G at a = 1; the circle is Mindlin's 8Ga/(2 − nu) and the
    punch 4Ga/(1 − nu)."""
    G, nu = 2.5, 0.3
    K = ref.galin_ellipse_stiffness(lambda phi: ref.green_isotropic(phi, nu, G), 1.0)
    assert K["K_xx"] == pytest.approx(8.0 * G / (2.0 - nu), rel=REL_CLOSED_FORM, abs=0.0)
    assert K["K_yy"] == pytest.approx(8.0 * G / (2.0 - nu), rel=REL_CLOSED_FORM, abs=0.0)
    assert K["K_zz"] == pytest.approx(4.0 * G / (1.0 - nu), rel=REL_CLOSED_FORM, abs=0.0)


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.45])
def test_isotropic_green_is_the_limit_of_stroh(nu: float) -> None:
    """``green_isotropic`` (Re and Im, the engine's sign of i(1 − 2nu)m/(2G)) is the A → 1 limit
    of ``green_stroh``: at A = 1 + 1e-8 they differ by O(A − 1) (measured 1.0000e-8, all three
    nu); bound 2e-8."""
    phi = np.linspace(0.0, 2.0 * math.pi, 37)
    H = ref.green_stroh(ref.cubic_from_nu_A(nu, 1.0 + 1e-8), phi)
    assert np.max(np.abs(H - ref.green_isotropic(phi, nu))) <= 2e-8


def test_voigt_input_is_the_tensor() -> None:
    """A 6 × 6 Voigt stiffness (order 11, 22, 33, 23, 13, 12) gives the tensor it came from (the
    rotated tensor keeps its minor symmetries to round-off only: 1.1e-16 of C11), and the same
    Galin compliance."""
    C = _crystal("A3_psi60")
    pairs = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))
    C6 = np.array([[C[i, j, k, l] for (k, l) in pairs] for (i, j) in pairs])
    assert np.max(np.abs(ref.stiffness_tensor(C6) - C)) <= 1e-15 * np.max(np.abs(C))
    J, _ = ref.galin_ellipse_compliance(C, 0.3)
    J6, _ = ref.galin_ellipse_compliance(C6, 0.3)
    assert np.max(np.abs(J6 - J)) <= ROUND_OFF * np.max(np.abs(J))
    with pytest.raises(ValueError):
        ref.stiffness_tensor(np.eye(3))


# ------------------------------------------------------------------------------------------
# 2. Tilted cubic crystals
@pytest.mark.parametrize("aspect", [0.3, 0.01])
@pytest.mark.parametrize("name", list(CRYSTALS))
def test_crystal_agrees_with_adaptive_quadrature(name: str, aspect: float) -> None:
    """J against scipy.integrate.quad of (1/4π) ∫_0^π Re H_ij/s dφ per entry (break point at
    φ = π/2, epsrel 1e-13, epsabs 1e-15 of the largest entry): measured ≤ 2.5e-15 of max |J|.
    Bound 1e-12: the two requested accuracies (1e-13 each) with a factor 5."""
    C = _crystal(name)
    J, error = ref.galin_ellipse_compliance(C, aspect)
    scale = float(np.max(np.abs(J)))
    memo: dict[float, np.ndarray] = {}

    def integrand(phi: float) -> np.ndarray:  # every entry at once: quad's nodes repeat per entry
        if phi not in memo:
            s = math.hypot(math.cos(phi), aspect * math.sin(phi))
            memo[phi] = ref.green_stroh(C, np.array(phi)).real / s
        return memo[phi]

    Q = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            value, _ = quad(
                lambda phi: integrand(phi)[i, j],
                0.0,
                math.pi,
                points=[0.5 * math.pi],
                epsabs=1e-15 * 4.0 * math.pi * scale,
                epsrel=1e-13,
                limit=200,
            )
            Q[i, j] = value / (4.0 * math.pi)
    assert error <= 1e-13
    assert np.max(np.abs(J - Q)) <= 1e-12 * scale
    assert np.max(np.abs(J - J.T)) <= ROUND_OFF * scale
    assert np.all(np.linalg.eigvalsh(0.5 * (J + J.T)) > 0.0)
    assert np.all(np.linalg.eigvalsh(np.linalg.inv(0.5 * (J + J.T))) > 0.0)


#: Measured (load held − approach held)/approach held of K_yy = −J_yz²/(J_yy J_zz). At A = 3,
#: psi = 60° it grows slowly as the ellipse thins (6.80e-3 at b/a = 1, 8.90e-3 at 1e-3); at
#: A = 0.5, psi = 20° J_yz changes sign near b/a = 0.18 and the two meanings nearly coincide there.
LOAD_HELD_DIFFERENCE = {
    ("A3_psi60", 0.3): -7.7189e-3,
    ("A3_psi60", 0.01): -8.6711e-3,
    ("A0.5_psi20", 0.3): -1.6058e-5,
    ("A0.5_psi20", 0.01): -1.3014e-4,
}


@pytest.mark.parametrize(("name", "aspect"), list(LOAD_HELD_DIFFERENCE))
def test_crystal_load_held_is_not_approach_held(name: str, aspect: float) -> None:
    """The orientation path keeps a mirror plane normal to x, so J_xy = J_xz = 0 (round-off) and
    only K_yy depends on what the normal does: approach held K_yy = 1/(J_yy − J_yz²/J_zz), load
    held 1/J_yy (to round-off); K_xx = 1/J_xx in both. The difference is a fact of the material,
    pinned to the 5 digits measured (rel 1e-4); at A = 3, psi = 60° it exceeds 1e-4 (the issue's
    "up to 0.8 %")."""
    K = _crystal_stiffness(name, aspect)
    J = K["J"]
    scale = float(np.max(np.abs(J)))
    assert abs(J[0, 1]) <= ROUND_OFF * scale and abs(J[0, 2]) <= ROUND_OFF * scale
    approach, load = K["approach_held"], K["load_held"]
    assert approach[0, 0] == pytest.approx(1.0 / J[0, 0], rel=ROUND_OFF)
    assert load[0, 0] == pytest.approx(1.0 / J[0, 0], rel=ROUND_OFF)
    assert approach[1, 1] == pytest.approx(1.0 / (J[1, 1] - J[1, 2] ** 2 / J[2, 2]), rel=ROUND_OFF)
    assert load[1, 1] == pytest.approx(1.0 / J[1, 1], rel=ROUND_OFF)
    difference = load[1, 1] / approach[1, 1] - 1.0
    assert difference == pytest.approx(-(J[1, 2] ** 2) / (J[1, 1] * J[2, 2]), rel=1e-12, abs=1e-15)
    assert difference == pytest.approx(LOAD_HELD_DIFFERENCE[(name, aspect)], rel=1e-4)
    if name == "A3_psi60":
        assert abs(difference) > 1e-4
    assert K["K_xy"] == approach[0, 1] and K["K_yy"] == approach[1, 1]
    assert K["K_zz"] == 1.0 / J[2, 2]


# ------------------------------------------------------------------------------------------
# 3. Convergence of the rule itself
@pytest.mark.parametrize("name", list(CRYSTALS))
def test_rule_is_converged_for_a_thin_ellipse(name: str) -> None:
    """b/a = 1e-3: the error estimate is ≤ 1e-12 (measured 7.7e-16 and 5.2e-14), one more
    doubling of the panels moves J by less than 1e-12 (measured 2.2e-15, 1.6e-15), and
    lengthening the truncated v-interval by 5 (tails × e^{−5}) moves it by round-off only
    (measured ≤ 1.3e-15)."""
    C = _crystal(name)
    q = ref.galin_ellipse_quadrature(C, 1e-3)
    J = q["J"]
    scale = float(np.max(np.abs(J)))
    assert q["error"] <= 1e-12
    finer = ref.galin_ellipse_rule(C, 1e-3, 2 * q["panels"], v_max=q["v_max"])
    assert np.max(np.abs(finer - J)) <= 1e-12 * scale
    longer = ref.galin_ellipse_rule(C, 1e-3, 2 * q["panels"], v_max=q["v_max"] + 5.0)
    assert np.max(np.abs(longer - finer)) <= 1e-14 * scale


@pytest.mark.parametrize("X, Y", [(1.0, 0.0), (2.0, 1.0), (-1.0, 3.0), (0.0, -2.0)])
def test_cell_integrals_against_adaptive_quadrature(X: float, Y: float) -> None:
    """The closed-form cell integrals of the dense BEM (``cell_integrals``) against scipy's
    dblquad of the kernels over a unit cell, field points one or more cells away (smooth
    integrands: dblquad's default 1.49e-8 tolerances; measured ≤ 6e-16 relative)."""
    kernels = {
        "1": lambda u, v: 1.0 / math.hypot(u, v),
        "xx": lambda u, v: u * u / math.hypot(u, v) ** 3,
        "yy": lambda u, v: v * v / math.hypot(u, v) ** 3,
        "xy": lambda u, v: u * v / math.hypot(u, v) ** 3,
        "x": lambda u, v: u / (u * u + v * v),
        "y": lambda u, v: v / (u * u + v * v),
    }
    closed = ref.cell_integrals(np.array(X), np.array(Y), 1.0, 1.0)
    scale = abs(float(closed["1"]))
    for name, k in kernels.items():
        value = dblquad(lambda v, u: k(X - u, Y - v), -0.5, 0.5, -0.5, 0.5)[0]
        assert abs(float(closed[name]) - value) <= 1e-8 * scale, name
