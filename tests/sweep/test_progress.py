"""Progress lines and the summary."""

from __future__ import annotations

import io

from hpcontact.sweep.progress import Progress, Summary


def test_progress_line_counts_reused_tasks_and_extrapolates_cost():
    progress = Progress(total=100, reused=20, todo_cost=1000.0, interval=10.0, stream=io.StringIO())
    line = progress.line(done=40, cost_done=250.0, elapsed=30.0)
    assert "60/100 tasks (60%)" in line
    assert "1.33 tasks/s" in line
    assert "ETA 1m30s" in line  # a quarter of the cost in 30 s: 90 s to go


def test_progress_is_due_every_interval():
    stream = io.StringIO()
    progress = Progress(total=3, reused=0, todo_cost=3.0, interval=3600.0, stream=stream)
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
