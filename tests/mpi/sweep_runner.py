"""A sweep run for ``test_kill_resume``: the real solver, with each task's start logged per rank.

``python sweep_runner.py SPEC --output PATH --log DIR [--resume] [--delay S]`` (under mpiexec):
before each task, the rank appends ``pid key`` to ``DIR/rank{R}.log`` and waits ``--delay``
seconds, so a test can see what started where and kill a rank mid-sweep. The rank is the
team's (``MPI.COMM_WORLD``), whatever launcher started the processes.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from hpcontact.solve import solve
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.schedule import world
from hpcontact.sweep.tasks import task_key


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("spec")
    parser.add_argument("--output", required=True)
    parser.add_argument("--log", required=True)
    parser.add_argument("--resume", action="store_true")
    parser.add_argument("--delay", type=float, default=0.0)
    args = parser.parse_args()
    team = world()
    log = Path(args.log) / f"rank{team.rank}.log"

    def task(params: Mapping[str, Any]) -> dict[str, Any]:
        with open(log, "a", encoding="utf-8") as fh:
            fh.write(f"{os.getpid()} {task_key(params)}\n")
        time.sleep(args.delay)
        return solve(params)

    run_sweep(args.spec, resume=args.resume, output=args.output, task_function=task, team=team)


if __name__ == "__main__":
    main()
