"""Writing a generated clip's manifest and ground truth, exactly per FORMATS.md.

Numbers are written with fixed formatting, so the same seed gives byte-identical truth files.
Besides the required files, ``truth/scene.json`` (scenario, seed, cameras' K/R/t, sun, boxes,
people) and ``truth/background/<camera>.png`` (the noise-free empty scene) are written for
evaluation; readers ignore what they do not know.
"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

from mvtrack.generate.camera import Camera
from mvtrack.generate.render import FrameRender
from mvtrack.generate.world import FPS, Scene

__all__ = ["TruthWriter", "source_name", "write_clip_toml"]

# FORMATS.md's columns, then the optional `in_frame`: the share of the person's whole
# silhouette that lies inside the frame (`visible` counts only occlusion, not the frame edge).
CAMERA_HEADER = "frame,person,foot_x,foot_y,box_x,box_y,box_w,box_h,visible,in_frame"
WORLD_HEADER = "frame,person,x,y"


def source_name(cam: Camera, image_format: str) -> str:
    return f"{cam.name}.mp4" if image_format == "mp4" else cam.name


def write_clip_toml(out_dir: Path, scene: Scene, image_format: str) -> None:
    lines = [f"fps = {FPS:.1f}", ""]
    for cam in scene.cameras:
        lines += [
            "[[camera]]",
            f'name = "{cam.name}"',
            f'source = "{source_name(cam, image_format)}"',
            "offset = 0",
            f'modality = "{cam.modality}"',
            "",
        ]
    for a, b in scene.overlaps:
        lines += ["[[overlap]]", f'cameras = ["{a}", "{b}"]', ""]
    (out_dir / "clip.toml").write_text("\n".join(lines))


class TruthWriter:
    """Collects truth rows frame by frame; writes the files in :meth:`close`."""

    def __init__(self, out_dir: Path, scene: Scene) -> None:
        self.dir = out_dir / "truth"
        self.scene = scene
        self.rows: dict[str, list[str]] = {c.name: [CAMERA_HEADER] for c in scene.cameras}
        self.world: list[str] = [WORLD_HEADER]
        self.H = {c.name: c.image_from_ground() for c in scene.cameras}
        for cam in scene.cameras:
            (self.dir / "masks" / cam.name).mkdir(parents=True, exist_ok=True)
        (self.dir / "background").mkdir(parents=True, exist_ok=True)

    def add_world(self, frame: int, positions: dict[int, np.ndarray]) -> None:
        for pid, xy in positions.items():
            self.world.append(f"{frame},{pid},{xy[0]:.3f},{xy[1]:.3f}")

    def add_camera(
        self, frame: int, cam: Camera, render: FrameRender, positions: dict[int, np.ndarray]
    ) -> None:
        """Rows for every person with a pixel in the frame, in person order."""
        for pid in sorted(render.people):
            px = render.people[pid]
            foot = self.H[cam.name] @ np.array([positions[pid][0], positions[pid][1], 1.0])
            fx, fy = foot[0] / foot[2], foot[1] / foot[2]
            x0, y0, x1, y1 = px.visible_box if px.visible_box is not None else px.alone_box
            visible = px.visible_px / px.alone_px
            in_frame = px.alone_px / px.full_px
            self.rows[cam.name].append(
                f"{frame},{pid},{fx:.3f},{fy:.3f},{x0 - 0.5:.1f},{y0 - 0.5:.1f},"
                f"{x1 - x0 + 1},{y1 - y0 + 1},{visible:.4f},{in_frame:.4f}"
            )

    def add_mask(self, frame: int, cam: Camera, render: FrameRender) -> None:
        mask = np.where(render.label > 0, 1, np.where(render.shadow, 2, 0)).astype(np.uint8)
        cv2.imwrite(str(self.dir / "masks" / cam.name / f"{frame:06d}.png"), mask)

    def add_background(self, cam: Camera, image: np.ndarray) -> None:
        img = np.clip(np.round(image), 0, 255).astype(np.uint8)
        cv2.imwrite(str(self.dir / "background" / f"{cam.name}.png"),
                    img[..., ::-1] if img.shape[2] == 3 else img[..., 0])

    def close(self, frames: int) -> None:
        for name, rows in self.rows.items():
            (self.dir / f"{name}.csv").write_text("\n".join(rows) + "\n")
        (self.dir / "world.csv").write_text("\n".join(self.world) + "\n")
        ground = {
            "units": "m",
            "cameras": {n: {"image_from_ground": H.tolist()} for n, H in self.H.items()},
        }
        (self.dir / "ground.json").write_text(json.dumps(ground, indent=2) + "\n")
        (self.dir / "scene.json").write_text(json.dumps(scene_record(self.scene, frames),
                                                        indent=1) + "\n")


def scene_record(scene: Scene, frames: int) -> dict[str, object]:
    """Everything about how the clip was made, for evaluation and debugging."""
    cams = {
        c.name: {
            "size": [c.width, c.height],
            "modality": c.modality,
            "K": c.K.tolist(),
            "R_cam_from_world": c.R.tolist(),
            "t": c.t.tolist(),
            "centre_m": c.centre.tolist(),
        }
        for c in scene.cameras
    }
    boxes = [
        {"centre_m": list(b.centre), "size_m": list(b.size), "height_m": b.height,
         "yaw_rad": b.yaw_rad, "door": b.door}
        for b in scene.boxes
    ]
    people = {
        str(w.pid): {
            "stature_m": w.appearance.stature_m,
            "speed_mps": w.speed_mps,
            "start_s": w.t0_s,
            "path_length_m": float(w.arc[-1]),
            "colours_rgb": [list(c) for c in w.appearance.colours],
        }
        for w in scene.walkers
    }
    return {
        "scenario": scene.scenario,
        "seed": scene.seed,
        "frames": frames,
        "fps": FPS,
        "sun_direction": scene.sun.tolist(),
        "overlaps": [list(p) for p in scene.overlaps],
        "cameras": cams,
        "boxes": boxes,
        "people": people,
    }
