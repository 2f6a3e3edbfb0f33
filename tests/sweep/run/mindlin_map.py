"""A small adaptive map whose solver is Mindlin's closed form: the stand-in of the run tests
that count what an adaptive run reuses, journals and records (test_resume_counts,
test_resume_rounds)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from hpcontact.analytic import mindlin_ellipse_stiffness

#: 17 b/a x 9 nu, adaptive to 1e-3; the solver is ``mindlin``.
MAP = """
[sweep]
title = "map"
progress_interval = 100.0
[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
accuracy = 1e-4
[axes]
aspect = { logspace = [0, -4, 17] }
nu = { linspace = [0, 0.5, 9] }
[adaptive]
tolerance = 1e-3
"""


def mindlin(params: Mapping[str, Any]) -> dict[str, Any]:
    """Mindlin's ellipse (hpcontact.analytic) as a solve to accuracy 1e-4 reports it."""
    ka, kb = (float(k) for k in mindlin_ellipse_stiffness(1.0, float(params["aspect"]), 1.0, float(params["nu"])))
    record = {"K_xx": ka, "K_yy": kb, "K_xy": 0.0, "K_yx": 0.0, "estimated_error": 1e-4, "accuracy_met": "true"}
    record.update({f"{name}_error": 1e-4 for name in ("K_xx", "K_yy", "K_xy", "K_yx")})
    return record
