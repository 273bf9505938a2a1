"""Consistent-labelling figures over all cameras jointly (SPEC §11, thesis Chapter 5).

From the clip's truth and a run's `tracks.csv` (and `cues.csv`):

- ``idf1_global``: IDF1 of ``meta`` against truth people, every camera's rows together, and
  what it lacks of 1 split into ``idf1_global_loss_detection`` (rows the per-frame matching
  left unmatched: the front end) and ``idf1_global_loss_identity`` (matched rows under
  another person's ``meta``: the labels);
- ``consistency``: of the (frame, person) pairs matched in two or more cameras, the share whose
  targets all carry one ``meta``; ``consistency_by_pair``: the same for each two cameras ("a-b":
  share and count), which tells the pair that fails when there are more than two;
- ``fragmentation``: distinct metas matched to a person (mean over people; 1 is ideal);
- ``occlusion_recovery``: episodes where a person vanished from one camera for at least
  ``min_gap_frames`` while seen in another; the share that came back with the same ``meta``;
- ``cueing``: agreement of ``expected`` with the truth (is the person in that camera's view);
- ``creation``: per person, from the first frame matched in two cameras to the first frame two
  cameras' targets share a ``meta``: frames and ground distance walked (truth units).

:func:`truth_detections_clip` writes a clip whose cameras are the truth given as detections
(perfect detector, and a perfect single-camera tracker whose ids change after every gap): it
isolates the multi-camera stages from the front end.
"""

from __future__ import annotations

import shutil
from collections import Counter
from dataclasses import dataclass, replace
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

from mvtrack.evaluate.metrics import FrameRows, idf1, match_all
from mvtrack.io import Truth
from mvtrack.io.results import CueRows, TrackRows, read_cues

__all__ = [
    "LabelConfig", "Matched", "label_metrics", "labels_report", "match_rows",
    "truth_detections_clip",
]


@dataclass(frozen=True)
class LabelConfig:
    """How labels are scored.

    gate_heights, min_visible: as in :class:`~mvtrack.evaluate.report.EvalConfig`
    min_gap_frames:        occlusion episodes: frames a person must be missing from a camera
    recover_window_frames: the meta a person comes back with: the most frequent in this window
    """

    gate_heights: float = 0.5
    min_visible: float = 0.5
    min_gap_frames: int = 10
    recover_window_frames: int = 25


@dataclass(frozen=True)
class Matched:
    """Predicted rows matched to counted truth rows, all cameras (parallel (M,) int64 arrays)."""

    frame: np.ndarray
    camera: np.ndarray  # index into the sorted camera list
    person: np.ndarray
    meta: np.ndarray


def match_rows(truth: Truth, rows: TrackRows, cameras: list[str], frames: range,
               cfg: LabelConfig) -> Matched:
    """Per camera and frame, height-gated Hungarian matching of predictions to truth."""
    parts: list[list[np.ndarray]] = [[], [], [], []]
    for c, name in enumerate(cameras):
        t = FrameRows.from_truth(truth.cameras[name], frames)
        mine = rows.of_camera(name)
        m = match_all(FrameRows.of(mine.frame, mine.meta, mine.feet), t, cfg.gate_heights,
                      cfg.min_visible)
        parts[0].append(mine.frame[m.pred_rows])
        parts[1].append(np.full(len(m.pred_rows), c, np.int64))
        parts[2].append(t.ids[m.true_rows])
        parts[3].append(mine.meta[m.pred_rows])
    return Matched(*(np.concatenate(col).astype(np.int64) if col else np.zeros(0, np.int64)
                     for col in parts))


def _global_idf1(truth: Truth, rows: TrackRows, cameras: list[str], frames: range,
                 cfg: LabelConfig) -> dict[str, float]:
    """IDF1 of meta over all cameras: frames made unique per camera."""
    n = len(cameras)
    preds, truths = [], []
    for c, name in enumerate(cameras):
        t = FrameRows.from_truth(truth.cameras[name], frames)
        mine = rows.of_camera(name)
        preds.append(FrameRows.of(mine.frame * n + c, mine.meta, mine.feet))
        truths.append(replace(t, frames=t.frames * n + c))

    def cat(parts: list[FrameRows]) -> FrameRows:
        return FrameRows(*(np.concatenate([getattr(p, f) for p in parts])
                           for f in FrameRows.__dataclass_fields__))

    return idf1(cat(preds), cat(truths), cfg.gate_heights, cfg.min_visible)


def _consistency(m: Matched, cameras: list[str]) -> dict[str, Any]:
    groups: dict[tuple[int, int], dict[int, int]] = {}
    for f, c, p, meta in zip(m.frame.tolist(), m.camera.tolist(), m.person.tolist(),
                             m.meta.tolist(), strict=True):
        groups.setdefault((f, p), {})[c] = meta
    multi = [g for g in groups.values() if len(g) >= 2]
    same = sum(len(set(g.values())) == 1 for g in multi)
    by_pair: dict[str, dict[str, float]] = {}
    for i, a in enumerate(cameras):
        for j in range(i + 1, len(cameras)):
            both = [g[i] == g[j] for g in multi if i in g and j in g]
            if both:
                by_pair[f"{a}-{cameras[j]}"] = {"consistency": sum(both) / len(both),
                                                "pairs": len(both)}
    return {"consistency": same / len(multi) if multi else float("nan"),
            "consistency_pairs": len(multi), "consistency_by_pair": by_pair}


def _fragmentation(m: Matched) -> dict[str, float]:
    per: dict[int, set[int]] = {}
    for p, meta in zip(m.person.tolist(), m.meta.tolist(), strict=True):
        per.setdefault(p, set()).add(meta)
    counts = [len(v) for v in per.values()]
    return {"metas_per_person": float(np.mean(counts)) if counts else float("nan"),
            "metas_per_person_max": max(counts, default=0), "people": len(counts)}


def _visible_sets(truth: Truth, cameras: list[str], frames: range,
                  cfg: LabelConfig) -> list[dict[int, set[int]]]:
    """Per camera: person -> frames it is visible (at least ``min_visible``)."""
    out = []
    for name in cameras:
        t = FrameRows.from_truth(truth.cameras[name], frames)
        per: dict[int, set[int]] = {}
        for f, p in zip(t.frames[t.visible >= cfg.min_visible].tolist(),
                        t.ids[t.visible >= cfg.min_visible].tolist(), strict=True):
            per.setdefault(p, set()).add(f)
        out.append(per)
    return out


def _episodes(vis: list[dict[int, set[int]]], cfg: LabelConfig) -> list[tuple[int, int, int, int]]:
    """(camera, person, last frame before, first frame after) of every qualifying gap."""
    out = []
    for c, per in enumerate(vis):
        for p, frames in per.items():
            seq = sorted(frames)
            for f0, f1 in pairwise(seq):
                if f1 - f0 - 1 < cfg.min_gap_frames:
                    continue
                others = [o[p] for k, o in enumerate(vis) if k != c and p in o]
                gap = range(f0 + 1, f1)
                if all(any(f in o for o in others) for f in gap):
                    out.append((c, p, f0, f1))
    return out


def _occlusion_recovery(m: Matched, vis: list[dict[int, set[int]]],
                        cfg: LabelConfig) -> dict[str, float]:
    by: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for f, c, p, meta in zip(m.frame.tolist(), m.camera.tolist(), m.person.tolist(),
                             m.meta.tolist(), strict=True):
        by.setdefault((c, p), []).append((f, meta))
    recovered = scored = 0
    for c, p, f0, f1 in _episodes(vis, cfg):
        seq = by.get((c, p), [])
        before = [meta for f, meta in seq if f <= f0]
        after = [meta for f, meta in seq if f1 <= f < f1 + cfg.recover_window_frames]
        if not before or not after:
            continue
        scored += 1
        recovered += Counter(after).most_common(1)[0][0] == before[-1]
    return {"occlusion_recovery": recovered / scored if scored else float("nan"),
            "occlusion_episodes": scored}


def _meta_person(m: Matched) -> dict[int, int]:
    """Each meta's person: the one it was matched to most often."""
    counts: dict[int, Counter[int]] = {}
    for p, meta in zip(m.person.tolist(), m.meta.tolist(), strict=True):
        counts.setdefault(meta, Counter())[p] += 1
    return {meta: c.most_common(1)[0][0] for meta, c in counts.items()}


def _cueing(m: Matched, cues: CueRows, truth: Truth, cameras: list[str],
            frames: range) -> dict[str, float]:
    """Agreement of ``expected`` with the truth: the person has a truth row in that camera."""
    person_of = _meta_person(m)
    in_view = {
        (name, int(f), int(p))
        for name in cameras
        for f, p in zip(truth.cameras[name].frame.tolist(), truth.cameras[name].person.tolist(),
                        strict=True)
        if f in frames
    }
    hits = total = tp = fp = fn = 0
    for f, meta, cam, exp in zip(cues.frame.tolist(), cues.meta.tolist(), cues.camera.tolist(),
                                 cues.expected.tolist(), strict=True):
        if meta not in person_of or cam not in cameras:
            continue
        real = (cam, f, person_of[meta]) in in_view
        total += 1
        hits += exp == real
        tp += exp and real
        fp += exp and not real
        fn += real and not exp
    nan = float("nan")
    return {"cue_accuracy": hits / total if total else nan,
            "cue_precision": tp / (tp + fp) if tp + fp else nan,
            "cue_recall": tp / (tp + fn) if tp + fn else nan, "cue_rows": total}


def _creation(m: Matched, truth: Truth) -> dict[str, Any]:
    """Frames and ground distance from first two-camera match to first shared meta, per person."""
    per: dict[int, dict[int, dict[int, int]]] = {}
    for f, c, p, meta in zip(m.frame.tolist(), m.camera.tolist(), m.person.tolist(),
                             m.meta.tolist(), strict=True):
        per.setdefault(p, {}).setdefault(f, {})[c] = meta
    world = _world_paths(truth)
    frames_to, dists, never = [], [], 0
    for p, by_frame in per.items():
        multi = sorted(f for f, cams in by_frame.items() if len(cams) >= 2)
        if not multi:
            continue
        joined = [f for f in multi if len(set(by_frame[f].values())) < len(by_frame[f])]
        if not joined:
            never += 1
            continue
        frames_to.append(joined[0] - multi[0])
        if p in world:
            dists.append(_walked(world[p], multi[0], joined[0]))
    nan = float("nan")
    return {
        "creation_frames_median": float(np.median(frames_to)) if frames_to else nan,
        "creation_frames_mean": float(np.mean(frames_to)) if frames_to else nan,
        "creation_distance_median": float(np.median(dists)) if dists else nan,
        "creation_distance_mean": float(np.mean(dists)) if dists else nan,
        "creation_distance_units": truth.units,
        "created": len(frames_to), "never_joined": never,
    }


def _world_paths(truth: Truth) -> dict[int, dict[int, np.ndarray]]:
    if truth.world is None:
        return {}
    out: dict[int, dict[int, np.ndarray]] = {}
    for f, p, xy in zip(truth.world.frame.tolist(), truth.world.person.tolist(), truth.world.xy,
                        strict=True):
        out.setdefault(p, {})[f] = xy
    return out


def _walked(path: dict[int, np.ndarray], f0: int, f1: int) -> float:
    pts = [path[f] for f in range(f0, f1 + 1) if f in path]
    if len(pts) < 2:
        return 0.0
    return float(np.linalg.norm(np.diff(np.asarray(pts), axis=0), axis=1).sum())


def label_metrics(truth: Truth, rows: TrackRows, frames: range, cues: CueRows | None = None,
                  cfg: LabelConfig = LabelConfig()) -> dict[str, Any]:
    """Every consistent-labelling figure (module docstring) for one run."""
    cameras = sorted(set(rows.camera.tolist()) & set(truth.cameras))
    m = match_rows(truth, rows, cameras, frames, cfg)
    g = _global_idf1(truth, rows, cameras, frames, cfg)
    out: dict[str, Any] = {"idf1_global": g["idf1"], "idp_global": g["idp"],
                           "idr_global": g["idr"],
                           "idf1_global_loss_detection": g["loss_detection"],
                           "idf1_global_loss_identity": g["loss_identity"], "cameras": cameras}
    out |= _consistency(m, cameras) | _fragmentation(m)
    out |= _occlusion_recovery(m, _visible_sets(truth, cameras, frames, cfg), cfg)
    if cues is not None:
        out |= _cueing(m, cues, truth, cameras, frames)
    out |= _creation(m, truth)
    return out


def labels_report(truth: Truth, rows: TrackRows, cues_csv: Path, frames: range,
                  gate_heights: float, min_visible: float) -> dict[str, Any]:
    """:func:`label_metrics` of a run's rows (with its cues when ``cues_csv`` exists)."""
    path = Path(cues_csv)
    cues = read_cues(path) if path.is_file() else None
    return label_metrics(truth, rows, frames, cues, LabelConfig(gate_heights, min_visible))


def truth_detections_clip(clip: Path, out: Path, min_visible: float = 0.5) -> Path:
    """Write a clip whose cameras are ``clip``'s truth given as detections (FORMATS.md).

    Rows at least ``min_visible`` visible become detections (truth box and feet); the ``track``
    column is a perfect single-camera tracker whose id changes after every frame the person is
    missing, as a real tracker's would. ``truth/`` is copied so `mvtrack eval` works.
    """
    import tomllib

    from mvtrack.io import read_truth

    clip, out = Path(clip), Path(out)
    truth = read_truth(clip)
    if truth is None:
        raise ValueError(f"{clip}: no truth/ to turn into detections")
    spec = tomllib.loads((clip / "clip.toml").read_text(encoding="utf-8"))
    (out / "detections").mkdir(parents=True, exist_ok=True)
    lines = [f"fps = {float(spec.get('fps', 25.0))!r}", ""]
    for cam in spec["camera"]:
        name = cam["name"]
        size = _frame_size(clip / cam["source"]) if "source" in cam else tuple(cam["size"])
        _write_detections(truth, name, out / "detections" / f"{name}.csv", min_visible)
        lines += ["[[camera]]", f'name = "{name}"', f'detections = "detections/{name}.csv"',
                  f"size = [{size[0]}, {size[1]}]", ""]
    for ov in spec.get("overlap", []):
        lines += ["[[overlap]]", f'cameras = ["{ov["cameras"][0]}", "{ov["cameras"][1]}"]', ""]
    (out / "clip.toml").write_text("\n".join(lines), encoding="utf-8")
    shutil.copytree(clip / "truth", out / "truth", dirs_exist_ok=True)
    return out


def _frame_size(source: Path) -> tuple[int, int]:
    import cv2

    if source.is_dir():
        first = sorted(p for p in source.iterdir() if p.is_file())[0]
        img = cv2.imread(str(first))
        if img is None:
            raise ValueError(f"{first}: cannot be read as an image")
        return int(img.shape[1]), int(img.shape[0])
    cap = cv2.VideoCapture(str(source))
    size = int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)), int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
    cap.release()
    return size


def _write_detections(truth: Truth, camera: str, path: Path, min_visible: float) -> None:
    t = truth.cameras[camera]
    keep = np.flatnonzero(t.visible >= min_visible)
    order = keep[np.lexsort((t.person[keep], t.frame[keep]))]
    last: dict[int, int] = {}
    track_of: dict[int, int] = {}
    next_track = 1
    lines = ["frame,x,y,w,h,score,foot_x,foot_y,track"]
    for r in order.tolist():
        f, p = int(t.frame[r]), int(t.person[r])
        if p not in track_of or last[p] != f - 1:
            track_of[p], next_track = next_track, next_track + 1
        last[p] = f
        x, y, w, h = t.box_xywh[r]
        fx, fy = t.foot[r]
        lines.append(f"{f},{x:.2f},{y:.2f},{w:.2f},{h:.2f},1,{fx:.2f},{fy:.2f},{track_of[p]}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
