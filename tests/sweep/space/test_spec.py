"""Job specs: parsing, generated axes, and refusal of bad specs naming the key."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.scene import canonical_json
from hpcontact.sweep.space import enumeration
from hpcontact.sweep.space.parse import load_spec, parse_spec


def accept(params):
    """A validator that accepts every scene."""


def parse(text: str, **kwargs):
    return parse_spec(text, path="job.toml", validate=kwargs.pop("validate", accept), **kwargs)


def refused(text: str, **kwargs) -> InputError:
    with pytest.raises(InputError) as info:
        parse(text, **kwargs)
    return info.value


def test_full_spec_is_parsed():
    spec = parse(
        """
        [sweep]
        title = "t"
        output = "results/x.nc"
        [scene]
        quantities = ["tangential", "normal"]
        G = 2
        [numerics]
        n = 32
        tol = 1e-9
        [axes]
        shape = ["ellipse", { label = "hexagon", shape = "polygon", sides = 6 }]
        aspect = { logspace = [0, -8, 9] }
        nu = [0, 0.25, 0.5]
        angle = { linspace = [0, 180, 7] }
        """
    )
    assert spec.title == "t"
    assert spec.output == Path("results/x.nc")
    assert spec.journal == Path("results/x.nc.journal")
    assert spec.fixed == {"quantities": ["tangential", "normal"], "G": 2.0, "n": 32, "tol": 1e-9}
    assert [a.name for a in spec.axes] == ["shape", "aspect", "nu", "angle"]
    assert [a.name for a in spec.task_axes] == ["shape", "aspect", "nu"]  # tensor mode: angle is free
    assert spec.axis("shape").values == ("ellipse", "hexagon")
    aspect = np.array(spec.axis("aspect").values)
    assert aspect.dtype == np.float64 and aspect[0] == 1.0 and aspect[-1] == 1e-8
    np.testing.assert_allclose(aspect, 10.0 ** -np.arange(9.0), rtol=1e-15)
    assert spec.axis("nu").values == (0.0, 0.25, 0.5)
    assert spec.axis("angle").values == tuple(np.linspace(0.0, 180.0, 7))


def test_scene_params_merge_fixed_axes_and_shape_tables():
    spec = parse(
        """
        [scene]
        nu = 0.3
        [axes]
        shape = ["circle", "ellipse", { label = "thin", shape = "rectangle", aspect = 0.01 }]
        aspect = [1, 0.5]
        """
    )
    # circle ignores aspect: left out, so both aspect points are one scene
    assert spec.scene_params((0, 1)) == {"nu": 0.3, "shape": "circle"}
    assert spec.scene_params((1, 1)) == {"nu": 0.3, "shape": "ellipse", "aspect": 0.5}
    assert spec.scene_params((2, 0)) == {"nu": 0.3, "shape": "rectangle", "aspect": 0.01}  # table wins


def test_rotated_mode_turns_the_shape_by_minus_angle():
    spec = parse(
        """
        [sweep]
        angle_mode = "rotated"
        [scene]
        shape = "star"
        shape_angle = 10
        [axes]
        angle = [0, 30]
        """
    )
    assert [a.name for a in spec.task_axes] == ["angle"]
    assert spec.scene_params((1,))["shape_angle"] == -20.0


def test_output_override_and_journal():
    spec = parse('[sweep]\noutput = "a.nc"\njournal = "j"\n', output="b/c.nc")
    assert spec.output == Path("b/c.nc") and spec.journal == Path("j")
    assert parse("").output == Path("job.nc")


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ("[bogus]\nx = 1\n", "bogus"),
        ("[sweep]\nspeed = 1\n", "sweep.speed"),
        ("[scene]\nn = 64\n", "scene.n"),
        ("[numerics]\ncells = 64\n", "numerics.cells"),
        ("[axes]\ncolour = [1, 2]\n", "axes.colour"),
        ("[axes]\nnu = []\n", "axes.nu"),
        ("[axes]\nnu = { linspace = [0, 0.5, 0] }\n", "axes.nu.linspace"),
        ("[axes]\nnu = { linspace = [0, 0.5] }\n", "axes.nu.linspace"),
        ("[axes]\nnu = { arange = [0, 0.5, 0.1] }\n", "axes.nu"),
        ("[axes]\nnu = 0.3\n", "axes.nu"),
        ("[axes]\nnu = [0.1, 0.1]\n", "axes.nu"),
        ('[axes]\nnu = [0.1, "x"]\n', "axes.nu"),
        ("[axes]\nnu = [0.1, nan]\n", "axes.nu"),
        ("[axes]\nn = [16, 24.5]\n", "axes.n"),
        ("[scene]\nnu = 0.3\n[axes]\nnu = [0.1]\n", "axes.nu"),
        ("[numerics]\nn = 16\n[axes]\nn = [32]\n", "axes.n"),
        ('[sweep]\nangle_mode = "rotated"\n', "sweep.angle_mode"),
        ('[sweep]\nangle_mode = "spin"\n', "sweep.angle_mode"),
        ("[sweep]\nprogress_interval = 0\n", "sweep.progress_interval"),
        ('[sweep]\noutput = "x.h5"\n', "sweep.output"),
        ('[axes]\nshape = [{ shape = "polygon" }]\n', "axes.shape[0].label"),
        ('[axes]\nshape = [{ label = "p" }]\n', "axes.shape[0].shape"),
        ('[axes]\nshape = ["circle", 3]\n', "axes.shape[1]"),
        ('[axes]\nshape = ["circle", "circle"]\n', "axes.shape"),
        ("x = = 1\n", "spec"),
        ("[numerics]\naccuracy = 1e-4\nn = 64\n", "numerics.accuracy"),
        ("[numerics]\naccuracy = 1e-4\n[axes]\nn = [32, 64]\n", "numerics.accuracy"),
        ("[numerics]\naccuracy = 1e-4\nn_across = 8\n", "numerics.accuracy"),
        ('[numerics]\naccuracy = "fine"\n', "numerics.accuracy"),
        ('[scene]\nquantities = "slip"\n[numerics]\naccuracy = 1e-4\n', "numerics.accuracy"),
    ],
)
def test_bad_specs_are_refused_naming_the_key(text, key):
    assert refused(text).field == key


def test_a_scene_field_under_axes_that_no_axis_runs_over_says_where_it_goes():
    """A field with no axis (``fields``: ``axis`` False) is refused naming the table it goes in,
    and, where labelled entries carry it, how: a shape's field per entry of axes.shape (taken up
    as the message says, the spec parses), a slip scene's per entry of axes.pair; a key that is
    no field at all stays "unknown"."""
    sides = refused('[scene]\nshape = "polygon"\n[axes]\nsides = [3, 4]\n')
    assert sides.field == "axes.sides" and sides.allowed == (
        'not a sweep axis: fix it in [scene] or per entry of axes.shape ({ label = "...", shape = "polygon", sides = ... })'
    )
    spec = parse(
        '[axes]\nshape = [{ label = "triangle", shape = "polygon", sides = 3 }, { label = "square", shape = "polygon", sides = 4 }]\n'
    )
    assert [a.name for a in spec.axes] == ["shape"]
    assert refused("[axes]\nn_across = [8, 16]\n").allowed == "not a sweep axis: fix it in [numerics]"
    assert refused("[axes]\nthreads = [1, 2]\n").allowed == "not a sweep axis: fix it in [scene]"
    assert refused("[axes]\nradius2 = [1.0, 2.0]\n").allowed.endswith(
        'per entry of axes.pair ({ label = "...", radius2 = ... })'
    )
    assert refused("[axes]\nsidez = [3]\n").allowed.startswith("unknown key; allowed: shape, aspect")


def test_impossible_values_are_refused_by_the_scene_validator_with_the_spec_key():
    text = """
    [scene]
    G = 1
    [numerics]
    n = 16
    [axes]
    shape = ["circle", { label = "tri", shape = "polygon", sides = 3 }]
    nu = [0.1, %s]
    """
    parse(text % "0.5", validate=None)  # the engine's validator accepts nu = 0.5
    assert refused(text % "0.7", validate=None).field == "axes.nu"
    assert refused(text.replace("sides = 3", "sides = 1") % "0.5", validate=None).field == "axes.shape[1].sides"
    assert refused(text.replace("G = 1", "G = -1") % "0.5", validate=None).field == "scene.G"
    assert refused(text.replace("n = 16", "n = 1") % "0.5", validate=None).field == "numerics.n"
    assert refused(text.replace("G = 1", "colour = 1") % "0.5", validate=None).field == "scene.colour"


def test_every_distinct_scene_is_validated_once():
    seen = []
    parse(
        """
        [axes]
        shape = ["circle", "ellipse"]
        aspect = [1, 0.1, 0.01]
        nu = [0.1, 0.2]
        """,
        validate=seen.append,
    )
    assert len(seen) == 2 * (1 + 3)  # the circle is one scene per nu, the ellipse three


def test_load_spec_reads_a_file_and_refuses_a_missing_one(tmp_path):
    path = tmp_path / "job.toml"
    path.write_text("[axes]\nnu = [0.1]\n")
    spec = load_spec(path, validate=accept)
    assert spec.text == path.read_text() and spec.path == path
    with pytest.raises(InputError) as info:
        load_spec(tmp_path / "missing.toml", validate=accept)
    assert info.value.field == "spec"


@pytest.mark.parametrize("constants", ["cubic = [168.4, 121.4, 75.4]", 'material = "Cu"', "anisotropy = 2.0"])
def test_an_anisotropic_body_keeps_its_orientation_axis(constants):
    # A body given by elastic constants has A = 1 by default; its orientation must still make
    # distinct scenes (it was dropped as if the body were isotropic: one scene for every psi).
    spec = parse(f"[scene]\n{constants}\n[axes]\norientation = [0.0, 90.0]\n", validate=None)
    scenes = [spec.scene_params(index) for index in spec.points()]
    assert [s["orientation"] for s in scenes] == [0.0, 90.0]
    assert all("nu" not in s and "G" not in s for s in scenes) or constants.startswith("anisotropy")


def test_an_isotropic_body_drops_its_orientation():
    spec = parse("[scene]\nnu = 0.3\n[axes]\norientation = [0.0, 90.0]\n", validate=None)
    assert [spec.scene_params(index) for index in spec.points()] == [{"nu": 0.3}, {"nu": 0.3}]


# ------------------------------------------------------------------------------------------
# a long axis checked at its extreme values (scene_runs): the error of a scene-by-scene check
# ------------------------------------------------------------------------------------------
def _values(values) -> str:
    return "[" + ", ".join(repr(v) for v in values) + "]"


LONG = enumeration.SCENE_CHECK_POINTS // 4  # the tests below check ranges of more than LONG // 2 as intervals
NU_WITH_MINUS_ONE = [0.1 + 0.3 * i / LONG for i in range(LONG)]
NU_WITH_MINUS_ONE[1234] = -1.0
LONG_AXES = [
    # ([scene] or [numerics] fields, the long axis): bad values first, in the middle, last, at both ends
    ('[scene]\nshape = "ellipse"\naspect = 0.5', f"nu = {{ linspace = [-0.2, 0.7, {LONG}] }}"),
    ('[scene]\nshape = "ellipse"\naspect = 0.5', f"nu = {{ linspace = [0.7, -0.2, {LONG}] }}"),
    ('[scene]\nshape = "ellipse"\naspect = 0.5', f"nu = {_values(NU_WITH_MINUS_ONE)}"),
    ('[scene]\nshape = "ellipse"', f"aspect = {{ logspace = [2, -14, {LONG}] }}"),
    ('[scene]\nshape = "circle"', f"aspect = {{ logspace = [0, -3, {LONG}] }}"),  # ignored: one scene
    ("[scene]\nnu = 0.3", f"aspect = {{ logspace = [0, -3, {LONG}] }}"),  # no shape: a circle, b/a != 1 refused
    ("[scene]\nanisotropy = 2.0", f"nu = {{ linspace = [0.3, 0.5, {LONG}] }}"),  # a cubic crystal: nu < 0.5
    ("[scene]\nanisotropy = 2.0", f"orientation = {{ linspace = [-10, 100, {LONG}] }}"),
    ("[scene]\nnu = 0.5", f"anisotropy = {{ linspace = [1.0, 3.0, {LONG}] }}"),  # A = 1 isotropic: valid
    ("[scene]\nnu = 0.5", f"anisotropy = {{ linspace = [0.5, 1.5, {LONG + 1}] }}"),  # A = 1 in the middle
    ("[scene]\nnu = 0.3", f"anisotropy = {{ logspace = [-3, 3, {LONG}] }}"),
    ('[scene]\nshape = "ellipse"\naspect = 0.5', f"tol = {{ logspace = [-16, 0, {LONG}] }}"),
    ('[scene]\nshape = "ellipse"\naspect = 0.5', f"tol = {{ logspace = [-13, -3, {LONG}] }}"),  # all valid
    ("[numerics]\nn_across = 40000", f"n = {_values(range(2, LONG + 2))}"),  # n x n_across > 2**26 from 1678
    ("[numerics]\ntol = 1e-8", f"n = {_values(range(1, LONG + 1))}"),
]


@pytest.fixture
def interval_checks(monkeypatch):
    """Ranges of more than LONG // 2 points checked run by run at their extreme values."""
    monkeypatch.setattr(enumeration, "SCENE_CHECK_POINTS", LONG // 2)


EXPECTED = [
    "axes.nu", "axes.nu", "axes.nu", "axes.aspect", "ok", "axes.aspect", "axes.nu", "axes.orientation",
    "scene.nu", "scene.nu", "axes.anisotropy", "axes.tol", "ok", "axes.n", "axes.n",
]  # fmt: skip


@pytest.mark.parametrize(("fixed", "axis", "expected"), [(*case, e) for case, e in zip(LONG_AXES, EXPECTED)])
def test_a_long_axis_checked_at_its_ends_refuses_the_first_bad_point_as_a_scene_by_scene_check(
    fixed, axis, expected, monkeypatch, interval_checks
):
    """The kind's validator sees a long run at its extreme values (a bisection when one is
    refused); another validator (the same checks in a lambda) sees every scene: the same
    outcome, the same error naming the same key and value, at far fewer validations."""
    from hpcontact.scene import Scene
    from hpcontact.scene import validate as contact_validate

    text = f"{fixed}\n[axes]\n{axis}\n"
    calls = []
    build = Scene.from_params.__func__
    monkeypatch.setattr(Scene, "from_params", classmethod(lambda cls, p: calls.append(1) or build(cls, p)))
    fast = _outcome(lambda: parse_spec(text, path="job.toml"))
    checked = len(calls)
    one_by_one = _outcome(lambda: parse_spec(text, path="job.toml", validate=lambda p: contact_validate(p)))
    assert fast == one_by_one and fast[0] == expected
    assert checked < 40  # the scenes validated (from_params calls): a few, not one per point of the run


def _outcome(parse) -> tuple:
    """(field, allowed, value) of the InputError ``parse`` raises, or the points it checked."""
    try:
        spec = parse()
    except InputError as exc:
        return exc.field, exc.allowed, exc.value
    return ("ok", math.prod(len(a) for a in spec.task_axes))


def test_a_rotated_rough_shape_refuses_its_first_turned_point(interval_checks):
    from hpcontact.scene import validate as contact_validate

    text = f'[sweep]\nangle_mode = "rotated"\n[scene]\nshape = "rough"\n[axes]\nangle = {{ linspace = [0, 180, {LONG}] }}\n'
    fast, one_by_one = (
        _outcome(lambda v=v: parse_spec(text, path="job.toml", validate=v)) for v in (None, contact_validate)
    )
    assert fast == one_by_one and fast[0] == "axes.angle"  # angle 0 leaves the shape as it is: the next is bad


def test_a_label_table_that_sets_the_axis_field_is_one_scene_checked_once(interval_checks):
    text = (
        "[axes]\n"
        'shape = ["ellipse", { label = "bad", shape = "rectangle", aspect = 1e-13 }]\n'
        f"aspect = {{ logspace = [0, -3, {LONG}] }}\n"
    )
    assert refused(text, validate=None).field == "axes.shape[1].aspect"


def test_runs_give_the_scenes_of_the_points_one_by_one():
    """``scene_texts`` (runs expanded) against ``Spec.scene_params`` point by point, on specs with
    label tables, a table overriding the axis' field, A = 1 in a run, the rotated angle, ranges."""
    texts = [
        '[scene]\nnu = 0.3\n[axes]\nshape = ["circle", "ellipse", { label = "thin", shape = "rectangle", aspect = 0.01 }]\n'
        "aspect = { logspace = [0, -2, 41] }\n",
        '[axes]\nshape = ["ellipse", { label = "tri", shape = "polygon", sides = 3 }]\nnu = [0.0, 0.45]\n'
        "angle = { linspace = [0, 180, 7] }\norientation = [0.0, 20.0, 90.0]\nanisotropy = [0.5, 1.0, 2.0]\n",
        '[scene]\nmaterial = "Cu"\n[axes]\nshape = ["circle", "ellipse"]\norientation = { linspace = [0, 90, 30] }\n',
        '[sweep]\nangle_mode = "rotated"\n[axes]\nshape = [{ label = "a", shape = "ellipse", aspect = 0.5, shape_angle = 10 },'
        ' { label = "b", shape = "ellipse", aspect = 0.5, shape_angle = 20 }]\nangle = [-0.0, 10, 20, 1e-300]\n',
        "[axes]\nnu = [0.1, 0.2]\n",
        '[scene]\nshape = "ellipse"\n',
    ]
    for text in texts:
        spec = parse(text, validate=None)
        want = [(i, spec.scene_params(i)) for i in spec.points()]
        n = len(want)
        for start, stop in ((0, n), (1, n - 1), (n // 3, n // 3 + 5), (n - 1, n)):
            got = list(enumeration.scene_texts(spec, start=start, stop=stop))
            assert [(i, p, list(p)) for i, p, _ in got] == [(i, p, list(p)) for i, p in want[start:stop]]
            assert [t for _, _, t in got] == [canonical_json(p) for _, p in want[start:stop]]


@pytest.mark.parametrize("where", [[0], [1], [999], [1500], [LONG - 1], [700, 30], [5, LONG - 2]])
def test_bad_values_anywhere_on_a_long_axis_are_found_first_in_point_order(where, interval_checks):
    from hpcontact.scene import validate as contact_validate

    nu = [0.05 + 0.4 * i / LONG for i in range(LONG)]
    aspect = [10.0 ** (-3.0 * i / LONG) for i in range(LONG)]
    for k, at in enumerate(where):
        nu[at], aspect[at] = (0.6, 2.0) if k % 2 == 0 else (-1.5, 1e-13)
    for axis in (f"nu = {_values(nu)}", f"aspect = {_values(aspect)}"):
        text = f'[scene]\nshape = "rectangle"\n[numerics]\nn = 16\n[axes]\n{axis}\n'
        fast = _outcome(lambda: parse_spec(text, path="job.toml"))
        assert fast == _outcome(lambda: parse_spec(text, path="job.toml", validate=lambda p: contact_validate(p)))
        assert fast[2] == float(axis.split("[", 1)[1].split(", ")[min(where)].rstrip("]"))


@pytest.mark.parametrize(("isotropic", "top"), [(0, 0.5), (17, 0.5), (0, 0.49), (59, 0.5)])
def test_short_runs_of_many_contexts_are_checked_at_their_ends_too(isotropic, top, monkeypatch, interval_checks):
    """Two axes (60 A × 50 nu up to ``top``): every run of the last axis checked at its ends.
    nu = 0.5 is refused for a crystal (A != 1) only: with A = 1 first, the first bad point is
    in the second run, found as a check of every scene finds it."""
    from hpcontact.scene import Scene
    from hpcontact.scene import validate as contact_validate

    anisotropy = [1.5 + 0.01 * k for k in range(60)]
    anisotropy[isotropic] = 1.0
    text = f"[axes]\nanisotropy = {_values(anisotropy)}\nnu = {{ linspace = [0.3, {top}, 50] }}\n"
    monkeypatch.setattr(enumeration, "SCENE_CHECK_POINTS", 100)
    calls = []
    build = Scene.from_params.__func__
    monkeypatch.setattr(Scene, "from_params", classmethod(lambda cls, p: calls.append(1) or build(cls, p)))
    fast = _outcome(lambda: parse_spec(text, path="job.toml"))
    checked = len(calls)
    assert fast == _outcome(lambda: parse_spec(text, path="job.toml", validate=lambda p: contact_validate(p)))
    assert (fast[0] == "ok") == (top < 0.5) and checked <= 60 * 12  # a few per run of 50, not 50


@pytest.mark.parametrize("top", [0.45, 0.55])
def test_a_ranks_share_of_a_large_spec_is_checked_as_the_whole_spec_is(monkeypatch, top):
    """A share of a large spec smaller than ``SCENE_CHECK_POINTS`` (a rank's, on many ranks) is
    checked run by run at the runs' ends as the whole spec is, not scene by scene (which cost
    each of 16 ranks 5-8 CPU s on the 4-D map), and finds the same first bad point as a check of
    every scene of that share."""
    from hpcontact.scene import Scene
    from hpcontact.scene import validate as contact_validate
    from hpcontact.sweep.work.tasks import enumerate_part

    text = f"[scene]\nanisotropy = 1.5\n[axes]\norientation = [0.0, 10.0, 20.0, 30.0]\nnu = {{ linspace = [0.3, {top}, 50] }}\n"
    spec = parse_spec(text, path="job.toml", check_scenes=False)
    monkeypatch.setattr(enumeration, "SCENE_CHECK_POINTS", 150)  # the spec's 200 points are many
    calls = []
    build = Scene.from_params.__func__
    monkeypatch.setattr(Scene, "from_params", classmethod(lambda cls, p: calls.append(1) or build(cls, p)))

    def outcome(validate=None) -> tuple:
        try:
            return ("ok", len(enumerate_part(spec, 50, 150, validate, check=True).task_of))
        except InputError as exc:
            return exc.field, exc.allowed, exc.value

    fast = outcome()  # a share of 100 points: two runs of 50
    checked = len(calls)
    every = outcome(lambda p: contact_validate(p))
    assert fast == every and (fast[0] == "ok") == (top < 0.5)
    assert checked <= 2 * 12 < 100  # a few per run of 50, not every scene


def test_a_small_spec_is_checked_scene_by_scene(monkeypatch):
    from hpcontact.scene import Scene

    calls = []
    build = Scene.from_params.__func__
    monkeypatch.setattr(Scene, "from_params", classmethod(lambda cls, p: calls.append(1) or build(cls, p)))
    text = '[scene]\nshape = "circle"\n[axes]\nnu = { linspace = [0, 0.5, 300] }\naspect = [1.0, 0.5]\n'
    parse_spec(text, path="job.toml")
    assert len(calls) == 300  # every distinct scene: the circle ignores b/a


def test_an_accuracy_is_a_numerical_setting_of_every_scene():
    spec = parse("[numerics]\naccuracy = 1e-4\n[axes]\nnu = [0.1, 0.3]\n", validate=None)
    assert [spec.scene_params((i,))["accuracy"] for i in range(2)] == [1e-4, 1e-4]
    assert refused("[numerics]\naccuracy = 2.0\n[axes]\nnu = [0.1]\n", validate=None).field == "numerics.accuracy"
    swept = parse("[axes]\naccuracy = [1e-3, 1e-4]\n", validate=None)  # what each accuracy costs
    assert [swept.scene_params((i,))["accuracy"] for i in range(2)] == [1e-3, 1e-4]


def test_the_command_line_accuracy_replaces_the_spec_grid_and_accuracy():
    text = "[numerics]\nn = 64\nn_across = 8\ntol = 1e-10\n[axes]\nnu = [0.1]\n"
    spec = parse_spec(text, accuracy=1e-3)
    assert spec.fixed == {"tol": 1e-10, "accuracy": 1e-3}
    for bad in (0.0, 1.5, float("nan")):
        with pytest.raises(InputError) as info:
            parse_spec(text, accuracy=bad)
        assert info.value.field == "--accuracy"
    with pytest.raises(InputError) as info:
        parse_spec("[axes]\nn = [32, 64]\n", accuracy=1e-3)
    assert info.value.field == "--accuracy" and "axes.n" in str(info.value)


def test_a_spec_without_an_output_writes_beside_its_file_not_in_the_working_folder():
    """Issue 42 item 6 (``spec.default_output``): a spec file's default output is beside it."""
    from hpcontact.sweep.space.spec import default_output

    assert default_output("jobs/acc.toml", "acc", "") == Path("jobs/acc.nc")
    assert default_output("/data/specs/acc.toml", "acc", "") == Path("/data/specs/acc.nc")
    assert default_output("acc.toml", "acc", "") == Path("acc.nc")  # a spec in the working folder: there


def test_a_dict_spec_gets_a_title_from_its_axes_and_an_output_of_its_own():
    """Issue 42 item 6: a dict spec without a title is named by its axes (not ``<dict>``); without
    an output it writes in ``results/``, a file per spec (its text's hash), the same for the same
    spec (a resume finds its journals)."""
    from hpcontact.sweep.space.spec import DICT_OUTPUT_FOLDER, DICT_SPEC_PATH, default_output, default_title

    axes = parse('[scene]\nshape = "ellipse"\n[axes]\naspect = [0.5, 1]\nnu = [0, 0.25, 0.5]\n').axes
    title = default_title(DICT_SPEC_PATH, axes)
    assert title == "sweep over aspect × nu (2 × 3 points)"
    assert default_title(DICT_SPEC_PATH, ()) == "one scene" and default_title("jobs/acc.toml", axes) == "acc"
    first, again, other = (default_output(DICT_SPEC_PATH, title, text) for text in ("a = 1", "a = 1", "a = 2"))
    assert first == again != other and first.parent == DICT_OUTPUT_FOLDER
    assert first.name.startswith("sweep-over-aspect-nu-2-3-points-") and first.suffix == ".nc"
