"""Kill a rank of a 2-rank adaptive sweep ([adaptive]) in its second round with SIGKILL, resume,
and compare with an uninterrupted run: the same rounds, the same data set, no scene solved twice.

Launches its own ``mpiexec -n 2`` (skips under a launcher), like test_kill_resume.
"""

from __future__ import annotations

import io
import os
import signal
import time

import xarray as xr
from launcher import STARTS_ITS_OWN_MPIEXEC
from test_kill_resume import launch, resumed, started

from hpcontact.problems.contact import solve
from hpcontact.scene import Scene
from hpcontact.sweep.data.journal import read_journals
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run.schedule import SerialTeam

SPEC = """
[sweep]
title = "adaptive kill and resume"
progress_interval = 0.5
[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
n = 16
tol = 1e-12
[axes]
aspect = { logspace = [0, -3, 17] }
nu = { linspace = [0, 0.5, 9] }
[adaptive]
tolerance = 3e-3
"""
FIRST_ROUND = 25  # 5 x 5 nodes

pytestmark = STARTS_ITS_OWN_MPIEXEC


def test_an_adaptive_sweep_killed_in_a_round_resumes_to_the_same_map(tmp_path, assert_same_results, launched):
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    output = tmp_path / "out.nc"
    reference = run_sweep(
        spec,
        output=tmp_path / "reference.nc",
        task_function=lambda fields: solve(Scene.from_params(fields)),
        team=SerialTeam(),
        stream=io.StringIO(),
    )
    with xr.open_dataset(reference) as ref:
        assert ref.attrs["adaptive_rounds"] >= 3 and ref.attrs["sweep_solves"] > FIRST_ROUND + 8

    first = launch(spec, output, tmp_path / "log1", "--delay", "0.1")
    launched.append(first)
    deadline = time.monotonic() + 120.0
    while len(started(tmp_path / "log1", 0)) + len(started(tmp_path / "log1", 1)) < FIRST_ROUND + 6:
        assert first.poll() is None and time.monotonic() < deadline, first.communicate()[0]
        time.sleep(0.02)
    os.kill(started(tmp_path / "log1", 1)[-1][0], signal.SIGKILL)  # rank 1, in the second round
    text = first.communicate(timeout=60)[0]
    assert first.returncode != 0, text
    assert not output.exists()
    journaled = set(read_journals(output.with_name("out.nc.journal")))
    assert FIRST_ROUND < len(journaled)

    _, rerun = resumed(spec, output, tmp_path / "log2", journaled, launched)
    with xr.open_dataset(output) as a, xr.open_dataset(reference) as b:
        assert a.attrs["sweep_solves"] == b.attrs["sweep_solves"] == len(journaled | set(rerun))
        assert a.attrs["adaptive_rounds"] == b.attrs["adaptive_rounds"]
        assert (a["solved"] == b["solved"]).all()
        assert_same_results(a, b)
