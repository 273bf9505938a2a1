"""Accuracy figures against ground truth: detection, feet, identity (IDF1), masks.

Pure numpy/scipy on arrays, so every figure can be unit-tested on hand-made rows. Matching is by
feet distance gated by the person's height (a gate in body heights works at every depth):
a prediction matches a truth row when ``|foot_pred - foot_true| < gate_heights * height_true``.

Truth rows of people less than ``min_visible`` visible are "don't care": a prediction matched to
one is neither a hit nor a false alarm, and missing one is not a miss. A person cut by the frame
edge has its feet outside the frame, where no prediction can put them: a prediction left
unmatched whose feet fall inside the visible box of a don't-care row of its frame is that
person's, and is ignored too (MOTChallenge ignores predictions on its ignore regions alike).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from mvtrack.io import CameraTruth

__all__ = [
    "FrameRows",
    "MaskScores",
    "Matches",
    "along_motion",
    "detection_scores",
    "error_causes",
    "frame_matches",
    "idf1",
    "mask_scores",
    "match_all",
]

_BIG = 1e9


@dataclass(frozen=True)
class FrameRows:
    """Rows of one camera (or one kind of thing) over many frames, as parallel arrays.

    frames: (N,) int64; ids: (N,) int64; feet: (N, 2) float64; heights: (N,) float64 (truth: the
    person's box height in px; predictions: unused, may be zeros); visible: (N,) float64 (1.0 for
    predictions); boxes_xywh: (N, 4) float64, truth: the visible box (predictions: NaN);
    in_frame: (N,) float64, truth: the share of the silhouette inside the frame (1.0 for
    predictions).
    """

    frames: np.ndarray
    ids: np.ndarray
    feet: np.ndarray
    heights: np.ndarray
    visible: np.ndarray
    boxes_xywh: np.ndarray
    in_frame: np.ndarray

    @classmethod
    def of(cls, frames: object, ids: object, feet: object, heights: object = None,
           visible: object = None, boxes_xywh: object = None) -> FrameRows:
        f = np.asarray(frames, np.int64).reshape(-1)
        n = len(f)
        return cls(
            frames=f,
            ids=np.asarray(ids, np.int64).reshape(n),
            feet=np.asarray(feet, np.float64).reshape(n, 2),
            heights=np.zeros(n) if heights is None else np.asarray(heights, np.float64).reshape(n),
            visible=np.ones(n) if visible is None else np.asarray(visible, np.float64).reshape(n),
            boxes_xywh=np.full((n, 4), np.nan) if boxes_xywh is None
            else np.asarray(boxes_xywh, np.float64).reshape(n, 4),
            in_frame=np.ones(n),
        )

    @classmethod
    def from_truth(cls, t: CameraTruth, frames: range) -> FrameRows:
        """One camera's truth rows within ``frames``; heights are the truth box heights and
        ``visible`` the share of the whole silhouette seen (occlusion and frame edge)."""
        keep = (t.frame >= frames.start) & (t.frame < frames.stop)
        assert t.in_frame is not None  # CameraTruth fills it
        rows = cls.of(t.frame[keep], t.person[keep], t.foot[keep], t.box_xywh[keep, 3],
                      t.shown[keep], t.box_xywh[keep])
        return replace(rows, in_frame=np.asarray(t.in_frame[keep], np.float64))

    def by_frame(self) -> dict[int, np.ndarray]:
        """Frame index -> row indices."""
        order = np.argsort(self.frames, kind="stable")
        cuts = np.flatnonzero(np.diff(self.frames[order])) + 1
        return {int(self.frames[g[0]]): g for g in np.split(order, cuts) if len(g)}


def frame_matches(
    pred_feet: np.ndarray, true_feet: np.ndarray, true_heights: np.ndarray, gate_heights: float
) -> tuple[np.ndarray, np.ndarray]:
    """Minimum-distance one-to-one matching within the gate. Returns (pred_idx, true_idx)."""
    if len(pred_feet) == 0 or len(true_feet) == 0:
        empty = np.zeros(0, np.int64)
        return empty, empty
    dist = np.linalg.norm(pred_feet[:, None, :] - true_feet[None, :, :], axis=2)
    gate = gate_heights * np.maximum(true_heights, 1.0)[None, :]
    cost = np.where(dist < gate, dist, _BIG)
    rows, cols = linear_sum_assignment(cost)
    keep = cost[rows, cols] < _BIG
    return rows[keep].astype(np.int64), cols[keep].astype(np.int64)


@dataclass(frozen=True)
class Matches:
    pred_rows: np.ndarray  # global row indices into pred, matched to counted truth
    true_rows: np.ndarray  # global row indices into truth
    pred_counted: int  # predictions not matched to a don't-care truth row
    true_counted: int  # truth rows at least min_visible visible
    pred_missed: np.ndarray  # global row indices into pred: the counted ones left unmatched


def match_all(pred: FrameRows, truth: FrameRows, gate_heights: float,
              min_visible: float) -> Matches:
    """Per-frame height-gated matching of every frame; only truth rows at least
    ``min_visible`` visible count (predictions matched to others are ignored)."""
    pred_by, true_by = pred.by_frame(), truth.by_frame()
    pr, tr, missed = [], [], []
    pred_ignored = 0
    for frame, p_idx in pred_by.items():
        t_idx = true_by.get(frame, np.zeros(0, np.int64))
        i, j = frame_matches(pred.feet[p_idx], truth.feet[t_idx], truth.heights[t_idx],
                             gate_heights)
        counted = truth.visible[t_idx[j]] >= min_visible
        pred_ignored += int((~counted).sum())
        unmatched = np.delete(p_idx, i)
        ignored = _in_boxes(pred.feet[unmatched], truth.boxes_xywh[
            t_idx[truth.visible[t_idx] < min_visible]])
        pred_ignored += int(ignored.sum())
        pr.append(p_idx[i[counted]])
        tr.append(t_idx[j[counted]])
        missed.append(unmatched[~ignored])
    empty = np.zeros(0, np.int64)
    return Matches(
        pred_rows=np.concatenate(pr) if pr else empty,
        true_rows=np.concatenate(tr) if tr else empty,
        pred_counted=len(pred.frames) - pred_ignored,
        true_counted=int((truth.visible >= min_visible).sum()),
        pred_missed=np.sort(np.concatenate(missed)) if missed else empty,
    )


def _in_boxes(points: np.ndarray, boxes_xywh: np.ndarray) -> np.ndarray:
    """(N,) bool: each point inside any of the boxes (edges included; NaN boxes never)."""
    if not len(points) or not len(boxes_xywh):
        return np.zeros(len(points), bool)
    x, y = points[:, 0:1], points[:, 1:2]
    x0, y0 = boxes_xywh[:, 0], boxes_xywh[:, 1]
    inside = (x >= x0) & (x <= x0 + boxes_xywh[:, 2]) & (y >= y0) & (y <= y0 + boxes_xywh[:, 3])
    return inside.any(axis=1)


_MOTION_HALF_FRAMES = 2  # the truth's direction of motion at f: its feet at f - 2 to f + 2
_MOTION_MIN_PX = 2.0  # ... over which they moved at least this far (0.5 px per frame)


def along_motion(pred_feet: np.ndarray, truth: FrameRows, true_rows: np.ndarray) -> np.ndarray:
    """(M,) each matched prediction's feet error along its truth person's direction of motion
    in the image, px (negative: behind the person), NaN where the person moved under
    ``_MOTION_MIN_PX`` from ``_MOTION_HALF_FRAMES`` frames before to as many after, or was not
    in the truth at both. ``pred_feet`` (M, 2) and ``true_rows`` (M,) are the matched pairs."""
    key = truth.ids * (1 << 32) + truth.frames
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]

    def feet_at(frames: np.ndarray) -> np.ndarray:
        want = truth.ids[true_rows] * (1 << 32) + frames
        i = np.minimum(np.searchsorted(sorted_key, want), len(key) - 1)
        found = sorted_key[i] == want
        return np.where(found[:, None], truth.feet[order[i]], np.nan)

    frames = truth.frames[true_rows]
    step = feet_at(frames + _MOTION_HALF_FRAMES) - feet_at(frames - _MOTION_HALF_FRAMES)
    length = np.linalg.norm(step, axis=1)
    moving = length >= _MOTION_MIN_PX  # False for NaN
    err = pred_feet - truth.feet[true_rows]
    along = np.full(len(true_rows), np.nan)
    along[moving] = (err[moving] * step[moving]).sum(axis=1) / length[moving]
    return along


def detection_scores(pred: FrameRows, truth: FrameRows, gate_heights: float = 0.5,
                     min_visible: float = 0.5) -> dict[str, float]:
    """Recall, precision and feet error of per-frame predictions against truth (one camera).

    Feet error is over matched pairs: median and 90th percentile in px and as a fraction of
    the truth height, and the median of its component along the person's direction of motion
    (:func:`along_motion`; negative: the feet trail the person), over the matched people who
    walk. The false alarms and misses by cause: :func:`error_causes`.
    ``recall_cut_by_frame``: the recall of the counted people partly outside the frame.
    """
    m = match_all(pred, truth, gate_heights, min_visible)
    hits = len(m.true_rows)
    err = np.linalg.norm(pred.feet[m.pred_rows] - truth.feet[m.true_rows], axis=1)
    rel = err / np.maximum(truth.heights[m.true_rows], 1.0)
    nan = float("nan")
    cut = (truth.visible >= min_visible) & (truth.in_frame < 1.0)
    cut_hits = int(cut[m.true_rows].sum())
    cut_rows = int(cut.sum())
    along = along_motion(pred.feet[m.pred_rows], truth, m.true_rows)
    walking = along[np.isfinite(along)]
    return {
        "recall": hits / m.true_counted if m.true_counted else nan,
        "precision": hits / m.pred_counted if m.pred_counted else nan,
        "matches": hits,
        "truth_rows": m.true_counted,
        "predicted_rows": m.pred_counted,
        "recall_cut_by_frame": cut_hits / cut_rows if cut_rows else nan,
        "truth_rows_cut_by_frame": cut_rows,
        "foot_error_px_median": float(np.median(err)) if hits else nan,
        "foot_error_px_p90": float(np.percentile(err, 90)) if hits else nan,
        "foot_error_height_median": float(np.median(rel)) if hits else nan,
        "foot_error_height_p90": float(np.percentile(rel, 90)) if hits else nan,
        "foot_error_px_along_motion_median": float(np.median(walking)) if len(walking) else nan,
        "foot_error_along_motion_matches": len(walking),
    } | error_causes(pred, truth, m, min_visible)


def error_causes(pred: FrameRows, truth: FrameRows, m: Matches, min_visible: float = 0.5,
                 near_heights: float = 1.0) -> dict[str, int]:
    """Why predictions were false alarms and truth rows were missed, in rows of ``m``
    (:func:`match_all`); the first three add up to the false alarms, the last three to the
    misses. Each looks at the nearest counted person (false alarms) or prediction (misses) of
    the row's frame, within ``near_heights`` of the person's height:

    - false_alarm_duplicate: that person is matched to another prediction: a second target on
      one person (a leg or a head tracked apart, a target left on someone after its own
      person went out of sight);
    - false_alarm_displaced: that person is missed: the target is theirs but its feet are off
      by more than the gate (legs lost, a cast shadow taken for legs, a group's feet);
    - false_alarm_phantom: nobody that near (noise, a ghost, a person the truth leaves out);
    - miss_displaced: that prediction is matched to nobody (mostly the other side of a
      displaced false alarm);
    - miss_taken: that prediction is matched to someone else: the person is inside another
      person's target (one blob for people one behind the other, a merge given to one);
    - miss_undetected: no prediction that near.
    """
    matched_pred = np.zeros(len(pred.frames), bool)
    matched_pred[m.pred_rows] = True
    matched_true = np.zeros(len(truth.frames), bool)
    matched_true[m.true_rows] = True
    counted = truth.visible >= min_visible
    pred_by, true_by = pred.by_frame(), truth.by_frame()
    none = np.zeros(0, np.int64)

    def nearest(rows: np.ndarray, dist: np.ndarray, matched: np.ndarray) -> int:
        """0: nobody within near_heights, 1: the nearest is matched, 2: it is not."""
        if not len(rows) or dist.min() >= near_heights:
            return 0
        return 1 if matched[rows[np.argmin(dist)]] else 2

    alarms, misses = [0, 0, 0], [0, 0, 0]
    for i in m.pred_missed:
        people = true_by.get(int(pred.frames[i]), none)
        people = people[counted[people]]
        dist = np.linalg.norm(truth.feet[people] - pred.feet[i], axis=1) / np.maximum(
            truth.heights[people], 1.0)
        alarms[nearest(people, dist, matched_true)] += 1
    for j in np.flatnonzero(counted & ~matched_true):
        targets = pred_by.get(int(truth.frames[j]), none)
        dist = np.linalg.norm(pred.feet[targets] - truth.feet[j], axis=1) / max(
            float(truth.heights[j]), 1.0)
        misses[nearest(targets, dist, matched_pred)] += 1
    return {
        "false_alarm_duplicate": alarms[1], "false_alarm_displaced": alarms[2],
        "false_alarm_phantom": alarms[0],
        "miss_displaced": misses[2], "miss_taken": misses[1], "miss_undetected": misses[0],
    }


def idf1(pred: FrameRows, truth: FrameRows, gate_heights: float = 0.5,
         min_visible: float = 0.5) -> dict[str, float]:
    """Identity F1 (Ristani et al. 2016) of predicted ids against truth ids.

    Rows may come from several cameras at once (pass frames made unique per camera, e.g.
    ``frame * n_cameras + camera_index``) for a global IDF1 of cross-camera labels.
    The per-frame matches decide which (pred id, truth id) pairs co-occur; the id-to-id
    assignment that maximizes co-occurrences gives IDTP.

    What IDF1 lacks of 1 splits in two (the three add up to 1): ``loss_detection``, the
    counted truth and predicted rows the per-frame matching left unmatched, and
    ``loss_identity``, the matched rows whose pred id is not the one assigned to their truth
    id (each counts twice, as a miss and a false alarm of IDF1), both over truth + pred rows.
    """
    m = match_all(pred, truth, gate_heights, min_visible)
    nan = float("nan")
    counted = m.true_counted + m.pred_counted
    if counted == 0:
        return {"idf1": nan, "idp": nan, "idr": nan, "idtp": 0, "loss_detection": nan,
                "loss_identity": nan}
    p_ids, p_inv = np.unique(pred.ids[m.pred_rows], return_inverse=True)
    t_ids, t_inv = np.unique(truth.ids[m.true_rows], return_inverse=True)
    co = np.zeros((len(p_ids), len(t_ids)))
    np.add.at(co, (p_inv, t_inv), 1.0)
    rows, cols = linear_sum_assignment(-co) if co.size else (np.zeros(0, int), np.zeros(0, int))
    idtp = float(co[rows, cols].sum())
    matched = len(m.true_rows)
    return {
        "idf1": 2 * idtp / counted,
        "idp": idtp / m.pred_counted if m.pred_counted else nan,
        "idr": idtp / m.true_counted if m.true_counted else nan,
        "idtp": idtp,
        "loss_detection": (counted - 2 * matched) / counted,
        "loss_identity": 2 * (matched - idtp) / counted,
    }


@dataclass(frozen=True)
class MaskScores:
    """Pixel counts behind the mask figures, summed over frames (so they add up correctly)."""

    fg_true_pos: int = 0  # truth person, predicted foreground
    fg_false_pos: int = 0  # truth background or shadow, predicted foreground
    fg_false_neg: int = 0  # truth person, not predicted foreground
    shadow_pixels: int = 0  # truth cast-shadow pixels
    shadow_detected: int = 0  # truth shadow predicted shadow and not foreground
    person_not_shadow: int = 0  # truth person pixels not called shadow
    shadow_in_fg: int = 0  # truth shadow pixels that entered the foreground

    def __add__(self, other: MaskScores) -> MaskScores:
        return MaskScores(*(a + b for a, b in zip(self.counts(), other.counts(), strict=True)))

    def counts(self) -> tuple[int, ...]:
        return (self.fg_true_pos, self.fg_false_pos, self.fg_false_neg, self.shadow_pixels,
                self.shadow_detected, self.person_not_shadow, self.shadow_in_fg)

    def summary(self) -> Mapping[str, float]:
        nan = float("nan")
        person = self.fg_true_pos + self.fg_false_neg
        pred = self.fg_true_pos + self.fg_false_pos
        return {
            "fg_precision": self.fg_true_pos / pred if pred else nan,
            "fg_recall": self.fg_true_pos / person if person else nan,
            "shadow_detection": self.shadow_detected / self.shadow_pixels
            if self.shadow_pixels else nan,
            "shadow_discrimination": self.person_not_shadow / person if person else nan,
            # the share of cast-shadow pixels kept out of the foreground, whether called shadow
            # or background (faint shadows, e.g. of a thermal camera, never pass T_L at all)
            "shadow_kept_out": 1.0 - self.shadow_in_fg / self.shadow_pixels
            if self.shadow_pixels else nan,
        }


def mask_scores(pred_label: np.ndarray, truth_label: np.ndarray) -> MaskScores:
    """Compare one predicted mask image with one truth mask image.

    Both are (H, W) uint8 with 0 background, 1 person/foreground, 2 shadow (FORMATS.md).
    Shadow detection (Prati et al.) is the share of truth shadow pixels called shadow and not
    foreground; shadow discrimination the share of truth person pixels not called shadow.
    """
    if pred_label.shape != truth_label.shape:
        raise ValueError(f"mask shapes differ: {pred_label.shape} vs {truth_label.shape}")
    pf, tf = pred_label == 1, truth_label == 1
    ts = truth_label == 2
    return MaskScores(
        fg_true_pos=int((pf & tf).sum()),
        fg_false_pos=int((pf & ~tf).sum()),
        fg_false_neg=int((~pf & tf).sum()),
        shadow_pixels=int(ts.sum()),
        shadow_detected=int((ts & (pred_label == 2)).sum()),
        person_not_shadow=int((tf & (pred_label != 2)).sum()),
        shadow_in_fg=int((ts & pf).sum()),
    )
