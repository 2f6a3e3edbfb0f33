"""Rank 0 of an adaptive map decides its rounds without xarray and imports its data set's modules
(xarray, dask.array) in the first round whose estimated work a rank covers them
(``run.rounds.imports_array_modules``), not in a short first round the other ranks would finish
first (issue 40 item 5: the 4-D map's first round on 16 ranks waited ~1.1 s for rank 0's
announcement and imports). Each run is a fresh process: this one has imported xarray already."""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr

from hpcontact import __version__
from hpcontact.sweep.cost.calibration_file import save_calibration
from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate
from hpcontact.sweep.run.records import EVERY_TASK, RoundScope, RoundTally
from hpcontact.sweep.run.rounds import ARRAY_IMPORTS_COVER_S, imports_array_modules

HERE = Path(__file__).resolve().parent

# One process runs the Mindlin map (mindlin_map.py) with ARRAY_IMPORTS_COVER_S = @COVER@ and
# prints, for each decision after a round, whether xarray was imported by then, and each
# round's estimated task seconds a rank (as rank 0's announcement gives them).
RUN = """
import io, json, sys
sys.path.insert(0, @HERE@)
from mindlin_map import MAP, mindlin
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.maps import rounds as map_rounds
from hpcontact.sweep.run import rounds
from hpcontact.sweep.run.schedule import SerialTeam

rounds.ARRAY_IMPORTS_COVER_S = float(@COVER@)
decided, estimated = [], []
decide, announce = map_rounds.next_step, rounds._announce

def noted(*args, **kwargs):
    decided.append("xarray" in sys.modules)
    return decide(*args, **kwargs)

def announced(*args, **kwargs):
    progress, per_rank_s = announce(*args, **kwargs)
    estimated.append(per_rank_s)
    return progress, per_rank_s

map_rounds.next_step, rounds._announce = noted, announced
spec = "spec.toml"
open(spec, "w").write(MAP.replace("[sweep]", "[sweep]\\noutput = " + json.dumps(@OUTPUT@), 1))
run_sweep(spec, task_function=mindlin, team=SerialTeam(), stream=io.StringIO())
print(json.dumps({"decided": decided, "estimated": estimated, "xarray": "xarray" in sys.modules}))
"""


@pytest.fixture
def solve_calibration(tmp_path: Path) -> Path:
    """A cost-model calibration of this host and version at 10 ms a task (the sweep tests'
    ``cost_calibration`` estimates an exact cell at 0 s): every process estimates alike."""
    rates = {kind: Rate(rate_s=1e-6, solve_s=0.0, task_s=1e-2) for kind in KINDS}
    calibration = Calibration(socket.gethostname(), __version__, rates, base_bytes=100.0 * 2**20)
    return save_calibration(calibration, tmp_path / "costmodel.json")


def run_map(folder: Path, cover: float, calibration: Path) -> dict:
    """The Mindlin map in a fresh process with ``ARRAY_IMPORTS_COVER_S`` = ``cover``."""
    code = RUN
    for name, value in (("HERE", HERE), ("COVER", cover), ("OUTPUT", folder / "map.nc")):
        code = code.replace(f"@{name}@", repr(str(value)))
    folder.mkdir()
    env = {**os.environ, "HPCONTACT_COSTMODEL": str(calibration)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False, cwd=folder, env=env)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_rounds_decide_without_xarray_until_a_round_covers_its_import(tmp_path, solve_calibration):
    """Never covered (inf): every decision without xarray, the data set still made (xarray
    imported at it) and equal to the one of a run that imports in its first round (cover 0:
    every decision with xarray); covered from the second round's estimate a rank on: imported
    in the first round that reaches it (the second: every task of this map is estimated alike,
    and its first round has fewer), not before."""
    never = run_map(tmp_path / "never", math.inf, solve_calibration)
    first = run_map(tmp_path / "first", 0.0, solve_calibration)
    assert len(never["decided"]) > 2 and not any(never["decided"]) and never["xarray"]
    assert all(first["decided"]) and len(first["decided"]) == len(never["decided"])
    second = never["estimated"][1]  # the second round's estimate a rank (one rank: all of it)
    assert 0.0 < never["estimated"][0] and 0.0 < second, never
    covered = run_map(tmp_path / "second", second, solve_calibration)
    expected = [any(e >= second for e in never["estimated"][: k + 1]) for k in range(len(never["decided"]))]
    assert covered["decided"] == expected and not expected[0] and expected[1]  # the map's first round is its smaller
    with xr.open_dataset(tmp_path / "never" / "map.nc") as a, xr.open_dataset(tmp_path / "first" / "map.nc") as b:
        xr.testing.assert_equal(a.drop_vars("wall_time_s"), b.drop_vars("wall_time_s"))


def test_a_plain_run_imports_in_its_round_and_an_adaptive_round_from_the_cover():
    """A plain run's one round always imports (its data set follows); an adaptive round from
    ``ARRAY_IMPORTS_COVER_S`` seconds a rank."""
    adaptive = RoundScope(tally=RoundTally())
    assert imports_array_modules(EVERY_TASK, 0.0)
    assert not imports_array_modules(adaptive, 0.999 * ARRAY_IMPORTS_COVER_S)
    assert imports_array_modules(adaptive, ARRAY_IMPORTS_COVER_S)
