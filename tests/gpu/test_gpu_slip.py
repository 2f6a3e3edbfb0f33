"""A slip scene on the GPU (device = "gpu": CuPy, cuFFT) against the CPU path (issue 41, "done
when": a slip scene's results equal the CPU path's to ≤ 1e-12 relative).

Marked ``gpu``: skipped without CuPy or a CUDA device (tests/conftest.py). The comparisons and their
bounds are tests/problems/slip/slip_agreement.py's, which tests/problems/slip/test_slip_device.py
runs on array-api-strict's arrays (the same code): a difference here is CuPy's or cuFFT's rounding.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from hpcontact.numerics.backend import array_namespace

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "problems" / "slip"))
from slip_agreement import REQUIRED, SCENES, check_disc_programme, check_slip_paths  # noqa: E402

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def cupy():
    return array_namespace("gpu")


def test_the_friction_disc_programme_on_the_gpu_is_the_numpy_one(cupy):
    assert check_disc_programme(cupy) <= REQUIRED


@pytest.mark.parametrize("name", sorted(SCENES))
def test_a_slip_scene_on_the_gpu_is_the_cpu_one(cupy, name):
    assert check_slip_paths(name, "gpu") >= 2
