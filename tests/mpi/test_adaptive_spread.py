"""An adaptive map on 2 ranks whose rank 1 computes leaves of rank 0's estimate between rounds,
or slabs of the sparse grid's decisions (``hpcontact.sweep.maps.spread``): the data set is
bitwise that of one process, rank 1 computed parts, and both ranks end. The task function is
exact arithmetic (no solve, whose FFT plans may differ between processes), so every bit of the
map is the estimate's.

Launches its own ``mpiexec -n 2`` (skips under a launcher), running this file as the sweep:
``python test_adaptive_spread.py SPEC OUTPUT COUNTS`` (rank R writes the box points of the parts
and the rows of the slabs it computed to COUNTS/rankR.txt).
"""

from __future__ import annotations

import io
import json
import math
import os
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from launcher import ROOT, STARTS_ITS_OWN_MPIEXEC, finish, start

SPEC = """
[sweep]
title = "adaptive map, the estimate shared out"
progress_interval = 100.0
[scene]
shape = "circle"
quantities = ["tangential"]
nu = 0.25
[axes]
anisotropy = { linspace = [0.5, 1.5, 41] }
orientation = { linspace = [0, 90, 37] }
[adaptive]
tolerance = 1e-3
quantities = ["K_xx"]
method = "{method}"
"""


def record(params):
    """K_xx with one local feature over (A, ψ) (a Gaussian bump at A = 1.3, ψ = 70°: the map
    refines and cuts its leaves there), the rest constant; exact solve errors."""
    a, psi = float(params["anisotropy"]), float(params.get("orientation", 0.0))
    xx = 2.0 + 0.2 * math.exp(-(((a - 1.3) / 0.1) ** 2) - ((psi - 70.0) / 8.0) ** 2)
    out = {"K_xx": xx, "K_yy": 2.0, "K_xy": 0.0, "K_yx": 0.0, "K_max": max(xx, 2.0), "K_min": 2.0}
    out.update(K_a_over_K_b=xx / 2.0, K_min_over_K_max=2.0 / max(xx, 2.0), iterations=1)
    out.update({f"{name}_error": 1e-12 for name in list(out) if name.startswith("K_")})
    return out


pytestmark = STARTS_ITS_OWN_MPIEXEC


@pytest.mark.parametrize("method", ["leaves", "sparse"])
def test_an_adaptive_map_on_two_ranks_shares_its_estimate_and_equals_one_process(tmp_path, launched, method):
    from hpcontact.sweep.driver import run_sweep
    from hpcontact.sweep.run.schedule import SerialTeam

    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC.replace("{method}", method))
    reference = run_sweep(
        spec, output=tmp_path / "one.nc", task_function=record, team=SerialTeam(), stream=io.StringIO()
    )
    counts = tmp_path / "counts"
    counts.mkdir()
    env = {"PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "HPCONTACT_GIT_REVISION": "test"}
    proc = start(tmp_path, [__file__, str(spec), str(tmp_path / "two.nc"), str(counts)], env=env, procs=launched)
    status, out, err = finish(proc, timeout=300)
    assert status == 0, out + err
    parts = {rank: json.loads((counts / f"rank{rank}.txt").read_text()) for rank in (0, 1)}
    kind = "leaves" if method == "leaves" else "slabs"
    assert parts[1][kind], f"rank 1 computed none of rank 0's {kind}"
    if method == "sparse":  # one slab a rank, together the anisotropy axis, in every decision
        assert parts[0]["slabs"] and all(a + b == 41 for a, b in zip(parts[0]["slabs"], parts[1]["slabs"]))
    with xr.open_dataset(tmp_path / "two.nc") as two, xr.open_dataset(reference) as one:
        assert two.attrs["adaptive_rounds"] == one.attrs["adaptive_rounds"] >= 4
        assert two.attrs["sweep_solves"] == one.attrs["sweep_solves"]
        assert set(two.data_vars) == set(one.data_vars)
        for name in sorted(set(one.data_vars) - {"wall_time_s"}):
            x, y = two[name].values, one[name].values
            same = np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f" else np.array_equal(x, y)
            assert same, name
        for attr in ("adaptive_max_map_error", "adaptive_estimate_factor", "adaptive_check_points", "adaptive_met"):
            assert two.attrs[attr] == one.attrs[attr], attr


def main(spec: str, output: str, counts: str) -> None:
    """One rank of the 2-rank run: the sweep, recording the parts this rank computed."""
    from hpcontact.sweep.driver import run_sweep
    from hpcontact.sweep.maps import spread
    from hpcontact.sweep.run.schedule import world

    team = world()
    computed: dict[str, list[int]] = {"leaves": [], "slabs": []}
    original, steps = spread.leaf_estimate, spread._slab_steps

    def counted(job):
        computed["leaves"].append(job.points)
        return original(job)

    def stepped(team, function, job, pieces):
        computed["slabs"].append(pieces[team.rank].stop - pieces[team.rank].start)
        return steps(team, function, job, pieces)

    spread.leaf_estimate, spread._slab_steps = counted, stepped
    with open(os.devnull, "w", encoding="utf-8") as sink:
        run_sweep(spec, output=output, task_function=record, team=team, stream=sink)
    Path(counts, f"rank{team.rank}.txt").write_text(json.dumps(computed))


if __name__ == "__main__":
    main(*sys.argv[1:4])
