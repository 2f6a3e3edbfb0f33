"""A batch task started without MPI process management is refused (issue 15, point 3).

``srun --mpi=none`` (a common site default) starts N plain processes that see only ``SLURM_*``
variables; each would run the whole sweep alone into the same output. Simulated here with two
plain processes carrying what srun sets for the tasks of a 2-task step: both must exit 2 with
one line on stderr saying how to launch, and write nothing. The batch script itself (rank 0 of
the allocation, outside any job step) is a deliberate one-process run and must still work.

Starts its own processes, so it skips when pytest itself runs under a launcher.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from launcher import CLEARED

from hpcontact.sweep.run.schedule import LAUNCHER_VARIABLES, launched_by_mpi

pytestmark = pytest.mark.skipif(launched_by_mpi(), reason="starts its own processes; run pytest without a launcher")

SPEC = """
[sweep]
title = "launch check"
[scene]
quantities = ["normal"]
[numerics]
n = 16
[axes]
shape = ["circle"]
"""
# Prefixes of variables any MPI launcher or process manager sets; none may leak into the
# simulated srun --mpi=none tasks (the test's own environment may hold some).
MPI_PREFIXES = ("PMI_", "PMIX_", "OMPI_", "MPI_", "MV2_", "HYDRA_", "PRTE_", "PALS_", "SLURM_", "FLUX_", "PBS_")


def _plain_environment(**slurm: str) -> dict[str, str]:
    """This process's environment without launcher variables and what no launched run inherits
    (``launcher.CLEARED``), plus ``slurm``."""
    cleared = {*LAUNCHER_VARIABLES, *CLEARED}
    env = {k: v for k, v in os.environ.items() if k not in cleared and not k.startswith(MPI_PREFIXES)}
    env.update(OMP_NUM_THREADS="1", **slurm)
    return env


def _start(spec: Path, output: Path, env: dict[str, str]) -> subprocess.Popen:
    command = [sys.executable, "-m", "hpcontact.cli", "run", str(spec), "--output", str(output)]
    return subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def test_srun_without_mpi_plugin_is_refused_with_one_line(tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC, encoding="utf-8")
    output = tmp_path / "out.nc"
    step = {
        "SLURM_JOB_ID": "4242",
        "SLURM_STEP_ID": "0",
        "SLURM_NTASKS": "2",
        "SLURM_NPROCS": "2",
        "SLURM_STEP_NUM_TASKS": "2",
        "SLURM_NNODES": "1",
    }
    procs = [
        _start(spec, output, _plain_environment(SLURM_PROCID=str(r), SLURM_LOCALID=str(r), **step)) for r in (0, 1)
    ]
    for proc in procs:
        stdout, stderr = proc.communicate(timeout=120)
        lines = stderr.strip().splitlines()
        assert proc.returncode == 2, stderr
        assert len(lines) == 1, stderr
        assert "srun --mpi=pmix" in lines[0] and "mpirun" in lines[0], lines[0]
        assert stdout == ""
    assert not output.exists() and not output.with_name(output.name + ".journal").exists()


def test_the_batch_script_itself_runs_one_process(tmp_path):
    """Outside a job step (no SLURM_STEP_NUM_TASKS) one process is a deliberate serial run."""
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC, encoding="utf-8")
    output = tmp_path / "out.nc"
    env = _plain_environment(SLURM_JOB_ID="4242", SLURM_PROCID="0", SLURM_NTASKS="2", SLURM_NNODES="1")
    proc = _start(spec, output, env)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    assert output.exists() and "1 rank" in stdout
