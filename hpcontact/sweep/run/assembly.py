"""Rank 0 at the end of a round: the data set from the ranks' outcome columns of this run and the
outcomes reused from earlier journals, its summary, and the netCDF file (xarray is imported
here: the other ranks, and runs that stop, never need it)."""

from __future__ import annotations

import datetime
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from hpcontact.sweep import faults
from hpcontact.sweep.data import provenance
from hpcontact.sweep.data.columns import NOT_COMPUTED, join
from hpcontact.sweep.data.journal import OK
from hpcontact.sweep.run.options import RESUME
from hpcontact.sweep.run.records import Kept, Options, Outcome, Plan, RankTotals, RoundScope
from hpcontact.sweep.run.resume import round_memory
from hpcontact.sweep.run.summary import Summary, print_summary, round_sums


def outcome_parts(plan: Plan, kept: Kept, totals: list[RankTotals], scope: RoundScope) -> list[Any]:
    """The last outcome of every task of ``scope`` as columns in parts, to be joined
    (``columns.join``): this run's, from the ranks' ``totals``, and those of earlier journals
    (reused, quarantined, or carried from an adaptive round before). An adaptive round's scope
    is the tasks of its rounds so far (``select`` and ``earlier``): an entry the journals hold
    for another point of the grid (a finer map's) is no solve of this data set, nor counted
    among its contributors. The earlier entries are turned into columns once in an adaptive run
    (``resume.RoundMemory``): the ranks' columns of a round stand for its entries in the rounds
    after it (so this is called once a round)."""
    history, tasks = kept.history, plan.tasks
    # an adaptive round looks at the tasks of its rounds alone (thousands), not the grid's 139 725
    covered = range(len(tasks)) if scope.select is None else sorted(scope.select | scope.earlier)
    earlier = [
        (history.crashed_entry(t.key, t.params) if t.key in kept.crashed else history.entries[t.key], i)
        for i, t in ((i, tasks[i]) for i in covered)
        if t.key in kept.crashed or t.key in kept.reused or t.key in kept.carried
    ]
    once = round_memory(scope).earlier_columns
    parts = once.parts([e for e, _ in earlier], [i for _, i in earlier]) + [t.columns for t in totals]
    for t in totals:  # the next round finds these entries in the journals: their columns are built
        once.ran(t.columns)
    return parts


def joined_outcomes(parts: list[Any], plan: Plan, kept: Callable[[str], bool] | None = None) -> Any:
    """``columns.join`` of the ``outcome_parts`` over the tasks of ``plan``; with ``kept``, only
    the record keys it keeps (an adaptive round's decision: ``dataset.stiffness_record``)."""
    from hpcontact.sweep.data.dataset import FIXED_VARIABLES

    return join(parts, len(plan.tasks), FIXED_VARIABLES, kept)


def assemble(
    plan: Plan,
    kept: Kept,
    scope: RoundScope,
    ranks: int,
    totals: list[RankTotals],
    started: float,
    setup_s: float,
    options: Options,
    stream: TextIO,
    command: str | None = None,
) -> Outcome:
    """Rank 0: the data set of the round (``joined_outcomes``; an adaptive round's
    ``scope.finish`` gets the columns and the function that makes it, and makes it only in its
    last round), with its summary, written as netCDF; the summary printed on ``stream``;
    ``command``: the command as its user gave it, for the history (``dataset.history_attribute``):
    that of the run as its user started it (an adaptive run's first round's ``options``; its
    later rounds run as resumes), made only for the data set that is written."""
    from hpcontact.sweep.data.dataset import dataset_of, history_attribute, stiffness_record, write_netcdf

    spec = plan.spec
    gather_started = time.perf_counter()
    parts = outcome_parts(plan, kept, totals, scope)
    if scope.finish is None:
        joined = joined_outcomes(parts, plan)
    else:  # an adaptive round decides from the stiffnesses; the last joins every variable (made)
        joined = joined_outcomes(parts, plan, lambda name: stiffness_record(spec, name))
    first = round_memory(scope).first_options or options
    run = {
        "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "history": f"hpcontact run {spec.path}{' ' + RESUME.flag if first.resume else ''}",  # the command line's
    }
    failed = [int(i) for i in np.flatnonzero((joined.status != OK) & (joined.status != NOT_COMPUTED))]

    def made() -> Any:
        nonlocal joined
        if scope.finish is not None:
            joined = joined_outcomes(parts, plan)  # every variable: the summary's too
        return dataset_of(
            spec,
            kept.task_of,
            joined,
            {
                "hpcontact_version": plan.decision.provenance["hpcontact_version"],
                "git_revision": plan.decision.provenance["git_revision"],
                "numerics": json.dumps(provenance.numerics(), sort_keys=True),
                "sweep_contributors": joined.provenance,
                "created": run["created"],
                "mpi_size": ranks,
                "sweep_journal_sync_time_s": sum(t.sync_s for t in totals),
            },
            derive=False,  # write_netcdf stores K_nn and normalized_nn (it derives them once, there)
            command=command,
        )

    sums = round_sums(plan, scope, totals, setup_s)
    if scope.finish is None:
        dataset = made()
    else:  # an adaptive round (maps.rounds.run_rounds): the data set made only if it is the last
        dataset = scope.finish(made, joined)
        if dataset is None:  # not the last round: nothing to write
            return Outcome(Path(spec.output), len(failed))
    dataset.attrs["history"] = history_attribute(spec, run, command)
    now = time.perf_counter()
    summary = Summary.of(plan, sums, len(failed), ranks, now - started, now - gather_started)
    dataset.attrs.update(summary.attrs())
    faults.slow_phase("write")
    path = write_netcdf(dataset, spec.output)
    print_summary(summary, plan, joined, failed, totals, path, now, stream, options.front)
    return Outcome(path, len(failed))
