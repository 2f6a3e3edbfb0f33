"""The GPU engine (device = "gpu": CuPy, cuFFT) against the CPU path (issue 41, "done when").

Marked ``gpu``: without CuPy or a CUDA device these tests are skipped (tests/conftest.py), the only
skips CI allows besides the MPI launcher split. On a machine with a GPU they run as they are
(benchmarks/README.md, "GPU"). The comparisons and their bounds are those of
tests/numerics/test_array_api_strict.py (tests/numerics/device_agreement.py): the same code on
CuPy's arrays instead of array-api-strict's, so a difference here is CuPy's or cuFFT's rounding,
bounded the same way (κ of the mask's operator × the true residuals ≤ 1e-12).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import hpcontact
from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import array_namespace, to_host
from hpcontact.numerics.convolution import ArrayConvolutionOperator, ConvolutionOperator, kernel_spectrum, padded_shape

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "numerics"))
from device_agreement import (  # noqa: E402
    REQUIRED,
    SCENES,
    U,
    check_contact_solves,
    check_polonsky_keer,
    scene_params,
)

pytestmark = pytest.mark.gpu


@pytest.fixture(scope="module")
def cupy():
    return array_namespace("gpu")


@pytest.mark.parametrize("n", [64, 512])
def test_convolution_on_the_gpu_is_the_pyfftw_one(cupy, n):
    components, material, h = "xyz", Isotropic(nu=0.3), 1.0 / n
    shape = padded_shape(n, n)
    spectra = {
        a + b: kernel_spectrum(isotropic_block(material, n, n, h, h, a + b), shape)
        for a in components
        for b in components
    }
    traction = np.random.default_rng(3).standard_normal((3, n, n))
    reference = ConvolutionOperator(n, n, components, spectra).apply(traction)
    u = to_host(ArrayConvolutionOperator(n, n, components, spectra, cupy).apply(cupy.asarray(traction)))
    largest = max(np.max(np.abs(s)) for s in spectra.values()) * len(components)
    bound = 2 * 5 * math.log2(shape[0] * shape[1]) * U * largest * np.linalg.norm(traction)
    assert np.linalg.norm(u - reference) <= min(bound, REQUIRED * np.linalg.norm(reference))


@pytest.mark.parametrize("name", sorted(SCENES))
def test_the_contact_solves_on_the_gpu_are_the_cpu_ones(cupy, name, tmp_path):
    assert check_contact_solves(scene_params(name, tmp_path), cupy) >= 1


def test_polonsky_keer_on_the_gpu_is_the_cpu_one(cupy):
    check_polonsky_keer(cupy)


def test_a_whole_solve_on_the_gpu_gives_the_cpu_record(cupy):
    params = {**SCENES["crystal_ellipse"], "tol": 1e-14}
    cpu = hpcontact.solve(**params, device="cpu")
    gpu = hpcontact.solve(**params, device="gpu")
    stiffness = [k for k in cpu if k.startswith("K_")]
    assert stiffness and cpu["iterations"] > 0
    for key in stiffness:  # the per-solve bound above, carried to the stiffness (a resultant)
        assert abs(gpu[key] - cpu[key]) <= REQUIRED * max(abs(cpu[k]) for k in stiffness), key


def test_auto_on_a_rank_with_a_gpu_solves_on_it(cupy, monkeypatch):
    """Device "auto" on local rank 0 of a machine with a GPU: the GPU's namespace, the GPU's record."""
    from hpcontact.numerics import backend

    for name in backend.LOCAL_RANK_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    assert backend.resolved_device("auto") == "gpu" and backend.array_namespace("auto") is cupy
    params = {**SCENES["circle"], "tol": 1e-14}
    assert hpcontact.solve(**params, device="auto")["K_zz"] == hpcontact.solve(**params, device="gpu")["K_zz"]
