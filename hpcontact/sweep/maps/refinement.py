"""The nodes of an adaptive map, its error estimate and their refinement (the rounds:
``hpcontact.sweep.maps.rounds``; the check rounds: ``hpcontact.sweep.maps.checks``). What
follows is the leaves' method; with ``[adaptive] method`` "sparse" (or "auto" on 3 or more
interpolated axes, ``sparse_method``) each sub-problem's part of the state is a sparse grid's
set instead (``hpcontact.sweep.maps.sparse_grid``), and ``initial_state``, ``node_mask``,
``state_points``, ``estimate`` and ``refine`` hand it to that module.

Axes. The *numeric* task axes (``INTERPOLATED_AXES``: nu, aspect, anisotropy, orientation, …)
are interpolated, in log10 of the value for a ``{ logspace = … }`` axis (and those named in
``log``), in the value otherwise; no axis is treated as periodic (both ends of every axis are
always solved). Every other task axis (shape, material, pair, n, tol, accuracy) is
*categorical*: each combination of their values is its own sub-problem with its own nodes,
never interpolated across. A derived axis (``angle`` in tensor mode) stays derived.

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
is large and stays coarse elsewhere. The new nodes' points are the next round, broadcast to
every rank; the refinement ends when no interval is split, or at ``max_solves`` (the splits with
the largest estimates first, as many as fit), or when every point is solved. The state
(``State``: each sub-problem's leaves) is a function of the values at its nodes alone, so a
resumed sweep rebuilds it round by round from its journals.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from hpcontact.numerics.interpolation import Scale, TensorInterpolant, bisection_nodes, coordinate, refined
from hpcontact.sweep.data.dataset import TENSOR
from hpcontact.sweep.space.adaptive_settings import INTERPOLATED_AXES, Settings

#: Stiffnesses the estimate of an off-diagonal entry is relative to (as ``dataset.error_attributes``).
OFF_DIAGONAL = re.compile(r"^K_(xy|yx|xz|zx|yz|zy)(_coupled)?$")
#: Factor on the interpolation estimate (the next Newton term): measured on Mindlin's map
#: (tests/sweep/maps/test_adaptive.py), 1 under-estimates at ~7 % of the points, 1.5 at none. The
#: check rounds raise it per sub-problem where random solves show it short (``hpcontact.sweep.maps.checks``).
SAFETY = 1.5


#: Fewest nodes along an axis that cutting a leaf leaves in each half: one more than the cubic's
#: stencil, so each half's estimate (one order higher, ``interpolation.estimate_weights``) has
#: its own node to add and its middle interval a centred stencil.
LEAF_NODES = 5

#: Nodes a cut leaves each half beyond its face (of the other half's): the interval at the face
#: keeps a centred cubic stencil, as it had before the cut.
HALO = 1


class Leaf(NamedTuple):
    """A leaf of a sub-problem's k-d tree: ``nodes``, one increasing index list per numeric axis
    (their tensor product is solved), and ``box``, the first and last index per axis of the
    points it interpolates (its nodes may reach ``HALO`` nodes beyond a cut face)."""

    nodes: tuple[tuple[int, ...], ...]
    box: tuple[tuple[int, int], ...]


State = tuple[tuple[tuple[int, ...], tuple[Leaf, ...]], ...]  # (categorical index, the leaves tiling it)


@dataclass(frozen=True)
class Layout:
    """The task axes of a spec as an adaptive sweep sees them: ``shape`` (their lengths), the
    positions of the numeric and categorical ones, and the numeric ones' coordinates in their
    interpolation scale."""

    shape: tuple[int, ...]
    numeric: tuple[int, ...]
    categorical: tuple[int, ...]
    xs: tuple[np.ndarray, ...]
    scales: tuple[Scale, ...]

    @classmethod
    def of(cls, spec: Any) -> Layout:
        axes = spec.task_axes
        settings: Settings = spec.adaptive
        numeric = tuple(i for i, a in enumerate(axes) if a.name in INTERPOLATED_AXES)
        scales = tuple(Scale.LOG if axes[i].name in settings.log else Scale.LINEAR for i in numeric)
        xs = tuple(coordinate(axes[i].values, s) for i, s in zip(numeric, scales))
        categorical = tuple(i for i in range(len(axes)) if i not in numeric)
        return cls(tuple(len(a) for a in axes), numeric, categorical, xs, scales)

    def block(self, cat: Sequence[int], nodes: Sequence[Sequence[int]]) -> tuple:
        """``np.ix_`` index of the sub-problem ``cat`` at ``nodes``."""
        index: list[Any] = [None] * len(self.shape)
        for p, c in zip(self.categorical, cat):
            index[p] = [c]
        for j, p in enumerate(self.numeric):
            index[p] = list(nodes[j])
        return np.ix_(*index)

    def whole(self, cat: Sequence[int]) -> tuple:
        """The basic index (an integer per categorical axis, every point of the numeric ones) of
        the sub-problem ``cat``: a view, not a fancy-indexed copy of the grid."""
        index: list[Any] = [slice(None)] * len(self.shape)
        for p, c in zip(self.categorical, cat):
            index[p] = int(c)
        return tuple(index)

    def take(self, array: np.ndarray, cat: Sequence[int], nodes: Sequence[Sequence[int]] | None = None) -> np.ndarray:
        """The values of ``array`` (over the task axes, any trailing dimensions) of the
        sub-problem ``cat`` at ``nodes`` (None: every point), numeric axes first in order; a copy."""
        if nodes is None:
            return array[self.whole(cat)].copy()
        return np.squeeze(array[self.block(cat, nodes)], axis=self.categorical)

    def put(self, array: np.ndarray, cat: Sequence[int], values: np.ndarray) -> None:
        """Set every point of the sub-problem ``cat`` of ``array`` to ``values`` (``take``'s layout)."""
        array[self.whole(cat)] = values


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
    from hpcontact.sweep.maps.sparse_grid import SparseSet

    return isinstance(leaves, SparseSet)


def initial_state(layout: Layout, settings: Settings) -> State:
    """The first round's nodes: in every sub-problem one leaf, the first bisection level with
    ``settings.initial`` nodes along each numeric axis; for a sparse grid (``sparse_method``)
    its first set (``sparse_grid.initial_set``)."""
    cats = [tuple(int(c) for c in cat) for cat in np.ndindex(*(layout.shape[p] for p in layout.categorical))]
    if sparse_method(layout, settings):
        from hpcontact.sweep.maps.sparse_grid import initial_set

        first = initial_set(tuple(len(x) for x in layout.xs), settings.initial)
        return tuple((cat, first) for cat in cats)
    nodes = tuple(tuple(bisection_nodes(layout.shape[p], settings.initial)) for p in layout.numeric)
    leaf = Leaf(nodes, tuple((n[0], n[-1]) for n in nodes))
    return tuple((cat, (leaf,)) for cat in cats)


def box(leaf: Leaf) -> tuple[slice, ...]:
    """The index box of ``leaf`` in its sub-problem's grid (numeric axes in order)."""
    return tuple(slice(lo, hi + 1) for lo, hi in leaf.box)


def node_mask(layout: Layout, leaves: Sequence[Leaf]) -> np.ndarray:
    """Whether each point of a sub-problem's grid (numeric axes) is a node of one of ``leaves``
    (or of a sparse grid's set)."""
    if is_sparse(leaves):
        from hpcontact.sweep.maps.sparse_grid import set_nodes

        return set_nodes(tuple(len(x) for x in layout.xs), leaves.indices)
    mask = np.zeros(tuple(len(x) for x in layout.xs), dtype=bool)
    for leaf in leaves:
        mask[np.ix_(*leaf.nodes)] = True
    return mask


@dataclass(frozen=True)
class Checks:
    """The check rounds so far (``hpcontact.sweep.maps.checks``): the flat indices of the random points
    solved (sorted), the factor on the interpolation estimate of each sub-problem (in the
    state's order; empty: ``SAFETY`` for every one), the check rounds judged, whether the last
    one raised a factor, whether points are drawn but not yet judged, and which sub-problems
    estimate conservatively (empty: none)."""

    points: tuple[int, ...] = ()
    safety: tuple[float, ...] = ()
    rounds: int = 0
    raised: bool = False
    pending: bool = False
    conservative: tuple[bool, ...] = ()

    def factor(self, s: int) -> float:
        """The factor on the interpolation estimate of the sub-problem ``s``."""
        return self.safety[s] if self.safety else SAFETY

    def factors(self, count: int) -> tuple[float, ...]:
        """The factors of all ``count`` sub-problems."""
        return self.safety or tuple(SAFETY for _ in range(count))

    @property
    def largest_factor(self) -> float:
        """The largest factor of any sub-problem (``SAFETY`` before a check round)."""
        return max(self.safety, default=SAFETY)

    def cautious(self, s: int) -> bool:
        """Whether the sub-problem ``s`` estimates conservatively (``TensorInterpolant.estimates``)."""
        return self.conservative[s] if self.conservative else False


def state_points(layout: Layout, state: State, checks: Checks | None = None) -> np.ndarray:
    """The flat (C order over the task axes) indices of every node point of ``state`` and
    every check point of ``checks``, sorted."""
    flat = np.arange(math.prod(layout.shape)).reshape(layout.shape)
    parts = [layout.take(flat, cat)[node_mask(layout, leaves)] for cat, leaves in state]
    if checks is not None and checks.points:
        parts.append(np.asarray(checks.points, dtype=np.intp))
    return np.unique(np.concatenate(parts)) if parts else np.empty(0, dtype=np.intp)


def state_tasks(layout: Layout, state: State, task_of: np.ndarray, checks: Checks | None = None) -> np.ndarray:
    """The distinct tasks (positions) of the node points of ``state`` and the check points."""
    return np.unique(np.asarray(task_of).ravel()[state_points(layout, state, checks)])


@dataclass
class Estimate:
    """A sub-problem's interpolated quantities on its full grid (numeric axes first, then the
    quantities), the relative error estimate of each axis, the interpolated solve error, the
    size the errors are relative to and, at each point, the position of the leaf they come from."""

    values: np.ndarray
    axes: list[np.ndarray]
    solve: np.ndarray
    scale: np.ndarray
    owner: np.ndarray

    @property
    def interpolation(self) -> np.ndarray:
        """Σ_d e_d: the interpolation part of the map error."""
        return sum(self.axes, np.zeros_like(self.solve))

    @property
    def map_error(self) -> np.ndarray:
        """Σ_d e_d + s at every point (NaN where a node value is)."""
        return sum(self.axes, np.zeros_like(self.solve)) + self.solve


def _relative_scale(names: Sequence[str], values: np.ndarray) -> np.ndarray:
    """The size each quantity's error is relative to: |q|, the largest diagonal entry for an
    off-diagonal one; where that is 0, the largest |q| of the sub-problem (1 if all are 0)."""
    scale = np.abs(values)
    for q, name in enumerate(names):
        match = OFF_DIAGONAL.match(name)
        if match:
            suffix = match.group(2) or ""
            diagonal = [names.index(f"K_{a}{a}{suffix}") for a in "xyz" if f"K_{a}{a}{suffix}" in names]
            if diagonal:
                scale[..., q] = np.max(np.abs(values[..., diagonal]), axis=-1)
    for q in range(len(names)):
        column = scale[..., q]
        fallback = np.nanmax(column) if np.any(np.isfinite(column)) else 1.0
        column[~(column > 0.0)] = fallback if fallback > 0.0 else 1.0
    return scale


#: Principal stiffnesses: not smooth where K_max = K_min (a kink |A − 1| at the isotropic body, one
#: at the {111} orientation), so an adaptive map derives them from the interpolated tensor
#: (``principal_from_tensor``), which is smooth there, instead of interpolating them.
PRINCIPAL = ("K_max", "K_min", "K_min_over_K_max")


def principal_from_tensor(values: np.ndarray, axes: list[np.ndarray], names: Sequence[str]) -> None:
    """Replace in place, along the last axis of ``values`` (quantities ``names``) and of each
    axis' relative estimate in ``axes``, the principal stiffnesses (``PRINCIPAL``) by those of
    the tensor's symmetric part, (a + d)/2 ± √(((a − d)/2)² + c²) with c = (K_xy + K_yx)/2
    (``quantities.principal_stiffness``), and their estimates from the entries' absolute
    estimates e (entrywise, of the symmetric part; e_c = ½(e_xy + e_yx)): the smaller of Weyl's
    bound W = ½(e_xx + e_yy) + hypot(½(e_xx − e_yy), e_c) (``accuracy.principal_error``; Horn &
    Johnson Thm 4.3.1) and the expansion of K_max,min = m ± r, m = ½(a + d), r = |p|, p = (h, c)
    = r (cos φ, sin φ), h = ½(a − d): |p + δp| ≤ r + p̂·δp + |δp⊥|²/(2r) (√(1 + x) ≤ 1 + x/2),
    so |δK_max,min| ≤ ½e_xx(1 ± cos φ) + ½e_yy(1 ∓ cos φ) + |sin φ| e_c + (|sin φ| ½(e_xx + e_yy)
    + |cos φ| e_c)²/gap, gap = 2r = K_max − K_min; each relative to itself, the ratio's the sum
    of the two. Well apart (a diagonal tensor: K_xx's own estimate for its eigenvalue) the
    expansion is the sharper, near a crossing Weyl's. Needs the four
    entries and their estimates relative to ``_relative_scale`` (the diagonal entries to
    themselves, the off-diagonal ones to the largest diagonal entry)."""
    index = {n: i for i, n in enumerate(names)}
    a, b, c, d = (values[..., index[n]] for n in TENSOR)
    mean, half = 0.5 * (a + d), np.hypot(0.5 * (a - d), 0.5 * (b + c))
    derived = {"K_max": mean + half, "K_min": mean - half}
    derived["K_min_over_K_max"] = derived["K_min"] / derived["K_max"]
    scale = _relative_scale(names, values)
    for name, value in derived.items():
        if name in index:
            values[..., index[name]] = value
    phi = np.arctan2(0.5 * (b + c), 0.5 * (a - d))  # (h, c) = r (cos φ, sin φ): twice K_max's direction
    cos, sin = np.cos(phi), np.abs(np.sin(phi))
    gap = 2.0 * half
    for e in axes:
        ea, eb, ec, ed = (np.abs(e[..., index[n]] * scale[..., index[n]]) for n in TENSOR)
        off = 0.5 * (eb + ec)
        weyl = 0.5 * (ea + ed) + np.hypot(0.5 * (ea - ed), off)
        with np.errstate(divide="ignore", invalid="ignore"):
            second = np.where(gap > 0.0, (sin * 0.5 * (ea + ed) + np.abs(cos) * off) ** 2 / gap, np.inf)
        first = {
            "K_max": 0.5 * ea * (1.0 + cos) + 0.5 * ed * (1.0 - cos) + sin * off,
            "K_min": 0.5 * ea * (1.0 - cos) + 0.5 * ed * (1.0 + cos) + sin * off,
        }
        relative = {n: np.fmin(weyl, first[n] + second) / np.abs(derived[n]) for n in ("K_max", "K_min")}
        relative["K_min_over_K_max"] = relative["K_max"] + relative["K_min"]
        for name, value in relative.items():
            if name in index:
                e[..., index[name]] = value


#: Relative size below which the tensor's off-diagonal part and the diagonal's difference count
#: as zero (``_crosses``): far above the solves' round-off, far below any tolerance.
CROSSING_NOISE = 1e-8


def _crosses(data: np.ndarray, errors: np.ndarray, names: Sequence[str]) -> bool:
    """Whether the principal stiffnesses of a sub-problem may cross (K_max = K_min, a kink of
    each): its tensor at the nodes (``data``, quantities ``names`` last; ``errors`` the solves'
    relative errors, laid out alike) has an off-diagonal part, or K_xx − K_yy of both signs,
    above the solves' errors (at least ``CROSSING_NOISE``) relative to the diagonal. Otherwise
    they are its diagonal entries, as smooth as those, and interpolated directly (a ratio's
    errors then partly cancel, which the tensor's bound cannot see)."""
    index = {n: i for i, n in enumerate(names)}
    a, b, c, d = (data[..., index[n]] for n in TENSOR)
    noise = np.fmax(CROSSING_NOISE, sum(errors[..., index[n]] for n in TENSOR))
    size = np.fmax(np.abs(a), np.abs(d))
    with np.errstate(invalid="ignore", divide="ignore"):
        off = np.abs(0.5 * (b + c)) / size - noise
        difference = (a - d) / size
    return bool(np.nanmax(off, initial=-1.0) > 0.0) or bool(np.any(difference > noise) and np.any(difference < -noise))


def solve_errors(
    layout: Layout,
    fields: Mapping[str, np.ndarray],
    names: Sequence[str],
    cat: Sequence[int],
    nodes: Sequence[Sequence[int]] | None = None,
) -> np.ndarray:
    """The solves' own relative errors ``<name>_error`` of ``names`` in the sub-problem ``cat``
    at ``nodes`` (None: every point), quantities last; 0 where a quantity has none or a point
    NaN."""
    shape = layout.take(fields[names[0]], cat, nodes).shape
    return np.stack(
        [
            np.abs(np.nan_to_num(layout.take(fields[f"{n}_error"], cat, nodes), nan=0.0))
            if f"{n}_error" in fields
            else np.zeros(shape)
            for n in names
        ],
        axis=-1,
    )


def worked_quantities(
    layout: Layout, cat: Sequence[int], mask: np.ndarray, names: Sequence[str], fields: Mapping[str, np.ndarray]
) -> tuple[list[str], bool]:
    """The quantities an estimate interpolates: ``names``, then the tensor entries the principal
    stiffnesses derive from where ``fields`` has them and they may cross at the nodes ``mask``
    of the sub-problem ``cat`` (``_crosses``), and whether they derive."""
    derive = any(n in PRINCIPAL for n in names) and all(t in fields for t in TENSOR)
    work = list(names) + [t for t in TENSOR if derive and t not in names]
    if derive:
        data = np.stack([layout.take(fields[n], cat)[mask] for n in work], axis=-1)
        derive = _crosses(data, solve_errors(layout, fields, work, cat)[mask], work)
    return work, derive


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
    whole = interpolant.values(job.data)
    full = whole[job.inner]
    relative = _relative_scale(work, full)
    leaf_axes = [job.safety * e[job.inner] / relative for e in interpolant.estimates(job.data, whole, job.conservative)]
    if job.derive:
        principal_from_tensor(full, leaf_axes, work)
        relative = _relative_scale(work, full)
    leaf_solve = np.abs(interpolant.values(job.solve_data))[job.inner]
    error = (sum(leaf_axes, np.zeros_like(leaf_solve)) + leaf_solve)[..., kept]
    worst = np.where(np.isnan(error), np.inf, error).max(axis=-1)
    return LeafPart(
        full[..., kept], [a[..., kept] for a in leaf_axes], leaf_solve[..., kept], relative[..., kept], worst
    )


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


#: Estimates computed inside ``remembered_estimates`` (None outside): (sub-problem, leaves,
#: quantities, factor, kind) → (the leaves' jobs, the estimate).
_REMEMBERED: ContextVar[dict[tuple, tuple[list[LeafJob], Estimate]] | None] = ContextVar("remembered", default=None)


@contextmanager
def remembered_estimates() -> Iterator[None]:
    """Inside, an ``estimate`` asked again of the same sub-problem, leaves, quantities, factor
    and kind, whose leaves' values at the nodes (and the solves' errors) are bitwise those of
    the first, is the first's (the same object: callers only read it). After the last check
    round the judgement (``checks.judged``) and the fill (``fill.fill``) estimate the same
    quantities with the same factor unless the check raised it: one estimate, not two."""
    token = _REMEMBERED.set({})
    try:
        yield
    finally:
        _REMEMBERED.reset(token)


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
    ``principal_from_tensor``). A sparse grid's set instead of leaves: ``sparse_grid.estimate``
    (``conservative`` has no meaning there)."""
    if is_sparse(leaves):
        from hpcontact.sweep.maps import sparse_grid

        return sparse_grid.estimate(layout, cat, leaves, names, fields, safety)
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
    remembered = _REMEMBERED.get()
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
    state: State,
    fields: Mapping[str, np.ndarray],
    names: Sequence[str],
    task_of: np.ndarray,
    checks: Checks | None = None,
) -> State | None:
    """The next round's state from the values at ``state``'s nodes (module docstring), or None
    when no interval needs a split (or none fits ``max_solves``, which counts the check points
    too). Deterministic: every rank given the same values decides the same."""
    checks = checks if checks is not None else Checks()
    if not names:
        return None
    if state and is_sparse(state[0][1]):
        from hpcontact.sweep.maps import sparse_grid

        return sparse_grid.refine(layout, settings, state, fields, names, task_of, checks)
    tol = np.array([settings.tolerance(n) for n in names])
    candidates = []  # (score, sub-problem position, leaf position, axis, interval)
    for s, (cat, leaves) in enumerate(state):
        est = estimate(layout, cat, leaves, names, fields, checks.factor(s), checks.cautious(s))
        with np.errstate(invalid="ignore"):
            over = est.map_error > tol
            budget = np.maximum(tol - est.solve, tol / 4.0)
            excess = np.nan_to_num(np.where(over, est.map_error / tol, 0.0), nan=0.0)
            ratios = [np.where(n, excess, 0.0).max(axis=-1) for n in needed_axes(est.axes, budget)]
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
                    worst = float(np.take(ratio, range(i + 1 - lo, j - lo), axis=d).max())
                    if worst > 1.0:
                        candidates.append((worst, s, position, d, m))
    if not candidates:
        return None
    flat = np.arange(math.prod(layout.shape)).reshape(layout.shape)
    task_of = np.asarray(task_of).ravel()
    taken = set(state_tasks(layout, state, task_of, checks).tolist())
    marks: dict[tuple[int, int], dict[int, set[int]]] = {}  # (sub-problem, leaf) -> axis -> intervals
    for _, s, position, d, m in sorted(candidates, key=lambda c: (-c[0], *c[1:])):
        trial = {a: set(ms) for a, ms in marks.get((s, position), {}).items()}
        trial.setdefault(d, set()).add(m)
        cat, leaves = state[s]
        added = set(task_of[layout.take(flat, cat, _split(leaves[position], trial).nodes).ravel()].tolist()) - taken
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
            grown.extend(_cut(_split(leaf, marks.get((s, position), {}))))
        out.append((cat, tuple(grown)))
    return tuple(out)


def needed_axes(axes: Sequence[np.ndarray], budget: np.ndarray) -> list[np.ndarray]:
    """Per axis, whether a point (and quantity) over its tolerance has it split: with its axes'
    estimates in decreasing order e_(0) ≥ e_(1) ≥ …, the axis of e_(0), and that of e_(k) where
    e_(k) + e_(k+1) + … alone exceeds ``budget`` (the tolerance less the solve's error): what the
    larger axes' splits cannot bring within the budget however well they work. (Splitting every
    axis whose estimate exceeded ``budget / D``, as before, split both axes of points whose error
    one of them held: 91 nodes instead of 71 on the smooth 2-D map of
    benchmarks/local_refinement.py. Preferring, of the axes whose split alone would do, the one
    that adds the fewest nodes to the point's leaf was measured there too: 85, a cheap split at
    each point but more of them.)"""
    errors = np.stack([np.nan_to_num(e, nan=0.0) for e in axes])
    order = np.argsort(-errors, axis=0, kind="stable")
    ranked = np.take_along_axis(errors, order, axis=0)
    tails = np.cumsum(ranked[::-1], axis=0)[::-1]  # e_(k) + e_(k+1) + …
    need = tails > budget
    need[0] = True
    out = np.empty_like(need)
    np.put_along_axis(out, order, need, axis=0)
    return list(out)


def _between_nodes(leaf: Leaf, axis: int) -> np.ndarray:
    """Whether each point of ``leaf``'s box lies strictly between two nodes along ``axis``
    (broadcast over the box's other axes)."""
    lo, hi = leaf.box[axis]
    between = ~np.isin(np.arange(lo, hi + 1), leaf.nodes[axis])
    shape = [1] * len(leaf.box)
    shape[axis] = len(between)
    return between.reshape(shape)


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
