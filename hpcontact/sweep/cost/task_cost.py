"""The cost of one task of a sweep, in arbitrary cost units, and the sizes the cost model reads.

A contact scene on one grid costs its padded FFT cells S · log2 S (per operator application) ×
its solves × its CG iterations (digits of tolerance × the grid's iteration factor); a crystal
costs more (coupled tangential solves, kernels by quadrature); a scene extrapolated by default
costs ``EXTRAPOLATION_WORK`` × the sum over its grids (``cost.grids.solved_grids``); a task that
asks for an accuracy is costed over the grids it is predicted to solve, each with its boundary
cells' work (``accuracy_work``, ``Work``); a slip scene follows its load path (``slip_cost``).
``costed`` gives a task's cost with its ``Sizing`` (its kind, padded cells and array bytes),
cached per scene but for the fields that do not change the cost. The cost units order tasks
and, at the calibrated rates, give their seconds (``cost.rates``).
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

from hpcontact import fields
from hpcontact.accuracy import MIN_GRIDS, STRATEGIES
from hpcontact.accuracy.strategies import EXACT
from hpcontact.problems import footprint
from hpcontact.problems.footprint import iteration_factor, task_kind
from hpcontact.problems.kinds import CONTACT, SLIP, quantity_names, scene_kind
from hpcontact.problems.slip.crystal_pair import pair_from_params
from hpcontact.scene import canonical_json
from hpcontact.sweep.cost.engine import strip_pairs
from hpcontact.sweep.cost.grids import (
    BOUNDARY_TAG,
    COVERAGE_FOUR_GRIDS_TO,
    DEFAULT_TOL,
    accuracy_levels,
    accuracy_plan,
    asks_accuracy,
    padded_cells,
    solved_grids,
    with_request,
)
from hpcontact.sweep.space.axes import PATH_FIELDS

# Fields that do not change a scene's estimated cost, by kind (``hpcontact.fields``): a contact
# scene's cost reads the grid, the solves, the tolerance and whether the body is a crystal, not an
# isotropic body's constants nor how a crystal is oriented; a slip scene's reads its pair's
# constants (the coupling size β, ``slip_cost``): none of its fields is left out.
COST_NEUTRAL_FIELDS: Mapping[str, frozenset[str]] = {
    CONTACT: frozenset(fields.names(CONTACT, neutral_to="cost")),
    SLIP: frozenset(),
}
# Fields that change a contact scene's cost, grid and memory only where they cross these values
# (A = 1: an isotropic body, else a crystal): a run away from them has one cost. By kind.
COST_BRANCH_FIELDS: Mapping[str, Mapping[str, tuple[float, ...]]] = {CONTACT: {"anisotropy": (1.0,)}, SLIP: {}}
# Fields that change a contact scene with ``n`` (one grid) only through its contact grid
# (``footprint.contact_grid``: the cost reads the padded cells and the grid's iteration factor):
# a run over one of them is costed once per distinct grid. By kind (a slip scene: none).
GRID_ONLY_FIELDS: Mapping[str, frozenset[str]] = {
    CONTACT: frozenset(footprint.GRID_FIELDS) - {"quantities"},
    SLIP: frozenset(),
}
# Relative number of operator solves per requested quantity (tangential: x and y loads).
SOLVES_PER_QUANTITY = {"tangential": 2.0, "normal": 1.0, "compliance": 0.1, "coupled": 3.0, "indentation": 3.0}
# The engine's quantities where a spec leaves them out; only ratios of costs matter.
DEFAULT_QUANTITIES = ("tangential",)
# A crystal scene (named material or A != 1): the tangential tensor comes from the coupled 3 x 3
# bonded punch (three solves, nine kernel blocks per operator application instead of four), and
# its kernels are integrated by quadrature (~10x an isotropic scene: docs/performance.md §"Task
# cost constants").
CRYSTAL_TANGENTIAL_SOLVES = 3.0 * 9.0 / 4.0
CRYSTAL_FACTOR = 2.0
# A slip scene (hpcontact.problems.slip.partial_slip): one Polonsky–Keer normal solve, then ~8 CG-sized solves per load
# step (semismooth Newton steps and the tangent tensor), on the padded grid of ±1.1 Hertz radii
# (≈ 1.1 n cells a side). A dissimilar pair solved coupled alternates normal and tangential
# solves (Panagiotopoulos passes) until they agree to the tolerance: the passes converge at the
# rate of the coupling size β, so a step takes digits / (−log10 β) of them, each at ~0.5 of a
# decoupled step's work (warm started; ``SLIP_PASS_WORK``, docs/performance.md §"Task cost
# constants").
SLIP_SOLVES_PER_STEP = 8.0
SLIP_TENSOR_SOLVES_PER_STEP = 2.0  # a step without tangential load: the 2 x 2 tangent tensor only
SLIP_PASS_WORK = 0.5
SLIP_DEFAULT_STEPS = 10
# A scene extrapolated by default (``solved_grids``) costs this many times the one-grid solves of
# its grids: coverage-weighted cells take 2-18 % more CG iterations and build their coverage,
# and every grid from the fourth on is extrapolated; default_solve took 1.27-1.60x the sum of
# solve() on its five grids (docs/performance.md §"Task cost constants").
EXTRAPOLATION_WORK = 1.4
# Below 1e-3 the count of coverage-weighted cells is the most frequent one, not the only one: 2 of
# 12 requests of 1e-4 took a grid more, 2 one fewer; 3 of 8 of 1e-5 one fewer. A grid costs 4-5
# times the one before, so the time counts ``ONE_MORE_SHARE`` of the next planned grid and takes
# off ``ONE_FEWER_SHARE`` of the last predicted one (beyond ``MIN_GRIDS``): the expected time of
# many such tasks, not the time of the most frequent count (``accuracy_work``).
ONE_MORE_SHARE = 0.2
ONE_FEWER_SHARE = 0.25
# A grid of coverage-weighted cells costs the one-grid FFT model of that grid (every
# term of the cost model (``cost.rates``), the contact kind's rates: ``level_work``) times a factor: isotropic
# coverage-weighted cells ``COVERAGE_WORK`` × (1 + ``COVERAGE_ASPECT_WORK`` log2 ρ), ρ the grid's
# aspect in cells (coverage, damping and preconditioner weights; their CG iterations grow faster
# with ρ than the one-grid model's). A crystal's grid costs the one-grid model at the crystal
# kind's calibrated rates (``Work.crystal_fft``, ``Work.crystal_solves``): its fixed work per grid
# (the near cells' edge integrals of its nine kernel blocks, its preconditioner's symbol summed from
# the kernel's Fourier series per solve) is what those rates measure, and the contact kind's rates
# times one factor missed it by 2-10x on the main job's small grids (16 x 4 … 64 x 16: 0.1-0.2 s
# each, estimated 0.02-0.06 s) while overestimating its large ones by 1.5x; at its rates every crystal
# grid after a task's first is within 0.7-1.25x (the main job's first-hour run, 2 idle cores,
# 2026-11-29: ``benchmarks/cost_estimates.py --journals``).
# A crystal task also builds its material's kernel (``Work.kernel_builds``: the Barnett–Lothe
# Fourier series and table, ``kernels.anisotropic.kernel_for``, at ``Rate.exact_s``), once per
# kernel group of a sweep (``estimate.shared_kernel_builds``). An outline that is
# not an ellipse, circle or rectangle (polygons, stars, masks) builds its coverage by clipping:
# ``OUTLINE_COVERAGE_WORK`` cost units per cell along both sides and grid.
COVERAGE_WORK = 1.05
COVERAGE_ASPECT_WORK = 0.37
OUTLINE_COVERAGE_WORK = 2.1e5
ANALYTIC_OUTLINES = ("circle", "ellipse", "rectangle")
# Strip cells (``strip_cells``: dense Galerkin integrals, then Cholesky; ``auto`` takes them for
# slender rectangles only, b/a ≤ ``strip_cells.MAX_ASPECT``: ellipses take their exact cell) cost,
# per grid of n strips (``strip_units``), ``STRIP_SECONDS_PER_FAR_PAIR`` per far pair (Gauss
# product rule on the moment series) and ``STRIP_SECONDS_PER_STRIP`` per strip: CPU seconds on the
# development machine (fitted to two runs, 77 and 80 grids, rectangles b/a 1e-6 … 1e-12 on
# 32 … 1024 strips among them), counted in units of ``STRIP_UNIT_SECONDS`` (its contact rate_s,
# so that a strip unit weighs as an FFT grid's cost unit in a task's cost); ``cost.calibration``
# calibrates the seconds of a strip unit on each host (``Rate.strip_s``).
STRIP_UNIT_SECONDS = 2.4e-9
STRIP_SECONDS_PER_FAR_PAIR = 2.6e-6
STRIP_SECONDS_PER_STRIP = 1.9e-4


class Work(NamedTuple):
    """The work of an accuracy task summed over its predicted grids (``accuracy_work``), one
    number per term of the cost model's seconds (``cost.rates.work_seconds``): ``fft`` cost units
    (× the contact kind's rate_s), ``solves`` solve units (× solve_s), ``cells`` padded cells whose
    kernels are built (× cell_s), ``grids`` (× task_s), ``strips`` strip units (× strip_s),
    ``kernel_builds`` crystal kernels built (× exact_s: the material's Barnett–Lothe Fourier series,
    whether its task solves grids or one exact cell) and a crystal's grids at the crystal kind's
    rates: ``crystal_fft`` cost units (× its rate_s) and ``crystal_solves`` solve units (× its
    solve_s); the FFT terms of an isotropic grid carry its boundary cells' factor."""

    fft: float
    solves: float
    cells: float
    grids: float
    strips: float
    kernel_builds: float
    crystal_fft: float = 0.0
    crystal_solves: float = 0.0


class Sizing(NamedTuple):
    """What the cost model reads of a task besides its cost (``sizing``): the calibration
    ``kind`` (``footprint.task_kind``), the padded ``cells`` of the finest grid it solves
    (``padded_cells``) and that grid's ``array_bytes`` (``footprint.array_bytes``). Few distinct
    values in a sweep: tasks share one object per value. A task that asks for an accuracy also
    has its ``work`` (``Work``: its seconds are those terms, not the cost's) and the ``label``
    the dry run lists its grids under; its ``array_bytes`` are ``accuracy.grid_bytes`` of its
    finest predicted grid with its boundary cells."""

    kind: str
    cells: float
    array_bytes: float
    work: Work | None = None
    label: str | None = None


def strip_units(level: Mapping[str, Any]) -> float:
    """Strip units (``STRIP_UNIT_SECONDS`` each on the development machine) of one grid of strip
    cells of a rectangle, the level ``level`` (n strips): its far pairs (``strip_pairs``) and
    strips at their seconds. Rectangles only: an ellipse's strips (its near pairs' width
    corrections) are not modelled, as ``auto`` never gives an ellipse strips."""
    shape, aspect, n = str(level.get("shape")), float(level.get("aspect", 1.0)), int(level["n"])
    if shape != "rectangle":
        raise ValueError(f"strip units are modelled for rectangles only, not {shape}")
    _, far = strip_pairs(shape, aspect, n)
    return (STRIP_SECONDS_PER_FAR_PAIR * far + STRIP_SECONDS_PER_STRIP * n) / STRIP_UNIT_SECONDS


def level_work(level: Mapping[str, Any]) -> Work:
    """``Work`` of one level of ``accuracy_levels``: the one exact cell of an ellipse (galin) one
    task term; a strip grid its ``strip_units``; an isotropic grid of coverage-weighted cells its
    one-grid FFT model (``_contact_cost``: cost units, solve units cost / (S log2 S), S padded
    cells, one task term) times its cells' factor (``COVERAGE_WORK`` × (1 + ``COVERAGE_ASPECT_WORK``
    log2 ρ)); a crystal's grid its one-grid model at the crystal kind's rates (``crystal_fft``,
    ``crystal_solves``) and one task term; plus, for an outline that is not an ellipse, circle or
    rectangle, its clipping: ``OUTLINE_COVERAGE_WORK`` per cell along both sides (n + n_across).
    A crystal's kernel build is the task's, not a level's (``accuracy_work``)."""
    boundary = level.get(BOUNDARY_TAG)  # None: coverage-weighted cells (default_solve's grids)
    if boundary == EXACT:  # a contour integral over the kernel's Fourier series: one task term
        return Work(0.0, 0.0, 0.0, 1.0, 0.0, 0.0)
    if boundary is not None and STRATEGIES[boundary].strips:
        return Work(0.0, 0.0, 0.0, 1.0, strip_units(level), 0.0)
    cost = _contact_cost(level)
    cells = footprint.padded_cells(level)
    clipping = 0.0
    if level.get("shape", "circle") not in ANALYTIC_OUTLINES:
        clipping = OUTLINE_COVERAGE_WORK * (int(level["n"]) + int(level["n_across"]))
    units = cost / (cells * math.log2(cells))
    if task_kind(level) in footprint.KERNEL_BUILD_BYTES:  # a crystal's coverage factor
        return Work(clipping, 0.0, 0.0, 1.0, 0.0, 0.0, cost, units)
    nx, ny = footprint.contact_grid(level)
    factor = COVERAGE_WORK * (1.0 + COVERAGE_ASPECT_WORK * math.log2(max(nx, ny) / min(nx, ny)))
    return Work(factor * cost + clipping, factor * units, factor * cells, factor, 0.0, 0.0)


def accuracy_work(params: Mapping[str, Any]) -> Work:
    """``Work`` of the accuracy task ``params``: the sum of its levels' (``level_work``) and, for a
    crystal, one build of its kernel (``Work.kernel_builds``); for
    coverage-weighted cells below ``COVERAGE_FOUR_GRIDS_TO``, plus ``ONE_MORE_SHARE`` of the next
    planned grid's and less ``ONE_FEWER_SHARE`` of the last predicted grid's beyond
    ``MIN_GRIDS`` (the expected time of a count that varies by one: docs/performance.md
    §"Accuracy tasks")."""
    params = with_request(params)
    plan, levels = accuracy_plan(params), accuracy_levels(params)
    parts = [(1.0, level_work(level)) for level in levels]
    if task_kind(params) in footprint.KERNEL_BUILD_BYTES:  # a crystal: its kernel, once, whatever its cells
        parts.append((1.0, Work(0.0, 0.0, 0.0, 0.0, 0.0, 1.0)))
    if not plan.exact and not plan.cells.strips and float(params["accuracy"]) < COVERAGE_FOUR_GRIDS_TO:
        if plan.next_grid is not None:
            n, na = plan.next_grid
            parts.append((ONE_MORE_SHARE, level_work({**levels[-1], "n": n, "n_across": na})))
        if len(levels) > MIN_GRIDS:
            parts.append((-ONE_FEWER_SHARE, parts[len(levels) - 1][1]))
    return Work(*(math.fsum(w * part[k] for w, part in parts) for k in range(len(Work._fields))))


def estimated_cost(params: Mapping[str, Any]) -> float:
    """Relative cost of a scene: padded FFT size · log (per operator application) × solves ×
    digits of tolerance × the iteration factor of the grid's aspect in cells (CG iterations:
    ``footprint.iteration_factor``, (1 + 0.3 log2 ρ) log2 S / 18). The grid is ``footprint.contact_grid``'s
    (the rule of ``geometry.grid_for`` on the turned shape); crystal scenes cost more
    (``CRYSTAL_FACTOR``, coupled tangential solves); slip scenes see ``slip_cost``. A contact
    scene without ``n`` that is extrapolated by default costs ``EXTRAPOLATION_WORK`` × the sum
    over the grids it solves (``solved_grids``). Cached per scene, the fields that do not
    change the cost (``COST_NEUTRAL_FIELDS``) aside, except for scenes reading a file (a mask:
    its grid is the file's)."""
    return costed(params)[0]


def costed(params: Mapping[str, Any]) -> tuple[float, Sizing]:
    """``estimated_cost`` and ``sizing`` of the scene ``params``, cached as ``estimated_cost``
    (the sizes depend on the grid, the kind and the solves, which the cost key holds)."""
    return COSTED_BY_KIND[scene_kind(params)](params)


def _contact_costed(params: Mapping[str, Any]) -> tuple[float, Sizing]:
    """``costed`` of a contact scene: cached by its cost key (its fields but the cost-neutral
    ones), except for a scene reading a file (a mask: its grid is the file's)."""
    if any(params.get(name) is not None for name in PATH_FIELDS):
        return _contact_cost(params), sizing(params)
    neutral = COST_NEUTRAL_FIELDS[CONTACT]
    return _cached_contact_cost(canonical_json({k: v for k, v in params.items() if k not in neutral}))


def _slip_costed(params: Mapping[str, Any]) -> tuple[float, Sizing]:
    """``costed`` of a slip scene: ``slip_cost``, scene by scene."""
    return slip_cost(params), sizing(params)


@functools.lru_cache(maxsize=4096)
def _cached_contact_cost(text: str) -> tuple[float, Sizing]:
    """``_contact_cost`` and ``sizing`` of the scene ``text`` (canonical JSON)."""
    params = json.loads(text)
    return _contact_cost(params), sizing(params)


_SIZINGS: dict[Sizing, Sizing] = {}  # one object per distinct value


def sizing(params: Mapping[str, Any]) -> Sizing:
    """The ``Sizing`` of the scene ``params``: its kind, and the padded cells and array bytes of
    the finest grid it solves (``solved_grids``); for a scene that asks for an accuracy, the
    bytes of ``accuracy.grid_bytes`` on that grid with its boundary cells, the ``Work`` of its
    grids and the label of its grids."""
    levels = solved_grids(params)
    finest = levels[-1]
    if asks_accuracy(params):
        plan = accuracy_plan(params)
        n, na = plan.grids[-1]
        kind = task_kind(params)
        if plan.exact:
            label, cells = f"{kind} accuracy: one exact cell (galin)", 0.0
        else:
            where = f"{n} strips" if plan.cells.strips else f"{n} x {na}"
            label, cells = f"{kind} accuracy: {plan.strategy} cells to {where}", footprint.padded_cells(finest)
        size = Sizing(kind, cells, plan.finest_bytes, accuracy_work(params), label)
    else:
        size = Sizing(task_kind(params), footprint.padded_cells(finest), footprint.array_bytes(finest))
    return _SIZINGS.setdefault(size, size)


def _contact_cost(params: Mapping[str, Any]) -> float:
    """``estimated_cost`` of the contact scene ``params``; of one that asks for an accuracy, its
    FFT cost units, a crystal's included, and strip units (``accuracy_work``: comparable on the
    development machine)."""
    levels = solved_grids(params)
    if asks_accuracy(params):
        work = accuracy_work(params)
        return work.fft + work.strips + work.crystal_fft
    if len(levels) > 1:
        return EXTRAPOLATION_WORK * sum(_contact_cost(level) for level in levels)
    quantities = quantity_names(params.get("quantities", DEFAULT_QUANTITIES))
    size = padded_cells(params)
    crystal = params.get("material") is not None or float(params.get("anisotropy", 1.0)) != 1.0
    solves = sum(
        CRYSTAL_TANGENTIAL_SOLVES if crystal and q == "tangential" else SOLVES_PER_QUANTITY.get(q, 1.0)
        for q in quantities
    )
    if params.get("shape") == "rough":
        solves += 1.0  # the contact patch comes from a normal contact solve
    digits = max(1.0, -math.log10(float(params.get("tol", DEFAULT_TOL))))
    iterations = digits * iteration_factor(params)
    return size * math.log2(size) * max(solves, 0.1) * iterations * (CRYSTAL_FACTOR if crystal else 1.0)


def slip_cost(params: Mapping[str, Any]) -> float:
    """Relative cost of a slip scene: padded FFT size · log × (1 + solves per step × steps ×
    passes) × digits of tolerance, on the n × n contact grid with its margin. A step under a
    tangential load (q_ratio > 0, or displacement control) costs ~8 CG-sized solves (semismooth
    Newton steps and the tangent tensor); without one (q_ratio = 0 under force control) only the
    tangent tensor's 2; a loop path has 5 × steps steps. A dissimilar pair pays for its coupled
    path (0.5 × digits / (−log10 β) decoupled steps per step, β the pair's coupling size:
    ``SLIP_PASS_WORK``; and the decoupled one with coupling auto/both); with ``normal_friction``
    the normal load too is applied in ``steps`` coupled steps, so the coupled path's work
    doubles. The counts behind these factors: docs/performance.md §"Task cost constants".
    Same units as ``estimated_cost``; the Barnett–Lothe cost of anisotropic bodies is
    a per-task term of the cost model (``cost.rates``)."""
    size = padded_cells(params)
    steps = int(params.get("steps", SLIP_DEFAULT_STEPS)) * (5 if params.get("path") == "loop" else 1)
    loaded = float(params.get("q_ratio", 0.0)) > 0.0 or params.get("control") == "displacement"
    per_step = SLIP_SOLVES_PER_STEP if loaded else SLIP_TENSOR_SOLVES_PER_STEP
    tangential = per_step * steps if float(params.get("mu", 1.0)) > 0.0 else 0.0
    coupling = params.get("coupling", "auto")
    digits = max(1.0, -math.log10(float(params.get("tol", DEFAULT_TOL))))
    pair = pair_from_params(params) if coupling != "decoupled" else None
    if pair is None or pair.similar:
        passes = 1.0
    else:
        beta = min(getattr(pair, "coupling_size", None) or abs(pair.dundurs_beta), 0.9)
        coupled = max(1.0, SLIP_PASS_WORK * digits / -math.log10(beta))
        coupled *= 2.0 if params.get("normal_friction") else 1.0
        passes = coupled if coupling == "coupled" else 1.0 + coupled
    return size * math.log2(size) * (1.0 + tangential * passes) * digits


# ``costed`` by scene kind (``hpcontact.problems.kinds``).
COSTED_BY_KIND: Mapping[str, Callable[[Mapping[str, Any]], tuple[float, Sizing]]] = {
    CONTACT: _contact_costed,
    SLIP: _slip_costed,
}
