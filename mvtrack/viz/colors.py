"""One colour per ``meta`` id, the same in every camera, every view and every run.

The colour is a pure function of the id (golden-ratio hue steps, two lightness levels), so a
person keeps their colour across cameras and across ``--watch`` re-runs.
"""

from __future__ import annotations

import colorsys

import numpy as np

__all__ = ["MASK_COLORS", "camera_color", "meta_color", "meta_colors"]

_GOLDEN = 0.618033988749895
_MIN_LUMINANCE = 0.25  # meta colours at least this bright: dark blue label text was unreadable

MASK_COLORS = {
    1: (255, 60, 60),  # MVO: red
    2: (60, 140, 255),  # ghost: blue
    3: (255, 200, 0),  # foreground shadow: amber
    4: (150, 90, 220),  # ghost shadow: violet
}
"""RGB colour of each class of the mask layer (:data:`mvtrack.viz.paths.MASK_LAYER`)."""


def meta_color(meta: int) -> tuple[int, int, int]:
    """RGB uint8 colour of a meta id (>= 1); meta 0 (no meta) is gray."""
    if meta <= 0:
        return (128, 128, 128)
    hue = (meta * _GOLDEN) % 1.0
    light = 0.62 if meta % 2 else 0.52
    r, g, b = colorsys.hls_to_rgb(hue, light, 0.85)
    while _luminance((r, g, b)) < _MIN_LUMINANCE and light < 0.8:  # blues and purples
        light += 0.02  # lighter until label text reads on the viewer's dark label background
        r, g, b = colorsys.hls_to_rgb(hue, light, 0.85)
    return (round(255 * r), round(255 * g), round(255 * b))


def _luminance(rgb: tuple[float, float, float]) -> float:
    """Relative luminance (Rec. 709 weights) of an RGB colour in [0, 1]."""
    r, g, b = rgb
    return 0.2126 * r + 0.7152 * g + 0.0722 * b


def meta_colors(metas: np.ndarray) -> np.ndarray:
    """(N, 3) uint8 colours of (N,) meta ids."""
    return np.array([meta_color(int(m)) for m in np.asarray(metas).reshape(-1)],
                    np.uint8).reshape(-1, 3)


_CAMERA_PALETTE = ((31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40),
                   (148, 103, 189), (140, 86, 75), (227, 119, 194), (127, 127, 127))


def camera_color(index: int) -> tuple[int, int, int]:
    """RGB colour of the ``index``-th camera's series in plots (distinct from meta colours)."""
    return _CAMERA_PALETTE[index % len(_CAMERA_PALETTE)]
