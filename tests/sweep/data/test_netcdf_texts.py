"""Text variables written as distinct texts encoded once (``netcdf._encoded_texts``) make the file
xarray's own encoding makes: every HDF5 data set's bytes, type, shape, chunks, filters and
attribute values equal, inspected with h5py, and plain ``xarray.open_dataset`` reads them back."""

from __future__ import annotations

import h5py
import numpy as np
import xarray as xr

from hpcontact.sweep.data import netcdf


def _texts_data_set() -> xr.Dataset:
    """Texts that repeat, non-ASCII ones (UTF-8 longer than their characters), empty ones, a text
    coordinate and a dimension of labels, beside numbers."""
    rng = np.random.default_rng(3)
    choices = np.array(["", "ok", "ν = 0.25 — 字", '{"solves": 2, "grids": [[32, 16]]}', "x" * 40], dtype=object)
    message = choices[rng.integers(0, len(choices), size=(4, 5))]
    empty = np.full((4, 5), "", dtype=object)
    return xr.Dataset(
        {
            "message": (("shape", "nu"), message),
            "blank": (("shape", "nu"), empty),
            "K": (("shape", "nu"), rng.random((4, 5))),
        },
        coords={
            "shape": ("shape", np.array(["circle", "ellipse", "ρ", "star"], dtype=object)),
            "nu": ("nu", np.linspace(0, 0.5, 5)),
            "material": ((), "isotropic"),
            "label": ("shape", np.array(["a", "bb", "", "dddd"], dtype=object)),
        },
        attrs={"title": "texts"},
    )


def _objects(path) -> dict[str, tuple]:
    """Every HDF5 data set of ``path``: its layout and bytes, and its attributes by name."""
    out = {}
    with h5py.File(path) as h5:
        names: list[str] = []
        h5.visit(names.append)
        for name in names:
            obj = h5[name]
            attrs = {
                k: np.asarray(v).tolist()
                for k, v in obj.attrs.items()
                if k not in ("REFERENCE_LIST", "DIMENSION_LIST", "_FillValue")
            }
            if isinstance(obj, h5py.Dataset):
                layout = (obj.dtype.str, obj.shape, obj.chunks, obj.compression, obj.shuffle, obj.fletcher32)
                out[name] = (layout, obj[()].tobytes(), attrs)
    return out


def test_texts_encoded_once_make_the_file_xarray_makes(tmp_path, monkeypatch):
    ds = _texts_data_set()
    netcdf.write(ds, tmp_path / "once.nc")
    monkeypatch.setattr(netcdf, "_encoded_texts", lambda ds: ds)  # xarray encodes every text itself
    netcdf.write(ds, tmp_path / "xarray.nc")
    once, plain = _objects(tmp_path / "once.nc"), _objects(tmp_path / "xarray.nc")
    assert list(once) == list(plain) and "message" in once and "label" in once
    for name in once:
        assert once[name] == plain[name], name
    with xr.open_dataset(tmp_path / "once.nc") as back:
        for name in ("message", "blank", "shape", "label", "material"):
            assert back[name].values.tolist() == ds[name].values.tolist(), name
        assert back["message"].encoding["char_dim_name"] == plain_char_dim(tmp_path / "xarray.nc", "message")


def plain_char_dim(path, name: str) -> str:
    with xr.open_dataset(path) as ds:
        return ds[name].encoding["char_dim_name"]
