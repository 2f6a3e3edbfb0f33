"""Cost per partial-slip scene of anisotropic pairs against the isotropic slip solver (issue 11).

The scene of ``jobs/tembleque2011_friction.toml`` (Rodríguez-Tembleque et al. 2011, §6.2:
ellipsoidal punch R = 0.5 m × 1.1 m, P = 0.37 MN, mu = 0.1, 0.15 mm along +x1 with the load in
one proportional step, n = 32) solved with

* ``iso similar``     two isotropic bodies E = 1 GPa, nu = 0.25 (closed-form kernels, no coupling);
* ``iso dissimilar``  E = 1 and 2 GPa (closed-form kernels, coupled and decoupled paths);
* ``ortho similar``   the paper's orthotropic pair (Barnett–Lothe kernels, no coupling);
* ``ortho E1 x2``     the dissimilar orthotropic pair (punch E1 = 50 GPa: coupled and decoupled);
* ``iso-ortho``       isotropic punch on the orthotropic block (coupled and decoupled);
* ``ortho E1 x32``    the stiffest punch of the job (E1 = 800 GPa).

Each scene twice in one process, scenes interleaved: ``cold`` (its kernels built: the first
scene of a material pair in a process, as in a sweep task) and ``warm`` (the spectra cached: the
solve alone). CPU seconds (``time.process_time``; one thread), and the ratio to ``iso similar``
and ``iso dissimilar`` of the same round, so a shared machine's load cancels to first order.

    .venv/bin/python benchmarks/slip_pair_cost.py [--n 32] [--rounds 2]

Not a test: numbers depend on the machine and its load.
"""

from __future__ import annotations

import argparse
from functools import partial

import harness

from hpcontact.problems.slip.partial_slip import solve_slip

ORTHO = "E1=25 E2=1 E3=1 G12=0.5 G13=0.5 G23=0.2 nu12=0.25 nu13=0.25 nu23=0.25"
SCENE = {
    "quantities": "slip",
    "radius": 0.5,
    "radius_b": 1.1,
    "load": 0.37e6,
    "mu": 0.1,
    "q_ratio": 0.5,
    "control": "displacement",
    "displacement": 0.15e-3,
    "angle": 180.0,
    "path": "proportional",
    "steps": 1,
    "tol": 1e-8,
    "tensor": True,
}
PAIRS = {
    "iso similar": {"E": 1e9, "nu": 0.25, "E2": 1e9, "nu2": 0.25},
    "iso dissimilar": {"E": 1e9, "nu": 0.25, "E2": 2e9, "nu2": 0.25},
    "ortho similar": {"orthotropic": ORTHO, "orthotropic2": ORTHO},
    "ortho E1 x2": {"orthotropic": ORTHO.replace("E1=25", "E1=50"), "orthotropic2": ORTHO},
    "iso-ortho": {"E": 1e9, "nu": 0.25, "orthotropic2": ORTHO},
    "ortho E1 x32": {"orthotropic": ORTHO.replace("E1=25", "E1=800"), "orthotropic2": ORTHO},
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=32, help="cells across the contact's major diameter (the job's: 32)")
    parser.add_argument("--rounds", type=int, default=2, help="cold + warm rounds are 1 + (rounds - 1) warm")
    args = parser.parse_args()
    print(f"slip_pair_cost: {harness.machine_line(1)}")
    times: dict[str, list[float]] = {name: [] for name in PAIRS}
    for _ in range(args.rounds):
        for name, pair in PAIRS.items():
            times[name].append(harness.timed(partial(solve_slip, {**SCENE, **pair, "n": args.n})).cpu_s)
    print(f"CPU s per scene, n = {args.n} (round 1 cold: kernels built; later rounds warm: spectra cached)")
    print(f"{'pair':16s} {'cold':>7s} {'warm':>7s} {'cold/iso sim':>13s} {'cold/iso dis':>13s} {'warm/iso dis':>13s}")
    for name, t in times.items():
        warm = min(t[1:]) if len(t) > 1 else float("nan")
        iso_warm = min(times["iso dissimilar"][1:]) if len(t) > 1 else float("nan")
        print(
            f"{name:16s} {t[0]:7.2f} {warm:7.2f} {t[0] / times['iso similar'][0]:13.2f} "
            f"{t[0] / times['iso dissimilar'][0]:13.2f} {warm / iso_warm:13.2f}"
        )


if __name__ == "__main__":
    harness.entry(main)
