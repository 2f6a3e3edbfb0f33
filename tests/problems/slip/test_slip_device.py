"""A slip scene on the device path (issue 41): the friction-disc programme, the pair's operators and
whole load paths on array-api-strict's arrays against the numpy path.

array-api-strict refuses every function outside the array API standard and any mixing with numpy
arrays, so a slip solve that completes on its arrays calls nothing CuPy lacks and copies nothing
between host and device but what ``numerics.backend`` copies explicitly. ``device = "gpu"`` runs on
them through the stand-in GPU of tests/gpu/stub_cupy.py; tests/gpu/test_gpu_slip.py runs the same
comparisons on CuPy. Bounds: tests/problems/slip/slip_agreement.py.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import array_api_strict as xps
import numpy as np
import pytest

from hpcontact.errors import InputError
from hpcontact.numerics import backend
from hpcontact.numerics.backend import namespace, to_host
from hpcontact.numerics.convolution import ArrayConvolutionOperator, ConvolutionOperator
from hpcontact.problems.slip.crystal_pair import PairEngine
from hpcontact.problems.slip.problem import SlipProblem, validate

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "gpu"))
from slip_agreement import REQUIRED, SCENES, check_disc_programme, check_slip_paths  # noqa: E402
from stub_cupy import use_standin_gpu  # noqa: E402

U = 2.0**-53


def test_the_friction_disc_programme_on_strict_arrays_is_the_numpy_one():
    assert check_disc_programme(xps) <= REQUIRED


@pytest.mark.parametrize("name", ["similar", "coupled"])
def test_a_slip_scene_on_the_standin_gpu_is_the_cpu_one(name, monkeypatch):
    use_standin_gpu(monkeypatch)
    assert check_slip_paths(name, "gpu") >= 2


def test_the_crystal_pairs_operator_on_strict_arrays_is_the_pyfftw_one():
    """The pair engine of a crystal scene (``PairEngine``) on ``xp``: xp.fft's convolution against
    pyFFTW's within twice c·log₂(N)·u·max|K̂|·‖t‖₂ (tests/numerics/test_array_api_strict.py)."""
    problem = SlipProblem(validate(SCENES["crystal"][0]))
    g = problem.grid
    kernels = ("xx", "xy", "yx", "yy", "zz")
    device = PairEngine(problem.compliance, g, kernels, xp=xps)
    operator = device.operator("xy")
    assert isinstance(operator, ArrayConvolutionOperator) and isinstance(problem.op_t, ConvolutionOperator)
    traction = np.random.default_rng(11).standard_normal((2, g.nx, g.ny))
    reference = problem.op_t.apply(traction)
    u = operator.apply(xps.asarray(traction))
    assert namespace(u) is xps
    largest = 2 * max(float(np.max(np.abs(problem.engine.spectrum(b)))) for b in ("xx", "xy", "yy"))
    shape = problem.engine.fft_shape
    bound = 2 * 5 * math.log2(shape[0] * shape[1]) * U * largest * np.linalg.norm(traction)
    assert np.linalg.norm(to_host(u) - reference) <= bound


def test_the_device_of_a_slip_scene(monkeypatch):
    """cpu by default; on a machine without CuPy "auto" is the CPU and "gpu" is refused naming the
    field and what is missing, before a grid is allocated."""
    monkeypatch.setattr(backend, "cuda_devices", lambda: (None, 0, "CuPy is not installed"))
    scene = validate(SCENES["similar"][0])
    assert scene.device == "cpu" and SlipProblem(scene).xp is np
    assert SlipProblem(dataclasses.replace(scene, device="auto")).xp is np
    with pytest.raises(InputError, match="device.*CuPy is not installed"):
        SlipProblem(dataclasses.replace(scene, device="gpu"))


def test_auto_takes_the_ranks_own_gpu(monkeypatch):
    standin = use_standin_gpu(monkeypatch)
    scene = validate(SCENES["similar"][0])
    assert SlipProblem(dataclasses.replace(scene, device="auto")).xp is standin


FE_PAIR = {
    "quantities": "slip",
    "radius": 8e-3,
    "load": 100.0,
    "mu": 0.3,
    "q_ratio": 0.5,
    "n": 8,
    "steps": 1,
    "tol": 1e-14,
    "material": "Fe",
    "material2": "Fe",
}


def test_a_slip_scene_solves_on_the_device_its_field_names(monkeypatch):
    """device is a field of a slip scene through ``hpcontact.solve``: "gpu" without CuPy is refused
    naming it, an unknown device too; on the stand-in GPU the record is the CPU one (to 1e-12
    relative, the bound of slip_agreement.py) with the same stick and contact areas."""
    import hpcontact

    monkeypatch.setattr(backend, "cuda_devices", lambda: (None, 0, "CuPy is not installed"))
    with pytest.raises(InputError, match="device.*CuPy"):
        hpcontact.solve(**FE_PAIR, device="gpu")
    with pytest.raises(InputError, match="device"):
        hpcontact.solve(**FE_PAIR, device="tpu")
    cpu = hpcontact.solve(**FE_PAIR)
    use_standin_gpu(monkeypatch)
    gpu = hpcontact.solve(**FE_PAIR, device="gpu")
    for key in ("tangential_force", "tangential_displacement", "tangential_stiffness", "stick_area_stiffness"):
        assert gpu[key] == pytest.approx(cpu[key], rel=1e-12, abs=0.0), key
    assert (gpu["stick_area"], gpu["contact_area"]) == (cpu["stick_area"], cpu["contact_area"])
