r"""The discretized pair of a partial-slip scene: validated fields, contact grid, gap and operators.

``validate`` checks the fields of ``hpcontact solve --quantities slip``; ``SlipProblem`` puts the
pair on its contact grid (scaled units) and gives the operators the load steps need
(``hpcontact.problems.slip.load_path``) and the incremental stiffness tensor of a stick/slip state.

Normal contact: Polonsky–Keer under load control on the same grid (``solvers.polonsky_keer``);
the normal pressure for the Mindlin checks is therefore the *discrete* Hertz solution of the
grid, not the analytic one. The normal load is applied first without friction (the
reference state s = −A_tz p0, t = 0), or, with ``normal_friction``, in ``steps`` increments with
friction acting on the coupled path (Spence's problem for dissimilar pairs, Johnson 1985 §5.5;
``slip_path.PathSolver``).

Crystal bodies (``anisotropic_pair``, ``elastic_constants``): a pair with a crystal is solved on
the pair's interface compliance (``PairEngine``: all tangential blocks, the coupling blocks when
they do not cancel), its stiffnesses turned from the lab into the grid's frame (x along the
contact ellipse's major axis, at ``hertz.angle_deg`` from lab x); the Hertz ellipse that sizes the grid uses the indentation-modulus estimate
of E* and the grid grows by sqrt(max/min H_zz) so that a non-elliptical contact fits.

Device (``device``: "cpu", "gpu" or "auto", ``hpcontact.numerics.backend``): the operators,
preconditioners and every array of the load steps live in the array namespace of the scene's
device (numpy with pyFFTW on the CPU, CuPy with cuFFT on a GPU); the kernel spectra, the gap and
the preconditioners' symbols are built on the host and copied to the device once, here. Inside
the solves only scalars reach the host (inner products, norms, resultant forces, whether a set
is empty).

Units: lengths are scaled by the Hertz semi-axis a and stresses by G_eq (G_ref for a crystal
pair) inside.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from hpcontact.errors import ConvergenceError, InputError
from hpcontact.fields import DEVICES, SLIP, field, names
from hpcontact.geometry import Grid
from hpcontact.kernels.engine import Engine
from hpcontact.kernels.isotropic import isotropic_surface_green
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import Array, array_namespace, copy, dot, is_numpy, namespace, norm, to_device, to_host
from hpcontact.numerics.conjugate_gradient import Solution, polonsky_keer
from hpcontact.numerics.convolution import ArrayConvolutionOperator, ConvolutionOperator, cached_spectrum
from hpcontact.numerics.friction_qp import Operator
from hpcontact.numerics.preconditioner import FourierPreconditioner
from hpcontact.problems.slip.bodies import HertzEllipse, Pair
from hpcontact.problems.slip.crystal_pair import AnisotropicPair, PairCompliance, PairEngine, pair_from_params

#: The fields of a slip scene (``hpcontact.fields``: those of kind slip).
FIELDS = names(SLIP)
#: Fields of the generic ``hpcontact solve`` parser that a slip scene does not use: the contact
#: shape follows from the bodies. Accepted (so the CLI may pass its defaults) and ignored.
IGNORED = ("shape",)
#: The fields a slip scene cannot do without (the first missing is the error's field).
REQUIRED = ("radius", "load", "mu", "q_ratio")
CONTROLS = ("force", "displacement")
PATHS = ("load", "loop", "proportional")
COUPLINGS = ("auto", "both", "coupled", "decoupled")
GRID_MARGIN = 1.1  # the grid spans ±1.1 Hertz semi-axes: contact growth under coupling fits
MIN_CELLS_ACROSS = 16


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
    normal_friction: bool
    coupling: str
    threads: int
    precondition: bool
    device: str


def _flag(name: str, value: Any) -> bool:
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, str) and value.strip().lower() in ("true", "false", "1", "0", "yes", "no"):
        return value.strip().lower() in ("true", "1", "yes")
    if isinstance(value, (int, np.integer)) and value in (0, 1):
        return bool(value)
    raise InputError(name, "true or false", value)


def _checked(p: Mapping[str, Any], name: str) -> Any:
    """``p[name]`` (the field's default where absent) checked as ``hpcontact.fields`` declares
    the field for a slip scene: its type, range and message (``Field.check``)."""
    declared = field(name, SLIP)
    return declared.check(p.get(name, declared.default))


def validate(params: Mapping[str, Any]) -> SlipScene:
    """Check the fields of a slip scene; ``InputError(field, allowed, value)`` on the first bad one.

    Required: ``radius`` (> 0), ``load`` (> 0), ``mu`` (≥ 0), ``q_ratio`` (0 ≤ Q/(mu P) < 1).
    Optional: ``radius_b radius2 radius2_b body2_angle`` (geometry, see ``bodies``),
    ``material material2`` (names; "crystal:NAME" for a library crystal) or ``E G nu E2 G2 nu2``;
    crystals by the fields of ``elastic_constants`` (``anisotropy cubic orthotropic voigt
    orientation miller azimuth`` and the same with suffix 2; GPa); ``angle`` (load direction, degrees
    from the scene's x axis, default 0); ``n`` (cells across the contact's major axis, 8–4096,
    default 64); ``tol`` (1e-14–1e-4, default 1e-8); ``steps`` (load steps to Q, 1–1000,
    default 10); ``control`` (force | displacement); ``displacement`` (final tangential
    displacement, required with control = displacement); ``path`` (load | loop | proportional:
    normal load and tangential displacement applied together, control = displacement);
    ``tensor`` and ``history`` (booleans: add the 2 × 2 tensor / the whole curve);
    ``coupling`` (auto | both | coupled | decoupled; auto = both for a dissimilar pair);
    ``threads``; ``precondition``; ``normal_friction`` (boolean: Spence's normal loading);
    ``device`` (cpu | gpu | auto, default cpu: where the solves run).
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
    missing = [name for name in REQUIRED if name not in p]
    if missing:
        first = field(missing[0], SLIP)
        also = f"; also missing: {', '.join(missing[1:])}" if missing[1:] else ""
        raise InputError(missing[0], f"required for a slip scene: {first.message or first.long_name}{also}", None)
    load = _checked(p, "load")
    # mu below 1e-6: the tangential load q mu P falls under the solver's resolution (smaller mu
    # stopped unconverged or silently gave the bonded state: docs/validation.md §"Partial slip")
    mu_field = field("mu", SLIP)
    mu = mu_field.check(p["mu"])
    if mu < 0.0 or 0.0 < mu < 1e-6:
        raise InputError("mu", mu_field.message, p["mu"])
    q_ratio = _checked(p, "q_ratio")
    pair = pair_from_params(p)
    angle = _checked(p, "angle")
    n = _checked(p, "n")
    tol = _checked(p, "tol")
    steps = _checked(p, "steps")
    control = p.get("control", "force")
    if control not in CONTROLS:
        raise InputError("control", f"one of {', '.join(CONTROLS)}", control)
    displacement = None
    if control == "displacement":
        if "displacement" not in p:
            raise InputError("displacement", "the final tangential displacement (control = displacement)", None)
        displacement = _checked(p, "displacement")
    elif "displacement" in p:
        raise InputError("displacement", "only with control = displacement", p["displacement"])
    path = p.get("path", "load")
    if path not in PATHS:
        raise InputError("path", f"one of {', '.join(PATHS)}", path)
    if path == "loop" and control != "force":
        raise InputError("path", "loop needs control = force (it reverses at +-q_ratio mu P)", path)
    if path == "proportional" and control != "displacement":
        raise InputError(
            "path", "proportional needs control = displacement (normal load and displacement ramp together)", path
        )
    normal_friction = _flag("normal_friction", p.get("normal_friction", False))
    if path == "proportional" and normal_friction:
        raise InputError(
            "normal_friction", "false with path = proportional (its normal load already meets friction)", True
        )
    coupling = p.get("coupling", "auto")
    if coupling not in COUPLINGS:
        raise InputError("coupling", f"one of {', '.join(COUPLINGS)}", coupling)
    threads = _checked(p, "threads")
    device = p.get("device", "cpu")
    if device not in DEVICES:
        raise InputError("device", f"one of {', '.join(DEVICES)}", device)
    return SlipScene(
        pair=pair,
        load=load,
        mu=mu,
        q_ratio=q_ratio,
        angle_deg=angle,
        n=n,
        tol=tol,
        steps=steps,
        control=control,
        displacement=displacement,
        path=path,
        tensor=_flag("tensor", p.get("tensor", False)),
        history=_flag("history", p.get("history", False)),
        normal_friction=normal_friction,
        coupling=coupling,
        threads=threads,
        precondition=_flag("precondition", p.get("precondition", True)),
        device=device,
    )


class SlipProblem:
    """The pair on its contact grid: scaled units, gap, operators, Hertz reference.

    Inside, lengths are in units of the Hertz semi-major axis ``L = hertz.a`` and stresses in
    units of ``G_eq`` (the equivalent body of ``Pair.equivalent``); the grid's x axis is the
    major axis of the contact ellipse (scene angle ``hertz.angle_deg``). ``n`` cells span the
    major diameter 2a (square cells unless fewer than 16 would span the minor one). The operators
    act on arrays of ``xp``, the namespace of the scene's device (``backend.array_namespace``:
    ``InputError`` naming what a GPU lacks); ``gap``, ``x`` and ``y`` stay on the host.
    """

    def __init__(self, scene: SlipScene) -> None:
        self.scene = scene
        self.xp = xp = array_namespace(scene.device)
        pair = scene.pair
        self.pair = pair
        self.hertz: HertzEllipse = pair.hertz(scene.load)
        self.L = self.hertz.a
        self.anisotropic = isinstance(pair, AnisotropicPair)
        self._green_memo: tuple[bytes, np.ndarray] | None = None
        if self.anisotropic:
            self.G_ref = pair.reference_modulus
            self.compliance = pair.scaled(self.G_ref, self.hertz.angle_deg)  # crystals in the grid frame
            self.material: Isotropic | None = None
        else:
            self.G_ref = pair.equivalent.G
            self.compliance = PairCompliance(
                *(
                    None if b.material is None else Isotropic(b.material.G / self.G_ref, b.material.nu)
                    for b in (pair.body1, pair.body2)
                )
            )
            self.material = Isotropic(G=1.0, nu=pair.equivalent.nu)
        aspect = self.hertz.aspect
        dx = 2.0 / scene.n
        across = scene.n * aspect
        dy = dx if across >= MIN_CELLS_ACROSS else 2.0 * aspect / MIN_CELLS_ACROSS
        margin = GRID_MARGIN * self._anisotropy_margin()
        nx = 2 * math.ceil(margin / dx)
        ny = 2 * math.ceil(margin * aspect / dy)
        self.grid = Grid(nx, ny, dx, dy)
        x, y = self.grid.centres()
        self.x, self.y = x, y
        A, B = self.hertz.A * self.L, self.hertz.B * self.L  # dimensionless gap coefficients
        self.gap = A * x * x + B * y * y
        self._gap = to_device(self.gap, xp)
        self.P = scene.load / (self.G_ref * self.L * self.L)
        if self.material is None:
            kernels = ("xx", "xy", "yx", "yy", "zz")
            self.engine: Engine = PairEngine(self.compliance, self.grid, kernels, scene.threads, xp)
        else:
            tangential = ("xx",) if self.material.nu == 0.0 else ("xx", "xy", "yx", "yy")
            self.engine = Engine(self.material, self.grid, tangential + ("zz",), scene.threads, xp)
        self.op_t = self.engine.operator("xy")
        self.op_z = self.engine.operator("z")
        self.precondition_t = (
            FourierPreconditioner(self.grid, self.surface_green, "xy", xp).apply if scene.precondition else None
        )
        self.norm_A = self._operator_norm()
        impulse = self.zeros(2)
        impulse[0, nx // 2, ny // 2] = 1.0
        self.self_compliance = float(self.op_t.apply(impulse)[0, nx // 2, ny // 2])
        self._op_c: ConvolutionOperator | ArrayConvolutionOperator | None = None
        self._coupling_spectra: dict[str, np.ndarray] = {}
        self._op_full: ConvolutionOperator | ArrayConvolutionOperator | None = None
        self._precondition_full: Operator | None = None

    def _anisotropy_margin(self) -> float:
        """Extra grid span for a crystal pair: sqrt(max/min of H_zz over directions) (1 when
        isotropic). A heuristic: the contact is not the Hertz ellipse of the indentation-modulus
        estimate, and a larger grid only costs time (the non-periodic solution does not change)."""
        if not self.anisotropic:
            return 1.0
        phi = np.arange(64) * (np.pi / 64)
        hzz = self.compliance.fourier(phi)[:, 2, 2].real
        return float(math.sqrt(hzz.max() / hzz.min()))

    def surface_green(self, phi: np.ndarray) -> np.ndarray:
        """H(m) of the pair (grid units, for the preconditioner): ``PairCompliance.fourier`` for a
        crystal pair; else the equivalent body's tangential and normal blocks, coupling ±i c m/2
        with c = G_eq[(1−2nu1)/G1 − (1−2nu2)/G2]."""
        if self.material is None:
            # the Barnett-Lothe sums dominate a crystal scene's set-up: the tangential and the
            # coupled preconditioner ask for the same directions, evaluated once
            key = np.asarray(phi, dtype=np.float64).tobytes()
            if self._green_memo is None or self._green_memo[0] != key:
                self._green_memo = (key, self.compliance.fourier(phi))
            return self._green_memo[1].copy()
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

    def _operator(self, spectra: Mapping[str, np.ndarray]) -> ConvolutionOperator | ArrayConvolutionOperator:
        """The convolution operator on "xyz" with the host ``spectra``, on the scene's device."""
        g = self.grid
        if is_numpy(self.xp):
            return ConvolutionOperator(g.nx, g.ny, "xyz", spectra, threads=self.scene.threads)
        return ArrayConvolutionOperator(g.nx, g.ny, "xyz", spectra, self.xp)

    def zeros(self, *leading: int) -> Array:
        """float64 zeros of shape ``(*leading, nx, ny)`` on the scene's device."""
        return self.xp.zeros(leading + self.gap.shape, dtype=self.xp.float64)

    @property
    def coupling_spectra(self) -> dict[str, np.ndarray]:
        """The host spectra of the pair's coupling blocks xz yz zx zy (``PairCompliance.blocks``;
        body 1's minus body 2's for isotropic bodies), built once."""
        if not self._coupling_spectra:
            g = self.grid
            names = ("xz", "yz", "zx", "zy")
            built: dict[str, np.ndarray] = {}

            def build(block: str) -> np.ndarray:
                if not built:  # all four in one pass (a crystal's cells share their work)
                    built.update(self.compliance.blocks(g.nx, g.ny, g.dx, g.dy, names, self.scene.threads))
                return built[block]

            for block in names:
                key = ("pair-coupling",) + self.compliance.key + (g.nx, g.ny, g.dx, g.dy, block)
                spectrum = cached_spectrum(key, lambda block=block: build(block), self.engine.fft_shape)
                self._coupling_spectra[block] = spectrum
        return self._coupling_spectra

    @property
    def coupling_operator(self) -> ConvolutionOperator | ArrayConvolutionOperator:
        """(t_x, t_y, p) ↦ (A_xz p, A_yz p, A_zx t_x + A_zy t_y): the coupling blocks of the pair
        (``coupling_spectra``) on the scene's device."""
        if self._op_c is None:
            self._op_c = self._operator(self.coupling_spectra)
        return self._op_c

    def coupling_tangential(self, p: Array) -> Array:
        """A_tz p: relative tangential displacement (2, nx, ny) caused by the pressure (nx, ny)."""
        field3 = self.zeros(3)
        field3[2, ...] = p
        return self.coupling_operator.apply(field3)[:2, ...]

    def coupling_normal(self, t: Array) -> Array:
        """A_zt t: relative normal displacement (nx, ny) caused by the tangential traction."""
        field3 = self.zeros(3)
        field3[:2, ...] = t
        return self.coupling_operator.apply(field3)[2, ...]

    def normal(self, extra_gap: Array | None = None, load: float | None = None) -> Solution:
        """Polonsky–Keer at the load P (or ``load``, grid units) on the gap (plus ``extra_gap``);
        raises if the contact reaches the grid edge."""
        gap = self._gap if extra_gap is None else self._gap + extra_gap
        solution = polonsky_keer(
            self.op_z.apply,
            gap,
            tol=min(self.scene.tol, 1e-10),
            load=self.P if load is None else load,
            cell_area=self.grid.cell_area,
        )
        contact = solution.traction[0, ...] > 0.0
        xp = self.xp
        edges = (contact[0, :], contact[-1, :], contact[:, 0], contact[:, -1])
        if any(bool(xp.any(edge)) for edge in edges):
            raise FloatingPointError("the contact reaches the edge of the slip grid")
        return solution

    @property
    def full_operator(self) -> ConvolutionOperator | ArrayConvolutionOperator:
        """The coupled 3-component operator of the pair (xx xy yx yy zz and the coupling blocks)."""
        if self._op_full is None:
            spectra = {}
            for a in "xyz":
                for c in "xyz":
                    block = a + c
                    if block in ("xz", "yz", "zx", "zy"):
                        spectra[block] = self.coupling_spectra[block]
                    else:
                        try:
                            spectra[block] = self.engine.spectrum(block)
                        except KeyError:
                            continue
            self._op_full = self._operator(spectra)
            if self.scene.precondition:
                self._precondition_full = FourierPreconditioner(self.grid, self.surface_green, "xyz", self.xp).apply
        return self._op_full

    def tangent_tensor(
        self, stick: Array, slip_direction: Array | None, contact: Array, coupled: bool
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
        term, ~2e-4 of k_t even for β = 0.29: docs/validation.md §"Partial slip"). The masks and
        directions are arrays of the scene's device; K comes back to the host (one column a solve).
        """
        xp = self.xp
        if not bool(xp.any(stick)) and slip_direction is None:
            return np.zeros((2, 2)), 0
        tau = None
        if slip_direction is not None:
            tau = xp.stack([-slip_direction[1, ...], slip_direction[0, ...]])
        slip = contact & ~stick if slip_direction is not None else xp.zeros_like(stick)
        if coupled:
            op, pc, comps = self.full_operator, self._precondition_full, 3
        else:
            op, pc, comps = self.op_t, self.precondition_t, 2

        def restrict(v: Array) -> Array:
            out = xp.zeros_like(v)
            out[:2, ...] = xp.where(stick, v[:2, ...], 0.0)
            if tau is not None:
                along = v[0, ...] * tau[0, ...] + v[1, ...] * tau[1, ...]
                out[:2, ...] += xp.where(slip, along * tau, 0.0)
            if comps == 3:
                out[2, ...] = xp.where(contact, v[2, ...], 0.0)
            return out

        K = np.zeros((comps, comps))
        iterations = 0
        for j in range(comps):
            rhs = self.zeros(comps)
            rhs[j, ...] = 1.0
            x, its = _pcg(op.apply, restrict(rhs), restrict, pc, self.scene.tol)
            iterations += its
            K[:, j] = to_host(xp.sum(xp.reshape(x, (comps, -1)), axis=1)) * self.grid.cell_area
        if comps == 3:
            K = K[:2, :2] - np.outer(K[:2, 2], K[2, :2]) / K[2, 2]
        return K, iterations


def _pcg(
    apply: Operator,
    rhs: Array,
    restrict: Operator,
    precondition: Operator | None,
    tol: float,
    maxiter: int = 5000,
) -> tuple[Array, int]:
    """Solve Π A Π x = Π b for x = Π x by preconditioned CG (Π a symmetric projection)."""
    xp = namespace(rhs)
    b = restrict(rhs)
    b_norm = norm(b)
    x = xp.zeros_like(b)
    if b_norm == 0.0:
        return x, 0
    r = copy(b)
    z = restrict(precondition(r)) if precondition is not None else r
    p = copy(z)
    rz = dot(r, z)
    residual = 1.0
    for iteration in range(1, maxiter + 1):
        q = restrict(apply(p))
        curvature = dot(p, q)
        if not curvature > 0.0:
            raise ConvergenceError("tangent operator is not positive definite", iteration, residual)
        alpha = rz / curvature
        x += alpha * p
        r -= alpha * q
        residual = norm(r) / b_norm
        if residual <= tol:
            return x, iteration
        z = restrict(precondition(r)) if precondition is not None else r
        rz_new = dot(r, z)
        p = z + (rz_new / rz) * p
        rz = rz_new
    raise ConvergenceError(f"tangent CG did not reach tol={tol:g}", maxiter, residual)
