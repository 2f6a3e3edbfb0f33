"""Non-periodic FFT convolution (hpcontact.numerics.convolution) against the direct O(N²) sum.

The reference is the definition u_i[a] = Σ_j Σ_b K_ij[a − b] t_j[b], summed term by term over
every pair of cells (no FFT), with the centred offset layout of the kernel blocks (entry
[nx−1+p, ny−1+q] is offset (p, q)). Rounding: the FFT route has error ~ε·log₂(N)·max|K|·Σ|t|
(Gentleman & Sande 1966) against O(N) roundings of the direct sum: ≲ 1e-14 relative to the norm
of u on these grids; 1e-12 leaves two decades of margin.
"""

from __future__ import annotations

import multiprocessing
import pickle

import numpy as np
import pyfftw
import pytest

from hpcontact.kernels.isotropic import BLOCKS, isotropic_block
from hpcontact.materials.isotropic import Isotropic
from hpcontact.numerics import convolution as op_mod
from hpcontact.numerics.convolution import (
    ConvolutionOperator,
    cached_spectrum,
    clear_cache,
    kernel_spectrum,
    load_wisdom,
    padded_shape,
    save_wisdom,
    wisdom_path,
)

pytestmark = pytest.mark.filterwarnings("error")

REL = 1e-12  # see module docstring


def direct_sum(blocks: dict[str, np.ndarray], components: str, traction: np.ndarray) -> np.ndarray:
    """u_i[a] = Σ_j Σ_b K_ij[a − b] t_j[b], term by term over source cells b (no FFT)."""
    c, nx, ny = traction.shape
    u = np.zeros_like(traction)
    for i, ci in enumerate(components):
        for j, cj in enumerate(components):
            K = blocks.get(ci + cj)
            if K is None:
                continue
            for ib in range(nx):
                for jb in range(ny):
                    # K[a − b] for all targets a: rows nx−1−ib … 2nx−2−ib
                    u[i] += K[nx - 1 - ib : 2 * nx - 1 - ib, ny - 1 - jb : 2 * ny - 1 - jb] * traction[j, ib, jb]
    return u


def spectra_of(blocks, nx, ny):
    shape = padded_shape(nx, ny)
    return {name: kernel_spectrum(K, shape) for name, K in blocks.items()}


def _rel(a, b):
    return np.linalg.norm(a - b) / np.linalg.norm(b)


@pytest.mark.parametrize("nx, ny", [(1, 1), (1, 6), (7, 5), (8, 3), (12, 9)])
@pytest.mark.parametrize("components", ["z", "xy", "xyz"])
def test_apply_equals_direct_sum_random_kernels(nx, ny, components):
    """Arbitrary (non-symmetric) kernels: the convolution indexing alone is tested."""
    rng = np.random.default_rng(nx * 100 + ny)
    blocks = {a + b: rng.normal(size=(2 * nx - 1, 2 * ny - 1)) for a in components for b in components}
    if len(components) > 1:
        del blocks[components[0] + components[-1]]  # an absent block is zero
    t = rng.normal(size=(len(components), nx, ny))
    op = ConvolutionOperator(nx, ny, components, spectra_of(blocks, nx, ny), planner_effort="FFTW_ESTIMATE")
    u = op.apply(t)
    assert u.shape == t.shape
    assert _rel(u, direct_sum(blocks, components, t)) <= REL
    assert op.applications == 1


@pytest.mark.parametrize("nx, ny, dx, dy", [(7, 5, 0.3, 0.1), (6, 9, 1.0, 2.5), (5, 5, 1e-3, 1.0)])
@pytest.mark.parametrize("components", ["x", "xy", "xyz"])
def test_apply_equals_direct_sum_isotropic_blocks(nx, ny, dx, dy, components):
    m = Isotropic(G=1.7, nu=0.3)
    names = [a + b for a in components for b in components]
    blocks = {name: isotropic_block(m, nx, ny, dx, dy, name) for name in names}
    for K in blocks.values():
        assert K.shape == (2 * nx - 1, 2 * ny - 1)
    rng = np.random.default_rng(1)
    t = rng.normal(size=(len(components), nx, ny))
    op = ConvolutionOperator(nx, ny, components, spectra_of(blocks, nx, ny), planner_effort="FFTW_ESTIMATE")
    u = op.apply(t)
    assert _rel(u, direct_sum(blocks, components, t)) <= REL
    # applying twice gives the same (buffers are reused, nothing left over)
    np.testing.assert_array_equal(op.apply(t), u)


def test_no_periodic_wrap_around():
    """A unit traction in one corner: the opposite corner sees exactly the kernel at the largest offset."""
    nx, ny = 9, 6
    m = Isotropic(G=1.0, nu=0.25)
    K = isotropic_block(m, nx, ny, 0.2, 0.35, "xx")
    op = ConvolutionOperator(nx, ny, "x", spectra_of({"xx": K}, nx, ny), planner_effort="FFTW_ESTIMATE")
    t = np.zeros((1, nx, ny))
    t[0, 0, 0] = 1.0
    u = op.apply(t)[0]
    # u[a] = K[a − 0]: offsets (0..nx−1, 0..ny−1); the far corner is offset (nx−1, ny−1)
    np.testing.assert_allclose(u, K[nx - 1 :, ny - 1 :], rtol=1e-12, atol=1e-15 * K.max())
    assert u[-1, -1] == pytest.approx(K[-1, -1], rel=1e-12)
    t[0, 0, 0] = 0.0
    t[0, -1, -1] = 1.0
    u = op.apply(t)[0]
    np.testing.assert_allclose(u, K[:nx, :ny], rtol=1e-12, atol=1e-15 * K.max())
    assert u[0, 0] == pytest.approx(K[0, 0], rel=1e-12)
    # a periodic convolution on the unpadded grid would have added the near-field value
    # K[0 offset] ≈ 1 order of magnitude larger: the comparison above would fail by far.
    assert K[nx - 1, ny - 1] > 10 * K[0, 0]


def test_odd_kernel_sign_convention():
    """Block xz is odd in x: a pressure at the centre pulls the surface toward it (u_x < 0 at x > 0)."""
    nx, ny = 7, 7
    m = Isotropic(G=1.0, nu=0.3)
    blocks = {"xz": isotropic_block(m, nx, ny, 0.1, 0.1, "xz"), "zz": isotropic_block(m, nx, ny, 0.1, 0.1, "zz")}
    op = ConvolutionOperator(nx, ny, "xz", spectra_of(blocks, nx, ny), planner_effort="FFTW_ESTIMATE")
    t = np.zeros((2, nx, ny))
    t[1, 3, 3] = 1.0
    u = op.apply(t)
    assert np.all(u[0, 4:, 3] < 0) and np.all(u[0, :3, 3] > 0)
    assert abs(u[0, 3, 3]) <= 1e-15 * np.max(np.abs(u[0]))  # odd kernel: zero under the load
    assert np.all(u[1] > 0)


def _random_operator(seed: int, nx: int, ny: int, components: str, **kwargs) -> tuple[ConvolutionOperator, dict]:
    rng = np.random.default_rng(seed)
    blocks = {a + b: rng.normal(size=(2 * nx - 1, 2 * ny - 1)) for a in components for b in components}
    return ConvolutionOperator(nx, ny, components, spectra_of(blocks, nx, ny), **kwargs), blocks


def test_operators_of_one_layout_share_buffers_and_plans():
    """Two operators on one layout (a sweep's scenes on one grid) share one Transforms; applied
    in turn, each still equals its direct sum (REL, module docstring)."""
    nx, ny = 7, 5
    a, blocks_a = _random_operator(1, nx, ny, "xy")
    b, blocks_b = _random_operator(2, nx, ny, "xy")
    assert a.transforms is b.transforms
    t = np.random.default_rng(3).normal(size=(2, nx, ny))
    for op, blocks in ((a, blocks_a), (b, blocks_b), (a, blocks_a)):
        assert _rel(op.apply(t), direct_sum(blocks, "xy", t)) <= REL
    other, _ = _random_operator(4, nx, ny, "xy", planner_effort="FFTW_ESTIMATE")  # a fixed effort: its own plans
    assert other.transforms is not a.transforms
    layout = a.transforms
    del a, b, other, op
    _random_operator(5, nx + 1, ny, "xy")  # a new layout drops the buffers no operator uses
    assert layout not in op_mod._TRANSFORMS.values()
    again, _ = _random_operator(6, nx, ny, "xy")  # new buffers; the layout's count goes on
    assert again.transforms is not layout and again.transforms.usage is layout.usage
    assert layout.usage.applications >= 3


def test_auto_plans_are_measured_once_the_layout_ran_long_enough(monkeypatch):
    """The re-planning rule counts the applications of every operator of a layout together; the
    FFTW_MEASURE plans then serve all of them and results stay the direct sum (REL)."""
    pyfftw.forget_wisdom()
    clear_cache()
    nx, ny = 6, 5
    monkeypatch.setattr(op_mod, "MEASURE_AFTER_SECONDS", 1e9)  # never pays
    a, blocks_a = _random_operator(1, nx, ny, "xy")
    t = np.random.default_rng(3).normal(size=(2, nx, ny))
    for _ in range(50):
        a.apply(t)
    assert a.plan_effort == "FFTW_ESTIMATE"
    monkeypatch.setattr(op_mod, "MEASURE_AFTER_SECONDS", 0.0)
    monkeypatch.setattr(op_mod, "MEASURE_AFTER_APPLICATIONS", 53)
    b, blocks_b = _random_operator(2, nx, ny, "xy")
    planned = a.planning_time_s
    a.apply(t), b.apply(t)
    assert b.plan_effort == "FFTW_ESTIMATE"  # 52 applications
    assert _rel(b.apply(t), direct_sum(blocks_b, "xy", t)) <= REL  # the 53rd re-plans, after its transforms
    assert a.plan_effort == b.plan_effort == "FFTW_MEASURE"
    assert a.planning_time_s > planned
    assert _rel(a.apply(t), direct_sum(blocks_a, "xy", t)) <= REL
    assert _rel(b.apply(t), direct_sum(blocks_b, "xy", t)) <= REL


def test_expected_applications_plan_measured_at_the_first_application(monkeypatch):
    """A layout the process expects to apply often enough (expect_applications, as a sweep rank
    is told its share) is re-planned with FFTW_MEASURE at its first application; other layouts
    and an empty expectation keep the rule on applications made so far."""
    pyfftw.forget_wisdom()
    clear_cache()
    nx, ny = 7, 5
    t = np.random.default_rng(4).normal(size=(2, nx, ny))
    a, blocks_a = _random_operator(1, nx, ny, "xy")
    other, _ = _random_operator(2, nx + 2, ny, "xy")
    # the rule: n >= 35 and mean x (n - 35) >= MEASURE_AFTER_SECONDS; a 1 s pay-back needs ~1e6
    # applications of a ~10 µs operator, fewer than expected here
    monkeypatch.setattr(op_mod, "MEASURE_AFTER_SECONDS", 1.0)
    op_mod.expect_applications({(2, a.shape): 1e9})
    try:
        assert a.plan_effort == "FFTW_ESTIMATE"
        assert _rel(a.apply(t), direct_sum(blocks_a, "xy", t)) <= REL  # re-plans after its transforms
        assert a.plan_effort == "FFTW_MEASURE"
        other.apply(np.random.default_rng(5).normal(size=(2, nx + 2, ny)))
        assert other.plan_effort == "FFTW_ESTIMATE"  # not expected: the rule on 1 application
        assert _rel(a.apply(t), direct_sum(blocks_a, "xy", t)) <= REL
    finally:
        op_mod.expect_applications({})
    assert op_mod._EXPECTED == {}


def test_block_outside_components_is_refused():
    nx, ny = 3, 3
    with pytest.raises(ValueError):
        ConvolutionOperator(nx, ny, "xy", {"xz": np.zeros(padded_shape(nx, ny))}, planner_effort="FFTW_ESTIMATE")


def test_padded_shape():
    for nx, ny in [(1, 1), (7, 5), (64, 3), (100, 101)]:
        n1, n2 = padded_shape(nx, ny)
        assert n1 >= 2 * nx - 1 and n2 >= 2 * ny - 1
        # FFT-friendly: 2, 3, 5 smooth (scipy next_fast_len for real transforms)
        for n in (n1, n2):
            for p in (2, 3, 5):
                while n % p == 0:
                    n //= p
            assert n == 1


def test_kernel_spectrum_real_for_even_kernels():
    nx, ny = 6, 5
    m = Isotropic(G=1.0, nu=0.3)
    shape = padded_shape(nx, ny)
    for block in ("xx", "yy", "zz", "xy"):  # even in x and y, or odd in both (xy): real spectrum
        K = isotropic_block(m, nx, ny, 0.4, 0.15, block)
        s = kernel_spectrum(K, shape)
        assert s.dtype == np.float64 and s.shape == (shape[0], shape[1] // 2 + 1)
        # independent layout: offset (p, q) at index (p mod N1, q mod N2), full complex rfft2
        wrapped = np.zeros(shape)
        for p in range(-(nx - 1), nx):
            for q in range(-(ny - 1), ny):
                wrapped[p % shape[0], q % shape[1]] = K[nx - 1 + p, ny - 1 + q]
        full = np.fft.rfft2(wrapped)
        assert np.max(np.abs(full.imag)) <= 1e-13 * np.max(np.abs(full))
        np.testing.assert_allclose(s, full.real, rtol=0, atol=1e-14 * np.max(np.abs(full)))
    for block in ("xz", "zy"):  # odd in one axis only: imaginary spectrum, returned complex
        K = isotropic_block(m, nx, ny, 0.4, 0.15, block)
        s = kernel_spectrum(K, shape)
        assert np.iscomplexobj(s)
        assert np.max(np.abs(s.real)) <= 1e-13 * np.max(np.abs(s.imag))


def test_spectrum_cache_hit_returns_same_object():
    clear_cache()
    calls = []
    K = np.arange(15.0).reshape(3, 5)

    def build():
        calls.append(1)
        return K

    key = ("test-material", 2, 3, 0.1, 0.2, "xx")
    shape = padded_shape(2, 3)
    first = cached_spectrum(key, build, shape)
    second = cached_spectrum(key, build, shape)
    assert second is first
    assert len(calls) == 1
    assert not first.flags.writeable  # shared between operators: must be read-only
    other = cached_spectrum(key, build, (shape[0] * 2, shape[1]))  # another padded shape: new entry
    assert other is not first and len(calls) == 2
    clear_cache()
    third = cached_spectrum(key, build, shape)
    assert third is not first and len(calls) == 3
    np.testing.assert_array_equal(third, first)
    clear_cache()


def _entries(wisdom: bytes) -> set[bytes]:
    return {line.strip() for line in wisdom.splitlines()[1:-1]}


def test_wisdom_roundtrip(tmp_path, monkeypatch):
    path = tmp_path / "sub" / "wisdom"
    monkeypatch.setenv("HPCONTACT_WISDOM", str(path))
    assert wisdom_path() == path
    assert load_wisdom() is False  # none yet
    clear_cache()  # plans of earlier tests would serve without planning
    ConvolutionOperator(10, 6, "xy", {}, planner_effort="FFTW_MEASURE")  # creates some wisdom
    saved = pyfftw.export_wisdom()
    assert _entries(saved[0])  # something to round-trip (double precision is all the engine plans)
    save_wisdom()
    assert path.is_file()
    assert not list(path.parent.glob("*.tmp"))  # atomic: the temporary file is gone
    assert path.read_bytes() == saved[0]  # the raw text FFTW exports, nothing else
    pyfftw.forget_wisdom()
    assert pyfftw.export_wisdom() != saved
    assert load_wisdom() is True
    # FFTW may re-export the same entries in another order: compare the entries
    assert _entries(pyfftw.export_wisdom()[0]) == _entries(saved[0])


def test_save_wisdom_merges_with_the_file(tmp_path, monkeypatch):
    """Another process's (or rank's) saved plans survive this process's save: the file holds the
    union of both, as FFTW exports it."""
    monkeypatch.setenv("HPCONTACT_WISDOM", str(tmp_path / "wisdom"))
    pyfftw.forget_wisdom()
    clear_cache()  # plans of earlier tests would serve without planning
    ConvolutionOperator(10, 6, "xy", {}, planner_effort="FFTW_MEASURE")
    first = _entries(pyfftw.export_wisdom()[0])
    save_wisdom()  # "the other process"
    pyfftw.forget_wisdom()
    clear_cache()
    ConvolutionOperator(9, 4, "z", {}, planner_effort="FFTW_MEASURE")
    second = _entries(pyfftw.export_wisdom()[0])
    assert first - second and second - first  # each process has plans the other lacks
    save_wisdom()
    assert _entries((tmp_path / "wisdom").read_bytes()) == first | second
    assert not list(tmp_path.glob("*.tmp"))


def _plan_and_save(nx: int) -> None:
    pyfftw.forget_wisdom()
    clear_cache()
    ConvolutionOperator(nx, 5, "z", {}, planner_effort="FFTW_MEASURE")
    save_wisdom()


def test_concurrent_saves_keep_every_process_plans(tmp_path, monkeypatch):
    """Four processes save at once (the ranks of a sweep at its end): the lock serializes the
    read-merge-replace, so the file ends with every process's plans: a process that loads it
    plans every layout from wisdom."""
    monkeypatch.setenv("HPCONTACT_WISDOM", str(tmp_path / "wisdom"))
    sizes = (6, 7, 11, 13)
    context = multiprocessing.get_context("fork")
    workers = [context.Process(target=_plan_and_save, args=(nx,)) for nx in sizes]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    assert [w.exitcode for w in workers] == [0] * len(sizes)
    pyfftw.forget_wisdom()
    clear_cache()
    assert load_wisdom() is True
    for nx in sizes:  # "auto" plans at FFTW_MEASURE only if FFTW has wisdom for all four plans
        assert ConvolutionOperator(nx, 5, "z", {}).plan_effort == "FFTW_MEASURE", nx
    assert ConvolutionOperator(17, 5, "z", {}).plan_effort == "FFTW_ESTIMATE"  # no process planned it


def test_foreign_or_unreadable_wisdom_is_ignored_with_a_warning(tmp_path, monkeypatch):
    path = tmp_path / "wisdom"
    monkeypatch.setenv("HPCONTACT_WISDOM", str(path))
    ran = tmp_path / "ran"
    # a pickle that would run code if unpickled: it must be neither run nor accepted
    path.write_bytes(pickle.dumps(Exploit(str(ran))))
    for content in (None, b"(fftw-3.3.5 fftw_wisdom #x1 garbage", b""):
        if content is not None:
            path.write_bytes(content)
        with pytest.warns(RuntimeWarning, match="ignored"):
            assert load_wisdom() is False
    assert not ran.exists()
    path.unlink()
    path.mkdir()  # unreadable as a file
    with pytest.warns(RuntimeWarning, match="ignored"):
        assert load_wisdom() is False


class Exploit:
    """Unpickling this would create a file (what a hostile wisdom file could do)."""

    def __init__(self, target: str) -> None:
        self.target = target

    def __reduce__(self):
        return (open, (self.target, "w"))


def test_wisdom_path_default(monkeypatch):
    monkeypatch.delenv("HPCONTACT_WISDOM", raising=False)
    assert wisdom_path().name == "fftw_wisdom" and wisdom_path().suffix == ""
    assert "hpcontact" in wisdom_path().parts


def test_module_constants():
    assert op_mod.COMPONENT_INDEX == {"x": 0, "y": 1, "z": 2}
    assert set(BLOCKS) == {a + b for a in "xyz" for b in "xyz"}


def test_planner_effort_from_the_environment(monkeypatch):
    """``HPCONTACT_FFTW_PLANNER`` sets the effort of operators made without one (FFTW_ESTIMATE:
    the same plans in every process, for runs that must agree to rounding); a bad value is an
    InputError naming the variable and the allowed values."""
    from hpcontact.errors import InputError
    from hpcontact.numerics import convolution as op_mod

    monkeypatch.setenv(op_mod.PLANNER_ENV, "FFTW_ESTIMATE")
    kernel = np.zeros((2 * 16 - 1, 2 * 8 - 1))
    kernel[15, 7] = 1.0
    spectra = {"zz": op_mod.kernel_spectrum(kernel, op_mod.padded_shape(16, 8))}
    operator = op_mod.ConvolutionOperator(16, 8, "z", spectra)
    assert operator.plan_effort == "FFTW_ESTIMATE" and not operator.transforms.auto
    monkeypatch.setenv(op_mod.PLANNER_ENV, "fast")
    with pytest.raises(InputError, match="HPCONTACT_FFTW_PLANNER.*one of auto, FFTW_ESTIMATE"):
        op_mod.ConvolutionOperator(16, 8, "z", spectra)


def test_importing_the_operator_imports_no_dask_nor_scipy_fft():
    """pyfftw is imported without its dask and scipy interfaces (``_import_pyfftw_alone``): a
    fresh process importing the sweep driver has neither dask nor ``scipy.fft`` (a process that
    solves no grid never needs them); ``scipy.fft`` comes at the first padded grid (the same
    sizes), and ``import scipy.fftpack``, hidden while pyfftw imported, works afterwards."""
    import subprocess
    import sys

    code = (
        "import sys; import hpcontact.sweep.driver; from hpcontact.numerics.convolution import padded_shape; "
        "before = sorted(m for m in ('dask', 'scipy.fft', 'scipy.fftpack', 'scipy.special') if m in sys.modules); "
        "shape = padded_shape(9, 17); import scipy.fftpack; "
        "print(before, 'scipy.fft' in sys.modules, shape)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert " ".join(out) == "[] True (18, 36)"
