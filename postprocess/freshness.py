"""Up-to-date check of the figure scripts: run again with nothing changed, a script draws nothing.

A script that reads a data set and writes figures into an output folder leaves a stamp
``OUTDIR/.<script>.stamp.json`` once its last figure is saved (``stamp``): its arguments and
working directory, a hash of the code that draws (the script, ``common.py``, this module and the
``hpcontact`` package it reads and solves with), and the size, mtime and inode of each input
(the data set) and of each file it wrote (``common.save`` reports them through ``wrote``). Run
again, the script first compares that stamp with the files as they are (``exit_if_fresh``, at
its top, before matplotlib, xarray and hpcontact are imported: those imports and the drawing
take seconds); when everything agrees it prints one line and exits 0. ``--force`` redraws.

The previous stamp is removed before the drawing starts and the new one is written atomically
(a temporary file renamed over it) after the last figure, so a failed or interrupted run leaves
no stamp and the next run draws again. A sweep that finds its data set up to date leaves the
file untouched, and one that writes it replaces it (new inode and mtime): the stamp tells
the two apart. This module uses the standard library only, so the check stays well under a
second.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import importlib.util
import json
import os
import sys
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import NoReturn

FORCE = "--force"
VERSION = 1  # of the stamp's layout
MAX_STAMP_BYTES = 2**20  # a stamp holds a few paths and signatures: a larger file is none
HERE = Path(__file__).resolve().parent
SHARED = ("common.py", "freshness.py")  # modules of postprocess/ every script draws with

_collectors: list[list[Path]] = []  # files written under the open ``stamp`` blocks, innermost last


def add_force(parser: argparse.ArgumentParser) -> None:
    """The ``--force`` option: draw even when the stamp says the figures are up to date."""
    parser.add_argument(FORCE, action="store_true", help="redraw even when the figures are up to date with the inputs")


def exit_if_fresh(script: str | os.PathLike, argv: Sequence[str] | None = None) -> None:
    """Print one line and exit 0 when ``script``'s figures are up to date; else return.

    Up to date: a stamp lies in one of the arguments ``argv`` (default ``sys.argv[1:]``; the
    output folder is the argument holding the stamp, so no parser is needed here) and it matches
    this run: the same arguments (``--force`` aside) and working directory, the same code, each
    input and each written file unchanged. ``--force`` (or an abbreviation argparse accepts)
    skips the check."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if any(_is_force(a) for a in _options(argv)):
        return
    for outdir in argv:
        path = stamp_path(script, outdir)
        try:
            if path.stat().st_size > MAX_STAMP_BYTES:
                continue
            recorded = json.loads(path.read_text(encoding="utf-8"))
            inputs, outputs = list(recorded["inputs"]), list(recorded["outputs"])
        except (OSError, ValueError, TypeError, KeyError, RecursionError):  # no stamp, or none of ours: draw
            continue
        if outputs and recorded == _record(script, argv, outdir, inputs, outputs):
            print(f"{sys.argv[0]}: figures in {outdir} up to date with {', '.join(inputs)} ({FORCE} redraws)")
            raise SystemExit(0)


@contextlib.contextmanager
def stamp(
    script: str | os.PathLike,
    outdir: str | os.PathLike,
    inputs: Iterable[str | os.PathLike | None],
    argv: Sequence[str] | None = None,
) -> Iterator[None]:
    """Write ``script``'s stamp into ``outdir`` when the block ends without an error.

    The block draws: every file reported by ``wrote`` inside it is recorded with ``inputs``
    (the data set and any other file read; ``None`` entries are skipped) and the arguments
    ``argv`` (default ``sys.argv[1:]``). The old stamp is removed on entry, so a block that
    raises (or is interrupted) leaves none. An old stamp that cannot be removed (a folder in its
    place, a read-only folder) stops the script before the block: one line on stderr, exit
    status 2."""
    argv = sys.argv[1:] if argv is None else list(argv)
    path = stamp_path(script, outdir)
    try:
        path.unlink(missing_ok=True)
    except OSError as exc:
        refuse(f"{path}: cannot remove the old stamp ({exc.strerror or type(exc).__name__}); remove it and run again")
    written: list[Path] = []
    _collectors.append(written)
    try:
        yield
    finally:
        _collectors.pop()
    record = _record(script, argv, outdir, [str(p) for p in inputs if p is not None], [str(p) for p in written])
    temporary = path.with_name(f"{path.name}.{os.getpid()}.tmp")  # open() honours the umask, as for the figures
    try:
        with open(temporary, "w", encoding="utf-8") as file:
            json.dump(record, file, indent=1)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def refuse(message: str) -> NoReturn:
    """Stop the script on input it cannot use: one line on stderr, exit status 2 (bad input, as
    ``hpcontact``'s own commands), no traceback, no figure (``common.refuse`` for the drawing
    scripts)."""
    print(f"{Path(sys.argv[0]).name}: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def wrote(path: str | os.PathLike) -> None:
    """Note a file the running script has written (``common.save`` calls it for every figure)."""
    if _collectors:
        _collectors[-1].append(Path(path))


def stamp_path(script: str | os.PathLike, outdir: str | os.PathLike) -> Path:
    """Where ``script`` keeps its stamp in ``outdir``: ``OUTDIR/.<script>.stamp.json``."""
    return Path(outdir) / f".{Path(script).stem}.stamp.json"


def _record(
    script: str | os.PathLike, argv: list[str], outdir: str | os.PathLike, inputs: list[str], outputs: list[str]
) -> dict:
    """The stamp of a run as the files are now (a missing file's signature is ``None``)."""
    return {
        "version": VERSION,
        "script": Path(script).name,
        "argv": [a for a in argv if not _is_force(a)],
        "cwd": os.getcwd(),
        "outdir": str(Path(outdir)),  # as argparse's Path gives it: "figures/" is "figures"
        "code": _code_hash(Path(script)),
        "inputs": {p: _signature(p) for p in inputs},
        "outputs": {p: _signature(p) for p in dict.fromkeys(outputs)},
    }


def _signature(path: str) -> list[int] | None:
    """Size, mtime (ns) and inode of ``path``: a rewrite, even atomic and of the same size, changes it."""
    try:
        info = os.stat(path)
    except OSError:
        return None
    return [info.st_size, info.st_mtime_ns, info.st_ino]


def _code_hash(script: Path) -> str:
    """SHA-256 over the text of the script, the shared modules and the ``hpcontact`` package's
    Python files (found without importing it), so that editing any code that draws redraws."""
    files = [script, *(HERE / name for name in SHARED)]
    spec = importlib.util.find_spec("hpcontact")
    for folder in (spec.submodule_search_locations or []) if spec else []:
        files += sorted(Path(folder).rglob("*.py"))
    digest = hashlib.sha256()
    for path in files:
        try:
            text = path.read_bytes()
        except OSError:
            text = b""
        digest.update(len(text).to_bytes(8, "little") + text)
    return digest.hexdigest()


def _options(argv: list[str]) -> list[str]:
    """The arguments before ``--`` (after it, everything is a positional argument)."""
    return argv[: argv.index("--")] if "--" in argv else argv


def _is_force(argument: str) -> bool:
    """``--force`` or a prefix argparse resolves to it (``--forc``; ``--for`` also fits ``--format``)."""
    return len(argument) >= len("--forc") and FORCE.startswith(argument)
