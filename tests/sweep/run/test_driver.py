"""The driver in one process: failures recorded and retried, resume exact, refusals before any
work (spec, lock, journals without a flag, stale journals, unusable output), stop requests."""

from __future__ import annotations

import argparse
import functools
import gc
import io
import json
import os
import socket
import subprocess
import sys
import time
from dataclasses import replace

import numpy as np
import pytest
import xarray as xr

from hpcontact.errors import ConvergenceError, InputError
from hpcontact.sweep.data.journal import BAD_INPUT, ERROR, NOT_CONVERGED, OK, journal_files, read_history, read_journals
from hpcontact.sweep.driver import main
from hpcontact.sweep.run.guard import Refused
from hpcontact.sweep.run.records import Options, Stopped, runner_name
from hpcontact.sweep.run.rounds import execute
from hpcontact.sweep.run.schedule import SerialTeam
from hpcontact.sweep.run.signals import StopControl

SPEC = """
[sweep]
title = "driver test"
progress_interval = 0.001
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 16
[axes]
shape = ["circle", "ellipse", { label = "hexagon", shape = "polygon", sides = 6 }]
aspect = [1.0, 0.1, 0.01]
nu = [0.0, 0.25, 0.5]
angle = { linspace = [0, 180, 5] }
"""
TASKS = 3 + 3 * 3 + 3  # circle and hexagon ignore the aspect: one task per nu


class Interrupted(BaseException):
    """Stands in for a killed process: not an Exception, so the sweep does not record it."""


def counting(function, calls):
    """``function``, its calls counted: the same runner (``functools.wraps``: its name), so
    that a resume with it reuses ``function``'s journal entries."""

    @functools.wraps(function)
    def task(params):
        calls.append(params)
        return function(params)

    return task


def data_equal(a: xr.Dataset, b: xr.Dataset) -> None:
    """Same coordinates, data variables and variable attributes to the last bit; wall times and
    the run's own global attributes (times, counts) aside."""
    a, b = a.drop_vars("wall_time_s"), b.drop_vars("wall_time_s")
    a.attrs, b.attrs = {}, {}
    xr.testing.assert_identical(a, b)


def test_a_sweep_runs_every_task_once_and_writes_the_data_set(sweep, write_spec, fake_solve, tmp_path):
    calls = []
    stream = io.StringIO()
    path = sweep(write_spec(SPEC), task_function=counting(fake_solve, calls), stream=stream)
    assert path == tmp_path / "out.nc" and len(calls) == TASKS
    with xr.open_dataset(path) as ds:
        assert {a: ds.sizes[a] for a in ("shape", "aspect", "nu", "angle")} == {
            "shape": 3,
            "aspect": 3,
            "nu": 3,
            "angle": 5,
        }
        assert (ds.status == OK).all() and ds.attrs["mpi_size"] == 1 and ds.attrs["sweep_tasks_run"] == TASKS
        for name in ("hpcontact_version", "created", "spec", "sweep_parallel_efficiency"):
            assert name in ds.attrs
    text = stream.getvalue()
    assert f"{TASKS} tasks, {TASKS} to run" in text and f"/{TASKS} tasks (" in text
    assert "parallel efficiency" in text and "0 failed" in text


def test_failing_tasks_are_recorded_and_the_others_complete(sweep, write_spec, fake_solve):
    def flaky(params):
        if params.get("aspect") == 0.01:
            raise ConvergenceError("CG stalled", 100, 1e-3)
        if params["shape"] == "polygon" and params["nu"] == 0.5:
            raise InputError("sides", "an integer in [3, 1000]", 6)
        if params["shape"] == "circle" and params["nu"] == 0.0:
            raise ZeroDivisionError("float division by zero")
        if params["shape"] == "circle" and params["nu"] == 0.25:
            return [1.0]
        return fake_solve(params)

    stream = io.StringIO()
    with xr.open_dataset(sweep(write_spec(SPEC), task_function=flaky, stream=stream)) as ds:
        status = ds.status
        assert (status.sel(shape="ellipse", aspect=0.01) == NOT_CONVERGED).all()
        assert int(status.sel(shape="hexagon", aspect=0.1, nu=0.5)) == BAD_INPUT
        assert (status.sel(shape="circle", nu=0.0) == ERROR).all()
        assert "ZeroDivisionError: float division by zero" in str(
            ds.message.sel(shape="circle", nu=0.0, aspect=1.0).values
        )
        assert "not a mapping" in str(ds.message.sel(shape="circle", nu=0.25, aspect=1.0).values)
        assert int((status == OK).sum()) == 27 - 4 * 3
        assert np.isfinite(ds.K_xx.where(status == OK)).sum() == (status == OK).sum()
    assert "6 failed" in stream.getvalue() and "CG stalled" in stream.getvalue()


def test_resume_after_an_interruption_recomputes_nothing_and_loses_nothing(sweep, write_spec, fake_solve, tmp_path):
    spec = write_spec(SPEC)
    reference = sweep(spec, output=tmp_path / "reference.nc", task_function=fake_solve)

    calls = []

    @functools.wraps(fake_solve)  # fake_solve's runner: a resume with fake_solve reuses its entries
    def dies_at_seventh(params):
        if len(calls) == 6:
            raise Interrupted
        calls.append(params)
        return fake_solve(params)

    with pytest.raises(Interrupted):
        sweep(spec, task_function=dies_at_seventh)
    journaled = read_journals(tmp_path / "out.nc.journal")
    assert len(journaled) == 6

    resumed = []
    stream = io.StringIO()
    path = sweep(spec, resume=True, task_function=counting(fake_solve, resumed), stream=stream)
    assert len(resumed) == TASKS - 6
    assert not {str(sorted(p.items())) for p in resumed} & {str(sorted(e.params.items())) for e in journaled.values()}
    assert "(6 from journals)" in stream.getvalue()
    with xr.open_dataset(path) as a, xr.open_dataset(reference) as b:
        data_equal(a, b)
        assert a.attrs["sweep_tasks_reused"] == 6

    again = []
    sweep(spec, resume=True, task_function=counting(fake_solve, again))
    assert again == []


def test_a_second_run_without_a_flag_is_refused_and_restart_discards(sweep, write_spec, fake_solve, tmp_path):
    spec = write_spec(SPEC)
    sweep(spec, task_function=fake_solve)
    before = journal_files(tmp_path / "out.nc.journal")
    with pytest.raises(Refused, match=rf"{TASKS} finished tasks in .*out.nc.journal; pass --resume .* --restart"):
        sweep(spec, task_function=fake_solve)
    assert journal_files(tmp_path / "out.nc.journal") == before  # nothing deleted
    calls = []
    sweep(spec, task_function=counting(fake_solve, calls), options=Options(restart=True))
    assert len(calls) == TASKS and len(journal_files(tmp_path / "out.nc.journal")) == 1

    (tmp_path / "out.nc.journal" / "rank00000-old.h5").write_bytes(b"HDF5 journal of an earlier hpcontact")
    with pytest.raises(Refused, match="HDF5 journals of an earlier hpcontact.*--restart"):
        sweep(spec, resume=True, task_function=fake_solve)
    sweep(spec, task_function=fake_solve, options=Options(restart=True))
    assert not list((tmp_path / "out.nc.journal").glob("*.h5"))

    edited = write_spec(SPEC.replace("nu = [0.0, 0.25, 0.5]", "nu = [0.0, 0.25, 0.3]"))
    calls = []
    sweep(edited, resume=True, task_function=counting(fake_solve, calls))
    assert len(calls) == 1 + 3 + 1 and {p["nu"] for p in calls} == {0.3}


def test_resume_retries_errors_and_non_convergence_and_keeps_bad_input(write_spec, fake_solve, tmp_path):
    spec = write_spec(SPEC)
    failing = {0.0: ConvergenceError("CG stalled", 9, 1e-3), 0.25: RuntimeError("flaky"), 0.5: InputError("nu", "x")}

    def first(params):
        if params["shape"] == "circle":
            raise failing[params["nu"]]
        return fake_solve(params)

    outcome = execute(spec, task_function=first, team=SerialTeam(), stream=io.StringIO())
    assert outcome.failures == 3
    calls = []
    outcome = execute(
        spec,
        task_function=counting(fake_solve, calls),
        team=SerialTeam(),
        stream=io.StringIO(),
        options=Options(resume=True),
    )
    assert sorted(p["nu"] for p in calls) == [0.0, 0.25] and outcome.failures == 1  # bad input is deterministic
    with xr.open_dataset(outcome.path) as ds:
        circle = ds.status.sel(shape="circle", aspect=1.0)
        assert circle.values.tolist() == [OK, OK, BAD_INPUT]  # the last outcome of each task
    history = read_history(tmp_path / "out.nc.journal")
    statuses = [
        json.loads(line.split(b" ", 1)[1])["status"]
        for path in journal_files(tmp_path / "out.nc.journal")
        for line in path.read_bytes().splitlines()
        if b'"finished"' in line and b'"circle"' in line
    ]
    assert sorted(statuses) == sorted([NOT_CONVERGED, ERROR, BAD_INPUT, OK, OK])  # the journals keep the history
    assert len(history.entries) == TASKS


def test_stale_journals_are_refused_unless_accepted_and_provenance_lists_every_contributor(
    sweep, write_spec, fake_solve, tmp_path, monkeypatch
):
    spec = write_spec(SPEC)
    monkeypatch.setenv("HPCONTACT_GIT_REVISION", "aaaa")

    calls = []

    @functools.wraps(fake_solve)  # fake_solve's runner: a resume with fake_solve reuses its entries
    def dies_at_fourth(params):
        if len(calls) == 3:
            raise Interrupted
        calls.append(params)
        return fake_solve(params)

    with pytest.raises(Interrupted):
        sweep(spec, task_function=dies_at_fourth)
    monkeypatch.setenv("HPCONTACT_GIT_REVISION", "bbbb-dirty")
    with pytest.raises(
        Refused, match=r"computed by hpcontact .*\(git aaaa,.*this is .*\(git bbbb-dirty,.*git revision.*--accept-stale"
    ):
        sweep(spec, resume=True, task_function=fake_solve)
    resumed = []
    path = sweep(spec, task_function=counting(fake_solve, resumed), options=Options(resume=True, accept_stale=True))
    assert len(resumed) == TASKS - 3
    with xr.open_dataset(path) as ds:
        contributors = {c["git_revision"]: c["tasks"] for c in json.loads(ds.attrs["sweep_contributors"])}
        assert contributors == {"aaaa": 3, "bbbb-dirty": TASKS - 3} and ds.attrs["git_revision"] == "bbbb-dirty"


def test_a_changed_engine_default_changes_the_task(sweep, write_spec, fake_solve, monkeypatch):
    from hpcontact.scene import DEFAULTS

    spec = write_spec(SPEC)  # n is given, tol is left to the engine's default
    sweep(spec, task_function=fake_solve)
    monkeypatch.setitem(DEFAULTS, "tol", DEFAULTS["tol"] / 10)
    calls = []
    sweep(spec, resume=True, task_function=counting(fake_solve, calls))
    assert len(calls) == TASKS


def test_one_run_per_output(sweep, write_spec, fake_solve, tmp_path, monkeypatch):
    spec = write_spec(SPEC)
    folder = tmp_path / "out.nc.journal"
    folder.mkdir()
    lock = folder / "LOCK"
    host = socket.gethostname()
    monkeypatch.delenv("SLURM_JOB_ID", raising=False)

    def hold(**holder):
        lock.write_text(
            json.dumps({"host": host, "pid": os.getpid(), "ranks": 2, "started": "T", "job": None, **holder})
        )

    hold()  # a live process on this host
    with pytest.raises(
        Refused, match=rf"in use by a run on {host} \(pid {os.getpid()}, 2 ranks, since T\).*--break-lock"
    ):
        sweep(spec, task_function=fake_solve)
    hold(host="elsewhere", pid=1)
    with pytest.raises(Refused, match="elsewhere"):
        sweep(spec, task_function=fake_solve)
    sweep(spec, task_function=fake_solve, options=Options(restart=True, break_lock=True))
    assert not lock.exists()  # released at the end
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    hold(pid=int(dead.stdout))  # a run on this host whose process is gone
    stream = io.StringIO()
    sweep(spec, task_function=fake_solve, options=Options(resume=True), stream=stream)
    assert "took over the lock" in stream.getvalue() and "is gone" in stream.getvalue()
    hold(host="elsewhere", job="77")  # the same batch job, requeued on another node
    monkeypatch.setenv("SLURM_JOB_ID", "77")
    sweep(spec, task_function=fake_solve, options=Options(resume=True))
    assert not lock.exists()


def test_unusable_outputs_are_refused_before_any_task(sweep, write_spec, tmp_path):
    def never(params):
        raise AssertionError("no task may run")

    spec = write_spec(SPEC)
    with pytest.raises(Refused, match="parent folder .* does not exist"):
        sweep(spec, output=tmp_path / "typo" / "deeper" / "out.nc", task_function=never)
    (tmp_path / "file").write_text("")
    with pytest.raises(Refused, match="not a folder"):
        sweep(spec, output=tmp_path / "file" / "out.nc", task_function=never)
    with pytest.raises(Refused, match="cannot (write|create)"):
        sweep(spec, output="/proc/hpcontact-test/out.nc", task_function=never)  # not writable, even by root


def test_a_stop_request_abandons_the_task_after_the_grace_and_resume_completes(sweep, write_spec, fake_solve, tmp_path):
    spec = write_spec(SPEC)
    stop = StopControl(grace_s=0.3).install()
    calls, woke = [], []

    @functools.wraps(fake_solve)  # fake_solve's runner: a resume with fake_solve reuses its entries
    def stops_then_hangs(params):
        calls.append(params)
        if len(calls) == 4:
            stop.request("test stop")
            time.sleep(60.0)  # abandoned after the grace: Abandoned is raised inside the sleep
            woke.append(params)  # reached only if it was not
        return fake_solve(params)

    try:
        with pytest.raises(Stopped, match="stopped \\(test stop\\).*journals intact") as info:
            sweep(spec, task_function=stops_then_hangs, stop=stop)
        # the event, not a time: the sleep never returned (a lost abandon fails here, 60 s later)
        assert info.value.status == 4 and not woke
    finally:
        stop.uninstall()
    history = read_history(tmp_path / "out.nc.journal")
    assert len(history.entries) == 3 and not history.suspects()  # abandoned: not counted as a crash
    again = []
    sweep(spec, resume=True, task_function=counting(fake_solve, again))
    assert len(again) == TASKS - 3


def test_a_bad_spec_is_refused_before_any_task(sweep, write_spec):
    def never(params):
        raise AssertionError("no task may run")

    with pytest.raises(InputError) as info:
        sweep(write_spec(SPEC.replace("0.5]", "0.7]")), task_function=never)
    assert info.value.field == "axes.nu"


def test_main_exits_2_with_one_line_naming_the_key(write_spec, capsys, monkeypatch):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    assert main([str(write_spec(SPEC.replace("[numerics]", "[numerics]\ncolour = 1")))]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "numerics.colour" in err


def test_a_data_set_that_cannot_be_written_stops_cleanly_and_resume_writes_it(
    sweep, write_spec, fake_solve, tmp_path, monkeypatch
):
    spec = write_spec(SPEC)
    monkeypatch.setenv("HPCONTACT_DATA_SET_LIMIT", "4096")  # the netCDF library fails as on a full disk
    with pytest.raises(Stopped, match="cannot write the data set .*out.nc.*journals intact.*--resume") as info:
        sweep(spec, task_function=fake_solve)
    assert info.value.status == 1 and len(read_journals(tmp_path / "out.nc.journal")) == TASKS
    assert not (tmp_path / "out.nc").exists() and not list(tmp_path.glob(".out.nc.tmp-*"))
    monkeypatch.delenv("HPCONTACT_DATA_SET_LIMIT")
    calls = []
    assert sweep(spec, resume=True, task_function=counting(fake_solve, calls)).is_file() and calls == []


def test_dry_run_lists_the_tasks_in_order_and_computes_nothing(write_spec, capsys, monkeypatch):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    spec = write_spec(SPEC)
    assert main([str(spec), "--dry-run"]) == 0
    lines = [line for line in capsys.readouterr().out.splitlines() if not line.startswith("#")]  # estimates: '#'
    assert len(lines) == TASKS and [int(line.split()[0]) for line in lines] == list(range(TASKS))  # 15: no sample
    assert json.loads(lines[0].split(None, 5)[5])["shape"] == "circle"
    assert not (spec.parent / "out.nc.journal").exists()


def test_a_malformed_fault_list_is_refused(write_spec, capsys, monkeypatch):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    monkeypatch.setenv("HPCONTACT_FAULTS", "3:explode")
    assert main([str(write_spec(SPEC))]) == 2
    assert "HPCONTACT_FAULTS" in capsys.readouterr().err


UP_TO_DATE = Options(up_to_date=True)  # what `hpcontact run` and hpcontact.run_sweep pass


def test_a_finished_sweep_run_again_is_up_to_date_and_touches_nothing(sweep, write_spec, fake_solve, tmp_path):
    """Issue 28: the README's command run twice. Nothing runs, the data set keeps its bytes and
    mtime, one line says so; without ``up_to_date`` (the library default) it is refused as before."""
    spec = write_spec(SPEC)
    path = sweep(spec, task_function=fake_solve)
    data, mtime = path.read_bytes(), path.stat().st_mtime_ns
    journals = {p: p.stat().st_mtime_ns for p in journal_files(tmp_path / "out.nc.journal")}
    calls, stream = [], io.StringIO()
    same_runner = replace(UP_TO_DATE, runner=runner_name(fake_solve))  # as run_sweep names it
    outcome = execute(spec, None, counting(fake_solve, calls), team=SerialTeam(), stream=stream, options=same_runner)
    assert outcome.up_to_date and outcome.path == path and outcome.failures == 0 and calls == []
    assert stream.getvalue() == f"hpcontact: {path} is up to date ({TASKS} tasks from journals); nothing to do\n"
    assert path.read_bytes() == data and path.stat().st_mtime_ns == mtime
    assert {p: p.stat().st_mtime_ns for p in journal_files(tmp_path / "out.nc.journal")} == journals
    assert not (tmp_path / "out.nc.journal" / "LOCK").exists()  # the lock is released
    with pytest.raises(Refused, match="finished tasks"):
        sweep(spec, task_function=fake_solve)


def _refused_unless_resumed(sweep, spec, fake_solve):
    with pytest.raises(Refused, match=r"finished tasks in .*; pass --resume .* --restart"):
        sweep(spec, task_function=fake_solve, options=UP_TO_DATE)


def test_up_to_date_means_every_task_ok_in_the_journals_and_the_data_set_written_after_them(
    sweep, write_spec, fake_solve, tmp_path, monkeypatch
):
    """Anything short of "the data set is the one a run would write now" keeps the refusal."""
    spec = write_spec(SPEC)
    path = sweep(spec, task_function=fake_solve)
    journal = tmp_path / "out.nc.journal"

    later = path.stat().st_mtime + 10.0  # a journal written after the data set (a later run that stopped)
    newest = journal_files(journal)[-1]
    os.utime(newest, (later, later))
    _refused_unless_resumed(sweep, spec, fake_solve)
    os.utime(newest, (later - 20.0, later - 20.0))
    sweep(spec, task_function=fake_solve, options=UP_TO_DATE)  # back in order: up to date

    edited = write_spec(SPEC + "# a comment\n")  # another spec text: its data set was not written from it
    _refused_unless_resumed(sweep, edited, fake_solve)
    more = write_spec(SPEC.replace("nu = [0.0, 0.25, 0.5]", "nu = [0.0, 0.25, 0.3, 0.5]"))  # tasks not journaled
    _refused_unless_resumed(sweep, more, fake_solve)
    fewer = write_spec(SPEC.replace("nu = [0.0, 0.25, 0.5]", "nu = [0.0, 0.25]"))  # every task ok, other data set
    _refused_unless_resumed(sweep, fewer, fake_solve)
    write_spec(SPEC)

    monkeypatch.setenv("HPCONTACT_GIT_REVISION", "another-revision")  # other code: stale, not up to date
    _refused_unless_resumed(sweep, spec, fake_solve)
    monkeypatch.delenv("HPCONTACT_GIT_REVISION")

    data = path.read_bytes()
    path.unlink()  # journals without their data set
    _refused_unless_resumed(sweep, spec, fake_solve)
    path.write_bytes(data[: len(data) // 2])  # a damaged data set
    _refused_unless_resumed(sweep, spec, fake_solve)


def test_a_sweep_with_failed_tasks_is_not_up_to_date(sweep, write_spec, fake_solve):
    def bad_at_half(params):
        if params["nu"] == 0.5:
            raise InputError("nu", "a Poisson ratio below 0.5 here")
        return fake_solve(params)

    spec = write_spec(SPEC)
    sweep(spec, task_function=bad_at_half)
    _refused_unless_resumed(sweep, spec, fake_solve)  # bad input is kept by --resume, but the data set is not all ok


def test_the_command_line_run_twice_exits_0_the_second_time(write_spec, tmp_path, capsys, monkeypatch):
    """``hpcontact run SPEC`` twice with the real solver (tiny grids): exit 0, one line, nothing
    written; a replaced task function (``task_function``: the accuracy study) keeps the refusal."""
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    monkeypatch.setenv("HPCONTACT_WISDOM", str(tmp_path / "wisdom"))
    spec = write_spec('[scene]\nshape = "circle"\n[numerics]\nn = 8\n[axes]\nnu = [0.0, 0.3]\n')
    assert main([str(spec)]) == 0
    capsys.readouterr()
    mtime = (tmp_path / "out.nc").stat().st_mtime_ns
    journals = {p: p.read_bytes() for p in journal_files(tmp_path / "out.nc.journal")}
    assert main([str(spec)]) == 0
    out, err = capsys.readouterr()
    assert out == f"hpcontact: {tmp_path / 'out.nc'} is up to date (2 tasks from journals); nothing to do\n", out + err
    # nothing solved (a task is journaled as started before it runs) and nothing written; not timed
    assert (tmp_path / "out.nc").stat().st_mtime_ns == mtime
    assert {p: p.read_bytes() for p in journal_files(tmp_path / "out.nc.journal")} == journals
    assert main([str(spec)], task_function=lambda params: {"K_xx": 1.0}) == 2
    assert "--resume" in capsys.readouterr().err


LONG_SPEC = """
[sweep]
title = "a long axis"
[scene]
shape = "ellipse"
aspect = 0.5
[numerics]
n = 16
[axes]
nu = {{ linspace = [0, 0.5, {points}] }}
"""


def test_a_dry_run_prints_its_summary_then_a_sample_of_the_tasks_and_list_all_lists_every_task(
    write_spec, capsys, monkeypatch
):
    """A dry run of more tasks than its sample prints its title line and summary first (grids,
    estimate, wall time), then the first ``LISTED_HEAD`` and the last ``LISTED_TAIL`` tasks with
    one line between them saying how many it left out; ``--list-all`` prints the same summary,
    then every task."""
    from hpcontact.sweep.run.dry_run import LISTED_HEAD, LISTED_TAIL

    assert (LISTED_HEAD, LISTED_TAIL) == (10, 5)
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    spec = write_spec(LONG_SPEC.format(points=3000))
    assert main([str(spec), "--dry-run"]) == 0
    sample = capsys.readouterr().out.splitlines()
    assert main([str(spec), "--dry-run", "--list-all"]) == 0
    every = capsys.readouterr().out.splitlines()
    assert len(sample) == 4 + 10 + 1 + 5
    assert sample[0].startswith("# a long axis: 3000 tasks -> ") and sample[0].endswith("(index, key, relative "
        "cost, estimated seconds, estimated peak MiB, scene)")  # fmt: skip
    assert [line.split(maxsplit=2)[1] for line in sample[1:4]] == ["1", "estimated:", "wall"]  # grids first
    assert [int(line.split()[0]) for line in sample[4:14] + sample[15:]] == [*range(10), *range(2995, 3000)]
    assert sample[14] == "# ... 2985 more tasks (10 ... 2994; --list-all lists every task)"
    assert every[:4] == sample[:4] and len(every) == 4 + 3000
    assert [int(line.split()[0]) for line in every[4:]] == list(range(3000))
    assert set(sample[4:14] + sample[15:]) <= set(every) and json.loads(every[-1].split(None, 5)[5])["nu"] == 0.5


def test_every_dry_run_follows_one_rule_for_its_sample():
    """Up to ``LISTED_HEAD + LISTED_TAIL`` tasks: every one; one more: the sample, one left out."""
    from hpcontact.sweep.run.arguments import add_run_arguments
    from hpcontact.sweep.run.dry_run import listed_tasks

    assert list(listed_tasks(0)) == [] and list(listed_tasks(15)) == list(range(15))
    assert list(listed_tasks(16)) == [*range(10), None, *range(11, 16)]
    assert list(listed_tasks(16, list_all=True)) == list(range(16))
    assert list(listed_tasks(10**6)) == [*range(10), None, *range(10**6 - 5, 10**6)]
    parser = argparse.ArgumentParser()
    add_run_arguments(parser)
    assert "of more than 15, a dry run lists the first 10 and the last 5" in " ".join(parser.format_help().split())


ADAPTIVE_SPEC = """
[sweep]
title = "adaptive"
[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
n = 16
[axes]
aspect = { logspace = [0, -2, 9] }
nu = { linspace = [0, 0.5, 5] }
[adaptive]
tolerance = 1e-3
"""


def test_an_adaptive_dry_run_states_its_first_round_before_the_tasks(write_spec, capsys, monkeypatch):
    """Issue 40: a dry run of an adaptive spec printed every task (861 lines for Mindlin's map)
    before its summary; now the summary, the first round and the bound come first."""
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    spec = write_spec(ADAPTIVE_SPEC)
    assert main([str(spec), "--dry-run"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("# adaptive: 45 tasks -> ")
    assert lines[4].startswith("# adaptive: first round ")  # and the bound (hpcontact.sweep.maps.rounds.dry_run_text)
    assert all(line.startswith("#") for line in lines[:5]) and not lines[5].startswith("#")
    assert len(lines) == 5 + 10 + 1 + 5 and lines[15] == "# ... 30 more tasks (10 ... 39; --list-all lists every task)"
    assert main([str(spec), "--dry-run", "--list-all"]) == 0
    every = capsys.readouterr().out.splitlines()
    assert every[:5] == lines[:5] and [int(line.split()[0]) for line in every[5:]] == list(range(45))


def test_a_dry_run_as_json_lists_every_task_and_list_all_needs_a_dry_run(write_spec, capsys, monkeypatch):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    spec = write_spec(LONG_SPEC.format(points=3000))  # more tasks than a text dry run lists
    assert main([str(spec), "--dry-run", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["tasks"] == 3000 and [t["index"] for t in out["tasks_list"]] == list(range(3000))
    assert len({t["key"] for t in out["tasks_list"]}) == 3000
    assert main([str(spec), "--list-all"]) == 2
    assert "--list-all" in capsys.readouterr().err


def test_a_custom_task_function_is_a_runner_of_its_own_without_being_named(sweep, write_spec, fake_solve, tmp_path):
    """Issue 43 item 1: ``run_sweep`` names the runner of any task function
    (``records.runner_name``) where the caller names none, so a resume with another never reuses
    its entries; with the same one it reuses them all."""

    def halved(params):  # other results than fake_solve's
        return {k: v / 2 if isinstance(v, float) else v for k, v in fake_solve(params).items()}

    spec = write_spec(SPEC)
    sweep(spec, task_function=halved)
    assert {e.provenance["runner"] for e in read_history(tmp_path / "out.nc.journal").entries.values()} == {
        runner_name(halved)
    }
    calls, stream = [], io.StringIO()
    sweep(spec, resume=True, task_function=counting(fake_solve, calls), stream=stream)
    assert len(calls) == TASKS
    assert f"{TASKS} journal entries were computed by {runner_name(halved)}, not reused" in stream.getvalue()
    again = []
    sweep(spec, resume=True, task_function=counting(fake_solve, again))
    assert again == []  # fake_solve's own entries: all reused


def test_main_names_the_runner_of_its_task_function(write_spec, fake_solve, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    spec = write_spec(SPEC)
    assert main([str(spec)], task_function=fake_solve) == 0
    capsys.readouterr()

    def other(params):
        return fake_solve(params)

    assert main([str(spec), "--resume"], task_function=other) == 0
    assert f"{TASKS} journal entries were computed by {runner_name(fake_solve)}, not reused" in capsys.readouterr().out


@pytest.mark.parametrize("kind", ["plain", "adaptive"])
def test_every_round_runs_with_the_grids_tasks_frozen_and_nothing_stays_frozen(kind, sweep, write_spec, fake_solve):
    """``tasks.frozen_heap`` around each round (``run.rounds.execute``): while a task runs, the
    collector's frozen objects include every task of the grid (each a tracked tuple); after the
    run, none (a plain sweep; the Mindlin map's rounds)."""
    from mindlin_map import MAP, mindlin

    spec, solve, tasks = (SPEC, fake_solve, TASKS) if kind == "plain" else (MAP, mindlin, 17 * 9)
    frozen: list[int] = []

    def task(params):
        frozen.append(gc.get_freeze_count())
        return solve(params)

    assert gc.get_freeze_count() == 0
    sweep(write_spec(spec), task_function=task)
    assert frozen and min(frozen) >= tasks
    assert gc.get_freeze_count() == 0
