"""May this run use this output? Refusals made before any task runs (exit status 2).

* The output's folder and the journal folder must be writable (each is created when its parent
  exists; a missing grandparent is a typo, refused), so a run never fails at its end for want of
  a place to write.
* One run per output: a lock file ``LOCK`` in the journal folder holds the holder's host, pid,
  MPI size, start time and batch job id. A second run is refused with one line naming the
  holder. A lock left by a dead run is taken over when the new run belongs to the same batch job
  (a requeued job) or runs on the same host where the holder's pid is gone; otherwise the message
  says to pass ``--break-lock`` once the holder is known to be dead.
"""

from __future__ import annotations

import datetime
import json
import os
import socket
from pathlib import Path
from typing import Any

from hpcontact.errors import InputError

LOCK_NAME = "LOCK"
JOB_VARIABLES = ("SLURM_JOB_ID", "PBS_JOBID", "LSB_JOBID", "JOB_ID")  # Slurm, PBS/Torque, LSF, SGE


class Refused(InputError):
    """The run may not go on (lock held, journals without a flag, stale journals, an unusable
    output): one line on stderr, exit status 2."""

    def __init__(self, message: str) -> None:
        super().__init__("output", message)
        self.args = (message,)

    def __str__(self) -> str:
        return str(self.args[0])


def usable_folder(folder: Path, what: str) -> None:
    """Create ``folder`` if its parent exists, then check a file can be written in it."""
    folder = Path(folder)
    if not folder.is_dir():
        if folder.exists():
            raise Refused(f"the {what} {folder} is not a folder")
        if not folder.parent.is_dir():
            raise Refused(f"the parent folder of the {what} {folder} does not exist: {folder.parent}")
        try:
            folder.mkdir()
        except FileExistsError:
            pass
        except OSError as exc:
            raise Refused(f"cannot create the {what} {folder}: {exc.strerror}") from None
    probe = folder / f".hpcontact-probe-{os.getpid()}"
    try:
        probe.write_bytes(b"probe")
        probe.unlink()
    except OSError as exc:
        raise Refused(f"cannot write in the {what} {folder}: {exc.strerror}") from None


def batch_job() -> str | None:
    """The batch system's job id, if any."""
    return next((os.environ[name] for name in JOB_VARIABLES if os.environ.get(name)), None)


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class RunLock:
    """The lock of one output (see the module docstring); ``acquire`` and ``release`` on rank 0."""

    def __init__(self, folder: Path, ranks: int) -> None:
        self.path = Path(folder) / LOCK_NAME
        self.info = {
            "host": socket.gethostname(), "pid": os.getpid(), "ranks": ranks, "job": batch_job(),
            "started": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        }
        self.held = False

    def holder(self) -> dict[str, Any] | None:
        """The current holder's record (an unreadable lock reads as an unknown holder)."""
        try:
            return json.loads(self.path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            return None
        except (OSError, ValueError):
            return {}

    def _takeover_reason(self, holder: dict[str, Any]) -> str | None:
        job = self.info["job"]
        if job is not None and holder.get("job") == job:
            return f"batch job {job} was requeued"
        if holder.get("host") == self.info["host"] and isinstance(holder.get("pid"), int) and not _pid_alive(holder["pid"]):
            return f"pid {holder['pid']} on this host is gone"
        return None

    def acquire(self, break_lock: bool = False) -> str | None:
        """Take the lock; the reason when a dead holder's lock was taken over. ``Refused`` when
        another run holds it."""
        text = json.dumps(self.info, sort_keys=True)
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            holder = self.holder()
            if holder is None:
                return self.acquire(break_lock)  # released in between
            reason = "--break-lock" if break_lock else self._takeover_reason(holder)
            if reason is None:
                raise Refused(
                    f"{self.path.parent} is in use by a run on {holder.get('host', '?')} (pid {holder.get('pid', '?')}, "
                    f"{holder.get('ranks', '?')} ranks, since {holder.get('started', '?')}"
                    f"{', job ' + str(holder['job']) if holder.get('job') else ''}); if that run is dead, pass "
                    f"--break-lock"
                ) from None
            tmp = self.path.with_name(f".{LOCK_NAME}.{os.getpid()}")
            tmp.write_text(text, encoding="utf-8")
            os.replace(tmp, self.path)
            self.held = True
            return f"took over the lock of {holder.get('host', '?')} pid {holder.get('pid', '?')} ({reason})"
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        self.held = True
        return None

    def release(self) -> None:
        """Remove the lock if this run still holds it."""
        if self.held:
            holder = self.holder()
            if holder and holder.get("pid") == self.info["pid"] and holder.get("host") == self.info["host"]:
                self.path.unlink(missing_ok=True)
            self.held = False
