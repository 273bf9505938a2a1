"""`mvtrack bench`: throughput and memory of the front end against OpenCV's MOG2, in one run.

Frames are decoded into memory first, so decoding is not timed; OpenCV runs on one thread.
Each figure is a ratio against a baseline measured in the same run on the same frames, which
is what the targets are stated in (wall-clock numbers alone mean little on a shared machine).
"""

from __future__ import annotations

import time
import tracemalloc
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from mvtrack.params import Params
from mvtrack.stages.background import (
    BackgroundState,
    background_step,
    train_background,
    training_offsets,
)
from mvtrack.stages.blobtrack import track_masks, tracker_init
from mvtrack.stages.feet import FeetState, feet_step

__all__ = ["FrontEndBench", "bench_frontend", "mog2_baseline", "run_frontend"]


def mog2_baseline(frames: Sequence[np.ndarray], params: Params) -> int:
    """MOG2 (with its shadow detection) + the same opening + connected components.

    Returns the number of blobs found, so the work cannot be optimized away.
    """
    mog = cv2.createBackgroundSubtractorMOG2(detectShadows=True)
    k = params.background.open_kernel_px
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))
    blobs = 0
    for frame in frames:
        fg = mog.apply(frame)
        fg = cv2.morphologyEx((fg == 255).view(np.uint8), cv2.MORPH_OPEN, kernel)
        n, _, _, _ = cv2.connectedComponentsWithStats(fg, connectivity=8)
        blobs += n - 1
    return blobs


def run_frontend(frames: Sequence[np.ndarray], params: Params, bg: BackgroundState,
                 full: bool = True) -> int:
    """mvtrack's front end from the trained state ``bg``: background subtraction, and with
    ``full`` the tracker and feet."""
    tracker, feet_state = tracker_init(), FeetState()
    targets = 0
    for frame in frames:
        bg, res = background_step(bg, frame, params.background)
        if full:
            tracker, tracks = track_masks(tracker, res.mvo_labels, frame, params.tracker, bg.sizes)
            feet_state, feet = feet_step(feet_state, tracks, params.feet, bg.sizes)
            targets += len(feet)
        else:
            targets += len(res.blobs)
    return targets


def _seconds(fn: Callable[[], Any], repeats: int) -> float:
    """Best of ``repeats`` runs: the least disturbed by the other processes on the machine."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


@dataclass(frozen=True)
class FrontEndBench:
    """Camera-frames per second of each contender on the same frames, memory growth, and the
    seconds mvtrack's training takes once per run (the median of the training frames and a
    first size model from them; MOG2 has none)."""

    name: str
    size: tuple[int, int]
    frames: int
    mog2_fps: float
    background_fps: float
    frontend_fps: float
    memory_growth: float  # traced peak over all frames / over the first third (1.0 = flat)
    train_s: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "clip": self.name,
            "size": f"{self.size[0]}x{self.size[1]}",
            "frames": self.frames,
            "mog2_fps": round(self.mog2_fps, 1),
            "background_fps": round(self.background_fps, 1),
            "frontend_fps": round(self.frontend_fps, 1),
            "background_vs_mog2": round(self.background_fps / self.mog2_fps, 3),
            "frontend_vs_mog2": round(self.frontend_fps / self.mog2_fps, 3),
            "memory_growth": round(self.memory_growth, 3),
            "train_s": round(self.train_s, 2),
        }


def _traced_peak(fn: Callable[[], Any]) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def bench_frontend(name: str, frames: Sequence[np.ndarray], modality: str, params: Params,
                   repeats: int = 2) -> FrontEndBench:
    """Time MOG2 and mvtrack's front end on ``frames`` (BGR or gray uint8, all one size)."""
    previous_threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        train = [frames[i] for i in training_offsets(len(frames), params.background)]
        start = time.perf_counter()
        trained = train_background(train, modality, params.background)
        train_s = time.perf_counter() - start
        n = len(frames)
        mog = _seconds(lambda: mog2_baseline(frames, params), repeats)
        bg = _seconds(lambda: run_frontend(frames, params, trained, full=False), repeats)
        full = _seconds(lambda: run_frontend(frames, params, trained), repeats)
        third = max(1, n // 3)
        short = _traced_peak(lambda: run_frontend(frames[:third], params, trained))
        whole = _traced_peak(lambda: run_frontend(frames, params, trained))
    finally:
        cv2.setNumThreads(previous_threads)
    h, w = frames[0].shape[:2]
    return FrontEndBench(name, (w, h), n, n / mog, n / bg, n / full, whole / max(short, 1),
                         train_s)
