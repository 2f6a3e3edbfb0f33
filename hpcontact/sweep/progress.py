"""Progress lines and the end-of-sweep summary (printed by rank 0).

The ETA is extrapolated from the estimated seconds done, not from the task count: tasks are
handed out largest first, so the first tasks take longer than the average and a count-based ETA
would run high for most of the sweep. The ranks count what they finish in cost units
(``schedule.cost_units``: the tasks' relative cost, which orders them); rank 0 turns the units
done into the cost model's seconds of the tasks that hold them in hand-out order (the finished
tasks are that order's first ones, give or take those in flight). Relative cost alone is not
seconds: on the main job at accuracy 1e-3 a crystal star's cost is 20× a thin crystal
rectangle's where its seconds are 11×, and an ETA by cost said 40 s with 1 min 47 s to go.
Without a calibration the ETA is by cost units.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TextIO

import numpy as np


def _duration(seconds: float) -> str:
    """``seconds`` as 42s, 3m07s or 2h05m."""
    seconds = max(0.0, seconds)
    if seconds < 60.0:
        return f"{seconds:.1f}s" if seconds < 10.0 else f"{seconds:.0f}s"
    minutes, secs = divmod(int(round(seconds)), 60)
    if minutes < 60:
        return f"{minutes}m{secs:02d}s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours}h{minutes:02d}m"


class Progress:
    """Prints ``done/total``, rate and ETA at most every ``interval`` seconds.

    ``total`` counts every task of the sweep, ``reused`` those already in journals; ``units`` are
    the cost units of the tasks the ranks report, in the order they are handed out, and
    ``seconds`` their estimated seconds (None without a calibration: the ETA is then by units).
    """

    def __init__(
        self,
        total: int,
        reused: int,
        units: Sequence[int],
        seconds: Sequence[float] | None,
        interval: float,
        stream: TextIO,
    ) -> None:
        self.total = total
        self.reused = reused
        self._units_done = np.concatenate(([0.0], np.cumsum(np.asarray(units, dtype=np.float64))))
        weights = units if seconds is None else seconds
        self._seconds_done = np.concatenate(([0.0], np.cumsum(np.asarray(weights, dtype=np.float64))))
        self.interval = interval
        self.stream = stream
        self.started = time.perf_counter()
        self._last = self.started

    def due(self) -> bool:
        """Whether ``interval`` seconds have passed since the last line."""
        return time.perf_counter() - self._last >= self.interval

    def report(self, done: int, units_done: float) -> None:
        """Print the line for ``done`` tasks of ``units_done`` cost units finished this run."""
        self._last = time.perf_counter()
        print(self.line(done, units_done, self._last - self.started), file=self.stream, flush=True)

    def fraction(self, units_done: float) -> float:
        """The share of the estimated seconds done when ``units_done`` cost units are."""
        total = float(self._seconds_done[-1])
        if total <= 0.0:
            return 1.0
        return min(1.0, float(np.interp(units_done, self._units_done, self._seconds_done)) / total)

    def line(self, done: int, units_done: float, elapsed: float) -> str:
        """One progress line after ``elapsed`` seconds, ``done`` tasks of ``units_done`` run so far."""
        rate = done / elapsed if elapsed > 0.0 else 0.0
        fraction = self.fraction(units_done)
        eta_text = _duration(elapsed * (1.0 - fraction) / fraction) if fraction > 0.0 else "?"
        finished = self.reused + done
        return (
            f"hpcontact: {finished}/{self.total} tasks ({100.0 * finished / max(self.total, 1):.0f}%), "
            f"{rate:.2f} tasks/s, elapsed {_duration(elapsed)}, ETA {eta_text}"
        )


@dataclass(frozen=True)
class Summary:
    """Totals of one run: tasks run now, reused from journals and failed; times in seconds.

    ``wall_s`` runs from the driver's start to the data set assembled (the netCDF write after it
    is reported on its own); ``setup_s`` is the time until the ranks start computing (each
    rank's share of the points enumerated and validated, rank 0's decision from the journals,
    the plan broadcast); ``schedule_s`` and ``journal_s`` are summed over ranks; ``gather_s`` is
    rank 0 joining the ranks' outcome columns and those reused from journals into the data set.
    """

    tasks: int
    points: int
    run: int
    reused: int
    failures: int
    ranks: int
    wall_s: float
    task_s: float
    setup_s: float
    schedule_s: float
    journal_s: float
    gather_s: float

    @property
    def efficiency(self) -> float:
        """Parallel efficiency Σ task time / (ranks × wall)."""
        return self.task_s / (self.ranks * self.wall_s) if self.wall_s > 0.0 else 0.0

    @property
    def overhead_per_task_s(self) -> float:
        """Driver time per task run: (ranks × wall − Σ task time) / tasks run."""
        return (self.ranks * self.wall_s - self.task_s) / max(self.run, 1)

    def attrs(self) -> dict[str, float | int]:
        """The summary as data-set attributes (``sweep_*``)."""
        return {
            "sweep_tasks": self.tasks,
            "sweep_tasks_run": self.run,
            "sweep_tasks_reused": self.reused,
            "sweep_failures": self.failures,
            "sweep_wall_time_s": self.wall_s,
            "sweep_task_time_s": self.task_s,
            "sweep_parallel_efficiency": self.efficiency,
            "sweep_overhead_per_task_s": self.overhead_per_task_s,
            "sweep_setup_time_s": self.setup_s,
            "sweep_schedule_time_s": self.schedule_s,
            "sweep_journal_time_s": self.journal_s,
            "sweep_gather_time_s": self.gather_s,
        }

    def text(self, failures: list[str]) -> str:
        """The end-of-sweep report; ``failures`` are up to a few failed-task messages."""
        lines = [
            f"hpcontact: sweep done: {self.tasks} tasks for {self.points} points "
            f"({self.run} run, {self.reused} from journals), {self.failures} failed",
        ]
        if self.run:
            lines += [
                f"hpcontact: wall {_duration(self.wall_s)} on {self.ranks} rank(s); task time {self.task_s:.2f}s "
                f"total, {self.task_s / self.run:.3f}s per task; parallel efficiency {self.efficiency:.3f}",
                f"hpcontact: driver time: setup {self.setup_s:.3f}s, scheduling {self.schedule_s:.3f}s, "
                f"journal {self.journal_s:.3f}s (all ranks), gather {self.gather_s:.3f}s; "
                f"{self.overhead_per_task_s * 1e3:.1f} ms per task",
            ]
        lines += [f"hpcontact: failed: {m}" for m in failures]
        return "\n".join(lines)
