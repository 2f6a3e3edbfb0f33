"""K_a/K_b versus b/a and nu: curves on a log axis against Mindlin's ellipse, and filled maps.

    python postprocess/anisotropy_map.py results/demo.nc figures/ [--shapes ellipse rectangle] [--format pdf]

Writes ``anisotropy_curves.png`` (one panel per shape: K_a/K_b = K_xx/K_yy versus b/a, points
per nu, Mindlin's bonded ellipse as lines, Li 2017 Fig. 7) and ``anisotropy_map_<shape>.png``
over log10 b/a and nu: filled contours where the data back the values between the grid points
(an adaptive map, or a dense grid: ``common.draw_map``; the caption states the worst map error
of what is drawn), the swept points alone, coloured, otherwise (the points marked on a coarse
grid); shapes whose
stiffness ignores b/a are left out. Other axes (anisotropy, orientation, n, tol) are taken at
their first value (A = 1 where swept) and named in the title. ``--format pdf`` or ``svg``
writes those instead of PNGs.

Where the data set estimates the error of K_a/K_b (``K_a_over_K_b_error``), the curves carry
bars ± the estimated error, a filled map is hatched where its error is more than one contour
interval, a map of points where a point's error is more than 10 % of the map's range
(``common.ERROR_FRACTION``; points without an estimate hatched the other way) and each title
states the worst error; a data set without estimates says so there.
"""

from __future__ import annotations

import freshness

if __name__ == "__main__":
    freshness.exit_if_fresh(__file__)  # before the imports that take seconds: an up-to-date run ends here

import matplotlib.pyplot as plt
import numpy as np
from common import (
    COARSE,
    arguments,
    by_shape,
    colours,
    draw_map,
    error_bars,
    error_caption,
    fixed_shape,
    label,
    open_dataset,
    panels,
    parameter_values,
    point_marks,
    refuse,
    require_values,
    save,
    scalar_notes,
    select_rest,
    shapes,
)
from matplotlib.ticker import MaxNLocator

from hpcontact.analytic import mindlin_ellipse_stiffness_ratio

RATIO = "K_a_over_K_b"
CURVES = 6  # nu values drawn as curves at most


def depends_on_aspect(ds, shape: str) -> bool:
    """Whether the shape's K_a/K_b changes along b/a (polygons and stars ignore it)."""
    da = by_shape(ds[RATIO], shape)
    spread = da.max("aspect") - da.min("aspect")
    return bool((spread > 0.0).any())


def shape_name(ds, shape: str) -> str:
    """The shape's label, or the sweep's one shape when shape is not an axis."""
    if shape:
        return shape
    return fixed_shape(ds)


def curves(ds, names, outdir) -> None:
    """K_a/K_b versus b/a per shape, one colour per nu, Mindlin's ellipse as lines."""
    fig, axes = panels(len(names))
    nus = parameter_values(ds, "nu")  # swept, or the scene's one value
    if len(nus) > CURVES:  # a dense map: CURVES of its nu values, evenly spread, the ends included
        nus = nus[np.unique(np.linspace(0, len(nus) - 1, CURVES).round().astype(int))]
    size = 3.5 if ds.sizes["aspect"] <= COARSE else 1.5
    fine = np.logspace(np.log10(ds["aspect"].values.min()), 0.0, 200)
    note = ""
    errors = []
    for ax, shape in zip(axes, names):
        da = by_shape(ds[RATIO], shape)
        for colour, nu in zip(colours(len(nus)), nus):
            at_nu = da.sel(nu=nu) if "nu" in da.dims else da
            at_nu, note = select_rest(at_nu, ["aspect"])
            errors.append(point_marks(ds, at_nu))
            error_bars(ax, at_nu["aspect"], at_nu, errors[-1].absolute, colour)
            ax.plot(at_nu["aspect"], at_nu, "o", ms=size, color=colour, label=f"ν = {nu:.2g}")
            ax.plot(fine, mindlin_ellipse_stiffness_ratio(fine, nu), "-", lw=1.0, color=colour)
        ax.set_xscale("log")
        ax.set_xlabel("aspect ratio b/a")
        ax.set_ylabel("K_a / K_b  (K_xx / K_yy)")
        ax.set_title(shape_name(ds, shape))
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(
        handles,
        labels,
        loc="outside right center",
        fontsize=8,
        title="points: sweep\nlines: Mindlin\nellipse",
        title_fontsize=8,
    )
    notes = ", ".join(filter(None, [note, scalar_notes(ds)]))
    fig.suptitle(
        f"Tangential stiffness anisotropy K_a/K_b (a: major axis along x){f' — {notes}' if notes else ''}\n"
        + error_caption(errors, "bars"),
        fontsize=10,
    )
    save(fig, outdir, "anisotropy_curves.png")


def maps(ds, names, outdir) -> None:
    """Filled contours of K_a/K_b over log10(b/a) and nu."""
    if "nu" not in ds[RATIO].dims or ds.sizes["nu"] < 2 or ds.sizes["aspect"] < 2:
        print("no map: needs nu and aspect axes with two values or more")
        return
    for shape in names:
        da, note = select_rest(by_shape(ds[RATIO], shape), ["aspect", "nu"])
        da = da.transpose("nu", "aspect")
        fig, ax = plt.subplots(figsize=(6.0, 4.2), layout="constrained")
        levels = MaxNLocator(20).tick_values(float(da.min()), 1.0)
        drawn, errors = draw_map(ax, ds, da, np.log10(da["aspect"]), da["nu"], levels)
        fig.colorbar(drawn, ax=ax, label="K_a / K_b  (K_xx / K_yy)")
        ax.set_xlabel("log10(b/a)")
        ax.set_ylabel(label(ds["nu"]))
        notes = ", ".join(filter(None, [note, scalar_notes(ds)]))
        title = f"Bonded {shape_name(ds, shape)}: tangential stiffness ratio K_a/K_b{f' ({notes})' if notes else ''}"
        ax.set_title(f"{title}\n{error_caption(errors)}", fontsize=10)
        save(fig, outdir, f"anisotropy_map_{shape or 'all'}.png")


def main() -> None:
    args = arguments(__doc__.splitlines()[0], [("--shapes", {"nargs": "+", "help": "shapes to plot (default: all)"})])
    with freshness.stamp(__file__, args.outdir, [args.dataset]):
        ds = open_dataset(args.dataset)
        if RATIO not in ds or "aspect" not in ds[RATIO].dims:
            refuse(f"{args.dataset}: needs {RATIO} with an aspect axis (a tangential sweep over b/a)")
        require_values(ds, [RATIO], args.dataset)
        names = [s for s in (args.shapes or shapes(ds)) if depends_on_aspect(ds, s)]
        flat = [s for s in (args.shapes or shapes(ds)) if s not in names]
        if flat:
            print(f"independent of b/a, not plotted: {', '.join(flat)}")
        if not names:
            refuse(f"{args.dataset}: no shape's K_a/K_b depends on b/a")
        curves(ds, names, args.outdir)
        maps(ds, names, args.outdir)


if __name__ == "__main__":
    main()
