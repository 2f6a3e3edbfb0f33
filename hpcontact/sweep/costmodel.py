"""Moved: the cost model lives in ``hpcontact.sweep.cost`` (``rates``, ``calibration``,
``calibration_file``, ``replay``, ``estimate``); these names stay importable here until their
importers are updated. Setting a name here (a test's monkeypatch of ``calibrate``) sets it in
every module of ``cost`` that holds it, where it is used."""

import sys
import types
from typing import Any

from hpcontact.sweep.cost import calibration as _calibration
from hpcontact.sweep.cost import calibration_file as _calibration_file
from hpcontact.sweep.cost import estimate as _estimate
from hpcontact.sweep.cost import rates as _rates
from hpcontact.sweep.cost import replay as _replay

# moved; importers updated by the coordinator
from hpcontact.sweep.cost.calibration import calibrate  # noqa: F401
from hpcontact.sweep.cost.calibration_file import (  # noqa: F401
    FORMAT,
    cached_calibration,
    load_calibration,
    read_calibration,
    save_calibration,
)
from hpcontact.sweep.cost.estimate import check_memory, estimate, start_estimate  # noqa: F401
from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate, base_memory_bytes, task_array_bytes  # noqa: F401
from hpcontact.sweep.cost.replay import Overheads, replay  # noqa: F401

_PARTS = (_calibration, _calibration_file, _estimate, _rates, _replay)


class _Moved(types.ModuleType):
    """``hpcontact.sweep.costmodel``: setting a name sets it in every module of ``cost`` that holds it."""

    def __setattr__(self, name: str, value: Any) -> None:
        for part in _PARTS:
            if name in vars(part):
                setattr(part, name, value)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Moved
