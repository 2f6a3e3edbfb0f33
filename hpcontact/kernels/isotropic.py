"""Influence coefficients of an isotropic half-space for uniform traction on rectangular cells.

Displacement component i at a cell centre due to unit traction component j on a cell at offset
(target − source) = (x, y) (Johnson 1985, §3.2 eq. 3.19–3.20 and §3.6 for Boussinesq and Cerruti;
Love 1929 for the rectangle), with the cell integrals of ``kernels.cells``:

    xx: [(1−nu) I1 + nu Ixx] / (2πG)        yy: [(1−nu) I1 + nu Iyy] / (2πG)
    xy = yx: nu Ixy / (2πG)                  zz: (1−nu) I1 / (2πG)
    xz: −(1−2nu) Ix / (4πG)   yz: −(1−2nu) Iy / (4πG)    (surface moves toward a pressing load)
    zx: +(1−2nu) Ix / (4πG)   zy: +(1−2nu) Iy / (4πG)

Units: displacement per traction (length / stress); I* carry units of length.
Blocks are returned on the centred offset grid of shape (2nx−1, 2ny−1): entry [nx−1+p, ny−1+q]
is the coefficient for offset (p dx, q dy).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from hpcontact.kernels.cell_integrals import PARITY, quadrant_integrals
from hpcontact.materials.isotropic import Isotropic

BLOCKS = ("xx", "xy", "yx", "yy", "zz", "xz", "yz", "zx", "zy")


@lru_cache(maxsize=16)
def _centred_integral(nx: int, ny: int, dx: float, dy: float, name: str) -> np.ndarray:
    """One geometric cell integral mirrored from the first quadrant to all offsets (read-only)."""
    quadrant = quadrant_integrals(nx, ny, dx, dy, [name])[name]
    px, py = PARITY[name]
    full = np.empty((2 * nx - 1, 2 * ny - 1))
    full[nx - 1 :, ny - 1 :] = quadrant
    full[: nx - 1, ny - 1 :] = px * quadrant[:0:-1, :]
    full[:, : ny - 1] = py * full[:, 2 * ny - 2 : ny - 1 : -1]
    full.setflags(write=False)
    return full


def isotropic_block(material: Isotropic, nx: int, ny: int, dx: float, dy: float, block: str) -> np.ndarray:
    """Influence coefficients of one block (e.g. ``"xx"``) on the centred offset grid."""
    if block not in BLOCKS:
        raise ValueError(f"unknown block {block!r}; expected one of {BLOCKS}")
    G, nu = material.G, material.nu

    def integral(name: str) -> np.ndarray:
        return _centred_integral(nx, ny, float(dx), float(dy), name)

    if block == "zz":
        return (1.0 - nu) / (2.0 * math.pi * G) * integral("one_over_r")
    if block in ("xx", "yy"):
        one = (1.0 - nu) / (2.0 * math.pi * G) * integral("one_over_r")
        if nu == 0.0:
            return one
        return one + nu / (2.0 * math.pi * G) * integral("xx_over_r3" if block == "xx" else "yy_over_r3")
    if block in ("xy", "yx"):
        return nu / (2.0 * math.pi * G) * integral("xy_over_r3")
    sign = -1.0 if block[1] == "z" else 1.0
    name = "x_over_r2" if "x" in block else "y_over_r2"
    return sign * (1.0 - 2.0 * nu) / (4.0 * math.pi * G) * integral(name)


def isotropic_surface_green(material: Isotropic, phi: np.ndarray) -> np.ndarray:
    """H(m) of û = H f̂/|k| for m = (cos φ, sin φ) (docs/design.md §2.1; units 1/stress), (..., 3, 3).

    Tangential block (I − nu m mᵀ)/G, normal (1 − nu)/G, coupling H_xz = +i(1−2nu) m_x/(2G),
    H_zx = −i(1−2nu) m_x/(2G) (signs fixed against the real-space Boussinesq–Cerruti blocks).
    """
    G, nu = material.G, material.nu
    m = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    H = np.zeros(np.shape(phi) + (3, 3), dtype=np.complex128)
    H[..., :2, :2] = (np.eye(2) - nu * m[..., :, None] * m[..., None, :]) / G
    H[..., 2, 2] = (1.0 - nu) / G
    H[..., :2, 2] = 1j * (1.0 - 2.0 * nu) * m / (2.0 * G)
    H[..., 2, :2] = -1j * (1.0 - 2.0 * nu) * m / (2.0 * G)
    return H
