"""Adaptive maps: solve the grid points a map needs, interpolate the rest (``[adaptive]``).

A spec with an ``[adaptive]`` table keeps its ``[axes]`` as the output grid, but the sweep
solves a subset of it, chosen in rounds::

    [adaptive]
    tolerance = 1e-3          # relative map error allowed (or a table: {K_a_over_K_b = 1e-3, ...})
    max_solves = 200          # optional: solves at most (distinct scenes)
    quantities = ["K_a_over_K_b"]   # optional: the stiffnesses refined on (default: every one stored)
    initial = 5               # optional: nodes per numeric axis in the first round (>= 2)
    log = ["load"]            # optional: list axes interpolated in log10 (logspace axes always are)

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

Checks. The estimate is a model of the interpolation error, tuned on the maps it was tested
on; a map nobody tuned it to can break it. So when the refinement ends, a check round solves
``checks`` random unsolved points of every sub-problem (default ``DEFAULT_CHECKS``; a fixed seed
per round and sub-problem, so a resumed sweep draws the same) and compares each solve with
the interpolant there. Where the interpolant misses a check by more than its map error (less
the two solves' own estimated errors, which the difference may hold), the sub-problem's
factor on the interpolation estimate (``SAFETY`` at first) is multiplied by the worst ratio
found × ``CHECK_MARGIN``, the refinement resumes with it, and a new check round follows, at
most ``MAX_CHECK_ROUNDS`` in all. A check point is a solved point of the data set (its map
error is its solve's error). What this guarantees: after a check round that needed no
increase, the estimate held at every one of the ``checks`` random points of each sub-problem;
were it below the true error on a fraction p of the map, that happens with probability
(1 − p)^checks (p = 10 %: 4 % for 30 checks).

Rounds. Each round is an ordinary run of the driver (``driver._round``) over the tasks of the
round's new points: every rank takes chunks of them, each journaled as usual; rank 0 builds
the data set of all journaled tasks and decides the next round from the values at the nodes
alone (not from other journaled points), so a sweep interrupted in any round and run again
with ``--resume`` takes the same rounds, reuses every journaled task and solves none twice.
Only the last round writes the data set (``fill``): the full grid, every variable of a full
sweep, stiffnesses and their ``<name>_error`` interpolated at unsolved points, plus
``solved``, ``<name>_map_error`` and the global attribute ``sweep_solves``
(docs/reference/dataset.md).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, TextIO

import numpy as np
import xarray as xr

from hpcontact.errors import InputError
from hpcontact.problems.kinds import CONTACT
from hpcontact.quantities import ESTIMATED, SLIP_ESTIMATED
from hpcontact.sweep import provenance
from hpcontact.sweep.adaptive_settings import INTERPOLATED_AXES, Settings
from hpcontact.sweep.columns import NOT_COMPUTED
from hpcontact.sweep.dataset import DIRECTIONAL, TENSOR, derive_directional, directional_errors
from hpcontact.sweep.interpolation import Scale, TensorInterpolant, bisection_nodes, coordinate, refined
from hpcontact.sweep.journal import OK

#: Stiffnesses the estimate of an off-diagonal entry is relative to (as ``dataset.error_attributes``).
OFF_DIAGONAL = re.compile(r"^K_(xy|yx|xz|zx|yz|zy)(_coupled)?$")
MAP_ERROR_SUFFIX = "_map_error"
INTERPOLATED_MESSAGE = "interpolated (adaptive map)"
#: An unsolved point whose interpolant needs a node whose solve failed (status not computed).
UNINTERPOLATED_MESSAGE = "not interpolated: a solve it depends on failed (adaptive map)"
#: Factor on the interpolation estimate (the next Newton term): measured on Mindlin's map
#: (tests/sweep/test_adaptive.py), 1 under-estimates at ~7 % of the points, 1.5 at none. The
#: check rounds raise it per sub-problem where random solves show it short (module docstring).
SAFETY = 1.5
#: A check that shows the estimate short by a ratio r raises the factor by r × this margin.
CHECK_MARGIN = 1.25
#: Check rounds at most (one, plus one after each round that had to raise a factor).
MAX_CHECK_ROUNDS = 3
#: The largest factor a check may raise a sub-problem's estimate by in one round (an estimate
#: of zero at a missed check: the interpolant is blind there; the map refines around it).
MAX_RAISE = 1e3


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
    """The check rounds so far (module docstring): the flat indices of the random points
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


def _solve_errors(
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
    errors = _solve_errors(layout, fields, work, cat, nodes)
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


def wants_check(settings: Settings, checks: Checks) -> bool:
    """Whether a refinement that has ended is followed by a check round: the first, and one
    after each that raised a factor, at most ``MAX_CHECK_ROUNDS``."""
    return settings.checks > 0 and checks.rounds < MAX_CHECK_ROUNDS and (checks.rounds == 0 or checks.raised)


def drawn_checks(layout: Layout, settings: Settings, state: State, checks: Checks, task_of: np.ndarray) -> Checks:
    """``checks`` with ``settings.checks`` more random points of every sub-problem whose tasks
    are not solved yet (fewer where fewer are left, or where ``max_solves`` leaves fewer); the
    generator seeded by the check round and the sub-problem, so every rank and a resumed sweep
    draw the same. Unchanged when there is none to draw."""
    task_of = np.asarray(task_of)
    flat = np.arange(math.prod(layout.shape)).reshape(layout.shape)
    solved = set(state_tasks(layout, state, task_of, checks).tolist())
    room = None if settings.max_solves is None else settings.max_solves - len(solved)
    drawn: list[int] = []
    for s, (cat, _) in enumerate(state):
        points = layout.take(flat, cat).ravel()
        tasks = task_of.ravel()[points]
        free: dict[int, int] = {}  # a task not solved yet -> its first point in the sub-problem
        for point, task in zip(points.tolist(), tasks.tolist()):
            if task not in solved:
                free.setdefault(task, point)
        count = min(settings.checks, len(free), room if room is not None else len(free))
        if count <= 0:
            continue
        rng = np.random.default_rng([checks.rounds, s, 27])
        picked = rng.choice(np.asarray(sorted(free.values())), size=count, replace=False)
        drawn.extend(int(p) for p in picked)
        solved.update(int(t) for t in task_of.ravel()[picked])
        if room is not None:
            room -= count
    if not drawn:
        return checks
    safety = checks.safety or tuple(SAFETY for _ in state)
    conservative = checks.conservative or tuple(False for _ in state)
    return replace(
        checks, points=tuple(sorted({*checks.points, *drawn})), safety=safety, conservative=conservative, pending=True
    )


def judged(
    layout: Layout, state: State, checks: Checks, fields: Mapping[str, np.ndarray], names: Sequence[str]
) -> Checks:
    """``checks`` after its pending points are solved: in each sub-problem, the worst ratio of
    the interpolant's miss at a check point — |solved − interpolated| relative to the
    quantity's scale, less the check's own and the nodes' interpolated solve errors — to the
    interpolation estimate there. Above 1, the sub-problem first turns conservative
    (``TensorInterpolant.estimates``: the lower order's error too) and is judged again; still
    above 1, its factor is raised by the ratio × ``CHECK_MARGIN`` (at most ``MAX_RAISE``).
    Every check point is judged again each time (the nodes may have moved)."""
    full = np.zeros(layout.shape, dtype=bool)
    full.ravel()[list(checks.points)] = True
    safety = list(checks.safety or (SAFETY for _ in state))
    conservative = list(checks.conservative or (False for _ in state))
    raised = False
    for s, (cat, nodes) in enumerate(state):
        here = layout.take(full, cat)
        if not here.any():
            continue
        worst = _worst_miss(layout, cat, nodes, names, fields, here, safety[s], conservative[s])
        if worst > 1.0 and not conservative[s]:
            conservative[s], raised = True, True
            worst = _worst_miss(layout, cat, nodes, names, fields, here, safety[s], True)
        if worst > 1.0:
            safety[s] *= min(worst * CHECK_MARGIN, MAX_RAISE)
            raised = True
    return replace(
        checks,
        safety=tuple(safety),
        conservative=tuple(conservative),
        rounds=checks.rounds + 1,
        raised=raised,
        pending=False,
    )


def _worst_miss(
    layout: Layout,
    cat: Sequence[int],
    nodes: Sequence[Sequence[int]],
    names: Sequence[str],
    fields: Mapping[str, np.ndarray],
    here: np.ndarray,
    safety: float,
    conservative: bool,
) -> float:
    """The worst ratio of miss to interpolation estimate at the check points ``here`` of the
    sub-problem ``cat`` (``judged``); 0 where every check holds."""
    est = estimate(layout, cat, nodes, names, fields, safety, conservative)
    actual = np.stack([layout.take(fields[n], cat)[here] for n in names], axis=-1)
    own = _solve_errors(layout, fields, names, cat)[here]
    with np.errstate(invalid="ignore", divide="ignore"):
        miss = np.abs(actual - est.values[here]) / est.scale[here] - own - est.solve[here]
        interpolation = est.interpolation[here]
        ratio = np.where(miss > interpolation, np.where(interpolation > 0.0, miss / interpolation, np.inf), 0.0)
    ratio = np.nan_to_num(ratio, nan=0.0, posinf=np.inf)
    return float(ratio.max()) if ratio.size else 0.0


def stiffness_names(ds: Any, kind: str) -> list[str]:
    """The stored stiffnesses of the data set ``ds`` (those that carry ``<name>_error``)."""

    pattern = ESTIMATED if kind == CONTACT else SLIP_ESTIMATED
    return [str(v) for v in ds.data_vars if pattern.match(str(v)) and not str(v).endswith("_error")]


def refined_names(ds: Any, spec: Any) -> list[str]:
    """The quantities refined on: ``[adaptive] quantities`` that the data set holds, else
    every stored stiffness."""
    stored = stiffness_names(ds, spec.kind)
    chosen = spec.adaptive.quantities
    if chosen is None:
        return stored
    for name in chosen:
        if name not in stored:
            raise InputError("adaptive.quantities", f"stiffnesses the scenes store ({', '.join(stored)})", name)
    return list(chosen)


def _fields(ds: Any, names: Sequence[str]) -> dict[str, np.ndarray]:
    out = {}
    for name in names:
        for full in (name, f"{name}_error"):
            if full in ds:
                out[full] = np.asarray(ds[full].values, dtype=np.float64)
    return out


def fill(
    ds: Any, spec: Any, layout: Layout, state: State, task_of: np.ndarray, rounds: int, checks: Checks | None = None
) -> Any:
    """The final data set of an adaptive sweep from ``ds`` (``dataset.dataset_of`` of every
    journaled task, derive off): every unsolved point of a sub-problem filled by interpolation
    from its nodes (stiffnesses and their ``<name>_error``; other record variables NaN or "",
    ``status`` ok where the stiffnesses are finite, ``message`` ``INTERPOLATED_MESSAGE``,
    ``error_status`` the worst of the sub-problem's nodes), plus ``solved``,
    ``<name>_map_error`` for every stored stiffness (linked by ``ancillary_variables``) and the
    global attributes ``sweep_solves``, ``adaptive_*``. The check points of ``checks`` are
    solved points; each sub-problem's estimate carries the factor its checks set."""

    checks = checks if checks is not None else Checks()
    task_of = np.asarray(task_of)
    solved_tasks = state_tasks(layout, state, task_of, checks)
    solved = np.isin(task_of, solved_tasks)
    names = stiffness_names(ds, spec.kind)
    dims = ds["status"].dims
    fields = _fields(ds, names)
    values = {n: a.copy() for n, a in fields.items()}
    maps = {n: np.full(layout.shape, np.nan) for n in names}
    worst_status = ds["error_status"].values.copy() if "error_status" in ds else None
    for s, (cat, nodes) in enumerate(state):
        est = estimate(layout, cat, nodes, names, fields, checks.factor(s), checks.cautious(s))
        mask = layout.take(solved, cat)
        for q, name in enumerate(names):
            current = layout.take(values[name], cat)
            layout.put(values[name], cat, np.where(mask, current, est.values[..., q]))
            solve = (
                np.abs(np.nan_to_num(layout.take(fields[f"{name}_error"], cat), nan=0.0))
                if f"{name}_error" in fields
                else 0.0
            )
            interp = sum(e[..., q] for e in est.axes) + est.solve[..., q]
            layout.put(maps[name], cat, np.where(mask, solve, interp))
            if f"{name}_error" in values:
                current = layout.take(values[f"{name}_error"], cat)
                layout.put(values[f"{name}_error"], cat, np.where(mask, current, est.solve[..., q]))
        if worst_status is not None:
            node_status = layout.take(ds["error_status"].values, cat, nodes)
            current = layout.take(worst_status, cat)
            layout.put(worst_status, cat, np.where(mask, current, node_status.max()))
    out = ds.copy()
    unsolved = ~solved
    for name in out.data_vars:
        if name in values:
            out[name] = (out[name].dims, values[name], out[name].attrs)
        elif out[name].dims == dims and name not in ("status", "message", "error_status"):
            array = out[name].values.copy()
            if array.dtype.kind == "f":
                array[unsolved] = np.nan
            elif array.dtype.kind in "OUS":
                array = array.astype(object)
                array[unsolved] = ""
            else:
                continue
            out[name] = (dims, array, out[name].attrs)
    finite = np.all([np.isfinite(values[n]) for n in names], axis=0) if names else np.ones(layout.shape, bool)
    status = out["status"].values.copy()
    status[unsolved] = np.where(finite[unsolved], OK, NOT_COMPUTED)
    out["status"] = (dims, status, out["status"].attrs)
    message = out["message"].values.astype(object).copy()
    message[unsolved] = np.where(finite[unsolved], INTERPOLATED_MESSAGE, UNINTERPOLATED_MESSAGE)
    out["message"] = (dims, message, out["message"].attrs)
    if worst_status is not None:
        out["error_status"] = (dims, worst_status, out["error_status"].attrs)
    out["solved"] = (
        dims,
        solved.astype(np.int32),  # the file's integer type (netcdf: every integer is int32)
        {
            "long_name": "whether the point was solved (1) or interpolated from solved points (0) by the adaptive map",
            "flag_values": np.array([0, 1], dtype=np.int32),
            "flag_meanings": "interpolated solved",
        },
    )
    for name in names:
        error = f"{name}{MAP_ERROR_SUFFIX}"
        relative_to = "the largest diagonal entry" if OFF_DIAGONAL.match(name) else f"|{name}|"
        out[error] = (
            dims,
            maps[name],
            {
                "long_name": f"estimated relative error of {name} in the adaptive map, relative to {relative_to}: "
                f"the interpolation estimate (0 at solved points) plus the solve's own {name}_error where it has one",
                "units": "1",
            },
        )
        linked = str(out[name].attrs.get("ancillary_variables", "")).split()
        out[name].attrs["ancillary_variables"] = " ".join([*linked, error, "solved"])
    out = _directional_map_error(derive_directional(out))
    refined = refined_names(ds, spec)
    worst = max((float(np.nanmax(maps[n])) for n in refined if np.any(np.isfinite(maps[n]))), default=float("nan"))
    out.attrs.update(
        sweep_solves=int(len(solved_tasks)),
        sweep_points_solved=int(solved.sum()),
        adaptive_points_not_interpolated=int(np.count_nonzero(unsolved & ~finite)),
        adaptive_rounds=int(rounds),
        adaptive_tolerance=float(spec.adaptive.default),
        adaptive_quantities=" ".join(refined),
        adaptive_max_map_error=worst,
        adaptive_met=int(
            all(not np.any(maps[n] > spec.adaptive.tolerance(n)) for n in refined)
            and not np.count_nonzero(unsolved & ~finite)
        ),
        adaptive_check_points=len(checks.points),
        adaptive_check_rounds=int(checks.rounds),
        adaptive_estimate_factor=float(max(checks.safety, default=SAFETY)),
        adaptive_conservative_subproblems=int(sum(checks.conservative)),
    )
    if spec.adaptive.max_solves is not None:
        out.attrs["adaptive_max_solves"] = int(spec.adaptive.max_solves)
    return xr.Dataset(out.data_vars, coords=out.coords, attrs=out.attrs)


def _directional_map_error(ds: Any) -> Any:
    """``ds`` with ``K_nn_map_error`` (and ``normalized_nn_map_error``) where it has K_nn: the
    bound ``dataset`` derives ``K_nn_error`` by, on the tensor's map errors."""

    if "K_nn" not in ds or not all(f"{n}{MAP_ERROR_SUFFIX}" in ds for n in TENSOR):
        return ds
    names = [*TENSOR, "K_zz", "K_nn", "normalized_nn"]
    tmp = ds[[n for n in names if n in ds]]
    tmp = tmp.assign({f"{n}_error": ds[f"{n}{MAP_ERROR_SUFFIX}"] for n in [*TENSOR, "K_zz"] if n in ds})
    order = ds.attrs.get("sweep_axes", " ".join(map(str, ds.dims))).split()
    derived = directional_errors(tmp, order)
    out = ds
    for name in DIRECTIONAL:
        if f"{name}_error" in derived and name in ds:
            error = f"{name}{MAP_ERROR_SUFFIX}"
            array = derived[f"{name}_error"]
            out = out.assign({error: array})
            out[error].attrs = {
                "long_name": f"estimated relative error of {name} in the adaptive map (from the tensor's map errors)",
                "units": "1",
            }
            linked = str(out[name].attrs.get("ancillary_variables", "")).split()
            out[name].attrs["ancillary_variables"] = " ".join([*linked, error, "solved"])
    return out


RoundFunction = Callable[[Any, "frozenset[int] | None", "Callable[[Any, Any], Any] | None", "frozenset[int]"], Any]


def run_rounds(
    team: Any, spec: Any, task_of: np.ndarray, options: Any, stream: TextIO, run_round: RoundFunction
) -> Any:
    """Every rank: the rounds of an adaptive sweep (module docstring). ``run_round(options,
    select, finish, earlier)`` is one ordinary driver run over the tasks ``select`` (positions),
    whose rank 0 calls ``finish(dataset, joined)`` on the data set of every journaled task and
    writes what it returns (None: nothing, not the last round); ``earlier`` are the tasks of
    the rounds before (their failures stay in the data set, not run again)."""

    # one git revision for every round: a commit in the checkout while the sweep runs must not
    # make the rounds' own journals look stale to the next round (the code running is the same)
    pinned = os.environ.get(provenance.REVISION_VARIABLE)
    revision = team.bcast(provenance.git_revision() if team.rank == 0 else None)
    if revision is not None:
        os.environ[provenance.REVISION_VARIABLE] = revision
    try:
        return _rounds(team, spec, task_of, options, stream, run_round)
    finally:
        if pinned is None:
            os.environ.pop(provenance.REVISION_VARIABLE, None)
        else:
            os.environ[provenance.REVISION_VARIABLE] = pinned


def _rounds(team: Any, spec: Any, task_of: np.ndarray, options: Any, stream: TextIO, run_round: RoundFunction) -> Any:
    layout = Layout.of(spec)
    task_of = np.asarray(task_of)
    state = initial_state(layout, spec.adaptive)
    checks = Checks()
    done: np.ndarray = np.empty(0, dtype=np.intp)
    decided: dict[str, Any] = {}
    rounds = 0
    while True:
        rounds += 1
        tasks = state_tasks(layout, state, task_of, checks)
        new = np.setdiff1d(tasks, done)
        if team.rank == 0:
            what = "random point(s) solved to check the map error" if checks.pending else "scene(s) added"
            print(
                f"hpcontact: adaptive round {rounds}: {len(new)} {what}, {len(tasks)} of "
                f"{len(np.unique(task_of))} in all",
                file=stream,
                flush=True,
            )
        this_round = rounds

        def finish(
            ds: Any, joined: Any, state: State = state, checks: Checks = checks, this_round: int = this_round
        ) -> Any:
            names = refined_names(ds, spec)
            stored = stiffness_names(ds, spec.kind)
            if checks.pending:
                checks = judged(layout, state, checks, _fields(ds, stored), stored)
            following = refine(layout, spec.adaptive, state, _fields(ds, stored), names, task_of, checks)
            if following is None and wants_check(spec.adaptive, checks):
                drawn = drawn_checks(layout, spec.adaptive, state, checks, task_of)
                if drawn.pending:
                    decided["next"] = (state, drawn)
                    return None
            decided["next"] = None if following is None else (following, checks)
            if following is not None:
                return None
            out = fill(ds, spec, layout, state, task_of, this_round, checks)
            decided["line"] = outcome_line(out, spec)
            return out

        outcome = run_round(
            options
            if rounds == 1
            else replace(options, resume=True, restart=False, break_lock=False, up_to_date=False),
            frozenset(int(i) for i in new),
            finish,
            frozenset(int(i) for i in done),
        )
        following = team.bcast(decided.get("next") if team.rank == 0 else None)
        done = tasks
        if following is None:
            if team.rank == 0 and "line" in decided:
                print(decided["line"], file=stream, flush=True)
            return outcome
        state, checks = following


def _shown(value: Any) -> str:
    """An axis value for a line of text: numbers to four digits, labels as they are."""
    return f"{value:.4g}" if isinstance(value, (int, float, np.number)) else str(value)


def outcome_line(ds: Any, spec: Any) -> str:
    """The run's last word on the map (``fill``'s data set): whether every refined quantity met
    its tolerance, the worst map error, the quantity and point where it is, the solves and the
    check points."""
    settings: Settings = spec.adaptive
    worst, where = -1.0, ""
    for name in str(ds.attrs.get("adaptive_quantities", "")).split():
        error = ds[f"{name}{MAP_ERROR_SUFFIX}"]
        if not np.any(np.isfinite(error.values)):
            continue
        flat = int(np.nanargmax(error.values))
        value = float(error.values.ravel()[flat])
        if value > worst:
            index = np.unravel_index(flat, error.shape)
            point = ", ".join(f"{d} = {_shown(ds[d].values[i])}" for d, i in zip(error.dims, index) if ds.sizes[d] > 1)
            worst, where = value, f"{name} at {point}" if point else name
    met = bool(ds.attrs.get("adaptive_met", 0))
    solves, points = int(ds.attrs["sweep_solves"]), int(np.prod([ds.sizes[d] for d in ds["status"].dims]))
    verdict = "met its tolerance" if met else "did NOT meet its tolerance"
    tolerance = f"{settings.default:g}" if not settings.tolerances else "the quantities' tolerances"
    checked = int(ds.attrs.get("adaptive_check_points", 0))
    check = (
        f"; {checked} random check point(s), estimate factor {float(ds.attrs['adaptive_estimate_factor']):.3g}"
        if checked
        else "; no check points"
    )
    return (
        f"hpcontact: adaptive map {verdict} ({tolerance}): worst map error {worst:.2e} ({where}); "
        f"{solves} solves for {points} points{check}"
    )


def dry_run_text(spec: Any, task_of: np.ndarray) -> str:
    """The dry run's lines on an adaptive spec: the first round and the bound."""
    layout = Layout.of(spec)
    task_of = np.asarray(task_of)
    first = state_tasks(layout, initial_state(layout, spec.adaptive), task_of)
    total = len(np.unique(task_of))
    settings: Settings = spec.adaptive
    bound = (
        f"at most {min(settings.max_solves, total)} (max_solves)"
        if settings.max_solves is not None
        else f"at most {total} (the full grid)"
    )
    scales = ", ".join(f"{spec.task_axes[p].name} ({s.value})" for p, s in zip(layout.numeric, layout.scales))
    quantities = "every stored stiffness" if settings.quantities is None else ", ".join(settings.quantities)
    return (
        f"# adaptive: first round {len(first)} of the {total} tasks (nodes "
        f"{' x '.join(str(len(bisection_nodes(layout.shape[p], settings.initial))) for p in layout.numeric)} per "
        f"sub-problem); solves {bound}; tolerance {settings.default:g} on {quantities}; interpolated axes: {scales}"
    )
