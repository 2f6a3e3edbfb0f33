"""Lengths and areas of a sized scene (issue 42 item 4): with the contact size ``a`` in metres a
record's cell sizes are in m and its contact area in m², as its stiffnesses are in N/m, in
``hpcontact.solve``, ``hpcontact solve --json``, its text and a sweep's data set alike.

The check is Euclid's: a rectangle of half-sides a and b covers 4ab, which coverage-weighted
cells count exactly (``contact_area`` = Σ f dA: the coverage of each cell is its exact share), so
b/a = 0.5 at a = 2 mm is 4 × 0.5 × (2e-3 m)² = 8e-6 m² on every grid; a cell of a grid of nx
cells over the long side 2a is 2a/nx long."""

from __future__ import annotations

import io
import json

import pytest

import hpcontact
from hpcontact.cli import main as cli_main

A_M = 2e-3  # the contact size a, m
G_PA = 26e9  # an isotropic body's shear modulus, Pa (aluminium)
RECTANGLE = {"shape": "rectangle", "aspect": 0.5, "nu": 0.3}
AREA_M2 = 4.0 * 0.5 * A_M**2


def test_a_sized_scenes_lengths_are_metres_and_its_area_square_metres():
    sized = hpcontact.solve(**RECTANGLE, G=G_PA, a=A_M, accuracy=1e-2)
    plain = hpcontact.solve(**RECTANGLE, accuracy=1e-2)
    assert sized["units"]["contact_area"] == "m2" and sized["units"]["dx"] == sized["units"]["dy"] == "m"
    assert plain["units"]["contact_area"] == "a2" and plain["units"]["dx"] == "a"
    assert sized["contact_area"] == pytest.approx(AREA_M2, rel=1e-12)
    assert plain["contact_area"] == pytest.approx(4.0 * 0.5, rel=1e-12)
    assert sized["dx"] == pytest.approx(2.0 * A_M / sized["nx"], rel=1e-12)
    # every grid's area is the rectangle's, in m² too
    assert [level["contact_area"] for level in sized["levels"]] == pytest.approx([AREA_M2] * len(sized["levels"]))


def test_the_command_lines_json_and_text_say_metres(capsys):
    args = ["solve", "--shape", "rectangle", "--aspect", "0.5", "--nu", "0.3", "--G", str(G_PA), "--a", str(A_M)]
    args += ["--accuracy", "1e-2"]
    assert cli_main([*args, "--json"]) == 0
    record = json.loads(capsys.readouterr().out)
    assert record["units"]["contact_area"] == "m2" and record["contact_area"] == pytest.approx(AREA_M2, rel=1e-12)
    assert cli_main(args) == 0
    lines = {line.split()[0]: line.split()[1:] for line in capsys.readouterr().out.splitlines() if line.split()}
    assert float(lines["contact_area"][0]) == pytest.approx(AREA_M2, rel=1e-6) and lines["contact_area"][1] == "m²"
    assert lines["dx"][1] == "m"


def test_a_sized_sweeps_data_set_stores_metres_and_says_so(tmp_path):
    scene = {"shape": "rectangle", "aspect": 0.5, "G": G_PA, "a": A_M}
    spec = {"scene": scene, "numerics": {"accuracy": 1e-2}, "axes": {"nu": [0.3]}}
    path = hpcontact.run_sweep(spec, output=tmp_path / "sized.nc", stream=io.StringIO())
    with hpcontact.open_dataset(path) as ds:
        assert ds["contact_area"].attrs["units"] == "m2" and ds["dx"].attrs["units"] == "m"
        assert float(ds["contact_area"].squeeze()) == pytest.approx(AREA_M2, rel=1e-12)
        assert float(ds["dx"].squeeze()) == pytest.approx(2.0 * A_M / float(ds["nx"].squeeze()), rel=1e-12)
        assert ds.attrs["length_units"].startswith("m, areas m2")
