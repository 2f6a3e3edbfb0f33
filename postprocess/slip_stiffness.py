"""Tangential stiffness with partial slip: k_t against Q/(mu P) for the seed's sphere pairs.

    mpiexec -n 2 hpcontact run jobs/sphere_pairs.toml
    python postprocess/slip_stiffness.py results/sphere_pairs.nc results/figures/slip/ [--mu 0.2]

Another slip sweep over ``q_ratio`` (a user's own: one pair in ``[scene]``, say, over mu) gets
``kt_ratio.png`` alone, one curve per point of its other axes, and a line naming what the other
figures need; a data set without ``q_ratio`` is refused in one line (exit 2).

Reads the data set of ``jobs/sphere_pairs.toml`` (dimensions pair, load, mu, q_ratio; one
``hpcontact.problems.slip.partial_slip.solve_slip`` record per point, SI units). The pairs' scene fields (materials,
radii, n) are the data set's coordinates, so the scenes solved here for the maps are the
sweep's own.

Figures (PNG in OUTDIR):

* ``kt_vs_q.png`` — one panel per pair: the consistent k_t [N/µm] against Q/(mu P), one colour
  per load; open markers: Goodman's decoupled answer of a dissimilar pair; lines:
  Mindlin–Deresiewicz k_t = 8 a/[(2 − nu1)/G1 + (2 − nu2)/G2] (1 − Q/(mu P))^(1/3) (Johnson
  1985, §7.2, with the analytic Hertz radius a); band: the constant-ratio model
  k_t = c k_n, c = 0.25–0.35 (Sherif; Pan, cited by the seed paper), with the Hertz normal
  stiffness k_n = 3P/(2d).
* ``kt_ratio.png`` — k_t/k_t(0) for every pair, load and mu on one plot: they collapse on
  (1 − Q/(mu P))^(1/3); the constant-ratio model is the band c k_n/k_t(0).
* ``stick_zones.png`` — |t|/(mu p) on the contact of one pair (``--pair``, default Fe–Fe) at one
  load (``--load``, default 100 N) for a few load levels, solved here on the sweep's grid: the
  stick zone outlined and Cattaneo's stick circle c = a(1 − Q/(mu P))^(1/3) dashed.
* ``ellipse_kx_ky.png`` — an Fe ellipsoid (R_a = 8 mm, R_b = 24 mm) on an Fe flat: k along the
  major and the minor axis of the contact ellipse and their ratio against Q/(mu P), Mindlin's
  bonded ellipse at Q = 0 marked (solved here, n = 128 by default: the ratio carries the stick
  area's staircase, ±0.3 % at n = 64; ``--n-ellipse 0`` leaves it out).

Printed: k_t(0)/k_n per pair, the largest deviation from Mindlin–Deresiewicz, where k_t falls
into the constant-ratio band, and the coupled-minus-decoupled differences of the dissimilar pairs.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from hpcontact import analytic  # noqa: E402
from hpcontact.problems.slip.crystal_pair import pair_from_params  # noqa: E402
from hpcontact.problems.slip.partial_slip import PathSolver, SlipProblem, solve_slip, validate  # noqa: E402
from hpcontact.sweep.space.axes import LABEL_AXES  # noqa: E402
from postprocess.common import (  # noqa: E402
    add_format,
    error_caption,
    error_marks,
    open_dataset,
    refuse,
    require,
    save,
    use_format,
    value_text,
)

RATIO_BAND = (0.25, 0.35)  # constant-ratio model k_t = c k_n (seed paper, refs. 5 and 6)
UM = 1e-6  # stiffness shown in N/µm
SWEEP = "jobs/sphere_pairs.toml"  # the sweep whose data set this script draws
#: What ``kt_ratio.png`` draws, from any slip sweep over ``q_ratio`` (``figure_ratio``)
RATIO_DRAWN = ("stiffness_ratio", "normal_stiffness", "no_slip_stiffness")
#: The seed's sweep's axes and variables, which its other figures and the summary need
SEED_AXES = ("pair", "load", "mu", "q_ratio")
DRAWN = (
    "status",
    *RATIO_DRAWN,
    "tangential_stiffness",
    "mindlin_stiffness",
    "mindlin_no_slip_stiffness",
)


def scene_params(point: xr.Dataset) -> dict[str, Any]:
    """The solver fields of one selected point of the data set: its scalar coordinates, label
    coordinates (the pair's name) left out."""
    params = {}
    for name, coord in point.coords.items():
        if coord.ndim == 0 and name not in LABEL_AXES:
            value = coord.values.item()
            params[name] = value.decode() if isinstance(value, bytes) else value
    return params


def along_q(da: xr.DataArray) -> xr.DataArray:
    """A quantity that does not depend on Q (Hertz, bonded stiffness), taken over q_ratio."""
    return da.max("q_ratio", skipna=True)


def figure_kt_vs_q(ds: xr.Dataset, mu: float, outdir: Path) -> None:
    pairs = [str(p) for p in ds["pair"].values]
    cols = min(3, len(pairs))
    rows = math.ceil(len(pairs) / cols)
    fig, axes = plt.subplots(
        rows, cols, figsize=(3.6 * cols, 3.0 * rows), sharex=True, squeeze=False, layout="constrained"
    )
    q_fine = np.linspace(0.0, 0.999, 200)
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, ds.sizes["load"]))
    for ax, pair in zip(axes.flat, pairs):
        for colour, load in zip(colours, ds["load"].values):
            sel = ds.sel(pair=pair, load=load, mu=mu)
            q = sel["q_ratio"].values
            ax.plot(q, sel["tangential_stiffness"] * UM, "o", color=colour, ms=4, label=f"P = {load:g} N")
            if "decoupled_tangential_stiffness" in sel and np.isfinite(sel["decoupled_tangential_stiffness"]).any():
                ax.plot(q, sel["decoupled_tangential_stiffness"] * UM, "o", mfc="none", color=colour, ms=7)
            k0 = float(along_q(sel["mindlin_no_slip_stiffness"]))
            ax.plot(q_fine, k0 * np.cbrt(1.0 - q_fine) * UM, "-", color=colour, lw=1)
            kn = float(along_q(sel["normal_stiffness"]))
            ax.axhspan(RATIO_BAND[0] * kn * UM, RATIO_BAND[1] * kn * UM, color=colour, alpha=0.15, lw=0)
        ax.set_title(pair, fontsize=10)
        ax.set_xlim(0, 1)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("Q/(μP)")
    for ax in axes[:, 0]:
        ax.set_ylabel("k_t [N/µm]")
    for ax in list(axes.flat)[len(pairs) :]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=7, loc="lower left")
    radii = f"R = {float(ds['radius']) * 1e3:g}/{float(ds['radius2']) * 1e3:g} mm, " if ds["radius2"].ndim == 0 else ""
    fig.suptitle(
        f"Sphere pairs, {radii}μ = {mu:g}, n = {int(ds['n'])}: markers solver (open: decoupled), "
        f"lines Mindlin–Deresiewicz, bands k_t = (0.25–0.35) k_n",
        fontsize=9,
    )
    save(fig, outdir, "kt_vs_q.png", dpi=110)


def curve_label(curve: xr.DataArray, others: list[str]) -> str:
    """The legend of a curve of ``figure_ratio``: its value of the first of the ``others`` axes
    (a label axis' text, the pair's "Fe-Fe", as it is), or "sweep" without another axis."""
    if not others:
        return "sweep"
    name = others[0]
    return str(curve[name].values) if name in LABEL_AXES else value_text(curve.coords.to_dataset(), name)


def figure_ratio(ds: xr.Dataset, outdir: Path) -> None:
    """k_t/k_t(0) against Q/(μP), one curve per point of the data set's other axes (marked by
    the first of them: the pair in the seed's sweep), Mindlin–Deresiewicz's (1 − Q/μP)^⅓ and the
    constant-ratio band c k_n/k_t(0)."""
    fig, ax = plt.subplots(figsize=(5.5, 4.2), layout="constrained")
    q_fine = np.linspace(0.0, 0.999, 200)
    ax.plot(q_fine, np.cbrt(1.0 - q_fine), "k-", lw=1.2, label="Mindlin–Deresiewicz (1 − Q/μP)^⅓")
    markers = "osD^v<>p"
    ratio = ds["stiffness_ratio"]
    others = [d for d in ratio.dims if d != "q_ratio"]
    for index in np.ndindex(*(ratio.sizes[d] for d in others)):
        curve = ratio.isel(dict(zip(others, index)))
        ax.plot(
            ds["q_ratio"],
            curve,
            markers[(index[0] if index else 0) % len(markers)],
            ms=3,
            alpha=0.7,
            mfc="none",
            label=curve_label(curve, others) if not any(index[1:]) else None,
        )
    band = ds["normal_stiffness"] / ds["no_slip_stiffness"]
    ax.axhspan(
        RATIO_BAND[0] * float(band.min()),
        RATIO_BAND[1] * float(band.max()),
        color="tab:red",
        alpha=0.12,
        lw=0,
        label="k_t = (0.25–0.35) k_n",
    )
    ax.set_xlabel("Q/(μP)")
    ax.set_ylabel("k_t / k_t(Q = 0)")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.05)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title(
        f"{ds.attrs.get('title', 'k_t / k_t(0)')}\n{error_caption([error_marks(ds, ratio)], 'bars')}", fontsize=9
    )
    save(fig, outdir, "kt_ratio.png", dpi=110)


def figure_stick_zones(
    ds: xr.Dataset, outdir: Path, pair: str, load: float, mu: float, levels=(0.3, 0.6, 0.9), step: float = 0.1
) -> None:
    """|t|/(mu p) at a few levels of one monotonic loading path (steps of ``step`` mu P)."""
    point = ds.sel(pair=pair, load=load, mu=mu).isel(q_ratio=0)
    params = {**scene_params(point), "q_ratio": max(levels)}
    problem = SlipProblem(validate(params))
    solver = PathSolver(problem, coupled=not problem.pair.similar)
    limit = problem.scene.mu * problem.P
    x, y = problem.x * problem.L * 1e6, problem.y * problem.L * 1e6  # µm
    a = problem.hertz.a * 1e6
    targets = np.round(np.arange(1, round(max(levels) / step) + 1) * step, 12)
    fig, axes = plt.subplots(
        1, len(levels), figsize=(3.0 * len(levels) + 0.8, 3.4), squeeze=False, layout="constrained"
    )
    panels = iter(zip(axes[0], levels))
    ax, level = next(panels)
    state = solver.initial
    image = None
    for target in targets:
        state = solver.to_force(state, np.array([target * limit, 0.0]))
        if not math.isclose(target, level):
            continue
        bound = problem.scene.mu * state.p
        ratio = np.where(state.contact, np.hypot(state.t[0], state.t[1]) / np.where(bound > 0, bound, 1.0), np.nan)
        image = ax.pcolormesh(x, y, ratio, vmin=0.0, vmax=1.0, cmap="magma", shading="auto")
        ax.contour(x, y, state.stick.astype(float), levels=[0.5], colors="cyan", linewidths=1.2)
        c = analytic.stick_radius(level * limit, problem.P, problem.scene.mu, 1.0) * a
        phi = np.linspace(0.0, 2.0 * np.pi, 200)
        ax.plot(c * np.cos(phi), c * np.sin(phi), "k--", lw=1.1)
        ax.plot(a * np.cos(phi), a * np.sin(phi), ":", color="grey", lw=1.0)
        stick = math.sqrt(float(state.stick.sum()) * problem.grid.cell_area / math.pi) * problem.L * 1e6
        ax.set_aspect("equal")
        ax.set_title(f"Q/(μP) = {level:g}\nstick radius {stick:.0f} µm (Cattaneo {c:.0f})", fontsize=8)
        ax.set_xlabel("x [µm]")
        try:
            ax, level = next(panels)
        except StopIteration:
            break
    axes[0, 0].set_ylabel("y [µm]")
    fig.colorbar(image, ax=axes[0].tolist(), label="|t| / (μ p)", shrink=0.8)
    radii = f"{params['radius'] * 1e3:g}/{params.get('radius2', math.inf) * 1e3:g} mm"
    fig.suptitle(
        f"{pair}, {radii}, P = {load:g} N, μ = {mu:g}, n = {params.get('n')}: stick zone (cyan), "
        f"Cattaneo's circle (dashed), Hertz a = {a:.0f} µm (dotted)",
        fontsize=9,
    )
    save(fig, outdir, "stick_zones.png", dpi=110)


def figure_ellipse(outdir: Path, n: int = 128, steps: int = 9) -> None:
    base = {
        "radius": 8e-3,
        "radius_b": 24e-3,
        "material": "Fe",
        "material2": "Fe",
        "load": 100.0,
        "mu": 0.3,
        "q_ratio": 0.9,
        "steps": steps,
        "n": n,
        "history": True,
    }
    pair = pair_from_params(base)
    h = pair.hertz(100.0)
    K_a, K_b = analytic.mindlin_ellipse_stiffness(h.a, h.b, pair.equivalent.G, pair.equivalent.nu)
    major = solve_slip({**base, "angle": h.angle_deg})["history"]
    minor = solve_slip({**base, "angle": h.angle_deg + 90.0})["history"]
    q_major = np.array(major["tangential_force"]) / (0.3 * 100.0)
    q_minor = np.array(minor["tangential_force"]) / (0.3 * 100.0)
    k_major, k_minor = np.array(major["tangential_stiffness"]), np.array(minor["tangential_stiffness"])
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9.5, 3.8), layout="constrained")
    ax1.plot(q_major, k_major * UM, "o-", ms=4, label="along the major axis a")
    ax1.plot(q_minor, k_minor * UM, "s-", ms=4, label="along the minor axis b")
    ax1.plot([0, 0], [K_a * UM, K_b * UM], "k*", ms=9, label="Mindlin's bonded ellipse")
    ax1.set_xlabel("Q/(μP)")
    ax1.set_ylabel("k_t [N/µm]")
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3)
    ax2.plot(q_major, k_minor / k_major, "o-", ms=4, label="solver, k_b/k_a")
    ax2.axhline(K_b / K_a, color="k", lw=0.8, ls="--", label="Mindlin, Q = 0")
    ax2.set_xlabel("Q/(μP)")
    ax2.set_ylabel("k_b / k_a")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    fig.suptitle(
        f"Fe ellipsoid 8 × 24 mm on Fe flat, P = 100 N, n = {n}: Hertz ellipse b/a = {h.aspect:.3f}", fontsize=10
    )
    save(fig, outdir, "ellipse_kx_ky.png", dpi=110)


def summary(ds: xr.Dataset) -> None:
    """The numbers the figures show: k_t(0)/k_n, deviation from Mindlin–Deresiewicz, where k_t
    enters the constant-ratio band, coupled − decoupled."""
    ok = ds["status"] == 0
    print(f"{int(ok.sum())}/{ok.size} points ok; task wall time {float(ds['wall_time_s'].sum()):.0f} s in all")
    k0 = ds["no_slip_stiffness"]
    ratio0 = along_q(k0 / ds["normal_stiffness"])
    deviation = ds["tangential_stiffness"] / ds["mindlin_stiffness"] - 1.0
    print("pair          k_t(0)/k_n   k_t(0)/Mindlin-1   k_t/MD-1 (all Q)      Q/(mu P) at k_t = 0.35 k_n, 0.25 k_n")
    for pair in ds["pair"].values:
        r0 = float(ratio0.sel(pair=pair).mean())
        d0 = float(along_q(k0 / ds["mindlin_no_slip_stiffness"]).sel(pair=pair).mean() - 1.0)
        dev = deviation.sel(pair=pair)
        # Mindlin–Deresiewicz with the solver's k_t(0): k_t = k_t(0) (1 − q)^(1/3) = c k_n
        q_band = [1.0 - (c / r0) ** 3 for c in RATIO_BAND[::-1]]
        print(
            f"  {str(pair):12s} {r0:8.4f}     {d0:+.2e}          {float(dev.min()):+.2e} … {float(dev.max()):+.2e}"
            f"     {q_band[0]:.3f}, {q_band[1]:.3f}"
        )
    if "coupling_effect_stiffness" in ds:
        print("coupled / decoupled − 1 at the largest Q/(mu P) (k_t, δ), dissimilar pairs:")
        last = ds.isel(q_ratio=-1)
        for pair in ds["pair"].values:
            beta = float(last["dundurs_beta"].sel(pair=pair).max())
            if beta == 0.0:
                continue
            effect_k = last["coupling_effect_stiffness"].sel(pair=pair)
            effect_d = last["coupling_effect_displacement"].sel(pair=pair)
            print(
                f"  {str(pair):12s} beta = {beta:+.4f}: k_t {float(effect_k.min()):+.2e} … {float(effect_k.max()):+.2e},"
                f" δ {float(effect_d.min()):+.2e} … {float(effect_d.max()):+.2e}"
            )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="data set of jobs/sphere_pairs.toml (hpcontact run)")
    parser.add_argument("outdir", type=Path, help="folder for the figures")
    add_format(parser)
    parser.add_argument(
        "--mu", type=float, help="friction coefficient of kt_vs_q.png and the maps (default: the first)"
    )
    parser.add_argument("--pair", default="Fe-Fe", help="pair of stick_zones.png (default Fe-Fe, else the first)")
    parser.add_argument("--load", type=float, default=100.0, help="load of stick_zones.png (nearest in the data set)")
    parser.add_argument(
        "--n-ellipse",
        type=int,
        default=128,
        help="cells across the ellipse of ellipse_kx_ky.png, 0: leave it out (k_b/k_a carries "
        "the stick area's staircase, ±0.3 %% at 64)",
    )
    args = parser.parse_args()
    ds = open_dataset(args.dataset)
    require(ds, args.dataset, "a slip sweep over q_ratio", axes=("q_ratio",), variables=RATIO_DRAWN)
    try:
        args.outdir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        refuse(f"{args.outdir}: cannot make the figure folder ({exc.strerror or type(exc).__name__})")
    use_format(args.format)
    missing = [a for a in SEED_AXES if a not in ds.dims] + [v for v in DRAWN if v not in ds.variables]
    if missing:  # another slip sweep than the seed's: the figure that needs only q_ratio
        figure_ratio(ds, args.outdir)
        print(
            f"drew kt_ratio.png alone: the other figures draw the data set of {SWEEP} (this one lacks: "
            f"{', '.join(missing)})"
        )
        return
    mu = float(ds["mu"].values[0]) if args.mu is None else float(ds["mu"].sel(mu=args.mu, method="nearest"))
    pair = args.pair if args.pair in ds["pair"].values else str(ds["pair"].values[0])
    load = float(ds["load"].sel(load=args.load, method="nearest"))
    summary(ds)
    figure_kt_vs_q(ds, mu, args.outdir)
    figure_ratio(ds, args.outdir)
    figure_stick_zones(ds, args.outdir, pair, load, mu)
    if args.n_ellipse:
        figure_ellipse(args.outdir, n=args.n_ellipse)
    print(f"figures in {args.outdir}")


if __name__ == "__main__":
    main()
