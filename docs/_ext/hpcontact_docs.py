"""Sphinx directives that generate reference pages from the code at build time.

- ``hpcontact-help [SUBCOMMAND]``: the ``--help`` text of ``hpcontact`` (or of a subcommand),
  from the real parser (``hpcontact.cli.main``), 100 columns wide.
- ``hpcontact-spec-keys``: the tables and keys a sweep spec accepts (``hpcontact.sweep.space``).
- ``hpcontact-dataset-attributes AXES|CONTACT|SLIP``: names, ``long_name`` and units of the
  data set's coordinates and variables (``hpcontact.sweep.data.dataset``).
- ``hpcontact-status-codes``: the task status codes of a data set's ``status`` variable.
- ``hpcontact-jobs``: every shipped job (``jobs/*``) with its leading comment block.
- ``hpcontact-scripts FOLDER``: every script of ``postprocess/`` or ``benchmarks/`` with the first
  line of its docstring.

Pages written in Markdown use them as MyST fences, e.g. ``{hpcontact-help} solve``.

It also keeps the docstrings' absolute values as written: ``|t_i| ≤ mu p_i`` is the notation of
the papers, and reStructuredText would read ``|t_i|`` as a substitution reference. A reference
to a substitution that no document defines is put back as its text, ``|t_i|``
(``AbsoluteValues``, run just before docutils' own substitution transform). A defined
substitution (``|version|``, ``|release|``) is unchanged.
"""

from __future__ import annotations

import contextlib
import io
import os
from collections.abc import Iterable, Sequence

from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.transforms import Transform
from docutils.transforms.references import Substitutions

HELP_COLUMNS = "100"


def _help_text(words: Sequence[str]) -> str:
    """What ``hpcontact WORDS --help`` prints, from the parser itself (no subprocess)."""
    from hpcontact.cli import main

    out = io.StringIO()
    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = HELP_COLUMNS
    try:
        with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):
            main([*words, "--help"])
    finally:
        if old is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = old
    text = out.getvalue().rstrip()
    if not text:
        raise RuntimeError(f"hpcontact {' '.join(words)} --help printed nothing")
    return text


def _cell(text: str, literal: bool = False) -> nodes.entry:
    entry = nodes.entry()
    para = nodes.paragraph()
    para += nodes.literal(text, text) if literal else nodes.Text(text)
    entry += para
    return entry


def _table(headers: Sequence[str], rows: Iterable[Sequence[str]], literal_columns: Sequence[int] = (0,)) -> nodes.table:
    table = nodes.table()
    group = nodes.tgroup(cols=len(headers))
    table += group
    for _ in headers:
        group += nodes.colspec(colwidth=1)
    head = nodes.thead()
    row = nodes.row()
    for name in headers:
        row += _cell(name)
    head += row
    group += head
    body = nodes.tbody()
    for values in rows:
        row = nodes.row()
        for i, value in enumerate(values):
            row += _cell(str(value), literal=i in literal_columns and bool(value))
        body += row
    group += body
    return table


class HelpDirective(Directive):
    """``hpcontact-help [SUBCOMMAND]``: a literal block of the command's ``--help``."""

    optional_arguments = 1
    has_content = False

    def run(self) -> list[nodes.Node]:
        words = self.arguments[0].split() if self.arguments else []
        text = _help_text(words)
        block = nodes.literal_block(text, text)
        block["language"] = "text"
        return [block]


class SpecKeysDirective(Directive):
    """``hpcontact-spec-keys``: the spec's tables and the keys each accepts."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        from hpcontact.sweep.space import axes, spec

        rows = [
            ("[sweep]", ", ".join(spec.SWEEP_KEYS)),
            ("[scene]", "any field of hpcontact solve (its option names, - written _), except the [numerics] keys"),
            ("[numerics]", ", ".join(spec.NUMERIC_KEYS)),
            ("[axes]", ", ".join(axes.AXIS_NAMES)),
        ]
        tables = _table(("table", "keys"), rows)
        kinds = [
            ("label axes (values may be tables with a label)", ", ".join(axes.LABEL_AXES)),
            ("angle_mode", ", ".join(spec.ANGLE_MODES)),
            ("float fields", ", ".join(sorted(axes.FLOAT_FIELDS))),
            ("integer fields", ", ".join(sorted(axes.INT_FIELDS))),
            ("string fields", ", ".join(sorted(axes.STRING_FIELDS))),
            ('radii that may be inf or "flat"', ", ".join(sorted(axes.FLAT_FIELDS))),
            ("paths (relative to the spec's folder)", ", ".join(sorted(axes.PATH_FIELDS))),
            ("most points in a spec", f"{axes.MAX_POINTS:.0e}".replace("e+0", "e")),
            ("most points that each need a solve", f"{axes.MAX_TASK_POINTS:.0e}".replace("e+0", "e")),
        ]
        return [tables, _table(("rule", "keys"), kinds, literal_columns=())]


class DatasetAttributesDirective(Directive):
    """``hpcontact-dataset-attributes AXES|CONTACT|SLIP``: name, long_name, units."""

    required_arguments = 1
    has_content = False

    def run(self) -> list[nodes.Node]:
        from hpcontact.sweep.data import attributes

        which = self.arguments[0].upper()
        if which == "AXES":
            rows = [(k, v.get("long_name", ""), v.get("units", "")) for k, v in attributes.AXIS_ATTRS.items()]
        elif which == "CONTACT":
            rows = [
                (k, v.get("long_name", ""), v.get("units", "") if "flag_values" not in v else "flags")
                for k, v in attributes.VARIABLE_ATTRS.items()
            ]
        elif which == "SLIP":
            rows = [(k, name, unit) for k, (name, unit) in attributes.SLIP_ATTRS.items()]
        else:
            raise self.error(f"hpcontact-dataset-attributes: AXES, CONTACT or SLIP, not {self.arguments[0]!r}")
        return [_table(("name", "long_name", "units (scene scales)"), rows)]


class StatusCodesDirective(Directive):
    """``hpcontact-status-codes``: the data set's ``status`` flag values and meanings."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        from hpcontact.sweep.data import attributes

        rows = [(str(code), meaning) for code, meaning in sorted(attributes.STATUS_MEANINGS.items())]
        return [_table(("status", "flag meaning"), rows, literal_columns=(1,))]


def _repository(directive: Directive):
    from pathlib import Path

    env = directive.state.document.settings.env
    return env, Path(env.srcdir).parent


class JobsDirective(Directive):
    """``hpcontact-jobs``: each file of jobs/ with the comment block it starts with."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        env, root = _repository(self)
        out: list[nodes.Node] = []
        for path in sorted((root / "jobs").iterdir()):
            if not path.is_file() or path.name.startswith("."):
                continue
            env.note_dependency(str(path))
            lines = path.read_text(encoding="utf-8").splitlines()
            if lines and lines[0].startswith("#!"):
                lines = lines[1:]
            head = []
            for line in lines:
                if not line.startswith("#"):
                    break
                head.append(line[1:].removeprefix(" "))
            section = nodes.section(ids=[nodes.make_id(f"job-{path.name}")])
            section += nodes.title(text=f"jobs/{path.name}")
            text = "\n".join(head).strip() or "(no description)"
            section += nodes.literal_block(text, text)
            out.append(section)
        return out


class ScriptsDirective(Directive):
    """``hpcontact-scripts FOLDER``: the scripts of FOLDER and the first line of each docstring."""

    required_arguments = 1
    has_content = False

    def run(self) -> list[nodes.Node]:
        import ast

        env, root = _repository(self)
        folder = root / self.arguments[0]
        rows = []
        for path in sorted(folder.glob("*.py")):
            env.note_dependency(str(path))
            doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
            paragraph = doc.split("\n\n", 1)[0]
            rows.append((f"{self.arguments[0]}/{path.name}", " ".join(paragraph.split())))
        if not rows:
            raise self.error(f"hpcontact-scripts: no scripts in {folder}")
        return [_table(("script", "what it does"), rows)]


class AbsoluteValues(Transform):
    """Undefined ``|x|`` substitution references → the text ``|x|`` (absolute values)."""

    default_priority = Substitutions.default_priority - 1

    def apply(self) -> None:
        defined = self.document.substitution_defs
        normalized = self.document.substitution_names
        for ref in list(self.document.findall(nodes.substitution_reference)):
            name = ref["refname"]
            if name in defined or nodes.fully_normalize_name(name) in normalized:
                continue
            ref.replace_self(nodes.Text(f"|{ref.astext()}|"))


def setup(app):  # noqa: ANN001, ANN201 (Sphinx's extension hook)
    app.add_transform(AbsoluteValues)
    app.add_directive("hpcontact-help", HelpDirective)
    app.add_directive("hpcontact-spec-keys", SpecKeysDirective)
    app.add_directive("hpcontact-dataset-attributes", DatasetAttributesDirective)
    app.add_directive("hpcontact-status-codes", StatusCodesDirective)
    app.add_directive("hpcontact-jobs", JobsDirective)
    app.add_directive("hpcontact-scripts", ScriptsDirective)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
