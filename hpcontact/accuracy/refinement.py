r"""The refinement loop of ``--accuracy``: solve a planned grid sequence until the estimate
meets the request (:func:`refine`, :func:`solve_to_accuracy`), or the one exact cell
(:func:`exact_solve`).

The refinement stops when the request is met, when the planned grids run out (``max_cells``
cells, or the memory budget: :func:`plan_grids` counts this process's peak resident set plus the
sweep cost model's arrays of the next grid, ``hpcontact.sweep.cost``), or when the estimate
has not fallen over two refinements (stagnation); the grids also stop where the estimator's
calibration ends (``calibration``: n = 1024 along the long side for coverage-weighted cells,
``COVERAGE_MAX_N``; 2^20 cells for singular cells, ``SINGULAR_MAX_CELLS``; 1024 strips,
``STRIP_MAX_N``; masks unlimited); the
record says which (``stopped_by``).

A long refinement can say how it goes: inside ``with reporting_levels(LevelProgress()):`` (what
``hpcontact solve`` does) every finished grid level is reported, one line on stderr each once the
solve has run ``PROGRESS_AFTER_S`` seconds.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import math
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, TextIO

from hpcontact import fields
from hpcontact import quantities as q
from hpcontact.accuracy.extrapolation import MIN_GRIDS, TENSOR_KEYS, exact_errors, extrapolate
from hpcontact.accuracy.grid_plan import GridPlan, plan_grids
from hpcontact.accuracy.strategies import EXACT, MAX_CELLS, cells, first_grid
from hpcontact.discretizations import galin_ellipse
from hpcontact.discretizations.boundary_cells import covered_solve
from hpcontact.errors import ConvergenceError, InputError
from hpcontact.numerics.convolution import clear_cache
from hpcontact.numerics.memory import resident_bytes
from hpcontact.scene import Scene

#: The grid of the finest level, which an extrapolated record states as its own.
FINEST_GRID_KEYS = ("nx", "ny", "dx", "dy", "contact_cells", "contact_area")
STAGNATION_LEVELS = 2  # no fall of the estimate over this many refinements: the extrapolants stagnate


#: Seconds a solve to an accuracy runs before ``LevelProgress`` reports its grid levels (a faster
#: solve prints nothing).
PROGRESS_AFTER_S = 3.0

#: Called by :func:`refine` after each grid level: ``report(level, planned, (n, n_across),
#: estimate, accuracy)``, ``estimate`` None before ``MIN_GRIDS`` levels.
LevelReport = Callable[[int, int, tuple[int, int], float | None, float], None]
_LEVEL_REPORT: contextvars.ContextVar[LevelReport | None] = contextvars.ContextVar("level_report", default=None)


@contextlib.contextmanager
def reporting_levels(report: LevelReport) -> Iterator[None]:
    """Within this block, :func:`refine` (every ``solve_to_accuracy`` and the extrapolated
    default solve) calls ``report`` after each grid level it solves."""
    token = _LEVEL_REPORT.set(report)
    try:
        yield
    finally:
        _LEVEL_REPORT.reset(token)


class LevelProgress:
    """A ``LevelReport`` that writes one line per finished grid level on ``stream`` (default
    stderr) once ``after_s`` seconds (default ``PROGRESS_AFTER_S``) have passed since it was made,
    none before:

        hpcontact: grid 4 of at most 7 (n = 256, n_across = 240): estimated error 2.1e-06, target 1e-06; 12.4 s

    ``clock`` gives seconds (``time.perf_counter``; a test's fake)."""

    def __init__(
        self,
        stream: TextIO | None = None,
        after_s: float | None = None,
        clock: Callable[[], float] = time.perf_counter,
    ) -> None:
        self.stream = stream
        self.after_s = PROGRESS_AFTER_S if after_s is None else after_s
        self.clock = clock
        self.started = clock()

    def __call__(
        self, level: int, planned: int, grid: tuple[int, int], estimate: float | None, accuracy: float
    ) -> None:
        elapsed = self.clock() - self.started
        if elapsed < self.after_s:
            return
        shown = (
            f"estimated error {estimate:.2g}, target {accuracy:g}"
            if estimate is not None
            else f"no estimate before {MIN_GRIDS} grids, target {accuracy:g}"
        )
        print(
            f"hpcontact: grid {level} of at most {planned} (n = {grid[0]}, n_across = {grid[1]}): {shown}; {elapsed:.1f} s",
            file=self.stream or sys.stderr,
            flush=True,
        )


def stagnates(history: Sequence[float], levels: int = STAGNATION_LEVELS) -> bool:
    """True when the estimate has not fallen over the last ``levels`` refinements."""
    return len(history) > levels and history[-1] >= history[-1 - levels]


@dataclasses.dataclass(frozen=True)
class Refinement:
    """What :func:`refine` found: the per-grid records, the extrapolated values, their estimated
    relative errors, observed orders and expansions (as :func:`extrapolate`), and what stopped
    it (``met``, ``stagnation``, or None when the grids ran out)."""

    levels: list[dict[str, Any]]
    values: dict[str, float]
    relative: dict[str, float]
    orders: dict[str, float]
    expansions: dict[str, list[float]]
    stopped_by: str | None


class RefinementState:
    """The refinement loop of :func:`refine` as a step function: the state of one scene's
    refinement after each grid level (its per-grid records, the estimates so far, what stopped it),
    so that a batch can solve level k of all its still-running scenes together
    (:func:`solve_to_accuracy_batch`) while each scene stops by its own estimate.

    ``grids``, ``accuracy``, ``expansions``, ``safety`` and ``model_error`` as :func:`refine`;
    :meth:`next_grid` is the grid to solve next (None once stopped), :meth:`add` takes its record
    and decides whether to stop, :meth:`result` is the :class:`Refinement`. The arithmetic and the
    decisions are :func:`refine`'s, in the same order, so a scene refined here step by step gets
    bitwise the record it gets from :func:`refine`."""

    def __init__(
        self,
        grids: Sequence[tuple[int, int]],
        accuracy: float,
        expansions: Sequence[tuple[float, ...]] | None = None,
        safety: float | None = None,
        model_error: float = 0.0,
    ) -> None:
        self.grids, self.accuracy, self.expansions = list(grids), accuracy, expansions
        self.safety, self.model_error = safety, model_error
        self.levels: list[dict[str, Any]] = []
        self.history: list[float] = []
        self.found: tuple[dict[str, float], dict[str, float], dict[str, float], dict[str, list[float]]] = (
            {},
            {},
            {},
            {},
        )
        self.stopped_by: str | None = None
        self.stopped = not self.grids

    def next_grid(self) -> tuple[int, int] | None:
        """The grid (n, n_across) of the next level, or None when the refinement has stopped."""
        return None if self.stopped else self.grids[len(self.levels)]

    def add(self, level: dict[str, Any]) -> None:
        """Take the record of the level on :meth:`next_grid`; from the ``MIN_GRIDS``-th on,
        extrapolate and stop when the estimate is met (``met``) or stagnates (``stagnation``), or
        when the grids run out. The level is reported to the ``LevelReport`` of
        :func:`reporting_levels`, if any."""
        report = _LEVEL_REPORT.get()
        n, na = self.grids[len(self.levels)]
        self.levels.append(level)
        self.stopped = len(self.levels) == len(self.grids)
        if len(self.levels) < MIN_GRIDS:
            if report is not None:
                report(len(self.levels), len(self.grids), (n, na), None, self.accuracy)
            return
        found = extrapolate(self.levels, self.expansions, self.safety)
        if self.model_error:
            found = (found[0], {k: v + self.model_error for k, v in found[1].items()}, found[2], found[3])
        self.found = found
        self.history.append(max(found[1].values()))
        if report is not None:
            report(len(self.levels), len(self.grids), (n, na), self.history[-1], self.accuracy)
        if self.history[-1] <= self.accuracy:
            self.stopped, self.stopped_by = True, "met"
        elif stagnates(self.history):
            self.stopped, self.stopped_by = True, "stagnation"

    def result(self) -> Refinement:
        """What the refinement found so far (:class:`Refinement`)."""
        return Refinement(self.levels, *self.found, stopped_by=self.stopped_by)


def refine(
    grids: Sequence[tuple[int, int]],
    solve_level: Any,
    accuracy: float,
    expansions: Sequence[tuple[float, ...]] | None = None,
    safety: float | None = None,
    model_error: float = 0.0,
) -> Refinement:
    """Solve ``solve_level(n, n_across)`` on ``grids`` in turn, extrapolating from the
    ``MIN_GRIDS``-th on, until the largest estimated relative error is ≤ ``accuracy`` (``met``)
    or has not fallen over ``STAGNATION_LEVELS`` refinements (``stagnation``). The one loop of
    ``solve_to_accuracy`` and of the replays of ``benchmarks/accuracy_sharpness.py``;
    ``expansions`` and ``safety`` as :func:`estimate`; ``model_error``, a relative bound on what
    the discretization itself leaves whatever the grid (strip cells' profile), is added to every
    estimate. Each level is reported to the ``LevelReport`` of :func:`reporting_levels`, if any.
    The steps are :class:`RefinementState`'s."""
    state = RefinementState(grids, accuracy, expansions, safety, model_error)
    while (grid := state.next_grid()) is not None:
        state.add(solve_level(*grid))
    return state.result()


def solve_to_accuracy(
    scene: Scene,
    accuracy: float,
    *,
    n0: int | None = None,
    n_across0: int | None = None,
    max_cells: int = MAX_CELLS,
    memory_budget: float | None = None,
    max_grids: int | None = None,
    strategy: str = "coverage",
    strict: bool = True,
) -> dict[str, Any]:
    """Solve ``scene`` on refined coverage-weighted grids until the estimated relative error
    of every reported stiffness is ≤ ``accuracy``; return the extrapolated record.

    The grids are planned before the first solve (:func:`plan_grids`): none exceeds
    ``max_cells`` cells or the memory budget (bytes; default the machine's memory per core).
    The refinement stops at the first of: the request met; the planned grids used up (limit
    ``cells`` or ``memory budget``); ``max_grids`` grids; the estimate not falling over
    ``STAGNATION_LEVELS`` refinements (``stagnation``: the extrapolants stagnate, finer grids
    would not help). A request not met follows the rule of every solver here (docs/howto/accuracy.md:
    a missed tolerance is an error, exit status 1): :class:`AccuracyNotMet` names the finest grid and the
    limit that stopped it; ``strict=False`` returns the record instead (``accuracy_met`` False).

    The record has the keys of ``hpcontact.problems.contact.solve`` (extrapolated ``K_*`` and the
    quantities derived from them; ``nx ny dx dy`` of the finest grid), and

    * ``estimated_error``: the largest estimated relative error (K_xx, K_yy, K_zz and
      K_a/K_b relative to themselves, off-diagonal entries relative to the largest diagonal);
    * ``estimated_errors``: the same per quantity; ``convergence_order``: the observed order
      of each raw sequence; ``expansion``: the exponents of the expansion each value comes
      from; ``accuracy_met``: whether ``estimated_error`` ≤ ``accuracy``;
    * ``stopped_by``: ``met``, ``cells``, ``memory budget``, ``calibration`` (the next grid is
      beyond the estimator's calibrated range, :func:`calibrated`), ``grids``, ``stagnation`` or
      ``model`` (cells whose own bound, :func:`model_error`, is not below the request);
      ``memory_budget_bytes``, ``memory_budget_source``, ``estimated_peak_bytes`` (of the finest
      grid used);
    * ``grids``: the n of every grid used, ``grids_across``: their n_across, ``levels``: the
      per-grid stiffnesses, wall times and iterations; ``wall_time_s``: the total.

    The scene's ``n`` and ``n_across`` are ignored (the sequence
    starts at ``n0`` (default 32) and ``n_across0``). ``strategy`` is the boundary treatment of
    ``covered_solve`` (coverage, singular, strip) or galin or auto; ``auto`` (what ``hpcontact solve
    --accuracy`` uses) takes the one exact cell of circles and ellipses (galin, :func:`exact_solve`:
    no grids, errors at round-off), strips (``STRIP_N0`` = 32 strips first, one across) for slender
    rectangles (:func:`strip_applies`; where their model bound is not below the
    request, four grids and ``stopped_by`` "model"), and coverage-weighted cells elsewhere
    (:func:`first_grid`); the record's ``boundary`` says which ran, and with strips
    ``model_error`` the bound included in every estimate. The memory plan counts the arrays of
    the cells used (:func:`grid_bytes`, with singular cells' near field, strips' dense matrices). The CG tolerance is tightened to at most
    accuracy/100 so that it never limits the answer. A mask is refined by splitting its pixels
    (the sequence starts at the contact's long side in pixels); a rough patch cannot be refined
    and is refused (InputError), as are quantities other than tangential, normal, coupled.
    """
    run = plan_accuracy(
        scene,
        accuracy,
        n0=n0,
        n_across0=n_across0,
        max_cells=max_cells,
        memory_budget=memory_budget,
        max_grids=max_grids,
        strategy=strategy,
    )
    if run.state is None:
        return exact_solve(scene, accuracy, strict, run.started)
    while (grid := run.state.next_grid()) is not None:
        run.state.add(run.solve_level(*grid))
    return run.record(strict)


@dataclasses.dataclass
class AccuracyRun:
    """One scene's :func:`solve_to_accuracy` once planned (:func:`plan_accuracy`): the cells
    (``strategy``), the CG tolerance of its levels (``tol``), the grid plan and the sequence it
    refines over, its cells' model bound (``model``) and its :class:`RefinementState` (None for the
    one exact cell, ``strategy`` "galin": no grids). ``started``: ``time.perf_counter()`` when the
    request began (the record's ``wall_time_s`` counts from it)."""

    scene: Scene
    accuracy: float
    strategy: str
    started: float
    tol: float
    plan: GridPlan | None = None
    max_grids: int | None = None
    model: float = 0.0
    state: RefinementState | None = None

    def level_scene(self, n: int, n_across: int) -> Scene:
        """The scene on the level grid n × n_across, at the levels' CG tolerance."""
        return self.scene.on_grid(n, n_across, self.tol)

    def solve_level(self, n: int, n_across: int) -> dict[str, Any]:
        """The record of the level n × n_across (``covered_solve`` on this run's cells); the kernel
        cache is cleared after it (this grid's kernels serve no other grid: the budget counts one
        grid's)."""
        level = covered_solve(self.level_scene(n, n_across), self.strategy)
        clear_cache()
        return level

    def record(self, strict: bool = True) -> dict[str, Any]:
        """The extrapolated record of the refinement so far (:func:`solve_to_accuracy`'s keys);
        with ``strict`` a request not met raises :class:`AccuracyNotMet`."""
        if self.state is None or self.plan is None:
            raise ValueError("the one exact cell's record is exact_solve's")
        scene, plan, model, accuracy = self.scene, self.plan, self.model, self.accuracy
        chosen = cells(self.strategy)
        sequence = self.state.grids
        done = self.state.result()
        levels, values, relative, orders, expansions = (
            done.levels,
            done.values,
            done.relative,
            done.orders,
            done.expansions,
        )
        stopped_by = done.stopped_by or (
            "model"
            if model >= accuracy
            else "grids"
            if self.max_grids is not None and self.max_grids < len(plan.grids)
            else plan.limit
        )
        finest = levels[-1]
        record: dict[str, Any] = {k: finest[k] for k in (*FINEST_GRID_KEYS, *fields.recorded_names()) if k in finest}
        record.update(values)
        worst = max(relative.values())
        record.update(q.derived_quantities(values, scene.material, noise=worst))
        record["estimated_error"] = worst
        record["estimated_errors"] = dict(relative)
        record["convergence_order"] = {k: (v if math.isfinite(v) else None) for k, v in orders.items()}  # JSON-safe
        record["expansion"] = expansions
        record["accuracy"] = float(accuracy)
        record["accuracy_met"] = bool(worst <= accuracy)
        record["stopped_by"] = stopped_by
        record["boundary"] = self.strategy
        record["grids"] = [n for n, _ in sequence[: len(levels)]]
        record["grids_across"] = [na for _, na in sequence[: len(levels)]]
        record["memory_budget_bytes"] = plan.budget
        record["memory_budget_source"] = plan.budget_source
        record["estimated_peak_bytes"] = plan.base_bytes + chosen.grid_bytes(scene, *sequence[len(levels) - 1])
        record["model_error"] = model
        record["levels"] = [
            {k: r[k] for k in (*TENSOR_KEYS, "K_a_over_K_b", "wall_time_s", "iterations", "contact_area") if k in r}
            for r in levels
        ]
        record["iterations"] = int(sum(r["iterations"] for r in levels))
        record["residual"] = max(r["residual"] for r in levels)
        record["plan"] = {
            **finest["plan"],
            "extrapolation": "generalized Richardson over grids ratio 2, expansion of least spread",
        }
        record["wall_time_s"] = time.perf_counter() - self.started
        if strict and not record["accuracy_met"]:
            raise AccuracyNotMet(record, plan)
        return record

    def peak_bytes(self) -> float:
        """The arrays' bytes of the largest grid this run may solve (``Strategy.grid_bytes`` of
        the last grid of its sequence; 0 for the one exact cell, which solves no grid)."""
        if self.state is None or not self.state.grids:
            return 0.0
        return cells(self.strategy).grid_bytes(self.scene, *self.state.grids[-1])


def plan_accuracy(
    scene: Scene,
    accuracy: float,
    *,
    n0: int | None = None,
    n_across0: int | None = None,
    max_cells: int = MAX_CELLS,
    memory_budget: float | None = None,
    max_grids: int | None = None,
    strategy: str = "coverage",
) -> AccuracyRun:
    """The request of :func:`solve_to_accuracy` (same arguments) checked and planned, nothing
    solved: the cells of ``strategy`` (``auto`` resolved by :func:`first_grid`), the levels' CG
    tolerance min(``scene.tol``, accuracy/100) (at least 1e-14), the grids within the limits
    (:func:`plan_grids`; the first ``MIN_GRIDS`` alone where the cells' model bound is not below the
    request) and a fresh :class:`RefinementState` over them. Bad input, or fewer than ``MIN_GRIDS``
    grids within the limits, raises ``InputError``."""
    started = time.perf_counter()
    if not (isinstance(accuracy, (int, float)) and math.isfinite(accuracy) and 1e-9 <= accuracy < 1.0):
        raise InputError("accuracy", fields.ACCURACY_RANGE, accuracy)
    if memory_budget is not None and not (math.isfinite(memory_budget) and memory_budget > 0):
        raise InputError("memory", "a memory budget > 0 bytes", memory_budget)
    tol = max(min(scene.tol, accuracy * 1e-2), 1e-14)
    strategy, n0, n_across0 = first_grid(scene, strategy, n0, n_across0, accuracy)
    if strategy == EXACT:
        return AccuracyRun(scene, accuracy, strategy, started, tol)
    chosen = cells(strategy)
    plan = plan_grids(scene, n0, n_across0, max_cells, memory_budget, strategy)
    sequence = plan.grids[:max_grids] if max_grids is not None else plan.grids
    if len(sequence) < MIN_GRIDS:
        within = "the estimator's calibrated range" if plan.limit == "calibration" else f"{max_cells} cells"
        field, limit = (
            ("memory", f"a memory budget above {plan.next_bytes / 2**20:.0f} MiB")
            if plan.limit == "memory budget"
            else ("accuracy", f"a first grid small enough for {MIN_GRIDS} levels within {within}")
        )
        raise InputError(
            field,
            f"{limit} ({MIN_GRIDS} grids are the fewest an estimate needs)",
            plan.budget if plan.limit == "memory budget" else sequence[:1],
        )
    model = chosen.model_error(scene)
    if model >= accuracy:  # no grid can bring the estimate below the cells' own bound
        sequence = sequence[:MIN_GRIDS]
    state = RefinementState(sequence, accuracy, chosen.expansions, chosen.safety, model_error=model)
    return AccuracyRun(scene, accuracy, strategy, started, tol, plan, max_grids, model, state)


#: Solves one grid level of several runs at once: [(run, n, n_across)] → each one's level record
#: (``AccuracyRun.solve_level``'s) or the ``Exception`` its solve raised, in order.
LevelSolver = Callable[[Sequence[tuple["AccuracyRun", int, int]]], list[Any]]


def solve_levels_one_by_one(levels: Sequence[tuple[AccuracyRun, int, int]]) -> list[Any]:
    """The ``LevelSolver`` that solves each run's level alone (``AccuracyRun.solve_level``), an
    ``Exception`` of one kept as its result: on the CPU, where a batch of scenes is slower per scene
    (``sweep.work.batches``), and what a level gives each scene alone, bitwise."""
    out: list[Any] = []
    for run, n, n_across in levels:
        try:
            out.append(run.solve_level(n, n_across))
        except Exception as error:  # noqa: BLE001 - this scene's result; the others go on
            out.append(error)
    return out


def solve_to_accuracy_batch(
    scenes: Sequence[Scene],
    requests: Sequence[Mapping[str, Any]],
    solve_levels: LevelSolver = solve_levels_one_by_one,
) -> list[Any]:
    """:func:`solve_to_accuracy` of each of ``scenes`` with the keyword arguments of its
    ``requests`` (``accuracy`` among them), refined level by level together: each round solves the
    next level of every scene still refining in one call of ``solve_levels`` (a ``LevelSolver``),
    then each scene's :class:`RefinementState` decides by its own estimate whether it stops
    (met, stagnation, grids, cells, memory budget), so scenes stop at different levels. The one
    exact cell (strategy "galin") is solved per scene (``exact_solve``: a closed-form integral,
    no grid to batch).

    Returns, in order, each scene's record, or the ``Exception`` it raised (its input refused, a
    level's solve failed, ``AccuracyNotMet`` with ``strict``); a failing scene stops and the others
    go on. Each record is the one :func:`solve_to_accuracy` gives the scene alone where
    ``solve_levels`` gives each level's record alone (``solve_levels_one_by_one``: bitwise, the
    memory plan's and timing keys aside: ``memory_budget_bytes``/``estimated_peak_bytes`` count this
    process's resident set when planned, and ``wall_time_s`` runs from the batch's start)."""
    results: list[Any] = [None] * len(scenes)
    runs: dict[int, tuple[AccuracyRun, bool]] = {}
    for index, (scene, request) in enumerate(zip(scenes, requests)):
        options = dict(request)
        strict = bool(options.pop("strict", True))
        accuracy = options.pop("accuracy")
        try:
            run = plan_accuracy(scene, accuracy, **options)
            if run.state is None:
                results[index] = exact_solve(scene, accuracy, strict, run.started)
            else:
                runs[index] = (run, strict)
        except Exception as error:  # noqa: BLE001 - this scene's result; the others go on
            results[index] = error
    while refining := [(index, run) for index, (run, _) in runs.items() if run.state.next_grid() is not None]:
        levels = solve_levels([(run, *run.state.next_grid()) for _, run in refining])
        for (index, run), level in zip(refining, levels):
            try:
                if isinstance(level, Exception):
                    raise level
                run.state.add(level)
            except Exception as error:  # noqa: BLE001 - this scene's result; the others go on
                results[index] = error
                del runs[index]
    for index, (run, strict) in runs.items():
        try:
            results[index] = run.record(strict)
        except Exception as error:  # noqa: BLE001 - this scene's result (AccuracyNotMet with strict)
            results[index] = error
    return results


def exact_solve(scene: Scene, accuracy: float, strict: bool, started: float) -> dict[str, Any]:
    """:func:`solve_to_accuracy` of an elliptical contact on its one exact cell
    (``galin_ellipse.solve``): the same record keys, with ``grids`` [1], no ``levels``,
    ``stopped_by`` "met" or, where the integral's own bound is not below the request, "model"
    (``model_error`` is that bound); the estimates per quantity come from :func:`exact_errors`."""
    record = galin_ellipse.solve(scene)
    relative = exact_errors(record, record.pop("absolute_errors"))
    worst = max(relative.values())
    record.update(
        {
            "estimated_error": worst,
            "estimated_errors": relative,
            "convergence_order": {},
            "expansion": {},
            "accuracy": float(accuracy),
            "accuracy_met": bool(worst <= accuracy),
            "stopped_by": "met" if worst <= accuracy else "model",
            "grids": [1],
            "grids_across": [1],
            "levels": [],
            "model_error": worst,
            "estimated_peak_bytes": resident_bytes(),
            "wall_time_s": time.perf_counter() - started,
        }
    )
    if strict and not record["accuracy_met"]:
        raise AccuracyNotMet(record, GridPlan([(1, 1)], "model", (1, 1), 0.0, 0.0, math.inf, "none", 1))
    return record


class AccuracyNotMet(ConvergenceError):
    """``--accuracy`` stopped before its request: the estimate on the finest grid is above it.

    ``record`` is the extrapolated record (``accuracy_met`` False, ``stopped_by`` the limit)."""

    def __init__(self, record: Mapping[str, Any], plan: GridPlan) -> None:
        self.record = dict(record)
        finest = f"{record['grids'][-1]} x {record['grids_across'][-1]}"
        nxt = f"{plan.next_grid[0]} x {plan.next_grid[1]}"
        stopped = record["stopped_by"]
        why = (
            f"the next grid, {nxt}, is beyond those on which the error estimate of {record['boundary']} cells is "
            f"calibrated ({cells(record['boundary']).calibration_range()})"
            if stopped == "calibration"
            else {
                "cells": f"the next grid, {nxt}, exceeds the {plan.max_cells} cells allowed",
                "memory budget": f"the next grid, {nxt}, needs an estimated {plan.next_bytes / 2**20:.0f} MiB, above the memory "
                f"budget of {plan.budget / 2**20:.0f} MiB ({plan.budget_source})",
                "grids": "the number of grids allowed is used up",
                "model": f"the {record['boundary']} cells' own error bound, {record.get('model_error', 0.0):.2g} "
                "(accuracy.model_error: what they leave at this b/a on the grids of their sequence), is not below the request",
                "stagnation": f"the estimate did not fall over the last {STAGNATION_LEVELS} refinements (the extrapolants stagnate)",
            }[stopped]
        )
        super().__init__(
            f"accuracy {record['accuracy']:g} not met: estimated error {record['estimated_error']:.3g} on the finest "
            f"grid {finest}; stopped by {record['stopped_by']}: {why}",
            int(record["iterations"]),
            float(record["residual"]),
        )
