"""The pipeline runs the cameras' front ends concurrently: each camera's results must be those
of that camera's front end run alone, one frame after the other; viewer runs keep OpenCV on one
thread."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from test_viz_scene import write_scene_clip

from mvtrack.io import open_clip
from mvtrack.params import Params, load_params
from mvtrack.pipeline import FrameResult, run, train_backgrounds
from mvtrack.stages.background import background_step
from mvtrack.stages.blobtrack import track_masks, tracker_init
from mvtrack.stages.feet import target_feet_records
from mvtrack.viz.session import one_opencv_thread

N_FRAMES = 36


def _params() -> Params:
    return load_params(None, ["background.train_frames=8"])


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_scene_clip(tmp_path_factory.mktemp("conc") / "scene", N_FRAMES)


class _Keep:
    def __init__(self) -> None:
        self.results: list[FrameResult] = []

    def on_frame(self, result: FrameResult) -> None:
        self.results.append(result)


def test_concurrent_front_ends_equal_each_camera_alone(scene: Path) -> None:
    params = _params()
    keep = _Keep()
    with open_clip(scene) as clip:
        frames = range(clip.spec.frame_count)
        run(clip, params, frames, [keep])
        states = train_backgrounds(clip, frames, params)
        images = [fs.images for fs in clip.frames(frames)]
    assert len(keep.results) == N_FRAMES and len(states) == 2
    for name, trained in states.items():
        bg, tracker = trained, tracker_init()
        for result, frame in zip(keep.results, images, strict=True):
            bg, bres = background_step(bg, frame[name], params.background)
            tracker, tracks = track_masks(tracker, bres.mvo_labels, frame[name], params.tracker)
            feet = target_feet_records(tracks, params.feet)
            got = result.cameras[name]
            assert got.background is not None and got.tracks.label_image is not None
            assert np.array_equal(got.background.background_bgr, bres.background_bgr)
            assert np.array_equal(got.background.mvo_labels, bres.mvo_labels)
            assert np.array_equal(got.background.fg_shadow, bres.fg_shadow)
            assert np.array_equal(got.tracks.label_image, tracks.label_image)
            assert np.array_equal(got.tracks.labels, tracks.labels)
            assert np.array_equal(got.targets.feet.reshape(-1, 2),
                                  np.array([f.point for f in feet]).reshape(-1, 2))
    assert sum(len(r.cameras["cam0"].targets) for r in keep.results) > 0  # people were seen
    assert sum(r.stage_ms["background"] for r in keep.results) > 0.0


def test_one_opencv_thread_inside_and_restored_after() -> None:
    before = cv2.getNumThreads()
    with one_opencv_thread():
        assert cv2.getNumThreads() == 1
    assert cv2.getNumThreads() == before
    with pytest.raises(KeyError), one_opencv_thread():
        raise KeyError("x")
    assert cv2.getNumThreads() == before
