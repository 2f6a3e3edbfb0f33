"""Extrapolated answers and their error estimates (``hpcontact.accuracy``; issue 4, items 2–3).

The estimate must be honest: on every case with a closed form the true error is below it. The
closed forms are the circle (8Ga/(2 − nu), 2aE*) and Mindlin's bonded ellipse with the
elliptical punch (``hpcontact.analytic``). Every tolerance states where it comes from.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from hpcontact import accuracy as acc
from hpcontact import analytic
from hpcontact.errors import InputError

pytestmark = pytest.mark.filterwarnings("error")


def references(shape: str, aspect: float, nu: float) -> dict[str, float]:
    """Closed-form K_xx, K_yy, K_zz, K_a/K_b of a circle (radius 1) or ellipse (1, aspect), G = 1."""
    if shape == "circle":
        k = analytic.circle_tangential_stiffness(1.0, 1.0, nu)
        return {"K_xx": k, "K_yy": k, "K_zz": analytic.circle_normal_stiffness(1.0, 1.0, nu), "K_a_over_K_b": 1.0}
    K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
    return {
        "K_xx": K_a,
        "K_yy": K_b,
        "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu),
        "K_a_over_K_b": analytic.mindlin_ellipse_stiffness_ratio(aspect, nu),
    }


# ------------------------------------------------------------------------------------------
# the estimator on synthetic sequences
# ------------------------------------------------------------------------------------------
def test_richardson_and_observed_order() -> None:
    """Q(h) = 2 + 0.3h: the order-1 extrapolant is exact and the observed order is 1."""
    Q = [2.0 + 0.3 * h for h in (1.0, 0.5, 0.25)]
    assert acc.richardson(Q[1], Q[2]) == pytest.approx(2.0, abs=1e-15)
    assert acc.observed_order(*Q) == pytest.approx(1.0, abs=1e-12)
    assert math.isnan(acc.observed_order(1.0, 1.0, 1.0))


def test_estimate_is_honest_on_synthetic_expansions() -> None:
    """Q(h) = Q* (1 + c₁h + c₂h^q + c₃h^q'), h = 2^−k/8 (k = 0 … 3 to 6), in the regime the
    engine shows: a first-order term that dominates (|c₁| ∈ [0.05, 1], |c₂|, |c₃| ≤ |c₁|;
    measured c₂/c₁ ≈ 0.1) and next orders q, q' ∈ [1.5, 3] (observed orders of the
    extrapolants 1.5 … 3.5). The estimate bounds the error of every extrapolant: worst
    true/estimate 0.75 over 20 000 draws, median 0.10 (measured; 3000 drawn here).

    Outside that regime the estimator can be fooled, as any finite-grid estimator can: with
    c₁ ≈ 0 or a second order ≈ 1.2 as large as the first, 13 of 22 000 draws exceeded it
    (worst 19×). That is why the boundary treatment must make the leading term clean.
    """
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(3000):
        c1 = rng.uniform(0.05, 1.0) * rng.choice([-1.0, 1.0])
        c2, c3 = rng.uniform(-1.0, 1.0, 2) * abs(c1)
        q2, q3 = rng.uniform(1.5, 3.0, 2)
        h = [2.0**-k / 8 for k in range(int(rng.integers(4, 8)))]
        Q = [3.0 * (1 + c1 * x + c2 * x**q2 + c3 * x**q3) for x in h]
        e = acc.estimate(Q)
        worst = max(worst, abs(e.value - 3.0) / e.error)
    assert worst < 1.0


def test_estimate_of_flat_and_oscillating_sequences() -> None:
    """A flat sequence (nu = 0: K_a/K_b = 1 on every grid) has a rounding-sized estimate; an
    extrapolant that swings (R up, then down) is bounded by the swing (Roache's oscillatory
    convergence)."""
    flat = acc.estimate([1.0, 1.0, 1.0, 1.0])
    assert flat.value == 1.0 and flat.error < 1e-14
    Q = [1.0 - 0.1, 1.0 - 0.05 + 2e-3, 1.0 - 0.025 - 1e-3, 1.0 - 0.0125 + 1e-3]
    e = acc.estimate(Q)
    R = [2 * b - a for a, b in zip(Q, Q[1:])]
    assert e.error >= acc.SAFETY * max(abs(R[2] - R[1]), abs(R[1] - R[0])) - 1e-15


# ------------------------------------------------------------------------------------------
# solve_to_accuracy: honest on every closed form
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "shape, aspect, nu",
    [("circle", 1.0, 0.3), ("circle", 1.0, 0.5), ("ellipse", 0.1, 0.3), ("ellipse", 1e-3, 0.5), ("ellipse", 1e-6, 0.3)],
)
def test_solve_to_accuracy_meets_and_bounds(shape: str, aspect: float, nu: float) -> None:
    """--accuracy 1e-3: the estimate is met and every true error is below its estimate.

    Measured (true / estimated K_xx error): circle nu = 0.3 8.0e-6 / 2.0e-5 (5 grids, n ≤ 512;
    on 4 grids the estimate, 4.8e-3, is still above the request); ellipse 0.1 7.2e-5 / 2.1e-4,
    1e-3 1.2e-5 / 2.3e-4, 1e-6 1.4e-5 / 4.9e-4 (4 grids, up to 256 × 64).
    """
    params = {"shape": shape, "aspect": aspect, "nu": nu, "quantities": "tangential,normal"}
    r = acc.solve_to_accuracy(params, 1e-3)
    assert r["accuracy_met"] and r["estimated_error"] <= 1e-3
    assert r["estimated_error"] == max(r["estimated_errors"].values())
    for key, value in references(shape, aspect, nu).items():
        true = abs(r[key] / value - 1.0)
        assert true <= r["estimated_errors"][key], (key, true, r["estimated_errors"][key])
    assert len(r["grids"]) >= acc.MIN_GRIDS
    assert r["grids"] == [32 * 2**k for k in range(len(r["grids"]))]
    assert r["wall_time_s"] >= sum(level["wall_time_s"] for level in r["levels"])
    for key in ("K_xx", "K_yy", "K_zz"):
        assert 0.5 < r["convergence_order"][key] < 1.7  # the leading order is 1 (edge layer)


def test_accuracy_not_reachable_is_reported_not_hidden() -> None:
    """A grid budget too small for the request is an error naming the finest grid (the rule of
    every missed tolerance, exit 1 on the command line); the record it carries still has an
    honest estimate (measured 4.8e-3 > requested 1e-6, true 1.6e-5)."""
    with pytest.raises(acc.AccuracyNotMet, match="finest grid 256 x 256") as caught:
        acc.solve_to_accuracy({"shape": "circle", "nu": 0.3}, 1e-6, max_cells=256 * 256)
    r = caught.value.record
    assert not r["accuracy_met"] and r["grids"][-1] == 256
    assert r["estimated_error"] > 1e-6
    exact = analytic.circle_tangential_stiffness(1.0, 1.0, 0.3)
    assert abs(r["K_xx"] / exact - 1.0) <= r["estimated_errors"]["K_xx"]


def test_nu_zero_extrapolation_keeps_isotropy() -> None:
    """nu = 0, ellipse: K_xx = K_yy on every grid, so the extrapolated ratio is exactly 1."""
    r = acc.solve_to_accuracy({"shape": "ellipse", "aspect": 0.3, "nu": 0.0}, 1e-2)
    assert r["K_a_over_K_b"] == 1.0
    assert r["K_xy"] == 0.0


@pytest.mark.parametrize(
    "params, accuracy",
    [
        ({"shape": "rough"}, 1e-3),
        ({"shape": "circle", "quantities": "compliance"}, 1e-3),
        ({"shape": "circle"}, 0.0),
        ({"shape": "circle"}, float("nan")),
        ({"shape": "circle"}, 2.0),
    ],
)
def test_solve_to_accuracy_refuses_bad_requests(params: dict, accuracy: float) -> None:
    with pytest.raises(InputError):
        acc.solve_to_accuracy(params, accuracy)


def test_the_study_runner_is_hpcontact_run_with_cold_solves(tmp_path, capsys):
    """``python -m hpcontact.accuracy`` takes ``hpcontact run``'s options and exit statuses."""
    from hpcontact.accuracy import run_study

    spec = tmp_path / "study.toml"
    spec.write_text('[scene]\nquantities = ["tangential"]\nshape = "circle"\n[numerics]\ntol = 1e-8\n[axes]\nn = [8, 16]\n')
    output = tmp_path / "study.nc"
    assert run_study([str(spec), "--output", str(output)]) == 0 and output.exists()
    assert run_study([str(spec), "--output", str(output)]) == 2  # journals exist: --resume or --restart
    assert "--resume" in capsys.readouterr().err
    assert run_study([str(spec), "--output", str(output), "--resume"]) == 0
