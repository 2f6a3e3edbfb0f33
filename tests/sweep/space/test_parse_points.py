"""A spec's points are counted from its axes' descriptions before any axis is made (issue 43
item 3), and a spec given as a dict is parsed directly, not written as TOML and read back
(issue 38 item 4).

The bounds: a refusal of 10**7 points or more by counting reads each axis's length (a list's
``len``, a generator's ``num``): O(number of axes) work and no allocation that grows with the
points, so 1 s and 1 MiB of Python allocations (tracemalloc) bound it with room for a loaded
machine; making the axes instead (what was done before) allocates ~24 bytes per value at least
(a float object each: 2·10**7 of them is ~0.5 GB) and takes seconds.
"""

from __future__ import annotations

import math
import time
import tomllib
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.sweep.space import parse
from hpcontact.sweep.space.axes import MAX_POINTS, MAX_TASK_POINTS, axis_length
from hpcontact.sweep.space.parse import parse_spec, parse_spec_dict, toml_text

REFUSAL_SECONDS = 1.0
REFUSAL_BYTES = 2**20


def accept(params):
    """A validator that accepts every scene."""


def refused_quickly(call) -> InputError:
    """The ``InputError`` of ``call()``, checked to come within the bounds of the module docstring."""
    tracemalloc.start()
    started = time.perf_counter()
    try:
        with pytest.raises(InputError) as info:
            call()
    finally:
        seconds = time.perf_counter() - started
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert seconds <= REFUSAL_SECONDS and peak <= REFUSAL_BYTES, (seconds, peak)
    return info.value


def test_an_axis_length_is_read_from_its_description_without_making_it():
    assert axis_length("nu", {"linspace": [0, 0.5, MAX_POINTS]}) == MAX_POINTS
    with pytest.raises(InputError) as info:  # one axis over the limit: refused naming it, no 8 TB array made
        axis_length("nu", {"linspace": [0, 0.5, 10**12]})
    assert info.value.field == "axes.nu.linspace" and f"num <= {MAX_POINTS}" in str(info.value)
    assert axis_length("nu", {"logspace": (0, -3, np.int64(7))}) == 7
    assert axis_length("nu", [0.1, 0.2]) == 2 and axis_length("nu", np.zeros(5)) == 5
    with pytest.raises(InputError) as info:
        axis_length("nu", "0.3")
    assert info.value.field == "axes.nu" and "linspace" in str(info.value)
    with pytest.raises(InputError) as info:
        axis_length("nu", {"linspace": [0, 0.5, 2.5]})
    assert info.value.field == "axes.nu.linspace" and "integer num" in str(info.value)


def test_generated_axes_over_the_limit_together_are_refused_before_either_is_made():
    """Two axes of 5·10**6 points each: each under the limit, their product (2.5·10**13) far
    over it; before, both were generated (and every value formatted) before the product was
    looked at: seconds and ~0.5 GB."""
    text = (
        "[numerics]\nn = 8\n[axes]\nnu = { linspace = [0, 0.5, 5000000] }\naspect = { logspace = [0, -3, 5000000] }\n"
    )
    error = refused_quickly(lambda: parse_spec(text, validate=accept, check_scenes=False))
    assert error.field == "axes" and "5000000 x 5000000 = 25000000000000" in str(error)
    assert str(MAX_POINTS) in str(error)


@pytest.mark.parametrize("make", [lambda n: [0.25] * n, lambda n: np.full(n, 0.25)], ids=["list", "array"])
def test_a_dict_axis_of_an_explicit_list_over_the_limit_is_refused_by_counting(make):
    """The fault round's case: a dict spec whose axis is an explicit list of 2·10**7 values was
    written as TOML and parsed (200 s, 2.8 GB) before its points were counted."""
    values = make(2 * MAX_POINTS)
    spec = {"scene": {"shape": "circle"}, "numerics": {"n": 8}, "axes": {"nu": values}}
    error = refused_quickly(lambda: parse_spec_dict(spec, validate=accept, check_scenes=False))
    assert error.field == "axes" and f"= {2 * MAX_POINTS}" in str(error)


SPEC = {
    "sweep": {"title": "dict", "output": "out/d.nc", "progress_interval": 2.5},
    "scene": {"quantities": ("tangential", "normal"), "G": np.float64(2.5)},
    "numerics": {"n": np.int64(16), "tol": 1e-9},
    "axes": {
        "shape": ["ellipse", {"label": "hexagon", "shape": "polygon", "sides": 6}],
        "aspect": {"logspace": [0, -2, 3]},
        "nu": np.array([0.0, 0.25]),
        "angle": {"linspace": (0, 90, np.int64(4))},
    },
}


def test_a_dict_spec_is_parsed_without_toml_as_its_toml_text_would_be(monkeypatch):
    """The same Spec as from its TOML text (what ``hpcontact.run_sweep`` parsed before), with
    the TOML text as its record; the TOML reader is never called on the way."""
    from_text = parse_spec(toml_text(SPEC), path="<dict>", validate=accept)

    def no_toml(text):
        raise AssertionError("a dict spec was read back from TOML")

    monkeypatch.setattr(parse.tomllib, "loads", no_toml)
    spec = parse_spec_dict(SPEC, validate=accept)
    assert spec == from_text  # every field, the text (the data set's record of the spec) included
    assert spec.output == Path("out/d.nc") and spec.fixed == {
        "quantities": ["tangential", "normal"],
        "G": 2.5,
        "n": 16,
        "tol": 1e-9,
    }
    assert spec.axis("nu").values == (0.0, 0.25) and spec.axis("angle").values == (0.0, 30.0, 60.0, 90.0)
    monkeypatch.undo()
    assert tomllib.loads(spec.text)["axes"]["nu"] == [0.0, 0.25]


def test_toml_text_writes_what_toml_reads_back():
    spec = {
        "sweep": {"title": 'quote " backslash \\ tab \t ünïcode 😀 \x7f', "output": Path("r/x.nc")},
        "scene": {"precondition": np.bool_(False), "G": np.float64(2.5)},
        "numerics": {"n": np.int64(64)},
        "axes": {"nu": np.array([0.0, 0.25]), "weird key": [math.inf, -math.inf], "e": [math.nan]},
    }
    parsed = tomllib.loads(toml_text(spec))
    assert parsed["sweep"] == {"title": spec["sweep"]["title"], "output": "r/x.nc"}
    assert parsed["scene"] == {"precondition": False, "G": 2.5} and parsed["numerics"] == {"n": 64}
    assert parsed["axes"]["nu"] == [0.0, 0.25] and parsed["axes"]["weird key"] == [math.inf, -math.inf]
    assert math.isnan(parsed["axes"]["e"][0])


@pytest.mark.parametrize(
    "spec, field, words",
    [
        ({"scene": {"shape": None}}, "scene.shape", "a TOML value"),
        ({"scene": {"shape": object()}}, "scene.shape", "a TOML value"),
        ({"scene": {3: "circle"}}, "spec", "string keys"),
        ({"axes": {"nu": [0.1, {1j: 2}]}}, "spec", "string keys"),
        ({"axes": {"nu": [0.1, None]}}, "axes.nu", "a TOML value"),
    ],
)
def test_what_toml_cannot_hold_is_refused_naming_the_key(spec, field, words):
    with pytest.raises(InputError) as info:
        parse_spec_dict({"numerics": {"n": 8}, **spec}, validate=accept)
    assert info.value.field == field and words in str(info.value)


def test_a_dict_spec_nested_too_deep_or_containing_itself_is_refused_naming_where():
    deep: dict = {}
    inner = deep
    for _ in range(5000):  # deeper than Python's recursion limit
        inner["a"] = {}
        inner = inner["a"]
    with pytest.raises(InputError) as info:
        parse_spec_dict({"scene": deep}, validate=accept)
    assert info.value.field.startswith("scene.a.a.a") and f"{parse.MAX_SPEC_DEPTH} levels" in str(info.value)
    looped: dict = {"scene": {"shape": "circle"}, "axes": {"nu": [0.3]}}
    looped["scene"]["self"] = looped
    with pytest.raises(InputError) as info:
        parse_spec_dict(looped, validate=accept)
    assert info.value.field == "scene.self" and "contains itself" in str(info.value)
    shared = [0.1, 0.2]  # the same list twice is no cycle
    spec = parse_spec_dict({"numerics": {"n": 8}, "axes": {"nu": shared, "aspect": shared}}, validate=accept)
    assert spec.axis("nu").values == spec.axis("aspect").values == (0.1, 0.2)


def test_points_that_each_need_a_solve_are_bounded_apart_from_the_angles_of_a_tensor():
    """10**7 points of which 10 need a solve (tensor-mode angles) run end to end (MAX_POINTS'
    measurement); 10**7 points that each need a solve did not (the fault round: MemoryError
    after 3 min and 6.6 GB), so points of the task axes are bounded by MAX_TASK_POINTS."""
    tensor = parse_spec(
        f"[numerics]\nn = 8\n[axes]\nnu = {{ linspace = [0, 0.45, 10] }}\n"
        f"angle = {{ linspace = [0, 180, {MAX_POINTS // 10}] }}\n",
        validate=accept,
        check_scenes=False,
    )
    assert math.prod(len(a) for a in tensor.axes) == MAX_POINTS and len(tensor.task_axes) == 1
    rotated = f'[sweep]\nangle_mode = "rotated"\n[numerics]\nn = 8\n[axes]\nangle = {{ linspace = [0, 180, {MAX_TASK_POINTS + 1}] }}\n'
    with pytest.raises(InputError) as info:
        parse_spec(rotated, validate=accept, check_scenes=False)
    assert info.value.field == "axes" and f"at most {MAX_TASK_POINTS} points that each need a solve" in str(info.value)
    assert f"= {MAX_TASK_POINTS + 1}" in str(info.value)


def test_a_generated_axis_of_more_solves_than_the_limit_is_refused_by_counting():
    """The fault round's 10**7-point linspace of nu (10**7 solves): refused before its values
    are made (it ran 3 min and took 6.6 GB before)."""
    text = f"[numerics]\nn = 8\n[axes]\nnu = {{ linspace = [0, 0.45, {MAX_POINTS}] }}\n"
    error = refused_quickly(lambda: parse_spec(text, validate=accept, check_scenes=False))
    assert error.field == "axes" and f"= {MAX_POINTS}" in str(error) and "each need a solve" in str(error)
