"""Marker dropping: the three tests, motion, and the bounded grid store."""

from __future__ import annotations

import numpy as np

from mvtrack.params import MarkerConfig
from mvtrack.stages.markers import marker_points, marker_step, markers_init
from mvtrack.stages.targets import CameraTargets

SIZE = (320, 240)
CFG = MarkerConfig(marker_every_frames=1, height_window_frames=5, marker_min_move_px=5.0)


def _one(label: int, foot: tuple[float, float], height: float = 40.0) -> CameraTargets:
    x, y = foot
    return CameraTargets(
        np.array([label], np.int64),
        np.array([[x, y]]),
        np.array([height]),
        np.array([[x - 8, y - height, 16, height]]),
        SIZE,
    )


def test_a_walking_linked_pair_drops_markers_and_a_still_one_does_not() -> None:
    state = markers_init(SIZE)
    dropped = []
    for f in range(10):
        state, res = marker_step(
            state, [(1, 2)], _one(1, (50 + 25 * f, 120)), _one(2, (200, 100 + 6 * f)), CFG, f
        )
        dropped.append(len(res.dropped))
    assert dropped == [1] * 10
    for f in range(10, 14):  # standing still: test (c) fails
        state, res = marker_step(state, [(1, 2)], _one(1, (275, 120)), _one(2, (200, 154)), CFG, f)
        assert res.dropped == () and res.rejected == ((1, 2, "no motion"),)
    pts_a, pts_b = marker_points(state)
    assert pts_a.shape == pts_b.shape == (10, 2)
    assert np.allclose(pts_b[:, 0], 200)


def test_only_one_camera_moving_is_enough() -> None:
    state = markers_init(SIZE)
    for f in range(4):
        state, res = marker_step(
            state, [(1, 2)], _one(1, (100, 120)), _one(2, (100 + 20 * f, 150)), CFG, f
        )
        assert len(res.dropped) == 1


def test_partly_outside_targets_give_no_marker() -> None:
    state = markers_init(SIZE)
    state, res = marker_step(state, [(1, 2)], _one(1, (5, 120)), _one(2, (100, 150)), CFG, 0)
    assert res.dropped == () and res.rejected == ((1, 2, "outside"),)
    state, res = marker_step(state, [(1, 2)], _one(1, (100, 239.4)), _one(2, (100, 150)), CFG, 1)
    assert res.rejected == ((1, 2, "outside"),)


def test_height_jump_gives_no_marker() -> None:
    state = markers_init(SIZE)
    for f in range(5):
        state, _ = marker_step(state, [], _one(1, (100, 120)), _one(2, (100, 150)), CFG, f)
    state, res = marker_step(
        state, [(1, 2)], _one(1, (130, 120), 28.0), _one(2, (100, 150)), CFG, 5
    )
    assert res.rejected == ((1, 2, "height"),)
    state, res = marker_step(
        state, [(1, 2)], _one(1, (130, 120), 38.0), _one(2, (100, 150)), CFG, 6
    )
    assert len(res.dropped) == 1  # within 15 % of the median 40


def test_markers_only_every_n_frames_and_only_for_present_links() -> None:
    cfg = MarkerConfig(marker_every_frames=5)
    state = markers_init(SIZE)
    tried = []
    for f in range(12):
        state, res = marker_step(
            state, [(1, 2), (9, 9)], _one(1, (50 + 10 * f, 120)), _one(2, (100, 150)), cfg, f
        )
        tried.append(res.tried)
        assert all(m.a_label == 1 for m in res.dropped)
    assert tried == [f % 5 == 0 for f in range(12)]
    assert state.n_dropped == 3


def test_store_is_bounded_one_marker_per_cell_newest_wins() -> None:
    cfg = MarkerConfig(marker_every_frames=1, marker_min_move_px=0.0, grid_cols=4, grid_rows=3)
    state = markers_init(SIZE)
    rng = np.random.default_rng(0)
    for f in range(300):
        xa = tuple(rng.uniform(20, 300, 1).tolist() + rng.uniform(60, 230, 1).tolist())
        state, res = marker_step(state, [(1, 2)], _one(1, xa), _one(2, (100, 150)), cfg, f)
    assert state.n_dropped == 300
    assert len(state.cells) <= 12 and len(res.markers) == len(state.cells)
    # every stored marker is the newest of the markers that fell in its cell
    assert max(m.frame for m in res.markers) == 299


def test_no_input_is_modified() -> None:
    a, b = _one(1, (100, 120)), _one(2, (100, 150))
    before = (a.feet.copy(), b.feet.copy())
    state = markers_init(SIZE)
    new, _ = marker_step(state, [(1, 2)], a, b, CFG, 0)
    assert state.cells == {} and state.heights_a == {} and len(new.cells) == 1
    assert np.array_equal(a.feet, before[0]) and np.array_equal(b.feet, before[1])
