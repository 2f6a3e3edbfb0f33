"""The planner builds and runs only what a scene needs (docs/design.md §1, "simulate only the effects").

Two kinds of checks:
* ``make_plan`` on scenes and their real masks: the kernel blocks and solves listed;
* end to end through ``hpcontact.problems.contact.solve``: which kernel spectra were really built (read off
  the operator's spectrum cache, emptied first) and which solves really ran (the solver
  functions wrapped to count calls and record the number of traction components), and that
  what the plan derives instead of solving equals what a real solve gives (run here through
  the engine's pieces, or from a dense matrix of the influence coefficients).
"""

from __future__ import annotations

import numpy as np
import pytest

from hpcontact.geometry import Grid, grid_for, rasterize
from hpcontact.kernels.isotropic import isotropic_block
from hpcontact.numerics import convolution as op_mod
from hpcontact.plan import Solve, make_plan, transpose_symmetric
from hpcontact.problems import contact as solve_mod
from hpcontact.problems.contact import Engine, _run_solve, discretize, solve
from hpcontact.scene import Scene

pytestmark = pytest.mark.filterwarnings("error")

N = 24  # small grids: the plan does not depend on n; CG tol 1e-8 (scene default) unless set


def _plan(**params):
    scene = Scene.from_params({"n": N, **params})
    grid, mask = discretize(scene)
    return make_plan(scene, mask, grid)


@pytest.fixture
def spy(monkeypatch):
    """Empties the spectrum cache and counts solver calls; yields a function returning a report."""
    op_mod.clear_cache()
    calls: list[tuple[str, int]] = []
    cg, pk = solve_mod.conjugate_gradient, solve_mod.polonsky_keer

    def counting_cg(apply, rhs, mask, **kw):
        calls.append(("cg", rhs.shape[0]))
        return cg(apply, rhs, mask, **kw)

    def counting_pk(apply, gap, **kw):
        calls.append(("pk", 1))
        return pk(apply, gap, **kw)

    monkeypatch.setattr(solve_mod, "conjugate_gradient", counting_cg)
    monkeypatch.setattr(solve_mod, "polonsky_keer", counting_pk)

    def report():
        built = sorted({key[5] for key in op_mod._SPECTRUM_CACHE})  # key = (material, nx, ny, dx, dy, block, shape)
        return built, list(calls)

    yield report
    op_mod.clear_cache()


# ------------------------------------------------------------------------------------------
# make_plan
# ------------------------------------------------------------------------------------------
def test_isotropic_tangential_builds_no_zz_or_coupling():
    plan = _plan(shape="ellipse", aspect=0.5, nu=0.3)
    assert set(plan.kernels) == {"xx", "xy", "yx", "yy"}
    assert [(s.name, s.components, s.load) for s in plan.solves] == [
        ("tangential_x", "xy", "x"),
        ("tangential_y", "xy", "y"),
    ]


def test_circle_runs_one_tangential_solve():
    plan = _plan(shape="circle", nu=0.3)
    assert [s.name for s in plan.solves] == ["tangential_x"]
    assert any("x <-> y" in d for d in plan.derived)


def test_nu_zero_builds_only_xx_and_scalar_solves():
    plan = _plan(shape="ellipse", aspect=0.5, nu=0.0)
    assert plan.kernels == ("xx",)
    assert [(s.components, s.load) for s in plan.solves] == [("x", "x"), ("y", "y")]


def test_normal_alone_builds_only_zz():
    plan = _plan(quantities="normal", nu=0.3)
    assert plan.kernels == ("zz",)
    assert plan.solves == (Solve("normal_z", "z", "z"),)


def test_indentation_builds_only_zz():
    plan = _plan(quantities="indentation", radius=1.0, depth=0.01)
    assert plan.kernels == ("zz",)
    assert [s.name for s in plan.solves] == ["indentation_polonsky_keer"]


def test_coupled_builds_all_blocks_and_three_component_solves():
    plan = _plan(shape="ellipse", aspect=0.5, quantities="coupled", nu=0.3)
    assert set(plan.kernels) == {a + b for a in "xyz" for b in "xyz"}
    assert [(s.components, s.load) for s in plan.solves] == [("xyz", "x"), ("xyz", "y"), ("xyz", "z")]


def test_coupled_at_nu_half_reduces():
    plan = _plan(shape="ellipse", aspect=0.5, quantities="coupled", nu=0.5)
    assert set(plan.kernels) == {"xx", "xy", "yx", "yy", "zz"}
    assert {s.components for s in plan.solves} == {"xy", "z"}
    assert not any("z" in k and k != "zz" for k in plan.kernels)


def test_coupled_at_nu_zero_drops_xy():
    plan = _plan(shape="ellipse", aspect=0.5, quantities="coupled", nu=0.0)
    assert "xy" not in plan.kernels and "yx" not in plan.kernels
    assert {"xz", "zx", "yz", "zy", "zz"} <= set(plan.kernels)


def test_compliance_runs_no_solve():
    plan = _plan(shape="ellipse", aspect=0.5, quantities="compliance", nu=0.3)
    assert plan.solves == ()
    assert set(plan.kernels) == {"xx", "xy", "yx", "yy"}
    assert plan.applications == ("uniform_traction_x", "uniform_traction_y")


def test_nu_zero_normal_with_tangential_is_derived():
    plan = _plan(quantities="tangential,normal", nu=0.0)
    assert plan.kernels == ("xx",)
    assert [s.name for s in plan.solves] == ["tangential_x"]


def test_plan_as_dict_is_json_ready():
    d = _plan(shape="ellipse", aspect=0.5, nu=0.3).as_dict()
    assert d == {
        "kernel_source": "isotropic closed form (Boussinesq-Cerruti cell integrals)",
        "kernels": ["xx", "xy", "yx", "yy"],
        "solves": ["tangential_x[xy]", "tangential_y[xy]"],
        "derived": [],
        "operator_applications": [],
    }


def test_transpose_symmetry_is_read_off_the_mask():
    grid = Grid(5, 5, 0.2, 0.2)
    tri = np.add.outer(np.arange(5), np.arange(5)) <= 4  # symmetric about the diagonal
    assert transpose_symmetric(tri, grid)
    assert not transpose_symmetric(tri, Grid(5, 5, 0.2, 0.3))  # needs square cells
    lopsided = tri.copy()
    lopsided[4, 0] = False
    assert not transpose_symmetric(lopsided, grid)
    assert not transpose_symmetric(np.ones((5, 4), dtype=bool), Grid(5, 4, 0.2, 0.2))
    # decided by the mask, not the shape's name: an "ellipse" of aspect 1 is a circle, one solve
    assert len(_plan(shape="ellipse", aspect=1.0).solves) == 1


# ------------------------------------------------------------------------------------------
# end to end: what is really built and run
# ------------------------------------------------------------------------------------------
def test_e2e_isotropic_tangential(spy):
    record = solve(Scene.from_params({"shape": "ellipse", "aspect": 0.5, "nu": 0.3, "n": N}))
    built, calls = spy()
    assert built == ["xx", "xy", "yx", "yy"]
    assert calls == [("cg", 2), ("cg", 2)]
    assert record["plan"]["kernels"] == ["xx", "xy", "yx", "yy"]
    assert record["plan"]["solves"] == ["tangential_x[xy]", "tangential_y[xy]"]
    assert "K_zz" not in record
    # two independent solves: K_xy and K_yx agree to the CG tolerance (1e-8 relative residual)
    assert abs(record["K_xy"] - record["K_yx"]) <= 1e-6 * record["K_xx"]


def test_e2e_nu_zero_scalar(spy):
    record = solve(Scene.from_params({"shape": "ellipse", "aspect": 0.5, "nu": 0.0, "n": N}))
    built, calls = spy()
    assert built == ["xx"]
    assert calls == [("cg", 1), ("cg", 1)]
    assert record["K_xy"] == 0.0 and record["K_yx"] == 0.0


def test_e2e_circle_one_solve(spy):
    record = solve(Scene.from_params({"shape": "circle", "nu": 0.3, "n": N}))
    built, calls = spy()
    assert built == ["xx", "xy", "yx", "yy"]
    assert calls == [("cg", 2)]  # one two-component solve: K_yy from the mirror (checked in test_conventions)
    assert "K_yy = K_xx, K_yx = K_xy (mask symmetric under x <-> y)" in record["plan"]["derived"]


def test_e2e_normal_alone(spy):
    solve(Scene.from_params({"quantities": "normal", "nu": 0.3, "n": N}))
    built, calls = spy()
    assert built == ["zz"]
    assert calls == [("cg", 1)]


def test_e2e_compliance_no_solve(spy):
    record = solve(
        Scene.from_params({"shape": "ellipse", "aspect": 0.5, "quantities": "compliance", "nu": 0.3, "n": N})
    )
    built, calls = spy()
    assert calls == []
    assert built == ["xx", "xy", "yx", "yy"]
    assert record["iterations"] == 0
    # Li's proxy from a dense matrix of the same coefficients: uniform unit traction on the
    # contact, mean displacement, J = ū/F, K = J⁻¹
    scene = Scene.from_params({"shape": "ellipse", "aspect": 0.5, "nu": 0.3, "n": N})
    grid, mask = discretize(scene)
    ia, ja = np.nonzero(mask)
    di = ia[:, None] - ia[None, :] + grid.nx - 1
    dj = ja[:, None] - ja[None, :] + grid.ny - 1
    B = {
        b: isotropic_block(scene.material, grid.nx, grid.ny, grid.dx, grid.dy, b)[di, dj]
        for b in ("xx", "xy", "yx", "yy")
    }
    ones = np.ones(ia.size)
    mean = np.array(
        [[(B["xx"] @ ones).mean(), (B["xy"] @ ones).mean()], [(B["yx"] @ ones).mean(), (B["yy"] @ ones).mean()]]
    )
    force = ia.size * grid.cell_area
    K = np.linalg.inv(mean / force)
    for i, a in enumerate("xy"):
        for j, b in enumerate("xy"):
            # FFT vs direct sum: ~1e-14 relative (test_operator); inversion of a 2 × 2 with
            # cond ~ 1.1: a few ulp more
            assert record[f"proxy_K_{a}{b}"] == pytest.approx(K[i, j], rel=1e-10, abs=1e-12 * K[0, 0])


def test_e2e_coupled_nu_half_reduces(spy):
    params = {"shape": "ellipse", "aspect": 0.5, "quantities": "coupled", "nu": 0.5, "n": N, "tol": 1e-12}
    record = solve(Scene.from_params(params))
    built, calls = spy()
    assert built == ["xx", "xy", "yx", "yy", "zz"]
    assert sorted(calls) == [("cg", 1), ("cg", 2), ("cg", 2)]
    # the reduction is exact: a real three-component solve with all nine blocks gives the same
    scene = Scene.from_params(params)
    grid, mask = discretize(scene)
    engine = Engine(scene.material, grid, tuple(a + b for a in "xyz" for b in "xyz"))
    fx, _ = _run_solve(scene, engine, mask, Solve("coupled_x", "xyz", "x"))
    fz, _ = _run_solve(scene, engine, mask, Solve("coupled_z", "xyz", "z"))
    # both to CG tol 1e-12 (cond ~ √N ≈ 20): 1e-9 relative
    assert record["K_xx"] == pytest.approx(fx[0], rel=1e-9)
    assert record["K_yx"] == pytest.approx(fx[1], rel=1e-9, abs=1e-9 * fx[0])
    assert record["K_zz"] == pytest.approx(fz[2], rel=1e-9)
    assert abs(fx[2]) <= 1e-9 * fx[0] and abs(fz[0]) <= 1e-9 * fz[2]


def test_e2e_coupled_nu_half_reports_zero_coupling():
    record = solve(Scene.from_params({"shape": "ellipse", "aspect": 0.5, "quantities": "coupled", "nu": 0.5, "n": N}))
    for key in ("K_xz", "K_yz", "K_zx", "K_zy"):
        assert record[key] == 0.0


def test_e2e_nu_zero_normal_derived_equals_real_normal_solve(spy):
    both = solve(
        Scene.from_params(
            {"shape": "ellipse", "aspect": 0.5, "quantities": "tangential,normal", "nu": 0.0, "n": N, "tol": 1e-12}
        )
    )
    built, calls = spy()
    assert built == ["xx"]
    assert calls == [("cg", 1), ("cg", 1)]
    normal = solve(
        Scene.from_params({"shape": "ellipse", "aspect": 0.5, "quantities": "normal", "nu": 0.0, "n": N, "tol": 1e-12})
    )
    assert spy()[0] == ["xx", "zz"]  # the normal-only scene built its own zz
    # same operator at nu = 0 (zz = xx = I1/(2πG)); both solved to 1e-12: 1e-9 relative
    assert both["K_zz"] == pytest.approx(normal["K_zz"], rel=1e-9)
    assert both["normalized_xx"] == pytest.approx(1.0, rel=1e-9)  # Li: E*/G* = 1 at nu = 0


def test_e2e_indentation_builds_only_zz(spy):
    record = solve(Scene.from_params({"quantities": "indentation", "radius": 1.0, "depth": 0.01, "n": N}))
    built, calls = spy()
    assert built == ["zz"]
    assert calls == [("pk", 1)]
    assert record["load"] > 0.0


def test_e2e_indentation_reports_its_grid():
    R, d = 1.0, 0.01
    record = solve(Scene.from_params({"quantities": "indentation", "radius": R, "depth": d, "n": N}))
    h = 2.0 * 1.5 * np.sqrt(R * d) / N
    assert record["dx"] == pytest.approx(h) and record["dy"] == pytest.approx(h)
    assert record["contact_cells"] * h * h == pytest.approx(record["contact_area"])


# ------------------------------------------------------------------------------------------
# mirror-derived results equal real solves (mask symmetric under x <-> y, not under x -> -x)
# ------------------------------------------------------------------------------------------
@pytest.fixture
def triangle_mask(tmp_path):
    n = 14
    tri = np.add.outer(np.arange(n), np.arange(n)) <= n - 1  # right triangle, legs on the axes
    path = tmp_path / "tri.npy"
    np.save(path, tri)
    return str(path)


@pytest.mark.parametrize(
    "quantities, solves", [("tangential", ["tangential_x[xy]"]), ("coupled", ["coupled_x[xyz]", "coupled_z[xyz]"])]
)
def test_mirror_derived_equals_real_y_solve(triangle_mask, quantities, solves):
    params = {"shape": "mask", "mask": triangle_mask, "nu": 0.3, "quantities": quantities, "tol": 1e-12}
    record = solve(Scene.from_params(params))
    assert record["plan"]["solves"] == solves
    scene = Scene.from_params(params)
    grid, mask = discretize(scene)
    components = "xy" if quantities == "tangential" else "xyz"
    blocks = tuple(a + b for a in components for b in components)
    engine = Engine(scene.material, grid, blocks)
    fy, _ = _run_solve(scene, engine, mask, Solve("real_y", components, "y"))
    scale = record["K_xx"]
    # the triangle couples x and y (K_xy ≠ 0) and, coupled, z too: the check has teeth
    assert abs(record["K_xy"]) > 1e-3 * scale
    # CG tol 1e-12, cond ~ 10: 1e-9 of the scale
    assert record["K_xy"] == pytest.approx(fy[0], abs=1e-9 * scale)
    assert record["K_yy"] == pytest.approx(fy[1], abs=1e-9 * scale)
    if quantities == "coupled":
        assert abs(fy[2]) > 1e-4 * scale
        assert record["K_zy"] == pytest.approx(fy[2], abs=1e-9 * scale)


def test_rectangle_grid_for_plan_is_not_square():
    # a thin rectangle with its default grid has dx ≠ dy: never mirror-derived
    shape = Scene.from_params({"shape": "rectangle", "aspect": 0.5, "n": 20}).shape
    grid = grid_for(shape, 20, 13)
    mask = rasterize(shape, grid)
    assert not transpose_symmetric(mask, grid)


def test_coupled_and_normal_keep_both_k_zz():
    coupled = solve(Scene.from_params({"quantities": "coupled", "nu": 0.3, "n": N}))
    both = solve(Scene.from_params({"quantities": "coupled,normal", "nu": 0.3, "n": N}))
    normal = solve(Scene.from_params({"quantities": "normal", "nu": 0.3, "n": N}))
    assert abs(coupled["K_zz"] / normal["K_zz"] - 1.0) > 1e-2  # they really differ
    # with both asked, K_zz is the frictionless punch and K_zz_bonded the coupled tensor's zz
    # entry: the same solves as when asked alone, so the same numbers (measured bit-identical)
    assert both["K_zz"] == normal["K_zz"]
    assert both["K_zz_bonded"] == coupled["K_zz"]


def test_tangential_and_coupled_keep_their_own_meanings():
    """Asked together, K_xx … K_yy are the decoupled tangential tensor (as when asked alone)
    and the coupled punch's block is K_ij_coupled (before issue 14 K_xx silently became the
    coupled value). They differ by the coupling (measured 0.9 % at nu = 0.3)."""
    tangential = solve(
        Scene.from_params({"shape": "ellipse", "aspect": 0.5, "quantities": "tangential", "nu": 0.3, "n": N})
    )
    coupled = solve(Scene.from_params({"shape": "ellipse", "aspect": 0.5, "quantities": "coupled", "nu": 0.3, "n": N}))
    both = solve(
        Scene.from_params({"shape": "ellipse", "aspect": 0.5, "quantities": "tangential,coupled", "nu": 0.3, "n": N})
    )
    for key in ("K_xx", "K_xy", "K_yx", "K_yy"):
        assert both[key] == tangential[key] and both[f"{key}_coupled"] == coupled[key], key
    assert abs(coupled["K_xx"] / tangential["K_xx"] - 1.0) > 3e-3


# ------------------------------------------------------------------------------------------
# normal_held (issue 26 item 4): the third Re-H solve only for a crystal with the load held
# ------------------------------------------------------------------------------------------
CRYSTAL = {"anisotropy": 3.0, "orientation": 60.0}


@pytest.mark.parametrize("crystal", [False, True])
@pytest.mark.parametrize("held", ["approach", "load"])
@pytest.mark.parametrize("quantities", ["tangential", "tangential,normal", "normal", "coupled"])
def test_the_load_held_solve_is_planned_only_for_a_crystal_tangential(crystal, held, quantities):
    params = {"shape": "ellipse", "aspect": 0.5, "nu": 0.3, "quantities": quantities, "normal_held": held}
    plan = _plan(**params, **(CRYSTAL if crystal else {}))
    default = _plan(**{k: v for k, v in params.items() if k != "normal_held"}, **(CRYSTAL if crystal else {}))
    extra = crystal and held == "load" and "tangential" in quantities
    assert plan.kernels == default.kernels  # the third column needs no other kernel block
    if extra:
        assert plan.solves == (*default.solves[:2], Solve("tangential_z", "xyz", "z", "Re H"), *default.solves[2:])
    else:
        assert plan.solves == default.solves
    isotropic_load = not crystal and held == "load" and "tangential" in quantities
    assert plan.derived == default.derived + (
        ("normal_held load = approach (isotropic: Re H = H has no real x-z, y-z coupling, K_tz = 0)",)
        if isotropic_load
        else ()
    )


def test_the_load_held_solve_really_runs_only_for_a_crystal(spy):
    """End to end: a crystal with the load held runs one more three-component CG solve on the
    same kernel spectra; an isotropic body runs the same solves either way."""
    runs, seen = {}, 0
    for crystal in (False, True):
        for held in ("approach", "load"):
            params = {"shape": "ellipse", "aspect": 0.5, "nu": 0.3, "n": N, "normal_held": held}
            op_mod.clear_cache()
            solve(Scene.from_params({**params, **(CRYSTAL if crystal else {})}))
            built, calls = spy()
            runs[crystal, held] = built, calls[seen:]  # this scene's calls
            seen = len(calls)
    assert runs[False, "load"] == runs[False, "approach"] and runs[False, "approach"][1]
    built, calls = runs[True, "approach"]
    built_load, calls_load = runs[True, "load"]
    assert built_load == built
    assert calls == [("cg", 3), ("cg", 3)] and calls_load == [("cg", 3), ("cg", 3), ("cg", 3)]
