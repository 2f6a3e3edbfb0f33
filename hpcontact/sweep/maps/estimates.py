"""What both methods of an adaptive map share (the leaves of a k-d tree: ``maps.refinement``; a
sparse grid: ``maps.sparse_grid``; which one a map uses: ``maps.state``): the task axes as the map
sees them (``Layout``), the check rounds' record (``Checks``), a sub-problem's ``Estimate`` and
the size its errors are relative to (``relative_scale``), the principal stiffnesses derived from
the interpolated tensor (``principal_from_tensor``), the solves' own errors, the axes (or
indices) a point over its tolerance needs split (``needed_axes``), the points of a map's nodes
(``node_points``) and the estimates remembered within one decision (``remembered_estimates``).

Axes. The *numeric* task axes (``INTERPOLATED_AXES``: nu, aspect, anisotropy, orientation, …)
are interpolated, in log10 of the value for a ``{ logspace = … }`` axis (and those named in
``log``), in the value otherwise; no axis is treated as periodic (both ends of every axis are
always solved). Every other task axis (shape, material, pair, n, tol, accuracy) is
*categorical*: each combination of their values is its own sub-problem with its own nodes,
never interpolated across. A derived axis (``angle`` in tensor mode) stays derived.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

import numpy as np

from hpcontact.numerics.interpolation import Scale, coordinate
from hpcontact.sweep.data.dataset import TENSOR
from hpcontact.sweep.space.adaptive_settings import INTERPOLATED_AXES, Settings

#: Stiffnesses the estimate of an off-diagonal entry is relative to (as ``dataset.error_attributes``).
OFF_DIAGONAL = re.compile(r"^K_(xy|yx|xz|zx|yz|zy)(_coupled)?$")
#: Factor on the interpolation estimate (the next Newton term): measured on Mindlin's map
#: (tests/sweep/maps/test_adaptive.py), 1 under-estimates at ~7 % of the points, 1.5 at none. The
#: check rounds raise it per sub-problem where random solves show it short (``hpcontact.sweep.maps.checks``).
SAFETY = 1.5


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


def node_points(
    layout: Layout, masks: Sequence[tuple[Sequence[int], np.ndarray]], checks: Checks | None = None
) -> np.ndarray:
    """The flat (C order over the task axes) indices of every node point of a map, each
    sub-problem ``cat`` with its ``mask`` of nodes over its grid (numeric axes; ``masks``: (cat,
    mask) pairs), and every check point of ``checks``, sorted."""
    flat = np.arange(math.prod(layout.shape)).reshape(layout.shape)
    parts = [layout.take(flat, cat)[mask] for cat, mask in masks]
    if checks is not None and checks.points:
        parts.append(np.asarray(checks.points, dtype=np.intp))
    return np.unique(np.concatenate(parts)) if parts else np.empty(0, dtype=np.intp)


def node_tasks(
    layout: Layout,
    masks: Sequence[tuple[Sequence[int], np.ndarray]],
    task_of: np.ndarray,
    checks: Checks | None = None,
) -> np.ndarray:
    """The distinct tasks (positions) of the node points (``node_points``) and the check points."""
    return np.unique(np.asarray(task_of).ravel()[node_points(layout, masks, checks)])


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


def _sizes(names: Sequence[str], values: np.ndarray) -> np.ndarray:
    """|q|, the largest diagonal |entry| for an off-diagonal one (``relative_scale``)."""
    scale = np.abs(values)
    for q, name in enumerate(names):
        match = OFF_DIAGONAL.match(name)
        if match:
            suffix = match.group(2) or ""
            diagonal = [names.index(f"K_{a}{a}{suffix}") for a in "xyz" if f"K_{a}{a}{suffix}" in names]
            if diagonal:
                scale[..., q] = np.max(np.abs(values[..., diagonal]), axis=-1)
    return scale


def scale_extent(names: Sequence[str], values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per quantity, what ``relative_scale`` falls back on over the points of ``values``: the
    largest size (NaN where every one is NaN) and whether one is finite. Of a part of a grid,
    combined with the other parts' exactly whatever the order (``np.fmax``, or): the slabs of
    ``maps.sparse_grid``."""
    sizes = _sizes(names, values).reshape(-1, len(names))
    return np.fmax.reduce(sizes, axis=0), np.isfinite(sizes).any(axis=0)


def relative_scale(
    names: Sequence[str], values: np.ndarray, extent: tuple[np.ndarray, np.ndarray] | None = None
) -> np.ndarray:
    """The size each quantity's error is relative to: |q|, the largest diagonal entry for an
    off-diagonal one; where that is 0, the largest |q| of the sub-problem (1 if all are 0):
    of ``values``, or ``extent`` (``scale_extent`` of the whole sub-problem, where ``values``
    are a part of it)."""
    scale = _sizes(names, values)
    largest, finite = scale_extent(names, values) if extent is None else extent
    for q in range(len(names)):
        fallback = largest[q] if finite[q] else 1.0
        scale[..., q][~(scale[..., q] > 0.0)] = fallback if fallback > 0.0 else 1.0
    return scale


#: Principal stiffnesses: not smooth where K_max = K_min (a kink |A − 1| at the isotropic body, one
#: at the {111} orientation), so an adaptive map derives them from the interpolated tensor
#: (``principal_from_tensor``), which is smooth there, instead of interpolating them.
PRINCIPAL = ("K_max", "K_min", "K_min_over_K_max")


def principal_from_tensor(
    values: np.ndarray,
    axes: list[np.ndarray],
    names: Sequence[str],
    extent: tuple[np.ndarray, np.ndarray] | None = None,
) -> None:
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
    entries and their estimates relative to ``relative_scale`` (the diagonal entries to
    themselves, the off-diagonal ones to the largest diagonal entry; ``extent`` as there)."""
    index = {n: i for i, n in enumerate(names)}
    a, b, c, d = (values[..., index[n]] for n in TENSOR)
    mean, half = 0.5 * (a + d), np.hypot(0.5 * (a - d), 0.5 * (b + c))
    derived = {"K_max": mean + half, "K_min": mean - half}
    derived["K_min_over_K_max"] = derived["K_min"] / derived["K_max"]
    scale = relative_scale(names, values, extent) if axes else None
    for name, value in derived.items():
        if name in index:
            values[..., index[name]] = value
    if scale is None:
        return
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


def needed_axes(
    axes: Sequence[np.ndarray], budget: np.ndarray, costs: Sequence[np.ndarray] | None = None
) -> list[np.ndarray]:
    """Per axis, whether a point (and quantity) over its tolerance has it split: with its axes'
    estimates in decreasing order e_(0) ≥ e_(1) ≥ …, the axis of e_(0), and that of e_(k) where
    e_(k) + e_(k+1) + … alone exceeds ``budget`` (the tolerance less the solve's error): what the
    larger axes' splits cannot bring within the budget however well they work. With ``costs``
    (per axis, the nodes a split along it adds to the point's leaf, broadcast to the estimates),
    where the split of one axis alone would do (the other axes' estimates add up to at most
    ``budget``), the cheapest such axis instead, of equal costs the one with the largest
    estimate (on a cube of nodes the costs tie; the first axis took the crystal 3-D map of
    benchmarks/local_refinement.py to 1 770 solves, the largest estimate to 1 320). (Splitting every axis whose estimate exceeded
    ``budget / D``, as before, split both axes of points whose error one of them held: 91 nodes
    instead of 71 on the smooth 2-D map of benchmarks/local_refinement.py. The cheapest axis was
    measured there with the cubic alone: 85, a cheap split at each point but more of them; with
    the quintic where it converges (``interpolation.chosen_stencils``) a split removes nearly all
    of its axis' error, and the cheapest axis takes 55 nodes where the largest took 70 (before
    the end rule ``interpolation.FALLING``).)"""
    errors = np.stack([np.nan_to_num(e, nan=0.0) for e in axes], axis=-1)  # axes last: a point's contiguous
    ranked = -np.sort(-errors, axis=-1)  # e_(0) ≥ e_(1) ≥ …
    tails = np.cumsum(ranked[..., ::-1], axis=-1)[..., ::-1]  # e_(k) + e_(k+1) + …
    last = np.maximum(np.count_nonzero(tails > np.asarray(budget)[..., None], axis=-1) - 1, 0)  # tails decrease
    threshold = np.take_along_axis(ranked, last[..., None], axis=-1)  # e_(last): the axes ranked up to it
    above = errors > threshold
    tied = errors == threshold  # ranked in their order (a stable sort): the first (last + 1 − #above) of them
    room = last[..., None] + 1 - np.count_nonzero(above, axis=-1, keepdims=True)
    need = above | (tied & (np.cumsum(tied, axis=-1) <= room))
    if costs is not None:
        cost = np.stack([np.broadcast_to(c, errors.shape[:-1]) for c in costs], axis=-1).astype(np.float64)
        alone = errors.sum(axis=-1, keepdims=True) - errors <= np.asarray(budget)[..., None]
        priced = np.where(alone & (errors > 0.0), cost, np.inf)
        cheapest = np.lexsort((-errors, priced), axis=-1)[..., 0]  # equal costs: the largest estimate's
        some = np.isfinite(np.min(priced, axis=-1))
        pick = np.arange(errors.shape[-1]) == cheapest[..., None]
        need = np.where(some[..., None], pick, need)
    return list(np.moveaxis(need, -1, 0))


#: Estimates computed inside ``remembered_estimates`` (None outside): (sub-problem, leaves or sparse
#: set, quantities, factor, kind) → (the inputs it was computed from: the leaves' jobs, the sparse
#: set's values at its nodes; the estimate).
REMEMBERED: ContextVar[dict[tuple, tuple[Any, Any]] | None] = ContextVar("remembered", default=None)


@contextmanager
def remembered_estimates() -> Iterator[None]:
    """Inside, an ``estimate`` asked again of the same sub-problem, leaves, quantities, factor
    and kind, whose leaves' values at the nodes (and the solves' errors) are bitwise those of
    the first, is the first's (the same object: callers only read it). After the last check
    round the judgement (``checks.judged``) and the fill (``fill.fill``) estimate the same
    quantities with the same factor unless the check raised it: one estimate, not two."""
    token = REMEMBERED.set({})
    try:
        yield
    finally:
        REMEMBERED.reset(token)
