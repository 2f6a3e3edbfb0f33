"""No result reused across runners (issue 43, item 1): a journal entry names the task function
that computed it, a resume runs the entries of another runner again and says how many, and the
accuracy study and ``hpcontact run`` write to distinct default places."""

from __future__ import annotations

import io
import json
from collections.abc import Mapping
from typing import Any

import pytest

from hpcontact import accuracy
from hpcontact.sweep.accuracy_study import run_study, study_output
from hpcontact.sweep.data.journal import encode_line, journal_files, read_history, scan_file
from hpcontact.sweep.driver import main, run_sweep
from hpcontact.sweep.run.records import Options, runner_name
from hpcontact.sweep.run.resume import RUNNER
from hpcontact.sweep.run.schedule import SerialTeam
from hpcontact.sweep.space.parse import load_spec

STUDY = "hpcontact.sweep.accuracy_study.cold_solve"
SPEC = '[scene]\nquantities = ["tangential"]\nshape = "circle"\n[numerics]\ntol = 1e-8\n[axes]\nn = [8, 16]\n'


@pytest.fixture
def spec(tmp_path, monkeypatch):
    """A two-task spec ``st.toml`` without [sweep].output, in the working directory."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "st.toml"
    path.write_text(SPEC)
    return path


def own_runner(spec) -> str:
    """The runner name of the spec's scene kind's own solver."""
    return runner_name(accuracy.task_function(load_spec(spec).kind))


def runners(journal) -> set[str | None]:
    """The runners named by the last outcome of every task in ``journal``."""
    return {entry.provenance.get(RUNNER) for entry in read_history(journal).entries.values()}


def test_the_runner_names_module_and_qualified_name():
    assert runner_name(None) is None
    assert runner_name(accuracy.task_function("contact")).endswith(".solve_contact_fields")
    from hpcontact.sweep.accuracy_study import cold_solve

    assert runner_name(cold_solve) == STUDY


def test_the_study_and_the_run_write_to_distinct_default_places(spec, tmp_path, capsys):
    assert run_study([str(spec)]) == 0
    assert (tmp_path / "st.study.nc").is_file() and (tmp_path / "st.study.nc.journal").is_dir()
    assert not (tmp_path / "st.nc").exists()
    assert main([str(spec)]) == 0  # no journals of its own: nothing to resume or refuse
    assert (tmp_path / "st.nc").is_file() and (tmp_path / "st.nc.journal").is_dir()
    assert "not reused" not in capsys.readouterr().out
    assert runners(tmp_path / "st.study.nc.journal") == {STUDY}
    assert runners(tmp_path / "st.nc.journal") == {own_runner(spec)}


def test_a_spec_that_names_its_output_keeps_it_for_the_study(tmp_path):
    named = tmp_path / "named.toml"
    named.write_text('[sweep]\noutput = "results/named.nc"\n' + SPEC)
    assert study_output(named) is None  # the spec's own [sweep].output
    plain = tmp_path / "plain.toml"
    plain.write_text(SPEC)
    assert study_output(plain) == str(tmp_path / "plain.study.nc")  # beside the spec, not the working folder
    assert study_output(tmp_path / "missing.toml") is None  # the run refuses it, naming the spec


def test_a_run_resumed_on_the_study_output_runs_its_entries_again(spec, tmp_path, capsys):
    assert run_study([str(spec)]) == 0
    capsys.readouterr()
    assert main([str(spec), "--output", "st.study.nc", "--resume"]) == 0
    out = capsys.readouterr().out
    assert f"hpcontact: 2 journal entries were computed by {STUDY}, not reused" in out
    assert "2 tasks, 2 to run, " in out and "(2 run, 0 from journals)" in out
    assert runners(tmp_path / "st.study.nc.journal") == {own_runner(spec)}
    # the run's own entries are reused by the next resume
    assert main([str(spec), "--output", "st.study.nc", "--resume"]) == 0
    out = capsys.readouterr().out
    assert "0 to run (2 from journals)" in out and "not reused" not in out


def test_a_study_resumed_on_the_run_output_runs_its_entries_again(spec, tmp_path, capsys):
    assert main([str(spec)]) == 0
    capsys.readouterr()
    assert run_study([str(spec), "--output", "st.nc", "--resume"]) == 0
    out = capsys.readouterr().out
    assert f"hpcontact: 2 journal entries were computed by {own_runner(spec)}, not reused" in out
    assert "2 tasks, 2 to run, " in out
    assert runners(tmp_path / "st.nc.journal") == {STUDY}
    # the data set now holds the study's results: the run is not "up to date" on them
    assert main([str(spec)]) == 2
    assert "--resume" in capsys.readouterr().err


def test_journals_without_a_runner_are_the_spec_kinds_own(spec, tmp_path, capsys):
    assert main([str(spec)]) == 0
    for path in journal_files(tmp_path / "st.nc.journal"):  # as journals before runners were recorded
        header, events, _ = scan_file(path)
        lines = []
        for event in [header, *events]:
            event = json.loads(json.dumps(event))
            event.get("provenance", {}).pop(RUNNER, None)
            event.pop(RUNNER, None)
            lines.append(encode_line(event))
        path.write_bytes(b"".join(lines))
    assert runners(tmp_path / "st.nc.journal") == {None}
    capsys.readouterr()
    assert main([str(spec), "--resume"]) == 0
    assert "0 to run (2 from journals)" in capsys.readouterr().out
    assert run_study([str(spec), "--output", "st.nc", "--resume"]) == 0
    assert f"2 journal entries were computed by {own_runner(spec)}, not reused" in capsys.readouterr().out


def doubled(params: Mapping[str, Any]) -> dict[str, Any]:
    """A custom task function: the spec kind's own record, every number doubled."""
    record = accuracy.task_function("contact")(params)
    return {k: 2 * v if isinstance(v, float) else v for k, v in record.items()}


def test_a_custom_task_function_named_in_the_options_is_a_runner_of_its_own(spec, tmp_path):
    stream = io.StringIO()
    options = Options(runner=runner_name(doubled))
    run_sweep(spec, task_function=doubled, team=SerialTeam(), stream=stream, options=options)
    assert runners(tmp_path / "st.nc.journal") == {runner_name(doubled)}
    run_sweep(spec, resume=True, team=SerialTeam(), stream=stream)
    assert f"2 journal entries were computed by {runner_name(doubled)}, not reused" in stream.getvalue()
    assert runners(tmp_path / "st.nc.journal") == {own_runner(spec)}
