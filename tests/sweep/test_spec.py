"""Job specs: parsing, generated axes, and refusal of bad specs naming the key."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.sweep.spec import load_spec, parse_spec


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
    ],
)
def test_bad_specs_are_refused_naming_the_key(text, key):
    assert refused(text).field == key


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
