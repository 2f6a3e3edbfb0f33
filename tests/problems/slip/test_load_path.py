"""Load paths of a partial-slip scene (hpcontact.problems.slip.load_path) against the closed forms
of Cattaneo–Mindlin and Mindlin–Deresiewicz (Johnson 1985, §7.2, eqs. 7.46–7.52), for a sphere
(R = 1, G = 1, nu = 0) on a rigid flat at P = 1, mu = 0.3, loaded to Q* = 0.5 mu P, unloaded
to −Q* and reloaded to Q* (path "loop", one step each way), 32 cells across the contact.

At nu = 0 the slip tractions stay parallel to the load, so the closed forms hold exactly and the
consistent tangent equals the stick-area stiffness (module docstring). With the analytic Hertz
radius a, c = a(1 − Q/mu P)^(1/3), δ_load(Q) = (3 mu P (2 − nu)/(16 G a))[1 − (1 − Q/mu P)^(2/3)],
dQ/dδ = 8 G c/(2 − nu), and on unloading from Q*: δ(Q) = δ* − 2 δ_load((Q* − Q)/2).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hpcontact.problems.slip.load_path import PathResult, along, rotation, run_path
from hpcontact.problems.slip.problem import SlipProblem, validate

MU, P, Q_RATIO = 0.3, 1.0, 0.5
A = (3.0 * P * 1.0 / (4.0 * 2.0)) ** (1.0 / 3.0)  # Hertz: E* = 2 for G = 1, nu = 0 on a rigid flat
CELL = 2.0 * A / 32  # the cell size in scene units


def delta_load(q: float) -> float:
    """Cattaneo–Mindlin displacement at the tangential load q (nu = 0, G = 1)."""
    return 3.0 * MU * P * 2.0 / (16.0 * A) * (1.0 - (1.0 - q / (MU * P)) ** (2.0 / 3.0))


@pytest.fixture(scope="module")
def loop() -> PathResult:
    params = {"radius": 1.0, "load": P, "G": 1.0, "nu": 0.0, "mu": MU, "q_ratio": Q_RATIO, "n": 32}
    return run_path(SlipProblem(validate({**params, "path": "loop", "steps": 1})), coupled=False)


def test_the_loop_visits_its_branches_at_the_target_forces(loop):
    q_star = Q_RATIO * MU * P
    assert [p.branch for p in loop.points] == ["initial", "loading", "unloading", "unloading", "reloading", "reloading"]
    forces = [p.force for p in loop.points]
    np.testing.assert_allclose(forces, [0.0, q_star, 0.0, -q_star, 0.0, q_star], rtol=0.0, atol=1e-7 * MU * P)
    assert loop.last is loop.points[-1] and loop.counters.newton > 0 and loop.counters.total() > 0


def test_loading_follows_cattaneo_mindlin(loop):
    q_star = Q_RATIO * MU * P
    point = loop.points[1]
    c = A * (1.0 - Q_RATIO) ** (1.0 / 3.0)
    assert point.displacement == pytest.approx(delta_load(q_star), rel=2e-3)
    assert point.stiffness == pytest.approx(4.0 * c, rel=2e-2)  # 8Gc/(2 − nu)
    assert point.stick_stiffness == pytest.approx(point.stiffness, rel=1e-6)  # equal at nu = 0
    assert abs(math.sqrt(point.stick_area / math.pi) - c) <= 0.5 * CELL  # stick radius to half a cell
    assert point.contact_area == loop.points[0].contact_area == pytest.approx(math.pi * A * A, rel=3e-2)


def test_the_bonded_start_is_as_stiff_as_the_whole_contact_stuck(loop):
    start = loop.points[0]
    assert start.displacement == 0.0 and start.stick_area == start.contact_area
    assert start.stiffness == pytest.approx(4.0 * A, rel=1e-2)  # 8Ga/(2 − nu)


def test_unloading_follows_mindlin_deresiewicz_and_the_loop_closes(loop):
    q_star = Q_RATIO * MU * P
    d_star = loop.points[1].displacement
    unloaded = d_star - 2.0 * delta_load(q_star / 2.0)  # at Q = 0 on the way down
    assert loop.points[2].displacement == pytest.approx(unloaded, rel=2e-2)
    assert loop.points[3].displacement == pytest.approx(-d_star, rel=1e-9)  # symmetric at −Q*
    assert loop.points[4].displacement == pytest.approx(-loop.points[2].displacement, rel=1e-6)
    assert loop.points[5].displacement == pytest.approx(d_star, rel=1e-9)  # back where loading ended


def test_the_tensor_of_a_circle_at_nu_0_is_isotropic_in_the_scene_frame(loop):
    tensor = loop.points[0].tensor
    assert tensor[0, 0] == pytest.approx(tensor[1, 1], rel=1e-8) and abs(tensor[0, 1]) <= 1e-8 * tensor[0, 0]


@pytest.mark.parametrize("angle", [0.0, 30.0, 90.0, -135.0])
def test_a_rotation_turns_counter_clockwise_and_keeps_lengths(angle):
    R = rotation(angle)
    np.testing.assert_allclose(R @ R.T, np.eye(2), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0)
    t = math.radians(angle)
    np.testing.assert_allclose(R @ np.array([1.0, 0.0]), [math.cos(t), math.sin(t)], atol=1e-15)


def test_the_stiffness_along_a_direction_is_one_over_the_compliance_along_it():
    K = np.diag([2.0, 8.0])
    assert along(K, np.array([1.0, 0.0])) == pytest.approx(2.0)
    assert along(K, np.array([0.0, 1.0])) == pytest.approx(8.0)
    n = np.array([1.0, 1.0]) / math.sqrt(2.0)
    assert along(K, n) == pytest.approx(1.0 / (0.5 / 2.0 + 0.5 / 8.0))  # 3.2: not nᵀKn = 5
    R = rotation(40.0)
    assert along(R @ K @ R.T, R @ n) == pytest.approx(3.2)


def test_a_singular_tensor_slides_and_a_non_finite_one_is_refused():
    assert along(np.zeros((2, 2)), np.array([1.0, 0.0])) == 0.0
    assert along(np.array([[1.0, 1.0], [1.0, 1.0]]), np.array([1.0, 0.0])) == 0.0
    with pytest.raises(FloatingPointError, match="non-finite stiffness tensor"):
        along(np.array([[np.nan, 0.0], [0.0, 1.0]]), np.array([1.0, 0.0]))
