"""Rank 0 of an adaptive map reads the journals ahead while a round runs (issue 40 item 5;
``run.rounds.READ_AHEAD_SHARE``, ``journal.HistoryReader.advance``): the decision after the
round parses only what was written after its reading ahead, and the data set is the one of a
run that never reads ahead."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import xarray as xr
from mindlin_map import MAP, mindlin

from hpcontact.sweep.data import journal
from hpcontact.sweep.run import rounds


def run_counted(sweep, folder: Path, share: float, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, dict[str, int]]:
    """The Mindlin map run in ``folder`` with ``READ_AHEAD_SHARE`` = ``share``; the journal
    bytes parsed by reading ahead and by the reads before each round's decision."""
    parsed = {"ahead": 0, "read": 0}
    inside = {"ahead": False}
    scan, advance = journal.scan_lines, journal.HistoryReader.advance

    def counted(data: bytes):
        parsed["ahead" if inside["ahead"] else "read"] += len(data)
        return scan(data)

    def ahead(self) -> None:
        inside["ahead"] = True
        try:
            advance(self)
        finally:
            inside["ahead"] = False

    monkeypatch.setattr(journal, "scan_lines", counted)
    monkeypatch.setattr(journal.HistoryReader, "advance", ahead)
    monkeypatch.setattr(rounds, "READ_AHEAD_SHARE", share)
    folder.mkdir()
    spec = folder / "spec.toml"
    spec.write_text(MAP.replace("[sweep]", f'[sweep]\noutput = "{folder / "out.nc"}"', 1), encoding="utf-8")
    path = sweep(spec, mindlin)
    monkeypatch.undo()
    return path, parsed


def test_reading_ahead_leaves_the_decision_nothing_to_parse_and_the_data_set_as_it_was(sweep, tmp_path, monkeypatch):
    """One rank (it takes every claim and reads ahead after each): with reading ahead always
    due (share inf) the reads before the rounds' decisions parse no byte, every journal byte
    was parsed ahead; never due (share 0) they parse them all; the data sets are equal in every
    variable but the measured wall times."""
    never, never_parsed = run_counted(sweep, tmp_path / "never", 0.0, monkeypatch)
    always, always_parsed = run_counted(sweep, tmp_path / "always", math.inf, monkeypatch)
    journaled = sum(p.stat().st_size for p in journal.journal_files(tmp_path / "always" / "out.nc.journal"))
    assert never_parsed["ahead"] == 0 and never_parsed["read"] > 0
    assert always_parsed["read"] == 0 and always_parsed["ahead"] == journaled
    with xr.open_dataset(never) as a, xr.open_dataset(always) as b:
        assert a.attrs["adaptive_rounds"] > 2 and a.attrs["sweep_solves"] == b.attrs["sweep_solves"]
        xr.testing.assert_equal(a.drop_vars("wall_time_s"), b.drop_vars("wall_time_s"))
