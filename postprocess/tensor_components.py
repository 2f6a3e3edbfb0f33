"""The four tangential stiffness components versus load angle, with the transformation law as
lines (Li 2017 Fig. 4, eq. 6).

    python postprocess/tensor_components.py results/li2017_rotated.nc figures/ [--nu 0.3] [--aspect 0.2] [--format pdf]

In axes (n, t) turned by θ, n = (cos θ, sin θ), t = (−sin θ, cos θ), the components are
K_nn = nᵀKn, K_nt = nᵀKt, K_tn = tᵀKn, K_tt = tᵀKt. With c = cos θ, s = sin θ (eq. 6):

    K_nn =  c²K_xx + cs(K_xy + K_yx) + s²K_yy      K_nt = cs(K_yy − K_xx) + c²K_xy − s²K_yx
    K_tt =  s²K_xx − cs(K_xy + K_yx) + c²K_yy      K_tn = cs(K_yy − K_xx) + c²K_yx − s²K_xy

Lines: this law applied to the tensor solved at θ = 0 (the angle nearest 0). Points: in a
rotated-mode sweep (``angle_mode = "rotated"``, Li's method: the shape turned by −θ, loaded along
x) the components solved independently at every θ — the figure then tests the law and the
grid's isotropy; in a tensor-mode sweep, RᵀKR of the tensor at each θ (a consistency check).
One figure ``tensor_components_<shape>.png`` per shape; K in units of G·a.

Where the data set estimates the components' errors (``K_xx_error`` …; those of K_xy and K_yx
relative to the largest diagonal entry), the points carry bars ± the estimated error: in a
rotated-mode sweep each component's own, in a tensor-mode sweep the bound the law gives,
|δK_nn| ≤ c²|δK_xx| + |cs|(|δK_xy| + |δK_yx|) + s²|δK_yy| and so on (``law_bound``); the title
states the worst estimated relative error of the components, or that the data set has none.
"""

from __future__ import annotations

import freshness

if __name__ == "__main__":
    freshness.exit_if_fresh(__file__)  # before the imports that take seconds: an up-to-date run ends here

import numpy as np
from common import (
    arguments,
    by_shape,
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

from hpcontact.quantities import rotated_tensor

COMPONENTS = ("K_xx", "K_xy", "K_yx", "K_yy")
NAMES = ("K_nn", "K_nt", "K_tn", "K_tt")


def transformation_law(K: np.ndarray, theta_deg: np.ndarray) -> np.ndarray:
    """(K_nn, K_nt, K_tn, K_tt) at each θ from the 2 × 2 tensor K (Li 2017 eq. 6), shape (4, nθ)."""
    t = np.radians(theta_deg)
    c, s = np.cos(t), np.sin(t)
    xx, xy, yx, yy = K[0, 0], K[0, 1], K[1, 0], K[1, 1]
    return np.array(
        [
            c * c * xx + c * s * (xy + yx) + s * s * yy,
            c * s * (yy - xx) + c * c * xy - s * s * yx,
            c * s * (yy - xx) + c * c * yx - s * s * xy,
            s * s * xx - c * s * (xy + yx) + c * c * yy,
        ]
    )


def law_bound(errors: np.ndarray, theta_deg: np.ndarray) -> np.ndarray:
    """Bounds of the errors of (K_nn, K_nt, K_tn, K_tt) at each θ, shape (4, nθ), from the
    absolute errors (δK_xx, δK_xy, δK_yx, δK_yy) of the tensor: eq. 6 with the absolute values
    of its coefficients (|δK_nn| ≤ c²|δK_xx| + |cs|(|δK_xy| + |δK_yx|) + s²|δK_yy|, ...)."""
    units = np.eye(4).reshape(4, 2, 2)  # K_xx, K_xy, K_yx, K_yy alone
    return sum(np.abs(transformation_law(unit, theta_deg)) * error for unit, error in zip(units, errors))


def figure(ds, shape: str, choose: dict, outdir) -> None:
    rotated = "angle" in ds["K_xx"].dims
    tensor = []
    note = ""
    for name in COMPONENTS:
        da, note = select_rest(by_shape(ds[name], shape), ["angle"] if rotated else [], choose)
        tensor.append(da)
    errors = [error_marks(ds, da) for da in tensor]  # of K_xy, K_yx: relative to the largest diagonal entry
    fine = np.linspace(0.0, 180.0, 361)
    angles = ds["angle"].values
    if rotated:
        zero = int(np.argmin(np.abs(angles)))
        points = np.array([da.values for da in tensor])
        K0 = points[:, zero].reshape(2, 2)
        source = "points: Li's rotated-shape solves"
        bars = np.array([e.absolute.values for e in errors])
    else:
        K0 = np.array([float(da) for da in tensor]).reshape(2, 2)
        points = np.array([rotated_tensor(K0, a).ravel() for a in angles]).T
        source = "points: RᵀKR of the solved tensor"
        bars = law_bound(np.array([float(e.absolute) for e in errors]), angles)
    lines = transformation_law(K0, fine)
    fig, axes = panels(4, size=3.6, columns=2)
    unit = ds["K_xx"].attrs.get("scale", ds["K_xx"].attrs.get("units", ""))  # scaled: "G a"
    for ax, name, line, point, bar in zip(axes, NAMES, lines, points, bars):
        ax.plot(fine, line, "-", lw=1.2, color="C0", label="transformation law (eq. 6)")
        error_bars(ax, angles, point, bar, "C1")
        ax.plot(angles, point, "o", ms=3.5, color="C1", label=source)
        ax.set_xlabel(label(ds["angle"], "load direction θ"))
        ax.set_ylabel(f"{name} [{unit}]" if unit and unit != "1" else name)
        ax.set_xticks(np.arange(0.0, 181.0, 45.0))
        ax.grid(True, alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize=8)
    notes = ", ".join(filter(None, [note, scalar_notes(ds)]))
    fig.suptitle(
        f"{shape}: tangential stiffness tensor in axes turned by θ{f' — {notes}' if notes else ''}\n"
        + error_caption(errors, "bars"),
        fontsize=10,
    )
    save(fig, outdir, f"tensor_components_{shape or 'all'}.png")


def main() -> None:
    args = arguments(
        __doc__.splitlines()[0],
        [
            ("--nu", {"type": float, "default": None, "help": "Poisson ratio (nearest; default: the largest)"}),
            ("--aspect", {"type": float, "default": 0.2, "help": "b/a for shapes with an aspect axis (nearest)"}),
            ("--shapes", {"nargs": "+", "help": "shapes to plot (default: all)"}),
        ],
    )
    with freshness.stamp(__file__, args.outdir, [args.dataset]):
        ds = open_dataset(args.dataset)
        if not set(COMPONENTS) <= set(ds.data_vars) or "angle" not in ds.dims:
            refuse(f"{args.dataset}: needs K_xx, K_xy, K_yx, K_yy and an angle axis")
        require_values(ds, COMPONENTS, args.dataset)
        choose = {"aspect": args.aspect}
        if "nu" in ds.dims:
            choose["nu"] = args.nu if args.nu is not None else float(ds["nu"].max())
        for shape in args.shapes or shapes(ds):
            figure(ds, shape, choose, args.outdir)


if __name__ == "__main__":
    main()
