"""Helpers shared by the post-processing scripts: arguments, selections, labels, maps, saving.

The scripts read a sweep data set (docs/design.md §4.2) through ``hpcontact.open_dataset`` (the
labelled hypercube, K_nn along the angle) and write figures; run them as
``python postprocess/<script>.py DATASET OUTDIR [--format png|pdf|svg] [--force] [options]``.

Every figure uses matplotlib's constrained layout, and ``save`` wraps a title wider than its
figure (or its axes) onto more lines, so no title is cut. Contour maps of a coarse grid mark
the grid points they interpolate between (``mark_points``); anisotropy axes carry a tick at
A = 1, the isotropic body (``anisotropy_ticks``).

``save`` reports every file to ``freshness`` (standard library only), which stamps the output
folder when a script has drawn everything; a script run again with nothing changed stops at
``freshness.exit_if_fresh``, before this module's imports, and ``--force`` (``arguments``)
draws anyway.
"""

from __future__ import annotations

import argparse
import textwrap
from collections.abc import Iterable
from pathlib import Path

import freshness
import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

import hpcontact  # noqa: E402

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
    args.outdir.mkdir(parents=True, exist_ok=True)
    use_format(args.format)
    return args


def open_dataset(path: Path) -> xr.Dataset:
    """The sweep data set (``hpcontact.open_dataset``), loaded into memory and closed."""
    with hpcontact.open_dataset(path) as ds:
        return ds.load()


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
    note naming the values taken."""
    keep = set(keep)
    choose = {**{d: v for d, v in PREFERRED.items() if d in da.dims and np.any(da[d].values == v)}, **(choose or {})}
    notes = []
    for dim in [d for d in da.dims if d not in keep]:
        if dim in choose and da[dim].dtype.kind == "f":
            da = da.sel({dim: choose[dim]}, method="nearest")
        elif dim in choose:
            da = da.sel({dim: choose[dim]})
        else:
            da = da.isel({dim: 0})
        notes.append(value_text(da.coords.to_dataset(), dim))
    return da, ", ".join(notes)


def scalar_notes(ds: xr.Dataset, names: Iterable[str] = ("nu", "n", "tol", "aspect")) -> str:
    """Fixed settings of the sweep (scalar coordinates) as a note."""
    return ", ".join(value_text(ds, n) for n in names if n in ds.coords and ds[n].ndim == 0)


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


def save(fig: plt.Figure, outdir: Path, name: str, dpi: int = DPI) -> Path:
    """Write ``fig`` as ``outdir/name`` in the chosen format (``use_format``: the name's suffix
    becomes .png, .pdf or .svg; PNGs at ``dpi``), its titles fitted (``fit_titles``), and close
    it; the file is reported to ``freshness.wrote`` for the output folder's stamp."""
    path = outdir / Path(name).with_suffix("." + plt.rcParams["savefig.format"])
    fit_titles(fig)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    freshness.wrote(path)
    print(f"wrote {path}")
    return path


def fit_titles(fig: plt.Figure) -> None:
    """Wrap the figure's suptitle and its axes' titles onto more lines where they are wider
    than the figure (suptitle) or their axes (titles, with a little room to the sides), so
    that none is cut at the edge of the figure. Constrained layout then makes room."""
    fig.draw_without_rendering()  # the layout: sizes of the axes and the texts
    renderer = fig.canvas.get_renderer()
    texts = [(getattr(fig, "_suptitle", None), fig.bbox.width * 0.96)]
    for ax in fig.axes:
        room = min(fig.bbox.width * 0.96, ax.bbox.width * 1.15)
        texts += [(title, room) for title in (ax.title, ax._left_title, ax._right_title)]
    for text, room in texts:
        if text is None or not text.get_text() or not text.get_visible():
            continue
        width = text.get_window_extent(renderer).width
        if width <= room:
            continue
        lines = text.get_text().splitlines()
        longest = max(len(line) for line in lines)
        columns = max(12, int(longest * room / width))
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
