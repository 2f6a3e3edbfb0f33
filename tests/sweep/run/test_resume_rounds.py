"""Rank 0 between an adaptive map's rounds (issue 40 item 5): the journals read once (each
round reads what was appended since the last), the earlier rounds' columns built once, and the
data set's history that of the run as its user started it, whatever its later rounds pass."""

from __future__ import annotations

import json
import sys

import xarray as xr
from mindlin_map import MAP, mindlin

from hpcontact.sweep.data import provenance
from hpcontact.sweep.data.journal import decode_lines, encode_line
from hpcontact.sweep.run.records import Options


def history(path) -> list[str]:
    with xr.open_dataset(path) as ds:
        assert ds.attrs["sweep_solves"] > 25  # more than one round: later rounds ran
        return ds.attrs["history"].splitlines()


def test_a_restarted_adaptive_map_starts_a_new_history(sweep, write_spec):
    """``--restart`` discards the journals and the history: the new data set's history is its
    own line alone. Before, every round after the first ran as a resume and appended the line
    to the history of the old file, which is still there until the last round writes."""
    spec = write_spec(MAP)
    first = history(sweep(spec, mindlin))
    assert len(first) == 1
    again = history(sweep(spec, mindlin, options=Options(restart=True)))
    assert len(again) == 1 and again != first, again


def test_a_resumed_adaptive_map_adds_one_line_to_its_history(sweep, write_spec):
    """A resume of a finished map: the old history and one line for the resumed run."""
    spec = write_spec(MAP)
    first = history(sweep(spec, mindlin))
    resumed = history(sweep(spec, mindlin, options=Options(resume=True)))
    assert resumed[:1] == first and len(resumed) == 2, resumed


def resolutions(monkeypatch) -> list[str]:
    """The scenes ``resume._decide`` resolves again (``provenance.resolved_scene``
    called from it), listed as they are resolved."""
    seen: list[str] = []
    real = provenance.resolved_scene

    def counted(params):
        if sys._getframe(1).f_code.co_name == "_decide":
            seen.append(json.dumps(dict(params), sort_keys=True))
        return real(params)

    monkeypatch.setattr(provenance, "resolved_scene", counted)
    return seen


def test_a_run_trusts_the_entries_of_the_tasks_it_handed_out_and_checks_every_other(sweep, write_spec, monkeypatch):
    """``RoundMemory.handed_out``: between its rounds rank 0 resolves no scene the run handed out
    itself (its own code journaled them, under its lock); a resume, a new run, resolves each
    journaled entry's scene once to compare it with the entry's."""
    seen = resolutions(monkeypatch)
    spec = write_spec(MAP)
    with xr.open_dataset(sweep(spec, mindlin)) as ds:
        solves, rounds = int(ds.attrs["sweep_solves"]), int(ds.attrs["adaptive_rounds"])
    assert rounds >= 2 and seen == []
    sweep(spec, mindlin, options=Options(resume=True))
    assert len(seen) == len(set(seen)) == solves


def test_an_entry_whose_scene_resolves_otherwise_now_is_solved_again(sweep, write_spec, tmp_path):
    """An entry journaled with another resolution of its scene (a default changed since) is not
    reused: a resume solves that scene again, and only it."""
    spec = write_spec(MAP)
    sweep(spec, mindlin)
    journal = sorted((tmp_path / "out.nc.journal").glob("rank*.jsonl"))[0]
    events = list(decode_lines(journal.read_bytes()))
    event = next(e for e in events if e["event"] == "finished")
    event["resolved"]["tol"] = event["resolved"]["tol"] * 10.0  # as if the default had changed since
    journal.write_bytes(b"".join(encode_line(e) for e in events))
    calls: list = []

    def solve(params):
        calls.append(dict(params))
        return mindlin(params)

    solve.__qualname__, solve.__module__ = mindlin.__qualname__, mindlin.__module__  # the same runner
    sweep(spec, solve, options=Options(resume=True))
    assert calls == [event["params"]]
