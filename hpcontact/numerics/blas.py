"""BLAS threads of the solves: ``HPCONTACT_BLAS_THREADS`` (default 1), applied only while a
solve runs.

The solvers' only BLAS calls are vector reductions, and threaded OpenBLAS on a machine whose
cores are already busy (MPI ranks, FFTW threads) made each of them ~200× slower
(docs/performance.md §"BLAS threads"). The limit is a context (``limited_blas``) around the
entry points that solve — ``hpcontact.solve``, ``hpcontact solve`` and a sweep's tasks
(``hpcontact.sweep.run.rounds.execute``) — and is lifted when they return: importing hpcontact
changes no thread pool and no environment variable of the process that imports it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager

from hpcontact.errors import InputError

VARIABLE = "HPCONTACT_BLAS_THREADS"
DEFAULT_THREADS = 1


def blas_threads(environ: Mapping[str, str] | None = None) -> int:
    """The BLAS threads a solve may use: ``$HPCONTACT_BLAS_THREADS`` (an integer ≥ 1), else 1."""
    text = (os.environ if environ is None else environ).get(VARIABLE, "").strip()
    if not text:
        return DEFAULT_THREADS
    if not text.isdigit() or int(text) < 1:
        raise InputError(VARIABLE, "an integer >= 1 (BLAS threads per process)", text)
    return int(text)


@contextmanager
def limited_blas() -> Iterator[None]:
    """BLAS limited to ``blas_threads()`` threads inside the block, the previous limits restored
    after it (threadpoolctl; it sees the BLAS libraries loaded when the block starts)."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=blas_threads(), user_api="blas"):
        yield
