"""The sweep data set on disk (hpcontact.sweep.data.netcdf): chunks, the stored types, a write that is
atomic and names its output when it fails, checksums that catch a damaged chunk, and the plan
codes of older files read back as text. What was stored is inspected with netCDF4 and h5py."""

from __future__ import annotations

import errno
import json
import math
import os
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

from hpcontact.sweep.data import netcdf
from hpcontact.sweep.data.netcdf import CHUNK_BYTES, INT_FILL, DamagedFile, chunk_shape, read, verify, write


@pytest.mark.parametrize(
    ("shape", "itemsize", "expected"),
    [
        ((3, 4), 8, (3, 4)),  # small: one chunk
        ((1000, 1000), 8, (500, 1000)),  # 8 MB: the leading axis halved once (4 000 000 B <= 4 MiB)
        ((64, 3, 10_000), 8, (16, 3, 10_000)),  # 15.4 MB: the first axis only (64 -> 32 -> 16: 3.8 MB)
        ((9, 7, 100_000), 8, (1, 4, 100_000)),  # the first axis down to 1 (5.6 MB), then the second
        ((1, 10**7), 8, (1, 312_500)),  # the last axis halved only when the leading ones are 1
        ((0, 5), 8, (1, 5)),  # an empty axis: chunks of at least 1
    ],
)
def test_chunks_halve_the_leading_axes_first_until_they_fit(shape, itemsize, expected):
    chunks = chunk_shape(shape, itemsize)
    assert chunks == expected and math.prod(chunks) * itemsize <= CHUNK_BYTES


def _data_set() -> xr.Dataset:
    aspect = np.array([1.0, 0.5, 0.25])
    nu = np.array([0.0, 0.5])
    K = np.arange(6.0).reshape(3, 2) / 7.0
    K[1, 1] = np.nan
    iterations = np.array([[3.0, 4.0], [5.0, np.nan], [7.0, 8.0]])
    plans = np.array([['{"solves": 2}', ""], ['{"solves": 2}', '{"solves": 1}'], ["", ""]], dtype=object)
    return xr.Dataset(
        {
            "K_xx": (("aspect", "nu"), K, {"long_name": "stiffness", "units": "1"}),
            "iterations": (("aspect", "nu"), iterations),
            "status": (("aspect", "nu"), np.zeros((3, 2), dtype=np.int64)),
            "plan": (("aspect", "nu"), plans),
            "radius": ((), 1.5),
        },
        coords={"aspect": aspect, "nu": nu},
        attrs={"title": "t", "resumed": True, "tasks": 6, "big": 2**40},
    )


def test_a_written_data_set_reads_back_as_it_was_built(tmp_path):
    ds = _data_set()
    path = write(ds, tmp_path / "sub" / "out.nc")
    assert path == tmp_path / "sub" / "out.nc" and os.listdir(path.parent) == ["out.nc"]  # no temporary left
    with read(path) as back:
        back = back.load()
    for name in ("K_xx", "iterations", "radius", "aspect", "nu"):
        np.testing.assert_array_equal(back[name].values, ds[name].values, err_msg=name)  # NaN where NaN
    assert back["status"].values.tolist() == [[0, 0]] * 3
    assert back["plan"].values.tolist() == ds["plan"].values.tolist()
    assert back["K_xx"].attrs["long_name"] == "stiffness"
    assert back.attrs["resumed"] == "true" and back.attrs["tasks"] == 6 and back.attrs["big"] == 2**40


def test_counts_are_int32_with_a_fill_numbers_compressed_and_checksummed(tmp_path):
    path = write(_data_set(), tmp_path / "out.nc")
    with netCDF4.Dataset(path) as nc:
        iterations = nc["iterations"]
        assert iterations.dtype == np.int32 and iterations.getncattr("_FillValue") == INT_FILL
        iterations.set_auto_maskandscale(False)
        assert iterations[1, 1] == INT_FILL
        assert nc["status"].dtype == np.int32 and "_FillValue" not in nc["status"].ncattrs()
        assert "_FillValue" not in nc["aspect"].ncattrs()  # a coordinate without a fill
        assert nc["plan"].dtype == np.dtype("S1")  # text as characters
        for name in ("iterations", "plan"):  # counts and text: always compressed
            filters = nc[name].filters()
            assert filters["zlib"] and filters["shuffle"] and filters["fletcher32"], name
            assert filters["complevel"] == netcdf.COMPLEVEL
        # a float stored as float: compressed where zlib pays (test_zlib_only_where_it_pays), checksummed always
        assert nc["K_xx"].filters()["zlib"] == netcdf._compresses(_data_set()["K_xx"].values)
        assert nc["K_xx"].filters()["fletcher32"]
        assert nc["radius"].chunking() == "contiguous"  # a scalar cannot be chunked
        assert type(nc.getncattr("tasks")) in (int, np.int32)


def _shuffled_ratio(values: np.ndarray) -> float:
    """The whole array's bytes over its zlib size after HDF5's shuffle (byte k of every value
    together), computed here without the module's sample."""
    import zlib

    raw = np.ascontiguousarray(values).reshape(-1).view(np.uint8).reshape(values.size, values.itemsize)
    return raw.size / len(zlib.compress(raw.T.tobytes(), netcdf.COMPLEVEL))


def test_zlib_only_where_it_pays(tmp_path):
    """Floats that zlib cannot shrink to half (random mantissas, as an interpolated stiffness
    over a 4-D map: 1.1-1.3x) are stored uncompressed, with their checksum; floats that repeat
    (a count, a constant) compressed; the sample's verdict is the whole array's on both, and
    both read back bitwise."""
    rng = np.random.default_rng(7)
    noisy = 1.0 + rng.random((40, 30, 20))  # 24 000 values: the sample is 8 runs of 1024
    steps = np.repeat(np.arange(40.0), 600).reshape(40, 30, 20)
    steps[3, 4, 5] = np.nan
    assert _shuffled_ratio(noisy) < netcdf.MIN_ZLIB_RATIO < _shuffled_ratio(steps)
    assert not netcdf._compresses(noisy) and netcdf._compresses(steps)
    ds = xr.Dataset({"noisy": (("a", "b", "c"), noisy), "steps": (("a", "b", "c"), steps)})
    path = write(ds, tmp_path / "out.nc")
    with netCDF4.Dataset(path) as nc:
        assert not nc["noisy"].filters()["zlib"] and nc["noisy"].filters()["fletcher32"]
        assert nc["steps"].filters()["zlib"] and nc["steps"].filters()["fletcher32"]
    verify(path)
    with read(path) as back:
        for name in ("noisy", "steps"):
            assert np.array_equal(back[name].values, ds[name].values, equal_nan=True), name


def test_a_failed_write_names_the_output_and_leaves_no_temporary_file(tmp_path, monkeypatch):
    def fails(self, target, **options):
        Path(target).write_bytes(b"partial")
        raise RuntimeError("NetCDF: HDF error")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", fails)
    path = tmp_path / "out.nc"
    with pytest.raises(OSError) as caught:
        write(_data_set(), path)
    assert caught.value.filename == str(path) and caught.value.errno == errno.EIO  # the disk has room
    assert "NetCDF: HDF error" in str(caught.value) and os.listdir(tmp_path) == []


def test_a_failed_write_on_a_full_file_system_is_enospc_with_the_free_bytes(tmp_path, monkeypatch):
    def fails(self, target, **options):
        raise RuntimeError("NetCDF: HDF error")

    class Full:
        f_bavail, f_frsize = 3, 512

    monkeypatch.setattr(xr.Dataset, "to_netcdf", fails)
    monkeypatch.setattr(netcdf.os, "statvfs", lambda folder: Full())
    with pytest.raises(OSError) as caught:
        write(_data_set(), tmp_path / "out.nc")
    assert caught.value.errno == errno.ENOSPC
    assert caught.value.strerror == f"{os.strerror(errno.ENOSPC)} (NetCDF: HDF error); 1536 bytes free"


def test_the_old_file_stays_whole_when_a_new_write_fails(tmp_path, monkeypatch):
    path = write(_data_set(), tmp_path / "out.nc")
    before = path.read_bytes()
    monkeypatch.setattr(xr.Dataset, "to_netcdf", lambda self, target, **options: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        write(_data_set(), path)
    assert path.read_bytes() == before and os.listdir(tmp_path) == ["out.nc"]


def test_verify_passes_a_whole_file_and_names_the_variable_of_a_damaged_chunk(tmp_path, damage):
    path = write(_data_set(), tmp_path / "out.nc")
    verify(path)
    damage(path, "iterations")
    with pytest.raises(DamagedFile) as caught:
        verify(path)
    assert caught.value.variable == "iterations" and caught.value.filename == str(path)
    assert str(caught.value).startswith(f"{path}: variable iterations is damaged (")


def test_verify_reads_a_large_variable_a_few_chunks_at_a_time(tmp_path, monkeypatch, damage):
    monkeypatch.setattr(netcdf, "VERIFY_BYTES", 64)  # 8 values: each row of 2 read on its own
    ds = xr.Dataset({"v": (("i", "j"), np.arange(40.0).reshape(20, 2))})
    path = write(ds, tmp_path / "big.nc")
    verify(path)
    damage(path, "v")
    with pytest.raises(DamagedFile, match="variable v is damaged"):
        verify(path)


def test_plan_codes_of_an_older_file_read_back_as_text(tmp_path):
    plans = ['{"solves": 1}', '{"solves": 2}']
    codes = xr.DataArray(
        [[0.0, 1.0], [np.nan, 0.0]],
        dims=("aspect", "nu"),
        attrs={"plan_table": json.dumps(plans), "text_attributes": json.dumps({"long_name": "solve plan"})},
    )
    path = tmp_path / "old.nc"
    xr.Dataset({"plan": codes}).to_netcdf(path, engine="netcdf4")
    with read(path) as ds:
        assert ds["plan"].values.tolist() == [[plans[0], plans[1]], ["", plans[0]]]
        assert ds["plan"].attrs == {"long_name": "solve plan"}
