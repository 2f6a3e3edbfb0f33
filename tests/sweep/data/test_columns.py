"""Outcomes as columns (``hpcontact.sweep.data.columns``): any split of the entries joins to the same
per-task arrays, later parts win, provenance counts add up."""

from __future__ import annotations

import struct
from dataclasses import replace

import numpy as np

from hpcontact.sweep.data.columns import NOT_COMPUTED, Texts, join, to_columns
from hpcontact.sweep.data.journal import ERROR, OK, Entry
from hpcontact.sweep.data.provenance import contributors

FIXED = ("status", "message", "wall_time_s")


def entry(i: int, status: int = OK, version: str = "1") -> Entry:
    """Task i's outcome: numbers, an integer, a text some records lack, a JSON plan; a number
    beside text in ``mixed``."""
    record = {"K": 1.0 / (i + 1), "n": i, "plan": {"solves": i % 2}, "mixed": "x" if i == 3 else float(i)}
    if i % 3 == 0:
        record["note"] = f"thin {i}"
    return Entry(
        key=f"k{i}",
        params={},
        status=status,
        message="" if status == OK else f"failed {i}",
        record=record if status == OK else {},
        wall_time_s=float(i),
        finished=0.0,
        rank=0,
        provenance={"hpcontact_version": version, "git_revision": "r", "numerics": {}},
    )


def joined(parts: list[list[int]], entries: dict[int, Entry], tasks: int):
    return join([to_columns([entries[i] for i in part], part) for part in parts], tasks, FIXED)


def test_every_split_joins_to_the_same_arrays_and_provenance():
    entries = {i: entry(i, ERROR if i == 4 else OK, "2" if i > 5 else "1") for i in range(8)}  # task 8: no entry
    whole = joined([list(range(8))], entries, 9)
    for split in ([[0, 2, 4, 6], [1, 3, 5, 7]], [[7], [5, 6], [0, 1, 2, 3, 4]], [[i] for i in range(8)]):
        part = joined(split, entries, 9)
        assert list(part.records) == list(whole.records) == ["K", "n", "plan", "mixed", "note"]  # first appearance
        for name, values in whole.records.items():
            assert values.dtype == part.records[name].dtype
            if values.dtype == object:
                assert values.tolist() == part.records[name].tolist()
            else:
                np.testing.assert_array_equal(values, part.records[name])  # bitwise: NaN where missing
        np.testing.assert_array_equal(part.status, whole.status)
        assert part.message.tolist() == whole.message.tolist() and part.provenance == whole.provenance
    assert whole.provenance == contributors(entries.values())
    assert whole.status[8] == NOT_COMPUTED and whole.message[8] == "not computed" and np.isnan(whole.wall_time_s[8])
    assert whole.records["mixed"][3] == "x" and whole.records["mixed"][2] == "2.0"  # numbers beside text: JSON floats
    assert whole.records["note"].tolist()[:4] == ["thin 0", "", "", "thin 3"] and np.isnan(whole.records["K"][4])


def test_later_parts_win():
    first, second = entry(1), entry(1, ERROR)
    out = join([to_columns([first], [0]), to_columns([second], [0])], 1, FIXED)
    assert out.status[0] == ERROR and out.message[0] == "failed 1" and np.isnan(out.records["K"][0])


def test_texts_decode_equal_texts_to_one_object():
    shared: dict[str, str] = {}
    a, b = Texts.of(["p", "q", "p"]).decoded(shared), Texts.of(["q", "p"]).decoded(shared)
    assert a.tolist() == ["p", "q", "p"] and a[0] is a[2] is b[1]


def test_number_columns_are_each_value_as_float_bit_for_bit():
    """A column of numbers (Python's, numpy's of several widths, ints past 2**53 and 2**64, -0.0, a
    subnormal, a NaN with a payload) and missing values is float(v) of each value and NaN where
    missing, to the bit (the definition, value by value); a failed task's record is not read; a
    bool, a numpy bool or a string among the numbers makes the column text."""
    payload_nan = float(np.frombuffer(np.uint64(0x7FF800000000ABCD).tobytes(), dtype=np.float64)[0])
    numbers = [1.0 / 3.0, 7, 2**53 + 1, 2**64 + 2**11 + 1, -(2**70) - 3, -0.0, payload_nan, None, 1e-310]
    numbers += [np.float32(0.1), np.float16(0.3), np.longdouble(0.1), np.int8(-5), np.uint64(2**64 - 1)]
    ok = [entry(0, OK) for _ in numbers]
    entries = [replace(e, record={} if v is None else {"x": v}) for e, v in zip(ok, numbers)]
    entries.append(replace(entry(1, ERROR), record={"x": 2.0}))
    column = to_columns(entries, list(range(len(entries)))).records["x"]
    expected = [struct.pack("<d", np.nan if v is None else float(v)) for v in numbers] + [struct.pack("<d", np.nan)]
    assert column.dtype == np.float64 and [struct.pack("<d", v) for v in column.tolist()] == expected
    for odd in (True, np.bool_(False), "1.0"):
        mixed = to_columns([*entries[:2], replace(entries[0], record={"x": odd})], [0, 1, 2]).records["x"]
        assert isinstance(mixed, Texts), odd
