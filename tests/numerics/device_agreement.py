"""The device path against the numpy path, on any array namespace: the comparisons of
tests/numerics/test_array_api_strict.py (array-api-strict) and tests/gpu/test_gpu_engine.py (CuPy),
with the bounds that module's docstring derives."""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType

import numpy as np

from hpcontact.geometry import Grid
from hpcontact.kernels.engine import Engine
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import to_device, to_host
from hpcontact.numerics.conjugate_gradient import polonsky_keer
from hpcontact.plan import make_plan
from hpcontact.problems.contact import _run_solve, discretize
from hpcontact.scene import Scene

U = 2.0**-53
REQUIRED = 1e-12  # the agreement of the device path with the CPU path


def dense(apply, shape, mask):
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


def residual(A, x, b):
    """‖A x − b‖/‖b‖ in extended precision (its own rounding negligible beside float64's)."""
    A, x, b = (np.asarray(v, dtype=np.longdouble) for v in (A, x, b))
    return float(np.linalg.norm(A @ x - b) / np.linalg.norm(b))


def check_contact_solves(params: dict, xp: ModuleType) -> int:
    """Every solve of the scene ``params`` on the numpy path and on ``xp``: the tractions differ by
    at most κ(A_mask)·(ρ₁ + ρ₂) ≤ ``REQUIRED`` relative, the resultants by their bound and by at
    most ``REQUIRED`` relative. Returns the number of solves compared."""
    scene = Scene.from_params(params)
    grid, mask = discretize(scene)
    plan = make_plan(scene, mask, grid)
    host = Engine(scene.material, grid, plan.kernels)
    device = Engine(scene.material, grid, plan.kernels, xp=xp)
    compared = 0
    for solve in plan.solves:
        force, solution = _run_solve(scene, host, mask, solve)
        force_device, solution_device = _run_solve(scene, device, mask, solve)
        assert isinstance(solution_device.traction, np.ndarray)  # copied back once, at the boundary
        c = len(solve.components)
        A, kappa, cells = dense(host.operator(solve.components, solve.green).apply, (c,) + mask.shape, mask)
        b = np.zeros((c,) + mask.shape)
        b[solve.components.index(solve.load)] = 1.0
        b = b.reshape(-1)[cells]
        x1, x2 = solution.traction.reshape(-1)[cells], solution_device.traction.reshape(-1)[cells]
        bound = kappa * (residual(A, x1, b) + residual(A, x2, b))
        assert bound <= REQUIRED, (solve.name, kappa)
        difference = np.linalg.norm(x1 - x2)
        assert difference <= bound * np.linalg.norm(x1), solve.name
        m, area = len(cells), grid.cell_area
        force_bound = area * (math.sqrt(m) * difference + m * U * np.sum(np.abs(x1)))
        assert np.all(np.abs(force - force_device) <= force_bound), solve.name
        assert np.max(np.abs(force - force_device)) <= REQUIRED * np.max(np.abs(force)), solve.name
        compared += 1
    return compared


def check_polonsky_keer(xp: ModuleType, n: int = 24) -> None:
    """A Hertzian indentation (sphere R = 1, approach 0.01, nu = 0.3) by Polonsky–Keer on the numpy
    path and on ``xp``: the same contact set, pressures within κ(A_c)·(ρ₁ + ρ₂) ≤ ``REQUIRED``."""
    R, d = 1.0, 0.01
    half = 1.5 * math.sqrt(R * d)
    grid = Grid(n, n, 2 * half / n, 2 * half / n)
    x, y = grid.centres()
    gap = (x * x + y * y) / (2 * R) - d
    host = Engine(Isotropic(nu=0.3), grid, ("zz",))
    device = Engine(Isotropic(nu=0.3), grid, ("zz",), xp=xp)
    p1 = polonsky_keer(host.operator("z").apply, gap, tol=1e-14).traction[0]
    p2 = to_host(polonsky_keer(device.operator("z").apply, to_device(gap, xp), tol=1e-14).traction)[0]
    contact = p1 > 0.0
    assert np.array_equal(contact, p2 > 0.0) and contact.sum() > 20
    # on the contact, A_c p = −h_c; the difference of two pressures is A_c⁻¹ of their gap residuals
    A, kappa, cells = dense(host.operator("z").apply, (1, n, n), contact[None])
    h = gap.reshape(-1)[cells]
    bound = kappa * sum(residual(A, p.reshape(-1)[cells], -h) for p in (p1, p2))
    assert bound <= REQUIRED, kappa
    assert np.linalg.norm(p1 - p2) / np.linalg.norm(p1) <= bound


#: The scenes of issue 41's "done when" (circle, crystal ellipse, rectangle b/a = 1e-4, star, a mask),
#: on grids small enough for the dense bound; every quantity's solves. A mask scene's "mask" is the
#: path of ``write_mask``'s file.
SCENES = {
    "circle": {"shape": "circle", "n": 20, "nu": 0.3, "quantities": "tangential,normal"},
    "crystal_ellipse": {
        "shape": "ellipse",
        "aspect": 0.5,
        "n": 18,
        "material": "Cu",
        "quantities": "tangential,normal",
    },
    "rectangle_1e-4": {
        "shape": "rectangle",
        "aspect": 1e-4,
        "n": 24,
        "n_across": 3,
        "nu": 0.3,
        "quantities": "tangential",
    },
    "star": {"shape": "star", "n": 16, "nu": 0.45, "quantities": "tangential"},
    "mask": {"shape": "mask", "nu": 0.2, "quantities": "tangential,normal"},
}


def write_mask(folder: Path) -> str:
    """An L-shaped contact mask (.npy) in ``folder``; its path."""
    mask = np.zeros((14, 12), dtype=bool)
    mask[1:13, 1:5] = True
    mask[9:13, 1:11] = True
    path = folder / "l_shape.npy"
    np.save(path, mask)
    return str(path)


def scene_params(name: str, folder: Path) -> dict:
    """The fields of scene ``name`` of ``SCENES`` at tol 1e-14 (a mask written into ``folder``)."""
    params = {**SCENES[name], "tol": 1e-14}
    if params["shape"] == "mask":
        params["mask"] = write_mask(folder)
    return params
