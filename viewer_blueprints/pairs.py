"""Pair learning: both cameras with FOV lines, markers and projections, the Hough spaces,
and the homography's quality, marker count and transfer error over time. One tab per pair.
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

from mvtrack.viz import paths
from viewer_blueprints._views import camera_view, events_view, time_panel

__all__ = ["build"]


def _pair_tab(a: str, b: str) -> rrb.Container:
    cams = rrb.Horizontal(camera_view(a, name=f"{a} (lines of {b}'s edges)"),
                          camera_view(b, name=f"{b} (lines of {a}'s edges)"))
    hough = rrb.Spatial2DView(origin=paths.hough(a, b),
                              name="Hough spaces (rows: seen in A, B; theta down, rho across)")
    series = rrb.Tabs(
        rrb.TimeSeriesView(origin=paths.pair(a, b), name="markers, links, quality (px)",
                           contents=[paths.pair_layer(a, b, layer) for layer in
                                     paths.PAIR_LAYERS]),
        rrb.TimeSeriesView(origin=paths.marker_rejections(a, b),
                           name="marker tests failed (links, so far)"),
        rrb.TimeSeriesView(origin=f"{paths.METRICS}/transfer_error_px", name="transfer error"),
        rrb.TextDocumentView(origin=paths.pair_costs(a, b), name="association costs"),
    )
    bottom = rrb.Horizontal(hough, series, events_view(), column_shares=[1.3, 1.0, 1.0])
    return rrb.Vertical(cams, bottom, row_shares=[1.6, 1.0], name=paths.pair_name(a, b))


def build(cameras: Sequence[str], pairs: Sequence[tuple[str, str]]) -> rrb.Blueprint:
    """One tab per pair (a placeholder text view when the clip has no pairs)."""
    tabs: list[rrb.Container | rrb.View] = [_pair_tab(a, b) for a, b in pairs]
    if not tabs:
        tabs = [rrb.TextDocumentView(origin=paths.CLIP, name="no overlapping pairs")]
    return rrb.Blueprint(rrb.Tabs(*tabs), time_panel(), collapse_panels=True)
