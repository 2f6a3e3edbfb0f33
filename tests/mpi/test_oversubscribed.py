"""The same sweep on 1, 2 and oversubscribed 4, 8 and 16 ranks gives the same data set.

Launches its own ``mpiexec`` (so it skips when pytest itself runs under a launcher); the tasks
are ``sweep_runner.synthetic`` (exact records, a failing scene), so the data sets must agree
bitwise in every variable, coordinate and attribute except the timings: what differs between
the runs is only how the driver splits the spec check, the tasks and the gather over the ranks.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import xarray as xr
from launcher import MPIEXEC, ROOT, STARTS_ITS_OWN_MPIEXEC
from test_kill_resume import RUNNER

from hpcontact.sweep.data.dataset import open_dataset

SPEC = """
[sweep]
title = "oversubscribed"
[scene]
quantities = ["tangential"]
[numerics]
n = 16
[axes]
shape = ["circle", "ellipse", "rectangle", { label = "hexagon", shape = "polygon", sides = 6 }]
aspect = { logspace = [0, -3, 7] }
nu = [0.0, 0.3, 0.45]
angle = { linspace = [0, 180, 5] }
"""
RANKS = (1, 2, 4, 8, 16)
TIMINGS = ("wall_time_s",)  # the only variable that depends on the run
RUN_ATTRIBUTES = ("created", "mpi_size", "history", "sweep_parallel_efficiency")  # besides timings (*_s)

pytestmark = STARTS_ITS_OWN_MPIEXEC


def sweep(spec: Path, ranks: int, folder: Path) -> tuple[xr.Dataset, int]:
    """The data set of ``spec`` computed on ``ranks`` ranks (1: one plain process), and how many
    ranks computed tasks."""
    output, log = folder / f"ranks{ranks}.nc", folder / f"log{ranks}"
    log.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "HPCONTACT_MPI"}
    env.update(PYTHONPATH=f"{ROOT}{os.pathsep}{env.get('PYTHONPATH', '')}", OMP_NUM_THREADS="1")
    launcher = [] if ranks == 1 else [MPIEXEC, "-n", str(ranks)]
    command = [
        *launcher,
        sys.executable,
        str(RUNNER),
        str(spec),
        "--output",
        str(output),
        "--log",
        str(log),
        "--synthetic",
        "--delay",
        "0.01",
        "--parent",
        str(os.getpid()),
    ]
    done = subprocess.run(command, check=False, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    with open_dataset(output) as ds:
        return ds.load(), len(list(log.glob("rank*.log")))


def untimed(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` without its timings and the attributes that name the run."""
    out = ds.drop_vars(TIMINGS)
    out.attrs = {k: v for k, v in ds.attrs.items() if not k.endswith("_s") and k not in RUN_ATTRIBUTES}
    return out


def test_data_sets_on_1_2_4_8_16_ranks_are_bitwise_equal_but_for_timings(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    reference, _ = sweep(spec, 1, tmp_path)
    assert int((reference.status != 0).sum()) > 0 and "note" in reference and "plan" in reference  # what is compared
    for ranks in RANKS[1:]:
        ds, computing = sweep(spec, ranks, tmp_path)
        assert ds.attrs["mpi_size"] == ranks and computing >= 2  # the gather joins several ranks' columns
        xr.testing.assert_identical(untimed(ds), untimed(reference))
