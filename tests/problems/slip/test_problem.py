"""The discretized pair of a partial-slip scene (hpcontact.problems.slip.problem): the fields a
scene accepts, the grid and units, the normal contact against Hertz, the bonded tangential
stiffness against Mindlin's 8Ga/(2 − nu) (Johnson 1985, eq. 7.41), and the operator-norm bound
against power iteration. A sphere of radius 1 (G = 1) on a rigid flat at P = 1, 32 cells across."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.problems.slip.problem import SlipProblem, validate

SPHERE = {"quantities": "slip", "radius": 1.0, "load": 1.0, "G": 1.0, "nu": 0.0, "mu": 0.3, "q_ratio": 0.5, "n": 32}


def test_the_defaults_of_a_slip_scene():
    scene = validate({"radius": 1.0, "load": 2.0, "E": 2.0, "mu": 0.3, "q_ratio": 0.5})
    assert (scene.n, scene.tol, scene.steps, scene.control, scene.path) == (64, 1e-8, 10, "force", "load")
    assert (scene.angle_deg, scene.coupling, scene.threads, scene.displacement) == (0.0, "auto", 1, None)
    assert scene.precondition and not (scene.tensor or scene.history or scene.normal_friction)


@pytest.mark.parametrize(
    ("value", "flag"), [("yes", True), ("TRUE", True), ("1", True), (1, True), ("no", False), (0, False)]
)
def test_flags_take_the_usual_spellings(value, flag):
    scene = validate({**SPHERE, "tensor": value, "history": value, "precondition": value})
    assert scene.tensor is flag and scene.history is flag and scene.precondition is flag


@pytest.mark.parametrize(
    ("change", "field", "allowed"),
    [
        ({"tensor": "maybe"}, "tensor", "true or false"),
        ({"tensor": 2}, "tensor", "true or false"),
        ({"mu": 5e-7}, "mu", "0 or finite and >= 1e-6"),
        ({"tol": 1e-3}, "tol", "a tolerance in [1e-14, 1e-4]"),
        ({"tol": 1e-15}, "tol", "a tolerance in [1e-14, 1e-4]"),
        ({"displacement": 0.1}, "displacement", "only with control = displacement"),
        ({"control": "displacement", "displacement": -1.0}, "displacement", "a finite displacement >= 0"),
        ({"path": "loop", "control": "displacement", "displacement": 0.1}, "path", "loop needs control = force"),
        ({"path": "proportional"}, "path", "proportional needs control = displacement"),
        (
            {"path": "proportional", "control": "displacement", "displacement": 0.1, "normal_friction": True},
            "normal_friction",
            "false with path = proportional",
        ),
        ({"coupling": "sometimes"}, "coupling", "one of auto, both, coupled, decoupled"),
        ({"quantities": ["slip", "normal"]}, "quantities", "slip (a slip scene solves nothing else)"),
        ({"threads": 0}, "threads", "an integer >= 1"),
    ],
)
def test_a_bad_field_is_named_with_what_it_allows(change, field, allowed):
    with pytest.raises(InputError) as caught:
        validate({**SPHERE, **change})
    assert caught.value.field == field and allowed in str(caught.value)


def test_the_contact_shape_field_is_accepted_and_ignored_and_zero_friction_is_allowed():
    assert validate({**SPHERE, "shape": "ellipse"}) == validate(SPHERE)
    assert validate({**SPHERE, "mu": 0.0, "quantities": ["slip"]}).mu == 0.0


@pytest.fixture(scope="module")
def sphere() -> SlipProblem:
    return SlipProblem(validate(SPHERE))


def test_the_grid_spans_the_hertz_contact_in_units_of_its_radius(sphere):
    # Hertz (Johnson 1985, eq. 4.22): a = (3PR/4E*)^(1/3), E* = E/(1 − nu²) = 2G(1 + nu)/(1 − nu²) = 2
    a = (3.0 * 1.0 * 1.0 / (4.0 * 2.0)) ** (1.0 / 3.0)
    assert sphere.L == pytest.approx(a, rel=1e-14)
    assert sphere.grid.dx == sphere.grid.dy == 2.0 / 32  # 32 cells across the diameter 2a = 2
    assert sphere.grid.nx == sphere.grid.ny == 2 * math.ceil(1.1 * 16)  # ±1.1 a
    assert sphere.P == pytest.approx(1.0 / (1.0 * a * a), rel=1e-14)  # P / (G L²)
    assert sphere.force_unit == pytest.approx(a * a) and sphere.stiffness_unit == pytest.approx(a)


def test_the_normal_contact_carries_the_load_with_hertzs_pressure_and_area(sphere):
    p = sphere.normal().traction[0]
    cell = sphere.grid.cell_area
    assert float(p.sum()) * cell == pytest.approx(sphere.P, rel=1e-10)
    assert float(p.max()) == pytest.approx(3.0 * sphere.P / (2.0 * math.pi), rel=5e-3)  # p0 = 3P/2πa², a = 1
    assert float((p > 0.0).sum()) * cell == pytest.approx(math.pi, rel=3e-2)  # πa², to the cells on its edge


@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_the_bonded_contact_is_as_stiff_as_mindlins_circle(nu):
    problem = SlipProblem(validate({**SPHERE, "nu": nu}))
    contact = problem.normal().traction[0] > 0.0
    K, iterations = problem.tangent_tensor(contact, None, contact, coupled=False)
    mindlin = 8.0 / (2.0 - nu)  # 8 G a / (2 − nu), G = a = 1 in grid units
    assert iterations > 0
    assert K[0, 0] == pytest.approx(mindlin, rel=1e-2) and K[1, 1] == pytest.approx(K[0, 0], rel=1e-8)
    assert abs(K[0, 1]) <= 1e-8 * K[0, 0] and K[0, 1] == pytest.approx(K[1, 0], abs=1e-8 * K[0, 0])


def test_nothing_stuck_and_no_slip_direction_is_no_stiffness(sphere):
    none = np.zeros(sphere.gap.shape, dtype=bool)
    K, iterations = sphere.tangent_tensor(none, None, none, coupled=False)
    assert iterations == 0 and not K.any()


def test_the_operator_norm_bounds_the_largest_eigenvalue_and_the_self_compliance(sphere):
    x = np.random.default_rng(0).normal(size=(2, sphere.grid.nx, sphere.grid.ny))
    for _ in range(100):  # power iteration on the (symmetric) tangential operator
        y = sphere.op_t.apply(x)
        largest = float(np.vdot(x, y) / np.vdot(x, x))
        x = y / np.linalg.norm(y)
    assert 0.0 < sphere.self_compliance <= largest <= sphere.norm_A  # eᵀAe <= λ_max <= ‖A‖ bound


def test_elastically_similar_spheres_have_no_coupling():
    similar = SlipProblem(validate({**SPHERE, "nu": 0.3, "G2": 1.0, "nu2": 0.3, "radius2": 1.0}))
    assert similar.pair.similar
    p = similar.normal().traction[0]
    assert not similar.coupling_tangential(p).any()
    t = np.stack([p, -0.5 * p])
    assert not similar.coupling_normal(t).any()
