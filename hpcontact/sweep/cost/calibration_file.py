"""The cost model's calibration cached in a file, like FFTW wisdom: saved, read, checked, loaded.

The calibration takes 12-30 s (12.0 s alone on the 2-core development machine, 28 s beside
other work) and is cached beside the wisdom file in ``costmodel-CPU-Nc.json``, one file per node
type (CPU model and core count, ``rates.node_type``), not per host: the nodes of one type share
it where they share a home folder. A cache of another node type or package version, or one that
cannot be read as a calibration, is ignored with a warning and replaced. A file its user names
($HPCONTACT_COSTMODEL, ``hpcontact run --costmodel FILE``) is used as it is, whoever made it,
and the lines that use it say whose it is (``Calibration.whose``) and if its CPU is another.

What a run's start line uses when nothing is cached is ``cost.prior.run_calibration``: the
shipped prior scaled by a probe of this machine (under a second), never a calibration a run would
wait for.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
import warnings
from collections.abc import Mapping
from dataclasses import asdict
from pathlib import Path
from typing import Any

from hpcontact import __version__
from hpcontact.numerics.memory import GpuMemory, gpu_memory
from hpcontact.sweep.cost.calibration import calibrate
from hpcontact.sweep.cost.rates import (
    KINDS,
    Calibration,
    Rate,
    calibration_path,
    gpu_calibration_path,
    named_calibration_path,
    node_type,
)

# version of the calibration file's layout (2: node_s, Barnett–Lothe; 3: cell_s, kernels; 4: task_s; 5: strip_s;
# 6: exact_s; 7: every solve under the sweep's BLAS limit, older files' rates 2-3x high; 8: cpu, cores, date)
FORMAT = 8
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
    than ``CALIBRATION_BYTES``, JSON nested deeper than ``CALIBRATION_DEPTH``, or not a
    ``calibration_from_record``)."""
    data = _calibration_bytes(Path(path))
    if _json_depth(data) > CALIBRATION_DEPTH:
        raise ValueError(f"JSON nested deeper than {CALIBRATION_DEPTH}")
    return calibration_from_record(json.loads(data.decode("utf-8")))


def calibration_from_record(record: Any) -> Calibration:
    """The calibration a file's JSON ``record`` holds; ``ValueError`` if it is not one (wrong
    format, missing, non-numeric or non-finite numbers, a negative rate, no host, version, CPU,
    core count or date)."""
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        raise ValueError("not a calibration file of this format")
    if not isinstance(record.get("rates"), dict) or not all(
        isinstance(record.get(k), str) for k in ("host", "version", "cpu", "date")
    ):
        raise ValueError("rates, cpu, date, host and version missing")
    cores = record.get("cores")
    if isinstance(cores, bool) or not isinstance(cores, int) or cores < 1:
        raise ValueError("cores must be an integer >= 1")
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
    return Calibration(
        record["host"], record["version"], rates, base, seconds, others, record["cpu"], cores, record["date"]
    )


def cached_calibration(path: Path | None = None) -> tuple[Calibration | None, str]:
    """The calibration a run uses without calibrating, and a note; or None and why not.

    A file its user named (``path``, $HPCONTACT_COSTMODEL) is used whoever made it, the note
    saying whose it is and, when its CPU or core count is not this machine's, that too. The
    cache of this node type (``rates.calibration_path``) is used when its CPU model, core count
    and package version are this machine's and this package's (the host does not matter);
    else None, and why (no file, a corrupt one, another node type or version)."""
    named = Path(path) if path is not None else named_calibration_path()
    path = named if named is not None else calibration_path()
    if not path.exists():
        return None, f"no calibration cached in {path}"
    try:
        cached = read_calibration(path)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"cost calibration {path} ignored: {exc}"
    cpu, cores = node_type()
    if named is None and ((cached.cpu, cached.cores) != (cpu, cores) or cached.version != __version__):
        return None, (
            f"cost calibration {path} ignored: measured on {cached.cpu}, {cached.cores} cores by hpcontact "
            f"{cached.version}, not {cpu}, {cores} cores / {__version__}"
        )
    return cached, described(cached)


def gpu_calibration(gpu: GpuMemory) -> tuple[Calibration | None, str]:
    """The cost model of tasks on the GPU ``gpu`` (``rates.gpu_calibration_path``, made by this
    package's version) and whose it is, in words; or None and, in words, that there is no
    calibration for this GPU (none is made here: GPU seconds are never derived from a CPU's)."""
    path = gpu_calibration_path(gpu)
    if not path.exists():
        return None, f"no calibration for this GPU ({gpu.label}; none in {path}: calibrate_gpu() makes it)"
    try:
        cached = read_calibration(path)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, f"no calibration for this GPU ({gpu.label}; {path} ignored: {exc})"
    if cached.version != __version__:
        return None, f"no calibration for this GPU ({gpu.label}; {path} is hpcontact {cached.version}'s)"
    return cached, f"cost model of {gpu.label} on {cached.host}, {cached.date}, hpcontact {cached.version}"


def calibrate_gpu(stream: Any = None) -> Path:
    """Calibrate the cost model on this rank's GPU (``calibration.calibrate`` with device "gpu":
    wall seconds of each calibration scene solved alone on it; a batch's scenes take less each,
    not measured yet) and save it where ``gpu_calibration`` reads it (``rates.gpu_calibration_path``);
    ``stream`` is told. ``InputError`` on ``device`` where there is no GPU."""
    gpu = gpu_memory()
    path = gpu_calibration_path(gpu)
    if stream is not None:
        print(f"hpcontact: calibrating the cost model on {gpu.label} (saved in {path})", file=stream, flush=True)
    return save_calibration(calibrate(device="gpu"), path)


def described(calibration: Calibration) -> str:
    """Whose cost model an estimate uses, in words (``Calibration.whose``), and, when its CPU
    or core count is not this machine's, that too."""
    cpu, cores = node_type()
    if (calibration.cpu, calibration.cores) == (cpu, cores):
        return f"cost model of {calibration.whose()}"
    return f"cost model of {calibration.whose()}; not this {cpu}, {cores} cores: estimates may be off"


def load_calibration(path: Path | None = None, stream: Any = None) -> Calibration:
    """This machine's calibration: ``cached_calibration``'s when there is one, else a new one
    (saved for next time; ``stream`` is told). A corrupt file, or a cache of another node
    type or version, is ignored with a ``RuntimeWarning`` and replaced."""
    cached, why = cached_calibration(path)
    if cached is not None:
        return cached
    path = path if path is not None else calibration_path()
    if path.exists():
        warnings.warn(why, RuntimeWarning, stacklevel=2)
    if stream is not None:
        cpu, cores = node_type()
        print(
            f"hpcontact: calibrating the cost model on this {cpu} with {cores} cores (12-30 s, once per node type "
            f"and version; cached in {path})",
            file=stream,
            flush=True,
        )
    calibration = calibrate()
    try:
        save_calibration(calibration, path)
    except OSError as exc:
        warnings.warn(f"cost calibration not saved to {path}: {exc}", RuntimeWarning, stacklevel=2)
    return calibration
