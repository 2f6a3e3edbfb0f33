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

``conjugate_gradient_batch`` runs CG on a stack of independent systems that share a grid shape
(the leading axis: the scene), one operator application for all of them per iteration (a batched
FFT on a GPU): per-scene step lengths and stopping, one small vector copied to the host per
iteration.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from hpcontact.errors import ConvergenceError
from hpcontact.numerics.backend import Array, add_scaled, copy, dot, is_numpy, namespace, norm, to_device, to_host

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
    step = np.empty_like(b) if is_numpy(xp) else None  # scratch for the x and r updates (add_scaled)

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
        add_scaled(x, alpha, p, step)
        add_scaled(r, -alpha, q, step)
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


@dataclass
class BatchSolution:
    """The solutions of a batch of B scenes: tractions (B, c, nx, ny) in the namespace of the
    solve's arrays, and per scene the iterations used and the final relative residual ‖r‖/‖b‖."""

    traction: Array
    iterations: list[int]
    residuals: list[float]

    def scene(self, index: int) -> Solution:
        """Scene ``index``'s solution, as ``conjugate_gradient`` returns one."""
        return Solution(self.traction[index, ...], self.iterations[index], self.residuals[index])


def conjugate_gradient_batch(
    apply: Operator,
    rhs: Array,
    mask: Array,
    tol: float | Sequence[float] = 1e-10,
    maxiter: int | Sequence[int] | None = None,
    precondition: Operator | None = None,
) -> BatchSolution:
    """``conjugate_gradient`` on B independent systems P_k A_k P_k t_k = P_k b_k at once (k the
    leading axis of every array: the scene).

    ``rhs`` is (B, c, nx, ny), ``mask`` (B, nx, ny) or (B, c, nx, ny); ``apply`` and
    ``precondition`` map a stack (B, c, nx, ny) to a stack, scene k by A_k and M_k⁻¹ (e.g. one
    batched FFT over the last two axes with per-scene spectra). Each scene runs Hestenes & Stiefel's
    recurrence with its own step lengths α_k = r_kᵀz_k / p_kᵀA_k p_k and β_k = r_kᵀz_k (new) / r_kᵀz_k,
    and stops by the single-scene rule, ‖r_k‖₂ ≤ tol_k ‖b_k‖₂ (``tol`` one value or one per
    scene; ``maxiter`` likewise, by default the single-scene default of each scene's mask). A scene
    that has converged stops changing (its α and β are frozen at 0 and 1 and its direction kept)
    while the others iterate; its iterations and residual are those of the iteration it converged
    at. The per-scene scalars are computed on the arrays' device; the one copy to the host per
    iteration is the vector (pᵀAp, ‖r‖/‖b‖) of the B scenes, by which the loop decides. A scene whose
    curvature pᵀAp ≤ 0, whose residual is not finite or that reaches its ``maxiter`` raises
    ``ConvergenceError`` naming it (the batch fails as a whole).
    """
    if rhs.ndim != 4:
        raise ValueError("rhs must have shape (scenes, components, nx, ny)")
    xp = namespace(rhs)
    scenes = rhs.shape[0]
    weight = xp.astype(mask, xp.float64)
    if weight.ndim == 3:
        weight = xp.expand_dims(weight, axis=1)
    b = rhs * weight
    b_norm = _scene_norms(b)
    b_norm_host = to_host(b_norm)
    if not bool(np.all(np.isfinite(b_norm_host))):
        raise ValueError(f"prescribed displacement is not finite in scenes {np.flatnonzero(~np.isfinite(b_norm_host))}")
    if maxiter is None:  # the single-scene default of each scene's mask
        cells = to_host(xp.sum(weight, axis=(1, 2, 3))) / weight.shape[1]
        limits = [max(200, 10 * int(math.sqrt(float(m))) + 50) for m in cells]
    else:
        limits = _per_scene(maxiter, scenes, "maxiter")
    tolerances = _per_scene(tol, scenes, "tol")
    tol_device = to_device(np.asarray(tolerances, dtype=np.float64), xp)
    iterations = [0] * scenes
    residuals = [0.0] * scenes
    active_host = b_norm_host > 0.0  # a scene with b = 0 has t = 0: converged before the first iteration
    active = to_device(active_host, xp)
    scale = to_device(np.where(active_host, 1.0 / np.where(active_host, b_norm_host, 1.0), 0.0), xp)
    x = xp.zeros_like(b)
    r = copy(b)

    def preconditioned(residual_: Array) -> Array:
        return precondition(residual_) * weight if precondition else residual_

    def per_scene(values: Array) -> Array:  # (B,) → (B, 1, 1, 1), to scale each scene's field
        return xp.reshape(values, (scenes, 1, 1, 1))

    z = preconditioned(r)
    p = copy(z)
    rz = _scene_dots(r, z)
    for iteration in range(1, max(limits, default=0) + 1):
        if not bool(active_host.any()):
            break
        q = apply(p)
        q *= weight
        curvature = _scene_dots(p, q)
        alpha = xp.where(active, rz / xp.where(active, curvature, 1.0), 0.0)
        x += per_scene(alpha) * p
        r -= per_scene(alpha) * q
        residual = _scene_norms(r) * scale
        still = active & ~(residual <= tol_device)
        z = preconditioned(r)
        rz_new = _scene_dots(r, z)
        beta = xp.where(still, rz_new / xp.where(still, rz, 1.0), 1.0)
        p = xp.where(per_scene(still), p * per_scene(beta) + z, p)
        rz = xp.where(still, rz_new, rz)
        curvature_host, residual_host = to_host(xp.stack([curvature, residual]))  # the iteration's one copy
        for k in np.flatnonzero(active_host):
            if not curvature_host[k] > 0.0:
                raise ConvergenceError(
                    f"scene {k}: operator is not positive definite on the mask", iteration, residuals[k]
                )
            if not math.isfinite(residual_host[k]):
                raise ConvergenceError(
                    f"scene {k}: non-finite residual in conjugate gradients", iteration, residual_host[k]
                )
            iterations[k], residuals[k] = iteration, float(residual_host[k])
            if residual_host[k] <= tolerances[k]:
                active_host[k] = False
            elif iteration >= limits[k]:
                raise ConvergenceError(
                    f"scene {k}: conjugate gradients did not reach tol={tolerances[k]:g}", iteration, residuals[k]
                )
        active = still
    return BatchSolution(x, iterations, residuals)


def _scene_dots(a: Array, b: Array) -> Array:
    """Σ a·b over each scene of two stacks (B, ...) of one shape: a (B,) array on their device."""
    xp = namespace(a)
    return xp.vecdot(xp.reshape(a, (a.shape[0], -1)), xp.reshape(b, (b.shape[0], -1)))


def _scene_norms(a: Array) -> Array:
    """‖a_k‖₂ of each scene of a stack (B, ...): a (B,) array on its device."""
    xp = namespace(a)
    return xp.linalg.vector_norm(xp.reshape(a, (a.shape[0], -1)), axis=1)


def _per_scene(value: float | int | Sequence | None, scenes: int, name: str) -> list:
    """``value`` repeated for each of ``scenes`` scenes, or the sequence itself when it has one per scene."""
    if value is None or np.ndim(value) == 0:
        return [value] * scenes
    values = list(value)
    if len(values) != scenes:
        raise ValueError(f"{name} has {len(values)} values for {scenes} scenes")
    return values
