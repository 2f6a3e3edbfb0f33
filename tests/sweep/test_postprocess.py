"""The post-processing scripts plot the data set's numbers: each script runs as from the command
line (in this process, its figures captured as they are saved) on a sweep of the stand-in
solver, and the plotted points are checked against the data set and against the stand-in's
closed form (tests/sweep/conftest.py: K_a = (1 + nu)(1 + 0.01 sides), K_b = K_a / (b/a)^0.05,
K_xy = K_yx = 0 for unturned shapes, normalized_xx = 0.5)."""

from __future__ import annotations

import ast
import io
import os
import re
import runpy
import shutil
import subprocess
import sys
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.contour import ContourSet
from scipy.interpolate import RegularGridInterpolator

import hpcontact
from hpcontact.quantities import rotated_tensor
from hpcontact.sweep.driver import run_sweep
from hpcontact.sweep.run.schedule import SerialTeam

ROOT = Path(__file__).resolve().parents[2]
SPEC = """
[scene]
quantities = ["tangential", "normal"]
[axes]
shape = ["ellipse", { label = "hexagon", shape = "polygon", sides = 6 }]
aspect = [1.0, 0.1, 0.01]
nu = [0.1, 0.3, 0.5]
angle = { linspace = [0, 180, 7] }
"""
EXACT = 1e-12  # the scripts plot stored values and closed forms in float64: rounding only


@pytest.fixture(scope="module")
def dataset(tmp_path_factory, fake_solve) -> Path:
    folder = tmp_path_factory.mktemp("post")
    spec = folder / "spec.toml"
    spec.write_text(SPEC)
    return run_sweep(
        spec, output=folder / "sweep.nc", task_function=fake_solve, team=SerialTeam(), stream=io.StringIO()
    )


@pytest.fixture
def plotted(monkeypatch, tmp_path):
    """Run ``postprocess/<script>`` with arguments; returns {file name: [(panel title,
    [(x, y, marker) per plotted line])]} of the figures it saved (and it saved them)."""
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    import common

    figures: dict[str, list] = {}
    save = common.save

    def capture(fig, outdir, name):
        figures[name] = [
            (
                ax.get_title(),
                [
                    (
                        np.asarray(line.get_xdata(), dtype=float),
                        np.asarray(line.get_ydata(), dtype=float),
                        line.get_marker(),
                    )
                    for line in ax.get_lines()
                ],
            )
            for ax in fig.axes
            if ax.get_lines()
        ]
        path = save(fig, outdir, name)
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        return path

    monkeypatch.setattr(common, "save", capture)

    def run(script: str, *args: str) -> dict[str, list]:
        monkeypatch.setattr(sys, "argv", [script, *args, str(tmp_path / "fig")])
        runpy.run_path(str(ROOT / "postprocess" / script), run_name="__main__")
        return figures

    return run


def points(panel):
    """The marker lines of a panel (the data set's points), in plotting order."""
    return [(x, y) for x, y, marker in panel[1] if marker not in ("None", "", None)]


def test_anisotropy_curves_plot_K_a_over_K_b_of_the_data_set(plotted, dataset):
    figures = plotted("anisotropy_map.py", str(dataset))
    assert set(figures) == {"anisotropy_curves.png", "anisotropy_map_ellipse.png"}  # the hexagon ignores b/a
    ((title, _),) = figures["anisotropy_curves.png"]
    assert title == "ellipse"
    with hpcontact.open_dataset(dataset) as ds:
        ratio = ds.K_a_over_K_b.sel(shape="ellipse").load()
    curves = points(figures["anisotropy_curves.png"][0])
    assert len(curves) == 3  # one per nu
    for nu, (x, y) in zip(ratio.nu.values, curves):
        np.testing.assert_array_equal(x, ratio.aspect.values)
        np.testing.assert_allclose(y, ratio.sel(nu=nu).values, rtol=EXACT)
        np.testing.assert_allclose(y, x**0.05, rtol=EXACT)  # the stand-in: K_a/K_b = (b/a)^0.05


def test_polar_plots_normalized_K_nn_at_the_nearest_aspect(plotted, dataset):
    figures = plotted("polar.py", str(dataset))  # default --aspect 0.2: nearest is 0.1
    panels = dict(figures["knn_vs_angle.png"])
    assert set(panels) == {"ellipse", "hexagon"} and len(figures["polar.png"]) == 2
    with hpcontact.open_dataset(dataset) as ds:
        normalized = ds.normalized_nn.load()
    for shape, aspect in (("ellipse", 0.1), ("hexagon", 1.0)):
        curves = points(("", panels[shape]))
        assert len(curves) == 3
        for nu, (x, y) in zip((0.1, 0.3, 0.5), curves):
            np.testing.assert_array_equal(x, np.linspace(0.0, 180.0, 7))
            np.testing.assert_allclose(y, normalized.sel(shape=shape, aspect=aspect, nu=nu).values, rtol=EXACT)
            # Li's eq. 6 on the stand-in: normalized_nn = 0.5 K_nn/K_xx = 0.5 (cos² + sin² K_yy/K_xx),
            # K_yy/K_xx = (b/a)^-0.05 for the ellipse, 1 for the hexagon (it ignores b/a)
            t = np.radians(x)
            expected = 0.5 * (np.cos(t) ** 2 + np.sin(t) ** 2 * (aspect if shape == "ellipse" else 1.0) ** -0.05)
            np.testing.assert_allclose(y, expected, rtol=EXACT)


def test_tensor_components_plot_the_turned_tensor(plotted, dataset):
    figures = plotted("tensor_components.py", str(dataset))  # nu: the largest (0.5), b/a nearest 0.2
    assert set(figures) == {"tensor_components_ellipse.png", "tensor_components_hexagon.png"}
    with hpcontact.open_dataset(dataset) as ds:
        point = ds.sel(shape="ellipse", nu=0.5, aspect=0.1).load()
    K = np.array([[point.K_xx, point.K_xy], [point.K_yx, point.K_yy]], dtype=float)
    panels = figures["tensor_components_ellipse.png"]
    assert len(panels) == 4
    for k, (_, lines) in enumerate(panels):
        ((x, y),) = points(("", lines))
        np.testing.assert_allclose(y, [rotated_tensor(K, a).ravel()[k] for a in x], rtol=EXACT, atol=EXACT * K.max())
        if k == 0:  # K_nn: the data set's own K_nn(angle)
            np.testing.assert_allclose(y, point.K_nn.values, rtol=EXACT)


@pytest.fixture
def saved(monkeypatch, tmp_path):
    """Run ``postprocess/<script>`` with arguments (``tmp_path/fig`` the output folder); returns
    {file name: the matplotlib figure} of what it saved, after saving."""
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    import common

    figures: dict[str, object] = {}
    save = common.save

    def keep(fig, outdir, name, **options):
        path = save(fig, outdir, name, **options)
        figures[path.name] = fig
        return path

    monkeypatch.setattr(common, "save", keep)

    def run(script: str, *args: str) -> dict[str, object]:
        figures.clear()
        monkeypatch.setattr(sys, "argv", [script, *args, str(tmp_path / "fig")])
        runpy.run_path(str(ROOT / "postprocess" / script), run_name="__main__")
        return dict(figures)

    return run


@pytest.mark.parametrize("fmt, magic", [("pdf", b"%PDF-"), ("svg", b"<svg")])
def test_format_writes_pdf_and_svg(saved, dataset, tmp_path, fmt, magic):
    figures = saved("polar.py", str(dataset), "--format", fmt)
    assert set(figures) == {f"polar.{fmt}", f"knn_vs_angle.{fmt}"}
    written = sorted(p.name for p in (tmp_path / "fig").iterdir())
    assert written == [".polar.stamp.json", f"knn_vs_angle.{fmt}", f"polar.{fmt}"]  # no PNG beside them
    for name in written[1:]:
        head = (tmp_path / "fig" / name).read_bytes()[:400]
        assert head.startswith(magic) if fmt == "pdf" else magic in head, name
    # the next run without --format writes PNGs again (the format is not left over)
    assert set(saved("tensor_components.py", str(dataset))) == {
        "tensor_components_ellipse.png",
        "tensor_components_hexagon.png",
    }


def titles_inside(fig) -> list[str]:
    """The suptitle and axes titles of ``fig`` (laid out as saved), each checked to lie inside it."""
    canvas = FigureCanvasAgg(fig)  # closed after saving: a canvas again, laid out as saved
    canvas.draw()
    renderer = canvas.get_renderer()
    shown = []
    for text in [fig._suptitle, *(ax.title for ax in fig.axes)]:
        if text is None or not text.get_text():
            continue
        box = text.get_window_extent(renderer)
        assert box.x0 >= 0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height, text.get_text()
        shown.append(text.get_text())
    return shown


def test_titles_fit_in_their_figures(saved, dataset):
    """Constrained layout; every title inside its figure."""
    figures = {
        **saved("tensor_components.py", str(dataset)),
        **saved("anisotropy_map.py", str(dataset)),
        **saved("polar.py", str(dataset)),
    }
    assert len(figures) == 6
    for fig in figures.values():
        assert type(fig.get_layout_engine()).__name__ == "ConstrainedLayoutEngine"
        assert titles_inside(fig)


def test_titles_name_only_the_values_that_matter(saved, dataset):
    """The hexagon ignores b/a (the sweep solved one scene for every b/a): its title does not
    name the b/a taken, as if it mattered; the ellipse's does (issue 40: no "b/a" on shapes that
    ignore it). nu matters to both."""
    figures = saved("tensor_components.py", str(dataset))
    hexagon = " ".join(figures["tensor_components_hexagon.png"]._suptitle.get_text().split())
    ellipse = " ".join(figures["tensor_components_ellipse.png"]._suptitle.get_text().split())
    assert "b/a" not in hexagon and "ν = 0.5" in hexagon
    assert "b/a = 0.1" in ellipse and "ν = 0.5" in ellipse


def test_a_fixed_shape_is_named_with_what_makes_it_one_of_its_kind(monkeypatch):
    """A sweep of one polygon says how many sides ("polygon" alone titled a hexagon's crystal
    map), a star its lobes and amplitude; a shape axis is no one shape."""
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    import common

    def fixed(**coords):
        return xr.Dataset(coords={name: ((), value) for name, value in coords.items()})

    assert common.fixed_shape(fixed(shape="polygon", sides=6, nu=0.3)) == "polygon, 6 sides"
    assert common.fixed_shape(fixed(shape="star", sides=5, amplitude=0.3)) == "star, 5 lobes, amplitude 0.3"
    assert common.fixed_shape(fixed(shape="ellipse", aspect=0.5)) == "ellipse"
    axis = xr.Dataset(coords={"shape": ("shape", ["ellipse", "hexagon"])})
    assert common.fixed_shape(axis) == "contact" == common.fixed_shape(xr.Dataset())


def test_save_wraps_titles_wider_than_the_figure(monkeypatch, tmp_path):
    """A title wider than its figure (the demo's tensor components: b/a, nu, A, psi, n and tol
    in the suptitle of a 7.2-inch figure, cut at both ends before) is wrapped, not cut."""
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    import common

    common.use_format("png")
    long = (
        "ellipse: tangential stiffness tensor in axes turned by θ — b/a = 0.01, ν = 0.45, A = 1, ψ = 0, "
        "n = 64, tol = 1e-10"
    )
    fig, axes = common.panels(4, columns=2)
    fig.suptitle(long, fontsize=10)
    axes[0].set_title(long)
    common.save(fig, tmp_path, "wide.png")
    suptitle, title = titles_inside(fig)[:2]
    for text in (suptitle, title):
        assert "\n" in text and " ".join(text.split()) == long  # wrapped, every word kept


def test_save_wraps_axis_labels_longer_than_their_axes(monkeypatch, tmp_path):
    """A colour-bar label longer than its bar (the one-panel crystal map of
    ``orientation_map.py``: its label on a 4.2-inch panel, its start cut off below the figure
    before) is wrapped, every word kept, and lies inside the figure."""
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    import common

    common.use_format("png")
    fig, (ax,) = common.panels(1, size=4.2)
    drawn = ax.pcolormesh(np.arange(9.0).reshape(3, 3))
    long = "K_min / K_max (principal tangential stiffnesses)"
    bar = fig.colorbar(drawn, ax=[ax], label=long)
    fig.suptitle("Tangential stiffness anisotropy\nν = 0.3\nswept points only, nothing drawn between them")
    common.save(fig, tmp_path, "labels.png")
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    text = bar.ax.yaxis.label
    box = text.get_window_extent(canvas.get_renderer())
    assert "\n" in text.get_text() and " ".join(text.get_text().split()) == long
    assert box.x0 >= 0 and box.y0 >= 0 and box.x1 <= fig.bbox.width and box.y1 <= fig.bbox.height


def test_the_anisotropy_map_marks_the_swept_points(plotted, dataset):
    figures = plotted("anisotropy_map.py", str(dataset))
    ((title, lines),) = figures["anisotropy_map_ellipse.png"]
    ((x, y),) = points((title, lines))
    aspects, nus = np.meshgrid(np.log10([1.0, 0.1, 0.01]), [0.1, 0.3, 0.5])
    assert sorted(zip(x, y)) == sorted(zip(aspects.ravel(), nus.ravel()))  # every (b/a, nu) of the sweep, once


CRYSTAL = """
[scene]
quantities = ["tangential"]
shape = "ellipse"
[axes]
aspect = [1.0, 0.5]
anisotropy = [0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0]
orientation = [0.0, 35.26438968275465, 90.0]
"""


def crystal_solve(params):
    """A stand-in with principal stiffnesses: K_min/K_max = 1 - 0.1 |ln A| (1 + cos ψ) (1.5 - b/a) - 0.01
    (an isotropic body, A = 1, has no orientation)."""
    A, psi, aspect = float(params["anisotropy"]), float(params.get("orientation", 0.0)), float(params["aspect"])
    ratio = 1.0 - 0.1 * abs(np.log(A)) * (1.0 + np.cos(np.radians(psi))) * (1.5 - aspect) - 0.01
    return {"K_max": 2.0, "K_min": 2.0 * ratio}


def test_the_orientation_map_has_a_tick_at_A_1_and_marks_the_points(saved, tmp_path_factory):
    folder = tmp_path_factory.mktemp("crystal")
    (folder / "spec.toml").write_text(CRYSTAL)
    path = run_sweep(
        folder / "spec.toml",
        output=folder / "crystal.nc",
        task_function=crystal_solve,
        team=SerialTeam(),
        stream=io.StringIO(),
    )
    figures = saved("orientation_map.py", str(path))
    fig = figures["orientation_tangential_map.png"]
    maps = [ax for ax in fig.axes if ax.get_yscale() == "log"]
    assert len(maps) == 2  # one per b/a
    for ax in maps:
        ticks = list(ax.get_yticks())
        assert 1.0 in ticks and ticks == [0.25, 0.75, 1.0, 1.5, 3.0]  # every other A of eight, and A = 1
        assert [t.get_text() for t in ax.get_yticklabels()] == ["0.25", "0.75", "1", "1.5", "3"]
        (dots,) = [line for line in ax.get_lines() if line.get_marker() == "o"]
        assert len(dots.get_xdata()) == 8 * 3  # every (ψ, A) point of the sweep
        assert set(np.round(dots.get_ydata(), 12)) == {0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0}


# The up-to-date check (postprocess/freshness.py): a script run again with nothing changed prints
# one line and draws nothing; a changed data set, a missing figure, --force or other arguments
# draw again; a run that fails leaves no stamp.

POLAR = {"polar.png", "knn_vs_angle.png"}
HEAVY = {"numpy", "matplotlib", "xarray", "scipy", "hpcontact", "common", "postprocess"}


@pytest.fixture
def data(dataset, tmp_path) -> Path:
    """A copy of the data set (same bytes and mtime) that a test may change."""
    copy = tmp_path / "data.nc"
    shutil.copy2(dataset, copy)
    return copy


def rerun(saved, script: str, *args: str) -> dict[str, object] | None:
    """Run a script as ``saved`` does; None when it stopped as up to date (exit 0, nothing drawn)."""
    try:
        return saved(script, *args)
    except SystemExit as stop:
        assert stop.code in (0, None), stop.code
        return None


def mtimes(folder: Path) -> dict[str, int]:
    return {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}


def test_a_second_run_is_up_to_date_without_the_heavy_imports(saved, data, tmp_path):
    assert set(saved("polar.py", str(data))) == POLAR
    figures = tmp_path / "fig"
    before = mtimes(figures)
    script = ROOT / "postprocess" / "polar.py"
    done = subprocess.run(
        [sys.executable, "-X", "importtime", str(script), str(data), str(figures)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [f"{script}: figures in {figures} up to date with {data} (--force redraws)"]
    imported = {
        line.rsplit("|", 1)[1].strip().split(".")[0]
        for line in done.stderr.splitlines()
        if line.startswith("import time:")
    }
    assert {"freshness", "json", "hashlib"} <= imported  # the listing is read right
    assert not imported & HEAVY, imported & HEAVY
    assert mtimes(figures) == before  # nothing rewritten, the stamp included


def touch(data: Path, figures: Path) -> None:
    """A new mtime, the same bytes."""
    info = data.stat()
    os.utime(data, ns=(info.st_atime_ns, info.st_mtime_ns + 1_000_000_000))


def replace(data: Path, figures: Path) -> None:
    """An atomic rewrite with the same bytes, size and mtime (as a sweep writes its data set): a new inode."""
    shutil.copy2(data, data.with_name("new.nc"))
    os.replace(data.with_name("new.nc"), data)


def delete_a_figure(data: Path, figures: Path) -> None:
    (figures / "polar.png").unlink()


@pytest.mark.parametrize("change", [touch, replace, delete_a_figure])
def test_a_changed_data_set_or_a_missing_figure_redraws(saved, data, tmp_path, capsys, change):
    assert set(saved("polar.py", str(data))) == POLAR
    assert rerun(saved, "polar.py", str(data)) is None
    assert "up to date" in capsys.readouterr().out
    change(data, tmp_path / "fig")
    assert set(rerun(saved, "polar.py", str(data)) or ()) == POLAR
    assert rerun(saved, "polar.py", str(data)) is None  # stamped again


def test_force_redraws_and_is_not_remembered(saved, data, tmp_path):
    assert set(saved("polar.py", str(data))) == POLAR
    before = mtimes(tmp_path / "fig")
    assert set(rerun(saved, "polar.py", str(data), "--force") or ()) == POLAR
    after = mtimes(tmp_path / "fig")
    assert all(after[name] > before[name] for name in POLAR)
    assert rerun(saved, "polar.py", str(data)) is None  # the run without --force finds the forced run's figures


def test_another_format_draws_that_format(saved, data, tmp_path):
    assert set(saved("polar.py", str(data))) == POLAR
    assert set(rerun(saved, "polar.py", str(data), "--format", "svg") or ()) == {"polar.svg", "knn_vs_angle.svg"}
    assert rerun(saved, "polar.py", str(data), "--format", "svg") is None
    assert set(rerun(saved, "polar.py", str(data)) or ()) == POLAR  # one stamp per script: the last arguments


def test_a_failed_run_leaves_no_stamp(saved, data, tmp_path):
    assert set(saved("polar.py", str(data))) == POLAR
    stamp = tmp_path / "fig" / ".polar.stamp.json"
    assert stamp.is_file()
    data.write_bytes(b"not a netCDF file")
    with pytest.raises(SystemExit) as stop:  # common.refuse: one line, exit status 2
        saved("polar.py", str(data))
    assert stop.value.code == 2
    assert sorted(p.name for p in (tmp_path / "fig").iterdir()) == sorted(POLAR)  # no stamp, no temporary file


def test_an_interrupted_run_leaves_no_stamp_and_the_next_run_draws(saved, data, tmp_path, monkeypatch):
    import common

    keep = common.save
    written = []

    def interrupted(fig, outdir, name, **options):
        if written:
            raise KeyboardInterrupt
        written.append(keep(fig, outdir, name, **options))
        return written[-1]

    monkeypatch.setattr(common, "save", interrupted)
    with pytest.raises(KeyboardInterrupt):
        saved("polar.py", str(data))
    assert [p.name for p in written] == ["polar.png"]
    assert sorted(p.name for p in (tmp_path / "fig").iterdir()) == ["polar.png"]  # the first figure, no stamp
    monkeypatch.setattr(common, "save", keep)
    assert set(rerun(saved, "polar.py", str(data)) or ()) == POLAR


def stamped_scripts() -> list[Path]:
    return sorted(p for p in (ROOT / "postprocess").glob("*.py") if "freshness.stamp(" in p.read_text(encoding="utf-8"))


def test_the_readme_scripts_are_stamped():
    """The four scripts of the README's first command (a second run of it must take seconds)."""
    names = {p.name for p in stamped_scripts()}
    assert {"anisotropy_map.py", "polar.py", "tensor_components.py", "orientation_map.py"} <= names


@pytest.mark.parametrize("script", stamped_scripts(), ids=lambda p: p.name)
def test_every_stamped_script_checks_before_its_heavy_imports(script):
    """The check is worth something only before the imports that take seconds: it comes first
    among the module's statements that import numpy, matplotlib, xarray, scipy, hpcontact or common."""
    body = ast.parse(script.read_text(encoding="utf-8")).body
    heavy = [
        i
        for i, node in enumerate(body)
        if isinstance(node, ast.Import | ast.ImportFrom)
        and {(alias.name if isinstance(node, ast.Import) else node.module or "").split(".")[0] for alias in node.names}
        & HEAVY
    ]
    check = [
        i
        for i, node in enumerate(body)
        if isinstance(node, ast.If) and "freshness.exit_if_fresh(__file__)" in ast.unparse(node)
    ]
    assert heavy and check and check[0] < heavy[0]


# Error estimates (common.error_marks): a data set with ``V_error`` and ``error_status`` gets
# hatches where a map's estimated error is more than 10 % of its range, bars or bands on curves
# and the worst error in the title; an old data set (none of them) is drawn as before, its
# titles saying it has no estimates. The data sets are built by hand: every axis the four
# scripts need, K_xy = K_yx = 0, K_a/K_b = (b/a)^0.05, K_max = 2.

ERROR_AXES = {
    "aspect": [1.0, 0.1],
    "nu": [0.1, 0.3, 0.5],
    "anisotropy": [0.5, 1.0, 2.0],
    "orientation": [0.0, 45.0, 90.0],
}
ANGLES = [0.0, 45.0, 90.0, 135.0, 180.0]
ESTIMATED = ("K_xx", "K_xy", "K_yx", "K_yy", "K_a_over_K_b", "K_min", "K_max", "K_nn")
MAP_PANEL = {"anisotropy": 1.0, "orientation": 0.0}  # anisotropy_map.py's selection (A = 1, first ψ)
HATCHED = {"nu": 0.3, "aspect": 0.1}  # error 0.05 · 0.891 > 10 % of the range 1 − 0.1^0.05 = 0.109
BELOW = {"nu": 0.1, "aspect": 0.1}  # error 0.01 · 0.891 < 0.0109: not hatched
WITHOUT = {"nu": 0.5, "aspect": 1.0}  # error_status 2: no estimate


def error_dataset(kind: str) -> xr.Dataset:
    """``kind`` "none": no error variables (an old file); "small": every estimate 1e-4;
    "large": as small, with K_a/K_b's error 0.05 at ``HATCHED`` and 0.01 at ``BELOW`` and no
    estimate at ``WITHOUT`` (the map panel), requested accuracy 1e-3."""
    dims = tuple(ERROR_AXES)
    aspect, nu, A, psi = np.meshgrid(*(np.array(v) for v in ERROR_AXES.values()), indexing="ij")
    k_a = (1.0 + nu) * (1.0 + 0.1 * np.log(A) * np.cos(np.radians(psi)))
    k_b = k_a / aspect**0.05
    theta = np.radians(ANGLES)
    values = {
        "K_xx": k_a,
        "K_xy": 0.0 * k_a,
        "K_yx": 0.0 * k_a,
        "K_yy": k_b,
        "K_a_over_K_b": k_a / k_b,
        "K_min": 2.0 * (1.0 - 0.1 * np.abs(np.log(A)) * (1.0 + np.cos(np.radians(psi))) * (1.5 - aspect) - 0.01),
        "K_max": 2.0 + 0.0 * k_a,
    }
    ds = xr.Dataset(
        {name: (dims, v, {"long_name": name, "units": "1"}) for name, v in values.items()},
        coords={**ERROR_AXES, "angle": ANGLES},
    )
    knn = k_a[..., None] * np.cos(theta) ** 2 + k_b[..., None] * np.sin(theta) ** 2
    ds["K_nn"] = ((*dims, "angle"), knn, {"long_name": "K_nn", "units": "1"})
    if kind == "none":
        return ds
    status = np.zeros(aspect.shape, dtype=np.int8)
    for name in ESTIMATED:
        ds[f"{name}_error"] = (ds[name].dims, np.full(ds[name].shape, 1e-4), {"units": "1"})
        ds[name].attrs["ancillary_variables"] = f"{name}_error error_status"
    if kind == "large":
        ds["K_a_over_K_b_error"].loc[{**HATCHED, **MAP_PANEL}] = 0.05
        ds["K_a_over_K_b_error"].loc[{**BELOW, **MAP_PANEL}] = 0.01
        for name in ESTIMATED:
            ds[f"{name}_error"].loc[{**WITHOUT, **MAP_PANEL}] = np.nan
        status = xr.DataArray(status, coords={d: ERROR_AXES[d] for d in dims}, dims=dims)
        status.loc[{**HATCHED, **MAP_PANEL}] = 1
        status.loc[{**BELOW, **MAP_PANEL}] = 1
        status.loc[{**WITHOUT, **MAP_PANEL}] = 2
        status = status.values
        ds.attrs["requested_accuracy"] = 1e-3
    flags = {"flag_values": np.array([0, 1, 2], dtype=np.int8), "flag_meanings": "met not_met no_estimate"}
    ds["error_status"] = (dims, status, {"long_name": "error estimate status", **flags})
    return ds


@pytest.fixture(scope="module")
def error_files(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("errors")
    files = {}
    for kind in ("none", "small", "large"):
        files[kind] = folder / f"{kind}.nc"
        error_dataset(kind).to_netcdf(files[kind], engine="netcdf4")
    return files


@pytest.fixture
def common_module(monkeypatch):
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    import common

    return common


def marked(mask: xr.DataArray) -> set[tuple[float, float]]:
    """The (nu, b/a) points where a mask over (nu, aspect) is set."""
    nus, aspects = np.nonzero(mask.transpose("nu", "aspect").values)
    return {(float(mask["nu"][i]), float(mask["aspect"][j])) for i, j in zip(nus, aspects)}


def test_error_marks_are_the_points_whose_error_exceeds_a_tenth_of_the_range(common_module):
    common = common_module
    ds = error_dataset("large")
    da, _ = common.select_rest(ds["K_a_over_K_b"], ["nu", "aspect"])  # as anisotropy_map.py draws it
    da = da.transpose("nu", "aspect")
    marks = common.error_marks(ds, da)
    relative = ds["K_a_over_K_b_error"].sel(MAP_PANEL).transpose("nu", "aspect")
    np.testing.assert_array_equal(marks.relative.values, relative.values)
    np.testing.assert_allclose(marks.absolute.values, np.nan_to_num(np.abs(da.values) * relative.values), rtol=EXACT)
    assert marks.span == pytest.approx(1.0 - 0.1**0.05, rel=EXACT) and common.ERROR_FRACTION == 0.1
    assert marked(marks.exceeds) == {(0.3, 0.1)}  # BELOW is not, nor any 1e-4 point
    assert marked(marks.missing) == {(0.5, 1.0)}
    assert marks.worst == 0.05
    caption = common.error_caption(marks)
    assert caption == (
        "worst estimated relative error 5.0e-02 (requested 1.0e-03); "
        "hatched ///: error > 10 % of the map's range (1 point); hatched \\\\\\: no estimate (1 point)"
    )
    # K_xy's error is relative to the largest diagonal entry (K_xy = 0 here)
    kxy, _ = common.select_rest(ds["K_xy"], ["nu"])
    kxx, _ = common.select_rest(ds["K_xx"], ["nu"])
    kyy, _ = common.select_rest(ds["K_yy"], ["nu"])
    expected = 1e-4 * np.maximum(abs(kxx.values), abs(kyy.values))
    expected[np.isnan(common.relative_error(ds, kxy).values)] = 0.0
    np.testing.assert_allclose(common.error_marks(ds, kxy).absolute.values, expected, rtol=EXACT)
    # a ratio computed in a script: the sum of its parts' relative errors
    ratio, _ = common.select_rest(ds["K_min"] / ds["K_max"], ["anisotropy", "orientation"], {"nu": 0.3})
    both = common.error_marks(ds, ratio, names=["K_min", "K_max"])
    np.testing.assert_allclose(both.relative.values, 2e-4, rtol=EXACT)
    np.testing.assert_allclose(both.absolute.values, 2e-4 * ratio.values, rtol=EXACT)
    # a panel with no variation (K_max = 2): hatched where the error is above 10 % of |V|
    flat = ds.copy(deep=True)
    flat["K_max_error"].loc[{"nu": 0.1, **MAP_PANEL, "aspect": 0.1}] = 0.15  # 0.3 > 0.2
    flat["K_max_error"].loc[{"nu": 0.3, **MAP_PANEL, "aspect": 0.1}] = 0.05  # 0.1 < 0.2
    kmax, _ = common.select_rest(flat["K_max"], ["nu", "aspect"])
    assert marked(common.error_marks(flat, kmax).exceeds) == {(0.1, 0.1)}
    # an old data set: no marks, and the caption says so
    old = common.error_marks(error_dataset("none"), da)
    assert old.relative is None and not old.exceeds.any() and not old.missing.any()
    assert common.error_caption(old) == common.NO_ESTIMATES == "no error estimates in this data set (fixed grid)"


def hatches(fig) -> list[str]:
    """The hatch patterns drawn on the axes of ``fig`` (contour sets keep theirs in ``hatches``)."""
    found = []
    for ax in fig.axes:
        for artist in ax.collections:
            found += [h for h in (getattr(artist, "hatches", None) or [artist.get_hatch()]) if h]
    return found


def test_hatches_are_drawn_only_where_a_point_exceeds(common_module):
    common = common_module
    for kind, expected in (("large", [common.EXCEEDS_HATCH, common.MISSING_HATCH]), ("small", []), ("none", [])):
        ds = error_dataset(kind)
        da, _ = common.select_rest(ds["K_a_over_K_b"], ["nu", "aspect"])
        da = da.transpose("nu", "aspect")
        fig, ax = common.plt.subplots()
        ax.contourf(da["aspect"], da["nu"], da.values)
        drawn = common.hatch_errors(ax, da["aspect"], da["nu"], common.error_marks(ds, da))
        assert [d.hatches[0] for d in drawn] == expected, kind
        assert hatches(fig) == expected, kind
        common.plt.close(fig)


def titles(fig) -> str:
    """The suptitle and axes titles of ``fig``, one space between words (titles are wrapped)."""
    texts = [fig._suptitle, *(ax.title for ax in fig.axes)]
    return " ".join(" ".join(t.get_text().split()) for t in texts if t is not None)


ERROR_FIGURES = {
    "anisotropy_map.py": {"anisotropy_curves.png", "anisotropy_map_all.png"},
    "orientation_map.py": {"orientation_tangential_map.png", "orientation_tangential_curves.png"},
    "polar.py": {"polar.png", "knn_vs_angle.png"},
    "tensor_components.py": {"tensor_components_all.png"},
}


@pytest.mark.parametrize("kind", ["none", "large"])
def test_scripts_mark_the_estimated_errors_or_say_there_are_none(saved, error_files, kind):
    drawn = {}
    for script, names in ERROR_FIGURES.items():
        figures = saved(script, str(error_files[kind]), "--force")
        assert set(figures) == names, script
        drawn.update(figures)
    for name, fig in drawn.items():
        text = titles(fig)
        if kind == "none":
            assert "no error estimates in this data set (fixed grid)" in text, name
            assert "worst estimated" not in text, name
        else:
            assert "worst estimated relative error" in text and "(requested 1.0e-03)" in text, name
    # the map: hatched at the points that exceed and those without an estimate (old file: none)
    expected = ["///", "\\\\\\"] if kind == "large" else []
    assert hatches(drawn["anisotropy_map_all.png"]) == expected
    assert hatches(drawn["orientation_tangential_map.png"]) == []  # no point's error above 10 % of the range
    if kind == "large":
        assert "worst estimated relative error 5.0e-02" in titles(drawn["anisotropy_map_all.png"])
        assert "(1 point)" in titles(drawn["anisotropy_map_all.png"])
    # curves: bars (anisotropy, tensor components, K_nn) and bands (polar) only with estimates
    for name in ("anisotropy_curves.png", "polar.png", "knn_vs_angle.png", "tensor_components_all.png"):
        collections = [c for ax in drawn[name].axes for c in ax.collections]
        assert bool(collections) == (kind == "large"), name


# Maps drawn only where the data back them (common.draw_map): a filled map states the worst
# error of what it draws, the drawing between grid points included; a plain sweep's few nodes
# are drawn alone.


def _known_map(aspects: np.ndarray, nus: np.ndarray) -> np.ndarray:
    """A known smooth map over (nu, log10 b/a): Mindlin's bonded-ellipse K_a/K_b."""
    from hpcontact.analytic import mindlin_ellipse_stiffness_ratio

    return mindlin_ellipse_stiffness_ratio(aspects[None, :], nus[:, None])


def _map_dataset(aspects: np.ndarray, nus: np.ndarray, map_error: float | None) -> xr.Dataset:
    values = _known_map(aspects, nus).T  # (aspect, nu)
    ds = xr.Dataset({"K_a_over_K_b": (("aspect", "nu"), values)}, coords={"aspect": aspects, "nu": nus})
    if map_error is not None:  # an adaptive map whose every point is exact to map_error
        ds["K_a_over_K_b_map_error"] = (("aspect", "nu"), np.full(values.shape, map_error))
        ds["solved"] = (("aspect", "nu"), np.ones(values.shape, dtype=np.int32))
        ds.attrs["adaptive_tolerance"] = 1e-3
    return ds


def _worst_in(caption: str) -> float:
    return float(re.search(r"worst map error of what is drawn ([0-9.e+-]+)", caption).group(1))


def test_a_filled_map_states_an_error_that_holds_for_what_it_draws(common_module):
    """A map of a known function (Mindlin's K_a/K_b, 25 b/a x 11 nu, as the main job's) drawn
    filled: its caption's worst error is at least the true error of the picture — the bilinear
    interpolant between grid points that the filled contours draw, sampled 8 x 8 per cell,
    against the function itself — and not more than 10 x it (a bound that says something); the
    error of the values at the points (here a stated 1e-5) is added to it."""
    common = common_module
    aspects, nus = np.logspace(0, -8, 25), np.linspace(0.0, 0.5, 11)
    for stated in (0.0, 1e-5):
        ds = _map_dataset(aspects, nus, stated)
        da = ds["K_a_over_K_b"].transpose("nu", "aspect")
        fig, ax = plt.subplots()
        levels = np.linspace(float(da.min()), 1.0, 21)
        _, marks = common.draw_map(ax, ds, da, np.log10(aspects), nus, levels)
        plt.close(fig)
        caption = common.error_caption(marks)
        x, y = np.log10(aspects), nus
        fine_x = np.concatenate([np.linspace(a, b, 9)[:-1] for a, b in zip(x[:-1], x[1:])] + [x[-1:]])
        fine_y = np.concatenate([np.linspace(a, b, 9)[:-1] for a, b in zip(y[:-1], y[1:])] + [y[-1:]])
        drawn = RegularGridInterpolator((y, x[::-1]), da.values[:, ::-1])(
            np.stack(np.meshgrid(fine_y, fine_x, indexing="ij"), axis=-1)
        )
        exact = _known_map(10.0**fine_x, fine_y)
        true = float(np.max(np.abs(drawn / exact - 1.0)))
        assert true > 1e-6  # the drawing has an error to state
        assert true + stated <= _worst_in(caption) <= 10.0 * (true + stated), (caption, true)
        assert "map tolerance 1.0e-03" in caption


def test_a_plain_sweep_of_few_points_draws_them_alone(common_module):
    """5 b/a x 3 nu nodes (the old main job's map): no contour between them, coloured points,
    and the caption says nothing is drawn between them."""
    common = common_module
    aspects, nus = np.logspace(0, -8, 5), np.array([0.0, 0.25, 0.45])
    ds = _map_dataset(aspects, nus, None)
    da = ds["K_a_over_K_b"].transpose("nu", "aspect")
    fig, ax = plt.subplots()
    mappable, marks = common.draw_map(ax, ds, da, np.log10(aspects), nus, np.linspace(0.5, 1.0, 21))
    assert not [c for c in ax.collections if isinstance(c, ContourSet)]
    assert len(mappable.get_offsets()) == 15
    plt.close(fig)
    assert common.error_caption(marks).startswith("swept points only, nothing drawn between them")
    dense = _map_dataset(np.logspace(0, -8, 9), np.linspace(0, 0.5, 9), None)
    assert not common.filled(ds, da) and common.filled(dense, dense["K_a_over_K_b"])


@pytest.mark.parametrize("script", ["anisotropy_map.py", "polar.py", "tensor_components.py", "orientation_map.py"])
def test_an_unreadable_data_set_is_refused_in_one_line(script, tmp_path, monkeypatch, capsys):
    """A missing file, a text file named .nc, a netCDF that is no sweep's: exit 2, one line on
    stderr naming the file, no traceback, no figure (issue 43 item 6: a 20-line OSError before).
    The damaged file, whose read raised that OSError, runs the script as a command (exit status
    and stderr as a shell sees them); the other two run it in this process (``runpy``, as
    ``saved`` does: 3 s of imports fewer each), where any exception but the refusal's
    ``SystemExit(2)`` fails the test."""
    damaged = tmp_path / "damaged.nc"
    damaged.write_text("not netCDF\n")
    foreign = tmp_path / "foreign.nc"
    xr.Dataset({"x": ("i", np.arange(3.0))}).to_netcdf(foreign, engine="netcdf4")
    monkeypatch.syspath_prepend(str(ROOT / "postprocess"))
    for path, says, as_command in (
        (tmp_path / "missing.nc", "no such file", False),
        (damaged, "cannot read it as a sweep data set", True),
        (foreign, "not a sweep data set", False),
    ):
        arguments = [str(ROOT / "postprocess" / script), str(path), str(tmp_path / "fig"), "--force"]
        if as_command:
            done = subprocess.run([sys.executable, *arguments], capture_output=True, text=True)
            status, stderr = done.returncode, done.stderr
        else:
            monkeypatch.setattr(sys, "argv", arguments)
            with pytest.raises(SystemExit) as stop:
                runpy.run_path(arguments[0], run_name="__main__")
            status, stderr = stop.value.code, capsys.readouterr().err
        assert status == 2, (script, path, stderr)
        lines = stderr.strip().splitlines()
        assert len(lines) == 1 and str(path) in lines[0] and says in lines[0], (script, lines)
        assert not list((tmp_path / "fig").glob("*.png"))
