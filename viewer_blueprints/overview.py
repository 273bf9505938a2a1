"""Overview: every camera side by side, the ground map, the event log and the metrics.

The event log shows INFO and above (FOV events, links, homographies, meta-target merges,
warnings); the tracker's per-camera births, splits, merges and retirements are DEBUG lines,
shown in the camera layout's log (or here after ticking DEBUG in the view's level filter).
"""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

from mvtrack.viz import paths
from viewer_blueprints._views import (
    INFO_AND_ABOVE,
    camera_view,
    events_view,
    ground_view,
    time_panel,
)

__all__ = ["build"]


def build(cameras: Sequence[str], pairs: Sequence[tuple[str, str]]) -> rrb.Blueprint:
    """Cameras in a grid on top; ground map, events and metrics below."""
    cams = rrb.Grid(*(camera_view(c) for c in cameras), grid_columns=min(3, max(1, len(cameras))),
                    name="cameras")
    metrics = rrb.Tabs(
        rrb.TimeSeriesView(origin=f"{paths.METRICS}/targets", name="targets per camera"),
        rrb.TimeSeriesView(origin=f"{paths.METRICS}/stage_ms", name="ms per stage"),
        rrb.TimeSeriesView(origin=paths.METRICS, name="errors vs truth (px)",
                           contents=[f"{paths.METRICS}/foot_error_px/**",
                                     f"{paths.METRICS}/transfer_error_px/**"]),
        name="metrics",
    )
    bottom = rrb.Horizontal(ground_view(), events_view(INFO_AND_ABOVE), metrics,
                            column_shares=[1.0, 1.2, 1.2])
    return rrb.Blueprint(rrb.Vertical(cams, bottom, row_shares=[2.0, 1.0]), time_panel(),
                         collapse_panels=True)
