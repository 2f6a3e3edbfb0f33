"""An adaptive map probes the machine for its start estimate (no calibration cached) only in the
first round whose estimated work a rank covers the probe (``run.rounds.PROBE_COVER_S``), not in
a short first round the other ranks would finish first (issue 40 item 5: the 4-D map's first
round on 16 ranks, ~0.5 s a rank, waited for rank 0's 0.85-0.90 CPU s probe); before that its
line is the shipped prior's, unscaled, and says so."""

from __future__ import annotations

import io
import json
import math
from pathlib import Path

import pytest
from mindlin_map import MAP, mindlin

from hpcontact.sweep.cost import prior
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run import rounds
from hpcontact.sweep.run.schedule import SerialTeam


@pytest.fixture
def unprobed(tmp_path, monkeypatch):
    """No calibration cached or named, this process not probed yet, a probe that measures the
    probe scenes at 2.5 x the prior's seconds; each announcement's estimate a rank and whether
    the machine was probed by then, recorded."""
    monkeypatch.delenv("HPCONTACT_COSTMODEL", raising=False)
    monkeypatch.setenv("HPCONTACT_WISDOM", str(tmp_path / "fftw_wisdom"))
    shipped = prior.prior_calibration()
    monkeypatch.setattr(
        prior, "probe", lambda: {name: 2.5 * shipped.task_seconds(s) for name, s in prior.PROBE_SCENES.items()}
    )
    announce, seen = rounds._announce, []

    def announced(*args, **kwargs):
        progress, per_rank_s = announce(*args, **kwargs)
        seen.append((per_rank_s, prior.probed_yet()))
        return progress, per_rank_s

    monkeypatch.setattr(rounds, "_announce", announced)
    prior._probed.cache_clear()
    yield seen
    prior._probed.cache_clear()


def mindlin_map(folder: Path) -> str:
    """The Mindlin map (mindlin_map.py) run in this process on one rank into ``folder``: what it printed."""
    folder.mkdir()
    spec = folder / "spec.toml"
    spec.write_text(MAP.replace("[sweep]", f"[sweep]\noutput = {json.dumps(str(folder / 'map.nc'))}", 1))
    out = io.StringIO()
    run_sweep(spec, task_function=mindlin, team=SerialTeam(), stream=out)
    return out.getvalue()


def test_the_probe_waits_for_the_first_round_that_covers_it(unprobed, tmp_path, monkeypatch):
    monkeypatch.setattr(rounds, "PROBE_COVER_S", math.inf)
    printed = mindlin_map(tmp_path / "never")
    never = [per_rank for per_rank, _ in unprobed]
    assert len(never) >= 3 and not any(probed for _, probed in unprobed)  # no round covers it: no probe at all
    assert "not scaled to this machine yet" in printed and "scaled x" not in printed
    # the cover at the third round's estimate (the prior's, unscaled): the probe comes with it
    cover = never[2]
    assert never[0] < cover and never[1] < cover
    monkeypatch.setattr(rounds, "PROBE_COVER_S", cover)
    unprobed.clear()
    printed = mindlin_map(tmp_path / "third")
    assert [probed for _, probed in unprobed] == [False, False] + [True] * (len(unprobed) - 2)
    # the first two rounds at the prior's seconds, the third (probed) and after at 2.5 x them
    scales = [2.5 if probed else 1.0 for _, probed in unprobed]
    assert [per_rank for per_rank, _ in unprobed] == pytest.approx([s * n for s, n in zip(scales, never)], rel=1e-12)
    assert "not scaled to this machine yet" in printed  # the first round's line, the one printed
