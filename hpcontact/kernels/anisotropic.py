r"""Surface Green's function of a general anisotropic half-space and its cell influence coefficients.

Geometry and conventions (identical to the isotropic engine, docs/design.md §2): the body fills z > 0
(z points INTO the body), the surface is z = 0, a surface traction f = (f_x, f_y, f_z) acts on
the body (f_z > 0 presses in) and u is the surface displacement, u = G * f.  Stiffness ``C`` is
the lab-frame Voigt matrix (see :mod:`hpcontact.materials.crystal`); displacements per force come out in
1/(stress unit of C) × length.

1. Fourier space (Barnett & Lothe 1973, 1985; Ting, *Anisotropic Elasticity*, 1996, §7.1–7.5,
   §8.1).  With f̂(k) = ∫ f e^{−ik·x} dx, k = |k| m, m = (cos φ, sin φ, 0), n = e_z:

       û(k) = H(m) f̂(k) / k,        H(m) = (I − i S) L⁻¹,

   where S and L are the Barnett–Lothe integrals over the rotated pair
   m(ω) = m cos ω + n sin ω, n(ω) = −m sin ω + n cos ω, ω ∈ [0, π):

       S = (1/π) ∫ N1(ω) dω,   L = −(1/π) ∫ N3(ω) dω,
       N1 = −T⁻¹Rᵀ,  N3 = R T⁻¹ Rᵀ − Q,  Q = (m m), R = (m n), T = (n n),  (a b)_ik = a_j C_ijkl b_l.

   Derivation: a decaying Stroh mode u = a e^{ik(m·x + p z)} (Im p > 0) has traction
   σ_iz = ik b_i e^{…} with b = (Rᵀ + pT) a; the boundary condition −σ_iz(z=0) = f_i gives
   û = (i/k) A B⁻¹ f̂, and Ting's identities (S = i(2ABᵀ − I), L = −2iBBᵀ) turn i A B⁻¹ into
   (I − iS)L⁻¹ — the inverse of the (Hermitian, positive definite) surface impedance.  The
   integrands are smooth and π-periodic in ω, so the trapezoidal rule converges exponentially
   (the number of nodes is doubled until converged); nothing in the formulas refers to Stroh
   eigenvectors, so degenerate points (isotropy, A = 1) are as regular as any other.
   Isotropic check (Johnson 1985 §3.2, §3.6): H = [(I − nu m mᵀ)/G, +i(1−2nu) m/(2G);
   −i(1−2nu) mᵀ/(2G), (1−nu)/G].  H(−m) = conj(H(m)); L⁻¹ is real symmetric and S L⁻¹
   antisymmetric (Ting §7.5), so H is Hermitian.
   Nearly incompressible bodies: R T⁻¹ Rᵀ − Q cancels O(λ²/μ) terms down to O(μ) (relative
   loss eps (λ/μ)², 2.5e-9 at nu = 0.4999).  The integrands are therefore formed from
   C = C' + λ δ_ij δ_kl with C' of the size of the shear moduli and the rank-one term restored
   exactly by Sherman–Morrison (:func:`_pressure_split`, :func:`_bl_sums`).

2. Real space.  H is expanded in a Fourier series in φ, H(φ) = Σ_n h_n e^{inφ} (FFT of H at
   equispaced directions; the series converges geometrically, e^{−β|n|}, because H is analytic
   in a strip |Im φ| < β).  Since ∫_0^∞ e^{ikρ} dk = π δ(ρ) + i P(1/ρ),

       G(x) = (1/(2π)²) ∫ H(φ) e^{ik·x} dk = g(θ)/r,
       g(θ) = (1/2π) H_R(θ + π/2) − (1/2π²) P∫_{−π/2}^{π/2} H_I(θ + α)/cos α dα,

   (H = H_R + i H_I; the δ-term gives the even part, the principal value the odd part), and
   term by term, using P∫_0^{2π} e^{inα}/cos α dα = 2π (−1)^{(|n| − 1)/2} for odd n,

       g(θ) = (1/2π) Σ_n i^{|n|} h_n e^{inθ}.

   g is real, G_ij(−x) = G_ji(x) (reciprocity), and at A = 1 this is Boussinesq–Cerruti.
   For fast evaluation g is tabulated on 2^17 or more equispaced angles (zero-padded inverse
   FFT of the coefficients) and interpolated with 4-point local Lagrange polynomials
   (relative error at the 2e-15 round-off level for the bandwidths met at 0.25 ≤ A ≤ 8).

3. Cells.  The coefficient of a cell at offset (X, Y) = (target − source centre) with half sides
   a = dx/2, b = dy/2 is I = ∫∫_cell g(θ)/r.  Because g/r is homogeneous of degree −1,
   ∇·(ξ g/r) = g/r and I = ∮ (ξ·ν) g/r ds (exact; equivalent to the chord-length form
   ∫ g(θ)(r_out − r_in) dθ).  On an edge at distance d with foot angle θ_e and φ = atan(s/d):

       (ξ·ν) ∫ g/r ds = (ξ·ν) ∫ G(φ)/cos φ dφ,   G(φ) = g(θ_e ± φ),

   evaluated as c0 Δasinh(s/d) + c1 Δ ln(r/d) + ∫ [G − c0 − c1 sin φ]/cos φ dφ with
   c0 ± c1 = G(±π/2): the subtracted part is integrated in closed form (the isotropic rectangle
   formula x asinh(y/|x|) is its constant part), the remainder is analytic on the closed interval
   and is integrated by 14-point Gauss–Legendre panels of width ≤ β.  Used near the source
   (min(β, 1/2) r_min / max(a, b) < 4) and for any cell aspect ratio (1e-10 … 1e10: the
   panels refine themselves and the closed-form part carries the logarithmic end behaviour).
   Far cells use a tensor Gauss–Legendre rule whose order per direction follows from the
   Bernstein-ellipse bound 0.3 ρ^{−2p} ≤ 1e-14 with ρ from the distance to the nearest complex
   singularity (≥ min(β, 1/2) r_min): p = 3 for most cells of a 512² grid.

   Accuracy reached (tests/kernels/test_anisotropic.py): H against the isotropic closed form
   and against Stroh eigenvectors ≤ 2e-15; g against Johnson's point-force solutions ≤ 2e-15;
   cell coefficients against exact isotropic rectangle integrals and against independent
   quadrature of the chord form ≤ 1e-14 for square and moderately thin cells.  The edge formula
   loses ~eps × (offset index) to cancellation between opposite edges (3e-13 at 1000 cells of
   aspect 1e-6); nearly incompressible bodies lose ~eps λ/μ in forming C' (1e-14 at nu = 0.4999).

References: D. M. Barnett and J. Lothe, Phys. Norv. 7 (1973) 13; Proc. R. Soc. A 402 (1985)
135 (free surface / half-space Green's functions).  T. C. T. Ting, Anisotropic Elasticity,
Oxford (1996), ch. 7 (integral formalism), ch. 8 (half-space Green's functions).  J. J. Vlassak
and W. D. Nix, J. Mech. Phys. Solids 42 (1994) 1223 (indentation modulus).  K. L. Johnson,
Contact Mechanics (1985) §3.2, §3.6.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hpcontact.errors import ConvergenceError, InputError
from hpcontact.materials.crystal import Crystal, check_stiffness, isotropic, voigt_to_tensor

__all__ = [
    "AnisotropicKernel",
    "surface_green_fourier",
    "kernel_for",
    "anisotropic_offset_blocks",
    "indentation_modulus",
    "as_voigt",
]

# Convergence targets (relative to the largest entry).
#: Barnett–Lothe ω-quadrature: doubling stops when two successive trapezoidal sums differ by
#: less than this; the error of the finer sum is then ~ its square (geometric convergence),
#: i.e. at round-off.
_OMEGA_TOL = 1e-9
#: Fourier series of H(φ): the top quarter of the spectrum must fall below this ...
_PHI_TOL = 1e-15
#: ... or stopped decreasing below this level (round-off noise of H).
_PHI_NOISE = 1e-13
_MAX_OMEGA = 1 << 14
_MAX_PHI = 1 << 14
#: Table size for g(θ) (power of two) and the local Lagrange interpolation stencil.
_TABLE_MIN = 1 << 17
_STENCIL = np.arange(-1, 3)
#: Gauss–Legendre order of the near-field edge panels (panel width ≤ β in φ: ρ ≥ 2 + √5,
#: error ~ρ^{−28} ≈ 3e-18).
_EDGE_ORDER = 14
#: Near/far switch: edges when min(β, _BETA_FAR) r_min / max(a, b) < _Q_NEAR.
_Q_NEAR = 4.0
#: Far-field tensor Gauss–Legendre: relative target and prefactor of the error model
#: prefactor × ρ^{−2p}.  The prefactor 0.3 is calibrated against p = 20 reference integrals for
#: A = 0.25, 2, 8 (nu = 0.3, psi = 20°) at distances 4 … 500 cells: the observed error is then
#: below the model by a factor ≥ 3 everywhere (e.g. 3e-14 observed where it predicts 1e-13).
_FAR_TOL = 1e-14
_BETA_FAR = 0.5
_FAR_PREFACTOR = 0.3
_FAR_MAX_ORDER = 24
#: Workspace of one vectorized chunk of quadrature points, in bytes: a chunk holds
#: ``CHUNK_BYTES`` // bytes-per-point points (``_chunk_points``), ~1e5 for the nine columns of
#: a tangential + normal crystal, enough for numpy to run at full speed (chunks of 2^20 points,
#: ~310 MiB of temporaries, were 5–45 % slower on 128² … 512²: docs/performance.md §"Memory
#: per task"). With ``threads`` > 1 each thread holds one chunk.
CHUNK_BYTES = 32 << 20
#: Bytes per quadrature point of one chunk with ``ncol`` table columns, as ``tracemalloc``
#: measures them: far field 8 (13 + 3 ncol) (coordinates, 1/r weights, angle, the stencil's
#: index and four weights; gathered term, running sum and a transient per column: 128, 168,
#: 312 B measured for ncol = 1, 3, 9), edges 8 (16 + 4 ncol) (the panel angle, sin and cos
#: terms and one more array per column).
_FAR_POINT_WORDS = (13, 3)
_EDGE_POINT_WORDS = (16, 4)


def _chunk_points(ncol: int, words: tuple[int, int]) -> int:
    """Quadrature points per chunk: ``CHUNK_BYTES`` over the bytes per point of ``ncol``
    columns (``words`` = float64 words per point, fixed and per column)."""
    return max(1, CHUNK_BYTES // (8 * (words[0] + words[1] * ncol)))


# --------------------------------------------------------------------------------------------
# Materials in, Voigt matrices out
# --------------------------------------------------------------------------------------------
def as_voigt(material: Any) -> NDArray[np.float64]:
    """Lab-frame Voigt stiffness from a :class:`~hpcontact.materials.crystal.Crystal`, a 6 × 6 array, an
    object with a ``voigt`` attribute, or an isotropic material with ``G`` and ``nu`` (< 0.5)."""
    if isinstance(material, Crystal):
        return material.voigt
    voigt = getattr(material, "voigt", None)
    if voigt is not None:
        return check_stiffness(voigt)
    if hasattr(material, "G") and hasattr(material, "nu"):
        return isotropic(material.G, material.nu).voigt
    return check_stiffness(material)


# --------------------------------------------------------------------------------------------
# Barnett–Lothe integrals
# --------------------------------------------------------------------------------------------
def _pair(C4: NDArray, a: NDArray, b: NDArray) -> NDArray:
    """(a b)_ik = a_j C_ijkl b_l for stacks of vectors a, b of shape (P, 3) → (P, 3, 3)."""
    return np.einsum("pj,ijkl,pl->pik", a, C4, b, optimize=True)


def _inv3(M: NDArray) -> NDArray:
    """Inverse of a stack of 3 × 3 matrices by cofactors (vectorized; M symmetric positive
    definite here, the acoustic tensor (n n), whose condition number is ≲ 1/(1 − 2nu))."""
    a, b, c = M[..., 0, 0], M[..., 0, 1], M[..., 0, 2]
    d, e, f = M[..., 1, 0], M[..., 1, 1], M[..., 1, 2]
    g, h, i = M[..., 2, 0], M[..., 2, 1], M[..., 2, 2]
    A = e * i - f * h
    B = -(d * i - f * g)
    Cc = d * h - e * g
    det = a * A + b * B + c * Cc
    out = np.empty_like(M)
    out[..., 0, 0] = A
    out[..., 1, 0] = B
    out[..., 2, 0] = Cc
    out[..., 0, 1] = -(b * i - c * h)
    out[..., 1, 1] = a * i - c * g
    out[..., 2, 1] = -(a * h - b * g)
    out[..., 0, 2] = b * f - c * e
    out[..., 1, 2] = -(a * f - c * d)
    out[..., 2, 2] = a * e - b * d
    return out / det[..., None, None]


def _bl_sums(
    MM: NDArray, MN: NDArray, NN: NDArray, m: NDArray, n: NDArray, lam: float, omega: NDArray
) -> tuple[NDArray, NDArray]:
    """Σ_ω N1 and Σ_ω N3 over the given ω nodes for P directions.

    ``MM, MN, NN`` ((P, 3, 3)) are the pairings (m m)', (m n)', (n n)' of the reduced stiffness
    C' = C − λ δ_ij δ_kl; ``m, n`` ((P, 3)) the direction and the normal.  With the rank-one
    term restored by Sherman–Morrison (T = T' + λ n nᵀ etc. for the rotated pair),

        u = T'⁻¹ n(ω),  σ = n(ω)·u,  γ = λ/(1 + λσ),  d = m(ω) − R'u,
        N1 = −T'⁻¹R'ᵀ − γ u dᵀ,       N3 = R'T'⁻¹R'ᵀ − Q' − γ d dᵀ,

    which equals −T⁻¹Rᵀ and R T⁻¹ Rᵀ − Q exactly but has no O(λ²/μ) terms that cancel: the
    plain form loses ~eps (λ/μ)² relative (2.5e-9 at nu = 0.4999), this one ~eps λ/μ (from
    forming C').  1 + λσ = det T / det T' > 0 (matrix determinant lemma).
    """
    c = np.cos(omega)[None, :, None, None]
    s = np.sin(omega)[None, :, None, None]
    MM_, MN_, NN_ = MM[:, None], MN[:, None], NN[:, None]
    NM_ = np.swapaxes(MN_, -1, -2)
    T = s * s * MM_ - s * c * (MN_ + NM_) + c * c * NN_
    R = -c * s * MM_ + c * c * MN_ - s * s * NM_ + s * c * NN_
    Q = c * c * MM_ + c * s * (MN_ + NM_) + s * s * NN_
    Ti = _inv3(T)
    RT = np.swapaxes(R, -1, -2)
    N1 = -Ti @ RT
    N3 = R @ Ti @ RT - Q
    if lam != 0.0:
        cw, sw = c[..., 0], s[..., 0]  # (1, M, 1)
        mw = cw * m[:, None, :] + sw * n[:, None, :]
        nw = -sw * m[:, None, :] + cw * n[:, None, :]
        u = np.einsum("pwij,pwj->pwi", Ti, nw)
        sigma = np.einsum("pwi,pwi->pw", nw, u)
        gamma = (lam / (1.0 + lam * sigma))[..., None, None]
        d = mw - np.einsum("pwij,pwj->pwi", R, u)
        N1 = N1 - gamma * (u[..., :, None] * d[..., None, :])
        N3 = N3 - gamma * (d[..., :, None] * d[..., None, :])
    return N1.sum(axis=1), N3.sum(axis=1)


def _pressure_split(C6: NDArray) -> tuple[NDArray, float]:
    """C = C' + λ δ_ij δ_kl with C' positive definite and of the size of the shear moduli.

    λ = K_R − μ_min/3, K_R = 1/Σ_{i,j≤3} S_ij the Reuss bulk modulus (the largest λ with
    C − λ w wᵀ ≥ 0, w = (1,1,1,0,0,0)), μ_min the smallest Kelvin modulus (eigenvalue of
    W C W, W = diag(1,1,1,√2,√2,√2)).  Isotropic: λ = Lamé λ exactly (C' = 2G I); cubic with
    A ≥ 1: λ = C12.  Any λ is algebraically exact (see :func:`_bl_sums`); this one removes the
    nearly incompressible cancellation.  Falls back to λ = 0 if C' is not safely positive definite.
    """
    w = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    S = np.linalg.inv(C6)
    K_R = 1.0 / float(w @ S @ w)
    W = np.diag([1.0, 1.0, 1.0, math.sqrt(2.0), math.sqrt(2.0), math.sqrt(2.0)])
    kelvin = np.linalg.eigvalsh(W @ C6 @ W)
    lam = K_R - kelvin[0] / 3.0
    Cp = C6 - lam * np.outer(w, w)
    ev = np.linalg.eigvalsh(W @ Cp @ W)
    if not ev[0] > 1e-3 * kelvin[0]:
        return C6, 0.0
    return Cp, lam


def surface_green_nodes(C6: NDArray, phi: NDArray) -> int:
    """The ω nodes the adaptive Barnett–Lothe rule needs for the 6 × 6 stiffness ``C6`` (Pa) on
    the in-plane directions ``phi`` (radians): the measure of its cost (the sweep's cost model)."""
    return _surface_green(C6, phi)[1]


def _surface_green(C6: NDArray, phi: NDArray) -> tuple[NDArray, int]:
    """H(φ) (shape (P, 3, 3) complex, exactly Hermitian) and the number of ω nodes used."""
    phi = np.asarray(phi, dtype=np.float64).reshape(-1)
    Cp, lam = _pressure_split(C6)
    C4 = voigt_to_tensor(Cp)
    m = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=-1)
    n = np.ascontiguousarray(np.broadcast_to(np.array([0.0, 0.0, 1.0]), m.shape))
    MM, MN, NN = _pair(C4, m, m), _pair(C4, m, n), _pair(C4, n, n)
    M = 32
    s1, s3 = _bl_sums(MM, MN, NN, m, n, lam, np.arange(M) * (np.pi / M))
    S_old = L_old = None
    while True:
        S = s1 / M
        L = -s3 / M
        if S_old is not None:
            # S is dimensionless and O(1); L is measured relative to its largest entry.
            diff = max(float(np.max(np.abs(S - S_old))), float(np.max(np.abs(L - L_old))) / float(np.max(np.abs(L))))
            if diff < _OMEGA_TOL:
                break
            if M >= _MAX_OMEGA:
                raise ConvergenceError("Barnett-Lothe omega quadrature did not converge", M, diff)
        S_old, L_old = S, L
        # Trapezoidal refinement: add the midpoints (nested nodes).
        a1, a3 = _bl_sums(MM, MN, NN, m, n, lam, (np.arange(M) + 0.5) * (np.pi / M))
        s1, s3 = s1 + a1, s3 + a3
        M *= 2
    L = 0.5 * (L + np.swapaxes(L, -1, -2))
    Li = np.linalg.inv(L)
    Li = 0.5 * (Li + np.swapaxes(Li, -1, -2))
    H = (np.eye(3) - 1j * S) @ Li
    H = 0.5 * (H + np.conj(np.swapaxes(H, -1, -2)))
    return H, M


def surface_green_fourier(material: Any, phi: ArrayLike) -> NDArray[np.complex128]:
    """H(m) for in-plane directions m = (cos φ, sin φ) (φ in radians, any shape).

    Returns an array of shape φ.shape + (3, 3), complex128, Hermitian, with û = H f̂ / |k|
    (units: 1/stress).  Computed directly by the Barnett–Lothe integrals (section 1 above).
    """
    phi = np.asarray(phi, dtype=np.float64)
    H, _ = _surface_green(as_voigt(material), phi.reshape(-1))
    return H.reshape(phi.shape + (3, 3))


# --------------------------------------------------------------------------------------------
# The kernel object: Fourier coefficients, real-space angular function, cell integrals
# --------------------------------------------------------------------------------------------
def _lagrange_weights(t: NDArray) -> list[NDArray]:
    """Weights of the 4-point (cubic) Lagrange stencil at nodes -1, 0, 1, 2 for t in [0, 1)."""
    tp = t + 1.0
    tm = t - 1.0
    tmm = t - 2.0
    a = t * tm  # t (t - 1)
    b = tp * tmm  # (t + 1)(t - 2)
    return [
        a * tmm * (-1.0 / 6.0),
        b * tm * 0.5,
        b * t * -0.5,
        a * tp * (1.0 / 6.0),
    ]


@dataclass
class AnisotropicKernel:
    """Surface Green's function of one lab-frame stiffness, ready for cell integration.

    Attributes: ``voigt`` (6 × 6), ``n_omega`` (ω nodes of the BL quadrature), ``n_phi``
    (directions sampled), ``coeffs`` (h_n in FFT order, (n_phi, 3, 3) complex), ``beta``
    (half-width of the strip of analyticity of g(θ), estimated from the coefficient decay,
    ≤ 1), ``table`` ((K, 3, 3) real values of g at θ_k = 2πk/K).
    """

    voigt: NDArray[np.float64]
    n_omega: int
    n_phi: int
    coeffs: NDArray[np.complex128]
    beta: float
    table: NDArray[np.float64]
    _gl: dict = field(default_factory=dict, repr=False)

    # ---- construction ---------------------------------------------------------------------
    @classmethod
    def build(cls, material: Any) -> AnisotropicKernel:
        C6 = as_voigt(material)
        N = 64
        Hhalf, M = _surface_green(C6, np.arange(N // 2) * (2 * np.pi / N))
        top_prev = np.inf
        while True:
            H = np.concatenate([Hhalf, np.conj(Hhalf)], axis=0)  # H(φ + π) = conj H(φ)
            h = np.fft.fft(H, axis=0) / N
            mag = np.max(np.abs(h), axis=(1, 2))
            top = np.max(mag[N // 2 - N // 8 : N // 2 + N // 8 + 1]) / mag.max()
            # Converged: the top quarter of the spectrum is at round-off, or it stopped
            # decreasing at a level that is noise of H itself (nearly incompressible bodies
            # lose ~log10(λ/μ) digits when C' = C − λδδ is formed, see _pressure_split).
            if top <= _PHI_TOL or (top <= _PHI_NOISE and top > 0.1 * top_prev):
                break
            if N >= _MAX_PHI:
                raise ConvergenceError("Fourier series of H(phi) did not converge", N, top)
            top_prev = top
            # Double N: new directions are the odd multiples of 2π/(2N) in [0, π).
            Hnew, M2 = _surface_green(C6, (2 * np.arange(N // 2) + 1) * (np.pi / N))
            M = max(M, M2)
            merged = np.empty((N, 3, 3), dtype=complex)
            merged[0::2] = Hhalf
            merged[1::2] = Hnew
            Hhalf = merged
            N *= 2
        freq = np.rint(np.fft.fftfreq(N) * N).astype(np.int64)
        # Strip of analyticity from the decay |h_n| ≈ e^{−β|n|}: n_eff = last |n| with
        # |h_n| > 1e-12 max (above any noise floor), β = 0.8 ln(1e12)/n_eff (20 % margin).
        rel = mag / mag.max()
        n_eff = max(int(np.max(np.abs(freq)[rel > 1e-12])), 1)
        beta = min(1.0, 0.8 * math.log(1e12) / n_eff)
        K = max(_TABLE_MIN, 16 * N)
        cpad = np.zeros((K, 3, 3), dtype=complex)
        cg = (1j ** np.abs(freq))[:, None, None] * h / (2 * np.pi)
        cpad[freq % K] = cg
        gt = np.fft.ifft(cpad, axis=0) * K
        if np.max(np.abs(gt.imag)) > 1e-12 * np.max(np.abs(gt.real)):
            raise ConvergenceError("real-space kernel is not real", N, float(np.max(np.abs(gt.imag))))
        table = np.ascontiguousarray(gt.real)
        table.setflags(write=False)
        return cls(C6, M, N, h, beta, table)

    # ---- Fourier space ----------------------------------------------------------------------
    def fourier(self, phi: ArrayLike) -> NDArray[np.complex128]:
        """H(φ) directly from the Barnett–Lothe integrals (shape φ.shape + (3, 3))."""
        return surface_green_fourier(self.voigt, phi)

    def fourier_series(self, phi: ArrayLike) -> NDArray[np.complex128]:
        """H(φ) summed from the stored Fourier coefficients (for checks)."""
        phi = np.asarray(phi, dtype=np.float64)
        freq = np.rint(np.fft.fftfreq(self.n_phi) * self.n_phi)
        e = np.exp(1j * phi[..., None] * freq)
        return np.einsum("...n,nij->...ij", e, self.coeffs)

    # ---- real space -------------------------------------------------------------------------
    def angular_exact(self, theta: ArrayLike) -> NDArray[np.float64]:
        """g(θ) by direct summation of its Fourier series (shape θ.shape + (3, 3)); for checks."""
        theta = np.asarray(theta, dtype=np.float64)
        freq = np.rint(np.fft.fftfreq(self.n_phi) * self.n_phi)
        c = (1j ** np.abs(freq))[:, None, None] * self.coeffs / (2 * np.pi)
        e = np.exp(1j * theta[..., None] * freq)
        return np.einsum("...n,nij->...ij", e, c).real

    def _columns(self, cols: NDArray) -> NDArray:
        """Table rows for flat 3 × 3 indices ``cols``: shape (ncol, K), contiguous per column."""
        flat = self.table.reshape(self.table.shape[0], 9)
        return np.ascontiguousarray(flat[:, np.asarray(cols, dtype=np.int64)].T)

    @staticmethod
    def _interp(tab: NDArray, theta: NDArray) -> NDArray:
        """4-point (cubic) periodic Lagrange interpolation of table columns (ncol, K) at theta.

        Returns shape (ncol,) + theta.shape.  Nodes k0 - 1 ... k0 + 2 around u = theta K/2pi,
        k0 = floor(u).  Error <~ (h^4/24) max|g^(4)| with h = 2pi/K <= 4.8e-5: at the 2e-15
        round-off of the direct series for the bandwidths of 0.25 <= A <= 8 (docs/validation.md
        §"Anisotropic kernels").
        """
        K = tab.shape[1]
        u = theta * (K / (2 * np.pi))
        k0 = np.floor(u)
        t = u - k0
        k0 = k0.astype(np.int64)
        w = _lagrange_weights(t)
        out = None
        for j, off in enumerate(_STENCIL):
            idx = (k0 + off) & (K - 1)
            term = np.take(tab, idx, axis=1)
            term *= w[j]
            if out is None:
                out = term
            else:
                out += term
        return out

    def angular(self, theta: ArrayLike) -> NDArray[np.float64]:
        """g(θ) (shape θ.shape + (3, 3)) from the table; G(x) = g(θ)/r."""
        theta = np.asarray(theta, dtype=np.float64)
        vals = self._interp(self._columns(np.arange(9)), theta)
        return np.moveaxis(vals, 0, -1).reshape(theta.shape + (3, 3))

    def point_kernel(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Real-space point-force kernel G_ij(x, y) = g_ij(θ)/r (displacement i per force j)."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        r = np.hypot(x, y)
        return self.angular(np.arctan2(y, x)) / r[..., None, None]

    # ---- cell integrals ---------------------------------------------------------------------
    def _gauss(self, p: int) -> tuple[NDArray, NDArray]:
        if p not in self._gl:
            self._gl[p] = np.polynomial.legendre.leggauss(p)
        return self._gl[p]

    def _edge_integrals(self, tab: NDArray, X: NDArray, Y: NDArray, a: float, b: float) -> NDArray:
        """Cell integrals by the edge (divergence-theorem) formula; (Nc,) centres → (ncol, Nc)."""
        Nc = X.size
        ncol = tab.shape[0]
        E = 4 * Nc
        # Four edges per cell: line coordinate c, outward sign, range s1 < s2, vertical or not.
        c = np.concatenate([X + a, X - a, Y + b, Y - b])
        sgn = np.repeat([1.0, -1.0, 1.0, -1.0], Nc)
        s1 = np.concatenate([Y - b, Y - b, X - a, X - a])
        s2 = np.concatenate([Y + b, Y + b, X + a, X + a])
        vertical = np.repeat([True, True, False, False], Nc)
        weight = sgn * c  # ξ·ν, constant on the edge
        live = c != 0.0  # an edge on a line through the source contributes nothing
        d = np.where(live, np.abs(c), 1.0)
        pos = c > 0
        # Points of the edge: θ = θ_e + σ φ with φ = atan(s/d).
        theta_e = np.where(vertical, np.where(pos, 0.0, np.pi), np.where(pos, 0.5 * np.pi, -0.5 * np.pi))
        sigma = np.where(vertical, np.where(pos, 1.0, -1.0), np.where(pos, -1.0, 1.0))
        u1, u2 = s1 / d, s2 / d
        phi1, phi2 = np.arctan(u1), np.arctan(u2)
        # Closed-form part: c0 Δt + c1 Δℓ, t = asinh(u), ℓ = ln(r/d) = ½ log1p(u²).
        g_plus = self._interp(tab, theta_e + sigma * (0.5 * np.pi))
        g_minus = self._interp(tab, theta_e - sigma * (0.5 * np.pi))
        c0 = 0.5 * (g_plus + g_minus)
        c1 = 0.5 * (g_plus - g_minus)
        dt = _asinh_difference(u1, u2, (s2 - s1) / d)
        dl = 0.5 * np.log1p((u2 - u1) * (u2 + u1) / (1.0 + u1 * u1))
        total = c0 * dt + c1 * dl
        # Remainder [G − c0 − c1 sin φ]/cos φ (analytic on [−π/2, π/2]) by Gauss–Legendre
        # panels of width ≤ β in φ.
        npan = np.maximum(1, np.ceil((phi2 - phi1) / self.beta - 1e-12).astype(np.int64))
        npan[~live] = 0
        edge_of_panel = np.repeat(np.arange(E), npan)
        first = np.cumsum(npan) - npan
        k = np.arange(edge_of_panel.size) - first[edge_of_panel]
        h = (phi2 - phi1)[edge_of_panel] / npan[edge_of_panel]
        lo = phi1[edge_of_panel] + k * h
        xg, wg = self._gauss(_EDGE_ORDER)
        rem = np.zeros((ncol, E))
        step = max(1, _chunk_points(ncol, _EDGE_POINT_WORDS) // _EDGE_ORDER)
        for start in range(0, edge_of_panel.size, step):
            sl = slice(start, start + step)
            e = edge_of_panel[sl]
            ph = lo[sl, None] + 0.5 * h[sl, None] * (xg[None, :] + 1.0)
            G = self._interp(tab, theta_e[e, None] + sigma[e, None] * ph)
            G -= c0[:, e, None]
            G -= c1[:, e, None] * np.sin(ph)
            G *= (wg[None, :] / np.cos(ph)) * (0.5 * h[sl, None])
            contrib = G.sum(axis=-1)
            for col in range(ncol):
                rem[col] += np.bincount(e, weights=contrib[col], minlength=E)
        total = (total + rem) * np.where(live, weight, 0.0)
        return total.reshape(ncol, 4, Nc).sum(axis=1)

    def _far_integrals(self, tab: NDArray, X: NDArray, Y: NDArray, a: float, b: float, px: int, py: int) -> NDArray:
        """Tensor Gauss–Legendre (px × py) cell integrals for cells far from the source → (ncol, Nc)."""
        xg, wx = self._gauss(px)
        yg, wy = self._gauss(py)
        w = (wx[:, None] * wy[None, :]).ravel() * (a * b)
        x = X[:, None] + np.repeat(a * xg, py)[None, :]
        y = Y[:, None] + np.tile(b * yg, px)[None, :]
        wr = w[None, :] / np.sqrt(x * x + y * y)
        G = self._interp(tab, np.arctan2(y, x))
        G *= wr
        return G.sum(axis=-1)

    def cell_integrals(self, X: ArrayLike, Y: ArrayLike, dx: float, dy: float) -> NDArray[np.float64]:
        """∫∫ g_ij(θ)/r over rectangles of sides dx, dy centred at (X, Y) (offsets target − source).

        Returns shape (X.size, 3, 3): displacement i per unit uniform traction j.
        """
        tab = self._columns(np.arange(9))
        X = np.asarray(X, float).ravel()
        vals = self._cells_from_table(tab, X, np.asarray(Y, float).ravel(), dx, dy)
        return vals.T.reshape(X.size, 3, 3)

    def _cells_from_table(
        self, tab: NDArray, X: NDArray, Y: NDArray, dx: float, dy: float, threads: int = 1
    ) -> NDArray:
        """Cell integrals of the table columns (ncol, K) for centres X, Y → (ncol, Nc).

        ``threads`` > 1 spreads the far-field chunks over a thread pool (numpy releases the GIL
        in the gathers and arithmetic); each chunk writes its own columns of the output.
        """
        a, b = 0.5 * float(dx), 0.5 * float(dy)
        if not (math.isfinite(a) and math.isfinite(b) and a > 0 and b > 0):
            raise InputError("dx, dy", "finite cell sizes > 0", (dx, dy))
        out = np.empty((tab.shape[0], X.size))
        # Distance from the source point to the nearest point of each cell.
        rmin = np.hypot(np.maximum(np.abs(X) - a, 0.0), np.maximum(np.abs(Y) - b, 0.0))
        # Distance to the nearest complex singularity of g(θ)/r in units of the half side:
        # ≥ β r_min (g) and ≥ r_min (1/r); β is capped at _BETA_FAR for this model, since the
        # prefactor was calibrated on strips β ≤ 0.65 (isotropic kernels, β = 1, otherwise
        # exceed the tolerance by 8×).
        beta = min(self.beta, _BETA_FAR)
        qx = beta * rmin / a
        qy = beta * rmin / b
        near = np.minimum(qx, qy) < _Q_NEAR
        if np.any(near):
            out[:, near] = self._edge_integrals(tab, X[near], Y[near], a, b)
        far = np.nonzero(~near)[0]
        if far.size:
            px = _far_order(qx[far])
            py = _far_order(qy[far])
            key = px * 1000 + py
            tasks = []
            points = _chunk_points(tab.shape[0], _FAR_POINT_WORDS)
            for k in np.unique(key):
                sel = far[key == k]
                p2 = int(k // 1000) * int(k % 1000)
                step = max(1, points // p2)
                tasks += [(sel[i : i + step], int(k // 1000), int(k % 1000)) for i in range(0, sel.size, step)]

            def work(task: tuple[NDArray, int, int]) -> None:
                sel, kx, ky = task
                out[:, sel] = self._far_integrals(tab, X[sel], Y[sel], a, b, kx, ky)

            if threads > 1 and len(tasks) > 1:
                with ThreadPoolExecutor(max_workers=threads) as pool:
                    list(pool.map(work, tasks))
            else:
                for task in tasks:
                    work(task)
        return out


def _far_order(q: NDArray) -> NDArray:
    """Gauss–Legendre order per direction: ρ^{−2p} × prefactor ≤ tol, ρ = q + √(q² − 1)."""
    rho = q + np.sqrt(np.maximum(q * q - 1.0, 0.0))
    p = np.ceil(math.log(_FAR_PREFACTOR / _FAR_TOL) / (2.0 * np.log(np.maximum(rho, 1.0001))))
    return np.clip(p, 1, _FAR_MAX_ORDER).astype(np.int64)


def _asinh_difference(u1: NDArray, u2: NDArray, du: NDArray) -> NDArray:
    """asinh(u2) - asinh(u1) for u2 >= u1 without cancellation when both are large and of one sign.

    For 0 <= u1: D = log1p(du (1 + (u1 + u2)/(S1 + S2)) / (u1 + S1)), S = sqrt(1 + u^2),
    du = u2 - u1 passed in exactly from the geometry; for u2 <= 0 by oddness; otherwise the
    plain difference (the two terms then have opposite signs and add).  Each formula is
    evaluated only where it applies (no overflow or 0/0 elsewhere).
    """
    out = np.arcsinh(u2) - np.arcsinh(u1)
    pos = u1 >= 0
    neg = (u2 <= 0) & ~pos
    for sel, lo, hi in ((pos, u1, u2), (neg, -u2, -u1)):
        if np.any(sel):
            lo, hi, d = lo[sel], hi[sel], du[sel]
            Slo, Shi = np.hypot(1.0, lo), np.hypot(1.0, hi)
            out[sel] = np.log1p(d * (1.0 + (lo + hi) / (Slo + Shi)) / (lo + Slo))
    return out


# --------------------------------------------------------------------------------------------
# Cache and the grid API
# --------------------------------------------------------------------------------------------
_KERNELS: OrderedDict[bytes, AnisotropicKernel] = OrderedDict()
_KERNEL_CACHE_SIZE = 8  # each kernel holds a 2^17 x 9 table: ~9.4 MB


def kernel_for(material: Any) -> AnisotropicKernel:
    """The (cached) :class:`AnisotropicKernel` of a lab-frame stiffness (material + orientation)."""
    C6 = as_voigt(material)
    key = np.ascontiguousarray(C6).tobytes()
    kern = _KERNELS.get(key)
    if kern is None:
        kern = AnisotropicKernel.build(C6)
        _KERNELS[key] = kern
        while len(_KERNELS) > _KERNEL_CACHE_SIZE:
            _KERNELS.popitem(last=False)
    else:
        _KERNELS.move_to_end(key)
    return kern


def clear_cache() -> None:
    """Forget all cached kernels."""
    _KERNELS.clear()


def _check_grid(nx: int, ny: int, dx: float, dy: float) -> tuple[int, int, float, float]:
    for name, v in (("nx", nx), ("ny", ny)):
        if int(v) != v or v < 1:
            raise InputError(name, "an integer >= 1", v)
    for name, v in (("dx", dx), ("dy", dy)):
        if not (math.isfinite(float(v)) and float(v) > 0):
            raise InputError(name, "a finite cell size > 0", v)
    return int(nx), int(ny), float(dx), float(dy)


def anisotropic_offset_blocks(
    material: Any,
    nx: int,
    ny: int,
    dx: float,
    dy: float,
    blocks: Iterable[tuple[int, int]] = tuple((i, j) for i in range(3) for j in range(3)),
    *,
    threads: int = 1,
) -> dict[tuple[int, int], NDArray[np.float64]]:
    """Cell influence coefficients of an anisotropic half-space on an nx × ny grid.

    For each requested block (i, j) — displacement component i at a cell centre due to a unit
    uniform traction component j on a cell, 0 = x, 1 = y, 2 = z — returns a float64 array of
    shape (2nx − 1, 2ny − 1) indexed by offset (target − source) + (nx − 1, ny − 1).  Units:
    length / (stress unit of the stiffness).  ``material``: a lab-frame stiffness (see
    :func:`as_voigt`); the surface Green's function is cached per stiffness.

    Only the offsets with p > 0 or (p = 0, q ≥ 0) are integrated: reciprocity
    K_ij(−o) = K_ji(o) gives the rest, using the even (symmetric in ij) and odd (antisymmetric)
    parts of g.  ``threads``: worker threads for the far-field quadrature (results identical).
    """
    nx, ny, dx, dy = _check_grid(nx, ny, dx, dy)
    if int(threads) != threads or threads < 1:
        raise InputError("threads", "an integer >= 1", threads)
    wanted = []
    for blk in blocks:
        try:
            i, j = (int(v) for v in blk)
        except (TypeError, ValueError):
            raise InputError("blocks", "pairs (i, j) with i, j in {0, 1, 2}", blk) from None
        if not (0 <= i < 3 and 0 <= j < 3):
            raise InputError("blocks", "pairs (i, j) with i, j in {0, 1, 2}", blk)
        if (i, j) not in wanted:
            wanted.append((i, j))
    if not wanted:
        return {}
    kern = kernel_for(material)
    g = kern.table
    pairs = sorted({(min(i, j), max(i, j)) for i, j in wanted})
    cols = []
    col_index: dict[tuple[str, int, int], int] = {}
    for i, j in pairs:
        col_index[("e", i, j)] = len(cols)
        cols.append(0.5 * (g[:, i, j] + g[:, j, i]))
        if i != j:
            col_index[("o", i, j)] = len(cols)
            cols.append(0.5 * (g[:, i, j] - g[:, j, i]))
    tab = np.ascontiguousarray(np.stack(cols, axis=0))
    del cols  # the columns live on in tab only (9 columns of 2^17: 9 MiB)
    # Half plane of offsets.
    P, Q = np.meshgrid(np.arange(nx), np.arange(-(ny - 1), ny), indexing="ij")
    keep = (P > 0) | (Q >= 0)
    P, Q = P[keep], Q[keep]
    vals = kern._cells_from_table(tab, (P * dx).astype(np.float64), (Q * dy).astype(np.float64), dx, dy, int(threads))
    out: dict[tuple[int, int], NDArray[np.float64]] = {}
    ip, iq = P + nx - 1, Q + ny - 1
    im, jm = -P + nx - 1, -Q + ny - 1
    for i, j in wanted:
        lo, hi = min(i, j), max(i, j)
        e = vals[col_index[("e", lo, hi)]]
        if lo == hi:
            here = there = e
        else:
            o = vals[col_index[("o", lo, hi)]]
            s = 1.0 if i < j else -1.0
            here = e + s * o  # K_ij(o)
            there = e - s * o  # K_ij(−o) = K_ji(o)
        arr = np.empty((2 * nx - 1, 2 * ny - 1))
        arr[ip, iq] = here
        arr[im, jm] = there
        out[(i, j)] = arr
    return out


def indentation_modulus(material: Any, n_phi: int = 256) -> float:
    """Indentation modulus M = 2/⟨H_zz⟩ (average over in-plane directions).

    The circular-contact approximation of Vlassak & Nix (1993, 1994): with the axisymmetric
    pressure of a rigid flat punch, the centre displacement gives K = 2aM.  Exact for isotropic
    bodies (M = E/(1 − nu²) = 2G/(1 − nu)) and for transversely isotropic bodies with the axis
    along the normal (H_zz then independent of direction).  Units of the stiffness.
    """
    phi = np.arange(n_phi) * (2 * np.pi / n_phi)
    H = surface_green_fourier(material, phi)
    return float(2.0 / np.mean(H[:, 2, 2].real))
