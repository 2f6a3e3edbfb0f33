"""Elastic stiffness: constructors, validation, tensor conversion, rotations, the crystal library."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.materials import crystal as cr

# Round-off of a few float64 operations on O(1)–O(500) numbers: ~1e-16 relative; 1e-13 leaves
# a wide margin for the 81-term einsum of a rotation.
RTOL = 1e-13


def rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


# ------------------------------------------------------------------ constructors
def test_cubic_from_nu_A_relations() -> None:
    for nu in (-0.5, 0.0, 0.25, 0.49):
        for A in (0.25, 1.0, 3.0):
            C = cr.cubic_from_nu_A(nu, A, scale=2.5).voigt
            C11, C12, C44 = C[0, 0], C[0, 1], C[3, 3]
            assert C12 == pytest.approx(C11 * nu / (1 - nu), rel=1e-14, abs=1e-14)
            assert (C11 - C12) / 2 == pytest.approx(2.5, rel=1e-14)
            assert C44 == pytest.approx(A * (C11 - C12) / 2, rel=1e-14)
            assert cr.zener_ratio(C) == pytest.approx(A, rel=1e-14)


def test_isotropic_is_cubic_with_A_1() -> None:
    iso = cr.isotropic(1.7, 0.3).voigt
    assert rel(iso, cr.cubic_from_nu_A(0.3, 1.0, scale=1.7).voigt) < RTOL
    # Lamé: C11 = λ + 2G, C12 = λ, C44 = G
    lam = 2 * 1.7 * 0.3 / (1 - 0.6)
    assert iso[0, 0] == pytest.approx(lam + 3.4, rel=1e-15)
    assert iso[0, 1] == pytest.approx(lam, rel=1e-15)
    assert iso[5, 5] == pytest.approx(1.7, rel=1e-15)


def test_orthotropic_compliance_and_isotropic_special_case() -> None:
    E1, E2, E3, n12, n13, n23, G12, G13, G23 = 3.0, 2.0, 1.5, 0.2, 0.25, 0.3, 0.9, 0.7, 0.6
    C = cr.orthotropic(E1, E2, E3, n12, n13, n23, G12, G13, G23).voigt
    S = np.linalg.inv(C)
    assert 1 / S[0, 0] == pytest.approx(E1, rel=1e-13)
    assert 1 / S[1, 1] == pytest.approx(E2, rel=1e-13)
    assert -S[0, 1] * E1 == pytest.approx(n12, rel=1e-13)
    assert -S[1, 2] * E2 == pytest.approx(n23, rel=1e-13)
    assert 1 / S[3, 3] == pytest.approx(G23, rel=1e-13)
    assert 1 / S[5, 5] == pytest.approx(G12, rel=1e-13)
    E, nu = 2.6, 0.3
    G = E / (2 * (1 + nu))
    iso = cr.orthotropic(E, E, E, nu, nu, nu, G, G, G).voigt
    assert rel(iso, cr.isotropic(G, nu).voigt) < RTOL


# ------------------------------------------------------------------ validation
@pytest.mark.parametrize(
    "args, field",
    [
        ((1.0, 1.2, 0.5), "C12"),  # C11 − C12 < 0
        ((1.0, 0.5, 0.0), "C44"),  # C44 = 0
        ((1.0, -0.6, 0.5), "C12"),  # C11 + 2 C12 < 0
        ((float("nan"), 0.5, 0.5), "C11"),
    ],
)
def test_cubic_refuses_unstable(args, field) -> None:
    with pytest.raises(InputError) as e:
        cr.cubic(*args)
    assert e.value.field == field


def test_check_stiffness_refusals() -> None:
    good = cr.cubic(3.0, 1.0, 1.0).voigt
    with pytest.raises(InputError, match="6 x 6"):
        cr.check_stiffness(np.eye(5))
    bad = np.array(good)
    bad[0, 1] += 1e-6
    with pytest.raises(InputError, match="symmetric"):
        cr.check_stiffness(bad)
    notpd = np.array(good)
    notpd[3, 3] = -0.1
    with pytest.raises(InputError, match="positive definite") as e:
        cr.check_stiffness(notpd, "C")
    assert e.value.field == "C"
    with pytest.raises(InputError, match="finite"):
        cr.check_stiffness(np.full((6, 6), np.inf))
    with pytest.raises(InputError):
        cr.Crystal(np.zeros((6, 6)))
    with pytest.raises(InputError) as e:
        cr.cubic_from_nu_A(0.5, 2.0)
    assert e.value.field == "nu"
    with pytest.raises(InputError) as e:
        cr.cubic_from_nu_A(0.3, 0.0)
    assert e.value.field == "anisotropy"
    with pytest.raises(InputError):
        cr.orthotropic(1, 1, 1, 1.2, 0.2, 0.2, 1, 1, 1)  # |nu12| > sqrt(E1/E2): not PD
    # Nearly incompressible is still accepted (eigenvalue ratio ~ 1 − 2 nu = 2e-9 > 1e-13).
    cr.isotropic(1.0, 0.499999999)


def test_result_is_read_only_float64() -> None:
    C = cr.cubic(3.0, 1.0, 1.0).voigt
    assert C.dtype == np.float64 and not C.flags.writeable


# ------------------------------------------------------------------ Voigt ↔ tensor
def test_voigt_tensor_round_trip_and_symmetries() -> None:
    rng = np.random.default_rng(0)
    M = rng.normal(size=(6, 6))
    C6 = M @ M.T + 6 * np.eye(6)
    C = cr.voigt_to_tensor(C6)
    assert rel(cr.tensor_to_voigt(C), C6) < 1e-15
    assert np.array_equal(C, C.transpose(1, 0, 2, 3))
    assert np.array_equal(C, C.transpose(0, 1, 3, 2))
    assert np.array_equal(C, C.transpose(2, 3, 0, 1))
    assert C[1, 2, 0, 2] == C6[3, 4] and C[0, 1, 0, 1] == C6[5, 5]


# ------------------------------------------------------------------ rotations
def _is_rotation(R) -> bool:
    # Built from unit vectors and re-orthonormalized by QR: orthogonal to round-off (1e-15).
    return np.max(np.abs(R @ R.T - np.eye(3))) < 1e-14 and abs(np.linalg.det(R) - 1) < 1e-14


@pytest.mark.parametrize(
    "hkl",
    [(0, 0, 1), (1, 1, 0), (1, 1, 1), (1, 0, 0), (0, 1, 0), (1, 2, 3), (-1, 1, 2), (0, 0, -1), (3, -1, 0), (1, 1, 5)],
)
def test_miller_rotation_is_proper_and_normal_is_hkl(hkl) -> None:
    for az in (0.0, 37.0):
        R = cr.rotation_from_miller(hkl, az)
        assert _is_rotation(R)
        n = np.array(hkl, float) / np.linalg.norm(hkl)
        assert rel(R[2], n) < 1e-15


def test_psi_path_endpoints_and_miller_agreement() -> None:
    s2 = math.sqrt(0.5)
    R0 = cr.rotation_from_orientation(0.0)
    assert rel(R0[2], [s2, s2, 0]) < 1e-15 and rel(R0[0], [-s2, s2, 0]) < 1e-15
    psi111 = math.degrees(math.atan(1 / math.sqrt(2)))  # 35.26°
    assert rel(cr.rotation_from_orientation(psi111)[2], np.ones(3) / math.sqrt(3)) < 1e-15
    R90 = cr.rotation_from_orientation(90.0)
    assert np.max(np.abs(R90[2] - [0, 0, 1])) < 1e-15
    assert np.max(np.abs(R90[0] - [-s2, s2, 0])) < 1e-15
    # Miller [h h l] with h > 0 gives the same frame as psi = atan(l/(h√2)).
    for h, l in ((1, 0), (1, 1), (1, 2), (2, 1), (1, 5), (0, 1)):
        psi = math.degrees(math.atan2(l, h * math.sqrt(2)))
        for az in (0.0, -20.0):
            assert rel(cr.rotation_from_miller((h, h, l), az), cr.rotation_from_orientation(psi, az)) < 1e-14
    # Continuity along the path: neighbouring psi give neighbouring frames.
    psis = np.linspace(0, 90, 181)
    frames = np.array([cr.rotation_from_orientation(p) for p in psis])
    assert np.max(np.abs(np.diff(frames, axis=0))) < 0.01  # step 0.5° = 0.0087 rad


def test_azimuth_turns_in_plane_axes() -> None:
    R0 = cr.rotation_from_miller((1, 2, 3))
    R = cr.rotation_from_miller((1, 2, 3), 30.0)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    assert rel(R[0], c * R0[0] + s * R0[1]) < 1e-15
    assert rel(R[2], R0[2]) < 1e-15


def test_rotation_invariants_and_symmetries() -> None:
    cu = cr.crystal("Cu")
    for miller in ((1, 1, 1), (1, 2, 3), (1, 1, 0)):
        Cr = cu.oriented(miller=miller, azimuth_deg=11.0)
        T0, T1 = cu.tensor, Cr.tensor
        # Isotropic invariants C_iijj and C_ijij are unchanged by a rotation.
        assert np.einsum("iijj", T1) == pytest.approx(np.einsum("iijj", T0), rel=1e-14)
        assert np.einsum("ijij", T1) == pytest.approx(np.einsum("ijij", T0), rel=1e-14)
        # Kelvin (Mandel) moduli, eigenvalues of W C W with W = diag(1, 1, 1, √2, √2, √2),
        # are rotation invariant (Mehrabadi & Cowin 1990).
        W = np.diag([1, 1, 1, math.sqrt(2), math.sqrt(2), math.sqrt(2)])
        assert rel(np.linalg.eigvalsh(W @ Cr.voigt @ W), np.linalg.eigvalsh(W @ cu.voigt @ W)) < RTOL
    # A cubic symmetry operation (90° about [001]) leaves the cubic stiffness unchanged.
    Q = np.array([[0.0, 1, 0], [-1, 0, 0], [0, 0, 1]])
    assert rel(cr.rotate_voigt(cu.voigt, Q), cu.voigt) < RTOL
    # An isotropic stiffness is unchanged by any rotation.
    iso = cr.isotropic(1.0, 0.3)
    assert rel(iso.oriented(miller=(1, 2, 3), azimuth_deg=5).voigt, iso.voigt) < RTOL
    with pytest.raises(InputError):
        cr.rotate_voigt(cu.voigt, np.diag([1.0, 1.0, -1.0]))  # improper
    with pytest.raises(InputError):
        cu.oriented()
    with pytest.raises(InputError):
        cr.rotation_from_miller((0, 0, 0))
    with pytest.raises(InputError):
        cr.rotation_from_miller((1.5, 0, 1))


def test_oriented_records_rotation_and_round_trips() -> None:
    cu = cr.crystal("Cu")
    Cr = cu.oriented(miller=(1, 2, 3))
    assert rel(Cr.rotation, cr.rotation_from_miller((1, 2, 3))) < 1e-15
    back = cr.rotate_voigt(Cr.voigt, Cr.rotation.T)
    assert rel(back, cu.voigt) < RTOL
    with pytest.raises(InputError):
        Cr.oriented(miller=(0, 0, 1))  # already in a lab frame


# ------------------------------------------------------------------ library
def test_library() -> None:
    names = cr.library_names()
    for required in ("Cu", "Al", "Fe", "Ni", "W", "Si"):
        assert required in names
    for name in names:
        c = cr.crystal(name)
        assert c.citation and c.name == name
        assert np.all(np.linalg.eigvalsh(c.voigt) > 0)
    # Zener ratios of the cited constants (Cu ≈ 3.2, W ≈ 1.0, Al ≈ 1.2, Si ≈ 1.56; Hirth & Lothe
    # 1982 Table 13-1 quote A to two digits, hence 1 %).
    assert cr.crystal("Cu").zener_ratio() == pytest.approx(3.21, rel=0.01)
    assert cr.crystal("W").zener_ratio() == pytest.approx(1.01, rel=0.01)
    assert cr.crystal("Al").zener_ratio() == pytest.approx(1.22, rel=0.01)
    assert cr.crystal("Si").zener_ratio() == pytest.approx(1.56, rel=0.01)
    assert cr.crystal("copper") == cr.crystal("cu")
    assert hash(cr.crystal("Ni")) == hash(cr.crystal("nickel"))
    with pytest.raises(InputError) as e:
        cr.crystal("unobtainium")
    assert e.value.field == "material"
