"""The grid sequences of a batch of accuracy tasks on the device path, run on a stand-in GPU
(``stub_cupy.use_standin_gpu``: array-api-strict's arrays behind CuPy's device calls), against each scene
alone on the CPU (tests/gpu/sequence_agreement.py). Not marked ``gpu``: it runs everywhere; the same
check on CuPy is tests/gpu/test_gpu_batches.py's."""

from __future__ import annotations

from sequence_agreement import check_batched_sequences
from stub_cupy import use_standin_gpu
from test_batches_accuracy import REQUESTS


def test_a_batch_of_grid_sequences_on_the_device_path_gives_the_cpu_records(monkeypatch, tmp_path):
    use_standin_gpu(monkeypatch)
    chosen = [REQUESTS[0], REQUESTS[2], REQUESTS[6]]  # circle on grids, rectangle 1e-4, an exact cell
    assert check_batched_sequences(chosen, tmp_path) > 0
