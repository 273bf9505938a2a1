"""Procedural ground and sky colours, evaluated at any ground point (so every camera, near or far,
sees the same infinite, seeded ground): a paved plaza of running-bond slabs with a concrete curb,
grass around it, large-scale stains, and haze with distance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mvtrack.generate.camera import Camera

__all__ = ["GroundTexture", "background_colours", "thermal_from_rgb"]

SLAB_M = (0.6, 0.4)
GROUT_M = 0.022
CURB_M = 0.3
HAZE_RGB = np.array([188.0, 198.0, 210.0])
HAZE_M = 140.0
FAR_M = 600.0
SKY_HORIZON_RGB = np.array([205.0, 215.0, 232.0])
SKY_ZENITH_RGB = np.array([95.0, 140.0, 212.0])
_TABLE = 128


@dataclass(frozen=True, eq=False)
class GroundTexture:
    """Random tables drawn once from the scene's generator; ``plaza`` is (x0, y0, x1, y1) m."""

    slab: np.ndarray  # (T, T, 3) per-slab brightness and tint
    noise: np.ndarray  # (3, T, T) value-noise lattices
    plaza: tuple[float, float, float, float]
    paving_rgb: np.ndarray
    grass_rgb: np.ndarray

    @classmethod
    def random(
        cls, rng: np.random.Generator, plaza: tuple[float, float, float, float]
    ) -> GroundTexture:
        paving = np.array([168.0, 160.0, 146.0]) * rng.uniform(0.9, 1.08)
        grass = np.array([86.0, 122.0, 58.0]) * rng.uniform(0.85, 1.1)
        return cls(
            slab=rng.random((_TABLE, _TABLE, 3)),
            noise=rng.random((3, _TABLE, _TABLE)),
            plaza=plaza,
            paving_rgb=paving,
            grass_rgb=grass,
        )

    def value_noise(self, x: np.ndarray, y: np.ndarray, octave: int, cell_m: float) -> np.ndarray:
        """Smooth noise in [0, 1] with features of ``cell_m`` metres."""
        gx, gy = x / cell_m, y / cell_m
        ix, iy = np.floor(gx).astype(np.int64), np.floor(gy).astype(np.int64)
        fx, fy = gx - ix, gy - iy
        fx, fy = fx * fx * (3 - 2 * fx), fy * fy * (3 - 2 * fy)
        t = self.noise[octave]
        i0, i1, j0, j1 = ix % _TABLE, (ix + 1) % _TABLE, iy % _TABLE, (iy + 1) % _TABLE
        top = t[i0, j0] * (1 - fx) + t[i1, j0] * fx
        bottom = t[i0, j1] * (1 - fx) + t[i1, j1] * fx
        return top * (1 - fy) + bottom * fy

    def colour(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(N,) ground metres -> (N, 3) RGB in 0..255 (float)."""
        x0, y0, x1, y1 = self.plaza
        inside = np.maximum(np.maximum(x0 - x, x - x1), np.maximum(y0 - y, y - y1))
        out = np.empty((len(x), 3))
        paved = inside <= 0.0
        out[paved] = self._paving(x[paved], y[paved])
        curb = (inside > 0.0) & (inside <= CURB_M)
        out[curb] = np.array([196.0, 194.0, 188.0]) * (
            0.93 + 0.1 * self.value_noise(x[curb], y[curb], 2, 0.15)
        )[:, None]
        grass = inside > CURB_M
        n = 0.55 + 0.3 * self.value_noise(x[grass], y[grass], 1, 1.3) + 0.35 * (
            self.value_noise(x[grass], y[grass], 2, 0.09)
        )
        out[grass] = self.grass_rgb * n[:, None]
        stain = 0.86 + 0.22 * self.value_noise(x, y, 0, 4.5)
        return out * stain[:, None]

    def _paving(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        sx, sy = SLAB_M
        row = np.floor(y / sy).astype(np.int64)
        xs = x + 0.5 * sx * (row % 2)
        col = np.floor(xs / sx).astype(np.int64)
        fx, fy = xs / sx - col, y / sy - row
        edge = np.minimum(np.minimum(fx, 1 - fx) * sx, np.minimum(fy, 1 - fy) * sy)
        r = self.slab[col % _TABLE, row % _TABLE]
        shade = 0.86 + 0.2 * r[:, 0] - 0.14 * (r[:, 1] > 0.9)
        tint = np.column_stack([1 + 0.05 * (r[:, 2] - 0.5), np.ones(len(x)),
                                1 - 0.05 * (r[:, 2] - 0.5)])
        grain = 0.94 + 0.12 * self.value_noise(x, y, 2, 0.05)
        rgb = self.paving_rgb * tint * (shade * grain)[:, None]
        return np.where((edge < GROUT_M / 2.0)[:, None], rgb * 0.62, rgb)


def thermal_from_rgb(rgb: np.ndarray) -> np.ndarray:
    """A thermal camera's view of a passive surface: dim, low contrast (people are brighter)."""
    lum = rgb @ np.array([0.3, 0.59, 0.11])
    return 48.0 + 0.25 * lum


def background_colours(cam: Camera, tex: GroundTexture, uv: np.ndarray) -> np.ndarray:
    """(N, 2) pixels -> (N, 3) RGB of the ground (with haze) or the sky seen there."""
    rays = cam.ray_directions(uv)
    centre = cam.centre
    down = rays[:, 2] < -1e-9
    s = np.where(down, -centre[2] / np.where(down, rays[:, 2], -1.0), np.inf)
    gx, gy = centre[0] + s * rays[:, 0], centre[1] + s * rays[:, 1]
    dist = np.hypot(gx - centre[0], gy - centre[1])
    ground = down & (dist < FAR_M)
    out = np.empty((len(uv), 3))
    col = tex.colour(gx[ground], gy[ground])
    haze = 1.0 - np.exp(-dist[ground] / HAZE_M)
    out[ground] = col * (1 - haze[:, None]) + HAZE_RGB * haze[:, None]
    elev = rays[~ground, 2] / np.linalg.norm(rays[~ground], axis=1)
    k = np.sqrt(np.clip(elev, 0.0, 1.0))[:, None]
    out[~ground] = SKY_HORIZON_RGB * (1 - k) + SKY_ZENITH_RGB * k
    return out
