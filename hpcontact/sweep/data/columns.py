"""Task outcomes as columns: what each rank pre-assembles from its own results, rank 0 joins.

At the end of a sweep every rank turns the journal entries it wrote (``journal.Entry``) into one
array per variable (``to_columns``): the entries' task positions (0-based, task order), status,
message, wall time, and every record key of its successful entries: float64 with NaN where a
value is missing, or coded text when a value is not a number (JSON for non-strings, "" where
missing; numbers beside text as JSON floats). Rank 0 then only scatters arrays (``join``): one
vectorized assignment per variable and rank into per-task arrays, instead of per-entry Python
work on 10^5 entries while every other rank waits. Later parts win where they name the same task
(the journals of earlier runs first, then this run's ranks). The join of any split of the
entries is the same (the 1-rank and the n-rank data sets are equal): record keys are ordered by
their first appearance in task order, then by their place in the record; equal texts become one
string object.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hpcontact.sweep.data.journal import OK, Entry, to_json
from hpcontact.sweep.data.provenance import contributors

NOT_COMPUTED = -1  # status of a task no journal holds


@dataclass(frozen=True)
class Texts:
    """Coded texts: the distinct ``texts`` and the ``codes`` (int32) indexing them."""

    texts: list[str]
    codes: np.ndarray

    @classmethod
    def of(cls, values: Iterable[str]) -> Texts:
        """``values`` coded in first-appearance order."""
        index: dict[str, int] = {}
        codes = np.fromiter((index.setdefault(v, len(index)) for v in values), dtype=np.int32)
        return cls(list(index), codes)

    def decoded(self, shared: dict[str, str]) -> np.ndarray:
        """The texts as an object array, equal texts one object (``shared`` across calls)."""
        table = np.empty(len(self.texts), dtype=object)
        table[:] = [shared.setdefault(t, t) for t in self.texts]
        return table[self.codes] if len(self.codes) else np.empty(0, dtype=object)


@dataclass(frozen=True)
class Columns:
    """Entries of some tasks as columns (module docstring). ``records`` maps each record key of
    the ok entries to float64 values or ``Texts``; ``first`` gives each key's first appearance
    (task position, place in its record); ``provenance`` is ``provenance.contributors`` of the
    entries that carry one (JSON), ``with_provenance`` how many do."""

    position: np.ndarray
    status: np.ndarray
    message: Texts
    wall_time_s: np.ndarray
    records: dict[str, np.ndarray | Texts] = field(default_factory=dict)
    first: dict[str, tuple[int, int]] = field(default_factory=dict)
    provenance: str = "[]"


@dataclass(frozen=True)
class Joined:
    """Per-task arrays of every task of a sweep (``join``): ``status`` (int32, ``NOT_COMPUTED``
    where no entry), ``message`` and ``wall_time_s``, the record keys in order with float64 or
    object (text) values, and the merged provenance JSON (``provenance.contributors``)."""

    status: np.ndarray
    message: np.ndarray
    wall_time_s: np.ndarray
    records: dict[str, np.ndarray]
    provenance: str


def is_number(value: Any) -> bool:
    """Whether ``value`` is a number (not a bool)."""
    return is_number_type(type(value))


def is_number_type(kind: type) -> bool:
    """Whether values of type ``kind`` are numbers (``is_number``): ints, floats and numpy's, not bools."""
    return issubclass(kind, (int, float, np.integer, np.floating)) and not issubclass(kind, (bool, np.bool_))


def _text(value: Any) -> str:
    """A record value as text: strings as they are, numbers as JSON floats ("" for NaN, as a
    missing number), anything else as JSON, missing as ""."""
    if value is None:
        return ""
    if isinstance(value, str):
        return value
    if is_number(value):
        number = float(value)
        return "" if math.isnan(number) else to_json(number)
    return to_json(value)


def to_columns(entries: Sequence[Entry], positions: Sequence[int]) -> Columns:
    """The ``entries`` (of the tasks at ``positions``) as columns (module docstring)."""
    names: dict[str, tuple[int, int]] = {}
    layouts: set[tuple[str, ...]] = set()  # the records' key sequences seen: a repeated one adds no name
    for entry, at in zip(entries, positions):
        if entry.status == OK and (layout := tuple(entry.record)) not in layouts:
            layouts.add(layout)
            for place, name in enumerate(layout):
                if name not in names:
                    names[name] = (int(at), place)
    ok_records = [e.record if e.status == OK else {} for e in entries]
    records: dict[str, np.ndarray | Texts] = {}
    for name in names:
        values = [record.get(name) for record in ok_records]
        if all(kind is type(None) or is_number_type(kind) for kind in set(map(type, values))):
            # numpy converts each number as float() does and None to NaN (tests/sweep/data/test_columns.py)
            records[name] = np.array(values, dtype=np.float64)
        else:
            records[name] = Texts.of(_text(v) for v in values)
    return Columns(
        position=np.asarray(positions, dtype=np.intp),
        status=np.array([e.status for e in entries], dtype=np.int32),
        message=Texts.of(e.message for e in entries),
        wall_time_s=np.array([e.wall_time_s for e in entries], dtype=np.float64),
        records=records,
        first=names,
        provenance=contributors(e for e in entries if e.provenance),
    )


class ColumnsOnce:
    """Columns of a growing set of entries, each turned into columns once (rank 0's journal
    entries of an adaptive map's earlier rounds, which every round joins again): ``parts``
    gives columns whose ``join`` is that of ``to_columns`` of all the entries at once (the join
    of any split is the same, module docstring), built only for the entries not given before,
    and not at all for those of the columns the ranks built as they ran them (``ran``). An
    entry given before that is now another (not the same object, nor equal) or left out makes
    them all built again."""

    def __init__(self) -> None:
        self._given: dict[int, Entry] = {}  # position → entry
        self._parts: list[Columns] = []
        self._ran: list[Columns] = []

    def ran(self, columns: Columns) -> None:
        """The columns a rank built of the entries it ran and journaled (``to_columns``): taken
        at the next ``parts`` for those entries, if the entries it is given there have the same
        status and measured seconds at every position (the ones the rank wrote)."""
        self._ran.append(columns)

    def parts(self, entries: Sequence[Entry], positions: Sequence[int]) -> list[Columns]:
        """Columns of ``entries`` at ``positions`` (``to_columns``), in parts."""
        given = self._given
        fresh = [(e, int(at)) for e, at in zip(entries, positions) if not _same(given.get(int(at)), e)]
        if len(entries) - len(fresh) != len(given) or any(at in given for _, at in fresh):
            given, self._parts = {}, []  # an entry changed or dropped: all of them again
            fresh = [(e, int(at)) for e, at in zip(entries, positions)]
        ran, self._ran = self._ran, []
        if ran and fresh:
            new = {at: e for e, at in fresh}
            for columns in ran:
                those = [new.get(int(at)) for at in columns.position]
                if all(e is not None for e in those) and _written(columns, those):
                    self._parts.append(columns)
                    given.update(zip(columns.position.tolist(), those))
            fresh = [(e, at) for e, at in fresh if at not in given]
        if fresh or not self._parts:
            self._parts.append(to_columns([e for e, _ in fresh], [at for _, at in fresh]))
            given.update((at, e) for e, at in fresh)
        self._given = given
        return list(self._parts)


def _written(columns: Columns, entries: Sequence[Entry]) -> bool:
    """Whether ``entries`` are those ``columns`` were built of: the same status and measured
    seconds (to the bit) at every position."""
    return np.array_equal(columns.status, [e.status for e in entries]) and np.array_equal(
        columns.wall_time_s.view(np.int64), np.array([e.wall_time_s for e in entries], dtype=np.float64).view(np.int64)
    )


def _same(old: Entry | None, new: Entry) -> bool:
    return old is not None and (old is new or old == new)


def join(
    parts: Sequence[Columns], tasks: int, excluded: Iterable[str] = (), kept: Callable[[str], bool] | None = None
) -> Joined:
    """Per-task arrays of ``tasks`` tasks from ``parts`` (later parts win); record keys in
    ``excluded`` (the names of the fixed variables) are left out, and with ``kept`` every key
    it refuses (an adaptive round's decision reads the stiffnesses alone: the others' arrays,
    ~50 of 139 725 tasks each on the 4-D map, are not made; those it keeps are the same)."""
    shared: dict[str, str] = {}
    status = np.full(tasks, NOT_COMPUTED, dtype=np.int32)
    message = np.full(tasks, shared.setdefault("not computed", "not computed"), dtype=object)
    wall = np.full(tasks, np.nan, dtype=np.float64)
    firsts: dict[str, tuple[int, int]] = {}
    for part in parts:
        status[part.position] = part.status
        message[part.position] = part.message.decoded(shared)
        wall[part.position] = part.wall_time_s
        for name, first in part.first.items():
            firsts[name] = min(first, firsts.get(name, first))
    skip = set(excluded)
    records: dict[str, np.ndarray] = {}
    for name in sorted((n for n in firsts if n not in skip and (kept is None or kept(n))), key=firsts.__getitem__):
        if any(isinstance(p.records.get(name), Texts) for p in parts):
            values = np.full(tasks, shared.setdefault("", ""), dtype=object)
            for part in parts:
                column = part.records.get(name)
                if isinstance(column, Texts):
                    values[part.position] = column.decoded(shared)
                elif column is not None:
                    values[part.position] = Texts.of(map(_text, column.tolist())).decoded(shared)
                else:
                    values[part.position] = ""
        else:
            values = np.full(tasks, np.nan, dtype=np.float64)
            for part in parts:
                column = part.records.get(name)
                values[part.position] = column if column is not None else np.nan
        records[name] = values
    return Joined(status, message, wall, records, _merged_provenance(p.provenance for p in parts))


def _merged_provenance(parts: Iterable[str]) -> str:
    """``provenance.contributors`` of the union of the entries behind the JSON lists ``parts``:
    the task counts of equal provenances added."""
    counts: dict[str, int] = {}
    for text in parts:
        for item in json.loads(text):
            tasks = item.pop("tasks")
            key = to_json(item)
            counts[key] = counts.get(key, 0) + tasks
    return json.dumps([{**json.loads(key), "tasks": n} for key, n in sorted(counts.items())], sort_keys=True)


def task_positions(where: Mapping[tuple[int, ...], str], shape: tuple[int, ...]) -> tuple[list[str], np.ndarray]:
    """The task keys in first-appearance order of the point → key map ``where``, and each
    point's task position (an integer array of ``shape``)."""
    position: dict[str, int] = {}
    task_of = np.empty(shape, dtype=np.intp)
    for index, key in where.items():
        task_of[index] = position.setdefault(key, len(position))
    return list(position), task_of
