"""Single-camera tracker (SPEC §2, thesis §3.2.2): labels MVO blobs (or boxes) frame to frame.

    state = tracker_init()
    for mvo_labels, frame in frames:
        state, result = track_masks(state, mvo_labels, frame, params.tracker)

Labels are integers >= 1, never reused within a camera (the counter lives in the state).

Rules, applied to the overlap matrix of previous targets (rows) x current blobs (columns); a pair
overlaps when it shares at least ``min_overlap_px`` pixels (boxes: IoU above ``min_box_iou``).

1. Every previous target picks one *continuation* blob among those it overlaps:
   - when none of those blobs overlaps another previous target (a plain move or a pure split),
     the largest blob (thesis: "the largest blob inherits"; ties: larger overlap, then lower id);
   - otherwise (combination cases) the blob sharing the most pixels with it (ties: larger blob,
     then lower id), because there the largest blob is often someone else's.
2. A blob that is the continuation of exactly one previous target inherits its label.
3. A blob that is the continuation of two or more previous targets is a *merge*: its pixels are
   divided among them (:func:`_divide_blob`) and each keeps its label while merged. A merged
   target that receives no pixel is fully occluded and is retired, and so is one given under
   ``merge_hidden_frac`` of its template for ``merge_hidden_frames`` frames in a row (behind
   something that is not foreground, it was fed a sliver of its neighbour); one whose template
   is predicted more than half past the left, right or bottom border has walked out and is
   retired too (``merge_exit``; the pixels the division gives it stay unlabelled, not someone
   else's). Targets that were parts of one person (stacked head and body, or a leg inside its
   person's box) reunite instead: the largest in view keeps its label (:func:`_reunite`,
   ``reunite_fragments``; of one walking out over the left, right or bottom border only the part
   of its template still inside counts). Stacked parts taller together than the camera's size
   line says a person is there are two people, one behind the other, and stay a merge
   (``fragment_max_height_frac``; needs ``size_model``). A part cut from a target by a group cut
   (rule 0) that shares one merged blob with it, the blob showing one head, for
   ``group_rejoin_frames`` frames in a row reunites with it too: the cut was false. So does a
   split child (rule 4, ``split_rejoin``) that is one merged blob with the target it split from
   from the frame after the split on (a leg that came apart for a frame; one still apart then
   walked away, and is forgotten as a part). So does a merged target whose share of the blob
   has been a leg part of the blob for ``part_merge_frames`` frames in a row (born on a leg or
   a shadow patch, so its template is no leg of its person's and the merge did not reunite
   it).
4. A blob that is nobody's continuation gets a new label: a *split* child of the previous target
   it overlaps most if it overlaps any (combination case: blob 2 overlaps targets 1 and 2, which
   both continue in blob 1 -> blob 2 is a split child of whichever it shares more pixels with),
   else a *birth*.
5. A previous target with no pixel (no box) this frame is retired; if the person reappears, the
   new blob gets a new label (the multi-camera stage restores the identity).

Merge division (a sound replacement for the thesis's colour segmentation + B-spline matching):
each merged target's template (its mask the last frame it was alone) is placed at its predicted
centroid (last centroid + mean velocity over ``merge_motion_frames``). Each blob pixel scores,
for each target, a spatial term (0 inside its prediction, -d / ``merge_distance_px`` at d px
outside, from distance transforms) plus, when a frame is given, the log-likelihood of its colour
under the target's appearance histogram (learned while it was alone); the best target takes the
pixel. Without colour, a pixel inside several predictions goes to the front-most (lowest bottom
edge: nearest the camera), a pixel inside none to the nearest. The merged target's centroid is
then corrected by how far its assigned pixels sit from the part of its prediction that the other
targets do not explain, so the prediction follows the target through the merge. Someone walking
out over the left or right border (:func:`_leaving`) is the exception: the part in view shrinks
and changes shape, its centroid slows to half the person's speed and stops, and a newcomer
walking in there would keep a stalled prediction fed ('three' seed 2 cam0 followed one for 150
frames). Its x moves on at its velocity instead, merged or not (``TargetTrack.anchor_dx``).

Detections (:func:`track_boxes`, in :mod:`mvtrack.stages.boxtrack`, importable from here too):
the same rules on boxes, except that continuations are chosen
one-to-one first (:func:`_associate_boxes`); a merged target that does not get the detection box
coasts on its predicted box. Rows with an external ``track`` id >= 0 skip the
rules: an external id present in the previous frame keeps its label; an external id seen for
the first time, or again after one or more frames of absence, gets a new label (a label's life
is one unbroken run of frames everywhere in mvtrack; the multi-camera stage re-attaches).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import cv2
import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import find_peaks

from mvtrack.params import TrackerConfig
from mvtrack.stages.background import (
    SizeModel,
    box_intersections,
    link_groups,
    stacked_boxes,
    too_tall_unions,
)
from mvtrack.stages.targets import touching_sides

if TYPE_CHECKING:
    from mvtrack.stages.boxtrack import track_boxes

__all__ = [
    "MergeDivision",
    "TargetTrack",
    "TrackResult",
    "TrackerState",
    "group_cuts",
    "track_boxes",
    "track_masks",
    "tracker_init",
]

_HALF_PX = 0.5  # pixel centre to pixel edge (FORMATS.md pixel convention)
_NO_CUTS = np.zeros(0, np.int64)


@dataclass(frozen=True)
class TargetTrack:
    """What the tracker remembers of one live target.

    label:                 int >= 1
    centroids_xy:          (k, 2) float64, recent positions (boxes: box centres), oldest first,
                           k <= merge_motion_frames + 1: the mask's centroid shifted right by
                           ``anchor_dx``
    box_xywh:              (4,) float64, the target's box in the last frame
    template:              (h, w) bool or None, its mask the last frame it was alone (masks only)
    template_centroid_xy:  (2,) float64, the position in template pixel coordinates (the
                           template's centroid shifted right by ``anchor_dx``)
    colour_hist:           (bins**channels,) float64 summing to 1, or None before any colour
    merged:                bool, whether it was part of a merge in the last frame
    external_id:           int, the detection's own track id, -1 when tracked by the rules
    cut_from:              int, the label of the target whose blob a group cut gave it its
                           part, or (``split_rejoin``) that it split from (0: none)
    split_child:           bool, cut_from is the target it split from: it is forgotten the
                           first frame the two are not one merged blob
    rejoined:              int, frames in a row it has shared one merged blob with cut_from
    as_part:               int, frames in a row its share of a merged blob was a leg part of
                           the blob (:func:`_legs_of`)
    hidden:                int, frames in a row it was merged and given under
                           ``merge_hidden_frac`` of its template's pixels
    anchor_dx:             float, how far right of the mask's centroid the position lies. It
                           changes only while someone walks out over the left or right border
                           (:func:`_leaving`): then the position moves on at their velocity
    seen_whole:            bool, whether one of its unmerged masks touched neither the left
                           nor the right border (someone born at one is walking in until then)
    """

    label: int
    centroids_xy: np.ndarray
    box_xywh: np.ndarray
    template: np.ndarray | None = None
    template_centroid_xy: np.ndarray = field(default_factory=lambda: np.zeros(2))
    colour_hist: np.ndarray | None = None
    merged: bool = False
    external_id: int = -1
    cut_from: int = 0
    split_child: bool = False
    rejoined: int = 0
    as_part: int = 0
    hidden: int = 0
    anchor_dx: float = 0.0
    seen_whole: bool = False

    def velocity_xy(self) -> np.ndarray:
        """(2,) float64 px/frame: mean displacement over the remembered centroids."""
        c = self.centroids_xy
        if len(c) < 2:
            return np.zeros(2)
        return (c[-1] - c[0]) / (len(c) - 1)

    def predicted_xy(self) -> np.ndarray:
        """(2,) float64: the position expected this frame (constant velocity)."""
        return self.centroids_xy[-1] + self.velocity_xy()


@dataclass(frozen=True)
class TrackerState:
    """Frozen tracker state of one camera.

    label_image:  (H, W) int32 or None, last frame's labels (None before the first mask frame
                  and for detections)
    targets:      live targets, sorted by label
    next_label:   the next label to hand out (labels are never reused)
    """

    label_image: np.ndarray | None = None
    targets: tuple[TargetTrack, ...] = ()
    next_label: int = 1

    def target(self, label: int) -> TargetTrack:
        for t in self.targets:
            if t.label == label:
                return t
        raise KeyError(f"no live target with label {label}")


@dataclass(frozen=True)
class MergeDivision:
    """How one merged blob's pixels (or one detection box) were divided.

    blob_id:          MVO blob id (masks) or detection row (boxes)
    labels:           (T,) int64, the merged targets
    predicted_xy:     (T, 2) float64, each target's predicted centroid (its template's,
                      placed where it is expected)
    assigned_px:      (T,) int64, pixels given to each target (boxes: 1 for the target that got
                      the detection box, 0 for those that coast on their prediction)
    by_cover_px:      pixels covered by exactly one prediction, and given to it
    by_colour_px:     contested or uncovered pixels decided by appearance
    by_distance_px:   uncovered pixels decided by distance to the predictions
    by_depth_px:      contested pixels decided by depth order (no colour available)
    """

    blob_id: int
    labels: np.ndarray
    predicted_xy: np.ndarray
    assigned_px: np.ndarray
    by_cover_px: int = 0
    by_colour_px: int = 0
    by_distance_px: int = 0
    by_depth_px: int = 0


@dataclass(frozen=True)
class TrackResult:
    """One camera, one frame of single-camera tracking.

    labels:           (N,) int64, target labels present this frame, sorted
    label_image:      (H, W) int32, 0 background else the target label; None for detections
    boxes_xywh:       (N, 4) float64 (FORMATS.md: a box over columns 10..20 has x=9.5, w=11)
    areas_px:         (N,) float64, mask pixel counts (boxes: w * h)
    blob_of_target:   (N,) int64, the MVO blob id (masks) or detection row (boxes) of each target;
                      -1 for a merged detection target coasting on its prediction
    feet_xy:          (N, 2) float64, the detection's own foot point, NaN rows when absent (and
                      always NaN for masks)
    overlap:          (P, B) previous targets x current blobs: shared pixels (int64) for masks,
                      IoU (float64) for boxes
    overlap_rows:     (P,) int64, the previous labels (rows of ``overlap``)
    overlap_cols:     (B,) int64, the blob ids (masks) or detection rows (boxes)
    births:           labels born this frame (not from a split)
    retirements:      labels of the previous frame that are gone
    splits:           (parent label, (new child labels...)) per splitting target
    merges:           (blob id, (labels...)) per merged blob
    merge_divisions:  the evidence of each merge, same order as ``merges``
    reunions:         (kept label, (absorbed labels...)) per blob that merged fragment targets
                      of one person (masks only); the absorbed labels are retired
    groups:           (blob id, (labels left to right...)) per unmerged blob cut into people
                      by :func:`group_cuts` (masks only)
    hidden:           labels left out of a merge division as hidden (``merge_hidden_frac``;
                      masks only); they are retired
    """

    labels: np.ndarray
    label_image: np.ndarray | None
    boxes_xywh: np.ndarray
    areas_px: np.ndarray
    blob_of_target: np.ndarray
    feet_xy: np.ndarray
    overlap: np.ndarray
    overlap_rows: np.ndarray
    overlap_cols: np.ndarray
    births: tuple[int, ...] = ()
    retirements: tuple[int, ...] = ()
    splits: tuple[tuple[int, tuple[int, ...]], ...] = ()
    merges: tuple[tuple[int, tuple[int, ...]], ...] = ()
    merge_divisions: tuple[MergeDivision, ...] = ()
    reunions: tuple[tuple[int, tuple[int, ...]], ...] = ()
    groups: tuple[tuple[int, tuple[int, ...]], ...] = ()
    hidden: tuple[int, ...] = ()

    def index_of(self, label: int) -> int | None:
        """Row of ``label`` in this frame, or None if absent."""
        hits = np.flatnonzero(self.labels == label)
        return int(hits[0]) if len(hits) else None

    def shared_labels(self) -> set[int]:
        """Labels in a merge or a group this frame, or in a split (parent and children): their
        masks may hold two people, or half of one."""
        out = {label for _, labels in self.merges + self.groups for label in labels}
        return out | {label for parent, children in self.splits for label in (parent, *children)}


def tracker_init() -> TrackerState:
    """A fresh tracker for one camera: no targets, next label 1."""
    return TrackerState()


# --------------------------------------------------------------------------- association


@dataclass(frozen=True)
class _Plan:
    """Outcome of the rules on an overlap matrix (indices into rows / columns)."""

    inheritors: tuple[tuple[int, ...], ...]  # per blob: previous rows continuing in it
    split_parent: tuple[int, ...]  # per blob with no inheritor: the row it split from, or -1


def _associate(overlap: np.ndarray, linked: np.ndarray, sizes: np.ndarray) -> _Plan:
    """Apply rules 1-4 of the module docstring. overlap, linked: (P, B); sizes: (B,)."""
    n_rows, n_blobs = linked.shape
    parents_per_blob = linked.sum(axis=0)
    heirs: list[list[int]] = [[] for _ in range(n_blobs)]
    for row in range(n_rows):
        kids = np.flatnonzero(linked[row])
        if len(kids) == 0:
            continue
        ov, sz = overlap[row, kids], sizes[kids]
        if np.all(parents_per_blob[kids] == 1):
            order = np.lexsort((kids, -ov, -sz))  # largest blob, then overlap, then lowest id
        else:
            order = np.lexsort((kids, -sz, -ov))  # largest overlap, then blob, then lowest id
        heirs[int(kids[order[0]])].append(row)
    parent = []
    for b in range(n_blobs):
        rows = np.flatnonzero(linked[:, b])
        parent.append(-1 if heirs[b] or len(rows) == 0 else int(rows[np.argmax(overlap[rows, b])]))
    return _Plan(tuple(tuple(h) for h in heirs), tuple(parent))


def _events(
    plan: _Plan,
    row_labels: np.ndarray,
    new_labels: dict[int, int],
    extra: list[tuple[int, int]] | None = None,
) -> tuple[tuple[int, ...], tuple[tuple[int, tuple[int, ...]], ...]]:
    """Births and splits from a plan; new_labels maps blob index -> the label it was given,
    extra lists further (blob index, label) pairs (group parts: children of the blob's
    inheritor, if any)."""
    births: list[int] = []
    kids: dict[int, list[int]] = {}
    pairs = sorted([*new_labels.items(), *(extra or [])], key=lambda bl: bl[1])
    for b, label in pairs:
        heirs = plan.inheritors[b]
        p = heirs[0] if heirs else plan.split_parent[b]
        if p < 0:
            births.append(label)
        else:
            kids.setdefault(int(row_labels[p]), []).append(label)
    splits = tuple((parent, tuple(ch)) for parent, ch in sorted(kids.items()))
    return tuple(births), splits


def _push_centroid(track: TargetTrack, xy: np.ndarray, cfg: TrackerConfig) -> np.ndarray:
    keep = cfg.merge_motion_frames
    return np.concatenate([track.centroids_xy, xy[None]])[-(keep + 1) :].copy()


# --------------------------------------------------------------------------- appearance


def _colour_codes(frame: np.ndarray, cfg: TrackerConfig) -> np.ndarray:
    """(h, w) int64 histogram bin of every pixel; frame (h, w) or (h, w, C), uint8 or [0, 1]."""
    f = np.asarray(frame)
    if f.dtype == np.uint8:  # floor(f / 256 * bins) in integers: 3x faster than in floats
        q = (f.astype(np.int64) * cfg.colour_bins) >> 8
    else:
        q = np.clip((f.astype(np.float64) * cfg.colour_bins).astype(np.int64), 0,
                    cfg.colour_bins - 1)
    if q.ndim == 2:
        return q
    codes = np.zeros(q.shape[:2], np.int64)
    for ch in range(q.shape[2]):
        codes = codes * cfg.colour_bins + q[..., ch]
    return codes


def _n_codes(frame: np.ndarray, cfg: TrackerConfig) -> int:
    channels = 1 if np.ndim(frame) == 2 else np.shape(frame)[2]
    return int(cfg.colour_bins**channels)


def _update_hist(
    old: np.ndarray | None, codes: np.ndarray, n_codes: int, cfg: TrackerConfig
) -> np.ndarray:
    h = np.bincount(codes, minlength=n_codes).astype(np.float64)
    h /= max(h.sum(), 1.0)
    if old is None or len(old) != n_codes:
        return h
    return (1.0 - cfg.colour_rate) * old + cfg.colour_rate * h


# --------------------------------------------------------------------------- merge division


def _paint_prediction(track: TargetTrack, shape: tuple[int, int], origin: np.ndarray) -> np.ndarray:
    """(h, w) bool: the track's template placed at its predicted centroid, in a crop at origin."""
    out = np.zeros(shape, bool)
    if track.template is None:
        return out
    top_left = np.round(track.predicted_xy() - track.template_centroid_xy - origin).astype(int)
    x0, y0 = int(top_left[0]), int(top_left[1])
    th, tw = track.template.shape
    ys, xs = slice(max(y0, 0), min(y0 + th, shape[0])), slice(max(x0, 0), min(x0 + tw, shape[1]))
    if ys.start < ys.stop and xs.start < xs.stop:
        out[ys, xs] = track.template[ys.start - y0 : ys.stop - y0, xs.start - x0 : xs.stop - x0]
    return out


def _crop_window(
    blob_slice: tuple[slice, slice], tracks: list[TargetTrack], shape: tuple[int, ...]
) -> tuple[slice, slice]:
    """The blob's box grown to hold every merged target's prediction, clipped to the frame."""
    y0, y1 = blob_slice[0].start, blob_slice[0].stop
    x0, x1 = blob_slice[1].start, blob_slice[1].stop
    for t in tracks:
        if t.template is None:
            continue
        tl = np.round(t.predicted_xy() - t.template_centroid_xy).astype(int)
        x0, y0 = min(x0, int(tl[0])), min(y0, int(tl[1]))
        x1 = max(x1, int(tl[0]) + t.template.shape[1])
        y1 = max(y1, int(tl[1]) + t.template.shape[0])
    return slice(max(y0, 0), min(y1, shape[0])), slice(max(x0, 0), min(x1, shape[1]))


def _colour_scores(
    tracks: list[TargetTrack], codes: np.ndarray | None, cfg: TrackerConfig
) -> np.ndarray | None:
    """(T, n) log-likelihood of each pixel's colour code under each target, or None."""
    if codes is None or any(t.colour_hist is None for t in tracks):
        return None
    hists = np.stack([t.colour_hist for t in tracks if t.colour_hist is not None])
    if hists.shape[1] <= int(codes.max(initial=0)):
        return None
    return np.log(np.maximum(hists[:, codes], cfg.colour_floor))


def _depth_key(tracks: list[TargetTrack]) -> np.ndarray:
    """(T,) float64: predicted bottom edge of each target (larger = nearer the camera)."""
    return np.array(
        [
            t.predicted_xy()[1] + t.template.shape[0] - t.template_centroid_xy[1]
            if t.template is not None
            else -np.inf
            for t in tracks
        ]
    )


def _divide_blob(
    blob: np.ndarray,
    tracks: list[TargetTrack],
    codes: np.ndarray | None,
    origin: np.ndarray,
    cfg: TrackerConfig,
) -> tuple[np.ndarray, dict[str, int], np.ndarray]:
    """Assign each pixel of ``blob`` (a crop at ``origin``) to one of ``tracks``.

    Spatial evidence: a pixel d px outside a target's prediction scores -d / merge_distance_px
    for it (0 inside). With colour, each pixel goes to the best spatial + log colour likelihood;
    without, to the target whose prediction covers it, the front-most when several do, the
    nearest when none does.
    codes: (h, w) int64 colour codes of the crop, or None. Returns (h, w) int index into tracks
    (-1 outside the blob), the counts per decision kind, and the (T, h, w) bool predictions.
    """
    pred = np.stack([_paint_prediction(t, blob.shape, origin) for t in tracks])
    ys, xs = np.nonzero(blob)
    far = float(sum(blob.shape))  # farther than any pixel of the crop
    dist = np.stack(
        [
            cv2.distanceTransform((~p).astype(np.uint8), cv2.DIST_L2, 5)[ys, xs]
            if p.any()
            else np.full(len(ys), far)
            for p in pred
        ]
    ).astype(np.float64)
    cover = dist == 0
    n_cover = cover.sum(axis=0)
    spatial = -dist / cfg.merge_distance_px
    scores = _colour_scores(tracks, None if codes is None else codes[ys, xs], cfg)
    if scores is not None:
        who = np.argmax(spatial + scores, axis=0)
        by_cover = int(((n_cover == 1) & cover[who, np.arange(len(ys))]).sum())
        counts = {"by_cover_px": by_cover, "by_colour_px": len(ys) - by_cover}
    else:
        many = n_cover >= 2
        key = spatial.copy()
        depth = np.broadcast_to(_depth_key(tracks)[:, None], cover.shape)
        key[:, many] = np.where(cover[:, many], depth[:, many], -np.inf)
        who = np.argmax(key, axis=0)
        counts = {
            "by_cover_px": int((n_cover == 1).sum()),
            "by_depth_px": int(many.sum()),
            "by_distance_px": int((n_cover == 0).sum()),
        }
    out = np.full(blob.shape, -1)
    out[ys, xs] = who
    return out, counts, pred


def _corrected_centroid(
    track: TargetTrack, mine: np.ndarray, visible: np.ndarray, origin: np.ndarray
) -> np.ndarray:
    """Prediction + (centroid of the assigned pixels - centroid of the visible prediction)."""
    pred = track.predicted_xy()
    if not mine.any():
        return pred
    my, mx = np.nonzero(mine)
    got = np.array([mx.mean(), my.mean()]) + origin
    if not visible.any():
        return got + np.array([track.anchor_dx, 0.0])
    vy, vx = np.nonzero(visible)
    return pred + got - (np.array([vx.mean(), vy.mean()]) + origin)


# --------------------------------------------------------------------------- masks


@dataclass(frozen=True)
class _Inputs:
    """This frame's colour evidence and the config, passed together."""

    frame: np.ndarray | None  # (H, W) or (H, W, C) image, None without colour
    cfg: TrackerConfig
    size_model: SizeModel | None = None  # the camera's person height per feet row, if learned
    cols: int | None = None  # the frame's width (the border cuts boxes on its sides)

    def codes_in(self, window: tuple[slice, slice]) -> np.ndarray | None:
        """(h, w) int64 colour codes of the frame in ``window``, or None without a frame."""
        return None if self.frame is None else _colour_codes(self.frame[window], self.cfg)


@dataclass
class _Frame:
    """Mutable scratch for building one frame's result (never leaves this module)."""

    label_image: np.ndarray
    rows: np.ndarray  # (P,) previous labels
    overlap: np.ndarray  # (P, B)
    blob_ids: np.ndarray  # (B,)
    plan: _Plan
    next_label: int
    new_labels: dict[int, int] = field(default_factory=dict)  # blob index -> new label
    centroids: dict[int, np.ndarray] = field(default_factory=dict)
    merged: set[int] = field(default_factory=set)
    blob_of: dict[int, int] = field(default_factory=dict)
    merged_boxes: dict[int, np.ndarray] = field(default_factory=dict)  # merged blob id -> box
    merges: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)
    divisions: list[MergeDivision] = field(default_factory=list)
    reunions: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)
    extra_labels: list[tuple[int, int]] = field(default_factory=list)  # (blob index, label)
    cut_from: dict[int, int] = field(default_factory=dict)  # new group part -> label cut from
    split_children: set[int] = field(default_factory=set)  # of cut_from: split children
    two_heads: set[int] = field(default_factory=set)  # merged with a group sibling, two heads
    hidden: list[int] = field(default_factory=list)  # labels left out of a division as hidden
    groups: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)


def _stacked(box_xywh: np.ndarray, ctx: _Inputs) -> np.ndarray:
    """(K, K) bool: boxes (K, 4) stacked like the parts of one person (TrackerConfig.fragment_*):
    :func:`stacked_boxes` (with no aspect test at the frame's side borders once there is a
    size model), and no taller together than ``fragment_max_height_frac`` times the person
    height the size line predicts at their union's bottom (:func:`too_tall_unions`)."""
    cfg = ctx.cfg
    stacked = stacked_boxes(
        box_xywh,
        cfg.fragment_x_overlap_frac,
        cfg.fragment_y_gap_frac,
        cfg.fragment_y_overlap_frac,
        cfg.fragment_max_aspect,
        None if ctx.size_model is None or ctx.size_model.slope_intercept() is None else ctx.cols,
    )
    too_tall = too_tall_unions(box_xywh, ctx.size_model, cfg.fragment_max_height_frac)
    return stacked if too_tall is None else stacked & ~too_tall


def _legs_of(box_xywh: np.ndarray, ctx: _Inputs) -> np.ndarray:
    """(K, K) bool, [i, j]: box i is a lower part of box j (a leg or the feet of that person):
    at least ``part_contained_frac`` of its area inside j's box grown by ``part_reach_frac`` of
    j's height to the left, right and below (a trailing leg steps out of the rest of its
    person), under ``part_max_height_frac`` of j's height and of the height the camera's size
    line predicts at its bottom (j may be people stacked one behind the other), its bottom
    within ``part_bottom_frac`` of j's height from j's bottom; a part at most
    ``part_raised_frac`` of j's height tall may end up to that fraction above it (a lower leg
    stretched out behind, its foot raised). A person behind another is contained too, but
    stands further back: the feet are higher up (and even a far one is taller than a lower
    leg of the near one: generated 'crowd' seed 7, three far people side by side)."""
    cfg = ctx.cfg
    x, y, w, h = np.asarray(box_xywh, np.float64).reshape(-1, 4).T
    bottom, reach = y + h, cfg.part_reach_frac * h
    grown = np.c_[x - reach, y, w + 2 * reach, h + reach]
    inside = (box_intersections(box_xywh, grown)
              >= cfg.part_contained_frac * np.maximum(w * h, 1e-9)[:, None])
    rise = bottom - bottom[:, None]  # [i, j]: how far box i ends above box j's bottom
    raised = (h[:, None] <= cfg.part_raised_frac * h) & (rise <= cfg.part_raised_frac * h)
    part = (
        inside
        & (h[:, None] < cfg.part_max_height_frac * h)
        & (rise >= -cfg.part_bottom_frac * h)
        & ((rise <= cfg.part_bottom_frac * h) | raised)
    )
    person = None if ctx.size_model is None else ctx.size_model.height_at(bottom)
    if person is not None:
        part &= ~((person > 0) & (h >= cfg.part_max_height_frac * person))[:, None]
    np.fill_diagonal(part, False)
    return part


def _sizes_in_view(tracks: list[TargetTrack], boxes: np.ndarray,
                   shape: tuple[int, ...]) -> np.ndarray:
    """(K,) float64: each target's template pixels (no template: its box area) times the share
    of its template box (``boxes`` (K, 4), :func:`_template_box`) inside the left, right and
    bottom borders of a frame of ``shape``: a target walking out over one keeps the template
    of when it was more in view. Not the top, as in :func:`_walked_out` (generated 'doors'
    seed 0 cam1, frame 392: a far person cut by the top border, whose shrinking share moved
    the prediction up, was taken for one leaving and absorbed by a sliver of the person
    hidden behind the doors)."""
    rows, cols = shape[:2]
    top = min(float(boxes[:, 1].min()), -_HALF_PX)  # the frame, open above
    frame = np.array([-_HALF_PX, top, cols, rows - _HALF_PX - top])
    area = boxes[:, 2] * boxes[:, 3]
    share = box_intersections(boxes, frame)[:, 0] / np.maximum(area, 1e-9)
    pixels = np.array([float(t.template.sum()) if t.template is not None else a
                       for t, a in zip(tracks, area, strict=True)])
    return pixels * share


def _template_box(t: TargetTrack) -> np.ndarray:
    """(4,) float64: the box of the target's last unmerged mask placed at its predicted centroid
    (while merged, its divided box is only the visible part and would look like a fragment)."""
    if t.template is None:
        return t.box_xywh
    x, y = t.predicted_xy() - t.template_centroid_xy - _HALF_PX
    return np.array([x, y, t.template.shape[1], t.template.shape[0]], np.float64)


def _reunite(
    heirs: tuple[int, ...], targets: tuple[TargetTrack, ...], work: _Frame, ctx: _Inputs
) -> tuple[int, ...]:
    """The heirs of a merged blob that are distinct people: of every group of fragment targets
    (stacked, :func:`_stacked`, or a leg inside its person's box, :func:`_legs_of`, on their
    previous boxes) only the largest in view (:func:`_sizes_in_view`) stays; the others are
    recorded as absorbed in ``work.reunions`` and, receiving no pixel, retire."""
    if not ctx.cfg.reunite_fragments:
        return heirs
    boxes = np.stack([_template_box(targets[r]) for r in heirs])
    legs = _legs_of(boxes, ctx)
    linked = (_stacked(boxes, ctx) | legs | legs.T | _rejoined(heirs, targets, work, ctx.cfg)
              | _long_parts(heirs, targets, ctx.cfg))
    n_groups, group = link_groups(linked)
    if n_groups == len(heirs):
        return heirs
    in_view = _sizes_in_view([targets[r] for r in heirs], boxes, work.label_image.shape)
    kept = []
    for g in range(n_groups):
        members = [heirs[i] for i in sorted(np.flatnonzero(group == g),
                                            key=lambda i: (-in_view[i], targets[heirs[i]].label))]
        kept.append(members[0])
        if len(members) > 1:
            absorbed = tuple(sorted(targets[r].label for r in members[1:]))
            work.reunions.append((targets[members[0]].label, absorbed))
    return tuple(sorted(kept))


def _not_hidden(heirs: tuple[int, ...], targets: tuple[TargetTrack, ...], work: _Frame,
                cfg: TrackerConfig) -> tuple[int, ...]:
    """The heirs of a merged blob less those hidden (``merge_hidden_frames`` frames in a row
    with a share under ``merge_hidden_frac`` of their template: behind something that is not
    foreground), which receive no pixel and retire (recorded in ``work.hidden``); all of them
    if every one is."""
    seen = tuple(r for r in heirs if targets[r].hidden < cfg.merge_hidden_frames)
    if not seen:
        return heirs
    work.hidden += [targets[r].label for r in heirs if r not in seen]
    return seen


def _walked_out(tracks: list[TargetTrack], shape: tuple[int, ...], cfg: TrackerConfig
                ) -> frozenset[int]:
    """Labels of the merged targets whose template, at its predicted place, has its centre past
    the left, right or bottom frame border (more than half of what was last seen of them,
    moved on, is out): they have left, though the division still gives them the sliver at
    the border (none when all of them have). Not the top: a far person cut by it keeps the
    feet in view, and a division that shrinks the part seen moves its centroid up, not the
    person."""
    if not cfg.merge_exit:
        return frozenset()
    h, w = shape[:2]
    centres = [bx[:2] + bx[2:] / 2 for bx in map(_template_box, tracks)]
    out = frozenset(t.label for t, (x, y) in zip(tracks, centres, strict=True)
                    if x < -0.5 or x > w - 0.5 or y > h - 0.5)
    return out if len(out) < len(tracks) else frozenset()


def _two_heads(
    heirs: tuple[int, ...],
    targets: tuple[TargetTrack, ...],
    mvo_labels: np.ndarray,
    blob_id: int,
    window: tuple[slice, slice],
    cfg: TrackerConfig,
) -> set[int]:
    """The labels of a merged blob's heirs (for ``work.two_heads``) when they include a group
    part and the target it was cut from and the blob (``blob_id`` of ``mvo_labels``, in
    ``window``) still shows several heads (:func:`group_cuts`): evidence that the cut was
    right. Else the empty set."""
    labels = {targets[r].label for r in heirs}
    if not any(targets[r].cut_from in labels for r in heirs):
        return set()  # the common case: no group part here, nothing to look at
    crop = mvo_labels[window] == blob_id
    if _inside(window, mvo_labels.shape) and len(group_cuts(crop, cfg)):
        return labels
    return set()


def _rejoined(
    heirs: tuple[int, ...], targets: tuple[TargetTrack, ...], work: _Frame, cfg: TrackerConfig
) -> np.ndarray:
    """(K, K) bool, [i, j]: heir i is a group part cut from heir j that has shared one merged
    blob with it, showing one head, for ``group_rejoin_frames`` frames in a row (this one
    included): the cut was false."""
    if cfg.group_rejoin_frames <= 0:
        return np.zeros((len(heirs),) * 2, bool)
    labels = np.array([targets[r].label for r in heirs])
    cut_from = np.array([targets[r].cut_from for r in heirs])
    due = np.array([targets[r].rejoined + 1 >= cfg.group_rejoin_frames
                    and targets[r].label not in work.two_heads for r in heirs])
    return (cut_from[:, None] == labels[None, :]) & due[:, None]


def _long_parts(
    heirs: tuple[int, ...], targets: tuple[TargetTrack, ...], cfg: TrackerConfig
) -> np.ndarray:
    """(K, K) bool, [i, j]: heir i's share of the merged blob it has been in has been a leg
    part of that blob for ``part_merge_frames`` frames in a row, and heir j is the other heir
    its last box shares most area with."""
    k = len(heirs)
    linked = np.zeros((k, k), bool)
    if cfg.part_merge_frames <= 0:
        return linked
    boxes = np.stack([targets[r].box_xywh for r in heirs])
    shared = box_intersections(boxes)
    np.fill_diagonal(shared, -1.0)
    for i, r in enumerate(heirs):
        if targets[r].as_part >= cfg.part_merge_frames:
            linked[i, int(np.argmax(shared[i]))] = True
    return linked


def _blob_box(window: tuple[slice, slice]) -> np.ndarray:
    ys, xs = window
    return np.array(
        [xs.start - _HALF_PX, ys.start - _HALF_PX, xs.stop - xs.start, ys.stop - ys.start],
        np.float64,
    )


def _parent_fragment(
    b: int,
    plan: _Plan,
    slices: dict[int, tuple[slice, slice]],
    blob_ids: np.ndarray,
    ctx: _Inputs,
) -> int:
    """For a blob with no inheritor: the index of its split parent's continuation blob when the
    two are parts of one person (stacked, or one a leg of the other: the blob is a fragment of
    the parent), else -1."""
    parent = plan.split_parent[b]
    if parent < 0 or not ctx.cfg.reunite_fragments:
        return -1
    for c, heirs in enumerate(plan.inheritors):
        if heirs == (parent,):
            window, other = slices[int(blob_ids[b])], slices[int(blob_ids[c])]
            pair = np.stack([_blob_box(window), _blob_box(other)])
            legs = _legs_of(pair, ctx)
            return c if bool(_stacked(pair, ctx)[0, 1] or legs[0, 1] or legs[1, 0]) else -1
    return -1


def group_cuts(blob: np.ndarray, cfg: TrackerConfig) -> np.ndarray:
    """Columns where an unmerged blob holding several people side by side is cut (rule 0).

    blob: (h, w) bool, one blob's mask in its bounding box. The top silhouette (per column, the
    blob height above the highest foreground row), smoothed over a head width, must have two or
    more peaks at least ``group_person_width_frac * h`` apart (parts that wide and at least
    ``group_min_part_height_frac * h`` high) with dips of at least
    ``group_head_prominence_frac * h`` between them; the blob must be at least
    ``group_min_aspect`` times as wide as high and ``group_min_height_px`` high. When it shows
    two heads or more, they are looked for again without the blob's components smaller than
    ``group_min_head_area_frac * h**2`` (specks). Each cut is half-way between two heads.
    Returns (k,) int64 sorted cut columns (a part is ``[cut_i, cut_{i+1})``), empty when the
    blob is one person (or ``group_split`` is off).
    """
    h, w = blob.shape
    if not cfg.group_split or w < cfg.group_min_aspect * h or h < cfg.group_min_height_px:
        return np.zeros(0, np.int64)
    heads = _heads(blob, cfg)
    if len(heads) >= 2 and cfg.group_min_head_area_frac > 0:
        blob = _without_specks(blob, cfg.group_min_head_area_frac * h * h)
        heads = _heads(blob, cfg)
    if len(heads) < 2:
        return np.zeros(0, np.int64)
    person_px = cfg.group_person_width_frac * h
    cuts = (np.floor((heads[:-1] + heads[1:]) / 2.0) + 1).astype(np.int64)
    edges = np.r_[0, cuts, w]
    for a, z in itertools.pairwise(edges):
        rows = blob[:, a:z].any(axis=1)
        part_h = np.flatnonzero(rows)
        tall = len(part_h) and part_h[-1] - part_h[0] + 1 >= cfg.group_min_part_height_frac * h
        if z - a < person_px or not tall:
            return np.zeros(0, np.int64)
    return cuts


def _heads(blob: np.ndarray, cfg: TrackerConfig) -> np.ndarray:
    """(k,) float64 columns of the heads on a blob's top silhouette (:func:`group_cuts`)."""
    h = blob.shape[0]
    top = np.where(blob.any(axis=0), h - np.argmax(blob, axis=0), 0).astype(np.float64)
    person_px = cfg.group_person_width_frac * h
    smooth = uniform_filter1d(top, max(int(person_px / 2), 1), mode="constant")
    _, props = find_peaks(
        np.r_[0.0, smooth, 0.0],
        prominence=cfg.group_head_prominence_frac * h,
        distance=max(person_px, 1.0),
        plateau_size=1,
    )
    return np.asarray((props["left_edges"] + props["right_edges"]) / 2.0 - 1.0)  # plateau centres


def _without_specks(blob: np.ndarray, min_px: float) -> np.ndarray:
    """The blob (h, w) bool without its connected components of fewer than ``min_px`` pixels
    (specks left by a shadow's head or a noisy background: no head of anyone)."""
    n, comp, stats, _ = cv2.connectedComponentsWithStats(blob.astype(np.uint8), connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= min_px
    keep[0] = False
    return np.asarray(keep[comp], bool) if n > 2 else blob


def _mask_overlap(
    prev: np.ndarray | None,
    rows: np.ndarray,
    cur: np.ndarray,
    blob_ids: np.ndarray,
    cur_index: np.ndarray,
) -> np.ndarray:
    """(P, B) int64 pixel counts shared by previous label rows and current blob ids.
    cur_index: (n,) flat indices of the labelled pixels of ``cur``."""
    n_rows, n_blobs = len(rows), len(blob_ids)
    if prev is None or n_rows == 0 or n_blobs == 0:
        return np.zeros((n_rows, n_blobs), np.int64)
    before = prev.ravel()[cur_index]
    both = before > 0
    r = np.searchsorted(rows, before[both])
    c = np.searchsorted(blob_ids, cur.ravel()[cur_index[both]])
    ok = (r < n_rows) & (rows[np.minimum(r, n_rows - 1)] == before[both])
    flat = np.bincount(r[ok] * n_blobs + c[ok], minlength=n_rows * n_blobs)
    return flat.reshape(n_rows, n_blobs).astype(np.int64)


def _merge_blob(
    work: _Frame,
    blob_id: int,
    window: tuple[slice, slice],
    blob: np.ndarray,
    tracks: list[TargetTrack],
    ctx: _Inputs,
) -> None:
    """Divide a merged blob among its targets; the pixels given to targets that have left
    (:func:`_walked_out`) stay unlabelled and those targets retire."""
    gone = _walked_out(tracks, work.label_image.shape, ctx.cfg)
    origin = np.array([window[1].start, window[0].start], np.float64)
    who, counts, pred = _divide_blob(blob, tracks, ctx.codes_in(window), origin, ctx.cfg)
    labels = np.array([t.label for t in tracks], np.int64)
    view = work.label_image[window]
    assigned = np.zeros(len(tracks), np.int64)
    for i, t in enumerate(tracks):
        if t.label in gone:
            continue
        mine = who == i
        view[mine] = t.label
        assigned[i] = int(mine.sum())
        if assigned[i]:
            visible = pred[i] & blob & ((who == i) | (who < 0))  # not explained by the others
            xy = _corrected_centroid(t, mine, visible, origin)
            if _leaving(t, ctx):  # its x moves on at its velocity
                xy[0] = t.predicted_xy()[0]
            work.centroids[t.label] = xy
            work.merged.add(t.label)
            work.blob_of[t.label] = blob_id
    work.merges.append((blob_id, tuple(int(v) for v in labels)))
    work.divisions.append(
        MergeDivision(
            blob_id=blob_id,
            labels=labels,
            predicted_xy=np.stack([t.predicted_xy() - [t.anchor_dx, 0.0] for t in tracks]),
            assigned_px=assigned,
            **counts,
        )
    )


@dataclass(frozen=True)
class _LabelIndex:
    """Where each label of a label image is: sorted labels (L,) int64, their bounding slices,
    pixel counts (L,) int64, and the flat indices (P,) int64 of all labelled pixels."""

    labels: np.ndarray
    slices: dict[int, tuple[slice, slice]]
    sizes: np.ndarray
    index: np.ndarray


def _label_index(label_image: np.ndarray) -> _LabelIndex:
    """One pass over the labelled pixels only (``ndimage.find_objects`` scans the whole frame
    per call: 2.5 ms at 768x576, against about 0.5 ms here for a few people)."""
    index = np.flatnonzero(label_image > 0)  # 15x faster than on the int32 image
    values = label_image.ravel()[index].astype(np.int64)
    order = np.argsort(values, kind="stable")
    values = values[order]
    starts = np.flatnonzero(np.r_[True, values[1:] != values[:-1]]) if len(values) else index[:0]
    width = label_image.shape[1]
    ys, xs = index[order] // width, index[order] % width
    labels = values[starts]
    slices: dict[int, tuple[slice, slice]] = {}
    if len(starts):
        y0, y1 = np.minimum.reduceat(ys, starts), np.maximum.reduceat(ys, starts)
        x0, x1 = np.minimum.reduceat(xs, starts), np.maximum.reduceat(xs, starts)
        for k, lab in enumerate(labels.tolist()):
            slices[lab] = (slice(int(y0[k]), int(y1[k]) + 1), slice(int(x0[k]), int(x1[k]) + 1))
    sizes = np.diff(np.r_[starts, len(values)]).astype(np.int64)
    return _LabelIndex(labels, slices, sizes, index)


def _mask_stats(label_image: np.ndarray) -> tuple[np.ndarray, dict[int, tuple[slice, slice]]]:
    """Sorted labels present (int64) and each one's bounding slices."""
    found = _label_index(label_image)
    return found.labels, found.slices


def _side_cut(box_xywh: np.ndarray, cols: int | None) -> int:
    """-1 when the box touches the frame's left border only, +1 the right border only, 0 when
    it touches neither (or both, or the width is not known)."""
    if cols is None:
        return 0
    left, right = touching_sides(box_xywh, (cols, 0), 0.0)[0, :2]  # rows do not matter here
    return int(right) - int(left)


def _leaving(track: TargetTrack, ctx: _Inputs) -> int:
    """The side (-1 left, +1 right) whose border cut the track's last box and toward which it
    moves, when it has been seen whole (someone walking out), else 0. Someone walking in is
    not: the part in view grows in every direction, and its centroid may move either way
    (generated 'doors' seed 0 cam1: a newcomer whose centroid moved left was walked out)."""
    side = _side_cut(track.box_xywh, ctx.cols)
    return side if track.seen_whole and side * track.velocity_xy()[0] > 0 else 0


def _anchor_dx(old: TargetTrack | None, box: np.ndarray, centroid_x: float,
               ctx: _Inputs) -> float:
    """The target's ``anchor_dx`` after an unmerged frame with mask ``box`` and centroid x.
    While someone walks out over the left or right border (:func:`_leaving`, and still cut
    by it), their position moves on at their velocity: the part in view changes shape as it
    shrinks, and its centroid slows to half their speed, then stops. Otherwise the position
    keeps its offset from the centroid."""
    if old is None:
        return 0.0
    side = _leaving(old, ctx)
    if side == 0 or _side_cut(box, ctx.cols) != side:
        return old.anchor_dx
    return float(old.predicted_xy()[0] - centroid_x)


def _new_mask_track(
    old: TargetTrack | None,
    label: int,
    crop: np.ndarray,
    window: tuple[slice, slice],
    ctx: _Inputs,
) -> TargetTrack:
    """A target's memory after an unmerged frame: template, centroid and colour refreshed."""
    ys, xs = np.nonzero(crop)
    origin = np.array([window[1].start, window[0].start], np.float64)
    local = np.array([xs.mean(), ys.mean()])
    box = np.array(
        [
            origin[0] + xs.min() - _HALF_PX,
            origin[1] + ys.min() - _HALF_PX,
            xs.max() - xs.min() + 1.0,
            ys.max() - ys.min() + 1.0,
        ]
    )
    hist = None if old is None else old.colour_hist
    codes, cfg = ctx.codes_in(window), ctx.cfg
    if codes is not None and ctx.frame is not None:
        hist = _update_hist(hist, codes[ys, xs], _n_codes(ctx.frame, cfg), cfg)
    base = old or TargetTrack(label=label, centroids_xy=np.zeros((0, 2)), box_xywh=box)
    dx = _anchor_dx(old, box, origin[0] + local[0], ctx)
    return replace(
        base,
        centroids_xy=_push_centroid(base, origin + local + [dx, 0.0], cfg),
        box_xywh=box,
        template=crop.copy(),
        template_centroid_xy=local + [dx, 0.0],
        anchor_dx=dx,
        seen_whole=base.seen_whole or _side_cut(box, ctx.cols) == 0,
        colour_hist=hist,
        merged=False,
        hidden=0,
        as_part=0,
    )


def _check_mask_inputs(
    state: TrackerState, mvo_labels: np.ndarray, frame: np.ndarray | None
) -> None:
    if mvo_labels.ndim != 2:
        raise ValueError(f"track_masks: mvo_labels must be (H, W), got {mvo_labels.shape}")
    if state.label_image is not None and state.label_image.shape != mvo_labels.shape:
        raise ValueError(
            f"track_masks: frame size changed from {state.label_image.shape} to {mvo_labels.shape}"
        )
    if frame is not None and np.shape(frame)[:2] != mvo_labels.shape:
        raise ValueError(f"track_masks: frame {np.shape(frame)} does not match {mvo_labels.shape}")


def track_masks(
    state: TrackerState,
    mvo_labels: np.ndarray,
    frame: np.ndarray | None,
    cfg: TrackerConfig,
    size_model: SizeModel | None = None,
) -> tuple[TrackerState, TrackResult]:
    """One frame of mask tracking.

    mvo_labels: (H, W) integer, 0 none, 1..K MVO blobs (ids need not be contiguous)
    frame:      (H, W, C) or (H, W) uint8 (or float in [0, 1]) image, or None (no colour cue)
    size_model: the camera's person heights per feet row (background subtraction learns them),
                or None: no height test on fragments (:func:`_stacked`)
    Returns the new state and the :class:`TrackResult` (label image, boxes, events, overlap).
    """
    cur = np.asarray(mvo_labels)
    _check_mask_inputs(state, cur, frame)
    found = _label_index(cur)
    blob_ids, slices, sizes = found.labels, found.slices, found.sizes
    rows = np.array([t.label for t in state.targets], np.int64)
    overlap = _mask_overlap(state.label_image, rows, cur, blob_ids, found.index)
    plan = _associate(overlap, overlap >= cfg.min_overlap_px, sizes)
    ctx = _Inputs(frame, cfg, size_model, cur.shape[1])

    work = _Frame(np.zeros(cur.shape, np.int32), rows, overlap, blob_ids, plan, state.next_label)
    for b, blob_id in enumerate(blob_ids):
        window = slices[int(blob_id)]
        heirs = plan.inheritors[b]
        if len(heirs) >= 2:
            work.two_heads |= _two_heads(heirs, state.targets, cur, int(blob_id), window, cfg)
            heirs = _not_hidden(heirs, state.targets, work, cfg)
            heirs = _reunite(heirs, state.targets, work, ctx)
        if len(heirs) >= 2:
            tracks = [state.targets[r] for r in heirs]
            grown = _crop_window(window, tracks, cur.shape)
            work.merged_boxes[int(blob_id)] = _blob_box(window)
            _merge_blob(work, int(blob_id), grown, cur[grown] == blob_id, tracks, ctx)
            continue
        whole = _parent_fragment(b, plan, slices, blob_ids, ctx) if not heirs else -1
        crop = cur[window] == blob_id
        cuts = group_cuts(crop, cfg) if whole < 0 and _inside(window, cur.shape) else _NO_CUTS
        if len(cuts):
            prev = None if state.label_image is None else state.label_image[window]
            _split_group(work, b, int(blob_id), window, _column_parts(crop, cuts), prev)
            continue
        if heirs:
            label = int(rows[heirs[0]])
        elif whole >= 0:
            label = int(rows[plan.inheritors[whole][0]])
        else:
            label, work.next_label = work.next_label, work.next_label + 1
            work.new_labels[b] = label
            if cfg.split_rejoin and plan.split_parent[b] >= 0:
                work.cut_from[label] = int(rows[plan.split_parent[b]])
                work.split_children.add(label)
        work.label_image[window][crop] = label
        if whole < 0:
            work.blob_of[label] = int(blob_id)
    return _finish_masks(state, work, ctx)


def _count_rejoined(track: TargetTrack, work: _Frame) -> TargetTrack:
    """The track with its group-cut bookkeeping for this frame: a part cut (or split) off
    this frame starts at 0; one merged into the blob of the target it was cut from, the blob
    showing one head, counts one more frame; any other frame resets the count, and makes a
    split child (rule 4, ``split_rejoin``) a target of its own for good: it walked away from
    its parent."""
    if track.label in work.cut_from:
        return replace(track, cut_from=work.cut_from[track.label], rejoined=0,
                       split_child=track.label in work.split_children)
    if not track.cut_from:
        return track
    together = (track.label in work.merged and track.cut_from in work.merged
                and work.blob_of.get(track.label) == work.blob_of.get(track.cut_from)
                and track.label not in work.two_heads)
    if track.split_child and not together:  # a person who walked apart, not a piece
        return replace(track, cut_from=0, split_child=False, rejoined=0)
    return replace(track, rejoined=track.rejoined + 1 if together else 0)


def _inside(window: tuple[slice, slice], shape: tuple[int, ...]) -> bool:
    """Whether a blob's bounding slices keep off the frame border (a person cut by the frame
    edge has a misleading top silhouette)."""
    ys, xs = window
    return ys.start > 0 and xs.start > 0 and ys.stop < shape[0] and xs.stop < shape[1]


def _split_group(
    work: _Frame,
    b: int,
    blob_id: int,
    window: tuple[slice, slice],
    parts: list[np.ndarray],
    prev: np.ndarray | None,
) -> None:
    """Label the parts (masks in ``window``, left to right) of a group blob: an inheriting
    target keeps the part it shares most pixels with in ``prev`` (last frame's label image in
    ``window``, or None); every other part is a new target (a split child of the inheritor,
    else a birth)."""
    heirs = work.plan.inheritors[b]
    keep = -1
    if heirs and prev is not None:
        mine = prev == work.rows[heirs[0]]
        keep = int(np.argmax([(mine & part).sum() for part in parts]))
    labels = []
    for k, part in enumerate(parts):
        if k == keep:
            label = int(work.rows[heirs[0]])
        else:
            label, work.next_label = work.next_label, work.next_label + 1
            work.extra_labels.append((b, label))
            if keep >= 0:
                work.cut_from[label] = int(work.rows[heirs[0]])
        work.label_image[window][part] = label
        work.blob_of[label] = blob_id
        labels.append(label)
    work.groups.append((blob_id, tuple(labels)))


def _column_parts(crop: np.ndarray, cuts: np.ndarray) -> list[np.ndarray]:
    """(h, w) bool masks of ``crop`` between successive cut columns, left to right."""
    parts = []
    for a, z in itertools.pairwise(np.r_[0, cuts, crop.shape[1]]):
        part = np.zeros_like(crop)
        part[:, a:z] = crop[:, a:z]
        parts.append(part)
    return parts


def _finish_masks(
    state: TrackerState, work: _Frame, ctx: _Inputs
) -> tuple[TrackerState, TrackResult]:
    cfg, rows = ctx.cfg, work.rows
    labels, slices = _mask_stats(work.label_image)
    old = {t.label: t for t in state.targets}
    tracks, boxes, areas = [], [], []
    for lab in labels:
        window = slices[int(lab)]
        crop = work.label_image[window] == lab
        fresh = _new_mask_track(old.get(int(lab)), int(lab), crop, window, ctx)
        boxes.append(fresh.box_xywh)
        areas.append(float(crop.sum()))
        if int(lab) in work.merged:  # keep the pre-merge template and colours
            prev = old[int(lab)]
            small = prev.template is not None and areas[-1] < cfg.merge_hidden_frac * float(
                prev.template.sum())
            blob_box = work.merged_boxes[work.blob_of[int(lab)]]
            leg = bool(_legs_of(np.stack([fresh.box_xywh, blob_box]), ctx)[0, 1])
            fresh = replace(
                prev,
                centroids_xy=_push_centroid(prev, work.centroids[int(lab)], cfg),
                box_xywh=fresh.box_xywh,
                merged=True,
                hidden=prev.hidden + 1 if small else 0,
                as_part=prev.as_part + 1 if leg else 0,
            )
        tracks.append(_count_rejoined(fresh, work))
    births, splits = _events(work.plan, rows, work.new_labels, work.extra_labels)
    present = set(labels.tolist())
    result = TrackResult(
        labels=labels,
        label_image=work.label_image,
        boxes_xywh=np.array(boxes, np.float64).reshape(-1, 4),
        areas_px=np.array(areas, np.float64),
        blob_of_target=np.array([work.blob_of[int(v)] for v in labels], np.int64),
        feet_xy=np.full((len(labels), 2), np.nan),
        overlap=work.overlap,
        overlap_rows=rows.copy(),
        overlap_cols=work.blob_ids,
        births=births,
        retirements=tuple(int(v) for v in rows if int(v) not in present),
        splits=splits,
        merges=tuple(work.merges),
        merge_divisions=tuple(work.divisions),
        reunions=tuple(work.reunions),
        groups=tuple(work.groups),
        hidden=tuple(sorted(work.hidden)),
    )
    new_state = TrackerState(
        label_image=work.label_image.copy(), targets=tuple(tracks), next_label=work.next_label
    )
    return new_state, result


def __getattr__(name: str) -> object:
    """``track_boxes`` lives in :mod:`mvtrack.stages.boxtrack` (which imports this module's
    types); it is loaded on first use here so that either module can be imported first."""
    if name == "track_boxes":
        from mvtrack.stages.boxtrack import track_boxes

        return track_boxes
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
