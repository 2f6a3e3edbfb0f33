"""Peak bytes of one solve on one grid of each kind of boundary cells (the memory model of
``hpcontact.accuracy.strategies``; ``hpcontact.accuracy.grid_plan`` budgets a sequence by it)."""

from __future__ import annotations

from hpcontact.discretizations import strip_cells
from hpcontact.problems import footprint
from hpcontact.scene import Scene

#: Bytes per contact cell that a coverage-weighted solve adds to the engine's arrays (coverage,
#: damping and preconditioner weights; bounds the ``tracemalloc`` peaks: docs/performance.md
#: §"Cost and memory of `--accuracy`").
COVERAGE_BYTES_PER_CELL = 128.0
#: Singular cells' near set (``singular_cells``: cells within BAND + NEAR of a cut cell) per cell
#: along both sides, n + n_across: the boundary crosses ~2(n + n_across) cells, dilated by BAND
#: and NEAR on both sides (counted just below 8 on circles and ellipses b/a 0.7 … 0.05:
#: docs/performance.md §"Cost and memory of `--accuracy`").
SINGULAR_NEAR_CELLS_PER_SIDE_CELL = 8.0
#: Bytes per near-set cell that singular cells add to the coverage-weighted count (sub-cell
#: weights, the near-field pairs' gathers and sparse corrections): bounds the ``tracemalloc``
#: peaks of one solve less :func:`grid_bytes` (docs/performance.md §"Cost and memory of
#: `--accuracy`").
SINGULAR_BYTES_PER_NEAR_CELL = 9.0 * 1024
#: Bytes of one strip solve on n strips: ``STRIP_BYTES_PER_PAIR`` · n² (the pair indices, the
#: two integral matrices, the system and its Cholesky factor; an ellipse's near pairs, which
#: reach 100 b) + ``STRIP_BYTES_BASE`` (one batch of ``strip_cells.FAR_CHUNK`` far pairs or
#: width corrections' points, ``strip_cells.TWO_WIDTH_CHUNK`` rows of the two-width averages).
#: It bounds the ``tracemalloc`` peaks of ``covered_solve`` on rectangles and ellipses
#: (docs/performance.md §"Cost and memory of `--accuracy`").
STRIP_BYTES_PER_PAIR = 160.0
STRIP_BYTES_BASE = 128.0 * 2**20
#: A rectangle's strips (no two-width averages): ``STRIP_BYTES_PER_PAIR`` · n² +
#: ``STRIP_FAR_BYTES`` per far pair of one batch (min(n(n + 1)/2, ``strip_cells.FAR_CHUNK``) pairs:
#: the Gauss product rule's arrays) + ``STRIP_RECTANGLE_BASE``. It bounds the ``tracemalloc``
#: peaks of ``covered_solve`` on rectangles b/a 1e-6, 1e-8, 1e-12 at n = 32 … 1024: 3.7, 7.6,
#: 15.3, 53.2, 126.7, 157.7 MiB against 7.0, 9.8, 21.1, 66.2, 146, 266 (2026-11-26; the batch
#: dominates below ~360 strips, where ``STRIP_BYTES_BASE`` over-counted 2.4–35×;
#: docs/performance.md §"Cost and memory of `--accuracy`").
STRIP_FAR_BYTES = 1600.0
STRIP_RECTANGLE_BASE = 6.0 * 2**20


def coverage_bytes(scene: Scene, n: int, n_across: int) -> float:
    """Peak bytes of the arrays of one coverage-weighted solve of ``scene`` on an n × n_across
    grid: the sweep's cost model (``hpcontact.problems.footprint.array_bytes``) plus
    ``COVERAGE_BYTES_PER_CELL`` per cell."""
    return footprint.array_bytes(scene.fields(n=n, n_across=n_across)) + COVERAGE_BYTES_PER_CELL * n * n_across


def singular_bytes(scene: Scene, n: int, n_across: int) -> float:
    """Peak bytes of one solve on singular cells: :func:`coverage_bytes` plus
    ``SINGULAR_BYTES_PER_NEAR_CELL`` per cell of the near set (``SINGULAR_NEAR_CELLS_PER_SIDE_CELL``
    × (n + n_across) cells)."""
    near = SINGULAR_BYTES_PER_NEAR_CELL * SINGULAR_NEAR_CELLS_PER_SIDE_CELL * (n + n_across)
    return coverage_bytes(scene, n, n_across) + near


def strip_bytes(scene: Scene, n: int, n_across: int) -> float:
    """Peak bytes of one solve on n strips (``n_across`` is 1): ``STRIP_BYTES_PER_PAIR`` n² +
    ``STRIP_BYTES_BASE``, a rectangle's with its far-pair batch instead (``STRIP_FAR_BYTES``,
    ``STRIP_RECTANGLE_BASE``)."""
    if scene.shape.name == "rectangle":
        batch = min(n * (n + 1) // 2, strip_cells.FAR_CHUNK)
        return STRIP_BYTES_PER_PAIR * n * n + STRIP_FAR_BYTES * batch + STRIP_RECTANGLE_BASE
    return STRIP_BYTES_PER_PAIR * n * n + STRIP_BYTES_BASE
