"""Adaptive maps (issue 27): solves needed for Mindlin's map K_a/K_b, adaptive vs uniform vs python-adaptive.

    python benchmarks/adaptive_maps.py [--python-adaptive /tmp/adaptive-venv/bin/python]
    mpiexec -n 2 python benchmarks/adaptive_maps.py --real [--output results/adaptive_mindlin.nc]
    mpiexec -n 2 python benchmarks/adaptive_maps.py --crystal [--crystal-output results/adaptive_crystal.nc]

The map: bonded ellipse, tangential, b/a ∈ logspace(0, −4, 41) × nu ∈ linspace(0, 0.5, 21) (861
points), ``[adaptive] tolerance = 1e-3``, ``[numerics] accuracy = 1e-4``; the truth is Mindlin's
closed form (``analytic.mindlin_ellipse_stiffness``). Columns: solves, the worst true relative
error over the 861 points of K_a/K_b, K_xx = K_a and K_yy = K_b, the fraction of points whose
``<name>_map_error`` is >= the true error (worst over the three), the wall time.

* ``--real``: the adaptive sweep with the real solver (every rank: ``run_sweep`` on the MPI
  world; minutes on 2 cores, the solves cost 0.3-9 s each).
* always: the same sweep on the closed-form stand-in of tests/sweep/maps/test_adaptive.py (Mindlin
  perturbed by <= 5e-5, ``<name>_error`` = 1e-4; seconds), and the smallest *uniform* sub-grid
  (every s_a-th b/a and s_nu-th nu, ends included, the same cubic interpolation in log b/a and
  nu) whose worst true error of the exact closed form (optimistic for uniform: no solve error)
  is at most the adaptive run's.
* ``--python-adaptive PY``: python-adaptive's ``Learner2D`` and ``LearnerND`` (Nijholt, Weston,
  Hoofwijk, Akhmerov, *Adaptive*, Zenodo 2019; their default losses, in PY, a separate environment
  with ``adaptive``; never a dependency of hpcontact) on the exact ratio over (log10 b/a, nu): run
  in chunks of ``--chunk`` points (``runner.simple`` with an npoints goal), after each chunk the
  worst error of the linear interpolant of their points (scipy LinearNDInterpolator, as
  Learner2D's) on the 861 grid points; the points at which it first is <= 1e-3 (at most
  ``--max-points`` points or ``--budget`` seconds per learner). Their points are not grid points: the comparison
  counts solves alone.
* ``--crystal`` (alone; under mpiexec): the 4-D crystal map ``CRYSTAL_SPEC`` (bonded ellipse,
  b/a × nu × cubic anisotropy A × orientation ψ, 25 × 9 × 21 × 31 points, accuracy 1e-6 per solve:
  one exact cell each), adaptive with tolerance 1e-3 on K_a/K_b; then ``--points`` random
  interpolated grid points (``--seed``) solved directly (``accuracy.solve_to_accuracy``, the same
  accuracy) against the map's values and its ``<name>_map_error``; then the smallest uniform
  sub-grid (every k-th index per axis, the last included) whose cubic interpolant (the adaptive
  module's ``interpolation.weights``) is as good at those points: each axis' largest stride alone
  (1-D interpolation at the points) first, then the tensor interpolant at the points, tightening
  the coarsest axis until it holds. Every value is a direct solve (cached).
"""

from __future__ import annotations

import argparse
import io
import itertools
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SPEC = """
[sweep]
title = "Mindlin's map K_a/K_b, adaptive (benchmarks/adaptive_maps.py)"
progress_interval = 30.0
[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
accuracy = 1e-4
[axes]
aspect = { logspace = [0, -4, 41] }
nu = { linspace = [0, 0.5, 21] }
[adaptive]
tolerance = 1e-3
"""
NAMES = ("K_a_over_K_b", "K_xx", "K_yy")

CHILD = r"""
import json, sys, time
import numpy as np
from scipy.special import ellipkm1, elliprd
from scipy.interpolate import LinearNDInterpolator
import adaptive

def ratio(x):
    log_g, nu = x
    g = 10.0 ** log_g
    p = g * g
    K = ellipkm1(p); D = elliprd(0.0, p, 1.0) / 3.0; B = p * elliprd(0.0, 1.0, p) / 3.0
    return (K - nu * D) / (K - nu * B)

X, Y = np.meshgrid(np.linspace(0, -4, 41), np.linspace(0, 0.5, 21), indexing="ij")
grid = np.stack([X.ravel(), Y.ravel()], axis=1)
exact = np.array([ratio(p) for p in grid])
step, limit, budget = int(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
targets = sorted(map(float, sys.argv[4:]), reverse=True)
out = {}
for name, make in (("Learner2D", lambda: adaptive.Learner2D(ratio, bounds=[(-4, 0), (0, 0.5)])),
                   ("LearnerND", lambda: adaptive.LearnerND(ratio, bounds=[(-4, 0), (0, 0.5)]))):
    learner, pending, worst = make(), list(targets), float("nan")
    started = time.perf_counter()
    while pending and learner.npoints < limit and time.perf_counter() - started < budget:
        # a chunk of `step` points with the learner's own loss, then the worst error of the
        # linear interpolant of its points (as Learner2D's) on the 861 grid points
        adaptive.runner.simple(learner, npoints_goal=learner.npoints + step)
        data = learner.data
        values = LinearNDInterpolator(np.array(list(data)), np.array(list(data.values())))(grid)
        worst = float(np.nanmax(np.abs(values / exact - 1.0)))
        while pending and worst <= pending[0]:
            out[f"{name} to {pending.pop(0):.2e}"] = [learner.npoints, worst, time.perf_counter() - started]
    for target in pending:
        out[f"{name} to {target:.2e}"] = None
    out[f"{name} stopped at"] = [learner.npoints, worst, time.perf_counter() - started]
print(json.dumps(out))
"""


CRYSTAL_SPEC = """
[sweep]
title = "4-D crystal map, adaptive (benchmarks/adaptive_maps.py --crystal)"
progress_interval = 60.0
[scene]
shape = "ellipse"
quantities = ["tangential", "normal"]
[numerics]
accuracy = 1e-6
[axes]
aspect = { logspace = [0, -3, 25] }
nu = { linspace = [0.05, 0.45, 9] }
anisotropy = { linspace = [0.5, 3.0, 21] }
orientation = { linspace = [0, 90, 31] }
[adaptive]
tolerance = 1e-3
quantities = ["K_a_over_K_b"]
"""
CRYSTAL_NAMES = ("K_xx", "K_yy", "K_zz", "K_a_over_K_b")
CRYSTAL_AXES = ("aspect", "nu", "anisotropy", "orientation")
CRYSTAL_ACCURACY = 1e-6
CRYSTAL_REFINED = "K_a_over_K_b"
CRYSTAL_TOLERANCE = 1e-3


def solve_points(team, points: list[dict]) -> list[dict]:
    """Direct solves (``solve_to_accuracy``, exact cells) of ``points`` shared over the ranks;
    every rank gets every record (the quantities of ``CRYSTAL_NAMES``)."""
    from hpcontact.accuracy import solve_to_accuracy
    from hpcontact.scene import Scene

    mine = {}
    for i in range(team.rank, len(points), team.size):
        params = {"shape": "ellipse", "quantities": ["tangential", "normal"], **points[i]}
        record = solve_to_accuracy(Scene.from_params(params), CRYSTAL_ACCURACY, strategy="auto")
        mine[i] = [float(record[n]) for n in CRYSTAL_NAMES]
    parts = team.gather(mine)
    merged = {}
    for part in parts or []:
        merged.update(part)
    merged = team.bcast(merged if team.rank == 0 else None)
    return [merged[i] for i in range(len(points))]


class Solved:
    """Direct solves of grid points by index tuple, cached (every rank calls ``need`` together)."""

    def __init__(self, team, values: list[np.ndarray]) -> None:
        self.team, self.values, self.cache = team, values, {}

    def need(self, indices) -> int:
        new = sorted({tuple(int(i) for i in ix) for ix in indices} - set(self.cache))
        points = [{a: float(v[i]) for a, v, i in zip(CRYSTAL_AXES, self.values, ix)} for ix in new]
        for ix, record in zip(new, solve_points(self.team, points)):
            self.cache[ix] = np.array(record)
        return len(new)


def uniform_nodes(n: int, stride: int) -> list[int]:
    """Every ``stride``-th index of ``0 … n-1``, the last one included."""
    return sorted(set(range(0, n, stride)) | {n - 1})


def tensor_at(solved: Solved, xs, nodes, point) -> np.ndarray:
    """The tensor cubic interpolant (``interpolation.weights``) from ``nodes`` at the grid ``point``."""
    from hpcontact.numerics.interpolation import weights

    rows = [weights(x, n)[p] for x, n, p in zip(xs, nodes, point)]
    stencil = [[(int(n[j]), w[j]) for j in np.flatnonzero(w)] for n, w in zip(nodes, rows)]
    combos = list(itertools.product(*stencil))
    solved.need([[c[0] for c in combo] for combo in combos])
    return sum(np.prod([c[1] for c in combo]) * solved.cache[tuple(c[0] for c in combo)] for combo in combos)


def smallest_uniform(solved: Solved, xs, shape, picked, direct, q: int, target: float):
    """The smallest uniform sub-grid (every k-th index per axis, the last included) whose cubic
    interpolant of quantity ``q`` is within ``target`` at the grid points ``picked`` (``direct``
    their solved values): each axis alone first (1-D interpolation along it at the points), then
    the tensor interpolant of that candidate at the points, tightening the coarsest axis until it
    holds. Returns (strides, strides each axis alone allowed, node count, worst error)."""
    from hpcontact.numerics.interpolation import weights

    alone = []
    for d, n in enumerate(shape):
        best = 1
        for stride in range(2, n):
            nodes = uniform_nodes(n, stride)
            errors = []
            for p, exact in zip(picked, direct):
                row = weights(xs[d], nodes)[p[d]]
                need = [tuple(p[:d]) + (nodes[j],) + tuple(p[d + 1 :]) for j in np.flatnonzero(row)]
                solved.need(need)
                value = sum(row[j] * solved.cache[ix] for j, ix in zip(np.flatnonzero(row), need))
                errors.append(abs(value[q] / exact[q] - 1.0))
            if max(errors) > target:
                break
            best = stride
        alone.append(best)
    strides = list(alone)
    while True:
        nodes = [uniform_nodes(n, s) for n, s in zip(shape, strides)]
        errors = np.array([abs(tensor_at(solved, xs, nodes, p)[q] / e[q] - 1.0) for p, e in zip(picked, direct)])
        if errors.max() <= target or all(s == 1 for s in strides):
            break
        d = int(np.argmax([s if s > 1 else 0 for s in strides]))  # the coarsest axis first
        strides[d] = max(s for s in range(1, strides[d]) if len(uniform_nodes(shape[d], s)) > len(nodes[d]))
    return strides, alone, int(np.prod([len(n) for n in nodes])), float(errors.max())


def crystal(team, output: Path, count: int, seed: int, reuse: bool = False) -> None:
    """The 4-D crystal map (``CRYSTAL_SPEC``) adaptively on ``team``, checked at ``count``
    random interpolated grid points against direct solves, and the smallest uniform sub-grid
    (``smallest_uniform``) at the map's worst error there and at the tolerance; ``reuse``: check
    the existing ``output`` instead of running the sweep."""
    import xarray as xr

    from hpcontact.sweep.driver import run_sweep
    from hpcontact.sweep.space.parse import parse_spec
    from hpcontact.sweep.work.tasks import enumerate_tasks

    folder = Path(team.bcast(tempfile.mkdtemp(prefix="adaptive-crystal-") if team.rank == 0 else None))
    spec = folder / "crystal.toml"
    if team.rank == 0 and not reuse:
        spec.write_text(CRYSTAL_SPEC)
        output.parent.mkdir(parents=True, exist_ok=True)
        output.unlink(missing_ok=True)
        shutil.rmtree(output.with_name(output.name + ".journal"), ignore_errors=True)
    scenes = len(enumerate_tasks(parse_spec(CRYSTAL_SPEC, output=output))[0]) if team.rank == 0 else None
    team.barrier()
    started = time.perf_counter()
    if not reuse:
        run_sweep(spec, output=output, team=team, stream=sys.stderr if team.rank == 0 else io.StringIO(), options=None)
    wall = time.perf_counter() - started
    info = None
    if team.rank == 0:
        shutil.rmtree(folder, ignore_errors=True)
        if not reuse:
            shutil.rmtree(output.with_name(output.name + ".journal"), ignore_errors=True)
        with xr.open_dataset(output) as ds:
            ds = ds.transpose(*CRYSTAL_AXES, ...)
            values = [ds[a].values for a in CRYSTAL_AXES]
            stored = np.stack([ds[n].values for n in CRYSTAL_NAMES], axis=-1)
            estimate = np.stack([ds[f"{n}_map_error"].values for n in CRYSTAL_NAMES], axis=-1)
            candidates = np.argwhere(ds["solved"].values == 0)
            info = dict(
                values=values,
                stored=stored,
                estimate=estimate,
                solves=int(ds.attrs["sweep_solves"]),
                rounds=int(ds.attrs["adaptive_rounds"]),
                tasks=int(ds["solved"].size),
                scenes=scenes,
                picked=candidates[np.random.default_rng(seed).choice(len(candidates), count, replace=False)],
            )
    info = team.bcast(info)
    values, picked = info["values"], [tuple(int(i) for i in p) for p in info["picked"]]
    solved = Solved(team, values)
    solved.need(picked)
    direct = np.array([solved.cache[p] for p in picked])
    mapped = np.array([info["stored"][p] for p in picked])
    true = np.abs(mapped / direct - 1.0)
    estimate = np.array([info["estimate"][p] for p in picked])
    covered = estimate >= true
    q = CRYSTAL_NAMES.index(CRYSTAL_REFINED)
    worst = float(true[:, q].max())
    xs = [np.log10(values[0]), *values[1:]]
    shape = [len(v) for v in values]
    uniform = {t: smallest_uniform(solved, xs, shape, picked, direct, q, t) for t in (worst, CRYSTAL_TOLERANCE)}
    if team.rank == 0:
        print(
            f"4-D crystal map {' x '.join(map(str, shape))} = {info['tasks']} points ({info['scenes']} distinct "
            f"scenes), accuracy {CRYSTAL_ACCURACY:g}, tolerance 1e-3 on {CRYSTAL_REFINED}"
        )
        print(
            f"  adaptive ({team.size} rank(s)): {info['solves']} solves in {info['rounds']} rounds"
            + ("" if reuse else f", {wall:.0f} s wall")
        )
        print(
            f"  at {count} random interpolated points (seed {seed}), direct solves: worst true error "
            + ", ".join(f"{n} {true[:, q].max():.2e}" for q, n in enumerate(CRYSTAL_NAMES))
            + "; map error >= true error at "
            + ", ".join(f"{n} {int(covered[:, k].sum())}/{count}" for k, n in enumerate(CRYSTAL_NAMES))
            + " points"
        )
        under = ~covered[:, q]
        if under.any():
            print(
                f"  {CRYSTAL_REFINED} under-estimated at {int(under.sum())} point(s): true error "
                + ", ".join(f"{t:.1e} (map error {e:.1e})" for t, e in zip(true[under, q], estimate[under, q]))
            )
        for target, (strides, alone, count_uniform, error) in uniform.items():
            print(
                f"  smallest uniform sub-grid with {CRYSTAL_REFINED} within {target:.2e} at the points: every "
                f"{strides}-th index per axis ({count_uniform} points; each axis alone allowed {alone}), worst "
                f"{error:.2e}; adaptive / uniform = {info['solves'] / count_uniform:.2f}"
            )
        print(f"  adaptive / full grid = {info['solves'] / info['scenes']:.3f}")
        print(f"  direct solves of the check: {len(solved.cache)}")


def exact_map(aspect: np.ndarray, nu: np.ndarray) -> dict[str, np.ndarray]:
    from hpcontact.analytic import mindlin_ellipse_stiffness

    ka, kb = mindlin_ellipse_stiffness(1.0, aspect[:, None], 1.0, nu[None, :])
    return {"K_a_over_K_b": ka / kb, "K_xx": ka, "K_yy": kb}


def measure(path: Path) -> dict[str, float]:
    import xarray as xr

    with xr.open_dataset(path) as ds:
        exact = exact_map(ds["aspect"].values, ds["nu"].values)
        worst, honest = {}, []
        for name in NAMES:
            true = np.abs(ds[name].values / exact[name] - 1.0)
            worst[name] = float(true.max())
            honest.append(float(np.mean(ds[f"{name}_map_error"].values >= true)))
        return {
            "solves": int(ds.attrs["sweep_solves"]),
            "rounds": int(ds.attrs["adaptive_rounds"]),
            **{f"worst_{n}": w for n, w in worst.items()},
            "honest": min(honest),
            "estimate": float(ds.attrs["adaptive_max_map_error"]),
        }


def run(task_function, output: Path, team) -> tuple[dict[str, float], float]:
    from hpcontact.sweep.driver import run_sweep

    folder = Path(tempfile.mkdtemp(prefix="adaptive-maps-")) if team.rank == 0 else None
    folder = Path(team.bcast(str(folder) if folder else None))
    spec = folder / "mindlin.toml"
    if team.rank == 0:
        spec.write_text(SPEC)
    team.barrier()
    started = time.perf_counter()
    run_sweep(spec, output=output, task_function=task_function, team=team, stream=io.StringIO(), options=None)
    wall = time.perf_counter() - started
    if team.rank == 0:
        shutil.rmtree(folder, ignore_errors=True)
        shutil.rmtree(output.with_name(output.name + ".journal"), ignore_errors=True)
    return (measure(output) if team.rank == 0 else {}), wall


def uniform(target: float) -> tuple[int, float, tuple[int, int]]:
    """The smallest uniform sub-grid whose cubic interpolant of the exact map is within ``target``."""
    from hpcontact.numerics.interpolation import TensorInterpolant

    aspect, nu = np.logspace(0, -4, 41), np.linspace(0, 0.5, 21)
    exact = exact_map(aspect, nu)
    data = np.stack([exact[n] for n in NAMES], axis=-1)
    best = None
    for sa in (1, 2, 4, 5, 8, 10, 20, 40):
        for sn in (1, 2, 4, 5, 10, 20):
            nodes = [list(range(0, 41, sa)), list(range(0, 21, sn))]
            values = TensorInterpolant([np.log10(aspect), nu], nodes).values(data[np.ix_(*nodes)])
            worst = float(np.max(np.abs(values / data - 1.0)))
            count = len(nodes[0]) * len(nodes[1])
            if worst <= target and (best is None or count < best[0]):
                best = (count, worst, (sa, sn))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--real", action="store_true", help="also the real solver (minutes; run under mpiexec)")
    parser.add_argument("--output", default="results/adaptive_mindlin.nc")
    parser.add_argument("--python-adaptive", metavar="PY", help="a Python with python-adaptive installed")
    parser.add_argument("--chunk", type=int, default=25, help="python-adaptive: points between checks (default 25)")
    parser.add_argument(
        "--max-points", type=int, default=20000, help="python-adaptive: points per learner at most (default 20000)"
    )
    parser.add_argument(
        "--budget", type=float, default=300.0, help="python-adaptive: seconds per learner at most (default 300)"
    )
    parser.add_argument("--crystal", action="store_true", help="the 4-D crystal map alone (minutes; run under mpiexec)")
    parser.add_argument("--crystal-output", default="results/adaptive_crystal.nc")
    parser.add_argument("--reuse", action="store_true", help="--crystal: check the existing output, no sweep")
    parser.add_argument("--points", type=int, default=50, help="random points of the crystal check (default 50)")
    parser.add_argument("--seed", type=int, default=27, help="their seed (default 27)")
    args = parser.parse_args()
    if args.crystal:
        from hpcontact.sweep.run.schedule import world

        crystal(world(), Path(args.crystal_output), args.points, args.seed, args.reuse)
        return
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "sweep" / "maps"))
    from test_adaptive import mindlin  # the stand-in of the unit test

    from hpcontact.sweep.run.schedule import SerialTeam, world

    team = world()
    rows = []
    if team.rank == 0:
        with tempfile.TemporaryDirectory() as tmp:
            result, wall = run(mindlin, Path(tmp) / "standin.nc", SerialTeam())
        rows.append(("adaptive, closed-form stand-in", result, wall))
    if args.real:
        output = Path(args.output)
        if team.rank == 0:
            output.parent.mkdir(parents=True, exist_ok=True)
            output.unlink(missing_ok=True)
        result, wall = run(None, output, team)
        rows.append((f"adaptive, real solver ({team.size} rank(s))", result, wall))
    if team.rank != 0:
        return
    print(
        f"{'run':40s} {'solves':>6s} {'rounds':>6s} {'K_a/K_b':>9s} {'K_xx':>9s} {'K_yy':>9s} {'honest':>7s} {'est':>9s} {'wall s':>7s}"
    )
    for label, r, wall in rows:
        print(
            f"{label:40s} {r['solves']:6d} {r['rounds']:6d} {r['worst_K_a_over_K_b']:9.2e} {r['worst_K_xx']:9.2e} "
            f"{r['worst_K_yy']:9.2e} {r['honest']:7.3f} {r['estimate']:9.2e} {wall:7.1f}"
        )
    target = max(rows[-1][1][f"worst_{n}"] for n in NAMES)
    count, worst, strides = uniform(target)
    print(
        f"{'uniform sub-grid, exact values':40s} {count:6d} {'':6s} worst {worst:.2e} over the three "
        f"(every {strides[0]}-th b/a, {strides[1]}-th nu) for the adaptive run's worst {target:.2e}"
    )
    if args.python_adaptive:
        out = subprocess.run(
            [args.python_adaptive, "-c", CHILD, str(args.chunk), str(args.max_points), str(args.budget), "1e-3"],
            capture_output=True,
            text=True,
            check=False,
        )
        if out.returncode != 0:
            print(f"python-adaptive: failed: {out.stderr.strip().splitlines()[-1:]}")
        else:
            for name, reached in json.loads(out.stdout.strip().splitlines()[-1]).items():
                shown = (
                    f"not reached ({args.max_points} points or {args.budget:.0f} s)"
                    if reached is None
                    else f"{reached[0]} points (worst {reached[1]:.2e}, {reached[2]:.0f} s)"
                )
                print(f"python-adaptive {name}, K_a/K_b, chunks of {args.chunk}: {shown}")


if __name__ == "__main__":
    main()
