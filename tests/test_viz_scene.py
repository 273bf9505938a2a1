"""A tiny two-camera scene for the viewer tests: walkers over a textured ground, with truth.

Camera B sees the ground through a fixed homography of camera A's view (a ground plane seen
from two places), so FOV lines, markers and a homography can be learned from it. Frames are
PNG folders (lossless, fast to read); ``truth/`` holds the feet of every walker.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

SIZE = (320, 240)
H_B_FROM_A = np.array([[0.9, 0.08, 40.0], [-0.05, 0.95, 10.0], [0.0, 0.0002, 1.0]])


def _walkers(n_frames: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(start, velocity) of each walker's feet in camera A, px and px/frame."""
    w, h = SIZE
    return [
        (np.array([-20.0, 120.0]), np.array([w / n_frames * 1.6, 0.3])),
        (np.array([w + 20.0, 200.0]), np.array([-w / n_frames * 1.4, -0.2])),
        (np.array([150.0, h + 40.0]), np.array([0.2, -h / n_frames * 1.3])),
    ]


def _texture(seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    w, h = SIZE
    small = rng.integers(60, 200, size=(h // 8, w // 8, 3), dtype=np.uint8)
    return cv2.resize(small, (w, h), interpolation=cv2.INTER_CUBIC)


def _project(H: np.ndarray, xy: np.ndarray) -> np.ndarray:
    p = H @ np.array([xy[0], xy[1], 1.0])
    return p[:2] / p[2]


def write_scene_clip(root: Path, n_frames: int = 60, truth: bool = True) -> Path:
    """Write the clip (cam0 and cam1 as PNG folders, clip.toml, truth/) and return ``root``."""
    colours = [(40, 40, 220), (220, 60, 40), (40, 200, 60)]
    backs = {"cam0": _texture(1), "cam1": _texture(2)}
    maps = {"cam0": np.eye(3), "cam1": H_B_FROM_A}
    rows: dict[str, list[str]] = {"cam0": [], "cam1": []}
    world: list[str] = []
    for cam in backs:
        (root / cam).mkdir(parents=True, exist_ok=True)
    walkers = _walkers(n_frames)
    for t in range(n_frames):
        for cam, back in backs.items():
            img = back.copy()
            for pid, (start, vel) in enumerate(walkers, start=1):
                foot = _project(maps[cam], start + t * vel)
                if cam == "cam0":
                    xy = (start + t * vel) / 40.0
                    world.append(f"{t},{pid},{xy[0]:.4f},{xy[1]:.4f}")
                x0, x1 = round(float(foot[0]) - 8), round(float(foot[0]) + 8)
                y0, y1 = round(float(foot[1]) - 44), round(float(foot[1]))
                cv2.rectangle(img, (x0, y0), (x1, y1), colours[pid - 1], thickness=-1)
                inside = x1 >= 0 and x0 < SIZE[0] and y1 >= 0 and y0 < SIZE[1]
                if inside:
                    rows[cam].append(f"{t},{pid},{foot[0]:.2f},{foot[1]:.2f},"
                                     f"{x0 - 0.5},{y0 - 0.5},{x1 - x0 + 1},{y1 - y0 + 1},1.0")
            cv2.imwrite(str(root / cam / f"{t:06d}.png"), img)
    (root / "clip.toml").write_text(
        'fps = 25.0\n\n[[camera]]\nname = "cam0"\nsource = "cam0"\n\n'
        '[[camera]]\nname = "cam1"\nsource = "cam1"\n'
    )
    if truth:
        (root / "truth").mkdir(exist_ok=True)
        for cam, lines in rows.items():
            (root / "truth" / f"{cam}.csv").write_text(
                "frame,person,foot_x,foot_y,box_x,box_y,box_w,box_h,visible\n"
                + "".join(line + "\n" for line in lines))
        # ground = camera A's pixels / 40 (metres), so image_from_ground of A is a scaling
        g_a = np.diag([40.0, 40.0, 1.0])
        ground = {"units": "m", "cameras": {"cam0": g_a.tolist(),
                                             "cam1": (H_B_FROM_A @ g_a).tolist()}}
        ground = {"units": "m", "cameras": {k: {"image_from_ground": v}
                                             for k, v in ground["cameras"].items()}}
        (root / "truth" / "ground.json").write_text(json.dumps(ground))
        (root / "truth" / "world.csv").write_text(
            "frame,person,x,y\n" + "".join(line + "\n" for line in world))
    return root
