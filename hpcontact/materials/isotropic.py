"""Isotropic elastic materials and the moduli that the references use.

G is the shear modulus (any consistent stress unit; dimensionless G = 1 by default), nu the
Poisson ratio in (−1, 0.5] (``NU_RANGE``). E* = 2G/(1−nu) and G* = 4G/(2−nu) are the effective moduli of one
elastic body against a rigid one (Li 2017, §3; Johnson 1985, §4.2 and §7.1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hpcontact.errors import InputError

# The Poisson ratio's range (nu = 0.5 allowed: the closed-form kernels hold; a crystal needs
# nu < 0.5, ``crystal.CRYSTAL_NU_RANGE``) and the moduli's are stated once, in the field schema.
from hpcontact.fields import MAX_MODULUS, MIN_MODULUS, NU_RANGE, modulus_range


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
