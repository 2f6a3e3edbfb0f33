"""FourierPreconditioner (``hpcontact.numerics.preconditioner``): the reused padded buffer and the in-place
product give bitwise the arithmetic of a fresh zero-padded transform on every call."""

from __future__ import annotations

from functools import partial

import numpy as np
import pytest
import scipy.fft

from hpcontact.geometry import Grid
from hpcontact.kernels.isotropic import isotropic_surface_green
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.preconditioner import FourierPreconditioner


def _reference(pc: FourierPreconditioner, r: np.ndarray) -> np.ndarray:
    """M⁻¹ r as first written: pad on the call, product into a new array."""
    spectra = scipy.fft.rfft2(r, s=pc.shape, axes=(1, 2))
    out = spectra * pc.symbol[0] if spectra.shape[0] == 1 else np.einsum("ij...,j...->i...", pc.symbol, spectra)
    return scipy.fft.irfft2(out, s=pc.shape, axes=(1, 2))[:, : pc.grid_shape[0], : pc.grid_shape[1]]


@pytest.mark.parametrize("components", ["z", "x", "xy", "xyz"])
@pytest.mark.parametrize("nx, ny, dy", [(40, 30, 0.05), (70, 9, 0.01), (91, 91, 0.02)])
def test_apply_is_bitwise_a_fresh_padded_transform(components, nx, ny, dy):
    pc = FourierPreconditioner(
        Grid(nx=nx, ny=ny, dx=0.02, dy=dy), partial(isotropic_surface_green, Isotropic(G=1.0, nu=0.3)), components
    )
    assert pc.shape[0] >= nx and pc.shape[1] >= ny and pc.shape != (nx, ny)  # some padding to keep zero
    rng = np.random.default_rng(nx + ny)
    first = rng.normal(size=(len(components), nx, ny))
    second = rng.normal(size=(len(components), nx, ny))
    z1 = pc.apply(first)
    z2 = pc.apply(second)  # the buffer still holds the first residual's cells: overwritten, padding zero
    assert np.array_equal(z1, _reference(pc, first))
    assert np.array_equal(z2, _reference(pc, second))
    assert np.array_equal(pc.apply(first), z1)
    assert not np.shares_memory(z1, z2)  # results are not views of a reused buffer
