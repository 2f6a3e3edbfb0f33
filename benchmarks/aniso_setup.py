"""Construction time of anisotropic cell influence coefficients (kernel set-up, not solves).

For each material/orientation and grid size n (nx = ny = n, square cells) prints
* ``green_s``   – surface Green's function: Barnett–Lothe H(φ), Fourier series, g(θ) table
                  (done once per material + orientation, then cached);
* ``zz_s``      – the zz block alone (frictionless normal contact);
* ``all9_s``    – all nine blocks (coupled bonded contact);
wall-clock and CPU seconds, with the quadrature statistics (directions, ω nodes, strip β); and,
for comparison, one solve on the same grid once its kernels are built (the engine's cache warm):
* ``setup_s``    – what a scene's engine builds before its first solve on that grid: the nine
                   blocks' cell coefficients and their zero-padded FFT spectra (cached per
                   material + grid in each process);
* ``solve_z_s``  – one frictionless flat-punch solve (circle of n cells across, zz only, CG);
* ``solve_xyz_s``– one coupled bonded solve (circle, unit x displacement, three components);
  a tangential crystal scene runs three of these (x, y and z loads).
The ``setup/solve`` column is (green + setup) / solve_xyz: above 1, kernel construction
costs more than a solve, so a sweep that revisits a material + grid (``tol`` studies, shapes
of one bounding box, load cases) gains from the per-process cache; well below 1, the solves
dominate and the cache hardly matters.

    .venv/bin/python benchmarks/aniso_setup.py [--n 256 512] [--threads 1] [--json] [--no-solve]

Not a test: numbers depend on the machine and its load (the CPU column is the robust one).
"""

from __future__ import annotations

import argparse
import json
import sys
from functools import partial

import harness
import numpy as np

from hpcontact.geometry import Grid
from hpcontact.kernels import anisotropic as an
from hpcontact.kernels.engine import Engine
from hpcontact.materials import crystal as cr
from hpcontact.numerics import convolution as op
from hpcontact.numerics.conjugate_gradient import conjugate_gradient
from hpcontact.numerics.preconditioner import FourierPreconditioner

ALL9 = ("xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz")


def materials() -> list[tuple[str, cr.Crystal]]:
    out = [
        ("cubic nu=0.3 A=1 [110]", cr.cubic_from_nu_A(0.3, 1.0).oriented(psi_deg=0.0)),
        ("cubic nu=0.3 A=2 psi=20", cr.cubic_from_nu_A(0.3, 2.0).oriented(psi_deg=20.0)),
        ("cubic nu=0.3 A=8 psi=20", cr.cubic_from_nu_A(0.3, 8.0).oriented(psi_deg=20.0)),
        ("cubic nu=0.49 A=0.25 [111]", cr.cubic_from_nu_A(0.49, 0.25).oriented(psi_deg=35.26438968)),
        ("Cu (111)", cr.crystal("Cu").oriented(miller=(1, 1, 1))),
        ("Fe (123) az=15", cr.crystal("Fe").oriented(miller=(1, 2, 3), azimuth_deg=15.0)),
        ("Si (001)", cr.crystal("Si").oriented(miller=(0, 0, 1))),
    ]
    return out


def timed(fn):
    """(value, wall s, CPU s) of one call of ``fn()``."""
    t = harness.timed(fn)
    return t.value, t.wall_s, t.cpu_s


def one_solve(mat: cr.Crystal, n: int, threads: int) -> dict:
    """Engine set-up (nine blocks + spectra), then one z and one coupled x solve on a circle.

    The grid is n × n cells of size 2/n (the circle of radius 1 touches its edges), the grid
    ``hpcontact.solve`` uses for a circle of ``n`` cells; H(φ) is already cached by the
    caller's timing, as in a sweep that revisits the material."""
    grid = Grid(n, n, 2.0 / n, 2.0 / n)
    x, y = grid.centres()
    mask = x * x + y * y <= 1.0
    engine = Engine(mat, grid, ALL9, threads)
    op.clear_cache()
    _, t_setup, _ = timed(lambda: engine.operator("xyz"))
    out = {"setup_s": t_setup}
    for name, components, load in (("z", "z", "z"), ("xyz", "xyz", "x")):
        operator = engine.operator(components)
        rhs = np.zeros((len(components),) + mask.shape)
        rhs[components.index(load)] = 1.0
        pre = FourierPreconditioner(grid, engine.surface_green, components).apply
        sol, t, c = timed(partial(conjugate_gradient, operator.apply, rhs, mask, tol=1e-10, precondition=pre))
        out.update({f"solve_{name}_s": t, f"solve_{name}_cpu_s": c, f"solve_{name}_iterations": sol.iterations})
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json", action="store_true", help="one JSON object per line")
    ap.add_argument("--no-solve", action="store_true", help="kernel construction only (no solve columns)")
    args = ap.parse_args(argv)
    rows = []
    print(f"aniso_setup: {harness.machine_line(args.threads)}", file=sys.stderr if args.json else sys.stdout)
    if not args.json:
        solve_head = (
            ""
            if args.no_solve
            else (
                f" {'setup_s':>7s} {'solve_z_s':>9s} {'it_z':>4s} {'solve_xyz_s':>11s} "
                f"{'it_xyz':>6s} {'setup/solve':>11s}"
            )
        )
        print(
            f"{'material':30s} {'n':>5s} {'green_s':>8s} {'zz_s':>7s} {'zz_cpu':>7s} "
            f"{'all9_s':>7s} {'all9_cpu':>8s} {'n_phi':>6s} {'n_om':>5s} {'beta':>5s}{solve_head}"
        )
    for name, mat in materials():
        for n in args.n:
            an.clear_cache()
            kern, t_green, _ = timed(partial(an.kernel_for, mat))
            _, t_zz, c_zz = timed(
                partial(an.anisotropic_offset_blocks, mat, n, n, 1.0, 1.0, [(2, 2)], threads=args.threads)
            )
            _, t_all, c_all = timed(partial(an.anisotropic_offset_blocks, mat, n, n, 1.0, 1.0, threads=args.threads))
            row = dict(
                material=name,
                n=n,
                green_s=t_green,
                zz_s=t_zz,
                zz_cpu_s=c_zz,
                all9_s=t_all,
                all9_cpu_s=c_all,
                n_phi=kern.n_phi,
                n_omega=kern.n_omega,
                beta=kern.beta,
                threads=args.threads,
            )
            solve_text = ""
            if not args.no_solve:
                row.update(one_solve(mat, n, args.threads))
                row["setup_over_solve"] = (t_green + row["setup_s"]) / row["solve_xyz_s"]
                solve_text = (
                    f" {row['setup_s']:7.2f} {row['solve_z_s']:9.2f} {row['solve_z_iterations']:4d} "
                    f"{row['solve_xyz_s']:11.2f} {row['solve_xyz_iterations']:6d} {row['setup_over_solve']:11.2f}"
                )
            rows.append(row)
            if args.json:
                print(json.dumps(row))
            else:
                print(
                    f"{name:30s} {n:5d} {t_green:8.3f} {t_zz:7.2f} {c_zz:7.2f} {t_all:7.2f} "
                    f"{c_all:8.2f} {kern.n_phi:6d} {kern.n_omega:5d} {kern.beta:5.2f}{solve_text}",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    harness.entry(main)
