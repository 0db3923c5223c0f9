"""Sphinx configuration of the taskspace documentation.

Build (warnings are errors)::

    .venv/bin/python -m sphinx -W --keep-going -b html docs docs/_build/html

The gallery runs every script of ``examples/`` with ``TASKSPACE_FAST=1`` (short runs);
``TASKSPACE_DOCS_GALLERY=0`` skips running them (pages without outputs), and
``TASKSPACE_DOCS_GALLERY=<regex>`` runs only the scripts whose path matches (every script still
gets its page; ``tests/test_docs.py`` runs in this way only the examples whose figures it
checks). The default runs them all.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

import taskspace_gallery  # noqa: E402

os.environ.setdefault("TASKSPACE_FAST", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.pop("DISPLAY", None)

import taskspace  # noqa: E402

project = "taskspace"
author = "taskspace contributors"
copyright = "taskspace contributors"
release = getattr(taskspace, "__version__", "0.1.0")
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx.ext.intersphinx",
    "sphinx_gallery.gen_gallery",
]

exclude_patterns = [
    "_build",
    "_generated/gallery_src",
    "_generated/example_outputs",
    "_generated/slides",  # included by the guide pages
]
templates_path = ["_templates"]

# Theme: furo (PyPI), Sphinx's alabaster when furo is not installed.
try:
    import furo  # noqa: F401

    html_theme = "furo"
except ImportError:  # pragma: no cover
    html_theme = "alabaster"
html_title = f"taskspace {release}"

# API reference from the Google-style docstrings.
autosummary_generate = True
autosummary_imported_members = False
autodoc_default_options = {
    "members": True,
    "show-inheritance": True,
    "member-order": "bysource",
}
autodoc_typehints = "description"
autodoc_typehints_format = "short"
autodoc_member_order = "bysource"
autodoc_mock_imports: list[str] = []
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False
napoleon_attr_annotations = True
add_module_names = False
# Not every type of a signature has a page (numpy arrays, pinocchio objects...).
nitpicky = False
intersphinx_mapping: dict[str, tuple[str, str | None]] = {}

# Gallery: a mirror of examples/ with reST titles, run at build time.
_pattern = os.environ.get("TASKSPACE_DOCS_GALLERY", "")
_gallery_src = taskspace_gallery.mirror_examples()
sphinx_gallery_conf = {
    "examples_dirs": os.path.relpath(_gallery_src, DOCS),
    "gallery_dirs": "_generated/gallery",
    "filename_pattern": _pattern if _pattern not in ("", "0", "1") else r"/[^_][^/]*\.py$",
    "ignore_pattern": r"__init__\.py$",
    "plot_gallery": "False" if _pattern == "0" else "True",
    "reset_argv": "taskspace_gallery.reset_argv",
    "image_scrapers": ("taskspace_gallery.png_scraper",),
    "subsection_order": "taskspace_gallery.subsection_key",
    "within_subsection_order": "FileNameSortKey",
    "abort_on_example_error": False,
    "only_warn_on_example_error": False,
    "download_all_examples": False,
    "remove_config_comments": True,
    "capture_repr": (),
    "show_memory": False,
    "write_computation_times": False,
    "copyfile_regex": "",
}

# API reference pages, one per public subpackage, from each package's ``__all__``.
import taskspace_api  # noqa: E402

taskspace_api.write_pages()
taskspace_api.write_slide_tables()


def _stubs_off_the_toctree(app: object, doctree: object) -> None:
    """Drop the hidden toctrees that ``autosummary :toctree:`` adds to the API pages.

    The ~500 stub pages (one per exported object, ``:orphan:`` in
    ``_templates/autosummary``) are reached through the autosummary tables' links. Kept in the
    toctree, they would make furo render a navigation tree of every stub on every page: the
    HTML writing grows quadratically with the number of pages.
    """
    from sphinx.ext.autosummary import autosummary_toc

    for node in list(doctree.findall(autosummary_toc)):  # type: ignore[attr-defined]
        node.parent.remove(node)


def setup(app: object) -> None:
    """Register :func:`_stubs_off_the_toctree` before the toctree collector reads the pages."""
    app.connect("doctree-read", _stubs_off_the_toctree, priority=400)  # type: ignore[attr-defined]
