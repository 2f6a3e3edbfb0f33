"""The friction-disc programme min ½ tᵀAt − bᵀt, |t_i| ≤ g_i (hpcontact.numerics.friction_qp),
on small dense operators: the separable case against its closed form (each cell's unconstrained
minimizer b_i/a_i projected onto its disc), a coupled case against scipy's SLSQP and the KKT
conditions checked here from their definition (free cells: At − b = 0; cells on the limit:
At − b = −λ t/|t| with λ ≥ 0; cells with g = 0: no traction); both solvers on array-api-strict's
arrays (the device path) against numpy within the natural-residual bound of
tests/problems/slip/slip_agreement.py; and on the half-space operator Cattaneo's problem (Hertz
pressure, nu = 0, a uniform tangential displacement) against its closed form.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import array_api_strict as xps
import numpy as np
import pytest
from scipy.optimize import minimize

from hpcontact.errors import ConvergenceError
from hpcontact.geometry import Grid
from hpcontact.kernels.engine import Engine
from hpcontact.kernels.isotropic import isotropic_surface_green
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import namespace, to_host
from hpcontact.numerics.friction_qp import disc_qp, kkt_residual, mprgp_disc
from hpcontact.numerics.preconditioner import FourierPreconditioner

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "problems" / "slip"))
from slip_agreement import REQUIRED, distance_bound  # noqa: E402

SHAPE = (2, 3, 4)  # (components, nx, ny)


def _problem(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A coupled SPD operator on (2, 3, 4) tractions, a right-hand side and disc radii (one cell 0)."""
    rng = np.random.default_rng(seed)
    m = int(np.prod(SHAPE))
    M = rng.normal(size=(m, m))
    A = M @ M.T / m + 0.5 * np.eye(m)
    b = rng.normal(size=SHAPE)
    bound = rng.uniform(0.1, 1.0, size=SHAPE[1:])
    bound[0, 0] = 0.0
    return A, b, bound


def _apply(A: np.ndarray):
    return lambda x: (A @ x.ravel()).reshape(x.shape)


def _energy(A: np.ndarray, b: np.ndarray, t: np.ndarray) -> float:
    x = t.ravel()
    return 0.5 * float(x @ A @ x) - float(b.ravel() @ x)


def _slsqp(A: np.ndarray, b: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """The reference minimizer from scipy (SLSQP, the disc constraints g_i² − |t_i|² ≥ 0)."""
    cells = bound > 0.0
    n = int(cells.sum())

    def full(z: np.ndarray) -> np.ndarray:
        t = np.zeros(SHAPE)
        t[:, cells] = z.reshape(2, n)
        return t

    def energy(z):
        return _energy(A, b, full(z))

    def gradient(z):
        return ((A @ full(z).ravel()).reshape(SHAPE) - b)[:, cells].ravel()

    def room(z):
        t = z.reshape(2, n)
        return bound[cells] ** 2 - t[0] ** 2 - t[1] ** 2

    result = minimize(
        energy,
        np.zeros(2 * n),
        jac=gradient,
        constraints=[{"type": "ineq", "fun": room}],
        method="SLSQP",
        options={"ftol": 1e-15, "maxiter": 1000},
    )
    assert result.success, result.message
    return full(result.x)


def _assert_kkt(A: np.ndarray, b: np.ndarray, bound: np.ndarray, t: np.ndarray, tol: float) -> None:
    """The optimality conditions of the programme, from their definition (module docstring)."""
    g = (A @ t.ravel()).reshape(SHAPE) - b
    mag = np.hypot(t[0], t[1])
    scale = float(np.linalg.norm(b))
    assert (mag <= bound * (1.0 + 1e-12)).all()  # feasible
    assert (t[:, bound == 0.0] == 0.0).all()
    active = (bound > 0.0) & (mag >= bound * (1.0 - 1e-9))
    free = (bound > 0.0) & ~active
    assert np.abs(g[:, free]).max(initial=0.0) <= tol * scale
    n = t[:, active] / mag[active]
    lam = -(g[0, active] * n[0] + g[1, active] * n[1])  # g = −λ n
    assert (lam >= -tol * scale).all()
    assert np.abs(g[:, active] + lam * n).max(initial=0.0) <= tol * scale


@pytest.mark.parametrize("solver", ["newton", "mprgp"])
def test_a_separable_programme_gives_each_cells_minimizer_projected_onto_its_disc(solver):
    rng = np.random.default_rng(1)
    a = rng.uniform(0.5, 2.0, size=SHAPE[1:])  # A = diag(a_i) on both components
    b = rng.normal(size=SHAPE)
    bound = rng.uniform(0.2, 1.5, size=SHAPE[1:])
    free = b / a
    mag = np.hypot(free[0], free[1])
    exact = free * np.minimum(1.0, bound / mag)
    assert (mag > bound).any() and (mag < bound).any()  # both kinds of cell
    apply = lambda x: a * x  # noqa: E731
    if solver == "newton":
        result = disc_qp(apply, b, bound, None, 1e-13, c=1.0 / float(a.max()), norm_A=float(a.max()))
    else:
        result = mprgp_disc(apply, b, bound, None, 1e-13, norm_A=float(a.max()))
    np.testing.assert_allclose(result.traction, exact, rtol=0.0, atol=1e-12)
    assert result.residual <= 1e-13 and result.iterations > 0
    assert kkt_residual(exact, a * exact - b, bound) <= 1e-15 * float(np.linalg.norm(b))


@pytest.mark.parametrize("seed", [2, 3, 4])
@pytest.mark.parametrize("solver", ["newton", "mprgp"])
def test_a_coupled_programme_meets_its_kkt_conditions_and_scipys_minimum(seed, solver):
    A, b, bound = _problem(seed)
    apply, norm_A = _apply(A), float(np.linalg.eigvalsh(A).max())
    if solver == "newton":
        result = disc_qp(apply, b, bound, None, 1e-12, c=1.0 / float(np.diag(A).max()), norm_A=norm_A)
    else:
        result = mprgp_disc(apply, b, bound, None, 1e-12, norm_A=norm_A)
    t = result.traction
    _assert_kkt(A, b, bound, t, 1e-10)
    reference = _slsqp(A, b, bound)
    assert _energy(A, b, t) <= _energy(A, b, reference) + 1e-12 * abs(_energy(A, b, reference))
    np.testing.assert_allclose(t, reference, atol=1e-5)  # SLSQP's own accuracy
    mag = np.hypot(t[0], t[1])
    assert (mag >= bound * (1 - 1e-9))[bound > 0].any()  # some cells slip: the discs matter


def test_a_preconditioner_and_a_warm_start_change_the_work_not_the_answer():
    A, b, bound = _problem(5)
    apply, norm_A, c = _apply(A), float(np.linalg.eigvalsh(A).max()), 1.0 / float(np.diag(A).max())
    plain = disc_qp(apply, b, bound, None, 1e-12, c, norm_A)
    jacobi = 1.0 / np.diag(A).reshape(SHAPE)
    preconditioned = disc_qp(apply, b, bound, None, 1e-12, c, norm_A, precondition=lambda v: jacobi * v)
    np.testing.assert_allclose(preconditioned.traction, plain.traction, atol=1e-10)
    warm = disc_qp(apply, b, bound, plain.traction, 1e-12, c, norm_A)
    assert warm.iterations == 1 and warm.steps["newton"] == 0  # one application: already converged
    np.testing.assert_array_equal(warm.traction, plain.traction)


def test_the_kkt_residual_is_the_gradient_where_nothing_touches_its_disc():
    A, b, bound = _problem(6)
    zero = np.zeros(SHAPE)
    expected = float(np.linalg.norm(np.where(bound > 0.0, b, 0.0)))  # g = −b, every cell free
    assert kkt_residual(zero, -b, bound) == pytest.approx(expected, rel=1e-15)


def test_no_load_or_no_disc_gives_no_traction_without_work():
    A, b, bound = _problem(7)
    for rhs, radii in ((np.zeros(SHAPE), bound), (b, np.zeros(SHAPE[1:]))):
        for result in (
            disc_qp(_apply(A), rhs, radii, None, 1e-12, 1.0, 10.0),
            mprgp_disc(_apply(A), rhs, radii, None, 1e-12, 10.0),
        ):
            assert result.iterations == 0 and result.residual == 0.0 and not result.traction.any()


def test_a_non_finite_load_is_refused():
    A, b, bound = _problem(8)
    b[1, 2, 3] = np.nan
    with pytest.raises(ValueError, match="not finite"):
        disc_qp(_apply(A), b, bound, None, 1e-12, 1.0, 10.0)


def test_mprgp_out_of_iterations_raises_unless_not_strict():
    A, b, bound = _problem(9)
    norm_A = float(np.linalg.eigvalsh(A).max())
    with pytest.raises(ConvergenceError, match="did not reach tol=1e-12"):
        mprgp_disc(_apply(A), b, bound, None, 1e-12, norm_A, maxiter=2)
    loose = mprgp_disc(_apply(A), b, bound, None, 1e-12, norm_A, maxiter=2, strict=False)
    assert loose.residual > 1e-12 and _energy(A, b, loose.traction) < 0.0  # improved on t = 0


def test_an_operator_that_is_not_positive_definite_is_named():
    _, b, bound = _problem(10)
    with pytest.raises(ConvergenceError, match="not positive definite"):
        mprgp_disc(lambda x: -x, b, bound, None, 1e-12, 1.0)


@pytest.mark.parametrize("solver", ["newton", "mprgp"])
def test_both_solvers_on_strict_arrays_are_the_numpy_ones(solver):
    """The device path (array-api-strict: nothing outside the standard) against numpy, on the
    coupled programme: each solution within the natural-residual bound 2κ(‖r(t₁)‖ + ‖r(t₂)‖) of
    the other, ≤ 1e-12 relative."""
    A, b, bound = _problem(3)
    norm_A, c = float(np.linalg.eigvalsh(A).max()), 1.0 / float(np.diag(A).max())
    A_strict = xps.asarray(A)

    def apply_strict(x):
        return xps.reshape(xps.matmul(A_strict, xps.reshape(x, (-1,))), x.shape)

    runs = []
    for apply, rhs, radii in ((_apply(A), b, bound), (apply_strict, xps.asarray(b), xps.asarray(bound))):
        if solver == "newton":
            runs.append(disc_qp(apply, rhs, radii, None, 1e-14, c, norm_A))
        else:
            runs.append(mprgp_disc(apply, rhs, radii, None, 1e-14, norm_A))
    assert namespace(runs[1].traction) is xps
    t1, t2 = runs[0].traction, to_host(runs[1].traction)
    cells = bound > 0.0
    unknowns = np.flatnonzero(np.broadcast_to(cells, SHAPE))
    solutions = [t[:, cells] for t in (t1, t2)]
    limit = distance_bound(A[np.ix_(unknowns, unknowns)], b[:, cells], bound[cells], solutions)
    assert limit <= REQUIRED * np.linalg.norm(t1)
    assert np.linalg.norm(t1 - t2) <= limit
    assert (t2[:, ~cells] == 0.0).all()


@pytest.mark.parametrize("n", [32, 64])
def test_cattaneos_stick_radius_on_the_half_space(n):
    """Cattaneo's problem (Johnson 1985, §7.2): a Hertz pressure p = p0 √(1 − r²/a²) (a = 1,
    p0 = 1), nu = 0 (no normal–tangential or transverse coupling: the closed form is exact), G = 1,
    and a uniform tangential displacement δ = δ_max/2, δ_max = 3μP(2 − nu)/(16 G a) the
    displacement at sliding. Closed form: Q/μP = 1 − (1 − δ/δ_max)^{3/2}, stick radius
    c/a = (1 − Q/μP)^{1/3}. The programme on the grid's half-space operator (n cells across the
    contact), with the discrete P and Q: the stick boundary lies between cell centres, so the
    radius of the stick area is within half a cell of the closed form's (measured 0.08 and 0.17
    cells at n = 32, 64; 0.08 at 128); Q is asserted to 1e-4 of the closed form (measured 2.4e-5,
    3.6e-5: the grid's discretization, not a bound from analysis); t_y = 0 exactly (nu = 0: the
    x and y problems decouple, and none is loaded along y)."""
    dx = 2.0 / n
    cells = 2 * math.ceil(1.1 / dx)
    grid = Grid(cells, cells, dx, dx)
    x, y = grid.centres()
    material = Isotropic(G=1.0, nu=0.0)
    engine = Engine(material, grid, ("xx",))  # nu = 0: yy = xx, xy = 0
    operator = engine.operator("xy")
    preconditioner = FourierPreconditioner(grid, lambda phi: isotropic_surface_green(material, phi), "xy")
    p = np.sqrt(np.maximum(1.0 - (x * x + y * y), 0.0))
    P, mu = float(p.sum()) * grid.cell_area, 0.3
    impulse = np.zeros((2, cells, cells))
    impulse[0, cells // 2, cells // 2] = 1.0
    self_compliance = float(operator.apply(impulse)[0, cells // 2, cells // 2])
    norm_A = float(np.abs(engine.spectrum("xx")).max())  # the symbol's largest eigenvalue
    b = np.zeros((2, cells, cells))
    b[0] = 0.5 * 3.0 * mu * (2.0 * math.pi / 3.0) * 2.0 / 16.0  # δ_max/2 with the analytic P = 2π p0 a²/3
    result = disc_qp(operator.apply, b, mu * p, None, 1e-12, 1.0 / self_compliance, norm_A, preconditioner.apply)
    t = result.traction
    Q = float(t[0].sum()) * grid.cell_area
    assert abs(Q / (mu * P) / (1.0 - 0.5**1.5) - 1.0) < 1e-4
    stick = (p > 0.0) & (np.hypot(t[0], t[1]) < mu * p * (1.0 - 1e-9))
    radius = math.sqrt(float(stick.sum()) * grid.cell_area / math.pi)
    assert abs(radius - (1.0 - Q / (mu * P)) ** (1.0 / 3.0)) < 0.5 * dx
    assert not t[1].any()
