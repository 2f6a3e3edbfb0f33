"""Scene kinds of a sweep: which function solves a task and which validator checks a scene.

A sweep runs one kind of scene, named by its [scene] ``quantities``:

* ``contact`` (every other ``quantities``): a flat punch or a rigid sphere on one body,
  ``hpcontact.accuracy.default_solve`` checked by ``hpcontact.scene.validate``: a scene with
  ``n`` is one grid (``hpcontact.solve.solve``, as ``hpcontact solve --n``); a scene without it
  gets the extrapolated default of ``hpcontact solve`` without ``--n`` where
  ``accuracy.extrapolates_by_default`` holds (grids 16 … 256, coverage-weighted cells, stop at
  an estimate ≤ 1e-4; its record's ``estimated_error`` and the finest grid's ``nx``, ``ny`` go
  into the data set), else one grid of the engine's default n = 128;
* ``slip`` (``quantities = "slip"`` or ``["slip"]``): two bodies pressed together and loaded
  tangentially with Coulomb friction, ``hpcontact.slip.solve_slip`` checked by
  ``hpcontact.slip.validate``.

This module is the one place that maps a kind to its functions; ``spec`` (validation),
``driver`` (the task function), ``tasks`` (cost) and ``dataset`` (units) ask it.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

CONTACT = "contact"
SLIP = "slip"

TaskFunction = Callable[[Mapping[str, Any]], Mapping[str, Any]]
Validator = Callable[[Mapping[str, Any]], Any]


def quantity_names(value: Any) -> list[str]:
    """The names in a ``quantities`` field (a comma string or a list), stripped."""
    if value is None:
        return []
    items = value.split(",") if isinstance(value, str) else value if isinstance(value, (list, tuple)) else [value]
    return [str(item).strip() for item in items if str(item).strip()]


def scene_kind(params: Mapping[str, Any]) -> str:
    """The kind of the scene (or of the fixed fields of a spec) ``params``: ``slip`` when its
    ``quantities`` name slip (the slip validator then refuses anything else beside it), else
    ``contact``."""
    return SLIP if SLIP in quantity_names(params.get("quantities")) else CONTACT


def task_function(kind: str) -> TaskFunction:
    """The function that solves one scene of ``kind``: parameters → record."""
    if kind == SLIP:
        from ..slip import solve_slip

        return solve_slip
    from ..accuracy import default_solve

    return default_solve


def validator(kind: str) -> Validator:
    """The check of one scene of ``kind``: raises ``InputError`` naming the bad field."""
    if kind == SLIP:
        from ..slip import validate

        return validate
    from ..scene import validate

    return validate
