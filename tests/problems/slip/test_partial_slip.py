"""Coulomb partial slip (hpcontact.problems.slip.partial_slip) against Cattaneo–Mindlin, Mindlin–Deresiewicz and Mindlin.

Grids here are moderate (32–128 cells across the contact) so the file runs in well under 90 s on
two cores; the finer-grid evidence is quoted where it matters. Measured convergence (sphere on
flat, mu = 0.3, loading to Q/(mu P) = 0.9 in 9 steps, worst over Q/(mu P) = 0.1 … 0.9;
k_t is the consistent tangent, "stick" the stick-area stiffness; errors against the closed forms
of Cattaneo–Mindlin with the analytic Hertz radius):

    n (cells across 2a)        32        64        128       256
    nu = 0     δ             2.8e-3    1.3e-4    4.5e-5    6.5e-6   (Cattaneo–Mindlin exact)
               k_t = stick   1.2e-2    4.4e-3    2.0e-3    6.0e-4
    Fe–Fe      δ             2.9e-3    8.4e-4    8.3e-4    8.2e-4   (floor: see below)
    nu = 0.293 k_t           1.2e-2    6.7e-3    3.1e-3    1.9e-3
               stick         1.1e-2    4.1e-3    9.1e-4    2.5e-3
    stick radius             ≤ 0.23 cells at every n (effective radius sqrt(stick area/π))
    wall time (2 cores)      1 s       2–3 s     11–13 s   52–127 s

The δ floor of 8e-4 at nu ≠ 0 is physics, not discretization: the solver lets slip tractions
turn (Coulomb's law in 2-D), while Cattaneo and Mindlin assume them parallel to the load
(Johnson 1985, §7.2); at nu = 0 the two coincide and the error falls to 6e-6. The stiffness
errors fluctuate with n (the stick area is a staircase of cells) and shrink on average.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from hpcontact import analytic as an
from hpcontact import fields
from hpcontact.errors import InputError
from hpcontact.fields import SLIP
from hpcontact.materials.isotropic import Isotropic
from hpcontact.problems.contact import Engine
from hpcontact.problems.slip.crystal_pair import pair_from_params
from hpcontact.problems.slip.partial_slip import PathSolver, SlipProblem, solve_slip, validate

pytestmark = pytest.mark.filterwarnings("error")

SPHERE = {"radius": 8e-3, "load": 100.0, "mu": 0.3}  # the seed's 8 mm sphere, P = 100 N


def _reference(params: dict) -> tuple[float, float, float, float]:
    """(P, mu, a, G_eq, nu_eq) of the pair: analytic Hertz radius, equivalent body."""
    pair = pair_from_params(params)
    eq = pair.equivalent
    return params["load"], params["mu"], pair.hertz(params["load"]).a, eq.G, eq.nu


# ------------------------------------------------------------------------------------------
# input checking
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "change, field",
    [
        ({"mu": -0.1}, "mu"),
        ({"q_ratio": 1.0}, "q_ratio"),
        ({"q_ratio": 1.5}, "q_ratio"),
        ({"q_ratio": -0.1}, "q_ratio"),
        ({"load": 0.0}, "load"),
        ({"load": -5.0}, "load"),
        ({"radius": 0.0}, "radius"),
        ({"radius": -8e-3}, "radius"),
        ({"radius2": -1.0}, "radius2"),
        ({"material": "Ti"}, "material"),
        ({"material2": "wood"}, "material2"),
        ({"mu": float("nan")}, "mu"),
        ({"load": "heavy"}, "load"),
        ({"n": 4}, "n"),
        ({"steps": 0}, "steps"),
        ({"control": "energy"}, "control"),
        ({"path": "zigzag"}, "path"),
        ({"quantities": "tangential"}, "quantities"),
        ({"colour": "red"}, "colour"),
        ({"control": "displacement"}, "displacement"),
    ],
)
def test_bad_input_names_the_field(change: dict, field: str) -> None:
    params = {**SPHERE, "material": "Fe", "q_ratio": 0.5, **change}
    with pytest.raises(InputError) as info:
        validate(params)
    assert info.value.field == field
    with pytest.raises(InputError):
        solve_slip(params)


def test_missing_required_fields() -> None:
    for name in ("radius", "load", "mu", "q_ratio"):
        params = {**SPHERE, "q_ratio": 0.5}
        params.pop(name, None)
        with pytest.raises(InputError) as info:
            validate(params)
        assert info.value.field == name
        declared = fields.field(name, SLIP)  # what is allowed, as fields.py declares it
        assert str(info.value) == f"{name}: required for a slip scene: {declared.message or declared.long_name}"
    with pytest.raises(InputError) as info:  # every missing field named in the one line
        validate({key: value for key, value in SPHERE.items() if key not in ("radius", "load")})
    assert info.value.field == "radius" and str(info.value).endswith("; also missing: load, q_ratio")


# ------------------------------------------------------------------------------------------
# Cattaneo–Mindlin: sphere on a flat of the same material (and nu = 0.5 on a rigid flat)
# ------------------------------------------------------------------------------------------
#: Bounds of test_sphere_on_flat_follows_cattaneo_mindlin: (δ, stick-area k_t, consistent k_t,
#: stick radius in cells). Fe–Fe: README "Partial slip" (δ within 8.4e-4, k_t within 6.7e-3,
#: stick radius within 0.22 cells) + half a unit of the quoted digit; measured 8.376e-4, 4.061e-3,
#: 6.735e-3, 0.2221 (2026-11-23). nu = 0.5 on a rigid flat (not in the README): measured 3.153e-3,
#: 7.436e-3, 1.0934e-2, 0.1776; bounds the measured values rounded up at their second digit.
#: The issue's targets were 1 % (1.5 % for the consistent k_t at nu = 0.5) and one cell.
SPHERE_ON_FLAT_BOUNDS = {"Fe-Fe": (8.45e-4, 4.1e-3, 6.75e-3, 0.225), "nu0.5-rigid": (3.2e-3, 7.5e-3, 1.1e-2, 0.18)}


@pytest.mark.parametrize(
    "bodies, case",
    [({"material": "Fe", "material2": "Fe"}, "Fe-Fe"), ({"E": 1e9, "nu": 0.5}, "nu0.5-rigid")],
    ids=["Fe-Fe", "nu0.5-rigid"],
)
def test_sphere_on_flat_follows_cattaneo_mindlin(bodies: dict, case: str) -> None:
    """δ(Q) and k_t against Cattaneo–Mindlin for Q/(mu P) ≤ 0.9, stick radius within a cell.

    Issue targets: 1 % and one cell; asserted: the measured errors (``SPHERE_ON_FLAT_BOUNDS``).
    Measured at n = 64, worst over Q/(mu P) = 0.1 … 0.9:
    Fe–Fe: δ 8.4e-4, stick-area k_t 4.1e-3, consistent k_t 6.7e-3, stick radius 0.22 cells;
    nu = 0.5: δ 3.2e-3, stick-area k_t 7.4e-3, consistent k_t 1.09e-2, 0.18 cells.
    The stick-area stiffness is Mindlin–Deresiewicz's own definition (slip tractions frozen
    along the load) and meets 1 % in both cases; the consistent tangent also restrains the
    transverse slip that nu ≠ 0 drives in the slip annulus (a physical stiffening, +0.9 % at
    nu = 0.5, Q = 0.9 mu P on the n = 128 grid, absent at nu = 0), hence 1.5 % at nu = 0.5.
    The normal pressure is the discrete (Polonsky–Keer) Hertz solution of the same grid; the
    references use the analytic Hertz radius.
    """
    params = {**SPHERE, **bodies, "q_ratio": 0.9, "steps": 9, "n": 64, "history": True}
    record = solve_slip(params)
    P, mu, a, G, nu = _reference(params)
    h = record["history"]
    d_tol, stick_tol, consistent_tol, radius_cells = SPHERE_ON_FLAT_BOUNDS[case]
    assert "similar=True" in record["plan"]["pair"] and not any("(pair)" in k for k in record["plan"]["kernels"])
    for Q, delta, k, k_stick, area in zip(
        h["tangential_force"][1:],
        h["tangential_displacement"][1:],
        h["tangential_stiffness"][1:],
        h["stick_area_stiffness"][1:],
        h["stick_area"][1:],
    ):
        k_ref = an.cattaneo_mindlin_stiffness(Q, P, mu, a, G, nu)
        assert abs(delta / an.cattaneo_mindlin_displacement(Q, P, mu, a, G, nu) - 1) < d_tol
        assert abs(k_stick / k_ref - 1) < stick_tol
        assert abs(k / k_ref - 1) < consistent_tol
        assert k >= k_stick * (1 - 1e-9)  # restraining transverse slip only stiffens
        c = an.stick_radius(Q, P, mu, a)
        assert abs(math.sqrt(area / math.pi) - c) < radius_cells * record["dx"]
    assert record["force_ratio"] == pytest.approx(0.9, rel=1e-6)  # force control reached its target
    assert abs(record["stick_area_stiffness"] / record["mindlin_stiffness"] - 1) < stick_tol


def test_grid_convergence_at_nu_zero() -> None:
    """At nu = 0 Cattaneo–Mindlin is exact: the README's k_t errors "1.2e-2, 4.4e-3, 2.0e-3,
    6.0e-4 at n = 32, 64, 128, 256" and the fall of δ's error.

    Measured, worst over the load steps: 9 steps to Q/(mu P) = 0.9 (the README's protocol):
    k_t 1.153e-2, 4.435e-3 and δ 2.76e-3, 1.34e-4 at n = 32, 64; 3 steps (0.3, 0.6, 0.9):
    k_t 6.09e-3, 3.98e-3, 1.96e-3, 5.86e-4 and δ 3.9e-4, 1.34e-4, 6.54e-6, 1.18e-6 at n = 32,
    64, 128, 256. Asserted: 1.2e-2 and 4.4e-3 (9 steps) and 2.0e-3 (3 steps, n = 128: the 9-step
    run there costs 3×; the docstring of partial_slip measured 2.0e-3 with 9 steps too) to their
    digits; δ below 7e-6 at n = 128 and falling ≥ 10× from n = 32 (measured 60×). n = 256 (a
    minute or more) is not run: its 6.0e-4 (9 steps; 5.9e-4 with 3) is a measurement only.
    Neighbouring grids need not be ordered (the stick area's staircase fluctuates); these are."""
    params = {**SPHERE, "E": 200e9, "nu": 0.0, "E2": 200e9, "nu2": 0.0, "q_ratio": 0.9, "history": True}
    P, mu, a, G, nu = _reference(params)
    nine = []
    for n in (32, 64):
        h = solve_slip({**params, "steps": 9, "n": n})["history"]
        nine.append(
            max(
                abs(k / an.cattaneo_mindlin_stiffness(Q, P, mu, a, G, nu) - 1)
                for Q, k in zip(h["tangential_force"][1:], h["tangential_stiffness"][1:])
            )
        )
    assert 1.15e-2 <= nine[0] < 1.25e-2 and 4.35e-3 <= nine[1] < 4.45e-3
    worst = []
    for n in (32, 128):
        h = solve_slip({**params, "steps": 3, "n": n})["history"]
        e_d = max(
            abs(d / an.cattaneo_mindlin_displacement(Q, P, mu, a, G, nu) - 1)
            for Q, d in zip(h["tangential_force"][1:], h["tangential_displacement"][1:])
        )
        e_k = max(
            abs(k / an.cattaneo_mindlin_stiffness(Q, P, mu, a, G, nu) - 1)
            for Q, k in zip(h["tangential_force"][1:], h["tangential_stiffness"][1:])
        )
        worst.append((e_d, e_k))
    (d32, k32), (d128, k128) = worst
    assert d128 < d32 / 10 and k128 < k32 / 2
    assert d128 < 7e-6 and k128 < 2.05e-3


def test_loading_unloading_reloading_loop() -> None:
    """The full Mindlin–Deresiewicz loop (+Q*, −Q*, +Q*) within 2 % of its closed form.

    Issue target 2 % (of the loop amplitude δ(Q*) for δ; relative for k_t). Measured at n = 48,
    4 steps per half branch, Q* = 0.8 mu P: δ ≤ 7.22e-4 of the amplitude, k_t ≤ 6.82e-3, and
    the loop closes to 2.1e-5 of the amplitude. Bounds: the README's "7.2e-4 (δ) and 6.8e-3
    (k_t)" + half a unit of their last digit; closure 3e-5 (it was 1e-3).
    """
    params = {
        **SPHERE,
        "material": "Fe",
        "material2": "Fe",
        "q_ratio": 0.8,
        "path": "loop",
        "steps": 4,
        "n": 48,
        "history": True,
    }
    record = solve_slip(params)
    P, mu, a, G, nu = _reference(params)
    q_star = 0.8 * mu * P
    amplitude = an.cattaneo_mindlin_displacement(q_star, P, mu, a, G, nu)
    h = record["history"]
    assert h["branch"].count("unloading") == 8 and h["branch"].count("reloading") == 8
    for branch, Q, delta, k in zip(
        h["branch"], h["tangential_force"], h["tangential_displacement"], h["tangential_stiffness"]
    ):
        if branch in ("initial", "loading"):
            d_ref = an.cattaneo_mindlin_displacement(Q, P, mu, a, G, nu)
            k_ref = an.cattaneo_mindlin_stiffness(Q, P, mu, a, G, nu)
        elif branch == "unloading":
            Q = min(max(Q, -q_star), q_star)  # the Newton target is met to 1e-7 mu P
            d_ref = an.mindlin_deresiewicz_unloading_displacement(Q, q_star, P, mu, a, G, nu)
            k_ref = an.mindlin_deresiewicz_unloading_stiffness(Q, q_star, P, mu, a, G, nu)
        else:
            Q = min(max(Q, -q_star), q_star)
            d_ref = an.mindlin_deresiewicz_reloading_displacement(Q, q_star, P, mu, a, G, nu)
            k_ref = an.mindlin_deresiewicz_unloading_stiffness(-Q, q_star, P, mu, a, G, nu)
        assert abs(delta - d_ref) < 7.25e-4 * amplitude, (branch, Q)
        assert abs(k / k_ref - 1) < 6.85e-3, (branch, Q)
    # the loop closes: back at +Q* on the loading curve
    first_peak = h["tangential_displacement"][4]
    assert abs(record["tangential_displacement"] - first_peak) < 3e-5 * amplitude


# ------------------------------------------------------------------------------------------
# the tangent: stick-area stiffness, checked against the solver's own increments
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("coupled", [False, True])
def test_tangent_matches_the_solvers_own_increments(coupled: bool) -> None:
    """The consistent tensor is the derivative of the solver's response, and along the load it
    is, to first order, the no-slip stiffness of the stick area (the issue's check).

    Sphere of Fe on a rigid flat (beta = 0.29), Q/(mu P) = 0.5, n = 48, increments of 1e-5 δ.
    Measured: along the load |FD/K − 1| = 5e-8 (decoupled) and 2.0e-4 (coupled: the tangent
    leaves out that a slip cell's limit mu p follows the pressure increment, a non-symmetric
    term of order beta mu), across it 4e-4 and 1.1e-3; the stick-area stiffness is below the
    consistent one by 9e-4 and 1.5e-3 (the restrained transverse slip). Bounds: 1e-5 and 1e-3
    along, 1e-2 across, 1e-2 for the stick-area check.
    """
    params = {**SPHERE, "material": "Fe", "q_ratio": 0.5, "n": 48, "tol": 1e-10}
    problem = SlipProblem(validate(params))
    assert not problem.pair.similar
    solver = PathSolver(problem, coupled)
    state = solver.initial
    limit = problem.scene.mu * problem.P
    for q in (0.25, 0.5):
        state = solver.to_force(state, np.array([q * limit, 0.0]))
    K = solver.tangent(state)
    eps = 1e-5 * state.delta[0]
    along = solver.equilibrium(state, state.delta + np.array([eps, 0.0]))
    across = solver.equilibrium(state, state.delta + np.array([0.0, eps]))
    assert np.array_equal(along.stick, state.stick)
    assert abs((along.force[0] - state.force[0]) / eps / K[0, 0] - 1) < (1e-3 if coupled else 1e-5)
    assert abs((across.force[1] - state.force[1]) / eps / K[1, 1] - 1) < 1e-2
    assert abs(K[0, 1]) < 1e-8 * K[0, 0] and abs(K[1, 0]) < 1e-8 * K[0, 0]
    K_stick = solver.stick_tangent(state)
    assert 0 <= 1 - K_stick[0, 0] / K[0, 0] < 1e-2
    assert K[1, 1] > 1.1 * K_stick[1, 1]  # across the load the slip tractions turn


def test_coupled_operator_matches_the_engine_for_a_rigid_partner() -> None:
    """Against a rigid flat the pair's 3-component operator is body 1's own (engine kernels)."""
    problem = SlipProblem(validate({**SPHERE, "material": "Cu", "q_ratio": 0.5, "n": 16}))
    g = problem.grid
    engine = Engine(
        Isotropic(G=problem.pair.body1.material.G / problem.G_ref, nu=problem.pair.body1.material.nu),
        g,
        ("xx", "xy", "yx", "yy", "zz", "xz", "yz", "zx", "zy"),
    )
    rng = np.random.default_rng(1)
    t = rng.standard_normal((3, g.nx, g.ny))
    mine, theirs = problem.full_operator.apply(t), engine.operator("xyz").apply(t)
    assert np.max(np.abs(mine - theirs)) < 1e-12 * np.max(np.abs(theirs))


def test_dissimilar_pair_reports_coupled_and_decoupled() -> None:
    """Cu–Fe (β = 0.032): both answers, their difference, coupling kernels only here.

    Bounds from analysis (they were 3 % and 1 %, 80× and 34× the effects). The pair's relative
    surface compliance in Fourier space (Johnson 1985 §3.2; ``green_isotropic`` of
    tests/independent_reference.py summed over the two bodies) has tangential part
    Σ(I − νᵢ m mᵀ)/Gᵢ, normal part N = Σ(1 − νᵢ)/Gᵢ and coupling i m [(1 − 2ν₁)/G₁ −
    (1 − 2ν₂)/G₂]/2 = i β N m: the coupling meets only the component of t along m, on which
    the tangential part is N, so |⟨t, B p⟩|² ≤ β² ⟨t, A t⟩⟨p, D p⟩ for every t, p (equality in
    the worst direction: the strengthened Cauchy–Schwarz constant is |β|). For one restriction
    (the same stick, slip and contact cells) the coupled tangent is the decoupled one with the
    normal tractions condensed in: the Schur complement S = A − B D⁻¹ Bᵀ of the compliance
    satisfies (1 − β²) A ≤ S ≤ A, so 1 ≤ k_coupled/k_decoupled ≤ 1/(1 − β²), and along a load
    path whose tangents obey it δ = ∫ dQ/k gives −β² ≤ δ_coupled/δ_decoupled − 1 ≤ 0. Premise
    checked here: the two paths end on the same stick cells (coupling_effect_stick_area = 0).
    The constant |β| is that of the continuum operator; the grid's collocation operator (its
    symbol the aliased sum of the continuum one weighted by the cells' transforms) is not
    proved to share it, but the dense reference of test_sphere_pairs.py (same cells, no FFT)
    shows the stuck contact's effect at 0.13 β². Measured at n = 48, Q/(mu P) = 0.9: k_t
    coupled/decoupled − 1 = +3.65e-4, stick-area stiffness +3.34e-4, δ −2.93e-4, against
    β²/(1 − β²) = 1.05e-3 and −β² = −1.05e-3 (the effect is O(β²), not O(β mu) = 0.01 as this
    test used to allow).
    """
    params = {**SPHERE, "radius2": 9e-3, "material": "Cu", "material2": "Fe", "q_ratio": 0.9, "steps": 3, "n": 48}
    record = solve_slip(params)
    for key in ("tangential_force", "tangential_displacement", "tangential_stiffness", "stick_area"):
        assert f"decoupled_{key}" in record
    beta = record["dundurs_beta"]
    assert beta == pytest.approx(0.0324, abs=5e-4)
    assert record["coupling_effect_stick_area"] == 0.0  # the same stick cells: the bound's premise
    stiffening = beta**2 / (1.0 - beta**2)
    assert 0.0 < record["coupling_effect_stiffness"] <= stiffening
    assert 0.0 < record["stick_area_stiffness"] / record["decoupled_stick_area_stiffness"] - 1.0 <= stiffening
    assert -(beta**2) <= record["coupling_effect_displacement"] < 0.0
    assert any("(pair)" in k for k in record["plan"]["kernels"])
    assert any("Panagiotopoulos" in item for item in record["plan"]["pair"])
    # both agree with Cattaneo–Mindlin for the equivalent body within the 1 % of the issue
    assert abs(record["decoupled_tangential_displacement"] / record["mindlin_displacement"] - 1) < 0.01


# ------------------------------------------------------------------------------------------
# elliptical contact
# ------------------------------------------------------------------------------------------
def test_ellipse_no_slip_limit_is_mindlins_ellipse() -> None:
    """As Q → 0, k_t along both axes is Mindlin's bonded ellipse on the Hertz ellipse, 0.1 %.

    Ellipsoid R_a = 8 mm, R_b = 24 mm on an Fe flat: b/a = 0.483, major axis along the 24 mm
    direction (y, contact_angle 90°). Measured errors of K_a, K_b: n = 64: 1.7e-3, 7.4e-4;
    n = 128: 5.4e-4, 3.2e-4; n = 256: 2.5e-4, 1.3e-4; n = 512: 2.1e-4, 1.5e-4. Issue target 0.1 %;
    asserted: the README's "within 5.4e-4 and 3.2e-4 at n = 128" (measured 5.35e-4, 3.22e-4)
    + half a unit of their last digit.
    """
    base = {**SPHERE, "radius_b": 24e-3, "material": "Fe", "material2": "Fe", "q_ratio": 0.0, "n": 128, "tensor": True}
    pair = pair_from_params(base)
    h = pair.hertz(100.0)
    K_a, K_b = an.mindlin_ellipse_stiffness(h.a, h.b, pair.equivalent.G, pair.equivalent.nu)
    record = solve_slip(base)
    assert record["contact_angle_deg"] == pytest.approx(90.0)
    # scene frame: the major axis a is along y
    assert abs(record["tangential_stiffness_yy"] / K_a - 1) < 5.45e-4
    assert abs(record["tangential_stiffness_xx"] / K_b - 1) < 3.25e-4
    assert abs(record["tangential_stiffness_xy"]) < 1e-8 * K_a
    # load along x: n·K·n in the contact frame (turned 90°) against (R K Rᵀ)_xx in the scene frame,
    # the same number through two rotations: equal to rounding (measured 2.4e-16 relative)
    assert record["tangential_stiffness"] == pytest.approx(record["tangential_stiffness_xx"], rel=1e-14)
    assert record["stick_area"] == record["contact_area"]


def test_ellipse_stiffness_falls_along_both_axes() -> None:
    """k along the major and the minor axis fall with Q/(mu P) from their Mindlin values."""
    base = {
        **SPHERE,
        "radius_b": 24e-3,
        "material": "Al",
        "material2": "Al",
        "q_ratio": 0.8,
        "steps": 4,
        "n": 48,
        "history": True,
    }
    ks = {}
    for angle in (90.0, 0.0):  # along the major axis, then the minor one
        h = solve_slip({**base, "angle": angle})["history"]
        ks[angle] = np.array(h["tangential_stiffness"])
        assert np.all(np.diff(ks[angle]) < 0)
    assert np.all(ks[0.0] > ks[90.0])  # stiffer across the ellipse than along it (nu > 0)


def test_load_direction_on_a_circle() -> None:
    """A circular contact is isotropic: loading at 30° gives the 0° answer (to the staircase)."""
    base = {**SPHERE, "material": "Al", "material2": "Al", "q_ratio": 0.6, "steps": 2, "n": 48, "tensor": True}
    r0, r30 = solve_slip(base), solve_slip({**base, "angle": 30.0})
    assert r30["tangential_force"] == pytest.approx(r0["tangential_force"], rel=1e-6)
    assert r30["tangential_displacement"] == pytest.approx(r0["tangential_displacement"], rel=3e-3)
    assert r30["tangential_stiffness"] == pytest.approx(r0["tangential_stiffness"], rel=1e-2)


# ------------------------------------------------------------------------------------------
# control modes and limits
# ------------------------------------------------------------------------------------------
def test_displacement_control_reaches_the_force_controlled_state() -> None:
    """Driving δ to the force-controlled δ(0.6 mu P) gives back Q = 0.6 mu P (1e-3)."""
    base = {**SPHERE, "material": "Fe", "material2": "Fe", "n": 48, "steps": 3}
    forced = solve_slip({**base, "q_ratio": 0.6})
    driven = solve_slip(
        {**base, "q_ratio": 0.0, "control": "displacement", "displacement": forced["tangential_displacement"]}
    )
    assert driven["tangential_force"] == pytest.approx(forced["tangential_force"], rel=1e-3)
    assert driven["tangential_stiffness"] == pytest.approx(forced["tangential_stiffness"], rel=1e-2)


def test_frictionless_and_unloaded_limits() -> None:
    base = {**SPHERE, "material": "Al", "material2": "Al", "n": 32}
    r = solve_slip({**base, "mu": 0.0, "q_ratio": 0.5})
    assert r["tangential_force"] == 0.0 and r["tangential_stiffness"] == 0.0 and r["stick_area"] == 0.0
    r = solve_slip({**base, "q_ratio": 0.0})
    assert r["tangential_force"] == 0.0 and r["stiffness_ratio"] == 1.0
    assert r["tangential_stiffness"] == r["no_slip_stiffness"] > 0.0


def test_record_keys_and_units() -> None:
    """The keys of docs/design.md §4.1 for slip, in SI for library materials, all finite."""
    t0 = time.perf_counter()
    r = solve_slip(
        {**SPHERE, "radius2": 9e-3, "material": "Fe", "material2": "Fe", "q_ratio": 0.5, "n": 32, "steps": 2}
    )
    for key in (
        "tangential_force",
        "tangential_displacement",
        "tangential_stiffness",
        "stick_area",
        "contact_area",
        "load",
        "iterations",
        "residual",
        "wall_time_s",
        "nx",
        "ny",
        "dx",
        "dy",
        "plan",
    ):
        assert key in r
    assert r["load"] == 100.0 and r["tangential_force"] == pytest.approx(0.5 * 0.3 * 100.0, rel=1e-6)
    assert 1e-4 < r["hertz_a"] < 3e-4 and 1e-7 < r["tangential_displacement"] < 1e-5  # metres
    assert r["wall_time_s"] <= time.perf_counter() - t0
    assert all(math.isfinite(v) for v in r.values() if isinstance(v, float))


def test_record_without_relative_stick_area_when_the_decoupled_contact_slides() -> None:
    """Displacement control past the decoupled (Goodman) sliding limit while the coupled contact
    still sticks (steel on E = 120 GPa, β = 0.105, mu = 0.1, 0.6 µm with the load, one
    proportional step: measured stick area 3.6e-9 m² coupled, 0 decoupled): the relative change
    of a zero area is undefined, so the record leaves coupling_effect_stick_area out (it raised
    FloatingPointError on an infinite value before)."""
    r = solve_slip(
        {
            "radius": 8e-3,
            "load": 100.0,
            "mu": 0.1,
            "q_ratio": 0.5,
            "n": 16,
            "steps": 1,
            "E": 200e9,
            "nu": 0.3,
            "E2": 120e9,
            "nu2": 0.25,
            "control": "displacement",
            "displacement": 6e-7,
            "path": "proportional",
        }
    )
    assert r["stick_area"] > 0.0 and r["decoupled_stick_area"] == 0.0
    assert "coupling_effect_stick_area" not in r
