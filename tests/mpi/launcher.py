"""What the tests that start their own ``mpiexec -n 2`` share: the launcher that belongs to this
Python (the venv's ``mpiexec`` from the ``mpich`` wheel before the PATH's), and the marks that
skip them where they cannot run — under a launcher (``mpiexec -n 2 pytest tests/mpi``, where
the other half of tests/mpi runs) or without any ``mpiexec``.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

import pytest

from hpcontact.sweep.schedule import launched_by_mpi

ROOT = Path(__file__).resolve().parents[2]
MPIEXEC = shutil.which("mpiexec", path=f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}")

#: ``pytestmark`` of a module whose tests launch ``mpiexec`` themselves.
STARTS_ITS_OWN_MPIEXEC = [
    pytest.mark.skipif(launched_by_mpi(), reason="starts its own mpiexec; run pytest without a launcher"),
    pytest.mark.skipif(MPIEXEC is None, reason="no mpiexec"),
]
