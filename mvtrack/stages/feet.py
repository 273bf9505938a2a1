"""Feet and height of a target (SPEC §3, thesis §3.2.4).

Two methods, both always available:

- :func:`feet_pca` (the thesis's): PCA of the mask's pixel coordinates gives the height axis;
  the mask is rotated upright, its upright bounding box taken, and the outline points closest to
  the box's two bottom corners found; the feet are their midpoint (``anchor = "corners"``), or
  by default the point on their mean row under the mask's centroid, rotated back to the image.
  The height is the distance from the feet to the top of the upright box.
- :func:`feet_bbox` (Khan & Shah's baseline): the bottom centre of the axis-aligned box.

Cameras given as detections use :func:`feet_from_box`. :func:`target_feet` applies the method
chosen in :class:`~mvtrack.params.FeetConfig` to every target of a
:class:`~mvtrack.stages.blobtrack.TrackResult`.

Pixel convention (FORMATS.md): pixel centres are at integer coordinates, so a pixel covers
[x - 0.5, x + 0.5]. Boxes and feet refer to the silhouette's edges, not its pixel centres: the
bottom of a mask whose lowest row is 40 is y = 40.5.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace

import cv2
import numpy as np

from mvtrack.params import FeetConfig
from mvtrack.stages.background import SizeModel, feet_row
from mvtrack.stages.blobtrack import TrackResult
from mvtrack.stages.targets import touching_sides
from mvtrack.stages.vertical import Verticals, up_at, vertical_step

__all__ = [
    "Feet",
    "FeetState",
    "HeightMemory",
    "complete_step",
    "feet_bbox",
    "feet_from_box",
    "feet_pca",
    "feet_step",
    "target_feet",
    "target_feet_records",
]

_HALF_PX = 0.5  # half a pixel: from a pixel centre to the pixel's edge (pixel convention)
_IMAGE_UP = np.array([0.0, -1.0])


@dataclass(frozen=True)
class Feet:
    """The feet of one target, with what the viewer draws.

    point:           (2,) float64, feet [x, y] in image pixels
    height_px:       float, distance from the feet to the top of the (upright) box, pixels
    up:              (2,) float64 unit vector, the target's height axis pointing to the head
                     (image coordinates: [0, -1] is straight up)
    box_corners_xy:  (4, 2) float64, the upright box's corners in image pixels, in the order
                     top-left, top-right, bottom-right, bottom-left of the upright view
    outline_xy:      (2, 2) float64, the two outline points closest to the bottom-left and
                     bottom-right corners (pca); the box's bottom corners for the box methods
    method:          "pca", "bbox" or "box" (detections)
    completed_px:    how far :func:`complete_step` moved the feet down along ``-up`` (0: not)
    """

    point: np.ndarray
    height_px: float
    up: np.ndarray
    box_corners_xy: np.ndarray
    outline_xy: np.ndarray
    method: str
    completed_px: float = 0.0


def _mask_points(mask: np.ndarray, offset_xy: tuple[float, float]) -> np.ndarray:
    mask = np.asarray(mask)
    if mask.ndim != 2:
        raise ValueError(f"feet: mask must be (H, W), got shape {mask.shape}")
    ys, xs = np.nonzero(mask)
    if len(xs) == 0:
        raise ValueError("feet: the mask is empty")
    pts = np.stack([xs, ys], axis=1).astype(np.float64)
    return pts + np.asarray(offset_xy, np.float64)


def _height_axis(cov: np.ndarray, min_elongation: float) -> np.ndarray:
    """Unit 'up' vector: the principal direction (of the four ±e1, ±e2) of the pixel
    coordinates' (2, 2) covariance ``cov`` closest to image up.

    Taking the closest of both axes, not always the major one, keeps a blob that is wider than
    tall (a person half inside the frame, two people side by side) upright instead of turning it
    by 90 degrees. A mask too round for PCA to give a direction (sqrt(l1/l2) below
    ``min_elongation``, a single pixel) keeps image up.
    """
    evals, evecs = np.linalg.eigh(cov)  # ascending
    major, minor = float(evals[1]), float(evals[0])
    if major <= 0.0 or major < min_elongation**2 * max(minor, 0.0):
        return _IMAGE_UP.copy()
    cands = np.concatenate([evecs.T, -evecs.T], axis=0)  # (4, 2)
    best = int(np.argmax(cands @ _IMAGE_UP))
    up = cands[best]
    return up / np.linalg.norm(up)


def feet_pca(
    mask: np.ndarray, offset_xy: tuple[float, float] = (0.0, 0.0), cfg: FeetConfig | None = None,
    vertical_vp: np.ndarray | None = None,
) -> Feet:
    """Thesis feet: PCA upright box, outline points nearest its bottom corners (SPEC §3); the
    feet midway between those (``cfg.anchor == "corners"``) or on their mean row under the
    centroid (``"centroid"``: a walker's swing foot, lifted behind, pulls the midpoint back).

    mask:       (H, W) bool, the target's pixels (the whole frame, or a crop)
    offset_xy:  image coordinates [x, y] of the crop's pixel (0, 0)
    vertical_vp: the camera's vertical vanishing point (:mod:`~mvtrack.stages.vertical`): the
                height axis is the vertical through the centroid, not the mask's own PCA axis
    Returns :class:`Feet` in image pixels. Raises ValueError on an empty mask.

    The pixels' mean and covariance come from the mask's image moments, and the upright box
    from its outline (a linear function of position is extreme over a set of pixels on the
    set's outer boundary): the same as from every pixel's coordinates, without listing them
    (a third of the time per target).
    """
    cfg = cfg or FeetConfig()
    mask = np.ascontiguousarray(mask, bool)
    if mask.ndim != 2:
        raise ValueError(f"feet: mask must be (H, W), got shape {mask.shape}")
    mask8 = mask.view(np.uint8)
    m = cv2.moments(mask8, binaryImage=True)
    n = m["m00"]
    if n == 0:
        raise ValueError("feet: the mask is empty")
    centre = np.array([m["m10"] / n, m["m01"] / n]) + np.asarray(offset_xy, np.float64)
    if vertical_vp is not None:
        up = up_at(vertical_vp, centre)[0]
    elif n < 2:
        up = _IMAGE_UP.copy()
    else:  # np.cov of the pixel coordinates
        up = _height_axis(np.array([[m["mu20"], m["mu11"]], [m["mu11"], m["mu02"]]]) / (n - 1),
                          cfg.min_elongation)
    down = -up
    right = np.array([down[1], -down[0]])  # (right, down) is a right-handed image frame

    contours, _ = cv2.findContours(mask8, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if cfg.min_part_px > 0 and len(contours) > 1:
        areas = [cv2.contourArea(c) for c in contours]
        contours = ([c for c, a in zip(contours, areas, strict=True) if a >= cfg.min_part_px]
                    or [contours[int(np.argmax(areas))]])
    outline = np.concatenate([c.reshape(-1, 2) for c in contours]).astype(np.float64)
    outline = outline + np.asarray(offset_xy, np.float64) - centre
    outline_uv = np.stack([outline @ right, outline @ down], axis=1)
    u0, v0 = outline_uv.min(axis=0) - _HALF_PX
    u1, v1 = outline_uv.max(axis=0) + _HALF_PX
    corners_uv = np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]])
    picks = []
    for corner in (corners_uv[3], corners_uv[2]):  # bottom-left, bottom-right
        d2 = ((outline_uv - corner) ** 2).sum(axis=1)
        picks.append(outline_uv[int(np.argmin(d2))])
    picks_uv = np.array(picks)
    # Outline points are boundary pixel centres; the silhouette ends half a pixel further down.
    feet_uv = picks_uv.mean(axis=0) + np.array([0.0, _HALF_PX])
    if cfg.anchor == "centroid":  # u = 0: under the centroid (the origin of u, v)
        feet_uv[0] = 0.0

    def to_image(uv: np.ndarray) -> np.ndarray:
        uv = np.atleast_2d(uv)
        return centre + uv[:, :1] * right + uv[:, 1:2] * down

    return Feet(
        point=to_image(feet_uv)[0],
        height_px=float(feet_uv[1] - v0),
        up=up,
        box_corners_xy=to_image(corners_uv),
        outline_xy=to_image(picks_uv),
        method="pca",
    )


def _box_feet(box_xywh: np.ndarray, point: np.ndarray, method: str) -> Feet:
    x, y, w, h = (float(v) for v in box_xywh)
    corners = np.array([[x, y], [x + w, y], [x + w, y + h], [x, y + h]])
    return Feet(
        point=np.asarray(point, np.float64),
        height_px=h,
        up=_IMAGE_UP.copy(),
        box_corners_xy=corners,
        outline_xy=corners[[3, 2]].copy(),
        method=method,
    )


def feet_bbox(mask: np.ndarray, offset_xy: tuple[float, float] = (0.0, 0.0)) -> Feet:
    """Baseline feet: bottom centre of the mask's axis-aligned box; height = the box height.

    mask: (H, W) bool (frame or crop at ``offset_xy``). Raises ValueError on an empty mask.
    """
    pts = _mask_points(np.asarray(mask, bool), offset_xy)
    lo, hi = pts.min(axis=0) - _HALF_PX, pts.max(axis=0) + _HALF_PX
    box = np.array([lo[0], lo[1], hi[0] - lo[0], hi[1] - lo[1]])
    return _box_feet(box, np.array([(lo[0] + hi[0]) / 2, hi[1]]), "bbox")


def feet_from_box(box_xywh: np.ndarray, foot_xy: np.ndarray | None = None) -> Feet:
    """Detections: the given foot point if finite, else the box's bottom centre; height = h.

    box_xywh: (4,) float64 (FORMATS.md); foot_xy: (2,) float64 or None / NaNs when absent.
    """
    box = np.asarray(box_xywh, np.float64).reshape(4)
    if foot_xy is not None and np.all(np.isfinite(foot_xy)):
        point = np.asarray(foot_xy, np.float64).reshape(2)
    else:
        point = np.array([box[0] + box[2] / 2, box[1] + box[3]])
    return _box_feet(box, point, "box")


def target_feet_records(result: TrackResult, cfg: FeetConfig,
                        vertical_vp: np.ndarray | None = None) -> tuple[Feet, ...]:
    """:class:`Feet` of every target of ``result`` (same order as ``result.labels``).

    Mask targets use ``cfg.method`` on their pixels in ``result.label_image`` (with
    ``vertical_vp``, :func:`feet_pca` takes its height axes from it); box targets (no label
    image) use :func:`feet_from_box` with the detection's foot point when it has one.
    """
    records: list[Feet] = []
    for i, label in enumerate(result.labels):
        box = result.boxes_xywh[i]
        if result.label_image is None:
            records.append(feet_from_box(box, result.feet_xy[i]))
            continue
        x0, y0, w, h = (int(v) for v in np.rint(box + [_HALF_PX, _HALF_PX, 0.0, 0.0]))
        x1, y1 = x0 + w, y0 + h
        crop = result.label_image[y0:y1, x0:x1] == label
        offset = (float(x0), float(y0))
        if cfg.method == "pca":
            records.append(feet_pca(crop, offset, cfg, vertical_vp))
        else:
            records.append(feet_bbox(crop, offset))
    return tuple(records)


_WHOLE_FRAMES = 5  # the whole height is the median of the last frames seen whole


@dataclass(frozen=True)
class HeightMemory:
    """Per live mask target: its heights the last frames it was seen whole, and since when.

    whole_px:  label -> heights px (:attr:`Feet.height_px`) of its last (at most 5) frames
               seen whole, oldest first
    since:     label -> frames since the last of them
    top:       label -> the top of its box last frame (px edge)
    """

    whole_px: Mapping[int, tuple[float, ...]] = field(default_factory=dict)
    since: Mapping[int, int] = field(default_factory=dict)
    top: Mapping[int, float] = field(default_factory=dict)


def complete_step(memory: HeightMemory, records: tuple[Feet, ...], result: TrackResult,
                  cfg: FeetConfig, sizes: SizeModel | None = None
                  ) -> tuple[HeightMemory, tuple[Feet, ...]]:
    """Feet of mask targets that lost their lower body, put back where the body ends [beyond].

    Walking behind the booth or a person, or on trousers that match the ground, a target ends
    at the hips and its feet land there, up to a body height above the truth; its walk then
    leads nowhere (the same-camera stitches and hand-offs miss it). A target's whole height is
    the median of its heights in its last 5 frames seen whole (alone, touching no border, not
    just split off or cut from a group, not completed): one frame with a shadow or a passer-by
    in its blob does not set it. A target shorter than that by more than
    ``complete_min_loss_frac`` of it, touching no border and in no merge, split or group, gets
    that height back: its feet move down along its down axis (image down when that leans more
    than 45 degrees) to that height below its top, and its box with them. Only the bottom may
    have gone: a target whose top moved more than ``complete_top_step_frac`` of its whole
    height since the last frame (its head went, or it is someone else), or that has not been
    seen whole for ``complete_max_frames``, has its heights forgotten. Nor is a frame whole
    where the target is taller than its whole height by more than ``complete_min_loss_frac``
    of it: someone joined its blob, and would be taken for its legs once they left ('crowd'
    s9 cam1: a person of 60 px, then 100 px with one behind for 30 frames). A target that
    touches the bottom border and no other (someone walking out towards the camera) lost its
    lower body to the frame: it gets its whole height back, its feet below the frame, while it
    shows at least ``complete_min_shown_frac`` of it (further out, the truth's walk and ours
    part). One never seen whole (walking in) gets the height the camera's line of whole
    people (``sizes``, :attr:`~mvtrack.stages.background.SizeModel.whole`) gives a person
    whose head is at its top, on the same terms. Returns the new memory and the records
    (``result``'s order).
    """
    if result.label_image is None or not cfg.complete_short:
        return memory, records
    rows, cols = result.label_image.shape
    sides = touching_sides(result.boxes_xywh, (cols, rows), 0.0)  # left, right, top, bottom
    cut = np.any(sides, axis=1).tolist()
    cut_below = (sides[:, 3] & ~np.any(sides[:, :3], axis=1)).tolist()
    unsure = result.shared_labels()
    loss = cfg.complete_min_loss_frac
    whole: dict[int, tuple[float, ...]] = {}
    since: dict[int, int] = {}
    top = {label: float(y) for label, y in zip(result.labels.tolist(), result.boxes_xywh[:, 1],
                                               strict=True)}
    out = []
    for i, (label, feet) in enumerate(zip(result.labels.tolist(), records, strict=True)):
        if label in unsure:  # forgotten: what it was before may be two people or half of one
            out.append(feet)
            continue
        heights, age = memory.whole_px.get(label, ()), memory.since.get(label, 0)
        ref = float(np.median(heights)) if heights else 0.0
        if (abs(top[label] - memory.top.get(label, np.inf)) > cfg.complete_top_step_frac * ref
                or age >= cfg.complete_max_frames):
            heights, ref = (), 0.0  # its head is not where it was, or that was long ago
        if cut_below[i] and not heights:
            ref = _line_height(sizes, top[label])
        if cut[i]:  # only by the bottom border, and still showing enough of itself
            short = cut_below[i] and cfg.complete_min_shown_frac * ref <= feet.height_px < ref
        else:
            short = feet.height_px < (1.0 - loss) * ref
        if short:  # ref > 0: a remembered height, or the line's for one walking in
            out.append(_lengthen(feet, ref - feet.height_px))
            age += 1
        elif not cut[i] and not (heights and feet.height_px > (1.0 + loss) * ref):
            out.append(feet)
            heights, age = (*heights, feet.height_px)[-_WHOLE_FRAMES:], 0
        else:
            out.append(feet)
            age += 1
        if heights:
            whole[label], since[label] = heights, age
    return HeightMemory(whole, since, top), tuple(out)


@dataclass(frozen=True)
class FeetState:
    """One camera's memory for its targets' feet: the heights they were seen whole
    (:func:`complete_step`) and the vertical learned from them (:func:`vertical_step`)."""

    heights: HeightMemory = field(default_factory=HeightMemory)
    verticals: Verticals = field(default_factory=Verticals)


def feet_step(state: FeetState, result: TrackResult, cfg: FeetConfig,
              sizes: SizeModel | None = None) -> tuple[FeetState, tuple[Feet, ...]]:
    """Feet of every target of one frame (``result``'s order), completed where a target lost
    its lower body. With ``cfg.up == "learned"`` their height axes are the camera's verticals
    as learned from the frames before; this frame's axes are then added to what it learned."""
    learned = cfg.method == "pca" and cfg.up == "learned"
    vp = state.verticals.vp if learned else None
    heights, feet = complete_step(state.heights, target_feet_records(result, cfg, vp), result,
                                  cfg, sizes)
    verticals = vertical_step(state.verticals, result, cfg) if learned else state.verticals
    return FeetState(heights, verticals), feet


def _line_height(sizes: SizeModel | None, top: float) -> float:
    """The height in px of a whole person whose head is at row ``top`` (px edge) by the
    size model's line of whole people (:attr:`SizeModel.whole`); 0 without that line."""
    if sizes is None or sizes.whole is None:
        return 0.0
    return max(0.0, float(feet_row(sizes.whole, np.array(top))) - top)


def _lengthen(feet: Feet, step_px: float) -> Feet:
    """``feet`` moved ``step_px`` further down its down axis, its height and box with it."""
    down = -feet.up if -feet.up[1] >= np.sqrt(0.5) else -_IMAGE_UP
    shift = step_px * down
    corners = feet.box_corners_xy.copy()
    corners[2:] += shift  # bottom-right, bottom-left
    return replace(feet, point=feet.point + shift, height_px=feet.height_px + step_px,
                   box_corners_xy=corners, outline_xy=feet.outline_xy + shift,
                   completed_px=step_px)


def target_feet(result: TrackResult, cfg: FeetConfig) -> tuple[np.ndarray, np.ndarray]:
    """Feet (N, 2) float64 [x, y] and heights (N,) float64 pixels of every target, by cfg.method."""
    records = target_feet_records(result, cfg)
    if not records:
        return np.zeros((0, 2)), np.zeros(0)
    return np.stack([r.point for r in records]), np.array([r.height_px for r in records])


def smooth_feet(
    frame: np.ndarray,
    track: np.ndarray,
    feet: np.ndarray,
    height: np.ndarray,
    half_window: int,
    break_heights: float,
) -> np.ndarray:
    """Each target's feet smoothed over time: a centred local linear fit (offline) [beyond].

    frame (N,) int64; track (N,) int64, one id per target track (one row per frame and track);
    feet (N, 2) float64 px; height (N,) float64 px. Returns (N, 2) float64.

    The per-frame feet swing about the walker's ground point with the gait (the midpoint of the
    two feet is ahead of it, then behind it, once a step); fitting a straight walk to the
    frames within ``half_window`` of each row and taking the fit at that frame removes the
    swing without the lag of a causal filter (fitted to past frames only, it did not help).
    The fit never spans a step of the feet of more than ``break_heights`` of the target's
    height (the smaller of the two frames') per frame: a merge, split or door moved the blob,
    not the person. A row with fewer than three frames in its piece keeps its feet.
    """
    feet = np.asarray(feet, np.float64).reshape(-1, 2)
    out = feet.copy()
    if half_window <= 0 or len(feet) < 3:
        return out
    frame = np.asarray(frame, np.int64)
    order = np.lexsort((frame, track))
    f, xy, h = frame[order], feet[order], np.asarray(height, np.float64)[order]
    t = np.asarray(track)[order]
    gap = np.diff(f).astype(np.float64)
    step = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    new_piece = (t[1:] != t[:-1]) | (gap <= 0) | (
        step > break_heights * np.maximum(np.minimum(h[1:], h[:-1]), 1.0) * np.maximum(gap, 1.0))
    piece = np.concatenate([[0], np.cumsum(new_piece)])
    # Rows of one piece are contiguous in this order; a neighbour at frame f + d is found
    # by searching (piece, frame) keys.
    key = piece * (int(f.max()) - int(f.min()) + 2 * half_window + 2) + (f - f.min())
    s0, s1, s2 = np.zeros(len(f)), np.zeros(len(f)), np.zeros(len(f))
    sx, stx = np.zeros((len(f), 2)), np.zeros((len(f), 2))
    for d in range(-half_window, half_window + 1):
        j = np.searchsorted(key, key + d)
        ok = j < len(key)
        ok[ok] = key[j[ok]] == key[ok] + d
        s0 += ok
        s1 += ok * d
        s2 += ok * d * d
        sx[ok] += xy[j[ok]]
        stx[ok] += d * xy[j[ok]]
    det = s0 * s2 - s1 * s1
    fit = (s0 >= 3) & (det > 0)
    smooth = (s2[fit, None] * sx[fit] - s1[fit, None] * stx[fit]) / det[fit, None]
    out[order[fit]] = smooth
    return out
