"""Pair-learning metrics (SPEC §11, thesis Chapter 5): learned geometry against the truth.

For each pair of ``pairs.json`` whose two cameras have a ground homography in
``truth/ground.json`` (G = image_from_ground per camera):

- the true H_b_from_a = G_b @ inv(G_a), and the learned H's symmetric transfer error against it
  on ground points visible in both cameras (the truth feet of people seen in both at the same
  frame; a grid of ground points inside both frames when there are none): median, p90, max px;
- each learned FOV line against the true one: the image in ``seen_in`` of ``edge_of``'s frame
  border on the ground, G_seen @ inv(G_edge) applied to the border, clipped to the part in front
  of both cameras and inside ``seen_in``'s frame; the error is the mean (and max) distance of
  that segment to the learned line, px (sides left, right, bottom: the top border of a camera
  images far ground, or the sky, where nobody's feet are);
- FOV events and markers made before the first valid homography, and its frame;
- the transfer error of ``H_whole_run`` (the whole run's co-motion H) and ``H_refit`` (H fitted
  again from the whole-run labels) too, where there is one, that of the H the run hands on
  (:func:`~mvtrack.io.results.handed_on`), and the error of the refit's FOV lines and of
  those handed on (``refit_error_px_mean``, ``handed_on_error_px_mean`` beside each line's).

    metrics = pair_metrics(truth, json.loads((results / "pairs.json").read_text()))
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mvtrack.io import Truth, open_clip
from mvtrack.io.results import handed_on, handed_on_lines
from mvtrack.stages.homography import apply_homography, transfer_errors

__all__ = [
    "EVAL_SIDES",
    "border_points",
    "fov_segment",
    "line_error_px",
    "pair_metrics",
    "pairs_metrics_for_results",
    "shared_ground_points",
    "true_H_b_from_a",
]

EVAL_SIDES = ("left", "right", "bottom")
"""Sides whose FOV lines are scored."""

_BORDER_STEP_PX = 0.5
_GRID_STEP_PX = 4.0
_SEGMENT_SAMPLES = 201


def true_H_b_from_a(G_a: np.ndarray, G_b: np.ndarray) -> np.ndarray:
    """(3, 3) float64 G_b @ inv(G_a): camera A pixels -> ground -> camera B pixels."""
    return np.asarray(G_b, np.float64) @ np.linalg.inv(np.asarray(G_a, np.float64))


def _inside(points: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(N,) bool: inside the frame's area, [-0.5, W - 0.5] x [-0.5, H - 0.5]."""
    w, h = size
    x, y = points[:, 0], points[:, 1]
    return np.isfinite(x) & (x >= -0.5) & (x <= w - 0.5) & (y >= -0.5) & (y <= h - 0.5)


def _in_front(G: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N,) bool: the ground point imaged at each pixel lies in front of the camera.

    Assumes G's scale makes its third output coordinate the (positive) depth, as in
    ``truth/ground.json`` written by the generator and by the PETS converter.
    """
    ground = np.c_[points, np.ones(len(points))] @ np.linalg.inv(G).T
    return ground[:, 2] > 0


def _depth_positive(G: np.ndarray, feet: np.ndarray) -> np.ndarray:
    """G, or -G when most of the camera's truth feet would otherwise lie behind it."""
    if len(feet) and np.mean(_in_front(G, feet)) < 0.5:
        return -G
    return G


def border_points(size: tuple[int, int], side: str, step_px: float = _BORDER_STEP_PX) -> np.ndarray:
    """(N, 2) float64 points along one side of a (width, height) frame's outer edge."""
    w, h = size
    xs = np.arange(-0.5, w - 0.5 + 1e-9, step_px)
    ys = np.arange(-0.5, h - 0.5 + 1e-9, step_px)
    edges = {
        "left": np.c_[np.full(len(ys), -0.5), ys],
        "right": np.c_[np.full(len(ys), w - 0.5), ys],
        "top": np.c_[xs, np.full(len(xs), -0.5)],
        "bottom": np.c_[xs, np.full(len(xs), h - 0.5)],
    }
    if side not in edges:
        raise ValueError(f"side {side!r} is not one of {tuple(edges)}")
    return edges[side]


def fov_segment(
    G_seen: np.ndarray,
    G_edge: np.ndarray,
    sizes: tuple[tuple[int, int], tuple[int, int]],
    side: str,
) -> np.ndarray | None:
    """(2, 2) endpoints, in the seen camera, of the visible image of the edge camera's border.

    ``sizes`` = (seen size, edge size). The border of ``side`` of the edge camera is mapped to
    the ground and into the seen camera; only points in front of both cameras and inside the
    seen frame are kept (their image is a straight segment). None when nothing is visible.
    """
    border = border_points(sizes[1], side)
    mapped = apply_homography(true_H_b_from_a(G_edge, G_seen), border)
    ground = np.c_[border, np.ones(len(border))] @ np.linalg.inv(G_edge).T
    with np.errstate(divide="ignore", invalid="ignore"):
        ground_xy = ground[:, :2] / ground[:, 2:3]
    depth_seen = np.c_[ground_xy, np.ones(len(ground_xy))] @ np.asarray(G_seen)[2]
    keep = (ground[:, 2] > 0) & (depth_seen > 0) & _inside(mapped, sizes[0])
    if keep.sum() < 2:
        return None
    pts = mapped[keep]
    direction = pts[-1] - pts[0]
    norm = float(np.linalg.norm(direction))
    if norm < 1e-9:
        return None
    t = (pts - pts[0]) @ (direction / norm)
    return np.array([pts[int(np.argmin(t))], pts[int(np.argmax(t))]])


def line_error_px(segment: np.ndarray, line: Sequence[float]) -> tuple[float, float]:
    """(mean, max) distance in px of a (2, 2) segment's points to line [a, b, c] (a²+b²=1)."""
    a, b, c = (float(v) for v in line)
    s = np.linspace(0.0, 1.0, _SEGMENT_SAMPLES)[:, None]
    pts = segment[0] + s * (segment[1] - segment[0])
    d = np.abs(pts @ np.array([a, b]) + c) / max(np.hypot(a, b), 1e-12)
    return float(d.mean()), float(d.max())


def shared_ground_points(
    truth: Truth, a: str, b: str, sizes: tuple[tuple[int, int], tuple[int, int]]
) -> tuple[np.ndarray, str]:
    """((N, 2) A pixels of ground points visible in both cameras, how they were chosen).

    "truth_feet": A's truth feet of people that both cameras have at the same frame, inside
    both frames by the true homography (duplicates removed). "grid": when there are none, a
    grid over A's frame of points whose ground point is in front of both and inside B.
    """
    H = true_H_b_from_a(truth.image_from_ground[a], truth.image_from_ground[b])
    ta, tb = truth.cameras.get(a), truth.cameras.get(b)
    if ta is not None and tb is not None and len(ta) and len(tb):
        key_b = {(int(f), int(p)) for f, p in zip(tb.frame, tb.person, strict=True)}
        both = np.array(
            [(int(f), int(p)) in key_b for f, p in zip(ta.frame, ta.person, strict=True)], bool
        )
        pts = np.unique(np.round(np.asarray(ta.foot, np.float64)[both], 2), axis=0)
        pts = pts[_inside(pts, sizes[0]) & _in_front(_g(truth, a), pts)]
        pts = pts[_inside(apply_homography(H, pts), sizes[1])]
        if len(pts):
            return pts, "truth_feet"
    w, h = sizes[0]
    gx, gy = np.meshgrid(np.arange(0, w, _GRID_STEP_PX), np.arange(0, h, _GRID_STEP_PX))
    grid = np.c_[gx.ravel(), gy.ravel()].astype(np.float64)
    mapped = apply_homography(H, grid)
    keep = _in_front(_g(truth, a), grid) & _in_front(_g(truth, b), mapped)
    return grid[keep & _inside(mapped, sizes[1])], "grid"


def _g(truth: Truth, camera: str) -> np.ndarray:
    t = truth.cameras.get(camera)
    feet = np.zeros((0, 2)) if t is None else np.asarray(t.foot, np.float64)
    return _depth_positive(np.asarray(truth.image_from_ground[camera], np.float64), feet)


def _stats(values: np.ndarray) -> dict[str, float | int | None]:
    if len(values) == 0:
        return {"median": None, "p90": None, "max": None, "points": 0}
    return {
        "median": float(np.median(values)),
        "p90": float(np.percentile(values, 90)),
        "max": float(np.max(values)),
        "points": len(values),
    }


def _transfer(truth: Truth, pair: Mapping[str, Any], sizes: Any) -> dict[str, Any]:
    a, b = pair["cameras"]
    pts_a, source = shared_ground_points(truth, a, b, sizes)
    H_true = true_H_b_from_a(_g(truth, a), _g(truth, b))
    pts_b = apply_homography(H_true, pts_a)
    out = {"points_from": source, "transfer_error_px": _errors(pair.get("H"), pts_a, pts_b)}
    if pair.get("H_whole_run") is not None:
        out["whole_run_transfer_error_px"] = _errors(pair["H_whole_run"]["H"], pts_a, pts_b)
    if pair.get("H_refit") is not None:
        out["refit_transfer_error_px"] = _errors(pair["H_refit"]["H"], pts_a, pts_b)
    key = handed_on(pair)
    out["handed_on_transfer_error_px"] = _errors(pair[key] if key == "H" else pair[key]["H"],
                                                 pts_a, pts_b)
    return out


def _errors(H: Any, pts_a: np.ndarray, pts_b: np.ndarray) -> dict[str, float | int | None]:
    """:func:`_stats` of ``H``'s transfer errors (none without H or points)."""
    if H is None or not len(pts_a):
        return _stats(np.zeros(0))
    return _stats(transfer_errors(np.asarray(H, np.float64), pts_a, pts_b))


def _fov_lines(truth: Truth, pair: Mapping[str, Any], sizes: Any) -> list[dict[str, Any]]:
    """Every scored side: the learned line's error, or ``learned: false`` where it is missing."""
    names = list(pair["cameras"])
    learned = {(x["seen_in"], x["side"]): x for x in pair.get("fov_lines", [])}
    refit = {(x["seen_in"], x["side"]): x
             for x in (pair.get("H_refit") or {}).get("fov_lines", [])}
    ends = {(x["seen_in"], x["side"]): x for x in handed_on_lines(pair)}
    out = []
    for i, seen in enumerate(names):
        edge = names[1 - i]
        for side in EVAL_SIDES:
            seg = fov_segment(_g(truth, seen), _g(truth, edge), (sizes[i], sizes[1 - i]), side)
            line = learned.get((seen, side))
            if seg is None and line is None:
                continue
            row: dict[str, Any] = {
                "seen_in": seen,
                "edge_of": edge,
                "side": side,
                "visible_length_px": None if seg is None else float(np.hypot(*(seg[1] - seg[0]))),
                "learned": line is not None,
                "error_px_mean": None,
                "error_px_max": None,
            }
            if line is not None and seg is not None:
                row["error_px_mean"], row["error_px_max"] = line_error_px(seg, line["line"])
                row["events"] = line["events"]
            if (seen, side) in refit and seg is not None:
                row["refit_error_px_mean"] = line_error_px(seg, refit[seen, side]["line"])[0]
            if (seen, side) in ends and seg is not None:
                row["handed_on_error_px_mean"] = line_error_px(seg, ends[seen, side]["line"])[0]
            out.append(row)
    return out


def pair_metrics(
    truth: Truth,
    pairs: Sequence[Mapping[str, Any]],
    sizes: Mapping[str, tuple[int, int]] | None = None,
) -> list[dict[str, Any]]:
    """One metrics object per pair of ``pairs.json`` whose cameras both have a true G.

    ``sizes``: (width, height) per camera, used when a pair object lacks its optional
    ``sizes`` key.
    """
    out = []
    for pair in pairs:
        a, b = pair["cameras"]
        if a not in truth.image_from_ground or b not in truth.image_from_ground:
            continue
        if "sizes" in pair:
            pair_sizes = (tuple(pair["sizes"][0]), tuple(pair["sizes"][1]))
        elif sizes is not None and a in sizes and b in sizes:
            pair_sizes = (tuple(sizes[a]), tuple(sizes[b]))
        else:
            raise ValueError(f"pair {a}-{b}: no frame sizes in pairs.json nor given")
        lines = _fov_lines(truth, pair, pair_sizes)
        errors = [x["error_px_mean"] for x in lines if x["error_px_mean"] is not None]
        refit_errors = [x["refit_error_px_mean"] for x in lines if "refit_error_px_mean" in x]
        end_errors = [x["handed_on_error_px_mean"] for x in lines
                      if "handed_on_error_px_mean" in x]
        first = pair.get("H_first")
        out.append(
            {"cameras": [a, b], "H_from_frame": pair.get("H_from_frame")}
            | _transfer(truth, pair, pair_sizes)
            | {
                "fov_lines": lines,
                "fov_line_error_px_mean_worst": max(errors) if errors else None,
                "refit_fov_line_error_px_mean_worst": max(refit_errors) if refit_errors else None,
                "handed_on_fov_line_error_px_mean_worst": max(end_errors) if end_errors else None,
                "first_valid_H": first,
                "markers": pair.get("markers"),
                "fov_events": pair.get("fov_events"),
                "whole_run_h_used": bool((pair.get("H_whole_run") or {}).get("used")),
                "refit_h_used": bool((pair.get("H_refit") or {}).get("used")),
            }
        )
    return out


def pairs_metrics_for_results(
    clip: Path, results: Path, truth: Truth
) -> list[dict[str, Any]] | None:
    """:func:`pair_metrics` of ``results/pairs.json`` (None without it or without ground.json)."""
    path = Path(results) / "pairs.json"
    if not path.is_file() or not truth.image_from_ground:
        return None
    pairs = json.loads(path.read_text(encoding="utf-8"))
    sizes = None
    if any("sizes" not in p for p in pairs):
        with open_clip(clip) as opened:
            sizes = {c.name: c.size for c in opened.spec.cameras}
    return pair_metrics(truth, pairs, sizes)
