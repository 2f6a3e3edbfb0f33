"""Per-rank journals: exact round trip, last outcome, torn and damaged lines, killed writers,
crash attribution."""

from __future__ import annotations

import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from hpcontact.sweep.data.journal import (
    CRASHED,
    ERROR,
    OK,
    Entry,
    Journal,
    clear_journals,
    journal_files,
    read_history,
    read_journals,
)


def entry(key: str, status: int = OK, finished: float = 1.0, **record) -> Entry:
    return Entry(
        key=key,
        params={"nu": 0.3, "shape": "circle"},
        status=status,
        message="" if status == OK else "boom",
        record=record,
        wall_time_s=0.25,
        finished=finished,
        rank=0,
    )


def journal(folder: Path, name: str = "a", rank: int = 0) -> Journal:
    return Journal(folder / f"rank{rank:05d}-{name}.jsonl", rank, {"session": name})


def test_round_trip_is_exact(tmp_path):
    value = np.float64(1.0) / 3.0
    with journal(tmp_path) as j:
        j.append(entry("k1", K_xx=value, nx=np.int64(16), plan={"solves": ["x", "y"]}, tiny=5e-324, gap=math.nan))
        j.append(entry("k2", status=ERROR))
    entries = read_journals(tmp_path)
    assert set(entries) == {"k1", "k2"}
    record = dict(entries["k1"].record)
    assert math.isnan(record.pop("gap"))
    assert record == {"K_xx": value, "nx": 16, "plan": {"solves": ["x", "y"]}, "tiny": 5e-324}
    assert entries["k1"].params == {"nu": 0.3, "shape": "circle"} and entries["k1"].host
    assert entries["k2"].status == ERROR and entries["k2"].message == "boom"
    assert read_history(tmp_path).headers[0]["session"] == "a"


def test_the_last_outcome_wins_and_every_file_is_read(tmp_path):
    with journal(tmp_path, rank=0) as a, journal(tmp_path, rank=1) as b:
        a.append(entry("k1", status=ERROR, finished=1.0))
        b.append(entry("k1", finished=2.0, K_xx=1.0))
        b.append(entry("k2", finished=3.0, K_xx=2.0))
        a.append(entry("k2", status=ERROR, finished=4.0))
    entries = read_journals(tmp_path)
    assert entries["k1"].status == OK and entries["k1"].rank == 1
    assert entries["k2"].status == ERROR and entries["k2"].rank == 0  # a retry's outcome replaces the first


def test_torn_and_damaged_lines_and_unreadable_files_are_skipped(tmp_path, capsys):
    with journal(tmp_path) as j:
        for key in ("k1", "k2", "k3"):
            j.append(entry(key, K_xx=1.0))
    path = journal_files(tmp_path)[0]
    lines = path.read_bytes().split(b"\n")
    lines[2] = lines[2].replace(b"K_xx", b"K_yy")  # k2's line damaged: its CRC no longer matches
    path.write_bytes(b"\n".join(lines)[:-5])  # and k3's line torn
    assert set(read_journals(tmp_path)) == {"k1"}
    (tmp_path / "rank00001-b.jsonl").mkdir()  # not readable as a file
    assert set(read_journals(tmp_path)) == {"k1"}
    assert "rank00001-b.jsonl" in capsys.readouterr().err


def test_files_appear_with_the_first_event_and_clear_journals_removes_only_them(tmp_path):
    with journal(tmp_path, rank=1):
        pass
    assert journal_files(tmp_path) == []
    with journal(tmp_path) as j:
        j.started("k1")
    (tmp_path / "notes.txt").write_text("keep")
    assert len(journal_files(tmp_path)) == 1
    assert clear_journals(tmp_path) == 1
    assert journal_files(tmp_path) == [] and (tmp_path / "notes.txt").exists()
    assert read_journals(tmp_path / "missing") == {}


def test_a_task_started_in_two_runs_that_died_is_quarantined(tmp_path):
    with journal(tmp_path, "run1") as j:  # the first run died in k1 (and in k2, beside it)
        j.started("k1")
    with journal(tmp_path, "run1", rank=1) as j:
        j.started("k2")
    with journal(tmp_path, "run2") as j:  # the second: k2 finishes, k3 abandoned on a signal, k1 dies
        j.started("k2")
        j.append(entry("k2", finished=time.time()))
        j.started("k3")
        j.interrupted("k3", "SIGTERM")
        j.started("k1")
    history = read_history(tmp_path)
    assert set(history.suspects()) == {"k1"} and set(history.crashed()) == {"k1"}
    crashed = history.crashed_entry("k1", {"nu": 0.3})
    assert crashed.status == CRASHED and crashed.rank == 0
    assert "died while running this task in 2 runs (last: " in crashed.message and "out of memory" in crashed.message
    with journal(tmp_path, "run3") as j:  # --retry-crashed, and it finished
        j.started("k1")
        j.append(entry("k1", finished=time.time() + 1.0))
    assert read_history(tmp_path).crashed() == {}


WRITER = """
import sys, time
from hpcontact.sweep.data.journal import Entry, Journal
journal = Journal(sys.argv[1], 0, {})
for i in range(10**6):
    journal.started(f"{sys.argv[2]}-{i}")
    journal.append(Entry(f"{sys.argv[2]}-{i}", {"i": i}, 0, "", {"K_xx": i / 3.0}, 0.0, time.time(), 0))
    if i == 20:
        print("ready", flush=True)
"""


def test_a_writer_killed_mid_append_leaves_a_readable_journal(tmp_path):
    root = Path(__file__).resolve().parents[3]
    env = {**os.environ, "PYTHONPATH": f"{root}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    for attempt in range(3):
        path = tmp_path / f"rank0000{attempt}-k.jsonl"
        proc = subprocess.Popen(
            [sys.executable, "-c", WRITER, str(path), str(attempt)], stdout=subprocess.PIPE, env=env
        )
        assert proc.stdout.readline().strip() == b"ready"
        time.sleep(0.05 * attempt)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
    history = read_history(tmp_path)
    assert len(history.entries) >= 3 * 21
    assert all(e.record["K_xx"] == e.params["i"] / 3.0 for e in history.entries.values())
    assert all(len(starts) == 1 for starts in history.suspects().values())  # at most the task in flight
