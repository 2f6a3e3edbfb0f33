"""Kernel spectra and convolution operators of one (material, grid), built only as a plan asks.

Block names (displacement component first, docs/design.md §2.5): ``"xy"`` is the block of the surface
Green's function H(m) of one half-space; ``"Re xy"`` the block of its real part Re H(m), the
per-body compliance of an interface between two identical bodies (same material, same
orientation; see ``hpcontact.plan``). In real space Re H is the even part of the kernel,
and by reciprocity K_ab(−r) = K_ba(r) that is the cell-exact average (K_ab + K_ba)/2; a
diagonal block is already even (``"Re xx"`` is ``"xx"``). For an isotropic body Re H differs from
H only in the coupling blocks, which vanish: (K_xz + K_zx)/2 = 0.

The kernels and their spectra are made on the host (numpy) and cached there; an engine on
another array namespace (``xp``: CuPy on a GPU, ``hpcontact.numerics.backend``) copies each spectrum
to it once, when an operator is made (``ArrayConvolutionOperator``), and its operators then take
and return arrays of ``xp``.

Units: displacement per traction (length/stress), as the kernels.
"""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import numpy as np

from hpcontact.geometry import Grid
from hpcontact.kernels.anisotropic import anisotropic_offset_blocks, kernel_for
from hpcontact.kernels.isotropic import isotropic_block, isotropic_surface_green
from hpcontact.materials.crystal import Crystal
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import is_numpy
from hpcontact.numerics.convolution import (
    COMPONENT_INDEX,
    ArrayConvolutionOperator,
    ConvolutionOperator,
    cached_spectrum,
    padded_shape,
)

#: Green's functions a solve can use: H of one body, or Re H (two identical bodies, per body).
GREENS = ("H", "Re H")


def block_name(a: str, b: str, green: str) -> str:
    """Name of block (a, b) of ``green``: "ab" for H and for diagonal blocks, else "Re ab" with
    a, b in x, y, z order (Re H is symmetric: "Re xy" serves (x, y) and (y, x))."""
    if green not in GREENS:
        raise ValueError(f"unknown Green's function {green!r}; expected one of {GREENS}")
    if green == "H" or a == b:
        return a + b
    return "Re " + "".join(sorted(a + b))


def _pair(block: str) -> str:
    return block.split()[-1]


class Engine:
    """Kernel spectra and operators of one (material, grid), built only as the plan asks; the
    operators act on arrays of ``xp`` (numpy: pyFFTW's ``ConvolutionOperator``; another namespace:
    ``ArrayConvolutionOperator``)."""

    def __init__(
        self,
        material: Isotropic | Crystal,
        grid: Grid,
        kernels: tuple[str, ...],
        threads: int = 1,
        xp: ModuleType = np,
    ) -> None:
        self.material, self.grid, self.threads, self.xp = material, grid, threads, xp
        self.kernels = kernels
        self._operators: dict[tuple[str, str], ConvolutionOperator | ArrayConvolutionOperator] = {}
        self.fft_shape = padded_shape(grid.nx, grid.ny)
        self._crystal_blocks: dict[str, np.ndarray] | None = None

    def _raw_block(self, block: str) -> np.ndarray:
        """Influence coefficients of an H block ("xy") on the centred offset grid."""
        g, m = self.grid, self.material
        if isinstance(m, Isotropic):
            return isotropic_block(m, g.nx, g.ny, g.dx, g.dy, block)
        if self._crystal_blocks is None:  # every planned block in one pass (shared work)
            names = {_pair(b) for b in self.kernels} | {_pair(b)[::-1] for b in self.kernels if b.startswith("Re ")}
            names = sorted(names)
            pairs = [(COMPONENT_INDEX[b[0]], COMPONENT_INDEX[b[1]]) for b in names]
            blocks = anisotropic_offset_blocks(m, g.nx, g.ny, g.dx, g.dy, pairs, threads=self.threads)
            self._crystal_blocks = {b: blocks[p] for b, p in zip(names, pairs)}
        return self._crystal_blocks[block]

    def centred_block(self, block: str) -> np.ndarray:
        """Influence coefficients of ``block`` ("xy" or "Re xy") on the centred offset grid."""
        if not block.startswith("Re "):
            return self._raw_block(block)
        pair = _pair(block)
        return 0.5 * (self._raw_block(pair) + self._raw_block(pair[::-1]))

    def surface_green(self, phi: np.ndarray, green: str = "H") -> np.ndarray:
        """H(m) (or Re H(m)) of the material at in-plane directions φ (for the preconditioner).

        A crystal's H is summed from the Fourier series its kernel already holds
        (``AnisotropicKernel.fourier_series``: converged to ≤ 1e-15 of its largest coefficient),
        not integrated again by Barnett–Lothe for every solve: that took 0.18 s per solve on the
        preconditioner's 1024 directions, more than half of a crystal scene's time at
        ``--accuracy 1e-3``; the series takes milliseconds."""
        if isinstance(self.material, Isotropic):
            H = isotropic_surface_green(self.material, phi)
        else:
            H = kernel_for(self.material).fourier_series(phi)
        return H if green == "H" else H.real.astype(np.complex128)

    def green_function(self, green: str) -> Callable[[np.ndarray], np.ndarray]:
        """φ ↦ H(φ) or Re H(φ): the symbol the Fourier preconditioner inverts."""
        return lambda phi: self.surface_green(phi, green)

    def spectrum(self, block: str) -> np.ndarray:
        """Spectrum of ``block``; at nu = 0 the yy block is the xx block (one kernel)."""
        if block not in self.kernels and block == "yy" and "xx" in self.kernels:
            block = "xx"
        if block not in self.kernels:
            raise KeyError(block)
        g, m = self.grid, self.material
        key = (m.key, g.nx, g.ny, g.dx, g.dy, block)
        return cached_spectrum(key, lambda: self.centred_block(block), self.fft_shape)

    def spectra(self, components: str, green: str = "H") -> dict[str, np.ndarray]:
        """The host spectra of ``operator(components, green)``: every planned block of ``green``
        among ``components``, by block name ("xx", "xz", …; absent blocks are zero)."""
        spectra = {}
        for a in components:
            for b in components:
                try:
                    spectra[a + b] = self.spectrum(block_name(a, b, green))
                except KeyError:
                    continue
        return spectra

    def operator(self, components: str, green: str = "H") -> ConvolutionOperator | ArrayConvolutionOperator:
        """The convolution operator on ``components`` with every planned block of ``green`` among them."""
        if (components, green) not in self._operators:
            spectra = self.spectra(components, green)
            nx, ny = self.grid.nx, self.grid.ny
            self._operators[(components, green)] = (
                ConvolutionOperator(nx, ny, components, spectra, threads=self.threads)
                if is_numpy(self.xp)
                else ArrayConvolutionOperator(nx, ny, components, spectra, self.xp)
            )
        return self._operators[(components, green)]
