"""What the ranks share before they run: a value made on rank 0 (or its error) on every rank,
and each rank's share of the parameter space joined into the tasks of every rank.

A share travels as bytes (``packed``, ``unpacked``): its rows as plain tuples, made tasks again
with ``tasks.Task``'s C-level constructor, not pickled as named tuples (which unpickle through
``Task.__new__``, a Python call a row): on the 4-D map's 139 725 rows in 2 shares a share packed
in 0.458 -> 0.361 CPU s, both unpacked in 0.326 -> 0.312 (one process, min of 4, 2026-11-29,
docs/performance.md § Adaptive rounds on many ranks; ``benchmarks/adaptive_scaling.py`` times both
phases in its runs)."""

from __future__ import annotations

import pickle
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from hpcontact.errors import InputError
from hpcontact.sweep.run.records import Options
from hpcontact.sweep.run.schedule import Team
from hpcontact.sweep.space.spec import Spec, Validator
from hpcontact.sweep.work.estimate import check_memory
from hpcontact.sweep.work.tasks import Part, Task, as_task, enumerate_part, join_parts, paused_gc, points


@dataclass(frozen=True)
class SharedError:
    """An error of one rank as every rank raises it: an ``InputError``'s field, allowed values
    and value (``bad_input``), or any other exception's type and message naming the rank."""

    bad_input: tuple[str, str, Any] | None
    other: str | None

    @classmethod
    def of(cls, exc: Exception, rank: int) -> SharedError:
        """The error ``exc`` raised on ``rank``."""
        if isinstance(exc, InputError):
            return cls((exc.field, exc.allowed, exc.value), None)
        return cls(None, f"{type(exc).__name__} on rank {rank}: {exc}")

    def exception(self) -> Exception:
        """The exception every rank raises: an ``InputError`` alike, else a ``RuntimeError``."""
        return InputError(*self.bad_input) if self.bad_input is not None else RuntimeError(self.other)


def from_rank_zero(team: Team, make: Callable[[], Any]) -> Any:
    """``make()`` on rank 0, its value (or its exception) on every rank; rank 0 raises the
    exception itself."""
    value, error, raised = None, None, None
    if team.rank == 0:
        try:
            value = make()
        except Exception as exc:  # noqa: BLE001 - re-raised on every rank below
            error, raised = SharedError.of(exc, 0), exc
    value, error = team.bcast((value, error))
    if error is not None:
        if raised is not None:
            raise raised
        raise error.exception()
    return value


@dataclass(frozen=True)
class Share:
    """A rank's share of the points: its tasks, whether one may exceed the memory per rank, or
    the error that stopped its enumeration."""

    part: Part | None
    over: bool
    error: SharedError | None


def share(spec: Spec, rank: int, ranks: int, validate: Validator | None, options: Options) -> Share:
    """This rank's share of the points (a contiguous 1/ranks of them in C order): its tasks with
    every distinct scene validated, whether one exceeds the memory per rank, or the error."""
    total = points(spec)
    try:
        part = enumerate_part(spec, total * rank // ranks, total * (rank + 1) // ranks, validate, check=True)
        over = False
        if options.mem_per_rank is not None:
            try:
                check_memory([Task(*row) for row in part.rows], *options.mem_per_rank)
            except InputError:
                over = True  # rank 0 checks every task again and names the largest
        return Share(part, over, None)
    except Exception as exc:  # noqa: BLE001 - raised by rank 0 on every rank
        return Share(None, False, SharedError.of(exc, rank))


def joined(spec: Spec, shares: list[Share]) -> tuple[list[Task], Any, bool]:
    """Every rank: the tasks and each point's task from every rank's ``share`` (in rank order:
    the first bad scene in point order is the one raised, on every rank alike), and whether a
    task may exceed the memory per rank."""
    for each in shares:
        if each.error is not None:
            raise each.error.exception()
    tasks, task_of = join_parts(spec, [each.part for each in shares])
    return tasks, task_of, any(each.over for each in shares)


def packed(each: Share) -> bytes:
    """The share ``each`` as bytes for the other ranks (module docstring: rows as plain tuples)."""
    part = None if each.part is None else (list(map(tuple, each.part.rows)), each.part.task_of)
    return pickle.dumps((part, each.over, each.error), protocol=pickle.HIGHEST_PROTOCOL)


def unpacked(data: bytes) -> Share:
    """The ``Share`` that ``packed`` made ``data`` of (the collector off: rows without cycles,
    ``tasks.paused_gc``)."""
    with paused_gc():
        part, over, error = pickle.loads(data)
        return Share(None if part is None else Part(list(map(as_task, part[0])), part[1]), over, error)
