"""A grid level of several accuracy runs solved as one batch on a device (the ``LevelSolver`` of a GPU
rank: ``refinement.solve_to_accuracy_batch``; issue 41 item 2).

The levels on coverage-weighted cells (``discretizations.boundary_cells.coverage_system``) whose solves
share a device, traction components, cropped grid shape and preconditioning are one
``conjugate_gradient_batch``: the operators (A_k + D_k) t_k as one ``FourierProductStack`` (a batched
FFT over the stacked tractions, each scene's kernel spectra) plus the stacked damping D_k, the
preconditioner w_k P_k (w_k r_k) as the stacked symbols and weights. Every other level (strips,
singular cells) is solved alone. Each record is ``covered_solve``'s of the level alone up to rounding
(the batched CG's reductions and transform differ from the single path's by round-off: tests bound it).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from hpcontact.discretizations.boundary_cells import (
    CoverageSystem,
    coverage_solved,
    coverage_system,
    covered_record,
    resolved_strategy,
)
from hpcontact.numerics.backend import to_device
from hpcontact.numerics.conjugate_gradient import Solution, conjugate_gradient_batch
from hpcontact.numerics.convolution import clear_cache
from hpcontact.numerics.preconditioner import FourierPreconditioner
from hpcontact.problems.contact import operator_stacks
from hpcontact.scene import Scene


def solve_levels_batched(levels: Sequence[tuple[Any, int, int]]) -> list[Any]:
    """The ``LevelSolver`` that batches coverage-weighted levels (module docstring): [(run, n,
    n_across)] → each level's record or the ``Exception`` it raised, in order. A batch that raises
    is solved again one level at a time, so a failing level is that level's alone."""
    from hpcontact.accuracy.refinement import solve_levels_one_by_one

    results: list[Any] = [None] * len(levels)
    coverage: list[tuple[int, Scene, CoverageSystem, float]] = []
    for index, (run, n, n_across) in enumerate(levels):
        started = time.perf_counter()
        try:
            scene = run.level_scene(n, n_across)
            if resolved_strategy(scene, run.strategy) != "coverage":
                (results[index],) = solve_levels_one_by_one([levels[index]])
                continue
            coverage.append((index, scene, coverage_system(scene), started))
        except Exception as error:  # noqa: BLE001 - this level's result; the others go on
            results[index] = error
    solves = [(i, k) for i, (_, _, system, _) in enumerate(coverage) for k in range(len(system.plan.solves))]
    groups: dict[tuple, list[tuple[int, int]]] = {}
    preconditioners: dict[tuple[int, int], FourierPreconditioner | None] = {}
    for i, k in solves:
        system = coverage[i][2]
        s, pre = system.plan.solves[k], system.preconditioner(k)
        preconditioners[(i, k)] = pre
        key = (id(system.engine.xp), s.components, system.mask.shape, None if pre is None else pre.shape)
        groups.setdefault(key, []).append((i, k))
    solutions: dict[tuple[int, int], Solution] = {}
    failed: set[int] = set()
    for members in groups.values():
        try:
            batch = _batch_solve([(coverage[i][2], k, coverage[i][1].tol, preconditioners[(i, k)]) for i, k in members])
        except Exception:  # noqa: BLE001 - this group's levels alone: a failing one gives its own error
            failed.update(i for i, _ in members)
            continue
        for (i, k), solution in zip(members, batch):
            solutions[(i, k)] = solution
    for i, (index, scene, system, started) in enumerate(coverage):
        if i in failed:
            (results[index],) = solve_levels_one_by_one([levels[index]])
            continue
        try:
            solved = coverage_solved(system, [solutions[(i, k)] for k in range(len(system.plan.solves))])
            results[index] = covered_record(scene, "coverage", solved, started)
        except Exception as error:  # noqa: BLE001 - this level's result
            results[index] = error
    clear_cache()  # this level's kernels serve no other grid
    return results


def _batch_solve(
    members: Sequence[tuple[CoverageSystem, int, float, FourierPreconditioner | None]],
) -> list[Solution]:
    """Solve k of each (system, k, tol, its preconditioner) of ``members`` (one device, components,
    grid shape and preconditioner grid) as one ``conjugate_gradient_batch``; the solutions in order
    (tractions on the device)."""
    system0 = members[0][0]
    xp, shape = system0.engine.xp, system0.mask.shape
    operator, fourier = operator_stacks(
        [system.engine for system, _, _, _ in members],
        [system.plan.solves[k] for system, k, _, _ in members],
        [pre for _, _, _, pre in members],
        shape,
        xp,
    )
    damping = xp.stack([system.damping[k] for system, k, _, _ in members])
    apply = lambda t: operator.apply(t) + damping * t  # noqa: E731
    precondition = None
    if fourier is not None:
        weights = xp.stack([system.weights[k] for system, k, _, _ in members])
        precondition = lambda r: weights * fourier(weights * r)  # noqa: E731
    rhs = to_device(np.stack([system.rhs[k] for system, k, _, _ in members]), xp)
    mask = to_device(np.stack([system.mask for system, _, _, _ in members]), xp)
    batch = conjugate_gradient_batch(apply, rhs, mask, tol=[tol for _, _, tol, _ in members], precondition=precondition)
    return [batch.scene(m) for m in range(len(members))]
