"""Stiffness quantities from solved tractions (Li 2017, §2 and §3).

The tangential stiffness tensor K relates the tangential force to the rigid tangential
displacement of a bonded punch, F = K · δ (force per length, e.g. G·a units). Solving for unit
displacement along x and along y gives its two columns (Li 2017 §3.1), with the normal approach
held, or the normal force held instead (a scene field, ``hpcontact.fields.NORMAL_HELD``;
:func:`load_held_stiffness`).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hpcontact.fields import LOAD_HELD_RECORD


@dataclass(frozen=True)
class Quantity:
    """What a scene may ask for (``quantities``), declared once: everything that depends on
    the quantity (validation, the cost model, the strategies of ``hpcontact.accuracy``, the
    discretizations that give it) reads this record rather than a list of its own.

    ``solves``: operator solves it costs relative to one scalar solve (the cost model's
    weight; a crystal's ``tangential`` is costed apart). ``refinable``: its discretization
    follows the contact's edge, so its grids can be refined and extrapolated. ``exact_cell``:
    Galin's one exact cell of an ellipse gives it (``discretizations/galin_ellipse.py``).
    ``singular_cells``: one scalar block per load direction, as the singular and strip cells
    of ``discretizations/boundary_cells.py`` need."""

    name: str
    meaning: str
    solves: float
    refinable: bool = False
    exact_cell: bool = False
    singular_cells: bool = False


#: The quantities a contact scene may ask for, in the order the command line lists them.
QUANTITIES: Mapping[str, Quantity] = {
    q.name: q
    for q in (
        Quantity(
            "tangential",
            "the 2 x 2 tangential stiffness tensor of the bonded punch (x and y loads)",
            solves=2.0,
            refinable=True,
            exact_cell=True,
            singular_cells=True,
        ),
        Quantity(
            "normal", "the normal stiffness K_zz", solves=1.0, refinable=True, exact_cell=True, singular_cells=True
        ),
        Quantity("compliance", "Li's uniform-traction compliance proxy (Li 2017 sec. 3.2)", solves=0.1),
        Quantity("coupled", "the 3 x 3 stiffness with normal-tangential coupling", solves=3.0, refinable=True),
        Quantity("indentation", "a rigid sphere pressed to an approach d (Polonsky-Keer)", solves=3.0),
    )
}


def names_where(test: Callable[[Quantity], bool] = lambda q: True) -> tuple[str, ...]:
    """The names of the quantities for which ``test`` holds, in ``QUANTITIES`` order."""
    return tuple(name for name, q in QUANTITIES.items() if test(q))


#: Record keys that hold a stiffness (force per unit displacement): in units of G·a, or in N/m
#: where the scene gives its contact size (:func:`in_newtons_per_metre`).
STIFFNESS_KEY = re.compile(r"(proxy_)?K_[xyz][xyz](_bonded|_coupled)?|K_max|K_min")


def in_newtons_per_metre(record: Mapping[str, Any], newtons_per_metre: float | None) -> dict[str, Any]:
    """``record`` with every stiffness (``STIFFNESS_KEY``) times ``newtons_per_metre``, what its
    unit G·a is in N/m (``Scene.newtons_per_metre``: a in m times G in Pa), those of its per-grid
    ``levels`` too; unchanged where that is None. Relative errors, ratios, normalized
    stiffnesses and angles have no unit."""
    if newtons_per_metre is None:
        return dict(record)
    out = {k: v * newtons_per_metre if STIFFNESS_KEY.fullmatch(k) and v is not None else v for k, v in record.items()}
    if isinstance(out.get("levels"), list):
        out["levels"] = [in_newtons_per_metre(level, newtons_per_metre) for level in out["levels"]]
    return out


#: Record keys that hold a length in units of a (the grid's cell sizes) or an area in units of a²
#: (the punch's contact area): in m and m² where the scene gives its contact size a in m
#: (:func:`in_metres`). A sphere's lengths are in the unit of its radius (a is refused beside an
#: indentation).
LENGTH_KEY = re.compile(r"d[xy]")
AREA_KEY = re.compile(r"contact_area")


def in_metres(record: Mapping[str, Any], metres: float | None) -> dict[str, Any]:
    """``record`` with every length in units of a (``LENGTH_KEY``) times ``metres`` (the scene's
    ``a`` in m) and every area in units of a² (``AREA_KEY``) times ``metres``², those of its
    per-grid ``levels`` too; unchanged where that is None."""
    if metres is None:
        return dict(record)

    def power(key: str, value: Any) -> int:
        """The power of a in the unit of ``value`` (0: not a length or area, or not a number)."""
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            return 0
        return 2 if AREA_KEY.fullmatch(key) else 1 if LENGTH_KEY.fullmatch(key) else 0

    out = {k: v * float(metres) ** power(k, v) if power(k, v) else v for k, v in record.items()}
    if isinstance(out.get("levels"), list):
        out["levels"] = [in_metres(level, metres) for level in out["levels"]]
    return out


def in_si_units(record: Mapping[str, Any], newtons_per_metre: float | None, metres: float | None) -> dict[str, Any]:
    """A sized scene's ``record`` in SI units: its stiffnesses in N/m (:func:`in_newtons_per_metre`,
    ``Scene.newtons_per_metre``), its lengths and areas in m and m² (:func:`in_metres`, ``Scene.a``);
    unchanged for a scene without ``a`` (both None)."""
    return in_metres(in_newtons_per_metre(record, newtons_per_metre), metres)


#: The suffix of a quantity's estimated relative error in a sweep's records and data set
#: (``K_xx_error``: ``hpcontact.accuracy.error_columns``, docs/reference/dataset.md).
ERROR_SUFFIX = "_error"

#: Stored stiffnesses that carry an estimated relative error (``<name>_error``, linked from them
#: by CF ``ancillary_variables`` in a sweep's data set): K_<ij>, K_max, K_min, K_min_over_K_max,
#: K_a_over_K_b, Li's normalized_<ij>, and their coupled and bonded variants. Principal angles
#: and the compliance proxy have none.
ESTIMATED = re.compile(r"^(K_(?!nn$)\w+|normalized_(?!nn$)\w+)$")
#: A slip sweep's computed stiffnesses: one grid each, so their ``<name>_error`` is NaN and
#: ``error_status`` 2 everywhere (the Hertz and Mindlin references are closed forms).
SLIP_ESTIMATED = re.compile(r"^((decoupled_)?(tangential|stick_area)_stiffness(_\w\w)?|no_slip_stiffness)$")


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
    return c * c * K[..., 0, 0] + c * s * (K[..., 0, 1] + K[..., 1, 0]) + s * s * K[..., 1, 1]


def directional_error(bounds: np.ndarray, theta_deg: np.ndarray | float) -> np.ndarray:
    """Bound on the error of K_nn(θ) (:func:`directional_stiffness`) from bounds B_ij ≥ |δK_ij|
    on the tensor's entries: |nᵀ δK n| ≤ c² B_xx + |c s| (B_xy + B_yx) + s² B_yy, with
    n = (c, s) = (cos θ, sin θ) (triangle inequality on the three terms of nᵀ δK n). ``bounds``
    has shape (..., 2, 2), in the units of K; θ in degrees broadcasts against the leading axes."""
    B = np.abs(np.asarray(bounds, dtype=np.float64))
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    return c * c * B[..., 0, 0] + np.abs(c * s) * (B[..., 0, 1] + B[..., 1, 0]) + s * s * B[..., 1, 1]


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


#: Noise floor of a solved tensor's entries relative to its largest (64 ulp: sums over cells).
ROUNDING = 64.0 * np.finfo(float).eps


def load_held_stiffness(K3: np.ndarray) -> np.ndarray:
    """The tangential stiffness with the normal load held (F_z = 0), from the 3 × 3 stiffness
    ``K3`` (K3[i, j]: force i per unit rigid displacement j, i, j in x y z; units of K, G·a):

        K_load = K_tt − K_tz K_zz⁻¹ K_zt = (J_tt)⁻¹,   J = K3⁻¹,

    the Schur complement of K_zz (t = x, y). Holding the approach instead (u_z = 0) gives K_tt
    itself. This is the stiffness of Cattaneo's experiment as Mindlin (1949) analysed it — a
    constant normal force, then a tangential one (Johnson 1985, Contact Mechanics, ch. 7) — for
    a body whose normal and tangential responses couple (a crystal's Re H, ``hpcontact.plan``).
    Returns the 2 × 2 array [[K_xx, K_xy], [K_yx, K_yy]].

    Raises ``FloatingPointError`` unless ``K3`` is finite and positive definite within
    round-off: the eigenvalues of its symmetric part all above ``ROUNDING`` times the largest
    (a bonded punch's stiffness is; anything else is a failed solve, and its Schur complement
    would mean nothing). Its asymmetry, CG noise of the order of the tolerance, is not refused
    here: the record's ``asymmetry`` (of the 2 × 2 result) shows it.
    """
    K3 = np.asarray(K3, dtype=np.float64)
    if K3.shape != (3, 3) or not np.isfinite(K3).all():
        raise FloatingPointError(f"3 x 3 stiffness with the normal load held: finite 3 x 3 entries needed, got {K3!r}")
    values = np.linalg.eigvalsh(0.5 * (K3 + K3.T))
    if not values[0] > ROUNDING * abs(values[-1]):
        raise FloatingPointError(
            "3 x 3 stiffness with the normal load held is not positive definite within round-off "
            f"(eigenvalues of its symmetric part {values.tolist()})"
        )
    return K3[:2, :2] - np.outer(K3[:2, 2], K3[2, :2]) / K3[2, 2]


def tensor_from_forces(forces: Mapping[str, np.ndarray], quantities: Sequence[str]) -> dict[str, float]:
    """Stiffness entries K_ij (force i per unit displacement j) from the plan's solves.

    ``forces[name]`` is the resultant force (x, y, z) of solve ``name`` (unit displacement along
    its load). ``tangential_x/y`` give K_xx … K_yy (normal approach held); with ``tangential_z``
    (the normal load held, a crystal) the three columns form the 3 × 3 Re-H stiffness and
    K_xx … K_yy are its Schur complement (:func:`load_held_stiffness`); ``coupled_x/y/z`` the 3 × 3 tensor (its
    2 × 2 block as K_ij_coupled when ``tangential`` is asked too, its K_zz as K_zz_bonded when
    ``normal`` is); ``normal_z`` K_zz. Solves the plan skipped follow from its shortcuts: a
    missing y solve is the x ↔ y mirror image of the x solve; coupled asked without coupled
    solves is nu = 0.5 (coupling exactly 0, the tangential block is the tangential tensor);
    normal asked without a normal solve is nu = 0 (K_zz = K_xx).
    """
    out: dict[str, float] = {}

    def mirrored(f: np.ndarray) -> np.ndarray:
        return np.array([f[1], f[0], f[2]])

    if "tangential_x" in forces:
        fx = forces["tangential_x"]
        fy = forces.get("tangential_y", mirrored(fx))
        if "tangential_z" in forces:  # normal load held: the Schur complement of the 3 x 3
            fx, fy = load_held_stiffness(np.column_stack([fx, fy, forces["tangential_z"]])).T
        out.update({"K_xx": fx[0], "K_yx": fx[1], "K_xy": fy[0], "K_yy": fy[1]})
    if "coupled_x" in forces:
        fx, fz = forces["coupled_x"], forces["coupled_z"]
        fy = forces.get("coupled_y", mirrored(fx))
        K3 = np.column_stack([fx, fy, fz])
        for i, a in enumerate("xyz"):
            for j, b in enumerate("xyz"):
                key = f"K_{a}{b}"
                if a != "z" and b != "z" and "tangential" in quantities:
                    key += "_coupled"
                elif key == "K_zz" and "normal" in quantities:
                    key = "K_zz_bonded"
                out[key] = K3[i, j]
    if "normal_z" in forces:
        out["K_zz"] = forces["normal_z"][2]
    elif "normal" in quantities and "tangential_x" in forces:
        out["K_zz"] = out["K_xx"]  # nu = 0
    if "coupled" in quantities and "coupled_x" not in forces:  # nu = 0.5: coupling exactly 0
        out.update({"K_xz": 0.0, "K_yz": 0.0, "K_zx": 0.0, "K_zy": 0.0})
        if "tangential" in quantities:
            out.update({f"{k}_coupled": out[k] for k in ("K_xx", "K_xy", "K_yx", "K_yy")})
        if "normal" in quantities:
            out["K_zz_bonded"] = out["K_zz"]
    return {k: float(v) for k, v in out.items()}


def derived_quantities(
    entries: Mapping[str, float], material: Any, noise: float = 0.0
) -> dict[str, float | str | None]:
    """Quantities that follow from the tensor entries (the one place they are computed).

    From the 2 × 2 block K_xx … K_yy: principal values K_max, K_min and the direction of K_max
    (``principal_angle_deg``; None — JSON null, NaN in a data set — with ``principal_angle_note`` when K_max − K_min is within the
    tensor's own accuracy max(``noise``, |K_xy − K_yx|/K, 64 eps) of K_max: such a tensor is
    isotropic and has no principal direction), ``K_a_over_K_b`` = K_xx/K_yy in the lab frame,
    ``K_min_over_K_max`` (frame-free), ``asymmetry``; with K_zz and an isotropic material, Li's
    normalization K E*/(K_zz G*) (Li 2017 eq. 9; not defined for a crystal, whose E* and G*
    depend on direction). ``noise``: relative accuracy of the entries (CG tolerance, or the
    estimated error of an extrapolation).
    """
    out: dict[str, float | str | None] = {}
    if "K_xx" not in entries:
        return out
    K2 = np.array([[entries["K_xx"], entries["K_xy"]], [entries["K_yx"], entries["K_yy"]]])
    k_max, k_min, angle = principal_stiffness(K2)
    skew = asymmetry(K2)
    if k_max - k_min <= max(noise, skew, ROUNDING) * abs(k_max):
        angle = None
        out["principal_angle_note"] = "tensor isotropic within its accuracy: no principal direction"
    out.update({"K_max": k_max, "K_min": k_min, "principal_angle_deg": angle})
    out["K_a_over_K_b"] = float(K2[0, 0] / K2[1, 1])
    out["K_min_over_K_max"] = float(k_min / k_max)
    out["asymmetry"] = skew
    if "K_zz" in entries and hasattr(material, "E_star"):
        out["normalized_xx"] = float(li_normalization(K2[0, 0], entries["K_zz"], material.E_star, material.G_star))
        out["normalized_yy"] = float(li_normalization(K2[1, 1], entries["K_zz"], material.E_star, material.G_star))
    return out


def stiffness_record(
    forces: Mapping[str, np.ndarray], quantities: Sequence[str], material: Any, noise: float = 0.0
) -> dict[str, float | str | None]:
    """Tensor entries and every quantity derived from them, from the solves' resultant forces
    (:func:`tensor_from_forces`, then :func:`derived_quantities`): used by ``solve`` and by the
    coverage-weighted solves of ``accuracy`` alike. With a ``tangential_z`` solve (a crystal
    whose tangential stiffness holds the normal load) K_xx … K_yy hold it
    (:func:`load_held_stiffness`) and the record says so (``fields.LOAD_HELD_RECORD``)."""
    entries = tensor_from_forces(forces, quantities)
    record: dict[str, float | str | None] = {**entries, **derived_quantities(entries, material, noise)}
    if "tangential_z" in forces:
        record.update(LOAD_HELD_RECORD)
    return record
