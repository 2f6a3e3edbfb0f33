"""Non-periodic convolution of cell tractions with half-space influence coefficients (pyFFTW).

u_i[a] = Σ_j Σ_b K_ij[a − b] t_j[b] over an nx × ny grid is a linear (non-periodic) convolution:
zero-pad to N1 × N2 with N1 ≥ 2nx − 1, N2 ≥ 2ny − 1 (FFTW-friendly sizes), transform with
real-to-complex FFTs, multiply by the kernel spectra, transform back and crop (docs/design.md §2.2).
Only the blocks a scene needs are given; a missing block is zero. The FFT buffers and plans
belong to the process, one set per layout (components, data rows, padded shape, threads; see
``Transforms``), shared by every operator of that layout: a sweep's many scenes on one grid plan
once. Plans come from FFTW wisdom when there is some, else FFTW_ESTIMATE, upgraded to
FFTW_MEASURE once the layout has been applied long enough for the planning to pay (see
``MEASURE_AFTER_SECONDS``); wisdom is kept across processes and merged between them
(``load_wisdom``/``save_wisdom``); kernel spectra are cached per (material, grid, block).

Units: t in stress, u in length (the blocks carry length/stress).
"""

from __future__ import annotations

import fcntl
import os
import sys
import threading
import time
import warnings
import weakref
from collections import OrderedDict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

from hpcontact.errors import InputError
from hpcontact.numerics.backend import Array, to_device


def _import_pyfftw_alone():
    """``pyfftw``, imported without its optional dask and scipy interfaces.

    ``pyfftw/interfaces/__init__.py`` (0.15) tries ``from dask.array.fft import fft_wrap`` and
    builds ``pyfftw.interfaces.dask_fft`` when dask is installed: 1.1 s of every process's
    start-up (measured: ``python -X importtime``, 2.4 s → 1.3 s for ``import hpcontact.cli`` on
    the 2-core development VM, 2026-11-26), paid by every rank of every job in an environment
    with xarray's dask extra; and it imports ``scipy.fftpack`` (and with it ``scipy.fft`` and
    ``scipy.special``) for its scipy interfaces: 0.25-0.35 s more (2026-11-29, same VM), which a
    process that solves no grid (exact cells, the 4-D map's every task) never needs.
    hpcontact uses only ``pyfftw.FFTW`` and the wisdom functions, so both are hidden (a ``None``
    entry in ``sys.modules`` makes their import raise ImportError, which pyfftw catches) while
    pyfftw imports, unless already imported; ``import dask`` or ``import scipy.fft`` afterwards
    works as usual (this module and ``preconditioner`` import ``scipy.fft`` at first use).
    """
    hidden = [name for name in ("dask", "scipy.fftpack") if name not in sys.modules]
    for name in hidden:
        sys.modules[name] = None  # type: ignore[assignment]
    try:
        import pyfftw as module
    finally:
        for name in hidden:
            del sys.modules[name]
    return module


pyfftw = _import_pyfftw_alone()

COMPONENT_INDEX = {"x": 0, "y": 1, "z": 2}
_SPECTRUM_CACHE: OrderedDict[tuple, np.ndarray] = OrderedDict()
_SPECTRUM_CACHE_BYTES = int(os.environ.get("HPCONTACT_KERNEL_CACHE_MB", "1024")) * 2**20
_TRANSFORMS: dict[tuple, Transforms] = {}  # FFT buffers and plans per layout (transforms_for)
_USAGE: dict[tuple, Usage] = {}  # per layout, kept when its buffers are dropped (clear_cache forgets)
_EXPECTED: dict[
    tuple, float
] = {}  # applications this process expects per (components, padded shape): expect_applications
_LOCK = threading.Lock()
# planner_effort="auto": a layout's plans come from FFTW wisdom at FFTW_MEASURE when there is some
# (planning then takes milliseconds), else from FFTW_ESTIMATE; they are re-planned with
# FFTW_MEASURE once the layout's applications (all operators of the process together) number at
# least MEASURE_AFTER_APPLICATIONS and have taken MEASURE_AFTER_SECONDS + that many mean
# applications' time, i.e. after n = 35 + 1.3 s / (time of one application) applications. That is
# ski rental (buy about when the rent paid would have bought): FFTW_MEASURE planning pays for
# itself after a few dozen applications on large grids and hundreds on small ones, and on those
# grids the rule re-plans within a few dozen applications of that break-even (docs/performance.md
# §"FFTW planning"; benchmarks/solve_speed.py's cold table, column `b-even`).
# Small grids keep their ESTIMATE plans unless a long run applies them; measured plans then
# serve later processes through the wisdom file (save_wisdom).
# A sweep knows its future (expect_applications): the rule is then applied to the applications
# the process expects in all, not those made so far, so a layout that will pay re-plans at its
# first application instead of after ~43-78 (ski rental with a known season: buy at once).
# Known limit: on the non-power-of-two padded shapes of singular cells (one component) planning
# is slower and saves less, and the rule re-plans ~3x too early (docs/performance.md §"FFTW
# planning").
MEASURE_AFTER_APPLICATIONS = 35
#: Environment variable that sets the default planner effort of every operator of the process:
#: "auto" (unset) or an FFTW flag. "FFTW_ESTIMATE" makes the plans, and so every result, the same in
#: every process: "auto" and FFTW_MEASURE choose plans by timing, and different plans round
#: differently (a stiffness moves by up to ~3e-12 relative through CG on thin contacts:
#: docs/validation.md §"Rounding across FFTW plans").
PLANNER_ENV = "HPCONTACT_FFTW_PLANNER"
PLANNER_EFFORTS = ("auto", "FFTW_ESTIMATE", "FFTW_MEASURE", "FFTW_PATIENT", "FFTW_EXHAUSTIVE")
MEASURE_AFTER_SECONDS = 1.3


def padded_shape(nx: int, ny: int) -> tuple[int, int]:
    """Smallest FFTW-friendly sizes ≥ (2nx − 1, 2ny − 1): enough for a linear convolution."""
    import scipy.fft  # on first use, not at import: 0.2-0.4 CPU s a process that solves no grid (exact cells)

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
    """Forget every cached kernel spectrum and the FFT buffers and plans no operator uses
    (tests and memory-bound sweeps; FFTW's wisdom stays)."""
    with _LOCK:
        _SPECTRUM_CACHE.clear()
        for key in _drop_unused_transforms():
            del _USAGE[key]


def _drop_unused_transforms() -> list[tuple]:
    """Forget the ``Transforms`` no live operator holds (call with ``_LOCK`` held); their keys."""
    unused = [k for k, t in _TRANSFORMS.items() if not t.users]
    for key in unused:
        del _TRANSFORMS[key]
    return unused


WISDOM_MAX_BYTES = 64 * 2**20  # a wisdom file is a few kB to a few MB of text


def wisdom_path() -> Path:
    """Where FFTW wisdom is kept: $HPCONTACT_WISDOM, else ~/.cache/hpcontact/fftw_wisdom (the
    double-precision wisdom text exactly as FFTW exports it; no pickle, so a file shared between
    jobs can at worst hold useless plans, never code)."""
    env = os.environ.get("HPCONTACT_WISDOM")
    return Path(env) if env else Path.home() / ".cache" / "hpcontact" / "fftw_wisdom"


def _read_wisdom(path: Path) -> bytes | None:
    """The wisdom text at ``path``, None if there is no file; OSError if it cannot be read."""
    try:
        with open(path, "rb") as fh:
            return fh.read(WISDOM_MAX_BYTES + 1)
    except FileNotFoundError:
        return None


def _import_wisdom(data: bytes) -> bool:
    """Add ``data`` to this process's FFTW wisdom (FFTW keeps the union); False if FFTW refuses it."""
    return len(data) <= WISDOM_MAX_BYTES and data.startswith(b"(fftw-") and pyfftw.import_wisdom((data, b"", b""))[0]


def load_wisdom() -> bool:
    """Import saved FFTW wisdom (plans then build in milliseconds); False if there is none. A
    file that cannot be read or that FFTW does not accept (another format, another FFTW, a
    truncated file) is ignored with a warning."""
    path = wisdom_path()
    try:
        data = _read_wisdom(path)
    except OSError as exc:
        warnings.warn(f"FFTW wisdom {path} ignored: {exc.strerror or exc}", RuntimeWarning, stacklevel=2)
        return False
    if data is None:
        return False
    if not _import_wisdom(data):
        warnings.warn(
            f"FFTW wisdom {path} ignored: not double-precision wisdom this FFTW accepts", RuntimeWarning, stacklevel=2
        )
        return False
    return True


def save_wisdom() -> None:
    """Merge this process's double-precision FFTW wisdom into the wisdom file.

    Under an exclusive lock on ``<file>.lock`` (``flock``; where the file system has no locks,
    unlocked), the file's wisdom is imported first (FFTW keeps the union, so plans that other
    processes or ranks saved meanwhile survive; a file FFTW refuses is replaced), then the union
    is written as FFTW exports it, atomically (temporary file, then rename): every rank of a
    sweep can save, and a reader never sees a partial file."""
    path = wisdom_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_name(f"{path.name}.lock"), "ab") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX)
        except OSError:  # no locks on this file system: a concurrent writer may drop our plans, no more
            pass
        try:
            data = _read_wisdom(path)
        except OSError:
            data = None  # unreadable: replaced below
        if data is not None:
            _import_wisdom(data)
        tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
        try:
            tmp.write_bytes(pyfftw.export_wisdom()[0])
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)


@dataclass
class Usage:
    """Applications of one layout in this process, and the seconds they took with ESTIMATE plans."""

    applications: int = 0
    estimate_seconds: float = 0.0


class Transforms:
    """Zero-padded FFT buffers and the four FFTW plans of one layout: ``c`` components of ``nx``
    data rows on the padded ``shape`` (N1, N2), ``threads`` FFTW threads.

    The 2-D transforms are split into row (axis 2) and column (axis 1) passes so that the zero
    padding is skipped where it is known: the padded input is zero in rows nx … N1−1, so the
    forward row transforms run on the nx data rows only, and only rows 0 … nx−1 of the result are
    kept, so the inverse row transforms run on those nx rows only. The column passes are full
    length N1. This is the same arithmetic as the full 2-D transforms (bitwise, with FFTW's
    row-column algorithm) at ~3/4 of the work.

    One instance serves every operator of the process with this layout and planner effort
    (``transforms_for``): buffers are scratch within one ``apply``, so operators applied one at a
    time can share them. ``effort`` is the effort of the plans in use; ``usage`` counts the
    layout's applications (all operators together, also those of earlier instances of the
    layout in this process); ``users`` are the operators holding it.
    """

    def __init__(self, c: int, nx: int, shape: tuple[int, int], threads: int, effort: str, usage: Usage) -> None:
        n1, n2 = shape
        half = n2 // 2 + 1
        self.nx, self.threads, self.auto = nx, threads, effort == "auto"
        self.layout = (c, tuple(shape))  # what expect_applications counts by
        # real buffers hold the nx data rows only; spectra are full (N1 rows) for the columns
        self.real_in = pyfftw.zeros_aligned((c, nx, n2), dtype=np.float64)
        self.real_out = pyfftw.zeros_aligned((c, nx, n2), dtype=np.float64)
        self.spec_in = pyfftw.zeros_aligned((c, n1, half), dtype=np.complex128)
        # one component: the product is taken in place; several: a separate output
        self.spec_out = self.spec_in if c == 1 else pyfftw.zeros_aligned((c, n1, half), dtype=np.complex128)
        self.users: weakref.WeakSet[ConvolutionOperator] = weakref.WeakSet()
        self.usage, self.planning_time_s = usage, 0.0
        self.effort = self.plan("FFTW_MEASURE", wisdom_only=True) if self.auto else self.plan(effort)

    def plan(self, effort: str, wisdom_only: bool = False) -> str:
        """Build the four FFTW plans at ``effort``; with ``wisdom_only``, each plan that FFTW has no
        wisdom for at that effort is made with FFTW_ESTIMATE instead. Returns the effort in use
        ("FFTW_ESTIMATE" if any plan fell back). Planning overwrites the buffers: they are cleared.
        """
        t0 = time.perf_counter()
        nx, threads = self.nx, self.threads
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
        self._rows_forward = make(self.real_in, self.spec_in[:, :nx, :], 2, "FFTW_FORWARD")
        self._columns_forward = make(self.spec_in, self.spec_in, 1, "FFTW_FORWARD")
        self._columns_inverse = make(self.spec_out, self.spec_out, 1, "FFTW_BACKWARD")
        self._rows_inverse = make(self.spec_out[:, :nx, :], self.real_out, 2, "FFTW_BACKWARD", ("FFTW_DESTROY_INPUT",))
        self.real_in[...] = 0.0  # planning may scribble on the arrays
        self.spec_out[...] = 0.0
        self.planning_time_s += time.perf_counter() - t0
        return "FFTW_ESTIMATE" if fell_back else effort

    def forward(self) -> None:
        """Spectra of the zero-padded ``real_in`` into ``spec_in`` (unnormalized)."""
        self._rows_forward.execute()
        self.spec_in[:, self.nx :, :] = 0.0  # the padding rows (the column pass overwrote them)
        self._columns_forward.execute()

    def inverse(self) -> None:
        """Rows 0 … nx−1 of the inverse transform of ``spec_out`` into ``real_out`` (× N1·N2)."""
        self._columns_inverse.execute()
        self._rows_inverse.execute()

    def count(self, seconds: float) -> None:
        """Record one application that took ``seconds``; with effort "auto", re-plan with
        FFTW_MEASURE when the rule of ``MEASURE_AFTER_SECONDS`` says it pays: once the
        applications so far, or those the process expects in all (``expect_applications``),
        number n ≥ 35 + 1.3 s / (mean time of one application)."""
        usage = self.usage
        usage.applications += 1
        if not self.auto or self.effort != "FFTW_ESTIMATE":
            return
        usage.estimate_seconds += seconds
        n = max(usage.applications, _EXPECTED.get(self.layout, 0.0))
        mean = usage.estimate_seconds / usage.applications
        if n >= MEASURE_AFTER_APPLICATIONS and mean * (n - MEASURE_AFTER_APPLICATIONS) >= MEASURE_AFTER_SECONDS:
            self.effort = self.plan("FFTW_MEASURE")


def expect_applications(expected: Mapping[tuple[int, tuple[int, int]], float]) -> None:
    """Tell the planner how many operator applications this process expects per layout
    (components c, padded shape (N1, N2)), e.g. a sweep rank's share of its tasks' CG iterations
    (``hpcontact.problems.footprint.fft_applications``); replaces what was expected before. Layouts
    whose expected applications pay for FFTW_MEASURE planning get it at their first application
    (``Transforms.count``); an empty mapping restores the rule on applications made so far."""
    with _LOCK:
        _EXPECTED.clear()
        _EXPECTED.update({(int(c), tuple(int(x) for x in shape)): float(n) for (c, shape), n in expected.items()})


def default_planner_effort() -> str:
    """The planner effort of operators made without one: ``PLANNER_ENV`` or "auto"."""
    effort = os.environ.get(PLANNER_ENV, "auto")
    if effort not in PLANNER_EFFORTS:
        raise InputError(PLANNER_ENV, f"one of {', '.join(PLANNER_EFFORTS)}", effort)
    return effort


def transforms_for(c: int, nx: int, shape: tuple[int, int], threads: int, effort: str) -> Transforms:
    """The process's ``Transforms`` of this layout and planner effort, made on first use. Making
    a new one first drops those no operator uses any more (their buffers would otherwise stay
    allocated: a sweep moving from grid to grid holds one grid's buffers, as before sharing)."""
    key = (c, nx, tuple(shape), threads, effort)
    with _LOCK:
        transforms = _TRANSFORMS.get(key)
        if transforms is None:
            _drop_unused_transforms()
            usage = _USAGE.setdefault(key, Usage())
            transforms = _TRANSFORMS[key] = Transforms(c, nx, shape, threads, effort, usage)
        return transforms


def block_table(
    components: str, spectra: Mapping[str, np.ndarray], shape: tuple[int, int]
) -> list[list[np.ndarray | None]]:
    """The blocks of ``spectra`` as a table over ``components``: entry [i][j] the spectrum of block
    (components[i], components[j]) or None where it is absent (zero). A block outside the components
    or a spectrum not of the rfft2 shape of the padded ``shape`` is refused (ValueError)."""
    for block in spectra:
        if block[0] not in components or block[1] not in components:
            raise ValueError(f"block {block!r} does not act within components {components!r}")
    expected = (shape[0], shape[1] // 2 + 1)
    for spectrum in spectra.values():
        if spectrum.shape != expected:
            raise ValueError(f"spectrum of shape {spectrum.shape}; expected {expected} for this grid")
    return [[spectra.get(a + b) for b in components] for a in components]


class ConvolutionOperator:
    """u = K * t for ``components`` (e.g. "z", "xy", "xyz") on an nx × ny grid, non-periodic.

    ``spectra`` maps block names ("xx", "xy", ... displacement component first) to kernel
    spectra on ``padded_shape(nx, ny)``; absent blocks are zero. ``threads`` FFTW threads.
    ``apply`` takes and returns arrays of shape (len(components), nx, ny). The transforms
    (``Transforms``: pruned row passes, full column passes) are shared with the other operators
    of the process on the same layout; the 1/(N1·N2) normalization of the inverse is folded into
    the final crop instead of a separate pass over the padded array.

    ``planner_effort`` is an FFTW planner flag ("FFTW_ESTIMATE", "FFTW_MEASURE", ...) or "auto"
    (default: ``default_planner_effort``, "auto" unless ``PLANNER_ENV`` says otherwise): FFTW_MEASURE plans from wisdom if FFTW has it for these problems, else
    FFTW_ESTIMATE plans, re-planned with FFTW_MEASURE once the layout has been applied long
    enough (``MEASURE_AFTER_SECONDS``). ``plan_effort`` says which plans are in use;
    ``planning_time_s`` is the planning time of its layout so far.
    """

    def __init__(
        self,
        nx: int,
        ny: int,
        components: str,
        spectra: Mapping[str, np.ndarray],
        threads: int = 1,
        planner_effort: str | None = None,
    ) -> None:
        if planner_effort is None:
            planner_effort = default_planner_effort()
        self.nx, self.ny, self.components = nx, ny, components
        self.shape = padded_shape(nx, ny)
        c = len(components)
        self.pairs = block_table(components, spectra, self.shape)  # pairs[i][j]: block (i, j) or None
        n1, n2 = self.shape
        half = n2 // 2 + 1
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
                if np.iscomplexobj(spectrum):
                    factors.append((False, np.asarray(spectrum, dtype=np.complex128)))
                else:
                    key = next(
                        (
                            k
                            for k, (original, _) in doubled.items()
                            if original is spectrum or np.array_equal(original, spectrum)
                        ),
                        id(spectrum),
                    )  # e.g. xy = yx: one copy
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
        self.applications = 0
        self.transforms = transforms_for(c, nx, self.shape, threads, planner_effort)
        self.transforms.users.add(self)

    @property
    def plan_effort(self) -> str:
        """The FFTW planner effort of the plans in use ("FFTW_ESTIMATE", "FFTW_MEASURE", ...)."""
        return self.transforms.effort

    @property
    def planning_time_s(self) -> float:
        """FFTW planning time of this operator's layout so far (seconds)."""
        return self.transforms.planning_time_s

    def _product(self) -> None:
        """spec_out[i] = Σ_j K_ij · spec_in[j] (in place when there is one component)."""
        spec_in, spec_out, scratch = self.transforms.spec_in, self.transforms.spec_out, self._scratch
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
        t0 = time.perf_counter()
        transforms, ny = self.transforms, self.ny
        transforms.real_in[:, :, :ny] = traction
        transforms.forward()
        self._product()
        transforms.inverse()
        u = np.multiply(transforms.real_out[:, :, :ny], self._scale)
        self.applications += 1
        transforms.count(time.perf_counter() - t0)
        return u

    def fft_only(self) -> None:
        """One forward and one inverse transform of all components: the floor of ``apply``."""
        self.transforms.forward()
        self.transforms.inverse()


class ArrayConvolutionOperator:
    """u = K * t as ``ConvolutionOperator``, on the arrays of an array-API namespace ``xp`` (CuPy on
    a GPU: its FFTs are cuFFT's; array-api-strict in the tests), through ``xp.fft`` alone.

    The same non-periodic convolution (zero padding to ``padded_shape``, kernel spectra, crop) with
    full 2-D transforms: no pruned passes, no shared plans (cuFFT caches its own). ``spectra`` are
    host (numpy) spectra as ``kernel_spectrum`` makes them; each is copied to ``xp`` once, here
    (``backend.to_device``). ``apply`` takes and returns arrays of ``xp``, (c, nx, ny), and copies
    nothing to or from the host.
    """

    def __init__(self, nx: int, ny: int, components: str, spectra: Mapping[str, np.ndarray], xp: ModuleType) -> None:
        self.nx, self.ny, self.components, self.xp = nx, ny, components, xp
        self.shape = padded_shape(nx, ny)
        on_device: dict[int, Array] = {}  # one device copy per host spectrum (xy = yx shares)
        for row in block_table(components, spectra, self.shape):
            for spectrum in row:
                if spectrum is not None and id(spectrum) not in on_device:
                    on_device[id(spectrum)] = to_device(spectrum, xp)
        factors = [
            [None if s is None else on_device[id(s)] for s in row]
            for row in block_table(components, spectra, self.shape)
        ]
        self._product = FourierProductStack([factors], (nx, ny), self.shape, xp)  # a stack of one scene
        self.applications = 0

    def apply(self, traction: Array) -> Array:
        """Displacements (c, nx, ny) of tractions (c, nx, ny) on the grid (non-periodic), in ``xp``."""
        self.applications += 1
        return self._product.apply(self.xp.expand_dims(traction, axis=0))[0, ...]


class FourierProductStack:
    """y_k = crop(F⁻¹ Σ_j S_k,ij F pad(t_k,j)) for a stack of B scenes (k) of c components (i, j)
    on one grid (nx, ny): the batched form of a convolution operator (S the kernel spectra, the
    grid zero-padded to ``padded_shape``; docs/design.md §2.2) and of the Fourier preconditioner
    (S its symbol |k| H⁻¹ on its periodic grid). F is ``xp.fft``'s real 2-D transform over the
    last two axes of the whole stack (B, c, N1, N2): one batched transform each way per
    application (cuFFT through CuPy on a GPU).

    ``tables[k][i][j]`` is scene k's block (i, j): an array of ``xp`` of the rfft2 shape of
    ``shape``, or None (zero). A block that is the same array in every scene is kept once and
    broadcast over the stack; else the scenes' blocks are stacked (complex if any is). Units: those
    of S times those of t.
    """

    def __init__(
        self,
        tables: Sequence[Sequence[Sequence[Array | None]]],
        grid_shape: tuple[int, int],
        shape: tuple[int, int],
        xp: ModuleType,
    ) -> None:
        self.xp, self.grid_shape, self.shape = xp, grid_shape, shape
        scenes, c = len(tables), len(tables[0])
        self.blocks: list[list[Array | None]] = []
        for i in range(c):
            row: list[Array | None] = []
            for j in range(c):
                entries = [table[i][j] for table in tables]
                present = [e for e in entries if e is not None]
                if not present:
                    row.append(None)
                elif len(present) == scenes and all(e is present[0] for e in present):
                    row.append(xp.expand_dims(present[0], axis=0))
                else:
                    complex_ = any(xp.isdtype(e.dtype, "complex floating") for e in present)
                    dtype = xp.complex128 if complex_ else xp.float64
                    zero = xp.zeros(present[0].shape, dtype=dtype)
                    row.append(xp.stack([zero if e is None else xp.astype(e, dtype) for e in entries]))
            self.blocks.append(row)
        self._padded = xp.zeros((scenes, c) + shape, dtype=xp.float64)  # zero outside the grid's cells

    def apply(self, stack: Array) -> Array:
        """The products of a stack (B, c, nx, ny) of ``xp``: a stack (B, c, nx, ny)."""
        xp, (nx, ny) = self.xp, self.grid_shape
        self._padded[:, :, :nx, :ny] = stack
        spectra = xp.fft.rfftn(self._padded, axes=(2, 3))
        rows = []
        for row in self.blocks:
            total = None
            for j, block in enumerate(row):
                if block is not None:
                    term = block * spectra[:, j, ...]
                    total = term if total is None else total + term
            rows.append(xp.zeros_like(spectra[:, 0, ...]) if total is None else total)
        return xp.fft.irfftn(xp.stack(rows, axis=1), s=self.shape, axes=(2, 3))[:, :, :nx, :ny]
