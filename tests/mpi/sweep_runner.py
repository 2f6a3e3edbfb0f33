"""A sweep run for ``test_kill_resume``, ``test_oversubscribed`` and ``test_parallel_sweep``: the
real solver (or, with ``--synthetic``, ``synthetic``), with each task's start logged per rank.
Synthetic records carry the same bits in any process; real solves do only when every process
uses the same FFTW plans (``HPCONTACT_FFTW_PLANNER=FFTW_ESTIMATE`` in the environment).

``python sweep_runner.py SPEC --output PATH --log DIR [--resume] [--delay S] [--synthetic]
[--parent PID]`` (under mpiexec): before each task, the rank appends ``pid key`` to
``DIR/rank{R}.log`` and waits ``--delay`` seconds, so a test can see what started where and kill a
rank mid-sweep. The rank is the team's (``MPI.COMM_WORLD``), whatever launcher started the
processes. With ``--parent``, a rank ends itself once that process (the test's pytest) is gone:
a pytest killed mid-test runs no fixture clean-up, and a rank left waiting for its dead peer
spun a core for 1.5 h (2026-11-23).
"""

from __future__ import annotations

import argparse
import math
import os
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from hpcontact.problems.contact import solve
from hpcontact.scene import Scene
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run.schedule import world
from hpcontact.sweep.work.tasks import task_key


def synthetic(params: Mapping[str, Any]) -> dict[str, Any]:
    """A record computed exactly from the scene (the same bits in any process): numbers, an
    integer, a text only some records have and a JSON plan; the rectangle at nu = 0.3 raises
    (an error status with its message)."""
    shape, nu, aspect = params.get("shape"), float(params.get("nu", 0.0)), float(params.get("aspect", 1.0))
    if shape == "rectangle" and nu == 0.3:
        raise RuntimeError(f"synthetic failure at b/a = {aspect}")
    record: dict[str, Any] = {
        "K_xx": (1.0 + nu) * math.sqrt(aspect),
        "K_yy": math.log1p(aspect) / (2.0 - nu),
        "iterations": 10 + int(params.get("sides", 0)),
        "plan": {"shape": shape, "thin": aspect < 0.1},
    }
    if aspect < 0.1:
        record["note"] = f"thin: b/a = {aspect}"
    return record


def end_with(parent: int, poll_s: float = 1.0) -> None:
    """End this process (exit status 3) once process ``parent`` no longer exists (a daemon thread)."""

    def watch() -> None:
        while True:
            time.sleep(poll_s)
            try:
                os.kill(parent, 0)
            except ProcessLookupError:
                os._exit(3)
            except PermissionError:  # exists, owned by someone else
                pass

    threading.Thread(target=watch, name="end-with-parent", daemon=True).start()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("spec")
    parser.add_argument("--output", required=True)
    parser.add_argument("--log", required=True)
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--delay", type=float, default=0.0)
    parser.add_argument("--synthetic", action="store_true", help="tasks return ``synthetic`` records")
    parser.add_argument("--parent", type=int, help="end this rank once process PID is gone")
    args = parser.parse_args()
    if args.parent is not None:
        end_with(args.parent)
    team = world()
    log = Path(args.log) / f"rank{team.rank}.log"

    def task(params: Mapping[str, Any]) -> dict[str, Any]:
        with open(log, "a", encoding="utf-8") as fh:
            fh.write(f"{os.getpid()} {task_key(params)}\n")
        time.sleep(args.delay)
        return synthetic(params) if args.synthetic else solve(Scene.from_params(params))

    run_sweep(args.spec, resume=args.resume, output=args.output, task_function=task, team=team)


if __name__ == "__main__":
    main()
