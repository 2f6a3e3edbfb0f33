"""The options of a run, declared once: each one's command-line flag, its Python keyword (how
``hpcontact.run_sweep`` spells it; None: the command line's alone), whether it is a switch, its
value's type and placeholder, and its help. ``arguments.add_run_arguments`` builds the argparse
options of ``hpcontact run`` from ``RUN_OPTIONS``; ``hpcontact.run_sweep`` takes the keywords
(``KEYWORDS``, checked by tests/test_api.py); a message that names an option carries it
(``errors.Message``, ``errors.InputError`` with the option as its field), and each front end
spells it: ``--resume`` on the command line, ``resume=True`` in Python (``errors.Option``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from hpcontact.errors import Option


class RunOption(Option):
    """One option of a run (module docstring): ``help`` its help, ``value`` converts a flag's
    text (None: text as given), ``metavar`` names it in the help, ``exclusive``: the options of
    one named group that cannot be given together."""

    help: str
    value: Callable[[str], Any] | None
    metavar: str | None
    exclusive: str | None

    def __new__(
        cls,
        flag: str,
        keyword: str | None,
        switch: bool,
        help: str,
        value: Callable[[str], Any] | None = None,
        metavar: str | None = None,
        exclusive: str | None = None,
    ) -> RunOption:
        option = super().__new__(cls, flag, keyword, switch)
        option.help, option.value, option.metavar, option.exclusive = help, value, metavar, exclusive
        return option

    def __getnewargs__(self) -> tuple[Any, ...]:  # type: ignore[override]
        return (*super().__getnewargs__(), self.help, self.value, self.metavar, self.exclusive)


OUTPUT = RunOption("--output", "output", False, "data set path (.nc), instead of the spec's [sweep].output")
ACCURACY = RunOption(
    "--accuracy",
    "accuracy",
    False,
    "solve every scene to this estimated relative error (grid sequence and extrapolation, as "
    "hpcontact solve --accuracy), instead of the spec's [numerics] accuracy, n and n_across",
    value=float,
    metavar="REL",
)
RESUME = RunOption(
    "--resume",
    "resume",
    True,
    "continue from the journals: reuse finished tasks, run failed ones again",
    exclusive="journals",
)
RESTART = RunOption("--restart", "restart", True, "discard the journals of this output first", exclusive="journals")
ACCEPT_STALE = RunOption(
    "--accept-stale",
    "accept_stale",
    True,
    "reuse journal entries computed by another version, git revision or numerics",
)
RETRY_CRASHED = RunOption(
    "--retry-crashed", "retry_crashed", True, "run quarantined tasks (their process died in 2 runs) again"
)
BREAK_LOCK = RunOption("--break-lock", "break_lock", True, "take the output's lock from a run known to be dead")
GRACE = RunOption(
    "--grace",
    None,
    False,
    "after SIGTERM/SIGUSR1, let the task in flight finish this long (default 30)",
    value=float,
    metavar="SECONDS",
)
STALL_TIMEOUT = RunOption(
    "--stall-timeout",
    None,
    False,
    "end the run (resumably) when a rank shows no sign of life this long: stopped, frozen (default 900; 0: never)",
    value=float,
    metavar="SECONDS",
)
DRY_RUN = RunOption(
    "--dry-run",
    None,
    True,
    "print the estimated cost (core-seconds, peak memory, wall time at 1, 64, 1024 ranks), "
    "then the tasks with their indices (of more than 15: the first 10 and the last 5); compute nothing",
)
JSON = RunOption("--json", None, True, "with --dry-run: print one JSON object")
LIST_ALL = RunOption(
    "--list-all",
    None,
    True,
    "with --dry-run: list every task (of more than 15, a dry run lists the first 10 and the last 5 "
    "and the number left out)",
)
COSTMODEL = RunOption(
    "--costmodel",
    None,
    False,
    "the cost model's calibration to estimate with (as $HPCONTACT_COSTMODEL; a file another node "
    "of the type wrote, e.g. ~/.cache/hpcontact/costmodel-*.json): used whoever made it, the estimate "
    "saying whose it is (default: the cache of this CPU model and core count, else the shipped prior "
    "scaled by a probe of this machine; --dry-run calibrates, 12-30 s)",
    metavar="FILE",
)
MEM_PER_RANK = RunOption(
    "--mem-per-rank",
    "mem_per_rank",
    False,
    "memory one rank may use (4G, 512M, bytes): a run refuses a spec with a task that needs "
    "more, a dry run warns (default: SLURM_MEM_PER_CPU, or SLURM_MEM_PER_NODE / tasks per node, "
    "else the machine's memory per core)",
    metavar="SIZE",
)

#: Every option of ``hpcontact run``, in the order of its help.
RUN_OPTIONS = (
    OUTPUT,
    ACCURACY,
    RESUME,
    RESTART,
    ACCEPT_STALE,
    RETRY_CRASHED,
    BREAK_LOCK,
    GRACE,
    STALL_TIMEOUT,
    DRY_RUN,
    JSON,
    LIST_ALL,
    COSTMODEL,
    MEM_PER_RANK,
)
#: The keywords of ``hpcontact.run_sweep`` that are options of a run.
KEYWORDS = tuple(o.keyword for o in RUN_OPTIONS if o.keyword is not None)
