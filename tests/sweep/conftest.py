"""Shared helpers of the sweep tests: specs written to a temporary folder, fake solvers and a
sweep run in this process alone."""

from __future__ import annotations

import io
import socket
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, TextIO

import pytest

from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run.schedule import SerialTeam


def _fake_solve(params: Mapping[str, Any]) -> dict[str, Any]:
    """A cheap stand-in for ``hpcontact.problems.contact.solve``: a smooth, shape-dependent tensor."""
    nu = float(params.get("nu", 0.3))
    aspect = float(params.get("aspect", 1.0))
    turn = float(params.get("shape_angle", 0.0))
    sides = float(params.get("sides", 0.0))
    k_a = (1.0 + nu) * (1.0 + 0.01 * sides)
    k_b = k_a / aspect**0.05
    return {
        "K_xx": k_a,
        "K_xy": 1e-3 * turn,
        "K_yx": 1e-3 * turn,
        "K_yy": k_b,
        "K_zz": 2.0 * k_a,
        "K_a_over_K_b": k_a / k_b,
        "normalized_xx": 0.5,
        "normalized_yy": 0.5 * k_b / k_a,
        "iterations": 7,
        "plan": {"kernels": ["xx", "yy"], "solves": 2},
    }


@pytest.fixture
def write_spec(tmp_path: Path) -> Callable[[str], Path]:
    """Write spec text to ``tmp_path/spec.toml`` (output defaults inside ``tmp_path``)."""

    def write(text: str, name: str = "spec.toml") -> Path:
        if "output" not in text:
            text = (
                f'[sweep]\noutput = "{tmp_path / "out.nc"}"\n' + text
                if "[sweep]" not in text
                else text.replace("[sweep]", f'[sweep]\noutput = "{tmp_path / "out.nc"}"', 1)
            )
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path

    return write


@pytest.fixture(scope="session")
def sweep() -> Callable[..., Path]:
    """``run_sweep(spec, task_function, stream=..., **options)`` in this process alone (a
    ``SerialTeam``, also when pytest runs under mpiexec); the progress lines go to ``stream``, a
    fresh ``io.StringIO`` unless given. Returns the path of the data set written."""

    def run(
        spec: str | Path,
        task_function: Callable[[Mapping[str, Any]], Mapping[str, Any]] | None = None,
        stream: TextIO | None = None,
        **options: Any,
    ) -> Path:
        stream = stream if stream is not None else io.StringIO()
        return run_sweep(spec, task_function=task_function, team=SerialTeam(), stream=stream, **options)

    return run


@pytest.fixture(scope="session")
def cost_calibration(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A cost-model calibration file for this host and version with round numbers (1e-6 s per
    cost unit for every kind, 100 MiB base), so no test spends seconds calibrating."""
    from hpcontact import __version__
    from hpcontact.sweep.cost.calibration_file import save_calibration
    from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate

    rates = {kind: Rate(rate_s=1e-6, solve_s=0.0) for kind in KINDS}
    calibration = Calibration(socket.gethostname(), __version__, rates, base_bytes=100.0 * 2**20)
    return save_calibration(calibration, tmp_path_factory.mktemp("costmodel") / "costmodel.json")


@pytest.fixture(autouse=True)
def _cached_cost_calibration(cost_calibration: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every sweep test's dry run reads ``cost_calibration`` (``--dry-run`` never calibrates)."""
    monkeypatch.setenv("HPCONTACT_COSTMODEL", str(cost_calibration))


@pytest.fixture(scope="session")
def fake_solve() -> Callable[[Mapping[str, Any]], dict[str, Any]]:
    """A cheap stand-in for the solver: a smooth, shape-dependent tensor and a plan."""
    return _fake_solve
