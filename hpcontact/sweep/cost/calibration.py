"""Calibration of the cost model: ``Rate`` per kind of task measured by timing real solves on this machine.

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
only BLAS calls that a thread pool slows) less ``task_s``, over its ``cost.task_cost.strip_units``.
"""

from __future__ import annotations

import math
import socket
import statistics
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from hpcontact import __version__
from hpcontact.accuracy import task_function
from hpcontact.numerics.blas import limited_blas
from hpcontact.numerics.convolution import clear_cache
from hpcontact.problems.kinds import scene_kind
from hpcontact.sweep.cost.engine import omega_nodes, timed_exact, timed_strips
from hpcontact.sweep.cost.grids import padded_cells
from hpcontact.sweep.cost.rates import Calibration, Rate, base_memory_bytes, solve_units
from hpcontact.sweep.cost.task_cost import estimated_cost, strip_units

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
# slender rectangles): its seconds over its ``cost.task_cost.strip_units`` are the contact kind's
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
# development machine over A 0.5–3, ψ 0–55°, nu 0.05–0.45; its warm solve ~1 ms), and what any
# crystal task of an accuracy costs to build its material's kernel (``task_cost.Work.kernel_builds``:
# the same ``kernels.anisotropic.kernel_for``, which a crystal's grids read too).
EXACT_CALIBRATION_SCENE: dict[str, Any] = {
    "shape": "ellipse",
    "aspect": 0.5,
    "nu": 0.3,
    "anisotropy": 2.0,
    "orientation": 30.0,
    "quantities": _TANGENTIAL_NORMAL,
}


#: What a calibration times with, per device: CPU seconds of the process on the CPU (module
#: docstring), wall seconds on a GPU (the host thread waits for the device; its CPU seconds would
#: count its spinning or nothing, not the device's work).
CLOCKS: dict[str, Callable[[], float]] = {"cpu": time.process_time, "gpu": time.perf_counter}


def scene_clock(params: Mapping[str, Any]) -> Callable[[], float]:
    """The clock a calibration scene is timed with: its device's (``CLOCKS``)."""
    return CLOCKS[params.get("device", "cpu")]


def _timed(params: Mapping[str, Any], repeats: int = 2, clock: Callable[[], float] = time.process_time) -> float:
    """Seconds of a solve of ``params`` on ``clock`` (``_timed_solve``)."""
    return _timed_solve(params, repeats, clock)[0]


def _timed_solve(
    params: Mapping[str, Any], repeats: int = 2, clock: Callable[[], float] = time.process_time
) -> tuple[float, int]:
    """Seconds on ``clock`` (CPU seconds by default) of a solve of ``params`` with warm FFT plans
    (an untimed solve first) and a cold kernel cache: the time on a core of its own, whatever else
    shares the machine; the least of ``repeats`` timings (the others carry interference); and its
    CG iterations."""

    function = task_function(scene_kind(params))
    record = function(dict(params))
    best = math.inf
    for _ in range(repeats):
        clear_cache()
        started = clock()
        function(dict(params))
        best = min(best, clock() - started)
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
    clock = scene_clock(small)
    task_s = _timed(on_device(TINY_CONTACT_SCENE, small.get("device", "cpu")), clock=clock)
    t_small = max(0.0, _timed(small, clock=clock) - task_s)
    (t_large, it_large), (t_loose, it_loose) = (_timed_solve(p, clock=clock) for p in (large, loose))
    t_large, t_loose = max(0.0, t_large - task_s), max(0.0, t_loose - task_s)
    per_iteration = (t_large - t_loose) / max(1, it_large - it_loose)
    cell_s = max(0.0, t_loose - per_iteration * it_loose) / padded_cells(large)
    fitted = fit_rate(pair, [t - cell_s * padded_cells(p) for t, p in ((t_small, small), (t_large, large))])
    return Rate(fitted.rate_s, fitted.solve_s, 0.0, cell_s, task_s)


def other_running() -> float | None:
    """Processes running or runnable on this machine besides this one, now: the fourth field of
    /proc/loadavg (running threads) less this process's running threads (at least the caller's;
    rank 0's counter thread serving the other ranks' claims is its own work, not another
    process's); None where there is no /proc/loadavg."""
    try:
        running = int(Path("/proc/loadavg").read_text().split()[3].split("/")[0])
    except (OSError, ValueError, IndexError):
        return None
    return max(0.0, running - max(_own_running_threads(), 1))


def _own_running_threads() -> int:
    """This process's threads in state R (running or runnable), from /proc/self/task; 0 where
    it cannot be read."""
    count = 0
    try:
        tasks = list(Path("/proc/self/task").iterdir())
    except OSError:
        return 0
    for task in tasks:
        try:
            stat = (task / "stat").read_text()
        except OSError:  # a thread that ended meanwhile
            continue
        count += stat[stat.rfind(")") + 2 : stat.rfind(")") + 3] == "R"
    return count


def on_device(params: Mapping[str, Any], device: str) -> dict[str, Any]:
    """The calibration scene ``params`` with its solves on ``device`` (its ``device`` field, which
    contact and slip scenes both have)."""
    if device == "cpu":
        return dict(params)
    return {**params, "device": device}


def calibrate(
    scenes: Mapping[str, Sequence[Mapping[str, Any]]] = CALIBRATION_SCENES, device: str = "cpu"
) -> Calibration:
    """Measure ``Rate`` per kind on this machine (module docstring) and the base memory, every
    solve under the BLAS limit a sweep's tasks run under (``numerics.blas.limited_blas``:
    without it OpenBLAS's threads made the calibration's CPU seconds 2-3x those of the same
    solves in a task, and every estimate as high; docs/performance.md §"Sweep cost model").
    With ``device`` "gpu" every scene (contact and slip) is solved on this rank's GPU one at a
    time and timed in wall seconds (``CLOCKS``): the cost model of a GPU
    (``calibration_file.calibrate_gpu``)."""

    started = time.perf_counter()
    scenes = {kind: [on_device(p, device) for p in pair] for kind, pair in scenes.items()}
    contact_scenes = scenes.pop("contact")  # fitted with its kernels' builds (_fit_with_kernels)
    others = [other_running()]
    base = base_memory_bytes()
    with limited_blas():
        rates = {kind: fit_rate(pair, [_timed(p, clock=scene_clock(p)) for p in pair]) for kind, pair in scenes.items()}
        others.append(other_running())
        contact = _fit_with_kernels(contact_scenes)
        others.append(other_running())
        strip_scene = on_device(STRIP_CALIBRATION_SCENE, device)
        exact_scene = on_device(EXACT_CALIBRATION_SCENE, device)
        strips = max(0.0, timed_strips(strip_scene, clock=scene_clock(strip_scene)) - contact.task_s)
        exact = timed_exact(exact_scene, clock=scene_clock(exact_scene))
        rates["contact"] = replace(contact, strip_s=strips / strip_units(strip_scene), exact_s=exact)
        slip, scene = rates["slip"], on_device(ANISOTROPIC_SLIP_SCENE, device)
        cost = estimated_cost(scene)
        rest = _timed(scene, clock=scene_clock(scene)) - slip.rate_s * cost - slip.solve_s * solve_units(scene, cost)
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
