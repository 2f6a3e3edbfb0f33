"""Device selection (hpcontact.numerics.backend): one GPU per rank, the refusal without one."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import hpcontact
from hpcontact.cli import main as cli_main
from hpcontact.errors import InputError
from hpcontact.numerics import backend
from hpcontact.numerics.backend import array_namespace, gpu_for_rank, local_rank, own_gpu, resolved_device

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "gpu"))
from stub_cupy import stub_cupy  # noqa: E402


def test_ranks_take_the_visible_gpus_in_turn():
    assert [gpu_for_rank(rank, 4) for rank in range(9)] == [0, 1, 2, 3, 0, 1, 2, 3, 0]
    assert [gpu_for_rank(rank, 1) for rank in range(3)] == [0, 0, 0]
    with pytest.raises(ValueError):
        gpu_for_rank(0, 0)


def test_the_rank_on_the_node_comes_from_the_launcher():
    assert local_rank({}) == 0
    assert local_rank({"OMPI_COMM_WORLD_LOCAL_RANK": "3"}) == 3
    assert local_rank({"MPI_LOCALRANKID": "2", "SLURM_LOCALID": "5"}) == 2  # the launcher's own first
    assert local_rank({"SLURM_LOCALID": "5"}) == 5
    assert local_rank({"OMPI_COMM_WORLD_LOCAL_RANK": "", "PMIX_LOCAL_RANK": "1"}) == 1


def test_cpu_is_numpy_and_other_devices_are_refused():
    assert array_namespace("cpu") is np
    with pytest.raises(InputError, match="one of cpu, gpu"):
        array_namespace("tpu")


@pytest.mark.parametrize(
    "cupy, why",
    [(None, "CuPy is not installed (pip install 'hpcontact[gpu]')"), (np, "CuPy sees no CUDA device")],
)
def test_a_gpu_without_one_is_refused_in_one_line_naming_what_is_missing(monkeypatch, capsys, cupy, why):
    monkeypatch.setattr(backend, "cuda_devices", lambda: (cupy, 0, why))  # as on a machine without
    with pytest.raises(InputError) as info:
        hpcontact.solve(shape="circle", n=8, device="gpu")
    assert info.value.field == "device" and why in str(info.value)
    assert cli_main(["solve", "--n", "8", "--device", "gpu"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "device" in err and why in err


@pytest.mark.parametrize(
    ("devices", "rank", "own"),
    [(0, 0, None), (2, 0, 0), (2, 1, 1), (2, 2, None), (1, 5, None)],
)
def test_auto_is_the_ranks_own_gpu_where_it_has_one_else_the_cpu(monkeypatch, devices, rank, own):
    """Device "auto": local rank r solves on GPU r while r < the visible devices, on the CPU
    beyond them (a node of 2 GPUs and 16 ranks: 2 GPU ranks, 14 CPU ranks) and where CuPy sees
    none; "cpu" and "gpu" stay what they say (no lookup for "cpu")."""
    cupy = stub_cupy(2**30, 2**31)
    monkeypatch.setattr(backend, "cuda_devices", lambda: (cupy if devices else None, devices, "" if devices else "no"))
    for name in backend.LOCAL_RANK_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("SLURM_LOCALID", str(rank))
    assert own_gpu() == own
    assert resolved_device("auto") == ("cpu" if own is None else "gpu")
    assert (resolved_device("cpu"), resolved_device("gpu")) == ("cpu", "gpu")
    if own is None:
        assert array_namespace("auto") is np
    else:
        assert array_namespace("auto") is cupy and cupy.cuda.Device().id == own
