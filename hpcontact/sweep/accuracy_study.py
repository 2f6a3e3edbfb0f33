"""The accuracy-versus-cost study as a sweep: every scene timed on its own, kernels built cold.

``[mpiexec -n N] python -m hpcontact.sweep.accuracy_study SPEC [hpcontact run options]`` runs
``jobs/accuracy_cost.toml`` (``postprocess/accuracy_cost.py`` draws it).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from hpcontact.problems.contact import solve
from hpcontact.scene import Scene
from hpcontact.sweep.cost.engine import clear_kernel_caches
from hpcontact.sweep.driver import main


def cold_solve(params: Mapping[str, Any]) -> dict[str, Any]:
    """``hpcontact.problems.contact.solve`` with the kernel caches emptied first.

    A sweep's process keeps kernel spectra per (material, grid), so in an accuracy study the
    tasks that differ only in ``tol`` would reuse the first one's kernels and time only their
    CG. The study wants what one scene costs on its own: influence coefficients, spectra, FFT
    operator and solves (FFTW wisdom stays warm, as in any long-running sweep).
    """
    clear_kernel_caches()
    return solve(Scene.from_params(params))


def run_study(argv: Sequence[str] | None = None) -> int:
    """``[mpiexec -n N] python -m hpcontact.sweep.accuracy_study SPEC [hpcontact run options]``.

    ``hpcontact run`` with :func:`cold_solve` as the task function (MPI, locks, resumable
    journals, signals, exit statuses and the data set of ``hpcontact run``); used for
    ``jobs/accuracy_cost.toml``.
    """
    return main(
        argv,
        prog="python -m hpcontact.sweep.accuracy_study",
        task_function=cold_solve,
        description="Run an accuracy-versus-cost sweep, every scene timed with cold kernel caches.",
    )


if __name__ == "__main__":
    raise SystemExit(run_study())
