"""The camera's vertical learned from its people (mvtrack/stages/vertical.py)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage
from test_feet import _truth_people

from mvtrack.generate import generate_clip
from mvtrack.params import FeetConfig, TrackerConfig
from mvtrack.stages.blobtrack import track_masks, tracker_init
from mvtrack.stages.feet import FeetState, feet_pca, feet_step
from mvtrack.stages.vertical import Verticals, fit_vanishing_point, up_at, vertical_step


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.degrees(np.abs(np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0],
                                        (a * b).sum(axis=1))))


def _noisy_axes(vp: np.ndarray, n: int, sigma_rad: float, seed: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    centres = rng.uniform([0, 0], [320, 240], (n, 2))
    up = up_at(vp, centres)
    turn = rng.normal(0.0, sigma_rad, n)
    c, s = np.cos(turn), np.sin(turn)
    return centres, np.c_[c * up[:, 0] - s * up[:, 1], s * up[:, 0] + c * up[:, 1]]


@pytest.mark.parametrize(
    "vp",
    [
        np.array([170.0, 700.0, 1.0]),  # looking down: verticals fan out from a point below
        np.array([math.sin(math.radians(18)), -math.cos(math.radians(18)), 0.0]),  # rolled,
    ],  # looking horizontally: parallel verticals, a point at infinity
)
def test_fit_recovers_the_vanishing_point_from_noisy_axes(vp: np.ndarray) -> None:
    vp = vp / np.linalg.norm(vp)
    centres, axes = _noisy_axes(vp, 400, math.radians(3), seed=1)
    axes[:40] = [1.0, 0.0]  # a tenth lying flat (blobs that are no people) pull little
    fit = fit_vanishing_point(centres, axes)
    grid = np.stack(np.meshgrid(np.linspace(0, 320, 9), np.linspace(0, 240, 7)), -1).reshape(-1, 2)
    assert _angle_deg(up_at(fit, grid), up_at(vp, grid)).max() < 1.0


def test_up_points_up_the_image_and_is_unit() -> None:
    vp = np.array([160.0, 500.0, 1.0])
    up = up_at(vp, np.array([[10.0, 20.0], [300.0, 200.0], [160.0, 500.0]]))
    np.testing.assert_allclose(np.linalg.norm(up, axis=1), 1.0)
    assert np.all(up[:, 1] < 0)
    assert up[0, 0] < 0 < up[1, 0]  # leaning away from the point below the frame's centre
    np.testing.assert_allclose(up[2], [0.0, -1.0])  # at the point itself: image up


def _person(mask: np.ndarray, foot: tuple[float, float], up: np.ndarray, height: float) -> None:
    """A filled 0.3-height-wide band standing on ``foot`` along ``up``."""
    ys, xs = np.mgrid[: mask.shape[0], : mask.shape[1]]
    rel = np.stack([xs - foot[0], ys - foot[1]], -1)
    along, across = rel @ up, rel @ np.array([-up[1], up[0]])
    mask |= (along >= 0) & (along <= height) & (np.abs(across) <= 0.15 * height)


def test_the_step_learns_from_whole_single_people_only() -> None:
    vp = np.array([160.0, 600.0, 1.0])
    cfg = FeetConfig(vertical_min_samples=6, vertical_refit_frames=3)
    model, state = Verticals(), tracker_init()
    for frame in range(4):
        mask = np.zeros((240, 320), bool)
        for x in (40.0, 120.0, 200.0):
            foot = (x + 3 * frame, 200.0)
            _person(mask, foot, up_at(vp, np.array([foot]))[0], 60.0)
        mask[0:30, 280:290] = True  # touches the top border: not whole
        mask[100:104, 250:300] = True  # lying flat
        state, res = track_masks(state, ndimage.label(mask)[0].astype(np.int32), None,
                                 TrackerConfig())
        model = vertical_step(model, res, cfg)
        assert len(model.centres) == 3 * (frame + 1)
        assert (model.vp is None) == (frame < 1)
    assert model.since_fit == 2  # fitted at frames 1 (six axes), then due again at 4
    grid = np.array([[20.0, 200.0], [300.0, 200.0], [160.0, 20.0]])
    assert _angle_deg(up_at(model.vp, grid), up_at(vp / np.linalg.norm(vp), grid)).max() < 1.5


def test_feet_step_uses_the_vertical_learned_before() -> None:
    vp = np.array([160.0, 600.0, 1.0])
    cfg = FeetConfig(up="learned", vertical_min_samples=3)
    mask = np.zeros((240, 320), bool)
    for x in (40.0, 160.0, 280.0):
        _person(mask, (x, 200.0), up_at(vp, np.array([[x, 200.0]]))[0], 60.0)
    _, res = track_masks(tracker_init(), ndimage.label(mask)[0].astype(np.int32), None,
                         TrackerConfig())
    first_state, first = feet_step(FeetState(), res, cfg)
    assert first_state.verticals.vp is not None
    _, second = feet_step(first_state, res, cfg)
    assert len(feet_step(FeetState(), res, FeetConfig())[0].verticals.centres) == 0  # "pca"
    own = np.array([f.up for f in first])  # each mask's own axis the first frame
    np.testing.assert_allclose(own, [f.up for f in feet_step(FeetState(), res,
                                                              FeetConfig(up="pca"))[1]])
    learned = np.array([f.up for f in second])
    centres = np.array([np.mean(np.argwhere(ndimage.label(mask)[0] == k)[:, ::-1], axis=0)
                        for k in (1, 2, 3)])
    np.testing.assert_allclose(learned, up_at(first_state.verticals.vp, centres), atol=1e-9)


def test_the_learned_vertical_on_a_generated_camera(tmp_path: Path) -> None:
    """'tilted' cam1 (rolled 18 degrees, looking down): the vertical fitted to its people's
    axes is within a degree of the true one where they walk, and the feet along it are nearer
    the truth than along each mask's own axis."""
    clip = generate_clip(tmp_path / "tilted", "tilted", seed=0, frames=100, size=(320, 240),
                         image_format="png")
    cam = json.loads((clip / "truth" / "scene.json").read_text())["cameras"]["cam1"]
    true_vp = np.array(cam["K"]) @ np.array(cam["R_cam_from_world"]) @ [0.0, 0.0, 1.0]
    people = _truth_people(clip, "cam1")
    centres, axes = [], []
    for mask, _ in people:
        f = feet_pca(mask)
        ys, xs = np.nonzero(mask)
        centres.append([xs.mean(), ys.mean()])
        axes.append(f.up)
    vp = fit_vanishing_point(np.array(centres), np.array(axes))
    err = _angle_deg(up_at(vp, np.array(centres)), up_at(true_vp, np.array(centres)))
    assert err.max() < 1.5, err  # 0.8 degrees
    own = np.median([np.linalg.norm(feet_pca(m).point - t) for m, t in people])
    along = np.median([np.linalg.norm(feet_pca(m, vertical_vp=vp).point - t) for m, t in people])
    assert along < 0.8 * own, (along, own)  # 1.1 against 1.8 px
