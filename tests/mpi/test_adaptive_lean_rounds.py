"""An adaptive map's rounds on 2 ranks do only what the next round needs: rank 0 decides from the
stored stiffnesses (``dataset.stored_stiffnesses``) and makes the whole data set once, in the
last round; rank 1 never imports xarray, pandas or netCDF4 (only rank 0 makes a data set). The
map is a smooth crystal pattern (several rounds, exact arithmetic); its data set equals that
of one process.

Launches its own ``mpiexec -n 2`` (skips under a launcher), running this file as the sweep:
``python test_adaptive_lean_rounds.py SPEC OUTPUT FOLDER`` (rank R writes FOLDER/rankR.json).
"""

from __future__ import annotations

import io
import json
import math
import os
import sys
from pathlib import Path

import numpy as np
from launcher import ROOT, STARTS_ITS_OWN_MPIEXEC, finish, start

pytestmark = STARTS_ITS_OWN_MPIEXEC
HEAVY = ("xarray", "pandas", "netCDF4")

SPEC = """
[sweep]
title = "adaptive map, lean rounds"
progress_interval = 100.0
[scene]
shape = "circle"
quantities = ["tangential"]
nu = 0.25
[axes]
anisotropy = { linspace = [0.5, 2.0, 31] }
orientation = { linspace = [0, 90, 31] }
[adaptive]
tolerance = 1e-3
quantities = ["K_a_over_K_b"]
"""


def record(params):
    """A cubic crystal's K_xx/K_yy pattern over (A, ψ): 1 + 0.1 (A - 1) sin²(2ψ), smooth but
    curved, so the map takes several rounds; exact solve errors."""
    a, psi = float(params["anisotropy"]), math.radians(float(params.get("orientation", 0.0)))
    ratio = 1.0 + 0.1 * (a - 1.0) * math.sin(2.0 * psi) ** 2
    out = {"K_xx": 2.0 * ratio, "K_yy": 2.0, "K_xy": 0.0, "K_yx": 0.0, "K_a_over_K_b": ratio}
    out.update({f"{name}_error": 1e-12 for name in list(out) if name.startswith("K_")})
    return out


def test_rounds_make_one_data_set_and_rank_1_imports_no_xarray(tmp_path, launched):
    import xarray as xr

    from hpcontact.sweep.driver import run_sweep
    from hpcontact.sweep.run.schedule import SerialTeam

    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC)
    reference = run_sweep(
        spec, output=tmp_path / "one.nc", task_function=record, team=SerialTeam(), stream=io.StringIO()
    )
    env = {"PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "HPCONTACT_GIT_REVISION": "test"}
    proc = start(tmp_path, [__file__, str(spec), str(tmp_path / "two.nc"), str(tmp_path)], env=env, procs=launched)
    status, out, err = finish(proc, timeout=300)
    assert status == 0, out + err
    ranks = {rank: json.loads((tmp_path / f"rank{rank}.json").read_text()) for rank in (0, 1)}
    with xr.open_dataset(tmp_path / "two.nc") as two, xr.open_dataset(reference) as one:
        assert two.attrs["adaptive_rounds"] == one.attrs["adaptive_rounds"] >= 3
        for name in sorted(set(one.data_vars) - {"wall_time_s"}):
            x, y = two[name].values, one[name].values
            assert np.array_equal(x, y, equal_nan=True) if x.dtype.kind == "f" else np.array_equal(x, y), name
    assert ranks[0]["made"] == 1 and ranks[0]["decided"] == two.attrs["adaptive_rounds"]
    assert ranks[1] == {"made": 0, "decided": 0, "imported": []}


def main(spec: str, output: str, folder: str) -> None:
    """One rank of the 2-rank run: the sweep, counting the data sets made and the decisions'
    stiffness sets, and which of ``HEAVY`` the rank imported."""
    from hpcontact.sweep.data import dataset
    from hpcontact.sweep.driver import run_sweep
    from hpcontact.sweep.run.schedule import world

    team = world()
    calls = {"made": 0, "decided": 0}

    def counted(name: str, function):
        def call(*args, **kwargs):
            calls[name] += 1
            return function(*args, **kwargs)

        return call

    dataset.dataset_of = counted("made", dataset.dataset_of)
    dataset.stored_stiffnesses = counted("decided", dataset.stored_stiffnesses)
    with open(os.devnull, "w", encoding="utf-8") as sink:
        run_sweep(spec, output=output, task_function=record, team=team, stream=sink)
    imported = [m for m in HEAVY if m in sys.modules]
    Path(folder, f"rank{team.rank}.json").write_text(json.dumps({**calls, "imported": imported}))


if __name__ == "__main__":
    main(*sys.argv[1:4])
