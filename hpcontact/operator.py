"""Non-periodic convolution of cell tractions with half-space influence coefficients (pyFFTW).

u_i[a] = Σ_j Σ_b K_ij[a − b] t_j[b] over an nx × ny grid is a linear (non-periodic) convolution:
zero-pad to N1 × N2 with N1 ≥ 2nx − 1, N2 ≥ 2ny − 1 (FFTW-friendly sizes), transform with
real-to-complex FFTs, multiply by the kernel spectra, transform back and crop (DESIGN §2.2).
Only the blocks a scene needs are given; a missing block is zero. Plans are built once per
operator (by default from FFTW wisdom when there is some, else FFTW_ESTIMATE, upgraded to
FFTW_MEASURE for operators applied many times; see ``AUTO_MEASURE_AFTER``), with FFTW wisdom
reused across operators and processes (``load_wisdom``/``save_wisdom``); kernel spectra are
cached per (material, grid, block).

Units: t in stress, u in length (the blocks carry length/stress).
"""

from __future__ import annotations

import os
import threading
import time
import warnings
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
# planner_effort="auto": plans come from FFTW wisdom at FFTW_MEASURE when there is some (planning
# then takes milliseconds), else from FFTW_ESTIMATE; an operator applied AUTO_MEASURE_AFTER times
# is re-planned with FFTW_MEASURE (which costs ~20-300 transforms of planning and makes each
# transform ~1.4-1.8x faster, so it pays off only for long runs; the new wisdom then serves
# every later operator of the same problem in the process, and across processes via save_wisdom).
AUTO_MEASURE_AFTER = 100


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


WISDOM_MAX_BYTES = 64 * 2**20  # a wisdom file is a few kB to a few MB of text


def wisdom_path() -> Path:
    """Where FFTW wisdom is kept: $HPCONTACT_WISDOM, else ~/.cache/hpcontact/fftw_wisdom (the
    double-precision wisdom text exactly as FFTW exports it; no pickle, so a file shared between
    jobs can at worst hold useless plans, never code)."""
    env = os.environ.get("HPCONTACT_WISDOM")
    return Path(env) if env else Path.home() / ".cache" / "hpcontact" / "fftw_wisdom"


def load_wisdom() -> bool:
    """Import saved FFTW wisdom (plans then build in milliseconds); False if there is none. A
    file that cannot be read or that FFTW does not accept (another format, another FFTW, a
    truncated file) is ignored with a warning."""
    path = wisdom_path()
    try:
        with open(path, "rb") as fh:
            data = fh.read(WISDOM_MAX_BYTES + 1)
    except FileNotFoundError:
        return False
    except OSError as exc:
        warnings.warn(f"FFTW wisdom {path} ignored: {exc.strerror or exc}", RuntimeWarning, stacklevel=2)
        return False
    if len(data) > WISDOM_MAX_BYTES or not data.startswith(b"(fftw-") or not pyfftw.import_wisdom((data, b"", b""))[0]:
        warnings.warn(f"FFTW wisdom {path} ignored: not double-precision wisdom this FFTW accepts", RuntimeWarning,
                      stacklevel=2)
        return False
    return True


def save_wisdom() -> None:
    """Export the double-precision FFTW wisdom as FFTW writes it, atomically (temporary file,
    then rename)."""
    path = wisdom_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_bytes(pyfftw.export_wisdom()[0])
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


class ConvolutionOperator:
    """u = K * t for ``components`` (e.g. "z", "xy", "xyz") on an nx × ny grid, non-periodic.

    ``spectra`` maps block names ("xx", "xy", ... displacement component first) to kernel
    spectra on ``padded_shape(nx, ny)``; absent blocks are zero. ``threads`` FFTW threads.
    ``apply`` takes and returns arrays of shape (len(components), nx, ny).

    The 2-D transforms are split into row (axis 2) and column (axis 1) passes so that the zero
    padding is skipped where it is known: the padded input is zero in rows nx … N1−1, so the
    forward row transforms run on the nx data rows only, and only rows 0 … nx−1 of the result are
    kept, so the inverse row transforms run on those nx rows only. The column passes are full
    length N1. This is the same arithmetic as the full 2-D transforms (bitwise, with FFTW's
    row-column algorithm) at ~3/4 of the work; the 1/(N1·N2) normalization of the inverse is
    folded into the final crop instead of a separate pass over the padded array.

    ``planner_effort`` is an FFTW planner flag ("FFTW_ESTIMATE", "FFTW_MEASURE", ...) or "auto"
    (default): FFTW_MEASURE plans from wisdom if FFTW has it for these problems, else
    FFTW_ESTIMATE plans, re-planned with FFTW_MEASURE after ``AUTO_MEASURE_AFTER`` applications.
    ``plan_effort`` says which plans are in use; ``planning_time_s`` is the planning time so far.
    """

    def __init__(
        self,
        nx: int,
        ny: int,
        components: str,
        spectra: Mapping[str, np.ndarray],
        threads: int = 1,
        planner_effort: str = "auto",
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
        half = n2 // 2 + 1
        # real buffers hold the nx data rows only; spectra are full (N1 rows) for the columns
        self._real_in = pyfftw.zeros_aligned((c, nx, n2), dtype=np.float64)
        self._real_out = pyfftw.zeros_aligned((c, nx, n2), dtype=np.float64)
        self._spec_in = pyfftw.zeros_aligned((c, n1, half), dtype=np.complex128)
        # one component: the product is taken in place; several: a separate output
        self._spec_out = self._spec_in if c == 1 else pyfftw.zeros_aligned((c, n1, half), dtype=np.complex128)
        # Products with real spectra (even-even and odd-odd kernels) are taken on the float64
        # view of the complex planes against a copy of the spectrum with every value doubled
        # (re and im factors side by side): a contiguous float multiply, ~2x faster than numpy's
        # mixed float-by-complex product. Imaginary spectra (odd-even kernels) stay complex.
        doubled: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._factors: list[list[tuple[bool, np.ndarray] | None]] = []
        for row in self.pairs:
            factors: list[tuple[bool, np.ndarray] | None] = []
            for spectrum in row:
                if spectrum is None:
                    factors.append(None)
                    continue
                if spectrum.shape != (n1, half):
                    raise ValueError(f"spectrum of shape {spectrum.shape}; expected {(n1, half)} for this grid")
                if np.iscomplexobj(spectrum):
                    factors.append((False, np.asarray(spectrum, dtype=np.complex128)))
                else:
                    key = next((k for k, (original, _) in doubled.items() if original is spectrum or
                                np.array_equal(original, spectrum)), id(spectrum))  # e.g. xy = yx: one copy
                    if key not in doubled:
                        doubled[key] = (spectrum, np.repeat(np.asarray(spectrum, dtype=np.float64), 2, axis=1))
                    factors.append((True, doubled[key][1]))
            self._factors.append(factors)
        sums = any(sum(f is not None for f in row) > 1 for row in self._factors)
        # sums over blocks run in bands of rows that stay in cache (~512 KiB a plane), with a
        # band-sized scratch for the products
        self._band = max(1, 2**19 // (16 * half)) if sums else n1
        self._scratch = pyfftw.zeros_aligned((self._band, half), dtype=np.complex128) if sums else None
        self._scale = 1.0 / (n1 * n2)
        self._threads = threads
        self.applications = 0
        t0 = time.perf_counter()
        if planner_effort == "auto":
            self.plan_effort = self._plan("FFTW_MEASURE", wisdom_only=True)
            self._measure_at = AUTO_MEASURE_AFTER if self.plan_effort != "FFTW_MEASURE" else None
        else:
            self.plan_effort = self._plan(planner_effort)
            self._measure_at = None
        self.planning_time_s = time.perf_counter() - t0

    def _plan(self, effort: str, wisdom_only: bool = False) -> str:
        """Build the four FFTW plans at ``effort``; with ``wisdom_only``, each plan that FFTW has no
        wisdom for at that effort is made with FFTW_ESTIMATE instead. Returns the effort in use
        ("FFTW_ESTIMATE" if any plan fell back). Planning overwrites the buffers: they are cleared.
        """
        nx, threads = self.nx, self._threads
        fell_back = False

        def make(input_array, output_array, axis, direction, extra=()):
            nonlocal fell_back
            kwargs = dict(axes=(axis,), direction=direction, threads=threads)
            if wisdom_only:
                try:
                    return pyfftw.FFTW(input_array, output_array, flags=(effort, "FFTW_WISDOM_ONLY") + extra, **kwargs)
                except RuntimeError:  # no wisdom for this problem
                    fell_back = True
                    return pyfftw.FFTW(input_array, output_array, flags=("FFTW_ESTIMATE",) + extra, **kwargs)
            return pyfftw.FFTW(input_array, output_array, flags=(effort,) + extra, **kwargs)

        # rows: axis 2 of the nx data rows; columns: axis 1, full length N1, in place
        self._rows_forward = make(self._real_in, self._spec_in[:, :nx, :], 2, "FFTW_FORWARD")
        self._columns_forward = make(self._spec_in, self._spec_in, 1, "FFTW_FORWARD")
        self._columns_inverse = make(self._spec_out, self._spec_out, 1, "FFTW_BACKWARD")
        self._rows_inverse = make(
            self._spec_out[:, :nx, :], self._real_out, 2, "FFTW_BACKWARD", ("FFTW_DESTROY_INPUT",)
        )
        self._real_in[...] = 0.0  # planning may scribble on the arrays
        self._spec_out[...] = 0.0
        return "FFTW_ESTIMATE" if fell_back else effort

    def _forward(self) -> None:
        """Spectra of the zero-padded ``_real_in`` into ``_spec_in`` (unnormalized)."""
        self._rows_forward.execute()
        self._spec_in[:, self.nx :, :] = 0.0  # the padding rows (the column pass overwrote them)
        self._columns_forward.execute()

    def _inverse(self) -> None:
        """Rows 0 … nx−1 of the inverse transform of ``_spec_out`` into ``_real_out`` (× N1·N2)."""
        self._columns_inverse.execute()
        self._rows_inverse.execute()

    def _product(self) -> None:
        """_spec_out[i] = Σ_j K_ij · _spec_in[j] (in place when there is one component)."""
        spec_in, spec_out, scratch = self._spec_in, self._spec_out, self._scratch
        n1, band = self.shape[0], self._band
        for r0 in range(0, n1, band):
            rows = slice(r0, r0 + band)
            for i, row in enumerate(self._factors):
                out = spec_out[i, rows]
                first = True
                for j, factor in enumerate(row):
                    if factor is None:
                        continue
                    real, spectrum = factor
                    target = out if first else scratch[: out.shape[0]]
                    if real:
                        np.multiply(spectrum[rows], spec_in[j, rows].view(np.float64), out=target.view(np.float64))
                    else:
                        np.multiply(spectrum[rows], spec_in[j, rows], out=target)
                    if not first:
                        out += target
                    first = False
                if first:
                    out[...] = 0.0

    def apply(self, traction: np.ndarray) -> np.ndarray:
        """Displacements (c, nx, ny) of tractions (c, nx, ny) on the grid (non-periodic)."""
        if self._measure_at is not None and self.applications >= self._measure_at:
            t0 = time.perf_counter()  # applied often enough for FFTW_MEASURE plans to pay off
            self.plan_effort = self._plan("FFTW_MEASURE")
            self._measure_at = None
            self.planning_time_s += time.perf_counter() - t0
        ny = self.ny
        self._real_in[:, :, :ny] = traction
        self._forward()
        self._product()
        self._inverse()
        self.applications += 1
        return np.multiply(self._real_out[:, :, :ny], self._scale)

    def fft_only(self) -> None:
        """One forward and one inverse transform of all components: the floor of ``apply``."""
        self._forward()
        self._inverse()
