"""The device path of the numerics runs on the array-API standard alone (issue 41, item 1).

array-api-strict is a minimal implementation of the Python array API standard: an array of it
refuses every function outside the standard, numpy's included, and mixing with numpy arrays. The
device path (``ArrayConvolutionOperator``, ``conjugate_gradient``, ``polonsky_keer``, the Fourier
preconditioner on ``xp``, the contact solve of ``problems.contact``) run here on its arrays is the
code CuPy runs on a GPU. Each result is compared with the numpy path's (pyFFTW, pocketfft), an
independent implementation of the same arithmetic.

Bounds, from analysis:

- Convolution: each path's FFT route errs by ≲ c·log₂(N)·u·max|K̂|·‖t‖₂ (Gentleman & Sande 1966;
  Parseval: ‖u‖₂ ≤ max|K̂|·‖t‖₂), u = 2⁻⁵³, N = N1·N2 the padded size, c a small constant (5
  here, for the forward transform, the product and the inverse transform); two paths: twice that.
- A linear solve: both solutions x₁, x₂ of P A P x = P b have true residuals ρᵢ = ‖P(A xᵢ − b)‖/‖b‖,
  so ‖x₁ − x₂‖/‖x₁‖ ≤ κ(A_mask)·(ρ₁ + ρ₂) with A_mask the dense matrix of the operator on the mask
  (its columns: the operator applied to unit tractions) and κ = σ_max/σ_min its condition number
  (SVD of a 100–300 unknown matrix); ρᵢ evaluated in extended precision (np.longdouble), so the
  bound holds whatever the rounding inside either iteration. A resultant differs by at most
  cell area·√m·‖x₁ − x₂‖₂ (m unknowns) plus its summation's rounding, m·u·cell area·Σ|x|. The solves run to tol 1e-14 (the least a scene takes), so the bound is ≲ 1e-12, as the
  issue asks; the test checks that as well.
- Polonsky–Keer: on the same contact set both pressures solve A_c p = −h_c, so the bound of a
  linear solve holds with A_c (the operator on the contact cells) and ρᵢ = ‖A_c pᵢ + h_c‖/‖h_c‖.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import array_api_strict as xps
import numpy as np
import pytest

from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import dot, namespace, norm, to_device, to_host
from hpcontact.numerics.convolution import ArrayConvolutionOperator, ConvolutionOperator, kernel_spectrum, padded_shape

sys.path.insert(0, str(Path(__file__).resolve().parent))
from device_agreement import (  # noqa: E402
    REQUIRED,
    SCENES,
    U,
    check_contact_solves,
    check_polonsky_keer,
    scene_params,
)


def test_the_backend_helpers_stay_in_the_standard():
    a = xps.asarray([[3.0, 0.0], [0.0, 4.0]])
    assert namespace(a) is xps and namespace(np.zeros(1)) is np
    assert norm(a) == 5.0 and dot(a, a) == 25.0
    host = to_host(a)
    assert isinstance(host, np.ndarray) and host.tolist() == [[3.0, 0.0], [0.0, 4.0]]
    assert namespace(to_device(host, xps)) is xps
    assert to_device(host, np) is host


@pytest.mark.parametrize("components, nu", [("z", 0.3), ("xy", 0.3), ("xyz", 0.3), ("xyz", 0.0)])
def test_convolution_on_strict_arrays_is_the_pyfftw_one(components, nu):
    nx, ny = 13, 9
    material, dx, dy = Isotropic(nu=nu), 0.1, 0.07
    shape = padded_shape(nx, ny)
    spectra = {
        a + b: kernel_spectrum(isotropic_block(material, nx, ny, dx, dy, a + b), shape)
        for a in components
        for b in components
    }
    spectra = {k: s for k, s in spectra.items() if np.max(np.abs(s)) > 0.0}  # an absent block is zero
    traction = np.random.default_rng(7).standard_normal((len(components), nx, ny))
    reference = ConvolutionOperator(nx, ny, components, spectra).apply(traction)
    device = ArrayConvolutionOperator(nx, ny, components, spectra, xps)
    u = device.apply(xps.asarray(traction))
    assert namespace(u) is xps and u.shape == (len(components), nx, ny) and u.dtype == xps.float64
    largest = max(np.max(np.abs(s)) for s in spectra.values()) * len(components)
    bound = 2 * 5 * math.log2(shape[0] * shape[1]) * U * largest * np.linalg.norm(traction)
    difference = np.linalg.norm(to_host(u) - reference)
    assert difference <= bound
    assert difference <= REQUIRED * np.linalg.norm(reference)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_the_contact_solves_on_strict_arrays_are_the_numpy_ones(name, tmp_path):
    assert check_contact_solves(scene_params(name, tmp_path), xps) >= 1


def test_plain_cg_on_strict_arrays_is_the_numpy_one(tmp_path):
    assert check_contact_solves({**scene_params("star", tmp_path), "precondition": False}, xps) >= 1


def test_polonsky_keer_on_strict_arrays_is_the_numpy_one():
    check_polonsky_keer(xps)
