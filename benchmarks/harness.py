"""What every benchmark shares: the results folder, fresh-process runs, timing, the machine line.

Scripts import it as a sibling (``import harness``: ``python benchmarks/X.py`` puts the script's
folder first on ``sys.path``; hpcontact is installed in the environment), so none edits
``sys.path``. It does not import hpcontact, so a child can import hpcontact from another source
tree (``env={"PYTHONPATH": tree}``). benchmarks/README.md describes each part; speed claims are
ratios against a baseline measured in the same run, never absolute times.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime
from importlib import metadata
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
THREAD_VARIABLES = (
    "HPCONTACT_BLAS_THREADS",
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
)
CLOCKS: dict[str, Callable[[], float]] = {"wall": time.perf_counter, "cpu": time.process_time}
CALL = "--harness-call"  # argv[1] of a child started by call_in_child
_KIB = 1 if sys.platform == "darwin" else 1024  # ru_maxrss: bytes on macOS, KiB on Linux


# --- results -------------------------------------------------------------------------------
def write_json(path: str | Path, data: Any, indent: int | None = 1) -> Path:
    """Write ``data`` as JSON to ``path`` atomically (folders made as needed); numpy scalars
    become floats."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(data, indent=indent, default=float) + "\n", encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def append_jsonl(path: str | Path, row: Mapping[str, Any]) -> None:
    """Append ``row`` as one JSON line to the cache ``path`` (folders made as needed)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", encoding="utf-8") as fh:
        fh.write(json.dumps(row, default=float) + "\n")


def read_jsonl(path: str | Path) -> list[dict[str, Any]]:
    """The rows of the JSON-lines file ``path`` ([] when it does not exist)."""
    path = Path(path)
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


# --- timing in this process ----------------------------------------------------------------
@dataclass(frozen=True)
class Timed:
    """One call's value, wall seconds and CPU seconds of this process."""

    value: Any
    wall_s: float
    cpu_s: float


def with_principal(row: Mapping[str, Any]) -> dict[str, Any]:
    """A cached grid's stiffness row with K_max and K_min (the principal values of its tangential
    entries, ``hpcontact.quantities.principal_stiffness``), which ``accuracy.extrapolate`` takes per
    grid for K_min/K_max: rows cached before it did get them here."""
    row = dict(row)
    if "K_max" not in row and all(k in row for k in ("K_xx", "K_xy", "K_yx", "K_yy")):
        import numpy as np

        from hpcontact.quantities import principal_stiffness

        k_max, k_min, _ = principal_stiffness(np.array([[row["K_xx"], row["K_xy"]], [row["K_yx"], row["K_yy"]]]))
        row.update(K_max=k_max, K_min=k_min)
    return row


def timed(function: Callable[[], Any]) -> Timed:
    """Call ``function()`` once; its value with the wall and CPU time it took."""
    wall, cpu = time.perf_counter(), time.process_time()
    value = function()
    return Timed(value, time.perf_counter() - wall, time.process_time() - cpu)


@dataclass(frozen=True)
class Timing:
    """Seconds of repeated calls (``times``) and the last call's value."""

    times: list[float]
    value: Any = None

    @property
    def best(self) -> float:
        return min(self.times)

    @property
    def median(self) -> float:
        return statistics.median(self.times)


def repeat_timing(
    function: Callable[[], Any],
    repeat: int = 3,
    *,
    warmup: bool = False,
    min_time: float = 0.0,
    max_calls: int = 200,
    clock: Callable[[], float] = time.perf_counter,
) -> Timing:
    """Time ``function()`` ``repeat`` times, and more until ``min_time`` seconds are spent (at most
    ``max_calls``); with ``warmup``, one untimed call first (plans made, caches filled)."""
    if warmup:
        function()
    times: list[float] = []
    value = None
    while len(times) < max(repeat, 1) or (sum(times) < min_time and len(times) < max_calls):
        start = clock()
        value = function()
        times.append(clock() - start)
    return Timing(times, value)


def peak_rss_mb() -> float:
    """Peak resident set of this process so far, MiB (``getrusage(RUSAGE_SELF).ru_maxrss``)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * _KIB / 2**20


# --- fresh processes -----------------------------------------------------------------------
def thread_environment(threads: int) -> dict[str, str]:
    """The variables that make BLAS, OpenMP and hpcontact use ``threads`` threads."""
    return {name: str(threads) for name in THREAD_VARIABLES}


@dataclass(frozen=True)
class Child:
    """A finished child process: exit status, output, wall seconds, CPU seconds (user + system
    of it and its descendants) and peak resident set in MiB (Linux may count the parent's
    resident set at the fork: an upper bound while the parent stays small)."""

    command: list[str]
    returncode: int
    stdout: str
    stderr: str
    wall_s: float
    cpu_s: float
    peak_rss_mb: float
    timed_out: float | None = None  # the timeout that killed it

    @property
    def result(self) -> Any:
        """The last stdout line that parses as a JSON object (None without one)."""
        for line in reversed(self.stdout.splitlines()):
            if line.startswith("{"):
                try:
                    return json.loads(line)
                except json.JSONDecodeError:
                    continue
        return None

    @property
    def error(self) -> str | None:
        """Why the child gave no result (None if it did)."""
        if self.timed_out is not None:
            return f"did not finish within {self.timed_out:g} s"
        if self.returncode != 0 or self.result is None:
            tail = (self.stderr.strip().splitlines() or ["no output"])[-1]
            return f"failed (exit {self.returncode}): {tail}"
        return None

    def or_error(self, spec: Mapping[str, Any]) -> dict[str, Any]:
        """The child's result, or ``spec`` with an ``error`` entry."""
        return {**spec, "error": self.error} if self.error else self.result


def run_child(
    command: Sequence[str],
    *,
    threads: int = 1,
    timeout: float | None = None,
    cwd: str | Path | None = None,
    env: Mapping[str, str] | None = None,
    check: bool = False,
) -> Child:
    """Run ``command`` to the end with ``threads`` in the thread variables (``env`` on top);
    with ``timeout`` it is killed after that many seconds; with ``check`` a failure raises
    ``RuntimeError`` with the last line of its stderr."""
    environment = {**os.environ, **thread_environment(threads), **(env or {})}
    killed: list[bool] = []
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        started = time.perf_counter()
        process = subprocess.Popen(list(command), stdout=out, stderr=err, cwd=cwd, env=environment)

        def kill() -> None:
            killed.append(True)
            process.kill()

        timer = threading.Timer(timeout, kill) if timeout else None
        if timer is not None:
            timer.start()
        try:
            _, status, usage = os.wait4(process.pid, 0)  # this child's own rusage, not all children's
        except BaseException:
            process.kill()
            process.wait()
            raise
        finally:
            if timer is not None:
                timer.cancel()
        process.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - started
        out.seek(0)
        err.seek(0)
        child = Child(
            list(command),
            process.returncode,
            out.read().decode(errors="replace"),
            err.read().decode(errors="replace"),
            wall,
            usage.ru_utime + usage.ru_stime,
            usage.ru_maxrss * _KIB / 2**20,
            timeout if killed else None,
        )
    if check and (child.returncode != 0 or child.timed_out is not None):
        raise RuntimeError(f"{' '.join(child.command[:4])} …: {child.error}")
    return child


def child_command(script: str | Path, function: str, *args: Any) -> list[str]:
    """The command line that runs ``function(*args)`` of ``script`` in a fresh interpreter
    (the script must end with ``harness.entry(main)``); its JSON value is the last stdout line."""
    return [sys.executable, str(Path(script).resolve()), CALL, function, json.dumps(list(args))]


def call_in_child(script: str | Path, function: str, *args: Any, **options: Any) -> Child:
    """``run_child(child_command(script, function, *args), **options)``."""
    return run_child(child_command(script, function, *args), **options)


def entry(main: Callable[[], int | None]) -> None:
    """A script's ``if __name__ == "__main__"`` hook: ``main()`` as the exit status, or in a child
    of ``call_in_child`` the named function of the script, its value printed as JSON."""
    if len(sys.argv) == 4 and sys.argv[1] == CALL:
        value = getattr(sys.modules["__main__"], sys.argv[2])(*json.loads(sys.argv[3]))
        print(json.dumps(value, default=float), flush=True)
        raise SystemExit(0)
    raise SystemExit(main())


def add_run_options(parser: argparse.ArgumentParser, timeout: float) -> None:
    """Options of the scripts that time fresh processes: per-run timeout, clock, JSON output."""
    parser.add_argument("--timeout", type=float, default=timeout, help=f"seconds per run (default {timeout:.0f})")
    parser.add_argument(
        "--clock",
        choices=sorted(CLOCKS),
        default="wall",
        help="wall: elapsed time (default); cpu: each run's process CPU time, robust on a loaded "
        "machine but meaningful with --threads 1 only",
    )
    parser.add_argument("--json", type=Path, help="also write every measurement to this JSON file")


# --- the machine ---------------------------------------------------------------------------
def _version(package: str) -> str:
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "absent"


def machine_line(threads: int | None = None) -> str:
    """Host, CPU, cores, load average, Python / numpy / pyfftw / hpcontact versions and the date:
    the first line of every report (``threads``: the benchmark's thread count, if it has one)."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            cpu = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), cpu)
    except OSError:
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    versions = ", ".join(f"{p} {_version(p)}" for p in ("numpy", "pyfftw", "hpcontact"))
    threads_text = "" if threads is None else f"; {threads} thread(s)"
    return (
        f"{platform.node()}: {cpu}, {os.cpu_count()} cores, load average {load:.1f}; Python "
        f"{platform.python_version()}, {versions}; {datetime.now().isoformat(timespec='minutes')}{threads_text}"
    )
