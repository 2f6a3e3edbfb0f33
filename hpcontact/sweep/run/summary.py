"""The end of a run's round on rank 0: its sums (an adaptive map's over its rounds so far), the
summary of the data set (``progress.Summary``) and the lines printed after it is written."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any, TextIO

from hpcontact.sweep.progress import Summary
from hpcontact.sweep.run.records import Kept, Plan, RankTotals, RoundScope, RoundTally
from hpcontact.sweep.run.resume import journal_path

SHOWN_FAILURES = 5  # failed tasks the summary names (and tasks over memory a dry run names)


def round_sums(plan: Plan, kept: Kept, scope: RoundScope, totals: list[RankTotals], setup_s: float) -> RoundTally:
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
    selected = scope.select if scope.select is not None else range(len(plan.tasks))
    reused = sum(1 for i in selected if plan.tasks[i].key in kept.reused)  # this round's, from journals
    tally.add(sums.run, reused, sums.task_s, sums.setup_s, sums.schedule_s, sums.journal_s)
    return tally


def summary_of(plan: Plan, sums: RoundTally, failures: int, ranks: int, wall_s: float, gather_s: float) -> Summary:
    """The summary of the data set of ``plan``."""
    return Summary(
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


def print_summary(
    summary: Summary,
    plan: Plan,
    joined: Any,
    failed: list[int],
    totals: list[RankTotals],
    path: Path,
    written_from: float,
    stream: TextIO,
) -> None:
    """The summary with the first ``SHOWN_FAILURES`` failed tasks (``failed``: positions) and
    their messages, a warning naming the ranks whose journals rank 0 does not see (not on a
    shared file system: a ``--resume`` would run their tasks again), and the data set written
    at ``path`` with the seconds since ``written_from`` (``time.perf_counter``)."""
    spec = plan.spec
    shown = [
        f"{json.dumps(dict(plan.tasks[i].params), sort_keys=True)}: {joined.message[i]}"
        for i in failed[:SHOWN_FAILURES]
    ]
    print(summary.text(shown), file=stream)
    unseen = [r for r, t in enumerate(totals) if t.run and not journal_path(spec, r, plan.decision.session).exists()]
    if unseen:
        print(
            f"hpcontact: warning: rank 0 does not see the journals of rank(s) {', '.join(map(str, unseen[:10]))} in "
            f"{spec.journal} (a --resume would compute their tasks again); is it on a file system every node shares?",
            file=stream,
        )
    print(f"hpcontact: wrote {path} in {time.perf_counter() - written_from:.2f}s", file=stream, flush=True)
