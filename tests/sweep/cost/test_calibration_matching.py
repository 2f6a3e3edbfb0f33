"""Which calibration an estimate uses (issue 42 item 3): matched by CPU model and core count, not
host; a named file (--costmodel, $HPCONTACT_COSTMODEL) used as given, saying whose it is; a new
machine's start estimate from the shipped prior scaled by a probe, never a calibration run."""

from __future__ import annotations

import dataclasses
import json
import math
import socket

import pytest

from hpcontact import __version__
from hpcontact.sweep.cost import calibration_file, prior, rates
from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate, load_note
from hpcontact.sweep.driver import main

SPEC = """
[scene]
shape = "circle"
quantities = ["tangential"]
[numerics]
n = 16
tol = 1e-6
[axes]
nu = [0.2, 0.3]
"""


def calibration_of(host: str, cpu: str | None = None, cores: int | None = None) -> Calibration:
    here_cpu, here_cores = rates.node_type()
    return Calibration(
        host,
        __version__,
        {kind: Rate(rate_s=1e-6, solve_s=0.0) for kind in KINDS},
        1.0,
        cpu=here_cpu if cpu is None else cpu,
        cores=here_cores if cores is None else cores,
        date="2026-11-28 12:00 UTC",
    )


@pytest.fixture
def node_cache(tmp_path, monkeypatch):
    """No file named: the cache of this node type, beside a wisdom file in ``tmp_path``."""
    monkeypatch.delenv("HPCONTACT_COSTMODEL", raising=False)
    monkeypatch.setenv("HPCONTACT_WISDOM", str(tmp_path / "fftw_wisdom"))
    return rates.calibration_path()


def test_the_cache_is_named_by_cpu_model_and_cores_not_by_host(node_cache, monkeypatch):
    monkeypatch.setattr(socket, "gethostname", lambda: "node042")
    assert rates.calibration_path() == node_cache and node_cache.name.endswith(f"-{rates.node_type()[1]}c.json")
    monkeypatch.setattr(rates, "node_type", lambda: ("AMD EPYC 7763 64-Core Processor", 128))
    assert rates.calibration_path().name == "costmodel-amd-epyc-7763-64-core-processor-128c.json"
    monkeypatch.setattr(rates, "node_type", lambda: ("Intel(R) Xeon(R) Gold 6248 CPU @ 2.50GHz", 40))
    assert rates.calibration_path().name == "costmodel-intel-xeon-gold-6248-cpu-2-50ghz-40c.json"


def test_a_calibration_of_another_host_of_this_node_type_is_used_and_says_whose(node_cache):
    saved = calibration_of("node042")
    calibration_file.save_calibration(saved, node_cache)
    cached, note = calibration_file.cached_calibration()
    assert cached == saved
    assert note.startswith("cost model of node042 (") and "2026-11-28 12:00 UTC" in note
    assert rates.node_type()[0] in note and "may be off" not in note


@pytest.mark.parametrize("other", [{"cpu": "Another CPU"}, {"cores": 4096}])
def test_the_cache_of_another_node_type_is_not_used(node_cache, other):
    calibration_file.save_calibration(calibration_of("here", **other), node_cache)
    cached, why = calibration_file.cached_calibration()
    assert cached is None and "ignored: measured on" in why


def test_a_named_file_is_used_whoever_made_it_and_says_so(tmp_path, monkeypatch):
    path = calibration_file.save_calibration(
        calibration_of("node042", cpu="Another CPU", cores=64), tmp_path / "c.json"
    )
    monkeypatch.setenv("HPCONTACT_COSTMODEL", str(path))
    cached, note = calibration_file.cached_calibration()
    assert cached is not None and cached.host == "node042"
    assert "of node042 (Another CPU, 64 cores)" in note and "estimates may be off" in note
    monkeypatch.setattr(calibration_file, "calibrate", lambda: pytest.fail("a named calibration is used"))
    assert calibration_file.load_calibration() == cached


def test_the_file_keeps_cpu_cores_and_date_and_refuses_a_file_without_them(tmp_path):
    saved = calibration_of("h", cpu="X", cores=3)
    path = calibration_file.save_calibration(saved, tmp_path / "c.json")
    assert calibration_file.read_calibration(path) == saved
    record = json.loads(path.read_text())
    for name, bad in (("cpu", None), ("cores", 0), ("cores", True), ("date", 5)):
        broken = {**record, name: bad}
        path.write_text(json.dumps(broken))
        with pytest.raises(ValueError, match=name):
            calibration_file.read_calibration(path)


def test_the_shipped_prior_is_a_calibration_of_its_machine():
    shipped = prior.prior_calibration()
    assert shipped.cpu and shipped.cores >= 1 and shipped.date and shipped.others is not None
    assert all(shipped.task_seconds(scene) > 0.0 for scene in prior.PROBE_SCENES.values())


def test_a_new_machine_gets_the_prior_scaled_by_its_probe_and_never_waits_for_a_calibration(node_cache, monkeypatch):
    """A machine that runs the probe scenes in 2.5x the prior's seconds gets every rate 2.5x
    the prior's (the geometric mean of equal ratios is that ratio)."""
    shipped = prior.prior_calibration()
    monkeypatch.setattr(calibration_file, "calibrate", lambda: pytest.fail("a run must not wait for a calibration"))
    monkeypatch.setattr(
        prior, "probe", lambda: {name: 2.5 * shipped.task_seconds(s) for name, s in prior.PROBE_SCENES.items()}
    )
    calibration, origin = prior.run_calibration()
    for kind in KINDS:
        for name, value in dataclasses.asdict(calibration.rates[kind]).items():
            assert value == pytest.approx(2.5 * getattr(shipped.rates[kind], name), rel=1e-12)
    assert origin.startswith(f"shipped prior of {shipped.host} (") and "scaled x2.50 by a" in origin
    assert "--dry-run calibrates" in origin and not node_cache.exists()  # a probe is not cached


def test_the_memory_base_is_a_task_ranks_imports_without_xarray():
    """The probe's memory base (``rates.base_memory_bytes``, in a run's first announcement)
    imports what a rank that runs tasks imports, not xarray: rank 0 imports it where a round's
    work covers it (``run.rounds.imports_array_modules``). A fresh process: this one has
    imported xarray already."""
    import subprocess
    import sys

    code = (
        "import sys; from hpcontact.sweep.cost.rates import base_memory_bytes; b = base_memory_bytes(); "
        "print(b > 0, 'mpi4py.MPI' in sys.modules, 'xarray' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["True", "True", "False"]


def test_the_probe_scale_is_the_geometric_mean_of_its_ratios():
    shipped = prior.prior_calibration()
    factors = dict(zip(prior.PROBE_SCENES, (1.0, 2.0, 4.0)))
    here = {name: factors[name] * shipped.task_seconds(s) for name, s in prior.PROBE_SCENES.items()}
    assert prior.scale_of(here, shipped) == pytest.approx(2.0, rel=1e-12)


def test_the_load_note_says_the_run_is_slower_where_cores_are_shared():
    assert load_note(2.0, 2) == "" and load_note(1.0, 2) == "" and load_note(None, 2) == ""
    assert "may take up to 3.0x the estimated wall time" in load_note(6.0, 2)


def test_a_contended_calibration_says_its_estimates_are_high_not_low():
    """The direction: a calibration's CPU seconds on a shared core are high, so an idle machine
    runs faster than it estimates (docs/performance.md: 226.5 core-seconds calibrated beside a
    busy process against 68.9 alone for the same job)."""
    contended = dataclasses.replace(calibration_of("h"), others=2.0)
    assert "likely high" in contended.contended() and "faster than it estimates" in contended.contended()
    assert math.isclose(rates.CONTENDED_RATES, 226.5 / 68.9)


def test_costmodel_names_the_file_the_run_uses(tmp_path, write_spec, monkeypatch, capsys):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    spec = write_spec(SPEC)
    path = calibration_file.save_calibration(
        calibration_of("node042", cpu="Another CPU", cores=64), tmp_path / "c.json"
    )
    assert main([str(spec), "--dry-run", "--costmodel", str(path)]) == 0
    out = capsys.readouterr().out
    assert "cost model of node042 (Another CPU, 64 cores), 2026-11-28 12:00 UTC" in out
    missing = tmp_path / "missing.json"
    assert main([str(spec), "--costmodel", str(missing)]) == 2  # a run: the file must be there
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 1 and err[0].startswith("hpcontact run: error: --costmodel = ") and "calibrates into it" in err[0]
    )
    (tmp_path / "not.json").write_text("{}")
    assert main([str(spec), "--dry-run", "--costmodel", str(tmp_path / "not.json")]) == 2
    assert "not a calibration file" in capsys.readouterr().err
    fresh = calibration_of("here")
    monkeypatch.setattr(calibration_file, "calibrate", lambda: fresh)
    assert main([str(spec), "--dry-run", "--costmodel", str(missing)]) == 0  # a dry run calibrates into it
    assert calibration_file.read_calibration(missing) == fresh


def test_a_probe_beside_other_work_says_its_scale_is_likely_high(node_cache, monkeypatch):
    shipped = prior.prior_calibration()
    monkeypatch.setattr(prior, "probe", lambda: {n: shipped.task_seconds(s) for n, s in prior.PROBE_SCENES.items()})
    monkeypatch.setattr(prior, "other_running", lambda: 3.0)
    calibration, origin = prior.run_calibration()
    assert "scaled x1.00" in origin and "probed beside ~3.0 other process(es): likely high" in origin
    assert calibration.contended() == ""  # no calibration file to remove and redo
    monkeypatch.setattr(prior, "other_running", lambda: 0.0)
    assert "probed beside" not in prior.run_calibration()[1]
    # a run's own other ranks on this node are not others: its tasks run beside them too
    monkeypatch.setattr(prior, "other_running", lambda: 15.0)
    assert "probed beside" not in prior.run_calibration(own=15)[1]
    assert "probed beside ~2.0 other process(es) besides this run: likely high" in prior.run_calibration(own=13)[1]
    # a moment's wake-up in one of the two samples (before and after the probe) is no busy process
    samples = iter([2.0, 0.0])
    monkeypatch.setattr(prior, "other_running", lambda: next(samples))
    assert "probed beside" not in prior.run_calibration()[1]


@pytest.fixture
def fresh_probe(node_cache, monkeypatch):
    """No calibration cached, this process not probed yet, and a probe that measures the probe
    scenes at 2.5 x the prior's seconds, counted; the probe's cache cleared after."""
    shipped = prior.prior_calibration()
    calls = []

    def measured():
        calls.append(1)
        return {name: 2.5 * shipped.task_seconds(s) for name, s in prior.PROBE_SCENES.items()}

    prior._probed.cache_clear()
    monkeypatch.setattr(prior, "probe", measured)
    yield calls
    prior._probed.cache_clear()


def test_a_round_too_short_for_the_probe_is_estimated_by_the_prior_as_it_is(fresh_probe):
    """``start_estimate`` with ``probe_cover_s`` (an adaptive round, ``run.rounds.PROBE_COVER_S``):
    tasks estimated by the shipped prior below it a rank leave the probe for later and say the
    line is the prior's, unscaled; a round that reaches it probes, once a process, and every
    round after uses the probe's scale whatever its length."""
    from hpcontact.sweep.work.estimate import start_estimate, task_arrays
    from hpcontact.sweep.work.tasks import Task

    params = {"shape": "circle", "n": 32, "tol": 1e-6}
    tasks = [Task(key=f"k{i}", params=params, cost=4096 * 12 * 6.0, group="g") for i in range(4)]
    unscaled = float(task_arrays(tasks[:1], prior.prior_calibration())[0][0])
    assert unscaled > 0.0
    per_rank = 4 * unscaled / 2
    assert prior.probe_pending()
    line, seconds = start_estimate(tasks, 2, probe_cover_s=per_rank * 1.01)
    assert "not scaled to this machine yet" in line and "--dry-run calibrates" in line
    assert seconds.tolist() == [pytest.approx(unscaled, rel=1e-12)] * 4 and fresh_probe == []
    line, seconds = start_estimate(tasks, 2, probe_cover_s=per_rank * 0.99)
    assert "scaled x2.50 by a" in line and fresh_probe == [1] and not prior.probe_pending()
    assert seconds.tolist() == [pytest.approx(2.5 * unscaled, rel=1e-12)] * 4
    line, seconds = start_estimate(tasks, 2, probe_cover_s=per_rank * 100.0)  # probed: the scale stays
    assert "scaled x2.50 by a" in line and fresh_probe == [1]
    # a plain run's estimate probes whatever its length (its one round covers it)
    prior._probed.cache_clear()
    assert "scaled x2.50 by a" in start_estimate(tasks[:1], 64)[0] and fresh_probe == [1, 1]
