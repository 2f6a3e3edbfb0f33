"""Batched conjugate gradients (``conjugate_gradient_batch``, issue 41 item 2) against the
single-scene ``conjugate_gradient``, on numpy and on array-api-strict.

The operators are dense: scene k's full-grid compliance A_k[(i,a),(j,b)] = K_ij[a − b] of an isotropic
body (nu_k), assembled from the influence-coefficient blocks by direct indexing (no FFT) and applied
by ``xp.matmul`` over the stack, so the comparison is of the two iterations alone. Each scene has its
own mask and material; a per-scene diagonal preconditioner (random positive weights) makes each
scene's preconditioned iteration its own.

Bound, from analysis (as tests/numerics/device_agreement.py): both solutions x₁ (single) and x₂
(batched) of P A P x = P b have true residuals ρᵢ = ‖P(A xᵢ − b)‖/‖b‖, evaluated in extended
precision, so ‖x₁ − x₂‖/‖x₁‖ ≤ κ(A_mask)·(ρ₁ + ρ₂), κ the condition number of A on the mask's
unknowns (SVD). The solves run to tol 1e-14 so that the bound is ≲ 1e-12 (asserted as well).
"""

from __future__ import annotations

import sys
from pathlib import Path

import array_api_strict as xps
import numpy as np
import pytest

from hpcontact.errors import ConvergenceError
from hpcontact.geometry import Grid, Shape, rasterize
from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import namespace, to_device, to_host
from hpcontact.numerics.conjugate_gradient import conjugate_gradient, conjugate_gradient_batch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from device_agreement import REQUIRED, residual  # noqa: E402

GRID = Grid(10, 8, 2.0 / 10, 1.6 / 8)
COMPONENTS = "xy"
TOL = 1e-14
#: (material's nu, contact shape) of each scene of the batch: one grid, masks and materials of their own
SCENES = [
    (0.3, Shape("ellipse", aspect=0.8)),
    (0.45, Shape("ellipse", aspect=0.6, angle_deg=30.0)),
    (0.0, Shape("rectangle", aspect=0.5)),
    (0.2, Shape("ellipse", aspect=0.3, angle_deg=-20.0)),
]


def full_grid_matrix(nu: float) -> np.ndarray:
    """A[(i,a),(j,b)] = K_ij[a − b] over every cell of ``GRID`` (component-major), SPD."""
    ia, ja = np.nonzero(np.ones((GRID.nx, GRID.ny), dtype=bool))
    di = ia[:, None] - ia[None, :] + GRID.nx - 1
    dj = ja[:, None] - ja[None, :] + GRID.ny - 1
    n, c = ia.size, len(COMPONENTS)
    A = np.zeros((c * n, c * n))
    for i, ci in enumerate(COMPONENTS):
        for j, cj in enumerate(COMPONENTS):
            K = isotropic_block(Isotropic(nu=nu), GRID.nx, GRID.ny, GRID.dx, GRID.dy, ci + cj)
            A[i * n : (i + 1) * n, j * n : (j + 1) * n] = K[di, dj]
    return A


def problem(scenes=SCENES, seed: int = 3):
    """Dense operators (B, N, N), masks (B, nx, ny), right-hand sides (B, c, nx, ny) (unit x
    displacement plus a random part) and diagonal preconditioner weights (B, c, nx, ny)."""
    rng = np.random.default_rng(seed)
    shape = (len(scenes), len(COMPONENTS), GRID.nx, GRID.ny)
    matrices = np.stack([full_grid_matrix(nu) for nu, _ in scenes])
    masks = np.stack([rasterize(contact, GRID) for _, contact in scenes])
    rhs = rng.standard_normal(shape)
    rhs[:, 0] += 1.0
    weights = rng.uniform(0.5, 2.0, shape)
    return matrices, masks, rhs, weights


def stacked(matrices, xp):
    """``apply`` of the dense operators: a stack (B, c, nx, ny) of ``xp`` → A_k t_k for each scene."""
    A = to_device(matrices, xp)

    def apply(t):
        flat = namespace(t).reshape(t, (t.shape[0], -1, 1))
        return namespace(t).reshape(namespace(t).matmul(A, flat), t.shape)

    return apply


def one(matrix):
    """``apply`` of one scene's dense operator on numpy arrays (c, nx, ny)."""
    return lambda t: (matrix @ t.reshape(-1)).reshape(t.shape)


def agreement(matrix, mask, rhs, x_single, x_batched):
    """Assert ‖x₁ − x₂‖ ≤ κ(A_mask)(ρ₁ + ρ₂)‖x₁‖ ≤ REQUIRED‖x₁‖ on the mask's unknowns."""
    cells = np.flatnonzero(np.broadcast_to(mask, rhs.shape))
    A = matrix[np.ix_(cells, cells)]
    singular = np.linalg.svd(A, compute_uv=False)
    kappa = singular[0] / singular[-1]
    b = rhs.reshape(-1)[cells]
    x1, x2 = x_single.reshape(-1)[cells], x_batched.reshape(-1)[cells]
    bound = kappa * (residual(A, x1, b) + residual(A, x2, b))
    assert bound <= REQUIRED, kappa
    assert np.linalg.norm(x1 - x2) <= bound * np.linalg.norm(x1)


@pytest.mark.parametrize("xp", [np, xps], ids=["numpy", "array-api-strict"])
@pytest.mark.parametrize("preconditioned", [False, True])
def test_batched_cg_is_the_single_scene_cg(xp, preconditioned):
    matrices, masks, rhs, weights = problem()
    scale = to_device(weights, xp)
    batch = conjugate_gradient_batch(
        stacked(matrices, xp),
        to_device(rhs, xp),
        to_device(masks, xp),
        tol=TOL,
        precondition=(lambda r: r * scale) if preconditioned else None,
    )
    assert namespace(batch.traction) is xp and batch.traction.shape == rhs.shape
    tractions = to_host(batch.traction)
    for k in range(len(SCENES)):
        single = conjugate_gradient(
            one(matrices[k]),
            rhs[k],
            masks[k],
            tol=TOL,
            precondition=(lambda r, w=weights[k]: r * w) if preconditioned else None,
        )
        assert batch.iterations[k] == single.iterations  # per-scene steps: each scene's own iteration
        assert batch.residuals[k] <= TOL
        assert np.all(tractions[k][:, ~masks[k]] == 0.0)  # supported on the scene's own mask
        agreement(matrices[k], masks[k], rhs[k], single.traction, tractions[k])
        solution = batch.scene(k)
        assert solution.iterations == batch.iterations[k] and solution.residual == batch.residuals[k]


@pytest.mark.parametrize("xp", [np, xps], ids=["numpy", "array-api-strict"])
def test_a_converged_scene_stops_changing_while_the_others_iterate(xp):
    """Scenes stop at different iterations (tolerances 1e-4 … 1e-14); after its last iteration a
    scene's search direction is what every later operator application gets (α, β frozen), and its
    solution is the single-scene CG's at its own tolerance."""
    matrices, masks, rhs, _ = problem()
    tolerances = [1e-4, 1e-14, 1e-7, 1e-10]
    seen = []
    apply = stacked(matrices, xp)

    def recording(t):
        seen.append(to_host(t).copy())
        return apply(t)

    batch = conjugate_gradient_batch(recording, to_device(rhs, xp), to_device(masks, xp), tol=tolerances)
    assert len(set(batch.iterations)) == len(SCENES)  # every scene stops at its own iteration
    assert len(seen) == max(batch.iterations)  # one application of the whole stack per iteration
    tractions = to_host(batch.traction)
    for k, tol in enumerate(tolerances):
        last = batch.iterations[k]
        for later in seen[last:]:
            assert np.array_equal(later[k], seen[last - 1][k])
        single = conjugate_gradient(one(matrices[k]), rhs[k], masks[k], tol=tol)
        assert single.iterations == last and batch.residuals[k] <= tol
        cells = np.flatnonzero(np.broadcast_to(masks[k], rhs[k].shape))
        difference = np.linalg.norm((tractions[k] - single.traction).reshape(-1)[cells])
        # both stop at tol; their difference is bounded by κ(ρ₁ + ρ₂) with ρ ≈ tol
        A = matrices[k][np.ix_(cells, cells)]
        singular = np.linalg.svd(A, compute_uv=False)
        b = rhs[k].reshape(-1)[cells]
        rho = sum(residual(A, x.reshape(-1)[cells], b) for x in (single.traction, tractions[k]))
        assert difference <= singular[0] / singular[-1] * rho * np.linalg.norm(single.traction)


@pytest.mark.parametrize("xp", [np, xps], ids=["numpy", "array-api-strict"])
def test_a_batch_of_one_is_the_single_scene_cg(xp):
    matrices, masks, rhs, _ = problem(SCENES[1:2])
    batch = conjugate_gradient_batch(stacked(matrices, xp), to_device(rhs, xp), to_device(masks, xp), tol=TOL)
    single = conjugate_gradient(one(matrices[0]), rhs[0], masks[0], tol=TOL)
    assert batch.iterations == [single.iterations]
    agreement(matrices[0], masks[0], rhs[0], single.traction, to_host(batch.traction)[0])


def test_a_scene_with_nothing_prescribed_is_solved_by_zero_without_iterating():
    matrices, masks, rhs, _ = problem()
    rhs[2] = 0.0
    batch = conjugate_gradient_batch(stacked(matrices, np), rhs, masks, tol=TOL)
    assert batch.iterations[2] == 0 and batch.residuals[2] == 0.0
    assert np.all(batch.traction[2] == 0.0) and min(batch.iterations[:2] + batch.iterations[3:]) > 0


def test_a_scene_whose_operator_is_not_positive_definite_is_named():
    matrices, masks, rhs, _ = problem()
    matrices[1] = -matrices[1]
    with pytest.raises(ConvergenceError, match="scene 1: operator is not positive definite"):
        conjugate_gradient_batch(stacked(matrices, np), rhs, masks, tol=TOL)


def test_a_scene_short_of_its_tolerance_is_named():
    matrices, masks, rhs, _ = problem()
    with pytest.raises(ConvergenceError, match="scene 3: conjugate gradients did not reach tol=1e-14"):
        conjugate_gradient_batch(stacked(matrices, np), rhs, masks, tol=TOL, maxiter=[500, 500, 500, 3])


def test_per_scene_settings_have_one_value_per_scene():
    matrices, masks, rhs, _ = problem()
    with pytest.raises(ValueError, match="tol has 2 values for 4 scenes"):
        conjugate_gradient_batch(stacked(matrices, np), rhs, masks, tol=[1e-8, 1e-8])
    with pytest.raises(ValueError, match="rhs must have shape"):
        conjugate_gradient_batch(stacked(matrices, np), rhs[0], masks[0])
