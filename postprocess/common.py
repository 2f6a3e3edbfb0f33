"""Helpers shared by the post-processing scripts: arguments, selections, labels, saving.

The scripts read a sweep data set (docs/design.md §4.2) through ``hpcontact.open_dataset`` (the
labelled hypercube, K_nn along the angle) and write PNGs; run them as
``python postprocess/<script>.py DATASET OUTDIR [options]``.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

import hpcontact  # noqa: E402

SYMBOLS = {"nu": "ν", "aspect": "b/a", "angle": "θ", "anisotropy": "A", "orientation": "ψ", "n": "n", "tol": "tol"}


def arguments(description: str, extra: Iterable[tuple[str, dict]] = ()) -> argparse.Namespace:
    """``dataset`` and ``outdir`` plus the script's own options."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("dataset", type=Path, help="sweep data set (netCDF) written by hpcontact run")
    parser.add_argument("outdir", type=Path, help="folder for the PNG files (created if missing)")
    for flag, options in extra:
        parser.add_argument(flag, **options)
    args = parser.parse_args()
    args.outdir.mkdir(parents=True, exist_ok=True)
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


def select_rest(da: xr.DataArray, keep: Iterable[str], choose: dict[str, float] | None = None) -> tuple[xr.DataArray, str]:
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
        rows, cols, figsize=(size * cols, size * rows * 0.9), squeeze=False,
        subplot_kw={"projection": "polar"} if polar else None, layout="constrained",
    )
    flat = list(axes.ravel())
    for ax in flat[count:]:
        ax.remove()
    return fig, flat[:count]


def save(fig: plt.Figure, outdir: Path, name: str) -> Path:
    """Write ``fig`` as ``outdir/name`` (PNG, 150 dpi) and close it."""
    path = outdir / name
    fig.savefig(path, dpi=150)
    plt.close(fig)
    print(f"wrote {path}")
    return path
