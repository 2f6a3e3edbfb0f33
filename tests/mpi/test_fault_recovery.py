"""Faults found by testing (issue 30), with real 2-rank runs (``mpiexec -n 2 hpcontact run``):

* the data set cannot be written (``HPCONTACT_DATA_SET_LIMIT``: the netCDF library fails as on
  a full disk): exit 1 with one line naming the output, no traceback, no MPI abort; journals
  intact; ``--resume`` writes it without computing anything;
* a requeued batch job finds the lock of its dead first run zero-filled (a node crash before
  the lock reached the disk): it takes the lock over and completes;
* journal lines with a valid CRC but missing fields: ``--resume`` completes, recomputes those
  tasks only and says how many lines it dropped;
* a cost-model cache that is a symlink to /dev/zero, or 100 000-deep JSON: the run completes
  without a cost estimate;
* a spec that is not UTF-8 or is empty, an output that is a folder: exit 2, one line.

Launches its own ``mpiexec`` (skips when pytest itself runs under a launcher, like
``test_faults``); each run is 4 small tasks.
"""

from __future__ import annotations

import json
import os
import time
import zlib
from pathlib import Path

import pytest
import xarray as xr
from launcher import STARTS_ITS_OWN_MPIEXEC, finish, start_run

from hpcontact.sweep.data.journal import OK, journal_files, read_history

SPEC = """
[sweep]
title = "fault recovery"
output = "out.nc"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 16
[axes]
shape = ["circle", "ellipse"]
nu = [0.0, 0.5]
"""
TASKS = 4
pytestmark = STARTS_ITS_OWN_MPIEXEC


def run(folder: Path, *options: str, spec: str | bytes = SPEC, **env: str) -> tuple[int, str, str]:
    """``mpiexec -n 2 hpcontact run spec.toml OPTIONS`` in ``folder`` with ``env``, its cost-model
    cache there too: exit status, stdout, stderr."""
    return finish(start_run(folder, spec, *options, env={"HPCONTACT_COSTMODEL": str(folder / "costmodel.json"), **env}))


def complete(folder: Path) -> None:
    with xr.open_dataset(folder / "out.nc") as ds:
        assert (ds.status == OK).all() and ds.attrs["mpi_size"] == 2


def test_a_data_set_that_cannot_be_written_exits_1_in_one_line_and_resume_writes_it(tmp_path):
    code, out, err = run(tmp_path, HPCONTACT_DATA_SET_LIMIT="4096")
    assert code == 1, out + err
    assert err.count("\n") == 1 and "Traceback" not in err and "Abort" not in err, err
    assert err.startswith("hpcontact: cannot write the data set out.nc: NetCDF: HDF error; "), err  # relative, as given
    assert "journals intact" in err and "--resume" in err
    assert not (tmp_path / "out.nc").exists() and len(read_history(tmp_path / "out.nc.journal").entries) == TASKS
    code, out, err = run(tmp_path, "--resume")
    assert code == 0, out + err
    assert f"{TASKS} tasks, 0 to run ({TASKS} from journals)" in out
    complete(tmp_path)


def test_a_requeued_job_takes_over_the_zero_filled_lock_of_its_dead_run(tmp_path):
    code, out, err = run(tmp_path, SLURM_JOB_ID="4242", HPCONTACT_FAULTS="2:kill")
    assert code != 0 and not (tmp_path / "out.nc").exists(), out + err
    lock = tmp_path / "out.nc.journal" / "LOCK"
    assert json.loads(lock.read_text())["job"] == "4242"  # left by the dead run
    lock.write_bytes(b"\0" * len(lock.read_bytes()))  # the node crashed before its content reached the disk
    then = time.time() - 60.0
    os.utime(lock, (then, then))
    code, out, err = run(tmp_path, "--resume", SLURM_JOB_ID="4242")
    assert code == 0, out + err
    assert (
        "took over the unreadable lock out.nc.journal/LOCK (its run's journals name batch job 4242, which was requeued)"
    ) in out
    assert not lock.exists()
    complete(tmp_path)


def test_resume_over_entries_with_missing_fields_completes_and_reports_the_lines_dropped(tmp_path):
    code, out, err = run(tmp_path)
    assert code == 0, out + err
    broken = 0
    for path in journal_files(tmp_path / "out.nc.journal"):
        lines = path.read_bytes().split(b"\n")
        for i, line in enumerate(lines):
            event = json.loads(line.partition(b" ")[2]) if line else {}
            if event.get("event") == "finished" and broken < 2 and event["key"]:
                del event["record"]  # valid CRC, a field missing
                payload = json.dumps(event).encode()
                lines[i] = b"%08x %s" % (zlib.crc32(payload), payload)
                broken += 1
        path.write_bytes(b"\n".join(lines))
    assert broken == 2
    code, out, err = run(tmp_path, "--resume")
    assert code == 0, out + err
    assert f"{TASKS} tasks, 2 to run ({TASKS - 2} from journals)" in out
    assert "hpcontact: warning: 2 journal lines dropped (damaged or incomplete)" in out
    complete(tmp_path)


@pytest.mark.parametrize("cache", ["/dev/zero", "deep"])
def test_a_hostile_cost_cache_leaves_the_run_with_the_probed_prior(tmp_path, cache):
    path = tmp_path / "costmodel.json"
    if cache == "deep":
        path.write_text("[" * 100_000 + "]" * 100_000)
    else:
        path.symlink_to(cache)
    code, out, err = run(tmp_path)
    assert code == 0, out + err
    why = "not a regular file" if cache == "/dev/zero" else "JSON nested deeper than 8"
    assert "hpcontact: estimated " in out and f"(cost calibration {path} ignored: {why};" in out
    complete(tmp_path)


@pytest.mark.parametrize("case", ["not UTF-8", "empty", "output folder"])
def test_bad_specs_and_outputs_exit_2_in_one_line_before_any_task(tmp_path, case):
    spec: str | bytes = SPEC
    if case == "not UTF-8":
        spec = SPEC.replace("recovery", "r\xe9cup\xe9ration").encode("latin-1")
    elif case == "empty":
        spec = b""
    else:
        (tmp_path / "out.nc").mkdir()
    code, out, err = run(tmp_path, spec=spec)
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, out + err
    expected = {
        "not UTF-8": "a TOML file in UTF-8",
        "empty": "a TOML spec with content",
        "output folder": "the output out.nc is a folder, not a file",
    }[case]
    assert expected in err
    assert not (tmp_path / "out.nc.journal").exists()
