"""One colour per ``meta`` id, the same in every camera, every view and every run.

The colour is a pure function of the id (a fixed palette of :data:`PALETTE_SIZE` colours, meta
m takes entry (m - 1) mod size), so a person keeps their colour across cameras and across
``--watch`` re-runs. The palette is picked by farthest-point sampling in CIELAB, so any two of
its colours differ by more than 25 (Delta E 1976): golden-ratio hue steps, used before, made
metas m and m + 8 the same green (Delta E 5.6).
"""

from __future__ import annotations

import colorsys
from functools import cache

import cv2
import numpy as np

__all__ = ["HEIGHTS_COLOR", "HEIGHTS_FALLBACK_COLOR", "MASK_COLORS", "PALETTE_SIZE", "TRUTH_COLOR",
           "camera_color", "meta_color", "meta_colors"]

PALETTE_SIZE = 32
"""Distinct meta colours; metas m and m + PALETTE_SIZE share one."""
_NO_META = (128, 128, 128)
_MIN_LUMINANCE = 0.25  # meta colours at least this bright: dark blue label text was unreadable

MASK_COLORS = {
    1: (255, 60, 60),  # MVO: red
    2: (60, 140, 255),  # ghost: blue
    3: (255, 200, 0),  # foreground shadow: amber
    4: (150, 90, 220),  # ghost shadow: violet
    5: (255, 120, 200),  # border mover (kept out of B, not tracked): pink
}
"""RGB colour of each class of the mask layer (:data:`mvtrack.viz.paths.MASK_LAYER`)."""

HEIGHTS_COLOR = (255, 255, 255)
"""RGB colour of the heights layer read off the line of whole people (white: apart from every
mask class)."""
HEIGHTS_FALLBACK_COLOR = (150, 150, 150)
"""RGB colour of the heights layer while the size model has no line of whole people (gray)."""
TRUTH_COLOR = (90, 255, 150)
"""RGB colour of the true people drawn in a camera (a green no mask class uses)."""


def meta_color(meta: int) -> tuple[int, int, int]:
    """RGB uint8 colour of a meta id (>= 1); meta 0 (no meta) is gray."""
    if meta <= 0:
        return _NO_META
    return _palette()[(meta - 1) % PALETTE_SIZE]


@cache
def _palette() -> tuple[tuple[int, int, int], ...]:
    """:data:`PALETTE_SIZE` colours far apart in CIELAB and from the no-meta gray.

    Candidates: 72 hues x 4 lightness levels x 2 saturations (HLS), those bright enough for
    label text on the viewer's dark label background (luminance >= ``_MIN_LUMINANCE``: dark
    blue text was unreadable). Greedy farthest-point sampling, seeded with the gray, so the
    first metas (most often on screen together) are the most distinct.
    """
    rgb = [colorsys.hls_to_rgb(h / 72, light, sat)
           for h in range(72) for light in (0.42, 0.52, 0.62, 0.72) for sat in (0.85, 0.5)]
    rgb = [c for c in rgb if _luminance(c) >= _MIN_LUMINANCE]
    cand = np.round(255 * np.array(rgb)).astype(np.uint8)
    lab = _lab(cand)
    nearest = np.linalg.norm(lab - _lab(np.array([_NO_META], np.uint8)), axis=1)
    picked = []
    for _ in range(PALETTE_SIZE):
        k = int(np.argmax(nearest))
        picked.append(k)
        nearest = np.minimum(nearest, np.linalg.norm(lab - lab[k], axis=1))
    return tuple((int(r), int(g), int(b)) for r, g, b in cand[picked])


def _lab(rgb: np.ndarray) -> np.ndarray:
    """(N, 3) CIELAB (L in 0..100) of (N, 3) uint8 RGB colours."""
    lab = cv2.cvtColor(rgb.reshape(1, -1, 3), cv2.COLOR_RGB2Lab)[0].astype(np.float64)
    lab[:, 0] *= 100 / 255  # 8-bit Lab: L scaled to 0..255, a and b offset by 128
    return lab


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
