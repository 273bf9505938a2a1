"""Camera cueing (SPEC §9, thesis §1.4): which cameras should see each person now.

For every live meta-target and every camera: ``seen`` when the camera has a target in the
meta-target; ``expected`` when it is seen there or when its feet, projected from any camera that
sees it through a learned pair homography, fall at least ``cue_margin_px`` inside that camera's
frame. A live meta-target with no target this frame (not seen anywhere for less than the
timeout) is projected from the last feet seen in each camera.

    cues = camera_cues(CueInputs(meta_result, sizes, homographies), params.meta)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mvtrack.params import MetaConfig
from mvtrack.stages.homography import apply_homography
from mvtrack.stages.meta import MetaResult

__all__ = ["Cue", "CueInputs", "camera_cues"]


@dataclass(frozen=True)
class Cue:
    """One (meta, camera) cue.

    expected:    the camera should see the meta-target now
    seen:        the camera has a target in it
    projections: (source camera, [x, y] px in this camera) for every projection made
    """

    meta: int
    camera: str
    expected: bool
    seen: bool
    projections: tuple[tuple[str, tuple[float, float]], ...] = ()


@dataclass(frozen=True)
class CueInputs:
    """The meta step's record, each camera's (width, height), and the valid pair homographies.

    homographies: (camera a, camera b) -> (3, 3) H_b_from_a for pairs with a valid estimate
    """

    metas: MetaResult
    sizes: Mapping[str, tuple[int, int]]
    homographies: Mapping[tuple[str, str], np.ndarray]


def _inside(point: np.ndarray, size: tuple[int, int], margin: float) -> bool:
    w, h = size
    x, y = float(point[0]), float(point[1])
    return margin - 0.5 <= x <= w - 0.5 - margin and margin - 0.5 <= y <= h - 0.5 - margin


def _transfers(homographies: Mapping[tuple[str, str], np.ndarray]) -> dict[
        tuple[str, str], np.ndarray]:
    """(source, destination) -> H_dst_from_src, both directions of every pair."""
    out: dict[tuple[str, str], np.ndarray] = {}
    for (a, b), H in homographies.items():
        out[a, b] = np.asarray(H, np.float64)
        out[b, a] = np.asarray(np.linalg.inv(out[a, b]), np.float64)
    return out


def camera_cues(inputs: CueInputs, cfg: MetaConfig) -> tuple[Cue, ...]:
    """Every live meta-target x every camera, sorted by (meta, camera)."""
    transfers = _transfers(inputs.homographies)
    seen_in: dict[int, set[str]] = {}
    for meta, members in inputs.metas.members.items():
        seen_in[meta] = {cam for cam, _ in members}
    cues = []
    for meta in inputs.metas.live:
        cams = seen_in.get(meta, set())
        feet = inputs.metas.last_feet.get(meta, {})
        sources = {c: p for c, p in feet.items() if c in cams} if cams else feet
        for camera in sorted(inputs.sizes):
            projections = []
            expected = camera in cams
            for src, point in sorted(sources.items()):
                H = transfers.get((src, camera))
                if H is None:
                    continue
                p = apply_homography(H, np.asarray([point], np.float64))[0]
                projections.append((src, (float(p[0]), float(p[1]))))
                expected |= bool(np.all(np.isfinite(p))) and _inside(
                    p, inputs.sizes[camera], cfg.cue_margin_px)
            cues.append(Cue(meta, camera, expected, camera in cams, tuple(projections)))
    return tuple(cues)
