"""Iterative solvers on a contact mask: conjugate gradients and Polonsky–Keer.

Neither knows about kernels, FFTs or MPI: each takes the operator as a function
``apply(t) -> u`` on arrays of shape (c, nx, ny) (c traction components) and returns the
traction with the iterations and the final relative residual. A solver that stops short of its
tolerance raises ``ConvergenceError``; a non-positive curvature pᵀAp ≤ 0 (operator not positive
definite on the mask) raises it too.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hpcontact.errors import ConvergenceError

Operator = Callable[[np.ndarray], np.ndarray]


@dataclass
class Solution:
    """Traction (c, nx, ny), iterations used and final relative residual ‖r‖/‖b‖."""

    traction: np.ndarray
    iterations: int
    residual: float


def conjugate_gradient(
    apply: Operator,
    rhs: np.ndarray,
    mask: np.ndarray,
    tol: float = 1e-10,
    maxiter: int | None = None,
    precondition: Operator | None = None,
) -> Solution:
    """Solve P A P t = P b for t supported on ``mask`` (prescribed surface displacement b).

    A is symmetric positive definite (a principal block of the half-space compliance), so CG
    (Hestenes & Stiefel 1952) converges; ``precondition`` applies an SPD approximation of
    (P A P)⁻¹ to a residual. Stops when ‖r‖₂ ≤ tol ‖b‖₂ on the mask.
    """
    if rhs.ndim != 3:
        raise ValueError("rhs must have shape (components, nx, ny)")
    weight = mask.astype(np.float64)  # P as a 0/1 multiplier: ~3x cheaper than np.where
    b = rhs * weight
    b_norm = float(np.linalg.norm(b))
    if not math.isfinite(b_norm):
        raise ValueError("prescribed displacement is not finite")
    x = np.zeros_like(b)
    if b_norm == 0.0:
        return Solution(x, 0, 0.0)
    maxiter = maxiter if maxiter is not None else max(200, 10 * int(math.sqrt(mask.sum())) + 50)
    r = b.copy()
    step = np.empty_like(b)  # scratch for the x and r updates

    def preconditioned(residual_: np.ndarray) -> np.ndarray:
        return precondition(residual_) * weight if precondition else residual_

    z = preconditioned(r)
    p = z.copy()
    rz = float(np.vdot(r, z))
    residual = 1.0
    for iteration in range(1, maxiter + 1):
        q = apply(p)
        q *= weight
        curvature = float(np.vdot(p, q))
        if not curvature > 0.0:
            raise ConvergenceError("operator is not positive definite on the mask", iteration, residual)
        alpha = rz / curvature
        x += np.multiply(alpha, p, out=step)
        r -= np.multiply(alpha, q, out=step)
        residual = float(np.linalg.norm(r)) / b_norm
        if not math.isfinite(residual):
            raise ConvergenceError("non-finite residual in conjugate gradients", iteration, residual)
        if residual <= tol:
            return Solution(x, iteration, residual)
        z = preconditioned(r)
        rz_new = float(np.vdot(r, z))
        p *= rz_new / rz
        p += z
        rz = rz_new
    raise ConvergenceError(f"conjugate gradients did not reach tol={tol:g}", maxiter, residual)


def polonsky_keer(
    apply: Operator,
    gap: np.ndarray,
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
    pressure (1, nx, ny) to displacements (1, nx, ny). Converged when the relative change of p
    is ≤ tol and the residuals of the problem itself are too (:func:`contact_residuals`): the
    gap on the contact (complementarity, p g = 0 with p > 0), the penetration outside it and,
    under load control, the load. Returns p as (1, nx, ny); ``residual`` is the largest of the
    four. A search direction of zero curvature before those are met raises ConvergenceError.
    """
    h = np.asarray(gap, dtype=np.float64)
    if not np.all(np.isfinite(h)):
        raise ValueError("gap is not finite")
    n_cells = h.size
    maxiter = maxiter if maxiter is not None else max(500, 20 * int(math.sqrt(n_cells)))
    if load is None:
        p = np.where(h < 0.0, -h, 0.0)
        if not p.any():
            return Solution(p[None], 0, 0.0)
        scale = float(np.max(-h))
        p *= 1.0 / max(float(np.max(apply(p[None])[0])), 1e-300) * scale
    else:
        if not load > 0.0:
            raise ValueError("load must be positive")
        p = np.full(h.shape, load / (n_cells * cell_area))
    t = np.zeros_like(p)
    g_norm_old = 1.0
    delta = 0.0
    change = 1.0
    for iteration in range(1, maxiter + 1):
        g = apply(p[None])[0] + h
        contact = p > 0.0
        if load is not None:
            g -= g[contact].mean()
        g_norm = float(np.sum(g[contact] ** 2))
        t = np.where(contact, g + delta * (g_norm / g_norm_old) * t, 0.0)
        g_norm_old = g_norm
        r = apply(t[None])[0]
        if load is not None:
            r -= r[contact].mean()
        denominator = float(np.sum(r[contact] * t[contact]))
        if denominator == 0.0:  # no search direction left: converged only if the residuals say so
            worst = max(contact_residuals(apply(p[None])[0], h, p, load, cell_area))
            if worst <= tol:
                return Solution(p[None], iteration, worst)
            raise ConvergenceError("Polonsky-Keer search direction of zero curvature", iteration, worst)
        tau = float(np.sum(g[contact] * t[contact])) / denominator
        p_old = p.copy()
        p = p - tau * t
        p[p < 0.0] = 0.0
        overlap = (p == 0.0) & (g < 0.0)
        if overlap.any():
            delta = 0.0
            p[overlap] -= tau * g[overlap]
        else:
            delta = 1.0
        if load is not None:
            p *= load / (p.sum() * cell_area)
        total = float(np.sum(p))
        change = float(np.sum(np.abs(p - p_old))) / total if total > 0 else 0.0
        if not math.isfinite(change):
            raise ConvergenceError("non-finite pressure in Polonsky-Keer iteration", iteration, change)
        if change <= tol:
            worst = max(contact_residuals(apply(p[None])[0], h, p, load, cell_area))
            if worst <= tol:
                return Solution(p[None], iteration, max(change, worst))
    raise ConvergenceError(f"Polonsky-Keer did not reach tol={tol:g}", maxiter, change)


def contact_residuals(
    u: np.ndarray, h: np.ndarray, p: np.ndarray, load: float | None, cell_area: float
) -> tuple[float, float, float]:
    """Residuals of the Signorini conditions at pressure ``p`` with displacement u = A p:
    (largest |gap| on the contact, largest penetration −g outside it, both relative to the
    largest displacement on the contact; relative load error |Σ p · cell_area − load|/load,
    0 under displacement control). Under load control the gap is taken after the mean-gap
    shift (the unknown approach)."""
    contact = p > 0.0
    if not contact.any():
        return 0.0, max(0.0, float(-np.min(h))), 0.0
    g = u + h
    if load is not None:
        g = g - g[contact].mean()
    scale = max(float(np.max(np.abs(u[contact]))), 1e-300)
    gap = float(np.max(np.abs(g[contact]))) / scale
    penetration = max(0.0, float(-np.min(g[~contact]))) / scale if (~contact).any() else 0.0
    load_error = 0.0 if load is None else abs(float(np.sum(p)) * cell_area - load) / load
    return gap, penetration, load_error
