"""The one field schema (``hpcontact.fields``): the tables it replaced are its queries.

Each reference below is the literal table as the package held it before the schema (issue 38):
a derived table must equal it exactly.
"""

from __future__ import annotations

import math

import pytest

from hpcontact import fields
from hpcontact.errors import InputError
from hpcontact.fields import CONTACT, SLIP

OLD_KERNEL_NEUTRAL_FIELDS = {
    "shape",
    "sides",
    "amplitude",
    "shape_angle",
    "seed",
    "hurst",
    "rms",
    "mask",
    "tol",
    "quantities",
    "threads",
    "precondition",
    "normal_held",
}
OLD_GRID_NEUTRAL_FIELDS = {
    "nu",
    "G",
    "tol",
    "threads",
    "precondition",
    "orientation",
    "miller",
    "azimuth",
    "normal_held",
}
OLD_COST_NEUTRAL_FIELDS = {"nu", "G", "threads", "precondition", "orientation", "miller", "azimuth"}
OLD_SLIP_KERNEL_NEUTRAL_FIELDS = {
    "load",
    "mu",
    "q_ratio",
    "angle",
    "steps",
    "control",
    "displacement",
    "path",
    "coupling",
    "tensor",
    "history",
    "tol",
    "quantities",
    "threads",
    "precondition",
}
OLD_DEFAULTS = {
    "shape": "circle",
    "aspect": 1.0,
    "sides": 5,
    "shape_angle": 0.0,
    "amplitude": 0.2,
    "seed": 0,
    "hurst": 0.8,
    "rms": 0.02,
    "mask": None,
    "nu": 0.3,
    "G": 1.0,
    "anisotropy": 1.0,
    "orientation": None,
    "miller": None,
    "azimuth": 0.0,
    "material": None,
    "cubic": None,
    "orthotropic": None,
    "voigt": None,
    "n": 128,
    "n_across": None,
    "tol": 1e-8,
    "accuracy": None,
    "quantities": ("tangential",),
    "radius": None,
    "depth": None,
    "threads": 1,
    "precondition": True,
    "normal_held": "approach",
}
OLD_FLOAT_FIELDS = {
    "angle",
    "nu",
    "aspect",
    "anisotropy",
    "orientation",
    "tol",
    "accuracy",
    "G",
    "shape_angle",
    "amplitude",
    "hurst",
    "rms",
    "radius",
    "depth",
    "azimuth",
    "load",
    "mu",
    "q_ratio",
    "radius_b",
    "radius2",
    "radius2_b",
    "body2_angle",
    "E",
    "E2",
    "G2",
    "nu2",
    "displacement",
    "anisotropy2",
    "orientation2",
    "azimuth2",
}
OLD_INT_FIELDS = {"n", "n_across", "sides", "seed", "threads", "steps"}
OLD_FLAT_FIELDS = {"radius_b", "radius2", "radius2_b"}
OLD_PATH_FIELDS = {"mask"}
OLD_STRING_FIELDS = {
    "material": "a library material name (crystals: Cu, Al, Fe, ...; slip bodies: Cu, Fe, Al, rigid)",
    "material2": "a library material name of body 2 (Cu, Fe, Al, rigid)",
    "control": "force or displacement",
    "path": "load or loop",
    "coupling": "auto, both, coupled or decoupled",
    "mask": "a .npy or .png mask file; a relative path is relative to the spec's folder",
    "normal_held": "approach or load: what the tangential stiffness holds in the normal direction",
}
OLD_SHAPE_ONLY_FIELDS = {
    "aspect": {"ellipse", "rectangle"},
    "sides": {"polygon", "star"},
    "amplitude": {"star"},
    "seed": {"rough"},
    "hurst": {"rough"},
    "rms": {"rough"},
    "mask": {"mask"},
}
OLD_AXIS_ATTRS = {
    "shape": {"long_name": "contact shape"},
    "angle": {"long_name": "direction of the tangential load from the x axis", "units": "degree"},
    "nu": {"long_name": "Poisson ratio", "units": "1"},
    "aspect": {"long_name": "aspect ratio b/a of the contact", "units": "1"},
    "anisotropy": {"long_name": "cubic anisotropy factor A = 2 C44 / (C11 - C12)", "units": "1"},
    "orientation": {"long_name": "surface normal along [110] -> [111] -> [001]", "units": "degree"},
    "material": {"long_name": "library crystal (elastic constants in GPa)"},
    "normal_held": {
        "long_name": "what the tangential stiffness holds in the normal direction: approach (u_z = 0) or load (F_z = 0)"
    },
    "miller": {"long_name": "surface normal (h k l) of the crystal"},
    "azimuth": {"long_name": "in-plane turn of the crystal about the surface normal", "units": "degree"},
    "radius": {"long_name": "radius R of the rigid sphere", "units": "L"},
    "depth": {"long_name": "approach d of the rigid sphere", "units": "L"},
    "n": {"long_name": "grid cells along the long side", "units": "1"},
    "n_across": {"long_name": "grid cells across the short side", "units": "1"},
    "tol": {"long_name": "conjugate-gradient relative residual tolerance", "units": "1"},
    "accuracy": {"long_name": "requested relative accuracy of every stiffness (grid extrapolation)", "units": "1"},
    "G": {"long_name": "shear modulus G: the stress unit of the scene", "units": "1"},
    "amplitude": {"long_name": "relative lobe amplitude of the star", "units": "1"},
    "sides": {"long_name": "polygon sides or star lobes", "units": "1"},
    "shape_angle": {"long_name": "rotation of the shape on the grid", "units": "degree"},
    "seed": {"long_name": "random seed of the rough surface", "units": "1"},
    "hurst": {"long_name": "Hurst exponent of the rough surface", "units": "1"},
    "rms": {"long_name": "rms height of the rough surface", "units": "a"},
    "mask": {"long_name": "contact mask image (path)"},
    "threads": {"long_name": "FFTW threads per solve", "units": "1"},
    "quantities": {"long_name": "quantities solved for"},
}
#: The coordinate entries of the old ``dataset.SLIP_ATTRS`` that are fields (not ``pair``),
#: and the kind-neutral ones a slip data set took from the contact table (tol, threads, quantities).
OLD_SLIP_COORDINATE_ATTRS = {
    "mu": ("friction coefficient", "1"),
    "q_ratio": ("tangential load at the end of the path Q/(mu P)", "1"),
    "angle": ("direction of the tangential load from x", "degree"),
    "radius": ("radius of curvature of body 1", "L"),
    "radius_b": ("second principal radius of curvature of body 1", "L"),
    "radius2": ("radius of curvature of body 2 (inf: flat)", "L"),
    "radius2_b": ("second principal radius of curvature of body 2", "L"),
    "body2_angle": ("angle between the principal axes of the bodies", "degree"),
    "material": ("material of body 1 (hpcontact.problems.slip.bodies library, or crystal:NAME)", ""),
    "material2": ("material of body 2 (hpcontact.problems.slip.bodies library, or crystal:NAME)", ""),
    "orthotropic": ("orthotropic engineering constants of body 1", ""),
    "orthotropic2": ("orthotropic engineering constants of body 2", ""),
    "orientation": ("surface normal of the crystal along [110] -> [111] -> [001]", "degree"),
    "azimuth": ("in-plane turn of the crystal about the surface normal", "degree"),
    "miller": ("surface normal (h k l) of the crystal", ""),
    "E": ("Young's modulus of body 1", "F L-2"),
    "G": ("shear modulus of body 1", "F L-2"),
    "nu": ("Poisson ratio of body 1", "1"),
    "E2": ("Young's modulus of body 2", "F L-2"),
    "G2": ("shear modulus of body 2", "F L-2"),
    "nu2": ("Poisson ratio of body 2", "1"),
    "displacement": ("final tangential displacement (displacement control)", "L"),
    "n": ("grid cells across the contact's major diameter", "1"),
    "steps": ("tangential load steps", "1"),
    "control": ("tangential load control: force or displacement", ""),
    "path": ("tangential loading path: load, or loop (load, unload, reload)", ""),
    "coupling": ("coupling of the normal and tangential problems: auto, both, coupled or decoupled", ""),
    "load": ("normal load P", "F"),
    "tol": ("conjugate-gradient relative residual tolerance", "1"),
    "threads": ("FFTW threads per solve", "1"),
    "quantities": ("quantities solved for", ""),
}
OLD_SLIP_VALIDATOR_FIELDS = (
    "quantities radius radius_b radius2 radius2_b body2_angle material material2 E G nu E2 G2 nu2 load mu q_ratio "
    "angle n tol steps control displacement path tensor history coupling threads precondition normal_friction "
    "anisotropy cubic orthotropic voigt orientation miller azimuth "
    "anisotropy2 cubic2 orthotropic2 voigt2 orientation2 miller2 azimuth2"
).split()


#: Fields added after the schema replaced the tables above, with what each changes in a task: the
#: contact size (issue 38's field added end to end) no kernel, grid or cost, only the unit of a
#: record; the device (issue 41) the cost alone (its results agree with the CPU's to round-off).
NEW_FIELDS = {"a": set(), "device": {"cost"}}
#: Their defaults: a contact size is optional; solves run on the CPU unless asked otherwise.
NEW_DEFAULTS = {"a": None, "device": "cpu"}


def _old(names) -> set[str]:
    return set(names) - set(NEW_FIELDS)


#: The keywords of ``hpcontact.solve`` by their annotation, as its explicit signature had them
#: before the schema gave them (issue 38).
OLD_SOLVE_ANNOTATIONS = {
    "str | None": "shape material device normal_held material2 control path coupling",
    "float | None": "aspect shape_angle amplitude hurst rms nu G anisotropy orientation azimuth tol radius depth a "
    "accuracy body2_angle E E2 G2 nu2 load mu q_ratio angle displacement anisotropy2 orientation2 azimuth2",
    "int | None": "sides seed n n_across threads steps",
    "str | os.PathLike[str] | None": "mask",
    "str | Sequence[int] | None": "miller miller2",
    "str | Mapping[str, float] | Sequence[float] | None": "cubic orthotropic cubic2 orthotropic2",
    "str | Sequence[float] | Sequence[Sequence[float]] | None": "voigt voigt2",
    "str | Sequence[str] | None": "quantities",
    "bool | None": "precondition tensor history normal_friction",
    "str | int | None": "memory",
    "float | str | None": "radius_b radius2 radius2_b",
}
#: The axes a spec could name, as ``sweep.space.axes.AXIS_NAMES`` listed them by hand (issue 38).
OLD_AXIS_NAMES = (
    "shape angle nu aspect anisotropy orientation material n tol accuracy pair load mu q_ratio orientation2 "
    "anisotropy2 normal_held"
).split()


def test_solve_keywords_are_typed_as_the_old_explicit_signature():
    old = {name: annotation for annotation, names in OLD_SOLVE_ANNOTATIONS.items() for name in names.split()}
    assert {name: fields.python_annotation(name) for name in old} == old
    assert set(old) == set(fields.names(CONTACT)) | set(fields.names(SLIP)) | {"memory"}


def test_axes_are_the_old_ones_and_fields():
    from hpcontact.sweep.space.axes import AXIS_NAMES

    assert sorted(AXIS_NAMES) == sorted(OLD_AXIS_NAMES)
    assert set(fields.axis_names()) <= set(fields.names()), "an axis that is no field"


def test_task_neutral_tables_are_the_old_ones():
    assert _old(fields.names(CONTACT, neutral_to="kernel")) == OLD_KERNEL_NEUTRAL_FIELDS
    assert _old(fields.names(CONTACT, neutral_to="grid")) == OLD_GRID_NEUTRAL_FIELDS
    assert _old(fields.names(CONTACT, neutral_to="cost")) == OLD_COST_NEUTRAL_FIELDS
    assert set(fields.names(SLIP, neutral_to="kernel")) - {"device"} == OLD_SLIP_KERNEL_NEUTRAL_FIELDS
    assert "device" in fields.names(SLIP, neutral_to="kernel")
    for name, changes in NEW_FIELDS.items():
        for effect in ("kernel", "grid", "cost"):
            assert (name in fields.names(CONTACT, neutral_to=effect)) == (effect not in changes), (name, effect)


def test_contact_defaults_are_the_old_ones_in_their_order():
    old = {k: v for k, v in fields.defaults(CONTACT).items() if k not in NEW_FIELDS}
    assert old == OLD_DEFAULTS
    assert list(old) == list(OLD_DEFAULTS)
    assert _old(fields.names(CONTACT)) == set(OLD_DEFAULTS)
    assert {name: fields.defaults(CONTACT)[name] for name in NEW_FIELDS} == NEW_DEFAULTS


def test_spec_type_tables_are_the_old_ones():
    assert fields.of_type(float) - set(NEW_FIELDS) == OLD_FLOAT_FIELDS
    assert fields.of_type(int) == OLD_INT_FIELDS
    assert fields.flat_fields() == OLD_FLAT_FIELDS
    assert fields.path_fields() == OLD_PATH_FIELDS
    assert {k: v for k, v in fields.string_texts().items() if k not in NEW_FIELDS} == OLD_STRING_FIELDS
    assert fields.string_texts()["device"] == "cpu, gpu or auto: where the solves run"
    shape_only = {name: set(readers) for name, (_, readers, why) in fields.read_by("shape").items() if why is None}
    assert shape_only == OLD_SHAPE_ONLY_FIELDS


def test_coordinate_attributes_are_the_old_ones():
    contact = fields.axis_attrs(CONTACT)
    assert {k: v for k, v in contact.items() if k not in NEW_FIELDS} == OLD_AXIS_ATTRS
    assert contact["a"] == {"long_name": "semi-major extent a of the contact", "units": "m"}
    slip = {name: (a["long_name"], a.get("units", "")) for name, a in fields.axis_attrs(SLIP).items()}
    assert {k: v for k, v in slip.items() if k != "device"} == OLD_SLIP_COORDINATE_ATTRS
    assert slip["device"] == (fields.field("device").long_name, "")


def test_a_slip_data_sets_coordinates_are_described_by_their_fields():
    """Every slip field's coordinate attributes come from its declaration (``device`` too), the
    units in the spec's force and length units or in SI where it names library materials."""
    from pathlib import Path

    from hpcontact.sweep.data.attributes import attribute_table
    from hpcontact.sweep.space.parse import parse_spec

    job = Path(__file__).resolve().parents[1] / "jobs" / "sphere_pairs.toml"
    table = attribute_table(parse_spec(job.read_text(), path=job, validate=lambda params: None))
    declared = fields.axis_attrs(SLIP)
    assert "device" in declared
    for name, attrs in declared.items():
        assert table[name]["long_name"] == attrs["long_name"], name
        assert ("units" in table[name]) == ("units" in attrs), name


def test_lower_layers_word_a_bad_value_as_its_field_does():
    """The shape, the grid, the crystal, the pair and the accuracy loop check their own inputs
    with the message their field declares (one text, whichever layer refuses the value)."""
    from hpcontact.accuracy import solve_to_accuracy
    from hpcontact.geometry import Shape, grid_for
    from hpcontact.materials.elastic_constants import anisotropic_material
    from hpcontact.materials.isotropic import Isotropic
    from hpcontact.problems.slip.bodies import Body, Pair
    from hpcontact.scene import Scene

    cases = [
        (lambda: Shape("star", amplitude=1.5), "amplitude", fields.field("amplitude").message),
        (lambda: Shape("rough", hurst=1.0), "hurst", fields.field("hurst").message),
        (lambda: Shape("circle", angle_deg=math.inf), "shape_angle", fields.field("shape_angle").message),
        (lambda: grid_for(Shape("circle"), 1), "n", fields.field("n").message),
        (lambda: grid_for(Shape("circle"), 8, 0), "n_across", fields.field("n_across").message),
        (lambda: anisotropic_material({"anisotropy": 200.0}), "anisotropy", fields.field("anisotropy").message),
        (lambda: anisotropic_material({"anisotropy": 2.0, "orientation": math.nan}), "orientation", None),
        (lambda: anisotropic_material({"anisotropy": 2.0, "orientation": 95.0}), "orientation", None),
        (lambda: anisotropic_material({"anisotropy": 2.0, "azimuth": math.inf}), "azimuth", None),
        (lambda: Pair(Body.sphere(Isotropic(1.0, 0.3), 1.0), Body.flat(None)).hertz(-1.0), "load", None),
        (lambda: Body(None, 1.0, 1.0, math.nan), "angle", None),
    ]
    for make, name, message in cases:
        with pytest.raises(InputError) as info:
            make()
        assert info.value.field == name
        assert info.value.allowed == (
            message or fields.field(name, SLIP if name in ("load", "angle") else CONTACT).message
        ), name
    with pytest.raises(InputError) as info:
        solve_to_accuracy(Scene.from_params({"shape": "circle", "nu": 0.3}), 2.0)
    assert (info.value.field, info.value.allowed) == ("accuracy", fields.ACCURACY_RANGE)


def test_slip_fields_are_the_slip_validators():
    assert set(fields.names(SLIP)) - {"device"} == set(OLD_SLIP_VALIDATOR_FIELDS)
    assert "device" in fields.names(SLIP)


def test_shapes_are_the_geometrys():
    from hpcontact.geometry import SHAPES

    assert fields.SHAPES == SHAPES


def test_range_messages_are_the_materials():
    from hpcontact.materials import isotropic

    assert isotropic.NU_RANGE == fields.field("nu").message
    assert isotropic.modulus_range("shear modulus") == fields.field("G").message


def test_a_slip_variant_differs_only_where_declared():
    contact, slip = fields.field("n"), fields.field("n", SLIP)
    assert (contact.default, slip.default) == (128, 64)
    assert slip.check(8) == 8 and contact.check(2) == 2
    with pytest.raises(InputError, match=r"n = 4: an integer in \[8, 4096\]"):
        slip.check(4)
    assert slip.help == contact.help and slip.kinds == contact.kinds


@pytest.mark.parametrize(
    ("name", "good", "bad"),
    [
        ("nu", (0.5, -0.999), (-1.0, 0.51, math.nan, "x", True)),
        ("aspect", (1e-12, 1.0), (1e-13, 1.5, math.inf)),
        ("tol", (1e-14, 1e-2), (1e-15, 0.1)),
        ("accuracy", (1e-9, 0.999), (1.0, 1e-10)),
        ("anisotropy", (0.01, 100.0), (0.0, 101.0)),
        ("n", (2, 4096.0), (1, 2.5, "a")),
        ("seed", (0,), (-1,)),
    ],
)
def test_check_is_the_interval_with_its_one_message(name, good, bad):
    f = fields.field(name)
    for value in good:
        assert f.check(value) == value
    for value in bad:
        with pytest.raises(InputError) as caught:
            f.check(value)
        assert caught.value.field == name and caught.value.allowed == f.message


def test_cli_help_fills_default_range_and_choices():
    assert fields.cli_help("nu") == "Poisson ratio in (-1, 0.5]; < 0.5 for a crystal (A != 1) (default: 0.3)"
    assert fields.cli_help("shape").startswith("circle, ellipse, rectangle") and "(default: circle)" in fields.cli_help(
        "shape"
    )
    assert fields.cli_help("quantities").endswith("(default: tangential)")
    assert fields.cli_help("n").endswith("else 128)")
    assert "{" not in "".join(fields.cli_help(f.name) for f in fields.cli_fields())


def test_every_field_is_declared_once_with_a_kind_or_as_a_solve_option():
    all_names = [f.name for f in fields.FIELDS]
    assert len(all_names) == len(set(all_names))
    assert [f.name for f in fields.FIELDS if not f.kinds] == ["memory"]
    assert all(set(f.changes) <= set(fields.EFFECTS) for f in fields.FIELDS)
