"""The cost model's calibration cached in a file, like FFTW wisdom: saved, read, checked, loaded.

The calibration takes tens of seconds and is cached in ``costmodel-HOST.json`` beside the wisdom file
($HPCONTACT_COSTMODEL overrides), keyed by host and package version: a file of another host or
version, or one that cannot be read as a calibration, is ignored with a warning and replaced.
"""

from __future__ import annotations

import json
import math
import os
import re
import socket
import stat
import warnings
from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path
from typing import Any

from hpcontact import __version__
from hpcontact.sweep.cost.calibration import calibrate
from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate, calibration_path

# version of the calibration file's layout (2: node_s, Barnett–Lothe; 3: cell_s, kernels; 4: task_s; 5: strip_s;
# 6: exact_s; 7: every solve under the sweep's BLAS limit, older files' rates 2-3x high)
FORMAT = 7
CALIBRATION_BYTES = 2**20  # a calibration file is ~2 kB: one larger than 1 MiB is not one (nor read further)
CALIBRATION_DEPTH = 8  # a calibration nests 3 deep ({"rates": {kind: {...}}}): deeper JSON is not one
_JSON_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"')
_NOT_BRACKETS = bytes(sorted(set(range(256)) - set(b"[]{}")))


def save_calibration(calibration: Calibration, path: Path | None = None) -> Path:
    """Write ``calibration`` as JSON, atomically (temporary file, then rename)."""
    path = calibration_path() if path is None else Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {"format": FORMAT, **asdict(calibration)}
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(record, indent=1, sort_keys=True))
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def _calibration_bytes(path: Path) -> bytes:
    """The bytes of the calibration file ``path``, at most ``CALIBRATION_BYTES``: ``ValueError``
    for a larger file or one that is not a regular file (a symlink to /dev/zero, a FIFO: never
    read to the end, never waited on)."""
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise ValueError("not a regular file")
        data = b""
        while len(data) <= CALIBRATION_BYTES:
            chunk = os.read(fd, CALIBRATION_BYTES + 1 - len(data))
            if not chunk:
                break
            data += chunk
    finally:
        os.close(fd)
    if len(data) > CALIBRATION_BYTES:
        raise ValueError(f"larger than {CALIBRATION_BYTES} bytes")
    return data


def _json_depth(data: bytes) -> int:
    """How deep the arrays and objects of the JSON text ``data`` nest (brackets outside strings)."""
    depth = deepest = 0
    for bracket in _JSON_STRING.sub(b"", data).translate(None, _NOT_BRACKETS):
        depth += 1 if bracket in b"[{" else -1
        deepest = max(deepest, depth)
    return deepest


def _number(record: Mapping[str, Any], name: str, where: str = "") -> float:
    value = record.get(name)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{where}{name} must be a number")
    return float(value)


def read_calibration(path: Path) -> Calibration:
    """The calibration in ``path``; ``ValueError`` if it is not one (not a regular file, larger
    than ``CALIBRATION_BYTES``, JSON nested deeper than ``CALIBRATION_DEPTH``, wrong format,
    missing, non-numeric or non-finite numbers, a negative rate)."""
    data = _calibration_bytes(Path(path))
    if _json_depth(data) > CALIBRATION_DEPTH:
        raise ValueError(f"JSON nested deeper than {CALIBRATION_DEPTH}")
    record = json.loads(data.decode("utf-8"))
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        raise ValueError("not a calibration file of this format")
    if not isinstance(record.get("rates"), dict) or not all(
        isinstance(record.get(k), str) for k in ("host", "version")
    ):
        raise ValueError("rates, host and version missing")
    rates = {}
    for kind in KINDS:
        entry = record["rates"].get(kind)
        if not isinstance(entry, dict):
            raise ValueError(f"rates.{kind} missing")
        rates[kind] = Rate(
            *(
                _number(entry, name, f"rates.{kind}.")
                for name in ("rate_s", "solve_s", "node_s", "cell_s", "task_s", "strip_s", "exact_s")
            )
        )
        if not all(math.isfinite(v) and v >= 0.0 for v in asdict(rates[kind]).values()):
            raise ValueError(f"{kind}: rates must be finite and >= 0")
        if rates[kind].rate_s + rates[kind].solve_s <= 0.0:
            raise ValueError(f"{kind}: a task must take time")
    base = _number(record, "base_bytes")
    if not (math.isfinite(base) and base >= 0.0):
        raise ValueError("base_bytes must be finite and >= 0")
    seconds = _number(record, "seconds") if "seconds" in record else 0.0
    others = _number(record, "others") if record.get("others") is not None else None
    return Calibration(record["host"], record["version"], rates, base, seconds, others)


def cached_calibration(path: Path | None = None) -> tuple[Calibration | None, str]:
    """The cached calibration when it was measured on this host by this package version, else
    None and why not (no file, a corrupt one, another host or version)."""

    path = calibration_path() if path is None else Path(path)
    host = socket.gethostname()
    if not path.exists():
        return None, f"no calibration cached in {path}"
    try:
        cached = read_calibration(path)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"cost calibration {path} ignored: {exc}"
    if cached.host != host or cached.version != __version__:
        return None, (
            f"cost calibration {path} ignored: measured on {cached.host} by hpcontact {cached.version}, "
            f"not {host} / {__version__}"
        )
    return cached, ""


def load_calibration(path: Path | None = None, stream: Any = None) -> Calibration:
    """This machine's calibration: the cached one when it was measured here by this version,
    else a new one (saved for next time; ``stream`` is told). A corrupt or foreign file is
    ignored with a ``RuntimeWarning`` and replaced."""
    path = calibration_path() if path is None else Path(path)
    cached, why = cached_calibration(path)
    if cached is not None:
        return cached
    if path.exists():
        warnings.warn(why, RuntimeWarning, stacklevel=2)
    if stream is not None:
        print(
            f"hpcontact: calibrating the cost model on {socket.gethostname()} (once per host and version; cached in "
            f"{path})",
            file=stream,
            flush=True,
        )
    calibration = calibrate()
    try:
        save_calibration(calibration, path)
    except OSError as exc:
        warnings.warn(f"cost calibration not saved to {path}: {exc}", RuntimeWarning, stacklevel=2)
    return calibration
