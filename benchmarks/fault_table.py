"""The fault table of issue 43, re-run: every fault of its eight points, one row per case.

    python benchmarks/fault_table.py [--only TEXT ...] [--json FILE]

Each case runs in a fresh temporary folder and in fresh processes (``harness.run_child``) that
import hpcontact from the checkout this script sits in (``PYTHONPATH`` = its root, so a clean
clone tests its own code even with another checkout installed in the environment; the first
line printed names the package file imported). ``HPCONTACT_MPI=0``: one process, no launcher.
Real solves use grids of n <= 32; the adaptive cases of point 8 solve with Mindlin's closed form
(``tests/sweep/run/mindlin_map.py``, the run tests' stand-in).

Printed per case: its point of the issue, the case, what is expected (a one-line refusal with
exit status 2, data identical to an uninterrupted run in every variable but the wall times, a
figure, ...), what was observed, the wall and CPU seconds and the peak resident MiB of the
process that met the fault (``ru_maxrss`` of that child; the interpreter's start and imports
included), and PASS or FAIL. A refusal passes when it is one line on stderr, exit status 2, no
traceback, and nothing was written that it should not; the memory refusals of point 2 also need
<= 2 CPU seconds and <= 200 MB where the issue's "Done when" asks it (``solve`` and ``run_sweep``;
it says 2 s: CPU seconds here, as wall seconds on a machine shared by other work measure the
others too). The machine line (load included)
comes first: the seconds are this machine's under that load. Exit status 1 when a case fails.
``--only 2 6`` runs the cases of points 2 and 6, ``--only polar`` those whose name says polar.
"""

from __future__ import annotations

import argparse
import atexit
import functools
import os
import shutil
import sys
import tempfile
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import harness

ROOT = harness.ROOT
POSTPROCESS = ROOT / "postprocess"
STAND_IN = ROOT / "tests" / "sweep" / "run"  # mindlin_map.py: Mindlin's closed form as a task function
ENV = {
    "PYTHONPATH": os.pathsep.join([str(ROOT), str(STAND_IN)]),
    "HPCONTACT_MPI": "0",
    "MPLBACKEND": "Agg",
}
STUDY_RUNNER = "hpcontact.sweep.accuracy_study.cold_solve"
MEMORY_SECONDS, MEMORY_MB = 2.0, 200.0  # issue 43 "Done when": a memory refusal within these
TIMINGS = ("wall_time_s",)  # the variables two runs of the same tasks may differ in
#: scripts of postprocess/ that draw a data set (DATASET OUTDIR); the others solve their own scenes
DATASET_SCRIPTS = (
    "accuracy_cost.py",
    "adaptive_points.py",
    "anisotropy_map.py",
    "crystal_friction_map.py",
    "orientation_map.py",
    "polar.py",
    "slip_stiffness.py",
    "tembleque2011_friction.py",
    "tensor_components.py",
)
TWO_TASKS = '[scene]\nquantities = ["tangential"]\nshape = "circle"\n[numerics]\ntol = 1e-8\n[axes]\nn = [8, 16]\n'
ONE_TASK = '[scene]\nshape = "circle"\nquantities = ["tangential"]\n[numerics]\nn = 16\n[axes]\nnu = [0.1, 0.2]\n'
#: a tangential sweep without a nu axis (nu fixed by the scene), a shape label with a '/'
FIGURE_SWEEP = """[scene]
quantities = ["tangential"]
[numerics]
n = 16
[axes]
shape = ["ellipse", { label = "a/b", shape = "rectangle" }]
aspect = [1.0, 0.5, 0.25]
angle = [0.0, 45.0, 90.0]
"""
#: a 1-D adaptive map over b/a (n = 16)
FIGURE_MAP = """[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
n = 16
[axes]
aspect = { logspace = [0, -1, 5] }
[adaptive]
tolerance = 1e-2
"""


@dataclass
class Row:
    """One case's line of the table."""

    item: str
    case: str
    expected: str
    observed: str
    wall_s: float
    cpu_s: float
    peak_mb: float
    passed: bool


@dataclass
class Case:
    """A fault of point ``item``: ``run(folder)`` meets it in the empty ``folder`` and returns
    (what was observed, whether it is what was ``expected``, the child that met the fault)."""

    item: str
    case: str
    expected: str
    run: Callable[[Path], tuple[str, bool, harness.Child]]


# --- running children -------------------------------------------------------------------------------
def child(command: Sequence[str], cwd: Path, timeout: float) -> harness.Child:
    return harness.run_child(list(command), cwd=cwd, env=ENV, timeout=timeout)


def hpcontact(cwd: Path, *args: object, timeout: float = 120.0) -> harness.Child:
    """``python -m hpcontact ARGS`` in ``cwd``."""
    return child([sys.executable, "-m", "hpcontact", *map(str, args)], cwd, timeout)


def study(cwd: Path, *args: object, timeout: float = 120.0) -> harness.Child:
    """``python -m hpcontact.sweep.accuracy_study ARGS`` in ``cwd``."""
    return child([sys.executable, "-m", "hpcontact.sweep.accuracy_study", *map(str, args)], cwd, timeout)


def python(cwd: Path, body: str, timeout: float = 120.0) -> harness.Child:
    """``body`` in a fresh interpreter after ``import hpcontact``; an ``InputError`` it raises
    ends the process as the command line does (its message as one line on stderr, exit 2), any
    other exception with its traceback (exit 1)."""
    code = (
        "import io, sys\nimport hpcontact\ntry:\n"
        + textwrap.indent(textwrap.dedent(body).strip() + "\n", "    ")
        + "except hpcontact.InputError as error:\n"
        + "    print(f'InputError {error.field}: {error}', file=sys.stderr)\n"
        + "    sys.exit(2)\n"
    )
    return child([sys.executable, "-c", code], cwd, timeout)


def script(cwd: Path, name: str, *args: object, timeout: float = 120.0) -> harness.Child:
    """``python postprocess/NAME ARGS``."""
    return child([sys.executable, str(POSTPROCESS / name), *map(str, args)], cwd, timeout)


def must(done: harness.Child) -> harness.Child:
    """``done``, which prepares a case: a failure there is no observation but an error of the table."""
    if done.returncode != 0 or done.timed_out is not None:
        words = " ".join(word.splitlines()[0][:40] for word in done.command[1:4] if word.strip())
        raise RuntimeError(f"{words} …: {done.error}")
    return done


# --- what was observed --------------------------------------------------------------------------------
def said(done: harness.Child) -> str:
    """Exit status and the first line of stderr (how many lines, a traceback named)."""
    if done.timed_out is not None:
        return f"killed after {done.timed_out:.0f} s"
    lines = done.stderr.strip().splitlines()
    if "Traceback" in done.stderr:
        return f"exit {done.returncode}, traceback: {lines[-1][:90] if lines else ''}"
    if not lines:
        return f"exit {done.returncode}"
    first = lines[0][:110] + ("…" if len(lines[0]) > 110 else "")
    return f"exit {done.returncode}: {first}" + (f" (+{len(lines) - 1} lines)" if len(lines) > 1 else "")


def one_line(done: harness.Child, *says: str) -> bool:
    """Exit 2 and one line on stderr, no traceback, saying each of ``says``."""
    lines = done.stderr.strip().splitlines()
    return (
        done.timed_out is None
        and done.returncode == 2
        and len(lines) == 1
        and "Traceback" not in done.stderr
        and all(s in lines[0] for s in says)
    )


def refusal(done: harness.Child, *says: str, intact: bool = True) -> tuple[str, bool, harness.Child]:
    """A case that passes on a one-line refusal (``one_line``) with ``intact`` inputs."""
    return said(done) + ("" if intact else "; an input was changed"), one_line(done, *says) and intact, done


def bounded(result: tuple[str, bool, harness.Child], start: harness.Child) -> tuple[str, bool, harness.Child]:
    """``result`` of a memory refusal, passing only within ``MEMORY_SECONDS`` and ``MEMORY_MB``;
    the CPU seconds and peak of ``start`` (the same program started with nothing to do: the
    interpreter and its imports) are named beside it, the baseline measured in the same run."""
    observed, passed, done = result
    within = done.cpu_s <= MEMORY_SECONDS and done.peak_rss_mb <= MEMORY_MB
    observed += "" if within else f"; over {MEMORY_SECONDS:g} CPU s or {MEMORY_MB:g} MB"
    return observed + f"; its start alone {start.cpu_s:.2f} CPU s, {start.peak_rss_mb:.0f} MB", passed and within, done


def differing(a: Path, b: Path, cwd: Path) -> list[str]:
    """The variables and coordinates of data sets ``a`` and ``b`` that differ (but ``TIMINGS``),
    compared exactly (NaN equal to NaN) in a child."""
    done = must(
        python(
            cwd,
            f"""
            import xarray as xr
            with hpcontact.open_dataset({str(a)!r}) as x, hpcontact.open_dataset({str(b)!r}) as y:
                x, y = x.drop_vars({TIMINGS!r}, errors="ignore"), y.drop_vars({TIMINGS!r}, errors="ignore")
                names = sorted(set(x.variables) | set(y.variables))
                print(" ".join(n for n in names if n not in x or n not in y or not x[n].identical(y[n])) or "-")
            """,
        )
    )
    return [n for n in done.stdout.split() if n != "-"]


def figures(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.glob("*.png")) if folder.is_dir() else []


# --- point 1: no result reused across runners ------------------------------------------------------------
def run_resumed_on_study(folder: Path):
    (folder / "st.toml").write_text(TWO_TASKS)
    must(study(folder, "st.toml"))
    done = hpcontact(folder, "run", "st.toml", "--output", "st.study.nc", "--resume")
    (folder / "fresh").mkdir()
    (folder / "fresh" / "st.toml").write_text(TWO_TASKS)
    must(hpcontact(folder / "fresh", "run", "st.toml"))
    differ = differing(folder / "st.study.nc", folder / "fresh" / "st.nc", folder)
    says = f"2 journal entries were computed by {STUDY_RUNNER}, not reused" in done.stdout
    observed = f"exit {done.returncode}, {'says' if says else 'does not say'} not reused; differs from fresh: {differ or 'nothing'}"
    return observed, done.returncode == 0 and says and not differ, done


def study_resumed_on_run(folder: Path):
    (folder / "st.toml").write_text(TWO_TASKS)
    must(hpcontact(folder, "run", "st.toml"))
    done = study(folder, "st.toml", "--output", "st.nc", "--resume")
    ran = "2 tasks, 2 to run, " in done.stdout and "not reused" in done.stdout
    (folder / "fresh").mkdir()
    (folder / "fresh" / "st.toml").write_text(TWO_TASKS)
    must(study(folder / "fresh", "st.toml"))
    differ = differing(folder / "st.nc", folder / "fresh" / "st.study.nc", folder)
    observed = f"exit {done.returncode}, {'all 2 run again' if ran else 'journal entries reused'}; differs from fresh: {differ or 'nothing'}"
    return observed, done.returncode == 0 and ran and not differ, done


# --- point 2: memory checked before it is spent ----------------------------------------------------------------
def solve_over_memory(n: int, *memory: str):
    def run(folder: Path):
        done = hpcontact(folder, "solve", "--shape", "rectangle", "--aspect", 1, "--n", n, *memory)
        return bounded(
            refusal(done, "estimated peak memory", "over the limit"), must(hpcontact(folder, "solve", "--help"))
        )

    return run


def run_sweep_over_memory(folder: Path):
    spec = {"scene": {"shape": "rectangle", "aspect": 1.0}, "numerics": {"n": 8192}, "axes": {"nu": [0.3]}}
    done = python(
        folder,
        f"""
        spec = {spec!r}
        spec["sweep"] = {{"output": "huge.nc"}}
        hpcontact.run_sweep(spec, task_function=lambda params: sys.exit("a task started"), stream=io.StringIO())
        """,
    )
    start = must(python(folder, "pass"))  # the interpreter and hpcontact's import
    return bounded(refusal(done, "mem_per_rank", intact=not (folder / "huge.nc").exists()), start)


def run_over_memory(folder: Path):
    (folder / "huge.toml").write_text(
        '[scene]\nshape = "rectangle"\naspect = 1.0\n[numerics]\nn = 8192\n[axes]\nnu = [0.3]\n'
    )
    return refusal(hpcontact(folder, "run", "huge.toml"), "memory", intact=not (folder / "huge.nc").exists())


# --- point 3: point counts from the description ----------------------------------------------------------------
def run_sweep_points(axis: str):
    def run(folder: Path):
        done = python(
            folder,
            f"""
            spec = {{"scene": {{"shape": "circle"}}, "numerics": {{"n": 8}}, "axes": {{"nu": {axis}}}, "sweep": {{"output": "big.nc"}}}}
            hpcontact.run_sweep(spec, task_function=lambda params: sys.exit("a task started"), stream=io.StringIO())
            """,
        )
        return refusal(done, "axes", intact=not (folder / "big.nc").exists())

    return run


def run_file_points(folder: Path):
    (folder / "big.toml").write_text(
        '[scene]\nshape = "circle"\n[numerics]\nn = 8\n[axes]\nnu = { linspace = [0, 0.5, 10000000] }\n'
    )
    return refusal(hpcontact(folder, "run", "big.toml"), "axes", intact=not (folder / "big.nc").exists())


# --- points 4 and 5: outputs apart from inputs -------------------------------------------------------------------
def journal_is_output(folder: Path):
    (folder / "s.toml").write_text('[sweep]\noutput = "out.nc"\njournal = "out.nc"\n' + ONE_TASK)
    done = hpcontact(folder, "run", "s.toml")
    return refusal(done, "out.nc", "journal folder", intact=not (folder / "out.nc").exists())


def spec_is_output(folder: Path):
    (folder / "foo.nc").write_text(ONE_TASK)
    done = hpcontact(folder, "run", "foo.nc")
    return refusal(done, "is the spec", intact=(folder / "foo.nc").read_text() == ONE_TASK)


# --- point 6: figure scripts ----------------------------------------------------------------------------------------
@functools.cache
def made(spec: str) -> Path:
    """The data set of a real sweep of ``spec`` (``FIGURE_SWEEP`` or ``FIGURE_MAP``): run once
    per table, in a folder removed when the table ends."""
    folder = Path(tempfile.mkdtemp(prefix="fault_table_made_"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    (folder / "made.toml").write_text(spec)
    must(hpcontact(folder, "run", "made.toml"))
    return folder / "made.nc"


def figure_sweep(folder: Path, spec: str = FIGURE_SWEEP) -> Path:
    """``made(spec)`` copied into ``folder``."""
    return Path(shutil.copyfile(made(spec), folder / "sweep.nc"))


def force(name: str) -> list[str]:
    """``--force`` for a script that keeps a stamp (it would skip an up-to-date drawing), else nothing."""
    return ["--force"] if "freshness" in (POSTPROCESS / name).read_text(encoding="utf-8") else []


def unreadable(name: str, kind: str):
    def run(folder: Path):
        path = folder / f"{kind}.nc"
        if kind == "damaged":
            path.write_bytes(b"\x89HDF\r\n\x1a\n" + bytes(range(256)) * 8)  # an HDF5 signature, then noise
        done = script(folder, name, path, folder / "fig", *force(name))
        return refusal(done, str(path), intact=not figures(folder / "fig"))

    return run


def unsuitable(name: str):
    """``name`` on a tangential sweep that is not the kind it draws (or is: then a figure)."""

    def run(folder: Path):
        data = figure_sweep(folder)
        done = script(folder, name, data, folder / "fig", *force(name))
        drawn = done.returncode == 0 and figures(folder / "fig") and not done.stderr.strip()
        if drawn:
            return f"exit 0, {len(figures(folder / 'fig'))} figure(s)", True, done
        return refusal(done, str(data), intact=not figures(folder / "fig"))

    return run


def one_dimensional_adaptive_map(folder: Path):
    done = script(folder, "adaptive_points.py", figure_sweep(folder, FIGURE_MAP), folder / "fig", "--force")
    return said(done) + f", figures {figures(folder / 'fig')}", done.returncode == 0 and figures(folder / "fig"), done


def drawn(name: str, *args: str):
    """``name`` on the figure sweep draws figures (exit 0)."""

    def run(folder: Path):
        data = figure_sweep(folder)
        done = script(folder, name, data, folder / "fig", "--force", *args)
        made = figures(folder / "fig")
        return said(done) + f", figures {made}", done.returncode == 0 and bool(made), done

    return run


def stamp(kind: str):
    """anisotropy_map.py with a stamp that is a deep JSON array or a folder, run without
    --force: it draws (an unreadable stamp is no stamp) or refuses in one line."""

    def run(folder: Path):
        data = figure_sweep(folder)
        path = folder / "fig" / ".anisotropy_map.stamp.json"
        path.parent.mkdir()
        if kind == "folder":
            path.mkdir()
        else:
            path.write_text("[" * 100_000 + "]" * 100_000)
        done = script(folder, "anisotropy_map.py", data, folder / "fig")
        made = figures(folder / "fig")
        if done.returncode == 0 and made:
            return f"exit 0, figures {made}", True, done
        return refusal(done, "stamp")

    return run


def all_nan(name: str, spec: str = FIGURE_SWEEP):
    def run(folder: Path):
        data = figure_sweep(folder, spec)
        must(
            python(
                folder,
                f"""
                import numpy as np
                with hpcontact.open_dataset({str(data)!r}) as ds:
                    ds = ds.load()
                for name in ds.data_vars:
                    if name.startswith(("K_", "normalized")):
                        ds[name] = ds[name] * np.nan
                ds.to_netcdf("nan.nc")
                """,
            )
        )
        done = script(folder, name, folder / "nan.nc", folder / "fig", "--force")
        return refusal(done, "no finite value", intact=not figures(folder / "fig"))

    return run


def read_only_folder(folder: Path):
    """A figure folder the process cannot write: a folder made read-only, or as root (whom
    permissions do not stop) /sys/fs, an existing folder no file can be made in."""
    data = figure_sweep(folder)
    if os.geteuid() == 0:
        target = Path("/sys/fs")
    else:
        target = folder / "ro"
        target.mkdir(mode=0o555)
    return refusal(script(folder, "polar.py", data, target, "--force"), str(target))


# --- point 7: the Python API --------------------------------------------------------------------------------
def api(call: str, *says: str, setup: str = ""):
    def run(folder: Path):
        return refusal(python(folder, setup + "\n" + call), *says)

    return run


DEEP = "spec = {}\ninner = spec\nfor _ in range(5000):\n    inner['x'] = {}\n    inner = inner['x']\n"
SELF = "spec = {'scene': {}}\nspec['scene']['self'] = spec\n"
SPEC = "spec = {'scene': {'shape': 'circle'}, 'numerics': {'n': 8}, 'axes': {'nu': [0.1]}}\n"


# --- point 8: bookkeeping ----------------------------------------------------------------------------------------
def contributors(folder: Path):
    """A coarse map resumed after a fine one: the contributors count the data set's solves."""
    body = """
        import json, xarray as xr
        from mindlin_map import MAP, mindlin
        open("map.toml", "w").write(MAP)
        hpcontact.run_sweep("map.toml", output="map.nc", task_function=mindlin, stream=io.StringIO())
        open("map.toml", "w").write(MAP.replace("tolerance = 1e-3", "tolerance = 0.5\\nchecks = 0"))
        hpcontact.run_sweep("map.toml", output="map.nc", resume=True, task_function=mindlin, stream=io.StringIO())
        with xr.open_dataset("map.nc") as ds:
            counted = sum(item["tasks"] for item in json.loads(ds.attrs["sweep_contributors"]))
            print(counted, ds.attrs["sweep_solves"], int(ds["solved"].sum()))
    """
    done = python(folder, body)
    if done.returncode != 0:
        return said(done), False, done
    counted, solves, solved = map(int, done.stdout.split()[-3:])
    return f"contributors {counted}, solves {solves}, solved {solved}", counted == solves == solved, done


def rounds_from_journals(folder: Path):
    """Killed in adaptive round 2 after 28 solves, resumed: each round's line counts its own
    tasks from journals (25, 3), not every round's."""
    body = """
        import re
        from hpcontact.sweep.run.records import Options
        from mindlin_map import MAP, mindlin
        open("map.toml", "w").write(MAP)
        calls, kill = [], [True]
        def dies(params):  # one task function for both runs: one runner, its entries reused
            if kill[0] and len(calls) == 28:
                raise SystemExit("killed")
            calls.append(params)
            return mindlin(params)
        try:
            hpcontact.run_sweep("map.toml", output="map.nc", task_function=dies, stream=io.StringIO())
        except SystemExit:
            kill[0] = False
        stream = io.StringIO()
        hpcontact.run_sweep("map.toml", output="map.nc", resume=True, task_function=dies, stream=stream)
        print(" ".join(j or "0" for _, j in re.findall(r"tasks, (\\d+) to run(?: \\((\\d+) from journals\\))?", stream.getvalue())))
    """
    done = python(folder, body)
    if done.returncode != 0:
        return said(done), False, done
    journaled = [int(j) for j in done.stdout.split()]
    return f"from journals per round {journaled}", journaled[:2] == [25, 3] and sum(journaled) == 28, done


def stalled_rank(folder: Path):
    """Rank 1 stalls (no heartbeat) twice in two sessions: recorded as stalled, so its task is
    no crash suspect; a start left by a rank that died still is."""
    body = """
        import time
        from pathlib import Path
        from hpcontact.sweep.data.journal import Journal, read_history
        from hpcontact.sweep.run.signals import ALIVE_PREFIX, POLL_S, STOP_NAME, StopControl
        here = Path(".")
        for session in ["20250101T000000Z-1-aaaaaa", "20250101T010000Z-2-bbbbbb"]:
            for left in [here / STOP_NAME, *here.glob(ALIVE_PREFIX + "*")]:
                left.unlink(missing_ok=True)
            with Journal(here / f"rank00001-{session}.jsonl", 1, {"session": session}) as journal:
                journal.started("stuck")
            stop = StopControl(stall_s=4 * POLL_S)
            stop.watch(here, rank=0, ranks=2, session=session)
            deadline = time.monotonic() + 60.0
            while stop.reason is None and time.monotonic() < deadline:
                time.sleep(POLL_S)
            stop.close()
            print("stall:", stop.reason is not None and "made no progress" in stop.reason)
        history = read_history(here)
        print("suspects", len(history.suspects()), "crashed", len(history.crashed()))
        with Journal(here / "rank00001-20250101T020000Z-3-cccccc.jsonl", 1, {"session": "x"}) as journal:
            journal.started("stuck")
        print("died", len(read_history(here).suspects().get("stuck", [])))
    """
    done = python(folder, body)
    text = " ".join(done.stdout.split())
    expected = "stall: True stall: True suspects 0 crashed 0 died 1"
    return text or said(done), done.returncode == 0 and text == expected, done


# --- the table ---------------------------------------------------------------------------------------------------
REFUSE = "one-line refusal, exit 2"


def cases() -> list[Case]:
    table = [
        Case("1", "hpcontact run --resume on the study's output", "not reused; data = fresh run", run_resumed_on_study),
        Case(
            "1",
            "accuracy_study --resume on the run's output",
            "all run again; data = fresh study",
            study_resumed_on_run,
        ),
        Case(
            "2", "solve --n 4096 --memory 2G", f"{REFUSE}, ≤2 CPU s, ≤200 MB", solve_over_memory(4096, "--memory", "2G")
        ),
        Case("2", "solve --n 8192 (this machine's memory)", f"{REFUSE}, ≤2 CPU s, ≤200 MB", solve_over_memory(8192)),
        Case("2", "run_sweep n 8192", f"InputError {REFUSE}, ≤2 CPU s, ≤200 MB", run_sweep_over_memory),
        Case("2", "hpcontact run, n 8192", REFUSE, run_over_memory),
        Case(
            "3",
            "run_sweep 10^7-point linspace",
            f"InputError {REFUSE}",
            run_sweep_points("{'linspace': [0, 0.5, 10**7]}"),
        ),
        Case(
            "3",
            "run_sweep dict axis of 2·10^7 listed values",
            f"InputError {REFUSE}",
            run_sweep_points("[0.25] * (2 * 10**7)"),
        ),
        Case("3", "hpcontact run, 10^7-point linspace", REFUSE, run_file_points),
        Case("4", "journal folder = output", f"{REFUSE}, nothing written", journal_is_output),
        Case("5", "hpcontact run foo.nc, a TOML spec", f"{REFUSE}, spec unchanged", spec_is_output),
        Case("6", "adaptive_points.py, 1-D adaptive map", "a figure, exit 0", one_dimensional_adaptive_map),
        Case("6", "anisotropy_map.py, no nu axis", "figures, exit 0", drawn("anisotropy_map.py")),
        Case("6", "tensor_components.py, '/' in a shape label", "figures, exit 0", drawn("tensor_components.py")),
        Case("6", "anisotropy_map.py, stamp a deep JSON array", "figures (or refusal)", stamp("array")),
        Case("6", "anisotropy_map.py, stamp a folder", "figures (or refusal)", stamp("folder")),
        Case("6", "polar.py, read-only figure folder", REFUSE, read_only_folder),
    ]
    for name in ("anisotropy_map.py", "polar.py", "tensor_components.py"):
        table.append(Case("6", f"{name}, all-NaN data", f"{REFUSE}, no figure", all_nan(name)))
    table.append(
        Case("6", "adaptive_points.py, all-NaN map", f"{REFUSE}, no figure", all_nan("adaptive_points.py", FIGURE_MAP))
    )
    for name in DATASET_SCRIPTS:
        for kind in ("missing", "damaged"):
            table.append(Case("6", f"{name}, {kind} .nc", f"{REFUSE}, no figure", unreadable(name, kind)))
        table.append(Case("6", f"{name}, a tangential sweep", "figures or one-line refusal", unsuitable(name)))
    run_sweep = "hpcontact.run_sweep(spec, stream=io.StringIO())"
    table += [
        Case("7", "run_sweep(spec=[...])", f"InputError {REFUSE}", api("spec = [1, 2]\n" + run_sweep, "spec")),
        Case("7", "run_sweep(spec=7)", f"InputError {REFUSE}", api("spec = 7\n" + run_sweep, "spec")),
        Case("7", "run_sweep(spec=None)", f"InputError {REFUSE}", api("spec = None\n" + run_sweep, "spec")),
        Case("7", "run_sweep, 5 000-deep dict", f"InputError {REFUSE}", api(DEEP + run_sweep)),
        Case("7", "run_sweep, self-referencing dict", f"InputError {REFUSE}", api(SELF + run_sweep)),
        Case(
            "7",
            "run_sweep, NUL in output",
            f"InputError {REFUSE}",
            api(SPEC + "hpcontact.run_sweep(spec, output='a\\x00.nc')", "output"),
        ),
        Case(
            "7",
            "run_sweep, 300-character output",
            f"InputError {REFUSE}",
            api(SPEC + "hpcontact.run_sweep(spec, output='x' * 300 + '.nc')", "output"),
        ),
        Case(
            "7",
            "solve(threads=10**6)",
            f"InputError {REFUSE}",
            api("hpcontact.solve(shape='circle', n=8, threads=10**6)", "threads"),
        ),
        Case("7", "solve(G=1e308)", f"InputError {REFUSE}", api("hpcontact.solve(shape='circle', n=8, G=1e308)", "G")),
        Case("7", "run_sweep('/dev/zero')", f"InputError {REFUSE}", api("hpcontact.run_sweep('/dev/zero')", "spec")),
        Case(
            "7",
            "hpcontact run /dev/zero",
            REFUSE,
            lambda folder: refusal(hpcontact(folder, "run", "/dev/zero"), "spec"),
        ),
        Case(
            "7",
            "hpcontact solve --threads 1000000",
            REFUSE,
            lambda folder: refusal(hpcontact(folder, "solve", "--n", 8, "--threads", 10**6), "threads"),
        ),
        Case(
            "7",
            "hpcontact solve --G 1e308",
            REFUSE,
            lambda folder: refusal(hpcontact(folder, "solve", "--n", 8, "--G", "1e308"), "G"),
        ),
        Case("8", "contributors of a coarse map resumed after a fine one", "= the data set's solves", contributors),
        Case("8", "adaptive run killed in round 2, resumed", "from journals per round [25, 3]", rounds_from_journals),
        Case("8", "a rank stalled twice", "recorded as stalled, no suspect", stalled_rank),
    ]
    return table


def run_case(case: Case) -> Row:
    with tempfile.TemporaryDirectory(prefix="fault_table_") as folder:
        try:
            observed, passed, done = case.run(Path(folder))
        except (RuntimeError, OSError, ValueError) as error:  # the case could not be prepared
            return Row(case.item, case.case, case.expected, f"not run: {error}"[:160], 0.0, 0.0, 0.0, False)
    return Row(case.item, case.case, case.expected, observed, done.wall_s, done.cpu_s, done.peak_rss_mb, bool(passed))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", default=[], help="the cases whose item or name contains one of these")
    parser.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    args = parser.parse_args(argv)
    print(harness.machine_line())
    imported = must(child([sys.executable, "-c", "import hpcontact; print(hpcontact.__file__)"], ROOT, 60.0))
    print(f"hpcontact from {imported.stdout.strip()}")
    selected = [
        c for c in cases() if not args.only or any(t == c.item if t.isdigit() else t in c.case for t in args.only)
    ]
    rows = []
    print(f"{'#':<2} {'case':<48} {'expected':<44} {'wall s':>6} {'CPU s':>6} {'MB':>5}  verdict  observed")
    for case in selected:
        row = run_case(case)
        rows.append(row)
        verdict = "PASS" if row.passed else "FAIL"
        print(
            f"{row.item:<2} {row.case:<48} {row.expected:<44} {row.wall_s:6.2f} {row.cpu_s:6.2f} {row.peak_mb:5.0f}"
            f"  {verdict:<7}  {row.observed}",
            flush=True,
        )
    failed = sum(not r.passed for r in rows)
    print(f"{len(rows)} cases, {len(rows) - failed} PASS, {failed} FAIL")
    if args.json:
        harness.write_json(args.json, {"machine": harness.machine_line(), "rows": [asdict(r) for r in rows]})
    return 1 if failed else 0


if __name__ == "__main__":
    harness.entry(main)
