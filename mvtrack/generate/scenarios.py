"""Scenarios: where the cameras stand, what stands on the ground, who walks where and when.

A scenario is a camera layout (seed-jittered) plus a walker planner. Planners draw paths that
start and end outside every camera's view (people enter and leave across image borders), except
where the scenario says otherwise (doors), and schedule them so people do not walk through each
other (groups excepted: they walk side by side on purpose).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from mvtrack.generate.body import random_appearance
from mvtrack.generate.camera import Camera, CameraSpec, look_at
from mvtrack.generate.world import FPS, Box, Walker, make_path, person_box, visible_in

__all__ = ["SCENARIOS", "Layout", "Planner", "Scenario", "fully_visible", "schedule"]

MIN_SEPARATION_M = 0.8
OBSTACLE_CLEARANCE_M = 0.55
EXTEND_MAX_M = 90.0
EXTEND_STEP_M = 0.4
EDGE_MARGIN_PX = 4.0
TRIES = 25


@dataclass(frozen=True, eq=False)
class Layout:
    """Cameras, static boxes, overlapping pairs, the paved area (x0, y0, x1, y1) and the sun
    (unit vector pointing towards it)."""

    cameras: tuple[Camera, ...]
    boxes: tuple[Box, ...]
    overlaps: tuple[tuple[str, str], ...]
    plaza: tuple[float, float, float, float]
    sun: np.ndarray

    def camera(self, name: str) -> Camera:
        return next(c for c in self.cameras if c.name == name)


@dataclass(frozen=True)
class Member:
    """One walker of a planned group: ``waypoints`` (K, 2); it is at waypoint ``via`` at the
    group's scheduled time; ``free_near`` is a point near which obstacles are ignored (a door)."""

    waypoints: np.ndarray
    via: int
    free_near: tuple[float, float] | None = None


MakeFn = Callable[["Planner", int], list[Member] | None]


@dataclass(frozen=True)
class Scenario:
    """A named scene recipe. ``concurrency`` is the mean number of people in the scene."""

    name: str
    summary: str
    layout: Callable[[np.random.Generator, tuple[int, int]], Layout]
    make: MakeFn
    concurrency: float


class Planner:
    """Accumulates walkers for one clip; owns the generator and the collision bookkeeping."""

    def __init__(self, rng: np.random.Generator, layout: Layout, frames: int) -> None:
        self.rng = rng
        self.layout = layout
        self.frames = np.arange(frames, dtype=float)
        self.walkers: list[Walker] = []
        self._tracks: list[np.ndarray] = []
        x0, y0, x1, y1 = layout.plaza
        gx, gy = np.meshgrid(np.arange(x0 - 8, x1 + 8, 0.5), np.arange(y0 - 8, y1 + 8, 0.5))
        self.grid = np.column_stack([gx.ravel(), gy.ravel()])
        self._full = {c.name: fully_visible(c, self.grid) for c in layout.cameras}
        self._feet = {c.name: _feet_inside(c, self.grid) for c in layout.cameras}

    def seen_fully_by(self, *names: str) -> np.ndarray:
        """(N, 2) grid points where a person is entirely inside every named camera's frame."""
        return self._region(self._full, names)

    def feet_seen_by(self, *names: str) -> np.ndarray:
        """(N, 2) grid points whose ground point is well inside every named camera's frame."""
        return self._region(self._feet, names)

    def _region(self, masks: dict[str, np.ndarray], names: tuple[str, ...]) -> np.ndarray:
        ok = np.logical_and.reduce([masks[n] for n in names])
        for box in self.layout.boxes:
            ok &= box.distance(self.grid) > 1.2
        return self.grid[ok]

    def pick(self, points: np.ndarray) -> np.ndarray:
        """A random row of ``points`` (N, 2)."""
        if len(points) == 0:
            raise RuntimeError("scenario layout leaves no ground region to walk through")
        return points[self.rng.integers(len(points))].copy()

    def extend(self, p: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """The point on the ray from ``p`` along ``direction`` past which no camera sees a
        person, plus a metre."""
        d = direction / np.linalg.norm(direction)
        s = np.arange(0.0, EXTEND_MAX_M, EXTEND_STEP_M)
        pts = p + s[:, None] * d
        seen = np.zeros(len(s), bool)
        for cam in self.layout.cameras:
            seen |= visible_in(cam, pts, margin_px=2.0)
        last = int(np.nonzero(seen)[0].max()) if seen.any() else 0
        return p + (s[last] + 1.0) * d

    def add(self, members: list[Member], t_via_s: float, speed_mps: float) -> bool:
        """Adds a group if no member collides with anyone or any box; returns whether it did."""
        new: list[Walker] = []
        for m in members:
            path, arc = make_path(m.waypoints)
            if not self._clear_of_boxes(path, m.free_near):
                return False
            k = int(np.argmin(np.hypot(*(path - m.waypoints[m.via]).T)))
            t0 = t_via_s - arc[k] / speed_mps
            pid = len(self.walkers) + len(new) + 1
            app = random_appearance(self.rng)
            phase0 = float(self.rng.uniform(0, 2 * math.pi))
            new.append(Walker(pid, app, path, arc, speed_mps, t0, phase0))
        tracks = [w.positions(self.frames) for w in new]
        for tr in tracks:
            for other in self._tracks:
                d = np.hypot(*(tr - other).T)
                if np.any(d[~np.isnan(d)] < MIN_SEPARATION_M):
                    return False
        self.walkers.extend(new)
        self._tracks.extend(tracks)
        return True

    def _clear_of_boxes(self, path: np.ndarray, free_near: tuple[float, float] | None) -> bool:
        pts = path
        if free_near is not None:
            pts = path[np.hypot(*(path - np.asarray(free_near)).T) > 1.2]
        return all(b.distance(pts).min() > OBSTACLE_CLEARANCE_M for b in self.layout.boxes)


def fully_visible(cam: Camera, xy: np.ndarray, margin_px: float = EDGE_MARGIN_PX) -> np.ndarray:
    """(N,) bool: a person at each ground point (N, 2) is entirely inside ``cam``'s frame."""
    box = person_box(cam, xy)
    with np.errstate(invalid="ignore"):
        return (
            (box[:, 0] > margin_px) & (box[:, 1] > margin_px)
            & (box[:, 2] < cam.width - 1 - margin_px) & (box[:, 3] < cam.height - 1 - margin_px)
        )


def _feet_inside(cam: Camera, xy: np.ndarray, frac: float = 0.08) -> np.ndarray:
    uv = cam.ground_to_image(xy)
    depth = cam.to_camera(np.column_stack([xy, np.zeros(len(xy))]))[:, 2]
    mx, my = frac * cam.width, frac * cam.height
    return (depth > 1.0) & (uv[:, 0] > mx) & (uv[:, 0] < cam.width - mx) & (
        uv[:, 1] > my) & (uv[:, 1] < cam.height - my)


def schedule(planner: Planner, scenario: Scenario) -> list[Walker]:
    """Walkers for the whole clip. Walker 0 (a scenario's showcase) passes its via point at
    0.4 s; about ``concurrency / 2`` more passed theirs before the clip began (the scene is
    not empty at frame 0); then arrivals follow at random gaps, scaled by how long people
    stay, so that about ``concurrency`` people are in the scene at once."""
    rng = planner.rng
    stays = [15.0]  # seconds a person spends in the scene (a prior, then the real ones)

    def place(i: int, t: float) -> int:
        speed = float(rng.uniform(1.0, 1.6))
        before = len(planner.walkers)
        for _ in range(TRIES):
            members = scenario.make(planner, i)
            if members and planner.add(members, t, speed):
                break
        added = planner.walkers[before:]
        stays.extend(w.arc[-1] / speed for w in added)
        return max(len(added), 1)

    place(0, 0.4)
    pre_roll = int(scenario.concurrency // 2)
    for k in range(pre_roll):
        place(1 + k, 0.4 - (k + 0.5) * float(rng.uniform(0.5, 1.0)) * 15.0 / scenario.concurrency)
    t, i = 0.4, pre_roll + 1
    while t < len(planner.frames) / FPS + 2.0:
        share = float(np.mean(stays)) / scenario.concurrency
        t += share * float(rng.uniform(0.4, 1.6))
        t += share * (place(i, t) - 1)
        i += 1
    return planner.walkers


# ----------------------------------------------------------------------------- geometry helpers


def _unit(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def _angle(v: np.ndarray) -> float:
    return math.atan2(float(v[1]), float(v[0]))


def _aim(rng: np.random.Generator, spec: CameraSpec, size: tuple[int, int]) -> Camera:
    """The camera ``spec`` with its position and target jittered by a few decimetres."""
    pos = tuple(v + d for v, d in zip(spec.position, rng.uniform(-0.3, 0.3, 3), strict=True))
    tgt = tuple(v + d for v, d in zip(spec.target, rng.uniform(-0.4, 0.4, 2), strict=True))
    return look_at(replace(spec, position=pos, target=tgt), size)


def _sun(rng: np.random.Generator) -> np.ndarray:
    az, el = rng.uniform(0, 2 * math.pi), math.radians(rng.uniform(42, 58))
    return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])


def _pair_layout(
    rng: np.random.Generator, size: tuple[int, int], roll_deg: float = 0.0, modality: str = "rgb"
) -> Layout:
    """Two cameras about 90 degrees apart around a shared patch of ground; each also sees
    ground the other does not. ``roll_deg`` and ``modality`` apply to cam1."""
    cams = (
        _aim(rng, CameraSpec("cam0", (-4.0, 1.5, 6.2), (0.0, 7.5), 0.9), size),
        _aim(rng, CameraSpec("cam1", (6.0, 3.0, 4.5), (0.0, 7.5), 1.1, 0.75, roll_deg, modality),
             size),
    )
    return Layout(cams, (), (("cam0", "cam1"),), (-16.0, -6.0, 16.0, 24.0), _sun(rng))


# ----------------------------------------------------------------------------- walker recipes


def _crossing(pl: Planner, focus: np.ndarray, heading: float | None = None,
              spread: float = math.pi) -> list[Member]:
    """One person crossing the scene through a random point of ``focus``, with one turn."""
    rng = pl.rng
    v = pl.pick(focus)
    a = (heading if heading is not None else 0.0) + rng.uniform(-spread, spread)
    d1 = _unit(a)
    d2 = _unit(a + rng.normal(0.0, 0.45))
    v2 = v + rng.uniform(2.5, 6.0) * d2
    return [Member(np.array([pl.extend(v, -d1), v, v2, pl.extend(v2, d2)]), via=1)]


def _make_pair(pl: Planner, i: int) -> list[Member]:
    return _crossing(pl, pl.feet_seen_by("cam0", "cam1"))


def _make_one_edge(pl: Planner, i: int) -> list[Member] | None:
    """cam1 is entered and left only through its left edge: in, a turn inside, back out.

    Drawn in cam1's image: the entry and exit are on horizontal image lines near the left
    edge, whose ground lines lead out through the left edge only; the turn is further right.
    """
    cam = pl.layout.camera("cam1")
    rng = pl.rng
    w, h = cam.width, cam.height
    y_in, y_turn, y_out = rng.uniform(0.5, 0.85, 3) * h
    if abs(y_in - y_out) < 0.12 * h:
        return None
    x_turn = rng.uniform(0.4, 0.75) * w
    img = np.array([[0.1 * w, y_in], [x_turn, y_turn], [0.1 * w, y_out],
                    [-0.5 * w, y_in], [-0.5 * w, y_out]])
    e, t, x, e_out, x_out = cam.image_to_ground(img)
    way = np.array([pl.extend(e, e_out - e), e, t, x, pl.extend(x, x_out - x)])
    if not _one_edge_ok(cam, way):
        return None
    return [Member(way, via=2)]


def _one_edge_ok(cam: Camera, waypoints: np.ndarray) -> bool:
    """The path shows in ``cam`` once, touching no edge but the left one."""
    path, _ = make_path(waypoints)
    box = person_box(cam, path[::3])
    with np.errstate(invalid="ignore"):
        shown = (box[:, 2] > -0.5) & (box[:, 0] < cam.width - 0.5) & (box[:, 3] > -0.5) & (
            box[:, 1] < cam.height - 0.5
        )
        idx = np.nonzero(shown)[0]
        if len(idx) == 0 or idx[-1] - idx[0] + 1 != len(idx):
            return False
        b = box[idx]
        m = EDGE_MARGIN_PX
        return bool(np.all(b[:, 2] < cam.width - 1 - m) & np.all(b[:, 1] > m)
                    & np.all(b[:, 3] < cam.height - 1 - m))


def _make_pillar(pl: Planner, i: int) -> list[Member]:
    """Every other person walks straight away from (or towards) cam1 right behind the pillar."""
    if i % 2:
        return _make_pair(pl, i)
    pillar = pl.layout.boxes[0]
    centre = np.asarray(pillar.centre)
    u = centre - pl.layout.camera("cam1").centre[:2]
    u /= np.linalg.norm(u)
    p1 = centre + u * (np.hypot(*pillar.size) / 2 + 1.2)
    p2 = p1 + u * pl.rng.uniform(2.5, 3.5)
    turn = pl.rng.choice([-1.0, 1.0]) * pl.rng.uniform(0.9, 1.3)
    d_in, d_out = _unit(_angle(u) + turn), _unit(_angle(u) - turn * 0.6)
    way = np.array([pl.extend(p1, -d_in), p1, p2, pl.extend(p2, d_out)])
    if pl.rng.random() < 0.5:  # towards cam1 instead: the same walk backwards
        return [Member(way[::-1], via=2)]
    return [Member(way, via=1)]


def _make_doors(pl: Planner, i: int) -> list[Member]:
    """Every other person comes out of (or goes into) the booth's door."""
    if i % 2:
        return _make_pair(pl, i)
    booth = pl.layout.boxes[0]
    d0, d1 = booth.door_point(0.35), booth.door_point(1.8)
    out = d1 - d0
    d2 = _unit(_angle(out) + pl.rng.uniform(-1.2, 1.2))
    v2 = d1 + pl.rng.uniform(2.0, 4.0) * d2
    way = np.array([d0, d1, v2, pl.extend(v2, d2)])
    free = (float(d0[0]), float(d0[1]))
    if i > 0 and pl.rng.random() < 0.5:  # into the door (walker 0 always comes out)
        return [Member(way[::-1], via=3, free_near=free)]
    return [Member(way, via=0, free_near=free)]


def _make_crowd(pl: Planner, i: int) -> list[Member]:
    """Singles and groups of 2-3 side by side who either split apart or meet and walk on."""
    rng = pl.rng
    k = int(rng.choice([1, 2, 2, 3]))
    if k == 1:
        return _make_pair(pl, i)
    v = pl.pick(pl.seen_fully_by("cam0", "cam1"))
    a = rng.uniform(-math.pi, math.pi)
    d = _unit(a)
    n = _unit(a + math.pi / 2)
    offsets = (np.arange(k) - (k - 1) / 2) * 0.9
    split = rng.random() < 0.5
    members = []
    for o in offsets:
        turn = math.copysign(rng.uniform(0.6, 1.1), o) if o else rng.normal(0, 0.2)
        vi = v + o * n
        if split:  # together up to v, then apart
            di = _unit(a + turn)
            v2 = vi + 2.5 * di
            way = np.array([pl.extend(v, -d) + o * n, vi, v2, pl.extend(v2, di)])
        else:  # from different sides to v, then together
            di = _unit(a - turn)
            v0 = vi - 2.5 * di
            v2 = v + 4.0 * d
            way = np.array([pl.extend(v0, -di), v0, vi, v2 + o * n, pl.extend(v2, d) + o * n])
        members.append(Member(way, via=1 if split else 2))
    return members


def _make_three(pl: Planner, i: int) -> list[Member]:
    """People walk along the row of views, through cam0|cam2 or cam1|cam2 overlaps."""
    pair = ("cam0", "cam2") if i % 2 == 0 else ("cam1", "cam2")
    focus = pl.seen_fully_by(*pair)
    if len(focus) < 10:
        focus = pl.feet_seen_by(*pair)
    heading = 0.0 if pl.rng.random() < 0.5 else math.pi
    return _crossing(pl, focus, heading, spread=0.35)


# ----------------------------------------------------------------------------- layouts


def _pillar_layout(rng: np.random.Generator, size: tuple[int, int]) -> Layout:
    pair = _pair_layout(rng, size)
    cam1 = pair.camera("cam1")
    # The pillar stands on cam1's line of sight to the middle of the overlap.
    mid = np.array([0.5, 6.5]) + rng.uniform(-0.4, 0.4, 2)
    u = mid - cam1.centre[:2]
    u /= np.linalg.norm(u)
    centre = mid - 2.0 * u
    pillar = Box((float(centre[0]), float(centre[1])), (1.0, 1.0), 4.6,
                 _angle(u) + float(rng.uniform(-0.3, 0.3)), (172.0, 168.0, 160.0), 96.0)
    return Layout(pair.cameras, (pillar,), pair.overlaps, pair.plaza, pair.sun)


def _doors_layout(rng: np.random.Generator, size: tuple[int, int]) -> Layout:
    pair = _pair_layout(rng, size)
    centre = np.array([1.0, 8.5]) + rng.uniform(-0.5, 0.5, 2)
    # The door faces roughly towards cam0, so cam0 sees people step out; cam1 sees its side.
    yaw = _angle(pair.camera("cam0").centre[:2] - centre) + float(rng.uniform(-0.4, 0.1))
    booth = Box((float(centre[0]), float(centre[1])), (1.1, 1.6), 2.5, yaw,
                (150.0, 72.0, 58.0), 100.0, door=True)
    return Layout(pair.cameras, (booth,), pair.overlaps, pair.plaza, pair.sun)


def _one_edge_layout(rng: np.random.Generator, size: tuple[int, int]) -> Layout:
    # cam1 looks away from cam0's area, so its left edge is the only side people can reach.
    cams = (
        _aim(rng, CameraSpec("cam0", (-6.0, -3.0, 6.0), (0.0, 5.0), 0.85), size),
        _aim(rng, CameraSpec("cam1", (2.0, -3.0, 4.5), (6.0, 3.5), 1.0, 0.75), size),
    )
    return Layout(cams, (), (("cam0", "cam1"),), (-16.0, -8.0, 16.0, 20.0), _sun(rng))


def _crowd_layout(rng: np.random.Generator, size: tuple[int, int]) -> Layout:
    cams = (
        _aim(rng, CameraSpec("cam0", (-5.0, -3.0, 7.0), (0.0, 6.0), 0.8), size),
        _aim(rng, CameraSpec("cam1", (8.0, 3.0, 6.0), (0.0, 7.0), 0.95), size),
    )
    return Layout(cams, (), (("cam0", "cam1"),), (-16.0, -10.0, 16.0, 22.0), _sun(rng))


def _three_layout(rng: np.random.Generator, size: tuple[int, int]) -> Layout:
    cams = (
        _aim(rng, CameraSpec("cam0", (-6.5, -3.0, 5.5), (-7.3, 3.1), 1.2), size),
        _aim(rng, CameraSpec("cam1", (6.5, -3.0, 5.5), (7.3, 3.1), 1.15), size),
        _aim(rng, CameraSpec("cam2", (0.0, -7.5, 7.5), (0.0, 1.5), 0.7, 0.75), size),
    )
    overlaps = (("cam0", "cam2"), ("cam1", "cam2"))
    return Layout(cams, (), overlaps, (-24.0, -8.0, 24.0, 16.0), _sun(rng))


SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("pair", "two overlapping cameras, people crossing in all directions",
                 _pair_layout, _make_pair, 4.0),
        Scenario("one_edge", "everyone enters and leaves cam1 through its left edge only",
                 _one_edge_layout, _make_one_edge, 3.0),
        Scenario("pillar", "a tall pillar hides people from cam1 while cam0 still sees them",
                 _pillar_layout, _make_pillar, 4.0),
        Scenario("doors", "people step out of and into a door booth in the middle of the overlap",
                 _doors_layout, _make_doors, 4.0),
        Scenario("tilted", "an overlapping pair whose cam1 is rolled 18 degrees",
                 lambda rng, size: _pair_layout(rng, size, roll_deg=18.0), _make_pair, 4.0),
        Scenario("gray", "an overlapping pair whose cam1 is a gray (thermal) camera",
                 lambda rng, size: _pair_layout(rng, size, modality="gray"), _make_pair, 4.0),
        Scenario("crowd", "about ten people, groups that walk together, meet and split",
                 _crowd_layout, _make_crowd, 10.0),
        Scenario("three", "three cameras: cam0-cam2 and cam1-cam2 overlap, cam0-cam1 do not",
                 _three_layout, _make_three, 4.0),
    )
}
