"""The earlier rounds' entries of an adaptive map turned into columns once (``ColumnsOnce``):
joined, its parts give what the columns of every entry at once give, as the entries grow
round after round, and when one changes or is left out."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from hpcontact.sweep.data.columns import ColumnsOnce, join, to_columns
from hpcontact.sweep.data.journal import ERROR, OK, Entry


def entry(at: int, status: int = OK, **record) -> Entry:
    return Entry(
        key=f"k{at}",
        params={"at": at},
        status=status,
        message="" if status == OK else f"failed {at}",
        record=record,
        wall_time_s=0.1 * at,
        finished=float(at),
        rank=0,
        provenance={"hpcontact_version": "1", "git_revision": "r" if at % 2 else "s"},
    )


def assert_same_join(parts, entries, positions, tasks=12):
    once, whole = join(parts, tasks, ("status",)), join([to_columns(entries, positions)], tasks, ("status",))
    for name in ("status", "message", "wall_time_s"):
        np.testing.assert_array_equal(getattr(once, name), getattr(whole, name))
    assert list(once.records) == list(whole.records) and once.provenance == whole.provenance
    for name, values in whole.records.items():
        assert once.records[name].dtype == values.dtype
        np.testing.assert_array_equal(once.records[name], values)


def test_the_parts_join_as_all_the_entries_at_once():
    rounds = [
        [entry(2, K=1.0, plan={"solves": 1}), entry(5, K=2.5)],
        [entry(0, K=math.nan), entry(7, ERROR)],
        [entry(3, K=4.0, plan="text", grid=[16, 32]), entry(9, K=0.5, extra=1.0)],
    ]
    once = ColumnsOnce()
    given: list[tuple[Entry, int]] = []
    built = []
    for new in rounds:
        given = sorted(given + [(e, e.params["at"]) for e in new], key=lambda item: item[1])
        entries, positions = [e for e, _ in given], [at for _, at in given]
        parts = once.parts(entries, positions)
        built.append(len(parts[-1].position))
        assert_same_join(parts, entries, positions)
    assert built == [2, 2, 2]  # each round's new entries alone
    # an entry changed (a later outcome): everything again; one left out: everything again
    entries[1] = entry(2, K=9.0)
    parts = once.parts(entries, positions)
    assert len(parts) == 1 and len(parts[0].position) == 6
    assert_same_join(parts, entries, positions)
    parts = once.parts(entries[1:], positions[1:])
    assert len(parts) == 1 and len(parts[0].position) == 5
    assert_same_join(parts, entries[1:], positions[1:])
    # the same entries again (equal, not the same objects): nothing new, nothing built
    again = once.parts([entry(e.params["at"], e.status, **e.record) for e in entries[1:]], positions[1:])
    assert [p.position.tolist() for p in again] == [p.position.tolist() for p in parts]


def test_the_ranks_columns_stand_for_the_entries_they_wrote():
    """A round's ranks built the columns of the entries they ran: the next round takes them for
    those entries (nothing built again), but not for entries that are other ones (another
    outcome of the task, read from the journals), which it builds."""
    once = ColumnsOnce()
    first = [entry(1, K=1.0), entry(4, K=2.0, plan={"solves": 2})]
    once.parts(first, [1, 4])
    ran = [entry(6, K=3.0, plan="x"), entry(8, ERROR)]
    once.ran(to_columns(ran, [6, 8]))
    entries, positions = [first[0], first[1], *ran], [1, 4, 6, 8]
    parts = once.parts(entries, positions)
    assert len(parts) == 2  # the first round's and the ranks': nothing built
    assert_same_join(parts, entries, positions)
    other = entry(10, K=5.0)
    once.ran(to_columns([other], [10]))
    journaled = replace(other, wall_time_s=7.0)  # not the outcome the rank wrote
    entries, positions = [*entries, journaled], [*positions, 10]
    parts = once.parts(entries, positions)
    assert len(parts) == 3 and parts[-1].wall_time_s.tolist() == [7.0]
    assert_same_join(parts, entries, positions)
