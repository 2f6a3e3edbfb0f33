"""The records a run passes between its roles: the options of ``hpcontact run``, rank 0's
decision and what it keeps for itself, the scope of an adaptive round, each rank's totals, and
the outcome."""

from __future__ import annotations

import sys
from collections.abc import Callable, Mapping
from collections.abc import Set as AbstractSet
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hpcontact.errors import Front
from hpcontact.sweep.data.columns import ColumnsOnce
from hpcontact.sweep.data.journal import Entry, History, HistoryReader
from hpcontact.sweep.run.guard import RunLock
from hpcontact.sweep.space.spec import Spec
from hpcontact.sweep.work.tasks import Task

TaskFunction = Callable[[Mapping[str, Any]], Mapping[str, Any]]


def runner_name(function: TaskFunction | None) -> str | None:
    """The identity of a task function as journals record it (``Options.runner``): its
    ``__module__.__qualname__`` ("hpcontact.sweep.accuracy_study.cold_solve"), the module named
    as imported even when it runs as ``__main__`` (``python -m``), so that both ways of starting
    one runner give one name; None for None, the spec's scene kind's own solver."""
    if function is None:
        return None
    module = getattr(function, "__module__", None) or "?"
    if module == "__main__":
        module = getattr(getattr(sys.modules.get("__main__"), "__spec__", None), "name", None) or module
    return f"{module}.{getattr(function, '__qualname__', type(function).__qualname__)}"


class Stopped(Exception):
    """The run ended without a data set on every rank: stopped by a signal (``status`` 4), or a
    journal or the data set could not be written (a full disk; ``status`` 1); journals intact."""

    def __init__(self, message: str, status: int) -> None:
        super().__init__(message)
        self.status = status


@dataclass(frozen=True)
class Options:
    """How a run treats existing journals and locks (``hpcontact run`` flags)."""

    resume: bool = False
    restart: bool = False
    accept_stale: bool = False
    retry_crashed: bool = False
    break_lock: bool = False
    mem_per_rank: tuple[int, str] | None = None  # bytes a rank may use and where that comes from: checked if set
    up_to_date: bool = (
        False  # journals without resume/restart: a data set that is ``up_to_date`` is left as is, not refused
    )
    # the runner journal entries name (``runner_name`` of a task function; None: the spec's scene
    # kind's own solver): set where a task function computes other results than the kind's own
    # solver (the accuracy study), not for a wrapper of it (one that counts calls, a stand-in)
    runner: str | None = None
    # the front end that started the run: its words for an option the run's printed advice names
    # (``errors.Option``: ``--retry-crashed`` on the command line, ``retry_crashed=True`` in Python)
    front: Front = Front.COMMAND_LINE


NO_FLAGS = Options()  # ``hpcontact run`` without flags


@dataclass(frozen=True)
class Outcome:
    """What a finished run produced: the data set and its failed tasks (crashed included);
    ``up_to_date``: nothing was run or written (``up_to_date``)."""

    path: Path
    failures: int
    up_to_date: bool = False


@dataclass
class RoundTally:
    """The summary's sums over the rounds of an adaptive run (``adaptive.run_rounds``): each
    round is a run of its own, and the data set's summary is of them all (tasks run and reused,
    task, set-up, scheduling and journal seconds); ``begun`` counts the rounds begun (every
    rank), the sums are rank 0's."""

    begun: int = 0
    run: int = 0
    reused: int = 0
    task_s: float = 0.0
    setup_s: float = 0.0
    schedule_s: float = 0.0
    journal_s: float = 0.0

    def add(self, run: int, reused: int, task_s: float, setup_s: float, schedule_s: float, journal_s: float) -> None:
        """Count one more round."""
        self.run += run
        self.reused += reused
        self.task_s += task_s
        self.setup_s += setup_s
        self.schedule_s += schedule_s
        self.journal_s += journal_s


@dataclass
class RoundMemory:
    """What rank 0 keeps from one round of an adaptive map to the next (issue 40 item 5: rank 0
    alone between rounds, every other rank waiting, re-read every journal and rebuilt the
    columns of every earlier round, each round): the journals' reader (``HistoryReader``: each
    round parses what was appended since the last), each journaled task's verdict (``_decide``:
    its entry, and its runner if its outcome and scene let it be reused, else None), the keys
    of the tasks the run has handed out (``handed_out``: their entries were journaled under the
    run's lock by its own code from the scenes as rank 0 resolves them, so ``_decide`` does not
    resolve them again: ``provenance.resolved_scene``, ~60 µs a scene, was 0.15-0.3 CPU s of the
    4-D map's 5 323 entries), the earlier rounds' columns (``columns.ColumnsOnce``) and the first
    round's options (a later round runs as a resume; the data set's history is the run's as its
    user started it)."""

    reader: HistoryReader | None = None
    verdicts: dict[str, tuple[Entry, str | None]] = field(default_factory=dict)
    handed_out: set[str] = field(default_factory=set)
    earlier_columns: ColumnsOnce = field(default_factory=ColumnsOnce)
    first_options: Options | None = None

    def history(self, folder: Path) -> History:
        """The history of the journals in ``folder`` (``journal.read_history``), read
        incrementally from the last round's."""
        if self.reader is None or self.reader.folder != Path(folder):
            self.reader = HistoryReader(folder)
        return self.reader.read()


@dataclass(frozen=True)
class RoundScope:
    """What one round of a run covers: a plain run is one round of every task (the defaults);
    an adaptive round (``adaptive.run_rounds``) runs the tasks of ``select`` (positions) alone,
    rank 0 gives ``finish(make, joined)`` the joined columns of every journaled task (the
    stiffness records) and ``make()``, which builds their data set, and writes what it returns
    (None: nothing), ``tally`` sums the rounds for the summary, and the outcomes of ``earlier`` (the
    rounds before) that are not reused (failures) are carried into the data set as they are."""

    select: frozenset[int] | None = None
    finish: Callable[[Any, Any], Any] | None = None
    tally: RoundTally | None = None
    earlier: frozenset[int] = frozenset()
    memory: RoundMemory | None = None  # rank 0's, shared by an adaptive run's rounds


EVERY_TASK = RoundScope()  # a plain run's one round


@dataclass(frozen=True)
class Decision:
    """Rank 0's decisions, broadcast to every rank: tasks by position (0-based, task order)."""

    isolated: list[int]  # suspects, run by rank 0 alone
    shared: list[int]  # the rest of the work, in chunks for every rank
    reused: int  # the round's tasks from journals (an adaptive round's own, not its earlier rounds')
    crashed: int
    session: str
    provenance: dict[str, Any]
    faults: dict[int, str]
    up_to_date: bool = False  # the data set is the one this run would write: nothing to do


@dataclass(frozen=True)
class Kept:
    """What rank 0's preparation keeps on rank 0 for the round (``resume.prepare``): each
    point's task, the output's lock, the journals' history, the keys of the tasks reused from
    it, quarantined (crashed) and carried (an adaptive round's earlier failures), and the
    preparation's note, if any (a broken lock; entries of another runner, not reused)."""

    task_of: Any
    lock: RunLock
    history: History
    reused: AbstractSet[str]
    crashed: AbstractSet[str]
    note: str | None
    carried: AbstractSet[str] = frozenset()


@dataclass(frozen=True)
class Plan:
    """The work of every rank: the spec, its tasks (every rank joins them from the ranks'
    shares) and rank 0's decisions, with the suspects (run by rank 0 alone) and the rest of the
    work (in chunks for every rank) as tasks."""

    spec: Spec
    tasks: list[Task]
    decision: Decision
    isolated: list[Task]
    shared: list[Task]

    @classmethod
    def of(cls, spec: Spec, tasks: list[Task], decision: Decision) -> Plan:
        """The plan of ``decision``, its task positions turned into tasks."""
        return cls(spec, tasks, decision, [tasks[i] for i in decision.isolated], [tasks[i] for i in decision.shared])


@dataclass(frozen=True)
class RankTotals:
    """What one rank sends rank 0 at the end of a round: its task, scheduling, journal and
    journal-sync seconds, the tasks it ran, why it stopped (None: it did not) and whether that
    was a failure, the journal error that stopped it, and the columns of its outcomes
    (``columns.to_columns``; None when the run stopped)."""

    task_s: float
    run: int
    schedule_s: float
    journal_s: float
    sync_s: float
    reason: str | None
    failed: bool
    failure: str | None
    columns: Any
