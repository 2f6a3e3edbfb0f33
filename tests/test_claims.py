"""docs/claims.md checked row by row (issue 39 item 2): every figure the README and the docs
quote has a row naming its page and section, what reproduces it and a status; this test keeps
the rows true to today's tree without running what they name.

For every row of every table in docs/claims.md:

- each path it names (``tests/…``, ``benchmarks/…``, ``jobs/…``, ``postprocess/…``, ``docs/…``,
  ``README.md``, ``.ci/run``) exists, and each ``python -m MODULE`` it names is importable;
- each test node id (``tests/x.py::test_name``, ``tests/x.py::Class::test_name``, or
  ``::test_name`` for the file named last before it in the row) names a function of that file, found
  by parsing it (``ast``), not by running or importing it;
- in the claim tables (``| figure as stated | where | reproduced by | status |``): the page of
  "where" exists and has the section named after its "§" (a heading, or a bold run-in heading
  as the README's), every excerpt quoted in “…” in the figure appears in that page (spaces,
  ``*`` and backticks ignored), and the status is one of the page's words: ``test``,
  ``test (bound)``, ``benchmark, dated (… YYYY-MM-DD …)`` or ``untested``; a test row names a
  test, a benchmark row a command (``hpcontact …``, ``python -m MODULE``) or a file.

And for the deterministic figures a fast command reproduces, the number every page quotes
equals what the command prints: the task and point counts of the two main jobs' dry runs (~2.5 s
each: a dry run enumerates and estimates, it never solves), the records of ``hpcontact solve``
that the README and the one-scene tutorial print (~3 s), and the adaptive maps' check
probability (arithmetic).
"""

from __future__ import annotations

import ast
import importlib.util
import json
import os
import re
import socket
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CLAIMS = ROOT / "docs" / "claims.md"

CLAIM_HEADER = ("figure as stated", "where", "reproduced by", "status")
STATUS = re.compile(r"^(test \(bound\)|test|benchmark, dated \(.*\d{4}-\d{2}-\d{2}.*\)|untested)(\W|$)", re.S)
PATH = re.compile(r"(?<![\w./-])((?:tests|benchmarks|jobs|postprocess|docs|hpcontact|\.ci)/[\w./-]*\w|README\.md)")
NODE = re.compile(r"(?<![\w.])((?:tests/[\w/]+\.py)?)((?:::\w+)+)")
MODULE = re.compile(r"python -m ([\w.]+)")
QUOTED = re.compile(r"“([^”]+)”")


@dataclass(frozen=True)
class Row:
    """One table row of claims.md: its line number and cells (the header's names as keys)."""

    line: int
    cells: dict[str, str]

    def __str__(self) -> str:
        first = next(iter(self.cells.values()))
        return f"docs/claims.md:{self.line} ({first[:70]}…)"


def _cells(line: str) -> list[str]:
    return [cell.strip() for cell in re.split(r"(?<!\\)\|", line.strip())[1:-1]]


def claim_rows() -> list[Row]:
    """Every body row of every table of docs/claims.md, keyed by its table's header."""
    rows: list[Row] = []
    lines = CLAIMS.read_text(encoding="utf-8").splitlines()
    header: list[str] | None = None
    for number, line in enumerate(lines, start=1):
        if not line.startswith("|"):
            header = None
            continue
        if header is None:
            header = _cells(line)
            continue
        if re.fullmatch(r"\|[\s|:-]+\|", line.strip()):
            continue
        cells = _cells(line)
        assert len(cells) == len(header), f"docs/claims.md:{number}: {len(cells)} cells under a header of {len(header)}"
        rows.append(Row(number, dict(zip(header, cells, strict=True))))
    return rows


ROWS = claim_rows()
CLAIM_ROWS = [row for row in ROWS if tuple(row.cells) == CLAIM_HEADER]


def _normalized(text: str) -> str:
    return " ".join(re.sub(r"[*`]", "", text).split())


@cache
def _test_names(path: Path) -> frozenset[str]:
    """``name`` of every function and ``Class::name`` of every method defined in ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names: set[str] = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            names.add(node.name)
        elif isinstance(node, ast.ClassDef):
            names.update(
                f"{node.name}::{item.name}"
                for item in node.body
                if isinstance(item, ast.FunctionDef | ast.AsyncFunctionDef)
            )
    return frozenset(names)


def _node_ids(cell: str) -> Iterator[tuple[str, str]]:
    """(test file, ``name`` or ``Class::name``) for every node id in ``cell``; ``::name`` refers
    to the test file named last before it in the cell (a row's cells joined, for a row)."""
    current = ""
    for match in NODE.finditer(cell):
        current = match.group(1) or current
        yield current, match.group(2).removeprefix("::")


def _sections(page: Path) -> list[str]:
    text = page.read_text(encoding="utf-8")
    headings = [line.lstrip("#").strip() for line in text.splitlines() if line.startswith("#")]
    return [_normalized(h) for h in headings + re.findall(r"\*\*([^*]+)\*\*", text)]


@pytest.mark.parametrize("row", ROWS, ids=lambda row: str(row.line))
def test_every_named_path_and_test_exists(row: Row) -> None:
    text = " ".join(row.cells.values())
    for path in PATH.findall(text):
        assert (ROOT / path).exists(), f"{row}: {path} does not exist"
    for module in MODULE.findall(text):
        assert importlib.util.find_spec(module) is not None, f"{row}: no module {module}"
    for path, name in _node_ids(" | ".join(row.cells.values())):
        assert path, f"{row}: ::{name} names no test file before it"
        assert (ROOT / path).is_file(), f"{row}: {path} does not exist"
        assert name in _test_names(ROOT / path), f"{row}: {path} has no test {name}"


@pytest.mark.parametrize("row", CLAIM_ROWS, ids=lambda row: str(row.line))
def test_every_claim_names_its_page_section_excerpts_and_status(row: Row) -> None:
    where, reproduced, status = row.cells["where"], row.cells["reproduced by"], row.cells["status"]
    pages = PATH.findall(where)
    assert len(pages) == 1 and pages[0].endswith(".md"), f"{row}: 'where' names no single page"
    page = ROOT / pages[0]
    assert page.is_file(), f"{row}: {pages[0]} does not exist"
    if "§" in where:
        section = _normalized(where.split("§", 1)[1])
        assert any(section in s for s in _sections(page)), f"{row}: {pages[0]} has no section {section!r}"
    quoted_on_page = _normalized(page.read_text(encoding="utf-8"))
    for excerpt in QUOTED.findall(row.cells["figure as stated"].replace("\\|", "|")):
        assert _normalized(excerpt) in quoted_on_page, f"{row}: {pages[0]} no longer says “{excerpt}”"
    assert STATUS.match(status), f"{row}: status {status[:40]!r} is none of the page's words"
    if status.startswith("test"):
        assert any(_node_ids(reproduced)) or "tests/" in reproduced, f"{row}: a test row names no test"
    if status.startswith("benchmark"):
        assert PATH.search(reproduced) or MODULE.search(reproduced) or "hpcontact " in reproduced, (
            f"{row}: a benchmark row names no command"
        )


# The figures that commands reproduce: the dry runs of the main jobs and the records of
# `hpcontact solve` the pages print, all run at once by the fixture `printed`. A dry run reads the
# cost model's calibration but never calibrates here: a calibration file with round numbers is
# written first (as tests/sweep do).


@pytest.fixture(scope="module")
def calibration(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A cost-model calibration for this host and version (1e-6 s per cost unit, 100 MiB base):
    without one, a dry run would spend ~30 s calibrating."""
    from hpcontact import __version__
    from hpcontact.sweep.cost.calibration_file import save_calibration
    from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate

    rates = {kind: Rate(rate_s=1e-6, solve_s=0.0) for kind in KINDS}
    calibration = Calibration(socket.gethostname(), __version__, rates, base_bytes=100.0 * 2**20)
    return save_calibration(calibration, tmp_path_factory.mktemp("costmodel") / "costmodel.json")


@dataclass(frozen=True)
class DryRun:
    """What ``hpcontact run --dry-run --list-all SPEC`` prints: the task count of its first
    line and the scene of every task line."""

    tasks: int
    scenes: list[dict]

    @classmethod
    def parse(cls, output: str) -> DryRun:
        lines = output.splitlines()
        tasks = re.search(r": (\d+) tasks -> ", lines[0])
        assert tasks, f"the dry run's first line names no task count: {lines[0]}"
        return cls(int(tasks[1]), [json.loads(line[line.index("{") :]) for line in lines if not line.startswith("#")])


def _dry_run(spec: str) -> tuple[str, ...]:
    """The arguments of ``hpcontact`` for the dry run of ``spec``, every task listed."""
    return ("run", "--dry-run", "--list-all", spec)


def _solve(arguments: str) -> tuple[str, ...]:
    """The arguments of ``hpcontact`` for ``hpcontact solve ARGUMENTS``."""
    return ("solve", *arguments.split())


@pytest.fixture(scope="module")
def printed(calibration: Path) -> dict[tuple[str, ...], str]:
    """What ``hpcontact ARGUMENTS`` prints, for the dry runs of ``DRY_RUN_SPECS`` and every
    ``hpcontact solve`` console block of ``SOLVE_PAGES``: each in a fresh interpreter, all at once."""
    commands = [_dry_run(spec) for spec in DRY_RUN_SPECS]
    commands += [_solve(arguments) for page in SOLVE_PAGES for arguments, _ in _console_blocks(page)]
    env = {**os.environ, "HPCONTACT_COSTMODEL": str(calibration), "HPCONTACT_MPI": "0"}

    def run(arguments: tuple[str, ...]) -> str:
        command = [sys.executable, "-m", "hpcontact", *arguments]
        return subprocess.run(
            command, cwd=ROOT, env=env, capture_output=True, text=True, timeout=120, check=True
        ).stdout

    unique = list(dict.fromkeys(commands))
    with ThreadPoolExecutor(max_workers=len(unique)) as pool:
        return dict(zip(unique, pool.map(run, unique), strict=True))


def _count(text: str) -> int:
    """``33 300`` → 33300 (the docs group thousands with spaces)."""
    return int(re.sub(r"\s", "", text))


def _axis_lengths(spec: str) -> dict[str, int]:
    """Values per axis of a spec's ``[axes]``: a list's length, the count of a lin/logspace."""
    axes = tomllib.loads((ROOT / spec).read_text(encoding="utf-8"))["axes"]
    return {name: len(axis) if isinstance(axis, list) else next(iter(axis.values()))[2] for name, axis in axes.items()}


def _quoted(pattern: str, pages: tuple[str, ...]) -> list[tuple[str, re.Match[str]]]:
    """Every match of ``pattern`` on the pages (whitespace collapsed); each page must quote it."""
    found = []
    for page in pages:
        matches = list(re.finditer(pattern, " ".join((ROOT / page).read_text(encoding="utf-8").split())))
        assert matches, f"{page} no longer quotes /{pattern}/: drop or change its row in docs/claims.md"
        found += [(page, match) for match in matches]
    return found


DRY_RUN_SPECS = ("jobs/demo.toml", "jobs/demo_map.toml")
DEMO_PAGES = ("README.md", "docs/tutorials/sweep.md", "docs/performance.md")
DEMO_MAP_PAGES = ("README.md", "docs/tutorials/sweep.md")


def test_demo_tasks_and_points_as_quoted(printed: dict[tuple[str, ...], str]) -> None:
    """“396 tasks for 33 300 points”: the dry run's task count, and the product of the spec's
    axes (the points of the data set); “5 b/a × 3 nu (× 3 A × 5 ψ) points”: the spec's axes."""
    tasks = DryRun.parse(printed[_dry_run("jobs/demo.toml")]).tasks
    points = 1
    for length in _axis_lengths("jobs/demo.toml").values():
        points *= length
    for page, match in _quoted(r"(\d[\d ]*\d|\d) tasks for (\d[\d ]*\d) points", DEMO_PAGES):
        assert (_count(match[1]), _count(match[2])) == (tasks, points), (
            f"{page}: “{match[0]}”, the dry run: {tasks}, {points}"
        )


def test_demo_map_points_as_quoted(printed: dict[tuple[str, ...], str]) -> None:
    """“65 b/a × 21 nu” and “of the 1 365 points” of the dense map: the distinct b/a and nu of
    the dry run's tasks, and their number."""
    report = DryRun.parse(printed[_dry_run("jobs/demo_map.toml")])
    aspects = len({scene["aspect"] for scene in report.scenes})
    nus = len({scene["nu"] for scene in report.scenes})
    for page, match in _quoted(r"(\d+) b/a × (\d+) nu(?! \(×)", DEMO_MAP_PAGES):
        assert (int(match[1]), int(match[2])) == (aspects, nus), f"{page}: “{match[0]}”, the dry run: {aspects} × {nus}"
    for page, match in _quoted(r"solves of the (\d[\d ]*\d) points", ("docs/tutorials/sweep.md",)):
        assert _count(match[1]) == report.tasks == aspects * nus, f"{page}: “{match[0]}”, the dry run: {report.tasks}"


# The record of one scene as the pages print it: the command of each console block is run, and
# every line of the block whose value does not move with rounding (the CG's noise in K_xy, K_yx,
# the residual, the iteration count, an estimate at round-off, the wall time) must be printed so.

STABLE_KEYS = frozenset(
    "nx ny dx dy contact_cells K_xx K_yy K_zz K_max K_min K_a_over_K_b K_min_over_K_max normalized_xx normalized_yy"
    " boundary accuracy accuracy_met stopped_by grids plan.kernel_source plan.kernels plan.solves".split()
)
SOLVE_PAGES = ("README.md", "docs/tutorials/one-scene.md")


def _console_blocks(page: str) -> Iterator[tuple[str, dict[str, str]]]:
    """(arguments, name → value) of every ``$ … hpcontact solve …`` console block of ``page``
    that prints a record."""
    text = (ROOT / page).read_text(encoding="utf-8")
    for block in re.findall(r"```console\n(.*?)```", text, re.S):
        first, *lines = block.splitlines()
        command = re.match(r"\$ (?:\.venv/bin/)?hpcontact solve (.+)", first)
        record = dict(line.split(None, 1) for line in lines if re.match(r"\s+\S+\s+\S", line))
        if command and record:
            yield command[1], record


@pytest.mark.parametrize("page", SOLVE_PAGES)
def test_the_printed_records_are_what_the_commands_print(page: str, printed: dict[tuple[str, ...], str]) -> None:
    """“K_xx  1.958717286” and the other values of a record that do not move with rounding."""
    blocks = list(_console_blocks(page))
    assert blocks, f"{page} no longer prints a record of hpcontact solve: drop its row in docs/claims.md"
    for arguments, quoted in blocks:
        record = dict(line.split(None, 1) for line in printed[_solve(arguments)].splitlines() if line.strip())
        for name in STABLE_KEYS & quoted.keys():
            assert record[name].split()[0] == quoted[name].split()[0], (
                f"{page}: hpcontact solve {arguments}: {name} quoted {quoted[name]}, printed {record[name]}"
            )


def test_check_pass_probability_as_quoted() -> None:
    """“(1 − p)^30 (4 % for p = 10 %)”: the chance that 30 random checks all miss a fraction p
    of a map where the estimate is short, at the quoted precision."""
    for page, match in _quoted(r"\(1 − p\)\^(\d+) \((\d+) % for p = (\d+) %\)", ("docs/howto/adaptive.md",)):
        checks, quoted, share = map(int, match.groups())
        assert round(100 * (1 - share / 100) ** checks) == quoted, f"{page}: “{match[0]}”"
