"""Opening a clip (FORMATS.md): its validated cameras and their synchronized frames.

    with open_clip("my_clip", cameras=["cam0", "cam1"]) as clip:
        for fs in clip.frames(parse_frame_range("100:400", clip.spec.frame_count)):
            fs.images["cam0"]        # (H, W, 3) uint8 BGR, or (H, W) uint8 for a gray camera
            fs.detections["View_5"]  # Detections of a camera given as a detections CSV

:func:`open_clip` validates everything it can before any frame is read (manifest keys, camera
names, sources, the first frame's size of every stream, every detections row) and raises a
:class:`ClipError` naming the file (and line or key) and the problem. Streams of different lengths
are not an error: the clip is their common range, and :attr:`ClipSpec.warnings` says so.
:mod:`mvtrack.io.manifest` reads the declared cameras, :mod:`mvtrack.io.streams` probes and reads
their frames; the decisions about each are documented there.

Decisions beyond FORMATS.md (documented here, tested in tests/test_clip.py):

- The clip range is the frames where every video/frames camera has a frame. A detections camera
  has data in every frame (a frame without rows has no detections) and does not shorten the clip;
  rows past the clip's end are ignored with a warning. A clip of detections cameras only lasts
  until the last row of any camera.
- A stream that ends earlier than its header said while reading stops the iteration cleanly;
  :attr:`Clip.warnings` then says where (and it is logged).
- :meth:`Clip.frames` decodes the next frame set on a background thread while the caller works
  on the current one; frames, errors and warnings arrive exactly as without it
  (``prefetch=False``), each error at the frame set it belongs to.
"""

from __future__ import annotations

import logging
import math
import re
import threading
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

from mvtrack.io.detections import ClipError, Detections, read_detections_csv
from mvtrack.io.manifest import (
    RESERVED_NAMES,
    VIDEO_EXTENSIONS,
    Entry,
    declared_cameras,
    resolve_overlaps,
    select_cameras,
)
from mvtrack.io.streams import (
    IMAGE_EXTENSIONS,
    FolderReader,
    Reader,
    VideoReader,
    probe_frames,
    probe_video,
    read_ahead,
)

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

DEFAULT_FPS = 25.0


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
# The clip range


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
        self._open: set[Reader] = set()
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

    def _open_readers(self) -> dict[str, Reader]:
        readers: dict[str, Reader] = {}
        for cam in self.spec.cameras:
            if cam.kind == "video":
                readers[cam.name] = VideoReader(cam.source)
            elif cam.kind == "frames":
                readers[cam.name] = FolderReader(self._files[cam.name], cam.modality)
        self._open.update(readers.values())
        return readers

    def _read_set(
        self, readers: Mapping[str, Reader], k: int
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

        def read(k: int) -> dict[str, np.ndarray] | CameraSpec | None:
            return self._read_set(readers, k)

        def more(got: dict[str, np.ndarray] | CameraSpec | None) -> bool:
            return isinstance(got, dict) and all(r in self._open for r in readers.values())

        sets = read_ahead(read, rng, prefetch and bool(readers), more)
        try:
            for k, got in sets:
                if got is None or any(r not in self._open for r in readers.values()):
                    return  # the clip was closed
                if isinstance(got, CameraSpec):
                    self._stream_ended(got, k)
                    return
                detections = {
                    c.name: self._detections[c.name].get(k, self._empty)
                    for c in self.spec.cameras
                    if c.kind == "detections"
                }
                yield FrameSet(k, got, detections)
        finally:
            sets.close()  # waits for a background read: none runs while the readers close
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


def _probe(entry: Entry) -> tuple[CameraSpec, float, list[Path], dict[int, Detections] | None]:
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
        info = probe_frames(entry.path, entry.modality)
    else:
        info = probe_video(entry.path, entry.where)
    if entry.size is not None and entry.size != info.size:
        raise ClipError(
            f"{entry.where}: {entry.path} has frames of {info.size[0]}x{info.size[1]}, "
            f"but size = [{entry.size[0]}, {entry.size[1]}]"
        )
    spec = CameraSpec(
        entry.name, entry.kind, entry.path, entry.offset, entry.modality, info.size, info.length
    )
    return spec, info.fps, list(info.files), None


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
    fps, entries, declared = declared_cameras(root)
    chosen = select_cameras(entries, cameras, root)
    specs, files, detections = [], {}, {}
    for entry in chosen:
        cam, own_fps, files[entry.name], dets = _probe(entry)
        specs.append(cam)
        if dets is not None:
            detections[entry.name] = dets
        if fps is None and math.isfinite(own_fps) and own_fps > 0:
            fps = own_fps
    overlaps = resolve_overlaps(declared, entries, [e.name for e in chosen], root / "clip.toml")
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


_RANGE = re.compile(r"\s*(?:(?P<count>\d+)|(?P<start>\d*)\s*:\s*(?P<end>\d*))\s*")


def parse_frame_range(text: str, frame_count: int) -> range:
    """Parse ``--frames``: "100:400" (end exclusive, like Python), "100:", ":50", or "50", the
    first 50 frames (a count, as ``--frames`` is for ``generate``, ``sweep`` and ``bench``).

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
            f"--frames {text!r}: expected START:END (END exclusive), START:, :END or COUNT "
            "(the first COUNT frames), with non-negative integers"
        )
    if m["count"] is not None:
        start, end = 0, int(m["count"])
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
