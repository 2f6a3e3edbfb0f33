"""Dry runs of sweeps with one long axis: 10^4, 10^5 and 10^6 points (issue 30: 10^6 in ≤ 30 s).

    python benchmarks/dry_run_points.py [--points 10000 100000 1000000] [--kinds nu aspect ...]
        [--json-output] [--phases] [--code TREE ...] [--timeout 600] [--json FILE]

Each dry run is ``python -m hpcontact run SPEC --dry-run`` in a fresh process (its wall and CPU
seconds and peak resident memory from ``harness.run_child``), on a spec with one axis of N
values and every other field fixed, every point a distinct task:

* ``nu``: an ellipse of b/a = 0.5 (n = 64, tangential and normal) over nu = linspace(0, 0.5, N):
  a field that changes neither the grid nor the cost;
* ``aspect``: an ellipse (n = 64) over b/a = logspace(0, -8, N): a grid per value;
* ``orientation``: a cubic crystal (nu = 0.3, A = 2, n = 32, tangential) over
  ψ = linspace(0, 90, N): a crystal per value, which the scene check would rotate at ~1 ms each;
* ``rotated``: an ellipse of b/a = 0.5 turned by angle = linspace(0, 180, N) in rotated mode
  (``angle_mode = "rotated"``): a turned shape, and its grid, per value.

The text output lists the first and last tasks of a long sweep; ``--json-output`` prints the
JSON object instead, which lists every task (written to a file, not kept). No run calibrates: a
synthetic calibration (round numbers, as the tests') is written for each code tree first
(``HPCONTACT_COSTMODEL``). ``--code TREE ...`` times the same dry runs with hpcontact imported
from other source trees (e.g. ``git worktree add /tmp/before <commit>`` and ``.``), side by
side, so that speed-ups are ratios measured in the same run; a tree that times out at N points
is not run at larger N. ``--phases`` adds, for this checkout only, the seconds per point of each
phase of the dry run measured in one process (spec, enumeration with the scene check, join, cost
estimate, output). Printed per run: points, tasks, wall and CPU seconds, µs per point, peak
resident MiB.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import socket
import sys
import tempfile
import time
from pathlib import Path

import harness

SPECS = {
    "nu": (
        '[scene]\nshape = "ellipse"\naspect = 0.5\nquantities = ["tangential", "normal"]\n[numerics]\nn = 64\n'
        "tol = 1e-10\n[axes]\nnu = {{ linspace = [0, 0.5, {points}] }}\n"
    ),
    "aspect": (
        '[scene]\nshape = "ellipse"\nnu = 0.3\nquantities = ["tangential", "normal"]\n[numerics]\nn = 64\n'
        "tol = 1e-10\n[axes]\naspect = {{ logspace = [0, -8, {points}] }}\n"
    ),
    "orientation": (
        '[scene]\nnu = 0.3\nanisotropy = 2.0\nquantities = ["tangential"]\n[numerics]\nn = 32\ntol = 1e-10\n'
        "[axes]\norientation = {{ linspace = [0, 90, {points}] }}\n"
    ),
    "rotated": (
        '[sweep]\nangle_mode = "rotated"\n[scene]\nshape = "ellipse"\naspect = 0.5\nnu = 0.3\n[numerics]\n'
        "n = 64\n[axes]\nangle = {{ linspace = [0, 180, {points}] }}\n"
    ),
}
TARGET_POINTS, TARGET_S = 10**6, 30.0  # issue 30: a 10^6-point axis dry run answers in <= 30 s


def spec_text(kind: str, points: int, output: Path) -> str:
    """The spec of ``kind`` with ``points`` values on its axis, writing (never) to ``output``."""
    body = SPECS[kind].format(points=points)
    head = f'[sweep]\ntitle = "dry run {kind} {points}"\noutput = "{output}"\n'
    return head + body.replace("[sweep]\n", "", 1) if body.startswith("[sweep]") else head + body


def write_calibration(path: str) -> str:
    """A synthetic calibration for this host and the hpcontact this process imports (1e-6 s per
    cost unit for every kind, 100 MiB base): the dry run reads it instead of calibrating."""
    from hpcontact import __version__
    from hpcontact.sweep.cost.calibration_file import save_calibration
    from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate

    rates = {kind: Rate(rate_s=1e-6, solve_s=0.0) for kind in KINDS}
    return str(save_calibration(Calibration(socket.gethostname(), __version__, rates, 100.0 * 2**20), Path(path)))


def phases(spec_path: str) -> dict[str, float]:
    """Seconds of each phase of a dry run of ``spec_path`` in this process (this checkout's API;
    the calibration of ``HPCONTACT_COSTMODEL``), and the points and tasks."""
    from hpcontact.sweep.cost.calibration_file import load_calibration
    from hpcontact.sweep.run.dry_run import dry_run
    from hpcontact.sweep.space.parse import load_spec
    from hpcontact.sweep.work.estimate import estimate
    from hpcontact.sweep.work.tasks import enumerate_part, join_parts, points

    calibration = load_calibration()
    out: dict[str, float] = {}

    def timed(name, function):
        started = time.process_time()
        value = function()
        out[name] = time.process_time() - started
        return value

    spec = timed("spec", lambda: load_spec(spec_path, check_scenes=False))
    part = timed("enumerate and check", lambda: enumerate_part(spec, check=True))
    tasks, _ = timed("join", lambda: join_parts(spec, [part]))
    timed("estimate", lambda: estimate(tasks, calibration))
    with open(os.devnull, "w", encoding="utf-8") as sink:
        total = timed("dry run", lambda: dry_run(spec_path, stream=sink, calibration=calibration))
    assert total == 0
    out["output"] = max(0.0, out.pop("dry run") - sum(out.values()))
    return {**out, "points": points(spec), "tasks": len(tasks)}


def dry_run(code: str | None, kind: str, points: int, folder: Path, as_json: bool, timeout: float) -> dict:
    """One dry run in a fresh process: wall and CPU seconds, peak MiB, tasks (or an error)."""
    spec = folder / f"{kind}_{points}.toml"
    spec.write_text(spec_text(kind, points, folder / f"{kind}.nc"), encoding="utf-8")
    listing = folder / f"{kind}_{points}.out"
    tree = Path(code).resolve() if code else None
    env = {"HPCONTACT_COSTMODEL": str(calibration_file(folder, code))}
    if tree is not None:
        env["PYTHONPATH"] = str(tree)
    if not Path(env["HPCONTACT_COSTMODEL"]).exists():
        harness.call_in_child(
            __file__, "write_calibration", env["HPCONTACT_COSTMODEL"], env=env, cwd=folder, check=True
        )
    # exec: the measured process is the dry run itself, its listing to a file (10^6 JSON entries)
    command = ["sh", "-c", 'exec "$@" > "$0"', str(listing), sys.executable, "-m", "hpcontact", "run", str(spec)]
    command += ["--dry-run"] + (["--json"] if as_json else [])
    child = harness.run_child(command, timeout=timeout, cwd=folder, env=env)  # cwd: -m imports the tree's package
    row = {"kind": kind, "points": points, "code": code or ".", "wall_s": child.wall_s, "cpu_s": child.cpu_s}
    row["peak_mb"] = child.peak_rss_mb
    if child.timed_out is not None or child.returncode != 0:
        tail = (child.stderr.strip().splitlines() or ["no output"])[-1]
        row["error"] = f"did not finish within {timeout:g} s" if child.timed_out else f"exit {child.returncode}: {tail}"
    else:
        with listing.open("rb") as fh:
            head = fh.read(4096).decode(errors="replace")
        # JSON: {"title": ..., "output": ..., "tasks": N, ...}; text: "# TITLE: N tasks -> ..."
        row["tasks"] = int(re.search(r'"tasks": (\d+)' if as_json else r": (\d+) tasks -> ", head).group(1))
    listing.unlink(missing_ok=True)
    return row


def calibration_file(folder: Path, code: str | None) -> Path:
    """Where the synthetic calibration of the source tree ``code`` (None: this checkout) goes."""
    tree = str(Path(code).resolve()) if code else "."
    return folder / f"costmodel-{hashlib.sha1(tree.encode()).hexdigest()[:12]}.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=[10**4, 10**5, 10**6], help="axis lengths")
    parser.add_argument("--kinds", nargs="+", choices=sorted(SPECS), default=list(SPECS), help="specs (see above)")
    parser.add_argument("--json-output", action="store_true", help="dry runs print JSON (every task listed)")
    parser.add_argument("--phases", action="store_true", help="also time the phases in one process (this checkout)")
    parser.add_argument("--code", nargs="+", default=[None], help="source trees to import hpcontact from")
    harness.add_run_options(parser, timeout=600.0)
    args = parser.parse_args()
    print(f"dry_run_points: {harness.machine_line(1)}")
    rows, late = [], set()
    with tempfile.TemporaryDirectory(prefix="dry_run_points-") as name:
        folder = Path(name)
        for points in sorted(args.points):
            for kind in args.kinds:
                for code in args.code:
                    if (kind, code) in late:
                        continue
                    row = dry_run(code, kind, points, folder, args.json_output, args.timeout)
                    rows.append(row)
                    shown = f"{kind:12s} {points:8d} points  {code or '.'}: "
                    if "error" in row:
                        late.add((kind, code))
                        print(f"{shown}{row['error']} (peak {row['peak_mb']:.0f} MiB)", flush=True)
                        continue
                    seconds = row["cpu_s"] if args.clock == "cpu" else row["wall_s"]
                    target = "" if points != TARGET_POINTS else f"  (target <= {TARGET_S:.0f} s)"
                    print(
                        f"{shown}{row['tasks']:8d} tasks  {row['wall_s']:7.2f} s wall  {row['cpu_s']:7.2f} s CPU  "
                        f"{1e6 * seconds / points:6.1f} µs/point  peak {row['peak_mb']:5.0f} MiB{target}",
                        flush=True,
                    )
                if args.phases:
                    spec = folder / f"{kind}_{points}.toml"
                    env = {"HPCONTACT_COSTMODEL": str(calibration_file(folder, None))}
                    times = harness.call_in_child(__file__, "phases", str(spec), env=env, check=True).result
                    rows.append({"kind": kind, "points": points, "phases_s": times})
                    steps = ", ".join(
                        f"{k} {1e6 * v / points:.1f}" for k, v in times.items() if k not in ("points", "tasks")
                    )
                    print(f"{'':12s} {points:8d} points  phases (µs/point, CPU, one process): {steps}", flush=True)
    if args.json:
        harness.write_json(args.json, {"machine": harness.machine_line(1), "runs": rows})


if __name__ == "__main__":
    harness.entry(main)
