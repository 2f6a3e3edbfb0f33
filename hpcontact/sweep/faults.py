"""Fault injection for tests: ``HPCONTACT_FAULTS="INDEX:KIND[,INDEX:KIND...]"``.

The task at 0-based position INDEX of the sweep's deterministic task order (the order
``hpcontact run SPEC --dry-run`` lists: ``tasks.enumerate_tasks``) fails with KIND:

* ``raise``: the task raises ``RuntimeError`` (journaled as an error, retried by ``--resume``);
* ``kill``: the process sends itself SIGKILL as the task starts (a crash, see ``journal``);
* ``hang``: the task sleeps until a stop request abandons it (``signals``);
* ``slow``: the task sleeps ``SLOW_S`` seconds, then runs (work left for a test to strike in,
  however fast the machine: the journal entries a full disk cuts short);
* ``torn``: the task runs, then the process writes half of its journal line and SIGKILLs itself
  (a kill in the middle of a journal write).

Off unless the variable is set; a malformed value is refused (exit 2) before any task runs.

``HPCONTACT_SLOW_PHASE="PHASE:SECONDS"`` makes rank 0 sleep that long in a phase where the other
ranks wait for it in a collective: ``setup`` (after reading the journals, before the plan's
broadcast) or ``write`` (before writing the data set) — where a stop request must still end
the job (``signals``) — or ``done`` (after writing it), where a stop request changes nothing.

``HPCONTACT_DATA_SET_LIMIT=BYTES`` lets the data set's file grow to BYTES only while rank 0
writes it (``RLIMIT_FSIZE``, ``data_set_limit``): the netCDF library then fails as it does on a
full disk ("NetCDF: HDF error"), after every journal is written and closed.
"""

from __future__ import annotations

import contextlib
import os
import resource
import signal
import time
from collections.abc import Callable, Iterator

from hpcontact.errors import InputError

VARIABLE = "HPCONTACT_FAULTS"
KINDS = ("raise", "kill", "hang", "slow", "torn")
#: Seconds a ``slow`` task sleeps before it runs.
SLOW_S = 0.1
PHASE_VARIABLE = "HPCONTACT_SLOW_PHASE"
SLOW_PHASES = ("setup", "write", "done")


def parse_faults(text: str | None) -> dict[int, str]:
    """``{index: kind}`` from the variable's value (empty when unset)."""
    faults: dict[int, str] = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        index, _, kind = item.strip().partition(":")
        if not index.isdigit() or kind not in KINDS:
            raise InputError(VARIABLE, f"comma list of INDEX:KIND with KIND one of {', '.join(KINDS)}", text)
        faults[int(index)] = kind
    return faults


def faults_from_environment() -> dict[int, str]:
    """The faults ``$HPCONTACT_FAULTS`` asks for."""
    return parse_faults(os.environ.get(VARIABLE))


def slow_phase(phase: str) -> None:
    """Sleep in ``phase`` as ``$HPCONTACT_SLOW_PHASE`` asks (rank 0 only: its callers)."""
    text = os.environ.get(PHASE_VARIABLE)
    if not text:
        return
    name, _, seconds = text.partition(":")
    try:
        delay = float(seconds)
    except ValueError:
        delay = -1.0
    if name not in SLOW_PHASES or not delay >= 0.0:
        raise InputError(PHASE_VARIABLE, f"PHASE:SECONDS with PHASE one of {', '.join(SLOW_PHASES)}", text)
    if name == phase:
        time.sleep(delay)


def before_task(kind: str | None) -> None:
    """Inject a fault that strikes as the task starts (``raise``, ``kill``, ``hang``, ``slow``)."""
    if kind == "raise":
        raise RuntimeError(f"injected fault ({VARIABLE})")
    if kind == "kill":
        os.kill(os.getpid(), signal.SIGKILL)
    if kind == "hang":
        while True:
            time.sleep(3600.0)
    if kind == "slow":
        time.sleep(SLOW_S)


def tear(kind: str | None, line: bytes, write: Callable[[bytes], None]) -> None:
    """With ``torn``: write the first half of the journal ``line`` with ``write`` and SIGKILL."""
    if kind == "torn":
        write(line[: len(line) // 2])
        os.kill(os.getpid(), signal.SIGKILL)


LIMIT_VARIABLE = "HPCONTACT_DATA_SET_LIMIT"


@contextlib.contextmanager
def data_set_limit() -> Iterator[None]:
    """While the data set is written: the file-size limit ``$HPCONTACT_DATA_SET_LIMIT`` asks for
    (none when unset), SIGXFSZ ignored so that a write past it fails with EFBIG."""
    text = os.environ.get(LIMIT_VARIABLE)
    if not text:
        yield
        return
    if not text.isdigit():
        raise InputError(LIMIT_VARIABLE, "the bytes the data set's file may grow to", text)
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    limit = int(text) if hard == resource.RLIM_INFINITY else min(int(text), hard)
    handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, handler)
