"""Cubic crystals versus surface orientation: sphere contact ellipse and load, tangential anisotropy.

    python postprocess/orientation_map.py results/tembleque2011_sphere.nc figures/ [--fine 61]
    python postprocess/orientation_map.py results/crystal_tangential.nc figures/ [--nu 0.3]
    python postprocess/orientation_map.py results/demo.nc figures/ [--nu 0.25] [--shape ellipse] [--format pdf]

What is drawn depends on the data set (both need ``anisotropy`` and ``orientation`` axes; ψ runs
along [110] (0°) -> [111] (35.26°) -> [001] (90°), docs/design.md §2.5):

* an indentation sweep (``load`` and ``ellipse_b_over_a``; jobs/tembleque2011_sphere.toml) gives
  ``orientation_sphere.png``: Rodríguez-Tembleque et al. 2011, Figs. 9 and 10 — the contact
  ellipse's b/a and the load normalized by the [001] load at the same depth, P(ψ)/P([001]),
  versus ψ, one colour per A, one column per nu. Points: the BEM sweep; lines: Willis' (1966)
  elliptical Hertz solution (``hpcontact.analytic.willis_sphere_contact``, the semi-analytical
  reference of Swadener & Pharr 2001) at the same (A, nu) on a fine ψ grid. The largest
  BEM-Willis differences are printed. The normalized load is computed here, not stored.
* a tangential sweep (``K_min``, ``K_max``; jobs/crystal_tangential.toml) gives
  ``orientation_tangential_map.png``: filled map of K_min/K_max (principal values of the 2 x 2
  tangential stiffness, docs/reference/quantities.md convention table: Re H for a crystal) over
  ψ × A, one panel per contact b/a (the swept points marked on a coarse grid, a tick at A = 1), and
  ``orientation_tangential_curves.png``: the same ratio versus ψ, one colour per A. With a nu axis
  the map is drawn at ``--nu`` (default: the value nearest 0.3, crystal_tangential's); with a
  shape axis (jobs/demo.toml) for ``--shape`` (default: the first).

The map is filled only where the data back the values between its grid points (an adaptive
map, or a dense grid; ``common.draw_map``: the caption states the worst map error of what is
drawn, interpolation and drawing included); otherwise it shows the swept points alone.

Error estimates (``V_error`` in the data set): a filled map is hatched where its error is more
than one contour interval, a map of points where a point's estimated error of K_min/K_max is
more than 10 % of the panel's range (``common.ERROR_FRACTION``; points without an estimate
hatched the other way), the curves carry bars ± the estimated error; the ratio's error
is the stored ``K_min_over_K_max_error`` when there is one, else the sum of the relative errors
of K_min and K_max (a first-order bound). The sphere's points carry bars where the data set
estimates ``ellipse_b_over_a`` and ``load`` (P/P([001]): the sum of the two loads' relative
errors). Each figure's title states the worst estimated relative error, or that the data set
has no estimates.
"""

from __future__ import annotations

import functools
import math

import freshness

if __name__ == "__main__":
    freshness.exit_if_fresh(__file__)  # before the imports that take seconds: an up-to-date run ends here

import numpy as np
from common import (
    anisotropy_ticks,
    arguments,
    colours,
    draw_map,
    error_bars,
    error_caption,
    error_marks,
    fixed_shape,
    label,
    open_dataset,
    panels,
    refuse,
    relative_error,
    require,
    save,
    scalar_notes,
    select_rest,
)
from matplotlib.ticker import MaxNLocator  # noqa: E402

from hpcontact.analytic import willis_sphere_contact
from hpcontact.kernels.anisotropic import surface_green_fourier
from hpcontact.materials.crystal import cubic_from_nu_A

PSI_111 = math.degrees(math.atan(1.0 / math.sqrt(2.0)))  # 35.26°: n(ψ) ∥ [111]
POLES = ((0.0, "[110]"), (PSI_111, "[111]"), (90.0, "[001]"))
PSI_LABEL = "surface normal ψ from [110] towards [001] [degree]"


def scalar(ds, name: str, default: float) -> float:
    """A fixed field of the sweep (scalar coordinate), else ``default``."""
    return float(ds[name].values) if name in ds.coords and ds[name].ndim == 0 else default


@functools.cache
def willis(nu: float, A: float, psi: float, R: float, d: float, G: float = 1.0, n_phi: int = 256) -> dict:
    """Willis' elliptical contact of a rigid sphere on the cubic crystal (nu, A) cut at ψ.

    H_zz(φ) by the Barnett–Lothe integrals directly (not the BEM's cell coefficients). The
    contact axes are along x and y: x = [1̄10] is normal to a mirror plane of the crystal for
    every ψ of the path, so H_zz(φ) = H_zz(−φ) as the solution assumes. b/a is reported ≤ 1.
    256 directions give the load and b/a to ~1e-15 (checked against 4096 at A = 5).
    """
    material = cubic_from_nu_A(nu, A, scale=G).oriented(psi_deg=psi)
    out = willis_sphere_contact(lambda phi: surface_green_fourier(material, phi)[..., 2, 2].real, R, d, n_phi=n_phi)
    out["b_over_a"] = min(out["b_over_a"], 1.0 / out["b_over_a"])
    return out  # cached: callers must not modify it


def pole_ticks(ax) -> None:
    """[110], [111], [001] marked on a top axis, [111] also as a dotted line."""
    top = ax.secondary_xaxis("top")
    top.set_xticks([p for p, _ in POLES], [name for _, name in POLES], fontsize=8)
    for psi, _ in POLES[1:2]:
        ax.axvline(psi, color="0.6", lw=0.6, ls=":")
    ax.set_xlim(0.0, 90.0)
    ax.set_xticks(np.arange(0, 91, 15))


def sphere_curves(ds, outdir, fine: int) -> None:
    """Figs. 9 and 10 of Rodríguez-Tembleque et al. 2011: b/a and P/P[001] versus ψ."""
    if not np.any(np.isclose(ds["orientation"].values, 90.0)):
        refuse("the normalized load needs ψ = 90° ([001]) on the orientation axis")
    R, d, G = scalar(ds, "radius", 1.0), scalar(ds, "depth", 1e-4), scalar(ds, "G", 1.0)
    ratio, note = select_rest(ds["ellipse_b_over_a"], ["anisotropy", "nu", "orientation"])
    load, _ = select_rest(ds["load"], ["anisotropy", "nu", "orientation"])
    psi_001 = float(load["orientation"].sel(orientation=90.0, method="nearest"))
    load_001 = load.sel(orientation=psi_001)
    normalized = load / load_001
    load_error = relative_error(ds, load)  # P/P([001]): the sum of the two loads' relative errors
    normalized_error = None if load_error is None else load_error + relative_error(ds, load_001)
    errors = []
    nus = ratio["nu"].values if "nu" in ratio.dims else np.atleast_1d(scalar(ds, "nu", 0.3))
    anis = ratio["anisotropy"].values
    psi_fine = np.union1d(np.linspace(0.0, 90.0, fine), [PSI_111, psi_001])
    fig, axes = panels(2 * len(nus), columns=len(nus), size=4.0)
    rows = [axes[: len(nus)], axes[len(nus) :]]
    worst = {"b/a": (0.0, None), "P/P[001]": (0.0, None)}
    for col, nu in enumerate(nus):
        at = {"nu": nu} if "nu" in ratio.dims else {}
        for colour, A in zip(colours(len(anis)), anis):
            r = ratio.sel(anisotropy=A, **at)
            p = normalized.sel(anisotropy=A, **at)
            errors.append(error_marks(ds, r))
            error_bars(rows[0][col], r["orientation"], r, errors[-1].absolute, colour)
            if normalized_error is None:
                errors.append(error_marks(ds, p, names=["load"]))  # no estimate: says so
            else:
                errors.append(error_marks(ds, p, relative=normalized_error.sel(anisotropy=A, **at)))
                error_bars(rows[1][col], p["orientation"], p, errors[-1].absolute, colour)
            refs = [willis(float(nu), float(A), float(psi), R, d, G) for psi in psi_fine]
            ref_001 = willis(float(nu), float(A), psi_001, R, d, G)["load"]
            rows[0][col].plot(psi_fine, [w["b_over_a"] for w in refs], "-", lw=1.0, color=colour)
            rows[1][col].plot(psi_fine, [w["load"] / ref_001 for w in refs], "-", lw=1.0, color=colour)
            rows[0][col].plot(r["orientation"], r, "o", ms=3.5, color=colour, label=f"A = {A:g}")
            rows[1][col].plot(p["orientation"], p, "o", ms=3.5, color=colour, label=f"A = {A:g}")
            at_points = {
                float(psi): willis(float(nu), float(A), float(psi), R, d, G) for psi in r["orientation"].values
            }
            for name, bem, key in (("b/a", r, "b_over_a"), ("P/P[001]", p, "load")):
                for psi, value in zip(bem["orientation"].values, bem.values):
                    w = at_points[float(psi)][key] / (ref_001 if key == "load" else 1.0)
                    if abs(value - w) > worst[name][0]:
                        worst[name] = (abs(value - w), (float(A), float(nu), float(psi), float(value), w))
        rows[0][col].set_ylabel("contact ellipse b/a")
        rows[1][col].set_ylabel("load P(ψ) / P([001]) at the same depth")
        rows[0][col].set_title(f"ν = {nu:g}", fontsize=10)
        for ax in (rows[0][col], rows[1][col]):
            pole_ticks(ax)
            ax.set_xlabel(PSI_LABEL, fontsize=8)
            ax.grid(True, alpha=0.3)
    handles, labels = rows[0][0].get_legend_handles_labels()
    fig.legend(
        handles,
        labels,
        loc="outside right center",
        fontsize=8,
        title="points: BEM\n(Polonsky-Keer)\nlines: Willis\nelliptical Hertz",
        title_fontsize=8,
    )
    notes = ", ".join(filter(None, [note, f"d/R = {d / R:.3g}", scalar_notes(ds, ())]))
    fig.suptitle(
        f"Rigid sphere on a cubic crystal (Rodríguez-Tembleque et al. 2011, Figs. 9-10)\n{notes}\n"
        + error_caption(errors, "bars"),
        fontsize=10,
    )
    save(fig, outdir, "orientation_sphere.png")
    for name, (diff, where) in worst.items():
        if where is not None:
            A, nu, psi, value, w = where
            print(
                f"largest |BEM - Willis| in {name}: {diff:.2e} at A = {A:g}, nu = {nu:g}, psi = {psi:.2f} "
                f"(BEM {value:.6f}, Willis {w:.6f})"
            )
    hertz_ratio = (load / willis_loads(load, R, d, G)).values
    print(f"BEM load / Willis load over all points: {np.nanmin(hertz_ratio):.6f} ... {np.nanmax(hertz_ratio):.6f}")


def willis_loads(load, R: float, d: float, G: float):
    """Willis' load at every (A, nu, ψ) point of ``load`` (same shape)."""
    out = load.copy()
    for index in np.ndindex(load.shape):
        point = load[index]
        nu = float(point["nu"]) if "nu" in point.coords else scalar(load, "nu", 0.3)
        out[index] = willis(float(nu), float(point["anisotropy"]), float(point["orientation"]), R, d, G)["load"]
    return out


DEFAULT_NU = 0.3  # the tangential map's Poisson ratio when the data set has a nu axis


def ratio_parts(ds) -> list[str]:
    """The stored variables whose relative errors bound K_min/K_max's: the stored ratio's own
    estimate when the data set has one, else K_min's and K_max's (their sum, a first-order bound)."""
    return ["K_min_over_K_max"] if "K_min_over_K_max_error" in ds else ["K_min", "K_max"]


def tangential_ratio(ds, nu: float | None, shape: str | None):
    """K_min/K_max over (aspect?, anisotropy, orientation), nu at ``nu`` (default: nearest 0.3),
    shape at ``shape`` (default: the first), other axes at their first value."""
    ratio = ds["K_min"] / ds["K_max"]
    keep = ["anisotropy", "orientation"] + (["aspect"] if "aspect" in ratio.dims else [])
    choose = {"nu": DEFAULT_NU if nu is None else nu}
    if shape is not None:
        choose["shape"] = shape
    return select_rest(ratio, keep, choose)


def aspect_title(da, aspect) -> str:
    """Panel title: the shape (a scalar coordinate of ``da``: fixed or selected) and b/a."""
    shape = fixed_shape(da)
    if aspect is None or aspect == 1.0:
        return "circle" if shape in ("ellipse", "circle") else shape
    return f"{shape}, b/a = {aspect:g} (major axis along x = [1̄10])"


def tangential_map(ds, outdir, nu: float | None, shape: str | None) -> None:
    """Filled map of K_min/K_max over ψ × A, one panel per b/a; and curves versus ψ."""
    ratio, note = tangential_ratio(ds, nu, shape)
    aspects = list(ratio["aspect"].values) if "aspect" in ratio.dims else [None]
    notes = ", ".join(filter(None, [note, scalar_notes(ds, ("nu",))]))
    lowest = float(ratio.min())
    levels = MaxNLocator(24).tick_values(lowest, 1.0)
    fig, axes = panels(len(aspects), size=4.2)
    errors = []
    for ax, aspect in zip(axes, aspects):
        da = (ratio.sel(aspect=aspect) if aspect is not None else ratio).transpose("anisotropy", "orientation")
        drawn, marks = draw_map(ax, ds, da, da["orientation"], da["anisotropy"], levels, ratio_parts(ds), lines=3)
        errors.append(marks)
        ax.set_yscale("log")
        anisotropy_ticks(ax, da["anisotropy"].values)
        ax.axhline(1.0, color="w", lw=0.6, ls="--")
        pole_ticks(ax)
        ax.set_xlabel(PSI_LABEL, fontsize=8)
        ax.set_ylabel(label(ds["anisotropy"], "cubic anisotropy A = 2 C44/(C11 - C12)"), fontsize=8)
        ax.set_title(aspect_title(ratio, aspect), fontsize=9)
    fig.colorbar(drawn, ax=axes, label="K_min / K_max (principal tangential stiffnesses)")
    fig.suptitle(
        f"Tangential stiffness anisotropy of a bonded punch on a cubic crystal\n{notes}\n{error_caption(errors)}",
        fontsize=10,
    )
    save(fig, outdir, "orientation_tangential_map.png")

    fig, axes = panels(len(aspects), size=4.0)
    anis = ratio["anisotropy"].values
    errors = []
    for ax, aspect in zip(axes, aspects):
        da = ratio.sel(aspect=aspect) if aspect is not None else ratio
        errors.append(error_marks(ds, da, names=ratio_parts(ds)))
        for colour, A in zip(colours(len(anis)), anis):
            error_bars(ax, da["orientation"], da.sel(anisotropy=A), errors[-1].absolute.sel(anisotropy=A), colour)
            (line,) = ax.plot(
                da["orientation"], da.sel(anisotropy=A), "o-", ms=3, lw=0.8, color=colour, label=f"A = {A:.3g}"
            )
            # what is drawn, for checks against the data set: psi then K_min/K_max per point
            print(
                f"plotted {'' if aspect is None else f'b/a = {aspect:.12g}, '}A = {A:.12g}: "
                + " ".join(f"{x:.12g}:{y:.12g}" for x, y in zip(line.get_xdata(), line.get_ydata()))
            )
        pole_ticks(ax)
        ax.set_xlabel(PSI_LABEL, fontsize=8)
        ax.set_ylabel("K_min / K_max")
        ax.set_title(aspect_title(ratio, aspect), fontsize=9)
        ax.grid(True, alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right center", fontsize=8)
    fig.suptitle(
        f"K_min/K_max of the bonded punch versus orientation\n{notes}\n{error_caption(errors, 'bars')}", fontsize=10
    )
    save(fig, outdir, "orientation_tangential_curves.png")


def main() -> None:
    args = arguments(
        __doc__.splitlines()[0],
        [
            ("--fine", {"type": int, "default": 61, "help": "ψ points of the Willis lines (default 61)"}),
            ("--nu", {"type": float, "help": f"Poisson ratio of the tangential map (default: nearest {DEFAULT_NU})"}),
            ("--shape", {"help": "shape label of the tangential map (default: the first)"}),
        ],
    )
    with freshness.stamp(__file__, args.outdir, [args.dataset]):
        ds = open_dataset(args.dataset)
        require(ds, args.dataset, "a crystal sweep over anisotropy and orientation", axes=("anisotropy", "orientation"))
        done = False
        if {"load", "ellipse_b_over_a"} <= set(ds.data_vars):
            sphere_curves(ds, args.outdir, args.fine)
            done = True
        if {"K_min", "K_max"} <= set(ds.data_vars):
            tangential_map(ds, args.outdir, args.nu, args.shape)
            done = True
        if not done:
            refuse(
                f"{args.dataset}: neither an indentation sweep (load, ellipse_b_over_a) nor a tangential one (K_min, K_max)"
            )


if __name__ == "__main__":
    main()
