"""Partial-slip sweeps (issue 6): the pair/load/mu/q_ratio axes, the slip scene kind's solver and
validator, its cost, units and data set; one tiny real sweep (n = 24) in one process."""

from __future__ import annotations

import io
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hpcontact.errors import InputError
from hpcontact.problems import kinds
from hpcontact.problems.slip.crystal_pair import pair_from_params
from hpcontact.sweep.cost.task_cost import estimated_cost
from hpcontact.sweep.data.dataset import build_dataset
from hpcontact.sweep.data.journal import OK, Entry
from hpcontact.sweep.driver import main, run_sweep
from hpcontact.sweep.run.schedule import SerialTeam
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_tasks

ROOT = Path(__file__).resolve().parents[2]
SPEC = """
[sweep]
title = "slip test"
[scene]
quantities = "slip"
radius = 8e-3
radius2 = 9e-3
steps = 2
[numerics]
n = 24
[axes]
pair = [
    { label = "Fe-Fe", material = "Fe", material2 = "Fe" },
    { label = "Cu-Fe flat", material = "Cu", material2 = "Fe", radius2 = "flat" },
]
load = [100.0]
mu = [0.3]
q_ratio = [0.0, 0.6]
"""


def slip_spec(text: str = SPEC):
    """The spec checked by the real slip validator (the default for a slip spec)."""
    return parse_spec(text, path="slip.toml")


def refused(text: str) -> InputError:
    with pytest.raises(InputError) as info:
        slip_spec(text)
    return info.value


def test_a_spec_with_a_pair_axis_validates_with_the_slip_validator():
    spec = slip_spec()
    assert spec.kind == kinds.SLIP and spec.angle_mode == "field"
    assert [a.name for a in spec.task_axes] == ["pair", "load", "mu", "q_ratio"]
    assert spec.axis("pair").values == ("Fe-Fe", "Cu-Fe flat")
    assert spec.fixed["steps"] == 2 and isinstance(spec.fixed["steps"], int)
    params = spec.scene_params((1, 0, 0, 1))
    assert params == {
        "quantities": "slip",
        "radius": 8e-3,
        "radius2": math.inf,
        "steps": 2,
        "n": 24,
        "material": "Cu",
        "material2": "Fe",
        "load": 100.0,
        "mu": 0.3,
        "q_ratio": 0.6,
    }  # the pair table wins over the fixed radius2; nothing dropped for a slip scene
    assert spec.scene_params((0, 0, 0, 0))["radius2"] == 9e-3
    assert kinds.scene_kind({"quantities": ["slip"]}) == kinds.SLIP
    assert kinds.scene_kind({"quantities": "tangential,normal"}) == kinds.CONTACT


def test_in_a_slip_sweep_angle_is_the_load_direction_solved_per_value():
    spec = slip_spec(SPEC.replace("q_ratio = [0.0, 0.6]", "q_ratio = [0.6]\nangle = [0.0, 90.0]"))
    assert [a.name for a in spec.task_axes] == ["pair", "load", "mu", "q_ratio", "angle"]
    assert spec.scene_params((0, 0, 0, 0, 1))["angle"] == 90.0 and "shape_angle" not in spec.scene_params(
        (0, 0, 0, 0, 1)
    )
    assert len(enumerate_tasks(spec)[0]) == 4


@pytest.mark.parametrize(
    "old, new, key",
    [
        ('radius2 = "flat" }', 'radius2 = "flat", mu = -0.1 }', "axes.pair[1].mu"),
        (
            'material2 = "Fe" },\n    { label = "Cu-Fe flat"',
            'material2 = "Ti" },\n    { label = "Cu-Fe flat"',
            "axes.pair[0].material2",
        ),
        ('radius2 = "flat" }', 'radius2 = "big" }', "axes.pair[1].radius2"),
        ('{ label = "Fe-Fe", material = "Fe", material2 = "Fe" }', '"Fe-Fe"', "axes.pair[0]"),
        ('{ label = "Fe-Fe", ', "{ ", "axes.pair[0].label"),
        ('radius2 = "flat" }', 'radius2 = "flat", colour = 1 }', "axes.pair[1].colour"),
        ("q_ratio = [0.0, 0.6]", "q_ratio = [0.0, 1.0]", "axes.q_ratio"),
        ("load = [100.0]", "load = [100.0, -1.0]", "axes.load"),
        ("steps = 2", "steps = 2.5", "scene.steps"),
        ("[sweep]", '[sweep]\nangle_mode = "tensor"', "sweep.angle_mode"),
        ('quantities = "slip"', 'quantities = ["slip", "normal"]', "scene.quantities"),
    ],
)
def test_bad_slip_specs_are_refused_naming_the_key(old, new, key):
    assert old in SPEC
    assert refused(SPEC.replace(old, new, 1)).field == key


def test_the_command_line_exits_2_naming_the_pair_field(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    path = tmp_path / "bad.toml"
    path.write_text(SPEC.replace('radius2 = "flat" }', 'radius2 = "flat", mu = -0.1 }'), encoding="utf-8")
    assert main([str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "axes.pair[1].mu" in err


def test_slip_cost_follows_grid_steps_and_coupling_and_groups_ignore_the_loading():
    base = {
        "quantities": "slip",
        "radius": 8e-3,
        "material": "Fe",
        "material2": "Fe",
        "load": 10.0,
        "mu": 0.3,
        "q_ratio": 0.5,
        "n": 32,
        "steps": 4,
    }
    cost = estimated_cost(base)
    assert estimated_cost({**base, "n": 64}) > 4.0 * cost
    assert estimated_cost({**base, "steps": 8}) == pytest.approx(cost * 65.0 / 33.0)
    # coupling auto: the decoupled path and the coupled one, 0.5 x 8 digits / -log10(beta) passes
    passes = 0.5 * 8.0 / -math.log10(abs(pair_from_params({**base, "material2": "Al"}).dundurs_beta))
    assert estimated_cost({**base, "material2": "Al"}) == pytest.approx(cost * (1.0 + 32.0 * (1.0 + passes)) / 33.0)
    assert estimated_cost({**base, "material2": "Al", "coupling": "decoupled"}) == pytest.approx(cost)
    assert estimated_cost({**base, "path": "loop"}) > 4.0 * cost
    tasks, _ = enumerate_tasks(slip_spec(SPEC.replace("load = [100.0]", "load = [10.0, 100.0]")))
    assert len(tasks) == 8 and len({t.group for t in tasks}) == 2  # one kernel group per pair


def _entry(params, record):
    return Entry(key="", params=params, status=OK, message="", record=record, wall_time_s=0.1, finished=0.0, rank=0)


def _dataset(spec, record_of):
    tasks, where = enumerate_tasks(spec)
    entries = {t.key: _entry(t.params, record_of(t.params)) for t in tasks}
    return build_dataset(spec, where, entries, {})


def test_record_keys_naming_coordinates_are_left_out_when_equal_and_kept_when_not():
    spec = slip_spec(SPEC.replace("load = [100.0]", "load = [10.0, 100.0]"))
    ds = _dataset(spec, lambda p: {"load": p["load"], "tangential_stiffness": 1e7 * p["load"]})
    assert "record_load" not in ds and ds["load"].dims == ("load",) and "tangential_stiffness" in ds
    # a table that overrides an axis: the record differs from the coordinate and is kept
    text = SPEC.replace("load = [100.0]", "load = [10.0, 100.0]").replace(
        'radius2 = "flat" }', 'radius2 = "flat", load = 50.0 }'
    )
    ds = _dataset(slip_spec(text), lambda p: {"load": p["load"]})
    assert ds["record_load"].sel(pair="Cu-Fe flat").values.ravel().tolist() == [50.0] * 4
    assert ds["record_load"].attrs["units"] == "N"
    # a fixed field: the scalar coordinate stands
    ds = _dataset(
        slip_spec(SPEC.replace("load = [100.0]\n", "").replace("steps = 2", "steps = 2\nload = 100.0")),
        lambda p: {"load": p["load"]},
    )
    assert "record_load" not in ds and float(ds["load"]) == 100.0


def test_units_follow_the_scene_kind():
    slip = _dataset(slip_spec(), lambda p: {"contact_area": 1e-8, "load": p["load"], "tangential_stiffness": 1e7})
    assert slip["contact_area"].attrs["units"] == "m2" and slip["tangential_stiffness"].attrs["units"] == "N m-1"
    assert slip["load"].attrs["units"] == "N" and slip["radius2"].attrs["units"] == "m"
    assert slip.attrs["scene_kind"] == "slip" and "SI" in slip.attrs["units"]
    moduli = SPEC.replace('material = "Fe", material2 = "Fe"', "E = 2.0, E2 = 2.0").replace(
        'material = "Cu", material2 = "Fe"', "E = 1.0, E2 = 2.0"
    )
    plain = _dataset(slip_spec(moduli), lambda p: {"contact_area": 1.0})
    # input units F and L: ratios to them (units "1", the scale named)
    assert plain["contact_area"].attrs["scale"] == "L2" and plain["radius"].attrs["scale"] == "L"
    assert plain["contact_area"].attrs["units"] == "1" and plain["radius"].attrs["units"] == "1"
    # bodies by elastic constants (GPa) are SI like library materials
    iron, copper = "cubic = [230.0, 135.0, 117.0]", "cubic = [168.4, 121.4, 75.4]"
    constants = SPEC.replace('material = "Fe", material2 = "Fe"', f"{iron}, {iron.replace('cubic', 'cubic2')}").replace(
        'material = "Cu", material2 = "Fe"', f"{copper}, {iron.replace('cubic', 'cubic2')}"
    )
    crystal = _dataset(slip_spec(constants), lambda p: {"contact_area": 1e-8})
    assert crystal["contact_area"].attrs["units"] == "m2" and "SI" in crystal.attrs["units"]
    indentation = parse_spec(
        '[scene]\nquantities = ["indentation"]\nradius = 1.0\ndepth = 1e-3\n[axes]\nnu = [0.3]\n',
        validate=lambda p: None,
    )
    ds = _dataset(indentation, lambda p: {"contact_area": 1e-3, "load": 1e-4})
    assert ds["contact_area"].attrs["scale"] == "L2" and ds["load"].attrs["scale"] == "G L2"
    assert ds.attrs["scene_kind"] == "contact"


@pytest.fixture(scope="module")
def tiny_sweep(tmp_path_factory):
    """The tiny real sweep of SPEC (4 scenes at n = 24, ~2 s) in one process: (data set path, output)."""
    folder = tmp_path_factory.mktemp("slip")
    spec = folder / "slip.toml"
    spec.write_text(SPEC.replace("[sweep]", f'[sweep]\noutput = "{folder / "slip.nc"}"'), encoding="utf-8")
    stream = io.StringIO()
    path = run_sweep(spec, team=SerialTeam(), stream=stream)  # default task function: the kind's
    return path, stream.getvalue()


def test_a_tiny_slip_sweep_writes_the_data_set(tiny_sweep):
    path, text = tiny_sweep
    assert "4 tasks, 4 to run" in text and "0 failed" in text
    with xr.open_dataset(path) as ds:
        assert dict(ds.sizes) == {"pair": 2, "load": 1, "mu": 1, "q_ratio": 2}
        assert ds["pair"].values.tolist() == ["Fe-Fe", "Cu-Fe flat"]
        assert (ds.status == OK).all()
        assert ds["radius2"].dims == ("pair",) and ds["radius2"].values.tolist() == [9e-3, math.inf]
        assert ds["material2"].values.tolist() == ["Fe", "Fe"] and float(ds["radius"]) == 8e-3
        names = (
            "tangential_force",
            "tangential_displacement",
            "tangential_stiffness",
            "stick_area",
            "contact_area",
            "stick_area_stiffness",
            "no_slip_stiffness",
            "stiffness_ratio",
            "mindlin_stiffness",
            "normal_stiffness",
            "decoupled_tangential_stiffness",
            "coupling_effect_displacement",
            "iterations",
            "wall_time_s",
            "plan",
        )
        for name in names:
            assert ds[name].dims == ("pair", "load", "mu", "q_ratio"), name
        assert "record_load" not in ds and ds["load"].values.tolist() == [100.0]
        assert ds["tangential_stiffness"].attrs["units"] == "N m-1" and ds["stick_area"].attrs["units"] == "m2"
        point = ds.sel(load=100.0, mu=0.3)
        # Q = 0: k_t is the no-slip stiffness; the coupled-decoupled δ difference of two zeros is 0
        np.testing.assert_allclose(
            point.tangential_stiffness.sel(q_ratio=0.0), point.no_slip_stiffness.sel(q_ratio=0.0)
        )
        assert float(point.coupling_effect_displacement.sel(pair="Cu-Fe flat", q_ratio=0.0)) == 0.0
        # Q = 0.6 mu P: Mindlin–Deresiewicz k_t/k_t(0) = (1 − 0.6)^(1/3) to the grid's accuracy (n = 24)
        np.testing.assert_allclose(point.stiffness_ratio.sel(q_ratio=0.6), np.cbrt(0.4), rtol=0.03)
        np.testing.assert_allclose(point.tangential_force.sel(q_ratio=0.6), 0.6 * 0.3 * 100.0, rtol=1e-6)
        # similar pair: no decoupled answer
        assert np.isnan(point.decoupled_tangential_stiffness.sel(pair="Fe-Fe")).all()
        assert ds.attrs["scene_kind"] == "slip" and ds.attrs["mpi_size"] == 1
        # one grid per scene: no error estimate, said by NaN and the flag (docs/reference/dataset.md)
        assert (ds["error_status"] == 2).all() and ds["error_status"].attrs[
            "flag_meanings"
        ] == "met not_met no_estimate"
        for name in ("tangential_stiffness", "no_slip_stiffness", "stick_area_stiffness"):
            assert np.isnan(ds[f"{name}_error"]).all(), name
            assert ds[name].attrs["ancillary_variables"] == f"{name}_error error_status", name
        assert "mindlin_stiffness_error" not in ds and "normal_stiffness_error" not in ds  # closed forms


def test_the_postprocess_script_reads_the_sweep_data_set(tiny_sweep, tmp_path):
    path, _ = tiny_sweep
    script = ROOT / "postprocess" / "slip_stiffness.py"
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "MPLBACKEND": "Agg"}
    done = subprocess.run(
        [sys.executable, str(script), str(path), str(tmp_path / "fig"), "--n-ellipse", "0"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in (tmp_path / "fig").iterdir()) == ["kt_ratio.png", "kt_vs_q.png", "stick_zones.png"]
    assert "4/4 points ok" in done.stdout and "Cu-Fe flat" in done.stdout


def test_the_postprocess_script_draws_a_users_own_slip_sweep(tmp_path):
    """A slip sweep of one pair over mu and q_ratio (no pair or load axis: not the seed's
    layout) gets the figure that needs only q_ratio, k_t/k_t(0), one curve per mu, and one line
    saying why the others are not drawn; before, the script refused it."""
    spec = tmp_path / "own.toml"
    text = SPEC.replace("[sweep]", f'[sweep]\noutput = "{tmp_path / "own.nc"}"')
    text = text.replace("steps = 2", 'steps = 2\nmaterial = "Fe"\nmaterial2 = "Fe"\nload = 100.0')
    text = text[: text.index("pair = [")] + "mu = [0.2, 0.4]\nq_ratio = [0.0, 0.6]\n"
    spec.write_text(text, encoding="utf-8")
    path = run_sweep(spec, team=SerialTeam(), stream=io.StringIO())
    script = ROOT / "postprocess" / "slip_stiffness.py"
    env = {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{os.environ.get('PYTHONPATH', '')}", "MPLBACKEND": "Agg"}
    done = subprocess.run(
        [sys.executable, str(script), str(path), str(tmp_path / "fig")],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in (tmp_path / "fig").iterdir() if p.suffix == ".png") == ["kt_ratio.png"]
    assert "drew kt_ratio.png alone" in done.stdout and "lacks: pair, load" in done.stdout
