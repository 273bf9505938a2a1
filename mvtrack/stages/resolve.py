"""Whole-run label resolution [beyond]: each target's meta decided with all the run learned.

Online (SPEC §7–8) a target's meta is what the evidence said at that frame. People who are in
two views before the pair has a homography, and leave before it exists, only ever get FOV-event
links, and a target's meta changes when a later link joins it to another. After the run, every
pair's final homography can score every pair of targets that were ever in view together, so
the results give each target one meta for its whole life:

- **votes**: in each frame, for each pair with a final H, a gated minimum-cost assignment on
  the symmetric transfer distance (body heights, as the matcher) of the targets present; a vote
  for (A target, B target) per frame they are assigned;
- **fragment votes**: a target the assignment left out votes for the nearest target of the
  other camera within the gate if it is clearly shorter than the target of its own camera
  that took that one (a person's legs tracked apart from the torso);
- a **cross-camera link** needs ``min_votes`` votes and ``min_vote_share`` of the frames both
  targets were present;
- pairs without a final H (and every pair with the FOV-only matcher, which must not use H) keep
  the run's own links: votes = frames the two targets carried one meta together; but a
  co-motion search over each pair's whole run (`pipeline.resolve_rows`,
  :func:`~mvtrack.stages.markers.comotion_of_run`) first gives a pair the run learned no H
  for one, and replaces a final H whose projections find clearly fewer targets;
- **identity switches**: a target whose votes go to one target of the other camera for at
  least ``switch_min_votes`` frames, then to another for as long, while those two are present
  together for more than ``max_shared_frames`` frames (two people), changed person in between
  (two people crossing at a door or a frame edge): it is cut there into segments, which vote
  apart; consecutive segments are rejoined (after the votes) unless that joins two people.
  Two people swapped (or a person handed over) by one camera make mirror switches in both
  cameras; only the target whose feet left the line it walked at the switch is cut. Two partners
  never seen together may be one person who left and came back: the target is cut only if
  its feet jumped between the runs (``switch_jump_heights``) or it turned back on the left,
  right or bottom border (``switch_turn_heights``: one person walked out of the view as
  another walked in, one blob for both; read from its box's inner edge), and those parts are
  not linked as segments (a stitch may rejoin a jump's parts: a glitch; no link joins a
  turn's);
- **within one camera** a target that took over the meta of an earlier one (the meta stage's
  resume, or a re-attach through another camera) after at most ``resume_gap_frames`` frames
  stays with it, if the earlier target was gone by then (a meta moved between two live
  targets is the online stage changing its mind, not one person coming back) and had not
  walked out of the view (as for stitches, below);
- **stitches**: a target of one camera that begins, at most ``stitch_max_gap_frames`` after
  another ended, where that one would be had it walked on as before, continues it (a person
  hidden behind a pillar while no other camera saw both parts), unless the one that ended
  walked out of the view: last seen on the left, right or bottom border, not walking back
  into the view;
- **hand-offs**: a target of one camera that ended, walking, while the other camera of a
  pair with H showed nobody where H put it (hidden there, or just out of view), and a target
  of the other camera that began at most ``handoff_max_gap_frames`` later where its walk,
  carried through H, leads: one person who left one view, or was lost in it, while behind a
  pillar or a booth in the other and came out there. A hand-off joins no two targets of one
  camera present together even in one frame;
- links join strongest first (cross-camera votes, then same-camera continuity, then
  stitches, then hand-offs). A join that
  would put two targets of one camera present together in more than ``max_shared_frames``
  frames into one meta is refused: those are two people, not two fragments of one; so is one
  joining two targets of a pair with H that were beyond each other's vote gate in more than
  ``max_shared_frames`` frames and voted for each other in few of them
  (``apart_max_vote_share``), and one joining two targets present together as long in two
  cameras that do not overlap (one person is not seen in both at once);
- each group of targets keeps the online meta most of its rows carried, unless a larger group
  took it; otherwise it gets a new one above every online meta.

    res = resolve_labels(rows, [("cam0", "cam1", H_1_from_0)], params.resolve, use_h=True)
    res.meta                   # (N,) int64, the resolved meta of every row
    res.cue_meta(frames, metas) # online metas of cues.csv rows -> resolved metas
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations, pairwise
from typing import Any, Protocol

import numpy as np

from mvtrack.params import ResolveConfig
from mvtrack.stages.markers import Comotion
from mvtrack.stages.matcher import gated_assignment, symmetric_transfer
from mvtrack.stages.meta import cameras_apart
from mvtrack.stages.refit import RefitH
from mvtrack.stages.targets import CameraTargets, exit_outward

__all__ = ["Resolution", "ResolvedLink", "Rows", "Switch", "WholeRunH", "camera_frames",
           "resolve_labels"]

Track = tuple[str, int]
"""(camera, camera-local target label): a target's whole life."""

Node = tuple[str, int, int]
"""(camera, camera-local target label, segment): segment 0 unless the target switched person."""


class Rows(Protocol):
    """A whole run's targets, one row per (frame, camera, target) (`tracks.csv` as arrays):
    frame (N,) int64; camera (N,) str; target (N,) int64; meta (N,) int64, the online meta;
    feet (N, 2) float64 px; boxes_xywh (N, 4) float64 px; height (N,) float64 px."""

    @property
    def frame(self) -> np.ndarray: ...
    @property
    def camera(self) -> np.ndarray: ...
    @property
    def target(self) -> np.ndarray: ...
    @property
    def meta(self) -> np.ndarray: ...
    @property
    def feet(self) -> np.ndarray: ...
    @property
    def boxes_xywh(self) -> np.ndarray: ...
    @property
    def height(self) -> np.ndarray: ...


@dataclass(frozen=True)
class Switch:
    """A target that changed person: its votes went from ``before`` to ``after`` (targets of
    another camera) and it was cut at frame ``cut`` (its rows from there on are a new
    segment); ``frames``: the end of the first run of votes, the gap and the start of the
    second."""

    track: Track
    before: Track
    after: Track
    cut: int
    frames: range
    rejoin: bool = True  # False: the target jumped or turned there, no segment link
    turned: bool = False  # it turned back at the border: its parts are never joined (a
    # hand-off from the first to the second's partner: 'crowd' seed 10)

    @property
    def why(self) -> str:
        """What showed the change, in words (the viewer's event log)."""
        if self.turned:
            return ("it turned back at the border in between (one walked out as the other walked "
                    "in)")
        if not self.rejoin:
            return "its feet jumped in between"
        return "the two were in view together (two people)"


@dataclass(frozen=True)
class ResolvedLink:
    """One link considered: ``source`` "homography" (votes), "online" (the run's own),
    "segment" (a target's segments before and after an identity switch) or "stitch" (one
    camera's target that continues another after a gap)."""

    a: Node
    b: Node
    votes: int
    source: str
    joined: bool


@dataclass(frozen=True)
class WholeRunH:
    """A pair's co-motion hypothesis found over its whole run, the share of the targets its H
    projects well inside the other camera that find one there
    (:func:`~mvtrack.stages.pair.found_share`), the same of the run's final H (None: none or
    no projection) and whether the votes used the hypothesis's H."""

    hypothesis: Comotion
    found_share: float | None
    final_share: float | None
    used: bool


@dataclass(frozen=True)
class Resolution:
    """The resolved meta of every row, and the links that decided it."""

    meta: np.ndarray  # (N,) int64
    links: tuple[ResolvedLink, ...]
    online_to_resolved: dict[tuple[int, int], int]  # (frame, online meta) -> resolved meta
    switches: tuple[Switch, ...] = ()  # targets cut where they changed person
    # per pair searched (`pipeline.resolve_rows`): the whole run's co-motion hypothesis
    # (None: none found)
    comotion: Mapping[tuple[str, str], WholeRunH | None] = field(default_factory=dict)
    # per pair, with the homography matcher (`pipeline.resolve_rows`): its H fitted again
    # from these labels
    refit: Mapping[tuple[str, str], RefitH] = field(default_factory=dict)

    def cue_meta(self, frames: np.ndarray, metas: np.ndarray) -> np.ndarray:
        """Resolved metas for (frame, online meta) pairs; a meta with no target in that frame
        keeps the mapping of its latest earlier frame (unknown: unchanged)."""
        last: dict[int, int] = {}
        out = np.empty(len(metas), np.int64)
        for i in np.argsort(frames, kind="stable").tolist():
            f, m = int(frames[i]), int(metas[i])
            last[m] = self.online_to_resolved.get((f, m), last.get(m, m))
            out[i] = last[m]
        return out


def _frames(rows: Rows) -> list[np.ndarray]:
    """Row indices of each frame, frames in order."""
    order = np.argsort(rows.frame, kind="stable")
    frames = rows.frame[order]
    return np.split(order, np.flatnonzero(frames[1:] != frames[:-1]) + 1) if len(order) else []


def camera_frames(rows: Rows, names: tuple[str, str], sizes: Mapping[str, tuple[int, int]]
                  ) -> Iterator[tuple[int, CameraTargets, CameraTargets]]:
    """(frame, A targets, B targets) of two cameras for every frame from the rows' first to
    their last (a camera without targets in a frame gives none): the run as a pair saw it."""
    chunks = {int(rows.frame[c[0]]): c for c in _frames(rows)}
    none = np.zeros(0, np.int64)
    for frame in range(min(chunks, default=0), max(chunks, default=-1) + 1):
        chunk = chunks.get(frame, none)
        a, b = (_rows_of(chunk, name, rows) for name in names)
        yield frame, _targets(rows, a, sizes[names[0]]), _targets(rows, b, sizes[names[1]])


def _targets(rows: Rows, index: np.ndarray, size: tuple[int, int]) -> CameraTargets:
    return CameraTargets(rows.target[index].astype(np.int64), rows.feet[index],
                         rows.height[index], rows.boxes_xywh[index], size)


def _assignments(rows: Rows, frames: list[np.ndarray], names: tuple[str, str], H: np.ndarray,
                 cfg: ResolveConfig) -> tuple[list[tuple[int, int]], list[tuple[int, int]],
                                              list[tuple[int, int]]]:
    """Votes of one pair as (A row, B row): every frame's gated assignment of the pair's
    targets on the transfer distance (body heights, as the matcher), and the fragment votes: a
    target left out of the assignment votes for the nearest other-camera target within the
    gate (the legs of a person whose torso took the assignment); then every (A row, B row)
    beyond the gate."""
    pairs, fragments, far = [], [], []
    for chunk in frames:
        ia = chunk[rows.camera[chunk] == names[0]]
        ib = chunk[rows.camera[chunk] == names[1]]
        if not len(ia) or not len(ib):
            continue
        cost, _, _ = symmetric_transfer(H, rows.feet[ia], rows.height[ia], rows.feet[ib],
                                        rows.height[ib])
        got = gated_assignment(cost, range(len(ia)), range(len(ib)), cfg.vote_gate_heights)
        pairs += [(int(ia[i]), int(ib[k])) for i, k, _ in got]
        far += [(int(ia[i]), int(ib[k]))
                for i, k in zip(*np.nonzero(cost >= cfg.vote_gate_heights), strict=True)]
        a_of = {k: i for i, k, _ in got}
        b_of = {i: k for i, k, _ in got}
        for i in set(range(len(ia))) - set(b_of):
            k = int(np.argmin(cost[i]))
            if _fragment_of(rows, ia[i], ia[a_of[k]] if k in a_of else None, cost[i, k], cfg):
                fragments.append((int(ia[i]), int(ib[k])))
        for k in set(range(len(ib))) - set(a_of):
            i = int(np.argmin(cost[:, k]))
            if _fragment_of(rows, ib[k], ib[b_of[i]] if i in b_of else None, cost[i, k], cfg):
                fragments.append((int(ia[i]), int(ib[k])))
    return pairs, fragments, far


def _fragment_of(rows: Rows, part: int, whole: int | None, cost: float,
                 cfg: ResolveConfig) -> bool:
    """Whether row ``part``, left out of a frame's assignment at ``cost`` from the nearest
    other-camera target, looks like a piece of row ``whole`` of its own camera (the target
    that other one was assigned to): within the vote gate and at most
    ``fragment_max_height_frac`` of its height. A person walking beside another is as tall."""
    return (whole is not None and cost < cfg.vote_gate_heights
            and rows.height[part] <= cfg.fragment_max_height_frac * rows.height[whole])


_VELOCITY_FRAMES = 10  # rows over which a walking velocity is measured
# ...and where a target began and ended (:class:`_Ends`), over these many rows: a stitch
# (:func:`_continues`) may also go by a walk as long as the gap it bridges. Over 10 rows the
# feet's sway with the stride puts the velocity off by a few tenths of a px a frame, 15 px
# after a 50-frame gap ('doors' s9 cam0's target 1, hidden 36 frames behind the booth, was
# put 38 px from where it came out). Candidates are still ranked by the 10-row walk: ranked
# by the longer ones, PETS (View_001 video + View_003 detections, whose tracks break
# everywhere and whose people wander) fell from IDF1 0.535 to 0.488.
_END_WALK_ROWS = (10, 20, 30)
_TURN_FRAMES = 20  # a turn at the border: the walks out and back in over this many frames


def _outward(rows: Rows, sizes: Mapping[str, tuple[int, int]] | None) -> np.ndarray:
    """(N, 2): each row's :func:`~mvtrack.stages.targets.exit_outward` in its camera's frame
    (zeros off the exit borders, and for every row without the frame sizes)."""
    out = np.zeros((len(rows.frame), 2))
    for cam, size in (sizes or {}).items():
        mine = rows.camera == cam
        out[mine] = exit_outward(rows.boxes_xywh[mine], size)
    return out


class _Tracks:
    """Each target's rows by frame; ``outward``: each row's :func:`_outward` (``at_exit``: on
    a border people walk out over)."""

    def __init__(self, rows: Rows, outward: np.ndarray) -> None:
        self.rows = rows
        self.outward = outward
        self.at_exit = np.asarray(outward.any(axis=1))
        self._ends: dict[Track, _Ends] = {}
        self.at: dict[Track, dict[int, int]] = {}
        for i, (c, t, f) in enumerate(zip(rows.camera.tolist(), rows.target.tolist(),
                                          rows.frame.tolist(), strict=True)):
            self.at.setdefault((c, t), {})[f] = i

    def continues(self, p: Track, q: Track, cfg: ResolveConfig) -> bool:
        """Whether target ``q`` began where ``p``, walked on, would be (:func:`_continues`,
        the gaps doubled: another camera's target saw the person throughout): one person its
        camera lost and found again."""
        for t in (p, q):
            if t not in self._ends:  # a target is the partner of many: its ends once
                self._ends[t] = _end_of(self.rows, np.array(list(self.at[t].values())),
                                        self.outward)
        return _continues(self._ends[p], self._ends[q], cfg, gap_factor=2) is not None

    def mostly_out(self, least: float) -> np.ndarray:
        """(N,) bool: rows on a border people walk out over showing less than ``least`` of
        their target's median height. Their feet are guesses: the feet completion gives up on
        people that far out ('tilted' s11: cam0's target 1, walking out over the bottom, 16-26
        px of 60 shown, its feet drifting on the border, won 8 votes from a newcomer in cam1
        and made the two one person)."""
        out = np.zeros(len(self.rows.frame), bool)
        if least <= 0 or not self.at_exit.any():
            return out
        for at in self.at.values():
            mine = np.fromiter(at.values(), np.int64, len(at))
            out[mine] = self.at_exit[mine] & (self.rows.height[mine]
                                              < least * np.median(self.rows.height[mine]))
        return out

    def median_height(self, p: Track) -> float:
        """The target's median height (px, at least 1)."""
        return max(float(np.median(self.rows.height[list(self.at[p].values())])), 1.0)

    def together(self, p: Track, q: Track) -> int:
        """Frames both targets were present."""
        return len(self.at[p].keys() & self.at[q].keys())

    def bend(self, p: Track, cut: int) -> float:
        """How far the target's feet in the ``_VELOCITY_FRAMES`` frames from ``cut`` on lie
        from where its walk over as many frames before ``cut`` (:func:`_walk`) puts them:
        the median distance in its median heights (0 without rows on both sides)."""
        at, r, k = self.at[p], self.rows, _VELOCITY_FRAMES
        before = [at[f] for f in range(cut - k, cut) if f in at]
        after = [at[f] for f in range(cut, cut + k) if f in at]
        if not before or not after:
            return 0.0
        xy, v = _walk(r.frame[before], r.feet[before], cut)
        ahead = xy + (r.frame[after] - cut)[:, None] * v
        d = np.linalg.norm(r.feet[after] - ahead, axis=1)
        return float(np.median(d)) / self.median_height(p)

    def jump(self, p: Track, frames: range, heights: float) -> int | None:
        """The frame in ``frames`` where the target's feet moved furthest from the frame
        before, if more than ``heights`` times its median height (not the frame's: a target
        shrinking at the frame's edge is no jump); else None."""
        at, r = self.at[p], self.rows
        scale = self.median_height(p)
        best, where = heights * scale, None
        for f in frames:
            i, k = at.get(f - 1), at.get(f)
            if i is not None and k is not None:
                d = float(np.linalg.norm(r.feet[k] - r.feet[i]))
                if d > best:
                    best, where = d, f
        return where

    def turn(self, p: Track, frames: range, heights: float) -> int | None:
        """The frame in ``frames`` where the target walked back the way it came at the left,
        right or bottom border: its box on that border, whose inner edge (the one away from
        it) came more than ``heights`` times the target's median height towards it over the
        ``_TURN_FRAMES`` before and went as far back over those after (of such frames, the
        one with the most each way: the apex); else None. One person walking out of the view
        as another walks in there, one blob for both, make this turn; a person turning round
        inside the view does not. The inner edge, not the feet: a blob the border cuts moves
        its inner edge by the whole walk, the feet under its centroid by half, and two people
        in turn there stand on different rows, which puts a jump across the walk into the
        feet."""
        at, r, k = self.at[p], self.rows, _TURN_FRAMES
        best, where = heights * self.median_height(p), None
        for f in frames:
            j = at.get(f)
            if j is None or not self.at_exit[j]:
                continue
            u = self.outward[j] / np.linalg.norm(self.outward[j])
            near = [at[g] for g in range(f - k, f + k + 1) if g in at]
            out = _inner_edges(r.boxes_xywh[near], u) @ u  # how far out each row's is
            here = out[near.index(j)]
            split = r.frame[near] < f
            came, went = (here - out[side | (r.frame[near] == f)].min()
                          for side in (split, ~split))
            if min(came, went) > best:
                best, where = min(came, went), f
        return where


def _inner_edges(boxes_xywh: np.ndarray, outward: np.ndarray) -> np.ndarray:
    """(N, 2): the boxes' edges away from the border(s) of ``outward`` (a direction of
    :func:`_outward`): left edge x for the right border, top edge y for the bottom one, ...
    (the other coordinate is the box's top-left corner's). A blob the border cuts moves this
    edge with the walk; the feet under its centroid, by half, and they slide to another row
    with another person."""
    boxes = np.asarray(boxes_xywh, np.float64).reshape(-1, 4)
    return boxes[:, :2] + np.where(np.asarray(outward) < 0, boxes[:, 2:], 0.0)


def _long_runs(runs: list[list[Any]], least: int) -> list[list[Any]]:
    """The runs of votes (partner, first frame, last frame, votes) with at least ``least``
    votes, those next to each other for one partner joined (new lists)."""
    long: list[list[Any]] = []
    for run in (r for r in runs if r[3] >= least):
        if long and long[-1][0] == run[0]:
            long[-1][2], long[-1][3] = run[2], long[-1][3] + run[3]
        else:
            long.append([*run])
    return long


def _switches(track: Track, partners: list[tuple[int, Track]], tracks: _Tracks,
              cfg: ResolveConfig) -> list[Switch]:
    """Where a target's votes change person. ``partners``: its (frame, voted partner) in one
    other camera, by frame. Runs of one partner shorter than ``switch_min_votes`` are ignored;
    two long runs in a row whose partners are two people (present together longer than
    ``max_shared_frames``) make a switch, cut half-way between the runs. Partners never seen
    together may be one person who left the other camera and came back, or was lost there
    and found again: when the second began where the first would be
    (:meth:`_Tracks.continues`) there is no switch; otherwise the switch holds only if the
    target itself jumped between the runs (feet more than ``switch_jump_heights`` of its
    height from one frame to the next: the label moved to someone else) or turned back
    (:meth:`_Tracks.turn`, ``switch_turn_heights``: one person walked out as another walked
    in), and its parts are never rejoined; the cut is at the turn where there is one, else at
    the jump (a jump between the same runs may be a glitch, legs lost in a merge, where a turn
    at the border is where one person left). That evidence is enough with shorter runs, of
    ``switch_moved_min_votes``."""
    runs: list[list[Any]] = []  # [partner, first frame, last frame, votes]
    for f, partner in partners:
        if runs and runs[-1][0] == partner:
            runs[-1][2], runs[-1][3] = f, runs[-1][3] + 1
        else:
            runs.append([partner, f, f, 1])
    margin = cfg.switch_min_votes
    out = []
    for p, q in pairwise(_long_runs(runs, cfg.switch_min_votes)):
        frames = range(p[2] - margin, q[1] + margin + 1)
        if tracks.together(p[0], q[0]) > cfg.max_shared_frames:
            out.append(Switch(track, p[0], q[0], (p[2] + q[1] + 1) // 2, frames))
    for p, q in pairwise(_long_runs(runs, cfg.switch_moved_min_votes)):
        frames = range(p[2] - margin, q[1] + margin + 1)
        between = range(p[2] + 1, q[1] + 1)
        if (tracks.together(p[0], q[0]) > cfg.max_shared_frames
                or tracks.continues(p[0], q[0], cfg)):
            continue
        turn = cfg.switch_turn_heights > 0 and tracks.turn(track, between,
                                                           cfg.switch_turn_heights)
        if at := turn or tracks.jump(track, between, cfg.switch_jump_heights):
            out.append(Switch(track, p[0], q[0], at, frames, rejoin=False,
                              turned=bool(turn)))
    return sorted(out, key=lambda sw: sw.cut)


def _who_switched(sw: Switch, by_track: dict[Track, list[Switch]], tracks: _Tracks) -> bool:
    """Whether ``sw``'s own target changed person. Two people swapped in one camera, or one
    target there handed from one to the other, make switches in both cameras: the other
    camera's targets see this one go from one to the other. The target that changed person
    was put on the other's path: of the two, the one whose feet after the switch lie further
    from its walk before (:meth:`_Tracks.bend`) switched; without such a mirror switch the
    target's own camera did. A mirror happens at the same time: each cut lies within the
    other's frames. (Generated 'tilted' seed 6: cam0's target 3 turned at the border at frame
    97, one person walking out as another walked in; cam1's target of the newcomer changed
    partner at 226, when cam0 lost that newcomer and found it again. The two share a target
    but 129 frames lie between them, and cam1's was cut instead.)"""
    for other in (sw.before, sw.after):
        for mirror in by_track.get(other, ()):
            overlap = mirror.cut in sw.frames and sw.cut in mirror.frames
            if sw.track in (mirror.before, mirror.after) and overlap:
                return tracks.bend(sw.track, sw.cut) > tracks.bend(mirror.track, mirror.cut)
    return True


def _segments(rows: Rows, votes: list[tuple[int, int]], cfg: ResolveConfig,
              tracks: _Tracks
              ) -> tuple[np.ndarray, list[Switch], set[Node], set[tuple[Node, Node]]]:
    """(N,) int64: each row's segment of its target, cut where it changed person
    (:func:`_switches`, :func:`_who_switched`; 0 without cuts), the switches cut, the
    segments not to be linked to the one before (a jump or a turn) and the (segment, next
    segment) pairs of two people, never joined by any link (a turn at the border: a stitch,
    which walks on the same way, may rejoin the parts of a glitch's jump; 'doors' seed 9)."""
    partners: dict[tuple[Track, str], list[tuple[int, Track]]] = {}
    cams, targets, frame = rows.camera.tolist(), rows.target.tolist(), rows.frame.tolist()
    for i, k in votes:
        a, b = (cams[i], targets[i]), (cams[k], targets[k])
        partners.setdefault((a, b[0]), []).append((frame[i], b))
        partners.setdefault((b, a[0]), []).append((frame[k], a))
    by_track: dict[Track, list[Switch]] = {}
    for (track, _), seq in partners.items():
        seq.sort()
        by_track.setdefault(track, []).extend(_switches(track, seq, tracks, cfg))
    segment = np.zeros(len(frame), np.int64)
    cut: list[Switch] = []
    apart: set[Node] = set()
    two_people: set[tuple[Node, Node]] = set()
    for track, switches in by_track.items():
        mine = sorted({sw.cut: sw for sw in switches
                       if _who_switched(sw, by_track, tracks)}.values(), key=lambda sw: sw.cut)
        cut += mine
        apart |= {(*track, n + 1) for n, sw in enumerate(mine) if not sw.rejoin}
        two_people |= {((*track, n), (*track, n + 1)) for n, sw in enumerate(mine) if sw.turned}
        for sw in mine:
            for f, i in tracks.at[track].items():
                segment[i] += f >= sw.cut
    return segment, cut, apart, two_people


def _apart(nodes: list[Node], assigned: Mapping[tuple[str, str], list[tuple[int, int]]],
           far: Mapping[tuple[str, str], list[tuple[int, int]]],
           cfg: ResolveConfig) -> set[tuple[Node, Node]]:
    """(A node, B node) pairs of two people: present together beyond the vote gate in more
    than ``max_shared_frames`` frames, and assigned to each other in fewer than
    ``apart_max_vote_share`` of as many. ``assigned``, ``far``: (A row, B row) per pair."""
    voted = Counter((nodes[i], nodes[k]) for vs in assigned.values() for i, k in vs)
    frames_far = Counter((nodes[i], nodes[k]) for vs in far.values() for i, k in vs)
    return {xy for xy, n in frames_far.items()
            if n > cfg.max_shared_frames and voted[xy] < cfg.apart_max_vote_share * n}


def _homography_votes(rows: Rows, nodes: list[Node], frames: list[np.ndarray],
                      names: tuple[str, str], assigned: list[tuple[int, int]],
                      cfg: ResolveConfig) -> list[tuple[int, Node, Node]]:
    """(votes, A target, B target) of the pairs that pass ``min_votes`` and
    ``min_vote_share``: a vote per frame a pair is assigned, counted against the frames both
    were present."""
    votes = Counter((nodes[i], nodes[k]) for i, k in assigned)
    together: Counter[tuple[Node, Node]] = Counter()
    for chunk in frames:
        ia = chunk[rows.camera[chunk] == names[0]]
        ib = chunk[rows.camera[chunk] == names[1]]
        together.update((nodes[i], nodes[k]) for i in ia.tolist() for k in ib.tolist())
    return [(v, x, y) for (x, y), v in votes.items()
            if v >= cfg.min_votes and v >= cfg.min_vote_share * together[(x, y)]]


def _segment_links(nodes: list[Node], apart: set[Node]) -> list[tuple[int, Node, Node]]:
    """(rows of the shorter, segment, next segment) of every target cut into segments, but
    for the segments in ``apart``."""
    count = Counter(nodes)
    return [(min(count[n], count[(n[0], n[1], n[2] + 1)]), n, (n[0], n[1], n[2] + 1))
            for n in sorted(count)
            if (n[0], n[1], n[2] + 1) in count and (n[0], n[1], n[2] + 1) not in apart]


@dataclass(frozen=True)
class _Ends:
    """Where a node (a target or a segment of one) begins and ends: frame, feet (px) and
    velocity (px per frame), the walks (:func:`_walk`) of its first or last k rows for each k
    of ``_END_WALK_ROWS``; its median height (px), and whether it walked out of the view: its
    last box on a border it can walk out over (:func:`_outward`), its box's inner edge over
    its last 10 rows (:func:`_inner_edges`) not heading back into the view (a person who came
    in there and merged with someone on the border at the end did not walk out; a person
    walking out over the bottom whose feet, completed below the frame, fell back onto it at
    the end did: 'tilted' seed 11 cam0's target 1 with feet.up = "learned")."""

    first: int
    last: int
    starts: tuple[tuple[np.ndarray, np.ndarray], ...]  # (feet, velocity) per k
    ends: tuple[tuple[np.ndarray, np.ndarray], ...]
    height: float
    walked_out: bool


def _walk_index(gap: int) -> int:
    """Index into ``_END_WALK_ROWS`` of the longest walk for a gap of ``gap`` frames."""
    return min(int(np.searchsorted(_END_WALK_ROWS, gap)), len(_END_WALK_ROWS) - 1)


def _walk(frames: np.ndarray, xy: np.ndarray, at: int) -> tuple[np.ndarray, np.ndarray]:
    """Where a target was at frame ``at`` and its velocity (px per frame), from rows
    (frames, feet) near it: the Theil-Sen line (median of the pairwise velocities, median of
    the rows' feet carried to ``at`` at that velocity), so that a few bad rows (a merge with
    someone, legs lost) bend neither."""
    i, j = np.triu_indices(len(frames), 1)
    if not len(i):
        return xy[0].astype(np.float64), np.zeros(2)
    v = np.median((xy[j] - xy[i]) / np.maximum(frames[j] - frames[i], 1)[:, None], axis=0)
    return np.median(xy + (at - frames)[:, None] * v, axis=0), v


def _end_of(rows: Rows, idx: np.ndarray, outward: np.ndarray) -> _Ends:
    """The :class:`_Ends` of the rows ``idx`` (one target's or segment's)."""
    order = idx[np.argsort(rows.frame[idx], kind="stable")]
    f, xy = rows.frame[order], rows.feet[order]
    starts = tuple(_walk(f[:k], xy[:k], int(f[0])) for k in _END_WALK_ROWS)
    ends = tuple(_walk(f[-k:], xy[-k:], int(f[-1])) for k in _END_WALK_ROWS)
    side, last = outward[order[-1]], order[-_END_WALK_ROWS[0]:]
    walked_out = bool(side.any()) and float(_walk(
        rows.frame[last], _inner_edges(rows.boxes_xywh[last], side), int(f[-1]))[1] @ side) >= 0
    return _Ends(int(f[0]), int(f[-1]), starts, ends, float(np.median(rows.height[order])),
                 walked_out)


def _rows_by_node(nodes: list[Node]) -> dict[Node, np.ndarray]:
    """Each node's row indices, in row order."""
    at: dict[Node, list[int]] = {}
    for i, n in enumerate(nodes):
        at.setdefault(n, []).append(i)
    return {n: np.array(idx) for n, idx in at.items()}


def _ends(rows: Rows, by_node: Mapping[Node, np.ndarray], outward: np.ndarray
          ) -> dict[Node, _Ends]:
    return {n: _end_of(rows, idx, outward) for n, idx in by_node.items()}


def _continues(ex: _Ends, ey: _Ends, cfg: ResolveConfig, gap_factor: int = 1) -> float | None:
    """Whether ``ey`` may go on as ``ex`` (one camera's target, a person hidden a while): it
    began at most ``gap_factor`` times ``stitch_max_gap_frames`` frames after ``ex`` ended
    (``stitch_walking_max_gap_frames`` if ``ex`` was walking: its last 30 rows' speed at
    least ``stitch_walking_min_speed_heights``), ``ex`` did not walk out of the view, and by
    one of the walks of ``_END_WALK_ROWS`` no longer than the gap (10 rows, and more for
    longer gaps) ``ey`` began within ``stitch_gate_heights`` of where ``ex``, walked on,
    would be, walking the same way. Returns how far (in heights) by the 10-row walks, which
    rank the candidates, or None."""
    gap = ey.first - ex.last
    longest = max(cfg.stitch_walking_max_gap_frames, cfg.stitch_max_gap_frames)
    if ex.walked_out or not 0 < gap <= gap_factor * longest:
        return None
    if gap > gap_factor * cfg.stitch_max_gap_frames and (
            np.linalg.norm(ex.ends[-1][1]) < cfg.stitch_walking_min_speed_heights * ex.height):
        return None  # standing still: anyone may stand there by now
    off = []  # per walk: (heights apart, walking the same way)
    for (end_xy, end_v), (start_xy, start_v) in zip(ex.ends, ey.starts, strict=True):
        off.append((float(np.linalg.norm(start_xy - (end_xy + gap * end_v))) / ex.height,
                    float(end_v @ start_v) >= 0))
    walks = off[: _walk_index(gap) + 1]
    if not any(d <= cfg.stitch_gate_heights and same for d, same in walks):
        return None
    return off[0][0]


def _stitch_links(nodes: list[Node], ends: dict[Node, _Ends], cfg: ResolveConfig
                  ) -> list[tuple[int, Node, Node]]:
    """(rows of the shorter, earlier node, later node): one camera's target that ended and
    one that began where the first would be after a while (:func:`_continues`), each the
    other's only such match: a person hidden behind something for a while."""
    candidates = ((_continues(ex, ey, cfg), x, y) for x, ex in ends.items()
                  for y, ey in ends.items() if y[0] == x[0])
    return _mutual_best(candidates, Counter(nodes))


def _mutual_best(candidates: Iterable[tuple[float | None, Node, Node]],
                 count: Mapping[Node, int]) -> list[tuple[int, Node, Node]]:
    """(rows of the shorter, earlier node, later node) of the candidate (cost, earlier, later)
    links (cost None: none) that are each end's cheapest; ``count``: rows per node."""
    best: dict[Node, tuple[float, Node]] = {}
    back: dict[Node, tuple[float, Node]] = {}
    for cost, x, y in candidates:
        if cost is None:
            continue
        if cost < best.get(x, (np.inf,))[0]:
            best[x] = (cost, y)
        if cost < back.get(y, (np.inf,))[0]:
            back[y] = (cost, x)
    return [(min(count[x], count[y]), x, y) for x, (_, y) in best.items() if back[y][1] == x]


def _handoff_links(rows: Rows, frames: list[np.ndarray], by_node: Mapping[Node, np.ndarray],
                   ends: dict[Node, _Ends], pairs: Mapping[tuple[str, str], np.ndarray],
                   cfg: ResolveConfig) -> list[tuple[int, Node, Node]]:
    """(rows of the shorter, earlier node, later node) for each pair with H (``pairs``: A, B
    -> H_b_from_a; ``frames``, ``by_node``: each frame's and each node's row indices), both
    ways: a target of one camera that ended while walking (its last 30
    rows at least ``stitch_walking_min_speed_heights``) unseen by the other camera (in none
    of its last 10 frames had that camera a target within ``handoff_seen_heights`` of where
    H put its feet: hidden there, or just out of its view), and a target of that camera that
    began at most ``handoff_max_gap_frames`` later within ``stitch_gate_heights`` (its own
    height) of where the first's walk, carried through H, leads; both at least
    ``handoff_min_rows`` rows long, each the other's only such match. A person hidden in one
    view who leaves (or is lost in) the other comes out there: the pillar, the booth. The
    unseen test keeps apart someone walking on where the other camera sees them (or, with
    detections, loses them for a frame) and a newcomer there."""
    if cfg.handoff_max_gap_frames <= 0:
        return []
    at = {int(rows.frame[c[0]]): c for c in frames}
    count = {n: len(idx) for n, idx in by_node.items()}

    def candidates(src: str, dst: str, M: np.ndarray) -> Iterator[tuple[float, Node, Node]]:
        starts = [(y, ey) for y, ey in ends.items()
                  if y[0] == dst and count[y] >= cfg.handoff_min_rows]
        for x, ex in ends.items():
            if (x[0] != src or count[x] < cfg.handoff_min_rows or np.linalg.norm(
                    ex.ends[-1][1]) < cfg.stitch_walking_min_speed_heights * ex.height
                    or not _unseen(rows, at, by_node[x], dst, M,
                                   cfg.handoff_seen_heights)):
                continue
            for y, ey in starts:
                gap = ey.first - ex.last
                lead = _on_ground(M, ex.ends[0][0] + gap * ex.ends[0][1])
                if 0 < gap <= cfg.handoff_max_gap_frames and lead is not None:
                    d = float(np.linalg.norm(ey.starts[0][0] - lead)) / ey.height
                    if d <= cfg.stitch_gate_heights:
                        yield d, x, y

    return _mutual_best((c for (a, b), H in pairs.items()
                         for src, dst, M in ((a, b, H), (b, a, np.linalg.inv(H)))
                         for c in candidates(src, dst, M)), count)


def _unseen(rows: Rows, at: Mapping[int, np.ndarray], mine: np.ndarray, camera: str,
            H: np.ndarray, gate: float) -> bool:
    """Whether ``camera`` did not see a target (its rows ``mine``; H: from its camera to
    that one; ``at``: frame -> row indices) when it ended: in none of its last 10 frames had
    that camera a target within ``gate`` heights (that target's) of where H put its feet."""
    for r in mine[np.argsort(rows.frame[mine], kind="stable")][-_END_WALK_ROWS[0]:]:
        there = _rows_of(at[int(rows.frame[r])], camera, rows)
        feet = _on_ground(H, rows.feet[r])
        if feet is not None and (np.linalg.norm(rows.feet[there] - feet, axis=1)
                                 <= gate * rows.height[there]).any():
            return False
    return True


def _on_ground(H: np.ndarray, xy: np.ndarray) -> np.ndarray | None:
    """(2,) H applied to one point, or None where H maps it beyond the horizon (w <= 0: a
    walk carried past the ground plane's horizon lands on the wrong side of the image)."""
    q = H @ np.r_[xy, 1.0]
    return None if q[2] <= 0 else q[:2] / q[2]


def _rows_of(chunk: np.ndarray, camera: str, rows: Rows) -> np.ndarray:
    """The rows of ``chunk`` (row indices) that are ``camera``'s."""
    return chunk[rows.camera[chunk] == camera]


def _online_links(rows: Rows, nodes: list[Node], pairs_without_h: set[frozenset[str]],
                  cfg: ResolveConfig, ends: dict[Node, _Ends]) -> tuple[Counter, Counter]:
    """The run's own links: cross-camera (same meta in one frame, only for pairs without H)
    and same-camera continuity (a meta taken over within ``resume_gap_frames`` from a target
    that did not walk out of the view, ``_Ends.walked_out``)."""
    cross: Counter[tuple[Node, Node]] = Counter()
    by_key: dict[tuple[int, int], list[Node]] = {}
    span: dict[tuple[Node, int], list[int]] = {}
    for f, m, n in zip(rows.frame.tolist(), rows.meta.tolist(), nodes, strict=True):
        by_key.setdefault((f, m), []).append(n)
        s = span.setdefault((n, m), [f, f, 0])
        s[0], s[1], s[2] = min(s[0], f), max(s[1], f), s[2] + 1
    for group in by_key.values():
        for x, y in combinations(sorted(set(group)), 2):
            if x[0] != y[0] and frozenset((x[0], y[0])) in pairs_without_h:
                cross[(x, y)] += 1
    same: Counter[tuple[Node, Node]] = Counter()
    carriers: dict[int, list[tuple[Node, list[int]]]] = {}
    for (n, m), s in span.items():
        carriers.setdefault(m, []).append((n, s))
    for members in carriers.values():
        for (x, sx), (y, sy) in combinations(sorted(members), 2):
            gap = max(sx[0], sy[0]) - min(sx[1], sy[1])
            earlier, taken_at = (x, sy[0]) if sx[1] < sy[0] else (y, sx[0])
            # A take-over, not a meta handed from one live target to another: the earlier
            # target is gone when the later one takes the meta.
            if (x[0] == y[0] and x[:2] != y[:2] and 0 < gap <= cfg.resume_gap_frames
                    and ends[earlier].last < taken_at and not ends[earlier].walked_out):
                # (segments of one target: _segment_links)
                same[(x, y)] = min(sx[2], sy[2])
    return cross, same


class _Groups:
    """Union-find of targets that refuses to join two people: two targets of one camera, or
    of two cameras in ``apart_cameras`` (:func:`~mvtrack.stages.meta.cameras_apart`), present
    together in more than ``max_shared`` frames, or a pair in ``apart``."""

    def __init__(self, rows: Rows, nodes: list[Node], max_shared: int,
                 apart: set[tuple[Node, Node]],
                 apart_cameras: Collection[frozenset[str]] = ()) -> None:
        self.apart = apart
        self.apart_cameras = frozenset(apart_cameras)
        self.parent = {n: n for n in nodes}
        self.members = {n: [n] for n in self.parent}
        self.frames: dict[Node, set[int]] = {}
        for n, f in zip(nodes, rows.frame.tolist(), strict=True):
            self.frames.setdefault(n, set()).add(f)
        self.max_shared = max_shared

    def find(self, n: Node) -> Node:
        while self.parent[n] != n:
            self.parent[n] = self.parent[self.parent[n]]
            n = self.parent[n]
        return n

    def join(self, x: Node, y: Node, max_shared: int | None = None) -> bool:
        """Join the groups of x and y unless that joins two people (``max_shared``: instead of
        the groups' own)."""
        rx, ry = self.find(x), self.find(y)
        if rx == ry:
            return True
        most = self.max_shared if max_shared is None else max_shared
        for p in self.members[rx]:
            for q in self.members[ry]:
                one_view = p[0] == q[0] or frozenset((p[0], q[0])) in self.apart_cameras
                if one_view and len(self.frames[p] & self.frames[q]) > most:
                    return False
                if (p, q) in self.apart or (q, p) in self.apart:
                    return False
        if len(self.members[rx]) < len(self.members[ry]):
            rx, ry = ry, rx
        self.parent[ry] = rx
        self.members[rx] += self.members.pop(ry)
        return True


def _name_groups(rows: Rows, nodes: list[Node], groups: _Groups) -> np.ndarray:
    """A meta per row: each group keeps its most carried online meta unless a larger group
    took it; the others get new ids above every online meta."""
    roots = [groups.find(n) for n in nodes]
    carried: dict[Node, Counter[int]] = {}
    for r, m in zip(roots, rows.meta.tolist(), strict=True):
        carried.setdefault(r, Counter())[m] += 1
    taken: set[int] = set()
    name: dict[Node, int] = {}
    fresh = int(rows.meta.max(initial=0)) + 1
    for r in sorted(carried, key=lambda r: -sum(carried[r].values())):
        m = carried[r].most_common(1)[0][0]
        if m in taken:
            m, fresh = fresh, fresh + 1
        taken.add(m)
        name[r] = m
    return np.array([name[r] for r in roots], np.int64)


def resolve_labels(rows: Rows, pairs: Sequence[tuple[str, str, np.ndarray | None]],
                   cfg: ResolveConfig, use_h: bool = True,
                   sizes: Mapping[str, tuple[int, int]] | None = None,
                   overlaps: Collection[tuple[str, str]] | None = None) -> Resolution:
    """Resolve every target's meta over the whole run (module docstring).

    pairs: (camera A, camera B, final H_b_from_a or None) per declared overlap
    use_h: False for the FOV-only baseline: every pair keeps the run's own links
    sizes: camera -> (width, height) of its frame; without them the borders are unknown: no
           target is cut where it turned back at one, and stitches may start at one
    overlaps: the camera pairs that overlap (either order); None: every pair does
    """
    frames = _frames(rows)
    assigned: dict[tuple[str, str], list[tuple[int, int]]] = {}
    fragment_votes: dict[tuple[str, str], list[tuple[int, int]]] = {}
    without_h: set[frozenset[str]] = set()
    far: dict[tuple[str, str], list[tuple[int, int]]] = {}
    outward = _outward(rows, sizes)
    tracks = _Tracks(rows, outward)
    guessed = tracks.mostly_out(cfg.vote_min_shown_frac)
    voting = [chunk[~guessed[chunk]] for chunk in frames]
    for a, b, H in pairs:
        if H is None or not use_h:
            without_h.add(frozenset((a, b)))
        else:
            assigned[a, b], fragment_votes[a, b], far[a, b] = _assignments(
                rows, voting, (a, b), np.asarray(H, np.float64), cfg)
    segment, switches, apart, two_people = _segments(
        rows, [v for vs in assigned.values() for v in vs], cfg, tracks)
    nodes: list[Node] = list(zip(rows.camera.tolist(), rows.target.tolist(), segment.tolist(),
                                 strict=True))
    scored: list[tuple[int, int, Node, Node, str]] = []  # (rank, votes, a, b, source)
    for names, votes in assigned.items():
        scored += [(0, v, x, y, "homography") for v, x, y in _homography_votes(
            rows, nodes, frames, names, votes + fragment_votes[names], cfg)]
    by_node = _rows_by_node(nodes)
    ends = _ends(rows, by_node, outward)
    cross, same = _online_links(rows, nodes, without_h, cfg, ends)
    scored += [(0, v, x, y, "online") for (x, y), v in cross.items() if v >= cfg.min_votes]
    scored += [(1, v, x, y, "online") for (x, y), v in same.items()]
    scored += [(1, v, x, y, "segment") for v, x, y in _segment_links(nodes, apart)]
    scored += [(2, v, x, y, "stitch") for v, x, y in _stitch_links(nodes, ends, cfg)]
    with_h = {(a, b): np.asarray(H, np.float64) for a, b, H in pairs if H is not None and use_h}
    scored += [(3, v, x, y, "handoff")
               for v, x, y in _handoff_links(rows, frames, by_node, ends, with_h, cfg)]
    groups = _Groups(rows, nodes, cfg.max_shared_frames,
                     _apart(nodes, assigned, far, cfg) | two_people,
                     cameras_apart(rows.camera.tolist(), overlaps))
    links = []
    for _, v, x, y, source in sorted(scored, key=lambda s: (s[0], -s[1], s[2], s[3])):
        # a hand-off joins no two targets of one camera seen together even for a frame: the
        # person was hidden in one view and gone from the other
        links.append(ResolvedLink(x, y, v, source,
                                  groups.join(x, y, 0 if source == "handoff" else None)))
    meta = _name_groups(rows, nodes, groups)
    mapping: dict[tuple[int, int], Counter[int]] = {}
    for f, m, r in zip(rows.frame.tolist(), rows.meta.tolist(), meta.tolist(), strict=True):
        mapping.setdefault((f, m), Counter())[r] += 1
    return Resolution(meta, tuple(links),
                      {k: c.most_common(1)[0][0] for k, c in mapping.items()}, tuple(switches))

