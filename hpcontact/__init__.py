"""hpcontact: anisotropy of contact stiffness with FFT-accelerated half-space boundary elements.

The face a notebook uses (``api``): ``hpcontact.solve(shape=..., nu=..., ...)`` returns one
scene's record, ``hpcontact.run_sweep(spec)`` runs a sweep in this process and
``hpcontact.open_dataset(path)`` reads a sweep's data set. The package's layout, floor by
floor, is in ``docs/design.md`` §3.

Importing hpcontact changes nothing in the process: no environment variable, no thread pool.
BLAS is limited to ``HPCONTACT_BLAS_THREADS`` threads (default 1) only while a solve runs
(``hpcontact.numerics.blas``: the solvers' only BLAS calls are vector reductions, and threaded
OpenBLAS on busy cores made each of them ~200× slower, docs/performance.md §"BLAS threads").
FFTW threads are set separately (``threads``).
"""

__version__ = "0.1.0"

from hpcontact.api import open_dataset, run_sweep, solve  # noqa: E402  (after __version__: the sweep reads it)
from hpcontact.errors import InputError  # noqa: E402  (what every front end raises for bad input)

__all__ = ["InputError", "__version__", "open_dataset", "run_sweep", "solve"]
