"""Command line contract (docs/design.md §4.1): `hpcontact solve --json` and its error reporting.

* One JSON object on stdout with the keys that apply to the quantities asked, and a `plan`
  object listing the kernels built and the solves run.
* Bad input: exit status 2 and ONE line on stderr naming the bad field (nothing on stdout).

The physics of the numbers is tested elsewhere (test_solve, test_solvers); here the values are
checked only for consistency with the contract (finite, symmetric where the plan derives them).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from hpcontact import analytic
from hpcontact.cli import EXAMPLES, main

pytestmark = pytest.mark.filterwarnings("error")

SMALL = ["--n", "16"]
TANGENTIAL_KEYS = {"K_xx", "K_xy", "K_yx", "K_yy", "K_max", "K_min", "principal_angle_deg", "K_a_over_K_b"}
COMMON_KEYS = {"iterations", "residual", "wall_time_s", "nx", "ny", "dx", "dy", "plan"}
COUPLING_KEYS = {"K_xz", "K_yz", "K_zx", "K_zy"}
INDENTATION_KEYS = {"load", "contact_area", "ellipse_b_over_a", "ellipse_angle_deg"}


def _run(capsys, *args) -> tuple[int, str, str]:
    code = main(["solve", *args])
    out, err = capsys.readouterr()
    return code, out, err


def _json(capsys, *args) -> dict:
    code, out, err = _run(capsys, *args, "--json")
    assert code == 0, err
    assert err == ""
    lines = out.strip().splitlines()
    assert len(lines) == 1  # one JSON object, one line
    record = json.loads(lines[0])
    assert isinstance(record, dict)
    for key, value in record.items():
        if isinstance(value, float):
            assert math.isfinite(value), key
    plan = record["plan"]
    assert isinstance(plan, dict)
    assert isinstance(plan["kernels"], list) and isinstance(plan["solves"], list)
    assert all(isinstance(k, str) for k in plan["kernels"])
    return record


def test_tangential_keys(capsys):
    r = _json(capsys, "--shape", "ellipse", "--aspect", "0.5", "--nu", "0.3", *SMALL)
    assert TANGENTIAL_KEYS | COMMON_KEYS <= set(r)
    assert not ({"K_zz", "normalized_xx"} | COUPLING_KEYS | INDENTATION_KEYS) & set(r)
    assert r["plan"]["kernels"] == ["xx", "xy", "yx", "yy"]
    assert r["plan"]["solves"] == ["tangential_x[xy]", "tangential_y[xy]"]
    assert isinstance(r["nx"], int) and isinstance(r["iterations"], int)
    assert r["nx"] == 16 and r["dx"] == pytest.approx(2.0 / 16)
    assert r["K_a_over_K_b"] == pytest.approx(r["K_xx"] / r["K_yy"], rel=1e-15)
    assert r["K_max"] >= r["K_min"] > 0
    assert 0.0 <= r["principal_angle_deg"] < 180.0
    assert r["wall_time_s"] > 0.0 and r["residual"] <= 1e-8  # default tol


def test_normal_and_tangential_keys(capsys):
    r = _json(capsys, "--quantities", "tangential,normal", "--nu", "0.25", *SMALL)
    assert TANGENTIAL_KEYS | COMMON_KEYS | {"K_zz", "normalized_xx", "normalized_yy"} <= set(r)
    # Li's normalization, recomputed from the record: K E*/(K_zz G*), E* = 2G/(1−ν), G* = 4G/(2−ν)
    nu = 0.25
    expected = r["K_xx"] * (2 / (1 - nu)) / (r["K_zz"] * (4 / (2 - nu)))
    assert r["normalized_xx"] == pytest.approx(expected, rel=1e-14)
    assert set(r["plan"]["kernels"]) == {"xx", "xy", "yx", "yy", "zz"}


def test_coupled_keys(capsys):
    r = _json(capsys, "--quantities", "coupled", "--shape", "ellipse", "--aspect", "0.5", *SMALL)
    assert TANGENTIAL_KEYS | COUPLING_KEYS | COMMON_KEYS | {"K_zz"} <= set(r)
    assert all(s.endswith("[xyz]") for s in r["plan"]["solves"])


def test_compliance_keys(capsys):
    r = _json(capsys, "--quantities", "compliance", *SMALL)
    assert {"proxy_K_xx", "proxy_K_xy", "proxy_K_yx", "proxy_K_yy"} | COMMON_KEYS <= set(r)
    assert r["plan"]["solves"] == [] and r["iterations"] == 0


def test_indentation_keys(capsys):
    r = _json(capsys, "--quantities", "indentation", "--radius", "1", "--depth", "0.01", *SMALL)
    assert INDENTATION_KEYS | COMMON_KEYS <= set(r)
    assert r["plan"]["kernels"] == ["zz"]
    # a sphere on a grid symmetric under x <-> y: the pressure moments are equal, b/a = 1 to
    # round-off (measured 1 − 1.1e-16)
    assert r["ellipse_b_over_a"] == pytest.approx(1.0, abs=4e-16)


def test_mask_file(capsys, tmp_path):
    mask = np.zeros((9, 6), dtype=bool)
    mask[1:8, 1:5] = True
    path = tmp_path / "m.npy"
    np.save(path, mask)
    r = _json(capsys, "--shape", "mask", "--mask", str(path))
    assert (r["nx"], r["ny"]) == (7, 4)  # cropped to the support
    assert r["dx"] == r["dy"] == 2.0 / 7  # unit a: half the contact's long side (7 cells), not the array's
    assert r["length_unit"].startswith("a = half the long side of the contact")


def test_plain_text_output(capsys):
    code, out, err = _run(capsys, *SMALL)
    assert code == 0 and err == ""
    assert "K_xx" in out and "plan.kernels" in out
    with pytest.raises(json.JSONDecodeError):
        json.loads(out)


def test_the_first_help_example_meets_its_accuracy(capsys):
    """Issue 42 item 2: the first example of ``hpcontact --help`` ("to about 1e-4") ended with
    accuracy_met False, stopped_by grids, 1.66e-4 and exit 0. Without --n it is solved as
    --accuracy 1e-4: the ellipse's one exact cell, Mindlin's closed form to round-off."""
    line = EXAMPLES.split("examples:\n", 1)[1].splitlines()[0].split()
    assert line[:2] == ["hpcontact", "solve"] and "--n" not in line and "--accuracy" not in line
    args = line[2 : line.index("one")]  # the command, before its description
    assert args == ["--shape", "ellipse", "--aspect", "0.3", "--nu", "0.3"]
    r = _json(capsys, *args)  # exit 0, nothing on stderr
    assert r["accuracy_met"] and r["stopped_by"] == "met" and r["accuracy"] == 1e-4 and r["boundary"] == "galin"
    K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, 0.3, 1.0, 0.3)
    assert r["estimated_error"] <= 1e-10
    assert abs(r["K_xx"] / K_a - 1.0) <= 1e-12 and abs(r["K_yy"] / K_b - 1.0) <= 1e-12
    code, out, err = _run(capsys, *args)
    assert code == 0 and err == "" and "accuracy_met  True" in out


def test_levels_only_with_verbose_or_json(capsys):
    """The per-grid ``levels`` (a list of dicts) are not printed in plain text: with --verbose one
    line per grid, in --json always; the plain text shows no raw Python dict or list."""
    args = ("--shape", "rectangle", "--aspect", "0.5", "--accuracy", "1e-3")
    record = _json(capsys, *args)
    assert len(record["levels"]) == len(record["grids"]) >= 4 and isinstance(record["levels"][0], dict)
    code, plain, err = _run(capsys, *args)
    assert code == 0 and err == ""
    keys = [line.split()[0] for line in plain.splitlines()]
    assert not any(k.startswith("levels") for k in keys) and "K_xx" in keys and "estimated_error" in keys
    assert "{'" not in plain and "[{" not in plain and "[16" not in plain
    assert f"grids  {', '.join(map(str, record['grids']))}\n" in plain
    code, verbose, err = _run(capsys, *args, "--verbose")
    assert code == 0 and err == ""
    lines = [line.split(None, 1) for line in verbose.splitlines()]
    levels = [rest for key, rest in lines if key.startswith("levels")]
    named = [key for key, _ in lines if key.startswith("levels")]
    assert named == [f"levels[{i}]" for i in range(len(record["grids"]))]
    assert all(rest.startswith("K_xx ") and "iterations" in rest for rest in levels)
    assert "{'" not in verbose
    assert [key for key, _ in lines if not key.startswith("levels")] == keys  # the rest as in plain text


def test_no_precondition_same_answer(capsys):
    a = _json(capsys, "--shape", "ellipse", "--aspect", "0.5", "--tol", "1e-12", *SMALL)
    b = _json(capsys, "--shape", "ellipse", "--aspect", "0.5", "--tol", "1e-12", "--no-precondition", *SMALL)
    # both to CG tol 1e-12 (cond ~ √N ≈ 15): 1e-10 relative
    for key in ("K_xx", "K_yy"):
        assert a[key] == pytest.approx(b[key], rel=1e-10)


def test_subprocess_solve_json():
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "hpcontact.cli",
            "solve",
            "--shape",
            "ellipse",
            "--aspect",
            "0.4",
            "--n",
            "12",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert len(lines) == 1
    record = json.loads(lines[0])
    assert TANGENTIAL_KEYS | COMMON_KEYS <= set(record)
    assert record["K_a_over_K_b"] < 1.0  # long along x: softer along x (ν = 0.3 default)


def test_subprocess_bad_input_exit_2():
    proc = subprocess.run(
        [sys.executable, "-m", "hpcontact.cli", "solve", "--nu", "0.7", "--json"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "nu" in lines[0] and "0.5" in lines[0]


BAD = [
    (["--nu", "0.6"], "nu"),
    (["--nu", "-1.5"], "nu"),
    (["--nu", "-1"], "nu"),
    (["--aspect", "0", "--shape", "ellipse"], "aspect"),
    (["--aspect", "-0.3", "--shape", "rectangle"], "aspect"),
    (["--aspect", "1.5", "--shape", "ellipse"], "aspect"),
    (["--n", "1"], "n"),
    (["--n", "0"], "n"),
    (["--n", "nan"], "--n"),  # argparse: invalid int value
    (["--n", "2.5"], "--n"),
    (["--n-across", "0"], "n_across"),
    (["--shape", "blob"], "shape"),
    (["--shape", "mask"], "mask"),
    (["--shape", "polygon", "--sides", "2"], "sides"),
    (["--G", "0"], "G"),
    (["--tol", "0.5"], "tol"),
    (["--threads", "0"], "threads"),
    (["--quantities", "slip"], "radius"),  # a slip scene needs its sphere radius first
    (["--quantities", "slip,normal"], "quantities"),
    (["--quantities", "indentation"], "radius"),
    (["--quantities", "indentation", "--radius", "1"], "depth"),
    (["--colour", "red"], "--colour"),
] + [
    ([f"{option}={value}", *extra], field)  # "=" form: argparse takes "-inf" for an option otherwise
    for value in ("nan", "inf", "-inf")
    for option, field, extra in [
        ("--nu", "nu", []),
        ("--G", "G", []),
        ("--aspect", "aspect", ["--shape", "ellipse"]),
        ("--shape-angle", "shape_angle", []),
        ("--amplitude", "amplitude", ["--shape", "star"]),
        ("--anisotropy", "anisotropy", []),
        ("--tol", "tol", []),
        ("--radius", "radius", ["--quantities", "indentation", "--depth", "0.1"]),
        ("--depth", "depth", ["--quantities", "indentation", "--radius", "1"]),
    ]
]


def _exit_code(capsys, *args) -> tuple[int, str, str]:
    """main()'s status, whether returned (InputError) or raised as SystemExit (argparse errors)."""
    try:
        code = main(["solve", *args])
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize("args, field", BAD, ids=lambda v: " ".join(v) if isinstance(v, list) else v)
def test_bad_input_exits_2_with_one_line(capsys, args, field):
    code, out, err = _exit_code(capsys, *SMALL, *args, "--json")  # last --n wins: bad args after
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert field in lines[0]


def test_empty_mask_file_exits_2(capsys, tmp_path):
    path = tmp_path / "empty.npy"
    np.save(path, np.zeros((5, 5)))
    code, out, err = _exit_code(capsys, "--shape", "mask", "--mask", str(path), "--json")
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "mask" in lines[0]


def test_missing_command_exits_2(capsys):
    with pytest.raises(SystemExit) as info:
        main([])
    assert info.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_png_mask_with_no_dark_pixel_exits_2(capsys, tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = tmp_path / "white.png"
    plt.imsave(path, np.ones((6, 6)), cmap="gray", vmin=0.0, vmax=1.0)
    code, out, err = _exit_code(capsys, "--shape", "mask", "--mask", str(path), "--json")
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "mask" in err


@pytest.mark.parametrize("option", ["--radius", "--depth"])
def test_nan_radius_or_depth_on_tangential_scene_exits_2(capsys, option):
    code, out, err = _exit_code(capsys, option, "nan", *SMALL, "--json")
    assert code == 2


@pytest.mark.parametrize("G", ["1e100", "1e-100"])
def test_huge_and_tiny_moduli_with_normalization(capsys, G):
    """Li's normalization does not depend on G: the value at the ends of G's range, 1e±100, is
    the G = 1 value to round-off (bound 1.5e-15). The coarse circle's own value is 1.00034.
    Beyond the range (1e±300, where the crystal kernels and large grids overflow) G is refused
    naming it, exit 2."""
    r = _json(capsys, "--G", G, "--quantities", "tangential,normal", "--n", "8")
    one = _json(capsys, "--G", "1", "--quantities", "tangential,normal", "--n", "8")
    assert r["normalized_xx"] == pytest.approx(one["normalized_xx"], rel=1.5e-15)
    beyond = G.replace("100", "300")
    code, _, err = _exit_code(capsys, "--G", beyond, "--quantities", "tangential,normal", "--n", "8")
    assert code == 2 and "G = " in err and len(err.strip().splitlines()) == 1


def test_a_run_command_names_itself_in_its_errors(capsys, tmp_path):
    """``python -m hpcontact.sweep.accuracy_study`` is ``hpcontact run`` with another task function: its bad
    input is reported under its own name (exit 2), not as ``hpcontact run``."""
    from hpcontact.sweep.driver import main as run_main

    missing = str(tmp_path / "missing.toml")
    assert run_main([missing], prog="python -m hpcontact.sweep.accuracy_study") == 2
    err = capsys.readouterr().err
    assert err.startswith("python -m hpcontact.sweep.accuracy_study: error: spec = ") and "hpcontact run" not in err
    assert run_main([missing]) == 2
    assert capsys.readouterr().err.startswith("hpcontact run: error: spec = ")


def _help(capsys, *args) -> str:
    with pytest.raises(SystemExit) as info:
        main([*args, "--help"])
    assert info.value.code == 0
    return capsys.readouterr().out


def test_solve_help_shows_defaults_groups_and_examples(capsys):
    """Issue 28: every scene option's engine default (hpcontact.scene.DEFAULTS), the options in
    groups, and examples."""
    text = " ".join(_help(capsys, "solve").split("options:", 1)[1].split())  # after the usage; argparse wraps lines
    for option, default in (
        ("--nu NU", "0.3"),
        ("--shape SHAPE", "circle"),
        ("--aspect ASPECT", "1.0"),
        ("--tol TOL", "1e-08"),
        ("--quantities QUANTITIES", "tangential"),
        ("--threads", "1"),
    ):
        assert option in text and f"(default: {default})" in text.split(option, 1)[1][:300], option
    for group in ("scene (", "material (", "numerics:", "output:", "partial slip ("):
        assert group in text, group
    assert "examples: hpcontact solve --shape ellipse --aspect 0.3 --nu 0.3" in text
    assert "--accuracy" in text.split("examples:")[1] and "--quantities slip" in text.split("examples:")[1]
    top = _help(capsys)
    assert "examples:" in top and "mpiexec -n 2 hpcontact run jobs/demo.toml" in top
    assert "examples:" in _help(capsys, "run") and "exit status:" in _help(capsys, "run")


@pytest.mark.parametrize(
    "args, suggestion",
    [
        (["solve", "--aspekt", "0.3"], "did you mean --aspect?"),
        (["solve", "--quantitys=normal"], "did you mean --quantities?"),
        (["solve", "--q-ratoi", "0.5"], "did you mean --q-ratio?"),
        (["slove"], "did you mean solve?"),
        (["run", "spec.toml", "--restrat"], "did you mean --restart?"),
    ],
)
def test_an_unknown_option_or_command_names_the_closest(capsys, args, suggestion):
    with pytest.raises(SystemExit) as info:
        main(args)
    assert info.value.code == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert captured.out == "" and len(lines) == 1 and lines[0].endswith(suggestion), captured.err


def test_an_unknown_spec_key_names_the_closest():
    from hpcontact.errors import InputError
    from hpcontact.sweep.space.parse import parse_spec

    for text, suggestion in (
        ("[numerics]\ntoll = 1e-8\n[axes]\nnu = [0.1]\n", "numerics.toll: .*did you mean tol\\?$"),
        ("[axes]\nnuu = [0.1]\n", "axes.nuu: .*did you mean nu\\?$"),
        ("[scene]\naspekt = 0.5\n[axes]\nnu = [0.1]\n", "scene.aspekt = 0.5: .*did you mean aspect\\?$"),
    ):
        with pytest.raises(InputError, match=suggestion):
            parse_spec(text)


def test_text_output_names_units(capsys):
    code, out, err = _run(capsys, "--shape", "ellipse", "--aspect", "0.5", "--quantities", "tangential,normal", *SMALL)
    assert code == 0 and err == ""
    units = {line.split()[0]: line.split()[2:] for line in out.splitlines() if len(line.split()) >= 2}
    for key in ("K_xx", "K_yy", "K_zz", "K_max"):
        assert units[key] == ["G·a"], (key, units[key])
    assert units["dx"] == ["a"] and units["wall_time_s"] == ["s"] and units["principal_angle_deg"] == ["deg"]
    assert units["K_a_over_K_b"] == [] and units["iterations"] == []  # pure numbers
    assert "G: shear modulus" in out and "a: semi-major extent of the contact" in out
    code, out, _ = _run(capsys, "--cubic", "C11=168 C12=121 C44=75", "--n", "8")
    assert (
        code == 0
        and "K_xx" in out
        and [line.split()[2] for line in out.splitlines() if line.split()[0] == "K_xx"] == ["GPa·a"]
    )
    code, out, _ = _run(capsys, "--quantities", "indentation", "--radius", "1", "--depth", "0.01", *SMALL)
    units = {line.split()[0]: line.split()[2:] for line in out.splitlines() if len(line.split()) >= 2}
    assert units["load"] == ["G·L²"] and units["contact_area"] == ["L²"] and units["dx"] == ["L"]


def test_memory_and_slip_options_are_refused_where_unused(capsys):
    code, out, err = _exit_code(capsys, *SMALL, "--memory", "1K")  # a one-grid solve's budget: this one far too small
    assert code == 2 and err.strip().startswith(
        "hpcontact: error: --memory = '1K': a grid (16 × 16 cells here) that fits"
    )
    code, out, err = _exit_code(capsys, *SMALL, "--load", "3")
    assert code == 2 and err.strip() == "hpcontact: error: --load = 3.0: only with --quantities slip"
    code, out, err = _exit_code(
        capsys,
        "--quantities",
        "slip",
        "--radius",
        "1",
        "--load",
        "1",
        "--mu",
        "0.3",
        "--q-ratio",
        "0.5",
        "--accuracy",
        "1e-3",
    )
    assert code == 2 and "--accuracy" in err and "not with --quantities slip" in err


def test_python_dash_m_hpcontact():
    proc = subprocess.run([sys.executable, "-m", "hpcontact", "--version"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.startswith("hpcontact ")


def test_normal_held_option(capsys):
    """--normal-held: a bad value exits 2 with one line naming the field and both values; "load"
    on an isotropic body gives the approach-held numbers, bit for bit (no solve is added, the
    plan says why) and the record says what was held."""
    code, out, err = _exit_code(capsys, *SMALL, "--normal-held", "force", "--json")
    assert code == 2 and out == ""
    assert err.strip().splitlines() == ["hpcontact: error: normal_held = 'force': one of approach, load"]
    approach = _json(capsys, *SMALL, "--shape", "ellipse", "--aspect", "0.5")
    load = _json(capsys, *SMALL, "--shape", "ellipse", "--aspect", "0.5", "--normal-held", "load")
    assert "normal_held" not in approach and load["normal_held"] == "load"
    assert load["plan"]["solves"] == approach["plan"]["solves"]
    assert any("normal_held load = approach" in line for line in load["plan"]["derived"])
    for key in TANGENTIAL_KEYS:
        assert load[key] == approach[key], key


# ------------------------------------------------------------------------------------------
# a field the material makes unused exits 2 with one line (issue 42 item 1)
# ------------------------------------------------------------------------------------------
UNUSED_BESIDE_A_BODY = [
    (
        ["--material", "Cu", "--nu", "0.1", "--n", "32"],
        "nu = 0.1: not used with material = 'Cu' (its elastic constants fix the Poisson ratio); leave nu out",
    ),
    (
        ["--material", "Cu", "--anisotropy", "3"],
        "anisotropy = 3.0: not used with material = 'Cu' (its elastic constants fix the anisotropy); "
        "leave anisotropy out",
    ),
    (
        ["--material", "Cu", "--G", "2", "--orientation", "20"],
        "G = 2.0: not used with material = 'Cu' (its elastic constants fix the moduli, in GPa); leave G out",
    ),
    (
        ["--cubic", "C11=168 C12=121 C44=75", "--nu", "0.3"],
        "nu = 0.3: not used with cubic = 'C11=168 C12=121 C44=75' (its elastic constants fix the Poisson ratio); "
        "leave nu out",
    ),
    (
        ["--shape", "circle", "--sides", "6"],
        "sides = 6: not used with shape = 'circle' (only polygon or star read it); leave sides out",
    ),
]


@pytest.mark.parametrize("args, line", UNUSED_BESIDE_A_BODY, ids=lambda v: " ".join(v) if isinstance(v, list) else "")
def test_a_field_the_scene_does_not_use_exits_2_with_one_line(capsys, args, line):
    code, out, err = _exit_code(capsys, *args, "--json")
    assert code == 2 and out == ""
    assert err.splitlines() == [f"hpcontact: error: {line}"]


def test_the_issue_42_command_exits_2_in_a_process():
    proc = subprocess.run(
        [sys.executable, "-m", "hpcontact", "solve", "--material", "Cu", "--nu", "0.1", "--n", "32"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [f"hpcontact: error: {UNUSED_BESIDE_A_BODY[0][1]}"]


def test_what_the_material_reads_still_solves(capsys):
    alone = _json(capsys, "--material", "Cu", "--n", "8")
    turned = _json(capsys, "--material", "Cu", "--orientation", "20", "--n", "8")
    assert turned["K_xx"] != alone["K_xx"]  # a named crystal reads its orientation
    assert _json(capsys, "--material", "Cu", "--miller", "1 1 0", "--azimuth", "10", "--n", "8")["K_xx"] > 0
    crystal = _json(capsys, "--nu", "0.2", "--anisotropy", "3", "--orientation", "20", "--n", "8")
    assert crystal["plan"]["kernel_source"].startswith("anisotropic")
    isotropic = _json(capsys, "--nu", "0.1", "--n", "8")
    assert isotropic["plan"]["kernel_source"].startswith("isotropic closed form")


@pytest.mark.parametrize(
    "axes, key",
    [
        ('[scene]\nmaterial = "Cu"\n[axes]\nnu = [0.1, 0.3]\n', "axes.nu"),
        ('[scene]\nnu = 0.3\n[axes]\nmaterial = ["Cu", "W"]\n', "scene.nu"),
    ],
)
def test_a_sweep_combining_a_material_with_nu_exits_2_with_one_line(capsys, tmp_path, axes, key):
    spec = tmp_path / "job.toml"
    spec.write_text(f"{axes}[numerics]\nn = 16\n")
    code = main(["run", str(spec), "--dry-run", "--output", str(tmp_path / "job.nc")])
    out, err = capsys.readouterr()
    assert code == 2 and out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].endswith(
        f"{key} = {0.1 if key == 'axes.nu' else 0.3}: not used with material = 'Cu' "
        "(its elastic constants fix the Poisson ratio); leave nu out"
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--material", "Cu", "--nu", "0.1"],
            "nu = 0.1: not used with material = 'Cu' (its elastic constants fix the Poisson ratio); leave nu out",
        ),
        (
            ["--cubic", "C11=168 C12=121 C44=75", "--G", "2"],
            "G = 2.0: not used with cubic = 'C11=168 C12=121 C44=75' (its elastic constants fix the moduli, in GPa); "
            "leave G out",
        ),
        (
            ["--shape", "circle", "--sides", "7"],
            "sides = 7: not used with shape = 'circle' (only polygon or star read it); leave sides out",
        ),
    ],
)
def test_a_field_the_scene_does_not_read_is_refused(capsys, args, message):
    """Issue 38: ``hpcontact solve --material Cu --nu 0.1`` exits 2 naming nu, as Python does."""
    code, out, err = _run(capsys, *args, "--n", "8")
    assert (code, out, err) == (2, "", f"hpcontact: error: {message}\n")


def test_solve_options_are_the_field_schemas(capsys):
    """Issue 38: every field of the schema with a command-line group is an option of
    ``hpcontact solve``, with its help text (``hpcontact.fields.cli_help``)."""
    from hpcontact.cli import parser
    from hpcontact.fields import cli_fields, cli_help

    solve = next(a for a in parser()._actions if a.dest == "command").choices["solve"]
    options = {a.dest: a for a in solve._actions}
    for f in cli_fields():
        assert options[f.name].option_strings == [f.cli_option] and options[f.name].help == cli_help(f.name), f.name
