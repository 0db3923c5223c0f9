"""Tolerant comparison of two PNG images (snapshot tests).

Two images match when

* ``differing_pixels <= max_differing_pixels``, where a pixel differs if
  ``max_c |a_c - b_c| > pixel_threshold`` over the RGB channels (0..255), and
* ``mean_difference <= max_mean_difference``, the mean absolute channel difference.

The first bound catches local changes (a link moved by a few pixels), the second diffuse ones
(lighting, background).

Thread safety: :class:`ImageComparisonOptions` and :class:`ImageComparison` are immutable values;
:func:`compare_images` keeps its state local to the call.
"""

from __future__ import annotations

import io
from dataclasses import dataclass

import numpy as np

from taskspace.errors import InvalidInputError


@dataclass(frozen=True, kw_only=True)
class ImageComparisonOptions:
    """Tolerances of :func:`compare_images`.

    Attributes:
        pixel_threshold: a pixel differs when a channel differs by more than this (0..255).
        max_differing_pixels: largest accepted number of differing pixels.
        max_mean_difference: largest accepted mean absolute channel difference (0..255).
    """

    pixel_threshold: int = 32
    max_differing_pixels: int = 40
    max_mean_difference: float = 0.5


@dataclass(frozen=True, kw_only=True)
class ImageComparison:
    """Result of :func:`compare_images`.

    Attributes:
        success: both bounds hold (and the sizes agree).
        size_mismatch: the images have different sizes (nothing else is compared).
        differing_pixels: number of pixels over the threshold.
        total_pixels: number of pixels.
        mean_difference: mean absolute channel difference (0..255).
        max_difference: largest channel difference (0..255).
        diff_png: a PNG visualizing the difference (differing pixels red over a gray copy).
        options: the tolerances used.
    """

    success: bool
    size_mismatch: bool
    differing_pixels: int
    total_pixels: int
    mean_difference: float
    max_difference: int
    diff_png: bytes
    options: ImageComparisonOptions

    def summary(self) -> str:
        """One line with the numbers and the bounds."""
        if self.size_mismatch:
            return "image sizes differ"
        o = self.options
        return (
            f"{self.differing_pixels} of {self.total_pixels} pixels differ by more than "
            f"{o.pixel_threshold} (allowed {o.max_differing_pixels}); mean difference "
            f"{self.mean_difference:.3f} (allowed {o.max_mean_difference}); max difference "
            f"{self.max_difference}"
        )


def _rgb(png: bytes, name: str) -> np.ndarray:
    from PIL import Image

    try:
        with Image.open(io.BytesIO(png)) as img:
            return np.asarray(img.convert("RGB"), dtype=np.int16)
    except Exception as exc:
        raise InvalidInputError(f"{name} is not a readable image: {exc}") from exc


def compare_images(
    actual: bytes, expected: bytes, options: ImageComparisonOptions | None = None
) -> ImageComparison:
    """Compare two PNG images with the tolerances of :class:`ImageComparisonOptions`."""
    from PIL import Image

    opts = options if options is not None else ImageComparisonOptions()
    a = _rgb(actual, "actual")
    b = _rgb(expected, "expected")
    if a.shape != b.shape:
        return ImageComparison(
            success=False,
            size_mismatch=True,
            differing_pixels=-1,
            total_pixels=int(a.shape[0] * a.shape[1]),
            mean_difference=float("inf"),
            max_difference=255,
            diff_png=b"",
            options=opts,
        )
    diff = np.abs(a - b)
    per_pixel = diff.max(axis=2)
    mask = per_pixel > opts.pixel_threshold
    count = int(mask.sum())
    mean = float(diff.mean())
    gray = (0.3 * a.mean(axis=2) + 150).clip(0, 255).astype(np.uint8)
    vis = np.stack([gray, gray, gray], axis=2)
    vis[mask] = (255, 0, 0)
    buffer = io.BytesIO()
    Image.fromarray(vis).save(buffer, format="PNG")
    return ImageComparison(
        success=count <= opts.max_differing_pixels and mean <= opts.max_mean_difference,
        size_mismatch=False,
        differing_pixels=count,
        total_pixels=int(mask.size),
        mean_difference=mean,
        max_difference=int(diff.max()),
        diff_png=buffer.getvalue(),
        options=opts,
    )
