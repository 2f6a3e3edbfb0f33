"""The device path of the numerics runs on the array-API standard alone (issue 41, item 1).

array-api-strict is a minimal implementation of the Python array API standard: an array of it
refuses every function outside the standard, numpy's included, and mixing with numpy arrays. The
device path (``ArrayConvolutionOperator``, ``conjugate_gradient``, ``polonsky_keer``, the Fourier
preconditioner on ``xp``, the contact solve of ``problems.contact``) run here on its arrays is the
code CuPy runs on a GPU. Each result is compared with the numpy path's (pyFFTW, pocketfft), an
independent implementation of the same arithmetic.

Bounds, from analysis:

- Convolution: each path's FFT route errs by ≲ c·log₂(N)·u·max|K̂|·‖t‖₂ (Gentleman & Sande 1966;
  Parseval: ‖u‖₂ ≤ max|K̂|·‖t‖₂), u = 2⁻⁵³, N = N1·N2 the padded size, c a small constant (5
  here, for the forward transform, the product and the inverse transform); two paths: twice that.
- A linear solve: both solutions x₁, x₂ of P A P x = P b have true residuals ρᵢ = ‖P(A xᵢ − b)‖/‖b‖,
  so ‖x₁ − x₂‖/‖x₁‖ ≤ κ(A_mask)·(ρ₁ + ρ₂) with A_mask the dense matrix of the operator on the mask
  (its columns: the operator applied to unit tractions) and κ = σ_max/σ_min its condition number
  (SVD of a 100–300 unknown matrix); ρᵢ evaluated in extended precision (np.longdouble), so the
  bound holds whatever the rounding inside either iteration. A resultant differs by at most
  cell area·√m·‖x₁ − x₂‖₂ (m unknowns) plus its summation's rounding, m·u·cell area·Σ|x|. The solves run to tol 1e-14 (the least a scene takes), so the bound is ≲ 1e-12, as the
  issue asks; the test checks that as well.
- Polonsky–Keer: on the same contact set both pressures solve A_c p = −h_c, so the bound of a
  linear solve holds with A_c (the operator on the contact cells) and ρᵢ = ‖A_c pᵢ + h_c‖/‖h_c‖.
"""

from __future__ import annotations

import math

import array_api_strict as xps
import numpy as np
import pytest

from hpcontact.geometry import Grid
from hpcontact.kernels.engine import Engine
from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import dot, namespace, norm, to_device, to_host
from hpcontact.numerics.conjugate_gradient import polonsky_keer
from hpcontact.numerics.convolution import ArrayConvolutionOperator, ConvolutionOperator, kernel_spectrum, padded_shape
from hpcontact.plan import make_plan
from hpcontact.problems.contact import _run_solve, discretize
from hpcontact.scene import Scene

U = 2.0**-53
REQUIRED = 1e-12  # the agreement of the device path with the CPU path


def test_the_backend_helpers_stay_in_the_standard():
    a = xps.asarray([[3.0, 0.0], [0.0, 4.0]])
    assert namespace(a) is xps and namespace(np.zeros(1)) is np
    assert norm(a) == 5.0 and dot(a, a) == 25.0
    host = to_host(a)
    assert isinstance(host, np.ndarray) and host.tolist() == [[3.0, 0.0], [0.0, 4.0]]
    assert namespace(to_device(host, xps)) is xps
    assert to_device(host, np) is host


@pytest.mark.parametrize("components, nu", [("z", 0.3), ("xy", 0.3), ("xyz", 0.3), ("xyz", 0.0)])
def test_convolution_on_strict_arrays_is_the_pyfftw_one(components, nu):
    nx, ny = 13, 9
    material, dx, dy = Isotropic(nu=nu), 0.1, 0.07
    shape = padded_shape(nx, ny)
    spectra = {
        a + b: kernel_spectrum(isotropic_block(material, nx, ny, dx, dy, a + b), shape)
        for a in components
        for b in components
    }
    spectra = {k: s for k, s in spectra.items() if np.max(np.abs(s)) > 0.0}  # an absent block is zero
    traction = np.random.default_rng(7).standard_normal((len(components), nx, ny))
    reference = ConvolutionOperator(nx, ny, components, spectra).apply(traction)
    device = ArrayConvolutionOperator(nx, ny, components, spectra, xps)
    u = device.apply(xps.asarray(traction))
    assert namespace(u) is xps and u.shape == (len(components), nx, ny) and u.dtype == xps.float64
    largest = max(np.max(np.abs(s)) for s in spectra.values()) * len(components)
    bound = 2 * 5 * math.log2(shape[0] * shape[1]) * U * largest * np.linalg.norm(traction)
    difference = np.linalg.norm(to_host(u) - reference)
    assert difference <= bound
    assert difference <= REQUIRED * np.linalg.norm(reference)


def _dense(apply, shape, mask):
    """The matrix of the operator restricted to the mask's unknowns (columns: unit tractions),
    its condition number σ_max/σ_min, and the unknowns' flat indices."""
    cells = np.flatnonzero(np.broadcast_to(mask, shape))
    columns = []
    for index in cells:
        t = np.zeros(math.prod(shape))
        t[index] = 1.0
        columns.append(apply(t.reshape(shape)).reshape(-1)[cells])
    A = np.array(columns).T
    singular = np.linalg.svd(A, compute_uv=False)
    return A, singular[0] / singular[-1], cells


def _residual(A, x, b):
    """‖A x − b‖/‖b‖ in extended precision (its own rounding negligible beside float64's)."""
    A, x, b = (np.asarray(v, dtype=np.longdouble) for v in (A, x, b))
    return float(np.linalg.norm(A @ x - b) / np.linalg.norm(b))


@pytest.mark.parametrize(
    "params",
    [
        {"shape": "ellipse", "aspect": 0.6, "n": 16, "nu": 0.3, "quantities": "tangential,normal"},
        {"shape": "star", "n": 14, "nu": 0.45, "quantities": "tangential"},
    ],
)
@pytest.mark.parametrize("precondition", [True, False])
def test_the_contact_solve_on_strict_arrays_is_the_numpy_one(params, precondition):
    scene = Scene.from_params({**params, "tol": 1e-14, "precondition": precondition})
    grid, mask = discretize(scene)
    plan = make_plan(scene, mask, grid)
    host = Engine(scene.material, grid, plan.kernels)
    strict = Engine(scene.material, grid, plan.kernels, xp=xps)
    for solve in plan.solves:
        force, solution = _run_solve(scene, host, mask, solve)
        force_strict, solution_strict = _run_solve(scene, strict, mask, solve)
        assert isinstance(solution_strict.traction, np.ndarray)  # copied back once, at the boundary
        c = len(solve.components)
        op = host.operator(solve.components, solve.green)
        A, kappa, cells = _dense(op.apply, (c,) + mask.shape, mask)
        b = np.zeros((c,) + mask.shape)
        b[solve.components.index(solve.load)] = 1.0
        b = b.reshape(-1)[cells]
        x1, x2 = solution.traction.reshape(-1)[cells], solution_strict.traction.reshape(-1)[cells]
        bound = kappa * (_residual(A, x1, b) + _residual(A, x2, b))
        assert bound <= REQUIRED, kappa
        difference = np.linalg.norm(x1 - x2)
        assert difference <= bound * np.linalg.norm(x1)
        m, area = len(cells), grid.cell_area
        force_bound = area * (math.sqrt(m) * difference + m * U * np.sum(np.abs(x1)))
        assert np.all(np.abs(force - force_strict) <= force_bound)
        assert np.max(np.abs(force - force_strict)) <= REQUIRED * np.max(np.abs(force))


def test_polonsky_keer_on_strict_arrays_is_the_numpy_one():
    n, R, d = 24, 1.0, 0.01
    half = 1.5 * math.sqrt(R * d)
    grid = Grid(n, n, 2 * half / n, 2 * half / n)
    x, y = grid.centres()
    gap = (x * x + y * y) / (2 * R) - d
    host = Engine(Isotropic(nu=0.3), grid, ("zz",))
    strict = Engine(Isotropic(nu=0.3), grid, ("zz",), xp=xps)
    p1 = polonsky_keer(host.operator("z").apply, gap, tol=1e-14).traction[0]
    p2 = to_host(polonsky_keer(strict.operator("z").apply, xps.asarray(gap), tol=1e-14).traction)[0]
    contact = p1 > 0.0
    assert np.array_equal(contact, p2 > 0.0) and contact.sum() > 20
    # on the contact, A_c p = −h_c; the difference of two pressures is A_c⁻¹ of their gap residuals
    A, kappa, cells = _dense(host.operator("z").apply, (1, n, n), contact[None])
    h = gap.reshape(-1)[cells]
    bound = kappa * sum(_residual(A, p.reshape(-1)[cells], -h) for p in (p1, p2))
    assert bound <= REQUIRED, kappa
    assert np.linalg.norm(p1 - p2) / np.linalg.norm(p1) <= bound
