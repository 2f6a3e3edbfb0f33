"""Scene validation (hpcontact.scene.Scene.from_params): defaults, ranges, NaN/inf, unknown fields.

Every refusal must be an InputError whose ``field`` names the bad field and whose message is one
line holding the field name (the command line prints it as is, docs/design.md §4.1 "Errors").
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.materials.crystal import CRYSTAL_NU_RANGE, Crystal, cubic_from_nu_A
from hpcontact.materials.crystal import isotropic as isotropic_stiffness
from hpcontact.materials.elastic_constants import anisotropic_material
from hpcontact.materials.isotropic import NU_RANGE, Isotropic
from hpcontact.scene import DEFAULTS, QUANTITIES, Scene, validate
from hpcontact.sweep.space.parse import load_spec, parse_spec

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


# ------------------------------------------------------------------------------------------
# a field the scene would not use is refused (issue 42 item 1): one table, one message
# ------------------------------------------------------------------------------------------
CU = {"material": "Cu", "n": 16}
CUBIC = {"cubic": "C11=168.4 C12=121.4 C44=75.4", "n": 16}
ORTHOTROPIC = {"orthotropic": "E1=25 E2=1 E3=1 G12=0.5 G13=0.5 G23=0.2 nu12=0.25 nu13=0.25 nu23=0.25"}
VOIGT = {"voigt": " ".join(str(float(v)) for v in np.diag([2.0, 2.0, 2.0, 0.5, 0.5, 0.5]).ravel())}  # A = 0.5


@pytest.mark.parametrize(
    "body, setting",
    [(CU, "material"), (CUBIC, "cubic"), (ORTHOTROPIC, "orthotropic"), (VOIGT, "voigt")],
    ids=["material", "cubic", "orthotropic", "voigt"],
)
@pytest.mark.parametrize(
    "field, value, why",
    [
        ("nu", 0.1, "the Poisson ratio"),
        ("nu", 0.3, "the Poisson ratio"),  # the default value too: given is given
        ("nu", 0.7, "the Poisson ratio"),  # out of range, but unused first
        ("G", 2.0, "the moduli, in GPa"),
        ("G", 1.0, "the moduli, in GPa"),
        ("anisotropy", 3.0, "the anisotropy"),
        ("anisotropy", 1.0, "the anisotropy"),
    ],
)
def test_a_body_given_by_its_constants_refuses_nu_G_and_A(body, setting, field, value, why):
    err = _refused({**body, field: value})
    shown = body[setting]
    assert err.field == field and err.value == value
    assert str(err) == (
        f"{field} = {value!r}: not used with {setting} = {shown!r} (its elastic constants fix {why}); leave {field} out"
    )


def test_the_issue_42_command_lines_are_refused_with_one_message():
    assert str(_refused({"material": "Cu", "nu": 0.1, "n": 32})) == (
        "nu = 0.1: not used with material = 'Cu' (its elastic constants fix the Poisson ratio); leave nu out"
    )
    assert str(_refused({"material": "Cu", "anisotropy": 3})) == (
        "anisotropy = 3: not used with material = 'Cu' (its elastic constants fix the anisotropy); leave anisotropy out"
    )
    # the first unused field of the table is named (nu before G before anisotropy)
    assert _refused({"material": "Cu", "anisotropy": 3.0, "G": 2.0, "nu": 0.2}).field == "nu"
    # two descriptions of the body: a conflict, not an unused field
    assert _refused({"material": "Cu", **CUBIC}).field == "material"


def test_what_a_named_crystal_or_constants_read_is_still_accepted():
    plain = Scene.from_params(CU).material
    assert plain == Scene.from_params({**CU, "nu": None, "G": None, "anisotropy": None}).material  # None: not given
    turned = {
        "orientation": 20.0,
        "miller": "1 1 0",
        "azimuth": 30.0,
        "shape_angle": 15.0,
    }
    for name, value in turned.items():  # the orientation fields and the shape's turn act on every crystal
        assert Scene.from_params({**CU, name: value}).material != plain, name
        for body in (CUBIC, ORTHOTROPIC, VOIGT):
            base = Scene.from_params(body).material
            assert Scene.from_params({**body, name: value}).material != base, (name, body)
    assert Scene.from_params({**CU, "orientation": 20.0, "azimuth": 30.0}).material.name == "Cu"


def test_nu_G_and_A_still_describe_the_body_without_constants():
    assert Scene.from_params({"nu": 0.1}).material == Isotropic(G=1.0, nu=0.1)
    assert Scene.from_params({"nu": 0.1, "G": 2.0, "anisotropy": 1.0}).material == Isotropic(G=2.0, nu=0.1)
    crystal = Scene.from_params({"nu": 0.2, "anisotropy": 3.0, "orientation": 20.0}).material
    assert isinstance(crystal, Crystal) and crystal != Scene.from_params({"nu": 0.2, "anisotropy": 3.0}).material
    # orientation of an isotropic body: accepted (a sweep over A that contains 1 gives it to every scene)
    assert Scene.from_params({"anisotropy": 1.0, "orientation": 20.0}).material == Isotropic(G=1.0, nu=0.3)
    assert Scene.from_params({"orientation": 20.0, "miller": None}).material == Isotropic(G=1.0, nu=0.3)


@pytest.mark.parametrize(
    "params, message",
    [
        (
            {"shape": "circle", "sides": 6},
            "sides = 6: not used with shape = 'circle' (only polygon or star read it); leave sides out",
        ),
        (
            {"shape": "ellipse", "amplitude": 0.3},
            "amplitude = 0.3: not used with shape = 'ellipse' (only star reads it); leave amplitude out",
        ),
        (
            {"shape": "polygon", "aspect": 0.5},
            "aspect = 0.5: not used with shape = 'polygon' (only ellipse or rectangle read it); leave aspect out",
        ),
        (
            {"shape": "rough", "shape_angle": 30.0},
            "shape_angle = 30.0: not used with shape = 'rough' (a mask or a rough patch is not turned); "
            "leave shape_angle out",
        ),
        (
            {"quantities": "tangential,normal", "radius": 2.0},
            "radius = 2.0: not used with quantities = 'tangential,normal' (only indentation reads it); leave radius out",
        ),
        (
            {"depth": 0.1},
            "depth = 0.1: not used with quantities = 'tangential' (only indentation reads it); leave depth out",
        ),
    ],
)
def test_shape_and_indentation_fields_are_refused_in_the_same_message(params, message):
    assert str(_refused(params)) == message


def test_a_shape_field_at_its_default_changes_nothing_and_is_accepted():
    # a loop over shapes may pass aspect = 1 (or sides = 5, shape_angle = 0) to each
    for shape in ("circle", "polygon", "star"):
        assert Scene.from_params({"shape": shape, "aspect": 1.0}).shape.name == shape
    assert Scene.from_params({"shape": "circle", "sides": 5, "amplitude": 0.2}).shape.name == "circle"
    assert Scene.from_params({"shape": "rough", "shape_angle": 0}).shape.angle_deg == 0.0
    assert Scene.from_params({"shape": "rough", "shape_angle": -0.0}).shape.name == "rough"
    assert _refused({"shape": "rough", "shape_angle": "x"}).field == "shape_angle"  # not a number: not 0


# ------------------------------------------------------------------------------------------
# the Poisson ratio's range, stated once for an isotropic body and once for a crystal
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("nu", [-1.0, -1.5, 0.5000001, 0.7, NAN, "soft"])
def test_an_isotropic_nu_out_of_range_names_the_half_open_range(nu):
    err = _refused({"nu": nu})
    assert err.field == "nu" and err.allowed == NU_RANGE == "Poisson ratio in (-1, 0.5]"
    with pytest.raises(InputError) as info:
        Isotropic(G=1.0, nu=-1.0 if isinstance(nu, str) else nu)
    assert info.value.allowed == NU_RANGE


def test_a_crystal_nu_range_is_open_at_one_half():
    assert CRYSTAL_NU_RANGE.startswith("Poisson ratio in (-1, 0.5) ")
    assert _refused({"nu": 0.5, "anisotropy": 2.0}).allowed == CRYSTAL_NU_RANGE
    assert _refused({"nu": -1.0, "anisotropy": 2.0}).allowed == NU_RANGE  # the isotropic check comes first
    for build in (lambda: cubic_from_nu_A(0.5, 2.0), lambda: isotropic_stiffness(1.0, 0.5)):
        with pytest.raises(InputError) as info:
            build()
        assert info.value.field == "nu" and info.value.allowed == CRYSTAL_NU_RANGE
    with pytest.raises(InputError) as info:  # a slip body from (nu, A): the same text
        anisotropic_material({"anisotropy2": 2.0, "nu2": 0.5}, "2")
    assert info.value.field == "nu2" and info.value.allowed == CRYSTAL_NU_RANGE
    assert Scene.from_params({"nu": 0.5}).material.nu == 0.5  # A = 1: the isotropic body takes 0.5


def test_the_slip_bodies_refuse_nu_beside_constants_in_the_same_message():
    with pytest.raises(InputError) as info:
        anisotropic_material({"material2": "crystal:Ni", "nu2": 0.2}, "2", library=False)
    assert str(info.value) == (
        "nu2 = 0.2: not used with material2 = 'crystal:Ni' (its elastic constants fix the Poisson ratio); leave nu2 out"
    )
    with pytest.raises(InputError) as info:
        anisotropic_material({**CUBIC, "E": 2.0}, "")
    assert info.value.field == "E" and "not used with cubic" in str(info.value)


# ------------------------------------------------------------------------------------------
# sweeps: the same refusal, located in the spec; the shipped jobs still pass
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "text, key, field",
    [
        ('[scene]\nmaterial = "Cu"\n[axes]\nnu = [0.1, 0.3]\n', "axes.nu", "nu"),
        ('[scene]\nnu = 0.3\n[axes]\nmaterial = ["Cu", "W"]\n', "scene.nu", "nu"),
        ('[axes]\nmaterial = ["Cu", "W"]\nanisotropy = [1.0, 2.0]\n', "axes.anisotropy", "anisotropy"),
        ('[scene]\ncubic = "C11=168 C12=121 C44=75"\nG = 2.0\n[axes]\norientation = [0.0, 90.0]\n', "scene.G", "G"),
        (
            '[axes]\nshape = ["ellipse", { label = "Cu disk", shape = "circle", material = "Cu" }]\nnu = [0.1, 0.3]\n',
            "axes.nu",
            "nu",
        ),
    ],
)
def test_a_spec_combining_a_named_body_with_nu_G_or_A_is_refused(text, key, field):
    with pytest.raises(InputError) as info:
        parse_spec(text + "[numerics]\nn = 16\n", path="job.toml")
    assert info.value.field == key and "\n" not in str(info.value)
    assert "not used with" in info.value.allowed and info.value.allowed.endswith(f"leave {field} out")


def test_sweeps_whose_fields_apply_to_some_points_only_are_accepted():
    accepted = [
        '[axes]\nmaterial = ["Cu", "W"]\norientation = [0.0, 90.0]\n',  # orientation turns every crystal
        "[scene]\nnu = 0.3\n[axes]\nanisotropy = [1.0, 2.0]\norientation = [0.0, 90.0]\n",  # A = 1 ignores it
        '[axes]\nshape = ["circle", "ellipse"]\naspect = [1.0, 0.5]\n',  # a circle ignores b/a
        '[axes]\nshape = ["ellipse", { label = "Cu disk", shape = "circle", material = "Cu" }]\naspect = [0.5]\n',
    ]
    for text in accepted:
        spec = parse_spec(text + "[numerics]\nn = 16\n", path="job.toml")
        assert len(list(spec.points())) >= 2


def test_every_shipped_job_passes_the_scene_validation(tmp_path):
    jobs = sorted((Path(__file__).resolve().parents[1] / "jobs").glob("*.toml"))
    assert len(jobs) >= 10
    for path in jobs:
        assert load_spec(path, output=tmp_path / f"{path.stem}.nc").axes, path.name


def test_contact_size_in_metres_needs_a_modulus_with_a_unit():
    """``a`` (metres) turns the record's unit G·a into N/m: a × G for G in Pa, a × 1e9 for a body
    in GPa; without a modulus in a unit, or beside an indentation, it is refused."""
    assert Scene.from_params({"shape": "circle", "a": 2e-3, "G": 26e9}).newtons_per_metre == 2e-3
    assert Scene.from_params({"shape": "circle", "a": 2e-3, "material": "Cu"}).newtons_per_metre == 2e-3 * 1e9
    assert Scene.from_params({"shape": "circle", "G": 26e9}).newtons_per_metre is None
    with pytest.raises(InputError, match="G in Pa"):
        Scene.from_params({"shape": "circle", "a": 2e-3})
    with pytest.raises(InputError, match=r"in \[1e-12, 1e3\]"):
        Scene.from_params({"shape": "circle", "a": 0.0, "G": 1.0})
    with pytest.raises(InputError, match="not used with quantities"):
        Scene.from_params(
            {"shape": "circle", "a": 1e-3, "G": 1.0, "quantities": "indentation", "radius": 1.0, "depth": 0.01}
        )


def test_a_scene_is_a_value_keyed_by_its_fields():
    """``Scene.key`` is the canonical JSON of the fields (any order, floats to the last bit);
    ``Scene.from_key`` builds the same scene from it, once per key, and refuses a bad one as
    ``from_params`` does."""
    fields = {"shape": "ellipse", "aspect": 0.1 + 0.2, "nu": 0.25, "quantities": ["tangential", "normal"]}
    scene = Scene.from_params(fields)
    assert scene.key() == Scene.from_params(dict(reversed(list(fields.items())))).key()
    assert (
        scene.key() == '{"aspect":0.30000000000000004,"nu":0.25,"quantities":["tangential","normal"],"shape":"ellipse"}'
    )
    again = Scene.from_key(scene.key())
    assert again == scene and again.key() == scene.key() and again.shape.aspect == 0.1 + 0.2
    assert Scene.from_key(scene.key()) is again
    assert Scene.from_params({**fields, "nu": 0.3}).key() != scene.key()
    with pytest.raises(InputError, match="nu"):
        Scene.from_key('{"nu":0.7,"shape":"circle"}')
