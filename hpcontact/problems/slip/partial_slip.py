r"""Coulomb partial slip (Cattaneo–Mindlin) of two bodies on the non-periodic FFT operator.

``solve_slip(params)`` is the task behind ``hpcontact solve --quantities slip``: two bodies
(``hpcontact.problems.slip.bodies``) are pressed together by a normal load P, then loaded tangentially in
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

Either body may be a crystal (cubic, orthotropic or a general 6 × 6 stiffness, oriented;
``hpcontact.materials.elastic_constants``): the pair then acts through its interface compliance
H_pair(φ) = H_1(φ) + H_2(φ + π) (``hpcontact.problems.slip.crystal_pair``), with no closed-form Hertz or
Mindlin references in the record.

The programme and its solvers live in ``hpcontact.numerics.friction_qp``, the validated scene and the
discretized pair in ``hpcontact.problems.slip.problem``, the load steps in ``hpcontact.problems.slip.load_path``; this
module turns a scene into its record.

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
from collections.abc import Mapping
from typing import Any

import numpy as np

from hpcontact import analytic
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import to_host
from hpcontact.problems.slip.bodies import HertzEllipse
from hpcontact.problems.slip.load_path import PathResult, PathSolver, rotation, run_path
from hpcontact.problems.slip.problem import SlipProblem, SlipScene, validate

__all__ = ["solve_slip", "validate", "SlipProblem", "PathSolver"]


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
    """One partial-slip scene → the record of docs/design.md §4.1 for ``--quantities slip``.

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
    ``stick_radius`` (sqrt(stick_area/π)), ``stick_centroid_x stick_centroid_y`` (scene frame),
    ``hertz_a hertz_b contact_angle_deg``
    (analytic Hertz ellipse), ``normal_stiffness`` (Hertz dP/dd = 3P/(2d)),
    ``mindlin_no_slip_stiffness`` (Mindlin's bonded ellipse along the load), for circular
    contacts ``mindlin_stiffness`` and ``mindlin_displacement`` (Cattaneo–Mindlin /
    Mindlin–Deresiewicz closed forms at the same Q and path) and ``mindlin_stick_radius``;
    ``dundurs_beta`` and ``coupling_size`` (|β|; for crystal pairs only ``coupling_size``, and no
    Hertz/Mindlin closed forms: ``hertz_*`` is then the indentation-modulus estimate); for a dissimilar pair solved both ways the Goodman (decoupled) answers as
    ``decoupled_*`` and the relative differences ``coupling_effect_stiffness``,
    ``coupling_effect_displacement``, ``coupling_effect_stick_area`` (absent when the decoupled
    contact slides entirely: displacement control past its sliding limit); ``history`` (every step)
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
    record.update(_stick_centroid(problem, main))
    record["hertz_a"], record["hertz_b"] = hertz.a, hertz.b
    record["contact_angle_deg"] = hertz.angle_deg
    record["normal_stiffness"] = hertz.normal_stiffness
    if problem.anisotropic:  # no closed forms: Hertz and Mindlin need isotropic bodies
        record["coupling_size"] = pair.coupling_size
    else:
        record["dundurs_beta"] = pair.dundurs_beta
        record["coupling_size"] = abs(pair.dundurs_beta)
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
        if decoupled.last.stick_area > 0.0:  # else the decoupled contact slides: no relative change of 0
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


def _stick_centroid(problem: SlipProblem, path: PathResult) -> dict[str, float]:
    """Centroid of the stick zone at the path's end (scene frame, input length unit; 0 when the
    whole contact slides or mu = 0): off the contact centre for dissimilar pairs (Rodríguez-
    Tembleque et al. 2011, Fig. 6d) and for crystals without a symmetric frame."""
    stick = to_host(path.final.stick)
    if problem.scene.mu == 0.0 or not stick.any():
        return {"stick_centroid_x": 0.0, "stick_centroid_y": 0.0}
    local = np.array([problem.x[stick].mean(), problem.y[stick].mean()]) * problem.L
    x, y = rotation(problem.hertz.angle_deg) @ local
    return {"stick_centroid_x": float(x), "stick_centroid_y": float(y)}


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


def _pair_lines(problem: SlipProblem, coupling: str) -> list[str]:
    """The pair's coupling and moduli for the plan (crystal pairs: Barnett-Lothe kernels of each body)."""
    pair = problem.pair
    if problem.anisotropic:
        bodies = [
            "rigid" if b.material is None else getattr(b.material, "name", "") or type(b.material).__name__
            for b in (pair.body1, pair.body2)
        ]
        return [
            f"similar={pair.similar}",
            f"coupling_size={pair.coupling_size:.6g}",
            f"coupling={coupling}",
            f"bodies={bodies[0]} | {bodies[1]} (lab frame; interface H = H1(phi) + H2(phi + pi))",
            f"G_ref={problem.G_ref:.6g}",
            f"E_star_estimate={pair.E_star:.6g} (indentation moduli; grid sizing only)",
        ]
    return [
        f"similar={pair.similar}",
        f"dundurs_beta={pair.dundurs_beta:.6g}",
        f"coupling={coupling}",
        f"G_eq={pair.equivalent.G:.6g}",
        f"nu_eq={pair.equivalent.nu:.6g}",
        f"E_star={pair.E_star:.6g}",
    ]


def _plan(problem: SlipProblem, modes: list[bool], paths: Mapping[bool, PathResult]) -> dict[str, Any]:
    """What was built and run, the pair's coupling and the method (docs/design.md §1: only what is needed)."""
    scene, pair = problem.scene, problem.pair
    kernels = list(problem.engine.kernels)
    if True in modes:
        kernels += ["xz(pair)", "yz(pair)", "zx(pair)", "zy(pair)"]
    derived = []
    if problem.material is not None and problem.material.nu == 0.0:
        derived.append("yy = xx, xy = 0 (nu_eq = 0)")
    if pair.similar:
        derived.append(
            "no coupling blocks: elastically similar pair (coupling blocks of body 2 cancel body 1's, "
            "coupling_size < 1e-12)"
            if problem.anisotropic
            else "no coupling blocks: elastically similar pair ((1-2nu1)/G1 = (1-2nu2)/G2, beta = 0)"
        )
    solves = []
    for coupled in modes:
        c = paths[coupled].counters
        name = "coupled[panagiotopoulos: slip xy + polonsky_keer z]" if coupled else "decoupled[slip xy, p fixed]"
        solves.append(
            f"{name}: {len(paths[coupled].points) - 1} steps, {c.newton} newton, {c.qp} slip applications, "
            f"{c.cg} stick-tensor CG, {c.pk} polonsky_keer, {c.outer} normal-tangential passes"
        )
    coupling = (
        "none: elastically similar"
        if pair.similar
        else "coupled (Panagiotopoulos) and decoupled (Goodman)"
        if len(modes) == 2
        else "coupled (Panagiotopoulos)"
        if modes[0]
        else "decoupled (Goodman approximation)"
    )
    return {
        "kernels": kernels,
        "solves": ["normal_polonsky_keer[z]"] + solves,
        "derived": derived,
        "operator_applications": [],
        "pair": _pair_lines(problem, coupling),
        "method": [
            "normal load: Polonsky-Keer on the slip grid, applied "
            + (
                f"in {scene.steps} steps with friction (Spence), coupled path"
                if scene.normal_friction
                else f"with the tangential displacement in {scene.steps} proportional steps, friction acting"
                if scene.path == "proportional"
                else "without friction"
            ),
            "slip: semismooth Newton (primal-dual active set, linearized slip directions), PCG inner solves, "
            "MPRGP fallback",
            "tangent: consistent (stick cells stuck, slip cells slide along their traction); "
            "stick_area_stiffness: no-slip stiffness of the stick area",
            f"control={scene.control}",
            f"path={scene.path}",
        ],
    }
