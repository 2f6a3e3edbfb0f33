"""Grids, shape rasterization and rotation, masks from files, rough surfaces (hpcontact.geometry).

References are independent of the code: exact areas and perimeters of the shapes, explicit
vertex and boundary positions, and a rigorous bound on the area error of centre-in-shape
rasterization (every cell that the shape and its complement share lies within half a cell
diagonal d of the boundary, so |mask area − shape area| ≤ area of the d-tube around the boundary
≤ 2·d·perimeter + π·d²: the Gauss-circle-problem bound).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, special

from hpcontact.errors import InputError
from hpcontact.geometry import (
    Grid,
    Shape,
    crop_to_support,
    grid_for,
    load_mask,
    mask_grid,
    rasterize,
    self_affine_surface,
)

pytestmark = pytest.mark.filterwarnings("error")


# ------------------------------------------------------------------------------------------
# exact area and perimeter of each shape (semi-major extent / circumradius 1)
# ------------------------------------------------------------------------------------------
def _star_radius(phi, k, eps):
    return (1.0 + eps * np.cos(k * phi)) / (1.0 + eps)


def _exact(shape: Shape) -> tuple[float, float]:
    """(area, perimeter) from textbook formulas, not from the code under test."""
    b, k = shape.aspect, shape.sides
    if shape.name == "circle":
        return math.pi, 2.0 * math.pi
    if shape.name == "ellipse":
        # perimeter 4 a E(e²), e² = 1 − b²  (complete elliptic integral of the 2nd kind)
        return math.pi * b, 4.0 * float(special.ellipe(1.0 - b * b))
    if shape.name == "rectangle":
        return 4.0 * b, 4.0 * (1.0 + b)
    if shape.name == "polygon":
        # k isosceles triangles with apex angle 2π/k and legs 1
        return 0.5 * k * math.sin(2.0 * math.pi / k), 2.0 * k * math.sin(math.pi / k)
    if shape.name == "star":
        eps = shape.amplitude
        area = math.pi * (1.0 + 0.5 * eps * eps) / (1.0 + eps) ** 2  # ½∮ r² dφ
        dr = lambda p: -eps * k * np.sin(k * p) / (1.0 + eps)  # noqa: E731
        per, _ = integrate.quad(lambda p: math.hypot(_star_radius(p, k, eps), dr(p)), 0.0, 2 * math.pi, limit=200)
        return area, per
    raise AssertionError(shape.name)


SHAPES = [
    Shape("circle"),
    Shape("ellipse", aspect=0.4),
    Shape("ellipse", aspect=0.4, angle_deg=30.0),
    Shape("rectangle", aspect=0.3),
    Shape("rectangle", aspect=0.3, angle_deg=-20.0),
    Shape("polygon", sides=3),
    Shape("polygon", sides=6, angle_deg=7.0),
    Shape("star", sides=5, amplitude=0.3),
]


@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: f"{s.name}-{s.aspect}-{s.sides}-{s.angle_deg}")
def test_rasterized_area_converges_within_tube_bound(shape):
    area, perimeter = _exact(shape)
    errors = []
    for n in (16, 64, 256):
        grid = grid_for(shape, n)
        mask = rasterize(shape, grid)
        assert mask.shape == (grid.nx, grid.ny)
        d = 0.5 * math.hypot(grid.dx, grid.dy)
        bound = 2.0 * d * perimeter + math.pi * d * d  # tube around the boundary (module docstring)
        err = abs(mask.sum() * grid.cell_area - area)
        assert err <= bound, (n, err, bound)
        errors.append(err)
    # The rigorous bound shrinks like h (≈ 2–5 % at n = 256); the lattice errors cancel far
    # better, like h^(4/3) (Gauss circle problem): h^(4/3) ≈ 1.6e-3 at n = 256, measured ≤ 1e-3
    # relative for every shape here.
    assert errors[-1] <= 1.6e-3 * area


def test_circle_area_gauss_bound_fine_grid():
    # n = 1000 cells across: R = 500 cells. Lattice points in a disc: |N − πR²| = O(R^(2/3))
    # (Gauss circle problem; the constant is ~1 at these R), i.e. a relative error ≈ 8e-5
    # (measured 7.4e-5); bound 3·R^(2/3)/(πR²). The rigorous tube bound would allow 6e-3.
    shape = Shape("circle")
    grid = grid_for(shape, 1000)
    area = rasterize(shape, grid).sum() * grid.cell_area
    R = 500.0
    assert abs(area - math.pi) / math.pi <= 3.0 * R ** (2 / 3) / (math.pi * R * R)


def test_rectangle_fills_its_grid_exactly():
    for b, n, n_across in [(0.3, 10, 4), (1e-3, 64, 5), (1.0, 7, None), (0.05, 40, None)]:
        shape = Shape("rectangle", aspect=b)
        grid = grid_for(shape, n, n_across)
        mask = rasterize(shape, grid)
        assert mask.all()
        assert grid.dx == pytest.approx(2.0 / n, rel=1e-15)  # one rounding
        assert grid.dy == pytest.approx(2.0 * b / grid.ny, rel=1e-15)
        # n·dx · ny·dy = 2 · 2b: area exact to a few roundings
        assert mask.sum() * grid.cell_area == pytest.approx(4.0 * b, rel=1e-14)


def test_rotation_by_90_degrees_transposes_an_ellipse_mask():
    # Square cells, odd n: no cell centre lies on the ellipse x² + 4y² = 1 (4(k²+4m²) = n² has no
    # solution for odd n), so the 6e-17 of cos(90°) cannot flip a boundary cell.
    n = 41
    h = 2.0 / n
    grid = Grid(n, n, h, h)
    m0 = rasterize(Shape("ellipse", aspect=0.5), grid)
    m90 = rasterize(Shape("ellipse", aspect=0.5, angle_deg=90.0), grid)
    assert m0.sum() > 0
    assert not np.array_equal(m0, m0.T)  # the test would be empty for a circle
    assert np.array_equal(m90, m0.T)


def test_rotation_is_counter_clockwise():
    e = Shape("ellipse", aspect=0.5, angle_deg=30.0)
    major = np.radians(30.0)
    minor = np.radians(120.0)
    # along the turned major axis the boundary is at distance 1, along the minor axis at 0.5
    assert e.contains(np.array(0.99 * math.cos(major)), np.array(0.99 * math.sin(major)))
    assert not e.contains(np.array(1.01 * math.cos(major)), np.array(1.01 * math.sin(major)))
    assert e.contains(np.array(0.49 * math.cos(minor)), np.array(0.49 * math.sin(minor)))
    assert not e.contains(np.array(0.51 * math.cos(minor)), np.array(0.51 * math.sin(minor)))


@pytest.mark.parametrize("k", [4, 5, 8])
@pytest.mark.parametrize("angle", [0.0, 10.0])
def test_polygon_vertices_on_circumradius_one(k, angle):
    shape = Shape("polygon", sides=k, angle_deg=angle)
    t = np.radians(angle) + 2.0 * np.pi * np.arange(k) / k  # vertex directions (one on +x, turned)
    vx, vy = np.cos(t), np.sin(t)
    assert shape.contains(0.999 * vx, 0.999 * vy).all()
    assert not shape.contains(1.001 * vx, 1.001 * vy).any()
    # side midpoints at the apothem cos(π/k)
    mid = t + np.pi / k
    apothem = math.cos(math.pi / k)
    assert shape.contains(0.999 * apothem * np.cos(mid), 0.999 * apothem * np.sin(mid)).all()
    assert not shape.contains(1.001 * apothem * np.cos(mid), 1.001 * apothem * np.sin(mid)).any()
    # the box of the turned shape is the box of its vertices (for k = 4, 5, 8 the code's
    # boundary samples, 2π/20000 apart, land exactly on every vertex)
    X, Y = shape.half_extents()
    assert X == pytest.approx(np.max(np.abs(vx)), abs=1e-12)
    assert Y == pytest.approx(np.max(np.abs(vy)), abs=1e-12)


@pytest.mark.parametrize("k, angle", [(3, 0.0), (9, 0.0), (7, 10.0)])
def test_polygon_half_extents_contain_every_vertex(k, angle):
    shape = Shape("polygon", sides=k, angle_deg=angle)
    t = np.radians(angle) + 2.0 * np.pi * np.arange(k) / k
    X, Y = shape.half_extents()
    # the bounding box must hold every vertex; 1e-12 leaves room for rounding of cos/sin only
    assert X >= np.max(np.abs(np.cos(t))) - 1e-12
    assert Y >= np.max(np.abs(np.sin(t))) - 1e-12


def test_star_radius():
    k, eps = 5, 0.3
    shape = Shape("star", sides=k, amplitude=eps, angle_deg=0.0)
    phi = np.linspace(0.0, 2.0 * np.pi, 97, endpoint=False)
    r = (1.0 + eps * np.cos(k * phi)) / (1.0 + eps)
    assert shape.contains(0.999 * r * np.cos(phi), 0.999 * r * np.sin(phi)).all()
    assert not shape.contains(1.001 * r * np.cos(phi), 1.001 * r * np.sin(phi)).any()
    # outer radius 1 at the lobe tips, inner (1 − ε)/(1 + ε) between them
    assert r.max() == pytest.approx(1.0)
    assert shape.contains(np.array(0.999), np.array(0.0))
    assert not shape.contains(np.array(1.001), np.array(0.0))
    inner = (1.0 - eps) / (1.0 + eps)
    p = math.pi / k
    assert not shape.contains(np.array(1.001 * inner * math.cos(p)), np.array(1.001 * inner * math.sin(p)))


@pytest.mark.parametrize(
    "shape",
    [
        Shape("circle"),
        Shape("ellipse", aspect=0.3, angle_deg=0.0),
        Shape("ellipse", aspect=0.3, angle_deg=35.0),
        Shape("ellipse", aspect=0.3, angle_deg=90.0),
        Shape("rectangle", aspect=0.2, angle_deg=0.0),
        Shape("rectangle", aspect=0.2, angle_deg=-60.0),
        Shape("rectangle", aspect=0.2, angle_deg=135.0),
        Shape("star", sides=4, amplitude=0.25, angle_deg=22.0),
    ],
    ids=lambda s: f"{s.name}-{s.angle_deg}",
)
def test_half_extents_match_boundary_box(shape):
    """Bounding box of 200 000 points of the turned boundary, built from the textbook curves."""
    s = np.linspace(0.0, 2.0 * np.pi, 200_001)
    b = shape.aspect
    if shape.name in ("circle", "ellipse"):
        x, y = np.cos(s), b * np.sin(s)
    elif shape.name == "rectangle":
        x, y = np.array([1, -1, -1, 1.0]), np.array([b, b, -b, -b])  # corners
    else:
        r = _star_radius(s, shape.sides, shape.amplitude)
        x, y = r * np.cos(s), r * np.sin(s)
    t = math.radians(shape.angle_deg)
    X = np.max(np.abs(math.cos(t) * x - math.sin(t) * y))
    Y = np.max(np.abs(math.sin(t) * x + math.cos(t) * y))
    hx, hy = shape.half_extents()
    # sampled maxima miss the true ones by ≤ (Δs)²/2 · curvature scale ≈ 5e-10; the code's own
    # sampling for the star by ≤ (2π/20000)² ≈ 1e-7
    assert hx == pytest.approx(X, abs=2e-7)
    assert hy == pytest.approx(Y, abs=2e-7)


def test_grid_for_rules():
    # square-ish box: ny = n, square cells
    g = grid_for(Shape("circle"), 20)
    assert (g.nx, g.ny) == (20, 20) and g.dx == g.dy == pytest.approx(0.1)
    # thin box: never fewer than min(n, 16) cells across
    g = grid_for(Shape("ellipse", aspect=0.1), 100)
    assert (g.nx, g.ny) == (100, 16)
    assert g.dx == pytest.approx(0.02) and g.dy == pytest.approx(0.2 / 16)
    g = grid_for(Shape("ellipse", aspect=0.1), 10)
    assert (g.nx, g.ny) == (10, 10)
    # moderately thin: as square as the box allows, round(n·Y/X)
    g = grid_for(Shape("rectangle", aspect=0.5), 64)
    assert (g.nx, g.ny) == (64, 32) and g.dx == pytest.approx(g.dy)
    # explicit n_across wins
    g = grid_for(Shape("rectangle", aspect=1e-6), 50, 3)
    assert (g.nx, g.ny) == (50, 3)
    assert g.dy == pytest.approx(2e-6 / 3)
    # grid coordinates: centred cells
    assert g.x[0] == pytest.approx(-1.0 + g.dx / 2) and g.x[-1] == pytest.approx(1.0 - g.dx / 2)
    assert g.y.mean() == pytest.approx(0.0, abs=1e-20)
    xs, ys = g.centres()
    assert xs.shape == ys.shape == (50, 3)
    assert np.all(xs[:, 0] == g.x) and np.all(ys[0, :] == g.y)


@pytest.mark.parametrize("n, n_across, field", [(1, None, "n"), (0, None, "n"), (10, 0, "n_across")])
def test_grid_for_refuses(n, n_across, field):
    with pytest.raises(InputError) as info:
        grid_for(Shape("circle"), n, n_across)
    assert info.value.field == field


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"name": "blob"}, "shape"),
        ({"name": "ellipse", "aspect": 0.0}, "aspect"),
        ({"name": "ellipse", "aspect": 1.5}, "aspect"),
        ({"name": "ellipse", "aspect": float("nan")}, "aspect"),
        ({"name": "circle", "angle_deg": float("inf")}, "shape_angle"),
        ({"name": "polygon", "sides": 2}, "sides"),
        ({"name": "star", "sides": 1}, "sides"),
        ({"name": "star", "amplitude": 1.0}, "amplitude"),
        ({"name": "rough", "hurst": 1.0}, "hurst"),
        ({"name": "rough", "rms": 0.0}, "rms"),
        ({"name": "mask"}, "mask"),
    ],
)
def test_shape_refuses_bad_fields(kwargs, field):
    with pytest.raises(InputError) as info:
        Shape(**kwargs)
    assert info.value.field == field
    assert field in str(info.value) and "\n" not in str(info.value)


# ------------------------------------------------------------------------------------------
# masks from files, cropping
# ------------------------------------------------------------------------------------------
def _asymmetric_mask() -> np.ndarray:
    """An L-shaped, chiral mask [x, y] that changes under every flip and transpose."""
    m = np.zeros((7, 5), dtype=bool)
    m[1:6, 1] = True  # foot along x at low y
    m[1, 1:4] = True  # stem along y at low x
    m[5, 3] = True  # a lone cell at high x, high y
    return m


def test_load_mask_npy(tmp_path):
    m = _asymmetric_mask()
    path = tmp_path / "m.npy"
    np.save(path, np.where(m, 2.5, 0.0))  # any non-zero value is contact
    loaded = load_mask(path)
    assert loaded.dtype == bool and np.array_equal(loaded, m)
    g = mask_grid(loaded)
    # the contact spans 5 × 3 of the 7 × 5 cells: the unit a is half its long side, 2.5 cells
    assert (g.nx, g.ny) == (7, 5) and g.dx == g.dy == 2.0 / 5


def test_load_mask_png_orientation(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = _asymmetric_mask()
    # image rows run top (high y) to bottom, columns along x; dark pixels are contact
    image = np.where(m[:, ::-1].T, 0.0, 1.0)
    path = tmp_path / "m.png"
    plt.imsave(path, image, cmap="gray", vmin=0.0, vmax=1.0)
    loaded = load_mask(path)
    assert np.array_equal(loaded, m)


def test_load_mask_png_transparent_pixels_are_not_contact(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rgba = np.zeros((4, 6, 4))  # all black
    rgba[..., 3] = 1.0
    rgba[:2, :, 3] = 0.0  # top two rows transparent
    path = tmp_path / "a.png"
    plt.imsave(path, rgba)
    loaded = load_mask(path)
    assert loaded.shape == (6, 4)
    # top rows (high y) are transparent → columns j = 2, 3 in [x, y] order are empty
    assert loaded[:, :2].all() and not loaded[:, 2:].any()


def test_load_mask_refuses(tmp_path):
    empty = tmp_path / "empty.npy"
    np.save(empty, np.zeros((4, 4)))
    cube = tmp_path / "cube.npy"
    np.save(cube, np.ones((2, 2, 2)))
    text = tmp_path / "m.txt"
    text.write_text("1 1\n")
    for path in (empty, cube, text, tmp_path / "missing.npy"):
        with pytest.raises(InputError) as info:
            load_mask(path)
        assert info.value.field == "mask"


def test_load_mask_refuses_empty_png(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = tmp_path / "white.png"
    plt.imsave(path, np.ones((5, 5)), cmap="gray", vmin=0.0, vmax=1.0)
    with pytest.raises(InputError) as info:
        load_mask(path)
    assert info.value.field == "mask"


def test_crop_to_support():
    m = _asymmetric_mask()
    big = np.zeros((20, 13), dtype=bool)
    big[4:11, 6:11] = m
    grid = Grid(20, 13, 0.1, 0.3)
    sub, g = crop_to_support(big, grid)
    # the L touches x = 1..5 and y = 1..3 of the 7 × 5 pattern
    assert np.array_equal(sub, m[1:6, 1:4])
    assert (g.nx, g.ny) == sub.shape and (g.dx, g.dy) == (0.1, 0.3)
    assert sub.sum() == big.sum()
    assert sub[0].any() and sub[-1].any() and sub[:, 0].any() and sub[:, -1].any()
    with pytest.raises(InputError) as info:
        crop_to_support(np.zeros((3, 3), dtype=bool), grid)
    assert info.value.field == "mask"


# ------------------------------------------------------------------------------------------
# self-affine rough surface
# ------------------------------------------------------------------------------------------
def test_self_affine_surface_rms_mean_seed():
    h = self_affine_surface(64, 48, 0.03, 0.05, hurst=0.7, rms=0.02, seed=3)
    assert h.shape == (64, 48) and np.all(np.isfinite(h))
    # mean subtracted then scaled: zero up to summation rounding (~N·ulp·rms)
    assert abs(h.mean()) <= 1e-14 * 0.02
    assert math.sqrt(np.mean(h * h)) == pytest.approx(0.02, rel=1e-12)
    again = self_affine_surface(64, 48, 0.03, 0.05, hurst=0.7, rms=0.02, seed=3)
    assert np.array_equal(h, again)
    other = self_affine_surface(64, 48, 0.03, 0.05, hurst=0.7, rms=0.02, seed=4)
    assert not np.allclose(h, other)
    assert np.std(h - other) > 0.01  # two independent fields of rms 0.02 differ by ~0.028


def test_self_affine_surface_power_law():
    """|ĥ(q)|² ∝ q^(−2(1+H)) for q ≥ q0 (Persson et al. 2005), none below q0.

    Columns 0 < q_y < Nyquist of the half spectrum survive irfft2/rfft2 unchanged, so there
    the amplitude follows the power law exactly (up to FFT rounding, ~1e-13 relative).
    """
    nx, ny, dx, dy, H = 32, 50, 0.05, 0.04, 0.6  # lengths 1.6 and 2.0: q0 = 2π/2.0
    h = self_affine_surface(nx, ny, dx, dy, hurst=H, rms=0.1, seed=11)
    spec = np.fft.rfft2(h)
    qx = 2 * np.pi * np.fft.fftfreq(nx, dx)
    qy = 2 * np.pi * np.fft.rfftfreq(ny, dy)
    q = np.hypot(qx[:, None], qy[None, :])
    interior = np.zeros_like(q, dtype=bool)
    interior[:, 1 : (ny - 1) // 2 + 1] = True  # 0 < q_y < Nyquist (ny even: Nyquist at ny/2)
    ratio = np.abs(spec[interior]) * q[interior] ** (1.0 + H)
    assert np.std(ratio) <= 1e-10 * np.mean(ratio)
    # q = 0 carries nothing (zero mean); the rest of the q_y = 0 column is below q0 along x only
    # where q_x = 0, so the spectrum there is the mean alone
    assert abs(spec[0, 0]) <= 1e-12 * np.max(np.abs(spec))


def _parametric_bend_radius(x: np.ndarray, y: np.ndarray, dt: float) -> np.ndarray:
    """ρ = (x′² + y′²)^(3/2) / |x′y″ − y′x″| of a closed curve sampled at equal steps dt of its
    parameter: periodic central differences (second order), independent of the polar formula."""

    def d(f: np.ndarray) -> np.ndarray:
        return (np.roll(f, -1) - np.roll(f, 1)) / (2.0 * dt)

    x1, y1 = d(x), d(y)
    x2, y2 = d(x1), d(y1)
    with np.errstate(divide="ignore"):
        return (x1 * x1 + y1 * y1) ** 1.5 / np.abs(x1 * y2 - y1 * x2)


@pytest.mark.parametrize("k, eps", [(5, 0.3), (3, 0.2), (7, 0.05), (2, 0.6)])
def test_star_smallest_bend_radius_against_the_parametric_curvature(k, eps):
    """The star's smallest bend against the curvature of its outline as a parametric curve
    (x, y) = r(t)(cos t, sin t) differentiated numerically on 400 000 samples: central
    differences of step 1.6e-5 leave a relative error ~ (k·step)² ≈ 1e-8, so 1e-6 is a bound."""
    t = np.linspace(0.0, 2.0 * np.pi, 400_000, endpoint=False)
    r = (1.0 + eps * np.cos(k * t)) / (1.0 + eps)
    expected = float(np.min(_parametric_bend_radius(r * np.cos(t), r * np.sin(t), t[1])))
    assert Shape("star", sides=k, amplitude=eps).smallest_bend_radius() == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize("aspect", [1.0, 0.5, 0.1])
def test_ellipse_smallest_bend_radius_is_at_its_tips(aspect):
    """(b/a)² (a = 1): the ellipse (cos t, b sin t) bends tightest at its tips, against the
    parametric curvature on 400 000 samples (tolerance as the star's)."""
    t = np.linspace(0.0, 2.0 * np.pi, 400_000, endpoint=False)
    expected = float(np.min(_parametric_bend_radius(np.cos(t), aspect * np.sin(t), t[1])))
    shape = Shape("circle") if aspect == 1.0 else Shape("ellipse", aspect=aspect, angle_deg=30.0)
    assert shape.smallest_bend_radius() == pytest.approx(expected, rel=1e-6)


def test_straight_sided_shapes_do_not_bend():
    assert Shape("rectangle", aspect=1e-8).smallest_bend_radius() == math.inf
    assert Shape("polygon", sides=6, angle_deg=10.0).smallest_bend_radius() == math.inf
