r"""A long rigid cylinder on an anisotropic half-space and its plane-strain limit (Hwu & Fan 1998).

Plane-strain reference. Far from the ends of a long cylinder (axis along y, curvature 1/R
across it) the contact is the two-dimensional Hertz problem of a half-space whose surface
compliance for a line load is the 2-D surface Green's function: û_z = H_zz(m) p̂/|k| with m
the direction across the axis (frictionless, rigid indenter: only H_zz enters, and it is real).
With 2/E*_2D = H_zz(m) the pressure is Hertz's (Johnson 1985, §4.3, eq. 4.43 … 4.45 with E*):

    p(x) = p0 sqrt(1 − x²/a²),   a² = 4 P′ R/(π E*_2D),   p0 = 2 P′/(π a) = a E*_2D/(2 R),

P′ the load per unit length (Hwu & Fan 1998; Rodríguez-Tembleque et al. 2011, eqs. 23–24).
Two independent evaluations of E*_2D, neither through the Barnett–Lothe integrals of the 3-D
kernels:

* ``stroh_surface_green``: the Stroh eigen-solution, H = i A B⁻¹ over the three roots with
  Im p > 0 of the sextic (Ting 1996, §5.3 and §8.1; the derivation of ``kernels.anisotropic``);
  needs distinct roots (not isotropic exactly);
* ``orthotropic_plane_strain_modulus``: the closed form for an orthotropic body with a symmetry
  plane on the surface and one across the cylinder (x1 across, x3 normal, plane strain
  stiffnesses C11, C33, C13, C55; Lekhnitskii 1963, ch. 3; Delafargue & Ulm 2004, eq. 8 form):

      E*_2D = 2 sqrt( (C11 C33 − C13²)/C11 · [1/C55 + 2/(sqrt(C11 C33) + C13)]⁻¹ ),

  which is 2G/(1 − nu) for an isotropic body and equals the Stroh value to 2e-16 for the
  orthotropic body of the paper (``tests/problems/test_line_contact.py``).

Finite cylinder (``finite_cylinder``): length ``length`` with rounded ends (gap
x²/(2R) + max(|y| − length/2, 0)²/(2 R_end)) or flat ends (R_end = 0: no contact beyond the
ends, the pressure is singular at the end edges), pressed by a total load under Polonsky–Keer
on the 3-D kernel of the body (``engine.Engine``); the centre section is compared with the
plane-strain pressure of its own load per unit length.

References: C. Hwu and C. W. Fan, Proc. R. Soc. A 454 (1998) 1949 (contact of anisotropic
bodies, Stroh formalism); T. C. T. Ting, Anisotropic Elasticity, Oxford 1996; S. G. Lekhnitskii,
Theory of Elasticity of an Anisotropic Body, Holden-Day 1963; A. Delafargue and F.-J. Ulm,
Int. J. Solids Struct. 41 (2004) 7351; K. L. Johnson, Contact Mechanics, 1985.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hpcontact.errors import InputError
from hpcontact.geometry import Grid
from hpcontact.kernels.engine import Engine
from hpcontact.materials.crystal import Crystal, voigt_to_tensor
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.conjugate_gradient import polonsky_keer
from hpcontact.problems.slip.crystal_pair import PairCompliance, PairEngine


def stroh_surface_green(C6: np.ndarray, direction_deg: float) -> np.ndarray:
    """H(m) = i A B⁻¹ from the Stroh eigenvectors (Im p > 0), m at ``direction_deg`` from x."""
    C = voigt_to_tensor(C6)
    t = math.radians(direction_deg)
    m, n = np.array([math.cos(t), math.sin(t), 0.0]), np.array([0.0, 0.0, 1.0])
    Q, R, T = (np.einsum("j,ijkl,l->ik", a, C, b) for a, b in ((m, m), (m, n), (n, n)))
    Ti = np.linalg.inv(T)
    N = np.block([[-Ti @ R.T, Ti], [R @ Ti @ R.T - Q, -R @ Ti]])
    p, xi = np.linalg.eig(N)
    upper = p.imag > 0.0
    if upper.sum() != 3:
        raise InputError("stiffness", "a stiffness with three Stroh roots in the upper half plane", p.tolist())
    A = xi[:3, upper]
    B = np.stack([(R.T + root * T) @ A[:, k] for k, root in enumerate(p[upper])], axis=1)
    if np.linalg.cond(A) > 1e8:  # (nearly) repeated roots: the eigenvectors are not a basis
        raise InputError("stiffness", "distinct Stroh roots (use the Barnett-Lothe kernels near isotropy)", None)
    return 1j * A @ np.linalg.inv(B)


def plane_strain_modulus(C6: np.ndarray, direction_deg: float) -> float:
    """E*_2D = 2/H_zz(m) of the Stroh solution: the modulus of Hertz's line contact across m."""
    return 2.0 / float(stroh_surface_green(C6, direction_deg)[2, 2].real)


def orthotropic_plane_strain_modulus(C11: float, C33: float, C13: float, C55: float) -> float:
    """Closed-form E*_2D of an aligned orthotropic half-space in plane strain (module text)."""
    return 2.0 * math.sqrt((C11 * C33 - C13 * C13) / C11 / (1.0 / C55 + 2.0 / (math.sqrt(C11 * C33) + C13)))


@dataclass(frozen=True)
class CylinderContact:
    """Centre section of a finite cylinder: x (cell centres), p(x), load per length, references."""

    x: np.ndarray
    pressure: np.ndarray
    line_load: float
    half_width: float  # plane-strain a of the section's own load per length
    peak: float  # plane-strain p0 of the same
    total_load: float
    grid: Grid

    def hertz(self) -> np.ndarray:
        """Plane-strain Hertz pressure p0 sqrt(1 − x²/a²) at the section's cells."""
        return self.peak * np.sqrt(np.clip(1.0 - (self.x / self.half_width) ** 2, 0.0, None))

    def error(self) -> float:
        """max |p − p_Hertz| / p0 over the section."""
        return float(np.max(np.abs(self.pressure - self.hertz())) / self.peak)


def finite_cylinder(
    material: Isotropic | Crystal | PairCompliance,
    modulus: float,
    radius: float,
    half_width: float,
    widths: float,
    n: int,
    tol: float = 1e-10,
    end_radius: float | None = None,
    threads: int = 1,
) -> CylinderContact:
    """A rigid cylinder (or, for a ``PairCompliance``, an elastic one on an elastic flat: the
    interface compliance of both bodies) (axis y, radius ``radius``, length ``widths`` × 2·``half_width``, rounded
    ends of radius ``end_radius``, default ``radius``; 0: flat ends) on ``material``; load from the plane-strain
    estimate P′ = π a² E*/(4R) with ``modulus`` E*_2D and a = ``half_width``, times the length;
    ``n`` cells across 2a. Returns the centre section with the plane-strain reference of its own
    load per unit length (E*_2D = ``modulus``)."""
    if not (n >= 4 and widths >= 1.0 and radius > 0.0 and half_width > 0.0 and modulus > 0.0):
        raise InputError("n", "n >= 4 cells across, widths >= 1, positive radius, width and modulus", n)
    end = radius if end_radius is None else end_radius
    h = 2.0 * half_width / n
    length = widths * 2.0 * half_width
    nx = 2 * math.ceil((1.3 if end > 0.0 else 2.0) * half_width / h)  # flat ends: the contact widens there
    ny = 2 * math.ceil((0.5 * length + 2.0 * half_width) / h)
    grid = Grid(nx, ny, h, h)
    x, y = grid.centres()
    over = np.maximum(np.abs(y) - 0.5 * length, 0.0)
    if end > 0.0:
        gap = x * x / (2.0 * radius) + over * over / (2.0 * end)
    elif end == 0.0:  # flat ends: beyond them the gap is far beyond any approach of the load
        gap = x * x / (2.0 * radius) + np.where(over > 0.0, 1e3 * half_width * half_width / radius, 0.0)
    else:
        raise InputError("end_radius", "a radius >= 0 (0: flat ends)", end_radius)
    line_load = math.pi * half_width**2 * modulus / (4.0 * radius)
    total = line_load * length
    engine = (
        PairEngine(material, grid, ("zz",), threads)
        if isinstance(material, PairCompliance)
        else Engine(material, grid, ("zz",), threads)
    )
    op = engine.operator("z")
    solution = polonsky_keer(op.apply, gap, tol=tol, load=total, cell_area=grid.cell_area)
    p = solution.traction[0]
    if (p[0, :] > 0).any() or (p[-1, :] > 0).any() or (p[:, 0] > 0).any() or (p[:, -1] > 0).any():
        raise FloatingPointError("the cylinder's contact reaches the edge of its grid")
    j = ny // 2  # the two middle rows straddle y = 0 symmetrically: average them
    section = 0.5 * (p[:, j - 1] + p[:, j])
    local = float(section.sum() * h)
    a = math.sqrt(4.0 * local * radius / (math.pi * modulus))
    return CylinderContact(x[:, 0].copy(), section, local, a, 2.0 * local / (math.pi * a), total, grid)
