"""The cost model and the dry run know the device (issue 41 item 5): GPU tasks take the cost model of
their GPU (a file per kind of GPU), never a CPU's; without one their seconds are not estimated and
every line says so; memory on the device per scene and per batch; the run's memory check on the GPU.

No GPU here: the GPU is ``tests/gpu/stub_cupy.py``'s stand-in (its name and memory), which is all
these decisions read."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from hpcontact import __version__
from hpcontact.errors import InputError
from hpcontact.numerics.memory import GpuMemory
from hpcontact.problems.footprint import array_bytes
from hpcontact.sweep.cost.calibration_file import gpu_calibration, save_calibration
from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate, gpu_calibration_path
from hpcontact.sweep.driver import main
from hpcontact.sweep.work.batches import BATCH_MEMORY_FRACTION
from hpcontact.sweep.work.estimate import check_memory, start_estimate
from hpcontact.sweep.work.tasks import Task, task_key

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "gpu"))
from stub_cupy import stub_cupy, use_stub_gpu  # noqa: E402

GIB = 2**30
SPEC = """
[sweep]
title = "gpu cost test"
[scene]
quantities = ["tangential"]
shape = "circle"
device = "gpu"
[numerics]
n = 32
tol = 1e-6
[axes]
nu = [0.0, 0.3, 0.45]
"""
STUB = GpuMemory(8 * GIB, 16 * GIB, 0, "Stub H")


@pytest.fixture
def gpu(monkeypatch, tmp_path):
    """The stand-in GPU (8 GiB free of 16) and a wisdom folder of the test's own (where GPU cost
    models are looked for); the CPU's cost model is the sweep tests' (1e-6 s per cost unit)."""
    monkeypatch.setenv("HPCONTACT_WISDOM", str(tmp_path / "wisdom" / "fftw_wisdom"))
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    use_stub_gpu(monkeypatch, stub_cupy(STUB.free, STUB.total, name=STUB.name))
    return STUB


def save_gpu_calibration(seconds_per_unit: float) -> Path:
    rates = {kind: Rate(rate_s=seconds_per_unit, solve_s=0.0) for kind in KINDS}
    return save_calibration(Calibration("gpu-node", __version__, rates, base_bytes=0.0), gpu_calibration_path(STUB))


def test_a_gpu_cost_model_is_a_file_per_kind_of_gpu(gpu, tmp_path):
    path = gpu_calibration_path(gpu)
    assert path == tmp_path / "wisdom" / "costmodel-gpu-stub-h-16g.json"
    assert gpu_calibration_path(GpuMemory(1, 80 * GIB, 3, "NVIDIA H100 80GB HBM3")).name == (
        "costmodel-gpu-nvidia-h100-80gb-hbm3-80g.json"
    )
    calibration, note = gpu_calibration(gpu)
    assert calibration is None and note.startswith("no calibration for this GPU (GPU 0 (Stub H, 16 GiB); none in")
    save_gpu_calibration(1e-9)
    calibration, note = gpu_calibration(gpu)
    assert calibration.rates["contact"].rate_s == 1e-9 and "cost model of GPU 0 (Stub H, 16 GiB) on gpu-node" in note


def test_without_a_calibration_for_the_gpu_its_tasks_have_no_seconds(gpu, write_spec, capsys):
    spec = write_spec(SPEC)
    assert main([str(spec), "--dry-run", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [t["estimated_seconds"] for t in out["tasks_list"]] == [None] * 3
    assert out["tasks_not_estimated"] == 3 and out["estimated_task_seconds"] == 0.0 and out["wall_time_s"] == {}
    assert out["gpu"]["tasks"] == 3 and out["gpu"]["calibrated"] is False and out["gpu"]["device"] == STUB.label
    assert out["gpu"]["cost_model"].startswith("no calibration for this GPU")
    scene = array_bytes({"shape": "circle", "n": 32, "quantities": ["tangential"]})
    (batch,) = out["gpu"]["batches"]
    assert batch["scene_bytes"] == scene and batch["scenes_per_batch"] == int(
        BATCH_MEMORY_FRACTION * STUB.free // scene
    )
    assert main([str(spec), "--dry-run"]) == 0
    text = capsys.readouterr().out
    assert "(3 GPU task(s) not estimated)" in text and "# wall time: not estimated while a task has no seconds" in text
    assert "# GPU tasks: 3 on GPU 0 (Stub H, 16 GiB), 8.0 GiB free here; no calibration for this GPU" in text
    assert "their seconds are not estimated" in text and text.count("      none  ") == 3
    assert f"{scene / 2**20:.0f} MiB a scene on the device, up to {batch['scenes_per_batch']} scene(s) a batch" in text


def test_with_its_gpus_calibration_a_gpu_task_takes_that_cost_model(gpu, write_spec, capsys):
    save_gpu_calibration(1e-9)  # the sweep tests' CPU calibration: 1e-6 s per cost unit; this GPU's: 1e-9
    assert main([str(write_spec(SPEC)), "--dry-run", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["tasks_not_estimated"] == 0 and out["gpu"]["calibrated"] is True and out["wall_time_s"]["1"] > 0.0
    for task in out["tasks_list"]:
        assert task["estimated_seconds"] == pytest.approx(1e-9 * task["cost"], rel=1e-12)


def test_the_run_start_line_says_gpu_tasks_are_not_estimated(gpu):
    params = {"shape": "circle", "n": 32, "quantities": ["tangential"], "tol": 1e-6}
    tasks = [Task(task_key(p), p, 1000.0, "g") for p in (params, {**params, "device": "gpu"})]
    line, seconds = start_estimate(tasks, 1)
    assert "1 GPU task(s) not estimated: no calibration for this GPU (GPU 0 (Stub H, 16 GiB)" in line
    assert "the 1 CPU task(s): estimated" in line and len(seconds) == 2
    save_gpu_calibration(1e-9)
    line, _ = start_estimate(tasks, 1)
    assert "GPU tasks: cost model of GPU 0 (Stub H, 16 GiB)" in line and "not estimated" not in line


def test_a_gpu_task_whose_arrays_exceed_the_gpus_free_memory_is_refused(monkeypatch, tmp_path):
    params = {"shape": "circle", "n": 32, "quantities": ["tangential"], "tol": 1e-6, "device": "gpu"}
    scene = array_bytes(params)
    tasks = [Task(task_key(params), params, 1.0, "g")]
    use_stub_gpu(monkeypatch, stub_cupy(int(scene) + 1, GIB))
    check_memory(tasks, 64 * GIB, "test")  # fits
    use_stub_gpu(monkeypatch, stub_cupy(2**20, GIB))
    with pytest.raises(InputError) as info:
        check_memory(tasks, 64 * GIB, "test")
    assert info.value.field == "device" and 1 * 2**20 < scene < 2.5 * 2**20
    assert "device memory 2 MiB over the free 1 MiB of GPU 0 (Stub H, 1 GiB)" in str(info.value)
