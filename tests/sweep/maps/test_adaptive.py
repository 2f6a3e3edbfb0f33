"""Adaptive maps (hpcontact.sweep.maps): the [adaptive] table, the rounds, the data set,
resume without solving a point twice.

The map tests solve with a stand-in for the solver: Mindlin's closed form (hpcontact.analytic)
times a deterministic relative perturbation of at most 5e-5 (half the solve error that
``[numerics] accuracy = 1e-4`` allows), reported with ``<name>_error`` = 1e-4, as a solve to
that accuracy reports it. The full check with the real solver (861 points, the same thresholds)
is benchmarks/adaptive_maps.py (minutes: too slow for this suite).
"""

from __future__ import annotations

import functools
import hashlib
import io
import math
import sys

import numpy as np
import pytest
import xarray as xr

from hpcontact.analytic import mindlin_ellipse_stiffness
from hpcontact.errors import InputError
from hpcontact.sweep.data.journal import ERROR, read_journals
from hpcontact.sweep.maps import estimates
from hpcontact.sweep.maps.checks import MAX_CHECKS, MIN_CHECKS, check_count, drawn_checks
from hpcontact.sweep.maps.estimates import Checks, Layout
from hpcontact.sweep.maps.rounds import distinct_tasks, dry_run_text
from hpcontact.sweep.maps.state import initial_state, state_points, state_tasks
from hpcontact.sweep.run.records import Options, runner_name
from hpcontact.sweep.run.rounds import execute
from hpcontact.sweep.run.schedule import SerialTeam
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_part, enumerate_tasks, join_parts

MINDLIN = """
[sweep]
title = "Mindlin's map"
progress_interval = 100.0
[scene]
shape = "ellipse"
quantities = ["tangential"]
[numerics]
accuracy = 1e-4
[axes]
aspect = { logspace = [0, -4, 41] }
nu = { linspace = [0, 0.5, 21] }
angle = { linspace = [0, 180, 7] }
[adaptive]
tolerance = 1e-3
"""
NOISE = 5e-5
SOLVE_ERROR = 1e-4


def _wiggle(params, name: str) -> float:
    """A deterministic relative perturbation in [-NOISE, NOISE] of the scene and quantity."""
    text = f"{params.get('shape')} {params.get('aspect')} {params.get('nu')} {name}".encode()
    return 1.0 + NOISE * (2.0 * int(hashlib.sha1(text).hexdigest()[:8], 16) / 0xFFFFFFFF - 1.0)


def mindlin(params):
    """Mindlin's ellipse (K_xx = K_a along the long axis) as a solve to accuracy 1e-4 reports it;
    a rectangle (for the categorical test) is the ellipse's tensor plus 1 (a jump between shapes)."""
    ka, kb = mindlin_ellipse_stiffness(1.0, float(params.get("aspect", 1.0)), 1.0, float(params["nu"]))
    ka, kb = float(ka), float(kb)
    if params.get("shape") == "rectangle":
        ka, kb = ka + 1.0, kb + 1.0
    exact = {"K_xx": ka, "K_yy": kb, "K_max": kb, "K_min": ka, "K_a_over_K_b": ka / kb, "K_min_over_K_max": ka / kb}
    record = {name: value * _wiggle(params, name) for name, value in exact.items()}
    record.update(K_xy=0.0, K_yx=0.0, estimated_error=SOLVE_ERROR, accuracy_met="true", iterations=5)
    record.update({f"{name}_error": SOLVE_ERROR for name in [*exact, "K_xy", "K_yx"]})
    return record


def counting(calls):
    """``mindlin``, its calls listed: the same runner (``functools.wraps``: its name), so a resume
    or an up-to-date check with it reuses the journals of a run with ``mindlin``."""

    @functools.wraps(mindlin)
    def task(params):
        calls.append(dict(params))
        return mindlin(params)

    return task


def exact_map(ds: xr.Dataset) -> dict[str, np.ndarray]:
    ka, kb = mindlin_ellipse_stiffness(1.0, ds["aspect"].values[:, None], 1.0, ds["nu"].values[None, :])
    return {"K_xx": ka, "K_yy": kb, "K_max": kb, "K_min": ka, "K_a_over_K_b": ka / kb, "K_min_over_K_max": ka / kb}


def test_mindlin_map_within_tolerance_with_honest_estimates_and_few_solves(sweep, write_spec):
    """Issue 27's done-when on the stand-in: 41 x 21 points, every one within 1e-3 of Mindlin's
    closed form, the map-error estimate >= the true error at >= 95 % of the points, <= 172
    solves (20 % of the grid)."""
    calls: list = []
    ds = xr.open_dataset(sweep(write_spec(MINDLIN), counting(calls)))
    assert ds.attrs["sweep_solves"] == len(calls) == int(ds["solved"].sum()) <= 172
    assert len({(c["aspect"], c["nu"]) for c in calls}) == len(calls)  # none twice
    for name, exact in exact_map(ds).items():
        true = np.abs(ds[name].values / exact - 1.0)
        assert true.max() <= 1e-3, name
        assert np.mean(ds[f"{name}_map_error"].values >= true) >= 0.95, name
        assert ds[f"{name}_map_error"].max() <= 1e-3  # the tolerance met by the estimate
    assert ds.attrs["adaptive_max_map_error"] <= 1e-3
    # the summary is of every round: tasks run and task time summed, set-up per round (not the
    # time since the run began, which counted the earlier rounds' tasks as set-up)
    assert ds.attrs["adaptive_rounds"] >= 2
    assert ds.attrs["sweep_tasks_run"] == len(calls) and ds.attrs["sweep_tasks_reused"] == 0
    assert ds.attrs["sweep_task_time_s"] == pytest.approx(float(ds["wall_time_s"].where(ds["solved"] == 1).sum()))
    spent = ds.attrs["sweep_setup_time_s"] + ds.attrs["sweep_task_time_s"]
    assert spent <= ds.attrs["sweep_wall_time_s"] and 0.0 < ds.attrs["sweep_parallel_efficiency"] <= 1.0


def test_the_data_set_has_the_full_sweeps_variables_and_marks_the_solved_points(sweep, write_spec, tmp_path):
    small = MINDLIN.replace("[0, -4, 41]", "[0, -4, 9]").replace("[0, 0.5, 21]", "[0, 0.5, 5]")
    adaptive = xr.open_dataset(
        sweep(write_spec(small.replace("tolerance = 1e-3", "tolerance = 0.5\nchecks = 0")), mindlin)
    )
    full_text = small.split("[adaptive]")[0]
    full = xr.open_dataset(sweep(write_spec(full_text, "full.toml"), mindlin, output=tmp_path / "full.nc"))
    extra = {"solved", *(f"{n}_map_error" for n in full.data_vars if f"{n}_error" in full.data_vars)}
    assert set(adaptive.data_vars) == set(full.data_vars) | extra
    for name in full.data_vars:
        assert adaptive[name].dims == full[name].dims, name
    solved = adaptive["solved"].values.astype(bool)
    assert solved.sum() == 25 and adaptive.attrs["sweep_solves"] == 25  # the first round met tolerance 0.5
    assert adaptive["solved"].dtype == np.int32  # netCDF integers are int32, as status
    assert list(adaptive["solved"].attrs["flag_values"]) == [0, 1]
    assert adaptive["solved"].attrs["flag_meanings"] == "interpolated solved"
    assert adaptive["K_xx"].attrs["ancillary_variables"] == "K_xx_error error_status K_xx_map_error solved"
    assert "K_nn_map_error" in adaptive["K_nn"].attrs["ancillary_variables"]
    for name in ("K_xx", "K_a_over_K_b", "K_xx_error"):
        np.testing.assert_array_equal(adaptive[name].values[solved], full[name].values[solved])
        assert np.all(np.isfinite(adaptive[name].values))
    np.testing.assert_array_equal(adaptive["K_xx_map_error"].values[solved], SOLVE_ERROR)  # no interpolation error
    assert np.all(adaptive["K_xx_map_error"].values[~solved] > SOLVE_ERROR)
    assert np.all(adaptive["status"].values == 0)
    assert set(adaptive["message"].values[~solved]) == {"interpolated (adaptive map)"}
    assert np.all(np.isnan(adaptive["iterations"].values[~solved]))  # no solve, no diagnostics
    assert adaptive["K_nn"].dims == full["K_nn"].dims


def test_categorical_axes_are_separate_sub_problems(sweep, write_spec):
    """A shape axis is never interpolated across: the rectangle's jump of +1 leaves the
    ellipse's map as accurate as alone, and each shape gets its own nodes."""
    text = MINDLIN.replace('shape = "ellipse"\n', "").replace("[axes]\n", '[axes]\nshape = ["ellipse", "rectangle"]\n')
    text = text.replace("[0, -4, 41]", "[0, -4, 17]").replace("[0, 0.5, 21]", "[0, 0.5, 9]")
    ds = xr.open_dataset(sweep(write_spec(text), mindlin))
    exact = exact_map(ds.sel(shape="ellipse"))
    for shape, offset in (("ellipse", 0.0), ("rectangle", 1.0)):
        true = np.abs(ds["K_xx"].sel(shape=shape).values / (exact["K_xx"] + offset) - 1.0)
        assert true.max() <= 1e-3, shape
    assert ds["solved"].sel(shape="ellipse").sum() >= 25 and ds["solved"].sel(shape="rectangle").sum() >= 25


def test_an_interrupted_adaptive_sweep_resumes_without_solving_twice(sweep, write_spec, tmp_path):
    class Interrupted(BaseException):
        pass

    text = MINDLIN.replace("[0, -4, 41]", "[0, -4, 17]").replace("[0, 0.5, 21]", "[0, 0.5, 9]")
    spec = write_spec(text)
    reference = xr.open_dataset(sweep(spec, mindlin, output=tmp_path / "reference.nc"))
    assert reference.attrs["adaptive_rounds"] >= 2
    first_round = 25
    calls: list = []

    @functools.wraps(mindlin)
    def dies(params):
        if len(calls) == first_round + 3:  # in the second round
            raise Interrupted
        calls.append(dict(params))
        return mindlin(params)

    with pytest.raises(Interrupted):
        sweep(spec, dies)
    journaled = set(read_journals(tmp_path / "out.nc.journal"))
    assert len(journaled) == first_round + 3
    again: list = []
    resumed = xr.open_dataset(sweep(spec, counting(again), resume=True))
    keys = {t.key: t for t in enumerate_tasks(parse_spec(text, check_scenes=False))[0]}
    rerun = {k for k, t in keys.items() if dict(t.params) in again}
    assert not rerun & journaled, "a journaled task was solved again"
    assert len(again) + len(journaled) == resumed.attrs["sweep_solves"] == reference.attrs["sweep_solves"]
    assert (resumed.attrs["sweep_tasks_run"], resumed.attrs["sweep_tasks_reused"]) == (len(again), len(journaled))
    for name in reference.data_vars:
        if name not in ("wall_time_s",):
            xr.testing.assert_equal(resumed[name], reference[name])


def test_a_failed_solve_is_recorded_and_the_map_around_it_still_meets_tolerance(sweep, write_spec):
    """A scene that fails (a node of the first round: b/a = 1e-2, nu = 0.25) keeps its status
    and message in the data set and is not solved again; the lines through it interpolate from
    their other nodes, so every other point is filled and within tolerance of Mindlin's closed
    form. Before, the failure made 837 of the 861 points NaN after the first round, the map
    stopped there and its reported largest map error was the solves' 1e-4; and the failed point
    itself showed as not computed, its message lost."""
    calls: list = []

    def fails_once(params):
        calls.append(dict(params))
        if math.isclose(float(params["aspect"]), 1e-2) and math.isclose(float(params["nu"]), 0.25):
            raise RuntimeError("this scene fails")
        return mindlin(params)

    ds = xr.open_dataset(sweep(write_spec(MINDLIN), fails_once))
    failed = ds["status"].values == ERROR
    assert failed.sum() == 1 and ds.attrs["sweep_failures"] == 1
    assert np.all(ds["message"].values[failed] == "RuntimeError: this scene fails")
    assert len(calls) == ds.attrs["sweep_solves"] and ds.attrs["adaptive_points_not_interpolated"] == 0
    for name, exact in exact_map(ds).items():
        true = np.abs(ds[name].values / exact - 1.0)
        assert np.all(np.isnan(true[failed])) and np.nanmax(true) <= 1e-3, name
        assert np.nanmax(ds[f"{name}_map_error"].values) <= 1e-3


def test_a_finished_adaptive_sweep_run_again_is_up_to_date(sweep, write_spec, tmp_path):
    """As a finished plain sweep (tests/sweep/run/test_driver.py): run again as `hpcontact run` runs
    it, nothing is solved and the file is left as it is; it needed --resume before."""
    spec = write_spec(MINDLIN)
    path = sweep(spec, mindlin)
    data, solves = path.read_bytes(), xr.open_dataset(path).attrs["sweep_solves"]
    calls, stream = [], io.StringIO()
    same_runner = Options(up_to_date=True, runner=runner_name(mindlin))  # as run_sweep names it
    outcome = execute(spec, None, counting(calls), team=SerialTeam(), stream=stream, options=same_runner)
    assert outcome.up_to_date and calls == [] and path.read_bytes() == data
    assert stream.getvalue().endswith(
        f"hpcontact: {path} is up to date ({solves} tasks from journals); nothing to do\n"
    )


@pytest.mark.parametrize(
    "table, field",
    [
        ("", "adaptive.tolerance"),
        ("tolerance = 0", "adaptive.tolerance"),
        ("tolerance = 0.9", "adaptive.tolerance"),
        ('tolerance = "1e-3"', "adaptive.tolerance"),
        ("tolerance = 1e-3\nmax_solves = 10", "adaptive.max_solves"),
        ("tolerance = 1e-3\nmax_solves = 100.5", "adaptive.max_solves"),
        ("tolerance = 1e-3\nsteps = 3", "adaptive.steps"),
        ('tolerance = 1e-3\nquantities = ["iterations"]', "adaptive.quantities"),
        ("tolerance = { K_xx = 2.0 }", "adaptive.tolerance.K_xx"),
        ("tolerance = 1e-3\ninitial = 1", "adaptive.initial"),
        ('tolerance = 1e-3\nlog = ["shape"]', "adaptive.log"),
        ('tolerance = 1e-3\nlog = ["nu"]', "adaptive.log"),  # nu = 0 has no log
    ],
)
def test_bad_adaptive_tables_are_refused_naming_the_field(table, field):
    text = MINDLIN.replace('[sweep]\ntitle = "Mindlin\'s map"', '[sweep]\ntitle = "x"').replace(
        "[adaptive]\ntolerance = 1e-3\n", f"[adaptive]\n{table}\n"
    )
    with pytest.raises(InputError) as refused:
        parse_spec(text, check_scenes=False)
    assert refused.value.field == field


def test_a_spec_without_a_numeric_axis_to_interpolate_is_refused():
    text = '[scene]\nquantities = ["tangential"]\n[axes]\nshape = ["circle", "ellipse"]\nnu = [0.1, 0.3]\n'
    with pytest.raises(InputError) as refused:
        parse_spec(text + "[adaptive]\ntolerance = 1e-3\n", check_scenes=False)
    assert refused.value.field == "adaptive"


def test_settings_scales_first_round_and_dry_run_line():
    spec = parse_spec(MINDLIN.replace("tolerance = 1e-3", "tolerance = 1e-3\nmax_solves = 172"), check_scenes=False)
    layout = Layout.of(spec)
    assert [spec.task_axes[p].name for p in layout.numeric] == ["aspect", "nu"]
    assert [s.value for s in layout.scales] == ["log", "linear"]  # angle is derived: no task axis
    np.testing.assert_allclose(layout.xs[0], np.linspace(0, -4, 41), atol=1e-12)
    tasks, where = enumerate_tasks(spec)
    task_of = np.array(
        [[tasks.index(next(t for t in tasks if t.key == where[(i, j)])) for j in range(21)] for i in range(41)]
    )
    assert len(state_tasks(layout, initial_state(layout, spec.adaptive), task_of)) == 25
    line = dry_run_text(spec, task_of)
    assert "first round 25 of the 861 tasks" in line and "at most 172 (max_solves)" in line
    assert "aspect (log), nu (linear)" in line
    # with each task's estimated seconds: the first round's (its 25 tasks'), not the bound's
    seconds = np.arange(len(tasks), dtype=float)
    first = state_tasks(layout, initial_state(layout, spec.adaptive), task_of)
    assert f"estimated {seconds[first].sum():.4g} core-seconds)" in dry_run_text(spec, task_of, seconds)
    seconds[first[0]] = np.nan  # a GPU task the model does not estimate: said, not summed as NaN
    assert "not all estimated" in dry_run_text(spec, task_of, seconds)


def test_a_quantity_the_scenes_do_not_store_is_refused(sweep, write_spec):
    text = MINDLIN.replace("[0, -4, 41]", "[0, -4, 5]").replace("[0, 0.5, 21]", "[0, 0.5, 3]")
    with pytest.raises(InputError) as refused:
        sweep(write_spec(text.replace("tolerance = 1e-3", 'tolerance = 1e-3\nquantities = ["K_zz"]')), mindlin)
    assert refused.value.field == "adaptive.quantities" and refused.value.value == "K_zz"


def test_max_solves_bounds_the_solves(sweep, write_spec):
    calls: list = []
    ds = xr.open_dataset(
        sweep(write_spec(MINDLIN.replace("tolerance = 1e-3", "tolerance = 1e-6\nmax_solves = 60")), counting(calls))
    )
    assert len(calls) == ds.attrs["sweep_solves"] <= 60
    assert ds.attrs["adaptive_max_solves"] == 60


def test_a_commit_during_the_rounds_does_not_make_their_own_journals_stale(sweep, write_spec, monkeypatch):
    """The git revision is read once per adaptive sweep: a commit in the checkout between two
    rounds (another revision on every later read) must not refuse the rounds' own journals."""
    import itertools
    import os

    from hpcontact.sweep.data import provenance

    counter = itertools.count()
    monkeypatch.delenv(provenance.REVISION_VARIABLE, raising=False)
    monkeypatch.setattr(
        provenance, "git_revision", lambda: os.environ.get(provenance.REVISION_VARIABLE) or f"rev{next(counter)}"
    )
    calls: list = []
    ds = xr.open_dataset(sweep(write_spec(MINDLIN), counting(calls)))
    assert ds.attrs["adaptive_rounds"] >= 2 and ds.attrs["sweep_solves"] == len(calls)
    assert provenance.REVISION_VARIABLE not in os.environ  # restored after the sweep


def test_checks_make_an_estimator_tuned_too_low_honest_again(sweep, write_spec, monkeypatch, tmp_path):
    """A map nobody tuned the estimate to, made here by tuning it wrong: the factor on the
    interpolation estimate at 0.1 instead of 1.5 (15x too small). Without checks the map
    claims its tolerance and is dishonest at most interpolated points; the check rounds
    (random solves compared with the interpolant) raise the factor until they hold, the
    refinement goes on with it, and the map is honest at >= 95 % of its points and within
    its tolerance of Mindlin's closed form everywhere."""
    monkeypatch.setattr(estimates, "SAFETY", 0.1)
    text = MINDLIN.replace("tolerance = 1e-3", "tolerance = 1e-4").replace("accuracy = 1e-4", "accuracy = 1e-6")
    monkeypatch.setattr(sys.modules[__name__], "SOLVE_ERROR", 1e-6)
    monkeypatch.setattr(sys.modules[__name__], "NOISE", 1e-7)
    plain = write_spec(text.replace("tolerance = 1e-4", "tolerance = 1e-4\nchecks = 0"), "plain.toml")
    unchecked = xr.open_dataset(sweep(plain, mindlin, output=tmp_path / "plain.nc"))
    checked = xr.open_dataset(sweep(write_spec(text), mindlin))
    exact = exact_map(checked)
    for ds, honest in ((unchecked, False), (checked, True)):
        true = np.abs(ds["K_yy"].values / exact["K_yy"] - 1.0)
        share = float(np.mean(ds["K_yy_map_error"].values >= true))
        assert (share >= 0.95) == honest, share
    assert checked.attrs["adaptive_check_rounds"] >= 2 and checked.attrs["adaptive_estimate_factor"] > 0.1
    rounds = checked.attrs["adaptive_check_rounds"]
    assert checked.attrs["adaptive_check_points"] >= rounds * MIN_CHECKS and checked.attrs["adaptive_met"] == 1
    for name, value in exact.items():
        assert np.max(np.abs(checked[name].values / value - 1.0)) <= 1e-4, name


def test_check_points_are_reproducible_unsolved_and_bounded_by_max_solves():
    """Every rank and a resumed run draw the same check points; none is a task already solved;
    ``max_solves`` counts them."""
    text = MINDLIN.replace("tolerance = 1e-3", "tolerance = 1e-3\nmax_solves = 40\nchecks = 30")
    spec = parse_spec(text, check_scenes=False)
    layout = Layout.of(spec)
    task_of = join_parts(spec, [enumerate_part(spec)])[1]
    state = initial_state(layout, spec.adaptive)
    first = drawn_checks(layout, spec.adaptive, state, Checks(), task_of)
    again = drawn_checks(layout, spec.adaptive, state, Checks(), task_of)
    assert first == again and first.pending and len(first.points) == 40 - 25
    nodes = set(np.asarray(task_of).ravel()[state_points(layout, state)].tolist())
    assert not nodes & set(np.asarray(task_of).ravel()[list(first.points)].tolist())
    assert len(state_tasks(layout, state, task_of, first)) == 40
    full = drawn_checks(layout, spec.adaptive, state, first, task_of)
    assert full == first  # no room left: nothing drawn


def test_a_check_round_draws_a_tenth_of_the_nodes_within_bounds_unless_the_spec_sets_it():
    """By default the random checks of a sub-problem are ⌈nodes / 10⌉, at least MIN_CHECKS and at
    most MAX_CHECKS; ``checks = N`` draws N (0: no check round)."""
    default = parse_spec(MINDLIN, check_scenes=False).adaptive
    assert default.checks is None
    assert [check_count(default, n) for n in (25, 100, 101, 250, 300, 10_000)] == [10, 10, 11, 25, 30, 30]
    assert (MIN_CHECKS, MAX_CHECKS) == (10, 30)
    for n in (0, 7, 300):
        settings = parse_spec(
            MINDLIN.replace("tolerance = 1e-3", f"tolerance = 1e-3\nchecks = {n}"), check_scenes=False
        )
        assert [check_count(settings.adaptive, nodes) for nodes in (25, 1000)] == [n, n]
    spec = parse_spec(MINDLIN, check_scenes=False)
    layout = Layout.of(spec)
    task_of = join_parts(spec, [enumerate_part(spec)])[1]
    drawn = drawn_checks(layout, spec.adaptive, initial_state(layout, spec.adaptive), Checks(), task_of)
    assert len(drawn.points) == MIN_CHECKS  # 25 nodes in the first round


def test_the_run_says_whether_the_map_met_its_tolerance(sweep, write_spec, tmp_path):
    """The last line of an adaptive run: met or not, the worst map error, where, the solves."""
    out = io.StringIO()
    sweep(write_spec(MINDLIN), mindlin, stream=out)
    last = out.getvalue().strip().splitlines()[-1]
    assert last.startswith("hpcontact: adaptive map met its tolerance (0.001): worst map error ")
    assert " at aspect = " in last and "solves for 861 points" in last and "random check point(s)" in last
    out = io.StringIO()
    capped = MINDLIN.replace("tolerance = 1e-3", "tolerance = 1e-6\nmax_solves = 60")
    sweep(write_spec(capped, "capped.toml"), mindlin, stream=out, output=tmp_path / "capped.nc")
    assert "adaptive map did NOT meet its tolerance (1e-06)" in out.getvalue().strip().splitlines()[-1]


CROSSING = """
[sweep]
title = "a tensor whose principal values cross"
progress_interval = 100.0
[scene]
shape = "circle"
quantities = ["tangential"]
nu = 0.25
[axes]
anisotropy = { linspace = [0.5, 1.5, 41] }
orientation = { linspace = [0, 90, 19] }
[adaptive]
tolerance = 1e-3
"""


def crossing(params):
    """A stand-in of a circle on a cubic crystal: K = 2 I + t [[cos 2ψ, sin 2ψ], [sin 2ψ,
    −cos 2ψ]] with t = (A − 1)/4 (an isotropic body at A = 1), so K_max,min = 2 ± |t|: the
    principal values and K_min/K_max have a kink at A = 1, the tensor none."""
    t = (float(params.get("anisotropy", 1.0)) - 1.0) / 4.0
    psi = math.radians(float(params.get("orientation", 0.0)))
    xx, yy, xy = 2.0 + t * math.cos(2 * psi), 2.0 - t * math.cos(2 * psi), t * math.sin(2 * psi)
    k_max, k_min = 2.0 + abs(t), 2.0 - abs(t)
    record = {"K_xx": xx, "K_yy": yy, "K_xy": xy, "K_yx": xy, "K_max": k_max, "K_min": k_min}
    record.update(K_a_over_K_b=xx / yy, K_min_over_K_max=k_min / k_max, iterations=1)
    record.update({f"{name}_error": 1e-12 for name in list(record) if name.startswith("K_")})
    return record


def test_principal_values_come_from_the_interpolated_tensor_across_their_kink(sweep, write_spec, tmp_path, monkeypatch):
    """K_min/K_max = (2 − |t|)/(2 + |t|) has a kink at A = 1 that no polynomial interpolant
    follows; the tensor is linear in A. Derived from the interpolated tensor, the map is within
    its tolerance everywhere with an honest map error, in fewer solves than interpolating the
    principal values themselves (there the checks see the kink and the map refines around it)."""
    path = sweep(write_spec(CROSSING), crossing)
    ds = xr.open_dataset(path).transpose("anisotropy", "orientation")
    t = (ds["anisotropy"].values[:, None] - 1.0) / 4.0 + 0.0 * ds["orientation"].values[None, :]
    exact = {"K_min": 2.0 - np.abs(t), "K_max": 2.0 + np.abs(t), "K_min_over_K_max": (2 - np.abs(t)) / (2 + np.abs(t))}
    for name, value in exact.items():
        true = np.abs(ds[name].values / value - 1.0)
        assert true.max() <= 1e-3, name
        assert np.mean(ds[f"{name}_map_error"].values >= true) >= 0.95, name
    monkeypatch.setattr(estimates, "PRINCIPAL", ())
    direct = xr.open_dataset(sweep(write_spec(CROSSING, "direct.toml"), crossing, output=tmp_path / "direct.nc"))
    assert ds.attrs["sweep_solves"] < direct.attrs["sweep_solves"]


@pytest.mark.parametrize("shape", [(0,), (1,), (7, 5), (146_475,)])
def test_distinct_tasks_counts_what_np_unique_counts(shape: tuple[int, ...]) -> None:
    """``distinct_tasks`` (the rounds' "of N in all"): the count of distinct positions that a
    sort gives, on points that share tasks and on positions left unused."""
    rng = np.random.default_rng(7)
    size = math.prod(shape)
    task_of = rng.integers(0, max(1, size // 2), size=size).reshape(shape)
    assert distinct_tasks(task_of) == len(np.unique(task_of))


def test_the_dry_run_of_a_map_says_its_totals_are_the_bound(write_spec, capsys):
    """An adaptive map's totals are every task solved, its bound (the 4-D map's "89.3 min" on one
    rank where it solves 5 353 of 139 725 tasks): the dry run says so, and gives the first
    round's own estimate."""
    from hpcontact.sweep.driver import main

    assert main([str(write_spec(MINDLIN)), "--dry-run"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[2].startswith("# estimated if every task is solved (an adaptive map's bound): ")
    assert lines[3].startswith("# wall time if every task is solved (an adaptive map's bound): ")
    assert lines[4].startswith("# adaptive: first round 25 of the 861 tasks (") and "core-seconds);" in lines[4]
