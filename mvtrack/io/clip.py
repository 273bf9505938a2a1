"""Clip reading exactly per FORMATS.md: cameras, offsets, modality, overlaps, fps, frames.

    with open_clip("my_clip", cameras=["cam0", "cam1"]) as clip:
        for fs in clip.frames(parse_frame_range("100:400", clip.spec.frame_count)):
            fs.images["cam0"]        # (H, W, 3) uint8 BGR, or (H, W) uint8 for a gray camera
            fs.detections["View_5"]  # Detections of a camera given as a detections CSV

:func:`open_clip` validates everything it can before any frame is read (manifest keys, camera
names, sources, the first frame's size of every stream, every detections row) and raises a
:class:`ClipError` naming the file (and line or key) and the problem. Streams of different lengths
are not an error: the clip is their common range, and :attr:`ClipSpec.warnings` says so.

Decisions beyond FORMATS.md (documented here, tested in tests/test_clip.py):

- ``offset`` is the index in the stream of clip frame 0, so it must be >= 0: a camera that starts
  later than the others is expressed by positive offsets on the others. Clip frame ``k`` of a
  camera is its stream frame ``k + offset``.
- The frames of a detections CSV are clip frame indices (FORMATS.md: every frame index is a clip
  index), so a detections camera takes no ``offset`` (or ``offset = 0``).
- The clip range is the frames where every video/frames camera has a frame. A detections camera
  has data in every frame (a frame without rows has no detections) and does not shorten the clip;
  rows past the clip's end are ignored with a warning. A clip of detections cameras only lasts
  until the last row of any camera.
- A ``clip.toml`` without ``[[camera]]`` tables discovers the cameras as if it were absent (its
  ``fps`` and ``[[overlap]]`` still apply). ``size`` may also be given for a video/frames camera;
  the stream must then have that size.
- Frame folders are ordered by file name, digit runs compared as numbers (``9.png`` before
  ``10.png``; zero-padded names sort the same either way). Hidden files and files that are not
  images are ignored; ``.jpg`` and ``.jpeg`` are one family, and families cannot be mixed.
- Video frame counts come from the container header. A stream that ends earlier while reading
  stops the iteration cleanly; :attr:`Clip.warnings` then says where (and it is logged).
- Seeking to a range's start reads and discards frames (``grab``), which is exact for every codec
  (``CAP_PROP_POS_FRAMES`` is not).
- :meth:`Clip.frames` decodes the next frame set on a background thread while the caller works
  on the current one (decoding releases the GIL); frames, errors and warnings arrive exactly
  as without it (``prefetch=False``), each error at the frame set it belongs to.
"""

from __future__ import annotations

import logging
import math
import re
import struct
import threading
import tomllib
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace
from itertools import combinations
from pathlib import Path
from typing import Any, BinaryIO, Literal

import cv2
import numpy as np

from mvtrack.io.detections import ClipError, Detections, read_detections_csv

__all__ = [
    "DEFAULT_FPS",
    "IMAGE_EXTENSIONS",
    "RESERVED_NAMES",
    "VIDEO_EXTENSIONS",
    "CameraSpec",
    "Clip",
    "ClipError",
    "ClipSpec",
    "FrameSet",
    "open_clip",
    "parse_frame_range",
]

log = logging.getLogger(__name__)

VIDEO_EXTENSIONS = (".mp4", ".avi", ".mkv", ".mov")
IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp")
RESERVED_NAMES = ("truth", "results", "detections")
DEFAULT_FPS = 25.0
_FAMILY = {".png": "png", ".jpg": "jpeg", ".jpeg": "jpeg", ".bmp": "bmp"}
_TOP_KEYS = ("fps", "camera", "overlap")
_CAMERA_KEYS = ("name", "source", "detections", "offset", "modality", "size")
_OVERLAP_KEYS = ("cameras",)
_BAD_NAME_CHARS = set(',"/\\\n\r\t')


@dataclass(frozen=True)
class CameraSpec:
    """One camera of a clip, validated.

    Attributes:
        name: camera name (file stem / folder name without a manifest).
        kind: "video" (a video file), "frames" (a folder of images) or "detections" (a CSV).
        source: the video file, frame folder or detections CSV.
        offset: index in this stream of clip frame 0 (>= 0; 0 for detections).
        modality: "rgb" (frames come out (H, W, 3) uint8 BGR) or "gray" ((H, W) uint8).
        size: (width, height) in pixels of the camera's full-resolution frame.
        length: frames in the stream before the offset (for detections: last row's frame + 1).
    """

    name: str
    kind: Literal["video", "frames", "detections"]
    source: Path
    offset: int
    modality: Literal["rgb", "gray"]
    size: tuple[int, int]
    length: int


@dataclass(frozen=True)
class ClipSpec:
    """A validated clip.

    Attributes:
        root: the clip directory.
        fps: frames per second of the clip.
        cameras: the cameras, in manifest order (sorted by name when discovered).
        overlaps: camera pairs whose views overlap, as declared (default: every pair).
        frame_count: length of the common clip range ``[0, frame_count)`` after offsets.
        warnings: things that are not errors but change what is read (e.g. different lengths).
        truth_dir: ``root/truth`` if it exists (only evaluation reads it).
        params_file: ``root/mvtrack.toml`` if it exists.
    """

    root: Path
    fps: float
    cameras: tuple[CameraSpec, ...]
    overlaps: tuple[tuple[str, str], ...]
    frame_count: int
    warnings: tuple[str, ...]
    truth_dir: Path | None
    params_file: Path | None

    def camera(self, name: str) -> CameraSpec:
        """The camera called ``name``; KeyError naming the known cameras otherwise."""
        for cam in self.cameras:
            if cam.name == name:
                return cam
        known = ", ".join(c.name for c in self.cameras)
        raise KeyError(f"no camera {name!r} in {self.root} (cameras: {known})")


@dataclass(frozen=True)
class FrameSet:
    """The synchronized data of all cameras at one clip frame.

    Attributes:
        index: clip frame index.
        images: per video/frames camera, (H, W, 3) uint8 BGR (rgb) or (H, W) uint8 (gray).
        detections: per detections camera, its :class:`Detections` (possibly empty).
    """

    index: int
    images: Mapping[str, np.ndarray]
    detections: Mapping[str, Detections]


# --------------------------------------------------------------------------------------------
# Manifest and discovery


@dataclass(frozen=True)
class _Entry:
    """A camera as declared, before its source is probed."""

    name: str
    path: Path
    kind: Literal["video", "frames", "detections"]
    offset: int = 0
    modality: Literal["rgb", "gray"] = "rgb"
    size: tuple[int, int] | None = None
    where: str = ""  # for messages: "clip.toml [[camera]] 'cam0'" or the discovered path


def _check_name(name: Any, where: str) -> str:
    if not isinstance(name, str) or not name.strip() or name != name.strip():
        raise ClipError(f"{where}: camera name must be a non-empty string, got {name!r}")
    if _BAD_NAME_CHARS & set(name):
        raise ClipError(
            f'{where}: camera name {name!r} may not contain , " / \\ tabs or line breaks'
        )
    return name


def _int(value: Any, where: str, key: str, lo: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < lo:
        raise ClipError(f"{where}: {key} must be an integer >= {lo}, got {value!r}")
    return value


def _size(value: Any, where: str) -> tuple[int, int]:
    if not isinstance(value, list) or len(value) != 2:
        raise ClipError(f"{where}: size must be [width, height], got {value!r}")
    w, h = (_int(v, where, "size", 1) for v in value)
    return (w, h)


def _kind_of(path: Path) -> Literal["video", "frames"]:
    return "frames" if path.is_dir() else "video"


def _camera_entry(table: Any, root: Path, where: str) -> _Entry:
    if not isinstance(table, dict):
        raise ClipError(f"{where}: expected a [[camera]] table")
    for key in table:
        if key not in _CAMERA_KEYS:
            raise ClipError(f"{where}: unknown key {key!r} (known: {', '.join(_CAMERA_KEYS)})")
    name = _check_name(table.get("name"), where)
    where = f"{where} {name!r}"
    if ("source" in table) == ("detections" in table):
        raise ClipError(f"{where}: give exactly one of `source` or `detections`")
    rel = table.get("source", table.get("detections"))
    if not isinstance(rel, str) or not rel:
        raise ClipError(f"{where}: source/detections must be a path string, got {rel!r}")
    path = root / rel
    if not path.exists():
        raise ClipError(f"{where}: {path} does not exist")
    modality = table.get("modality", "rgb")
    if modality not in ("rgb", "gray"):
        raise ClipError(f"{where}: modality must be 'rgb' or 'gray', got {modality!r}")
    offset = _int(table.get("offset", 0), where, "offset", 0)
    size = _size(table["size"], where) if "size" in table else None
    if "detections" in table:
        if size is None:
            raise ClipError(f"{where}: `size = [width, height]` is required with `detections`")
        if offset != 0:
            raise ClipError(
                f"{where}: a detections camera takes no offset (its CSV frames are clip frames)"
            )
        if not path.is_file():
            raise ClipError(f"{where}: {path} is not a file")
        return _Entry(name, path, "detections", 0, modality, size, where)
    return _Entry(name, path, _kind_of(path), offset, modality, size, where)


def _overlap(table: Any, where: str) -> tuple[str, str]:
    if not isinstance(table, dict):
        raise ClipError(f"{where}: expected an [[overlap]] table")
    for key in table:
        if key not in _OVERLAP_KEYS:
            raise ClipError(f"{where}: unknown key {key!r} (known: cameras)")
    pair = table.get("cameras")
    if (
        not isinstance(pair, list)
        or len(pair) != 2
        or not all(isinstance(n, str) for n in pair)
        or pair[0] == pair[1]
    ):
        raise ClipError(f"{where}: cameras must be two different camera names, got {pair!r}")
    return (pair[0], pair[1])


def _tables(data: dict[str, Any], key: str, path: Path) -> list[Any]:
    value = data.get(key, [])
    if not isinstance(value, list):
        raise ClipError(f"{path}: `{key}` must be an array of tables ([[{key}]])")
    return value


def _read_manifest(
    path: Path,
) -> tuple[float | None, list[_Entry], list[tuple[str, str]] | None]:
    """Parse clip.toml: (fps or None, declared cameras, declared overlaps or None)."""
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise ClipError(f"{path}: cannot read: {exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ClipError(f"{path}: not valid TOML: {exc}") from None
    for key in data:
        if key not in _TOP_KEYS:
            raise ClipError(f"{path}: unknown key {key!r} (known: {', '.join(_TOP_KEYS)})")
    fps = data.get("fps")
    if fps is not None and (
        isinstance(fps, bool) or not isinstance(fps, int | float) or not 0 < fps < math.inf
    ):
        raise ClipError(f"{path}: fps must be a positive number, got {fps!r}")
    entries = [
        _camera_entry(t, path.parent, f"{path} [[camera]] #{i + 1}")
        for i, t in enumerate(_tables(data, "camera", path))
    ]
    overlap_tables = _tables(data, "overlap", path)
    overlaps = [_overlap(t, f"{path} [[overlap]] #{i + 1}") for i, t in enumerate(overlap_tables)]
    return (None if fps is None else float(fps)), entries, (overlaps if "overlap" in data else None)


def _discover(root: Path) -> list[_Entry]:
    """Cameras of a clip without a manifest: top-level videos and image folders, by name."""
    entries = []
    for path in sorted(root.iterdir(), key=lambda p: p.name):
        if path.name.startswith(".") or path.name in RESERVED_NAMES:
            continue
        if path.is_dir() or (path.is_file() and path.suffix.lower() in VIDEO_EXTENSIONS):
            name = _check_name(path.stem if path.is_file() else path.name, str(path))
            entries.append(_Entry(name, path, _kind_of(path), where=str(path)))
    if not entries:
        raise ClipError(
            f"{root}: no cameras: no clip.toml, no video ({' '.join(VIDEO_EXTENSIONS)}) "
            "and no frame folder at the top level"
        )
    return entries


# --------------------------------------------------------------------------------------------
# Probing the sources


def _natural_key(path: Path) -> tuple[list[Any], str]:
    parts = re.split(r"(\d+)", path.name)
    return [int(p) if i % 2 else p for i, p in enumerate(parts)], path.name


def _list_frames(folder: Path) -> list[Path]:
    """The image files of a frame folder in frame order; ClipError if none or mixed types."""
    try:
        files = [
            p
            for p in folder.iterdir()
            if p.suffix.lower() in IMAGE_EXTENSIONS and not p.name.startswith(".") and p.is_file()
        ]
    except OSError as exc:
        raise ClipError(f"{folder}: cannot list the frame folder: {exc.strerror}") from None
    if not files:
        raise ClipError(f"{folder}: empty frame folder: no {' '.join(IMAGE_EXTENSIONS)} images")
    families = sorted({_FAMILY[p.suffix.lower()] for p in files})
    if len(families) > 1:
        raise ClipError(
            f"{folder}: frame folder mixes image types ({', '.join(families)}); use one type"
        )
    return sorted(files, key=_natural_key)


def _jpeg_size(f: BinaryIO) -> tuple[int, int] | None:
    sof = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}
    f.seek(2)
    while True:
        if f.read(1) != b"\xff":
            return None
        b = f.read(1)
        while b == b"\xff":
            b = f.read(1)
        if not b:
            return None
        if b[0] == 0x01 or 0xD0 <= b[0] <= 0xD8:  # markers without a length
            continue
        seg = f.read(2)
        if len(seg) < 2:
            return None
        if b[0] in sof:
            data = f.read(5)
            return None if len(data) < 5 else struct.unpack(">HH", data[1:5])[::-1]
        f.seek(int.from_bytes(seg, "big") - 2, 1)


def _image_size(path: Path) -> tuple[int, int] | None:
    """(width, height) from a PNG/JPEG/BMP header without decoding; None if not parsed."""
    try:
        with open(path, "rb") as f:
            head = f.read(26)
            if head[:8] == b"\x89PNG\r\n\x1a\n" and head[12:16] == b"IHDR":
                w, h = struct.unpack(">II", head[16:24])
                return (w, h)
            if head[:2] == b"BM" and len(head) == 26:
                if struct.unpack("<I", head[14:18])[0] == 12:  # OS/2 header
                    w, h = struct.unpack("<HH", head[18:22])
                    return (w, h)
                w, h = struct.unpack("<ii", head[18:26])
                return (w, abs(h))
            if head[:2] == b"\xff\xd8":
                return _jpeg_size(f)
    except OSError:
        return None
    return None


def _imread(path: Path, modality: str) -> np.ndarray:
    flag = cv2.IMREAD_GRAYSCALE if modality == "gray" else cv2.IMREAD_COLOR
    image = cv2.imread(str(path), flag | cv2.IMREAD_IGNORE_ORIENTATION)
    if image is None:
        raise ClipError(f"{path}: cannot be read as an image")
    return image


def _probe_frames(entry: _Entry) -> tuple[CameraSpec, list[Path]]:
    files = _list_frames(entry.path)
    h, w = _imread(files[0], entry.modality).shape[:2]
    for i, path in enumerate(files[1:], start=1):
        size = _image_size(path)
        if size is not None and size != (w, h):
            raise ClipError(
                f"{path}: frame {i} is {size[0]}x{size[1]}, expected {w}x{h} like {files[0].name}"
            )
    spec = CameraSpec(entry.name, "frames", entry.path, entry.offset, entry.modality, (w, h), 0)
    return replace(spec, length=len(files)), files


def _probe_video(entry: _Entry) -> tuple[CameraSpec, float]:
    """The video's camera spec and its own frame rate (nan if unknown)."""
    if not entry.path.is_file():
        raise ClipError(f"{entry.where}: {entry.path} is not a video file")
    cap = cv2.VideoCapture(str(entry.path))
    try:
        ok, frame = cap.read() if cap.isOpened() else (False, None)
        if not ok or frame is None:
            raise ClipError(f"{entry.path}: cannot be read as a video (no frame decodes)")
        length = int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
        if length <= 0:  # the container does not say: count
            length = 1
            while cap.grab():
                length += 1
        fps = float(cap.get(cv2.CAP_PROP_FPS) or math.nan)
    finally:
        cap.release()
    h, w = frame.shape[:2]
    spec = CameraSpec(entry.name, "video", entry.path, entry.offset, entry.modality, (w, h), length)
    return spec, fps


# --------------------------------------------------------------------------------------------
# Streams


class _VideoReader:
    """Sequential frames of one video; wraps the cv2.VideoCapture, the only state it holds."""

    def __init__(self, path: Path) -> None:
        self._path = path
        self._cap = self._open()
        self._next = 0  # stream index of the next frame the capture returns

    def _open(self) -> cv2.VideoCapture:
        cap = cv2.VideoCapture(str(self._path))
        if not cap.isOpened():
            raise ClipError(f"{self._path}: cannot be read as a video")
        return cap

    def read(self, index: int) -> np.ndarray | None:
        """Stream frame ``index``, or None past the stream's end. Going back reopens the video."""
        if index < self._next:
            self._cap.release()
            self._cap, self._next = self._open(), 0
        while self._next < index:  # read and discard: exact for every codec
            if not self._cap.grab():
                return None
            self._next += 1
        ok, frame = self._cap.read()
        self._next += 1
        return frame if ok else None

    def close(self) -> None:
        self._cap.release()


class _FolderReader:
    """Frames of one frame folder, by index."""

    def __init__(self, files: Sequence[Path], modality: str) -> None:
        self._files = files
        self._modality = modality

    def read(self, index: int) -> np.ndarray | None:
        if index >= len(self._files):
            return None
        return _imread(self._files[index], self._modality)

    def close(self) -> None:
        pass


def _display(cam: CameraSpec, root: Path) -> str:
    """A short name of the camera's source for warnings: relative to the clip if inside it."""
    try:
        text = str(cam.source.relative_to(root))
    except ValueError:
        text = str(cam.source)
    return text + ("/" if cam.kind == "frames" else "")


def _common_range(cams: Sequence[CameraSpec], root: Path) -> tuple[int, list[str]]:
    """Clip frames where every video/frames camera has data, and warnings about it."""
    streams = [c for c in cams if c.kind != "detections"]
    if not streams:
        return max(c.length for c in cams), []
    avail = [c.length - c.offset for c in streams]
    n = min(avail)
    describe = [
        f"{_display(c, root)} has {c.length} frames"
        + (f" (from offset {c.offset}: {a})" if c.offset else "")
        for c, a in zip(streams, avail, strict=True)
    ]
    if n <= 0:
        raise ClipError(
            f"{root}: no clip frame where every camera has a frame: {', '.join(describe)}"
        )
    warnings = []
    if len(set(avail)) > 1:
        warnings.append(
            f"streams of different lengths: {', '.join(describe)}: "
            f"using the common range 0..{n - 1}"
        )
    return n, warnings


# --------------------------------------------------------------------------------------------
# The clip


class Clip:
    """An open clip: its validated :class:`ClipSpec` and synchronized, streaming frames.

    Detections CSVs are held in memory (they are small); images are read one frame set at a
    time. Use as a context manager, or call :meth:`close`.
    """

    def __init__(
        self,
        spec: ClipSpec,
        files: Mapping[str, Sequence[Path]],
        detections: Mapping[str, Mapping[int, Detections]],
    ) -> None:
        self.spec = spec
        self._files = files
        self._detections = detections
        self._late: list[str] = []
        self._open: set[_VideoReader | _FolderReader] = set()
        self._lock = threading.Lock()  # held while a frame set is read and while closing
        self._empty = Detections.empty()

    @property
    def warnings(self) -> tuple[str, ...]:
        """``spec.warnings`` plus what reading found (a stream that ended early)."""
        return self.spec.warnings + tuple(self._late)

    def frames(self, frames: range | None = None, prefetch: bool = True) -> Iterator[FrameSet]:
        """Synchronized frame sets for the clip frames in ``frames`` (default: all).

        ``frames`` must lie in ``[0, frame_count)`` with a positive step. Reading starts at
        ``frames.start`` (earlier video frames are decoded and discarded); only the current
        frame set is held, and with ``prefetch`` the next one, decoded on a background thread
        meanwhile. If a stream ends before its header said, iteration stops there and
        :attr:`warnings` says so.

        Raises:
            ClipError: a bad range (at the call), an unreadable frame or a frame of the wrong
                size (while iterating, naming the file and frame).
        """
        n = self.spec.frame_count
        rng = range(n) if frames is None else frames
        if rng.step <= 0 or (len(rng) and (rng[0] < 0 or rng[-1] >= n)):
            raise ClipError(f"{self.spec.root}: frames {rng} outside the clip's 0..{n - 1}")
        return self._iterate(rng, prefetch)

    def _open_readers(self) -> dict[str, _VideoReader | _FolderReader]:
        readers: dict[str, _VideoReader | _FolderReader] = {}
        for cam in self.spec.cameras:
            if cam.kind == "video":
                readers[cam.name] = _VideoReader(cam.source)
            elif cam.kind == "frames":
                readers[cam.name] = _FolderReader(self._files[cam.name], cam.modality)
        self._open.update(readers.values())
        return readers

    def _read_set(self, readers: Mapping[str, _VideoReader | _FolderReader], k: int
                  ) -> dict[str, np.ndarray] | CameraSpec | None:
        """Every camera's image at clip frame ``k``; the camera whose stream ended; None if the
        clip was closed. Raises ClipError for a bad frame."""
        images = {}
        with self._lock:
            for name, reader in readers.items():
                if reader not in self._open:  # the clip was closed
                    return None
                cam = self.spec.camera(name)
                image = reader.read(k + cam.offset)
                if image is None:
                    return cam
                images[name] = _checked(image, cam, k + cam.offset)
        return images

    def _iterate(self, rng: range, prefetch: bool) -> Iterator[FrameSet]:
        readers = self._open_readers()
        pool = ThreadPoolExecutor(1, thread_name_prefix="mvtrack-read") \
            if prefetch and readers and len(rng) > 1 else None
        ahead: Future[dict[str, np.ndarray] | CameraSpec | None] | None = None
        try:
            for i, k in enumerate(rng):
                got = ahead.result() if ahead is not None else self._read_set(readers, k)
                ahead = None
                if got is None or any(r not in self._open for r in readers.values()):
                    return  # the clip was closed
                if isinstance(got, CameraSpec):
                    self._stream_ended(got, k)
                    return
                if pool is not None and i + 1 < len(rng):
                    ahead = pool.submit(self._read_set, readers, rng[i + 1])
                detections = {
                    c.name: self._detections[c.name].get(k, self._empty)
                    for c in self.spec.cameras
                    if c.kind == "detections"
                }
                yield FrameSet(k, got, detections)
        finally:
            if pool is not None:
                pool.shutdown(wait=True)  # no read runs while the readers close
            for reader in readers.values():
                reader.close()
                self._open.discard(reader)

    def _stream_ended(self, cam: CameraSpec, k: int) -> None:
        text = (
            f"{_display(cam, self.spec.root)} ended at stream frame {k + cam.offset} although "
            f"it claims {cam.length} frames: stopping before clip frame {k}"
        )
        self._late.append(text)
        log.warning(text)

    def close(self) -> None:
        """Release every open video (iterators still running then stop reading)."""
        with self._lock:  # not while a background read is running
            for reader in list(self._open):
                reader.close()
            self._open.clear()

    def __enter__(self) -> Clip:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _checked(image: np.ndarray, cam: CameraSpec, index: int) -> np.ndarray:
    """The frame in the camera's modality; ClipError if its size is not the camera's."""
    if cam.modality == "gray" and image.ndim == 3:
        image = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    h, w = image.shape[:2]
    if (w, h) != cam.size:
        raise ClipError(
            f"{cam.source}: frame {index} is {w}x{h}, expected {cam.size[0]}x{cam.size[1]}"
        )
    return image


def _clip_root(path: Path | str) -> Path:
    root = Path(path)
    if root.is_file() and root.name == "clip.toml":
        root = root.parent
    if not root.exists():
        raise ClipError(f"{root}: no such clip directory")
    if not root.is_dir():
        raise ClipError(f"{root}: a clip is a directory (with cameras, optionally clip.toml)")
    return root


def _select(entries: list[_Entry], cameras: Sequence[str] | None, root: Path) -> list[_Entry]:
    names = [e.name for e in entries]
    for name in names:
        if names.count(name) > 1:
            where = " and ".join(e.where for e in entries if e.name == name)
            raise ClipError(f"{root}: camera name {name!r} is used twice ({where})")
    if cameras is None:
        return entries
    if not cameras:
        raise ClipError(f"{root}: no camera selected")
    for name in cameras:
        if name not in names:
            raise ClipError(f"{root}: no camera {name!r} (cameras: {', '.join(names)})")
    return [e for e in entries if e.name in cameras]


def _probe(
    entry: _Entry,
) -> tuple[CameraSpec, float, list[Path], dict[int, Detections] | None]:
    """Probe one declared camera: (spec, own fps or nan, frame files, detections)."""
    if entry.kind == "detections":
        dets = read_detections_csv(entry.path)
        length = max(dets, default=-1) + 1
        assert entry.size is not None
        spec = CameraSpec(
            entry.name, "detections", entry.path, 0, entry.modality, entry.size, length
        )
        return spec, math.nan, [], dets
    if entry.kind == "frames":
        spec, files = _probe_frames(entry)
        fps = math.nan
    else:
        spec, fps = _probe_video(entry)
        files = []
    if entry.size is not None and entry.size != spec.size:
        raise ClipError(
            f"{entry.where}: {entry.path} has frames of {spec.size[0]}x{spec.size[1]}, "
            f"but size = [{entry.size[0]}, {entry.size[1]}]"
        )
    return spec, fps, files, None


def _overlaps(
    declared: list[tuple[str, str]] | None, entries: list[_Entry], chosen: list[str], where: Path
) -> tuple[tuple[str, str], ...]:
    if declared is None:
        return tuple(combinations(chosen, 2))
    names = {e.name for e in entries}
    out: list[tuple[str, str]] = []
    for pair in declared:
        for name in pair:
            if name not in names:
                raise ClipError(
                    f"{where}: [[overlap]] names unknown camera {name!r} "
                    f"(cameras: {', '.join(e.name for e in entries)})"
                )
        if set(pair) <= set(chosen) and not any(set(pair) == set(p) for p in out):
            out.append(pair)
    return tuple(out)


def _late_rows(cams: Sequence[CameraSpec], n: int, root: Path) -> list[str]:
    return [
        f"{_display(c, root)} has rows up to frame {c.length - 1} but the clip has frames "
        f"0..{n - 1}: rows after frame {n - 1} are ignored"
        for c in cams
        if c.kind == "detections" and c.length > n
    ]


def open_clip(path: Path | str, cameras: Sequence[str] | None = None) -> Clip:
    """Open and validate a clip directory (FORMATS.md) before any frame is read.

    Args:
        path: the clip directory (or its clip.toml).
        cameras: names of the cameras to use (in clip order); default all.

    Returns:
        A :class:`Clip`; ``clip.spec`` describes it, ``clip.frames()`` streams it.

    Raises:
        ClipError: naming the file (and key or line) and the problem: bad clip.toml, missing or
            unreadable video, empty frame folder, a frame of the wrong size, unknown camera in an
            overlap, a bad detections row, no common frame range...
    """
    root = _clip_root(path)
    manifest = root / "clip.toml"
    fps, entries, declared = _read_manifest(manifest) if manifest.is_file() else (None, [], None)
    if not entries:
        entries = _discover(root)
    chosen = _select(entries, cameras, root)
    specs, files, detections = [], {}, {}
    for entry in chosen:
        cam, own_fps, files[entry.name], dets = _probe(entry)
        specs.append(cam)
        if dets is not None:
            detections[entry.name] = dets
        if fps is None and math.isfinite(own_fps) and own_fps > 0:
            fps = own_fps
    overlaps = _overlaps(declared, entries, [e.name for e in chosen], manifest)
    n, warnings = _common_range(specs, root)
    if n <= 0:
        raise ClipError(f"{root}: no frames: every detections CSV is empty and there is no video")
    spec = ClipSpec(
        root=root,
        fps=DEFAULT_FPS if fps is None else fps,
        cameras=tuple(specs),
        overlaps=overlaps,
        frame_count=n,
        warnings=tuple(warnings + _late_rows(specs, n, root)),
        truth_dir=root / "truth" if (root / "truth").is_dir() else None,
        params_file=root / "mvtrack.toml" if (root / "mvtrack.toml").is_file() else None,
    )
    return Clip(spec, files, detections)


_RANGE = re.compile(r"\s*(?:(?P<one>\d+)|(?P<start>\d*)\s*:\s*(?P<end>\d*))\s*")


def parse_frame_range(text: str, frame_count: int) -> range:
    """Parse ``--frames``: "100:400" (end exclusive, like Python), "100:", ":50" or "7".

    Args:
        text: the range text; indices are clip frame indices (after offsets).
        frame_count: the clip's ``frame_count``.

    Returns:
        A non-empty ``range`` inside ``[0, frame_count)``.

    Raises:
        ClipError: malformed text, an empty range, or a range past the clip's end.
    """
    m = _RANGE.fullmatch(text)
    if m is None:
        raise ClipError(
            f"--frames {text!r}: expected START:END (END exclusive), START:, :END or FRAME, "
            "with non-negative integers"
        )
    if m["one"] is not None:
        start, end = int(m["one"]), int(m["one"]) + 1
    else:
        start = int(m["start"]) if m["start"] else 0
        end = int(m["end"]) if m["end"] else frame_count
    if start >= end:
        raise ClipError(f"--frames {text!r}: empty range (start {start} >= end {end})")
    if end > frame_count:
        raise ClipError(
            f"--frames {text!r}: the clip has {frame_count} frames (0..{frame_count - 1})"
        )
    return range(start, end)
