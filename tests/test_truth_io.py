"""Ground-truth reading (mvtrack.io.truth)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from mvtrack.io import ClipError, read_truth

HEADER = "frame,person,foot_x,foot_y,box_x,box_y,box_w,box_h,visible"
H0 = [[100.0, 0.0, 160.0], [0.0, -100.0, 200.0], [0.0, 0.0, 1.0]]


def _write(root: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        path = root / "truth" / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return root


GOOD = {
    "cam0.csv": f"{HEADER}\n0,1,160.0,200.0,150.5,120.5,20,80,1.0\n0,2,10,20,5,6,7,8,0.25\n"
    "3,1,161,201,151,121,20,80,0\n",
    "cam1.csv": f"{HEADER}\n",
    "world.csv": "frame,person,x,y\n0,1,0.0,0.0\n0,2,-1.5,2.25\n",
    "ground.json": json.dumps(
        {"units": "m", "cameras": {"cam0": {"image_from_ground": H0, "other": 1}}}
    ),
    "notes.csv": "what,ever\n1,2\n",  # unknown files are ignored
    "README.txt": "ignored",
}


def test_read_truth_values(tmp_path):
    truth = read_truth(_write(tmp_path, GOOD))
    assert truth is not None and truth.root == tmp_path / "truth"
    assert sorted(truth.cameras) == ["cam0", "cam1"] and truth.units == "m"
    cam = truth.cameras["cam0"]
    assert len(cam) == 3 and cam.frame.tolist() == [0, 0, 3] and cam.person.tolist() == [1, 2, 1]
    assert cam.foot.shape == (3, 2) and cam.foot[1].tolist() == [10, 20]
    assert cam.box_xywh[0].tolist() == [150.5, 120.5, 20, 80]
    assert cam.visible.tolist() == [1.0, 0.25, 0.0]
    assert cam.frame.dtype == np.int64 and cam.box_xywh.dtype == np.float64
    at0 = cam.at(0)
    assert at0.person.tolist() == [1, 2] and len(cam.at(1)) == 0
    assert len(truth.cameras["cam1"]) == 0 and truth.cameras["cam1"].foot.shape == (0, 2)
    H = truth.image_from_ground["cam0"]
    assert H.shape == (3, 3)
    foot = H @ np.array([0.0, 0.0, 1.0])
    assert (foot[:2] / foot[2]).tolist() == cam.foot[0].tolist()  # person 1 stands at (0, 0)
    assert truth.world is not None and truth.world.xy.tolist() == [[0, 0], [-1.5, 2.25]]
    with pytest.raises(ValueError, match="read-only"):
        cam.foot[0, 0] = 1.0


def test_no_truth_and_optional_files(tmp_path):
    assert read_truth(tmp_path) is None
    truth = read_truth(_write(tmp_path, {"cam0.csv": f"{HEADER}\n"}))
    assert truth is not None
    assert truth.world is None and dict(truth.image_from_ground) == {} and truth.units is None
    assert truth.mask_frames("cam0") == ()


def test_explicit_cameras_are_read_strictly(tmp_path):
    _write(tmp_path, {"cam0.csv": "frame,who\n0,1\n", "cam1.csv": f"{HEADER}\n"})
    truth = read_truth(tmp_path)  # cam0.csv is not camera truth by its header: ignored
    assert truth is not None and sorted(truth.cameras) == ["cam1"]
    only = read_truth(tmp_path, cameras=["cam1", "cam9"])
    assert only is not None and sorted(only.cameras) == ["cam1"]
    with pytest.raises(ClipError, match=r"cam0\.csv:1: header must start with frame,person"):
        read_truth(tmp_path, cameras=["cam0"])


def test_masks(tmp_path):
    root = _write(tmp_path, GOOD)
    folder = root / "truth" / "masks" / "cam0"
    folder.mkdir(parents=True)
    mask = np.zeros((24, 32), np.uint8)
    mask[5:10, 6:9] = 1
    mask[10:12, 6:12] = 2
    for k in (12, 3):
        cv2.imwrite(str(folder / f"{k:06d}.png"), mask)
    (folder / "preview.jpg").write_bytes(b"ignored")
    truth = read_truth(root)
    assert truth is not None
    assert truth.mask_frames("cam0") == (3, 12) and truth.mask_frames("cam1") == ()
    got = truth.load_mask("cam0", 12)
    assert got.dtype == np.uint8 and got.shape == (24, 32)
    np.testing.assert_array_equal(got, mask)
    with pytest.raises(ClipError, match=r"000004\.png: no such mask"):
        truth.load_mask("cam0", 4)
    cv2.imwrite(str(folder / "000005.png"), mask * 3)
    with pytest.raises(ClipError, match=r"000005\.png: mask values must be 0, 1 or 2; found \[3"):
        truth.load_mask("cam0", 5)
    cv2.imwrite(str(folder / "000006.png"), np.zeros((4, 4, 3), np.uint8))
    with pytest.raises(ClipError, match=r"000006\.png: expected a single-channel uint8"):
        truth.load_mask("cam0", 6)


BAD_TRUTH = [
    ("visible above 1", "cam0.csv", f"{HEADER}\n0,1,1,1,1,1,1,1,0.5\n0,2,1,1,1,1,1,1,1.5\n",
     "cam0.csv:3: column 'visible' expected a value <= 1"),
    ("negative width", "cam0.csv", f"{HEADER}\n0,1,1,1,1,1,-1,1,1\n",
     "cam0.csv:2: column 'box_w'"),
    ("text foot", "cam0.csv", f"{HEADER}\n0,1,left,1,1,1,1,1,1\n",
     "cam0.csv:2: column 'foot_x' expected a number"),
    ("duplicate person", "cam0.csv", f"{HEADER}\n4,1,1,1,1,1,1,1,1\n4,2,1,1,1,1,1,1,1\n"
     "4,1,2,2,1,1,1,1,1\n", "cam0.csv:4: person 1 appears again in frame 4 (first on line 2)"),
    ("short row", "cam0.csv", f"{HEADER}\n0,1,1\n", "cam0.csv:2: expected 9 columns"),
    ("world header", "world.csv", "frame,person,y,x\n", "world.csv:1: header must start with"),
    ("world bad row", "world.csv", "frame,person,x,y\n0,1,1,1\n1,x,1,1\n",
     "world.csv:3: column 'person' expected an integer"),
    ("ground not json", "ground.json", '{"units": "m",\n "cameras": {,}}',
     "ground.json:2: not valid JSON"),
    ("ground no cameras", "ground.json", '{"units": "m"}', "ground.json: expected an object"),
    ("ground H shape", "ground.json",
     json.dumps({"cameras": {"cam0": {"image_from_ground": [[1, 0], [0, 1]]}}}),
     "ground.json: cameras.cam0.image_from_ground must be a 3x3 array"),
    ("ground H missing", "ground.json", json.dumps({"cameras": {"cam0": {"H": H0}}}),
     "ground.json: cameras.cam0.image_from_ground is missing"),
    ("ground H singular", "ground.json",
     json.dumps({"cameras": {"cam0": {"image_from_ground": [[1, 0, 0], [2, 0, 0], [0, 0, 1]]}}}),
     "cameras.cam0.image_from_ground is singular"),
    ("ground units", "ground.json", json.dumps({"units": 1, "cameras": {}}),
     "ground.json: units must be a string"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("rel", "text", "message"), [c[1:] for c in BAD_TRUTH], ids=[c[0] for c in BAD_TRUTH]
)
def test_malformed_truth_names_file_and_line(tmp_path, rel, text, message):
    _write(tmp_path, {**GOOD, rel: text})
    with pytest.raises(ClipError) as err:
        read_truth(tmp_path)
    assert message in str(err.value) and str(tmp_path / "truth" / rel) in str(err.value)
