"""Local refinement of adaptive maps (issue 40 item 4): solves against uniform sub-grids and libraries.

    python benchmarks/local_refinement.py [--libraries] [--no-crystal] [--cache FILE] [--output FILE]
    python benchmarks/local_refinement.py --families [--output FILE]

The adaptive map's decisions (``maps.rounds.next_step``: refinement, check rounds) are driven
here in memory, on maps whose value at every grid point is known, so every method is judged at
every grid point and no sweep machinery (journals, data sets) is timed:

* **Mindlin**: the closed-form stand-in of tests/sweep/maps/test_adaptive.py (Mindlin's bonded
  ellipse, perturbed by <= 5e-5, ``<name>_error`` = 1e-4) over its 41 × 21 map, tolerance 1e-3,
  every stored stiffness refined; the truth is the closed form.
* **smooth 2-D**: the same over b/a logspace(0, −3, 25) × nu linspace(0, 0.5, 21) (525 points):
  the share of the points solved.
* **crystal**: the bonded ellipse on a cubic crystal at nu 0.25 over a reduced 3-D grid
  (``CRYSTAL_SPEC``: every second b/a, A and ψ of jobs/adaptive_orientation_map.toml), every
  scene solved for real (one exact cell, accuracy 1e-6; minutes, cached in ``--cache``) and
  taken as the truth; K_a/K_b refined at 1e-3.
* **families** (``--families``, alone): known functions K_xx = 2 + c · f(t) · g(s) over
  anisotropy × orientation (t, s their positions, 0 … 1; ``FAMILY_T`` × ``FAMILY_S``, c 0.1 and
  0.5, 25 × 17 and 49 × 33 points; 48 maps, seconds): the leaves' solves, worst true error and
  honesty on maps no one tuned the estimate to, a robustness table for a change of the refinement;
  split into a tuning half and a half held aside (``family_half``).
* **crystal 4-D** (``--crystal-4d CACHE``): the same over b/a logspace(0, −3, 7) × nu
  linspace(0.05, 0.45, 5) × A linspace(0.5, 3, 6) × ψ linspace(0, 90, 6) (``CRYSTAL_4D_SPEC``:
  every 4th b/a, 2nd nu, 4th A and 6th ψ of jobs/adaptive_orientation_map.toml; 1 260 points),
  the scenes at nu 0.25 taken from the 3-D map's cache, the others solved (~870, minutes).

For each, by leaves and by the sparse grid (``[adaptive] method``; ``maps.sparse_grid``): the
adaptive map's solves (check points included; the points solved, against the uniform sub-grid's
points), worst true relative error and honesty (the share of points whose map error is at
least the true error); the smallest uniform
sub-grid (every k_d-th index per axis, the last included; the same cubic tensor interpolant)
that meets the tolerance by the truth and by the adaptive map's own estimate; a
dimension-adaptive sparse grid (``sparse_grid``: this file's own combination technique on the
same nested nodes, stopped by the truth); with ``--libraries``, python-adaptive's learners
(``pip install adaptive`` into the environment; not a dependency of hpcontact).
"""

from __future__ import annotations

import argparse
import itertools
import math
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import harness
import numpy as np

from hpcontact.analytic import mindlin_ellipse_stiffness
from hpcontact.numerics.interpolation import TensorInterpolant, bisection_nodes
from hpcontact.sweep.maps.estimates import Checks, Layout
from hpcontact.sweep.maps.refinement import Leaf
from hpcontact.sweep.maps.rounds import next_step
from hpcontact.sweep.maps.state import estimate, initial_state, is_sparse, state_tasks
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_part, join_parts

Fields = Mapping[str, np.ndarray]


def all_points(text: str, function: Callable[[Mapping[str, Any]], Mapping[str, float]]) -> dict[str, np.ndarray]:
    """``function`` (a solver's record) at every distinct scene of the spec ``text``: its
    stiffnesses and their ``<name>_error`` as arrays over the task axes."""
    spec = parse_spec(text, check_scenes=False)
    tasks, task_of = join_parts(spec, [enumerate_part(spec)])
    records = [function(task.params) for task in tasks]
    names = [n for n in records[0] if n.startswith("K_")]
    return {n: np.array([float(r[n]) for r in records])[task_of] for n in names}


def simulate(text: str, fields: Fields, names: list[str], method: str = "auto") -> dict[str, Any]:
    """The adaptive map of the spec ``text`` whose solves return ``fields`` (every stiffness and
    its ``<name>_error`` over the task axes; the decisions see them only at solved points, NaN
    elsewhere), decided as a sweep decides (``next_step``), refined on ``names``: the filled map
    (solved points their value, the rest interpolated), its map error, the solved mask, the
    solves, the rounds, the check points and the leaves (a sparse grid: its level indices);
    ``method``: ``[adaptive] method``."""
    spec = parse_spec(f'{text.rstrip()}\nmethod = "{method}"\n', check_scenes=False)
    layout = Layout.of(spec)
    task_of = join_parts(spec, [enumerate_part(spec)])[1]
    stored = [n for n in fields if not n.endswith("_error")]
    state, checks = initial_state(layout, spec.adaptive), Checks()
    rounds = 0
    while True:
        rounds += 1
        solved = np.isin(task_of, state_tasks(layout, state, task_of, checks))
        seen = {n: np.where(solved, v, np.nan) for n, v in fields.items()}
        step = next_step(layout, spec.adaptive, state, checks, seen, names, stored, task_of)
        if not isinstance(step, tuple):
            checks = step
            break
        state, checks = step
    values = {n: seen[n].copy() for n in names}
    errors = {n: np.abs(np.nan_to_num(seen[f"{n}_error"])) for n in names}
    for s, (cat, leaves) in enumerate(state):
        est = estimate(layout, cat, leaves, names, seen, checks.factor(s), checks.cautious(s))
        mask = layout.take(solved, cat)
        for q, name in enumerate(names):
            layout.put(values[name], cat, np.where(mask, layout.take(values[name], cat), est.values[..., q]))
            layout.put(errors[name], cat, np.where(mask, layout.take(errors[name], cat), est.map_error[..., q]))
    return {
        "values": values,
        "errors": errors,
        "solved": solved,
        "solves": len(np.unique(np.asarray(task_of)[solved])),
        "rounds": rounds,
        "checks": len(checks.points),
        "leaves": sum(len(leaves.indices) if is_sparse(leaves) else len(leaves) for _, leaves in state),
        "layout": layout,
        "spec": spec,
    }


def judge(values: Fields, errors: Fields | None, truth: Fields) -> dict[str, float]:
    """Worst true relative error, worst stated map error and honesty (the share of points whose
    map error is at least the true error) of the map ``values`` against ``truth``, the worst
    over the quantities of ``truth``."""
    worst, stated, honest = 0.0, 0.0, 1.0
    for name, exact in truth.items():
        true = np.abs(values[name] / exact - 1.0)
        worst = max(worst, float(true.max()))
        if errors is not None:
            stated = max(stated, float(errors[name].max()))
            honest = min(honest, float(np.mean(errors[name] >= true)))
    return {"worst true": worst, "worst stated": stated, "honest": honest}


def uniform_nodes(n: int, stride: int) -> list[int]:
    """Every ``stride``-th index of ``0 … n-1``, the last one included."""
    return sorted(set(range(0, n, stride)) | {n - 1})


def smallest_uniform(result: dict[str, Any], fields: Fields, names: list[str], truth: Fields, target: float) -> dict:
    """The uniform sub-grids (every k_d-th index per axis, the last included; one sub-problem) of
    fewest nodes that meet ``target``: by the truth (the cubic tensor interpolant of ``fields``
    at its nodes within ``target`` of ``truth`` everywhere) and by the adaptive map's own
    estimate (``refinement.estimate`` of one leaf, ``SAFETY``, the solves' errors: the map error
    <= the tolerance everywhere). Strides are searched exhaustively up to the largest that each
    axis allows alone (by the truth)."""
    layout: Layout = result["layout"]
    settings = result["spec"].adaptive
    shape = tuple(len(x) for x in layout.xs)
    cat = tuple(0 for _ in layout.categorical)
    tol = np.array([settings.tolerance(n) for n in names])

    def nodes_of(strides: tuple[int, ...]) -> tuple[tuple[int, ...], ...]:
        return tuple(tuple(uniform_nodes(n, s)) for n, s in zip(shape, strides))

    def true_error(strides: tuple[int, ...]) -> float:
        nodes = nodes_of(strides)
        interpolant = TensorInterpolant(list(layout.xs), nodes)
        out = 0.0
        for name, exact in truth.items():
            values = interpolant.values(layout.take(fields[name], cat, nodes))
            out = max(out, float(np.max(np.abs(values / layout.take(exact, cat) - 1.0))))
        return out

    def estimated(strides: tuple[int, ...]) -> float:
        nodes = nodes_of(strides)
        est = estimate(layout, cat, [Leaf(nodes, tuple((n[0], n[-1]) for n in nodes))], names, fields)
        return float(np.max(est.map_error / tol))

    limits = []
    for d, n in enumerate(shape):
        best = 1
        for stride in range(2, n):
            if true_error(tuple(stride if e == d else 1 for e in range(len(shape)))) > target:
                break
            best = stride
        limits.append(best)
    found: dict[str, tuple[int, tuple[int, ...], float]] = {}
    for strides in itertools.product(*(range(1, m + 1) for m in limits)):
        count = math.prod(len(n) for n in nodes_of(strides))
        for key, measure, bound in (("by truth", true_error, target), ("by estimate", estimated, 1.0)):
            if key not in found or count < found[key][0]:
                value = measure(strides)
                if value <= bound:
                    found[key] = (count, strides, value)
    return {k: {"nodes": c, "strides": s, "worst": v} for k, (c, s, v) in found.items()}


def sparse_grid(layout: Layout, fields: Fields, truth: Fields, target: float) -> dict[str, Any]:
    """A dimension-adaptive sparse grid (Gerstner & Griebel, Computing 71, 2003) on the same
    nested nodes and interpolant: the combination technique over tensor grids of bisection
    levels (level l: ``bisection_nodes`` with 2^l + 1 nodes, the cubic ``TensorInterpolant`` on
    each); an admissible index with the largest surplus (the largest change its tensor
    difference makes at a grid point, relative) is added next. Stops when the combination is
    within ``target`` of ``truth`` at every grid point (the truth guides it: optimistic); its
    solves are the union of the nodes of every tensor grid evaluated."""
    shape = tuple(len(x) for x in layout.xs)
    cat = tuple(0 for _ in layout.categorical)
    tops = tuple(max(0, math.ceil(math.log2(max(n - 1, 1)))) for n in shape)
    cache: dict[tuple[int, ...], dict[str, np.ndarray]] = {}
    points: set[tuple[int, ...]] = set()

    def level_nodes(d: int, level: int) -> list[int]:
        return bisection_nodes(shape[d], 2**level + 1) if shape[d] > 1 else [0]

    def tensor(index: tuple[int, ...]) -> dict[str, np.ndarray]:
        if index not in cache:
            nodes = [level_nodes(d, level) for d, level in enumerate(index)]
            points.update(itertools.product(*nodes))
            interpolant = TensorInterpolant(list(layout.xs), nodes)
            cache[index] = {n: interpolant.values(layout.take(fields[n], cat, nodes)) for n in truth}
        return cache[index]

    def difference(index: tuple[int, ...]) -> dict[str, np.ndarray]:
        out = {n: np.zeros(shape) for n in truth}
        for z in itertools.product((0, 1), repeat=len(shape)):
            lower = tuple(i - s for i, s in zip(index, z))
            if min(lower) < 0:
                continue
            for n, v in tensor(lower).items():
                out[n] += (-1) ** sum(z) * v
        return out

    def surplus(delta: dict[str, np.ndarray]) -> float:
        return max(float(np.max(np.abs(delta[n] / layout.take(truth[n], cat)))) for n in truth)

    root = tuple(0 for _ in shape)
    accepted: set[tuple[int, ...]] = set()
    combination = {n: np.zeros(shape) for n in truth}
    active = {root: difference(root)}
    worst = math.inf
    while active:
        index = max(sorted(active), key=lambda k: surplus(active[k]))
        delta = active.pop(index)
        accepted.add(index)
        for n in truth:
            combination[n] += delta[n]
        worst = max(float(np.max(np.abs(combination[n] / layout.take(truth[n], cat) - 1.0))) for n in truth)
        if worst <= target:
            break
        for d in range(len(shape)):
            forward = tuple(i + (e == d) for e, i in enumerate(index))
            if forward[d] > tops[d] or forward in active:
                continue
            backward = (tuple(f - (e == b) for e, f in enumerate(forward)) for b in range(len(shape)))
            if all(min(k) < 0 or k in accepted for k in backward):
                active[forward] = difference(forward)
    return {"solves": len(points), "worst true": worst, "indices": len(accepted)}


MINDLIN_SPEC = """
[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
accuracy = 1e-4
[axes]
aspect = {{ logspace = [0, {low}, {count}] }}
nu = {{ linspace = [0, 0.5, 21] }}
[adaptive]
tolerance = 1e-3
"""


def mindlin_standin() -> Callable[[Mapping[str, Any]], Mapping[str, float]]:
    """The closed-form stand-in of tests/sweep/maps/test_adaptive.py (its ``mindlin``)."""
    import sys

    sys.path.insert(0, str(harness.ROOT / "tests" / "sweep" / "maps"))
    from test_adaptive import mindlin

    return mindlin


def mindlin_truth(text: str) -> dict[str, np.ndarray]:
    """Mindlin's closed form (``analytic.mindlin_ellipse_stiffness``) over the spec's b/a × nu."""
    axes = {a.name: np.asarray(a.values, dtype=np.float64) for a in parse_spec(text, check_scenes=False).task_axes}
    ka, kb = mindlin_ellipse_stiffness(1.0, axes["aspect"][:, None], 1.0, axes["nu"][None, :])
    return {"K_xx": ka, "K_yy": kb, "K_a_over_K_b": ka / kb}


def python_adaptive(layout: Layout, truth: Fields, target: float, chunk: int, limit: int, budget: float) -> dict:
    """python-adaptive's ``LearnerND`` (and ``Learner2D`` in 2-D), default losses, on the
    quantities of ``truth`` as one vector, between grid points the cubic spline of the grid
    values (``scipy.interpolate.RegularGridInterpolator``; equal to the truth at the grid
    points, where the learners are judged): after each ``chunk`` of points, the worst relative
    error at the grid points of the linear interpolant of its points (scipy's
    ``LinearNDInterpolator``, as the learners' own); the points at which it first is <= ``target``
    (at most ``limit`` points or ``budget`` seconds per learner)."""
    import adaptive
    from scipy.interpolate import LinearNDInterpolator, RegularGridInterpolator

    keep = [d for d, x in enumerate(layout.xs) if len(x) > 1]
    xs = [layout.xs[d] for d in keep]
    exact = np.stack([v.reshape([len(x) for x in xs]) for v in truth.values()], axis=-1)
    spline = RegularGridInterpolator(xs, exact, method="cubic", bounds_error=False, fill_value=None)
    grid = np.stack(np.meshgrid(*xs, indexing="ij"), axis=-1).reshape(-1, len(xs))
    flat = exact.reshape(-1, exact.shape[-1])
    bounds = [(float(x.min()), float(x.max())) for x in xs]
    learners = {"LearnerND": lambda: adaptive.LearnerND(lambda x: spline(np.asarray(x))[0], bounds=bounds)}
    if len(xs) == 2:
        learners["Learner2D"] = lambda: adaptive.Learner2D(lambda x: spline(np.asarray(x))[0], bounds=bounds)
    out: dict[str, Any] = {"version": adaptive.__version__}
    for name, make in learners.items():
        learner, worst, reached = make(), math.inf, None
        started = time.perf_counter()
        while learner.npoints < limit and time.perf_counter() - started < budget:
            adaptive.runner.simple(learner, npoints_goal=learner.npoints + chunk)
            data = learner.data
            values = LinearNDInterpolator(np.array(list(data)), np.array(list(data.values())))(grid)
            worst = float(np.nanmax(np.abs(values / flat - 1.0)))
            if worst <= target:
                reached = learner.npoints
                break
        out[name] = {"points": reached, "stopped at": learner.npoints, "worst": worst}
    return out


def compare(label: str, text: str, fields: Fields, names: list[str], truth: Fields, libraries: bool) -> dict:
    """One map: the adaptive map by leaves and by the sparse grid (``[adaptive] method``), the
    smallest uniform sub-grids, the truth-guided sparse grid and (with ``libraries``)
    python-adaptive, every one against ``truth`` at every grid point."""
    row: dict[str, Any] = {"map": label}
    for method in ("leaves", "sparse"):
        started = time.perf_counter()
        result = simulate(text, fields, names, method)
        found: dict[str, Any] = {"points": int(np.asarray(result["values"][names[0]]).size)}
        found.update(solves=result["solves"], rounds=result["rounds"], checks=result["checks"])
        found.update(parts=result["leaves"], points_solved=int(np.count_nonzero(result["solved"])))
        found.update(judge(result["values"], result["errors"], truth), wall_s=round(time.perf_counter() - started, 2))
        found["share solved"] = found["solves"] / found["points"]
        row[method] = found
    row["points"] = row["leaves"]["points"]
    tolerance = result["spec"].adaptive.default
    row["uniform"] = smallest_uniform(result, fields, names, truth, tolerance)
    row["sparse grid"] = sparse_grid(result["layout"], fields, truth, tolerance)
    if libraries:
        row["python-adaptive"] = python_adaptive(result["layout"], truth, tolerance, 25, 5000, 60.0)
    return row


def mindlin_map(label: str, low: float, count: int, libraries: bool) -> dict:
    text = MINDLIN_SPEC.format(low=low, count=count)
    names = ["K_xx", "K_yy", "K_max", "K_min", "K_a_over_K_b", "K_min_over_K_max"]
    return compare(label, text, all_points(text, mindlin_standin()), names, mindlin_truth(text), libraries)


CRYSTAL_SPEC = """
[scene]
shape = "ellipse"
quantities = ["tangential"]
nu = 0.25
[numerics]
accuracy = 1e-6
[axes]
aspect = { logspace = [0, -3, 13] }
anisotropy = { linspace = [0.5, 3.0, 11] }
orientation = { linspace = [0, 90, 16] }
[adaptive]
tolerance = 1e-3
quantities = ["K_a_over_K_b"]
"""
#: The crystal map's quantities kept from each solve.
CRYSTAL_NAMES = ("K_xx", "K_yy", "K_a_over_K_b", "K_xx_error", "K_yy_error", "K_a_over_K_b_error")


CRYSTAL_4D_SPEC = """
[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
accuracy = 1e-6
[axes]
aspect = { logspace = [0, -3, 7] }
nu = { linspace = [0.05, 0.45, 5] }
anisotropy = { linspace = [0.5, 3.0, 6] }
orientation = { linspace = [0, 90, 6] }
[adaptive]
tolerance = 1e-3
quantities = ["K_a_over_K_b"]
"""


FAMILY_SPEC = """
[scene]
shape = "circle"
quantities = ["tangential"]
nu = 0.25
[axes]
anisotropy = {{ linspace = [0.5, 1.5, {nx}] }}
orientation = {{ linspace = [0, 90, {ny}] }}
[adaptive]
tolerance = 1e-3
quantities = ["K_xx"]
"""
#: Known functions of t = A − 0.5 and s = ψ/90° (both 0 … 1): K_xx = 2 + c · f(t) · g(s), the
#: map's error along s large where f is.
FAMILY_T: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "(1-t)^3": lambda t: (1.0 - t) ** 3,
    "exp(-4t)": lambda t: np.exp(-4.0 * t),
    "bump(t)": lambda t: np.exp(-(((t - 0.3) / 0.2) ** 2)),
}
FAMILY_S: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "s^6": lambda s: s**6,
    "sin(4s)": lambda s: np.sin(4.0 * s),
    "0.2/(1.15-s)": lambda s: 0.2 / (1.15 - s),
    "tanh(6(s-0.6))": lambda s: np.tanh(6.0 * (s - 0.6)),
}


def family_half(f_name: str, g_name: str) -> str:
    """The half of the families table a function f(t) g(s) belongs to, by a rule fixed before the
    estimate's end terms were tuned (2026-11-29, ``interpolation.end_terms``): "tuning" where the
    positions of f in ``FAMILY_T`` and of g in ``FAMILY_S`` add up to an odd number, "held aside"
    where even (a checkerboard over f × g: each half has every f and every g, both grids and both
    c; no function of one half is a function of the other)."""
    return "tuning" if (list(FAMILY_T).index(f_name) + list(FAMILY_S).index(g_name)) % 2 else "held aside"


def families() -> list[dict[str, Any]]:
    """The adaptive map (leaves) of every known function 2 + c · f(t) · g(s) (``FAMILY_T`` ×
    ``FAMILY_S``, c = 0.1 and 0.5; exact, solve error 1e-12) over 25 × 17 and 49 × 33 points:
    its half (``family_half``), solves, checks, leaves, worst true error and honesty against the
    function itself."""
    rows = []
    for nx, ny in ((25, 17), (49, 33)):
        text = FAMILY_SPEC.format(nx=nx, ny=ny)
        t, s = np.linspace(0.0, 1.0, nx)[:, None], np.linspace(0.0, 1.0, ny)[None, :]
        for (f_name, f), (g_name, g), c in itertools.product(FAMILY_T.items(), FAMILY_S.items(), (0.1, 0.5)):
            exact = 2.0 + c * f(t) * g(s)
            result = simulate(text, {"K_xx": exact, "K_xx_error": np.full_like(exact, 1e-12)}, ["K_xx"], "leaves")
            row = {"grid": f"{nx} x {ny}", "function": f"2 + {c} {f_name} {g_name}", "solves": result["solves"]}
            row["half"] = family_half(f_name, g_name)
            row.update(checks=result["checks"], leaves=result["leaves"])
            row.update(judge(result["values"], result["errors"], {"K_xx": exact}))
            rows.append(row)
    return rows


def _scene(params: Mapping[str, Any]) -> tuple[float, ...]:
    """A scene's numeric parameters, rounded (the same scene in two specs' tasks)."""
    return tuple(round(float(params.get(k, 0.0)), 9) for k in ("aspect", "nu", "anisotropy", "orientation"))


def crystal_truth(cache: Path, text: str = CRYSTAL_SPEC, seed: Path | None = None) -> dict[str, np.ndarray]:
    """Every distinct scene of the spec ``text`` (``CRYSTAL_SPEC``) solved by the scene kind's
    solver (one exact cell each, accuracy 1e-6), as arrays over its task axes; ``cache`` (.npz)
    keeps the solves made so far (saved every 50), so an interrupted run goes on where it
    stopped; the scenes ``seed`` (the cache of ``CRYSTAL_SPEC``) holds are taken from it."""
    from hpcontact.accuracy import task_function

    spec = parse_spec(text, check_scenes=False)
    tasks, task_of = join_parts(spec, [enumerate_part(spec)])
    table = dict(np.load(cache)) if cache.exists() else {}
    table = {n: table.get(n, np.full(len(tasks), np.nan)) for n in CRYSTAL_NAMES}
    if seed is not None and seed.exists():
        known = dict(np.load(seed))
        base = parse_spec(CRYSTAL_SPEC, check_scenes=False)
        where = {_scene(t.params): i for i, t in enumerate(join_parts(base, [enumerate_part(base)])[0])}
        for i, task in enumerate(tasks):
            j = where.get(_scene(task.params))
            if j is not None and np.isnan(table["K_a_over_K_b"][i]):
                for name in CRYSTAL_NAMES:
                    table[name][i] = known[name][j]
    solve = task_function(spec.kind)
    missing = np.flatnonzero(np.isnan(table["K_a_over_K_b"]))
    for count, task in enumerate(missing.tolist(), start=1):
        record = solve(tasks[task].params)
        for name in CRYSTAL_NAMES:
            table[name][task] = float(record[name])
        if count % 50 == 0 or count == len(missing):
            np.savez(cache, **table)
            print(f"crystal truth: {count} of {len(missing)} solved", flush=True)
    return {n: v[task_of] for n, v in table.items()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", type=Path, default=harness.RESULTS / "local_refinement_crystal.npz")
    parser.add_argument("--no-crystal", action="store_true", help="the two closed-form maps alone")
    parser.add_argument(
        "--crystal-4d",
        type=Path,
        default=None,
        metavar="CACHE",
        help="the reduced 4-D crystal map too (CRYSTAL_4D_SPEC; its truth cached in CACHE, .npz)",
    )
    parser.add_argument("--libraries", action="store_true", help="python-adaptive too (pip install adaptive)")
    parser.add_argument(
        "--families", action="store_true", help="the known functions 2 + c f(t) g(s) alone (FAMILY_T x FAMILY_S)"
    )
    parser.add_argument("--output", type=Path, default=None)
    args = parser.parse_args()
    print(harness.machine_line(), flush=True)
    if args.families:
        found = families()
        for row in found:
            print(
                f"{row['half']:10s} {row['grid']:8s} {row['function']:34s} solves {row['solves']:4d} (checks {row['checks']:3d}, "
                f"leaves {row['leaves']:2d}) worst true {row['worst true']:.1e} stated {row['worst stated']:.1e} "
                f"honest {100 * row['honest']:.1f} %",
                flush=True,
            )
        for half in ("tuning", "held aside"):
            rows = [row for row in found if row["half"] == half]
            print(
                f"{half}: solves {sum(row['solves'] for row in rows)}, least honest "
                f"{100 * min(row['honest'] for row in rows):.1f} %, below 95 %: "
                f"{sum(row['honest'] < 0.95 for row in rows)}, over 1e-3: {sum(row['worst true'] > 1e-3 for row in rows)}"
            )
        print(f"solves in all: {sum(row['solves'] for row in found)}")
        if args.output is not None:
            harness.write_json(args.output, found)
        return
    rows = [
        mindlin_map("Mindlin, b/a 1 ... 1e-4 x nu, 41 x 21", -4, 41, args.libraries),
        mindlin_map("smooth 2-D, b/a 1 ... 1e-3 x nu, 25 x 21", -3, 25, args.libraries),
    ]
    if not args.no_crystal:
        truth = crystal_truth(args.cache)
        fields = {n: v for n, v in truth.items()}
        rows.append(
            compare(
                "crystal ellipse nu 0.25, b/a x A x psi, 13 x 11 x 16",
                CRYSTAL_SPEC,
                fields,
                ["K_a_over_K_b"],
                {"K_a_over_K_b": truth["K_a_over_K_b"]},
                args.libraries,
            )
        )
    if args.crystal_4d is not None:
        truth = crystal_truth(args.crystal_4d, CRYSTAL_4D_SPEC, args.cache)
        rows.append(
            compare(
                "crystal ellipse, b/a x nu x A x psi, 7 x 5 x 6 x 6",
                CRYSTAL_4D_SPEC,
                truth,
                ["K_a_over_K_b"],
                {"K_a_over_K_b": truth["K_a_over_K_b"]},
                args.libraries,
            )
        )
    for row in rows:
        uniform, sparse = row["uniform"], row["sparse grid"]
        print(f"{row['map']}: {row['points']} points", flush=True)
        for method in ("leaves", "sparse"):
            found = row[method]
            ratios = ", ".join(
                f"{found['points_solved'] / u['nodes']:.2f} x uniform {key}" for key, u in uniform.items()
            )
            print(
                f"    {method}: {found['solves']} solves ({100 * found['share solved']:.1f} %, {found['checks']} checks, "
                f"{found['rounds']} rounds, {found['parts']} leaves or indices; {found['points_solved']} points solved: "
                f"{ratios}), worst true {found['worst true']:.2e}, worst stated {found['worst stated']:.2e}, "
                f"honest {100 * found['honest']:.1f} %, {found['wall_s']} s",
                flush=True,
            )
        for key, found in uniform.items():
            print(f"    uniform {key}: {found['nodes']} nodes, strides {found['strides']}, worst {found['worst']:.2e}")
        print(f"    sparse grid (truth-guided): {sparse['solves']} points, worst {sparse['worst true']:.2e}")
        for name, learned in row.get("python-adaptive", {}).items():
            if name != "version":
                print(f"    python-adaptive {row['python-adaptive']['version']} {name}: {learned}")
    if args.output is not None:
        harness.write_json(args.output, rows)


if __name__ == "__main__":
    main()
