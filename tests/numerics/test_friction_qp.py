"""The friction-disc programme min ½ tᵀAt − bᵀt, |t_i| ≤ g_i (hpcontact.numerics.friction_qp),
on small dense operators: the separable case against its closed form (each cell's unconstrained
minimizer b_i/a_i projected onto its disc), a coupled case against scipy's SLSQP and the KKT
conditions checked here from their definition (free cells: At − b = 0; cells on the limit:
At − b = −λ t/|t| with λ ≥ 0; cells with g = 0: no traction)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from hpcontact.errors import ConvergenceError
from hpcontact.numerics.friction_qp import disc_qp, kkt_residual, mprgp_disc

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
