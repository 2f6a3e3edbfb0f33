"""``benchmarks/sweep_scaling.py --job``: a job as users run it on R ranks, judged against the
machine's own run on the fewest ranks (the command that measures issue 40's 16-rank bar where a
16-core machine is lent), end to end on the main job's dense map, 2 ranks then 1: it cannot fail
on that machine for want of having been run."""

from __future__ import annotations

import importlib.util
import json
import re
import subprocess
import sys

from launcher import CLEARED, ROOT, STARTS_ITS_OWN_MPIEXEC

pytestmark = STARTS_ITS_OWN_MPIEXEC


def test_a_job_on_2_and_1_ranks_is_judged_against_its_1_rank_run_and_its_data_sets_agree(tmp_path, monkeypatch):
    for name in CLEARED:
        monkeypatch.delenv(name, raising=False)
    script = ROOT / "benchmarks" / "sweep_scaling.py"
    report = tmp_path / "scaling.json"
    done = subprocess.run(
        [sys.executable, str(script), "--job", str(ROOT / "jobs" / "demo_map.toml"), "--ranks", "2", "1"]
        + ["--json", str(report), "--keep", str(tmp_path / "runs")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    runs = json.loads(report.read_text())["runs"]
    assert [(r["tasks"], r["ranks"]) for r in runs] == [("job", 2), ("job", 1)]
    assert runs[0]["attrs"]["mpi_size"] == 2 and runs[1]["attrs"]["mpi_size"] == 1
    assert runs[0]["attrs"]["sweep_solves"] == runs[1]["attrs"]["sweep_solves"] > 0
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # its harness
    spec = importlib.util.spec_from_file_location("sweep_scaling", script)
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "sweep_scaling", module)  # its dataclass looks itself up there
    spec.loader.exec_module(module)
    # the map is the same on 1 and 2 ranks: nothing but a run's own timings differs
    assert runs[0]["differs"] == [] and set(runs[1]["differs"]) <= set(module.TIMINGS)
    one = runs[1]["attrs"]["sweep_wall_time_s"]
    printed = re.findall(r"^ +(\d+) ranks: sweep (\d\.\d{3}), command", done.stdout, re.MULTILINE)
    assert printed == [("2", f"{one / (2 * runs[0]['attrs']['sweep_wall_time_s']):.3f}"), ("1", "1.000")]
    assert "beyond its timings (wall_time_s, levels, estimated_peak_bytes): none" in done.stdout
