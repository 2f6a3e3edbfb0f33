"""Moved: the cost model lives in ``hpcontact.sweep.cost`` (``rates``, ``calibration``,
``calibration_file``, ``replay``, ``estimate``); these names stay importable here until their
importers are updated."""

# ruff: noqa: F401 - moved; importers updated by the coordinator
from hpcontact.sweep.cost.calibration import calibrate
from hpcontact.sweep.cost.calibration_file import (
    FORMAT,
    cached_calibration,
    load_calibration,
    read_calibration,
    save_calibration,
)
from hpcontact.sweep.cost.estimate import check_memory, estimate, start_estimate
from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate, base_memory_bytes, task_array_bytes
from hpcontact.sweep.cost.replay import Overheads, replay
