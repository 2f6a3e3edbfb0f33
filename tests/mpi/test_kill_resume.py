"""Kill a rank of a 2-rank sweep with SIGKILL, resume, and compare with an uninterrupted run.

Launches its own ``mpiexec -n 2`` (so it skips when pytest itself runs under a launcher).
"""

from __future__ import annotations

import io
import os
import signal
import subprocess
import time
from pathlib import Path

import xarray as xr
from launcher import ROOT, STARTS_ITS_OWN_MPIEXEC, start

from hpcontact.problems.contact import solve
from hpcontact.scene import Scene
from hpcontact.sweep.data.journal import read_journals
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run.schedule import SerialTeam
from hpcontact.sweep.space.parse import load_spec
from hpcontact.sweep.work.tasks import enumerate_tasks

RUNNER = Path(__file__).with_name("sweep_runner.py")
SPEC = """
[sweep]
title = "kill and resume"
progress_interval = 0.5
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 16
tol = 1e-12
[axes]
shape = ["circle", "ellipse", "rectangle"]
aspect = [1.0, 0.3, 0.01]
nu = [0.1, 0.3, 0.5]
angle = { linspace = [0, 180, 7] }
"""

pytestmark = STARTS_ITS_OWN_MPIEXEC


def launch(spec: Path, output: Path, log: Path, *extra: str) -> subprocess.Popen:
    """``sweep_runner.py`` on 2 ranks (``launcher.start``) in the spec's folder, each rank's
    started tasks logged in ``log``; stderr with stdout. The checkout first on the path, and one
    git revision, so that a commit by someone else between the runs is not a stale journal."""
    log.mkdir()
    env = {"PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "HPCONTACT_GIT_REVISION": "test"}
    arguments = [str(RUNNER), str(spec), "--output", str(output), "--log", str(log), "--parent", str(os.getpid())]
    return start(spec.parent, [*arguments, *extra], env=env, stderr=subprocess.STDOUT)


def started(log: Path, rank: int) -> list[tuple[int, str]]:
    """(pid, task key) of each task the rank started, in order."""
    path = log / f"rank{rank}.log"
    lines = path.read_text().splitlines() if path.exists() else []
    return [(int(pid), key) for pid, key in (line.split() for line in lines)]


def resumed(spec: Path, output: Path, log: Path, journaled: set[str], launched: list) -> tuple[str, list[str]]:
    """Run the killed sweep again with ``--resume`` (logging to ``log``) and check that it ends
    well, starts no task twice and none of the ``journaled`` ones; its output and the keys it ran."""
    second = launch(spec, output, log, "--resume")
    launched.append(second)
    text = second.communicate(timeout=120)[0]
    assert second.returncode == 0, text
    rerun = [key for rank in (0, 1) for _, key in started(log, rank)]
    assert len(rerun) == len(set(rerun)), "a task ran twice"
    assert not set(rerun) & journaled, "a journaled task was computed again"
    return text, rerun


def test_resume_after_a_killed_rank_loses_nothing_and_recomputes_nothing(tmp_path, assert_same_results, launched):
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    output = tmp_path / "out.nc"
    keys = {t.key for t in enumerate_tasks(load_spec(spec))[0]}
    assert len(keys) == 3 + 9 + 9  # the circle ignores the aspect

    first = launch(spec, output, tmp_path / "log1", "--delay", "0.25")
    launched.append(first)
    deadline = time.monotonic() + 120.0
    while len(started(tmp_path / "log1", 1)) < 4 or not started(tmp_path / "log1", 0):
        assert first.poll() is None and time.monotonic() < deadline, first.communicate()[0]
        time.sleep(0.02)
    os.kill(started(tmp_path / "log1", 1)[-1][0], signal.SIGKILL)  # rank 1, in the middle of a task
    text = first.communicate(timeout=60)[0]
    assert first.returncode != 0, text
    assert not output.exists()

    journaled = set(read_journals(output.with_name("out.nc.journal")))
    assert 3 <= len(journaled) < len(keys) and journaled <= keys

    text, rerun = resumed(spec, output, tmp_path / "log2", journaled, launched)
    assert set(rerun) | journaled == keys, "a task was lost"
    assert f"({len(journaled)} from journals)" in text

    reference = run_sweep(
        spec,
        output=tmp_path / "reference.nc",
        task_function=lambda fields: solve(Scene.from_params(fields)),
        team=SerialTeam(),
        stream=io.StringIO(),
    )
    with xr.open_dataset(output) as a, xr.open_dataset(reference) as b:
        assert a.attrs["mpi_size"] == 2 and a.attrs["sweep_tasks_reused"] == len(journaled)
        assert_same_results(a, b)
