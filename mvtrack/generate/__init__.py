"""The scene generator (thesis §4.1, SPEC §10): seeded multi-camera clips with ground truth.

    from mvtrack.generate import SCENARIOS, generate_clip
    generate_clip(Path("demo"), "pillar", seed=3, frames=300, size=(640, 480))

writes ``demo/clip.toml``, one video (or frame folder) per camera and ``demo/truth/`` exactly
as FORMATS.md describes. People are articulated 3D figures walking on a textured ground plane,
rendered with a z-buffer, casting shadows; frames get sensor noise and a slow illumination drift.
The same arguments give byte-identical truth files.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from mvtrack.generate.body import Appearance, Pose, pose_figure
from mvtrack.generate.camera import Camera
from mvtrack.generate.ground import GroundTexture
from mvtrack.generate.render import Background, render_background, render_frame
from mvtrack.generate.scenarios import SCENARIOS, Planner, Scenario, schedule
from mvtrack.generate.truth import TruthWriter, source_name, write_clip_toml
from mvtrack.generate.world import FPS, Scene

__all__ = ["IMAGE_FORMATS", "MASK_EVERY_FRAMES", "SCENARIOS", "Scenario", "build_scene",
           "generate_clip"]

IMAGE_FORMATS = ("mp4", "png", "jpg")
MASK_EVERY_FRAMES = 10
MIN_SIDE_PX, MAX_SIDE_PX = 64, 4096
NOISE_SIGMA = 2.0
DRIFT_RANGE = (0.02, 0.045)  # relative amplitude of the slow global gain change
BLUR_SIGMA_PX = 0.6


def build_scene(scenario: str, seed: int, frames: int, size: tuple[int, int]) -> Scene:
    """The scenario's cameras, boxes and walkers for this seed (no pixels rendered)."""
    recipe = SCENARIOS[scenario]
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0]))
    layout = recipe.layout(rng, size)
    walkers = schedule(Planner(rng, layout, frames), recipe)
    return Scene(scenario, seed, layout.cameras, layout.boxes, layout.sun, tuple(walkers),
                 layout.overlaps, layout.plaza)


def _check_args(out_dir: Path, scenario: str, seed: int, frames: int, size: tuple[int, int],
                image_format: str) -> None:
    if scenario not in SCENARIOS:
        raise ValueError(f"unknown scenario {scenario!r}; choose one of {', '.join(SCENARIOS)}")
    if not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    if not isinstance(frames, int) or frames < 1:
        raise ValueError(f"frames must be an integer >= 1, got {frames!r}")
    ok = (
        isinstance(size, tuple | list) and len(size) == 2
        and all(isinstance(v, int) and MIN_SIDE_PX <= v <= MAX_SIDE_PX and v % 2 == 0
                for v in size)
    )
    if not ok:
        raise ValueError(f"size must be (width, height), even integers in "
                         f"[{MIN_SIDE_PX}, {MAX_SIDE_PX}], got {size!r}")
    if image_format not in IMAGE_FORMATS:
        raise ValueError(f"image_format must be one of {IMAGE_FORMATS}, got {image_format!r}")
    if out_dir.exists() and (not out_dir.is_dir() or any(out_dir.iterdir())):
        raise ValueError(f"out_dir {str(out_dir)!r} exists and is not an empty directory")


class _FrameSink:
    """Writes one camera's frames: an mp4 (cv2 'mp4v') or a folder of numbered images."""

    def __init__(self, out_dir: Path, cam: Camera, image_format: str) -> None:
        self.format = image_format
        self.path = out_dir / source_name(cam, image_format)
        self.writer: cv2.VideoWriter | None = None
        if image_format == "mp4":
            fourcc = cv2.VideoWriter.fourcc(*"mp4v")
            self.writer = cv2.VideoWriter(str(self.path), fourcc, FPS, (cam.width, cam.height),
                                          isColor=cam.channels == 3)
            if not self.writer.isOpened():
                raise OSError(f"cannot open a video writer for {self.path}")
        else:
            self.path.mkdir()

    def write(self, frame: int, image: np.ndarray) -> None:
        """``image`` (H, W, C) uint8 RGB or gray."""
        out = np.ascontiguousarray(image[..., ::-1] if image.shape[2] == 3 else image[..., 0])
        if self.writer is not None:
            self.writer.write(out)
        else:
            cv2.imwrite(str(self.path / f"{frame:06d}.{self.format}"), out)

    def close(self) -> None:
        if self.writer is not None:
            self.writer.release()


class _Sensor:
    """Per-camera sensor effects: optics blur, slow gain drift, Gaussian noise."""

    def __init__(self, rng: np.random.Generator, frames: int) -> None:
        self.rng = rng
        self.amp = float(rng.uniform(*DRIFT_RANGE))
        self.period = max(float(frames), 250.0) * float(rng.uniform(0.8, 1.6))
        self.phase = float(rng.uniform(0, 2 * np.pi))

    def apply(self, frame: int, image: np.ndarray) -> np.ndarray:
        gain = 1.0 + self.amp * np.sin(2 * np.pi * frame / self.period + self.phase)
        img = cv2.GaussianBlur(image, (3, 3), BLUR_SIGMA_PX).reshape(image.shape)
        noise = self.rng.standard_normal(image.shape, dtype=np.float32) * NOISE_SIGMA
        return np.clip(img * gain + noise + 0.5, 0, 255).astype(np.uint8)


def generate_clip(  # noqa: PLR0913, PLR0917  (the CLI's contract: one flag per argument)
    out_dir: Path,
    scenario: str,
    seed: int = 0,
    frames: int = 600,
    size: tuple[int, int] = (640, 480),
    progress: Callable[[int, int], None] | None = None,
    image_format: str = "mp4",
) -> Path:
    """Writes a clip of ``scenario`` into ``out_dir`` (created; must not hold anything yet).

    ``size`` is the (width, height) of full-size cameras (some scenarios have a 0.75x camera);
    ``image_format`` "mp4" writes ``camN.mp4``, "png"/"jpg" write ``camN/000000.png`` folders.
    ``progress(done, total)`` is called after each frame. Returns ``out_dir``.
    Raises ValueError naming the bad argument.
    """
    out_dir = Path(out_dir)
    _check_args(out_dir, scenario, seed, frames, size, image_format)
    scene = build_scene(scenario, seed, frames, (size[0], size[1]))
    out_dir.mkdir(parents=True, exist_ok=True)
    write_clip_toml(out_dir, scene, image_format)
    truth = TruthWriter(out_dir, scene)
    texture_rng, sensor_rng = (np.random.default_rng(s)
                               for s in np.random.SeedSequence([seed, 1]).spawn(2))
    tex = GroundTexture.random(texture_rng, scene.plaza)
    backgrounds: list[Background] = []
    for cam in scene.cameras:
        backgrounds.append(render_background(cam, tex, scene.boxes, scene.sun, texture_rng))
        truth.add_background(cam, backgrounds[-1].image)
    sensors = [_Sensor(sensor_rng, frames) for _ in scene.cameras]
    sinks = [_FrameSink(out_dir, cam, image_format) for cam in scene.cameras]
    try:
        for frame in range(frames):
            _frame(scene, frame, backgrounds, sensors, sinks, truth)
            if progress is not None:
                progress(frame + 1, frames)
    finally:
        for sink in sinks:
            sink.close()
    truth.close(frames)
    return out_dir


def _frame(scene: Scene, frame: int, backgrounds: list[Background], sensors: list[_Sensor],
           sinks: list[_FrameSink], truth: TruthWriter) -> None:
    people: list[tuple[int, Pose, Appearance]] = []
    positions: dict[int, np.ndarray] = {}
    for w in scene.walkers:
        state = w.state(frame)
        if state is None:
            continue
        xy, heading, phase = state
        positions[w.pid] = xy
        people.append((w.pid, pose_figure(w.appearance, xy, heading, phase), w.appearance))
    truth.add_world(frame, positions)
    for cam, bg, sensor, sink in zip(scene.cameras, backgrounds, sensors, sinks, strict=True):
        render = render_frame(cam, bg, people, scene.sun)
        truth.add_camera(frame, cam, render, positions)
        if frame % MASK_EVERY_FRAMES == 0:
            truth.add_mask(frame, cam, render)
        sink.write(frame, sensor.apply(frame, render.image))
