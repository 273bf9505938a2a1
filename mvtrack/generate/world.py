"""The generator's world: static boxes (pillars, door booths), walkers on smooth paths, the sun.

Everything here is in world metres and seconds; nothing here knows about pixels except the
visibility test used to place path ends outside every camera's view.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mvtrack.generate.body import Appearance
from mvtrack.generate.camera import NEAR_M, Camera

__all__ = [
    "Box",
    "Face",
    "Scene",
    "Walker",
    "make_path",
    "person_box",
    "visible_in",
]

FPS = 25.0
PATH_STEP_M = 0.05
SMOOTH_SIGMA_M = 0.8
# A person's bounding cylinder, for visibility tests (generous: swinging arms, tall people).
BODY_RADIUS_M, BODY_HEIGHT_M = 0.45, 1.95
_CYL = np.array(
    [[BODY_RADIUS_M * math.cos(a), BODY_RADIUS_M * math.sin(a), z]
     for a in np.linspace(0, 2 * math.pi, 8, endpoint=False) for z in (0.0, 1.0, BODY_HEIGHT_M)]
)


@dataclass(frozen=True, eq=False)
class Face:
    """A planar convex polygon (N, 3) with unit outward ``normal``, gray level or RGB ``colour``."""

    vertices: np.ndarray
    normal: np.ndarray
    rgb: tuple[float, float, float]
    thermal: float


@dataclass(frozen=True)
class Box:
    """A static box standing on the ground: pillar, booth. ``door`` puts a dark door panel
    (0.95 m x 2.05 m) on the face pointing along the box's local +x axis."""

    centre: tuple[float, float]
    size: tuple[float, float]
    height: float
    yaw_rad: float
    rgb: tuple[float, float, float]
    thermal: float
    door: bool = False

    def axes(self) -> tuple[np.ndarray, np.ndarray]:
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        return np.array([c, s]), np.array([-s, c])

    def corners(self) -> np.ndarray:
        """(8, 3) corners: the 4 ground corners then the 4 top corners."""
        ex, ey = self.axes()
        hx, hy = self.size[0] / 2.0, self.size[1] / 2.0
        base = [np.asarray(self.centre) + sx * hx * ex + sy * hy * ey
                for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
        return np.array([[*p, z] for z in (0.0, self.height) for p in base])

    def door_point(self, out_m: float) -> np.ndarray:
        """(2,) ground point ``out_m`` metres in front of the door's centre."""
        ex, _ = self.axes()
        return np.asarray(self.centre) + (self.size[0] / 2.0 + out_m) * ex

    def faces(self) -> list[Face]:
        c = self.corners()
        ex, ey = self.axes()
        quads = [((0, 3, 7, 4), ex), ((1, 0, 4, 5), ey), ((2, 1, 5, 6), -ex), ((3, 2, 6, 7), -ey)]
        faces = [Face(c[list(q)], np.array([*n, 0.0]), self.rgb, self.thermal) for q, n in quads]
        faces.append(Face(c[4:], np.array([0.0, 0.0, 1.0]), self.rgb, self.thermal))
        if self.door:
            ctr = np.array([*self.door_point(0.01), 0.0])
            half = 0.475 * np.array([*ey, 0.0])
            up = np.array([0.0, 0.0, 2.05])
            panel = np.array([ctr - half, ctr + half, ctr + half + up, ctr - half + up])
            faces.append(Face(panel, np.array([*ex, 0.0]), (45.0, 38.0, 34.0), self.thermal - 20))
        return faces

    def distance(self, xy: np.ndarray) -> np.ndarray:
        """(N,) ground distance (metres) from points (N, 2) to the box's footprint."""
        ex, ey = self.axes()
        d = xy - np.asarray(self.centre)
        u = np.abs(d @ ex) - self.size[0] / 2.0
        v = np.abs(d @ ey) - self.size[1] / 2.0
        return np.hypot(np.maximum(u, 0.0), np.maximum(v, 0.0)) + np.minimum(np.maximum(u, v), 0)


@dataclass(frozen=True, eq=False)
class Walker:
    """A person walking ``path`` (M, 2) metres (arc length ``arc`` (M,)) at ``speed_mps``,
    starting at clip time ``t0_s`` (negative: already under way at frame 0)."""

    pid: int
    appearance: Appearance
    path: np.ndarray
    arc: np.ndarray
    speed_mps: float
    t0_s: float
    phase0_rad: float

    @property
    def stride_m(self) -> float:
        return 0.8 * self.appearance.stature_m * (0.55 + 0.45 * self.speed_mps / 1.3)

    def distance_at(self, frames: np.ndarray) -> np.ndarray:
        """(F,) arc length walked at each clip frame (outside [0, length]: not in the world)."""
        return (frames / FPS - self.t0_s) * self.speed_mps

    def positions(self, frames: np.ndarray) -> np.ndarray:
        """(F, 2) ground positions, rounded to the millimetre; NaN when not in the world."""
        s = self.distance_at(frames)
        alive = (s >= 0.0) & (s <= self.arc[-1])
        xy = np.column_stack([np.interp(s, self.arc, self.path[:, i]) for i in (0, 1)])
        xy = np.round(xy, 3)
        xy[~alive] = np.nan
        return xy

    def state(self, frame: int) -> tuple[np.ndarray, float, float] | None:
        """(position (2,), heading rad, gait phase rad) at ``frame``; None when not in the world."""
        s = float(self.distance_at(np.array([frame]))[0])
        if not 0.0 <= s <= self.arc[-1]:
            return None
        xy = np.round([np.interp(s, self.arc, self.path[:, i]) for i in (0, 1)], 3)
        a = np.array([np.interp(s + d, self.arc, self.path[:, i]) for d in (-0.3, 0.3)
                      for i in (0, 1)])
        heading = math.atan2(a[3] - a[1], a[2] - a[0])
        phase = self.phase0_rad + 2.0 * math.pi * s / self.stride_m
        return xy, heading, phase


@dataclass(frozen=True, eq=False)
class Scene:
    """A whole scenario instance: cameras, static boxes, sun, walkers, overlapping pairs."""

    scenario: str
    seed: int
    cameras: tuple[Camera, ...]
    boxes: tuple[Box, ...]
    sun: np.ndarray
    walkers: tuple[Walker, ...]
    overlaps: tuple[tuple[str, str], ...]
    plaza: tuple[float, float, float, float]


def make_path(waypoints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Waypoints (K, 2) -> a smooth path (M, 2) sampled every ~5 cm and its arc length (M,).

    The polyline is resampled densely and smoothed with a Gaussian of SMOOTH_SIGMA_M metres
    (corners become round turns; straight runs and the two ends stay where they were).
    """
    seg = np.diff(waypoints, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    arc = np.concatenate([[0.0], np.cumsum(lengths)])
    s = np.linspace(0.0, arc[-1], math.ceil(arc[-1] / PATH_STEP_M) + 1)
    dense = np.column_stack([np.interp(s, arc, waypoints[:, i]) for i in (0, 1)])
    half = min(int(3 * SMOOTH_SIGMA_M / PATH_STEP_M), len(dense) - 2)
    k = np.exp(-0.5 * (np.arange(-half, half + 1) * PATH_STEP_M / SMOOTH_SIGMA_M) ** 2)
    k /= k.sum()
    # Reflect the ends through the end points, so the smoothing keeps them fixed and straight.
    head = 2 * dense[0] - dense[half:0:-1]
    tail = 2 * dense[-1] - dense[-2 : -half - 2 : -1]
    padded = np.vstack([head, dense, tail])
    smooth = np.column_stack([np.convolve(padded[:, i], k, mode="valid") for i in (0, 1)])
    step = np.hypot(*np.diff(smooth, axis=0).T)
    return smooth, np.concatenate([[0.0], np.cumsum(step)])


def visible_in(cam: Camera, xy: np.ndarray, margin_px: float = 0.0) -> np.ndarray:
    """(N,) bool: would a person standing at each ground point (N, 2) show any part in ``cam``?

    Uses a generous bounding cylinder, so False means surely out of view.
    """
    pts = (xy[:, None, :2] + _CYL[None, :, :2]).reshape(-1, 2)
    z = np.tile(_CYL[:, 2], len(xy))
    uv, depth = cam.project(np.column_stack([pts, z]))
    inside = (
        (depth > NEAR_M)
        & (uv[:, 0] > -0.5 - margin_px) & (uv[:, 0] < cam.width - 0.5 + margin_px)
        & (uv[:, 1] > -0.5 - margin_px) & (uv[:, 1] < cam.height - 0.5 + margin_px)
    )
    return np.any(inside.reshape(len(xy), -1), axis=1)


def person_box(cam: Camera, xy: np.ndarray) -> np.ndarray:
    """(N, 4) x0, y0, x1, y1 pixel box of the bounding cylinder at each ground point (N, 2);
    NaN rows where part of the cylinder is behind the camera."""
    pts = (xy[:, None, :2] + _CYL[None, :, :2]).reshape(-1, 2)
    z = np.tile(_CYL[:, 2], len(xy))
    uv, depth = cam.project(np.column_stack([pts, z]))
    uv = uv.reshape(len(xy), -1, 2)
    box = np.concatenate([uv.min(axis=1), uv.max(axis=1)], axis=1)
    box[(depth.reshape(len(xy), -1) <= NEAR_M).any(axis=1)] = np.nan
    return box
