"""End-of-run homography (stages/refit.py): markers from the whole-run labels, and the fit."""

from __future__ import annotations

import numpy as np

from mvtrack.io.results import TrackRows
from mvtrack.params import HomographyConfig, MarkerConfig
from mvtrack.stages.homography import apply_homography, transfer_errors
from mvtrack.stages.refit import label_markers, refit_homography

SIZES = {"cam0": (320, 240), "cam1": (320, 240)}
H_TRUE = np.array([[0.9, 0.1, 12.0], [-0.05, 0.95, 8.0], [0.0003, -0.0002, 1.0]])


def _rows(tracks: list[tuple[str, int, int, np.ndarray, np.ndarray]]) -> TrackRows:
    """(camera, target, meta, frames (F,), feet (F, 2)) -> rows, every target 40 px tall
    in a box half as wide standing on its feet."""
    cols: list[list] = [[] for _ in range(5)]
    for cam, target, meta, frames, feet in tracks:
        for col, v in zip(cols, ([*frames], [cam] * len(frames), [target] * len(frames),
                                 [meta] * len(frames), [*feet]), strict=True):
            col.extend(v)
    feet = np.array(cols[4], np.float64).reshape(-1, 2)
    h = np.full(len(feet), 40.0)
    return TrackRows(np.array(cols[0], np.int64), np.array(cols[1]), np.array(cols[2], np.int64),
                     np.array(cols[3], np.int64), feet,
                     np.c_[feet[:, 0] - h / 4, feet[:, 1] - h, h / 2, h], h)


def _walk(start: tuple[float, float], end: tuple[float, float], frames: range) -> np.ndarray:
    t = np.linspace(0.0, 1.0, len(frames))[:, None]
    return np.array(start) + t * (np.array(end) - np.array(start))


def test_markers_are_same_meta_pairs_on_marker_frames_inside_both_frames() -> None:
    """One person (meta 7) walks from x=0 (cut by cam0's left border) to x=200, frames 0-40:
    markers on frames 5, 10, ..., 40 once both boxes are 2 px inside. Another person (meta 8)
    is seen by cam0 only."""
    frames = np.arange(41)
    feet0 = _walk((0.0, 120.0), (200.0, 120.0), range(41))
    rows = _rows([("cam0", 1, 7, frames, feet0),
                  ("cam1", 4, 7, frames, apply_homography(H_TRUE, feet0)),
                  ("cam0", 2, 8, frames, feet0 + [0.0, 60.0])])
    got = label_markers(rows, rows.meta, ("cam0", "cam1"), SIZES, MarkerConfig())
    frames_a = rows.frame[got.rows_a]
    assert (frames_a == rows.frame[got.rows_b]).all() and (frames_a % 5 == 0).all()
    assert (rows.camera[got.rows_a] == "cam0").all() and (rows.target[got.rows_a] == 1).all()
    assert (rows.camera[got.rows_b] == "cam1").all() and (rows.target[got.rows_b] == 4).all()
    left = rows.boxes_xywh[got.rows_a, 0]
    assert left.min() >= 2.0 and frames_a.tolist() == [f for f in range(5, 41, 5)
                                                       if feet0[f, 0] - 10.0 >= 2.0]
    assert (got.groups == 0).all()


def test_the_labels_given_decide_not_the_rows_own_metas() -> None:
    frames = np.arange(0, 21)
    feet0 = _walk((60.0, 120.0), (200.0, 150.0), range(21))
    rows = _rows([("cam0", 1, 1, frames, feet0),
                  ("cam1", 1, 2, frames, apply_homography(H_TRUE, feet0))])
    assert len(label_markers(rows, rows.meta, ("cam0", "cam1"), SIZES, MarkerConfig())) == 0
    joined = np.ones(len(rows.frame), np.int64)
    assert len(label_markers(rows, joined, ("cam0", "cam1"), SIZES, MarkerConfig())) == 5


def test_a_shrunk_target_and_a_meta_with_two_targets_drop_no_marker() -> None:
    """cam0's target loses its legs (height 40 -> 20) on frames 20-22, and from frame 30 a
    second cam0 target carries the same meta (the legs tracked apart, as tall as the first
    was): frame 20 drops no marker (test b), nor do frames 30 and 35 (which feet?)."""
    frames = np.arange(40)
    feet0 = _walk((60.0, 120.0), (200.0, 150.0), range(40))
    rows = _rows([("cam0", 1, 1, frames, feet0),
                  ("cam1", 3, 1, frames, apply_homography(H_TRUE, feet0)),
                  ("cam0", 2, 1, frames[30:], feet0[30:] + [0.0, 30.0])])
    short = (rows.camera == "cam0") & (rows.target == 1) & (rows.frame >= 20) & (rows.frame < 23)
    rows = TrackRows(rows.frame, rows.camera, rows.target, rows.meta, rows.feet,
                     rows.boxes_xywh, np.where(short, 20.0, rows.height))
    got = label_markers(rows, rows.meta, ("cam0", "cam1"), SIZES, MarkerConfig())
    assert rows.frame[got.rows_a].tolist() == [0, 5, 10, 15, 25]


def test_refit_recovers_h_from_noisy_labels_despite_a_wrong_join() -> None:
    """Four people cross both views (feet with 0.7 px noise); a fifth pair of targets, two
    different people 50 px apart under H, was joined by mistake: its markers are outliers and
    the fit stays within a pixel of the true H over the walked area."""
    rng = np.random.default_rng(3)
    walks = [((30.0, 80.0), (290.0, 200.0)), ((280.0, 70.0), (40.0, 220.0)),
             ((150.0, 60.0), (170.0, 225.0)), ((40.0, 160.0), (290.0, 120.0))]
    tracks = []
    for k, (start, end) in enumerate(walks):
        frames = np.arange(100 * k, 100 * k + 150)
        feet0 = _walk(start, end, range(150))
        feet1 = apply_homography(H_TRUE, feet0)
        tracks += [("cam0", k + 1, k + 1, frames, feet0 + rng.normal(0, 0.7, feet0.shape)),
                   ("cam1", k + 1, k + 1, frames, feet1 + rng.normal(0, 0.7, feet1.shape))]
    frames = np.arange(500, 600)
    feet0 = _walk((60.0, 100.0), (250.0, 110.0), range(100))
    tracks += [("cam0", 9, 9, frames, feet0),
               ("cam1", 9, 9, frames, apply_homography(H_TRUE, feet0) + [0.0, 50.0])]
    rows = _rows(tracks)
    est, markers = refit_homography(rows, rows.meta, ("cam0", "cam1"), SIZES, MarkerConfig(),
                                    HomographyConfig())
    assert est, est
    assert len(np.unique(markers.groups)) == 5
    wrong = markers.groups == markers.groups[rows.target[markers.rows_a] == 9][0]
    assert not est.inliers[wrong].any()
    grid = np.stack(np.meshgrid(np.arange(40, 290, 10.0), np.arange(70, 220, 10.0)),
                    -1).reshape(-1, 2)
    assert transfer_errors(est.H_b_from_a, grid, apply_homography(H_TRUE, grid)).max() < 1.0
