"""Frame sources: probing and reading videos and frame folders, and reading ahead.

:func:`probe_video` and :func:`probe_frames` check a source before any frame is read and say its
frame size and length; :class:`VideoReader` and :class:`FolderReader` return its frames by stream
index; :func:`read_ahead` overlaps reading the next frame set with the caller's work. Every
problem raises a :class:`ClipError` naming the file.

Decisions beyond FORMATS.md (documented here, tested in tests/test_clip.py):

- Frame folders are ordered by file name, digit runs compared as numbers (``9.png`` before
  ``10.png``; zero-padded names sort the same either way). Hidden files and files that are not
  images are ignored; ``.jpg`` and ``.jpeg`` are one family, and families cannot be mixed.
- Video frame counts come from the container header. A stream that ends earlier while reading
  reads as None there (:class:`mvtrack.io.clip.Clip` then stops and warns).
- Seeking to a range's start reads and discards frames (``grab``), which is exact for every codec
  (``CAP_PROP_POS_FRAMES`` is not).
- :func:`read_ahead` reads the next frame set on a background thread while the caller works on
  the current one (decoding releases the GIL); values and errors arrive exactly as without it,
  each error at the index it belongs to.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Callable, Generator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO, TypeVar

import cv2
import numpy as np

from mvtrack.io.detections import ClipError

__all__ = [
    "IMAGE_EXTENSIONS",
    "FolderReader",
    "Reader",
    "StreamInfo",
    "VideoReader",
    "probe_frames",
    "probe_video",
    "read_ahead",
]

IMAGE_EXTENSIONS = (".png", ".jpg", ".jpeg", ".bmp")
_FAMILY = {".png": "png", ".jpg": "jpeg", ".jpeg": "jpeg", ".bmp": "bmp"}

T = TypeVar("T")


@dataclass(frozen=True)
class StreamInfo:
    """What probing a video or frame folder found.

    Attributes:
        size: (width, height) in pixels of the first frame.
        length: frames in the stream.
        fps: the video's own frame rate (nan for a frame folder or if the container has none).
        files: a frame folder's image files in frame order (empty for a video).
    """

    size: tuple[int, int]
    length: int
    fps: float
    files: tuple[Path, ...]


# --------------------------------------------------------------------------------------------
# Probing


def probe_frames(folder: Path, modality: str) -> StreamInfo:
    """Probe a frame folder: its first image is decoded, the others' sizes read from headers.

    ``modality`` is "rgb" or "gray". ClipError if the folder has no images, mixes image types,
    the first image does not decode, or a header gives another size.
    """
    files = _list_frames(folder)
    h, w = _imread(files[0], modality).shape[:2]
    for i, path in enumerate(files[1:], start=1):
        size = _image_size(path)
        if size is not None and size != (w, h):
            raise ClipError(
                f"{path}: frame {i} is {size[0]}x{size[1]}, expected {w}x{h} like {files[0].name}"
            )
    return StreamInfo((w, h), len(files), math.nan, tuple(files))


def probe_video(path: Path, where: str) -> StreamInfo:
    """Probe a video file: its first frame is decoded, its length read from the header (or
    counted if the header has none). ``where`` names the declaration for messages."""
    if not path.is_file():
        raise ClipError(f"{where}: {path} is not a video file")
    cap = cv2.VideoCapture(str(path))
    try:
        ok, frame = cap.read() if cap.isOpened() else (False, None)
        if not ok or frame is None:
            raise ClipError(f"{path}: cannot be read as a video (no frame decodes)")
        length = int(cap.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
        if length <= 0:  # the container does not say: count
            length = 1
            while cap.grab():
                length += 1
        fps = float(cap.get(cv2.CAP_PROP_FPS) or math.nan)
    finally:
        cap.release()
    h, w = frame.shape[:2]
    return StreamInfo((w, h), length, fps, ())


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


# --------------------------------------------------------------------------------------------
# Reading


class VideoReader:
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


class FolderReader:
    """Frames of one frame folder, by index."""

    def __init__(self, files: Sequence[Path], modality: str) -> None:
        self._files = files
        self._modality = modality

    def read(self, index: int) -> np.ndarray | None:
        """Frame ``index`` in the folder's modality, or None past the last file."""
        if index >= len(self._files):
            return None
        return _imread(self._files[index], self._modality)

    def close(self) -> None:
        pass


Reader = VideoReader | FolderReader


def read_ahead(
    read: Callable[[int], T], indices: range, prefetch: bool, more: Callable[[T], bool]
) -> Generator[tuple[int, T], None, None]:
    """``(k, read(k))`` for each ``k`` in ``indices``, in order.

    With ``prefetch`` the next ``read`` runs on a background thread while the caller works on
    the current value, unless ``more`` says the current value is the last one wanted. An error
    of ``read`` is raised at the index it belongs to. Closing the iterator waits for a running
    ``read``: close it before releasing what ``read`` uses.
    """
    pool = (
        ThreadPoolExecutor(1, thread_name_prefix="mvtrack-read")
        if prefetch and len(indices) > 1
        else None
    )
    ahead: Future[T] | None = None
    try:
        for i, k in enumerate(indices):
            got = ahead.result() if ahead is not None else read(k)
            ahead = None
            if pool is not None and i + 1 < len(indices) and more(got):
                ahead = pool.submit(read, indices[i + 1])
            yield k, got
    finally:
        if pool is not None:
            pool.shutdown(wait=True)  # no read runs after the iterator is closed
