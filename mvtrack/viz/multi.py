"""Multi-camera layers: association costs, link and meta-target events, cues, ground trails.

Reads the matcher's :class:`~mvtrack.stages.matcher.MatchResult`, the meta step's
:class:`~mvtrack.stages.meta.MetaResult` and the :class:`~mvtrack.stages.cues.Cue` records of a
:class:`~mvtrack.pipeline.FrameResult` and logs through a :class:`~mvtrack.viz.sink.RerunSink`.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import partial
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr

from mvtrack.viz import paths
from mvtrack.viz.log import ring_strips, strips_key, to_viewer

if TYPE_CHECKING:
    from mvtrack.viz.sink import RerunSink

__all__ = ["conflict_message", "cost_table", "log_cues", "log_matches", "log_meta"]

_CUE_RADIUS_PX = 10.0  # hollow ring of an expected-but-unseen meta-target, pixels


def cost_table(a: str, b: str, m: Any) -> str:
    """Markdown table of a match step's cost matrix (body heights), rows A, columns B."""
    if not m.used_homography:
        return f"**{a}–{b}**: no homography yet; links come from FOV associations only."
    head = "| " + a + " \\\\ " + b + " | " + " | ".join(f"t{x}" for x in m.b_labels.tolist()) \
        + " |"
    rule = "|---" * (len(m.b_labels) + 1) + "|"
    rows = [f"| t{x} | " + " | ".join(f"{v:.2f}" for v in m.cost[i]) + " |"
            for i, x in enumerate(m.a_labels.tolist())]
    return "\n".join([f"symmetric transfer distance in body heights ({a} rows, {b} columns)",
                      "", head, rule, *rows])


def log_matches(sink: RerunSink, key: tuple[str, str], m: Any) -> None:
    """Costs and the link events of one pair's match step."""
    a, b = key
    name = paths.pair_name(a, b)
    table = cost_table(a, b, m)
    sink.log_changed(paths.pair_costs(a, b), table.encode(),
                     partial(rr.TextDocument, table, media_type=rr.MediaType.MARKDOWN))
    info, debug = rr.TextLogLevel.INFO, rr.TextLogLevel.DEBUG
    for what, rows, level in (("created", m.created, info), ("re-attached", m.reattached, info),
                              ("broken (inconsistent)", m.broken, rr.TextLogLevel.WARN),
                              ("FOV association rejected by H", m.fov_rejected, info)):
        for x, y, d in rows:
            sink.event(f"pair {name}: link t{x} ↔ t{y} {what}, d = {d:.2f} heights", level)
    for x, y in m.fov_added:
        sink.event(f"pair {name}: link t{x} ↔ t{y} from a FOV association", debug)


def log_meta(sink: RerunSink, meta: Any) -> None:
    """Meta-targets created, merged, split and ended this frame, and links newly rejected as
    conflicts (a rejected link is rejected again every frame: each is told once, until it is
    no longer rejected)."""
    if meta is None:
        return
    rejected = {(c.rejected.a, c.rejected.b): c for c in meta.conflicts}
    for key in sorted(rejected.keys() - sink.conflicts_told):
        sink.event(conflict_message(rejected[key]), rr.TextLogLevel.WARN)
    sink.conflicts_told = set(rejected)
    if meta.created:
        sink.event("new meta-targets " + ", ".join(f"m{x}" for x in meta.created),
                   rr.TextLogLevel.DEBUG)
    for gone, kept in meta.merged:
        sink.event(f"meta-targets merged: m{gone} joins m{kept}")
    for resumed, camera, label in meta.resumed:
        sink.event(f"{camera} t{label} takes back m{resumed}, last seen near it there")
    for old, new in meta.split:
        sink.event(f"meta-target m{old} split: part becomes m{new}", rr.TextLogLevel.WARN)
    if meta.ended:
        sink.event("meta-targets ended " + ", ".join(f"m{x}" for x in meta.ended),
                   rr.TextLogLevel.DEBUG)


def conflict_message(conflict: Any) -> str:
    """One line for a :class:`~mvtrack.stages.meta.Conflict`: the link, the target that keeps
    the meta-target, and why the link cannot join it."""
    (ca, la), (cb, lb) = conflict.rejected.a, conflict.rejected.b
    source = f" ({conflict.rejected.source})" if conflict.rejected.source else ""
    why = (f"{conflict.camera} and {conflict.apart} do not overlap" if conflict.apart
           else f"a meta-target holds one target of {conflict.camera}")
    return (f"link {ca} t{la} ↔ {cb} t{lb}{source} rejected: {conflict.holder[0]} "
            f"t{conflict.holder[1]} keeps the meta-target ({why})")


def log_cues(sink: RerunSink, cameras: Sequence[str], cues: Sequence[Any]) -> None:
    """Hollow rings where a meta-target is expected but not seen, in every camera."""
    rings: dict[str, list[np.ndarray]] = {c: [] for c in cameras}
    ids: dict[str, list[int]] = {c: [] for c in cameras}
    for cue in cues:
        if not cue.expected or cue.seen or not cue.projections or cue.camera not in rings:
            continue
        centre = np.mean([xy for _, xy in cue.projections], axis=0)
        rings[cue.camera] += [to_viewer(r) for r in ring_strips(centre, _CUE_RADIUS_PX)]
        ids[cue.camera].append(cue.meta)
    for cam in cameras:
        labels = [f"m{m} expected" for m in ids[cam]]
        sink.log_changed(paths.camera_layer(cam, "cues"), strips_key(rings[cam], labels),
                         partial(rr.LineStrips2D, rings[cam], class_ids=ids[cam], labels=labels,
                                 radii=1.5, draw_order=12.0))
