"""The end of a run's round on rank 0: its sums (an adaptive map's over its rounds so far), the
summary of the data set (``Summary``: its attributes and lines) and the lines printed after it
is written."""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from hpcontact.errors import Front, Message
from hpcontact.sweep.run.options import RESUME
from hpcontact.sweep.run.progress import clock_text
from hpcontact.sweep.run.records import Plan, RankTotals, RoundScope, RoundTally
from hpcontact.sweep.run.resume import journal_path

SHOWN_FAILURES = 5  # failed tasks the summary names (and tasks over memory a dry run names)


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

    @classmethod
    def of(cls, plan: Plan, sums: RoundTally, failures: int, ranks: int, wall_s: float, gather_s: float) -> Summary:
        """The summary of the data set of ``plan`` with the round's (or rounds') ``sums``."""
        return cls(
            tasks=len(plan.tasks),
            points=math.prod(len(a) for a in plan.spec.axes),
            run=sums.run,
            reused=sums.reused,
            failures=failures,
            ranks=ranks,
            wall_s=wall_s,
            task_s=sums.task_s,
            setup_s=sums.setup_s,
            schedule_s=sums.schedule_s,
            journal_s=sums.journal_s,
            gather_s=gather_s,
        )

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
                f"hpcontact: wall {clock_text(self.wall_s)} on {self.ranks} rank(s); task time {self.task_s:.2f}s "
                f"total, {self.task_s / self.run:.3f}s per task; parallel efficiency {self.efficiency:.3f}",
                f"hpcontact: driver time: setup {self.setup_s:.3f}s, scheduling {self.schedule_s:.3f}s, "
                f"journal {self.journal_s:.3f}s (all ranks), gather {self.gather_s:.3f}s; "
                f"{self.overhead_per_task_s * 1e3:.1f} ms per task",
            ]
        lines += [f"hpcontact: failed: {m}" for m in failures]
        return "\n".join(lines)


def round_sums(plan: Plan, scope: RoundScope, totals: list[RankTotals], setup_s: float) -> RoundTally:
    """The summary's sums of this round (tasks run and reused, task, set-up, scheduling and
    journal seconds); an adaptive round's are added to ``scope.tally`` and it is returned: the
    summary counts the run's rounds so far."""
    sums = RoundTally(
        run=sum(t.run for t in totals),
        reused=plan.decision.reused,
        task_s=sum(t.task_s for t in totals),
        setup_s=setup_s,
        schedule_s=sum(t.schedule_s for t in totals),
        journal_s=sum(t.journal_s for t in totals),
    )
    tally = scope.tally
    if tally is None:
        return sums
    tally.add(sums.run, sums.reused, sums.task_s, sums.setup_s, sums.schedule_s, sums.journal_s)
    return tally


def print_summary(
    summary: Summary,
    plan: Plan,
    joined: Any,
    failed: list[int],
    totals: list[RankTotals],
    path: Path,
    written_from: float,
    stream: TextIO,
    front: Front = Front.COMMAND_LINE,
) -> None:
    """The summary with the first ``SHOWN_FAILURES`` failed tasks (``failed``: positions) and
    their messages, a warning naming the ranks whose journals rank 0 does not see (not on a
    shared file system: a resume would run their tasks again; its option in ``front``'s words),
    and the data set written at ``path`` with the seconds since ``written_from``
    (``time.perf_counter``)."""
    spec = plan.spec
    shown = [
        f"{json.dumps(dict(plan.tasks[i].params), sort_keys=True)}: {joined.message[i]}"
        for i in failed[:SHOWN_FAILURES]
    ]
    print(summary.text(shown), file=stream)
    unseen = [r for r, t in enumerate(totals) if t.run and not journal_path(spec, r, plan.decision.session).exists()]
    if unseen:
        warning = Message(
            f"hpcontact: warning: rank 0 does not see the journals of rank(s) {', '.join(map(str, unseen[:10]))} in "
            f"{spec.journal} (a ",
            RESUME,
            " would compute their tasks again); is it on a file system every node shares?",
        )
        print(warning.render(front), file=stream)
    print(f"hpcontact: wrote {path} in {time.perf_counter() - written_from:.2f}s", file=stream, flush=True)
