"""Stopping a sweep on every rank: SIGINT (Ctrl-C, which ``mpiexec`` forwards to every rank),
SIGTERM or SIGUSR1 to any rank (what SLURM's ``--signal`` sends ahead of a time limit), or a
rank that cannot write its journal. Each is a stop request: no traceback, journals synced, exit
status 4, ``--resume`` goes on.

A rank that makes no progress — stopped for good (SIGSTOP), its node frozen — would leave the
others waiting in a collective until the batch limit. Each rank's stop thread therefore writes a
heartbeat (a counter in ``alive-rankNNNNN`` in the journal folder) every ``HEARTBEAT_S`` (or
a quarter of the stall timeout, if shorter); rank 0's
thread watches the others' (and theirs rank 0's) and, when one has not changed for ``stall_s``
seconds (``hpcontact run --stall-timeout``, default ``DEFAULT_STALL_S``; 0 turns it off),
requests a stop naming that rank (status 1): the live ranks end as after any stop — at once
outside the tasks' phase, where the next collective would wait for the stalled rank forever —
and ``--resume`` goes on. The heartbeat
comes from a thread, so a long task does not stop it (the solvers release the GIL); only a
frozen process does. A counter, not a time stamp: nodes' clocks need not agree.

Every phase of a run honours a stop request (``phase``). While the ranks set up (spec, shares, journal
reading, the plan's broadcast) or gather and write the data set, no task is in flight: a rank
that is still there ``HARD_EXIT_S`` after the request's grace (blocked in a collective with a
rank that is, or in a long read or write; counted from the request on every rank, so that they
end together) prints one line and ends with status 4 — the journals hold
every finished task, and the data set is written atomically, so nothing is lost. Once the
data set is written (``done``) a request changes nothing: the run ends with its own status.

A rank that receives the signal (or fails) records the reason and drops a stop file ``STOP`` in
the journal folder (the signal also reaches the polling thread below through
``signal.set_wakeup_fd``, so a rank whose main thread is blocked in an MPI call, where Python
runs no signal handler, still passes the request on); a light daemon thread on every rank polls for that file (every
``POLL_S``), so the request reaches every rank without MPI calls from a second thread (the MPI
library may grant no more than ``MPI_THREAD_SERIALIZED``) and without any rank having to enter
MPI. A stopping rank claims no more work and lets the task in flight finish for ``grace_s``
seconds (default 30); then the thread sends SIGUSR2 to the main thread, whose handler raises
``Abandoned`` inside the task (a sleeping or Python-level computation stops at once, C code when
it returns). The driver journals the abandoned task as ``interrupted`` (not a crash), syncs,
and every rank exits with status 4. Should a rank still be running ``HARD_EXIT_S`` after the
grace (stuck in C code or in a collective with such a rank), the thread syncs the file systems
and ends the process with status 4 (1 after a write failure).
"""

from __future__ import annotations

import os
import signal
import socket
import threading
import time
from pathlib import Path
from types import FrameType

from hpcontact.sweep.data.journal import record_stall
from hpcontact.sweep.run.options import RESUME, STALL_TIMEOUT

STOP_NAME = "STOP"
SIGNALS = (signal.SIGTERM, signal.SIGUSR1, signal.SIGINT)
#: The phases of a run, as the stop thread sees them (module docstring).
PHASES = ("setup", "tasks", "finish", "done")
ABANDON = signal.SIGUSR2
POLL_S = 0.2
DEFAULT_GRACE_S = 30.0
HARD_EXIT_S = 10.0
HEARTBEAT_S = 5.0
DEFAULT_STALL_S = 900.0
ALIVE_PREFIX = "alive-rank"
STOPPED_STATUS = 4


class Abandoned(BaseException):
    """Raised in the task in flight when the grace period after a stop request is over (a
    BaseException, so a task's own ``except Exception`` does not swallow it)."""


class StopControl:
    """One run's stop state on one rank (see the module docstring). ``install`` sets the signal
    handlers (main thread only: the command line); ``watch`` starts the polling thread. Without
    ``install`` (``run_sweep`` called from a program) the rank still stops claiming work when
    another rank asks, but its task in flight runs to its end and the process is never ended."""

    def __init__(self, grace_s: float = DEFAULT_GRACE_S, stall_s: float = DEFAULT_STALL_S) -> None:
        if not grace_s >= 0.0:
            raise ValueError(f"grace_s = {grace_s}: a number of seconds >= 0")
        if not stall_s >= 0.0:
            raise ValueError(f"stall_s = {stall_s}: a number of seconds >= 0 (0: off)")
        self.grace_s = grace_s
        self.stall_s = stall_s
        self.ranks = 1
        self._beats = 0
        self._seen: dict[Path, tuple[bytes, float]] = {}  # rank 0: heartbeat file -> (content, when it last changed)
        self._next_beat = 0.0
        self._session: str | None = None  # the run's, where stalls are recorded (``watch``)
        self.reason: str | None = None
        self.failed = False  # stopped by an error (a full disk), not by a signal
        self.running = False  # the main thread is inside a task function
        self.rank = 0
        self._stopped_at = 0.0
        self._file: Path | None = None
        self._done = threading.Event()
        self._thread: threading.Thread | None = None
        self._previous: dict[int, object] = {}
        self._wakeup: tuple[int, int] | None = None  # pipe the C-level handler writes signal numbers to
        self._previous_wakeup = -1
        self.phase = "setup"
        self._phase_at = time.monotonic()

    @property
    def stopping(self) -> bool:
        """True once a stop was requested on any rank (as far as this rank has seen)."""
        return self.reason is not None

    def install(self, rank: int = 0) -> StopControl:
        """Handle SIGINT, SIGTERM and SIGUSR1 (stop) and SIGUSR2 (abandon the task in flight),
        and start the stop thread: from here on a request ends this rank in every phase."""
        self.rank = rank
        for signum in SIGNALS:
            self._previous[signum] = signal.signal(signum, self._on_signal)
        self._previous[ABANDON] = signal.signal(ABANDON, self._on_abandon)
        self._wakeup = os.pipe()
        for fd in self._wakeup:
            os.set_blocking(fd, False)
        self._previous_wakeup = signal.set_wakeup_fd(self._wakeup[1], warn_on_full_buffer=False)
        self._start()
        return self

    def watch(self, folder: Path, rank: int, ranks: int = 1, session: str | None = None) -> None:
        """Poll for the stop file in ``folder`` (after rank 0 removed an old one) and keep the
        heartbeats of ``ranks`` ranks there: the tasks' phase begins. ``session`` names the run
        (``journal.session_name``): a stall found in it is recorded in the journals
        (``journal.record_stall``), so that the task the stalled rank had started is not taken
        for one its process died running (None: not recorded)."""
        self.rank, self.ranks, self._session = rank, ranks, session
        self._file = Path(folder) / STOP_NAME
        self.enter("tasks")
        if self.reason is not None:
            self._drop_file()
        self._start()

    def enter(self, phase: str) -> None:
        """The run moves on to ``phase`` (``PHASES``)."""
        if phase not in PHASES:
            raise ValueError(f"phase = {phase!r}: one of {', '.join(PHASES)}")
        self.phase, self._phase_at = phase, time.monotonic()

    def _start(self) -> None:
        if self._thread is None:
            self._done.clear()
            self._thread = threading.Thread(target=self._poll, name="hpcontact-stop", daemon=True)
            self._thread.start()

    def request(self, reason: str, failed: bool = False) -> None:
        """Stop every rank: record ``reason`` and drop the stop file (best effort)."""
        if self.reason is None:
            self.reason, self.failed, self._stopped_at = reason, failed, time.monotonic()
            self._drop_file()

    def close(self) -> None:
        """End the polling thread (the run's work is over)."""
        self._done.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None

    def uninstall(self) -> None:
        """Restore the signal handlers ``install`` replaced."""
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)  # type: ignore[arg-type]
        self._previous.clear()
        if self._wakeup is not None:
            signal.set_wakeup_fd(self._previous_wakeup)
            for fd in self._wakeup:
                os.close(fd)
            self._wakeup = None

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        self.request(f"{signal.Signals(signum).name} on rank {self.rank} ({socket.gethostname()})")

    def _on_abandon(self, signum: int, frame: FrameType | None) -> None:
        if self.running and self.stopping:
            raise Abandoned(f"abandoned {self.grace_s:g} s after the stop request ({self.reason})")

    def _drop_file(self) -> None:
        if self._file is None:
            return
        try:
            fd = os.open(self._file, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except OSError:
            return  # another rank was first, or the disk is full: the others still stop at the end
        try:
            os.write(fd, f"{'failed' if self.failed else 'signal'} {self.reason}\n".encode())
        except OSError:
            pass
        finally:
            os.close(fd)

    def _read_file(self) -> None:
        if self._file is None:
            return  # setting up: the journal folder is not known yet
        try:
            text = self._file.read_text(encoding="utf-8").strip()
        except FileNotFoundError:
            return
        except OSError:
            text = ""
        kind, _, reason = text.partition(" ")
        if self.reason is None:
            self.reason, self.failed, self._stopped_at = reason or "stop file", kind == "failed", time.monotonic()

    def _signalled(self) -> None:
        """A stop signal the C-level handler recorded in the wakeup pipe, if any."""
        try:
            received = os.read(self._wakeup[0], 64) if self._wakeup is not None else b""
        except (BlockingIOError, OSError):
            return
        for signum in received:
            if signum in SIGNALS:
                self._on_signal(signum, None)

    def _poll(self) -> None:
        abandoned = False
        while not self._done.wait(POLL_S):
            if self.phase == "done":
                continue  # the data set is written: a request changes nothing
            if self.reason is None:
                self._signalled()
                self._read_file()
            stalled = self._heartbeat()
            if stalled is not None:
                other, why = stalled
                if self.phase == "tasks" and self.reason is None:
                    self._record_stall(other)
                    self.request(why, failed=True)  # the live ranks stop as after any request
                elif self._wakeup is not None:
                    self.reason, self.failed = why, True
                    self._exit_now()  # a collective with the stalled rank would never return
            if self.reason is None or self._wakeup is None:
                continue  # nothing asked, or not installed (a library call): no abandoning, no forced exit
            now = time.monotonic()
            late = now - self._stopped_at - self.grace_s
            if self.phase == "tasks":
                if late >= 0.0 and self.running and not abandoned:
                    abandoned = True
                    signal.pthread_kill(threading.main_thread().ident, ABANDON)
                if late >= HARD_EXIT_S:
                    self._exit_now()
            elif (
                (self.phase == "setup" or self.rank == 0)
                and late >= HARD_EXIT_S
                and now - self._phase_at >= HARD_EXIT_S
            ):
                # no task in flight: HARD_EXIT_S after the grace, as with a task, and at least the
                # phase's own HARD_EXIT_S to end cleanly. Counted from the request, which reaches every
                # rank at once, not from each rank's entry into the phase: ranks that started seconds
                # apart ended seconds apart, and the launcher's clean-up of the later one (Hydra's)
                # then reported status 9, not 4. While rank 0 writes the data set the others wait for
                # its word (or for its heartbeat to stop).
                self._exit_now()

    def _record_stall(self, other: int) -> None:
        """Record in the journal folder that rank ``other`` stalled in this run (``watch``'s
        session; best effort: a full disk stops the run anyway)."""
        if self._session is None or self._file is None:
            return
        try:
            record_stall(self._file.parent, self.rank, self._session, other)
        except OSError:
            pass

    def _heartbeat(self) -> tuple[int, str] | None:
        """Write this rank's heartbeat and look at the ranks it waits for: rank 0 at every other,
        the others at rank 0 (module docstring). The stall found, if any: the rank and why."""
        now = time.monotonic()
        if self._file is None or self.stall_s == 0.0 or self.ranks < 2 or now < self._next_beat:
            return None
        self._next_beat = now + min(HEARTBEAT_S, self.stall_s / 4.0)  # a stall is 4 beats missed at least
        self._beats += 1
        folder = self._file.parent
        try:
            (folder / f"{ALIVE_PREFIX}{self.rank:05d}").write_bytes(str(self._beats).encode())
        except OSError:
            pass  # a full disk stops the run through the journal, not here
        for other in range(1, self.ranks) if self.rank == 0 else (0,):
            path = folder / f"{ALIVE_PREFIX}{other:05d}"
            try:
                content = path.read_bytes()
            except OSError:
                content = b""  # not written yet: counts as unchanged from the start
            seen = self._seen.get(path)
            if seen is None or seen[0] != content:
                self._seen[path] = (content, now)
            elif now - seen[1] >= self.stall_s:
                return other, f"rank {other} made no progress for {now - seen[1]:.0f} s ({STALL_TIMEOUT.flag})"
        return None

    def _exit_now(self) -> None:
        """End this rank from the stop thread (the main thread is blocked): one line, the file
        systems synced, status 4 (1 after a write failure). Only the command line installs the
        handlers that lead here (``install``), so the line is in its words (``RESUME.flag``)."""
        status = 1 if self.failed else STOPPED_STATUS
        where = {
            "setup": "while setting up",
            "tasks": "with a task that did not end",
            "finish": "before the data set was written",
        }[self.phase]
        try:
            os.write(
                2,
                (
                    f"hpcontact: rank {self.rank} stopped {where} ({self.reason}); journals intact; "
                    f"run again with {RESUME.flag}\n"
                ).encode(),
            )
        except OSError:
            pass
        os.sync()
        os._exit(status)
