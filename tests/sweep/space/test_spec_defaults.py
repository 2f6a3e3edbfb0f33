"""Where a spec without ``[sweep] output`` writes and what a spec without a title is called
(issue 42 item 6), end to end: a file's output beside it, a dict's in ``results/`` under the
working folder with a title from its axes; ``hpcontact.run_sweep(dict)`` without an output runs."""

from __future__ import annotations

import io
from pathlib import Path

import xarray as xr

import hpcontact
from hpcontact.sweep.space.parse import load_spec, parse_spec_dict
from hpcontact.sweep.space.spec import DICT_OUTPUT_FOLDER

SPEC = '[scene]\nshape = "circle"\nquantities = ["tangential"]\n[numerics]\nn = 16\n[axes]\nnu = [0.2, 0.3]\n'
DICT = {"scene": {"shape": "circle", "quantities": ["tangential"]}, "numerics": {"n": 16}, "axes": {"nu": [0.2, 0.3]}}


def test_a_spec_file_without_an_output_writes_beside_itself(tmp_path, monkeypatch):
    folder = tmp_path / "specs"
    folder.mkdir()
    (folder / "acc.toml").write_text(SPEC)
    monkeypatch.chdir(tmp_path)
    spec = load_spec(folder / "acc.toml", check_scenes=False)
    assert spec.output == folder / "acc.nc" and spec.journal == folder / "acc.nc.journal"
    assert spec.title == "acc"


def test_a_dict_spec_is_titled_by_its_axes_and_runs_without_an_output(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    spec = parse_spec_dict(DICT, check_scenes=False)
    assert spec.title == "sweep over nu (2 points)" and spec.output.parent == DICT_OUTPUT_FOLDER
    stream = io.StringIO()
    path = Path(hpcontact.run_sweep(DICT, stream=stream))
    assert path.resolve() == (tmp_path / spec.output).resolve() and path.is_file()
    assert f"writes {spec.output}" in stream.getvalue().splitlines()[0]  # the first line names it
    with xr.open_dataset(path) as ds:
        assert ds.attrs["title"] == "sweep over nu (2 points)"
    assert not list(tmp_path.glob("*.nc"))  # nothing in the working folder itself
