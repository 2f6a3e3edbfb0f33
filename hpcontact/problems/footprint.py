"""The footprint of a one-grid solve, from its parameters alone (no rasterizing): the contact
grid, what its shape does to the CG iteration count, and the bytes of its arrays — the inputs
of the sweep's cost model and of the accuracy study's memory plan.

**Memory.** The arrays of one solve take fixed_k + per_cell_k × padded cells bytes
(``MEMORY_MODEL``; k = ``task_kind``), float64 array sizes fitted to ``tracemalloc`` peaks of
single solves with cold kernel caches (docs/performance.md §"Memory per task"). A crystal's
peak is the larger of two phases: the solve's arrays (that line) and the kernels' build
(``KERNEL_BUILD_BYTES``: the Barnett–Lothe table's construction, ~45 MiB, or the cell
quadrature's workspace: one chunk of ``kernels.anisotropic.CHUNK_BYTES`` = 32 MiB per thread,
the table's columns and the offsets' arrays), which is the larger below ~256 × 256 cells; each
thread beyond the first adds one chunk.

**Grid.** A contact scene is solved on ``geometry.grid_for(shape, n, n_across)``: n cells along
x and, unless ``n_across`` is given, max(min(n, 16), round(n Y/X)) across, with (X, Y) the
half-extents of the *turned* shape's bounding box (``Shape.half_extents``; a rectangle of
b/a = 0.2 turned by 90° gets 128 × 640 cells at n = 128, not 128 × 26). An indentation-only scene
is solved on n × n cells around the sphere's contact; a mask scene's grid is its image's: counted
at the pixels its file's header gives (``geometry.mask_pixels``, nothing decoded: a bound on the
grid cropped to the contact), or at n × n_across when that is larger (the accuracy study's
refined grids); at n × n when the file cannot be read.

**Iterations.** CG iterations per digit of tolerance grow with the grid's aspect in cells,
ρ = max(nx, ny) / min(nx, ny): a contact that is thin in *index* space, whether because the
shape is thin (b/a < 1 with square cells) or because its cells are (n_across fixed: a square on
512 × 32 cells), has its operator's spectrum spread over the long and the short direction at
once, and CG needs more iterations: iterations ≈ it(ρ = 1) × (1 + 0.3 log2 ρ)
(``ITERATIONS_PER_DOUBLING`` = 0.3, fitted to CG iteration counts within ±25 % for ρ = 1 … 16),
while the time per iteration stays ∝ S log S.

They grow with the grid as well, in proportion to log2 S (S = 4 nx ny the padded cells). The
factor is relative to ``REFERENCE_LOG2_CELLS`` = 18 (a square contact of 256 cells a side):

    iteration_factor = (1 + 0.3 log2 ρ) log2 S / 18.

The counts behind both fits and the command that reproduces them: docs/performance.md §"CG
iterations and grid aspect".
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping
from typing import Any

from hpcontact.errors import InputError
from hpcontact.geometry import Shape, grid_for, mask_pixels
from hpcontact.kernels.anisotropic import CHUNK_BYTES
from hpcontact.materials.elastic_constants import describes_crystal
from hpcontact.numerics.convolution import padded_shape
from hpcontact.numerics.memory import MIB
from hpcontact.plan import plan_for
from hpcontact.problems.kinds import KINDS, kind_of, quantity_names
from hpcontact.scene import DEFAULTS, Scene

ITERATIONS_PER_DOUBLING = 0.3  # relative growth of CG iterations per doubling of ρ (module docstring)
REFERENCE_LOG2_CELLS = 18.0  # log2 of the padded cells at which the grid's own factor is 1 (module docstring)
# CG iterations per solve and digit of tolerance at iteration factor 1 (fft_applications):
# between the 1.5 and 2.0 of two reference solves (docs/performance.md §"Iterations per digit").
ITERATIONS_PER_DIGIT = 1.8
# Memory per kind: (fixed bytes, bytes per padded cell), fitted as stated in the module docstring.
MEMORY_MODEL = {
    "contact": (1.0 * MIB, 182.0),
    "crystal": (12.0 * MIB, 300.0),
    "crystal_indentation": (45.0 * MIB, 60.0),
    "slip": (2.0 * MIB, 530.0),
}
#: The least a crystal solve peaks at on any grid (one thread): its kernels' build (module
#: docstring); ``array_bytes`` is at least this + (threads − 1) × ``CHUNK_BYTES``.
KERNEL_BUILD_BYTES = {"crystal": 55.0 * MIB, "crystal_indentation": 45.0 * MIB}
#: A crystal body's quadrature tables, a slip scene's fixed part (docs/performance.md §"Memory
#: per task").
CRYSTAL_TABLES_BYTES = 45.0 * MIB
#: The calibration groups (``task_kind``) whose solver builds a crystal body's tables in each
#: task (``Kind.builds_body_tables``: the slip scenes'): their cost counts the tables' ω nodes
#: and their memory ``CRYSTAL_TABLES_BYTES`` for a crystal body.
BODY_TABLE_GROUPS = frozenset(
    k.memory_group for k in KINDS.values() if k.builds_body_tables and k.memory_group is not None
)
#: A slip scene is solved on n × n cells around the Hertz contact (``Kind.grid_margin``), by
#: default n = ``SLIP_DEFAULT_N``.
SLIP_DEFAULT_N = 64


def task_kind(params: Mapping[str, Any]) -> str:
    """The calibration group: 'slip'; 'crystal' (a named material or A != 1), or
    'crystal_indentation' when a crystal scene asks for the indentation alone (one normal kernel
    by quadrature and a few solves: a far smaller share of solves in its cost, and slower per
    cost unit than the crystal punch's, docs/performance.md §"Crystal indentation"); else
    'contact'."""
    group = kind_of(params).memory_group
    if group is not None:
        return group
    if params.get("material") is None and float(params.get("anisotropy", 1.0)) == 1.0:
        return "contact"
    return "crystal_indentation" if quantity_names(params.get("quantities")) == ["indentation"] else "crystal"


def padded_cells(params: Mapping[str, Any]) -> float:
    """Cells of the padded FFT grid (twice the contact grid each way) of the one-grid scene
    ``params``: 4 nx × ny for a contact scene (``contact_grid``), (2 × 1.1 n)² for a slip scene."""
    margin = kind_of(params).grid_margin
    if margin is not None:  # n × n cells around the Hertz contact
        side = 2.0 * margin * int(params.get("n", SLIP_DEFAULT_N))
        return side * side
    nx, ny = contact_grid(params)
    return 4.0 * nx * ny


def array_bytes(params: Mapping[str, Any]) -> float:
    """The arrays of one solve of the one-grid scene ``params``: fixed_k + per_cell_k × padded cells (bytes), for a
    crystal at least its kernels' build (``KERNEL_BUILD_BYTES`` + one quadrature chunk per thread beyond the first);
    a slip scene with a crystal body has ``CRYSTAL_TABLES_BYTES`` as its fixed part."""
    kind = task_kind(params)
    fixed, per_cell = MEMORY_MODEL[kind]
    if kind in BODY_TABLE_GROUPS and describes_crystal(params):
        fixed = CRYSTAL_TABLES_BYTES
    arrays = fixed + per_cell * padded_cells(params)
    if kind in KERNEL_BUILD_BYTES:
        threads = int(params.get("threads") or 1)
        arrays = max(arrays, KERNEL_BUILD_BYTES[kind] + (threads - 1) * CHUNK_BYTES)
    return arrays


def tables_bytes(params: Mapping[str, Any]) -> float:
    """What a solve on no grid holds (an ellipse's one exact cell): a crystal's kernel tables
    (``CRYSTAL_TABLES_BYTES``), else the kind's fixed part."""
    kind = task_kind(params)
    return CRYSTAL_TABLES_BYTES if kind in KERNEL_BUILD_BYTES else MEMORY_MODEL[kind][0]


def contact_grid(params: Mapping[str, Any]) -> tuple[int, int]:
    """Cells (nx, ny) of the contact grid of the contact scene ``params`` (module docstring).
    Cached per grid-relevant fields: a sweep's cost model asks ~10 times per task."""
    get = params.get
    if get("shape") == "mask" and get("mask") is not None:  # the image's pixels, from its header
        pixels = _mask_cells(str(get("mask")))
        if pixels is not None:
            n = int(DEFAULTS["n"] if get("n") is None else get("n"))
            given = (n, int(get("n_across"))) if get("n_across") is not None else (0, 0)
            return pixels if pixels[0] * pixels[1] >= given[0] * given[1] else given
    quantities = get("quantities")
    return _contact_grid(
        (
            get("n"),
            get("n_across"),
            get("shape"),
            get("aspect"),
            get("sides"),
            get("shape_angle"),
            get("amplitude"),
            tuple(quantities) if isinstance(quantities, list) else quantities,
        )
    )


GRID_FIELDS = (
    "n",
    "n_across",
    "shape",
    "aspect",
    "sides",
    "shape_angle",
    "amplitude",
    "quantities",
)  # contact_grid's key


@functools.lru_cache(maxsize=4096)
def _contact_grid(values: tuple) -> tuple[int, int]:
    """``contact_grid`` of the fields ``GRID_FIELDS`` = ``values`` (None: the default)."""
    p = {**DEFAULTS, **{k: v for k, v in zip(GRID_FIELDS, values) if v is not None}}
    n = int(p["n"])
    if p["n_across"] is not None:
        return n, int(p["n_across"])
    if set(quantity_names(p["quantities"])) == {"indentation"} or p["shape"] == "mask":
        return n, n
    return _grid(
        str(p["shape"]), float(p["aspect"]), int(p["sides"]), float(p["shape_angle"]), float(p["amplitude"]), n
    )


@functools.lru_cache(maxsize=4096)
def _grid(name: str, aspect: float, sides: int, angle: float, amplitude: float, n: int) -> tuple[int, int]:
    """``geometry.grid_for``'s cell counts for a shape (cached: a star's extents sample 20 001
    points, and a sweep asks for the same few shapes many times)."""
    grid = grid_for(Shape(name=name, aspect=aspect, sides=sides, angle_deg=angle, amplitude=amplitude), n)
    return grid.nx, grid.ny


def _mask_cells(path: str) -> tuple[int, int] | None:
    """(nx, ny) of the mask file ``path`` from its header (``geometry.mask_pixels``), or None
    when it cannot be read (the scene's validation refuses it)."""
    try:
        return mask_pixels(path)
    except InputError:
        return None


def iteration_factor(params: Mapping[str, Any]) -> float:
    """CG iterations of the contact scene ``params`` relative to a square grid of 256 × 256 cells:
    (1 + 0.3 log2 ρ) × log2 S / 18, ρ = max(nx, ny) / min(nx, ny), S = 4 nx ny the padded cells
    (module docstring)."""
    nx, ny = contact_grid(params)
    aspect = 1.0 + ITERATIONS_PER_DOUBLING * math.log2(max(nx, ny) / min(nx, ny))
    return aspect * math.log2(4.0 * nx * ny) / REFERENCE_LOG2_CELLS


def fft_applications(scenes: Iterable[Mapping[str, Any]]) -> dict[tuple[int, tuple[int, int]], float]:
    """Operator applications expected per FFT layout (components c, padded shape) over
    ``scenes``: per isotropic contact scene with a grid (``n``), the solves of its plan
    (``hpcontact.plan.plan_for``, mirror symmetry not assumed) on their components ×
    ``ITERATIONS_PER_DIGIT`` × digits of tolerance × ``iteration_factor``. A sweep rank passes
    every R-th task of the sweep (its share, estimated at 1/R of the cost: ~10 µs per task).
    For ``hpcontact.numerics.convolution.expect_applications``: a hint to plan FFTW_MEASURE early; other
    scenes (crystals, slip, rough, masks, grids chosen per task) are not counted."""
    components: dict[tuple, list[int]] = {}  # per (quantities, nu): the components of each solve
    expected: dict[tuple[int, tuple[int, int]], float] = {}
    for params in scenes:
        p = {**DEFAULTS, **{k: v for k, v in params.items() if v is not None}}
        crystal = p.get("material") is not None or float(p.get("anisotropy", 1.0)) != 1.0
        if params.get("n") is None or crystal or not kind_of(params).planned or p["shape"] in ("rough", "mask"):
            continue
        key = (tuple(quantity_names(p["quantities"])), float(p["nu"]))
        if key not in components:
            plan = plan_for(Scene.from_params(params), mirror=False)  # the first scene of its (quantities, nu)
            components[key] = [len(solve.components) for solve in plan.solves]
        shape = padded_shape(*contact_grid(params))
        iterations = ITERATIONS_PER_DIGIT * max(1.0, -math.log10(float(p["tol"]))) * iteration_factor(params)
        for c in components[key]:
            expected[(c, shape)] = expected.get((c, shape), 0.0) + iterations
    return expected
