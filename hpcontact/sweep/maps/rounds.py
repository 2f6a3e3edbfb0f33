"""Adaptive maps: solve the grid points a map needs, interpolate the rest (``[adaptive]``).

A spec with an ``[adaptive]`` table keeps its ``[axes]`` as the output grid, but the sweep
solves a subset of it, chosen in rounds::

    [adaptive]
    tolerance = 1e-3          # relative map error allowed (or a table: {K_a_over_K_b = 1e-3, ...})
    max_solves = 200          # optional: solves at most (distinct scenes)
    quantities = ["K_a_over_K_b"]   # optional: the stiffnesses refined on (default: every one stored)
    initial = 5               # optional: nodes per numeric axis in the first round (>= 2)
    method = "auto"           # optional: "leaves" (k-d tree), "sparse" (sparse grid); auto: sparse from 3 axes
    log = ["load"]            # optional: list axes interpolated in log10 (logspace axes always are)

Rounds. Each round is an ordinary run of the driver (``driver._round``) over the tasks of the
round's new points: every rank takes chunks of them, each journaled as usual; rank 0 decides
the next round from the stored stiffnesses of all journaled tasks (``dataset.stored_stiffnesses``:
numpy arrays, no other variable, no data set made, no xarray) at the nodes alone (not from other journaled points), so a sweep interrupted in any round and run again
with ``--resume`` takes the same rounds, reuses every journaled task and solves none twice.
Only the last round makes and writes the data set (``fill``): the full grid, every variable of a full
sweep, stiffnesses and their ``<name>_error`` interpolated at unsolved points, plus
``solved``, ``<name>_map_error`` and the global attribute ``sweep_solves``
(docs/reference/dataset.md).

The nodes, the map error and the refinement: ``hpcontact.sweep.maps.state`` (by the method:
``hpcontact.sweep.maps.refinement``, ``hpcontact.sweep.maps.sparse_grid``); the check
rounds: ``hpcontact.sweep.maps.checks``; the data set: ``hpcontact.sweep.maps.fill``.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import replace
from typing import Any, TextIO

import numpy as np

from hpcontact.numerics.interpolation import bisection_nodes
from hpcontact.sweep.data import provenance
from hpcontact.sweep.maps.checks import drawn_checks, judged, wants_check
from hpcontact.sweep.maps.estimates import Checks, Layout, remembered_estimates
from hpcontact.sweep.maps.state import State, initial_state, refine, sparse_method, state_tasks
from hpcontact.sweep.space.adaptive_settings import Settings

RoundFunction = Callable[[Any, "frozenset[int] | None", "Callable[[Any, Any], Any] | None", "frozenset[int]"], Any]


def run_rounds(
    team: Any, spec: Any, task_of: np.ndarray, options: Any, stream: TextIO, run_round: RoundFunction
) -> Any:
    """Every rank: the rounds of an adaptive sweep (module docstring). ``run_round(options,
    select, finish, earlier)`` is one ordinary driver run over the tasks ``select`` (positions),
    whose rank 0 calls ``finish(make, joined)`` on the columns of every journaled task
    (``columns.Joined``) and ``make()``, their data set, and writes what it returns (None:
    nothing, not the last round); ``earlier`` are the tasks of the rounds before (their
    failures stay in the data set, not run again)."""

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
    distinct = distinct_tasks(task_of) if team.rank == 0 else 0  # said each round
    while True:
        rounds += 1
        tasks = state_tasks(layout, state, task_of, checks)
        new = np.setdiff1d(tasks, done)
        if team.rank == 0:
            what = "random point(s) solved to check the map error" if checks.pending else "scene(s) added"
            print(
                f"hpcontact: adaptive round {rounds}: {len(new)} {what}, {len(tasks)} of {distinct} in all",
                file=stream,
                flush=True,
            )
        this_round = rounds

        def finish(
            make: Callable[[], Any],
            joined: Any,
            state: State = state,
            checks: Checks = checks,
            this_round: int = this_round,
        ) -> Any:
            # rank 0 alone: the decision reads the stored stiffnesses alone (no xarray); the whole
            # data set is made only for the map's last round
            from hpcontact.sweep.data.dataset import stored_stiffnesses
            from hpcontact.sweep.maps.fill import fill, refined_names, stiffness_names

            fields = stored_stiffnesses(spec, task_of, joined)
            stored = stiffness_names(fields, spec.kind)
            with remembered_estimates():  # the last check's judgement and the fill: one estimate
                step = next_step(
                    layout, spec.adaptive, state, checks, fields, refined_names(fields, spec), stored, task_of
                )
                decided["next"] = step if isinstance(step, tuple) else None
                if isinstance(step, tuple):
                    return None
                out = fill(make(), spec, layout, state, task_of, this_round, step)
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


def next_step(
    layout: Layout,
    settings: Settings,
    state: State,
    checks: Checks,
    fields: dict[str, np.ndarray],
    names: list[str],
    stored: list[str],
    task_of: np.ndarray,
) -> tuple[State, Checks] | Checks:
    """Rank 0's decision after a round, from the values ``fields`` of the stored stiffnesses
    ``stored`` at the points solved so far (``names``: those refined on): the pending check
    points judged (``checks.judged``), then the next round's state and checks, or a check
    round's (``checks.drawn_checks``) when the refinement has ended; or, when the map is
    finished, its final checks alone."""
    if checks.pending:
        checks = judged(layout, state, checks, fields, stored)
    following = refine(layout, settings, state, fields, names, task_of, checks)
    if following is not None:
        return following, checks
    if wants_check(settings, checks):
        drawn = drawn_checks(layout, settings, state, checks, task_of)
        if drawn.pending:
            return state, drawn
    return checks


def _shown(value: Any) -> str:
    """An axis value for a line of text: numbers to four digits, labels as they are."""
    return f"{value:.4g}" if isinstance(value, (int, float, np.number)) else str(value)


def outcome_line(ds: Any, spec: Any) -> str:
    """The run's last word on the map (``fill``'s data set): whether every refined quantity met
    its tolerance, the worst map error, the quantity and point where it is, the solves and the
    check points."""
    from hpcontact.sweep.maps.fill import MAP_ERROR_SUFFIX

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


def distinct_tasks(task_of: np.ndarray) -> int:
    """How many distinct tasks the points' ``task_of`` (0-based positions) name: counted by
    ``np.bincount``, linear in the points (``np.unique`` sorts them: 25-50 ms on the 4-D map's
    146 475 points, rank 0 alone before the first round, every other rank waiting; 0.5 ms so;
    2026-11-30, 2-core development VM)."""
    return int(np.count_nonzero(np.bincount(np.ravel(task_of)))) if np.size(task_of) else 0


def _estimated(seconds: np.ndarray) -> str:
    """ ", estimated S core-seconds" of tasks estimated at ``seconds``; that not all are (a task
    the model leaves out, NaN) where one is not: said, not summed."""
    return (
        f", estimated {float(seconds.sum()):.4g} core-seconds" if np.isfinite(seconds).all() else ", not all estimated"
    )


def dry_run_text(spec: Any, task_of: np.ndarray, seconds: np.ndarray | None = None) -> str:
    """The dry run's line on an adaptive spec: the first round (with its estimated core-seconds,
    the sum of ``seconds``, each task's, where given) and the bound. The rounds after the first
    are decided from its results: no dry run can say how many they solve."""
    layout = Layout.of(spec)
    task_of = np.asarray(task_of)
    first = state_tasks(layout, initial_state(layout, spec.adaptive), task_of)
    total = distinct_tasks(task_of)
    settings: Settings = spec.adaptive
    bound = (
        f"at most {min(settings.max_solves, total)} (max_solves)"
        if settings.max_solves is not None
        else f"at most {total} (the full grid)"
    )
    scales = ", ".join(f"{spec.task_axes[p].name} ({s.value})" for p, s in zip(layout.numeric, layout.scales))
    quantities = "every stored stiffness" if settings.quantities is None else ", ".join(settings.quantities)
    grid = (
        "a sparse grid's first levels per sub-problem"
        if sparse_method(layout, settings)
        else f"nodes {' x '.join(str(len(bisection_nodes(layout.shape[p], settings.initial))) for p in layout.numeric)}"
        " per sub-problem"
    )
    cost = "" if seconds is None else _estimated(np.asarray(seconds, dtype=float)[first])
    return (
        f"# adaptive: first round {len(first)} of the {total} tasks ({grid}{cost}); solves {bound}; "
        f"tolerance {settings.default:g} on {quantities}; interpolated axes: {scales}"
    )
