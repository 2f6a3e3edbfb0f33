"""Faults found by testing (issue 30), in one process: each gives its documented outcome.

1. the data set cannot be written (the netCDF library fails as on a full disk): exit 1, one line
   naming the output, journals intact, ``--resume`` writes it;
2. a lock left empty, zero-filled or garbage by a crash: taken over when the journals of its run
   name this batch job or this host with its process gone, else refused naming ``--break-lock``;
   the lock is written complete (synced, then linked into place) or not at all;
3. journal lines with a valid CRC but missing or mistyped fields: dropped and counted, never
   fatal; the run reports the lines it dropped in one line;
4. a hostile cost-model cache (deeply nested JSON, an endless file, a FIFO, a huge file, wrong
   types): ignored with a warning and replaced;
5. a spec that is not UTF-8 or is empty, an output that is a folder: exit 2, one line, before any
   task;
6. the data set's variables carry checksums; a damaged chunk makes ``open_dataset`` raise an
   error naming the file and the variable.
"""

from __future__ import annotations

import errno
import functools
import io
import json
import os
import socket
import subprocess
import sys
import time
import zlib
from pathlib import Path

import h5py
import netCDF4
import numpy as np
import pytest
import xarray as xr

from hpcontact import __version__
from hpcontact.sweep.cost import calibration_file, rates
from hpcontact.sweep.cost.rates import Calibration, Rate
from hpcontact.sweep.data import netcdf
from hpcontact.sweep.data.dataset import DamagedFile, open_dataset
from hpcontact.sweep.data.journal import OK, Entry, Journal, journal_files, read_history, read_journals
from hpcontact.sweep.driver import main
from hpcontact.sweep.run.guard import LOCK_NAME, Refused, RunLock
from hpcontact.sweep.run.records import Options

SPEC = """
[sweep]
title = "fault inputs"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 16
[axes]
shape = ["circle", "ellipse"]
aspect = [1.0, 0.5]
nu = [0.0, 0.25, 0.5]
"""
TASKS = 3 + 2 * 3  # the circle ignores the aspect


def counting(function, calls):
    @functools.wraps(function)  # ``function``'s runner: a resume with it reuses ``function``'s entries
    def task(params):
        calls.append(params)
        return function(params)

    return task


def never(params):
    raise AssertionError("no task may run")


@pytest.fixture
def cli(monkeypatch, capsys):
    """``hpcontact run ARGS`` in this process (no MPI): exit status, stdout, stderr."""
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    monkeypatch.delenv("HPCONTACT_FAULTS", raising=False)

    def run(*args: str, task_function=None) -> tuple[int, str, str]:
        status = main([str(a) for a in args], task_function=task_function)
        out, err = capsys.readouterr()
        return status, out, err

    return run


# 1. The data set cannot be written ------------------------------------------------------------


def test_a_data_set_write_that_fails_as_on_a_full_disk_exits_1_in_one_line_and_resume_writes_it(
    write_spec, fake_solve, tmp_path, monkeypatch, cli
):
    spec = write_spec(SPEC)
    monkeypatch.setenv("HPCONTACT_DATA_SET_LIMIT", "4096")  # RLIMIT_FSIZE while the data set is written
    status, _, err = cli(spec, task_function=fake_solve)
    assert status == 1, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert (
        f"cannot write the data set {tmp_path / 'out.nc'}: " in err and "free space and run again with --resume" in err
    )
    assert not (tmp_path / "out.nc").exists() and not list(tmp_path.glob(".out.nc.tmp-*"))  # no partial file
    assert len(read_journals(tmp_path / "out.nc.journal")) == TASKS  # journals intact
    assert not (tmp_path / "out.nc.journal" / LOCK_NAME).exists()  # released
    monkeypatch.delenv("HPCONTACT_DATA_SET_LIMIT")
    calls = []
    status, out, err = cli(spec, "--resume", task_function=counting(fake_solve, calls))
    assert status == 0 and calls == [], out + err
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        assert (ds.status == OK).all() and int(ds.attrs["sweep_tasks_run"]) == 0


def test_a_failed_write_keeps_the_old_data_set_and_names_the_output(tmp_path, monkeypatch):
    ds = xr.Dataset({"K_xx": (("nu",), np.linspace(1.0, 2.0, 50))}, coords={"nu": np.linspace(0.0, 0.5, 50)})
    path = netcdf.write(ds, tmp_path / "out.nc")
    before = path.read_bytes()
    monkeypatch.setenv("HPCONTACT_DATA_SET_LIMIT", "2048")
    with pytest.raises(OSError) as info:
        netcdf.write(ds * 2.0, path)
    assert info.value.filename == str(path) and "NetCDF" in info.value.strerror  # the library's own words
    assert path.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["out.nc"]


@pytest.mark.parametrize(("free", "expected"), [(0, errno.ENOSPC), (10 * 2**30, errno.EIO)])
def test_a_netcdf_error_with_no_space_left_reads_as_enospc(tmp_path, monkeypatch, free, expected):
    class Stats:
        f_bavail, f_frsize = free, 1

    monkeypatch.setattr(netcdf.os, "statvfs", lambda path: Stats())
    error = netcdf._write_error("NetCDF: HDF error", tmp_path / "out.nc", 5000)
    assert error.errno == expected and error.filename == str(tmp_path / "out.nc")
    assert "NetCDF: HDF error" in error.strerror
    assert ("No space left on device" in error.strerror) == (expected == errno.ENOSPC)


# 2. A lock left unreadable by a crash ---------------------------------------------------------


def _dead_pid() -> int:
    return int(
        subprocess.run(
            [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True, check=True
        ).stdout
    )


def _dead_run(folder: Path, lock: bytes, *, job: str | None, host: str | None = None, pid: int | None = None) -> None:
    """What a run that died leaves: its journal (header naming host, pid, job) and a lock
    holding ``lock``, older than the journal (a run takes its lock first)."""
    folder.mkdir(exist_ok=True)
    header = {"session": "dead", "job": job, "pid": pid if pid is not None else _dead_pid()}
    if host is not None:
        header["host"] = host
    with Journal(folder / "rank00000-dead.jsonl", 0, header) as journal:
        journal.started("k1")
    (folder / LOCK_NAME).write_bytes(lock)
    then = time.time() - 60.0
    os.utime(folder / LOCK_NAME, (then, then))


UNREADABLE = [b"", b"\0" * 97, b'{"host": "n1", "pi', b"[1, 2]", b'{"host": "", "pid": "7"}', b"\xff\xfe" * 9]


@pytest.mark.parametrize("lock", UNREADABLE)
def test_an_unreadable_lock_of_this_batch_job_is_taken_over(tmp_path, monkeypatch, lock):
    monkeypatch.setenv("SLURM_JOB_ID", "77")
    _dead_run(tmp_path, lock, job="77", host="another-node", pid=os.getpid())  # requeued onto another node
    run = RunLock(tmp_path, 2)
    note = run.acquire()
    assert note is not None and "took over the unreadable lock" in note and "batch job 77" in note
    assert json.loads((tmp_path / LOCK_NAME).read_text())["pid"] == os.getpid()
    run.release()
    assert not (tmp_path / LOCK_NAME).exists()


def test_an_unreadable_lock_of_this_host_with_its_process_gone_is_taken_over(tmp_path, monkeypatch):
    monkeypatch.delenv("SLURM_JOB_ID", raising=False)
    for name in ("PBS_JOBID", "LSB_JOBID", "JOB_ID"):
        monkeypatch.delenv(name, raising=False)
    dead = _dead_pid()
    _dead_run(tmp_path, b"\0" * 120, job=None, pid=dead)
    note = RunLock(tmp_path, 1).acquire()
    assert note is not None and f"this host, where pid {dead} is gone" in note


@pytest.mark.parametrize("case", ["no journal", "other job, other host", "this host, process alive"])
def test_an_unreadable_lock_without_evidence_is_refused_naming_break_lock(tmp_path, monkeypatch, case):
    monkeypatch.setenv("SLURM_JOB_ID", "78")
    if case == "no journal":
        tmp_path.joinpath(LOCK_NAME).write_bytes(b"")
    elif case == "other job, other host":
        _dead_run(tmp_path, b"", job="77", host="another-node")
    else:
        _dead_run(tmp_path, b"", job=None, pid=os.getpid())
    with pytest.raises(Refused) as info:
        RunLock(tmp_path, 1).acquire()
    message = str(info.value)
    assert "\n" not in message and f"the lock {tmp_path / LOCK_NAME} is unreadable" in message
    assert message.endswith("pass --break-lock") and "?" in message  # "... reached the disk?"
    assert (tmp_path / LOCK_NAME).read_bytes() in (b"",)  # left as it was
    note = RunLock(tmp_path, 1).acquire(break_lock=True)
    assert note is not None and "--break-lock" in note and json.loads((tmp_path / LOCK_NAME).read_text())


def test_a_requeued_run_takes_over_an_empty_lock_and_completes(sweep, write_spec, fake_solve, tmp_path, monkeypatch):
    monkeypatch.setenv("SLURM_JOB_ID", "77")
    spec = write_spec(SPEC)
    calls = []

    @functools.wraps(fake_solve)  # fake_solve's runner, as the resume's
    def dies(params):
        if len(calls) == 4:
            raise KeyboardInterrupt  # the node crashes: no outcome, lock left behind
        calls.append(params)
        return fake_solve(params)

    with pytest.raises(KeyboardInterrupt):
        sweep(spec, task_function=dies)
    folder = tmp_path / "out.nc.journal"
    (folder / LOCK_NAME).write_bytes(b"")  # its content never reached the disk
    then = time.time() - 60.0
    os.utime(folder / LOCK_NAME, (then, then))
    stream = io.StringIO()
    sweep(spec, task_function=counting(fake_solve, calls), options=Options(resume=True), stream=stream)
    assert "took over the unreadable lock" in stream.getvalue() and "batch job 77" in stream.getvalue()
    assert len(calls) == TASKS and not (folder / LOCK_NAME).exists()


def test_the_lock_appears_complete_synced_and_linked_into_place(tmp_path, monkeypatch):
    events = []
    fsync, link = os.fsync, os.link

    def recording_fsync(fd):
        events.append(("fsync", os.readlink(f"/proc/self/fd/{fd}")))
        return fsync(fd)

    def recording_link(src, dst):
        events.append(("link", str(src), str(dst)))
        assert json.loads(Path(src).read_text())["pid"] == os.getpid()  # complete before it has the name
        return link(src, dst)

    monkeypatch.setattr(os, "fsync", recording_fsync)
    monkeypatch.setattr(os, "link", recording_link)
    RunLock(tmp_path, 3).acquire()
    (first, tmp), (kind, src, dst), (last, folder) = events
    assert (first, kind, last) == ("fsync", "link", "fsync")
    assert src == tmp and dst == str(tmp_path / LOCK_NAME) and folder == str(tmp_path)
    assert os.listdir(tmp_path) == [LOCK_NAME] and json.loads((tmp_path / LOCK_NAME).read_text())["ranks"] == 3


def test_a_takeover_puts_back_a_lock_that_changed_in_between(tmp_path):
    (tmp_path / LOCK_NAME).write_bytes(b'{"host": "n2", "pid": 5}')  # another run took it over meanwhile
    run = RunLock(tmp_path, 1)
    assert run._take_over(b"") is False
    assert (tmp_path / LOCK_NAME).read_bytes() == b'{"host": "n2", "pid": 5}' and os.listdir(tmp_path) == [LOCK_NAME]


# 3. Journal lines with a valid CRC but missing fields -----------------------------------------


def _line(event: dict) -> bytes:
    payload = json.dumps(event).encode()
    return b"%08x %s\n" % (zlib.crc32(payload), payload)


def _finished(key: str, **changes) -> dict:
    event = {
        "event": "finished",
        "key": key,
        "params": {"nu": 0.3},
        "status": OK,
        "message": "",
        "record": {"K": 1.0},
        "wall_time_s": 0.5,
        "finished": 10.0,
        "resolved": {},
        "provenance": {},
    }
    event.update(changes)
    return {k: v for k, v in event.items() if v is not None}


MALFORMED = [
    _finished("m1", record=None),  # no record
    _finished("m2", status="ok"),  # a status that is not a code
    _finished("m3", finished="soon"),
    _finished("m4", params=[1, 2]),
    {**_finished("m5"), "key": 5},  # a key that is not text
    {k: v for k, v in _finished("m5b").items() if k != "key"},
    _finished("m6", status=True),
    _finished("m7", provenance="git"),
    {"event": "started", "key": "m8"},  # no time
    {"event": "started", "key": "m9", "time": float("nan")},
    {"event": "interrupted", "reason": "x"},  # no key
    {"key": "m10"},  # no event
]


def test_malformed_entries_are_dropped_and_counted_never_fatal(tmp_path):
    good = [
        _finished("g1"),
        _finished("g2", finished=11.0),
        {"event": "started", "key": "g3", "time": 12.0},
        {"event": "future-kind", "key": "g4"},
    ]
    header = {"event": "run", "rank": 0, "host": "n1", "pid": 1, "session": "s"}
    data = _line(header) + b"".join(_line(e) for e in good + MALFORMED)
    data += b"00000000 " + json.dumps(_finished("bad-crc")).encode() + b"\n"  # damaged
    data += _line(_finished("torn"))[:-7]  # incomplete
    (tmp_path / "rank00000-s.jsonl").write_bytes(data)
    history = read_history(tmp_path)
    assert set(history.entries) == {"g1", "g2"} and set(history.unfinished) == {"g3"}
    assert history.entries["g1"].rank == 0 and history.entries["g1"].host == "n1"
    assert history.dropped == len(MALFORMED) + 2
    assert (
        history.dropped_note(tmp_path)
        == f"{len(MALFORMED) + 2} journal lines dropped (damaged or incomplete) in {tmp_path}"
    )
    # a header with a valid CRC and a mistyped field is dropped too; the entries after it are kept
    (tmp_path / "rank00000-s.jsonl").write_bytes(_line({**header, "rank": "zero"}) + _line(_finished("g1")))
    history = read_history(tmp_path)
    assert set(history.entries) == {"g1"} and history.entries["g1"].rank == -1 and history.dropped == 1
    assert history.dropped_note(tmp_path).startswith("1 journal line dropped")
    (tmp_path / "rank00000-s.jsonl").write_bytes(_line(header) + _line(_finished("g1")))
    assert read_history(tmp_path).dropped == 0 and read_history(tmp_path).dropped_note(tmp_path) is None


def test_resume_with_malformed_entries_recomputes_them_and_reports_the_lines_dropped(
    write_spec, fake_solve, tmp_path, cli
):
    spec = write_spec(SPEC)
    status, _, err = cli(spec, task_function=fake_solve)
    assert status == 0, err
    (path,) = journal_files(tmp_path / "out.nc.journal")
    lines = path.read_bytes().split(b"\n")
    broken = 0
    for i, line in enumerate(lines):
        event = json.loads(line.partition(b" ")[2]) if line else {}
        if event.get("event") == "finished" and broken < 3:  # valid CRC, fields missing
            event.pop(("record", "status", "finished")[broken])
            lines[i] = _line(event)[:-1]
            broken += 1
    lines[-2] = lines[-2][:-1] + b"X"  # and a damaged line
    path.write_bytes(b"\n".join(lines))
    calls = []
    status, out, err = cli(spec, "--resume", task_function=counting(fake_solve, calls))
    assert status == 0, out + err
    assert len(calls) == 4  # the three malformed entries and the damaged one: computed again, nothing else
    noted = [line for line in out.splitlines() if "journal lines dropped" in line]
    assert noted == [
        f"hpcontact: warning: 4 journal lines dropped (damaged or incomplete) in {tmp_path / 'out.nc.journal'}"
    ]


# 4. A hostile cost-model cache ----------------------------------------------------------------


def _fresh() -> Calibration:
    return Calibration(socket.gethostname(), __version__, {k: Rate(1e-7, 0.0) for k in rates.KINDS}, 1.0)


def _valid_record() -> dict:
    return {
        "format": calibration_file.FORMAT,
        "host": socket.gethostname(),
        "version": __version__,
        "cpu": rates.node_type()[0],
        "cores": rates.node_type()[1],
        "date": "2026-11-28 12:00 UTC",
        "base_bytes": 1.0,
        "seconds": 1.0,
        "rates": {
            k: {
                "rate_s": 1e-7,
                "solve_s": 0.0,
                "node_s": 0.0,
                "cell_s": 0.0,
                "task_s": 0.0,
                "strip_s": 0.0,
                "exact_s": 0.0,
            }
            for k in rates.KINDS
        },
    }


HOSTILE = {
    "100000 deep": ("[" * 100_000 + "]" * 100_000, "nested deeper than"),
    "deep inside a string is fine, deep outside is not": (
        '{"a": "[[[[[[[[[[", "b": ' + "[" * 20 + "]" * 20 + "}",
        "nested deeper than",
    ),
    "2 MiB": (" " * 2**21 + json.dumps(_valid_record()), "larger than 1048576 bytes"),
    "a string rate": (
        json.dumps(
            {
                **_valid_record(),
                "rates": {**_valid_record()["rates"], "slip": {**_valid_record()["rates"]["slip"], "rate_s": "1e-7"}},
            }
        ),
        "rates.slip.rate_s must be a number",
    ),
    "a list host": (json.dumps({**_valid_record(), "host": [socket.gethostname()]}), "host and version missing"),
    "rates a list": (json.dumps({**_valid_record(), "rates": [1]}), "missing"),
    "not UTF-8": (b"\xff" * 10, "can't decode"),
}


@pytest.mark.parametrize("name", HOSTILE)
def test_a_hostile_cost_cache_is_ignored_with_a_warning_and_replaced(tmp_path, monkeypatch, name):
    content, why = HOSTILE[name]
    path = tmp_path / "cm.json"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    cached, reason = calibration_file.cached_calibration(path)
    assert cached is None and f"cost calibration {path} ignored: " in reason and why in reason, reason
    monkeypatch.setattr(calibration_file, "calibrate", _fresh)
    with pytest.warns(RuntimeWarning, match="ignored"):
        assert calibration_file.load_calibration(path) == _fresh()
    assert calibration_file.read_calibration(path) == _fresh()  # replaced


def test_a_valid_cache_still_reads(tmp_path):
    path = tmp_path / "cm.json"
    path.write_text(json.dumps(_valid_record(), indent=1))
    assert calibration_file.cached_calibration(path)[0] == Calibration(
        socket.gethostname(),
        __version__,
        {k: Rate(1e-7, 0.0) for k in rates.KINDS},
        1.0,
        1.0,
        date="2026-11-28 12:00 UTC",
    )


@pytest.mark.parametrize("kind", ["/dev/zero", "fifo"])
def test_an_endless_or_blocking_cost_cache_is_ignored_at_once_and_replaced(tmp_path, kind):
    """In a child process with a timeout: reading /dev/zero to its end, or waiting on a FIFO's
    writer, would hang or exhaust memory."""
    path = tmp_path / "calibration.json"
    if kind == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to("/dev/zero")
    code = (
        "import sys, warnings; from pathlib import Path; from hpcontact.sweep.cost import calibration_file, rates; from hpcontact.sweep.work import estimate\n"
        "path = Path(sys.argv[1]); cached, why = calibration_file.cached_calibration(path); print(why)\n"
        "print(estimate.start_estimate([], 2)[0])\n"
        "from hpcontact import __version__; import socket\n"
        "fresh = rates.Calibration(socket.gethostname(), __version__, {k: rates.Rate(1e-7, 0.0) for k in "
        "rates.KINDS}, 1.0)\n"
        "calibration_file.calibrate = lambda: fresh\n"
        "with warnings.catch_warnings(record=True) as seen:\n"
        "    warnings.simplefilter('always'); assert calibration_file.load_calibration(path) == fresh\n"
        "print(seen[0].message); assert calibration_file.read_calibration(path) == fresh\n"
    )
    env = {**os.environ, "HPCONTACT_COSTMODEL": str(path)}
    done = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, timeout=120, env=env)
    assert done.returncode == 0, done.stdout + done.stderr
    why, start, warning = done.stdout.splitlines()
    assert why == f"cost calibration {path} ignored: not a regular file"
    assert start.startswith("hpcontact: estimated 0 core-seconds") and "(shipped prior of " in start
    assert f"(cost calibration {path} ignored: not a regular file;" in start
    assert warning == why and path.is_file() and not path.is_symlink()  # replaced by a file


# 5. Specs and outputs refused up front --------------------------------------------------------


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (SPEC.replace('"fault inputs"', '"d\xe9fauts"').encode("latin-1"), "a TOML file in UTF-8 (byte "),
        (b"", "a TOML spec with content (this file is empty or holds only comments)"),
        (b"  \n\t\n", "a TOML spec with content"),
        (b"# a comment\n   # another\n", "a TOML spec with content"),
    ],
)
def test_a_spec_not_utf8_or_empty_exits_2_in_one_line_before_any_task(tmp_path, cli, content, expected):
    spec = tmp_path / "spec.toml"
    spec.write_bytes(content)
    status, out, err = cli(spec, task_function=never)
    assert status == 2 and err.count("\n") == 1, err
    assert err.startswith(f"hpcontact run: error: spec = '{spec}': ") and expected in err
    assert os.listdir(tmp_path) == ["spec.toml"]  # no journal folder, no output


def test_an_output_that_is_a_folder_exits_2_in_one_line_before_any_task(write_spec, tmp_path, cli):
    spec = write_spec(SPEC)
    (tmp_path / "out.nc").mkdir()
    status, out, err = cli(spec, task_function=never)
    assert status == 2 and err.count("\n") == 1, err
    assert f"the output {tmp_path / 'out.nc'} is a folder, not a file" in err and "--output" in err
    assert not (tmp_path / "out.nc.journal").exists() and not os.listdir(tmp_path / "out.nc")


def test_an_output_that_is_a_device_is_refused(sweep, write_spec, tmp_path):
    (tmp_path / "out.nc").symlink_to("/dev/null")
    with pytest.raises(Refused, match="is not a regular file, not a file"):
        sweep(write_spec(SPEC), task_function=never)


# 6. Checksums on every variable, and the damaged one named ------------------------------------


@pytest.fixture
def written(sweep, write_spec, fake_solve, tmp_path) -> Path:
    return sweep(write_spec(SPEC), task_function=fake_solve)


def _flip(path: Path, variable: str, where: float = 0.5) -> None:
    """Flip one byte inside the first stored chunk of ``variable``."""
    with h5py.File(path, "r") as h5:
        info = h5[variable].id.get_chunk_info(0)
    offset = info.byte_offset + int(where * (info.size - 1))
    with open(path, "r+b") as fh:
        fh.seek(offset)
        byte = fh.read(1)[0]
        fh.seek(offset)
        fh.write(bytes([byte ^ 0x5A]))


def test_every_variable_with_dimensions_is_written_with_a_checksum(written):
    with netCDF4.Dataset(written) as nc:
        dimensioned = [name for name, var in nc.variables.items() if var.ndim]
        assert {"K_xx", "status", "message", "nu"} <= set(dimensioned)
        assert [name for name in dimensioned if not nc.variables[name].filters()["fletcher32"]] == []
    ds = open_dataset(written)
    assert (ds.status == OK).all() and np.isfinite(ds.K_xx).all()  # verified and read back whole
    ds.close()


@pytest.mark.parametrize(("variable", "where"), [("K_xx", 0.5), ("status", 0.5), ("message", 0.3), ("K_xx", 1.0)])
def test_a_damaged_variable_is_named_on_open_not_read_as_numbers(written, variable, where):
    _flip(written, variable, where)  # where = 1.0: the stored checksum itself
    with pytest.raises(DamagedFile) as info:
        open_dataset(written)
    assert isinstance(info.value, OSError) and info.value.variable == variable
    assert str(info.value).startswith(f"{written}: variable {variable} is damaged (NetCDF: HDF error")
    with xr.open_dataset(written) as ds, pytest.raises(RuntimeError, match="HDF error"):
        ds[variable].load()  # unverified, the read still fails: never numbers


def test_a_file_that_is_not_netcdf_fails_naming_it(tmp_path):
    path = tmp_path / "out.nc"
    path.write_bytes(b"\0" * 4096)
    with pytest.raises(OSError, match="out.nc"):
        open_dataset(path)


def test_verify_reads_large_variables_a_few_chunks_at_a_time(monkeypatch):
    monkeypatch.setattr(netcdf, "VERIFY_BYTES", 1500)
    regions = list(netcdf._regions((4, 10, 30), (1, 5, 30), 8))  # 2400 bytes a row: chunk by chunk on 2 axes
    assert len(regions) == 8 and regions[0] == (slice(0, 1), slice(0, 5), slice(None))
    assert list(netcdf._regions((4, 3), (2, 3), 8)) == [(slice(None), slice(None))]  # 96 bytes: all at once
    assert list(netcdf._regions((), (), 8)) == [()]


def test_entries_of_a_well_formed_journal_are_unchanged(tmp_path):
    entry = Entry(
        key="k",
        params={"nu": 0.3},
        status=OK,
        message="",
        record={"K_xx": 1.5, "plan": {"a": [1]}},
        wall_time_s=float("nan"),
        finished=3.0,
        rank=0,
        resolved={"nu": 0.3},
        provenance={"v": "1"},
    )
    with Journal(tmp_path / "rank00000-a.jsonl", 0, {"session": "a"}) as journal:
        journal.append(entry)
    history = read_history(tmp_path)
    got = history.entries["k"]
    assert history.dropped == 0 and got.record == entry.record and np.isnan(got.wall_time_s)
    assert history.headers[0]["job"] == os.environ.get("SLURM_JOB_ID") or history.headers[0]["job"] is None


# 7. Malformed inputs refused naming the field (issue 43 item 7) -------------------------------


@pytest.mark.parametrize("kind", ["folder", "fifo", "device", "large"])
def test_a_spec_that_is_not_a_regular_file_or_too_large_exits_2_in_one_line(tmp_path, cli, kind):
    from hpcontact.sweep.space.parse import MAX_SPEC_BYTES

    path = {"folder": tmp_path, "fifo": tmp_path / "spec.toml", "device": Path("/dev/zero")}.get(kind)
    if kind == "fifo":
        os.mkfifo(path)
    if kind == "large":
        path = tmp_path / "spec.toml"
        path.write_text("# " + "x" * MAX_SPEC_BYTES + "\n" + SPEC)
    status, _, err = cli(path, task_function=never)
    assert status == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert f"spec = {str(path)!r}" in err and "at most 16 MiB" in err


@pytest.mark.parametrize("name", ["a\0b.nc", "a" * 300 + ".nc"])
def test_an_output_the_os_cannot_name_exits_2_naming_the_output(write_spec, tmp_path, cli, name):
    spec = write_spec(SPEC)
    status, _, err = cli(spec, "--output", str(tmp_path / name), task_function=never)
    assert status == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert "the output" in err and "--output" in err
    named = SPEC.replace("[sweep]", f"[sweep]\noutput = {json.dumps(str(tmp_path / name))}")
    status, _, err = cli(write_spec(named), task_function=never)
    assert status == 2 and "sweep.output" in err and "Traceback" not in err, err


def test_every_shipped_spec_is_still_accepted():
    from hpcontact.sweep.space.parse import MAX_SPEC_BYTES, load_spec, parse_spec

    jobs = sorted((Path(__file__).parents[3] / "jobs").glob("*.toml"))
    assert jobs
    for job in jobs:
        assert job.stat().st_size < MAX_SPEC_BYTES
        assert load_spec(job, check_scenes=False).text == job.read_text(encoding="utf-8")
        parse_spec(job.read_text(encoding="utf-8"), path=job, check_scenes=False)
