"""Tasks: distinct scenes, stable keys, cost order and kernel-sharing chunks."""

from __future__ import annotations

import gc
import sys
import weakref

import pytest

from hpcontact.sweep.cost.task_cost import estimated_cost
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import Task, enumerate_tasks, frozen_heap, make_chunks, paused_gc, task_key


def spec_of(text: str):
    return parse_spec(text, validate=lambda params: None)


def test_points_that_are_one_scene_share_a_task():
    spec = spec_of(
        """
        [axes]
        shape = ["circle", "ellipse"]
        aspect = [1, 0.1, 0.01]
        nu = [0.1, 0.5]
        angle = { linspace = [0, 180, 5] }
        """
    )
    tasks, where = enumerate_tasks(spec)
    assert len(where) == 2 * 3 * 2  # the angle costs nothing in tensor mode
    assert len(tasks) == 2 + 6
    assert where[(0, 0, 1)] == where[(0, 2, 1)]
    assert len({where[(1, i, 0)] for i in range(3)}) == 3
    assert {t.key for t in tasks} == set(where.values())


def test_keys_name_the_scene_and_are_stable():
    assert task_key({"nu": 0.3, "n": 16}) == task_key({"n": 16, "nu": 0.3})
    assert task_key({"nu": 0.3}) != task_key({"nu": 0.30000000000000004})
    spec = spec_of("[axes]\nnu = [0.1, 0.2]\ntol = [1e-6, 1e-8]\n")
    assert [t.key for t in enumerate_tasks(spec)[0]] == [t.key for t in enumerate_tasks(spec)[0]]


def test_rotated_mode_solves_every_angle():
    spec = spec_of('[sweep]\nangle_mode = "rotated"\n[scene]\nshape = "star"\n[axes]\nangle = [0, 45, 90]\n')
    tasks, where = enumerate_tasks(spec)
    assert len(tasks) == 3
    assert [t.params["shape_angle"] for t in tasks] == [0.0, -45.0, -90.0]


def test_cost_grows_with_grid_solves_and_digits():
    base = {"n": 64, "quantities": ["tangential"], "tol": 1e-8}
    assert estimated_cost({**base, "n": 128}) > 4 * estimated_cost(base)
    assert estimated_cost({**base, "quantities": ["tangential", "normal"]}) == pytest.approx(1.5 * estimated_cost(base))
    assert estimated_cost({**base, "tol": 1e-12}) > estimated_cost(base)
    thin = {**base, "shape": "rectangle", "aspect": 1e-8}
    assert estimated_cost(thin) < estimated_cost({**base, "shape": "rectangle", "aspect": 1.0})
    assert estimated_cost({**thin, "n_across": 64}) == pytest.approx(estimated_cost({**base, "shape": "rectangle"}))


def make(key: str, cost: float, group: str) -> Task:
    return Task(key=key, params={"k": key}, cost=cost, group=group)


def test_chunks_cover_every_task_once_largest_first():
    tasks = [make(str(i), float(1 + i % 7), str(i % 5)) for i in range(40)]
    chunks = make_chunks(tasks, ranks=2)
    assert sorted(t.key for c in chunks for t in c) == sorted(t.key for t in tasks)
    costs = [sum(t.cost for t in c) for c in chunks]
    assert costs == sorted(costs, reverse=True)
    cap = sum(t.cost for t in tasks) / 8
    assert all(len(c) == 1 or sum(t.cost for t in c) <= cap for c in chunks)
    assert all(len({t.group for t in c}) == 1 for c in chunks)


def test_tasks_sharing_a_kernel_go_together_when_cheap():
    spec = spec_of("[numerics]\nn = 32\n[axes]\nnu = [0.1, 0.2, 0.3, 0.4]\ntol = [1e-6, 1e-8, 1e-10]\n")
    tasks, _ = enumerate_tasks(spec)
    chunks = make_chunks(tasks, ranks=1)
    assert len(chunks) == 4  # one per nu: the tol variants build the same kernels
    assert all(len({t.params["nu"] for t in c}) == 1 and len(c) == 3 for c in chunks)
    assert make_chunks([], ranks=4) == []


def test_shapes_of_one_grid_share_a_group_and_materials_do_not():
    spec = spec_of(
        '[numerics]\nn = 32\n[axes]\nshape = ["ellipse", "rectangle"]\naspect = [0.1, 0.01]\nnu = [0.1, 0.5]\n'
    )
    tasks, _ = enumerate_tasks(spec)
    groups = {}
    for t in tasks:
        groups.setdefault(t.group, set()).add(t.params["shape"])
    assert len(groups) == 4 and all(shapes == {"ellipse", "rectangle"} for shapes in groups.values())


# ------------------------------------------------------------------------------------------
# runs: the tasks of a point-by-point enumeration, key for key
# ------------------------------------------------------------------------------------------
MIXED = [
    # shapes that keep, ignore and override b/a on a long b/a axis, nu; the angle free (tensor mode)
    '[numerics]\nn = 32\n[axes]\nshape = ["circle", "ellipse", "rectangle", { label = "tri", shape = "polygon", sides = 3 },'
    ' { label = "thin", shape = "rectangle", aspect = 0.01 }]\nnu = [0.0, 0.3]\naspect = { logspace = [0, -4, 1501] }\n'
    "angle = { linspace = [0, 180, 5] }\n",
    # A = 1 in a run (orientation dropped), a crystal's orientation (cost-neutral), no n (default grids)
    '[scene]\nshape = "ellipse"\naspect = 0.5\n[axes]\norientation = [0.0, 45.0]\nanisotropy = { linspace = [0.5, 1.5, 1201] }\n',
    "[numerics]\nn = 16\n[axes]\nanisotropy = [1.0, 2.0]\norientation = { linspace = [0, 90, 1300] }\n",
    # the rotated angle: a turned shape (and grid) per value; equal turned angles of two tables
    '[sweep]\nangle_mode = "rotated"\n[numerics]\nn = 16\n[axes]\nshape = [{ label = "a", shape = "rectangle", aspect = 0.3,'
    ' shape_angle = 10 }, { label = "b", shape = "rectangle", aspect = 0.3, shape_angle = 20 }]\n'
    "angle = { linspace = [0, 90, 901] }\n",
    # a field of the grid (n), a tolerance axis (kernel-neutral: one group), the shape last (point by point)
    '[scene]\nshape = "ellipse"\naspect = 0.2\n[axes]\nn = [16, 24, 32]\ntol = { logspace = [-6, -12, 700] }\n',
    '[numerics]\nn = 16\n[axes]\nnu = { linspace = [0, 0.5, 300] }\nshape = ["circle", "ellipse"]\n',
    # an accuracy: strips, coverage-weighted cells and crystals along b/a (the grids each is predicted to solve)
    '[scene]\nshape = "ellipse"\n[numerics]\naccuracy = 1e-3\n[axes]\nanisotropy = [1.0, 2.0]\n'
    "aspect = { logspace = [0, -4, 30] }\nnu = [0.1, 0.3]\n",
]


def point_by_point(spec):
    """The tasks and each point's task as the enumeration of every point computes them: the
    scene of each point (``Spec.scene_params``), distinct by canonical JSON, keyed, costed and
    grouped one by one."""
    from hpcontact import fields
    from hpcontact.scene import canonical_json

    neutral_fields = frozenset(fields.names(spec.kind, neutral_to="kernel"))
    rows, row_of, task_of = [], {}, []
    for index in spec.points():
        params = spec.scene_params(index)
        text = canonical_json(params)
        if text not in row_of:
            neutral = [k for k in params if k in neutral_fields]
            group = canonical_json({k: v for k, v in params.items() if k not in neutral_fields}) if neutral else text
            row_of[text] = len(rows)
            rows.append((task_key(params, text), params, estimated_cost(params), group))
        task_of.append(row_of[text])
    return rows, task_of


@pytest.mark.parametrize("text", MIXED)
def test_tasks_of_runs_are_those_of_the_points_one_by_one(text, monkeypatch):
    """Keys, parameters (key order too), costs, groups and each point's task: the same in the same
    order, whole, cut into runs at every 257th point (later runs find the scenes of earlier ones
    by value) and in three ranges joined; ``lean`` tasks read the same parameters."""
    from hpcontact.sweep.space.enumeration import scene_runs
    from hpcontact.sweep.work.tasks import RunScene, enumerate_part, join_parts, points

    spec = spec_of(text)
    rows, task_of = point_by_point(spec)
    n = points(spec)
    enumeration = sys.modules[scene_runs.__module__]  # where scene_runs counts its points
    monkeypatch.setattr(enumeration, "PROGRESS_POINTS", 257)
    calls = []
    for parts in (
        [enumerate_part(spec)],
        [enumerate_part(spec, progress=calls.append)],
        [enumerate_part(spec, n * r // 3, n * (r + 1) // 3, progress=lambda done: None) for r in range(3)],
        [enumerate_part(spec, progress=lambda done: None, lean=True)],
    ):
        tasks, where = join_parts(spec, parts)
        assert [(t.key, dict(t.params), t.cost, t.group) for t in tasks] == rows
        assert [list(t.params) for t in tasks] == [list(p) for _, p, _, _ in rows]
        assert where.reshape(-1).tolist() == task_of
        assert all(type(t.params) in (dict, RunScene) for t in tasks)
    assert calls == list(range(257, n, 257))  # every PROGRESS_POINTS points, while points are left


def test_a_run_of_new_scenes_keys_each_once_and_costs_its_grids_once(monkeypatch):
    from hpcontact.problems import footprint
    from hpcontact.sweep.work import tasks as tasks_module

    keys, costs = [], []
    key, cost = tasks_module.task_key, tasks_module.costed
    monkeypatch.setattr(tasks_module, "task_key", lambda p, text=None: keys.append(1) or key(p, text))
    monkeypatch.setattr(tasks_module, "costed", lambda p: costs.append(1) or cost(p))
    spec = spec_of('[scene]\nshape = "ellipse"\n[numerics]\nn = 32\n[axes]\naspect = { logspace = [0, -3, 5000] }\n')
    tasks, _ = enumerate_tasks(spec)
    grids = {footprint.contact_grid(t.params) for t in tasks}
    assert len(tasks) == len(keys) == 5000 and len(costs) == len(grids) < 40  # a cost per grid, not per scene
    spec = spec_of(
        '[scene]\nshape = "ellipse"\naspect = 0.5\n[numerics]\nn = 32\n[axes]\nnu = { linspace = [0, 0.5, 5000] }\n'
    )
    costs.clear()
    tasks, _ = enumerate_tasks(spec)
    assert len(costs) == 1 and len({t.sizing for t in tasks}) == 1  # nu changes neither grid nor cost


# ------------------------------------------------------------------------------------------
# tasks that ask for an accuracy: the grids solve_to_accuracy is predicted to solve
# ------------------------------------------------------------------------------------------
ISO = {"nu": 0.3, "quantities": ["tangential", "normal"], "tol": 1e-10}


def grids_of(params):
    from hpcontact.sweep.cost.grids import BOUNDARY_TAG, solved_grids

    levels = solved_grids(params)
    grids = [(level["n"], level["n_across"]) for level in levels if level[BOUNDARY_TAG] != "galin"]
    return {level[BOUNDARY_TAG] for level in levels}, grids


@pytest.mark.parametrize(
    ("scene", "accuracy", "boundary", "grids"),
    [
        # an ellipse or circle, any material, any request: one exact cell (galin), no grid
        ({"shape": "ellipse", "aspect": 0.3}, 1e-4, "galin", []),
        ({"shape": "circle"}, 1e-6, "galin", []),
        ({"shape": "ellipse", "aspect": 1e-6}, 1e-8, "galin", []),
        ({"shape": "ellipse", "aspect": 0.01, "anisotropy": 3.0, "shape_angle": 30.0}, 1e-4, "galin", []),
        # coverage-weighted cells: four grids at 1e-3 (from 16 where the outline allows:
        # accuracy.coverage_n0), one more per full decade below (docs/performance.md)
        ({"shape": "rectangle", "aspect": 0.3}, 1e-3, "coverage", [(16, 5), (32, 10), (64, 20), (128, 40)]),
        ({"shape": "star", "amplitude": 0.3}, 1e-3, "coverage", [(32 * 2**k, 31 * 2**k) for k in range(4)]),
        ({"shape": "rectangle", "aspect": 0.3}, 1e-4, "coverage", [(32 * 2**k, 10 * 2**k) for k in range(5)]),
        ({"shape": "polygon", "sides": 3}, 3e-4, "coverage", [(32 * 2**k, 28 * 2**k) for k in range(4)]),
        ({"shape": "polygon", "sides": 3}, 1e-5, "coverage", [(32 * 2**k, 28 * 2**k) for k in range(6)]),
        # ... never beyond the estimator's calibration (n = 1024 along x)
        ({"shape": "rectangle", "aspect": 0.01}, 1e-7, "coverage", [(32 * 2**k, 8 * 2**k) for k in range(6)]),
        ({"shape": "rectangle", "aspect": 1.0}, 1e-6, "coverage", [(32 * 2**k, 32 * 2**k) for k in range(6)]),
        # a crystal: coverage-weighted cells whatever its outline (but an ellipse's)
        (
            {"shape": "rectangle", "aspect": 1e-8, "anisotropy": 3.0},
            1e-4,
            "coverage",
            [(32 * 2**k, 8 * 2**k) for k in range(5)],
        ),
        # strips (slender rectangles, b/a <= 1e-6): four grids from 32 strips, one across
        ({"shape": "rectangle", "aspect": 1e-6}, 1e-3, "strip", [(32, 1), (64, 1), (128, 1), (256, 1)]),
        ({"shape": "rectangle", "aspect": 1e-8}, 1e-6, "strip", [(32, 1), (64, 1), (128, 1), (256, 1)]),
        # ... below 1e-7, every planned grid (up to 1024 strips), unless the strips' own bound stops them at four
        ({"shape": "rectangle", "aspect": 1e-8}, 1e-8, "strip", [(32 * 2**k, 1) for k in range(6)]),
        ({"shape": "rectangle", "aspect": 1e-6}, 1e-8, "strip", [(32, 1), (64, 1), (128, 1), (256, 1)]),
    ],
)
def test_an_accuracy_task_is_costed_over_the_grids_it_is_predicted_to_solve(scene, accuracy, boundary, grids):
    params = {**ISO, **scene, "accuracy": accuracy}
    assert grids_of(params) == ({boundary}, grids)


def test_an_accuracy_tasks_levels_are_one_grid_scenes_whose_tag_never_reaches_validation():
    from hpcontact.errors import InputError
    from hpcontact.scene import Scene
    from hpcontact.sweep.cost.grids import BOUNDARY_TAG, level_fields, solved_grids

    for scene, ns in (
        ({"shape": "rectangle", "aspect": 1e-8}, [32, 64, 128, 256]),  # strips
        ({"shape": "polygon", "sides": 3}, [32, 64, 128, 256, 512]),  # coverage-weighted cells
    ):
        params = {**ISO, **scene, "tol": 1e-4, "accuracy": 1e-4, "n": 64}  # n: ignored
        levels = solved_grids(params)
        assert [level["n"] for level in levels] == ns
        for level in levels:
            assert "accuracy" not in level and level["tol"] == 1e-4 * 1e-2  # solve_to_accuracy's: accuracy / 100
            assert solved_grids(level) == [level]  # a level is one grid
            with pytest.raises(InputError, match=BOUNDARY_TAG):
                Scene.from_params(level)  # a scene refuses the tag ...
            fields = level_fields(level)
            assert (
                BOUNDARY_TAG not in fields and Scene.from_params(fields).n == level["n"]
            )  # ... which level_fields drops
        assert BOUNDARY_TAG not in params
    # an exact cell: one level, the scene without its accuracy (its n unused), tagged galin
    params = {**ISO, "shape": "ellipse", "aspect": 0.3, "accuracy": 1e-4, "n": 64}
    (level,) = solved_grids(params)
    assert level == {**ISO, "shape": "ellipse", "aspect": 0.3, "n": 64, BOUNDARY_TAG: "galin"}
    assert Scene.from_params(level_fields(level)).n == 64


def test_the_grids_predicted_do_not_depend_on_this_processs_memory(monkeypatch):
    from hpcontact import accuracy
    from hpcontact.sweep.cost import grids

    params = {**ISO, "shape": "polygon", "sides": 3, "accuracy": 1e-5}
    planned = grids_of(params)
    grids._accuracy_plan.cache_clear()
    monkeypatch.setattr(accuracy, "resident_bytes", lambda: 1e18)  # plan_grids adds it to every grid's bytes
    assert grids_of(params) == planned and len(planned[1]) == 6
    grids._accuracy_plan.cache_clear()


def test_a_tighter_accuracy_costs_more():
    from hpcontact.sweep.cost.task_cost import Work, sizing

    for scene in ({"shape": "rectangle", "aspect": 0.3, "anisotropy": 3.0}, {"shape": "star", "sides": 5}):
        costs = [estimated_cost({**ISO, **scene, "accuracy": a}) for a in (1e-2, 1e-3, 1e-4, 1e-5)]
        assert costs[0] == costs[1] < costs[2] < costs[3]  # 4, 4, 5, 6 grids
        works = [sizing({**ISO, **scene, "accuracy": a}).work for a in (1e-3, 1e-4, 1e-5)]
        grown = [name for name in Work._fields if name != "kernel_builds"]  # a crystal builds its kernel once
        assert all(all(getattr(w, k) < getattr(v, k) for k in grown if getattr(v, k)) for w, v in zip(works, works[1:]))
        assert len({w.kernel_builds for w in works}) == 1
    # strips: four grids down to 1e-7, then every planned grid
    thin = {**ISO, "shape": "rectangle", "aspect": 1e-8}
    assert estimated_cost({**thin, "accuracy": 1e-3}) == estimated_cost({**thin, "accuracy": 1e-6})
    assert estimated_cost({**thin, "accuracy": 1e-8}) > estimated_cost({**thin, "accuracy": 1e-6})
    # an accuracy is costed over its grids, not as the default extrapolation (16 ... 256)
    square = {**ISO, "shape": "rectangle", "aspect": 1.0}
    assert estimated_cost({**square, "accuracy": 1e-6}) > 10 * estimated_cost(square)
    # ... except an exact cell's: one task term whatever the request, no FFT or strip work; a
    # crystal's also one build of its kernel
    for ellipse, build in (({"shape": "ellipse", "aspect": 0.3}, 0.0), ({"shape": "circle", "anisotropy": 3.0}, 1.0)):
        works = {sizing({**ISO, **ellipse, "accuracy": a}).work for a in (1e-2, 1e-4, 1e-6, 1e-8)}
        assert works == {Work(0.0, 0.0, 0.0, 1.0, 0.0, build)}
        assert (
            estimated_cost({**ISO, **ellipse, "accuracy": 1e-8}) == 0.0 < estimated_cost({**square, "accuracy": 1e-2})
        )


def test_strip_grids_are_costed_by_their_pairs_and_strips():
    from hpcontact.sweep.cost.engine import strip_pairs
    from hpcontact.sweep.cost.task_cost import (
        STRIP_SECONDS_PER_FAR_PAIR,
        STRIP_SECONDS_PER_STRIP,
        STRIP_UNIT_SECONDS,
        strip_units,
    )

    for aspect in (1e-6, 1e-8, 1e-12):
        near, far = strip_pairs("rectangle", aspect, 256)
        assert near + far == 256 * 257 // 2 and far > near
        units = [strip_units({"shape": "rectangle", "aspect": aspect, "n": n}) for n in (32, 64, 128, 256)]
        assert units == sorted(units) and units[0] > 0
        seconds = STRIP_SECONDS_PER_FAR_PAIR * far + STRIP_SECONDS_PER_STRIP * 256
        assert units[-1] == pytest.approx(seconds / STRIP_UNIT_SECONDS, rel=1e-14)
    # a rectangle's near pairs are a band along the diagonal
    assert strip_pairs("rectangle", 1e-8, 128)[0] < strip_pairs("rectangle", 1e-8, 128)[1]
    # an ellipse never takes strips in a sweep (its exact cell instead): its strips are not modelled
    with pytest.raises(ValueError, match="rectangles only"):
        strip_units({"shape": "ellipse", "aspect": 1e-3, "n": 64})


class Node:
    """A cyclic garbage's node (weakly referable)."""

    def __init__(self) -> None:
        self.me = self


def test_a_frozen_heap_hides_what_lives_on_entry_and_still_collects_what_is_made_inside():
    """``frozen_heap``: the objects alive on entry leave the collector's generations (frozen),
    a cycle made inside is collected, and on exit (also by an exception) nothing stays frozen;
    a heap the caller froze itself stays frozen."""
    assert gc.get_freeze_count() == 0
    alive = [[k] for k in range(1000)]  # 1001 tracked lists
    with pytest.raises(RuntimeError), frozen_heap():
        assert gc.get_freeze_count() >= len(alive) + 1
        made = Node()
        gone = weakref.ref(made)
        del made
        gc.collect()
        assert gone() is None
        raise RuntimeError("a round that fails")
    assert gc.get_freeze_count() == 0
    gc.freeze()
    try:
        later = [[k] for k in range(10)]  # made after the caller's freeze, alive on entry
        frozen = gc.get_freeze_count()
        with frozen_heap():
            assert gc.get_freeze_count() >= frozen + len(later) + 1
        assert gc.get_freeze_count() >= frozen + len(later) + 1
    finally:
        gc.unfreeze()


def test_a_paused_collector_hands_what_was_made_to_the_oldest_generation():
    """``paused_gc``: the collector is off inside; on exit what was made meanwhile is in the
    oldest generation, not the youngest (whose first collection would traverse it all), the
    generations' counts start again from 0, and a cycle made inside is collected by the next
    full collection; a heap the caller froze stays frozen, and nothing is moved then."""
    assert gc.isenabled() and gc.get_freeze_count() == 0
    with paused_gc():
        assert not gc.isenabled()
        made = [[k] for k in range(5000)]
        cycle = Node()
        gone = weakref.ref(cycle)
        del cycle
    assert gc.isenabled() and gc.get_freeze_count() == 0
    assert gc.get_count()[0] < 5000
    young = {id(o) for o in gc.get_objects(generation=0)}
    oldest = {id(o) for o in gc.get_objects(generation=2)}
    assert not any(id(o) in young for o in made)
    assert all(id(o) in oldest for o in made)
    gc.collect()
    assert gone() is None
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        with paused_gc():
            later = [[k] for k in range(10)]
        assert gc.isenabled() and gc.get_freeze_count() == frozen
        assert all(id(o) not in {id(f) for f in gc.get_objects(generation=2)} for o in later)
    finally:
        gc.unfreeze()
