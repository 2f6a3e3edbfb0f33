"""The grids an accuracy request may use: its strategy's sequence within the cell limit, the
estimator's calibrated range and the memory budget (:func:`plan_grids`)."""

from __future__ import annotations

import dataclasses

from hpcontact.accuracy.strategies import cells
from hpcontact.numerics.memory import default_memory_per_rank, resident_bytes
from hpcontact.scene import Scene


@dataclasses.dataclass(frozen=True)
class GridPlan:
    """The grids an accuracy request may use, and what stops the sequence after them:
    ``limit`` is ``"cells"`` (more than ``max_cells``), ``"memory budget"`` or, set by
    ``"calibration"`` (beyond the estimator's calibrated range, ``strategies.calibrated``);
    ``next_grid`` the first grid refused, ``next_bytes`` its estimated peak (``base_bytes``, this process's
    peak resident set when planned, + arrays), ``budget`` the budget in bytes and
    ``budget_source`` where it comes from."""

    grids: list[tuple[int, int]]
    limit: str
    next_grid: tuple[int, int]
    next_bytes: float
    base_bytes: float
    budget: float
    budget_source: str
    max_cells: int


def plan_grids(
    scene: Scene,
    n0: int,
    n_across0: int | None,
    max_cells: int,
    memory_budget: float | None,
    strategy: str = "coverage",
) -> GridPlan:
    """The grid sequence within ``max_cells`` cells, the estimator's calibrated range
    (``Strategy.calibrated``) and the memory budget (bytes; default the machine's memory per core,
    ``numerics.memory.default_memory_per_rank``): a grid is used only if this process's peak resident
    set so far plus ``Strategy.grid_bytes`` of ``strategy``'s cells fits the budget. Strip cells'
    grids are n₀ 2ᵏ strips, one across."""
    if memory_budget is None:
        budget, source = default_memory_per_rank()
    else:
        budget, source = float(memory_budget), "given"
    chosen = cells(strategy)
    everything = chosen.grids(scene.shape, n0, n_across0)
    base = resident_bytes()
    within = chosen.calibrated(scene.shape)
    grids: list[tuple[int, int]] = []
    for n, na in everything:
        need = base + chosen.grid_bytes(scene, n, na)
        limit = (
            "cells"
            if n * na > max_cells
            else "calibration"
            if not within(n, na)
            else "memory budget"
            if need > budget
            else None
        )
        if limit is not None:
            return GridPlan(grids, limit, (n, na), need, base, float(budget), source, max_cells)
        grids.append((n, na))
    raise AssertionError("the grid sequence is unbounded")  # pragma: no cover - 2**62 cells never fit
