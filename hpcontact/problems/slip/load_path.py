r"""Load paths of a partial-slip scene: converged states, load steps, the consistent tangent.

``PathSolver`` carries one coupling mode from the normal contact through the tangential steps of
the scene (``run_path``); each step solves the friction-disc programme (``hpcontact.numerics.friction_qp``)
on the operators of ``hpcontact.problems.slip.problem.SlipProblem``.

Coupling (dissimilar pairs, β ≠ 0). Goodman's approximation (1962) keeps p = p0 (decoupled: only
the xx, xy, yy blocks). The coupled solution iterates Panagiotopoulos' process (Kalker 1990,
§5.2): tangential programme with the current p, then the normal problem with the gap changed
by A_zt t at the same load, until p and t stop changing. Both are run for a dissimilar pair and
the record states the difference (a few 1e-4 for Cu–Fe, a few % for Fe on a rigid flat:
docs/validation.md §"Partial slip").

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
in the slip annulus that the consistent tangent restrains (it is stiffer by ≲ 1 % near
Q = 0.9 mu P). Across the load they differ a lot (a pure transverse increment turns the slip
tractions without slipping: k_yy/k_xx ≈ 2 at Q = 0.9 mu P on a circle; docs/validation.md
§"Partial slip"), which is why the tensor is the tangent of *continued* loading,
valid for increments that keep every slip cell slipping. The scalar k_t along the load
direction n is 1/(nᵀ K⁻¹ n) (force control: displacement along n per unit force along n).

Force control is solved by Newton's method on δ with the consistent tensor as Jacobian (exact
while no cell changes state; monotone from below on the concave loading curve).

Device: a state's fields (t, p, s, the masks) are arrays of the problem's namespace
(``SlipProblem.xp``: numpy on the CPU, CuPy on a GPU); δ, the force and K are small host arrays,
the force summed on the device and read back as two numbers per equilibrium.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hpcontact.errors import ConvergenceError
from hpcontact.numerics.backend import Array, copy, namespace, to_device, to_host
from hpcontact.numerics.friction_qp import disc_qp
from hpcontact.problems.slip.problem import SlipProblem, SlipScene


@dataclass
class SlipState:
    """A converged state (grid frame, grid units).

    ``delta`` rigid tangential displacement (2,); ``t`` traction (2, nx, ny); ``p`` pressure;
    ``s`` accumulated slip δ − u_t on every cell; ``force`` (2,); ``stick`` and ``contact``
    masks; ``K`` the incremental (stick-area) tensor once computed. ``delta``, ``force`` and the
    tensors are numpy arrays, the fields on the grid arrays of the problem's device.
    """

    delta: np.ndarray
    t: Array
    p: Array
    s: Array
    force: np.ndarray
    stick: Array
    contact: Array
    K: np.ndarray | None = None
    K_stick: np.ndarray | None = None

    def slip_direction(self) -> Array:
        """t̂ = t/|t| on the slip cells (contact cells not in the stick set), zero elsewhere."""
        xp = namespace(self.t)
        mag = xp.hypot(self.t[0, ...], self.t[1, ...])
        slip = self.contact & ~self.stick & (mag > 0.0)
        return xp.where(slip, self.t / xp.where(slip, mag, 1.0), 0.0)


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
        # L1); it contracts by ~1e-2 per pass (docs/validation.md §"Partial slip"), so 2-4 passes
        self.outer_tol = 10.0 * self.tol
        if coupled and problem.scene.normal_friction and self.mu > 0.0:
            self.initial = self._normal_loading_with_friction()
        else:
            normal = problem.normal()
            self.count.pk += normal.iterations
            p0 = normal.traction[0, ...]
            zero = problem.zeros(2)
            s0 = -problem.coupling_tangential(p0) if coupled else copy(zero)
            contact = p0 > 0.0
            self.initial = SlipState(np.zeros(2), copy(zero), p0, s0, np.zeros(2), copy(contact), contact)
        self.initial.K = None
        self.K0 = self.tangent(self.initial)
        self._last_increment: np.ndarray | None = None

    def _normal_loading_with_friction(self) -> SlipState:
        """Spence's problem (Johnson 1985, §5.5): the normal load applied in ``steps`` equal
        increments with friction acting and the bodies held tangentially (δ = 0), each step the
        coupled process of ``equilibrium`` at its load. A dissimilar pair's pressure pulls the
        surfaces tangentially by different amounts (A_tz p), friction resists it in a central
        stick zone: the residual shear that a later tangential load adds to on one side and
        subtracts from on the other. Zero for an elastically similar pair (A_tz = 0). The paper of
        the shifted stick zone (Rodríguez-Tembleque et al. 2011, Fig. 6d) applies both loads at
        once instead: ``path = "proportional"``."""
        pb = self.problem
        state = self.unloaded()
        steps = pb.scene.steps
        for k in range(1, steps + 1):
            state = self.equilibrium(state, np.zeros(2), load=pb.P * k / steps)
        return state

    def unloaded(self) -> SlipState:
        """The bodies before any load: no contact, no traction, no slip."""
        pb = self.problem
        zero2, none = pb.zeros(2), pb.zeros() > 0.0
        return SlipState(np.zeros(2), zero2, pb.zeros(), copy(zero2), np.zeros(2), none, none)

    def equilibrium(
        self, prev: SlipState, delta: np.ndarray, warm: SlipState | None = None, load: float | None = None
    ) -> SlipState:
        """The state reached from ``prev`` when the rigid displacement becomes ``delta`` and the
        normal load ``load`` (grid units; default: coupled, the scene's; decoupled, the pressure
        of ``prev`` is kept; with ``load`` given the decoupled pressure is the frictionless one at it).

        ``warm`` (a nearby state, e.g. the previous Newton iterate) only seeds the iteration.
        """
        pb = self.problem
        p, t = (prev.p, prev.t) if warm is None else (warm.p, warm.t)
        if not self.coupled and load is not None:
            normal = pb.normal(None, load)
            self.count.pk += normal.iterations
            p = normal.traction[0, ...]
        shift = to_device(np.asarray(delta, dtype=np.float64)[:, None, None], pb.xp)
        c = 1.0 / pb.self_compliance
        p_change = math.inf
        for outer in range(1, self.MAX_OUTER + 1):  # noqa: B007 (the count is reported after the loop)
            b = shift - prev.s
            if self.coupled:
                b = b - pb.coupling_tangential(p)
            result = disc_qp(pb.op_t.apply, b, self.mu * p, t, self.tol, c, pb.norm_A, precondition=pb.precondition_t)
            self.count.qp += result.iterations
            self.count.residual = max(self.count.residual, result.residual)
            t = result.traction
            if not self.coupled or p_change <= self.outer_tol:
                break  # (coupled: this last slip solve used the settled pressure)
            normal = pb.normal(pb.coupling_normal(t), load)
            self.count.pk += normal.iterations
            p_new = normal.traction[0, ...]
            xp = pb.xp
            p_change = float(xp.sum(xp.abs(p_new - p))) / float(xp.sum(xp.abs(p_new)))
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
        xp = pb.xp
        stick = contact & (xp.hypot(t[0, ...], t[1, ...]) < bound * (1.0 - 1e-12))
        force = to_host(xp.sum(xp.reshape(t, (2, -1)), axis=1)) * pb.grid.cell_area
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

    def to_displacement(self, prev: SlipState, delta: np.ndarray, load: float | None = None) -> SlipState:
        state = self.equilibrium(prev, delta, load=load)
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
        any_stick = self.problem.xp.any
        K = self.tangent(prev) if continuing and bool(any_stick(prev.stick)) else self.K0
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
            if not bool(any_stick(state.stick)) or abs(np.linalg.det(K)) <= 1e-14 * np.linalg.det(self.K0):
                raise ConvergenceError(
                    "no stick cells left: the contact slides (grid too coarse for this q_ratio?)",
                    self.count.newton,
                    float(np.linalg.norm(residual)) / scale,
                )
            delta = delta + np.linalg.solve(K, residual)
            warm = state
        raise ConvergenceError(
            "force-controlled Newton iteration did not converge",
            self.MAX_NEWTON,
            float(np.linalg.norm(residual)) / scale,
        )


# ------------------------------------------------------------------------------------------
# load paths and the record
# ------------------------------------------------------------------------------------------
def rotation(angle_deg: float) -> np.ndarray:
    """2 × 2 rotation by ``angle_deg`` (counter-clockwise)."""
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
    """Normal contact, then the scene's tangential steps, in one coupling mode; ``proportional``
    path: the normal load and the tangential displacement grow together from the unloaded bodies
    in ``steps`` equal increments, friction acting throughout (one step: the single static
    problem of Rodríguez-Tembleque et al. 2011, §6.2, slip measured from the unloaded state). The
    first point is the frictionless normal contact at the full load (the record's no-slip
    reference) on every path."""
    scene = problem.scene
    solver = PathSolver(problem, coupled)
    theta = math.radians(scene.angle_deg - problem.hertz.angle_deg)
    n = np.array([math.cos(theta), math.sin(theta)])
    R = rotation(problem.hertz.angle_deg)
    L, Fu, Ku = problem.L, problem.force_unit, problem.stiffness_unit
    area = problem.grid.cell_area * L * L

    count = problem.xp.count_nonzero

    def point(branch: str, state: SlipState) -> PathPoint:
        K = state.K if scene.mu > 0.0 else np.zeros((2, 2))
        K_stick = solver.stick_tangent(state) if scene.mu > 0.0 else np.zeros((2, 2))
        return PathPoint(
            branch=branch,
            force=float(n @ state.force) * Fu,
            displacement=float(n @ state.delta) * L,
            stiffness=along(K, n) * Ku,
            stick_area=float(count(state.stick)) * area if scene.mu > 0.0 else 0.0,
            contact_area=float(count(state.contact)) * area,
            tensor=R @ K @ R.T * Ku,
            stick_stiffness=along(K_stick, n) * Ku,
        )

    state = solver.initial
    points = [point("initial", state)]
    if scene.mu > 0.0:
        proportional = scene.path == "proportional"
        if proportional:  # the reference point stays the frictionless contact at the full load
            state = solver.unloaded()
        for k, (branch, target) in enumerate(_targets(scene, scene.mu * scene.load), start=1):
            if scene.control == "force":
                state = solver.to_force(state, n * (target / Fu))
            else:
                load = problem.P * k / scene.steps if proportional else None
                state = solver.to_displacement(state, n * (target / L), load)
            points.append(point(branch, state))
    return PathResult(points, solver.count, state, solver.initial)
