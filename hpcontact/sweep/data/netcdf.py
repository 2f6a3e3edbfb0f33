"""The sweep data set on disk (netCDF4) and back: compact, CF-checkable, read as it was built.

``write(ds, path)`` stores a labelled data set (``dataset.build_dataset``):

* every array with dimensions in chunks of at most ``CHUNK_BYTES`` that keep the trailing axes
  whole (``chunk_shape``), so a curve along the last axes is one chunk and
  ``xr.open_dataset(path, chunks={})`` gives dask chunks of 1–10 MB on large sweeps; compressed
  (zlib level ``COMPLEVEL`` after the shuffle filter) where it pays: counts and text always, a
  float array where a sample shrinks to at most 1 / ``MIN_ZLIB_RATIO`` (``_compresses``). Points
  that share a task hold equal values next to each other (a polygon's values repeat along b/a),
  which the compression stores nearly for free; an adaptive map's interpolated stiffnesses and
  errors do not repeat (1.1–1.3x on the 4-D map's 146 475 points), and compressing them was
  ~1 of rank 0's 2.3–2.7 CPU s writing that data set while every other rank waited (1.4–1.6
  without, the file 27.0 -> 32.9 MB; ``benchmarks/adaptive_scaling.py``'s data set, 2026-11-29,
  load ~1);
* counts (``COUNTS``: iterations, grid cells, polygon sides) as int32 with ``INT_FILL`` where
  a task has none; 64-bit integers as int32; coordinates without ``_FillValue``;
* text (labels, messages, ``plan``: the JSON of each point's plan, "" where a task has none)
  as char arrays, which the CF checkers, ``ncdump`` and plain ``xarray.open_dataset`` read as
  text; compressed in chunks like the numbers (a sweep's few distinct plans repeat: the
  demo's 900 plans of up to 350 characters, 315 kB as characters, take 3 kB);

* every variable with dimensions with a Fletcher-32 checksum per chunk (``fletcher32``; HDF5
  filters need chunked storage, which scalars cannot have): a damaged chunk fails its read
  loudly (``dataset.open_dataset`` names the variable) instead of giving wrong numbers;

to a temporary file in the same folder, synced (``fsync``), then renamed, and the folder synced,
so ``path`` is always either the old file or the complete new one. A failure to write (a full
disk, which the netCDF library reports as "NetCDF: HDF error") raises ``OSError`` naming
``path``, with ``ENOSPC`` when its file system has less free space than the data set's size or
``FULL_BYTES``; the temporary file is removed. ``read(path)`` opens it lazily with xarray: what
was stored comes back (counts as float64 with NaN where missing: xarray's decoding of an
integer with a fill value). Files written before ``plan`` was text hold int32 codes into the
JSON list of the distinct plans in the attribute ``plan_table``: ``read`` turns them into the
text again (one string object per distinct plan).
"""

from __future__ import annotations

import errno
import itertools
import json
import math
import os
import zlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hpcontact.sweep import faults
from hpcontact.sweep.data.journal import sync_folder

if TYPE_CHECKING:  # xarray and pandas are imported where a data set is written or read (rank 0)
    import xarray as xr

COUNTS = frozenset({"iterations", "nx", "ny", "contact_cells", "sides", "n", "n_across", "steps", "seed", "threads"})
INT_FILL = -2147483647  # NC_FILL_INT, netCDF's default fill of int32
CHUNK_BYTES = 4 * 2**20
# zlib's level: 1. Level 4 made the 4-D map's file (146 475 points, its 12 text variables 70 MB as
# characters) 1.4 % smaller for 1.27-1.38 against 1.00-1.25 CPU s of rank 0's write, the demo map's
# 0.8 % smaller for the same time (alternating, 4 each, 2026-11-29 14:26 UTC, load ~3); level 9
# made the demo's file of then 1.5 % smaller than level 4
COMPLEVEL = 1
# zlib only where it pays (``_compresses``): the interpolated stiffnesses and errors of a 4-D map
# (146 475 points) shrink 1.1-1.3x for ~0.045 CPU s each, the others 13-990x
MIN_ZLIB_RATIO = 2.0
ZLIB_SAMPLE_RUNS, ZLIB_SAMPLE_RUN = 8, 1024
PLAN = "plan"
PLAN_TABLE = "plan_table"  # files before plan was text: attribute of the stored codes, the distinct plans
TEXT_ATTRS = "text_attributes"  # files before plan was text: attribute of the stored codes, the text's attributes
VERIFY_BYTES = 64 * 2**20  # ``verify`` reads at most this much at a time
FULL_BYTES = 2**20  # a write that fails with less free space than this (or the data set's size) failed for want of it


def chunk_shape(shape: tuple[int, ...], itemsize: int, limit: int = CHUNK_BYTES) -> tuple[int, ...]:
    """Chunks of an array of ``shape``: the whole array, halved along the leading axes first
    until a chunk holds at most ``limit`` bytes (trailing axes stay whole: curves along them
    are read in one piece)."""
    chunks = [max(1, s) for s in shape]
    for axis in range(len(chunks)):
        while chunks[axis] > 1 and math.prod(chunks) * itemsize > limit:
            chunks[axis] = -(-chunks[axis] // 2)
    return tuple(chunks)


def write(ds: xr.Dataset, path: Path) -> Path:
    """Write the data set ``ds`` (``build_dataset``) to ``path`` as netCDF4 (see the module
    docstring), atomically; returns ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    stored = _encoded_texts(ds.assign_attrs({k: _attribute(v) for k, v in ds.attrs.items()}))
    encoding = {name: _encoding(stored, name) for name in stored.variables}
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        try:
            with faults.data_set_limit():
                stored.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
            _sync(tmp)
            os.replace(tmp, path)
        except RuntimeError as exc:  # the netCDF library's errors: "NetCDF: HDF error" on a full disk
            raise _write_error(str(exc), path, stored.nbytes) from exc
        except OSError as exc:  # named after the output, not the temporary file
            raise _write_error(exc.strerror or str(exc), path, stored.nbytes, exc.errno) from exc
        sync_folder(path.parent)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def _sync(path: Path) -> None:
    """Push the file ``path`` to the disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _write_error(message: str, path: Path, size: int, number: int | None = None) -> OSError:
    """The ``OSError`` of a failed write of ``path`` (module docstring)."""
    try:
        stats = os.statvfs(path.parent)
        free = stats.f_bavail * stats.f_frsize
    except OSError:
        free = None
    if number == errno.ENOSPC or (number is None and free is not None and free < max(size, FULL_BYTES)):
        shown = message if number == errno.ENOSPC else f"{os.strerror(errno.ENOSPC)} ({message})"
        return OSError(errno.ENOSPC, shown if free is None else f"{shown}; {free} bytes free", str(path))
    return OSError(number if number is not None else errno.EIO, message, str(path))


class DamagedFile(OSError):
    """A variable of a netCDF file cannot be read back: a chunk fails its checksum or does not
    decompress (``verify``). ``variable`` names it; ``filename`` is the file."""

    def __init__(self, path: str | Path, variable: str, reason: str) -> None:
        super().__init__(
            errno.EIO,
            f"variable {variable} is damaged ({reason}: a chunk fails its checksum or does not decompress)",
            str(path),
        )
        self.variable = variable

    def __str__(self) -> str:
        return f"{self.filename}: {self.strerror}"


def verify(path: str | Path) -> None:
    """Read every variable of the netCDF file ``path`` once, a few chunks at a time (at most
    ``VERIFY_BYTES``), so that each chunk's checksum is checked: ``DamagedFile`` naming the
    first variable that cannot be read. A file netCDF cannot open raises its ``OSError``."""
    import netCDF4

    with netCDF4.Dataset(path) as nc:
        for name, var in nc.variables.items():
            var.set_auto_maskandscale(False)
            var.set_auto_chartostring(False)
            chunking = var.chunking()
            chunks = var.shape if chunking == "contiguous" or chunking is None else tuple(chunking)
            try:
                for region in _regions(var.shape, chunks, getattr(var.dtype, "itemsize", 8)):
                    var[region]
            except (RuntimeError, OSError) as exc:
                raise DamagedFile(path, name, str(exc)) from None


def _regions(shape: tuple[int, ...], chunks: tuple[int, ...], itemsize: int) -> Any:
    """Index tuples that cover an array of ``shape`` stored in ``chunks``: whole chunks along the
    fewest leading axes that keep a region under ``VERIFY_BYTES``, the trailing axes whole."""
    lead = 0
    while lead < len(shape) and math.prod(chunks[:lead]) * math.prod(shape[lead:]) * itemsize > VERIFY_BYTES:
        lead += 1
    starts = [range(0, n, c) for n, c in zip(shape[:lead], chunks[:lead])]
    for corner in itertools.product(*starts):
        yield tuple(slice(s, s + c) for s, c in zip(corner, chunks[:lead])) + (slice(None),) * (len(shape) - lead)


def read(path: str | Path, **options: Any) -> xr.Dataset:
    """The data set ``write`` stored at ``path``, read lazily (``options`` go to
    ``xarray.open_dataset``, e.g. ``chunks={}`` for dask arrays); the plan codes of an older
    file as the JSON text of each point's plan (module docstring)."""
    import xarray as xr

    ds = xr.open_dataset(path, engine="netcdf4", **options)
    if PLAN not in ds.data_vars or PLAN_TABLE not in ds[PLAN].attrs:
        return ds
    codes = ds[PLAN]
    plans = json.loads(codes.attrs[PLAN_TABLE])
    table = np.empty(len(plans) + 1, dtype=object)
    table[:] = [*plans, ""]  # the last: no plan (NaN code)
    values = codes.values
    text = table[np.where(np.isnan(values), len(table) - 1, values).astype(np.intp)]
    return ds.assign({PLAN: xr.Variable(codes.dims, text, json.loads(codes.attrs[TEXT_ATTRS]))})


def _encoded_texts(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with its text arrays (not its dimensions) as the UTF-8 bytes xarray would write for
    them: each distinct text encoded once (a sweep's texts repeat: 11 text variables of 146 475
    points, 1.6 million ``str.encode`` calls in xarray's ``encode_string_array``), fixed width
    the longest's, ``_Encoding`` = "utf-8" as xarray sets it; the file is the same."""
    import pandas as pd

    texts = {}
    for name, var in ds.variables.items():
        if var.ndim and var.size and name not in ds.dims and (var.dtype == object or var.dtype.kind == "U"):
            codes, distinct = pd.factorize(np.ravel(var.values))
            if (codes < 0).any():  # a missing value (None, NaN): xarray's own encoding says what it does
                continue
            encoded = np.array([text.encode("utf-8") for text in distinct], dtype=bytes)
            texts[name] = var.copy(data=encoded[codes].reshape(var.shape))
            texts[name].attrs["_Encoding"] = "utf-8"
    return ds.assign(texts) if texts else ds


def _encoding(ds: xr.Dataset, name: str) -> dict[str, Any]:
    """How ``name`` is stored: dtype, fill value, compression and chunks (module docstring)."""
    import pandas as pd

    var = ds[name]
    dimension = name in ds.dims
    coordinate = name in ds.coords
    encoding: dict[str, Any] = {}
    if var.dtype.kind == "S" and "_Encoding" in var.attrs:  # text, encoded (``_encoded_texts``)
        # xarray reads trailing digits of the name as the length: name the length there
        width = var.dtype.itemsize
        encoding.update(dtype="S1", char_dim_name=f"{name}_strlen{max(width, 1)}")
    elif var.dtype == object or var.dtype.kind == "U":
        # xarray reads trailing digits of the name as the length: name the length there
        width = max((len(str(v).encode("utf-8")) for v in pd.unique(np.ravel(var.values))), default=0)
        encoding.update(dtype="S1", char_dim_name=f"{name}_strlen{max(width, 1)}")
    elif var.dtype.kind == "f" and name in COUNTS:
        encoding.update(dtype="int32", _FillValue=None if dimension else INT_FILL)
    elif var.dtype.kind in "iu":
        encoding.update(dtype="int32", _FillValue=None)
    elif var.dtype.kind == "f":
        missing = coordinate and bool(np.isnan(var.values).any()) and not dimension
        encoding.update(_FillValue=np.nan if missing or not coordinate else None)
    if var.ndim:
        encoding["fletcher32"] = True
    if var.ndim and var.size:
        if var.dtype.kind != "f" or "dtype" in encoding or _compresses(var.values):  # floats stored as floats: tried
            encoding.update(zlib=True, shuffle=True, complevel=COMPLEVEL)
        if "char_dim_name" in encoding:  # the characters: one more, trailing, dimension
            encoding["chunksizes"] = chunk_shape((*var.shape, max(width, 1)), 1)
        else:
            itemsize = 4 if encoding.get("dtype") == "int32" else var.dtype.itemsize
            encoding["chunksizes"] = chunk_shape(var.shape, itemsize)
    return encoding


def _compresses(values: np.ndarray) -> bool:
    """Whether zlib (after the shuffle filter, level ``COMPLEVEL``) stores the float array
    ``values`` in at most 1 / ``MIN_ZLIB_RATIO`` of its bytes, judged on a sample
    (``ZLIB_SAMPLE_RUNS`` runs of ``ZLIB_SAMPLE_RUN`` consecutive values, evenly spaced; the
    whole array when it is smaller) shuffled as HDF5's filter does (byte k of every value, then
    byte k + 1)."""
    flat = np.ascontiguousarray(values).reshape(-1)
    if flat.size > ZLIB_SAMPLE_RUNS * ZLIB_SAMPLE_RUN:
        starts = np.linspace(0, flat.size - ZLIB_SAMPLE_RUN, ZLIB_SAMPLE_RUNS).astype(np.intp)
        flat = np.concatenate([flat[s : s + ZLIB_SAMPLE_RUN] for s in starts.tolist()])
    raw = flat.view(np.uint8).reshape(flat.size, flat.itemsize)
    return raw.size >= MIN_ZLIB_RATIO * len(zlib.compress(raw.T.tobytes(), COMPLEVEL))


def _attribute(value: Any) -> Any:
    """A global attribute netCDF (and the CF checkers) can hold: text, a number (64-bit
    integers as int32 where they fit) or a numeric array."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, (int, np.integer)) and -(2**31) < value < 2**31:
        return np.int32(value)
    return value
