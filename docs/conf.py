"""Sphinx configuration of grainlab's documentation site (``make docs``).

Sphinx with the PyData theme and MyST (myst-nb: the tutorials are MyST notebooks executed at
every build): the pages are Markdown (the same files the repository
shows), the API reference comes from the docstrings (autodoc + napoleon, NumPy style), the
command-line reference from the CLI's own help (docs/_cli.py), and equations are
rendered by MathJax. Warnings are errors in ``make docs`` (``-W --keep-going``)."""

from __future__ import annotations

import sys
from pathlib import Path

import grainlab

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))  # _cli.py: the command-line reference

project = "grainlab"
author = "the grainlab developers"
copyright = "2026, the grainlab developers"
release = grainlab.__version__
version = release

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb"}
nb_execution_mode = "force"
"""Tutorials are executed at every build: a tutorial that no longer runs fails the build."""
nb_execution_timeout = 900
nb_execution_raise_on_error = True
exclude_patterns = ["_build", "studies/**", "**/.ipynb_checkpoints", "reference/cli_commands.md",
                    "reference/config_keys_table.md", "reference/result_columns_table.md",
                    "reference/lab_tests_table.md", "reference/citations_table.md"]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

autosummary_generate = True
templates_path = ["_templates"]
autodoc_default_options = {"members": True, "undoc-members": False, "show-inheritance": True}
autodoc_typehints = "description"
autodoc_member_order = "bysource"
napoleon_numpy_docstring = True
napoleon_google_docstring = False
napoleon_use_ivar = True
suppress_warnings = ["ref.python"]
"""A field name typed in a Returns or Attributes section (``unit``, ``type``) matches the
attributes of several classes; Sphinx then links none of them, which is what we want."""

html_theme = "pydata_sphinx_theme"
html_title = f"grainlab {release}"
html_theme_options = {"navigation_depth": 2, "show_toc_level": 2}

autodoc_default_options["ignore-module-all"] = True


def _plain_bars(app, what, name, obj, options, lines) -> None:
    """The docstrings write |x| for a norm or an absolute value, which reStructuredText reads
    as a substitution: escape the bars, except on the rows of a grid table."""
    for index, line in enumerate(lines):
        text = line.strip()
        row = text.startswith(("+-", "+=")) or (text.startswith("|") and text.endswith("|"))
        if "|" in line and not row:
            lines[index] = line.replace("|", r"\|")


SECTIONS = ("Parameters", "Returns", "Yields", "Raises", "Attributes", "Other Parameters")


def _prose_after_sections(app, what, name, obj, options, lines) -> None:
    """The docstrings often go on in prose after a Parameters (or Returns, Raises) block,
    separated by a blank line; NumPy style would read that prose as more parameters. Give
    such a paragraph a Notes heading (before napoleon reads the docstring)."""
    inside = False
    index = 0
    while index < len(lines):
        text = lines[index]
        heading = index + 1 < len(lines) and set(lines[index + 1].strip()) == {"-"}
        if heading:
            inside = text.strip() in SECTIONS
            index += 2
            continue
        if inside and not text.strip() and index + 1 < len(lines):
            following = lines[index + 1]
            after = lines[index + 2] if index + 2 < len(lines) else ""
            starts_prose = following.strip() and not following.startswith(" ") and \
                not after.startswith(" ") and not (index + 2 < len(lines) and
                                                   set(after.strip()) == {"-"})
            if starts_prose:
                lines[index + 1:index + 1] = ["Notes", "-----"]
                inside = False
                index += 3
                continue
        index += 1


def _generated_references(app) -> None:
    """The reference pages written from the CLI and the registries (docs/_cli.py,
    docs/_registries.py)."""
    from _citations import write_citations
    from _cli import write_cli_reference
    from _registries import (
        write_columns_reference,
        write_config_reference,
        write_lab_tests_reference,
    )

    write_cli_reference(HERE / "reference" / "cli_commands.md")
    write_config_reference(HERE / "reference" / "config_keys_table.md")
    write_columns_reference(HERE / "reference" / "result_columns_table.md")
    write_lab_tests_reference(HERE / "reference" / "lab_tests_table.md",
                              HERE / "howto" / "lab-tests")
    write_citations(HERE / "reference" / "citations_table.md")


def _unreadable_modules_out_of_viewcode(app):
    """viewcode remembers a module whose source it could not read (``builtins``, named by an
    attribute whose value is a built-in) and still lists it on its index, linking to a page
    it never writes: forget such modules before viewcode writes its pages."""
    modules = getattr(app.env, "_viewcode_modules", {})
    for name in [name for name, entry in modules.items() if entry is False]:
        del modules[name]
    return []


def setup(app) -> None:
    app.connect("html-collect-pages", _unreadable_modules_out_of_viewcode, priority=100)
    app.connect("builder-inited", _generated_references)
    app.connect("autodoc-process-docstring", _prose_after_sections, priority=400)
    app.connect("autodoc-process-docstring", _plain_bars)
