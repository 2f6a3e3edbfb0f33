"""Figure scripts on a hostile stamp or a data set of another sweep (issue 43 item 6, found again
by benchmarks/fault_table.py): a stamp that is a deep JSON array is no stamp (was: RecursionError),
a folder in place of the stamp is refused in one line before anything is drawn (was:
IsADirectoryError after the drawing), and a script whose sweep is another refuses the data set
in one line, naming what it lacks, before it solves or draws anything (tembleque2011_friction.py
solved line contacts for a minute, drew two figures, then raised KeyError: 'pair')."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def freshness(monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    import freshness

    return freshness


def test_a_stamp_that_is_a_deep_json_array_is_no_stamp(freshness, tmp_path):
    path = freshness.stamp_path("anisotropy_map.py", tmp_path)
    path.write_text("[" * 100_000 + "]" * 100_000)
    freshness.exit_if_fresh("anisotropy_map.py", ["data.nc", str(tmp_path)])  # returns: draw


def test_a_stamp_larger_than_any_stamp_is_not_read(freshness, tmp_path, monkeypatch):
    path = freshness.stamp_path("anisotropy_map.py", tmp_path)
    path.write_text(" " * (freshness.MAX_STAMP_BYTES + 1) + "{}")

    def never(*args, **kwargs):
        raise AssertionError("the stamp was parsed")

    monkeypatch.setattr(freshness.json, "loads", never)
    freshness.exit_if_fresh("anisotropy_map.py", ["data.nc", str(tmp_path)])


def test_a_folder_in_place_of_the_stamp_is_refused_before_drawing(freshness, tmp_path, capsys):
    path = freshness.stamp_path("anisotropy_map.py", tmp_path)
    path.mkdir()
    drawn = []
    with pytest.raises(SystemExit) as stop:
        with freshness.stamp("anisotropy_map.py", tmp_path, [], argv=["data.nc", str(tmp_path)]):
            drawn.append(True)
    assert stop.value.code == 2 and drawn == [] and path.is_dir()
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and "stamp" in lines[0], lines


def tangential_sweep(path: Path) -> Path:
    """A tangential sweep's data set: K over shape x b/a, none of the variables of the pair,
    crystal or sphere sweeps."""
    aspects = np.array([1.0, 0.5])
    k = np.ones((1, 2))
    xr.Dataset(
        {
            "status": (("shape", "aspect"), np.zeros((1, 2), dtype=np.int32)),
            **{name: (("shape", "aspect"), k) for name in ("K_xx", "K_yy", "K_xy", "K_yx")},
        },
        coords={"shape": ["ellipse"], "aspect": aspects},
    ).to_netcdf(path, engine="netcdf4")
    return path


@pytest.mark.parametrize(
    "name, says",
    [
        ("tembleque2011_friction.py", "pair"),
        ("crystal_friction_map.py", "material"),
        ("slip_stiffness.py", "q_ratio"),
        ("orientation_map.py", "anisotropy"),
        ("accuracy_cost.py", "n"),
    ],
)
def test_a_data_set_of_another_sweep_is_refused_before_anything_is_drawn(tmp_path, name, says):
    data = tangential_sweep(tmp_path / "t.nc")
    done = subprocess.run(
        [sys.executable, str(ROOT / "postprocess" / name), str(data), str(tmp_path / "fig")],
        capture_output=True,
        text=True,
        env={**os.environ, "MPLBACKEND": "Agg"},
        timeout=120,
    )
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr
    assert str(data) in lines[0] and "missing: " in lines[0] and says in lines[0], lines
    assert not list((tmp_path / "fig").glob("*.png"))
