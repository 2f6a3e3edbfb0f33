"""End-to-end scenes against closed forms (docs/design.md §2.4) and independent checks (Li 2017).

These tests assert the figures README "What the engine gets right, measured" quotes, at the
precision it quotes them (docs/claims.md maps each figure to its test). Where the issue's
acceptance target is looser than what the code measures, the bound is the measured figure plus
half a unit of its last quoted digit (the scenes are deterministic: CG at a fixed tolerance, so
the errors move only by rounding, ~1e-13, between machines and FFTW plans); the targets are named
beside them. Measured 2026-11-23 on the 2-core development machine.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from hpcontact import analytic
from hpcontact.problems.contact import solve
from hpcontact.quantities import directional_stiffness
from hpcontact.scene import Scene

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import independent_reference as ref  # noqa: E402

pytestmark = pytest.mark.filterwarnings("error")


def tensor(record: dict) -> np.ndarray:
    return np.array([[record["K_xx"], record["K_xy"]], [record["K_yx"], record["K_yy"]]])


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_circle_converges_to_closed_forms(nu: float) -> None:
    """K_xx → 8Ga/(2−nu), K_zz → 2aE*; the README's errors 1.9e-3 (n = 64), 9.3e-4 (256),
    2.0e-4 (1024) and the error falls with n.

    Measured (largest of K_xx, K_zz): nu = 0: 1.878e-3, 9.331e-4, 1.986e-4 (K_xx = K_zz at
    nu = 0); nu = 0.3: K_zz the same, K_xx 1.806e-3, 9.148e-4, 1.940e-4; nu = 0.5: K_xx 1.617e-3,
    8.669e-4, 1.821e-4. Bounds: the quoted figures + half a unit of their last digit (the issue's
    target was 5e-3 at n = 256). The staircase area of a rasterized circle fluctuates with n
    (Gauss circle problem), so neighbouring grids need not be ordered; grids a factor 4 apart are.
    """
    quoted = {64: 1.95e-3, 256: 9.35e-4, 1024: 2.05e-4}  # README: 1.9e-3, 9.3e-4, 2.0e-4
    errors = []
    for n in (64, 256, 1024):
        r = solve(Scene.from_params({"shape": "circle", "nu": nu, "n": n, "quantities": "tangential,normal"}))
        e_xx = abs(r["K_xx"] / analytic.circle_tangential_stiffness(1.0, 1.0, nu) - 1.0)
        e_zz = abs(r["K_zz"] / analytic.circle_normal_stiffness(1.0, 1.0, nu) - 1.0)
        errors.append((e_xx, e_zz))
        assert e_xx < quoted[n] and e_zz < quoted[n]
        # circle symmetry: the plan derives K_yy from K_xx (that shortcut is checked against a
        # real y solve in test_conventions), and K_xy vanishes by mirror symmetry
        assert any("x <-> y" in d for d in r["plan"]["derived"])
        assert abs(r["K_xy"]) < 1e-6 * r["K_xx"]  # CG tol 1e-8 on the residual bounds it
    for (a, b), (c, d) in zip(errors, errors[1:]):
        assert c < a and d < b


@pytest.mark.parametrize("aspect", [0.5, 0.1])
@pytest.mark.parametrize("nu", [0.3, 0.5])
def test_ellipse_ratio_matches_mindlin(aspect: float, nu: float) -> None:
    """K_a/K_b against Mindlin's no-slip ellipse at n = 512: measured 3.56e-6, 8.52e-6 (b/a = 0.5,
    nu = 0.3, 0.5), 8.83e-6, 2.97e-5 (b/a = 0.1); bound 3.05e-5, README's "≤ 3.0e-5" (the issue's
    target was 5e-4). Asymmetry |K_xy − K_yx|/K at CG tol 1e-8 (a CG truncation effect, fixed
    by the tolerance and the iteration count): measured 7.4e-11, 1.12e-9, 1.2e-10, 3.7e-10;
    bound 1.15e-9, README's "≤ 1.1e-9"."""
    r = solve(Scene.from_params({"shape": "ellipse", "aspect": aspect, "nu": nu, "n": 512}))
    reference = analytic.mindlin_ellipse_stiffness_ratio(aspect, nu)
    assert abs(r["K_a_over_K_b"] / reference - 1.0) < 3.05e-5
    assert r["asymmetry"] < 1.15e-9


@pytest.mark.parametrize("sides", range(3, 9))
def test_regular_polygons_are_isotropic(sides: int) -> None:
    """A shape with a 3-fold or higher axis has an isotropic tensor (Li 2017 §3.1).

    Target 0.05 % at n = 512 (Li reports 0.5 % noise); measured 1.79e-4, 1.41e-4, 1.17e-4,
    1.67e-4, 7.3e-5 (sides 3–7) and 6.8e-10 for the octagon (its mask is symmetric under x <-> y,
    so the y-solve is derived); bound 1.85e-4, README's "≤ 1.8e-4". Asymmetry measured
    1.9e-10 … 9.0e-10 (sides 3–7); bound 1.15e-9 as for the ellipses.
    """
    r = solve(Scene.from_params({"shape": "polygon", "sides": sides, "nu": 0.5, "n": 512}))
    spread = (r["K_max"] - r["K_min"]) / (0.5 * (r["K_max"] + r["K_min"]))
    assert spread < 1.85e-4
    if not any("x <-> y" in d for d in r["plan"]["derived"]):  # a mirrored tensor is symmetric by construction
        assert r["asymmetry"] < 1.15e-9


def test_tensor_transformation_matches_rotated_shape() -> None:
    """K_nn(θ) = nᵀKn from one tensor agrees with Li's rotated-shape solve (shape turned by −θ).

    Both carry the staircase error of different rasterizations; measured differences at
    n = 256: 3.16e-4 (30°), 2.33e-4 (45°), 5.69e-5 (60°); bound 3.25e-4, README's "≤ 3.2e-4"
    (a deterministic rasterization difference; it was 1e-3 before the README quoted it).
    """
    base = {"shape": "ellipse", "aspect": 0.5, "nu": 0.5, "n": 256}
    K = tensor(solve(Scene.from_params(base)))
    for theta in (30.0, 45.0, 60.0):
        turned = solve(Scene.from_params({**base, "shape_angle": -theta}))
        assert abs(directional_stiffness(K, theta) / turned["K_xx"] - 1.0) < 3.25e-4


def test_json_plan_lists_only_what_ran() -> None:
    """An isotropic tangential scene builds no normal or coupling kernel (docs/design.md §1)."""
    r = solve(Scene.from_params({"shape": "ellipse", "aspect": 0.3, "nu": 0.3, "n": 32}))
    assert set(r["plan"]["kernels"]) == {"xx", "xy", "yx", "yy"}
    assert r["plan"]["solves"] == ["tangential_x[xy]", "tangential_y[xy]"]
    assert "K_zz" not in r
    r0 = solve(
        Scene.from_params({"shape": "ellipse", "aspect": 0.3, "nu": 0.0, "n": 32, "quantities": "tangential,normal"})
    )
    assert r0["plan"]["kernels"] == ["xx"]
    assert r0["plan"]["solves"] == ["tangential_x[x]", "tangential_y[y]"]
    assert r0["K_zz"] == r0["K_xx"] and r0["K_xy"] == 0.0


def test_thin_rectangle_converges_towards_li_2017() -> None:
    """Rectangle b/a = 1e-8, nu = 0.5: K_a/K_b converges over three grids (n, n_across).

    Measured: 0.5394107 (64×8), 0.5394650 (128×16), 0.5394927 (256×32), 0.5395067 (512×64):
    differences halve with each refinement (first order, the edge singularity of the traction),
    so the Richardson limit is ≈ 0.53952. Li 2017 (§3.2) reports 0.5390 from a grid it does not
    state; our limit is 9.6e-4 above it.

    Independent references: (1) the 64×8 grid's discrete problem solved by
    ``dense_bonded_stiffness`` of tests/independent_reference.py (closed-form cell integrals
    written there, one dense LU; no FFT, no CG; measured 2026-11-29: 0.5394106748591334 against
    the engine's 0.5394106748591326), within the sum of the two computations' round-off and
    truncation bounds κ (tol² + 3 m u) per stiffness (CG's energy error ≤ tol² κ; LU with no
    growth, Higham 2002 Thm 9.4; κ LAPACK's 1-norm estimate, m = 1024 unknowns); (2) Li's
    0.5390 within 0.1 % (the README's words). The 128×16 and 256×32 values (0.5394650,
    0.5394927, ±2e-7: CG at tol 1e-8 moves a ratio by ~1e-10) are REGRESSION GUARDS of the
    engine's own output (the dense check at 128×16 costs 30 s; it gave 0.5394650458331559,
    2026-11-29), as is the limit 0.53952 (±5e-6) the README quotes; what guards the physics
    there is (1), the monotone first-order convergence asserted here, and the strip
    discretization's agreement with the 2-D grids
    (tests/discretizations/test_strip_cells.py::test_rectangle_against_an_in_test_coverage_extrapolation).
    """
    ratios = []
    for n, n_across in ((64, 8), (128, 16), (256, 32)):
        r = solve(Scene.from_params({"shape": "rectangle", "aspect": 1e-8, "nu": 0.5, "n": n, "n_across": n_across}))
        assert r["K_yy"] > r["K_xx"] > 0.0
        ratios.append(r["K_a_over_K_b"])
        if n == 64:  # the engine's grid covers the rectangle exactly: 64 × 8 cells of 2/64 × 2e-8/8
            constants = ref.pair_constants(3.0, 0.5)  # G = 1 (E = 2G(1 + nu))
            dense = ref.dense_bonded_stiffness(np.ones((64, 8), bool), 2.0 / 64, 2e-8 / 8, **constants, coupled=False)
            K = dense["tangential"]
            bound = dense["condition"] * (1e-8**2 + 3 * dense["unknowns"] * np.finfo(np.float64).eps / 2)
            assert abs(r["K_xx"] / K[0, 0] - 1.0) <= bound and abs(r["K_yy"] / K[1, 1] - 1.0) <= bound
            assert abs(r["K_a_over_K_b"] / (K[0, 0] / K[1, 1]) - 1.0) <= 2.0 * bound
    np.testing.assert_allclose(ratios, [0.5394107, 0.5394650, 0.5394927], rtol=0.0, atol=2e-7)  # regression guard
    d1, d2 = ratios[1] - ratios[0], ratios[2] - ratios[1]
    assert d1 > d2 > 0.0  # monotone, converging
    order = np.log2(d1 / d2)
    assert 0.7 < order < 1.5  # first order, as the measured sequence shows
    limit = ratios[2] + d2 / (2.0**order - 1.0)
    assert abs(limit - 0.53952) < 5e-6
    assert 0.0 < limit / 0.5390 - 1.0 < 1e-3


def test_crystal_path_reproduces_closed_form_at_isotropy() -> None:
    """A = 1 + 1e-12 through the Barnett–Lothe kernels equals the closed-form coupled solve.

    Both run the same coupled 3 × 3 bonded punch; they differ in every kernel (anisotropic
    edge-integral cells vs Boussinesq–Cerruti closed forms). Measured differences relative to
    K_zz: K_zz 9.5e-13, K_yy 3.9e-13, K_xx 3.4e-13, K_yz 1.3e-13, the others ≤ 7e-15. Part of
    it is physics, not error: A − 1 = 1e-12 moves K by dK/dA × 1e-12 (at A = 1 − 1e-12 the
    differences are −1.6e-13, −5.3e-13, −3.2e-13, −1.7e-13; the mean of both sides is within
    3.9e-13 of the closed form). Bound 1.5e-12 (the measured 9.5e-13 and 1.6× for CG at tol
    1e-12 on two different operators); the issue's stiffness target was 1e-10.
    """
    base = {"shape": "ellipse", "aspect": 0.5, "nu": 0.3, "n": 48, "tol": 1e-12}
    closed = solve(Scene.from_params({**base, "quantities": "coupled"}))
    crystal = solve(Scene.from_params({**base, "quantities": "coupled", "anisotropy": 1.0 + 1e-12, "miller": "1 1 0"}))
    assert crystal["plan"]["kernel_source"].startswith("anisotropic")
    assert closed["plan"]["kernel_source"].startswith("isotropic")
    scale = closed["K_zz"]
    for key in ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz", "K_xz", "K_zx", "K_yz", "K_zy"):
        assert abs(crystal[key] - closed[key]) < 1.5e-12 * scale, key


@pytest.mark.parametrize("miller", ["0 0 1", "1 1 1"])
@pytest.mark.parametrize("anisotropy", [0.5, 2.0, 5.0])
def test_sphere_on_cube_and_octahedral_faces_gives_circular_contact(miller: str, anisotropy: float) -> None:
    """On (001) (4-fold) and (111) (3-fold) the contact is circular: the second-rank pressure
    moment tensor is isotropic by symmetry. The square grid breaks 3-fold symmetry at the cell
    level: measured |b/a − 1| at n = 96 on (111): 1.07e-6, 1.34e-6, 7.10e-6 (A = 0.5, 2, 5); on
    (001) ≤ 1.8e-14 (the 4-fold axis is the grid's). Bound 7.5e-6, README's "within 7.1e-6"
    (b/a from pressure moments at CG tol 1e-8: deterministic to ~1e-9)."""
    r = solve(
        Scene.from_params(
            {
                "quantities": "indentation",
                "radius": 1.0,
                "depth": 1e-4,
                "n": 96,
                "anisotropy": anisotropy,
                "nu": 0.3,
                "miller": miller,
            }
        )
    )
    assert abs(r["ellipse_b_over_a"] - 1.0) < (7.5e-6 if miller == "1 1 1" else 1e-12)


def test_sphere_on_110_converges_to_willis_ellipse() -> None:
    """A = 3, nu = 0.3, normal [110]: elliptical contact; b/a and load converge to Willis' (1966)
    semi-analytical solution, computed independently of hpcontact: ``willis_contact`` of
    tests/independent_reference.py (its own C_ijkl, rotation to normal [110] with x = [1̄10], Stroh's
    H_zz, a Gauss rule in φ; no grid, no cells, no contact solver). Load and b/a do not depend on
    the in-plane axes, so the engine's frame for miller 1 1 0 need not be the reference's. The
    reference agrees with the engine's own Willis (``analytic.willis_sphere_contact`` on the
    Barnett–Lothe H_zz) to 2.2e-16, and its φ rule is converged (16 × 48 nodes against 8 × 32:
    2.2e-16; tests/problems/test_crystal_indentation.py checks it over the README's table).

    Measured (d/R = 1e-4, so the sphere is a paraboloid to 1e-4·1e-4): load error 5.08e-4,
    7.53e-5, 2.25e-5 at n = 32, 64, 128 (observed orders 2.75, 1.74); b/a error 8.0e-5, 5.9e-5,
    1.35e-5. Bounds: the README's 5.1e-4, 7.5e-5, 2.3e-5 + half a unit of their last digit;
    b/a 1.4e-5 at n = 128 (it was 5e-5).
    """
    params = {
        "quantities": "indentation",
        "radius": 1.0,
        "depth": 1e-4,
        "anisotropy": 3.0,
        "nu": 0.3,
        "miller": "1 1 0",
    }
    # Lengths in units of R, stresses in G = (C11 − C12)/2 = 1: the engine's units for (nu, A).
    willis = ref.willis_contact(ref.rotate(ref.cubic_from_nu_A(0.3, 3.0), ref.orientation_frame(0.0)), 1.0, 1e-4)
    assert willis["b_over_a"] < 0.95  # really elliptical
    load_errors = []
    for n in (32, 64, 128):
        r = solve(Scene.from_params({**params, "n": n}))
        load_errors.append(abs(r["load"] / willis["load"] - 1.0))
        if n == 128:
            assert abs(r["ellipse_b_over_a"] - willis["b_over_a"]) < 1.4e-5
    assert load_errors[0] > load_errors[1] > load_errors[2]
    assert load_errors[0] < 5.15e-4 and load_errors[1] < 7.55e-5 and load_errors[2] < 2.35e-5
    order = np.log2(load_errors[1] / load_errors[2])
    assert 1.5 < order < 3.0  # "order ≈ 2"
