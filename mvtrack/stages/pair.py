"""One overlapping camera pair learns its geometry (SPEC §4–6): the pair step.

Per frame: FOV events in both cameras → point sets and FOV lines (both ways: A's feet at events in
B give B's lines seen in A, and vice versa) → FOV associations, kept as :class:`PairLinks` →
markers from the links → the homography H_b_from_a, re-fitted as markers accumulate.

    state = pair_init(("cam0", "cam1"), ((320, 240), (320, 240)))
    for frame, (ta, tb) in enumerate(targets):
        state, result = pair_step(state, ta, tb, PairConfigs.from_params(params), frame)
    summary = pair_summary(state)          # one pairs.json object (FORMATS.md)

The links are a simple pair-level meta record: the multi-camera stage generalizes them.
Nothing here uses calibration or ground truth.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from mvtrack.params import FovConfig, HomographyConfig, MarkerConfig, Params
from mvtrack.stages import fov
from mvtrack.stages.fov import FovEvent, FovSlot
from mvtrack.stages.homography import HomographyEstimate, HomographyFailure, fit_homography
from mvtrack.stages.markers import (
    MarkerResult,
    MarkerState,
    marker_points,
    marker_step,
    markers_init,
)
from mvtrack.stages.targets import SIDES, CameraTargets

__all__ = [
    "PairConfigs",
    "PairLinks",
    "PairResult",
    "PairState",
    "pair_init",
    "pair_step",
    "pair_summary",
]

SlotKey = tuple[int, str]
"""(index of the camera the line is seen in: 0 = A, 1 = B; side of the other camera)."""


@dataclass(frozen=True)
class PairConfigs:
    """The three stage configs the pair step composes."""

    fov: FovConfig = field(default_factory=FovConfig)
    markers: MarkerConfig = field(default_factory=MarkerConfig)
    homography: HomographyConfig = field(default_factory=HomographyConfig)

    @classmethod
    def from_params(cls, params: Params) -> PairConfigs:
        return cls(params.fov, params.markers, params.homography)


@dataclass(frozen=True)
class PairLinks:
    """One-to-one links between A labels and B labels, with the frame each was made.

    b_of_a: A label -> B label;  since: (A label, B label) -> frame of the link
    """

    b_of_a: dict[int, int] = field(default_factory=dict)
    since: dict[tuple[int, int], int] = field(default_factory=dict)

    def pairs(self) -> tuple[tuple[int, int], ...]:
        return tuple(sorted(self.b_of_a.items()))

    def a_of(self, b_label: int) -> int | None:
        return next((a for a, b in self.b_of_a.items() if b == b_label), None)

    def add(self, a_label: int, b_label: int, frame: int) -> PairLinks:
        """A copy with (a, b) linked; earlier links of either label are replaced."""
        b_of_a = {a: b for a, b in self.b_of_a.items() if a != a_label and b != b_label}
        b_of_a[a_label] = b_label
        since = {k: v for k, v in self.since.items() if k in b_of_a.items()}
        since[(a_label, b_label)] = frame
        return PairLinks(b_of_a, since)

    @classmethod
    def of(cls, pairs: Sequence[tuple[int, int]], earlier: PairLinks, frame: int) -> PairLinks:
        """Exactly ``pairs`` (decided outside); ``since`` kept from ``earlier``, else ``frame``."""
        b_of_a = {int(a): int(b) for a, b in pairs}
        since = {k: earlier.since.get(k, frame) for k in b_of_a.items()}
        return cls(b_of_a, since)

    def prune(self, a_labels: set[int], b_labels: set[int]) -> PairLinks:
        """A copy without links whose A or B target is absent (retired)."""
        b_of_a = {a: b for a, b in self.b_of_a.items() if a in a_labels and b in b_labels}
        since = {k: v for k, v in self.since.items() if k in b_of_a.items()}
        return PairLinks(b_of_a, since)


@dataclass(frozen=True)
class PairState:
    """Everything one pair has learned. Frozen; steps return a new state.

    names, sizes:   the two cameras (A, B) and their (width, height)
    touches:        per camera, previous frame's touched sides per label (FOV events)
    slots:          (seen_in index, side) -> point set, line and Hough transform
    homography:     the current valid estimate, else the latest failure
    fit_markers:    marker count at the last fit;  fit_dropped: markers ever dropped then
    fit_frame:      frame of the last fit attempt (-1: none)
    n_events:       FOV events so far, both cameras
    """

    names: tuple[str, str]
    sizes: tuple[tuple[int, int], tuple[int, int]]
    touches: tuple[fov.TouchHistory, fov.TouchHistory]
    slots: dict[SlotKey, FovSlot]
    links: PairLinks
    markers: MarkerState
    homography: HomographyEstimate | HomographyFailure
    fit_markers: int = 0
    fit_dropped: int = 0
    fit_frame: int = -1
    n_events: int = 0


@dataclass(frozen=True)
class PairResult:
    """Every intermediate of one pair step, for the viewer.

    events:        FOV events this frame, both cameras
    slots:         all eight point sets with their lines and last Hough transforms
    reestimated:   slot keys whose line was re-estimated this frame
    associations:  (A label, B label, the event that made it) linked this frame
    links:         all (A label, B label) links after this frame
    markers:       marker dropping this frame (new markers, rejections, the whole store)
    homography:    current estimate (valid) or failure;  attempt: this frame's fit, if any
    """

    frame: int
    events: tuple[FovEvent, ...]
    slots: tuple[FovSlot, ...]
    reestimated: tuple[SlotKey, ...]
    associations: tuple[tuple[int, int, FovEvent], ...]
    links: tuple[tuple[int, int], ...]
    markers: MarkerResult
    homography: HomographyEstimate | HomographyFailure
    attempt: HomographyEstimate | HomographyFailure | None


def pair_init(names: tuple[str, str], sizes: tuple[tuple[int, int], tuple[int, int]]) -> PairState:
    """The empty state of pair (A, B) = ``names`` with frame sizes (width, height)."""
    slots = {
        (i, side): fov.new_slot(names[i], names[1 - i], side, sizes[i])
        for i in (0, 1)
        for side in SIDES
    }
    return PairState(
        names=names,
        sizes=sizes,
        touches=({}, {}),
        slots=slots,
        links=PairLinks(),
        markers=markers_init(sizes[0]),
        homography=HomographyFailure("no markers yet"),
    )


def _learn_lines(
    state: PairState, cams: tuple[CameraTargets, CameraTargets], cfg: FovConfig, frame: int
) -> tuple[dict[SlotKey, FovSlot], tuple[FovEvent, ...], list[SlotKey], tuple]:
    """Events in both cameras, the slots they feed, and which lines were re-estimated."""
    slots = dict(state.slots)
    touches = []
    events: list[FovEvent] = []
    for i in (0, 1):
        hist, evs = fov.detect_events(
            state.touches[i], cams[i], state.names[i], frame, cfg.edge_margin_px
        )
        touches.append(hist)
        events += evs
        for ev in evs:  # an event in camera i feeds the line seen in the other camera
            key = (1 - i, ev.side)
            slots[key] = fov.add_event(slots[key], frame, cams[1 - i], cfg)
    changed = sorted({(1 - state.names.index(ev.camera), ev.side) for ev in events})
    for key in changed:
        slots[key] = fov.estimate_line(slots[key], cfg, frame)
    return slots, tuple(events), changed, (touches[0], touches[1])


def _associate(
    events: tuple[FovEvent, ...],
    slots: dict[SlotKey, FovSlot],
    links: PairLinks,
    cams: tuple[CameraTargets, CameraTargets],
    cfg: FovConfig,
) -> tuple[PairLinks, list[tuple[int, int, FovEvent]]]:
    """At each event, link its target to the other camera's target nearest the learned line."""
    made = []
    present = (set(cams[0].labels.tolist()), set(cams[1].labels.tolist()))
    for ev in events:
        i = 1 if ev.camera == slots[(0, ev.side)].edge_of else 0  # camera of the event
        line = slots[(1 - i, ev.side)].line
        linked = links.b_of_a.values() if i == 1 else links.b_of_a.keys()
        if line is None or ev.target in linked:
            continue
        other_linked = links.b_of_a.keys() if i == 1 else links.b_of_a.values()
        taken = frozenset(label for label in other_linked if label in present[1 - i])
        match = fov.best_match(line.line, cams[1 - i], taken, cfg)
        if match is None:
            continue
        a_label, b_label = (match, ev.target) if i == 1 else (ev.target, match)
        links = links.add(a_label, b_label, ev.frame)
        made.append((a_label, b_label, ev))
    return links, made


def _maybe_fit(
    state: PairState, markers: MarkerState, cfg: HomographyConfig, frame: int
) -> tuple[HomographyEstimate | HomographyFailure, HomographyEstimate | HomographyFailure | None]:
    """Re-fit when new markers arrived and (no valid H yet, count grew, or it is time)."""
    n = len(markers.cells)
    current = state.homography
    if markers.n_dropped == state.fit_dropped or n < 4:
        return current, None
    due = (
        not current
        or n >= state.fit_markers * (1 + cfg.refit_growth_frac)
        or frame - state.fit_frame >= cfg.refit_every_frames
    )
    if not due:
        return current, None
    pts_a, pts_b = marker_points(markers)
    rng = np.random.default_rng([cfg.ransac_seed, frame])
    attempt = replace(fit_homography(pts_a, pts_b, cfg, rng), from_frame=frame)
    return (attempt if attempt or not current else current), attempt


def pair_step(
    state: PairState,
    a: CameraTargets,
    b: CameraTargets,
    cfg: PairConfigs,
    frame: int,
    *,
    links: Sequence[tuple[int, int]] | None = None,
) -> tuple[PairState, PairResult]:
    """Advance pair (A, B) by one frame with both cameras' targets of clip frame ``frame``.

    ``links``: the (A label, B label) pairs currently sharing a meta-target, decided outside
    (the multi-camera stage). When given, markers come from exactly these links and FOV
    association treats them as already linked; the associations it proposes this frame are in
    :attr:`PairResult.associations` for the caller to act on. When None, the pair keeps its own
    :class:`PairLinks` from its FOV associations (a pair-level meta record).
    """
    for cam, size, name in zip((a, b), state.sizes, state.names, strict=True):
        if tuple(cam.size) != tuple(size):
            raise ValueError(f"camera {name}: targets have size {cam.size}, pair expects {size}")
    cams = (a, b)
    slots, events, changed, touches = _learn_lines(state, cams, cfg.fov, frame)
    base = state.links if links is None else PairLinks.of(links, state.links, frame)
    base = base.prune(set(a.labels.tolist()), set(b.labels.tolist()))
    new_links, made = _associate(events, slots, base, cams, cfg.fov)
    marker_links = new_links.pairs() if links is None else base.pairs()
    markers, marker_result = marker_step(state.markers, marker_links, a, b, cfg.markers, frame)
    homography, attempt = _maybe_fit(state, markers, cfg.homography, frame)
    fitted = attempt is not None
    new_state = PairState(
        names=state.names,
        sizes=state.sizes,
        touches=touches,
        slots=slots,
        links=new_links,
        markers=markers,
        homography=homography,
        fit_markers=len(markers.cells) if fitted else state.fit_markers,
        fit_dropped=markers.n_dropped if fitted else state.fit_dropped,
        fit_frame=frame if fitted else state.fit_frame,
        n_events=state.n_events + len(events),
    )
    result = PairResult(
        frame=frame,
        events=events,
        slots=tuple(slots.values()),
        reestimated=tuple(changed),
        associations=tuple(made),
        links=new_links.pairs(),
        markers=marker_result,
        homography=homography,
        attempt=attempt,
    )
    return new_state, result


def pair_summary(state: PairState) -> dict[str, Any]:
    """The pair's ``pairs.json`` object (FORMATS.md)."""
    est = state.homography
    lines = [
        {
            "seen_in": s.line.seen_in,
            "edge_of": s.line.edge_of,
            "side": s.line.side,
            "line": list(s.line.line),
            "events": s.line.events,
            "from_frame": s.line.from_frame,
        }
        for s in state.slots.values()
        if s.line is not None
    ]
    return {
        "cameras": list(state.names),
        "H": est.H_b_from_a.tolist() if isinstance(est, HomographyEstimate) else None,
        "H_from_frame": est.from_frame if isinstance(est, HomographyEstimate) else None,
        "markers": len(state.markers.cells),
        "fov_events": state.n_events,
        "fov_lines": lines,
    }
