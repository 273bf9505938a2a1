"""Field-of-view events, lines and associations (SPEC §4, thesis §3.2.3; Khan & Shah 2003).

For an ordered pair, camera A "sees the edges of" camera B: whenever a target in B fully enters
(stops touching side s) or starts touching side s, the feet of every target in A are recorded in
the point set of (B, s). A Hough transform of that set gives the FOV line L = (a, b, c),
a² + b² = 1, in A's pixels; a later event in B links B's target to the A target nearest L.

Event definition (Calderara et al.): *enter* on s is the first frame in which a target that touched
exactly side s touches no side; *leave* on s is the first frame in which a target that touched no
side touches exactly side s. Touching two sides at once gives no event.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage

from mvtrack.params import FovConfig
from mvtrack.stages.homography import apply_homography
from mvtrack.stages.targets import SIDES, CameraTargets, touching_sides

__all__ = [
    "FovEvent",
    "FovEventPoints",
    "FovLine",
    "FovSlot",
    "HoughResult",
    "TouchHistory",
    "add_event",
    "best_match",
    "border_distance",
    "border_line",
    "crossing_time",
    "detect_events",
    "estimate_line",
    "event_match",
    "event_votes",
    "hough_line",
    "hough_points",
    "interpolate_targets",
    "line_distances",
    "mask_touching_sides",
    "new_slot",
]

TouchHistory = Mapping[int, tuple[bool, bool, bool, bool]]
"""Previous frame's touched sides (SIDES order) per target label of one camera."""


@dataclass(frozen=True)
class FovEvent:
    """A target of ``camera`` entered (fully inside now) or left (touches now) through ``side``."""

    frame: int
    camera: str
    target: int
    side: str
    kind: str  # "enter" or "leave"


@dataclass(frozen=True)
class HoughResult:
    """A Hough transform over (theta, rho) about the image centre, and the line it gives.

    accumulator: (n_theta, n_rho) float64, smoothed weighted votes
    thetas_rad:  (n_theta,) normal angles in [0, pi)
    rhos_px:     (n_rho,) signed distances from the image centre ``centre``
    centre:      (cx, cy) origin of rho in pixels
    peaks:       (K, 3) float64 rows [theta_rad, rho_px, votes], strongest first
    peak_line:   (3,) the strongest peak as a line [a, b, c]
    line:        (3,) the peak refined by weighted total least squares on its inliers
    inlier_events: (K,) int64 the events (indices into the points' ``owner``) whose point
                 nearest the refined line is within ``hough_inlier_px`` of it
    """

    accumulator: np.ndarray
    thetas_rad: np.ndarray
    rhos_px: np.ndarray
    centre: tuple[float, float]
    peaks: np.ndarray
    peak_line: np.ndarray
    line: np.ndarray
    inlier_events: np.ndarray

    @property
    def n_inliers(self) -> int:
        """Points (one per event at most) within ``hough_inlier_px`` of the refined line."""
        return len(self.inlier_events)


@dataclass(frozen=True)
class FovLine:
    """The FOV line of side ``side`` of ``edge_of``, in ``seen_in``'s pixels (a² + b² = 1).

    source: what gave it (:func:`estimate_line`): "events" (the Hough peak of the events'
            points alone, as every line before the pair has a homography; on generated scenes
            most such lines are tens of px off, or stand for a border ``seen_in`` does not see),
            "homography" (the border mapped through H), "crossers" (a top line fitted to the
            crossers H picks out) or "prior" (loaded from an earlier run)
    """

    seen_in: str
    edge_of: str
    side: str
    line: tuple[float, float, float]
    events: int
    from_frame: int
    source: str = "events"


@dataclass(frozen=True)
class FovEventPoints:
    """What one event recorded: ``seen_in``'s targets at that frame.

    labels (M,) int64, feet (M, 2) float64 px, heights (M,) float64 px, weights (M,) float64
    (1 / (1 + earlier points of the same label within ``hough_repeat_heights`` of its heights):
    a person who stands still through many events cannot outvote the line of many crossings,
    while a walker present at many events, somewhere new each time, keeps its full vote).
    """

    frame: int
    labels: np.ndarray
    feet: np.ndarray
    heights: np.ndarray
    weights: np.ndarray
    event_target: int = -1
    """Label of the target that crossed the edge, in the edge camera (-1: unknown)."""
    crosser_foot: tuple[float, float] | None = None
    """The crosser's feet in the edge camera's pixels when they were on the border."""


@dataclass(frozen=True)
class FovSlot:
    """The point set of one (seen_in, edge_of, side), its line and its last Hough transform.

    size:         (width, height) of ``seen_in``'s frame
    events:       recent events, oldest first, at most ``max_fov_events``
    accumulator:  sum of the retained events' votes (see :func:`event_votes`), or None
    n_events:     all events ever recorded here
    line:         the current line, or None before ``min_fov_events`` events from
                  ``min_fov_crossers`` different crossers (and, without a homography, a
                  Hough line that explains events of that many)
    hough:        the Hough transform behind ``line``
    """

    seen_in: str
    edge_of: str
    side: str
    size: tuple[int, int]
    events: tuple[FovEventPoints, ...] = ()
    accumulator: np.ndarray | None = None
    n_events: int = 0
    line: FovLine | None = None
    hough: HoughResult | None = None

    def points(self) -> tuple[np.ndarray, np.ndarray]:
        """(P, 2) feet of all retained events and (P,) the index of each point's event."""
        if not self.events:
            return np.zeros((0, 2)), np.zeros(0, np.int64)
        feet = np.concatenate([e.feet for e in self.events])
        owner = np.concatenate([np.full(len(e.feet), k) for k, e in enumerate(self.events)])
        return feet, owner


def new_slot(seen_in: str, edge_of: str, side: str, size: tuple[int, int]) -> FovSlot:
    """An empty slot: the line of ``side`` of ``edge_of`` in a (width, height) ``seen_in``."""
    if side not in SIDES:
        raise ValueError(f"side {side!r} is not one of {SIDES}")
    return FovSlot(seen_in, edge_of, side, (int(size[0]), int(size[1])))


def mask_touching_sides(mask: np.ndarray, margin_px: float) -> np.ndarray:
    """(4,) bool, SIDES order: which borders a (H, W) bool mask comes within ``margin_px`` of.

    The rule of :func:`mvtrack.stages.targets.touching_sides`, applied to the mask's box.
    """
    rows, cols = np.nonzero(mask)
    if len(rows) == 0:
        return np.zeros(4, bool)
    box = np.array([[cols.min() - 0.5, rows.min() - 0.5, np.ptp(cols) + 1, np.ptp(rows) + 1]])
    height, width = mask.shape
    return touching_sides(box, (width, height), margin_px)[0]


def detect_events(
    history: TouchHistory, targets: CameraTargets, camera: str, frame: int, margin_px: float
) -> tuple[dict[int, tuple[bool, bool, bool, bool]], tuple[FovEvent, ...]]:
    """This frame's FOV events of one camera, and the touch history for the next frame.

    ``history`` holds the previous frame's touches per label; targets absent from it (new this
    frame) give no event. Returns a new dict; ``history`` is not modified.
    """
    touches = targets.touches(margin_px)
    now: dict[int, tuple[bool, bool, bool, bool]] = {}
    events = []
    for label, row in zip(targets.labels.tolist(), touches, strict=True):
        t = (bool(row[0]), bool(row[1]), bool(row[2]), bool(row[3]))
        now[label] = t
        before = history.get(label)
        if before is None:
            continue
        if sum(before) == 1 and not any(t):
            events.append(FovEvent(frame, camera, label, SIDES[before.index(True)], "enter"))
        elif not any(before) and sum(t) == 1:
            events.append(FovEvent(frame, camera, label, SIDES[t.index(True)], "leave"))
    return now, tuple(events)


def _grid(size: tuple[int, int], cfg: FovConfig) -> tuple[np.ndarray, np.ndarray, int]:
    """(thetas (n_theta,), rhos (2 half + 1,), half) of the Hough space of a frame."""
    thetas = np.arange(cfg.hough_theta_bins) * (np.pi / cfg.hough_theta_bins)
    diag = 0.5 * np.hypot(size[0], size[1]) * (1 + cfg.hough_margin_frac)
    half = int(np.ceil(diag / cfg.hough_rho_step_px))
    return thetas, np.arange(-half, half + 1) * cfg.hough_rho_step_px, half


def _centre(size: tuple[int, int]) -> tuple[float, float]:
    return (size[0] - 1) / 2.0, (size[1] - 1) / 2.0


def event_votes(
    feet: np.ndarray,
    heights: np.ndarray,
    weights: np.ndarray,
    size: tuple[int, int],
    cfg: FovConfig,
) -> np.ndarray:
    """(n_theta, n_rho) float64 votes of one event's points (the rho/theta grid of ``size``).

    A point votes its weight for every line passing within ``hough_height_frac`` of its height
    (at least half a rho bin) of it. Only one target at an event is the one that crossed the
    edge, so an event votes for a line with its best point (the maximum over its points, not
    the sum): a line scores the number of events it explains, and the dense band of distant
    people near the horizon, several per event, cannot outvote the true line.
    """
    thetas, rhos, half = _grid(size, cfg)
    acc = np.zeros((len(thetas), len(rhos)))
    pts = np.asarray(feet, np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return acc
    cx, cy = _centre(size)
    rho = (pts[:, 0:1] - cx) * np.cos(thetas) + (pts[:, 1:2] - cy) * np.sin(thetas)
    h = np.asarray(heights, np.float64)
    reach = np.maximum(cfg.hough_height_frac * h, 0.5 * cfg.hough_rho_step_px)[:, None]
    step = cfg.hough_rho_step_px
    lo = np.clip(np.ceil((rho - reach) / step - 0.5).astype(np.int64) + half, 0, len(rhos))
    hi = np.clip(np.floor((rho + reach) / step + 0.5).astype(np.int64) + half, 0, len(rhos))
    w = np.asarray(weights, np.float64)
    for k in np.argsort(w):  # ascending: the heaviest point's value wins where boxes overlap
        box = np.arange(len(rhos))[None, :]
        inside = (box >= lo[k][:, None]) & (box < hi[k][:, None])
        acc = np.where(inside, np.maximum(acc, w[k]), acc)
    return acc


def add_event(
    slot: FovSlot,
    frame: int,
    seen: CameraTargets,
    cfg: FovConfig,
    event_target: int = -1,
    crosser_foot: tuple[float, float] | None = None,
) -> FovSlot:
    """The slot with one more event: the feet of all of ``seen_in``'s targets (bounded).

    ``seen`` may be the targets at the moment the crosser's feet were on the edge (see
    :mod:`mvtrack.stages.pair`); ``event_target`` is the crosser's label in the edge camera.

    The accumulator is updated incrementally; the oldest event beyond ``max_fov_events`` is
    dropped and its votes removed. An event of a known crosser that already gave a retained
    event within ``event_repeat_frames`` is a repeat (a target flickering at the margin) and
    leaves the slot unchanged.
    """
    if event_target >= 0 and any(
        e.event_target == event_target and abs(frame - e.frame) <= cfg.event_repeat_frames
        for e in slot.events
    ):
        return slot
    labels = seen.labels.astype(np.int64, copy=True)
    feet = np.array(seen.feet, np.float64).reshape(-1, 2)
    repeats = np.zeros(len(labels))
    for e in slot.events:
        for k, j in zip(*np.nonzero(labels[:, None] == e.labels[None, :]), strict=True):
            reach = cfg.hough_repeat_heights * max(float(seen.heights_px[k]), 1.0)
            repeats[k] += float(np.hypot(*(feet[k] - e.feet[j])) <= reach)
    weights = 1.0 / (1.0 + repeats)
    ev = FovEventPoints(
        frame,
        labels,
        feet,
        np.array(seen.heights_px, np.float64),
        weights,
        int(event_target),
        crosser_foot,
    )
    for arr in (ev.labels, ev.feet, ev.heights, ev.weights):
        arr.flags.writeable = False
    acc = event_votes(ev.feet, ev.heights, ev.weights, slot.size, cfg)
    if slot.accumulator is not None:
        acc = acc + slot.accumulator
    events = (*slot.events, ev)
    if len(events) > cfg.max_fov_events:
        old = events[0]
        acc = acc - event_votes(old.feet, old.heights, old.weights, slot.size, cfg)
        events = events[1:]
    acc.flags.writeable = False
    return replace(slot, events=events, accumulator=acc, n_events=slot.n_events + 1)


def _crossers(events: tuple[FovEventPoints, ...]) -> int:
    """Distinct crossers of these events (an unknown crosser counts once each)."""
    known = {e.event_target for e in events if e.event_target >= 0}
    return len(known) + sum(e.event_target < 0 for e in events)


def _line_from_peak(theta: float, rho: float, centre: tuple[float, float]) -> np.ndarray:
    a, b = np.cos(theta), np.sin(theta)
    return np.array([a, b, -(a * centre[0] + b * centre[1] + rho)])


def _tls_line(points: np.ndarray, weights: np.ndarray, like: np.ndarray) -> np.ndarray:
    """Weighted total-least-squares line through points, normal oriented like ``like``."""
    w = weights / weights.sum()
    centroid = w @ points
    d = points - centroid
    scatter = (d * w[:, None]).T @ d
    _, vecs = np.linalg.eigh(scatter)
    normal = vecs[:, 0]
    if normal @ like[:2] < 0:
        normal = -normal
    return np.array([normal[0], normal[1], -normal @ centroid])


def _wrap_pad(acc: np.ndarray, pad: int) -> np.ndarray:
    """Pad the theta axis periodically: (theta + pi, rho) is (theta, -rho), rho reversed."""
    pad = min(pad, len(acc))
    return np.concatenate([acc[-pad:, ::-1], acc, acc[:pad, ::-1]])


def _find_peaks(acc: np.ndarray, cfg: FovConfig) -> list[tuple[int, int]]:
    r = cfg.hough_peak_radius_bins
    padded = _wrap_pad(acc, r)
    local_max = ndimage.maximum_filter(padded, size=2 * r + 1, mode="constant")[r : r + len(acc)]
    ti, ri = np.nonzero((acc >= local_max) & (acc > 0))
    order = np.argsort(-acc[ti, ri], kind="stable")
    peaks: list[tuple[int, int]] = []
    for k in order:  # plateaus give several equal maxima: keep the first of each
        t, p = int(ti[k]), int(ri[k])
        if all(abs(t - t2) > r or abs(p - p2) > r for t2, p2 in peaks):
            peaks.append((t, p))
        if len(peaks) == cfg.hough_num_peaks:
            break
    return peaks


def _nearest_per_event(
    line: np.ndarray, pts: np.ndarray, owner: np.ndarray, tol: float
) -> np.ndarray:
    """(P,) bool: per event, its point nearest the line, if within ``tol`` px."""
    d = np.abs(pts @ line[:2] + line[2])
    keep = np.zeros(len(pts), bool)
    for e in np.unique(owner):
        idx = np.flatnonzero(owner == e)
        k = idx[np.argmin(d[idx])]
        keep[k] = d[k] <= tol
    return keep


def hough_line(
    accumulator: np.ndarray,
    points: np.ndarray,
    owner: np.ndarray,
    size: tuple[int, int],
    cfg: FovConfig,
) -> HoughResult | None:
    """Peaks of a Hough accumulator (from :func:`event_votes`) and the refined best line.

    ``points`` (P, 2) are the feet that voted and ``owner`` (P,) their event index. The
    accumulator is smoothed (``hough_smooth_bins``, wrapping around in theta), its strongest
    peak is the line, refined three times by total least squares on each event's point nearest
    it within a tolerance that starts at ``hough_inlier_px`` and shrinks to three robust sigmas
    of the residuals. None when nothing voted.
    """
    thetas, rhos, _ = _grid(size, cfg)
    if accumulator.shape != (len(thetas), len(rhos)):
        raise ValueError(f"accumulator shape {accumulator.shape} does not match frame {size}")
    acc = np.array(accumulator, np.float64)
    if cfg.hough_smooth_bins > 0:
        pad = int(np.ceil(4 * cfg.hough_smooth_bins))
        acc = ndimage.gaussian_filter(_wrap_pad(acc, pad), cfg.hough_smooth_bins, mode="constant")
        acc = acc[pad : pad + len(thetas)]
    peak_idx = _find_peaks(acc, cfg)
    if not peak_idx:
        return None
    peaks = np.array([[thetas[t], rhos[r], acc[t, r]] for t, r in peak_idx]).reshape(-1, 3)
    centre = _centre(size)
    peak_line = _line_from_peak(peaks[0, 0], peaks[0, 1], centre)
    line = peak_line
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    tol = cfg.hough_inlier_px
    for _ in range(3):
        near = _nearest_per_event(line, pts, owner, tol)
        if near.sum() < 2:
            break
        line = _tls_line(pts[near], np.ones(int(near.sum())), peak_line)
        # Tighten to 3 robust sigmas of the inliers' residuals (never below a third of the
        # tolerance), so a stray point near the line does not tilt the refinement.
        resid = np.abs(pts[near] @ line[:2] + line[2])
        tol = float(np.clip(3 * 1.4826 * np.median(resid), tol / 3, tol))
    inliers = np.unique(np.asarray(owner)[_nearest_per_event(line, pts, owner,
                                                              cfg.hough_inlier_px)])
    acc.flags.writeable = False
    return HoughResult(acc, thetas, rhos, centre, peaks, peak_line, line,
                       inliers.astype(np.int64))


def hough_points(
    points: np.ndarray, size: tuple[int, int], cfg: FovConfig, heights: np.ndarray | None = None
) -> HoughResult | None:
    """Hough line of a plain point set: each point is its own event, weight 1."""
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    h = np.zeros(len(pts)) if heights is None else np.asarray(heights, np.float64)
    thetas, rhos, _ = _grid(size, cfg)
    acc = np.zeros((len(thetas), len(rhos)))
    for k in range(len(pts)):
        acc += event_votes(pts[k : k + 1], h[k : k + 1], np.ones(1), size, cfg)
    return hough_line(acc, pts, np.arange(len(pts)), size, cfg)


def _crosser_points(
    slot: FovSlot, H_seen_from_edge: np.ndarray, cfg: FovConfig
) -> np.ndarray:
    """(K, 2) per event, the point the homography says is the crosser (within the gate)."""
    out = []
    for e in slot.events:
        if e.crosser_foot is None or len(e.feet) == 0:
            continue
        x = apply_homography(H_seen_from_edge, np.array([e.crosser_foot]))[0]
        d = np.hypot(*(e.feet - x).T) / np.maximum(e.heights, 1.0)
        k = int(np.argmin(d))
        if d[k] <= cfg.fov_match_heights:
            out.append(e.feet[k])
    return np.array(out).reshape(-1, 2)


def border_line(
    H_seen_from_edge: np.ndarray, side: str, edge_size: tuple[int, int]
) -> tuple[float, float, float]:
    """The edge camera's border ``side`` seen in the other camera through the homography.

    A homography maps lines to lines: the border l_e (l_e . x_e = 0, at -0.5 / W - 0.5 /
    H - 0.5, :func:`border_distance`) is l = M^-T l_e in the seen camera, x_seen ~ M x_edge.
    Returned with a^2 + b^2 = 1.
    """
    width, height = edge_size
    edge = {
        "left": (1.0, 0.0, 0.5),
        "right": (1.0, 0.0, -(width - 0.5)),
        "top": (0.0, 1.0, 0.5),
        "bottom": (0.0, 1.0, -(height - 0.5)),
    }[side]
    line = np.linalg.solve(np.asarray(H_seen_from_edge, np.float64).T, np.array(edge))
    a, b, c = (float(v) for v in line / np.hypot(line[0], line[1]))
    return a, b, c


def estimate_line(
    slot: FovSlot,
    cfg: FovConfig,
    frame: int,
    H_seen_from_edge: np.ndarray | None = None,
    edge_size: tuple[int, int] | None = None,
) -> FovSlot:
    """Re-estimate the slot's line from its accumulator once it has ``min_fov_events`` events
    from ``min_fov_crossers`` different crossers.

    Before the pair has a homography the line is the Hough line, taken only when the events it
    explains (a point within ``hough_inlier_px``) come from ``min_fov_crossers`` different
    crossers too; else the slot keeps the line it had, if any. One person walking near the
    border, in and out of the margin, gives an event each time, with a bystander's feet along
    its path: a line through that path alone is not the border ('three' seed 10, cam2's right
    border seen in cam1: seven events of one crosser, 94 px off). The next peaks are not
    tried: on the sweep's clips the strongest one explaining enough crossers was worse
    ('pillar' seed 8, IDF1 0.993 -> 0.949).

    With a homography from the edge camera to the seen one (once the pair has learned it):
    for the left, right and bottom sides the line is the edge camera's border through it
    (:func:`border_line`; the events are recorded when the crosser's feet are on that border,
    so both are the same line, and H's comes from every marker rather than a few noisy
    events). For the top side (feet never reach it: events record the feet when the crosser
    is fully inside) each event's crosser is known (the point nearest the mapped
    ``crosser_foot``): when at least ``min_fov_events`` events have one (or two or more
    spanning two body heights), the line is their total-least-squares fit instead of the Hough
    peak, which bystanders near the line can pull away.
    """
    if (
        slot.n_events < cfg.min_fov_events
        or slot.accumulator is None
        or _crossers(slot.events) < cfg.min_fov_crossers
    ):
        return slot
    points, owner = slot.points()
    hough = hough_line(slot.accumulator, points, owner, slot.size, cfg)
    if hough is None:
        return slot
    best, source = hough.line, "events"
    if H_seen_from_edge is None:
        explained = tuple(slot.events[k] for k in hough.inlier_events)
        if _crossers(explained) < cfg.min_fov_crossers:
            return replace(slot, hough=hough)  # the line it had, if any, stays
    elif slot.side != "top" and edge_size is not None:
        best, source = np.array(border_line(H_seen_from_edge, slot.side, edge_size)), "homography"
    else:
        crossers = _crosser_points(slot, H_seen_from_edge, cfg)
        span = float(np.ptp(crossers, axis=0).max()) if len(crossers) else 0.0
        heights = np.median(np.concatenate([e.heights for e in slot.events]))
        if len(crossers) >= max(cfg.min_fov_events, 2) or (
            len(crossers) >= 2 and span >= 2 * heights
        ):
            best, source = _tls_line(crossers, np.ones(len(crossers)), hough.line), "crossers"
    a, b, c = (float(v) for v in best)
    line = FovLine(slot.seen_in, slot.edge_of, slot.side, (a, b, c), slot.n_events, frame,
                   source)
    return replace(slot, line=line, hough=hough)


def line_distances(line: tuple[float, float, float], targets: CameraTargets) -> np.ndarray:
    """(N,) float64: |L·x| of each target's feet divided by its height (body heights)."""
    a, b, c = line
    d = np.abs(targets.feet @ np.array([a, b]) + c)
    return d / np.maximum(targets.heights_px, 1.0)


def best_match(
    line: tuple[float, float, float],
    targets: CameraTargets,
    taken: frozenset[int],
    cfg: FovConfig,
) -> int | None:
    """Label of the only free target within ``fov_match_heights`` body heights of the line.

    Targets whose labels are in ``taken`` (already linked elsewhere) are not candidates; when
    several free targets are within the gate the match is ambiguous and none is made.
    """
    d = line_distances(line, targets)
    free = np.array([label not in taken for label in targets.labels.tolist()], bool)
    if not free.any():
        return None
    d = np.where(free, d, np.inf)
    return _unique_within(d, targets.labels, cfg.fov_match_heights)


def _unique_within(d: np.ndarray, labels: np.ndarray, gate: float) -> int | None:
    """The label whose distance is within ``gate`` when exactly one is (else ambiguous: None)."""
    inside = np.flatnonzero(d <= gate)
    return int(labels[inside[0]]) if len(inside) == 1 else None


def border_distance(feet: np.ndarray, side: str, size: tuple[int, int]) -> np.ndarray:
    """(N,) float64 px from each [x, y] foot point to the frame's outer edge on ``side``.

    Positive inside the frame. The edge is at -0.5 / W - 0.5 / H - 0.5 (pixel centres at
    integers); "top" is measured to y = -0.5 too, though feet never reach it.
    """
    pts = np.asarray(feet, np.float64).reshape(-1, 2)
    width, height = size
    return {
        "left": pts[:, 0] + 0.5,
        "right": width - 0.5 - pts[:, 0],
        "top": pts[:, 1] + 0.5,
        "bottom": height - 0.5 - pts[:, 1],
    }[side]


def crossing_time(samples: np.ndarray, event_frame: int, kind: str, cfg: FovConfig) -> float:
    """When the crosser's feet were on the border: a line fitted to its distance over time.

    ``samples`` (K, 2) rows [frame, distance to the border, px] from frames in which the target
    was fully inside. Leaving targets approach the border (the crossing follows the event),
    entering ones move away from it (the crossing precedes it). Falls back to ``event_frame``
    with fewer than two samples or motion the wrong way; the shift is at most
    ``crossing_max_shift_frames``.
    """
    s = np.asarray(samples, np.float64).reshape(-1, 2)
    if len(s) < 2 or np.ptp(s[:, 0]) == 0:
        return float(event_frame)
    slope, intercept = np.polyfit(s[:, 0], s[:, 1], 1)
    if (kind == "leave" and slope >= 0) or (kind == "enter" and slope <= 0):
        return float(event_frame)
    shift = -intercept / slope - event_frame
    limit = cfg.crossing_max_shift_frames
    return float(event_frame + np.clip(shift, -limit, limit))


def interpolate_targets(
    before: tuple[int, CameraTargets], after: tuple[int, CameraTargets], t: float
) -> CameraTargets:
    """Targets at fractional frame ``t`` between two frames (before[0] <= t <= after[0]).

    Labels present in both frames are interpolated linearly; the others are taken from the
    nearer frame when they are present there.
    """
    (f0, ta), (f1, tb) = before, after
    u = 0.0 if f1 == f0 else (t - f0) / (f1 - f0)
    near, far = (ta, tb) if u <= 0.5 else (tb, ta)
    feet, heights, boxes = near.feet.copy(), near.heights_px.copy(), near.boxes_xywh.copy()
    for k, label in enumerate(near.labels.tolist()):
        j = far.index_of(label)
        if j is None:
            continue
        w_far = u if near is ta else 1.0 - u
        feet[k] = (1 - w_far) * near.feet[k] + w_far * far.feet[j]
        heights[k] = (1 - w_far) * near.heights_px[k] + w_far * far.heights_px[j]
        boxes[k] = (1 - w_far) * near.boxes_xywh[k] + w_far * far.boxes_xywh[j]
    return CameraTargets(near.labels.copy(), feet, heights, boxes, near.size)


def event_match(
    line: tuple[float, float, float], event: FovEventPoints, cfg: FovConfig
) -> int | None:
    """Label of the event's only point within ``fov_match_heights`` body heights of the line."""
    if len(event.labels) == 0:
        return None
    a, b, c = line
    d = np.abs(event.feet @ np.array([a, b]) + c) / np.maximum(event.heights, 1.0)
    return _unique_within(d, event.labels, cfg.fov_match_heights)
