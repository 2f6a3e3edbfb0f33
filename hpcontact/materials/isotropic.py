"""Isotropic elastic materials and the moduli that the references use.

G is the shear modulus (any consistent stress unit; dimensionless G = 1 by default), nu the
Poisson ratio in (−1, 0.5] (``NU_RANGE``). E* = 2G/(1−nu) and G* = 4G/(2−nu) are the effective moduli of one
elastic body against a rigid one (Li 2017, §3; Johnson 1985, §4.2 and §7.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hpcontact.errors import InputError

#: The Poisson ratio of an isotropic body, the one statement of its range (``hpcontact.scene``
#: and the command line's help import it): nu = −1 (zero bulk modulus) is refused, nu = 0.5
#: (incompressible) allowed, its closed-form kernels hold. A crystal's stiffness needs
#: nu < 0.5 (``crystal.CRYSTAL_NU_RANGE``).
NU_RANGE = "Poisson ratio in (-1, 0.5]"
#: Moduli (G, E, a crystal's constants, in the scene's stress unit) within 1e-100 … 1e100: the
#: solver's arithmetic stays finite and normal there. Kernels scale as h/G (cells h down to
#: ~1e-16 a at b/a = 1e-12), CG inner products as N h^k G^±1 over up to 2**26 cells, and the
#: Barnett–Lothe kernel forms 3 x 3 Christoffel determinants, cubes of the constants: at
#: 1e±100 these are ~1e±300 at worst, inside float64's 1e-308 … 1.8e308 (measured: G = 1e300
#: fails on a 1024 grid, a crystal at 1e±290 on any grid).
MIN_MODULUS = 1e-100
MAX_MODULUS = 1e100


def modulus_range(what: str = "modulus") -> str:
    """The allowed range of a modulus in words (``MIN_MODULUS`` … ``MAX_MODULUS``)."""
    return f"{what} in [{MIN_MODULUS:g}, {MAX_MODULUS:g}] (finite arithmetic in the solver)"


def modulus(field: str, value: float, what: str = "modulus") -> float:
    """``value`` (a finite float > 0) if within ``MIN_MODULUS`` … ``MAX_MODULUS``, else
    ``InputError`` naming ``field`` and the range."""
    if not MIN_MODULUS <= value <= MAX_MODULUS:
        raise InputError(field, modulus_range(what), value)
    return value


@dataclass(frozen=True)
class Isotropic:
    """Isotropic linear elastic half-space with shear modulus ``G`` and Poisson ratio ``nu``."""

    G: float = 1.0
    nu: float = 0.3

    def __post_init__(self) -> None:
        if not (math.isfinite(self.G) and self.G > 0.0):
            raise InputError("G", "a finite shear modulus > 0", self.G)
        if not (math.isfinite(self.nu) and -1.0 < self.nu <= 0.5):
            raise InputError("nu", NU_RANGE, self.nu)

    @property
    def E_star(self) -> float:
        """Indentation modulus against a rigid body, E* = 2G/(1−nu)."""
        return 2.0 * self.G / (1.0 - self.nu)

    @property
    def G_star(self) -> float:
        """Tangential modulus against a rigid body, G* = 4G/(2−nu)."""
        return 4.0 * self.G / (2.0 - self.nu)

    @property
    def key(self) -> tuple:
        """Hashable identity for kernel caches."""
        return ("isotropic", self.G, self.nu)
