"""Where an adaptive sweep solved (docs/howto/adaptive.md): its map with the solved points.

    python postprocess/adaptive_points.py results/adaptive_orientation_map.nc figures/ [--quantity K_a_over_K_b]

Draws ``adaptive_points.png``: for every pair of numeric task axes of the data set (log axes for
b/a), a panel of the quantity (default K_a_over_K_b, else the first stiffness) at the other axes'
first values, filled, with the solved points (``solved`` = 1) marked as black dots and the
interpolated ones as small grey dots, and beside it ``<quantity>_map_error``, the estimated
relative error of the map (log colour scale). A data set without ``solved`` (an ordinary sweep)
is refused: every point of it was solved.
"""

from __future__ import annotations

import itertools
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import LogNorm  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

NUMERIC = ("aspect", "nu", "anisotropy", "orientation", "load", "mu", "q_ratio")


def main() -> None:
    args = common.arguments(
        "Where an adaptive sweep solved: its map with the solved points.",
        [("--quantity", {"default": None, "help": "the stiffness drawn (default K_a_over_K_b)"})],
    )
    ds = common.open_dataset(args.dataset)
    if "solved" not in ds:
        common.refuse(f"{args.dataset}: not an adaptive sweep (no 'solved' variable)")
    name = args.quantity or ("K_a_over_K_b" if "K_a_over_K_b" in ds else str(next(iter(ds.data_vars))))
    common.require_values(ds, [name], args.dataset)
    axes = [d for d in ds["solved"].dims if d in NUMERIC and ds.sizes[d] > 1]
    if not axes:
        common.refuse(f"{args.dataset}: no numeric axis with two values or more in 'solved' (nothing to map)")
    pairs = list(itertools.combinations(axes, 2)) or [(axes[0], None)]  # a 1-D map: its curve
    fig, grid = plt.subplots(len(pairs), 2, figsize=(9.0, 3.6 * len(pairs)), squeeze=False)
    for row, (x, y) in zip(grid, pairs):
        rest = {d: 0 for d in ds["solved"].dims if d not in (x, y)}
        shown = [d for d in (x, y) if d is not None]
        value = ds[name].isel(rest)
        error = ds[f"{name}_map_error"].isel(rest) if f"{name}_map_error" in ds else None
        solved = ds["solved"].isel(rest).transpose(*shown).values.astype(bool)
        panels = [(row[0], value.transpose(*shown).values, name, None)]
        if error is not None:
            floor = max(float(np.nanmin(error.values[error.values > 0], initial=1e-12)), 1e-12)
            panels.append((row[1], np.maximum(error.transpose(*shown).values, floor), f"{name}_map_error", LogNorm()))
        for ax, data, title, norm in panels:
            if y is None:  # the values along the one axis, solved points black, interpolated grey
                X, Y = ds[x].values, data
                ax.plot(X, Y, "-", color="0.6", lw=0.8)
                ax.set_ylabel(title)
                if norm is not None:
                    ax.set_yscale("log")
            else:
                X, Y = np.meshgrid(ds[x].values, ds[y].values, indexing="ij")
                mesh = ax.pcolormesh(X, Y, data, shading="nearest", norm=norm)
                fig.colorbar(mesh, ax=ax)
                ax.set_ylabel(common.label(ds[y]))
            ax.plot(X[~solved], Y[~solved], ".", color="0.6", ms=2)
            ax.plot(X[solved], Y[solved], "k.", ms=5)
            if x == "aspect":
                ax.set_xscale("log")
            ax.set_xlabel(common.label(ds[x]))
            fixed = ", ".join(f"{d} = {ds[d].values[0]:g}" for d in rest if np.issubdtype(ds[d].dtype, np.number))
            ax.set_title(f"{title}{f' ({fixed})' if fixed else ''}", fontsize=8)
    fig.suptitle(
        f"{ds.attrs.get('title', '')}: {ds.attrs.get('sweep_solves')} solves for {int(ds['solved'].size)} points "
        "(black: solved, grey: interpolated)",
        fontsize=9,
    )
    fig.tight_layout()
    print(common.save(fig, args.outdir, "adaptive_points"))


if __name__ == "__main__":
    main()
