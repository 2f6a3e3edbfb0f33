"""Grid sequences of ``--accuracy`` refined in a batch on the device path against each scene alone on the
CPU (issue 41's agreement: ≤ 1e-12 relative, ``device_agreement.REQUIRED``), shared by the stand-in GPU's
test (tests/gpu/test_standin_sequences.py) and the GPU's (tests/gpu/test_gpu_batches.py).

The scenes are those of tests/sweep/work/test_batches_accuracy.py's ``REQUESTS`` with CG to 1e-14 on
every level (``tol``), so each level's stiffnesses on the two devices differ by the round-off of two
converged solves (bounded for one grid by κ(A_mask)·(ρ₁ + ρ₂) in tests/problems/test_contact_batch.py),
and the extrapolated values, fixed linear combinations of the levels' (the same expansion chosen on
both, asserted, but for entries zero by symmetry, whose expansion is chosen on round-off), carry it over. Both devices must refine over the same grids and stop alike.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "numerics"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sweep" / "work"))
from device_agreement import REQUIRED  # noqa: E402
from test_batches_accuracy import alone, scenes_of  # noqa: E402

from hpcontact.accuracy import solve_to_accuracy_batch  # noqa: E402
from hpcontact.accuracy.level_batches import solve_levels_batched  # noqa: E402
from hpcontact.accuracy.refinement import LevelSolver  # noqa: E402
from hpcontact.scene import Scene  # noqa: E402


def check_batched_sequences(
    requests: list[tuple[str, dict]],
    folder: Path,
    device: str = "gpu",
    solve_levels: LevelSolver = solve_levels_batched,
) -> int:
    """Solve ``requests`` (``REQUESTS``' rows) as one batch on ``device``, levels by ``solve_levels``
    (default: a level's coverage-weighted solves as one batched CG), and each alone on the CPU;
    assert the same grids, stops, cells and expansions, and every stiffness (per level and
    extrapolated) within ``REQUIRED`` of the tensor's largest entry, the estimates within ``REQUIRED``.
    Returns the number of levels compared."""
    scenes = scenes_of(requests, folder)
    options = [r for _, r in requests]
    on_device = [Scene.from_params({**s.params, "tol": 1e-14, "device": device}) for s in scenes]
    batched = solve_to_accuracy_batch(on_device, options, solve_levels)
    compared = 0
    for (name, _), scene, request, record in zip(requests, scenes, options, batched):
        single = alone(Scene.from_params({**scene.params, "tol": 1e-14}), request)
        assert isinstance(record, dict) and isinstance(single, dict), (name, record, single)
        for key in ("grids", "grids_across", "stopped_by", "boundary", "accuracy_met"):
            assert record[key] == single[key], (name, key, record[key], single[key])
        names = [k for k, v in single.items() if k.startswith("K_") and "_over_" not in k and isinstance(v, float)]
        scale = max(abs(single[k]) for k in names)
        # an entry zero by symmetry (K_xy of a circle) is round-off on each device: its expansion is
        # chosen on noise; every other entry's must be the same
        for k in (k for k in record["expansion"] if abs(single[k]) > 1e-8 * scale):
            assert record["expansion"][k] == single["expansion"][k], (name, k)
        for level, level_single in zip(record["levels"], single["levels"]):
            for k in names:
                if k in level_single:
                    assert abs(level[k] - level_single[k]) <= REQUIRED * scale, (name, k)
                    compared += 1
        for k in names:
            assert abs(record[k] - single[k]) <= REQUIRED * scale, (name, k)
        assert abs(record["estimated_error"] - single["estimated_error"]) <= REQUIRED, name
    return compared
