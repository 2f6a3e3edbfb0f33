"""Non-periodic convolution of cell tractions with half-space influence coefficients (pyFFTW).

u_i[a] = Σ_j Σ_b K_ij[a − b] t_j[b] over an nx × ny grid is a linear (non-periodic) convolution:
zero-pad to N1 × N2 with N1 ≥ 2nx − 1, N2 ≥ 2ny − 1 (FFTW-friendly sizes), transform with
real-to-complex FFTs, multiply by the kernel spectra, transform back and crop (DESIGN §2.2).
Only the blocks a scene needs are given; a missing block is zero. Plans are built once per
operator with FFTW wisdom reused across operators and processes (``load_wisdom``/``save_wisdom``);
kernel spectra are cached per (material, grid, block).

Units: t in stress, u in length (the blocks carry length/stress).
"""

from __future__ import annotations

import os
import pickle
import threading
import time
from collections import OrderedDict
from pathlib import Path
from typing import Callable, Mapping

import numpy as np
import pyfftw
import scipy.fft

COMPONENT_INDEX = {"x": 0, "y": 1, "z": 2}
_SPECTRUM_CACHE: "OrderedDict[tuple, np.ndarray]" = OrderedDict()
_SPECTRUM_CACHE_BYTES = int(os.environ.get("HPCONTACT_KERNEL_CACHE_MB", "1024")) * 2**20
_LOCK = threading.Lock()


def padded_shape(nx: int, ny: int) -> tuple[int, int]:
    """Smallest FFTW-friendly sizes ≥ (2nx − 1, 2ny − 1): enough for a linear convolution."""
    return (
        scipy.fft.next_fast_len(2 * nx - 1, real=True),
        scipy.fft.next_fast_len(2 * ny - 1, real=True),
    )


def kernel_spectrum(centred: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """rfft2 of a centred offset array (2nx−1, 2ny−1) laid out with wrap-around on ``shape``.

    Spectra of real kernels with even or odd parity in both axes are real or imaginary; the real
    or imaginary part alone is then returned (as float64 or as a complex array with zero real
    part), halving the work of the product in ``apply``.
    """
    m1, m2 = centred.shape
    nx, ny = (m1 + 1) // 2, (m2 + 1) // 2
    padded = np.zeros(shape)
    padded[:m1, :m2] = centred
    padded = np.roll(padded, (-(nx - 1), -(ny - 1)), axis=(0, 1))
    spectrum = np.fft.rfft2(padded)
    scale = np.max(np.abs(spectrum))
    if scale > 0.0 and np.max(np.abs(spectrum.imag)) <= 1e-13 * scale:
        return np.ascontiguousarray(spectrum.real)
    return spectrum


def cached_spectrum(key: tuple, build: Callable[[], np.ndarray], shape: tuple[int, int]) -> np.ndarray:
    """The spectrum for ``key`` (material, grid, block, padded shape), built on first use."""
    full_key = key + (shape,)
    with _LOCK:
        if full_key in _SPECTRUM_CACHE:
            _SPECTRUM_CACHE.move_to_end(full_key)
            return _SPECTRUM_CACHE[full_key]
    spectrum = kernel_spectrum(build(), shape)
    spectrum.setflags(write=False)
    with _LOCK:
        _SPECTRUM_CACHE[full_key] = spectrum
        while sum(s.nbytes for s in _SPECTRUM_CACHE.values()) > _SPECTRUM_CACHE_BYTES and len(_SPECTRUM_CACHE) > 1:
            _SPECTRUM_CACHE.popitem(last=False)
    return spectrum


def clear_cache() -> None:
    """Forget every cached kernel spectrum (tests and memory-bound sweeps)."""
    with _LOCK:
        _SPECTRUM_CACHE.clear()


def wisdom_path() -> Path:
    """Where FFTW wisdom is kept: $HPCONTACT_WISDOM, else ~/.cache/hpcontact/fftw_wisdom.pkl."""
    env = os.environ.get("HPCONTACT_WISDOM")
    return Path(env) if env else Path.home() / ".cache" / "hpcontact" / "fftw_wisdom.pkl"


def load_wisdom() -> bool:
    """Import saved FFTW wisdom (plans then build in milliseconds); False if none or unreadable."""
    path = wisdom_path()
    try:
        with open(path, "rb") as fh:
            pyfftw.import_wisdom(pickle.load(fh))
        return True
    except (OSError, EOFError, pickle.UnpicklingError, ValueError, TypeError):
        return False


def save_wisdom() -> None:
    """Export FFTW wisdom atomically (temporary file, then rename)."""
    path = wisdom_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as fh:
        pickle.dump(pyfftw.export_wisdom(), fh)
    os.replace(tmp, path)


class ConvolutionOperator:
    """u = K * t for ``components`` (e.g. "z", "xy", "xyz") on an nx × ny grid, non-periodic.

    ``spectra`` maps block names ("xx", "xy", ... displacement component first) to kernel
    spectra on ``padded_shape(nx, ny)``; absent blocks are zero. ``threads`` FFTW threads.
    ``apply`` takes and returns arrays of shape (len(components), nx, ny).
    """

    def __init__(
        self,
        nx: int,
        ny: int,
        components: str,
        spectra: Mapping[str, np.ndarray],
        threads: int = 1,
        planner_effort: str = "FFTW_MEASURE",
    ) -> None:
        self.nx, self.ny, self.components = nx, ny, components
        self.shape = padded_shape(nx, ny)
        c = len(components)
        self.pairs = [
            [spectra.get(a + b) for b in components] for a in components
        ]  # pairs[i][j]: block (i, j) or None
        for block in spectra:
            if block[0] not in components or block[1] not in components:
                raise ValueError(f"block {block!r} does not act within components {components!r}")
        n1, n2 = self.shape
        self._real_in = pyfftw.zeros_aligned((c, n1, n2), dtype=np.float64)
        self._real_out = pyfftw.empty_aligned((c, n1, n2), dtype=np.float64)
        self._spec_in = pyfftw.empty_aligned((c, n1, n2 // 2 + 1), dtype=np.complex128)
        self._spec_out = pyfftw.empty_aligned((c, n1, n2 // 2 + 1), dtype=np.complex128)
        t0 = time.perf_counter()
        flags = (planner_effort,)
        self._forward = pyfftw.FFTW(self._real_in, self._spec_in, axes=(1, 2), flags=flags, threads=threads)
        self._inverse = pyfftw.FFTW(
            self._spec_out, self._real_out, axes=(1, 2), direction="FFTW_BACKWARD", flags=flags, threads=threads
        )
        self._real_in[...] = 0.0  # planning may scribble on the arrays
        self.planning_time_s = time.perf_counter() - t0
        self.applications = 0

    def apply(self, traction: np.ndarray) -> np.ndarray:
        """Displacements (c, nx, ny) of tractions (c, nx, ny) on the grid (non-periodic)."""
        nx, ny = self.nx, self.ny
        self._real_in[:, :nx, :ny] = traction
        self._forward()
        for i, row in enumerate(self.pairs):
            out = self._spec_out[i]
            first = True
            for j, spectrum in enumerate(row):
                if spectrum is None:
                    continue
                if first:
                    np.multiply(spectrum, self._spec_in[j], out=out)
                    first = False
                else:
                    out += spectrum * self._spec_in[j]
            if first:
                out[...] = 0.0
        self._inverse()
        self.applications += 1
        return self._real_out[:, :nx, :ny].copy()

    def fft_only(self) -> None:
        """One forward and one inverse transform of all components: the floor of ``apply``."""
        self._forward()
        self._inverse()
