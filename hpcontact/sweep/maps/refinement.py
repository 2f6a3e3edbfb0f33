"""The leaves' method of an adaptive map: its nodes, their error estimate and their refinement
(the rounds: ``hpcontact.sweep.maps.rounds``; the check rounds: ``hpcontact.sweep.maps.checks``;
what it shares with the sparse grid, ``hpcontact.sweep.maps.sparse_grid``, the axes among them:
``hpcontact.sweep.maps.estimates``; which of the two a map uses: ``hpcontact.sweep.maps.state``).

Leaves. Each sub-problem's grid (its numeric axes, in index space) is tiled by the boxes of the
leaves of a k-d tree; neighbouring boxes share their face (the grid points on it belong to
both). A leaf (``Leaf``) is one increasing index list per numeric axis and its box; its nodes,
the points solved, are their tensor product, and it interpolates its own box only
(``interpolation.TensorInterpolant`` over the span of its nodes: local cubic Lagrange along each
axis, an error estimate per axis). The first round has one leaf per sub-problem, its box the
whole grid: the first nested-bisection level with ``initial`` nodes along each axis (every
2^k-th index, ends included: ``interpolation.bisection_nodes``).

Estimate. After each round, rank 0 estimates the relative error at every grid point from the
solved points: ``map error = Σ_d e_d + s``, ``e_d`` the estimate of axis ``d`` of the point's
leaf relative to the quantity's own size (``|q|``; the off-diagonal K_xy, K_yx, … relative to the
largest diagonal entry, as their ``<name>_error``), ``s`` the solve's own estimated relative error
``<name>_error`` interpolated from the leaf's nodes (0 where a solve has none). A point on a face
takes the value and estimate of the leaf whose map error is smallest there (a node of any leaf:
its solve's own error).

Refinement. Where the map error of a quantity exceeds its tolerance ``t``, the axis of the
point's largest ``e_d``, and each other axis whose ``e_d`` together with the smaller ones alone
exceeds ``max(t − s, t/4)`` (``needed_axes``), has the node interval of the point's leaf around
the point split at its midpoint, inside that leaf only: the new nodes are the midpoint
index × the leaf's nodes along the other axes, not a hyperplane of the whole grid. A leaf that
then has ``2 LEAF_NODES − 1`` or more nodes inside its box along an axis is cut at the middle
one along the axis with the most, again until none has: two leaves whose boxes share the cut's
face, each keeping ``HALO`` node(s) of the other beyond it, so the intervals at the face keep
the centred stencil they had (without it the one-sided stencils there refined the faces: 486
instead of 222 solves on jobs/demo_map.toml). A cut adds no node, but later splits in one half
leave the other as it is (but for its ``HALO`` line), so the map grows nodes where its estimate
is large and stays coarse elsewhere. And before a leaf is split, where the points over their
tolerance that its splits serve lie on one side of one of its nodes along an axis it is not
split along, it is cut there first (at fewer nodes, each half keeping ``LEAF_NODES`` with its
halo: ``_grown``), and only the half holding those points gets the new nodes: a new line of
nodes spans the part of the leaf that needs it, not the whole leaf (measured with
benchmarks/local_refinement.py and benchmarks/map_honesty.py: docs/howto/adaptive.md). The new nodes' points are the next round, broadcast to
every rank; the refinement ends when no interval is split, or at ``max_solves`` (the splits with
the largest estimates first, as many as fit), or when every point is solved. The state
(``state.State``: each sub-problem's leaves) is a function of the values at its nodes alone, so a
resumed sweep rebuilds it round by round from its journals.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from hpcontact.numerics.interpolation import ORDERS, TensorInterpolant, bisection_nodes, chosen_stencils, refined
from hpcontact.sweep.maps.estimates import (
    REMEMBERED,
    SAFETY,
    Checks,
    Estimate,
    Layout,
    needed_axes,
    node_tasks,
    principal_from_tensor,
    relative_scale,
    solve_errors,
    worked_quantities,
)
from hpcontact.sweep.space.adaptive_settings import Settings

#: Fewest nodes along an axis that cutting a leaf leaves in each half: one more than the largest
#: stencil (``interpolation.ORDERS``: the quintic's 6), so each half's estimate of that order
#: (one order higher, ``interpolation.estimate_weights``) has its own node to add and each half
#: may take it (``interpolation.chosen_stencils``); with the cubic's 5 the halves of a leaf
#: stayed cubic and the smooth 2-D map of benchmarks/local_refinement.py took 80 solves, not 65
#: (both before the end rule ``interpolation.FALLING``; 70 with it).
LEAF_NODES = max(ORDERS) + 1

#: Nodes a cut leaves each half beyond its face (of the other half's): the intervals at the face
#: keep the centred stencil of the largest order (two nodes either side of the quintic's
#: interval), as they had before the cut. With one (the cubic's) a quintic at a face was
#: one-sided there and stated 0.5 × its error on a map of the families table (docs/howto/adaptive.md).
HALO = max(ORDERS) // 2 - 1


class Leaf(NamedTuple):
    """A leaf of a sub-problem's k-d tree: ``nodes``, one increasing index list per numeric axis
    (their tensor product is solved), and ``box``, the first and last index per axis of the
    points it interpolates (its nodes may reach ``HALO`` nodes beyond a cut face)."""

    nodes: tuple[tuple[int, ...], ...]
    box: tuple[tuple[int, int], ...]


def initial_leaf(shape: Sequence[int], initial: int) -> Leaf:
    """The first round's leaf of a sub-problem whose grid (numeric axes) has ``shape``: the first
    bisection level with ``initial`` nodes along each axis, its box the whole grid."""
    nodes = tuple(tuple(bisection_nodes(n, initial)) for n in shape)
    return Leaf(nodes, tuple((n[0], n[-1]) for n in nodes))


def box(leaf: Leaf) -> tuple[slice, ...]:
    """The index box of ``leaf`` in its sub-problem's grid (numeric axes in order)."""
    return tuple(slice(lo, hi + 1) for lo, hi in leaf.box)


def node_mask(layout: Layout, leaves: Sequence[Leaf]) -> np.ndarray:
    """Whether each point of a sub-problem's grid (numeric axes) is a node of one of ``leaves``."""
    mask = np.zeros(tuple(len(x) for x in layout.xs), dtype=bool)
    for leaf in leaves:
        mask[np.ix_(*leaf.nodes)] = True
    return mask


@dataclass(frozen=True)
class LeafJob:
    """What one leaf's part of a sub-problem's estimate needs (``leaf_estimate``), small enough
    to send to another rank: the coordinates over the span of its nodes (``xs``), its nodes in
    that span (``local``), its box in that span (``inner``), the values of the quantities
    ``work`` at its nodes (``data``, quantities last) and the solves' relative errors there
    (``solve_data``), how many of ``work`` are kept (the first ``kept``; the rest: the tensor a
    principal stiffness is derived from), the factor and kind of the estimate, and whether the
    principal stiffnesses are derived from the tensor (``principal_from_tensor``). ``points``:
    the points of its box, the cost the leaves are shared out by (``maps.spread``)."""

    xs: tuple[np.ndarray, ...]
    local: tuple[tuple[int, ...], ...]
    inner: tuple[slice, ...]
    data: np.ndarray
    solve_data: np.ndarray
    work: tuple[str, ...]
    kept: int
    safety: float
    conservative: bool
    derive: bool

    @property
    def points(self) -> int:
        return math.prod(s.stop - s.start for s in self.inner)


class LeafPart(NamedTuple):
    """One leaf's part of the estimate over its box, the kept quantities last: the interpolated
    values, each axis' relative estimate, the interpolated solve error, the size the errors are
    relative to, and the largest map error over the quantities at each point (inf where NaN)."""

    values: np.ndarray
    axes: list[np.ndarray]
    solve: np.ndarray
    scale: np.ndarray
    worst: np.ndarray


def leaf_estimate(job: LeafJob) -> LeafPart:
    """One leaf's part of ``estimate`` (``LeafJob``): a function of the job alone, so every rank
    computes it alike (``maps.spread`` shares the leaves out)."""
    work, kept = list(job.work), slice(0, job.kept)
    interpolant = TensorInterpolant(list(job.xs), job.local)
    solve = np.abs(interpolant.values(job.solve_data))
    whole, estimates = _hp(job, interpolant, solve)
    full = whole[job.inner]
    relative = relative_scale(work, full)
    leaf_axes = [job.safety * e[job.inner] / relative for e in estimates]
    if job.derive:
        principal_from_tensor(full, leaf_axes, work)
        relative = relative_scale(work, full)
    leaf_solve = solve[job.inner]
    error = (sum(leaf_axes, np.zeros_like(leaf_solve)) + leaf_solve)[..., kept]
    worst = np.where(np.isnan(error), np.inf, error).max(axis=-1)
    return LeafPart(
        full[..., kept], [a[..., kept] for a in leaf_axes], leaf_solve[..., kept], relative[..., kept], worst
    )


def _hp(job: LeafJob, cubic: TensorInterpolant, solve: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """The values of ``job``'s quantities over the span of its nodes and each axis' absolute
    estimate, each quantity interpolated along each axis with the stencil ``chosen_stencils``
    picks for it (the cubic, or the quintic where its next Newton term is the smaller at every
    point), the solves' own error (``solve``, relative, interpolated by ``cubic``, the leaf's
    cubic interpolant) the noise below which the terms are not compared: the values and the
    estimate of the order chosen, the map error of what is drawn."""
    xs, nodes = list(job.xs), job.local
    chosen = chosen_stencils(xs, nodes, job.data, np.abs(cubic.values(job.data)) * solve)
    values = np.full((*(len(x) for x in xs), job.data.shape[-1]), np.nan)
    axes = [np.full_like(values, np.nan) for _ in xs]
    for stencils in sorted(set(map(tuple, chosen.tolist()))):
        columns = np.flatnonzero((chosen == stencils).all(axis=1))
        interpolant = TensorInterpolant(xs, nodes, stencils)
        data = job.data[..., columns]
        full = interpolant.values(data)
        values[..., columns] = full
        for target, e in zip(axes, interpolant.estimates(data, full, job.conservative)):
            target[..., columns] = e
    return values, axes


LeafMap = Callable[[Sequence[LeafJob]], list[LeafPart]]


def _serial(jobs: Sequence[LeafJob]) -> list[LeafPart]:
    """``leaf_estimate`` of every job on this process, in order."""
    return [leaf_estimate(job) for job in jobs]


#: How ``estimate`` computes its leaves' parts (``spread_leaves``: over the ranks of a team).
_LEAF_MAP: ContextVar[LeafMap] = ContextVar("leaf_map", default=_serial)


@contextmanager
def spread_leaves(leaf_map: LeafMap) -> Iterator[None]:
    """Every ``estimate`` inside computes its leaves' parts with ``leaf_map`` (a list of
    ``LeafJob`` → their ``LeafPart`` in order; ``maps.spread.LeafPool.map`` shares them out
    over the ranks), not one after the other here."""
    token = _LEAF_MAP.set(leaf_map)
    try:
        yield
    finally:
        _LEAF_MAP.reset(token)


def _same_jobs(a: Sequence[LeafJob], b: Sequence[LeafJob]) -> bool:
    """Whether two lists of jobs hold bitwise the same inputs."""
    return len(a) == len(b) and all(
        x.derive == y.derive
        and x.work == y.work
        and np.array_equal(x.data, y.data, equal_nan=True)
        and np.array_equal(x.solve_data, y.solve_data, equal_nan=True)
        for x, y in zip(a, b)
    )


def estimate(
    layout: Layout,
    cat: Sequence[int],
    leaves: Sequence[Leaf],
    names: Sequence[str],
    fields: Mapping[str, np.ndarray],
    safety: float = SAFETY,
    conservative: bool = False,
) -> Estimate:
    """The ``Estimate`` of the sub-problem ``cat`` from the values at the nodes of its
    ``leaves`` of the quantities ``names`` (``fields``: name → array over the task axes;
    ``<name>_error``, when there, the solve's relative error); ``safety`` the factor on the
    interpolation estimate, ``conservative`` its kind (``TensorInterpolant.estimates``). Each
    leaf interpolates its own box (``leaf_estimate``, computed as ``spread_leaves`` says); a
    point on a face shared by several takes the leaf whose largest map error over the
    quantities is smallest there (the first where all are NaN), merged in leaf order whoever
    computed the parts. The principal stiffnesses come from the interpolated tensor where
    ``fields`` has it and they may cross (``_crosses``, on every node of the sub-problem;
    ``principal_from_tensor``)."""
    work, derive = worked_quantities(layout, cat, node_mask(layout, leaves), names, fields)
    grid = tuple(len(x) for x in layout.xs)
    jobs = [
        LeafJob(
            xs=tuple(x[n[0] : n[-1] + 1] for x, n in zip(layout.xs, leaf.nodes)),
            local=tuple(tuple(i - n[0] for i in n) for n in leaf.nodes),
            inner=tuple(slice(lo - n[0], hi - n[0] + 1) for (lo, hi), n in zip(leaf.box, leaf.nodes)),
            data=np.stack([layout.take(fields[n], cat, leaf.nodes) for n in work], axis=-1),
            solve_data=solve_errors(layout, fields, work, cat, leaf.nodes),
            work=tuple(work),
            kept=len(names),
            safety=safety,
            conservative=conservative,
            derive=derive,
        )
        for leaf in leaves
    ]
    remembered = REMEMBERED.get()
    key = (tuple(cat), tuple(leaves), tuple(names), safety, conservative)
    if remembered is not None and key in remembered and _same_jobs(remembered[key][0], jobs):
        return remembered[key][1]
    values = np.full((*grid, len(names)), np.nan)
    axes = [np.full((*grid, len(names)), np.nan) for _ in grid]
    solve, scale = np.full((*grid, len(names)), np.nan), np.ones((*grid, len(names)))
    owner, best = np.full(grid, -1, dtype=np.intp), np.full(grid, np.inf)
    for position, (leaf, part) in enumerate(zip(leaves, _LEAF_MAP.get()(jobs))):
        region = box(leaf)  # slices: each target[region] is a view, written in place
        better = (part.worst < best[region]) | (owner[region] < 0)
        np.copyto(best[region], part.worst, where=better)
        np.copyto(owner[region], position, where=better)
        chosen = better[..., None]
        for target, source in zip((values, solve, scale, *axes), (part.values, part.solve, part.scale, *part.axes)):
            np.copyto(target[region], source, where=chosen)
    result = Estimate(values, axes, solve, scale, owner)
    if remembered is not None:
        remembered[key] = (jobs, result)
    return result


def refine(
    layout: Layout,
    settings: Settings,
    state: Sequence[tuple[tuple[int, ...], tuple[Leaf, ...]]],
    fields: Mapping[str, np.ndarray],
    names: Sequence[str],
    task_of: np.ndarray,
    checks: Checks,
) -> tuple | None:
    """The next round's state from the values at ``state``'s nodes (module docstring), or None
    when no interval needs a split (or none fits ``max_solves``, which counts the check points
    too). Deterministic: every rank given the same values decides the same."""
    tol = np.array([settings.tolerance(n) for n in names])
    candidates = []  # (score, sub-problem position, leaf position, axis, interval)
    reach: dict[tuple[int, int, int, int], Span] = {}  # (s, leaf, axis, interval) -> its points over, per axis
    for s, (cat, leaves) in enumerate(state):
        est = estimate(layout, cat, leaves, names, fields, checks.factor(s), checks.cautious(s))
        with np.errstate(invalid="ignore"):
            over = est.map_error > tol
            budget = np.maximum(tol - est.solve, tol / 4.0)
            excess = np.nan_to_num(np.where(over, est.map_error / tol, 0.0), nan=0.0)
            ratios = [
                np.where(n, excess, 0.0).max(axis=-1)
                for n in needed_axes(est.axes, budget, _split_costs(leaves, est.owner))
            ]
            excess = excess.max(axis=-1)
        for position, leaf in enumerate(leaves):
            region = box(leaf)
            mine = est.owner[region] == position
            inside = [_between_nodes(leaf, d) for d in range(len(leaf.box))]
            leaf_ratios = [np.where(mine, r[region], 0.0) for r in ratios]
            # a point over its tolerance whose large shares are all along axes where it sits on a
            # node (the error comes from a line through a failed node) splits its other axes
            split = np.any([(r > 1.0) & between for r, between in zip(leaf_ratios, inside)], axis=0)
            stuck = (excess[region] > 1.0) & mine & ~split
            for d, (nodes, (lo, hi)) in enumerate(zip(leaf.nodes, leaf.box)):
                ratio = np.where(stuck & inside[d], np.fmax(leaf_ratios[d], excess[region]), leaf_ratios[d])
                for m, (i, j) in enumerate(zip(nodes[:-1], nodes[1:])):
                    if j - i < 2 or i < lo or j > hi:
                        continue
                    slab = np.take(ratio, range(i + 1 - lo, j - lo), axis=d)
                    worst = float(slab.max())
                    if worst > 1.0:
                        candidates.append((worst, s, position, d, m))
                        reach[(s, position, d, m)] = _span(slab > 1.0, leaf, d, (i + 1, j - 1))
    if not candidates:
        return None
    flat = np.arange(math.prod(layout.shape)).reshape(layout.shape)
    task_of = np.asarray(task_of).ravel()
    masks = [(cat, node_mask(layout, leaves)) for cat, leaves in state]
    taken = set(node_tasks(layout, masks, task_of, checks).tolist())
    marks: dict[tuple[int, int], dict[int, set[int]]] = {}  # (sub-problem, leaf) -> axis -> intervals
    for _, s, position, d, m in sorted(candidates, key=lambda c: (-c[0], *c[1:])):
        trial = {a: set(ms) for a, ms in marks.get((s, position), {}).items()}
        trial.setdefault(d, set()).add(m)
        cat, leaves = state[s]
        pieces = _grown(leaves[position], trial, _reach_of(reach, s, position, trial))
        added = {t for piece in pieces for t in task_of[layout.take(flat, cat, piece.nodes).ravel()].tolist()} - taken
        if settings.max_solves is not None and len(taken) + len(added) > settings.max_solves:
            continue
        marks[(s, position)] = trial
        taken |= added
    if not marks:
        return None
    out = []
    for s, (cat, leaves) in enumerate(state):
        grown: list[Leaf] = []
        for position, leaf in enumerate(leaves):
            marked = marks.get((s, position), {})
            grown.extend(_grown(leaf, marked, _reach_of(reach, s, position, marked)))
        out.append((cat, tuple(grown)))
    return tuple(out)


def _split_costs(leaves: Sequence[Leaf], owner: np.ndarray) -> list[np.ndarray]:
    """Per axis, the nodes a split of one interval along it adds to the leaf of each point
    (``owner``): the product of the leaf's node counts along the other axes (quantities last: a
    trailing axis of 1)."""
    counts = np.array([[len(n) for n in leaf.nodes] for leaf in leaves], dtype=np.float64)
    per_leaf = np.prod(counts, axis=1, keepdims=True) / counts
    return [per_leaf[owner, d][..., None] for d in range(counts.shape[1])]


def _between_nodes(leaf: Leaf, axis: int) -> np.ndarray:
    """Whether each point of ``leaf``'s box lies strictly between two nodes along ``axis``
    (broadcast over the box's other axes)."""
    lo, hi = leaf.box[axis]
    between = ~np.isin(np.arange(lo, hi + 1), leaf.nodes[axis])
    shape = [1] * len(leaf.box)
    shape[axis] = len(between)
    return between.reshape(shape)


#: The grid indices, first and last per axis, of the points over their tolerance that a split serves.
Span = tuple[tuple[int, int], ...]


def _span(over: np.ndarray, leaf: Leaf, axis: int, interval: tuple[int, int]) -> Span:
    """The first and last grid index along each axis of the points ``over`` (a boolean slab of
    ``leaf``'s box: the points strictly inside the node interval ``interval`` along ``axis``)."""
    out = []
    for e, (lo, _) in enumerate(leaf.box):
        if e == axis:
            out.append(interval)
            continue
        hit = np.flatnonzero(over.any(axis=tuple(a for a in range(over.ndim) if a != e)))
        out.append((lo + int(hit[0]), lo + int(hit[-1])))
    return tuple(out)


def _reach_of(
    reach: Mapping[tuple[int, int, int, int], Span], s: int, position: int, marks: Mapping[int, set[int]]
) -> Span | None:
    """The smallest box holding the spans (``_span``) of the marked intervals ``marks`` of the
    leaf ``position`` of the sub-problem ``s`` (None: no mark)."""
    spans = [reach[(s, position, d, m)] for d, ms in marks.items() for m in ms]
    if not spans:
        return None
    return tuple((min(sp[e][0] for sp in spans), max(sp[e][1] for sp in spans)) for e in range(len(spans[0])))


def _grown(leaf: Leaf, marks: Mapping[int, set[int]], reach: Span | None) -> list[Leaf]:
    """The leaves ``leaf`` becomes when the intervals ``marks`` are split, ``reach`` the box
    of the points over their tolerance that the splits serve (None: no mark). First, along an
    axis with no mark, ``leaf`` is cut at the node nearest to ``reach`` whose face leaves
    ``reach`` on one side and each half at least ``LEAF_NODES`` nodes along that axis, ``HALO``
    beyond the face included (a cut as ``_cut``'s, at fewer nodes): the half that holds
    ``reach`` is grown the same way, the other half keeps its nodes, so the new nodes span only
    the part of the leaf whose points need them. Then the marks are split (``_split``) and the
    leaf cut where it has grown to ``2 LEAF_NODES − 1`` nodes (``_cut``)."""
    if reach is None:
        return _cut(leaf)
    for e, (nodes, (lo, hi)) in enumerate(zip(leaf.nodes, leaf.box)):
        if e in marks:
            continue
        n, (first, last) = len(nodes), reach[e]
        fits = [k for k, i in enumerate(nodes) if lo < i < hi and k + 1 + HALO >= LEAF_NODES <= n - k + HALO]
        above = [k for k in fits if nodes[k] >= last]
        below = [k for k in fits if nodes[k] <= first]
        if above:
            k = above[0]
            keep, rest = (nodes[: k + 1 + HALO], (lo, nodes[k])), (nodes[k - HALO :], (nodes[k], hi))
        elif below:
            k = below[-1]
            keep, rest = (nodes[k - HALO :], (nodes[k], hi)), (nodes[: k + 1 + HALO], (lo, nodes[k]))
        else:
            continue
        kept, other = (
            Leaf((*leaf.nodes[:e], half, *leaf.nodes[e + 1 :]), (*leaf.box[:e], span, *leaf.box[e + 1 :]))
            for half, span in (keep, rest)
        )
        return [*_grown(kept, marks, reach), other]
    return _cut(_split(leaf, marks))


def _split(leaf: Leaf, marks: Mapping[int, set[int]]) -> Leaf:
    """``leaf`` with the midpoints of the intervals ``marks[d]`` of each axis ``d`` added."""
    nodes = tuple(
        tuple(refined(n, [m in marks[d] for m in range(len(n) - 1)])) if d in marks else n
        for d, n in enumerate(leaf.nodes)
    )
    return Leaf(nodes, leaf.box)


def _cut(leaf: Leaf) -> list[Leaf]:
    """``leaf`` cut at the middle of its nodes inside its box along the axis with the most of
    them, while that axis has at least ``2 LEAF_NODES − 1``: two leaves whose boxes share the
    cut's face, each keeping ``HALO`` of the other's nodes beyond it (no node is added)."""
    inside = [[k for k, i in enumerate(n) if lo <= i <= hi] for n, (lo, hi) in zip(leaf.nodes, leaf.box)]
    d = max(range(len(leaf.box)), key=lambda a: (len(inside[a]), -a))
    if len(inside[d]) < 2 * LEAF_NODES - 1:
        return [leaf]
    k = inside[d][len(inside[d]) // 2]
    nodes, (lo, hi) = leaf.nodes[d], leaf.box[d]
    halves = ((nodes[: k + 1 + HALO], (lo, nodes[k])), (nodes[max(k - HALO, 0) :], (nodes[k], hi)))
    return [
        piece
        for half, span in halves
        for piece in _cut(
            Leaf((*leaf.nodes[:d], half, *leaf.nodes[d + 1 :]), (*leaf.box[:d], span, *leaf.box[d + 1 :]))
        )
    ]
