r"""The boundary cells ``--accuracy`` refines over grids, one ``Strategy`` record each in
``STRATEGIES`` (grid sequence, first grid, calibrated range, memory model, model error,
estimator settings), and the choice of ``auto`` (:func:`first_grid`).

``hpcontact solve --accuracy`` uses strategy ``auto``. Unturned rectangles of b/a ≤ 1e-6 and
unturned ellipses, isotropic — ellipses wider than ``STRIP_WIDE_ASPECT`` = 1e-2 for requests
below ``SINGULAR_BELOW`` only — take strip cells (``hpcontact.discretizations.strip_cells``): n = 32, 64, …
strips (``STRIP_N0``; ellipses, whose strips contain the exact traction, from
``STRIP_ELLIPSE_N0`` = 16) up to ``STRIP_MAX_N`` = 1024 (ellipses wider than 1e-2:
``STRIP_WIDE_MAX_N`` = 256), the estimator of coverage-weighted cells (``EXPANSIONS``,
``SAFETY``) plus the bound ``strip_cells.model_error`` (where that bound is not below the
request, ``stopped_by`` "model" after four grids; coverage-weighted cells on ellipses of b/a
0.002 … 0.04 add a measured bias bound likewise, :func:`model_error`). Replayed on every grid of those sequences
(``benchmarks/strip_calibration.py``: rectangles b/a = 1e-6 … 1e-12 against the strip model's
limit from 2048 and 4096 strips, ellipses b/a = 1 … 1e-10 against Mindlin and Galin; nu 0, 0.3,
0.5; n₀ = 32, 64 and 16, 32; requests 1e-3 … 1e-7): honest on every record
(docs/validation.md §"Calibration on strip cells"). Singular cells, where they apply, are taken
only when asked for (``strategy="singular"``: every contact they apply to has the exact cell,
which ``auto`` takes; their calibration covers requests below 1e-4, ``SINGULAR_BELOW``), on
sequences from :func:`singular_start` (near-square cells; b/a = 0.05 starts at 160 × 8), with
the candidates led by order 1 only (``SINGULAR_EXPANSIONS``) and the spread times
``SINGULAR_SAFETY`` = 6, on grids up to ``SINGULAR_MAX_CELLS`` = 2^20 cells. Replayed on every
grid of those sequences up to 2^20 cells (b/a = 1, 0.7, 0.5, 0.3, 0.2, 0.1, 0.05; nu = 0, 0.3,
0.5; n₀ = 16 and 32; requests 1e-3 … 1e-6; ``benchmarks/edge_order.py --singular-calibration``):
honest on every record and every per-quantity pair. Their factor is larger than coverage-weighted
cells' 3 because singular cells' error levels off at a few 1e-7 without a steady sign, which
no difference of grids shows (docs/validation.md §"Calibration on singular cells").
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping

from hpcontact.accuracy import memory
from hpcontact.accuracy.extrapolation import EXPANSIONS, RATIO
from hpcontact.discretizations import galin_ellipse, singular_cells, strip_cells
from hpcontact.discretizations.boundary_cells import SINGULAR_SUPPORTED, mask_cells, strip_applies
from hpcontact.discretizations.boundary_cells import STRATEGIES as CELL_STRATEGIES
from hpcontact.errors import InputError
from hpcontact.geometry import Shape, grid_for
from hpcontact.scene import Scene

Grids = list[tuple[int, int]]

N0 = 32  # cells along the long side on the first grid
#: Requests at least this loose start coverage-weighted cells at ``LOOSE_N0`` where that grid's
#: cell is no wider than the outline's smallest bend (:func:`coverage_n0`). From ``N0`` their
#: four grids overshoot such requests: over the main job's 396 tasks at 1e-3 every coverage
#: sequence stopped at its fourth grid (n = 256) with estimates of 1e-4 … 4e-4 (docs/performance.md
#: §"The first grid of loose requests"). Sequences from 16 are inside the estimator's calibration
#: (the module docstring's 336 records).
LOOSE_REQUEST = 1e-3
LOOSE_N0 = 16
MIN_ACROSS = 8  # never fewer cells across than 8 at n = N0 (thin shapes; 4 at n = 16, and so on)
MAX_CELLS = 2**22  # largest grid (nx · ny) the sequence may reach by default
#: The candidates for singular cells (``hpcontact.discretizations.singular_cells``): those led by order 1. Their
#: error is led by C/n with a constant that need not be steady (cut-cell quadrature); on the
#: sequences of :func:`singular_start` leads 1.5 and 2 extrapolated past the true value, leads
#: of 1 did not (docs/validation.md §"Calibration on singular cells").
SINGULAR_EXPANSIONS: tuple[tuple[float, ...], ...] = tuple(e for e in EXPANSIONS if not e or e[0] <= 1.0)
#: strategy "auto": singular cells when their square-cell sequence starts at most this many cells
#: along x (b/a ≥ 8/256 with ``MIN_ACROSS`` = 8 across); thinner ellipses would need ≥ 8 b/a-square
#: cells across on every grid (1e-3: 8000 × 8 cells first, tens of CPU seconds for that one
#: grid: docs/performance.md §"Cost and memory of `--accuracy`").
SINGULAR_MAX_N0 = 256
#: strategy "auto" takes singular cells only for requests below this: at 1e-3 and 1e-4
#: coverage-weighted cells meet the request sooner than singular cells' four grids; below 1e-4
#: coverage misses within n = 1024 where singular cells meet 1e-5 in seconds
#: (``benchmarks/accuracy_sharpness.py --cost`` and the replay of :data:`SINGULAR_EXPANSIONS`;
#: docs/performance.md §"Cost and memory of `--accuracy`").
SINGULAR_BELOW = 1e-4
#: Singular cells' grids stop at this many cells: the largest of their calibration
#: (``benchmarks/edge_order.py --singular-calibration``: every grid of :func:`singular_start`'s
#: sequences up to 2^20 cells — circle 1024², b/a 0.2 to 2048 × 512). Their error is a sum of
#: first-order terms of opposite sign (far field and sub-cell quadrature) that cancel to a few
#: 1e-7, not a steady expansion, and beyond these grids the estimate fell below the true error,
#: so the estimator is trusted only where it was checked (docs/validation.md §"Calibration on
#: singular cells").
SINGULAR_MAX_CELLS = 2**20
#: Coverage-weighted grids stop at this many cells along the long side (x): the finest grid of
#: their calibration (``benchmarks/accuracy_sharpness.py``, n ≤ 1024); one grid beyond, a thin
#: ellipse's estimate fell below its true error (``benchmarks/thin_grids.py``; docs/validation.md
#: §"Coverage-weighted grids beyond n = 1024"). Masks, refined by splitting their pixels, are not limited.
COVERAGE_MAX_N = 1024
#: The factor on the spread for singular cells' sequences (``SAFETY`` for coverage-weighted
#: cells). Their error levels off at a few 1e-7 without a steady sign, which no difference of
#: grids shows: over every grid up to ``SINGULAR_MAX_CELLS`` the factor 3 left records below
#: their true error, 5.5 is the least that is honest on all, and 6 leaves a margin
#: (docs/validation.md §"Calibration on singular cells").
SINGULAR_SAFETY = 6.0
#: Strip cells' grids (``hpcontact.discretizations.strip_cells``: n strips, one across) start at this many
#: strips and stop at ``STRIP_MAX_N``, the finest grid of their calibration
#: (``benchmarks/strip_calibration.py``); their estimate is that of coverage-weighted cells
#: (``EXPANSIONS``, ``SAFETY``) plus the model's own bound ``strip_cells.MODEL_ERROR`` · b/a.
STRIP_N0 = 32
STRIP_MAX_N = 1024
#: An ellipse's strips contain its exact traction whatever their number (``strip_cells``
#: docstring), so its sequence starts at ``STRIP_ELLIPSE_N0``; wider than
#: ``STRIP_WIDE_ASPECT`` nearly every point of its near pairs takes the exact two-width average
#: (``strip_cells.width_difference``), whose cost roughly doubles with each doubling of n, so
#: its sequence stops at ``STRIP_WIDE_MAX_N`` (docs/performance.md §"Cost and memory of `--accuracy`").
STRIP_ELLIPSE_N0 = 16
STRIP_WIDE_ASPECT = 1e-2
STRIP_WIDE_MAX_N = 256
#: Coverage-weighted cells on ellipses of b/a in ``COVERAGE_THIN_BAND`` (open interval): their
#: sequences from 32 × 8 look converged on five grids (up to 512 × 128) while the extrapolated
#: K is 2.5–4.7e-5 too high, up to 23× the estimate (the tips, of radius b²/a, are not resolved
#: there); ``benchmarks/thin_ellipse_bias.py`` measured b/a 0.2 … 1e-4, nu 0, 0.3, 0.5, requests
#: 1e-4 and 1e-5 against Mindlin: the excess of the true error over the estimate is ≤ 0 outside
#: the band and at most 3.3e-5 inside (flat from b/a 0.03 to 0.007); a cubic crystal (A = 3,
#: ψ = 60°) at b/a 0.01 showed the same 3.2–3.5e-5 against Galin's exact Re H solution
#: (tests/sweep/test_accuracy_sweep.py). ``COVERAGE_THIN_BIAS`` = 2.1× the worst excess is
#: added to every estimate there (:func:`model_error`), as strips add theirs.
COVERAGE_THIN_BAND = (0.002, 0.04)
COVERAGE_THIN_BIAS = 7e-5


def grid_sequence(
    shape: Shape, n0: int = N0, n_across0: int | None = None, max_cells: int = MAX_CELLS
) -> list[tuple[int, int]]:
    """Grids (n, n_across) = (n₀ rᵏ, n_across₀ rᵏ) with at most ``max_cells`` cells (k = 0, 1, …).

    The first grid has n₀ cells along x and, unless given, as many across as square cells
    allow but at least ``MIN_ACROSS`` · n₀/``N0`` (thin shapes: elongated cells whose aspect is
    the same whatever the start, and fixed along the sequence).
    """
    if shape.name == "mask":  # pixels split 2^k ways: n0 is the contact's long side in pixels
        pixels, _ = mask_cells(shape.mask_path)
        n0, n_across0 = max(pixels.shape), min(pixels.shape)
        X, Y = 1.0, 1.0
    else:
        X, Y = shape.half_extents()
    if n_across0 is None:
        n_across0 = max(int(round(MIN_ACROSS * n0 / N0)), int(round(n0 * Y / X)), 1)
    out = []
    n, na = int(n0), int(n_across0)
    while n * na <= max_cells:
        out.append((n, na))
        n, na = int(round(n * RATIO)), int(round(na * RATIO))
    return out


def singular_start(scene: Scene, n0: int, n_across0: int | None) -> tuple[int, int] | None:
    """First grid (n, n_across) of a sequence on singular cells (``hpcontact.discretizations.singular_cells``)
    with near-square cells, or None where they do not apply or would need more than
    ``SINGULAR_MAX_N0`` cells along x on the first grid.

    The first grid is ``grid_sequence``'s (n₀ along x, n_across₀ or as many across as square
    cells allow but at least ``MIN_ACROSS`` · n₀/``N0``). Singular cells need dy/dx within
    [1/2, 2] (``singular_cells.supports``): where that grid's cells are more elongated (b/a
    below 1/4 from n₀ = 32), the cells across stay and x takes as many as square cells need
    (b/a = 0.05: 160 × 8). The sequence then refines both by ``RATIO`` (fixed cell aspect).
    """
    shape = scene.shape
    if shape.name not in ("circle", "ellipse") or not set(scene.quantities) <= set(SINGULAR_SUPPORTED):
        return None
    aspect = shape.aspect if shape.name == "ellipse" else 1.0
    na = n_across0 if n_across0 is not None else max(int(round(MIN_ACROSS * n0 / N0)), int(round(n0 * aspect)), 1)
    n = int(n0)
    if not singular_cells.supports(shape, scene.material, grid_for(shape, n, na)):
        n = max(n, int(round(na / aspect)))  # as many along x as square cells need
    if n > SINGULAR_MAX_N0 or not singular_cells.supports(shape, scene.material, grid_for(shape, n, na)):
        return None
    return n, na


def strip_max_n(shape: Shape) -> int:
    """The finest strip grid of ``shape``'s calibration: ``STRIP_WIDE_MAX_N`` for ellipses wider
    than ``STRIP_WIDE_ASPECT``, else ``STRIP_MAX_N``."""
    return STRIP_WIDE_MAX_N if shape.name == "ellipse" and shape.aspect > STRIP_WIDE_ASPECT else STRIP_MAX_N


def strip_n0(shape: Shape) -> int:
    """The first strip grid: ``STRIP_ELLIPSE_N0`` for ellipses, ``STRIP_N0`` for rectangles."""
    return STRIP_ELLIPSE_N0 if shape.name == "ellipse" else STRIP_N0


def coverage_n0(shape: Shape, accuracy: float | None) -> int:
    """The first grid (cells along the long side) of coverage-weighted cells for a request of
    ``accuracy``: ``LOOSE_N0`` for requests ≥ ``LOOSE_REQUEST`` whose outline bends no tighter
    than that grid's cell (2X/``LOOSE_N0`` ≤ ``Shape.smallest_bend_radius``: straight-sided shapes,
    circles, ellipses of b/a ≥ 0.354), ``N0`` otherwise. A bend narrower than the first grid's cell
    leaves that grid outside the sequence's asymptotic range: a five-lobed star of ε = 0.3 (bend
    radius 0.055) from 16 stops on five grids with estimates 5.6–5.7e-4 where from 32 it stops on
    four with 2.0–2.9e-4, at 1.09–1.11× the CPU (``benchmarks/first_grid.py``)."""
    bend = shape.smallest_bend_radius()  # 0 for a mask, whose sequence splits its pixels instead
    if accuracy is None or accuracy < LOOSE_REQUEST or bend == 0.0:
        return N0
    X, _ = shape.half_extents()
    return LOOSE_N0 if 2.0 * X / LOOSE_N0 <= bend else N0


def _coverage_calibrated(shape: Shape) -> Callable[[int, int], bool]:
    """Coverage-weighted cells: up to ``COVERAGE_MAX_N`` along the long side, masks on any grid
    (no closed form to calibrate on)."""
    if shape.name == "mask":
        return lambda n, na: True
    return lambda n, na: max(n, na) <= COVERAGE_MAX_N


def _singular_calibrated(shape: Shape) -> Callable[[int, int], bool]:
    """Singular cells: up to ``SINGULAR_MAX_CELLS`` cells."""
    return lambda n, na: n * na <= SINGULAR_MAX_CELLS


def _strip_calibrated(shape: Shape) -> Callable[[int, int], bool]:
    """Strip cells: up to :func:`strip_max_n` strips."""
    finest = strip_max_n(shape)
    return lambda n, na: n <= finest


def _coverage_model_error(scene: Scene) -> float:
    """``COVERAGE_THIN_BIAS`` for coverage-weighted cells on ellipses (any turn) with b/a in
    ``COVERAGE_THIN_BAND``; 0 elsewhere."""
    low, high = COVERAGE_THIN_BAND
    if scene.shape.name == "ellipse" and low < scene.shape.aspect < high:
        return COVERAGE_THIN_BIAS
    return 0.0


def _square_grids(shape: Shape, n0: int, n_across0: int | None) -> Grids:
    """:func:`grid_sequence` from (n0, n_across0), unbounded (``plan_grids`` cuts it)."""
    return grid_sequence(shape, n0, n_across0, 2**62)


def _strip_grids(shape: Shape, n0: int, n_across0: int | None) -> Grids:
    """n₀ 2ᵏ strips, one across, unbounded (``plan_grids`` cuts it)."""
    return [(n0 * 2**k, 1) for k in range(62)]


def _coverage_range() -> str:
    return f"{COVERAGE_MAX_N} cells along the long side, accuracy.COVERAGE_MAX_N"


def _singular_range() -> str:
    return f"{SINGULAR_MAX_CELLS} cells, accuracy.SINGULAR_MAX_CELLS"


def _any_scene(scene: Scene) -> str | None:
    """No refusal before the solve (``covered_solve`` refuses what its cells cannot solve)."""
    return None


def _strip_refuses(scene: Scene) -> str | None:
    """Why strip cells do not apply to ``scene`` (``strip_applies``), or None where they do."""
    return None if strip_applies(scene) else strip_cells.SUPPORTED_TEXT


def _no_model_error(scene: Scene) -> float:
    return 0.0


@dataclasses.dataclass(frozen=True)
class Strategy:
    """One kind of boundary cells refined over a grid sequence (``covered_solve(scene, name)``).

    ``start(scene, n0, n_across0, accuracy)``: the first grid (n₀, n_across₀) from the ``n0``,
    ``n_across0`` asked for (None: the cells' default) and the request; ``calibrated(shape)``:
    whether the estimator was calibrated on a grid (n, n_across), ``calibration_range()`` that
    range in words; ``grid_bytes(scene, n, n_across)``: the peak bytes of one solve
    (``hpcontact.accuracy.memory``). The rest hold for square-celled grids unless a record says
    otherwise: ``refuses(scene)``: why the cells do not apply to ``scene`` (None: they may be
    tried; strategy ``auto`` takes the first of ``AUTO`` that does not refuse); ``grids(shape,
    n₀, n_across₀)``: the sequence from that grid, unbounded
    (:func:`hpcontact.accuracy.grid_plan.plan_grids` cuts it); ``model_error(scene)``: a relative
    bound on what the cells leave whatever the grids, added to every estimate; ``expansions``
    and ``safety``: the estimator's candidates and factor (None: ``extrapolation.EXPANSIONS`` and
    ``SAFETY``); ``strips``: whether a grid is n strips, one across (the sweep's cost model
    costs such a grid by its strip pairs, ``hpcontact.sweep.cost.task_cost.strip_units``, and
    predicts its count by the strips' own bound, ``hpcontact.sweep.cost.grids``)."""

    name: str
    start: Callable[[Scene, int | None, int | None, float | None], tuple[int, int | None]]
    calibrated: Callable[[Shape], Callable[[int, int], bool]]
    calibration_range: Callable[[], str]
    grid_bytes: Callable[[Scene, int, int], float]
    refuses: Callable[[Scene], str | None] = _any_scene
    grids: Callable[[Shape, int, int | None], Grids] = _square_grids
    model_error: Callable[[Scene], float] = _no_model_error
    expansions: tuple[tuple[float, ...], ...] | None = None
    safety: float | None = None
    strips: bool = False


STRATEGIES: Mapping[str, Strategy] = {
    "coverage": Strategy(
        name="coverage",
        start=lambda scene, n0, na0, accuracy: (n0 or coverage_n0(scene.shape, accuracy), na0),
        calibrated=_coverage_calibrated,
        calibration_range=_coverage_range,
        grid_bytes=memory.coverage_bytes,
        model_error=_coverage_model_error,
    ),
    "singular": Strategy(
        name="singular",
        start=lambda scene, n0, na0, accuracy: (n0 or N0, na0),
        calibrated=_singular_calibrated,
        calibration_range=_singular_range,
        grid_bytes=memory.singular_bytes,
        expansions=SINGULAR_EXPANSIONS,
        safety=SINGULAR_SAFETY,
    ),
    "strip": Strategy(
        name="strip",
        start=lambda scene, n0, na0, accuracy: (n0 or strip_n0(scene.shape), 1),
        # the words coverage-weighted cells' limit has always had in AccuracyNotMet's message
        calibration_range=_coverage_range,
        calibrated=_strip_calibrated,
        grid_bytes=memory.strip_bytes,
        refuses=_strip_refuses,
        grids=_strip_grids,
        model_error=lambda scene: strip_cells.model_error(scene.shape),
        strips=True,
    ),
}
#: The one exact cell of an elliptical contact (``hpcontact.discretizations.galin_ellipse``): no
#: grid sequence, :func:`hpcontact.accuracy.refinement.exact_solve`.
EXACT = "galin"
#: Strategy ``auto``: the exact cell where it applies, else the first of these that does not refuse.
AUTO = ("strip", "coverage")


def cells(strategy: str) -> Strategy:
    """The record of ``strategy``; an ``InputError`` naming the choices (as ``covered_solve``)
    for any other name."""
    if strategy not in STRATEGIES:
        raise InputError("strategy", f"one of {', '.join(CELL_STRATEGIES)}", strategy)
    return STRATEGIES[strategy]


def calibrated(strategy: str, shape: Shape) -> Callable[[int, int], bool]:
    """Whether the estimator of ``strategy``'s cells was calibrated on a grid (n, n_across):
    singular cells up to ``SINGULAR_MAX_CELLS`` cells, strip cells up to ``STRIP_MAX_N`` strips
    (:func:`strip_max_n`), coverage-weighted cells up to ``COVERAGE_MAX_N`` along the long side,
    masks on any grid (no closed form to calibrate on)."""
    return cells(strategy).calibrated(shape)


def model_error(scene: Scene, strategy: str) -> float:
    """A relative bound on what ``strategy``'s cells leave on ``scene`` whatever the grids of the
    sequence, added to every estimate: strips' profile bound (``strip_cells.model_error``), and
    ``COVERAGE_THIN_BIAS`` for coverage-weighted cells on ellipses (any turn) with b/a in
    ``COVERAGE_THIN_BAND``; 0 elsewhere."""
    return cells(strategy).model_error(scene)


def grid_bytes(scene: Scene, n: int, n_across: int, strategy: str = "coverage") -> float:
    """Peak bytes of the arrays of one solve of ``scene`` on an n × n_across grid with
    ``strategy``'s cells (``hpcontact.accuracy.memory``): coverage-weighted, the sweep's cost model
    (``hpcontact.problems.footprint.array_bytes``) plus ``COVERAGE_BYTES_PER_CELL`` per cell;
    singular, plus ``SINGULAR_BYTES_PER_NEAR_CELL`` per cell of the near set
    (``SINGULAR_NEAR_CELLS_PER_SIDE_CELL`` × (n + n_across) cells); strip (n strips),
    ``STRIP_BYTES_PER_PAIR`` n² + ``STRIP_BYTES_BASE``, a rectangle's with its far-pair batch
    instead (``STRIP_FAR_BYTES``, ``STRIP_RECTANGLE_BASE``)."""
    return cells(strategy).grid_bytes(scene, n, n_across)


def first_grid(
    scene: Scene,
    strategy: str = "auto",
    n0: int | None = None,
    n_across0: int | None = None,
    accuracy: float | None = None,
) -> tuple[str, int, int | None]:
    """The boundary cells :func:`solve_to_accuracy` uses for ``scene`` and the
    first grid of its sequence: (strategy, n₀, n_across₀), with ``strategy`` ``auto`` resolved:
    the one exact cell of an elliptical contact (``hpcontact.discretizations.galin_ellipse``:
    circles and ellipses, turned or not, any material, tangential and normal; ("galin", 1, 1),
    no grid sequence); strips for slender rectangles (:func:`strip_applies`) from
    :func:`strip_n0` strips, one across; coverage-weighted cells from ``n0`` (default
    :func:`coverage_n0` of the request ``accuracy``) otherwise. Singular cells are taken only
    when asked for (``strategy="singular"``): every contact they apply to is an ellipse. The
    request changes only coverage-weighted cells' first grid, never the choice of cells. The
    sweep's cost model plans the same grids (``hpcontact.sweep.work.tasks``)."""
    if strategy in ("auto", EXACT) and galin_ellipse.applies(scene):
        return EXACT, 1, 1
    if strategy == EXACT:
        raise InputError("strategy", "galin only for circles and ellipses, quantities tangential/normal", strategy)
    why = None
    for name in AUTO if strategy == "auto" else (strategy,):
        chosen = cells(name)
        why = chosen.refuses(scene)
        if why is None:
            return (name, *chosen.start(scene, n0, n_across0, accuracy))
    raise InputError("strategy", why, strategy)
