"""Suite-wide rules: every test solves with BLAS limited as the command line and the sweep do
(``hpcontact.numerics.blas.limited_blas``, one thread unless ``HPCONTACT_BLAS_THREADS``); and in
CI (``CI`` set to 1, true or yes: ``.ci/run`` exports ``CI=true`` itself, so the gate does not
depend on the CI service setting it) a skipped test fails the run.

The only skips allowed there (``allowed_skip``) split the MPI tests between the two pytest
invocations of ``.ci/run`` — plain ``pytest tests`` runs the tests that start their own ``mpiexec``
and skips the ones that need to be 2 ranks; ``mpiexec -n 2 pytest tests/mpi`` the other way round —
and skip the tests marked ``gpu`` (tests/gpu) where CuPy or a CUDA device is missing: CI's machine
has no GPU; a machine that has one runs them (benchmarks/README.md). Any other skip — a checker or
an optional package missing, a ``gpu`` test skipped for another reason, an unmarked test skipped
with the GPU's reason — would leave a claim unchecked in CI, so the session ends with a failure
naming each skipped test.

The suite runs on pytest-xdist workers, a test file each (``-n auto --dist loadfile`` in the
README's command); the files of tests/mpi go first: their tests start processes and mostly wait
for them, and the longest (test_faults.py, 2–4 min on 2 cores) would otherwise end the run alone.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from hpcontact.numerics.backend import cuda_devices
from hpcontact.numerics.blas import limited_blas

#: Skip reasons of the launcher split (tests/mpi): each test runs in the other invocation.
LAUNCHER_SPLIT = ("needs 2 ranks", "run pytest without a launcher")
#: The skip reason of a ``gpu``-marked test on a machine without a GPU (``pytest_runtest_setup``).
NO_GPU = "needs CuPy and a CUDA device"
GPU_SKIP = ("skipped", "gpu marker, no GPU")


@pytest.fixture(autouse=True)
def _solves_with_limited_blas() -> Iterator[None]:
    with limited_blas():
        yield


def pytest_configure(config: pytest.Config) -> None:
    """xdist hands out files in the collection's order (``pytest_collection_modifyitems``), not
    reordered by their number of tests: pytest-xdist ≥ 3.7 sorts the files of ``--dist loadfile``
    by test count unless ``--no-loadscope-reorder``, which put tests/mpi (few tests, the longest
    files) last, test_faults.py alone on one worker at the end of the run. An explicit
    ``--loadscope-reorder`` still reorders (to compare both orders)."""
    if hasattr(config.option, "loadscopereorder") and "--loadscope-reorder" not in config.invocation_params.args:
        config.option.loadscopereorder = False


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """tests/mpi first (stable otherwise): xdist hands out files in this order (``pytest_configure``)."""
    mpi = Path(__file__).parent / "mpi"
    items.sort(key=lambda item: mpi not in item.path.parents)


def pytest_runtest_setup(item: pytest.Item) -> None:
    """A test marked ``gpu`` is skipped, with ``NO_GPU`` and what is missing, without a GPU; its
    report then carries ``GPU_SKIP`` in its user properties (they travel with xdist's reports)."""
    if item.get_closest_marker("gpu") is not None:
        _, count, why = cuda_devices()
        if count == 0:
            item.user_properties.append(GPU_SKIP)
            pytest.skip(f"{NO_GPU}: {why}")


def allowed_skip(report: pytest.TestReport) -> bool:
    """Whether CI allows this skip: the launcher split, or a ``gpu``-marked test that
    ``pytest_runtest_setup`` skipped for the want of a GPU (a test skipping itself with the same
    words is not allowed)."""
    text = str(report.longrepr)
    return any(reason in text for reason in LAUNCHER_SPLIT) or (
        any(tuple(entry) == GPU_SKIP for entry in report.user_properties) and NO_GPU in text
    )


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")


@pytest.hookimpl(trylast=True)
def pytest_sessionfinish(session: pytest.Session, exitstatus: int) -> None:
    if not _in_ci():
        return
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if reporter is None:
        return
    skipped = [report for report in reporter.stats.get("skipped", []) if not getattr(report, "wasxfail", None)]
    unexpected = [report for report in skipped if not allowed_skip(report)]
    if unexpected:
        reporter.write_line("")
        for report in unexpected:
            reporter.write_line(f"CI: skipped, which CI does not allow: {report.nodeid}: {report.longrepr}", red=True)
        reporter.write_line(
            f"CI: {len(unexpected)} test(s) skipped; install what they need (see their reasons)", red=True
        )
        session.exitstatus = pytest.ExitCode.TESTS_FAILED
