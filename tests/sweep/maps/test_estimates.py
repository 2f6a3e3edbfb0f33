"""The axes a point over its tolerance splits (hpcontact.sweep.maps.estimates.needed_axes)."""

from __future__ import annotations

import numpy as np

from hpcontact.sweep.maps.estimates import needed_axes


def test_a_split_of_one_axis_alone_takes_the_cheapest_and_of_equal_costs_the_largest_estimate():
    """Three points over a budget of 1e-3, each of whose axes' split alone would do (the others
    add to ≤ the budget): with costs 81, 81, 99 the cheaper two tie and the larger estimate of
    those two is split; with costs 99, 81, 81 the cheapest wins over a larger estimate; where no
    single split would do (both estimates above the budget) every axis needed is split."""
    errors = [np.array([4e-4, 9e-4, 2e-3]), np.array([8e-4, 3e-4, 2e-3]), np.array([1e-4, 5e-5, 1e-5])]
    budget = np.full(3, 1e-3)
    need = needed_axes(errors, budget, costs=[np.array(81), np.array(81), np.array(99)])
    assert [list(n) for n in np.array(need).T] == [[False, True, False], [True, False, False], [True, True, False]]
    need = needed_axes(errors, budget, costs=[np.array(99), np.array(81), np.array(81)])
    assert [list(n) for n in np.array(need).T][:2] == [[False, True, False], [False, True, False]]
