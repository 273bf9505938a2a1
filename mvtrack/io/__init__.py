"""Reading mvtrack's input files (FORMATS.md): clips, detections CSVs and ground truth."""

from mvtrack.io.clip import (
    CameraSpec,
    Clip,
    ClipError,
    ClipSpec,
    FrameSet,
    open_clip,
    parse_frame_range,
)
from mvtrack.io.detections import Detections, read_detections_csv
from mvtrack.io.truth import CameraTruth, Truth, WorldTruth, read_truth

__all__ = [
    "CameraSpec",
    "CameraTruth",
    "Clip",
    "ClipError",
    "ClipSpec",
    "Detections",
    "FrameSet",
    "Truth",
    "WorldTruth",
    "open_clip",
    "parse_frame_range",
    "read_detections_csv",
    "read_truth",
]
