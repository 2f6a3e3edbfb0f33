r"""Interface compliance of two bodies either of which may be anisotropic (crystal, orthotropic, 6 × 6).

Conventions (docs/design.md §2, ``hpcontact.problems.slip.bodies``): body 1 fills z > 0 and carries the traction
t = (t_x, t_y, p) (p > 0 presses into it); body 2 fills z < 0 and carries −t. The contact
conditions see the relative surface displacement u = u_1 − u_2 (u_z positive into body 1, so
the gap closes by u_z).

Body 2, the same lattice in the lab. Body 2's stiffness C_2 is given in the lab frame, like
body 1's (identical fields: one crystal cut along the interface). Reflected through the surface,
P = diag(1, 1, −1), body 2 becomes an upper half-space with stiffness P C_2 P carrying
f′ = P(−t) (its pressure presses into it), and −u_2(x) = P G_{P C_2 P}(x − ξ) P t. The
reflected Green's function is the conjugate, P H_{P C P}(m) P = conj H_C(m) = H_C(−m)
(``tests/test_conventions.py``), so

    u_1 − u_2 = [G_1(r) + G_2(−r)] * t,        H_pair(φ) = H_1(φ) + H_2(φ + π),

with G_2, H_2 the kernels body 2 would have as an upper half-space. For two isotropic bodies this
is A_1 + A_2 for xx xy yy zz and A_1 − A_2 for the odd coupling blocks (``bodies``); two
identical crystals give 2 Re H, the per-body ``Re H`` of ``hpcontact.kernels.engine``. On the grid,
G_2(−r) is the centred coefficient array of body 2 reversed along both offset axes (cells are
centrally symmetric).

Coupling. The coupling blocks vanish when body 2's cancel body 1's — two isotropic bodies with
(1 − 2nu)/G equal, or two identical bodies whose H_xz, H_yz are imaginary (a mirror plane
z = 0 of the lattice, e.g. the orthotropic pair of Rodríguez-Tembleque et al. 2011, §6.2, with
its axes on the lab axes). Its size is

    coupling_size = max_φ |(H_xz, H_yz)(φ)| / max_φ H_zz(φ),

which for isotropic pairs is Dundurs' |β| (H_xz = i c m_x/2 with c = Σ ±(1 − 2nu_i)/G_i and
H_zz = Σ (1 − nu_i)/G_i). Below ``bodies.SIMILARITY_TOL`` the pair is treated as similar.

Hertz estimate (contact grid sizing only): E* from the indentation moduli of the bodies
(Vlassak & Nix 1994), 1/E* = Σ 1/M_i, M = 2/⟨H_zz⟩ over directions; exact for isotropic bodies.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from types import ModuleType
from typing import Any

import numpy as np

from hpcontact.geometry import Grid
from hpcontact.kernels.anisotropic import anisotropic_offset_blocks, indentation_modulus, surface_green_fourier
from hpcontact.kernels.engine import Engine
from hpcontact.kernels.isotropic import isotropic_block, isotropic_surface_green
from hpcontact.materials.crystal import Crystal
from hpcontact.materials.elastic_constants import CONSTANT_FIELDS, anisotropic_material, describes_crystal
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics.convolution import COMPONENT_INDEX
from hpcontact.problems.slip.bodies import SIMILARITY_TOL, Body, Pair, isotropic_pair

Material = Isotropic | Crystal
#: Crystal constants are given in GPa (``elastic_constants``); pairs (slip scenes) are in SI units.
GPA = 1e9
#: In-plane directions sampled for the coupling size (H is a trigonometric series of low degree
#: for the materials met; 256 directions resolve its maximum to < 1e-4 relative).
N_DIRECTIONS = 256


def _scaled(material: Material | None, G_ref: float, angle_deg: float) -> Material | None:
    if material is None:
        return None
    if isinstance(material, Isotropic):
        return Isotropic(G=material.G / G_ref, nu=material.nu)
    crystal = Crystal(material.voigt / G_ref, material.name, material.citation)
    if angle_deg == 0.0:
        return crystal
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    return crystal.rotated(np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]))


def shear_modulus(material: Material) -> float:
    """G of an isotropic body; the mean shear stiffness (C44 + C55 + C66)/3 of a crystal (lab frame)."""
    if isinstance(material, Isotropic):
        return material.G
    return float(np.trace(material.voigt[3:, 3:])) / 3.0


def surface_green(material: Material, phi: np.ndarray) -> np.ndarray:
    """H(m(φ)) of one body as an upper half-space (lab-frame stiffness), shape (len(φ), 3, 3)."""
    if isinstance(material, Isotropic):
        return isotropic_surface_green(material, phi)
    return surface_green_fourier(material, phi)


#: ``PairCompliance.coupling_size`` by the pair's key (its bodies' exact lab-frame stiffnesses):
#: a sweep's cost model asks it of every task (``sweep.cost.task_cost``, ``sweep.cost.engine``)
#: and the solve again, the same for every load, friction and q_ratio of one pair (the
#: Barnett–Lothe integrals at 256 directions: 0.24 CPU s for each of the 7 pairs of
#: jobs/tembleque2011_friction.toml; jobs/crystal_friction_map.toml asks 84 times of 21 pairs, its
#: enumeration 1.84 → 0.45 CPU s; 2026-11-29, 2-core VM). A float per pair, a few per process.
_COUPLING_SIZES: dict[tuple, float] = {}


@dataclass(frozen=True, eq=False)
class PairCompliance:
    """H_pair and the cell blocks of u_1 − u_2 for two bodies (None: rigid), in one stress unit."""

    body1: Material | None
    body2: Material | None

    @property
    def key(self) -> tuple:
        """Hashable identity for the spectrum cache."""
        return ("pair",) + tuple("rigid" if m is None else m.key for m in (self.body1, self.body2))

    def fourier(self, phi: np.ndarray) -> np.ndarray:
        """H_pair(φ) = H_1(φ) + H_2(φ + π) (complex, shape (len(φ), 3, 3))."""
        phi = np.asarray(phi, dtype=np.float64)
        H = np.zeros(phi.shape + (3, 3), dtype=np.complex128)
        if self.body1 is not None:
            H += surface_green(self.body1, phi)
        if self.body2 is not None:
            H += surface_green(self.body2, phi + np.pi)
        return H

    def blocks(
        self, nx: int, ny: int, dx: float, dy: float, names: tuple[str, ...], threads: int = 1
    ) -> dict[str, np.ndarray]:
        """Centred cell coefficients (2nx − 1, 2ny − 1) of the blocks ``names`` (e.g. "xz")."""
        out = {name: np.zeros((2 * nx - 1, 2 * ny - 1)) for name in names}
        for material, reversed_ in ((self.body1, False), (self.body2, True)):
            if material is None:
                continue
            own = _own_blocks(material, nx, ny, dx, dy, names, threads)
            for name in names:
                out[name] += own[name][::-1, ::-1] if reversed_ else own[name]
        return out

    def coupling_size(self) -> float:
        """max_φ |(H_xz, H_yz)| / max_φ H_zz (Dundurs' |β| for isotropic pairs), once per pair
        and process (``_COUPLING_SIZES``)."""
        key = self.key
        if key not in _COUPLING_SIZES:
            phi = np.arange(N_DIRECTIONS) * (2.0 * np.pi / N_DIRECTIONS)
            H = self.fourier(phi)
            _COUPLING_SIZES[key] = float(
                np.sqrt(np.abs(H[:, 0, 2]) ** 2 + np.abs(H[:, 1, 2]) ** 2).max() / H[:, 2, 2].real.max()
            )
        return _COUPLING_SIZES[key]


def _own_blocks(
    material: Material, nx: int, ny: int, dx: float, dy: float, names: tuple[str, ...], threads: int
) -> dict[str, np.ndarray]:
    if isinstance(material, Isotropic):
        return {name: isotropic_block(material, nx, ny, dx, dy, name) for name in names}
    pairs = [(COMPONENT_INDEX[n[0]], COMPONENT_INDEX[n[1]]) for n in names]
    blocks = anisotropic_offset_blocks(material, nx, ny, dx, dy, pairs, threads=threads)
    return {name: blocks[p] for name, p in zip(names, pairs)}


@dataclass(frozen=True)
class AnisotropicPair(Pair):
    """A ``bodies.Pair`` at least one of whose bodies is a crystal (``Crystal``, both in the lab
    frame, see the module text). Geometry (curvatures, Hertz ellipse) as ``Pair``."""

    @property
    def compliance(self) -> PairCompliance:
        return PairCompliance(self.body1.material, self.body2.material)

    @property
    def reference_modulus(self) -> float:
        """G_ref = 1/Σ 1/G_i with G of ``shear_modulus`` (= G_eq of ``Pair`` for isotropic bodies)."""
        return 1.0 / sum(1.0 / shear_modulus(b.material) for b in (self.body1, self.body2) if b.material is not None)

    @cached_property
    def E_star(self) -> float:
        """1/E* = Σ 1/M_i, M_i the indentation modulus (Vlassak & Nix 1994); the Hertz estimate."""
        return 1.0 / sum(1.0 / _indentation(b.material) for b in (self.body1, self.body2) if b.material is not None)

    @cached_property
    def coupling_size(self) -> float:
        """``PairCompliance.coupling_size`` (|β| for isotropic bodies)."""
        return self.compliance.coupling_size()

    @property
    def similar(self) -> bool:
        """The coupling blocks vanish (coupling_size below ``SIMILARITY_TOL``)."""
        return self.coupling_size <= SIMILARITY_TOL

    def scaled(self, G_ref: float, angle_deg: float = 0.0) -> PairCompliance:
        """The pair's compliance with stresses in units of ``G_ref``, seen in the frame turned by
        ``angle_deg`` about the normal from the lab (the contact grid's frame: its x axis at
        ``angle_deg`` from lab x; crystals rotated, C′ = R⁴C with rows of R the grid axes)."""
        return PairCompliance(*(_scaled(b.material, G_ref, angle_deg) for b in (self.body1, self.body2)))


def pair_from_params(p: Mapping[str, Any]) -> Pair:
    """The pair named by solver fields (the names of ``hpcontact solve``): ``crystal_pair`` where
    the fields make a body a crystal (``elastic_constants.describes_crystal``), else
    ``bodies.isotropic_pair``."""
    return crystal_pair(p) if describes_crystal(p) else isotropic_pair(p)


def crystal_pair(p: Mapping[str, Any]) -> AnisotropicPair:
    """The pair of solver fields ``p`` (``pair_from_params``) with a crystal in place of each
    body whose fields describe one (``elastic_constants.anisotropic_material``: "crystal:NAME",
    ``anisotropy`` ≠ 1 with nu and G or E, ``cubic``, ``orthotropic``, ``voigt``; GPa, converted to
    SI; both in the lab frame). Geometry and the isotropic partner come from ``bodies.isotropic_pair``."""
    crystals = [anisotropic_material(p, suffix, GPA, library=False) for suffix in ("", "2")]
    if crystals == [None, None]:
        raise ValueError("crystal_pair: no crystal among the fields")  # callers check describes_crystal
    iso = {k: v for k, v in p.items() if k.rstrip("2") not in CONSTANT_FIELDS}
    for suffix, c in zip(("", "2"), crystals):
        if c is not None:  # the crystal replaces the isotropic description of this body
            for name in ("material", "E", "G", "nu"):
                iso.pop(f"{name}{suffix}", None)
    if crystals[1] is not None:
        iso["G2"] = 1.0  # a placeholder elastic body 2 (not rigid), replaced below
    base = isotropic_pair(iso)
    bodies = [
        b if c is None else Body(c, b.radius_a, b.radius_b, b.angle_deg)
        for b, c in zip((base.body1, base.body2), crystals)
    ]
    return AnisotropicPair(*bodies)


def _indentation(material: Material) -> float:
    if isinstance(material, Isotropic):
        return material.E_star
    return indentation_modulus(material)


class PairEngine(Engine):
    """``engine.Engine`` on the pair's compliance: spectra and operators of u_1 − u_2 (scaled units),
    the operators on arrays of ``xp`` (numpy: pyFFTW; CuPy on a GPU)."""

    def __init__(
        self,
        compliance: PairCompliance,
        grid: Grid,
        kernels: tuple[str, ...],
        threads: int = 1,
        xp: ModuleType = np,
    ) -> None:
        super().__init__(compliance, grid, kernels, threads, xp)  # type: ignore[arg-type]
        self._blocks: dict[str, np.ndarray] | None = None

    def centred_block(self, block: str) -> np.ndarray:
        """The pair's coefficients of ``block`` (every planned block built in one pass)."""
        if self._blocks is None:
            g = self.grid
            self._blocks = self.material.blocks(g.nx, g.ny, g.dx, g.dy, self.kernels, self.threads)
        return self._blocks[block]

    def surface_green(self, phi: np.ndarray, green: str = "H") -> np.ndarray:
        """H_pair(φ) (``green`` "H"; "Re H" its real part, as ``engine.Engine``)."""
        H = self.material.fourier(phi)
        return H if green == "H" else H.real.astype(np.complex128)
