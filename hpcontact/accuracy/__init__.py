r"""Extrapolated answers with an honest error estimate (``hpcontact solve --accuracy REL``).

Why the plain grid sequence cannot be extrapolated
--------------------------------------------------
The engine puts a cell in the contact when its centre lies inside the shape (docs/design.md §2.2). The
staircase area of a curved shape then fluctuates with n (the Gauss circle problem): the error
is not a smooth function of the cell size h, and the fluctuation survives an area correction
K·(A/A_n)^½ (the edge's sensitivity is not uniform), so a Richardson extrapolation on
consecutive grids can land anywhere within that band, and a difference of two extrapolants can
be small by accident, ten times below the true error. Neither is honest (docs/validation.md
§"Why the centre-in-cell sequence cannot be extrapolated").

The grid sequence is solved on coverage-weighted boundary cells (``hpcontact.discretizations.boundary_cells``):
the discrete edge moves continuously with the true one and the error is a smooth expansion
c₁ h + c₂ h^q + … with q ≈ 1.5–3, which Richardson extrapolation can use.

The package, by role (each module's docstring states its part):

* ``extrapolation``: the estimator (generalized Richardson extrapolation, the spread of the
  extrapolants, the estimate per reported quantity);
* ``strategies``: the boundary cells refined over grids, one ``Strategy`` record each (grid
  sequence, first grid, calibrated range, memory model, model error), and the choice of ``auto``;
* ``memory``: the peak bytes of one solve per kind of cells; ``grid_plan``: the grids a request
  may use within the cell limit, the calibrated range and the memory budget;
* ``refinement``: the loop (``refine`` over the steps of ``RefinementState``, ``solve_to_accuracy``,
  ``exact_solve``, ``AccuracyNotMet``) and the grid sequences of a batch of scenes refined level by
  level together (``solve_to_accuracy_batch``);
* ``defaults``: the default discretization of a scene without ``n`` and each scene kind's solver.

This module is the package's face: the names below, and any other public name of those modules
(``hpcontact.accuracy.SAFETY``). Setting a name here (a test's ``monkeypatch``, a calibration
benchmark's ``--set``) sets it in every module of the package that holds it, so a constant is
still changed where it is used.
"""

from __future__ import annotations

import sys
import types
from typing import Any

from hpcontact.accuracy import defaults, extrapolation, grid_plan, memory, refinement, strategies
from hpcontact.accuracy.defaults import (
    DEFAULT_ACCURACY,
    DEFAULT_GRIDS,
    DEFAULT_N0,
    SOLVERS,
    accuracy_request,
    default_grids,
    default_scene_solve,
    default_solve,
    default_solve_batch,
    error_columns,
    extrapolates_by_default,
    requested_by_default,
    task_function,
)
from hpcontact.accuracy.extrapolation import (
    EXPANSIONS,
    MIN_GRIDS,
    RATIO,
    SAFETY,
    TENSOR_KEYS,
    estimate,
    exact_errors,
    extrapolant,
    extrapolate,
    observed_order,
    principal_error,
    spread,
)
from hpcontact.accuracy.grid_plan import GridPlan, plan_grids
from hpcontact.accuracy.refinement import (
    AccuracyNotMet,
    AccuracyRun,
    Refinement,
    RefinementState,
    exact_solve,
    plan_accuracy,
    refine,
    solve_levels_one_by_one,
    solve_to_accuracy,
    solve_to_accuracy_batch,
)
from hpcontact.accuracy.strategies import (
    COVERAGE_MAX_N,
    MAX_CELLS,
    N0,
    SINGULAR_EXPANSIONS,
    SINGULAR_MAX_CELLS,
    SINGULAR_SAFETY,
    STRATEGIES,
    Strategy,
    calibrated,
    coverage_n0,
    first_grid,
    grid_bytes,
    grid_sequence,
    model_error,
    singular_start,
)

__all__ = [
    "RATIO",
    "SAFETY",
    "EXPANSIONS",
    "SINGULAR_EXPANSIONS",
    "SINGULAR_MAX_CELLS",
    "COVERAGE_MAX_N",
    "calibrated",
    "SINGULAR_SAFETY",
    "singular_start",
    "grid_sequence",
    "plan_grids",
    "extrapolant",
    "observed_order",
    "spread",
    "estimate",
    "extrapolate",
    "principal_error",
    "refine",
    "first_grid",
    "coverage_n0",
    "model_error",
    "solve_to_accuracy",
    "solve_to_accuracy_batch",
    "solve_levels_one_by_one",
    "plan_accuracy",
    "AccuracyRun",
    "RefinementState",
    "default_solve",
    "default_solve_batch",
    "accuracy_request",
    "default_scene_solve",
    "default_grids",
    "requested_by_default",
    "extrapolates_by_default",
    "AccuracyNotMet",
    "error_columns",
    "DEFAULT_ACCURACY",
    "DEFAULT_GRIDS",
    "DEFAULT_N0",
    "MAX_CELLS",
    "MIN_GRIDS",
    "N0",
    "TENSOR_KEYS",
    "GridPlan",
    "Refinement",
    "STRATEGIES",
    "Strategy",
    "SOLVERS",
    "exact_errors",
    "exact_solve",
    "grid_bytes",
    "task_function",
]

_PARTS = (extrapolation, memory, strategies, grid_plan, refinement, defaults)
# every other public name of the modules is an attribute here too (``hpcontact.accuracy.STRIP_N0``),
# so that setting one (below) and undoing it restores the modules' value
for _part in _PARTS:
    for _name, _value in vars(_part).items():
        if not _name.startswith("_") and not isinstance(_value, types.ModuleType):
            globals().setdefault(_name, _value)
del _part, _name, _value


class _Face(types.ModuleType):
    """``hpcontact.accuracy``: setting a name sets it in every module of the package that holds it."""

    def __setattr__(self, name: str, value: Any) -> None:
        for part in _PARTS:
            if name in vars(part):
                setattr(part, name, value)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Face
