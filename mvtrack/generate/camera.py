"""Pinhole cameras of the generator: intrinsics, pose, projection, the ground homography.

World frame: metres, ground plane Z = 0, Z up. Camera frame (OpenCV): x right, y down, z
forward. A world point X maps to camera coordinates ``R @ X + t`` and to pixels through ``K``;
pixel centres are at integer coordinates, so the principal point of a W x H image is
((W - 1) / 2, (H - 1) / 2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "NEAR_M",
    "Camera",
    "CameraSpec",
    "look_at",
]

NEAR_M = 0.1
"""Near plane (camera depth, metres): geometry closer than this is clipped or skipped."""

MIN_PITCH_DEG, MAX_PITCH_DEG = 15.0, 45.0
MIN_HEIGHT_M, MAX_HEIGHT_M = 2.5, 8.0


@dataclass(frozen=True, eq=False)
class Camera:
    """A static pinhole camera. ``K`` (3, 3), ``R`` (3, 3) camera-from-world, ``t`` (3,) metres."""

    name: str
    width: int
    height: int
    K: np.ndarray
    R: np.ndarray
    t: np.ndarray
    modality: str = "rgb"

    @property
    def centre(self) -> np.ndarray:
        """(3,) camera centre in world metres."""
        return -self.R.T @ self.t

    @property
    def channels(self) -> int:
        return 1 if self.modality == "gray" else 3

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) world metres -> (N, 3) camera-frame metres."""
        return points @ self.R.T + self.t

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) world metres -> ((N, 2) pixels, (N,) depth in metres along the optical axis).

        Points at or behind the camera get meaningless pixels: check the depth.
        """
        cam = self.to_camera(points)
        depth = cam[:, 2]
        safe = np.where(np.abs(depth) < 1e-9, 1e-9, depth)
        uv = cam[:, :2] / safe[:, None] * self.K[0, 0] + self.K[:2, 2]
        return uv, depth

    def image_from_ground(self) -> np.ndarray:
        """(3, 3) homography H_image_from_ground = K [r1 r2 t]: (X, Y, 1) metres -> pixels.

        Its third output coordinate is the camera depth of the ground point (positive in front).
        """
        return self.K @ np.column_stack([self.R[:, 0], self.R[:, 1], self.t])

    def ground_to_image(self, xy: np.ndarray) -> np.ndarray:
        """(N, 2) ground metres -> (N, 2) pixels via :meth:`image_from_ground`."""
        h = np.column_stack([xy, np.ones(len(xy))]) @ self.image_from_ground().T
        return h[:, :2] / h[:, 2:3]

    def image_to_ground(self, uv: np.ndarray) -> np.ndarray:
        """(N, 2) pixels -> (N, 2) ground metres (meaningless above the horizon)."""
        g = np.column_stack([uv, np.ones(len(uv))]) @ np.linalg.inv(self.image_from_ground()).T
        return g[:, :2] / g[:, 2:3]

    def ray_directions(self, uv: np.ndarray) -> np.ndarray:
        """(N, 2) pixels -> (N, 3) world-frame ray directions (not normalised)."""
        f = self.K[0, 0]
        rays = np.column_stack([(uv - self.K[:2, 2]) / f, np.ones(len(uv))])
        return rays @ self.R

    def plane_depth_coeffs(self, normal: np.ndarray, point: np.ndarray) -> np.ndarray:
        """(3,) (a, b, c) such that the camera depth of the world plane through ``point`` with
        ``normal`` seen at pixel (u, v) is 1 / (a u + b v + c)."""
        n_c = self.R @ normal
        d0 = float(n_c @ (self.R @ point + self.t))
        f, cx, cy = self.K[0, 0], self.K[0, 2], self.K[1, 2]
        return np.array([n_c[0] / f, n_c[1] / f, n_c[2] - n_c[0] * cx / f - n_c[1] * cy / f]) / d0

    def project_polygon(self, points: np.ndarray) -> np.ndarray:
        """(N, 3) world polygon -> (M, 2) pixels of its part in front of the near plane
        (Sutherland-Hodgman clipping); empty (0, 2) when nothing is in front."""
        cam = self.to_camera(points)
        if cam[:, 2].min() < NEAR_M:
            cam = clip_near(cam, NEAR_M)
        if len(cam) == 0:
            return np.zeros((0, 2))
        return cam[:, :2] / cam[:, 2:3] * self.K[0, 0] + self.K[:2, 2]


def clip_near(poly: np.ndarray, near: float) -> np.ndarray:
    """Clip a camera-frame polygon (N, 3) to z >= near."""
    out: list[np.ndarray] = []
    n = len(poly)
    for i in range(n):
        a, b = poly[i], poly[(i + 1) % n]
        a_in, b_in = a[2] >= near, b[2] >= near
        if a_in:
            out.append(a)
        if a_in != b_in:
            s = (near - a[2]) / (b[2] - a[2])
            out.append(a + s * (b - a))
    return np.array(out) if out else np.zeros((0, 3))


@dataclass(frozen=True)
class CameraSpec:
    """Where a camera stands and looks. ``position`` (x, y, z) metres; its optical axis meets
    the ground at ``target``; ``focal_rel`` is the focal length in image widths; ``scale``
    shrinks the clip's frame size for this camera; ``roll_deg`` rolls it about its axis."""

    name: str
    position: tuple[float, float, float]
    target: tuple[float, float]
    focal_rel: float
    scale: float = 1.0
    roll_deg: float = 0.0
    modality: str = "rgb"


def look_at(spec: CameraSpec, size: tuple[int, int]) -> Camera:
    """The camera ``spec`` for a clip of frame ``size`` (width, height) pixels; its own size is
    ``size * spec.scale`` rounded to even numbers. Raises ValueError when the pose breaks the
    generator's rules (height 2.5-8 m, looking down 15-45 degrees)."""
    x, y, z = spec.position
    dx, dy = spec.target[0] - x, spec.target[1] - y
    pitch = math.degrees(math.atan2(z, math.hypot(dx, dy)))
    if not (MIN_HEIGHT_M <= z <= MAX_HEIGHT_M and MIN_PITCH_DEG <= pitch <= MAX_PITCH_DEG):
        raise ValueError(
            f"camera {spec.name}: height {z:.2f} m / pitch {pitch:.1f} deg out of range"
        )
    yaw = math.atan2(dy, dx)
    p = math.radians(pitch)
    forward = np.array([math.cos(p) * math.cos(yaw), math.cos(p) * math.sin(yaw), -math.sin(p)])
    right = np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    down = np.cross(forward, right)
    r = math.radians(spec.roll_deg)
    right, down = (
        math.cos(r) * right + math.sin(r) * down,
        -math.sin(r) * right + math.cos(r) * down,
    )
    R = np.vstack([right, down, forward])
    w, h = (2 * round(v * spec.scale / 2) for v in size)
    f = spec.focal_rel * w
    K = np.array([[f, 0.0, (w - 1) / 2.0], [0.0, f, (h - 1) / 2.0], [0.0, 0.0, 1.0]])
    t = -R @ np.asarray(spec.position, dtype=float)
    return Camera(name=spec.name, width=w, height=h, K=K, R=R, t=t, modality=spec.modality)
