"""Scene validation (hpcontact.scene.Scene.from_params): defaults, ranges, NaN/inf, unknown fields.

Every refusal must be an InputError whose ``field`` names the bad field and whose message is one
line holding the field name (the command line prints it as is, docs/design.md §4.1 "Errors").
"""

from __future__ import annotations

import math

import pytest

from hpcontact.errors import InputError
from hpcontact.scene import DEFAULTS, QUANTITIES, Scene, validate

pytestmark = pytest.mark.filterwarnings("error")

NAN, INF = float("nan"), float("inf")


def _refused(params: dict) -> InputError:
    with pytest.raises(InputError) as info:
        Scene.from_params(params)
    err = info.value
    assert "\n" not in str(err)
    assert str(err).startswith(err.field)
    return err


def test_defaults():
    s = Scene.from_params({})
    assert s.shape.name == DEFAULTS["shape"] == "circle"
    assert s.material.nu == 0.3 and s.material.G == 1.0
    assert s.quantities == ("tangential",)
    assert s.n == 128 and s.n_across is None and s.tol == 1e-8
    assert s.radius is None and s.depth is None


def test_fields_are_converted_and_kept():
    s = Scene.from_params(
        {
            "shape": "ellipse",
            "aspect": "0.25",
            "nu": 0,
            "n": 64.0,
            "n_across": 9,
            "shape_angle": 30,
            "quantities": "normal, tangential,normal",
            "G": 2e9,
            "tol": 1e-10,
        }
    )
    assert s.shape.name == "ellipse" and s.shape.aspect == 0.25 and s.shape.angle_deg == 30.0
    assert s.n == 64 and isinstance(s.n, int) and s.n_across == 9
    assert s.material.nu == 0.0 and s.material.G == 2e9
    assert s.quantities == ("normal", "tangential")  # stripped, de-duplicated, order kept
    assert s.tol == 1e-10
    # None means "not given": the default applies
    assert Scene.from_params({"nu": None}).material.nu == 0.3


def test_indentation_fields():
    s = Scene.from_params({"quantities": ["indentation"], "radius": 10.0, "depth": 0.01})
    assert s.radius == 10.0 and s.depth == 0.01


@pytest.mark.parametrize(
    "params, field",
    [
        ({"colour": "red"}, "colour"),
        ({"nu": 0.6}, "nu"),
        ({"nu": -1.0}, "nu"),
        ({"nu": -1.5}, "nu"),
        ({"nu": 0.5000001}, "nu"),
        ({"nu": "soft"}, "nu"),
        ({"G": 0.0}, "G"),
        ({"G": -1.0}, "G"),
        ({"anisotropy": 0.0}, "anisotropy"),
        ({"anisotropy": 2.0, "nu": 0.5}, "nu"),
        ({"miller": "0 0 0", "anisotropy": 2.0}, "miller"),
        ({"orientation": 95.0, "anisotropy": 2.0}, "orientation"),
        ({"material": "Unobtainium"}, "material"),
        ({"aspect": 0.0}, "aspect"),
        ({"aspect": -0.5}, "aspect"),
        ({"aspect": 1.0000001}, "aspect"),
        ({"n": 1}, "n"),
        ({"n": 0}, "n"),
        ({"n": 2.5}, "n"),
        ({"n": 10_000, "n_across": 10_000}, "n"),
        ({"n_across": 0}, "n_across"),
        ({"tol": 0.0}, "tol"),
        ({"tol": 0.1}, "tol"),
        ({"tol": 1e-16}, "tol"),
        ({"quantities": ""}, "quantities"),
        ({"quantities": []}, "quantities"),
        ({"quantities": "tangential,stiffness"}, "quantities"),
        ({"quantities": "indentation"}, "radius"),
        ({"quantities": "indentation", "radius": 1.0}, "depth"),
        ({"quantities": "indentation", "depth": 0.1}, "radius"),
        ({"quantities": "indentation", "radius": -1.0, "depth": 0.1}, "radius"),
        ({"quantities": "indentation", "radius": 1.0, "depth": 0.0}, "depth"),
        ({"quantities": "indentation", "radius": 1.0, "depth": 1.0}, "depth"),
        ({"shape": "blob"}, "shape"),
        ({"shape": "polygon", "sides": 2}, "sides"),
        ({"shape": "polygon", "sides": 4.5}, "sides"),
        ({"shape": "star", "amplitude": 1.0}, "amplitude"),
        ({"shape": "rough", "hurst": 0.0}, "hurst"),
        ({"shape": "rough", "rms": 2.0}, "rms"),
        ({"shape": "mask"}, "mask"),
        ({"seed": -1}, "seed"),
        ({"threads": 0}, "threads"),
        ({"accuracy": 0.0}, "accuracy"),
        ({"accuracy": 1.0}, "accuracy"),
        ({"accuracy": 1e-10}, "accuracy"),
        ({"accuracy": 1e-4, "shape": "rough"}, "accuracy"),
        ({"accuracy": 1e-4, "quantities": "compliance"}, "accuracy"),
    ],
)
def test_refuses_out_of_range(params, field):
    assert _refused(params).field == field


NUMERIC_FIELDS = [
    "nu",
    "G",
    "anisotropy",
    "aspect",
    "n",
    "n_across",
    "tol",
    "shape_angle",
    "amplitude",
    "seed",
    "hurst",
    "rms",
    "sides",
    "threads",
]


@pytest.mark.parametrize("value", [NAN, INF, -INF])
@pytest.mark.parametrize("field", NUMERIC_FIELDS)
def test_refuses_non_finite(field, value):
    assert _refused({field: value}).field == field


@pytest.mark.parametrize("value", [NAN, INF])
@pytest.mark.parametrize("field", ["radius", "depth"])
def test_refuses_non_finite_indentation_fields(field, value):
    params = {"quantities": "indentation", "radius": 1.0, "depth": 0.1, field: value}
    assert _refused(params).field == field


@pytest.mark.parametrize("field", ["radius", "depth"])
def test_refuses_non_finite_radius_depth_on_any_scene(field):
    assert _refused({"quantities": "tangential", field: NAN}).field == field


def test_every_quantity_is_accepted():
    for quantity in QUANTITIES:
        extra = {"radius": 2.0, "depth": 0.1} if quantity == "indentation" else {}
        assert Scene.from_params({"quantities": quantity, **extra}).quantities == (quantity,)


def test_boundary_values_accepted():
    assert Scene.from_params({"nu": 0.5}).material.nu == 0.5
    assert Scene.from_params({"nu": -0.999}).material.nu == -0.999
    assert Scene.from_params({"aspect": 1.0, "shape": "ellipse"}).shape.aspect == 1.0
    assert Scene.from_params({"aspect": 1e-8, "shape": "rectangle"}).shape.aspect == 1e-8
    assert Scene.from_params({"n": 2}).n == 2
    assert Scene.from_params({"tol": 1e-14}).tol == 1e-14
    assert Scene.from_params({"tol": 1e-2}).tol == 1e-2


def test_validate_raises_like_from_params():
    validate({"nu": 0.2})
    with pytest.raises(InputError) as info:
        validate({"nu": math.nan})
    assert info.value.field == "nu"


def test_a_crystal_is_built_once_per_distinct_material():
    # a sweep validates every scene; its crystals repeat across shapes and b/a (rotating one ~1 ms)
    crystal = {"shape": "ellipse", "nu": 0.3, "anisotropy": 2.0, "orientation": 20.0}
    first = Scene.from_params({**crystal, "aspect": 0.5}).material
    assert Scene.from_params({**crystal, "aspect": 0.25, "n": 32}).material is first
    assert Scene.from_params({**crystal, "orientation": 21.0}).material != first
    Scene.from_params({"nu": 0.3, "anisotropy": 1})
    with pytest.raises(InputError) as info:  # True == 1 must not hit the cached A = 1 body
        Scene.from_params({"nu": 0.3, "anisotropy": True})
    assert info.value.field == "anisotropy"


@pytest.mark.parametrize("value", ["force", "Load", " load", "", "approach,load", 1, True, ["load"]])
def test_normal_held_is_approach_or_load(value):
    """Issue 26 item 4: what ``tangential`` holds in the normal direction, exactly one of the
    two names (a typo or another case is refused, never guessed); default approach; accepted
    with any quantities (only ``tangential`` reads it)."""
    err = _refused({"normal_held": value})
    assert err.field == "normal_held" and err.allowed == "one of approach, load"
    assert Scene.from_params({}).normal_held == "approach" == DEFAULTS["normal_held"]
    assert Scene.from_params({"normal_held": None}).normal_held == "approach"
    assert Scene.from_params({"normal_held": "load", "quantities": "normal"}).normal_held == "load"
