"""Sakbot background subtraction: median exactness, hand-built scenes, immutability, real video."""

from __future__ import annotations

import csv
import dataclasses
import os
from pathlib import Path
from types import SimpleNamespace

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from mvtrack.params import BackgroundConfig
from mvtrack.stages.background import (
    BackgroundResult,
    BackgroundState,
    SizeModel,
    _area_thresholds,
    _fit_sizes,
    _fragment_links,
    _grow_down,
    _learn_sizes,
    background_step,
    link_groups,
    min_area_at,
    stacked_boxes,
    train_background,
    training_offsets,
)
from mvtrack.stages.feet import feet_pca
from mvtrack.stages.median import clamp, lower_median, median_network, order_statistics

H, W = 120, 160
CFG = BackgroundConfig(train_frames=10)


def _shared_data() -> Path:
    here = Path(__file__).resolve().parents[2] / "shared" / "data"
    return here if here.exists() else Path(os.environ.get("MVTRACK_SHARED_DATA", here))


# ---------------------------------------------------------------------------------- median


@settings(max_examples=150, deadline=None)
@given(
    n=st.integers(1, 17),
    shape=st.sampled_from([(1,), (5, 3), (4, 6, 3), (40000,)]),
    data=st.data(),
)
def test_lower_median_equals_numpy(n: int, shape: tuple[int, ...], data: st.DataObject) -> None:
    values = st.integers(0, 255) if data.draw(st.booleans()) else st.integers(0, 3)  # many ties
    stack = data.draw(arrays(np.uint8, (n, *shape), elements=values))
    got = lower_median(list(stack))
    assert got.shape == shape and got.dtype == np.uint8
    np.testing.assert_array_equal(got, np.quantile(stack, 0.5, axis=0, method="lower"))
    if n % 2 == 1:
        np.testing.assert_array_equal(got, np.median(stack, axis=0))


def test_median_network_is_pruned_and_inputs_untouched() -> None:
    network, _ = median_network(8)
    ops = sum(keep_min + keep_max for _, _, keep_min, keep_max in network)
    assert ops == 27  # a full 19-comparator sort would take 38 min/max operations
    rng = np.random.default_rng(1)
    stack = [rng.integers(0, 256, (30, 20, 3), dtype=np.uint8) for _ in range(8)]
    copies = [s.copy() for s in stack]
    out = lower_median(stack)
    assert all(np.array_equal(a, b) for a, b in zip(stack, copies, strict=True))
    assert not any(np.shares_memory(out, s) for s in stack)
    with pytest.raises(ValueError, match="image 1"):
        lower_median([stack[0], stack[1][:5]])


@settings(max_examples=100, deadline=None)
@given(n=st.integers(1, 12), data=st.data())
def test_order_statistics_equal_sorting(n: int, data: st.DataObject) -> None:
    stack = data.draw(arrays(np.uint8, (n, 6, 5), elements=st.integers(0, 4)))  # many ties
    ranks = data.draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=3))
    got = order_statistics(list(stack), ranks)
    ordered = np.sort(stack, axis=0)
    assert len(got) == len(ranks)
    for rank, out in zip(ranks, got, strict=True):
        np.testing.assert_array_equal(out, ordered[rank])
    if n >= 3:  # rank k of n images = the last clamped between ranks k-1, k of the others
        k = (n - 1) // 2
        lo, hi = order_statistics(list(stack[:-1]), (k - 1, k))
        np.testing.assert_array_equal(clamp(stack[-1], lo, hi), ordered[k])
    with pytest.raises(ValueError, match="ranks"):
        order_statistics(list(stack), [n])


@pytest.mark.parametrize(("n", "m"), [(8, 5), (3, 1), (4, 2), (2, 3), (1, 2), (9, 4)])
def test_fifo_median_shares_work_and_equals_lower_median(n: int, m: int) -> None:
    """The background's B sequence equals the plain lower median of the FIFO samples at every
    step, and half of the steps reuse a stored pair (n >= 3)."""
    rng = np.random.default_rng(n * 10 + m)
    cfg = dataclasses.replace(CFG, fifo_n=n, fifo_spacing_frames=m, train_frames=3)
    frames = [rng.integers(0, 6, (12, 16, 3), dtype=np.uint8) for _ in range(60)]
    state = train_background(frames[:3], "rgb", cfg)
    fifo = list(state.fifo)
    stored = []
    for frame in frames[3:]:
        state, _ = background_step(state, frame, cfg)
        fifo = fifo[1:] + [state.fifo[-1]]
        samples = [fifo[len(fifo) - 1 - i * m] for i in range(n)]
        np.testing.assert_array_equal(state.background, lower_median(samples))
        stored.append(sum(pair is not None for pair in state.shared))
    if n >= 3:
        assert len(state.shared) == m and 0 < max(stored) <= m
    else:
        assert state.shared == ()


# ------------------------------------------------------------------------- scene building


def _ground(rng: np.random.Generator, modality: str = "rgb") -> np.ndarray:
    """A lightly textured greenish ground, (H,W,3) BGR (or (H,W) gray) uint8."""
    base = np.array([60, 140, 90], np.float64)  # BGR, saturated enough for hue to count
    tex = cv2.GaussianBlur(rng.normal(0.0, 20.0, (H, W)), (0, 0), 2.0)[..., None]  # ~4 levels
    img = np.clip(base + tex, 0, 255).astype(np.uint8)
    return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if modality == "gray" else img


def _noisy(img: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return np.clip(img + rng.normal(0.0, 1.5, img.shape), 0, 255).astype(np.uint8)


def _paste(img: np.ndarray, patch: np.ndarray, x: int, y: int) -> np.ndarray:
    out = img.copy()
    out[y : y + patch.shape[0], x : x + patch.shape[1]] = patch
    return out


def _person(rng: np.random.Generator, modality: str = "rgb") -> np.ndarray:
    """A textured 30x14 'person' patch: reddish, or bright (a warm body in thermal) for gray.

    A gray person darker than the ground would pass the V-ratio shadow test: gray cameras
    cannot tell a dark person from a shadow."""
    if modality == "gray":
        return np.clip(200 + rng.normal(0, 25, (30, 14)), 0, 255).astype(np.uint8)
    patch = np.clip(np.array([40, 40, 200]) + rng.normal(0, 25, (30, 14, 3)), 0, 255)
    return patch.astype(np.uint8)


def _train(
    ground: np.ndarray, rng: np.random.Generator, modality: str = "rgb", cfg: BackgroundConfig = CFG
) -> BackgroundState:
    return train_background([_noisy(ground, rng) for _ in range(cfg.train_frames)], modality, cfg)


def _run_moving(modality: str) -> list[BackgroundResult]:
    rng = np.random.default_rng(0)
    ground, person = _ground(rng, modality), _person(rng, modality)
    state = _train(ground, rng, modality)
    results = []
    for t in range(12):
        frame = _noisy(_paste(ground, person, 20 + 4 * t, 50), rng)
        state, result = background_step(state, frame, CFG)
        results.append(result)
    return results


# ------------------------------------------------------------------------------- hand-built


@pytest.mark.parametrize("modality", ["rgb", "gray"])
def test_moving_square_is_one_mvo(modality: str) -> None:
    results = _run_moving(modality)
    for t, r in enumerate(results[1:], start=1):  # step 0 has no previous frame for the flow
        assert int(r.mvo_labels.max()) == 1, f"frame {t}"
        b = r.blobs
        assert b.is_mvo.sum() == 1
        x, y, w, h = b.box_xywh[b.is_mvo][0]
        # the 14x30 patch at columns 20+4t.., rows 50..79: x = left edge - 0.5
        assert abs(x - (20 + 4 * t - 0.5)) <= 1 and abs(y - 49.5) <= 1
        assert abs(w - 14) <= 2 and abs(h - 30) <= 2
        assert 1.5 < b.mean_flow_px[b.is_mvo][0] < 6.0  # it moves 4 px/frame (DIS underestimates)
        assert r.mvo_labels[60, 20 + 4 * t + 7] == 1
    assert np.isnan(results[0].blobs.mean_flow_px).all()
    if modality == "gray":
        assert results[-1].background_bgr.shape == (H, W)


def _fragments_frame(rng: np.random.Generator, x: int, gap_px: int) -> tuple[np.ndarray, ...]:
    """A 'head' (8x8) above a 'body' (14x30) with a gap of ground between, at column x."""
    ground, person = _ground(rng), _person(rng)
    head = person[:8, 3:11]
    frame = _paste(_paste(ground, head, x + 3, 40 - gap_px - 8), person, x, 40)
    return ground, frame


def test_stacked_fragments_are_one_blob_side_by_side_people_two() -> None:
    rng = np.random.default_rng(5)
    ground, _ = _fragments_frame(rng, 20, 3)
    state = _train(ground, rng)
    for t in range(4):
        frame = _fragments_frame(np.random.default_rng(5), 20 + 4 * t, 3)[1]
        frame = _paste(frame, _person(rng), 86 + 4 * t, 40)  # two people side by side, 4 px apart
        frame = _paste(frame, _person(rng), 104 + 4 * t, 40)
        state, r = background_step(state, _noisy(frame, rng), CFG)
    b = r.blobs
    assert len(b) == 3 and b.is_mvo.all()
    _, y, _, h = b.box_xywh[0]
    assert abs(y - (40 - 3 - 8 - 0.5)) <= 1 and abs(h - 41) <= 2  # head, gap and body in one
    assert r.mvo_labels[36, 20 + 12 + 7] == r.mvo_labels[60, 20 + 12 + 7] == 1
    # the fragment test can be switched off: head and body are two blobs again
    off = dataclasses.replace(CFG, group_fragments=False)
    state = _train(ground, rng, cfg=off)
    for t in range(2):
        frame = _fragments_frame(np.random.default_rng(5), 20 + 4 * t, 3)[1]
        state, r = background_step(state, _noisy(frame, rng), off)
    assert len(r.blobs) == 2


def test_people_one_behind_the_other_are_two_blobs_where_the_size_line_says_so() -> None:
    """Two whole people stacked 3 px apart pass the fragment test (generated pair seed 1: a
    person walking in behind another, above their head). Taller together than 1.4 times the
    30 px the camera's size line predicts, and each at least 0.7 of that, they stay two blobs;
    a head fragment above its body (41 px together) still joins it. Without a size line the
    two people are one blob, as before the line is learned."""
    rng = np.random.default_rng(6)
    ground = _ground(rng)
    rows = np.linspace(40.0, 119.0, 60)
    people_30 = SizeModel(np.c_[rows, np.full(60, 30.0)], (0.0, 30.0))

    def last_step(sizes: SizeModel, two_people: bool) -> BackgroundResult:
        state = dataclasses.replace(_train(ground, rng), sizes=sizes)
        for t in range(4):
            if two_people:
                frame = _paste(ground, _person(rng), 40 + 3 * t, 10)  # rows 10-39
                frame = _paste(frame, _person(rng), 42 + 3 * t, 43)  # rows 43-72
            else:
                frame = _fragments_frame(np.random.default_rng(5), 20 + 4 * t, 3)[1]
            state, r = background_step(state, _noisy(frame, rng), CFG)
        return r

    assert len(last_step(people_30, two_people=True).blobs) == 2
    assert len(last_step(SizeModel(), two_people=True).blobs) == 1
    assert len(last_step(people_30, two_people=False).blobs) == 1
    # a head above a body taller than the line says (46 px together > 1.4 x 30) is still one
    # person: the head is no whole person (8 px < 0.7 x 30)
    head_body = np.array([[10.0, 10.0, 8.0, 8.0], [8.0, 20.0, 12.0, 36.0]])
    assert _fragment_links(head_body, 160, people_30, CFG)[0, 1]
    any_part_whole = dataclasses.replace(CFG, group_whole_frac=0.2)
    assert not _fragment_links(head_body, 160, people_30, any_part_whole)[0, 1]


@pytest.mark.parametrize(
    ("boxes", "linked"),
    [
        ([[0, 0, 10, 10], [1, 12, 10, 30]], True),  # head above a body, 2 px gap
        ([[0, 0, 10, 10], [1, 30, 10, 30]], False),  # gap 20 px > 0.15 * 30
        ([[0, 0, 10, 30], [14, 0, 10, 30]], False),  # side by side
        ([[0, 0, 10, 30], [5, 20, 10, 30]], True),  # 10 shared rows <= 0.5 * 30, 5 columns
        ([[0, 0, 10, 30], [5, 10, 10, 30]], False),  # 20 shared rows: beside, not stacked
        ([[0, 0, 10, 40], [0, 40, 10, 40]], False),  # union 80 x 10: taller than 4.5 : 1
    ],
)
def test_stacked_boxes_table(boxes: list[list[float]], linked: bool) -> None:
    m = stacked_boxes(np.array(boxes, np.float64), 0.5, 0.15, 0.5, 4.5)
    assert m[0, 0] and m[1, 1] and m[0, 1] == m[1, 0]
    assert bool(m[0, 1]) is linked


@pytest.mark.parametrize(
    ("x0", "on_border"),
    [(233.5, True), (234.0, True), (-0.5, True), (0.0, True), (223.5, False), (1.0, False)],
)
def test_stacked_slivers_on_a_side_border_need_no_upright_aspect(
    x0: float, on_border: bool
) -> None:
    """Torso and legs of someone walking in at a side border, 6 px of them in view and 34 tall
    together (5.7 : 1), are stacked there (edge boxes at -0.5 / 239.5 or pixel-index boxes at
    0 / 240 of a 240 px frame); the same slivers inside the frame are not. Without a size
    model the border is no exception: two people, one above the other, look the same."""
    boxes = np.array([[x0, 31.5, 6.0, 17.0], [x0, 49.5, 6.0, 16.0]])
    assert not stacked_boxes(boxes, 0.5, 0.15, 0.5, 4.5)[0, 1]
    assert bool(stacked_boxes(boxes, 0.5, 0.15, 0.5, 4.5, cols=240)[0, 1]) is on_border
    # blobs are grouped so only once a size model bounds their height (people 36 px tall)
    assert bool(_fragment_links(boxes, 240, SizeModel(line=(0.0, 36.0)), CFG)[0, 1]) is on_border
    assert not _fragment_links(boxes, 240, SizeModel(), CFG)[0, 1]


def test_removed_object_is_a_ghost_and_is_absorbed() -> None:
    rng = np.random.default_rng(2)
    ground = _ground(rng)
    with_box = _paste(ground, _person(rng), 70, 40)
    state = _train(with_box, rng)  # the object stood there during training
    ghost_px = []
    for t in range(45):
        state, r = background_step(state, _noisy(ground, rng), CFG)
        assert r.mvo_labels.max() == 0 or t == 0, f"frame {t}: a ghost became an MVO"
        ghost_px.append(int(r.ghost_mask[40:70, 70:84].sum()))
    assert ghost_px[1] > 0.9 * 30 * 14  # the vacated region is a ghost...
    # ...that the median absorbs once more than half the n samples (spaced m apart) are clean.
    absorbed_after = (CFG.fifo_n // 2 + 1) * CFG.fifo_spacing_frames
    assert ghost_px[absorbed_after] == 0 and ghost_px[-1] == 0
    assert np.abs(state.background.astype(int) - ground.astype(int)).max() < 12


def test_removed_object_ghost_fails_the_edge_test_even_when_it_moves() -> None:
    """The vacated region's boundary has B's edges (the object), not the frame's."""
    rng = np.random.default_rng(2)
    ground = _ground(rng)
    state = _train(_paste(ground, _person(rng), 70, 40), rng)
    cfg = dataclasses.replace(CFG, min_mean_flow_px=0.0, min_changed_frac=0.0)  # all "move"
    for t in range(4):
        state, r = background_step(state, _noisy(ground, rng), cfg)
        b = r.blobs
        big = b.area_px > cfg.min_area_px
        assert big.sum() == 1, f"frame {t}"
        assert b.edge_frame[big][0] < 0.5 * b.edge_background[big][0]
        assert not b.edge_ok[big][0] and not b.is_mvo[big][0]
    off = dataclasses.replace(cfg, edge_ghost_ratio=0.0)  # without the edge test: an MVO
    state = _train(_paste(ground, _person(rng), 70, 40), rng)
    for _ in range(2):
        state, r = background_step(state, _noisy(ground, rng), off)
    assert r.blobs.is_mvo.sum() == 1 and np.isnan(r.blobs.edge_frame).all()


def test_ghost_with_a_neighbours_flow_but_no_changed_pixel_does_not_move() -> None:
    """DIS spreads a walker's flow over the ghost beside it (generated pair seed 3). Here every
    blob passes the flow test (T_AOF 0) and the edge test is off: the ghost of an object
    present in training changes no pixel, so it stops being an MVO once its hold runs out and
    the median absorbs it; the walker beside it, whose pixels change, stays one."""
    rng = np.random.default_rng(4)
    ground = _ground(rng)
    cfg = dataclasses.replace(CFG, min_mean_flow_px=0.0, edge_ghost_ratio=0.0, mvo_hold_frames=5)

    def run(cfg: BackgroundConfig) -> tuple[list[bool], list[bool]]:
        state = _train(_paste(ground, _person(rng), 70, 40), rng, cfg=cfg)
        ghost, walker = [], []
        for t in range(20):  # the walker's right side ends 8 px left of the ghost
            frame = _paste(ground, _person(rng), 10 + 2 * t, 45)
            state, r = background_step(state, _noisy(frame, rng), cfg)
            ghost.append(bool(r.mvo_labels[50:65, 74:80].any()))
            walker.append(bool(r.mvo_labels[50:65, 15 + 2 * t : 19 + 2 * t].any()))
        return ghost, walker

    ghost, walker = run(cfg)
    assert all(walker)
    assert ghost[0] and not any(ghost[2 + cfg.mvo_hold_frames :])  # an MVO, then held
    ghost_off, _ = run(dataclasses.replace(cfg, still_changed_frac=0.0))
    assert ghost_off[-1]  # without the test, flow alone keeps the ghost an MVO


@pytest.mark.parametrize("hold", [0, 5])
def test_person_who_stops_is_held_for_a_bounded_time(hold: int) -> None:
    rng = np.random.default_rng(3)
    ground, person = _ground(rng), _person(rng)
    cfg = dataclasses.replace(CFG, mvo_hold_frames=hold, fifo_spacing_frames=20)
    state = _train(ground, rng, cfg=cfg)
    mvo, held = [], []
    for t in range(16):
        x = 20 + 4 * min(t, 6)  # walks 6 frames, then stands at column 44
        state, r = background_step(state, _noisy(_paste(ground, person, x, 50), rng), cfg)
        mvo.append(bool(r.blobs.is_mvo.any()))
        held.append(bool(r.blobs.held.any()))
    assert all(mvo[1:7])  # walking
    # standing: the motion tests fail once the flow gap (3 frames) holds no motion
    still = [t for t in range(10, 16) if not held[t] and not mvo[t]]
    if hold == 0:
        assert not any(held) and still == list(range(10, 16))
    else:
        first = held.index(True)
        assert 7 <= first <= 10 and held[first : first + hold] == [True] * hold
        assert mvo[first : first + hold] == [True] * hold
        assert not mvo[first + hold] and not held[first + hold]  # released after the bound


@pytest.mark.parametrize("frac", [0.5, 1.0])
def test_what_is_left_of_a_tracked_person_stays_an_mvo(frac: float) -> None:
    """A walker of whom only the top 5 rows show for three frames (70 px, under T_area = 100):
    the remnant of last frame's MVO stays an MVO with ``hold_area_frac`` 0.5, not with 1 (off).
    A piece of the same size beside someone detected whole is never one."""
    rng = np.random.default_rng(5)
    ground, person = _ground(rng), _person(rng)
    cfg = dataclasses.replace(CFG, hold_area_frac=frac)
    state = _train(ground, rng, cfg=cfg)
    for t in range(10):
        patch = person[:5] if t in (6, 7, 8) else person
        state, r = background_step(state, _noisy(_paste(ground, patch, 20 + 3 * t, 50), rng), cfg)
        assert r.blobs.area_px.max() < 100 or t not in (6, 7, 8)
        assert r.blobs.is_mvo.sum() == (0 if frac == 1.0 and t in (6, 7, 8) else 1), t
    state = _train(ground, rng, cfg=cfg)
    wide = np.concatenate([person, person[:, :8]], axis=1)  # 30x22: the piece is still attached
    for t in range(8):
        frame = _paste(ground, wide if t < 5 else person, 20 + 2 * t, 50)
        if t >= 5:  # the piece comes apart: 5x12 px, 3 px right of the body
            frame = _paste(frame, person[:5, :12], 20 + 2 * t + 17, 50)
        state, r = background_step(state, _noisy(frame, rng), cfg)
        small = r.blobs.area_px < 100
        assert small.any() == (t >= 5) and not r.blobs.is_mvo[small].any(), t
        assert not r.blobs.border_mover.any()  # inside the frame: left to the thesis's rule


@pytest.mark.parametrize("keep", [True, False])
def test_a_person_entering_slowly_is_not_learned_as_background(keep: bool) -> None:
    """A thin person slides into view down from the top border at 1/3 px per frame: under
    T_area = 100 px for 45 frames, a border mover. Kept out of B's update (the default) they are
    one whole MVO once large enough; learned meanwhile (the thesis) their top is background."""
    rng = np.random.default_rng(6)
    ground, person = _ground(rng), _person(rng)[:, :6]  # 30x6
    cfg = dataclasses.replace(CFG, keep_border_movers=keep)
    state = _train(ground, rng, cfg=cfg)
    movers = []
    for t in range(80):
        rows = min(30, 1 + t // 3)
        frame = _paste(ground, person[-rows:], 70, 0)
        state, r = background_step(state, _noisy(frame, rng), cfg)
        movers.append(int(r.border_mover_mask.sum()))
        assert r.blobs.border_mover.any() == r.border_mover_mask.any(), t
    visible = 6 * rows
    assert visible > 1.5 * CFG.min_area_px
    top = np.abs(state.background[:5, 70:76].astype(int) - ground[:5, 70:76].astype(int))
    if keep:
        assert min(movers[30:42]) > 0.8 * 6 * (1 + 30 // 3)  # all of the person, under T_area
        assert r.blobs.is_mvo.sum() == 1 and r.mvo_mask.sum() >= 0.9 * visible
        assert top.mean() < 10  # B still has the ground where the person's head came in
    else:
        assert r.mvo_mask.sum() < 0.5 * visible
        assert top.mean() > 40  # B learned the person


def test_walkers_crossing_in_one_blob_move_by_frame_difference() -> None:
    """Two people walking in opposite directions in one blob: their flow cancels, their
    pixels change."""
    rng = np.random.default_rng(4)
    ground, a, b = _ground(rng), _person(rng), _person(rng)
    state = _train(ground, rng)
    for t in range(8):
        frame = _paste(_paste(ground, a, 60 + 2 * t, 50), b, 74 - 2 * t, 50)
        state, r = background_step(state, _noisy(frame, rng), CFG)
    blobs = r.blobs
    big = blobs.area_px > CFG.min_area_px
    assert big.sum() == 1
    assert blobs.mean_flow_px[big][0] < 1.0  # +2 and -2 px/frame cancel (mostly)
    assert blobs.changed_frac[big][0] > 2 * CFG.min_changed_frac
    assert blobs.moving_ok[big][0] and blobs.is_mvo[big][0]


def test_darkened_same_hue_region_is_shadow_not_foreground() -> None:
    rng = np.random.default_rng(3)
    ground = _ground(rng)
    state = _train(ground, rng)
    frame = _noisy(ground, rng).astype(np.float64)
    frame[30:60, 20:60] *= 0.6  # cast shadow: same hue and saturation, 60 % of the value
    frame[30:60, 100:140] = frame[30:60, 100:140][..., ::-1] * 0.6  # darker AND other hue
    state, r = background_step(state, frame.astype(np.uint8), CFG)
    assert r.shadow[30:60, 20:60].mean() > 0.95
    assert r.candidate[30:60, 20:60].sum() == 0
    assert r.shadow[30:60, 100:140].mean() < 0.05
    assert r.candidate[32:58, 102:138].all()
    assert r.shadow[:, 65:95].sum() == 0  # untouched ground is not shadow


@pytest.mark.parametrize("hue_min_sat, legs_are_shadow", [(0.09, False), (0.15, True)])
def test_gray_trousers_on_gray_pavement_are_not_shadow(hue_min_sat: float,
                                                      legs_are_shadow: bool) -> None:
    """Pale pavement (S ~ 0.12) and blue-gray trousers as dark as a shadow: their hue differs,
    a shadow's does not. Hue counts in the shadow test from shadow_hue_min_sat on (0.09); with
    hue ignored below 0.15 the legs would be called shadow and cut off the person."""
    rng = np.random.default_rng(5)
    pavement = np.array([150.0, 160.0, 170.0])  # BGR: S = 20/170, orange-ish hue
    ground = np.clip(pavement + rng.normal(0.0, 1.0, (H, W, 3)), 0, 255).astype(np.uint8)
    cfg = dataclasses.replace(CFG, shadow_hue_min_sat=hue_min_sat)
    state = _train(ground, rng, cfg=cfg)
    frame = _noisy(ground, rng).astype(np.float64)
    frame[30:60, 20:60] *= 0.6  # cast shadow: same hue, 60 % of the value
    frame[30:60, 100:140] = [110.0, 100.0, 95.0]  # trousers: V 0.65 of B, S 15/110, bluish
    state, r = background_step(state, frame.astype(np.uint8), cfg)
    assert r.shadow[30:60, 20:60].mean() > 0.95
    assert r.candidate[30:60, 20:60].sum() == 0
    if legs_are_shadow:
        assert r.shadow[30:60, 100:140].mean() > 0.95
    else:
        assert r.shadow[30:60, 100:140].mean() < 0.05
        assert r.candidate[32:58, 102:138].mean() > 0.95


def test_shadow_attached_to_mvo_is_foreground_shadow() -> None:
    rng = np.random.default_rng(4)
    ground, person = _ground(rng), _person(rng)
    state = _train(ground, rng)
    for t in range(6):
        frame = _paste(ground, person, 20 + 4 * t, 30).astype(np.float64)
        frame[60:68, 14 + 4 * t : 40 + 4 * t] *= 0.6  # its shadow at its feet
        frame[90:110, 110:140] *= 0.6  # a shadow nobody casts
        state, r = background_step(state, _noisy(frame, rng), CFG)
    assert r.blobs.is_mvo.sum() == 1
    assert r.fg_shadow[61:67, 16 + 4 * 5 : 38 + 4 * 5].mean() > 0.9
    assert r.fg_shadow[90:110, 110:140].sum() == 0
    assert r.ghost_shadow[91:109, 111:139].mean() > 0.9
    assert not (r.fg_shadow & r.ghost_shadow).any()
    assert np.array_equal(r.fg_shadow | r.ghost_shadow, r.shadow)


@pytest.mark.parametrize("gap_px", [0, 4])
def test_a_broken_shadow_near_an_mvo_is_foreground_shadow(gap_px: int) -> None:
    """A far person's cast shadow passes the shadow test only in specks (the ground's texture
    and the video's noise break it up): 2x2 specks 2 px apart, the first 2 px from the feet.
    Unconnected, they were ghost shadows and went into the background, which then held a dark
    trail of the person's path. Within fg_shadow_gap_px of the MVO they are its shadow."""
    rng = np.random.default_rng(4)
    ground, person = _ground(rng), _person(rng)
    cfg = dataclasses.replace(CFG, fg_shadow_gap_px=gap_px)
    state = _train(ground, rng, cfg=cfg)
    for t in range(6):
        x = 20 + 4 * t
        frame = _paste(ground, person, x, 30).astype(np.float64)
        specks = np.zeros((H, W), bool)
        for sx in range(x + 16, x + 40, 4):  # right of the feet (the person is 14 px wide)
            specks[56:58, sx : sx + 2] = True
        frame[specks] *= 0.6
        frame[90:110, 110:140] *= 0.6  # a shadow nobody casts, 30 px from the person
        state, r = background_step(state, _noisy(frame, rng), cfg)
    assert r.blobs.is_mvo.sum() == 1
    assert r.shadow[specks].mean() > 0.9
    found = r.fg_shadow[specks & r.shadow]
    assert found.all() if gap_px else not found.any()
    assert r.fg_shadow[90:110, 110:140].sum() == 0


def test_result_masks_are_consistent() -> None:
    r = _run_moving("rgb")[-1]
    assert r.distance.dtype == np.float32 and 0 <= r.distance.min() <= r.distance.max() <= 1
    assert np.array_equal(r.candidate, r.blob_labels > 0)
    assert not (r.mvo_mask & r.ghost_mask).any() and not (r.border_mover_mask & r.ghost_mask).any()
    assert not (r.mvo_mask & r.border_mover_mask).any()
    assert np.array_equal(r.mvo_mask | r.ghost_mask | r.border_mover_mask, r.candidate)
    assert not (r.candidate & r.shadow).any()
    b = r.blobs
    assert np.array_equal(b.label, np.arange(1, len(b) + 1))
    assert np.array_equal(np.bincount(r.blob_labels.ravel(), minlength=len(b) + 1)[1:], b.area_px)
    assert np.array_equal(b.is_mvo, b.area_ok & b.strong_ok & b.flow_ok)
    assert sorted(set(np.unique(r.mvo_labels)) - {0}) == list(range(1, int(b.is_mvo.sum()) + 1))


# --------------------------------------------------------------------------- immutability


def test_inputs_and_results_do_not_change() -> None:
    rng = np.random.default_rng(5)
    ground, person = _ground(rng), _person(rng)
    state = _train(ground, rng)
    frames = [_noisy(_paste(ground, person, 20 + 4 * t, 50), rng) for t in range(4)]
    originals = [f.copy() for f in frames]
    state, first = background_step(state, frames[0], CFG)
    state1, second = background_step(state, frames[1], CFG)
    snapshot = {
        f.name: np.array(getattr(second, f.name), copy=True)
        for f in dataclasses.fields(second)
        if isinstance(getattr(second, f.name), np.ndarray)
    }
    # stepping on from the same state (twice: a pure function) must not touch earlier results
    state2, again = background_step(state, frames[1], CFG)
    background_step(state2, frames[2], CFG)
    background_step(state1, frames[3], CFG)
    for name, value in snapshot.items():
        np.testing.assert_array_equal(getattr(second, name), value, err_msg=name)
        np.testing.assert_array_equal(getattr(again, name), value, err_msg=name)
    assert all(np.array_equal(a, b) for a, b in zip(frames, originals, strict=True))
    assert not first.background_bgr.flags.writeable
    assert not any(f.flags.writeable for f in state.fifo)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda s: background_step(s, np.zeros((H, W + 1, 3), np.uint8), CFG), "frame"),
        (lambda s: background_step(s, np.zeros((H, W), np.uint8), CFG), "rgb frame"),
        (lambda s: background_step(s, np.zeros((H, W, 3), np.float32), CFG), "uint8"),
        (
            lambda s: background_step(
                s, np.zeros((H, W, 3), np.uint8), dataclasses.replace(CFG, fifo_n=3)
            ),
            "FIFO",
        ),
        (lambda s: train_background([np.zeros((H, W, 3), np.uint8)], "ir", CFG), "modality"),
        (lambda s: train_background([], "rgb", CFG), "no frames"),
    ],
)
def test_bad_input_is_named(call: object, message: str) -> None:
    state = train_background([np.zeros((H, W, 3), np.uint8)], "rgb", CFG)
    with pytest.raises(ValueError, match=message):
        call(state)  # type: ignore[operator]


def test_gray_camera_accepts_bgr_frames_and_shadow_switch() -> None:
    rng = np.random.default_rng(6)
    ground = _ground(rng)
    state = train_background([_noisy(ground, rng) for _ in range(5)], "gray", CFG)
    assert state.background.shape == (H, W)
    frame = ground.astype(np.float64)
    frame[30:60, 20:60] *= 0.6
    _, r = background_step(state, frame.astype(np.uint8), CFG)
    assert r.shadow[30:60, 20:60].mean() > 0.95 and not r.candidate[30:60, 20:60].any()
    no_shadows = dataclasses.replace(CFG, gray_shadows=False)
    _, r = background_step(state, frame.astype(np.uint8), no_shadows)
    assert not r.shadow.any() and r.candidate[32:58, 22:58].all()


# ----------------------------------------------------------------------------- real video


def _pets_truth(path: Path, last_frame: int) -> tuple[dict[int, list[tuple[float, ...]]], int]:
    """gt.txt rows per 0-based frame: (foot_x, foot_y, height)."""
    out: dict[int, list[tuple[float, ...]]] = {}
    count = 0
    with path.open() as fh:
        for row in csv.reader(fh):
            frame = int(row[0]) - 1
            if frame <= last_frame:  # conf 0 rows are real people too (far away, or leaving)
                x, y, w, h = map(float, row[2:6])
                out.setdefault(frame, []).append((x + w / 2, y + h, h))
                count += 1
    return out, count


@pytest.mark.slow
def test_pets_view001_blobs_match_people() -> None:
    folder = _shared_data() / "pets2009-s2l1"
    if not (folder / "View_001.avi").exists():
        pytest.skip(f"PETS 2009 data not found at {folder} (set MVTRACK_SHARED_DATA)")
    from mvtrack.evaluate.metrics import frame_matches

    cfg = BackgroundConfig()
    cap = cv2.VideoCapture(str(folder / "View_001.avi"))
    frames = []
    while len(frames) < 400:  # frames 0-399 (of 795): 100 train, 400 steps; half the time
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    cap.release()
    truth, _ = _pets_truth(folder / "gt.txt", len(frames) - 1)
    state = train_background(frames[: cfg.train_frames], "rgb", cfg)
    hits = n_pred = n_true = 0
    for i, frame in enumerate(frames):
        state, r = background_step(state, frame, cfg)
        boxes = r.blobs.box_xywh[r.blobs.is_mvo]
        feet = np.column_stack([boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + boxes[:, 3]])
        rows = np.array(truth.get(i, []), np.float64).reshape(-1, 3)
        pi, _ = frame_matches(feet, rows[:, :2], rows[:, 2], 0.5)
        hits, n_pred, n_true = hits + len(pi), n_pred + len(feet), n_true + len(rows)
    # blob level (before tracking), all annotated people (occluded ones included)
    print(f"PETS View_001: recall {hits / n_true:.3f} precision {hits / n_pred:.3f}")
    assert hits / n_true >= 0.8, f"recall {hits / n_true:.3f}"
    assert hits / n_pred >= 0.8, f"precision {hits / n_pred:.3f}"


# ------------------------------------------------------------------------- generated clip


def _read_video(path: Path) -> list[np.ndarray]:
    cap = cv2.VideoCapture(str(path))
    frames = []
    while True:
        ok, frame = cap.read()
        if not ok:
            break
        frames.append(frame)
    cap.release()
    return frames


@pytest.mark.slow
def test_generated_pair_masks_and_shadows(tmp_path: Path) -> None:
    generate = pytest.importorskip("mvtrack.generate")
    from mvtrack.evaluate.metrics import MaskScores, frame_matches, mask_scores

    clip = generate.generate_clip(tmp_path / "clip", "pair", seed=0, frames=200, size=(320, 240))
    cfg = BackgroundConfig()
    scores = MaskScores()
    hits = n_pred = n_true = 0
    for cam in ("cam0", "cam1"):
        frames = _read_video(clip / f"{cam}.mp4")
        height, width = frames[0].shape[:2]
        truth: dict[int, list[tuple[float, ...]]] = {}
        with (clip / "truth" / f"{cam}.csv").open() as fh:
            for row in csv.DictReader(fh):
                x, y, w, h = (float(row[k]) for k in ("box_x", "box_y", "box_w", "box_h"))
                inside = x > 1 and y > 1 and x + w < width - 1 and y + h < height - 1
                counted = float(row["visible"]) >= 0.5 and inside
                truth.setdefault(int(row["frame"]), []).append((x + w / 2, y + h, h, counted))
        state = train_background(frames[: cfg.train_frames], "rgb", cfg)
        for i, frame in enumerate(frames):
            state, r = background_step(state, frame, cfg)
            boxes = r.blobs.box_xywh[r.blobs.is_mvo]
            feet = np.column_stack([boxes[:, 0] + boxes[:, 2] / 2, boxes[:, 1] + boxes[:, 3]])
            rows = np.array(truth.get(i, []), np.float64).reshape(-1, 4)
            _, ti = frame_matches(feet, rows[:, :2], rows[:, 2], 0.5)
            counted = rows[:, 3] > 0
            # recall over counted people; an MVO on a border or occluded person is no error
            hits, n_true = hits + int(counted[ti].sum()), n_true + int(counted.sum())
            n_pred += len(feet) - int((~counted[ti]).sum())
            mask_path = clip / "truth" / "masks" / cam / f"{i:06d}.png"
            if mask_path.exists():
                pred = np.zeros(r.shadow.shape, np.uint8)
                pred[r.shadow] = 2
                pred[r.mvo_mask] = 1
                scores = scores + mask_scores(pred, cv2.imread(str(mask_path), 0))
    s = scores.summary()
    print(
        f"generated pair: people inside the frame recall {hits / n_true:.3f}, "
        f"MVO precision {hits / n_pred:.3f}, {dict((k, round(v, 3)) for k, v in s.items())}"
    )
    # measured (both cameras, seed 0): shadow detection 0.890, fg precision 0.857, fg recall
    # 0.826, shadow discrimination 0.904, recall 0.972, precision 0.959; blob level, before
    # tracking. With hue ignored in the shadow test below S 0.15 (shadow_hue_min_sat = 0.15):
    # 0.899, 0.836, 0.746, 0.851 (legs of gray trousers called shadow).
    assert s["shadow_detection"] >= 0.8  # issue 3 target
    assert s["fg_precision"] >= 0.8
    assert s["fg_recall"] >= 0.78
    assert s["shadow_discrimination"] >= 0.88  # person pixels not called shadow
    assert hits / n_true >= 0.9  # people touching the frame border are not counted
    assert hits / n_pred >= 0.87


@settings(max_examples=200, deadline=None)
@given(n=st.integers(1, 120), spacing=st.integers(1, 6), available=st.integers(1, 800))
def test_training_offsets_are_spaced_and_spread_over_short_runs(
    n: int, spacing: int, available: int
) -> None:
    offsets = training_offsets(available, BackgroundConfig(train_frames=n,
                                                           train_spacing_frames=spacing))
    assert len(offsets) == min(n, available) and offsets[0] == 0
    assert np.all(np.diff(offsets) >= 1) and offsets[-1] < available  # distinct frames of the run
    if (n - 1) * spacing < available:  # room for the spacing: exactly that
        assert np.array_equal(offsets, np.arange(n) * spacing)
    else:  # a short run: spread evenly to its end, steps differing by at most one frame
        steps = np.diff(offsets)
        assert offsets[-1] == available - 1 and (len(steps) == 0 or np.ptp(steps) <= 1)


def test_spaced_training_does_not_learn_slow_walkers(tmp_path: Path) -> None:
    """Generated 'crowd' people on the far grass walk 0.25 px/frame: over 50 frames in a row
    the median keeps them (ghosts), over 50 frames 3 apart it does not."""
    generate = pytest.importorskip("mvtrack.generate")
    from mvtrack.io import open_clip
    from mvtrack.params import load_params
    from mvtrack.pipeline import train_backgrounds

    clip_dir = generate.generate_clip(tmp_path / "c", "crowd", seed=0, frames=150,
                                      size=(320, 240))
    wrong = {}
    for spacing in (1, 3):
        params = load_params(None, ["background.train_frames=50",
                                    f"background.train_spacing_frames={spacing}"])
        with open_clip(clip_dir) as clip:
            states = train_backgrounds(clip, range(clip.spec.frame_count), params)
        for cam, state in states.items():
            truth = cv2.imread(str(clip_dir / "truth" / "background" / f"{cam}.png"))
            off = np.abs(state.model.bgr.max(axis=2).astype(np.int16)
                         - truth.max(axis=2).astype(np.int16))  # V = max(B, G, R)
            wrong[spacing, cam] = int((off > 255 * params.background.t_low).sum())
    print("trained B pixels off the true background by > T_L:", wrong)
    # measured: 1444 / 1335 px in a row, 243 / 218 px spaced (cam0 / cam1)
    for cam in ("cam0", "cam1"):
        assert wrong[1, cam] > 1000  # the scene does have slow walkers
        assert wrong[3, cam] < 400 and wrong[3, cam] < wrong[1, cam] / 4


@pytest.mark.parametrize(
    ("shape", "ref", "expected"),
    [
        ((240, 320), 277.0, 100.0),  # the reference size (sqrt(W*H) = 277.1)
        ((120, 160, 3), 277.0, 100.0),  # never below min_area_px
        ((480, 640, 3), 277.0, 100.0 * 554.3 / 277.0),  # twice the size: twice T_area
        ((576, 768), 277.0, 100.0 * 665.1 / 277.0),  # PETS
        ((576, 768), 0.0, 100.0),  # off: absolute
    ],
)
def test_min_area_grows_with_the_frame_size(
    shape: tuple[int, ...], ref: float, expected: float
) -> None:
    cfg = dataclasses.replace(CFG, min_area_px=100, min_area_ref_size_px=ref)
    assert min_area_at(shape, cfg) == pytest.approx(expected, rel=1e-3)


def test_blob_table_records_the_min_area_it_used() -> None:
    rng = np.random.default_rng(5)
    ground = _ground(rng)
    state = _train(ground, rng)
    cfg = dataclasses.replace(CFG, min_area_ref_size_px=0.5 * np.sqrt(H * W))
    _, r = background_step(state, _noisy(_paste(ground, _person(rng), 70, 40), rng), cfg)
    assert r.blobs.min_area_px == pytest.approx(2 * cfg.min_area_px)
    assert np.array_equal(r.blobs.area_ok, r.blobs.area_px > 2 * cfg.min_area_px)
    assert r.blobs.area_ok.any()


# ------------------------------------------------------------------------ person-size model


def test_size_line_is_robust_to_people_who_lost_their_legs() -> None:
    rng = np.random.default_rng(2)
    rows = rng.uniform(40, 230, 200)
    heights = 0.25 * rows + 5 + rng.normal(0, 1.0, 200)
    heights[:50] *= 0.6  # a quarter lost their legs to the shadow test
    cfg = BackgroundConfig()
    fit = _fit_sizes(np.c_[rows, heights], 240, cfg)
    assert fit is not None and fit.line is not None and fit.band is None
    slope, intercept = fit.line
    assert slope == pytest.approx(0.25, abs=0.02) and intercept == pytest.approx(5, abs=3)
    assert _fit_sizes(np.c_[rows, heights][:20], 240, cfg) is None  # too few


def test_the_line_of_whole_people_is_not_pulled_down_by_far_people_without_legs() -> None:
    """Far people (rows 40-100) lost their legs more often than not, as on generated 'pair'
    s2 cam0 (53 % of its samples on rows 30-60): the least-squares line, however trimmed, is
    pulled down there and steepened; the consensus line is within 4 % of the truth on every
    row, and the same samples give the same line."""
    rng = np.random.default_rng(4)
    rows = rng.uniform(40, 230, 300)
    stature = rng.uniform(0.92, 1.08, 300)  # +-8 %
    heights = (0.2 * rows + 20) * stature
    far = np.flatnonzero(rows < 100)
    lost = far[: int(0.6 * len(far))]
    heights[lost] *= rng.uniform(0.5, 0.65, len(lost))  # ended at the hips or knees
    cfg = BackgroundConfig()
    fit = _fit_sizes(np.c_[rows, heights], 240, cfg)
    assert fit is not None and fit.line is not None and fit.whole is not None
    check = np.linspace(40, 230, 20)
    truth = 0.2 * check + 20
    whole_err = np.abs(np.polyval(fit.whole, check) - truth) / truth
    line_err = np.abs(np.polyval(fit.line, check) - truth) / truth
    assert whole_err.max() < 0.04
    assert line_err.max() > 0.08  # what the regrowth and completion used before
    assert _fit_sizes(np.c_[rows, heights], 240, cfg).whole == fit.whole  # deterministic
    # people entering at the top, their heads cut at row 1, are most samples early on:
    # height = bottom row is the consensus, steeper than the least-squares line; not taken
    entering = rng.uniform(20, 70, 120)
    heads_cut = np.c_[entering, 0.96 * entering - 1.0]  # their tops on rows 2-4
    mixed = np.r_[heads_cut, np.c_[rows, heights][rows >= 100][:60]]
    early = _fit_sizes(mixed, 240, cfg)
    assert early is not None and early.line is not None and early.whole is None
    # no consensus: heights scattered over a factor of three
    scattered = np.c_[rows, rng.uniform(20, 60, 300)]
    assert _fit_sizes(scattered, 240, dataclasses.replace(cfg, size_whole_tol=0.02)).whole is None


def test_people_in_a_band_of_rows_have_their_median_height_there_only() -> None:
    """Samples on rows 100-120 are too close for a slope: no line, but their median height
    (32.5 px) holds within one height of the band (T_area, fragments, leg regrowth) and
    nowhere else; a line learned before is kept when the newest samples crowd into one band."""
    rng = np.random.default_rng(3)
    clustered = np.c_[rng.uniform(100, 120, 100), rng.uniform(30, 35, 100)]
    cfg = BackgroundConfig()
    fit = _fit_sizes(clustered, 240, cfg)
    assert fit is not None and fit.line is None and fit.band is not None
    assert fit.slope_intercept() == (0.0, fit.band[0])
    h = fit.height_at(np.array([60.0, 75.0, 110.0, 145.0, 160.0]))
    assert h is not None and np.isnan(h[[0, 4]]).all()
    assert h[1:4] == pytest.approx(np.median(clustered[:, 1]), abs=1e-9)
    bottoms = np.array([110.0, 160.0])  # two blobs: in the band, and beyond it
    stats = np.zeros((3, 5), np.int32)
    stats[1:, cv2.CC_STAT_TOP], stats[1:, cv2.CC_STAT_HEIGHT] = bottoms - 30, 30
    thresholds = _area_thresholds(stats, fit, 200.0, cfg)
    assert thresholds == pytest.approx([cfg.size_area_frac * h[2] ** 2, 200.0])
    assert _fit_sizes(clustered, 240, dataclasses.replace(cfg, size_band_heights=0)) is None
    no_blobs = SimpleNamespace(**{k: np.zeros(0, bool) for k in (
        "strong_ok", "edge_ok", "moving_ok", "is_mvo")}, area_px=np.zeros(0),
        box_xywh=np.zeros((0, 4)))
    kept = _learn_sizes(SizeModel(clustered, (0.25, 5.0)), no_blobs, (240, 320), cfg, 0)
    assert kept.line == (0.25, 5.0) and len(kept.samples) == 100


def _small_walkers(ground: np.ndarray, rng: np.random.Generator, t: int) -> np.ndarray:
    """``ground`` with four walkers whose height grows with their feet row (h = 0.2 row + 4:
    12-24 px on rows 40-100, h/4 wide, under T_area 100 but the nearest), crossing at 2 px a
    frame, each starting at its own column."""
    frame = ground
    for k, feet in enumerate((40, 60, 80, 100)):
        h = int(0.2 * feet + 4)
        x = (10 + 37 * k + 2 * t) % (W - 10)
        frame = _paste(frame, _person(rng)[:h, : max(h // 4, 3)], x, feet - h)
    return _noisy(frame, rng)


def test_training_frames_give_the_size_model_that_holds_t_area_until_the_run_has_one() -> None:
    """Far people under T_area are MVOs from the first frame when the training frames taught
    the camera how tall people are at each row; without that they wait for the run's own size
    model (size_min_samples samples)."""
    cfg = dataclasses.replace(CFG, train_frames=40)
    rng = np.random.default_rng(11)
    ground = _ground(rng)
    training = [_small_walkers(ground, rng, 5 * t) for t in range(cfg.train_frames)]
    state = train_background(training, "rgb", cfg)
    prior = state.prior_sizes
    assert prior is not None and prior.line is not None and len(state.sizes.samples) == 0
    assert prior.height_at(np.array([60.0]))[0] == pytest.approx(16.0, abs=2.0)
    off = train_background(training, "rgb", dataclasses.replace(cfg, train_sizes=False))
    assert off.prior_sizes is None
    person = _person(rng)[:16, :4]  # 64 px: h = 16 on row 60, 0.12 h^2 = 31 px < 64 < 100
    for start, expected in ((state, 1), (off, 0)):
        s = start
        for t in range(3):
            frame = _noisy(_paste(ground, person, 40 + 2 * t, 44), rng)
            s, r = background_step(s, frame, cfg)
            assert int(r.blobs.is_mvo.sum()) == expected, (t, expected)
        assert s.prior_sizes is start.prior_sizes  # carried from frame to frame


@pytest.mark.parametrize("regrow_legs", [True, False])
@pytest.mark.parametrize("legs", ["shadow", "thin"])
def test_lost_legs_are_grown_back(regrow_legs: bool, legs: str) -> None:
    """A walker whose legs leave the MVO: trousers as dark as a shadow on ground of their hue
    (the shadow test takes them), or legs 2 px wide (the opening removes them). The MVO ends
    at the hips. The camera's size line (height = 0.5 x feet row) says where the feet are: the
    legs are grown back down to them and the feet are found within 2.5 px, while the cast
    shadow running sideways from the feet stays a shadow."""
    rng = np.random.default_rng(8)
    ground = _ground(rng)
    cfg = dataclasses.replace(CFG, regrow_legs=regrow_legs)
    state = _train(ground, rng, cfg=cfg)
    rows = np.linspace(40.0, 119.0, 60)  # samples on the line: refits keep it
    state = dataclasses.replace(state, sizes=SizeModel(np.c_[rows, 0.5 * rows], (0.5, 0.0)))
    torso = np.clip(np.array([40, 40, 200]) + rng.normal(0, 25, (25, 12, 3)), 0, 255)
    for t in range(6):
        x = 30 + 3 * t
        frame = ground.astype(np.float64)
        frame[50:75, x : x + 12] = torso  # head and torso: rows 50-74, feet at row 100
        if legs == "shadow":  # 60 % of the ground's value, its hue
            frame[75:100, x + 1 : x + 5] *= 0.6
            frame[75:100, x + 7 : x + 11] *= 0.6
        else:  # blue jeans, thinner than the 3 px opening
            frame[75:100, x + 2 : x + 4] = [150, 60, 30]
            frame[75:100, x + 8 : x + 10] = [150, 60, 30]
        frame[95:100, x + 10 : x + 40] *= 0.6  # cast shadow towards the right
        state, r = background_step(state, _noisy(frame, rng), cfg)
    assert r.blobs.is_mvo.sum() == 1
    rows, cols = np.nonzero(r.mvo_labels)
    feet = feet_pca(r.mvo_labels > 0)
    if regrow_legs:
        assert rows.max() == 99 and cols.max() <= x + 11 + 5  # legs back, a little shadow
        assert np.hypot(*(feet.point - [x + 6, 100])) < 2.5
        assert r.fg_shadow[96:99, x + 18 : x + 38].all()
        assert not (r.fg_shadow & (r.mvo_labels > 0)).any()
    else:
        assert rows.max() < 77
        assert feet.point[1] < 77
        if legs == "shadow":
            assert r.fg_shadow[80:95, x + 2 : x + 4].all()
        else:
            assert r.distance[80:95, x + 2 : x + 4].min() > CFG.t_low
            assert not r.candidate[80:95, x + 2 : x + 4].any()


def test_a_walker_leaving_over_the_top_keeps_its_legs_out_of_its_shadow() -> None:
    """'three' seed 0 cam1: a person walking up and out over the top border, legs all there,
    a cast shadow below the feet. Cut by the border, the MVO's top is not the head, and the
    size line (height = 0.25 x feet row + 30) puts the feet 10 px below the true ones: leg
    regrowth took the shadow and the feet landed in it (109 false alarms, precision 0.810).
    Its legs were there while it was below the border: none are grown, and its feet stay
    within 2 px. Met first at that spot (no history), the shadow is grown as legs."""
    # The border cuts the person 7.5 px at feet row 30 (height 37.5 px, top at -7.5).
    rng = np.random.default_rng(9)
    ground = _ground(rng)
    state = _train(ground, rng)
    rows = np.linspace(40.0, 119.0, 60)
    state = dataclasses.replace(state, sizes=SizeModel(np.c_[rows, 0.25 * rows + 30],
                                                       (0.25, 30.0)))

    def frame_at(feet_row: int, legs_lost: bool) -> np.ndarray:
        height = round(0.25 * feet_row + 30)
        frame = ground.astype(np.float64)
        top = feet_row - height
        body = np.clip(np.array([40, 40, 200]) + rng.normal(0, 25, (height, 12, 3)), 0, 255)
        frame[max(top, 0) : feet_row, 40:52] = body[max(-top, 0) :]
        if legs_lost:  # trousers that pass the shadow test from here on
            frame[feet_row - 12 : feet_row, 40:52] = 0.6 * ground[feet_row - 12 : feet_row, 40:52]
        frame[feet_row : feet_row + 12, 42:50] *= 0.6  # the cast shadow, straight below
        return _noisy(frame, rng)

    def last_mvo_bottom(state: BackgroundState, feet_rows: range, lost_from: int = 0
                        ) -> tuple[int, float]:
        for feet_row in feet_rows:
            state, r = background_step(state, frame_at(feet_row, feet_row < lost_from), CFG)
        assert r.blobs.is_mvo.sum() == 1
        return int(np.nonzero(r.mvo_labels)[0].max()), feet_pca(r.mvo_labels > 0).point[1]

    bottom, feet = last_mvo_bottom(state, range(70, 29, -2))  # cut from feet row 39 on
    assert bottom <= 30 and abs(feet - 30) < 2.0
    bottom, feet = last_mvo_bottom(state, range(30, 29, -1))  # first seen there
    assert bottom >= 35
    # 'pillar' seed 0 cam1: legs lost on the way out are grown down to where they last
    # reached (row 35 with the feet at 36), not into the shadow, nor left at the hips
    bottom, feet = last_mvo_bottom(state, range(70, 31, -2), lost_from=35)
    assert bottom == 35


@settings(max_examples=200, deadline=None)
@given(upper=arrays(bool, st.integers(0, 12).map(lambda n: (n, n))))
def test_link_groups_equals_scipy_connected_components(upper: np.ndarray) -> None:
    """The small-graph components the blob grouping and the tracker use: the same count and
    the same numbering as scipy's (components in order of their first node)."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    linked = upper | upper.T
    n, group = link_groups(linked)
    n_ref, ref = connected_components(csr_matrix(linked), directed=False)
    assert n == n_ref and np.array_equal(group, ref)


@settings(max_examples=60, deadline=None)
@given(body=arrays(bool, (9, 13)), shade=arrays(bool, (9, 13)))
def test_grow_down_equals_row_by_row_reachability(body: np.ndarray, shade: np.ndarray) -> None:
    reached = np.zeros_like(shade)
    reached[0] = body[0]
    for r in range(1, len(shade)):
        spread = np.convolve(reached[r - 1].astype(int), [1, 1, 1], "same") > 0
        reached[r] = spread & (shade[r] | body[r])
    assert np.array_equal(_grow_down(body, shade), reached & shade)


def _walker(height: int, rng: np.random.Generator) -> np.ndarray:
    width = max(3, height // 3)
    return np.clip(np.array([40, 40, 200]) + rng.normal(0, 25, (height, width, 3)), 0, 255
                   ).astype(np.uint8)


@pytest.mark.parametrize("size_area_frac, far_found", [(0.15, True), (0.0, False)])
def test_small_far_walker_is_an_mvo_once_the_camera_knows_people_are_small_there(
        size_area_frac: float, far_found: bool) -> None:
    """A walker comes towards the camera (feet from row 50 to 118, height 0.3 x row) and
    teaches the camera how tall people are; then a far walker 12 px tall (area 48 px, below
    T_area 100) appears at row 40 and is an MVO; with one T_area for the frame it is a ghost."""
    rng = np.random.default_rng(6)
    ground = _ground(rng)
    cfg = dataclasses.replace(CFG, size_area_frac=size_area_frac, size_min_samples=20,
                              size_refit_frames=5)
    state = _train(ground, rng, cfg=cfg)
    for t in range(35):
        bottom = 50 + 2 * t
        h = int(0.3 * bottom)
        frame = _paste(ground, _walker(h, rng), 30 + t, bottom - h)
        state, r = background_step(state, _noisy(frame, rng), cfg)
    assert (state.sizes.line is not None) == (size_area_frac > 0)
    far = _walker(12, rng)
    for t in range(4):
        frame = _paste(ground, far, 100 + 3 * t, 40 - 12)
        state, r = background_step(state, _noisy(frame, rng), cfg)
    b = r.blobs
    near_far = b.box_xywh[:, 1] + b.box_xywh[:, 3] < 45
    assert near_far.sum() == 1
    assert bool(b.is_mvo[near_far][0]) == far_found
    assert b.area_px[near_far][0] < b.min_area_px


def test_camera_learns_people_sizes_where_every_walker_is_below_t_area() -> None:
    """In a small frame, people may all be under T_area: none becomes an MVO to learn from.
    Moving person-shaped blobs teach the size model anyway, and then they are MVOs."""
    rng = np.random.default_rng(7)
    ground = _ground(rng)
    cfg = dataclasses.replace(CFG, min_area_px=500, min_area_ref_size_px=0, size_min_samples=20,
                              size_refit_frames=5)
    state = _train(ground, rng, cfg=cfg)
    mvo = []
    for t in range(35):
        bottom = 50 + 2 * t
        h = int(0.3 * bottom)
        frame = _paste(ground, _walker(h, rng), 30 + t, bottom - h)
        state, r = background_step(state, _noisy(frame, rng), cfg)
        walker = r.blobs.area_px > 20
        assert walker.sum() == 1 and r.blobs.area_px[walker][0] < 500
        mvo.append(bool(r.blobs.is_mvo[walker][0]))
    assert state.sizes.line is not None
    assert not any(mvo[:5]) and all(mvo[-10:])


@pytest.mark.parametrize("skip", [True, False])
def test_two_people_walking_one_behind_the_other_teach_no_size(skip: bool) -> None:
    """A walker teaches the camera how tall people are (height 0.3 x feet row). Then two walk
    side by side in depth, first apart, then one partly hidden behind the other: one blob 1.36
    times a person's height and still person-shaped ('tilted' s6 cam0 frames 180-273, boxes
    1.5-1.9 times the truth's: the size line's slope went 0.13 -> 0.26 and the legs regrowth
    grew people into their shadows). With ``size_skip_merged`` the blob that took in two of
    last frame's MVOs, and the blob that follows it while it stays too tall for one person,
    give no size sample; without, they do."""
    rng = np.random.default_rng(8)
    ground = _ground(rng)
    cfg = dataclasses.replace(CFG, size_min_samples=20, size_refit_frames=5,
                              size_skip_merged=skip)
    state = _train(ground, rng, cfg=cfg)
    for t in range(35):
        bottom = 50 + 2 * t
        h = int(0.3 * bottom)
        state, _ = background_step(state, _noisy(_paste(ground, _walker(h, rng), 30 + t,
                                                        bottom - h), rng), cfg)
    assert state.sizes.line is not None
    n_before = len(state.sizes.samples)
    front, back = _walker(33, rng), _walker(22, rng)  # feet at rows 110 and 87 - gap
    for t in range(35):
        gap = max(0, 25 - t)  # the back one's feet are 10 - gap rows below the front one's head
        frame = _paste(ground, back, 80 + t, 87 - gap - 22)
        frame = _paste(frame, front, 84 + t, 110 - 33)
        state, _ = background_step(state, _noisy(frame, rng), cfg)
    new = state.sizes.samples[n_before:]
    assert len(new) > 0
    tall = new[:, 1] > 1.3 * (0.3 * new[:, 0])
    assert (not tall.any()) if skip else tall.sum() >= 10
