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
  ``test (bound)``, ``regenerated``, ``benchmark, dated (…)`` or ``one-off, dated (…)``; a test
  row names a test, a regenerated row its check of ``benchmarks/check_claims.py`` (which has
  it), a benchmark row a command (``hpcontact …``, ``python -m MODULE``) or a file; a
  benchmark's parenthesis names a date and the machine, a one-off's a date, the machine and a
  commit of this history; no status says ``untested``.

And for the deterministic figures a fast command reproduces, the number every page quotes
equals what the command prints: the task and point counts of the two main jobs' dry runs (~2.5 s
each: a dry run enumerates and estimates, it never solves), the records of ``hpcontact solve``
that the README and the one-scene tutorial print (~3 s), the triangle and the square at
``--accuracy 1e-3`` (~1.3 s each), the sweep tutorial's interpolation miss against Mindlin's
closed form and the adaptive maps' check probability (arithmetic). The slower regenerated
figures are ``benchmarks/check_claims.py``'s (minutes: the dense map, the main job).
"""

from __future__ import annotations

import ast
import importlib.util
import json
import math
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

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
CLAIMS = ROOT / "docs" / "claims.md"

CLAIM_HEADER = ("figure as stated", "where", "reproduced by", "status")
STATUS = re.compile(
    r"^(test \(bound\)|test|regenerated|benchmark, dated \(.*\d{4}-\d{2}-\d{2}.*\)|one-off, dated \(.*\))(\W|$)", re.S
)
#: A one-off figure's parenthesis: its date, the machine and the commit (issue 39 item 2); a
#: benchmark's: its date and the machine.
ONE_OFF = re.compile(r"one-off, dated \(((?:[^()]|\([^()]*\))*)\)")
BENCHMARK = re.compile(r"^benchmark, dated \(((?:[^()]|\([^()]*\))*)\)")
DATE = re.compile(r"\d{4}-\d{2}-\d{2}")
MACHINE = re.compile(r"EPYC|Xeon|VM\b|machine(?!-dependent)|CI\b")
COMMIT = re.compile(r"\b[0-9a-f]{7,40}\b")
#: ``benchmarks/check_claims.py --check NAME`` in a regenerated row: the script's check of it.
CHECK = re.compile(r"benchmarks/check_claims\.py --check (\w+)")
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


@cache
def _known_commit(commit: str) -> bool:
    """Whether ``commit`` is a commit of this checkout's history (true where there is no full
    history to look in: no git, a shallow clone)."""

    def git(*arguments: str) -> subprocess.CompletedProcess:
        return subprocess.run(["git", "-C", str(ROOT), *arguments], capture_output=True, text=True, check=False)

    try:
        shallow = git("rev-parse", "--is-shallow-repository")
    except FileNotFoundError:
        return True
    if shallow.returncode != 0 or shallow.stdout.strip() != "false":
        return True
    return git("cat-file", "-e", f"{commit}^{{commit}}").returncode == 0


@cache
def _claim_checks() -> frozenset[str]:
    """The names of ``benchmarks/check_claims.py``'s checks (its module loaded, nothing run)."""
    spec = importlib.util.spec_from_file_location("check_claims", ROOT / "benchmarks" / "check_claims.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # as an import would: dataclasses look their module up
    spec.loader.exec_module(module)
    return frozenset(module.CHECKS)


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
    assert "untested" not in status, f"{row}: a figure is untested: name a test or a command, or date it as a one-off"
    for dated in BENCHMARK.findall(status):
        assert MACHINE.search(dated), f"{row}: a benchmark names its machine"
    for one_off in ONE_OFF.findall(status):
        assert DATE.search(one_off) and MACHINE.search(one_off), f"{row}: a one-off names its date and machine"
        commits = COMMIT.findall(one_off)
        assert commits and all(map(_known_commit, commits)), f"{row}: a one-off names a commit of this history"
    if status.startswith("regenerated"):
        names = CHECK.findall(reproduced)
        assert names, f"{row}: a regenerated row names its check: benchmarks/check_claims.py --check NAME"
        assert set(names) <= _claim_checks(), (
            f"{row}: benchmarks/check_claims.py has no check {set(names) - _claim_checks()}"
        )
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
    commands = [_dry_run(spec) for spec in DRY_RUN_SPECS] + [_solve(arguments) for arguments in ACCURACY_SOLVES]
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


def at_quoted_precision(quoted: str, value: float) -> bool:
    """Whether ``value`` rounds to ``quoted`` at its precision: as many decimals of the mantissa
    as ``3.32e-4`` has (scientific), or as ``0.077`` has (fixed)."""
    mantissa, _, exponent = quoted.partition("e")
    decimals = len(mantissa.partition(".")[2])
    shown = f"{value:.{decimals}e}" if exponent else f"{value:.{decimals}f}"
    return float(shown) == float(quoted)


def test_interpolation_between_the_main_jobs_points_as_quoted() -> None:
    """“by up to 0.077 (10 % relative, at b/a ≈ 0.14, nu = 0.45”: the ellipse's K_a/K_b
    interpolated bilinearly in log b/a and nu from the main job's 5 b/a × 3 nu points against
    Mindlin's closed form (``hpcontact.analytic``, tested against mpmath in tests/test_analytic.py)
    on an 801 × 91 grid over the same ranges."""
    from scipy.interpolate import RegularGridInterpolator

    from hpcontact.analytic import mindlin_ellipse_stiffness_ratio

    axes = tomllib.loads((ROOT / "jobs/demo.toml").read_text(encoding="utf-8"))["axes"]
    start, stop, count = axes["aspect"]["logspace"]
    log_aspects, nus = np.linspace(start, stop, count)[::-1], np.array(axes["nu"], dtype=np.float64)
    at_points = mindlin_ellipse_stiffness_ratio(10.0 ** log_aspects[:, None], nus[None, :])
    fine_log, fine_nu = np.linspace(stop, start, 801), np.linspace(nus[0], nus[-1], 91)
    grid = np.stack(np.meshgrid(fine_log, fine_nu, indexing="ij"), axis=-1)
    interpolated = RegularGridInterpolator((log_aspects, nus), at_points)(grid)
    exact = mindlin_ellipse_stiffness_ratio(10.0 ** fine_log[:, None], fine_nu[None, :])
    worst = np.unravel_index(np.argmax(np.abs(interpolated - exact)), exact.shape)
    miss = abs(interpolated[worst] - exact[worst])
    pattern = r"by up to (\S+) \((\d+) % relative, at b/a ≈ (\S+), nu = ([\d.]+)"
    for page, match in _quoted(pattern, ("docs/tutorials/sweep.md",)):
        computed = (miss, 100.0 * miss / exact[worst], 10.0 ** fine_log[worst[0]], fine_nu[worst[1]])
        assert all(map(at_quoted_precision, match.groups(), computed)), f"{page}: “{match[0]}”, computed {computed}"


# `hpcontact solve --accuracy 1e-3` of the triangle and the square that docs/validation.md and
# docs/performance.md quote (~1.3 s of CPU each, run with the dry runs by ``printed``).
TRIANGLE = "--shape polygon --sides 3 --nu 0.3 --accuracy 1e-3 --quantities tangential,normal --json"
SQUARE = "--shape rectangle --aspect 1 --nu 0.3 --accuracy 1e-3 --quantities tangential,normal --json"
ACCURACY_SOLVES = (TRIANGLE, SQUARE)


def test_the_triangle_at_1e_3_as_quoted(printed: dict[tuple[str, ...], str]) -> None:
    """“stops on grids 16 … 128 (× 14 … 112) with an estimate of 3.32e-4”: the record's grids
    along and across and its ``estimated_error``."""
    record = json.loads(printed[_solve(TRIANGLE)])
    pattern = r"stops on grids (\d+) … (\d+) \(× (\d+) … (\d+)\) with an estimate of (\S+) "
    for page, match in _quoted(pattern, ("docs/validation.md",)):
        grids = (record["grids"][0], record["grids"][-1], record["grids_across"][0], record["grids_across"][-1])
        assert tuple(map(int, match.groups()[:4])) == grids, f"{page}: “{match[0]}”, the record's grids {grids}"
        assert at_quoted_precision(match[5], record["estimated_error"]), (
            f"{page}: “{match[0]}”, {record['estimated_error']}"
        )


def test_the_square_against_its_capacitance_as_quoted(printed: dict[tuple[str, ...], str]) -> None:
    """“the square's capacitance: true 4.6e-5 against 2.9e-4”: the square's K_zz at 1e-3
    against π E* C̃ (C̃ = 2 × 0.3667874, the unit square plate's capacitance, Hwang & Mascagni
    2004; E* = 2G/(1 − nu), G = 1, half-side 1), and its estimate for K_zz."""
    record = json.loads(printed[_solve(SQUARE)])
    exact = math.pi * 2.0 / (1.0 - 0.3) * 2.0 * 0.3667874
    true, estimate = abs(record["K_zz"] / exact - 1.0), record["estimated_errors"]["K_zz"]
    for page, match in _quoted(r"the square's capacitance: true (\S+) against (\S+)\)", ("docs/performance.md",)):
        assert at_quoted_precision(match[1], true), f"{page}: “{match[0]}”, computed {true}"
        assert at_quoted_precision(match[2], estimate), f"{page}: “{match[0]}”, the record's {estimate}"
