"""Cost model of a sweep: core-seconds, peak memory and wall time before it runs (``--dry-run``).

**Seconds.** A task of kind k (``task_kind``: ``contact``, ``crystal``, ``crystal_indentation``
or ``slip``) takes, on one core of the calibrated host,

    seconds = rate_k × cost + solve_k × cost / (S log2 S) + cell_k × S + task_k [+ node_s × ω nodes, slip]

with ``cost = hpcontact.sweep.tasks.estimated_cost(params)`` as the cost units (padded FFT cells
S · log2 S × solves × CG iterations, the iterations as digits of tolerance × the grid's
iteration factor (1 + 0.3 log2 ρ) log2 S / 18, ρ the contact grid's aspect in cells: ``footprint``; a slip
scene's solves follow its load path, ``tasks.slip_cost``) and S = ``tasks.padded_cells(params)``
(the grid of the turned shape's bounding box, ``footprint.contact_grid``): the first term is the
FFT work, the second the work per solve-iteration that does not grow with the grid (Python, CG
bookkeeping, set-up: cost / (S log2 S)). A slip scene with anisotropic bodies (a crystal, an
orthotropic body) evaluates their surface Green's functions by the Barnett–Lothe integrals
several times per task (the grid's kernels, the preconditioner, the coupling size, the Hertz
estimate), at a cost proportional to the ω nodes the adaptive rule needs for that body
(``omega_nodes``: 64 for Cu, Ni, Si crystals; 256-1024 for the orthotropic bodies of
Rodríguez-Tembleque et al. 2011, E1/E2 = 25-800), twice when both the coupled and the
decoupled path are solved (each builds its preconditioner from them), and independent of the
grid and the load steps: the third term.

``calibrate`` fits the coefficients. ``rate_k`` (seconds per cost unit) and ``solve_k``: two
real solves per kind on a small and a larger grid (each run once untimed first, so that FFT
plans are warm as in a sweep, then timed twice with the kernel cache cleared, as a sweep's
first task of a kernel group runs; the lesser time counts) give the two coefficients.
``cell_k`` is the task's kernel set (influence coefficients on the padded grid and their
spectra, built once per task whatever its tolerance), calibrated for the isotropic contact kind
(0 for the others, whose kernel work the two coefficients absorb): the larger contact scene is
timed again at tol = 1e-2, and that loose solve less its CG iterations at the time per
iteration of the two solves (their difference over the difference of their iterations),
divided by its S, is cell_k (iterations, not digits of tolerance: the two are not
proportional). ``task_k`` is what any task takes whatever its grid (scene, plan, kernels'
set-up, record): the time of a 16 × 16 circle at tol 1e-2 (``TINY_CONTACT_SCENE``), subtracted
from the other timings before they are fitted; contact kind only. ``node_s`` is what a small
slip scene of two orthotropic bodies (``ANISOTROPIC_SLIP_SCENE``) takes beyond the slip kind's
two terms, per ω node. The crystal indentation kind is calibrated on n = 128 and 256, the grids
of its shipped job (``tembleque2011_sphere``, n = 256), because its time per cost unit rises
once the arrays leave the L3 cache. Each term is there because the model without it missed
measured task times by 1.6-4x (docs/performance.md §"Sweep cost model": the fits, the models
rejected, and the estimates against measurement, ``benchmarks/cost_estimates.py``). Times are
CPU seconds of the process (``time.process_time``; the solvers run one thread unless a scene
asks for more, and the whole calibration runs under the BLAS limit of a sweep's tasks,
``numerics.blas.limited_blas``: OpenBLAS's own threads had made its CPU seconds 2-3x a task's):
the time on a core of its own, as a batch system gives one per rank, and unlike wall time not
inflated by whatever else shares the machine while it calibrates (but slowed where that shares
the core: ``Calibration.contended``). ``strip_s``
(contact kind only): one grid of strip cells (``STRIP_CALIBRATION_SCENE``, timed as the others
but under the sweep's BLAS limit, ``numerics.blas.limited_blas``: its Cholesky factors are the
only BLAS calls that a thread pool slows) less ``task_s``, over its ``tasks.strip_units``. The
calibration takes tens of seconds and is cached like FFTW wisdom, in ``costmodel-HOST.json`` beside the wisdom file
($HPCONTACT_COSTMODEL overrides), keyed by host and package version: a file of another host or
version, or one that cannot be read as a calibration, is ignored with a warning and replaced.
``hpcontact run`` prints the estimate of the tasks it will compute before it starts
(``start_estimate``), from the cached calibration only: without one it says so rather than make
every rank wait for a calibration.

**Accuracy tasks.** A task that asks for an accuracy (``[numerics] accuracy``, ``hpcontact run
--accuracy``) solves a sequence of grids (``accuracy.solve_to_accuracy``, strategy auto): it is
costed over the grids it is predicted to solve (``tasks.accuracy_plan``: ``accuracy.first_grid``'s
boundary cells, ``accuracy.plan_grids``' grids, four at 1e-3 for coverage-weighted cells and one
more per decade below, ``tasks.predicted_grid_count``), each grid's work summed into a
``tasks.Work`` whose terms take the contact kind's coefficients:

    seconds = rate_s × fft + solve_s × solves + cell_s × cells + task_s × grids + strip_s × strips
              + exact_s × exact

(``work_seconds``): an ellipse's or circle's one exact cell (galin: no grid) one task term, and
a crystal's also ``exact_s``, the build of its kernel's Fourier series (``EXACT_CALIBRATION_SCENE``
timed cold less warm: every crystal exact cell is costed cold, although a rank's kernel cache
keeps the last 8 materials, so sweeps that repeat a material over consecutive tasks run below
the estimate); a
grid of coverage-weighted cells its one-grid FFT model
(cost, cost / (S log2 S), S and one task term) times its cells' measured factor, a crystal's
included (the crystal kind's own fit, on n = 32 and 64, has no FFT term to carry to n = 1024);
a slender rectangle's strip cells (dense Galerkin integrals, ``hpcontact.discretizations.strip_cells``) their
``tasks.strip_units`` at ``strip_s``, the seconds of a strip unit on this host; below 1e-3 a
coverage-weighted task also counts a share of the grid after its last and less a share of its
last (``tasks.accuracy_work``: the count varies by one about the predicted one). Their memory
is ``accuracy.grid_bytes`` of the finest predicted grid with its boundary cells (the arrays that
``accuracy.plan_grids`` budgets; an exact cell: its kind's fixed bytes,
``footprint.MEMORY_MODEL``). The measurements: docs/performance.md §"Accuracy tasks".

**Memory.** The peak resident memory of a rank running a task is

    bytes = base + fixed_k + per_cell_k × padded_cells(params)

``base`` is this process's peak resident set (``resource.getrusage``) after importing what a
run imports (the solvers, MPI, xarray); ``padded_cells`` is the padded FFT grid
(``tasks.padded_cells``). ``fixed_k`` and ``per_cell_k`` are float64 array sizes (no machine
dependence), fitted to ``tracemalloc`` peaks of single solves with cold kernel caches
(``footprint.MEMORY_MODEL``; the fits: docs/performance.md §"Memory per task"):

* contact: 182 B/cell (kernels xx, xy, yy, zz spectra, traction and CG vectors for 2
  components, FFT buffers) + 1 MiB;
* crystal: 300 B/cell (nine kernel blocks and their spectra, 3 components) + 12 MiB, and at
  least the kernels' build, 55 MiB (``footprint.KERNEL_BUILD_BYTES``: the quadrature tables'
  construction, one 32 MiB quadrature chunk per thread); indentation alone 60 B/cell + 45 MiB;
* slip: 530 B/cell + 2 MiB; with a crystal body, the crystal's 45 MiB tables instead of 2.

The kernel-spectrum cache (``HPCONTACT_KERNEL_CACHE_MB``, default 1 GiB) can hold more than one
task's kernels on a rank; the model counts one task's, as the refusal must (a task that does not
fit alone cannot run; the cache evicts before it).

**Wall time on R ranks** (``replay``): a discrete-event model of the scheduler
(``hpcontact.sweep.schedule``): the tasks are chunked and ordered by the real ``make_chunks`` for R
ranks; every rank computes; a worker's claim of the next chunk waits for the server (FIFO,
``Overheads.service_s`` per message) plus the wake-up latency ``wake_s``; rank 0 claims without
messages; every task pays ``driver_s`` (journal, progress, scheduling) and ``spread_gather_s``
(its outcome turned into columns by the rank that ran it); before any rank computes, every rank
enumerates and validates 1/R of the parameter space (``spread_setup_s`` per task, divided by R)
and rank 0 alone joins the shares, decides what to run and broadcasts the plan (``setup_s`` per
task); at the end rank 0 alone joins the ranks' columns and writes the data set (``gather_s``
per task) while the others wait. Wall time = makespan; efficiency = Σ task seconds / (R ×
makespan).
``benchmarks/sweep_scale.py`` measures the overheads and replays real task costs with this model.

**At scale.** ``estimate`` reads each task's cost and ``tasks.Sizing`` (kind, padded cells, array
bytes: made once per distinct value while the tasks are enumerated) and computes seconds and
bytes for all tasks at once (numpy, the same operations in the same order as ``task_seconds``,
so the same numbers); the tasks are put in chunk order once (``tasks.chunk_order``) and cut for
each number of ranks replayed (``tasks.chunk_bounds``): a dry run of 10^6 tasks estimates in
seconds (``benchmarks/dry_run_points.py``).
"""

from __future__ import annotations

import functools
import heapq
import json
import math
import os
import re
import socket
import stat
import statistics
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from hpcontact import __version__
from hpcontact.accuracy import task_function
from hpcontact.discretizations import galin_ellipse
from hpcontact.discretizations.boundary_cells import covered_solve
from hpcontact.errors import InputError
from hpcontact.kernels.anisotropic import as_voigt, surface_green_nodes
from hpcontact.kernels.anisotropic import clear_cache as clear_kernels  # convolution has a clear_cache too
from hpcontact.materials.elastic_constants import anisotropic_material
from hpcontact.numerics.blas import limited_blas
from hpcontact.numerics.convolution import clear_cache, wisdom_path
from hpcontact.numerics.memory import MIB, resident_bytes
from hpcontact.problems import footprint
from hpcontact.problems.footprint import task_kind
from hpcontact.problems.kinds import scene_kind
from hpcontact.problems.slip.crystal_pair import GPA, pair_from_params
from hpcontact.scene import Scene
from hpcontact.sweep.tasks import (
    ChunkOrder,
    Sizing,
    Task,
    Work,
    asks_accuracy,
    chunk_bounds,
    chunk_order,
    estimated_cost,
    padded_cells,
    paused_gc,
    sizing,
    solved_grids,
    strip_units,
)

KINDS = ("contact", "crystal", "crystal_indentation", "slip")
# version of the calibration file's layout (2: node_s, Barnett–Lothe; 3: cell_s, kernels; 4: task_s; 5: strip_s;
# 6: exact_s; 7: every solve under the sweep's BLAS limit, older files' rates 2-3x high)
FORMAT = 7
_TANGENTIAL_NORMAL = ["tangential", "normal"]
# Calibration scenes: (small, larger) per kind, with the fields a sweep of that kind sets.
CALIBRATION_SCENES: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {
    "contact": (
        {"shape": "ellipse", "aspect": 0.5, "nu": 0.3, "n": 64, "quantities": _TANGENTIAL_NORMAL, "tol": 1e-10},
        {"shape": "ellipse", "aspect": 0.5, "nu": 0.3, "n": 256, "quantities": _TANGENTIAL_NORMAL, "tol": 1e-10},
    ),
    "crystal": (
        {
            "shape": "circle",
            "nu": 0.3,
            "anisotropy": 2.0,
            "orientation": 30.0,
            "n": 32,
            "quantities": ["tangential"],
            "tol": 1e-10,
        },
        {
            "shape": "circle",
            "nu": 0.3,
            "anisotropy": 2.0,
            "orientation": 30.0,
            "n": 64,
            "quantities": ["tangential"],
            "tol": 1e-10,
        },
    ),
    "crystal_indentation": tuple(
        {
            "shape": "circle",
            "nu": 0.3,
            "anisotropy": 2.0,
            "orientation": 30.0,
            "n": n,
            "quantities": ["indentation"],
            "radius": 1.0,
            "depth": 1e-4,
            "tol": 1e-10,
        }
        for n in (128, 256)
    ),
    "slip": tuple(
        {
            "quantities": "slip",
            "material": "Cu",
            "material2": "Cu",
            "radius": 8e-3,
            "radius2": 9e-3,
            "load": 10.0,
            "mu": 0.3,
            "q_ratio": 0.6,
            "steps": 3,
            "n": n,
            "tol": 1e-8,
        }
        for n in (32, 64)
    ),
}


# The smallest contact task (16 × 16 cells, tol 1e-2): what any contact task takes beyond its
# grid's work (scene, plan, kernels' set-up, record; a few ms: docs/performance.md §"Task term").
TINY_CONTACT_SCENE: dict[str, Any] = {
    "shape": "circle",
    "nu": 0.3,
    "n": 16,
    "quantities": _TANGENTIAL_NORMAL,
    "tol": 1e-2,
}


# A slip scene with two anisotropic bodies (the orthotropic pair of Rodríguez-Tembleque et al.
# 2011, §6.2; 256 ω nodes each), small: what it takes beyond the isotropic slip rates is the
# Barnett–Lothe cost, per ω node.
_ORTHOTROPIC = "E1=25 E2=1 E3=1 G12=0.5 G13=0.5 G23=0.2 nu12=0.25 nu13=0.25 nu23=0.25"
ANISOTROPIC_SLIP_SCENE: dict[str, Any] = {
    "quantities": "slip",
    "orthotropic": _ORTHOTROPIC,
    "orthotropic2": _ORTHOTROPIC,
    "radius": 0.5,
    "radius_b": 2.0,
    "load": 1.0e6,
    "mu": 0.1,
    "q_ratio": 0.5,
    "steps": 1,
    "n": 16,
    "tol": 1e-8,
}


# One grid of strip cells (``hpcontact.discretizations.strip_cells``, a rectangle b/a = 1e-8 on
# 512 strips, tangential and normal: ~0.35 s, its far pairs and strips in it; strips serve only
# slender rectangles): its seconds over its ``tasks.strip_units`` are the contact kind's
# ``strip_s`` (the dense integrals of an accuracy task's strips: docs/performance.md §"Accuracy
# tasks"; on the development machine the same ``strip_s`` as the ellipse b/a = 1e-3 on 64 strips
# it replaced, which ``auto`` no longer gives strips).
STRIP_CALIBRATION_SCENE: dict[str, Any] = {
    "shape": "rectangle",
    "aspect": 1e-8,
    "nu": 0.3,
    "n": 512,
    "n_across": 1,
    "quantities": _TANGENTIAL_NORMAL,
    "tol": 1e-10,
}


# A crystal ellipse on its one exact cell (``hpcontact.discretizations.galin_ellipse``): the
# seconds its kernel's Fourier series takes to build (cold cache) are the contact kind's
# ``exact_s``, what a crystal exact cell costs beyond the task term (0.05–0.12 s on the
# development machine over A 0.5–3, ψ 0–55°, nu 0.05–0.45; its warm solve ~1 ms).
EXACT_CALIBRATION_SCENE: dict[str, Any] = {
    "shape": "ellipse",
    "aspect": 0.5,
    "nu": 0.3,
    "anisotropy": 2.0,
    "orientation": 30.0,
    "quantities": _TANGENTIAL_NORMAL,
}


@dataclass(frozen=True)
class Rate:
    """Seconds of a task of one kind: ``rate_s × cost + solve_s × solve_units + cell_s ×
    padded cells + node_s × omega_nodes + task_s`` (module docstring; ``cell_s``,
    ``task_s``, ``strip_s``, seconds per strip unit of an accuracy task's strip cells, and
    ``exact_s``, seconds of a crystal exact cell's kernel build, are measured for the isotropic
    contact kind, ``node_s`` for slip scenes)."""

    rate_s: float
    solve_s: float
    node_s: float = 0.0
    cell_s: float = 0.0
    task_s: float = 0.0
    strip_s: float = 0.0
    exact_s: float = 0.0


def work_seconds(rate: Rate, work: Work) -> float:
    """Seconds of an accuracy task's ``tasks.Work`` at the contact kind's ``rate`` (module
    docstring, "Accuracy tasks")."""
    return (
        rate.rate_s * work.fft
        + rate.solve_s * work.solves
        + rate.cell_s * work.cells
        + rate.task_s * work.grids
        + rate.strip_s * work.strips
        + rate.exact_s * work.exact
    )


def solve_units(params: Mapping[str, Any], cost: float) -> float:
    """Solves × digits of the scene ``params`` of estimated ``cost``: cost / (S log2 S)."""
    cells = padded_cells(params)
    return cost / (cells * math.log2(cells))


@dataclass(frozen=True)
class Calibration:
    """This machine's seconds per kind and the base memory of a run, with where they were
    measured (``host``, package ``version``) and how long the calibration took."""

    host: str
    version: str
    rates: dict[str, Rate]
    base_bytes: float
    seconds: float = 0.0
    others: float | None = None  # other processes running beside it (``other_running``; None: unknown)

    def contended(self) -> str:
        """ "" when the calibration ran alone, else what a reader of an estimate must know: other
        processes ran beside it (``CONTENDED_FROM``), so its seconds, and every estimate, are
        likely high."""
        if self.others is None or self.others < CONTENDED_FROM:
            return ""
        return (
            f"calibrated while ~{self.others:.1f} other process(es) ran: estimates may be 2-4x high where cores "
            f"are shared or hyper-threaded; remove {calibration_path()} and rerun on an idle machine"
        )

    def task_seconds(self, params: Mapping[str, Any], cost: float | None = None) -> float:
        """Estimated seconds of the scene ``params`` on one core (a scene that asks for an
        accuracy: its ``tasks.Work`` at the contact kind's rates, whatever ``cost``)."""
        if asks_accuracy(params):
            return work_seconds(self.rates["contact"], sizing(params).work)
        kind = task_kind(params)
        rate = self.rates[kind]
        cost = estimated_cost(params) if cost is None else cost
        nodes = omega_nodes(params) if kind == "slip" else 0
        return (
            rate.rate_s * cost
            + rate.solve_s * solve_units(params, cost)
            + rate.cell_s * padded_cells(params)
            + rate.node_s * nodes
            + rate.task_s
        )

    def task_bytes(self, params: Mapping[str, Any]) -> float:
        """Estimated peak resident bytes of a rank running the scene ``params``."""
        return self.base_bytes + task_array_bytes(params)


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


# What importing a run's modules (hpcontact.solve, xarray, the slip solver, mpi4py.MPI) can add
# to a process that has not yet: 3x the 80 MiB they added (docs/performance.md §"Base memory of a rank").
IMPORTS_BYTES = 3 * 80 * MIB


def task_array_bytes(params: Mapping[str, Any]) -> float:
    """The arrays of one task of ``params`` (``footprint.array_bytes`` of the finest grid it
    solves, ``tasks.solved_grids``; a task that asks for an accuracy: ``accuracy.grid_bytes`` of
    its finest predicted grid with its boundary cells, ``tasks.sizing``)."""
    if asks_accuracy(params):
        return sizing(params).array_bytes
    return footprint.array_bytes(solved_grids(params)[-1])


def base_memory_bytes() -> float:
    """Peak resident bytes of this process after importing what a run imports (module
    docstring)."""
    import mpi4py.MPI  # noqa: F401 - imported for its resident size, as a run does
    import xarray  # noqa: F401

    return resident_bytes()


def _timed(params: Mapping[str, Any], repeats: int = 2) -> float:
    """CPU seconds of a solve of ``params`` (``_timed_solve``)."""
    return _timed_solve(params, repeats)[0]


def _timed_solve(params: Mapping[str, Any], repeats: int = 2) -> tuple[float, int]:
    """CPU seconds of a solve of ``params`` with warm FFT plans (an untimed solve first) and a
    cold kernel cache: the time on a core of its own, whatever else shares the machine; the
    least of ``repeats`` timings (the others carry interference); and its CG iterations."""

    function = task_function(scene_kind(params))
    record = function(dict(params))
    best = math.inf
    for _ in range(repeats):
        clear_cache()
        started = time.process_time()
        function(dict(params))
        best = min(best, time.process_time() - started)
    return best, int(record.get("iterations", 0))


def fit_rate(scenes: Sequence[Mapping[str, Any]], seconds: Sequence[float]) -> Rate:
    """The ``Rate`` through two timed scenes (a 2 × 2 solve); a negative coefficient is set to
    zero and the other fitted to both points by least squares."""
    (c1, c2) = (estimated_cost(p) for p in scenes)
    (u1, u2) = (solve_units(p, c) for p, c in zip(scenes, (c1, c2)))
    (t1, t2) = seconds
    det = c1 * u2 - c2 * u1
    if det != 0.0:
        rate, solve = (t1 * u2 - t2 * u1) / det, (c1 * t2 - c2 * t1) / det
        if rate >= 0.0 and solve >= 0.0:
            return Rate(rate, solve)
    by_cost = (c1 * t1 + c2 * t2) / (c1 * c1 + c2 * c2)
    by_units = (u1 * t1 + u2 * t2) / (u1 * u1 + u2 * u2)
    miss_cost = (t1 - by_cost * c1) ** 2 + (t2 - by_cost * c2) ** 2
    miss_units = (t1 - by_units * u1) ** 2 + (t2 - by_units * u2) ** 2
    return Rate(by_cost, 0.0) if miss_cost <= miss_units else Rate(0.0, by_units)


def _fit_with_kernels(pair: Sequence[Mapping[str, Any]]) -> Rate:
    """``Rate`` with ``cell_s`` and ``task_s`` for the contact kind: ``TINY_CONTACT_SCENE`` gives
    the time of a task whatever its grid (``task_s``); the larger scene timed at its tolerance
    and at 1e-2 gives the time per CG iteration (the difference of the two over the difference
    of their iterations) and so the kernels' time (the loose solve less its iterations); the
    rest is fitted as usual, all of them less ``task_s``."""
    small, large = pair
    loose = {**large, "tol": 1e-2}
    task_s = _timed(TINY_CONTACT_SCENE)
    t_small = max(0.0, _timed(small) - task_s)
    (t_large, it_large), (t_loose, it_loose) = (_timed_solve(p) for p in (large, loose))
    t_large, t_loose = max(0.0, t_large - task_s), max(0.0, t_loose - task_s)
    per_iteration = (t_large - t_loose) / max(1, it_large - it_loose)
    cell_s = max(0.0, t_loose - per_iteration * it_loose) / padded_cells(large)
    fitted = fit_rate(pair, [t - cell_s * padded_cells(p) for t, p in ((t_small, small), (t_large, large))])
    return Rate(fitted.rate_s, fitted.solve_s, 0.0, cell_s, task_s)


def _timed_strips(params: Mapping[str, Any], repeats: int = 2) -> float:
    """CPU seconds of one grid of strip cells of ``params`` (``boundary_cells.covered_solve``,
    strategy strip), as ``_timed_solve`` times a task: an untimed solve first, the least of
    ``repeats`` timings; BLAS limited as in a sweep's tasks."""
    scene = Scene.from_params(dict(params))
    best = math.inf
    with limited_blas():  # as a sweep's tasks run: threaded BLAS made these Cholesky factors 3x slower
        covered_solve(scene, "strip")
        for _ in range(repeats):
            started = time.process_time()
            covered_solve(scene, "strip")
            best = min(best, time.process_time() - started)
    return best


def _timed_exact(params: Mapping[str, Any], repeats: int = 2) -> float:
    """CPU seconds that the crystal ellipse ``params`` takes on its exact cell beyond its warm
    solve: the build of its kernel's Fourier series, the kernel cache emptied before each of
    ``repeats`` timings (the least counts)."""
    scene = Scene.from_params(dict(params))
    best = math.inf
    for _ in range(repeats):
        clear_kernels()
        started = time.process_time()
        galin_ellipse.solve(scene)
        cold = time.process_time() - started
        started = time.process_time()
        galin_ellipse.solve(scene)
        best = min(best, cold - (time.process_time() - started))
    return max(0.0, best)


#: A calibration that ran beside this many other running processes (mean of its samples) is
#: flagged (``Calibration.contended``). On the 2-vCPU development machine, whose two vCPUs share
#: a core, one other busy process during the ~20 s calibration made the main job's dry run
#: 226.5 core-seconds against 68.9 calibrated alone (2026-11-26 13:32, its task time 58.6 s).
CONTENDED_FROM = 0.5


def other_running() -> float | None:
    """Processes running or runnable on this machine besides this one, now (the fourth field
    of /proc/loadavg less this process); None where there is no /proc/loadavg."""
    try:
        running = int(Path("/proc/loadavg").read_text().split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return None
    return max(0.0, running - 1.0)


def calibrate(scenes: Mapping[str, Sequence[Mapping[str, Any]]] = CALIBRATION_SCENES) -> Calibration:
    """Measure ``Rate`` per kind on this machine (module docstring) and the base memory, every
    solve under the BLAS limit a sweep's tasks run under (``numerics.blas.limited_blas``:
    without it OpenBLAS's threads made the calibration's CPU seconds 2-3x those of the same
    solves in a task, and every estimate as high; docs/performance.md §"Sweep cost model")."""

    started = time.perf_counter()
    others = [other_running()]
    base = base_memory_bytes()
    with limited_blas():
        rates = {kind: fit_rate(pair, [_timed(p) for p in pair]) for kind, pair in scenes.items() if kind != "contact"}
        others.append(other_running())
        contact = _fit_with_kernels(scenes["contact"])
        others.append(other_running())
        strips = max(0.0, _timed_strips(STRIP_CALIBRATION_SCENE) - contact.task_s)
        exact = _timed_exact(EXACT_CALIBRATION_SCENE)
        rates["contact"] = replace(contact, strip_s=strips / strip_units(STRIP_CALIBRATION_SCENE), exact_s=exact)
        slip, scene = rates["slip"], ANISOTROPIC_SLIP_SCENE
        cost = estimated_cost(scene)
        rest = _timed(scene) - slip.rate_s * cost - slip.solve_s * solve_units(scene, cost)
        rates["slip"] = Rate(slip.rate_s, slip.solve_s, max(0.0, rest) / omega_nodes(scene))
    others.append(other_running())
    known = [n for n in others if n is not None]
    return Calibration(
        socket.gethostname(),
        __version__,
        rates,
        base,
        time.perf_counter() - started,
        statistics.fmean(known) if known else None,
    )


def calibration_path() -> Path:
    """$HPCONTACT_COSTMODEL, else ``costmodel-HOST.json`` beside the FFTW wisdom file."""

    env = os.environ.get("HPCONTACT_COSTMODEL")
    return Path(env) if env else wisdom_path().with_name(f"costmodel-{socket.gethostname()}.json")


def save_calibration(calibration: Calibration, path: Path | None = None) -> Path:
    """Write ``calibration`` as JSON, atomically (temporary file, then rename)."""
    path = calibration_path() if path is None else Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {"format": FORMAT, **asdict(calibration)}
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(record, indent=1, sort_keys=True))
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


CALIBRATION_BYTES = 2**20  # a calibration file is ~2 kB: one larger than 1 MiB is not one (nor read further)
CALIBRATION_DEPTH = 8  # a calibration nests 3 deep ({"rates": {kind: {...}}}): deeper JSON is not one
_JSON_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"')
_NOT_BRACKETS = bytes(sorted(set(range(256)) - set(b"[]{}")))


def _calibration_bytes(path: Path) -> bytes:
    """The bytes of the calibration file ``path``, at most ``CALIBRATION_BYTES``: ``ValueError``
    for a larger file or one that is not a regular file (a symlink to /dev/zero, a FIFO: never
    read to the end, never waited on)."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError("not a regular file")
        data = b""
        while len(data) <= CALIBRATION_BYTES:
            chunk = os.read(fd, CALIBRATION_BYTES + 1 - len(data))
            if not chunk:
                break
            data += chunk
    finally:
        os.close(fd)
    if len(data) > CALIBRATION_BYTES:
        raise ValueError(f"larger than {CALIBRATION_BYTES} bytes")
    return data


def _json_depth(data: bytes) -> int:
    """How deep the arrays and objects of the JSON text ``data`` nest (brackets outside strings)."""
    depth = deepest = 0
    for bracket in _JSON_STRING.sub(b"", data).translate(None, _NOT_BRACKETS):
        depth += 1 if bracket in b"[{" else -1
        deepest = max(deepest, depth)
    return deepest


def _number(record: Mapping[str, Any], name: str, where: str = "") -> float:
    value = record.get(name)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{where}{name} must be a number")
    return float(value)


def read_calibration(path: Path) -> Calibration:
    """The calibration in ``path``; ``ValueError`` if it is not one (not a regular file, larger
    than ``CALIBRATION_BYTES``, JSON nested deeper than ``CALIBRATION_DEPTH``, wrong format,
    missing, non-numeric or non-finite numbers, a negative rate)."""
    data = _calibration_bytes(Path(path))
    if _json_depth(data) > CALIBRATION_DEPTH:
        raise ValueError(f"JSON nested deeper than {CALIBRATION_DEPTH}")
    record = json.loads(data.decode("utf-8"))
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        raise ValueError("not a calibration file of this format")
    if not isinstance(record.get("rates"), dict) or not all(
        isinstance(record.get(k), str) for k in ("host", "version")
    ):
        raise ValueError("rates, host and version missing")
    rates = {}
    for kind in KINDS:
        entry = record["rates"].get(kind)
        if not isinstance(entry, dict):
            raise ValueError(f"rates.{kind} missing")
        rates[kind] = Rate(
            *(
                _number(entry, name, f"rates.{kind}.")
                for name in ("rate_s", "solve_s", "node_s", "cell_s", "task_s", "strip_s", "exact_s")
            )
        )
        if not all(math.isfinite(v) and v >= 0.0 for v in asdict(rates[kind]).values()):
            raise ValueError(f"{kind}: rates must be finite and >= 0")
        if rates[kind].rate_s + rates[kind].solve_s <= 0.0:
            raise ValueError(f"{kind}: a task must take time")
    base = _number(record, "base_bytes")
    if not (math.isfinite(base) and base >= 0.0):
        raise ValueError("base_bytes must be finite and >= 0")
    seconds = _number(record, "seconds") if "seconds" in record else 0.0
    others = _number(record, "others") if record.get("others") is not None else None
    return Calibration(record["host"], record["version"], rates, base, seconds, others)


def cached_calibration(path: Path | None = None) -> tuple[Calibration | None, str]:
    """The cached calibration when it was measured on this host by this package version, else
    None and why not (no file, a corrupt one, another host or version)."""

    path = calibration_path() if path is None else Path(path)
    host = socket.gethostname()
    if not path.exists():
        return None, f"no calibration cached in {path}"
    try:
        cached = read_calibration(path)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"cost calibration {path} ignored: {exc}"
    if cached.host != host or cached.version != __version__:
        return None, (
            f"cost calibration {path} ignored: measured on {cached.host} by hpcontact {cached.version}, "
            f"not {host} / {__version__}"
        )
    return cached, ""


def load_calibration(path: Path | None = None, stream: Any = None) -> Calibration:
    """This machine's calibration: the cached one when it was measured here by this version,
    else a new one (saved for next time; ``stream`` is told). A corrupt or foreign file is
    ignored with a ``RuntimeWarning`` and replaced."""
    path = calibration_path() if path is None else Path(path)
    cached, why = cached_calibration(path)
    if cached is not None:
        return cached
    if path.exists():
        warnings.warn(why, RuntimeWarning, stacklevel=2)
    if stream is not None:
        print(
            f"hpcontact: calibrating the cost model on {socket.gethostname()} (once per host and version; cached in "
            f"{path})",
            file=stream,
            flush=True,
        )
    calibration = calibrate()
    try:
        save_calibration(calibration, path)
    except OSError as exc:
        warnings.warn(f"cost calibration not saved to {path}: {exc}", RuntimeWarning, stacklevel=2)
    return calibration


def start_estimate(tasks: Sequence[Task], ranks: int) -> tuple[str, np.ndarray | None]:
    """The line ``hpcontact run`` prints on rank 0 before work starts — the estimated core-seconds
    of ``tasks`` (those this run computes) and the replayed wall time on ``ranks`` ranks — and
    each task's estimated seconds (for the progress lines' ETA), from the cached calibration. It
    never calibrates (that takes ~30 s, which a run must not wait for): without a usable cache
    the line says so and how to get one, and the seconds are None."""
    calibration, why = cached_calibration()
    if calibration is None:
        return f"hpcontact: no cost estimate ({why}; hpcontact run SPEC --dry-run calibrates once, ~30 s)", None
    tasks = list(tasks)
    seconds = task_arrays(tasks, calibration)[0]
    wall = _replay(chunk_order(tasks), seconds, ranks, Overheads())["makespan_s"] if tasks else 0.0
    warning = f"; {calibration.contended()}" if calibration.contended() else ""
    line = (
        f"hpcontact: estimated {sum(seconds.tolist()):.4g} core-seconds, {wall:.3g} s on {ranks} rank(s) "
        f"(cost model of {calibration.host}; --dry-run for each task{warning})"
    )
    return line, seconds


@dataclass(frozen=True)
class Overheads:
    """Seconds the scheduler and driver add (module docstring). Defaults measured on the 2-core
    development machine (docs/performance.md §"Scheduler and driver overheads"): the claim round
    trip and the server's time per message as ``benchmarks/sweep_scale.py``'s probe measures
    them, the driver's per-task time (scheduling + journal) by ``benchmarks/sweep_scaling.py``,
    rank 0's setup and gather and their shares spread over the ranks by
    ``benchmarks/sweep_scale.py`` on the six-axis job (48 132 tasks)."""

    driver_s: float = 4.3e-3
    service_s: float = 4.5e-5  # server time per message on a full queue
    wake_s: float = 2.5e-3  # claim round trip while rank 0 computes in Python, less service_s
    setup_s: float = 3.2e-5  # rank 0 alone: join the shares, decide, broadcast the plan, chunk
    gather_s: float = 3.4e-5  # rank 0 alone: join the ranks' columns, build and write the data set
    spread_setup_s: float = 6.7e-4  # enumeration and validation, 1/R of it on each rank
    spread_gather_s: float = 1.2e-4  # an outcome turned into columns, on the rank that ran it


def replay(
    tasks: Sequence[Task], seconds: Mapping[str, float], ranks: int, overheads: Overheads = Overheads()
) -> dict[str, float]:
    """Discrete-event model of one sweep of ``tasks`` (their one-core ``seconds`` by key) on
    ``ranks`` ranks (module docstring): makespan, efficiency and where the time goes (shares of
    the makespan lost to the tail, to claims, and to setup + gather)."""
    if ranks < 1:
        raise InputError("ranks", "an integer >= 1", ranks)
    tasks = list(tasks)
    times = np.array([seconds[t.key] for t in tasks], dtype=np.float64)
    return _replay(chunk_order(tasks), times, ranks, overheads)


def _replay(chunks: ChunkOrder, seconds: np.ndarray, ranks: int, overheads: Overheads) -> dict[str, float]:
    """``replay`` of the tasks in ``chunks`` (``tasks.chunk_order``) with ``seconds`` in task
    order: the chunks ``make_chunks`` makes for ``ranks`` (``tasks.chunk_bounds``), each chunk's
    work summed in its order as ``make_chunks``' tuples would be, then taken by the ranks."""
    if ranks < 1:
        raise InputError("ranks", "an integer >= 1", ranks)
    starts, stops = chunk_bounds(chunks, ranks)
    per_task = overheads.driver_s + overheads.spread_gather_s
    work = seconds[chunks.order] + per_task  # each task's seconds and overheads, in chunk order
    single = stops - starts == 1
    chunk_seconds = np.empty(len(starts), dtype=np.float64)
    chunk_seconds[single] = work[starts[single]]
    for k in np.flatnonzero(~single).tolist():
        chunk_seconds[k] = sum(work[starts[k] : stops[k]].tolist())
    n = len(seconds)
    setup = overheads.setup_s * n + overheads.spread_setup_s * n / ranks
    claim_wait = 0.0
    if ranks == 1:  # rank 0 alone: each chunk starts when the last one ends
        last = setup
        for chunk in chunk_seconds.tolist():
            last = last + chunk
        finish = [last]
    else:
        free = [(setup, r) for r in range(ranks)]  # every rank starts after the setup
        heapq.heapify(free)
        server_free = setup
        finish = [setup] * ranks
        service_s, wake_s, replace_first = overheads.service_s, overheads.wake_s, heapq.heapreplace
        for chunk in chunk_seconds.tolist():
            t, rank = free[0]
            if rank == 0:
                start = t
            else:
                served = (t if t > server_free else server_free) + service_s  # max(t, server_free)
                server_free = served
                start = served + wake_s
                claim_wait += start - t
            end = finish[rank] = start + chunk
            replace_first(free, (end, rank))
        last = max(finish)
    makespan = last + overheads.gather_s * n
    work_total = float(sum(seconds.tolist()))
    return {
        "chunks": len(starts),
        "makespan_s": makespan,
        "efficiency": work_total / (ranks * makespan) if makespan > 0 else 1.0,
        "tail": (last - statistics.fmean(finish)) / makespan if makespan > 0 else 0.0,
        "claims": claim_wait / (ranks * makespan) if makespan > 0 else 0.0,
        "setup_gather": (setup + overheads.gather_s * n) / makespan if makespan > 0 else 0.0,
    }


@dataclass
class Estimate:
    """A sweep's estimate: per task (in sweep order) seconds and bytes (float64 arrays: 16 B a
    task, not the 64 of two lists of floats); totals; wall time by ranks; the distinct grids
    (padded cells → tasks) and kernel sets; tasks over the limit. ``sizing_of`` gives each
    task's position in ``sizings`` (distinct ``tasks.Sizing`` values, in first-appearance
    order)."""

    tasks: list[Task]
    seconds: np.ndarray
    bytes: np.ndarray
    wall_s: dict[int, float] = field(default_factory=dict)
    efficiency: dict[int, float] = field(default_factory=dict)
    sizing_of: np.ndarray | None = None
    sizings: list[Sizing] = field(default_factory=list)
    chunks: ChunkOrder | None = None  # the tasks in chunk order (``tasks.chunk_order``), when replayed

    @property
    def total_seconds(self) -> float:
        return float(sum(np.asarray(self.seconds, dtype=np.float64).tolist()))  # in task order, as sum() adds

    @property
    def peak_bytes(self) -> float:
        return float(np.max(self.bytes)) if len(self.bytes) else 0.0

    def grids(self) -> dict[str, int]:
        """Distinct grids: label → number of tasks (labels in first-appearance order)."""
        if self.sizing_of is None:
            self.sizing_of, self.sizings = _sizings(self.tasks)
        counts: dict[str, int] = {}
        for size, count in zip(self.sizings, np.bincount(self.sizing_of, minlength=len(self.sizings)).tolist()):
            label = sizing_label(size)
            counts[label] = counts.get(label, 0) + count
        return counts

    def kernel_sets(self) -> int:
        """Distinct kernel sets (the tasks' kernel groups)."""
        if self.chunks is not None:
            return len(self.chunks.groups) - 1  # where each group starts, and the end
        return len({t.group for t in self.tasks})

    def over(self, limit: float) -> list[int]:
        """Indices of the tasks whose memory exceeds ``limit`` bytes."""
        return np.flatnonzero(np.asarray(self.bytes, dtype=np.float64) > limit).tolist()


def grid_label(params: Mapping[str, Any]) -> str:
    """A grid, as the dry-run names it: the kind's FFT grid in padded cells (a task that asks for
    an accuracy: its boundary cells and finest predicted grid, ``tasks.sizing``)."""
    if asks_accuracy(params):
        return sizing_label(sizing(params))
    return f"{task_kind(params)} {padded_cells(params):.0f} padded cells"


def sizing_label(size: Sizing) -> str:
    """``grid_label`` of a task of this ``tasks.Sizing``."""
    if size.label is not None:
        return size.label
    return f"{size.kind} {size.cells:.0f} padded cells"


def _sizings(tasks: Sequence[Task]) -> tuple[np.ndarray, list[Sizing]]:
    """Each task's position in the list of distinct sizings (first-appearance order), and that
    list; a task without one (``Task.sizing`` None) gets ``tasks.sizing`` of its parameters.
    Tasks share a few sizing objects: they are told apart by ``id`` with numpy, then by value."""
    objects = [t.sizing for t in tasks]
    ids = np.fromiter(map(id, objects), dtype=np.int64, count=len(objects))
    for i in np.flatnonzero(ids == id(None)).tolist():
        objects[i] = sizing(tasks[i].params)
        ids[i] = id(objects[i])
    unique, first, inverse = np.unique(ids, return_index=True, return_inverse=True)
    slot = np.empty(len(unique), dtype=np.intp)
    position: dict[Sizing, int] = {}
    for k in np.argsort(first, kind="stable").tolist():  # distinct objects in first-appearance order
        slot[k] = position.setdefault(objects[first[k]], len(position))  # equal values share a slot
    return slot[inverse.reshape(-1)], list(position)


def task_arrays(
    tasks: Sequence[Task], calibration: Calibration
) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[Sizing]]:
    """``Calibration.task_seconds`` and ``task_bytes`` of every task at once, from its cost and
    sizing (the same operations in the same order: the same floats), with ``_sizings``' map."""
    which, sizes = _sizings(tasks)
    cost = np.array([t.cost for t in tasks], dtype=np.float64)
    seconds = np.empty(len(tasks), dtype=np.float64)
    for k, size in enumerate(sizes):  # a few distinct sizings: each a vector operation
        if size.work is not None:  # an accuracy task: its work, whatever its cost
            seconds[which == k] = work_seconds(calibration.rates["contact"], size.work)
            continue
        rate, at = calibration.rates[size.kind], np.flatnonzero(which == k)
        c = cost[at]
        nodes = 0.0
        if size.kind == "slip":
            nodes = np.array([omega_nodes(dict(tasks[i].params)) for i in at.tolist()], dtype=np.float64)
        seconds[at] = (
            rate.rate_s * c
            + rate.solve_s * (c / (size.cells * math.log2(size.cells)))
            + rate.cell_s * size.cells
            + rate.node_s * nodes
            + rate.task_s
        )
    nbytes = calibration.base_bytes + np.array([s.array_bytes for s in sizes], dtype=np.float64)[which]
    return seconds, nbytes, which, sizes


def estimate(
    tasks: Sequence[Task],
    calibration: Calibration,
    ranks: Sequence[int] = (1, 64, 1024),
    overheads: Overheads = Overheads(),
) -> Estimate:
    """Seconds and bytes of every task (``task_arrays``), and the replayed wall time on each of
    ``ranks`` (the tasks put in chunk order once, ``tasks.chunk_order``)."""
    tasks = tasks if isinstance(tasks, list) else list(tasks)
    with paused_gc():
        seconds, nbytes, which, sizes = task_arrays(tasks, calibration)
        result = Estimate(tasks, seconds, nbytes, sizing_of=which, sizings=sizes)
        chunks = result.chunks = chunk_order(tasks) if tasks else None
        for r in ranks:
            replayed = _replay(chunks, seconds, r, overheads) if tasks else {"makespan_s": 0.0, "efficiency": 1.0}
            result.wall_s[r], result.efficiency[r] = replayed["makespan_s"], replayed["efficiency"]
    return result


def check_memory(tasks: Sequence[Task], limit: float, source: str) -> None:
    """``InputError`` (field --mem-per-rank) when a task's estimated peak memory exceeds
    ``limit`` bytes; the base memory is this process's (no calibration needed). Importing what
    a run imports to measure it costs rank 0 ~1 s while every rank waits, so that is done only
    for a task within IMPORTS_BYTES of the limit."""
    if not tasks:
        return
    which, sizes = _sizings(tasks)
    arrays = np.array([s.array_bytes for s in sizes], dtype=np.float64)[which]  # task_array_bytes of each
    worst = int(np.argmax(arrays))
    if resident_bytes() + IMPORTS_BYTES + float(arrays[worst]) <= limit:
        return
    base = base_memory_bytes()
    need = base + float(arrays[worst])
    if need > limit:
        over = int(np.count_nonzero(base + arrays > limit))
        raise InputError(
            "--mem-per-rank",
            f"at least the largest task's estimated peak memory {need / MIB:.0f} MiB (task {worst}; {over} task(s) "
            f"over the limit; see hpcontact run SPEC --dry-run)",
            f"{limit / MIB:.0f} MiB ({source})",
        )
