"""Stiffness quantities (hpcontact.quantities) against explicit linear algebra and the circle references.

Every reference is built independently: directions n = (cos θ, sin θ) and t = (−sin θ, cos θ)
and the quadratic forms nᵀ K n, nᵀ K t written out; tensors with known eigen-decomposition
R diag(K1, K2) Rᵀ; compliance matrices inverted by hand for 2 × 2. Tolerances are a few ulp of
the quantities (products of O(1) numbers, no cancellation beyond the stated one).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hpcontact import analytic
from hpcontact import quantities as q
from hpcontact.materials.isotropic import Isotropic

pytestmark = pytest.mark.filterwarnings("error")

# A generic non-symmetric tensor (K_xy ≠ K_yx, as a solver's output has) and a few angles
K = np.array([[3.0, 0.4], [0.7, 1.5]])
ANGLES = [0.0, 17.0, 45.0, 90.0, 123.4, 180.0, -30.0]
ULP = 1e-14  # O(1) sums of four products of O(1) numbers: a few ulp, ×10 margin


def _n(theta):
    t = math.radians(theta)
    return np.array([math.cos(t), math.sin(t)])


def _t(theta):
    t = math.radians(theta)
    return np.array([-math.sin(t), math.cos(t)])


@pytest.mark.parametrize("theta", ANGLES)
def test_directional_stiffness_is_quadratic_form(theta):
    n = _n(theta)
    assert q.directional_stiffness(K, theta) == pytest.approx(n @ K @ n, abs=ULP)


@pytest.mark.parametrize("theta", ANGLES)
def test_rotated_tensor_transformation_law(theta):
    n, t = _n(theta), _t(theta)
    Kr = q.rotated_tensor(K, theta)
    expected = np.array([[n @ K @ n, n @ K @ t], [t @ K @ n, t @ K @ t]])
    np.testing.assert_allclose(Kr, expected, rtol=0, atol=ULP)
    # K'[0,0] is K_nn of the same direction, K'[1,1] the one 90° further
    assert Kr[0, 0] == pytest.approx(float(q.directional_stiffness(K, theta)), abs=ULP)
    assert Kr[1, 1] == pytest.approx(float(q.directional_stiffness(K, theta + 90.0)), abs=ULP)
    # invariants of a similarity transform
    assert np.trace(Kr) == pytest.approx(np.trace(K), abs=ULP)
    assert np.linalg.det(Kr) == pytest.approx(np.linalg.det(K), abs=ULP)
    # the antisymmetric part K_xy − K_yx is invariant under rotation
    assert Kr[0, 1] - Kr[1, 0] == pytest.approx(K[0, 1] - K[1, 0], abs=ULP)


def test_directional_stiffness_broadcasts():
    stack = np.stack([K, 2.0 * K, K.T])  # (3, 2, 2)
    theta = np.array([[0.0], [30.0], [90.0], [200.0]])  # (4, 1) against (3,)
    out = q.directional_stiffness(stack, theta)
    assert out.shape == (4, 3)
    for a, th in enumerate(theta[:, 0]):
        for b in range(3):
            n = _n(th)
            assert out[a, b] == pytest.approx(n @ stack[b] @ n, abs=4 * ULP)


def test_directional_stiffness_of_symmetric_part_only():
    # nᵀ K n sees only the symmetric part: K and K + antisymmetric give the same K_nn
    W = np.array([[0.0, 5.0], [-5.0, 0.0]])
    th = np.linspace(0.0, 180.0, 13)
    np.testing.assert_allclose(q.directional_stiffness(K + W, th), q.directional_stiffness(K, th), atol=1e-13)


@pytest.mark.parametrize("angle", [0.0, 30.0, 89.0, 120.0, 179.0])
def test_principal_values_and_angle(angle):
    R = np.array(
        [
            [math.cos(math.radians(angle)), -math.sin(math.radians(angle))],
            [math.sin(math.radians(angle)), math.cos(math.radians(angle))],
        ]
    )
    K_sym = R @ np.diag([4.0, 1.5]) @ R.T
    W = np.array([[0.0, 0.3], [-0.3, 0.0]])  # antisymmetric error part: must be ignored
    k_max, k_min, principal = q.principal_stiffness(K_sym + W)
    assert k_max == pytest.approx(4.0, rel=1e-14)
    assert k_min == pytest.approx(1.5, rel=1e-14)
    # angle in [0, 180), compare modulo 180; eigenvector accuracy ~ ulp / gap (gap 2.5) in rad
    assert 0.0 <= principal < 180.0
    diff = (principal - angle + 90.0) % 180.0 - 90.0
    assert abs(diff) <= 1e-12
    # K_max is the directional stiffness along the principal angle
    assert float(q.directional_stiffness(K_sym, principal)) == pytest.approx(4.0, rel=1e-13)


def test_principal_of_isotropic_tensor():
    k_max, k_min, angle = q.principal_stiffness(2.5 * np.eye(2))
    assert k_max == k_min == 2.5
    assert 0.0 <= angle < 180.0


def test_asymmetry():
    assert q.asymmetry(K) == pytest.approx(0.3 / 3.0, rel=1e-15)
    assert q.asymmetry(np.array([[1.0, 0.2], [0.2, 1.0]])) == 0.0


def test_resultant_sums_traction_times_cell_area():
    rng = np.random.default_rng(0)
    t = rng.normal(size=(3, 5, 4))
    f = q.resultant(t, cell_area=0.25)
    expected = [sum(t[c, i, j] for i in range(5) for j in range(4)) * 0.25 for c in range(3)]
    np.testing.assert_allclose(f, expected, rtol=1e-14, atol=1e-14)


def test_compliance_proxy_is_inverse_of_compliance():
    K_true = np.array([[2.0, 0.3], [0.3, 0.8]])
    J = np.linalg.inv(K_true)
    force = np.array([2.0, 5.0])  # different total forces per load case
    mean_displacement = J * force[None, :]  # ū_i for a uniform traction along j with force F_j
    proxy = q.compliance_proxy(mean_displacement, force)
    # 2 × 2 inverse by hand
    det = J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
    by_hand = np.array([[J[1, 1], -J[0, 1]], [-J[1, 0], J[0, 0]]]) / det
    # condition number of J ≈ 3: a few ulp × 3
    np.testing.assert_allclose(proxy, by_hand, rtol=1e-14)
    np.testing.assert_allclose(proxy, K_true, rtol=1e-14)


@pytest.mark.parametrize("nu", [-0.5, 0.0, 0.3, 0.5])
@pytest.mark.parametrize("G", [1.0, 7.3e10])
@pytest.mark.parametrize("a", [1.0, 2.5e-3])
def test_li_normalization_is_one_for_the_circle(nu, G, a):
    m = Isotropic(G=G, nu=nu)
    k_t = analytic.circle_tangential_stiffness(a, G, nu)
    k_n = analytic.circle_normal_stiffness(a, G, nu)
    value = q.li_normalization(k_t, k_n, m.E_star, m.G_star)
    # (8Ga/(2−nu)) (2G/(1−nu)) / ((4Ga/(1−nu)) (4G/(2−nu))) = 1: ~6 roundings
    assert value == pytest.approx(1.0, abs=1e-14)
    # and it is not 1 for a non-circle (Mindlin ellipse b/a = 0.3), a sanity guard on the test
    ka, kb = analytic.mindlin_ellipse_stiffness(1.0, 0.3, G, nu)
    kzz = analytic.elliptical_punch_normal_stiffness(1.0, 0.3, G, nu)
    na = q.li_normalization(ka, kzz, m.E_star, m.G_star)
    ref = analytic.mindlin_ellipse_normalized_stiffness(0.3, nu)[0]
    assert na == pytest.approx(ref, rel=1e-12)


@pytest.mark.parametrize("G", [1e300, 1e-300])
def test_li_normalization_huge_and_tiny_moduli(G):
    m = Isotropic(G=G, nu=0.3)
    k_t = analytic.circle_tangential_stiffness(1.0, G, 0.3)
    k_n = analytic.circle_normal_stiffness(1.0, G, 0.3)
    with np.errstate(all="ignore"):
        value = q.li_normalization(k_t, k_n, m.E_star, m.G_star)
    assert value == pytest.approx(1.0, abs=1e-14)


def test_principal_angle_of_an_isotropic_tensor_is_missing_not_noise():
    """A tensor isotropic within its own accuracy has no principal direction: the angle is None
    (NaN in a data set) with a note, where the eigenvectors of 2.5 I + noise gave any angle
    (45.0 for a circle). Accuracy: max(noise asked, |K_xy − K_yx|/K, 64 eps)."""
    iso = {"K_xx": 2.5, "K_xy": 1e-17, "K_yx": -1e-17, "K_yy": 2.5 * (1 + 1e-15)}
    out = q.derived_quantities(iso, None)
    assert out["principal_angle_deg"] is None and "isotropic" in out["principal_angle_note"]
    assert out["K_min_over_K_max"] == pytest.approx(1.0, abs=2e-15)
    # a spread above the stated accuracy keeps its angle: 1e-6 apart with noise 1e-8
    aniso = {**iso, "K_yy": 2.5 * (1 + 1e-6)}
    out = q.derived_quantities(aniso, None, noise=1e-8)
    assert out["principal_angle_deg"] == pytest.approx(90.0, abs=1e-6) and "principal_angle_note" not in out
    assert q.derived_quantities(aniso, None, noise=1e-5)["principal_angle_deg"] is None


def test_the_directional_error_bound_holds_and_is_attained():
    """|nᵀ δK n| ≤ c² B_xx + |cs| (B_xy + B_yx) + s² B_yy for every |δK_ij| ≤ B_ij, with equality
    for the perturbation whose signs follow c², cs and s² (so the bound is the least one)."""
    rng = np.random.default_rng(7)
    bounds = np.array([[3e-4, 1e-5], [4e-5, 2e-4]])
    theta = np.linspace(-180.0, 180.0, 73)
    bound = q.directional_error(bounds, theta)
    for _ in range(200):
        dK = bounds * rng.uniform(-1.0, 1.0, size=(2, 2))
        assert np.all(np.abs(q.directional_stiffness(dK, theta)) <= bound * (1 + 1e-12))
    t = np.radians(theta)
    worst = np.stack(
        [bounds * np.array([[1.0, np.sign(c * s)], [np.sign(c * s), 1.0]]) for c, s in zip(np.cos(t), np.sin(t))]
    )
    np.testing.assert_allclose(q.directional_stiffness(worst, theta), bound, rtol=1e-13)


# A hand-built 3 x 3 stiffness with normal-tangential coupling (a crystal's Re H): symmetric
# positive definite, K_xy ≠ 0 and both K_xz and K_yz nonzero, as R diag(4, 2.5, 1) Rᵀ.
_R3 = np.linalg.qr(np.array([[1.0, 0.3, -0.2], [0.1, 1.0, 0.4], [0.5, -0.2, 1.0]]))[0]
K3 = _R3 @ np.diag([4.0, 2.5, 1.0]) @ _R3.T


def test_load_held_stiffness_is_the_schur_complement_and_the_inverse_compliance():
    """K_load = K_tt − K_tz K_zz⁻¹ K_zt = (J_tt)⁻¹, J = K⁻¹ (Mindlin 1949 with the normal force
    held): written out entry by entry, and against the compliance inverted by numpy."""
    found = q.load_held_stiffness(K3)
    by_hand = np.array([[K3[i, j] - K3[i, 2] * K3[2, j] / K3[2, 2] for j in range(2)] for i in range(2)])
    np.testing.assert_allclose(found, by_hand, rtol=0, atol=4 * ULP)
    np.testing.assert_allclose(found, np.linalg.inv(np.linalg.inv(K3)[:2, :2]), rtol=0, atol=4 * ULP)
    assert abs(found[0, 0] / K3[0, 0] - 1.0) > 1e-2  # the coupling matters here
    # no coupling: the load held is the approach held, exactly
    decoupled = K3.copy()
    decoupled[:2, 2] = decoupled[2, :2] = 0.0
    assert np.array_equal(q.load_held_stiffness(decoupled), decoupled[:2, :2])


def test_the_record_forms_the_schur_complement_from_three_solves_and_says_so():
    """tangential_x/y/z (unit displacement x, y, z) are the columns of the 3 × 3; K_xx … K_yy
    and every derived quantity follow from its Schur complement; ``normal_held`` = "load"."""
    forces = {"tangential_x": K3[:, 0], "tangential_y": K3[:, 1], "tangential_z": K3[:, 2]}
    record = q.stiffness_record(forces, ("tangential",), None)
    schur = q.load_held_stiffness(K3)
    assert record["normal_held"] == "load"
    assert [record[k] for k in ("K_xx", "K_xy", "K_yx", "K_yy")] == [schur[0, 0], schur[0, 1], schur[1, 0], schur[1, 1]]
    k_max, k_min, _ = q.principal_stiffness(schur)
    assert (record["K_max"], record["K_min"]) == (k_max, k_min)
    assert record["K_a_over_K_b"] == schur[0, 0] / schur[1, 1]
    approach = q.stiffness_record({k: v for k, v in forces.items() if k != "tangential_z"}, ("tangential",), None)
    assert "normal_held" not in approach and approach["K_xx"] == K3[0, 0] and approach["K_yx"] == K3[1, 0]


@pytest.mark.parametrize(
    "bad",
    [
        np.diag([1.0, 1.0, -1.0]),  # indefinite
        np.diag([1.0, 1.0, 0.0]),  # singular: K_zz = 0
        np.array([[1.0, 0.0, 2.0], [0.0, 1.0, 0.0], [2.0, 0.0, 1.0]]),  # K_zz > 0, yet indefinite
        np.diag([1.0, 1.0, 1e-17]),  # positive, but not above round-off
        np.diag([1.0, np.nan, 1.0]),
    ],
)
def test_a_stiffness_that_is_not_positive_definite_is_refused(bad):
    with pytest.raises(FloatingPointError, match="with the normal load held"):
        q.load_held_stiffness(bad)
    forces = {"tangential_x": bad[:, 0], "tangential_y": bad[:, 1], "tangential_z": bad[:, 2]}
    with pytest.raises(FloatingPointError, match="with the normal load held"):
        q.stiffness_record(forces, ("tangential",), None)


def test_quantity_registry_drives_what_each_discretization_accepts():
    """Each quantity is declared once (``quantities.QUANTITIES``): the scene accepts exactly
    those, Galin's exact cell applies to a circle exactly for the ``exact_cell`` ones, and the
    coverage-weighted cells refuse the ones that are not ``refinable`` before solving."""
    from hpcontact.discretizations import boundary_cells, galin_ellipse
    from hpcontact.errors import InputError
    from hpcontact.quantities import QUANTITIES
    from hpcontact.scene import Scene

    for name, quantity in QUANTITIES.items():
        extra = {"radius": 1.0, "depth": 0.01} if name == "indentation" else {}
        scene = Scene.from_params({"shape": "circle", "quantities": name, "n": 8, **extra})
        assert galin_ellipse.applies(scene) is quantity.exact_cell, name
        if not quantity.refinable:
            with pytest.raises(InputError, match="coverage-weighted cells"):
                boundary_cells.covered_solve(scene)
    with pytest.raises(InputError, match="quantities"):
        Scene.from_params({"shape": "circle", "quantities": "shear"})
