"""Dynamic distribution of chunks over ranks: rank 0 holds the work counter and serves it over
two-sided messages from a thread, every rank (rank 0 included) computes.

Why not one-sided atomics (a counter in an MPI window, ``Fetch_and_op`` per chunk). MPI does
not promise that a passive-target operation completes while the target computes, and
multi-node transports do not give that progress: under Open MPI ``osc/ucx`` and MPICH over UCX
the workers stalled until rank 0 next entered MPI, and Open MPI over TCP could not create the
window; only shared-memory windows on one node worked — exactly the case clusters are not
(docs/performance.md §"Sweep scheduler").

Why not ``mpi4py.futures.MPICommExecutor``. It dedicates rank 0 to serving (half of a 2-rank
job idle) and funnels every result through it.

The choice. Rank 0 runs a server thread that answers requests (``fetch_add``: the index of
the next claim's first chunk, a claim being one chunk or, when the chunks are cheap against the
request, several: ``claimed_chunks``; ``add``: progress counts, no answer, sent at most once a second per worker) with ``Iprobe`` + ``Recv``, sleeping 0.5–4 ms
between empty polls; its main thread computes chunks like every other rank and takes its own
chunk indices from the same counter under a lock, without MPI. Point-to-point messages progress
on every transport as soon as the server thread polls, so a worker waits at most ``IDLE_POLL_S`` plus
one GIL switch interval (1 ms while serving) for a chunk, whatever rank 0 computes (FFTW and numpy release the
GIL). A server blocked in ``Recv`` would be simpler, but Open MPI's blocking receive busy-polls
a core, which takes it from rank 0's own solves (on 2 cores a blocking server thread cost about
half of what two ranks gain over one: docs/performance.md §"Sweep scheduler").

Thread level. Only one thread of rank 0 calls MPI at a time (the main thread makes no MPI call
between starting and joining the server), so ``MPI_THREAD_SERIALIZED`` suffices; it is requested
explicitly (mpi4py's default is ``MULTIPLE``, which some components refuse). An MPI that grants
less makes the server thread unsafe: rank 0 then answers requests between its own tasks and
while idle at the end, so a worker waits at most one of rank 0's tasks (one line says so and
names the setting to change).

Launch check. A batch system that starts N > 1 tasks without MPI process management (``srun``
without ``--mpi=pmix`` at a site whose default is ``none``) gives N independent processes that
would each run the whole sweep alone into the same output: ``world`` refuses that with
``LaunchError`` (exit 2 on the command line). ``HPCONTACT_MPI=0`` runs one process on purpose.

A solver never imports MPI: ``mpi4py`` is imported here, only when a launcher started the
process (``world``), and a single process without mpiexec runs with ``SerialTeam``.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from hpcontact.sweep.work.replay import claim_size
from hpcontact.sweep.work.tasks import CHUNKS_PER_RANK

# Environment variables through which a launcher hands MPI process management to a process:
# MPICH/Hydra, Intel MPI, MVAPICH and Slurm's pmi/pmi2 (PMI_*), PMIx (Slurm --mpi=pmix, prrte,
# Open MPI 5), Open MPI's own launcher (OMPI_*), Cray PALS (its PMI reads PALS_*), MPICH's
# MPI_LOCALNRANKS.
LAUNCHER_VARIABLES = (
    "PMI_RANK",
    "PMI_SIZE",
    "PMI_FD",
    "PMIX_RANK",
    "PMIX_NAMESPACE",
    "OMPI_COMM_WORLD_SIZE",
    "OMPI_COMM_WORLD_RANK",
    "MV2_COMM_WORLD_RANK",
    "PALS_RANKID",
    "MPI_LOCALNRANKS",
)
# Variables whose value is the number of processes the launcher started (checked against
# MPI.COMM_WORLD.size).
SIZE_VARIABLES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "MV2_COMM_WORLD_SIZE", "SLURM_STEP_NUM_TASKS")
# Batch systems: (name, variable that marks a task of a parallel launch, variables holding the
# number of tasks started, first one set wins). Slurm: srun sets SLURM_STEP_NUM_TASKS for the
# tasks of a step; the batch script itself has SLURM_PROCID=0 and SLURM_NTASKS (the allocation)
# but no step size, and one process started there is a deliberate serial run.
BATCH_LAUNCHES = (
    ("Slurm", "SLURM_PROCID", ("SLURM_STEP_NUM_TASKS",)),
    ("Flux", "FLUX_TASK_RANK", ("FLUX_JOB_SIZE",)),
    ("LSF jsrun", "JSM_NAMESPACE_RANK", ("JSM_NAMESPACE_SIZE",)),
    ("LSF blaunch", "LSF_PM_TASKID", ("LSB_DJOB_NUMPROC",)),
    ("PBS pbsdsh", "PBS_TASKNUM", ("PBS_NP",)),
)
# The server thread sleeps between empty polls: POLL_S after a message, doubling while none
# comes, up to IDLE_POLL_S; while it runs, rank 0's GIL switch interval is SWITCH_INTERVAL_S
# (Python's default, 5 ms, is how long a waking server waits for a main thread busy in Python
# code). A worker's claim then waits at most ~IDLE_POLL_S + SWITCH_INTERVAL_S, and rank 0's own
# work is interrupted at most 1/IDLE_POLL_S times a second (one GIL hand-over, ~µs, each).
# 16 ms polls with the default interval cost a 2-rank demo about a second of waiting
# (docs/performance.md §"Sweep scheduler").
POLL_S = 0.0005
IDLE_POLL_S = 0.004
SWITCH_INTERVAL_S = 0.001
# A worker's ``add``s are summed locally and sent at most every ADD_EVERY_S seconds (and before
# each claim and at close): rank 0 answers O(ranks) messages a second, not one per task, so its
# own solves do not pay for 1000 ranks' progress counts; progress lines lag by ≤ ADD_EVERY_S.
ADD_EVERY_S = 1.0


class LaunchError(RuntimeError):
    """The processes were started in a way that cannot run one sweep together (one line)."""


class Counter(Protocol):
    """Integer slots all ranks add to atomically."""

    def fetch_add(self, slot: int, value: int) -> int:
        """Add ``value`` to ``slot``; the value before the addition (waits for the result)."""

    def add(self, slot: int, values: Sequence[int]) -> None:
        """Add ``values`` to ``slot``, ``slot + 1``, …, without waiting (seen by other ranks
        after a delay: at the latest at this rank's next ``fetch_add`` or ``close``)."""

    def close(self) -> None:
        """Release the counter (collective; a rank may call it before the chunks run out)."""


class Team(Protocol):
    """The processes of a sweep: rank, size, the ranks on this rank's node and the few
    collectives the driver needs."""

    rank: int
    size: int
    node_size: int  # ranks of the team on this rank's node (shared memory), this one among them

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
    """The counter of a single process (thread-safe: rank 0's server thread shares it)."""

    def __init__(self, slots: int) -> None:
        self._values = [0] * slots
        self._lock = threading.Lock()

    def fetch_add(self, slot: int, value: int) -> int:
        with self._lock:
            old = self._values[slot]
            self._values[slot] += value
            return old

    def add(self, slot: int, values: Sequence[int]) -> None:
        with self._lock:
            for i, value in enumerate(values):
                self._values[slot + i] += value

    def close(self) -> None:
        """Nothing to release."""


class SerialTeam:
    """One process, no MPI."""

    rank = 0
    size = 1
    node_size = 1

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


# Messages to rank 0: int64 [operation, slot, count, value_0, …, value_{count-1}, 0, …].
FETCH_ADD, ADD, LEAVE = 0, 1, 2
REQUEST_TAG, ANSWER_TAG = 7301, 7302


class ServedCounter:
    """The counter on rank 0, served to the other ranks by messages (see the module docstring).

    ``threaded``: rank 0 serves from a thread (needs ``MPI_THREAD_SERIALIZED``); otherwise it
    answers pending requests whenever it touches the counter itself (between its tasks) and, at
    ``close``, until every other rank has left.
    """

    def __init__(self, comm: Any, slots: int, threaded: bool) -> None:
        from mpi4py import MPI

        self._MPI = MPI
        self._comm = comm
        self._message = np.zeros(3 + slots, dtype=np.int64)
        self._answer = np.zeros(1, dtype=np.int64)
        self._unsent = np.zeros(slots, dtype=np.int64)  # a worker's adds not yet sent
        self._sent_at = time.monotonic()
        self._left = False
        self._server: threading.Thread | None = None
        if comm.rank == 0:
            self._local = LocalCounter(slots)
            self._workers = comm.size - 1  # ranks that have not left yet
            if threaded and self._workers:
                self._switch_interval = sys.getswitchinterval()
                sys.setswitchinterval(min(self._switch_interval, SWITCH_INTERVAL_S))
                self._server = threading.Thread(target=self._serve, name="hpcontact-scheduler", daemon=True)
                self._server.start()
        self._threaded = threaded

    # rank 0 -----------------------------------------------------------------------------------
    def serve_one(self) -> bool:
        """Answer one pending request; False when none is waiting."""
        status = self._MPI.Status()
        if not self._comm.Iprobe(source=self._MPI.ANY_SOURCE, tag=REQUEST_TAG, status=status):
            return False
        source = status.Get_source()
        message = np.empty_like(self._message)
        self._comm.Recv([message, self._MPI.INT64_T], source=source, tag=REQUEST_TAG)
        operation, slot, values = int(message[0]), int(message[1]), message[3 : 3 + int(message[2])]
        if operation == FETCH_ADD:
            answer = np.array([self._local.fetch_add(slot, int(values[0]))], dtype=np.int64)
            self._comm.Send([answer, self._MPI.INT64_T], dest=source, tag=ANSWER_TAG)
        elif operation == ADD:
            self._local.add(slot, [int(v) for v in values])
        else:
            self._workers -= 1
        return True

    def _serve(self) -> None:
        """Answer requests until every other rank has left (the server thread's loop). A failure
        here would leave the other ranks waiting for ever: it ends the job instead."""
        try:
            pause = POLL_S
            while self._workers:
                if self.serve_one():
                    pause = POLL_S
                else:
                    time.sleep(pause)
                    pause = min(2.0 * pause, IDLE_POLL_S)
        except BaseException:
            traceback.print_exc()
            self._comm.Abort(1)
            raise

    def _drain(self) -> None:
        """Unthreaded rank 0: answer what is pending now."""
        if not self._threaded:
            while self._workers and self.serve_one():
                pass

    # every rank -------------------------------------------------------------------------------
    def _send(self, operation: int, slot: int, values: Sequence[int]) -> None:
        self._message[:] = 0
        self._message[:3] = operation, slot, len(values)
        self._message[3 : 3 + len(values)] = values
        self._comm.Send([self._message, self._MPI.INT64_T], dest=0, tag=REQUEST_TAG)

    def _send_adds(self) -> None:
        """A worker: send the adds summed since the last send, if any."""
        if self._unsent.any():
            self._send(ADD, 0, list(self._unsent))
            self._unsent[:] = 0
        self._sent_at = time.monotonic()

    def fetch_add(self, slot: int, value: int) -> int:
        if self._comm.rank == 0:
            self._drain()
            return self._local.fetch_add(slot, value)
        self._send_adds()
        self._send(FETCH_ADD, slot, [value])
        self._comm.Recv([self._answer, self._MPI.INT64_T], source=0, tag=ANSWER_TAG)
        return int(self._answer[0])

    def add(self, slot: int, values: Sequence[int]) -> None:
        if self._comm.rank == 0:
            self._drain()
            self._local.add(slot, values)
            return
        self._unsent[slot : slot + len(values)] += values
        if time.monotonic() - self._sent_at >= ADD_EVERY_S:
            self._send_adds()

    def close(self) -> None:
        if self._comm.rank == 0:
            if self._server is not None:
                self._server.join()
                sys.setswitchinterval(self._switch_interval)
            else:
                self._serve()
        elif not self._left:
            self._send_adds()
            self._send(LEAVE, 0, [])
            self._left = True
        self._comm.Barrier()


class MPITeam:
    """The ranks of an MPI communicator; ``threaded``: rank 0 may serve the counter from a
    thread (the MPI granted at least ``MPI_THREAD_SERIALIZED``)."""

    def __init__(self, comm: Any, threaded: bool = True) -> None:
        from mpi4py import MPI

        self.comm = comm
        self.rank = comm.rank
        self.size = comm.size
        self.threaded = threaded
        node = comm.Split_type(MPI.COMM_TYPE_SHARED)  # collective: every rank makes its team
        self.node_size = node.size
        node.Free()

    def bcast(self, obj: Any) -> Any:
        return self.comm.bcast(obj, root=0)

    def gather(self, obj: Any) -> list[Any] | None:
        return self.comm.gather(obj, root=0)

    def barrier(self) -> None:
        self.comm.Barrier()

    def counter(self, slots: int) -> Counter:
        return ServedCounter(self.comm, slots, self.threaded)

    def abort(self, code: int) -> None:
        self.comm.Abort(code)


def launched_by_mpi() -> bool:
    """True when an MPI launcher started this process (``HPCONTACT_MPI=0/1`` overrides)."""
    forced = os.environ.get("HPCONTACT_MPI")
    if forced in ("0", "1"):
        return forced == "1"
    return any(name in os.environ for name in LAUNCHER_VARIABLES)


def _count(value: str | None) -> int | None:
    """A task count from an environment variable (Slurm writes e.g. ``4(x2)`` in some)."""
    if value is None:
        return None
    digits = value.split("(")[0].strip()
    return int(digits) if digits.isdigit() else None


def check_launch(environ: Mapping[str, str] | None = None) -> None:
    """Refuse (``LaunchError``) a process that a batch system started as one of N > 1 tasks
    without MPI process management: every such process would run the whole sweep alone."""
    env = os.environ if environ is None else environ
    if env.get("HPCONTACT_MPI") in ("0", "1") or any(name in env for name in LAUNCHER_VARIABLES):
        return
    for name, marker, sizes in BATCH_LAUNCHES:
        if marker not in env:
            continue
        tasks = next((_count(env[v]) for v in sizes if v in env), None)
        if tasks is not None and tasks > 1:
            raise LaunchError(
                f"{name} started {tasks} tasks without MPI process management ({marker} set, no PMI/PMIx "
                "variables): each would run the whole sweep alone. Launch with `srun --mpi=pmix hpcontact run ...` "
                "(or --mpi=pmi2, or `mpirun -n N hpcontact run ...`); set HPCONTACT_MPI=0 to run one process on purpose"
            )


def _thread_level_name(MPI: Any, level: int) -> str:
    names = {
        MPI.THREAD_SINGLE: "SINGLE",
        MPI.THREAD_FUNNELED: "FUNNELED",
        MPI.THREAD_SERIALIZED: "SERIALIZED",
        MPI.THREAD_MULTIPLE: "MULTIPLE",
    }
    return names.get(level, str(level))


def world() -> Team:
    """``MPI.COMM_WORLD`` as a team under a launcher, else a ``SerialTeam`` (mpi4py not imported).

    Requests ``MPI_THREAD_SERIALIZED`` (unless ``MPI4PY_RC_THREAD_LEVEL`` or an earlier import of
    mpi4py decided otherwise); raises ``LaunchError`` for a batch launch without MPI process
    management and for a launcher whose rank count mpi4py does not see.
    """
    check_launch()
    if not launched_by_mpi():
        return SerialTeam()
    import mpi4py

    if "mpi4py.MPI" not in sys.modules and "MPI4PY_RC_THREAD_LEVEL" not in os.environ:
        mpi4py.rc.thread_level = "serialized"
    from mpi4py import MPI

    size = MPI.COMM_WORLD.size
    for name in SIZE_VARIABLES:
        expected = _count(os.environ.get(name))
        if expected is not None and expected != size:
            raise LaunchError(
                f"the launcher started {expected} ranks ({name}) but mpi4py sees {size}: mpi4py is built against "
                "another MPI than the mpiexec/srun in use (rebuild it: pip install --no-binary=mpi4py mpi4py)"
            )
    granted = MPI.Query_thread()
    threaded = granted >= MPI.THREAD_SERIALIZED
    if not threaded and size > 1 and MPI.COMM_WORLD.rank == 0:
        print(
            f"hpcontact: MPI granted thread level {_thread_level_name(MPI, granted)} (< SERIALIZED): rank 0 hands out "
            "work only between its own tasks; set MPI4PY_RC_THREAD_LEVEL=serialized or use an MPI built with thread support",
            file=sys.stderr,
            flush=True,
        )
    return MPITeam(MPI.COMM_WORLD, threaded)


NEXT_CHUNK = 0  # counter slots
TASKS_DONE = 1
COST_DONE = 2
SLOTS = 3


def claimed_chunks(
    chunks: Sequence[tuple[Any, ...]],
    counter: Counter,
    ranks: int | None = None,
    clock: Callable[[], float] = time.perf_counter,
    fill: Callable[[int, int], int] | None = None,
) -> Iterator[tuple[Any, ...]]:
    """The chunks this rank takes, until none is left (every rank calls it; a rank may stop
    early, e.g. on a signal, and then calls ``counter.close``). With ``ranks`` (the team's
    size), each request takes the next ``replay.claim_size`` chunks, from this rank's mean round
    trip and chunk seconds so far on ``clock`` (the time from a claim's answer to the next
    request, divided by its chunks); without, one chunk a request.

    ``fill`` (a GPU rank's ``work.batches.batch_fill``): fill(i, most), the chunks from index i
    (at most ``most``) that fill one of this rank's batches. Each request then takes at least
    fill(i, most) chunks, i the index where this rank's last claim ended (where the next free
    chunk was when it last looked: chunks are in decreasing cost, so the chunks there are like
    the next ones; 0 at first), ``most`` the bound ``claim_size`` puts on a claim (a share
    1/(CHUNKS_PER_RANK × ranks) of the chunks left, so that one fast rank does not take the
    tail; with no ``ranks`` or one, all of them); and a claim's chunks come as one tuple of
    their items, so that the rank batches them together (issue 41 item 2: a chunk holds one
    kernel group, a batch the scenes of many). A guess that misses (other ranks took those
    chunks, the next ones batch less) changes how many scenes a batch holds, never a result."""
    asked = taken = 0
    waited = busy = 0.0
    take = 1 if fill is None else _filling(fill, 0, len(chunks), ranks)
    while True:
        before = clock()
        index = counter.fetch_add(NEXT_CHUNK, take)
        after = clock()
        if index >= len(chunks):
            return
        got = chunks[index : index + take]
        if fill is None:
            yield from got
        else:
            yield tuple(item for chunk in got for item in chunk)
        take, remaining = 1, len(chunks) - index - len(got)
        if ranks is not None:
            asked, taken = asked + 1, taken + len(got)
            waited, busy = waited + after - before, busy + clock() - after
            take = claim_size(waited / asked, busy / taken, remaining, ranks)
        if fill is not None:
            take = max(take, _filling(fill, index + len(got), remaining, ranks))


def _filling(fill: Callable[[int, int], int], index: int, remaining: int, ranks: int | None) -> int:
    """fill(index, most) within [1, most]: ``most`` the bound ``replay.claim_size`` puts on a
    claim with ``ranks`` > 1 (all ``remaining`` chunks alone: no other rank to leave a tail to)."""
    most = max(1, remaining if ranks is None or ranks == 1 else remaining // (CHUNKS_PER_RANK * ranks))
    return max(1, min(fill(index, most), most))


def cost_units(cost: float) -> int:
    """The units a finished task of relative ``cost`` adds to the count (at least one)."""
    return max(1, int(round(cost)))


def report_done(counter: Counter, cost: float) -> None:
    """Count one finished task of relative ``cost`` (``cost_units``), without waiting."""
    counter.add(TASKS_DONE, (1, cost_units(cost)))


def totals_done(counter: Counter) -> tuple[int, int]:
    """Tasks and estimated cost finished so far by all ranks (as far as they have arrived)."""
    return counter.fetch_add(TASKS_DONE, 0), counter.fetch_add(COST_DONE, 0)
