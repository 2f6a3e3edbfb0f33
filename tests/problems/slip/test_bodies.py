"""Two bodies (hpcontact.problems.slip.bodies): materials by name, combined compliance, similarity, Hertz ellipse.

Each check compares against a form derived independently of the code under test (Johnson 1985
§4.2 and §5.4, Dundurs 1969) or against the engine's own single-body kernels; tolerances are
rounding-level unless stated.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import ellipe, ellipk

from hpcontact.errors import InputError
from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.problems.slip.bodies import MATERIALS, Body, Pair, hertz_aspect, material_by_name
from hpcontact.problems.slip.crystal_pair import pair_from_params

# Double-precision sums of a few terms: 1e-13 relative leaves ~500 ulp of margin.
ROUNDING = 1e-13


def test_library_materials_are_the_cited_values() -> None:
    """Cu, Fe, Al from Dowling 2013, Table 5.2; G = E/(2(1 + nu)); names are case-insensitive."""
    assert set(MATERIALS) == {"Cu", "Fe", "Al"}
    for name, (E, nu) in {"Cu": (130e9, 0.343), "Fe": (212e9, 0.293), "Al": (70.3e9, 0.345)}.items():
        m = material_by_name(name)
        assert m.nu == nu and math.isclose(m.G, E / (2 * (1 + nu)), rel_tol=ROUNDING)
    assert material_by_name("steel") == material_by_name("fe") == material_by_name("Iron")
    assert material_by_name("rigid") is None


@pytest.mark.parametrize("bad", ["Ti", "", 3.0, None])
def test_unknown_material_names_the_field(bad: object) -> None:
    with pytest.raises(InputError) as info:
        material_by_name(bad, "material2")
    assert info.value.field == "material2"


def test_pair_blocks_are_those_of_the_equivalent_body() -> None:
    """Sum of the two bodies' xx, xy, yy, zz blocks = blocks of (G_eq, nu_eq), to rounding."""
    pair = pair_from_params({"radius": 1.0, "material": "Cu", "material2": "Al"})
    m1, m2 = (Isotropic(G=b.material.G / 1e9, nu=b.material.nu) for b in (pair.body1, pair.body2))
    eq = Pair(Body(m1, 1.0, 1.0), Body(m2)).equivalent
    for block in ("xx", "xy", "yy", "zz"):
        total = isotropic_block(m1, 9, 7, 0.3, 0.2, block) + isotropic_block(m2, 9, 7, 0.3, 0.2, block)
        single = isotropic_block(eq, 9, 7, 0.3, 0.2, block)
        assert np.max(np.abs(total - single)) <= ROUNDING * np.max(np.abs(single))


def test_dundurs_beta_and_similarity() -> None:
    """β against Dundurs' form in E and nu (Johnson 1985, eq. 5.4b with G = E/(2(1+nu)))."""

    def beta(E1: float, n1: float, E2: float, n2: float) -> float:
        num = (1 + n1) * (1 - 2 * n1) / E1 - (1 + n2) * (1 - 2 * n2) / E2
        den = (1 + n1) * (1 - n1) / E1 + (1 + n2) * (1 - n2) / E2
        return 0.5 * num / den

    cu_fe = pair_from_params({"radius": 8e-3, "radius2": 9e-3, "material": "Cu", "material2": "Fe"})
    assert math.isclose(cu_fe.dundurs_beta, beta(130e9, 0.343, 212e9, 0.293), rel_tol=ROUNDING)
    assert not cu_fe.similar and 0.03 < cu_fe.dundurs_beta < 0.035  # measured 0.0324
    assert pair_from_params({"radius": 8e-3, "material": "Al", "material2": "Al"}).similar
    # nu = 0.5 against a rigid flat: (1 - 2nu)/G = 0 on both sides
    assert pair_from_params({"radius": 1.0, "nu": 0.5}).similar
    rigid = pair_from_params({"radius": 1.0, "nu": 0.3})
    assert not rigid.similar and math.isclose(rigid.dundurs_beta, 0.5 * 0.4 / 0.7, rel_tol=ROUNDING)
    # E* = 1/Σ(1 − nu²)/E (Johnson 1985, eq. 4.22)
    assert math.isclose(cu_fe.E_star, 1 / ((1 - 0.343**2) / 130e9 + (1 - 0.293**2) / 212e9), rel_tol=ROUNDING)


def test_hertz_sphere_pair() -> None:
    """Two spheres: R = R1R2/(R1 + R2), a³ = 3PR/(4E*), d = a²/R, k_n = 2aE* (Johnson §4.2)."""
    pair = pair_from_params({"radius": 8e-3, "radius2": 9e-3, "material": "Cu", "material2": "Fe"})
    h = pair.hertz(100.0)
    R = 8e-3 * 9e-3 / 17e-3
    a = (3 * 100.0 * R / (4 * pair.E_star)) ** (1 / 3)
    assert h.aspect == 1.0 and math.isclose(h.a, a, rel_tol=ROUNDING)
    assert math.isclose(h.depth, a * a / R, rel_tol=ROUNDING)
    assert math.isclose(h.normal_stiffness, 2 * a * pair.E_star, rel_tol=ROUNDING)


@pytest.mark.parametrize("ratio", [1.5, 3.0, 20.0, 1e4])
def test_hertz_ellipse_satisfies_the_contact_condition(ratio: float) -> None:
    """The semi-axes make the Hertz pressure's displacement fit the gap A x² + B y².

    Johnson 1985 eq. 3.49: p0(1 − x²/a² − y²/b²)^½ displaces the surfaces by
    (L − M x² − N y²)/(π E*), M = π p0 b (K − E)/(e² a²), N = π p0 b ((a²/b²)E − K)/(e² a²),
    L = π p0 b K, with K, E from scipy's ellipk/ellipe of m = e² (not the code's thin-safe
    forms). Agreement to 1e-9: the direct forms lose ~log10(1/(1 − k)) digits near k = 1.
    """
    pair = Pair(Body(Isotropic(G=1.0, nu=0.3), 1.0, ratio), Body(None))
    h = pair.hertz(0.01)
    m = 1.0 - h.aspect**2
    K, E = ellipk(m), ellipe(m)
    M = math.pi * h.p0 * h.b * (K - E) / (m * h.a**2)
    N = math.pi * h.p0 * h.b * (E / (1 - m) - K) / (m * h.a**2)
    assert math.isclose(M / (math.pi * h.E_star), h.A, rel_tol=1e-9)
    assert math.isclose(N / (math.pi * h.E_star), h.B, rel_tol=1e-9)
    assert math.isclose(math.pi * h.p0 * h.b * K / (math.pi * h.E_star), h.depth, rel_tol=1e-9)  # L/(πE*)
    # the major axis lies along the flatter direction: R_b = ratio > R_a = 1, i.e. along y
    assert math.isclose(h.angle_deg, 90.0) and h.B / h.A == pytest.approx(ratio, rel=1e-12)


def test_hertz_aspect_limits() -> None:
    assert hertz_aspect(1.0) == 1.0
    assert 1.0 - 1e-8 < hertz_aspect(1.0 + 1e-9) < 1.0  # near-circles stay near-circles
    with pytest.raises(InputError):
        hertz_aspect(0.5)


def test_crossed_and_parallel_cylinders() -> None:
    """Equal crossed cylinders touch in a circle; parallel ones in a line (refused)."""
    m = Isotropic(G=1.0, nu=0.3)
    crossed = Pair(Body.cylinder(m, 2.0, 0.0), Body.cylinder(m, 2.0, 90.0))
    assert crossed.hertz(1e-3).aspect == 1.0
    unequal = Pair(Body.cylinder(m, 2.0, 0.0), Body.cylinder(m, 3.0, 90.0))
    A, B, angle = unequal.relative_curvature()
    assert math.isclose(A, 1 / 6) and math.isclose(B, 1 / 4) and angle == 0.0  # flatter along x
    with pytest.raises(InputError) as info:
        Pair(Body.cylinder(m, 2.0, 0.0), Body.cylinder(m, 3.0, 0.0)).relative_curvature()
    assert info.value.field == "radius2"


def test_pair_from_params_refuses_bad_fields() -> None:
    base = {"radius": 1.0}
    for params, field in [
        ({"radius": 0.0}, "radius"),
        ({"radius": -1.0}, "radius"),
        ({**base, "radius2": 0.0}, "radius2"),
        ({**base, "material": "unobtainium"}, "material"),
        ({**base, "material": "Cu", "E": 1.0}, "E"),
        ({**base, "E": -1.0}, "E"),
        ({**base, "E": 1e308}, "E"),  # beyond the moduli's range: named, not a ZeroDivisionError
        ({**base, "G2": 1e-308}, "G2"),
        ({**base, "nu": 0.7}, "nu"),
        ({**base, "nu2": 0.7}, "nu2"),
        ({**base, "material2": "rigid", "material": "rigid"}, "material"),
    ]:
        with pytest.raises(InputError) as info:
            pair_from_params(params)
        assert info.value.field == field, params
