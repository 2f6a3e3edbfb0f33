"""The progress line of a long solve to an accuracy (issue 42 item 8): one line per finished grid
level on stderr once the solve has run ``PROGRESS_AFTER_S`` seconds, nothing before; stdout of
``--json`` stays one JSON object."""

from __future__ import annotations

import io
import json
import re
import sys

from hpcontact.accuracy import refinement
from hpcontact.accuracy.refinement import LevelProgress, reporting_levels, solve_to_accuracy
from hpcontact.cli import main as cli_main
from hpcontact.scene import Scene

LINE = re.compile(
    r"hpcontact: grid (\d+) of at most (\d+) \(n = (\d+), n_across = (\d+)\): "
    r"(?:estimated error (\S+)|no estimate before \d grids), target (\S+); (\d+\.\d) s"
)


class FakeClock:
    """Seconds that advance only when the test says so."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_levels_are_reported_only_once_the_solve_has_run_its_threshold():
    clock, stream = FakeClock(), io.StringIO()
    progress = LevelProgress(stream, after_s=3.0, clock=clock)
    clock.now += 1.0
    progress(1, 5, (32, 32), None, 1e-6)
    clock.now += 1.9  # 2.9 s: still quiet
    progress(2, 5, (64, 64), None, 1e-6)
    assert stream.getvalue() == ""
    clock.now += 0.2  # 3.1 s
    progress(3, 5, (128, 128), 3.2e-5, 1e-6)
    clock.now += 10.0
    progress(4, 5, (256, 240), 4.1e-7, 1e-6)
    lines = stream.getvalue().splitlines()
    assert lines == [
        "hpcontact: grid 3 of at most 5 (n = 128, n_across = 128): estimated error 3.2e-05, target 1e-06; 3.1 s",
        "hpcontact: grid 4 of at most 5 (n = 256, n_across = 240): estimated error 4.1e-07, target 1e-06; 13.1 s",
    ]


def test_a_fast_solve_says_nothing():
    stream = io.StringIO()
    with reporting_levels(LevelProgress(stream, after_s=3.0, clock=lambda: 0.0)):
        solve_to_accuracy(Scene.from_params({"shape": "polygon"}), 1e-2, strict=False)
    assert stream.getvalue() == ""


def test_every_grid_level_of_a_refinement_is_reported_with_its_estimate():
    stream = io.StringIO()
    with reporting_levels(LevelProgress(stream, after_s=0.0)):
        record = solve_to_accuracy(Scene.from_params({"shape": "polygon"}), 1e-3, strict=False)
    found = [LINE.fullmatch(line) for line in stream.getvalue().splitlines()]
    assert all(found) and len(found) == len(record["grids"])
    assert [int(m.group(1)) for m in found] == list(range(1, len(found) + 1))
    assert [int(m.group(3)) for m in found] == record["grids"]
    assert [int(m.group(4)) for m in found] == record["grids_across"]
    assert all(m.group(5) is None for m in found[:2]) and found[-1].group(5) == f"{record['estimated_error']:.2g}"
    assert all(float(m.group(6)) == 1e-3 for m in found)
    seconds = [float(m.group(7)) for m in found]
    assert seconds == sorted(seconds)
    # outside the block nothing is reported
    solve_to_accuracy(Scene.from_params({"shape": "polygon"}), 1e-2, strict=False)
    assert len(stream.getvalue().splitlines()) == len(found)


def test_the_command_line_reports_on_stderr_and_keeps_json_pure(capsys, monkeypatch):
    """On a terminal (stderr a tty) past the threshold: one line per grid on stderr; below it, or
    with stderr a file or a pipe (as under pytest), nothing."""
    monkeypatch.setattr(refinement, "PROGRESS_AFTER_S", 0.0)
    assert cli_main(["solve", "--shape", "polygon", "--accuracy", "1e-2", "--json"]) == 0
    assert capsys.readouterr().err == ""  # not a terminal
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert cli_main(["solve", "--shape", "polygon", "--accuracy", "1e-2", "--json"]) == 0
    captured = capsys.readouterr()
    record = json.loads(captured.out)  # stdout: one JSON object and nothing else
    lines = captured.err.splitlines()
    assert len(lines) == len(record["grids"]) and all(LINE.fullmatch(line) for line in lines)
    monkeypatch.setattr(refinement, "PROGRESS_AFTER_S", 3600.0)
    assert cli_main(["solve", "--shape", "polygon", "--accuracy", "1e-2"]) == 0
    assert capsys.readouterr().err == ""
