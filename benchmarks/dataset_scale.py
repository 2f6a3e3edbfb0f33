"""Data set assembly at scale: a six-axis sweep of 2·10^5 task points from synthetic journal entries.

    python benchmarks/dataset_scale.py [--folder DIR] [--keep]

The sweep of issue 13: 10 shapes × 37 load angles (tensor mode: free) × 6 nu × 17 b/a × 11
anisotropy factors × 19 orientations = 213 180 task points (7.9 million points with the angle).
Shapes that ignore b/a and isotropic bodies (A = 1) that ignore the orientation share tasks, as
in a real sweep. Each task gets a synthetic crystal-tangential record (smooth functions of the
scene at full float64 precision, so they compress like solver output, and one of four plans),
written to two ranks' journals (``journal.Journal``). Rank 0's assembly is then timed as the
driver runs it: ``read_journals``, ``build_dataset`` (entries → labelled hypercube) and
``write_netcdf`` (compressed file); then ``hpcontact.open_dataset`` with the full hypercube
loaded. Printed: the times, the peak resident memory of this process (measured in a child
process that only assembles, so the journal writing does not count), the file size and the
in-memory size of the opened hypercube. Targets (issue 13): assembly ≤ 60 s, peak memory ≤
2 GB, file ≤ 60 MB.
"""

from __future__ import annotations

import argparse
import math
import shutil
import tempfile
from functools import partial
from pathlib import Path

import harness

import hpcontact
from hpcontact.sweep.data.dataset import build_dataset, write_netcdf
from hpcontact.sweep.data.journal import OK, Entry, Journal, read_journals
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_tasks

SPEC = """
[sweep]
title = "dataset scale: six axes, 2e5 task points"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 64
[axes]
shape = [
    "ellipse", "rectangle",
    { label = "triangle", shape = "polygon", sides = 3 }, { label = "square", shape = "polygon", sides = 4 },
    { label = "pentagon", shape = "polygon", sides = 5 }, { label = "hexagon", shape = "polygon", sides = 6 },
    { label = "heptagon", shape = "polygon", sides = 7 }, { label = "octagon", shape = "polygon", sides = 8 },
    { label = "star5", shape = "star", sides = 5, amplitude = 0.3 }, { label = "star6", shape = "star", sides = 6, amplitude = 0.3 },
]
angle = { linspace = [0, 180, 37] }
nu = { linspace = [0.0, 0.5, 6] }
aspect = { logspace = [0, -8, 17] }
anisotropy = { linspace = [0.5, 3.0, 11] }
orientation = { linspace = [0, 90, 19] }
"""
PLANS = [
    {"kernels": ["xx", "xy", "yx", "yy", "zz"], "solves": s, "preconditioner": p} for s in (3, 4) for p in (True, False)
]


def record(key: str, params: dict) -> dict:
    """A synthetic crystal-tangential record: smooth in the scene, with a relative perturbation
    of up to 1e-6 drawn from the task key standing in for discretization error, so that the
    low mantissa bits are as incompressible as a solver's."""
    noise = 1.0 + 1e-6 * int(key[:8], 16) / 2**32
    nu = params.get("nu", 0.3)
    aspect = params.get("aspect", 1.0)
    a = params.get("anisotropy", 1.0)
    psi = math.radians(params.get("orientation", 0.0))
    sides = params.get("sides", 0)
    kxx = (1.0 + nu) * (1.0 + 0.01 * sides) * (1.0 + 0.1 * (a - 1.0) * math.cos(2.0 * psi)) * aspect**0.01 * noise
    kyy = kxx / aspect**0.05 * (1.0 + 0.05 * (a - 1.0) * math.sin(psi))
    kxy = 1e-3 * (a - 1.0) * math.sin(2.0 * psi)
    return {
        "K_xx": kxx,
        "K_xy": kxy,
        "K_yx": kxy * (1.0 + 1e-9),
        "K_yy": kyy,
        "K_zz": 2.0 * kxx / (1.0 - nu / 2),
        "K_max": max(kxx, kyy) + abs(kxy),
        "K_min": min(kxx, kyy) - abs(kxy),
        "principal_angle_deg": math.degrees(psi),
        "K_a_over_K_b": kxx / kyy,
        "K_min_over_K_max": min(kxx, kyy) / max(kxx, kyy),
        "asymmetry": 1e-9 * abs(kxy),
        "iterations": 40 + sides + int(10 * a),
        "residual": 1e-9 * (1.0 + nu),
        "nx": 64,
        "ny": max(16, round(64 * aspect)),
        "dx": 2.0 / 64,
        "dy": 2.0 * aspect / max(16, round(64 * aspect)),
        "contact_cells": int(3000 * aspect**0.5) + sides,
        "plan": PLANS[(sides + int(a == 1.0)) % len(PLANS)],
    }


def write_journals(folder: Path) -> tuple[int, int]:
    """Synthetic journals of the sweep in ``folder`` (two ranks, tasks dealt alternately):
    (task points, distinct tasks)."""
    spec = parse_spec(SPEC, validate=lambda params: None)
    tasks, where = enumerate_tasks(spec)
    folder.mkdir(parents=True, exist_ok=True)
    journals = [Journal(folder / f"rank{rank:05d}-synthetic.jsonl", rank, {"session": "synthetic"}) for rank in (0, 1)]
    for i, t in enumerate(tasks):
        journals[i % 2].append(
            Entry(
                key=t.key,
                params=t.params,
                status=OK,
                message="",
                record=record(t.key, dict(t.params)),
                wall_time_s=1.0,
                finished=0.0,
                rank=i % 2,
            )
        )
    for journal in journals:
        journal.close()
    return len(where), len(tasks)


def assemble(folder: str) -> dict:
    """Rank 0's assembly from the journals in ``folder``, then the data set opened again (run in
    a fresh process: the peak memory is the assembly's own)."""
    folder = Path(folder)
    spec = parse_spec(SPEC, validate=lambda params: None)
    enumerated = harness.timed(lambda: enumerate_tasks(spec)[1])
    where = enumerated.value
    before_mb = harness.peak_rss_mb()
    read = harness.timed(partial(read_journals, folder / "journal"))
    build = harness.timed(
        partial(build_dataset, spec, where, read.value, {"history": "benchmarks/dataset_scale.py", "mpi_size": 2})
    )
    write = harness.timed(partial(write_netcdf, build.value, folder / "scale.nc"))
    path, read_s, build_s = write.value, read.wall_s, build.wall_s
    assembly_mb = harness.peak_rss_mb()
    del build, read  # the data set and the entries, before the file is opened again

    def load():
        with hpcontact.open_dataset(path) as back:
            return back.load()

    opened = harness.timed(load)
    return {
        "tasks_s": enumerated.wall_s,
        "read_s": read_s,
        "build_s": build_s,
        "write_s": write.wall_s,
        "before_mb": before_mb,
        "assembly_mb": assembly_mb,
        "size_mb": path.stat().st_size / 1e6,
        "open_s": opened.wall_s,
        "loaded_mb": opened.value.nbytes / 1e6,
        "points": math.prod(len(a) for a in spec.axes),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--folder", type=Path, help="where to write journals and data set (default: a temporary folder)"
    )
    parser.add_argument("--keep", action="store_true", help="keep them")
    args = parser.parse_args()
    print(f"dataset_scale: {harness.machine_line(1)}")
    folder = args.folder or Path(tempfile.mkdtemp(prefix="dataset_scale-"))
    written = harness.timed(lambda: write_journals(folder / "journal"))
    points, distinct = written.value
    print(f"{points} task points, {distinct} distinct tasks; synthetic journals written in {written.wall_s:.1f} s")
    m = harness.call_in_child(__file__, "assemble", str(folder.resolve()), check=True).result
    assembly = m["read_s"] + m["build_s"] + m["write_s"]
    print(f"{m['points']} points with the angle; task enumeration {m['tasks_s']:.1f} s (before the sweep runs)")
    print(
        f"assembly: read journals {m['read_s']:.1f} s + build {m['build_s']:.1f} s + write {m['write_s']:.1f} s "
        f"= {assembly:.1f} s (target <= 60 s)"
    )
    print(
        f"peak memory of rank 0: {m['assembly_mb']:.0f} MB (target <= 2048 MB; {m['before_mb']:.0f} MB before "
        f"reading the journals)"
    )
    print(f"file: {m['size_mb']:.1f} MB on disk (target <= 60 MB)")
    print(f"open_dataset + load: {m['open_s']:.1f} s, {m['loaded_mb']:.0f} MB in memory (K_nn, normalized_nn stored)")
    if not args.keep and args.folder is None:
        shutil.rmtree(folder)


if __name__ == "__main__":
    harness.entry(main)
