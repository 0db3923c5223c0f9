"""A self-contained HTML page of PNG figures (``taskspace demo NAME --html`` for plot demos).

Each image is embedded as a ``data:`` URL, so the page opens without the files beside it.
"""

from __future__ import annotations

import base64
import html
from collections.abc import Sequence
from pathlib import Path

from taskspace.errors import InvalidInputError

_PAGE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; }}
figure {{ margin: 0 0 2em 0; }}
img {{ max-width: 100%; }}
</style>
</head>
<body>
<h1>{title}</h1>
{figures}
</body>
</html>
"""


def figure_page_html(images: Sequence[str | Path], title: str = "taskspace figures") -> str:
    """HTML text showing each PNG of ``images`` with its file name as caption.

    Raises:
        InvalidInputError: no image, a missing file, or a file that is not a PNG.
    """
    if isinstance(images, (str, Path)):
        # a single path was read letter by letter ("image not found: /")
        raise InvalidInputError(f"images must be a list of PNG paths, got one path {images!r}")
    if not isinstance(title, str):
        raise InvalidInputError(f"title must be a string, got {type(title).__name__}")
    if not images:
        raise InvalidInputError("figure_page_html needs at least one PNG file")
    parts = []
    for image in images:
        path = Path(image)
        if not path.is_file():
            raise InvalidInputError(f"image not found: {path}")
        data = path.read_bytes()
        if not data.startswith(b"\x89PNG"):
            raise InvalidInputError(f"not a PNG file: {path}")
        name = html.escape(path.name)
        encoded = base64.b64encode(data).decode("ascii")
        parts.append(
            f'<figure><img alt="{name}" src="data:image/png;base64,{encoded}">'
            f"<figcaption>{name}</figcaption></figure>"
        )
    return _PAGE.format(title=html.escape(title), figures="\n".join(parts))


def save_figure_page(
    path: str | Path, images: Sequence[str | Path], title: str = "taskspace figures"
) -> Path:
    """Write :func:`figure_page_html` to ``path`` (parent directories are created)."""
    from taskspace.viz.snapshots import check_output_path, write_output

    check_output_path(path)
    return write_output(path, figure_page_html(images, title).encode("utf-8"))
