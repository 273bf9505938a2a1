"""`mvtrack bench`'s front-end timing on a small hand-built clip (figures only, no speeds)."""

from __future__ import annotations

import numpy as np

from mvtrack.bench import bench_frontend, run_frontend
from mvtrack.params import load_params
from mvtrack.stages.background import train_background


def _frames(n: int) -> list[np.ndarray]:
    """A textured ground with a 14x30 red walker crossing it 3 px a frame."""
    rng = np.random.default_rng(0)
    ground = np.clip(np.array([60, 140, 90]) + rng.normal(0, 6, (96, 128, 1)), 0, 255)
    out = []
    for t in range(n):
        frame = ground.copy()
        frame[40:70, 5 + 3 * t : 19 + 3 * t] = (40, 40, 200)
        out.append(np.clip(frame + rng.normal(0, 1.5, frame.shape), 0, 255).astype(np.uint8))
    return out


def test_bench_times_the_front_end_apart_from_its_training() -> None:
    params = load_params(None, ("background.train_frames=10",))
    frames = _frames(30)
    row = bench_frontend("tiny", frames, "rgb", params, repeats=1).as_dict()
    assert row["clip"] == "tiny" and row["size"] == "128x96" and row["frames"] == 30
    for key in ("mog2_fps", "background_fps", "frontend_fps", "train_s"):
        assert row[key] > 0, key
    assert row["memory_growth"] > 0
    # the front end from a trained state finds the walker on every frame
    trained = train_background(frames[::3], "rgb", params.background)
    assert run_frontend(frames, params, trained) == 30  # one target a frame
