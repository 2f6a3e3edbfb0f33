"""What the tests that start their own ``mpiexec -n 2`` share: the launcher that belongs to this
Python (the venv's ``mpiexec`` from the ``mpich`` wheel before the PATH's), the marks that skip
them where they cannot run — under a launcher (``mpiexec -n 2 pytest tests/mpi``, where the other
half of tests/mpi runs) or without any ``mpiexec`` — and ``mpiexec -n 2 python ...`` itself
(``start``; ``hpcontact run``: ``start_run``): started in a folder, waited for (``finish``) and
killed with every rank (``kill``).
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

import pytest

from hpcontact.sweep.run.schedule import launched_by_mpi

ROOT = Path(__file__).resolve().parents[2]
MPIEXEC = shutil.which("mpiexec", path=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")

#: ``pytestmark`` of a module whose tests launch ``mpiexec`` themselves.
STARTS_ITS_OWN_MPIEXEC = [
    pytest.mark.skipif(launched_by_mpi(), reason="starts its own mpiexec; run pytest without a launcher"),
    pytest.mark.skipif(MPIEXEC is None, reason="no mpiexec"),
]

#: Variables of pytest's environment a launched run does not inherit: MPI switched off, injected
#: faults, slowed phases, a data-set size limit, a batch job's id (a test sets them per run).
CLEARED = (
    "HPCONTACT_MPI",
    "HPCONTACT_FAULTS",
    "HPCONTACT_SLOW_PHASE",
    "HPCONTACT_DATA_SET_LIMIT",
    "SLURM_JOB_ID",
    "PBS_JOBID",
    "LSB_JOBID",
    "JOB_ID",
)


def start(
    folder: Path,
    arguments: Sequence[str],
    env: Mapping[str, str] | None = None,
    procs: list[subprocess.Popen] | None = None,
    stderr: int = subprocess.PIPE,
) -> subprocess.Popen:
    """``mpiexec -n 2 python ARGUMENTS`` in ``folder``: in a session of its own, one OpenMP
    thread, FFTW wisdom in ``folder/wisdom``, pytest's environment less ``CLEARED`` plus ``env``;
    its stderr to ``stderr`` (``subprocess.STDOUT``: with its stdout). Appended to ``procs`` when
    given (the ``launched`` fixture kills what is left of it)."""
    environment = {k: v for k, v in os.environ.items() if k not in CLEARED}
    environment.update(OMP_NUM_THREADS="1", HPCONTACT_WISDOM=str(folder / "wisdom"), **(env or {}))
    proc = subprocess.Popen(
        [MPIEXEC, "-n", "2", sys.executable, *arguments],
        cwd=folder,
        env=environment,
        stdout=subprocess.PIPE,
        stderr=stderr,
        text=True,
        start_new_session=True,
    )
    if procs is not None:
        procs.append(proc)
    return proc


def start_run(
    folder: Path,
    spec: str | bytes,
    *options: str,
    env: Mapping[str, str] | None = None,
    procs: list[subprocess.Popen] | None = None,
) -> subprocess.Popen:
    """``mpiexec -n 2 hpcontact run spec.toml OPTIONS`` in ``folder`` (``start``), ``spec``
    written there first."""
    (folder / "spec.toml").write_bytes(spec if isinstance(spec, bytes) else spec.encode())
    return start(folder, ["-m", "hpcontact.cli", "run", "spec.toml", *options], env=env, procs=procs)


def finish(proc: subprocess.Popen, timeout: float = 120.0) -> tuple[int, str, str]:
    """Wait for ``proc`` to end: exit status, stdout, stderr. One still running after ``timeout``
    seconds is killed with every rank and ``subprocess.TimeoutExpired`` raised."""
    try:
        out, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            kill(proc)
    return proc.returncode, out, err


def descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (Hydra starts each rank in a session of its own, so the
    launcher's process group does not hold them)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                parent = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            children.setdefault(parent, []).append(int(entry.name))
    found, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def kill(proc: subprocess.Popen) -> None:
    """SIGKILL to ``proc``'s ranks, then to its process group; reaped, its pipes drained."""
    for pid in descendants(proc.pid):
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:  # ended meanwhile
        pass
    proc.communicate()
