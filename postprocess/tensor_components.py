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
"""

from __future__ import annotations

import freshness

if __name__ == "__main__":
    freshness.exit_if_fresh(__file__)  # before the imports that take seconds: an up-to-date run ends here

import numpy as np
from common import arguments, by_shape, label, open_dataset, panels, save, scalar_notes, select_rest, shapes

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


def figure(ds, shape: str, choose: dict, outdir) -> None:
    rotated = "angle" in ds["K_xx"].dims
    tensor = []
    note = ""
    for name in COMPONENTS:
        da, note = select_rest(by_shape(ds[name], shape), ["angle"] if rotated else [], choose)
        tensor.append(da)
    fine = np.linspace(0.0, 180.0, 361)
    angles = ds["angle"].values
    if rotated:
        zero = int(np.argmin(np.abs(angles)))
        points = np.array([da.values for da in tensor])
        K0 = points[:, zero].reshape(2, 2)
        source = "points: Li's rotated-shape solves"
    else:
        K0 = np.array([float(da) for da in tensor]).reshape(2, 2)
        points = np.array([rotated_tensor(K0, a).ravel() for a in angles]).T
        source = "points: RᵀKR of the solved tensor"
    lines = transformation_law(K0, fine)
    fig, axes = panels(4, size=3.6, columns=2)
    unit = ds["K_xx"].attrs.get("scale", ds["K_xx"].attrs.get("units", ""))  # scaled: "G a"
    for ax, name, line, point in zip(axes, NAMES, lines, points):
        ax.plot(fine, line, "-", lw=1.2, color="C0", label="transformation law (eq. 6)")
        ax.plot(angles, point, "o", ms=3.5, color="C1", label=source)
        ax.set_xlabel(label(ds["angle"], "load direction θ"))
        ax.set_ylabel(f"{name} [{unit}]" if unit and unit != "1" else name)
        ax.set_xticks(np.arange(0.0, 181.0, 45.0))
        ax.grid(True, alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize=8)
    notes = ", ".join(filter(None, [note, scalar_notes(ds)]))
    fig.suptitle(
        f"{shape}: tangential stiffness tensor in axes turned by θ{f' — {notes}' if notes else ''}", fontsize=10
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
            raise SystemExit(f"{args.dataset}: needs K_xx, K_xy, K_yx, K_yy and an angle axis")
        choose = {"aspect": args.aspect}
        if "nu" in ds.dims:
            choose["nu"] = args.nu if args.nu is not None else float(ds["nu"].max())
        for shape in args.shapes or shapes(ds):
            figure(ds, shape, choose, args.outdir)


if __name__ == "__main__":
    main()
