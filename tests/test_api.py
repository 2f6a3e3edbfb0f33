"""The Python face (``hpcontact.solve``, ``hpcontact.run_sweep``; issue 28): explicit keyword
parameters, the CLI's dispatch shared, no process-wide side effect at import, sweeps from a
path or a dict, safe to run twice, messages that name keywords rather than command-line flags."""

from __future__ import annotations

import inspect
import io
import json
import os
import re
import subprocess
import sys
import tomllib

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import hpcontact
from hpcontact import accuracy as acc
from hpcontact import analytic, api
from hpcontact.accuracy import DEFAULT_ACCURACY, AccuracyNotMet
from hpcontact.cli import main as cli_main
from hpcontact.errors import AccuracyWarning, InputError
from hpcontact.sweep.run.guard import Refused
from hpcontact.sweep.space.parse import toml_text

SOLVE_PARAMETERS = (
    "shape aspect sides shape_angle amplitude seed hurst rms mask nu G anisotropy orientation miller azimuth material "
    "cubic orthotropic voigt n n_across tol quantities radius depth threads precondition normal_held accuracy memory"
).split()


def test_solve_has_explicit_keyword_only_typed_documented_parameters():
    signature = inspect.signature(hpcontact.solve)
    for name in SOLVE_PARAMETERS:
        parameter = signature.parameters[name]
        assert parameter.kind is inspect.Parameter.KEYWORD_ONLY and parameter.default is None, name
        assert parameter.annotation is not inspect.Parameter.empty, name
        assert re.search(rf"^    (\w+, )*{name}(, \w+)*$", hpcontact.solve.__doc__, re.MULTILINE), (
            name
        )  # numpydoc entry
    assert hpcontact.solve is api.solve and hpcontact.run_sweep is api.run_sweep


def test_solve_to_an_accuracy():
    """``accuracy=`` goes through solve_to_accuracy (strategy auto) as ``hpcontact solve --accuracy``."""
    record = hpcontact.solve(shape="ellipse", aspect=0.3, nu=0.3, accuracy=1e-4)
    assert record["estimated_error"] <= 1e-4 and record["accuracy_met"]
    assert {"K_xx", "K_yy", "grids", "levels"} <= set(record)


def test_solve_and_the_command_line_give_the_same_record(capsys):
    loose = hpcontact.solve(shape="ellipse", aspect=0.5, accuracy=1e-2)
    assert cli_main(["solve", "--shape", "ellipse", "--aspect", "0.5", "--accuracy", "1e-2", "--json"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert (
        printed["grids"] == loose["grids"]
        and printed["K_xx"] == loose["K_xx"]
        and printed["boundary"] == loose["boundary"]
    )
    one = hpcontact.solve(shape="ellipse", aspect=0.5, n=16)  # a grid given: that grid, not extrapolated
    assert one["nx"] == 16 and "estimated_error" not in one
    default = hpcontact.solve(shape="ellipse", aspect=0.5)  # no n, no accuracy: as accuracy=1e-4
    exact = hpcontact.solve(shape="ellipse", aspect=0.5, accuracy=1e-4)
    assert default["boundary"] == exact["boundary"] == "galin" and default["K_xx"] == exact["K_xx"]
    assert default["accuracy_met"] and default["estimated_error"] <= 1e-10


@pytest.mark.filterwarnings("error")
def test_the_default_of_a_circle_takes_the_exact_cell():
    """Issue 42 item 2: ``hpcontact.solve(shape="circle", nu=0.3)`` took coverage-weighted grids
    16 … 256 (1.1 s, estimate 1.8e-4, its own 1e-4 missed in silence) where ``accuracy=1e-4``
    takes the one exact Galin cell (ms, round-off). The default is that request now."""
    record = hpcontact.solve(shape="circle", nu=0.3)
    K = analytic.circle_tangential_stiffness(1.0, 1.0, 0.3)
    assert record["boundary"] == "galin" and record["accuracy_met"] and record["stopped_by"] == "met"
    assert record["estimated_error"] <= 1e-10 and record["accuracy"] == DEFAULT_ACCURACY
    for key in ("K_xx", "K_yy"):
        assert abs(record[key] / K - 1.0) <= max(record["estimated_error"], 1e-14), key


def test_a_default_that_misses_its_accuracy_warns(monkeypatch):
    """A default (no n, no accuracy) that misses its target returns its record with an
    ``AccuracyWarning`` naming the requested and estimated error and the limit that stopped it
    (here a star asked for 1e-6 within 64 x 64 cells); an ``accuracy`` asked for still raises."""
    monkeypatch.setattr(acc, "DEFAULT_ACCURACY", 1e-6)
    monkeypatch.setattr(
        acc.solve_to_accuracy, "__kwdefaults__", {**acc.solve_to_accuracy.__kwdefaults__, "max_cells": 64 * 64, "n0": 8}
    )
    with pytest.warns(AccuracyWarning) as caught:
        record = hpcontact.solve(shape="star", nu=0.3)
    assert len(caught) == 1 and caught[0].filename == __file__  # points at the caller
    message = str(caught[0].message)
    assert message.startswith("default accuracy 1e-06 not met: estimated error ")
    assert f"{record['estimated_error']:.3g}" in message and "finest grid 64 x 64; stopped by cells" in message
    assert not record["accuracy_met"] and record["estimated_error"] > 1e-6 and record["grids"] == [8, 16, 32, 64]
    with pytest.raises(AccuracyNotMet, match="^accuracy 1e-06 not met"):
        hpcontact.solve(shape="star", nu=0.3, accuracy=1e-6)


def test_solve_refuses_unknown_keywords_and_misplaced_fields():
    with pytest.raises(TypeError, match="'aspekt'; did you mean 'aspect'"):
        hpcontact.solve(aspekt=0.3)
    with pytest.raises(InputError, match="^memory = '2G': not with quantities slip"):
        hpcontact.solve(quantities="slip", radius=1.0, load=1.0, mu=0.3, q_ratio=0.5, memory="2G")
    with pytest.raises(InputError, match="^load = 1.0: only with quantities slip$"):
        hpcontact.solve(n=8, load=1.0)
    with pytest.raises(InputError, match="^accuracy = 0.001: not with quantities slip"):
        hpcontact.solve(quantities="slip", radius=1.0, load=1.0, mu=0.3, q_ratio=0.5, accuracy=1e-3)
    with pytest.raises(InputError, match="nu"):
        hpcontact.solve(nu=0.7, n=8)


@pytest.mark.parametrize(
    "fields, message",
    [
        (
            {"material": "Cu", "nu": 0.1},
            "nu = 0.1: not used with material = 'Cu' (its elastic constants fix the Poisson ratio); leave nu out",
        ),
        (
            {"material": "Cu", "anisotropy": 3},
            "anisotropy = 3: not used with material = 'Cu' (its elastic constants fix the anisotropy); "
            "leave anisotropy out",
        ),
        (
            {"cubic": (168.4, 121.4, 75.4), "G": 2.0},
            "G = 2.0: not used with cubic = (168.4, 121.4, 75.4) (its elastic constants fix the moduli, in GPa); "
            "leave G out",
        ),
    ],
)
def test_solve_refuses_a_field_the_material_makes_unused(capsys, fields, message):
    """Issue 42: the Python face goes through the scene's validation, so it refuses what the
    command line refuses, in the same words (the CLI prints them after "hpcontact: error: ")."""
    with pytest.raises(InputError) as info:
        hpcontact.solve(n=8, **fields)
    body, unused = fields  # the body's field first, the unused one second
    assert str(info.value) == message and info.value.field == unused
    if body == "material":  # the command line: the same line (its --anisotropy is a float: 3.0)
        assert cli_main(["solve", "--n", "8", *(f"--{k}={v}" for k, v in fields.items())]) == 2
        assert capsys.readouterr().err == f"hpcontact: error: {message.replace(' = 3:', ' = 3.0:')}\n"


def test_blas_is_limited_only_while_solving(monkeypatch):
    """The limit is a context around the solve (HPCONTACT_BLAS_THREADS, default 1), lifted after."""
    monkeypatch.delenv("HPCONTACT_BLAS_THREADS", raising=False)
    seen = []

    def record_threads(scene):
        seen.extend(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas")
        return {"K_xx": 1.0}

    monkeypatch.setattr(api, "default_scene_solve", record_threads)
    with threadpool_limits(limits=2, user_api="blas"):
        before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
        assert hpcontact.solve(n=8)["K_xx"] == 1.0
        assert [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"] == before
    assert seen and set(seen) == {1}
    monkeypatch.setenv("HPCONTACT_BLAS_THREADS", "many")
    with pytest.raises(InputError, match="HPCONTACT_BLAS_THREADS"):
        hpcontact.solve(n=8)


IMPORT_PROBE = """
import json, os
import numpy, scipy.linalg  # the BLAS libraries a solve uses, loaded before hpcontact
from threadpoolctl import threadpool_info, threadpool_limits
threadpool_limits(limits=2, user_api="blas")
environ = dict(os.environ)
before = {i["filepath"]: i["num_threads"] for i in threadpool_info()}
import hpcontact
after = {i["filepath"]: i["num_threads"] for i in threadpool_info()}
print(json.dumps({"environ_same": environ == dict(os.environ), "changed": [p for p, n in before.items() if after.get(p) != n],
                  "pools": len(before)}))
"""


def test_import_changes_no_environment_variable_and_no_thread_pool():
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("HPCONTACT_BLAS_THREADS", "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
    }
    proc = subprocess.run([sys.executable, "-c", IMPORT_PROBE], capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert result["environ_same"] and result["changed"] == [] and result["pools"] >= 1, result


SPEC = {
    "sweep": {"title": "api test"},
    "scene": {"shape": "circle", "quantities": ["tangential"]},
    "numerics": {"n": 8},
    "axes": {"nu": [0.0, 0.3], "angle": {"linspace": [0, 90, 3]}},
}


def test_run_sweep_from_a_dict_twice_and_its_refusals_name_keywords(tmp_path):
    output = tmp_path / "api.nc"
    stream = io.StringIO()
    path = hpcontact.run_sweep(SPEC, output=output, stream=stream)
    assert path == output and "2 tasks, 2 to run" in stream.getvalue()
    with hpcontact.open_dataset(path) as ds:
        assert ds.sizes["nu"] == 2 and ds.sizes["angle"] == 3 and ds.attrs["title"] == "api test"
    mtime, again = output.stat().st_mtime_ns, io.StringIO()
    assert hpcontact.run_sweep(SPEC, output=output, stream=again) == output  # safe to run twice
    assert again.getvalue() == f"hpcontact: {output} is up to date (2 tasks from journals); nothing to do\n"
    assert output.stat().st_mtime_ns == mtime

    output.unlink()  # journals without their data set: refused, in a Python caller's words
    with pytest.raises(Refused) as info:
        hpcontact.run_sweep(SPEC, output=output, stream=io.StringIO())
    message = str(info.value)
    assert "resume=True" in message and "restart=True" in message and "--" not in message
    assert hpcontact.run_sweep(SPEC, output=output, resume=True, stream=io.StringIO()) == output
    with pytest.raises(InputError, match="resume=True"):
        hpcontact.run_sweep(SPEC, output=output, resume=True, restart=True)


def test_run_sweep_from_a_path_takes_keywords(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(toml_text({**SPEC, "sweep": {"output": str(tmp_path / "file.nc")}}), encoding="utf-8")
    assert hpcontact.run_sweep(spec, stream=io.StringIO()) == tmp_path / "file.nc"
    assert hpcontact.run_sweep(str(spec), restart=True, stream=io.StringIO()) == tmp_path / "file.nc"
    with pytest.raises(TypeError):
        hpcontact.run_sweep(spec, True)  # keywords only


def test_a_dict_spec_goes_through_the_spec_parser():
    with pytest.raises(InputError, match="numerics.toll.*did you mean tol"):
        hpcontact.run_sweep({**SPEC, "numerics": {"toll": 1e-8}}, output="x.nc")
    with pytest.raises(InputError, match="scene.shape"):
        hpcontact.run_sweep({**SPEC, "scene": {"shape": None}}, output="x.nc")


def test_toml_text_round_trips():
    spec = {
        "sweep": {"title": 'quote " backslash \\ tab \t ünïcode 😀', "output": "r/x.nc", "progress_interval": 1e-3},
        "scene": {"quantities": ("tangential", "normal"), "precondition": np.bool_(False), "G": np.float64(2.5)},
        "numerics": {"n": np.int64(64), "tol": 1e-10},
        "axes": {
            "shape": ["ellipse", {"label": "hexagon", "shape": "polygon", "sides": 6}],
            "aspect": {"logspace": [0, -8, 5]},
            "nu": np.array([0.0, 0.25]),
            "weird key": [float("inf"), -float("inf")],
        },
    }
    parsed = tomllib.loads(toml_text(spec))
    assert parsed["sweep"] == spec["sweep"] and parsed["numerics"] == {"n": 64, "tol": 1e-10}
    assert parsed["scene"] == {"quantities": ["tangential", "normal"], "precondition": False, "G": 2.5}
    assert parsed["axes"]["shape"] == spec["axes"]["shape"] and parsed["axes"]["aspect"] == {"logspace": [0, -8, 5]}
    assert parsed["axes"]["nu"] == [0.0, 0.25] and parsed["axes"]["weird key"] == [float("inf"), -float("inf")]


# Malformed inputs raise InputError naming the field (issue 43 item 7) -------------------------


@pytest.mark.parametrize("spec", [[1, 2], 3, None, b"jobs/demo.toml"])
def test_run_sweep_refuses_a_spec_that_is_not_a_path_or_a_dict(spec):
    with pytest.raises(InputError) as info:
        hpcontact.run_sweep(spec, stream=io.StringIO())
    assert info.value.field == "spec" and "dict" in str(info.value) and "os.PathLike" in str(info.value)


def test_run_sweep_refuses_a_dict_spec_nested_too_deep_or_containing_itself(tmp_path):
    deep: dict = {}
    inner = deep
    for _ in range(5000):
        inner["a"] = {}
        inner = inner["a"]
    with pytest.raises(InputError) as info:
        hpcontact.run_sweep({"scene": deep}, output=tmp_path / "x.nc", stream=io.StringIO())
    assert info.value.field.startswith("scene.a.a.a") and "64 levels" in str(info.value)
    looped: dict = {"scene": {"shape": "circle"}, "axes": {"nu": [0.3]}}
    looped["scene"]["self"] = looped
    with pytest.raises(InputError) as info:
        hpcontact.run_sweep(looped, output=tmp_path / "x.nc", stream=io.StringIO())
    assert info.value.field == "scene.self" and "contains itself" in str(info.value)


@pytest.mark.parametrize("name", ["a\0b.nc", "a" * 300 + ".nc"])
def test_run_sweep_refuses_an_output_the_os_cannot_name(tmp_path, name):
    spec = {"scene": {"shape": "circle"}, "numerics": {"n": 8}, "axes": {"nu": [0.3]}}
    for kwargs in ({"output": tmp_path / name}, {}):
        given = spec if kwargs else {**spec, "sweep": {"output": str(tmp_path / name)}}
        with pytest.raises(InputError) as info:
            hpcontact.run_sweep(given, stream=io.StringIO(), **kwargs)
        assert info.value.field == "output" and "the output" in str(info.value)
        assert ("output=" if kwargs else "sweep.output") in str(info.value)


def test_threads_above_this_machines_cpus_are_refused_naming_the_range(capsys):
    from hpcontact.scene import usable_cpus

    with pytest.raises(InputError) as info:
        hpcontact.solve(shape="circle", n=8, threads=10**6)
    assert info.value.field == "threads" and f"[1, {usable_cpus()}]" in str(info.value)
    assert cli_main(["solve", "--n", "8", "--threads", str(usable_cpus() + 1)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "threads" in err


@pytest.mark.parametrize(
    ("fields", "field"),
    [
        ({"G": 1e308}, "G"),
        ({"G": 1e-101}, "G"),
        ({"cubic": "C11=1e300 C12=5e299 C44=4e299"}, "cubic.C11"),
        ({"orthotropic": "E1=1e101 E2=1 E3=1 G12=1 G13=1 G23=1 nu12=0 nu13=0 nu23=0"}, "orthotropic.E1"),
        ({"voigt": [1e-101 if i % 7 == 0 else 0.0 for i in range(36)]}, "voigt"),
    ],
)
def test_moduli_outside_the_finite_range_are_refused_naming_the_field(fields, field):
    with pytest.raises(InputError) as info:
        hpcontact.solve(shape="circle", n=8, **fields)
    assert info.value.field == field and "[1e-100, 1e+100]" in str(info.value)


def test_moduli_at_the_ends_of_the_range_still_solve():
    one = hpcontact.solve(shape="circle", n=8, quantities="tangential")
    for G in (1e-100, 1e100):
        record = hpcontact.solve(shape="circle", n=8, G=G, quantities="tangential")
        assert record["K_xx"] / G == pytest.approx(one["K_xx"], rel=1e-12)


def test_run_sweep_refuses_a_spec_file_too_large_or_not_regular(tmp_path):
    from hpcontact.sweep.space.parse import MAX_SPEC_BYTES

    big = tmp_path / "big.toml"
    big.write_text("# " + "x" * MAX_SPEC_BYTES + "\n")
    for path in (big, tmp_path, "/dev/zero"):
        with pytest.raises(InputError) as info:
            hpcontact.run_sweep(path, stream=io.StringIO())
        assert info.value.field == "spec" and f"at most {MAX_SPEC_BYTES // 2**20} MiB" in str(info.value)


def test_solve_keywords_are_the_field_schemas():
    """Issue 38: the explicit keywords of ``hpcontact.solve`` are the schema's contact fields,
    the documented extra ``memory`` (``accuracy`` is a contact field) and the slip scene's own
    fields, each keyword-only, typed and documented, generated from the schema (no keyword is
    listed by hand in ``api.py``); an unknown keyword is a TypeError, as for any function."""
    from hpcontact import fields
    from hpcontact.fields import CONTACT, SLIP, names

    parameters = inspect.signature(hpcontact.solve).parameters
    keywords = [name for name, p in parameters.items() if p.kind is inspect.Parameter.KEYWORD_ONLY]
    assert set(keywords) == set(names(CONTACT)) | {"accuracy", "memory"} | set(names(SLIP)) - {"quantities"}
    assert len(keywords) == len(set(keywords))
    assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in parameters.values())
    for name in ("normal_held", "a", "load"):  # a contact field, the contact size, a slip field: not in api.py's text
        assert fields.python_doc(name) in " ".join(hpcontact.solve.__doc__.split())
        assert parameters[name].annotation == fields.python_annotation(name)
        assert not re.search(rf"\b{name}\b", inspect.getsource(api.solve).split('"""')[2]), name
    for name in names(SLIP):
        assert parameters[name].annotation is not inspect.Parameter.empty, name
        assert re.search(rf"^    (\w+, )*{name}(, \w+)*$", hpcontact.solve.__doc__, re.MULTILINE), name


def test_a_field_the_scene_does_not_read_is_refused_as_on_the_command_line(capsys):
    """Issue 38: ``nu`` beside a library crystal is refused with one message, in Python and on
    the command line alike (never silently ignored)."""
    message = "nu = 0.1: not used with material = 'Cu' (its elastic constants fix the Poisson ratio); leave nu out"
    with pytest.raises(InputError) as caught:
        hpcontact.solve(material="Cu", nu=0.1, n=8)
    assert str(caught.value) == message
    assert cli_main(["solve", "--material", "Cu", "--nu", "0.1", "--n", "8"]) == 2
    assert capsys.readouterr().err == f"hpcontact: error: {message}\n"


def test_contact_size_gives_newtons_per_metre_against_mindlin():
    """A bonded circle of radius a = 1 mm on a body of G = 26 GPa, nu = 0.3: Mindlin's closed form
    K = 8 G a / (2 - nu) in N/m (Johnson 1985 §7.2), met within the record's estimated error; the
    same scene without ``a`` is that stiffness in units of G·a."""
    G, nu, a = 26e9, 0.3, 1e-3
    record = hpcontact.solve(shape="circle", nu=nu, G=G, a=a)
    mindlin = 8.0 * G * a / (2.0 - nu)
    assert abs(record["K_xx"] / mindlin - 1.0) <= 2.0 * record["estimated_error"] + 1e-12
    assert record["K_xx"] == hpcontact.solve(shape="circle", nu=nu, G=G)["K_xx"] * a
