"""The check rounds of an adaptive map: random solves that test its error estimate.

Checks. The estimate is a model of the interpolation error, tuned on the maps it was tested
on; a map nobody tuned it to can break it. So when the refinement ends, a check round solves
``checks`` random unsolved points of every sub-problem (by default ``check_count``: a tenth of
the sub-problem's nodes, at least ``MIN_CHECKS`` and at most ``MAX_CHECKS``; a fixed seed per
round and sub-problem, so a resumed sweep draws the same) and compares each solve with
the interpolant there. Where the interpolant misses a check by more than its map error (less
the two solves' own estimated errors, which the difference may hold), the sub-problem's
factor on the interpolation estimate (``SAFETY`` at first) is multiplied by the worst ratio
found × ``CHECK_MARGIN``, the refinement resumes with it, and a new check round follows, at
most ``MAX_CHECK_ROUNDS`` in all. A check point is a solved point of the data set (its map
error is its solve's error). What this guarantees: after a check round that needed no
increase, the estimate held at every one of the n random points of each sub-problem; were it
below the true error on a fraction p of the map, that happens with probability (1 − p)^n:
p = 25 %: 5.6 % for the fewest, n = 10 (an estimate short on a quarter of a map is caught 19
times in 20); p = 10 %: 4 % for n = 30, a map of 300 nodes or more. The checks cost a tenth of
the nodes' solves (rounded up) on a map of 100 nodes or more (30 per sub-problem before: 30 %
of a map of 100 nodes; 10 random points caught the estimate short on the maps M2, M3, M5 and M7
of docs/howto/adaptive.md as 30 did).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from hpcontact.sweep.maps.estimates import Checks, Layout, solve_errors
from hpcontact.sweep.maps.refinement import Leaf
from hpcontact.sweep.maps.state import State, estimate, is_sparse, node_mask, state_tasks
from hpcontact.sweep.space.adaptive_settings import Settings

#: Random points per check round and sub-problem by default (``check_count``): a tenth of its
#: nodes, within these bounds.
MIN_CHECKS, MAX_CHECKS = 10, 30
#: A check that shows the estimate short by a ratio r raises the factor by r × this margin.
CHECK_MARGIN = 1.25
#: Check rounds at most (one, plus one after each round that had to raise a factor).
MAX_CHECK_ROUNDS = 3
#: The largest factor a check may raise a sub-problem's estimate by in one round (an estimate
#: of zero at a missed check: the interpolant is blind there; the map refines around it).
MAX_RAISE = 1e3


def check_count(settings: Settings, nodes: int) -> int:
    """Random points a check round draws in a sub-problem of ``nodes`` nodes: ``settings.checks``
    where the spec sets it, else ⌈nodes / 10⌉ within [``MIN_CHECKS``, ``MAX_CHECKS``]."""
    if settings.checks is not None:
        return settings.checks
    return min(max(math.ceil(nodes / 10), MIN_CHECKS), MAX_CHECKS)


def wants_check(settings: Settings, checks: Checks) -> bool:
    """Whether a refinement that has ended is followed by a check round: the first, and one
    after each that raised a factor, at most ``MAX_CHECK_ROUNDS``."""
    return settings.checks != 0 and checks.rounds < MAX_CHECK_ROUNDS and (checks.rounds == 0 or checks.raised)


def drawn_checks(layout: Layout, settings: Settings, state: State, checks: Checks, task_of: np.ndarray) -> Checks:
    """``checks`` with ``check_count`` more random points of every sub-problem whose tasks
    are not solved yet (fewer where fewer are left, or where ``max_solves`` leaves fewer); the
    generator seeded by the check round and the sub-problem, so every rank and a resumed sweep
    draw the same. Unchanged when there is none to draw."""
    task_of = np.asarray(task_of)
    flat = np.arange(math.prod(layout.shape)).reshape(layout.shape)
    solved = set(state_tasks(layout, state, task_of, checks).tolist())
    room = None if settings.max_solves is None else settings.max_solves - len(solved)
    drawn: list[int] = []
    for s, (cat, leaves) in enumerate(state):
        points = layout.take(flat, cat).ravel()
        tasks = task_of.ravel()[points]
        free: dict[int, int] = {}  # a task not solved yet -> its first point in the sub-problem
        for point, task in zip(points.tolist(), tasks.tolist()):
            if task not in solved:
                free.setdefault(task, point)
        wanted = check_count(settings, int(np.count_nonzero(node_mask(layout, leaves))))
        count = min(wanted, len(free), room if room is not None else len(free))
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
    safety = checks.factors(len(state))
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
    (``TensorInterpolant.estimates``: the lower order's error too; a sparse grid's has no other
    kind) and is judged again; still above 1, its factor is raised by the ratio × ``CHECK_MARGIN`` (at most ``MAX_RAISE``).
    Every check point is judged again each time (the nodes may have moved)."""
    full = np.zeros(layout.shape, dtype=bool)
    full.ravel()[list(checks.points)] = True
    safety = list(checks.factors(len(state)))
    conservative = list(checks.conservative or (False for _ in state))
    raised = False
    for s, (cat, leaves) in enumerate(state):
        here = layout.take(full, cat)
        if not here.any():
            continue
        worst = _worst_miss(layout, cat, leaves, names, fields, here, safety[s], conservative[s])
        if worst > 1.0 and not conservative[s] and not is_sparse(leaves):
            conservative[s], raised = True, True
            worst = _worst_miss(layout, cat, leaves, names, fields, here, safety[s], True)
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
    leaves: Sequence[Leaf],
    names: Sequence[str],
    fields: Mapping[str, np.ndarray],
    here: np.ndarray,
    safety: float,
    conservative: bool,
) -> float:
    """The worst ratio of miss to interpolation estimate at the check points ``here`` of the
    sub-problem ``cat`` (``judged``); 0 where every check holds."""
    est = estimate(layout, cat, leaves, names, fields, safety, conservative)
    actual = np.stack([layout.take(fields[n], cat)[here] for n in names], axis=-1)
    own = solve_errors(layout, fields, names, cat)[here]
    with np.errstate(invalid="ignore", divide="ignore"):
        miss = np.abs(actual - est.values[here]) / est.scale[here] - own - est.solve[here]
        interpolation = est.interpolation[here]
        ratio = np.where(miss > interpolation, np.where(interpolation > 0.0, miss / interpolation, np.inf), 0.0)
    ratio = np.nan_to_num(ratio, nan=0.0, posinf=np.inf)
    return float(ratio.max()) if ratio.size else 0.0
