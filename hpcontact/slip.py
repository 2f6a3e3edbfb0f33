r"""Coulomb partial slip (Cattaneo–Mindlin) of two bodies on the non-periodic FFT operator.

``solve_slip(params)`` is the task behind ``hpcontact solve --quantities slip``: two bodies
(``hpcontact.bodies``) are pressed together by a normal load P, then loaded tangentially in
steps up to Q = q_ratio·mu·P along a direction in the contact plane (force control), or through
a full Mindlin–Deresiewicz loop (+Q*, −Q*, +Q*); the record gives the force, the displacement,
the incremental tangential stiffness (scalar along the load and the 2 × 2 tensor), the stick and
contact areas.

Problem (Johnson 1985, §7.2; Kalker 1990, §2). On the contact grid with cell tractions t (on
body 1; −t on body 2), pressure p and the combined compliance of ``bodies.Pair``, the relative
tangential surface displacement is u = A_tt t + A_tz p and the accumulated slip of a cell is
s = δ − u (δ: rigid tangential displacement of body 2's remote points relative to body 1's,
signed so that Q = K δ with K > 0). Coulomb's law: |t| ≤ mu p; where a cell slips, its traction
is mu p along the slip increment Δs = s − s_prev (friction on body 1 opposes body 1's slip
relative to body 2). In one load step from a converged state (s_prev), with p fixed, these are
exactly the optimality conditions of the convex quadratic programme

    min_t  ½ tᵀ A_tt t − tᵀ b,   b = δ − s_prev − A_tz p,   subject to |t_i| ≤ g_i = mu p_i,

since Δs = b − A_tt t must lie in the normal cone of the disc |t_i| ≤ g_i (Δs_i = λ_i t_i,
λ_i ≥ 0, λ_i = 0 inside): the maximum-dissipation form of Coulomb's law (Kalker 1990, §2.6;
Duvaut & Lions 1976 for the "Tresca" problem with given bound). History enters only through
s_prev, so loading, unloading and reloading follow one algorithm and trace the
Mindlin–Deresiewicz loop (Mindlin & Deresiewicz 1953).

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
self-compliance at 64 cells across the contact): measured ~1500 operator applications per
load step for tol 1e-8 against ~150–300 for the Newton method, which also reaches 1e-13;
(iv) Kalker's plain active-set iteration can cycle (it did here from a cold start, without the
energy test); the descent test and the MPRGP fallback make the iteration globally convergent
for this convex programme. ``‖A‖`` is bounded by the largest eigenvalue of the 2 × 2 kernel
symbol over the padded FFT grid (the grid operator is a principal block of that circulant).

Normal contact: Polonsky–Keer under load control on the same grid (``solvers.polonsky_keer``);
the normal pressure for the Mindlin checks is therefore the *discrete* Hertz solution of the
grid, not the analytic one. The normal load is applied first without friction (the
reference state s = −A_tz p0, t = 0; friction during normal loading — Spence's problem for
dissimilar pairs, Johnson 1985 §5.5 — is not modelled).

Coupling (dissimilar pairs, β ≠ 0). Goodman's approximation (1962) keeps p = p0 (decoupled: only
the xx, xy, yy blocks). The coupled solution iterates Panagiotopoulos' process (Kalker 1990,
§5.2): tangential programme with the current p, then the normal problem with the gap changed
by A_zt t at the same load, until p and t stop changing. Both are run for a dissimilar pair and
the record states the difference (measured, P = 100 N, mu = 0.3, grid-converged to the digits
shown: Cu–Fe, β = 0.032: δ −2.3e-4 at Q = 0.5 mu P and −2.8e-4 at 0.9, k_t within ±2e-3
(the stick area's staircase); Fe on a rigid flat, β = 0.29: δ −1.9 % and −2.4 %, k_t +2.5 %
and +3.1 %).

Incremental stiffness. The record's k_t = dQ/dδ and its 2 × 2 tensor are the *consistent*
tangent of continued loading, Coulomb's law to first order in rate form: stick cells move
rigidly with dδ; a slip cell keeps |t| = mu p and slides only along its traction, so its traction
may turn on the friction circle (dt ⊥ t) while its displacement across t follows dδ
(``SlipProblem.tangent_tensor``; two PCG solves of an SPD restriction of the compliance). It is
checked against the solver's own response to a small displacement increment (agreement ~1e-5
along the load, 1e-3 across it) and against the *frozen-slip-zone* stiffness — the no-slip
stiffness of the current stick area, K_bonded(stick), which is what Mindlin & Deresiewicz (1953)
and Johnson (1985, §7.2: dQ/dδ = 8G c/(2 − nu)) use, reported as ``stick_area_stiffness``. The
two agree exactly at nu = 0 along the load; at nu ≠ 0 x-loading drives a small transverse slip
in the slip annulus that the consistent tangent restrains (measured +0.4 % at nu = 0.29,
+0.9 % at nu = 0.5 near Q = 0.9 mu P, n = 128). Across the load they differ a lot (a pure
transverse increment turns the slip tractions without slipping: k_yy/k_xx = 2.1 at
Q = 0.9 mu P on a circle), which is why the tensor is the tangent of *continued* loading,
valid for increments that keep every slip cell slipping. The scalar k_t along the load
direction n is 1/(nᵀ K⁻¹ n) (force control: displacement along n per unit force along n).

Force control is solved by Newton's method on δ with the consistent tensor as Jacobian (exact
while no cell changes state; monotone from below on the concave loading curve).

Units: lengths are scaled by the Hertz semi-axis a and stresses by G_eq inside; the record is in
the units of the input (SI for library materials: N, m, N/m, m²).

References
----------
- K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985 (§4.2, §5.4–5.5, §7.2, §7.4).
- R. D. Mindlin and H. Deresiewicz, J. Appl. Mech. 20 (1953) 327–344.
- J. J. Kalker, *Three-dimensional Elastic Bodies in Rolling Contact*, Kluwer, 1990.
- I. A. Polonsky and L. M. Keer, Wear 231 (1999) 206–219.
- M. Hintermüller, K. Ito and K. Kunisch, SIAM J. Optim. 13 (2002) 865–888.
- G. Stadler, SIAM J. Optim. 15 (2004) 39–62 (semismooth Newton, given-friction problems).
- S. Hüeber, G. Stadler and B. I. Wohlmuth, SIAM J. Sci. Comput. 30 (2008) 572–596.
- R. S. Dembo, S. C. Eisenstat and T. Steihaug, SIAM J. Numer. Anal. 19 (1982) 400–408.
- Z. Dostál and J. Schöberl, Comput. Optim. Appl. 30 (2005) 23–43 (MPRGP).
- R. Kučera, SIAM J. Optim. 19 (2008) 846–862 (separable convex constraints).
- Z. Dostál and T. Kozubek, Math. Program. 135 (2012) 195–220.
- L. M. Goodman, J. Appl. Mech. 29 (1962) 515–522.
- The seed paper: tangential contact stiffness of sphere pairs (Cu, Fe, Al; radii 8 and 9 mm)
  with friction, validated by experiment (shared/seeds/001).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping

import numpy as np

from . import analytic
from .bodies import HertzEllipse, Pair, pair_from_params
from .errors import ConvergenceError, InputError, finite_number, integer
from .geometry import Grid
from .kernels.isotropic import isotropic_block, isotropic_surface_green
from .materials import Isotropic
from .operator import ConvolutionOperator, cached_spectrum
from .preconditioner import FourierPreconditioner
from .solve import Engine
from .solvers import Solution, polonsky_keer

Operator = Callable[[np.ndarray], np.ndarray]

FIELDS = (
    "quantities", "radius", "radius_b", "radius2", "radius2_b", "body2_angle",
    "material", "material2", "E", "G", "nu", "E2", "G2", "nu2",
    "load", "mu", "q_ratio", "angle", "n", "tol", "steps", "control", "displacement", "path",
    "tensor", "history", "coupling", "threads", "precondition",
)
#: Fields of the generic ``hpcontact solve`` parser that a slip scene does not use: the contact
#: shape follows from the bodies. Accepted (so the CLI may pass its defaults) and ignored.
IGNORED = ("shape",)
CONTROLS = ("force", "displacement")
PATHS = ("load", "loop")
COUPLINGS = ("auto", "both", "coupled", "decoupled")
GRID_MARGIN = 1.1  # the grid spans ±1.1 Hertz semi-axes: contact growth under coupling fits
MIN_CELLS_ACROSS = 16


# ------------------------------------------------------------------------------------------
# the quadratic programme with disc constraints (semismooth Newton, MPRGP fallback)
# ------------------------------------------------------------------------------------------
def _project(t: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """Nearest point of the product of discs |t_i| ≤ bound_i (radial shrink; 0 where bound = 0)."""
    mag = np.hypot(t[0], t[1])
    scale = np.where(mag > bound, bound / np.where(mag > 0.0, mag, 1.0), 1.0)
    return t * scale


def _feasible_step(t: np.ndarray, p: np.ndarray, bound: np.ndarray, free: np.ndarray) -> float:
    """Largest α ≥ 0 with |t_i − α p_i| ≤ bound_i on the free cells (positive root of a quadratic)."""
    pp = p[0] * p[0] + p[1] * p[1]
    moving = free & (pp > 0.0)
    if not moving.any():
        return math.inf
    tp = (t[0] * p[0] + t[1] * p[1])[moving]
    room = np.maximum(bound[moving] ** 2 - (t[0] ** 2 + t[1] ** 2)[moving], 0.0)
    q = pp[moving]
    alpha = (tp + np.sqrt(tp * tp + q * room)) / q
    return float(alpha.min())


@dataclass
class QPResult:
    """Traction (2, nx, ny), iterations (operator applications), final relative projected gradient."""

    traction: np.ndarray
    iterations: int
    residual: float
    steps: dict = field(default_factory=dict)


def _disc_rhs(b: np.ndarray, bound: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Cells with a friction disc (bound > 0), the right-hand side restricted to them, its norm."""
    mask = bound > 0.0
    b = np.where(mask, b, 0.0)
    b_norm = float(np.linalg.norm(b))
    if not math.isfinite(b_norm):
        raise ValueError("right-hand side of the slip problem is not finite")
    return mask, b, b_norm


def mprgp_disc(
    apply: Operator,
    b: np.ndarray,
    bound: np.ndarray,
    t0: np.ndarray | None,
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
    so they creep (measured: ~1500 operator applications for tol 1e-8 at n = 64, against ~200
    for ``disc_qp``).
    """
    mask, b, b_norm = _disc_rhs(b, bound)
    zero = np.zeros_like(b)
    if b_norm == 0.0 or not mask.any():
        return QPResult(zero, 0, 0.0)
    maxiter = maxiter if maxiter is not None else max(2000, 40 * int(math.sqrt(mask.sum())))
    abar = 1.0 / norm_A
    t = _project(np.where(mask, t0, 0.0) if t0 is not None else zero.copy(), bound)
    applications = 0

    def gradient(x: np.ndarray) -> np.ndarray:
        nonlocal applications
        applications += 1
        return np.where(mask, apply(x) - b, 0.0)

    def parts(x: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        mag = np.hypot(x[0], x[1])
        active = mask & (mag >= bound * (1.0 - 1e-12))
        free = mask & ~active
        phi = np.where(free, g, 0.0)
        n = np.where(active, x / np.where(mag > 0.0, mag, 1.0), 0.0)
        gn = g[0] * n[0] + g[1] * n[1]
        beta = np.where(active, g - np.minimum(gn, 0.0) * n, 0.0)
        return phi, beta, free

    def energy(x: np.ndarray, g: np.ndarray) -> float:
        return 0.5 * float(np.vdot(x, g)) - 0.5 * float(np.vdot(b, x))

    def direction(phi: np.ndarray, free: np.ndarray) -> np.ndarray:
        if precondition is None:
            return phi
        return np.where(free, precondition(phi), 0.0)

    g = gradient(t)
    phi, beta, free = parts(t, g)
    z = direction(phi, free)
    p = z.copy()
    counts = {"cg": 0, "expansion": 0, "proportioning": 0, "fallback": 0}
    residual = math.inf
    for _ in range(maxiter):
        residual = float(np.linalg.norm(phi + beta)) / b_norm
        if not math.isfinite(residual):
            raise ConvergenceError("non-finite residual in the partial-slip solver", applications, residual)
        if residual <= tol:
            return QPResult(t, applications, residual, counts)
        if float(np.vdot(beta, beta)) <= gamma * gamma * float(np.vdot(phi, phi)):
            Ap = np.where(mask, apply(p), 0.0)
            applications += 1
            pAp = float(np.vdot(p, Ap))
            if not pAp > 0.0:
                raise ConvergenceError("operator is not positive definite on the stick cells", applications, residual)
            a_cg = float(np.vdot(z, phi)) / pAp
            a_f = _feasible_step(t, p, bound, free)
            if a_cg <= a_f:
                counts["cg"] += 1
                t = t - a_cg * p
                g = g - a_cg * Ap
                free_before = free
                phi, beta, free = parts(t, g)
                z = direction(phi, free)
                if np.array_equal(free, free_before):
                    p = z - (float(np.vdot(z, Ap)) / pAp) * p
                else:
                    p = z.copy()
            else:
                counts["expansion"] += 1
                t = t - a_f * p
                g = g - a_f * Ap
                phi_half, _, _ = parts(t, g)
                t = _project(t - abar * phi_half, bound)
                g = gradient(t)
                phi, beta, free = parts(t, g)
                z = direction(phi, free)
                p = z.copy()
        else:
            counts["proportioning"] += 1
            Ab = np.where(mask, apply(beta), 0.0)
            applications += 1
            f_old = energy(t, g)
            a = float(np.vdot(g, beta)) / float(np.vdot(beta, Ab))
            trial = _project(t - a * beta, bound)
            g_trial = gradient(trial)
            if not energy(trial, g_trial) < f_old:
                counts["fallback"] += 1
                trial = _project(t - abar * g, bound)
                g_trial = gradient(trial)
            t, g = trial, g_trial
            phi, beta, free = parts(t, g)
            z = direction(phi, free)
            p = z.copy()
    if not strict:
        return QPResult(t, applications, residual, counts)
    raise ConvergenceError(f"partial-slip solver did not reach tol={tol:g}", applications, residual)


def kkt_residual(t: np.ndarray, g: np.ndarray, bound: np.ndarray) -> float:
    """‖φ + β‖ of ``mprgp_disc`` at the feasible t with gradient g: zero exactly at the solution."""
    mask = bound > 0.0
    mag = np.hypot(t[0], t[1])
    active = mask & (mag >= bound * (1.0 - 1e-12))
    n = np.where(active, t / np.where(mag > 0.0, mag, 1.0), 0.0)
    gn = g[0] * n[0] + g[1] * n[1]
    projected = np.where(active, g - np.minimum(gn, 0.0) * n, np.where(mask, g, 0.0))
    return float(np.linalg.norm(projected))


def disc_qp(
    apply: Operator,
    b: np.ndarray,
    bound: np.ndarray,
    t0: np.ndarray | None,
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
    mask, b, b_norm = _disc_rhs(b, bound)
    zero = np.zeros_like(b)
    if b_norm == 0.0 or not mask.any():
        return QPResult(zero, 0, 0.0)
    applications = 0

    def A(x: np.ndarray) -> np.ndarray:
        nonlocal applications
        applications += 1
        return np.where(mask, apply(x), 0.0)

    def energy(x: np.ndarray, g: np.ndarray) -> float:
        return 0.5 * float(np.vdot(x, g - b))

    t = _project(np.where(mask, t0, 0.0) if t0 is not None else zero.copy(), bound)
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
        ymag = np.hypot(y[0], y[1])
        slip = mask & (ymag > bound)
        stick = mask & ~slip
        safe = np.where(slip, ymag, 1.0)
        yh = np.where(slip, y / safe, 0.0)
        tau = np.stack([-yh[1], yh[0]])
        rho = np.where(slip, bound / safe, 1.0)
        w = np.where(slip, (1.0 - rho) / (rho * c), 0.0)
        t_n = t[0] * yh[0] + t[1] * yh[1]
        t_t = t[0] * tau[0] + t[1] * tau[1]
        known = np.where(slip, (bound - t_n) * yh, 0.0)  # normal components go to the limit

        def restrict(v: np.ndarray) -> np.ndarray:
            along = v[0] * tau[0] + v[1] * tau[1]
            return np.where(stick, v, np.where(slip, along * tau, 0.0))

        def system(v: np.ndarray) -> np.ndarray:
            return restrict(A(v)) + w * v

        jacobi = 1.0 / (1.0 / c + w)

        def precond(v: np.ndarray) -> np.ndarray:
            if precondition is None:
                return np.where(stick, v, 0.0) + np.where(slip, jacobi * v, 0.0)
            return np.where(stick, precondition(np.where(stick, v, 0.0)), 0.0) + np.where(slip, jacobi * v, 0.0)

        rhs = np.where(stick, -r, 0.0) + np.where(slip, (-t_t / (rho * c)) * tau, 0.0)
        if slip.any():
            rhs = rhs - restrict(A(known))
        x = zero.copy()
        res_cg = rhs.copy()
        rhs_norm = float(np.linalg.norm(rhs))
        forcing = max(min(0.1, residual), 0.01 * tol)
        z = precond(res_cg)
        p = z.copy()
        rz = float(np.vdot(res_cg, z))
        for _ in range(2000):
            if float(np.linalg.norm(res_cg)) <= forcing * rhs_norm:
                break
            Mp = system(p)
            curvature = float(np.vdot(p, Mp))
            if not curvature > 0.0:
                break
            alpha = rz / curvature
            x += alpha * p
            res_cg -= alpha * Mp
            counts["cg"] += 1
            z = precond(res_cg)
            rz_new = float(np.vdot(res_cg, z))
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


# ------------------------------------------------------------------------------------------
# the discretized pair
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class SlipScene:
    """Validated fields of one partial-slip scene (see ``validate``)."""

    pair: Pair
    load: float
    mu: float
    q_ratio: float
    angle_deg: float
    n: int
    tol: float
    steps: int
    control: str
    displacement: float | None
    path: str
    tensor: bool
    history: bool
    coupling: str
    threads: int
    precondition: bool


def _flag(name: str, value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, str) and value.strip().lower() in ("true", "false", "1", "0", "yes", "no"):
        return value.strip().lower() in ("true", "1", "yes")
    if isinstance(value, (int, np.integer)) and value in (0, 1):
        return bool(value)
    raise InputError(name, "true or false", value)


def validate(params: Mapping[str, Any]) -> SlipScene:
    """Check the fields of a slip scene; ``InputError(field, allowed, value)`` on the first bad one.

    Required: ``radius`` (> 0), ``load`` (> 0), ``mu`` (≥ 0), ``q_ratio`` (0 ≤ Q/(mu P) < 1).
    Optional: ``radius_b radius2 radius2_b body2_angle`` (geometry, see ``bodies``),
    ``material material2`` (names) or ``E G nu E2 G2 nu2``; ``angle`` (load direction, degrees
    from the scene's x axis, default 0); ``n`` (cells across the contact's major axis, 8–4096,
    default 64); ``tol`` (1e-14–1e-4, default 1e-8); ``steps`` (load steps to Q, 1–1000,
    default 10); ``control`` (force | displacement); ``displacement`` (final tangential
    displacement, required with control = displacement); ``path`` (load | loop);
    ``tensor`` and ``history`` (booleans: add the 2 × 2 tensor / the whole curve);
    ``coupling`` (auto | both | coupled | decoupled; auto = both for a dissimilar pair);
    ``threads``; ``precondition``.
    """
    unknown = sorted(set(params) - set(FIELDS) - set(IGNORED))
    if unknown:
        raise InputError(unknown[0], f"a field of a slip scene ({', '.join(FIELDS)})", params[unknown[0]])
    p = {k: v for k, v in params.items() if v is not None}
    if "quantities" in p:
        q = p["quantities"]
        items = [s.strip() for s in (q.split(",") if isinstance(q, str) else q)]
        if items != ["slip"]:
            raise InputError("quantities", "slip (a slip scene solves nothing else)", q)
    for name in ("radius", "load", "mu", "q_ratio"):
        if name not in p:
            raise InputError(name, "required for a slip scene", None)
    load = finite_number("load", p["load"], "a normal load, finite and > 0")
    if not load > 0.0:
        raise InputError("load", "a normal load, finite and > 0", p["load"])
    mu = finite_number("mu", p["mu"], "a friction coefficient, finite and >= 0")
    if mu < 0.0:
        raise InputError("mu", "a friction coefficient, finite and >= 0", p["mu"])
    q_ratio = finite_number("q_ratio", p["q_ratio"], "Q/(mu P) in [0, 1) (1 is gross sliding)")
    if not 0.0 <= q_ratio < 1.0:
        raise InputError("q_ratio", "Q/(mu P) in [0, 1) (1 is gross sliding)", p["q_ratio"])
    pair = pair_from_params(p)
    angle = finite_number("angle", p.get("angle", 0.0), "a finite angle in degrees")
    n = integer("n", p.get("n", 64), 8, "an integer in [8, 4096] (cells across the contact)", 4096)
    tol = finite_number("tol", p.get("tol", 1e-8), "a tolerance in [1e-14, 1e-4]")
    if not 1e-14 <= tol <= 1e-4:
        raise InputError("tol", "a tolerance in [1e-14, 1e-4]", p["tol"])
    steps = integer("steps", p.get("steps", 10), 1, "an integer in [1, 1000]", 1000)
    control = p.get("control", "force")
    if control not in CONTROLS:
        raise InputError("control", f"one of {', '.join(CONTROLS)}", control)
    displacement = None
    if control == "displacement":
        if "displacement" not in p:
            raise InputError("displacement", "the final tangential displacement (control = displacement)", None)
        displacement = finite_number("displacement", p["displacement"], "a finite displacement >= 0")
        if displacement < 0.0:
            raise InputError("displacement", "a finite displacement >= 0", p["displacement"])
    elif "displacement" in p:
        raise InputError("displacement", "only with control = displacement", p["displacement"])
    path = p.get("path", "load")
    if path not in PATHS:
        raise InputError("path", f"one of {', '.join(PATHS)}", path)
    if path == "loop" and control != "force":
        raise InputError("path", "loop needs control = force (it reverses at +-q_ratio mu P)", path)
    coupling = p.get("coupling", "auto")
    if coupling not in COUPLINGS:
        raise InputError("coupling", f"one of {', '.join(COUPLINGS)}", coupling)
    threads = integer("threads", p.get("threads", 1), 1, "an integer >= 1", 1024)
    return SlipScene(
        pair=pair, load=load, mu=mu, q_ratio=q_ratio, angle_deg=angle, n=n, tol=tol, steps=steps,
        control=control, displacement=displacement, path=path,
        tensor=_flag("tensor", p.get("tensor", False)), history=_flag("history", p.get("history", False)),
        coupling=coupling, threads=threads, precondition=_flag("precondition", p.get("precondition", True)),
    )


class SlipProblem:
    """The pair on its contact grid: scaled units, gap, operators, Hertz reference.

    Inside, lengths are in units of the Hertz semi-major axis ``L = hertz.a`` and stresses in
    units of ``G_eq`` (the equivalent body of ``Pair.equivalent``); the grid's x axis is the
    major axis of the contact ellipse (scene angle ``hertz.angle_deg``). ``n`` cells span the
    major diameter 2a (square cells unless fewer than 16 would span the minor one).
    """

    def __init__(self, scene: SlipScene) -> None:
        self.scene = scene
        pair = scene.pair
        self.pair = pair
        self.hertz: HertzEllipse = pair.hertz(scene.load)
        self.L = self.hertz.a
        self.G_ref = pair.equivalent.G
        self.material = Isotropic(G=1.0, nu=pair.equivalent.nu)
        aspect = self.hertz.aspect
        dx = 2.0 / scene.n
        across = scene.n * aspect
        dy = dx if across >= MIN_CELLS_ACROSS else 2.0 * aspect / MIN_CELLS_ACROSS
        nx = 2 * math.ceil(GRID_MARGIN / dx)
        ny = 2 * math.ceil(GRID_MARGIN * aspect / dy)
        self.grid = Grid(nx, ny, dx, dy)
        x, y = self.grid.centres()
        self.x, self.y = x, y
        A, B = self.hertz.A * self.L, self.hertz.B * self.L  # dimensionless gap coefficients
        self.gap = A * x * x + B * y * y
        self.P = scene.load / (self.G_ref * self.L * self.L)
        nu = self.material.nu
        tangential = ("xx",) if nu == 0.0 else ("xx", "xy", "yx", "yy")
        self.engine = Engine(self.material, self.grid, tangential + ("zz",), scene.threads)
        self.op_t = self.engine.operator("xy")
        self.op_z = self.engine.operator("z")
        self.precondition_t = (
            FourierPreconditioner(self.grid, self.surface_green, "xy").apply if scene.precondition else None
        )
        self.norm_A = self._operator_norm()
        impulse = np.zeros((2, nx, ny))
        impulse[0, nx // 2, ny // 2] = 1.0
        self.self_compliance = float(self.op_t.apply(impulse)[0, nx // 2, ny // 2])
        self._op_c: ConvolutionOperator | None = None
        self._op_full: ConvolutionOperator | None = None
        self._precondition_full: Operator | None = None

    def surface_green(self, phi: np.ndarray) -> np.ndarray:
        """H(m) of the pair (grid units, for the preconditioner): the equivalent body's tangential
        and normal blocks, coupling ±i c m/2 with c = G_eq[(1−2nu1)/G1 − (1−2nu2)/G2]."""
        H = isotropic_surface_green(self.material, phi)
        c = self.pair.coupling_modulus * self.G_ref
        m = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
        H[..., :2, 2] = 0.5j * c * m
        H[..., 2, :2] = -0.5j * c * m
        return H

    # scaling between scene units and the grid's
    @property
    def force_unit(self) -> float:
        return self.G_ref * self.L * self.L

    @property
    def stiffness_unit(self) -> float:
        return self.G_ref * self.L

    def _operator_norm(self) -> float:
        """Upper bound of ‖A_tt‖ on the grid: max over the padded FFT grid of λ_max of the symbol."""
        sxx = np.abs(self.engine.spectrum("xx"))
        syy = np.abs(self.engine.spectrum("yy"))
        try:
            sxy = np.abs(self.engine.spectrum("xy"))
        except KeyError:
            sxy = 0.0
        lam = 0.5 * (sxx + syy) + np.sqrt(0.25 * (sxx - syy) ** 2 + sxy * sxy)
        return float(lam.max())

    @property
    def coupling_operator(self) -> ConvolutionOperator:
        """(t_x, t_y, p) ↦ (A_xz p, A_yz p, A_zx t_x + A_zy t_y): blocks of body 1 minus body 2."""
        if self._op_c is None:
            g = self.grid
            mats = [self.pair.coupling_material(i) for i in (1, 2)]
            scaled = [None if m is None else Isotropic(G=m.G / self.G_ref, nu=m.nu) for m in mats]
            key_base = ("pair-coupling",) + tuple(("rigid",) if m is None else m.key for m in scaled)
            spectra = {}
            for block in ("xz", "yz", "zx", "zy"):
                def build(block: str = block) -> np.ndarray:
                    out = np.zeros((2 * g.nx - 1, 2 * g.ny - 1))
                    for sign, m in zip((1.0, -1.0), scaled):
                        if m is not None:
                            out = out + sign * isotropic_block(m, g.nx, g.ny, g.dx, g.dy, block)
                    return out
                key = key_base + (g.nx, g.ny, g.dx, g.dy, block)
                spectra[block] = cached_spectrum(key, build, self.engine.fft_shape)
            self._op_c = ConvolutionOperator(g.nx, g.ny, "xyz", spectra, threads=self.scene.threads)
        return self._op_c

    def coupling_tangential(self, p: np.ndarray) -> np.ndarray:
        """A_tz p: relative tangential displacement (2, nx, ny) caused by the pressure (nx, ny)."""
        field3 = np.zeros((3,) + p.shape)
        field3[2] = p
        return self.coupling_operator.apply(field3)[:2]

    def coupling_normal(self, t: np.ndarray) -> np.ndarray:
        """A_zt t: relative normal displacement (nx, ny) caused by the tangential traction."""
        field3 = np.zeros((3,) + t.shape[1:])
        field3[:2] = t
        return self.coupling_operator.apply(field3)[2]

    def normal(self, extra_gap: np.ndarray | None = None) -> Solution:
        """Polonsky–Keer at the load P on the gap (plus ``extra_gap``); raises if the contact
        reaches the grid edge."""
        gap = self.gap if extra_gap is None else self.gap + extra_gap
        solution = polonsky_keer(
            self.op_z.apply, gap, tol=min(self.scene.tol, 1e-10), load=self.P, cell_area=self.grid.cell_area
        )
        contact = solution.traction[0] > 0.0
        if contact[0, :].any() or contact[-1, :].any() or contact[:, 0].any() or contact[:, -1].any():
            raise FloatingPointError("the contact reaches the edge of the slip grid")
        return solution

    @property
    def full_operator(self) -> ConvolutionOperator:
        """The coupled 3-component operator of the pair (xx xy yx yy zz and the coupling blocks)."""
        if self._op_full is None:
            op_c = self.coupling_operator
            spectra = {}
            for a in "xyz":
                for c in "xyz":
                    block = a + c
                    if block in ("xz", "yz", "zx", "zy"):
                        spectra[block] = op_c.pairs["xyz".index(a)]["xyz".index(c)]
                    else:
                        try:
                            spectra[block] = self.engine.spectrum(block)
                        except KeyError:
                            continue
            self._op_full = ConvolutionOperator(self.grid.nx, self.grid.ny, "xyz", spectra, threads=self.scene.threads)
            if self.scene.precondition:
                self._precondition_full = FourierPreconditioner(self.grid, self.surface_green, "xyz").apply
        return self._op_full

    def tangent_tensor(
        self, stick: np.ndarray, slip_direction: np.ndarray | None, contact: np.ndarray, coupled: bool
    ) -> tuple[np.ndarray, int]:
        r"""Incremental stiffness tensor (grid frame and units) of a state, at constant normal load.

        Stick cells move rigidly with the increment dδ. Slip cells (traction on the limit,
        direction ``slip_direction`` t̂_i) either

        * keep their traction (``slip_direction`` None: the *frozen slip zone*, the no-slip
          stiffness of the stick area — Mindlin & Deresiewicz 1953; Johnson 1985 §7.2), or
        * slide along t̂_i only: Coulomb's law to first order in the rate form (the slip rate
          stays parallel to the traction, λ̇ ≥ 0), so the traction may turn on its friction
          circle, dt_i ⊥ t̂_i, while the relative displacement across t̂_i follows dδ
          (the *consistent* tangent of continued loading).

        Both are the Schur complement of a symmetric positive definite restriction Π A Π of the
        compliance (Π: all components on stick cells, the τ̂ = t̂^⊥ component on slip cells, the
        pressure on the contact cells when ``coupled``), solved by PCG for unit δ_x, δ_y (and a
        unit approach d when coupled, whose row is condensed out with dP = 0:
        K = K_tt − K_tz K_zz⁻¹ K_zt). Coupled, the contact area is held and the change of a slip
        cell's limit mu dp is left out (it would make the system non-symmetric; an O(β mu)
        term, measured 2e-4 of k_t for Fe on a rigid flat, β = 0.29).
        """
        if not stick.any() and slip_direction is None:
            return np.zeros((2, 2)), 0
        tau = None
        if slip_direction is not None:
            tau = np.stack([-slip_direction[1], slip_direction[0]])
        slip = contact & ~stick if slip_direction is not None else np.zeros_like(stick)
        if coupled:
            op, pc, comps = self.full_operator, self._precondition_full, 3
        else:
            op, pc, comps = self.op_t, self.precondition_t, 2

        def restrict(v: np.ndarray) -> np.ndarray:
            out = np.zeros_like(v)
            out[:2] = np.where(stick, v[:2], 0.0)
            if tau is not None:
                along = v[0] * tau[0] + v[1] * tau[1]
                out[:2] += np.where(slip, along * tau, 0.0)
            if comps == 3:
                out[2] = np.where(contact, v[2], 0.0)
            return out

        K = np.zeros((comps, comps))
        iterations = 0
        for j in range(comps):
            rhs = np.zeros((comps,) + stick.shape)
            rhs[j] = 1.0
            x, its = _pcg(op.apply, restrict(rhs), restrict, pc, self.scene.tol)
            iterations += its
            K[:, j] = x.reshape(comps, -1).sum(axis=1) * self.grid.cell_area
        if comps == 3:
            K = K[:2, :2] - np.outer(K[:2, 2], K[2, :2]) / K[2, 2]
        return K, iterations


def _pcg(
    apply: Operator, rhs: np.ndarray, restrict: Operator, precondition: Operator | None, tol: float,
    maxiter: int = 5000,
) -> tuple[np.ndarray, int]:
    """Solve Π A Π x = Π b for x = Π x by preconditioned CG (Π a symmetric projection)."""
    b = restrict(rhs)
    b_norm = float(np.linalg.norm(b))
    x = np.zeros_like(b)
    if b_norm == 0.0:
        return x, 0
    r = b.copy()
    z = restrict(precondition(r)) if precondition is not None else r
    p = z.copy()
    rz = float(np.vdot(r, z))
    residual = 1.0
    for iteration in range(1, maxiter + 1):
        q = restrict(apply(p))
        curvature = float(np.vdot(p, q))
        if not curvature > 0.0:
            raise ConvergenceError("tangent operator is not positive definite", iteration, residual)
        alpha = rz / curvature
        x += alpha * p
        r -= alpha * q
        residual = float(np.linalg.norm(r)) / b_norm
        if residual <= tol:
            return x, iteration
        z = restrict(precondition(r)) if precondition is not None else r
        rz_new = float(np.vdot(r, z))
        p = z + (rz_new / rz) * p
        rz = rz_new
    raise ConvergenceError(f"tangent CG did not reach tol={tol:g}", maxiter, residual)


# ------------------------------------------------------------------------------------------
# states and load steps
# ------------------------------------------------------------------------------------------
@dataclass
class SlipState:
    """A converged state (grid frame, grid units).

    ``delta`` rigid tangential displacement (2,); ``t`` traction (2, nx, ny); ``p`` pressure;
    ``s`` accumulated slip δ − u_t on every cell; ``force`` (2,); ``stick`` and ``contact``
    masks; ``K`` the incremental (stick-area) tensor once computed.
    """

    delta: np.ndarray
    t: np.ndarray
    p: np.ndarray
    s: np.ndarray
    force: np.ndarray
    stick: np.ndarray
    contact: np.ndarray
    K: np.ndarray | None = None
    K_stick: np.ndarray | None = None

    def slip_direction(self) -> np.ndarray:
        """t̂ = t/|t| on the slip cells (contact cells not in the stick set), zero elsewhere."""
        mag = np.hypot(self.t[0], self.t[1])
        slip = self.contact & ~self.stick & (mag > 0.0)
        return np.where(slip, self.t / np.where(slip, mag, 1.0), 0.0)


@dataclass
class Counters:
    """Work done: operator applications of the slip solver, CG iterations, PK iterations."""

    qp: int = 0
    cg: int = 0
    pk: int = 0
    newton: int = 0
    outer: int = 0
    residual: float = 0.0

    def total(self) -> int:
        return self.qp + self.cg + self.pk


class PathSolver:
    """Load steps of one coupling mode (``coupled`` True: Panagiotopoulos; False: Goodman)."""

    MAX_NEWTON = 40
    MAX_OUTER = 50

    def __init__(self, problem: SlipProblem, coupled: bool) -> None:
        self.problem = problem
        self.coupled = coupled
        self.mu = problem.scene.mu
        self.tol = problem.scene.tol
        self.count = Counters()
        # Panagiotopoulos' process stops when the pressure changes by less than this (relative
        # L1); it contracts by ~1e-2 per pass (measured, Cu-Fe and Fe on rigid), so 2-4 passes
        self.outer_tol = 10.0 * self.tol
        normal = problem.normal()
        self.count.pk += normal.iterations
        p0 = normal.traction[0]
        zero = np.zeros((2,) + p0.shape)
        s0 = -problem.coupling_tangential(p0) if coupled else zero.copy()
        contact = p0 > 0.0
        self.initial = SlipState(np.zeros(2), zero.copy(), p0, s0, np.zeros(2), contact.copy(), contact)
        self.initial.K = None
        self.K0 = self.tangent(self.initial)
        self._last_increment: np.ndarray | None = None

    def equilibrium(self, prev: SlipState, delta: np.ndarray, warm: SlipState | None = None) -> SlipState:
        """The state reached from ``prev`` when the rigid displacement becomes ``delta``.

        ``warm`` (a nearby state, e.g. the previous Newton iterate) only seeds the iteration.
        """
        pb = self.problem
        p, t = (prev.p, prev.t) if warm is None else (warm.p, warm.t)
        shift = np.asarray(delta, dtype=np.float64)[:, None, None]
        c = 1.0 / pb.self_compliance
        p_change = math.inf
        for outer in range(1, self.MAX_OUTER + 1):
            b = shift - prev.s
            if self.coupled:
                b = b - pb.coupling_tangential(p)
            result = disc_qp(pb.op_t.apply, b, self.mu * p, t, self.tol, c, pb.norm_A, precondition=pb.precondition_t)
            self.count.qp += result.iterations
            self.count.residual = max(self.count.residual, result.residual)
            t = result.traction
            if not self.coupled or p_change <= self.outer_tol:
                break  # (coupled: this last slip solve used the settled pressure)
            normal = pb.normal(pb.coupling_normal(t))
            self.count.pk += normal.iterations
            p_new = normal.traction[0]
            p_change = float(np.abs(p_new - p).sum()) / float(np.abs(p_new).sum())
            p = p_new
            self.count.outer += 1
        else:
            raise ConvergenceError("normal-tangential (Panagiotopoulos) iteration did not settle", outer, p_change)
        u = pb.op_t.apply(t)
        if self.coupled:
            u = u + pb.coupling_tangential(p)
        s = shift - u
        contact = p > 0.0
        bound = self.mu * p
        stick = contact & (np.hypot(t[0], t[1]) < bound * (1.0 - 1e-12))
        force = t.reshape(2, -1).sum(axis=1) * pb.grid.cell_area
        return SlipState(np.array(delta, dtype=np.float64), t, p, s, force, stick, contact)

    def tangent(self, state: SlipState) -> np.ndarray:
        """The consistent incremental tensor of ``state`` (``SlipProblem.tangent_tensor``: stick
        cells stuck, slip cells sliding along their traction), computed once."""
        if state.K is None:
            K, iterations = self.problem.tangent_tensor(
                state.stick, state.slip_direction(), state.contact, self.coupled
            )
            self.count.cg += iterations
            state.K = K
        return state.K

    def stick_tangent(self, state: SlipState) -> np.ndarray:
        """The frozen-slip-zone tensor of ``state``: no-slip stiffness of its stick area."""
        if state.K_stick is None:
            K, iterations = self.problem.tangent_tensor(state.stick, None, state.contact, self.coupled)
            self.count.cg += iterations
            state.K_stick = K
        return state.K_stick

    def to_displacement(self, prev: SlipState, delta: np.ndarray) -> SlipState:
        state = self.equilibrium(prev, delta)
        self.tangent(state)
        return state

    def to_force(self, prev: SlipState, target: np.ndarray) -> SlipState:
        """Newton on δ for the force ``target`` (grid units) with the consistent tangent as Jacobian.

        Predictor: the previous step's tangent when the load keeps its direction, the stiffest
        one (whole contact stuck, K_0) after a reversal or at the start. Along a concave branch
        (stiffness falling as the load grows) a tangent from behind overestimates the slope, so
        every iterate stays short of the target and Newton approaches it monotonically.
        """
        scale = max(self.mu * self.problem.P, 1e-300)
        ftol = 10.0 * self.tol * scale
        increment = target - prev.force
        continuing = self._last_increment is not None and float(increment @ self._last_increment) > 0.0
        K = self.tangent(prev) if continuing and prev.stick.any() else self.K0
        delta = prev.delta + np.linalg.solve(K, increment)
        warm: SlipState | None = None
        residual = increment
        for _ in range(self.MAX_NEWTON):
            self.count.newton += 1
            state = self.equilibrium(prev, delta, warm)
            residual = target - state.force
            if float(np.linalg.norm(residual)) <= ftol:
                self.tangent(state)
                self._last_increment = increment
                return state
            K = self.tangent(state)
            if not state.stick.any() or abs(np.linalg.det(K)) <= 1e-14 * np.linalg.det(self.K0):
                raise ConvergenceError("no stick cells left: the contact slides (grid too coarse for this q_ratio?)",
                                       self.count.newton, float(np.linalg.norm(residual)) / scale)
            delta = delta + np.linalg.solve(K, residual)
            warm = state
        raise ConvergenceError("force-controlled Newton iteration did not converge", self.MAX_NEWTON,
                               float(np.linalg.norm(residual)) / scale)


# ------------------------------------------------------------------------------------------
# load paths and the record
# ------------------------------------------------------------------------------------------
def _rotation(angle_deg: float) -> np.ndarray:
    t = math.radians(angle_deg)
    return np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])


def along(K: np.ndarray, n: np.ndarray) -> float:
    """Stiffness along n under force control: 1/(nᵀ K⁻¹ n) (0 when K is singular: sliding)."""
    if not np.isfinite(K).all():
        raise FloatingPointError("non-finite stiffness tensor")
    scale = float(np.abs(K).max())
    if scale == 0.0 or float(np.linalg.det(K)) <= 1e-12 * scale * scale:
        return 0.0
    return float(1.0 / (n @ np.linalg.solve(K, n)))


@dataclass
class PathPoint:
    """One converged step in scene units: force and displacement along the load, k_t, areas."""

    branch: str
    force: float
    displacement: float
    stiffness: float
    stick_area: float
    contact_area: float
    tensor: np.ndarray  # scene frame
    stick_stiffness: float  # frozen-slip-zone (stick-area) stiffness along the load


class PathResult:
    """All steps of one coupling mode and the work they took."""

    def __init__(self, points: list[PathPoint], counters: Counters, final: SlipState, initial: SlipState) -> None:
        self.points, self.counters, self.final, self.initial = points, counters, final, initial

    @property
    def last(self) -> PathPoint:
        return self.points[-1]


def _targets(scene: SlipScene, limit: float) -> list[tuple[str, float]]:
    """(branch, target) of every step: Q in force control (scene units), δ in displacement control."""
    m = scene.steps
    if scene.control == "displacement":
        return [("loading", scene.displacement * k / m) for k in range(1, m + 1)]
    q_star = scene.q_ratio * limit
    out = [("loading", q_star * k / m) for k in range(1, m + 1)]
    if scene.path == "loop":
        out += [("unloading", q_star * (1.0 - k / m)) for k in range(1, 2 * m + 1)]
        out += [("reloading", q_star * (-1.0 + k / m)) for k in range(1, 2 * m + 1)]
    return out


def run_path(problem: SlipProblem, coupled: bool) -> PathResult:
    """Normal contact, then the scene's tangential steps, in one coupling mode."""
    scene = problem.scene
    solver = PathSolver(problem, coupled)
    theta = math.radians(scene.angle_deg - problem.hertz.angle_deg)
    n = np.array([math.cos(theta), math.sin(theta)])
    R = _rotation(problem.hertz.angle_deg)
    L, Fu, Ku = problem.L, problem.force_unit, problem.stiffness_unit
    area = problem.grid.cell_area * L * L

    def point(branch: str, state: SlipState) -> PathPoint:
        K = state.K if scene.mu > 0.0 else np.zeros((2, 2))
        K_stick = solver.stick_tangent(state) if scene.mu > 0.0 else np.zeros((2, 2))
        return PathPoint(
            branch=branch,
            force=float(n @ state.force) * Fu,
            displacement=float(n @ state.delta) * L,
            stiffness=along(K, n) * Ku,
            stick_area=float(state.stick.sum()) * area if scene.mu > 0.0 else 0.0,
            contact_area=float(state.contact.sum()) * area,
            tensor=R @ K @ R.T * Ku,
            stick_stiffness=along(K_stick, n) * Ku,
        )

    state = solver.initial
    points = [point("initial", state)]
    if scene.mu > 0.0:
        for branch, target in _targets(scene, scene.mu * scene.load):
            if scene.control == "force":
                state = solver.to_force(state, n * (target / Fu))
            else:
                state = solver.to_displacement(state, n * (target / L))
            points.append(point(branch, state))
    return PathResult(points, solver.count, state, solver.initial)


def _check_finite(record: Mapping[str, Any]) -> None:
    for key, value in record.items():
        if isinstance(value, float) and not math.isfinite(value):
            raise FloatingPointError(f"{key} is not finite ({value})")


def _mode_keys(path: PathResult, prefix: str = "") -> dict[str, float]:
    last = path.last
    return {
        f"{prefix}tangential_force": last.force,
        f"{prefix}tangential_displacement": last.displacement,
        f"{prefix}tangential_stiffness": last.stiffness,
        f"{prefix}stick_area_stiffness": last.stick_stiffness,
        f"{prefix}stick_area": last.stick_area,
        f"{prefix}contact_area": last.contact_area,
    }


def _history(path: PathResult) -> dict[str, list]:
    pts = path.points
    secant = [math.nan] + [
        (b.force - a.force) / (b.displacement - a.displacement) if b.displacement != a.displacement else math.nan
        for a, b in zip(pts, pts[1:])
    ]
    return {
        "branch": [p.branch for p in pts],
        "tangential_force": [p.force for p in pts],
        "tangential_displacement": [p.displacement for p in pts],
        "tangential_stiffness": [p.stiffness for p in pts],
        "stick_area_stiffness": [p.stick_stiffness for p in pts],
        "secant_stiffness": [None if math.isnan(s) else s for s in secant],
        "stick_area": [p.stick_area for p in pts],
        "contact_area": [p.contact_area for p in pts],
        "tangential_stiffness_tensor": [p.tensor.tolist() for p in pts],
    }


def solve_slip(params: Mapping[str, Any]) -> dict[str, Any]:
    """One partial-slip scene → the record of DESIGN §4.1 for ``--quantities slip``.

    Keys: ``tangential_force tangential_displacement tangential_stiffness stick_area
    contact_area load`` at the end of the path (force and displacement along the load direction;
    k_t = dQ/dδ, the consistent incremental stiffness along it), ``stick_area_stiffness`` (the
    frozen-slip-zone check: no-slip stiffness of the stick area along the load), with
    ``tangential_stiffness_xx … _yy`` (the consistent incremental 2 × 2 tensor, scene frame,
    force = K·displacement) when ``tensor`` is true;
    ``iterations`` (operator applications of the slip solver + CG + Polonsky–Keer iterations),
    ``residual`` (largest final relative KKT residual), ``wall_time_s``, ``nx ny dx dy`` (cell
    sizes in input length units), ``plan``; and the references: ``no_slip_stiffness`` (k_t at
    Q = 0 on the grid), ``stiffness_ratio`` (k_t over it), ``force_ratio`` (Q/(mu P) reached),
    ``stick_radius`` (sqrt(stick_area/π)), ``hertz_a hertz_b contact_angle_deg``
    (analytic Hertz ellipse), ``normal_stiffness`` (Hertz dP/dd = 3P/(2d)),
    ``mindlin_no_slip_stiffness`` (Mindlin's bonded ellipse along the load), for circular
    contacts ``mindlin_stiffness`` and ``mindlin_displacement`` (Cattaneo–Mindlin /
    Mindlin–Deresiewicz closed forms at the same Q and path) and ``mindlin_stick_radius``;
    ``dundurs_beta``; for a dissimilar pair solved both ways the Goodman (decoupled) answers as
    ``decoupled_*`` and the relative differences ``coupling_effect_stiffness``,
    ``coupling_effect_displacement``, ``coupling_effect_stick_area``; ``history`` (every step)
    when asked. Bad input raises ``InputError`` naming the field.
    """
    started = time.perf_counter()
    scene = validate(params)
    problem = SlipProblem(scene)
    pair, hertz = problem.pair, problem.hertz
    if pair.similar or scene.coupling == "decoupled":
        modes = [False]
    elif scene.coupling == "coupled":
        modes = [True]
    else:
        modes = [True, False]
    paths = {coupled: run_path(problem, coupled) for coupled in modes}
    main = paths[modes[0]]
    g = problem.grid
    record: dict[str, Any] = _mode_keys(main)
    record["load"] = scene.load
    last = main.last
    if scene.tensor:
        for i, a in enumerate("xy"):
            for j, c in enumerate("xy"):
                record[f"tangential_stiffness_{a}{c}"] = float(last.tensor[i, j])
    k0 = main.points[0].stiffness
    record["no_slip_stiffness"] = k0
    record["stiffness_ratio"] = last.stiffness / k0 if k0 > 0.0 else 0.0
    limit = scene.mu * scene.load
    record["force_ratio"] = last.force / limit if limit > 0.0 else 0.0
    record["stick_radius"] = math.sqrt(last.stick_area / math.pi)
    record["hertz_a"], record["hertz_b"] = hertz.a, hertz.b
    record["contact_angle_deg"] = hertz.angle_deg
    record["normal_stiffness"] = hertz.normal_stiffness
    record["dundurs_beta"] = pair.dundurs_beta
    eq = pair.equivalent
    theta = math.radians(scene.angle_deg - hertz.angle_deg)
    J_a, J_b = analytic.mindlin_ellipse_compliance(hertz.a, hertz.b, eq.G, eq.nu)
    record["mindlin_no_slip_stiffness"] = 1.0 / (J_a * math.cos(theta) ** 2 + J_b * math.sin(theta) ** 2)
    if hertz.aspect == 1.0 and limit > 0.0:
        record.update(_mindlin_reference(main, scene, hertz, eq))
    if len(modes) == 2:
        decoupled = paths[False]
        record.update(_mode_keys(decoupled, "decoupled_"))
        record["coupling_effect_stiffness"] = _relative(last.stiffness, decoupled.last.stiffness)
        # δ is zero to the solver's tolerance at Q = 0 (scale: δ at the sliding limit, mu P/k_t(0))
        record["coupling_effect_displacement"] = _relative(
            last.displacement, decoupled.last.displacement, scene.tol * limit / k0 if k0 > 0.0 else 0.0
        )
        record["coupling_effect_stick_area"] = _relative(last.stick_area, decoupled.last.stick_area)
    counters = [p.counters for p in paths.values()]
    record["iterations"] = int(sum(c.total() for c in counters))
    record["residual"] = float(max(c.residual for c in counters))
    record["nx"], record["ny"] = g.nx, g.ny
    record["dx"], record["dy"] = g.dx * problem.L, g.dy * problem.L
    record["plan"] = _plan(problem, modes, paths)
    if scene.history:
        record["history"] = _history(main)
        if len(modes) == 2:
            record["decoupled_history"] = _history(paths[False])
    record["wall_time_s"] = time.perf_counter() - started
    _check_finite(record)
    return record


def _relative(a: float, b: float, zero: float = 0.0) -> float:
    """a/b − 1; 0 when both are zero (|a|, |b| ≤ ``zero``: solver round-off of a vanishing value)."""
    if abs(a) <= zero and abs(b) <= zero:
        return 0.0
    return a / b - 1.0 if b != 0.0 else (0.0 if a == 0.0 else math.copysign(math.inf, a))


def _mindlin_reference(path: PathResult, scene: SlipScene, hertz: HertzEllipse, eq: Isotropic) -> dict[str, float]:
    """Cattaneo–Mindlin / Mindlin–Deresiewicz closed forms at the path's last point (circle only).

    Johnson 1985, §7.2 and §7.4, with the pair's equivalent body (G_eq, nu_eq) and the analytic
    Hertz radius: the loop ends on the reloading branch at +Q*, where δ and k_t equal the
    loading values (the loop closes).
    """
    Q, P, mu, a = path.last.force, scene.load, scene.mu, hertz.a
    if abs(Q) > mu * P:  # displacement control past the sliding limit: no closed form
        return {}
    return {
        "mindlin_displacement": float(analytic.cattaneo_mindlin_displacement(Q, P, mu, a, eq.G, eq.nu)),
        "mindlin_stiffness": float(analytic.cattaneo_mindlin_stiffness(Q, P, mu, a, eq.G, eq.nu)),
        "mindlin_stick_radius": float(analytic.stick_radius(Q, P, mu, a)),
    }


def _plan(problem: SlipProblem, modes: list[bool], paths: Mapping[bool, PathResult]) -> dict[str, Any]:
    """What was built and run, the pair's coupling and the method (DESIGN §1: only what is needed)."""
    scene, pair = problem.scene, problem.pair
    kernels = list(problem.engine.kernels)
    if True in modes:
        kernels += ["xz(pair)", "yz(pair)", "zx(pair)", "zy(pair)"]
    derived = []
    if problem.material.nu == 0.0:
        derived.append("yy = xx, xy = 0 (nu_eq = 0)")
    if pair.similar:
        derived.append("no coupling blocks: elastically similar pair ((1-2nu1)/G1 = (1-2nu2)/G2, beta = 0)")
    solves = []
    for coupled in modes:
        c = paths[coupled].counters
        name = "coupled[panagiotopoulos: slip xy + polonsky_keer z]" if coupled else "decoupled[slip xy, p fixed]"
        solves.append(f"{name}: {len(paths[coupled].points) - 1} steps, {c.newton} newton, {c.qp} slip applications, "
                      f"{c.cg} stick-tensor CG, {c.pk} polonsky_keer, {c.outer} normal-tangential passes")
    coupling = ("none: elastically similar" if pair.similar else
                "coupled (Panagiotopoulos) and decoupled (Goodman)" if len(modes) == 2 else
                "coupled (Panagiotopoulos)" if modes[0] else "decoupled (Goodman approximation)")
    return {
        "kernels": kernels,
        "solves": ["normal_polonsky_keer[z]"] + solves,
        "derived": derived,
        "operator_applications": [],
        "pair": [
            f"similar={pair.similar}",
            f"dundurs_beta={pair.dundurs_beta:.6g}",
            f"coupling={coupling}",
            f"G_eq={pair.equivalent.G:.6g}",
            f"nu_eq={pair.equivalent.nu:.6g}",
            f"E_star={pair.E_star:.6g}",
        ],
        "method": [
            "normal pressure: discrete Hertz, Polonsky-Keer on the slip grid at the load, applied without friction",
            "slip: semismooth Newton (primal-dual active set, linearized slip directions), PCG inner solves, "
            "MPRGP fallback",
            "tangent: consistent (stick cells stuck, slip cells slide along their traction); "
            "stick_area_stiffness: no-slip stiffness of the stick area",
            f"control={scene.control}",
            f"path={scene.path}",
        ],
    }
