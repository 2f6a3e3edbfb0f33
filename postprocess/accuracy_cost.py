"""What accuracy costs: error versus wall time, error versus n, error versus tol, and the table
of docs/howto/accuracy.md, from the data set of ``jobs/accuracy_cost.toml`` (issue 4, item 1).

    python postprocess/accuracy_cost.py results/accuracy_cost.nc figures/accuracy_cost/ \
        [--extrapolated results/boundary_treatment.json]

Cases are the shape labels up to the first comma ("ellipse b/a=1e-4, 32 across" is case
"ellipse b/a=1e-4" on a grid with 32 cells across). References:

* circle: K_xx = K_yy = 8Ga/(2 − nu), K_zz = 2aE* (Johnson 1985 §3.4, §7.2);
* ellipse b/a = γ: Mindlin 1949 (K_a, K_b) and the elliptical punch π a E*/K(m) (K_zz);
* square and rectangle b/a = 1e-8 (no closed form): extrapolation over the finest grids at the
  tightest tol — a least-squares fit Q = Q* + Σ c_i h^{p_i} with p = 1, 1.5, 2 in the cell
  size along each resolved direction (n only for the square; n and n_across for the thin
  rectangle, whose mesh is exact so the error is a smooth edge-layer expansion). The spread of
  Q* over fits with fewer terms is printed as the reference's own uncertainty.

Figures (PNG): ``error_vs_time.png`` (log–log, one panel per quantity, one curve per case: the
cheapest time that reaches each error, over all grids and tolerances; every task as a faint
point), ``error_vs_n.png`` (at the tightest tol; thin cases one curve per n_across) and
``error_vs_tol.png`` (at n = 256). ``accuracy_cost_table.md``: the time that 1 %, 0.1 %,
0.01 % cost for each case (largest relative error of K_xx, K_yy, K_a/K_b and K_zz), the grid
and tol that achieve it, as measured (one thread per task; the machine is named). With
``--extrapolated`` (written by ``benchmarks/boundary_treatment.py``) the error and time of
``solve --accuracy`` runs are overlaid and tabulated too.
"""

from __future__ import annotations

import json
import math
import platform
import re
from pathlib import Path

import freshness

if __name__ == "__main__":
    freshness.exit_if_fresh(__file__)  # before the imports that take seconds: an up-to-date run ends here

import numpy as np
import xarray as xr
from common import arguments, colours, open_dataset, panels, save

from hpcontact import analytic

QUANTITIES = ("K_xx", "K_yy", "K_a_over_K_b", "K_zz")
TITLES = {
    "K_xx": "K_xx (along the long axis)",
    "K_yy": "K_yy (across)",
    "K_a_over_K_b": "K_a/K_b",
    "K_zz": "K_zz (normal)",
}
TARGETS = (1e-2, 1e-3, 1e-4)
EXACT = 1e-12  # errors below this are symmetry (K_a/K_b = 1 of circle and square), not shown on log axes
LABEL = re.compile(r"^(?P<shape>[a-z]+)(?: b/a=(?P<aspect>[0-9.eE+-]+))?")


def case_of(label: str) -> str:
    """'ellipse b/a=1e-4, 32 across' → 'ellipse b/a=1e-4'."""
    return label.split(",")[0].strip()


def shape_of(case: str) -> tuple[str, float]:
    """'ellipse b/a=1e-4' → ('ellipse', 1e-4); 'square' → ('rectangle', 1.0)."""
    m = LABEL.match(case)
    if m is None:
        raise SystemExit(f"cannot read the shape of case {case!r}")
    shape = m["shape"]
    if shape == "square":
        return "rectangle", 1.0
    return shape, float(m["aspect"]) if m["aspect"] else 1.0


def closed_form(shape: str, aspect: float, nu: float) -> dict[str, float] | None:
    """Closed-form K_xx, K_yy, K_a/K_b, K_zz (G = 1, semi-major axis 1), or None."""
    if shape == "circle":
        k = analytic.circle_tangential_stiffness(1.0, 1.0, nu)
        return {"K_xx": k, "K_yy": k, "K_a_over_K_b": 1.0, "K_zz": analytic.circle_normal_stiffness(1.0, 1.0, nu)}
    if shape == "ellipse":
        K_a, K_b = analytic.mindlin_ellipse_stiffness(1.0, aspect, 1.0, nu)
        return {
            "K_xx": K_a,
            "K_yy": K_b,
            "K_a_over_K_b": analytic.mindlin_ellipse_stiffness_ratio(aspect, nu),
            "K_zz": analytic.elliptical_punch_normal_stiffness(1.0, aspect, 1.0, nu),
        }
    return None


def _fit(h_columns: list[np.ndarray], values: np.ndarray, powers: tuple[float, ...]) -> float:
    """Q* of the least-squares fit Q = Q* + Σ_dir Σ_p c h_dir^p."""
    columns = [np.ones_like(values)] + [h**p for h in h_columns for p in powers]
    A = np.column_stack(columns)
    coef, *_ = np.linalg.lstsq(A, values, rcond=None)
    return float(coef[0])


def extrapolated_reference(points: list[dict], quantity: str, thin: bool) -> tuple[float, float]:
    """Q* and its spread over fits (p = 1, 1.5, 2 / 1, 1.5 / 1, 2), finest grids only.

    ``points``: dicts with n, na, value at the tightest tol. Square: n ≥ 128. Thin rectangle:
    n ≥ 128 and n_across ≥ 16 (both directions resolved).
    """
    chosen = [p for p in points if p["n"] >= 128 and (not thin or p["na"] >= 16) and math.isfinite(p[quantity])]
    values = np.array([p[quantity] for p in chosen])
    hs = [np.array([1.0 / p["n"] for p in chosen])]
    if thin:
        hs.append(np.array([1.0 / p["na"] for p in chosen]))
    fits = []
    for powers in ((1.0, 1.5, 2.0), (1.0, 1.5), (1.0, 2.0)):
        if len(values) > 1 + len(hs) * len(powers):
            fits.append(_fit(hs, values, powers))
    if not fits:
        raise SystemExit(f"too few fine grids to extrapolate {quantity}")
    return fits[0], max(abs(f - fits[0]) for f in fits)


def gather(ds: xr.Dataset) -> dict[str, list[dict]]:
    """Per case, one dict per finished task: n, na (cells across), tol, time, iterations, values."""
    nu = float(ds["nu"].values) if "nu" in ds.coords else 0.3
    cases: dict[str, list[dict]] = {}
    for label in ds["shape"].values:
        for n in ds["n"].values:
            for tol in ds["tol"].values:
                point = ds.sel(shape=label, n=n, tol=tol)
                if int(point["status"]) != 0:
                    continue
                record = {
                    "n": int(n),
                    "na": int(point["ny"]),
                    "tol": float(tol),
                    "nu": nu,
                    "time": float(point["wall_time_s"]),
                    "iterations": int(point["iterations"]),
                }
                record.update({q: float(point[q]) for q in QUANTITIES})
                cases.setdefault(case_of(str(label)), []).append(record)
    return cases


def add_errors(cases: dict[str, list[dict]]) -> dict[str, str]:
    """Relative errors per point (``err_<q>`` and ``err``: the largest of the four); returns a
    note per case on where its reference comes from."""
    notes = {}
    for case, points in cases.items():
        shape, aspect = shape_of(case)
        reference = closed_form(shape, aspect, points[0]["nu"])
        if reference is not None:
            notes[case] = "closed form"
        else:
            tightest = min(p["tol"] for p in points)
            finest = [p for p in points if p["tol"] == tightest]
            thin = aspect < 1.0
            reference, spreads = {}, {}
            for q in QUANTITIES:
                reference[q], spreads[q] = extrapolated_reference(finest, q, thin)
            notes[case] = (
                "extrapolated (reference uncertainty "
                + ", ".join(f"{q} {spreads[q] / abs(reference[q]):.1e}" for q in QUANTITIES)
                + ")"
            )
        for p in points:
            for q in QUANTITIES:
                p[f"err_{q}"] = abs(p[q] / reference[q] - 1.0)
            p["err"] = max(p[f"err_{q}"] for q in QUANTITIES)
    return notes


def pareto(points: list[dict], key: str) -> tuple[np.ndarray, np.ndarray]:
    """(time, error) of the points no other point beats in both (cheapest time per error)."""
    ordered = sorted(points, key=lambda p: (p["time"], p[key]))
    t, e, best = [], [], math.inf
    for p in ordered:
        if p[key] < best:
            best = p[key]
            t.append(p["time"])
            e.append(max(p[key], 1e-16))
    return np.array(t), np.array(e)


def load_extrapolated(path: Path | None) -> list[dict]:
    if path is None:
        return []
    with open(path) as fh:
        return json.load(fh).get("accuracy_runs", [])


def figure_error_vs_time(cases: dict[str, list[dict]], extrapolated: list[dict], outdir: Path) -> None:
    fig, axes = panels(len(QUANTITIES), columns=2, size=4.4)
    names = list(cases)
    for ax, q in zip(axes, QUANTITIES):
        key = f"err_{q}"
        for colour, case in zip(colours(len(names)), names):
            pts = [p for p in cases[case] if p[key] > EXACT]  # K_a/K_b of circle and square: 1 by symmetry
            if not pts:
                continue
            ax.loglog([p["time"] for p in pts], [p[key] for p in pts], ".", color=colour, alpha=0.15, ms=3)
            t, e = pareto(pts, key)
            ax.loglog(t, e, "-", color=colour, lw=1.5, label=case)
            runs = [r for r in extrapolated if r["case"] == case and r.get(key, 0.0) > EXACT]
            if runs:
                ax.loglog(
                    [r["wall_time_s"] for r in runs],
                    [max(r[key], 1e-16) for r in runs],
                    "*",
                    color=colour,
                    ms=9,
                    mec="k",
                    mew=0.5,
                )
        ax.set_xlabel("wall time per scene [s] (one thread)")
        ax.set_ylabel("relative error")
        ax.set_title(TITLES[q], fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8)
    note = "lines: cheapest grid and tol reaching each error; dots: every task"
    if extrapolated:
        note += "\nstars: solve --accuracy (coverage-weighted cells + Richardson), whole grid sequence"
    fig.suptitle(f"Error versus wall time per scene\n{note}", fontsize=9)
    save(fig, outdir, "error_vs_time.png")


def _tightest(points: list[dict]) -> list[dict]:
    tightest = min(p["tol"] for p in points)
    return [p for p in points if p["tol"] == tightest]


def _is_thin(points: list[dict]) -> bool:
    """A case studied on several n_across for the same n (thin shapes)."""
    across: dict[tuple, set] = {}
    for p in points:
        across.setdefault((p["n"], p["tol"]), set()).add(p["na"])
    return any(len(v) > 1 for v in across.values())


def figure_error_vs_n(cases: dict[str, list[dict]], outdir: Path) -> None:
    """Every case at the tightest tol; thin cases on their finest n_across."""
    fig, axes = panels(len(QUANTITIES), columns=2, size=4.4)
    names = list(cases)
    for ax, q in zip(axes, QUANTITIES):
        key = f"err_{q}"
        for colour, case in zip(colours(len(names)), names):
            pts = _tightest(cases[case])
            label = case
            if _is_thin(cases[case]):
                most = max(p["na"] for p in pts)
                pts = [p for p in pts if p["na"] == most]
                label = f"{case} ({most} across)"
            pts = sorted((p for p in pts if p[key] > EXACT), key=lambda p: p["n"])
            if pts:
                ax.loglog([p["n"] for p in pts], [p[key] for p in pts], "o-", color=colour, ms=3, label=label)
        ax.set_xlabel("n (cells along the long side)")
        ax.set_ylabel("relative error")
        ax.set_title(TITLES[q], fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8)
    fig.suptitle(
        "Error versus grid at the tightest CG tolerance (the staircase error of curved shapes is not monotone in n)",
        fontsize=9,
    )
    save(fig, outdir, "error_vs_n.png")


def figure_thin_grids(cases: dict[str, list[dict]], outdir: Path) -> None:
    """Thin cases: error versus n, one line per n_across (the (n, n_across) study)."""
    thin = [c for c in cases if _is_thin(cases[c])]
    if not thin:
        return
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        len(thin),
        len(QUANTITIES),
        figsize=(3.6 * len(QUANTITIES), 3.3 * len(thin)),
        squeeze=False,
        layout="constrained",
    )
    for row, case in zip(axes, thin):
        pts = _tightest(cases[case])
        across = sorted({p["na"] for p in pts})
        shades = plt.cm.plasma(np.linspace(0.0, 0.85, len(across)))
        for ax, q in zip(row, QUANTITIES):
            key = f"err_{q}"
            for shade, na in zip(shades, across):
                line = sorted((p for p in pts if p["na"] == na and p[key] > EXACT), key=lambda p: p["n"])
                ax.loglog(
                    [p["n"] for p in line],
                    [p[key] for p in line],
                    "o-",
                    color=shade,
                    ms=2.5,
                    lw=1,
                    label=f"{na} across",
                )
            ax.set_title(f"{case}: {TITLES[q]}", fontsize=8)
            ax.set_xlabel("n (cells along)", fontsize=8)
            ax.grid(True, which="major", alpha=0.3)
        row[0].set_ylabel("relative error")
        row[0].legend(fontsize=6)
    fig.suptitle("Thin contacts: error versus cells along (n) and across (n_across), tightest tol", fontsize=9)
    save(fig, outdir, "error_vs_grid_thin.png")


def figure_error_vs_tol(cases: dict[str, list[dict]], outdir: Path, n: int = 256) -> None:
    """Total error (solid) and the CG part alone (dashed: change from the tightest tol) at n."""
    fig, axes = panels(2, columns=2, size=4.4)
    names = list(cases)
    for colour, case in zip(colours(len(names)), names):
        pts = [p for p in cases[case] if p["n"] == n]
        if not pts:
            continue
        na = max(p["na"] for p in pts)
        pts = sorted((p for p in pts if p["na"] == na), key=lambda p: p["tol"])
        tight = pts[0]
        solver = [max(abs(p[q] / tight[q] - 1.0) for q in QUANTITIES) for p in pts]
        tols = [p["tol"] for p in pts]
        axes[0].loglog(tols, [max(p["err"], EXACT) for p in pts], "o-", color=colour, label=case, ms=3)
        axes[0].loglog(tols[1:], [max(e, EXACT) for e in solver[1:]], "s--", color=colour, ms=3, lw=0.8)
        axes[1].semilogx(tols, [p["time"] for p in pts], "o-", color=colour, ms=3)
    axes[0].set_ylabel("relative error (worst of the four)")
    axes[0].set_title("solid: total error; dashed: CG part (change from tightest tol)", fontsize=8)
    axes[1].set_ylabel("wall time per scene [s]")
    for ax in axes:
        ax.set_xlabel("CG tolerance (relative residual)")
        ax.invert_xaxis()
        ax.grid(True, which="major", alpha=0.3)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=3, fontsize=8)
    fig.suptitle(
        f"Error and cost versus CG tolerance at n = {n} (thin cases: most cells across)\nK is the energy of "
        "the solve: its CG error falls about like the residual squared",
        fontsize=9,
    )
    save(fig, outdir, "error_vs_tol.png")


def machine() -> str:
    try:
        with open("/proc/cpuinfo") as fh:
            model = next((line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")), "")
    except OSError:
        model = ""
    return f"{model or platform.processor() or platform.machine()}, {platform.system()}"


def table(cases: dict[str, list[dict]], notes: dict[str, str], extrapolated: list[dict], ds: xr.Dataset) -> str:
    """Markdown: per case and target, the cheapest measured (time, grid, tol, iterations)."""
    lines = ["| case | reference | 1 % | 0.1 % | 0.01 % |", "|---|---|---|---|---|"]
    for case, pts in cases.items():
        cells = []
        for target in TARGETS:
            good = [p for p in pts if p["err"] <= target]
            if not good:
                best_err = min(p["err"] for p in pts)
                cells.append(f"not reached (best {best_err:.1e})")
                continue
            p = min(good, key=lambda p: p["time"])
            cells.append(f"{p['time']:.2g} s ({p['n']}×{p['na']}, tol {p['tol']:.0e}, {p['iterations']} it.)")
        ref = "closed form" if notes[case] == "closed form" else "extrapolated"
        lines.append(f"| {case} | {ref} | " + " | ".join(cells) + " |")
    if extrapolated:
        lines.append("")
        lines.append(
            "`hpcontact solve --accuracy REL` (coverage-weighted cells, Richardson; time of the whole grid sequence):"
        )
        lines.append("")
        lines.append("| case | requested | estimated | true | grids (n × n_across) | time |")
        lines.append("|---|---|---|---|---|---|")
        for r in extrapolated:
            grids = ", ".join(f"{a}×{b}" for a, b in zip(r["grids"], r["grids_across"]))
            true = r.get("err")
            lines.append(
                f"| {r['case']} | {r['accuracy']:.0e} | {r['estimated_error']:.1e} | "
                f"{'—' if true is None else f'{true:.1e}'} | {grids} | {r['wall_time_s']:.2g} s |"
            )
    nu = float(ds["nu"].values) if "nu" in ds.coords else float("nan")
    lines.append("")
    lines.append(
        f"Error: largest relative error of K_xx, K_yy, K_a/K_b and K_zz (nu = {nu:g}); time: wall time of one "
        f"scene (tangential + normal solves, kernels and FFT plans included, one thread), the cheapest grid and CG "
        f"tolerance of the sweep that reaches the error. Measured on {machine()}, {ds.attrs.get('mpi_size', '?')} "
        f"MPI rank(s), hpcontact {ds.attrs.get('hpcontact_version', ds.attrs.get('version', '?'))}. "
        "References: " + "; ".join(f"{c}: {n}" for c, n in notes.items()) + "."
    )
    return "\n".join(lines) + "\n"


def main() -> None:
    args = arguments(
        __doc__.splitlines()[0],
        [
            (
                "--extrapolated",
                {
                    "type": Path,
                    "default": None,
                    "help": "JSON of solve --accuracy runs (benchmarks/boundary_treatment.py)",
                },
            )
        ],
    )
    with freshness.stamp(__file__, args.outdir, [args.dataset, args.extrapolated]):
        ds = open_dataset(args.dataset)
        cases = gather(ds)
        notes = add_errors(cases)
        extrapolated = load_extrapolated(args.extrapolated)
        figure_error_vs_time(cases, extrapolated, args.outdir)
        figure_error_vs_n(cases, args.outdir)
        figure_thin_grids(cases, args.outdir)
        figure_error_vs_tol(cases, args.outdir)
        text = table(cases, notes, extrapolated, ds)
        path = args.outdir / "accuracy_cost_table.md"
        path.write_text(text, encoding="utf-8")
        freshness.wrote(path)
        print(f"wrote {path}\n")
        print(text)


if __name__ == "__main__":
    main()
