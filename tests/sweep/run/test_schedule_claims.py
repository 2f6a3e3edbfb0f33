"""Claims (``schedule.claimed_chunks``): a rank takes several cheap chunks with one request,
sized by ``replay.claim_size`` from its own measured round trips and chunk seconds; and a sweep
run in claims writes the data set and the journal entries of a sweep run one chunk a claim."""

from __future__ import annotations

import io
import json
import threading

import xarray as xr

from hpcontact.sweep.data.journal import journal_files
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run import schedule
from hpcontact.sweep.run.schedule import NEXT_CHUNK, SLOTS, LocalCounter, claimed_chunks
from hpcontact.sweep.run.schedule import SerialTeam as _SerialTeam
from hpcontact.sweep.work.replay import claim_size


class Clock:
    """A clock that only the test moves."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class SlowCounter(LocalCounter):
    """A counter whose every request takes ``round_trip`` seconds of ``clock`` and is recorded."""

    def __init__(self, clock: Clock, round_trip: float) -> None:
        super().__init__(SLOTS)
        self.clock, self.round_trip, self.requests = clock, round_trip, []

    def fetch_add(self, slot: int, value: int) -> int:
        self.clock.now += self.round_trip
        self.requests.append(value)
        return super().fetch_add(slot, value)


def test_a_rank_asks_for_as_many_chunks_as_its_measured_times_say():
    """Round trips of 1/64 s, chunks of 1/8 s, 200 chunks, 2 ranks: after a first claim of one
    chunk, each claim is claim_size(1/64, 1/8, remaining, 2) chunks: ceil(6.25) = 7 while
    remaining // 8 allows it, fewer as the chunks run out; every chunk once, in order."""
    clock = Clock()
    counter = SlowCounter(clock, 1 / 64)
    chunks = [(f"t{i}",) for i in range(200)]
    got = []
    for chunk in claimed_chunks(chunks, counter, 2, clock):
        got.append(chunk)
        clock.now += 0.125
    assert got == chunks
    expected, seen = [1], 1
    while seen < len(chunks):
        expected.append(claim_size(1 / 64, 0.125, len(chunks) - seen, 2))
        seen += expected[-1]
    assert counter.requests == [*expected, expected[-1]]  # and the request that finds none left
    assert expected[1] == 7 and expected[-1] == 1 and len(expected) < len(chunks) / 3


def test_ranks_claiming_at_once_take_every_chunk_exactly_once():
    counter = LocalCounter(SLOTS)
    chunks = [(i,) for i in range(5000)]
    taken: list[list[tuple[int, ...]]] = [[], [], [], []]

    def rank(r: int) -> None:
        for chunk in claimed_chunks(chunks, counter, 4):
            taken[r].append(chunk)

    threads = [threading.Thread(target=rank, args=(r,)) for r in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(c for part in taken for c in part) == chunks
    assert counter.fetch_add(NEXT_CHUNK, 0) >= len(chunks)


def test_a_rank_that_fills_batches_takes_what_fills_one_and_gets_a_claim_as_one_tuple():
    """``fill`` (a GPU rank's ``batches.batch_fill``): each request takes max(claim_size, fill(i,
    most)) chunks, i where the last claim ended, ``most`` claim_size's bound remaining // (4 ×
    ranks); a claim's chunks come joined. 100 chunks of two items, 2 ranks, round trips of 1/64 s
    and chunks of 1/8 s (claim_size 7 at most): fill asks for 12 from index 0, 30 beyond."""
    clock = Clock()
    counter = SlowCounter(clock, 1 / 64)
    chunks = [(2 * i, 2 * i + 1) for i in range(100)]
    asked = []

    def fill(index: int, most: int) -> int:
        asked.append((index, most))
        return 12 if index == 0 else 30

    claims = []
    for claim in claimed_chunks(chunks, counter, 2, clock, fill):
        claims.append(claim)
        clock.now += 0.125 * len(claim) / 2
    assert [item for claim in claims for item in claim] == list(range(200))  # every item once, in order
    remaining = [100 - sum(len(c) // 2 for c in claims[: k + 1]) for k in range(len(claims))]
    assert asked == [(0, 100 // 8)] + [(100 - r, max(1, r // 8)) for r in remaining]
    expected = [12] + [max(claim_size(1 / 64, 0.125, r, 2), min(30, max(1, r // 8))) for r in remaining[:-1]]
    assert counter.requests[:-1] == expected and [len(c) // 2 for c in claims] == [
        min(e, 100 - sum(expected[:k])) for k, e in enumerate(expected)
    ]


def test_a_rank_alone_fills_without_the_tail_bound():
    asked = []

    def fill(index: int, most: int) -> int:
        asked.append((index, most))
        return 100

    chunks = [(i,) for i in range(10)]
    assert list(claimed_chunks(chunks, LocalCounter(SLOTS), 1, fill=fill)) == [tuple(range(10))]
    assert asked == [(0, 10), (10, 1)]  # all ten at once; after them the bound of none left


def test_ranks_that_fill_batches_take_every_item_exactly_once():
    counter = LocalCounter(SLOTS)
    chunks = [(3 * i, 3 * i + 1, 3 * i + 2) for i in range(2000)]
    taken: list[list[int]] = [[], [], []]

    def rank(r: int) -> None:
        fill = None if r == 2 else (lambda index, most: min(most, 5 + index % 7))  # ranks 0, 1 fill; 2 does not
        for claim in claimed_chunks(chunks, counter, 3, fill=fill):
            taken[r].extend(claim)

    threads = [threading.Thread(target=rank, args=(r,)) for r in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(i for part in taken for i in part) == list(range(6000))


SPEC = """
[sweep]
title = "claims test"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 16
[axes]
shape = ["circle", "ellipse", { label = "hexagon", shape = "polygon", sides = 6 }]
aspect = [1.0, 0.1, 0.01]
nu = [0.0, 0.25, 0.5]
angle = { linspace = [0, 180, 5] }
"""


def _journal(folder) -> dict[str, tuple]:
    """Each finished task's parameters, status, message and record, by key."""
    entries = {}
    for path in journal_files(folder):
        for line in path.read_text(encoding="utf-8").splitlines():
            event = json.loads(line.split(" ", 1)[1])
            if event.get("event") == "finished":
                entries[event["key"]] = (event["params"], event["status"], event["message"], event["record"])
    return entries


def test_a_sweep_in_claims_writes_what_one_chunk_a_claim_writes(write_spec, fake_solve, tmp_path, monkeypatch):
    """The same sweep with claims of one chunk and of three chunks (``claim_size`` replaced):
    the data sets are identical to the last bit but for the wall times and the run's own
    attributes, and so are the journals' finished entries."""
    results = {}
    for size in (1, 3):
        requests: list[int] = []

        class Recording(LocalCounter):
            def fetch_add(self, slot: int, value: int) -> int:
                if slot == NEXT_CHUNK:
                    requests.append(value)
                return super().fetch_add(slot, value)

        class Team(_SerialTeam):
            def counter(self, slots: int) -> LocalCounter:
                return Recording(slots)

        monkeypatch.setattr(schedule, "claim_size", lambda *args, size=size: size)
        output = tmp_path / f"claims{size}.nc"
        run_sweep(write_spec(SPEC), output=output, task_function=fake_solve, team=Team(), stream=io.StringIO())
        assert set(requests[1:]) == {size}  # every claim after the first took `size` chunks
        with xr.open_dataset(output) as ds:
            ds = ds.drop_vars("wall_time_s").load()
            ds.attrs = {}
        results[size] = ds, _journal(tmp_path / f"claims{size}.nc.journal")
    (one, one_journal), (three, three_journal) = results[1], results[3]
    xr.testing.assert_identical(one, three)
    assert one_journal == three_journal and len(one_journal) == 15
