"""The README's tangential-stiffness figures for crystals, rerun on the scenes of their jobs.

``jobs/crystal_tangential.toml`` (nu = 0.3, n = 64, tol 1e-10), ``jobs/demo.toml`` (nu = 0.25,
accuracy 1e-3: an ellipse is one exact cell, ``hpcontact.discretizations.galin_ellipse``) and ``jobs/crystal_friction_map.toml`` (sphere of radius 8 mm on Cu, Ni, Si,
P = 100 N, μ = 0.3, n = 32) print K_min/K_max through ``postprocess/orientation_map.py`` and
``postprocess/crystal_friction_map.py``; the README quotes some of those numbers. Here the same
single scenes are solved and the quoted figures asserted to their digits. The references are
symmetry (a 4-fold axis makes a tangential tensor isotropic) and, at A = 1, Mindlin's ellipse;
the other figures are measurements of this code, asserted so that the README cannot drift from
it. Measured 2026-11-23 on the 2-core development machine.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hpcontact import analytic
from hpcontact.accuracy import default_solve
from hpcontact.problems.slip.partial_slip import solve_slip
from hpcontact.scene import Scene

pytestmark = pytest.mark.filterwarnings("error")

PSI_111 = math.degrees(math.atan(1.0 / math.sqrt(2.0)))
CRYSTAL_TANGENTIAL = {"quantities": ["tangential"], "shape": "ellipse", "nu": 0.3, "n": 64, "tol": 1e-10}
DEMO = {"quantities": ["tangential", "normal"], "shape": "ellipse", "nu": 0.25, "accuracy": 1e-3, "tol": 1e-10}


def ratio(params: dict) -> float:
    r = default_solve(Scene.from_params(params))  # one grid with n, the sweep's accuracy task with accuracy
    return r["K_min"] / r["K_max"]


def test_circle_on_110_is_anisotropic_on_001_and_111_it_is_not() -> None:
    """README: crystal_tangential "on {110} it is not (K_min/K_max = 0.63 at A = 8, 0.75 at
    A = 0.25)"; demo "not on {110} (0.860 at A = 0.5, 0.854 at A = 2)". Measured 0.62987,
    0.74707 (n = 64), 0.860243, 0.854411 (the demo's exact cell). On {001} (4-fold axis) and
    {111} (3-fold axis) the tensor is isotropic by symmetry; the exact cell has the circle's full
    symmetry, so it shows it to round-off: measured 1 − ratio ≤ 4.5e-16 (A = 0.5 and 2), bound
    1e-14 (a few hundred ulps of the sums behind K). (On the n = 64 staircase, which has only
    the square grid's mirrors, {111} was 1 − 1.30e-6.)"""
    for A, quoted in ((8.0, 0.63), (0.25, 0.75)):
        assert abs(ratio({**CRYSTAL_TANGENTIAL, "aspect": 1.0, "anisotropy": A, "orientation": 0.0}) - quoted) < 0.005
    for A, quoted in ((0.5, 0.860), (2.0, 0.854)):
        assert abs(ratio({**DEMO, "aspect": 1.0, "anisotropy": A, "orientation": 0.0}) - quoted) < 0.0005
        for psi in (90.0, PSI_111):
            assert abs(1.0 - ratio({**DEMO, "aspect": 1.0, "anisotropy": A, "orientation": psi})) < 1e-14


def test_shape_and_crystal_anisotropy_add_or_cancel() -> None:
    """README: "At A = 1 the ellipses reproduce Mindlin (0.942 for 0.5)" and "on {110} the
    b/a = 0.5 ellipse is almost isotropic at A ≈ 0.7" (crystal_tangential); "the thin ellipse's
    isotropic 0.772 (b/a = 1e-8) moves between 0.737 and 0.833 with A and ψ" (demo: A = 0.5,
    2; ψ = 0, 20°, 35.26°, 55°, 90°). Measured: 0.94210 against Mindlin's 0.94204; 0.99816 at
    A = 0.7071 on {110} (0.9457 at A = 0.5, 0.8897 at A = 1.414); the demo's exact cells 0.772371
    (Mindlin's K_a/K_b within 3.4e-16; bound 1e-14), 0.736519 (A = 0.5, ψ = 0) … 0.833306
    (A = 2, ψ = 0); at n = 64 the minimum was 0.73642, quoted then as 0.736. Asserted to the digits quoted; "almost isotropic" as
    within 0.5 % of 1 and closer than both neighbours of the job's A axis."""
    assert abs(ratio({**CRYSTAL_TANGENTIAL, "aspect": 0.5}) - 0.942) < 0.0005
    assert abs(analytic.mindlin_ellipse_stiffness_ratio(0.5, 0.3) - 0.942) < 0.0005
    near = [
        ratio({**CRYSTAL_TANGENTIAL, "aspect": 0.5, "anisotropy": A, "orientation": 0.0}) for A in (0.5, 0.7071, 1.414)
    ]
    assert 1.0 - near[1] < 5e-3 and near[1] > max(near[0], near[2])
    thin = ratio({**DEMO, "aspect": 1e-8})
    assert abs(thin - 0.772) < 0.0005
    assert thin == pytest.approx(analytic.mindlin_ellipse_stiffness_ratio(1e-8, 0.25), rel=1e-14, abs=0.0)
    values = [
        ratio({**DEMO, "aspect": 1e-8, "anisotropy": A, "orientation": psi})
        for A in (0.5, 2.0)
        for psi in (0.0, 20.0, PSI_111, 55.0, 90.0)
    ]
    assert abs(min(values) - 0.737) < 0.0005 and abs(max(values) - 0.833) < 0.0005


@pytest.mark.parametrize("material, quoted, tol", [("Cu", 0.761, 5e-4), ("Ni", 0.8065, 5e-5), ("Si", 0.902, 5e-4)])
def test_friction_map_no_slip_anisotropy_on_110(material: str, quoted: float, tol: float) -> None:
    """README "Crystal-sphere friction map": "k_min/k_max of the consistent tangent at Q = 0 is
    … smallest on [110]: 0.761 (Cu), 0.807 (Ni), 0.902 (Si)" (the job's scene at Q = 0, n = 32;
    k_min, k_max the principal values of the symmetric part, as the figure script takes them).
    Measured 0.76126, 0.80650, 0.90187: Ni rounds to 0.806, not 0.807, so Ni is asserted at
    its measured 0.8065 (docs/claims.md: the README must say 0.806)."""
    r = solve_slip(
        {
            "radius": 8e-3,
            "load": 100.0,
            "mu": 0.3,
            "angle": 0.0,
            "steps": 3,
            "tensor": True,
            "coupling": "coupled",
            "n": 32,
            "tol": 1e-8,
            "material": f"crystal:{material}",
            "orientation": 0.0,
            "q_ratio": 0.0,
        }
    )
    K = np.array(
        [
            [r["tangential_stiffness_xx"], r["tangential_stiffness_xy"]],
            [r["tangential_stiffness_yx"], r["tangential_stiffness_yy"]],
        ]
    )
    low, high = np.linalg.eigvalsh(0.5 * (K + K.T))
    assert abs(low / high - quoted) < tol
