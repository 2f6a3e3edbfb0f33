r"""Friction discs: min ½ tᵀAt − bᵀt subject to |t_i| ≤ g_i, the programme of one load step of
Coulomb partial slip (``hpcontact.problems.slip.partial_slip``).

Solver choice: a semismooth Newton method on the projection form t = P(t − c(At − b)) of these
conditions — a primal–dual active-set method with linearized slip directions (Hintermüller, Ito
& Kunisch 2002; Stadler 2004; Hüeber, Stadler & Wohlmuth 2008), i.e. Kalker's Newton iteration
on the stick/slip partition (Kalker 1990, §5) — whose linear systems are symmetric positive
definite restrictions of the half-space compliance and are solved by the engine's kind of
preconditioned CG; globalized by energy descent, with MPRGP (Dostál & Schöberl 2005; Kučera
2008 for separable spherical constraints) as the monotone, provably convergent fallback
(``disc_qp``, ``mprgp_disc``). Why: (i) the discs leave the slip direction free, so the
transverse slip that nu ≠ 0 drives under x-loading (assumed away by Cattaneo and Mindlin,
Johnson 1985 §7.2) is resolved; (ii) the active set settles in a few Newton steps
(superlinear, ~10 steps to 1e-13 from a cold start, 2–4 warm), each one PCG solve on the same
FFT operator — no dense matrices, no inner ADMM/augmented-Lagrangian loops; (iii) plain
projected-gradient methods, MPRGP included, turn the slip tractions only through steps of
length 1/‖A‖, and ‖A‖ is set by the smoothest mode of the half-space compliance (~150× the cell
self-compliance at 64 cells across the contact): they need ~5–10× the operator applications
per load step of the Newton method, which also reaches 1e-13 (docs/performance.md §"Friction
discs");
(iv) Kalker's plain active-set iteration can cycle (it did here from a cold start, without the
energy test); the descent test and the MPRGP fallback make the iteration globally convergent
for this convex programme. ``‖A‖`` is bounded by the largest eigenvalue of the 2 × 2 kernel
symbol over the padded FFT grid (the grid operator is a principal block of that circulant).

Device: the solvers run on the arrays they are given, of any array-API namespace (numpy on the
CPU, CuPy on a GPU: ``hpcontact.numerics.backend``), and call only the standard's functions and
``backend.dot``/``backend.norm`` (numpy's ``vdot`` and ``norm`` on the CPU, so its results are
bitwise what they were): no copy to or from the host inside an iteration but the scalars the
iteration decides by (inner products, norms, the feasible step, whether a set is empty), read by
``float``/``bool``. Units: those of ``apply`` and ``b`` (tractions and displacements, any unit).

References
----------
- M. Hintermüller, K. Ito and K. Kunisch, SIAM J. Optim. 13 (2002) 865–888.
- G. Stadler, SIAM J. Optim. 15 (2004) 39–62 (semismooth Newton, given-friction problems).
- S. Hüeber, G. Stadler and B. I. Wohlmuth, SIAM J. Sci. Comput. 30 (2008) 572–596.
- R. S. Dembo, S. C. Eisenstat and T. Steihaug, SIAM J. Numer. Anal. 19 (1982) 400–408.
- Z. Dostál and J. Schöberl, Comput. Optim. Appl. 30 (2005) 23–43 (MPRGP).
- R. Kučera, SIAM J. Optim. 19 (2008) 846–862 (separable convex constraints).
- Z. Dostál and T. Kozubek, Math. Program. 135 (2012) 195–220.
- J. J. Kalker, *Three-dimensional Elastic Bodies in Rolling Contact*, Kluwer, 1990.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from hpcontact.errors import ConvergenceError
from hpcontact.numerics.backend import Array, copy, dot, namespace, norm

Operator = Callable[[Array], Array]


def _project(t: Array, bound: Array) -> Array:
    """Nearest point of the product of discs |t_i| ≤ bound_i (radial shrink; 0 where bound = 0)."""
    xp = namespace(t)
    mag = xp.hypot(t[0, ...], t[1, ...])
    scale = xp.where(mag > bound, bound / xp.where(mag > 0.0, mag, 1.0), 1.0)
    return t * scale


def _feasible_step(t: Array, p: Array, bound: Array, free: Array) -> float:
    """Largest α ≥ 0 with |t_i − α p_i| ≤ bound_i on the free cells (positive root of a quadratic;
    the smallest over the cells that move, each cell's root computed on the whole grid and the
    others set to ∞: no data-dependent shapes on a device)."""
    xp = namespace(t)
    pp = p[0, ...] * p[0, ...] + p[1, ...] * p[1, ...]
    moving = free & (pp > 0.0)
    if not bool(xp.any(moving)):
        return math.inf
    tp = t[0, ...] * p[0, ...] + t[1, ...] * p[1, ...]
    room = xp.maximum(bound**2 - (t[0, ...] ** 2 + t[1, ...] ** 2), 0.0)
    q = xp.where(moving, pp, 1.0)
    alpha = (tp + xp.sqrt(tp * tp + q * room)) / q
    return float(xp.min(xp.where(moving, alpha, math.inf)))


@dataclass
class QPResult:
    """Traction (2, nx, ny), iterations (operator applications), final relative projected gradient."""

    traction: Array
    iterations: int
    residual: float
    steps: dict = field(default_factory=dict)


def _disc_rhs(b: Array, bound: Array) -> tuple[Array, Array, float]:
    """Cells with a friction disc (bound > 0), the right-hand side restricted to them, its norm."""
    mask = bound > 0.0
    b = namespace(b).where(mask, b, 0.0)
    b_norm = norm(b)
    if not math.isfinite(b_norm):
        raise ValueError("right-hand side of the slip problem is not finite")
    return mask, b, b_norm


def mprgp_disc(
    apply: Operator,
    b: Array,
    bound: Array,
    t0: Array | None,
    tol: float,
    norm_A: float,
    maxiter: int | None = None,
    precondition: Operator | None = None,
    gamma: float = 1.0,
    strict: bool = True,
) -> QPResult:
    r"""min ½ tᵀAt − bᵀt subject to |t_i| ≤ bound_i (t_i ∈ R², one disc per cell): MPRGP.

    Modified proportioning with reduced gradient projections (Dostál & Schöberl 2005) for
    separable spherical constraints (Kučera 2008; Dostál & Kozubek 2012). With g = At − b,
    a cell is *active* when |t_i| = bound_i (outward normal n_i = t_i/|t_i|), else *free*;

        free gradient      φ_i = g_i (free), 0 (active),
        chopped gradient   β_i = g_i − min(0, g_i·n_i) n_i (active), 0 (free),

    and the KKT conditions are φ + β = 0 (g_i = −λ_i n_i, λ_i ≥ 0, on the active cells). While
    ‖β‖ ≤ Γ‖φ‖ the iteration takes (preconditioned-in-face) CG steps on the free cells; a CG step
    that would leave a disc is cut at the disc (feasible step) and followed by an expansion step
    P(t − ᾱφ) with ᾱ = 1/‖A‖; otherwise a proportioning step P(t − αβ) with α the exact line
    minimizer along β, replaced by the always-descending projected-gradient step P(t − ᾱ g)
    when the projection spoils it. Every step decreases the energy. ``apply`` maps (2, nx, ny)
    tractions to displacements; cells with bound = 0 carry no traction. Converged when
    ‖φ + β‖ ≤ tol ‖b‖ (both on the cells with bound > 0). ``norm_A`` bounds ‖A‖ from above.
    With ``strict`` False, running out of ``maxiter`` returns the (improved) iterate instead of
    raising: ``disc_qp`` uses a few MPRGP steps as its globally convergent fallback.

    Globally convergent, but slow on this operator: the rotation of tractions on the slip limit
    moves only through proportioning steps, and ᾱ = 1/‖A‖ is set by the smoothest mode of the
    half-space compliance (‖A‖ ≈ 150× the cell self-compliance at 64 cells across the contact),
    so they creep (~5–10× the operator applications of ``disc_qp``: docs/performance.md
    §"Friction discs").
    """
    xp = namespace(b)
    mask, b, b_norm = _disc_rhs(b, bound)
    zero = xp.zeros_like(b)
    if b_norm == 0.0 or not bool(xp.any(mask)):
        return QPResult(zero, 0, 0.0)
    maxiter = maxiter if maxiter is not None else max(2000, 40 * int(math.sqrt(int(xp.count_nonzero(mask)))))
    abar = 1.0 / norm_A
    t = _project(xp.where(mask, t0, 0.0) if t0 is not None else copy(zero), bound)
    applications = 0

    def gradient(x: Array) -> Array:
        nonlocal applications
        applications += 1
        return xp.where(mask, apply(x) - b, 0.0)

    def parts(x: Array, g: Array) -> tuple[Array, Array, Array]:
        mag = xp.hypot(x[0, ...], x[1, ...])
        active = mask & (mag >= bound * (1.0 - 1e-12))
        free = mask & ~active
        phi = xp.where(free, g, 0.0)
        n = xp.where(active, x / xp.where(mag > 0.0, mag, 1.0), 0.0)
        gn = g[0, ...] * n[0, ...] + g[1, ...] * n[1, ...]
        beta = xp.where(active, g - xp.minimum(gn, 0.0) * n, 0.0)
        return phi, beta, free

    def energy(x: Array, g: Array) -> float:
        return 0.5 * dot(x, g) - 0.5 * dot(b, x)

    def direction(phi: Array, free: Array) -> Array:
        if precondition is None:
            return phi
        return xp.where(free, precondition(phi), 0.0)

    g = gradient(t)
    phi, beta, free = parts(t, g)
    z = direction(phi, free)
    p = copy(z)
    counts = {"cg": 0, "expansion": 0, "proportioning": 0, "fallback": 0}
    residual = math.inf
    for _ in range(maxiter):
        residual = norm(phi + beta) / b_norm
        if not math.isfinite(residual):
            raise ConvergenceError("non-finite residual in the partial-slip solver", applications, residual)
        if residual <= tol:
            return QPResult(t, applications, residual, counts)
        if dot(beta, beta) <= gamma * gamma * dot(phi, phi):
            Ap = xp.where(mask, apply(p), 0.0)
            applications += 1
            pAp = dot(p, Ap)
            if not pAp > 0.0:
                raise ConvergenceError("operator is not positive definite on the stick cells", applications, residual)
            a_cg = dot(z, phi) / pAp
            a_f = _feasible_step(t, p, bound, free)
            if a_cg <= a_f:
                counts["cg"] += 1
                t = t - a_cg * p
                g = g - a_cg * Ap
                free_before = free
                phi, beta, free = parts(t, g)
                z = direction(phi, free)
                if bool(xp.all(free == free_before)):
                    p = z - (dot(z, Ap) / pAp) * p
                else:
                    p = copy(z)
            else:
                counts["expansion"] += 1
                t = t - a_f * p
                g = g - a_f * Ap
                phi_half, _, _ = parts(t, g)
                t = _project(t - abar * phi_half, bound)
                g = gradient(t)
                phi, beta, free = parts(t, g)
                z = direction(phi, free)
                p = copy(z)
        else:
            counts["proportioning"] += 1
            Ab = xp.where(mask, apply(beta), 0.0)
            applications += 1
            f_old = energy(t, g)
            a = dot(g, beta) / dot(beta, Ab)
            trial = _project(t - a * beta, bound)
            g_trial = gradient(trial)
            if not energy(trial, g_trial) < f_old:
                counts["fallback"] += 1
                trial = _project(t - abar * g, bound)
                g_trial = gradient(trial)
            t, g = trial, g_trial
            phi, beta, free = parts(t, g)
            z = direction(phi, free)
            p = copy(z)
    if not strict:
        return QPResult(t, applications, residual, counts)
    raise ConvergenceError(f"partial-slip solver did not reach tol={tol:g}", applications, residual)


def kkt_residual(t: Array, g: Array, bound: Array) -> float:
    """‖φ + β‖ of ``mprgp_disc`` at the feasible t with gradient g: zero exactly at the solution."""
    xp = namespace(t)
    mask = bound > 0.0
    mag = xp.hypot(t[0, ...], t[1, ...])
    active = mask & (mag >= bound * (1.0 - 1e-12))
    n = xp.where(active, t / xp.where(mag > 0.0, mag, 1.0), 0.0)
    gn = g[0, ...] * n[0, ...] + g[1, ...] * n[1, ...]
    projected = xp.where(active, g - xp.minimum(gn, 0.0) * n, xp.where(mask, g, 0.0))
    return norm(projected)


def disc_qp(
    apply: Operator,
    b: Array,
    bound: Array,
    t0: Array | None,
    tol: float,
    c: float,
    norm_A: float,
    precondition: Operator | None = None,
    maxnewton: int = 100,
) -> QPResult:
    r"""min ½ tᵀAt − bᵀt subject to |t_i| ≤ bound_i: semismooth Newton with PCG inner solves.

    The optimality conditions are the fixed point t = P(t − c(At − b)) (P: projection onto the
    discs, any c > 0; here c = 1/A_ii, the inverse cell self-compliance). Newton's method on
    F(t) = t − P(y), y = t − c(At − b), with the generalized derivative of P (identity where
    |y_i| ≤ bound_i: the *stick* prediction; ρ_i(I − ŷ_iŷ_iᵀ), ρ_i = bound_i/|y_i|, where it
    exceeds it: *slip*) is a primal–dual active-set step with linearized slip directions
    (Hintermüller, Ito & Kunisch 2002; Stadler 2004; Hüeber, Stadler & Wohlmuth 2008 — the
    Tresca/given-pressure form of Kalker's Newton–Raphson in CONTACT, Kalker 1990 §5). Written
    in the stick components and the slip cells' tangential components (along τ̂_i ⊥ ŷ_i), with
    the normal components fixed at the limit, the Newton system is

        (A Δ)_i = −(At − b)_i                                (stick cells),
        τ̂ᵢᵀ(A Δ)_i + w_i Δ_τ,i = −(t_i·τ̂_i)/(ρ_i c),   w_i = (1 − ρ_i)/(ρ_i c) ≥ 0   (slip),

    i.e. (QᵀAQ + W) x = r: symmetric positive definite, so it is solved by preconditioned CG
    (the half-space Fourier preconditioner on the stick cells, Jacobi 1/(A_ii + w_i) on the slip
    cells) to the inexact-Newton forcing tolerance min(0.1, residual) (Dembo, Eisenstat &
    Steihaug 1982). Globalization: the new iterate is projected onto the discs and accepted
    when the energy falls (step halving up to 1/32); otherwise 50 MPRGP steps
    (``mprgp_disc``, monotone and globally convergent) are taken and Newton resumes. Converged
    when the projected gradient ‖φ + β‖ ≤ tol ‖b‖ at a feasible iterate (``kkt_residual``).
    Returns the traction, the operator applications and the final relative residual.
    """
    xp = namespace(b)
    mask, b, b_norm = _disc_rhs(b, bound)
    zero = xp.zeros_like(b)
    if b_norm == 0.0 or not bool(xp.any(mask)):
        return QPResult(zero, 0, 0.0)
    applications = 0

    def A(x: Array) -> Array:
        nonlocal applications
        applications += 1
        return xp.where(mask, apply(x), 0.0)

    def energy(x: Array, g: Array) -> float:
        return 0.5 * dot(x, g - b)

    t = _project(xp.where(mask, t0, 0.0) if t0 is not None else copy(zero), bound)
    r = A(t) - b
    f = energy(t, r)
    counts = {"newton": 0, "cg": 0, "halvings": 0, "fallback": 0}
    residual = kkt_residual(t, r, bound) / b_norm
    for _ in range(maxnewton):
        if not math.isfinite(residual):
            raise ConvergenceError("non-finite residual in the partial-slip solver", applications, residual)
        if residual <= tol:
            return QPResult(t, applications, residual, counts)
        counts["newton"] += 1
        y = t - c * r
        ymag = xp.hypot(y[0, ...], y[1, ...])
        slip = mask & (ymag > bound)
        stick = mask & ~slip
        safe = xp.where(slip, ymag, 1.0)
        yh = xp.where(slip, y / safe, 0.0)
        tau = xp.stack([-yh[1, ...], yh[0, ...]])
        rho = xp.where(slip, bound / safe, 1.0)
        w = xp.where(slip, (1.0 - rho) / (rho * c), 0.0)
        t_n = t[0, ...] * yh[0, ...] + t[1, ...] * yh[1, ...]
        t_t = t[0, ...] * tau[0, ...] + t[1, ...] * tau[1, ...]
        known = xp.where(slip, (bound - t_n) * yh, 0.0)  # normal components go to the limit

        def restrict(v: Array) -> Array:
            along = v[0, ...] * tau[0, ...] + v[1, ...] * tau[1, ...]
            return xp.where(stick, v, xp.where(slip, along * tau, 0.0))

        def system(v: Array) -> Array:
            return restrict(A(v)) + w * v

        jacobi = 1.0 / (1.0 / c + w)

        def precond(v: Array) -> Array:
            if precondition is None:
                return xp.where(stick, v, 0.0) + xp.where(slip, jacobi * v, 0.0)
            return xp.where(stick, precondition(xp.where(stick, v, 0.0)), 0.0) + xp.where(slip, jacobi * v, 0.0)

        rhs = xp.where(stick, -r, 0.0) + xp.where(slip, (-t_t / (rho * c)) * tau, 0.0)
        if bool(xp.any(slip)):
            rhs = rhs - restrict(A(known))
        x = copy(zero)
        res_cg = copy(rhs)
        rhs_norm = norm(rhs)
        forcing = max(min(0.1, residual), 0.01 * tol)
        z = precond(res_cg)
        p = copy(z)
        rz = dot(res_cg, z)
        for _ in range(2000):
            if norm(res_cg) <= forcing * rhs_norm:
                break
            Mp = system(p)
            curvature = dot(p, Mp)
            if not curvature > 0.0:
                break
            alpha = rz / curvature
            x += alpha * p
            res_cg -= alpha * Mp
            counts["cg"] += 1
            z = precond(res_cg)
            rz_new = dot(res_cg, z)
            p = z + (rz_new / rz) * p
            rz = rz_new
        step = x + known
        accepted = False
        lam = 1.0
        for _ in range(6):
            trial = _project(t + lam * step, bound)
            r_trial = A(trial) - b
            f_trial = energy(trial, r_trial)
            res_trial = kkt_residual(trial, r_trial, bound) / b_norm
            # energy decrease; near the solution, where f changes below rounding, a smaller
            # projected gradient at an energy equal to rounding decides
            if f_trial < f or (f_trial <= f + 1e-13 * abs(f) and res_trial < residual):
                accepted = True
                break
            lam *= 0.5
            counts["halvings"] += 1
        if not accepted:
            counts["fallback"] += 1
            sub = mprgp_disc(apply, b, bound, t, tol, norm_A, maxiter=50, strict=False)
            applications += sub.iterations
            trial = sub.traction
            r_trial = A(trial) - b
            f_trial = energy(trial, r_trial)
            res_trial = kkt_residual(trial, r_trial, bound) / b_norm
        t, r, f, residual = trial, r_trial, f_trial, res_trial
    raise ConvergenceError(f"partial-slip solver did not reach tol={tol:g}", applications, residual)
