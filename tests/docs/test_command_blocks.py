"""Every command block of the README and of docs/ runs as written (issue 42 item 5).

A page's commands are the lines of its ``bash``/``sh``/``shell`` blocks and the ``$ `` lines of
its ``console`` blocks (continuation lines joined, comments dropped). For every page:

- **as written**: each simple command of a line (split at ``&&``, ``||``, ``;``, ``|``, in a
  ``for`` loop too) starts with the venv's ``.venv/bin/…``, with a command the system or the
  cluster provides (``python3`` to make the venv, ``module``, ``sbatch``, ``srun``, ``mpirun``,
  ``which``), or with a shell builtin; a bare ``hpcontact``, ``python``, ``pip`` or ``mpiexec``
  only on a page that activates the venv first (``. .venv/bin/activate`` in a block above it).
  After the README's install, a bare ``hpcontact`` is "command not found".
- **no hidden commands**: an indented code block whose lines start with a command is refused
  (it is not a ``bash`` block, so nothing would check it).
- **classified**: each command line is run by this test (``RUN``) or listed in ``NOT_RUN`` with
  why; a new command on a page fails here until it is put in one of them.
- **run**: the ``RUN`` commands run in a temporary folder that links the checkout's ``.venv``,
  ``jobs`` and ``postprocess`` (what they write lands there), with a cost calibration of round
  numbers so that a dry run does not spend ~30 s calibrating. Each must exit 0, or, in a
  ``console`` block that prints an error, exit 2 with the printed line on stderr. The records
  that console blocks print are compared by
  ``tests/test_claims.py::test_the_printed_records_are_what_the_commands_print`` (it runs them).
  A page whose commands read a file that its Python blocks write (``SETUP_BLOCKS``) gets those
  blocks run first.
"""

from __future__ import annotations

import os
import re
import shlex
import socket
import subprocess
import sys
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest
from markdown_it import MarkdownIt

ROOT = Path(__file__).resolve().parents[2]
SHELL_LANGUAGES = {"bash", "sh", "shell", "console"}
GENERATED = (ROOT / "docs" / "_build", ROOT / "docs" / "reference" / "modules")
ACTIVATE = re.compile(r"^(?:\.|source) \.venv/bin/activate$")
# What a fresh clone's shell has without the venv: the system's python3 (to make the venv), the
# cluster's commands, and shell builtins.
SYSTEM = frozenset({"python3", "module", "sbatch", "srun", "mpirun", "which"})
BUILTINS = frozenset({"cd", "exit", "echo", "export", ".", "source"})
VENV_ONLY = frozenset({"hpcontact", "python", "pip", "mpiexec", "sphinx-build", "ruff", "pytest"})
KEYWORDS = frozenset({"do", "then", "else", "done", "fi"})
SEPARATORS = frozenset({"&&", "||", ";", "|", "&"})


def pages() -> list[Path]:
    found = [ROOT / "README.md"] + sorted((ROOT / "docs").rglob("*.md"))
    return [page for page in found if not any(page.is_relative_to(folder) for folder in GENERATED)]


def _name(page: Path) -> str:
    return page.relative_to(ROOT).as_posix()


@dataclass(frozen=True)
class Command:
    """One command line of a page: its text, whether a console block shows it with a ``$``
    prompt, and the lines that block prints after it."""

    page: str
    text: str
    printed: tuple[str, ...] = ()


def _without_comment(line: str) -> str:
    """``line`` without its trailing ``# comment`` (a ``#`` outside quotes, after a blank)."""
    quote = ""
    for index, char in enumerate(line):
        if quote:
            quote = "" if char == quote else quote
        elif char in "'\"":
            quote = char
        elif char == "#" and (index == 0 or line[index - 1].isspace()):
            return line[:index].rstrip()
    return line.rstrip()


def _logical_lines(block: str) -> list[str]:
    """The block's lines with backslash continuations joined and comments dropped."""
    joined = re.sub(r"\\\n\s*", " ", block)
    lines = (_without_comment(line.strip()) for line in joined.splitlines())
    return [line for line in lines if line]


def commands(page: Path) -> list[Command]:
    """The command lines of ``page``, in order."""
    found: list[Command] = []
    for token in MarkdownIt("commonmark").parse(page.read_text(encoding="utf-8")):
        if token.type != "fence" or token.info.strip() not in SHELL_LANGUAGES:
            continue
        if token.info.strip() == "console":
            current: list[str] = []
            shown: list[tuple[str, list[str]]] = []
            for line in token.content.splitlines():
                if line.startswith("$ "):
                    current = []
                    shown.append((_without_comment(line[2:].strip()), current))
                elif shown and line.strip() and line.strip() != "...":
                    current.append(line)
            found += [Command(_name(page), text, tuple(lines)) for text, lines in shown]
        else:
            found += [Command(_name(page), line) for line in _logical_lines(token.content)]
    return found


def programs(line: str) -> list[str]:
    """The program of each simple command of a shell line (``for`` loops, ``&&`` chains,
    pipes), quotes and comments as the shell reads them."""
    lexer = shlex.shlex(line, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    words = list(lexer)
    found = []
    start = True
    skipping_for = False
    for word in words:
        if word in SEPARATORS:
            start, skipping_for = True, False
        elif skipping_for:
            continue
        elif start and word == "for":
            skipping_for, start = True, False
        elif start and word in KEYWORDS:
            start = word != "done"
        elif start:
            found.append(word)
            start = False
    return found


def _indented_commands(page: Path) -> list[str]:
    """First lines of indented code blocks that start with a command."""
    known = SYSTEM | VENV_ONLY | {".venv/bin/hpcontact"}
    return [
        token.content.splitlines()[0]
        for token in MarkdownIt("commonmark").parse(page.read_text(encoding="utf-8"))
        if token.type == "code_block" and token.content.split(None, 1)[0].split("/")[-1] in known
    ]


PAGES = pages()
COMMANDS = [command for page in PAGES for command in commands(page)]


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_every_command_runs_as_written_after_the_install(page: Path) -> None:
    activated = False
    for command in commands(page):
        if ACTIVATE.match(command.text):
            activated = True
            continue
        for program in programs(command.text):
            allowed = (
                program.startswith(".venv/bin/")
                or program in SYSTEM
                or program in BUILTINS
                or (activated and program in VENV_ONLY)
            )
            assert allowed, (
                f"{command.page}: `{command.text}`: `{program}` is not on PATH after the README's install: "
                f"write .venv/bin/{program}, or activate the venv once on the page (. .venv/bin/activate)"
            )


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_no_command_hides_in_an_indented_block(page: Path) -> None:
    hidden = _indented_commands(page)
    assert not hidden, f"{_name(page)}: indented code blocks of commands (fence them as ```bash): {hidden}"


# --- what runs here and what does not ---------------------------------------------------------

# Commands this test runs: (page, regular expression of the line). Cheap: a few seconds each.
RUN: list[tuple[str, str]] = [
    ("README.md", r"\.venv/bin/hpcontact run jobs/demo\.toml --dry-run"),
    ("README.md", r'\.venv/bin/python -c "from mpi4py import MPI; .*" && \.venv/bin/hpcontact info'),
    ("docs/tutorials/one-scene.md", r"\.venv/bin/hpcontact info"),
    ("docs/tutorials/one-scene.md", r"\.venv/bin/hpcontact solve --material Cu --nu 0\.1 --n 32"),
    ("docs/tutorials/cluster.md", r'python -c "from mpi4py import MPI; .*"'),
    ("docs/tutorials/cluster.md", r"hpcontact info"),
    ("docs/tutorials/cluster.md", r"hpcontact run jobs/li2017_aspect\.toml --dry-run"),
    ("docs/howto/install-cluster.md", r'\.venv/bin/python -c "from mpi4py import MPI; .*"'),
    ("docs/howto/install-cluster.md", r"\.venv/bin/hpcontact info"),
    ("docs/howto/accuracy.md", r"\.venv/bin/hpcontact solve .*"),
    ("docs/howto/accuracy.md", r"\.venv/bin/hpcontact run ellipses\.toml"),
    ("docs/howto/crystals.md", r"\.venv/bin/hpcontact solve .*"),
    (
        "docs/howto/masks.md",
        r"\.venv/bin/hpcontact solve --shape mask --mask ell\.npy --nu 0\.3 --quantities tangential --json",
    ),
    ("docs/howto/cost-estimates.md", r"(\.venv/bin/)?hpcontact run jobs/sphere_pairs\.toml --dry-run.*"),
    ("docs/index.md", r"\.venv/bin/hpcontact solve .*"),
    ("docs/tutorials/one-scene.md", r"\.venv/bin/hpcontact solve .* --json"),
]

# Commands it does not run, and why: (regular expression of the line, the reason).
INSTALL = "the install itself (PyPI, about a minute): the suite runs in the venv it made"
CLUSTER = "needs a cluster (its modules, MPI, SLURM); the batch script runs with fakes in tests/docs/test_cluster.py"
MINUTES = "a sweep or figure job of minutes on 2 cores (its time is quoted beside it and dated)"
AFTER_JOB = "reads the data set a sweep of minutes writes"
NOT_RUN: list[tuple[str, str]] = [
    (r"(\.venv/bin/)?hpcontact run jobs/x\.toml .*", "jobs/x.toml stands for the reader's own spec"),
    # CPU seconds measured 2026-11-28 on the 2-core Intel Xeon VM, imports (~2.3 s) included.
    (r"\.venv/bin/hpcontact solve --quantities slip .*", "a partial-slip solve: 16–18 s of CPU each"),
    (r"\.venv/bin/hpcontact solve --shape mask .* --accuracy 1e-3 --json", "grids of the mask to 1e-3: 11 s of CPU"),
    (r"python3 -m venv \.venv && \.venv/bin/pip install -q -e '\.\[mpich\]'( && .*)?", INSTALL + "; then " + MINUTES),
    (r"python3 -m venv \.venv && \.venv/bin/pip install -q -e '\.\[test\]' && .*", "the test suite itself"),
    (r"\.venv/bin/pip install -e '\.\[docs\]' && \.venv/bin/sphinx-build .*", ".ci/run builds the docs so (a minute)"),
    (r"module load .*", CLUSTER),
    (r"python3 (--version|-m venv \.venv)", CLUSTER + " (the install on a login node)"),
    (
        r"\.venv/bin/pip install (--force-reinstall )?--no-binary mpi4py .*",
        CLUSTER + " (builds mpi4py against its MPI)",
    ),
    (r"\.venv/bin/pip install -e \.", CLUSTER + " (the install on a login node)"),
    (r"\. \.venv/bin/activate", "activates the venv: the commands after it run with .venv/bin first on PATH"),
    (r"which mpirun mpiexec", CLUSTER + " (the module's launchers)"),
    (r"(mpirun -n 64|srun --mpi=pmix|sbatch) .*", CLUSTER),
    (r"\.venv/bin/mpiexec -n 64 .*", CLUSTER + " (64 ranks)"),
    (r"mpiexec -n 64 hpcontact run jobs/x\.toml .*", CLUSTER + " (64 ranks)"),
    (r"\.venv/bin/mpiexec -n 2 \.venv/bin/hpcontact run jobs/\w+\.toml( --resume)?", MINUTES),
    (r"\.venv/bin/python postprocess/indentation_moduli\.py", MINUTES + " (9 crystal solves, 25–30 s)"),
    (r"\.venv/bin/python postprocess/\w+\.py results/\S+ results/\S+( --\S+ \S+)*", AFTER_JOB),
    (
        r"\.venv/bin/mpiexec -n 2 \.venv/bin/python -m hpcontact\.sweep\.accuracy_study jobs/accuracy_cost\.toml",
        MINUTES,
    ),
    (r"\.venv/bin/python benchmarks/boundary_treatment\.py --full", MINUTES),
    (
        r"\.venv/bin/python -c \"from hpcontact\.sweep\.cost\.calibration import .*",
        "a calibration: ~30 s of timed solves",
    ),
]
# A console block that prints a record of `hpcontact solve`: run, and the record compared, by
# tests/test_claims.py::test_the_printed_records_are_what_the_commands_print.
COMPARED_BY_CLAIMS = "run and its printed record compared by tests/test_claims.py"


def _matches(command: Command, pattern: str) -> bool:
    return re.fullmatch(pattern, command.text) is not None


def _runs(command: Command) -> bool:
    return any(page == command.page and _matches(command, pattern) for page, pattern in RUN)


def _prints_a_record(command: Command) -> bool:
    return command.text.startswith(".venv/bin/hpcontact solve ") and any(
        re.match(r"\s+K_xx\s", line) for line in command.printed
    )


def _skips(command: Command) -> list[str]:
    reasons = [reason for pattern, reason in NOT_RUN if _matches(command, pattern)]
    return reasons + [COMPARED_BY_CLAIMS] * _prints_a_record(command)


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: f"{c.page}:{c.text[:60]}")
def test_every_command_is_run_here_or_listed_with_why(command: Command) -> None:
    skipped = _skips(command)
    assert _runs(command) or skipped, f"{command.page}: `{command.text}`: run it here (RUN) or say why not (NOT_RUN)"
    assert not (_runs(command) and skipped), f"{command.page}: `{command.text}` is both run and listed as not run"


# Pages whose commands read what the page's Python blocks write (masks.md: ell.npy, ell.png),
# and the folders of the work folder where they are run (the spec of masks.md reads
# masks/ell.npy beside itself, in specs/).
SETUP_BLOCKS = {"docs/howto/masks.md": (".", "specs/masks")}
# Pages whose commands read a spec the page prints: the file the page tells to write it to.
SPEC_FILES = {"docs/howto/accuracy.md": "ellipses.toml"}


def _blocks(page: str, language: str) -> list[str]:
    tokens = MarkdownIt("commonmark").parse((ROOT / page).read_text(encoding="utf-8"))
    return [token.content for token in tokens if token.type == "fence" and token.info.strip() == language]


@pytest.fixture(scope="module")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder that looks like the checkout to the commands (links to .venv, jobs,
    postprocess), with the setup blocks' files, and a cost calibration for this host."""
    from hpcontact import __version__
    from hpcontact.sweep.cost.calibration_file import save_calibration
    from hpcontact.sweep.cost.rates import KINDS, Calibration, Rate

    folder = tmp_path_factory.mktemp("docs-commands")
    for name in (".venv", "jobs", "postprocess"):
        (folder / name).symlink_to(ROOT / name)
    for page, places in SETUP_BLOCKS.items():
        script = "\n".join(_blocks(page, "python"))
        for place in places:
            (folder / place).mkdir(parents=True, exist_ok=True)
            subprocess.run([sys.executable, "-c", script], cwd=folder / place, check=True, timeout=60, env=_env(folder))
    for page, name in SPEC_FILES.items():
        (specs,) = _blocks(page, "toml")
        (folder / name).write_text(specs, encoding="utf-8")
    rates = {kind: Rate(rate_s=1e-6, solve_s=0.0) for kind in KINDS}
    calibration = Calibration(socket.gethostname(), __version__, rates, base_bytes=100.0 * 2**20)
    save_calibration(calibration, folder / "costmodel.json")
    return folder


def _env(folder: Path) -> dict[str, str]:
    return {
        **os.environ,
        "HOME": str(folder),
        "HPCONTACT_COSTMODEL": str(folder / "costmodel.json"),
        "HPCONTACT_MPI": "0",
        "MPLBACKEND": "Agg",
    }


def _activated(page: str) -> bool:
    return any(ACTIVATE.match(command.text) for command in commands(ROOT / page))


@dataclass(frozen=True)
class Outcome:
    status: int
    stdout: str
    stderr: str


@pytest.fixture(scope="module")
def outcomes(workdir: Path) -> dict[tuple[bool, str], Outcome]:
    """Every RUN command run once in ``workdir`` (two at a time: the machine has 2 cores; each
    is ~2.5 s of CPU, mostly the imports); a page that activates the venv gets .venv/bin first
    on PATH."""
    chosen = list(dict.fromkeys((_activated(c.page), c.text) for c in COMMANDS if _runs(c)))

    def run(key: tuple[bool, str]) -> Outcome:
        activated, text = key
        env = _env(workdir)
        if activated:
            env["PATH"] = f"{workdir / '.venv' / 'bin'}:{env['PATH']}"
            env["VIRTUAL_ENV"] = str(workdir / ".venv")
        done = subprocess.run(["bash", "-c", text], cwd=workdir, env=env, capture_output=True, text=True, timeout=300)
        return Outcome(done.returncode, done.stdout, done.stderr)

    with ThreadPoolExecutor(max_workers=2) as pool:
        return dict(zip(chosen, pool.map(run, chosen), strict=True))


@pytest.mark.parametrize("command", [c for c in COMMANDS if _runs(c)], ids=lambda c: f"{c.page}:{c.text[:60]}")
def test_the_command_runs_and_prints_what_the_page_shows(
    command: Command, outcomes: dict[tuple[bool, str], Outcome]
) -> None:
    outcome = outcomes[(_activated(command.page), command.text)]
    errors = [line for line in command.printed if line.startswith("hpcontact: error:")]
    if errors:
        assert outcome.status == 2, (
            f"{command.page}: `{command.text}` exited {outcome.status}, the page shows a refusal"
        )
        assert outcome.stderr.splitlines() == errors, f"{command.page}: `{command.text}` printed {outcome.stderr!r}"
    else:
        assert outcome.status == 0, (
            f"{command.page}: `{command.text}` exited {outcome.status}: {outcome.stderr[-2000:]}"
        )


# --- the specs the pages print ------------------------------------------------------------------

SPECS = [(_name(page), index, text) for page in PAGES for index, text in enumerate(_blocks(_name(page), "toml"))]
SWEEP_SPECS = [spec for spec in SPECS if "[axes]" in spec[2]]


@pytest.mark.parametrize(("page", "index", "text"), SWEEP_SPECS, ids=lambda v: str(v)[:40])
def test_every_spec_names_its_output(page: str, index: int, text: str) -> None:
    """A spec without ``[sweep] output`` writes beside wherever it is run (issue 42 item 6):
    every spec a page prints says where its data set goes."""
    output = tomllib.loads(text).get("sweep", {}).get("output")
    assert output, f"{page}: spec {index + 1} names no [sweep] output"


@pytest.mark.parametrize(("page", "index", "text"), SWEEP_SPECS, ids=lambda v: str(v)[:40])
def test_every_spec_is_accepted_by_the_spec_parser(page: str, index: int, text: str, workdir: Path) -> None:
    """Each printed spec, written to a file, passes the parser ``hpcontact run`` checks a spec
    with (its keys, values and scenes; a mask path relative to the file)."""
    from hpcontact.sweep.space.parse import parse_spec

    spec = workdir / "specs" / f"{Path(page).stem}-{index}.toml"
    spec.parent.mkdir(exist_ok=True)
    spec.write_text(text, encoding="utf-8")
    parse_spec(text, path=spec)
