"""A grid level of several accuracy runs as one batched CG (``accuracy.level_batches``, issue 41 item 2),
forced on the CPU, against each scene refined alone: the agreement of tests/gpu/sequence_agreement.py
(same grids and stops; stiffnesses within 1e-12), and a batch that fails solved again level by level."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "gpu"))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sweep" / "work"))
from sequence_agreement import check_batched_sequences  # noqa: E402
from test_batches_accuracy import REQUESTS, scenes_of, without_clocks  # noqa: E402

from hpcontact.accuracy import level_batches, solve_levels_one_by_one, solve_to_accuracy_batch  # noqa: E402
from hpcontact.accuracy.level_batches import solve_levels_batched  # noqa: E402


def test_batched_levels_give_each_scene_its_record_alone(tmp_path):
    """The circle, the crystal ellipse and the star on grids, an exact cell, and the circle twice (its
    levels' solves batch with their twin's): each record the scene's alone within 1e-12 (issue 41's
    other scenes on the GPU: tests/gpu/test_gpu_batches.py)."""
    requests = [REQUESTS[0], REQUESTS[1], REQUESTS[3], REQUESTS[6], REQUESTS[0]]
    assert check_batched_sequences(requests, tmp_path, device="cpu") > 0


def test_a_batch_that_fails_is_solved_level_by_level(monkeypatch, tmp_path):
    chosen = [REQUESTS[0], REQUESTS[2], REQUESTS[0]]
    scenes, requests = scenes_of(chosen, tmp_path), [r for _, r in chosen]

    def fails(members):
        raise FloatingPointError("a batch that fails")

    monkeypatch.setattr(level_batches, "_batch_solve", fails)
    batched = solve_to_accuracy_batch(scenes, requests, solve_levels_batched)
    alone = solve_to_accuracy_batch(scenes, requests, solve_levels_one_by_one)
    assert [without_clocks(r) for r in batched] == [without_clocks(r) for r in alone]
