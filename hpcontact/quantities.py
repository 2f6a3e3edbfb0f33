"""Stiffness quantities from solved tractions (Li 2017, §2 and §3).

The tangential stiffness tensor K relates the tangential force to the rigid tangential
displacement of a bonded punch, F = K · δ (force per length, e.g. G·a units). Solving for unit
displacement along x and along y gives its two columns (Li 2017 §3.1).
"""

from __future__ import annotations

import math

import numpy as np


def resultant(traction: np.ndarray, cell_area: float) -> np.ndarray:
    """Total force per component: Σ t · cell_area over the grid (traction (c, nx, ny))."""
    return traction.reshape(traction.shape[0], -1).sum(axis=1) * cell_area


def directional_stiffness(K: np.ndarray, theta_deg: np.ndarray | float) -> np.ndarray:
    """K_nn(θ) = nᵀ K n with n = (cos θ, sin θ): stiffness along a load direction (Li 2017, eq. 6).

    ``K`` has shape (..., 2, 2); θ in degrees broadcasts against the leading axes.
    """
    K = np.asarray(K, dtype=np.float64)
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    return (
        c * c * K[..., 0, 0] + c * s * (K[..., 0, 1] + K[..., 1, 0]) + s * s * K[..., 1, 1]
    )


def rotated_tensor(K: np.ndarray, theta_deg: float) -> np.ndarray:
    """K in axes (n, t) turned by θ: K' = Rᵀ K R, R = [n t] (transformation law, Li 2017 eq. 6).

    K'[0, 0] = K_nn, K'[0, 1] = K_nt, K'[1, 0] = K_tn, K'[1, 1] = K_tt.
    """
    t = math.radians(theta_deg)
    R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    return R.T @ np.asarray(K, dtype=np.float64) @ R


def principal_stiffness(K: np.ndarray) -> tuple[float, float, float]:
    """(K_max, K_min, angle of K_max in degrees from x in [0, 180)) of the symmetric part of K."""
    sym = 0.5 * (np.asarray(K, dtype=np.float64) + np.asarray(K).T)
    values, vectors = np.linalg.eigh(sym)
    angle = math.degrees(math.atan2(vectors[1, 1], vectors[0, 1])) % 180.0
    return float(values[1]), float(values[0]), angle


def asymmetry(K: np.ndarray) -> float:
    """|K_xy − K_yx| / max(|K|): the accuracy diagnostic of a tensor that must be symmetric."""
    K = np.asarray(K, dtype=np.float64)
    return float(abs(K[0, 1] - K[1, 0]) / np.max(np.abs(K)))


def li_normalization(K_nn: np.ndarray | float, K_zz: float, E_star: float, G_star: float) -> np.ndarray | float:
    """Li's normalized stiffness K_nn E*/(K_zz G*): 1 for a circle (Li 2017 §3, eq. 9)."""
    return (K_nn / K_zz) * (E_star / G_star)  # ratios first: no overflow at G = 1e±300


def compliance_proxy(mean_displacement: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Li's uniform-traction proxy K = J⁻¹ (Li 2017 §3.2), J[i, j] = ū_i / F_j.

    ``mean_displacement[i, j]`` is the mean displacement component i over the contact under a
    uniform traction along j of total force ``force[j]``. Not the bonded stiffness: a proxy.
    """
    J = np.asarray(mean_displacement, dtype=np.float64) / np.asarray(force, dtype=np.float64)[None, :]
    return np.linalg.inv(J)
