"""What the sweep's cost model reads of the engine below it, in one place.

The sweep knows nothing of kernels or discretizations but through this module:

* ``strip_pairs``: the near and far pairs of strip cells
  (``hpcontact.discretizations.strip_cells``), for ``cost.task_cost.strip_units``;
* ``omega_nodes``: the Barnett–Lothe ω nodes of a slip scene's anisotropic bodies
  (``hpcontact.kernels.anisotropic.surface_green_nodes``), a term of a slip task's seconds
  (``cost.rates``);
* ``timed_strips``, ``timed_exact``: CPU seconds of one grid of strip cells
  (``boundary_cells.covered_solve``) and of a crystal exact cell's kernel build
  (``galin_ellipse``), which ``cost.calibration`` turns into ``strip_s`` and ``exact_s``;
* ``clear_kernel_caches``: the kernel caches emptied, for the accuracy-versus-cost study's cold
  solves (``hpcontact.sweep.accuracy_study``).
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from hpcontact.discretizations import galin_ellipse, strip_cells
from hpcontact.discretizations.boundary_cells import covered_solve
from hpcontact.kernels import isotropic
from hpcontact.kernels.anisotropic import as_voigt, surface_green_nodes
from hpcontact.kernels.anisotropic import clear_cache as clear_kernels  # convolution has a clear_cache too
from hpcontact.materials.elastic_constants import anisotropic_material
from hpcontact.numerics.blas import limited_blas
from hpcontact.numerics.convolution import clear_cache
from hpcontact.problems.slip.crystal_pair import GPA, pair_from_params
from hpcontact.scene import Scene


def omega_nodes(params: Mapping[str, Any]) -> int:
    """Barnett–Lothe ω nodes of the anisotropic bodies of the slip scene ``params`` (0 for
    isotropic bodies): the nodes the adaptive trapezoidal rule of
    ``kernels.anisotropic.surface_green_nodes`` counts on 32 in-plane directions, summed over the
    bodies, times the load paths solved (2 for a dissimilar pair under coupling auto or both:
    each path builds its preconditioner from the pair's Green's function, which is most of the
    Barnett–Lothe time: docs/performance.md §"Barnett–Lothe share of an anisotropic slip task")."""
    nodes = 0
    for suffix in ("", "2"):
        crystal = anisotropic_material(params, suffix, GPA, library=False)
        if crystal is not None:
            nodes += _omega_nodes(as_voigt(crystal).tobytes())
    if nodes and params.get("coupling", "auto") in ("auto", "both") and not pair_from_params(params).similar:
        nodes *= 2
    return nodes


@functools.lru_cache(maxsize=1024)
def _omega_nodes(voigt: bytes) -> int:
    """ω nodes for the 6 × 6 stiffness ``voigt`` (its bytes: a cache key), 32 directions."""
    stiffness = np.frombuffer(voigt, dtype=np.float64).reshape(6, 6)
    return surface_green_nodes(stiffness, np.linspace(0.0, 2.0 * math.pi, 32, endpoint=False))


def timed_strips(params: Mapping[str, Any], repeats: int = 2, clock: Callable[[], float] = time.process_time) -> float:
    """Seconds on ``clock`` (CPU seconds by default) of one grid of strip cells of ``params``
    (``boundary_cells.covered_solve``, strategy strip), as ``cost.calibration`` times a task: an
    untimed solve first, the least of ``repeats`` timings; BLAS limited as in a sweep's tasks."""
    scene = Scene.from_params(dict(params))
    best = math.inf
    with limited_blas():  # as a sweep's tasks run: threaded BLAS made these Cholesky factors 3x slower
        covered_solve(scene, "strip")
        for _ in range(repeats):
            started = clock()
            covered_solve(scene, "strip")
            best = min(best, clock() - started)
    return best


def timed_exact(params: Mapping[str, Any], repeats: int = 2, clock: Callable[[], float] = time.process_time) -> float:
    """Seconds on ``clock`` (CPU seconds by default) that the crystal ellipse ``params`` takes on its
    exact cell beyond its warm solve: the build of its kernel's Fourier series, the kernel cache emptied before each of
    ``repeats`` timings (the least counts)."""
    scene = Scene.from_params(dict(params))
    best = math.inf
    for _ in range(repeats):
        clear_kernels()
        started = clock()
        galin_ellipse.solve(scene)
        cold = clock() - started
        started = clock()
        galin_ellipse.solve(scene)
        best = min(best, cold - (clock() - started))
    return max(0.0, best)


def strip_pairs(shape: str, aspect: float, n: int) -> tuple[int, int]:
    """(near, far) pairs i ≤ j of n strips of an unturned ``shape`` (rectangle, ellipse) of
    ``aspect``: the split of ``strip_cells.galerkin_integrals`` (near: closer than
    ``NEAR_GAP`` strip lengths or ``SERIES_REACH`` half-widths). Cached."""
    return _strip_pairs(str(shape), float(aspect), int(n))


@functools.lru_cache(maxsize=1024)
def _strip_pairs(shape: str, aspect: float, n: int) -> tuple[int, int]:
    outline = strip_cells.Outline(shape, aspect)
    edges = strip_cells.graded_edges(n)
    lo, hi = edges[:-1], edges[1:]
    size = hi - lo
    i, j = np.triu_indices(n)
    gap = np.maximum(np.maximum(lo[j] - hi[i], lo[i] - hi[j]), 0.0)
    widest = np.maximum(outline.widest(lo[i], hi[i]), outline.widest(lo[j], hi[j]))
    near = int(
        np.count_nonzero(
            (gap < strip_cells.NEAR_GAP * np.maximum(size[i], size[j])) | (gap < strip_cells.SERIES_REACH * widest)
        )
    )
    return near, int(i.size) - near


def clear_kernel_caches() -> None:
    """Empty the kernel caches a process keeps (spectra per material and grid, the isotropic
    cell integrals), so that the next solve builds its kernels cold. FFTW wisdom stays warm."""
    clear_cache()
    isotropic._centred_integral.cache_clear()
