"""Stopping a sweep on every rank: SIGTERM or SIGUSR1 to any rank (what SLURM's ``--signal``
sends ahead of a time limit), or a rank that cannot write its journal.

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

STOP_NAME = "STOP"
SIGNALS = (signal.SIGTERM, signal.SIGUSR1)
ABANDON = signal.SIGUSR2
POLL_S = 0.2
DEFAULT_GRACE_S = 30.0
HARD_EXIT_S = 10.0
STOPPED_STATUS = 4


class Abandoned(BaseException):
    """Raised in the task in flight when the grace period after a stop request is over (a
    BaseException, so a task's own ``except Exception`` does not swallow it)."""


class StopControl:
    """One run's stop state on one rank (see the module docstring). ``install`` sets the signal
    handlers (main thread only: the command line); ``watch`` starts the polling thread. Without
    ``install`` (``run_sweep`` called from a program) the rank still stops claiming work when
    another rank asks, but its task in flight runs to its end and the process is never ended."""

    def __init__(self, grace_s: float = DEFAULT_GRACE_S) -> None:
        if not grace_s >= 0.0:
            raise ValueError(f"grace_s = {grace_s}: a number of seconds >= 0")
        self.grace_s = grace_s
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

    @property
    def stopping(self) -> bool:
        """True once a stop was requested on any rank (as far as this rank has seen)."""
        return self.reason is not None

    def install(self) -> StopControl:
        """Handle SIGTERM and SIGUSR1 (stop) and SIGUSR2 (abandon the task in flight)."""
        for signum in SIGNALS:
            self._previous[signum] = signal.signal(signum, self._on_signal)
        self._previous[ABANDON] = signal.signal(ABANDON, self._on_abandon)
        self._wakeup = os.pipe()
        for fd in self._wakeup:
            os.set_blocking(fd, False)
        self._previous_wakeup = signal.set_wakeup_fd(self._wakeup[1], warn_on_full_buffer=False)
        return self

    def watch(self, folder: Path, rank: int) -> None:
        """Start polling for the stop file in ``folder`` (after rank 0 removed an old one)."""
        self.rank = rank
        self._file = Path(folder) / STOP_NAME
        if self.reason is not None:
            self._drop_file()
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
        try:
            text = self._file.read_text(encoding="utf-8").strip() if self._file is not None else ""
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
            if self.reason is None:
                self._signalled()
                self._read_file()
                continue
            if self._wakeup is None:
                continue  # not installed (a library call): no abandoning, no forced exit
            late = time.monotonic() - self._stopped_at - self.grace_s
            if late >= 0.0 and self.running and not abandoned:
                abandoned = True
                signal.pthread_kill(threading.main_thread().ident, ABANDON)
            if late >= HARD_EXIT_S:
                os.sync()
                os._exit(1 if self.failed else STOPPED_STATUS)
