"""What a scene needs built and run, and nothing more (docs/design.md §1, "simulate only the effects").

One physical meaning per quantity, for every material (the same table is in
docs/reference/quantities.md):

.. list-table::
   :header-rows: 1

   * - quantity
     - bodies
     - problem
     - coupling kept
     - keys
   * - ``tangential``
     - two identical bodies, same material and orientation, bonded; stiffness per body (the pair's is half)
     - rigid tangential displacement, normal approach held (``normal_held = "load"``: normal load held)
     - all the pair has: the interface compliance is 2 Re H(m), so only Re H acts (below)
     - K_xx K_xy K_yx K_yy
   * - ``coupled``
     - one elastic half-space under a rigid bonded punch
     - unit rigid displacement along x, y, z
     - all of H(m), 3 × 3
     - K_ij, i, j in x y z (with ``tangential``: its 2 × 2 block as K_ij_coupled)
   * - ``normal``
     - one elastic half-space, rigid frictionless flat punch
     - unit approach, tangential traction free
     - none (zz block)
     - K_zz (with ``coupled``: the bonded one is K_zz_bonded)
   * - ``compliance``
     - as ``tangential``
     - uniform tangential traction, mean displacement (Li 2017 §3.2 proxy)
     - none
     - proxy_K_ij
   * - ``indentation``
     - one elastic half-space, rigid sphere, frictionless
     - Polonsky–Keer, unknown contact
     - none (zz block)
     - load, contact_area, ...

``tangential`` is Mindlin's (1949) and Li's (2017, assumption (ii)) decoupled stiffness,
generalized to crystals. For two bodies the bonded interface responds to its traction t with the
displacement jump (H₁(m) + H₂(m)) t̂/k, where H₂ is the lower body's Green's function. For the
same crystal in the same orientation below the interface (the lattice runs on), reflecting z
shows H₂ = conj(H₁) (checked to 6e-16 in ``tests/test_conventions.py``), so the jump is
2 Re H(m) t̂/k: the imaginary part — the antisymmetric normal–tangential coupling and the odd
part of the xy block — cancels; the real part remains. Per body, the stiffness is that of one
half-space with Green's function Re H. For an isotropic body the coupling of Re H is zero
(H_xz = +i(1 − 2nu)m_x/(2G) is imaginary), so z decouples and this is exactly Mindlin's K,
with two-component (x, y) solves; for a tilted crystal Re H_xz ≠ 0 (up to 14 % of |H| at
A = 3, psi = 20°), so the x and y solves carry z with the normal approach held (u_z = 0).
Through A = 1 both meanings join continuously: Re H_xz = O(A − 1).

``normal_held = "load"`` (scene field; default ``"approach"``) holds the normal load instead of
the approach, as Cattaneo's and Mindlin's (1949) experiment does (Johnson 1985, ch. 7): for a
crystal a third solve ``tangential_z`` (unit approach, x and y held) gives the last column of
the 3 × 3 Re-H stiffness K, and ``tangential`` is its Schur complement
K_tt − K_tz K_zz⁻¹ K_zt = (J_tt)⁻¹, J = K⁻¹ (``hpcontact.quantities.load_held_stiffness``). For
an isotropic body K_tz = 0 exactly, so the two are the same and no solve is added.

Shortcuts (each one tested against the general path at and next to its point,
``tests/test_conventions.py``):

- isotropic ``tangential``: kernels xx, yy and, unless nu = 0, xy (= yx). At nu = 0 the x and y
  problems decouple and share one kernel (xx = yy = I1/(2πG)), so each is a scalar solve. If the
  mask maps to itself under x ↔ y (square cells), the y-solve is the mirror image of the x-solve
  and is skipped.
- ``normal`` at nu = 0 is the same operator as the tangential x problem, so K_zz = K_xx without
  a solve when both are asked.
- ``coupled`` at nu = 0.5 (isotropic): the coupling blocks vanish and it is ``tangential`` +
  ``normal`` exactly.
- isotropic materials stay on the closed-form kernels whatever their orientation; a crystal
  (A ≠ 1 or a named crystal) uses the Barnett–Lothe kernels and none of the isotropic shortcuts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hpcontact.geometry import Grid
from hpcontact.materials.isotropic import Isotropic
from hpcontact.scene import Scene


@dataclass(frozen=True)
class Solve:
    """One linear solve: its name, the traction components it couples, the load it carries and
    the Green's function it uses ("H": one body; "Re H": per body of two identical bodies)."""

    name: str
    components: str  # e.g. "xy", "x", "z", "xyz"
    load: str  # displacement component prescribed = 1 ("x", "y", "z")
    green: str = "H"


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
            "solves": [f"{s.name}[{s.components}]" + ("" if s.green == "H" else f"({s.green})") for s in self.solves],
            "derived": list(self.derived),
            "operator_applications": list(self.applications),
        }


def transpose_symmetric(mask: np.ndarray, grid: Grid) -> bool:
    """True if the contact maps to itself under x ↔ y (needs square cells)."""
    return grid.dx == grid.dy and mask.shape[0] == mask.shape[1] and bool(np.array_equal(mask, mask.T))


def make_plan(scene: Scene, mask: np.ndarray, grid: Grid) -> Plan:
    """The kernels and solves ``scene`` needs on its contact ``mask`` (conventions: module docstring)."""
    return plan_for(scene, transpose_symmetric(mask, grid))


def holds_normal_load(scene: Scene) -> bool:
    """Whether the ``tangential`` stiffness of ``scene`` holds the normal load (F_z = 0, its
    ``normal_held = "load"``) rather than the normal approach (u_z = 0): K_tt − K_tz K_zz⁻¹ K_zt
    (module docstring; ``hpcontact.quantities.load_held_stiffness``)."""
    return scene.normal_held == "load"


def plan_for(scene: Scene, mirror: bool) -> Plan:
    """The kernels and solves ``scene`` needs on a contact that maps to itself under x ↔ y
    (``mirror``: one tangential solve serves both directions, isotropic bodies only) or not."""
    wanted = set(scene.quantities)
    kernels: list[str] = []
    solves: list[Solve] = []
    derived: list[str] = []
    applications: list[str] = []
    isotropic = isinstance(scene.material, Isotropic)
    if isotropic:
        nu = scene.material.nu
        source = "isotropic closed form (Boussinesq-Cerruti cell integrals)"
    else:
        nu = None  # no isotropic shortcut applies
        mirror = False
        source = "anisotropic (Barnett-Lothe surface Green's function)"

    def need(*blocks: str) -> None:
        kernels.extend(b for b in blocks if b not in kernels)

    if "coupled" in wanted and nu == 0.5:
        derived.append("coupled = tangential + normal (nu = 0.5: coupling blocks vanish, K_xz = ... = 0)")
        wanted = (wanted - {"coupled"}) | {"tangential", "normal"}

    if "coupled" in wanted:
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

    if ("tangential" in wanted or "compliance" in wanted) and isotropic:
        if nu == 0.0:
            need("xx")
            derived.append("yy = xx, xy = yx = 0 (nu = 0: no x-y coupling)")
        else:
            need("xx", "xy", "yx", "yy")
    elif "tangential" in wanted or "compliance" in wanted:
        need("xx", "yy", "Re xy")
    if "tangential" in wanted and isotropic:
        components = "x" if nu == 0.0 else "xy"
        solves.append(Solve("tangential_x", components, "x"))
        if mirror:
            derived.append("K_yy = K_xx, K_yx = K_xy (mask symmetric under x <-> y)")
        else:
            solves.append(Solve("tangential_y", "y" if nu == 0.0 else "xy", "y"))
    elif "tangential" in wanted:  # crystal: Re H couples z in general, the normal approach is held
        need("zz", "Re xz", "Re yz")
        solves.append(Solve("tangential_x", "xyz", "x", "Re H"))
        solves.append(Solve("tangential_y", "xyz", "y", "Re H"))
        if holds_normal_load(scene):  # the third column of the 3 x 3 Re-H stiffness: its Schur complement
            solves.append(Solve("tangential_z", "xyz", "z", "Re H"))
    if "tangential" in wanted and isotropic and holds_normal_load(scene):
        derived.append("normal_held load = approach (isotropic: Re H = H has no real x-z, y-z coupling, K_tz = 0)")
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
