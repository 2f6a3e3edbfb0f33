"""The stiffnesses an adaptive round decides from (``dataset.stored_stiffnesses``) are those of
the whole data set (``dataset.dataset_of``) of the same columns: same names in the same order,
same values bitwise (NaN where a task failed or has no entry), ``<name>_error`` NaN where a
record carries none; numpy arrays alone (no xarray), no other variable."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace

import numpy as np

from hpcontact.fields import SLIP
from hpcontact.quantities import SLIP_ESTIMATED
from hpcontact.sweep.data.columns import join, task_positions, to_columns
from hpcontact.sweep.data.dataset import FIXED_VARIABLES, dataset_of, stiffness_record, stored_stiffnesses
from hpcontact.sweep.data.journal import ERROR, OK, Entry
from hpcontact.sweep.space.parse import parse_spec
from hpcontact.sweep.work.tasks import enumerate_tasks

SPEC = """
[sweep]
title = "test"
[scene]
quantities = ["tangential", "normal"]
[numerics]
n = 16
[axes]
shape = ["circle", "ellipse"]
aspect = [1.0, 0.1, 0.01]
nu = [0.0, 0.25, 0.5]
"""


def columns_of(spec, solve):
    """The joined columns of ``spec``'s tasks (``solve`` gives the records; one task failed, one
    has no entry, only some records carry ``K_xx_error``), and each point's task."""
    parts, task_of = columns_parts(spec, solve, with_positions=True)
    return join(parts, task_of.max() + 1, FIXED_VARIABLES), task_of


def columns_parts(spec, solve, with_positions=False):
    """``columns_of``'s entries as one part of columns (and each point's task)."""
    tasks, where = enumerate_tasks(spec)
    keys, task_of = task_positions(where, tuple(len(a) for a in spec.task_axes))
    by_key = {t.key: t for t in tasks}
    entries, at = [], []
    for i, key in enumerate(keys):
        if i == 2:
            continue  # no entry: not computed
        record = dict(solve(by_key[key].params))
        if i % 2 and "K_xx" in record:
            record["K_xx_error"] = 1e-3 * (i + 1)
        failed = i == 3
        entries.append(
            Entry(
                key,
                by_key[key].params,
                ERROR if failed else OK,
                "x" if failed else "",
                {} if failed else record,
                0.5,
                0.0,
                0,
            )
        )
        at.append(i)
    parts = [to_columns(entries, at)]
    return (parts, task_of) if with_positions else parts


def assert_same_stiffnesses(spec, task_of, joined) -> list[str]:
    """``stored_stiffnesses`` against ``dataset_of`` of the same columns; the stiffness names."""
    whole = dataset_of(spec, task_of, joined, {"mpi_size": 1}, derive=False)
    alone = stored_stiffnesses(spec, task_of, joined)
    pattern = spec.kind_record.estimated
    expected = [str(v) for v in whole.data_vars if pattern.match(str(v)) and not str(v).endswith("_error")]
    names = [v for v in alone if pattern.match(v) and not v.endswith("_error")]
    assert names == expected
    for name in names:
        for full in (name, f"{name}_error"):
            a, b = alone[full], whole[full].values
            assert type(a) is np.ndarray and a.dtype == b.dtype == np.float64 and a.shape == b.shape, full
            assert np.array_equal(a, b, equal_nan=True), full
    assert set(alone) == {f"{n}{e}" for n in names for e in ("", "_error")}
    return names


def test_the_stiffnesses_are_those_of_the_whole_data_set(fake_solve):
    spec = parse_spec(SPEC, validate=lambda params: None)
    joined, task_of = columns_of(spec, fake_solve)
    names = assert_same_stiffnesses(spec, task_of, joined)
    assert "K_xx" in names and "K_zz" in names
    alone = stored_stiffnesses(spec, task_of, joined)
    assert np.isnan(alone["K_xx"][np.isin(task_of, [2, 3])]).all()  # not computed, failed
    assert np.isnan(alone["K_yy_error"]).all()  # no record carries it
    assert np.isfinite(alone["K_xx_error"]).any() and "plan" not in alone


def test_a_slip_sweeps_stored_errors_are_kept(fake_solve):
    """A record's own ``<name>_error`` is kept where the kind's pattern names the stiffness but
    not its error (a slip sweep's, ``SLIP_ESTIMATED``), as the whole data set keeps it."""
    assert not SLIP_ESTIMATED.match("tangential_stiffness_error")
    spec = replace(parse_spec(SPEC, validate=lambda params: None), kind=SLIP)

    def solve(params):
        return {"tangential_stiffness": params["nu"] + 1.0, "tangential_stiffness_error": 1e-4, "other": 1.0}

    joined, task_of = columns_of(spec, solve)
    assert assert_same_stiffnesses(spec, task_of, joined) == ["tangential_stiffness"]
    errors = stored_stiffnesses(spec, task_of, joined)["tangential_stiffness_error"]
    assert np.nanmax(errors) == np.nanmin(errors) == 1e-4


def test_deciding_ranks_import_no_xarray():
    """A worker rank imports the driver, the rounds of an adaptive map and the shared estimate,
    never xarray or pandas (only rank 0 makes a data set): measured as ~0.6 CPU s a rank."""
    code = (
        "import sys; import hpcontact.sweep.driver, hpcontact.sweep.maps.rounds, hpcontact.sweep.maps.spread; "
        "print(sorted(m for m in ('xarray', 'pandas', 'netCDF4', 'matplotlib') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_a_join_of_the_stiffness_records_alone_gives_the_same_stiffnesses(fake_solve):
    """``columns.join`` with ``kept = dataset.stiffness_record`` (what an adaptive round joins):
    the same stiffnesses, errors and status, bitwise; no other record array made."""
    spec = parse_spec(SPEC, validate=lambda params: None)
    joined, task_of = columns_of(spec, fake_solve)
    lean = join(
        columns_parts(spec, fake_solve) + [to_columns([], [])],
        joined.status.size,
        FIXED_VARIABLES,
        lambda name: stiffness_record(spec, name),
    )
    assert set(lean.records) == {n for n in joined.records if stiffness_record(spec, n)} and "plan" in joined.records
    assert "plan" not in lean.records and "K_xx_error" in lean.records
    np.testing.assert_array_equal(lean.status, joined.status)
    a, b = stored_stiffnesses(spec, task_of, lean), stored_stiffnesses(spec, task_of, joined)
    assert list(a) == list(b)
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=True), name


def test_after_import_array_modules_a_first_data_set_imports_nothing():
    """``import_array_modules`` (rank 0 during a round) imports what xarray imports at a
    process's first variable (dask.array where installed, as in the test environment) and at its
    first coordinate's index (pint where installed), so that the data set after it (the other
    ranks waiting) imports no module: without it the same data set imports dask's and pint."""
    make = (
        "link_errors(xr.Dataset({'status': (('x',), np.zeros(3, np.int32)), 'K_xx': (('x',), np.ones(3))}, "
        "coords={'x': np.linspace(0.0, 1.0, 3)})); "
    )
    code = (
        "import sys; import numpy as np; import xarray as xr; "
        "from hpcontact.sweep.data.dataset import import_array_modules, link_errors; "
        "WARM before = set(sys.modules); " + make + "print(sorted(set(sys.modules) - before))"
    )
    warm, cold = (
        subprocess.run(
            [sys.executable, "-c", code.replace("WARM", w)], capture_output=True, text=True, check=True
        ).stdout
        for w in ("import_array_modules();", "")
    )
    assert warm.strip() == "[]"
    assert "dask.array" in cold and "pint" in cold
