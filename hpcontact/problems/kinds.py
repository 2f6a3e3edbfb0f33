"""Scene kinds: the registry of what differs between a contact scene and a slip scene.

A sweep runs one kind of scene, named by its [scene] ``quantities``:

* ``contact`` (every other ``quantities``): a flat punch or a rigid sphere on one body,
  ``hpcontact.accuracy.default_solve`` checked by ``hpcontact.scene.validate``: a scene with
  ``n`` is one grid (``hpcontact.problems.contact.solve``, as ``hpcontact solve --n``); a scene without it
  one scene's default where its cells bound themselves (``accuracy.requested_by_default``: an
  elliptical contact's exact cell, a slender rectangle's strips), else
  the sweep's extrapolated default where ``accuracy.extrapolates_by_default`` holds
  (grids 16 … 256, coverage-weighted cells, stop at
  an estimate ≤ 1e-4; its record's ``estimated_error`` and the finest grid's ``nx``, ``ny`` go
  into the data set: an outline of any material), else one grid of the engine's default n = 128
  (a rough patch, a mask);
* ``slip`` (``quantities = "slip"`` or ``["slip"]``): two bodies pressed together and loaded
  tangentially with Coulomb friction, ``hpcontact.problems.slip.partial_slip.solve_slip`` checked by
  ``hpcontact.problems.slip.partial_slip.validate``.

Each kind is one ``Kind`` record in ``KINDS`` (``kind_of(params)`` finds a scene's): its
validator and the data that answer what the sweep asks of a kind (which record keys carry
estimated errors, whether an accuracy or an angle mode applies, whether ignored fields are
dropped, how a scene's defaults resolve; which fields leave its kernels, grids or cost alone is
``hpcontact.fields.names(kind, neutral_to=...)``). Upper floors that
need a function per kind keep a mapping keyed by ``Kind.name`` (``hpcontact.accuracy.task_function``:
the solver; the command line's units), a lookup rather than a comparison.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from hpcontact.fields import CONTACT, SLIP
from hpcontact.problems.slip.partial_slip import validate as validate_slip
from hpcontact.problems.slip.problem import GRID_MARGIN as SLIP_GRID_MARGIN
from hpcontact.quantities import ESTIMATED, SLIP_ESTIMATED
from hpcontact.scene import DEFAULTS, INTERVAL_FIELDS
from hpcontact.scene import validate as validate_contact

Validator = Callable[[Mapping[str, Any]], Any]


@dataclass(frozen=True)
class Kind:
    """One kind of scene and what the sweep needs to know of it.

    ``validate`` checks one scene (``InputError`` naming the bad field); ``interval_fields`` the
    fields whose valid values form one interval for it, with their branch values (a long axis
    of one is checked at its extreme and branch values, ``sweep.spec.scene_runs``);
    ``estimated`` matches the record keys that carry an estimated relative error
    ``<name>_error`` in the data set (``quantities.ESTIMATED`` / ``SLIP_ESTIMATED``);
    ``accuracy_refused`` says why a requested accuracy does not apply (None: it does, grids
    extrapolated by ``hpcontact.accuracy``); ``angle_mode_refused`` why ``[sweep] angle_mode``
    does not (None: it does; else ``angle`` is a scene field solved per value);
    ``reduces_fields`` whether fields the scene ignores (geometry its shape ignores, material
    fields its body ignores) are left out of its parameters, so equal scenes compare equal;
    ``memory_group`` the calibration and
    memory group of every scene of the kind (``problems.footprint.MEMORY_MODEL``; None: by the
    scene's body); ``planned`` whether ``hpcontact.plan.plan_for`` lays out its solves;
    ``grid_margin``, for a scene solved on n × n cells around its Hertz contact, the half-width
    of that grid in Hertz semi-axes (None: on its shape's contact grid, ``geometry.grid_for``);
    ``builds_body_tables`` whether its solver builds a crystal body's Barnett–Lothe tables in
    each task, so that its cost counts their ω nodes (``sweep.cost.engine.omega_nodes``) and its
    memory their ``problems.footprint.CRYSTAL_TABLES_BYTES`` (a contact scene's crystal kernels
    are costed by its calibration group instead, ``footprint.task_kind``).
    """

    name: str
    validate: Validator
    interval_fields: Mapping[str, tuple[float, ...]]
    estimated: re.Pattern[str]
    accuracy_refused: str | None
    angle_mode_refused: str | None
    reduces_fields: bool
    memory_group: str | None
    planned: bool
    grid_margin: float | None
    builds_body_tables: bool
    resolve: Callable[[Mapping[str, Any]], dict[str, Any]]

    @property
    def accuracy_applies(self) -> bool:
        """Whether a scene of this kind may ask for an accuracy (grid sequences extrapolated)."""
        return self.accuracy_refused is None


def _resolved_contact(params: Mapping[str, Any]) -> dict[str, Any]:
    """A contact scene with every default filled in: ``hpcontact.scene.DEFAULTS`` under its fields."""
    return {**DEFAULTS, **params}


def _resolved_slip(params: Mapping[str, Any]) -> dict[str, Any]:
    """A slip scene with every default filled in: the fields of its validated ``SlipScene``."""
    return dataclasses.asdict(validate_slip(params))


KINDS: Mapping[str, Kind] = {
    CONTACT: Kind(
        name=CONTACT,
        validate=validate_contact,
        interval_fields=INTERVAL_FIELDS,
        estimated=ESTIMATED,
        accuracy_refused=None,
        angle_mode_refused=None,
        reduces_fields=True,
        memory_group=None,
        planned=True,
        grid_margin=None,
        builds_body_tables=False,
        resolve=_resolved_contact,
    ),
    SLIP: Kind(
        name=SLIP,
        validate=validate_slip,
        interval_fields={},  # slip sweeps are small: checked scene by scene
        estimated=SLIP_ESTIMATED,
        accuracy_refused="a slip scene is solved on its grid, n cells across the contact",
        angle_mode_refused="angle is the load direction, solved per value",
        reduces_fields=False,
        memory_group=SLIP,
        planned=False,
        grid_margin=SLIP_GRID_MARGIN,
        builds_body_tables=True,
        resolve=_resolved_slip,
    ),
}


def quantity_names(value: Any) -> list[str]:
    """The names in a ``quantities`` field (a comma string or a list), stripped."""
    if value is None:
        return []
    items = value.split(",") if isinstance(value, str) else value if isinstance(value, (list, tuple)) else [value]
    return [str(item).strip() for item in items if str(item).strip()]


def kind_of(params: Mapping[str, Any]) -> Kind:
    """The kind of the scene (or of the fixed fields of a spec) ``params``: ``slip`` when its
    ``quantities`` name slip (the slip validator then refuses anything else beside it), else
    ``contact``."""
    return KINDS[SLIP if SLIP in quantity_names(params.get("quantities")) else CONTACT]


def scene_kind(params: Mapping[str, Any]) -> str:
    """The name of ``kind_of(params)``."""
    return kind_of(params).name


def validator(kind: str) -> Validator:
    """The check of one scene of the kind named ``kind``: raises ``InputError`` naming the bad field."""
    return KINDS[kind].validate


def interval_fields(kind: str) -> Mapping[str, tuple[float, ...]]:
    """Fields whose valid values form one interval for the validator of the kind named ``kind``,
    with their branch values (``Kind.interval_fields``)."""
    return KINDS[kind].interval_fields
