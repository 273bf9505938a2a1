"""End-of-run homography [beyond]: each pair's H fitted again from the whole-run labels.

Online (SPEC §5–6) a pair's H comes from the markers its links dropped while the run went on:
links made before the labels settled, a grid of cells where the newest marker wins, and a fit
re-done only as markers accumulate. Once the run is over, the whole-run labels
(`stages/resolve.py`) say which targets of the two cameras are one person in every frame, so
every such pair of targets is a correspondence: :func:`label_markers` takes one on every
marker frame (``markers.marker_every_frames``) that passes the thesis's marker tests (a) and
(b), both fully inside and heights near their recent median, but not (c), motion: a person
standing still gives a marker each time, as they are no less one person then. (With (c), 8
px, the refit beat the online H on 8 of the 27 pairs of seeds 0-2 instead of 17: it keeps a
third of the markers.) :func:`refit_homography` fits them with the robust fit and its link
checks (`stages/homography.py`; the markers of one target pair are one link).

On the generated sweep clips (105 pairs with H, seeds 0-11) the refit's p90 transfer error
against the true H is lower than the online H's by over 0.5 px on 58 pairs and higher on 16;
which one a run hands on is decided in `pipeline.refit_h` (``resolve.refit_h_max_share_drop``).

    est, markers = refit_homography(rows, res.meta, ("cam0", "cam1"), sizes, params.markers,
                                    params.homography)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from mvtrack.params import HomographyConfig, MarkerConfig
from mvtrack.stages.homography import (
    HomographyEstimate,
    HomographyFailure,
    fit_people_markers,
)
from mvtrack.stages.targets import CameraTargets

if TYPE_CHECKING:  # resolve.py keeps the refits in its Resolution
    from mvtrack.stages.resolve import Rows

__all__ = ["LabelMarkers", "RefitH", "label_markers", "refit_homography"]


@dataclass(frozen=True)
class LabelMarkers:
    """Markers of a run's labels: rows_a, rows_b (M,) int64, the A and B row of each marker;
    groups (M,) int64, the id of its (A target, B target) link."""

    rows_a: np.ndarray
    rows_b: np.ndarray
    groups: np.ndarray

    def __len__(self) -> int:
        return len(self.groups)


def _steady(rows: Rows, index: np.ndarray, cfg: MarkerConfig) -> np.ndarray:
    """(len(index),) bool: test (b), each row's height within ``height_tolerance`` of the
    median of its target's last ``height_window_frames`` rows (this one included)."""
    ok = np.zeros(len(index), bool)
    order = np.lexsort((rows.frame[index], rows.target[index]))
    targets = rows.target[index][order]
    for run in np.split(order, np.flatnonzero(targets[1:] != targets[:-1]) + 1):
        heights = rows.height[index[run]]
        for k, j in enumerate(run.tolist()):
            median = float(np.median(heights[max(0, k + 1 - cfg.height_window_frames): k + 1]))
            ok[j] = abs(heights[k] - median) <= cfg.height_tolerance * median
    return ok


def _usable(rows: Rows, meta: np.ndarray, camera: str, size: tuple[int, int],
            cfg: MarkerConfig) -> dict[tuple[int, int], int]:
    """(frame, meta) -> row of ``camera`` on the marker frames where the target is fully
    inside (test a) and steady (test b); a meta with two targets in one frame (a person's
    legs tracked apart) gives none."""
    index = np.flatnonzero(rows.camera == camera)
    targets = CameraTargets(rows.target[index], rows.feet[index], rows.height[index],
                            rows.boxes_xywh[index], size)
    keep = (~targets.touches(cfg.inside_margin_px).any(axis=1)
            & (rows.frame[index] % cfg.marker_every_frames == 0) & _steady(rows, index, cfg))
    frame_meta = np.c_[rows.frame[index], meta[index]]
    _, first, count = np.unique(frame_meta, axis=0, return_inverse=True, return_counts=True)
    keep &= count[first] == 1
    return {(int(rows.frame[i]), int(meta[i])): i for i in index[keep].tolist()}


def label_markers(rows: Rows, meta: np.ndarray, names: tuple[str, str],
                  sizes: Mapping[str, tuple[int, int]], cfg: MarkerConfig) -> LabelMarkers:
    """Every (A row, B row) of one frame and one ``meta`` ((N,) int64 per row: the whole-run
    labels) that passes the marker tests (a) and (b) in both cameras, in frame order."""
    a, b = (_usable(rows, meta, name, sizes[name], cfg) for name in names)
    keys = sorted(a.keys() & b.keys())
    rows_a = np.array([a[k] for k in keys], np.int64)
    rows_b = np.array([b[k] for k in keys], np.int64)
    ids: dict[tuple[int, int], int] = {}
    groups = np.array([ids.setdefault((int(rows.target[i]), int(rows.target[j])), len(ids))
                       for i, j in zip(rows_a.tolist(), rows_b.tolist(), strict=True)], np.int64)
    return LabelMarkers(rows_a, rows_b, groups)


def refit_homography(
    rows: Rows, meta: np.ndarray, names: tuple[str, str],
    sizes: Mapping[str, tuple[int, int]], mcfg: MarkerConfig, hcfg: HomographyConfig,
) -> tuple[HomographyEstimate | HomographyFailure, LabelMarkers]:
    """H_b_from_a fitted to the run's :func:`label_markers` as the pair stage fits its markers
    (:func:`~mvtrack.stages.homography.fit_people_markers`, the link checks on), seeded apart
    from the online fits; and the markers."""
    markers = label_markers(rows, meta, names, sizes, mcfg)
    if len(markers) < 4:
        return HomographyFailure(f"{len(markers)} markers, need 4", len(markers)), markers
    est = fit_people_markers(
        rows.feet[markers.rows_a], rows.feet[markers.rows_b],
        np.c_[rows.height[markers.rows_a], rows.height[markers.rows_b]], hcfg,
        np.random.default_rng([hcfg.ransac_seed, 3]), groups=markers.groups)
    return est, markers


@dataclass(frozen=True)
class RefitH:
    """A pair's end-of-run homography: the fit (falsy with a reason when it failed), how many
    markers it was given, the share of the targets it projects well inside the other camera
    that find one there (:func:`~mvtrack.stages.pair.found_share`), the same of the H the
    whole-run labels used (None: none or no projection) and whether the refit is the H the
    run hands on (``used``)."""

    estimate: HomographyEstimate | HomographyFailure
    markers: int
    found_share: float | None
    in_use_share: float | None
    used: bool

