"""Tensor-product interpolation and its error estimate (hpcontact.numerics.interpolation)."""

from __future__ import annotations

import numpy as np
import pytest

from hpcontact.analytic import mindlin_ellipse_stiffness_ratio
from hpcontact.numerics.interpolation import (
    Scale,
    TensorInterpolant,
    bisection_nodes,
    chosen_stencils,
    coordinate,
    end_terms,
    estimate_weights,
    refined,
    weights,
)
from hpcontact.sweep.maps.estimates import SAFETY


def test_bisection_nodes_take_every_2k_th_index_with_the_ends():
    assert bisection_nodes(41, 5) == [0, 10, 20, 30, 40]
    assert bisection_nodes(21, 5) == [0, 5, 10, 15, 20]
    assert bisection_nodes(17, 3) == [0, 8, 16]
    assert bisection_nodes(3, 5) == [0, 1, 2]  # all of a short axis
    assert bisection_nodes(2, 5) == [0, 1]
    assert bisection_nodes(1, 5) == [0]
    assert refined([0, 10, 20], [False, True]) == [0, 10, 15, 20]
    assert refined([0, 1, 2], [True, True]) == [0, 1, 2]  # nothing inside to add


@pytest.mark.parametrize("count", [2, 3, 4, 5, 9])
def test_exact_at_the_nodes(count):
    x = np.linspace(0.0, 1.0, 33)
    nodes = bisection_nodes(33, count)
    rng = np.random.default_rng(1)
    data = rng.normal(size=len(nodes))
    for matrix in (weights(x, nodes), estimate_weights(x, nodes, side=0), estimate_weights(x, nodes, side=1)):
        np.testing.assert_allclose(matrix[nodes] @ data, data, rtol=0, atol=1e-14)
        np.testing.assert_allclose(matrix.sum(axis=1), 1.0, atol=1e-12)  # reproduces constants


def test_cubics_are_reproduced_and_estimated_exact():
    x = np.linspace(-1.0, 2.0, 31)
    nodes = [0, 4, 10, 13, 20, 26, 30]  # uneven spacing
    f = 0.3 * x**3 - x**2 + 2.0 * x - 1.0
    interpolant = TensorInterpolant([x], [nodes])
    np.testing.assert_allclose(interpolant.values(f[nodes]), f, atol=1e-12)
    assert np.max(interpolant.estimates(f[nodes])[0]) < 1e-12


def test_the_estimate_of_a_known_second_derivative():
    """With three nodes the interpolant is the quadratic and the estimate is its difference from
    the linear interpolant across the point's interval: exactly |f''| / 2 |(x - x_k)(x - x_k+1)|
    on f = c x^2."""
    x = np.linspace(0.0, 1.0, 21)
    nodes = [0, 10, 20]
    c = 3.0
    f = c * x**2
    interpolant = TensorInterpolant([x], [nodes])
    np.testing.assert_allclose(interpolant.values(f[nodes]), f, atol=1e-12)
    ends = np.where(x <= 0.5, 0.0, 0.5), np.where(x <= 0.5, 0.5, 1.0)
    expected = c * np.abs((x - ends[0]) * (x - ends[1]))  # |f''|/2 = c
    np.testing.assert_allclose(interpolant.estimates(f[nodes])[0], expected, atol=1e-12)


def test_the_estimate_bounds_and_tracks_the_error_of_a_smooth_function():
    """exp(x) on nodes every h: the estimate (the next Newton term) is within a factor ~2 of the
    cubic's true error between the nodes, and both fall as h^4."""
    x = np.linspace(0.0, 2.0, 129)
    worst = []
    for stride in (16, 8):
        nodes = list(range(0, 129, stride))
        f = np.exp(x)
        interpolant = TensorInterpolant([x], [nodes])
        true = np.abs(interpolant.values(f[nodes]) - f)
        est = interpolant.estimates(f[nodes])[0]
        inside = np.setdiff1d(np.arange(129), nodes)
        ratio = est[inside] / true[inside]
        assert np.median(ratio) > 0.9 and np.median(ratio) < 3.0
        worst.append(true.max())
    assert 10.0 < worst[0] / worst[1] < 24.0  # ~16: fourth order


def test_log_scale_interpolates_in_log10():
    """A function linear in log10(b/a) is exact on a logspace axis interpolated in log scale,
    and not in the linear scale."""
    values = np.logspace(0, -4, 41)
    f = 2.0 - 0.5 * np.log10(values) + 0.1 * np.log10(values) ** 2
    nodes = bisection_nodes(41, 5)
    log = TensorInterpolant([coordinate(values, Scale.LOG)], [nodes])
    linear = TensorInterpolant([coordinate(values, Scale.LINEAR)], [nodes])
    np.testing.assert_allclose(log.values(f[nodes]), f, atol=1e-12)
    assert np.max(np.abs(linear.values(f[nodes]) - f)) > 0.1
    with pytest.raises(ValueError):
        coordinate([1.0, 0.0], Scale.LOG)


def test_tensor_product_in_two_dimensions_with_trailing_quantities():
    x = np.linspace(0.0, 1.0, 17)
    y = np.linspace(0.0, 2.0, 9)
    nodes = [[0, 4, 8, 12, 16], [0, 2, 4, 6, 8]]
    X, Y = np.meshgrid(x, y, indexing="ij")
    f = np.stack([X**3 * Y**2, np.sin(X) * np.cos(Y)], axis=-1)
    interpolant = TensorInterpolant([x, y], nodes)
    at_nodes = f[np.ix_(*nodes)]
    full = interpolant.values(at_nodes)
    assert full.shape == f.shape
    np.testing.assert_allclose(full[..., 0], f[..., 0], atol=1e-12)  # cubic x quadratic: exact
    np.testing.assert_allclose(full[np.ix_(*nodes)], at_nodes, atol=1e-14)
    ex, ey = interpolant.estimates(at_nodes, full)
    assert np.max(ex[..., 0]) < 1e-12 and np.max(ey[..., 0]) < 1e-12
    true = np.abs(full[..., 1] - f[..., 1])
    estimate = ex[..., 1] + ey[..., 1]
    assert np.mean(1.5 * estimate >= true) >= 0.95  # with maps.estimates.SAFETY: an estimate, not a bound
    assert 0.5 < estimate.max() / true.max() < 4.0
    assert np.all(ex[nodes[0], :, :] == 0.0) and np.all(ey[:, nodes[1], :] == 0.0)  # zero on its own nodes


def test_a_failed_node_is_left_out_of_its_lines_and_spoils_nothing_else():
    """A NaN node (a failed solve): the lines through it interpolate from their other nodes, so
    a cubic × quadratic is still reproduced exactly everywhere (four valid nodes remain on the
    cubic's line), the NaN itself included (it is interpolated over), and the estimates stay
    finite; before, the matrix product made every point NaN (0 × NaN)."""
    x = np.linspace(0.0, 1.0, 17)
    y = np.linspace(0.0, 2.0, 9)
    nodes = [[0, 4, 8, 12, 16], [0, 2, 4, 6, 8]]
    X, Y = np.meshgrid(x, y, indexing="ij")
    f = np.stack([X**3 * Y**2, 1.0 + X * Y], axis=-1)
    interpolant = TensorInterpolant([x, y], nodes)
    at_nodes = f[np.ix_(*nodes)].copy()
    at_nodes[2, 3, :] = np.nan  # the node (x = 0.5, y = 1.5) failed
    full = interpolant.values(at_nodes)
    np.testing.assert_allclose(full, f, atol=1e-12)
    assert all(np.all(np.isfinite(e)) for e in interpolant.estimates(at_nodes, full))
    # a whole row of failed nodes: the lines along y fill it from the other rows
    at_nodes[:, 3, :] = np.nan
    np.testing.assert_allclose(interpolant.values(at_nodes), f, atol=1e-12)
    # a line with no valid node left is NaN (nothing to interpolate from)
    line = TensorInterpolant([x], [nodes[0]])
    assert np.all(np.isnan(line.values(np.full((5, 2), np.nan))))


def test_the_conservative_estimate_covers_a_next_derivative_that_changes_sign_across_the_stencil():
    """cos(4x) on nodes 12 degrees apart (the K_yy of a circle on a cubic crystal versus the
    orientation, checked in an adaptive map): where the fourth derivative (256 cos 4x, zero at
    22.5° and 67.5°) changes sign inside a stencil, the next Newton term, and its growth read
    from the nodes inwards at the intervals near the ends, nearly vanish and under-estimate the
    cubic's error; the conservative estimate (also the lower order's own error) covers it at
    every point, and is never below the sharp one. At the ends the next two terms do not fall
    there (``FALLING``), so the sharp estimate takes the lower order's error too and covers it."""
    x = np.radians(np.linspace(0.0, 90.0, 31))
    nodes = [0, 3, 7, 11, 15, 19, 23, 27, 30]
    f = np.cos(4.0 * x) + 3.0
    interpolant = TensorInterpolant([x], [nodes])
    full = interpolant.values(f[nodes])
    sharp = interpolant.estimates(f[nodes], full)[0]
    conservative = interpolant.estimates(f[nodes], full, conservative=True)[0]
    true = np.abs(full - f)
    assert np.all(conservative >= sharp) and np.all(conservative >= true)
    assert np.all(sharp >= true)
    assert np.any(interpolant.next_term(f[nodes], full, 0) < true)  # the next term alone misses here


@pytest.mark.parametrize("nu", [0.05, 0.1, 0.2, 0.3])
def test_the_quintic_at_an_end_where_its_terms_do_not_fall(nu):
    """Mindlin's K_a/K_b (``analytic.mindlin_ellipse_stiffness_ratio``) along log10 b/a from 0
    to −2, nodes 0.25 apart (benchmarks/map_honesty.py M1's leaf next to b/a = 1): the quintic
    is chosen (its next term below the cubic's everywhere), but at its first interval its
    error is 1.9 … 28 × its next term (more than the map's factor, ``estimates.SAFETY``), whose
    second term is larger than the first: the estimate there takes the lower order's own error
    and covers the error at every interval that grows inwards only, and within the factor at
    every point."""
    x = np.linspace(0.0, -2.0, 17)
    nodes = list(range(0, 17, 2))
    f = mindlin_ellipse_stiffness_ratio(10.0**x, nu)
    assert chosen_stencils([x], [nodes], f[nodes]).tolist() == [[6]]
    interpolant = TensorInterpolant([x], [nodes], 6)
    full = interpolant.values(f[nodes])
    estimate = interpolant.estimates(f[nodes], full)[0]
    true = np.abs(full - f)
    assert true[1] > SAFETY * interpolant.next_term(f[nodes], full, 0)[1]
    ends = interpolant.ends[0].one_sided
    assert np.all(estimate[ends] >= true[ends])
    assert np.all(SAFETY * estimate >= true)


@pytest.mark.parametrize("nodes", [[0, 6, 12, 18, 24], [0, 4, 8, 12, 16, 20, 24], list(range(0, 25, 3))])
def test_at_the_ends_of_an_axis_the_estimate_covers_an_exponential_growing_towards_the_end(nodes):
    """exp(−4t), t = 0 … 1 (25 points), steepest at t = 0. At the intervals whose cubic stencil can
    grow inwards only (``end_terms``: the two at each end) the next Newton term samples the
    divided difference inwards of the point, where the fourth derivative is smaller: it falls
    short of the cubic's true error (measured: to 0.50 × with 5 nodes). The estimate extrapolates
    the divided difference's growth towards the end (harmonic: above the true growth where 1/|g|
    is convex, as on an exponential; with five nodes from the cubic windows' third differences),
    so it is at least the true error at every point; and cubics are still estimated exact."""
    t = np.linspace(0.0, 1.0, 25)
    f = np.exp(-4.0 * t)
    interpolant = TensorInterpolant([t], [nodes])
    full = interpolant.values(f[nodes])
    true = np.abs(full - f)
    next_term = np.fmax(*(np.abs(estimate_weights(t, nodes, side=s) @ f[nodes] - full) for s in (0, 1)))
    ends = end_terms(t, nodes)
    assert np.any(next_term[ends.one_sided] < 0.75 * true[ends.one_sided])  # the next term alone is short
    assert np.all(interpolant.estimates(f[nodes], full)[0] >= true)
    cubic = 0.3 * t**3 - t**2 + 2.0 * t - 1.0
    assert np.max(interpolant.estimates(cubic[nodes])[0]) < 1e-12


def test_at_the_end_near_a_pole_the_estimate_covers_the_error_wherever_the_lower_order_does():
    """0.2/(1.15 − s), s = 0 … 1 (33 points), nodes 0, 4, 8, 16, 20, 24, 28, 32 (a map of the
    benchmarks/local_refinement.py families with this s-dependence ended 1.3e-3 over its
    tolerance of 1e-3). Its divided differences are 0.2 / Π(1.15 − y_i): 1/D is nearly linear in
    the window's mean, and the harmonic growth read from the two windows at the end recovers the
    cubic's error at the end intervals near the pole, where the next term alone is 0.28 × of it.
    The estimate takes that growth up to the lower order's own error, so it is at least the true
    error wherever the lower order's error is, at least the smaller of the two everywhere, and
    nowhere below 0.8 × the true error (``maps.estimates.SAFETY`` 1.5 covers the rest)."""
    s = np.linspace(0.0, 1.0, 33)
    nodes = [0, 4, 8, 16, 20, 24, 28, 32]
    f = 0.2 / (1.15 - s)
    interpolant = TensorInterpolant([s], [nodes])
    full = interpolant.values(f[nodes])
    true = np.abs(full - f)
    estimate = interpolant.estimates(f[nodes], full)[0]
    lower = interpolant.estimates(f[nodes], full, conservative=True)[0]
    next_term = np.fmax(*(np.abs(estimate_weights(s, nodes, side=k) @ f[nodes] - full) for k in (0, 1)))
    one_sided = end_terms(s, nodes).one_sided
    assert np.min(next_term[30:32] / true[30:32]) < 0.3  # the next term alone: 0.28 of the error
    covered = one_sided & (lower >= true)
    assert covered.sum() >= 10
    assert np.all(estimate[covered] >= true[covered])
    assert np.all(estimate[one_sided] >= np.fmin(true, lower)[one_sided] * (1.0 - 1e-12))
    inside = np.setdiff1d(np.arange(33), nodes)
    assert np.all(estimate[inside] >= 0.8 * true[inside])


def test_the_quintic_is_chosen_on_an_analytic_function_and_its_estimate_bounds_its_error():
    """1/(3 − x) on x = 0 … 2 (49 points), nodes every 6th (a pole 1 beyond the end, 4 spacings):
    the quintic's next Newton term is below the cubic's at every point, so ``chosen_stencils``
    takes it; its error is 0.24 × the cubic's, and its estimate (next term and end terms, no
    safety factor) is at least its true error at every point. In two dimensions, per quantity
    and axis: exp(x) cos(y) takes the quintic along both axes; (|x − 0.77| + x) cos(y), a kink
    between two nodes, keeps the cubic along x and takes the quintic along y."""
    x = np.linspace(0.0, 2.0, 49)
    nodes = list(range(0, 49, 6))
    f = 1.0 / (3.0 - x)
    assert chosen_stencils([x], [nodes], f[nodes]).tolist() == [[6]]
    errors = []
    for stencil in (4, 6):
        interpolant = TensorInterpolant([x], [nodes], stencil)
        full = interpolant.values(f[nodes])
        true = np.abs(full - f)
        assert np.all(interpolant.estimates(f[nodes], full)[0] >= true)
        errors.append(true.max())
    assert errors[1] < 0.3 * errors[0]
    y = np.linspace(0.0, 1.0, 25)
    across = list(range(0, 25, 3))
    both = np.stack([np.exp(x)[:, None] * np.cos(y), (np.abs(x - 0.77) + x)[:, None] * np.cos(y)], axis=-1)
    assert chosen_stencils([x, y], [nodes, across], both[np.ix_(nodes, across)]).tolist() == [[6, 6], [4, 6]]


@pytest.mark.parametrize("stride", [4, 6, 8])
@pytest.mark.parametrize(
    "f",
    [lambda x: np.abs(x - 0.77) + x, lambda x: np.abs(x - 1.0) + x, lambda x: np.tanh(20.0 * (x - 0.93))],
    ids=["kink between nodes", "kink at a node", "steep front"],
)
def test_a_kink_or_a_steep_front_keeps_the_cubic(f, stride):
    """Where the function is not smooth on the scale of the nodes the Newton terms do not fall:
    the quintic's next term exceeds the cubic's somewhere near the kink or front (whichever is
    the larger at its largest), so ``chosen_stencils`` keeps the cubic. On exp(x) over the same
    nodes the quintic's term is the smaller everywhere, and it is chosen; a quintic term above the
    cubic's but below the data's own error (``noise``) is not held against it."""
    x = np.linspace(0.0, 2.0, 49)
    nodes = list(range(0, 49, stride))
    assert chosen_stencils([x], [nodes], f(x)[nodes]).tolist() == [[4]]
    smooth = np.exp(x)
    assert chosen_stencils([x], [nodes], smooth[nodes]).tolist() == [[6]]
    assert chosen_stencils([x], [nodes], f(x)[nodes], noise=1.0).tolist() == [[6]]


def test_the_quintic_needs_its_own_next_node():
    """With at most 6 nodes along an axis the quintic's next term would be no term of its own
    (``estimate_weights`` falls back one order lower): the cubic is kept."""
    x = np.linspace(0.0, 1.0, 21)
    nodes = [0, 4, 8, 12, 16, 20]
    assert chosen_stencils([x], [nodes], np.exp(x)[nodes]).tolist() == [[4]]
    assert chosen_stencils([x], [[0, 4, 8, 10, 12, 16, 20]], np.exp(x)[[0, 4, 8, 10, 12, 16, 20]]).tolist() == [[6]]
