"""What the single-camera front end hands to the multi-camera stages, one camera, one frame.

Masks and detections both end up as a :class:`CameraTargets`: labels, feet, heights and boxes.
Everything the pair stages need (FOV events, markers, homography matching) is derived from it,
so they work the same for video cameras and cameras given as detections.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SIDES", "CameraTargets", "exit_outward", "on_exit_border", "touching_sides"]

SIDES = ("left", "right", "top", "bottom")
"""Column order of :attr:`CameraTargets.touches`."""


@dataclass(frozen=True)
class CameraTargets:
    """The targets of one camera in one frame.

    labels:      (N,) int64, camera-local target labels (never reused within a camera)
    feet:        (N, 2) float64, feet points [x, y] in pixels
    heights_px:  (N,) float64, target heights in pixels
    boxes_xywh:  (N, 4) float64, boxes (FORMATS.md convention: x, y are the left/top edges)
    size:        (width, height) of the camera's frame in pixels
    """

    labels: np.ndarray
    feet: np.ndarray
    heights_px: np.ndarray
    boxes_xywh: np.ndarray
    size: tuple[int, int]

    def __post_init__(self) -> None:
        n = len(self.labels)
        shapes = {
            "feet": (self.feet.shape, (n, 2)),
            "heights_px": (self.heights_px.shape, (n,)),
            "boxes_xywh": (self.boxes_xywh.shape, (n, 4)),
        }
        for name, (got, want) in shapes.items():
            if got != want:
                raise ValueError(f"CameraTargets.{name} has shape {got}, expected {want}")

    @classmethod
    def empty(cls, size: tuple[int, int]) -> CameraTargets:
        return cls(
            labels=np.zeros(0, np.int64),
            feet=np.zeros((0, 2)),
            heights_px=np.zeros(0),
            boxes_xywh=np.zeros((0, 4)),
            size=size,
        )

    def __len__(self) -> int:
        return len(self.labels)

    def touches(self, margin_px: float) -> np.ndarray:
        """(N, 4) bool: which image sides (:data:`SIDES` order) each target touches."""
        return touching_sides(self.boxes_xywh, self.size, margin_px)

    def subset(self, keep: np.ndarray) -> CameraTargets:
        """The targets of the rows where ``keep`` (N,) bool is True."""
        return CameraTargets(self.labels[keep], self.feet[keep], self.heights_px[keep],
                             self.boxes_xywh[keep], self.size)

    def index_of(self, label: int) -> int | None:
        """Row of ``label`` in this frame, or None if the target is absent."""
        hits = np.flatnonzero(self.labels == label)
        return int(hits[0]) if len(hits) else None


def exit_outward(boxes_xywh: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(N, 2): for boxes on the left, right or bottom border, where people walk out of the
    view (not the top: a far person cut by it keeps its feet in view), the sum of those
    borders' outward directions in pixel axes; zeros for the others."""
    sides = touching_sides(boxes_xywh, size, 0.0).astype(np.float64)
    return np.c_[sides[:, 1] - sides[:, 0], sides[:, 3]]


def on_exit_border(boxes_xywh: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(N,) bool: boxes on the left, right or bottom border (:func:`exit_outward`)."""
    return np.asarray(exit_outward(boxes_xywh, size).any(axis=1))


def touching_sides(boxes_xywh: np.ndarray, size: tuple[int, int], margin_px: float) -> np.ndarray:
    """(N, 4) bool: a box touches a side when its outermost pixel is within ``margin_px`` of it.

    Box edges follow FORMATS.md: the leftmost pixel column of a box is ``x + 0.5`` and the last
    column of a W-wide frame is ``W - 1``. With ``margin_px = 0`` only boxes that include the
    border pixels touch.
    """
    boxes = np.asarray(boxes_xywh, np.float64).reshape(-1, 4)
    width, height = size
    first_col, first_row = boxes[:, 0] + 0.5, boxes[:, 1] + 0.5
    last_col = boxes[:, 0] + boxes[:, 2] - 0.5
    last_row = boxes[:, 1] + boxes[:, 3] - 0.5
    return np.stack(
        [
            first_col <= margin_px,
            last_col >= width - 1 - margin_px,
            first_row <= margin_px,
            last_row >= height - 1 - margin_px,
        ],
        axis=1,
    )
