"""Per-rank HDF5 journals: exact round trip, duplicates, torn rows, killed writers."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np

from hpcontact.sweep.journal import ERROR, OK, Entry, Journal, clear_journals, journal_files, read_journals


def entry(key: str, status: int = OK, finished: float = 1.0, **record) -> Entry:
    return Entry(
        key=key, params={"nu": 0.3, "shape": "circle"}, status=status, message="" if status == OK else "boom",
        record=record, wall_time_s=0.25, finished=finished, rank=0,
    )


def test_round_trip_is_exact(tmp_path):
    value = np.float64(1.0) / 3.0
    with Journal(tmp_path / "rank00000-a.h5", 0, {"session": "a"}) as journal:
        journal.append(entry("k1", K_xx=value, nx=np.int64(16), plan={"solves": ["x", "y"]}, tiny=5e-324))
        journal.append(entry("k2", status=ERROR))
    entries = read_journals(tmp_path)
    assert set(entries) == {"k1", "k2"}
    assert entries["k1"].record == {"K_xx": value, "nx": 16, "plan": {"solves": ["x", "y"]}, "tiny": 5e-324}
    assert entries["k1"].params == {"nu": 0.3, "shape": "circle"}
    assert entries["k2"].status == ERROR and entries["k2"].message == "boom"
    with h5py.File(tmp_path / "rank00000-a.h5") as f:
        assert f.attrs["session"] == "a" and f.attrs["rows"] == 2


def test_all_journals_are_read_and_success_wins(tmp_path):
    with Journal(tmp_path / "rank00000-a.h5", 0, {}) as a, Journal(tmp_path / "rank00001-a.h5", 1, {}) as b:
        a.append(entry("k1", status=ERROR, finished=1.0))
        b.append(entry("k1", finished=2.0, K_xx=1.0))
        b.append(entry("k2", finished=3.0, K_xx=2.0))
        a.append(entry("k2", finished=4.0, K_xx=3.0))
    entries = read_journals(tmp_path)
    assert entries["k1"].status == OK and entries["k1"].rank == 1
    assert entries["k2"].record["K_xx"] == 2.0  # the earlier of two successes


def test_unfinished_rows_and_unreadable_files_are_skipped(tmp_path, capsys):
    with Journal(tmp_path / "rank00000-a.h5", 0, {}) as journal:
        journal.append(entry("k1", K_xx=1.0))
        journal.append(entry("k2", K_xx=2.0))
    with h5py.File(tmp_path / "rank00000-a.h5", "a") as f:
        f.attrs["rows"] = 1  # as if killed between writing the row and counting it
    (tmp_path / "rank00001-a.h5").write_bytes(b"not hdf5")
    assert set(read_journals(tmp_path)) == {"k1"}
    assert "rank00001-a.h5" in capsys.readouterr().err


def test_files_appear_with_the_first_entry_and_clear_journals_removes_only_them(tmp_path):
    with Journal(tmp_path / "rank00001-a.h5", 1, {}):
        pass
    assert journal_files(tmp_path) == []
    with Journal(tmp_path / "rank00000-a.h5", 0, {}) as journal:
        journal.append(entry("k1"))
    (tmp_path / "notes.txt").write_text("keep")
    assert len(journal_files(tmp_path)) == 1
    clear_journals(tmp_path)
    assert journal_files(tmp_path) == [] and (tmp_path / "notes.txt").exists()
    assert read_journals(tmp_path / "missing") == {}


WRITER = """
import sys, time
from hpcontact.sweep.journal import Entry, Journal
journal = Journal(sys.argv[1], 0, {})
for i in range(10**6):
    journal.append(Entry(f"{sys.argv[2]}-{i}", {"i": i}, 0, "", {"K_xx": i / 3.0}, 0.0, time.time(), 0))
    if i == 20:
        print("ready", flush=True)
"""


def test_a_writer_killed_mid_append_leaves_a_readable_journal(tmp_path):
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": f"{root}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    for attempt in range(3):
        path = tmp_path / f"rank0000{attempt}-k.h5"
        proc = subprocess.Popen([sys.executable, "-c", WRITER, str(path), str(attempt)], stdout=subprocess.PIPE, env=env)
        assert proc.stdout.readline().strip() == b"ready"
        time.sleep(0.05 * attempt)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stdout.close()
    entries = read_journals(tmp_path)
    assert len(entries) >= 3 * 21
    assert all(e.record["K_xx"] == e.params["i"] / 3.0 for e in entries.values())
