"""A sparse-grid adaptive map: the dimension-adaptive combination technique with its own error
estimate (``[adaptive] method = "sparse"``; the leaves of a k-d tree: ``maps.refinement``; what
both share: ``maps.estimates``; which one a map uses: ``maps.state``).

Levels. Along a numeric axis of n points, level l is the nested bisection level with 2^l + 1
nodes (``interpolation.bisection_nodes(n, 2**l + 1)``; level 0: both ends), up to the first
level that holds all n points (``tops``). A level multi-index l (one level per numeric axis)
stands for the tensor grid of its axes' levels and the tensor interpolant U_l on it (local
cubic Lagrange per axis, ``interpolation.weights``: linear on 2 nodes, quadratic on 3).

Combination. Each sub-problem keeps a downward-closed set S of multi-indices (``SparseSet``):
``active`` the indices with a forward neighbour l + e_d (up to the tops) outside S, ``old`` the
rest. Its points solved are the union of the grids of S; the map at any grid point x is the
combination technique of Gerstner & Griebel (Computing 71:65–87, 2003)

    A_S f(x) = Σ_{l ∈ S} Δ_l f(x),    Δ_l = ⊗_d (U_{l_d} − U_{l_d − 1})    (U_{−1} = 0),

each Δ_l one tensor contraction of the values at the grid of l (``surplus``). With nested,
interpolating 1-D rules A_S reproduces the values at every point of the union (Barthelmann,
Novak & Ritter, Adv. Comput. Math. 12:273–288, 2000).

Estimate. The map error at x is

    factor × Σ_{l active} ρ_l |Δ_l f(x)| / scale(x) + s(x),

``scale`` the quantity's size (as the leaves': |q|, the largest diagonal entry for an
off-diagonal one), s the solves' own relative error combined alike from the nodes, ``factor``
``estimates.SAFETY`` (as the leaves') until a check round raises it, and ρ_l ≤ 1 the decay a
step to a missing forward neighbour of l is expected to bring (``next_terms``: the largest
ratio of surpluses seen for that step next to l; 1 where none is seen). The value reported is
the combination over *all* solved indices, active ones included (the best the solves give;
G&G's choice too); what is missing from it are the terms Δ_m of the indices m outside S, and
each m next to S is a forward neighbour of an active index l, estimated as ρ_l |Δ_l|. Without ρ
(G&G's error indicator, the active surpluses alone) it estimates the error of the combination
*without* the active indices, 5 to 30 times the true error of the value reported on the maps
of benchmarks/local_refinement.py and tests/sweep/maps/test_sparse_grid.py, and the map
refined a level past what it needed (815 points instead of 542 on the latter). It is an
estimate, not a bound: where the decay is not yet regular it can fall short (67 % of the
points in one round of the test's map, before the level that resolves its feature), so the
check rounds (``maps.checks``) test it at random points when the refinement ends and raise the
factor of that sub-problem alone where it falls short. The principal stiffnesses derive from
the combined tensor as the leaves' do (``estimates.principal_from_tensor``).

Refinement (``refine``, one round at a time, batched). At every point over its tolerance t the
active indices are ranked by their part of the estimate, and those needed are taken as
``estimates.needed_axes`` takes axes (the largest, and each whose tail alone exceeds
max(t − s, t/4)). Every forward neighbour of a taken index joins S, with what keeps S
downward closed (``admitted``); their new grid points are the next round. Indices go by their
largest excess first, as many as ``max_solves`` (check points included) allows. The
refinement ends when no point is over its tolerance (or none fits). A check round that finds
the estimate short raises the factor of that sub-problem only (``checks.judged``; no
"conservative" kind), and the refinement goes on where the raised estimate then exceeds the
tolerance. The state is a function of the values at its nodes alone (every decision is), so a
resumed sweep rebuilds it round by round from its journals.

First round (``initial_set``): the indices with Σ_d l_d ≤ L₀ (each l_d ≤ its axis' top), L₀
the level with ``[adaptive] initial`` nodes (5: L₀ = 2).

Failed nodes (``_Failures``). A solve that failed leaves NaN at its node. Where the
surplus of an index takes it (a nonzero weight: ``reached``), the map at that point x is the
combination over S_x, S less every index ≥ one that takes it there (downward closed: as if those
had not been solved), its map error the active surpluses of S_x, so it says what the indices
left out would add; the refinement leaves those points be (no index brings the node back).
Where the first index (level 0) takes it — a failed corner, at every point but the faces
opposite it — nothing is left to interpolate from: NaN, which the data set reports as not
interpolated (``fill``). A quantity undefined at some nodes (NaN by definition) is treated alike.

Cost of a decision (``combined``): the values and the solves' errors are one ``combination``
each (the indices sharing their last levels share one matrix product); the surpluses on the
full grid only of the active indices and of those whose maxima ``next_terms`` reads, each
contracted once where it can be kept (``_Surpluses``), quantities first, none for a principal
stiffness derived from the tensor; the active parts kept (float32) for the refinement's ranking.

Slabs (``_slab``, issue 40 item 5). A decision is computed in slabs of the grid's first axis
(``slab_rows``: contiguous ranges of it, every point of the others), as ``spread_slabs`` says:
the whole grid as one here, one a rank while rank 0 decides (``maps.spread``). Everything at a
point is a function of the nodes' values (every slab has them: ``SparseJob``) and of what needs
the whole grid: the surpluses' maxima ``next_terms`` reads and the size ``relative_scale`` falls
back on, which each slab yields for its points and takes back for the whole (``reduce_slabs``:
maxima and "any", exact in any order) before it goes on. The refinement's ranking needs no
parts on rank 0: each slab scores each active index over its points (``scores_slab``), and an
index's score is the largest of its slabs'. Joined, slabs are bitwise the whole grid: the sums
at a point run over the indices in index order whatever the slab, and every contraction is
batched over the slab's rows (``_along``: no BLAS call's dimensions depend on the slab's extent;
``tests/sweep/maps/test_sparse_grid.py``: slabs of 1, 2, 3 and 7 pieces, with failed nodes).
On the real 4-D crystal map (25 x 9 x 21 x 31, 232 indices, 104 active; /tmp/s4/map4d.nc of
2026-11-29), its decisions replayed with BLAS on one thread as in a sweep, old and new in one
sitting on the 2-core VM (2026-11-29 11:45 and 11:59 UTC, load 2.2-2.6 and 5-7): the rounds'
decisions 0.15-0.71 CPU s (0.25-1.04 before), the last (its check judged and the fill's estimate
of all 11 stiffnesses) 1.4-1.8 (11.2-11.3; 32.5 measured with OpenBLAS's own threads on the busy
VM), ``fill`` of the whole data set in a fresh process 2.5-2.7 (13.1-13.8).
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Generator, Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from hpcontact.numerics.interpolation import bisection_nodes, weights
from hpcontact.sweep.data.dataset import TENSOR
from hpcontact.sweep.maps.estimates import (
    PRINCIPAL,
    REMEMBERED,
    SAFETY,
    Checks,
    Estimate,
    Layout,
    needed_axes,
    node_tasks,
    principal_from_tensor,
    relative_scale,
    scale_extent,
    solve_errors,
    worked_quantities,
)
from hpcontact.sweep.space.adaptive_settings import Settings

Index = tuple[int, ...]
Fields = Mapping[str, np.ndarray]


class SparseSet(NamedTuple):
    """A sub-problem's downward-closed set of level multi-indices (module docstring): ``old``
    (every forward neighbour in the set) and ``active`` ones, each sorted."""

    old: tuple[Index, ...]
    active: tuple[Index, ...]

    @property
    def indices(self) -> tuple[Index, ...]:
        """Every index of the set, sorted."""
        return tuple(sorted(self.old + self.active))


@functools.lru_cache(maxsize=256)
def level_nodes(n: int, level: int) -> tuple[int, ...]:
    """The nodes of ``level`` along an axis of ``n`` points: the bisection level with 2^level + 1
    nodes (all n when that is at least n)."""
    return tuple(bisection_nodes(n, 2**level + 1))


def tops(shape: Sequence[int]) -> tuple[int, ...]:
    """Per axis of ``shape`` (its point counts), the first level that holds every point."""
    out = []
    for n in shape:
        level = 0
        while len(level_nodes(n, level)) < n:
            level += 1
        out.append(level)
    return tuple(out)


def index_nodes(shape: Sequence[int], index: Index) -> tuple[tuple[int, ...], ...]:
    """The grid of the multi-index ``index``: its nodes per axis."""
    return tuple(level_nodes(n, level) for n, level in zip(shape, index))


def set_nodes(shape: Sequence[int], indices: Sequence[Index]) -> np.ndarray:
    """Whether each point of a grid of ``shape`` is a node of one of ``indices``' grids."""
    mask = np.zeros(tuple(shape), dtype=bool)
    for index in indices:
        mask[np.ix_(*index_nodes(shape, index))] = True
    return mask


def _forward(index: Index, d: int) -> Index:
    return tuple(i + (e == d) for e, i in enumerate(index))


def _backward(index: Index) -> list[Index]:
    return [tuple(i - (e == d) for e, i in enumerate(index)) for d in range(len(index)) if index[d] > 0]


def initial_set(shape: Sequence[int], initial: int) -> SparseSet:
    """The first round's set (module docstring): Σ l_d ≤ L₀, l_d ≤ the axis' top; L₀ the first
    level with ``initial`` nodes (on an axis of at least that many)."""
    top = tops(shape)
    first = 0
    while 2**first + 1 < initial:
        first += 1
    indices = [index for index in itertools.product(*(range(min(first, t) + 1) for t in top)) if sum(index) <= first]
    return split_set(set(indices), top)


def difference_matrices(xs: Sequence[np.ndarray], top: Sequence[int]) -> list[list[np.ndarray]]:
    """Per axis and level l ≤ its top, the matrix of U_l − U_{l−1} (grid points × the level's
    nodes; U_{−1} = 0): ``interpolation.weights`` of the level, less that of the level below on
    its nodes (nested: a subset of the level's). Computed once per axis and top (the
    coordinates as the key): every decision of a map asks for the same."""
    return [_axis_differences(tuple(float(v) for v in x), t) for x, t in zip(xs, top)]


@functools.lru_cache(maxsize=64)
def _axis_differences(x: tuple[float, ...], top: int) -> list[np.ndarray]:
    """``difference_matrices`` of one axis (read only)."""
    coordinates = np.asarray(x)
    n = len(x)
    out = []
    for level in range(top + 1):
        nodes = level_nodes(n, level)
        matrix = weights(coordinates, nodes)
        if level > 0:
            below = level_nodes(n, level - 1)
            position = [nodes.index(i) for i in below]
            matrix[:, position] -= weights(coordinates, below)
        matrix.flags.writeable = False
        out.append(matrix)
    return out


#: Every point of the first axis (``rows``: a slab of the grid is a range of it, ``slab_rows``).
WHOLE = slice(None)


def _along(matrix: np.ndarray, data: np.ndarray, axis: int, lead: int) -> np.ndarray:
    """``matrix`` (n × k) applied along ``axis`` (≥ ``lead``) of ``data`` (k long there): a
    C-contiguous array n long there, each entry Σ_j matrix[i, j] data[…, j, …]. ``lead`` is the
    axis of the grid's first (the slab's: ``slab_rows``); the entries along it and the axes before it
    are batches, so every BLAS call (numpy's matmul: one per batch) has the dimensions, strides
    and values it has whatever the slab's extent: along ``lead`` (``matrix`` the slab's rows of
    the whole grid's matrix) one vector-matrix product per output row, elsewhere one matrix
    product per batch entry. OpenBLAS's products sum an element in an order that depends on the
    row count (0.3.31, SkylakeX kernels, 2026-11-29: rows of A @ B from a slice of A's rows
    differed from the whole product's for every one-row slice, and for every slice tried of a
    31 × 17 by 17 × 675 product); a call of the same dimensions on the same values gives the
    same, with the same BLAS threads (every rank's alike; ``tests/sweep/maps/test_sparse_grid.py``:
    slabs against the whole grid)."""
    shape = data.shape
    k = shape[axis]
    after = math.prod(shape[axis + 1 :])
    if axis == lead:
        flat = np.ascontiguousarray(data).reshape(math.prod(shape[:axis]), 1, k, after)
        out = np.matmul(matrix[:, None, :], flat)  # (before, n, 1, after): a row a call
    else:
        batch, middle = math.prod(shape[: lead + 1]), math.prod(shape[lead + 1 : axis])
        flat = np.ascontiguousarray(data).reshape(batch, middle, k, after)
        if after == 1:
            out = np.matmul(flat[..., 0], matrix.T)
        else:
            out = np.matmul(matrix, flat.reshape(batch * middle, k, after))
    return out.reshape(*shape[:axis], matrix.shape[0], *shape[axis + 1 :])


def _order(matrices: Sequence[np.ndarray]) -> list[int]:
    """The axes in the order they are contracted: those that grow the array least first (twice
    as fast as in order on the 4-D crystal map's 232 indices of 8 quantities, 25 x 9 x 21 x 31,
    2026-11-29; with the quantities last, before: 20 times with one quantity, 2.3 with 11).
    Always of the whole grid's matrices: a slab contracts in the whole grid's order."""
    return sorted(range(len(matrices)), key=lambda a: (matrices[a].shape[0] / matrices[a].shape[1], a))


def _applied(matrices: Sequence[np.ndarray], data: np.ndarray, rows: slice) -> np.ndarray:
    """``matrices`` (the whole grid's, one per axis) applied along the axes of ``data`` after
    its first (the quantities), in the whole grid's ``_order``, the first axis' on its ``rows``."""
    out = data
    for axis in _order(matrices):
        out = _along(matrices[axis][rows] if axis == 0 else matrices[axis], out, axis + 1, 1)
    return out


def surplus(matrices: Sequence[np.ndarray], data: np.ndarray, rows: slice = WHOLE) -> np.ndarray:
    """Δ_l f on the full grid (``rows``: on those of its first axis): ``matrices`` (one per axis,
    ``difference_matrices`` of the index's levels) applied along each axis of ``data`` (the
    values at the index's grid, quantities first: each one's surplus contiguous). A NaN node (a
    failed solve) makes NaN every point whose value it enters with a nonzero weight (Σ |w| over
    its NaN nodes > 0), not the whole lines through it."""
    missing = np.isnan(data)
    out = _applied(matrices, np.where(missing, 0.0, data), rows)
    rows_missing = [q for q in range(len(data)) if missing[q].any()]
    if rows_missing:
        for row, spread in zip(rows_missing, reached(matrices, missing[rows_missing], rows)):
            np.copyto(out[row], np.nan, where=spread)
    return out


def reached(matrices: Sequence[np.ndarray], missing: np.ndarray, rows: slice = WHOLE) -> np.ndarray:
    """Whether each point of the full grid (``rows``: of its first axis) takes a value from a
    ``missing`` node of an index's grid (quantities first, as ``surplus``'s data) with a nonzero
    weight: Σ |w| over them > 0."""
    return _applied([np.abs(m) for m in matrices], missing.astype(np.float64), rows) > 0.0


def combination(
    matrices: Sequence[Sequence[np.ndarray]], cores: Mapping[Index, np.ndarray], rows: slice = WHOLE
) -> np.ndarray:
    """Σ_l Δ_l f on the full grid (``rows``: on those of its first axis) over the indices l of
    ``cores`` (each the values at its grid, quantities last; no NaN): ``matrices`` per axis and
    level (``difference_matrices``). The indices sharing their levels along the last axes share
    the contraction of the rest: the sum over the children c of a suffix p = (l_j … l_{D−1}) of
    D_{j−1,c} applied along axis j − 1 is one product of [D_{j−1,c₁} | D_{j−1,c₂} | …] with their
    blocks stacked along that axis, each block the same sum one axis further in (Σ_l ⊗_d D_{d,l_d}
    = Σ_{l_{D−1}} D_{D−1,l_{D−1}} ⊗ Σ_{l_{D−2}} … ): one matrix product per suffix instead of one
    per index and axis on the full grid. The first axis (the slab's) is contracted first, on
    each core, so every product after it is batched over its rows (``_along``). Equal to the
    sum of ``surplus`` over the indices up to the order of the sums (|difference| ≤ 2γ_m Σ_l
    Σ_j |w_lj f_j|, m the terms of the longest sum: Higham, Accuracy and Stability, §3.1)."""
    dims = len(matrices)
    children: dict[Index, list[int]] = {}
    for index in cores:
        for j in range(dims, 0, -1):
            children.setdefault(index[j:], [])
            if index[j - 1] not in children[index[j:]]:
                children[index[j:]].append(index[j - 1])

    def summed(suffix: Index) -> np.ndarray:
        axis = dims - len(suffix) - 1
        if axis < 0:
            return cores[suffix]
        levels = sorted(children[suffix])
        blocks = [summed((level, *suffix)) for level in levels]
        stacked = blocks[0] if len(blocks) == 1 else np.concatenate(blocks, axis=axis)
        matrix = np.hstack([matrices[axis][level] for level in levels])
        return _along(matrix[rows] if axis == 0 else matrix, stacked, axis, 0)

    return summed(())


def split_set(indices: set[Index], top: Sequence[int]) -> SparseSet:
    """A downward-closed set as ``SparseSet``: active the indices with a forward neighbour (up to
    the axes' tops) outside it, old the rest."""
    active = {i for i in indices if any(i[d] < top[d] and _forward(i, d) not in indices for d in range(len(top)))}
    return SparseSet(tuple(sorted(indices - active)), tuple(sorted(active)))


def admitted(sparse: SparseSet, chosen: set[Index], top: Sequence[int]) -> tuple[SparseSet, list[Index]]:
    """``sparse`` with every forward neighbour of the active indices ``chosen`` (up to the tops)
    and what makes the set downward closed again (``_closed_over``): the new set and the indices
    added. An index stays active while one of its forward neighbours is missing, so its surplus
    stays in the estimate until every direction finer than it is in the set. (Gerstner &
    Griebel retire an index once chosen and add a forward neighbour only when all its backward
    ones are old; their error indicator then loses the surplus of a chosen index whose finer
    neighbours wait, and a mixed term hides behind an index of small surplus: 86 % honest, the
    true error stalled at 6.6e-4 while the estimate said 1.4e-4, on tests/sweep/maps/
    test_sparse_grid.py's map.)"""
    members = set(sparse.indices)
    added = _closed_over(members, _ahead(set(chosen) & set(sparse.active), top))
    return split_set(members | added, top), sorted(added)


def _ahead(indices: set[Index], top: Sequence[int]) -> set[Index]:
    """The forward neighbours of ``indices`` up to the tops."""
    return {_forward(i, d) for i in indices for d in range(len(top)) if i[d] < top[d]}


def _closed_over(members: set[Index], extra: set[Index]) -> set[Index]:
    """What the downward-closed ``members`` needs to hold ``extra`` and stay downward closed
    (with every index, every index ≤ it): ``extra`` and the indices behind them not in it."""
    added = {i for i in extra if i not in members}
    pending = list(added)
    while pending:
        for behind in _backward(pending.pop()):
            if behind not in members and behind not in added:
                added.add(behind)
                pending.append(behind)
    return added


def combined(
    layout: Layout,
    cat: Sequence[int],
    sparse: SparseSet,
    names: Sequence[str],
    fields: Fields,
    safety: float = SAFETY,
) -> tuple[Estimate, np.ndarray]:
    """The ``Estimate`` of the sub-problem ``cat`` from the values at the nodes of ``sparse``
    (module docstring: the combination over every index, the map error ``safety`` × the active
    surpluses scaled by ``next_terms``, relative to the quantity's scale, + the combined solve
    error; its one "axis" the interpolation part) and, per point and quantity, whether its map
    comes from fewer indices because a node it needs failed (``_Failures``; the refinement
    leaves those points be: no index brings the failed node back); computed in slabs of the
    first axis (``spread_slabs``). Inside ``estimates.remembered_estimates``, asked again of the
    same set, quantities and factor with bitwise the same values at its nodes, the first's (the
    check's judgement and the fill after a round ask alike)."""
    remembered = REMEMBERED.get()
    if remembered is None:
        return _combined(layout, cat, sparse, names, fields, safety)
    mask = set_nodes(tuple(len(x) for x in layout.xs), sparse.indices)
    keys = [n for n in fields if n.split("_error")[0] in names or n in TENSOR]
    data = [np.ascontiguousarray(layout.take(fields[n], cat)[mask]) for n in sorted(keys)]
    key = ("sparse", tuple(cat), sparse, tuple(names), safety)
    if key in remembered and _same_arrays(remembered[key][0], data):
        return remembered[key][1]
    result = _combined(layout, cat, sparse, names, fields, safety)
    remembered[key] = (data, result)
    return result


@dataclass(frozen=True)
class SparseJob:
    """What a slab of a sub-problem's decision needs (``_slab``), small enough to send to
    another rank: the coordinates per numeric axis (``xs``), the set, the quantities ``work``
    (the first ``kept`` reported; the rest the tensor a principal stiffness derives from,
    ``derive``), the estimate's factor, the set's nodes (``mask``, the whole grid) and there the
    values and the solves' relative errors (``data``, ``solve_data``: quantities last), the
    quantities left out of the estimate (``lost``: their NaN nodes reach every point through
    the first index, a function of the whole grid) and, for the refinement's ranking, the
    tolerances of the kept quantities (``tol``; None: the estimate itself)."""

    xs: tuple[np.ndarray, ...]
    sparse: SparseSet
    work: tuple[str, ...]
    kept: int
    derive: bool
    safety: float
    mask: np.ndarray
    data: np.ndarray
    solve_data: np.ndarray
    lost: frozenset[int]
    tol: np.ndarray | None = None

    @property
    def rows(self) -> int:
        """The points of the first axis: what the slabs share out."""
        return len(self.xs[0])


def _job(
    layout: Layout,
    cat: Sequence[int],
    sparse: SparseSet,
    names: Sequence[str],
    fields: Fields,
    safety: float,
    tol: np.ndarray | None = None,
) -> SparseJob:
    """The ``SparseJob`` of the sub-problem ``cat`` (``combined``'s arguments)."""
    shape = tuple(len(x) for x in layout.xs)
    matrices = difference_matrices(layout.xs, tops(shape))
    mask = set_nodes(shape, sparse.indices)
    work, derive = worked_quantities(layout, cat, mask, names, fields)
    data = np.stack([layout.take(fields[n], cat)[mask] for n in work], axis=-1)
    solve_data = solve_errors(layout, fields, work, cat)[mask]
    grid = _grid(shape, mask, data)
    root = sparse.indices[0]
    lost = {
        int(q)
        for q in np.flatnonzero(np.isnan(data).any(axis=0))
        if reached(
            [matrices[d][level] for d, level in enumerate(root)],
            np.isnan(grid[np.ix_(*index_nodes(shape, root))][..., q])[None],
        ).all()
    }
    return SparseJob(
        tuple(np.asarray(x) for x in layout.xs),
        sparse,
        tuple(work),
        len(names),
        derive,
        safety,
        mask,
        data,
        solve_data,
        frozenset(lost),
        tol,
    )


def _grid(shape: tuple[int, ...], mask: np.ndarray, data: np.ndarray, fill: float = np.nan) -> np.ndarray:
    """The whole grid of ``shape`` (quantities last): ``data`` at the points of ``mask``, ``fill`` elsewhere."""
    out = np.full((*shape, data.shape[-1]), fill)
    out[mask] = data
    return out


def _combined(
    layout: Layout,
    cat: Sequence[int],
    sparse: SparseSet,
    names: Sequence[str],
    fields: Fields,
    safety: float,
) -> tuple[Estimate, np.ndarray]:
    """``combined`` computed, its slabs as ``spread_slabs`` says, joined along the first axis."""
    results = _SLAB_MAP.get()(estimate_slab, _job(layout, cat, sparse, names, fields, safety))
    slabs = [est for est, _ in results]

    def joined(name: str) -> np.ndarray:
        return np.concatenate([getattr(est, name) for est in slabs])

    est = Estimate(
        joined("values"),
        [np.concatenate([e.axes[0] for e in slabs])],
        joined("solve"),
        joined("scale"),
        joined("owner"),
    )
    return est, np.concatenate([held for _, held in results])


class _Reduced(NamedTuple):
    """What a slab needs of the whole grid (``_slab``), each exact to combine over slabs in any
    order (``reduce_slabs``): per index the surpluses' maxima over the grid (what ``next_terms``
    reads; NaN points left out), and per quantity the largest size ``relative_scale`` falls back
    on, of the values before and after the principal stiffnesses derive (``scale_extent``)."""

    largest: dict[Index, np.ndarray]
    before: tuple[np.ndarray, np.ndarray]
    after: tuple[np.ndarray, np.ndarray]


def reduce_slabs(parts: Sequence[_Reduced]) -> _Reduced:
    """The whole grid's ``_Reduced`` from its slabs': maxima (``np.fmax``: NaN where every slab
    has NaN) and "any finite" (or): exact, whatever the order."""

    def extent(pairs: Sequence[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
        return np.fmax.reduce([p[0] for p in pairs]), np.logical_or.reduce([p[1] for p in pairs])

    return _Reduced(
        {k: np.fmax.reduce([p.largest[k] for p in parts]) for k in parts[0].largest},
        extent([p.before for p in parts]),
        extent([p.after for p in parts]),
    )


Slab = Generator[_Reduced, _Reduced, Any]


def _slab(job: SparseJob, rows: slice, shares: bool) -> Slab:
    """One slab of ``combined`` (the points ``rows`` of the first axis, every point of the
    others): the values and the solve errors as one ``combination`` each, each surplus only
    where the estimate reads it (``_Surpluses``), and, where a quantity has NaN nodes, the
    points they reach from ``_Failures``; yields its part of what needs the whole grid
    (``_Reduced``) and goes on with the whole grid's. Returns the slab's ``Estimate``, the parts
    (``shares``: each active index's part of the interpolation estimate, float32; else empty)
    and where a failed node takes part (``combined``). Every number at a point is computed as
    the whole grid computes it (``_along``; sums over the indices in index order at each
    point), so any slabs joined are bitwise the whole grid's."""
    shape = tuple(len(x) for x in job.xs)
    top = tops(shape)
    matrices = difference_matrices(job.xs, top)
    work, sparse, kept, derive = list(job.work), job.sparse, job.kept, job.derive
    width = len(work)
    grid = _grid(shape, job.mask, job.data)
    errors = _grid(shape, job.mask, job.solve_data, 0.0)
    cores = {index: grid[np.ix_(*index_nodes(shape, index))] for index in sparse.indices}
    values = combination(matrices, {index: np.nan_to_num(core, nan=0.0) for index, core in cores.items()}, rows)
    error_cores = {index: errors[np.ix_(*index_nodes(shape, index))] for index in cores}
    solve = np.abs(combination(matrices, error_cores, rows))
    slab_shape = values.shape[:-1]
    groups: dict[bytes, list[int]] = {}  # the quantities NaN at the same nodes (a failed solve: all)
    for q in np.flatnonzero(np.isnan(job.data).any(axis=0)):
        groups.setdefault(np.packbits(np.isnan(job.data[:, q])).tobytes(), []).append(int(q))
    # no surpluses of a principal stiffness derived from the tensor (its value and estimate are
    # replaced below: principal_from_tensor), nor of a quantity whose NaN nodes reach every point
    # through the first index (no map anywhere: _Failures; normalized_* of a crystal)
    derived = {q for q, name in enumerate(work) if derive and name in PRINCIPAL}
    own = [q for q in range(width) if q not in derived and q not in job.lost]
    surpluses = _Surpluses(
        matrices,
        {index: np.moveaxis(core[..., own], -1, 0) for index, core in cores.items()},
        width,
        own,
        set(sparse.active),
        rows,
    )
    members = set(sparse.indices)
    failures = []
    held = np.zeros(values.shape, dtype=bool)
    for columns in groups.values():
        found = _Failures(
            matrices,
            sparse,
            {index: np.moveaxis(core[..., columns], -1, 0) for index, core in cores.items()},
            {index: np.moveaxis(core[..., columns], -1, 0) for index, core in error_cores.items()},
            rows,
        )
        for j, c in enumerate(columns):
            values[..., c] = np.where(found.touched, found.value[j], values[..., c])
            solve[..., c] = np.where(found.touched, found.error[j], solve[..., c])
            held[..., c] = found.touched
        estimated = [(j, c) for j, c in enumerate(columns) if c not in derived]
        failures.append((found, estimated))
    steps = set_steps(sparse, top)
    read = set().union(*(steps[index].read(index) for index in sparse.active))
    wanted = members if any(columns for _, columns in failures) else read  # _Failures: any subset's
    for index in sorted(wanted):
        surpluses[index]
    principal = values.copy()
    if derive:
        principal_from_tensor(principal, [], work)
    whole = yield _Reduced(
        {index: surpluses.largest[index] for index in sorted(wanted)},
        scale_extent(work, values),
        scale_extent(work, principal),
    )
    summed = np.zeros((len(own), *slab_shape))  # Σ ρ_l |Δ_l| over the active indices, quantities first
    parts: dict[Index, np.ndarray] = {}
    rhos = next_terms_of(sparse.active, steps, whole.largest)
    for index in sparse.active:
        size = surpluses.size(index)
        rho = rhos[index][own].reshape(-1, *(1 for _ in shape))
        if shares:  # the refinement's ranking keeps the parts: |Δ_l| in float32, as before
            weighted = rho * size.astype(np.float32)
            parts[index] = weighted
        else:
            weighted = np.multiply(size, rho, out=size)
        summed += weighted
    absolute = np.zeros_like(values)
    absolute[..., own] = np.moveaxis(summed, 0, -1)
    for found, estimated in failures:
        interpolation_sum = found.summed(estimated, whole.largest, top)
        for k, (_, c) in enumerate(estimated):
            absolute[..., c] = np.where(found.touched, interpolation_sum[k], absolute[..., c])
    scale = relative_scale(work, values, whole.before)
    interpolation = job.safety * absolute / scale
    keep = slice(0, kept)
    for index, part in parts.items():
        if len(own) == width:  # every quantity
            parts[index] = (job.safety * np.moveaxis(part[:kept], 0, -1) / scale[..., keep]).astype(np.float32)
            continue
        share = np.zeros_like(values)
        share[..., own] = np.moveaxis(part, 0, -1)
        share = job.safety * share / scale
        if derive:
            principal_from_tensor(values.copy(), [share], work, whole.before)
        parts[index] = share[..., :kept].astype(np.float32)
    if derive:
        principal_from_tensor(values, [interpolation], work, whole.before)
        scale = relative_scale(work, values, whole.after)
        tensor_held = held[..., [work.index(n) for n in TENSOR]].any(axis=-1)
        for q in (q for q, name in enumerate(work) if name in PRINCIPAL):
            held[..., q] = tensor_held
    est = Estimate(
        values[..., keep],
        [interpolation[..., keep]],
        solve[..., keep],
        scale[..., keep],
        np.zeros(slab_shape, np.intp),
    )
    return est, parts, held[..., keep]


def estimate_slab(job: SparseJob, rows: slice) -> Slab:
    """A slab's ``Estimate`` and where a failed node takes part (``_slab`` without the parts)."""
    est, _, held = yield from _slab(job, rows, shares=False)
    return est, held


def scores_slab(job: SparseJob, rows: slice) -> Slab:
    """Per active index, the largest excess over the tolerance (``job.tol``) of the slab's
    points and quantities it is needed at (``estimates.needed_axes`` of the indices' parts, at
    the points over their tolerance but where a failed node takes part): the whole grid's
    score of an index is the largest of its slabs' (``refine``)."""
    est, parts, held = yield from _slab(job, rows, shares=True)
    tol = job.tol
    with np.errstate(invalid="ignore"):
        error = est.map_error
        over = (np.nan_to_num(error, nan=0.0) > tol) & ~held  # a failed node's surroundings: no index helps
        points = over.any(axis=-1)
    if not points.any() or not parts:
        return {}
    keys = sorted(parts)
    where = np.flatnonzero(points)
    stacked = np.stack([parts[k].reshape(-1, len(tol))[where] for k in keys])  # (indices, points, quantities)
    budget = np.maximum(tol - est.solve[points], tol / 4.0)
    excess = np.where(over[points], error[points] / tol, 0.0)
    need = needed_axes(list(stacked), budget)
    return {index: float(np.where(needed, excess, 0.0).max()) for index, needed in zip(keys, need)}


def slab_rows(rows: int, pieces: int) -> list[slice]:
    """``rows`` split into ``pieces`` contiguous slabs (at most one a row), the first ones a row
    longer where they do not divide."""
    count = max(1, min(pieces, rows))
    edges = [i * (rows // count) + min(i, rows % count) for i in range(count + 1)]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:])]


def stepped(slabs: Sequence[Slab]) -> list[Any]:
    """Run ``slabs`` (``estimate_slab``/``scores_slab`` generators of one job) in step: each
    time every one has yielded its part, it is sent the whole (``reduce_slabs``); their results in
    order."""
    message = None
    while True:
        yielded, results = [], []
        for slab in slabs:
            try:
                yielded.append(slab.send(message))
            except StopIteration as stop:
                results.append(stop.value)
        if len(results) == len(slabs):
            return results
        if results:
            raise RuntimeError("the slabs of one job ended at different steps")
        message = reduce_slabs(yielded)


SlabMap = Callable[[Callable[[SparseJob, slice], Slab], SparseJob], list[Any]]


def _serial(function: Callable[[SparseJob, slice], Slab], job: SparseJob) -> list[Any]:
    """The whole grid as one slab, here."""
    return stepped([function(job, WHOLE)])


#: How ``combined`` and ``refine`` compute their slabs (``spread_slabs``: over the ranks of a team).
_SLAB_MAP: ContextVar[SlabMap] = ContextVar("slab_map", default=_serial)


@contextmanager
def spread_slabs(slab_map: SlabMap) -> Iterator[None]:
    """Every decision inside computes its slabs with ``slab_map`` (a slab function and its job
    → the slabs' results in order; ``maps.spread.LeafPool.slabs`` shares them out over the
    ranks), not the whole grid here."""
    token = _SLAB_MAP.set(slab_map)
    try:
        yield
    finally:
        _SLAB_MAP.reset(token)


class _Failures:
    """Quantities NaN at the same nodes (a failed solve; ``cores``: each index's values at its
    grid, quantities first; ``errors``: their solve errors alike) on the points ``rows`` of the
    first axis: where a NaN node reaches (``reached``) a point x through the surplus of an index,
    the map there is the combination over S_x, the set less every index ≥ one whose surplus
    takes a NaN node at x (downward closed: the largest such subset), as if those indices had
    not been solved — a finer index needs the coarser ones' values to be a surplus at all.
    ``touched``: whether each point is such a point; there ``value`` and ``error`` the values
    and |solve errors| combined over S_x, NaN where S_x is empty (the first index takes a NaN
    node: nothing to interpolate from); ``summed`` the estimate there."""

    def __init__(
        self,
        matrices: Sequence[Sequence[np.ndarray]],
        sparse: SparseSet,
        cores: Mapping[Index, np.ndarray],
        errors: Mapping[Index, np.ndarray],
        rows: slice,
    ) -> None:
        self.matrices, self.sparse, self.cores, self.errors, self.rows = matrices, sparse, cores, errors, rows
        shape = (len(matrices[0][0][rows]), *(per_axis[0].shape[0] for per_axis in matrices[1:]))
        self.count = count = len(next(iter(cores.values())))
        self.value, self.error = np.full((count, *shape), np.nan), np.full((count, *shape), np.nan)
        self.shape = shape
        failing = [index for index in sparse.indices if np.isnan(cores[index][0]).any()]
        root = sparse.indices[0]  # (0, …, 0): below every index
        dead = self._reached(root) if root in failing else np.zeros(shape, dtype=bool)
        reach = {} if dead.all() else {i: self._reached(i) for i in failing if i != root}
        self.touched = np.logical_or.reduce([dead, *reach.values()])
        self.live = live = np.flatnonzero(self.touched & ~dead)
        self.evaluated: dict[Index, tuple[np.ndarray, np.ndarray]] = {}
        self.kept: list[tuple[set[Index], np.ndarray]] = []  # per pattern: S_x and its points among live
        if not len(live):
            return
        keys = list(reach)
        patterns, inverse = np.unique(
            np.stack([reach[i].ravel()[live] for i in keys], axis=1), axis=0, return_inverse=True
        )
        for p, pattern in enumerate(patterns):
            bad = [index for index, hit in zip(keys, pattern) if hit]
            kept = {m for m in sparse.indices if not any(all(a >= b for a, b in zip(m, i)) for i in bad)}
            here = np.flatnonzero(inverse.ravel() == p)
            points = live[here]
            self.value.reshape(count, -1)[:, points] = sum(self._at(index)[0][:, here] for index in sorted(kept))
            self.error.reshape(count, -1)[:, points] = np.abs(
                sum(self._at(index)[1][:, here] for index in sorted(kept))
            )
            self.kept.append((kept, here))

    def _along(self, index: Index) -> list[np.ndarray]:
        return [self.matrices[d][level] for d, level in enumerate(index)]

    def _reached(self, index: Index) -> np.ndarray:
        return reached(self._along(index), np.isnan(self.cores[index][:1]), self.rows)[0]

    def _at(self, index: Index) -> tuple[np.ndarray, np.ndarray]:
        """Δ_l f and Δ_l e at the live points."""
        if index not in self.evaluated:
            self.evaluated[index] = (
                surplus(self._along(index), self.cores[index], self.rows).reshape(self.count, -1)[:, self.live],
                surplus(self._along(index), self.errors[index], self.rows).reshape(self.count, -1)[:, self.live],
            )
        return self.evaluated[index]

    def summed(
        self, estimated: Sequence[tuple[int, int]], largest: Mapping[Index, np.ndarray], top: Sequence[int]
    ) -> np.ndarray:
        """For the quantities ``estimated`` ((position here, column of ``largest``, the whole
        grid's maxima)), Σ ρ_l |Δ_l f| over the active indices of S_x (``next_terms`` within
        S_x: an index whose finer neighbour is left out estimates what that one would add)."""
        out = np.full((len(estimated), *self.shape), np.nan)
        if not estimated:
            return out
        positions, columns = (list(c) for c in zip(*estimated))
        for kept, here in self.kept:
            total = np.zeros((len(estimated), len(here)))
            for index in split_set(kept, top).active:
                rho = next_terms(index, kept, largest, top)[columns]
                total += rho[:, None] * np.abs(self._at(index)[0][positions][:, here])
            out.reshape(len(estimated), -1)[:, self.live[here]] = total
        return out


#: Bytes of surpluses ``_Surpluses`` keeps for the index that will ask for them (beyond, it
#: evaluates them again): 14 of the 4-D crystal map's full grids of 8 quantities (9.4 MB each).
KEPT_BYTES = 2**27


class _Surpluses:
    """The surpluses of a set's indices (``cores``: the values at each one's grid, of the
    quantities ``own`` of ``width``), each evaluated on the points ``rows`` of the first axis
    (``surplus``) when first asked for: ``size(l)``, |Δ_l f|; ``[l]`` evaluates it for
    ``largest[l]``, its maximum per quantity (0 for the others; NaN points left out). Quantities
    first. A surplus evaluated for its maximum before ``size`` asks for it (an index of
    ``wanted``) is kept for that (up to ``KEPT_BYTES``)."""

    def __init__(
        self,
        matrices: Sequence[Sequence[np.ndarray]],
        cores: Mapping[Index, np.ndarray],
        width: int,
        own: Sequence[int],
        wanted: set[Index],
        rows: slice,
    ) -> None:
        self.matrices, self.cores, self.width, self.own, self.wanted = matrices, cores, width, list(own), wanted
        self.rows = rows
        self.largest: dict[Index, np.ndarray] = {}
        self.kept: dict[Index, np.ndarray] = {}

    def _evaluated(self, index: Index) -> np.ndarray:
        size = surplus([self.matrices[d][level] for d, level in enumerate(index)], self.cores[index], self.rows)
        np.abs(size, out=size)
        largest = np.zeros(self.width)
        largest[self.own] = np.fmax.reduce(size.reshape(len(self.own), -1), axis=1, initial=0.0)  # NaN: a failed node
        self.largest[index] = largest
        return size

    def size(self, index: Index) -> np.ndarray:
        """|Δ_l f| on the slab (the quantities ``own`` first), yours to change."""
        return self.kept.pop(index) if index in self.kept else self._evaluated(index)

    def __getitem__(self, index: Index) -> np.ndarray:
        if index not in self.largest:
            size = self._evaluated(index)
            if index in self.wanted and size.nbytes + sum(k.nbytes for k in self.kept.values()) <= KEPT_BYTES:
                self.kept[index] = size
        return self.largest[index]


def next_terms(
    index: Index, members: set[Index], largest: Mapping[Index, np.ndarray], top: Sequence[int]
) -> np.ndarray:
    """ρ_l (module docstring), per quantity: the expected |Δ_m| / |Δ_l| of the missing forward
    neighbours m = l + e_d of the active index l (``index``), the largest ratio of a step along
    d seen next to it, max|Δ_k| / max|Δ_{k − e_d}| (``largest``: the maxima over the grid) for
    k = l (the step before, where l_d ≥ 1) and for k = l − e_j + e_d in the set (the same step
    one level lower along another axis j); at most 1, and 1 where no such step is in the set.
    The interpolation's order grows up to the cubic's (linear, quadratic, then cubic on halved
    spacing: ratios about 1/4, 1/8, then 1/16), so the last step's ratio over-estimates the
    next one's where the surpluses are in their asymptotic regime. One index of
    ``next_terms_of``."""
    return next_terms_of([index], {index: next_steps(index, members, top)}, largest)[index]


class Steps(NamedTuple):
    """The steps whose ratios ``next_terms`` takes for an active index (structure alone, the
    same whatever the values): the pairs (k, k − e_d), and whether a missing forward neighbour
    has no step next to it (ρ = 1 whatever the pairs)."""

    pairs: tuple[tuple[Index, Index], ...]
    none_seen: bool

    def read(self, index: Index) -> set[Index]:
        """The indices whose maxima ``next_terms`` of ``index`` reads."""
        return {index, *(i for pair in self.pairs for i in pair)}


def next_steps(index: Index, members: set[Index], top: Sequence[int]) -> Steps:
    """``Steps`` of the active ``index`` of the set ``members`` (``next_terms``), the pairs in the
    order ``next_terms`` reads them up to the first missing neighbour without a step."""
    pairs: list[tuple[Index, Index]] = []
    for d in range(len(top)):
        if index[d] >= top[d] or _forward(index, d) in members:
            continue
        steps = [index] if index[d] > 0 else []
        steps += [
            _forward(behind, d)
            for behind in _backward(index)
            if behind != tuple(i - (e == d) for e, i in enumerate(index)) and _forward(behind, d) in members
        ]
        if not steps:
            return Steps(tuple(pairs), True)
        pairs += [(k, tuple(i - (e == d) for e, i in enumerate(k))) for k in steps]
    return Steps(tuple(pairs), False)


@functools.lru_cache(maxsize=32)
def set_steps(sparse: SparseSet, top: tuple[int, ...]) -> dict[Index, Steps]:
    """``next_steps`` of every active index of ``sparse`` (cached, not to be changed: a decision's
    slabs on one rank, its estimate and its ranking read the same set's)."""
    members = set(sparse.indices)
    return {index: next_steps(index, members, top) for index in sparse.active}


def next_terms_of(
    indices: Sequence[Index], steps: Mapping[Index, Steps], largest: Mapping[Index, np.ndarray]
) -> dict[Index, np.ndarray]:
    """``next_terms`` of each of ``indices`` from its ``steps``, every ratio at once: per pair
    max|Δ_k| / max|Δ_{k − e_d}| capped at 1 (1 where the step's maximum is not > 0), the largest
    of an index's pairs (0 without any), 1 where a neighbour has no step. Elementwise the
    operations of one index at a time, and a maximum is exact in any order: the same bits."""
    if not indices:
        return {}
    like = largest[indices[0]]
    refs = sorted({i for index in indices for pair in steps[index].pairs for i in pair})
    where = {ref: n for n, ref in enumerate(refs)}
    owner = [n for n, index in enumerate(indices) for _ in steps[index].pairs]
    above = [where[k] for index in indices for k, _ in steps[index].pairs]
    below_at = [where[b] for index in indices for _, b in steps[index].pairs]
    out = np.zeros((len(indices), *like.shape), like.dtype)
    if owner:
        maxima = np.stack([largest[ref] for ref in refs])
        below = maxima[below_at]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(below > 0.0, np.fmin(maxima[above] / below, 1.0), 1.0)
        np.fmax.at(out, np.asarray(owner), ratio)
    out[[n for n, index in enumerate(indices) if steps[index].none_seen]] = 1.0
    return {index: out[n] for n, index in enumerate(indices)}


def estimate(
    layout: Layout,
    cat: Sequence[int],
    sparse: SparseSet,
    names: Sequence[str],
    fields: Fields,
    safety: float = SAFETY,
) -> Estimate:
    """``combined``'s estimate alone."""
    return combined(layout, cat, sparse, names, fields, safety)[0]


def _same_arrays(a: Sequence[np.ndarray], b: Sequence[np.ndarray]) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y, equal_nan=True) for x, y in zip(a, b))


def refine(
    layout: Layout,
    settings: Settings,
    state: Sequence[tuple[tuple[int, ...], SparseSet]],
    fields: Fields,
    names: Sequence[str],
    task_of: np.ndarray,
    checks: Checks,
) -> tuple | None:
    """The next round's state (module docstring: refinement), or None when no point is over its
    tolerance (or no index fits ``max_solves``). Each index's score is the largest of its slabs'
    (``scores_slab``, computed as ``spread_slabs`` says). Deterministic: every rank given the
    same values decides the same."""
    shape = tuple(len(x) for x in layout.xs)
    top = tops(shape)
    tol = np.array([settings.tolerance(n) for n in names])
    candidates = []  # (score, sub-problem, index)
    for s, (cat, sparse) in enumerate(state):
        scores: dict[Index, float] = {}
        for slab in _SLAB_MAP.get()(scores_slab, _job(layout, cat, sparse, names, fields, checks.factor(s), tol)):
            for index, score in slab.items():
                scores[index] = max(scores.get(index, score), score)
        candidates += [(score, s, index) for index, score in scores.items() if score > 1.0]
    if not candidates:
        return None
    flat = np.arange(math.prod(layout.shape)).reshape(layout.shape)
    task_of = np.asarray(task_of).ravel()
    masks = [(cat, set_nodes(shape, sparse.indices)) for cat, sparse in state]
    taken = set(node_tasks(layout, masks, task_of, checks).tolist())
    chosen: dict[int, set[Index]] = {}
    members = {s: set(sparse.indices) for s, (_, sparse) in enumerate(state)}  # with the chosen so far
    for _, s, index in sorted(candidates, key=lambda c: (-c[0], c[1], c[2])):
        if settings.max_solves is not None:
            added = _closed_over(members[s], _ahead({index}, top))
            new = set()
            for extra in added:
                new |= set(task_of[layout.take(flat, state[s][0], index_nodes(shape, extra)).ravel()].tolist())
            if len(taken | new) > settings.max_solves:
                continue
            taken |= new
            members[s] |= added
        chosen.setdefault(s, set()).add(index)
    if not chosen:
        return None
    return tuple(
        (cat, admitted(sparse, chosen[s], top)[0] if s in chosen else sparse) for s, (cat, sparse) in enumerate(state)
    )
