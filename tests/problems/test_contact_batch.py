"""Batched scenes (``problems.contact.solve_batch``, issue 41 item 2) against one scene at a time.

The batched path (``_run_solve_batch``: ``numerics.convolution.FourierProductStack``, one batched ``xp.fft`` per
application with each scene's spectra and preconditioner symbol, ``conjugate_gradient_batch``) is
compared with the single-scene path (pyFFTW's ``ConvolutionOperator``, pocketfft's preconditioner,
``conjugate_gradient``), on numpy and on array-api-strict, by the bound of
tests/numerics/device_agreement.py: both tractions solve P A P t = P b with true residuals ρ₁, ρ₂
(extended precision), so they differ by at most κ(A_mask)·(ρ₁ + ρ₂) relative (κ by SVD of the
operator on the mask), and each resultant by cell area·(√m·‖t₁ − t₂‖ + m·u·Σ|t|). At tol 1e-14 the
bound is ≤ 1e-12 (asserted too), the issue's agreement.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import array_api_strict as xps
import numpy as np
import pytest

from hpcontact.kernels.engine import Engine
from hpcontact.numerics.convolution import PLANNER_ENV
from hpcontact.plan import make_plan
from hpcontact.problems import contact
from hpcontact.problems.contact import _run_solve, _run_solve_batch, discretize, solve, solve_batch
from hpcontact.scene import Scene

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "numerics"))
from device_agreement import REQUIRED, U, dense, residual, scene_params  # noqa: E402

#: Scenes of one batch: circles on one grid (three materials, one unpreconditioned) batch together
#: by components; the crystal ellipse, the star and the mask are groups of their own.
BATCH = [
    {"shape": "circle", "n": 20, "nu": 0.3, "quantities": "tangential,normal"},
    {"shape": "circle", "n": 20, "nu": 0.45, "quantities": "tangential,normal"},
    {"shape": "circle", "n": 20, "nu": 0.1, "quantities": "tangential,normal"},
    {"shape": "circle", "n": 20, "nu": 0.3, "quantities": "normal", "precondition": False},
]
OTHERS = ["crystal_ellipse", "star", "mask"]


def batch_params(folder: Path) -> list[dict]:
    return [{**params, "tol": 1e-14} for params in BATCH] + [scene_params(name, folder) for name in OTHERS]


def agree(operator_apply, mask, solve_, grid, single, batched) -> None:
    """Tractions within κ(ρ₁ + ρ₂) ≤ REQUIRED relative; resultants within their bound."""
    (force, solution), (force_batched, solution_batched) = single, batched
    c = len(solve_.components)
    A, kappa, cells = dense(operator_apply, (c,) + mask.shape, mask)
    b = np.zeros((c,) + mask.shape)
    b[solve_.components.index(solve_.load)] = 1.0
    b = b.reshape(-1)[cells]
    x1, x2 = solution.traction.reshape(-1)[cells], solution_batched.traction.reshape(-1)[cells]
    bound = kappa * (residual(A, x1, b) + residual(A, x2, b))
    assert bound <= REQUIRED, (solve_.name, kappa)
    difference = np.linalg.norm(x1 - x2)
    assert difference <= bound * np.linalg.norm(x1), solve_.name
    m = len(cells)
    force_bound = grid.cell_area * (math.sqrt(m) * difference + m * U * np.sum(np.abs(x1)))
    assert np.all(np.abs(force - force_batched) <= force_bound), solve_.name


@pytest.mark.parametrize("xp", [np, xps], ids=["numpy", "array-api-strict"])
def test_batched_solves_are_the_one_at_a_time_solves(xp, tmp_path):
    single_jobs, batch_jobs = [], []
    for params in batch_params(tmp_path):
        scene = Scene.from_params(params)
        grid, mask = discretize(scene)
        plan = make_plan(scene, mask, grid)
        host, device = Engine(scene.material, grid, plan.kernels), Engine(scene.material, grid, plan.kernels, xp=xp)
        single_jobs += [(scene, host, mask, s) for s in plan.solves]
        batch_jobs += [(scene, device, mask, s) for s in plan.solves]
    batched = _run_solve_batch(batch_jobs)
    assert len(batched) == len(single_jobs)
    for (scene, host, mask, s), result in zip(single_jobs, batched):
        assert isinstance(result[1].traction, np.ndarray)  # copied back once, at the boundary
        assert result[1].residual <= scene.tol
        agree(host.operator(s.components, s.green).apply, mask, s, host.grid, _run_solve(scene, host, mask, s), result)


def test_solve_batch_records_are_solve_records_and_batched_by_grid(tmp_path, monkeypatch):
    """One record per scene, in order, ``solve``'s up to the bound; the circles' solves of one
    components are one CG batch each (tangential: 3 scenes; normal: the 3 preconditioned ones, the
    unpreconditioned one alone), the other scenes' solves batches of their own."""
    scenes = [Scene.from_params(params) for params in batch_params(tmp_path)]
    sizes = []
    batch_cg = contact.conjugate_gradient_batch

    def counting(apply, rhs, *args, **kwargs):
        sizes.append(rhs.shape[0])
        return batch_cg(apply, rhs, *args, **kwargs)

    monkeypatch.setattr(contact, "conjugate_gradient_batch", counting)
    records = solve_batch(scenes)
    monkeypatch.undo()
    assert sorted(sizes, reverse=True)[:2] == [3, 3]  # the circles' tangential and normal solves
    expected_solves = sum(len(make_plan(s, *reversed(discretize(s))).solves) for s in scenes)
    assert sum(sizes) == expected_solves and len(sizes) < expected_solves
    for scene, record in zip(scenes, records):
        reference = solve(scene)
        assert record.keys() == reference.keys() and record["plan"] == reference["plan"]
        assert (record["nx"], record["ny"], record["contact_cells"]) == (
            reference["nx"],
            reference["ny"],
            reference["contact_cells"],
        )
        stiffness = [key for key in reference if key.startswith("K_")]
        largest = max(abs(reference[key]) for key in stiffness)
        for key in stiffness:
            assert abs(record[key] - reference[key]) <= REQUIRED * largest, key
        # the stopping iteration moves only where a residual lies within rounding of tol
        assert abs(record["iterations"] - reference["iterations"]) <= len(reference["plan"]["solves"])
        assert record["residual"] <= scene.tol and record["wall_time_s"] > 0.0


def test_scenes_of_one_batch_stop_at_their_own_iterations():
    """One grid, one material, tolerances 1e-4 … 1e-14: one CG batch whose scenes stop at different
    iterations, each at the single-scene path's stiffness to its own tolerance's bound."""
    params = {"shape": "circle", "n": 20, "nu": 0.3, "quantities": "normal"}
    tolerances = [1e-4, 1e-14, 1e-8]
    scenes = [Scene.from_params({**params, "tol": tol}) for tol in tolerances]
    records = solve_batch(scenes)
    iterations = [record["iterations"] for record in records]
    assert len(set(iterations)) == len(tolerances)
    assert [iterations[k] for k in np.argsort(tolerances)[::-1]] == sorted(iterations)  # tighter: later
    grid, mask = discretize(scenes[0])
    A, kappa, cells = dense(Engine(scenes[0].material, grid, ("zz",)).operator("z").apply, (1,) + mask.shape, mask)
    for scene, record in zip(scenes, records):
        reference = solve(scene)
        assert record["residual"] <= scene.tol
        # both stop at ‖r‖ ≤ tol‖b‖: their tractions differ by ≤ 2κ·tol (+ round-off), their sum likewise
        assert abs(record["K_zz"] - reference["K_zz"]) <= (2 * kappa * scene.tol + REQUIRED) * reference["K_zz"]


def test_a_batch_of_one_is_solve(tmp_path):
    scene = Scene.from_params(scene_params("crystal_ellipse", tmp_path))
    (record,) = solve_batch([scene])
    reference = solve(scene)
    stiffness = [key for key in reference if key.startswith("K_")]
    largest = max(abs(reference[key]) for key in stiffness)
    assert record["plan"] == reference["plan"]
    for key in stiffness:
        assert abs(record[key] - reference[key]) <= REQUIRED * largest, key


def test_indentation_and_compliance_are_solved_as_one_at_a_time(monkeypatch):
    """What is not batched (Polonsky–Keer indentation, the compliance proxy) is solve's own
    arithmetic: the same numbers, under plans fixed for the process (FFTW_ESTIMATE: timed plans may
    differ between the two calls and round differently)."""
    monkeypatch.setenv(PLANNER_ENV, "FFTW_ESTIMATE")
    scenes = [
        Scene.from_params({"quantities": "indentation", "n": 24, "nu": 0.3, "radius": 1.0, "depth": 0.01}),
        Scene.from_params({"shape": "circle", "n": 16, "nu": 0.3, "quantities": "tangential,compliance"}),
    ]
    for scene, record in zip(scenes, solve_batch(scenes)):
        reference = solve(scene)
        compared = [key for key in ("load", "max_pressure", "proxy_K_xx", "proxy_K_yy") if key in reference]
        assert compared and all(record[key] == reference[key] for key in compared), compared


def test_a_batch_system_is_of_one_grid_and_components():
    jobs = []
    for n in (16, 20):
        scene = Scene.from_params({"shape": "circle", "n": n, "nu": 0.3, "quantities": "normal"})
        grid, mask = discretize(scene)
        plan = make_plan(scene, mask, grid)
        jobs.append((scene, Engine(scene.material, grid, plan.kernels), mask, plan.solves[0]))
    preconditioners = [contact._preconditioner_of(scene, engine, s) for scene, engine, _, s in jobs]
    with pytest.raises(ValueError, match="share device, components, grid shape"):
        contact.batch_system(jobs, preconditioners)
