"""Single-camera deep dive: the frame with every layer, masks, background and D_B.

One tab per camera; in each, the main view (frame, masks, labels, blobs, the size model's
heights, targets, feet and their height axes, the true people where the clip has truth, FOV
lines, markers, projections) beside the background, D_B and the mask legend's view.
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

from mvtrack.viz import paths
from viewer_blueprints._views import camera_view, events_view, time_panel

__all__ = ["build"]


def _camera_tab(cam: str) -> rrb.Container:
    main = camera_view(cam, extra=[paths.camera_layer(cam, layer)
                                   for layer in ("masks", "blobs", "heights", "axes",
                                                 "truth", "truth_feet")],
                       name=f"{cam}: all layers")
    side = rrb.Vertical(
        rrb.Spatial2DView(origin=paths.camera(cam), name=f"{cam}: background B",
                          contents=[paths.camera_layer(cam, "background")]),
        rrb.Spatial2DView(origin=paths.camera(cam),
                          name=f"{cam}: D_B (white: far from the background)",
                          contents=[paths.camera_layer(cam, "distance"),
                                    paths.camera_layer(cam, "blobs")]),
        rrb.Spatial2DView(origin=paths.camera(cam),
                          name=f"{cam}: masks (MVO, ghost, shadows), heights",
                          contents=[paths.camera_layer(cam, layer)
                                    for layer in ("masks", "blobs", "heights")]),
    )
    below = rrb.Horizontal(
        rrb.TimeSeriesView(origin=f"{paths.METRICS}/targets", name="targets per camera"),
        events_view(),
    )
    return rrb.Vertical(rrb.Horizontal(main, side, column_shares=[2.0, 1.0]), below,
                        row_shares=[3.0, 1.0], name=cam)


def build(cameras: Sequence[str], pairs: Sequence[tuple[str, str]]) -> rrb.Blueprint:
    """One deep-dive tab per camera."""
    return rrb.Blueprint(rrb.Tabs(*(_camera_tab(c) for c in cameras)), time_panel(),
                         collapse_panels=True)
