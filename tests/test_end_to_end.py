"""The whole pipeline as a user runs it on a generated clip: generate, track, eval.

One 600-frame pair clip at 320x240 (the issue targets' clip length), tracked twice: with the
default homography matcher and with the FOV-only baseline (``--matcher fov``); and clips of
other generator seeds and scenarios on which pair learning used to fail. Nothing here uses
ground truth except ``mvtrack eval``. Each bound is a measured value with a margin; the
issue targets that are not met yet are named where the bound is looser than the target.
"""

from __future__ import annotations

import json
from typing import Any

import pytest
from typer.testing import CliRunner

from mvtrack.cli import app

runner = CliRunner()


def _invoke(*args: str) -> None:
    result = runner.invoke(app, list(args))
    assert result.exit_code == 0, result.output


@pytest.fixture(scope="module")
def metrics(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    root = tmp_path_factory.mktemp("e2e")
    clip = root / "pair"
    _invoke("generate", str(clip), "--scenario", "pair", "--frames", "600", "--size", "320x240")
    out = {}
    for matcher in ("homography", "fov"):
        results = root / matcher
        _invoke("track", str(clip), "--out", str(results), "--matcher", matcher)
        _invoke("eval", str(clip), str(results))
        out[matcher] = json.loads((results / "metrics.json").read_text())
    return out


def test_front_end_finds_people_and_their_feet(metrics: dict[str, dict[str, Any]]) -> None:
    """Issue 3's targets: recall and precision >= 0.95, median foot error <= 3 px. Measured:
    recall 0.987 / 0.966, precision 0.966 / 0.960, feet median 2.3 / 1.8 px and p90 5.5 /
    4.5 px (feet per frame, before smoothing over time: 3.1 / 2.4 and 8.3 / 7.2, recall 0.977
    / 0.952, precision 0.958 / 0.962; before legs were grown back below the torso: p90 10.8 /
    12.8; before gray trousers were told from shadow by hue: 16.0 / 19.2)."""
    for cam in metrics["homography"]["cameras"].values():
        assert cam["recall"] >= 0.95 and cam["precision"] >= 0.95, cam
        assert cam["foot_error_px_median"] <= 3.0 and cam["foot_error_px_p90"] <= 7.0, cam
        assert cam["foot_error_px_median"] < 0.85 * cam["foot_error_px_median_per_frame"], cam
        assert cam["foot_error_px_median"] < cam["foot_error_px_median_bbox_baseline"], cam


def test_pair_geometry_is_learned_from_people_walking(
    metrics: dict[str, dict[str, Any]],
) -> None:
    """Issue 4 targets on the pair scenario: a valid H before frame 300 (measured 100),
    transfer error median <= 3 px and p90 <= 8 px (2.6 / 4.4), every learned FOV line with at
    least 40 px of its true segment in view within 5 px (cam1's bottom edge in cam0: 2.2 px).
    Of the other long ones, cam1's left edge sees three events (SPEC §4; the fourth person
    leaves through its bottom-left corner, touching two sides), one short of min_fov_events:
    a leg fragment's 'entry' used to make up the fourth."""
    (pair,) = metrics["homography"]["pairs"]
    assert pair["first_valid_H"] is not None and pair["first_valid_H"]["frame"] < 300
    t = pair["transfer_error_px"]
    assert t["median"] <= 3.0 and t["p90"] <= 8.0, t
    lines = [x for x in pair["fov_lines"] if x["learned"] and x["visible_length_px"] >= 40]
    assert len(lines) >= 1
    assert all(x["error_px_mean"] <= 5.0 for x in lines), lines


def test_homography_matcher_beats_the_fov_baseline(metrics: dict[str, dict[str, Any]]) -> None:
    """Measured, labels resolved over the whole run (tracks.csv): IDF1 0.970 against 0.870 for
    FOV lines alone, consistency 1.0 against 0.787 (the baseline's before feet were smoothed
    over time; issue 5 asks 0.95 / 0.98). As assigned
    online (tracks_online.csv): 0.834 against 0.670, consistency 0.726 against 0.391: people
    in both views from frame 0 cannot share a label online before H exists (frame 100)."""
    h, f = metrics["homography"]["labels"], metrics["fov"]["labels"]
    assert h["idf1_global"] >= f["idf1_global"] + 0.05, (h["idf1_global"], f["idf1_global"])
    assert h["consistency"] >= f["consistency"] + 0.15, (h["consistency"], f["consistency"])
    assert h["idf1_global"] >= 0.95 and h["consistency"] >= 0.98, h
    h, f = metrics["homography"]["labels_online"], metrics["fov"]["labels_online"]
    assert h["idf1_global"] >= f["idf1_global"] + 0.02, (h["idf1_global"], f["idf1_global"])
    assert h["consistency"] >= f["consistency"] + 0.05, (h["consistency"], f["consistency"])
    assert h["idf1_global"] >= 0.78 and h["consistency"] >= 0.65, h


def _generate(tmp_path: Any, scenario: str, seed: int) -> Any:
    """A 600-frame 320x240 clip of ``scenario``."""
    clip = tmp_path / f"{scenario}{seed}"
    _invoke("generate", str(clip), "--scenario", scenario, "--seed", str(seed), "--frames",
            "600", "--size", "320x240")
    return clip


def _track(clip: Any, results: Any, *sets: str) -> dict[str, Any]:
    """metrics.json of `mvtrack track` (with ``--set`` values) and `mvtrack eval` on ``clip``."""
    _invoke("track", str(clip), "--out", str(results), *(a for v in sets for a in ("--set", v)))
    _invoke("eval", str(clip), str(results))
    return json.loads((results / "metrics.json").read_text())


def _track_generated(tmp_path: Any, scenario: str, seed: int) -> dict[str, Any]:
    """metrics.json of `mvtrack track` on a 600-frame 320x240 clip of ``scenario``."""
    return _track(_generate(tmp_path, scenario, seed), tmp_path / "res")


def test_a_clip_with_few_passers_by_still_learns_its_homography(tmp_path: Any) -> None:
    """'tilted' generated with --seed 1: few people are fully inside the rolled camera, and the
    co-motion hypothesis found at frame 315 never sees new candidates of its own target pairs.
    Held for confirmation and then dropped, the pair learned no homography (IDF1 0.547,
    consistency 0.020); accepted once nothing refuted it, it is refitted from markers. So few
    markers make the end result depend on RANSAC's draws, so the test takes the median over
    draws 0-2. Measured: transfer error medians 3.4 / 4.4 / 3.8 px (p90 11.7 / 11.4 / 8.2),
    IDF1 0.969 and consistency 0.986 with each. In cam0 the first person's legs come apart
    from the torso in the steep view (frame 65) and were a second target until frame 113,
    fed by the merge division (consistency 0.946, medians 5.0 / 4.4 / 4.2 px); as a leg part
    of the merged blob for tracker.part_merge_frames frames it is absorbed. In cam1 a person
    leaving by the bottom border while merged with the one behind is such a part too (frame
    80): while the larger template of the two was kept, not the larger in view, the two
    people's labels were swapped (IDF1 0.949). Before fragments taller together than a
    person stopped reuniting: 4.4 / 12.3 / 12.0 px, IDF1 0.951 / 0.951 / 0.831."""
    clip = _generate(tmp_path, "tilted", 1)
    runs = [_track(clip, tmp_path / f"draw{d}", f"homography.ransac_seed={d}") for d in range(3)]
    for m in runs:
        assert m["pairs"][0]["first_valid_H"] is not None, m["pairs"]
    median_px = sorted(m["pairs"][0]["transfer_error_px"]["median"] for m in runs)[1]
    assert median_px <= 5.0, [m["pairs"][0]["transfer_error_px"] for m in runs]
    assert sorted(m["labels"]["idf1_global"] for m in runs)[1] >= 0.95, [m["labels"] for m in runs]
    assert sorted(m["labels"]["consistency"] for m in runs)[1] >= 0.98, [m["labels"] for m in runs]


def test_a_person_whose_legs_match_the_ground_does_not_delay_the_homography(
    tmp_path: Any,
) -> None:
    """'pair' generated with --seed 2: person 5's trousers match the ground, so their blob
    often ends at the knees, 0.4 of their height short, with the feet far off. Pooled for the
    co-motion bootstrap, 8 of that pair's 14 candidates missed even the true H, so only two
    pairs supported it until a fourth person came: the first H at frame 350, IDF1 online 0.713
    (consistency 0.344). Left out while shorter than their recent median, the first H comes at
    frame 175: online 0.802 (0.518). Measured at the end: transfer error 6.3 / 11.8 px (issue 4
    asks 3 / 8: the same person's feet, SPEC §3), IDF1 0.961, consistency 1.0. (Earlier, FOV
    links gave a wrong H that verification dropped; the pool then held four true pairs.)"""
    m = _track_generated(tmp_path, "pair", 2)
    (pair,) = m["pairs"]
    assert pair["first_valid_H"] is not None and pair["first_valid_H"]["frame"] < 300, pair
    assert pair["transfer_error_px"]["median"] <= 10.0, pair["transfer_error_px"]
    assert m["labels"]["idf1_global"] >= 0.95 and m["labels"]["consistency"] >= 0.98, m["labels"]
    assert m["labels_online"]["idf1_global"] >= 0.77, m["labels_online"]


def test_a_pair_that_sees_three_people_in_a_clip_learns_its_homography(tmp_path: Any) -> None:
    """'three' generated with --seed 4: cam0 and cam2 share three people in 600 frames, one at
    a time (frames 0-20, 185-235, 470-545), and no FOV line. The co-motion hypothesis that all
    three follow can be found only once the third has walked by (frame 500), and nobody comes
    after to confirm it. Held for 100 frames before it was accepted, it never was: no H for the
    pair, whose labels agreed in 0.53 of the frames (IDF1 0.922). Accepted 50 frames after it
    was found, at 550: measured consistency 1.0 (both pairs), IDF1 0.978."""
    m = _track_generated(tmp_path, "three", 4)
    pair = next(p for p in m["pairs"] if p["cameras"] == ["cam0", "cam2"])
    assert pair["first_valid_H"] is not None, pair
    by_pair = m["labels"]["consistency_by_pair"]
    assert by_pair["cam0-cam2"]["consistency"] >= 0.95, by_pair
    assert m["labels"]["consistency"] >= 0.95, m["labels"]
    assert m["labels"]["idf1_global"] >= 0.95, m["labels"]
