"""One scene end to end: params → scene → grid and mask → plan → kernels → solves → record.

``solve(params)`` returns the JSON record of docs/design.md §4.1. Forces are in units of G·a² per unit
of traction and stiffnesses in units of G·a (a = semi-major extent = 1 on the grid).

The iterations run on the scene's device (``device``: numpy on the CPU, CuPy on a GPU;
``hpcontact.numerics.backend``). The grid, mask, kernels and records are the host's: each solve
copies its right-hand side and mask to the device once (``to_device``) and its traction back once
(``to_host``); resultants and the record are computed on the host from that copy.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from hpcontact import quantities as q
from hpcontact.errors import InputError
from hpcontact.geometry import Grid, crop_to_support, grid_for, load_mask, mask_grid, rasterize, self_affine_surface
from hpcontact.kernels.engine import Engine
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import Array, array_namespace, to_device, to_host
from hpcontact.numerics.conjugate_gradient import (
    BatchSolution,
    Solution,
    conjugate_gradient,
    conjugate_gradient_batch,
    polonsky_keer,
)
from hpcontact.numerics.convolution import COMPONENT_INDEX, FourierProductStack, block_table
from hpcontact.numerics.preconditioner import FourierPreconditioner
from hpcontact.plan import Solve, make_plan
from hpcontact.scene import Scene

#: The length unit of a mask scene (``geometry.mask_grid``), recorded with its results.
MASK_LENGTH_UNIT = "a = half the long side of the contact's bounding box (not of the image array)"


def discretize(scene: Scene) -> tuple[Grid, np.ndarray]:
    """The scene's grid and contact mask, cropped to the contact's bounding box."""
    shape = scene.shape
    if shape.name == "mask":
        mask = load_mask(shape.mask_path)
        grid = mask_grid(mask)
    elif shape.name == "rough":
        grid = grid_for(shape, scene.n, scene.n_across)
        mask = rough_patch(scene, grid)
    else:
        grid = grid_for(shape, scene.n, scene.n_across)
        mask = rasterize(shape, grid)
    if not mask.any():
        raise InputError("n", "a grid fine enough to put at least one cell in the contact", scene.n)
    cropped, cropped_grid = crop_to_support(mask, grid)
    return cropped_grid, cropped


def scene_namespace(scene: Scene) -> ModuleType:
    """The array namespace of the scene's ``device`` (InputError naming what a GPU lacks)."""
    return array_namespace(scene.device)


def rough_patch(scene: Scene, grid: Grid) -> np.ndarray:
    """Contact patch of a seeded self-affine rough disc (radius 1) pressed on a rigid flat.

    Heights h (rms ``scene.shape.rms``) on the unit disc; the flat approaches by one rms from
    first contact; Polonsky–Keer gives the pressure; the patch is where p > 0.
    """
    shape = scene.shape
    h = self_affine_surface(grid.nx, grid.ny, grid.dx, grid.dy, shape.hurst, shape.rms, shape.seed)
    x, y = grid.centres()
    inside = x * x + y * y <= 1.0
    separation = np.where(inside, h.max() - h, 1e3 * shape.rms) - shape.rms
    xp = scene_namespace(scene)
    engine = Engine(scene.material, grid, ("zz",), scene.threads, xp=xp)
    solution = polonsky_keer(engine.operator("z").apply, to_device(separation, xp), tol=max(scene.tol, 1e-8))
    return to_host(solution.traction)[0] > 0.0


def _preconditioner_of(scene: Scene, engine: Engine, solve: Solve) -> FourierPreconditioner | None:
    if not scene.precondition:
        return None
    return FourierPreconditioner(engine.grid, engine.green_function(solve.green), solve.components, xp=engine.xp)


def _force(traction: np.ndarray, components: str, grid: Grid) -> np.ndarray:
    """The resultant force (x, y, z) of a host traction (c, nx, ny) on ``components``."""
    force = np.zeros(3)
    for c, value in zip(components, q.resultant(traction, grid.cell_area)):
        force[COMPONENT_INDEX[c]] = value
    return force


def _run_solve(scene: Scene, engine: Engine, mask: np.ndarray, solve: Solve) -> tuple[np.ndarray, Solution]:
    """A bonded (or frictionless, for z alone) punch displaced by 1 along ``solve.load``; the
    solution's traction on the host."""
    op = engine.operator(solve.components, solve.green)
    rhs = np.zeros((len(solve.components),) + mask.shape)
    rhs[solve.components.index(solve.load)] = 1.0
    xp = engine.xp
    preconditioner = _preconditioner_of(scene, engine, solve)
    solution = conjugate_gradient(
        op.apply,
        to_device(rhs, xp),
        to_device(mask, xp),
        tol=scene.tol,
        precondition=None if preconditioner is None else preconditioner.apply,
    )
    solution.traction = to_host(solution.traction)
    return _force(solution.traction, solve.components, engine.grid), solution


@dataclass
class BatchSystem:
    """The linear solves of one batch as ``conjugate_gradient_batch`` takes them: the stacked
    operator and preconditioner (``FourierProductStack``), right-hand sides (B, c, nx, ny) and masks
    (B, nx, ny) on the device, and each scene's tolerance."""

    apply: Callable[[Array], Array]
    precondition: Callable[[Array], Array] | None
    rhs: Array
    mask: Array
    tol: list[float]

    def solve(self) -> BatchSolution:
        return conjugate_gradient_batch(self.apply, self.rhs, self.mask, tol=self.tol, precondition=self.precondition)


def batch_key(solve_: PunchSolve, preconditioner: FourierPreconditioner | None) -> tuple:
    """What the solves of one batch share: device, traction components, grid shape (nx, ny) (so the
    padded shape) and the preconditioner's grid."""
    _, engine, mask, s = solve_
    return (id(engine.xp), s.components, mask.shape, None if preconditioner is None else preconditioner.shape)


def operator_stacks(
    engines: Sequence[Any], plan_solves: Sequence[Any], preconditioners: Sequence[Any], shape: tuple[int, ...], xp: Any
) -> tuple[Any, Callable[[Array], Array] | None]:
    """The batched operator of solves that share components and padded grid (one
    ``FourierProductStack`` of each solve's kernel spectra, ``block_table``; one device copy per
    host spectrum, so scenes on one grid share theirs) and the application of their stacked
    Fourier preconditioners' symbols (None without preconditioners): what ``solve_batch`` and
    the batched levels of ``accuracy.level_batches`` iterate with."""
    on_device: dict[int, Array] = {}
    tables = []
    for e, s_ in zip(engines, plan_solves):
        table = block_table(s_.components, e.spectra(s_.components, s_.green), e.fft_shape)
        for row in table:
            for spectrum in row:
                if spectrum is not None and id(spectrum) not in on_device:
                    on_device[id(spectrum)] = to_device(spectrum, xp)
        tables.append([[None if x is None else on_device[id(x)] for x in row] for row in table])
    operator = FourierProductStack(tables, shape, engines[0].fft_shape, xp)
    if preconditioners[0] is None:
        return operator, None
    c = len(plan_solves[0].components)
    symbols = [[[p.symbol[i, j, ...] for j in range(c)] for i in range(c)] for p in preconditioners]
    return operator, FourierProductStack(symbols, shape, preconditioners[0].shape, xp).apply


def batch_system(solves: Sequence[PunchSolve], preconditioners: Sequence[FourierPreconditioner | None]) -> BatchSystem:
    """The ``BatchSystem`` of ``solves`` (one ``batch_key``; ``_preconditioner_of`` each): the
    spectra and symbols copied to the device once, a spectrum shared by all scenes kept once."""
    if len({batch_key(s, p) for s, p in zip(solves, preconditioners)}) != 1:
        raise ValueError("the solves of a batch share device, components, grid shape and preconditioner grid")
    scenes, engines, masks, plan_solves = zip(*solves)
    engine, s = engines[0], plan_solves[0]
    xp, shape, c = engine.xp, masks[0].shape, len(s.components)
    operator, precondition = operator_stacks(engines, plan_solves, preconditioners, shape, xp)
    rhs = np.zeros((len(solves), c) + shape)
    for k, s_ in enumerate(plan_solves):
        rhs[k, s_.components.index(s_.load)] = 1.0
    return BatchSystem(
        operator.apply, precondition, to_device(rhs, xp), to_device(np.stack(masks), xp), [sc.tol for sc in scenes]
    )


def _run_solve_batch(solves: Sequence[PunchSolve]) -> list[tuple[np.ndarray, Solution]]:
    """``_run_solve`` of each of ``solves``, those of one ``batch_key`` as one batch
    (``batch_system``); results in the order of ``solves``."""
    preconditioners = [_preconditioner_of(scene, engine, s) for scene, engine, _, s in solves]
    groups: dict[tuple, list[int]] = {}
    for index, (solve_, pre) in enumerate(zip(solves, preconditioners)):
        groups.setdefault(batch_key(solve_, pre), []).append(index)
    results: list[tuple[np.ndarray, Solution] | None] = [None] * len(solves)
    for members in groups.values():
        batch = batch_system([solves[m] for m in members], [preconditioners[m] for m in members]).solve()
        tractions = to_host(batch.traction)
        for k, m in enumerate(members):
            _, engine, _, s = solves[m]
            solution = Solution(tractions[k], batch.iterations[k], batch.residuals[k])
            results[m] = (_force(solution.traction, s.components, engine.grid), solution)
    return results


def solve(scene: Scene) -> dict[str, Any]:
    """Solve one scene on its grid; the record of docs/design.md §4.1 (keys that apply to the
    quantities asked). Build the scene from fields with ``Scene.from_params``."""
    return _solve_scenes([scene], lambda jobs: [_run_solve(*job) for job in jobs])[0]


def solve_batch(scenes: Sequence[Scene]) -> list[dict[str, Any]]:
    """Solve several scenes, their punch solves batched: one record per scene, in order, each
    ``solve``'s record of that scene up to rounding.

    The linear solves of all scenes that share a device, traction components, grid shape (nx, ny)
    and preconditioner grid are one ``conjugate_gradient_batch`` (``_run_solve_batch``): one
    batched FFT per operator application over their stacked tractions, with each scene's kernel
    spectra. Scenes of different grids are batched by grid, so any scenes may be given; a batch
    pays when its scenes share a grid (a sweep's points at one n and shape). The rest of a scene
    (discretization, kernels, the compliance proxy, indentation by Polonsky–Keer, the record) is
    ``solve``'s, one scene at a time. ``wall_time_s`` is a scene's own time plus an equal share of
    its batch's. A scene that fails its solve (``ConvergenceError``) fails the batch: the error
    names the scene's index in its group.
    """
    return _solve_scenes(list(scenes), _run_solve_batch)


#: One linear solve of a scene: (scene, engine, mask, solve), the arguments of ``_run_solve``.
PunchSolve = tuple[Scene, Engine, np.ndarray, Solve]


def _solve_scenes(
    scenes: list[Scene], run_solves: Callable[[list[PunchSolve]], list[tuple[np.ndarray, Solution]]]
) -> list[dict[str, Any]]:
    """The records of ``scenes``, their punch solves run by ``run_solves`` (all scenes' at once:
    one result per solve, in order)."""
    setups, solves, own_time = [], [], []
    for scene in scenes:
        started = time.perf_counter()
        punch = [q_ for q_ in scene.quantities if q_ != "indentation"]
        if punch:
            grid, mask = discretize(scene)
            plan = make_plan(scene, mask, grid)
            engine = Engine(scene.material, grid, plan.kernels, scene.threads, xp=scene_namespace(scene))
            solves += [(scene, engine, mask, s) for s in plan.solves if s.name != "indentation_polonsky_keer"]
            setups.append((plan, grid, mask, engine))
        else:
            setups.append((make_plan(scene, np.ones((1, 1), dtype=bool), Grid(1, 1, 1.0, 1.0)), None, None, None))
        own_time.append(time.perf_counter() - started)
    started = time.perf_counter()
    results = iter(run_solves(solves))
    shared_time = (time.perf_counter() - started) / max(len(scenes), 1)
    records = []
    for scene, (plan, grid, mask, engine), own in zip(scenes, setups, own_time):
        started = time.perf_counter()
        record: dict[str, Any] = {}
        iterations, residual = 0, 0.0
        if engine is not None:
            record.update(_grid_fields(grid))
            record["contact_cells"] = int(mask.sum())
            if scene.shape.name == "mask":  # the data set then says which length a is
                record["length_unit"] = MASK_LENGTH_UNIT
            forces: dict[str, np.ndarray] = {}
            for s in plan.solves:
                if s.name == "indentation_polonsky_keer":
                    continue
                force, solution = next(results)
                forces[s.name] = force
                iterations += solution.iterations
                residual = max(residual, solution.residual)
            record.update(q.stiffness_record(forces, scene.quantities, scene.material, noise=scene.tol))
            if "compliance" in scene.quantities:
                record.update(_compliance_proxy(engine, mask))
        if "indentation" in scene.quantities:
            indentation, solution, sphere_grid = _indentation(scene)
            if engine is not None:  # nx ny dx dy contact_cells describe the punch's grid
                indentation.pop("contact_cells")
            else:
                record.update(_grid_fields(sphere_grid))
            record.update(indentation)
            iterations += solution.iterations
            residual = max(residual, solution.residual)
        record["iterations"] = iterations
        record["residual"] = residual
        record["plan"] = plan.as_dict()
        record["wall_time_s"] = own + shared_time + time.perf_counter() - started
        _check_finite(record)
        records.append(record)
    return records


def _compliance_proxy(engine: Engine, mask: np.ndarray) -> dict[str, float]:
    """Li 2017 §3.2: uniform unit traction along x and y on the contact, mean displacements."""
    isotropic = isinstance(engine.material, Isotropic)  # Re H = H on its tangential blocks
    op = engine.operator("xy" if {"xy", "Re xy"} & set(engine.kernels) else "x", "H" if isotropic else "Re H")
    area = mask.sum() * engine.grid.cell_area
    mean = np.zeros((2, 2))
    for j in range(2):
        if op.components == "xy":
            t = np.zeros((2,) + mask.shape)
            t[j] = mask
            u = to_host(op.apply(to_device(t, engine.xp)))
            mean[:, j] = [u[0][mask].mean(), u[1][mask].mean()]
        else:
            mean[j, j] = to_host(op.apply(to_device(mask[None].astype(float), engine.xp)))[0][mask].mean()
    K = q.compliance_proxy(mean, np.array([area, area]))
    return {f"proxy_K_{a}{b}": float(K[i, j]) for i, a in enumerate("xy") for j, b in enumerate("xy")}


def _indentation(scene: Scene) -> tuple[dict[str, float], Solution, Grid]:
    """Rigid sphere (radius R, approach d) pressed on the half-space: Polonsky–Keer contact.

    The grid (``scene.n`` cells a side) spans 1.5 Hertz radii sqrt(R d) each way; the gap is
    the exact sphere R − sqrt(R² − r²) minus d (it differs from Hertz's paraboloid by r⁴/8R³,
    a relative O(d/R) effect on the load). The contact ellipse is fitted from the pressure's
    second moments (a Hertzian pressure on an ellipse of semi-axes a ≥ b has moments a²/5 and
    b²/5 along its axes): smoother under refinement than the staircase of contact cells.
    """
    R, d = scene.radius, scene.depth
    half = 1.5 * math.sqrt(R * d)
    h = 2.0 * half / scene.n
    grid = Grid(scene.n, scene.n, h, h)
    x, y = grid.centres()
    r2 = np.minimum(x * x + y * y, R * R)
    gap = r2 / (R + np.sqrt(R * R - r2)) - d  # = R − sqrt(R² − r²) without cancellation (d/R ≥ 1e-15)
    xp = scene_namespace(scene)
    engine = Engine(scene.material, grid, ("zz",), scene.threads, xp=xp)
    solution = polonsky_keer(engine.operator("z").apply, to_device(gap, xp), tol=scene.tol)
    solution.traction = to_host(solution.traction)
    p = solution.traction[0]
    contact = p > 0.0
    if contact[0, :].any() or contact[-1, :].any() or contact[:, 0].any() or contact[:, -1].any():
        raise FloatingPointError("indentation contact reaches the grid edge; the grid is too small")
    load = float(p.sum())
    xc, yc = (p * x).sum() / load, (p * y).sum() / load
    cov = (
        np.array([[(p * (x - xc) ** 2).sum(), (p * (x - xc) * (y - yc)).sum()], [0.0, (p * (y - yc) ** 2).sum()]])
        / load
    )
    cov[1, 0] = cov[0, 1]
    values, vectors = np.linalg.eigh(cov)
    out = {
        "contact_cells": int(contact.sum()),
        "load": float(p.sum() * grid.cell_area),
        "contact_area": float(contact.sum() * grid.cell_area),
        "max_pressure": float(p.max()),
        "ellipse_b_over_a": float(math.sqrt(values[0] / values[1])),
        "ellipse_angle_deg": float(math.degrees(math.atan2(vectors[1, 1], vectors[0, 1])) % 180.0),
    }
    return out, solution, grid


def _grid_fields(grid: Grid) -> dict[str, float]:
    return {"nx": grid.nx, "ny": grid.ny, "dx": grid.dx, "dy": grid.dy}


def _check_finite(record: Mapping[str, Any]) -> None:
    for key, value in record.items():
        if isinstance(value, float) and not math.isfinite(value):
            raise FloatingPointError(f"{key} is not finite ({value})")
