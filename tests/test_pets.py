"""Reading the real PETS 2009 S2L1 clip that ``shared/data/pets2009-s2l1/to_clip.py`` writes.

Skips with a stated reason when the shared data is absent (see conftest.py). Expected numbers
come from shared/data/pets2009-s2l1/README.md.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from mvtrack.io import open_clip, read_detections_csv, read_truth

VIEWS = ["View_001", "View_003", "View_004", "View_005", "View_006", "View_007", "View_008"]
CONFIDENT = {  # README: detections with score >= 0.5 (to_clip's default --min-score)
    "View_003": 5503,
    "View_004": 5835,
    "View_005": 3102,
    "View_006": 3107,
    "View_007": 5672,
    "View_008": 4158,
}


def test_pets_clip_spec(pets_clip):
    spec = open_clip(pets_clip).spec
    assert [c.name for c in spec.cameras] == VIEWS
    assert spec.fps == 7.0  # clip.toml overrides the AVI's 10 fps
    v1 = spec.camera("View_001")
    assert (v1.kind, v1.size, v1.length, v1.offset) == ("video", (768, 576), 795, 0)
    assert v1.source.name == "View_001.avi" and v1.source.is_symlink()
    sizes = {c.name: c.size for c in spec.cameras if c.kind == "detections"}
    assert sizes == {
        v: (768, 576) if v in ("View_003", "View_004") else (720, 576) for v in VIEWS[1:]
    }
    assert spec.frame_count == 795 and spec.warnings == ()
    assert len(spec.overlaps) == 21  # no [[overlap]]: every pair
    assert spec.truth_dir == pets_clip / "truth"


def test_pets_video_header_count_is_true(pets_clip):
    """View_001.avi (MP43): every one of the 795 frames the header claims decodes."""
    with open_clip(pets_clip, cameras=["View_001"]) as clip:
        n = 0
        for fs in clip.frames():
            assert fs.index == n and fs.images["View_001"].shape == (576, 768, 3)
            n += 1
        assert n == 795 and clip.warnings == ()


def test_pets_range_starts_at_the_right_frame(pets_clip):
    cap = cv2.VideoCapture(str(pets_clip / "View_001.avi"))
    for _ in range(400):
        cap.grab()
    ok, frame400 = cap.read()
    cap.release()
    assert ok
    with open_clip(pets_clip, cameras=["View_001", "View_005"]) as clip:
        fs = next(iter(clip.frames(range(400, 795))))
    assert fs.index == 400
    np.testing.assert_array_equal(fs.images["View_001"], frame400)
    expected = read_detections_csv(pets_clip / "detections" / "View_005.csv")[400]
    np.testing.assert_array_equal(fs.detections["View_005"].boxes_xywh, expected.boxes_xywh)


def test_pets_detections_count(pets_clip):
    with open_clip(pets_clip, cameras=list(CONFIDENT)) as clip:
        assert clip.spec.frame_count == 795
        counts = dict.fromkeys(CONFIDENT, 0)
        for fs in clip.frames():
            assert fs.images == {}
            for name, dets in fs.detections.items():
                counts[name] += len(dets)
                assert (dets.scores >= 0.5).all() and np.isnan(dets.feet).all()
                assert (dets.tracks == -1).all()
    assert counts == CONFIDENT


def _join(a_frame, a_person, b_frame, b_person):
    """Row indices (ia, ib) where (frame, person) agree."""
    key_a = a_frame * 1000 + a_person
    key_b = b_frame * 1000 + b_person
    _, ia, ib = np.intersect1d(key_a, key_b, return_indices=True)
    return ia, ib


@pytest.mark.parametrize(("view", "median_px"), [("View_001", 4.0), ("View_004", 1.0)])
def test_pets_truth_is_consistent(pets_clip, view, median_px):
    """World positions through image_from_ground land on the camera truth's feet.

    README: View_001's feet are the gt boxes' bottom centres (pinhole median 2.2 px away);
    View_004's are the full-model projection, which its fitted H matches to 0.1 px.
    """
    truth = read_truth(pets_clip)
    assert truth is not None and truth.units == "m"
    assert sorted(truth.cameras) == VIEWS and sorted(truth.image_from_ground) == VIEWS
    assert truth.world is not None and len(truth.world) == 4650
    assert len(truth.cameras["View_001"]) == 4650
    assert np.unique(truth.world.person).size == 19
    cam = truth.cameras[view]
    ia, ib = _join(truth.world.frame, truth.world.person, cam.frame, cam.person)
    assert ib.size == len(cam)  # every camera row has a world position
    xy1 = np.c_[truth.world.xy[ia], np.ones(ia.size)]
    img = xy1 @ truth.image_from_ground[view].T
    err = np.linalg.norm(img[:, :2] / img[:, 2:] - cam.foot[ib], axis=1)
    assert np.median(err) < median_px
