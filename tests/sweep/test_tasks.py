"""Tasks: distinct scenes, stable keys, cost order and kernel-sharing chunks."""

from __future__ import annotations

import pytest

from hpcontact.sweep.spec import parse_spec
from hpcontact.sweep.tasks import Task, enumerate_tasks, estimated_cost, make_chunks, task_key


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
