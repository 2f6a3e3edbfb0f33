"""A stand-in for CuPy on a machine without a GPU: the calls through which hpcontact asks for a GPU,
its memory and its name (``numerics.backend.cuda_devices``, ``numerics.memory.gpu_memory``), no
arrays. Tests of what is decided from a GPU's name and memory (batch sizes, the GPU's cost model,
the memory check) use it; the tests that compute on a GPU are this folder's ``gpu``-marked ones."""

from __future__ import annotations

from types import SimpleNamespace

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

    runtime = SimpleNamespace(
        memGetInfo=lambda: (free, total),
        getDeviceProperties=lambda i: {"name": name.encode()},
        getDeviceCount=lambda: 1,
    )
    pool = SimpleNamespace(free_bytes=lambda: pool_free)
    return SimpleNamespace(cuda=SimpleNamespace(Device=Device, runtime=runtime), get_default_memory_pool=lambda: pool)


def use_stub_gpu(monkeypatch: pytest.MonkeyPatch, cupy: SimpleNamespace, devices: int = 1) -> None:
    """Make hpcontact see ``cupy`` (``stub_cupy``) with ``devices`` CUDA devices."""
    from hpcontact.numerics import backend

    monkeypatch.setattr(backend, "cuda_devices", lambda: (cupy, devices, ""))
