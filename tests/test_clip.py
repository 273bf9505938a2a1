"""Clip reading (mvtrack.io.clip): every input form of FORMATS.md and every bad input."""

from __future__ import annotations

import gc
import math
import weakref
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from mvtrack.io import ClipError, Detections, open_clip, parse_frame_range, read_detections_csv
from mvtrack.io import streams as streams_module

# ---------------------------------------------------------------- input forms


def test_discovery_without_manifest(clip_builder):
    b = clip_builder
    b.video("cam_b.mp4", 20, fps=12.5)
    b.frames("cam_a", 20)
    b.video("cam_c.avi", 20, fourcc="MJPG", fps=10.0)
    for reserved in ("truth", "results", "detections"):
        b.frames(reserved, 3)
    (b.root / "README.txt").write_text("not a camera")
    (b.root / "mvtrack.toml").write_text("[feet]\nmethod = 'bbox'\n")
    with open_clip(b.root) as clip:
        spec = clip.spec
    assert [c.name for c in spec.cameras] == ["cam_a", "cam_b", "cam_c"]
    assert [c.kind for c in spec.cameras] == ["frames", "video", "video"]
    assert all(c.size == (320, 240) and c.length == 20 and c.offset == 0 for c in spec.cameras)
    assert spec.overlaps == (("cam_a", "cam_b"), ("cam_a", "cam_c"), ("cam_b", "cam_c"))
    assert spec.fps == 12.5  # the first video's own rate
    assert spec.frame_count == 20 and spec.warnings == ()
    assert spec.truth_dir == b.root / "truth"
    assert spec.params_file == b.root / "mvtrack.toml"
    assert spec.camera("cam_b").source == b.root / "cam_b.mp4"
    with pytest.raises(KeyError, match="cam_a, cam_b, cam_c"):
        spec.camera("nope")


def test_frames_only_default_fps(clip_builder):
    clip_builder.frames("only", 5, ext=".jpg")
    spec = open_clip(clip_builder.root).spec
    assert spec.fps == 25.0 and spec.overlaps == () and spec.truth_dir is None
    assert spec.params_file is None


@pytest.mark.parametrize(
    ("name", "fourcc"), [("v.mp4", "mp4v"), ("v.avi", "MJPG"), ("v.mkv", "mp4v"), ("v", None)]
)
def test_every_frame_comes_out_in_order(clip_builder, name, fourcc):
    """Content encodes the stream index: whole clip, then a range started mid-stream."""
    b = clip_builder
    if fourcc is None:
        b.frames(name, 40)
    else:
        b.video(name, 40, fourcc=fourcc)
    with open_clip(b.root) as clip:
        assert clip.spec.frame_count == 40
        seen = [(fs.index, b.decode(fs.images["v"])) for fs in clip.frames()]
        assert seen == [(k, k) for k in range(40)]
        part = [(fs.index, b.decode(fs.images["v"])) for fs in clip.frames(range(23, 31))]
        assert part == [(k, k) for k in range(23, 31)]
        stepped = [b.decode(fs.images["v"]) for fs in clip.frames(range(5, 40, 7))]
        assert stepped == list(range(5, 40, 7))


def test_offsets_synchronize_streams(clip_builder):
    b = clip_builder
    b.video("a.mp4", 30)
    b.frames("b", 30)
    b.toml(
        'fps = 5\n[[camera]]\nname = "a"\nsource = "a.mp4"\noffset = 4\n'
        '[[camera]]\nname = "b"\nsource = "b"\noffset = 1\n'
    )
    with open_clip(b.root) as clip:
        spec = clip.spec
        assert spec.fps == 5.0 and spec.frame_count == 26  # min(30 - 4, 30 - 1)
        assert len(spec.warnings) == 1
        warning = spec.warnings[0]
        assert "a.mp4 has 30 frames (from offset 4: 26)" in warning
        assert "b/ has 30 frames (from offset 1: 29)" in warning
        assert "0..25" in warning
        for fs in clip.frames(range(10, 26)):
            assert b.decode(fs.images["a"]) == fs.index + 4
            assert b.decode(fs.images["b"]) == fs.index + 1


def test_different_lengths_use_the_common_range(clip_builder):
    b = clip_builder
    b.video("cam0.mp4", 20)
    b.video("cam1.mp4", 26)
    with open_clip(b.root) as clip:
        assert clip.spec.frame_count == 20
        assert clip.spec.warnings == (
            "streams of different lengths: cam0.mp4 has 20 frames, cam1.mp4 has 26 frames: "
            "using the common range 0..19",
        )
        assert sum(1 for _ in clip.frames()) == 20


def test_gray_and_rgb_modalities(clip_builder):
    b = clip_builder
    b.video("v.mp4", 6)
    b.frames("f", 6)
    b.toml(
        '[[camera]]\nname = "v"\nsource = "v.mp4"\nmodality = "gray"\n'
        '[[camera]]\nname = "f"\nsource = "f"\nmodality = "gray"\n'
        '[[camera]]\nname = "c"\nsource = "f"\n'
    )
    with open_clip(b.root) as clip:
        fs = next(iter(clip.frames(range(5, 6))))
    for name in ("v", "f"):
        assert fs.images[name].shape == (240, 320) and fs.images[name].dtype == np.uint8
        assert b.decode(fs.images[name]) == 5
    assert fs.images["c"].shape == (240, 320, 3) and fs.images["c"].dtype == np.uint8
    assert set(fs.images) == {"v", "f", "c"} and dict(fs.detections) == {}


def test_frame_folder_natural_order_ignores_non_images(clip_builder):
    folder = clip_builder.root / "cam"
    folder.mkdir(parents=True)
    for i in (0, 1, 2, 9, 10, 11):  # unpadded: 10 must come after 9
        cv2.imwrite(str(folder / f"f{i}.png"), clip_builder.encode(i))
    (folder / "notes.txt").write_text("ignored")
    (folder / ".hidden.png").write_bytes(b"ignored")
    with open_clip(clip_builder.root) as clip:
        got = [clip_builder.decode(fs.images["cam"]) for fs in clip.frames()]
    assert got == [0, 1, 2, 9, 10, 11]


def test_detections_cameras(clip_builder):
    b = clip_builder
    b.video("cam0.mp4", 12)
    b.detections(
        "detections/d1.csv",
        ["3,10.5,20.5,30,40,0.9,,,", "3,100,50,20,60,,110,111,7", "", "8,1,2,3,4,0.5,,,2"],
    )
    b.toml(
        '[[camera]]\nname = "cam0"\nsource = "cam0.mp4"\n'
        '[[camera]]\nname = "d1"\ndetections = "detections/d1.csv"\nsize = [640, 480]\n'
        '[[overlap]]\ncameras = ["d1", "cam0"]\n'
    )
    with open_clip(b.root) as clip:
        spec = clip.spec
        assert spec.camera("d1").kind == "detections" and spec.camera("d1").size == (640, 480)
        assert spec.camera("d1").length == 9 and spec.frame_count == 12
        assert spec.overlaps == (("d1", "cam0"),) and spec.warnings == ()
        sets = list(clip.frames())
    assert [len(fs.detections["d1"]) for fs in sets] == [0, 0, 0, 2, 0, 0, 0, 0, 1, 0, 0, 0]
    d = sets[3].detections["d1"]
    np.testing.assert_array_equal(d.boxes_xywh, [[10.5, 20.5, 30, 40], [100, 50, 20, 60]])
    assert d.scores[0] == 0.9 and math.isnan(d.scores[1])
    assert np.isnan(d.feet[0]).all() and d.feet[1].tolist() == [110, 111]
    assert d.tracks.tolist() == [-1, 7] and d.tracks.dtype == np.int64
    empty = sets[0].detections["d1"]
    assert empty.boxes_xywh.shape == (0, 4) and empty.feet.shape == (0, 2)
    assert empty.scores.shape == (0,) and empty.tracks.dtype == np.int64
    with pytest.raises(ValueError, match="read-only"):
        d.boxes_xywh[0, 0] = 1.0


def test_detections_only_clip_and_rows_past_the_end(clip_builder):
    b = clip_builder
    b.detections("a.csv", ["0,1,1,5,5,,,,", "14,1,1,5,5,,,,"])
    b.detections("b.csv", ["30,1,1,5,5,,,,"])
    b.toml(
        '[[camera]]\nname = "a"\ndetections = "a.csv"\nsize = [320, 240]\n'
        '[[camera]]\nname = "b"\ndetections = "b.csv"\nsize = [320, 240]\n'
    )
    assert open_clip(b.root).spec.frame_count == 31  # until the last row of any camera
    b.frames("cam", 20)
    b.toml(
        '[[camera]]\nname = "cam"\nsource = "cam"\n'
        '[[camera]]\nname = "b"\ndetections = "b.csv"\nsize = [320, 240]\n'
    )
    spec = open_clip(b.root).spec
    assert spec.frame_count == 20
    assert spec.warnings == (
        "b.csv has rows up to frame 30 but the clip has frames 0..19: rows after frame 19 "
        "are ignored",
    )


def test_camera_selection_filters_overlaps(clip_builder):
    b = clip_builder
    for name in ("c0", "c1", "c2"):
        b.frames(name, 4)
    clip = open_clip(b.root, cameras=["c2", "c0"])
    assert [c.name for c in clip.spec.cameras] == ["c0", "c2"]
    assert clip.spec.overlaps == (("c0", "c2"),)
    assert set(next(iter(clip.frames())).images) == {"c0", "c2"}
    with pytest.raises(ClipError, match=r"no camera 'c9' \(cameras: c0, c1, c2\)"):
        open_clip(b.root, cameras=["c9"])


def test_manifest_without_cameras_discovers(clip_builder):
    b = clip_builder
    b.frames("x", 3)
    b.frames("y", 3)
    b.toml("fps = 3.5\n")
    spec = open_clip(b.root / "clip.toml").spec  # the manifest path is accepted too
    assert spec.fps == 3.5 and [c.name for c in spec.cameras] == ["x", "y"]


def test_stream_ending_early_stops_cleanly(clip_builder):
    """A truncated AVI whose header still claims every frame."""
    b = clip_builder
    path = b.video("cut.avi", 30, fourcc="MJPG")
    data = path.read_bytes()
    path.write_bytes(data[: len(data) * 6 // 10])
    with open_clip(b.root) as clip:
        assert clip.spec.frame_count == 30  # what the header says
        got = [b.decode(fs.images["cut"]) for fs in clip.frames()]
        assert 5 < len(got) < 30
        assert got[:-1] == list(range(len(got) - 1))  # the last one may be cut in the middle
        assert clip.warnings == (
            f"cut.avi ended at stream frame {len(got)} although it claims 30 frames: "
            f"stopping before clip frame {len(got)}",
        )


def test_iterator_holds_only_the_current_frame_set(clip_builder):
    clip_builder.video("v.mp4", 5)
    with open_clip(clip_builder.root) as clip:
        it = clip.frames()
        first = weakref.ref(next(it).images["v"])
        assert next(it).index == 1
        gc.collect()
        assert first() is None  # frame 0 is gone once frame 1 is out


def test_close_stops_running_iterators(clip_builder):
    clip_builder.video("v.mp4", 10)
    clip = open_clip(clip_builder.root)
    it = clip.frames()
    next(it)
    clip.close()
    assert list(it) == [] and clip.warnings == ()


def test_bad_range_for_frames(clip_builder):
    clip_builder.frames("f", 10)
    clip = open_clip(clip_builder.root)
    for bad in (range(5, 11), range(-1, 3), range(5, 0, -1)):
        with pytest.raises(ClipError, match=r"outside the clip's 0\.\.9"):
            clip.frames(bad)
    assert list(clip.frames(range(3, 3))) == []


# ---------------------------------------------------------------- frame ranges


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("100:400", range(100, 400)),
        ("100:", range(100, 795)),
        (":50", range(0, 50)),
        ("7", range(0, 7)),  # a count, like generate's --frames
        (" 3 : 9 ", range(3, 9)),
        (":", range(0, 795)),
        ("795", range(0, 795)),
    ],
)
def test_parse_frame_range(text, expected):
    assert parse_frame_range(text, 795) == expected


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("100:900", "the clip has 795 frames"),
        ("796", "the clip has 795 frames"),
        ("0", "empty range"),
        ("400:100", "empty range"),
        ("5:5", "empty range"),
        ("-3:", "expected START:END"),
        ("a:b", "expected START:END"),
        ("1:2:3", "expected START:END"),
        ("", "expected START:END"),
    ],
)
def test_parse_frame_range_errors(text, message):
    with pytest.raises(ClipError, match=message):
        parse_frame_range(text, 795)


# ---------------------------------------------------------------- detections CSV


def test_read_detections_csv_values(tmp_path):
    path = tmp_path / "d.csv"
    path.write_text(
        "frame,x,y,w,h,score,foot_x,foot_y,track,extra\n"
        "2,1.5,2.5,3,4,0.25,5,6,1,x\n"
        "0,0,0,1,1,,,,,\n"
        "2,9,9,9,9,,,,,\n"
    )
    dets = read_detections_csv(path)
    assert sorted(dets) == [0, 2]
    assert dets[2].boxes_xywh.tolist() == [[1.5, 2.5, 3, 4], [9, 9, 9, 9]]  # file order
    assert dets[2].tracks.tolist() == [1, -1] and dets[0].feet.shape == (1, 2)
    assert len(Detections.empty()) == 0


# ---------------------------------------------------------------- bad input table

VIDEO_TOML = '[[camera]]\nname = "cam0"\nsource = "cam0.mp4"\n'
DET_TOML = '[[camera]]\nname = "d"\ndetections = "d.csv"\nsize = [320, 240]\n'


def _with_toml(text: str) -> Callable:
    def build(b) -> None:
        b.video("cam0.mp4", 5)
        b.toml(text)

    return build


def _det_rows(*rows: str, header: str | None = None) -> Callable:
    def build(b) -> None:
        b.detections("d.csv", rows)
        if header is not None:
            path = b.root / "d.csv"
            path.write_text(header + "\n" + "\n".join(rows) + "\n")
        b.toml(DET_TOML)

    return build


def _garbage_video(b) -> None:
    (b.root / "cam0.mp4").write_bytes(b"not a video at all" * 100)


def _empty_video(b) -> None:
    (b.root / "cam0.mp4").write_bytes(b"")


def _empty_folder(b) -> None:
    b.video("cam0.mp4", 5)
    (b.root / "cam1").mkdir()


def _mixed_folder(b) -> None:
    b.frames("cam1", 3, ext=".png")
    cv2.imwrite(str(b.root / "cam1" / "000003.jpg"), b.encode(3))


def _wrong_size_frame(ext: str) -> Callable:
    def build(b) -> None:
        b.frames("cam1", 8, ext=ext)
        cv2.imwrite(str(b.root / "cam1" / f"000005{ext}"), b.encode(5, size=(322, 240)))

    return build


def _offset_past_end(b) -> None:
    b.video("cam0.mp4", 5)
    b.toml(VIDEO_TOML + "offset = 5\n")


BAD_INPUTS = [
    # (id, builder, file named in the message, phrase in the message)
    ("missing video", _with_toml(VIDEO_TOML.replace("cam0.mp4", "nope.mp4")), "nope.mp4",
     "does not exist"),
    ("unreadable video", _garbage_video, "cam0.mp4", "cannot be read as a video"),
    ("empty video file", _empty_video, "cam0.mp4", "cannot be read as a video"),
    ("empty frame folder", _empty_folder, "cam1", "empty frame folder"),
    ("mixed frame types", _mixed_folder, "cam1", "mixes image types"),
    ("wrong-size png frame", _wrong_size_frame(".png"), "000005.png",
     "frame 5 is 322x240, expected 320x240"),
    ("wrong-size jpg frame", _wrong_size_frame(".jpg"), "000005.jpg",
     "frame 5 is 322x240, expected 320x240"),
    ("declared size differs", _with_toml(VIDEO_TOML + "size = [640, 480]\n"), "cam0.mp4",
     "but size = [640, 480]"),
    ("no cameras", lambda b: None, "clip", "no cameras"),
    ("invalid toml", _with_toml("fps = = 3\n"), "clip.toml", "not valid TOML"),
    ("unknown top key", _with_toml("fsp = 3\n" + VIDEO_TOML), "clip.toml", "unknown key 'fsp'"),
    ("unknown camera key", _with_toml(VIDEO_TOML + 'sorce = "x"\n'), "clip.toml",
     "unknown key 'sorce'"),
    ("unknown overlap key", _with_toml(VIDEO_TOML + '[[overlap]]\ncams = ["a", "b"]\n'),
     "clip.toml", "unknown key 'cams'"),
    ("bad fps", _with_toml("fps = 0\n" + VIDEO_TOML), "clip.toml", "fps must be a positive"),
    ("camera not a table array", _with_toml('camera = "cam0"\n'), "clip.toml",
     "array of tables"),
    ("duplicate names", _with_toml(VIDEO_TOML + VIDEO_TOML), "clip.toml", "used twice"),
    ("nameless camera", _with_toml('[[camera]]\nsource = "cam0.mp4"\n'), "clip.toml",
     "camera name must be a non-empty string"),
    ("comma in name", _with_toml(VIDEO_TOML.replace('"cam0"', '"a,b"')), "clip.toml",
     "may not contain"),
    ("source and detections", _with_toml(VIDEO_TOML + 'detections = "d.csv"\n'), "clip.toml",
     "exactly one of `source` or `detections`"),
    ("neither source", _with_toml('[[camera]]\nname = "x"\n'), "clip.toml", "exactly one"),
    ("detections without size",
     _with_toml('[[camera]]\nname = "d"\ndetections = "cam0.mp4"\n'), "clip.toml",
     "`size = [width, height]` is required"),
    ("bad size", _with_toml(DET_TOML.replace("d.csv", "cam0.mp4").replace("[320, 240]", "[320]")),
     "clip.toml",
     "size must be [width, height]"),
    ("bad modality", _with_toml(VIDEO_TOML + 'modality = "thermal"\n'), "clip.toml",
     "modality must be 'rgb' or 'gray'"),
    ("negative offset", _with_toml(VIDEO_TOML + "offset = -2\n"), "clip.toml",
     "offset must be an integer >= 0"),
    ("offset on detections", _with_toml(DET_TOML.replace("d.csv", "cam0.mp4") + "offset = 3\n"),
     "clip.toml", "takes no offset"),
    ("offset past the end", _offset_past_end, "cam0.mp4", "no clip frame where every camera"),
    ("unknown overlap camera",
     _with_toml(VIDEO_TOML + '[[overlap]]\ncameras = ["cam0", "camX"]\n'), "clip.toml",
     "unknown camera 'camX'"),
    ("overlap with itself", _with_toml(VIDEO_TOML + '[[overlap]]\ncameras = ["cam0", "cam0"]\n'),
     "clip.toml", "two different camera names"),
    ("detections header",
     _det_rows("0,1,1,5,5,,,,", header="frame,x,y,h,w,score,foot_x,foot_y,track"), "d.csv:1",
     "header must start with frame,x,y,w,h"),
    ("detections not a number", _det_rows("0,1,1,5,5,,,,", "1,1,one,5,5,,,,"), "d.csv:3",
     "column 'y' expected a number, got 'one'"),
    ("detections empty box", _det_rows("0,1,1,,5,,,,"), "d.csv:2", "column 'w' is empty"),
    ("detections negative size", _det_rows("0,1,1,5,-5,,,,"), "d.csv:2",
     "column 'h' expected a value > 0"),
    ("detections fractional frame", _det_rows("2.5,1,1,5,5,,,,"), "d.csv:2",
     "column 'frame' expected an integer"),
    ("detections negative frame", _det_rows("-1,1,1,5,5,,,,"), "d.csv:2",
     "column 'frame' expected a value >= 0"),
    ("detections nan", _det_rows("0,nan,1,5,5,,,,"), "d.csv:2", "expected a finite number"),
    ("detections short row", _det_rows("0,1,1,5,5,0.5"), "d.csv:2", "expected 9 columns"),
    ("detections half foot", _det_rows("0,1,1,5,5,,3,,", "0,1,1,5,5,,3,,"), "d.csv:2",
     "foot_x and foot_y must be both given"),
    ("detections negative track", _det_rows("0,1,1,5,5,,,,-4"), "d.csv:2", "column 'track'"),
]  # fmt: skip


@pytest.mark.parametrize(
    ("build", "named", "phrase"), [case[1:] for case in BAD_INPUTS], ids=[c[0] for c in BAD_INPUTS]
)
def test_bad_input_fails_up_front_naming_the_file(clip_builder, build, named, phrase):
    build(clip_builder)
    with pytest.raises(ClipError) as err:
        open_clip(clip_builder.root)
    message = str(err.value)
    assert named in message and phrase in message, message


def test_missing_clip_directory(tmp_path):
    with pytest.raises(ClipError, match="no such clip directory"):
        open_clip(tmp_path / "nowhere")
    (tmp_path / "file.mp4").write_bytes(b"")
    with pytest.raises(ClipError, match="a clip is a directory"):
        open_clip(tmp_path / "file.mp4")


def test_unreadable_frame_while_reading_names_the_file(clip_builder):
    b = clip_builder
    b.frames("cam", 6)
    (b.root / "cam" / "000003.png").write_bytes(b"broken")  # header unknown: found on reading
    clip = open_clip(b.root)
    frames = clip.frames()
    assert [next(frames).index for _ in range(3)] == [0, 1, 2]
    with pytest.raises(ClipError, match=r"000003\.png: cannot be read as an image"):
        next(frames)


def test_wrong_size_while_reading_names_file_and_frame(clip_builder, monkeypatch):
    """When a header cannot be parsed up front, the size is checked on reading."""
    b = clip_builder
    b.frames("cam", 6)
    cv2.imwrite(str(b.root / "cam" / "000004.png"), b.encode(4, size=(160, 120)))
    monkeypatch.setattr(streams_module, "_image_size", lambda path: None)
    clip = open_clip(b.root)
    with pytest.raises(ClipError, match=r"cam: frame 4 is 160x120, expected 320x240"):
        list(clip.frames())


def test_image_header_sizes(tmp_path: Path):
    image = np.zeros((37, 53, 3), np.uint8)
    for ext in (".png", ".jpg", ".bmp"):
        path = tmp_path / f"x{ext}"
        cv2.imwrite(str(path), image)
        assert streams_module._image_size(path) == (53, 37), ext
