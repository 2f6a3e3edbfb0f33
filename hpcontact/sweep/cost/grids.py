"""The grids a sweep's task solves: one for a scene with ``n``; ``accuracy.default_solve``'s
extrapolated default over grids 16 … 256 for a contact scene without it; for a contact scene that
asks for an accuracy, the grids ``solve_to_accuracy`` (strategy auto) is predicted to solve, each
tagged with its boundary cells (``accuracy_plan``, ``accuracy_levels``). The cost model
(``cost.task_cost``) costs a task over these grids, and sizes its memory on the finest.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any, NamedTuple

from hpcontact import fields
from hpcontact.accuracy import (
    DEFAULT_ACCURACY,
    MAX_CELLS,
    MIN_GRIDS,
    STRATEGIES,
    default_grids,
    first_grid,
    grid_bytes,
    plan_grids,
    requested_by_default,
)
from hpcontact.accuracy.strategies import EXACT, Strategy
from hpcontact.problems import footprint
from hpcontact.problems.kinds import CONTACT, kind_of
from hpcontact.scene import Scene, canonical_json

# Fields that do not change the grids ``accuracy.default_grids`` picks (it reads the shape, the
# quantities and whether the body is isotropic, not its constants or the solver's settings):
# left out of ``solved_grids``' cache key, so an axis over nu builds one Scene for its grids.
GRID_NEUTRAL_FIELDS = frozenset(fields.names(CONTACT, neutral_to="grid"))  # ``hpcontact.fields``
# The engine's CG tolerance where a spec leaves it out.
DEFAULT_TOL = 1e-8
# A task that asks for an accuracy (``accuracy.default_solve`` of a scene with ``accuracy``:
# ``solve_to_accuracy(scene, accuracy, strategy="auto")``) is costed over the grids it is
# predicted to solve (``accuracy_levels``), each a one-grid scene tagged with its boundary cells
# under ``BOUNDARY_TAG`` (``accuracy.strategies.EXACT``, "galin", or the name of a record of
# ``accuracy.STRATEGIES``: never a scene field, ``level_fields`` drops it). An ellipse or circle
# takes its one exact cell (galin: no grid, one task term); the singular cells and the ellipses'
# strips that ``auto`` took before are no longer reached by it.
# The evidence behind the constants: docs/performance.md §"Accuracy tasks".
BOUNDARY_TAG = "boundary"
# Where the sequence stops (``predicted_grid_count``): coverage-weighted cells met every request
# of 1e-3 on ``MIN_GRIDS`` grids (20 scene types of the demo, isotropic and cubic) and took one
# more grid per full decade below it (the most frequent count at 1e-4 and 1e-5); strips
# (``Strategy.strips``) met every request down to ``STRIP_FOUR_GRIDS_TO`` on four grids (or stop
# there on their own bound, ``Strategy.model_error``).
COVERAGE_FOUR_GRIDS_TO = 1e-3
STRIP_FOUR_GRIDS_TO = 1e-7


def solved_grids(params: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """The one-grid scenes a task of ``params`` solves: ``[params]`` for a scene with ``n`` (or
    one that ``accuracy.extrapolates_by_default`` refuses, or a slip scene); for a contact scene
    that asks for an accuracy, the grids it is predicted to solve (``accuracy_levels``, each
    tagged with its boundary cells); for a contact scene
    without ``n`` that extrapolates by default (``accuracy.default_solve``, which the sweep's
    task function runs), one scene per grid of ``accuracy.default_grids`` (16 … 256 along the
    long side, five grids) with that grid's ``n``, ``n_across`` and the CG tolerance
    ``solve_to_accuracy`` uses (at most the default accuracy / 100). Cached per scene, the
    fields that do not change its grids (``GRID_NEUTRAL_FIELDS``) aside."""
    if not kind_of(params).accuracy_applies:  # solved on its own grid (a slip scene)
        return [params]
    if with_request(params).get("accuracy") is not None:  # before n: solve_to_accuracy ignores the scene's grid
        return accuracy_levels(params)
    if params.get("n") is not None:
        return [params]
    grids = _default_grids(canonical_json({k: v for k, v in params.items() if k not in GRID_NEUTRAL_FIELDS}))
    if not grids:
        return [params]
    tol = max(min(float(params.get("tol", DEFAULT_TOL)), DEFAULT_ACCURACY * 1e-2), 1e-14)
    return [{**params, "n": n, "n_across": na, "tol": tol} for n, na in grids]


@functools.lru_cache(maxsize=4096)
def _requested_by_default(text: str) -> bool:
    """``accuracy.requested_by_default`` of the scene ``text`` (canonical JSON, ``GRID_NEUTRAL_FIELDS``
    left out)."""
    return requested_by_default(Scene.from_key(text))


@functools.lru_cache(maxsize=4096)
def _default_grids(text: str) -> tuple[tuple[int, int], ...]:
    """(n, n_across) of every grid ``accuracy.default_solve`` solves the scene ``text``
    (canonical JSON, ``GRID_NEUTRAL_FIELDS`` left out) on; () when it solves one grid."""
    return tuple(default_grids(Scene.from_key(text)))


def with_request(params: Mapping[str, Any]) -> Mapping[str, Any]:
    """``params`` with the accuracy ``accuracy.default_solve`` solves the contact scene to: its
    own ``accuracy``, or ``DEFAULT_ACCURACY`` where it gives neither that nor ``n`` and the sweep
    solves it as one scene's default (``accuracy.requested_by_default``: an elliptical contact's
    exact cell, a slender rectangle's strips); ``params`` itself otherwise."""
    if params.get("accuracy") is not None or params.get("n") is not None or not kind_of(params).accuracy_applies:
        return params
    if _requested_by_default(canonical_json({k: v for k, v in params.items() if k not in GRID_NEUTRAL_FIELDS})):
        return {**params, "accuracy": DEFAULT_ACCURACY}
    return params


def asks_accuracy(params: Mapping[str, Any]) -> bool:
    """Whether ``params`` is a contact scene solved to an accuracy (a sweep's ``[numerics]
    accuracy``, ``hpcontact run --accuracy``, or a scene without ``n`` solved as a request:
    ``with_request``): ``accuracy.default_solve`` solves it as ``hpcontact solve --accuracy`` does."""
    return with_request(params).get("accuracy") is not None and kind_of(params).accuracy_applies


class AccuracyPlan(NamedTuple):
    """What ``solve_to_accuracy(scene, accuracy, strategy="auto")`` is predicted to do
    (``accuracy_plan``): its boundary cells (``strategy``), the grids (n, n_across) it solves,
    how many grids it could have planned (``planned``), the planned grid after the last one
    predicted (``next_grid``, None at the end of the plan) and the peak bytes of its finest
    grid's arrays (``accuracy.grid_bytes``)."""

    strategy: str
    grids: tuple[tuple[int, int], ...]
    planned: int
    next_grid: tuple[int, int] | None
    finest_bytes: float

    @property
    def exact(self) -> bool:
        """Whether the plan is the one exact cell of an elliptical contact (no grid sequence)."""
        return self.strategy == EXACT

    @property
    def cells(self) -> Strategy:
        """The record of the plan's boundary cells (``accuracy.STRATEGIES``); not of an exact one."""
        return STRATEGIES[self.strategy]


def predicted_grid_count(strategy: str, accuracy: float, planned: int, model_error: float = 0.0) -> int:
    """How many of its ``planned`` grids ``solve_to_accuracy`` is predicted to solve at
    ``accuracy`` with ``strategy``'s cells (docs/performance.md §"Accuracy tasks"): coverage-weighted
    cells ``MIN_GRIDS`` at requests ≥ ``COVERAGE_FOUR_GRIDS_TO`` (1e-3) and one more per full
    decade below (1e-4: 5, 1e-5: 6); strips ``MIN_GRIDS`` down to
    ``STRIP_FOUR_GRIDS_TO`` or where their own bound ``model_error`` is not below the request
    (``solve_to_accuracy`` stops there), every planned grid below (``Strategy.strips``). Never
    more than planned."""
    if STRATEGIES[strategy].strips:
        count = MIN_GRIDS if accuracy >= STRIP_FOUR_GRIDS_TO or model_error >= accuracy else planned
    else:  # the 1e-9 keeps 1e-4 at one decade whatever the rounding of the quotient
        count = MIN_GRIDS + max(0, math.floor(math.log10(COVERAGE_FOUR_GRIDS_TO / accuracy) + 1e-9))
    return max(1, min(count, planned))


def accuracy_plan(params: Mapping[str, Any]) -> AccuracyPlan:
    """The ``AccuracyPlan`` of the contact scene ``params`` with ``accuracy``: the boundary cells
    and first grid of ``accuracy.first_grid``, the grids of ``accuracy.plan_grids`` (at most
    ``accuracy.MAX_CELLS`` cells, within the estimator's calibrated range; no memory budget, so
    that the estimate never depends on this process's resident set: a finest grid over a rank's
    memory shows in the task's memory, which ``--mem-per-rank`` checks), the first
    ``predicted_grid_count`` of them (a plan of no grid: its first one). Cached per scene, the
    fields that do not change its grids (``GRID_NEUTRAL_FIELDS``) aside; its accuracy ``with_request``'s."""
    params = with_request(params)
    return _accuracy_plan(canonical_json({k: v for k, v in params.items() if k not in GRID_NEUTRAL_FIELDS}))


@functools.lru_cache(maxsize=4096)
def _accuracy_plan(text: str) -> AccuracyPlan:
    """``accuracy_plan`` of the scene ``text`` (canonical JSON, ``GRID_NEUTRAL_FIELDS`` left out)."""
    scene = Scene.from_key(text)
    accuracy = float(scene.accuracy)
    strategy, n0, n_across0 = first_grid(scene, "auto", accuracy=accuracy)
    if strategy == EXACT:  # one exact cell: the kernel's tables, no grid
        return AccuracyPlan(strategy, ((1, 1),), 1, None, footprint.tables_bytes(scene.params))
    plan = plan_grids(scene, n0, n_across0, MAX_CELLS, math.inf, strategy)
    count = predicted_grid_count(strategy, accuracy, len(plan.grids), STRATEGIES[strategy].model_error(scene))
    grids = tuple(plan.grids[:count]) or (plan.next_grid,)
    following = tuple(plan.grids[count]) if count < len(plan.grids) else None
    return AccuracyPlan(strategy, grids, len(plan.grids), following, grid_bytes(scene, *grids[-1], strategy))


def accuracy_levels(params: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The one-grid scenes of the accuracy task ``params`` (``accuracy_plan``): ``params``
    without ``accuracy``, with each grid's ``n``, ``n_across``, the CG tolerance
    ``solve_to_accuracy`` uses (at most accuracy / 100) and ``BOUNDARY_TAG`` the grid's
    boundary cells (``level_fields`` gives the scene's fields without it); its accuracy
    ``with_request``'s."""
    params = with_request(params)
    plan = accuracy_plan(params)
    tol = max(min(float(params.get("tol", DEFAULT_TOL)), float(params["accuracy"]) * 1e-2), 1e-14)
    fields = {k: v for k, v in params.items() if k not in ("accuracy", BOUNDARY_TAG)}
    if plan.exact:  # one exact cell, on no grid: the scene's own n stays (unused)
        return [{**fields, BOUNDARY_TAG: plan.strategy}]
    return [{**fields, "n": n, "n_across": na, "tol": tol, BOUNDARY_TAG: plan.strategy} for n, na in plan.grids]


def level_fields(level: Mapping[str, Any]) -> dict[str, Any]:
    """The scene fields of a level of ``accuracy_levels`` (its ``BOUNDARY_TAG`` dropped): what
    ``Scene.from_params`` accepts."""
    return {k: v for k, v in level.items() if k != BOUNDARY_TAG}


def padded_cells(params: Mapping[str, Any]) -> float:
    """Cells of the scene's padded FFT grid (``footprint.padded_cells``; for a scene extrapolated
    by default, the finest of ``solved_grids``)."""
    return footprint.padded_cells(solved_grids(params)[-1])
