"""Sphinx configuration of the hpcontact documentation.

Build (from the repository root, on a fresh clone)::

    .venv/bin/pip install -e '.[docs]' && .venv/bin/sphinx-build -W --keep-going -b html docs docs/_build/html

Markdown pages are read by myst-parser; the Python reference comes from the docstrings
(autodoc, numpy style through napoleon); the command-line reference and the spec keys are
generated at build time from the parser and from ``hpcontact.sweep.space`` (``_ext/hpcontact_docs.py``).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE / "_ext"))
sys.path.insert(0, str(ROOT))

# The documented package is imported for autodoc and for the generated CLI reference: one BLAS
# thread and no MPI launch, as on any machine that builds the docs.
os.environ.setdefault("HPCONTACT_MPI", "0")

import hpcontact  # noqa: E402

project = "hpcontact"
author = "the hpcontact developers"
copyright = "2026, the hpcontact developers"
version = release = hpcontact.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "hpcontact_docs",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
templates_path: list[str] = []

# MyST: ``{directive}`` fences, $…$ maths is not used (the pages write formulas as text),
# heading anchors so that pages can link to sections (design.md §2.5 → #25-anisotropic-half-space).
myst_enable_extensions = ["colon_fence", "deflist"]
myst_heading_anchors = 3

# autodoc: members in source order, the docstrings' numpy sections through napoleon.
autodoc_member_order = "bysource"
autodoc_typehints = "description"
autodoc_default_options = {"members": True, "ignore-module-all": True}
napoleon_google_docstring = False
napoleon_numpy_docstring = True
napoleon_use_rtype = False
# Cross-references written as :func:`x` or :class:`x` in the docstrings resolve where the target
# is documented; others render as code. Missing targets are not errors (nitpicky off).
nitpicky = False

html_theme = "furo"
html_title = f"hpcontact {release}"
html_static_path: list[str] = []


# --- Python reference: one page per module, written at build time ------------------------------
# Every module of the package (``__main__`` modules excepted: importing them runs the command)
# gets docs/reference/modules/<module>.rst with an ``automodule``; the folder is brought in step
# with the package on every build (git-ignored), so a new or removed module needs no edit here. The groups follow the
# package's floors (docs/design.md §3).
import pkgutil  # noqa: E402
import shutil  # noqa: E402

API_DIR = HERE / "reference" / "modules"
API_GROUPS = [
    ("Package top, scenes and records", None),
    ("Materials", "hpcontact.materials"),
    ("Numerics", "hpcontact.numerics"),
    ("Kernels", "hpcontact.kernels"),
    ("Discretizations", "hpcontact.discretizations"),
    ("Problems", "hpcontact.problems"),
    ("Partial slip", "hpcontact.problems.slip"),
    ("Sweeps", "hpcontact.sweep"),
]


def _modules() -> list[str]:
    names = ["hpcontact"]
    for info in pkgutil.walk_packages(hpcontact.__path__, "hpcontact."):
        if info.name.rsplit(".", 1)[-1] != "__main__":
            names.append(info.name)
    return sorted(names)


def _group(name: str) -> str | None:
    """The group of module ``name``: itself if it is a group's package, else its parent's."""
    packages = {group for _, group in API_GROUPS}
    if name in packages:
        return name
    parent = name.rsplit(".", 1)[0]
    return parent if parent in packages else None


def write_api_pages() -> None:
    """Write one page per module and the modules' index under docs/reference/modules/.

    Files whose text is unchanged are left alone (so an incremental build re-reads only what
    changed) and pages of modules that no longer exist are removed."""
    groups: dict[str | None, list[str]] = {g: [] for _, g in API_GROUPS}
    pages: dict[str, str] = {}
    for name in _modules():
        groups.setdefault(_group(name), []).append(name)
        title = f"``{name}``"
        pages[f"{name}.rst"] = f"{title}\n{'=' * len(title)}\n\n.. automodule:: {name}\n"
    lines = [
        "# Modules",
        "",
        "Every module of the package, from its docstrings (generated when the docs are built).",
        "The stable face is [the Python API](../python-api.md); the layout is docs/design.md §3.",
        "",
    ]
    for title, group in API_GROUPS:
        if not groups.get(group):
            continue
        lines += [f"## {title}", "", "```{toctree}", ":maxdepth: 1", "", *groups[group], "```", ""]
    pages["index.md"] = "\n".join(lines)
    API_DIR.mkdir(parents=True, exist_ok=True)
    for path in API_DIR.iterdir():
        if path.name not in pages:
            shutil.rmtree(path) if path.is_dir() else path.unlink()
    for filename, text in pages.items():
        path = API_DIR / filename
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")


write_api_pages()
