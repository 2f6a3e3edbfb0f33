"""Where a result came from: package version, git revision, numerics fingerprint, resolved scene;
and the check that refuses to reuse journal entries computed by other code (``--accept-stale``).

A task's key names its parameters as the spec gives them (``tasks.task_key``), which leave the
engine's defaults out; the journal entry therefore also carries the *resolved* scene, every
default filled in (contact scenes: ``hpcontact.scene.DEFAULTS`` under the given fields; slip
scenes: the fields of the validated ``SlipScene``), so an entry whose resolved scene differs
from the current one (a changed default) is not the same task and is computed again. The
fingerprint covers what else decides the numbers besides the package's own code: the versions of
numpy, scipy and pyFFTW and the machine architecture.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import platform
import shlex
import subprocess
import sys
from collections.abc import Iterable, Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from typing import Any

import hpcontact
from hpcontact import __version__
from hpcontact.problems.kinds import kind_of
from hpcontact.sweep.data.journal import Entry, to_json

REVISION_VARIABLE = "HPCONTACT_GIT_REVISION"  # overrides the detected revision (installs without .git)
FIELDS = ("hpcontact_version", "git_revision", "numerics")
NAMES = {"hpcontact_version": "package version", "git_revision": "git revision", "numerics": "numerics fingerprint"}


def git_revision() -> str | None:
    """The commit of the source checkout hpcontact runs from, ``-dirty`` when tracked files have
    changes; ``$HPCONTACT_GIT_REVISION`` when set; None outside a checkout."""
    forced = os.environ.get(REVISION_VARIABLE)
    if forced:
        return forced
    root = Path(hpcontact.__file__).resolve().parents[1]  # the checkout that holds the package
    if not (root / ".git").exists():
        return None
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10, check=True
        ).stdout.strip()
        changes = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=30,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{head}-dirty" if head and changes else head or None


@lru_cache(maxsize=1)
def numerics() -> dict[str, str]:
    """The libraries and machine that produce the numbers besides hpcontact itself."""
    import numpy
    import scipy

    from hpcontact.numerics.convolution import pyfftw  # imported as the engine imports it

    return {
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
        "pyfftw": pyfftw.__version__,
        "machine": platform.machine(),
    }


def fingerprint(settings: Mapping[str, Any]) -> str:
    """A short stable hash (12 hex digits of SHA-1) of ``settings``."""
    return hashlib.sha1(to_json(settings).encode("utf-8")).hexdigest()[:12]


def current() -> dict[str, Any]:
    """The provenance of this process: package version, git revision, numerics fingerprint."""
    return {"hpcontact_version": __version__, "git_revision": git_revision(), "numerics": fingerprint(numerics())}


def resolved_scene(params: Mapping[str, Any]) -> dict[str, Any]:
    """The scene ``params`` with every default filled in (``Kind.resolve``, see the module
    docstring), as its JSON reads back."""
    return json.loads(to_json(kind_of(params).resolve(params)))


def describe(provenance: Mapping[str, Any]) -> str:
    """``hpcontact 0.1.0 (git abc123-dirty, numerics 0123456789ab)``."""
    return (
        f"hpcontact {provenance.get('hpcontact_version')} (git {provenance.get('git_revision') or 'unknown'}, "
        f"numerics {provenance.get('numerics')})"
    )


def first_mismatch(entries: Iterable[Entry], now: Mapping[str, Any]) -> str | None:
    """A one-line description of the first entry computed by other code than ``now``, or None."""
    for entry in entries:
        for name in FIELDS:
            if entry.provenance.get(name) != now.get(name):
                return (
                    f"task {entry.key[:12]} was computed by {describe(entry.provenance)} on {entry.host or '?'}, "
                    f"rank {entry.rank}; this is {describe(now)} (first difference: {NAMES[name]})"
                )
    return None


def contributors(entries: Iterable[Entry]) -> str:
    """JSON list of every provenance that computed the given entries, with its task count."""
    counts: dict[str, int] = {}
    for entry in entries:
        text = to_json({name: entry.provenance.get(name) for name in FIELDS})
        counts[text] = counts.get(text, 0) + 1
    return json.dumps([{**json.loads(text), "tasks": n} for text, n in sorted(counts.items())], sort_keys=True)


def command_line(program: str, argv: Sequence[str] | None = None) -> str:
    """A command-line entry point's command as its user typed it, for a data set's history:
    ``program`` and ``argv`` (``main(argv)`` called with arguments), or, with ``argv`` None, this
    process's own command line: its arguments ``sys.argv[1:]`` after the program that started it
    (``python -m <module>`` for a module of this package run as a script, else the script's
    name, ``hpcontact`` for the console command; ``program`` when neither is known)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if argv is None and sys.argv and sys.argv[0]:
        program = _program(sys.argv[0], program)
    return " ".join([program, shlex.join(map(str, args))]).strip()


def _program(argv0: str, default: str) -> str:
    """How the process was started: ``python -m <module>`` for a module of this package run as
    a script, else the name of the script (``hpcontact``: the console command)."""
    path = Path(argv0).resolve()
    package = Path(hpcontact.__file__).resolve().parent
    if path.suffix == ".py" and path.is_relative_to(package):
        parts = path.relative_to(package.parent).with_suffix("").parts
        return "python -m " + ".".join(parts[:-1] if parts[-1] == "__main__" else parts)
    return Path(argv0).name or default


def call_text(name: str, function: Any, values: Mapping[str, Any]) -> str:
    """A Python entry point's call as its user wrote it, for a data set's history:
    ``name(arguments)``, the arguments of a call of ``function`` (``values``: its parameters,
    ``locals()`` on entry) that differ from their defaults, positional ones first; streams left
    out ("hpcontact.run_sweep('jobs/demo.toml', resume=True)")."""
    shown = []
    for parameter in inspect.signature(function).parameters.values():
        if parameter.name not in values or parameter.name == "stream":
            continue
        value = values[parameter.name]
        if parameter.default is not inspect.Parameter.empty and value is parameter.default:
            continue
        if (
            parameter.default is not inspect.Parameter.empty
            and isinstance(value, (bool, int, float, str))
            and value == parameter.default
        ):
            continue
        text = _argument_text(value)
        no_default = parameter.default is inspect.Parameter.empty
        shown.append(
            text if no_default and parameter.kind is parameter.POSITIONAL_OR_KEYWORD else f"{parameter.name}={text}"
        )
    return f"{name}({', '.join(shown)})"


def _argument_text(value: Any) -> str:
    """An argument as it reads in a call: paths as strings, functions by name, a spec dict
    in full (its JSON), other objects by their type."""
    if isinstance(value, os.PathLike):
        return repr(os.fspath(value))
    if value is None or isinstance(value, (bool, int, float, str)):
        return repr(value)
    if isinstance(value, Mapping):
        return json.dumps(value, sort_keys=True, default=str)
    if callable(value) and hasattr(value, "__qualname__"):
        return value.__qualname__
    return f"{type(value).__name__}(...)"
