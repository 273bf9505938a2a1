"""Writing and reading a results directory (FORMATS.md, `mvtrack track CLIP --out DIR`).

`tracks.csv` is written row by row as frames arrive, so an interrupted run keeps what it did.
`run.json` is written at the end (and says whether the run was interrupted).
:func:`rewrite_tracks` then replaces the online metas with whole-run ones and the per-frame
feet with smoothed ones: the streamed files stay beside them as `tracks_online.csv` and
`cues_online.csv` (same formats).

Optional, beyond FORMATS.md: `masks/<camera>/<frame:06d>.png` every ``mask_every`` frames for
video cameras, uint8 with 0 background, 1 foreground (tracked target pixels), 2 detected cast
shadow: the same coding as `truth/masks`, so evaluation can score the segmentation.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

__all__ = [
    "CUES_HEADER", "TRACKS_HEADER", "CueRows", "LearnedPair", "ResultsWriter", "RowsCollector",
    "TrackRows", "handed_on", "handed_on_lines", "read_cues", "read_pairs", "read_tracks",
    "restore_streamed", "rewrite_tracks", "write_pairs",
]

TRACKS_HEADER = (
    "frame", "camera", "target", "meta", "foot_x", "foot_y",
    "box_x", "box_y", "box_w", "box_h", "height",
)
CUES_HEADER = ("frame", "meta", "camera", "expected", "seen")
_FEET_DP, _BOX_DP, _HEIGHT_DP = 2, 1, 2
"""Decimal places of `tracks.csv`'s feet, box and height columns."""


class ResultsWriter:
    """A sink that streams `tracks.csv` (and optional masks) into ``out_dir``.

    A small class because it owns open files; ``close(run_info)`` writes `run.json`.
    """

    def __init__(self, out_dir: Path, mask_every: int = 0) -> None:
        self.out_dir = Path(out_dir)
        self.out_dir.mkdir(parents=True, exist_ok=True)
        self.mask_every = mask_every
        self._file = (self.out_dir / "tracks.csv").open("w", newline="", encoding="utf-8")
        self._csv = csv.writer(self._file, lineterminator="\n")
        self._csv.writerow(TRACKS_HEADER)
        self._cues_file = (self.out_dir / "cues.csv").open("w", newline="", encoding="utf-8")
        self._cues = csv.writer(self._cues_file, lineterminator="\n")
        self._cues.writerow(CUES_HEADER)

    def on_frame(self, result: Any) -> None:
        """Write one :class:`~mvtrack.pipeline.FrameResult`."""
        for name, cam in result.cameras.items():
            t = cam.targets
            metas = result.metas[name]
            for i, label in enumerate(t.labels.tolist()):
                self._csv.writerow(_track_row(result.index, name, label, int(metas[i]),
                                              (*t.feet[i], *t.boxes_xywh[i], t.heights_px[i])))
            if self.mask_every and result.index % self.mask_every == 0 and cam.background:
                self._write_mask(name, result.index, cam)
        for cue in getattr(result, "cues", ()):
            self._cues.writerow([result.index, cue.meta, cue.camera, int(cue.expected),
                                 int(cue.seen)])
        self._file.flush()
        self._cues_file.flush()

    def _write_mask(self, name: str, index: int, cam: Any) -> None:
        coded = np.zeros(cam.background.mvo_labels.shape, np.uint8)
        coded[cam.background.fg_shadow | cam.background.ghost_shadow] = 2
        coded[cam.tracks.label_image > 0] = 1
        folder = self.out_dir / "masks" / name
        folder.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(folder / f"{index:06d}.png"), coded)

    def close(self, run_info: dict[str, Any], pairs: list[dict[str, Any]] | None = None) -> None:
        """Close `tracks.csv` and write `run.json` (and `pairs.json` when given)."""
        self._file.close()
        self._cues_file.close()
        (self.out_dir / "run.json").write_text(json.dumps(run_info, indent=2) + "\n")
        if pairs is not None:
            write_pairs(self.out_dir, pairs)


class RowsCollector:
    """A sink that keeps every target row in memory as `tracks.csv` would store it (same
    rounding), for whole-run label resolution without a results directory (the viewer)."""

    def __init__(self) -> None:
        self._parts: list[tuple[np.ndarray, ...]] = []

    def on_frame(self, result: Any) -> None:
        """Keep one :class:`~mvtrack.pipeline.FrameResult`'s targets."""
        for name, cam in result.cameras.items():
            t = cam.targets
            n = len(t.labels)
            if n:
                self._parts.append((
                    np.full(n, result.index, np.int64), np.full(n, name), t.labels.astype(np.int64),
                    np.asarray(result.metas[name], np.int64), np.round(t.feet, _FEET_DP),
                    np.round(t.boxes_xywh, _BOX_DP), np.round(t.heights_px, _HEIGHT_DP)))

    def rows(self) -> TrackRows:
        """Every row kept so far, in frame order."""
        if not self._parts:
            return TrackRows(np.zeros(0, np.int64), np.zeros(0, str), np.zeros(0, np.int64),
                             np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 4)),
                             np.zeros(0))
        return TrackRows(*(np.concatenate(col) for col in zip(*self._parts, strict=True)))


def _track_row(frame: int, camera: str, target: int, meta: int,
               numbers: tuple[float, ...]) -> list[Any]:
    """One `tracks.csv` row; ``numbers``: foot_x, foot_y, box_x, box_y, box_w, box_h, height."""
    places = (_FEET_DP,) * 2 + (_BOX_DP,) * 4 + (_HEIGHT_DP,)
    return [frame, camera, target, meta,
            *(f"{v:.{d}f}" for v, d in zip(numbers, places, strict=True))]


def rewrite_tracks(out_dir: Path, rows: TrackRows,
                   cue_meta: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> None:
    """Write `tracks.csv` again as ``rows`` (the rows as read, with whole-run metas and
    smoothed feet), and `cues.csv` with the metas ``cue_meta(frames, online metas)``; the
    originals become `*_online.csv`.

    Cue rows that now name one meta twice in a frame and camera are merged (expected or seen
    by either). Each file is written beside the original, then renamed over it.
    """
    out_dir = Path(out_dir)
    numbers = np.c_[rows.feet, rows.boxes_xywh, rows.height].tolist()
    tracks = [_track_row(f, c, t, m, tuple(n)) for f, c, t, m, n in zip(
        rows.frame.tolist(), rows.camera.tolist(), rows.target.tolist(), rows.meta.tolist(),
        numbers, strict=True)]
    cues = _csv_rows(out_dir / "cues.csv", CUES_HEADER)
    frames = np.array([int(r[0]) for r in cues], np.int64)
    new = cue_meta(frames, np.array([int(r[1]) for r in cues], np.int64))
    merged: dict[tuple[str, int, str], list[int]] = {}
    for r, m in zip(cues, new.tolist(), strict=True):
        flags = merged.setdefault((r[0], m, r[2]), [0, 0])
        flags[0] |= int(r[3])
        flags[1] |= int(r[4])
    _replace(out_dir / "tracks.csv", TRACKS_HEADER, tracks)
    _replace(out_dir / "cues.csv", CUES_HEADER,
             [[f, m, c, *flags] for (f, m, c), flags in merged.items()])


def write_pairs(out_dir: Path, pairs: list[dict[str, Any]]) -> None:
    """Write `pairs.json` (beside any earlier one, then renamed over it)."""
    path = Path(out_dir) / "pairs.json"
    part = path.with_name(path.name + ".part")
    part.write_text(json.dumps(pairs, indent=2) + "\n")
    part.replace(path)


def restore_streamed(out_dir: Path) -> None:
    """Undo :func:`rewrite_tracks`: the streamed `*_online.csv` files become `tracks.csv` and
    `cues.csv` again (nothing to do where they were never rewritten)."""
    for name in ("tracks.csv", "cues.csv"):
        streamed = _streamed(Path(out_dir) / name)
        if streamed.is_file():
            streamed.replace(Path(out_dir) / name)


def _streamed(path: Path) -> Path:
    """Where :func:`rewrite_tracks` keeps the streamed file ``path``: `*_online.csv`."""
    return path.with_name(path.stem + "_online" + path.suffix)


def _replace(path: Path, header: tuple[str, ...], rows: list[list[Any]]) -> None:
    part = path.with_name(path.name + ".part")
    with part.open("w", newline="", encoding="utf-8") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(header)
        w.writerows(rows)
    path.replace(_streamed(path))
    part.replace(path)


@dataclass(frozen=True)
class TrackRows:
    """`tracks.csv` as parallel arrays (N rows)."""

    frame: np.ndarray  # (N,) int64
    camera: np.ndarray  # (N,) str
    target: np.ndarray  # (N,) int64
    meta: np.ndarray  # (N,) int64
    feet: np.ndarray  # (N, 2) float64
    boxes_xywh: np.ndarray  # (N, 4) float64
    height: np.ndarray  # (N,) float64

    def of_camera(self, name: str) -> TrackRows:
        keep = self.camera == name
        return TrackRows(*(getattr(self, f)[keep] for f in self.__dataclass_fields__))


def _csv_rows(path: Path, header: tuple[str, ...]) -> list[list[str]]:
    """The rows of a results CSV after checking its header; errors name the file."""
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no {path.name} here (run `mvtrack track` first)")
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.reader(f)
        found = tuple(next(reader, ()))
        if found != header:
            raise ValueError(f"{path}:1: header {','.join(found)!r}, expected "
                             f"{','.join(header)!r}")
        return list(reader)


def read_tracks(path: Path) -> TrackRows:
    """Read a `tracks.csv`; errors name the file and line."""
    path = Path(path)
    rows = _csv_rows(path, TRACKS_HEADER)
    try:
        cols = list(zip(*rows, strict=True)) if rows else [()] * len(TRACKS_HEADER)
        num = np.array([list(map(float, c)) for i, c in enumerate(cols) if i != 1]).T
    except ValueError as exc:
        raise ValueError(f"{path}: a row is malformed ({exc})") from None
    num = num.reshape(len(rows), len(TRACKS_HEADER) - 1)
    return TrackRows(
        frame=num[:, 0].astype(np.int64),
        camera=np.array(cols[1], dtype=str),
        target=num[:, 1].astype(np.int64),
        meta=num[:, 2].astype(np.int64),
        feet=num[:, 3:5],
        boxes_xywh=num[:, 5:9],
        height=num[:, 9],
    )


@dataclass(frozen=True)
class CueRows:
    """`cues.csv` as parallel arrays (N rows)."""

    frame: np.ndarray  # (N,) int64
    meta: np.ndarray  # (N,) int64
    camera: np.ndarray  # (N,) str
    expected: np.ndarray  # (N,) bool
    seen: np.ndarray  # (N,) bool


def read_cues(path: Path) -> CueRows:
    """Read a `cues.csv`; errors name the file."""
    path = Path(path)
    rows = _csv_rows(path, CUES_HEADER)
    try:
        num = np.array([[int(r[0]), int(r[1]), int(r[3]), int(r[4])] for r in rows],
                       np.int64).reshape(len(rows), 4)
    except (ValueError, IndexError) as exc:
        raise ValueError(f"{path}: a row is malformed ({exc})") from None
    return CueRows(
        frame=num[:, 0], meta=num[:, 1], camera=np.array([r[2] for r in rows], dtype=str),
        expected=num[:, 2] != 0, seen=num[:, 3] != 0,
    )


@dataclass(frozen=True)
class LearnedPair:
    """One pair's geometry as an earlier run learned it (an object of `pairs.json`).

    cameras: (A, B); H_b_from_a: (3, 3) float64 or None, the H the run handed on (its
    ``H_refit`` where that is used, else the H its whole-run labels used: ``H_whole_run``
    where that is used, else ``H``); markers: markers (or candidates) behind it;
    lines: (seen_in, edge_of, side, (a, b, c), events) per learned FOV line (those of the H
    handed on: lines from the pair's H are given again through it)
    """

    cameras: tuple[str, str]
    H_b_from_a: np.ndarray | None
    markers: int
    lines: tuple[tuple[str, str, str, tuple[float, float, float], int], ...]


_SIDES = ("left", "right", "top", "bottom")


def read_pairs(path: Path) -> list[LearnedPair]:
    """Read a `pairs.json` (FORMATS.md); errors name the file, the pair and the key."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such pairs.json (written by `mvtrack track`)")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}:{exc.lineno}: not JSON ({exc.msg})") from None
    if not isinstance(data, list):
        raise ValueError(f"{path}: expected a list of pair objects, got {type(data).__name__}")
    return [_learned_pair(path, k, obj) for k, obj in enumerate(data)]


def _matrix(value: Any, where: str) -> np.ndarray | None:
    """A `pairs.json` homography: a finite 3x3 matrix or null (``where`` names it)."""
    try:
        H = None if value is None else np.asarray(value, np.float64)
    except (TypeError, ValueError):
        H = np.full((0, 0), np.nan)
    if H is not None and (H.shape != (3, 3) or not np.all(np.isfinite(H))):
        raise ValueError(f"{where} must be a finite 3x3 matrix or null")
    return H


def _learned_pair(path: Path, k: int, obj: Any) -> LearnedPair:
    where = f"{path}: pair {k}"
    if not isinstance(obj, dict):
        raise ValueError(f"{where}: expected an object, got {type(obj).__name__}")
    for key in ("cameras", "H"):
        if key not in obj:
            raise ValueError(f"{where}: missing key {key!r}")
    cams = obj["cameras"]
    if not (isinstance(cams, list) and len(cams) == 2 and all(isinstance(c, str) for c in cams)):
        raise ValueError(f"{where}: 'cameras' must be two camera names, got {cams!r}")
    H = _matrix(obj["H"], f"{where}: 'H'")
    markers = int(obj.get("markers", 0))
    lines = _lines(obj.get("fov_lines", []), f"{where}: fov_lines")
    key = handed_on(obj)
    if key != "H":
        H = _matrix(obj[key].get("H"), f"{where}: {key!r} is used, its 'H'")
        markers = int(obj[key].get("markers", obj[key].get("candidates", 0)))
        lines = _lines(handed_on_lines(obj), f"{where}: {key}'s fov_lines")
    return LearnedPair((cams[0], cams[1]), H, markers, lines)


def handed_on(pair: Mapping[str, Any]) -> str:
    """Which homography of a `pairs.json` object the run hands on (what `--geometry` reads and
    `mvtrack eval` scores as ``handed_on_transfer_error_px``): "H_refit" where the refit is
    used, else "H_whole_run" where the whole-run labels used it, else "H"."""
    for key in ("H_refit", "H_whole_run"):
        found = pair.get(key)
        if isinstance(found, dict) and found.get("used"):
            return key
    return "H"


def handed_on_lines(pair: Mapping[str, Any]) -> Any:
    """The FOV line objects a `pairs.json` object hands on: those of its :func:`handed_on` H
    (the pair's own where that H's object has none)."""
    key = handed_on(pair)
    own = pair.get("fov_lines", [])
    return own if key == "H" else pair[key].get("fov_lines", own)


def _lines(entries: Any, where: str) -> tuple[tuple[str, str, str, tuple[float, float, float],
                                                     int], ...]:
    """`pairs.json` FOV line objects as :class:`LearnedPair` lines (``where`` names them)."""
    lines = []
    for j, line in enumerate(entries):
        try:
            coeffs = tuple(float(v) for v in line["line"])
            entry = (str(line["seen_in"]), str(line["edge_of"]), str(line["side"]),
                     int(line["events"]))
        except (KeyError, TypeError, ValueError):
            coeffs, entry = (), ("", "", "", 0)
        if len(coeffs) != 3 or entry[2] not in _SIDES:
            raise ValueError(f"{where}[{j}] needs seen_in, edge_of, side (one of {_SIDES}), "
                             "line [a, b, c] and events")
        lines.append((entry[0], entry[1], entry[2], (coeffs[0], coeffs[1], coeffs[2]), entry[3]))
    return tuple(lines)
