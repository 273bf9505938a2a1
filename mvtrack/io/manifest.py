"""A clip's declared cameras: ``clip.toml`` (FORMATS.md), or discovery when it declares none.

Nothing here opens a video or an image: an :class:`Entry` is a camera as declared, and
:mod:`mvtrack.io.clip` probes its source. Every problem raises a :class:`ClipError` naming the
file, the table and the key.

Decisions beyond FORMATS.md (documented here, tested in tests/test_clip.py):

- ``offset`` is the index in the stream of clip frame 0, so it must be >= 0: a camera that starts
  later than the others is expressed by positive offsets on the others. Clip frame ``k`` of a
  camera is its stream frame ``k + offset``.
- The frames of a detections CSV are clip frame indices (FORMATS.md: every frame index is a clip
  index), so a detections camera takes no ``offset`` (or ``offset = 0``).
- A ``clip.toml`` without ``[[camera]]`` tables discovers the cameras as if it were absent (its
  ``fps`` and ``[[overlap]]`` still apply). ``size`` may also be given for a video/frames camera;
  the stream must then have that size (checked when the source is probed).
- Without ``[[overlap]]`` tables every pair of cameras overlaps; a declared pair naming a camera
  that was not selected is dropped, one naming an unknown camera is an error.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path
from typing import Any, Literal

from mvtrack.io.detections import ClipError

__all__ = [
    "RESERVED_NAMES",
    "VIDEO_EXTENSIONS",
    "Entry",
    "declared_cameras",
    "resolve_overlaps",
    "select_cameras",
]

VIDEO_EXTENSIONS = (".mp4", ".avi", ".mkv", ".mov")
RESERVED_NAMES = ("truth", "results", "detections")
_TOP_KEYS = ("fps", "camera", "overlap")
_CAMERA_KEYS = ("name", "source", "detections", "offset", "modality", "size")
_OVERLAP_KEYS = ("cameras",)
_BAD_NAME_CHARS = set(',"/\\\n\r\t')


@dataclass(frozen=True)
class Entry:
    """A camera as declared, before its source is probed."""

    name: str
    path: Path
    kind: Literal["video", "frames", "detections"]
    offset: int = 0
    modality: Literal["rgb", "gray"] = "rgb"
    size: tuple[int, int] | None = None
    where: str = ""  # for messages: "clip.toml [[camera]] 'cam0'" or the discovered path


def declared_cameras(
    root: Path,
) -> tuple[float | None, list[Entry], list[tuple[str, str]] | None]:
    """The clip's (fps or None, cameras, declared overlaps or None).

    The cameras are those of ``root/clip.toml`` if it declares any, else those discovered at the
    top level of ``root``.
    """
    manifest = root / "clip.toml"
    fps, entries, overlaps = _read_manifest(manifest) if manifest.is_file() else (None, [], None)
    return fps, entries or _discover(root), overlaps


def select_cameras(entries: list[Entry], cameras: Sequence[str] | None, root: Path) -> list[Entry]:
    """The entries named in ``cameras`` (in clip order; all if None); ClipError for a duplicate
    camera name, an empty selection or an unknown name."""
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


def resolve_overlaps(
    declared: list[tuple[str, str]] | None, entries: list[Entry], chosen: list[str], where: Path
) -> tuple[tuple[str, str], ...]:
    """The overlapping pairs among the ``chosen`` camera names, without repeats.

    Args:
        declared: the ``[[overlap]]`` pairs, or None if the clip declares none (every pair).
        entries: every camera of the clip (a pair may only name these).
        chosen: names of the selected cameras, in clip order.
        where: the clip.toml, for messages.
    """
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


def _camera_entry(table: Any, root: Path, where: str) -> Entry:
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
        return Entry(name, path, "detections", 0, modality, size, where)
    return Entry(name, path, _kind_of(path), offset, modality, size, where)


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
) -> tuple[float | None, list[Entry], list[tuple[str, str]] | None]:
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


def _discover(root: Path) -> list[Entry]:
    """Cameras of a clip without a manifest: top-level videos and image folders, by name."""
    entries = []
    for path in sorted(root.iterdir(), key=lambda p: p.name):
        if path.name.startswith(".") or path.name in RESERVED_NAMES:
            continue
        if path.is_dir() or (path.is_file() and path.suffix.lower() in VIDEO_EXTENSIONS):
            name = _check_name(path.stem if path.is_file() else path.name, str(path))
            entries.append(Entry(name, path, _kind_of(path), where=str(path)))
    if not entries:
        raise ClipError(
            f"{root}: no cameras: no clip.toml, no video ({' '.join(VIDEO_EXTENSIONS)}) "
            "and no frame folder at the top level"
        )
    return entries
