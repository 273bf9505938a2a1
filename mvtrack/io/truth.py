"""Ground-truth reading (FORMATS.md ``truth/``); only evaluation uses it, never the tracker.

    truth = read_truth(clip.spec.root)          # None when the clip has no truth/
    cam = truth.cameras["cam0"]                 # every row of truth/cam0.csv, as arrays
    rows = cam.at(12)                           # the rows of clip frame 12
    H = truth.image_from_ground["cam0"]         # (3, 3): ground (X, Y, 1) -> image (x, y, 1)
    for k in truth.mask_frames("cam0"):
        mask = truth.load_mask("cam0", k)       # (H, W) uint8: 0 background, 1 person, 2 shadow

Files read: ``truth/<camera>.csv``, ``truth/ground.json``, ``truth/world.csv`` and
``truth/masks/<camera>/<frame:06d>.png``; each is optional, other files are ignored. Without an
explicit camera list, a ``truth/*.csv`` (other than world.csv) is a camera's truth when its header
starts with ``frame,person,foot_x``. Malformed files raise :class:`ClipError` naming the file and
the line (or JSON key). Writing truth is the generator's job, not this module's.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from mvtrack.io.detections import ClipError, Column, read_table

__all__ = ["TRUTH_HEADER", "WORLD_HEADER", "CameraTruth", "Truth", "WorldTruth", "read_truth"]

TRUTH_HEADER = (
    "frame", "person", "foot_x", "foot_y", "box_x", "box_y", "box_w", "box_h", "visible",
)  # fmt: skip
WORLD_HEADER = ("frame", "person", "x", "y")
MASK_VALUES = (0, 1, 2)  # background, person, cast shadow of a person

_CAMERA_COLUMNS = (
    Column("frame", "int", lo=0),
    Column("person", "int", lo=0),
    Column("foot_x"),
    Column("foot_y"),
    Column("box_x"),
    Column("box_y"),
    Column("box_w", lo=0),
    Column("box_h", lo=0),
    Column("visible", lo=0, hi=1),
)
# Optional column after FORMATS.md's nine: the share of the silhouette inside the frame
# (mvtrack's generator writes it; without it every row counts as wholly inside).
_IN_FRAME = Column("in_frame", lo=0, hi=1)
_WORLD_COLUMNS = (
    Column("frame", "int", lo=0),
    Column("person", "int", lo=0),
    Column("x"),
    Column("y"),
)
_MASK_NAME = re.compile(r"(\d{6})\.png")


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class CameraTruth:
    """The truth rows of one camera, in file order (arrays are read-only).

    Attributes:
        camera: camera name.
        frame: (N,) int64 clip frame indices.
        person: (N,) int64 person ids (the same id is the same person in every camera).
        foot: (N, 2) float64 image of the ground point under the person's centre of mass, px.
        box_xywh: (N, 4) float64 box of the person's visible pixels (left/top edges, size), px.
        visible: (N,) float64 fraction 0..1 of the silhouette not hidden.
        in_frame: (N,) float64 fraction 0..1 of the silhouette inside the frame (optional
            column ``in_frame``; 1.0 when the file does not have it).
    """

    camera: str
    frame: np.ndarray
    person: np.ndarray
    foot: np.ndarray
    box_xywh: np.ndarray
    visible: np.ndarray
    in_frame: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.in_frame is None:
            object.__setattr__(self, "in_frame", _frozen(np.ones(len(self.frame))))

    @property
    def shown(self) -> np.ndarray:
        """(N,) float64: share of the whole silhouette seen, ``visible * in_frame``."""
        assert self.in_frame is not None
        return self.visible * self.in_frame

    def __len__(self) -> int:
        return int(self.frame.shape[0])

    def at(self, frame: int) -> CameraTruth:
        """The rows of one clip frame (a new record; possibly empty)."""
        rows = np.flatnonzero(self.frame == frame)
        return CameraTruth(
            self.camera,
            _frozen(self.frame[rows]),
            _frozen(self.person[rows]),
            _frozen(self.foot[rows]),
            _frozen(self.box_xywh[rows]),
            _frozen(self.visible[rows]),
            _frozen(self.in_frame[rows]) if self.in_frame is not None else None,
        )


@dataclass(frozen=True)
class WorldTruth:
    """Ground-plane positions (``truth/world.csv``; arrays are read-only).

    Attributes:
        frame: (N,) int64 clip frame indices.
        person: (N,) int64 person ids.
        xy: (N, 2) float64 ground-plane positions in ``Truth.units``.
    """

    frame: np.ndarray
    person: np.ndarray
    xy: np.ndarray

    def __len__(self) -> int:
        return int(self.frame.shape[0])


@dataclass(frozen=True)
class Truth:
    """Everything under a clip's ``truth/``.

    Attributes:
        root: the truth directory.
        cameras: per camera with a ``truth/<camera>.csv``, its rows.
        image_from_ground: per camera in ground.json, the (3, 3) float64 homography taking
            ground points (X, Y, 1) to image points (x, y, 1) (scale kept as stored).
        units: ground-plane units from ground.json ("m"), or None without ground.json.
        world: ``truth/world.csv`` rows, or None if absent.
    """

    root: Path
    cameras: Mapping[str, CameraTruth]
    image_from_ground: Mapping[str, np.ndarray]
    units: str | None
    world: WorldTruth | None

    def mask_frames(self, camera: str) -> tuple[int, ...]:
        """Clip frames with a mask file ``masks/<camera>/<frame:06d>.png``, ascending."""
        folder = self.root / "masks" / camera
        if not folder.is_dir():
            return ()
        found = (_MASK_NAME.fullmatch(p.name) for p in folder.iterdir())
        return tuple(sorted(int(m[1]) for m in found if m))

    def load_mask(self, camera: str, frame: int) -> np.ndarray:
        """The (H, W) uint8 mask of one frame: 0 background, 1 person, 2 cast shadow.

        Raises:
            ClipError: missing or unreadable file, not single-channel uint8, other values.
        """
        path = self.root / "masks" / camera / f"{frame:06d}.png"
        if not path.is_file():
            raise ClipError(f"{path}: no such mask")
        mask = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if mask is None:
            raise ClipError(f"{path}: cannot be read as an image")
        if mask.ndim != 2 or mask.dtype != np.uint8:
            raise ClipError(f"{path}: expected a single-channel uint8 image, got {mask.shape}")
        bad = np.setdiff1d(np.unique(mask), MASK_VALUES)
        if bad.size:
            raise ClipError(f"{path}: mask values must be 0, 1 or 2; found {bad.tolist()}")
        return mask


def _no_duplicates(path: Path, frame: np.ndarray, person: np.ndarray, lines: np.ndarray) -> None:
    order = np.lexsort((lines, person, frame))
    same = (np.diff(frame[order]) == 0) & (np.diff(person[order]) == 0)
    if same.any():
        j = int(np.argmax(same))
        first, again = int(lines[order[j]]), int(lines[order[j + 1]])
        raise ClipError(
            f"{path}:{again}: person {person[order[j]]} appears again in frame "
            f"{frame[order[j]]} (first on line {first})"
        )


def _has_in_frame(path: Path) -> bool:
    try:
        with open(path, encoding="utf-8") as f:
            header = [h.strip() for h in f.readline().split(",")]
    except (OSError, UnicodeDecodeError):
        return False  # read_table reports it
    return header[len(_CAMERA_COLUMNS) : len(_CAMERA_COLUMNS) + 1] == [_IN_FRAME.name]


def _read_camera(path: Path, camera: str) -> CameraTruth:
    extra = (_IN_FRAME,) if _has_in_frame(path) else ()
    t, lines = read_table(path, _CAMERA_COLUMNS + extra)
    _no_duplicates(path, t["frame"], t["person"], lines)
    in_frame = t["in_frame"] if extra else np.ones(len(t["frame"]))
    return CameraTruth(
        camera,
        _frozen(t["frame"]),
        _frozen(t["person"]),
        _frozen(np.stack([t["foot_x"], t["foot_y"]], axis=1)),
        _frozen(np.stack([t["box_x"], t["box_y"], t["box_w"], t["box_h"]], axis=1)),
        _frozen(t["visible"]),
        _frozen(in_frame),
    )


def _read_world(path: Path) -> WorldTruth:
    t, lines = read_table(path, _WORLD_COLUMNS)
    _no_duplicates(path, t["frame"], t["person"], lines)
    xy = np.stack([t["x"], t["y"]], axis=1)
    return WorldTruth(_frozen(t["frame"]), _frozen(t["person"]), _frozen(xy))


def _homography(value: Any, path: Path, key: str) -> np.ndarray:
    ok = (
        isinstance(value, list)
        and len(value) == 3
        and all(isinstance(r, list) and len(r) == 3 for r in value)
        and all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for r in value
            for v in r
        )
    )
    if not ok:
        raise ClipError(f"{path}: {key} must be a 3x3 array of finite numbers")
    H = np.array(value, dtype=np.float64)
    if np.linalg.matrix_rank(H) < 3:
        raise ClipError(f"{path}: {key} is singular")
    return _frozen(H)


def _read_ground(path: Path) -> tuple[str | None, dict[str, np.ndarray]]:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as exc:
        raise ClipError(f"{path}: cannot read: {exc}") from None
    except json.JSONDecodeError as exc:
        raise ClipError(f"{path}:{exc.lineno}: not valid JSON: {exc.msg}") from None
    if not isinstance(data, dict) or not isinstance(data.get("cameras"), dict):
        raise ClipError(f"{path}: expected an object with a `cameras` object")
    units = data.get("units")
    if units is not None and not isinstance(units, str):
        raise ClipError(f'{path}: units must be a string such as "m", got {units!r}')
    out = {}
    for camera, entry in data["cameras"].items():
        key = f"cameras.{camera}.image_from_ground"
        if not isinstance(entry, dict) or "image_from_ground" not in entry:
            raise ClipError(f"{path}: {key} is missing")
        out[camera] = _homography(entry["image_from_ground"], path, key)
    return units, out


def _is_camera_csv(path: Path) -> bool:
    try:
        with open(path, encoding="utf-8") as f:
            return f.readline().replace(" ", "").startswith("frame,person,foot_x")
    except (OSError, UnicodeDecodeError):
        return False


def read_truth(clip_root: Path, cameras: Sequence[str] | None = None) -> Truth | None:
    """Read a clip's ``truth/`` directory; None if it has none.

    Args:
        clip_root: the clip directory.
        cameras: read exactly ``truth/<camera>.csv`` for these cameras (those present), strictly
            checked; default: every ``truth/*.csv`` with a camera-truth header.

    Raises:
        ClipError: a malformed file, naming the file and line (CSV) or key (JSON).
    """
    root = Path(clip_root) / "truth"
    if not root.is_dir():
        return None
    if cameras is None:
        paths = sorted(p for p in root.glob("*.csv") if p.name != "world.csv")
        paths = [p for p in paths if _is_camera_csv(p)]
    else:
        paths = [root / f"{c}.csv" for c in cameras if (root / f"{c}.csv").is_file()]
    per_camera = {p.stem: _read_camera(p, p.stem) for p in paths}
    ground = root / "ground.json"
    units, H = _read_ground(ground) if ground.is_file() else (None, {})
    world = root / "world.csv"
    return Truth(
        root=root,
        cameras=per_camera,
        image_from_ground=H,
        units=units,
        world=_read_world(world) if world.is_file() else None,
    )
