"""Meta-targets over N cameras: one consistent label per person (SPEC §7–8).

The pair links of every declared overlap join targets into meta-targets: the connected
components of the link graph, so a person walking A → C → B keeps one label although A and B do
not overlap. A meta-target holds at most one target per camera, and no targets in two cameras
that do not overlap (one person is not seen in both at once: an entrance into C gives FOV
associations in both A–C and C–B, and only one of them is that person). Links are added
strongest first (evidence = frames the link was confirmed, then age), and a link that would
break either rule is rejected and reported as a :class:`Conflict`; the pairs drop markers only
for the links that were kept.

Labels are stable: each component inherits the previous meta of most of its members (ties: the
member that has carried it longest; merging components keep the oldest meta); components with
no previous meta get a new one, unless one of their targets is within ``reattach_heights`` of
where a live meta with no target anywhere was last seen in that camera: then it resumes that
meta (a person the front end lost and found again while no other camera saw it). Not where that
meta's target was last seen touching the left, right or bottom border: that person walked out
of the view, and who appears there next is someone walking in. Likewise a lone target whose
meta is only a few frames old gives it up for such a meta whose target vanished since (the
tracker followed a piece of the person while the body got the new target). Every present
target always has a meta. A meta-target ends ``meta_timeout_frames`` after its last target was
seen; ids are never reused.

    state = meta_init()
    state, result = meta_step(state, MetaInputs(cameras, edges, frame), params.meta)
    result.metas["cam0"]          # (N,) int64, one meta per target of cam0 (labels order)
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from mvtrack.params import MetaConfig
from mvtrack.stages.targets import CameraTargets, on_exit_border

__all__ = [
    "Conflict",
    "Edge",
    "MetaInputs",
    "MetaResult",
    "MetaState",
    "cameras_apart",
    "meta_init",
    "meta_step",
]

Node = tuple[str, int]
"""(camera, camera-local target label)."""


@dataclass(frozen=True)
class Edge:
    """A pair link between two targets of two cameras, with its evidence.

    evidence: frames the link was confirmed (+1 so that unconfirmed FOV links still count)
    since:    frame the link was made (older wins ties)
    source:   how the pair made it ("fov", "create", "reattach", ...)
    """

    a: Node
    b: Node
    evidence: float
    since: int
    source: str = ""


@dataclass(frozen=True)
class Conflict:
    """A link rejected because it would give one meta-target two targets of ``camera``, or
    targets in ``camera`` and in camera ``apart``, which does not overlap it.

    rejected: the link;  holder: the target of ``camera`` already in the meta-target (kept)
    apart:    "" for two targets of ``camera``, else the camera that does not overlap it
    """

    rejected: Edge
    camera: str
    holder: Node
    apart: str = ""


@dataclass(frozen=True)
class MetaState:
    """Consistent labels across frames. Frozen; steps return a new state.

    of_target:  present (camera, label) -> meta
    since:      present (camera, label) -> frame it got its current meta
    last_seen:  live meta -> last frame one of its targets was present
    last_feet:  live meta -> camera -> last feet [x, y] px seen there (for cueing)
    next_meta:  the next new meta id (ids start at 1, never reused)
    last_height: live meta -> camera -> height px of its target there when last seen
    walked_out: live meta -> cameras where its target, when last seen, touched the left, right
                or bottom border (not the top: a far person cut by it has its feet in view)
    born:       live meta -> frame it was made
    seen_in:    live meta -> camera -> last frame one of its targets was present there
    """

    of_target: Mapping[Node, int] = field(default_factory=dict)
    since: Mapping[Node, int] = field(default_factory=dict)
    last_seen: Mapping[int, int] = field(default_factory=dict)
    last_feet: Mapping[int, Mapping[str, tuple[float, float]]] = field(default_factory=dict)
    next_meta: int = 1
    last_height: Mapping[int, Mapping[str, float]] = field(default_factory=dict)
    walked_out: Mapping[int, frozenset[str]] = field(default_factory=dict)
    born: Mapping[int, int] = field(default_factory=dict)
    seen_in: Mapping[int, Mapping[str, int]] = field(default_factory=dict)


@dataclass(frozen=True)
class MetaInputs:
    """One frame: every camera's targets and the links of every pair.

    apart:    the cameras that do not overlap (:func:`cameras_apart`); empty: every pair does
    """

    cameras: Mapping[str, CameraTargets]
    edges: Sequence[Edge]
    frame: int
    apart: Collection[frozenset[str]] = frozenset()


@dataclass(frozen=True, eq=False)
class MetaResult:
    """Every intermediate of one meta step.

    metas:      camera -> (N,) int64 meta of each target (that camera's ``labels`` order)
    members:    meta -> its present targets, sorted
    accepted:   links that joined targets, strongest first;  conflicts: links rejected
    created:    metas new this frame;  merged: (absorbed meta, surviving meta)
    resumed:    (meta, camera, label): a new unlinked target took back a target-less live meta
                by its last position in that camera (``reattach_heights``), or a young one
                gave way to it (``handover_frames``)
    split:      (meta, new meta) when a meta-target came apart and one part got a new label
    ended:      metas timed out this frame;  live: metas alive after this frame (some may
                have no target now: not seen anywhere for less than the timeout)
    last_feet:  live meta -> camera -> last feet [x, y] px
    """

    frame: int
    metas: Mapping[str, np.ndarray]
    members: Mapping[int, tuple[Node, ...]]
    accepted: tuple[Edge, ...]
    conflicts: tuple[Conflict, ...]
    created: tuple[int, ...]
    merged: tuple[tuple[int, int], ...]
    resumed: tuple[tuple[int, str, int], ...]
    split: tuple[tuple[int, int], ...]
    ended: tuple[int, ...]
    live: tuple[int, ...]
    last_feet: Mapping[int, Mapping[str, tuple[float, float]]]


def meta_init() -> MetaState:
    """No targets, no metas; the first meta is 1."""
    return MetaState()


class _Components:
    """Union-find over nodes that keeps, per root, the camera -> node map (one per camera).

    ``apart``: cameras that do not overlap (:func:`cameras_apart`), so never share a component.
    """

    def __init__(self, nodes: Sequence[Node], apart: Collection[frozenset[str]] = ()) -> None:
        self.parent = {n: n for n in nodes}
        self.cams: dict[Node, dict[str, Node]] = {n: {n[0]: n} for n in nodes}
        self.apart = frozenset(apart)

    def find(self, n: Node) -> Node:
        while self.parent[n] != n:
            self.parent[n] = self.parent[self.parent[n]]
            n = self.parent[n]
        return n

    def join(self, edge: Edge) -> Conflict | None:
        """Union the edge's components unless that puts two targets of a camera together."""
        ra, rb = self.find(edge.a), self.find(edge.b)
        if ra == rb:
            return None
        clash = sorted(set(self.cams[ra]) & set(self.cams[rb]))
        if clash:
            cam = clash[0]
            holder = self.cams[ra][cam] if self.cams[ra][cam] not in (edge.a, edge.b) else (
                self.cams[rb][cam])
            return Conflict(edge, cam, holder)
        apart = sorted((x, y) for x in self.cams[ra] for y in self.cams[rb]
                       if frozenset((x, y)) in self.apart)
        if apart:  # the holder: the one of the two that is not an end of the link
            x, y = apart[0]
            if self.cams[ra][x] not in (edge.a, edge.b):
                return Conflict(edge, x, self.cams[ra][x], y)
            return Conflict(edge, y, self.cams[rb][y], x)
        self.parent[rb] = ra
        self.cams[ra].update(self.cams.pop(rb))
        return None

    def groups(self) -> list[tuple[Node, ...]]:
        out: dict[Node, list[Node]] = {}
        for n in self.parent:
            out.setdefault(self.find(n), []).append(n)
        return [tuple(sorted(g)) for g in out.values()]


def cameras_apart(cameras: Collection[str],
                  overlaps: Collection[tuple[str, str]] | None) -> frozenset[frozenset[str]]:
    """Every two of ``cameras`` that do not overlap (none when ``overlaps`` is None: every
    pair does). One person is never seen in both at once."""
    if overlaps is None:
        return frozenset()
    near = {frozenset(p) for p in overlaps}
    return frozenset(frozenset(p) for p in combinations(sorted(set(cameras)), 2)
                     if frozenset(p) not in near)


def _link(nodes: Sequence[Node], edges: Sequence[Edge],
          apart: Collection[frozenset[str]] = ()) -> tuple[
        list[tuple[Node, ...]], list[Edge], list[Conflict]]:
    """Components of the strongest consistent subset of ``edges`` (greedy, strongest first)."""
    present = set(nodes)
    comps = _Components(nodes, apart)
    accepted, conflicts = [], []
    order = sorted(edges, key=lambda e: (-e.evidence, e.since, e.a, e.b))
    for edge in order:
        if edge.a not in present or edge.b not in present:
            continue
        conflict = comps.join(edge)
        if conflict is None:
            accepted.append(edge)
        else:
            conflicts.append(conflict)
    return comps.groups(), accepted, conflicts


def _claims(state: MetaState, groups: list[tuple[Node, ...]],
            frame: int) -> list[tuple[int, int, int, int]]:
    """(group index, old meta, -members holding it, earliest since) for every candidate."""
    out = []
    for g, members in enumerate(groups):
        held: dict[int, list[int]] = {}
        for n in members:
            if n in state.of_target:
                held.setdefault(state.of_target[n], []).append(state.since.get(n, frame))
        out += [(g, m, -len(s), min(s)) for m, s in held.items()]
    return out


def _resume(state: MetaState, groups: list[tuple[Node, ...]], ids: list[int], taken: set[int],
            where: Mapping[Node, tuple[float, float, float]],
            cfg: MetaConfig) -> list[tuple[int, str, int]]:
    """Groups of new targets only take back live metas left with no target at all, when a
    member's feet are within ``reattach_heights`` of that meta's last feet in its camera and
    that meta did not walk out of that camera's view (nearest first, one-to-one). Fills
    ``ids`` and ``taken``; returns (meta, camera, label)."""
    if cfg.reattach_heights <= 0:
        return []
    free = [m for m in state.last_seen if m not in taken]
    options = [option for g, members in enumerate(groups)
               if not ids[g] and not any(n in state.of_target for n in members)
               for option in _near_last_feet(state, g, members, free, where, cfg)]
    return _take(options, ids, taken)


def _take(options: list[tuple[float, int, int, Node]], ids: list[int], taken: set[int]
          ) -> list[tuple[int, str, int]]:
    """Give each group its nearest option's meta ((distance, g, meta, member), nearest first,
    one-to-one), releasing the meta it had (0: none). Fills ``ids`` and ``taken``; returns
    (meta, camera, label) of those given."""
    given, done = [], set()
    for _, g, m, n in sorted(options):
        if g not in done and m not in taken:
            done.add(g)
            taken.discard(ids[g])
            ids[g] = m
            taken.add(m)
            given.append((m, n[0], n[1]))
    return given


def _near_last_feet(state: MetaState, g: int, members: Sequence[Node], metas: Sequence[int],
                    where: Mapping[Node, tuple[float, float, float]], cfg: MetaConfig
                    ) -> list[tuple[float, int, int, Node]]:
    """(distance in heights, g, meta, member) for each of ``metas`` whose last feet in a
    member's camera are within ``reattach_heights`` of it there, and that did not walk out
    of that camera's view."""
    options = []
    for n in members:
        x, y, h = where[n]
        for m in metas:
            last = state.last_feet.get(m, {}).get(n[0])
            h_last = state.last_height.get(m, {}).get(n[0])
            if last is None or h_last is None or n[0] in state.walked_out.get(m, ()):
                continue
            d = float(np.hypot(x - last[0], y - last[1])) / max(h, h_last, 1.0)
            if d <= cfg.reattach_heights:
                options.append((d, g, m, n))
    return options


def _handover(  # noqa: PLR0913, PLR0917 (as _resume, and the frame)
    state: MetaState, groups: list[tuple[Node, ...]], ids: list[int], taken: set[int],
    where: Mapping[Node, tuple[float, float, float]], frame: int, cfg: MetaConfig,
) -> list[tuple[int, str, int]]:
    """A lone target (no links) whose meta was made at most ``handover_frames`` ago takes a
    live meta that still had a target in its camera then and has none anywhere now, if that
    target's last feet are near it (:func:`_near_last_feet`): one person split in one
    camera, and the piece the old meta's target followed is gone (nearest first,
    one-to-one). Not a meta last seen in this camera before the young one was made ('doors'
    seed 6: a newcomer in cam1 took the meta of a person seen there 100 frames before, whose
    cam0 target had just left). Changes ``ids`` and ``taken`` (the young meta is then merged
    into the old one); returns (meta, camera, label)."""
    if cfg.handover_frames <= 0 or cfg.reattach_heights <= 0:
        return []
    options = []
    for g, members in enumerate(groups):
        born = state.born.get(ids[g])
        if len(members) != 1 or born is None or frame - born > cfg.handover_frames:
            continue
        camera = members[0][0]
        gone = [m for m in state.last_seen
                if m not in taken and state.seen_in.get(m, {}).get(camera, -1) >= born]
        options += _near_last_feet(state, g, members, gone, where, cfg)
    return _take(options, ids, taken)


def _name(state: MetaState, groups: list[tuple[Node, ...]], frame: int,
          where: Mapping[Node, tuple[float, float, float]], cfg: MetaConfig) -> tuple[
        list[int], int, list[int], list[tuple[int, int]], list[tuple[int, int]],
        list[tuple[int, str, int]]]:
    """A meta per group: kept from the previous frame where possible, else resumed, else new."""
    claims = sorted(_claims(state, groups, frame), key=lambda c: (c[2], c[3], c[1]))
    ids = [0] * len(groups)
    taken: set[int] = set()
    for g, meta, _, _ in claims:
        if not ids[g] and meta not in taken:
            ids[g] = meta
            taken.add(meta)
    resumed = _resume(state, groups, ids, taken, where, cfg)
    resumed += _handover(state, groups, ids, taken, where, frame, cfg)
    next_meta, created = state.next_meta, []
    for g in range(len(groups)):
        if not ids[g]:
            ids[g], next_meta = next_meta, next_meta + 1
            created.append(ids[g])
    merged: set[tuple[int, int]] = set()
    split: set[tuple[int, int]] = set()
    for g, meta, _, _ in claims:  # an old meta not kept by this group: split off or absorbed
        if ids[g] != meta:
            (split if meta in taken else merged).add((meta, ids[g]))
    return ids, next_meta, created, sorted(merged), sorted(split), resumed


def _feet_of(cameras: Mapping[str, CameraTargets]) -> dict[Node, tuple[float, float, float]]:
    """(camera, label) -> (feet x, feet y, height) px of every present target."""
    return {
        (name, int(label)): (float(t.feet[i, 0]), float(t.feet[i, 1]), float(t.heights_px[i]))
        for name, t in cameras.items()
        for i, label in enumerate(t.labels.tolist())
    }


def _at_exit_border(cameras: Mapping[str, CameraTargets]) -> set[Node]:
    """Present targets whose box is on the left, right or bottom border (:func:`~mvtrack.
    stages.targets.on_exit_border`)."""
    return {
        (name, int(label))
        for name, t in cameras.items()
        for label, out in zip(t.labels.tolist(), on_exit_border(t.boxes_xywh, t.size).tolist(),
                              strict=True)
        if out
    }


def meta_step(state: MetaState, inputs: MetaInputs,
              cfg: MetaConfig) -> tuple[MetaState, MetaResult]:
    """Join this frame's targets into meta-targets and name them (module docstring)."""
    frame = inputs.frame
    feet = _feet_of(inputs.cameras)
    groups, accepted, conflicts = _link(list(feet), inputs.edges, inputs.apart)
    ids, next_meta, created, merged, split, resumed = _name(state, groups, frame, feet, cfg)
    of_target = {n: ids[g] for g, members in enumerate(groups) for n in members}
    since = {n: state.since.get(n, frame) if state.of_target.get(n) == m else frame
             for n, m in of_target.items()}
    last_seen = {m: s for m, s in state.last_seen.items() if frame - s <= cfg.meta_timeout_frames}
    last_feet = {m: dict(state.last_feet.get(m, {})) for m in last_seen}
    last_height = {m: dict(state.last_height.get(m, {})) for m in last_seen}
    walked_out = {m: set(state.walked_out.get(m, ())) for m in last_seen}
    born = {m: f for m, f in state.born.items() if m in last_seen} | dict.fromkeys(created, frame)
    seen_in = {m: dict(state.seen_in.get(m, {})) for m in last_seen}
    at_border = _at_exit_border(inputs.cameras)
    for n, m in of_target.items():
        last_seen[m] = frame
        last_feet.setdefault(m, {})[n[0]] = feet[n][:2]
        last_height.setdefault(m, {})[n[0]] = feet[n][2]
        seen_in.setdefault(m, {})[n[0]] = frame
        out = walked_out.setdefault(m, set())
        if n in at_border:
            out.add(n[0])
        else:
            out.discard(n[0])
    absorbed = {m for m, _ in merged}
    for m in absorbed - set(ids):
        last_seen.pop(m, None)
        last_feet.pop(m, None)
        last_height.pop(m, None)
        walked_out.pop(m, None)
        born.pop(m, None)
        seen_in.pop(m, None)
    ended = sorted(set(state.last_seen) - set(last_seen) - absorbed)
    metas = {
        name: np.array([of_target[(name, int(label))] for label in t.labels.tolist()], np.int64)
        for name, t in inputs.cameras.items()
    }
    frozen_feet = {m: dict(v) for m, v in last_feet.items()}
    new_state = MetaState(of_target, since, last_seen, frozen_feet, next_meta,
                          {m: dict(v) for m, v in last_height.items()},
                          {m: frozenset(v) for m, v in walked_out.items() if v}, born,
                          seen_in)
    result = MetaResult(
        frame=frame,
        metas=metas,
        members={ids[g]: members for g, members in enumerate(groups)},
        accepted=tuple(accepted),
        conflicts=tuple(conflicts),
        created=tuple(created),
        merged=tuple(merged),
        resumed=tuple(resumed),
        split=tuple(split),
        ended=tuple(ended),
        live=tuple(sorted(last_seen)),
        last_feet=frozen_feet,
    )
    return new_state, result
