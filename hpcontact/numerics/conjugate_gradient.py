"""Iterative solvers on a contact mask: conjugate gradients and Polonsky–Keer.

Neither knows about kernels, FFTs or MPI: each takes the operator as a function
``apply(t) -> u`` on arrays of shape (c, nx, ny) (c traction components) and returns the
traction with the iterations and the final relative residual. A solver that stops short of its
tolerance raises ``ConvergenceError``; a non-positive curvature pᵀAp ≤ 0 (operator not positive
definite on the mask) raises it too.

Both run on the arrays they are given, of any array-API namespace (numpy on the CPU, CuPy on a
GPU: ``hpcontact.numerics.backend``), and call only the standard's functions and
``backend.dot``/``backend.norm``: no copy to or from the host inside an iteration but the scalars
the iteration decides by (pᵀAp, rᵀz, ‖r‖, the step τ), read by ``float``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from hpcontact.errors import ConvergenceError
from hpcontact.numerics.backend import Array, copy, dot, namespace, norm

Operator = Callable[[Array], Array]


@dataclass
class Solution:
    """Traction (c, nx, ny) in the namespace of the solve's arrays, iterations used and final
    relative residual ‖r‖/‖b‖."""

    traction: Array
    iterations: int
    residual: float


def conjugate_gradient(
    apply: Operator,
    rhs: Array,
    mask: Array,
    tol: float = 1e-10,
    maxiter: int | None = None,
    precondition: Operator | None = None,
) -> Solution:
    """Solve P A P t = P b for t supported on ``mask`` (prescribed surface displacement b).

    A is symmetric positive definite (a principal block of the half-space compliance), so CG
    (Hestenes & Stiefel 1952) converges; ``precondition`` applies an SPD approximation of
    (P A P)⁻¹ to a residual. Stops when ‖r‖₂ ≤ tol ‖b‖₂ on the mask. ``rhs``, ``mask`` and what
    ``apply`` and ``precondition`` return are arrays of one namespace; so is the traction returned.
    """
    if rhs.ndim != 3:
        raise ValueError("rhs must have shape (components, nx, ny)")
    xp = namespace(rhs)
    weight = xp.astype(mask, xp.float64)  # P as a 0/1 multiplier: ~3x cheaper than a where
    b = rhs * weight
    b_norm = norm(b)
    if not math.isfinite(b_norm):
        raise ValueError("prescribed displacement is not finite")
    x = xp.zeros_like(b)
    if b_norm == 0.0:
        return Solution(x, 0, 0.0)
    maxiter = maxiter if maxiter is not None else max(200, 10 * int(math.sqrt(float(xp.sum(weight)))) + 50)
    r = copy(b)

    def preconditioned(residual_: Array) -> Array:
        return precondition(residual_) * weight if precondition else residual_

    z = preconditioned(r)
    p = copy(z)
    rz = dot(r, z)
    residual = 1.0
    for iteration in range(1, maxiter + 1):
        q = apply(p)
        q *= weight
        curvature = dot(p, q)
        if not curvature > 0.0:
            raise ConvergenceError("operator is not positive definite on the mask", iteration, residual)
        alpha = rz / curvature
        x += alpha * p
        r -= alpha * q
        residual = norm(r) / b_norm
        if not math.isfinite(residual):
            raise ConvergenceError("non-finite residual in conjugate gradients", iteration, residual)
        if residual <= tol:
            return Solution(x, iteration, residual)
        z = preconditioned(r)
        rz_new = dot(r, z)
        p *= rz_new / rz
        p += z
        rz = rz_new
    raise ConvergenceError(f"conjugate gradients did not reach tol={tol:g}", maxiter, residual)


def polonsky_keer(
    apply: Operator,
    gap: Array,
    tol: float = 1e-10,
    maxiter: int | None = None,
    load: float | None = None,
    cell_area: float = 1.0,
) -> Solution:
    """Unilateral normal contact: pressure p ≥ 0, gap g = A p + h ≥ 0, p g = 0 (Signorini).

    Constrained conjugate gradients of Polonsky & Keer (1999, Wear 231, 206–219, §2). ``gap`` is
    h (nx, ny): the initial separation minus the rigid approach when ``load`` is None
    (displacement control), else the initial separation alone with the approach found so that
    Σ p · cell_area = load (load control, PK eq. 13's mean-gap shift). ``apply`` maps a
    pressure (1, nx, ny) to displacements (1, nx, ny), arrays of the namespace of ``gap``.
    Converged when the relative change of p is ≤ tol and the residuals of the problem itself are
    too (:func:`contact_residuals`): the gap on the contact (complementarity, p g = 0 with p > 0),
    the penetration outside it and, under load control, the load. Returns p as (1, nx, ny);
    ``residual`` is the largest of the four. A search direction of zero curvature before those
    are met raises ConvergenceError.
    """
    xp = namespace(gap)
    h = xp.astype(gap, xp.float64)
    if not bool(xp.all(xp.isfinite(h))):
        raise ValueError("gap is not finite")
    n_cells = math.prod(h.shape)
    maxiter = maxiter if maxiter is not None else max(500, 20 * int(math.sqrt(n_cells)))
    if load is None:
        p = xp.where(h < 0.0, -h, 0.0)
        if not bool(xp.any(p != 0.0)):
            return Solution(p[None, ...], 0, 0.0)
        scale = float(xp.max(-h))
        p *= 1.0 / max(float(xp.max(apply(p[None, ...])[0, ...])), 1e-300) * scale
    else:
        if not load > 0.0:
            raise ValueError("load must be positive")
        p = xp.full(h.shape, load / (n_cells * cell_area), dtype=xp.float64)
    t = xp.zeros_like(p)
    g_norm_old = 1.0
    delta = 0.0
    change = 1.0
    for iteration in range(1, maxiter + 1):
        g = apply(p[None, ...])[0, ...] + h
        contact = p > 0.0
        if load is not None:
            g -= xp.mean(g[contact])
        g_norm = float(xp.sum(g[contact] ** 2))
        t = xp.where(contact, g + delta * (g_norm / g_norm_old) * t, 0.0)
        g_norm_old = g_norm
        r = apply(t[None, ...])[0, ...]
        if load is not None:
            r -= xp.mean(r[contact])
        denominator = float(xp.sum(r[contact] * t[contact]))
        if denominator == 0.0:  # no search direction left: converged only if the residuals say so
            worst = max(contact_residuals(apply(p[None, ...])[0, ...], h, p, load, cell_area))
            if worst <= tol:
                return Solution(p[None, ...], iteration, worst)
            raise ConvergenceError("Polonsky-Keer search direction of zero curvature", iteration, worst)
        tau = float(xp.sum(g[contact] * t[contact])) / denominator
        p_old = copy(p)
        p = p - tau * t
        p[p < 0.0] = 0.0
        overlap = (p == 0.0) & (g < 0.0)
        if bool(xp.any(overlap)):
            delta = 0.0
            p[overlap] = p[overlap] - tau * g[overlap]
        else:
            delta = 1.0
        if load is not None:
            p *= load / (float(xp.sum(p)) * cell_area)
        total = float(xp.sum(p))
        change = float(xp.sum(xp.abs(p - p_old))) / total if total > 0 else 0.0
        if not math.isfinite(change):
            raise ConvergenceError("non-finite pressure in Polonsky-Keer iteration", iteration, change)
        if change <= tol:
            worst = max(contact_residuals(apply(p[None, ...])[0, ...], h, p, load, cell_area))
            if worst <= tol:
                return Solution(p[None, ...], iteration, max(change, worst))
    raise ConvergenceError(f"Polonsky-Keer did not reach tol={tol:g}", maxiter, change)


def contact_residuals(u: Array, h: Array, p: Array, load: float | None, cell_area: float) -> tuple[float, float, float]:
    """Residuals of the Signorini conditions at pressure ``p`` with displacement u = A p:
    (largest |gap| on the contact, largest penetration −g outside it, both relative to the
    largest displacement on the contact; relative load error |Σ p · cell_area − load|/load,
    0 under displacement control). Under load control the gap is taken after the mean-gap
    shift (the unknown approach). Arrays of one namespace; floats on the host."""
    xp = namespace(u)
    contact = p > 0.0
    if not bool(xp.any(contact)):
        return 0.0, max(0.0, float(-xp.min(h))), 0.0
    g = u + h
    if load is not None:
        g = g - xp.mean(g[contact])
    scale = max(float(xp.max(xp.abs(u[contact]))), 1e-300)
    gap = float(xp.max(xp.abs(g[contact]))) / scale
    outside = ~contact
    penetration = max(0.0, float(-xp.min(g[outside]))) / scale if bool(xp.any(outside)) else 0.0
    load_error = 0.0 if load is None else abs(float(xp.sum(p)) * cell_area - load) / load
    return gap, penetration, load_error
