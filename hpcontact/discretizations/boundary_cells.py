r"""Boundary cells that follow the contact's edge: coverage weights (``hpcontact.accuracy`` refines them).

Why
---
The engine puts a cell in the contact when its centre lies inside the shape (docs/design.md §2.2); the
staircase area of a curved shape then fluctuates with n (the Gauss circle problem) and the grid
sequence cannot be extrapolated (``hpcontact.accuracy``). Here every cell the shape touches
takes part, weighted by the fraction of it the shape covers.

Coverage-weighted boundary cells
--------------------------------
Here a cell carries its exact covered fraction f ∈ (0, 1] of the shape (closed form for circles,
ellipses and rectangles in their own axes, sub-sampled otherwise), and a partly covered cell is
made more compliant: the bonded-punch system A t = u on the cells with f > 0 becomes

    (A + D) t = u,        D_ii = A_ii (1 − f_i)/f_i        (diagonal, ≥ 0),

i.e. the self-compliance of cell i is A_ii / f_i. A cell that is barely touched (f → 0) carries
no force, a full cell is unchanged, and the system stays symmetric positive definite, so the
engine's conjugate gradients and FFT operator apply unchanged (the preconditioner is scaled by
(1 + D_ii/A_ii)^(−1/2) on both sides). The discrete edge now moves continuously with the true
one, the fluctuation disappears (circle, nu = 0.3: n·(K_xx error) = −0.2125, −0.2084, −0.2035,
−0.2015, −0.1994 at n = 32, 64, 128, 256, 512, where centre-in-cell masks give −0.084, −0.116,
−0.110, −0.234, −0.219) and the error is a smooth expansion c₁ h + c₂ h^q + … with q ≈ 1.5–3.
Per grid it costs no more: CG needs about as many iterations, and the exact coverage of a
circle or ellipse is a closed form (``benchmarks/boundary_treatment.py``).

Strip cells
-----------
``covered_solve(params, strategy="strip")`` (or ``"auto"``) solves unturned rectangles of
b/a ≤ ``strip_cells.MAX_ASPECT`` and unturned ellipses of any aspect as n
strips across which the traction has the plane punch's profile f_i/(π√(b(x)² − y²)), graded
toward the ends (``hpcontact.discretizations.strip_cells``): one dense Galerkin system of n unknowns per load
direction.

Singular cells
--------------
``covered_solve(params, strategy="singular")`` (or ``"auto"``) solves unturned circles and
ellipses instead with cells that carry the punch's edge singularity, a Galerkin discretization
whose error is 200 to several thousand times smaller per grid but not a smooth expansion in h
(``hpcontact.discretizations.singular_cells``; ``benchmarks/edge_order.py`` compares the two,
docs/validation.md §"Singular cells").
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from hpcontact import quantities as q
from hpcontact.discretizations import singular_cells, strip_cells
from hpcontact.errors import InputError
from hpcontact.geometry import Grid, Shape, crop_to_support, grid_for, load_mask, mask_grid
from hpcontact.kernels.engine import Engine
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import array_namespace, to_device, to_host
from hpcontact.numerics.conjugate_gradient import conjugate_gradient
from hpcontact.numerics.convolution import COMPONENT_INDEX
from hpcontact.numerics.preconditioner import FourierPreconditioner
from hpcontact.plan import Plan, Solve, make_plan
from hpcontact.scene import Scene

__all__ = [
    "COVERAGE_ROUNDING",
    "MIN_COVERAGE",
    "SINGULAR_SUPPORTED",
    "STRATEGIES",
    "SUBSAMPLES",
    "SUPPORTED",
    "CoverageSystem",
    "coverage",
    "coverage_solved",
    "coverage_system",
    "covered_record",
    "covered_solve",
    "mask_cells",
    "resolved_strategy",
    "strip_applies",
]

MIN_COVERAGE = 1e-12  # cells covered less than this are left out (D_ii would overflow)
COVERAGE_ROUNDING = (
    1e-9  # closed-form coverage loses ~n²·eps to differences (~6e-11 at n = 1024: docs/validation.md §"Boundary cells")
)
SUBSAMPLES = 32  # sub-samples per cell side where the coverage has no closed form
SUPPORTED = q.names_where(lambda q: q.refinable)
SINGULAR_SUPPORTED = q.names_where(lambda q: q.singular_cells)  # one scalar block per load direction
STRATEGIES = ("auto", "singular", "strip", "coverage")


# ------------------------------------------------------------------------------------------
# coverage
# ------------------------------------------------------------------------------------------
def _half_ellipse_integral(u: np.ndarray) -> np.ndarray:
    """S(u) = ∫₀^u (1 − t²)^½ dt = (u (1 − u²)^½ + asin u)/2, with u clamped to [−1, 1]."""
    u = np.clip(u, -1.0, 1.0)
    return 0.5 * (u * np.sqrt((1.0 - u) * (1.0 + u)) + np.arcsin(u))


def _ellipse_coverage(grid: Grid, a: float, b: float) -> np.ndarray:
    """Exact covered fraction of every cell by the ellipse x²/a² + y²/b² ≤ 1 (centred, unturned).

    With Y(x) = b (1 − x²/a²)^½, the area of {(x, y) in the column [x₁, x₂], y ≤ η, inside}
    is H(η) = ∫ Y dx + sgn(η) ∫ min(|η|, Y) dx, both in closed form through
    S(u) = ∫₀^u (1 − t²)^½ dt; a cell's area is H(y₂) − H(y₁). Lengths are scaled by (a, b)
    so thin ellipses (b/a = 1e-12) lose nothing.
    """
    u1 = ((grid.x - 0.5 * grid.dx) / a)[:, None]
    u2 = ((grid.x + 0.5 * grid.dx) / a)[:, None]
    edges = (np.arange(grid.ny + 1) - 0.5 * grid.ny) * grid.dy / b  # row edges over b
    v = edges[None, :]
    gamma = np.minimum(np.abs(v), 1.0)
    big_u = np.sqrt((1.0 - gamma) * (1.0 + gamma))  # |u| where Y = |η|
    full = _half_ellipse_integral(u2) - _half_ellipse_integral(u1)  # ∫ Y dx / (a b)
    lo, hi = np.maximum(u1, -big_u), np.minimum(u2, big_u)
    inner = np.maximum(hi - lo, 0.0)
    s_inner = np.where(hi > lo, _half_ellipse_integral(hi) - _half_ellipse_integral(lo), 0.0)
    capped = gamma * inner + (full - s_inner)  # ∫ min(|η|, Y) dx / (a b)
    H = full + np.sign(v) * capped
    area = (H[:, 1:] - H[:, :-1]) * (a * b)
    return np.clip(area / (grid.dx * grid.dy), 0.0, 1.0)


def _rectangle_coverage(grid: Grid, X: float, Y: float) -> np.ndarray:
    """Exact covered fraction by the axis-aligned rectangle |x| ≤ X, |y| ≤ Y."""
    x, y = grid.x, grid.y
    fx = np.clip(np.minimum(x + 0.5 * grid.dx, X) - np.maximum(x - 0.5 * grid.dx, -X), 0.0, grid.dx) / grid.dx
    fy = np.clip(np.minimum(y + 0.5 * grid.dy, Y) - np.maximum(y - 0.5 * grid.dy, -Y), 0.0, grid.dy) / grid.dy
    return fx[:, None] * fy[None, :]


def _sampled_coverage(shape: Shape, grid: Grid, subsamples: int) -> np.ndarray:
    """Covered fractions by sub-sampling: 5 × 5 probes find the boundary cells (and their
    neighbours), ``subsamples²`` midpoint samples measure them. Error per cell ≲ 1/subsamples."""
    from scipy.ndimage import binary_dilation

    x, y = grid.centres()
    probes = np.linspace(-0.5, 0.5, 5)
    inside_any = np.zeros(x.shape, dtype=bool)
    inside_all = np.ones(x.shape, dtype=bool)
    for a in probes:
        for b in probes:
            hit = shape.contains(x + a * grid.dx, y + b * grid.dy)
            inside_any |= hit
            inside_all &= hit
    f = inside_all.astype(np.float64)
    boundary = binary_dilation(inside_any & ~inside_all) & ~inside_all
    ii, jj = np.nonzero(boundary)
    s = (np.arange(subsamples) + 0.5) / subsamples - 0.5
    sx, sy = np.meshgrid(s * grid.dx, s * grid.dy, indexing="ij")
    # 2^19 sample points per batch: ~70 B a point in ``contains``' temporaries, ~36 MiB (2^22 took
    # ~110 MiB on 256 cells, 225 on 512, in the same CPU time; docs/performance.md §"Accuracy tasks")
    step = max(1, 2**19 // subsamples**2)
    for k in range(0, ii.size, step):
        i, j = ii[k : k + step], jj[k : k + step]
        hit = shape.contains(x[i, j][:, None, None] + sx[None], y[i, j][:, None, None] + sy[None])
        f[i, j] = hit.mean(axis=(1, 2))
    return f


def coverage(shape: Shape, grid: Grid, subsamples: int = SUBSAMPLES) -> np.ndarray:
    """Fraction f ∈ [0, 1] of every cell of ``grid`` that the shape covers, shape (nx, ny).

    Exact (to rounding) for circles, ellipses and rectangles that are not turned; sub-sampled
    (``subsamples`` × ``subsamples`` points per boundary cell) for turned shapes, polygons and stars.
    """
    if shape.angle_deg == 0.0:
        if shape.name == "circle":
            return _ellipse_coverage(grid, 1.0, 1.0)
        if shape.name == "ellipse":
            return _ellipse_coverage(grid, 1.0, shape.aspect)
        if shape.name == "rectangle":
            return _rectangle_coverage(grid, 1.0, shape.aspect)
    if shape.name in ("rough", "mask"):
        raise InputError("shape", "a shape with a boundary that can be refined (not rough or mask)", shape.name)
    return _sampled_coverage(shape, grid, subsamples)


def _crop(f: np.ndarray, grid: Grid) -> tuple[np.ndarray, Grid]:
    support = f > 0.0
    if not support.any():
        raise InputError("n", "a grid fine enough to put at least one cell in the contact", grid.nx)
    ii = np.flatnonzero(support.any(axis=1))
    jj = np.flatnonzero(support.any(axis=0))
    sub = f[ii[0] : ii[-1] + 1, jj[0] : jj[-1] + 1]
    return sub, Grid(nx=sub.shape[0], ny=sub.shape[1], dx=grid.dx, dy=grid.dy)


# ------------------------------------------------------------------------------------------
# one coverage-weighted solve
# ------------------------------------------------------------------------------------------
def _self_compliance(engine: Any, component: str) -> float:
    """A_ii: displacement of a cell's centre per unit traction on the cell itself (block cc)."""
    block = component + component
    if block not in engine.kernels and block == "yy":  # nu = 0: yy is the xx kernel
        block = "xx"
    g = engine.grid
    return float(engine.centred_block(block)[g.nx - 1, g.ny - 1])


def _with_all_solves(plan: Plan, scene: Scene) -> Plan:
    """The plan without the x ↔ y mirror shortcut (coverage can break a mask's symmetry)."""
    solves = list(plan.solves)
    names = {s.name for s in solves}
    nu0 = isinstance(scene.material, Isotropic) and scene.material.nu == 0.0
    if "tangential_x" in names and "tangential_y" not in names:
        solves.insert(
            [s.name for s in solves].index("tangential_x") + 1, Solve("tangential_y", "y" if nu0 else "xy", "y")
        )
    if "coupled_x" in names and "coupled_y" not in names:
        solves.insert([s.name for s in solves].index("coupled_x") + 1, Solve("coupled_y", "xyz", "y"))
    derived = tuple(d for d in plan.derived if "mirror" not in d and "x <-> y" not in d)
    return dataclasses.replace(plan, solves=tuple(solves), derived=derived)


def covered_solve(scene: Scene, strategy: str = "coverage") -> dict[str, Any]:
    """``hpcontact.problems.contact.solve`` on boundary cells that follow the contact's edge.

    ``strategy``: ``"coverage"`` — coverage-weighted cells (module docstring), every shape and
    material; ``"singular"`` — cells that carry the edge singularity w = (1 − x²/a² − y²/b²)^(−½)
    (``hpcontact.discretizations.singular_cells``: unturned circles and ellipses on an isotropic half-space,
    quantities tangential and normal); ``"auto"`` — singular where it applies, coverage
    otherwise. The default stays ``"coverage"``; ``hpcontact.accuracy.solve_to_accuracy`` with
    ``"auto"`` (``hpcontact solve --accuracy``) takes singular cells on near-square grids where they
    apply and estimates their error from expansions led by order 1 only (their error is ≲ C/n
    without a steady sign: ``hpcontact.discretizations.singular_cells``).

    Same record keys (``K_*``, ``K_max``, ``K_a_over_K_b``, ``normalized_*``, ``iterations``,
    ``residual``, ``wall_time_s``, ``nx ny dx dy``, ``plan``) plus ``contact_area`` = Σ f dA,
    which is exact where the coverage is, and ``boundary`` (the strategy used).
    """
    started = time.perf_counter()
    strategy = resolved_strategy(scene, strategy)
    solved = {"singular": _singular_forces, "strip": _strip_forces, "coverage": _coverage_forces}[strategy](scene)
    return covered_record(scene, strategy, solved, started)


def resolved_strategy(scene: Scene, strategy: str) -> str:
    """The boundary cells ``covered_solve`` takes for ``scene`` (``auto`` resolved); InputError
    where ``strategy`` does not apply or a quantity is not one coverage-weighted cells solve."""
    if strategy not in STRATEGIES:
        raise InputError("strategy", f"one of {', '.join(STRATEGIES)}", strategy)
    grid = grid_for(scene.shape, scene.n, scene.n_across) if scene.shape.name != "mask" else None
    singular = (
        set(scene.quantities) <= set(SINGULAR_SUPPORTED)
        and grid is not None
        and singular_cells.supports(scene.shape, scene.material, grid)
    )
    strip = strip_applies(scene)
    if strategy == "singular" and not singular:
        raise InputError(
            "strategy",
            "singular only for unturned circles and ellipses, isotropic, cells dy/dx in [1/2, 2], quantities tangential/normal",
            strategy,
        )
    if strategy == "strip" and not strip:
        raise InputError("strategy", strip_cells.SUPPORTED_TEXT, strategy)
    if strategy == "auto":
        strategy = "singular" if singular else "strip" if strip else "coverage"
    unsupported = [x for x in scene.quantities if x not in SUPPORTED]
    if unsupported:
        raise InputError("quantities", f"{', '.join(SUPPORTED)} with coverage-weighted cells", unsupported[0])
    return strategy


def covered_record(scene: Scene, strategy: str, solved: _Solved, started: float) -> dict[str, Any]:
    """``covered_solve``'s record of ``scene`` solved on ``strategy``'s cells (``solved``);
    ``wall_time_s`` from ``started`` (``time.perf_counter()``)."""
    grid, f, mask = solved.grid, solved.coverage, solved.mask
    record: dict[str, Any] = {"nx": grid.nx, "ny": grid.ny, "dx": grid.dx, "dy": grid.dy}
    record["contact_cells"] = int(mask.sum())
    record["contact_area"] = float(f.sum() * grid.cell_area)
    record.update(q.stiffness_record(solved.forces, scene.quantities, scene.material, noise=scene.tol))
    record["iterations"] = solved.iterations
    record["residual"] = solved.residual
    record["plan"] = {**solved.plan.as_dict(), "boundary": solved.description}
    record["boundary"] = strategy
    record["wall_time_s"] = time.perf_counter() - started
    for key, value in record.items():
        if isinstance(value, float) and not math.isfinite(value):
            raise FloatingPointError(f"{key} is not finite ({value})")
    return record


@dataclasses.dataclass
class _Solved:
    """What a boundary strategy hands to the record: resultant forces per solve and the grid."""

    grid: Grid
    coverage: np.ndarray
    mask: np.ndarray
    plan: Plan
    forces: dict[str, np.ndarray]
    iterations: int
    residual: float
    description: str


@dataclasses.dataclass
class CoverageSystem:
    """The linear systems of one coverage-weighted solve, none solved yet: per solve of ``plan``,
    (A + D) t = u on the mask (module docstring: D_ii = A_ii (1 − f_i)/f_i), A the ``engine``'s
    operator on the scene's device, D ``damping[k]`` (c, nx, ny) and the Fourier preconditioner's rows
    scaled by ``weights[k]`` (c, nx, ny) = 1/sqrt(1 + D_ii/A_ii), both on the device; ``rhs[k]`` on the
    host. ``precondition``: whether the scene asks for the preconditioner."""

    grid: Grid
    coverage: np.ndarray
    mask: np.ndarray
    plan: Plan
    engine: Engine
    damping: list[Any]
    weights: list[Any]
    rhs: list[np.ndarray]
    precondition: bool

    def operator(self, k: int) -> Callable[[Any], Any]:
        """t ↦ (A + D) t of solve k."""
        op, damping = self.engine.operator(self.plan.solves[k].components, self.plan.solves[k].green), self.damping[k]
        return lambda t: op.apply(t) + damping * t

    def preconditioner(self, k: int) -> FourierPreconditioner | None:
        """The Fourier preconditioner of solve k (None without one); applied as w P(w r)."""
        if not self.precondition:
            return None
        s = self.plan.solves[k]
        return FourierPreconditioner(self.grid, self.engine.green_function(s.green), s.components, xp=self.engine.xp)


def coverage_system(scene: Scene) -> CoverageSystem:
    """The :class:`CoverageSystem` of ``scene`` on its grid (the mirror shortcut dropped unless the
    coverage is x ↔ y symmetric to rounding)."""
    if scene.shape.name == "mask":
        f, grid = _refined_mask(scene.shape.mask_path, scene.n)
    else:
        full_grid = grid_for(scene.shape, scene.n, scene.n_across)
        f, grid = _crop(_thresholded(coverage(scene.shape, full_grid)), full_grid)
    mask = f > 0.0
    plan = make_plan(scene, mask, grid)
    symmetric = grid.dx == grid.dy and f.shape[0] == f.shape[1] and float(np.max(np.abs(f - f.T))) <= COVERAGE_ROUNDING
    if symmetric:  # x <-> y symmetric to rounding (closed-form coverage is evaluated by columns)
        f = 0.5 * (f + f.T)
    else:
        plan = _with_all_solves(plan, scene)
    xp = array_namespace(scene.device)  # the iterations on the scene's device; forces come back to the host
    engine = Engine(scene.material, grid, plan.kernels, scene.threads, xp=xp)
    phi = np.where(mask, (1.0 - f) / np.where(mask, f, 1.0), 0.0)  # D_ii / A_ii
    scale = np.where(mask, 1.0 / np.sqrt(1.0 + phi), 0.0)
    damping, weights, rhs = [], [], []
    for s in plan.solves:
        damping.append(to_device(np.stack([_self_compliance(engine, c) * phi for c in s.components]), xp))
        weights.append(to_device(np.stack([scale] * len(s.components)), xp))
        b = np.zeros((len(s.components),) + mask.shape)
        b[s.components.index(s.load)] = 1.0
        rhs.append(b)
    return CoverageSystem(grid, f, mask, plan, engine, damping, weights, rhs, scene.precondition)


def coverage_solved(system: CoverageSystem, solutions: Sequence[Any]) -> _Solved:
    """What the solutions of ``system``'s solves (one per solve, in order: ``traction`` on the
    device, ``iterations``, ``residual``) give the record: the resultant forces, on the host."""
    forces: dict[str, np.ndarray] = {}
    iterations, residual = 0, 0.0
    for s, solution in zip(system.plan.solves, solutions):
        force = np.zeros(3)
        for c, value in zip(s.components, q.resultant(to_host(solution.traction), system.grid.cell_area)):
            force[COMPONENT_INDEX[c]] = value
        forces[s.name] = force
        iterations += solution.iterations
        residual = max(residual, solution.residual)
    description = "coverage-weighted cells, D_ii = A_ii (1 - f)/f"
    return _Solved(system.grid, system.coverage, system.mask, system.plan, forces, iterations, residual, description)


def _coverage_forces(scene: Scene) -> _Solved:
    """Coverage-weighted cells: (A + D) t = u, D_ii = A_ii (1 − f)/f (module docstring), one CG per solve."""
    system = coverage_system(scene)
    xp = system.engine.xp
    solutions = []
    for k in range(len(system.plan.solves)):
        fourier = system.preconditioner(k)
        precondition = None
        if fourier is not None:
            precondition = lambda r, fourier=fourier.apply, w=system.weights[k]: w * fourier(w * r)
        solutions.append(
            conjugate_gradient(
                system.operator(k),
                to_device(system.rhs[k], xp),
                to_device(system.mask, xp),
                tol=scene.tol,
                precondition=precondition,
            )
        )
    return coverage_solved(system, solutions)


def singular_block_solve(cells: singular_cells.SingularCells, block: str, tol: float, precondition: bool = True) -> Any:
    """CG on one block's Galerkin system Ã s = 1 of singular cells (``SingularCells.system``),
    with the Fourier preconditioner on rows scaled to a common diagonal unless ``precondition``
    is false; returns the solver's result (``traction`` s, ``iterations``, ``residual``)."""
    system = cells.system(block)
    apply_preconditioner = None
    if precondition:
        green = Engine(cells.material, cells.grid, ()).green_function("H")
        fourier = FourierPreconditioner(cells.grid, green, block[0]).apply
        typical = float(np.median(system.diagonal[cells.mask]))
        w = np.where(cells.mask, np.sqrt(typical / np.where(cells.mask, system.diagonal, 1.0)), 0.0)
        apply_preconditioner = lambda r: w * fourier(w * r)
    rhs = np.ones((1,) + cells.mask.shape)
    return conjugate_gradient(system.apply, rhs, cells.mask, tol=tol, precondition=apply_preconditioner)


def _block_solves(scene: Scene) -> list[tuple[str, str]]:
    """(solve name, block) per load direction asked, for singular and strip cells: one scalar
    block each (xx, yy for tangential, zz for normal)."""
    solves = []
    if "tangential" in scene.quantities:
        solves += [("tangential_x", "xx"), ("tangential_y", "yy")]
    if "normal" in scene.quantities:
        solves.append(("normal_z", "zz"))
    return solves


def strip_applies(scene: Scene) -> bool:
    """Whether strip cells (``hpcontact.discretizations.strip_cells``) solve ``scene``: an unturned rectangle of
    b/a ≤ ``strip_cells.MAX_ASPECT`` or an unturned ellipse,
    isotropic, quantities tangential and normal only."""
    return strip_cells.supports(scene.shape, scene.material) and set(scene.quantities) <= set(SINGULAR_SUPPORTED)


def _singular_forces(scene: Scene) -> _Solved:
    """Singular cells (``hpcontact.discretizations.singular_cells``): one Galerkin solve per load direction.

    For the circle and ellipse the cross entries vanish exactly (the traction c·w along x gives
    no y displacement in the contact, Mindlin 1949), so each direction is one scalar block.
    """
    solves = _block_solves(scene)
    cells = singular_cells.SingularCells(scene.shape, scene.n, scene.n_across, scene.material)
    forces: dict[str, np.ndarray] = {}
    iterations, residual = 0, 0.0
    for name, block in solves:
        solution = singular_block_solve(cells, block, scene.tol, scene.precondition)
        force = np.zeros(3)
        force[COMPONENT_INDEX[block[0]]] = cells.force(solution.traction)
        forces[name] = force
        iterations += solution.iterations
        residual = max(residual, solution.residual)
    f = coverage(scene.shape, cells.grid)
    plan = make_plan(scene, cells.mask, cells.grid)
    description = "singular cells: Galerkin on w = (1 - x^2/a^2 - y^2/b^2)^(-1/2) per cell, precorrected FFT"
    return _Solved(cells.grid, f, cells.mask, plan, forces, iterations, residual, description)


def _strip_forces(scene: Scene) -> _Solved:
    """Strip cells (``hpcontact.discretizations.strip_cells``): one dense Galerkin solve per load direction on
    ``scene.n`` strips (the cross entries vanish: the profile is symmetric across). The grid
    reported is n × 1 with dx the mean strip length and dy the width."""
    solves = _block_solves(scene)
    cells = strip_cells.StripCells(
        scene.shape.aspect, scene.n, scene.material, tuple(block for _, block in solves), shape=scene.shape.name
    )
    forces: dict[str, np.ndarray] = {}
    residual = 0.0
    for name, block in solves:
        stiffness, _, block_residual = cells.solve(block)
        force = np.zeros(3)
        force[COMPONENT_INDEX[block[0]]] = stiffness
        forces[name] = force
        residual = max(residual, block_residual)
    grid = Grid(nx=scene.n, ny=1, dx=2.0 / scene.n, dy=2.0 * scene.shape.aspect)  # dx: the mean strip
    mask = np.ones((scene.n, 1), dtype=bool)
    description = (
        f"strip cells: Galerkin on f_i/(pi sqrt(b(x)^2 - y^2)) per strip, {scene.n} strips graded "
        f"x = sgn(xi)(1 - (1 - |xi|)^{strip_cells.GRADING:g}), dense Cholesky"
    )
    plan = Plan(
        kernels=cells.kernels,
        solves=tuple(Solve(name, block[0], block[0]) for name, block in solves),
        derived=(),
        kernel_source="isotropic point-force solutions averaged over the strip profile (hpcontact.discretizations.strip_cells)",
    )
    return _Solved(grid, mask.astype(np.float64), mask, plan, forces, 0, residual, description)


def mask_cells(path: str | None) -> tuple[np.ndarray, Grid]:
    """The contact of a mask file cropped to its bounding box, on its own grid (unit a: half
    the long side of the contact, ``geometry.mask_grid``)."""
    mask = load_mask(path)
    return crop_to_support(mask, mask_grid(mask))


def _refined_mask(path: str | None, n: int) -> tuple[np.ndarray, Grid]:
    """Coverage of a mask's contact on a grid of ``n`` cells along its long side.

    A mask is a union of square pixels: each pixel is split into k × k cells (k = n / the
    pixels along the long side, an integer), so the coverage is exact (0 or 1) and the
    sequence of grids converges to the pixelated contact itself.
    """
    pixels, grid = mask_cells(path)
    long_side = max(pixels.shape)
    if n % long_side:
        raise InputError("n", f"a multiple of the mask contact's long side ({long_side} pixels)", n)
    k = n // long_side
    f = np.kron(pixels, np.ones((k, k))).astype(np.float64)
    return f, Grid(nx=f.shape[0], ny=f.shape[1], dx=grid.dx / k, dy=grid.dy / k)


def _thresholded(f: np.ndarray) -> np.ndarray:
    return np.where(f >= MIN_COVERAGE, f, 0.0)
