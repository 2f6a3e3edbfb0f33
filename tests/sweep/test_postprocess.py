"""The post-processing scripts run on a sweep data set and write their PNGs."""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.schedule import SerialTeam

ROOT = Path(__file__).resolve().parents[2]
SPEC = """
[scene]
quantities = ["tangential", "normal"]
[axes]
shape = ["ellipse", { label = "hexagon", shape = "polygon", sides = 6 }]
aspect = [1.0, 0.1, 0.01]
nu = [0.1, 0.3, 0.5]
angle = { linspace = [0, 180, 7] }
"""


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, fake_solve) -> Path:
    folder = tmp_path_factory.mktemp("post")
    spec = folder / "spec.toml"
    spec.write_text(SPEC)
    return run_sweep(
        spec, output=folder / "sweep.nc", task_function=fake_solve, team=SerialTeam(), stream=io.StringIO()
    )


@pytest.mark.parametrize(
    ("script", "figures"),
    [
        ("anisotropy_map.py", ["anisotropy_curves.png", "anisotropy_map_ellipse.png"]),
        ("polar.py", ["polar.png", "knn_vs_angle.png"]),
        ("tensor_components.py", ["tensor_components_ellipse.png", "tensor_components_hexagon.png"]),
    ],
)
def test_script_writes_its_figures(script, figures, dataset, tmp_path):
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "MPLBACKEND": "Agg"}
    done = subprocess.run(
        [sys.executable, str(ROOT / "postprocess" / script), str(dataset), str(tmp_path / "fig")],
        env=env, capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 0, done.stderr
    for name in figures:
        path = tmp_path / "fig" / name
        assert path.stat().st_size > 10_000, name
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
