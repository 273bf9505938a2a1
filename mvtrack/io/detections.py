"""Detections CSV reading (FORMATS.md) and the validated CSV table reader shared by ``truth``.

A camera may be given as the output of any detector/tracker instead of pixels:

    frame,x,y,w,h,score,foot_x,foot_y,track
    12,100.5,80.5,30,90,0.93,,,
    12,300.5,60.5,25,70,,315.0,130.0,4

``frame`` is a 0-based clip frame index, ``x,y,w,h`` the box (left/top edges and size, pixel
centres at integer coordinates), ``score``, ``foot_x,foot_y`` and ``track`` may be empty.
:func:`read_detections_csv` reads a whole file, validates every row and returns one
:class:`Detections` per frame that has rows. Errors are :class:`ClipError`s naming the file, the
line number (the header is line 1) and the column.

The header must start with exactly the nine columns above, in that order; further columns
(FORMATS.md allows adding optional columns) are ignored.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

__all__ = ["DETECTIONS_HEADER", "ClipError", "Column", "Detections", "read_detections_csv"]

DETECTIONS_HEADER = ("frame", "x", "y", "w", "h", "score", "foot_x", "foot_y", "track")


class ClipError(ValueError):
    """Bad clip input; the message names the file (and line/key) and what was expected."""


def _frozen(array: np.ndarray) -> np.ndarray:
    array.flags.writeable = False
    return array


@dataclass(frozen=True)
class Detections:
    """The detections of one camera in one frame (arrays are read-only).

    Attributes:
        boxes_xywh: (N, 4) float64 boxes ``[x, y, w, h]`` in pixels (left/top edges, size).
        scores: (N,) float64 detector scores; nan where the CSV left ``score`` empty.
        feet: (N, 2) float64 foot points ``[x, y]`` in pixels; nan rows where the CSV left them
            empty (the feet stage then uses the box's bottom centre).
        tracks: (N,) int64 external single-camera track ids; -1 where empty.
    """

    boxes_xywh: np.ndarray
    scores: np.ndarray
    feet: np.ndarray
    tracks: np.ndarray

    @classmethod
    def empty(cls) -> Detections:
        """No detections: arrays of length 0 with the documented shapes and dtypes."""
        return cls(
            _frozen(np.zeros((0, 4))),
            _frozen(np.zeros(0)),
            _frozen(np.zeros((0, 2))),
            _frozen(np.zeros(0, np.int64)),
        )

    def __len__(self) -> int:
        return int(self.boxes_xywh.shape[0])


@dataclass(frozen=True)
class Column:
    """One column of a validated CSV table.

    ``kind`` "int" parses base-10 integers (empty -> -1 when optional), "float" parses finite
    floats (empty -> nan when optional). ``lo``/``hi`` are inclusive bounds; ``positive`` demands
    a value > 0.
    """

    name: str
    kind: Literal["int", "float"] = "float"
    optional: bool = False
    lo: float | None = None
    hi: float | None = None
    positive: bool = False


def _parse_cell(text: str, col: Column) -> float | int:
    """The value of one cell, or raise ValueError saying what was expected."""
    text = text.strip()
    if text == "":
        if col.optional:
            return -1 if col.kind == "int" else math.nan
        raise ValueError("is empty; a value is required")
    try:
        value: float | int = int(text) if col.kind == "int" else float(text)
    except ValueError:
        expected = "an integer" if col.kind == "int" else "a number"
        raise ValueError(f"expected {expected}, got {text!r}") from None
    if not math.isfinite(value):
        raise ValueError(f"expected a finite number, got {text!r}")
    if col.positive and value <= 0:
        raise ValueError(f"expected a value > 0, got {text!r}")
    if col.lo is not None and value < col.lo:
        raise ValueError(f"expected a value >= {col.lo}, got {text!r}")
    if col.hi is not None and value > col.hi:
        raise ValueError(f"expected a value <= {col.hi}, got {text!r}")
    return value


def _parse_row(
    path: Path, line: int, row: list[str], columns: Sequence[Column]
) -> list[float | int]:
    if len(row) < len(columns):
        raise ClipError(
            f"{path}:{line}: expected {len(columns)} columns "
            f"({','.join(c.name for c in columns)}), got {len(row)}"
        )
    out = []
    for cell, col in zip(row, columns, strict=False):
        try:
            out.append(_parse_cell(cell, col))
        except ValueError as exc:
            raise ClipError(f"{path}:{line}: column {col.name!r} {exc}") from None
    return out


def read_table(path: Path, columns: Sequence[Column]) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Read a CSV whose header starts with ``columns``; validate every row.

    Blank lines are skipped; columns after the listed ones are ignored.

    Returns:
        ``(table, lines)``: ``table[name]`` is an (N,) int64 or float64 array per column,
        ``lines`` the (N,) int64 1-based line number of every row (for later error messages).

    Raises:
        ClipError: naming the file, the line and the column of the first bad cell.
    """
    names = [c.name for c in columns]
    values: list[list[float | int]] = []
    lines: list[int] = []
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.reader(f)
            header = next(reader, None)
            if header is None or [h.strip() for h in header[: len(names)]] != names:
                got = "an empty file" if header is None else ",".join(header)
                raise ClipError(f"{path}:1: header must start with {','.join(names)}; got {got}")
            for row in reader:
                if all(cell.strip() == "" for cell in row):
                    continue
                values.append(_parse_row(path, reader.line_num, row, columns))
                lines.append(reader.line_num)
    except OSError as exc:
        raise ClipError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise ClipError(f"{path}: not a UTF-8 text file") from None
    except csv.Error as exc:
        raise ClipError(f"{path}: not a valid CSV file: {exc}") from None
    table = {}
    for j, col in enumerate(columns):
        dtype = np.int64 if col.kind == "int" else np.float64
        table[col.name] = np.array([v[j] for v in values], dtype=dtype)
    return table, np.array(lines, dtype=np.int64)


_DETECTION_COLUMNS = (
    Column("frame", "int", lo=0),
    Column("x"),
    Column("y"),
    Column("w", positive=True),
    Column("h", positive=True),
    Column("score", optional=True),
    Column("foot_x", optional=True),
    Column("foot_y", optional=True),
    Column("track", "int", optional=True, lo=0),
)


def read_detections_csv(path: Path) -> dict[int, Detections]:
    """Read and validate a whole detections CSV (FORMATS.md).

    Args:
        path: the CSV file.

    Returns:
        ``{clip frame index: Detections}`` for every frame that has at least one row, rows kept
        in file order. Frames without rows are absent (they have no detections).

    Raises:
        ClipError: unreadable file, wrong header, or a bad row; the message names the file, the
            line and the column (``foot_x`` and ``foot_y`` must be both given or both empty).
    """
    path = Path(path)
    table, lines = read_table(path, _DETECTION_COLUMNS)
    half = np.isnan(table["foot_x"]) != np.isnan(table["foot_y"])
    if half.any():
        line = int(lines[np.argmax(half)])
        raise ClipError(f"{path}:{line}: foot_x and foot_y must be both given or both empty")
    frame = table["frame"]
    if frame.size == 0:
        return {}
    boxes = np.stack([table[k] for k in ("x", "y", "w", "h")], axis=1)
    feet = np.stack([table["foot_x"], table["foot_y"]], axis=1)
    order = np.argsort(frame, kind="stable")
    frames, first = np.unique(frame[order], return_index=True)
    out: dict[int, Detections] = {}
    for f, rows in zip(frames, np.split(order, first[1:]), strict=True):
        out[int(f)] = Detections(
            _frozen(boxes[rows]),
            _frozen(table["score"][rows]),
            _frozen(feet[rows]),
            _frozen(table["track"][rows]),
        )
    return out
