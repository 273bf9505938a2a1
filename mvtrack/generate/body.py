"""Articulated walking figures: appearance, gait, and 3D surface samples of each body part.

A figure is built from convex parts (ellipsoids, capsules, a ring-lofted torso) in a local frame
(x forward, y left, z up, origin on the ground under the centre of mass) and placed in the world
by its ground position and heading. Each part is a set of surface samples with outward normals:
its image is the convex hull of the projected samples (a projection of a convex body is the hull
of the projected body), and the samples facing the sun give its lit side.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "MATERIALS",
    "Appearance",
    "Pose",
    "pose_figure",
    "random_appearance",
]

MATERIALS = ("shirt", "trousers", "skin", "hair", "shoes")
SHIRT, TROUSERS, SKIN, HAIR, SHOES = range(5)

HIP_SWING_RAD = 0.42
KNEE_FLEX_RAD = 1.0
ARM_SWING_RAD = 0.38


def _fibonacci_sphere(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    a = math.pi * (1.0 + math.sqrt(5.0)) * i
    return np.column_stack([r * np.cos(a), r * np.sin(a), z])


_SPHERE = _fibonacci_sphere(32)
_SPHERE_SMALL = _fibonacci_sphere(16)
_RING_ANGLES = np.linspace(0.0, 2.0 * math.pi, 14, endpoint=False)
# Torso rings: (height as a fraction of stature, half width m, half depth m) at 1.75 m.
_TORSO_RINGS = ((0.55, 0.150, 0.105), (0.66, 0.160, 0.110), (0.74, 0.195, 0.120),
                (0.805, 0.205, 0.105), (0.83, 0.150, 0.075))


@dataclass(frozen=True)
class Appearance:
    """Body size and clothing. Colours are RGB 0-255 per material (see ``MATERIALS``);
    ``thermal`` holds the gray level of each material in a thermal camera."""

    stature_m: float
    colours: tuple[tuple[float, float, float], ...]
    thermal: tuple[float, ...]
    long_sleeves: bool

    @property
    def scale(self) -> float:
        return self.stature_m / 1.75


@dataclass(frozen=True, eq=False)
class Pose:
    """One figure at one instant. ``points``/``normals`` (N, 3) world; part p owns rows
    ``starts[p]:starts[p + 1]``, has material ``material[p]`` and centre ``centres[p]``."""

    points: np.ndarray
    normals: np.ndarray
    starts: np.ndarray
    material: np.ndarray
    centres: np.ndarray


def _hsv_to_rgb(h: float, s: float, v: float) -> tuple[float, float, float]:
    c = v * s
    x = c * (1 - abs((h * 6.0) % 2 - 1))
    m = v - c
    k = int(h * 6.0) % 6
    r, g, b = [(c, x, 0), (x, c, 0), (0, c, x), (0, x, c), (x, 0, c), (c, 0, x)][k]
    return (255.0 * (r + m), 255.0 * (g + m), 255.0 * (b + m))


def random_appearance(rng: np.random.Generator, shirt_hue: float | None = None) -> Appearance:
    """A random person: stature 1.6-1.9 m, a saturated shirt (hue ``shirt_hue`` if given),
    darker trousers, a skin tone, hair and shoes."""
    hue = float(rng.random()) if shirt_hue is None else shirt_hue
    shirt = _hsv_to_rgb(hue, float(rng.uniform(0.45, 0.9)), float(rng.uniform(0.55, 0.95)))
    trousers = _hsv_to_rgb(
        float(rng.choice([0.6, 0.62, 0.08, 0.0, 0.3])),
        float(rng.uniform(0.05, 0.5)),
        float(rng.uniform(0.15, 0.5)),
    )
    tone = float(rng.uniform(0.0, 1.0))
    skin = (235.0 - 120.0 * tone, 190.0 - 110.0 * tone, 160.0 - 100.0 * tone)
    hair = _hsv_to_rgb(0.07, float(rng.uniform(0.3, 0.7)), float(rng.uniform(0.08, 0.55)))
    shoes = _hsv_to_rgb(0.0, 0.0, float(rng.uniform(0.08, 0.3)))
    thermal = (
        float(rng.uniform(165, 200)),  # clothing is cooler than skin but warmer than the ground
        float(rng.uniform(150, 190)),
        float(rng.uniform(215, 240)),
        float(rng.uniform(175, 205)),
        float(rng.uniform(135, 160)),
    )
    return Appearance(
        stature_m=float(rng.uniform(1.6, 1.9)),
        colours=(shirt, trousers, skin, hair, shoes),
        thermal=thermal,
        long_sleeves=bool(rng.random() < 0.5),
    )


class _Builder:
    """Collects parts in the figure's local frame."""

    def __init__(self) -> None:
        self.points: list[np.ndarray] = []
        self.normals: list[np.ndarray] = []
        self.material: list[int] = []
        self.centres: list[np.ndarray] = []

    def add(self, pts: np.ndarray, nrm: np.ndarray, material: int, centre: np.ndarray) -> None:
        self.points.append(pts)
        self.normals.append(nrm)
        self.material.append(material)
        self.centres.append(centre)

    def ellipsoid(self, centre: np.ndarray, axes: np.ndarray, material: int) -> None:
        self.add(centre + _SPHERE * axes, _SPHERE / axes, material, centre)

    def capsule(self, a: np.ndarray, b: np.ndarray, radius: float, material: int) -> None:
        pts = np.vstack([a + radius * _SPHERE_SMALL, b + radius * _SPHERE_SMALL])
        self.add(pts, np.vstack([_SPHERE_SMALL, _SPHERE_SMALL]), material, (a + b) / 2.0)


def _leg_angles(phase: float) -> tuple[float, float]:
    """(hip flexion, knee flexion) in radians at gait ``phase`` (swing when cos(phase) > 0)."""
    hip = HIP_SWING_RAD * math.sin(phase)
    knee = 0.08 + KNEE_FLEX_RAD * max(0.0, math.cos(phase - 0.35)) ** 2
    return hip, knee


def _sagittal(angle: float, length: float) -> np.ndarray:
    """A limb vector pointing down, swung forward by ``angle``."""
    return length * np.array([math.sin(angle), 0.0, -math.cos(angle)])


def _legs(b: _Builder, app: Appearance, phase: float) -> float:
    """Adds both legs; returns the hip height that puts the lower foot on the ground."""
    s, h = app.scale, app.stature_m
    thigh, shank, ankle = 0.245 * h, 0.245 * h, 0.04 * h
    angles = [_leg_angles(phase), _leg_angles(phase + math.pi)]
    hip_z = max(thigh * math.cos(a) + shank * math.cos(a - k) for a, k in angles) + ankle
    for side, (a, k) in zip((1.0, -1.0), angles, strict=True):
        hip = np.array([0.0, side * 0.09 * s, hip_z])
        knee = hip + _sagittal(a, thigh)
        foot = knee + _sagittal(a - k, shank)
        b.capsule(hip, knee, 0.068 * s, TROUSERS)
        b.capsule(knee, foot, 0.052 * s, TROUSERS)
        toe = foot + np.array([0.15 * s, 0.0, -0.015 * s])
        b.capsule(foot + np.array([-0.03 * s, 0, -0.01 * s]), toe, 0.04 * s, SHOES)
    return hip_z


def _arms(b: _Builder, app: Appearance, phase: float, shoulder_z: float) -> None:
    s, h = app.scale, app.stature_m
    upper, fore = 0.17 * h, 0.15 * h
    for side, leg_phase in ((1.0, phase + math.pi), (-1.0, phase)):
        swing = ARM_SWING_RAD * math.sin(leg_phase)
        shoulder = np.array([0.0, side * 0.195 * s, shoulder_z])
        elbow = shoulder + _sagittal(swing, upper) + np.array([0.0, side * 0.03 * s, 0.0])
        bend = 0.2 + 0.25 * max(0.0, math.sin(leg_phase))
        wrist = elbow + _sagittal(swing + bend, fore) + np.array([0.0, side * 0.01 * s, 0.0])
        b.capsule(shoulder, elbow, 0.048 * s, SHIRT)
        b.capsule(elbow, wrist, 0.04 * s, SHIRT if app.long_sleeves else SKIN)
        b.ellipsoid(wrist + _sagittal(swing + bend, 0.05 * s), np.full(3, 0.045 * s), SKIN)


def _torso(b: _Builder, app: Appearance, hip_z: float, lean: float) -> float:
    """Adds pelvis, torso, neck, head and hair; returns the shoulder height."""
    s, h = app.scale, app.stature_m
    rise = hip_z - 0.53 * h  # the pelvis bobs with the gait; the upper body follows it
    b.ellipsoid(np.array([0.0, 0.0, hip_z + 0.02 * h]), np.array([0.11, 0.165, 0.1]) * s,
                TROUSERS)
    rings, normals = [], []
    for frac, half_w, half_d in _TORSO_RINGS:
        z = frac * h + rise
        ring = np.column_stack([half_d * s * np.cos(_RING_ANGLES) + lean * (z - hip_z),
                                half_w * s * np.sin(_RING_ANGLES), np.full(len(_RING_ANGLES), z)])
        rings.append(ring)
        normals.append(np.column_stack([np.cos(_RING_ANGLES) / half_d,
                                        np.sin(_RING_ANGLES) / half_w,
                                        np.zeros(len(_RING_ANGLES))]))
    top = np.array([[lean * (0.84 * h + rise - hip_z), 0.0, 0.845 * h + rise]])
    pts = np.vstack([*rings, top])
    nrm = np.vstack([*normals, [[0.0, 0.0, 1.0]]])
    b.add(pts, nrm, SHIRT, pts.mean(axis=0))
    head_x = lean * (0.93 * h + rise - hip_z) + 0.01 * s
    neck_a = np.array([lean * (0.82 * h + rise - hip_z), 0.0, 0.82 * h + rise])
    b.capsule(neck_a, np.array([head_x, 0.0, 0.88 * h + rise]), 0.05 * s, SKIN)
    head = np.array([head_x, 0.0, 0.935 * h + rise])
    b.ellipsoid(head + np.array([-0.018, 0.0, 0.022]) * s, np.array([0.1, 0.088, 0.1]) * s, HAIR)
    b.ellipsoid(head, np.array([0.097, 0.08, 0.112]) * s, SKIN)
    return 0.81 * h + rise


def pose_figure(
    app: Appearance, xy: np.ndarray, heading_rad: float, phase_rad: float
) -> Pose:
    """The figure ``app`` standing at ground point ``xy`` (metres), facing ``heading_rad``
    (counter-clockwise from +X), at gait phase ``phase_rad`` (left leg's hip swing)."""
    b = _Builder()
    hip_z = _legs(b, app, phase_rad)
    shoulder_z = _torso(b, app, hip_z, lean=0.04)
    _arms(b, app, phase_rad, shoulder_z)
    c, s = math.cos(heading_rad), math.sin(heading_rad)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    offset = np.array([xy[0], xy[1], 0.0])
    sizes = [len(p) for p in b.points]
    starts = np.concatenate([[0], np.cumsum(sizes)])
    normals = np.vstack(b.normals) @ rot.T
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return Pose(
        points=np.vstack(b.points) @ rot.T + offset,
        normals=normals,
        starts=starts,
        material=np.array(b.material),
        centres=np.vstack(b.centres) @ rot.T + offset,
    )
