"""Stopping a sweep on every rank (hpcontact.sweep.run.signals): the stop file passes a request on,
a signal becomes a request, SIGUSR2 abandons the task in flight, and heartbeats name a rank that
made no progress. Two ``StopControl`` objects on one folder stand for two ranks. The grace here
is long, so the stop thread never ends the pytest process."""

from __future__ import annotations

import math
import os
import signal
import socket
import time
from collections.abc import Callable

import pytest

from hpcontact.sweep.run.signals import ALIVE_PREFIX, POLL_S, STOP_NAME, Abandoned, StopControl

LONG = 1e6  # seconds: no forced exit while a test runs


def wait_until(condition: Callable[[], bool], timeout: float = 3.0) -> bool:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.02)
    return True


@pytest.mark.parametrize(("grace", "stall"), [(-1.0, 10.0), (math.nan, 10.0), (1.0, -0.5), (1.0, math.nan)])
def test_negative_or_nan_seconds_are_refused(grace, stall):
    with pytest.raises(ValueError, match="a number of seconds >= 0"):
        StopControl(grace_s=grace, stall_s=stall)


def test_a_phase_is_one_of_the_runs_phases():
    control = StopControl()
    assert control.phase == "setup"
    control.enter("finish")
    assert control.phase == "finish"
    with pytest.raises(ValueError, match="phase = 'teardown': one of setup, tasks, finish, done"):
        control.enter("teardown")


def test_the_first_request_is_kept_and_dropped_as_the_stop_file(tmp_path):
    control = StopControl(grace_s=LONG)
    try:
        control.watch(tmp_path, rank=0)
        assert control.phase == "tasks" and not control.stopping
        control.request("disk full on rank 0", failed=True)
        control.request("SIGTERM on rank 0")
        assert control.stopping and control.reason == "disk full on rank 0" and control.failed
        assert (tmp_path / STOP_NAME).read_text() == "failed disk full on rank 0\n"
    finally:
        control.close()


def test_a_request_made_before_the_folder_is_known_is_dropped_once_it_is(tmp_path):
    control = StopControl(grace_s=LONG)
    control.request("SIGINT on rank 1")
    assert not (tmp_path / STOP_NAME).exists()
    try:
        control.watch(tmp_path, rank=1)
        assert (tmp_path / STOP_NAME).read_text() == "signal SIGINT on rank 1\n"
    finally:
        control.close()


def test_another_rank_reads_the_request_from_the_stop_file(tmp_path):
    asking, told = StopControl(grace_s=LONG), StopControl(grace_s=LONG)
    try:
        told.watch(tmp_path, rank=1)
        asking.watch(tmp_path, rank=0)
        asking.request("SIGUSR1 on rank 0 (node1)")
        assert wait_until(lambda: told.stopping, timeout=10 * POLL_S)
        assert told.reason == "SIGUSR1 on rank 0 (node1)" and not told.failed
    finally:
        asking.close()
        told.close()


def test_a_signal_is_a_stop_request_and_sigusr2_abandons_the_task_in_flight():
    control = StopControl(grace_s=LONG)
    before = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGUSR1, signal.SIGINT, signal.SIGUSR2)}
    try:
        control.install(rank=3)
        os.kill(os.getpid(), signal.SIGUSR2)  # no stop requested yet: nothing to abandon
        time.sleep(0.05)
        os.kill(os.getpid(), signal.SIGUSR1)
        assert wait_until(lambda: control.stopping)
        assert control.reason == f"SIGUSR1 on rank 3 ({socket.gethostname()})" and not control.failed
        control.running = True
        with pytest.raises(Abandoned, match=r"abandoned 1e\+06 s after the stop request \(SIGUSR1 on rank 3"):
            os.kill(os.getpid(), signal.SIGUSR2)
            time.sleep(1.0)  # the handler raises here, in the main thread
    finally:
        control.running = False
        control.close()
        control.uninstall()
    assert {s: signal.getsignal(s) for s in before} == before


def test_a_rank_whose_heartbeat_stops_is_named_and_the_live_rank_stops(tmp_path):
    stall = 0.8  # heartbeats every 0.2 s, at each poll
    rank0, rank1 = StopControl(grace_s=LONG, stall_s=stall), StopControl(grace_s=LONG, stall_s=stall)
    try:
        rank0.watch(tmp_path, rank=0, ranks=2)
        rank1.watch(tmp_path, rank=1, ranks=2)
        time.sleep(2 * stall)  # both beat: no stall
        assert not rank0.stopping and not rank1.stopping
        assert (tmp_path / f"{ALIVE_PREFIX}00000").exists() and (tmp_path / f"{ALIVE_PREFIX}00001").exists()
        rank1.close()  # rank 1 freezes
        assert wait_until(lambda: rank0.stopping, timeout=10 * stall)
        assert rank0.failed and rank0.reason.startswith("rank 1 made no progress for ")
        assert rank0.reason.endswith(" s (--stall-timeout)")
    finally:
        rank0.close()
        rank1.close()


def test_no_heartbeat_with_one_rank_or_the_stall_timeout_off(tmp_path):
    alone, off = StopControl(grace_s=LONG, stall_s=0.2), StopControl(grace_s=LONG, stall_s=0.0)
    try:
        (tmp_path / "alone").mkdir()
        alone.watch(tmp_path / "alone", rank=0, ranks=1)
        off.watch(tmp_path, rank=0, ranks=2)  # rank 1 never beats, but nobody watches
        time.sleep(5 * POLL_S)
        assert not alone.stopping and not off.stopping
        assert not any(p.name.startswith(ALIVE_PREFIX) for p in tmp_path.rglob("*"))
    finally:
        alone.close()
        off.close()
