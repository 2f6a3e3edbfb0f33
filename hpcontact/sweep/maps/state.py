"""The state of an adaptive map and which method each call goes to: each sub-problem's part of
the state is the leaves of a k-d tree (``hpcontact.sweep.maps.refinement``) or, with
``[adaptive] method`` "sparse" (or "auto" on 3 or more interpolated axes, ``sparse_method``), a
sparse grid's set (``hpcontact.sweep.maps.sparse_grid``); ``initial_state``, ``node_mask``,
``state_points``, ``estimate`` and ``refine`` hand it to that method's module. What both methods
share: ``hpcontact.sweep.maps.estimates``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from hpcontact.sweep.maps import refinement, sparse_grid
from hpcontact.sweep.maps.estimates import SAFETY, Checks, Estimate, Layout, node_points, node_tasks
from hpcontact.sweep.maps.refinement import Leaf
from hpcontact.sweep.maps.sparse_grid import SparseSet
from hpcontact.sweep.space.adaptive_settings import Settings

#: Each sub-problem's categorical index and its part of the state: the leaves tiling it or a
#: sparse grid's set.
State = tuple[tuple[tuple[int, ...], tuple[Leaf, ...] | SparseSet], ...]

#: Interpolated axes (of 3 points or more) from which ``[adaptive] method = "auto"`` maps with a
#: sparse grid (``maps.sparse_grid``) rather than leaves: measured, benchmarks/local_refinement.py
#: (docs/howto/adaptive.md, "A sparse grid").
AUTO_SPARSE_AXES = 3


def sparse_method(layout: Layout, settings: Settings) -> bool:
    """Whether the map is a sparse grid (``settings.method``; "auto": ``AUTO_SPARSE_AXES``)."""
    if settings.method != "auto":
        return settings.method == "sparse"
    return sum(len(x) >= 3 for x in layout.xs) >= AUTO_SPARSE_AXES


def is_sparse(leaves: Any) -> bool:
    """Whether a sub-problem's part of the state is a sparse grid's set (``maps.sparse_grid``),
    not leaves."""
    return isinstance(leaves, SparseSet)


def initial_state(layout: Layout, settings: Settings) -> State:
    """The first round's nodes: in every sub-problem one leaf, the first bisection level with
    ``settings.initial`` nodes along each numeric axis (``refinement.initial_leaf``); for a
    sparse grid (``sparse_method``) its first set (``sparse_grid.initial_set``)."""
    cats = [tuple(int(c) for c in cat) for cat in np.ndindex(*(layout.shape[p] for p in layout.categorical))]
    shape = tuple(len(x) for x in layout.xs)
    if sparse_method(layout, settings):
        first = sparse_grid.initial_set(shape, settings.initial)
        return tuple((cat, first) for cat in cats)
    leaf = refinement.initial_leaf(shape, settings.initial)
    return tuple((cat, (leaf,)) for cat in cats)


def node_mask(layout: Layout, leaves: Sequence[Leaf] | SparseSet) -> np.ndarray:
    """Whether each point of a sub-problem's grid (numeric axes) is a node of one of ``leaves``
    (or of a sparse grid's set)."""
    if is_sparse(leaves):
        return sparse_grid.set_nodes(tuple(len(x) for x in layout.xs), leaves.indices)
    return refinement.node_mask(layout, leaves)


def state_points(layout: Layout, state: State, checks: Checks | None = None) -> np.ndarray:
    """The flat (C order over the task axes) indices of every node point of ``state`` and
    every check point of ``checks``, sorted."""
    return node_points(layout, [(cat, node_mask(layout, leaves)) for cat, leaves in state], checks)


def state_tasks(layout: Layout, state: State, task_of: np.ndarray, checks: Checks | None = None) -> np.ndarray:
    """The distinct tasks (positions) of the node points of ``state`` and the check points."""
    return node_tasks(layout, [(cat, node_mask(layout, leaves)) for cat, leaves in state], task_of, checks)


def estimate(
    layout: Layout,
    cat: Sequence[int],
    leaves: Sequence[Leaf] | SparseSet,
    names: Sequence[str],
    fields: Mapping[str, np.ndarray],
    safety: float = SAFETY,
    conservative: bool = False,
) -> Estimate:
    """The ``Estimate`` of the sub-problem ``cat`` (``refinement.estimate``); a sparse grid's set
    instead of leaves: ``sparse_grid.estimate`` (``conservative`` has no meaning there)."""
    if is_sparse(leaves):
        return sparse_grid.estimate(layout, cat, leaves, names, fields, safety)
    return refinement.estimate(layout, cat, leaves, names, fields, safety, conservative)


def refine(
    layout: Layout,
    settings: Settings,
    state: State,
    fields: Mapping[str, np.ndarray],
    names: Sequence[str],
    task_of: np.ndarray,
    checks: Checks | None = None,
) -> State | None:
    """The next round's state from the values at ``state``'s nodes (``refinement.refine``; a
    sparse grid's: ``sparse_grid.refine``), or None when nothing needs refining (or nothing fits
    ``max_solves``, which counts the check points too) or there are no quantities ``names``.
    Deterministic: every rank given the same values decides the same."""
    checks = checks if checks is not None else Checks()
    if not names:
        return None
    if state and is_sparse(state[0][1]):
        return sparse_grid.refine(layout, settings, state, fields, names, task_of, checks)
    return refinement.refine(layout, settings, state, fields, names, task_of, checks)
