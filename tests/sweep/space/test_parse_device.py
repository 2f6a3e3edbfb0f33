"""A spec asking for the GPU where there is none is refused when it is read (issue 41 item 3)."""

from __future__ import annotations

import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.numerics import backend
from hpcontact.sweep.space.parse import parse_spec

SPEC = '[sweep]\noutput = "d.nc"\n[scene]\nshape = "circle"\ndevice = "{device}"\n[numerics]\nn = 16\n[axes]\nnu = [0.2, 0.3]\n'


@pytest.mark.parametrize(
    ("cupy", "why"),
    [(None, "CuPy is not installed (pip install 'hpcontact[gpu]')"), (np, "CuPy sees no CUDA device")],
)
def test_a_gpu_spec_without_cupy_or_a_device_is_refused_naming_which(tmp_path, monkeypatch, cupy, why):
    monkeypatch.setattr(backend, "cuda_devices", lambda: (cupy, 0, why))
    with pytest.raises(InputError) as info:
        parse_spec(SPEC.format(device="gpu"), path=tmp_path / "s.toml")
    assert info.value.field == "device" and why in str(info.value)


def test_a_cpu_spec_does_not_look_for_a_gpu(tmp_path, monkeypatch):
    def no_lookup():
        raise AssertionError("a cpu spec looked for CUDA devices")

    monkeypatch.setattr(backend, "cuda_devices", no_lookup)
    spec = parse_spec(SPEC.format(device="cpu"), path=tmp_path / "s.toml")
    assert spec.fixed["device"] == "cpu"
