"""CPU and GPU ranks in one job (issue 41 item 3): under ``mpiexec -n 2`` rank 0 sees a GPU (the stand-in of
tests/gpu/stub_cupy.py: array-api-strict's arrays behind CuPy's device calls) and rank 1 none. With
``device = "auto"`` rank 0 solves its tasks through the device path and rank 1 on numpy, in one sweep:
its data set equals the same sweep on one CPU process to 1e-12 of the stiffness tensor (the device
agreement of tests/numerics/device_agreement.py). In one plain process the team is rank 0 alone."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hpcontact.numerics import backend
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run.schedule import SerialTeam, Team

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "gpu"))
from stub_cupy import circle_sweep, use_standin_gpu  # noqa: E402

pytestmark = pytest.mark.mpi

SPEC = circle_sweep("mixed devices", "auto", [0.05, 0.15, 0.25, 0.35, 0.45])


def test_a_gpu_rank_and_a_cpu_rank_run_one_sweep_of_auto_scenes(team: Team, shared_dir: Path, monkeypatch):
    for name in backend.LOCAL_RANK_VARIABLES:  # both ranks on one node: rank r is local rank r
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("SLURM_LOCALID", str(team.rank))
    monkeypatch.setattr(backend, "cuda_devices", lambda: (None, 0, "CuPy is not installed"))
    spec = shared_dir / "mixed.toml"
    if team.rank == 0:
        spec.write_text(SPEC, encoding="utf-8")
        alone = run_sweep(spec, output=shared_dir / "cpu.nc", team=SerialTeam(), stream=io.StringIO())
    use_standin_gpu(monkeypatch)  # one GPU on the node: local rank 0 takes it, rank 1 has none
    assert team.gather(backend.resolved_device("auto")) in (["gpu"], ["gpu", "cpu"], None)
    mixed = run_sweep(spec, output=shared_dir / "mixed.nc", team=team, stream=io.StringIO())
    if team.rank == 0:
        with xr.open_dataset(alone) as a, xr.open_dataset(mixed) as b:
            names = [n for n in a.data_vars if n.startswith("K_") and "_over_" not in n and not n.endswith("_error")]
            scale = max(float(np.max(np.abs(a[name].values))) for name in names)
            for name in names:
                assert np.max(np.abs(a[name].values - b[name].values)) <= 1e-12 * scale, name
