"""Round-off bounds from analysis (issue 39): conditioning × unit round-off, not a measurement.

Shared by the tests whose bounds are round-off: tests/test_conventions.py (shortcuts against
the general path), tests/problems/test_crystal_indentation.py (b/a = 1 on [001]) and
tests/discretizations/test_strip_cells.py (the Galerkin integrals). Every bound here is a
first-order a-priori bound (terms of order u² dropped) built from

- u = 2⁻⁵³, the unit round-off, and γ_n = n u/(1 − n u), the bound on the relative error of a
  sum of n + 1 terms of one sign, or of a dot product of length n (Higham, *Accuracy and
  Stability of Numerical Algorithms*, 2nd ed., 2002, §3.1);
- ε_F = 7 log₂(M) u, the normwise relative error of a 2-D FFT of M points (Higham, Thm 24.2:
  log₂(M) η with η = μ + γ₄(√2 + μ) ≤ 7u for twiddle factors accurate to μ ≤ u), taken for
  FFTW's and numpy's transforms;
- properties of the problem computed here: the extreme eigenvalues λ_min, λ_max of the matrix A
  a solve inverts (a principal block, on the contact mask, of the half-space compliance:
  symmetric positive definite), the norm ‖C‖ of the circulant the FFT applies (the largest
  eigenvalue of the kernel's block symbol over all frequencies; A is a principal block of C, so
  ‖A‖ ≤ ‖C‖), the kernels themselves (so that a difference between two code paths' kernels
  enters as the number it is, not as a guess).

No bound here is a measured error times a margin; the few inputs that are tested accuracies of
another part of the code say so where they are used.

Conjugate gradients (``hpcontact.numerics.conjugate_gradient``) on A t = b, b the unit
displacement of one component on the N cells (‖b‖ = √N), stops when the recursive residual
‖r‖ ≤ τ‖b‖ (τ the scene's tol). An entry of the stiffness is K_ij = dA b_iᵀ t_j. Three errors:

1. Stopping. The true residual r_j = b_j − A t̃_j gives δK_ij = dA b_iᵀ A⁻¹ r_j, so
   |δK_ij| ≤ dA ‖A⁻¹b_i‖ ‖r_j‖. With z = A⁻¹b_i, ‖z‖ ‖Az‖/(zᵀAz) ≤ ρ(κ) = (κ + 1)/(2√κ),
   κ = λ_max/λ_min (Kantorovich: the cosine of z and Az), and K_ii = dA zᵀAz:
   |δK_ij| ≤ ρ(κ) K_ii ‖r_j‖/‖b‖.
2. The residual gap (attainable accuracy: Greenbaum, SIAM J. Matrix Anal. Appl. 18 (1997)
   535–551). The recursive residual drifts from b − A t̃ by what each iteration rounds: the
   product A p (≤ ε_mv ‖C‖ ‖p‖, ε_mv = 2ε_F + ((c + 2)√c + 1)u for c components: forward and
   inverse FFT, the c × c product per frequency, the 1/M scale) and the two vector updates
   (≤ 7u ‖C‖ X together). PCG's A-norm error falls monotonically from ‖t*‖_A, so every
   iterate and every step is within 2X of the origin, X = ‖t*‖_A/√λ_min, ‖t*‖_A² = K_jj/dA:
   ‖b − A t̃ − r‖ ≤ k (2ε_mv + 7u) ‖C‖ X after k iterations. ‖r_j‖/‖b‖ ≤ τ + that/√N.
3. The operator. The spectrum the FFT multiplies by is rfft2 of the kernel, off by at most
   ε_F √M ‖g‖₂ (Parseval) at any frequency; an operator perturbation δA changes K_ij by
   dA t_iᵀ δA t_j ≤ ‖δA‖ sqrt(K_ii K_jj)/λ_min (dA ‖t‖² ≤ K/λ_min). A difference between the
   kernels of two paths enters the same way, ‖ΔĜ(ω)‖ ≤ the ℓ¹ norms of the kernel differences
   (``kernel_gap``), and to second order (‖ΔA‖/λ_min)² K.

The resultant Σ t dA is a numpy sum (pairwise: ``pairwise_gamma``) of terms whose absolute
sum is ≤ dA √N ‖t‖ ≤ ρ K. Relative to the largest K of a record (``scale``) every entry is then
within ``cg_entry_error``.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.sparse.linalg import LinearOperator, eigsh, lobpcg

from hpcontact.geometry import Grid
from hpcontact.kernels.engine import Engine, block_name
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.preconditioner import FourierPreconditioner
from hpcontact.plan import make_plan
from hpcontact.problems.contact import _indentation, discretize
from hpcontact.scene import Scene

#: Unit round-off of float64.
U = 2.0**-53
#: Every block name a scene's operators can use (an Engine built with all of them).
ALL_BLOCKS = ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz", "Re xy", "Re xz", "Re yz")
#: Largest c · N solved densely (eigvalsh); larger masks use Lanczos and LOBPCG.
DENSE_LIMIT = 3000


def gamma(n: int) -> float:
    """γ_n = n u/(1 − n u) (Higham §3.1)."""
    return n * U / (1.0 - n * U)


def pairwise_gamma(n: int) -> float:
    """Bound on the relative error of numpy's sum of n terms of one sign (the sum of |terms|
    for mixed signs): numpy sums blocks of ≤ 128 in 8 interleaved partial sums (≤ 15 additions
    each, 3 levels to join them, ≤ 7 for a remainder) and halves longer arrays recursively
    (``pairwise_sum`` in numpy's loops), so every term passes through at most
    25 + ⌈log₂(n/128)⌉ additions."""
    depth = 25 + max(0, math.ceil(math.log2(max(n, 1) / 128.0)))
    return gamma(min(depth, max(n - 1, 1)))


def fft_error(shape: Iterable[int]) -> float:
    """ε_F = 7 log₂(M) u for an FFT of M = prod(shape) points (module docstring)."""
    return 7.0 * math.log2(math.prod(shape)) * U


def kantorovich(kappa: float) -> float:
    """ρ(κ) = (κ + 1)/(2√κ) ≥ ‖z‖ ‖Az‖/(zᵀAz) for SPD A of condition κ."""
    return (kappa + 1.0) / (2.0 * math.sqrt(kappa))


@dataclass(frozen=True)
class MaskOperator:
    """A solve's matrix A on its mask: extreme eigenvalues, ‖C‖, the spectrum's rounding."""

    components: str
    green: str
    cells: int
    cell_area: float
    lam_min: float
    lam_max: float
    norm: float  # ‖C‖ ≥ ‖A‖
    spectrum_error: float  # ≥ ‖δĜ(ω)‖₂ at every ω (rfft2 of the kernel, ε_F √M ‖g‖₂ per block)
    fft_size: int

    @property
    def kappa(self) -> float:
        return self.lam_max / self.lam_min

    @property
    def rho(self) -> float:
        return kantorovich(self.kappa)

    @property
    def matvec_error(self) -> float:
        """ε_mv: one application is A p + e, ‖e‖ ≤ ε_mv ‖C‖ ‖p‖."""
        c = len(self.components)
        return 2.0 * fft_error((self.fft_size,)) + ((c + 2) * math.sqrt(c) + 1.0) * U


def _blocks(engine: Engine, components: str, green: str) -> dict[tuple[str, str], np.ndarray]:
    """The centred kernel arrays of the blocks the operator (components, green) applies."""
    op = engine.operator(components, green)
    out = {}
    for i, a in enumerate(components):
        for j, b in enumerate(components):
            if op.pairs[i][j] is not None:
                out[a, b] = engine.centred_block(block_name(a, b, green))
    return out


def _symbol_norm(engine: Engine, components: str, green: str) -> float:
    """‖C‖: the largest |eigenvalue| of the c × c symbol over the frequencies (Hermitian there)."""
    op = engine.operator(components, green)
    c = len(components)
    first = next(s for row in op.pairs for s in row if s is not None)
    symbol = np.zeros(first.shape + (c, c), dtype=complex)
    for i in range(c):
        for j in range(c):
            if op.pairs[i][j] is not None:
                symbol[..., i, j] = op.pairs[i][j]
    symbol = 0.5 * (symbol + np.conj(np.swapaxes(symbol, -1, -2)))
    return float(np.max(np.abs(np.linalg.eigvalsh(symbol))))


def _dense(blocks: Mapping[tuple[str, str], np.ndarray], mask: np.ndarray, components: str) -> np.ndarray:
    """A on the mask, entry by entry from the centred kernels (offset target − source)."""
    idx = np.argwhere(mask)
    nx, ny = mask.shape
    di = idx[:, 0][:, None] - idx[:, 0][None, :] + nx - 1
    dj = idx[:, 1][:, None] - idx[:, 1][None, :] + ny - 1
    n, c = len(idx), len(components)
    A = np.zeros((c * n, c * n))
    for (a, b), g in blocks.items():
        i, j = components.index(a), components.index(b)
        A[i * n : (i + 1) * n, j * n : (j + 1) * n] = g[di, dj]
    return A


def _extreme_eigenvalues(engine: Engine, mask: np.ndarray, components: str, green: str) -> tuple[float, float]:
    """λ_min, λ_max of A: dense up to ``DENSE_LIMIT`` unknowns; else λ_max by Lanczos and λ_min
    by LOBPCG with the solver's own Fourier preconditioner, as θ − ‖Av − θv‖ (the Ritz value less
    its residual: an eigenvalue lies within the residual of θ, and the preconditioned iteration
    converges to the bottom of the spectrum)."""
    c, n = len(components), int(mask.sum())
    if c * n <= DENSE_LIMIT:
        A = _dense(_blocks(engine, components, green), mask, components)
        values = np.linalg.eigvalsh(0.5 * (A + A.T))
        return float(values[0]), float(values[-1])
    op = engine.operator(components, green)
    pre = FourierPreconditioner(engine.grid, engine.green_function(green), components)
    field = np.zeros((c,) + mask.shape)

    def restrict(apply):
        def matmat(v: np.ndarray) -> np.ndarray:
            v = np.asarray(v, dtype=float).reshape(c * n, -1)
            out = np.empty_like(v)
            for k in range(v.shape[1]):
                field[:, mask] = v[:, k].reshape(c, n)
                out[:, k] = apply(field)[:, mask].reshape(-1)
            return out

        return LinearOperator((c * n, c * n), matvec=matmat, matmat=matmat, dtype=float)

    A = restrict(op.apply)
    lam_max = float(eigsh(A, k=1, which="LA", tol=1e-6, return_eigenvectors=False)[0])
    start = np.random.default_rng(0).standard_normal((c * n, 2))
    with warnings.catch_warnings():  # its accuracy is the residual taken below, not lobpcg's tol
        warnings.simplefilter("ignore", UserWarning)
        values, vectors = lobpcg(A, start, M=restrict(pre.apply), largest=False, tol=1e-12, maxiter=40)
    k = int(np.argmin(values))
    v = vectors[:, k] / np.linalg.norm(vectors[:, k])
    residual = float(np.linalg.norm(A.matvec(v).ravel() - values[k] * v))
    return float(values[k]) - residual, lam_max


def mask_operator(engine: Engine, mask: np.ndarray, components: str, green: str) -> MaskOperator:
    """The ``MaskOperator`` of ``engine.operator(components, green)`` on ``mask``."""
    lam_min, lam_max = _extreme_eigenvalues(engine, mask, components, green)
    assert lam_min > 0.0, (components, green, lam_min)
    M = math.prod(engine.fft_shape)
    spread = math.sqrt(sum(float(np.sum(g * g)) for g in _blocks(engine, components, green).values()))
    return MaskOperator(
        components=components,
        green=green,
        cells=int(mask.sum()),
        cell_area=engine.grid.cell_area,
        lam_min=lam_min,
        lam_max=lam_max,
        norm=_symbol_norm(engine, components, green),
        spectrum_error=fft_error(engine.fft_shape) * math.sqrt(M) * spread,
        fft_size=M,
    )


@dataclass(frozen=True)
class SceneOperators:
    """What ``hpcontact.problems.contact.solve`` builds for a punch scene, with every solve's
    ``MaskOperator`` (by solve name) and the compliance proxy's (``proxy``, if asked)."""

    grid: Grid
    mask: np.ndarray
    solves: dict[str, MaskOperator]
    proxy: MaskOperator | None
    blocks: dict[str, np.ndarray]  # every block of ``ALL_BLOCKS``, centred


def scene_operators(scene: Scene) -> SceneOperators:
    """Grid, mask and operators exactly as ``solve`` builds them (discretize, make_plan, Engine)."""
    grid, mask = discretize(scene)
    plan = make_plan(scene, mask, grid)
    engine = Engine(scene.material, grid, plan.kernels)
    built: dict[tuple[str, str], MaskOperator] = {}
    for s in plan.solves:
        if (s.components, s.green) not in built:
            built[s.components, s.green] = mask_operator(engine, mask, s.components, s.green)
    solves = {s.name: built[s.components, s.green] for s in plan.solves}
    proxy = None
    if "compliance" in scene.quantities:
        components = "xy" if {"xy", "Re xy"} & set(engine.kernels) else "x"
        green = "H" if isinstance(scene.material, Isotropic) else "Re H"
        proxy = mask_operator(engine, mask, components, green)
    everything = Engine(scene.material, grid, ALL_BLOCKS)
    blocks = {name: everything.centred_block(name) for name in ALL_BLOCKS}
    return SceneOperators(grid, mask, solves, proxy, blocks)


def cg_entry_error(operators: Iterable[MaskOperator], scale: float, tol: float, iterations: int) -> float:
    """Bound on |δK_ij| (absolute) for every stiffness entry of a record whose solves use
    ``operators``, with ``scale`` ≥ every diagonal K of the record and ``iterations`` ≥ the
    iterations of each solve (the record's total): module docstring, items 1–3 without a path
    difference, as a fraction of ``scale``:

        ρ(κ) [τ + k (2ε_mv + 7u) ‖C‖ √(scale/(dA N λ_min)) + γ_pairwise] + ε_spectrum/λ_min.
    """
    worst = 0.0
    for op in operators:
        reach = op.norm * math.sqrt(scale / (op.cell_area * op.cells * op.lam_min))
        drift = iterations * (2.0 * op.matvec_error + 7.0 * U) * reach
        worst = max(worst, op.rho * (tol + drift + pairwise_gamma(op.cells)) + op.spectrum_error / op.lam_min)
    return worst * scale


def kernel_gap(terms: Iterable[tuple[float, Mapping[str, np.ndarray]]], components: str, green: str) -> float:
    """≥ ‖ΔĜ(ω)‖₂ at every ω for ΔA = Σ w_k A_k, the A_k the (components, green) operators of
    centred block arrays (``SceneOperators.blocks``, ``turned``) and ``terms`` the (w_k, blocks_k):
    the spectral norm of the c × c symbol difference is ≤ its Frobenius norm, and each entry
    |ΔĜ_ab(ω)| ≤ ‖Δg_ab‖₁ (the DFT of a finite array is bounded by its ℓ¹ norm)."""
    terms = list(terms)
    total = 0.0
    for a in components:
        for b in components:
            name = block_name(a, b, green)
            total += float(np.abs(sum(w * blocks[name] for w, blocks in terms)).sum()) ** 2
    return math.sqrt(total)


def path_gap(terms: Iterable[tuple[float, SceneOperators]], general: SceneOperators) -> tuple[float, float]:
    """``kernel_gap`` of Σ w_k A_k for the operators of the ``general`` path's solves (the largest)
    and for its compliance proxy's (0 if none): the shortcut's kernels, embedded in the general
    path's components (a kernel the shortcut does not use is what its engine builds for it:
    zero coupling at nu = 0.5, xx = yy at nu = 0, Re xz = 0 for an isotropic body)."""
    blocks = [(w, ops.blocks) for w, ops in terms]
    solves = max(kernel_gap(blocks, op.components, op.green) for op in general.solves.values())
    proxy = 0.0 if general.proxy is None else kernel_gap(blocks, general.proxy.components, general.proxy.green)
    return solves, proxy


def lam_min(*operators: SceneOperators) -> float:
    """The smallest λ_min of the solves of the given scenes."""
    return min(op.lam_min for ops in operators for op in ops.solves.values())


def turned(blocks: Mapping[str, np.ndarray], Q: np.ndarray) -> dict[str, np.ndarray]:
    """The kernel of the body turned (or mirrored) by the orthogonal Q (3 × 3, z fixed) on a
    square grid: g'_ab(o) = Σ Q_aa' Q_bb' g_a'b'(Q⁻¹ o) for the H blocks, and the Re blocks
    (g'_ab + g'_ba)/2 from them. Q's in-plane part must map the offset grid to itself (a quarter
    turn or the x ↔ y mirror)."""
    Q = np.asarray(Q, dtype=float)
    m = next(iter(blocks.values())).shape[0]
    c = (m - 1) // 2
    X, Y = np.meshgrid(np.arange(m) - c, np.arange(m) - c, indexing="ij")
    inverse = Q[:2, :2].T  # Q⁻¹ = Qᵀ
    Xs = np.rint(inverse[0, 0] * X + inverse[0, 1] * Y).astype(int) + c
    Ys = np.rint(inverse[1, 0] * X + inverse[1, 1] * Y).astype(int) + c
    axes = "xyz"
    out = {}
    for i, a in enumerate(axes):
        for j, b in enumerate(axes):
            out[a + b] = sum(
                Q[i, k] * Q[j, l] * blocks[axes[k] + axes[l]][Xs, Ys]
                for k in range(3)
                for l in range(3)
                if Q[i, k] != 0.0 and Q[j, l] != 0.0
            )
    for name in ("xy", "xz", "yz"):
        out["Re " + name] = 0.5 * (out[name] + out[name[::-1]])
    return out


def second_order(gap: float, lam_min: float) -> float:
    """The second-order term of K(A + ΔA) − K(A) − K'ΔA relative to K: ≤ (‖ΔA‖/λ_min)²
    (the Neumann series of (A + ΔA)⁻¹; K ≥ dA ‖t‖² λ_min)."""
    return (gap / lam_min) ** 2


def derived_errors(record: Mapping[str, object], entry: float) -> dict[str, float]:
    """Absolute error bounds of a record's tensor entries and of what ``hpcontact.quantities``
    derives from them, given a bound ``entry`` on every entry K_ij. Propagation, first order:
    a ratio's relative error is the sum of its parts'; eigenvalues of the 2 × 2 symmetric part
    move by ≤ ‖δK‖_F ≤ 2e (Weyl); the eigenvector's angle by ≤ 2e/(K_max − K_min) radians
    (Davis–Kahan); eigh, divisions and E*/G* add a few u of the value."""
    out: dict[str, float] = {}
    for key, value in record.items():
        if key.startswith("K_") and isinstance(value, float):
            out[key] = entry + 2.0 * U * abs(value)
    if "K_xx" not in record:
        return out
    kxx, kyy = abs(record["K_xx"]), abs(record["K_yy"])
    if "K_max" in record:
        kmax, kmin = abs(record["K_max"]), abs(record["K_min"])
        eigen = 2.0 * entry + 8.0 * U * kmax
        out["K_max"] = out["K_min"] = eigen
        out["K_min_over_K_max"] = abs(record["K_min_over_K_max"]) * (eigen / kmin + eigen / kmax + U)
        if isinstance(record.get("principal_angle_deg"), float):
            out["principal_angle_deg"] = math.degrees(eigen / (kmax - kmin))
    out["K_a_over_K_b"] = abs(record["K_a_over_K_b"]) * (entry / kxx + entry / kyy + U)
    for key, k in (("normalized_xx", kxx), ("normalized_yy", kyy)):
        if key in record:
            out[key] = abs(record[key]) * (entry / k + entry / abs(record["K_zz"]) + 6.0 * U)
    return out


def record_errors(
    scene: Scene, record: Mapping[str, object], ops: SceneOperators, extra: float = 0.0, proxy_gap: float = 0.0
) -> dict[str, float]:
    """Absolute error bounds of every number ``solve(scene)`` put in ``record`` that the tests
    compare: the entries (``cg_entry_error`` + ``extra``, a path difference's effect on an
    entry), what is derived from them (``derived_errors``), the compliance proxy
    (``proxy_errors``, a kernel difference ``proxy_gap``), and dx, dy (the same formula: exact)."""
    scale = max(abs(v) for k, v in record.items() if k.startswith("K_") and isinstance(v, float))
    entry = cg_entry_error(ops.solves.values(), scale, scene.tol, int(record["iterations"]))
    out = derived_errors(record, entry + extra)
    if ops.proxy is not None:
        out.update(proxy_errors(record, ops.proxy, proxy_gap))
    out["dx"] = out["dy"] = 0.0
    return out


def proxy_errors(record: Mapping[str, object], op: MaskOperator, gap: float = 0.0) -> dict[str, float]:
    """Bounds on the compliance proxy K = J⁻¹ (``_compliance_proxy``): J_ij = ū_i/F with ū the
    mean over the N cells of A applied to a uniform unit traction t and F = N dA. The applied
    field is off by ≤ η ‖t‖₂ = η √N, η = ε_mv ‖C‖ + ε_spectrum + ``gap`` (a kernel difference as
    in ``kernel_gap``), so a mean over N cells by ≤ η √N · √N/N = η; the mean's own rounding
    (numpy's pairwise sum) adds ≤ γ |ū| ≤ γ ‖C‖ (taken twice); then
    |δK_ij| ≤ ‖K‖₂² ‖δJ‖₂ ≤ ‖K‖_F² 2 max|δJ| (2 × 2), and inv adds a few u ‖K‖."""
    keys = [k for k in record if k.startswith("proxy_K_")]
    if not keys:
        return {}
    K = np.array([[record["proxy_K_xx"], record["proxy_K_xy"]], [record["proxy_K_yx"], record["proxy_K_yy"]]])
    norm = float(np.linalg.norm(K))
    mean = op.matvec_error * op.norm + op.spectrum_error + gap + 2.0 * pairwise_gamma(op.cells) * op.norm
    dJ = mean / (op.cells * op.cell_area)
    bound = norm * norm * 2.0 * dJ + 8.0 * U * norm
    return dict.fromkeys(keys, bound)


@dataclass(frozen=True)
class Indentation:
    """A Polonsky–Keer indentation re-run as ``solve`` runs it (``_indentation``): the pressure p,
    the contact S = {p > 0}, the displacement u = A p, A on S (``MaskOperator``), the zz kernel."""

    grid: Grid
    pressure: np.ndarray
    contact: np.ndarray
    displacement: np.ndarray
    operator: MaskOperator
    kernel: np.ndarray

    def pressure_error(self, tol: float, gap: float = 0.0) -> float:
        """Bound on ‖δp‖₂/‖p‖₂ for the converged p of a Polonsky–Keer solve at ``tol``, plus a
        kernel difference ``gap`` (``kernel_gap``) to another path.

        Polonsky–Keer returns only when the gap g = fl(A p) + h on the contact is within
        tol · max|u| there (``contact_residuals``, evaluated on a fresh product, so no drift
        accumulates). With the same contact set S as the exact solution p* (A_S p* = −h_S;
        first order: no cell on the margin), A_S (p̃ − p*) = g − e − δA p̃, e the product's
        rounding (≤ ε_mv ‖C‖ ‖p‖), δA the spectrum's rounding and the kernel difference:

            ‖δp‖₂/‖p‖₂ ≤ [√N tol ‖u‖_∞/‖p‖₂ + (ε_mv ‖C‖ + ε_spectrum + gap)]/λ_min(A_S).
        """
        op = self.operator
        p = float(np.linalg.norm(self.pressure[self.contact]))
        u = float(np.max(np.abs(self.displacement[self.contact])))
        stop = math.sqrt(op.cells) * tol * u / p
        return (stop + op.matvec_error * op.norm + op.spectrum_error + gap) / op.lam_min


def indentation(scene: Scene) -> Indentation:
    """Re-run the scene's indentation and build its ``Indentation`` (the contact set, p and u are
    the solve's to first order; what the bounds use of them — ‖p‖, max u, λ on S — is
    insensitive to round-off)."""
    _, solution, grid = _indentation(scene)
    p = solution.traction[0]
    contact = p > 0.0
    engine = Engine(scene.material, grid, ("zz",))
    u = engine.operator("z").apply(p[None])[0]
    return Indentation(grid, p, contact, u, mask_operator(engine, contact, "z", "H"), engine.centred_block("zz"))


def indentation_errors(record: Mapping[str, object], run: Indentation, eta: float) -> dict[str, float]:
    """Bounds on the indentation record's numbers from ‖δp‖₂ ≤ η ‖p‖₂: max_pressure by ‖δp‖_∞ ≤
    ‖δp‖₂, the load Σ p dA by dA √N ‖δp‖₂ (plus its pairwise sum's rounding), the contact area
    exactly (the same contact set), dx and dy exactly (the same grid formula)."""
    p = run.pressure[run.contact]
    norm = float(np.linalg.norm(p))
    dA = run.grid.cell_area
    load = float(record["load"])
    return {
        "max_pressure": eta * norm + 2.0 * U * float(record["max_pressure"]),
        "load": eta * norm * dA * math.sqrt(p.size) + 2.0 * pairwise_gamma(run.pressure.size) * load,
        "contact_area": 0.0,
        "dx": 0.0,
        "dy": 0.0,
    }
