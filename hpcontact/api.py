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

import os
import re
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from hpcontact.accuracy import (
    AccuracyNotMet,
    default_scene_solve,
    extrapolates_by_default,
    solve_to_accuracy,
    task_function,
)
from hpcontact.errors import AccuracyWarning, InputError, did_you_mean
from hpcontact.fields import CONTACT, cli_fields, cli_help, names, recorded
from hpcontact.numerics.blas import limited_blas
from hpcontact.numerics.memory import check_fits, default_memory_per_rank, memory_budget, parse_memory, resident_bytes
from hpcontact.problems import footprint
from hpcontact.problems.kinds import SLIP, kind_of
from hpcontact.quantities import in_newtons_per_metre
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
    contact size ``a`` in m), "1" for ratios and counts, "degree", "s", a slip scene's F and L or
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
        """The record with the fields it states, in N/m where the scene gives its size."""
        record.update(recorded(scene.quantities, vars(scene)))  # also where no Schur complement was formed
        return in_newtons_per_metre(record, scene.newtons_per_metre)

    if accuracy is not None:
        try:
            record = solve_to_accuracy(scene, accuracy, memory_budget=budget, strategy="auto")
        except AccuracyNotMet as exc:  # the record reached, as a met request's would be
            exc.record = finished(exc.record)
            raise
    else:
        if not extrapolates_by_default(scene):  # one grid: refused before it is allocated
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


def solve(
    *,
    shape: str | None = None,
    aspect: float | None = None,
    sides: int | None = None,
    shape_angle: float | None = None,
    amplitude: float | None = None,
    seed: int | None = None,
    hurst: float | None = None,
    rms: float | None = None,
    mask: str | os.PathLike[str] | None = None,
    nu: float | None = None,
    G: float | None = None,
    anisotropy: float | None = None,
    orientation: float | None = None,
    miller: str | Sequence[int] | None = None,
    azimuth: float | None = None,
    material: str | None = None,
    cubic: str | Mapping[str, float] | Sequence[float] | None = None,
    orthotropic: str | Mapping[str, float] | Sequence[float] | None = None,
    voigt: str | Sequence[float] | Sequence[Sequence[float]] | None = None,
    n: int | None = None,
    n_across: int | None = None,
    tol: float | None = None,
    quantities: str | Sequence[str] | None = None,
    radius: float | None = None,
    depth: float | None = None,
    a: float | None = None,
    threads: int | None = None,
    precondition: bool | None = None,
    device: str | None = None,
    normal_held: str | None = None,
    accuracy: float | None = None,
    memory: str | int | None = None,
    radius_b: float | str | None = None,
    radius2: float | str | None = None,
    radius2_b: float | str | None = None,
    body2_angle: float | None = None,
    material2: str | None = None,
    E: float | None = None,
    E2: float | None = None,
    G2: float | None = None,
    nu2: float | None = None,
    load: float | None = None,
    mu: float | None = None,
    q_ratio: float | None = None,
    angle: float | None = None,
    steps: int | None = None,
    control: str | None = None,
    displacement: float | None = None,
    path: str | None = None,
    coupling: str | None = None,
    tensor: bool | None = None,
    history: bool | None = None,
    normal_friction: bool | None = None,
    anisotropy2: float | None = None,
    orientation2: float | None = None,
    miller2: str | Sequence[int] | None = None,
    azimuth2: float | None = None,
    cubic2: str | Mapping[str, float] | Sequence[float] | None = None,
    orthotropic2: str | Mapping[str, float] | Sequence[float] | None = None,
    voigt2: str | Sequence[float] | Sequence[Sequence[float]] | None = None,
    **unknown: Any,
) -> dict[str, Any]:
    """Solve one scene and return its record, as ``hpcontact solve --json`` prints it.

    Every parameter is keyword-only; ``None`` (the default) means the engine's default
    (``hpcontact.scene.DEFAULTS``, shown in brackets). Lengths are in units of a, the
    semi-major extent of the contact (the long side's half; 1 on the grid).

    Parameters
    ----------
    shape
        ``circle`` [default], ``ellipse``, ``rectangle``, ``polygon``, ``star``, ``rough`` or
        ``mask``.
    aspect
        b/a of an ellipse or rectangle, in [1e-12, 1] [1].
    sides
        Sides of a polygon, lobes of a star (≥ 2) [5].
    shape_angle
        Turn of the shape (and of a crystal's lattice with it), degrees [0].
    amplitude
        Star modulation ε of r = 1 + ε cos(k φ), in [0, 1) [0.2].
    seed, hurst, rms
        The rough surface: random seed [0], Hurst exponent in (0, 1) [0.8], rms height in
        units of a [0.02].
    mask
        Contact mask file (.npy, or .png: dark pixels in contact) for ``shape="mask"``; unit a
        is half the long side of the contact.
    nu
        Poisson ratio in (-1, 0.5], < 0.5 for a crystal (A ≠ 1) [0.3].
    G
        Shear modulus, the stress unit of the scene [1].
    anisotropy
        Cubic anisotropy factor A = 2 C44/(C11 − C12) in [0.01, 100]; 1 is isotropic [1].
        ``nu``, ``G`` and ``anisotropy`` describe the body only without ``material``,
        ``cubic``, ``orthotropic`` or ``voigt``: beside one of them (its constants give the
        whole stiffness) they raise ``InputError``.
    orientation
        Surface normal along [110] → [111] → [001]: ψ in [0, 90] degrees [[001]].
    miller
        Surface normal as Miller indices, ``"1 1 0"`` or ``(1, 1, 0)`` (not with orientation).
    azimuth
        In-plane turn of the crystal, degrees [0].
    material
        Library crystal by name (``Cu``, ``Al``, ``Fe``, ``Ni``, ``W``, ``Si``, ...; constants
        in GPa). With ``quantities="slip"``: body 1 (``Cu``, ``Fe``/``steel``, ``Al``,
        ``rigid``, or ``crystal:NAME``).
    cubic
        Cubic crystal ``"C11=... C12=... C44=..."`` (GPa), a mapping or three numbers.
    orthotropic
        Orthotropic engineering constants ``"E1=.. E2=.. E3=.. G12=.. G13=.. G23=.. nu12=..
        nu13=.. nu23=.."`` (GPa), a mapping or nine numbers.
    voigt
        General 6 × 6 Voigt stiffness (GPa): 36 numbers row by row or a nested 6 × 6 list.
    n
        Cells along the long side. Without it (and without ``accuracy``): as ``accuracy=1e-4``
        (``hpcontact.accuracy.DEFAULT_ACCURACY``) where that applies (isotropic, outlined
        shapes: the one exact cell of a circle or an ellipse, refined grids extrapolated
        otherwise), else 128.
    n_across
        Cells across the short side (thin shapes).
    tol
        Conjugate-gradient relative residual tolerance in [1e-14, 1e-2] [1e-8].
    quantities
        Comma string or list of ``tangential`` [default], ``normal``, ``compliance``,
        ``coupled``, ``indentation``; or ``slip`` (partial slip of two bodies: give its fields
        below as keywords, e.g. ``radius=0.01, load=100.0, mu=0.3, q_ratio=0.5``).
    radius, depth
        Rigid sphere radius and approach (``indentation``), in a length unit L of your choice.
    a
        Contact size: the semi-major extent a in metres, in [1e-12, 1e3] (not for
        ``indentation``). Every stiffness of the record is then in N/m (K = k G a), which needs
        the body's modulus in physical units: ``G`` in Pa, or a library crystal or elastic
        constants in GPa.
    threads
        FFTW threads [1]. BLAS threads: ``$HPCONTACT_BLAS_THREADS`` [1], only while solving.
    precondition
        Fourier-preconditioned CG [True]; False for plain CG.
    device
        Where the contact solves run: ``"cpu"`` [default] (numpy, pyFFTW) or ``"gpu"`` (CuPy,
        cuFFT; the optional extra ``gpu``), one GPU per process (its rank on the node modulo the
        visible devices). Results agree to round-off. A GPU without CuPy or without a CUDA device
        raises ``InputError`` saying which.
    normal_held
        What ``tangential`` holds in the normal direction: ``"approach"`` (u_z = 0) [default]
        or ``"load"`` (F_z = 0, Cattaneo–Mindlin: the Schur complement K_tt − K_tz K_zz⁻¹ K_zt
        of the 3 × 3 Re-H stiffness, one more solve for a crystal; the same as ``"approach"``
        for an isotropic body). The record then has ``normal_held`` = "load".
    accuracy
        Extrapolate over refined grids until the estimated relative error of every reported
        stiffness is ≤ this (in [1e-9, 1)), exactly as ``hpcontact solve --accuracy``
        (``hpcontact.accuracy.solve_to_accuracy``, strategy "auto"); ``n`` is then ignored.
    memory
        Memory budget of a contact solve (``"2G"``, ``"512M"`` or bytes) [this machine's memory
        per core]: with ``accuracy`` its grids are planned within it; a one-grid solve (``n``
        given, or a scene the default solves on one grid) whose estimated peak exceeds it is
        refused before anything is allocated (``InputError``, field ``memory``, or ``n``
        without it). Not for ``quantities="slip"``.
    {slip_parameters}

    Returns
    -------
    dict
        The record: stiffnesses ``K_ij`` in units of G·a (GPa·a for a crystal given in GPa,
        N/m with ``a``), principal values and angle, ratios, grid, iterations, residual,
        ``wall_time_s`` and the ``plan``; with ``accuracy`` (or the extrapolated default) also
        ``estimated_error``, ``grids`` and ``levels``. Slip scenes: the record of
        ``hpcontact.problems.slip.partial_slip.solve_slip``. Its ``units`` maps each number's
        key to its unit: ``{"K_xx": "G a", "K_a_over_K_b": "1", "principal_angle_deg":
        "degree", "wall_time_s": "s", ...}`` ("GPa a" for a body given in GPa, "N m-1" with
        ``a``; UDUNITS strings, or products of the scene's scales G, a, L, F, which are
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
    given = locals()
    if unknown:
        word = sorted(unknown)[0]
        raise TypeError(
            f"solve() got an unexpected keyword argument {word!r}{did_you_mean(word, SOLVE_KEYWORDS, quote=True)}"
        )
    params = {name: given[name] for name in names(CONTACT) if name != "accuracy"}
    slip = {name: given[name] for name in SLIP_KEYWORDS}
    return solve_fields(params, slip, accuracy=accuracy, memory=memory)


def _slip_parameters(indent: str) -> str:
    """The slip scene's own keywords of ``solve``, as its docstring lists them (``indent``:
    that of its parameter names): each with its command-line help (``hpcontact.fields``)."""
    return "".join(
        f'{indent}{name}\n{indent}    Partial slip (``quantities="slip"`` only): {cli_help(name)}.\n'
        for name in SLIP_KEYWORDS
    )


solve.__doc__ = re.sub(
    r"^( *)\{slip_parameters\}\n", lambda m: _slip_parameters(m.group(1)), solve.__doc__ or "", flags=re.M
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


#: Command-line flags in the sweep's messages and the keywords of ``run_sweep`` that do the same.
_FLAGS = {
    "--resume": "resume=True",
    "--restart": "restart=True",
    "--accept-stale": "accept_stale=True",
    "--retry-crashed": "retry_crashed=True",
    "--break-lock": "break_lock=True",
    "--mem-per-rank": "mem_per_rank",
    "--accuracy": "accuracy",
    "--output": "output=",
}
_FLAG = re.compile(
    r"(?<![\w-])(" + "|".join(re.escape(f) for f in sorted(_FLAGS, key=len, reverse=True)) + r")(?![\w-])"
)


def python_message(text: str) -> str:
    """A sweep message with its command-line flags as ``run_sweep`` keywords (``--resume`` →
    ``resume=True``): what a Python caller passes."""
    return _FLAG.sub(lambda m: _FLAGS[m.group(1)], text)


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
    from hpcontact.sweep.run.guard import Refused
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
    except Refused as exc:
        raise Refused(python_message(str(exc))).with_traceback(exc.__traceback__) from None
    except Stopped as exc:
        raise Stopped(python_message(str(exc)), exc.status).with_traceback(exc.__traceback__) from None
    except InputError as exc:
        if not any(flag in f"{exc.field} {exc.allowed}" for flag in _FLAGS):
            raise
        raise InputError(python_message(exc.field), python_message(exc.allowed), exc.value).with_traceback(
            exc.__traceback__
        ) from None


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
