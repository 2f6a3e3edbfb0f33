"""The seconds and memory of one task at this machine's calibrated rates (``Rate``, ``Calibration``).

**Seconds.** A task of kind k (``task_kind``: ``contact``, ``crystal``, ``crystal_indentation``
or ``slip``) takes, on one core of the calibrated host,

    seconds = rate_k × cost + solve_k × cost / (S log2 S) + cell_k × S + task_k [+ node_s × ω nodes, slip]

with ``cost = sweep.cost.task_cost.estimated_cost(params)`` as the cost units (padded FFT cells
S · log2 S × solves × CG iterations, the iterations as digits of tolerance × the grid's
iteration factor (1 + 0.3 log2 ρ) log2 S / 18, ρ the contact grid's aspect in cells: ``footprint``; a slip
scene's solves follow its load path, ``tasks.slip_cost``) and S = ``cost.grids.padded_cells(params)``
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

``cost.calibration`` measures the coefficients; ``cost.calibration_file`` keeps them per node type
(CPU model and core count, ``node_type``) and version.

**Accuracy tasks.** A task that asks for an accuracy (``[numerics] accuracy``, ``hpcontact run
--accuracy``) solves a sequence of grids (``accuracy.solve_to_accuracy``, strategy auto): it is
costed over the grids it is predicted to solve (``cost.grids.accuracy_plan``: ``accuracy.first_grid``'s
boundary cells, ``accuracy.plan_grids``' grids, four at 1e-3 for coverage-weighted cells and one
more per decade below, ``cost.grids.predicted_grid_count``), each grid's work summed into a
``tasks.Work`` whose terms take the contact kind's coefficients, and a crystal's grids the
crystal kind's (c):

    seconds = rate_s × fft + solve_s × solves + cell_s × cells + task_s × grids + strip_s × strips
              + exact_s × kernel_builds + rate_s(c) × crystal_fft + solve_s(c) × crystal_solves

(``work_seconds``): an ellipse's or circle's one exact cell (galin: no grid) one task term; a
crystal task, on an exact cell or on grids, also ``exact_s``, the build of its material's kernel
(the Barnett–Lothe Fourier series and table: ``EXACT_CALIBRATION_SCENE`` timed cold less warm),
which a sweep counts once per kernel group (the tasks of one material and b/a, run one after
another on a rank whose kernel cache holds the last 8 materials: ``estimate.shared_kernel_builds``),
a task estimated alone cold; an isotropic
grid of coverage-weighted cells its one-grid FFT model
(cost, cost / (S log2 S), S and one task term) times its cells' measured factor; a crystal's grid
its one-grid model at the crystal kind's rates and one task term (the crystal kind's calibration
solves on n = 32 and 64 measure a crystal grid's fixed work, its near cells' edge integrals and
its preconditioner's symbol per solve, which the contact kind's rates lack);
a slender rectangle's strip cells (dense Galerkin integrals, ``hpcontact.discretizations.strip_cells``) their
``cost.task_cost.strip_units`` at ``strip_s``, the seconds of a strip unit on this host; below 1e-3 a
coverage-weighted task also counts a share of the grid after its last and less a share of its
last (``tasks.accuracy_work``: the count varies by one about the predicted one). Their memory
is ``accuracy.grid_bytes`` of the finest predicted grid with its boundary cells (the arrays that
``accuracy.plan_grids`` budgets; an exact cell: its kind's fixed bytes,
``footprint.MEMORY_MODEL``). The measurements: docs/performance.md §"Accuracy tasks".

**Memory.** The peak resident memory of a rank running a task is

    bytes = base + fixed_k + per_cell_k × padded_cells(params)

``base`` is this process's peak resident set (``resource.getrusage``) after importing what a
rank that runs tasks imports (the solvers, MPI; not xarray, ~41 MiB, which rank 0 alone imports
for its data set, whose arrays no task's model counts either); ``padded_cells`` is the padded
FFT grid (``cost.grids.padded_cells``). ``fixed_k`` and ``per_cell_k`` are float64 array sizes (no machine
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
"""

from __future__ import annotations

import datetime
import math
import os
import platform
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hpcontact.numerics.convolution import wisdom_path
from hpcontact.numerics.memory import MIB, GpuMemory, resident_bytes
from hpcontact.problems import footprint
from hpcontact.problems.footprint import BODY_TABLE_GROUPS, task_kind
from hpcontact.sweep.cost.engine import omega_nodes
from hpcontact.sweep.cost.grids import asks_accuracy, padded_cells, solved_grids
from hpcontact.sweep.cost.task_cost import Work, estimated_cost, sizing

# The calibrated kinds of task (``footprint.task_kind``): each has its ``Rate``.
KINDS = ("contact", "crystal", "crystal_indentation", "slip")

#: A calibration that ran beside this many other running processes (mean of its samples) is
#: flagged (``Calibration.contended``). On the 2-vCPU development machine, whose two vCPUs share
#: a core, one other busy process during the ~20 s calibration made the main job's dry run
#: 226.5 core-seconds against 68.9 calibrated alone (2026-11-26 13:32, its task time 58.6 s).
CONTENDED_FROM = 0.5
#: How much faster than a contended calibration estimates tasks may run on an idle machine: the
#: main job's dry run above, 226.5 / 68.9 core-seconds (the calibration's CPU seconds, measured on
#: a core shared with a busy neighbour, are high; never low: ``Calibration.contended``).
CONTENDED_RATES = 226.5 / 68.9

# What importing a run's modules (hpcontact.solve, xarray, the slip solver, mpi4py.MPI) can add
# to a process that has not yet: 3x the 80 MiB they added (docs/performance.md §"Base memory of a rank").
IMPORTS_BYTES = 3 * 80 * MIB


@dataclass(frozen=True)
class Rate:
    """Seconds of a task of one kind: ``rate_s × cost + solve_s × solve_units + cell_s ×
    padded cells + node_s × omega_nodes + task_s`` (module docstring; ``cell_s``,
    ``task_s``, ``strip_s``, seconds per strip unit of an accuracy task's strip cells, and
    ``exact_s``, seconds of a crystal's kernel build (timed on its exact cell), are measured for the isotropic
    contact kind, ``node_s`` for slip scenes)."""

    rate_s: float
    solve_s: float
    node_s: float = 0.0
    cell_s: float = 0.0
    task_s: float = 0.0
    strip_s: float = 0.0
    exact_s: float = 0.0


def work_seconds(rates: Mapping[str, Rate], work: Work) -> float:
    """Seconds of an accuracy task's ``tasks.Work`` at the calibrated ``rates`` (by kind): the
    contact kind's for its isotropic grids, strips, exact cells and crystal kernel builds, the
    crystal kind's for a crystal's grids (module docstring, "Accuracy tasks")."""
    rate, crystal = rates["contact"], rates["crystal"]
    return (
        rate.rate_s * work.fft
        + rate.solve_s * work.solves
        + rate.cell_s * work.cells
        + rate.task_s * work.grids
        + rate.strip_s * work.strips
        + rate.exact_s * work.kernel_builds
        + crystal.rate_s * work.crystal_fft
        + crystal.solve_s * work.crystal_solves
    )


def solve_units(params: Mapping[str, Any], cost: float) -> float:
    """Solves × digits of the scene ``params`` of estimated ``cost``: cost / (S log2 S)."""
    cells = padded_cells(params)
    return cost / (cells * math.log2(cells))


def cpu_model() -> str:
    """This machine's CPU model as the kernel names it (the first ``model name``, ``cpu model``
    or ``Hardware`` line of /proc/cpuinfo, spaces collapsed; else ``platform.processor()`` or
    ``platform.machine()``)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.lower().startswith(("model name", "cpu model", "hardware")) and ":" in line:
                    return " ".join(line.split(":", 1)[1].split())
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def node_type() -> tuple[str, int]:
    """What a calibration is matched by (``calibration_file.cached_calibration``): the CPU
    model and the machine's logical core count (``os.cpu_count``), not the host name, so that
    nodes of one type share a calibration."""
    return cpu_model(), os.cpu_count() or 1


def _today() -> str:
    """Now, UTC, to the minute (a calibration's ``date``)."""
    return datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")


@dataclass(frozen=True)
class Calibration:
    """This machine's seconds per kind and the base memory of a run, with where they were
    measured (``host``, its ``cpu`` model and ``cores``: by default this machine's,
    ``node_type``), by which package ``version``, when (``date``, UTC) and how long the
    calibration took."""

    host: str
    version: str
    rates: dict[str, Rate]
    base_bytes: float
    seconds: float = 0.0
    others: float | None = None  # other processes running beside it (``other_running``; None: unknown)
    cpu: str = field(default_factory=cpu_model)
    cores: int = field(default_factory=lambda: node_type()[1])
    date: str = field(default_factory=_today)

    def whose(self) -> str:
        """Where and when it was measured, for the lines that use it: "host (CPU, N cores),
        date, hpcontact version"."""
        return f"{self.host} ({self.cpu}, {self.cores} cores), {self.date}, hpcontact {self.version}"

    def contended(self) -> str:
        """ "" when the calibration ran alone, else what a reader of an estimate must know: other
        processes ran beside it (``CONTENDED_FROM``). Its CPU seconds were measured on cores it
        shared, which makes them high: on an idle machine tasks run faster than it estimates
        (``CONTENDED_RATES``). A run that itself shares its cores takes longer in wall time than
        any estimate says, whatever the calibration (``load_note``)."""
        if self.others is None or self.others < CONTENDED_FROM:
            return ""
        return (
            f"calibrated while ~{self.others:.1f} other process(es) ran: its seconds are likely high (on an idle "
            f"machine tasks run up to {CONTENDED_RATES:.1f}x faster than it estimates); for a calibration made "
            f"alone remove {calibration_path()} and rerun --dry-run on an idle machine"
        )

    def task_seconds(self, params: Mapping[str, Any], cost: float | None = None) -> float:
        """Estimated seconds of the scene ``params`` on one core (a scene that asks for an
        accuracy: its ``tasks.Work`` at the contact kind's rates, a crystal's grids at the crystal
        kind's, whatever ``cost``; a crystal's kernel built, as for a task alone: a sweep's estimate
        counts it once per kernel group, ``estimate.shared_kernel_builds``)."""
        if asks_accuracy(params):
            return work_seconds(self.rates, sizing(params).work)
        kind = task_kind(params)
        rate = self.rates[kind]
        cost = estimated_cost(params) if cost is None else cost
        nodes = omega_nodes(params) if kind in BODY_TABLE_GROUPS else 0
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


def load_note(running: float | None, cores: int) -> str:
    """ "" when the processes ``running`` on this machine now (running or runnable, a run's own
    ranks among them: ``calibration.other_running`` + 1 for the caller; None: unknown) fit on its
    ``cores``, else what a reader of an estimate must know: the estimate is the time of each
    task on a core of its own, and time-shared cores stretch the wall time by up to
    running / cores (the issue 42 run: estimated 196 core-seconds, 464 s on 2 cores beside a
    load of 3-6)."""
    if running is None or running <= cores:
        return ""
    return (
        f"~{running:.0f} processes share this machine's {cores} core(s) now, this run's among them: it may take "
        f"up to {running / cores:.1f}x the estimated wall time"
    )


def named_calibration_path() -> Path | None:
    """The calibration file its user named ($HPCONTACT_COSTMODEL; ``hpcontact run --costmodel
    FILE`` sets it), else None."""
    env = os.environ.get("HPCONTACT_COSTMODEL")
    return Path(env) if env else None


def calibration_path() -> Path:
    """The file named (``named_calibration_path``), else the cache of this node type beside the
    FFTW wisdom file: ``costmodel-CPU-Nc.json`` (the CPU model in letters, digits and dashes,
    N its cores, ``node_type``), shared by every node of the type where the home folder is."""
    named = named_calibration_path()
    if named is not None:
        return named
    cpu, cores = node_type()
    slug = re.sub(r"[^A-Za-z0-9]+", "-", cpu.replace("(R)", "").replace("(TM)", "")).strip("-").lower()
    return wisdom_path().with_name(f"costmodel-{slug[:60] or 'cpu'}-{cores}c.json")


def gpu_calibration_path(gpu: GpuMemory) -> Path:
    """The cost model of tasks on the GPU ``gpu`` (``numerics.memory.GpuMemory``): ``costmodel-gpu-NAME-MEMg.json``
    beside the CPU ones (``calibration_path``), NAME its name in letters, digits and dashes, MEM its
    memory in whole GiB: one file per kind of GPU, whatever the CPU beside it."""
    slug = re.sub(r"[^A-Za-z0-9]+", "-", gpu.name).strip("-").lower()
    return wisdom_path().with_name(f"costmodel-gpu-{slug[:60] or 'gpu'}-{gpu.total / 2**30:.0f}g.json")


def task_array_bytes(params: Mapping[str, Any]) -> float:
    """The arrays of one task of ``params`` (``footprint.array_bytes`` of the finest grid it
    solves, ``cost.grids.solved_grids``; a task that asks for an accuracy: ``accuracy.grid_bytes`` of
    its finest predicted grid with its boundary cells, ``tasks.sizing``)."""
    if asks_accuracy(params):
        return sizing(params).array_bytes
    return footprint.array_bytes(solved_grids(params)[-1])


def base_memory_bytes() -> float:
    """Peak resident bytes of this process after importing what a rank that runs tasks imports
    (module docstring): not xarray, whose import (0.5-0.6 CPU s) a run's first announcement
    paid while the other ranks of a short first round waited (``run.rounds``)."""
    import mpi4py.MPI  # noqa: F401 - imported for its resident size, as a run does

    return resident_bytes()
