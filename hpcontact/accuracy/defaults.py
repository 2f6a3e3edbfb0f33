"""The default discretization of a scene without ``n`` (extrapolated where it can be) and the
solver of each scene kind (:func:`task_function`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

from hpcontact import quantities as q
from hpcontact.accuracy.refinement import (
    LevelSolver,
    solve_levels_one_by_one,
    solve_to_accuracy,
    solve_to_accuracy_batch,
)
from hpcontact.accuracy.strategies import first_grid, grid_sequence
from hpcontact.discretizations import galin_ellipse
from hpcontact.discretizations.boundary_cells import SUPPORTED
from hpcontact.problems.contact import solve
from hpcontact.problems.kinds import CONTACT, SLIP
from hpcontact.problems.slip.partial_slip import solve_slip
from hpcontact.scene import Scene

#: Without ``n``: one scene (``hpcontact solve``, ``hpcontact.solve``) is solved as ``--accuracy
#: DEFAULT_ACCURACY`` (:func:`default_scene_solve`); a sweep whose spec gives none solves each
#: scene as that does where its cells are not coverage-weighted (:func:`requested_by_default`: an
#: elliptical contact's exact cell, a slender rectangle's strips), and coverage-weighted cells on
#: grids 16 … 256 along the long side (``DEFAULT_N0``, ``DEFAULT_GRIDS``), extrapolated, stopping
#: once the estimate is ≤ 1e-4 (:func:`default_solve`).
DEFAULT_ACCURACY = 1e-4
DEFAULT_N0 = 16
DEFAULT_GRIDS = 5


def extrapolates_by_default(scene: Scene) -> bool:
    """Whether ``scene`` without ``n`` gets the extrapolated default (:func:`default_solve`):
    a shape with a refinable outline (not rough, not a mask), any material (isotropic, a cubic
    crystal turned or not, a general Voigt stiffness), and quantities that coverage-weighted
    cells solve (tangential, normal, coupled). The estimator calibrated on isotropic ellipses is
    honest on crystals' grids too (docs/explanation/accuracy.md;
    ``tests/test_accuracy.py::test_default_discretization``: a turned crystal's lobeless star
    against Galin's exact cell of its circle); until 2026-11-30 a crystal's polygon, star or
    rectangle without ``n`` was one grid of n = 128 with no estimate."""
    if scene.grid_given:
        return False
    return scene.shape.name not in ("rough", "mask") and all(x in SUPPORTED for x in scene.quantities)


def requested_by_default(scene: Scene) -> bool:
    """Whether ``scene`` without ``n`` and without ``accuracy`` is solved in a sweep as one scene
    is without ``--n`` (``solve_to_accuracy`` at ``DEFAULT_ACCURACY``, strategy ``auto``): where the
    cells ``auto`` takes are not coverage-weighted, so that the request bounds itself — the one
    exact cell of an elliptical contact (``galin_ellipse.applies``: a circle or ellipse, turned or
    not, any material, quantities tangential or normal: estimates ~4e-14 in ~1 ms a scene where
    grids 16 … 256 took 0.3–0.5 s and estimated 7e-5–1.9e-4) and the strips of a slender
    isotropic rectangle (b/a = 1e-6: estimate 3.3e-7 where the grids estimated 3.6e-5, 0.26–0.49 s
    either way); 2026-11-30, 2-core Intel Xeon VM. Coverage-weighted cells keep the bounded grids of
    :func:`default_grids` (a request of 1e-4 takes them to n = 1024)."""
    if scene.accuracy is not None or scene.grid_given:
        return False
    if galin_ellipse.applies(scene):
        return True
    return extrapolates_by_default(scene) and first_grid(scene, "auto", accuracy=DEFAULT_ACCURACY)[0] != "coverage"


def default_grids(scene: Scene) -> list[tuple[int, int]]:
    """The grids (n, n_across) :func:`default_solve` solves ``scene`` on at most: grids 16, 32,
    … (``DEFAULT_N0``, ``DEFAULT_GRIDS`` of them, ``grid_sequence``'s cells across), or [] when
    ``scene`` gives ``n``, is solved as a request (:func:`requested_by_default`) or does not
    :func:`extrapolate by default <extrapolates_by_default>`.
    It stops earlier when the estimate is met on fewer (never before ``MIN_GRIDS``); the memory
    plan never cuts grids this small. The sweep's cost model sums its tasks' cost over these
    (``sweep.cost.grids.solved_grids``)."""
    if requested_by_default(scene) or not extrapolates_by_default(scene):
        return []
    return grid_sequence(scene.shape, DEFAULT_N0)[:DEFAULT_GRIDS]


def default_solve(scene: Scene) -> dict[str, Any]:
    """A sweep's scene with the default discretization (one scene from ``hpcontact solve`` or
    ``hpcontact.solve``: :func:`default_scene_solve`): ``hpcontact.problems.contact.solve`` when ``scene`` gives
    ``n`` (one grid, centre-in-cell, as always) or the scene is not one that
    :func:`extrapolates_by_default` (an elliptical contact aside); an elliptical contact's exact
    cell or a slender rectangle's strips as one scene's default (:func:`requested_by_default`:
    ``solve_to_accuracy`` at ``DEFAULT_ACCURACY``, strategy ``auto``, as ``hpcontact solve``
    without ``--n``); else ``solve_to_accuracy`` on grids 16, 32, … , 256
    (``DEFAULT_GRIDS``), stopping once the estimate is ≤ ``DEFAULT_ACCURACY`` = 1e-4, never an
    error: the record's ``estimated_error`` says what was reached (docs/howto/accuracy.md,
    "Without ``--n``: the default"; docs/performance.md, "A sweep's default extrapolation": 0.3–0.7 s
    CPU a task, measured when ellipses took these grids too).
    Its ``nx``, ``ny``, ``dx``, ``dy`` are the finest grid's, ``grids`` and ``grids_across`` list every grid.

    A scene with an ``accuracy`` field (a sweep's ``[numerics] accuracy``, ``hpcontact run
    --accuracy``) is solved as ``hpcontact solve --accuracy`` solves it: :func:`solve_to_accuracy`
    with strategy ``auto``, its ``n`` ignored, a request not met returned with ``accuracy_met``
    False and ``stopped_by`` the limit (not an error: the record's estimates say what was reached).

    A sweep's contact tasks run this too (:func:`task_function`): a spec
    without ``n`` gets the extrapolated default and its data set ``estimated_error``."""
    request = accuracy_request(scene)
    return solve(scene) if request is None else solve_to_accuracy(scene, **request)


def accuracy_request(scene: Scene) -> dict[str, Any] | None:
    """The keyword arguments of :func:`solve_to_accuracy` that :func:`default_solve` solves ``scene``
    with (``accuracy`` among them), or None where it solves one grid (``problems.contact.solve``)."""
    if scene.accuracy is not None or requested_by_default(scene):
        return {"accuracy": scene.accuracy or DEFAULT_ACCURACY, "strategy": "auto", "strict": False}
    if not extrapolates_by_default(scene):
        return None
    return {"accuracy": DEFAULT_ACCURACY, "n0": DEFAULT_N0, "max_grids": DEFAULT_GRIDS, "strict": False}


def default_solve_batch(scenes: Sequence[Scene], solve_levels: LevelSolver = solve_levels_one_by_one) -> list[Any]:
    """:func:`default_solve` of each of ``scenes``, every one a grid sequence (:func:`accuracy_request`
    not None), their levels refined together (:func:`solve_to_accuracy_batch`, levels solved by
    ``solve_levels``): in order, each scene's record or the ``Exception`` it raised."""
    requests = [accuracy_request(scene) for scene in scenes]
    if any(request is None for request in requests):
        raise ValueError("only scenes solved over a grid sequence batch here (an accuracy or the extrapolated default)")
    return solve_to_accuracy_batch(scenes, requests, solve_levels)


def default_scene_solve(scene: Scene) -> dict[str, Any]:
    """One scene without ``n`` and without ``accuracy`` (``hpcontact solve``, ``hpcontact.solve``):
    where the scene :func:`extrapolates_by_default`, exactly ``hpcontact solve --accuracy``
    with ``DEFAULT_ACCURACY`` = 1e-4 (:func:`solve_to_accuracy`, strategy ``auto``: the one exact
    cell of circles and ellipses, strips for slender rectangles, coverage-weighted grids from
    :func:`coverage_n0` until the estimate is met or a limit stops them), so the default takes the
    best cells for the shape. A request not met raises :class:`AccuracyNotMet` (its ``record``
    is the extrapolated record; ``hpcontact.api.solve_fields`` returns it with an
    ``errors.AccuracyWarning``). Other scenes: :func:`default_solve` (one grid).

    A sweep's task keeps :func:`default_solve`'s five fixed grids 16 … 256 on coverage-weighted
    cells (its cost model plans them, ``sweep.cost.grids.solved_grids``), not the
    unbounded grids of a request (a star to n = 1024 at 1e-4: 19.2 s and 0.93 GB peak, 2026-11-30,
    2-core Intel Xeon VM)."""
    if scene.accuracy is not None or not extrapolates_by_default(scene):
        return default_solve(scene)
    return solve_to_accuracy(scene, DEFAULT_ACCURACY, strategy="auto")


TaskFunction = Callable[[Mapping[str, Any]], Mapping[str, Any]]


def task_function(kind: str) -> TaskFunction:
    """The function that solves one scene of ``kind`` (``problems.kinds.Kind.name``): parameters →
    record (``SOLVERS``)."""
    return SOLVERS[kind]


def solve_contact_fields(fields: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`default_solve` of the contact scene of ``fields`` (a sweep's task, a journal's
    entry: the edge where fields become a ``Scene``), its per-quantity estimates as numbers
    (:func:`error_columns`), in N/m, m and m² where the scene gives its size ``a``
    (``Scene.in_si_units``)."""
    scene = Scene.from_params(fields)
    return error_columns(scene.in_si_units(default_solve(scene)))


def error_columns(record: Mapping[str, Any]) -> dict[str, Any]:
    """``record`` with its ``estimated_errors`` (a mapping per quantity) as one number per
    quantity, ``<quantity>_error`` (``quantities.ERROR_SUFFIX``): what a sweep's journals and data set store
    (docs/reference/dataset.md §"Error estimates"). A record without estimates (one grid) is
    returned as it is."""
    out = dict(record)
    errors = out.pop("estimated_errors", None)
    if not errors:
        return out
    out.update({f"{name}{q.ERROR_SUFFIX}": float(value) for name, value in errors.items()})
    return out


#: The solver of each scene kind (``problems.kinds.KINDS``), by ``Kind.name``: a slip scene
#: ``problems.slip.partial_slip.solve_slip``, a contact scene :func:`default_solve`
#: (:func:`solve_contact_fields`).
SOLVERS: Mapping[str, TaskFunction] = {CONTACT: solve_contact_fields, SLIP: solve_slip}
