"""Memory checked before it is spent (issue 43, item 2): ``hpcontact.solve``, ``hpcontact solve``
and ``hpcontact.run_sweep`` refuse a grid whose estimated peak exceeds the budget, in one line,
before its arrays exist. The budget is pinned through SLURM_MEM_PER_CPU (12000 MiB, about this
development machine's memory per core), so the refusals do not depend on the machine."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import textwrap
import time

import pytest

import hpcontact
from hpcontact.errors import InputError
from hpcontact.numerics.memory import MIB, check_fits, memory_budget
from hpcontact.problems import footprint

BUDGET_MIB = 12000
HUGE = {"shape": "rectangle", "aspect": 1, "n": 8192}  # ~46 GiB of arrays (footprint.array_bytes)


@pytest.fixture
def pinned_budget(monkeypatch):
    """This process's default budget per rank: ``BUDGET_MIB``, whatever the machine."""
    for name in ("SLURM_CPUS_PER_TASK", "SLURM_MEM_PER_NODE"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("SLURM_MEM_PER_CPU", str(BUDGET_MIB))


def test_the_budget_is_memory_when_given_else_the_machine_s(pinned_budget):
    assert memory_budget("2G", "memory") == (2 * 2**30, "memory")
    assert memory_budget(None, "memory") == (BUDGET_MIB * MIB, "SLURM_MEM_PER_CPU")
    check_fits(100.0, (100, "given"), "n", 8, "a grid")  # equal to the limit fits
    with pytest.raises(
        InputError, match=r"^n = 8: a grid: estimated peak memory 2 MiB over the limit 1 MiB \(given\)$"
    ):
        check_fits(2.0 * MIB, (MIB, "given"), "n", 8, "a grid")


def test_solve_refuses_a_grid_over_the_budget_in_one_line_before_allocating(pinned_budget):
    arrays = footprint.array_bytes(HUGE)
    assert arrays > 3 * BUDGET_MIB * MIB  # the scene really is far over the budget
    started = time.perf_counter()
    with pytest.raises(InputError) as refused:
        hpcontact.solve(**HUGE)
    assert time.perf_counter() - started < 2.0
    message = str(refused.value)
    assert "\n" not in message and refused.value.field == "n"
    assert message.startswith("n = 8192: a grid (8192 × 8192 cells here) that fits: a smaller n or a larger memory")
    assert f"over the limit {BUDGET_MIB} MiB (SLURM_MEM_PER_CPU)" in message
    estimate = float(message.split("estimated peak memory ")[1].split(" MiB")[0])
    assert arrays / MIB < estimate < arrays / MIB + 2048  # the arrays + this process's resident set


def test_memory_is_the_budget_of_a_one_grid_solve():
    with pytest.raises(InputError, match=r"^memory = '1M': a grid \(16 × 16 cells here\) that fits: .* \(memory\)$"):
        hpcontact.solve(n=16, memory="1M")  # this process alone is larger
    record = hpcontact.solve(n=16, memory="64G")  # a budget above the machine's is the caller's to give
    assert record["nx"] == 16
    with pytest.raises(InputError, match="^memory = '2G': not with quantities slip"):
        hpcontact.solve(quantities="slip", radius=1.0, load=1.0, mu=0.3, q_ratio=0.5, memory="2G")


def _peak_rss_script(body: str) -> str:
    """A script that runs ``body`` after importing hpcontact and prints the growth of its peak
    resident set (MiB) and the seconds ``body`` took."""
    return (
        textwrap.dedent(
            """
        import resource, sys, time
        import hpcontact
        from hpcontact.errors import InputError
        before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        started = time.perf_counter()
        """
        )
        + textwrap.dedent(body)
        + textwrap.dedent(
            """
        seconds = time.perf_counter() - started
        grown = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
        print(f"{grown:.1f} {seconds:.3f}")
        """
        )
    )


def _budget_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("SLURM_CPUS_PER_TASK", "SLURM_MEM_PER_NODE")}
    return {**env, "SLURM_MEM_PER_CPU": str(BUDGET_MIB)}


def test_a_refused_solve_grows_the_resident_set_by_at_most_200_mb():
    script = _peak_rss_script(
        """
        try:
            hpcontact.solve(shape="rectangle", aspect=1, n=8192)
            sys.exit("not refused")
        except InputError as exc:
            assert "over the limit" in str(exc), exc
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], env=_budget_env(), capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    grown, seconds = map(float, done.stdout.split())
    assert grown <= 200.0 and seconds < 2.0


def test_the_command_line_refuses_it_with_exit_2_and_one_line():
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-m", "hpcontact", "solve", "--shape", "rectangle", "--aspect", "1", "--n", "8192"],
        env=_budget_env(),
        capture_output=True,
        text=True,
        timeout=120,
    )
    elapsed = time.perf_counter() - started
    assert done.returncode == 2 and done.stdout == ""
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("hpcontact: error: --n = 8192: a grid (8192 × 8192 cells here)")
    assert "a larger --memory" in lines[0] and f"over the limit {BUDGET_MIB} MiB (SLURM_MEM_PER_CPU)" in lines[0]
    assert elapsed < 20.0  # the interpreter's start and imports included; the check itself: the tests above


def test_run_sweep_refuses_a_task_over_the_default_budget_before_it_starts(pinned_budget, tmp_path):
    started: list[dict] = []
    spec = {
        "scene": {"shape": "rectangle", "aspect": 1.0},
        "numerics": {"n": 8192},
        "axes": {"nu": [0.3]},
        "sweep": {"output": str(tmp_path / "huge.nc")},
    }
    import mpi4py.MPI  # noqa: F401 - what run_sweep imports once per process, not timed below
    import xarray  # noqa: F401

    import hpcontact.sweep.run.rounds  # noqa: F401

    clock = time.perf_counter()
    with pytest.raises(InputError) as refused:
        hpcontact.run_sweep(spec, task_function=lambda params: started.append(dict(params)) or {}, stream=io.StringIO())
    assert time.perf_counter() - clock < 2.0  # parsing the spec, costing its task, the check
    message = str(refused.value)
    assert refused.value.field == "mem_per_rank" and "\n" not in message
    assert f"{BUDGET_MIB} MiB (SLURM_MEM_PER_CPU)" in message and started == []
    assert not (tmp_path / "huge.nc").exists()
