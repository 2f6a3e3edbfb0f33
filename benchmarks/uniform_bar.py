"""The uniform sub-grids of the 4-D crystal map judged at every direct solve at hand (issue 40's bar).

    python benchmarks/uniform_bar.py --journals DIR [DIR ...] [--solve 3323 4323 ...] [--solved FILE] [--workers 2]

The map is jobs/adaptive_orientation_map.toml's: b/a logspace(0, −3, 25) × nu linspace(0.05, 0.45,
9) × A linspace(0.5, 3, 21) × ψ linspace(0, 90, 31), K_a/K_b of the bonded ellipse on one exact
cell at accuracy 1e-6 (at A = 1 the body is isotropic: one scene for every ψ). Issue 40 asks for
an adaptive map within 1.5 × "the smallest uniform sub-grid that meets the same tolerance"; the
bar on record (docs/howto/adaptive.md, 2026-11-26) was every 3rd index of each axis, 3 168 solves,
judged at 50 random points. Here a sub-grid is every k_d-th index of axis d (the last included:
``strides`` 3323 = every 3rd b/a, 3rd nu, 2nd A, 3rd ψ), interpolated as the adaptive map's leaves
interpolate (``TensorInterpolant``: local cubic Lagrange per axis, b/a in log10), and judged
against every solve at hand that is not one of its nodes: the finished records of the journals
given (an adaptive run's nodes and checks) and of ``--solved`` (this script's own solves). A
sub-grid is printed when all its nodes are at hand; ``--solve`` first solves the nodes the named
sub-grids lack (``solve_to_accuracy``, as a task of the map does; appended to ``--solved``).

What it says and what it cannot: a sub-grid over the tolerance at a point solved is shown not to
meet it; one within it at every point at hand is not proven to meet it at the grid points not
solved (most of the grid). The solves are counted as distinct scenes.
"""

from __future__ import annotations

import argparse
import glob
import itertools
import json
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from hpcontact.numerics.interpolation import weights

AXES = ("aspect", "nu", "anisotropy", "orientation")
VALUES = (np.logspace(0, -3, 25), np.linspace(0.05, 0.45, 9), np.linspace(0.5, 3.0, 21), np.linspace(0, 90, 31))
COORDINATES = (np.log10(VALUES[0]), *VALUES[1:])
ISOTROPIC = 4  # the index of A = 1
TOLERANCE = 1e-3


def nodes(n: int, stride: int) -> list[int]:
    """Every ``stride``-th index of ``0 … n-1``, the last one included."""
    return sorted(set(range(0, n, stride)) | {n - 1})


def sub_grid(strides: tuple[int, ...]) -> list[list[int]]:
    return [nodes(len(v), k) for v, k in zip(VALUES, strides)]


def scenes(grid: list[list[int]]) -> int:
    """Distinct scenes of a sub-grid (at A = 1 one for every ψ)."""
    count = int(np.prod([len(n) for n in grid]))
    return count - (len(grid[0]) * len(grid[1]) * (len(grid[3]) - 1) if ISOTROPIC in grid[2] else 0)


def put(truth: np.ndarray, index: tuple[int, ...], value: float) -> None:
    if index[2] == ISOTROPIC:
        truth[index[0], index[1], ISOTROPIC, :] = value
    else:
        truth[index] = value


def _index(value: float, values: np.ndarray) -> int | None:
    i = int(np.argmin(np.abs(values - value)))
    return i if abs(values[i] - value) <= 1e-9 * max(1.0, abs(value)) else None


def truth_at_hand(journals: list[str], solved: Path | None) -> np.ndarray:
    """K_a/K_b at every grid point a journal or ``solved`` holds a finished solve of (NaN elsewhere)."""
    truth = np.full(tuple(len(v) for v in VALUES), np.nan)
    for folder in journals:
        for path in glob.glob(str(Path(folder) / "*.jsonl")):
            for line in open(path):
                try:
                    body = json.loads(line.split(" ", 1)[1])
                except (IndexError, json.JSONDecodeError):
                    continue
                if body.get("event") != "finished" or "K_a_over_K_b" not in body.get("record", {}):
                    continue
                index = tuple(_index(float(body["params"].get(a, 0.0)), v) for a, v in zip(AXES, VALUES))
                if None not in index:
                    put(truth, index, float(body["record"]["K_a_over_K_b"]))
    if solved is not None and solved.exists():
        for line in open(solved):
            index, value = json.loads(line)
            put(truth, tuple(index), value)
    return truth


def solve(index: tuple[int, ...]) -> tuple[tuple[int, ...], float]:
    """The map's task at ``index``: the bonded ellipse on one exact cell to accuracy 1e-6."""
    from hpcontact.accuracy import solve_to_accuracy
    from hpcontact.scene import Scene

    params = {"shape": "ellipse", "quantities": ["tangential", "normal"]}
    params.update({a: float(v[i]) for a, v, i in zip(AXES, VALUES, index)})
    return index, float(solve_to_accuracy(Scene.from_params(params), 1e-6, strategy="auto")["K_a_over_K_b"])


def solve_missing(truth: np.ndarray, strides: list[tuple[int, ...]], solved: Path, workers: int) -> None:
    todo = sorted(
        {
            g
            for s in strides
            for g in itertools.product(*sub_grid(s))
            if np.isnan(truth[g]) and not (g[2] == ISOTROPIC and g[3] != 0)
        }
    )
    print(f"solving {len(todo)} scene(s) the sub-grids {', '.join(map(_name, strides))} lack", flush=True)
    started = time.perf_counter()
    with open(solved, "a") as out, Pool(workers) as pool:
        for k, (index, value) in enumerate(pool.imap_unordered(solve, todo, chunksize=4), 1):
            out.write(json.dumps([list(index), value]) + "\n")
            put(truth, index, value)
            if k % 500 == 0 or k == len(todo):
                print(f"  {k}/{len(todo)}, {time.perf_counter() - started:.0f} s", flush=True)


def _name(strides: tuple[int, ...]) -> str:
    return "".join(map(str, strides))


def _apply(matrices: list[np.ndarray], data: np.ndarray) -> np.ndarray:
    """``data`` at the nodes taken to the full grid, one interpolation matrix per axis."""
    out = data
    for axis, matrix in enumerate(matrices):
        out = np.moveaxis(np.tensordot(matrix, out, axes=([1], [axis])), 0, axis)
    return out


def judge(truth: np.ndarray, largest: int) -> list[tuple[int, str, int, float, int, int]]:
    """(scenes, strides, points judged, worst relative error, points over the tolerance, nodes not
    at hand) of every sub-grid of strides 1 … 6 per axis of at most ``largest`` scenes. The cubic
    interpolant is local: a point is judged where every node of its stencil is at hand (its
    value then is the sub-grid's whole interpolant's), so a sub-grid with nodes missing can still
    be shown over the tolerance; it is shown within it only with every node at hand."""
    rows = []
    for strides in itertools.product(range(1, 7), repeat=len(VALUES)):
        grid = sub_grid(strides)
        count = scenes(grid)
        if count > largest:
            continue
        matrices = [weights(x, n) for x, n in zip(COORDINATES, grid)]
        data = truth[np.ix_(*grid)]
        missing = np.isnan(data)
        values = _apply(matrices, np.where(missing, 0.0, data))
        blind = _apply([np.abs(m) for m in matrices], missing.astype(float)) > 0.0
        judged = np.isfinite(truth) & ~blind
        judged[np.ix_(*grid)] = False
        error = np.abs(values[judged] / truth[judged] - 1.0)
        unknown = int(sum(1 for g in np.argwhere(missing) if not (grid[2][g[2]] == ISOTROPIC and grid[3][g[3]] != 0)))
        worst = float(error.max()) if error.size else float("nan")
        rows.append((count, _name(strides), int(judged.sum()), worst, int((error > TOLERANCE).sum()), unknown))
    return sorted(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--journals", nargs="+", default=[], help="journal folders of runs of the map")
    parser.add_argument(
        "--solve", nargs="*", default=[], help="sub-grids (strides, e.g. 3323) whose missing nodes to solve"
    )
    parser.add_argument("--solved", type=Path, default=Path("results/uniform_bar_solves.jsonl"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--largest", type=int, default=8000, help="judge sub-grids of at most this many scenes")
    args = parser.parse_args()
    truth = truth_at_hand(args.journals, args.solved)
    print(f"{int(np.isfinite(truth).sum())} grid points solved at hand (of {truth.size})")
    if args.solve:
        solve_missing(truth, [tuple(int(c) for c in s) for s in args.solve], args.solved, args.workers)
    rows = judge(truth, args.largest)
    print("scenes  strides  judged at  worst error  over 1e-3  nodes not at hand")
    for count, name, judged, worst, over, unknown in rows:
        verdict = "fails" if over else ("meets at every point at hand" if unknown == 0 else "not judged")
        print(f"{count:6d}  {name:>7}  {judged:9d}  {worst:11.2e}  {over:9d}  {unknown:17d}  {verdict}")
    meets = [r for r in rows if r[4] == 0 and r[5] == 0]
    if meets:
        smallest = meets[0][0]
        open_below = [r for r in rows if r[0] < smallest and r[4] == 0]
        print(
            f"smallest sub-grid within {TOLERANCE:g} at every point at hand: {meets[0][1]}, {smallest} scenes; "
            f"smaller ones not shown over it: {len(open_below)}"
            + (f" (the smallest {open_below[0][1]}, {open_below[0][0]} scenes)" if open_below else "")
        )


if __name__ == "__main__":
    main()
