r"""The elliptical punch as one exact cell: Galin's traction on any half-space, by Fourier moments.

Why
---
Galin's theorem (Galin 1948; Willis 1966, J. Mech. Phys. Solids 14, 163, §2): for any surface
kernel that is even and homogeneous of degree −1 — the Boussinesq–Cerruti kernel, the
Barnett–Lothe kernel Re H of a crystal of any symmetry and orientation, H_zz alone — the traction

    t(x, y) = c w(x, y) / (2π a b),      w = (1 − x'²/a² − y'²/b²)^(−½)                       (1)

(x', y' the coordinates along the ellipse's own axes, total force c) displaces the whole ellipse
by one constant vector u = J c. The bonded rigid punch's traction is therefore exactly (1) for
every rigid displacement, and the one-function Galerkin basis {w e_j} contains it: on this one
"cell" the discretization error is zero, and K = J⁻¹ is exact but for the integral J. The
compliance is (Willis 1966, eq. 2.10 with the Hertz profile replaced by w; the same contour
integral ``tests/independent_reference.py`` evaluates by a graded quadrature)

    J = (1/8π) ∮ Re H(φ) / s(φ) dφ,      s(φ)² = a² cos²(φ − β) + b² sin²(φ − β),           (2)

with H(φ) the surface Green's function in Fourier space (û = H f̂ / |k|,
``hpcontact.kernels.anisotropic`` §1), β the turn of the ellipse (``shape_angle``) and a = 1 the
long semi-axis. The crystal turns with the shape (``scene._turned_with_shape``): its lab-frame
kernel is used as it is; the ellipse's turn enters only through s — the kernel is turned, not a
grid.

Where it applies: ellipses and circles, turned or not, any material (isotropic or crystal), the
quantities ``tangential`` (the 3 × 3 Re-H problem with the normal approach held: K = (J⁻¹)_tt;
with the normal force held instead, ``plan.holds_normal_load``: K = (J_tt)⁻¹, the Schur complement)
and ``normal`` (the frictionless punch: K_zz = 1 / J_zz of H_zz). Not ``coupled``: the full
complex H has an odd real-space part, and for it (1) is not the solution (the bonded isotropic
punch with coupling has an oscillating edge singularity, Mossakovskii 1954).

The moments
-----------
H is a trigonometric series, H(φ) = Σ_n h_n e^{inφ}, converged geometrically (the crystal
kernel's stored coefficients ``AnisotropicKernel.coeffs``: the top quarter of the spectrum below
1e-15 of the largest; the isotropic H has |n| ≤ 2, sampled at 8 directions). So

    ∮ Re H / s dφ = Re Σ_n h_n e^{inβ} M_n,      M_n = ∮ e^{inφ} / s₀(φ) dφ,                 (3)

s₀ the unturned s. s₀² = α + β₀ cos 2φ with α = (1 + e²)/2, β₀ = (1 − e²)/2, e = b/a, so M_n
vanishes for odd n and M_{2j} = c_j = ∫_0^{2π} cos(jψ)(α + β₀ cos ψ)^(−½) dψ, the cosine moments
of a toroidal kernel (c_j = 2(−1)^j (2/β₀)^½ Q_{j−½}(α/β₀), DLMF 14.12.4). Two ways, each where
it is accurate:

* trapezoidal rule (an FFT) in φ: (α + β₀ cos ψ)^(−½) is analytic in the strip
  |Im ψ| < η = 2 artanh e, so P points alias c_j by e^{−(P − j)η}; taken with
  P ≥ j_max + ``ALIAS_DIGITS``/η points while that is at most ``FFT_MAX_POINTS`` (e ≳ 5e-5);
* thinner ellipses: the three-term recurrence of the c_j (differentiate (α + β₀ cos ψ)^(−½)
  and integrate by parts),

      (j + ½) c_{j+1} = −2 (α/β₀) j c_j − (j − ½) c_{j−1},                                     (4)

  forward from c_0 = 4 K(1 − e²) and c_1 = (4 E(1 − e²) − α c_0)/β₀ (complete elliptic
  integrals; K by ``scipy.special.ellipkm1`` of e², exact for e → 0). c_j is the recessive
  solution, so forward recurrence amplifies rounding by at most e^{2 j η}: ≤ e^{0.5} where it
  is used (j_max η ≤ ``RECURRENCE_MAX_GROWTH``/2).

Error
-----
J's error is the truncation of (3) — the series' last quarter bounds what was left out
(geometric decay) — plus rounding: per entry

    δJ_ij = (1/8π) {[2 Σ_{|n| > N/4} |h_n,ij| + ``ROUNDING`` ε Σ_n |h_n,ij|] max_n |M_n|
                     + Σ_n |h_n,ij| δM_n},                                                       (5)

|M_n| ≤ M_0, δM_n the moments' own rounding bound (``inverse_support_moments``). The stiffness K = J⁻¹ takes |δK| ≤ |K| |δJ| |K| (first order, entrywise absolute
values), and each reported quantity's relative error follows from that
(``hpcontact.accuracy.exact_errors``). Against the independent reference (Stroh eigenvectors and a
graded Gauss–Legendre rule, ``tests/independent_reference.py``) and Mindlin's closed forms the
results agree to the round-off level the estimate states (``tests/discretizations/test_galin_ellipse.py``).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from hpcontact import quantities as q
from hpcontact.kernels.anisotropic import kernel_for
from hpcontact.kernels.isotropic import isotropic_surface_green
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.backend import require_gpu
from hpcontact.plan import holds_normal_load, plan_for
from hpcontact.scene import Scene

#: Quantities the one-cell Galin solve gives (``tangential``: Re H approach held; ``normal``: H_zz).
SUPPORTED = q.names_where(lambda q: q.exact_cell)
#: Shapes it solves: those whose contact is an ellipse.
SHAPES = ("circle", "ellipse")
#: Trapezoidal rule for the moments: aliasing e^{−ALIAS_DIGITS} ≈ 4e-18 (below round-off).
ALIAS_DIGITS = 40.0
#: The largest FFT taken for the moments (2^20 points: e ≳ 4e-5 at j_max ≤ 512).
FFT_MAX_POINTS = 1 << 20
#: Forward recurrence (4) only where rounding grows by at most e^{RECURRENCE_MAX_GROWTH}.
RECURRENCE_MAX_GROWTH = 0.5
#: Rounding allowance in (5), in units of machine epsilon times the sum of |h_n|: the sum (3)
#: has ~N terms of mixed sign; the measured discrepancy against the references is below it.
ROUNDING = 64.0
#: The isotropic H(φ) has Fourier modes |n| ≤ 2 only: sampled at this many directions it is exact.
ISOTROPIC_DIRECTIONS = 8


#: What the record's plan says was done (``plan.derived``, ``plan.boundary``).
DERIVED = "K = inverse of J = (1/8 pi) contour integral of Re H(phi)/s(phi) dphi (Galin 1948; Willis 1966)"
BOUNDARY = "galin: one cell carrying w = (1 - x^2/a^2 - y^2/b^2)^(-1/2), the exact traction of an ellipse"


def applies(scene: Scene) -> bool:
    """Whether the one-cell Galin solve gives ``scene`` exactly: an ellipse or circle (turned or
    not, any material) and quantities among ``SUPPORTED``."""
    return scene.shape.name in SHAPES and bool(scene.quantities) and set(scene.quantities) <= set(SUPPORTED)


def inverse_support_moments(aspect: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    """c_j = ∫_0^{2π} cos(2jφ) / s₀(φ) dφ for j = 0 … count − 1, s₀² = cos²φ + e² sin²φ,
    e = ``aspect`` ∈ (0, 1] (module docstring, "The moments"; dimensionless for a = 1), and a
    bound on each one's rounding error: ε log2(P) c_0 for the FFT of P points, ε j² c_0 for the
    recurrence (its rounding grows like j² near z = 1: measured against 30-digit quadrature at
    b/a = 1e-4, 1.4e-13 at j = 50 and 2.7e-12 at j = 200 relative, a third to a quarter of this)."""
    e = float(aspect)
    eps = np.finfo(float).eps
    if e == 1.0:  # the circle: s₀ = 1
        out = np.zeros(count)
        out[0] = 2.0 * math.pi
        return out, np.full(count, eps * out[0])
    eta = 2.0 * math.atanh(e)
    points = count + ALIAS_DIGITS / eta
    if points <= FFT_MAX_POINTS:
        P = 1 << max(6, math.ceil(math.log2(points)))
        phi = np.arange(P) * (math.pi / P)  # ψ = 2φ on P points of [0, 2π)
        f = 1.0 / np.sqrt(np.cos(phi) ** 2 + (e * np.sin(phi)) ** 2)
        out = (np.fft.rfft(f).real * (2.0 * math.pi / P))[:count]
        return out, np.full(count, eps * math.log2(P) * out[0])
    if count * eta > RECURRENCE_MAX_GROWTH:
        raise ValueError(f"no accurate rule for {count} moments at b/a = {e:g}")
    from scipy.special import ellipe, ellipkm1  # on first use, not at import (strip_cells' docstring)

    alpha, beta = 0.5 * (1.0 + e * e), 0.5 * (1.0 - e * e)
    z = alpha / beta
    out = np.empty(count)
    out[0] = 4.0 * float(ellipkm1(e * e))
    if count > 1:
        out[1] = (4.0 * float(ellipe(1.0 - e * e)) - alpha * out[0]) / beta
    for j in range(1, count - 1):
        out[j + 1] = (-2.0 * z * j * out[j] - (j - 0.5) * out[j - 1]) / (j + 0.5)
    return out, eps * np.maximum(np.arange(count), 1.0) ** 2 * out[0]


def fourier_coefficients(material: Any) -> tuple[np.ndarray, np.ndarray]:
    """(h_n, n): H(φ) = Σ_n h_n e^{inφ} for ``material`` (1/stress; ``hpcontact.kernels.anisotropic``
    §1-2), in FFT order."""
    if isinstance(material, Isotropic):
        N = ISOTROPIC_DIRECTIONS
        H = isotropic_surface_green(material, np.arange(N) * (2.0 * math.pi / N))
        h = np.fft.fft(H, axis=0) / N
    else:
        kernel = kernel_for(material)
        h, N = kernel.coeffs, kernel.n_phi
    return h, np.rint(np.fft.fftfreq(N) * N).astype(np.int64)


def compliance(material: Any, aspect: float, turn: float) -> tuple[np.ndarray, np.ndarray]:
    """J of (2) (3 × 3, units 1/(stress × length) for a = 1) and its error bound δJ of (5) for
    the ellipse of semi-axes 1 and ``aspect`` turned by ``turn`` radians. Its zz entry is the
    frictionless punch's compliance as well: H_zz is real."""
    h, freq = fourier_coefficients(material)
    top = int(np.max(np.abs(freq)))
    moments, rounding = inverse_support_moments(aspect, top // 2 + 1)
    even = freq % 2 == 0
    index = np.abs(freq) // 2 * even
    M = np.where(even, moments[index], 0.0)
    dM = np.where(even, rounding[index], 0.0)
    phase = np.exp(1j * freq * turn)
    # ∮ Re H / s dφ = Re Σ_n h_n e^{inβ} M_n: M_n and s are real.
    J = np.einsum("n,nij->ij", M * phase, h).real / (8.0 * math.pi)
    magnitude = np.abs(h)
    tail = magnitude[np.abs(freq) > top // 2].sum(axis=0)
    scale = float(np.max(np.abs(moments)))
    summed = (2.0 * tail + ROUNDING * np.finfo(float).eps * magnitude.sum(axis=0)) * scale
    dJ = (summed + np.einsum("n,nij->ij", dM, magnitude)) / (8.0 * math.pi)
    return J, dJ


def solve(scene: Scene) -> dict[str, Any]:
    """The stiffnesses of ``scene`` (``applies``) from the exact compliance (2): the record keys of
    ``hpcontact.problems.contact.solve`` for its quantities, with ``absolute_errors``, the bounds
    |δK| of the tensor entries K_xx … K_zz (module docstring, "Error"; ``hpcontact.accuracy``
    turns them into relative errors per reported quantity), ``boundary`` "galin", and one cell:
    nx = ny = 1 with the ellipse's bounding box as dx, dy (K in G·a, as everywhere).

    The cell is computed on the CPU (a contour integral, ~1 ms) whatever the scene's ``device``;
    ``device = "gpu"`` where CuPy or a CUDA device is missing is refused as a grid's solve refuses
    it (``backend.require_gpu``), so that one command gives one answer on a node, whatever the
    shape (before, an ellipse's was computed and a polygon's refused)."""
    if scene.device == "gpu":
        require_gpu()
    started = time.perf_counter()
    shape = scene.shape
    e = 1.0 if shape.name == "circle" else shape.aspect
    turn = math.radians(shape.angle_deg)
    forces: dict[str, np.ndarray] = {}
    absolute: dict[str, float] = {}
    J, dJ = compliance(scene.material, e, turn)
    if "tangential" in scene.quantities:
        K = _inverse(J)
        forces["tangential_x"], forces["tangential_y"] = K[:, 0].copy(), K[:, 1].copy()
        if holds_normal_load(scene):  # F_z = 0: stiffness_record forms K_tt − K_tz K_zz⁻¹ K_zt = (J_tt)⁻¹
            forces["tangential_z"] = K[:, 2].copy()
            K_load = np.linalg.inv(J[:2, :2])
            dK = np.abs(K_load) @ dJ[:2, :2] @ np.abs(K_load)
        else:
            dK = np.abs(K) @ dJ @ np.abs(K)
        for i, a in enumerate("xy"):
            for j, b in enumerate("xy"):
                absolute[f"K_{a}{b}"] = float(dK[i, j])
    if "normal" in scene.quantities:
        forces["normal_z"] = np.array([0.0, 0.0, 1.0 / J[2, 2]])
        absolute["K_zz"] = float(dJ[2, 2] / J[2, 2] ** 2)
    record: dict[str, Any] = q.stiffness_record(forces, scene.quantities, scene.material, noise=0.0)
    record.update(
        {
            "nx": 1,
            "ny": 1,
            "dx": 2.0,
            "dy": 2.0 * e,
            "contact_cells": 1,
            "contact_area": math.pi * e,
            "absolute_errors": absolute,
            "boundary": "galin",
            "iterations": 0,
            "residual": 0.0,
            "plan": {
                "kernel_source": plan_for(scene, mirror=False).kernel_source,
                "kernels": [],
                "solves": [],
                "derived": [DERIVED],
                "operator_applications": [],
                "boundary": BOUNDARY,
            },
            "wall_time_s": time.perf_counter() - started,
        }
    )
    return record


def _inverse(J: np.ndarray) -> np.ndarray:
    """J⁻¹ after checking that J is symmetric positive definite (a compliance must be)."""
    Js = 0.5 * (J + J.T)
    if not np.allclose(J, Js, rtol=0.0, atol=1e-12 * np.max(np.abs(J))):
        raise FloatingPointError(f"the Galin compliance is not symmetric: {J}")
    if np.linalg.eigvalsh(Js).min() <= 0.0:
        raise FloatingPointError(f"the Galin compliance is not positive definite: {J}")
    return np.linalg.inv(Js)
