"""The accuracy-versus-cost study as a sweep: every scene timed on its own, kernels built cold.

``[mpiexec -n N] python -m hpcontact.sweep.accuracy_study SPEC [hpcontact run options]`` runs
``jobs/accuracy_cost.toml`` (``postprocess/accuracy_cost.py`` draws it).

Its results differ from ``hpcontact run``'s for the same scene (one grid with cold caches, not
the default extrapolated solve), so the two never share an output by default: for a spec that
names no ``[sweep].output``, where ``hpcontact run`` writes ``<stem>.nc`` (journals in
``<stem>.nc.journal``) the study writes ``<stem>.study.nc`` beside the spec (journals in
``<stem>.study.nc.journal``); ``--output``, or the spec's own ``[sweep].output`` (as
``jobs/accuracy_cost.toml`` names ``results/accuracy_cost.nc``), is used as given. Where both do
write to one place, each journal entry names the runner that computed it and a ``--resume`` of
the other runs it again (``hpcontact.sweep.run.resume``).
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from hpcontact.errors import InputError
from hpcontact.problems.contact import solve
from hpcontact.scene import Scene
from hpcontact.sweep.cost.engine import clear_kernel_caches
from hpcontact.sweep.driver import main
from hpcontact.sweep.run.records import runner_name
from hpcontact.sweep.space.parse import load_spec

OUTPUT_SUFFIX = ".study.nc"  # the study's default output: <stem>.study.nc beside hpcontact run's <stem>.nc


def cold_solve(params: Mapping[str, Any]) -> dict[str, Any]:
    """``hpcontact.problems.contact.solve`` with the kernel caches emptied first.

    A sweep's process keeps kernel spectra per (material, grid), so in an accuracy study the
    tasks that differ only in ``tol`` would reuse the first one's kernels and time only their
    CG. The study wants what one scene costs on its own: influence coefficients, spectra, FFT
    operator and solves (FFTW wisdom stays warm, as in any long-running sweep).
    """
    clear_kernel_caches()
    return solve(Scene.from_params(params))


def study_output(spec_path: str | Path) -> str | None:
    """The study's output when ``--output`` is not given: ``<stem>.study.nc`` beside the spec
    for a spec that names no ``[sweep].output`` (see the module docstring; never the working
    folder unless the spec lies there); None, the spec's own output, for one that names it, or
    for a spec that does not load (the run refuses it, naming what is wrong)."""
    try:
        spec = load_spec(spec_path, check_scenes=False)
    except InputError:
        return None
    if "output" in tomllib.loads(spec.text).get("sweep", {}):
        return None
    return str(Path(spec_path).with_name(f"{Path(spec_path).stem}{OUTPUT_SUFFIX}"))


def run_study(argv: Sequence[str] | None = None) -> int:
    """``[mpiexec -n N] python -m hpcontact.sweep.accuracy_study SPEC [hpcontact run options]``.

    ``hpcontact run`` with :func:`cold_solve` as the task function (MPI, locks, resumable
    journals, signals, exit statuses and the data set of ``hpcontact run``) and
    :func:`study_output` as its default output; used for ``jobs/accuracy_cost.toml``.
    """
    return main(
        argv,
        prog="python -m hpcontact.sweep.accuracy_study",
        task_function=cold_solve,
        runner=runner_name(cold_solve),
        default_output=study_output,
        description="Run an accuracy-versus-cost sweep, every scene timed with cold kernel caches.",
    )


if __name__ == "__main__":
    raise SystemExit(run_study())
