"""Rendering one camera: the static background once, then people and their shadows per frame.

Visibility is a z-buffer. Box faces carry their exact per-pixel plane depth; a body part is a
filled convex polygon (the hull of its projected surface samples) at the depth of its centre,
drawn in two tones (the samples facing the sun give the lit side). Cast shadows are the
sun-projections of the same samples onto the ground, darkening the ground they fall on by a
constant factor, which keeps its hue. Every pixel's owner is recorded: that is the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from mvtrack.generate.body import Appearance, Pose
from mvtrack.generate.camera import NEAR_M, Camera
from mvtrack.generate.ground import GroundTexture, background_colours, thermal_from_rgb
from mvtrack.generate.world import Box

__all__ = [
    "Background",
    "FrameRender",
    "PersonPixels",
    "box_shadow",
    "render_background",
    "render_frame",
    "shadow_polygons",
]

SHIFT = 4  # fixed-point bits of polygon vertices handed to OpenCV
ONE = 1 << SHIFT
SHADOW_GAIN = {"rgb": 0.58, "gray": 0.86}
AMBIENT = {"rgb": 0.62, "gray": 0.93}
LIT_MIN_COS = 0.12
SUPERSAMPLE = 3


@dataclass(frozen=True, eq=False)
class Background:
    """The static scene of one camera: ``image`` (H, W, C) float32 0..255, ``depth`` (H, W)
    float32 (inf where ground or sky), ``ground`` (H, W) bool where cast shadows can fall,
    ``static_shadow`` (H, W) bool already shaded by a box."""

    image: np.ndarray
    depth: np.ndarray
    ground: np.ndarray
    static_shadow: np.ndarray


@dataclass(frozen=True)
class PersonPixels:
    """One person in one frame: pixels of the silhouette rendered alone (clipped to the
    frame), visible pixels, and inclusive pixel boxes (x0, y0, x1, y1) of both;
    ``full_px``: pixels of the whole silhouette, including what lies outside the frame."""

    alone_px: int
    visible_px: int
    alone_box: tuple[int, int, int, int]
    visible_box: tuple[int, int, int, int] | None
    full_px: int


@dataclass(frozen=True, eq=False)
class FrameRender:
    """``image`` (H, W, C) float32; ``label`` (H, W) int32 person id or 0; ``shadow`` (H, W)
    bool visible cast shadow of a person; ``people`` pid -> pixels, for people in the frame."""

    image: np.ndarray
    label: np.ndarray
    shadow: np.ndarray
    people: dict[int, PersonPixels]


def _fixed(uv: np.ndarray) -> np.ndarray:
    return np.round(np.clip(uv, -1e6, 1e6) * ONE).astype(np.int32)


def _raster(poly: np.ndarray, shape: tuple[int, int]) -> tuple[int, int, np.ndarray] | None:
    """Fixed-point convex polygon (K, 2) -> (x0, y0, bool mask of its frame-clipped box)."""
    lo = poly.min(axis=0) // ONE
    hi = -(-poly.max(axis=0) // ONE)
    x0, y0 = max(int(lo[0]), 0), max(int(lo[1]), 0)
    x1, y1 = min(int(hi[0]) + 1, shape[1]), min(int(hi[1]) + 1, shape[0])
    if x0 >= x1 or y0 >= y1:
        return None
    m = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.fillConvexPoly(m, poly - np.array([x0 * ONE, y0 * ONE], np.int32), 1, cv2.LINE_8, SHIFT)
    return x0, y0, m.view(bool)


def _union_px(polys: list[np.ndarray]) -> int:
    """Pixels of the union of fixed-point convex polygons, unclipped (for the in-frame share)."""
    pts = np.vstack(polys)
    lo, hi = pts.min(axis=0) // ONE, -(-pts.max(axis=0) // ONE)
    m = np.zeros((int(hi[1] - lo[1]) + 1, int(hi[0] - lo[0]) + 1), np.uint8)
    for poly in polys:
        cv2.fillConvexPoly(m, poly - (lo * ONE).astype(np.int32), 1, cv2.LINE_8, SHIFT)
    return int(np.count_nonzero(m))


def _grid(x0: int, y0: int, shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    return np.meshgrid(np.arange(x0, x0 + shape[1]), np.arange(y0, y0 + shape[0]))


def _colour(cam: Camera, rgb: tuple[float, float, float] | np.ndarray, thermal: float
            ) -> np.ndarray:
    """(C,) float32 colour of a surface in ``cam``: RGB, or its gray level in a gray camera."""
    if cam.modality == "gray":
        return np.array([thermal], np.float32)
    return np.asarray(rgb, np.float32)


def _ground_image(cam: Camera, tex: GroundTexture) -> np.ndarray:
    """Supersampled ground and sky, (H, W, C) float32."""
    acc = np.zeros((cam.height * cam.width, 3))
    u, v = _grid(0, 0, (cam.height, cam.width))
    uv = np.column_stack([u.ravel(), v.ravel()]).astype(float)
    offsets = (np.arange(SUPERSAMPLE) + 0.5) / SUPERSAMPLE - 0.5
    for dy in offsets:
        for dx in offsets:
            acc += background_colours(cam, tex, uv + [dx, dy])
    rgb = (acc / SUPERSAMPLE**2).reshape(cam.height, cam.width, 3)
    if cam.modality == "gray":
        return thermal_from_rgb(rgb)[..., None].astype(np.float32)
    return rgb.astype(np.float32)


def _ground_polygon_mask(cam: Camera, polys: list[np.ndarray], mask: np.ndarray) -> None:
    """Fills ground polygons (each (K, 2) metres) into ``mask`` (H, W) uint8, in place."""
    for poly in polys:
        uv = cam.project_polygon(np.column_stack([poly, np.zeros(len(poly))]))
        if len(uv) >= 3:
            cv2.fillConvexPoly(mask, _fixed(uv), 1, cv2.LINE_8, SHIFT)


def box_shadow(box: Box, sun: np.ndarray) -> np.ndarray:
    """(K, 2) ground polygon of a box's cast shadow (including its footprint)."""
    c = box.corners()
    g = c[:, :2] - c[:, 2:3] / sun[2] * sun[:2]
    return cv2.convexHull(g.astype(np.float32))[:, 0, :].astype(float)


def render_background(
    cam: Camera, tex: GroundTexture, boxes: tuple[Box, ...], sun: np.ndarray,
    rng: np.random.Generator,
) -> Background:
    """The static scene seen by ``cam``: ground, sky, boxes and their shadows."""
    image = _ground_image(cam, tex)
    shape = (cam.height, cam.width)
    shadow = np.zeros(shape, np.uint8)
    _ground_polygon_mask(cam, [box_shadow(b, sun) for b in boxes], shadow)
    static_shadow = shadow.view(bool)
    image[static_shadow] *= SHADOW_GAIN[cam.modality]
    depth = np.full(shape, np.inf, np.float32)
    centre = cam.centre
    for box in boxes:
        for face in box.faces():
            if face.normal @ (centre - face.vertices[0]) <= 0.0:
                continue  # back face
            uv = cam.project_polygon(face.vertices)
            hit = _raster(_fixed(uv), shape) if len(uv) >= 3 else None
            if hit is None:
                continue
            x0, y0, m = hit
            u, v = _grid(x0, y0, m.shape)
            a, b, c = cam.plane_depth_coeffs(face.normal, face.vertices[0])
            d = (1.0 / np.maximum(a * u + b * v + c, 1e-9)).astype(np.float32)
            roi = (slice(y0, y0 + m.shape[0]), slice(x0, x0 + m.shape[1]))
            win = m & (d < depth[roi] - 1e-4)
            light = AMBIENT["rgb"] + (1 - AMBIENT["rgb"]) * max(0.0, float(face.normal @ sun))
            grain = 1.0 + 0.04 * rng.standard_normal(m.shape).astype(np.float32)
            colour = _colour(cam, np.asarray(face.rgb) * light, face.thermal)
            image[roi][win] = (grain[..., None] * colour)[win]
            depth[roi][win] = d[win]
    ground = np.isinf(depth)
    return Background(image=image, depth=depth, ground=ground, static_shadow=static_shadow)


def shadow_polygons(pose: Pose, sun: np.ndarray) -> list[np.ndarray]:
    """Ground polygons (K, 2) of each body part's cast shadow under a sun along ``sun`` (3,)."""
    g = pose.points[:, :2] - pose.points[:, 2:3] / sun[2] * sun[:2]
    g32 = g.astype(np.float32)
    return [cv2.convexHull(g32[a:b])[:, 0, :].astype(float)
            for a, b in zip(pose.starts[:-1], pose.starts[1:], strict=True)]


class _Canvas:
    """The frame being drawn: colour, depth and owner of every pixel."""

    def __init__(self, bg: Background, modality: str) -> None:
        self.image = bg.image.copy()
        self.depth = bg.depth.copy()
        self.label = np.zeros(bg.depth.shape, np.int32)
        self.ambient = AMBIENT[modality]

    def person(self, cam: Camera, pid: int, pose: Pose, app: Appearance, sun: np.ndarray
               ) -> PersonPixels | None:
        """Draws one person; returns the silhouette's pixels alone (visible ones come later)."""
        uv, depth = cam.project(pose.points)
        fixed = _fixed(uv)
        h, w = self.depth.shape
        parts = []
        for p, (a, b) in enumerate(zip(pose.starts[:-1], pose.starts[1:], strict=True)):
            if depth[a:b].min() > NEAR_M:
                parts.append((p, a, b, cv2.convexHull(fixed[a:b])[:, 0, :]))
        if not parts:
            return None
        hulls = np.vstack([hull for *_, hull in parts])
        lo, hi = hulls.min(axis=0) // ONE, hulls.max(axis=0) // ONE + 1
        x0, y0 = max(int(lo[0]), 0), max(int(lo[1]), 0)
        x1, y1 = min(int(hi[0]) + 1, w), min(int(hi[1]) + 1, h)
        if x0 >= x1 or y0 >= y1:
            return None  # entirely outside the frame
        alone = np.zeros((y1 - y0, x1 - x0), bool)
        part_depth = cam.to_camera(pose.centres)[:, 2]
        lit = (pose.normals @ sun) > LIT_MIN_COS
        for p, a, b, hull in parts:
            hit = _raster(hull, (h, w))
            if hit is None:
                continue
            px0, py0, m = hit
            alone[py0 - y0 : py0 - y0 + m.shape[0], px0 - x0 : px0 - x0 + m.shape[1]] |= m
            lit_pts = fixed[a:b][lit[a:b]]
            lit_hull = cv2.convexHull(lit_pts)[:, 0, :] if len(lit_pts) >= 3 else None
            mat = pose.material[p]
            colour = _colour(cam, app.colours[mat], app.thermal[mat])
            self._paint(hit, lit_hull, float(part_depth[p]), pid, colour)
        ys, xs = np.nonzero(alone)
        if len(xs) == 0:
            return None
        box = (x0 + int(xs.min()), y0 + int(ys.min()), x0 + int(xs.max()), y0 + int(ys.max()))
        inside = lo.min() >= 0 and hi[0] < w and hi[1] < h
        full = len(xs) if inside else _union_px([hull for *_, hull in parts])
        return PersonPixels(len(xs), 0, box, None, max(full, len(xs)))

    def _paint(self, hit: tuple[int, int, np.ndarray], lit_hull: np.ndarray | None,
               depth: float, pid: int, base: np.ndarray) -> None:
        """Z-tested fill of one part (``hit`` = x0, y0, mask) at constant ``depth``: colour
        ``base`` in shade, full ``base`` inside ``lit_hull`` (fixed-point, frame pixels)."""
        x0, y0, m = hit
        roi = (slice(y0, y0 + m.shape[0]), slice(x0, x0 + m.shape[1]))
        win = m & (depth < self.depth[roi])
        if not win.any():
            return
        tone = np.full(m.shape, self.ambient, np.float32)
        if lit_hull is not None:
            lm = np.zeros(m.shape, np.uint8)
            cv2.fillConvexPoly(lm, lit_hull - np.array([x0 * ONE, y0 * ONE], np.int32), 1,
                               cv2.LINE_8, SHIFT)
            tone[lm.view(bool)] = 1.0
        self.image[roi][win] = tone[win][:, None] * base
        self.depth[roi][win] = depth
        self.label[roi][win] = pid


def _with_visible(px: PersonPixels, label: np.ndarray, pid: int) -> PersonPixels:
    x0, y0, x1, y1 = px.alone_box
    ys, xs = np.nonzero(label[y0 : y1 + 1, x0 : x1 + 1] == pid)
    if len(xs) == 0:
        return px
    box = (x0 + int(xs.min()), y0 + int(ys.min()), x0 + int(xs.max()), y0 + int(ys.max()))
    return PersonPixels(px.alone_px, len(xs), px.alone_box, box, px.full_px)


def render_frame(
    cam: Camera, bg: Background, people: list[tuple[int, Pose, Appearance]], sun: np.ndarray
) -> FrameRender:
    """Draws cast shadows then people over the background (noise-free, drift-free)."""
    canvas = _Canvas(bg, cam.modality)
    shadow = np.zeros(bg.depth.shape, np.uint8)
    _ground_polygon_mask(cam, [p for _, pose, _ in people for p in shadow_polygons(pose, sun)],
                         shadow)
    cast = shadow.view(bool) & bg.ground & ~bg.static_shadow
    canvas.image[cast] *= SHADOW_GAIN[cam.modality]
    alone = {}
    for pid, pose, app in people:
        px = canvas.person(cam, pid, pose, app, sun)
        if px is not None:
            alone[pid] = px
    pixels = {pid: _with_visible(px, canvas.label, pid) for pid, px in alone.items()}
    return FrameRender(
        image=canvas.image, label=canvas.label, shadow=cast & (canvas.label == 0), people=pixels
    )
