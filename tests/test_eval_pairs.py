"""evaluate.pairs: learned homography and FOV lines against truth/ground.json, hand-built."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mvtrack.evaluate.pairs import (
    border_points,
    fov_segment,
    line_error_px,
    pair_metrics,
    pairs_metrics_for_results,
    true_H_b_from_a,
)
from mvtrack.io import read_truth

SIZE = (320, 240)
# Two downward-looking cameras over the ground (metres): B is A shifted by 4 m in x, so the
# true H_b_from_a is a pure translation by -4 m * 20 px/m = -80 px in x.
G_A = np.array([[20.0, 0.0, 160.0], [0.0, 20.0, 120.0], [0.0, 0.0, 1.0]])
G_B = np.array([[20.0, 0.0, 80.0], [0.0, 20.0, 120.0], [0.0, 0.0, 1.0]])
SHIFT = np.array([[1.0, 0.0, -80.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def _write_truth(root: Path, feet_a: np.ndarray) -> None:
    truth = root / "truth"
    truth.mkdir(parents=True)
    ground = {"units": "m", "cameras": {"a": {"image_from_ground": G_A.tolist()},
                                        "b": {"image_from_ground": G_B.tolist()}}}
    (truth / "ground.json").write_text(json.dumps(ground))
    header = "frame,person,foot_x,foot_y,box_x,box_y,box_w,box_h,visible\n"
    for cam, shift in (("a", 0.0), ("b", -80.0)):
        rows = [f"{f},1,{x + shift},{y},{x + shift - 5},{y - 30},10,30,1"
                for f, (x, y) in enumerate(feet_a)]
        (truth / f"{cam}.csv").write_text(header + "\n".join(rows) + "\n")


def _pair(H: np.ndarray | None, lines: list[dict]) -> dict:
    return {"cameras": ["a", "b"], "H": None if H is None else H.tolist(), "H_from_frame": 7,
            "markers": 12, "fov_events": 9, "fov_lines": lines, "sizes": [list(SIZE)] * 2,
            "H_first": {"frame": 7, "markers": 10, "markers_dropped": 11, "fov_events": 5}}


@pytest.fixture
def truth(tmp_path: Path):  # type: ignore[no-untyped-def]
    feet = np.c_[np.linspace(100, 300, 50), np.linspace(40, 200, 50)]  # x >= 80: seen by both
    _write_truth(tmp_path, feet)
    t = read_truth(tmp_path)
    assert t is not None
    return t


def test_true_homography_and_border_images() -> None:
    assert np.allclose(true_H_b_from_a(G_A, G_B), SHIFT)
    # B's left border (x = -0.5 in B) is x = 79.5 in A, all of its height inside A.
    seg = fov_segment(G_A, G_B, (SIZE, SIZE), "left")
    assert seg is not None
    assert np.allclose(seg[:, 0], 79.5) and np.isclose(abs(seg[1, 1] - seg[0, 1]), 240.0)
    # B's right border is at x = 399.5 in A: outside A's frame, nothing visible.
    assert fov_segment(G_A, G_B, (SIZE, SIZE), "right") is None
    assert border_points(SIZE, "bottom")[:, 1].max() == 239.5
    with pytest.raises(ValueError, match="side"):
        border_points(SIZE, "middle")


def test_line_error_is_the_mean_and_max_distance() -> None:
    seg = np.array([[0.0, 0.0], [0.0, 100.0]])
    assert line_error_px(seg, [1.0, 0.0, 0.0]) == pytest.approx((0.0, 0.0))
    assert line_error_px(seg, [1.0, 0.0, -3.0]) == pytest.approx((3.0, 3.0))
    tilted = np.array([1.0, 0.01, -2.0]) / np.hypot(1.0, 0.01)  # 2 px at y=0, 1 px at y=100
    mean, worst = line_error_px(seg, tilted)
    assert mean == pytest.approx(1.5 / np.hypot(1.0, 0.01)) and worst == pytest.approx(
        2.0 / np.hypot(1.0, 0.01))


def test_exact_geometry_scores_zero_and_offsets_score_their_size(truth) -> None:  # type: ignore[no-untyped-def]
    lines = [
        {"seen_in": "a", "edge_of": "b", "side": "left", "line": [1.0, 0.0, -79.5],
         "events": 6, "from_frame": 3},
        {"seen_in": "b", "edge_of": "a", "side": "right", "line": [1.0, 0.0, -(239.5 + 4.0)],
         "events": 5, "from_frame": 4},
    ]
    (m,) = pair_metrics(truth, [_pair(SHIFT, lines)])
    assert m["points_from"] == "truth_feet" and m["transfer_error_px"]["points"] == 50
    assert m["transfer_error_px"]["max"] < 1e-9
    by_side = {(x["seen_in"], x["side"]): x for x in m["fov_lines"]}
    assert by_side[("a", "left")]["error_px_mean"] == pytest.approx(0.0, abs=1e-9)
    # A's right border (x = 319.5) is x = 239.5 in B; the learned line is 4 px off.
    assert by_side[("b", "right")]["error_px_mean"] == pytest.approx(4.0)
    assert m["fov_line_error_px_mean_worst"] == pytest.approx(4.0)
    # Visible true lines without a learned one are listed as not learned.
    assert by_side[("a", "bottom")]["learned"] is False
    assert by_side[("a", "bottom")]["error_px_mean"] is None
    assert ("a", "right") not in by_side  # not visible, not learned: not listed
    assert m["first_valid_H"] == {"frame": 7, "markers": 10, "markers_dropped": 11,
                                  "fov_events": 5}


def test_a_wrong_homography_gives_its_transfer_error(truth) -> None:  # type: ignore[no-untyped-def]
    off = SHIFT.copy()
    off[0, 2] += 6.0  # 6 px too far right in B: 6 px forward, 6 px back
    (m,) = pair_metrics(truth, [_pair(off, [])])
    t = m["transfer_error_px"]
    assert t["median"] == pytest.approx(6.0) and t["p90"] == pytest.approx(6.0)
    (none,) = pair_metrics(truth, [_pair(None, [])])
    assert none["transfer_error_px"]["median"] is None
    assert "whole_run_transfer_error_px" not in m | none


def test_the_whole_run_h_of_a_pair_without_h_is_scored(truth) -> None:  # type: ignore[no-untyped-def]
    off = SHIFT.copy()
    off[1, 2] -= 4.0
    pair = _pair(None, []) | {"H_whole_run": {"H": off.tolist(), "links": [], "used": True}}
    (m,) = pair_metrics(truth, [pair])
    assert m["transfer_error_px"]["median"] is None
    assert m["whole_run_transfer_error_px"]["median"] == pytest.approx(4.0)


def test_the_refit_h_and_its_lines_are_scored_beside_the_runs(truth) -> None:  # type: ignore[no-untyped-def]
    """The run's H and its line of A's right border in B are 4 px off; the refit's are exact;
    the lines handed on are the refit's, the whole-run H's (2 px off) or the run's."""
    off = SHIFT.copy()
    off[0, 2] += 4.0
    line = {"seen_in": "b", "edge_of": "a", "side": "right", "events": 5, "from_frame": 4}
    pair = _pair(off, [line | {"line": [1.0, 0.0, -(239.5 + 4.0)]}]) | {"H_refit": {
        "H": SHIFT.tolist(), "used": True, "fov_lines": [line | {"line": [1.0, 0.0, -239.5]}]}}
    (m,) = pair_metrics(truth, [pair])
    assert m["transfer_error_px"]["median"] == pytest.approx(4.0)
    assert m["refit_transfer_error_px"]["max"] < 1e-9 and m["refit_h_used"]
    (scored,) = [x for x in m["fov_lines"] if x["learned"]]
    assert scored["error_px_mean"] == pytest.approx(4.0)
    assert scored["refit_error_px_mean"] == pytest.approx(0.0, abs=1e-9)
    assert m["refit_fov_line_error_px_mean_worst"] == pytest.approx(0.0, abs=1e-9)
    assert scored["handed_on_error_px_mean"] == pytest.approx(0.0, abs=1e-9)  # the refit's
    # Handed on: the whole-run H's lines where the labels used it, else the run's own.
    whole_run = {"H": SHIFT.tolist(), "used": True,
                 "fov_lines": [line | {"line": [1.0, 0.0, -(239.5 - 2.0)]}]}
    for used, want in ((True, 2.0), (False, 4.0)):
        other = pair | {"H_refit": pair["H_refit"] | {"used": False},
                        "H_whole_run": whole_run | {"used": used}}
        (m,) = pair_metrics(truth, [other])
        (scored,) = [x for x in m["fov_lines"] if x["learned"]]
        assert scored["handed_on_error_px_mean"] == pytest.approx(want)
        assert m["handed_on_fov_line_error_px_mean_worst"] == pytest.approx(want)


def test_the_h_handed_on_is_the_refit_else_the_whole_run_h_the_labels_used(truth) -> None:  # type: ignore[no-untyped-def]
    def off_by(dx: float) -> list:
        H = SHIFT.copy()
        H[0, 2] += dx
        return H.tolist()

    pair = _pair(np.array(off_by(20.0)), []) | {
        "H_whole_run": {"H": off_by(5.0), "used": True},
        "H_refit": {"H": off_by(9.0), "used": False}}

    def end_p90(p: dict) -> float:
        (m,) = pair_metrics(truth, [p])
        return m["handed_on_transfer_error_px"]["p90"]

    assert end_p90(pair) == pytest.approx(5.0)
    assert end_p90(pair | {"H_refit": {"H": off_by(9.0), "used": True}}) == pytest.approx(9.0)
    assert end_p90(pair | {"H_whole_run": {"H": off_by(5.0), "used": False}}) == pytest.approx(20.0)


def test_grid_points_when_nobody_is_seen_by_both(tmp_path: Path) -> None:
    _write_truth(tmp_path, np.array([[20.0, 100.0]]))  # only A sees it (x < 80)
    t = read_truth(tmp_path)
    assert t is not None
    (m,) = pair_metrics(t, [_pair(SHIFT, [])])
    assert m["points_from"] == "grid" and m["transfer_error_px"]["points"] > 100


def test_results_folder_and_missing_sizes(tmp_path: Path) -> None:
    _write_truth(tmp_path, np.c_[np.linspace(100, 300, 5), np.full(5, 100.0)])
    t = read_truth(tmp_path)
    assert t is not None
    results = tmp_path / "results"
    results.mkdir()
    assert pairs_metrics_for_results(tmp_path, results, t) is None  # no pairs.json
    pair = _pair(SHIFT, [])
    del pair["sizes"]
    with pytest.raises(ValueError, match="sizes"):
        pair_metrics(t, [pair])
    (m,) = pair_metrics(t, [pair], {"a": SIZE, "b": SIZE})
    assert m["transfer_error_px"]["max"] < 1e-9
    (results / "pairs.json").write_text(json.dumps([_pair(SHIFT, [])]))
    got = pairs_metrics_for_results(tmp_path, results, t)
    assert got is not None and got[0]["cameras"] == ["a", "b"]
    # A pair whose cameras have no true G is skipped.
    other = _pair(SHIFT, []) | {"cameras": ["a", "zz"]}
    assert pair_metrics(t, [other]) == []
