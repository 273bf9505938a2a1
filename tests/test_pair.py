"""The pair step on a synthetic two-camera ground-plane scene with known geometry.

Two pinhole cameras look at a ground plane; walkers cross it on straight paths. Feet are the
projections of their ground points (plus noise, and 3 % mis-segmented frames whose feet and
height are wrong); boxes are the images of 0.5 x 0.5 x h m cuboids clipped to the frame. The
true H_b_from_a is the composition of the two cameras' ground homographies.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace

import numpy as np
import pytest

from mvtrack.evaluate.pairs import EVAL_SIDES, fov_segment, line_error_px
from mvtrack.params import load_params
from mvtrack.stages.homography import HomographyEstimate, apply_homography
from mvtrack.stages.markers import Comotion, Marker, markers_add, markers_init
from mvtrack.stages.pair import PairConfigs, PairState, pair_init, pair_step, pair_summary
from mvtrack.stages.targets import CameraTargets


@dataclass(frozen=True)
class Cam:
    P: np.ndarray  # (3,4)
    size: tuple[int, int]

    @property
    def H_img_from_ground(self) -> np.ndarray:
        return self.P[:, [0, 1, 3]]


def look_at(pos, target, f, size, roll_deg=0.0) -> Cam:
    pos, target = np.asarray(pos, float), np.asarray(target, float)
    z = target - pos
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    r = np.deg2rad(roll_deg)
    x, y = np.cos(r) * x + np.sin(r) * y, -np.sin(r) * x + np.cos(r) * y
    R = np.stack([x, y, z])
    K = np.array([[f, 0, (size[0] - 1) / 2], [0, f, (size[1] - 1) / 2], [0, 0, 1]])
    return Cam(K @ np.c_[R, -R @ pos], size)


def project(cam: Cam, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    h = np.c_[X, np.ones(len(X))] @ cam.P.T
    return h[:, :2] / h[:, 2:3], h[:, 2]


@dataclass(frozen=True)
class Scenario:
    cams: tuple[Cam, Cam]
    region: tuple[float, float, float, float]  # x0, y0, x1, y1 of the walk area (m)


def walkers(rng, region, n_frames, rate=0.035, speed=(0.1, 0.16)):
    """(n_frames, P, 2) ground positions (nan when absent), heights (P,)."""
    x0, y0, x1, y1 = region

    def edge_point():
        s = rng.integers(4)
        u = rng.random()
        return [
            (x0, y0 + u * (y1 - y0)),
            (x1, y0 + u * (y1 - y0)),
            (x0 + u * (x1 - x0), y0),
            (x0 + u * (x1 - x0), y1),
        ][s], s

    tracks = []
    start = -150
    for f in range(start, n_frames):
        if rng.random() < rate or f == start:
            (p0, s0) = edge_point()
            p1, s1 = edge_point()
            while s1 == s0:
                p1, s1 = edge_point()
            p0, p1 = np.array(p0), np.array(p1)
            v = rng.uniform(*speed)
            n = int(np.linalg.norm(p1 - p0) / v)
            tracks.append((f, p0, p1, n))
    pos = np.full((n_frames, len(tracks), 2), np.nan)
    for j, (f0, p0, p1, n) in enumerate(tracks):
        for k in range(n + 1):
            f = f0 + k
            if 0 <= f < n_frames:
                pos[f, j] = p0 + (p1 - p0) * k / n
    keep = ~np.all(np.isnan(pos[:, :, 0]), axis=0)
    return pos[:, keep], rng.uniform(1.6, 1.9, keep.sum())


def observe(  # noqa: PLR0913, PLR0917
    cam, pos_f, heights, rng, labels_state, next_label, noise_px=0.8, bad_rate=0.0
):
    """CameraTargets of one camera, one frame, and the truth person index of each target."""
    W, H = cam.size
    rows = []
    for j in np.flatnonzero(~np.isnan(pos_f[:, 0])):
        X, Y = pos_f[j]
        h = heights[j]
        corners = np.array(
            [[X + dx, Y + dy, z] for dx in (-0.25, 0.25) for dy in (-0.25, 0.25) for z in (0.0, h)]
        )
        pts, depth = project(cam, corners)
        if np.any(depth <= 0.5):
            continue
        lo, hi = pts.min(0), pts.max(0)
        lo_c, hi_c = np.maximum(lo, [-0.5, -0.5]), np.minimum(hi, [W - 0.5, H - 0.5])
        if np.any(hi_c - lo_c < 2):
            continue
        feet, _ = project(cam, np.array([[X, Y, 0.0]]))
        head, _ = project(cam, np.array([[X, Y, h]]))
        hp = float(np.linalg.norm(head[0] - feet[0]))
        foot = feet[0] + rng.normal(0, noise_px, 2)
        if rng.random() < bad_rate:  # mis-segmented: legs lost
            foot = foot + (head[0] - feet[0]) * 0.3
            hp *= 0.7
        rows.append(
            (
                j,
                foot,
                hp * rng.normal(1, 0.01),
                [lo_c[0], lo_c[1], hi_c[0] - lo_c[0], hi_c[1] - lo_c[1]],
            )
        )
    present = {r[0] for r in rows}
    for j in list(labels_state):
        if j not in present:
            del labels_state[j]
    labels = []
    for r in rows:
        if r[0] not in labels_state:
            labels_state[r[0]] = next_label[0]
            next_label[0] += 1
        labels.append(labels_state[r[0]])
    t = CameraTargets(
        labels=np.array(labels, np.int64),
        feet=np.array([r[1] for r in rows]).reshape(-1, 2),
        heights_px=np.array([r[2] for r in rows]),
        boxes_xywh=np.array([r[3] for r in rows]).reshape(-1, 4),
        size=cam.size,
    )
    return t, np.array([r[0] for r in rows], np.int64)


A = look_at((10, -4, 8), (10, 10, 0), 260, (320, 240))
SCENARIOS = {
    # B looks diagonally across the walk area: its left, right and bottom edges cross it.
    "default": (A, look_at((22, 22, 9), (12, 12, 0), 300, (320, 240)), (-4, 0, 24, 30), 5, 0.04),
    "tilted": (
        A,
        look_at((22, 22, 9), (12, 12, 0), 300, (320, 240), roll_deg=20),
        (-4, 0, 24, 30),
        2,
        0.04,
    ),
    # Walkers stay where only B's bottom edge crosses their area: one observable FOV line.
    "one_edge": (A, look_at((10, 1, 8), (10, 25, 0), 200, (320, 240)), (4, 5, 16, 28), 2, 0.06),
}


@dataclass
class Run:
    name: str
    state: PairState
    first_valid: int | None
    event_points: dict[tuple[str, str], list[np.ndarray]]
    transfer_px: np.ndarray


def _run(name: str, n_frames: int = 600) -> Run:
    cam_a, cam_b, region, seed, rate = SCENARIOS[name]
    rng = np.random.default_rng(seed)
    pos, heights = walkers(rng, region, n_frames, rate=rate)
    state = pair_init(("a", "b"), (cam_a.size, cam_b.size))
    labels_a: dict[int, int] = {}
    labels_b: dict[int, int] = {}
    next_a, next_b = [1], [1]
    first_valid = None
    event_points: dict[tuple[str, str], list[np.ndarray]] = {}
    for f in range(n_frames):
        ta, pa = observe(cam_a, pos[f], heights, rng, labels_a, next_a, bad_rate=0.03)
        tb, pb = observe(cam_b, pos[f], heights, rng, labels_b, next_b, bad_rate=0.03)
        state, res = pair_step(state, ta, tb, PairConfigs(), f)
        if res.homography and first_valid is None:
            first_valid = f
        for ev in res.events:  # truth: where the event's person stood in the other camera
            own, person, other = (ta, pa, cam_b) if ev.camera == "a" else (tb, pb, cam_a)
            j = person[own.index_of(ev.target)]
            x, _ = project(other, np.array([[*pos[f, j], 0.0]]))
            event_points.setdefault(("b" if ev.camera == "a" else "a", ev.side), []).append(x[0])
    ground = pos[~np.isnan(pos[:, :, 0])]
    xa, _ = project(cam_a, np.c_[ground, np.zeros(len(ground))])
    xb, _ = project(cam_b, np.c_[ground, np.zeros(len(ground))])
    seen = np.all((np.c_[xa, xb] > 0) & (np.c_[xa, xb] < [319, 239, 319, 239]), axis=1)
    transfer = np.full(1, np.inf)
    if state.homography:
        H = state.homography.H_b_from_a
        transfer = np.linalg.norm(apply_homography(H, xa[seen]) - xb[seen], axis=1)
    return Run(name, state, first_valid, event_points, transfer)


@pytest.fixture(scope="module", params=list(SCENARIOS))
def run(request: pytest.FixtureRequest) -> Run:
    return _run(request.param)


FIRST_VALID_BEFORE = {"default": 200, "tilted": 150, "one_edge": 150}
"""Issue 4 target (was 300). Measured: 100, 55, 50 (co-motion bootstrap with the held-out
check; before it 200, 65, 25; FOV associations alone: none)."""


def test_a_valid_homography_is_learned_and_accurate(run: Run) -> None:
    assert run.first_valid is not None and run.first_valid < FIRST_VALID_BEFORE[run.name]
    assert np.median(run.transfer_px) <= 3.0
    assert np.percentile(run.transfer_px, 90) <= 8.0
    est = run.state.homography
    assert est and est.quality_px < 3.0 and est.inliers.sum() >= 10


def _line_errors(name: str, state: PairState) -> dict[tuple[str, str], float]:
    """Mean px error of each learned left/right/bottom line against the true border image."""
    cam_a, cam_b = SCENARIOS[name][:2]
    cams = {"a": cam_a, "b": cam_b}
    errors = {}
    for line in pair_summary(state)["fov_lines"]:
        if line["side"] not in EVAL_SIDES:
            continue
        seen, edge = cams[line["seen_in"]], cams[line["edge_of"]]
        seg = fov_segment(
            seen.H_img_from_ground, edge.H_img_from_ground, (seen.size, edge.size), line["side"]
        )
        if seg is not None and np.hypot(*(seg[1] - seg[0])) > 40:
            errors[(line["seen_in"], line["side"])] = line_error_px(seg, line["line"])[0]
    return errors


def test_fov_lines_lie_on_the_true_border_images(run: Run) -> None:
    """Each learned left/right/bottom line (with >= 40 px of its true segment in view) is
    within 5 px mean error of the image of the other camera's border on the ground."""
    errors = _line_errors(run.name, run.state)
    assert errors
    assert max(errors.values()) <= 5.0, errors


def test_one_edge_scene_has_a_single_fov_line() -> None:
    result = _run("one_edge")
    lines = pair_summary(result.state)["fov_lines"]
    assert [(x["seen_in"], x["side"]) for x in lines] == [("a", "bottom")]
    assert result.state.homography


def test_summary_matches_pairs_json_format(run: Run) -> None:
    summary = json.loads(json.dumps(pair_summary(run.state)))
    assert set(summary) == {
        "cameras", "H", "H_from_frame", "markers", "fov_events", "fov_lines", "sizes", "H_first"
    }
    assert summary["sizes"] == [[320, 240], [320, 240]]
    first = summary["H_first"]
    assert first["frame"] == run.first_valid and first["markers"] >= 10
    assert 0 < first["fov_events"] <= summary["fov_events"]
    assert summary["cameras"] == ["a", "b"]
    assert np.array(summary["H"]).shape == (3, 3)
    assert isinstance(summary["H_from_frame"], int) and summary["H_from_frame"] >= run.first_valid
    assert summary["markers"] == len(run.state.markers.cells) > 0
    assert summary["fov_events"] == run.state.n_events > 0
    for line in summary["fov_lines"]:
        assert set(line) == {"seen_in", "edge_of", "side", "line", "events", "from_frame",
                             "source"}
        assert {line["seen_in"], line["edge_of"]} == {"a", "b"}
    assert {line["source"] for line in summary["fov_lines"]} <= {"events", "homography",
                                                                  "crossers"}
    assert any(line["source"] == "homography" for line in summary["fov_lines"])


def test_empty_cameras_and_size_mismatch() -> None:
    state = pair_init(("a", "b"), ((320, 240), (640, 480)))
    state, res = pair_step(
        state, CameraTargets.empty((320, 240)), CameraTargets.empty((640, 480)), PairConfigs(), 0
    )
    assert res.events == () and not res.homography and res.attempt is None
    assert pair_summary(state)["H"] is None and pair_summary(state)["H_from_frame"] is None
    with pytest.raises(ValueError, match="size"):
        pair_step(
            state,
            CameraTargets.empty((320, 240)),
            CameraTargets.empty((320, 240)),
            PairConfigs(),
            1,
        )


def _two_walkers(frame: int) -> tuple[CameraTargets, CameraTargets]:
    """A and B each see two targets inside the frame, moving 3 px per frame."""
    feet = np.array([[60.0 + 3 * frame, 120.0], [200.0, 60.0 + 2 * frame]])
    boxes = np.c_[feet - [10, 60], np.full((2, 2), [20, 60])]
    a = CameraTargets(np.array([1, 2]), feet, np.full(2, 60.0), boxes, (320, 240))
    b = CameraTargets(np.array([7, 8]), feet + 5, np.full(2, 60.0), boxes + [5, 5, 0, 0],
                      (320, 240))
    return a, b


def test_external_links_drive_markers_and_count_as_linked() -> None:
    state = pair_init(("a", "b"), ((320, 240), (320, 240)))
    for f in range(30):
        a, b = _two_walkers(f)
        state, res = pair_step(state, a, b, PairConfigs(), f, links=[(2, 8)])
        assert res.links == ((2, 8),)
        assert all((m.a_label, m.b_label) == (2, 8) for m in res.markers.markers)
    assert len(state.markers.cells) >= 3
    none_state = pair_init(("a", "b"), ((320, 240), (320, 240)))
    for f in range(30):
        a, b = _two_walkers(f)
        none_state, res = pair_step(none_state, a, b, PairConfigs(), f, links=[])
        assert res.links == () and res.markers.dropped == ()
    assert none_state.markers.n_dropped == 0


def _walkers_seen_twice(frame: int, people: list[int]) -> tuple[CameraTargets, CameraTargets]:
    """People ``people`` walking on straight paths; B sees A shifted by (200, 10) px, labels
    of person p: p in A and 100 + p in B."""
    p = np.asarray(people)
    feet = np.c_[100.0 + 30 * p + 0.8 * frame, 150.0 + 20 * p + 0.3 * frame * (p % 3)]
    boxes = np.c_[feet - [5, 30], np.full((len(p), 2), [10, 30])]
    a = CameraTargets(p.astype(np.int64), feet, np.full(len(p), 30.0), boxes, (640, 480))
    b = CameraTargets(p.astype(np.int64) + 100, feet + [200, 10], np.full(len(p), 30.0),
                      boxes + [200, 10, 0, 0], (640, 480))
    return a, b


@pytest.mark.parametrize("people, in_turn, kept",
                         [([9], True, True), ([9, 10], True, False), ([9], False, False)])
def test_one_person_unseen_in_turn_by_each_camera_is_one_miss(people: list[int], in_turn: bool,
                                                             kept: bool) -> None:
    """A correct H; each person is first seen by A only, then by B only (outside the other
    camera's frame where H extrapolates, or behind an occluder: generated 'pillar' seed 5
    lost a 4.6 px H so at frame 591). One person is two missing targets, one per camera, but
    one miss: with ``verify_min_targets`` 2 the H stays for one person and goes for two. Seen
    by both at once but 60 px from where H puts them, one person's two misses count twice."""
    cfg = PairConfigs()
    cfg = replace(cfg, homography=replace(cfg.homography, verify_min_targets=2))
    H = np.array([[1.0, 0, 200.0], [0, 1, 10.0], [0, 0, 1]])
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    state = replace(state, homography=HomographyEstimate(H, "dlt", 10, np.ones(10, bool),
                                                         np.zeros(10), 0.0, 0))
    for f in range(1, 90):
        a, b = _walkers_seen_twice(f, people)
        if not in_turn:
            b = replace(b, feet=b.feet + [60, 0], boxes_xywh=b.boxes_xywh + [60, 0, 0, 0])
        elif f <= 45:
            b = CameraTargets.empty((640, 480))
        else:
            a = CameraTargets.empty((640, 480))
        state, _ = pair_step(state, a, b, cfg, f)
    assert bool(state.homography) == kept


def test_a_held_swap_does_not_block_the_true_pairing() -> None:
    """Two people walking alike first fit a swapped pairing; after they leave, nothing can
    confirm or reject it. People who arrive later follow the true pairing, which a new search
    holds beside the swap and their held-out candidates confirm before the swap would time
    out and be accepted as unrefuted (comotion_confirm_frames after frame 0)."""
    cfg = PairConfigs()
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    swap = Comotion(np.array([[1.0, 0, 230], [0, 1, 0], [0, 0, 1]]), ((1, 102), (2, 101)), (),
                    since=0)
    state = replace(state, hypotheses=(swap,))
    linked_at = None
    for f in range(1, 140):
        a, b = _walkers_seen_twice(f, [4, 5, 6])
        state, res = pair_step(state, a, b, cfg, f)
        made = [(x, y) for x, y, ev in res.associations if ev.kind == "comotion"]
        if made:
            linked_at = f
            assert sorted(made) == [(4, 104), (5, 105), (6, 106)]
            break
        assert len(state.hypotheses) <= 3
    assert linked_at is not None and linked_at <= cfg.markers.comotion_confirm_frames


def test_a_strong_hypothesis_found_as_a_held_swap_times_out_is_taken_over_the_swap() -> None:
    """A swapped pairing held since frame 0 (its people gone) times out unrefuted at the round
    of frame 75, the round in which people who came after it first show a pairing that four
    pairs follow (strong: ``comotion_accept_pairs``, here with 3 inliers each). That search
    wins: accepting the timed-out swap first kept a wrong H online until verification dropped
    it (generated 'pair' seed 0: the swap at frame 125, the true pairing only at 275)."""
    cfg = PairConfigs.from_params(load_params(None, ["markers.comotion_accept_support=3"]))
    assert cfg.markers.comotion_confirm_frames < 75
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    swapped = tuple(Marker(5 * i, a_label, 103 - a_label, (40.0 * i + 20, 30.0 * a_label + 25 * i),
                           (40.0 * i + 250, 30.0 * a_label + 25 * i), 30.0, 30.0)
                    for i in range(6) for a_label in (1, 2))
    swap = Comotion(np.array([[1.0, 0, 230], [0, 1, 0], [0, 0, 1]]), ((1, 102), (2, 101)),
                    swapped, since=0)
    state = replace(state, hypotheses=(swap,))
    made: list[tuple[int, int]] = []
    rounds = {}
    for f in range(1, 76):
        a, b = _walkers_seen_twice(f, [4, 5, 6, 7] if f > 60 else [])
        state, res = pair_step(state, a, b, cfg, f)
        made += [(x, y) for x, y, ev in res.associations if ev.kind == "comotion"]
        if res.bootstrap is not None:
            rounds[f] = res.bootstrap
    assert sorted(made) == [(4, 104), (5, 105), (6, 106), (7, 107)]
    assert state.markers.cells and all(m.a_label >= 4 for m in state.markers.cells.values())
    # the round as the viewer tells it: every A walker with every B walker on marker frames
    # 65, 70 and 75 (16 target pairs, 3 candidates each); the swap timed out, four pairs were
    # found and accepted
    true_links = ((4, 104), (5, 105), (6, 106), (7, 107))
    assert sorted(rounds) == [75]  # fewer than four candidates pooled before (no round)
    r = rounds[75]
    assert (r.candidates, r.target_pairs, r.supported_pairs, r.needed_pairs) == (48, 16, 16, 3)
    assert r.verdicts == ((swap.links, "unrefuted"),)
    assert r.found == true_links and r.accepted == true_links


def test_of_rivals_left_unrefuted_the_best_supported_is_accepted() -> None:
    """Two hypotheses held since frame 0 whose people left (nothing confirms or refutes them):
    once ``comotion_confirm_frames`` passed, the one more candidates followed is accepted and
    its markers enter the store, whichever was found first."""
    cfg = PairConfigs()

    def rival(dx: float, a_label: int, n: int) -> Comotion:
        H = np.array([[1.0, 0, dx], [0, 1, 0], [0, 0, 1]])
        ms = tuple(Marker(5 * i, a_label, a_label + 100, (25.0 * i + 10, 20.0 * i + 10),
                          (25.0 * i + 10 + dx, 20.0 * i + 10), 30.0, 30.0) for i in range(n))
        return Comotion(H, ((a_label, a_label + 100),), ms, since=0)

    weak, strong = rival(300.0, 1, 4), rival(400.0, 2, 12)
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    state = replace(state, hypotheses=(weak, strong))
    every = cfg.markers.comotion_every_frames
    for f in range(1, 2 * every * 3):
        a, b = _walkers_seen_twice(f, [4, 5])  # two walkers: the pool grows, fits neither rival
        state, _ = pair_step(state, a, b, cfg, f)
        if f <= cfg.markers.comotion_confirm_frames:
            assert state.hypotheses == (weak, strong), f
    assert state.hypotheses == ()
    assert sorted(m.a_label for m in state.markers.cells.values()) == [2] * 12


@pytest.mark.parametrize("accept_pairs", [4, 0])
def test_a_hypothesis_four_pairs_follow_needs_no_held_out_check(accept_pairs: int) -> None:
    """Four people walking through both views: the first co-motion search (frame 25, five
    candidates per pair) links them at once when four pairs with five inliers each are enough
    (``comotion_accept_pairs``, ``comotion_accept_support``); with the held-out check for
    every hypothesis (0) the links wait for the next search's new candidates."""
    cfg = PairConfigs.from_params(load_params(None, [
        f"markers.comotion_accept_pairs={accept_pairs}", "markers.comotion_accept_support=5"]))
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    linked_at = None
    for f in range(1, 120):
        a, b = _walkers_seen_twice(f, [4, 5, 6, 7])
        state, res = pair_step(state, a, b, cfg, f)
        made = [(x, y) for x, y, ev in res.associations if ev.kind == "comotion"]
        if made:
            linked_at = f
            assert sorted(made) == [(4, 104), (5, 105), (6, 106), (7, 107)]
            break
    every = cfg.markers.comotion_every_frames
    assert linked_at is not None
    assert linked_at % every == 0 and (linked_at < 2 * every) == (accept_pairs == 4), linked_at


@pytest.mark.parametrize("shift, kept", [((200.0, 10.0), True), ((230.0, 0.0), False)])
def test_a_homography_that_predicts_people_where_there_are_none_is_dropped(
        shift: tuple[float, float], kept: bool) -> None:
    """B sees A shifted by (200, 10). The true H keeps finding a partner for every projected
    target; one 30 px off (a body height here) finds none and is dropped, with its markers,
    once ``verify_min_expected`` projections are pooled; learning then starts over."""
    cfg = PairConfigs()
    H = np.array([[1.0, 0, shift[0]], [0, 1, shift[1]], [0, 0, 1]])
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    state = replace(state, homography=HomographyEstimate(H, "dlt", 10, np.ones(10, bool),
                                                         np.zeros(10), 0.0, 0))
    dropped_at = None
    for f in range(1, 30):
        a, b = _walkers_seen_twice(f, [4, 5, 6])
        state, res = pair_step(state, a, b, cfg, f)
        if not res.homography and dropped_at is None:
            dropped_at = f
            assert res.homography.reason.startswith("dropped: over")
            assert res.attempt is res.homography and len(state.markers.cells) == 0
    if kept:
        assert dropped_at is None and state.homography
        assert sum(f for _, f, _ in state.checks) == sum(e for e, _, _ in state.checks) > 100
    else:
        # 3 targets x 2 directions a frame: 40 projections pooled by the 7th frame
        assert dropped_at == -(-cfg.homography.verify_min_expected // 6)


@pytest.mark.parametrize(("margin", "anywhere", "decoy", "kept"), [
    (0.5, 0.0, False, True), (-1.0, 0.0, False, False),
    (0.5, 0.1, False, False), (0.5, 0.1, True, True), (-1.0, 0.0, True, False)])
def test_h_is_judged_only_near_its_markers(margin: float, anywhere: float, decoy: bool,
                                           kept: bool) -> None:
    """An H 30 px off where people now walk, learned from markers in the far corner of A
    (x 420-600, y 20-120): there it extrapolates, so the misses say where markers are
    lacking and the H is kept; judged everywhere (margin < 0) it is dropped as above. Still,
    an H under which almost nobody anywhere finds a partner (under
    ``verify_anywhere_min_found_frac``) links nobody, so no marker would ever correct it: it
    is dropped, unless some do (a decoy in B where H sends one A walker: 2 of 9 projections
    found, too few for the 0.3 of the rule near markers, enough for 0.1 anywhere)."""
    cfg = PairConfigs()
    cfg = replace(cfg, homography=replace(cfg.homography, verify_hull_margin_heights=margin,
                                          verify_anywhere_min_found_frac=anywhere))
    H = np.array([[1.0, 0, 230.0], [0, 1, 0], [0, 0, 1]])
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    corner = [(x, y) for x in (420.0, 500.0, 600.0) for y in (20.0, 70.0, 120.0)]
    store = markers_add(markers_init((640, 480)), [
        Marker(0, 1, 101, (x, y), (x + 230.0, y), 30.0, 30.0) for x, y in corner], cfg.markers)
    state = replace(state, markers=store, homography=HomographyEstimate(
        H, "dlt", 9, np.ones(9, bool), np.zeros(9), 0.0, 0))
    for f in range(1, 30):
        a, b = _walkers_seen_twice(f, [4, 5, 6, 7])
        if decoy:  # a B target where H puts A's walker 7
            b = CameraTargets(np.r_[b.labels, 999], np.r_[b.feet, a.feet[3:] + [230.0, 0.0]],
                              np.r_[b.heights_px, 30.0], np.r_[b.boxes_xywh, a.boxes_xywh[3:]
                                                                + [230.0, 0, 0, 0]], b.size)
        state, _ = pair_step(state, a, b, cfg, f)
    assert bool(state.homography) == kept
    if kept and not decoy:
        assert sum(e for e, _, _ in state.checks) == 0


def test_after_a_dropped_homography_the_pool_gives_the_true_pairing_at_once() -> None:
    """A wrong H (30 px off) came with wrong links (4-105, 5-104). People 4, 5, 6 walk by
    while it is in use (until frame 16), then only person 7. The co-motion pool kept filling
    while H was in use; verification drops H at frame 7 and refutes its links (they leave the
    pool for good), and the true pairing is found in that pool and confirmed by person 7.
    A pool started afresh at the drop would hold two frames of 4, 5, 6: too little support."""
    cfg = PairConfigs()
    H = np.array([[1.0, 0, 230.0], [0, 1, 0], [0, 0, 1]])
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    state = replace(state, homography=HomographyEstimate(H, "dlt", 10, np.ones(10, bool),
                                                         np.zeros(10), 0.0, 0))
    wrong = [(4, 105), (5, 104)]
    dropped_at = linked_at = None
    for f in range(1, 120):
        a, b = _walkers_seen_twice(f, [4, 5, 6] if f <= 16 else [7])
        state, res = pair_step(state, a, b, cfg, f, links=wrong if dropped_at is None else [])
        if not res.homography and dropped_at is None:
            dropped_at = f
            assert state.refuted == frozenset(wrong)
            assert not {tuple(x) for x in state.candidates.labels.tolist()} & set(wrong)
        made = [(x, y) for x, y, ev in res.associations if ev.kind == "comotion"]
        if made:
            linked_at = f
            assert made == [(7, 107)]
            break
    assert dropped_at == 7 and linked_at is not None and linked_at <= 75, linked_at


@pytest.mark.parametrize("min_targets, kept", [(3, True), (1, False)])
def test_one_target_the_other_camera_never_sees_does_not_drop_h(min_targets: int,
                                                                kept: bool) -> None:
    """A correct H (B sees A shifted by (200, 10)); A's only target stands where B should see
    it, but B never does (a ghost in A, or a person B's front end misses). Every projection
    misses, yet one target is evidence against its own detection, not against H: the H is
    kept unless ``verify_min_targets`` allows a single target to drop it."""
    cfg = PairConfigs()
    cfg = replace(cfg, homography=replace(cfg.homography, verify_min_targets=min_targets))
    H = np.array([[1.0, 0, 200.0], [0, 1, 10.0], [0, 0, 1]])
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    state = replace(state, homography=HomographyEstimate(H, "dlt", 10, np.ones(10, bool),
                                                         np.zeros(10), 0.0, 0))
    a, _ = _walkers_seen_twice(0, [9])
    b = CameraTargets.empty((640, 480))
    for f in range(1, 80):
        state, _ = pair_step(state, a, b, cfg, f)
    assert bool(state.homography) == kept
    if not kept:
        assert "(misses from at least 1 people)" in state.homography.reason


@pytest.mark.parametrize("drop", [True, False])
def test_an_unrefuted_hypothesis_the_search_contradicts_is_not_accepted(drop: bool) -> None:
    """A hypothesis held since frame 0 pairs A's walker 4 with B's target 199, gone since (no
    candidate of its own to refute it), under an H 32 px off the true one (too far for the
    walker's candidates to confirm it). Walkers 5 and 6 join 4 at frame 61; in the round of
    frame 75 the held one has timed out unrefuted and the search finds the true pairing of
    the three, not strong enough to take at once. That search pairs walker 4 with 104: the
    held one is dropped, the search's held, and no marker comes from the held one
    (generated 'pillar' s8 with a front-end change: a hypothesis with one wrong pair of
    three, 217 px p90 off, was accepted at frame 300 in the round whose search had found the
    right one). Without ``comotion_drop_contradicted`` it is accepted there."""
    cfg = PairConfigs.from_params(load_params(
        None, [f"markers.comotion_drop_contradicted={str(drop).lower()}"]))
    state = pair_init(("a", "b"), ((640, 480), (640, 480)))
    held = Comotion(np.array([[1.0, 0, 230], [0, 1, 0], [0, 0, 1]]), ((4, 199),), (), since=0)
    state = replace(state, hypotheses=(held,))
    rounds = {}
    for f in range(1, 76):
        a, b = _walkers_seen_twice(f, [4, 5, 6] if f > 60 else [4])
        state, res = pair_step(state, a, b, cfg, f)
        if res.bootstrap is not None:
            rounds[f] = res.bootstrap
    true_links = ((4, 104), (5, 105), (6, 106))
    assert rounds[75].found == true_links
    if drop:
        assert rounds[75].accepted is None and state.hypotheses[-1].links == true_links
        assert not state.markers.cells
    else:
        assert rounds[75].accepted == held.links
