"""A stand-in for CuPy on a machine without a GPU: the calls through which hpcontact asks for a GPU,
its memory and its name (``numerics.backend.cuda_devices``, ``numerics.memory.gpu_memory``,
``backend.gpu_description``), no arrays. Tests of what is decided from a GPU's name and memory
(batch sizes, the GPU's cost model, the memory check) use it; ``use_standin_gpu`` adds arrays:
array-api-strict's, so code written for the GPU runs end to end on the CPU (benchmarks/gpu_engine.py
in tests/gpu/test_gpu_engine_script.py). The tests that compute on a GPU are this folder's
``gpu``-marked ones."""

from __future__ import annotations

from types import ModuleType, SimpleNamespace

import pytest


def stub_cupy(free: int, total: int, pool_free: int = 0, name: str = "Stub H") -> SimpleNamespace:
    """CuPy's ``cuda.Device`` (the device a rank chose with ``Device(i).use()`` is then
    ``Device().id``), ``cuda.runtime.memGetInfo`` / ``getDeviceProperties`` and the memory pool's
    ``free_bytes``, answering ``free``, ``total``, ``pool_free`` bytes and ``name``."""

    class Device:
        current = 0

        def __init__(self, ordinal: int | None = None) -> None:
            self.id = Device.current if ordinal is None else ordinal

        def use(self) -> None:
            Device.current = self.id

        def synchronize(self) -> None:
            """Nothing runs asynchronously on the stand-in."""

    runtime = SimpleNamespace(
        memGetInfo=lambda: (free, total),
        getDeviceProperties=lambda i: {"name": name.encode(), "totalGlobalMem": total},
        getDeviceCount=lambda: 1,
        runtimeGetVersion=lambda: 0,
    )
    pool = SimpleNamespace(free_bytes=lambda: pool_free, total_bytes=lambda: 0)
    return SimpleNamespace(
        cuda=SimpleNamespace(Device=Device, runtime=runtime),
        get_default_memory_pool=lambda: pool,
        __version__="stub",
    )


def use_stub_gpu(monkeypatch: pytest.MonkeyPatch, cupy: SimpleNamespace, devices: int = 1) -> None:
    """Make hpcontact see ``cupy`` (``stub_cupy``) with ``devices`` CUDA devices."""
    from hpcontact.numerics import backend

    monkeypatch.setattr(backend, "cuda_devices", lambda: (cupy, devices, ""))


def use_standin_gpu(monkeypatch: pytest.MonkeyPatch) -> ModuleType:
    """Make hpcontact see one GPU whose arrays are array-api-strict's (``stub_cupy``'s device calls
    on that namespace): ``device = "gpu"`` then computes on the CPU through the device path. Returns
    the namespace."""
    import array_api_strict

    cupy = stub_cupy(2**33, 2**34)
    for name in ("cuda", "get_default_memory_pool", "__version__"):
        monkeypatch.setattr(array_api_strict, name, getattr(cupy, name), raising=False)
    use_stub_gpu(monkeypatch, array_api_strict)
    return array_api_strict


def circle_sweep(title: str, device: str, nu: list[float]) -> str:
    """The spec of the device tests' sweeps: the circle's tangential and normal stiffness on a
    12 × 12 grid (CG to 1e-14, so records of the two devices agree to round-off) over ``nu``,
    solved on ``device``."""
    return f"""
[sweep]
title = "{title}"
[scene]
shape = "circle"
quantities = ["tangential", "normal"]
device = "{device}"
[numerics]
n = 12
tol = 1e-14
[axes]
nu = {nu}
"""
