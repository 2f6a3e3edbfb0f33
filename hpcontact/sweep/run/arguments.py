"""The command line of ``hpcontact run``: its arguments and exit statuses (kept apart from the
driver so that ``hpcontact --help`` and ``hpcontact solve`` do not import the sweep)."""

from __future__ import annotations

import argparse

from hpcontact.sweep.run.options import RUN_OPTIONS
from hpcontact.sweep.run.signals import STOPPED_STATUS

EXIT_OK, EXIT_UNEXPECTED, EXIT_REFUSED, EXIT_FAILED_TASKS, EXIT_STOPPED = 0, 1, 2, 3, STOPPED_STATUS
EXIT_STATUS = """exit status:
  0  every task ok, data set written (or already up to date: same spec and output, every task
     in the journals, the data set newer than them; nothing run, nothing written)
  1  anything unexpected (traceback on stderr), or a journal or the data set could not be
     written (disk full: the message names the file; journals intact, free space and --resume),
     or a rank showed no sign of life for --stall-timeout (journals intact, --resume)
  2  bad input or a refusal, before any task runs: bad spec, output or journal folder not
     writable, an output that is the spec, a mask or the journal folder (or lies in it), lock
     held by another run, journals without --resume/--restart, stale journals, a task whose
     estimated memory exceeds --mem-per-rank
  3  data set written, but some tasks failed (the summary names up to 5 with their messages)
  4  stopped by Ctrl-C (SIGINT), SIGTERM or SIGUSR1 to any rank, in any phase: journals
     intact, run again with --resume (a stop after the data set is written changes nothing)"""


def add_run_arguments(parser: argparse.ArgumentParser) -> None:
    """The arguments of ``hpcontact run`` (shared by ``hpcontact.cli`` and ``main``): the spec and
    every option of ``options.RUN_OPTIONS``, the options of one ``exclusive`` group mutually exclusive."""
    parser.add_argument("spec", help="sweep spec (TOML), e.g. jobs/demo.toml")
    groups: dict[str, argparse._MutuallyExclusiveGroup] = {}
    for option in RUN_OPTIONS:
        where: argparse.ArgumentParser | argparse._MutuallyExclusiveGroup = parser
        if option.exclusive is not None:
            if option.exclusive not in groups:
                groups[option.exclusive] = parser.add_mutually_exclusive_group()
            where = groups[option.exclusive]
        if option.switch:
            where.add_argument(option.flag, action="store_true", help=option.help)
        else:
            where.add_argument(option.flag, type=option.value, metavar=option.metavar, help=option.help)
    parser.epilog = EXIT_STATUS
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
