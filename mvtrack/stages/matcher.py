"""Homography-based association of one camera pair (SPEC §7, thesis §3.2.7 [completion]).

Each frame, with a valid ``H_b_from_a``, every A target's feet are projected into B and every B
target's feet into A. The pair distance is the symmetric transfer distance in body heights,

    d(i, k) = ( |H x_a(i) - x_b(k)| / h_b(k)  +  |H^-1 x_b(k) - x_a(i)| / h_a(i) ) / 2,

so one threshold works at every depth. With it the pair's one-to-one links are

- confirmed while d < ``keep_threshold_heights`` (looser than the gate that makes links: a
  front end that loses the legs puts one person's two feet up to a body height apart), broken
  after ``break_after_frames`` consecutive inconsistent frames (refine: wrong FOV associations,
  identity swaps), or at once when a link H never confirmed is inconsistent and one of its
  targets has a consistent unlinked partner;
- re-attached at once when a young target is consistent with a target whose partner was lost
  within ``reattach_window_frames`` (occlusion recovery, splits);
- created by a gated Hungarian assignment of the free targets, once a pair stays assigned for
  ``confirm_frames`` frames (in-scene entrances, no FOV event needed); re-attach and create take
  only unambiguous pairs (every rival at least ``create_margin_heights`` further);
- added from FOV associations (the only source with ``method == "fov"`` or before H exists;
  with H, an association it contradicts (d >= ``keep_threshold_heights``) is rejected). The
  FOV-only baseline takes those of FOV events alone, not the co-motion bootstrap's.

Targets projected inside the other frame without a partner are "expected but unseen".

    state = match_init(("cam0", "cam1"))
    state, result = match_step(state, MatchInputs(ta, tb, pair.homography, pair.associations,
                                                  frame), params.matcher)
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from mvtrack.params import MatcherConfig
from mvtrack.stages.homography import HomographyEstimate, HomographyFailure, apply_homography
from mvtrack.stages.targets import CameraTargets

__all__ = [
    "Link",
    "MatchInputs",
    "MatchResult",
    "MatchState",
    "gated_assignment",
    "match_init",
    "match_step",
    "symmetric_transfer",
    "transfer_costs",
]

_BIG = 1e9

Pair = tuple[int, int]
"""(A label, B label)."""


@dataclass(frozen=True)
class Link:
    """One link between an A target and a B target.

    source:        "fov" (FOV association), "comotion" (the pair's co-motion bootstrap),
                   "create" (Hungarian, confirmed), "reattach"
    since:         frame the link was made
    confirmations: frames in which d < threshold (the link's evidence)
    bad_streak:    consecutive frames with d >= threshold (breaks at ``break_after_frames``)
    """

    a: int
    b: int
    source: str
    since: int
    confirmations: int = 0
    bad_streak: int = 0

    @property
    def pair(self) -> Pair:
        return (self.a, self.b)


@dataclass(frozen=True)
class MatchState:
    """The pair's links and what the next frames need. Frozen; steps return a new state.

    links:    one-to-one links, in creation order
    pending:  (a, b) -> consecutive frames the pair was the gated assignment (create)
    lost_a:   A label -> frame its linked B target vanished (re-attach candidates); lost_b alike
    born_a:   A label -> first frame it was seen (present labels only); born_b alike
    """

    names: tuple[str, str]
    links: tuple[Link, ...] = ()
    pending: Mapping[Pair, int] = field(default_factory=dict)
    lost_a: Mapping[int, int] = field(default_factory=dict)
    lost_b: Mapping[int, int] = field(default_factory=dict)
    born_a: Mapping[int, int] = field(default_factory=dict)
    born_b: Mapping[int, int] = field(default_factory=dict)


@dataclass(frozen=True)
class MatchInputs:
    """One frame of one pair: both cameras' targets, the pair's H and its FOV associations.

    associations: (A label, B label, ...) tuples made at FOV events this frame
    """

    a: CameraTargets
    b: CameraTargets
    homography: HomographyEstimate | HomographyFailure
    associations: Sequence[tuple] = ()
    frame: int = 0


@dataclass(frozen=True, eq=False)
class MatchResult:
    """Every intermediate of one match step, for the viewer and the meta stage.

    used_homography: whether H drove this frame (False: FOV associations only)
    a_labels, b_labels: (NA,), (NB,) int64, row and column labels of ``cost``
    cost:          (NA, NB) float64 symmetric transfer distance in body heights ((0, 0) without H)
    proj_a_in_b:   (NA, 2) float64 A feet projected into B px;  proj_b_in_a: (NB, 2) alike
    confirmed:     (a, b, d) links consistent this frame (d < keep threshold)
    inconsistent:  (a, b, d, streak) links inconsistent this frame but not yet broken
    broken:        (a, b, d) links broken this frame (refine)
    fov_added:     (a, b) links made from FOV associations this frame
    fov_rejected:  (a, b, d) FOV associations rejected because H contradicts them
    reattached:    (a, b, d) links re-attached this frame
    created:       (a, b, d) links created this frame (after ``confirm_frames``)
    pending:       (a, b, frames, d) gated assignments not yet confirmed
    lost:          (camera index 0/1, label) targets whose partner vanished this frame
    unseen_in_b:   A labels projected inside B's frame with no partner;  unseen_in_a alike
    links:         all links after this frame
    """

    frame: int
    names: tuple[str, str]
    used_homography: bool
    a_labels: np.ndarray
    b_labels: np.ndarray
    cost: np.ndarray
    proj_a_in_b: np.ndarray
    proj_b_in_a: np.ndarray
    confirmed: tuple[tuple[int, int, float], ...] = ()
    inconsistent: tuple[tuple[int, int, float, int], ...] = ()
    broken: tuple[tuple[int, int, float], ...] = ()
    fov_added: tuple[Pair, ...] = ()
    fov_rejected: tuple[tuple[int, int, float], ...] = ()
    reattached: tuple[tuple[int, int, float], ...] = ()
    created: tuple[tuple[int, int, float], ...] = ()
    pending: tuple[tuple[int, int, int, float], ...] = ()
    lost: tuple[tuple[int, int], ...] = ()
    unseen_in_b: tuple[int, ...] = ()
    unseen_in_a: tuple[int, ...] = ()
    links: tuple[Link, ...] = ()

    def pairs(self) -> tuple[Pair, ...]:
        return tuple(link.pair for link in self.links)


def match_init(names: tuple[str, str]) -> MatchState:
    """The empty state of pair (A, B) = ``names``."""
    return MatchState(names=names)


def symmetric_transfer(
    H_b_from_a: np.ndarray, feet_a: np.ndarray, heights_a: np.ndarray, feet_b: np.ndarray,
    heights_b: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pair distance d (module docstring) between every A and every B point.

    feet_*: (N, 2) px; heights_*: (N,) px. Returns (cost (NA, NB) float64 in body heights,
    A feet in B (NA, 2) px, B feet in A (NB, 2) px). Each transfer error is divided by the
    height (px, at least 1) of the target it is compared with in that target's own camera;
    the two are averaged. Unprojectable points cost ``_BIG``.
    """
    H = np.asarray(H_b_from_a, np.float64)
    a_in_b = apply_homography(H, feet_a) if len(feet_a) else np.zeros((0, 2))
    b_in_a = apply_homography(np.linalg.inv(H), feet_b) if len(feet_b) else np.zeros((0, 2))
    if not len(feet_a) or not len(feet_b):
        return np.zeros((len(feet_a), len(feet_b))), a_in_b, b_in_a
    err_b = np.linalg.norm(a_in_b[:, None, :] - feet_b[None, :, :], axis=2)
    err_a = np.linalg.norm(b_in_a[None, :, :] - feet_a[:, None, :], axis=2)
    h_a = np.maximum(heights_a, 1.0)[:, None]
    h_b = np.maximum(heights_b, 1.0)[None, :]
    cost = 0.5 * (err_b / h_b + err_a / h_a)
    return np.where(np.isfinite(cost), cost, _BIG), a_in_b, b_in_a


def transfer_costs(
    H_b_from_a: np.ndarray, a: CameraTargets, b: CameraTargets
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`symmetric_transfer` of two cameras' targets."""
    return symmetric_transfer(H_b_from_a, a.feet, a.heights_px, b.feet, b.heights_px)


def gated_assignment(cost: np.ndarray, rows: Sequence[int], cols: Sequence[int],
                     gate: float, margin: float = 0.0) -> list[tuple[int, int, float]]:
    """Minimum-cost one-to-one assignment of ``rows`` x ``cols`` of ``cost``, each pair < gate
    and at least ``margin`` below every other entry of its row and column (unambiguous)."""
    if not len(rows) or not len(cols):
        return []
    sub = cost[np.ix_(list(rows), list(cols))]
    gated = np.where(sub < gate, sub, _BIG)
    r, c = linear_sum_assignment(gated)
    out = []
    for i, j in zip(r, c, strict=True):
        if gated[i, j] >= _BIG:
            continue
        rivals = np.r_[np.delete(sub[i, :], j), np.delete(sub[:, j], i)]
        if rivals.size and rivals.min() < sub[i, j] + margin:
            continue
        out.append((rows[i], cols[j], float(sub[i, j])))
    return out


@dataclass
class _Frame:
    """Scratch record of one step (mutable inside :func:`match_step` only)."""

    links: list[Link]
    index_a: dict[int, int]
    index_b: dict[int, int]
    lost: list[tuple[int, int]] = field(default_factory=list)
    confirmed: list[tuple[int, int, float]] = field(default_factory=list)
    inconsistent: list[tuple[int, int, float, int]] = field(default_factory=list)
    broken: list[tuple[int, int, float]] = field(default_factory=list)
    fov_added: list[Pair] = field(default_factory=list)
    fov_rejected: list[tuple[int, int, float]] = field(default_factory=list)
    reattached: list[tuple[int, int, float]] = field(default_factory=list)
    created: list[tuple[int, int, float]] = field(default_factory=list)

    def free(self, side: int) -> list[int]:
        """Rows (side 0) or columns (side 1) of targets with no link."""
        linked = {link.a for link in self.links} if side == 0 else {link.b for link in self.links}
        index = self.index_a if side == 0 else self.index_b
        return [i for label, i in index.items() if label not in linked]


def _prune(state: MatchState, f: _Frame, frame: int, window: int) -> tuple[dict, dict]:
    """Drop links with a vanished target; the surviving side becomes a re-attach candidate."""
    lost_a = {k: v for k, v in state.lost_a.items() if k in f.index_a and frame - v <= window}
    lost_b = {k: v for k, v in state.lost_b.items() if k in f.index_b and frame - v <= window}
    kept = []
    for link in state.links:
        has_a, has_b = link.a in f.index_a, link.b in f.index_b
        if has_a and has_b:
            kept.append(link)
        elif has_a:
            lost_a[link.a] = frame
            f.lost.append((0, link.a))
        elif has_b:
            lost_b[link.b] = frame
            f.lost.append((1, link.b))
    f.links = kept
    return lost_a, lost_b


def _add_fov(f: _Frame, associations: Sequence[tuple], frame: int,
             gate: tuple[np.ndarray, float] | None, fov_only: bool) -> None:
    """FOV associations between present, unlinked targets become links (``fov_only``: only
    those of FOV events, not the co-motion bootstrap's). A co-motion association first
    replaces the FOV links of its two targets (:func:`mvtrack.stages.pair._bootstrap` makes
    it from many frames; an FOV link from one event, perhaps on a line from few events).

    ``gate``: (cost, threshold) when H drives matching: an association H contradicts
    (d >= threshold) is rejected at once rather than linked and broken later; one it does not
    is confirmed (this runs after :func:`_refine`, which freed the targets of broken links).
    """
    for assoc in associations:
        comotion = len(assoc) > 2 and assoc[2].kind == "comotion"
        if fov_only and comotion:
            continue  # the FOV-only baseline (Khan & Shah) links on FOV events alone
        a, b = int(assoc[0]), int(assoc[1])
        if a not in f.index_a or b not in f.index_b:
            continue
        if comotion:  # many frames of co-motion outweigh one FOV event: replace its links
            f.links = [link for link in f.links
                       if link.source != "fov" or (link.a != a and link.b != b)]
        if any(link.a == a or link.b == b for link in f.links):
            continue
        source = "comotion" if comotion else "fov"
        if gate is None:
            f.links.append(Link(a, b, source, frame))
        else:
            d = float(gate[0][f.index_a[a], f.index_b[b]])
            if d >= gate[1]:
                f.fov_rejected.append((a, b, d))
                continue
            f.links.append(Link(a, b, source, frame, confirmations=1))  # consistent: evidence
            f.confirmed.append((a, b, d))
        f.fov_added.append((a, b))


def _refine(f: _Frame, cost: np.ndarray, cfg: MatcherConfig) -> None:
    """Confirm consistent links; break those inconsistent for ``break_after_frames``, or, if H
    never confirmed them, at once when one of their targets has a consistent unlinked partner
    (d below the gate): a wrong FOV association made before H existed."""
    linked_a = {link.a for link in f.links}
    linked_b = {link.b for link in f.links}
    free_rows = [i for label, i in f.index_a.items() if label not in linked_a]
    free_cols = [j for label, j in f.index_b.items() if label not in linked_b]
    kept = []
    for link in f.links:
        i, j = f.index_a[link.a], f.index_b[link.b]
        d = float(cost[i, j])
        if d < cfg.keep_threshold_heights:
            kept.append(replace(link, confirmations=link.confirmations + 1, bad_streak=0))
            f.confirmed.append((link.a, link.b, d))
            continue
        rival = link.confirmations == 0 and (
            (cost[i, free_cols] < cfg.match_threshold_heights).any()
            or (cost[free_rows, j] < cfg.match_threshold_heights).any())
        if rival or link.bad_streak + 1 >= cfg.break_after_frames:
            f.broken.append((link.a, link.b, d))
        else:
            kept.append(replace(link, bad_streak=link.bad_streak + 1))
            f.inconsistent.append((link.a, link.b, d, link.bad_streak + 1))
    f.links = kept


def _reattach(f: _Frame, cost: np.ndarray, state: MatchState, lost: tuple[dict, dict],
              cfg: MatcherConfig, frame: int) -> None:
    """Young free targets consistent with a target whose partner was lost join it at once."""
    labels_a = {i: label for label, i in f.index_a.items()}
    labels_b = {i: label for label, i in f.index_b.items()}
    born_a = {k: state.born_a.get(k, frame) for k in f.index_a}
    born_b = {k: state.born_b.get(k, frame) for k in f.index_b}
    max_age = cfg.confirm_frames + cfg.break_after_frames
    for side in (0, 1):  # side 0: lost A targets take young B targets; side 1: the reverse
        free_a, free_b = f.free(0), f.free(1)
        if side == 0:
            rows = [i for i in free_a if labels_a[i] in lost[0]]
            cols = [j for j in free_b if frame - born_b[labels_b[j]] <= max_age]
        else:
            rows = [i for i in free_a if frame - born_a[labels_a[i]] <= max_age]
            cols = [j for j in free_b if labels_b[j] in lost[1]]
        for i, j, d in gated_assignment(cost, rows, cols, cfg.match_threshold_heights,
                                        cfg.create_margin_heights):
            a, b = labels_a[i], labels_b[j]
            f.links.append(Link(a, b, "reattach", frame, confirmations=1))
            f.reattached.append((a, b, d))


def _create(f: _Frame, cost: np.ndarray, state: MatchState, cfg: MatcherConfig,
            frame: int) -> tuple[dict[Pair, int], list[tuple[int, int, int, float]]]:
    """Gated Hungarian on free targets; a pair assigned ``confirm_frames`` frames is linked."""
    labels_a = {i: label for label, i in f.index_a.items()}
    labels_b = {i: label for label, i in f.index_b.items()}
    pending: dict[Pair, int] = {}
    shown = []
    for i, j, d in gated_assignment(cost, f.free(0), f.free(1), cfg.match_threshold_heights,
                                    cfg.create_margin_heights):
        pair = (labels_a[i], labels_b[j])
        count = state.pending.get(pair, 0) + 1
        if count >= cfg.confirm_frames:
            f.links.append(Link(pair[0], pair[1], "create", frame, confirmations=count))
            f.created.append((pair[0], pair[1], d))
        else:
            pending[pair] = count
            shown.append((pair[0], pair[1], count, d))
    return pending, shown


def _unseen(proj: np.ndarray, rows: Sequence[int], labels: np.ndarray, size: tuple[int, int],
            margin: float) -> tuple[int, ...]:
    """Labels of ``rows`` whose projection lies at least ``margin`` px inside a frame of size."""
    w, h = size
    out = []
    for i in rows:
        x, y = proj[i]
        if margin - 0.5 <= x <= w - 0.5 - margin and margin - 0.5 <= y <= h - 0.5 - margin:
            out.append(int(labels[i]))
    return tuple(sorted(out))


def match_step(state: MatchState, inputs: MatchInputs,
               cfg: MatcherConfig) -> tuple[MatchState, MatchResult]:
    """Advance the pair's links by one frame (see the module docstring for the rules)."""
    a, b, frame = inputs.a, inputs.b, inputs.frame
    index_a = {int(label): i for i, label in enumerate(a.labels.tolist())}
    index_b = {int(label): i for i, label in enumerate(b.labels.tolist())}
    f = _Frame([], index_a, index_b)
    lost = _prune(state, f, frame, cfg.reattach_window_frames)
    use_h = cfg.method == "homography" and isinstance(inputs.homography, HomographyEstimate)
    pending: dict[Pair, int] = {}
    shown: list[tuple[int, int, int, float]] = []
    unseen: tuple[tuple[int, ...], tuple[int, ...]] = ((), ())
    if isinstance(inputs.homography, HomographyEstimate):
        cost, a_in_b, b_in_a = transfer_costs(inputs.homography.H_b_from_a, a, b)
    else:
        cost, a_in_b, b_in_a = np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((0, 2))
    if use_h:
        _refine(f, cost, cfg)
    _add_fov(f, inputs.associations, frame,
             (cost, cfg.keep_threshold_heights) if use_h else None, cfg.method == "fov")
    if use_h:
        _reattach(f, cost, state, lost, cfg, frame)
        pending, shown = _create(f, cost, state, cfg, frame)
    if isinstance(inputs.homography, HomographyEstimate):
        unseen = (
            _unseen(a_in_b, f.free(0), a.labels, b.size, cfg.unseen_margin_px),
            _unseen(b_in_a, f.free(1), b.labels, a.size, cfg.unseen_margin_px),
        )
    links = tuple(f.links)
    new_state = MatchState(
        names=state.names,
        links=links,
        pending=pending,
        lost_a={k: v for k, v in lost[0].items() if all(k != link.a for link in links)},
        lost_b={k: v for k, v in lost[1].items() if all(k != link.b for link in links)},
        born_a={k: state.born_a.get(k, frame) for k in index_a},
        born_b={k: state.born_b.get(k, frame) for k in index_b},
    )
    result = MatchResult(
        frame=frame, names=state.names, used_homography=use_h,
        a_labels=a.labels.copy(), b_labels=b.labels.copy(),
        cost=cost, proj_a_in_b=a_in_b, proj_b_in_a=b_in_a,
        confirmed=tuple(f.confirmed), inconsistent=tuple(f.inconsistent),
        broken=tuple(f.broken), fov_added=tuple(f.fov_added),
        fov_rejected=tuple(f.fov_rejected), reattached=tuple(f.reattached),
        created=tuple(f.created), pending=tuple(shown), lost=tuple(f.lost),
        unseen_in_b=unseen[0], unseen_in_a=unseen[1], links=links,
    )
    return new_state, result
