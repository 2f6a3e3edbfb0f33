"""The progress lines' ETA on a replayed run (issue 42 item 3): within 2x of the time truly left
after 20 % of the tasks, where ETAs by task count are not.

The replay: 120 tasks whose estimated seconds span two decades (0.2-20 s), whose true seconds are
the estimate times a systematic error of the calibration (0.4x or 2.4x: a calibration made under
load, or on another machine) times a task-to-task scatter (log-normal, σ = 0.3), and whose
relative cost (what orders them and what the ranks report) is not proportional to their seconds
(cost ∝ seconds^1.3, as the main job's crystal stars against thin crystal rectangles: 20x the
cost for 11x the seconds). The ranks take the chunks of ``tasks.make_chunks`` in order, each
running its chunk's tasks one after the other; every finished task is a moment at which the ETA
could be printed. The ETAs compared are those printed while more than one progress interval
(10 s) of the run is left: in the last interval the next line is the end of the run (the tail's
ETA is the load imbalance of the last few tasks, a few seconds either way).

The first-hour run (``first_hour_run.json``, issue 42): the README's main job as a new user ran it
(396 tasks on 2 ranks, 139 s of which every task's end is recorded), replayed as it ran — its
hand-out order, chunks and kernel groups, each task's end — with the ETA from the seconds the
cost model estimates today for each task at the calibration of that machine (in the fixture) and
at the shipped prior the run itself used. Its ETAs printed 0.47-0.78 of the time left (replayed
with the model it ran, at the prior: 0.46-0.77), its crystal rectangles' seconds estimated 2.25x
low and its crystal exact cells' 12x high (``benchmarks/cost_estimates.py --journals``).
"""

from __future__ import annotations

import heapq
import io
import json
from pathlib import Path

import numpy as np
import pytest

from hpcontact.sweep.cost.calibration_file import calibration_from_record
from hpcontact.sweep.cost.prior import prior_calibration
from hpcontact.sweep.cost.task_cost import estimated_cost
from hpcontact.sweep.run.progress import Progress
from hpcontact.sweep.run.schedule import cost_units
from hpcontact.sweep.work.estimate import task_arrays
from hpcontact.sweep.work.tasks import Task, make_chunks

FIRST_HOUR_RUN = Path(__file__).with_name("first_hour_run.json")

INTERVAL_S = 10.0


def replay(ranks: int, bias: float, seed: int, count: int = 120) -> list[tuple[float, float, float]]:
    """(seconds truly left, ETA by estimated seconds, ETA by task count) at each finished task
    after 20 % of the tasks while more than ``INTERVAL_S`` is left (module docstring)."""
    rng = np.random.default_rng(seed)
    estimated = np.exp(rng.uniform(np.log(0.2), np.log(20.0), count))
    true = bias * estimated * np.exp(rng.normal(0.0, 0.3, count))
    cost = 1000.0 * estimated**1.3
    tasks = [Task(key=str(i), params={"i": i}, cost=float(cost[i]), group=f"g{i % 6}") for i in range(count)]
    chunks = make_chunks(tasks, ranks)
    handed = [t for chunk in chunks for t in chunk]
    progress = Progress(
        count,
        0,
        [cost_units(t.cost) for t in handed],
        [float(estimated[int(t.key)]) for t in handed],
        INTERVAL_S,
        io.StringIO(),
        ranks,
        [len(chunk) for chunk in chunks],
    )
    free = [(0.0, rank) for rank in range(ranks)]
    finished = []
    for chunk in chunks:
        clock, rank = heapq.heappop(free)
        for task in chunk:
            clock += float(true[int(task.key)])
            finished.append((clock, task))
        heapq.heappush(free, (clock, rank))
    finished.sort(key=lambda event: event[0])
    end = finished[-1][0]
    rows, units = [], 0.0
    for done, (clock, task) in enumerate(finished, start=1):
        units += cost_units(task.cost)
        if done >= 0.2 * count and end - clock > INTERVAL_S:
            rows.append((end - clock, progress.eta(units, clock), clock * (count - done) / done))
    return rows


@pytest.mark.parametrize("ranks", [1, 2, 4])
@pytest.mark.parametrize("bias", [0.4, 2.4])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_every_eta_after_a_fifth_of_the_tasks_is_within_2x_of_the_time_left(ranks, bias, seed):
    rows = replay(ranks, bias, seed)
    assert rows  # the run is longer than its first fifth and a progress interval
    ratios = [eta / left for left, eta, _ in rows]
    assert 0.5 <= min(ratios) and max(ratios) <= 2.0, (min(ratios), max(ratios))


def test_the_replay_tells_a_count_based_eta_from_a_good_one():
    """The same replays with the ETA by task count (largest tasks first: the count runs ahead of
    the work) are off by more than 2x: the test above can fail."""
    worst = max(count / left for ranks in (1, 2, 4) for left, _, count in replay(ranks, 2.4, 0))
    assert worst > 2.0


def first_hour_replay(prior: bool = False) -> list[tuple[float, float]]:
    """(seconds truly left, ETA) at each task's end in the first-hour run (module docstring) after
    20 % of its tasks while more than its progress interval is left: the ranks report each
    finished task's cost units (today's ``estimated_cost``), the ETA maps them onto today's
    estimated seconds of the tasks in the run's hand-out order (``estimate.task_arrays`` at the
    run machine's calibration, as ``hpcontact run`` does; with ``prior``, at the shipped prior,
    what that run had: the ETA corrects its scale, not its proportions)."""
    run = json.loads(FIRST_HOUR_RUN.read_text())
    calibration = prior_calibration() if prior else calibration_from_record(run["calibration"])
    handed = [
        Task(str(i), {**run["common"], **params}, estimated_cost({**run["common"], **params}), f"g{group}")
        for i, (params, _, _, group) in enumerate(run["tasks"])
    ]
    seconds = task_arrays(handed, calibration)[0]
    progress = Progress(
        len(handed),
        0,
        [cost_units(t.cost) for t in handed],
        seconds.tolist(),
        run["interval_s"],
        io.StringIO(),
        run["ranks"],
        run["chunks"],
    )
    ends = sorted((end, i) for i, (_, end, _, _) in enumerate(run["tasks"]))
    last = ends[-1][0]
    rows, units = [], 0.0
    for done, (end, i) in enumerate(ends, start=1):
        units += cost_units(handed[i].cost)
        if done >= 0.2 * len(handed) and last - end > run["interval_s"]:
            rows.append((last - end, progress.eta(units, end)))
    return rows


@pytest.mark.parametrize("prior", [False, True], ids=["its-machines-calibration", "shipped-prior"])
def test_every_eta_of_the_first_hour_run_after_a_fifth_of_its_tasks_is_within_2x_of_the_time_left(prior):
    rows = first_hour_replay(prior)
    assert len(rows) > 200  # the tasks after the first fifth but the last interval's
    ratios = [eta / left for left, eta in rows]
    assert 0.5 <= min(ratios) and max(ratios) <= 2.0, (min(ratios), max(ratios))
