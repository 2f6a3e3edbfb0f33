"""``hpcontact show FILE`` (hpcontact.sweep.data.show): the summary of real sweep data sets — a plain
sweep, an adaptive map, one with a failed task — its numbers read back from the data set, the
same as JSON, and a bad file in one line with exit status 2. Also the citation the docs give
(docs/index.md, "Cite") against CITATION.cff.

The sweeps solve with a stand-in for the solver: Mindlin's bonded ellipse (hpcontact.analytic)
with a relative error estimate that varies over the points, so that the worst one has a place.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hpcontact import __version__, open_dataset
from hpcontact.analytic import mindlin_ellipse_stiffness
from hpcontact.cli import main
from hpcontact.sweep.data.show import summarize, summary

ROOT = Path(__file__).resolve().parents[3]

PLAIN = """
[sweep]
title = "show test"
progress_interval = 100.0
[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
accuracy = 1e-3
[axes]
aspect = { logspace = [0, -2, 3] }
nu = { linspace = [0, 0.5, 3] }
angle = { linspace = [0, 180, 5] }
"""
ADAPTIVE = (
    PLAIN.replace('"show test"', '"show test, adaptive"')
    .replace("[0, -2, 3]", "[0, -4, 33]")
    .replace("[0, 0.5, 3]", "[0, 0.5, 5]")
    + "[adaptive]\ntolerance = 1e-2\nchecks = 4\n"
)


def mindlin(params):
    """Mindlin's ellipse as a solve to accuracy 1e-3 reports it: errors 1e-4 (b/a = 1, nu = 0)
    ... 3e-4 (b/a = 0.01, nu = 0.5) ... 5e-4 (b/a = 1e-4, nu = 0.5)."""
    aspect, nu = float(params["aspect"]), float(params["nu"])
    ka, kb = (float(k) for k in mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu))
    error = 1e-4 * (1.0 + 2.0 * nu - 0.5 * math.log10(aspect))
    record = {"K_xx": ka, "K_yy": kb, "K_xy": 0.0, "K_yx": 0.0, "K_max": kb, "K_min": ka, "K_a_over_K_b": ka / kb}
    record.update({f"{name}_error": error for name in list(record)})
    record.update(estimated_error=error, accuracy_met="true", iterations=5)
    return record


def fails_once(params):
    if math.isclose(float(params["aspect"]), 0.1) and math.isclose(float(params["nu"]), 0.25):
        raise RuntimeError("this scene fails")
    return mindlin(params)


def show(capsys, *args) -> tuple[int, str, str]:
    code = main(["show", *map(str, args)])
    out, err = capsys.readouterr()
    return code, out, err


def at(ds: xr.Dataset, var: xr.DataArray) -> str:
    """ "aspect=0.01, nu=0.5" for the point of ``var``'s largest value, as the summary prints it."""
    index = np.unravel_index(int(np.nanargmax(var.values)), var.shape)
    return ", ".join(f"{d}={ds[d].values[i]:.4g}" for d, i in zip(var.dims, index) if ds.sizes[d] > 1)


@pytest.fixture
def plain(sweep, write_spec) -> Path:
    return sweep(write_spec(PLAIN), mindlin)


def test_the_summary_of_a_plain_sweep_states_its_axes_counts_worst_errors_and_provenance(plain, capsys):
    code, out, err = show(capsys, plain)
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert lines[0] == "show test"
    with open_dataset(plain) as ds:
        assert re.search(r"^  aspect +3  0\.01 … 1  \(aspect ratio b/a of the contact\)$", out, re.M)
        assert re.search(r"^  nu +3  0 … 0\.5  \(Poisson ratio\)$", out, re.M)
        assert re.search(r"^  angle +5  0 … 180 degree  \(direction", out, re.M)
        assert "  fixed: shape = ellipse, accuracy = 0.001" in lines
        assert re.search(r"^  K_max K_min K_xx K_xy K_yx K_yy K_nn  \[G a\]$", out, re.M)
        tasks = int(ds.attrs["sweep_tasks"])
        assert (
            f"  9 points (aspect × nu), {tasks} tasks ({tasks} run, 0 reused), {tasks} solves (one per task)" in lines
        )
        assert "  failures: 0" in lines
        header = "estimated relative errors (worst; requested accuracy 0.001)"
        assert header in lines
        for name in ["K_xx", "K_yy", "K_a_over_K_b", "K_nn"]:
            error = ds[f"{name}_error"]
            worst = float(error.max())
            line = next(line for line in lines[lines.index(header) :] if line.startswith(f"  {name} "))
            assert line.split()[1] == f"{worst:.2e}", name  # the data set's max, to the printed precision
            assert line.endswith(f"at {at(ds, error)}"), name
        assert re.search(r"^  K_xx +3\.00e-04  at aspect=0\.01, nu=0\.5$", out, re.M)  # the stand-in's worst point
        assert "  points: 9 met, 0 not_met, 0 no_estimate" in lines
        assert "adaptive map" not in out
        provenance = lines[lines.index("provenance") + 1]
        assert provenance == (
            f"  hpcontact {__version__}, git {ds.attrs['git_revision']}, created {ds.attrs['created']}, MPI size 1"
        )


def test_a_sweep_without_a_request_is_held_to_the_defaults_target(sweep, write_spec, capsys):
    """No ``accuracy`` in the spec: every point solved to the default's 1e-4 (its records'
    ``accuracy``), which the header names and each worst error over it is flagged against."""

    def default(params):
        record = mindlin(params)
        error = 2e-4 if float(params["nu"]) == 0.5 else 5e-5  # the grids' default missed 1e-4 at nu = 0.5
        record.update({k: error for k in record if k.endswith("_error")}, estimated_error=error, accuracy=1e-4)
        return record

    path = sweep(write_spec(PLAIN.replace("[numerics]\naccuracy = 1e-3\n", "")), default)
    code, out, _ = show(capsys, path)
    assert code == 0
    assert "estimated relative errors (worst; no accuracy requested: the default's target 0.0001)" in out
    assert re.search(r"^  K_xx +2\.00e-04  at .*\(above that target\)$", out, re.M)
    with open_dataset(path) as ds:
        assert summarize(ds)["errors"]["default_target"] == 1e-4


def test_the_summary_of_an_adaptive_map_states_its_map_errors_tolerance_and_solves(sweep, write_spec, capsys):
    path = sweep(write_spec(ADAPTIVE), mindlin)
    code, out, err = show(capsys, path)
    assert code == 0 and err == ""
    lines = out.splitlines()
    with open_dataset(path) as ds:
        solves, checks = int(ds.attrs["sweep_solves"]), int(ds.attrs["adaptive_check_points"])
        assert 0 < solves < 165 / 2 and checks >= 4 and ds.attrs["adaptive_met"] == 1
        assert f"  165 points (aspect × nu), 165 tasks ({solves} run, 0 reused), {solves} solves" in lines
        assert "adaptive map (tolerance 0.01: met)" in lines
        rounds = int(ds.attrs["adaptive_rounds"])
        assert int(ds["solved"].sum()) == solves  # no two points share a scene here
        assert (
            f"  {solves} solves for 165 points; {checks} random check points, estimate factor 1.5; {rounds} rounds"
            in lines
        )
        refined = ds.attrs["adaptive_quantities"].split()
        map_lines = [line for line in lines if "map error" in line]
        assert len(map_lines) == len(refined)
        for name in refined:
            error = ds[f"{name}_map_error"]
            line = next(line for line in map_lines if line.split()[0] == name)
            assert line.split()[3] == f"{float(error.max()):.2e}", name
            assert line.endswith(f"at {at(ds, error)}"), name
    result = summarize(open_dataset(path))
    assert result["adaptive"]["solves"] == solves and result["adaptive"]["met"] is True
    assert max(w["error"] for w in result["adaptive"]["worst"].values()) == pytest.approx(
        ds.attrs["adaptive_max_map_error"], rel=1e-12
    )


def test_a_failed_task_is_counted_with_its_point_and_message(sweep, write_spec, capsys):
    path = sweep(write_spec(PLAIN), fails_once)
    code, out, err = show(capsys, path)
    assert code == 0 and err == ""
    lines = out.splitlines()
    assert "  failures: 1 (1 error)" in lines
    assert "    aspect=0.1, nu=0.25: error: RuntimeError: this scene fails" in lines
    assert "  points: 8 met, 0 not_met, 1 no_estimate" in lines
    with open_dataset(path) as ds:
        assert int(ds.attrs["sweep_failures"]) == 1
        assert summary(ds) == out.rstrip("\n").replace(f"\n  file {path}", "", 1)  # summary(ds) names no file


def test_json_is_the_same_summary_in_one_object(plain, capsys):
    code, out, err = show(capsys, plain, "--json")
    assert code == 0 and err == ""
    assert len(out.strip().splitlines()) == 1
    result = json.loads(out)
    with open_dataset(plain) as ds:
        assert result == json.loads(json.dumps(summarize(ds, str(plain))))
        assert result["points"] == 9 and result["failures"]["count"] == 0 and result["adaptive"] is None
        assert [a["name"] for a in result["axes"]] == ["aspect", "nu", "angle"]
        for name, worst in result["errors"]["worst"].items():
            assert worst["error"] == float(ds[f"{name}_error"].max()), name  # every digit
        assert result["errors"]["requested_accuracy"] == 1e-3
        assert result["provenance"]["git_revision"] == ds.attrs["git_revision"]
        assert result["provenance"]["mpi_size"] == 1


@pytest.mark.parametrize(
    ("case", "reason"),
    [
        ("missing", "no such file"),
        ("text", "not a netCDF file (NetCDF: Unknown file format)"),
        ("not a sweep", "not a sweep data set: no status variable"),
        ("directory", "is a directory, not a data set"),
        ("damaged", "variable K_xx is damaged"),
    ],
)
def test_a_bad_file_is_one_line_naming_it_and_exit_2(sweep, case, reason, tmp_path, write_spec, capsys, damage):
    path = tmp_path / "results.nc"
    if case == "text":
        path.write_text("K_xx = 1.0\n", encoding="utf-8")
    elif case == "not a sweep":
        xr.Dataset({"K_xx": ("nu", np.ones(3))}, coords={"nu": [0.0, 0.25, 0.5]}).to_netcdf(path, engine="netcdf4")
    elif case == "directory":
        path.mkdir()
    elif case == "damaged":
        path = sweep(write_spec(PLAIN), mindlin)
        damage(path, "K_xx")
    code, out, err = show(capsys, path)
    assert code == 2 and out == ""
    assert len(err.splitlines()) == 1 and err.startswith(f"hpcontact show: {path}: {reason}"), err


def test_the_command_exits_2_without_a_traceback(tmp_path):
    path = tmp_path / "missing.nc"
    done = subprocess.run(
        [sys.executable, "-m", "hpcontact", "show", str(path)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr == f"hpcontact show: {path}: no such file\n"


def test_the_bibtex_entry_in_the_docs_has_the_fields_of_citation_cff():
    """docs/index.md's "Cite" gives a BibTeX entry made from CITATION.cff: the same title,
    version, author and year; a DOI or URL only where the CFF has one."""
    cff = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    field = {key: value.strip().strip('"') for key, value in re.findall(r"^([a-z-]+): *(.*)$", cff, re.M)}
    assert field["cff-version"] == "1.2.0" and field["message"] and field["title"] and "authors:" in cff
    assert field["version"] == __version__
    author = re.search(r"^  - name: \"(.*)\"$", cff, re.M).group(1)
    index = (ROOT / "docs" / "index.md").read_text(encoding="utf-8")
    bib = re.search(r"```bibtex\n(@software\{.*?\n\})\n```", index, re.S).group(1)
    entry = dict(re.findall(r"^  (\w+) *= \{(.*)\},?$", bib, re.M))
    assert entry["title"] == field["title"]
    assert entry["version"] == field["version"]
    assert entry["author"] == f"{{{author}}}"  # braced: an organisation, not a person's name
    assert entry["year"] == field["date-released"][:4]
    for key in ("doi", "url"):
        assert (key in entry) == (key in field), key
