"""A GPU rank's claims fill its batches in a sweep (issue 41 item 2: ``sweep.run.rounds`` claims with
``work.batches.batch_fill``): a sweep whose every task is its own kernel group, so a chunk of its own,
runs on one (stand-in) GPU rank as one batch, and its data set is the CPU's within the device
agreement (1e-12 of the stiffness tensor). The GPU is ``stub_cupy.use_standin_gpu``: array-api-strict's
arrays behind CuPy's device calls, the device path run on the CPU."""

from __future__ import annotations

import io
import sys
from pathlib import Path

import numpy as np
import xarray as xr

from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.work import batches

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "gpu"))
from stub_cupy import circle_sweep, use_standin_gpu  # noqa: E402

NU = [0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4]


def test_a_gpu_rank_solves_a_sweep_of_one_task_chunks_as_one_batch(monkeypatch, tmp_path):
    sizes: list[int] = []
    solve = batches.solve_contact_batch
    monkeypatch.setattr(batches, "solve_contact_batch", lambda fields: sizes.append(len(fields)) or solve(fields))
    outputs = {}
    for device in ("cpu", "gpu"):
        if device == "gpu":
            use_standin_gpu(monkeypatch)
        spec = tmp_path / f"{device}.toml"
        spec.write_text(circle_sweep("gpu claims", device, NU), encoding="utf-8")
        outputs[device] = run_sweep(spec, stream=io.StringIO())
        assert sizes == ([] if device == "cpu" else [8])  # the CPU rank: one task at a time
    with xr.open_dataset(outputs["cpu"]) as a, xr.open_dataset(outputs["gpu"]) as b:
        stiffness = [n for n in a.data_vars if n.startswith("K_") and "_over_" not in n and not n.endswith("_error")]
        scale = max(float(np.max(np.abs(a[name].values))) for name in stiffness)
        for name in stiffness:
            assert np.max(np.abs(a[name].values - b[name].values)) <= 1e-12 * scale, name
