"""`mvtrack eval CLIP RESULTS`: score a results directory against the clip's truth.

Reads only files: the clip's `truth/` and the results' `tracks.csv` (and `masks/` when the
run wrote them). Returns one JSON-ready dict, written as `metrics.json` beside the results.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mvtrack.evaluate.labels import labels_report
from mvtrack.evaluate.metrics import FrameRows, MaskScores, detection_scores, idf1, mask_scores
from mvtrack.evaluate.pairs import pairs_metrics_for_results
from mvtrack.io import ClipError, Truth, read_truth
from mvtrack.io.results import TrackRows, read_tracks
from mvtrack.stages.feet import smooth_feet

__all__ = ["EvalConfig", "evaluate", "processed_frames", "results_masks", "write_metrics"]


@dataclass(frozen=True)
class EvalConfig:
    """How predictions are matched to truth.

    gate_heights: a prediction matches a truth person within this many of its heights
    min_visible:  truth rows less visible than this are "don't care"
    """

    gate_heights: float = 0.5
    min_visible: float = 0.5


def processed_frames(results: Path) -> range:
    """The clip frames a run processed, from its `run.json` (all frames if it is absent)."""
    path = Path(results) / "run.json"
    if not path.is_file():
        return range(0, 2**62)
    frames = json.loads(path.read_text())["frames"]
    return range(frames["start"], frames["start"] + frames["processed"])


def _pred_rows(rows: TrackRows, ids: np.ndarray, feet: np.ndarray | None = None) -> FrameRows:
    return FrameRows.of(rows.frame, ids, rows.feet if feet is None else feet)


def _bbox_feet(rows: TrackRows, smoothing: tuple[int, float]) -> np.ndarray:
    """The classic baseline: bottom centre of each target's box, smoothed over time as the
    run smoothed its own feet (``smoothing``: :func:`_run_smoothing`), so the two compare
    like for like."""
    b = rows.boxes_xywh
    feet = np.stack([b[:, 0] + b[:, 2] / 2, b[:, 1] + b[:, 3]], axis=1)
    return smooth_feet(rows.frame, rows.target, feet, rows.height, *smoothing)


def _run_smoothing(results: Path) -> tuple[int, float]:
    """(half window in frames, break in heights) of the run's feet smoothing (`run.json`;
    none for a run from before feet were smoothed)."""
    path = Path(results) / "run.json"
    if not path.is_file():
        return 0, 0.0
    run = json.loads(path.read_text())
    feet = run.get("thresholds", {}).get("feet", {})
    return (round(float(feet.get("smooth_seconds", 0.0)) * float(run["clip"]["fps"])),
            float(feet.get("smooth_break_heights", 0.0)))


def results_masks(results: Path, camera: str) -> dict[int, Path]:
    """Frame -> mask file written by `mvtrack track` for one camera."""
    folder = Path(results) / "masks" / camera
    if not folder.is_dir():
        return {}
    return {int(p.stem): p for p in folder.glob("*.png") if p.stem.isdigit()}


def _mask_summary(truth: Truth, results: Path, camera: str) -> Mapping[str, float] | None:
    import cv2

    ours = results_masks(results, camera)
    frames = sorted(set(truth.mask_frames(camera)) & set(ours))
    if not frames:
        return None
    total = MaskScores()
    for f in frames:
        pred = cv2.imread(str(ours[f]), cv2.IMREAD_UNCHANGED)
        if pred is None:
            raise ClipError(f"{ours[f]}: cannot be read as an image")
        total = total + mask_scores(pred, truth.load_mask(camera, f))
    return dict(total.summary()) | {"frames": len(frames)}


def _camera_metrics(truth: Truth, rows: TrackRows, streamed: TrackRows | None, results: Path,
                    camera: str, cfg: EvalConfig) -> dict[str, Any]:
    t = FrameRows.from_truth(truth.cameras[camera], processed_frames(results))
    mine = rows.of_camera(camera)
    scores: dict[str, Any] = detection_scores(_pred_rows(mine, mine.target), t,
                                              cfg.gate_heights, cfg.min_visible)
    baseline = detection_scores(
        _pred_rows(mine, mine.target, _bbox_feet(mine, _run_smoothing(results))), t,
        cfg.gate_heights, cfg.min_visible)
    scores["foot_error_px_median_bbox_baseline"] = baseline["foot_error_px_median"]
    scores["foot_error_px_p90_bbox_baseline"] = baseline["foot_error_px_p90"]
    if streamed is not None:  # the feet as made frame by frame, before smoothing over the run
        made = streamed.of_camera(camera)
        per_frame = detection_scores(_pred_rows(made, made.target), t, cfg.gate_heights,
                                     cfg.min_visible)
        scores["foot_error_px_median_per_frame"] = per_frame["foot_error_px_median"]
        scores["foot_error_px_p90_per_frame"] = per_frame["foot_error_px_p90"]
    scores["idf1_single_camera"] = idf1(_pred_rows(mine, mine.target), t, cfg.gate_heights,
                                        cfg.min_visible)["idf1"]
    masks = _mask_summary(truth, results, camera)
    if masks is not None:
        scores["masks"] = masks
    return scores


def evaluate(clip: Path, results: Path, cfg: EvalConfig = EvalConfig()) -> dict[str, Any]:
    """Every figure we can compute for ``results`` against the truth of ``clip``."""
    truth = read_truth(Path(clip))
    if truth is None:
        raise ClipError(f"{clip}: no truth/ directory: nothing to evaluate against")
    rows = read_tracks(Path(results) / "tracks.csv")
    cameras = sorted(set(rows.camera.tolist()) & set(truth.cameras))
    if not cameras:
        raise ClipError(f"{results}/tracks.csv: no camera in common with {truth.root} "
                        f"(results: {sorted(set(rows.camera.tolist()))}, "
                        f"truth: {sorted(truth.cameras)})")
    online = Path(results) / "tracks_online.csv"
    streamed = read_tracks(online) if online.is_file() else None
    per_camera = {c: _camera_metrics(truth, rows, streamed, Path(results), c, cfg)
                  for c in cameras}
    metrics: dict[str, Any] = {
        "clip": str(clip),
        "results": str(results),
        "matching": {"gate_heights": cfg.gate_heights, "min_visible": cfg.min_visible},
        "cameras": per_camera,
        "labels": labels_report(truth, rows, Path(results) / "cues.csv",
                                processed_frames(results),
                                cfg.gate_heights, cfg.min_visible),
    }
    if streamed is not None:
        metrics["labels_online"] = labels_report(
            truth, streamed, Path(results) / "cues_online.csv",
            processed_frames(results), cfg.gate_heights, cfg.min_visible)
    pairs = pairs_metrics_for_results(Path(clip), Path(results), truth)
    if pairs is not None:
        metrics["pairs"] = pairs
    return metrics


def write_metrics(results: Path, metrics: Mapping[str, Any]) -> Path:
    """Write ``metrics`` as ``results/metrics.json``; NaN and infinities become null, so the
    file stays standard JSON. Returns the path."""
    path = Path(results) / "metrics.json"
    path.write_text(json.dumps(_json_safe(metrics), indent=2) + "\n")
    return path


def _json_safe(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, Mapping):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_json_safe(v) for v in value]
    return value
