"""Rank 0 between an adaptive map's rounds (issue 40 item 5): the journals read once (each
round reads what was appended since the last), the earlier rounds' columns built once, and the
data set's history that of the run as its user started it, whatever its later rounds pass."""

from __future__ import annotations

import xarray as xr
from mindlin_map import MAP, mindlin

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
