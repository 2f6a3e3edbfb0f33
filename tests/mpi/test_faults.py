"""Faults a 2-rank sweep survives, with real processes (``mpiexec -n 2 hpcontact run``):

* a second run on the same output is refused (exit 2, naming the holder) and does not disturb
  the first; SIGTERM to one rank stops both (exit 4, the hung task abandoned after the grace
  period and journaled as interrupted) while the other rank hangs in a task
  (``HPCONTACT_FAULTS`` ``hang``), and ``--resume`` completes the data set,
  equal to an undisturbed run; a rerun without a flag is refused and deletes nothing; an
  unwritable output is refused before any task;
* a raising task gives exit 3; journals of another git revision are refused (exit 2) unless
  ``--accept-stale``, which retries the failed task (exit 0) and lists both revisions;
* a task that kills its process is quarantined within 3 invocations of ``--resume``, every
  other task computed; ``--retry-crashed`` runs it again;
* 20 SIGKILLs of a random rank at random instants (every 4th in the middle of a journal write,
  ``torn``), each resumed: every data set equals the undisturbed one and no finished task is
  computed again (counted from the journals); a journal cut at 20 random byte offsets keeps
  every complete entry before the cut;
* a file-size limit (RLIMIT_FSIZE, a full disk) stops the run with exit 1 naming the journal,
  journals intact, and ``--resume`` completes.

Launches its own ``mpiexec`` (skips when pytest itself runs under a launcher). The reference is
one plain process of the same spec (``SerialTeam``).
"""

from __future__ import annotations

import io
import json
import os
import random
import resource
import signal
import subprocess
import time
from pathlib import Path

import pytest
import xarray as xr
from launcher import STARTS_ITS_OWN_MPIEXEC, finish, start_run

from hpcontact.sweep.data.journal import CRASHED, OK, decode_lines, journal_files, read_history
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run.schedule import SerialTeam
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_tasks

SPEC = """
[sweep]
title = "faults"
output = "out.nc"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 32
tol = 1e-12
[axes]
shape = ["circle", "ellipse", "rectangle"]
aspect = [1.0, 0.5, 0.2, 0.1]
nu = [0.0, 0.1, 0.2, 0.3, 0.4, 0.5]
"""
TASKS = 6 + 2 * 4 * 6  # the circle ignores the aspect
GRACE_S = 2.0
#: Liveness bound, not a speed bound (issue 39 item 6): a stopped job that has not ended this long
#: after the signal has hung, and the test fails (``subprocess.TimeoutExpired``). The hung task
#: never ends on its own, so a job that ends at all was ended by the stop (the grace, then
#: ``Abandoned``). The stop's own schedule is GRACE_S + MPI teardown (2.9-3.3 s measured,
#: docs/explanation/reliability.md; printed, not asserted), at most GRACE_S + HARD_EXIT_S = 12 s
#: should a rank not take the abandon signal: a machine loaded enough to stretch that 5 times
#: still passes.
STOP_TIMEOUT_S = GRACE_S + 60.0
KILLS = 20

pytestmark = STARTS_ITS_OWN_MPIEXEC


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """The undisturbed data set: one plain process, the real solver."""
    folder = tmp_path_factory.mktemp("reference")
    (folder / "spec.toml").write_text(SPEC)
    return run_sweep(folder / "spec.toml", output=folder / "out.nc", team=SerialTeam(), stream=io.StringIO())


def start(
    folder: Path, *options: str, revision: str = "a", faults: str | None = None, procs: list | None = None
) -> subprocess.Popen:
    """``mpiexec -n 2 hpcontact run spec.toml OPTIONS`` in ``folder`` as git ``revision``, with
    ``HPCONTACT_FAULTS`` set to ``faults`` when given."""
    env = {"HPCONTACT_GIT_REVISION": revision, **({"HPCONTACT_FAULTS": faults} if faults else {})}
    return start_run(folder, SPEC, *options, env=env, procs=procs)


def run(folder: Path, *options: str, **kwargs) -> tuple[int, str, str]:
    """Run to the end: exit status, stdout, stderr."""
    return finish(start(folder, *options, **kwargs))


def sessions(folder: Path) -> dict[str, dict]:
    """Per run (session): rank → pid, and the keys started, finished ok (with times), interrupted."""
    out: dict[str, dict] = {}
    for path in journal_files(folder / "out.nc.journal"):
        events = list(decode_lines(path.read_bytes()))
        if not events:
            continue
        header = events[0]
        s = out.setdefault(header["session"], {"pids": {}, "started": {}, "ok": {}, "interrupted": set()})
        s["pids"][header["rank"]] = header["pid"]
        for e in events[1:]:
            if e["event"] == "started":
                s["started"][e["key"]] = e["time"]
            elif e["event"] == "finished" and e["status"] == OK:
                s["ok"][e["key"]] = e["finished"]
            elif e["event"] == "interrupted":
                s["interrupted"].add(e["key"])
    return out


#: Liveness bound, not a speed bound (issue 39 item 6): a job that has not reached the state a
#: test waits for (its ranks started, a task hanging, a new session journaled) this long after it
#: was launched has hung or died, and the test fails. Starting two ranks is seconds of imports
#: (the command line alone: ~2 CPU s, benchmarks/fault_table.py), two orders of magnitude below.
START_TIMEOUT_S = 300.0


def wait_for(condition, proc: subprocess.Popen, timeout: float = START_TIMEOUT_S) -> None:
    """Poll ``condition`` until it holds; fail if ``proc`` ended first or ``timeout`` s passed."""
    deadline = time.monotonic() + timeout
    while not condition():
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.02)


def same(folder: Path, reference: Path, assert_same_results) -> None:
    with xr.open_dataset(folder / "out.nc") as a, xr.open_dataset(reference) as b:
        assert a.attrs["mpi_size"] == 2
        assert_same_results(a, b)


def keys_in_order() -> list[str]:
    """Task keys in the order ``--dry-run`` lists (the indices of ``HPCONTACT_FAULTS``)."""
    return [t.key for t in enumerate_tasks(parse_spec(SPEC))[0]]


def test_concurrent_run_refused_sigterm_stops_within_the_grace_and_resume_completes(
    tmp_path, reference, assert_same_results, launched
):
    keys = keys_in_order()
    hang = 7
    first = start(tmp_path, "--grace", str(GRACE_S), faults=f"{hang}:hang", procs=launched)

    def hanging():  # and both ranks' journals open: a rank slow to start opens its own later
        return any(keys[hang] in s["started"] and len(s["pids"]) == 2 for s in sessions(tmp_path).values())

    wait_for(hanging, first)
    files = journal_files(tmp_path / "out.nc.journal")
    code, _, err = run(tmp_path, "--resume")
    assert code == 2 and err.count("\n") == 1, err
    assert "in use by a run on" in err and "2 ranks" in err and "--break-lock" in err
    assert journal_files(tmp_path / "out.nc.journal") == files  # the second run wrote nothing

    def other_rank_started():
        ranks = started_by_rank(tmp_path)
        return len(ranks) == 2

    wait_for(other_rank_started, first)
    ranks = started_by_rank(tmp_path)
    hung_rank = next(r for r, (_, started) in ranks.items() if keys[hang] in started)
    other = ranks[1 - hung_rank][0]
    # the other rank runs out of work (the hung chunk's other tasks wait behind the hang) and then
    # waits in the scheduler's close, inside MPI, where Python runs no signal handler
    counts = [-1]

    def settled():
        time.sleep(1.0)
        counts.append(len(read_history(tmp_path / "out.nc.journal").entries))
        return counts[-1] == counts[-2]

    wait_for(settled, first)
    signalled = time.monotonic()
    os.kill(other, signal.SIGTERM)  # to the rank that is not hanging: the stop must reach the other one
    out, err = first.communicate(timeout=STOP_TIMEOUT_S)  # ends, though one rank hangs for good
    elapsed = time.monotonic() - signalled
    assert first.returncode == 4, out + err
    assert "stopped (SIGTERM on rank" in err and "run again with --resume" in err
    (session,) = sessions(tmp_path).values()
    # the stop reached the hanging rank, which abandoned its task after the grace (not the forced exit)
    assert keys[hang] in session["interrupted"] and not (tmp_path / "out.nc").exists()
    print(f"SIGTERM to exit 4: {elapsed:.2f} s with a {GRACE_S:g} s grace (rank {hung_rank} hung; not asserted)")

    code, out, err = run(tmp_path, "--resume")
    assert code == 0, out + err
    same(tmp_path, reference, assert_same_results)
    history = read_history(tmp_path / "out.nc.journal")
    assert not history.suspects()  # the abandoned task is not counted as a crash

    files = journal_files(tmp_path / "out.nc.journal")
    code, out, err = run(tmp_path)  # the same spec and output again: up to date, nothing run
    assert code == 0 and f"is up to date ({TASKS} tasks from journals)" in out, out + err
    (tmp_path / "out.nc").rename(tmp_path / "kept.nc")  # journals without their data set: still refused
    code, _, err = run(tmp_path)
    assert code == 2 and f"{TASKS} finished tasks in" in err and "--resume" in err and "--restart" in err, err
    assert journal_files(tmp_path / "out.nc.journal") == files  # nothing deleted
    (tmp_path / "kept.nc").rename(tmp_path / "out.nc")
    code, _, err = run(tmp_path, "--output", "/proc/hpcontact/out.nc")
    assert code == 2 and "/proc/hpcontact" in err and err.count("\n") == 1, err


def started_by_rank(folder: Path) -> dict[int, tuple[int, set[str]]]:
    """Rank → (pid, keys started) of the one run in ``folder``."""
    out = {}
    for path in journal_files(folder / "out.nc.journal"):
        events = list(decode_lines(path.read_bytes()))
        if events:
            out[events[0]["rank"]] = (events[0]["pid"], {e["key"] for e in events[1:] if e["event"] == "started"})
    return out


def test_a_raising_task_exits_3_and_stale_journals_are_refused_unless_accepted(
    tmp_path, reference, assert_same_results
):
    code, out, err = run(tmp_path, faults="3:raise", revision="a")
    assert code == 3, out + err
    assert "1 failed" in out and "injected fault (HPCONTACT_FAULTS)" in out
    code, out, err = run(tmp_path, "--resume", revision="b-dirty")
    assert code == 2 and err.count("\n") == 1, out + err
    assert "stale journals" in err and "(git a," in err and "(git b-dirty," in err and "--accept-stale" in err
    code, out, err = run(tmp_path, "--resume", "--accept-stale", revision="b-dirty")
    assert code == 0, out + err
    assert f"{TASKS - 1} from journals" in out
    same(tmp_path, reference, assert_same_results)
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        contributors = {c["git_revision"]: c["tasks"] for c in json.loads(ds.attrs["sweep_contributors"])}
    assert contributors == {"a": TASKS - 1, "b-dirty": 1}


def test_a_task_that_kills_its_process_is_quarantined_within_3_resumes(tmp_path, reference, assert_same_results):
    keys = keys_in_order()
    poison = 11
    code, out, err = run(tmp_path, faults=f"{poison}:kill")
    assert code not in (0, 2, 3, 4), out + err
    for resumes in range(1, 4):  # noqa: B007 (reported below)
        code, out, err = run(tmp_path, "--resume", faults=f"{poison}:kill")
        if code == 3:
            break
    assert code == 3, out + err
    print(f"poison task quarantined after {resumes} resume(s)")
    assert "1 failed" in out and "died while running this task in 2 runs" in out
    with xr.open_dataset(tmp_path / "out.nc") as ds:
        history = read_history(tmp_path / "out.nc.journal")
        where = [i for i, key in enumerate(keys) if key in history.crashed()]
        assert where == [poison]
        status = ds.status.values
        assert (status == CRASHED).sum() >= 1 and ((status == OK) | (status == CRASHED)).all()
        message = str(ds.message.values[status == CRASHED][0])
        assert "(last: " in message and "rank " in message and "likely out of memory or a crash" in message
    code, out, err = run(tmp_path, "--resume", "--retry-crashed")
    assert code == 0, out + err
    same(tmp_path, reference, assert_same_results)


def test_20_sigkills_at_random_instants_each_resumed_lose_nothing_and_recompute_nothing(
    tmp_path, reference, assert_same_results, launched
):
    rng = random.Random(20261122)
    keys = keys_in_order()
    kills = chains = torn = 0
    in_flight = 0
    while kills < KILLS:
        folder = tmp_path / f"chain{chains}"
        folder.mkdir()
        chains += 1
        first = True
        while True:
            options = () if first else ("--resume", "--retry-crashed")  # a task hit twice is not poison here
            first = False
            before = set(sessions(folder))
            done = {k for s in sessions(folder).values() for k in s["ok"]}
            if kills < KILLS and kills % 4 == 3 and len(done) < TASKS - 4:
                index = rng.choice([i for i, k in enumerate(keys) if k not in done])
                proc = start(folder, *options, faults=f"{index}:torn", procs=launched)
                proc.communicate(timeout=120)
                if proc.returncode == 0:
                    break
                kills += 1
                torn += 1
                torn_files = [p for p in journal_files(folder / "out.nc.journal") if not p.read_bytes().endswith(b"\n")]
                assert torn_files, "the torn write left no partial line"
                continue
            proc = start(folder, *options, procs=launched)
            if kills >= KILLS:
                out, err = proc.communicate(timeout=120)
                assert proc.returncode == 0, out + err
                break
            try:
                wait_for(lambda: set(sessions(folder)) - before, proc)
            except AssertionError:
                assert proc.returncode == 0, proc.communicate()  # finished before any new journal: complete
                break
            time.sleep(rng.uniform(0.0, 0.5))
            (new,) = set(sessions(folder)) - before
            pids = sessions(folder)[new]["pids"]
            victim = pids.get(rng.choice((0, 1)), next(iter(pids.values())))
            try:
                os.kill(victim, signal.SIGKILL)
            except ProcessLookupError:
                pass
            out, err = proc.communicate(timeout=120)
            if proc.returncode == 0:
                break  # the run ended before the kill
            kills += 1
        same(folder, reference, assert_same_results)
        runs = sorted(sessions(folder).values(), key=lambda s: min(s["started"].values(), default=0.0))
        finished: dict[str, float] = {}
        started: set[str] = set()
        for s in runs:  # from the journals: what each run computed that an earlier one had finished
            begun = min(s["started"].values(), default=float("inf"))
            again = {k for k in s["started"] if k in finished and finished[k] < begun}
            assert not again, f"{len(again)} finished tasks computed again"
            in_flight += len(set(s["started"]) & started)  # started before, never finished: killed in flight
            started |= set(s["started"])
            for k, t in s["ok"].items():
                finished.setdefault(k, t)
        assert set(finished) == set(keys)
    print(f"{kills} SIGKILLs ({torn} in a journal write) over {chains} chains; {in_flight} tasks in flight rerun")


def test_a_journal_cut_at_any_byte_keeps_every_complete_entry_before_the_cut(tmp_path):
    code, out, err = run(tmp_path)
    assert code == 0, out + err
    path = max(journal_files(tmp_path / "out.nc.journal"), key=lambda p: p.stat().st_size)
    data = path.read_bytes()
    ends, position = [], 0
    for line in data.split(b"\n")[:-1]:
        position += len(line) + 1
        ends.append((position, json.loads(line.split(b" ", 1)[1])))
    rng = random.Random(9)
    for cut in sorted(rng.sample(range(len(data) + 1), 20)):
        folder = tmp_path / f"cut{cut}"
        folder.mkdir()
        (folder / path.name).write_bytes(data[:cut])
        expected = {e["key"] for end, e in ends if end <= cut and e["event"] == "finished"}
        assert set(read_history(folder).entries) == expected, cut


def test_a_full_disk_stops_cleanly_naming_the_journal_and_resume_completes(
    tmp_path, reference, assert_same_results, launched
):
    # The limit is set on one running rank (after MPI's start-up, whose shared-memory files it would break),
    # its tasks slowed (0.1 s each, 2.7 s a rank in all) so that the sweep cannot end before the limit strikes.
    proc = start(tmp_path, faults=",".join(f"{i}:slow" for i in range(TASKS)), procs=launched)
    wait_for(lambda: len(started_by_rank(tmp_path)) == 2, proc)
    victim = random.Random(5).choice((0, 1))
    path = next(p for p in journal_files(tmp_path / "out.nc.journal") if p.name.startswith(f"rank{victim:05d}"))
    limit = path.stat().st_size + 1500  # a few more entries fit
    resource.prlimit(started_by_rank(tmp_path)[victim][0], resource.RLIMIT_FSIZE, (limit, limit))
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 1, out + err
    assert f"cannot write out.nc.journal/{path.name}: File too large" in err and "--resume" in err, err
    assert "Traceback" not in err
    history = read_history(tmp_path / "out.nc.journal")
    assert 0 < len(history.entries) < TASKS and path.stat().st_size <= limit
    code, out, err = run(tmp_path, "--resume")
    assert code == 0, out + err
    same(tmp_path, reference, assert_same_results)
