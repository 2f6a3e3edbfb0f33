"""The bookkeeping of a run counts what it says (issue 43 item 8): the data set's contributors
count the solves it holds, an adaptive round's line counts that round's tasks from journals, and
a rank that stalled is not taken for one that died."""

from __future__ import annotations

import io
import json
import re
import time

import pytest
import xarray as xr
from mindlin_map import MAP, mindlin

from hpcontact.sweep.data.journal import Journal, read_history
from hpcontact.sweep.run.records import Options
from hpcontact.sweep.run.signals import ALIVE_PREFIX, POLL_S, STOP_NAME, StopControl


def contributed(ds: xr.Dataset) -> int:
    return sum(item["tasks"] for item in json.loads(ds.attrs["sweep_contributors"]))


def test_the_contributors_count_the_solves_of_the_data_set_not_every_journaled_task(sweep, write_spec):
    """A coarser map after a finer one, resumed from its journals: 25 solves in the data set; its
    contributors counted every journaled task of the spec's grid (128, the finer map's) before."""
    spec = write_spec(MAP)
    with xr.open_dataset(sweep(spec, mindlin)) as fine:
        assert contributed(fine) == fine.attrs["sweep_solves"] > 25
    spec.write_text(spec.read_text().replace("tolerance = 1e-3", "tolerance = 0.5\nchecks = 0"))
    with xr.open_dataset(sweep(spec, mindlin, resume=True)) as coarse:
        assert coarse.attrs["sweep_solves"] == int(coarse["solved"].sum()) == 25  # the first round met it
        assert contributed(coarse) == 25 == coarse.attrs["sweep_tasks_reused"]


def test_each_adaptive_round_counts_its_own_tasks_from_journals(sweep, write_spec):
    """Killed in round 2, resumed: round 1 reuses its 25 scenes, round 2 the 3 journaled before
    the kill; before, round 1 said "(28 from journals)", every round's tasks in the journals."""

    class Killed(BaseException):
        pass

    calls: list = []

    def dies(params):
        if len(calls) == 28:
            raise Killed
        calls.append(params)
        return mindlin(params)

    spec, runner = write_spec(MAP), "Mindlin's closed form"  # both functions one runner: reused
    with pytest.raises(Killed):
        sweep(spec, dies, options=Options(runner=runner))
    stream = io.StringIO()
    with xr.open_dataset(sweep(spec, mindlin, stream=stream, options=Options(resume=True, runner=runner))) as ds:
        solves, reused = ds.attrs["sweep_solves"], ds.attrs["sweep_tasks_reused"]
    added = [int(n) for n in re.findall(r"adaptive round \d+: (\d+) ", stream.getvalue())]
    counted = re.findall(r"tasks, (\d+) to run(?: \((\d+) from journals\))?", stream.getvalue())
    ran, journaled = [int(r) for r, _ in counted], [int(j or 0) for _, j in counted]
    assert journaled[:2] == [25, 3] and sum(journaled) == reused == 28
    assert [r + j for r, j in zip(ran, journaled)] == added and sum(added) == solves


def test_a_stalled_rank_is_recorded_so_its_task_is_not_taken_for_a_crash(tmp_path):
    """Rank 0 finds rank 1 stalled (no heartbeat) and records it; the task rank 1 had started
    then is no suspect of a death, so two such stalls do not quarantine it, while a start left
    by a rank that died (no stall recorded) still counts."""
    sessions = ["20250101T000000Z-1-aaaaaa", "20250101T010000Z-2-bbbbbb"]
    for session in sessions:
        for left in [tmp_path / STOP_NAME, *tmp_path.glob(f"{ALIVE_PREFIX}*")]:  # as a run's preparation does
            left.unlink(missing_ok=True)
        with Journal(tmp_path / f"rank00001-{session}.jsonl", 1, {"session": session}) as journal:
            journal.started("stuck")
        stop = StopControl(stall_s=4 * POLL_S)
        stop.watch(tmp_path, rank=0, ranks=2, session=session)
        deadline = time.monotonic() + 60.0
        while stop.reason is None and time.monotonic() < deadline:
            time.sleep(POLL_S)
        stop.close()
        assert stop.reason is not None and "rank 1 made no progress" in stop.reason
    history = read_history(tmp_path)
    assert history.suspects() == {} and history.crashed() == {}
    with Journal(tmp_path / "rank00001-20250101T020000Z-3-cccccc.jsonl", 1, {"session": "x"}) as journal:
        journal.started("stuck")  # a run that died: no stall recorded
    assert len(read_history(tmp_path).suspects()["stuck"]) == 1


def test_an_adaptive_rounds_progress_counts_that_rounds_tasks(sweep, write_spec):
    """Each progress line of an adaptive round counts the round's tasks ("adaptive round 2:
    16/30"), not the whole grid's ("16/61" in a round of 30 read as the map's progress)."""
    spec = write_spec(MAP.replace("progress_interval = 100.0", "progress_interval = 1e-9"))
    stream = io.StringIO()
    sweep(spec, mindlin, stream=stream)
    text = stream.getvalue()
    # a round's line: its scenes added, or a check round's random points solved
    added = {int(k): int(n) for k, n in re.findall(r"adaptive round (\d+): (\d+) (?:scene|random point)", text)}
    shown = [tuple(map(int, m)) for m in re.findall(r"adaptive round (\d+): (\d+)/(\d+) tasks", text)]
    assert len(added) >= 2 and {k for k, _, _ in shown} == set(added)  # a line in every round
    assert all(total == added[k] and 0 <= done <= total for k, done, total in shown)
