"""The driver in one process: failures recorded, resume exact, spec errors before any work."""

from __future__ import annotations

import io

import numpy as np
import pytest
import xarray as xr

from hpcontact.errors import ConvergenceError, InputError
from hpcontact.sweep.driver import main, run_sweep
from hpcontact.sweep.journal import BAD_INPUT, ERROR, NOT_CONVERGED, OK, journal_files, read_journals
from hpcontact.sweep.schedule import SerialTeam

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


def sweep(spec, stream=None, **options):
    """``run_sweep`` in this process alone (also when pytest runs under mpiexec)."""
    return run_sweep(spec, team=SerialTeam(), stream=stream if stream is not None else io.StringIO(), **options)


def counting(function, calls):
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


def test_a_sweep_runs_every_task_once_and_writes_the_data_set(write_spec, fake_solve, tmp_path):
    calls = []
    stream = io.StringIO()
    path = sweep(write_spec(SPEC), task_function=counting(fake_solve, calls), stream=stream)
    assert path == tmp_path / "out.nc" and len(calls) == TASKS
    with xr.open_dataset(path) as ds:
        assert dict(ds.sizes) == {"shape": 3, "aspect": 3, "nu": 3, "angle": 5}
        assert (ds.status == OK).all() and ds.attrs["mpi_size"] == 1 and ds.attrs["sweep_tasks_run"] == TASKS
        for name in ("hpcontact_version", "created", "spec", "sweep_parallel_efficiency"):
            assert name in ds.attrs
    text = stream.getvalue()
    assert f"{TASKS} tasks, {TASKS} to run" in text and f"/{TASKS} tasks (" in text
    assert "parallel efficiency" in text and "0 failed" in text


def test_failing_tasks_are_recorded_and_the_others_complete(write_spec, fake_solve):
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
        assert "ZeroDivisionError: float division by zero" in str(ds.message.sel(shape="circle", nu=0.0, aspect=1.0).values)
        assert "not a mapping" in str(ds.message.sel(shape="circle", nu=0.25, aspect=1.0).values)
        assert int((status == OK).sum()) == 27 - 4 * 3
        assert np.isfinite(ds.K_xx.where(status == OK)).sum() == (status == OK).sum()
    assert "6 failed" in stream.getvalue() and "CG stalled" in stream.getvalue()


def test_resume_after_an_interruption_recomputes_nothing_and_loses_nothing(write_spec, fake_solve, tmp_path):
    spec = write_spec(SPEC)
    reference = sweep(spec, output=tmp_path / "reference.nc", task_function=fake_solve)

    calls = []

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


def test_a_fresh_run_clears_old_journals_and_resume_after_an_edit_reruns_changed_scenes(write_spec, fake_solve, tmp_path):
    spec = write_spec(SPEC)
    sweep(spec, task_function=fake_solve)
    sweep(spec, task_function=fake_solve)
    assert len(journal_files(tmp_path / "out.nc.journal")) == 1

    edited = write_spec(SPEC.replace("nu = [0.0, 0.25, 0.5]", "nu = [0.0, 0.25, 0.3]"))
    calls = []
    sweep(edited, resume=True, task_function=counting(fake_solve, calls))
    assert len(calls) == 1 + 3 + 1 and {p["nu"] for p in calls} == {0.3}


def test_a_bad_spec_is_refused_before_any_task(write_spec):
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
