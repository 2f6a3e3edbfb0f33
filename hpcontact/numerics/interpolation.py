"""Tensor-product interpolation of a map from a subset of its grid, with an error estimate.

An adaptive sweep (``hpcontact.sweep.maps``) solves the points of a tensor product of node
sets, one increasing list of grid indices per numeric axis (always both ends), and fills every
other grid point from them. Along one axis the interpolant is local Lagrange of ``STENCIL``
nodes (cubic: the two nodes either side of the point's interval, shifted inwards at the ends;
fewer when the axis has fewer nodes) in the axis' natural coordinate: ``log10`` of the value
for a logspace axis (``Scale.LOG``), the value itself otherwise. In several dimensions the
one-dimensional interpolants are applied axis after axis (a tensor product), so the map is
exact at the nodes and every axis keeps its own spacing. The stencil may differ by axis
(``TensorInterpolant``'s ``stencil``: one per axis): ``chosen_stencils`` takes the quintic (6)
along an axis where its next Newton term is below the cubic's at every point (an analytic
function the nodes resolve), the cubic elsewhere (a kink, a steep front).

The error estimate of axis ``d`` at a point is the larger difference between the interpolant
and the two interpolants of one order lower along ``d`` alone (the quadratics through the
stencil without its first or without its last node): the size of the next term of the
Newton form, which is the lower order's error and over-estimates the cubic's by about one
order of the node spacing; on a function with second derivative ``f''`` and spacing ``h`` it
is ``~|f'''| h^3 / 16`` (zero on a quadratic). At the two intervals next to each end of the
nodes the fifth node lies inwards only; there the estimate also extrapolates the divided
difference's growth towards the end (``end_terms``). The estimates of the axes add
(``estimates``). Both are linear in the data until the absolute value, so ``values`` and
``estimates`` take any trailing dimensions (the quantities of a map).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from enum import Enum
from typing import NamedTuple

import numpy as np

#: Nodes of the one-dimensional interpolant (4: cubic).
STENCIL = 4

#: At an interval whose stencil grows inwards only (``end_terms``), the largest ratio of the
#: second next Newton term to the first (both with nodes added inwards) for which the estimate
#: trusts its extrapolations (``TensorInterpolant.axis_estimate``); above it the terms do not
#: fall as the order assumes and the estimate takes the lower order's own error too. On Mindlin's
#: K_a/K_b (benchmarks/map_honesty.py M1) at the first interval of b/a next to b/a = 1, nodes
#: 0.25 apart in log10 b/a, the quintic's second term is 0.07 … 40 × its first (nu 0.5 … 0.025)
#: and its error 0.3 … 100 × the next term (nu 0.25: 0.97 × and 2.7 ×): with no such rule 44
#: points of M1 were under their estimate, with the ratio 1, 6. Half is the ratio test's usual
#: bound; a third (the geometric tail, Σ r^k = 1/(1 − r) within ``estimates.SAFETY`` 1.5) held
#: every map too but took M9's from 70 to 87 solves (docs/howto/adaptive.md).
FALLING = 0.5


class Scale(Enum):
    """The coordinate an axis is interpolated in."""

    LINEAR = "linear"
    LOG = "log"


def coordinate(values: Sequence[float], scale: Scale) -> np.ndarray:
    """The axis ``values`` in the coordinate of ``scale`` (``log10`` of positive values for LOG)."""
    x = np.asarray(values, dtype=np.float64)
    if scale is Scale.LOG:
        if not np.all(x > 0.0):
            raise ValueError("a log-scale axis needs positive values")
        return np.log10(x)
    return x


def bisection_nodes(n: int, minimum: int) -> list[int]:
    """The first nested bisection level of the indices ``0 … n-1`` with at least ``minimum``
    nodes (or all ``n``): level 0 is both ends, each next level adds the midpoint ``(i + j) // 2``
    of every interval of the last one that has an index inside (every 2^k-th index when
    ``n - 1`` is a power of two: 41 points → 0, 10, 20, 30, 40)."""
    nodes = [0] if n == 1 else [0, n - 1]
    while len(nodes) < min(minimum, n):
        nodes = refined(nodes, [True] * (len(nodes) - 1))
    return nodes


def refined(nodes: Sequence[int], split: Sequence[bool]) -> list[int]:
    """``nodes`` with the midpoint of each interval ``nodes[m], nodes[m + 1]`` for which
    ``split[m]`` holds and an index lies inside."""
    out = [nodes[0]]
    for m, (i, j) in enumerate(zip(nodes[:-1], nodes[1:])):
        if split[m] and j - i >= 2:
            out.append((i + j) // 2)
        out.append(j)
    return out


def _lagrange(x: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """Weights of the Lagrange interpolant through the nodes ``xs`` at the points ``x``
    (shape (len(x), len(xs)))."""
    w = np.ones((len(x), len(xs)))
    for j, xj in enumerate(xs):
        for k, xk in enumerate(xs):
            if k != j:
                w[:, j] *= (x - xk) / (xj - xk)
    return w


def weights(x: np.ndarray, nodes: Sequence[int], stencil: int = STENCIL, drop: int | None = None) -> np.ndarray:
    """The interpolation matrix (len(x) × len(nodes)) from the values at ``x[nodes]`` to every
    point of ``x``: local Lagrange of ``min(stencil, len(nodes))`` nodes around each point's
    interval; ``drop`` 0 or 1 leaves one node of each stencil out (one order lower: the
    estimate's interpolants): of the stencil's nodes other than the interval's ends, the one
    farthest from the interval (0) or the next (1; the same when there is one), so the lower
    order still interpolates across the interval and never extrapolates; a stencil of two nodes
    drops to the nearer one. Exact at the nodes."""
    x = np.asarray(x, dtype=np.float64)
    nodes = np.asarray(nodes, dtype=np.intp)
    xn = x[nodes]
    count = len(nodes)
    size = min(stencil, count)
    out = np.zeros((len(x), count))
    if count == 1:
        out[:, 0] = 1.0
        return out
    # the interval of each point: nodes[k] <= i < nodes[k + 1] (the last node: the last interval)
    k = np.clip(np.searchsorted(nodes, np.arange(len(x)), side="right") - 1, 0, count - 2)
    first = np.clip(k - (size - 2) // 2, 0, count - size)
    for start, interval in sorted(set(zip(first.tolist(), k.tolist()))):
        rows = np.flatnonzero((first == start) & (k == interval))
        cols = list(range(start, start + size))
        if drop is not None:
            others = sorted(
                (c for c in cols if c not in (interval, interval + 1)),
                key=lambda c: (-max(abs(c - interval), abs(c - interval - 1)), c),
            )
            if others:
                cols.remove(others[min(drop, len(others) - 1)])
            else:  # two nodes: the nearer one
                near = x[rows] - xn[interval] <= xn[interval + 1] - x[rows]
                out[rows, interval] = near
                out[rows, interval + 1] = ~near
                continue
        out[np.ix_(rows, cols)] = _lagrange(x[rows], xn[cols])
    out[nodes] = np.eye(count)  # exact at the nodes, whatever the stencil
    return out


def estimate_weights(x: np.ndarray, nodes: Sequence[int], stencil: int = STENCIL, side: int = 0) -> np.ndarray:
    """The interpolation matrix of one order higher than ``weights``: each point's stencil
    with one more node, the next one to the left (``side`` 0) or to the right (1), or the other
    side where there is none. Its difference from ``weights`` is the next term of the Newton
    form: the estimate of the interpolant's error. With no node to add (at most ``stencil``
    nodes), ``weights`` one order lower (``drop`` = ``side``): the estimate of the lower order's
    error, an over-estimate."""
    x = np.asarray(x, dtype=np.float64)
    nodes = np.asarray(nodes, dtype=np.intp)
    count = len(nodes)
    if count <= stencil:
        return weights(x, nodes, stencil, drop=side)
    xn = x[nodes]
    out = np.zeros((len(x), count))
    k = np.clip(np.searchsorted(nodes, np.arange(len(x)), side="right") - 1, 0, count - 2)
    first = np.clip(k - (stencil - 2) // 2, 0, count - stencil)
    begin = first - 1 if side == 0 else first
    begin = np.clip(begin, 0, count - stencil - 1)
    for start in np.unique(begin):
        rows = np.flatnonzero(begin == start)
        cols = np.arange(start, start + stencil + 1)
        out[np.ix_(rows, cols)] = _lagrange(x[rows], xn[cols])
    out[nodes] = np.eye(count)
    return out


class EndTerms(NamedTuple):
    """What the estimate adds at the intervals whose stencil can grow on one side only
    (``end_terms``): whether each point is in one (``one_sided``), the third divided differences
    of the cubic's window and of the window one node inwards as weights on the nodes, one row
    per end (``near``, ``far``: the first end, the last), the end of each point (``end``), the
    positions that extrapolate their growth (``base``, ``reach``), and the matrix of the next
    two Newton terms (``quintic``: the quintic's difference from the cubic; None with five
    nodes)."""

    one_sided: np.ndarray
    near: np.ndarray
    far: np.ndarray
    end: np.ndarray
    base: np.ndarray
    reach: np.ndarray
    quintic: np.ndarray | None


def _divided_difference(xs: np.ndarray) -> np.ndarray:
    """The divided difference f[xs] as weights on f(xs): Σ_j f(x_j) / Π_{k≠j} (x_j − x_k)."""
    return np.array([1.0 / np.prod([xj - xk for k, xk in enumerate(xs) if k != j]) for j, xj in enumerate(xs)])


def end_terms(x: np.ndarray, nodes: Sequence[int], stencil: int = STENCIL) -> EndTerms | None:
    """The estimate's terms at the intervals whose stencil can grow on one side only (None:
    none can grow, at most ``stencil`` nodes): the two next to each end of the nodes (an axis'
    end, or the halo beyond a leaf's cut face). There the next Newton term g(x_5) w(x) (g(y) =
    f[C, y], C the cubic's nodes, w(x) = Π_C (x − c), x_5 the next node inwards) samples the
    divided difference inwards of the point alone, while the cubic's error is g(x) w(x), x nearer
    the end; where the derivatives grow towards the end (a pole, s⁶, an exponential) the term
    falls short (to 0.28 × at the last interval of 0.2/(1.15 − s) on a 33-point axis with nodes 0,
    4, 8, 16, 20, … 32: tests/numerics/test_interpolation.py; docs/howto/adaptive.md). Two
    extrapolations towards the end:

    * linear (six nodes or more): g(x_5) + (x − x_5)(g(x_5) − g(x_6))/(x_5 − x_6), x_6 the node after
      x_5: the next two Newton terms (``quintic``), exact where f⁽⁵⁾ is constant;
    * the growth of the divided difference, read from the cubic's window at the end (C, its third
      difference D_near) and the window one node inwards (D_far), with 1/D linear in the
      window's mean m (harmonic): g(x)/g(x_5) = (1 + a (1 − ρ)) / (1 + b (1 − ρ)), ρ = D_near/D_far,
      a = (M_5 − m_near)/(m_near − m_far), b = (M − m_near)/(m_near − m_far), M_5 the mean of C and
      x_5 (g(x_5)'s nodes) and M = M_5 + (x − x_5)/5 that of g(x)'s (``base`` a, ``reach`` b).
      Exact on a pole c/(a − y) where the means stand for the nodes (its divided differences
      are c/Π(a − y_i)); above the true growth where 1/|D| is convex in the mean (an
      exponential, a power), so it over-estimates there rather than under. Where 1 + b (1 − ρ)
      ≤ 0 (1/D extrapolates through zero: a pole inside the interval, or ρ read from
      differences at round-off), the geometric growth |ρ|^(b − a) instead (ln |D| linear in the
      mean: exact to leading order on an exponential); where D changes sign between the two
      windows, no growth (the linear term's case).

    ``TensorInterpolant.estimates`` takes the larger of the next term, the linear one and the
    grown one bounded by the lower order's own error (a growth read from differences near
    round-off is noise; the lower order's error is not), and that error itself where the next
    two terms do not fall (``FALLING``): both extrapolations assume they do."""
    x = np.asarray(x, dtype=np.float64)
    nodes = np.asarray(nodes, dtype=np.intp)
    count = len(nodes)
    if count <= stencil:
        return None
    xn = x[nodes]
    k = np.clip(np.searchsorted(nodes, np.arange(len(x)), side="right") - 1, 0, count - 2)
    first = np.clip(k - (stencil - 2) // 2, 0, count - stencil)
    one_sided = (first == 0) | (first == count - stencil)
    one_sided[nodes] = False
    size = len(x)
    near, far = np.zeros((2, count)), np.zeros((2, count))
    quintic = np.zeros((size, count)) if count >= stencil + 2 else None
    end, base, reach = np.zeros(size, dtype=np.intp), np.zeros(size), np.zeros(size)
    cubic = weights(x, nodes, stencil)
    for start in sorted(set(first[one_sided].tolist())):
        rows = np.flatnonzero(one_sided & (first == start))
        cols = list(range(start, start + stencil))
        inwards = 1 if start == 0 else -1  # the side the stencil can grow to
        fifth = cols[-1] + 1 if inwards > 0 else cols[0] - 1
        if quintic is not None:
            chosen = sorted(cols + [fifth, fifth + inwards])
            quintic[np.ix_(rows, chosen)] = _lagrange(x[rows], xn[chosen])
            quintic[rows] -= cubic[rows]
        windows = (cols, [c + inwards for c in cols])
        side = 0 if inwards > 0 else 1
        end[rows] = side
        for matrix, window in zip((near, far), windows):
            matrix[side, window] = _divided_difference(xn[window])
        m_near, m_far = (float(np.mean(xn[w])) for w in windows)
        mean = float(np.mean(xn[sorted({*cols, fifth})]))
        base[rows] = (mean - m_near) / (m_near - m_far)
        reach[rows] = (mean + (x[rows] - xn[fifth]) / (stencil + 1) - m_near) / (m_near - m_far)
    return EndTerms(one_sided, near, far, end, base, reach, quintic)


def _apply(
    matrix: np.ndarray, data: np.ndarray, axis: int, without: Callable[[np.ndarray], np.ndarray] | None = None
) -> np.ndarray:
    """``matrix`` applied along ``axis`` of ``data``. A line of ``data`` along ``axis`` that
    holds NaN (a node whose solve failed) is interpolated from its other nodes instead, by
    ``without(valid)``, the matrix of the nodes where ``valid`` (all NaN where none is): the
    matrix product would spread the NaN to every point (0 × NaN is NaN), and a hole in one line
    leaves the others as they are."""
    moved = np.moveaxis(np.asarray(data, dtype=np.float64), axis, 0)
    lines = moved.reshape(moved.shape[0], -1)
    missing = np.isnan(lines)
    out = matrix @ np.where(missing, 0.0, lines)
    holed = np.flatnonzero(missing.any(axis=0))
    for line in holed:
        valid = ~missing[:, line]
        out[:, line] = without(valid) @ lines[valid, line] if without is not None and valid.any() else np.nan
    return np.moveaxis(out.reshape((matrix.shape[0], *moved.shape[1:])), 0, axis)


class TensorInterpolant:
    """Interpolation from the tensor product of ``nodes`` (one index list per axis) to the full
    grid of the axes' coordinates ``xs`` (in their interpolation coordinate: ``coordinate``)."""

    def __init__(
        self, xs: Sequence[np.ndarray], nodes: Sequence[Sequence[int]], stencil: int | Sequence[int] = STENCIL
    ) -> None:
        if len(xs) != len(nodes):
            raise ValueError("one node list per axis")
        self.xs = [np.asarray(x, dtype=np.float64) for x in xs]
        self.nodes = [list(n) for n in nodes]
        self.stencils = [stencil] * len(self.xs) if isinstance(stencil, int) else [int(s) for s in stencil]
        if len(self.stencils) != len(self.xs):
            raise ValueError("one stencil per axis")
        triples = list(zip(self.xs, self.nodes, self.stencils))
        self.high = [weights(x, n, s) for x, n, s in triples]
        self.low = [(estimate_weights(x, n, s, 0), estimate_weights(x, n, s, 1)) for x, n, s in triples]
        self.lower = [(weights(x, n, s, drop=0), weights(x, n, s, drop=1)) for x, n, s in triples]
        self.ends = [end_terms(x, n, s) for x, n, s in triples]
        self.cubic = [weights(x, n, STENCIL) if s > STENCIL else None for x, n, s in triples]

    def _without(
        self, axis: int, side: int | None, lower: bool = False, stencil: int | None = None
    ) -> Callable[[np.ndarray], np.ndarray]:
        """The matrix along ``axis`` (``weights``; ``estimate_weights`` of ``side``, or with
        ``lower`` ``weights`` one order lower) of the nodes where ``valid``: a line with a
        failed node interpolates from the others."""
        x, nodes = self.xs[axis], np.asarray(self.nodes[axis])

        def matrix(valid: np.ndarray) -> np.ndarray:
            kept, size = nodes[valid], self.stencils[axis] if stencil is None else stencil
            if side is None:
                return weights(x, kept, size)
            if lower:
                return weights(x, kept, size, drop=side)
            return estimate_weights(x, kept, size, side)

        return matrix

    def _along(self, data: np.ndarray, low: tuple[int, int] | None = None, lower: bool = False) -> np.ndarray:
        """``data`` at the nodes interpolated axis after axis; ``low`` = (axis, side): that
        axis with the estimate's matrix of ``side`` (with ``lower``: one order lower)."""
        if low is None:
            return self._through(data)
        axis, side = low
        return self._through(
            data, axis, (self.lower if lower else self.low)[axis][side], self._without(axis, side, lower)
        )

    def _through(
        self,
        data: np.ndarray,
        axis: int | None = None,
        matrix: np.ndarray | None = None,
        without: Callable[[np.ndarray], np.ndarray] | None = None,
    ) -> np.ndarray:
        """``data`` at the nodes interpolated axis after axis, ``axis`` with ``matrix`` (and
        ``without`` for its lines through a failed node) instead of the interpolant."""
        out = np.asarray(data, dtype=np.float64)
        for d, high in enumerate(self.high):
            if d == axis:
                out = _apply(matrix, out, d, without)
            else:
                out = _apply(high, out, d, self._without(d, None))
        return out

    def _end_without(self, axis: int, term: str) -> Callable[[np.ndarray], np.ndarray]:
        """The ``end_terms`` matrix ``term`` along ``axis`` of the nodes where ``valid`` (zero where
        those leave no term)."""
        x, nodes = self.xs[axis], np.asarray(self.nodes[axis])

        def matrix(valid: np.ndarray) -> np.ndarray:
            ends = end_terms(x, nodes[valid], self.stencils[axis])
            found = None if ends is None else getattr(ends, term)
            return np.zeros((len(x) if term == "quintic" else 2, int(valid.sum()))) if found is None else found

        return matrix

    def values(self, data: np.ndarray) -> np.ndarray:
        """The interpolant on the full grid from ``data`` at the nodes (shape: the node counts,
        then any trailing dimensions). A NaN node (a failed solve) is left out of the lines
        through it (``_apply``)."""
        return self._along(data)

    def estimates(
        self, data: np.ndarray, full: np.ndarray | None = None, conservative: bool = False
    ) -> list[np.ndarray]:
        """The absolute error estimate of each axis on the full grid (module docstring); ``full``
        is ``values(data)`` when the caller has it. Zero at the nodes of that axis.
        ``conservative``: the larger of that and the difference from the two interpolants one
        order lower (the lower order's own error: it over-estimates the interpolant's by about
        one order of the spacing, and does not vanish where the next derivative changes sign
        across the stencil, as the next term's estimate can). At an interval whose stencil can
        grow on one side only (``end_terms``: the ends of an axis' nodes), the larger of the next
        term, the next two (linear extrapolation of the divided difference towards the end) and
        the grown one bounded by the lower order's error; and the lower order's error itself where
        the second of the next two terms exceeds ``FALLING`` × the first by more than their
        round-off (the terms do not fall, so neither extrapolation holds), or, above the cubic,
        where there is no second term to tell."""
        full = self.values(data) if full is None else full
        return [self.axis_estimate(data, full, axis, conservative) for axis in range(len(self.xs))]

    def next_terms(self, data: np.ndarray, full: np.ndarray, axis: int) -> list[np.ndarray]:
        """The next Newton term along ``axis`` on the full grid, signed, with a node added to the
        left and with one added to the right (``estimate_weights``); ``full`` is ``values(data)``."""
        return [self._along(data, (axis, side)) - full for side in (0, 1)]

    def next_term(self, data: np.ndarray, full: np.ndarray, axis: int) -> np.ndarray:
        """The larger of the two ``next_terms`` in size."""
        return np.fmax(*(np.abs(t) for t in self.next_terms(data, full, axis)))

    def axis_estimate(self, data: np.ndarray, full: np.ndarray, axis: int, conservative: bool = False) -> np.ndarray:
        """The absolute error estimate of ``axis`` on the full grid (``estimates``), ``full`` the
        ``values(data)``."""
        terms = self.next_terms(data, full, axis)
        sharp = np.fmax(*(np.abs(t) for t in terms))
        lower = None
        if conservative or self.ends[axis] is not None:
            lower = np.fmax(*(np.abs(self._along(data, (axis, side), True) - full) for side in (0, 1)))
        worst = np.fmax(sharp, lower) if conservative else sharp
        ends = self.ends[axis]
        if ends is None:
            return worst
        cubic, cap = self.cubic[axis], lower
        if cubic is not None:  # above the cubic: the cap of the grown term is the cubic's difference too
            cap = np.fmax(
                lower, np.abs(self._through(data, axis, cubic, self._without(axis, None, stencil=STENCIL)) - full)
            )
        near, far = (  # one line per end along ``axis``, then each point's end
            np.take(self._through(data, axis, getattr(ends, term), self._end_without(axis, term)), ends.end, axis)
            for term in ("near", "far")
        )
        quintic = (
            np.zeros_like(sharp)
            if ends.quintic is None
            else self._through(data, axis, ends.quintic, self._end_without(axis, "quintic"))
        )
        shape = [1] * worst.ndim
        shape[axis] = len(ends.reach)
        base, reach = ends.base.reshape(shape), ends.reach.reshape(shape)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            ratio = near / far  # ρ
            numerator, denominator = 1.0 + base * (1.0 - ratio), 1.0 + reach * (1.0 - ratio)
            harmonic = (numerator > 0.0) & (denominator > 0.0)
            growth = np.where(harmonic, numerator / denominator, np.abs(ratio) ** (reach - base))
            growth = np.where(near * far > 0.0, growth, 0.0)  # a sign change: the linear term's
            grown = np.fmin(np.nan_to_num(sharp * growth, nan=0.0, posinf=np.inf), cap)
        extra = np.fmax(np.abs(quintic), grown)
        if ends.quintic is not None:  # where the next two terms do not fall (``FALLING``): the lower order's error
            first = np.where((ends.end == 0).reshape(shape), terms[1], terms[0])  # the node added inwards
            rising = np.abs(quintic - first) > FALLING * np.abs(first) + self._roundoff(data, axis, ends.quintic)
            extra = np.where(rising, np.fmax(extra, lower), extra)
        elif cubic is not None:  # above the cubic, no second term to show that its terms fall
            extra = np.fmax(extra, lower)
        return np.where(ends.one_sided.reshape(shape), np.fmax(worst, extra), worst)

    def _roundoff(self, data: np.ndarray, axis: int, terms: np.ndarray) -> np.ndarray:
        """A bound on the round-off of the Newton terms ``terms`` (a matrix along ``axis``, the
        difference of two interpolants) and of the interpolant on the full grid: n ε Σ_j |w_j| |f_j|
        (Higham, Accuracy and Stability of Numerical Algorithms, 2nd ed., eq. 3.5: a dot product of
        n terms is within γ_n ≤ 1.01 n u of its value, u = ε/2; the two interpolants' errors add),
        n the largest stencil the terms span plus one, with the weights of ``terms`` and of the
        interpolant along ``axis`` in size, the data in size (0 where a solve failed)."""
        n = int(np.count_nonzero(terms, axis=1).max(initial=0)) + 1
        size = self._through(np.abs(np.nan_to_num(data, nan=0.0)), axis, np.abs(terms) + np.abs(self.high[axis]))
        return n * np.finfo(np.float64).eps * size


#: The stencils an axis may be interpolated with (``chosen_stencils``): cubic, quintic.
ORDERS = (4, 6)


def chosen_stencils(
    xs: Sequence[np.ndarray],
    nodes: Sequence[Sequence[int]],
    data: np.ndarray,
    noise: np.ndarray | float = 0.0,
    orders: Sequence[int] = ORDERS,
) -> np.ndarray:
    """The stencil of each axis for each column of ``data`` (the values at ``nodes``; its trailing
    dimensions flattened: shape (columns, axes)): the smallest of ``orders`` (the cubic), unless
    along that axis a larger one has its own next node (``len(nodes[d]) > stencil``) and its next
    Newton term (``TensorInterpolant.next_term``) is at most the smaller one's at every grid
    point: the higher order where its terms fall faster everywhere (an analytic function the
    nodes resolve: on exp(x) with nodes 0.25 apart the quintic's term is 0.02 × the cubic's), the
    cubic where they do not somewhere (a kink, a steep front, a pole or a bump the nodes do not
    resolve: there the wider stencil's term is the larger near it; tests/numerics/
    test_interpolation.py). Where both terms are below ``noise`` (the data's own absolute error,
    broadcast to the grid and columns) they are differences of that error and not compared.
    Each axis is judged with the others cubic."""
    data = np.asarray(data, dtype=np.float64)
    dims = len(xs)
    columns = int(np.prod(data.shape[dims:], dtype=np.intp))
    first = orders[0]
    chosen = np.full((columns, dims), first, dtype=np.intp)

    def estimate(interpolant: TensorInterpolant, full: np.ndarray, axis: int) -> np.ndarray:
        return interpolant.next_term(data, full, axis).reshape(-1, columns)

    lowest = TensorInterpolant(xs, nodes, [first] * dims)  # built and applied once for every axis
    lowest_full = lowest.values(data)
    floor = np.broadcast_to(noise, (*(len(x) for x in xs), *data.shape[dims:])).reshape(-1, columns)
    for axis in range(dims):
        below = np.fmax(estimate(lowest, lowest_full, axis), floor)
        for stencil in orders[1:]:
            if len(nodes[axis]) <= stencil:
                break
            higher = TensorInterpolant(xs, nodes, [stencil if d == axis else first for d in range(dims)])
            found = estimate(higher, higher.values(data), axis)
            better = np.all(found <= below, axis=0)  # NaN (a failed node's line): not better
            if not better.any():
                break
            chosen[better, axis] = stencil
            below = np.where(better, np.fmax(found, floor), -np.inf)  # a column kept lower stays lower
    return chosen
