"""hpcontact: anisotropy of contact stiffness with FFT-accelerated half-space boundary elements.

BLAS is limited to ``HPCONTACT_BLAS_THREADS`` threads (default 1) on import: the solvers' only
BLAS calls are vector reductions, and threaded OpenBLAS on a machine whose cores are already
busy (MPI ranks, FFTW threads) made each of them 200× slower (22 ms instead of 0.1 ms for a
262k-entry norm, measured on 2 cores under load). FFTW threads are set separately (``threads``).

The face a notebook uses (``api``): ``hpcontact.solve(shape=..., nu=..., ...)`` returns one
scene's record, ``hpcontact.run_sweep(spec)`` runs a sweep in this process and
``hpcontact.open_dataset(path)`` reads a sweep's data set. The package's layout, floor by
floor, is in ``docs/design.md`` §3.
"""

import os as _os

import numpy as _numpy  # noqa: F401  (loads OpenBLAS so that the limit below reaches it)
from threadpoolctl import threadpool_limits as _threadpool_limits

__version__ = "0.1.0"

_threadpool_limits(limits=int(_os.environ.get("HPCONTACT_BLAS_THREADS", "1")), user_api="blas")

from hpcontact.api import open_dataset, run_sweep, solve  # noqa: E402  (after the limit: the solvers load numpy's BLAS users)

__all__ = ["__version__", "open_dataset", "run_sweep", "solve"]
