"""Tensor-product interpolation of a map from a subset of its grid, with an error estimate.

An adaptive sweep (``hpcontact.sweep.maps``) solves the points of a tensor product of node
sets, one increasing list of grid indices per numeric axis (always both ends), and fills every
other grid point from them. Along one axis the interpolant is local Lagrange of ``STENCIL``
nodes (cubic: the two nodes either side of the point's interval, shifted inwards at the ends;
fewer when the axis has fewer nodes) in the axis' natural coordinate: ``log10`` of the value
for a logspace axis (``Scale.LOG``), the value itself otherwise. In several dimensions the
one-dimensional interpolants are applied axis after axis (a tensor product), so the map is
exact at the nodes and every axis keeps its own spacing.

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
    round-off is noise; the lower order's error is not)."""
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

    def __init__(self, xs: Sequence[np.ndarray], nodes: Sequence[Sequence[int]], stencil: int = STENCIL) -> None:
        if len(xs) != len(nodes):
            raise ValueError("one node list per axis")
        self.xs = [np.asarray(x, dtype=np.float64) for x in xs]
        self.nodes = [list(n) for n in nodes]
        self.stencil = stencil
        self.high = [weights(x, n, stencil) for x, n in zip(self.xs, self.nodes)]
        self.low = [
            (estimate_weights(x, n, stencil, 0), estimate_weights(x, n, stencil, 1))
            for x, n in zip(self.xs, self.nodes)
        ]
        self.lower = [
            (weights(x, n, stencil, drop=0), weights(x, n, stencil, drop=1)) for x, n in zip(self.xs, self.nodes)
        ]
        self.ends = [end_terms(x, n, stencil) for x, n in zip(self.xs, self.nodes)]

    def _without(self, axis: int, side: int | None, lower: bool = False) -> Callable[[np.ndarray], np.ndarray]:
        """The matrix along ``axis`` (``weights``; ``estimate_weights`` of ``side``, or with
        ``lower`` ``weights`` one order lower) of the nodes where ``valid``: a line with a
        failed node interpolates from the others."""
        x, nodes = self.xs[axis], np.asarray(self.nodes[axis])

        def matrix(valid: np.ndarray) -> np.ndarray:
            kept = nodes[valid]
            if side is None:
                return weights(x, kept, self.stencil)
            if lower:
                return weights(x, kept, self.stencil, drop=side)
            return estimate_weights(x, kept, self.stencil, side)

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
            ends = end_terms(x, nodes[valid], self.stencil)
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
        the grown one bounded by the lower order's error."""
        full = self.values(data) if full is None else full
        out = []
        for axis in range(len(self.xs)):
            sharp = np.fmax(*(np.abs(self._along(data, (axis, side)) - full) for side in (0, 1)))
            lower = None
            if conservative or self.ends[axis] is not None:
                lower = np.fmax(*(np.abs(self._along(data, (axis, side), True) - full) for side in (0, 1)))
            worst = np.fmax(sharp, lower) if conservative else sharp
            ends = self.ends[axis]
            if ends is not None:
                near, far = (  # one line per end along ``axis``, then each point's end
                    np.take(
                        self._through(data, axis, getattr(ends, term), self._end_without(axis, term)), ends.end, axis
                    )
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
                    grown = np.fmin(np.nan_to_num(sharp * growth, nan=0.0, posinf=np.inf), lower)
                extra = np.fmax(np.abs(quintic), grown)
                worst = np.where(ends.one_sided.reshape(shape), np.fmax(worst, extra), worst)
            out.append(worst)
        return out
