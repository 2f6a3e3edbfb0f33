"""CI's skip gate (tests/conftest.py, ``allowed_skip``): the launcher split and a ``gpu``-marked
test skipped for the want of a GPU pass; every other skip fails the run, the GPU's words included.
Runs everywhere (not marked ``gpu``)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import SimpleNamespace

import pytest


def _gate():
    """tests/conftest.py, loaded by its path: the module name ``conftest`` is whichever conftest
    pytest imported last (tests/sweep/data has one too)."""
    spec = importlib.util.spec_from_file_location("root_conftest", Path(__file__).resolve().parents[1] / "conftest.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


gate = _gate()
GPU_SKIP, LAUNCHER_SPLIT, NO_GPU, allowed_skip = gate.GPU_SKIP, gate.LAUNCHER_SPLIT, gate.NO_GPU, gate.allowed_skip


def _report(reason: str, properties=()) -> SimpleNamespace:
    return SimpleNamespace(longrepr=("test_x.py", 1, f"Skipped: {reason}"), user_properties=list(properties))


def test_the_launcher_split_and_a_gpu_test_without_a_gpu_are_allowed():
    for reason in LAUNCHER_SPLIT:
        assert allowed_skip(_report(reason))
    assert allowed_skip(_report(f"{NO_GPU}: CuPy is not installed", [GPU_SKIP]))
    assert allowed_skip(_report(f"{NO_GPU}: CuPy sees no CUDA device", [list(GPU_SKIP)]))  # as xdist may send it


@pytest.mark.parametrize(
    "reason, properties",
    [
        ("cfchecker is not installed", []),  # an optional package missing
        (f"{NO_GPU}: CuPy is not installed", []),  # the GPU's words, but no gpu mark
        ("flaky on this machine", [GPU_SKIP]),  # a gpu test skipped for another reason
    ],
)
def test_any_other_skip_fails_ci(reason, properties):
    assert not allowed_skip(_report(reason, properties))


def test_a_gpu_marked_test_is_skipped_with_the_gate_s_mark_exactly_without_a_gpu():
    from hpcontact.numerics.backend import cuda_devices

    pytest_runtest_setup = gate.pytest_runtest_setup

    item = SimpleNamespace(user_properties=[], get_closest_marker=lambda name: object() if name == "gpu" else None)
    if cuda_devices()[1]:  # a GPU here: the test runs
        pytest_runtest_setup(item)
        assert item.user_properties == []
    else:
        with pytest.raises(pytest.skip.Exception, match=NO_GPU):
            pytest_runtest_setup(item)
        assert item.user_properties == [GPU_SKIP]
    unmarked = SimpleNamespace(user_properties=[], get_closest_marker=lambda name: None)
    pytest_runtest_setup(unmarked)  # never skipped by the gate
    assert unmarked.user_properties == []
