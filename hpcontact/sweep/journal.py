"""Per-rank HDF5 journals: every finished task is appended and flushed at once, so nothing done
is lost when a rank dies; ``--resume`` skips what any journal holds.

Each rank of each run writes its own file ``rank{rank:05d}-{session}.h5`` in the journal folder
(one writer per file, never two processes on one file, no HDF5 file locking needed, which
Lustre and NFS often lack). A file holds one row per task in a 1-D compound data set ``rows``
(one resize and one write per task: ~1 ms with the flush); the ``rows`` attribute is raised
only after a row is complete and is flushed with it, so a rank killed mid-append leaves at most
an unfinished row that readers ignore. Results travel as JSON text (exact float64 round trip,
any keys the task function returns).
"""

from __future__ import annotations

import json
import os
import secrets
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import h5py
import numpy as np

PATTERN = "rank*.h5"
OK, BAD_INPUT, NOT_CONVERGED, ERROR = 0, 1, 2, 3  # task status codes
STRING = h5py.string_dtype(encoding="utf-8")
ROW = np.dtype(
    [
        ("key", STRING),
        ("params", STRING),
        ("record", STRING),
        ("message", STRING),
        ("status", np.int32),
        ("wall_time_s", np.float64),
        ("finished", np.float64),
    ]
)


@dataclass(frozen=True)
class Entry:
    """One finished task: ``status`` OK when it succeeded, else BAD_INPUT, NOT_CONVERGED or ERROR
    and its ``message``; ``record`` is what the task function returned; ``finished`` a Unix time;
    ``rank`` the rank that ran it."""

    key: str
    params: Mapping[str, Any]
    status: int
    message: str
    record: Mapping[str, Any]
    wall_time_s: float
    finished: float
    rank: int


def json_default(value: Any) -> Any:
    """JSON fallback for numpy scalars and arrays."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def to_json(value: Mapping[str, Any]) -> str:
    """``value`` as JSON text (numpy scalars and arrays as numbers and lists)."""
    return json.dumps(value, default=json_default, sort_keys=True)


class Journal:
    """The append-only journal of one rank in one run: a new file, created with the first entry
    (a rank with nothing to do leaves none); see the module docstring."""

    def __init__(self, path: Path, rank: int, attrs: Mapping[str, Any]) -> None:
        self.path = Path(path)
        self.rank = rank
        self.attrs = {"rank": rank, "hostname": socket.gethostname(), **attrs}
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.rows = 0
        self._file: h5py.File | None = None

    def _create(self) -> h5py.File:
        f = h5py.File(self.path, "w-", locking=False)
        f.attrs.update(self.attrs)
        f.create_dataset("rows", shape=(0,), maxshape=(None,), chunks=(64,), dtype=ROW)
        f.attrs["rows"] = 0
        return f

    def append(self, entry: Entry) -> None:
        """Write ``entry`` as the next row and flush it to the file system."""
        if self._file is None:
            self._file = self._create()
        rows, row = self._file["rows"], self.rows
        rows.resize((row + 1,))
        rows[row] = (
            entry.key,
            to_json(entry.params),
            to_json(entry.record),
            entry.message,
            entry.status,
            entry.wall_time_s,
            entry.finished,
        )
        self._file.attrs["rows"] = row + 1
        self._file.flush()
        self.rows = row + 1

    def close(self) -> None:
        """Close the file (idempotent)."""
        if self._file is not None and self._file.id.valid:
            self._file.close()

    def __enter__(self) -> "Journal":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def journal_files(folder: Path) -> list[Path]:
    """The journal files in ``folder``, sorted by name."""
    return sorted(Path(folder).glob(PATTERN)) if Path(folder).is_dir() else []


def read_file(path: Path) -> list[Entry]:
    """The complete rows of one journal file."""
    with h5py.File(path, "r", locking=False) as f:
        rank = int(f.attrs["rank"])
        rows = f["rows"][: int(f.attrs["rows"])]
    return [
        Entry(
            key=_text(row["key"]),
            params=json.loads(_text(row["params"])),
            status=int(row["status"]),
            message=_text(row["message"]),
            record=json.loads(_text(row["record"])),
            wall_time_s=float(row["wall_time_s"]),
            finished=float(row["finished"]),
            rank=rank,
        )
        for row in rows
    ]


def _text(value: bytes | str) -> str:
    return value.decode("utf-8") if isinstance(value, bytes) else value


def read_journals(folder: Path) -> dict[str, Entry]:
    """Every task any journal in ``folder`` holds, by key.

    A task journaled twice keeps its successful entry, else the earliest. A file that cannot be
    read (a rank killed while creating it) is reported on stderr and skipped: its tasks are
    simply computed again.
    """
    entries: dict[str, Entry] = {}
    for path in journal_files(folder):
        try:
            rows = read_file(path)
        except (OSError, KeyError, ValueError) as exc:
            print(f"hpcontact: skipping unreadable journal {path}: {exc}", file=sys.stderr)
            continue
        for entry in rows:
            old = entries.get(entry.key)
            if old is None or (entry.status == OK, -entry.finished) > (old.status == OK, -old.finished):
                entries[entry.key] = entry
    return entries


def clear_journals(folder: Path) -> None:
    """Delete the journal files in ``folder`` (a fresh run of the same output)."""
    for path in journal_files(folder):
        path.unlink()


def session_name() -> str:
    """A name unique to one run (rank 0's, broadcast): UTC time, process id and a random tag."""
    return f"{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}-{os.getpid()}-{secrets.token_hex(3)}"
