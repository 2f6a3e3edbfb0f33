"""What accuracy costs: error versus wall time, error versus n, error versus tol, and the table
of docs/howto/accuracy.md, from the data set of ``jobs/accuracy_cost.toml`` (issue 4, item 1).

    python postprocess/accuracy_cost.py results/accuracy_cost.nc figures/accuracy_cost/ \
        [--extrapolated results/boundary_treatment.json]

Cases are the shape labels up to the first comma ("ellipse b/a=1e-4, 32 across" is case
"ellipse b/a=1e-4" on a grid with 32 cells across); each row's scene parameters are read from
the spec stored in the data set (``spec`` attribute; older data sets: from the label).
References:

* circle: K_xx = K_yy = 8Ga/(2 − nu), K_zz = 2aE* (Johnson 1985 §3.4, §7.2);
* ellipse b/a = γ (isotropic, unturned): Mindlin 1949 (K_a, K_b) and the elliptical punch
  π a E*/K(m) (K_zz);
* crystal or turned ellipses (anisotropy ≠ 1, or shape_angle ≠ 0): the one exact cell of
  Galin's theorem (``hpcontact.accuracy.exact_solve``, ``discretizations/galin_ellipse.py``:
  the bonded punch's traction c (1 − x²/a² − y²/b²)^(−½) on any half-space with an even kernel
  homogeneous of degree −1; no grid, its own error bound ~1e-14, printed);
* square and rectangle b/a = 1e-8 (no closed form): extrapolation over the finest grids at the
  tightest tol — a least-squares fit Q = Q* + Σ c_i h^{p_i} with p = 1, 1.5, 2 in the cell
  size along each resolved direction (n only for the square; n and n_across for the thin
  rectangle, whose mesh is exact so the error is a smooth edge-layer expansion). The spread of
  Q* over fits with fewer terms is printed as the reference's own uncertainty;
* regular polygons (no closed form): extrapolated from coverage-weighted grids 32 … 1024
  (``hpcontact.accuracy.solve_to_accuracy``, strategy coverage; its estimate printed): the
  centre-in-cell staircase of a slanted edge makes the study's own values fluctuate with n, so
  a fit over them is about as uncertain as the errors it would judge. A regular polygon of
  k ≥ 3 sides is tangentially isotropic (a second-order tensor invariant under a turn by 2π/k),
  so its K_a/K_b = K_xx/K_yy is 1 exactly.

Figures (PNG): ``error_vs_time.png`` (log–log, one panel per quantity, one curve per case: the
cheapest time that reaches each error, over all grids and tolerances; every task as a faint
point), ``error_vs_n.png`` (at the tightest tol; thin cases one curve per n_across) and
``error_vs_tol.png`` (at n = 256). ``accuracy_cost_table.md``: the time that 1 %, 0.1 %,
0.01 % cost for each case (largest relative error of K_xx, K_yy, K_a/K_b and K_zz), the grid
and tol that achieve it, as measured (one thread per task; the machine is named), and per case
the error at the finest n and the observed order (slope of log error against log n, n ≥ 128,
tightest tol). With
``--extrapolated`` (written by ``benchmarks/boundary_treatment.py``) the error and time of
``solve --accuracy`` runs are overlaid and tabulated too.
"""

from __future__ import annotations

import json
import math
import platform
import re
import time
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import freshness

if __name__ == "__main__":
    freshness.exit_if_fresh(__file__)  # before the imports that take seconds: an up-to-date run ends here

import numpy as np
import xarray as xr
from common import arguments, colours, open_dataset, panels, require, save

from hpcontact import accuracy, analytic
from hpcontact.scene import DEFAULTS, Scene

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


MATERIAL_KEYS = ("material", "cubic", "orthotropic", "voigt")  # a body other than the isotropic one


def case_params(ds: xr.Dataset) -> dict[str, dict[str, Any]]:
    """Per case, the scene parameters of its row: the data set's spec (``spec`` attribute: its
    [scene] table with the row of the shape axis; n_across and the label left out), else what the
    label says (shape and b/a) with the data set's nu."""
    nu = float(ds["nu"].values) if "nu" in ds.coords else 0.3
    rows: dict[str, dict[str, Any]] = {}
    spec = tomllib.loads(ds.attrs["spec"]) if isinstance(ds.attrs.get("spec"), str) else {}
    table = spec.get("axes", {}).get("shape", [])
    scene = {k: v for k, v in spec.get("scene", {}).items() if k in DEFAULTS}
    for entry in table if isinstance(table, list) else []:
        if isinstance(entry, Mapping) and "label" in entry:
            params = {"nu": nu, **scene, **{k: v for k, v in entry.items() if k in DEFAULTS and k != "n_across"}}
            rows.setdefault(case_of(str(entry["label"])), params)
    for label in ds["shape"].values:
        case = case_of(str(label))
        if case not in rows:
            shape, aspect = shape_of(case)
            rows[case] = {"shape": shape, "aspect": aspect, "nu": nu}
    return rows


def reference_kind(params: Mapping[str, Any]) -> str:
    """ "closed form" (isotropic circle, unturned isotropic ellipse), "exact cell" (any other
    ellipse or circle: crystal, turned), "coverage" (regular polygons: extrapolated from
    coverage-weighted grids) or "extrapolated" (rectangles: from the study's own finest grids)."""
    shape = params.get("shape", "circle")
    if shape == "polygon":
        return "coverage"
    if shape not in ("circle", "ellipse"):
        return "extrapolated"
    isotropic = float(params.get("anisotropy", 1.0)) == 1.0 and not any(params.get(k) for k in MATERIAL_KEYS)
    unturned = shape == "circle" or float(params.get("shape_angle", 0.0)) % 180.0 == 0.0
    return "closed form" if isotropic and unturned else "exact cell"


def exact_cell_reference(params: Mapping[str, Any]) -> tuple[dict[str, float], float, tuple[float, float]]:
    """K_xx, K_yy, K_a/K_b, K_zz of an ellipse on Galin's one exact cell
    (``hpcontact.accuracy.exact_solve``), its own estimated relative error and the CPU seconds
    of the solve (one thread): the first call for this material in the process, and the best of
    two more (the material's H(φ) then cached)."""
    scene = Scene.from_params({**params, "quantities": ["tangential", "normal"]})
    seconds = []
    for _ in range(3):
        start = time.process_time()
        record = accuracy.exact_solve(scene, 1e-9, False, time.perf_counter())
        seconds.append(time.process_time() - start)
    return {q: float(record[q]) for q in QUANTITIES}, float(record["estimated_error"]), (seconds[0], min(seconds[1:]))


#: What the polygons' reference asks of ``solve_to_accuracy`` (coverage-weighted cells): below
#: what n = 1024 reaches, so the whole calibrated sequence (32 … 1024) is solved.
POLYGON_REQUEST = 1e-6


def coverage_reference(params: Mapping[str, Any], request: float | None = None) -> tuple[dict[str, float], dict]:
    """K_xx, K_yy, K_a/K_b (1: a regular polygon is tangentially isotropic), K_zz extrapolated
    from coverage-weighted grids (``hpcontact.accuracy.solve_to_accuracy``, strategy coverage,
    ``strict=False``): each cut cell carries its covered area, so the error is smooth in h and
    Richardson applies, where the centre-in-cell staircase of a slanted edge makes the study's own
    grids fluctuate with n. Returns the values and the record (estimates, grids, wall time)."""
    scene = Scene.from_params({**params, "quantities": ["tangential", "normal"]})
    record = accuracy.solve_to_accuracy(
        scene, POLYGON_REQUEST if request is None else request, strategy="coverage", strict=False
    )
    values = {q: float(record[q]) for q in ("K_xx", "K_yy", "K_zz")}
    values["K_a_over_K_b"] = 1.0
    return values, record


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


def add_errors(cases: dict[str, list[dict]], rows: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, str]:
    """Relative errors per point (``err_<q>`` and ``err``: the largest of the four); returns a
    note per case on where its reference comes from. ``rows``: each case's scene parameters
    (:func:`case_params`; without them, the label's shape and b/a)."""
    notes = {}
    for case, points in cases.items():
        if rows is not None and case in rows:
            params = dict(rows[case])
        else:
            shape, aspect = shape_of(case)
            params = {"shape": shape, "aspect": aspect, "nu": points[0]["nu"]}
        kind = reference_kind(params)
        if kind == "closed form":
            reference = closed_form(params.get("shape", "circle"), float(params.get("aspect", 1.0)), points[0]["nu"])
            notes[case] = "closed form"
        elif kind == "exact cell":
            reference, bound, (first, again) = exact_cell_reference(params)
            notes[case] = (
                f"exact cell (Galin; its own estimate {bound:.1e}; "
                f"{1e3 * first:.0f} ms CPU the first call, {1e3 * again:.1f} ms again)"
            )
        elif kind == "coverage":
            reference, record = coverage_reference(params)
            grids = f"{record['grids'][0]}…{record['grids'][-1]}×{record['grids_across'][-1]}"
            notes[case] = (
                f"extrapolated from coverage-weighted grids {grids} (solve_to_accuracy; estimate "
                + ", ".join(f"{q} {record['estimated_errors'][q]:.1e}" for q in ("K_xx", "K_yy", "K_zz"))
                + f"; {record['wall_time_s']:.0f} s); K_a/K_b = 1 by symmetry)"
            )
        else:
            thin = _is_thin(points)
            finest = _tightest(points)
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


def observed_order(points: list[dict], key: str = "err", n_min: int = 128) -> tuple[float, float, int]:
    """(error at the finest n, observed order, that n) at the tightest tol: the order is minus the
    least-squares slope of log error against log n over n ≥ ``n_min`` (thin cases: on their most
    cells across); NaN with fewer than two such grids."""
    pts = _tightest(points)
    if _is_thin(points):
        most = max(p["na"] for p in pts)
        pts = [p for p in pts if p["na"] == most]
    pts = sorted((p for p in pts if p["n"] >= n_min and p[key] > EXACT), key=lambda p: p["n"])
    if not pts:
        return math.nan, math.nan, 0
    if len(pts) < 2:
        return pts[-1][key], math.nan, pts[-1]["n"]
    slope = np.polyfit(np.log([p["n"] for p in pts]), np.log([p[key] for p in pts]), 1)[0]
    return pts[-1][key], float(-slope), pts[-1]["n"]


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


LINES = {"closed form": "-", "exact cell": "--", "extrapolated": "-."}  # line style by the reference's kind


def short_reference(note: str) -> str:
    """The kind of reference a note of :func:`add_errors` names: closed form, exact cell,
    extrapolated (the study's grids) or extrapolated (coverage-weighted grids)."""
    if note.startswith("extrapolated from coverage"):
        return "extrapolated (coverage-weighted grids)"
    return note.split(" (")[0]


def styles(names: list[str], notes: Mapping[str, str] | None = None) -> dict[str, tuple[Any, str]]:
    """Per case a colour (a qualitative palette up to 10 cases, else viridis) and a line style
    that names its reference: solid closed form, dashed exact cell, dash-dotted extrapolated."""
    if len(names) <= 10:
        import matplotlib.pyplot as plt

        palette = list(plt.cm.tab10(np.arange(len(names))))
    else:
        palette = colours(len(names))
    notes = notes or {}
    return {
        c: (palette[i], LINES.get(short_reference(notes.get(c, "")).split(" (")[0], "-")) for i, c in enumerate(names)
    }


def legend_note(notes: Mapping[str, str] | None) -> str:
    """ "; lines by reference: solid closed form, dashed exact cell, …" when cases differ in it."""
    words = {"closed form": "solid", "exact cell": "dashed", "extrapolated": "dash-dotted"}
    kinds = {short_reference(n).split(" (")[0] for n in (notes or {}).values()}
    if len(kinds) < 2:
        return ""
    return "; lines by reference: " + ", ".join(f"{words[k]} {k}" for k in words if k in kinds)


def figure_error_vs_time(
    cases: dict[str, list[dict]], extrapolated: list[dict], outdir: Path, notes: Mapping[str, str] | None = None
) -> None:
    fig, axes = panels(len(QUANTITIES), columns=2, size=4.4)
    names = list(cases)
    style = styles(names, notes)
    for ax, q in zip(axes, QUANTITIES):
        key = f"err_{q}"
        for case in names:
            colour, ls = style[case]
            pts = [p for p in cases[case] if p[key] > EXACT]  # K_a/K_b of circle and square: 1 by symmetry
            if not pts:
                continue
            ax.loglog([p["time"] for p in pts], [p[key] for p in pts], ".", color=colour, alpha=0.15, ms=3)
            t, e = pareto(pts, key)
            ax.loglog(t, e, ls, color=colour, lw=1.5, label=case)
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
    note = "lines: cheapest grid and tol reaching each error; dots: every task" + legend_note(notes)
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


def figure_error_vs_n(cases: dict[str, list[dict]], outdir: Path, notes: Mapping[str, str] | None = None) -> None:
    """Every case at the tightest tol; thin cases on their finest n_across."""
    fig, axes = panels(len(QUANTITIES), columns=2, size=4.4)
    names = list(cases)
    style = styles(names, notes)
    for ax, q in zip(axes, QUANTITIES):
        key = f"err_{q}"
        for case in names:
            colour, ls = style[case]
            pts = _tightest(cases[case])
            label = case
            if _is_thin(cases[case]):
                most = max(p["na"] for p in pts)
                pts = [p for p in pts if p["na"] == most]
                label = f"{case} ({most} across)"
            pts = sorted((p for p in pts if p[key] > EXACT), key=lambda p: p["n"])
            if pts:
                ax.loglog([p["n"] for p in pts], [p[key] for p in pts], "o" + ls, color=colour, ms=3, label=label)
        ax.set_xlabel("n (cells along the long side)")
        ax.set_ylabel("relative error")
        ax.set_title(TITLES[q], fontsize=10)
        ax.grid(True, which="major", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8)
    fig.suptitle(
        "Error versus grid at the tightest CG tolerance (the staircase error of curved shapes is not monotone in n)"
        + legend_note(notes),
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
    style = styles(names)
    for case in names:
        colour = style[case][0]
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
        ref = short_reference(notes[case])
        lines.append(f"| {case} | {ref} | " + " | ".join(cells) + " |")
    lines.append("")
    lines.append(
        "Error at the finest n and observed order (minus the slope of log error against log n for n ≥ 128, "
        "tightest tol; thin cases on their most cells across), worst of the four and per quantity:"
    )
    lines.append("")
    lines.append(
        "| case | reference | finest grid | worst error | order | "
        + " | ".join(TITLES[q].split(" (")[0] for q in QUANTITIES)
        + " |"
    )
    lines.append("|---|---|---|---|---|" + "---|" * len(QUANTITIES))
    for case, pts in cases.items():
        err, order, n = observed_order(pts)
        finest = [p for p in _tightest(pts) if p["n"] == n]
        grid = f"{n}×{max(p['na'] for p in finest)}" if finest else "—"
        per = []
        for q in QUANTITIES:
            e, o, _ = observed_order(pts, f"err_{q}")
            per.append("exact by symmetry" if math.isnan(e) else f"{e:.1e} (order {o:.2f})")
        lines.append(
            f"| {case} | {short_reference(notes[case])} | {grid} | {err:.1e} | {order:.2f} | " + " | ".join(per) + " |"
        )
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
        require(
            ds,
            args.dataset,
            "jobs/accuracy_cost.toml",
            axes=("shape", "n", "tol"),
            variables=("status", "ny", "wall_time_s", "iterations", *QUANTITIES),
        )
        cases = gather(ds)
        notes = add_errors(cases, case_params(ds))
        extrapolated = load_extrapolated(args.extrapolated)
        figure_error_vs_time(cases, extrapolated, args.outdir, notes)
        figure_error_vs_n(cases, args.outdir, notes)
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
