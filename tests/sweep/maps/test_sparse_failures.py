"""A failed solve at a node of a sparse-grid map (hpcontact.sweep.maps.sparse_grid,
``_Failures``; issue 40): the map around it comes from the indices that do not need it,
its map error says what those miss, and a point nothing can be interpolated for is NaN with
the data set's reason — never a NaN map error that looks like a value, nor one below the true
error because of the failure. Judged against the closed form of tests/sweep/maps/test_sparse_grid.py."""

from __future__ import annotations

import math

import numpy as np
import xarray as xr
from test_sparse_grid import closed_form, record, spec_text

from hpcontact.sweep.data.columns import NOT_COMPUTED
from hpcontact.sweep.data.journal import ERROR, OK
from hpcontact.sweep.maps.fill import INTERPOLATED_MESSAGE, UNINTERPOLATED_MESSAGE

# the 19 x 17 x 31 map of test_sparse_grid.py (nu x A x psi); its first round: every 9th nu, 4th A, 15th psi and between
NU, A, PSI = np.linspace(0.0, 0.45, 19), np.linspace(0.5, 1.5, 17), np.linspace(0.0, 90.0, 31)


def failing_at(nu: float, anisotropy: float, orientation: float):
    """The closed form's stand-in, whose solve at (nu, A, ψ) raises (a failed solve: the sweep
    records it and its stiffnesses are NaN)."""

    def solve(params):
        here = (float(params["nu"]), float(params["anisotropy"]), float(params.get("orientation", 0.0)))
        if all(math.isclose(a, b, abs_tol=1e-12) for a, b in zip(here, (nu, anisotropy, orientation))):
            raise RuntimeError("this scene fails")
        return record(params)

    return solve


def judged(ds):
    ds = ds.transpose("nu", "anisotropy", "orientation")
    exact = closed_form(
        ds["nu"].values[:, None, None], ds["anisotropy"].values[None, :, None], ds["orientation"].values[None, None, :]
    )
    return ds, np.abs(ds["K_xx"].values / exact - 1.0)


def test_a_failed_inner_node_leaves_the_map_finite_and_its_error_honest_around_it(sweep, write_spec):
    """A node of the first round fails, the middle of the face A = 1.5 (a node of every index
    finer than level 0 along nu and ψ; the centre, A = 1, ignores ψ): every other point is
    interpolated and its map error is at least its true error. Around the failed node the map
    comes from fewer indices and says so (there 9.4e-2 where the true error is 1e-4, so the map
    did not meet its tolerance); before, 7 641 of the 10 013 points were NaN, K_xx and its map
    error, the refinement saw no error there and stopped around it."""
    ds = xr.open_dataset(sweep(write_spec(spec_text()), failing_at(NU[9], A[16], PSI[15])))
    ds, true = judged(ds)
    failed = ds["status"].values == ERROR
    assert (
        failed.sum() == 1 and failed[9, 16, 15] and ds["message"].values[9, 16, 15] == "RuntimeError: this scene fails"
    )
    others = ~failed
    assert np.all(np.isfinite(ds["K_xx"].values[others])) and np.all(np.isfinite(ds["K_xx_map_error"].values[others]))
    assert np.all(ds["status"].values[others] == OK) and ds.attrs["adaptive_points_not_interpolated"] == 0
    interpolated = others & (ds["solved"].values == 0)
    assert np.all(ds["message"].values[interpolated] == INTERPOLATED_MESSAGE)
    assert np.all(ds["K_xx_map_error"].values[others] >= true[others])  # honest at every point
    worst = float(np.max(ds["K_xx_map_error"].values[others]))
    assert bool(ds.attrs["adaptive_met"]) == (worst <= 1e-3) and true[others].max() <= 1e-3


def test_a_failed_corner_leaves_what_it_enters_not_interpolated_with_the_reason(sweep, write_spec):
    """A corner fails: it is a node of every index, and the first index (level 0: linear between
    the ends of each axis) takes it at every point but those on the three faces opposite it, so
    those alone can be interpolated (from the indices without it); every other unsolved point
    is NaN with status not computed and the reason, and the map says it did not meet its tolerance."""
    ds = xr.open_dataset(sweep(write_spec(spec_text()), failing_at(NU[0], A[0], PSI[0])))
    ds, true = judged(ds)
    failed = ds["status"].values == ERROR
    assert failed.sum() == 1 and failed[0, 0, 0]
    opposite = np.zeros(failed.shape, dtype=bool)
    opposite[-1], opposite[:, -1], opposite[:, :, -1] = True, True, True
    unsolved = ds["solved"].values == 0
    lost = unsolved & ~opposite
    assert (
        lost.any() and np.all(np.isnan(ds["K_xx"].values[lost])) and np.all(np.isnan(ds["K_xx_map_error"].values[lost]))
    )
    assert np.all(ds["status"].values[lost] == NOT_COMPUTED)
    assert np.all(ds["message"].values[lost] == UNINTERPOLATED_MESSAGE)
    assert ds.attrs["adaptive_points_not_interpolated"] == lost.sum() and ds.attrs["adaptive_met"] == 0
    kept = unsolved & opposite
    assert np.all(np.isfinite(ds["K_xx"].values[kept]))
    assert np.all(ds["K_xx_map_error"].values[kept] >= true[kept])
