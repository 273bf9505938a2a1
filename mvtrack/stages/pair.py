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

from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import cv2
import numpy as np
from scipy.optimize import linear_sum_assignment

from mvtrack.params import FovConfig, HomographyConfig, MarkerConfig, Params
from mvtrack.stages import fov
from mvtrack.stages.fov import FovEvent, FovSlot
from mvtrack.stages.homography import (
    HomographyEstimate,
    HomographyFailure,
    fit_people_markers,
    solve_homography,
    transfer_errors,
)
from mvtrack.stages.markers import (
    Candidates,
    Comotion,
    MarkerResult,
    MarkerState,
    candidates_add,
    comotion_confirm,
    comotion_search,
    marker_groups,
    marker_points,
    marker_step,
    markers_add,
    markers_init,
    poolable,
)
from mvtrack.stages.matcher import transfer_costs
from mvtrack.stages.targets import SIDES, CameraTargets

__all__ = [
    "BootstrapRound",
    "PairConfigs",
    "PairLinks",
    "PairPrior",
    "PairResult",
    "PairState",
    "PendingEvent",
    "found_share",
    "pair_init",
    "pair_step",
    "pair_summary",
]

SlotKey = tuple[int, str]
"""(index of the camera the line is seen in: 0 = A, 1 = B; side of the other camera)."""
Check = tuple[int, int, tuple[tuple[int, int], ...]]
"""One frame's verification of H: (projections expected, found, (camera index, label) missed)."""

_MAX_HYPOTHESES = 3  # co-motion hypotheses held side by side awaiting held-out evidence
_VERIFY_MARGIN_PX = 5.0  # verification: projections this far inside the other frame count
_PRIOR = "loaded"  # HomographyEstimate.method of a PairPrior's H: kept, never re-fitted


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
class PendingEvent:
    """An FOV event waiting for the moment its crosser's feet were on the border.

    edge:      index (0 = A, 1 = B) of the camera the event happened in
    samples:   (frame, px from the border) of the crosser's feet while fully inside
    crossing:  the fractional frame at which the other camera's feet are recorded, once known
    """

    event: FovEvent
    edge: int
    samples: tuple[tuple[float, float], ...] = ()
    crossing: float | None = None


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
    first_valid:    (frame, markers fitted, markers dropped, FOV events) when the first valid
                    homography was made, else None
    history:        the last frames' (frame, A targets, B targets), for recording events late
    pending:        events not yet recorded in their point set (crossing time not reached)
    candidates:     co-motion bootstrap pool (bounded); kept when a hypothesis is accepted, it keeps
                    pooling while H is valid so that a dropped H can be replaced at once
    hypotheses:     co-motion hypotheses found but not yet confirmed on later candidates
    refuted:        (A label, B label) pairs linked when verification dropped an H: they never
                    enter the pool again
    checks:         per frame with a valid H (the last ``verify_frames``): (targets it projected
                    well inside the other camera, how many of them had a target there, the
                    (camera index, label) of those that had none)
    checks_anywhere: the same for targets anywhere (not only near the markers)
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
    first_valid: tuple[int, int, int, int] | None = None
    history: tuple[tuple[int, CameraTargets, CameraTargets], ...] = ()
    pending: tuple[PendingEvent, ...] = ()
    candidates: Candidates = field(default_factory=Candidates.empty)
    hypotheses: tuple[Comotion, ...] = ()
    refuted: frozenset[tuple[int, int]] = frozenset()
    checks: tuple[Check, ...] = ()
    checks_anywhere: tuple[Check, ...] = ()


Links = tuple[tuple[int, int], ...]
"""(A label, B label) target pairs a co-motion hypothesis links."""


@dataclass(frozen=True)
class BootstrapRound:
    """One co-motion bootstrap round (every ``comotion_every_frames`` frames while the pair has
    no valid homography): what the viewer tells of why the pair has none yet.

    candidates:    candidate correspondences pooled;  target_pairs: distinct (A label,
                   B label) pairs among them;  supported_pairs: those with at least
                   ``comotion_min_support`` candidates;  needed_pairs: how many of those a
                   hypothesis needs (``comotion_min_pairs``)
    verdicts:      each held hypothesis's links and this round's verdict on it
                   (:func:`~mvtrack.stages.markers.comotion_confirm`: "confirmed", "rejected",
                   "unrefuted" or "waiting"), in the order they were checked (the first
                   confirmed one ends the round)
    found:         the links of the new search's hypothesis; None when no hypothesis is
                   followed by ``comotion_min_pairs`` target pairs, or no search ran
    accepted:      the links of the hypothesis accepted this round (its candidates become
                   markers), or None
    """

    frame: int
    candidates: int
    target_pairs: int
    supported_pairs: int
    needed_pairs: int
    verdicts: tuple[tuple[Links, str], ...] = ()
    found: Links | None = None
    accepted: Links | None = None


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
    bootstrap:     this frame's co-motion bootstrap round, if one ran
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
    bootstrap: BootstrapRound | None = None


@dataclass(frozen=True)
class PairPrior:
    """Geometry learned earlier for the same two static cameras (``mvtrack track --geometry``).

    H_b_from_a: (3, 3) or None; markers: how many markers it came from; lines: (seen_in, side,
    (a, b, c), events) per FOV line
    """

    H_b_from_a: np.ndarray | None
    markers: int = 0
    lines: tuple[tuple[str, str, tuple[float, float, float], int], ...] = ()


def pair_init(names: tuple[str, str], sizes: tuple[tuple[int, int], tuple[int, int]],
              prior: PairPrior | None = None) -> PairState:
    """The empty state of pair (A, B) = ``names`` with frame sizes (width, height).

    With a ``prior``, its H (method "loaded") is in use from the first frame and kept (no
    re-fits) unless it fails its verification (:func:`_verify`), and its FOV lines are known
    from the start.
    """
    slots = {
        (i, side): fov.new_slot(names[i], names[1 - i], side, sizes[i])
        for i in (0, 1)
        for side in SIDES
    }
    homography: HomographyEstimate | HomographyFailure = HomographyFailure("no markers yet")
    if prior is not None:
        for seen_in, side, line, events in prior.lines:
            i = names.index(seen_in)
            slots[i, side] = replace(slots[i, side], line=fov.FovLine(
                seen_in, names[1 - i], side, line, events, -1, "prior"))
        if prior.H_b_from_a is not None:
            homography = HomographyEstimate(prior.H_b_from_a, _PRIOR, prior.markers,
                                            np.zeros(0, bool), np.zeros(0), float("nan"))
    return PairState(
        names=names,
        sizes=sizes,
        touches=({}, {}),
        slots=slots,
        links=PairLinks(),
        markers=markers_init(sizes[0]),
        homography=homography,
    )


def _in_use_from(state: PairState, frame: int) -> PairState:
    """A :class:`PairPrior`'s H and lines (``from_frame`` -1) stamped with the pair's first
    frame: from then on they are in use."""
    H = state.homography
    if isinstance(H, HomographyEstimate) and H.from_frame < 0:
        state = replace(state, homography=replace(H, from_frame=frame))
    slots = {k: replace(s, line=replace(s.line, from_frame=frame))
             if s.line is not None and s.line.from_frame < 0 else s
             for k, s in state.slots.items()}
    return replace(state, slots=slots)


def _samples(
    history: tuple[tuple[int, CameraTargets, CameraTargets], ...],
    edge: int,
    ev: FovEvent,
    margin_px: float,
) -> tuple[tuple[float, float], ...]:
    """(frame, px from the border) of the event's target in ``history`` frames, fully inside."""
    out = []
    for frame, *cams in history:
        cam = cams[edge]
        k = cam.index_of(ev.target)
        if k is None or cam.touches(margin_px)[k].any():
            continue
        d = float(fov.border_distance(cam.feet[k : k + 1], ev.side, cam.size)[0])
        out.append((float(frame), d))
    return tuple(out)


def _decide(p: PendingEvent, state: PairState, frame: int, cfg: FovConfig) -> PendingEvent:
    """Fix the crossing time once enough fully-inside samples exist (or waiting is over)."""
    if p.crossing is not None:
        return p
    ev = p.event
    if ev.side == "top":  # feet never reach the top border: record at the event
        return replace(p, crossing=float(ev.frame))
    if ev.kind == "leave":
        before = [h for h in state.history if h[0] < ev.frame]
        samples = _samples(tuple(before), p.edge, ev, cfg.edge_margin_px)
        samples = samples[-cfg.crossing_fit_frames :]
    else:
        after = [h for h in state.history if h[0] >= ev.frame]
        samples = _samples(tuple(after), p.edge, ev, cfg.edge_margin_px)
        samples = samples[: cfg.crossing_fit_frames]
        if len(samples) < cfg.crossing_fit_frames and frame - ev.frame < cfg.crossing_fit_frames:
            return p
    t = fov.crossing_time(np.array(samples).reshape(-1, 2), ev.frame, ev.kind, cfg)
    return replace(p, samples=samples, crossing=t)


def _targets_at(state: PairState, seen: int, t: float) -> CameraTargets | None:
    """The ``seen`` camera's targets at fractional frame ``t`` from the history (None: gone)."""
    frames = [h[0] for h in state.history]
    if not frames or t < frames[0] or t > frames[-1]:
        return None
    k = int(np.searchsorted(frames, t, side="right")) - 1
    k1 = min(k + 1, len(frames) - 1)
    h0, h1 = state.history[k], state.history[k1]
    t0 = h0[1] if seen == 0 else h0[2]
    t1 = h1[1] if seen == 0 else h1[2]
    return fov.interpolate_targets((h0[0], t0), (h1[0], t1), t)


def _crosser_foot(state: PairState, p: PendingEvent) -> tuple[float, float] | None:
    """The crosser's feet in its own camera at the crossing time, or in the kept frame nearest
    it (a leaving target may be gone by then); None when it is in no kept frame."""
    t = p.crossing if p.crossing is not None else float(p.event.frame)
    own = _targets_at(state, p.edge, t)
    k = None if own is None else own.index_of(p.event.target)
    if own is not None and k is not None:
        return float(own.feet[k, 0]), float(own.feet[k, 1])
    best = None
    for frame, *cams in state.history:
        j = cams[p.edge].index_of(p.event.target)
        if j is not None and (best is None or abs(frame - t) < best[0]):
            best = (abs(frame - t), cams[p.edge].feet[j])
    return None if best is None else (float(best[1][0]), float(best[1][1]))


def _H_seen_from_edge(state: PairState, seen: int) -> np.ndarray | None:
    """The valid homography from the edge camera to camera ``seen`` (0 = A), else None."""
    est = state.homography
    if not isinstance(est, HomographyEstimate):
        return None
    return est.H_b_from_a if seen == 1 else np.linalg.inv(est.H_b_from_a)


def _learn_lines(
    state: PairState, cams: tuple[CameraTargets, CameraTargets], cfg: FovConfig, frame: int
) -> tuple[PairState, tuple[FovEvent, ...], list[SlotKey]]:
    """Events in both cameras, the slots they feed, and which lines were re-estimated.

    An event is recorded in its point set at the moment its crosser's feet were on the border
    (:func:`fov.crossing_time`), from the kept history of the other camera's targets.
    """
    touches = []
    events: list[FovEvent] = []
    for i in (0, 1):
        hist, evs = fov.detect_events(
            state.touches[i], cams[i], state.names[i], frame, cfg.edge_margin_px
        )
        touches.append(hist)
        events += evs
    keep = cfg.crossing_max_shift_frames + cfg.crossing_fit_frames + 2
    history = (*state.history, (frame, cams[0], cams[1]))[-keep:]
    state = replace(state, touches=(touches[0], touches[1]), history=history)
    new = [PendingEvent(ev, state.names.index(ev.camera)) for ev in events]
    slots = dict(state.slots)
    waiting = []
    changed = set()
    for old in (*state.pending, *new):
        p = _decide(old, state, frame, cfg)
        if p.crossing is None or p.crossing > frame:
            waiting.append(p)
            continue
        key = (1 - p.edge, p.event.side)  # an event in one camera feeds the line in the other
        seen = _targets_at(state, 1 - p.edge, p.crossing) or cams[1 - p.edge]
        slots[key] = fov.add_event(
            slots[key], p.event.frame, seen, cfg, p.event.target, _crosser_foot(state, p)
        )
        changed.add(key)
    for key in sorted(changed):
        slots[key] = fov.estimate_line(slots[key], cfg, frame, _H_seen_from_edge(state, key[0]),
                                       state.sizes[1 - key[0]])
    state = replace(state, slots=slots, pending=tuple(waiting))
    return state, tuple(events), sorted(changed)


def _link(
    links: PairLinks,
    edge: int,
    crosser: int,
    seen_label: int | None,
    present: tuple[set[int], set[int]],
) -> tuple[PairLinks, tuple[int, int] | None]:
    """Link the edge camera's ``crosser`` to ``seen_label`` when both are present and free."""
    if seen_label is None or crosser not in present[edge] or seen_label not in present[1 - edge]:
        return links, None
    a_label, b_label = (seen_label, crosser) if edge == 1 else (crosser, seen_label)
    if a_label in links.b_of_a or links.a_of(b_label) is not None:
        return links, None
    return links.add(a_label, b_label, -1), (a_label, b_label)


def _associate(
    events: tuple[FovEvent, ...],
    state: PairState,
    changed: list[SlotKey],
    links: PairLinks,
    cams: tuple[CameraTargets, CameraTargets],
    cfg: FovConfig,
) -> tuple[PairLinks, list[tuple[int, int, FovEvent]]]:
    """FOV associations: at each event, its target and the other camera's target nearest the
    learned line; and when a line is (re-)estimated, each recorded event's crosser and its own
    point on the line (if both targets are still present). Linked targets are not candidates.
    """
    made = []
    present = (set(cams[0].labels.tolist()), set(cams[1].labels.tolist()))
    for ev in events:
        edge = state.names.index(ev.camera)
        line = state.slots[(1 - edge, ev.side)].line
        if line is None:
            continue
        linked = links.b_of_a.keys() if edge == 1 else links.b_of_a.values()
        taken = frozenset(label for label in linked if label in present[1 - edge])
        match = fov.best_match(line.line, cams[1 - edge], taken, cfg)
        links, pair = _link(links, edge, ev.target, match, present)
        if pair is not None:
            made.append((*pair, ev))
    for key in changed:
        slot = state.slots[key]
        if slot.line is None:
            continue
        edge = 1 - key[0]
        for rec in slot.events:
            match = fov.event_match(slot.line.line, rec, cfg)
            links, pair = _link(links, edge, rec.event_target, match, present)
            if pair is not None:
                ev = FovEvent(rec.frame, state.names[edge], rec.event_target, key[1], "line")
                made.append((*pair, ev))
    return links, made


def _bootstrap(
    state: PairState,
    cams: tuple[CameraTargets, CameraTargets],
    links: PairLinks,
    cfg: PairConfigs,
    frame: int,
) -> tuple[Candidates, tuple[Comotion, ...], PairLinks, MarkerState,
           list[tuple[int, int, FovEvent]], BootstrapRound | None]:
    """Co-motion bootstrap while no homography is valid (see :class:`MarkerConfig`).

    Pools candidate pairs (leaving out targets much shorter than their recent heights,
    ``comotion_height_test``); every ``comotion_every_frames`` frames each held hypothesis is
    checked on the candidates pooled since it was found (never used to find it,
    :func:`comotion_confirm`), rejected ones are dropped, and a new search of the whole pool
    adds a hypothesis that pairs the targets differently from every held one (at most
    ``_MAX_HYPOTHESES``, the oldest dropped). Rivals are held side by side because two people
    walking alike fit a swapped pairing as well as the true one at first, and neither can be
    told from the other by support; only people who arrive later follow the true one.
    The first confirmed hypothesis links its present target pairs (associations of kind
    "comotion", side "none"), replacing FOV links of the same targets (one event is weaker
    evidence than many frames), and adds its inlier candidates to the marker store; the held
    hypotheses are then emptied. The pool is kept, and keeps pooling while H is valid: if
    verification drops that H, its links are refuted (they leave the pool) and the next round
    searches the rest at once, instead of waiting for new people to walk by.
    Returns (pool, held hypotheses, links, markers, associations made, this frame's round).
    """
    mcfg = cfg.markers
    if mcfg.comotion_min_pairs == 0:
        return Candidates.empty(), (), links, state.markers, [], None
    a, b = cams
    if frame % mcfg.marker_every_frames == 0:  # only marker frames pool
        a, b = poolable((state.markers.heights_a, state.markers.heights_b), a, b, mcfg)
    pool = candidates_add(state.candidates, a, b, mcfg, frame, state.refuted)
    if state.homography:
        return pool, (), links, state.markers, [], None
    if frame % mcfg.comotion_every_frames or len(pool) < 4:
        return pool, state.hypotheses, links, state.markers, [], None
    accepted, held, round_ = _review(pool, state.hypotheses, cfg, frame)
    if accepted is None:
        return pool, tuple(held), links, state.markers, [], round_
    present = (set(cams[0].labels.tolist()), set(cams[1].labels.tolist()))
    made = []
    for a_label, b_label in accepted.links:  # stronger evidence than one FOV event: replaces
        if a_label in present[0] and b_label in present[1] and links.b_of_a.get(a_label) != b_label:
            links = links.add(a_label, b_label, frame)
            made.append((a_label, b_label, FovEvent(frame, state.names[1], b_label, "none",
                                                    "comotion")))
    return pool, (), links, markers_add(state.markers, accepted.markers, mcfg), made, round_


def _review(pool: Candidates, hypotheses: tuple[Comotion, ...], cfg: PairConfigs,
            frame: int) -> tuple[Comotion | None, list[Comotion], BootstrapRound]:
    """One bootstrap round: the first held hypothesis the pool confirms, else a new search's
    if it is strong enough to need no held-out check (:func:`_strong`), else the
    best-supported (most inlier candidates) of those left unrefuted long enough, else none
    (the new search's hypothesis is held). A hypothesis that only timed out is weaker
    evidence than one that four target pairs follow now: generated 'pair' seed 0 held a swap
    of its first two people from frame 50, which timed out in the round that first found the
    true pairing of four. With ``comotion_drop_contradicted``, one that timed out is not
    accepted when the round's search pairs one of its targets with another target
    (:func:`_contradicts`): the search weighed all the candidates, its own among them, and
    chose otherwise (generated 'pillar' s8 with a front-end change: a timed-out hypothesis
    with one wrong pair of three, 217 px p90 off the true H, accepted at frame 300 in the
    round whose search found the right pairing). Returns (accepted or None, hypotheses still
    held, the round)."""
    mcfg = cfg.markers
    held: list[Comotion] = []
    unrefuted: list[Comotion] = []
    _, per_pair = np.unique(pool.labels, axis=0, return_counts=True)
    round_ = BootstrapRound(frame, len(pool), len(per_pair),
                            int((per_pair >= mcfg.comotion_min_support).sum()),
                            mcfg.comotion_min_pairs)
    verdicts: list[tuple[Links, str]] = []
    accepted = found = None
    for hypothesis in hypotheses:
        verdict, checked = comotion_confirm(pool, hypothesis, mcfg, solve_homography,
                                             transfer_errors, frame)
        verdicts.append((hypothesis.links, verdict))
        if verdict == "confirmed":
            accepted = checked
            break
        if checked is not None:
            (unrefuted if verdict == "unrefuted" else held).append(checked)
    else:
        rng = np.random.default_rng([cfg.homography.ransac_seed, frame, 1])
        found = comotion_search(pool, mcfg, solve_homography, transfer_errors, rng)
        strong = found is not None and _strong(found, mcfg)
        if found is not None and mcfg.comotion_drop_contradicted:
            unrefuted = [h for h in unrefuted if not _contradicts(h.links, found.links)]
        if unrefuted and not strong:  # rivals from the same people: more support pairs better
            accepted = max(unrefuted, key=lambda h: len(h.markers))
        elif found is None or mcfg.comotion_confirm_pairs == 0 or strong:
            accepted = found
        elif all(set(found.links) != set(h.links) for h in held):
            held = [*held, found][-_MAX_HYPOTHESES:]
    return accepted, held, replace(
        round_, verdicts=tuple(verdicts), found=None if found is None else found.links,
        accepted=None if accepted is None else accepted.links)


def _contradicts(links: Links, other: Links) -> bool:
    """Whether a target of one set of (A label, B label) links has another partner in the
    other set."""
    a_to_b, b_to_a = dict(other), {b: a for a, b in other}
    return any(a_to_b.get(a, b) != b or b_to_a.get(b, a) != a for a, b in links)


def _strong(found: Comotion, cfg: MarkerConfig) -> bool:
    """Whether at least ``comotion_accept_pairs`` of the hypothesis's target pairs follow it
    with ``comotion_accept_support`` inlier candidates each (it needs no held-out check)."""
    if cfg.comotion_accept_pairs <= 0:
        return False
    per_pair = Counter((m.a_label, m.b_label) for m in found.markers)
    strong = sum(n >= cfg.comotion_accept_support for n in per_pair.values())
    return strong >= cfg.comotion_accept_pairs


def _near_markers(targets: CameraTargets, hull: np.ndarray | None, margin_heights: float
                  ) -> np.ndarray:
    """(N,) bool: each target's feet within ``margin_heights`` of its heights of the markers'
    convex hull in its camera (every target when ``hull`` is None)."""
    if hull is None:
        return np.ones(len(targets), bool)
    dist = np.array([cv2.pointPolygonTest(hull, (float(x), float(y)), True)
                     for x, y in targets.feet])  # > 0 inside
    return dist >= -margin_heights * targets.heights_px if len(dist) else np.zeros(0, bool)


def _marker_hulls(markers: MarkerState, cfg: HomographyConfig
                  ) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Convex hull (cv2 contour) of the stored markers in each camera, or None (rule off)."""
    if cfg.verify_hull_margin_heights < 0 or len(markers.cells) < 3:
        return None, None
    pts_a, pts_b = marker_points(markers)
    return (cv2.convexHull(pts_a.astype(np.float32)), cv2.convexHull(pts_b.astype(np.float32)))


def _check(H_b_from_a: np.ndarray, a: CameraTargets, b: CameraTargets,
           cfg: HomographyConfig, hulls: tuple[np.ndarray | None, np.ndarray | None],
           ) -> tuple[Check, Check]:
    """This frame's checks of H near the markers and anywhere, each (expected, found, missed):
    targets fully inside their own frame (and, for the first, near the markers there:
    ``hulls``, :func:`_near_markers`) that H projects at least ``_VERIFY_MARGIN_PX`` inside
    the other one, how many of them have a target there within ``verify_gate_heights``
    (symmetric transfer distance, :func:`transfer_costs`), and the (camera index, label) of
    the others."""
    if not len(a) and not len(b):
        return (0, 0, ()), (0, 0, ())
    cost, a_in_b, b_in_a = transfer_costs(H_b_from_a, a, b)
    anywhere, marked, has = [], [], []
    for side, (own, proj, other, near) in enumerate(
            ((a, a_in_b, b, cost), (b, b_in_a, a, cost.T))):
        width, height = other.size
        m = _VERIFY_MARGIN_PX
        inside = (~own.touches(0.0).any(axis=1) & (proj[:, 0] > m) & (proj[:, 0] < width - m)
                  & (proj[:, 1] > m) & (proj[:, 1] < height - m))
        anywhere.append(inside)
        marked.append(inside & _near_markers(own, hulls[side], cfg.verify_hull_margin_heights))
        has.append(near.min(axis=1) < cfg.verify_gate_heights if near.shape[1]
                   else np.zeros(len(own), bool))
    camera = np.repeat([0, 1], [len(a), len(b)])
    labels = np.concatenate([a.labels, b.labels])
    found = np.concatenate(has)

    def tally(inside: np.ndarray) -> Check:
        missed = inside & ~found
        return (int(inside.sum()), int((inside & found).sum()),
                tuple(zip(camera[missed].tolist(), labels[missed].tolist(), strict=True)))

    return tally(np.concatenate(marked)), tally(np.concatenate(anywhere))


def found_share(H_b_from_a: np.ndarray,
                run: Iterable[tuple[int, CameraTargets, CameraTargets]],
                cfg: HomographyConfig) -> float | None:
    """Over a run's frames ((frame, A targets, B targets)), the share of the targets that
    ``H_b_from_a`` projects well inside the other camera (anywhere, :func:`_check`) that find
    a target there within ``verify_gate_heights``; None when it projects none there."""
    expected = found = 0
    for _, a, b in run:
        _, (e, f, _) = _check(H_b_from_a, a, b, cfg, (None, None))
        expected, found = expected + e, found + f
    return found / expected if expected else None


def _missing(checks: tuple[Check, ...], min_frac: float, cfg: HomographyConfig) -> str:
    """Why ``checks`` condemn H ("" when they do not): at least ``verify_min_expected``
    projections, under ``min_frac`` of them found, misses from ``verify_min_targets`` people
    (:func:`_fewest_people`)."""
    expected = sum(e for e, _, _ in checks)
    found = sum(f for _, f, _ in checks)
    if expected < cfg.verify_min_expected or found >= min_frac * expected:
        return ""  # the usual case, every frame: no need to count the people
    people = _fewest_people(checks)
    if people < cfg.verify_min_targets:
        return ""
    return (f"over {len(checks)} frames H put {expected} targets inside the other camera "
            f"and {found} had a target there (misses from at least {people} people)")


def _fewest_people(checks: tuple[Check, ...]) -> int:
    """The fewest people who could have made the checks' misses: each target is one person,
    but a target of A and one of B that missed in disjoint frame spans can be one person
    unseen in turn by each camera (out of one's frame where H extrapolates, then behind an
    occluder in the other). Two that missed in the same frames are two people, or one person
    that H misplaces: evidence against H either way."""
    spans: dict[tuple[int, int], tuple[int, int]] = {}
    for k, (_, _, missed) in enumerate(checks):
        for key in missed:
            first, _ = spans.get(key, (k, k))
            spans[key] = (first, k)
    a = [span for (camera, _), span in spans.items() if camera == 0]
    b = [span for (camera, _), span in spans.items() if camera == 1]
    if not a or not b:
        return len(spans)
    disjoint = np.array([[sa[1] < sb[0] or sb[1] < sa[0] for sb in b] for sa in a])
    rows, cols = linear_sum_assignment(disjoint, maximize=True)
    return len(spans) - int(disjoint[rows, cols].sum())


def _verify(state: PairState, homography: HomographyEstimate | HomographyFailure,
            a: CameraTargets, b: CameraTargets, markers: MarkerState, cfg: HomographyConfig
            ) -> tuple[tuple[Check, ...], tuple[Check, ...], str]:
    """This frame's checks of a valid H added to the pooled ones (near the markers, and
    anywhere), and why H must be dropped ("" while it holds): too few of its projections
    near the markers find a target where it puts them (``verify_min_found_frac``; away from
    the markers H extrapolates, and a miss there says where markers are lacking, not that H
    is wrong), or almost none anywhere (``verify_anywhere_min_found_frac``: an H right only
    near its few markers links nobody elsewhere, so no new marker would ever correct it)."""
    if not isinstance(homography, HomographyEstimate) or cfg.verify_min_found_frac <= 0:
        return (), (), ""
    near, everywhere = _check(homography.H_b_from_a, a, b, cfg, _marker_hulls(markers, cfg))
    checks = (*state.checks, near)[-cfg.verify_frames :]
    anywhere = (*state.checks_anywhere, everywhere)[-cfg.verify_frames :]
    why = (_missing(checks, cfg.verify_min_found_frac, cfg)
           or _missing(anywhere, cfg.verify_anywhere_min_found_frac, cfg))
    if why:
        return (), (), f"dropped: {why}"
    return checks, anywhere, ""


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
    h_ab = np.array([(m.h_a, m.h_b) for m in markers.cells.values()])
    rng = np.random.default_rng([cfg.ransac_seed, frame])
    previous = current.H_b_from_a if isinstance(current, HomographyEstimate) else None
    attempt = replace(fit_people_markers(pts_a, pts_b, h_ab, cfg, rng,
                                         groups=marker_groups(markers), previous=previous),
                      from_frame=frame)
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
    if not state.history:
        state = _in_use_from(state, frame)
    cams = (a, b)
    learned, events, changed = _learn_lines(state, cams, cfg.fov, frame)
    base = state.links if links is None else PairLinks.of(links, state.links, frame)
    base = base.prune(set(a.labels.tolist()), set(b.labels.tolist()))
    new_links, made = _associate(events, learned, changed, base, cams, cfg.fov)
    pool, held, new_links, boot_markers, boot, round_ = _bootstrap(state, cams, new_links, cfg,
                                                                  frame)
    made += boot
    learned = replace(learned, markers=boot_markers, candidates=pool, hypotheses=held)
    made_now = {(x, y) for x, y, _ in made}
    new_links = PairLinks(
        new_links.b_of_a,
        {k: (frame if k in made_now else v) for k, v in new_links.since.items()},
    )
    marker_links = new_links.pairs() if links is None else base.pairs()
    markers, marker_result = marker_step(learned.markers, marker_links, a, b, cfg.markers, frame)
    prior = isinstance(state.homography, HomographyEstimate) and state.homography.method == _PRIOR
    homography, attempt = (state.homography, None) if prior else _maybe_fit(
        state, markers, cfg.homography, frame)
    fitted = attempt is not None
    checks, anywhere, dropped = _verify(state, homography, a, b, markers, cfg.homography)
    refuted = state.refuted
    if dropped:  # its markers would fit it again: learning starts over, without its links
        homography = HomographyFailure(dropped, len(markers.cells), frame)
        refuted = refuted | set(marker_links)
        learned = replace(learned, candidates=learned.candidates.without(refuted))
        markers, new_links = markers_init(state.sizes[0]), PairLinks()
        attempt, fitted = homography, True
    n_events = state.n_events + len(events)
    first_valid = state.first_valid
    if first_valid is None and homography:
        first_valid = (frame, len(markers.cells), markers.n_dropped, n_events)
    if attempt:  # a new homography tells each recorded event's crosser: refine every line
        refit = replace(learned, homography=homography)
        slots = {
            key: fov.estimate_line(slot, cfg.fov, frame, _H_seen_from_edge(refit, key[0]),
                                   refit.sizes[1 - key[0]])
            if slot.line is not None else slot
            for key, slot in learned.slots.items()
        }
        learned = replace(learned, slots=slots)
    new_state = replace(
        learned,
        links=new_links,
        markers=markers,
        homography=homography,
        fit_markers=len(markers.cells) if fitted else state.fit_markers,
        fit_dropped=markers.n_dropped if fitted else state.fit_dropped,
        fit_frame=frame if fitted else state.fit_frame,
        n_events=n_events,
        first_valid=first_valid,
        refuted=refuted,
        checks=checks,
        checks_anywhere=anywhere,
    )
    result = PairResult(
        frame=frame,
        events=events,
        slots=tuple(learned.slots.values()),
        reestimated=tuple(changed),
        associations=tuple(made),
        links=new_links.pairs(),
        markers=marker_result,
        homography=homography,
        attempt=attempt,
        bootstrap=round_,
    )
    return new_state, result


def pair_summary(state: PairState) -> dict[str, Any]:
    """The pair's ``pairs.json`` object (FORMATS.md), with optional keys.

    ``sizes``: [[width, height], [width, height]] of the two cameras; ``H_first``: null, or
    ``{"frame", "markers", "markers_dropped", "fov_events"}`` when the first valid homography
    was made (markers in the fit, markers dropped so far, FOV events so far); each FOV line's
    ``source``, what gave it (:class:`~mvtrack.stages.fov.FovLine`: "homography" is the other
    camera's border through H).
    """
    est = state.homography
    lines = [
        {
            "seen_in": s.line.seen_in,
            "edge_of": s.line.edge_of,
            "side": s.line.side,
            "line": list(s.line.line),
            "events": s.line.events,
            "from_frame": s.line.from_frame,
            "source": s.line.source,
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
        "sizes": [list(size) for size in state.sizes],
        "H_first": None
        if state.first_valid is None
        else dict(zip(("frame", "markers", "markers_dropped", "fov_events"), state.first_valid,
                      strict=True)),
    }
