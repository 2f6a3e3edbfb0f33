"""K_nn(θ), the tangential stiffness along the load direction, per shape (Li 2017 Figs. 2, 3, 6).

    python postprocess/polar.py results/demo.nc figures/ [--aspect 0.2] [--shapes star square] [--format svg]

Writes ``polar.png`` (one polar panel per shape, one curve per nu; θ over the full circle,
K_nn(θ + 180°) = K_nn(θ)) and ``knn_vs_angle.png`` (the same on Cartesian axes, θ from 0 to
180°, as Li plots it). Shown is Li's normalized stiffness K_nn E*/(K_zz G*) when the sweep
solved K_zz (1 for a circle), else K_nn in units of G·a. Shapes with a b/a axis are taken at
``--aspect`` (nearest value, default 0.2 as Li's Fig. 6); other axes at their first value.

Where the data set estimates the error of the quantity shown (``normalized_nn_error`` or
``K_nn_error``), each curve carries a shaded band ± the estimated error (polar) or bars (the
Cartesian points), and the title states the worst estimated relative error; a data set without
estimates says so there.
"""

from __future__ import annotations

import freshness

if __name__ == "__main__":
    freshness.exit_if_fresh(__file__)  # before the imports that take seconds: an up-to-date run ends here

import numpy as np
from common import (
    arguments,
    by_shape,
    colours,
    error_band,
    error_bars,
    error_caption,
    error_marks,
    label,
    open_dataset,
    panels,
    refuse,
    require_values,
    save,
    scalar_notes,
    select_rest,
    shapes,
)
from matplotlib.ticker import MaxNLocator


def stiffness(ds):
    """Li's normalized K_nn when available, else K_nn."""
    for name in ("normalized_nn", "K_nn"):
        if name in ds and "angle" in ds[name].dims:
            return ds[name]
    refuse("the data set has no K_nn(angle): sweep with an angle axis and the tangential quantity")


def curves_per_nu(da, shape, aspect):
    """(nu or None, curve over angle) pairs for one shape, and a note on the values taken."""
    da = by_shape(da, shape)
    keep = ["angle", "nu"] if "nu" in da.dims else ["angle"]
    da, note = select_rest(da, keep, {"aspect": aspect})
    if "nu" not in da.dims:
        return [(None, da)], note
    return [(float(nu), da.sel(nu=nu)) for nu in da["nu"].values], note


def polar(ds, da, names, aspect, outdir) -> None:
    fig, axes = panels(len(names), polar=True)
    note = ""
    errors = []
    for ax, shape in zip(axes, names):
        pairs, note = curves_per_nu(da, shape, aspect)
        low, high = np.inf, -np.inf
        for colour, (nu, curve) in zip(colours(len(pairs)), pairs):
            theta = np.radians(np.concatenate([curve["angle"].values, curve["angle"].values + 180.0]))
            values = np.concatenate([curve.values, curve.values])
            errors.append(error_marks(ds, curve))
            band = np.concatenate([errors[-1].absolute.values, errors[-1].absolute.values])
            error_band(ax, theta, values, band, colour)
            ax.plot(theta, values, "-", lw=1.2, color=colour, label=None if nu is None else f"ν = {nu:.2g}")
            low, high = min(low, np.nanmin(values - band)), max(high, np.nanmax(values + band))
        pad = max(0.25 * (high - low), 1e-3 * abs(high))
        ax.set_rlim(low - pad, high + pad)
        ax.yaxis.set_major_locator(MaxNLocator(4))
        ax.set_rlabel_position(90)
        ax.tick_params(labelsize=7)
        ax.set_title(shape, fontsize=10)
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside right center", fontsize=8)
    notes = ", ".join(filter(None, [note, scalar_notes(ds)]))
    fig.suptitle(
        f"{label(da)} versus load direction θ (radial axis offset){f' — {notes}' if notes else ''}\n"
        + error_caption(errors, "band"),
        fontsize=10,
    )
    save(fig, outdir, "polar.png")


def cartesian(ds, da, names, aspect, outdir) -> None:
    fig, axes = panels(len(names))
    note = ""
    errors = []
    for ax, shape in zip(axes, names):
        pairs, note = curves_per_nu(da, shape, aspect)
        for colour, (nu, curve) in zip(colours(len(pairs)), pairs):
            errors.append(error_marks(ds, curve))
            error_bars(ax, curve["angle"], curve, errors[-1].absolute, colour)
            ax.plot(
                curve["angle"], curve, "o-", ms=2.5, lw=1.0, color=colour, label=None if nu is None else f"ν = {nu:.2g}"
            )
        ax.set_xlabel(label(ds["angle"], "load direction θ"))
        ax.set_ylabel(label(da, "K_nn E*/(K_zz G*)" if da.name == "normalized_nn" else "K_nn"))
        ax.set_xticks(np.arange(0.0, 181.0, 45.0))
        ax.set_title(shape, fontsize=10)
        ax.grid(True, alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside right center", fontsize=8)
    notes = ", ".join(filter(None, [note, scalar_notes(ds)]))
    fig.suptitle(
        f"{label(da)} versus load direction{f' — {notes}' if notes else ''}\n{error_caption(errors, 'bars')}",
        fontsize=10,
    )
    save(fig, outdir, "knn_vs_angle.png")


def main() -> None:
    args = arguments(
        __doc__.splitlines()[0],
        [
            ("--aspect", {"type": float, "default": 0.2, "help": "b/a for shapes with an aspect axis (nearest)"}),
            ("--shapes", {"nargs": "+", "help": "shapes to plot (default: all)"}),
        ],
    )
    with freshness.stamp(__file__, args.outdir, [args.dataset]):
        ds = open_dataset(args.dataset)
        da = stiffness(ds)
        require_values(ds, [str(da.name)], args.dataset)
        names = args.shapes or shapes(ds)
        polar(ds, da, names, args.aspect, args.outdir)
        cartesian(ds, da, names, args.aspect, args.outdir)


if __name__ == "__main__":
    main()
