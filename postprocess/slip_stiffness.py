"""Tangential stiffness with partial slip: k_t against Q/(mu P) for the seed's sphere pairs.

    python postprocess/slip_stiffness.py results/sphere_pairs.nc figures/slip/ [--mu 0.2]
    python postprocess/slip_stiffness.py results/sphere_pairs_quick.nc figures/slip/ --compute

Reads the data set of ``jobs/sphere_pairs.toml`` (dimensions pair, load, mu, q_ratio; one
``hpcontact.slip.solve_slip`` record per point). With ``--compute`` (or when the file is
missing) it first computes a reduced version directly — every pair, loads 10 and 100 N,
mu = 0.3, one loading path per pair and load with the whole curve (``history``) — and writes it
to DATASET in the same layout, so the figures do not wait for the sweep.

Figures (PNG in OUTDIR):

* ``kt_vs_q.png`` — one panel per pair: the consistent k_t [N/µm] against Q/(mu P), one colour
  per load; open markers: Goodman's decoupled answer of a dissimilar pair; lines:
  Mindlin–Deresiewicz k_t = 8 a/[(2 − nu1)/G1 + (2 − nu2)/G2] (1 − Q/(mu P))^(1/3) (Johnson
  1985, §7.2, with the analytic Hertz radius a); band: the constant-ratio model
  k_t = c k_n, c = 0.25–0.35 (Sherif; Pan, cited by the seed paper), with the Hertz normal
  stiffness k_n = 3P/(2d).
* ``kt_ratio.png`` — k_t/k_t(0) for every pair, load and mu on one plot: they collapse on
  (1 − Q/(mu P))^(1/3); the constant-ratio model would be a horizontal line at c k_n/k_t(0).
* ``stick_zones.png`` — |t|/(mu p) on the contact of the Fe–Fe pair at 100 N for a few load
  levels, the stick zone outlined and Cattaneo's stick circle c = a(1 − Q/(mu P))^(1/3) dashed
  (solved here at n = 64).
* ``ellipse_kx_ky.png`` — an Fe ellipsoid (R_a = 8 mm, R_b = 24 mm) on an Fe flat: k along the
  major and the minor axis of the contact ellipse and their ratio against Q/(mu P), Mindlin's
  bonded ellipse at Q = 0 marked (solved here, n = 128 by default: the ratio carries the stick
  area's staircase, ±0.3 % at n = 64).

The coupled-minus-decoupled differences of the dissimilar pairs are printed as a table.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from hpcontact import analytic  # noqa: E402
from hpcontact.bodies import pair_from_params  # noqa: E402
from hpcontact.slip import PathSolver, SlipProblem, solve_slip, validate  # noqa: E402

# the seed's design (jobs/sphere_pairs.toml): label -> body fields
PAIRS = {
    "Cu-Cu": {"material": "Cu", "material2": "Cu"},
    "Cu-Fe": {"material": "Cu", "material2": "Fe"},
    "Cu-Al": {"material": "Cu", "material2": "Al"},
    "Fe-Fe": {"material": "Fe", "material2": "Fe"},
    "Fe-Al": {"material": "Fe", "material2": "Al"},
    "Al-Al": {"material": "Al", "material2": "Al"},
    "Cu-Fe R8-R8": {"material": "Cu", "material2": "Fe", "radius2": 8e-3},
    "Fe-Al R8-R8": {"material": "Fe", "material2": "Al", "radius2": 8e-3},
}
BASE = {"radius": 8e-3, "radius2": 9e-3}
RATIO_BAND = (0.25, 0.35)  # constant-ratio model k_t = c k_n (seed paper, refs. 5 and 6)
VARIABLES = (
    "tangential_force", "tangential_displacement", "tangential_stiffness", "stick_area_stiffness", "stick_area",
    "contact_area", "normal_stiffness", "hertz_a", "mindlin_stiffness", "mindlin_no_slip_stiffness",
    "decoupled_tangential_stiffness", "decoupled_tangential_displacement", "coupling_effect_stiffness",
    "coupling_effect_displacement", "dundurs_beta", "wall_time_s",
)
UM = 1e-6  # stiffness shown in N/µm


def pair_params(label: str) -> dict:
    return {**BASE, **PAIRS[label]}


def compute(path: Path, loads=(10.0, 100.0), mus=(0.3,), n: int = 64, steps: int = 9) -> xr.Dataset:
    """The reduced sweep: one loading path to 0.9 mu P per (pair, load, mu), every step kept."""
    q = np.linspace(0.0, 0.9, steps + 1)
    shape = (len(PAIRS), len(loads), len(mus), len(q))
    data = {name: np.full(shape, np.nan) for name in VARIABLES}
    for i, label in enumerate(PAIRS):
        for j, load in enumerate(loads):
            for k, mu in enumerate(mus):
                params = {**pair_params(label), "load": load, "mu": mu, "q_ratio": 0.9, "steps": steps, "n": n,
                          "history": True}
                record = solve_slip(params)
                print(f"{label:12s} P = {load:6.1f} N mu = {mu}: {record['wall_time_s']:.1f} s", flush=True)
                h = record["history"]
                pair = pair_from_params(params)
                eq, a = pair.equivalent, pair.hertz(load).a
                data["tangential_force"][i, j, k] = h["tangential_force"]
                data["tangential_displacement"][i, j, k] = h["tangential_displacement"]
                data["tangential_stiffness"][i, j, k] = h["tangential_stiffness"]
                data["stick_area_stiffness"][i, j, k] = h["stick_area_stiffness"]
                data["stick_area"][i, j, k] = h["stick_area"]
                data["contact_area"][i, j, k] = h["contact_area"]
                data["mindlin_stiffness"][i, j, k] = analytic.cattaneo_mindlin_stiffness(
                    np.clip(h["tangential_force"], 0.0, mu * load), load, mu, a, eq.G, eq.nu)
                for name in ("normal_stiffness", "hertz_a", "mindlin_no_slip_stiffness", "dundurs_beta"):
                    data[name][i, j, k] = record[name]
                data["wall_time_s"][i, j, k] = record["wall_time_s"]
                if "decoupled_history" in record:
                    d = record["decoupled_history"]
                    data["decoupled_tangential_stiffness"][i, j, k] = d["tangential_stiffness"]
                    data["decoupled_tangential_displacement"][i, j, k] = d["tangential_displacement"]
                    data["coupling_effect_stiffness"][i, j, k] = (
                        np.array(h["tangential_stiffness"]) / np.array(d["tangential_stiffness"]) - 1.0)
                    with np.errstate(invalid="ignore", divide="ignore"):
                        data["coupling_effect_displacement"][i, j, k] = (
                            np.array(h["tangential_displacement"]) / np.array(d["tangential_displacement"]) - 1.0)
    dims = ("pair", "load", "mu", "q_ratio")
    ds = xr.Dataset(
        {name: (dims, values) for name, values in data.items()},
        coords={"pair": list(PAIRS), "load": np.array(loads), "mu": np.array(mus), "q_ratio": q},
        attrs={"title": "Sphere pairs with partial slip (reduced, computed by postprocess/slip_stiffness.py)",
               "n": n, "steps": steps},
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(path)
    return ds


def _mindlin_line(ds: xr.Dataset, pair: str, load: float, mu: float, q: np.ndarray) -> np.ndarray:
    """Mindlin–Deresiewicz k_t(q) of the pair from its bonded value (analytic Hertz radius)."""
    k0 = float(ds["mindlin_no_slip_stiffness"].sel(pair=pair, load=load, mu=mu).isel(q_ratio=0))
    return k0 * np.cbrt(1.0 - q)


def figure_kt_vs_q(ds: xr.Dataset, mu: float, outdir: Path) -> None:
    pairs = [str(p) for p in ds["pair"].values]
    cols = 4
    rows = math.ceil(len(pairs) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.0 * cols, 3.3 * rows), sharex=True, squeeze=False)
    q_fine = np.linspace(0.0, 0.999, 200)
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, ds.sizes["load"]))
    for ax, pair in zip(axes.flat, pairs):
        for colour, load in zip(colours, ds["load"].values):
            sel = ds.sel(pair=pair, load=load, mu=mu)
            q = sel["q_ratio"].values
            ax.plot(q, sel["tangential_stiffness"] * UM, "o", color=colour, ms=4, label=f"P = {load:g} N")
            if "decoupled_tangential_stiffness" in sel and np.isfinite(sel["decoupled_tangential_stiffness"]).any():
                ax.plot(q, sel["decoupled_tangential_stiffness"] * UM, "o", mfc="none", color=colour, ms=7)
            ax.plot(q_fine, _mindlin_line(ds, pair, load, mu, q_fine) * UM, "-", color=colour, lw=1)
            kn = float(sel["normal_stiffness"].isel(q_ratio=0))
            ax.axhspan(RATIO_BAND[0] * kn * UM, RATIO_BAND[1] * kn * UM, color=colour, alpha=0.12, lw=0)
        ax.set_title(pair)
        ax.set_xlim(0, 1)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("Q/(μP)")
    for ax in axes[:, 0]:
        ax.set_ylabel("k_t [N/µm]")
    for ax in list(axes.flat)[len(pairs):]:
        ax.axis("off")
    axes[0, 0].legend(fontsize=7, loc="lower left")
    fig.suptitle(f"Tangential stiffness with partial slip, μ = {mu:g}: markers solver (open: decoupled), "
                 f"lines Mindlin–Deresiewicz, bands k_t = (0.25–0.35) k_n", fontsize=10)
    fig.tight_layout()
    fig.savefig(outdir / "kt_vs_q.png", dpi=150)
    plt.close(fig)


def figure_ratio(ds: xr.Dataset, outdir: Path) -> None:
    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    q_fine = np.linspace(0.0, 0.999, 200)
    ax.plot(q_fine, np.cbrt(1.0 - q_fine), "k-", lw=1.2, label="Mindlin–Deresiewicz (1 − Q/μP)^⅓")
    markers = "osD^v<>p"
    lo, hi = [], []
    for marker, pair in zip(markers, ds["pair"].values):
        sel = ds.sel(pair=pair)
        k = sel["tangential_stiffness"]
        ratio = k / k.isel(q_ratio=0)
        for load in ds["load"].values:
            for mu in ds["mu"].values:
                ax.plot(ds["q_ratio"], ratio.sel(load=load, mu=mu), marker, ms=3, alpha=0.7, mfc="none",
                        label=str(pair) if (load == ds["load"].values[0] and mu == ds["mu"].values[0]) else None)
        cn = sel["normal_stiffness"].isel(q_ratio=0) / k.isel(q_ratio=0)
        lo.append(float(RATIO_BAND[0] * cn.min()))
        hi.append(float(RATIO_BAND[1] * cn.max()))
    ax.axhspan(min(lo), max(hi), color="tab:red", alpha=0.12, lw=0, label="k_t = (0.25–0.35) k_n")
    ax.set_xlabel("Q/(μP)")
    ax.set_ylabel("k_t / k_t(Q = 0)")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.05)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(outdir / "kt_ratio.png", dpi=150)
    plt.close(fig)


def figure_stick_zones(outdir: Path, levels=(0.3, 0.6, 0.9), n: int = 64) -> None:
    params = {**pair_params("Fe-Fe"), "load": 100.0, "mu": 0.3, "q_ratio": max(levels), "n": n}
    problem = SlipProblem(validate(params))
    solver = PathSolver(problem, coupled=False)
    limit = problem.scene.mu * problem.P
    x, y = problem.x * problem.L * 1e6, problem.y * problem.L * 1e6  # µm
    a = problem.hertz.a * 1e6
    state = solver.initial
    fig, axes = plt.subplots(1, len(levels), figsize=(4.0 * len(levels), 3.8), squeeze=False)
    for ax, level in zip(axes[0], levels):
        steps = max(1, round(10 * level))
        state = solver.initial
        solver._last_increment = None
        for k in range(1, steps + 1):
            state = solver.to_force(state, np.array([level * limit * k / steps, 0.0]))
        bound = problem.scene.mu * state.p
        ratio = np.where(state.contact, np.hypot(state.t[0], state.t[1]) / np.where(bound > 0, bound, 1.0), np.nan)
        image = ax.pcolormesh(x, y, ratio, vmin=0.0, vmax=1.0, cmap="magma", shading="auto")
        ax.contour(x, y, state.stick.astype(float), levels=[0.5], colors="cyan", linewidths=1.2)
        c = analytic.stick_radius(level * limit, problem.P, problem.scene.mu, 1.0) * a
        phi = np.linspace(0.0, 2.0 * np.pi, 200)
        ax.plot(c * np.cos(phi), c * np.sin(phi), "w--", lw=1)
        ax.plot(a * np.cos(phi), a * np.sin(phi), "w:", lw=0.8)
        ax.set_aspect("equal")
        ax.set_title(f"Q/(μP) = {level:g}")
        ax.set_xlabel("x [µm]")
    axes[0, 0].set_ylabel("y [µm]")
    fig.colorbar(image, ax=axes[0].tolist(), label="|t| / (μ p)")
    fig.suptitle("Fe–Fe, 8/9 mm, P = 100 N, μ = 0.3: stick zone (cyan), Cattaneo's circle (dashed)", fontsize=10)
    fig.savefig(outdir / "stick_zones.png", dpi=150)
    plt.close(fig)


def figure_ellipse(outdir: Path, n: int = 64, steps: int = 9) -> None:
    base = {"radius": 8e-3, "radius_b": 24e-3, "material": "Fe", "material2": "Fe", "load": 100.0, "mu": 0.3,
            "q_ratio": 0.9, "steps": steps, "n": n, "history": True}
    pair = pair_from_params(base)
    h = pair.hertz(100.0)
    K_a, K_b = analytic.mindlin_ellipse_stiffness(h.a, h.b, pair.equivalent.G, pair.equivalent.nu)
    major = solve_slip({**base, "angle": h.angle_deg})["history"]
    minor = solve_slip({**base, "angle": h.angle_deg + 90.0})["history"]
    q_major = np.array(major["tangential_force"]) / (0.3 * 100.0)
    q_minor = np.array(minor["tangential_force"]) / (0.3 * 100.0)
    k_major, k_minor = np.array(major["tangential_stiffness"]), np.array(minor["tangential_stiffness"])
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9.5, 3.8))
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
    fig.suptitle(f"Fe ellipsoid 8 × 24 mm on Fe flat, P = 100 N: Hertz ellipse b/a = {h.aspect:.3f}", fontsize=10)
    fig.tight_layout()
    fig.savefig(outdir / "ellipse_kx_ky.png", dpi=150)
    plt.close(fig)


def coupling_table(ds: xr.Dataset) -> None:
    if "coupling_effect_stiffness" not in ds:
        return
    print("coupled / decoupled − 1 at the largest Q/(mu P) (k_t, δ), dissimilar pairs:")
    last = ds.isel(q_ratio=-1)
    for pair in ds["pair"].values:
        beta = float(last["dundurs_beta"].sel(pair=pair).max())
        if beta == 0.0:
            continue
        effect_k = last["coupling_effect_stiffness"].sel(pair=pair)
        effect_d = last["coupling_effect_displacement"].sel(pair=pair)
        print(f"  {str(pair):12s} beta = {beta:+.4f}: k_t {float(effect_k.min()):+.2e} … {float(effect_k.max()):+.2e},"
              f" δ {float(effect_d.min()):+.2e} … {float(effect_d.max()):+.2e}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="data set of jobs/sphere_pairs.toml (or where to compute one)")
    parser.add_argument("outdir", type=Path, help="folder for the PNG files")
    parser.add_argument("--mu", type=float, help="friction coefficient of kt_vs_q.png (default: the first)")
    parser.add_argument("--compute", action="store_true", help="compute the reduced data set first")
    parser.add_argument("--n", type=int, default=64, help="cells across the contact for what is solved here")
    parser.add_argument("--n-ellipse", type=int, default=128,
                        help="cells across the ellipse (k_b/k_a carries the stick area's staircase, ±0.3 %% at 64)")
    args = parser.parse_args()
    args.outdir.mkdir(parents=True, exist_ok=True)
    if args.compute or not args.dataset.exists():
        ds = compute(args.dataset, n=args.n)
    else:
        with xr.open_dataset(args.dataset) as opened:
            ds = opened.load()
    mu = float(ds["mu"].values[0]) if args.mu is None else float(ds["mu"].sel(mu=args.mu, method="nearest"))
    figure_kt_vs_q(ds, mu, args.outdir)
    figure_ratio(ds, args.outdir)
    coupling_table(ds)
    figure_stick_zones(args.outdir, n=args.n)
    figure_ellipse(args.outdir, n=args.n_ellipse)
    print(f"figures in {args.outdir}")


if __name__ == "__main__":
    main()
