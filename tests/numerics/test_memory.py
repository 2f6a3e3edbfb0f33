"""Memory budgets and sizes (``hpcontact.numerics.memory``): what the accuracy study and the
sweep's ``--mem-per-rank`` share."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from hpcontact.errors import InputError
from hpcontact.numerics import memory

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "gpu"))
from stub_cupy import stub_cupy, use_stub_gpu  # noqa: E402


def test_memory_sizes_and_the_batch_systems_share():
    assert memory.parse_memory("4G") == 4 * 2**30 and memory.parse_memory("512MiB") == 512 * 2**20
    assert memory.parse_memory("1000") == 1000
    for bad in ("", "-1G", "lots", "0"):
        with pytest.raises(InputError, match="--mem-per-rank"):
            memory.parse_memory(bad)
    slurm = {"SLURM_MEM_PER_CPU": "2000", "SLURM_CPUS_PER_TASK": "2"}
    assert memory.default_memory_per_rank(slurm) == (4000 * 2**20, "SLURM_MEM_PER_CPU")
    node = {"SLURM_MEM_PER_NODE": "64000", "SLURM_TASKS_PER_NODE": "16(x4)"}
    assert memory.default_memory_per_rank(node) == (4000 * 2**20, "SLURM_MEM_PER_NODE / tasks per node")
    assert memory.default_memory_per_rank({})[1] == "physical memory / cores"


def test_gpu_memory_is_the_free_device_memory_and_the_pools_free_blocks(monkeypatch):
    from hpcontact.numerics import backend

    use_stub_gpu(monkeypatch, stub_cupy(3 * 2**30, 8 * 2**30, 2**20), devices=2)
    monkeypatch.setenv("SLURM_LOCALID", "3")  # the rank's GPU: 3 mod 2
    for name in backend.LOCAL_RANK_VARIABLES[:-2]:
        monkeypatch.delenv(name, raising=False)
    gpu = memory.gpu_memory()
    assert gpu == (3 * 2**30 + 2**20, 8 * 2**30, 1, "Stub H") and gpu.label == "GPU 1 (Stub H, 8 GiB)"
    monkeypatch.setattr(backend, "cuda_devices", lambda: (None, 0, "CuPy is not installed"))
    with pytest.raises(InputError, match="device.*CuPy is not installed"):
        memory.gpu_memory()
