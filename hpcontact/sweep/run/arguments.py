"""The command line of ``hpcontact run``: its arguments and exit statuses (kept apart from the
driver so that ``hpcontact --help`` and ``hpcontact solve`` do not import the sweep)."""

from __future__ import annotations

import argparse

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
    """The arguments of ``hpcontact run`` (shared by ``hpcontact.cli`` and ``main``)."""
    parser.add_argument("spec", help="sweep spec (TOML), e.g. jobs/demo.toml")
    parser.add_argument("--output", help="data set path (.nc), instead of the spec's [sweep].output")
    parser.add_argument(
        "--accuracy",
        type=float,
        metavar="REL",
        help="solve every scene to this estimated relative error (grid sequence and extrapolation, as "
        "hpcontact solve --accuracy), instead of the spec's [numerics] accuracy, n and n_across",
    )
    journals = parser.add_mutually_exclusive_group()
    journals.add_argument(
        "--resume", action="store_true", help="continue from the journals: reuse finished tasks, run failed ones again"
    )
    journals.add_argument("--restart", action="store_true", help="discard the journals of this output first")
    parser.add_argument(
        "--accept-stale",
        action="store_true",
        help="reuse journal entries computed by another version, git revision or numerics",
    )
    parser.add_argument(
        "--retry-crashed", action="store_true", help="run quarantined tasks (their process died in 2 runs) again"
    )
    parser.add_argument("--break-lock", action="store_true", help="take the output's lock from a run known to be dead")
    parser.add_argument(
        "--grace",
        type=float,
        default=None,
        metavar="SECONDS",
        help="after SIGTERM/SIGUSR1, let the task in flight finish this long (default 30)",
    )
    parser.add_argument(
        "--stall-timeout",
        type=float,
        default=None,
        metavar="SECONDS",
        help="end the run (resumably) when a rank shows no sign of life this long: stopped, frozen "
        "(default 900; 0: never)",
    )
    parser.add_argument(
        "--dry-run",
        action="store_true",
        help="print the estimated cost (core-seconds, peak memory, wall time at 1, 64, 1024 ranks), "
        "then the tasks with their indices (of more than 15: the first 10 and the last 5); compute nothing",
    )
    parser.add_argument("--json", action="store_true", help="with --dry-run: print one JSON object")
    parser.add_argument(
        "--list-all",
        action="store_true",
        help="with --dry-run: list every task (of more than 15, a dry run lists the first 10 and the last 5 "
        "and the number left out)",
    )
    parser.add_argument(
        "--costmodel",
        metavar="FILE",
        help="the cost model's calibration to estimate with (as $HPCONTACT_COSTMODEL; a file another node "
        "of the type wrote, e.g. ~/.cache/hpcontact/costmodel-*.json): used whoever made it, the estimate "
        "saying whose it is (default: the cache of this CPU model and core count, else the shipped prior "
        "scaled by a probe of this machine; --dry-run calibrates, 12-30 s)",
    )
    parser.add_argument(
        "--mem-per-rank",
        metavar="SIZE",
        help="memory one rank may use (4G, 512M, bytes): a run refuses a spec with a task that needs "
        "more, a dry run warns (default: SLURM_MEM_PER_CPU, or SLURM_MEM_PER_NODE / tasks per node, "
        "else the machine's memory per core)",
    )
    parser.epilog = EXIT_STATUS
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
