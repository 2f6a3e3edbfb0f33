"""The cost model (``hpcontact.sweep.cost``) and ``hpcontact run --dry-run`` / ``--mem-per-rank``."""

from __future__ import annotations

import json
import math
import socket
from dataclasses import replace

import numpy as np
import pytest

from hpcontact import __version__
from hpcontact.problems import footprint
from hpcontact.problems.slip.crystal_pair import pair_from_params
from hpcontact.sweep.cost import calibration as calibration_module
from hpcontact.sweep.cost import calibration_file
from hpcontact.sweep.cost.engine import omega_nodes, timed_exact
from hpcontact.sweep.cost.grids import padded_cells
from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate, task_array_bytes
from hpcontact.sweep.cost.task_cost import estimated_cost
from hpcontact.sweep.driver import main
from hpcontact.sweep.work.estimate import estimate, grid_label, start_estimate
from hpcontact.sweep.work.replay import Overheads, replay
from hpcontact.sweep.work.tasks import Task

SPEC = """
[sweep]
title = "cost model test"
[scene]
quantities = ["tangential"]
[numerics]
n = 32
tol = 1e-6
[axes]
shape = ["circle", "ellipse"]
aspect = [1.0, 0.5]
nu = [0.0, 0.3]
"""
TASKS = 2 + 2 * 2  # the circle ignores the aspect


def test_task_estimate_is_rate_times_cost_plus_per_solve_and_memory_grows_with_the_grid():
    rates = {kind: Rate(rate_s=2e-6, solve_s=0.5) for kind in KINDS}
    calibration = Calibration("h", "v", rates, base_bytes=1000.0)
    params = {"shape": "circle", "n": 32, "quantities": ["tangential"], "tol": 1e-6}
    # S = 4 x 32 x 32 = 4096 padded cells, log2 S = 12; 2 solves x 6 digits x the grid's
    # iteration factor 12/18 (taskgrid.REFERENCE_LOG2_CELLS) = 8 solve units
    assert padded_cells(params) == 4096 and estimated_cost(params) == pytest.approx(4096 * 12 * 8, rel=1e-15)
    assert calibration.task_seconds(params) == pytest.approx(2e-6 * 4096 * 12 * 8 + 0.5 * 8, rel=1e-15)
    fixed, per_cell = footprint.MEMORY_MODEL["contact"]
    assert calibration.task_bytes(params) == 1000.0 + fixed + per_cell * 4096
    crystal = {**params, "anisotropy": 2.0}
    assert footprint.task_kind(crystal) == "crystal" and calibration.task_bytes(crystal) > calibration.task_bytes(
        params
    )


def test_the_fit_recovers_the_rates_of_two_scenes():
    small = {"shape": "circle", "n": 32, "quantities": ["tangential"], "tol": 1e-6}
    large = {**small, "n": 128, "tol": 1e-10}
    true = Rate(rate_s=3e-8, solve_s=0.02)
    seconds = [Calibration("h", "v", {"contact": true}, 0.0).task_seconds(p) for p in (small, large)]
    fitted = calibration_module.fit_rate([small, large], seconds)
    # a 2 x 2 solve of exact data: rounding only
    assert fitted.rate_s == pytest.approx(true.rate_s, rel=1e-9) and fitted.solve_s == pytest.approx(0.02, rel=1e-9)
    # time proportional to cost alone: the fit's solve term would be negative, so it is dropped
    assert (
        calibration_module.fit_rate([small, large], [1e-7 * estimated_cost(p) for p in (small, large)]).solve_s == 0.0
    )


def test_calibration_cache_round_trips_and_is_used_without_calibrating(tmp_path, monkeypatch):
    rates = {kind: Rate(rate_s=1e-7 * (i + 1), solve_s=0.25 * i) for i, kind in enumerate(KINDS)}
    saved = Calibration(socket.gethostname(), __version__, rates, base_bytes=123456789.0, seconds=9.5)
    path = calibration_file.save_calibration(saved, tmp_path / "cm.json")
    assert calibration_file.read_calibration(path) == saved
    monkeypatch.setattr(calibration_file, "calibrate", lambda: pytest.fail("the cache was not used"))
    assert calibration_file.load_calibration(path) == saved


@pytest.mark.parametrize(
    "content",
    [
        "{not json",
        '{"format": 1}',
        '{"format": 1, "host": "h", "version": "v", "base_bytes": 1.0, "rates": {"contact": {"solve_s": "NaN", '
        '"rate_s": 1e-7}, "crystal": {"solve_s": 0, "rate_s": 1e-7}, "slip": {"solve_s": 0, "rate_s": 1e-7}}}',
        "FOREIGN",
    ],
)
def test_a_corrupt_or_foreign_cache_is_ignored_with_a_warning_and_replaced(tmp_path, monkeypatch, content):
    """The cache of this node type (no file named): a corrupt one, or one of another CPU (a
    foreign host alone is no reason: nodes of one type share it), is recalibrated."""
    monkeypatch.delenv("HPCONTACT_COSTMODEL")
    monkeypatch.setenv("HPCONTACT_WISDOM", str(tmp_path / "fftw_wisdom"))
    path = calibration_file.calibration_path()
    fresh = Calibration(socket.gethostname(), __version__, {k: Rate(1e-7, 0.0) for k in KINDS}, 1.0)
    if content == "FOREIGN":
        foreign = Calibration("another-host", __version__, fresh.rates, 1.0, cpu="Another CPU")
        calibration_file.save_calibration(foreign, path)
    else:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(content)
    monkeypatch.setattr(calibration_file, "calibrate", lambda: fresh)
    with pytest.warns(RuntimeWarning, match="cost calibration .* ignored"):
        assert calibration_file.load_calibration() == fresh
    assert calibration_file.read_calibration(path) == fresh  # replaced


def test_dry_run_json_has_the_totals_and_one_entry_per_task(write_spec, capsys, monkeypatch):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    spec = write_spec(SPEC)
    assert main([str(spec), "--dry-run", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)  # one JSON object, nothing else on stdout
    assert out["tasks"] == TASKS and [t["index"] for t in out["tasks_list"]] == list(range(TASKS))
    listed = [t["estimated_seconds"] for t in out["tasks_list"]]
    assert listed == [1e-6 * t["cost"] for t in out["tasks_list"]]  # conftest's calibration: 1e-6 s per unit
    assert out["estimated_task_seconds"] == pytest.approx(sum(listed), rel=1e-12)
    assert out["estimated_peak_memory_bytes"] == max(t["estimated_peak_memory_bytes"] for t in out["tasks_list"])
    assert out["wall_time_s"]["1"] >= out["estimated_task_seconds"] > out["wall_time_s"]["64"]
    # grids: the circle and the b/a = 1 ellipse share 4 x 32 x 32 cells, b/a = 0.5 has 4 x 32 x 16; kernel
    # sets: a circle has no aspect field, so its 2 nu values are 2 sets beside the ellipse's 2 nu x 2 b/a
    assert sorted(out["grids"].values()) == [2, 4] and out["kernel_sets"] == 6
    assert not (spec.parent / "out.nc.journal").exists()


def test_a_task_over_the_memory_per_rank_is_warned_by_dry_run_and_refused_by_run(write_spec, capsys, monkeypatch):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    spec = write_spec(SPEC)
    assert main([str(spec), "--dry-run", "--mem-per-rank", "1M"]) == 0
    assert f"{TASKS} task(s) need more memory than 1 MiB per rank (--mem-per-rank)" in capsys.readouterr().err
    assert main([str(spec), "--mem-per-rank", "1M"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--mem-per-rank" in err and "1 MiB (--mem-per-rank)" in err
    assert not (spec.parent / "out.nc.journal").exists()  # refused before any work


SIMILAR_SLIP = {
    "quantities": "slip",
    "material": "Cu",
    "material2": "Cu",
    "radius": 8e-3,
    "radius2": 9e-3,
    "load": 10.0,
    "mu": 0.3,
    "q_ratio": 0.6,
    "steps": 5,
    "n": 32,
    "tol": 1e-8,
}


def test_slip_work_follows_the_load_path():
    similar = estimated_cost(SIMILAR_SLIP)
    # a step without tangential load costs the tangent tensor's 2 solves, not 8: (1 + 2·5)/(1 + 8·5)
    assert estimated_cost({**SIMILAR_SLIP, "q_ratio": 0.0}) == pytest.approx(similar * 11.0 / 41.0, rel=1e-12)
    assert estimated_cost({**SIMILAR_SLIP, "q_ratio": 0.0, "control": "displacement", "displacement": 1e-6}) == similar
    # a similar pair has no coupled path: normal friction changes nothing
    assert estimated_cost({**SIMILAR_SLIP, "normal_friction": True}) == similar
    # a dissimilar pair, coupled: passes converge at the rate of Dundurs' beta (8 digits), each
    # half a decoupled step; the normal load in `steps` coupled steps doubles the coupled work
    coupled = {**SIMILAR_SLIP, "material2": "Al", "coupling": "coupled"}
    passes = 0.5 * 8.0 / -math.log10(abs(pair_from_params(coupled).dundurs_beta))
    assert passes > 1.0
    assert estimated_cost(coupled) == pytest.approx(similar * (1.0 + 40.0 * passes) / 41.0, rel=1e-12)
    assert estimated_cost({**coupled, "normal_friction": True}) == pytest.approx(
        estimated_cost(coupled) * (1.0 + 40.0 * 2.0 * passes) / (1.0 + 40.0 * passes), rel=1e-12
    )
    # a stronger coupling (a Cu crystal under a rigid sphere, beta ~ 0.3) needs more passes
    crystal = {**SIMILAR_SLIP, "material": "crystal:Cu", "material2": "rigid", "coupling": "coupled"}
    assert estimated_cost(crystal) > estimated_cost(coupled)


ORTHOTROPIC = calibration_module.ANISOTROPIC_SLIP_SCENE["orthotropic"]


def test_the_barnett_lothe_term_counts_the_omega_nodes_of_each_anisotropic_body():
    assert omega_nodes(SIMILAR_SLIP) == 0
    crystal = {**SIMILAR_SLIP, "material": "crystal:Cu"}  # on polycrystalline Cu: a dissimilar pair
    one = omega_nodes({**crystal, "coupling": "coupled"})
    assert one > 0
    assert omega_nodes(crystal) == 2 * one  # coupling auto: the coupled and the decoupled path
    assert omega_nodes({**crystal, "material2": "crystal:Cu"}) == 2 * one  # similar: one path, two bodies
    # the adaptive ω rule needs more nodes for a more anisotropic body (E1/E2 = 800 against 25)
    stiffer = ORTHOTROPIC.replace("E1=25", "E1=800")
    scene = calibration_module.ANISOTROPIC_SLIP_SCENE
    assert omega_nodes({**scene, "orthotropic": stiffer}) > omega_nodes(scene)
    rates = {kind: Rate(rate_s=0.0, solve_s=0.0, node_s=1e-3) for kind in KINDS}
    calibration = Calibration("h", "v", rates, base_bytes=0.0)
    assert calibration.task_seconds(scene) == pytest.approx(1e-3 * omega_nodes(scene), rel=1e-15)
    # the term is the slip scenes': a crystal punch has its own calibration kind
    assert calibration.task_seconds({"shape": "circle", "anisotropy": 2.0, "n": 16}) == 0.0


def test_the_start_estimate_uses_the_cached_calibration_and_never_calibrates(tmp_path, monkeypatch):
    monkeypatch.setenv("HPCONTACT_COSTMODEL", str(tmp_path / "cm.json"))
    monkeypatch.setattr(calibration_file, "calibrate", lambda: pytest.fail("a run must not wait for a calibration"))
    tasks = [Task(key="a", params={"shape": "circle", "n": 32, "tol": 1e-6}, cost=4096 * 12 * 6.0, group="g")]
    line, seconds = start_estimate(tasks, 2)  # no calibration: the shipped prior scaled by a probe
    assert "(shipped prior of " in line and "(no calibration cached in" in line and seconds[0] > 0.0
    rates = {kind: Rate(rate_s=1e-6, solve_s=0.0) for kind in KINDS}
    calibration_file.save_calibration(Calibration(socket.gethostname(), __version__, rates, 1.0))
    # 1e-6 s per unit x 294 912 units = 0.2949 s of one task; on 2 ranks the makespan adds the
    # replayed overheads, so only the core-seconds are exact
    line, seconds = start_estimate(tasks, 2)
    assert "estimated 0.2949 core-seconds" in line and seconds.tolist() == [pytest.approx(0.294912, rel=1e-12)]


def test_the_task_term_is_the_same_for_every_contact_task():
    rates = {kind: Rate(rate_s=0.0, solve_s=0.0, task_s=0.01) for kind in KINDS}
    calibration = Calibration("h", "v", rates, base_bytes=0.0)
    small = {"shape": "circle", "n": 16, "quantities": ["tangential"], "tol": 1e-2}
    large = {"shape": "ellipse", "aspect": 0.1, "n": 512, "quantities": ["tangential", "normal"], "tol": 1e-10}
    assert calibration.task_seconds(small) == calibration.task_seconds(large) == 0.01


def test_the_kernel_term_is_per_padded_cell_whatever_the_tolerance():
    rates = {kind: Rate(rate_s=0.0, solve_s=0.0, cell_s=1e-7) for kind in KINDS}
    calibration = Calibration("h", "v", rates, base_bytes=0.0)
    circle = {"shape": "circle", "n": 64, "quantities": ["tangential"], "tol": 1e-10}
    # 4 x 64 x 64 padded cells, once per task: the kernel set is built before any iteration
    assert (
        calibration.task_seconds(circle)
        == calibration.task_seconds({**circle, "tol": 1e-2})
        == pytest.approx(1e-7 * 16384, rel=1e-15)
    )


# ------------------------------------------------------------------------------------------
# at scale: chunks cut once per rank count, estimates for all tasks at once, the same numbers
# ------------------------------------------------------------------------------------------
def chunks_task_by_task(tasks, ranks):
    """``make_chunks`` as a loop over the tasks (the model ``chunk_bounds`` must equal)."""
    import numpy as np

    cap = sum(t.cost for t in tasks) / (4 * ranks)
    ids = {}
    group = [ids.setdefault(t.group, len(ids)) for t in tasks]
    order = np.lexsort((-np.array([t.cost for t in tasks]), np.array(group)))
    chunks, costs, current, total, last = [], [], [], 0.0, -1
    for i in order.tolist():
        if current and (group[i] != last or total + tasks[i].cost > cap):
            chunks.append(tuple(current))
            costs.append(total)
            current, total = [], 0.0
        current.append(tasks[i])
        total += tasks[i].cost
        last = group[i]
    chunks.append(tuple(current))
    costs.append(total)
    return [chunks[i] for i in np.argsort(-np.array(costs), kind="stable").tolist()]


def replay_task_by_task(tasks, seconds, ranks, overheads):
    """``replay`` as an event loop over the chunks of ``chunks_task_by_task``, taken in claims."""
    import heapq
    import math
    import statistics

    chunks = chunks_task_by_task(list(tasks), ranks)
    per_task = overheads.driver_s + overheads.spread_gather_s
    work = [sum(seconds[t.key] + per_task for t in chunk) for chunk in chunks]
    n = len(tasks)
    setup = overheads.setup_s * n + overheads.spread_setup_s * n / ranks
    free = [(setup, r) for r in range(ranks)]
    heapq.heapify(free)
    server, wait, finish = setup, 0.0, [setup] * ranks
    # a worker's claims: k chunks from its mean wait and chunk seconds so far (replay.claim_size's rule)
    # claims, waited, chunks and busy seconds so far, and where its last claim ended (what it knows is left)
    history = {r: [0, 0.0, 0, 0.0, 0] for r in range(ranks)}
    at = taken = 0
    while at < len(work):
        taken += 1
        t, rank = heapq.heappop(free)
        claims, waited, chunks_done, busy, seen = history[rank]
        k = 1
        if rank == 0 or ranks == 1:
            start = t
        else:
            if claims and waited > 0 and busy > 0:
                wanted = math.ceil((waited / claims) / (0.02 * (busy / chunks_done)))
                k = int(max(1, min(wanted, (len(work) - seen) // (4 * ranks))))
            server = max(t, server) + overheads.service_s
            start = server + overheads.wake_s
            wait += start - t
            waited += start - t
            claims += 1
        end = start
        for w in work[at : at + k]:
            end += w
        chunks_done += len(work[at : at + k])
        at += k
        history[rank] = [claims, waited, chunks_done, busy + end - start, at]
        finish[rank] = end
        heapq.heappush(free, (finish[rank], rank))
    last = max(finish)
    makespan = last + overheads.gather_s * n
    total = float(sum(seconds[t.key] for t in tasks))
    return {
        "chunks": len(chunks),
        "claims_taken": taken,
        "makespan_s": makespan,
        "efficiency": total / (ranks * makespan),
        "tail": (last - statistics.fmean(finish)) / makespan,
        "claims": wait / (ranks * makespan),
        "setup_gather": (setup + overheads.gather_s * n) / makespan,
    }


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_chunks_and_replay_equal_the_task_by_task_model_to_the_last_bit(seed):
    import numpy as np

    from hpcontact.sweep.work.tasks import make_chunks

    rng = np.random.default_rng(seed)
    sizes = rng.choice([1, 1, 1, 2, 3, 7, 40], size=300)  # groups of one task and larger ones
    tasks = [
        Task(key=f"t{g}-{j}", params={}, cost=float(rng.lognormal(0.0, 1.5)), group=f"g{g}")
        for g, size in enumerate(sizes)
        for j in range(size)
    ]
    order = rng.permutation(len(tasks))
    tasks = [tasks[i] for i in order]  # groups interleaved
    seconds = {t.key: float(rng.uniform(0.1, 10.0)) for t in tasks}
    overheads = Overheads()
    for ranks in (1, 2, 3, 64, 1024):
        assert [[t.key for t in c] for c in make_chunks(tasks, ranks)] == [
            [t.key for t in c] for c in chunks_task_by_task(tasks, ranks)
        ]
        assert replay(tasks, seconds, ranks, overheads) == replay_task_by_task(tasks, seconds, ranks, overheads)


def test_estimate_equals_each_task_s_seconds_bytes_and_grid(write_spec):
    """``estimate`` (all tasks at once from their sizings) against ``task_seconds``,
    ``task_bytes`` and ``grid_label`` task by task: the same floats, labels and counts; tasks
    without a sizing (made elsewhere) get theirs from their parameters."""
    from hpcontact.sweep.space.parse import parse_spec
    from hpcontact.sweep.work.tasks import enumerate_tasks

    spec = parse_spec(
        '[scene]\nquantities = ["tangential", "normal"]\n[axes]\nshape = ["circle", "ellipse", "rectangle"]\n'
        "aspect = { logspace = [0, -3, 40] }\nanisotropy = [1.0, 2.0]\nn = [16, 32]\n",
        validate=lambda p: None,
    )
    tasks, _ = enumerate_tasks(spec)
    tasks += [t._replace(key=t.key + "-bare", sizing=None) for t in tasks[::7]]  # hand-made: no sizing
    extrapolated = parse_spec('[scene]\nshape = "ellipse"\n[axes]\naspect = [1.0, 0.1]\n', validate=lambda p: None)
    tasks += enumerate_tasks(extrapolated)[0]  # no n: costed over the default grids
    rates = {
        k: Rate(rate_s=1e-6 * (i + 1), solve_s=3e-3, node_s=0.0, cell_s=1e-8, task_s=2e-3) for i, k in enumerate(KINDS)
    }
    calibration = Calibration("here", __version__, rates, 50.0 * 2**20)
    est = estimate(tasks, calibration)
    assert est.seconds.tolist() == [calibration.task_seconds(t.params, t.cost) for t in tasks]
    assert est.bytes.tolist() == [calibration.task_bytes(t.params) for t in tasks]
    labels = {}
    for t in tasks:
        labels[grid_label(t.params)] = labels.get(grid_label(t.params), 0) + 1
    assert list(est.grids().items()) == list(labels.items())
    assert est.kernel_sets() == len({t.group for t in tasks})
    assert est.total_seconds == sum(calibration.task_seconds(t.params, t.cost) for t in tasks)


# ------------------------------------------------------------------------------------------
# tasks that ask for an accuracy (docs/performance.md §"Accuracy tasks")
# ------------------------------------------------------------------------------------------
ACCURACY_ISO = {"nu": 0.3, "quantities": ["tangential", "normal"], "tol": 1e-10}


def test_an_accuracy_task_takes_the_seconds_of_its_work_at_the_contact_rates_and_a_crystals_grids_at_its_own():
    from hpcontact.sweep.cost.task_cost import Work, sizing

    rates = {k: Rate(rate_s=1e-6 * (i + 1), solve_s=0.0) for i, k in enumerate(KINDS)}
    rates["contact"] = Rate(rate_s=2e-9, solve_s=3e-4, cell_s=1e-7, task_s=5e-3, strip_s=4e-9, exact_s=0.07)
    rates["crystal"] = Rate(rate_s=7e-9, solve_s=6e-4)
    calibration = Calibration("h", "v", rates, base_bytes=0.0)
    for scene, crystal in (
        ({"shape": "rectangle", "aspect": 0.3, "accuracy": 1e-4}, False),  # coverage-weighted cells
        ({"shape": "rectangle", "aspect": 0.3, "anisotropy": 3.0, "accuracy": 1e-4}, True),  # the crystal rates
        ({"shape": "rectangle", "aspect": 1e-8, "accuracy": 1e-3}, False),  # strips
        ({"shape": "polygon", "sides": 3, "accuracy": 1e-5}, False),  # an outline clipped into cells
        ({"shape": "polygon", "sides": 3, "anisotropy": 0.5, "accuracy": 1e-3}, True),  # clipped, a crystal
    ):
        params = {**ACCURACY_ISO, **scene}
        work = sizing(params).work
        assert isinstance(work, Work) and work.grids >= 4
        # a crystal's grids carry no isotropic FFT, solve or kernel-cell work, and it builds its kernel once
        assert (work.solves == work.cells == 0.0 < work.crystal_fft) if crystal else (work.crystal_fft == 0.0)
        assert work.kernel_builds == (1.0 if crystal else 0.0)
        seconds = (
            2e-9 * work.fft
            + 3e-4 * work.solves
            + 1e-7 * work.cells
            + 5e-3 * work.grids
            + 4e-9 * work.strips
            + 0.07 * work.kernel_builds
            + 7e-9 * work.crystal_fft
            + 6e-4 * work.crystal_solves
        )
        assert calibration.task_seconds(params) == pytest.approx(seconds, rel=1e-14)
        assert calibration.task_seconds(params, cost=1.0) == calibration.task_seconds(params)  # work, not cost
    strips = sizing({**ACCURACY_ISO, "shape": "rectangle", "aspect": 1e-8, "accuracy": 1e-3}).work
    assert strips.fft == strips.solves == strips.cells == 0.0 and strips.strips > 0.0
    # an ellipse's or circle's exact cell (galin), isotropic or crystal, at any request: the task
    # term alone, and a crystal's kernel build
    square = calibration.task_seconds({**ACCURACY_ISO, "shape": "rectangle", "aspect": 1.0, "accuracy": 1e-4})
    for scene, build in (({"shape": "ellipse", "aspect": 0.3}, 0.0), ({"shape": "circle", "anisotropy": 3.0}, 0.07)):
        for request in (1e-3, 1e-8):
            params = {**ACCURACY_ISO, **scene, "accuracy": request}
            assert calibration.task_seconds(params) == pytest.approx(5e-3 + build, rel=1e-15)
            assert calibration.task_seconds(params) < square / 10


def test_an_accuracy_tasks_memory_is_its_finest_grids_with_its_boundary_cells():
    from hpcontact.accuracy import grid_bytes
    from hpcontact.scene import Scene

    calibration = Calibration("h", "v", {k: Rate(1e-6, 0.0) for k in KINDS}, base_bytes=1000.0)
    for scene, strategy, finest in (
        ({"shape": "rectangle", "aspect": 1e-8, "accuracy": 1e-3}, "strip", (256, 1)),
        ({"shape": "rectangle", "aspect": 1e-8, "anisotropy": 2.0, "accuracy": 1e-3}, "coverage", (128, 32)),  # from 16
        ({"shape": "rectangle", "aspect": 0.3, "accuracy": 1e-4}, "coverage", (512, 160)),
        ({"shape": "rectangle", "aspect": 1.0, "accuracy": 1e-6}, "coverage", (1024, 1024)),
    ):
        params = {**ACCURACY_ISO, **scene}
        arrays = grid_bytes(Scene.from_params(params), *finest, strategy)
        assert task_array_bytes(params) == arrays
        assert calibration.task_bytes(params) == 1000.0 + arrays
    # the strips' dense matrices on 256 strips against the crystal's FFT arrays on 128 x 32 cells
    thin = {**ACCURACY_ISO, "shape": "rectangle", "aspect": 1e-8, "accuracy": 1e-3}
    strips, crystal = task_array_bytes(thin), task_array_bytes({**thin, "anisotropy": 2.0})
    assert strips == 160.0 * 256**2 + 1600.0 * 256 * 257 / 2 + 6.0 * 2**20 and crystal < strips
    # 1024 strips of a thin rectangle at 1e-8: the dense matrices grow as n^2, the far pairs'
    # batch stops at strip_cells.FAR_CHUNK pairs
    assert task_array_bytes({**thin, "accuracy": 1e-8}) == 160.0 * 1024**2 + 1600.0 * 2**16 + 6.0 * 2**20
    # an exact cell (galin): no grid, its kind's fixed bytes (a crystal's: its kernel tables)
    # whatever the request
    for scene, fixed in (
        ({"shape": "ellipse", "aspect": 0.3}, footprint.MEMORY_MODEL["contact"][0]),
        ({"shape": "circle", "anisotropy": 2.0}, footprint.CRYSTAL_TABLES_BYTES),
    ):
        for request in (1e-3, 1e-8):
            params = {**ACCURACY_ISO, **scene, "accuracy": request}
            assert task_array_bytes(params) == fixed == footprint.tables_bytes(params)
            assert calibration.task_bytes(params) == 1000.0 + fixed


def test_the_dry_run_estimates_accuracy_tasks_as_task_by_task_and_labels_their_grids(write_spec, capsys, monkeypatch):
    from hpcontact.sweep.space.parse import parse_spec
    from hpcontact.sweep.work.tasks import enumerate_tasks

    spec = parse_spec(
        '[scene]\nquantities = ["tangential", "normal"]\n[numerics]\naccuracy = 1e-4\n'
        '[axes]\nshape = ["circle", "ellipse", "rectangle"]\naspect = [1.0, 0.3, 1e-2, 1e-8]\nanisotropy = [1.0, 2.0]\n',
        validate=lambda p: None,
    )
    tasks, _ = enumerate_tasks(spec)
    rates = {
        k: Rate(rate_s=1e-6 * (i + 1), solve_s=3e-3, cell_s=1e-8, task_s=2e-3, strip_s=5e-9)
        for i, k in enumerate(KINDS)
    }
    calibration = Calibration("here", __version__, rates, 50.0 * 2**20)
    est = estimate(tasks, calibration)
    assert est.seconds.tolist() == [calibration.task_seconds(t.params, t.cost) for t in tasks]
    assert est.bytes.tolist() == [calibration.task_bytes(t.params) for t in tasks]
    grids = est.grids()
    assert grids["contact accuracy: strip cells to 256 strips"] == 1  # the rectangle b/a = 1e-8
    assert grids["crystal accuracy: coverage cells to 512 x 160"] == 1  # the crystal rectangle b/a = 0.3
    # the circle and the four ellipses of each material: one exact cell each
    assert grids["contact accuracy: one exact cell (galin)"] == grids["crystal accuracy: one exact cell (galin)"] == 5
    assert sum(grids.values()) == len(tasks)
    # an exact cell costs its task term, and a crystal's also the build of its kernel (exact_s)
    exact = replace(rates["contact"], exact_s=0.07)
    with_build = Calibration("here", __version__, {**rates, "contact": exact}, 50.0 * 2**20)
    for t in tasks:
        if grid_label(t.params).endswith("(galin)"):
            build = 0.07 if grid_label(t.params).startswith("crystal") else 0.0
            assert with_build.task_seconds(t.params) == pytest.approx(calibration.task_seconds(t.params) + build)
    labels = {}
    for t in tasks:
        labels[grid_label(t.params)] = labels.get(grid_label(t.params), 0) + 1
    assert labels == grids
    # the command line's request replaces the spec's grid: the same tasks, costed over their grids
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    path = write_spec(
        '[scene]\nquantities = ["tangential", "normal"]\n[numerics]\nn = 64\n'
        '[axes]\nshape = ["ellipse", "rectangle"]\naspect = [0.3, 1e-8]\n'
    )
    assert main([str(path), "--dry-run", "--json", "--accuracy", "1e-4"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert sorted(out["grids"]) == [
        "contact accuracy: coverage cells to 512 x 160",
        "contact accuracy: one exact cell (galin)",
        "contact accuracy: strip cells to 256 strips",
    ]


def test_a_kernel_group_builds_its_crystal_kernel_once_in_a_sweeps_estimate():
    """A crystal ellipse handed out after the rectangle of its material and b/a finds its kernel
    built (the main job: 1-20 ms against the ~60 ms build, benchmarks/cost_estimates.py --journals): the
    estimate counts the build for the first task of each kernel group in hand-out order only; a
    task estimated alone (``task_seconds``) counts it."""
    from hpcontact.sweep.space.parse import parse_spec
    from hpcontact.sweep.work.tasks import enumerate_tasks

    spec = parse_spec(
        '[scene]\nquantities = ["tangential", "normal"]\n[numerics]\naccuracy = 1e-3\n'
        '[axes]\nshape = ["ellipse", "rectangle"]\naspect = [1.0, 1e-2]\nanisotropy = [1.0, 2.0]\n'
        "orientation = [0.0, 20.0]\n",
        validate=lambda p: None,
    )
    tasks, _ = enumerate_tasks(spec)
    rates = {k: Rate(rate_s=1e-8, solve_s=1e-4) for k in KINDS}
    rates["contact"] = Rate(rate_s=2e-9, solve_s=1e-4, cell_s=1e-8, task_s=2e-3, exact_s=0.06)
    calibration = Calibration("here", __version__, rates, 50.0 * 2**20)
    seconds = estimate(tasks, calibration, ranks=(1,)).seconds
    alone = np.array([calibration.task_seconds(t.params, t.cost) for t in tasks])
    crystal = np.array([t.params.get("anisotropy", 1.0) != 1.0 for t in tasks])
    assert np.array_equal(seconds[~crystal], alone[~crystal])  # isotropic tasks build no kernel
    first = {}  # each kernel group's task handed out first: the largest cost, ties first appearance
    for t in tasks:
        if t.group not in first or t.cost > first[t.group].cost:
            first[t.group] = t
    first = {t.key for t in first.values()}
    for t, estimated, single in zip(tasks, seconds.tolist(), alone.tolist()):
        if t.params.get("anisotropy", 1.0) != 1.0:
            assert estimated == pytest.approx(single if t.key in first else single - 0.06, rel=1e-12)
            assert (t.key in first) == (t.params["shape"] == "rectangle")  # the ellipse follows its rectangle
    # a group of crystal ellipses alone (over tol): its first builds the kernel, the others reuse it
    lone = [
        Task(
            str(k),
            {"shape": "ellipse", "aspect": 0.3, "nu": 0.3, "anisotropy": 2.0, "accuracy": 1e-3, "tol": tol},
            0.0,
            "g",
        )
        for k, tol in enumerate((1e-8, 1e-10))
    ]
    assert estimate(lone, calibration, ranks=(1,)).seconds.tolist() == pytest.approx([2e-3 + 0.06, 2e-3], rel=1e-12)


def test_the_calibration_measures_strips_and_its_file_keeps_them(tmp_path, monkeypatch):
    from hpcontact.sweep.cost.task_cost import strip_units

    rates = {kind: Rate(rate_s=1e-7, solve_s=0.1) for kind in KINDS}
    rates["contact"] = Rate(rate_s=1e-7, solve_s=0.1, cell_s=1e-7, task_s=0.01, strip_s=3e-9)
    saved = Calibration(socket.gethostname(), __version__, rates, base_bytes=1.0)
    assert calibration_file.read_calibration(calibration_file.save_calibration(saved, tmp_path / "cm.json")) == saved
    # a file of the layout before strips (format 4) is not this layout: ignored, recalibrated
    old = json.loads((tmp_path / "cm.json").read_text())
    old["format"] = 4
    for entry in old["rates"].values():
        del entry["strip_s"]
    (tmp_path / "cm.json").write_text(json.dumps(old))
    assert calibration_file.cached_calibration(tmp_path / "cm.json")[0] is None
    # strip_s: the strip scene's seconds, less the task term, over its strip units
    monkeypatch.setattr(calibration_module, "_timed", lambda params, repeats=2, clock=None: 0.01)
    monkeypatch.setattr(calibration_module, "_timed_solve", lambda params, repeats=2, clock=None: (0.02, 10))
    monkeypatch.setattr(calibration_module, "timed_strips", lambda params, repeats=2, clock=None: 0.51)
    monkeypatch.setattr(calibration_module, "timed_exact", lambda params, repeats=2, clock=None: 0.08)
    monkeypatch.setattr(calibration_module, "omega_nodes", lambda params: 64)
    calibration = calibration_module.calibrate()
    contact = calibration.rates["contact"]
    assert contact.strip_s == pytest.approx(
        (0.51 - contact.task_s) / strip_units(calibration_module.STRIP_CALIBRATION_SCENE)
    )
    assert all(calibration.rates[k].strip_s == 0.0 for k in KINDS if k != "contact")
    assert contact.exact_s == 0.08 and all(calibration.rates[k].exact_s == 0.0 for k in KINDS if k != "contact")


def test_a_gpu_calibration_solves_every_scene_on_the_gpu_in_wall_seconds(monkeypatch):
    """``calibrate(device="gpu")``: every scene (the crystals', the strips' and the exact cell's
    included, and the slip scenes, which run on the device too) with device gpu and timed on the
    wall clock."""
    import time

    timed = []

    def record(seconds):
        def timer(params, repeats=2, clock=time.process_time):
            timed.append((params.get("device", "cpu"), params.get("quantities") == "slip", clock))
            return seconds

        return timer

    monkeypatch.setattr(calibration_module, "_timed", record(0.01))
    monkeypatch.setattr(calibration_module, "_timed_solve", lambda *a, **k: (record(0.02)(*a, **k), 10))
    monkeypatch.setattr(calibration_module, "timed_strips", record(0.5))
    monkeypatch.setattr(calibration_module, "timed_exact", record(0.08))
    monkeypatch.setattr(calibration_module, "omega_nodes", lambda params: 64)
    monkeypatch.setattr(calibration_module, "base_memory_bytes", lambda: 1.0)
    calibration_module.calibrate(device="gpu")
    assert len(timed) == 2 + 2 + 2 + 1 + 3 + 1 + 1 + 1  # crystal, indentation, slip; tiny, contact x 3; strips, exact
    for device, _, clock in timed:
        assert (device, clock) == ("gpu", time.perf_counter)
    assert sum(slip for _, slip, _ in timed) == 3


def test_the_exact_cell_calibration_times_the_kernel_build_not_a_cached_kernel():
    """``_timed_exact`` empties the kernel cache before each cold solve: a cached kernel would
    leave cold − warm at ~0 (the warm exact cell takes ~1 ms, its kernel's build 50–120 ms)."""
    from hpcontact.kernels.anisotropic import kernel_for
    from hpcontact.scene import Scene

    kernel_for(Scene.from_params(calibration_module.EXACT_CALIBRATION_SCENE).material)  # cached before: must not count
    assert timed_exact(calibration_module.EXACT_CALIBRATION_SCENE, repeats=1) > 0.01


def test_a_calibration_made_beside_other_processes_says_so(tmp_path, monkeypatch, capsys):
    """``calibrate`` samples the processes running beside it; from ``CONTENDED_FROM`` on, the
    dry run and the run's start line warn that the estimates are likely high (on a machine whose
    two vCPUs share a core one busy neighbour made the main job's estimate 3.3x higher). The
    count survives the file; a file without it (written before) reads as unknown: no warning."""
    samples = iter([1.0, 2.0, 1.0, 0.0])
    monkeypatch.setattr(calibration_module, "other_running", lambda: next(samples))
    monkeypatch.setattr(calibration_module, "_timed", lambda params, repeats=2, clock=None: 0.01)
    monkeypatch.setattr(calibration_module, "_timed_solve", lambda params, repeats=2, clock=None: (0.02, 10))
    monkeypatch.setattr(calibration_module, "timed_strips", lambda params, repeats=2, clock=None: 0.5)
    monkeypatch.setattr(calibration_module, "timed_exact", lambda params, repeats=2, clock=None: 0.08)
    monkeypatch.setattr(calibration_module, "omega_nodes", lambda params: 64)
    assert calibration_module.calibrate().others == 1.0  # the mean of its four samples
    rates = {kind: Rate(rate_s=1e-7, solve_s=0.1) for kind in KINDS}
    calibration = Calibration(socket.gethostname(), __version__, rates, base_bytes=1.0, others=1.0)
    assert "1.0 other process(es)" in calibration.contended()
    path = calibration_file.save_calibration(calibration, tmp_path / "cm.json")
    assert calibration_file.read_calibration(path).others == 1.0
    monkeypatch.setenv("HPCONTACT_COSTMODEL", str(path))
    assert "its seconds are likely high" in start_estimate([], 2)[0]
    record = json.loads(path.read_text())
    del record["others"]
    path.write_text(json.dumps(record))
    assert calibration_file.read_calibration(path).others is None
    assert calibration_file.read_calibration(path).contended() == "" and "high" not in start_estimate([], 2)[0]


def test_other_running_counts_a_busy_neighbour():
    """/proc/loadavg's running count, less this process: a spinning child shows (the largest of
    samples over up to 2 s, as the scheduler's view moves)."""
    import subprocess
    import sys
    import time

    if calibration_module.other_running() is None:
        pytest.skip("no /proc/loadavg")
    child = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        seen, until = 0.0, time.monotonic() + 2.0
        while time.monotonic() < until and seen < 1.0:
            seen = max(seen, calibration_module.other_running())
            time.sleep(0.02)
    finally:
        child.kill()
        child.wait()
    assert seen >= 1.0


def test_other_running_does_not_count_this_processs_own_threads():
    """A thread of this process that runs without the GIL (hashing, as rank 0's counter thread
    serves claims beside its announcement) is this process's work: ``_own_running_threads`` sees
    it (the largest of samples over up to 2 s) and ``other_running`` subtracts it."""
    import hashlib
    import threading
    import time

    if calibration_module.other_running() is None:
        pytest.skip("no /proc/loadavg")
    stop = threading.Event()
    data = b"x" * 2**24

    def busy() -> None:
        while not stop.is_set():
            hashlib.sha256(data).digest()  # releases the GIL

    thread = threading.Thread(target=busy)
    thread.start()
    try:
        seen, until = 0, time.monotonic() + 2.0
        while time.monotonic() < until and seen < 2:
            seen = max(seen, calibration_module._own_running_threads())
    finally:
        stop.set()
        thread.join()
    assert seen >= 2


def test_the_calibration_times_its_solves_under_the_sweeps_blas_limit(monkeypatch):
    """A sweep's tasks run under ``limited_blas`` (one BLAS thread by default); the calibration's
    solves must too: with OpenBLAS's threads free its CPU seconds were 2-3x a task's on the
    2-vCPU development machine (docs/performance.md §"The calibration under the sweep's BLAS
    limit"). The BLAS limit of the suite is lifted to two threads around the calibration."""
    from threadpoolctl import threadpool_info, threadpool_limits

    def blas_threads() -> int:
        return max((i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"), default=1)

    seen = []

    def timed(params, repeats=2, clock=None):
        seen.append(blas_threads())
        return 0.01

    monkeypatch.delenv("HPCONTACT_BLAS_THREADS", raising=False)
    monkeypatch.setattr(calibration_module, "_timed", timed)
    monkeypatch.setattr(calibration_module, "_timed_solve", lambda params, repeats=2, clock=None: (timed(params), 10))
    monkeypatch.setattr(calibration_module, "timed_strips", timed)
    monkeypatch.setattr(calibration_module, "timed_exact", timed)
    monkeypatch.setattr(calibration_module, "omega_nodes", lambda params: 64)
    with threadpool_limits(limits=2, user_api="blas"):  # the suite limits BLAS (tests/conftest.py): lift it
        if blas_threads() < 2:
            pytest.skip("no BLAS with threads to limit here")
        calibration_module.calibrate()
    assert seen and set(seen) == {1}
