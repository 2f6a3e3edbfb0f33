"""What a scene needs built and run, and nothing more (DESIGN §1, "simulate only the effects").

The plan is made from the scene and its rasterized contact (symmetry is read off the actual
mask, not assumed from the shape's name):

- ``tangential`` (bonded punch, tangential load; normal–tangential coupling neglected as for
  elastically similar bodies, Li 2017 assumption (ii), exact at nu = 0.5): kernels xx, yy and,
  unless nu = 0, xy (= yx). At nu = 0 the x and y problems decouple and share one kernel
  (xx = yy = I1/(2πG)), so each is a scalar solve. If the mask maps to itself under x ↔ y
  (square cells), the y-solve is the mirror image of the x-solve and is skipped.
- ``normal`` (frictionless flat punch): kernel zz only; at nu = 0 it is the same operator as the
  tangential x problem, so K_zz = K_xx without a solve when both are asked.
- ``coupled`` (bonded punch, one elastic body on a rigid punch): all blocks, three-component
  solves; it supplies the tangential block too (no separate tangential solves). At nu = 0.5
  the coupling blocks vanish and it reduces to tangential + normal. With ``normal`` as well,
  ``K_zz`` is the frictionless punch and the bonded one is ``K_zz_bonded``.
- ``compliance`` (Li 2017 §3.2 proxy): tangential kernels, operator applications, no solve.
- ``indentation`` (rigid sphere, Polonsky–Keer): kernel zz only.

An anisotropic half-space (a crystal) couples normal and tangential response even for a bonded
punch alone, so ``tangential`` is solved as ``coupled`` (3 × 3, all nine blocks), and none of
the isotropic shortcuts (nu = 0, x ↔ y mirror, nu = 0.5) apply. An isotropic material stays on
the closed-form kernels whatever its orientation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import Grid
from .materials import Isotropic
from .scene import Scene


@dataclass(frozen=True)
class Solve:
    """One linear solve: its name, the traction components it couples, the loads it carries."""

    name: str
    components: str  # e.g. "xy", "x", "z", "xyz"
    load: str  # displacement component prescribed = 1 ("x", "y", "z")


@dataclass(frozen=True)
class Plan:
    """Kernel blocks to build, solves to run, and what follows without a solve."""

    kernels: tuple[str, ...]
    solves: tuple[Solve, ...]
    derived: tuple[str, ...]
    applications: tuple[str, ...] = ()
    kernel_source: str = ""

    def as_dict(self) -> dict:
        return {
            "kernel_source": self.kernel_source,
            "kernels": list(self.kernels),
            "solves": [f"{s.name}[{s.components}]" for s in self.solves],
            "derived": list(self.derived),
            "operator_applications": list(self.applications),
        }


def transpose_symmetric(mask: np.ndarray, grid: Grid) -> bool:
    """True if the contact maps to itself under x ↔ y (needs square cells)."""
    return grid.dx == grid.dy and mask.shape[0] == mask.shape[1] and bool(np.array_equal(mask, mask.T))


def make_plan(scene: Scene, mask: np.ndarray, grid: Grid) -> Plan:
    """The kernels and solves ``scene`` needs on its contact ``mask``."""
    wanted = set(scene.quantities)
    kernels: list[str] = []
    solves: list[Solve] = []
    derived: list[str] = []
    applications: list[str] = []
    if isinstance(scene.material, Isotropic):
        nu = scene.material.nu
        mirror = transpose_symmetric(mask, grid)
        source = "isotropic closed form (Boussinesq-Cerruti cell integrals)"
    else:
        nu = None  # no isotropic shortcut applies
        mirror = False
        source = "anisotropic (Barnett-Lothe surface Green's function)"
        if "tangential" in wanted:
            wanted.add("coupled")

    def need(*blocks: str) -> None:
        kernels.extend(b for b in blocks if b not in kernels)

    if "coupled" in wanted and nu == 0.5:
        derived.append("coupled = tangential + normal (nu = 0.5: coupling blocks vanish, K_xz = ... = 0)")
        wanted = (wanted - {"coupled"}) | {"tangential", "normal"}

    if "coupled" in wanted:
        if "tangential" in wanted:
            derived.append("tangential block from the coupled solves")
            wanted = wanted - {"tangential"}
        if nu == 0.0:
            need("xx", "zz", "xz", "zx", "yz", "zy")
            derived.append("yy = xx, xy = yx = 0 (nu = 0)")
        else:
            need("xx", "xy", "yx", "yy", "zz", "xz", "zx", "yz", "zy")
        solves.append(Solve("coupled_x", "xyz", "x"))
        if mirror:
            derived.append("coupled_y from coupled_x (mask symmetric under x <-> y)")
        else:
            solves.append(Solve("coupled_y", "xyz", "y"))
        solves.append(Solve("coupled_z", "xyz", "z"))

    if "tangential" in wanted or "compliance" in wanted:
        if nu == 0.0:
            need("xx")
            derived.append("yy = xx, xy = yx = 0 (nu = 0: no x-y coupling)")
        else:
            need("xx", "xy", "yx", "yy")
    if "tangential" in wanted:
        components = "x" if nu == 0.0 else "xy"
        solves.append(Solve("tangential_x", components, "x"))
        if mirror:
            derived.append("K_yy = K_xx, K_yx = K_xy (mask symmetric under x <-> y)")
        else:
            solves.append(Solve("tangential_y", "y" if nu == 0.0 else "xy", "y"))
    if "compliance" in wanted:
        applications.extend(["uniform_traction_x", "uniform_traction_y"])

    if "normal" in wanted:
        if nu == 0.0 and "tangential" in wanted:
            derived.append("K_zz = K_xx (nu = 0: the normal operator equals the tangential one)")
        else:
            need("zz")
            solves.append(Solve("normal_z", "z", "z"))
    if "indentation" in wanted:
        need("zz")
        solves.append(Solve("indentation_polonsky_keer", "z", "z"))
    return Plan(tuple(kernels), tuple(solves), tuple(derived), tuple(applications), source)
