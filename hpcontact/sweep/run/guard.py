"""May this run use this output? Refusals made before any task runs (exit status 2).

* What the run writes may not eat what it reads, nor each other (``apart``, also in a dry run):
  the output may not be the spec, a mask file the spec names or the journal folder, nor lie in
  the journal folder; the journal folder may not be the spec or a mask file. Paths are compared
  with their symbolic links resolved, and existing ones by ``os.path.samefile`` too (hard
  links), so ``hpcontact run foo.nc`` on a TOML spec named foo.nc (default output: foo.nc) is
  refused, not answered by the data set replacing the spec.
* The output's folder and the journal folder must be writable (each is created when its parent
  exists; a missing grandparent is a typo, refused), so a run never fails at its end for want of
  a place to write; the output itself, where it exists, must be a file (a folder in its place
  is refused, not found when the data set is renamed into place at the end).
* One run per output: a lock file ``LOCK`` in the journal folder holds the holder's host, pid,
  MPI size, start time and batch job id. A second run is refused with one line naming the
  holder. A lock left by a dead run is taken over when the new run belongs to the same batch job
  (a requeued job) or runs on the same host where the holder's pid is gone; otherwise the message
  says to pass ``--break-lock`` once the holder is known to be dead.
* The lock appears complete or not at all: its record is written to a temporary file and synced
  (``fsync``) before a hard link gives it the name ``LOCK`` (exclusive: of two runs, one gets
  it), and the folder is synced after; a takeover renames the dead run's lock away first, so of
  two runs taking it over at once one gets it. A lock that cannot be read as a record (empty,
  zero-filled or garbage: left by a crash of an older hpcontact, which did not sync it, or
  damaged) is a dead run's lock, since a live run's lock is always complete. Its holder is
  then known only from the journals its run wrote (those at least as new as the lock; each
  journal's header names its host, pid and batch job): it is taken over when one of them names
  this run's batch job, or when all name this host and their pids are gone; otherwise (no such
  journal: the run died before its first task reached the disk) the refusal names the lock and
  ``--break-lock``.
"""

from __future__ import annotations

import datetime
import errno
import json
import os
import secrets
import socket
import tomllib
from pathlib import Path
from typing import Any

from hpcontact.errors import Front, InputError, Message, Option, rendered
from hpcontact.sweep.data.journal import JOB_VARIABLES, batch_job, journal_files, read_file, sync_folder
from hpcontact.sweep.run.options import BREAK_LOCK, OUTPUT
from hpcontact.sweep.space.axes import LABEL_AXES, PATH_FIELDS
from hpcontact.sweep.space.spec import default_output

__all__ = [
    "JOB_VARIABLES",
    "LOCK_NAME",
    "Refused",
    "RunLock",
    "apart",
    "batch_job",
    "usable_folder",
    "usable_names",
    "usable_output",
]

LOCK_NAME = "LOCK"
LOCK_BYTES = 4096  # a lock record is ~150 bytes: a larger file is not one
JOURNAL_SLACK_S = 2.0  # journals this much older than an unreadable lock still count as its run's


class Refused(InputError):
    """The run may not go on (lock held, journals without a flag, stale journals, an unusable
    output): one line on stderr, exit status 2. Its advice names options as a ``Message``
    (``worded``: as a front end spells them; ``str()``: the command line's words)."""

    def __init__(self, message: str | Message) -> None:
        super().__init__("output", message)
        self.args = (message,)

    def worded(self, front: Front) -> str:
        """The refusal as ``front`` words it."""
        return rendered(self.args[0], front)

    def for_front(self, front: Front) -> Refused:
        """The same refusal in ``front``'s words, as plain text."""
        return Refused(self.worded(front))

    def __str__(self) -> str:
        return self.worded(Front.COMMAND_LINE)


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


def usable_output(path: Path) -> None:
    """The output ``path`` may be written: its folder is usable (``usable_folder``) and
    ``path``, where it exists, is a file (not a folder or a device)."""
    path = Path(path)
    usable_folder(path.parent, "output folder")
    if path.exists() and not path.is_file():
        what = "a folder" if path.is_dir() else "not a regular file"
        raise Refused(
            Message(
                f"the output {path} is {what}, not a file: name another output ([sweep].output or ",
                OUTPUT,
                ") or move it away",
            )
        )


def _same(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name one file or folder: the same path once symbolic links are
    resolved, or (both existing) the same file (``os.path.samefile``: hard links, bind mounts)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def _inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` lies in ``folder``, at any depth (symbolic links resolved)."""
    return any(_same(parent, folder) for parent in Path(os.path.realpath(path)).parents)


def _inputs(spec: Any) -> list[tuple[str, Path]]:
    """What the run of ``spec`` reads, each with the spec key that names it: the spec file and
    every input file (``spec.PATH_FIELDS``: masks) of [scene] and of the label tables."""
    found = [("spec", Path(spec.path))] if Path(spec.path).is_file() else []  # not a dict's "<dict>"
    found += [(f"scene.{name}", Path(spec.fixed[name])) for name in sorted(PATH_FIELDS) if name in spec.fixed]
    for axis in spec.axes:
        if axis.name in LABEL_AXES:
            found += [
                (f"axes.{axis.name}[{i}].{name}", Path(fields[name]))
                for i, fields in enumerate(axis.fields)
                for name in sorted(PATH_FIELDS)
                if name in fields
            ]
    return found


def _named(spec: Any, quoted: bool = False) -> tuple[Message, str]:
    """The output and the journal folder of ``spec`` as a refusal names them: path (``quoted``:
    as Python shows a string, a NUL as ``\\x00``) and origin (the spec's text read again: made
    only for a refusal)."""
    try:
        sweep = tomllib.loads(spec.text).get("sweep", {})
    except (tomllib.TOMLDecodeError, AttributeError):
        sweep = {}
    output, journal = Path(spec.output), Path(spec.journal)
    shown_output, shown_journal = (repr(str(output)), repr(str(journal))) if quoted else (output, journal)
    if "output" not in sweep and output == default_output(spec.path):
        how = "the spec's name with .nc, beside it: set sweep.output or pass "
    else:
        how = "sweep.output or "
    origin = "sweep.journal" if "journal" in sweep else "the output's name + .journal"
    return Message(f"the output {shown_output} ({how}", OUTPUT, ")"), f"the journal folder {shown_journal} ({origin})"


#: What the run adds to the output's name: its temporary data set ``.NAME.tmp-PID``
#: (``netcdf.write``, a pid has at most 7 digits) and the default journal folder ``NAME.journal``.
NAME_EXTRA = len(".") + len(".tmp-") + 7


def _name_max(folder: Path) -> int:
    """The longest file name (bytes) the file system of ``folder`` (or its nearest existing
    parent) allows: ``PC_NAME_MAX``, 255 where it cannot be asked."""
    for place in (folder, *folder.parents):
        try:
            return int(os.pathconf(place, "PC_NAME_MAX"))
        except (OSError, ValueError):
            continue
    return 255


def usable_names(spec: Any) -> None:
    """``Refused`` naming the output (or journal folder) whose path the OS cannot take: a NUL
    character, or a component longer than the file system's ``PC_NAME_MAX`` (the output's last
    component with room for its temporary file, ``NAME_EXTRA``). The one check of these names,
    made before any other look at them (``apart``)."""
    for path, what in ((Path(spec.output), 0), (Path(spec.journal), 1)):
        if "\0" in str(path):
            raise Refused(_named(spec, quoted=True)[what] + " contains a NUL character: name a path without one")
        limit = _name_max(path.absolute().parent)
        for part in path.parts:
            extra = NAME_EXTRA if (what == 0 and part == path.name) else 0
            size = len(os.fsencode(part)) + extra
            if size > limit:
                room = f" ({extra} bytes kept for its temporary file)" if extra else ""
                raise Refused(
                    _named(spec)[what] + f" has a name component of {len(os.fsencode(part))} bytes, over the "
                    f"{limit - extra} this file system allows{room}: name a shorter path"
                )


def apart(spec: Any) -> None:
    """``Refused`` (one line naming both paths and where they come from) when what the run of
    ``spec`` writes would overwrite what it reads, or each other (module docstring); first, a
    name the OS cannot take (``usable_names``). Changes nothing and reads only file metadata: a
    run (``driver.prepare``) and a dry run alike."""
    usable_names(spec)
    output, journal = Path(spec.output), Path(spec.journal)
    if _same(output, journal):
        output_name, journal_name = _named(spec)
        raise Refused(output_name + f" is {journal_name}: name them apart")
    if _inside(output, journal):
        output_name, journal_name = _named(spec)
        raise Refused(output_name + f" lies in {journal_name}: name an output outside it")
    for field, path in _inputs(spec):
        read = f"the spec {path}" if field == "spec" else f"the input file {path} ({field})"
        if _same(output, path):
            raise Refused(_named(spec)[0] + f" is {read}: the data set would replace it; name another output")
        if _same(journal, path):
            raise Refused(f"{_named(spec)[1]} is {read}: name another journal folder (sweep.journal)")


def _read(path: Path) -> bytes | None:
    """The first bytes of the lock ``path`` (at most ``LOCK_BYTES`` + 1); None when it does not
    exist, b"" when it cannot be read."""
    try:
        with open(path, "rb") as fh:
            return fh.read(LOCK_BYTES + 1)
    except FileNotFoundError:
        return None
    except OSError:
        return b""


def _record(data: bytes | None) -> dict[str, Any] | None:
    """The lock record in ``data`` (``_read``): None for no lock, ``{}`` for an unreadable one."""
    if data is None:
        return None
    try:
        record = json.loads(data.decode("utf-8")) if len(data) <= LOCK_BYTES else None
    except (ValueError, RecursionError):
        record = None
    return record if _valid_holder(record) else {}


def _valid_holder(record: Any) -> bool:
    """Whether ``record`` reads as a lock record: a host name and a pid at least."""
    return (
        isinstance(record, dict)
        and isinstance(record.get("host"), str)
        and record["host"] != ""
        and isinstance(record.get("pid"), int)
        and not isinstance(record.get("pid"), bool)
    )


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
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "ranks": ranks,
            "job": batch_job(),
            "started": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        }
        self.held = False

    def holder(self) -> dict[str, Any] | None:
        """The current holder's record: None when there is no lock, ``{}`` when it cannot be
        read as a record (empty, zero-filled, garbage, not a file)."""
        return _record(_read(self.path))

    def _journal_evidence(self) -> str | None:
        """For an unreadable lock (module docstring): the takeover reason the journals of its
        run give, else None."""
        try:
            since = self.path.stat().st_mtime - JOURNAL_SLACK_S
        except OSError:
            return None
        headers = []
        for path in journal_files(self.path.parent):
            try:
                if path.stat().st_mtime >= since:
                    headers.append(read_file(path)[0])
            except OSError:
                continue
        headers = [h for h in headers if _valid_holder(h)]
        job = self.info["job"]
        if job is not None and any(h.get("job") == job for h in headers):
            return f"its run's journals name batch job {job}, which was requeued"
        if headers and all(h["host"] == self.info["host"] and not _pid_alive(h["pid"]) for h in headers):
            pids = ", ".join(sorted({str(h["pid"]) for h in headers}))
            return f"its run's journals name this host, where pid {pids} is gone"
        return None

    def _takeover_reason(self, holder: dict[str, Any]) -> str | None:
        job = self.info["job"]
        if job is not None and holder.get("job") == job:
            return f"batch job {job} was requeued"
        if (
            holder.get("host") == self.info["host"]
            and isinstance(holder.get("pid"), int)
            and not _pid_alive(holder["pid"])
        ):
            return f"pid {holder['pid']} on this host is gone"
        return None

    def acquire(self, break_lock: bool = False) -> Message | None:
        """Take the lock; the note when a dead holder's lock was taken over, naming why (with
        ``break_lock``: its option, as a ``Message``). ``Refused`` when another run holds it
        (module docstring)."""
        for _ in range(10):  # another run may release or take the lock in between: look again
            if self._create():
                self.held = True
                return None
            data = _read(self.path)
            holder = _record(data)
            if holder is None:
                continue  # released in between
            if holder:
                reason: str | Option | None = BREAK_LOCK if break_lock else self._takeover_reason(holder)
                whose = f"the lock of {holder['host']} pid {holder['pid']}"
            else:
                reason = BREAK_LOCK if break_lock else self._journal_evidence()
                whose = f"the unreadable lock {self.path}"
            if reason is None:
                raise Refused(self._refusal(holder))
            if self._take_over(data):
                self.held = True
                return Message(f"took over {whose} (", reason, ")")
        raise Refused(f"{self.path} keeps changing (other runs starting on this output?); try again")

    def _refusal(self, holder: dict[str, Any]) -> Message:
        if not holder:
            return Message(
                f"the lock {self.path} is unreadable (empty or damaged: left by a run that died before it "
                f"reached the disk?) and no journal of that run names this batch job, or this host with its "
                f"process gone; if no run is using {self.path.parent}, pass ",
                BREAK_LOCK,
            )
        return Message(
            f"{self.path.parent} is in use by a run on {holder['host']} (pid {holder['pid']}, "
            f"{holder.get('ranks', '?')} ranks, since {holder.get('started', '?')}"
            f"{', job ' + str(holder['job']) if holder.get('job') else ''}); if that run is dead, pass ",
            BREAK_LOCK,
        )

    def _temporary(self) -> Path:
        """This run's record in a new temporary file beside the lock, synced."""
        tmp = self.path.with_name(f".{LOCK_NAME}.{os.getpid()}.{secrets.token_hex(4)}")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        try:
            os.write(fd, json.dumps(self.info, sort_keys=True).encode("utf-8"))
            os.fsync(fd)
        except BaseException:
            os.close(fd)
            tmp.unlink(missing_ok=True)
            raise
        os.close(fd)
        return tmp

    def _create(self) -> bool:
        """Create the lock with this run's record, complete, if there is none; whether it did."""
        tmp = self._temporary()
        try:
            os.link(tmp, self.path)
        except FileExistsError:
            return False
        except OSError as exc:  # a file system without hard links: exclusive create, then sync
            if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV, errno.EMLINK):
                raise
            return self._create_in_place()
        finally:
            tmp.unlink(missing_ok=True)
        sync_folder(self.path.parent)
        return True

    def _create_in_place(self) -> bool:
        try:
            fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            return False
        try:
            os.write(fd, json.dumps(self.info, sort_keys=True).encode("utf-8"))
            os.fsync(fd)
        finally:
            os.close(fd)
        sync_folder(self.path.parent)
        return True

    def _take_over(self, judged: bytes | None) -> bool:
        """Move the dead run's lock (which read as ``judged``) away, then create this run's
        (``_create``); False when another run changed the lock in between (it is put back) or
        created one first."""
        stale = self.path.with_name(f".{LOCK_NAME}.stale.{os.getpid()}.{secrets.token_hex(4)}")
        try:
            os.rename(self.path, stale)
        except FileNotFoundError:
            return False
        if _read(stale) != judged:  # another run took it over in between: put its lock back
            try:
                os.link(stale, self.path)
            except OSError:
                pass
            stale.unlink(missing_ok=True)
            return False
        stale.unlink(missing_ok=True)
        return self._create()

    def release(self) -> None:
        """Remove the lock if this run still holds it."""
        if self.held:
            holder = self.holder()
            if holder and holder.get("pid") == self.info["pid"] and holder.get("host") == self.info["host"]:
                self.path.unlink(missing_ok=True)
            self.held = False
