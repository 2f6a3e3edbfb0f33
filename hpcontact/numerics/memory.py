"""Memory of this process and of the machine: budgets per rank, sizes as users write them.

Shared by the accuracy study (which grids fit), one solve (``hpcontact solve --memory``: a grid
refused before it is allocated) and the sweep (``--mem-per-rank``, the dry run): the budget one
rank may use (from SLURM's variables, else physical memory ÷ cores), the peak resident set so
far, sizes such as ``4G`` in binary units as SLURM's ``--mem``, and the one refusal of an
estimate over its budget (``check_fits``).
"""

from __future__ import annotations

import math
import os
import resource
import sys
from collections.abc import Mapping
from typing import NamedTuple

from hpcontact.errors import InputError

MIB = 2**20

_SIZE_UNITS = {"": 1, "B": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def parse_memory(text: str, field_name: str = "--mem-per-rank") -> int:
    """Bytes of a size such as ``4G``, ``512M``, ``2.5GiB`` or ``1000000`` (binary units, as
    SLURM's ``--mem``); ``InputError`` naming ``field_name`` otherwise."""
    value = str(text).strip().upper().removesuffix("IB").removesuffix("B")
    unit = value[-1:] if value[-1:] in _SIZE_UNITS else ""
    try:
        number = float(value[: len(value) - len(unit)])
    except ValueError:
        number = float("nan")
    if not (math.isfinite(number) and number > 0):
        raise InputError(field_name, "a size > 0 such as 4G, 512M or a number of bytes", text)
    return int(number * _SIZE_UNITS[unit])


def _slurm_tasks_per_node(environ: Mapping[str, str]) -> int | None:
    """Tasks on this node from SLURM_NTASKS_PER_NODE, else the first count of
    SLURM_TASKS_PER_NODE (``"4(x2),3"``)."""
    for name in ("SLURM_NTASKS_PER_NODE", "SLURM_TASKS_PER_NODE"):
        text = environ.get(name, "").split(",")[0].split("(")[0]
        if text.isdigit() and int(text) > 0:
            return int(text)
    return None


def default_memory_per_rank(environ: Mapping[str, str] | None = None) -> tuple[int, str]:
    """Bytes one rank may use and where that number comes from: SLURM_MEM_PER_CPU (MiB) ×
    SLURM_CPUS_PER_TASK, else SLURM_MEM_PER_NODE (MiB) ÷ tasks per node, else this machine's
    physical memory ÷ its cores."""
    environ = os.environ if environ is None else environ
    per_cpu = environ.get("SLURM_MEM_PER_CPU", "")
    if per_cpu.isdigit():
        cpus = environ.get("SLURM_CPUS_PER_TASK", "1")
        return int(per_cpu) * MIB * (int(cpus) if cpus.isdigit() else 1), "SLURM_MEM_PER_CPU"
    per_node, tasks = environ.get("SLURM_MEM_PER_NODE", ""), _slurm_tasks_per_node(environ)
    if per_node.isdigit() and int(per_node) > 0 and tasks:
        return int(per_node) * MIB // tasks, "SLURM_MEM_PER_NODE / tasks per node"
    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    return total // (os.cpu_count() or 1), "physical memory / cores"


def resident_bytes() -> float:
    """Peak resident bytes of this process so far (ru_maxrss is in KiB on Linux, bytes on macOS)."""
    scale = 1 if sys.platform == "darwin" else 1024
    return float(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale)


def memory_budget(memory: str | float | None, field_name: str) -> tuple[int, str]:
    """Bytes a solve may use and where that number comes from: ``memory`` (``"2G"`` or bytes,
    ``parse_memory``; its source ``field_name``) when given, else ``default_memory_per_rank``."""
    if memory is None:
        return default_memory_per_rank()
    return parse_memory(memory, field_name), field_name


def check_fits(need: float, budget: tuple[int, str], field_name: str, value: object, what: str) -> None:
    """``InputError`` naming ``field_name`` (= ``value``) when the estimated peak ``need`` bytes
    exceed ``budget`` (bytes, its source): one line saying what would fit (``what``), the
    estimate and the limit, raised before anything is allocated."""
    limit, source = budget
    if need > limit:
        raise InputError(
            field_name,
            f"{what}: estimated peak memory {need / MIB:.0f} MiB over the limit {limit / MIB:.0f} MiB ({source})",
            value,
        )


class GpuMemory(NamedTuple):
    """This rank's GPU: bytes free for arrays now, its total bytes, its CUDA ordinal and name."""

    free: int
    total: int
    ordinal: int
    name: str

    @property
    def label(self) -> str:
        """How lines name it: "GPU 0 (NVIDIA H200, 140 GiB)"."""
        return f"GPU {self.ordinal} ({self.name}, {self.total / 2**30:.0f} GiB)"


def gpu_memory() -> GpuMemory:
    """This rank's GPU (``numerics.backend.gpu_namespace``: ``InputError`` naming what a GPU lacks):
    bytes free for arrays now (CUDA's free device memory, ``cudaMemGetInfo``, plus the blocks
    CuPy's memory pool holds free for reuse), its total memory, its ordinal and name."""
    from hpcontact.numerics.backend import gpu_namespace

    cupy = gpu_namespace()
    free, total = cupy.cuda.runtime.memGetInfo()
    ordinal = cupy.cuda.Device().id
    name = cupy.cuda.runtime.getDeviceProperties(ordinal)["name"]
    name = name.decode() if isinstance(name, bytes) else str(name)
    return GpuMemory(int(free) + int(cupy.get_default_memory_pool().free_bytes()), int(total), int(ordinal), name)
