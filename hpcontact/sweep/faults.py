"""Fault injection for tests: ``HPCONTACT_FAULTS="INDEX:KIND[,INDEX:KIND...]"``.

The task at 0-based position INDEX of the sweep's deterministic task order (the order
``hpcontact run SPEC --dry-run`` lists: ``tasks.enumerate_tasks``) fails with KIND:

* ``raise``: the task raises ``RuntimeError`` (journaled as an error, retried by ``--resume``);
* ``kill``: the process sends itself SIGKILL as the task starts (a crash, see ``journal``);
* ``hang``: the task sleeps until a stop request abandons it (``signals``);
* ``torn``: the task runs, then the process writes half of its journal line and SIGKILLs itself
  (a kill in the middle of a journal write).

Off unless the variable is set; a malformed value is refused (exit 2) before any task runs.
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable

from hpcontact.errors import InputError

VARIABLE = "HPCONTACT_FAULTS"
KINDS = ("raise", "kill", "hang", "torn")


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


def before_task(kind: str | None) -> None:
    """Inject a fault that strikes as the task starts (``raise``, ``kill``, ``hang``)."""
    if kind == "raise":
        raise RuntimeError(f"injected fault ({VARIABLE})")
    if kind == "kill":
        os.kill(os.getpid(), signal.SIGKILL)
    if kind == "hang":
        while True:
            time.sleep(3600.0)


def tear(kind: str | None, line: bytes, write: Callable[[bytes], None]) -> None:
    """With ``torn``: write the first half of the journal ``line`` with ``write`` and SIGKILL."""
    if kind == "torn":
        write(line[: len(line) // 2])
        os.kill(os.getpid(), signal.SIGKILL)
