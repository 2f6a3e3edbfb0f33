"""The nodes of an adaptive map, its error estimate and their refinement (the rounds:
``hpcontact.sweep.maps.rounds``; the check rounds: ``hpcontact.sweep.maps.checks``).

Axes. The *numeric* task axes (``INTERPOLATED_AXES``: nu, aspect, anisotropy, orientation, …)
are interpolated, in log10 of the value for a ``{ logspace = … }`` axis (and those named in
``log``), in the value otherwise; no axis is treated as periodic (both ends of every axis are
always solved). Every other task axis (shape, material, pair, n, tol, accuracy) is
*categorical*: each combination of their values is its own sub-problem with its own nodes,
never interpolated across. A derived axis (``angle`` in tensor mode) stays derived.

Nodes. In each sub-problem the solved points are the tensor product of one increasing index
list per numeric axis (``interpolation.TensorInterpolant``: local cubic Lagrange along each
axis, an error estimate per axis). The first round takes the first nested-bisection level with
``initial`` nodes along each axis (every 2^k-th index, ends included:
``interpolation.bisection_nodes``). After each round, rank 0 estimates the relative error at
every grid point from the solved points: ``map error = Σ_d e_d + s``, ``e_d`` the estimate of
axis ``d`` relative to the quantity's own size (``|q|``; the off-diagonal K_xy, K_yx, … relative
to the largest diagonal entry, as their ``<name>_error``), ``s`` the solve's own estimated
relative error ``<name>_error`` interpolated from the nodes (0 where a solve has none). Where the
map error of a quantity exceeds its tolerance ``t``, each axis ``d`` whose share
``e_d > max(t − s, t/4) / D`` (``D`` numeric axes) has the node interval around the point split
at its midpoint. The new nodes' points are the next round, broadcast to every rank; the
refinement ends when no interval is split, or at ``max_solves`` (the splits with the largest
estimates first, as many as fit), or when every point is solved.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

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


State = tuple[tuple[tuple[int, ...], tuple[tuple[int, ...], ...]], ...]  # (categorical index, nodes per axis)


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

    def block(self, cat: Sequence[int], nodes: Sequence[Sequence[int]] | None = None) -> tuple:
        """``np.ix_`` index of the sub-problem ``cat`` at ``nodes`` (None: every point of it)."""
        index: list[Any] = [None] * len(self.shape)
        for p, c in zip(self.categorical, cat):
            index[p] = [c]
        for j, p in enumerate(self.numeric):
            index[p] = list(range(self.shape[p])) if nodes is None else list(nodes[j])
        return np.ix_(*index)

    def take(self, array: np.ndarray, cat: Sequence[int], nodes: Sequence[Sequence[int]] | None = None) -> np.ndarray:
        """The values of ``array`` (over the task axes, any trailing dimensions) of the
        sub-problem ``cat`` at ``nodes``, numeric axes first in order."""
        return np.squeeze(array[self.block(cat, nodes)], axis=self.categorical)

    def put(self, array: np.ndarray, cat: Sequence[int], values: np.ndarray) -> None:
        """Set every point of the sub-problem ``cat`` of ``array`` to ``values`` (``take``'s layout)."""
        array[self.block(cat)] = np.expand_dims(values, self.categorical)


def initial_state(layout: Layout, settings: Settings) -> State:
    """The first round's nodes: in every sub-problem, the first bisection level with
    ``settings.initial`` nodes along each numeric axis."""
    nodes = tuple(tuple(bisection_nodes(layout.shape[p], settings.initial)) for p in layout.numeric)
    cats = np.ndindex(*(layout.shape[p] for p in layout.categorical))
    return tuple((tuple(int(c) for c in cat), nodes) for cat in cats)


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
    parts = [layout.take(flat, cat, nodes).ravel() for cat, nodes in state]
    if checks is not None and checks.points:
        parts.append(np.asarray(checks.points, dtype=np.intp))
    return np.unique(np.concatenate(parts)) if parts else np.empty(0, dtype=np.intp)


def state_tasks(layout: Layout, state: State, task_of: np.ndarray, checks: Checks | None = None) -> np.ndarray:
    """The distinct tasks (positions) of the node points of ``state`` and the check points."""
    return np.unique(np.asarray(task_of).ravel()[state_points(layout, state, checks)])


@dataclass
class Estimate:
    """A sub-problem's interpolated quantities on its full grid (numeric axes first, then the
    quantities), the relative error estimate of each axis and the interpolated solve error."""

    values: np.ndarray
    axes: list[np.ndarray]
    solve: np.ndarray
    scale: np.ndarray

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


def estimate(
    layout: Layout,
    cat: Sequence[int],
    nodes: Sequence[Sequence[int]],
    names: Sequence[str],
    fields: Mapping[str, np.ndarray],
    safety: float = SAFETY,
    conservative: bool = False,
) -> Estimate:
    """The ``Estimate`` of the sub-problem ``cat`` from the values at ``nodes`` of the
    quantities ``names`` (``fields``: name → array over the task axes; ``<name>_error``, when
    there, the solve's relative error); ``safety`` the factor on the interpolation estimate,
    ``conservative`` its kind (``TensorInterpolant.estimates``). The principal stiffnesses
    come from the interpolated tensor where ``fields`` has it and they may cross
    (``_crosses``, ``principal_from_tensor``)."""
    derive = any(n in PRINCIPAL for n in names) and all(t in fields for t in TENSOR)
    work = list(names) + [t for t in TENSOR if derive and t not in names]
    interpolant = TensorInterpolant([layout.xs[j] for j in range(len(layout.numeric))], nodes)
    data = np.stack([layout.take(fields[n], cat, nodes) for n in work], axis=-1)
    full = interpolant.values(data)
    scale = _relative_scale(work, full)
    estimates = interpolant.estimates(data, full, conservative)
    axes = [safety * e / scale for e in estimates]
    errors = solve_errors(layout, fields, work, cat, nodes)
    if derive and _crosses(data, errors, work):
        principal_from_tensor(full, axes, work)
        scale = _relative_scale(work, full)
    kept = slice(0, len(names))
    return Estimate(
        full[..., kept], [e[..., kept] for e in axes], np.abs(interpolant.values(errors))[..., kept], scale[..., kept]
    )


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
    tol = np.array([settings.tolerance(n) for n in names])
    dims = max(sum(1 for x in layout.xs if len(x) > 1), 1)
    candidates = []  # (score, sub-problem position, axis, interval)
    for s, (cat, nodes) in enumerate(state):
        est = estimate(layout, cat, nodes, names, fields, checks.factor(s), checks.cautious(s))
        with np.errstate(invalid="ignore"):
            over = est.map_error > tol
            share = np.maximum(tol - est.solve, tol / 4.0) / dims
            for d, e in enumerate(est.axes):
                ratio = np.where(over, e / share, 0.0)
                ratio = np.nan_to_num(ratio, nan=0.0).max(axis=-1)  # the worst quantity
                for m, (i, j) in enumerate(zip(nodes[d][:-1], nodes[d][1:])):
                    if j - i < 2:
                        continue
                    inside = np.take(ratio, range(i + 1, j), axis=d)
                    worst = float(inside.max())
                    if worst > 1.0:
                        candidates.append((worst, s, d, m))
    if not candidates:
        return None

    def split(chosen: Sequence[tuple[float, int, int, int]]) -> State:
        marks: dict[tuple[int, int], set[int]] = {}
        for _, s, d, m in chosen:
            marks.setdefault((s, d), set()).add(m)
        out = []
        for s, (cat, nodes) in enumerate(state):
            new = tuple(
                tuple(refined(n, [m in marks.get((s, d), ()) for m in range(len(n) - 1)])) if (s, d) in marks else n
                for d, n in enumerate(nodes)
            )
            out.append((cat, new))
        return tuple(out)

    proposed = split(candidates)
    if settings.max_solves is None or len(state_tasks(layout, proposed, task_of, checks)) <= settings.max_solves:
        return proposed
    chosen: list[tuple[float, int, int, int]] = []
    for candidate in sorted(candidates, key=lambda c: (-c[0], c[1], c[2], c[3])):
        trial = split([*chosen, candidate])
        if len(state_tasks(layout, trial, task_of, checks)) <= settings.max_solves:
            chosen.append(candidate)
    return split(chosen) if chosen else None
