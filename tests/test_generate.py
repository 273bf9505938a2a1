"""The scene generator: clips are readable, truth is exact, scenarios do what they promise."""

from __future__ import annotations

import csv
import json
import math
import tomllib
from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mvtrack.generate import MASK_EVERY_FRAMES, SCENARIOS, generate_clip
from mvtrack.generate.camera import CameraSpec, look_at
from mvtrack.generate.world import make_path

SIZE = (320, 240)
FRAMES = 80
CAMERA_HEADER = "frame,person,foot_x,foot_y,box_x,box_y,box_w,box_h,visible,in_frame"
ALL = sorted(SCENARIOS)


@pytest.fixture(scope="module")
def clips(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Every scenario once, small: 'pair' as PNG frames (lossless), the rest as mp4."""
    root = tmp_path_factory.mktemp("clips")
    out = {}
    for name in ALL:
        fmt = "png" if name == "pair" else "mp4"
        out[name] = generate_clip(root / name, name, seed=1, frames=FRAMES, size=SIZE,
                                  image_format=fmt)
    return out


def rows(clip: Path, camera: str) -> list[dict[str, float]]:
    with open(clip / "truth" / f"{camera}.csv") as f:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]


def cameras(clip: Path) -> list[dict[str, object]]:
    return tomllib.loads((clip / "clip.toml").read_text())["camera"]


def frames_of(clip: Path, cam: dict[str, object]) -> list[np.ndarray]:
    src = clip / str(cam["source"])
    if src.is_dir():
        return [cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in sorted(src.iterdir())]
    cap = cv2.VideoCapture(str(src))
    out = []
    while True:
        ok, img = cap.read()
        if not ok:
            return out
        out.append(img)


def by_frame(table: list[dict[str, float]]) -> dict[int, list[dict[str, float]]]:
    out: dict[int, list[dict[str, float]]] = defaultdict(list)
    for r in table:
        out[int(r["frame"])].append(r)
    return out


# --------------------------------------------------------------------------- arguments


@pytest.mark.parametrize(
    ("kwargs", "named"),
    [
        ({"scenario": "nope"}, "nope"),
        ({"frames": 0}, "0"),
        ({"seed": -3}, "-3"),
        ({"size": (320,)}, "(320,)"),
        ({"size": (31, 240)}, "(31, 240)"),
        ({"size": (321, 240)}, "(321, 240)"),
        ({"image_format": "gif"}, "gif"),
    ],
)
def test_bad_arguments_are_named(tmp_path: Path, kwargs: dict[str, object], named: str) -> None:
    args: dict[str, object] = {"scenario": "pair", "frames": 5, "size": SIZE, **kwargs}
    with pytest.raises(ValueError, match=named.replace("(", r"\(").replace(")", r"\)")):
        generate_clip(tmp_path / "clip", **args)  # type: ignore[arg-type]
    assert not (tmp_path / "clip").exists()


def test_existing_non_empty_out_dir_is_refused(tmp_path: Path) -> None:
    (tmp_path / "keep.txt").write_text("mine")
    with pytest.raises(ValueError, match="out_dir"):
        generate_clip(tmp_path, "pair", frames=2, size=SIZE)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]


def test_scenarios_are_the_issue_list_with_one_line_summaries() -> None:
    assert set(SCENARIOS) == {"pair", "one_edge", "pillar", "doors", "tilted", "gray", "crowd",
                              "three"}
    for s in SCENARIOS.values():
        assert s.summary and "\n" not in s.summary


def test_progress_reports_every_frame(tmp_path: Path) -> None:
    calls: list[tuple[int, int]] = []
    generate_clip(tmp_path / "c", "pair", frames=3, size=(96, 72),
                  progress=lambda d, t: calls.append((d, t)))
    assert calls == [(1, 3), (2, 3), (3, 3)]


def test_jpg_frames_and_a_single_channel_gray_camera(tmp_path: Path) -> None:
    clip = generate_clip(tmp_path / "c", "gray", frames=3, size=(96, 72), image_format="jpg")
    assert sorted(p.name for p in (clip / "cam0").iterdir()) == [
        "000000.jpg", "000001.jpg", "000002.jpg"
    ]
    gray = cv2.imread(str(clip / "cam1" / "000002.jpg"), cv2.IMREAD_UNCHANGED)
    assert gray.ndim == 2 and gray.shape == (54, 72)
    assert 'source = "cam1"' in (clip / "clip.toml").read_text()


# --------------------------------------------------------------------------- readable clips


@pytest.mark.parametrize("name", ALL)
def test_clip_is_readable_per_formats(clips: dict[str, Path], name: str) -> None:
    clip = clips[name]
    manifest = tomllib.loads((clip / "clip.toml").read_text())
    assert manifest["fps"] == 25.0
    scene = json.loads((clip / "truth" / "scene.json").read_text())
    ground = json.loads((clip / "truth" / "ground.json").read_text())
    assert ground["units"] == "m"
    for cam in manifest["camera"]:
        assert cam["offset"] == 0
        assert cam["modality"] == ("gray" if (name, cam["name"]) == ("gray", "cam1") else "rgb")
        imgs = frames_of(clip, cam)
        w, h = scene["cameras"][cam["name"]]["size"]
        assert len(imgs) == FRAMES
        assert imgs[0].shape[:2] == (h, w)
        H = np.array(ground["cameras"][cam["name"]]["image_from_ground"])
        assert H.shape == (3, 3)
        header = (clip / "truth" / f"{cam['name']}.csv").read_text().splitlines()[0]
        assert header == CAMERA_HEADER
        masks = sorted((clip / "truth" / "masks" / cam["name"]).iterdir())
        assert [m.name for m in masks] == [
            f"{f:06d}.png" for f in range(0, FRAMES, MASK_EVERY_FRAMES)
        ]
    assert (clip / "truth" / "world.csv").read_text().splitlines()[0] == "frame,person,x,y"
    pairs = {tuple(o["cameras"]) for o in manifest.get("overlap", [])}
    assert pairs == {tuple(p) for p in scene["overlaps"]}


def test_three_declares_only_the_overlapping_pairs(clips: dict[str, Path]) -> None:
    manifest = tomllib.loads((clips["three"] / "clip.toml").read_text())
    assert {tuple(o["cameras"]) for o in manifest["overlap"]} == {("cam0", "cam2"),
                                                                  ("cam1", "cam2")}


# --------------------------------------------------------------------------- truth is right


@pytest.mark.parametrize("name", ALL)
def test_feet_are_world_positions_through_ground_json(clips: dict[str, Path], name: str) -> None:
    clip = clips[name]
    ground = json.loads((clip / "truth" / "ground.json").read_text())
    with open(clip / "truth" / "world.csv") as f:
        world = {(int(r["frame"]), int(r["person"])): (float(r["x"]), float(r["y"]))
                 for r in csv.DictReader(f)}
    checked = 0
    for cam in cameras(clip):
        H = np.array(ground["cameras"][cam["name"]]["image_from_ground"])
        for r in rows(clip, str(cam["name"])):
            x, y = world[(int(r["frame"]), int(r["person"]))]
            p = H @ [x, y, 1.0]
            assert abs(p[0] / p[2] - r["foot_x"]) < 2e-3
            assert abs(p[1] / p[2] - r["foot_y"]) < 2e-3
            checked += 1
    assert checked > 50


@pytest.mark.parametrize("name", ALL)
def test_mask_people_are_inside_truth_boxes(clips: dict[str, Path], name: str) -> None:
    """Every person pixel of a mask is in some row's box; every visible row has mask pixels."""
    clip = clips[name]
    for cam in cameras(clip):
        table = by_frame(rows(clip, str(cam["name"])))
        for frame in range(0, FRAMES, MASK_EVERY_FRAMES):
            mask = cv2.imread(str(clip / "truth" / "masks" / str(cam["name"]) /
                                  f"{frame:06d}.png"), cv2.IMREAD_UNCHANGED)
            assert set(np.unique(mask)) <= {0, 1, 2}
            covered = np.zeros(mask.shape, bool)
            for r in table[frame]:
                x0, y0 = int(r["box_x"] + 0.5), int(r["box_y"] + 0.5)
                box = (slice(y0, y0 + int(r["box_h"])), slice(x0, x0 + int(r["box_w"])))
                covered[box] = True
                assert 0.0 <= r["visible"] <= 1.0
                if r["visible"] > 0:
                    assert (mask[box] == 1).any()
                    # the box is tight: its border rows and columns hold person pixels
                    assert (mask[box][0] == 1).any() and (mask[box][-1] == 1).any()
                    assert (mask[box][:, 0] == 1).any() and (mask[box][:, -1] == 1).any()
            assert not ((mask == 1) & ~covered).any()


def test_pillar_hides_people_from_cam1_while_cam0_sees_them(clips: dict[str, Path]) -> None:
    clip = clips["pillar"]
    cam0 = {(r["frame"], r["person"]): r["visible"] for r in rows(clip, "cam0")}
    hidden = [r for r in rows(clip, "cam1")
              if r["visible"] < 0.1 and cam0.get((r["frame"], r["person"]), 0.0) > 0.5]
    assert len(hidden) >= 5


def test_three_cameras_overlap_only_through_cam2(clips: dict[str, Path]) -> None:
    clip = clips["three"]
    seen = {c: {(r["frame"], r["person"]) for r in rows(clip, c)} for c in ("cam0", "cam1",
                                                                            "cam2")}
    assert seen["cam0"] & seen["cam2"]
    assert seen["cam1"] & seen["cam2"]
    assert not seen["cam0"] & seen["cam1"]


def test_one_edge_people_enter_and_leave_cam1_by_its_left_edge(clips: dict[str, Path]) -> None:
    clip = clips["one_edge"]
    width, height = json.loads((clip / "truth" / "scene.json").read_text())["cameras"]["cam1"][
        "size"]
    tracks: dict[float, list[dict[str, float]]] = defaultdict(list)
    for r in rows(clip, "cam1"):
        tracks[r["person"]].append(r)
    ends = 0
    for track in tracks.values():
        frames = [int(r["frame"]) for r in track]
        assert frames == list(range(frames[0], frames[-1] + 1))  # one visit
        for r in track:  # no other side is ever touched
            assert r["box_x"] + r["box_w"] < width - 0.5
            assert r["box_y"] > -0.5 and r["box_y"] + r["box_h"] < height - 0.5
        for r in (track[0], track[-1]):
            if 0 < r["frame"] < FRAMES - 1 and r["visible"] == 1.0:
                assert r["box_x"] == -0.5
                ends += 1
    assert ends >= 1


def test_doors_make_people_appear_inside_the_overlap(clips: dict[str, Path]) -> None:
    """Someone's first row in cam0 is well inside the frame: they stepped out of the door."""
    clip = clips["doors"]
    width, height = json.loads((clip / "truth" / "scene.json").read_text())["cameras"]["cam0"][
        "size"]
    first: dict[float, dict[str, float]] = {}
    for r in rows(clip, "cam0"):
        first.setdefault(r["person"], r)
    inner = [r for r in first.values() if r["frame"] > 0 and r["box_x"] > 5
             and r["box_x"] + r["box_w"] < width - 5 and r["box_y"] > 5
             and r["box_y"] + r["box_h"] < height - 5]
    assert inner


def test_crowd_has_many_people_and_merges(clips: dict[str, Path]) -> None:
    clip = clips["crowd"]
    table = by_frame(rows(clip, "cam0"))
    assert max(len(v) for v in table.values()) >= 6
    assert any(r["visible"] < 0.9 for v in table.values() for r in v)  # people occlude people


def test_shadows_darken_the_ground_and_keep_its_hue(clips: dict[str, Path]) -> None:
    """Shadow pixels are the empty ground scaled by one factor in every channel (same hue)."""
    clip = clips["pair"]
    bg = cv2.imread(str(clip / "truth" / "background" / "cam0.png")).astype(float)
    shadow, lit = np.zeros(3), np.zeros(3)
    for frame in range(0, FRAMES, MASK_EVERY_FRAMES):
        mask = cv2.imread(str(clip / "truth" / "masks" / "cam0" / f"{frame:06d}.png"), 0)
        img = cv2.imread(str(clip / "cam0" / f"{frame:06d}.png")).astype(float)
        inner = cv2.erode((mask == 2).astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
        shadow += img[inner].sum(axis=0)
        lit += bg[inner].sum(axis=0)
    assert lit.sum() > 0, "no cast shadow in any mask"
    ratio = shadow / lit
    assert np.all((ratio > 0.45) & (ratio < 0.75))
    assert ratio.max() / ratio.min() < 1.04


def test_gray_camera_is_gray_with_warm_people(clips: dict[str, Path]) -> None:
    clip = clips["gray"]
    cam = next(c for c in cameras(clip) if c["name"] == "cam1")
    imgs = frames_of(clip, cam)
    people, ground = [], []
    for frame in range(0, FRAMES, MASK_EVERY_FRAMES):
        img = imgs[frame]
        if img.ndim == 3:
            assert np.abs(img.astype(int) - img[..., :1]).max() <= 3  # gray stored as colour
            img = img[..., 0]
        mask = cv2.imread(str(clip / "truth" / "masks" / "cam1" / f"{frame:06d}.png"), 0)
        people.append(img[mask == 1])
        ground.append(img[mask == 0])
    assert np.mean(np.concatenate(people)) > np.mean(np.concatenate(ground)) + 40


# --------------------------------------------------------------------------- determinism


def test_same_seed_same_truth_bytes_and_other_seed_differs(tmp_path: Path) -> None:
    def truth(out: Path, seed: int) -> dict[str, bytes]:
        generate_clip(out, "doors", seed=seed, frames=25, size=(160, 120))
        return {str(p.relative_to(out)): p.read_bytes()
                for p in sorted((out / "truth").rglob("*")) if p.is_file()}

    a, b = truth(tmp_path / "a", 7), truth(tmp_path / "b", 7)
    assert a == b
    c = truth(tmp_path / "c", 8)
    assert c["truth/world.csv"] != a["truth/world.csv"]


# --------------------------------------------------------------------------- geometry


@settings(max_examples=50, deadline=None)
@given(
    x=st.floats(-20, 20), y=st.floats(0, 25), height=st.floats(2.5, 8.0),
    roll=st.floats(-20, 20), focal=st.floats(0.6, 1.5),
)
def test_image_from_ground_is_the_projection_of_ground_points(
    x: float, y: float, height: float, roll: float, focal: float
) -> None:
    dist = height / math.tan(math.radians(30))
    cam = look_at(CameraSpec("c", (0.0, -dist, height), (0.0, 0.0), focal, roll_deg=roll),
                  (320, 240))
    uv, depth = cam.project(np.array([[x, y, 0.0]]))
    assert depth[0] > 0
    assert np.allclose(cam.ground_to_image(np.array([[x, y]])), uv, atol=1e-6)
    assert np.allclose(cam.image_to_ground(uv), [[x, y]], atol=1e-6)


def test_camera_axis_hits_the_target_at_the_principal_point() -> None:
    cam = look_at(CameraSpec("c", (1.0, 2.0, 5.0), (4.0, 9.0), 1.0, roll_deg=17.0), (320, 240))
    uv = cam.ground_to_image(np.array([[4.0, 9.0]]))
    assert np.allclose(uv, [[159.5, 119.5]])
    assert np.allclose(cam.centre, [1.0, 2.0, 5.0])
    with pytest.raises(ValueError, match="pitch"):
        look_at(CameraSpec("c", (0.0, 0.0, 3.0), (0.0, 30.0), 1.0), (320, 240))


def test_smoothed_path_keeps_its_ends_and_rounds_corners() -> None:
    way = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    path, arc = make_path(way)
    assert np.allclose(path[0], way[0], atol=1e-6) and np.allclose(path[-1], way[-1], atol=1e-6)
    assert np.all(np.diff(arc) > 0)
    assert np.hypot(*(path - way[1]).T).min() > 0.2  # the corner is cut
    assert arc[-1] < 20.0
