"""A GPU rank's batches (``sweep.work.batches``: scenes of one grid, grid sequences of ``--accuracy``)
and the GPU's cost model (``calibrate_gpu``) on a real GPU (issue 41 items 2 and 5). Marked ``gpu``: skipped without CuPy or a CUDA device
(tests/conftest.py); the CPU tests of the same code force the batched path on numpy
(tests/sweep/work/test_batches.py) and read a stand-in GPU's name and memory
(tests/sweep/cost/test_gpu_costs.py)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from hpcontact.accuracy.defaults import solve_contact_fields
from hpcontact.numerics.memory import gpu_memory
from hpcontact.sweep.cost.calibration_file import calibrate_gpu, gpu_calibration
from hpcontact.sweep.data.journal import OK
from hpcontact.sweep.run.rounds import run_task
from hpcontact.sweep.work.batches import plan_batches, run_batch

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sweep" / "work"))
from sequence_agreement import check_batched_sequences  # noqa: E402
from test_batches import CIRCLES, alone, assert_same_records, tasks_of  # noqa: E402
from test_batches_accuracy import REQUESTS  # noqa: E402

pytestmark = pytest.mark.gpu


def test_a_gpu_rank_batches_one_grid_and_its_records_are_the_cpus_one_at_a_time():
    on_gpu = tasks_of([{**c, "device": "gpu"} for c in CIRCLES])
    (batch,) = plan_batches(on_gpu, solve_contact_fields)  # this GPU's free memory holds three 20 x 20 scenes
    entries = run_batch(batch, 0, lambda task: run_task(solve_contact_fields, task, 0))
    for task, entry in zip(tasks_of(CIRCLES), entries):
        assert entry.status == OK and entry.key != task.key  # the device is a field of the scene
        assert_same_records(entry.record, alone(task).record)


def test_a_gpu_batch_of_grid_sequences_gives_the_cpu_records_one_at_a_time(tmp_path):
    """Issue 41's scenes (circle and crystal ellipse on grids, rectangle 1e-4, star, mask, an exact
    cell) refined as one batch on the GPU: each the CPU's record alone, within 1e-12."""
    assert check_batched_sequences(REQUESTS, tmp_path) > 0


def test_a_gpu_calibration_is_made_on_the_gpu_and_read_back(monkeypatch, tmp_path):
    monkeypatch.setenv("HPCONTACT_WISDOM", str(tmp_path / "fftw_wisdom"))
    path = calibrate_gpu()
    gpu = gpu_memory()
    calibration, note = gpu_calibration(gpu)
    assert path.parent == tmp_path and calibration is not None and gpu.label in note
    for kind, rate in calibration.rates.items():
        assert rate.rate_s + rate.solve_s > 0.0, kind
