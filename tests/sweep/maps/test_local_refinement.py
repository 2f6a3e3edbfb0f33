"""Local refinement of adaptive maps (hpcontact.sweep.maps.refinement): leaves of a k-d tree in
index space, new nodes only where the estimate exceeds the tolerance (issue 40 item 4)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from test_adaptive import MINDLIN, mindlin

from hpcontact.analytic import mindlin_ellipse_stiffness
from hpcontact.numerics.interpolation import TensorInterpolant
from hpcontact.sweep.maps.checks import check_count
from hpcontact.sweep.maps.estimates import Checks, Layout
from hpcontact.sweep.maps.refinement import HALO, LEAF_NODES, Leaf, _cut, estimate, node_mask, refine
from hpcontact.sweep.maps.rounds import next_step
from hpcontact.sweep.maps.state import initial_state, state_tasks
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_part, join_parts

BUMP = """
[sweep]
title = "a map with one local feature"
progress_interval = 100.0
[scene]
shape = "circle"
quantities = ["tangential"]
nu = 0.25
[axes]
anisotropy = { linspace = [0.5, 1.5, 41] }
orientation = { linspace = [0, 90, 37] }
[adaptive]
tolerance = 1e-3
quantities = ["K_xx"]
"""
#: The feature: a Gaussian bump of K_xx at A = 1.3, ψ = 70° (widths 0.1 and 8°); elsewhere K_xx = 2
#: to round-off, a map that needs nodes around the bump alone.
CENTRE, WIDTH = (1.3, 70.0), (0.1, 8.0)


def bump(anisotropy, orientation):
    """K_xx = 2 + 0.2 exp(−Σ((x − c)/w)²) over (A, ψ)."""
    z = ((anisotropy - CENTRE[0]) / WIDTH[0]) ** 2 + ((orientation - CENTRE[1]) / WIDTH[1]) ** 2
    return 2.0 + 0.2 * np.exp(-z)


def bumped(params):
    """A stand-in scene with the bump in K_xx, exact (its solve error 1e-12)."""
    xx = float(bump(float(params["anisotropy"]), float(params.get("orientation", 0.0))))  # A = 1: no ψ
    record = {"K_xx": xx, "K_yy": 2.0, "K_xy": 0.0, "K_yx": 0.0, "K_max": max(xx, 2.0), "K_min": 2.0}
    record.update(K_a_over_K_b=xx / 2.0, K_min_over_K_max=2.0 / max(xx, 2.0), iterations=1)
    record.update({f"{name}_error": 1e-12 for name in list(record) if name.startswith("K_")})
    return record


def smallest_uniform_meeting(xs, exact, tolerance):
    """Nodes of the smallest sub-grid of every k-th index per axis (the last included) whose cubic
    tensor interpolant is within ``tolerance`` of ``exact`` at every grid point."""
    grids = {}
    for strides in np.ndindex(*(len(x) - 1 for x in xs)):
        nodes = [sorted(set(range(0, len(x), s + 1)) | {len(x) - 1}) for x, s in zip(xs, strides)]
        grids.setdefault(math.prod(len(n) for n in nodes), nodes)
    for count, nodes in sorted(grids.items()):
        values = TensorInterpolant(xs, nodes).values(exact[np.ix_(*nodes)])
        if np.max(np.abs(values / exact - 1.0)) <= tolerance:
            return count
    return exact.size


def test_a_local_feature_is_refined_where_it_is_and_the_rest_stays_coarse(sweep, write_spec):
    """Solves concentrate around the bump: the share of points solved near it (|A − 1.3| <= 0.25,
    |ψ − 70°| <= 20°) is at least 4 times that of the half far from it (ψ < 35°, 4.4 widths
    away), and the nodes are fewer than 0.6 times the smallest uniform sub-grid that meets the
    tolerance (a per-axis refinement adds whole lines of nodes through the far half); the map
    is within its tolerance of the known function with an honest map error."""
    ds = xr.open_dataset(sweep(write_spec(BUMP), bumped)).transpose("anisotropy", "orientation")
    a, psi = ds["anisotropy"].values, ds["orientation"].values
    exact = bump(a[:, None], psi[None, :])
    true = np.abs(ds["K_xx"].values / exact - 1.0)
    assert true.max() <= 1e-3
    assert np.mean(ds["K_xx_map_error"].values >= true) >= 0.95
    solved = ds["solved"].values.astype(bool)
    far = np.broadcast_to(psi[None, :] < 35.0, solved.shape)
    near = (np.abs(a[:, None] - CENTRE[0]) <= 0.25) & (np.abs(psi[None, :] - CENTRE[1]) <= 20.0)
    assert solved[near].mean() >= 4.0 * solved[far].mean(), (solved[near].mean(), solved[far].mean())
    nodes = ds.attrs["sweep_solves"] - ds.attrs["adaptive_check_points"]
    uniform = smallest_uniform_meeting([a, psi], exact, 1e-3)
    assert nodes < 0.6 * uniform, (nodes, uniform)


def test_each_rounds_decision_depends_on_its_nodes_alone_so_resume_rebuilds_it():
    """A resumed sweep's rank 0 sees every journaled point, also those of rounds not decided yet;
    the state it rebuilds round by round must be the one the uninterrupted run took. Each
    decision (``next_step``) is the same from the values at the state's points alone as from
    the values at every grid point."""
    spec = parse_spec(BUMP, check_scenes=False)
    layout = Layout.of(spec)
    tasks, task_of = join_parts(spec, [enumerate_part(spec)])
    a, psi = np.meshgrid(np.asarray(spec.task_axes[0].values), np.asarray(spec.task_axes[1].values), indexing="ij")
    records = [bumped(task.params) for task in tasks]
    every = {n: np.array([r[n] for r in records])[task_of] for n in records[0] if n.startswith("K_")}
    stored = [n for n in every if not n.endswith("_error")]
    state, checks, decisions = initial_state(layout, spec.adaptive), Checks(), 0
    while True:
        solved = np.isin(task_of, state_tasks(layout, state, task_of, checks))
        seen = {n: np.where(solved, v, np.nan) for n, v in every.items()}
        step = next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], stored, task_of)
        assert step == next_step(layout, spec.adaptive, state, checks, every, ["K_xx"], stored, task_of)
        decisions += 1
        if not isinstance(step, tuple):
            break
        state, checks = step
    assert decisions >= 4 and sum(len(leaves) for _, leaves in state) > 1  # it refined, and cut leaves


def test_a_cut_leaves_two_boxes_sharing_a_face_with_a_halo_and_adds_no_node():
    """A leaf with 2 LEAF_NODES − 1 = 13 nodes along an axis is cut at the middle one: each half
    keeps LEAF_NODES = 7 inside its box and HALO = 2 beyond the face (the quintic's centred
    stencil at the face's intervals), and no node is added; with 12 it is left as it is."""
    assert (LEAF_NODES, HALO) == (7, 2)
    nodes = tuple(range(0, 25, 2))  # 13 nodes along the first axis
    leaf = Leaf((nodes, (0, 5, 10)), ((0, 24), (0, 10)))
    halves = _cut(leaf)
    assert [h.box for h in halves] == [((0, 12), (0, 10)), ((12, 24), (0, 10))]
    assert halves[0].nodes[0] == (0, 2, 4, 6, 8, 10, 12, 14, 16)  # two nodes past the face
    assert halves[1].nodes[0] == (8, 10, 12, 14, 16, 18, 20, 22, 24)
    assert {i for h in halves for i in h.nodes[0]} == set(nodes)  # no new node
    fewer = Leaf((tuple(range(0, 23, 2)), (0, 5, 10)), ((0, 22), (0, 10)))
    assert _cut(fewer) == [fewer]  # fewer than 2 LEAF_NODES - 1 along every axis: left as it is


SMOOTH = MINDLIN.replace("[0, -4, 41]", "[0, -3, 25]").replace("angle = { linspace = [0, 180, 7] }\n", "")


def smooth_map(sweep, write_spec) -> tuple[xr.Dataset, dict[str, np.ndarray]]:
    """Issue 40's smooth 2-D map: Mindlin's ellipse (the closed-form stand-in of test_adaptive.py,
    solve error 1e-4) over b/a logspace(0, −3, 25) × nu (21), 525 points at tolerance 1e-3, swept
    adaptively; and Mindlin's closed form of K_xx, K_yy and K_a/K_b at its points."""
    ds = xr.open_dataset(sweep(write_spec(SMOOTH), mindlin)).transpose("aspect", "nu")
    ka, kb = mindlin_ellipse_stiffness(1.0, ds["aspect"].values[:, None], 1.0, ds["nu"].values[None, :])
    return ds, {"K_xx": ka, "K_yy": kb, "K_a_over_K_b": ka / kb}


def smallest_uniform_nodes(xs: list[np.ndarray], exact: dict[str, np.ndarray], tolerance: float) -> int:
    """The nodes of the smallest uniform sub-grid (every k_d-th index per axis, the last one
    included) whose cubic tensor interpolant of the closed form (over the map's coordinates
    ``xs``: ``Layout.xs``, log10 along a logspace axis) is within ``tolerance`` of it at every
    point, found by trying every pair of strides."""
    best = math.prod(len(x) for x in xs)
    for strides in np.ndindex(*(len(x) - 1 for x in xs)):
        nodes = [sorted(set(range(0, len(x), k + 1)) | {len(x) - 1}) for x, k in zip(xs, strides)]
        count = math.prod(len(n) for n in nodes)
        if count >= best:
            continue
        interpolant = TensorInterpolant(xs, nodes)
        at = np.ix_(*nodes)
        if all(np.max(np.abs(interpolant.values(f[at]) / f - 1.0)) <= tolerance for f in exact.values()):
            best = count
    return best


def test_a_smooth_map_is_filled_from_few_nodes_within_its_tolerance(sweep, write_spec):
    """The smooth 2-D map (``smooth_map``): every point within 1e-3 of the closed form, the map
    error at least the true error at ≥ 95 % of them, the check round's ``check_count`` random
    points on top, and the refinement's nodes at most 1.5 × those of the smallest uniform
    sub-grid that meets 1e-3 by the closed form (issue 40 item 4's bar for local refinement;
    65 nodes here, found by the test). Issue 40's own bar for this map, nodes and checks ≤ 15 %
    of the points: ``test_a_smooth_map_needs_at_most_15_percent_of_its_points``."""
    ds, exact = smooth_map(sweep, write_spec)
    for name, f in exact.items():
        true = np.abs(ds[name].values / f - 1.0)
        assert true.max() <= 1e-3, name
        assert np.mean(ds[f"{name}_map_error"].values >= true) >= 0.95, name
    points, checks = ds["solved"].size, ds.attrs["adaptive_check_points"]
    nodes = ds.attrs["sweep_solves"] - checks
    uniform = smallest_uniform_nodes(list(Layout.of(parse_spec(SMOOTH, check_scenes=False)).xs), exact, 1e-3)
    assert points == 525 and nodes <= 1.5 * uniform, (nodes, uniform)
    assert checks == check_count(parse_spec(SMOOTH, check_scenes=False).adaptive, nodes)


def test_a_smooth_map_needs_at_most_15_percent_of_its_points(sweep, write_spec):
    """Issue 40's bar: the smooth 2-D map (``smooth_map``) at tolerance 1e-3 from ≤ 15 % of its
    525 points, checks included: met by the quintic where a leaf's next terms say it converges
    (``interpolation.chosen_stencils``; 70 solves, 101 with the cubic alone:
    benchmarks/local_refinement.py --no-crystal)."""
    ds, _ = smooth_map(sweep, write_spec)
    assert ds.attrs["sweep_solves"] <= 0.15 * ds["solved"].size, ds.attrs["sweep_solves"]


ONE_SIDED = """
[scene]
shape = "circle"
quantities = ["tangential"]
nu = 0.25
[axes]
anisotropy = { linspace = [0.5, 1.5, 25] }
orientation = { linspace = [0, 90, 17] }
[adaptive]
tolerance = 1e-3
quantities = ["K_xx"]
"""


def test_a_split_needed_on_one_side_of_a_leaf_adds_nodes_on_that_side_alone():
    """K_xx = 2 + (1 − t)³ s⁶ / 5 over t = A − 0.5 (49 points) × s = ψ/90° (17): cubic in t, so
    the interpolation along t is exact and the error is along s, over the tolerance at small t
    alone (where (1 − t)³ is large). From one leaf of 13 × 5 nodes, the first decision cuts the
    leaf along t at the node nearest beyond the points over (index 24) before splitting along
    s: the new nodes lie at the t nodes up to the face's halo (0 … 32), 9 × 4 = 36 of them, none
    at t indices 36 … 48 (a split of the whole leaf adds 13 × 4 = 52), and the half beyond the
    face keeps its nodes. Refined to the end (``next_step``, check rounds included), the map is
    within its tolerance of the function and its stated error is at least the true error at
    every point."""
    spec = parse_spec(ONE_SIDED.replace("[0.5, 1.5, 25]", "[0.5, 1.5, 49]"), check_scenes=False)
    layout = Layout.of(spec)
    task_of = join_parts(spec, [enumerate_part(spec)])[1]
    t, s = np.linspace(0.0, 1.0, 49)[:, None], np.linspace(0.0, 1.0, 17)[None, :]
    exact = 2.0 + 0.2 * (1.0 - t) ** 3 * s**6
    every = {"K_xx": exact, "K_xx_error": np.full_like(exact, 1e-12)}
    leaf = Leaf((tuple(range(0, 49, 4)), (0, 4, 8, 12, 16)), ((0, 48), (0, 16)))
    before = node_mask(layout, [leaf])
    seen = {n: np.where(before, v, np.nan) for n, v in every.items()}
    over = estimate(layout, (), [leaf], ["K_xx"], seen).map_error[..., 0] > 1e-3
    rows = np.flatnonzero(over.any(axis=1))
    assert rows.size and rows.max() < 24  # the function does what the test needs: points over at small t alone
    state = refine(layout, spec.adaptive, (((), (leaf,)),), seen, ["K_xx"], task_of, Checks())
    leaves = state[0][1]
    new = node_mask(layout, leaves) & ~before
    assert np.flatnonzero(new.any(axis=1)).tolist() == list(range(0, 33, 4))
    assert np.flatnonzero(new.any(axis=0)).tolist() == [2, 6, 10, 14] and new.sum() == 36
    beyond = [piece for piece in leaves if piece.box[0] == (24, 48)]
    assert beyond == [Leaf((tuple(range(16, 49, 4)), (0, 4, 8, 12, 16)), ((24, 48), (0, 16)))]
    checks = Checks()
    while True:
        solved = np.isin(task_of, state_tasks(layout, state, task_of, checks))
        seen = {n: np.where(solved, v, np.nan) for n, v in every.items()}
        step = next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], ["K_xx"], task_of)
        if not isinstance(step, tuple):
            checks = step
            break
        state, checks = step
    est = estimate(layout, (), state[0][1], ["K_xx"], seen, checks.factor(0), checks.cautious(0))
    true = np.where(solved, 0.0, np.abs(est.values[..., 0] / exact - 1.0))
    stated = np.where(solved, 0.0, est.map_error[..., 0])
    assert true.max() <= 1e-3 and np.all(stated >= true), (true.max(), np.mean(stated >= true))


def refined_map(text: str, every: dict) -> tuple:
    """The adaptive map (leaves) of the spec ``text`` whose solves return ``every`` (arrays over the
    task axes), decided as a sweep decides (``next_step``, check rounds included), refined on
    K_xx: the stated map error and the interpolated values at every point (solved points: their
    solve's)."""
    spec = parse_spec(f'{text.rstrip()}\nmethod = "leaves"\n', check_scenes=False)
    layout = Layout.of(spec)
    task_of = join_parts(spec, [enumerate_part(spec)])[1]
    state, checks = initial_state(layout, spec.adaptive), Checks()
    while True:
        solved = np.isin(task_of, state_tasks(layout, state, task_of, checks))
        seen = {n: np.where(solved, v, np.nan) for n, v in every.items()}
        step = next_step(layout, spec.adaptive, state, checks, seen, ["K_xx"], ["K_xx"], task_of)
        if not isinstance(step, tuple):
            checks = step
            break
        state, checks = step
    est = estimate(layout, (), state[0][1], ["K_xx"], seen, checks.factor(0), checks.cautious(0))
    values = np.where(solved, every["K_xx"], est.values[..., 0])
    return values, np.where(solved, every["K_xx_error"], est.map_error[..., 0])


@pytest.mark.parametrize(
    ("grid", "f", "g"),
    [
        ((49, 33), lambda t: np.exp(-4.0 * t), lambda s: 0.2 / (1.15 - s)),
        ((25, 17), lambda t: np.exp(-4.0 * t), lambda s: s**6),
    ],
    ids=["exp(-4t) 0.2/(1.15-s), 49 x 33", "exp(-4t) s^6, 25 x 17"],
)
def test_a_map_steep_at_the_ends_of_its_axes_meets_its_tolerance_with_an_honest_error(grid, f, g):
    """K_xx = 2 + 0.1 f(t) g(s) over t = A − 0.5 × s = ψ/90° (both 0 … 1), steepest at the end of
    each axis (t = 0, s = 1): two maps of the families table of benchmarks/local_refinement.py
    (its tuning half). With the next Newton term alone as the estimate at the intervals whose
    stencil can grow inwards only, the first map ended 1.3e-3 over its tolerance of 1e-3 while
    stating at most 5.9e-4 (honest at 91.3 % of its points), the second honest at 87.3 %, and
    their check rounds held. Refined to the end, each is within its tolerance of the function at
    every point and its stated error is at least the true error at ≥ 95 % of them."""
    nx, ny = grid
    text = ONE_SIDED.replace("[0.5, 1.5, 25]", f"[0.5, 1.5, {nx}]").replace("[0, 90, 17]", f"[0, 90, {ny}]")
    t, s = np.linspace(0.0, 1.0, nx)[:, None], np.linspace(0.0, 1.0, ny)[None, :]
    exact = 2.0 + 0.1 * f(t) * g(s)
    values, stated = refined_map(text, {"K_xx": exact, "K_xx_error": np.full_like(exact, 1e-12)})
    true = np.abs(values / exact - 1.0)
    assert true.max() <= 1e-3, true.max()
    assert np.mean(stated >= true) >= 0.95, np.mean(stated >= true)
