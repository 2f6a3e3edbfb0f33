"""The scene-kind registry (``hpcontact.problems.kinds``)."""

from __future__ import annotations

import pytest

from hpcontact.errors import InputError
from hpcontact.problems import kinds
from hpcontact.problems.kinds import CONTACT, KINDS, SLIP, Kind, kind_of, quantity_names, scene_kind
from hpcontact.quantities import ESTIMATED, SLIP_ESTIMATED
from hpcontact.scene import DEFAULTS, INTERVAL_FIELDS

SLIP_SCENE = {"quantities": "slip", "radius": 8e-3, "load": 10.0, "mu": 0.3, "q_ratio": 0.5, "material": "Cu"}


def test_every_kind_is_registered_under_its_name():
    assert set(KINDS) == {CONTACT, SLIP}
    for name, kind in KINDS.items():
        assert isinstance(kind, Kind) and kind.name == name


@pytest.mark.parametrize(
    ("quantities", "name"),
    [
        (None, CONTACT),
        ("tangential,normal", CONTACT),
        (["indentation"], CONTACT),
        ("slip", SLIP),
        (["slip"], SLIP),
        (" slip ", SLIP),
    ],
)
def test_the_kind_follows_the_quantities(quantities, name):
    params = {} if quantities is None else {"quantities": quantities}
    assert kind_of(params) is KINDS[name]
    assert scene_kind(params) == name


def test_quantity_names_are_stripped_and_blank_ones_dropped():
    assert quantity_names(None) == []
    assert quantity_names(" tangential , ,normal") == ["tangential", "normal"]
    assert quantity_names(("slip",)) == ["slip"]
    assert quantity_names("normal") == ["normal"]


def test_the_validators_are_the_kinds_own():
    KINDS[CONTACT].validate({"shape": "circle", "nu": 0.3})
    with pytest.raises(InputError) as caught:
        KINDS[CONTACT].validate({"shape": "circle", "nu": 0.7})
    assert caught.value.field == "nu"
    KINDS[SLIP].validate(SLIP_SCENE)
    with pytest.raises(InputError) as caught:
        KINDS[SLIP].validate({**SLIP_SCENE, "mu": -1.0})
    assert caught.value.field == "mu"
    assert kinds.validator(SLIP) is KINDS[SLIP].validate
    assert kinds.validator(CONTACT) is KINDS[CONTACT].validate


def test_only_contact_fields_are_checked_as_intervals():
    assert kinds.interval_fields(CONTACT) is INTERVAL_FIELDS
    assert kinds.interval_fields(SLIP) == {}


def test_estimated_errors_follow_the_kind():
    assert KINDS[CONTACT].estimated is ESTIMATED and KINDS[SLIP].estimated is SLIP_ESTIMATED
    assert KINDS[CONTACT].estimated.match("K_xx") and not KINDS[CONTACT].estimated.match("K_nn")
    assert KINDS[SLIP].estimated.match("tangential_stiffness") and not KINDS[SLIP].estimated.match("K_xx")


def test_accuracy_and_angle_mode_apply_to_contact_scenes_only():
    contact, slip = KINDS[CONTACT], KINDS[SLIP]
    assert contact.accuracy_applies and contact.accuracy_refused is None and contact.angle_mode_refused is None
    assert not slip.accuracy_applies
    assert "solved on its grid" in slip.accuracy_refused
    assert "load direction" in slip.angle_mode_refused


def test_what_the_sweep_reduces_and_plans():
    contact, slip = KINDS[CONTACT], KINDS[SLIP]
    assert contact.reduces_fields and not slip.reduces_fields
    assert contact.planned and not slip.planned
    assert contact.memory_group is None and slip.memory_group == SLIP


def test_a_scene_resolves_with_its_kinds_defaults():
    contact = KINDS[CONTACT].resolve({"shape": "ellipse", "aspect": 0.5})
    assert contact == {**DEFAULTS, "shape": "ellipse", "aspect": 0.5}
    slip = KINDS[SLIP].resolve(SLIP_SCENE)
    assert slip["n"] == 64 and slip["load"] == 10.0 and slip["mu"] == 0.3
