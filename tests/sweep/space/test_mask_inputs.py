"""Mask files as sweep inputs (issue 30): no silently wrong data, bounded memory, cheap checks.

* A mask replaced under the same path between a run and ``--resume`` is computed again, and
  said so: task keys hash the file's content (``tasks.task_key``), and mask paths in a spec are
  relative to the spec's folder.
* A mask file is checked by its header before anything is decoded (``geometry.mask_pixels``):
  a PNG or .npy over the grid limit, a file that is not what its suffix says, a pickle, a
  non-mask file like /etc/passwd: one line naming ``mask``, exit status 2, in ``hpcontact solve``
  and in a sweep's dry run; the memory plan counts a mask task at the image's pixels.
* Enumerating a spec validates each distinct scene once and computes each task's key once,
  prints progress on long enumerations, and refuses more than ``spec.MAX_POINTS`` points.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import pickle
import shutil
import signal
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from hpcontact import cli, geometry
from hpcontact import scene as scene_module
from hpcontact.errors import InputError
from hpcontact.geometry import MAX_GRID_CELLS, file_sha256, load_mask, mask_pixels
from hpcontact.problems import footprint
from hpcontact.scene import Scene, canonical_json
from hpcontact.sweep import driver
from hpcontact.sweep.cost import grids as cost_grids
from hpcontact.sweep.cost import task_cost
from hpcontact.sweep.run.dry_run import dry_run
from hpcontact.sweep.run.records import Options
from hpcontact.sweep.run.rounds import execute
from hpcontact.sweep.run.schedule import SerialTeam, launched_by_mpi
from hpcontact.sweep.space import enumeration
from hpcontact.sweep.space.axes import MAX_POINTS
from hpcontact.sweep.space.parse import load_spec, parse_spec
from hpcontact.sweep.work import tasks as tasks_module
from hpcontact.sweep.work.tasks import enumerate_tasks, task_key

ROOT = Path(__file__).resolve().parents[3]
MPIEXEC = shutil.which("mpiexec", path=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")
#: The issue's bound on the peak resident memory of a refusal (the CLI's imports take ~90 MB).
PEAK_BYTES = 500 * 10**6
#: Stiffnesses of two processes agree to this fraction of the largest one: FFTW_MEASURE may plan
#: different algorithms in different processes, and the rounding differences stay below ~5e-13
#: relative at tol = 1e-12 (tests/mpi/conftest.py, ``_assert_same_results``).
SAME_RTOL = 1e-12
STIFFNESSES = ("K_xx", "K_xy", "K_yx", "K_yy", "K_zz")

SPEC = """
[sweep]
title = "mask resume"
output = "{output}"
[scene]
shape = "mask"
mask = "contact.npy"
quantities = ["tangential", "normal"]
[numerics]
tol = 1e-12
[axes]
nu = [0.2, 0.4]
"""


# ------------------------------------------------------------------------------------------
# files
# ------------------------------------------------------------------------------------------
def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def write_black_png(path: Path, width: int, height: int, rows_per_block: int = 1000) -> Path:
    """A valid 1-bit grayscale PNG of width × height black pixels (all contact), written without
    holding its pixels: its zlib stream repeats one raw-deflate block of ``rows_per_block`` zero
    rows, each ended by a full flush (which resets the compressor, so the blocks are
    byte-identical). 50 000² pixels: ~300 kB, as in the issue."""
    row = bytes(1 + (width + 7) // 8)  # filter byte 0, then the packed pixels
    blocks, rest = divmod(height, rows_per_block)
    deflate = zlib.compressobj(9, zlib.DEFLATED, -15)
    block = row * rows_per_block
    piece = deflate.compress(block) + deflate.flush(zlib.Z_FULL_FLUSH) if blocks else b""
    tail = deflate.compress(row * rest) + deflate.flush(zlib.Z_FINISH)
    adler = 1
    for _ in range(blocks):
        adler = zlib.adler32(block, adler)
    adler = zlib.adler32(row * rest, adler)
    stream = b"\x78\xda" + piece * blocks + tail + struct.pack(">I", adler)
    header = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)
    path.write_bytes(geometry.PNG_SIGNATURE + _chunk(b"IHDR", header) + _chunk(b"IDAT", stream) + _chunk(b"IEND", b""))
    return path


def write_npy_header(path: Path, shape: tuple[int, ...], descr: str = "|b1", complete: bool = True) -> Path:
    """A .npy of ``shape`` whose data is a hole (a sparse file: no disk, no time), or absent."""
    with open(path, "wb") as f:
        np.lib.format.write_array_header_1_0(f, {"descr": descr, "fortran_order": False, "shape": shape})
        if complete:
            f.truncate(f.tell() + int(np.prod(shape)) * np.dtype(descr).itemsize)
    return path


@pytest.fixture(scope="module")
def huge(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The issue's files: a 50 000² px PNG of ~300 kB and a complete 20 000² .npy."""
    folder = tmp_path_factory.mktemp("huge")
    return {
        "png": write_black_png(folder / "huge.png", 50_000, 50_000),
        "npy": write_npy_header(folder / "huge.npy", (20_000, 20_000)),
    }


def one_line(exc: BaseException | str) -> str:
    text = str(exc).strip()
    assert "\n" not in text, text
    return text


# ------------------------------------------------------------------------------------------
# 1. a mask replaced under its path: recomputed on --resume, and said so
# ------------------------------------------------------------------------------------------
def _masks() -> tuple[np.ndarray, np.ndarray]:
    """Two masks of one array shape (the same .npy size): a 6 × 4 rectangle and an L."""
    a = np.zeros((8, 6), dtype=bool)
    a[1:7, 1:5] = True
    b = np.zeros((8, 6), dtype=bool)
    b[1:7, 1] = True
    b[1, 1:5] = True
    return a, b


def _replace(path: Path, mask: np.ndarray) -> None:
    """Write ``mask`` over ``path``, its modification time moved on: a new ``hpcontact run``
    starts with empty caches; this process keeps them, keyed by mtime_ns, which a coarse file
    system need not change within a second."""
    before = path.stat().st_mtime_ns
    np.save(path, mask)
    os.utime(path, ns=(before, before + 2 * 10**9))


def _stiffness(path: Path) -> np.ndarray:
    with xr.open_dataset(path) as ds:
        assert (ds["status"].values == 0).all(), ds["message"].values
        return np.stack([ds[name].values for name in STIFFNESSES])


def test_a_mask_replaced_between_run_and_resume_is_recomputed_and_said_so(tmp_path, monkeypatch):
    job, elsewhere = tmp_path / "job", tmp_path / "elsewhere"
    job.mkdir()
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)  # the mask is found beside the spec, not in the working directory
    old, new = _masks()
    np.save(job / "contact.npy", old)
    spec = job / "spec.toml"
    spec.write_text(SPEC.format(output=tmp_path / "out.nc"))

    k_old = _stiffness(execute(spec, team=SerialTeam(), stream=io.StringIO()).path)
    _replace(job / "contact.npy", new)
    log = io.StringIO()
    resumed = execute(spec, team=SerialTeam(), stream=log, options=Options(resume=True)).path
    text = log.getvalue()
    assert (
        f"2 task(s) recomputed: their input file changed since the journals' run (mask {job / 'contact.npy'})" in text
    )
    assert "2 tasks, 2 to run" in text

    fresh_spec = job / "fresh.toml"
    fresh_spec.write_text(SPEC.format(output=tmp_path / "fresh.nc"))
    fresh = execute(fresh_spec, team=SerialTeam(), stream=io.StringIO()).path
    k_resumed, k_fresh = _stiffness(resumed), _stiffness(fresh)
    scale = np.abs(k_fresh).max()
    assert np.abs(k_resumed - k_fresh).max() <= SAME_RTOL * scale
    assert np.abs(k_old - k_fresh).max() > 0.1 * scale  # the two masks differ: the test can fail

    log = io.StringIO()  # resumed again: the new content's results are reused, nothing is said
    execute(spec, team=SerialTeam(), stream=log, options=Options(resume=True))
    assert "2 tasks, 0 to run (2 from journals)" in log.getvalue() and "recomputed" not in log.getvalue()


def test_task_keys_hash_the_mask_content_and_read_it_once(tmp_path, monkeypatch):
    mask = tmp_path / "m.npy"
    old, new = _masks()
    np.save(mask, old)
    params = {"mask": str(mask), "nu": 0.3, "shape": "mask"}
    plain = {"n": 16, "nu": 0.3}  # a scene without files keeps its key (and earlier journals)
    assert task_key(plain) == hashlib.sha1(canonical_json(plain).encode()).hexdigest()

    reads = []
    digest = hashlib.file_digest
    monkeypatch.setattr(geometry.hashlib, "file_digest", lambda f, name: reads.append(f.name) or digest(f, name))
    geometry._sha256.cache_clear()
    spec = parse_spec(f'[scene]\nshape = "mask"\nmask = "{mask}"\n[axes]\nnu = {{ linspace = [0, 0.5, 40] }}\n')
    tasks, _ = enumerate_tasks(spec)
    assert len(tasks) == 40 and len(reads) == 1  # one read for the 40 tasks

    before = task_key(params)
    _replace(mask, new)
    after = task_key(params)
    assert after != before and len(reads) == 2
    _replace(mask, old)
    assert task_key(params) == before  # the same content: the same key, earlier results reusable
    assert file_sha256(mask) == hashlib.sha256(mask.read_bytes()).hexdigest()


def test_mask_paths_are_relative_to_the_spec_folder(tmp_path, monkeypatch):
    job, elsewhere = tmp_path / "job", tmp_path / "elsewhere"
    (job / "masks").mkdir(parents=True)
    elsewhere.mkdir()
    old, _ = _masks()
    np.save(job / "masks" / "a.npy", old)
    absolute = tmp_path / "b.npy"
    np.save(absolute, old)
    spec = job / "spec.toml"
    spec.write_text(
        f'[sweep]\noutput = "{tmp_path / "o.nc"}"\n[numerics]\nn = 8\n[scene]\nmask = "masks/a.npy"\nshape = "mask"\n'
        f'[axes]\nshape = ["mask", {{ label = "b", shape = "mask", mask = "{absolute}" }}]\n'.replace(
            'shape = "mask"\n[axes]', "[axes]"
        )
    )
    monkeypatch.chdir(elsewhere)
    loaded = load_spec(spec)  # validated: the relative mask was found beside the spec
    assert loaded.fixed["mask"] == str(job / "masks" / "a.npy")
    assert loaded.axis("shape").fields[1]["mask"] == str(absolute)  # an absolute path stays as is
    tasks, _ = enumerate_tasks(loaded)
    assert sorted(t.params["mask"] for t in tasks) == sorted([str(job / "masks" / "a.npy"), str(absolute)])


# ------------------------------------------------------------------------------------------
# 2. headers before decoding
# ------------------------------------------------------------------------------------------
def _bad_files(folder: Path) -> dict[str, tuple[Path, str]]:
    """Files refused by their header, and a word of each refusal."""
    files = {
        "png over the limit (12 000², 17 kB-like: header only)": (
            write_black_png(folder / "a.png", 12_000, 12_000),
            "2**26",
        ),
        "npy over the limit": (write_npy_header(folder / "b.npy", (9000, 8000), "<f8", complete=False), "2**26"),
        "text named .png": (folder / "c.png", "PNG signature"),
        "random bytes .npy": (folder / "d.npy", "numpy.save"),
        "pickle named .npy": (folder / "e.npy", "numpy.save"),
        "object array": (folder / "f.npy", "objects"),
        "3-D array": (folder / "g.npy", "2-D"),
        "strings": (folder / "h.npy", "numeric"),
        "empty": (write_npy_header(folder / "i.npy", (0, 5)), "non-empty"),
        "truncated npy": (write_npy_header(folder / "j.npy", (100, 100), "<f8", complete=False), "truncated"),
        "no suffix": (folder / "passwd", ".npy or .png"),
        "missing": (folder / "missing.npy", "existing"),
    }
    (folder / "c.png").write_text("root:x:0:0:root:/root:/bin/bash\n")
    (folder / "d.npy").write_bytes(np.random.default_rng(0).bytes(1000))
    (folder / "e.npy").write_bytes(pickle.dumps({"a": 1}))
    np.save(folder / "f.npy", np.array([[{"a": 1}, None]], dtype=object), allow_pickle=True)
    np.save(folder / "g.npy", np.ones((2, 2, 2)))
    np.save(folder / "h.npy", np.array([["a", "b"]]))
    (folder / "passwd").write_text("root:x:0:0:root:/root:/bin/bash\n")
    return files


def test_bad_mask_files_are_refused_by_their_header_in_one_line(tmp_path):
    for what, (path, word) in _bad_files(tmp_path).items():
        for check in (mask_pixels, load_mask, lambda p: Scene.from_params({"shape": "mask", "mask": str(p)})):
            with pytest.raises(InputError) as info:
                check(path)
            assert info.value.field == "mask", what
            assert word in one_line(info.value), (what, str(info.value))
            if word == "2**26":
                assert f"({path.stat().st_size} bytes)" in str(info.value) and str(MAX_GRID_CELLS) in str(info.value)


def test_a_png_whose_body_does_not_decode_is_one_line(tmp_path):
    path = tmp_path / "cut.png"
    whole = write_black_png(tmp_path / "whole.png", 40, 30).read_bytes()
    path.write_bytes(whole[: len(whole) - 30])  # IHDR intact, IDAT cut short
    assert mask_pixels(path) == (40, 30)  # the header is fine
    with pytest.raises(InputError) as info:
        load_mask(path)
    assert info.value.field == "mask" and "decodes" in one_line(info.value)
    assert load_mask(tmp_path / "whole.png").shape == (40, 30)  # the writer makes valid PNGs


@pytest.mark.skipif(sys.platform == "win32", reason="resource.getrusage")
@pytest.mark.parametrize("kind", ["png", "npy"])
def test_huge_masks_exit_2_before_decoding(huge, kind, tmp_path):
    """The issue's 300 kB PNG of 50 000² px (4.9 GB before) and 20 000² .npy (3.6 GB): exit 2,
    one line naming the limit, peak memory of the command ≤ 500 MB (measured in a fresh parent,
    so RUSAGE_CHILDREN sees this child alone)."""
    measure = (
        "import json, resource, subprocess, sys, time; t = time.perf_counter(); "
        "r = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
        "print(json.dumps({'rc': r.returncode, 'stderr': r.stderr, 'seconds': time.perf_counter() - t, "
        "'peak_kib': resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}))"
    )
    command = [sys.executable, "-m", "hpcontact.cli", "solve", "--shape", "mask", "--mask", str(huge[kind])]
    done = subprocess.run(
        [sys.executable, "-c", measure, *command],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )
    result = json.loads(done.stdout)
    assert result["rc"] == 2, result
    line = one_line(result["stderr"])
    assert line.startswith("hpcontact: error: mask = ") and "2**26" in line and "bytes" in line, line
    assert result["peak_kib"] * 1024 <= PEAK_BYTES, result


def test_bad_masks_stop_a_dry_run_and_hpcontact_solve_with_exit_2(huge, tmp_path, capsys):
    files = {
        "passwd": "/etc/passwd" if Path("/etc/passwd").is_file() else str(tmp_path / "passwd"),
        "png": str(huge["png"]),
        "npy": str(huge["npy"]),
    }
    (tmp_path / "passwd").write_text("root:x:0:0\n")
    for what, mask in files.items():
        spec = tmp_path / f"{what}.toml"
        spec.write_text(
            f'[sweep]\noutput = "{tmp_path / "o.nc"}"\n[scene]\nshape = "mask"\nmask = "{mask}"\n'
            f"[axes]\nnu = [0.2, 0.3]\n"
        )
        assert driver.main([str(spec), "--dry-run"]) == 2
        err = one_line(capsys.readouterr().err)
        assert err.startswith(f"hpcontact run: error: scene.mask = '{mask}"), err
        assert cli.main(["solve", "--shape", "mask", "--mask", mask]) == 2
        err = one_line(capsys.readouterr().err)
        assert err.startswith(f"hpcontact: error: mask = '{mask}"), err


def test_the_memory_plan_counts_a_mask_at_its_pixels(tmp_path):
    mask = write_npy_header(tmp_path / "wide.npy", (8000, 6000))
    params = {"shape": "mask", "mask": str(mask), "nu": 0.3}
    assert footprint.contact_grid(params) == (8000, 6000)  # was n x n = 128 x 128
    assert footprint.padded_cells(params) == 4 * 8000 * 6000
    # a refined grid of the accuracy study (n, n_across given) larger than the image stays as given
    assert footprint.contact_grid({**params, "n": 16000, "n_across": 12000}) == (16000, 12000)
    spec = tmp_path / "spec.toml"
    spec.write_text(
        f'[sweep]\noutput = "{tmp_path / "o.nc"}"\n[scene]\nshape = "mask"\nmask = "wide.npy"\n'
        f"[axes]\nnu = [0.2, 0.3]\n"
    )
    with pytest.raises(InputError) as info:  # refused before any rank decodes the mask
        execute(spec, team=SerialTeam(), stream=io.StringIO(), options=Options(mem_per_rank=(4 * 2**30, "test")))
    assert info.value.field == "--mem-per-rank"


# ------------------------------------------------------------------------------------------
# 3. enumeration: each distinct scene validated once, each key made once, progress, a limit
# ------------------------------------------------------------------------------------------
def test_a_dry_run_validates_each_distinct_scene_once(write_spec, monkeypatch, capsys):
    """1000 points, 500 distinct scenes (a circle ignores b/a), no n (the default, whose grids
    needed a second Scene per scene before): 500 validations, 500 keys, and two more Scenes for
    the one outline: whether it takes its exact cell, and that cell's plan."""
    built, keys = [], []
    from_params = Scene.from_params.__func__
    monkeypatch.setattr(Scene, "from_params", classmethod(lambda cls, p: built.append(1) or from_params(cls, p)))
    key = tasks_module.task_key
    monkeypatch.setattr(tasks_module, "task_key", lambda p, text=None: keys.append(1) or key(p, text))
    monkeypatch.setattr(enumeration, "PROGRESS_POINTS", 200)
    cost_grids._default_grids.cache_clear()
    cost_grids._requested_by_default.cache_clear()
    cost_grids._accuracy_plan.cache_clear()
    task_cost._cached_contact_cost.cache_clear()
    scene_module._scene_of_key.cache_clear()  # Scene.from_key's cache: an earlier test may hold the outline's scene
    path = write_spec('[scene]\nshape = "circle"\n[axes]\naspect = [0.5, 1.0]\nnu = { linspace = [0, 0.5, 500] }\n')
    assert dry_run(path, stream=io.StringIO()) == 0
    assert len(keys) == 500
    assert len(built) == 500 + 2
    progress = [line for line in capsys.readouterr().err.splitlines() if "points checked" in line]
    assert [line.split()[1] for line in progress] == ["200", "400", "600", "800"]


def test_specs_over_the_point_limit_are_refused_before_enumerating(write_spec):
    with pytest.raises(InputError) as info:  # refused before numpy allocates the axis
        load_spec(write_spec(f"[numerics]\nn = 8\n[axes]\nnu = {{ linspace = [0, 0.5, {MAX_POINTS + 1}] }}\n"))
    assert info.value.field == "axes.nu.linspace" and str(MAX_POINTS) in one_line(info.value)
    with pytest.raises(InputError) as info:  # 4000 x 4000 points: each axis is fine, the product is not
        load_spec(
            write_spec(
                "[numerics]\nn = 8\n[axes]\nnu = { linspace = [0, 0.5, 4000] }\n"
                "aspect = { linspace = [0.1, 1, 4000] }\n"
            )
        )
    assert info.value.field == "axes" and "4000 x 4000 = 16000000" in one_line(info.value)


# ------------------------------------------------------------------------------------------
# the same with two ranks
# ------------------------------------------------------------------------------------------
@pytest.mark.skipif(launched_by_mpi(), reason="starts its own mpiexec; run pytest without a launcher")
@pytest.mark.skipif(MPIEXEC is None, reason="no mpiexec")
def test_two_ranks_recompute_a_replaced_mask_on_resume(tmp_path):
    """Every rank hashes the masks of its share of the points: the resumed 2-rank data set
    equals a fresh serial run on the new file."""
    old, new = _masks()
    np.save(tmp_path / "contact.npy", old)
    spec = tmp_path / "spec.toml"
    spec.write_text(SPEC.format(output=tmp_path / "out.nc").replace("nu = [0.2, 0.4]", "nu = [0.1, 0.2, 0.3, 0.4]"))
    env = {k: v for k, v in os.environ.items() if k != "HPCONTACT_MPI"}
    env.update(
        PYTHONPATH=f"{ROOT}{os.pathsep}{env.get('PYTHONPATH', '')}", OMP_NUM_THREADS="1", HPCONTACT_GIT_REVISION="test"
    )

    def run(*extra: str) -> str:
        proc = subprocess.Popen(
            [MPIEXEC, "-n", "2", sys.executable, "-m", "hpcontact.sweep", str(spec), *extra],
            env=env,
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,
        )
        try:
            out = proc.communicate(timeout=300)[0]
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.communicate()
        assert proc.returncode == 0, out
        return out

    run()
    _replace(tmp_path / "contact.npy", new)
    out = run("--resume")
    assert "4 task(s) recomputed: their input file changed" in out and "4 tasks, 4 to run" in out
    fresh = execute(spec, output=tmp_path / "fresh.nc", team=SerialTeam(), stream=io.StringIO()).path
    k_resumed, k_fresh = _stiffness(tmp_path / "out.nc"), _stiffness(fresh)
    assert np.abs(k_resumed - k_fresh).max() <= SAME_RTOL * np.abs(k_fresh).max()
