"""Per-rank journals: append-only, checksummed JSON lines that survive SIGKILL at any instant and
truncation at any byte; ``--resume`` continues from what they hold.

Each rank of each run writes its own file ``rank{rank:05d}-{session}.jsonl`` in the journal
folder (one writer per file, no file locking, which Lustre and NFS often lack). A file is a
sequence of lines ``CRC32 JSON\\n`` (the CRC, 8 hex digits, of the JSON bytes); each line is one
``os.write`` on a file opened with ``O_APPEND``. A reader keeps every line whose newline and CRC
are present and skips any other (a torn tail left by a kill or a full disk), so a file cut at
any byte keeps every entry before the cut; a line whose CRC matches but whose event lacks a
field its kind needs, or has one of the wrong type, is skipped as well (``well_formed``). What
is skipped is counted (``History.dropped``), never fatal: those tasks are computed again, and
the run says how many lines it dropped in one line. Events:

* ``run``: the first line, the writer's provenance (session, rank, host, pid, batch job id,
  package version, git revision, numerics fingerprint, runner, spec path);
* ``started``: a task is about to run (written before it runs, not synced: it survives the death
  of the process, which is what it is for; a task started in runs that died while running it is
  quarantined, see ``History.crashed``);
* ``finished``: the task's outcome (``Entry``), with its fully resolved scene and provenance;
* ``interrupted``: the task was abandoned after a stop request (a signal), not a crash;
* ``stalled``: the rank ``rank`` of the file's run made no progress for the stall timeout
  (``run.signals``) and the run stopped without it: the task it had started is not one its
  process died running (``History.suspects``). Written by the rank that found the stall, in a
  file of its own (``record_stall``).

Durability: a line reaches the page cache at once (it survives the death of the process); it
reaches the disk (``fsync``) at the first outcome ``SYNC_INTERVAL_S`` after the last sync, after
an interruption and on close, so a node failure loses at most the last few seconds of results.
Why not a sync per chunk: it would cost 3–10 % of the task time, over the 2 % budget, where
syncing by interval costs well under 1 % (docs/performance.md §"Journal durability"). Results
travel as JSON text (exact float64 round trip, NaN and inf kept).
"""

from __future__ import annotations

import errno
import json
import math
import os
import secrets
import socket
import sys
import time
import zlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

PATTERN = "rank*.jsonl"
LEGACY_PATTERN = "rank*.h5"  # HDF5 journals of hpcontact before these journals: never reused
OK, BAD_INPUT, NOT_CONVERGED, ERROR, CRASHED = 0, 1, 2, 3, 4  # task status codes
RETRIED = (NOT_CONVERGED, ERROR)  # outcomes --resume runs again (bad input is deterministic: kept)
SYNC_INTERVAL_S = 2.0
CRASH_RUNS = 2  # a task started in this many runs that died while running it is quarantined
JOB_VARIABLES = ("SLURM_JOB_ID", "PBS_JOBID", "LSB_JOBID", "JOB_ID")  # Slurm, PBS/Torque, LSF, SGE


def batch_job() -> str | None:
    """The batch system's job id, if any."""
    return next((os.environ[name] for name in JOB_VARIABLES if os.environ.get(name)), None)


@dataclass(frozen=True)
class Entry:
    """One finished task: ``status`` OK when it succeeded, else BAD_INPUT, NOT_CONVERGED, ERROR
    (or CRASHED, made by ``History.crashed_entry``) and its ``message``; ``record`` is what the
    task function returned; ``finished`` a Unix time; ``rank`` and ``host`` where it ran;
    ``resolved`` the scene with every default filled in and ``provenance`` the package version,
    git revision and numerics fingerprint of the code that computed it (``provenance``) and the
    task function that did (``runner``: ``run.resume.current``; absent in older journals)."""

    key: str
    params: Mapping[str, Any]
    status: int
    message: str
    record: Mapping[str, Any]
    wall_time_s: float
    finished: float
    rank: int
    host: str = ""
    resolved: Mapping[str, Any] = field(default_factory=dict)
    provenance: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Start:
    """A task started in a run that never journaled its outcome: where and when."""

    key: str
    session: str
    rank: int
    host: str
    time: float


def json_default(value: Any) -> Any:
    """JSON fallback for numpy scalars and arrays."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


#: One encoder for every journal line: ``json.dumps(value, default=json_default, sort_keys=True)``
#: builds the same encoder afresh on each call (20-35 % of a call on 140k plan records).
_ENCODER = json.JSONEncoder(default=json_default, sort_keys=True)


def to_json(value: Mapping[str, Any]) -> str:
    """``value`` as JSON text (numpy scalars and arrays as numbers and lists)."""
    return _ENCODER.encode(value)


def encode_line(event: Mapping[str, Any]) -> bytes:
    """One journal line: the CRC32 of the JSON text (8 hex digits), a space, the JSON, a newline."""
    payload = to_json(event).encode("utf-8")
    return b"%08x %s\n" % (zlib.crc32(payload), payload)


def decode_lines(data: bytes) -> Iterator[dict[str, Any]]:
    """The events of a journal file's bytes: complete lines with a matching CRC; anything else
    (a torn tail, a damaged line) is skipped."""
    yield from scan_lines(data)[0]


def scan_lines(data: bytes) -> tuple[list[dict[str, Any]], int]:
    """The events of a journal file's bytes (``decode_lines``) and the number of lines dropped:
    damaged (CRC mismatch, not a JSON object) or incomplete (a last line without its newline)."""
    events, dropped = [], 0
    lines = data.split(b"\n")
    if lines[-1]:  # the last piece has no newline: a torn tail (empty when the file ends a line)
        dropped += 1
    for line in lines[:-1]:
        crc, _, payload = line.partition(b" ")
        try:
            if int(crc, 16) != zlib.crc32(payload):
                raise ValueError("CRC mismatch")
            event = json.loads(payload)
        except (ValueError, RecursionError):
            event = None
        if isinstance(event, dict):
            events.append(event)
        else:
            dropped += 1
    return events, dropped


def sync_folder(folder: Path) -> None:
    """Make the names in ``folder`` durable: fsync of the folder (best effort: some file systems
    refuse it). Journals, the run lock and the data set use it after creating or renaming a file."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


class Journal:
    """The append-only journal of one rank in one run: a new file, created with the first event
    (a rank with nothing to do leaves none); see the module docstring. Write errors (a full
    disk, a file-size limit) raise ``OSError`` naming the file."""

    def __init__(self, path: Path, rank: int, header: Mapping[str, Any]) -> None:
        self.path = Path(path)
        self.rank = rank
        self.header = {
            "event": "run",
            "rank": rank,
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "job": batch_job(),
            **header,
        }
        self.rows = 0
        self.sync_s = 0.0  # time spent in fsync (for the summary and the cost measurement)
        self._fd: int | None = None
        self._synced = time.monotonic()

    def _write(self, data: bytes) -> None:
        if self._fd is None:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND, 0o644)
            self._sync_folder()
            self._write(encode_line(self.header))
        view = memoryview(data)
        while view:  # a short write (the disk filled up) is retried, so the real error is reported
            try:
                written = os.write(self._fd, view)
            except OSError as exc:
                raise OSError(exc.errno, exc.strerror, str(self.path)) from exc
            if written == 0:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.path))
            view = view[written:]

    def _sync_folder(self) -> None:
        """Make the new file's name durable."""
        sync_folder(self.path.parent)

    def started(self, key: str) -> None:
        """Record that task ``key`` is about to run (not synced; see the module docstring)."""
        self._write(encode_line({"event": "started", "key": key, "time": time.time()}))

    @staticmethod
    def line(entry: Entry) -> bytes:
        """The journal line of a task's outcome."""
        return encode_line(
            {
                "event": "finished",
                "key": entry.key,
                "params": entry.params,
                "status": entry.status,
                "message": entry.message,
                "record": entry.record,
                "wall_time_s": entry.wall_time_s,
                "finished": entry.finished,
                "resolved": entry.resolved,
                "provenance": entry.provenance,
            }
        )

    def append(self, entry: Entry) -> None:
        """Record a task's outcome; synced when the last sync is ``SYNC_INTERVAL_S`` old."""
        self._write(self.line(entry))
        self.rows += 1
        if time.monotonic() - self._synced >= SYNC_INTERVAL_S:
            self.sync()

    def interrupted(self, key: str, reason: str) -> None:
        """Record that task ``key`` was abandoned after a stop request (not a crash), and sync."""
        self._write(encode_line({"event": "interrupted", "key": key, "reason": reason, "time": time.time()}))
        self.sync()

    def stalled(self, rank: int) -> None:
        """Record that rank ``rank`` of this run stalled (``record_stall``), and sync."""
        self._write(encode_line({"event": "stalled", "rank": rank, "time": time.time()}))
        self.sync()

    def sync(self) -> None:
        """Push everything written so far to the disk (``fsync``)."""
        if self._fd is not None:
            mark = time.perf_counter()
            try:
                os.fsync(self._fd)
            except OSError as exc:
                raise OSError(exc.errno, exc.strerror, str(self.path)) from exc
            self.sync_s += time.perf_counter() - mark
        self._synced = time.monotonic()

    def write_raw(self, data: bytes) -> None:
        """Write bytes as they are (the ``torn`` fault of ``faults`` writes half a line)."""
        self._write(data)

    def close(self) -> None:
        """Sync and close the file (idempotent)."""
        if self._fd is not None:
            try:
                self.sync()
            finally:
                os.close(self._fd)
                self._fd = None

    def __enter__(self) -> Journal:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def journal_files(folder: Path) -> list[Path]:
    """The journal files in ``folder``, sorted by name."""
    return sorted(Path(folder).glob(PATTERN)) if Path(folder).is_dir() else []


def _text(value: Any) -> bool:
    return isinstance(value, str)


def _integer(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _finite(value: Any) -> bool:
    return _number(value) and math.isfinite(value)


def _mapping(value: Any) -> bool:
    return isinstance(value, dict)


def _status(value: Any) -> bool:
    return _integer(value) and value in (OK, BAD_INPUT, NOT_CONVERGED, ERROR)


# The fields each event needs, and those it may have, with their checks.
REQUIRED: Mapping[str, Mapping[str, Any]] = {
    "run": {},
    "started": {"key": _text, "time": _finite},
    "finished": {
        "key": _text,
        "params": _mapping,
        "status": _status,
        "message": _text,
        "record": _mapping,
        "wall_time_s": _number,
        "finished": _finite,
    },
    "interrupted": {"key": _text},
    "stalled": {"rank": _integer},
}
OPTIONAL: Mapping[str, Mapping[str, Any]] = {
    "run": {"rank": _integer, "host": _text, "session": _text, "pid": _integer},
    "finished": {"resolved": _mapping, "provenance": _mapping},
}


def well_formed(event: Mapping[str, Any]) -> bool:
    """Whether a decoded event has every field its kind needs, each of the right type (a
    ``finished`` event without its ``record``, a ``started`` one without its ``time``: written
    by a faulty tool, not by a torn write, since their CRC matches). An event of a kind this
    version does not know is well formed (kept, and ignored)."""
    kind = event.get("event")
    if not isinstance(kind, str):
        return False
    required, optional = REQUIRED.get(kind, {}), OPTIONAL.get(kind, {})
    return all(name in event and check(event[name]) for name, check in required.items()) and all(
        check(event[name]) for name, check in optional.items() if name in event
    )


def read_file(path: Path) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """The header (``run`` event; empty if torn) and the other events of one journal file."""
    header, events, _ = scan_file(path)
    return header, events


def scan_file(path: Path) -> tuple[dict[str, Any], list[dict[str, Any]], int]:
    """``read_file`` and the number of lines dropped: damaged, incomplete (``scan_lines``) or
    malformed (``well_formed``)."""
    decoded, dropped = scan_lines(Path(path).read_bytes())
    events = [e for e in decoded if well_formed(e)]
    dropped += len(decoded) - len(events)
    if events and events[0].get("event") == "run":
        return events[0], events[1:], dropped
    return {}, events, dropped


def _entry(event: Mapping[str, Any], header: Mapping[str, Any]) -> Entry:
    return Entry(
        key=event["key"],
        params=event["params"],
        status=int(event["status"]),
        message=event["message"],
        record=event["record"],
        wall_time_s=float(event["wall_time_s"]),
        finished=float(event["finished"]),
        rank=int(header.get("rank", -1)),
        host=str(header.get("host", "")),
        resolved=event.get("resolved", {}),
        provenance=event.get("provenance", {}),
    )


@dataclass
class History:
    """What the journals of one output hold: the last outcome of each task (``entries``, by
    finish time; the files keep every earlier one), the starts that never got an outcome
    (``unfinished``), the ranks that stalled in a run (``stalled``: ``record_stall``), the headers of the runs, the number of files and the number of lines
    dropped (damaged, incomplete or malformed: ``scan_file``; never fatal, their tasks are
    simply computed again)."""

    entries: dict[str, Entry] = field(default_factory=dict)
    unfinished: dict[str, list[Start]] = field(default_factory=dict)
    stalled: set[tuple[str, int]] = field(default_factory=set)  # (session, rank) of the ranks that stalled
    headers: list[dict[str, Any]] = field(default_factory=list)
    files: int = 0
    dropped: int = 0

    def dropped_note(self, folder: Path) -> str | None:
        """The line a run prints when lines were dropped, else None."""
        if not self.dropped:
            return None
        lines = "line" if self.dropped == 1 else "lines"
        return f"{self.dropped} journal {lines} dropped (damaged or incomplete) in {folder}"

    def suspects(self) -> dict[str, list[Start]]:
        """Per task, the runs that died while running it after its last outcome (not those
        whose rank stalled: ``stalled``)."""
        out: dict[str, list[Start]] = {}
        for key, starts in self.unfinished.items():
            last = self.entries.get(key)
            later = [
                s
                for s in starts
                if (last is None or s.time > last.finished) and (s.session, s.rank) not in self.stalled
            ]
            if later:
                out[key] = sorted(later, key=lambda s: s.time)
        return out

    def crashed(self) -> dict[str, list[Start]]:
        """Tasks quarantined: started in ``CRASH_RUNS`` runs that died while running them."""
        return {key: starts for key, starts in self.suspects().items() if len(starts) >= CRASH_RUNS}

    def crashed_entry(self, key: str, params: Mapping[str, Any]) -> Entry:
        """The ``CRASHED`` outcome of a quarantined task (data set and summary)."""
        starts = self.crashed()[key]
        last = starts[-1]
        when = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(last.time))
        message = (
            f"the process died while running this task in {len(starts)} runs (last: {last.host}, rank "
            f"{last.rank}, {when}): likely out of memory or a crash"
        )
        return Entry(
            key=key,
            params=params,
            status=CRASHED,
            message=message,
            record={},
            wall_time_s=float("nan"),
            finished=last.time,
            rank=last.rank,
            host=last.host,
        )


def read_history(folder: Path) -> History:
    """Every journal in ``folder`` (see ``History``). A file that cannot be read is reported on
    stderr and skipped: its tasks are simply computed again."""
    return HistoryReader(folder).read()


@dataclass
class _FileState:
    """What ``HistoryReader`` has read of one journal file: up to ``offset`` (bytes, the end of
    its last complete line) of the file ``identity`` (device, inode); its header (``scan_file``:
    the first well-formed event, if a ``run`` one; ``seen``: whether one was read), its last
    outcome per task, open starts, stalled ranks and the complete lines dropped."""

    identity: tuple[int, int]
    offset: int = 0
    seen: bool = False
    header: dict[str, Any] = field(default_factory=dict)
    entries: dict[str, Entry] = field(default_factory=dict)
    open_starts: dict[str, float] = field(default_factory=dict)
    stalled: set[tuple[str, int]] = field(default_factory=set)
    dropped: int = 0

    def add(self, events: list[dict[str, Any]], name: str) -> None:
        """Take the next well-formed ``events`` of the file ``name`` (its stem: the session when
        the header names none), in file order."""
        if events and not self.seen:
            self.seen = True
            if events[0].get("event") == "run":
                self.header, events = events[0], events[1:]
        session = str(self.header.get("session", name))
        for event in events:
            kind, key = event.get("event"), event.get("key")
            if kind == "started":
                self.open_starts[key] = float(event["time"])
            elif kind == "stalled":
                self.stalled.add((session, int(event["rank"])))
            elif kind in ("finished", "interrupted"):
                self.open_starts.pop(key, None)
                if kind == "finished":
                    entry = _entry(event, self.header)
                    old = self.entries.get(key)
                    if old is None or entry.finished >= old.finished:
                        self.entries[key] = entry


class HistoryReader:
    """The ``History`` of the journals in a folder, read again as often as needed (rank 0 before
    each round of an adaptive map): each ``read`` parses only what was appended to each file
    since the last (the journals are append-only: a file that shrank or was replaced, another
    inode, is read again from its start; one that is gone is forgotten), and gives what
    ``read_history`` of the whole folder gives. An ``Entry`` read once is the same object in
    every later ``History`` until a later outcome of its task replaces it. ``advance`` parses
    what was appended so far without making a ``History`` (rank 0 during a round, while the
    other ranks compute: the read after the round parses only the rest); a ``read`` gives the
    same ``History`` however often ``advance`` ran before it."""

    def __init__(self, folder: Path) -> None:
        self.folder = Path(folder)
        self._files: dict[Path, _FileState] = {}

    def advance(self) -> None:
        """Parse the complete lines appended to the journals since the last ``advance`` or
        ``read`` (an incomplete last line is left for later: a rank may be writing it). A file
        that cannot be read is left to the next ``read``, which reports it; one of the same
        identity and size as when last read (an earlier round's) is not opened."""
        for path in journal_files(self.folder):
            try:
                status, state = path.stat(), self._files.get(path)
                if state is None or state.identity != (status.st_dev, status.st_ino) or status.st_size != state.offset:
                    self._files[path] = self._update(path)[0]
            except OSError:
                continue

    def read(self) -> History:
        """The history of the journals as they are now (``read_history``)."""
        history = History()
        states: list[tuple[Path, _FileState, int]] = []  # with the lines dropped at a torn tail
        for path in journal_files(self.folder):
            try:
                state, torn = self._update(path)
            except OSError as exc:
                print(f"hpcontact: skipping unreadable journal {path}: {exc}", file=sys.stderr)
                self._files.pop(path, None)
                continue
            states.append((path, state, torn))
        self._files = {path: state for path, state, _ in states}
        for path, state, torn in states:
            history.files += 1
            history.dropped += state.dropped + torn
            header = state.header
            if header:
                history.headers.append(header)
            history.stalled |= state.stalled
            for key, entry in state.entries.items():  # the last outcome: by finish time, ties to the later file
                old = history.entries.get(key)
                if old is None or entry.finished >= old.finished:
                    history.entries[key] = entry
            rank, host = int(header.get("rank", -1)), str(header.get("host", "?"))
            session = str(header.get("session", path.stem))
            for key, started in state.open_starts.items():
                history.unfinished.setdefault(key, []).append(Start(key, session, rank, host, started))
        return history

    def _update(self, path: Path) -> tuple[_FileState, int]:
        """The state of ``path`` with what was appended since the last read, and 1 if the file
        ends in an incomplete line (a torn tail: dropped now, read again once it is complete)."""
        with open(path, "rb") as handle:
            status = os.fstat(handle.fileno())
            identity = (status.st_dev, status.st_ino)
            state = self._files.get(path)
            if state is None or state.identity != identity or status.st_size < state.offset:
                state = _FileState(identity)
            handle.seek(state.offset)
            data = handle.read()
        complete = data.rfind(b"\n") + 1
        decoded, dropped = scan_lines(data[:complete])
        events = [e for e in decoded if well_formed(e)]
        state.dropped += dropped + len(decoded) - len(events)
        state.offset += complete
        state.add(events, path.stem)
        return state, int(complete < len(data))


def record_stall(folder: Path, rank: int, session: str, stalled: int) -> None:
    """Record, from ``rank``, that rank ``stalled`` of the run ``session`` stalled (a ``stalled``
    event in a journal file of its own, ``rank{rank:05d}-{session}-stalled.jsonl``: one writer
    per file), synced."""
    with Journal(Path(folder) / f"rank{rank:05d}-{session}-stalled.jsonl", rank, {"session": session}) as journal:
        journal.stalled(stalled)


def read_journals(folder: Path) -> dict[str, Entry]:
    """The last outcome of every task the journals in ``folder`` hold, by key."""
    return read_history(folder).entries


def legacy_journals(folder: Path) -> list[Path]:
    """HDF5 journals an earlier hpcontact left in ``folder`` (no provenance: never reused)."""
    return sorted(Path(folder).glob(LEGACY_PATTERN)) if Path(folder).is_dir() else []


def clear_journals(folder: Path) -> int:
    """Delete the journal files in ``folder``, legacy ones included (``--restart``); the number
    deleted."""
    files = journal_files(folder) + legacy_journals(folder)
    for path in files:
        path.unlink()
    return len(files)


def session_name() -> str:
    """A name unique to one run (rank 0's, broadcast): UTC time, process id and a random tag."""
    return f"{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}-{os.getpid()}-{secrets.token_hex(3)}"
