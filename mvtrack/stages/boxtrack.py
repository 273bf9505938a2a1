"""Detections tracker (SPEC §2): the single-camera rules of :mod:`mvtrack.stages.blobtrack`
applied to boxes (a camera given as detections, FORMATS.md).

    state = tracker_init()
    for boxes_xywh, tracks, feet_xy in frames:
        state, result = track_boxes(state, boxes_xywh, tracks, params.tracker, feet_xy)

Overlap is IoU above ``min_box_iou``. Continuations are chosen one-to-one first
(:func:`_associate_boxes`); a merged target that does not get the detection box coasts on its
predicted box. Rows with an external ``track`` id >= 0 skip the rules: an external id present in
the previous frame keeps its label; an external id seen for the first time, or again after one
or more frames of absence, gets a new label (a label's life is one unbroken run of frames
everywhere in mvtrack; the multi-camera stage re-attaches).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from mvtrack.params import TrackerConfig
from mvtrack.stages.blobtrack import (
    MergeDivision,
    TargetTrack,
    TrackerState,
    TrackResult,
    _Plan,
    _push_centroid,
    tracker_init,
)

__all__ = ["track_boxes", "tracker_init"]

_NO_FEET = np.full(2, np.nan)


def _associate_boxes(overlap: np.ndarray, linked: np.ndarray) -> _Plan:
    """Rules 1-4 for boxes, with continuations chosen one-to-one first.

    Boxes of different people overlap far more often than blobs do (a box holds background), so
    a greedy per-target choice would send two targets to one box while another box they overlap
    stays free. Continuations are therefore the maximum-IoU one-to-one assignment on the linked
    pairs (Hungarian); a target left without a box continues in the box it overlaps most, which
    makes that box a merge; boxes left without a target are split children or births.
    """
    n_rows, n_blobs = linked.shape
    heirs: list[list[int]] = [[] for _ in range(n_blobs)]
    r_idx, c_idx = linear_sum_assignment(np.where(linked, overlap, 0.0), maximize=True)
    matched = set()
    for r, c in zip(r_idx, c_idx, strict=True):
        if linked[r, c]:
            heirs[int(c)].append(int(r))
            matched.add(int(r))
    for r in range(n_rows):
        if r not in matched and linked[r].any():
            heirs[int(np.argmax(np.where(linked[r], overlap[r], -np.inf)))].append(r)
    parent = []
    for b in range(n_blobs):
        rows = np.flatnonzero(linked[:, b])
        parent.append(-1 if heirs[b] or len(rows) == 0 else int(rows[np.argmax(overlap[rows, b])]))
    return _Plan(tuple(tuple(sorted(h)) for h in heirs), tuple(parent))


def _iou(a_xywh: np.ndarray, b_xywh: np.ndarray) -> np.ndarray:
    """(len(a), len(b)) float64 intersection over union of two box lists."""
    a, b = a_xywh[:, None, :], b_xywh[None, :, :]
    w = np.clip(
        np.minimum(a[..., 0] + a[..., 2], b[..., 0] + b[..., 2]) - np.maximum(a[..., 0], b[..., 0]),
        0,
        None,
    )
    h = np.clip(
        np.minimum(a[..., 1] + a[..., 3], b[..., 1] + b[..., 3]) - np.maximum(a[..., 1], b[..., 1]),
        0,
        None,
    )
    inter = w * h
    union = a[..., 2] * a[..., 3] + b[..., 2] * b[..., 3] - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def _box_centre(box: np.ndarray) -> np.ndarray:
    return np.array([box[0] + box[2] / 2, box[1] + box[3] / 2])


def _box_track(
    old: TargetTrack | None,
    label: int,
    box: np.ndarray,
    ext: int,
    cfg: TrackerConfig,
    merged: bool = False,
) -> TargetTrack:
    base = old or TargetTrack(
        label=label, centroids_xy=np.zeros((0, 2)), box_xywh=box, external_id=ext
    )
    return replace(
        base,
        centroids_xy=_push_centroid(base, _box_centre(box), cfg),
        box_xywh=box.copy(),
        merged=merged,
    )


def _predicted_box(t: TargetTrack) -> np.ndarray:
    box = t.box_xywh.copy()
    box[:2] += t.velocity_xy()
    return box


@dataclass
class _BoxFrame:
    """Mutable scratch for one detections frame: label -> (box, detection row or -1, foot)."""

    rows: np.ndarray  # (P,) previous labels
    iou: np.ndarray  # (P, N)
    own_rows: np.ndarray  # previous rows tracked by the rules (no external id)
    own_cols: np.ndarray  # detection rows without an external id
    plan: _Plan  # the rules on iou[own_rows, own_cols]
    next_label: int
    new_labels: dict[int, int] = field(default_factory=dict)  # detection row -> new label
    out: dict[int, tuple[np.ndarray, int, np.ndarray]] = field(default_factory=dict)
    tracks: dict[int, TargetTrack] = field(default_factory=dict)
    merges: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)
    divisions: list[MergeDivision] = field(default_factory=list)

    def take_label(self, old: TargetTrack | None, row: int) -> int:
        """The old target's label, or a new one recorded for detection row ``row``."""
        if old is not None:
            return old.label
        label, self.next_label = self.next_label, self.next_label + 1
        self.new_labels[row] = label
        return label


def _merge_box(
    work: _BoxFrame,
    row: int,
    box: np.ndarray,
    foot: np.ndarray,
    heirs: list[TargetTrack],
    cfg: TrackerConfig,
) -> None:
    """The heir whose predicted box fits the detection best gets it; the others coast."""
    predicted = np.stack([_predicted_box(t) for t in heirs])
    best = int(np.argmax(_iou(predicted, box[None])[:, 0]))
    for i, t in enumerate(heirs):
        mine = box if i == best else predicted[i]
        work.out[t.label] = (mine, row if i == best else -1, foot if i == best else _NO_FEET)
        work.tracks[t.label] = _box_track(t, t.label, mine, t.external_id, cfg, merged=True)
    work.merges.append((row, tuple(t.label for t in heirs)))
    work.divisions.append(
        MergeDivision(
            blob_id=row,
            labels=np.array([t.label for t in heirs], np.int64),
            predicted_xy=np.stack([_box_centre(p) for p in predicted]),
            assigned_px=(np.arange(len(heirs)) == best).astype(np.int64),
        )
    )


def _check_box_inputs(
    boxes_xywh: np.ndarray, tracks: np.ndarray | None, feet_xy: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    boxes = np.asarray(boxes_xywh, np.float64).reshape(-1, 4)
    n = len(boxes)
    ext = np.full(n, -1, np.int64) if tracks is None else np.asarray(tracks, np.int64).reshape(-1)
    feet = np.full((n, 2), np.nan) if feet_xy is None else np.asarray(feet_xy, np.float64)
    if len(ext) != n or feet.shape != (n, 2):
        raise ValueError(f"track_boxes: {n} boxes but tracks {ext.shape}, feet {feet.shape}")
    ids = ext[ext >= 0]
    if len(np.unique(ids)) != len(ids):
        raise ValueError(f"track_boxes: duplicate external track ids in one frame: {ids.tolist()}")
    return boxes, ext, feet


def track_boxes(
    state: TrackerState,
    boxes_xywh: np.ndarray,
    tracks: np.ndarray | None,
    cfg: TrackerConfig,
    feet_xy: np.ndarray | None = None,
) -> tuple[TrackerState, TrackResult]:
    """One frame of detections tracking (a camera given as detections, FORMATS.md).

    boxes_xywh: (N, 4) float64; tracks: (N,) int64 external ids, -1 when absent (or None);
    feet_xy: (N, 2) float64 the detector's foot points, NaN rows when absent (or None).
    Rows with an external id follow it (module docstring); the others follow the overlap rules
    with IoU > ``min_box_iou``, against previous targets that had no external id.
    """
    boxes, ext, feet = _check_box_inputs(boxes_xywh, tracks, feet_xy)
    prev = state.targets
    rows = np.array([t.label for t in prev], np.int64)
    iou = _iou(np.array([t.box_xywh for t in prev], np.float64).reshape(-1, 4), boxes)
    own_rows = np.array([i for i, t in enumerate(prev) if t.external_id < 0], np.int64)
    own_cols = np.flatnonzero(ext < 0)
    sub = iou[np.ix_(own_rows, own_cols)]
    plan = _associate_boxes(sub, sub > cfg.min_box_iou)
    work = _BoxFrame(rows, iou, own_rows, own_cols, plan, state.next_label)
    by_ext = {t.external_id: t for t in prev if t.external_id >= 0}
    for j in np.flatnonzero(ext >= 0):
        old = by_ext.get(int(ext[j]))
        label = work.take_label(old, int(j))
        work.out[label] = (boxes[j], int(j), feet[j])
        work.tracks[label] = _box_track(old, label, boxes[j], int(ext[j]), cfg)
    for b, j in enumerate(own_cols):
        heirs = [prev[own_rows[r]] for r in plan.inheritors[b]]
        if len(heirs) >= 2:
            _merge_box(work, int(j), boxes[j], feet[j], heirs, cfg)
            continue
        old = heirs[0] if heirs else None
        label = work.take_label(old, int(j))
        work.out[label] = (boxes[j], int(j), feet[j])
        work.tracks[label] = _box_track(old, label, boxes[j], -1, cfg)
    return _finish_boxes(work)


def _finish_boxes(work: _BoxFrame) -> tuple[TrackerState, TrackResult]:
    labels = np.array(sorted(work.out), np.int64)
    # Births and splits: detection rows with a new label; a split parent only for rule-tracked rows.
    rows = work.rows
    col_of = {int(j): b for b, j in enumerate(work.own_cols)}
    births: list[int] = []
    kids: dict[int, list[int]] = {}
    for j, label in sorted(work.new_labels.items(), key=lambda kv: kv[1]):
        b = col_of.get(j)
        p = -1 if b is None else work.plan.split_parent[b]
        if p < 0:
            births.append(label)
        else:
            kids.setdefault(int(rows[work.own_rows[p]]), []).append(label)
    present = set(labels.tolist())
    result = TrackResult(
        labels=labels,
        label_image=None,
        boxes_xywh=np.array([work.out[int(v)][0] for v in labels], np.float64).reshape(-1, 4),
        areas_px=np.array([work.out[int(v)][0][2] * work.out[int(v)][0][3] for v in labels]),
        blob_of_target=np.array([work.out[int(v)][1] for v in labels], np.int64),
        feet_xy=np.array([work.out[int(v)][2] for v in labels], np.float64).reshape(-1, 2),
        overlap=work.iou,
        overlap_rows=rows,
        overlap_cols=np.arange(work.iou.shape[1], dtype=np.int64),
        births=tuple(births),
        retirements=tuple(int(v) for v in rows if int(v) not in present),
        splits=tuple((p, tuple(ch)) for p, ch in sorted(kids.items())),
        merges=tuple(work.merges),
        merge_divisions=tuple(work.divisions),
    )
    new_state = TrackerState(
        label_image=None,
        targets=tuple(work.tracks[int(v)] for v in labels),
        next_label=work.next_label,
    )
    return new_state, result
