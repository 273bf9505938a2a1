"""Whole-run label resolution [beyond]: each target's meta decided with all the run learned.

Online (SPEC §7–8) a target's meta is what the evidence said at that frame. People who are in
two views before the pair has a homography, and leave before it exists, only ever get FOV-event
links, and a target's meta changes when a later link joins it to another. After the run, every
pair's final homography can score every pair of targets that were ever in view together, so
the results give each target one meta for its whole life:

- **votes**: in each frame, for each pair with a final H, a gated minimum-cost assignment on
  the symmetric transfer distance (body heights, as the matcher) of the targets present; a vote
  for (A target, B target) per frame they are assigned;
- a **cross-camera link** needs ``min_votes`` votes and ``min_vote_share`` of the frames both
  targets were present;
- pairs without a final H (and every pair with the FOV-only matcher, which must not use H) keep
  the run's own links: votes = frames the two targets carried one meta together;
- **within one camera** a target that took over the meta of an earlier one (the meta stage's
  resume, or a re-attach through another camera) after at most ``resume_gap_frames`` frames
  stays with it, if the earlier target was gone by then (a meta moved between two live
  targets is the online stage changing its mind, not one person coming back);
- links join strongest first (cross-camera votes before same-camera continuity). A join that
  would put two targets of one camera present together in more than ``max_shared_frames``
  frames into one meta is refused: those are two people, not two fragments of one;
- each group of targets keeps the online meta most of its rows carried, unless a larger group
  took it; otherwise it gets a new one above every online meta.

    res = resolve_labels(rows, [("cam0", "cam1", H_1_from_0)], params.resolve, use_h=True)
    res.meta                   # (N,) int64, the resolved meta of every row
    res.cue_meta(frames, metas) # online metas of cues.csv rows -> resolved metas
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from typing import Protocol

import numpy as np

from mvtrack.params import ResolveConfig
from mvtrack.stages.matcher import gated_assignment, symmetric_transfer

__all__ = ["Resolution", "ResolvedLink", "Rows", "resolve_labels"]

Node = tuple[str, int]
"""(camera, camera-local target label)."""


class Rows(Protocol):
    """A whole run's targets, one row per (frame, camera, target) (`tracks.csv` as arrays):
    frame (N,) int64; camera (N,) str; target (N,) int64; meta (N,) int64, the online meta;
    feet (N, 2) float64 px; height (N,) float64 px."""

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
    def height(self) -> np.ndarray: ...


@dataclass(frozen=True)
class ResolvedLink:
    """One link considered: ``source`` "homography" (votes) or "online" (the run's own)."""

    a: Node
    b: Node
    votes: int
    source: str
    joined: bool


@dataclass(frozen=True)
class Resolution:
    """The resolved meta of every row, and the links that decided it."""

    meta: np.ndarray  # (N,) int64
    links: tuple[ResolvedLink, ...]
    online_to_resolved: dict[tuple[int, int], int]  # (frame, online meta) -> resolved meta

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


def _nodes(rows: Rows) -> list[Node]:
    return list(zip(rows.camera.tolist(), rows.target.tolist(), strict=True))


def _frames(rows: Rows) -> list[np.ndarray]:
    """Row indices of each frame, frames in order."""
    order = np.argsort(rows.frame, kind="stable")
    frames = rows.frame[order]
    return np.split(order, np.flatnonzero(frames[1:] != frames[:-1]) + 1) if len(order) else []


def _homography_votes(rows: Rows, nodes: list[Node], frames: list[np.ndarray],
                      names: tuple[str, str], H: np.ndarray, cfg: ResolveConfig
                      ) -> list[tuple[int, Node, Node]]:
    """(votes, A target, B target) of the pairs that pass ``min_votes`` and
    ``min_vote_share``: per frame, the gated assignment of the pair's targets on the
    transfer distance, counted against the frames both targets were present."""
    votes: Counter[tuple[Node, Node]] = Counter()
    together: Counter[tuple[Node, Node]] = Counter()
    for chunk in frames:
        ia = chunk[rows.camera[chunk] == names[0]]
        ib = chunk[rows.camera[chunk] == names[1]]
        if not len(ia) or not len(ib):
            continue
        together.update((nodes[i], nodes[k]) for i in ia.tolist() for k in ib.tolist())
        cost, _, _ = symmetric_transfer(H, rows.feet[ia], rows.height[ia], rows.feet[ib],
                                        rows.height[ib])
        for i, k, _ in gated_assignment(cost, range(len(ia)), range(len(ib)),
                                        cfg.vote_gate_heights):
            votes[(nodes[ia[i]], nodes[ib[k]])] += 1
    return [(v, x, y) for (x, y), v in votes.items()
            if v >= cfg.min_votes and v >= cfg.min_vote_share * together[(x, y)]]


def _online_links(rows: Rows, nodes: list[Node], pairs_without_h: set[frozenset[str]],
                  cfg: ResolveConfig) -> tuple[Counter, Counter]:
    """The run's own links: cross-camera (same meta in one frame, only for pairs without H)
    and same-camera continuity (a meta taken over within ``resume_gap_frames``)."""
    cross: Counter[tuple[Node, Node]] = Counter()
    by_key: dict[tuple[int, int], list[Node]] = {}
    span: dict[tuple[Node, int], list[int]] = {}
    last: dict[Node, int] = {}
    for f, m, n in zip(rows.frame.tolist(), rows.meta.tolist(), nodes, strict=True):
        by_key.setdefault((f, m), []).append(n)
        s = span.setdefault((n, m), [f, f, 0])
        s[0], s[1], s[2] = min(s[0], f), max(s[1], f), s[2] + 1
        last[n] = max(last.get(n, f), f)
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
            if x[0] == y[0] and 0 < gap <= cfg.resume_gap_frames and last[earlier] < taken_at:
                same[(x, y)] = min(sx[2], sy[2])
    return cross, same


class _Groups:
    """Union-find of targets that refuses to join two people of one camera."""

    def __init__(self, rows: Rows, nodes: list[Node], max_shared: int) -> None:
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

    def join(self, x: Node, y: Node) -> bool:
        rx, ry = self.find(x), self.find(y)
        if rx == ry:
            return True
        for p in self.members[rx]:
            for q in self.members[ry]:
                if p[0] == q[0] and len(self.frames[p] & self.frames[q]) > self.max_shared:
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
                   cfg: ResolveConfig, use_h: bool = True) -> Resolution:
    """Resolve every target's meta over the whole run (module docstring).

    pairs: (camera A, camera B, final H_b_from_a or None) per declared overlap
    use_h: False for the FOV-only baseline: every pair keeps the run's own links
    """
    nodes = _nodes(rows)
    frames = _frames(rows)
    scored: list[tuple[int, int, Node, Node, str]] = []  # (rank, votes, a, b, source)
    without_h: set[frozenset[str]] = set()
    for a, b, H in pairs:
        if H is None or not use_h:
            without_h.add(frozenset((a, b)))
            continue
        scored += [(0, v, x, y, "homography") for v, x, y in _homography_votes(
            rows, nodes, frames, (a, b), np.asarray(H, np.float64), cfg)]
    cross, same = _online_links(rows, nodes, without_h, cfg)
    scored += [(0, v, x, y, "online") for (x, y), v in cross.items() if v >= cfg.min_votes]
    scored += [(1, v, x, y, "online") for (x, y), v in same.items()]
    groups = _Groups(rows, nodes, cfg.max_shared_frames)
    links = []
    for _, v, x, y, source in sorted(scored, key=lambda s: (s[0], -s[1], s[2], s[3])):
        links.append(ResolvedLink(x, y, v, source, groups.join(x, y)))
    meta = _name_groups(rows, nodes, groups)
    mapping: dict[tuple[int, int], Counter[int]] = {}
    for f, m, r in zip(rows.frame.tolist(), rows.meta.tolist(), meta.tolist(), strict=True):
        mapping.setdefault((f, m), Counter())[r] += 1
    return Resolution(meta, tuple(links),
                      {k: c.most_common(1)[0][0] for k, c in mapping.items()})

