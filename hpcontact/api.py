"""What a notebook user types, re-exported at the package top (``hpcontact.solve``,
``hpcontact.open_dataset``, ``hpcontact.run_sweep``): a stable face over the engine and the
sweep. The sweep is imported only when called: it brings xarray, and mpi4py, whose import
initializes MPI.

>>> import hpcontact
>>> record = hpcontact.solve(shape="ellipse", aspect=0.5, nu=0.3, n=64)
>>> record["K_xx"], record["K_yy"]                      # doctest: +SKIP
>>> path = hpcontact.run_sweep("jobs/demo.toml")          # one process
>>> ds = hpcontact.open_dataset(path)
>>> ds.K_nn.sel(shape="rectangle", nu=0.3, aspect=1e-4)  # doctest: +SKIP
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from hpcontact.problems.contact import solve as solve_scene
from hpcontact.scene import Scene

if TYPE_CHECKING:
    import xarray as xr


def solve(**params: Any) -> dict[str, Any]:
    """Solve one scene and return its record.

    Parameters
    ----------
    **params
        The scene's fields, the names of ``hpcontact solve`` and of a sweep's [scene] and
        [numerics] tables (docs/design.md §4.1): ``shape``, ``aspect``, ``nu``, ``quantities``, ``n``,
        ``tol``, ``material``, ``anisotropy``, ``orientation``, ... Missing fields take the
        engine's defaults.

    Returns
    -------
    dict
        The record of ``hpcontact.problems.contact.solve``: stiffnesses ``K_ij`` in units of G·a (G the
        shear modulus, a the semi-major extent of the contact), grid, iterations, residual and
        the plan, for the quantities asked.

    Raises
    ------
    hpcontact.errors.InputError
        A field is missing, unknown or out of range (the message names it and the range).
    hpcontact.errors.ConvergenceError
        A solve did not reach its tolerance.
    """
    return solve_scene(Scene.from_params(params))


def open_dataset(path: str | Path, **options: Any) -> xr.Dataset:
    """Open a sweep data set as the labelled hypercube over the spec's axes.

    Parameters
    ----------
    path
        The netCDF file ``hpcontact run`` (or ``run_sweep``) wrote.
    **options
        Passed to ``xarray.open_dataset``; ``chunks={}`` gives dask arrays in the file's
        chunks (1–10 MB on large sweeps).

    Returns
    -------
    xarray.Dataset
        Lazily read: one dimension per axis of the spec (labels select exactly:
        ``ds.sel(nu=0.3, shape="rectangle")``), every point of the parameter space, ``K_nn``
        and ``normalized_nn`` along ``angle``, ``plan`` as JSON text. Use it in a ``with``
        block, or ``.load()`` it, to close the file.
    """
    from hpcontact.sweep.dataset import open_dataset as open_sweep

    return open_sweep(path, **options)


def run_sweep(spec: str | Path, **options: Any) -> Path:
    """Run a sweep in this one process and return the path of its data set.

    Parameters
    ----------
    spec
        The sweep spec (TOML), e.g. ``"jobs/demo.toml"``.
    **options
        Options of ``hpcontact.sweep.driver.run_sweep``: ``resume=True`` reuses the tasks
        the journals hold, ``output=PATH`` overrides the spec's output, ``stream`` receives
        the progress lines (default stdout).

    Returns
    -------
    pathlib.Path
        The data set written (read it with ``open_dataset``).

    Raises
    ------
    hpcontact.errors.InputError
        The spec is invalid (the message names the key).
    """
    from hpcontact.sweep.driver import run_sweep as run
    from hpcontact.sweep.schedule import SerialTeam

    return run(spec, team=SerialTeam(), **options)
