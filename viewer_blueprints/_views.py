"""Views shared by the layouts."""

from __future__ import annotations

from collections.abc import Sequence

import rerun.blueprint as rrb

from mvtrack.viz import paths

__all__ = [
    "ALL_LEVELS",
    "INFO_AND_ABOVE",
    "camera_view",
    "events_view",
    "ground_view",
    "metrics_view",
    "time_panel",
]

OVERLAYS = ("image", "labels", "targets", "feet", "feet_final", "resolved", "fov_events", "cues")
"""Layers of the main camera view, bottom to top (the frame and what was found on it)."""


def camera_view(cam: str, extra: Sequence[str] = (), name: str | None = None) -> rrb.View:
    """The camera's frame with its targets (coloured by meta), feet, events and pair layers."""
    contents = [paths.camera_layer(cam, layer) for layer in OVERLAYS]
    contents += [f"{paths.camera(cam)}/{layer}/**" for layer in paths.CAMERA_PAIR_LAYERS]
    contents += list(extra)
    return rrb.Spatial2DView(origin=paths.camera(cam), contents=contents, name=name or cam)


def ground_view() -> rrb.View:
    return rrb.Spatial2DView(origin=paths.GROUND, name="ground plane (all cameras)")


INFO_AND_ABOVE = ("CRITICAL", "ERROR", "WARN", "INFO")
"""Event levels the overview shows: tracker births, splits, merges and retirements are DEBUG."""

ALL_LEVELS = (*INFO_AND_ABOVE, "DEBUG", "TRACE")
"""Every level of ``rr.TextLogLevel``."""


def events_view(levels: Sequence[str] = ALL_LEVELS) -> rrb.View:
    """The event log, showing only lines of ``levels`` (the viewer's level filter starts there;
    the user can tick the others back on in the view's selection panel)."""
    hidden = [level for level in ALL_LEVELS if level not in levels]
    name = "events" if not hidden else f"events ({', '.join(hidden)} hidden)"
    rows = rrb.archetypes.TextLogRows(filter_by_log_level=list(levels))
    return rrb.TextLogView(origin=paths.EVENTS, name=name, rows=rows)


def metrics_view(name: str, origin: str) -> rrb.View:
    return rrb.TimeSeriesView(origin=origin, name=name)


def time_panel() -> rrb.TimePanel:
    return rrb.TimePanel(timeline=paths.FRAME_TIMELINE, expanded=False)
