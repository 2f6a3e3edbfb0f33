"""Dynamic distribution of chunks over ranks: a shared atomic counter, every rank a worker.

Choice: a one-sided atomic counter (MPI RMA ``Fetch_and_op`` on an int64 window held by rank
0), not ``mpi4py.futures.MPICommExecutor``. The executor dedicates rank 0 to handing out work,
which idles half of a 2-rank job (and 1/64 of a 64-rank one) and funnels every result through
one process. With the counter, each rank takes the next chunk index itself, so all ranks
compute, results stay on the rank that made them (its journal), and the only traffic is one
8-byte atomic per chunk.

Progress: the passive-target epoch is opened once (``Lock_all`` with ``MODE_NOCHECK``) and an
operation whose result is needed is completed with ``Flush``. Locking per operation instead
makes a ``Fetch_and_op`` wait until the target rank next enters the MPI library, i.e. until rank
0 finishes its own solve (measured with MPICH: 3 s stalls behind a 3 s solve); within one epoch
the atomics complete in microseconds through shared memory or the network's hardware atomics,
with rank 0 busy. Finished-task counts (for progress lines only) are added with ``Accumulate``
and never waited for: one waiting operation per chunk is all a rank pays.

A solver never imports MPI: ``mpi4py`` is imported here, only when a launcher started the
process (``world``), and a single process without mpiexec runs with ``SerialTeam``.
"""

from __future__ import annotations

import os
from typing import Any, Iterator, Protocol, Sequence

import numpy as np

# Environment variables set by MPI launchers (MPICH/Hydra and PMI-1/2, PMIx, Open MPI, Slurm+PMI).
LAUNCHER_VARIABLES = ("PMI_RANK", "PMI_SIZE", "PMIX_RANK", "OMPI_COMM_WORLD_SIZE", "MPI_LOCALNRANKS")


class Counter(Protocol):
    """Integer slots all ranks add to atomically."""

    def fetch_add(self, slot: int, value: int) -> int:
        """Add ``value`` to ``slot``; the value before the addition (waits for the result)."""

    def add(self, slot: int, values: Sequence[int]) -> None:
        """Add ``values`` to ``slot``, ``slot + 1``, …; done by the next ``fetch_add`` or ``close``
        at the latest (no wait)."""

    def close(self) -> None:
        """Release the counter (collective)."""


class Team(Protocol):
    """The processes of a sweep: rank, size and the few collectives the driver needs."""

    rank: int
    size: int

    def bcast(self, obj: Any) -> Any:
        """Rank 0's ``obj`` on every rank."""

    def gather(self, obj: Any) -> list[Any] | None:
        """Every rank's ``obj`` as a list on rank 0, None elsewhere."""

    def barrier(self) -> None:
        """Wait for every rank."""

    def counter(self, slots: int) -> Counter:
        """A zeroed shared counter with ``slots`` int64 slots (collective)."""

    def abort(self, code: int) -> None:
        """End every process of the team after an unrecoverable error on this one."""


class LocalCounter:
    """The counter of a single process."""

    def __init__(self, slots: int) -> None:
        self._values = [0] * slots

    def fetch_add(self, slot: int, value: int) -> int:
        old = self._values[slot]
        self._values[slot] += value
        return old

    def add(self, slot: int, values: Sequence[int]) -> None:
        for i, value in enumerate(values):
            self._values[slot + i] += value

    def close(self) -> None:
        """Nothing to release."""


class SerialTeam:
    """One process, no MPI."""

    rank = 0
    size = 1

    def bcast(self, obj: Any) -> Any:
        return obj

    def gather(self, obj: Any) -> list[Any]:
        return [obj]

    def barrier(self) -> None:
        """Nothing to wait for."""

    def counter(self, slots: int) -> Counter:
        return LocalCounter(slots)

    def abort(self, code: int) -> None:
        """Nothing else to end: the caller returns its exit status."""


class RMACounter:
    """int64 slots in an MPI window on rank 0: ``Fetch_and_op`` + ``Flush`` when the value is
    needed, ``Accumulate`` without waiting otherwise (see the module docstring)."""

    def __init__(self, comm: Any, slots: int) -> None:
        from mpi4py import MPI

        self._MPI = MPI
        self._win = MPI.Win.Allocate(8 * slots if comm.rank == 0 else 0, disp_unit=8, comm=comm)
        if comm.rank == 0:
            self._win.Lock(0, MPI.LOCK_EXCLUSIVE)
            np.frombuffer(self._win.tomemory(), dtype=np.int64)[:] = 0
            self._win.Unlock(0)
        comm.Barrier()
        self._win.Lock_all(MPI.MODE_NOCHECK)
        self._comm = comm
        self._add = np.zeros(1, dtype=np.int64)
        self._old = np.zeros(1, dtype=np.int64)
        self._pending: list[np.ndarray] = []  # buffers of accumulates not yet flushed

    def fetch_add(self, slot: int, value: int) -> int:
        self._add[0] = value
        self._win.Fetch_and_op([self._add, self._MPI.INT64_T], [self._old, self._MPI.INT64_T], 0, slot, self._MPI.SUM)
        self._win.Flush(0)
        self._pending.clear()
        return int(self._old[0])

    def add(self, slot: int, values: Sequence[int]) -> None:
        buffer = np.array(values, dtype=np.int64)
        self._pending.append(buffer)
        target = (slot, len(buffer), self._MPI.INT64_T)
        self._win.Accumulate([buffer, self._MPI.INT64_T], 0, target=target, op=self._MPI.SUM)

    def close(self) -> None:
        self._win.Unlock_all()
        self._comm.Barrier()
        self._win.Free()


class MPITeam:
    """The ranks of an MPI communicator."""

    def __init__(self, comm: Any) -> None:
        self.comm = comm
        self.rank = comm.rank
        self.size = comm.size

    def bcast(self, obj: Any) -> Any:
        return self.comm.bcast(obj, root=0)

    def gather(self, obj: Any) -> list[Any] | None:
        return self.comm.gather(obj, root=0)

    def barrier(self) -> None:
        self.comm.Barrier()

    def counter(self, slots: int) -> Counter:
        return RMACounter(self.comm, slots)

    def abort(self, code: int) -> None:
        self.comm.Abort(code)


def launched_by_mpi() -> bool:
    """True when an MPI launcher started this process (``HPCONTACT_MPI=0/1`` overrides)."""
    forced = os.environ.get("HPCONTACT_MPI")
    if forced in ("0", "1"):
        return forced == "1"
    return any(name in os.environ for name in LAUNCHER_VARIABLES)


def world() -> Team:
    """``MPI.COMM_WORLD`` as a team under a launcher, else a ``SerialTeam`` (mpi4py not imported)."""
    if not launched_by_mpi():
        return SerialTeam()
    from mpi4py import MPI

    expected = os.environ.get("PMI_SIZE") or os.environ.get("OMPI_COMM_WORLD_SIZE")
    if expected is not None and int(expected) != MPI.COMM_WORLD.size:
        raise RuntimeError(
            f"the launcher started {expected} ranks but mpi4py sees {MPI.COMM_WORLD.size}: "
            "mpi4py is built against another MPI than the mpiexec/srun in use"
        )
    return MPITeam(MPI.COMM_WORLD)


NEXT_CHUNK = 0  # counter slots
TASKS_DONE = 1
COST_DONE = 2
SLOTS = 3


def claimed_chunks(chunks: Sequence[tuple[Any, ...]], counter: Counter) -> Iterator[tuple[Any, ...]]:
    """The chunks this rank takes, one at a time, until none is left (every rank calls it)."""
    while True:
        index = counter.fetch_add(NEXT_CHUNK, 1)
        if index >= len(chunks):
            return
        yield chunks[index]


def report_done(counter: Counter, cost: float) -> None:
    """Count one finished task of estimated ``cost`` (at least one unit), without waiting."""
    counter.add(TASKS_DONE, (1, max(1, int(round(cost)))))


def totals_done(counter: Counter) -> tuple[int, int]:
    """Tasks and estimated cost finished so far by all ranks (as far as they have arrived)."""
    return counter.fetch_add(TASKS_DONE, 0), counter.fetch_add(COST_DONE, 0)
