"""The sweep data set on disk (netCDF4) and back: compact, CF-checkable, read as it was built.

``write(ds, path)`` stores a labelled data set (``dataset.build_dataset``):

* every array with dimensions compressed (zlib level ``COMPLEVEL`` after the shuffle filter)
  in chunks of at most ``CHUNK_BYTES`` that keep the trailing axes whole (``chunk_shape``), so
  a curve along the last axes is one chunk and ``xr.open_dataset(path, chunks={})`` gives dask
  chunks of 1–10 MB on large sweeps. Points that share a task hold equal values next to each
  other (a polygon's values repeat along b/a), which the compression stores nearly for free;
* counts (``COUNTS``: iterations, grid cells, polygon sides) as int32 with ``INT_FILL`` where
  a task has none; 64-bit integers as int32; coordinates without ``_FillValue``;
* text (labels, messages) as char arrays, which the CF checkers read;
* ``plan`` once per distinct plan: int32 codes per point (``INT_FILL`` where a task has no
  plan) into the JSON list of the distinct plans in the variable's attribute ``plan_table``;

to a temporary file in the same folder, then renamed, so ``path`` is always either the old
file or the complete new one. ``read(path)`` opens it lazily with xarray and undoes the one
step xarray does not: the plan codes become the JSON text again (one string object per
distinct plan, shared by the points). Counts come back as float64 with NaN where missing
(xarray's decoding of an integer with a fill value).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

COUNTS = frozenset({"iterations", "nx", "ny", "contact_cells", "sides", "n", "n_across", "steps", "seed", "threads"})
INT_FILL = -2147483647  # NC_FILL_INT, netCDF's default fill of int32
CHUNK_BYTES = 4 * 2**20
COMPLEVEL = 4  # zlib: level 9 made the demo's file 1.5 % smaller (263 against 267 kB), level 1 0.5 % larger
PLAN = "plan"
PLAN_TABLE = "plan_table"  # attribute of the stored codes: the distinct plans
TEXT_ATTRS = "text_attributes"  # attribute of the stored codes: the attributes of the text


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
    stored = _with_plan_codes(ds)
    stored = stored.assign_attrs({k: _attribute(v) for k, v in stored.attrs.items()})
    encoding = {name: _encoding(stored, name) for name in stored.variables}
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        stored.to_netcdf(tmp, engine="netcdf4", format="NETCDF4", encoding=encoding)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def read(path: str | Path, **options: Any) -> xr.Dataset:
    """The data set ``write`` stored at ``path``, read lazily (``options`` go to
    ``xarray.open_dataset``, e.g. ``chunks={}`` for dask arrays), with ``plan`` the JSON text
    of each point's plan again."""
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


def _with_plan_codes(ds: xr.Dataset) -> xr.Dataset:
    """``ds`` with its ``plan`` text replaced by codes (float64, NaN for no plan; stored as
    int32) into the JSON list of the distinct plans in its attribute ``plan_table``."""
    if PLAN not in ds.data_vars or ds[PLAN].dtype != object:
        return ds
    text = ds[PLAN].values
    flat = text.ravel()
    present = flat != ""
    found, distinct = pd.factorize(flat[present])  # codes in first-appearance order
    codes = np.full(flat.shape, np.nan)
    codes[present] = found
    attrs = {
        "long_name": f"plan of the task: position in the JSON list {PLAN_TABLE} of the distinct plans",
        "units": "1",
        PLAN_TABLE: json.dumps(list(distinct)),
        TEXT_ATTRS: json.dumps(ds[PLAN].attrs),
    }
    return ds.assign({PLAN: xr.Variable(ds[PLAN].dims, codes.reshape(text.shape), attrs)})


def _encoding(ds: xr.Dataset, name: str) -> dict[str, Any]:
    """How ``name`` is stored: dtype, fill value, compression and chunks (module docstring)."""
    var = ds[name]
    dimension = name in ds.dims
    coordinate = name in ds.coords
    encoding: dict[str, Any] = {}
    if var.dtype == object or var.dtype.kind == "U":
        # xarray reads trailing digits of the name as the length: name the length there
        width = max((len(str(v).encode("utf-8")) for v in pd.unique(np.ravel(var.values))), default=0)
        encoding.update(dtype="S1", char_dim_name=f"{name}_strlen{max(width, 1)}")
    elif (var.dtype.kind == "f" and name in COUNTS) or name == PLAN:
        encoding.update(dtype="int32", _FillValue=None if dimension else INT_FILL)
    elif var.dtype.kind in "iu":
        encoding.update(dtype="int32", _FillValue=None)
    elif var.dtype.kind == "f":
        missing = coordinate and bool(np.isnan(var.values).any()) and not dimension
        encoding.update(_FillValue=np.nan if missing or not coordinate else None)
    if var.ndim and var.size:
        encoding.update(zlib=True, shuffle=True, complevel=COMPLEVEL)
        if "char_dim_name" not in encoding:
            itemsize = 4 if encoding.get("dtype") == "int32" else var.dtype.itemsize
            encoding["chunksizes"] = chunk_shape(var.shape, itemsize)
    return encoding


def _attribute(value: Any) -> Any:
    """A global attribute netCDF (and the CF checkers) can hold: text, a number (64-bit
    integers as int32 where they fit) or a numeric array."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, (int, np.integer)) and -(2**31) < value < 2**31:
        return np.int32(value)
    return value
