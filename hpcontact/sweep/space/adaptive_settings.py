"""The ``[adaptive]`` table of a sweep spec, checked: what ``spec.parse_spec`` reads and
``hpcontact.sweep.maps`` runs (``maps.rounds`` says what each key does)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

from hpcontact.errors import InputError
from hpcontact.numerics.interpolation import bisection_nodes
from hpcontact.quantities import ESTIMATED, SLIP_ESTIMATED

#: Task axes an adaptive sweep interpolates (the rest are categorical: one sub-problem per value).
INTERPOLATED_AXES = frozenset(
    {"nu", "aspect", "anisotropy", "orientation", "angle", "load", "mu", "q_ratio", "anisotropy2", "orientation2"}
)
KEYS = ("tolerance", "max_solves", "quantities", "initial", "log", "checks", "method")
#: How the map's nodes are chosen (``maps.refinement``: leaves of a k-d tree; ``maps.sparse_grid``:
#: a dimension-adaptive sparse grid; "auto": ``state.sparse_method``).
METHODS = ("auto", "leaves", "sparse")
TOLERANCE_RANGE = "a relative error in [1e-8, 0.5]"
DEFAULT_INITIAL = 5


@dataclass(frozen=True)
class Settings:
    """The checked ``[adaptive]`` table: ``tolerance`` per quantity (``quantities`` None: every
    stored stiffness at ``default``), ``max_solves`` (None: the full grid bounds it), nodes per
    axis of the first round, the list axes interpolated in log10 and the random points of
    each sub-problem solved per check round (0: no check; None: ``maps.checks.check_count``,
    a tenth of the sub-problem's nodes, 10 … 30) and the ``method`` (``METHODS``)."""

    default: float
    tolerances: tuple[tuple[str, float], ...] = ()
    quantities: tuple[str, ...] | None = None
    max_solves: int | None = None
    initial: int = DEFAULT_INITIAL
    log: tuple[str, ...] = ()
    checks: int | None = None
    method: str = "auto"

    def tolerance(self, name: str) -> float:
        """The tolerance of the quantity ``name``."""
        return dict(self.tolerances).get(name, self.default)


def _tolerance(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 1e-8 <= value <= 0.5:
        raise InputError(key, TOLERANCE_RANGE, value)
    return float(value)


def parse_settings(table: Any, axes: Sequence[Any], raw_axes: Mapping[str, Any], task_axes: Sequence[Any]) -> Settings:
    """The ``Settings`` of the spec's ``[adaptive]`` ``table`` (``spec.parse_spec``); ``axes``
    are the spec's checked axes, ``raw_axes`` its ``[axes]`` table as written, ``task_axes``
    the axes solved per value. Refuses, naming the key, anything else."""
    if not isinstance(table, dict):
        raise InputError("adaptive", "a TOML table", table)
    for key in table:
        if key not in KEYS:
            raise InputError(f"adaptive.{key}", f"unknown key; allowed: {', '.join(KEYS)}")
    if "tolerance" not in table:
        raise InputError("adaptive.tolerance", f"required: {TOLERANCE_RANGE} (or a table of them by quantity)")
    stiffness = (ESTIMATED, SLIP_ESTIMATED)

    def quantity(key: str, name: Any) -> str:
        if not isinstance(name, str) or not any(p.match(name) for p in stiffness) or name.endswith("_error"):
            raise InputError(
                key, "a stored stiffness (K_xx, K_a_over_K_b, normalized_yy, tangential_stiffness, ...)", name
            )
        return name

    raw = table["tolerance"]
    tolerances: tuple[tuple[str, float], ...] = ()
    if isinstance(raw, dict):
        if not raw:
            raise InputError("adaptive.tolerance", "a table of at least one quantity", raw)
        tolerances = tuple(
            (quantity(f"adaptive.tolerance.{k}", k), _tolerance(f"adaptive.tolerance.{k}", v)) for k, v in raw.items()
        )
        default = min(t for _, t in tolerances)
    else:
        default = _tolerance("adaptive.tolerance", raw)
    quantities = None
    if "quantities" in table:
        names = table["quantities"]
        if isinstance(names, str):
            names = [names]
        if not isinstance(names, list) or not names:
            raise InputError("adaptive.quantities", "a list of stored stiffnesses", names)
        quantities = tuple(dict.fromkeys(quantity("adaptive.quantities", n) for n in names))
        if tolerances and set(quantities) != {k for k, _ in tolerances}:
            raise InputError("adaptive.quantities", "the quantities of adaptive.tolerance, or left out", names)
    elif tolerances:
        quantities = tuple(k for k, _ in tolerances)
    initial = table.get("initial", DEFAULT_INITIAL)
    if isinstance(initial, bool) or not isinstance(initial, int) or not 2 <= initial <= 1000:
        raise InputError(
            "adaptive.initial", "an integer in [2, 1000] (nodes per numeric axis in the first round)", initial
        )
    checks = table.get("checks")
    if checks is not None and (isinstance(checks, bool) or not isinstance(checks, int) or not 0 <= checks <= 10_000):
        raise InputError(
            "adaptive.checks",
            "an integer in [0, 10000] (random points solved per sub-problem to check the map)",
            checks,
        )
    method = table.get("method", "auto")
    if method not in METHODS:
        raise InputError("adaptive.method", f"one of {', '.join(METHODS)}", method)
    log = table.get("log", [])
    if isinstance(log, str):
        log = [log]
    if not isinstance(log, list):
        raise InputError("adaptive.log", "a list of numeric axes", log)
    by_name = {a.name: a for a in axes}
    for name in log:
        axis = by_name.get(name)
        if axis is None or name not in INTERPOLATED_AXES:
            raise InputError("adaptive.log", f"numeric axes of this spec ({', '.join(numeric_names(task_axes))})", name)
        if not all(isinstance(v, (int, float)) and v > 0 for v in axis.values):
            raise InputError("adaptive.log", f"an axis of positive values (axes.{name} has one <= 0)", name)
    numeric = numeric_names(task_axes)
    if not any(len(a) >= 3 for a in task_axes if a.name in numeric):
        raise InputError(
            "adaptive",
            "a spec with a numeric task axis of 3 or more values to interpolate "
            f"({', '.join(sorted(INTERPOLATED_AXES))}); this one has none: leave [adaptive] out",
        )
    log = tuple(dict.fromkeys(log))
    log += tuple(
        name
        for name, raw_axis in raw_axes.items()
        if name in numeric and isinstance(raw_axis, dict) and "logspace" in raw_axis and name not in log
    )
    settings = Settings(default, tolerances, quantities, None, initial, log, checks, method)
    if "max_solves" in table:
        value = table["max_solves"]
        first = math.prod(len(bisection_nodes(len(a), initial)) if a.name in numeric else len(a) for a in task_axes)
        if isinstance(value, bool) or not isinstance(value, int) or value < first:
            raise InputError(
                "adaptive.max_solves",
                f"an integer >= {first} (the points of the first round, at most that many solves)",
                value,
            )
        settings = replace(settings, max_solves=value)
    return settings


def numeric_names(task_axes: Sequence[Any]) -> list[str]:
    return [a.name for a in task_axes if a.name in INTERPOLATED_AXES]
