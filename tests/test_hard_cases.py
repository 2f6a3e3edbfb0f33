"""Hard cases stay numerically stable (docs/design.md §1, second demand; issue 4, item 4).

Thin contacts down to b/a = 1e-10, nu at both ends of its range, moduli 21 decades apart,
contacts of one and two cells, and masks that touch the edge of their array: every result finite,
converging where a grid is refined, and equal to what theory says it must be. Warnings are errors
and numpy floating-point errors raise inside the solves (``np.errstate(all="raise")``), so a
silent overflow, division by zero or invalid operation fails the test instead of leaving a NaN.

Every tolerance states its source: a closed form's rounding, a measured value with a margin,
or the acceptance target of the issue.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hpcontact import analytic
from hpcontact.geometry import mask_grid
from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.problems.contact import solve
from hpcontact.scene import Scene

pytestmark = pytest.mark.filterwarnings("error")

THIN = (1e-8, 1e-10)
SHAPES_ANY = (
    {"shape": "ellipse", "aspect": 0.1},
    {"shape": "rectangle", "aspect": 0.3},
    {"shape": "polygon", "sides": 5},
    {"shape": "star", "sides": 4, "amplitude": 0.3},
    {"shape": "ellipse", "aspect": 0.4, "shape_angle": 27.0},
)


def strict_solve(params: dict) -> dict:
    """``solve`` with numpy floating-point errors raised, and every float in the record finite."""
    with np.errstate(all="raise"):
        record = solve(Scene.from_params(params))
    for key, value in record.items():
        if isinstance(value, float):
            assert math.isfinite(value), f"{key} = {value}"
    return record


def tensor(record: dict) -> np.ndarray:
    return np.array([[record["K_xx"], record["K_xy"]], [record["K_yx"], record["K_yy"]]])


def assert_spd(record: dict) -> None:
    """The tangential tensor is symmetric (to the CG tolerance) and positive definite."""
    K = tensor(record)
    assert record["asymmetry"] < 1e-6  # CG tol 1e-8 on the residual; measured ≤ 1e-9
    assert np.all(np.linalg.eigvalsh(0.5 * (K + K.T)) > 0.0)


# ------------------------------------------------------------------------------------------
# thin contacts
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("aspect", THIN)
@pytest.mark.parametrize("nu", [0.3, 0.5])
def test_thin_ellipse_within_0p1_percent_of_mindlin(aspect: float, nu: float) -> None:
    """K_xx, K_yy, K_zz and K_a/K_b within 0.1 % of Mindlin on a 32 × 32 grid (0.06 s).

    Cheapest grid found (issue 4): across the ellipse, 32 cells are needed for K_xx and K_yy
    (n_across = 8, 16, 24 leave 1.3e-3 … 2.9e-3 for n = 16 … 48), while along it 16 … 32 cells
    suffice; K_a/K_b is within 0.1 % already on 16 × 8 (errors cancel in the ratio). Measured on
    32 × 32: K_xx 3.4e-4 (1e-8, nu 0.3 and 0.5), 2.8e-4 (1e-10); K_a/K_b 1.21e-5, 2.45e-5 (1e-8),
    8.0e-6, 1.62e-5 (1e-10), asserted at the README's "≤ 2.5e-5" (+ half a unit). Staircase
    noise makes a smaller grid pass by luck (16 × 16: 2.5e-4), so the test sits on 32 × 32,
    where neighbouring grids (16 × 32, 24 × 32) pass too (5.7e-4, 5.8e-4).
    """
    r = strict_solve(
        {"shape": "ellipse", "aspect": aspect, "nu": nu, "n": 32, "n_across": 32, "quantities": "tangential,normal"}
    )
    K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
    K_zz = analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu)
    ratio = analytic.mindlin_ellipse_stiffness_ratio(aspect, nu)
    assert abs(r["K_xx"] / K_a - 1.0) < 1e-3  # issue target 0.1 %
    assert abs(r["K_yy"] / K_b - 1.0) < 1e-3
    assert abs(r["K_zz"] / K_zz - 1.0) < 1e-3
    assert abs(r["K_a_over_K_b"] / ratio - 1.0) < 2.55e-5  # README: K_a/K_b error ≤ 2.5e-5
    assert_spd(r)


@pytest.mark.parametrize("aspect", THIN)
def test_thin_ellipse_error_falls_under_refinement(aspect: float) -> None:
    """Error against Mindlin falls by ≥ 2 when both n and n_across grow fourfold (8 → 32).

    Measured (nu = 0.5): K_xx error 2.0e-3 (1e-8) and 1.6e-3 (1e-10) on 8 × 8, 3.4e-4 and 2.8e-4
    on 32 × 32. A factor 4 in both directions, not 2, because the staircase error is not
    monotone in n.
    """
    K_a, _ = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, 0.5)
    errors = []
    for n in (8, 32):
        r = strict_solve({"shape": "ellipse", "aspect": aspect, "nu": 0.5, "n": n, "n_across": n})
        errors.append(abs(r["K_xx"] / K_a - 1.0))
    assert errors[1] < 0.5 * errors[0]


@pytest.mark.parametrize("aspect", THIN)
@pytest.mark.parametrize("nu", [0.3, 0.5])
def test_thin_rectangle_converges_at_first_order(aspect: float, nu: float) -> None:
    """Rectangle b/a = 1e-8, 1e-10 (no closed form): successive differences halve.

    The rectangle is meshed exactly (its edges are cell faces), so the error is a smooth O(h)
    edge-layer term: measured differences of K_xx for grids 8×4 → 16×8 → 32×16 → 64×32 are
    1.1e-3, 5.8e-4, 3.0e-4 (ratios 1.96, 1.96); the test asks for ratios in [1.7, 2.3]. K_a/K_b
    changes by < 2e-4 (relative) between the finest two (measured 2.3e-5 … 7.2e-5).
    """
    grids = ((8, 4), (16, 8), (32, 16), (64, 32))
    records = [
        strict_solve(
            {
                "shape": "rectangle",
                "aspect": aspect,
                "nu": nu,
                "n": n,
                "n_across": na,
                "quantities": "tangential,normal",
            }
        )
        for n, na in grids
    ]
    for key in ("K_xx", "K_yy", "K_zz"):
        values = [r[key] for r in records]
        d = np.abs(np.diff(values))
        assert np.all(d[:-1] / d[1:] > 1.7) and np.all(d[:-1] / d[1:] < 2.3), (key, d)
    assert abs(records[-1]["K_a_over_K_b"] / records[-2]["K_a_over_K_b"] - 1.0) < 2e-4
    for r in records:
        assert_spd(r)
        assert r["K_a_over_K_b"] > 1.0 - nu  # the thin-strip limit is approached from above


@pytest.mark.parametrize("shape", ["rectangle", "ellipse"])
@pytest.mark.parametrize("nu", [0.3, 0.5])
def test_ratio_is_monotone_in_aspect(shape: str, nu: float) -> None:
    """K_a/K_b decreases strictly as b/a goes 1e-1 → 1e-12 and stays above 1 − nu.

    Mindlin: K_a/K_b = (1 − nu) + nu(2 − nu)/(ln(4/γ) − nu) + …, decreasing in ln(1/γ). The
    smallest step, 1e-10 → 1e-12, is 3.4e-3 (nu = 0.3) and 5.1e-3 (nu = 0.5), measured; the
    ellipse's grid error on 32 × 16 there is ≤ 9e-5 (≤ 2.1e-3 at b/a = 0.1, where the step is
    0.06), so the order tested is the physics, not the grid.
    """
    aspects = (1e-1, 1e-2, 1e-4, 1e-6, 1e-8, 1e-10, 1e-12)
    ratios = [
        strict_solve({"shape": shape, "aspect": a, "nu": nu, "n": 32, "n_across": 16})["K_a_over_K_b"] for a in aspects
    ]
    assert np.all(np.diff(ratios) < 0.0), ratios
    assert ratios[-1] > 1.0 - nu


# ------------------------------------------------------------------------------------------
# Poisson ratio at the ends of its range
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("params", SHAPES_ANY, ids=lambda p: p["shape"] + str(p.get("shape_angle", "")))
def test_nu_zero_is_exactly_isotropic(params: dict) -> None:
    """At nu = 0 the x and y problems share one scalar operator (xx = yy = I1/(2πG), xy = 0):
    K_xx = K_yy and K_xy = K_yx = 0 for any shape, to rounding (measured: bit-identical).

    Bound 1e-13 relative: two scalar CG runs on the same operator with the same right-hand side
    differ at most by the order of summation.
    """
    r = strict_solve({**params, "nu": 0.0, "n": 64})
    assert abs(r["K_xx"] - r["K_yy"]) <= 1e-13 * r["K_xx"]
    assert r["K_xy"] == 0.0 and r["K_yx"] == 0.0
    assert r["K_a_over_K_b"] == pytest.approx(1.0, abs=1e-13)
    assert abs(r["K_max"] - r["K_min"]) <= 1e-13 * r["K_max"]


def test_nu_half_is_finite_and_matches_closed_forms() -> None:
    """nu = 0.5 (incompressible; E* = 4G, G* = 8G/3): circle K_xx = 16G/3·a and K_zz = 8Ga within
    0.5 % at n = 128 (measured 8.6e-4 and 9.0e-4), coupled = tangential + normal exactly."""
    r = strict_solve({"shape": "circle", "nu": 0.5, "n": 128, "quantities": "tangential,normal,coupled"})
    assert abs(r["K_xx"] / analytic.circle_tangential_stiffness(1.0, 1.0, 0.5) - 1.0) < 5e-3
    assert abs(r["K_zz"] / analytic.circle_normal_stiffness(1.0, 1.0, 0.5) - 1.0) < 5e-3
    for key in ("K_xz", "K_yz", "K_zx", "K_zy"):
        assert r[key] == 0.0  # (1 − 2 nu) = 0: coupling vanishes identically
    assert_spd(r)


# ------------------------------------------------------------------------------------------
# huge and tiny moduli
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("G", [1e-9, 1e12])
@pytest.mark.parametrize(
    "params", [{"shape": "circle"}, {"shape": "ellipse", "aspect": 1e-8, "n_across": 16}], ids=["circle", "ellipse1e-8"]
)
def test_stiffness_scales_exactly_with_G(G: float, params: dict) -> None:
    """K(G) = G·K(1): the operator is (1/G)·(G-free integrals), the preconditioner G·(…), so
    conjugate gradients take the same steps up to the rounding of G's factors.

    Bound 1e-12 relative at CG tol 1e-12: rounding perturbs the iterates, and K moves by about
    its CG truncation error (measured 2e-13 at tol 1e-12; 3.5e-12 at the default tol 1e-8, where
    K itself is only converged to ~3e-12).
    """
    base = {**params, "nu": 0.3, "n": 64, "quantities": "tangential,normal", "tol": 1e-12}
    one = strict_solve({**base, "G": 1.0})
    scaled = strict_solve({**base, "G": G})
    for key in ("K_xx", "K_yy", "K_zz", "K_max", "K_min"):
        assert scaled[key] / G == pytest.approx(one[key], rel=1e-12), key
    assert scaled["K_a_over_K_b"] == pytest.approx(one["K_a_over_K_b"], rel=1e-12)
    assert scaled["normalized_xx"] == pytest.approx(one["normalized_xx"], rel=1e-12)
    assert scaled["iterations"] == one["iterations"]


@pytest.mark.parametrize("G", [2.0**-30, 2.0**40])
def test_power_of_two_moduli_scale_bit_for_bit(G: float) -> None:
    """With G a power of two every factor of G is exact, so K(G)/G equals K(1) bit for bit."""
    base = {"shape": "ellipse", "aspect": 0.2, "nu": 0.3, "n": 64, "quantities": "tangential,normal"}
    one = strict_solve({**base, "G": 1.0})
    scaled = strict_solve({**base, "G": G})
    for key in ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz"):
        assert scaled[key] / G == one[key], key


# ------------------------------------------------------------------------------------------
# one- and two-cell contacts
# ------------------------------------------------------------------------------------------
def _mask_file(tmp_path: Path, mask: np.ndarray, name: str = "mask.npy") -> str:
    path = tmp_path / name
    np.save(path, mask)
    return str(path)


def _dense_stiffness(mask: np.ndarray, nu: float) -> dict[str, float]:
    """K from the dense influence matrix of the mask's cells: K = h² 1ᵀ A⁻¹ 1 per component
    (x: the xx/xy/yx/yy blocks together; z: zz), solved with numpy."""
    grid = mask_grid(mask)
    material = Isotropic(1.0, nu)
    nx, ny = mask.shape
    cells = np.argwhere(mask)
    offsets = cells[:, None, :] - cells[None, :, :]  # target − source

    def block(name: str) -> np.ndarray:
        b = isotropic_block(material, nx, ny, grid.dx, grid.dy, name)
        return b[nx - 1 + offsets[..., 0], ny - 1 + offsets[..., 1]]

    m = len(cells)
    A = np.block([[block("xx"), block("xy")], [block("yx"), block("yy")]])
    area = grid.cell_area
    out = {}
    for j, key in enumerate(("x", "y")):
        rhs = np.zeros(2 * m)
        rhs[j * m : (j + 1) * m] = 1.0
        t = np.linalg.solve(A, rhs)
        out[f"K_x{key}"] = float(t[:m].sum() * area)
        out[f"K_y{key}"] = float(t[m:].sum() * area)
    out["K_zz"] = float(np.linalg.solve(block("zz"), np.ones(m)).sum() * area)
    return out


@pytest.mark.parametrize(
    "cells",
    [[(0, 0)], [(0, 0), (1, 0)], [(0, 0), (1, 1)], [(0, 0), (2, 1)]],
    ids=["one", "two-side", "two-diagonal", "two-apart"],
)
@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_one_and_two_cell_contacts(tmp_path: Path, cells: list[tuple[int, int]], nu: float) -> None:
    """A contact of one or two cells: finite, positive definite, and equal to the dense solve.

    One cell: K_xx = h²/A_xx(0), K_zz = h²/A_zz(0) exactly (one unknown). Two cells: the 2 × 2
    (4 × 4 with coupling) dense system. CG on at most 4 unknowns ends exact up to round-off:
    measured ≤ 2.6e-16 of the largest K (README: "match a dense solve to 3.4e-16", an earlier
    measurement); bound 1e-15 (≈ 4 ulp, round-off of the solve and of the dense reference).
    """
    mask = np.zeros((3, 2), dtype=bool)
    for c in cells:
        mask[c] = True
    r = strict_solve({"shape": "mask", "mask": _mask_file(tmp_path, mask), "nu": nu, "quantities": "tangential,normal"})
    reference = _dense_stiffness(mask, nu)
    for key, value in reference.items():
        scale = max(abs(reference["K_xx"]), abs(reference["K_yy"]))
        assert abs(r[key] - value) <= 1e-15 * scale, (key, r[key], value)
    assert_spd(r)
    assert r["K_zz"] > 0.0
    if len(cells) == 1:
        grid = mask_grid(mask)
        A = isotropic_block(Isotropic(1.0, nu), 1, 1, grid.dx, grid.dy, "xx")[0, 0]
        assert r["K_xx"] == pytest.approx(grid.cell_area / A, rel=1e-12)  # one unknown: exact
        assert r["K_xy"] == 0.0 or abs(r["K_xy"]) < 1e-15 * r["K_xx"]


# ------------------------------------------------------------------------------------------
# masks touching the edge of their array
# ------------------------------------------------------------------------------------------
def _edge_mask() -> np.ndarray:
    """A 40 × 64 blob that touches all four edges of its array (half-discs on the edges)."""
    x, y = np.meshgrid(np.arange(40) + 0.5, np.arange(64) + 0.5, indexing="ij")
    mask = (x - 20.0) ** 2 / 20.0**2 + (y - 32.0) ** 2 / 32.0**2 <= 1.0
    mask |= (x < 6) & (np.abs(y - 10) < 5)  # a tab on the x = 0 edge
    assert mask[0].any() and mask[-1].any() and mask[:, 0].any() and mask[:, -1].any()
    return mask


def test_mask_touching_the_edge_equals_padded_mask(tmp_path: Path) -> None:
    """The engine crops to the support and zero-pads the convolution, so a contact touching its
    array's edge is solved exactly like the same contact with empty rows and columns around it.

    The length unit a is half the long side of the contact (issue 14), so padding either side
    (40 → 64 columns, or → 80 × 80) changes neither the cell size h = 2/64 nor the answer:
    identical results, bound 1e-12 relative (measured bit-identical: the cropped problem is the
    same). (With the old unit, half the array's long side, the 80 × 80 padding was 0.8 × off.)
    """
    mask = _edge_mask()
    base = {"shape": "mask", "nu": 0.3, "quantities": "tangential,normal"}
    r = strict_solve({**base, "mask": _mask_file(tmp_path, mask)})
    same_h = np.zeros((64, 64), dtype=bool)
    same_h[10:50, :] = mask
    r_same = strict_solve({**base, "mask": _mask_file(tmp_path, same_h, "same.npy")})
    bigger = np.zeros((80, 80), dtype=bool)
    bigger[7:47, 9:73] = mask
    r_big = strict_solve({**base, "mask": _mask_file(tmp_path, bigger, "big.npy")})
    for key in ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz"):
        scale = max(r["K_xx"], r["K_yy"])
        assert abs(r_same[key] - r[key]) <= 1e-12 * scale, key
        assert abs(r_big[key] - r[key]) <= 1e-12 * scale, key
    assert r["dx"] == r_same["dx"] == r_big["dx"] == 2.0 / 64
    assert r["contact_cells"] == r_same["contact_cells"] == r_big["contact_cells"] == int(mask.sum())
    assert_spd(r)
