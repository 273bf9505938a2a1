"""The camera's vertical, learned from the people it sees [beyond].

People stand upright: in the image, the vertical through any point runs to the camera's
vertical vanishing point ``v`` (homogeneous (3,); at infinity, ``v[2] = 0``, for a camera that
looks horizontally). A wide camera looking down sees the verticals fan out, here from 25
degrees left of image up at one side of the frame to 21 right at the other. Each mask's own
PCA axis (the thesis's height axis) follows that, but with noise (the legs, the arms) and a
lean of 2-5 degrees into the walk; the feet under the mask's centroid, at the foot row, move
sideways by that angle times half the person's height. ``v`` fitted to the axes of many
people seen whole averages the noise out, and the lean where people walk both ways.

:func:`vertical_step` collects the axes of the masks that are elongated, whole (touching no
border) and alone (in no merge, split or group), and refits ``v`` every
``vertical_refit_frames`` frames once it has ``vertical_min_samples`` of them
(:func:`fit_vanishing_point`: the algebraic least-squares point of the axes' lines, then the
point whose verticals are nearest the axes in angle, with a robust loss). :func:`up_at` gives
the unit up direction towards (or away from) ``v`` at image points. The feet use it with
``feet.up = "learned"`` (:func:`~mvtrack.stages.feet.feet_step`; not the default, see
:class:`~mvtrack.params.FeetConfig`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.optimize import least_squares

from mvtrack.params import FeetConfig
from mvtrack.stages.blobtrack import TrackResult
from mvtrack.stages.targets import touching_sides

__all__ = ["Verticals", "fit_vanishing_point", "up_at", "vertical_step"]

_ANGLE_SCALE = 0.05  # robust loss scale of the fit: sin(3 degrees), the axes' spread


@dataclass(frozen=True)
class Verticals:
    """What one camera learned of its vertical.

    centres:    (N, 2) float64, centroids of the masks whose axes were kept (oldest first)
    axes:       (N, 2) float64, their PCA up directions (unit)
    vp:         (3,) float64 unit homogeneous vertical vanishing point, None until fitted
    since_fit:  frames since the last fit
    """

    centres: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    axes: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    vp: np.ndarray | None = None
    since_fit: int = 0


def up_at(vp: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, 2) unit up directions at image ``points`` (N, 2): along the line to ``vp``, pointing
    up the image (image up at the vanishing point itself)."""
    points = np.asarray(points, np.float64).reshape(-1, 2)
    d = vp[:2][None, :] - points * vp[2]
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    d = np.where(norm > 1e-12, d / np.maximum(norm, 1e-12), [[0.0, -1.0]])
    return np.where(d[:, 1:2] <= 0.0, d, -d)


def _unit_sphere(angles: np.ndarray) -> np.ndarray:
    lat, lon = angles
    return np.array([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])


def fit_vanishing_point(centres: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(3,) unit homogeneous point nearest, in angle, to lying on every line through
    ``centres`` (N, 2) along ``axes`` (N, 2); N >= 2 lines not all parallel to one another
    give a finite point, parallel ones a point at infinity."""
    c = np.column_stack([centres, np.ones(len(centres))])
    lines = np.cross(c, c + np.column_stack([axes, np.zeros(len(axes))]))
    lines /= np.linalg.norm(lines[:, :2], axis=1, keepdims=True)
    v0 = np.linalg.eigh(lines.T @ lines)[1][:, 0]  # algebraic: least squares of the distances

    def residuals(angles: np.ndarray) -> np.ndarray:  # sine of each axis' angle to its vertical
        up = up_at(_unit_sphere(angles), centres)
        return axes[:, 0] * up[:, 1] - axes[:, 1] * up[:, 0]

    start = np.array([np.arcsin(np.clip(v0[2], -1.0, 1.0)), np.arctan2(v0[1], v0[0])])
    fit = least_squares(residuals, start, loss="soft_l1", f_scale=_ANGLE_SCALE)
    return _unit_sphere(fit.x)


def _axis_samples(result: TrackResult, cfg: FeetConfig) -> tuple[np.ndarray, np.ndarray]:
    """(centroids (K, 2), PCA up axes (K, 2)) of ``result``'s mask targets that are whole,
    alone and elongated enough to teach the vertical."""
    if result.label_image is None or not len(result.labels):
        return np.zeros((0, 2)), np.zeros((0, 2))
    rows, cols = result.label_image.shape
    cut = np.any(touching_sides(result.boxes_xywh, (cols, rows), 0.0), axis=1)
    unsure = result.shared_labels()
    centres, axes = [], []
    for i, label in enumerate(result.labels.tolist()):
        if cut[i] or label in unsure:
            continue
        x0, y0, w, h = (int(v) for v in np.rint(result.boxes_xywh[i] + [0.5, 0.5, 0.0, 0.0]))
        crop = (result.label_image[y0 : y0 + h, x0 : x0 + w] == label).view(np.uint8)
        m = cv2.moments(crop, binaryImage=True)
        if m["m00"] < 2:
            continue
        evals, evecs = np.linalg.eigh(np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]))
        if evals[1] < cfg.vertical_min_elongation**2 * max(evals[0], 1e-9):
            continue
        up = evecs[:, 1] if evecs[1, 1] <= 0 else -evecs[:, 1]
        if -up[1] < np.sqrt(0.5):  # lying more than 45 degrees from image up: not a person
            continue
        centres.append([x0 + m["m10"] / m["m00"], y0 + m["m01"] / m["m00"]])
        axes.append(up)
    return np.array(centres).reshape(-1, 2), np.array(axes).reshape(-1, 2)


def vertical_step(model: Verticals, result: TrackResult, cfg: FeetConfig) -> Verticals:
    """``model`` with this frame's axes added (the last ``vertical_samples`` kept) and ``vp``
    refitted when due."""
    centres, axes = _axis_samples(result, cfg)
    keep = cfg.vertical_samples
    centres = np.concatenate([model.centres, centres])[-keep:]
    axes = np.concatenate([model.axes, axes])[-keep:]
    since = model.since_fit + 1
    vp = model.vp
    if len(centres) >= cfg.vertical_min_samples and (vp is None
                                                      or since >= cfg.vertical_refit_frames):
        vp, since = fit_vanishing_point(centres, axes), 0
    return Verticals(centres, axes, vp, since)
