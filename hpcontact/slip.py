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

Solver choice: MPRGP for separable spherical constraints (Dostál & Schöberl 2005; Kučera 2008;
Dostál & Kozubek 2012) — conjugate gradients on the free (stick) cells, an expansion step that
projects onto the discs when a CG step would leave them, and proportioning steps (projected
gradient with an exact line search and a guaranteed-descent fallback of step 1/‖A‖) that release
or rotate cells on the slip limit. Why this one: (i) the incremental problem is an SPD quadratic
programme with a product of discs as feasible set, for which MPRGP has a proven R-linear rate
(Kučera 2008) — Kalker's active-set iteration on the stick/slip partition has no convergence
guarantee and can cycle; (ii) it reduces to plain CG (the engine's solver) when nothing slips
and behaves like Polonsky & Keer's constrained CG (1999) when the limits are hit, so it uses the
same operator and needs no inner linear solves (ADMM / augmented-Lagrangian schemes need one
per outer iteration); (iii) the discs keep the slip direction free, so the small y-slip that
nu ≠ 0 causes under x-loading (neglected by Cattaneo and Mindlin, Johnson 1985 §7.2) is
resolved, not assumed away. ``‖A‖`` is bounded by the largest eigenvalue of the 2 × 2 kernel
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
the record states the difference.

Incremental stiffness. Within a step along the load the slip cells keep |t| = mu p with an
unchanged direction, so dt vanishes there and the stick cells move rigidly: to first order the
incremental stiffness is the bonded (no-slip) stiffness tensor of the current stick area,
K_t = K_bonded(stick) (Mindlin & Deresiewicz 1953; Johnson 1985, §7.2: dQ/dδ =
8G a_c/(2 − nu) for a stick circle of radius c). It is computed that way, by two bonded CG
solves on the stick cells (unit displacement along x and y), and checked against the solver's
own Q–δ curve (secant) and the closed forms. The scalar stiffness along the load direction n is
k_t = 1/(nᵀ K_t⁻¹ n) (force control: the displacement increment along n per unit force along n).
Perpendicular increments also rotate the slip tractions, which this tangent neglects: it is the
"frozen slip zone" tensor (stated in the plan).

Force control is solved by Newton's method on δ with that tensor as Jacobian (exact while no cell
changes state; monotone from below on the concave loading curve).

Units: lengths are scaled by the Hertz semi-axis a and stresses by G_eq inside; the record is in
the units of the input (SI for library materials: N, m, N/m, m²).

References
----------
- K. L. Johnson, *Contact Mechanics*, Cambridge University Press, 1985 (§4.2, §5.4–5.5, §7.2, §7.4).
- R. D. Mindlin and H. Deresiewicz, J. Appl. Mech. 20 (1953) 327–344.
- J. J. Kalker, *Three-dimensional Elastic Bodies in Rolling Contact*, Kluwer, 1990.
- I. A. Polonsky and L. M. Keer, Wear 231 (1999) 206–219.
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
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Mapping

import numpy as np

from . import analytic
from .bodies import HertzEllipse, Pair, pair_from_params
from .errors import ConvergenceError, InputError
from .geometry import Grid
from .kernels.isotropic import isotropic_block
from .materials import Isotropic
from .operator import ConvolutionOperator, cached_spectrum
from .preconditioner import FourierPreconditioner
from .solve import Engine
from .solvers import Solution, conjugate_gradient, polonsky_keer

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
# the quadratic programme with disc constraints (MPRGP)
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


def disc_qp(
    apply: Operator,
    b: np.ndarray,
    bound: np.ndarray,
    t0: np.ndarray | None,
    tol: float,
    norm_A: float,
    maxiter: int | None = None,
    precondition: Operator | None = None,
    gamma: float = 1.0,
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
    """
    mask = bound > 0.0
    b = np.where(mask, b, 0.0)
    b_norm = float(np.linalg.norm(b))
    if not math.isfinite(b_norm):
        raise ValueError("right-hand side of the slip problem is not finite")
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


def _number(name: str, value: Any, allowed: str) -> float:
    if isinstance(value, bool):
        raise InputError(name, allowed, value)
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(name, allowed, value) from None
    if not math.isfinite(x):
        raise InputError(name, allowed, value)
    return x


def _integer(name: str, value: Any, low: int, high: int, allowed: str) -> int:
    x = _number(name, value, allowed)
    if x != int(x) or not low <= x <= high:
        raise InputError(name, allowed, value)
    return int(x)


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
    load = _number("load", p["load"], "a normal load, finite and > 0")
    if not load > 0.0:
        raise InputError("load", "a normal load, finite and > 0", p["load"])
    mu = _number("mu", p["mu"], "a friction coefficient, finite and >= 0")
    if mu < 0.0:
        raise InputError("mu", "a friction coefficient, finite and >= 0", p["mu"])
    q_ratio = _number("q_ratio", p["q_ratio"], "Q/(mu P) in [0, 1) (1 is gross sliding)")
    if not 0.0 <= q_ratio < 1.0:
        raise InputError("q_ratio", "Q/(mu P) in [0, 1) (1 is gross sliding)", p["q_ratio"])
    pair = pair_from_params(p)
    angle = _number("angle", p.get("angle", 0.0), "a finite angle in degrees")
    n = _integer("n", p.get("n", 64), 8, 4096, "an integer in [8, 4096] (cells across the contact)")
    tol = _number("tol", p.get("tol", 1e-8), "a tolerance in [1e-14, 1e-4]")
    if not 1e-14 <= tol <= 1e-4:
        raise InputError("tol", "a tolerance in [1e-14, 1e-4]", p["tol"])
    steps = _integer("steps", p.get("steps", 10), 1, 1000, "an integer in [1, 1000]")
    control = p.get("control", "force")
    if control not in CONTROLS:
        raise InputError("control", f"one of {', '.join(CONTROLS)}", control)
    displacement = None
    if control == "displacement":
        if "displacement" not in p:
            raise InputError("displacement", "the final tangential displacement (control = displacement)", None)
        displacement = _number("displacement", p["displacement"], "a finite displacement >= 0")
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
    threads = _integer("threads", p.get("threads", 1), 1, 1024, "an integer >= 1")
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
        self.coupled_possible = not pair.similar
        nu = self.material.nu
        tangential = ("xx",) if nu == 0.0 else ("xx", "xy", "yx", "yy")
        self.engine = Engine(self.material, self.grid, tangential + ("zz",), scene.threads)
        self.op_t = self.engine.operator("xy")
        self.op_z = self.engine.operator("z")
        self.precondition_t = (
            FourierPreconditioner(self.grid, self.material, "xy").apply if scene.precondition else None
        )
        self.norm_A = self._operator_norm()
        self._op_c: ConvolutionOperator | None = None

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

    def bonded_tensor(self, stick: np.ndarray) -> tuple[np.ndarray, int]:
        """No-slip stiffness tensor (grid frame, grid units) of the cells ``stick``: two CG solves."""
        K = np.zeros((2, 2))
        if not stick.any():
            return K, 0
        iterations = 0
        for j in range(2):
            rhs = np.zeros((2,) + stick.shape)
            rhs[j] = 1.0
            sol = conjugate_gradient(
                self.op_t.apply, rhs, stick, tol=self.scene.tol, precondition=self.precondition_t
            )
            iterations += sol.iterations
            K[:, j] = sol.traction.reshape(2, -1).sum(axis=1) * self.grid.cell_area
        return K, iterations


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
        normal = problem.normal()
        self.count.pk += normal.iterations
        p0 = normal.traction[0]
        zero = np.zeros((2,) + p0.shape)
        s0 = -problem.coupling_tangential(p0) if coupled else zero.copy()
        contact = p0 > 0.0
        self.initial = SlipState(np.zeros(2), zero.copy(), p0, s0, np.zeros(2), contact.copy(), contact)
        K0, iterations = problem.bonded_tensor(contact)
        self.count.cg += iterations
        self.initial.K = K0
        self.K0 = K0

    def equilibrium(self, prev: SlipState, delta: np.ndarray) -> SlipState:
        """The state reached from ``prev`` when the rigid displacement becomes ``delta``."""
        pb = self.problem
        p, t = prev.p, prev.t
        shift = np.asarray(delta, dtype=np.float64)[:, None, None]
        for outer in range(1, self.MAX_OUTER + 1):
            b = shift - prev.s
            if self.coupled:
                b = b - pb.coupling_tangential(p)
            result = disc_qp(
                pb.op_t.apply, b, self.mu * p, t, self.tol, pb.norm_A, precondition=pb.precondition_t
            )
            self.count.qp += result.iterations
            self.count.residual = max(self.count.residual, result.residual)
            t_change = float(np.abs(result.traction - t).sum()) / max(float(np.abs(result.traction).sum()), 1e-300)
            t = result.traction
            if not self.coupled:
                break
            normal = pb.normal(pb.coupling_normal(t))
            self.count.pk += normal.iterations
            p_new = normal.traction[0]
            p_change = float(np.abs(p_new - p).sum()) / float(np.abs(p_new).sum())
            p = p_new
            self.count.outer += 1
            if p_change <= self.tol and (t_change <= 10.0 * self.tol or outer > 1 and p_change == 0.0):
                break
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
        """K_t of ``state``: the bonded tensor of its stick cells (computed once)."""
        if state.K is None:
            K, iterations = self.problem.bonded_tensor(state.stick)
            self.count.cg += iterations
            state.K = K
        return state.K

    def to_displacement(self, prev: SlipState, delta: np.ndarray) -> SlipState:
        state = self.equilibrium(prev, delta)
        self.tangent(state)
        return state

    def to_force(self, prev: SlipState, target: np.ndarray) -> SlipState:
        """Newton on δ for the force ``target`` (grid units), tangent K_t, predictor K_0.

        The predictor uses the stiffest tangent (the whole contact stuck), so on the concave
        loading (or unloading) curve every iterate stays short of the target and Newton with
        the current stick tensor approaches it monotonically.
        """
        scale = max(self.mu * self.problem.P, 1e-300)
        ftol = 10.0 * self.tol * scale
        delta = prev.delta + np.linalg.solve(self.K0, target - prev.force)
        for _ in range(self.MAX_NEWTON):
            self.count.newton += 1
            state = self.equilibrium(prev, delta)
            residual = target - state.force
            if float(np.linalg.norm(residual)) <= ftol:
                self.tangent(state)
                return state
            K = self.tangent(state)
            if not state.stick.any() or abs(np.linalg.det(K)) <= 1e-14 * np.linalg.det(self.K0):
                raise ConvergenceError("no stick cells left: the contact slides (grid too coarse for this q_ratio?)",
                                       self.count.newton, float(np.linalg.norm(residual)) / scale)
            delta = delta + np.linalg.solve(K, residual)
        raise ConvergenceError("force-controlled Newton iteration did not converge", self.MAX_NEWTON,
                               float(np.linalg.norm(residual)) / scale)
