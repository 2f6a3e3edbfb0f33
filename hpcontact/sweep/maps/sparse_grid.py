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

Failed nodes (``_around_failures``). A solve that failed leaves NaN at its node. Where the
surplus of an index takes it (a nonzero weight: ``reached``), the map at that point x is the
combination over S_x, S less every index ≥ one that takes it there (downward closed: as if those
had not been solved), its map error the active surpluses of S_x, so it says what the indices
left out would add; the refinement leaves those points be (no index brings the node back).
Where the first index (level 0) takes it — a failed corner, at every point but the faces
opposite it — nothing is left to interpolate from: NaN, which the data set reports as not
interpolated (``fill``). A quantity undefined at some nodes (NaN by definition) is treated alike.

Cost of a decision (``combined``): the values and the solves' errors are one ``combination``
each (the indices sharing their leading levels share one matrix product); the surpluses on the
full grid only of the active indices and of those whose maxima ``next_terms`` reads, each
contracted once where it can be kept (``_Surpluses``), quantities first, none for a principal
stiffness derived from the tensor; the active parts kept (float32) for the refinement's ranking.
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
from collections.abc import Iterator, Mapping, Sequence
from typing import NamedTuple

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


def _along(matrix: np.ndarray, data: np.ndarray, axis: int) -> np.ndarray:
    """``matrix`` (n × k) applied along ``axis`` of ``data`` (k long there): a C-contiguous array
    n long there, each entry Σ_j matrix[i, j] data[…, j, …] (matrix products, no transpose)."""
    shape = data.shape
    before, after = math.prod(shape[:axis]), math.prod(shape[axis + 1 :])
    flat = np.ascontiguousarray(data).reshape(before, shape[axis], after)
    if before == 1:
        out = matrix @ flat[0]
    elif after == 1:
        out = flat[..., 0] @ matrix.T
    else:
        out = np.matmul(matrix, flat)
    return out.reshape(*shape[:axis], matrix.shape[0], *shape[axis + 1 :])


def _order(matrices: Sequence[np.ndarray]) -> list[int]:
    """The axes in the order they are contracted: those that grow the array least first (twice
    as fast as in order on the 4-D crystal map's 232 indices of 8 quantities, 25 x 9 x 21 x 31,
    2026-11-29; with the quantities last, before: 20 times with one quantity, 2.3 with 11)."""
    return sorted(range(len(matrices)), key=lambda a: (matrices[a].shape[0] / matrices[a].shape[1], a))


def surplus(matrices: Sequence[np.ndarray], data: np.ndarray) -> np.ndarray:
    """Δ_l f on the full grid: ``matrices`` (one per axis, ``difference_matrices`` of the index's
    levels) applied along each axis of ``data`` (the values at the index's grid, quantities
    first: each one's surplus contiguous). A NaN node (a failed solve) makes NaN every point
    whose value it enters with a nonzero weight (Σ |w| over its NaN nodes > 0), not the whole
    lines through it."""
    missing = np.isnan(data)
    out = np.where(missing, 0.0, data)
    for axis in _order(matrices):
        out = _along(matrices[axis], out, axis + 1)
    rows = [q for q in range(len(data)) if missing[q].any()]
    if rows:
        for row, spread in zip(rows, reached(matrices, missing[rows])):
            np.copyto(out[row], np.nan, where=spread)
    return out


def reached(matrices: Sequence[np.ndarray], missing: np.ndarray) -> np.ndarray:
    """Whether each point of the full grid takes a value from a ``missing`` node of an index's
    grid (quantities first, as ``surplus``'s data) with a nonzero weight: Σ |w| over them > 0."""
    spread = missing.astype(np.float64)
    for axis in _order(matrices):
        spread = _along(np.abs(matrices[axis]), spread, axis + 1)
    return spread > 0.0


def combination(matrices: Sequence[Sequence[np.ndarray]], cores: Mapping[Index, np.ndarray]) -> np.ndarray:
    """Σ_l Δ_l f on the full grid over the indices l of ``cores`` (each the values at its grid,
    quantities last; no NaN): ``matrices`` per axis and level (``difference_matrices``). The
    indices sharing their levels along the first axes share the contraction of the rest: the
    sum over the children c of a prefix p = (l_0 … l_{j−1}) of D_{j,c} applied along axis j is
    one product of [D_{j,c₁} | D_{j,c₂} | …] with their blocks stacked along that axis, each
    block the same sum one axis deeper (Σ_l ⊗_d D_{d,l_d} = Σ_{l_0} D_{0,l_0} ⊗ Σ_{l_1} … ): one
    matrix product per prefix instead of one per index and axis on the full grid. Equal to the
    sum of ``surplus`` over the indices up to the order of the sums (|difference| ≤ 2γ_m Σ_l
    Σ_j |w_lj f_j|, m the terms of the longest sum: Higham, Accuracy and Stability, §3.1)."""
    dims = len(matrices)
    children: dict[Index, list[int]] = {}
    for index in cores:
        for j in range(dims):
            children.setdefault(index[:j], [])
            if index[j] not in children[index[:j]]:
                children[index[:j]].append(index[j])

    def summed(prefix: Index) -> np.ndarray:
        axis = len(prefix)
        if axis == dims:
            return cores[prefix]
        levels = sorted(children[prefix])
        blocks = [summed((*prefix, level)) for level in levels]
        stacked = blocks[0] if len(blocks) == 1 else np.concatenate(blocks, axis=axis)
        matrix = np.hstack([matrices[axis][level] for level in levels])
        return _along(matrix, stacked, axis)

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
    shares: bool = False,
) -> tuple[Estimate, dict[Index, np.ndarray], np.ndarray]:
    """The ``Estimate`` of the sub-problem ``cat`` from the values at the nodes of ``sparse``
    (module docstring: the combination over every index, the map error ``safety`` × the active
    surpluses scaled by ``next_terms``, relative to the quantity's scale, + the combined solve
    error; its one "axis" the interpolation part); with ``shares`` each active index's part of
    the interpolation estimate (grid × ``names``, float32; for a derived principal stiffness,
    the tensor bound of that index's part alone), without an empty dict; and, per point and
    quantity, whether its map comes from fewer indices because a node it needs failed
    (``_around_failures``; the refinement leaves those points be: no index brings the failed
    node back). Inside ``estimates.remembered_estimates``, asked again of the same set,
    quantities and factor with bitwise the same values at its nodes, the first's (the check's
    judgement, the refinement and the fill after a round ask alike)."""
    remembered = REMEMBERED.get()
    if remembered is None:
        return _combined(layout, cat, sparse, names, fields, safety, shares)
    mask = set_nodes(tuple(len(x) for x in layout.xs), sparse.indices)
    keys = [n for n in fields if n.split("_error")[0] in names or n in TENSOR]
    data = [np.ascontiguousarray(layout.take(fields[n], cat)[mask]) for n in sorted(keys)]
    key = ("sparse", tuple(cat), sparse, tuple(names), safety, shares)
    if key in remembered and _same_arrays(remembered[key][0], data):
        return remembered[key][1]
    result = _combined(layout, cat, sparse, names, fields, safety, shares)
    remembered[key] = (data, result)
    return result


def _combined(
    layout: Layout,
    cat: Sequence[int],
    sparse: SparseSet,
    names: Sequence[str],
    fields: Fields,
    safety: float,
    shares: bool,
) -> tuple[Estimate, dict[Index, np.ndarray], np.ndarray]:
    """``combined`` computed: the values and the solve errors as one ``combination`` each, each
    surplus on the full grid only where the estimate reads it (``_Surpluses``), and, where a
    quantity has NaN nodes, the points they reach from ``_around_failures``."""
    shape = tuple(len(x) for x in layout.xs)
    top = tops(shape)
    matrices = difference_matrices(layout.xs, top)
    work, derive = worked_quantities(layout, cat, set_nodes(shape, sparse.indices), names, fields)
    kept = len(names)
    grid = np.stack([layout.take(fields[n], cat) for n in work], axis=-1)
    cores = {index: grid[np.ix_(*index_nodes(shape, index))] for index in sparse.indices}
    values = combination(matrices, {index: np.nan_to_num(core, nan=0.0) for index, core in cores.items()})
    errors = solve_errors(layout, fields, work, cat)
    error_cores = {index: errors[np.ix_(*index_nodes(shape, index))] for index in cores}
    solve = np.abs(combination(matrices, error_cores))
    nodes = grid[set_nodes(shape, sparse.indices)]
    groups: dict[bytes, list[int]] = {}  # the quantities NaN at the same nodes (a failed solve: all)
    for q in np.flatnonzero(np.isnan(nodes).any(axis=0)):
        groups.setdefault(np.packbits(np.isnan(nodes[:, q])).tobytes(), []).append(int(q))
    # no surpluses of a principal stiffness derived from the tensor (its value and estimate are
    # replaced below: principal_from_tensor), nor of a quantity whose NaN nodes reach every point
    # through the first index (no map anywhere: _around_failures; normalized_* of a crystal)
    derived = {q for q, name in enumerate(work) if derive and name in PRINCIPAL}
    root = sparse.indices[0]
    lost = {
        q
        for columns in groups.values()
        if reached(
            [matrices[d][level] for d, level in enumerate(root)], np.isnan(cores[root][..., columns[0]])[None]
        ).all()
        for q in columns
    }
    own = [q for q in range(len(work)) if q not in derived and q not in lost]
    surpluses = _Surpluses(
        matrices,
        {index: np.moveaxis(core[..., own], -1, 0) for index, core in cores.items()},
        len(work),
        own,
        set(sparse.active),
    )
    summed = np.zeros((len(own), *shape))  # Σ ρ_l |Δ_l| over the active indices, quantities first
    members = set(sparse.indices)
    parts: dict[Index, np.ndarray] = {}
    for index in sparse.active:
        size = surpluses.size(index)
        rho = next_terms(index, members, surpluses, top)[own].reshape(-1, *(1 for _ in shape))
        if shares:  # the refinement's ranking keeps the parts: |Δ_l| in float32, as before
            weighted = rho * size.astype(np.float32)
            parts[index] = weighted
        else:
            weighted = np.multiply(size, rho, out=size)
        summed += weighted
    absolute = np.zeros_like(values)
    absolute[..., own] = np.moveaxis(summed, 0, -1)
    held = np.zeros(values.shape, dtype=bool)
    for columns in groups.values():
        estimated = [(j, c) for j, c in enumerate(columns) if c not in derived]
        touched, value, error, interpolation_sum = _around_failures(
            matrices,
            sparse,
            {index: np.moveaxis(core[..., columns], -1, 0) for index, core in cores.items()},
            {index: np.moveaxis(core[..., columns], -1, 0) for index, core in error_cores.items()},
            estimated,
            surpluses,
        )
        for j, c in enumerate(columns):
            values[..., c] = np.where(touched, value[j], values[..., c])
            solve[..., c] = np.where(touched, error[j], solve[..., c])
            held[..., c] = touched
        for k, (_, c) in enumerate(estimated):
            absolute[..., c] = np.where(touched, interpolation_sum[k], absolute[..., c])
    scale = relative_scale(work, values)
    interpolation = safety * absolute / scale
    keep = slice(0, kept)
    for index, part in parts.items():
        if len(own) == len(work):  # every quantity
            parts[index] = (safety * np.moveaxis(part[:kept], 0, -1) / scale[..., keep]).astype(np.float32)
            continue
        share = np.zeros_like(values)
        share[..., own] = np.moveaxis(part, 0, -1)
        share = safety * share / scale
        if derive:
            principal_from_tensor(values.copy(), [share], work)
        parts[index] = share[..., :kept].astype(np.float32)
    if derive:
        principal_from_tensor(values, [interpolation], work)
        scale = relative_scale(work, values)
        tensor_held = held[..., [work.index(n) for n in TENSOR]].any(axis=-1)
        for q in (q for q, name in enumerate(work) if name in PRINCIPAL):
            held[..., q] = tensor_held
    est = Estimate(
        values[..., keep], [interpolation[..., keep]], solve[..., keep], scale[..., keep], np.zeros(shape, np.intp)
    )
    return est, parts, held[..., keep]


def _around_failures(
    matrices: Sequence[Sequence[np.ndarray]],
    sparse: SparseSet,
    cores: Mapping[Index, np.ndarray],
    errors: Mapping[Index, np.ndarray],
    estimated: Sequence[tuple[int, int]],
    largest: Mapping[Index, np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Quantities NaN at the same nodes (a failed solve; ``cores``: each index's values at its
    grid, quantities first; ``errors``: their solve errors alike) where a NaN node reaches
    (``reached``) a point x through the surplus of an index: the map there is the combination
    over S_x, the set less every index ≥ one whose surplus takes a NaN node at x (downward closed:
    the largest such subset), as if those indices had not been solved — a finer index needs the
    coarser ones' values to be a surplus at all. Returns whether each point is such a point, and
    there the values and |solve errors| combined over S_x and, for the quantities ``estimated``
    ((position here, column of ``largest``)), Σ ρ_l |Δ_l f| over the active indices of S_x
    (``next_terms`` within S_x: an index whose finer neighbour is left out estimates what that
    one would add); NaN where S_x is empty (the first index takes a NaN node: nothing to
    interpolate from)."""
    shape = tuple(per_axis[0].shape[0] for per_axis in matrices)
    top = tuple(len(per_axis) - 1 for per_axis in matrices)
    count = len(next(iter(cores.values())))
    value, error = np.full((count, *shape), np.nan), np.full((count, *shape), np.nan)
    summed = np.full((len(estimated), *shape), np.nan)

    def along(index: Index) -> list[np.ndarray]:
        return [matrices[d][level] for d, level in enumerate(index)]

    failing = [index for index in sparse.indices if np.isnan(cores[index][0]).any()]
    root = sparse.indices[0]  # (0, …, 0): below every index
    dead = reached(along(root), np.isnan(cores[root][:1]))[0] if root in failing else np.zeros(shape, dtype=bool)
    reach = {} if dead.all() else {i: reached(along(i), np.isnan(cores[i][:1]))[0] for i in failing if i != root}
    touched = np.logical_or.reduce([dead, *reach.values()])
    live = np.flatnonzero(touched & ~dead)
    if not len(live):
        return touched, value, error, summed
    keys = list(reach)
    patterns, inverse = np.unique(np.stack([reach[i].ravel()[live] for i in keys], axis=1), axis=0, return_inverse=True)
    evaluated: dict[Index, tuple[np.ndarray, np.ndarray]] = {}

    def at(index: Index) -> tuple[np.ndarray, np.ndarray]:  # Δ_l f and Δ_l e at the live points
        if index not in evaluated:
            evaluated[index] = (
                surplus(along(index), cores[index]).reshape(count, -1)[:, live],
                surplus(along(index), errors[index]).reshape(count, -1)[:, live],
            )
        return evaluated[index]

    for p, pattern in enumerate(patterns):
        bad = [index for index, hit in zip(keys, pattern) if hit]
        kept = {m for m in sparse.indices if not any(all(a >= b for a, b in zip(m, i)) for i in bad)}
        here = np.flatnonzero(inverse.ravel() == p)
        points = live[here]
        value.reshape(count, -1)[:, points] = sum(at(index)[0][:, here] for index in sorted(kept))
        error.reshape(count, -1)[:, points] = np.abs(sum(at(index)[1][:, here] for index in sorted(kept)))
        if estimated:
            positions, columns = zip(*estimated)
            total = np.zeros((len(estimated), len(here)))
            for index in split_set(kept, top).active:
                rho = next_terms(index, kept, largest, top)[list(columns)]
                total += rho[:, None] * np.abs(at(index)[0][list(positions)][:, here])
            summed.reshape(len(estimated), -1)[:, points] = total
    return touched, value, error, summed


#: Bytes of surpluses ``_Surpluses`` keeps for the index that will ask for them (beyond, it
#: evaluates them again): 14 of the 4-D crystal map's full grids of 8 quantities (9.4 MB each).
KEPT_BYTES = 2**27


class _Surpluses(Mapping[Index, np.ndarray]):
    """The surpluses of a set's indices (``cores``: the values at each one's grid, of the
    quantities ``own`` of ``width``), each evaluated on the full grid (``surplus``) when first
    asked for: ``size(l)``, |Δ_l f|; as a mapping (what ``next_terms`` reads), max over the grid
    of |Δ_l f| per quantity (0 for the others; NaN points left out). Quantities first. A surplus evaluated for its maximum before
    ``size`` asks for it (an index of ``wanted``) is kept for that (up to ``KEPT_BYTES``)."""

    def __init__(
        self,
        matrices: Sequence[Sequence[np.ndarray]],
        cores: Mapping[Index, np.ndarray],
        width: int,
        own: Sequence[int],
        wanted: set[Index],
    ) -> None:
        self.matrices, self.cores, self.width, self.own, self.wanted = matrices, cores, width, list(own), wanted
        self.largest: dict[Index, np.ndarray] = {}
        self.kept: dict[Index, np.ndarray] = {}

    def _evaluated(self, index: Index) -> np.ndarray:
        size = surplus([self.matrices[d][level] for d, level in enumerate(index)], self.cores[index])
        np.abs(size, out=size)
        largest = np.zeros(self.width)
        largest[self.own] = np.fmax.reduce(size.reshape(len(self.own), -1), axis=1, initial=0.0)  # NaN: a failed node
        self.largest[index] = largest
        return size

    def size(self, index: Index) -> np.ndarray:
        """|Δ_l f| on the full grid (the quantities ``own`` first), yours to change."""
        return self.kept.pop(index) if index in self.kept else self._evaluated(index)

    def __getitem__(self, index: Index) -> np.ndarray:
        if index not in self.largest:
            size = self._evaluated(index)
            if index in self.wanted and size.nbytes + sum(k.nbytes for k in self.kept.values()) <= KEPT_BYTES:
                self.kept[index] = size
        return self.largest[index]

    def __iter__(self) -> Iterator[Index]:
        return iter(self.cores)

    def __len__(self) -> int:
        return len(self.cores)


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
    next one's where the surpluses are in their asymptotic regime."""
    out = np.zeros_like(largest[index])
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
            return np.ones_like(out)
        for k in steps:
            below = largest[tuple(i - (e == d) for e, i in enumerate(k))]
            with np.errstate(invalid="ignore", divide="ignore"):
                out = np.fmax(out, np.where(below > 0.0, np.fmin(largest[k] / below, 1.0), 1.0))
    return out


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
    tolerance (or no index fits ``max_solves``). Deterministic: every rank given the same values
    decides the same."""
    shape = tuple(len(x) for x in layout.xs)
    top = tops(shape)
    tol = np.array([settings.tolerance(n) for n in names])
    candidates = []  # (score, sub-problem, index)
    for s, (cat, sparse) in enumerate(state):
        est, parts, held = combined(layout, cat, sparse, names, fields, checks.factor(s), shares=True)
        with np.errstate(invalid="ignore"):
            error = est.map_error
            over = (np.nan_to_num(error, nan=0.0) > tol) & ~held  # a failed node's surroundings: no index helps
            points = over.any(axis=-1)
        if not points.any() or not parts:
            continue
        keys = sorted(parts)
        where = np.flatnonzero(points)
        stacked = np.stack([parts[k].reshape(-1, len(names))[where] for k in keys])  # (indices, points, quantities)
        budget = np.maximum(tol - est.solve[points], tol / 4.0)
        excess = np.where(over[points], error[points] / tol, 0.0)
        need = needed_axes(list(stacked), budget)
        for index, needed in zip(keys, need):
            score = float(np.where(needed, excess, 0.0).max())
            if score > 1.0:
                candidates.append((score, s, index))
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
