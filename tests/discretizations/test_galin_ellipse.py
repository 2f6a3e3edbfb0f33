"""The one exact cell of an elliptical contact (``hpcontact.discretizations.galin_ellipse``),
checked against what does not share its algorithm:

* Mindlin's and the elliptical punch's closed forms (isotropic, ``hpcontact.analytic``);
* the independent crystal reference ``tests/independent_reference.py`` (H from Stroh's
  eigenvectors, not Barnett–Lothe; the contour integral by a graded Gauss–Legendre rule, not by
  Fourier moments);
* coverage-weighted cells on grids (``solve_to_accuracy(strategy="coverage")``: no Galin
  theorem at all) for turned ellipses, which the reference does not turn;
* 30-digit quadrature (mpmath) for the moments.

Every comparison asserts true error ≤ the record's own estimate (the estimates are bounds at
the round-off level, ~1e-14 … 4e-12), not a tolerance picked here.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import mpmath
import numpy as np
import pytest

from hpcontact import accuracy as acc
from hpcontact import analytic
from hpcontact.discretizations import galin_ellipse
from hpcontact.errors import InputError
from hpcontact.scene import Scene

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import independent_reference as ref  # noqa: E402

BOTH = "tangential,normal"


def _exact(params: dict, request: float = 1e-6) -> dict:
    return acc.solve_to_accuracy(Scene.from_params({"quantities": BOTH, **params}), request, strategy="auto")


@pytest.mark.parametrize("aspect", [1.0, 0.5, 0.3, 1e-2, 1e-3, 1e-4, 1e-6, 1e-8])
@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_isotropic_ellipses_meet_mindlin_within_their_estimate(aspect: float, nu: float) -> None:
    """b/a 1 … 1e-8 and nu 0, 0.3, 0.5 (the incompressible and the thinnest cases included):
    K_xx, K_yy (Mindlin 1949), K_zz (the frictionless elliptical punch) and K_a/K_b within their
    estimates, every estimate ≤ 1e-12 (measured: true ≤ 2.4e-15, estimates 3e-14 … 1.2e-13)."""
    shape = {"shape": "circle"} if aspect == 1.0 else {"shape": "ellipse", "aspect": aspect}
    r = _exact({**shape, "nu": nu})
    assert r["boundary"] == "galin" and r["grids"] == [1] and r["stopped_by"] == "met" and r["accuracy_met"]
    K_xx, K_yy = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
    exact = {
        "K_xx": K_xx,
        "K_yy": K_yy,
        "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu),
        "K_a_over_K_b": K_xx / K_yy,
    }
    for key, value in exact.items():
        assert abs(r[key] / value - 1.0) <= r["estimated_errors"][key], key
    assert abs(r["K_xy"]) <= r["estimated_errors"]["K_xy"] * r["K_yy"]
    assert r["estimated_error"] <= 1e-12


CRYSTALS = [(A, psi) for A in (0.5, 2.0, 3.0) for psi in (20.0, 35.26438968275465, 60.0)]


@pytest.mark.parametrize("A, psi", CRYSTALS)
def test_cubic_crystal_ellipses_meet_the_independent_reference(A: float, psi: float) -> None:
    """Issue 26's crystal cases: nu 0.3, A ∈ {0.5, 2, 3}, ψ ∈ {20°, 35.26°, 60°}, b/a ∈ {0.3,
    0.05, 1e-2, 1e-3}, ``--accuracy 1e-6``: met, every entry of the tangential tensor, K_zz and
    K_a/K_b within its estimate of Galin's compliance computed independently (Stroh's H, graded
    Gauss–Legendre; its own quadrature error ≤ 7e-14), with the normal approach held and with
    the normal load held (``normal_held``: (J_tt)⁻¹)."""
    C = ref.rotate(ref.cubic_from_nu_A(0.3, A), ref.orientation_frame(psi))
    for aspect in (0.3, 0.05, 1e-2, 1e-3):
        found = ref.galin_ellipse_stiffness(C, aspect)
        assert found["error"] <= 1e-13
        base = {"shape": "ellipse", "aspect": aspect, "nu": 0.3, "anisotropy": A, "orientation": psi}
        for held, tensor in (("approach", found["approach_held"]), ("load", found["load_held"])):
            r = _exact({**base, "normal_held": held})
            assert r["boundary"] == "galin" and r["accuracy_met"] and r["estimated_error"] <= 1e-6
            scale = max(tensor[0, 0], tensor[1, 1])
            for (i, j), key in np.ndenumerate(np.array([["K_xx", "K_xy"], ["K_yx", "K_yy"]])):
                denominator = tensor[i, j] if i == j else scale
                assert abs(r[key] - tensor[i, j]) / denominator <= r["estimated_errors"][key], (held, aspect, key)
            ratio = tensor[0, 0] / tensor[1, 1]
            assert abs(r["K_a_over_K_b"] / ratio - 1.0) <= r["estimated_errors"]["K_a_over_K_b"]
            assert abs(r["K_zz"] / found["K_zz"] - 1.0) <= r["estimated_errors"]["K_zz"]


def test_the_isotropic_point_is_continuous() -> None:
    """A = 1 ± 1e-6 (a crystal's Barnett–Lothe kernel at the degenerate point of the anisotropic
    Green's function) against the isotropic closed-form kernel: K differs by O(A − 1), here
    ≤ 1e-6 relative, and both are finite and positive definite."""
    iso = _exact({"shape": "ellipse", "aspect": 0.2, "nu": 0.3})
    for A in (1.0 - 1e-6, 1.0 + 1e-6):
        near = _exact({"shape": "ellipse", "aspect": 0.2, "nu": 0.3, "anisotropy": A, "orientation": 20.0})
        for key in ("K_xx", "K_yy", "K_zz"):
            assert abs(near[key] / iso[key] - 1.0) <= 1e-6


def test_a_turned_isotropic_ellipse_is_the_turned_tensor() -> None:
    """Turning an isotropic ellipse by β turns its tensor: K(β) = R(β) K(0) R(β)ᵀ to the
    estimate (the turn enters only through s(φ − β) in the moments)."""
    base = {"shape": "ellipse", "aspect": 0.1, "nu": 0.4}
    K0 = _exact(base)
    beta = math.radians(35.0)
    R = np.array([[math.cos(beta), -math.sin(beta)], [math.sin(beta), math.cos(beta)]])
    expected = R @ np.diag([K0["K_xx"], K0["K_yy"]]) @ R.T
    turned = _exact({**base, "shape_angle": 35.0})
    for (i, j), key in np.ndenumerate(np.array([["K_xx", "K_xy"], ["K_yx", "K_yy"]])):
        assert abs(turned[key] - expected[i, j]) <= turned["estimated_errors"][key] * K0["K_yy"]


def test_a_turned_crystal_ellipse_meets_coverage_cells_on_grids() -> None:
    """A second algorithm that owes nothing to Galin's theorem: coverage-weighted cells
    extrapolated over grids (``strategy="coverage"`` at 1e-3) on a turned cubic crystal
    (A = 3, ψ = 60°, b/a = 0.5, turned by 40°): the exact cell's K within the grids' own
    estimate (measured at 1e-4: 3e-6 against estimates 4.5e-5)."""
    params = {"shape": "ellipse", "aspect": 0.5, "nu": 0.3, "anisotropy": 3.0, "orientation": 60.0, "shape_angle": 40.0}
    exact = _exact(params)
    grids = acc.solve_to_accuracy(Scene.from_params({**params, "quantities": BOTH}), 1e-3, strategy="coverage")
    assert grids["boundary"] == "coverage"
    for key in ("K_xx", "K_yy", "K_zz", "K_a_over_K_b"):
        assert abs(grids[key] / exact[key] - 1.0) <= grids["estimated_errors"][key], key
    for key in ("K_xy", "K_yx"):
        assert abs(grids[key] - exact[key]) / exact["K_xx"] <= grids["estimated_errors"][key], key


@pytest.mark.parametrize("aspect", [0.5, 1e-2, 1e-4])
def test_the_moments_meet_30_digit_quadrature(aspect: float) -> None:
    """c_j = ∫ cos(2jφ)/s₀(φ) dφ for j = 0, 1, 2, 7, 40 within the rounding bound the function
    states, against mpmath at 30 digits (split at φ = π/2, where 1/s₀ peaks at 1/e); b/a = 1e-4
    is where both rules apply: the FFT and the recurrence (4) agree within their bounds."""
    mpmath.mp.dps = 30
    e = mpmath.mpf(aspect)
    moments, bounds = galin_ellipse.inverse_support_moments(aspect, 41)
    for j in (0, 1, 2, 7, 40):
        half = mpmath.pi / 2
        cuts = [0, half - 1e-2, half - 1e-4, half - 1e-6, half, half + 1e-6, half + 1e-4, half + 1e-2, mpmath.pi]
        value = 2 * mpmath.quad(
            lambda p: mpmath.cos(2 * j * p) / mpmath.sqrt(mpmath.cos(p) ** 2 + (e * mpmath.sin(p)) ** 2), cuts
        )
        assert abs(moments[j] - float(value)) <= bounds[j] + 1e-15 * abs(float(value)), j
    if aspect == 1e-4:
        fft, _ = moments, bounds
        saved = galin_ellipse.FFT_MAX_POINTS
        try:
            galin_ellipse.FFT_MAX_POINTS = 1  # force the recurrence
            recurrence, rounding = galin_ellipse.inverse_support_moments(aspect, 41)
        finally:
            galin_ellipse.FFT_MAX_POINTS = saved
        assert np.all(np.abs(recurrence - fft) <= rounding + bounds)


def test_where_the_exact_cell_applies() -> None:
    """Ellipses and circles with tangential/normal only; ``coupled`` (an odd kernel part: not
    Galin's traction) and other shapes go to grids under ``auto``; asking ``galin`` for them is
    an InputError naming ``strategy``."""
    assert galin_ellipse.applies(Scene.from_params({"shape": "ellipse", "aspect": 0.3, "shape_angle": 10.0}))
    assert not galin_ellipse.applies(Scene.from_params({"shape": "ellipse", "quantities": "coupled"}))
    assert not galin_ellipse.applies(Scene.from_params({"shape": "polygon", "sides": 6}))
    assert acc.first_grid(Scene.from_params({"shape": "polygon", "sides": 6}))[0] == "coverage"
    with pytest.raises(InputError, match="strategy"):
        acc.solve_to_accuracy(Scene.from_params({"shape": "rectangle", "aspect": 0.5}), 1e-3, strategy="galin")


def test_a_gpu_asked_where_there_is_none_is_refused_as_a_grids_solve_refuses_it(monkeypatch) -> None:
    """``device = "gpu"`` on a node without CuPy or a CUDA device: the exact cell (computed on the
    CPU) refuses it naming the field, as a polygon's grid solve does, so one command gives one
    answer whatever the shape; where a GPU is there the cell is computed as on "cpu"."""
    from hpcontact.numerics import backend

    gpu = Scene.from_params({"shape": "ellipse", "aspect": 0.5, "device": "gpu"})
    monkeypatch.setattr(backend, "cuda_devices", lambda: (None, 0, "CuPy is not installed"))
    with pytest.raises(InputError) as refused:
        galin_ellipse.solve(gpu)
    assert refused.value.field == "device" and "CuPy is not installed" in str(refused.value)
    monkeypatch.setattr(backend, "cuda_devices", lambda: (object(), 1, ""))
    cpu = galin_ellipse.solve(Scene.from_params({"shape": "ellipse", "aspect": 0.5}))
    assert galin_ellipse.solve(gpu)["K_xx"] == cpu["K_xx"]
