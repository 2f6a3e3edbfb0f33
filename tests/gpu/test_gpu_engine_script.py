"""The device run's benchmarks (benchmarks/gpu_engine.py, benchmarks/batched_scenes.py) end to end on a
stand-in GPU (``stub_cupy.use_standin_gpu``: array-api-strict's arrays behind CuPy's device calls), at
small sizes: every table the device run needs is made and written, so the scripts cannot fail on the
GPU machine for want of having been run. Not marked ``gpu``: they run everywhere. What they time here
is the CPU under two namespaces: no GPU figure."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

from stub_cupy import use_standin_gpu

ROOT = Path(__file__).resolve().parents[2]
SPEC = """
[sweep]
title = "main"
[scene]
shape = "circle"
quantities = ["tangential", "normal"]
[numerics]
n = 12
[axes]
nu = [0.2, 0.4]
"""


def _script(name: str = "gpu_engine"):
    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_every_table_of_the_device_run_is_made_on_a_standin_gpu(monkeypatch, tmp_path, capsys):
    use_standin_gpu(monkeypatch)
    script = _script()
    monkeypatch.setattr(script, "ACCURACY_SHAPES", script.ACCURACY_SHAPES[1:2])  # the triangle alone
    monkeypatch.setattr(script, "ACCURACY_NUS", (0.3,))
    (tmp_path / "main.toml").write_text(SPEC, encoding="utf-8")
    output = tmp_path / "gpu_engine.json"
    argv = ["--n", "12", "--large", "16", "--iteration-n", "8", "--accuracy", "0.3", "--repeat", "1"]
    assert (
        script.main([*argv, "--main-job", str(tmp_path / "main.toml"), "--main-every", "1", "--json", str(output)]) == 0
    )
    results = json.loads(output.read_text(encoding="utf-8"))
    assert json.loads(capsys.readouterr().out) == results
    assert set(results) == {"machine", "done_when", *script.TABLES}
    assert results["machine"]["devices"][0] == "cpu, gpu (1)"
    assert results["solve"]["speedup"] > 0.0 and results["solve"]["K_zz_relative_difference"] < 1e-8
    assert results["large"]["best_s"] > 0.0 and math.isfinite(results["large"]["K_zz"])
    (row,) = results["accuracy"]
    assert "error" not in row and row["seconds"] > 0.0 and row["accuracy_met"] in (True, False) and row["grids"]
    batch = results["accuracy_batch"]
    assert batch["failed"] == 0 and batch["seconds"] > 0.0
    (batched,) = batch["rows"]  # the same scene's grid sequence in a batch: the same grids, its record
    assert (batched["grids"], batched["stopped_by"]) == (row["grids"], row["stopped_by"])
    assert batched["relative_difference_from_alone"] < 1e-8  # CG to tol 1e-8 on both paths, as the rows above
    main = results["main"]
    assert (main["tasks"], main["failed"]) == (2, 0) and main["largest_relative_difference"] < 1e-8
    assert main["batch_sizes"] == [2] and main["gpu_batched_s"] > 0.0  # the demo's two tasks: one group
    assert results["iteration"][0]["ratio"] > 0.0
    slip = results["slip"]  # the stand-in GPU (array-api-strict, numpy underneath) against pyFFTW
    assert slip["gpu_s"] > 0.0 and slip["largest_relative_difference"] < 1e-12 and slip["same_stick_area"]
    # the sizes were not run: no speed point is judged, but the main job's (a spec of 2 tasks)
    assert [v for k, v in results["done_when"].items() if not k.startswith("main")] == [None, None, None]
    assert isinstance(results["done_when"]["main_job_gpu_at_most_1_30_of_one_core"], bool)


def test_without_a_gpu_it_exits_2_in_one_line(monkeypatch, capsys):
    from hpcontact.numerics import backend

    monkeypatch.setattr(backend, "cuda_devices", lambda: (None, 0, "CuPy is not installed"))
    assert _script().main([]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "CuPy is not installed" in err


def test_batched_scenes_on_a_standin_gpu_measures_both_devices(monkeypatch, tmp_path):
    use_standin_gpu(monkeypatch)
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # its harness
    output = tmp_path / "batched.json"
    argv = ["--device", "cpu", "gpu", "--n", "8", "--batch", "3", "--clock", "wall", "--json", str(output)]
    assert _script("batched_scenes").main(argv) == 0
    rows = json.loads(output.read_text(encoding="utf-8"))["rows"]
    assert [(r["device"], r["scenes"]) for r in rows] == [("cpu", 3), ("gpu", 3)]
    for row in rows:
        assert row["batch_us_per_scene_iteration"] > 0.0 and row["force_relative_difference"] < 1e-6
    assert rows[1]["gpu_pool_bytes"] == 0  # the stand-in's pool
