"""Device "auto" (issue 41 item 3): each rank solves on its own GPU where it has one, else on its CPU
(``numerics.backend.resolved_device``), so CPU and GPU ranks run one job. The scene, its key and its
journal entry are the same whichever solves it: a sweep of "auto" scenes run on a CPU rank is up to
date for a GPU rank, and the same sweep solved on a (stand-in) GPU gives each value within the
device agreement of tests/numerics/device_agreement.py. The GPU here is ``stub_cupy.use_standin_gpu``
(array-api-strict's arrays behind CuPy's device calls): the device path, run on the CPU."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import hpcontact
from hpcontact.numerics import backend
from hpcontact.sweep.driver import run_sweep

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "gpu"))
from stub_cupy import circle_sweep, use_standin_gpu  # noqa: E402

SPEC = circle_sweep("auto", "auto", [0.1, 0.3, 0.45])


def _no_gpu(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(backend, "cuda_devices", lambda: (None, 0, "CuPy is not installed"))


def test_auto_solves_on_the_cpu_without_a_gpu_and_on_the_gpu_with_one(monkeypatch):
    params = {"shape": "circle", "n": 12, "quantities": "normal", "tol": 1e-14}
    _no_gpu(monkeypatch)
    cpu = hpcontact.solve(**params, device="cpu")
    assert hpcontact.solve(**params, device="auto")["K_zz"] == cpu["K_zz"]  # the same numpy path, bit for bit
    seen = []
    standin = use_standin_gpu(monkeypatch)
    real = backend.gpu_namespace
    monkeypatch.setattr(backend, "gpu_namespace", lambda: seen.append(1) or real())
    assert backend.array_namespace("auto") is standin
    assert abs(hpcontact.solve(**params, device="auto")["K_zz"] - cpu["K_zz"]) <= 1e-12 * cpu["K_zz"]
    assert seen  # the solve went through the GPU's namespace


def test_a_sweep_of_auto_scenes_is_one_job_for_cpu_and_gpu_ranks(monkeypatch, tmp_path):
    spec = tmp_path / "auto.toml"
    spec.write_text(SPEC, encoding="utf-8")
    _no_gpu(monkeypatch)
    on_cpu = run_sweep(spec, output=tmp_path / "cpu.nc", stream=io.StringIO())
    use_standin_gpu(monkeypatch)
    shown = io.StringIO()
    assert run_sweep(spec, resume=True, output=tmp_path / "cpu.nc", stream=shown) == on_cpu
    assert "3 tasks, 0 to run (3 from journals)" in shown.getvalue()  # the CPU rank's entries are the GPU rank's
    on_gpu = run_sweep(spec, output=tmp_path / "gpu.nc", stream=io.StringIO())
    with xr.open_dataset(on_cpu) as a, xr.open_dataset(on_gpu) as b:
        stiffness = [n for n in a.data_vars if n.startswith("K_") and "_over_" not in n and not n.endswith("_error")]
        assert len(stiffness) >= 3
        scale = max(float(np.max(np.abs(a[name].values))) for name in stiffness)  # an entry zero by symmetry
        for name in stiffness:  # is round-off of the tensor's size
            assert np.max(np.abs(a[name].values - b[name].values)) <= 1e-12 * scale, name
