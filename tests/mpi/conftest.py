"""Fixtures of the MPI tests.

Two ways to run them, both in CI:

* ``mpiexec -n 2 python -m pytest -p no:cacheprovider tests/mpi`` — every rank runs pytest; the
  tests marked ``mpi`` call the sweep collectively on ``MPI.COMM_WORLD`` (the same tests pass
  in one plain process, where the team is a single rank). Tests that launch ``mpiexec``
  themselves skip under a launcher.
* ``python -m pytest tests/mpi`` — one process; ``test_kill_resume`` starts its own
  ``mpiexec -n 2`` runs, kills a rank with SIGKILL and resumes.

The shared temporary folder is made by rank 0 and broadcast (pytest's ``tmp_path`` differs from
rank to rank).
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from launcher import kill

from hpcontact.sweep.run.schedule import Team, world


@pytest.fixture(scope="session")
def team() -> Team:
    """MPI.COMM_WORLD under a launcher, else one serial rank."""
    return world()


@pytest.fixture(scope="module")
def shared_dir(team: Team) -> Iterator[Path]:
    """A temporary folder every rank sees, removed after the module's tests."""
    path = Path(team.bcast(tempfile.mkdtemp(prefix="hpcontact-mpi-") if team.rank == 0 else None))
    yield path
    team.barrier()
    if team.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


# Run-dependent or ill-conditioned diagnostics: time, CG residual and iteration count (the last
# iteration can fall either side of the tolerance), |K_xy - K_yx| and the principal direction
# of a nearly isotropic tensor (rounding noise by definition).
NOT_COMPARED = ("wall_time_s", "residual", "iterations", "asymmetry", "principal_angle_deg")


def _is_stiffness(variable: xr.DataArray) -> bool:
    """A stiffness in units of G a (CF data sets: ``units = "1"``, ``scale = "G a"``)."""
    return variable.attrs.get("scale", variable.attrs.get("units")) == "G a"


def _assert_same_results(a: xr.Dataset, b: xr.Dataset, rtol: float = 1e-12) -> None:
    """Same coordinates, status, messages and plans; every stiffness equal to ``rtol`` of the
    largest stiffness, other floats to ``rtol`` of their own scale; NaN exactly where NaN.

    Not bitwise: by default each process plans its own FFTs and re-plans a layout with
    FFTW_MEASURE once it repays (or takes saved wisdom), and plans chosen by timing differ between
    processes and round differently. The tests' tiny grids keep FFTW_ESTIMATE plans, the same
    everywhere, and then agree bitwise (``test_parallel_sweep``'s real-solve test asserts it
    with ``HPCONTACT_FFTW_PLANNER=FFTW_ESTIMATE``); ``rtol`` leaves room for a process that did
    re-plan. Forced FFTW_MEASURE at n = 48 and 128, tol 1e-10, measured up to 2.2e-12 of the
    largest stiffness between 1 process and 2 ranks (2026-11-28, 2-core Intel Xeon VM): above
    the default ``rtol``: a comparison of grids that large needs ``rtol`` ~5e-12.
    """
    assert set(a.variables) == set(b.variables)
    for name in a.coords:
        xr.testing.assert_identical(a[name], b[name])
    stiffness = max(float(np.nanmax(np.abs(b[n].values))) for n in b.data_vars if _is_stiffness(b[n]))
    for name in sorted(set(a.data_vars) - set(NOT_COMPARED)):
        x, y = a[name].values, b[name].values
        assert a[name].attrs.keys() == b[name].attrs.keys(), name
        if x.dtype.kind != "f":
            np.testing.assert_array_equal(x, y, err_msg=name)
            continue
        np.testing.assert_array_equal(np.isnan(x), np.isnan(y), err_msg=name)
        scale = stiffness if _is_stiffness(b[name]) else float(np.nanmax(np.abs(y), initial=0.0))
        error = float(np.nanmax(np.abs(x - y), initial=0.0))
        assert error <= rtol * scale, f"{name}: {error:.3e} > {rtol:.0e} x {scale:.3e}"


@pytest.fixture(scope="session")
def assert_same_results() -> Callable[[xr.Dataset, xr.Dataset], None]:
    """Compare two sweep data sets (see ``_assert_same_results``)."""
    return _assert_same_results


@pytest.fixture
def launched():
    """Processes a test starts itself (mpiexec runs, each in its own session); any still running
    at the end are killed with their ranks."""
    procs: list[subprocess.Popen] = []
    yield procs
    for proc in procs:
        if proc.poll() is None:
            kill(proc)
