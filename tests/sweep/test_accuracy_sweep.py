"""A sweep at a requested accuracy: every point's estimate is met and honest against exact
references (docs/howto/accuracy.md §"A sweep at a stated accuracy").

The sweep asks ``[numerics] accuracy = 1e-4`` for bonded elliptical punches b/a 0.3 and 0.01 on
an isotropic body (Mindlin's closed form, ``hpcontact.analytic``) and on a cubic crystal A = 3,
ψ = 60° (Galin's theorem on the Re H kernel, computed from Stroh's eigenvectors in
``tests/independent_reference.py``, which imports nothing of hpcontact; its quadrature error is
≤ 1e-13, four decades below what is checked here). For every point and every stored stiffness
with an estimate, the data set must hold ``<name>_error`` ≤ 1e-4 (the request) and the true
relative error ≤ that estimate: the two promises of the error bars.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import hpcontact
from hpcontact.analytic import elliptical_punch_normal_stiffness, mindlin_ellipse_stiffness
from hpcontact.sweep.data.attributes import ERROR_MET

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import independent_reference as ref  # noqa: E402

ACCURACY = 1e-4
NU = 0.3
CRYSTAL = (3.0, 60.0)  # A, psi (degrees)
ASPECTS = (0.3, 0.01)


def exact(aspect: float, anisotropy: float) -> dict[str, float]:
    """Exact K_xx, K_xy, K_yx, K_yy, K_zz of the bonded (tangential) and frictionless (normal)
    elliptical punch a = 1, b = ``aspect``, in units of G a."""
    if anisotropy == 1.0:
        k_a, k_b = mindlin_ellipse_stiffness(1.0, aspect, 1.0, NU)
        k_zz = elliptical_punch_normal_stiffness(1.0, aspect, 1.0, NU)
        return {"K_xx": k_a, "K_xy": 0.0, "K_yx": 0.0, "K_yy": k_b, "K_zz": k_zz}
    C = ref.rotate(ref.cubic_from_nu_A(NU, anisotropy), ref.orientation_frame(CRYSTAL[1]))
    found = ref.galin_ellipse_stiffness(C, aspect)
    assert found["error"] <= 1e-12  # the reference's own quadrature estimate
    return {k: float(found[k]) for k in ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz")}


def derived(K: dict[str, float]) -> dict[str, float]:
    """K_a/K_b, K_max, K_min and K_min/K_max of the exact tensor (quantities.principal_stiffness:
    eigenvalues of the symmetric part)."""
    sym = np.array([[K["K_xx"], 0.5 * (K["K_xy"] + K["K_yx"])], [0.5 * (K["K_xy"] + K["K_yx"]), K["K_yy"]]])
    k_min, k_max = np.linalg.eigvalsh(sym)
    return {
        "K_a_over_K_b": K["K_xx"] / K["K_yy"],
        "K_max": k_max,
        "K_min": k_min,
        "K_min_over_K_max": k_min / k_max,
    }


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    out = tmp_path_factory.mktemp("accuracy_sweep") / "ellipses.nc"
    spec = {
        "sweep": {"title": "ellipses at 1e-4", "output": str(out)},
        "scene": {"quantities": ["tangential", "normal"], "shape": "ellipse", "nu": NU, "orientation": CRYSTAL[1]},
        "numerics": {"accuracy": ACCURACY},
        "axes": {"aspect": list(ASPECTS), "anisotropy": [1.0, CRYSTAL[0]]},
    }
    path = hpcontact.run_sweep(spec)
    with hpcontact.open_dataset(path) as ds:
        return ds.load()


def test_every_point_meets_the_request_and_says_so(swept):
    assert swept.attrs["requested_accuracy"] == ACCURACY
    assert (swept["status"] == 0).all()
    assert (swept["error_status"] == ERROR_MET).all()
    for name in ("K_xx", "K_yy", "K_zz", "K_a_over_K_b", "K_max", "K_min", "K_min_over_K_max"):
        error = swept[f"{name}_error"]
        assert swept[name].attrs["ancillary_variables"] == f"{name}_error error_status"
        assert np.isfinite(error).all() and (error <= ACCURACY).all(), name


@pytest.mark.parametrize("anisotropy", [1.0, CRYSTAL[0]])
@pytest.mark.parametrize("aspect", ASPECTS)
def test_true_errors_are_within_the_estimates(swept, aspect, anisotropy):
    point = swept.sel(aspect=aspect, anisotropy=anisotropy)
    K = exact(aspect, anisotropy)
    truth = {**K, **derived(K)}
    scale = max(abs(K["K_xx"]), abs(K["K_yy"]), abs(K["K_zz"]))  # off-diagonal errors are relative to it
    for name, value in truth.items():
        found = float(point[name])
        denominator = scale if name in ("K_xy", "K_yx") else abs(value)
        true_error = abs(found - value) / denominator
        estimate = float(point[f"{name}_error"])
        assert true_error <= estimate, f"{name} at b/a {aspect}, A {anisotropy}: true {true_error:.3g} > {estimate:.3g}"
