"""Fourier preconditioner for CG on a contact mask: the inverse of the half-space symbol.

The half-space compliance acts in Fourier space as û = H(m) t̂ / |k| (docs/design.md §2.1 and §2.5;
Johnson 1985 §3.2 for isotropic bodies, Barnett & Lothe 1985 for crystals), H Hermitian positive
definite and depending on the direction m alone. Restricted to the traction components c a solve
couples (e.g. "xy" with normal–tangential coupling neglected, "z", or "xyz"), its inverse
|k| H_cc(m)⁻¹ is applied on a periodic grid over the contact's bounding box (unpadded except
along short axes, ``preconditioner_length``) with the discrete wavenumber
k_x = 2 sin(κ_x dx/2)/dx (bounded at Nyquist like the cell-averaged operator) and |k| floored at
the lowest non-zero wavenumber: symmetric positive definite, and so is its restriction to the
mask, as CG requires. H is tabulated at ``TABLE_ANGLES`` directions (nearest entry used): a
preconditioner need not be exact. One application costs two FFTs on that grid (~1/4 of an
operator application's FFTs when unpadded).

The FFTs are scipy.fft's (pocketfft) on a zero-padded input buffer kept per preconditioner, the
product taken in place: the same arithmetic as padding on each call (bitwise), without two
transient arrays of the periodic grid per application. Not pyFFTW (the operator's
``Transforms``), though faster: its rounding differs from pocketfft's, and CG carries a
difference of 1e-16 per application to up to ~6e-9 relative in the stiffness at tolerance 1e-8
(docs/performance.md §"Fourier preconditioner").

On another array namespace ``xp`` (CuPy on a GPU; ``hpcontact.numerics.backend``) the symbol is
built on the host as above and copied to ``xp`` once; ``apply`` then runs ``xp.fft`` (cuFFT) and
the standard's element-wise products on ``xp``'s arrays, with no copy to or from the host.
"""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import numpy as np

from hpcontact.geometry import Grid
from hpcontact.numerics.backend import Array, is_numpy, to_device
from hpcontact.numerics.convolution import COMPONENT_INDEX, FourierProductStack

TABLE_ANGLES = 1024


def preconditioner_length(n: int, length: float, other_length: float) -> int:
    """Periodic length (cells) of the preconditioner's grid along an axis of ``n`` cells.

    Unpadded where the contact's periodic images barely touch; doubled (no wrap-around) along an
    axis that is short in cells (n < 64) or physically (``length`` < ``other_length``/4), where
    the images of a strip would lie side by side: unpadded, thin contacts took ~15× the CG
    iterations; contacts that are not thin are unaffected (docs/performance.md §"Fourier
    preconditioner").
    """
    import scipy.fft  # on first use, not at import: 0.2-0.4 CPU s a process that solves no grid (exact cells)

    return scipy.fft.next_fast_len(2 * n if (n < 64 or 4.0 * length < other_length) else n, real=True)


class FourierPreconditioner:
    """z = M⁻¹ r for residuals r of shape (c, nx, ny) on ``components`` ("x", "xy", "z", "xyz").

    ``surface_green(phi)`` returns H at in-plane directions φ (radians) as (..., 3, 3). Residuals
    and results are arrays of the namespace ``xp`` (numpy by default).
    """

    def __init__(
        self,
        grid: Grid,
        surface_green: Callable[[np.ndarray], np.ndarray],
        components: str,
        xp: ModuleType = np,
    ) -> None:
        lx, ly = grid.nx * grid.dx, grid.ny * grid.dy
        self.shape = (preconditioner_length(grid.nx, lx, ly), preconditioner_length(grid.ny, ly, lx))
        self.grid_shape = (grid.nx, grid.ny)
        n1, n2 = self.shape
        kx = 2.0 * np.sin(np.pi * np.fft.fftfreq(n1))[:, None] / grid.dx
        ky = 2.0 * np.sin(np.pi * np.fft.rfftfreq(n2))[None, :] / grid.dy
        k = np.hypot(kx, ky)
        k = np.maximum(k, np.min(k[k > 0.0]))
        index = [COMPONENT_INDEX[c] for c in components]
        phi_table = 2.0 * np.pi * np.arange(TABLE_ANGLES) / TABLE_ANGLES
        H = surface_green(phi_table)[:, index][:, :, index]
        inverse_table = np.linalg.inv(H)  # (angles, c, c)
        nearest = np.rint(np.mod(np.arctan2(ky, kx), 2.0 * np.pi) * (TABLE_ANGLES / (2.0 * np.pi))).astype(int)
        symbol = np.moveaxis(inverse_table[nearest % TABLE_ANGLES], (-2, -1), (0, 1)) * k
        if np.max(np.abs(symbol.imag)) == 0.0:
            symbol = symbol.real
        self.xp = xp
        self.symbol = to_device(np.ascontiguousarray(symbol), xp)
        if is_numpy(xp):  # pocketfft through scipy, the CPU path's transforms and rounding
            import scipy.fft  # imported by the grid's length (preconditioner_length)

            self._fft = scipy.fft
            self._padded = np.zeros((len(components),) + self.shape)  # zero outside the grid's cells
        else:  # the symbol's blocks as one scene's products (xp.fft: cuFFT on a GPU)
            c = len(components)
            blocks = [[[self.symbol[i, j, ...] for j in range(c)] for i in range(c)]]
            self._product = FourierProductStack(blocks, self.grid_shape, self.shape, xp)

    def apply(self, residual: Array) -> Array:
        """M⁻¹ r for a residual (c, nx, ny); a new array (c, nx, ny) (a view of a fresh one)."""
        nx, ny = self.grid_shape
        if is_numpy(self.xp):
            self._padded[:, :nx, :ny] = residual
            spectra = self._fft.rfft2(self._padded, axes=(1, 2))
            if spectra.shape[0] == 1:
                out = np.multiply(spectra, self.symbol[0], out=spectra)
            else:  # einsum: faster than the sums below on numpy, and the CPU path's rounding
                out = np.einsum("ij...,j...->i...", self.symbol, spectra)
            result = self._fft.irfft2(out, s=self.shape, axes=(1, 2), overwrite_x=True)
            return result[:, :nx, :ny]
        return self._product.apply(self.xp.expand_dims(residual, axis=0))[0, ...]
