"""Figure scripts on data sets they cannot draw as they are (issue 43 item 6): each ends with a
figure of what the data set holds or one line on stderr and exit status 2, never a traceback,
never an empty figure as success. The data sets are built here with xarray: the scripts read
any netCDF that holds a sweep's variables."""

from __future__ import annotations

import os
import runpy
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

ROOT = Path(__file__).resolve().parents[2]
ASPECTS = np.array([1.0, 0.3, 0.1, 0.03, 0.01])
ANGLES = np.linspace(0.0, 180.0, 7)


@dataclass(frozen=True)
class Ran:
    """How a script ended: its exit status and what it wrote on stderr."""

    returncode: int
    stderr: str


def command(name: str, *args: object) -> Ran:
    """Run ``postprocess/<name>`` as from the command line (``--force``: no stamp shortcut)."""
    done = subprocess.run(
        [sys.executable, str(ROOT / "postprocess" / name), *map(str, args), "--force"],
        capture_output=True,
        text=True,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    return Ran(done.returncode, done.stderr)


@pytest.fixture
def script(monkeypatch, capsys):
    """Run ``postprocess/<name>`` in this process as ``__main__`` (``runpy``, as
    tests/sweep/test_postprocess.py does; ``command`` runs one as a command, and that file each
    drawing script): its exit status (0 when it returns, a ``SystemExit``'s code otherwise) and
    stderr. Any other exception, a traceback from the command line, fails the test."""
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))

    def run(name: str, *args: object) -> Ran:
        path = ROOT / "postprocess" / name
        monkeypatch.setattr(sys, "argv", [str(path), *map(str, args), "--force"])
        capsys.readouterr()
        try:
            runpy.run_path(str(path), run_name="__main__")
            status = 0
        except SystemExit as stop:
            status = 0 if stop.code is None else stop.code if isinstance(stop.code, int) else 1
        return Ran(status, capsys.readouterr().err)

    return run


def refused(done: Ran, *says: str) -> None:
    """Exit 2 and one line on stderr that says each of ``says``."""
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1 and all(s in lines[0] for s in says), lines


def sweep(path: Path, shapes: list[str], ratio=None, spec: str = "") -> Path:
    """A tangential sweep over shape × aspect (× angle) with no nu axis; K_a/K_b = (b/a)^0.05
    (or ``ratio``, NaN for failed tasks); ``spec`` the text stored as the spec."""
    dims = ("shape", "aspect")
    k_a = np.ones((len(shapes), len(ASPECTS)))
    k_b = k_a / ASPECTS**0.05
    ratio = k_a / k_b if ratio is None else np.broadcast_to(ratio, k_a.shape)
    turn = np.radians(ANGLES)
    k_nn = k_a[..., None] * np.cos(turn) ** 2 + k_b[..., None] * np.sin(turn) ** 2
    if not np.isfinite(ratio).any():
        k_a, k_b, k_nn = k_a * np.nan, k_b * np.nan, k_nn * np.nan
    zero = np.zeros_like(k_a)
    ds = xr.Dataset(
        {
            "status": (dims, np.zeros(k_a.shape, dtype=np.int32)),
            "K_a_over_K_b": (dims, ratio),
            **{
                n: (dims + ("angle",), np.repeat(v[..., None], len(ANGLES), -1))
                for n, v in (("K_xx", k_a), ("K_yy", k_b), ("K_xy", zero), ("K_yx", zero))
            },
            "K_nn": (dims + ("angle",), k_nn),
        },
        coords={"shape": shapes, "aspect": ASPECTS, "angle": ANGLES},
        attrs={"spec": spec},
    )
    ds.to_netcdf(path, engine="netcdf4")
    return path


@pytest.fixture
def common(monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    import common

    return common


def test_a_sweep_without_a_nu_axis_draws_its_curves(script, tmp_path):
    """No nu axis (nu fixed by the scene): the curves at that nu (KeyError: 'nu' before)."""
    done = script("anisotropy_map.py", sweep(tmp_path / "s.nc", ["ellipse"]), tmp_path / "fig")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "fig" / "anisotropy_curves.png").stat().st_size > 0


def test_nu_is_found_where_the_data_set_keeps_it(common, tmp_path):
    """Swept: its values; fixed in the spec's [scene]: that value; neither: the engine's default."""
    from hpcontact import fields

    swept = xr.Dataset(coords={"nu": [0.1, 0.4]})
    np.testing.assert_array_equal(common.parameter_values(swept, "nu"), [0.1, 0.4])
    fixed = xr.Dataset(attrs={"spec": "[scene]\nnu = 0.25\n[axes]\naspect = [1.0]\n"})
    np.testing.assert_array_equal(common.parameter_values(fixed, "nu"), [0.25])
    np.testing.assert_array_equal(common.parameter_values(xr.Dataset(), "nu"), [fields.field("nu").default])


def test_a_one_dimensional_adaptive_map_is_drawn(tmp_path):
    """An adaptive map along b/a alone: its curve with the solved points (KeyError: No variable
    named None before)."""
    values = ASPECTS**0.05
    ds = xr.Dataset(
        {
            "status": ("aspect", np.zeros(len(ASPECTS), dtype=np.int32)),
            "K_a_over_K_b": ("aspect", values),
            "K_a_over_K_b_map_error": ("aspect", np.full(len(ASPECTS), 1e-4)),
            "solved": ("aspect", np.array([1, 0, 1, 0, 1], dtype=np.int8)),
        },
        coords={"aspect": ASPECTS},
    )
    ds.to_netcdf(tmp_path / "a.nc", engine="netcdf4")
    done = command("adaptive_points.py", tmp_path / "a.nc", tmp_path / "fig")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "fig" / "adaptive_points.png").stat().st_size > 0


@pytest.mark.parametrize(
    "name, variable", [("anisotropy_map.py", "K_a_over_K_b"), ("polar.py", "K_nn"), ("tensor_components.py", "K_xx")]
)
def test_all_nan_data_is_refused_naming_the_variable(script, tmp_path, name, variable):
    """Every task failed: no figure (tensor_components drew empty panels, exit 0; polar raised
    ValueError on NaN axis limits)."""
    data = sweep(tmp_path / "nan.nc", ["ellipse"], ratio=np.nan)
    refused(script(name, data, tmp_path / "fig"), str(data), variable, "no finite value")
    assert not list((tmp_path / "fig").glob("*.png"))


def test_a_slash_in_a_shape_label_stays_in_the_file_name(script, tmp_path):
    """A label "a/b" made the file name a path into a folder that does not exist."""
    done = script("tensor_components.py", sweep(tmp_path / "s.nc", ["a/b"]), tmp_path / "fig")
    assert done.returncode == 0, done.stderr
    assert [p.name for p in (tmp_path / "fig").glob("*.png")] == ["tensor_components_a_b.png"]


def test_a_figure_folder_that_cannot_be_made_is_refused(script, tmp_path):
    """The figure folder is a file: one line naming it, exit 2."""
    (tmp_path / "fig").write_text("a file\n")
    refused(script("polar.py", sweep(tmp_path / "s.nc", ["ellipse"]), tmp_path / "fig"), "fig", "figure folder")


def test_a_figure_that_cannot_be_written_is_refused(common, tmp_path, monkeypatch):
    """``save`` on a write that fails (a read-only folder, a full disk): one line, exit 2 (as
    root, whom permissions do not stop, the failure is made by the figure)."""
    import matplotlib.pyplot as plt

    fig = plt.figure()

    def fail(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(fig, "savefig", fail)
    with pytest.raises(SystemExit) as stop:
        common.save(fig, tmp_path, "x.png")
    assert stop.value.code == 2
    plt.close(fig)
