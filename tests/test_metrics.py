"""Evaluation figures on hand-made rows where the right answer is known."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mvtrack.evaluate.metrics import (
    FrameRows,
    MaskScores,
    detection_scores,
    error_causes,
    frame_matches,
    idf1,
    mask_scores,
    match_all,
)


def truth_two_people(frames: int = 10) -> FrameRows:
    f = np.repeat(np.arange(frames), 2)
    ids = np.tile([1, 2], frames)
    feet = np.stack([np.where(ids == 1, 50.0, 150.0), np.full(len(f), 100.0)], axis=1)
    return FrameRows.of(f, ids, feet, heights=np.full(len(f), 40.0))


def test_perfect_predictions_score_one() -> None:
    truth = truth_two_people()
    pred = FrameRows.of(truth.frames, truth.ids + 10, truth.feet + [1.0, 0.0])
    det = detection_scores(pred, truth)
    assert det["recall"] == det["precision"] == 1.0
    assert det["foot_error_px_median"] == pytest.approx(1.0)
    assert det["foot_error_height_median"] == pytest.approx(1 / 40)
    assert idf1(pred, truth)["idf1"] == 1.0


def test_gate_is_in_heights() -> None:
    truth = truth_two_people(1)
    far = FrameRows.of([0], [7], [[50.0, 121.0]])  # 21 px away, gate 0.5 * 40 = 20 px
    near = FrameRows.of([0], [7], [[50.0, 119.0]])
    assert detection_scores(far, truth)["recall"] == 0.0
    assert detection_scores(near, truth)["recall"] == 0.5
    assert detection_scores(near, truth)["precision"] == 1.0


def test_id_swap_halfway_halves_idf1() -> None:
    truth = truth_two_people(10)
    ids = truth.ids.copy()
    ids[truth.frames >= 5] = 3 - ids[truth.frames >= 5]  # labels swap at frame 5
    pred = FrameRows.of(truth.frames, ids, truth.feet)
    assert detection_scores(pred, truth)["recall"] == 1.0
    assert idf1(pred, truth)["idf1"] == pytest.approx(0.5)


def test_what_idf1_lacks_splits_into_detection_and_identity_losses() -> None:
    """Two people for 10 frames (40 rows with the predictions). Person 1's label swaps with
    person 2's for frames 8-9 (4 matched rows under the other id) and person 2 is missed in
    frames 0-2 (3 truth rows unmatched), plus one phantom (1 prediction unmatched): IDF1 =
    2 x 13 / 38, identity loss 2 x 4 / 38, detection loss 4 / 38, the three summing to 1."""
    truth = truth_two_people(10)
    keep = ~((truth.ids == 2) & (truth.frames <= 2))
    ids = truth.ids[keep].copy()
    frames, feet = truth.frames[keep], truth.feet[keep]
    late = frames >= 8
    ids[late] = 3 - ids[late]
    pred = FrameRows.of(np.r_[frames, 5], np.r_[ids, 7], np.r_[feet, [[150.0, 20.0]]])
    s = idf1(pred, truth)
    counted = 20 + 18
    assert s["idtp"] == 13.0
    assert s["idf1"] == pytest.approx(2 * 13 / counted)
    assert s["loss_identity"] == pytest.approx(2 * 4 / counted)
    assert s["loss_detection"] == pytest.approx((3 + 1) / counted)
    assert s["idf1"] + s["loss_identity"] + s["loss_detection"] == pytest.approx(1.0)


def test_fragmented_track_counts_only_longest_piece() -> None:
    truth = truth_two_people(10)
    ids = truth.ids.copy()
    ids[(truth.ids == 1) & (truth.frames >= 8)] = 99  # person 1 relabelled for 2 of 10 frames
    assert idf1(FrameRows.of(truth.frames, ids, truth.feet), truth)["idf1"] == pytest.approx(0.9)


def test_hardly_visible_truth_is_dont_care() -> None:
    truth = truth_two_people(4)
    vis = np.where(truth.ids == 2, 0.2, 1.0)
    truth = FrameRows.of(truth.frames, truth.ids, truth.feet, truth.heights, vis)
    only_one = truth.ids == 1
    pred_one = FrameRows.of(truth.frames[only_one], truth.ids[only_one], truth.feet[only_one])
    pred_all = FrameRows.of(truth.frames, truth.ids, truth.feet)
    for pred in (pred_one, pred_all):
        det = detection_scores(pred, truth)
        assert (det["recall"], det["precision"]) == (1.0, 1.0)


def test_prediction_on_a_person_cut_by_the_frame_edge_is_dont_care() -> None:
    """Person 2 is mostly below the frame: its feet (y 300) are outside, its visible box is
    the frame's bottom rows. A prediction with feet at the frame's bottom edge inside that box
    is not a false alarm; the same prediction beside the box is."""
    truth = truth_two_people(4)
    two = truth.ids == 2
    feet = np.where(two[:, None], [[100.0, 300.0]], truth.feet)
    boxes = np.where(two[:, None], [[90.0, 220.0, 20.0, 20.0]], [[0.0, 0.0, 1.0, 1.0]])
    truth = FrameRows.of(truth.frames, truth.ids, feet, truth.heights,
                         np.where(two, 0.2, 1.0), boxes)
    for x, precision in ((100.0, 1.0), (150.0, 0.5)):
        pred = FrameRows.of(truth.frames, truth.ids,
                            np.where(two[:, None], [[x, 239.0]], truth.feet))
        det = detection_scores(pred, truth)
        assert (det["recall"], det["precision"]) == (1.0, precision), x


def test_false_alarms_lower_precision() -> None:
    truth = truth_two_people(4)
    extra = FrameRows.of(
        np.concatenate([truth.frames, [0, 1]]),
        np.concatenate([truth.ids, [5, 5]]),
        np.concatenate([truth.feet, [[300.0, 10.0], [300.0, 10.0]]]),
    )
    assert detection_scores(extra, truth)["precision"] == pytest.approx(8 / 10)


def test_recall_of_people_cut_by_the_frame_edge() -> None:
    """Four counted people, two of them partly outside the frame, one of those missed; a
    hardly visible cut person counts in neither figure."""
    truth = FrameRows.of([0] * 5, range(5), [(50, 100), (150, 100), (250, 20), (350, 15),
                                             (450, 10)], np.full(5, 40.0),
                         [1, 1, 0.7, 0.6, 0.3])
    truth = replace(truth, in_frame=np.array([1, 1, 0.7, 0.6, 0.3]))
    pred = FrameRows.of([0] * 3, range(3), [(50, 100), (150, 100), (250, 20)])
    det = detection_scores(pred, truth)
    assert det["recall"] == pytest.approx(3 / 4)
    assert det["truth_rows_cut_by_frame"] == 2
    assert det["recall_cut_by_frame"] == pytest.approx(1 / 2)
    assert np.isnan(detection_scores(pred, FrameRows.of([0], [0], [(50, 100)], [40.0]))[
        "recall_cut_by_frame"])


def test_error_causes_sort_each_false_alarm_and_miss() -> None:
    """One frame, people 40 px tall (gate 20 px), one of each cause; a prediction on a hardly
    visible person is don't care and counts in none."""
    people = {1: (50, 100), 2: (150, 100), 3: (250, 100), 4: (250, 75), 5: (350, 100),
              6: (450, 100)}
    truth = FrameRows.of([0] * 6, list(people), list(people.values()), np.full(6, 40.0),
                         [1, 1, 1, 1, 1, 0.2])
    predictions = [
        (50, 100),  # on person 1
        (50, 85),  # person 1 again, a torso tracked apart: duplicate
        (150, 70),  # person 2's target, 30 px above the feet: displaced (and 2 is missed)
        (250, 100),  # on person 3; person 4 stands 25 px behind, in this target: taken
        (600, 10),  # nobody there: phantom
        (450, 99),  # on the hardly visible person 6: don't care
    ]  # person 5: undetected
    pred = FrameRows.of([0] * 6, range(6), predictions)
    det = detection_scores(pred, truth)
    assert {k: det[k] for k in det if k.startswith(("false_alarm", "miss"))} == {
        "false_alarm_duplicate": 1, "false_alarm_displaced": 1, "false_alarm_phantom": 1,
        "miss_displaced": 1, "miss_taken": 1, "miss_undetected": 1}
    assert det["predicted_rows"] - det["matches"] == 3
    assert det["truth_rows"] - det["matches"] == 3
    # nearer than near_heights = 0.5 only the duplicate is someone's; misses are undetected
    m = match_all(pred, truth, 0.5, 0.5)
    tight = error_causes(pred, truth, m, near_heights=0.5)
    assert (tight["false_alarm_displaced"], tight["false_alarm_phantom"]) == (0, 2)
    assert (tight["miss_displaced"], tight["miss_taken"], tight["miss_undetected"]) == (0, 0, 3)


@pytest.mark.parametrize("n_pred,n_true", [(0, 0), (0, 3), (3, 0)])
def test_frame_matches_empty(n_pred: int, n_true: int) -> None:
    i, j = frame_matches(np.zeros((n_pred, 2)), np.zeros((n_true, 2)), np.ones(n_true), 0.5)
    assert len(i) == len(j) == 0


def test_empty_rows_give_nan_not_errors() -> None:
    empty = FrameRows.of([], [], np.zeros((0, 2)))
    assert np.isnan(detection_scores(empty, empty)["recall"])
    assert np.isnan(idf1(empty, empty)["idf1"])


def test_mask_scores() -> None:
    truth = np.zeros((4, 6), np.uint8)
    truth[0:2, 0:2] = 1  # 4 person pixels
    truth[2:4, 0:3] = 2  # 6 shadow pixels
    pred = np.zeros_like(truth)
    pred[0:2, 0:1] = 1  # 2 of 4 person pixels found
    pred[0, 1] = 2  # one person pixel wrongly called shadow
    pred[2, 0:3] = 2  # 3 of 6 shadow pixels detected
    pred[3, 0] = 1  # a shadow pixel in the foreground
    s = (mask_scores(pred, truth) + MaskScores()).summary()
    assert s["fg_recall"] == pytest.approx(2 / 4)
    assert s["fg_precision"] == pytest.approx(2 / 3)
    assert s["shadow_detection"] == pytest.approx(3 / 6)
    assert s["shadow_discrimination"] == pytest.approx(3 / 4)
    assert s["shadow_kept_out"] == pytest.approx(5 / 6)


def test_foot_error_along_motion_tells_feet_that_trail_the_walker() -> None:
    """Feet one frame behind a walker (1.5 px per frame, rightwards, then back leftwards) are
    1.5 px behind along the motion, whichever way it goes; a person standing still does not
    count; feet ahead count positive."""
    f = np.arange(40)
    x = np.where(f < 20, 100 + 1.5 * f, 130 - 1.5 * (f - 20))
    walker = np.c_[x, np.full(40, 80.0)]
    still = np.tile([[200.0, 80.0]], (40, 1))
    truth = FrameRows.of(np.r_[f, f], np.r_[np.ones(40), np.full(40, 2)], np.r_[walker, still],
                         heights=np.full(80, 40.0))
    lag = np.r_[walker[:1], walker[:-1]]  # each frame's feet where the walker was before
    pred = FrameRows.of(np.r_[f, f], np.r_[np.full(40, 7), np.full(40, 8)],
                        np.r_[lag, still + [0.0, 3.0]])
    det = detection_scores(pred, truth)
    # frame 20 (it turns: back where it was 2 frames before 2 frames later) and the first and
    # last two (not in the truth 2 frames before or after) have no direction of motion
    assert det["foot_error_along_motion_matches"] == 40 - 1 - 4
    assert det["foot_error_px_along_motion_median"] == pytest.approx(-1.5)
    ahead = FrameRows.of(pred.frames, pred.ids, np.r_[walker + [[1.0, 0.0]], still])
    assert detection_scores(ahead, truth)["foot_error_px_along_motion_median"] == pytest.approx(
        1.0)
    assert np.isnan(detection_scores(FrameRows.of(f, np.ones(40), still), truth)[
        "foot_error_px_along_motion_median"])
