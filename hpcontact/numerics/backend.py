"""The array namespace of a device, and the few operations the solvers need beyond it.

A solve runs on one array namespace ``xp``: numpy on the CPU (device "cpu"), CuPy on an NVIDIA GPU
(device "gpu", imported only when asked for), or any namespace of the Python array API standard
(array-api-strict in the tests, which proves that the device path calls nothing outside the
standard: CuPy then sees the same code). The solvers (``conjugate_gradient``, ``polonsky_keer``,
the device convolution and the Fourier preconditioner) find ``xp`` from their arrays
(``namespace``) and call only the standard's functions, except where this module gives a faster
numpy form of the same arithmetic: ``dot`` and ``norm`` are BLAS's ``vdot`` and ``nrm2`` on numpy
(the CPU path's results stay bitwise what they were), ``xp.vecdot`` and ``xp.linalg.vector_norm``
elsewhere. The FFTs of the CPU path stay pyFFTW's (``convolution.ConvolutionOperator``) and
pocketfft's (the preconditioner); elsewhere they are ``xp.fft`` (cuFFT through CuPy).

Why a module of our own and not array-api-compat: numpy ≥ 2 and CuPy ≥ 13 arrays already carry
``__array_namespace__`` (so does array-api-strict), which is all ``namespace`` needs; what the CPU
path's speed rests on (pyFFTW plans, ``out=`` products, BLAS dot products) is outside any array-API
wrapper, and the rest is the choice of a device and the copies to and from it, a few lines here.
A dependency for that would add a layer to every call of the CPU path and save none of this code.

Copies between host and device are explicit and happen at the boundary of a solve, never inside
an iteration: ``to_device`` (kernel spectra, the preconditioner's symbol, the right-hand side and
the mask, once per solve) and ``to_host`` (the solution, once per solve). The per-iteration
scalars of CG and Polonsky–Keer (pᵀAp, rᵀz, ‖r‖) are read on the host by ``float`` (a device
synchronisation of one number each).

Units: none (arrays of any unit); float64 throughout.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from types import ModuleType
from typing import Any

import numpy as np

from hpcontact.errors import InputError
from hpcontact.fields import DEVICES

#: Environment variables that give a process's rank on its node, as launchers set them (Open MPI,
#: MPICH/Hydra and Intel MPI, MVAPICH2, Slurm's srun, PMIx); the first one set is used.
LOCAL_RANK_VARIABLES = (
    "OMPI_COMM_WORLD_LOCAL_RANK",
    "MPI_LOCALRANKID",
    "MV2_COMM_WORLD_LOCAL_RANK",
    "SLURM_LOCALID",
    "PMIX_LOCAL_RANK",
)

#: The device value with which each rank chooses for itself (``resolved_device``): its own GPU
#: where it has one, else the CPU; CPU and GPU ranks in one job.
AUTO = "auto"

Array = Any  # an array of some array-API namespace (numpy.ndarray, cupy.ndarray, ...)


def namespace(array: Array) -> ModuleType:
    """The array-API namespace of ``array`` (its ``__array_namespace__()``; numpy for numpy arrays)."""
    if isinstance(array, np.ndarray):
        return np
    return array.__array_namespace__()


def is_numpy(xp: ModuleType) -> bool:
    """Whether ``xp`` is numpy itself (the CPU path, with its faster numpy-only forms)."""
    return xp is np


def dot(a: Array, b: Array) -> float:
    """Σ a·b over all elements of two real arrays of one shape, on the host as a float."""
    xp = namespace(a)
    if is_numpy(xp):
        return float(np.vdot(a, b))
    return float(xp.vecdot(xp.reshape(a, (-1,)), xp.reshape(b, (-1,))))


def norm(a: Array) -> float:
    """‖a‖₂ over all elements of a real array, on the host as a float."""
    xp = namespace(a)
    if is_numpy(xp):
        return float(np.linalg.norm(a))
    return float(xp.linalg.vector_norm(a))


def add_scaled(target: Array, alpha: float, source: Array, scratch: np.ndarray | None = None) -> None:
    """target += alpha · source, in place. On numpy with a ``scratch`` array of the shape (the CPU
    path's CG: two of these per iteration) the product goes through it (``out=``), so no temporary
    is allocated per call; elsewhere the standard's ``alpha * source``. The same arithmetic either
    way: the results are bitwise equal."""
    if scratch is not None:
        target += np.multiply(alpha, source, out=scratch)
    else:
        target += alpha * source


def copy(a: Array) -> Array:
    """A new array equal to ``a`` in its own namespace."""
    return namespace(a).asarray(a, copy=True)


def to_device(host: np.ndarray, xp: ModuleType) -> Array:
    """A copy of the host array ``host`` in namespace ``xp`` (itself when ``xp`` is numpy): the one
    host → device copy of an input, made at the boundary of a solve."""
    if is_numpy(xp):
        return host
    return xp.asarray(np.ascontiguousarray(host))


def to_host(array: Array) -> np.ndarray:
    """``array`` as a numpy array (itself when it is one): the one device → host copy of a result."""
    if isinstance(array, np.ndarray):
        return array
    get = getattr(array, "get", None)  # CuPy: device memory is not reachable through DLPack on the host
    if get is not None:
        return get()
    return np.from_dlpack(array)


def cuda_devices() -> tuple[ModuleType | None, int, str]:
    """(CuPy or None, the CUDA devices it sees, why there are none or ""): CuPy's count honours
    ``CUDA_VISIBLE_DEVICES``."""
    try:
        import cupy
    except ImportError:
        return None, 0, "CuPy is not installed (pip install 'hpcontact[gpu]')"
    try:
        count = cupy.cuda.runtime.getDeviceCount()
    except cupy.cuda.runtime.CUDARuntimeError as exc:
        count, why = 0, f" ({exc})"
    else:
        why = ""
    if count == 0:
        visible = os.environ.get("CUDA_VISIBLE_DEVICES")
        shown = "" if visible is None else f" with CUDA_VISIBLE_DEVICES={visible!r}"
        return cupy, 0, f"CuPy sees no CUDA device{shown}{why}"
    return cupy, count, ""


def require_gpu() -> tuple[ModuleType, int]:
    """CuPy and the number of CUDA devices it sees; ``InputError`` on the ``device`` field saying
    which is missing: CuPy, or a CUDA device (a spec asking for "gpu" is refused by it before its
    first task, a solve before it allocates)."""
    cupy, count, why = cuda_devices()
    if cupy is None or count == 0:
        raise InputError("device", f"'gpu' needs CuPy and a CUDA device: {why}; use 'cpu'", "gpu")
    return cupy, count


def gpu_namespace() -> ModuleType:
    """CuPy, on this rank's GPU (``gpu_for_rank``; ``require_gpu`` names what is missing)."""
    cupy, count = require_gpu()
    cupy.cuda.Device(gpu_for_rank(local_rank(), count)).use()
    return cupy


def own_gpu(environ: Mapping[str, str] | None = None) -> int | None:
    """The CUDA ordinal of this rank's own GPU under device "auto": its rank on its node
    (``local_rank``) where that is below the number of devices CuPy sees (which honours
    ``CUDA_VISIBLE_DEVICES``); None where CuPy or a device is missing, or where the node has fewer
    visible GPUs than ranks and this rank is beyond them: such a rank solves on the CPU."""
    _, count, _ = cuda_devices()
    rank = local_rank(environ)
    return rank if rank < count else None


def resolved_device(device: str) -> str:
    """The device a solve of ``device`` runs on in this rank: "cpu" or "gpu" as given; "auto" is
    "gpu" where this rank has its own GPU (``own_gpu``), else "cpu". A job of "auto" scenes on
    nodes with G GPUs and R > G ranks each runs G GPU ranks and R − G CPU ranks: the scene (its
    key, journal and record) is the same whichever solves it, within ``REQUIRED``-sized rounding
    (tests/gpu/test_gpu_engine.py)."""
    if device == AUTO:
        return "cpu" if own_gpu() is None else "gpu"
    return device


def array_namespace(device: str) -> ModuleType:
    """The array namespace of a device: numpy for "cpu", CuPy on this rank's GPU for "gpu", and for
    "auto" the namespace of the device this rank resolves it to (``resolved_device``)."""
    if device == AUTO:
        device = resolved_device(device)
    if device == "cpu":
        return np
    if device == "gpu":
        return gpu_namespace()
    raise InputError("device", f"one of {', '.join(DEVICES)}", device)


def local_rank(environ: Mapping[str, str] | None = None) -> int:
    """This process's rank among the processes of its node, from the launcher's environment
    (``LOCAL_RANK_VARIABLES``); 0 for a process started without a launcher."""
    env = os.environ if environ is None else environ
    for name in LOCAL_RANK_VARIABLES:
        text = env.get(name, "").strip()
        if text.isdigit():
            return int(text)
    return 0


def gpu_for_rank(rank_on_node: int, visible_devices: int) -> int:
    """The GPU ordinal of the rank ``rank_on_node`` of a node with ``visible_devices`` GPUs visible
    (CUDA's count, which honours ``CUDA_VISIBLE_DEVICES``; its ordinals are the visible devices'):
    ranks take the visible devices in turn, rank i the device i mod count (one GPU per rank while
    there are as many devices as ranks, shared beyond)."""
    if visible_devices < 1:
        raise ValueError("no visible device")
    return rank_on_node % visible_devices


def gpu_description() -> list[str]:
    """For ``hpcontact info``: the devices a solve can use, then CuPy's and CUDA's versions and one
    line per GPU (ordinal, name, memory), or why there is none."""
    cupy, count, why = cuda_devices()
    if count == 0:
        return ["cpu", f"no gpu: {why}"] + ([f"cupy {cupy.__version__}"] if cupy is not None else [])
    lines = [f"cpu, gpu ({count})", f"cupy {cupy.__version__}, CUDA runtime {cupy.cuda.runtime.runtimeGetVersion()}"]
    for ordinal in range(count):
        props = cupy.cuda.runtime.getDeviceProperties(ordinal)
        name = props["name"].decode() if isinstance(props["name"], bytes) else props["name"]
        lines.append(f"gpu {ordinal}: {name}, {props['totalGlobalMem'] / 2**30:.1f} GiB")
    return lines
