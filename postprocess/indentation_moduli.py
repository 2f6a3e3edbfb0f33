"""Indentation moduli of cubic crystals on (001), (011), (111): BEM, Willis, Vlassak–Nix.

    python postprocess/indentation_moduli.py [--n 256] [--depth 1e-4] [--materials Cu Al ...]
                                             [--output table.md]

Prints a markdown table of the indentation modulus M (GPa) of library crystals (hpcontact.materials.crystal,
constants in GPa) indented by a rigid sphere on three surfaces, from

(i)   the BEM: a frictionless Polonsky–Keer sphere contact (``hpcontact.solve``, quantities
      ``indentation``, radius R = 1, approach d = 1e-4 R) read through Hertz's law,
      M = 3 P / (4 sqrt(R) d^{3/2}) (exact for isotropic bodies, where M = E/(1 − nu²), in the
      limit d/R → 0);
(ii)  Willis' (1966) elliptical Hertz contact (``hpcontact.analytic.willis_sphere_contact``;
      Swadener & Pharr 2001) with the same H_zz(φ) from the Barnett–Lothe integrals, read the
      same way; this is the exact small-d/R answer for the sphere;
(iii) Vlassak & Nix's approximation M = 2/⟨H_zz⟩, the in-plane average of the surface Green's
      function (J. J. Vlassak and W. D. Nix, "Measuring the elastic properties of anisotropic
      materials by means of indentation experiments", J. Mech. Phys. Solids 42 (1994) 1223–1245),
      which takes the contact as circular (``hpcontact.kernels.anisotropic.indentation_modulus``);

with the relative differences (BEM − Willis)/Willis and (Vlassak–Nix − Willis)/Willis, and the
contact ellipse's b/a (BEM and Willis; 1 on (001) and (111) by symmetry). Not a sweep: 18 small
solves, about 20 s on one core (n = 256).
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

from hpcontact.analytic import willis_sphere_contact
from hpcontact.kernels.anisotropic import indentation_modulus, surface_green_fourier
from hpcontact.materials.crystal import crystal
from hpcontact.problems.contact import solve
from hpcontact.scene import Scene

MATERIALS = ("Cu", "Al", "Fe", "Ni", "W", "Si")
PLANES = ("0 0 1", "0 1 1", "1 1 1")
CITATION = "Vlassak & Nix 1994, J. Mech. Phys. Solids 42:1223"


def hertz_modulus(load: float, R: float, d: float) -> float:
    """M from Hertz's P = (4/3) M sqrt(R) d^{3/2}."""
    return 3.0 * load / (4.0 * math.sqrt(R) * d**1.5)


def row(name: str, plane: str, R: float, d: float, n: int, tol: float) -> dict:
    """The three moduli (GPa) of ``name`` indented on ``plane``, and the contact's b/a."""
    hkl = tuple(int(v) for v in plane.split())
    material = crystal(name).oriented(miller=hkl)
    started = time.perf_counter()
    record = solve(
        Scene.from_params(
            {
                "quantities": ["indentation"],
                "material": name,
                "miller": plane,
                "radius": R,
                "depth": d,
                "n": n,
                "tol": tol,
            }
        )
    )
    bem_s = time.perf_counter() - started
    w = willis_sphere_contact(lambda phi: surface_green_fourier(material, phi)[..., 2, 2].real, R, d, n_phi=512)
    return {
        "material": name,
        "plane": f"({''.join(plane.split())})",
        "A": crystal(name).zener_ratio(),
        "bem": hertz_modulus(record["load"], R, d),
        "willis": hertz_modulus(w["load"], R, d),
        "vn": indentation_modulus(material, n_phi=512),
        "bem_b_over_a": record["ellipse_b_over_a"],
        "willis_b_over_a": min(w["b_over_a"], 1.0 / w["b_over_a"]),
        "bem_s": bem_s,
    }


def table(rows: list[dict], R: float, d: float, n: int) -> str:
    """The markdown table and its legend."""
    lines = [
        "| crystal | A | surface | M BEM [GPa] | M Willis [GPa] | M Vlassak–Nix [GPa] | BEM − Willis | VN − Willis | b/a BEM | b/a Willis |",
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['material']} | {r['A']:.2f} | {r['plane']} | {r['bem']:.2f} | {r['willis']:.2f} | {r['vn']:.2f} | "
            f"{(r['bem'] / r['willis'] - 1) * 100:+.4f} % | {(r['vn'] / r['willis'] - 1) * 100:+.3f} % | "
            f"{r['bem_b_over_a']:.4f} | {r['willis_b_over_a']:.4f} |"
        )
    lines += [
        "",
        f"M = 3P/(4 sqrt(R) d^(3/2)) from the sphere load P at d/R = {d / R:g} (BEM: Polonsky–Keer on {n} × {n} cells "
        "spanning 3 Hertz radii; Willis: elliptical Hertz contact, semi-analytical); Vlassak–Nix: M = 2/⟨H_zz⟩ "
        f"({CITATION}). Differences relative to Willis. A = 2 C44/(C11 − C12); constants of hpcontact.materials.crystal (GPa).",
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=256, help="cells a side of the BEM sphere grid (default 256)")
    parser.add_argument("--depth", type=float, default=1e-4, help="approach d for R = 1 (default 1e-4)")
    parser.add_argument("--tol", type=float, default=1e-10, help="Polonsky-Keer tolerance (default 1e-10)")
    parser.add_argument("--materials", nargs="+", default=list(MATERIALS), help="library crystals")
    parser.add_argument("--output", type=Path, help="also write the table to this markdown file")
    args = parser.parse_args(argv)
    R = 1.0
    started = time.perf_counter()
    rows = [row(m, p, R, args.depth, args.n, args.tol) for m in args.materials for p in PLANES]
    text = table(rows, R, args.depth, args.n)
    print(text)
    worst_bem = max(abs(r["bem"] / r["willis"] - 1) for r in rows)
    worst_vn = max(abs(r["vn"] / r["willis"] - 1) for r in rows)
    print(
        f"\nlargest |BEM - Willis|/Willis = {worst_bem:.2e}; largest |Vlassak-Nix - Willis|/Willis = {worst_vn:.2e}; "
        f"{len(rows)} BEM solves in {sum(r['bem_s'] for r in rows):.1f} s, total {time.perf_counter() - started:.1f} s"
    )
    if args.output is not None:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(text + "\n", encoding="utf-8")
        print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
