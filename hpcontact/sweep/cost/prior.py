"""The shipped prior of the cost model: a calibration of the development machine, scaled to this
machine by a probe that takes under a second, for a run's start line where no calibration of the
node type is cached yet (``run_calibration``).

The probe times three small solves of the calibration (``PROBE_SCENES``: the 16 × 16 contact
task, the 64 × 64 contact scene and the 32 × 32 crystal scene, each as ``calibration._timed``
times them: CPU seconds, warm FFT plans, cold kernels, the least of two) here; the prior's own
model gives their seconds on the machine it was calibrated on (``Calibration.task_seconds``).
Every rate of the prior is multiplied by

    scale = (∏_i t_here,i / t_prior,i)^(1/3)

(the geometric mean of the three ratios): one factor for the whole model, so the prior's
proportions between kinds and grid sizes are assumed to carry over. They do not exactly (cache
sizes, vector units): the run's ETA corrects the scale as tasks finish (``run.progress``), and
``hpcontact run SPEC --dry-run`` makes the full calibration (12-30 s) that later runs use.

``python -m hpcontact.sweep.cost.prior`` calibrates this machine and prints the record to paste
as ``PRIOR`` (the development machine's below, made with ~0.25 other processes running beside it).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import socket
import time
from collections.abc import Callable, Mapping
from typing import Any

from hpcontact import __version__
from hpcontact.numerics.blas import limited_blas
from hpcontact.sweep.cost import calibration_file
from hpcontact.sweep.cost.calibration import (
    CALIBRATION_SCENES,
    TINY_CONTACT_SCENE,
    _timed,
    calibrate,
    other_running,
)
from hpcontact.sweep.cost.rates import CONTENDED_FROM, Calibration, Rate, base_memory_bytes

PROBE_SCENES: dict[str, Mapping[str, Any]] = {
    "tiny_contact": TINY_CONTACT_SCENE,
    "contact_64": CALIBRATION_SCENES["contact"][0],
    "crystal_32": CALIBRATION_SCENES["crystal"][0],
}

# The development machine's calibration (``python -m hpcontact.sweep.cost.prior``; 12.0 s).
PRIOR: dict[str, Any] = {
    "base_bytes": 153473024.0,
    "cores": 2,
    "cpu": "Intel(R) Xeon(R) Processor",
    "date": "2026-11-28 22:17 UTC",
    "format": 8,
    "host": "vm",
    "others": 0.25,
    "rates": {
        "contact": {
            "cell_s": 1.2832548384232737e-07,
            "exact_s": 0.044145693999999125,
            "node_s": 0.0,
            "rate_s": 2.5599427891853263e-09,
            "solve_s": 0.0001948757991026672,
            "strip_s": 1.4240059514885767e-09,
            "task_s": 0.003480835000000404,
        },
        "crystal": {
            "cell_s": 0.0,
            "exact_s": 0.0,
            "node_s": 0.0,
            "rate_s": 2.1714279372970704e-09,
            "solve_s": 0.0004220449073593095,
            "strip_s": 0.0,
            "task_s": 0.0,
        },
        "crystal_indentation": {
            "cell_s": 0.0,
            "exact_s": 0.0,
            "node_s": 0.0,
            "rate_s": 2.510782621514329e-09,
            "solve_s": 0.0,
            "strip_s": 0.0,
            "task_s": 0.0,
        },
        "slip": {
            "cell_s": 0.0,
            "exact_s": 0.0,
            "node_s": 0.0017163326217501467,
            "rate_s": 1.2163576374549859e-08,
            "solve_s": 0.0005602826884919698,
            "strip_s": 0.0,
            "task_s": 0.0,
        },
    },
    "seconds": 12.025638148003054,
    "version": "0.1.0",
}


def probe() -> dict[str, float]:
    """CPU seconds of each of ``PROBE_SCENES`` on this machine, under the sweep's BLAS limit."""
    with limited_blas():
        return {name: _timed(scene) for name, scene in PROBE_SCENES.items()}


@functools.cache
def _probed(measure: Callable[[], dict[str, float]]) -> tuple[dict[str, float], float]:
    """What ``measure`` (``probe``) measures and its wall seconds, once per process (an adaptive
    map's rounds, ``hpcontact.run_sweep`` called again: the machine is the same)."""
    started = time.perf_counter()
    return measure(), time.perf_counter() - started


def prior_calibration() -> Calibration:
    """The shipped prior as a ``Calibration`` (checked as a calibration file is)."""
    return calibration_file.calibration_from_record(PRIOR)


def scale_of(here: Mapping[str, float], prior: Calibration) -> float:
    """The geometric mean over the probe scenes of ``here[s]``, the seconds measured, over the
    ``prior``'s seconds of the scene (module docstring)."""
    logs = [math.log(here[name] / prior.task_seconds(scene)) for name, scene in PROBE_SCENES.items()]
    return math.exp(sum(logs) / len(logs))


def probed_prior(own: int = 0) -> tuple[Calibration, str]:
    """The prior scaled to this machine by ``probe`` (module docstring), and where it came from
    in words (the prior's ``whose``, the scale, the probe's wall time and, from
    ``CONTENDED_FROM`` other processes running beside it, that its scale is likely high: CPU
    seconds on shared cores are; the probe is no calibration file, so the ``Calibration`` it
    returns carries no count of its own). The count is the least of two samples, before and
    after the probe: a process busy beside it shows in both, a moment's wake-up (a rank's
    thread, the launcher's) in one (a single sample said so in 2 of 4 runs of an idle machine).
    ``own``: the run's other ranks on this node, not counted among those processes (its tasks
    run beside them too: the probe measured what they will meet)."""
    before = other_running()
    here, probe_s = _probed(probe)
    samples = [n for n in (before, other_running()) if n is not None]
    others = max(0.0, min(samples) - own) if samples else None
    prior = prior_calibration()
    scale = scale_of(here, prior)
    rates = {
        kind: Rate(**{name: value * scale for name, value in dataclasses.asdict(rate).items()})
        for kind, rate in prior.rates.items()
    }
    probed = Calibration(socket.gethostname(), __version__, rates, base_memory_bytes(), probe_s)
    origin = f"shipped prior of {prior.whose()} scaled x{scale:.2f} by a {probe_s:.1f} s probe of this machine"
    if others is not None and others >= CONTENDED_FROM:  # as a contended calibration (Calibration.contended)
        origin += (
            f", probed beside ~{others:.1f} other process(es){' besides this run' if own else ''}: likely high on an idle "
            "machine"
        )
    return probed, origin


def run_calibration(own: int = 0, probe_now: bool = True) -> tuple[Calibration, str]:
    """The calibration a run's start line uses and where it came from, in words: the cached or
    named one (``calibration_file.cached_calibration``), else the shipped prior scaled by a probe
    of this machine (``probed_prior``, under a second, ``own`` the run's other ranks on this
    node; never a full calibration, which a run's ranks would wait 12-30 s for). Without
    ``probe_now``, a process that has not probed yet gets the shipped prior as it is, and its
    origin says so (``probe_pending``: an adaptive round too short to cover the probe)."""
    cached, note = calibration_file.cached_calibration()
    if cached is not None:
        return cached, note
    if not probe_now and not probed_yet():
        shipped = prior_calibration()
        return (
            shipped,
            f"shipped prior of {shipped.whose()}, not scaled to this machine yet ({note}; --dry-run calibrates, 12-30 s)",
        )
    probed, origin = probed_prior(own)
    return probed, f"{origin} ({note}; --dry-run calibrates, 12-30 s)"


def probed_yet() -> bool:
    """Whether this process has probed this machine (``_probed``: once per process)."""
    return _probed.cache_info().currsize > 0


def probe_pending() -> bool:
    """Whether ``run_calibration`` would probe now: no calibration cached or named, no probe yet."""
    return calibration_file.cached_calibration()[0] is None and not probed_yet()


if __name__ == "__main__":
    print(json.dumps({"format": calibration_file.FORMAT, **dataclasses.asdict(calibrate())}, indent=4, sort_keys=True))
