"""Scene kinds: which validator checks a scene (the solver of each kind: ``accuracy.task_function``).

A sweep runs one kind of scene, named by its [scene] ``quantities``:

* ``contact`` (every other ``quantities``): a flat punch or a rigid sphere on one body,
  ``hpcontact.accuracy.default_solve`` checked by ``hpcontact.scene.validate``: a scene with
  ``n`` is one grid (``hpcontact.problems.contact.solve``, as ``hpcontact solve --n``); a scene without it
  gets the sweep's extrapolated default where ``accuracy.extrapolates_by_default`` holds
  (grids 16 … 256, coverage-weighted cells, stop at
  an estimate ≤ 1e-4; its record's ``estimated_error`` and the finest grid's ``nx``, ``ny`` go
  into the data set), else one grid of the engine's default n = 128;
* ``slip`` (``quantities = "slip"`` or ``["slip"]``): two bodies pressed together and loaded
  tangentially with Coulomb friction, ``hpcontact.problems.slip.partial_slip.solve_slip`` checked by
  ``hpcontact.problems.slip.partial_slip.validate``.

This module names the kinds and their validators; ``hpcontact.accuracy.task_function`` maps a
kind to its solver (the contact kind's default is an accuracy study, one floor up). The sweep's
``spec`` (validation), ``tasks`` (cost) and ``dataset`` (units) ask them.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from hpcontact.problems.slip.partial_slip import validate as validate_slip
from hpcontact.scene import INTERVAL_FIELDS
from hpcontact.scene import validate as validate_contact

CONTACT = "contact"
SLIP = "slip"

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


def validator(kind: str) -> Validator:
    """The check of one scene of ``kind``: raises ``InputError`` naming the bad field."""
    return validate_slip if kind == SLIP else validate_contact


def interval_fields(kind: str) -> Mapping[str, tuple[float, ...]]:
    """Fields whose valid values form one interval for the validator of ``kind``, with their
    branch values (``hpcontact.scene.INTERVAL_FIELDS``; none for slip scenes, whose sweeps are
    small and checked scene by scene)."""
    return {} if kind == SLIP else INTERVAL_FIELDS
