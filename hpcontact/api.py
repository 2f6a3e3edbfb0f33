"""What a notebook user types, re-exported at the package top (``hpcontact.solve``,
``hpcontact.open_dataset``, ``hpcontact.run_sweep``): a stable face over the engine and the
sweep. The sweep is imported only when called: it brings xarray, and mpi4py, whose import
initializes MPI.

>>> import hpcontact
>>> record = hpcontact.solve(shape="ellipse", aspect=0.5, nu=0.3, n=64)
>>> record["K_xx"], record["K_yy"]                      # doctest: +SKIP
>>> record = hpcontact.solve(shape="ellipse", aspect=0.3, accuracy=1e-4)   # extrapolated over grids
>>> path = hpcontact.run_sweep("jobs/demo.toml")          # one process; again: "up to date"
>>> ds = hpcontact.open_dataset(path)
>>> ds.K_nn.sel(shape="rectangle", nu=0.3, aspect=1e-4)  # doctest: +SKIP

``solve_fields`` is the one dispatch of a single scene, shared by ``hpcontact solve`` and
``hpcontact.solve``: contact or slip scene (``problems.kinds``), ``accuracy`` or the default
discretization, BLAS limited while it runs (``numerics.blas``).
"""

from __future__ import annotations

import inspect
import os
import re
import textwrap
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from hpcontact.accuracy import (
    AccuracyNotMet,
    accuracy_request,
    default_scene_solve,
    solve_to_accuracy,
    task_function,
)
from hpcontact.errors import AccuracyWarning, Front, InputError, did_you_mean, rendered
from hpcontact.fields import CONTACT, cli_fields, names, python_annotation, python_doc, recorded
from hpcontact.numerics.blas import limited_blas
from hpcontact.numerics.memory import check_fits, default_memory_per_rank, memory_budget, parse_memory, resident_bytes
from hpcontact.problems import footprint
from hpcontact.problems.kinds import SLIP, kind_of
from hpcontact.scene import Scene

if TYPE_CHECKING:
    import xarray as xr

#: The slip scene's own fields (beyond a contact scene's), keywords of ``hpcontact.solve`` and
#: options of ``hpcontact solve``; all of its keywords: the contact scene's fields, ``memory``
#: (a solve option, not a field) and these (``hpcontact.fields``).
SLIP_KEYWORDS = tuple(f.name for f in cli_fields("slip"))
SOLVE_KEYWORDS = (*names(CONTACT), "memory", *SLIP_KEYWORDS)


def keyword(field: str) -> str:
    """A field as a Python caller names it: the keyword itself."""
    return field


def solve_fields(
    params: Mapping[str, Any],
    slip: Mapping[str, Any] | None = None,
    *,
    accuracy: float | None = None,
    memory: str | float | None = None,
    name: Callable[[str], str] = keyword,
) -> dict[str, Any]:
    """Solve one scene from its fields and return its record: the dispatch of ``hpcontact
    solve`` and ``hpcontact.solve``.

    ``params`` are the scene's fields (``hpcontact.fields`` declares them; ``None`` or
    missing: the engine's default), ``slip`` the slip scene's own fields (``SLIP_KEYWORDS``,
    only with ``quantities="slip"``). A slip scene goes to the slip solver
    (``accuracy.task_function``); a contact scene with ``accuracy`` to ``solve_to_accuracy``
    (strategy "auto", its grids within the ``memory`` budget: "2G" or bytes; default this
    machine's memory per core), else to ``default_scene_solve`` (without ``n``: as
    ``accuracy=1e-4`` where that applies, the exact cell of circles and ellipses; with ``n``:
    that grid). A one-grid solve is refused (``InputError``, field ``n``, or ``memory`` when
    given) before anything is allocated when the cost model's estimate of its peak (this
    process's resident set + ``footprint.array_bytes``) exceeds the budget. A
    default that misses its 1e-4 returns its record (``accuracy_met`` False) with an
    ``errors.AccuracyWarning`` naming the requested and estimated error and what stopped it; an
    ``accuracy`` asked for and missed raises ``AccuracyNotMet``, whose ``record`` is in the
    units of a met request's, ``units`` included. BLAS is limited while it runs
    (``numerics.blas``). ``name`` spells a field in a message (``--memory`` on the command line).

    The record's ``units`` maps each number's key to its unit (``sweep.data.attributes.record_units``,
    as a sweep's data set names it): "G a" (GPa a for a body given in GPa, "N m-1" with the
    contact size in metres), "1" for ratios and counts, "degree", "s", a slip scene's F and L or
    SI units.
    """
    fields = {k: os.fspath(v) if isinstance(v, os.PathLike) else v for k, v in params.items() if v is not None}
    extra = {k: v for k, v in (slip or {}).items() if v is not None}
    kind = kind_of(fields)  # the same dispatch as a sweep's (hpcontact.problems.kinds)
    if accuracy is not None and kind.accuracy_refused:
        raise InputError(
            name("accuracy"), f"not with {name('quantities')} {kind.name} ({kind.accuracy_refused})", accuracy
        )
    # imported here: the data set's tables load the sweep's modules, which a bare import hpcontact need not
    from hpcontact.sweep.data.attributes import record_units

    with limited_blas():
        try:
            record = _SOLVERS[kind.name](fields, extra, accuracy, memory, name)
        except AccuracyNotMet as exc:  # the record reached carries its units as a met one does
            exc.record["units"] = record_units(exc.record, {**fields, **extra})
            raise
    record["units"] = record_units(record, {**fields, **extra})
    return record


def _solve_slip(
    fields: dict[str, Any], extra: Mapping[str, Any], accuracy: float | None, memory: Any, name: Callable[[str], str]
) -> dict[str, Any]:
    """A slip scene: its own fields beside the common ones (no outline), on its grid (no
    memory budget: ``memory`` is a contact solve's)."""
    if memory is not None:
        raise InputError(
            name("memory"), f"not with {name('quantities')} {SLIP} (the budget of a contact solve)", memory
        )
    fields.pop("shape", None)
    return dict(task_function(SLIP)({**fields, **extra}))


def _solve_contact(
    fields: dict[str, Any], extra: Mapping[str, Any], accuracy: float | None, memory: Any, name: Callable[[str], str]
) -> dict[str, Any]:
    """A contact scene: ``solve_to_accuracy`` with ``accuracy``, else ``default_scene_solve``
    (a one-grid solve first checked against the memory budget, ``_check_one_grid``); its
    record in N/m where it gives its size (``Scene.newtons_per_metre``)."""
    if extra:
        field = next(iter(extra))
        raise InputError(name(field), f"only with {name('quantities')} slip", extra[field])
    budget = None if memory is None else parse_memory(memory, name("memory"))
    missed = None
    scene = Scene.from_params(fields)

    def finished(record: dict[str, Any]) -> dict[str, Any]:
        """The record with the fields it states, in N/m, m and m² where the scene gives its size."""
        record.update(recorded(scene.quantities, vars(scene)))  # also where no Schur complement was formed
        return scene.in_si_units(record)

    if accuracy is not None:
        try:
            record = solve_to_accuracy(scene, accuracy, memory_budget=budget, strategy="auto")
        except AccuracyNotMet as exc:  # the record reached, as a met request's would be
            exc.record = finished(exc.record)
            raise
    else:
        if accuracy_request(scene) is None:  # one grid: refused before it is allocated
            _check_one_grid(scene, memory, name)
        try:  # without n: as accuracy=DEFAULT_ACCURACY where that applies
            record = default_scene_solve(scene)
        except AccuracyNotMet as exc:  # the default's own target: say so, return what was reached
            record, missed = exc.record, str(exc)
    record = finished(record)
    if missed is not None:
        warnings.warn(f"default {missed}", AccuracyWarning, stacklevel=4)
    return record


def _check_one_grid(scene: Scene, memory: str | float | None, name: Callable[[str], str] = keyword) -> None:
    """``InputError`` (field ``memory`` when given, else ``n``) when the one-grid solve of
    ``scene`` would not fit the budget (``memory``, else this machine's memory per core): the
    cost model's peak of a one-grid task, this process's resident set so far +
    ``footprint.array_bytes`` (what ``sweep.cost.rates.task_array_bytes`` gives a task with
    ``n``), checked before the grid's arrays exist."""
    field = name("memory") if memory is not None else name("n")
    budget = memory_budget(memory, field)
    nx, ny = footprint.contact_grid(scene.params)
    need = resident_bytes() + footprint.array_bytes(scene.params)
    what = f"a grid ({nx} × {ny} cells here) that fits: a smaller {name('n')} or a larger {name('memory')}"
    check_fits(need, budget, field, memory if memory is not None else scene.params.get("n"), what)


_SOLVERS = {CONTACT: _solve_contact, SLIP: _solve_slip}


def solve(**keywords: Any) -> dict[str, Any]:
    """Solve one scene and return its record, as ``hpcontact solve --json`` prints it.

    Every parameter is keyword-only: a field of the schema (``hpcontact.fields``, which gives
    the keywords, their types and their entries below) or ``memory``. ``None`` (the default)
    means the engine's default (``hpcontact.scene.DEFAULTS``, shown in brackets). Lengths are
    in units of a, the semi-major extent of the contact (the long side's half; 1 on the grid).

    Parameters
    ----------
    {parameters}

    Returns
    -------
    dict
        The record: stiffnesses ``K_ij`` in units of G·a (GPa·a for a crystal given in GPa,
        N/m with the contact size in metres), principal values and angle, ratios, grid,
        iterations, residual, ``wall_time_s`` and the ``plan``; with ``accuracy`` (or the extrapolated default) also
        ``estimated_error``, ``grids`` and ``levels``. Slip scenes: the record of
        ``hpcontact.problems.slip.partial_slip.solve_slip``. Its ``units`` maps each number's
        key to its unit: ``{"K_xx": "G a", "K_a_over_K_b": "1", "principal_angle_deg":
        "degree", "wall_time_s": "s", ...}`` ("GPa a" for a body given in GPa, "N m-1" with
        the contact size in metres; UDUNITS strings, or products of the scene's scales G, a, L, F, which are
        parameters rather than units: ``hpcontact.sweep.data.units``).

    Raises
    ------
    TypeError
        An unknown keyword (the message suggests the closest known one).
    hpcontact.errors.InputError
        A field is missing, out of range or not used by the scene (the message names it and
        the range).
    hpcontact.errors.ConvergenceError
        A solve did not reach its tolerance, or ``accuracy`` was not met within the grids the
        limits allow (``hpcontact.accuracy.AccuracyNotMet`` names the limit).

    Warns
    -----
    hpcontact.errors.AccuracyWarning
        Without ``n`` and ``accuracy``, the default 1e-4 was not met within the grids the
        limits allow: the record is returned (``accuracy_met`` False, ``estimated_error`` what
        was reached) and the warning names the requested and estimated error and the limit.
    """
    unknown = sorted(set(keywords) - set(SOLVE_KEYWORDS))
    if unknown:
        word = unknown[0]
        raise TypeError(
            f"solve() got an unexpected keyword argument {word!r}{did_you_mean(word, SOLVE_KEYWORDS, quote=True)}"
        )
    params = {name: keywords.get(name) for name in names(CONTACT) if name != "accuracy"}
    slip = {name: keywords.get(name) for name in SLIP_KEYWORDS}
    return solve_fields(params, slip, accuracy=keywords.get("accuracy"), memory=keywords.get("memory"))


def _parameters(indent: str) -> str:
    """The entries of ``solve``'s keywords in its docstring (``indent``: that of their names),
    each from the schema (``fields.python_doc``), wrapped as numpydoc lays them out."""
    return "".join(
        f"{indent}{name}\n"
        + textwrap.fill(python_doc(name), 96, initial_indent=indent + "    ", subsequent_indent=indent + "    ")
        + "\n"
        for name in SOLVE_KEYWORDS
    )


solve.__doc__ = re.sub(r"^( *)\{parameters\}\n", lambda m: _parameters(m.group(1)), solve.__doc__ or "", flags=re.M)
#: What ``help(hpcontact.solve)`` and ``inspect.signature`` show: every keyword of
#: ``SOLVE_KEYWORDS``, keyword-only, default None, typed from the schema (``fields.python_annotation``).
solve.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
    [
        inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=None, annotation=python_annotation(name))
        for name in SOLVE_KEYWORDS
    ],
    return_annotation="dict[str, Any]",
)


def open_dataset(path: str | Path, **options: Any) -> xr.Dataset:
    """Open a sweep data set as the labelled hypercube over the spec's axes.

    Parameters
    ----------
    path
        The netCDF file ``hpcontact run`` (or ``run_sweep``) wrote.
    **options
        Passed to ``xarray.open_dataset``; ``chunks={}`` gives dask arrays in the file's
        chunks (1–10 MB on large sweeps).

    Returns
    -------
    xarray.Dataset
        Lazily read: one dimension per axis of the spec (labels select exactly:
        ``ds.sel(nu=0.3, shape="rectangle")``), every point of the parameter space, ``K_nn``
        and ``normalized_nn`` along ``angle``, ``plan`` as JSON text. Use it in a ``with``
        block, or ``.load()`` it, to close the file.
    """
    from hpcontact.sweep.data.dataset import open_dataset as open_sweep

    return open_sweep(path, **options)


def run_sweep(
    spec: str | os.PathLike[str] | Mapping[str, Any],
    *,
    resume: bool = False,
    restart: bool = False,
    output: str | os.PathLike[str] | None = None,
    accept_stale: bool = False,
    retry_crashed: bool = False,
    break_lock: bool = False,
    mem_per_rank: str | int | None = None,
    accuracy: float | None = None,
    task_function: Callable[[Mapping[str, Any]], Mapping[str, Any]] | None = None,
    stream: TextIO | None = None,
) -> Path:
    """Run a sweep in this one process and return the path of its data set.

    Parameters
    ----------
    spec
        The sweep spec: a TOML file (``"jobs/demo.toml"``) or a dict of the same structure
        (``{"scene": {...}, "numerics": {...}, "axes": {...}, "sweep": {"output": ...}}``),
        checked by the same parser (``hpcontact.sweep.space.parse.parse_spec``). A dict's relative
        mask paths are relative to the working directory; without an output (its
        ``sweep.output`` or ``output=``) it writes ``results/TITLE-HASH.nc`` in the working
        directory (``hpcontact.sweep.space.spec.default_output``), and without a title it is
        named by its axes (``default_title``).
    resume
        Continue from the journals of an earlier run: reuse its finished tasks, run failed
        ones again.
    restart
        Discard the journals of this output first (not with ``resume``).
    output
        The data set path (``.nc``), instead of the spec's ``sweep.output``.
    accept_stale, retry_crashed, break_lock
        Reuse journal entries of another version or revision; run quarantined tasks again;
        take the output's lock from a run known to be dead (``hpcontact run --help``).
    mem_per_rank
        Refuse a spec with a task whose estimated memory exceeds this (``"4G"`` or bytes)
        before any task starts; default: this machine's memory per core, as ``hpcontact run``
        (``numerics.memory.default_memory_per_rank``).
    accuracy
        Solve every scene to this estimated relative error (``hpcontact run --accuracy``),
        replacing the spec's ``[numerics]`` accuracy, n and n_across.
    task_function
        Replaces the solver of one scene (fields → record); default: the spec's scene kind's.
        Its journal entries name it (module and qualified name), so a ``resume`` with another
        task function runs them again; a wrapper made with ``functools.wraps`` keeps the name
        of what it wraps.
    stream
        Receives the progress lines and the summary (default stdout).

    Returns
    -------
    pathlib.Path
        The data set (read it with ``open_dataset``). A sweep already finished with this spec
        and output is up to date: nothing is computed or written, one line says so, and its
        path is returned (no ``resume`` needed).

    Raises
    ------
    hpcontact.errors.InputError
        The spec is invalid (the message names the key), or the run is refused
        (``hpcontact.sweep.run.guard.Refused``: journals of an earlier run without ``resume=True``
        or ``restart=True``, stale journals, the lock held, the output unusable); the message
        names the keyword to pass.
    hpcontact.sweep.run.records.Stopped
        The run stopped before writing the data set (journals intact: ``resume=True`` goes on).
    """
    arguments = dict(locals())  # the call as given, for the data set's history (after the checks)
    from hpcontact.sweep.run.records import Options, Stopped, runner_name
    from hpcontact.sweep.run.rounds import execute
    from hpcontact.sweep.run.schedule import SerialTeam

    if isinstance(spec, bytes) or not isinstance(spec, (str, os.PathLike, Mapping)):
        raise InputError(
            "spec",
            f"a TOML file's path (str or os.PathLike) or a dict of its tables, not {type(spec).__name__}",
        )
    if resume and restart:
        raise InputError(
            "restart", "not with resume=True (resume continues from the journals, restart discards them)", True
        )
    memory = (
        default_memory_per_rank()
        if mem_per_rank is None
        else (parse_memory(mem_per_rank, "mem_per_rank"), "mem_per_rank")
    )
    options = Options(
        resume=resume,
        restart=restart,
        accept_stale=accept_stale,
        retry_crashed=retry_crashed,
        break_lock=break_lock,
        mem_per_rank=memory,
        up_to_date=task_function is None,
        runner=runner_name(task_function),  # a resume never reuses another task function's entries
        front=Front.PYTHON,  # printed advice in a Python caller's words
    )
    target = None if output is None else os.fspath(output)
    try:
        source = _dict_spec(spec, target, accuracy) if isinstance(spec, Mapping) else spec
        return execute(
            source,
            None if isinstance(spec, Mapping) else target,
            task_function,
            team=SerialTeam(),
            stream=stream,
            options=options,
            accuracy=None if isinstance(spec, Mapping) else accuracy,
            command=_history_text(arguments),
        ).path
    except InputError as exc:  # a refusal too: options in a Python caller's words ("resume=True", "mem_per_rank")
        if not exc.names_option():
            raise
        raise exc.for_front(Front.PYTHON).with_traceback(exc.__traceback__) from None
    except Stopped as exc:
        raise Stopped(rendered(exc.args[0], Front.PYTHON), exc.status).with_traceback(exc.__traceback__) from None


#: The spec path a dict spec is recorded under (journals, the data set's ``spec_path``).
def _history_text(arguments: Mapping[str, Any]) -> str:
    """This call of ``run_sweep`` (``arguments``: its parameters) as a data set's history shows
    it: "hpcontact.run_sweep('jobs/demo.toml', resume=True)"."""
    from hpcontact.sweep.data.provenance import call_text

    return call_text("hpcontact.run_sweep", run_sweep, arguments)


def _dict_spec(spec: Mapping[str, Any], output: str | None, accuracy: float | None = None) -> Any:
    """The ``Spec`` of a spec given as a dict, read directly (``parse.parse_spec_dict``: its points
    counted before anything is expanded, no TOML round trip)."""
    from hpcontact.sweep.space.parse import parse_spec_dict

    return parse_spec_dict(spec, output=output, check_scenes=False, accuracy=accuracy)
