"""Units in a solve's record (issue 42 item 4): ``hpcontact.solve`` and ``hpcontact solve --json``
carry a ``units`` mapping, the text output writes the same units, and a sweep's data set names
the same unit for the same quantity (one table: ``hpcontact.sweep.data.attributes``)."""

from __future__ import annotations

import io
import json
import re

import cf_units
import pytest

import hpcontact
from hpcontact.cli import main as cli_main
from hpcontact.quantities import in_newtons_per_metre
from hpcontact.sweep.data.units import SCALE_SYMBOLS, scale_symbols

SMALL = ("--n", "8")


def _json(capsys, *args: str) -> dict:
    assert cli_main(["solve", *args, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _text_units(capsys, *args: str) -> dict[str, str]:
    """The unit each line of the text output writes after its value ("" for none)."""
    assert cli_main(["solve", *args]) == 0
    out = capsys.readouterr().out
    units = {}
    for line in out.splitlines():
        words = line.split()
        if len(words) >= 2 and words[0] != "units" and "." not in words[0]:
            units[words[0]] = " ".join(words[2:])
    return units


def test_a_crystal_with_a_contact_size_is_in_newtons_per_metre(capsys):
    record = _json(capsys, "--material", "Cu", "--a", "2e-3", *SMALL)
    units = record["units"]
    for key in ("K_xx", "K_xy", "K_yx", "K_yy", "K_max", "K_min"):
        assert units[key] == "N m-1", key
        assert cf_units.Unit(units[key]).is_convertible(cf_units.Unit("N/m"))
    assert units["principal_angle_deg"] == "degree" and units["wall_time_s"] == "s"
    for key in ("K_a_over_K_b", "K_min_over_K_max", "asymmetry", "iterations", "residual", "nx"):
        assert units[key] == "1", key
    # the same scene without a: in GPa a, and a times 1e9 Pa/GPa from N/m
    plain = hpcontact.solve(material="Cu", n=8)
    assert plain["units"]["K_xx"] == "GPa a"
    assert record["K_xx"] == pytest.approx(plain["K_xx"] * 2e-3 * 1e9, rel=1e-12)


def test_an_isotropic_body_is_in_units_of_G_a_and_ratios_are_1():
    record = hpcontact.solve(shape="ellipse", aspect=0.5, nu=0.3, quantities="tangential,normal", n=8)
    units = record["units"]
    assert {units[k] for k in ("K_xx", "K_yy", "K_zz", "K_max", "K_min")} == {"G a"}
    assert {units[k] for k in ("K_a_over_K_b", "K_min_over_K_max", "normalized_xx", "normalized_yy")} == {"1"}
    assert units["dx"] == "a"
    assert "principal_angle_note" not in units and "plan" not in units  # text has no unit
    # constants in GPa (no library name) are GPa too, as Scene.newtons_per_metre counts them
    assert hpcontact.solve(cubic="C11=168 C12=121 C44=75", n=8)["units"]["K_xx"] == "GPa a"


def test_every_unit_is_udunits_or_a_product_of_the_scene_scales():
    """A unit without a scale symbol parses with cf-units (UDUNITS); one with a scale is a
    product of powers of G, a, L, F and UDUNITS units (GPa, N, m)."""
    records = [
        hpcontact.solve(material="Cu", a=1e-3, n=8),
        hpcontact.solve(shape="polygon", nu=0.3, accuracy=1e-2),
        hpcontact.solve(quantities="indentation", radius=1.0, depth=0.01, n=16),
        hpcontact.solve(
            quantities="slip", radius=0.01, load=100.0, mu=0.3, q_ratio=0.5, material="steel", n=16, steps=1
        ),
        hpcontact.solve(quantities="slip", radius=1.0, load=1.0, mu=0.3, q_ratio=0.5, n=16, steps=1),
    ]
    seen = set()
    for record in records:
        for key, unit in record["units"].items():
            assert key in record, key
            if scale_symbols(unit):
                rest = [w for w in unit.split() if re.sub(r"-?\d+$", "", w) not in SCALE_SYMBOLS]
                assert all(not cf_units.Unit(w).is_unknown() for w in rest), (key, unit)
            else:
                assert not cf_units.Unit(unit).is_unknown(), (key, unit)
            seen.add(unit)
    assert {"N m-1", "G a", "G L2", "L2", "F L-1", "m2", "N", "byte", "degree", "s", "1"} <= seen


def test_the_text_output_writes_the_units_of_the_record(capsys):
    for args in (
        ("--material", "Cu", "--a", "2e-3", *SMALL),
        ("--shape", "ellipse", "--aspect", "0.5", "--quantities", "tangential,normal", *SMALL),
        ("--quantities", "indentation", "--radius", "1", "--depth", "0.01", "--n", "16"),
        (
            "--quantities",
            "slip",
            "--radius",
            "0.01",
            "--load",
            "100",
            "--mu",
            "0.3",
            "--q-ratio",
            "0.5",
            "--n",
            "16",
            "--steps",
            "1",
        ),
    ):
        record = _json(capsys, *args)
        text = _text_units(capsys, *args)
        written = {
            "N m-1": "N/m",
            "G a": "G·a",
            "GPa a": "GPa·a",
            "a": "a",
            "L": "L",
            "m": "m",
            "N": "N",
            "m2": "m²",
            "L2": "L²",
            "G L2": "G·L²",
            "G": "G",
            "F": "F",
            "F L-1": "F/L",
            "degree": "deg",
            "s": "s",
            "1": "",
        }
        for key, unit in record["units"].items():
            assert text[key] == written[unit], (args, key, unit, text[key])
        for key in text.keys() - record["units"].keys():  # numbers without a unit in the record: none in text
            if isinstance(record[key], (int, float)) and not isinstance(record[key], bool):
                assert text[key] == "", (args, key)


def test_a_sweep_names_the_unit_the_record_names(tmp_path):
    """The data set of a sweep over the same scene states, for every stored quantity, the unit
    the record states (as CF ``units``, or as ``scale`` where it is a scale of the scene)."""
    scene = {"shape": "ellipse", "material": "Cu", "a": 2e-3}
    spec = {"scene": scene, "numerics": {"n": 8}, "axes": {"aspect": [0.5]}}
    path = hpcontact.run_sweep(spec, output=tmp_path / "units.nc", stream=io.StringIO())
    record = hpcontact.solve(**scene, aspect=0.5, n=8)
    compared = 0
    with hpcontact.open_dataset(path) as ds:
        for key, unit in record["units"].items():
            if key in ds.data_vars:
                attrs = ds[key].attrs
                assert attrs.get("scale", attrs.get("units")) == unit, (key, unit, attrs)
                compared += 1
    assert compared >= 10


def test_the_levels_of_a_sized_scene_are_in_newtons_per_metre_too():
    """``levels`` repeat the record's keys per grid, in its units: ``in_newtons_per_metre``
    scales their stiffnesses as the record's (and no ratio); a sized solve's finest level is
    within its discretization error (a few % at an accuracy of 1e-2) of its extrapolated N/m."""
    record = {"K_xx": 2.0, "K_a_over_K_b": 0.5, "levels": [{"K_xx": 1.5, "K_a_over_K_b": 0.4, "iterations": 3}]}
    scaled = in_newtons_per_metre(record, 26e6)
    assert scaled["K_xx"] == 2.0 * 26e6 and scaled["K_a_over_K_b"] == 0.5
    assert scaled["levels"] == [{"K_xx": 1.5 * 26e6, "K_a_over_K_b": 0.4, "iterations": 3}]
    sized = hpcontact.solve(shape="polygon", nu=0.3, G=26e9, a=1e-3, accuracy=1e-2)
    assert sized["units"]["K_xx"] == "N m-1"
    assert abs(sized["levels"][-1]["K_xx"] / sized["K_xx"] - 1.0) < 0.05


def test_a_missed_request_keeps_its_record_in_the_units_it_names(monkeypatch):
    """``AccuracyNotMet.record`` (the grids reached) is in N/m with ``a``, as a met request's,
    and carries ``units``: the unsized record's stiffness times G a. The two solves differ only
    by G, under a CG tolerance of 1e-10 (accuracy/100): they agree far inside 1e-6."""
    from hpcontact import accuracy as acc

    monkeypatch.setattr(
        acc.solve_to_accuracy, "__kwdefaults__", {**acc.solve_to_accuracy.__kwdefaults__, "max_cells": 64 * 64, "n0": 8}
    )
    G, a = 26e9, 1e-3
    caught = []
    for sized in ({}, {"G": G, "a": a}):
        with pytest.raises(acc.AccuracyNotMet) as info:
            hpcontact.solve(shape="polygon", nu=0.3, accuracy=1e-8, **sized)
        caught.append(info.value.record)
    plain, sized = caught
    assert plain["units"]["K_xx"] == "G a" and sized["units"]["K_xx"] == "N m-1"
    assert sized["K_xx"] == pytest.approx(plain["K_xx"] * G * a, rel=1e-6)
    assert sized["estimated_error"] == pytest.approx(plain["estimated_error"], rel=1e-3)
