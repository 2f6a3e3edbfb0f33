"""References of the accuracy-versus-cost study (``postprocess/accuracy_cost.py``): closed forms
for the isotropic circle and unturned ellipses, Galin's exact cell for crystal and turned
ellipses, extrapolation over the study's finest grids for the square and thin rectangle, and
from coverage-weighted grids for polygons (K_a/K_b = 1 by symmetry)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hpcontact import accuracy
from hpcontact.discretizations import galin_ellipse
from hpcontact.scene import Scene
from hpcontact.sweep.accuracy_study import run_study

ROOT = Path(__file__).resolve().parents[3]
QUANTITIES = ("K_xx", "K_yy", "K_a_over_K_b", "K_zz")
CRYSTAL = {"shape": "ellipse", "aspect": 0.3, "anisotropy": 3.0, "orientation": 60.0}
TURNED = {"shape": "ellipse", "aspect": 0.5, "shape_angle": 40.0}


@pytest.fixture(scope="module")
def post():
    sys.path.insert(0, str(ROOT / "postprocess"))
    try:
        import accuracy_cost

        yield accuracy_cost
    finally:
        sys.path.remove(str(ROOT / "postprocess"))


def points(values_of_n, ns=(128, 192, 256, 384, 512, 768, 1024), nu=0.3):
    return [{"n": n, "na": n, "tol": 1e-10, "nu": nu, "time": 1.0, "iterations": 1, **values_of_n(n)} for n in ns]


@pytest.mark.parametrize("params", [CRYSTAL, TURNED], ids=["crystal", "turned"])
def test_crystal_and_turned_ellipses_are_measured_against_the_exact_cell(post, params):
    """The reference of a crystal or turned ellipse row is the exact cell's value: a grid value
    equal to it has error 0, one 1e-3 above has error 1e-3 (and the cell is Galin's solve)."""
    scene = Scene.from_params({**params, "nu": 0.3, "quantities": ["tangential", "normal"]})
    exact = galin_ellipse.solve(scene)
    assert post.reference_kind(params) == "exact cell"
    same = points(lambda n: {q: exact[q] for q in QUANTITIES})
    above = points(lambda n: {q: exact[q] * (1 + 1e-3) for q in QUANTITIES})
    cases = {"a": same, "b": above}
    notes = post.add_errors(cases, {"a": {**params, "nu": 0.3}, "b": {**params, "nu": 0.3}})
    assert notes["a"].startswith("exact cell")
    assert max(p["err"] for p in same) < 1e-15
    assert all(abs(p["err"] - 1e-3) < 1e-12 for p in above)
    record = accuracy.solve_to_accuracy(scene, 1e-6, strategy="auto")
    assert record["boundary"] == "galin" and record["grids"] == [1]


def test_isotropic_unturned_ellipses_keep_their_closed_forms(post):
    assert post.reference_kind({"shape": "ellipse", "aspect": 0.1}) == "closed form"
    assert post.reference_kind({"shape": "ellipse", "aspect": 0.1, "anisotropy": 1.0, "orientation": 60.0}) == (
        "closed form"
    )
    assert post.reference_kind({"shape": "circle", "shape_angle": 30.0}) == "closed form"
    assert post.reference_kind({"shape": "circle", "anisotropy": 3.0}) == "exact cell"
    assert post.reference_kind({"shape": "polygon", "sides": 3}) == "coverage"
    assert post.reference_kind({"shape": "rectangle", "aspect": 1.0}) == "extrapolated"


def test_a_square_row_is_extrapolated_over_its_finest_grids(post):
    """Grid values Q* + c h + d h² (h = 1/n, n ≥ 128; coarser grids off the expansion are left
    out): the reference recovers Q*, so every error is |c h + d h²|; the observed order is 1."""
    star = {"K_xx": 4.3, "K_yy": 4.31, "K_a_over_K_b": 4.3 / 4.31, "K_zz": 5.2}

    def values(n):
        h = 1.0 / n
        return {q: v * (1 - 0.9 * h + 3.0 * h**2) for q, v in star.items()}

    pts = points(values, ns=(32, 64, 128, 192, 256, 384, 512, 768, 1024))
    pts[0]["K_xx"] *= 1.1  # n = 32: not used by the fit
    notes = post.add_errors({"square": pts}, {"square": {"shape": "rectangle", "aspect": 1.0, "nu": 0.3}})
    assert notes["square"].startswith("extrapolated (reference uncertainty")
    for p in pts[1:]:
        h = 1.0 / p["n"]
        for q in star:
            assert p[f"err_{q}"] == pytest.approx(abs(-0.9 * h + 3.0 * h**2), rel=1e-6)
    err, order, n = post.observed_order(pts, "err_K_zz")
    assert n == 1024 and order == pytest.approx(1.0, abs=0.05)


def test_a_polygon_row_is_extrapolated_from_coverage_weighted_grids(post, monkeypatch):
    """A regular polygon's reference is ``solve_to_accuracy`` on coverage-weighted cells (here
    to 1e-3, four grids): extrapolated, not any one grid's value; K_a/K_b = 1 by symmetry."""
    monkeypatch.setattr(post, "POLYGON_REQUEST", 1e-3)
    params = {"shape": "polygon", "sides": 3, "nu": 0.3}
    assert post.reference_kind(params) == "coverage"
    reference, record = post.coverage_reference(params)
    assert len(record["grids"]) >= accuracy.MIN_GRIDS and record["boundary"] == "coverage"
    finest = record["levels"][-1]
    for q in ("K_xx", "K_yy", "K_zz"):
        assert reference[q] == record[q] != finest[q]
        assert abs(reference[q] / finest[q] - 1.0) > record["estimated_errors"][q]  # the extrapolation moved it
    assert reference["K_a_over_K_b"] == 1.0
    pts = points(lambda n: {q: reference[q] * (1 + 1e-3) for q in QUANTITIES}, ns=(64, 128))
    notes = post.add_errors({"triangle": pts}, {"triangle": params})
    assert notes["triangle"].startswith("extrapolated from coverage-weighted grids")
    assert post.short_reference(notes["triangle"]) == "extrapolated (coverage-weighted grids)"
    assert all(abs(p["err"] - 1e-3) < 1e-12 for p in pts)


def test_the_study_rows_parameters_come_from_the_stored_spec(post, tmp_path):
    """The data set of the study keeps its spec: each case's row (crystal, turned, polygon) is read back."""
    spec = tmp_path / "study.toml"
    spec.write_text(
        '[scene]\nquantities = ["tangential", "normal"]\nnu = 0.3\n[axes]\nshape = [\n'
        '  { label = "crystal ellipse b/a=0.3", shape = "ellipse", aspect = 0.3, anisotropy = 3.0, orientation = 60.0 },\n'
        '  { label = "turned ellipse b/a=0.5", shape = "ellipse", aspect = 0.5, shape_angle = 40.0 },\n'
        '  { label = "ellipse b/a=1e-4, 4 across", shape = "ellipse", aspect = 1e-4, n_across = 4 },\n'
        '  { label = "triangle", shape = "polygon", sides = 3 },\n]\nn = [16]\ntol = [1e-4]\n'
    )
    output = tmp_path / "study.nc"
    assert run_study([str(spec), "--output", str(output)]) == 0
    with xr.open_dataset(output) as ds:
        rows = post.case_params(ds.load())
    assert rows["crystal ellipse b/a=0.3"] == {"nu": 0.3, "quantities": ["tangential", "normal"], **CRYSTAL}
    assert rows["turned ellipse b/a=0.5"]["shape_angle"] == 40.0
    assert rows["ellipse b/a=1e-4"] == {
        "nu": 0.3,
        "quantities": ["tangential", "normal"],
        "shape": "ellipse",
        "aspect": 1e-4,
    }
    assert post.reference_kind(rows["triangle"]) == "coverage"
    assert np.isfinite(rows["triangle"]["nu"])
