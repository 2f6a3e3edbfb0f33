"""Helpers shared by the post-processing scripts: arguments, selections, labels, maps, saving.

The scripts read a sweep data set (docs/design.md §4.2) through ``hpcontact.open_dataset`` (the
labelled hypercube, K_nn along the angle) and write figures; run them as
``python postprocess/<script>.py DATASET OUTDIR [--format png|pdf|svg] [--force] [options]``.

Every figure uses matplotlib's constrained layout, and ``save`` wraps a title wider than its
figure (or its axes) onto more lines, so no title is cut. Contour maps of a coarse grid mark
the grid points they interpolate between (``mark_points``); anisotropy axes carry a tick at
A = 1, the isotropic body (``anisotropy_ticks``).

Error estimates: a data set may store, beside a quantity V, ``V_error`` (its estimated relative
error) and ``error_status`` (0 met, 1 not met, 2 no estimate; docs/reference/dataset.md).
``error_marks`` gives, for what a panel shows, the absolute error |V|·V_error and the points
where it is more than ``ERROR_FRACTION`` (10 %) of the panel's range; maps hatch them
(``hatch_errors``), curves draw ``error_bars`` or an ``error_band``, and ``error_caption`` is
the figure's one-line statement of it (``NO_ESTIMATES`` for a data set without estimates).

``save`` reports every file to ``freshness`` (standard library only), which stamps the output
folder when a script has drawn everything; a script run again with nothing changed stops at
``freshness.exit_if_fresh``, before this module's imports, and ``--force`` (``arguments``)
draws anyway.
"""

from __future__ import annotations

import argparse
import re
import textwrap
import tomllib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import freshness
import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

import hpcontact  # noqa: E402
from hpcontact import fields  # noqa: E402

SYMBOLS = {"nu": "ν", "aspect": "b/a", "angle": "θ", "anisotropy": "A", "orientation": "ψ", "n": "n", "tol": "tol"}


FORMATS = ("png", "pdf", "svg")
DPI = 150  # of PNGs (PDF and SVG are vector graphics)


def add_format(parser: argparse.ArgumentParser) -> None:
    """The ``--format`` option (``FORMATS``, default png) of every script; ``use_format`` applies it."""
    parser.add_argument("--format", choices=FORMATS, default="png", help="file format of the figures (default: png)")


def use_format(name: str) -> None:
    """Save the figures that follow as ``name`` files (``save``: the suffix of each file name)."""
    plt.rcParams["savefig.format"] = name


def arguments(description: str, extra: Iterable[tuple[str, dict]] = ()) -> argparse.Namespace:
    """``dataset``, ``outdir``, ``--format`` and ``--force`` (``freshness``) plus the script's own
    options."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("dataset", type=Path, help="sweep data set (netCDF) written by hpcontact run")
    parser.add_argument("outdir", type=Path, help="folder for the figures (created if missing)")
    add_format(parser)
    freshness.add_force(parser)
    for flag, options in extra:
        parser.add_argument(flag, **options)
    args = parser.parse_args()
    try:
        args.outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        refuse(f"{args.outdir}: cannot make the figure folder ({exc.strerror or type(exc).__name__})")
    use_format(args.format)
    return args


refuse = freshness.refuse  # one line on stderr, exit status 2 (defined there: standard library only)


def open_dataset(path: Path) -> xr.Dataset:
    """The sweep data set (``hpcontact.open_dataset``), loaded into memory and closed; a file
    that is missing, not netCDF, damaged or not a sweep's is ``refuse``d in one line."""
    if not Path(path).is_file():
        refuse(f"{path}: no such file (a data set written by hpcontact run)")
    try:
        with hpcontact.open_dataset(path) as ds:
            loaded = ds.load()
    except (OSError, ValueError, KeyError, TypeError, RuntimeError) as exc:
        refuse(
            f"{path}: cannot read it as a sweep data set ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else 'no detail'})"
        )
    if "status" not in loaded and not any(str(v).startswith(("K_", "load")) for v in loaded.data_vars):
        refuse(f"{path}: not a sweep data set (no status, stiffness or load: written by hpcontact run?)")
    return loaded


def require(ds: xr.Dataset, path: Path, made_by: str, axes: Iterable[str] = (), variables: Iterable[str] = ()) -> None:
    """``refuse`` a data set that lacks an axis (dimension) in ``axes`` or a variable in
    ``variables`` that a script draws, before anything is drawn or solved: one line naming the
    missing ones and ``made_by``, the sweep whose data set the script draws."""
    missing = [a for a in axes if a not in ds.dims] + [v for v in variables if v not in ds.variables]
    if missing:
        refuse(f"{path}: not a data set of {made_by} (missing: {', '.join(missing)})")


def require_values(ds: xr.Dataset, names: Iterable[str], path: Path) -> None:
    """``refuse`` a data set in which a variable a script draws (``names``, those it has) holds
    no finite value (every task failed): its figure would be empty, and no figure is drawn."""
    for name in names:
        if name in ds and not np.isfinite(np.asarray(ds[name].values, dtype=float)).any():
            refuse(f"{path}: {name} has no finite value (every task failed?): nothing to draw")


def parameter_values(ds: xr.Dataset, name: str) -> np.ndarray:
    """The values of the scene parameter ``name`` (nu, say) in the data set, whatever its role:
    the axis's values where it is swept, else its scalar coordinate, else the value the spec's
    [scene] fixed (the data set's ``spec`` attribute), else the engine's default
    (``hpcontact.fields``)."""
    if name in ds.coords:
        return np.atleast_1d(ds[name].values)
    scene = tomllib.loads(ds.attrs.get("spec", "")).get("scene", {})
    return np.atleast_1d(scene.get(name, fields.field(name).default))


def label(da: xr.DataArray, name: str | None = None) -> str:
    """Axis label: long name (or ``name``) and units in brackets."""
    text = name or da.attrs.get("long_name", da.name)
    units = da.attrs.get("units")
    return f"{text} [{units}]" if units and units != "1" else text


def value_text(ds: xr.Dataset, name: str) -> str:
    """``ν = 0.3`` for a scalar coordinate or a selected value."""
    value = ds[name].values.item()
    shown = f"{value:.3g}" if isinstance(value, float) else str(value)
    return f"{SYMBOLS.get(name, name)} = {shown}"


# Values taken for a dimension a figure does not show, when the data set has them: the isotropic
# body (A = 1; its orientation is then irrelevant, docs/design.md §2.5), so that the isotropic figures of
# a sweep with crystal axes (jobs/demo.toml) show the isotropic body whatever the axis order.
PREFERRED = {"anisotropy": 1.0}


def select_rest(
    da: xr.DataArray, keep: Iterable[str], choose: dict[str, float] | None = None
) -> tuple[xr.DataArray, str]:
    """``da`` reduced to the dimensions ``keep``: every other dimension at the value ``choose``
    gives (nearest), else at ``PREFERRED``'s value where the axis has it, else its first; also a
    note naming the values taken where they matter: a dimension along which ``da`` (at the
    values taken before) does not change is left out of it (a polygon's b/a, ψ of an isotropic
    body: the sweep solved one scene for all of them, and a title naming one reads as if it
    mattered)."""
    keep = set(keep)
    choose = {**{d: v for d, v in PREFERRED.items() if d in da.dims and np.any(da[d].values == v)}, **(choose or {})}
    notes = []
    for dim in [d for d in da.dims if d not in keep]:
        ignored = _constant_along(da, dim)
        if dim in choose and da[dim].dtype.kind == "f":
            da = da.sel({dim: choose[dim]}, method="nearest")
        elif dim in choose:
            da = da.sel({dim: choose[dim]})
        else:
            da = da.isel({dim: 0})
        if not ignored:
            notes.append(value_text(da.coords.to_dataset(), dim))
    return da, ", ".join(notes)


def _constant_along(da: xr.DataArray, dim: str) -> bool:
    """Whether every value of ``da`` is the same at each value of ``dim`` (NaN equal to NaN)."""
    first = da.isel({dim: 0})
    same = (da == first) | (da.isnull() & first.isnull())
    return bool(same.all())


def scalar_notes(ds: xr.Dataset, names: Iterable[str] = ("nu", "aspect")) -> str:
    """Fixed physical parameters of the sweep (scalar coordinates) as a note; solver settings
    (n, tol) stay out of titles: the error caption says what they buy."""
    return ", ".join(value_text(ds, n) for n in names if n in ds.coords and ds[n].ndim == 0)


def fixed_shape(data: xr.Dataset | xr.DataArray) -> str:
    """The sweep's one shape (a scalar coordinate: not an axis, or one selected) in words, with
    the fields that make it one of its kind where they are fixed too ("polygon, 6 sides", "star,
    5 lobes, amplitude 0.3"); "contact" without one."""
    if "shape" not in data.coords or data["shape"].ndim != 0:
        return "contact"
    fixed = {name: data[name].values for name in ("sides", "amplitude") if name in data.coords and data[name].ndim == 0}
    name = str(data["shape"].values)
    if name == "polygon" and "sides" in fixed:
        return f"polygon, {int(fixed['sides'])} sides"
    if name == "star" and "sides" in fixed:
        amplitude = f", amplitude {float(fixed['amplitude']):g}" if "amplitude" in fixed else ""
        return f"star, {int(fixed['sides'])} lobes{amplitude}"
    return name


def shapes(ds: xr.Dataset) -> list[str]:
    """The shape labels of the data set ([""] when shape is not an axis)."""
    return [str(s) for s in ds["shape"].values] if "shape" in ds.dims else [""]


def by_shape(da: xr.DataArray, shape: str) -> xr.DataArray:
    """``da`` at one shape (unchanged when shape is not an axis)."""
    return da.sel(shape=shape) if "shape" in da.dims else da


def colours(n: int) -> list:
    """``n`` colours from a perceptually ordered map."""
    return list(plt.cm.viridis(np.linspace(0.0, 0.9, max(n, 1))))


def panels(count: int, polar: bool = False, size: float = 3.6, columns: int = 3) -> tuple[plt.Figure, list]:
    """A figure with ``count`` panels in up to ``columns`` columns."""
    cols = min(columns, max(count, 1))
    rows = -(-count // cols)
    fig, axes = plt.subplots(
        rows,
        cols,
        figsize=(size * cols, size * rows * 0.9),
        squeeze=False,
        subplot_kw={"projection": "polar"} if polar else None,
        layout="constrained",
    )
    flat = list(axes.ravel())
    for ax in flat[count:]:
        ax.remove()
    return fig, flat[:count]


UNSAFE = re.compile(r"[/\\\x00]")  # characters a file name cannot hold: replaced by "_" (``save``)


def save(fig: plt.Figure, outdir: Path, name: str, dpi: int = DPI) -> Path:
    """Write ``fig`` as ``outdir/name`` in the chosen format (``use_format``: the name's suffix
    becomes .png, .pdf or .svg; PNGs at ``dpi``), its titles fitted (``fit_titles``), and close
    it; the file is reported to ``freshness.wrote`` for the output folder's stamp."""
    safe = UNSAFE.sub("_", name)  # a shape label may hold a "/" (and make the name a path)
    path = outdir / Path(safe).with_suffix("." + plt.rcParams["savefig.format"])
    fit_titles(fig)
    try:
        fig.savefig(path, dpi=dpi)
    except OSError as exc:
        refuse(f"{path}: cannot write the figure ({exc.strerror or type(exc).__name__})")
    plt.close(fig)
    freshness.wrote(path)
    print(f"wrote {path}")
    return path


#: Layouts ``fit_titles`` measures at most: a wrap changes the layout it was measured in.
FIT_PASSES = 3


def fit_titles(fig: plt.Figure) -> None:
    """Wrap the figure's suptitle, its axes' titles and their axis labels (a colour bar's
    among them) onto more lines where they are longer than the figure (suptitle) or their axes
    (along their axis: a title or an x label with a little room to the sides, a y label within
    its axes' height), so that none is cut at the edge of the figure (a one-panel crystal map's
    colour-bar label ran past its 4.2-inch figure before). Constrained layout then makes room;
    what it moves is measured again (at most ``FIT_PASSES`` times)."""
    for _ in range(FIT_PASSES):
        fig.draw_without_rendering()  # the layout: sizes of the axes and the texts
        renderer = fig.canvas.get_renderer()
        texts = [(getattr(fig, "_suptitle", None), fig.bbox.width * 0.96, "width")]
        for ax in fig.axes:
            across = min(fig.bbox.width * 0.96, ax.bbox.width * 1.15)
            texts += [(title, across, "width") for title in (ax.title, ax._left_title, ax._right_title)]
            texts.append((ax.xaxis.label, across, "width"))
            texts.append((ax.yaxis.label, min(fig.bbox.height * 0.96, ax.bbox.height), "height"))
        long = [(text, room, along) for text, room, along in texts if _too_long(text, room, along, renderer)]
        if not long:
            return
        for text, room, along in long:
            _wrap(text, room, along, renderer)


def _too_long(text: Any, room: float, along: str, renderer: Any) -> bool:
    """Whether the visible ``text`` is longer than ``room`` pixels ``along`` ("width", "height")."""
    if text is None or not text.get_text() or not text.get_visible():
        return False
    return getattr(text.get_window_extent(renderer), along) > room


def _wrap(text: Any, room: float, along: str, renderer: Any) -> None:
    """Wrap ``text`` onto lines of the characters that fit ``room`` pixels ``along`` it, every
    word kept (its own lines kept)."""
    length = getattr(text.get_window_extent(renderer), along)
    lines = text.get_text().splitlines()
    longest = max(len(line) for line in lines)
    columns = max(12, int(longest * room / length))
    text.set_text("\n".join(textwrap.fill(line, columns, break_on_hyphens=False) for line in lines))


COARSE = 40  # a contour map's axis with at most this many values is coarse: its grid points are marked


def mark_points(ax, x: np.ndarray, y: np.ndarray, values: np.ndarray) -> None:
    """Mark the grid points a contour map of ``values`` (shape ``(len(y), len(x))``) draws from,
    when the grid is coarse (at most ``COARSE`` values along each axis): small dots where the
    sweep has a value, crosses where it has none (a failed task)."""
    x, y, values = np.asarray(x, dtype=float), np.asarray(y, dtype=float), np.asarray(values, dtype=float)
    if len(x) > COARSE or len(y) > COARSE:
        return
    X, Y = np.meshgrid(x, y)
    ok = np.isfinite(values)
    dots = {"ls": "none", "clip_on": False, "zorder": 4}  # on the edges too: most grids end at their extreme values
    ax.plot(X[ok], Y[ok], "o", ms=2.6, mfc="w", mec="k", mew=0.5, label="solved points", **dots)
    if not ok.all():
        ax.plot(X[~ok], Y[~ok], "x", ms=4.0, color="r", label="failed points", **dots)


def anisotropy_ticks(ax, values: Iterable[float], axis: str = "y") -> None:
    """Ticks at the anisotropy factors ``values`` (every other one beyond six) and always at
    A = 1, the isotropic body, where the axis spans it."""
    values = np.unique(np.asarray(list(values), dtype=float))
    ticks = values[::2] if len(values) > 6 else values
    if values.min() <= 1.0 <= values.max():
        ticks = np.union1d(ticks, [1.0])
    target = ax.yaxis if axis == "y" else ax.xaxis
    target.set_ticks(ticks, [f"{a:.3g}" for a in ticks])
    target.set_minor_locator(plt.NullLocator())


# Error estimates of the data set (docs/reference/dataset.md): ``V_error`` beside a quantity V,
# float64 over V's dimensions, its estimated relative error |δV|/|V| (of an off-diagonal entry
# relative to the largest diagonal one, ``OFF_DIAGONAL``), NaN where there is none; ``error_status`` over the
# task dimensions, 0 (met the requested accuracy), 1 (not met; still an estimate) or 2 (no
# estimate: a fixed grid, a slip scene, a failed task); the global ``requested_accuracy``.

ERROR_FRACTION = 0.1  # hatched where the estimated error is more than 10 % of the map's range
EXCEEDS_HATCH = "///"  # points whose estimated error is more than ERROR_FRACTION of the range
MISSING_HATCH = "\\\\\\"  # points with a value but no estimate (error_status 2)
NO_ESTIMATE = 2  # error_status: no estimate
NO_ESTIMATES = "no error estimates in this data set (fixed grid)"
OFF_DIAGONAL = re.compile(r"K_(xy|yx|xz|zx|yz|zy)(?P<variant>_coupled)?")  # errors relative to max |K_ii|


def at_points(source: xr.DataArray, da: xr.DataArray) -> xr.DataArray:
    """``source`` (a variable of the data set ``da`` was selected from) at ``da``'s points: each
    dimension of ``source`` at the values ``da`` has along it (a dimension of ``da``, or a scalar
    coordinate left by a selection), broadcast over ``da``'s other dimensions, laid out as ``da``.
    A dimension ``da`` has lost to a reduction gives the largest value along it (for an error:
    a bound)."""
    index = {
        dim: da[dim].values
        for dim in source.dims
        if dim in source.indexes and (dim in da.dims or (dim in da.coords and da[dim].ndim == 0))
    }
    picked = source.sel(index)
    lost = [d for d in picked.dims if d not in da.dims]
    if lost:
        picked = picked.max(lost)
    order = [d for d in da.dims if d in picked.dims]
    shape = [da.sizes[d] if d in picked.dims else 1 for d in da.dims]
    values = np.broadcast_to(picked.transpose(*order).values.reshape(shape), da.shape)
    return xr.DataArray(values.copy(), coords=da.coords, dims=da.dims, name=source.name, attrs=source.attrs)


def has_estimates(ds: xr.Dataset, names: Iterable[str]) -> bool:
    """Whether the data set stores an error estimate for each of ``names`` with at least one
    finite value (a fixed-grid sweep stores none, or NaN everywhere)."""
    return all(f"{n}_error" in ds and bool(np.isfinite(ds[f"{n}_error"].values).any()) for n in names)


def relative_error(ds: xr.Dataset, da: xr.DataArray, names: Sequence[str] | None = None) -> xr.DataArray | None:
    """The estimated relative error of ``da`` (what a panel shows, selected from ``ds``) at its
    points: ``V_error`` of the stored variable ``da.name``, or, for a product or quotient of the
    stored variables ``names`` (K_min/K_max, say), the sum of their relative errors, the
    first-order bound |δ(a·b)|/|a·b|, |δ(a/b)|/|a/b| ≤ |δa|/|a| + |δb|/|b|. NaN where a point has
    no estimate; None when the data set holds no ``V_error`` for one of them."""
    names = [str(da.name)] if names is None else list(names)
    if not all(f"{n}_error" in ds for n in names):
        return None
    total = sum(at_points(ds[f"{n}_error"], da).astype(float) for n in names)
    total.name, total.attrs = f"{da.name}_error", {"long_name": f"estimated relative error of {da.name}", "units": "1"}
    return total


def error_scale(ds: xr.Dataset, da: xr.DataArray, name: str | None = None) -> xr.DataArray:
    """What the relative error of ``da`` (the stored ``name``, default ``da.name``) is relative
    to: |V|, or for an off-diagonal entry (K_xy, K_yx, …; ``OFF_DIAGONAL``) the largest diagonal
    entry max(|K_xx|, |K_yy|, |K_zz|) of the same variant at the same points (the entries the
    data set has)."""
    name = str(da.name) if name is None else name
    off = OFF_DIAGONAL.fullmatch(name)
    diagonal = [n for n in (f"K_{i}{off['variant'] or ''}" for i in ("xx", "yy", "zz")) if n in ds] if off else []
    if not diagonal:
        return abs(da)
    return xr.concat([abs(at_points(ds[n], da)) for n in diagonal], "entry").max("entry")


@dataclass
class ErrorMarks:
    """What a panel shows (``value``) and its estimated errors (``error_marks``).

    ``relative``: the estimated relative error at each point (NaN: no estimate), None when the
    data set has none (``reason`` says why); ``absolute``: the error |V|·relative (for K_xy and
    K_yx × the largest diagonal entry, ``error_scale``), zeros without an estimate; ``exceeds``: points
    whose absolute error is more than ``fraction`` × ``span``, the range nanmax − nanmin of
    ``value`` on the panel (where it is 0, × |V|: the relative error above ``fraction``);
    ``missing``: points with a value but no estimate (``error_status`` 2 or NaN);
    ``requested``: the data set's ``requested_accuracy`` (None when it asked for none)."""

    value: xr.DataArray
    relative: xr.DataArray | None
    absolute: xr.DataArray
    exceeds: xr.DataArray
    missing: xr.DataArray
    span: float
    fraction: float = ERROR_FRACTION
    requested: float | None = None
    reason: str = ""
    drawn: str = (
        ""  # draw_map: "map" (filled, map error + drawing), "drawing" (filled, no estimate of the values), "points"
    )

    @property
    def worst(self) -> float:
        """The largest estimated relative error on the panel (NaN when no point has one)."""
        if self.relative is None:
            return float("nan")
        values = self.relative.values[np.isfinite(self.value.values) & np.isfinite(self.relative.values)]
        return float(values.max()) if values.size else float("nan")


def error_marks(
    ds: xr.Dataset,
    da: xr.DataArray,
    names: Sequence[str] | None = None,
    relative: xr.DataArray | None = None,
    fraction: float = ERROR_FRACTION,
) -> ErrorMarks:
    """The estimated errors of the panel ``da`` (a quantity of ``ds`` after the script's
    selection; or a product or quotient of the stored ``names``, ``relative_error``; or with
    its relative error given as ``relative``, laid out as ``da``) and the points where the
    absolute error is more than ``fraction`` of the variation the panel shows (``ErrorMarks``).
    A data set without estimates (an old file, a fixed-grid sweep) gives no marks and the
    reason ``NO_ESTIMATES``."""
    value = da.astype(float)
    shown = np.isfinite(value.values)
    quiet = xr.zeros_like(value, dtype=bool)
    requested = ds.attrs.get("requested_accuracy")
    requested = float(requested) if requested is not None else None
    stored = [str(da.name)] if names is None else list(names)
    if relative is None:
        absent = [n for n in stored if f"{n}_error" not in ds]
        reason = NO_ESTIMATES  # an old file, or a sweep that estimated nothing (fixed grids)
        if absent and len(absent) < len(stored):
            reason = f"no error estimate stored for {', '.join(absent)}"
        if absent or not has_estimates(ds, stored):
            return ErrorMarks(
                value, None, xr.zeros_like(value), quiet, quiet, _span(value), fraction, requested, reason
            )
        relative = relative_error(ds, da, stored)
    relative = relative.astype(float)
    scale = error_scale(ds, value, stored[0]) if len(stored) == 1 else abs(value)
    absolute = (scale * relative).fillna(0.0)
    span = _span(value)
    limit = fraction * (span if span > 0.0 else abs(value))
    exceeds = (absolute > limit) & shown
    missing = np.isfinite(value) & ~np.isfinite(relative)
    if "error_status" in ds:
        missing = missing | (np.isfinite(value) & (at_points(ds["error_status"], da) == NO_ESTIMATE))
    return ErrorMarks(value, relative, absolute, exceeds, missing, span, fraction, requested)


def _span(value: xr.DataArray) -> float:
    """nanmax − nanmin of ``value`` (0 without finite values)."""
    finite = value.values[np.isfinite(value.values)]
    return float(finite.max() - finite.min()) if finite.size else 0.0


def error_caption(marks: ErrorMarks | Iterable[ErrorMarks], shown: str = "hatched") -> str:
    """One line for the caption of a figure of one or more panels (``marks``): the worst
    estimated relative error and what the marks mean — ``shown`` "hatched" (maps,
    ``hatch_errors``), "bars" (``error_bars``) or "band" (``error_band``) — and how many points
    have no estimate; ``NO_ESTIMATES`` (or the reason) when the data set has none."""
    marks = [marks] if isinstance(marks, ErrorMarks) else list(marks)
    drawn = marks[0].drawn if marks else ""
    lead = {"points": "swept points only, nothing drawn between them"}.get(drawn)
    without = list(dict.fromkeys(m.reason for m in marks if m.relative is None))  # in order, once each
    marks = [m for m in marks if m.relative is not None]
    if not marks:
        return "; ".join(filter(None, [lead, *without])) or NO_ESTIMATES
    missing = sum(int(m.missing.values.sum()) for m in marks)
    worst = [m.worst for m in marks if np.isfinite(m.worst)]
    if not worst:
        return "; ".join(filter(None, [lead, f"no error estimate at the {missing} points shown", *without]))
    requested = marks[0].requested
    what = {
        "map": "worst map error of what is drawn {} (interpolation between solves + solves + drawing between grid points)",
        "grid": "worst error of what is drawn {} (solves + drawing between grid points)",
        "points of a map": "worst map error at the points drawn {} (interpolation between solves + solves)",
        "drawing": "worst error of what is drawn {} (the drawing between grid points; the solves unestimated)",
    }.get(drawn, "worst estimated relative error {}")
    parts = [lead] if lead else []
    asked = "map tolerance" if drawn in ("map", "points of a map") else "requested"
    parts.append(what.format(f"{max(worst):.1e}") + (f" ({asked} {requested:.1e})" if requested else ""))
    if shown == "hatched":
        count = sum(int(m.exceeds.values.sum()) for m in marks)
        limit = (
            "one contour interval"
            if drawn in ("map", "drawing")
            else f"{marks[0].fraction * 100:g} % of the map's range"
        )
        parts.append(f"hatched {EXCEEDS_HATCH}: error > {limit} ({count or 'no'} point{'' if count == 1 else 's'})")
        if missing:
            parts.append(f"hatched {MISSING_HATCH}: no estimate ({missing} point{'' if missing == 1 else 's'})")
    else:
        parts.append(f"{'bars' if shown == 'bars' else 'band'}: ± estimated error")
        if missing:
            parts.append(f"no estimate at {missing} point{'' if missing == 1 else 's'}")
    return "; ".join(parts + without)


# Maps. A filled contour map draws every value between its grid points: contourf interpolates
# linearly between neighbours. So a map is drawn filled only where something backs those values:
# an adaptive map (``<name>_map_error``: interpolation between its solves, checked) or a grid of
# at least ``DENSE`` values along each axis; its error is then the map error (or the solves'
# error) plus the error of the drawing between grid points (``drawing_error``), and the caption
# states the worst of that sum over what is drawn. Any other map (a plain sweep on a few nodes)
# draws its points alone, coloured by value, and nothing between them (``draw_map``).

MAP_ERROR = "_map_error"
DENSE = 9  # values along each axis of a plain sweep's map for it to be drawn filled
#: Factor on the drawing error's estimate (|f''| h²/8 with f'' from the grid's second divided
#: differences at the interval's ends): f'' may peak inside an interval.
DRAWING_SAFETY = 2.0


def _drawing_error_1d(x: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Along the last axis of ``values`` (coordinates ``x``): the error of linear interpolation
    between neighbouring points, h²|f''|/8 on an interval of width h (Davis, *Interpolation
    and Approximation*, 1963, Thm. 3.1.1), with f'' the larger second divided difference at the
    interval's ends, × ``DRAWING_SAFETY``; each point gets the larger of its two intervals'.
    NaN with fewer than three points (no second difference)."""
    x = np.asarray(x, dtype=float)
    if len(x) < 3:
        return np.full(values.shape, np.nan)
    h = np.diff(x)  # signed: an axis may run down (b/a from 1)
    slope = np.diff(values, axis=-1) / h
    second = 2.0 * np.abs(np.diff(slope, axis=-1) / (h[:-1] + h[1:]))  # at the interior points
    second = np.concatenate([second[..., :1], second, second[..., -1:]], axis=-1)  # ends: their neighbour's
    interval = DRAWING_SAFETY * h**2 * np.fmax(second[..., :-1], second[..., 1:]) / 8.0
    edge = np.full(values.shape[:-1] + (1,), np.nan)
    left = np.concatenate([edge, interval], axis=-1)
    right = np.concatenate([interval, edge], axis=-1)
    return np.fmax(left, right)


def drawing_error(x: np.ndarray, y: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The absolute error of a filled map of ``values`` (shape ``(len(y), len(x))``) between
    its grid points, at each point the worst of the cells it corners: the errors of linear
    interpolation along x and along y add (``_drawing_error_1d``)."""
    values = np.asarray(values, dtype=float)
    along_x = _drawing_error_1d(np.asarray(x, dtype=float), values)
    along_y = _drawing_error_1d(np.asarray(y, dtype=float), values.T).T
    return along_x + along_y


def map_error(ds: xr.Dataset, da: xr.DataArray, names: Sequence[str] | None = None) -> xr.DataArray | None:
    """The map error of the panel ``da`` from the data set's ``<name>_map_error`` (an adaptive
    map; the sum over ``names`` for a product or quotient of stored variables), None when the
    data set has none for one of them."""
    names = [str(da.name)] if names is None else list(names)
    if not all(f"{n}{MAP_ERROR}" in ds for n in names):
        return None
    return sum(at_points(ds[f"{n}{MAP_ERROR}"], da).astype(float) for n in names)


def point_marks(ds: xr.Dataset, da: xr.DataArray, names: Sequence[str] | None = None) -> ErrorMarks:
    """``error_marks`` of values shown at their grid points (curves): of an adaptive map its
    map error (an interpolated point's value is an interpolation), else the solves' estimates."""
    error = map_error(ds, da, names)
    if error is None:
        return error_marks(ds, da, names)
    marks = error_marks(ds, da, names, relative=error)
    marks.drawn, marks.requested = "points of a map", float(ds.attrs.get("adaptive_tolerance", 0.0)) or None
    return marks


def filled(ds: xr.Dataset, da: xr.DataArray, names: Sequence[str] | None = None) -> bool:
    """Whether the map of ``da`` is drawn filled: an adaptive map, or ``DENSE`` values or more
    along each of its axes."""
    return map_error(ds, da, names) is not None or all(da.sizes[d] >= DENSE for d in da.dims)


def draw_map(ax, ds: xr.Dataset, da: xr.DataArray, x, y, levels, names: Sequence[str] | None = None, lines: int = 4):
    """Draw the map of ``da`` (a quantity of ``ds`` over ``(y, x)``; or a product or quotient
    of the stored ``names``) on ``ax`` with the colour ``levels``, and return ``(mappable,
    marks)`` for the colour bar and ``error_caption``. Filled (``filled``): contours, every
    ``lines``-th level labelled, the map error plus the drawing error at every point, hatched
    where that is more than one contour interval. Otherwise the swept points alone, coloured
    squares, their solves' estimated errors, the points that exceed hatched. The points are
    marked (``mark_points``; an adaptive map's: those it solved)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    values = np.asarray(da.values, dtype=float)
    if not filled(ds, da, names):
        marks = error_marks(ds, da, names)
        X, Y = np.meshgrid(x, y)
        ok = np.isfinite(values)
        style = {"marker": "s", "s": 120, "cmap": "viridis", "vmin": levels[0], "vmax": levels[-1], "zorder": 3}
        style["clip_on"] = False  # most grids end at their extreme values: the squares there whole
        mappable = ax.scatter(X[ok], Y[ok], c=values[ok], edgecolors="k", linewidths=0.4, **style)
        for mask, hatch in ((marks.exceeds, EXCEEDS_HATCH), (marks.missing, MISSING_HATCH)):
            chosen = np.asarray(mask, dtype=bool) & ok
            if chosen.any():
                ax.scatter(
                    X[chosen], Y[chosen], marker="s", s=120, facecolors="none", hatch=hatch, zorder=4, clip_on=False
                )
        mark_points(ax, x, y, values)
        marks.drawn = "points"
        return mappable, marks
    base = map_error(ds, da, names)
    drawn = "map"
    marks_base = error_marks(ds, da, names) if base is None else None
    if base is None and marks_base.relative is not None:
        base, drawn = marks_base.relative, "grid"
    drawing = drawing_error(x, y, values) / np.abs(error_scale(ds, da, (names or [str(da.name)])[0]).values)
    relative = xr.DataArray(drawing, coords=da.coords, dims=da.dims)
    relative = relative + (base.fillna(0.0) if base is not None else 0.0)
    span = _span(da.astype(float))
    interval = float(levels[1] - levels[0])
    marks = error_marks(ds, da, names, relative=relative, fraction=interval / span if span > 0.0 else ERROR_FRACTION)
    if base is None:
        marks.reason = marks_base.reason if marks_base is not None else NO_ESTIMATES
    marks.drawn = drawn if base is not None else "drawing"
    mappable = ax.contourf(x, y, values, levels=levels, cmap="viridis")
    contour = ax.contour(x, y, values, levels=levels[::lines], colors="w", linewidths=0.6)
    ax.clabel(contour, fmt="%.2f", fontsize=7)
    hatch_errors(ax, x, y, marks)
    if drawn == "map" and "solved" in ds:  # an adaptive map: the points it solved
        solved = at_points(ds["solved"], da).values == 1
        X, Y = np.meshgrid(x, y)
        ax.plot(
            X[solved], Y[solved], "o", ms=2.2, mfc="k", mec="w", mew=0.3, ls="none", label="solved points", zorder=4
        )
        marks.requested = float(ds.attrs.get("adaptive_tolerance", 0.0)) or None
    else:
        mark_points(ax, x, y, values)
    return mappable, marks


def hatch_errors(ax, x: np.ndarray, y: np.ndarray, marks: ErrorMarks) -> list:
    """Hatch a map (``values`` of shape ``(len(y), len(x))``, as ``mark_points``) over its points
    whose estimated error exceeds ``ERROR_FRACTION`` of the range (``EXCEEDS_HATCH``) and over
    those without an estimate (``MISSING_HATCH``): unfilled filled-contours of the masks (the
    region nearer a marked point than an unmarked one; vector hatches in PDF and SVG too).
    Returns the contour sets drawn (none when no point is marked)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    drawn = []
    for mask, hatch in ((marks.exceeds, EXCEEDS_HATCH), (marks.missing, MISSING_HATCH)):
        values = np.asarray(mask, dtype=float)
        if values.shape != (len(y), len(x)):
            raise ValueError(f"marks of shape {values.shape} on a map of {len(y)} × {len(x)} points")
        if values.any():
            drawn.append(ax.contourf(x, y, values, levels=[0.5, 1.5], colors="none", hatches=[hatch], zorder=3))
    return drawn


def error_bars(ax, x, y, error, colour) -> object | None:
    """Vertical bars ± ``error`` (absolute) at the points (x, y) that have an estimate; no
    marker or cap lines (the points are plotted by the script). None when no point has one."""
    x, y, error = (np.asarray(v, dtype=float) for v in (x, y, error))
    ok = np.isfinite(y) & np.isfinite(error) & (error > 0.0)
    if not ok.any():
        return None
    return ax.errorbar(x[ok], y[ok], yerr=error[ok], fmt="none", ecolor=colour, elinewidth=0.9, capsize=0, zorder=3)


def error_band(ax, x, y, error, colour) -> object | None:
    """A shaded band y ± ``error`` (absolute) along a curve, where it has an estimate; None when
    no point has one."""
    x, y, error = (np.asarray(v, dtype=float) for v in (x, y, error))
    ok = np.isfinite(y) & np.isfinite(error) & (error > 0.0)
    if not ok.any():
        return None
    return ax.fill_between(x, y - error, y + error, where=ok, color=colour, alpha=0.25, lw=0.0)
