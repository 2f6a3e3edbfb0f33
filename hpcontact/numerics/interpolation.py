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
is ``~|f'''| h^3 / 16`` (zero on a quadratic). The estimates of the axes add
(``estimates``). Both are linear in the data until the absolute value, so ``values`` and
``estimates`` take any trailing dimensions (the quantities of a map).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from enum import Enum

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
        out = np.asarray(data, dtype=np.float64)
        for axis, matrix in enumerate(self.high):
            side = low[1] if low is not None and low[0] == axis else None
            if side is not None:
                matrix = (self.lower if lower else self.low)[axis][side]
            out = _apply(matrix, out, axis, self._without(axis, side, lower))
        return out

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
        across the stencil, as the next term's estimate can)."""
        full = self.values(data) if full is None else full
        out = []
        for axis in range(len(self.xs)):
            worst = None
            for side in (0, 1):
                for lower in (False, True) if conservative else (False,):
                    diff = np.abs(self._along(data, (axis, side), lower) - full)
                    worst = diff if worst is None else np.fmax(worst, diff)
            out.append(worst)
        return out
