"""May this run use this output? (hpcontact.sweep.run.guard): usable folders and outputs, names the
OS can take, and the run lock — held, refused, taken over from a dead holder, released. The
paths that must stay apart are tested in test_guard_paths.py; these tests call the guard alone."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from hpcontact.errors import InputError
from hpcontact.sweep.data.journal import JOB_VARIABLES
from hpcontact.sweep.run.guard import LOCK_NAME, Refused, RunLock, usable_folder, usable_names, usable_output


@pytest.fixture(autouse=True)
def _no_batch_job(monkeypatch):
    for name in JOB_VARIABLES:
        monkeypatch.delenv(name, raising=False)


def _dead_pid() -> int:
    """The pid of a process that has ended (and been reaped)."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_a_refusal_is_an_input_error_that_prints_as_its_line():
    refusal = Refused("the output is in use")
    assert isinstance(refusal, InputError) and str(refusal) == "the output is in use"


def test_a_missing_folder_is_created_when_its_parent_exists(tmp_path):
    usable_folder(tmp_path / "new", "journal folder")
    assert (tmp_path / "new").is_dir() and os.listdir(tmp_path / "new") == []  # the probe removed


def test_a_missing_grandparent_is_a_typo_refused_naming_it(tmp_path):
    with pytest.raises(Refused, match=f"the parent folder of the output folder {tmp_path}/a/b does not exist"):
        usable_folder(tmp_path / "a" / "b", "output folder")
    assert not (tmp_path / "a").exists()


def test_a_file_in_place_of_the_folder_is_refused(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(Refused, match=f"the journal folder {tmp_path}/f is not a folder"):
        usable_folder(tmp_path / "f", "journal folder")


def test_an_output_may_be_a_new_or_an_existing_file(tmp_path):
    usable_output(tmp_path / "out" / "new.nc")
    (tmp_path / "old.nc").write_bytes(b"old")
    usable_output(tmp_path / "old.nc")
    assert (tmp_path / "out").is_dir() and (tmp_path / "old.nc").read_bytes() == b"old"


@pytest.mark.parametrize(("make", "what"), [("folder", "a folder"), ("device", "not a regular file")])
def test_an_output_that_is_no_file_is_refused(tmp_path, make, what):
    path = tmp_path / "out.nc"
    if make == "folder":
        path.mkdir()
    else:
        path.symlink_to("/dev/null")
    with pytest.raises(Refused, match=f"the output {path} is {what}, not a file: name another output"):
        usable_output(path)


def _spec(folder: Path, output: str) -> SimpleNamespace:
    """What ``usable_names`` reads of a spec: its output, journal folder, path and text."""
    return SimpleNamespace(
        output=folder / output, journal=folder / f"{output}.journal", path=folder / "spec.toml", text="[sweep]\n"
    )


def test_a_nul_in_the_output_is_refused_and_shown_escaped(tmp_path):
    with pytest.raises(Refused, match=r"contains a NUL character: name a path without one") as caught:
        usable_names(_spec(tmp_path, "out\0.nc"))
    assert "\\x00" in str(caught.value) and "\0" not in str(caught.value)


def test_the_longest_output_name_leaves_room_for_its_temporary_file(tmp_path):
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    # the temporary data set of the write: ".NAME.tmp-PID", a pid of at most 7 digits;
    # the journal folder NAME.journal is checked on its own
    longest = next(n for n in range(limit, 0, -1) if len(f".{'x' * n}.tmp-{9_999_999}") <= limit)
    fits = _spec(tmp_path, "x" * longest)
    fits.journal = tmp_path / "journal"
    usable_names(fits)
    over = _spec(tmp_path, "x" * (longest + 1))
    over.journal = tmp_path / "journal"
    with pytest.raises(Refused, match=f"has a name component of {longest + 1} bytes, over the {longest} this"):
        usable_names(over)


def test_a_journal_folder_name_over_the_limit_is_refused_naming_it(tmp_path):
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    spec = _spec(tmp_path, "out.nc")
    spec.journal = tmp_path / ("j" * (limit + 1))
    with pytest.raises(Refused, match=f"the journal folder .* has a name component of {limit + 1} bytes"):
        usable_names(spec)


def test_a_lock_holds_the_holder_and_refuses_a_second_run_naming_it(tmp_path):
    first = RunLock(tmp_path, ranks=2)
    assert first.acquire() is None and first.held
    record = json.loads((tmp_path / LOCK_NAME).read_text())
    assert record["host"] == socket.gethostname() and record["pid"] == os.getpid()
    assert record["ranks"] == 2 and record["job"] is None and record["started"]
    second = RunLock(tmp_path, ranks=1)
    with pytest.raises(Refused) as caught:
        second.acquire()
    assert str(caught.value).startswith(
        f"{tmp_path} is in use by a run on {socket.gethostname()} (pid {os.getpid()}, 2 ranks"
    )
    assert str(caught.value).endswith("if that run is dead, pass --break-lock")
    second.release()  # not the holder: the lock stays
    assert first.holder() == record
    first.release()
    assert not (tmp_path / LOCK_NAME).exists() and first.holder() is None
    assert [p.name for p in tmp_path.iterdir()] == []  # no temporary record left


def test_the_lock_of_a_dead_process_on_this_host_is_taken_over(tmp_path):
    pid = _dead_pid()
    (tmp_path / LOCK_NAME).write_text(json.dumps({"host": socket.gethostname(), "pid": pid, "ranks": 1}))
    lock = RunLock(tmp_path, ranks=1)
    assert lock.acquire() == f"took over the lock of {socket.gethostname()} pid {pid} (pid {pid} on this host is gone)"
    assert lock.holder()["pid"] == os.getpid()
    assert sorted(p.name for p in tmp_path.iterdir()) == [LOCK_NAME]  # the stale lock moved away and removed


def test_the_lock_of_the_same_batch_job_is_taken_over_and_another_hosts_lock_is_not(tmp_path, monkeypatch):
    (tmp_path / LOCK_NAME).write_text(json.dumps({"host": "elsewhere", "pid": 1, "job": "77"}))
    with pytest.raises(Refused, match=r"in use by a run on elsewhere \(pid 1, \? ranks, since \?, job 77\)"):
        RunLock(tmp_path, ranks=1).acquire()
    monkeypatch.setenv("SLURM_JOB_ID", "77")
    lock = RunLock(tmp_path, ranks=1)
    assert lock.acquire() == "took over the lock of elsewhere pid 1 (batch job 77 was requeued)"
    assert lock.holder()["job"] == "77"


def test_break_lock_takes_over_a_live_holder(tmp_path):
    (tmp_path / LOCK_NAME).write_text(json.dumps({"host": "elsewhere", "pid": 1}))
    assert RunLock(tmp_path, ranks=1).acquire(break_lock=True) == "took over the lock of elsewhere pid 1 (--break-lock)"


@pytest.mark.parametrize(
    "content",
    [b"", b"\0" * 150, b"not json", b'{"host": "", "pid": 3}', b'{"host": "h", "pid": true}', b" " * 5000],
)
def test_a_lock_that_is_no_record_is_unreadable_and_refused_without_journals(tmp_path, content):
    (tmp_path / LOCK_NAME).write_bytes(content)
    lock = RunLock(tmp_path, ranks=1)
    assert lock.holder() == {}
    with pytest.raises(Refused, match=f"the lock {tmp_path / LOCK_NAME} is unreadable .* pass --break-lock"):
        lock.acquire()
    assert (tmp_path / LOCK_NAME).read_bytes() == content  # left as it was
    assert lock.acquire(break_lock=True) == f"took over the unreadable lock {tmp_path / LOCK_NAME} (--break-lock)"
