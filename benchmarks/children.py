"""Run one benchmark measurement in a fresh child process (cold FFTW planning, its own peak memory).

Shared by ``solve_speed.py`` and ``vs_peers.py``: the script re-runs itself with
``--child JSON`` and prints the measurement as one JSON line; thread-count variables are set
to the spec's ``threads`` so that BLAS, OpenMP and FFTW all use the same number.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

THREAD_VARIABLES = ("HPCONTACT_BLAS_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def run_child(script: str, spec: dict, timeout: float) -> dict:
    """The JSON result of ``python script --child spec``, or ``spec`` with an ``error`` entry."""
    env = dict(os.environ)
    for var in THREAD_VARIABLES:
        env[var] = str(spec["threads"])
    try:
        out = subprocess.run(
            [sys.executable, os.path.abspath(script), "--child", json.dumps(spec)],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        return {**spec, "error": f"did not finish within {timeout:.0f} s"}
    lines = [line for line in out.stdout.splitlines() if line.startswith("{")]
    if out.returncode != 0 or not lines:
        tail = (out.stderr.strip().splitlines() or ["no output"])[-1]
        return {**spec, "error": f"failed: {tail}"}
    return json.loads(lines[-1])


def add_run_options(parser: argparse.ArgumentParser, timeout: float) -> None:
    """Options every benchmark shares: per-run timeout, clock, JSON output, the child entry."""
    parser.add_argument("--timeout", type=float, default=timeout, help=f"seconds per run (default {timeout:.0f})")
    parser.add_argument("--clock", choices=["wall", "cpu"], default="wall",
                        help="wall: elapsed time (default); cpu: each run's process CPU time, robust on a loaded "
                             "machine but meaningful with --threads 1 only")
    parser.add_argument("--json", help="also write the rows to this JSON file")
    parser.add_argument("--child", help=argparse.SUPPRESS)
