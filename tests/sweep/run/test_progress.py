"""Progress lines and the summary."""

from __future__ import annotations

import io

from hpcontact.sweep.run.progress import Progress
from hpcontact.sweep.run.summary import Summary


def test_progress_line_counts_reused_tasks_and_extrapolates_cost_units_without_a_calibration():
    progress = Progress(total=100, reused=20, units=[10] * 80, seconds=None, interval=10.0, stream=io.StringIO())
    line = progress.line(done=40, units_done=200.0, elapsed=30.0)
    assert "60/100 tasks (60%)" in line
    assert "1.33 tasks/s" in line
    assert "ETA 1m30s" in line  # a quarter of the units in 30 s: 90 s to go


def test_the_eta_counts_the_estimated_seconds_of_the_units_done():
    """Two large tasks first (100 units, 1 s each), then two small ones (1 unit, 1 s each): after
    the large two in 20 s half the estimated seconds are done, so 20 s remain — by units it
    would be 99 % done and say 0.2 s. Between two tasks' units the seconds are interpolated."""
    progress = Progress(
        total=4, reused=0, units=[100, 100, 1, 1], seconds=[1.0] * 4, interval=10.0, stream=io.StringIO()
    )
    assert "ETA 20s" in progress.line(done=2, units_done=200.0, elapsed=20.0)
    assert progress.fraction(50.0) == 0.125 and progress.fraction(201.0) == 0.75 and progress.fraction(1e9) == 1.0
    by_units = Progress(total=4, reused=0, units=[100, 100, 1, 1], seconds=None, interval=10.0, stream=io.StringIO())
    assert by_units.fraction(200.0) == 200.0 / 202.0


def test_progress_is_due_every_interval():
    stream = io.StringIO()
    progress = Progress(total=3, reused=0, units=[1, 1, 1], seconds=None, interval=3600.0, stream=stream)
    assert not progress.due()
    progress.interval = 0.0
    assert progress.due()
    progress.report(2, 2.0)
    assert stream.getvalue().startswith("hpcontact: 2/3 tasks")


def test_summary_efficiency_and_overhead():
    summary = Summary(
        tasks=10,
        points=40,
        run=8,
        reused=2,
        failures=1,
        ranks=2,
        wall_s=5.0,
        task_s=9.0,
        setup_s=0.1,
        schedule_s=0.01,
        journal_s=0.02,
        gather_s=0.3,
    )
    assert summary.efficiency == 0.9
    assert summary.overhead_per_task_s == 0.125
    text = summary.text(["{}: RuntimeError: x"])
    assert "parallel efficiency 0.900" in text and "1 failed" in text and "RuntimeError: x" in text
    assert summary.attrs()["sweep_parallel_efficiency"] == 0.9
