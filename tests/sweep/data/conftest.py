"""Shared helpers of the data-set tests: a file damaged inside one stored chunk."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import h5py
import pytest


def _flip_one_byte(path: Path, variable: str) -> None:
    """Flip every bit of the middle byte of the first stored chunk of ``variable`` in the netCDF-4
    (HDF5) file ``path``: the chunk's Fletcher-32 checksum then fails when it is read."""
    with h5py.File(path, "r") as h5:
        info = h5[variable].id.get_chunk_info(0)
    with open(path, "r+b") as fh:
        fh.seek(info.byte_offset + info.size // 2)
        byte = fh.read(1)[0]
        fh.seek(info.byte_offset + info.size // 2)
        fh.write(bytes([byte ^ 0xFF]))


@pytest.fixture
def damage() -> Callable[[Path, str], None]:
    """``damage(path, variable)``: one byte flipped inside the first stored chunk of ``variable``."""
    return _flip_one_byte
