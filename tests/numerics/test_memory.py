"""Memory budgets and sizes (``hpcontact.numerics.memory``): what the accuracy study and the
sweep's ``--mem-per-rank`` share."""

from __future__ import annotations

import pytest

from hpcontact.errors import InputError
from hpcontact.numerics import memory


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
