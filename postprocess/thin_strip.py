"""Thin-strip limit: K_a/K_b versus b/a down to 1e-12 for rectangles and ellipses (issue 4, item 5).

    python postprocess/thin_strip.py figures/thin_strip/ [--nu 0.1 0.3 0.5] [--n 64 --n-across 32]

The points are solved directly (``hpcontact.problems.contact.solve``; 25 aspects × 3 nu × 2 shapes on two
grids, ~1 minute on one core), no data set needed. As b/a → 0 the ratio tends to 1 − nu, but
only logarithmically: for Mindlin's ellipse (docs/design.md §2.4) with Λ = ln(4 a/b),

    K_a/K_b = (1 − nu) + nu(2 − nu)/(Λ − nu) + O((b/a)² Λ)     (analytic.thin_ellipse_ratio_asymptote),

so at b/a = 1e-12 the ratio is still 0.018 (nu = 0.3) above its limit. Left panel: K_a/K_b
against b/a with Mindlin's exact ratio (line), the asymptote (dashed) and 1 − nu (dotted);
Li 2017's rectangle value 0.5390 at b/a = 1e-8, nu = 0.5 is marked. Right panel: the distance to
the limit, K_a/K_b − (1 − nu), against 1/Λ — a straight line through the origin for the
asymptote, which shows the logarithmic approach. Grid check: the script solves every point on
the grid asked for and on half of it (each direction) and prints the largest difference, an
upper bound of the grid error of the plotted ratios.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from common import add_format, save, use_format  # noqa: E402

from hpcontact import analytic  # noqa: E402
from hpcontact.problems.contact import solve  # noqa: E402
from hpcontact.scene import Scene  # noqa: E402

LI_2017_RECTANGLE = (1e-8, 0.5, 0.5390)  # (b/a, nu, K_a/K_b) reported by Li 2017


def ratios(shape: str, aspects: np.ndarray, nu: float, n: int, n_across: int) -> np.ndarray:
    """K_a/K_b on n cells along and max(n_across, n·b/a) across (square cells where b/a is large)."""
    return np.array(
        [
            solve(
                Scene.from_params(
                    {"shape": shape, "aspect": float(a), "nu": nu, "n": n, "n_across": max(n_across, int(round(n * a)))}
                )
            )["K_a_over_K_b"]
            for a in aspects
        ]
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("outdir", type=Path, help="folder for the figure")
    add_format(parser)
    parser.add_argument("--nu", type=float, nargs="+", default=[0.1, 0.3, 0.5])
    parser.add_argument("--n", type=int, default=64, help="cells along the long side")
    parser.add_argument("--n-across", type=int, default=32, help="cells across (thin shapes)")
    parser.add_argument("--points", type=int, default=25, help="aspects from 1 to 1e-12 (log spaced)")
    args = parser.parse_args()
    args.outdir.mkdir(parents=True, exist_ok=True)
    use_format(args.format)
    aspects = np.logspace(0, -12, args.points)
    fine_line = np.logspace(0, -12, 400)
    started = time.perf_counter()
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.6), layout="constrained")
    colours = plt.cm.viridis(np.linspace(0.0, 0.85, len(args.nu)))
    worst = 0.0
    rows = []
    for colour, nu in zip(colours, args.nu):
        for shape, marker in (("rectangle", "s"), ("ellipse", "o")):
            fine = ratios(shape, aspects, nu, args.n, args.n_across)
            coarse = ratios(shape, aspects, nu, args.n // 2, max(1, args.n_across // 2))
            worst = max(worst, float(np.max(np.abs(fine - coarse))))
            rows.append((shape, nu, fine))
            left.semilogx(
                aspects,
                fine,
                marker,
                color=colour,
                ms=4,
                mfc="none" if shape == "rectangle" else colour,
                label=f"{shape}, ν = {nu:g}",
            )
            lam = np.log(4.0 / aspects)
            right.plot(
                1.0 / lam, fine - (1.0 - nu), marker, color=colour, ms=4, mfc="none" if shape == "rectangle" else colour
            )
        exact = analytic.mindlin_ellipse_stiffness_ratio(fine_line, nu)
        asymptote = analytic.thin_ellipse_ratio_asymptote(fine_line, nu)
        left.semilogx(fine_line, exact, "-", color=colour, lw=1)
        left.semilogx(fine_line, asymptote, "--", color=colour, lw=0.8)
        left.axhline(1.0 - nu, color=colour, ls=":", lw=0.8)
        lam = np.log(4.0 / fine_line)
        right.plot(1.0 / lam, exact - (1.0 - nu), "-", color=colour, lw=1)
        right.plot(1.0 / lam, asymptote - (1.0 - nu), "--", color=colour, lw=0.8)
    a, nu, value = LI_2017_RECTANGLE
    if nu in args.nu:
        left.plot([a], [value], "kx", ms=9, mew=1.5, label="Li 2017 rectangle")
    left.invert_xaxis()
    left.set_xlabel("b/a")
    left.set_ylabel("K_a/K_b")
    left.set_title("lines: Mindlin ellipse; dashed: thin asymptote; dotted: 1 − ν", fontsize=9)
    left.legend(fontsize=7, ncol=2, loc="upper right")
    right.set_xlim(left=0.0)
    right.set_ylim(bottom=0.0)
    right.set_xlabel("1/Λ = 1/ln(4a/b)")
    right.set_ylabel("K_a/K_b − (1 − ν)")
    right.set_title("the logarithmic approach: (1 − ν) + ν(2 − ν)/(Λ − ν)", fontsize=9)
    for ax in (left, right):
        ax.grid(True, alpha=0.3)
    fig.suptitle(
        f"Thin-strip limit of K_a/K_b (grid {args.n} × {args.n_across}; largest change from the half grid {worst:.1e})",
        fontsize=10,
    )
    save(fig, args.outdir, "thin_strip.png")
    print(f"grid check: largest |K_a/K_b({args.n}×{args.n_across}) − K_a/K_b(half grid)| = {worst:.2e}")
    for shape, nu, fine in rows:
        i8, i12 = int(np.argmin(np.abs(aspects - 1e-8))), len(aspects) - 1
        print(
            f"{shape:>9} nu={nu:g}: K_a/K_b = {fine[i8]:.5f} at b/a = {aspects[i8]:.0e}, {fine[i12]:.5f} at "
            f"{aspects[i12]:.0e} (limit {1 - nu:g}; Mindlin ellipse {analytic.mindlin_ellipse_stiffness_ratio(aspects[i12], nu):.5f})"
        )
    print(f"time {time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
