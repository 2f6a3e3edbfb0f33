"""Progress lines while a sweep runs (printed by rank 0; the end-of-sweep summary: ``run.summary``).

The ETA is extrapolated from the estimated seconds done, not from the task count: tasks are
handed out largest first, so the first tasks take longer than the average and a count-based ETA
would run high for most of the sweep. The ranks count what they finish in cost units
(``schedule.cost_units``: the tasks' relative cost, which orders them); rank 0 turns the units
done into the cost model's seconds of the tasks that hold them in hand-out order (the finished
tasks are that order's first ones, give or take those in flight). Relative cost alone is not
seconds: on the main job at accuracy 1e-3 a crystal star's cost is 20× a thin crystal
rectangle's where its seconds are 11×, and an ETA by cost said 40 s with 1 min 47 s to go.
The wall seconds per estimated second measured so far correct the calibration's scale (a
calibration made under load, a prior scaled by a probe: ``cost.prior.run_calibration``),
and the last chunks, fewer than the ranks, are counted on the ranks still at work
(``Progress.busy_ranks``). The scale is all it corrects: the estimate's proportions between kinds
of task must hold (the main job's first run on a new machine, whose crystal rectangles were
estimated 2.25x low and its crystal exact cells 12x high, printed ETAs of 0.47-0.78 of the time
left). On replayed runs, that one among them, every ETA after a fifth of the tasks is within 2x
of the time left (``tests/sweep/run/test_progress_eta.py``), where an ETA by task count is more
than 2x off. Without estimated seconds the ETA is by cost units.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import TextIO

import numpy as np


def clock_text(seconds: float) -> str:
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

    ``total`` counts every task of the run (an adaptive round's: that round's), ``reused`` those
    already in journals, ``label`` what the line counts (an adaptive round: "adaptive round 2: ",
    its tasks, not the whole grid's, whose other tasks it may never solve); ``units`` are
    the cost units of the tasks the ranks report, in the order they are handed out, and
    ``seconds`` their estimated seconds (None without a calibration: the ETA is then by units);
    ``ranks`` run them, in chunks of ``chunk_lengths`` tasks (in hand-out order; None: one chunk).
    """

    def __init__(
        self,
        total: int,
        reused: int,
        units: Sequence[int],
        seconds: Sequence[float] | None,
        interval: float,
        stream: TextIO,
        ranks: int = 1,
        chunk_lengths: Sequence[int] | None = None,
        label: str = "",
    ) -> None:
        self.total = total
        self.label = label
        self.reused = reused
        self._units_done = np.concatenate(([0.0], np.cumsum(np.asarray(units, dtype=np.float64))))
        weights = units if seconds is None else seconds
        self._seconds_done = np.concatenate(([0.0], np.cumsum(np.asarray(weights, dtype=np.float64))))
        self.ranks = ranks
        lengths = [len(units)] if chunk_lengths is None else list(chunk_lengths)
        self._chunk_ends = self._units_done[np.cumsum(lengths, dtype=np.int64)] if lengths else np.zeros(0)
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

    def busy_ranks(self, units_done: float) -> int:
        """The ranks still at work when ``units_done`` cost units are finished: one per chunk not
        finished (the chunks whose end in hand-out order lies beyond ``units_done``), at most
        ``ranks``, at least one."""
        unfinished = int(np.count_nonzero(self._chunk_ends > units_done))
        return max(1, min(self.ranks, unfinished))

    def eta(self, units_done: float, elapsed: float) -> float | None:
        """Seconds left after ``elapsed`` seconds with ``units_done`` cost units finished: the
        estimated seconds left times the measured wall seconds per estimated second so far,
        elapsed × (1 − f) / f with f = ``fraction``, on the ranks still at work
        (× ranks / ``busy_ranks``: the last chunks run on fewer ranks than the run has);
        None before any task finished."""
        fraction = self.fraction(units_done)
        if fraction <= 0.0:
            return None
        return elapsed * (1.0 - fraction) / fraction * self.ranks / self.busy_ranks(units_done)

    def line(self, done: int, units_done: float, elapsed: float) -> str:
        """One progress line after ``elapsed`` seconds, ``done`` tasks of ``units_done`` run so far."""
        rate = done / elapsed if elapsed > 0.0 else 0.0
        eta = self.eta(units_done, elapsed)
        eta_text = "?" if eta is None else clock_text(eta)
        finished = self.reused + done
        return (
            f"hpcontact: {self.label}{finished}/{self.total} tasks ({100.0 * finished / max(self.total, 1):.0f}%), "
            f"{rate:.2f} tasks/s, elapsed {clock_text(elapsed)}, ETA {eta_text}"
        )
