"""Crystal-sphere friction map: tangential stiffness anisotropy with partial slip (issue 11).

    mpiexec -n 2 hpcontact run jobs/crystal_friction_map.toml
    python postprocess/crystal_friction_map.py results/crystal_friction_map.nc results/figures/crystal_friction/

Reads the data set of ``jobs/crystal_friction_map.toml`` (dimensions material, orientation,
q_ratio; SI units). k_min and k_max are the principal values of the symmetric part of the
consistent 2 × 2 incremental tensor (``tangential_stiffness_xx … _yy``: force = K · displacement).

Figures (PNG in OUTDIR):

* ``kmin_kmax.png`` — k_min/k_max against ψ ([110] → [111] → [001]), one panel per crystal, one
  line per Q/(mu P). At Q = 0 it is the bonded contact's tangential anisotropy (elastic only);
  under load the slip annulus makes the tensor anisotropic even on an isotropic body (a
  transverse increment turns the slip tractions instead of slipping: k_yy/k_xx = 2.1 at
  Q = 0.9 mu P on a circle, ``hpcontact.problems.slip.partial_slip``), so the crystal's part is the departure from the
  dashed isotropic reference solved here (the same scene on an isotropic body, nu = 0.3; the
  ratio does not depend on its modulus).
* ``kt_ratio.png`` — k_t along the load over its value at Q = 0, against Q/(mu P), every ψ of
  every crystal, with Mindlin–Deresiewicz (1 − Q/(mu P))^(1/3) (Johnson 1985, §7.2).

Printed: k_min/k_max per crystal and ψ at each Q/(mu P), and the stick-zone centroid offsets.
"""

from __future__ import annotations

import sys
from pathlib import Path

import freshness

if __name__ == "__main__":
    freshness.exit_if_fresh(__file__)  # before the imports that take seconds: an up-to-date run ends here

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from hpcontact.problems.slip.partial_slip import solve_slip  # noqa: E402
from postprocess.common import arguments, open_dataset, plt, require, save  # noqa: E402

AXES = ("material", "orientation", "q_ratio")  # of the data set drawn, in this order
DRAWN = (
    "tangential_stiffness",
    "tangential_stiffness_xx",
    "tangential_stiffness_yy",
    "tangential_stiffness_xy",
    "tangential_stiffness_yx",
    "stick_centroid_x",
)


def principal_ratio(ds) -> np.ndarray:
    """k_min/k_max of the symmetric part of the tensor, shape of the data set's dimensions."""
    xx, yy = ds["tangential_stiffness_xx"].values, ds["tangential_stiffness_yy"].values
    xy = 0.5 * (ds["tangential_stiffness_xy"].values + ds["tangential_stiffness_yx"].values)
    mean, half = 0.5 * (xx + yy), np.sqrt(0.25 * (xx - yy) ** 2 + xy * xy)
    return (mean - half) / (mean + half)


def isotropic_reference(ds, q: np.ndarray) -> np.ndarray:
    """k_min/k_max of the same scene on an isotropic body (nu = 0.3) at each Q/(mu P)."""
    fixed = {k: ds[k].values.item() for k in ("radius", "load", "mu", "angle", "steps", "n", "tol")}
    out = []
    for qj in q:
        rec = solve_slip({**fixed, "q_ratio": float(qj), "E": 200e9, "nu": 0.3, "tensor": True})
        K = np.array(
            [
                [rec["tangential_stiffness_xx"], rec["tangential_stiffness_xy"]],
                [rec["tangential_stiffness_yx"], rec["tangential_stiffness_yy"]],
            ]
        )
        values = np.linalg.eigvalsh(0.5 * (K + K.T))
        out.append(values[0] / values[1])
    return np.array(out)


def main() -> None:
    args = arguments(__doc__.splitlines()[0])
    with freshness.stamp(__file__, args.outdir, [args.dataset]):
        ds = open_dataset(args.dataset)
        require(ds, args.dataset, "jobs/crystal_friction_map.toml", axes=AXES, variables=DRAWN)
        ds = ds.transpose(*AXES)
        ratio = principal_ratio(ds)
        materials = [str(m) for m in ds["material"].values]
        psi = ds["orientation"].values
        q = ds["q_ratio"].values
        reference = isotropic_reference(ds, q)
        fig, axes = plt.subplots(
            1, len(materials), figsize=(4.2 * len(materials), 3.8), sharey=True, layout="constrained"
        )
        for ax, name, r in zip(np.atleast_1d(axes), materials, ratio):
            for j, qj in enumerate(q):
                ax.plot(psi, r[:, j], "o-", ms=3, color=f"C{j}", label=f"Q/(mu P) = {qj:g}")
                ax.axhline(reference[j], color=f"C{j}", lw=0.8, ls="--")
            ax.axvline(35.26, color="k", lw=0.5, ls=":")
            ax.set_title(name.replace("crystal:", "") + " sphere, P = 100 N, mu = 0.3")
            ax.set_xlabel("ψ [deg]  ([110] → [111] → [001])")
        np.atleast_1d(axes)[0].set_ylabel("k_min / k_max (consistent tangent)")
        np.atleast_1d(axes)[0].legend(fontsize=7)
        save(fig, args.outdir, "kmin_kmax.png", dpi=110)

        kt = ds["tangential_stiffness"].values
        fig, ax = plt.subplots(figsize=(5.5, 4), layout="constrained")
        for i, name in enumerate(materials):
            for k in range(len(psi)):
                ax.plot(
                    q,
                    kt[i, k] / kt[i, k, 0],
                    "-",
                    color=f"C{i}",
                    lw=0.8,
                    alpha=0.7,
                    label=name.replace("crystal:", "") if k == 0 else None,
                )
        qs = np.linspace(0.0, q.max(), 50)
        ax.plot(qs, (1.0 - qs) ** (1.0 / 3.0), "k--", label="Mindlin–Deresiewicz (isotropic)")
        ax.set_xlabel("Q / (mu P)")
        ax.set_ylabel("k_t / k_t(0) along the load")
        ax.legend(fontsize=8)
        save(fig, args.outdir, "kt_ratio.png", dpi=110)

        print("isotropic reference k_min/k_max: " + "  ".join(f"{r:.4f}" for r in reference))
        for i, name in enumerate(materials):
            print(f"{name}: k_min/k_max")
            for k, p in enumerate(psi):
                print(f"  psi = {p:6.2f}: " + "  ".join(f"{r:.4f}" for r in ratio[i, k]))
        off = ds["stick_centroid_x"].values
        print(f"largest stick-centroid offset along the load: {np.nanmax(np.abs(off)):.3e} m")


if __name__ == "__main__":
    main()
