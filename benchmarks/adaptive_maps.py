"""Adaptive maps (issue 27): solves needed for Mindlin's map K_a/K_b, adaptive vs uniform vs python-adaptive.

    python benchmarks/adaptive_maps.py [--python-adaptive /tmp/adaptive-venv/bin/python]
    mpiexec -n 2 python benchmarks/adaptive_maps.py --real [--output results/adaptive_mindlin.nc]

The map: bonded ellipse, tangential, b/a ∈ logspace(0, −4, 41) × nu ∈ linspace(0, 0.5, 21) (861
points), ``[adaptive] tolerance = 1e-3``, ``[numerics] accuracy = 1e-4``; the truth is Mindlin's
closed form (``analytic.mindlin_ellipse_stiffness``). Columns: solves, the worst true relative
error over the 861 points of K_a/K_b, K_xx = K_a and K_yy = K_b, the fraction of points whose
``<name>_map_error`` is >= the true error (worst over the three), the wall time.

* ``--real``: the adaptive sweep with the real solver (every rank: ``run_sweep`` on the MPI
  world; minutes on 2 cores, the solves cost 0.3-9 s each).
* always: the same sweep on the closed-form stand-in of tests/sweep/test_adaptive.py (Mindlin
  perturbed by <= 5e-5, ``<name>_error`` = 1e-4; seconds), and the smallest *uniform* sub-grid
  (every s_a-th b/a and s_nu-th nu, ends included, the same cubic interpolation in log b/a and
  nu) whose worst true error of the exact closed form (optimistic for uniform: no solve error)
  is at most the adaptive run's.
* ``--python-adaptive PY``: python-adaptive's ``Learner2D`` and ``LearnerND`` (their default
  losses, in PY, a separate environment with ``adaptive``; never a dependency of hpcontact) on
  the exact ratio over (log10 b/a, nu), run until the worst error of their points' linear
  interpolant (scipy LinearNDInterpolator, as Learner2D's) on the 861 grid points is at most
  1e-3 (the tolerance) and at most the adaptive run's worst K_a/K_b error (at most 2000 points). Their points are not grid points: the comparison counts solves alone.
"""

from __future__ import annotations

import argparse
import io
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
import json, sys
import numpy as np
from scipy.special import ellipkm1, elliprd
import adaptive

def ratio(x):
    log_g, nu = x
    g = 10.0 ** log_g
    p = g * g
    K = ellipkm1(p); D = elliprd(0.0, p, 1.0) / 3.0; B = p * elliprd(0.0, 1.0, p) / 3.0
    return (K - nu * D) / (K - nu * B)

from scipy.interpolate import LinearNDInterpolator
X, Y = np.meshgrid(np.linspace(0, -4, 41), np.linspace(0, 0.5, 21), indexing="ij")
grid = np.stack([X.ravel(), Y.ravel()], axis=1)
exact = np.array([ratio(p) for p in grid])
out = {}
for target in map(float, sys.argv[1:]):
    for name, make in (("Learner2D", lambda: adaptive.Learner2D(ratio, bounds=[(-4, 0), (0, 0.5)])),
                       ("LearnerND", lambda: adaptive.LearnerND(ratio, bounds=[(-4, 0), (0, 0.5)]))):
        learner = make()
        reached = None
        while learner.npoints < 2000:
            points, _ = learner.ask(10)
            for p in points:
                learner.tell(p, ratio(p))
            data = learner.data
            values = LinearNDInterpolator(np.array(list(data)), np.array(list(data.values())))(grid)
            worst = float(np.nanmax(np.abs(values / exact - 1.0)))
            if worst <= target:
                reached = (learner.npoints, worst)
                break
        out[f"{name} to {target:.2e}"] = reached
print(json.dumps(out))
"""


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
    from hpcontact.sweep.interpolation import TensorInterpolant

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
    args = parser.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "sweep"))
    from test_adaptive import mindlin  # the stand-in of the unit test

    from hpcontact.sweep.schedule import SerialTeam, world

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
        ratio_target = rows[-1][1]["worst_K_a_over_K_b"]
        out = subprocess.run(
            [args.python_adaptive, "-c", CHILD, "1e-3", repr(ratio_target)], capture_output=True, text=True, check=False
        )
        if out.returncode != 0:
            print(f"python-adaptive: failed: {out.stderr.strip().splitlines()[-1:]}")
        else:
            for name, reached in json.loads(out.stdout.strip().splitlines()[-1]).items():
                shown = (
                    "not reached in 2000 points" if reached is None else f"{reached[0]} points (worst {reached[1]:.2e})"
                )
                print(f"python-adaptive {name}, K_a/K_b: {shown}")


if __name__ == "__main__":
    main()
