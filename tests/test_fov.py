"""FOV events, Hough lines and associations."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mvtrack.params import FovConfig
from mvtrack.stages.fov import (
    FovEventPoints,
    add_event,
    best_match,
    border_distance,
    border_line,
    crossing_time,
    detect_events,
    estimate_line,
    event_match,
    event_votes,
    hough_points,
    interpolate_targets,
    mask_touching_sides,
    new_slot,
)
from mvtrack.stages.targets import CameraTargets, touching_sides

SIZE = (320, 240)
CFG = FovConfig()


def _targets(boxes: list[list[float]], labels: list[int], heights: float = 40.0) -> CameraTargets:
    b = np.array(boxes, float).reshape(-1, 4)
    feet = np.c_[b[:, 0] + b[:, 2] / 2, b[:, 1] + b[:, 3]]
    return CameraTargets(np.array(labels, np.int64), feet, np.full(len(b), heights), b, SIZE)


@pytest.mark.parametrize(
    ("before", "after", "expected"),
    [
        ([-0.5, 100, 20, 40], [10, 100, 20, 40], [("left", "enter")]),  # left edge -> inside
        ([100, 100, 20, 40], [300, 100, 19.5, 40], [("right", "leave")]),  # inside -> right
        ([100, 100, 20, 40], [100, 199.5, 20, 40], [("bottom", "leave")]),
        ([100, -0.5, 20, 40], [100, 5, 20, 40], [("top", "enter")]),
        ([-0.5, -0.5, 20, 40], [10, 10, 20, 40], []),  # two sides at once: no event
        ([100, 100, 20, 40], [-0.5, -0.5, 20, 40], []),
        ([-0.5, 100, 20, 40], [-0.5, 100, 30, 40], []),  # still touching
        ([100, 100, 20, 40], [110, 100, 20, 40], []),  # still inside
    ],
)
def test_events_table(before: list[float], after: list[float], expected: list) -> None:
    hist, ev0 = detect_events({}, _targets([before], [7]), "b", 0, CFG.edge_margin_px)
    assert ev0 == ()  # a target new this frame gives no event
    _, events = detect_events(hist, _targets([after], [7]), "b", 1, CFG.edge_margin_px)
    assert [(e.side, e.kind) for e in events] == expected
    assert all(e.target == 7 and e.frame == 1 and e.camera == "b" for e in events)


def test_events_use_the_margin() -> None:
    hist, _ = detect_events({}, _targets([[1.0, 100, 20, 40]], [1]), "a", 0, 2.0)
    assert hist[1] == (True, False, False, False)  # first column 1.5 is within 2 px
    hist, _ = detect_events({}, _targets([[1.0, 100, 20, 40]], [1]), "a", 0, 1.0)
    assert hist[1] == (False, False, False, False)


def test_mask_touches_like_its_box() -> None:
    rng = np.random.default_rng(0)
    for _ in range(50):
        mask = np.zeros((24, 32), bool)
        x0, y0 = rng.integers(0, 30), rng.integers(0, 22)
        mask[y0 : y0 + rng.integers(1, 6), x0 : x0 + rng.integers(1, 6)] = True
        rows, cols = np.nonzero(mask)
        box = [[cols.min() - 0.5, rows.min() - 0.5, np.ptp(cols) + 1, np.ptp(rows) + 1]]
        for margin in (0.0, 1.0, 3.0):
            expected = touching_sides(np.array(box), (32, 24), margin)[0]
            assert np.array_equal(mask_touching_sides(mask, margin), expected)


def _line_error(line: np.ndarray, a: float, b: float, c: float) -> float:
    """Mean distance from the true line's points inside the frame to the found line."""
    xs = np.linspace(0, SIZE[0] - 1, 200)
    ys = np.linspace(0, SIZE[1] - 1, 200)
    pts = np.c_[xs, -(a * xs + c) / b] if abs(b) > abs(a) else np.c_[-(b * ys + c) / a, ys]
    inside = (pts[:, 0] >= 0) & (pts[:, 0] < SIZE[0]) & (pts[:, 1] >= 0) & (pts[:, 1] < SIZE[1])
    return float(np.abs(pts[inside] @ line[:2] + line[2]).mean())


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0, np.pi), st.integers(12, 40))
def test_hough_recovers_drawn_lines_among_outliers(seed: int, theta: float, n: int) -> None:
    rng = np.random.default_rng(seed)
    a, b = np.cos(theta), np.sin(theta)
    x0 = rng.uniform([60, 60], [260, 180])
    c = -(a * x0[0] + b * x0[1])
    t = rng.uniform(-150, 150, n)
    on = x0 + t[:, None] * np.array([-b, a]) + rng.normal(0, 0.7, (n, 2))
    on = on[(on[:, 0] >= 0) & (on[:, 0] < 320) & (on[:, 1] >= 0) & (on[:, 1] < 240)]
    if len(on) < 8:
        return
    outliers = rng.uniform([0, 0], SIZE, (4 * len(on), 2))
    # A random point that lands near the line is not an outlier: keep those well off it (one
    # 8.8 px off, inside the refit's band, moved a 10-point line by 3 px: seed 2734948).
    outliers = outliers[np.abs(outliers @ [a, b] + c) > 15.0][: len(on) // 2]
    result = hough_points(np.r_[on, outliers], SIZE, CFG)
    assert result is not None
    assert np.isclose(np.hypot(*result.line[:2]), 1.0)
    assert _line_error(result.line, a, b, c) < 2.0
    assert result.n_inliers >= len(on) - 1
    assert result.accumulator.shape == (len(result.thetas_rad), len(result.rhos_px))
    assert result.peaks.shape[1] == 3 and result.peaks[0, 2] == result.peaks[:, 2].max()


def test_hough_handles_vertical_lines_across_the_theta_wrap() -> None:
    ys = np.linspace(5, 235, 30)
    pts = np.c_[100 + 0.02 * (ys - 120), ys]  # nearly vertical: theta ~ 0 ~ pi
    result = hough_points(pts, SIZE, CFG)
    assert result is not None
    assert abs(abs(result.line[0]) - 1) < 1e-3
    assert np.abs(pts @ result.line[:2] + result.line[2]).max() < 0.5


def test_one_event_counts_once_however_many_points_lie_on_a_line() -> None:
    band = np.c_[np.linspace(20, 300, 10), np.full(10, 50.0)]  # ten people in a far band
    votes = event_votes(band, np.full(10, 15.0), np.ones(10), SIZE, CFG)
    assert votes.max() == 1.0


def _event_targets(rng: np.random.Generator, on_line: np.ndarray, label: int) -> CameraTargets:
    others = rng.uniform([0, 60], [320, 240], (4, 2))
    feet = np.r_[on_line[None], others]
    labels = np.r_[label, 1000 + rng.integers(0, 10**6, 4)]
    boxes = np.c_[feet[:, 0] - 8, feet[:, 1] - 40, np.full(5, 16), np.full(5, 40)]
    return CameraTargets(labels.astype(np.int64), feet, np.full(5, 40.0), boxes, SIZE)


def test_slot_learns_the_line_from_events_with_bystanders() -> None:
    rng = np.random.default_rng(1)
    a, b, c = 0.6, 0.8, -200.0  # 0.6 x + 0.8 y = 200
    slot = new_slot("a", "b", "left", SIZE)
    cfg = FovConfig(max_fov_events=15)
    for k in range(25):
        x = rng.uniform(40, 300)
        on = np.array([x, (200 - 0.6 * x) / 0.8]) + rng.normal(0, 0.7, 2)
        slot = add_event(slot, k, _event_targets(rng, on, k), cfg)
        slot = estimate_line(slot, cfg, k)
    assert slot.n_events == 25 and len(slot.events) == 15
    assert slot.line is not None and slot.line.events == 25 and slot.line.from_frame == 24
    assert _line_error(np.array(slot.line.line), a, b, c) < 1.5
    # the incremental accumulator equals a fresh sum over the retained events
    fresh = sum(event_votes(e.feet, e.heights, e.weights, SIZE, cfg) for e in slot.events)
    assert slot.accumulator is not None and np.allclose(slot.accumulator, fresh)


def test_no_line_before_min_events() -> None:
    slot = new_slot("a", "b", "top", SIZE)
    rng = np.random.default_rng(2)
    for k in range(CFG.min_fov_events - 1):
        slot = estimate_line(
            add_event(slot, k, _event_targets(rng, np.array([50.0, 90]), k), CFG), CFG, k
        )
    assert slot.line is None and slot.hough is None


def test_best_match_uses_body_heights_and_skips_taken_targets() -> None:
    line = (0.0, 1.0, -100.0)  # y = 100
    feet = np.array([[50, 108.0], [150, 95.0], [250, 160.0]])
    heights = np.array([20.0, 40.0, 40.0])  # 8/20 = 0.4 heights, 5/40 = 0.125 heights
    boxes = np.c_[feet[:, 0] - 5, feet[:, 1] - heights, np.full(3, 10), heights]
    t = CameraTargets(np.array([1, 2, 3], np.int64), feet, heights, boxes, SIZE)
    assert best_match(line, t, frozenset(), CFG) == 2
    assert best_match(line, t, frozenset({2}), CFG) is None  # 0.4 > 0.35 heights
    assert best_match(line, t, frozenset({2}), FovConfig(fov_match_heights=0.5)) == 1
    assert best_match(line, CameraTargets.empty(SIZE), frozenset(), CFG) is None


def test_crossing_time_from_the_feet_track() -> None:
    cfg = FovConfig()
    # Leaving at 2 px/frame: 10 px from the border at frame 20 -> on the border at frame 25.
    leave = np.array([[17.0, 16.0], [18.0, 14.0], [19.0, 12.0], [20.0, 10.0]])
    assert crossing_time(leave, 20, "leave", cfg) == pytest.approx(25.0)
    # Entering at 3 px/frame, 12 px inside at frame 40 -> crossed at frame 36.
    enter = np.array([[40.0, 12.0], [41.0, 15.0], [42.0, 18.0]])
    assert crossing_time(enter, 40, "enter", cfg) == pytest.approx(36.0)
    # Too few samples, or motion the wrong way: the event frame itself.
    assert crossing_time(leave[:1], 20, "leave", cfg) == 20.0
    assert crossing_time(enter, 40, "leave", cfg) == 40.0
    # The shift is bounded.
    slow = np.array([[0.0, 50.0], [1.0, 49.9]])
    assert crossing_time(slow, 1, "leave", cfg) == 1 + cfg.crossing_max_shift_frames


def test_border_distance_per_side() -> None:
    feet = np.array([[10.0, 200.0]])
    assert border_distance(feet, "left", (320, 240))[0] == 10.5
    assert border_distance(feet, "right", (320, 240))[0] == 309.5
    assert border_distance(feet, "bottom", (320, 240))[0] == 39.5


def _at(labels, feet, size=(320, 240)) -> CameraTargets:
    feet = np.asarray(feet, float)
    boxes = np.c_[feet - [5, 30], np.full((len(feet), 2), [10, 30])]
    return CameraTargets(np.asarray(labels, np.int64), feet, np.full(len(feet), 30.0), boxes,
                         size)


def test_interpolate_targets_between_frames() -> None:
    t0 = _at([1, 2], [[100, 100], [50, 50]])
    t1 = _at([1, 3], [[110, 120], [200, 200]])
    mid = interpolate_targets((10, t0), (12, t1), 10.5)  # nearer t0: its labels
    assert mid.labels.tolist() == [1, 2]
    assert np.allclose(mid.feet, [[102.5, 105.0], [50, 50]])
    late = interpolate_targets((10, t0), (12, t1), 11.5)
    assert late.labels.tolist() == [1, 3] and np.allclose(late.feet[0], [107.5, 115.0])
    assert np.allclose(t0.feet, [[100, 100], [50, 50]])  # inputs untouched


def test_matches_are_made_only_when_unambiguous() -> None:
    cfg = FovConfig()
    line = (1.0, 0.0, -100.0)  # x = 100
    one = _at([1, 2], [[101, 50], [180, 60]])
    assert best_match(line, one, frozenset(), cfg) == 1
    assert best_match(line, one, frozenset({1}), cfg) is None
    two = _at([1, 2], [[101, 50], [97, 160]])  # both within 0.35 heights (10.5 px)
    assert best_match(line, two, frozenset(), cfg) is None
    ev = FovEventPoints(0, one.labels, one.feet, one.heights_px, np.ones(2), 7)
    assert event_match(line, ev, cfg) == 1
    ev2 = FovEventPoints(0, two.labels, two.feet, two.heights_px, np.ones(2), 7)
    assert event_match(line, ev2, cfg) is None


def test_crossers_picked_by_a_homography_refine_the_top_line() -> None:
    """Top side (feet never reach B's top border: events record where the crosser's feet are
    once fully inside). Four events; at each a bystander sits near a wrong line. With H the
    crossers are known and their feet give the line."""
    cfg = FovConfig(min_fov_events=4)
    slot = new_slot("a", "b", "top", (320, 240))
    for k in range(4):
        y = 40.0 + 50 * k
        seen = _at([10 + k, 20 + k], [[100.0 + 0.2 * k, y], [150.0, 60.0 + 3 * k]])
        slot = add_event(slot, k, seen, cfg, event_target=k, crosser_foot=(0.0 - 100.0, y))
    shift = np.array([[1.0, 0.0, 200.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # b -> a: x + 200
    with_h = estimate_line(slot, cfg, 5, shift, (320, 240))
    assert with_h.line is not None and with_h.line.source == "crossers"
    a, _b, c = with_h.line.line
    assert abs(abs(a) - 1) < 1e-3 and abs(-c / a - 100.3) < 0.5
    plain = estimate_line(slot, cfg, 5)  # Hough alone: the compact bystander cluster ties
    assert plain.line is not None and abs(plain.line.line[0]) < 0.99
    assert plain.line.source == "events"


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["left", "right", "top", "bottom"]))
def test_border_line_is_the_edge_border_through_h(seed: int, side: str) -> None:
    rng = np.random.default_rng(seed)
    H = np.eye(3) + rng.normal(0, [[0.1, 0.1, 30], [0.1, 0.1, 30], [1e-4, 1e-4, 0]])
    size = (320, 240)
    t = np.linspace(-0.5, 319.5 if side in ("top", "bottom") else 239.5, 9)
    fixed = {"left": -0.5, "right": 319.5, "top": -0.5, "bottom": 239.5}[side]
    border = (np.c_[np.full(9, fixed), t] if side in ("left", "right")
              else np.c_[t, np.full(9, fixed)])
    mapped = np.c_[border, np.ones(9)] @ H.T
    mapped = mapped[:, :2] / mapped[:, 2:]
    a, b, c = border_line(H, side, size)
    assert np.hypot(a, b) == pytest.approx(1.0)
    assert np.abs(mapped @ [a, b] + c).max() < 1e-6 * (1 + np.abs(mapped).max())


def test_with_h_the_side_lines_are_the_border_through_h() -> None:
    """Left side: events give a line 6 px off (noisy feet); with H the line is B's border
    through it, where the feet of every crosser were."""
    cfg = FovConfig(min_fov_events=4)
    slot = new_slot("a", "b", "left", (320, 240))
    for k in range(5):
        slot = add_event(slot, k, _at([k], [[206.0, 40.0 + 40 * k]]), cfg, event_target=k)
    shift = np.array([[1.0, 0.0, 200.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # b -> a: x + 200
    plain = estimate_line(slot, cfg, 5)
    assert plain.line is not None and abs(-plain.line.line[2] / plain.line.line[0] - 206) < 1.5
    assert plain.line.source == "events"
    with_h = estimate_line(slot, cfg, 5, shift, (320, 240))
    assert with_h.line is not None and with_h.line.source == "homography"
    assert np.allclose(with_h.line.line, border_line(shift, "left", (320, 240)))
    assert -with_h.line.line[2] / with_h.line.line[0] == pytest.approx(199.5)


def test_a_crosser_flickering_at_the_margin_gives_one_event() -> None:
    """Repeats of one crosser within ``event_repeat_frames`` cannot outvote other crossings:
    six events of crosser 7 far off the line and four true crossings give the true line."""
    rng = np.random.default_rng(3)
    cfg = FovConfig(event_repeat_frames=25)
    slot = new_slot("a", "b", "left", SIZE)
    for k in range(6):  # one person flickering at B's border, seen at A's (20, 200)
        slot = add_event(slot, 40 + 3 * k, _at([7], [[20.0, 200.0]]), cfg, event_target=7)
    assert slot.n_events == 1 and len(slot.events) == 1
    for k, y in enumerate([40.0, 100.0, 160.0, 220.0]):  # true line x = 150
        slot = add_event(slot, 100 + 40 * k, _event_targets(rng, np.array([150.0, y]), k), cfg,
                         event_target=20 + k)
    slot = add_event(slot, 300, _at([7], [[20.0, 200.0]]), cfg, event_target=7)  # later: kept
    assert slot.n_events == 6
    slot = estimate_line(slot, cfg, 300)
    assert slot.line is not None
    assert _line_error(np.array(slot.line.line), 1.0, 0.0, -150.0) < 3.0


def test_a_line_waits_for_enough_distinct_crossers() -> None:
    """A person flickering at B's border gives many events from one place: four of them,
    with a bystander somewhere else at each, give a line through the flicker at any angle.
    With ``min_fov_crossers`` 3 the slot waits: the flicker keeps its votes, but the line
    comes once three different people have crossed, and it is the true one."""
    cfg = FovConfig(min_fov_events=4, min_fov_crossers=3)
    slot = new_slot("a", "b", "left", SIZE)
    bystanders = [[40.0, 60.0], [280.0, 100.0], [60.0, 230.0], [250.0, 40.0]]
    for k, xy in enumerate(bystanders):  # crosser 7 flickers about A's (150, 200)
        flicker = [150.0 + 0.5 * k, 200.0 - 0.5 * k]
        slot = add_event(slot, 10 + 2 * k, _at([7, 9 + k], [flicker, xy]), cfg, event_target=7)
    early = estimate_line(slot, replace(cfg, min_fov_crossers=1), 20)
    assert early.line is not None  # counting events alone: a line, and a wrong one
    assert _line_error(np.array(early.line.line), 1.0, 0.0, -150.0) > 20.0
    assert estimate_line(slot, cfg, 20).line is None
    rng = np.random.default_rng(5)
    for k, y in enumerate([40.0, 110.0]):  # two more people cross B's left border: x = 150
        slot = add_event(slot, 100 + 40 * k, _event_targets(rng, np.array([150.0, y]), k), cfg,
                         event_target=20 + k)
    slot = estimate_line(slot, cfg, 200)
    assert slot.line is not None
    assert _line_error(np.array(slot.line.line), 1.0, 0.0, -150.0) < 3.0


def test_a_line_through_one_crossers_bystander_is_not_taken() -> None:
    """A person walking near B's border, in and out of the margin, gives an event each time,
    and a bystander walking in A is at a new place at each: six events on the bystander's
    path. Before the pair has a homography the line must explain events of
    ``min_fov_crossers`` different crossers: the path (one crosser) gives no line, while it
    is the strongest peak, and the true line comes when more people have crossed than that."""
    cfg = FovConfig(min_fov_events=4, min_fov_crossers=3)
    slot = new_slot("a", "b", "left", SIZE)
    for k in range(6):  # crosser 7 in B; A's bystander 3 walks along y = 0.3 x + 150
        x = 40.0 + 30.0 * k
        slot = add_event(slot, 10 + 8 * k, _at([3], [[x, 0.3 * x + 150.0]]), cfg,
                         event_target=7)
    for k, xy in enumerate([[250.0, 40.0], [290.0, 100.0]]):  # two crossers A does not see
        slot = add_event(slot, 100 + 10 * k, _at([40 + k], [xy]), cfg, event_target=20 + k)
    plain = estimate_line(slot, replace(cfg, min_fov_crossers=1), 120)
    assert plain.line is not None  # the strongest peak: the bystander's path
    assert _line_error(np.array(plain.line.line), -0.3, 1.0, -150.0) < 2.0
    assert estimate_line(slot, cfg, 120).line is None
    bystanders = [[60.0, 60.0], [260.0, 180.0], [220.0, 30.0], [30.0, 120.0], [290.0, 60.0],
                  [100.0, 40.0], [250.0, 220.0]]
    ys = [40.0, 90.0, 150.0, 210.0, 65.0, 120.0, 180.0]
    for k, (y, xy) in enumerate(zip(ys, bystanders, strict=True)):
        # people cross B's left border, at A's x = 150, a bystander elsewhere each time
        slot = add_event(slot, 200 + 40 * k, _at([50 + k, 60 + k], [[150.0, y], xy]), cfg,
                         event_target=30 + k)
        slot = estimate_line(slot, cfg, 200 + 40 * k)
        if k < 5:  # up to five crossings the path's six events are the strongest peak
            assert slot.line is None
    assert slot.line is not None and slot.line.source == "events"
    assert _line_error(np.array(slot.line.line), 1.0, 0.0, -150.0) < 3.0
