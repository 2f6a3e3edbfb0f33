"""Errors carry the option they name (``errors.Option``, ``errors.Message``) and each front end
spells it (issue 38 item 4): the command line ``--resume``, Python ``resume=True``, from one
raise; the run's options declared once (``sweep/run/options.py``): argparse and
``hpcontact.run_sweep``'s keywords agree with the declaration; no sweep text spells a
declared flag by hand, where a Python caller would get the command line's words."""

from __future__ import annotations

import argparse
import ast
import inspect
import io
import pickle
import re
from pathlib import Path

import pytest

import hpcontact
from hpcontact.cli import main as cli_main
from hpcontact.errors import Front, InputError, Message, Option, rendered
from hpcontact.sweep.run.arguments import add_run_arguments
from hpcontact.sweep.run.guard import Refused
from hpcontact.sweep.run.options import (
    ACCURACY,
    BREAK_LOCK,
    KEYWORDS,
    MEM_PER_RANK,
    OUTPUT,
    RESUME,
    RUN_OPTIONS,
    STALL_TIMEOUT,
)
from hpcontact.sweep.space.parse import parse_spec, toml_text

PACKAGE = Path(hpcontact.__file__).parent
SPEC = {"scene": {"shape": "circle"}, "numerics": {"n": 8}, "axes": {"nu": [0.3]}}


def test_an_option_is_spelled_by_each_front_end():
    assert (RESUME.advised(Front.COMMAND_LINE), RESUME.advised(Front.PYTHON)) == ("--resume", "resume=True")
    assert (OUTPUT.advised(Front.COMMAND_LINE), OUTPUT.advised(Front.PYTHON)) == ("--output", "output=")
    assert (MEM_PER_RANK.named(Front.COMMAND_LINE), MEM_PER_RANK.named(Front.PYTHON)) == (
        "--mem-per-rank",
        "mem_per_rank",
    )
    # an option of the command line alone has no other spelling
    assert {STALL_TIMEOUT.advised(f) for f in Front} == {STALL_TIMEOUT.named(f) for f in Front} == {"--stall-timeout"}
    message = Message("pass ", RESUME, " to continue or ") + Message(OUTPUT) + " elsewhere"
    assert str(message) == message.render(Front.COMMAND_LINE) == "pass --resume to continue or --output elsewhere"
    assert message.render(Front.PYTHON) == "pass resume=True to continue or output= elsewhere"
    assert message.options() == (RESUME, OUTPUT) and rendered("plain", Front.PYTHON) == "plain"


def test_messages_and_options_cross_ranks_whole():
    """A refusal made on rank 0 is sent to the other ranks (pickled): it keeps its options."""
    message = pickle.loads(pickle.dumps(Message("run again with ", RESUME)))
    assert message.render(Front.PYTHON) == "run again with resume=True" and str(message) == "run again with --resume"
    option = pickle.loads(pickle.dumps(MEM_PER_RANK))
    assert type(option) is type(MEM_PER_RANK) and option.named(Front.PYTHON) == "mem_per_rank"
    assert option == "--mem-per-rank" and option.help == MEM_PER_RANK.help  # reads as its flag


def test_an_error_whose_field_is_an_option_is_worded_by_each_front_end():
    with pytest.raises(InputError) as info:
        parse_spec("[axes]\nnu = [0.1]\n", accuracy=2.0)
    error = info.value
    assert error.field is ACCURACY and error.names_option()
    assert str(error) == error.worded(Front.COMMAND_LINE) and str(error).startswith("--accuracy = 2.0: ")
    python = error.for_front(Front.PYTHON)
    assert type(python) is InputError and str(python) == "accuracy = 2.0: " + str(error).removeprefix(
        "--accuracy = 2.0: "
    )
    assert not InputError("nu", "a number in (-1, 0.5]", 2).names_option()


def test_one_refusal_in_the_words_of_the_command_line_and_of_python(tmp_path, capsys):
    """One raise (``guard.usable_output``: the output is a folder), met through ``hpcontact run``
    and through ``hpcontact.run_sweep``: the same line, the option in each front end's words."""
    folder = tmp_path / "taken.nc"
    folder.mkdir()
    spec = tmp_path / "spec.toml"
    spec.write_text(toml_text(SPEC), encoding="utf-8")
    said = f"the output {folder} is a folder, not a file: name another output ([sweep].output or {{}}) or move it away"

    assert cli_main(["run", str(spec), "--output", str(folder)]) == 2
    assert capsys.readouterr().err == "hpcontact run: error: " + said.format("--output") + "\n"
    with pytest.raises(Refused) as info:
        hpcontact.run_sweep(spec, output=folder, stream=io.StringIO())
    assert str(info.value) == said.format("output=")


def _run_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="hpcontact run")
    add_run_arguments(parser)
    return parser


def test_the_run_options_are_declared_once_for_argparse_and_run_sweep():
    parser = _run_parser()
    flags = {a.option_strings[0]: a for a in parser._actions if a.option_strings and a.option_strings[0] != "-h"}
    assert list(flags) == [o.flag for o in RUN_OPTIONS]
    for option in RUN_OPTIONS:
        action = flags[option.flag]
        assert action.help == option.help and action.metavar == option.metavar, option
        assert isinstance(action, argparse._StoreTrueAction) == option.switch, option
        if option.keyword is not None:  # argparse's name for it is the Python keyword
            assert action.dest == option.keyword, option
    with pytest.raises(SystemExit):  # one exclusive group: resume or restart
        parser.parse_args(["spec.toml", "--resume", "--restart"])
    keywords = set(inspect.signature(hpcontact.run_sweep).parameters) - {"spec", "task_function", "stream"}
    assert keywords == set(KEYWORDS)


#: Files whose text may spell a declared flag by hand: the declaration and the command line's
#: help (``arguments.EXIT_STATUS``), the command line's alone.
DECLARATIONS = {"sweep/run/options.py", "sweep/run/arguments.py"}


def _hand_spelled_flags(path: Path, flags: list[str]) -> list[str]:
    """Each flag of ``flags`` that a string literal of ``path`` (not a docstring) spells as a
    word, once per time (sorted)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    documentation = {
        id(n.value) for n in ast.walk(tree) if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)
    }
    word = re.compile(r"(?<![\w-])(" + "|".join(map(re.escape, flags)) + r")(?![\w-])")
    return sorted(
        match.group(1)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in documentation
        for match in word.finditer(node.value)
    )


def test_no_sweep_text_spells_a_flag_that_python_would_not_render():
    """A message names an option as its ``Option`` (``Message``, an error's field), rendered by
    the front end that shows it, or, where only the command line shows it, as ``OPTION.flag``:
    a flag written out in a string is one a Python caller would get as it is. Checked over the
    declared options that Python spells otherwise (a keyword)."""
    flags = [o.flag for o in RUN_OPTIONS if o.keyword is not None]
    assert _hand_spelled_flags(PACKAGE / "sweep/run/options.py", flags)  # the check sees a spelled flag
    found = {
        str(path.relative_to(PACKAGE)): spelled
        for path in sorted((PACKAGE / "sweep").rglob("*.py"))
        if str(path.relative_to(PACKAGE)) not in DECLARATIONS and (spelled := _hand_spelled_flags(path, flags))
    }
    assert found == {}


def test_options_and_messages_read_as_the_command_line_s_text():
    """Code that reads an error's field or a note as text (``InputError.field``, a lock's note)
    reads the command line's words, as before options were carried."""
    assert isinstance(RESUME, Option) and isinstance(RESUME, str) and f"{RESUME}" == "--resume"
    note = Message("took over the lock (", BREAK_LOCK, ")") + "; 2 entries not reused"
    assert isinstance(note, str) and "(--break-lock); 2" in note and note.startswith("took over")
    assert note.render(Front.PYTHON) == "took over the lock (break_lock=True); 2 entries not reused"
