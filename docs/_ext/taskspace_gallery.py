"""Sphinx-gallery hooks for the taskspace examples (used by ``docs/conf.py``).

The examples are argparse scripts (``--save DIR``) that import a sibling ``_common`` module
and sometimes use ``__file__``. The gallery runs a mirror of ``examples/`` (made by
:func:`mirror_examples`, which turns each script's first docstring paragraph into a reST
title and writes a header per folder), so ``examples/`` itself needs no gallery markup:

* :func:`reset_argv` gives each script ``--save <its own output dir>``, defines ``__file__``
  and makes the script's own ``_common`` importable;
* :func:`png_scraper` embeds every PNG the script wrote there (matplotlib figures and
  meshcat snapshots rendered by headless Chromium).
"""

from __future__ import annotations

import ast
import shutil
import sys
from pathlib import Path
from typing import Any

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent
EXAMPLES = ROOT / "examples"
GENERATED = DOCS / "_generated"
GALLERY_SRC = GENERATED / "gallery_src"
OUTPUTS = GENERATED / "example_outputs"

SECTION_TITLES = {
    "ik": "Inverse kinematics",
    "trajectories": "Motion profiles, path optimization and timing",
    "planning": "Path planning",
    "control": "Dynamics and control",
    "estimation": "State estimation and SLAM",
    "learning": "Optimal control and reinforcement learning",
    "grasping": "Grasping",
    "locomotion": "Legged locomotion",
}
SECTION_ORDER = list(SECTION_TITLES)


def _titled(source: str, name: str) -> str:
    """Source with its module docstring rewritten so its first paragraph is a reST title."""
    tree = ast.parse(source)
    doc = ast.get_docstring(tree, clean=True)
    first = tree.body[0] if tree.body else None
    if not doc or first is None or not isinstance(first, ast.Expr):
        title, rest = name, ""
        end = 0
    else:
        head, _, rest = doc.partition("\n\n")
        title = " ".join(line.strip() for line in head.splitlines())
        end = first.end_lineno or 0
    lines = source.splitlines(keepends=True)
    body = "".join(lines[end:])
    title = title.replace('"""', "'''")
    rest = rest.replace('"""', "'''").replace("\\", "\\\\")
    underline = "=" * len(title)
    return f'"""\n{title}\n{underline}\n\n{rest}\n"""\n{body}'


def mirror_examples(src: Path = EXAMPLES, dest: Path = GALLERY_SRC) -> Path:
    """Copy ``src`` to ``dest`` with reST titles and one ``GALLERY_HEADER.rst`` per folder.

    Files are rewritten only when their content changes, so sphinx-gallery's checksums skip
    examples that did not change since the last build.
    """
    wanted: set[Path] = set()

    def write(path: Path, text: str) -> None:
        wanted.add(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")

    write(
        dest / "GALLERY_HEADER.rst",
        "Gallery\n=======\n\nThe scripts of ``examples/``, run while the documentation is "
        "built (with ``TASKSPACE_FAST=1``, the short runs), with the figures and meshcat "
        "snapshots they write. Run one yourself with "
        "``python examples/<folder>/<name>.py --save out/``.\n",
    )
    for path in sorted(src.rglob("*.py")):
        rel = path.relative_to(src)
        if "__pycache__" in rel.parts:
            continue
        if path.name.startswith("_"):
            continue  # helpers (``_common.py``) are imported from examples/ itself
        write(dest / rel, _titled(path.read_text(encoding="utf-8"), path.stem))
    for folder in sorted(p for p in src.iterdir() if p.is_dir() and p.name != "__pycache__"):
        if not any(folder.glob("[!_]*.py")):
            continue
        title = SECTION_TITLES.get(folder.name, folder.name.replace("_", " ").capitalize())
        write(
            dest / folder.name / "GALLERY_HEADER.rst",
            f"{title}\n{'-' * len(title)}\n\nScripts of ``examples/{folder.name}/``.\n",
        )
    for path in sorted(dest.rglob("*"), reverse=True):
        if path.is_file() and path not in wanted:
            path.unlink()
        elif path.is_dir() and not any(path.iterdir()):
            path.rmdir()
    return dest


def _output_dir(src_file: str | Path) -> Path:
    rel = Path(src_file).resolve().relative_to(GALLERY_SRC.resolve())
    return OUTPUTS / rel.with_suffix("")


def reset_argv(gallery_conf: dict[str, Any], script_vars: dict[str, Any]) -> list[str]:
    """Arguments of each example: ``--save`` into a fresh directory of its own.

    Also defines ``__file__`` (the script in ``examples/``) and puts its folder first on
    ``sys.path`` so that its own ``_common`` module is imported (sphinx-gallery restores
    ``sys.path`` afterwards).
    """
    src = Path(script_vars["src_file"]).resolve()
    original = EXAMPLES / src.relative_to(GALLERY_SRC.resolve())
    example_globals = script_vars.get("example_globals")
    if example_globals is not None:
        example_globals["__file__"] = str(original)
        # sphinx-gallery blanks __doc__; the scripts' argparse descriptions read it
        example_globals["__doc__"] = ast.get_docstring(
            ast.parse(original.read_text(encoding="utf-8"))
        )
    sys.modules.pop("_common", None)
    sys.path.insert(0, str(original.parent))
    out = _output_dir(src)
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    return ["--save", str(out)]


def png_scraper(block: Any, block_vars: dict[str, Any], gallery_conf: dict[str, Any]) -> str:
    """Embed the PNG files the example wrote into its ``--save`` directory."""
    import matplotlib.pyplot as plt
    from sphinx_gallery.scrapers import figure_rst

    plt.close("all")
    out = _output_dir(block_vars["src_file"])
    seen: set[str] = block_vars.setdefault("taskspace_seen_png", set())
    images = []
    for png in sorted(out.rglob("*.png")) if out.is_dir() else []:
        if str(png) in seen:
            continue
        seen.add(str(png))
        target = Path(next(block_vars["image_path_iterator"]))
        shutil.copyfile(png, target)
        images.append(str(target))
    return figure_rst(images, gallery_conf["src_dir"])


def subsection_key(folder: str) -> tuple[int, str]:
    """Gallery sections in the order of the lecture (unknown folders last, by name)."""
    name = Path(folder).name
    index = SECTION_ORDER.index(name) if name in SECTION_ORDER else len(SECTION_ORDER)
    return index, name
