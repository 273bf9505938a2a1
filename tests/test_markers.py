"""Marker dropping: the three tests, motion, and the bounded grid store."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from mvtrack.params import MarkerConfig
from mvtrack.stages.homography import solve_homography, transfer_errors
from mvtrack.stages.markers import (
    Candidates,
    Comotion,
    Marker,
    _draw_samples,
    _PairIndex,
    candidates_add,
    comotion_confirm,
    comotion_draws,
    comotion_of_run,
    comotion_search,
    marker_points,
    marker_step,
    markers_add,
    markers_init,
    not_shrunk,
)
from mvtrack.stages.targets import CameraTargets

SIZE = (320, 240)
CFG = MarkerConfig(marker_every_frames=1, height_window_frames=5, marker_min_move_px=5.0)


def _one(label: int, foot: tuple[float, float], height: float = 40.0) -> CameraTargets:
    x, y = foot
    return CameraTargets(
        np.array([label], np.int64),
        np.array([[x, y]]),
        np.array([height]),
        np.array([[x - 8, y - height, 16, height]]),
        SIZE,
    )


def test_a_walking_linked_pair_drops_markers_and_a_still_one_does_not() -> None:
    state = markers_init(SIZE)
    dropped = []
    for f in range(10):
        state, res = marker_step(
            state, [(1, 2)], _one(1, (50 + 25 * f, 120)), _one(2, (200, 100 + 6 * f)), CFG, f
        )
        dropped.append(len(res.dropped))
    assert dropped == [1] * 10
    for f in range(10, 14):  # standing still: test (c) fails
        state, res = marker_step(state, [(1, 2)], _one(1, (275, 120)), _one(2, (200, 154)), CFG, f)
        assert res.dropped == () and res.rejected == ((1, 2, "no motion"),)
    pts_a, pts_b = marker_points(state)
    assert pts_a.shape == pts_b.shape == (10, 2)
    assert np.allclose(pts_b[:, 0], 200)


def test_only_one_camera_moving_is_enough() -> None:
    state = markers_init(SIZE)
    for f in range(4):
        state, res = marker_step(
            state, [(1, 2)], _one(1, (100, 120)), _one(2, (100 + 20 * f, 150)), CFG, f
        )
        assert len(res.dropped) == 1


def test_partly_outside_targets_give_no_marker() -> None:
    state = markers_init(SIZE)
    state, res = marker_step(state, [(1, 2)], _one(1, (5, 120)), _one(2, (100, 150)), CFG, 0)
    assert res.dropped == () and res.rejected == ((1, 2, "outside"),)
    state, res = marker_step(state, [(1, 2)], _one(1, (100, 239.4)), _one(2, (100, 150)), CFG, 1)
    assert res.rejected == ((1, 2, "outside"),)


def test_height_jump_gives_no_marker() -> None:
    state = markers_init(SIZE)
    for f in range(5):
        state, _ = marker_step(state, [], _one(1, (100, 120)), _one(2, (100, 150)), CFG, f)
    state, res = marker_step(
        state, [(1, 2)], _one(1, (130, 120), 28.0), _one(2, (100, 150)), CFG, 5
    )
    assert res.rejected == ((1, 2, "height"),)
    state, res = marker_step(
        state, [(1, 2)], _one(1, (130, 120), 38.0), _one(2, (100, 150)), CFG, 6
    )
    assert len(res.dropped) == 1  # within 15 % of the median 40


def test_markers_only_every_n_frames_and_only_for_present_links() -> None:
    cfg = MarkerConfig(marker_every_frames=5)
    state = markers_init(SIZE)
    tried = []
    for f in range(12):
        state, res = marker_step(
            state, [(1, 2), (9, 9)], _one(1, (50 + 10 * f, 120)), _one(2, (100, 150)), cfg, f
        )
        tried.append(res.tried)
        assert all(m.a_label == 1 for m in res.dropped)
    assert tried == [f % 5 == 0 for f in range(12)]
    assert state.n_dropped == 3


def test_store_is_bounded_one_marker_per_cell_newest_wins() -> None:
    cfg = MarkerConfig(marker_every_frames=1, marker_min_move_px=0.0, grid_cols=4, grid_rows=3)
    state = markers_init(SIZE)
    rng = np.random.default_rng(0)
    for f in range(300):
        xa = tuple(rng.uniform(20, 300, 1).tolist() + rng.uniform(60, 230, 1).tolist())
        state, res = marker_step(state, [(1, 2)], _one(1, xa), _one(2, (100, 150)), cfg, f)
    assert state.n_dropped == 300
    assert len(state.cells) <= 12 and len(res.markers) == len(state.cells)
    # every stored marker is the newest of the markers that fell in its cell
    assert max(m.frame for m in res.markers) == 299


def test_no_input_is_modified() -> None:
    a, b = _one(1, (100, 120)), _one(2, (100, 150))
    before = (a.feet.copy(), b.feet.copy())
    state = markers_init(SIZE)
    new, _ = marker_step(state, [(1, 2)], a, b, CFG, 0)
    assert state.cells == {} and state.heights_a == {} and len(new.cells) == 1
    assert np.array_equal(a.feet, before[0]) and np.array_equal(b.feet, before[1])


def _walk(labels_a, labels_b, feet_a, shift=(200.0, 10.0)):
    """A and B targets of one frame; B sees A's feet translated by ``shift`` when paired."""
    fa = np.asarray(feet_a, float)
    boxes = np.c_[fa - [5, 30], np.full((len(fa), 2), [10, 30])]
    a = CameraTargets(np.asarray(labels_a, np.int64), fa, np.full(len(fa), 30.0), boxes,
                      (640, 480))
    fb = fa + shift
    b = CameraTargets(np.asarray(labels_b, np.int64), fb, np.full(len(fb), 30.0),
                      boxes + [*shift, 0, 0], (640, 480))
    return a, b


def _walking(n_people: int, frames: int = 100
             ) -> list[tuple[int, CameraTargets, CameraTargets]]:
    """(frame, A, B) of ``n_people`` walking on distinct straight paths, all seen by both."""
    rng = np.random.default_rng(3)
    starts = rng.uniform([100, 100], [300, 300], (n_people, 2))
    vel = rng.uniform(-1.0, 1.0, (n_people, 2))
    return [(f, *_walk(np.arange(n_people) + 1, np.arange(n_people) + 101, starts + f * vel))
            for f in range(frames)]


def _pool(n_people: int, frames: int = 100) -> Candidates:
    """The candidates of :func:`_walking` (every marker frame)."""
    cfg = MarkerConfig()
    pool = Candidates.empty()
    for f, a, b in _walking(n_people, frames):
        pool = candidates_add(pool, a, b, cfg, f)
    return pool


def test_a_target_much_shorter_than_its_recent_heights_is_told() -> None:
    """The co-motion pool leaves such targets out: a blob that lost its legs has its feet
    too high, so its candidates would fit no H."""
    cfg = MarkerConfig(height_window_frames=5)
    state = markers_init(SIZE)
    for f in range(4):
        state, _ = marker_step(state, [], _one(1, (100, 120)), _one(2, (100, 150)), cfg, f)
    two = CameraTargets(np.array([1, 7], np.int64), np.array([[100.0, 120], [200, 120]]),
                        np.array([30.0, 60.0]), np.array([[92.0, 90, 16, 30], [192, 60, 16, 60]]),
                        SIZE)
    # 1 is 25 % below its median 40; 7 is new (its only height is its median)
    assert not_shrunk(state.heights_a, two, cfg).tolist() == [False, True]
    assert not_shrunk(state.heights_a, _one(1, (100, 120), 35.0), cfg).tolist() == [True]
    assert not_shrunk(state.heights_a, _one(1, (100, 120), 60.0), cfg).tolist() == [True]
    assert not_shrunk(state.heights_b, _one(2, (100, 150), 33.0), cfg).tolist() == [False]
    assert two.subset(not_shrunk(state.heights_a, two, cfg)).labels.tolist() == [7]


def _fit(pa, pb):
    return solve_homography(pa, pb)


def test_comotion_finds_the_pairs_that_move_together() -> None:
    pool = _pool(4)
    assert len(pool) == 20 * 16  # every marker frame, every A x B pair
    found = comotion_search(pool, MarkerConfig(), _fit, transfer_errors, np.random.default_rng(0))
    assert found is not None
    assert found.links == ((1, 101), (2, 102), (3, 103), (4, 104))
    assert np.allclose(found.H_b_from_a / found.H_b_from_a[2, 2],
                       [[1, 0, 200], [0, 1, 10], [0, 0, 1]], atol=1e-6)
    assert len(found.markers) == 80 and all(m.b_label == m.a_label + 100 for m in found.markers)


def test_comotion_of_a_whole_run_pools_every_candidate_but_those_of_shrunk_targets() -> None:
    """After the run (a pair without H): the pool is not bounded (comotion_pool_size 20 here,
    of 80 candidates) and, as in the bootstrap, A's target 1 is left out while it is a third
    shorter than the median of its last 10 heights: 20 px from frame 40 on, it is left out at
    marker frame 40; at 45 its median is 20 px too."""
    run = []
    for f, a, b in _walking(4):
        shrunk = CameraTargets(a.labels, a.feet, np.r_[20.0, a.heights_px[1:]], a.boxes_xywh,
                               a.size)
        run.append((f, shrunk if 40 <= f < 50 else a, b))
    found = comotion_of_run(run, MarkerConfig(comotion_pool_size=20), seed=0)
    assert found is not None and found.links == ((1, 101), (2, 102), (3, 103), (4, 104))
    per_pair = Counter((m.a_label, m.b_label) for m in found.markers)
    assert per_pair == {(1, 101): 19, (2, 102): 20, (3, 103): 20, (4, 104): 20}
    assert comotion_of_run([(f, a.subset(a.labels < 3), b.subset(b.labels < 103))
                            for f, a, b in run], MarkerConfig(), seed=0) is None


def test_comotion_of_a_whole_run_can_pool_targets_cut_by_the_top_border() -> None:
    """A's target 3 walks along the top border, its box cut by it (feet in view): with
    ``top_cut`` its pair is pooled and the three true pairs are found; without, two remain,
    too few for a hypothesis."""
    run = []
    for f, a, b in _walking(3):
        boxes = a.boxes_xywh.copy()
        boxes[2, 1], boxes[2, 3] = 0.0, boxes[2, 1] + boxes[2, 3]  # from the top row down
        run.append((f, CameraTargets(a.labels, a.feet, a.heights_px, boxes, a.size), b))
    assert comotion_of_run(run, MarkerConfig(), seed=0) is None
    found = comotion_of_run(run, MarkerConfig(), seed=0, top_cut=True)
    assert found is not None and found.links == ((1, 101), (2, 102), (3, 103))


def test_comotion_needs_enough_distinct_pairs() -> None:
    cfg = MarkerConfig()
    pool = _pool(2)  # two walks: any H could follow them, so no hypothesis is accepted
    assert comotion_search(pool, cfg, _fit, transfer_errors, np.random.default_rng(0)) is None
    assert comotion_search(Candidates.empty(), cfg, _fit, transfer_errors,
                           np.random.default_rng(0)) is None


def _before(pool: Candidates, frame: int) -> Candidates:
    keep = pool.frame < frame
    return Candidates(pool.frame[keep], pool.labels[keep], pool.x_a[keep], pool.x_b[keep],
                      pool.heights[keep])


def test_comotion_confirm_holds_a_hypothesis_to_later_candidates() -> None:
    cfg = MarkerConfig()
    pool = _pool(4)
    found = comotion_search(_before(pool, 50), cfg, _fit, transfer_errors,
                            np.random.default_rng(0))
    assert found is not None and found.since == 45 and len(found.markers) == 40
    assert comotion_confirm(_before(pool, 50), found, cfg, _fit, transfer_errors, 49) == (
        "waiting", found)
    verdict, confirmed = comotion_confirm(pool, found, cfg, _fit, transfer_errors, 95)
    assert verdict == "confirmed" and confirmed is not None
    assert confirmed.links == found.links and confirmed.since == 95
    assert len(confirmed.markers) == 80  # the held-out candidates join the hypothesis's own
    # A wrong H (30 px off) that its pairs followed by chance until frame 45: rejected, since
    # its own pairs' later candidates are all clear misses (gate max(4, 0.3 * 30) = 9 px,
    # refuted beyond 2.5 gates).
    wrong = Comotion(np.array([[1.0, 0, 230], [0, 1, 10], [0, 0, 1]]), ((1, 101), (2, 102)), (),
                     45)
    assert comotion_confirm(pool, wrong, cfg, _fit, transfer_errors, 95) == ("rejected", None)
    # 15 px off: outliers, but near enough for a loose early fit; it is not confirmed either.
    loose = Comotion(np.array([[1.0, 0, 215], [0, 1, 10], [0, 0, 1]]), ((1, 101), (2, 102)), (),
                     45)
    assert comotion_confirm(pool, loose, cfg, _fit, transfer_errors, 95) == ("waiting", loose)
    tight = MarkerConfig(comotion_refute_gates=1.0)
    assert comotion_confirm(pool, loose, tight, _fit, transfer_errors, 95) == ("rejected", None)
    # With no own evidence and no confirmation, it waits comotion_confirm_frames after it was
    # found (whether or not new candidates came), then is "unrefuted": accepted as it was
    # (verification judges it from there), or dropped when so configured.
    stale = Comotion(wrong.H_b_from_a, ((7, 107),), (), 0)
    assert cfg.comotion_confirm_frames == 50
    assert comotion_confirm(pool, stale, cfg, _fit, transfer_errors, 50)[0] == "waiting"
    assert comotion_confirm(pool, stale, cfg, _fit, transfer_errors, 51) == ("unrefuted", stale)
    longer = MarkerConfig(comotion_confirm_frames=100)
    assert comotion_confirm(pool, stale, longer, _fit, transfer_errors, 95)[0] == "waiting"
    strict = MarkerConfig(comotion_confirm_frames=50, comotion_accept_unrefuted=False)
    assert comotion_confirm(pool, stale, strict, _fit, transfer_errors, 95) == ("rejected", None)
    off = MarkerConfig(comotion_confirm_pairs=0)
    assert comotion_confirm(pool, wrong, off, _fit, transfer_errors, 95) == ("confirmed", wrong)


def test_comotion_confirm_refits_a_loose_hypothesis_with_a_newcomer() -> None:
    """A hypothesis fitted to a few early paths can extrapolate 15 px off (gates 9 px): later
    candidates of its own pairs and of a newcomer all miss it, but not clearly. Refitted to
    its markers and the newcomer's new candidates it explains every pair: confirmed, with the
    refit. A newcomer that no homography of that pairing explains confirms nothing."""
    cfg = MarkerConfig()
    pool = _pool(4)
    early = [Marker(int(f), int(la), int(lb), tuple(xa), tuple(xb), 30.0, 30.0)
             for f, (la, lb), xa, xb in zip(pool.frame, pool.labels, pool.x_a, pool.x_b,
                                            strict=True)
             if f < 50 and la <= 3 and lb == la + 100]
    three = ((1, 101), (2, 102), (3, 103))
    loose = Comotion(np.array([[1.0, 0, 215], [0, 1, 10], [0, 0, 1]]), three, tuple(early), 45)
    verdict, refit = comotion_confirm(pool, loose, cfg, _fit, transfer_errors, 95)
    assert verdict == "confirmed" and refit is not None
    assert refit.links == (*three, (4, 104)) and refit.since == 95
    assert np.allclose(refit.H_b_from_a / refit.H_b_from_a[2, 2],
                       [[1, 0, 200], [0, 1, 10], [0, 0, 1]], atol=1e-6)
    # The newcomer's later feet in B 40 px off its path: no refit keeps all four pairs.
    off = (pool.labels[:, 1] == 104) & (pool.frame > 45)
    astray = Candidates(pool.frame, pool.labels, pool.x_a, pool.x_b + off[:, None] * [0, 40],
                        pool.heights)
    assert comotion_confirm(astray, loose, cfg, _fit, transfer_errors, 95) == ("waiting", loose)


def test_markers_add_keeps_one_per_cell() -> None:
    state = markers_init((320, 240))
    ms = [Marker(f, 1, 2, (100.0 + f * 0.1, 100.0), (5.0, 5.0)) for f in range(3)]
    out = markers_add(state, ms, MarkerConfig())
    assert len(out.cells) == 1 and out.n_dropped == 3
    assert next(iter(out.cells.values())).frame == 2 and state.cells == {}


# --- The batched co-motion search gives the answer of the one-sample-at-a-time reference ----
# The reference is comotion_search as it was before batching (commit 44f4747), verbatim but
# for its samples: it takes the production draws (_draw_samples, vectorized since), so that
# what is compared is the batched evaluation of the same samples.


def _ref_one_to_one(pairs, n_in, ok):
    chosen: list[tuple[int, int]] = []
    for k in np.flatnonzero(ok)[np.argsort(-n_in[ok], kind="stable")]:
        pa, pb = int(pairs[k, 0]), int(pairs[k, 1])
        if all(pa != x and pb != y for x, y in chosen):
            chosen.append((pa, pb))
    return chosen


def _ref_support(pool, H, cfg, errors):
    pairs, inverse = np.unique(pool.labels, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    n_all = np.bincount(inverse, np.ones(len(pool), bool), len(pairs))
    inlier = errors(H, pool.x_a, pool.x_b) < pool.gates_px(cfg)
    n_in = np.bincount(inverse, inlier, len(pairs))
    ok = (n_in >= cfg.comotion_min_support) & (n_in >= cfg.comotion_min_frac * n_all)
    if ok.sum() < 1:
        return [], inlier & False
    chosen = _ref_one_to_one(pairs, n_in, ok)
    keep = np.isin(inverse, [k for k in range(len(pairs))
                             if (int(pairs[k, 0]), int(pairs[k, 1])) in chosen])
    return chosen, inlier & keep


def _ref_search(pool, cfg, fit, errors, rng):
    if len(pool) < 4:
        return None
    best = None
    for sample in _draw_samples(_PairIndex.of_pool(pool), cfg, rng):
        H = fit(pool.x_a[sample], pool.x_b[sample])
        if H is None:
            continue
        chosen, rows = _ref_support(pool, H, cfg, errors)
        if len(chosen) >= cfg.comotion_min_pairs and (best is None or rows.sum() > best[0]):
            best = (int(rows.sum()), rows)
    if best is None:
        return None
    H = fit(pool.x_a[best[1]], pool.x_b[best[1]])
    if H is None:
        return None
    chosen, rows = _ref_support(pool, H, cfg, errors)
    if len(chosen) < cfg.comotion_min_pairs:
        return None
    markers = tuple(
        Marker(int(f), int(la), int(lb), (float(xa[0]), float(xa[1])),
               (float(xb[0]), float(xb[1])), float(h[0]), float(h[1]))
        for f, (la, lb), xa, xb, h in zip(pool.frame[rows], pool.labels[rows], pool.x_a[rows],
                                          pool.x_b[rows], pool.heights[rows], strict=True))
    return Comotion(H, tuple(sorted(chosen)), markers, int(pool.frame.max()))


def _scene_pool(kind: str, seed: int) -> Candidates:
    """Every A x B pair of present targets on marker frames; B sees A's feet through a
    ground-like H (plus 0.5 px noise), so only the true pairs follow one homography.

    kind: "walks" (people on independent straight paths, some seen by one camera only),
    "alike" (people side by side with one velocity), "line" (everyone on one line in A: all
    samples degenerate), "few" (two people, two frames: a tiny pool), "sparse" (people
    present in few frames: pairs with one or two candidates), "crowd" (16 people, about half
    of them also in B: over a hundred target pairs, few of them true)."""
    rng = np.random.default_rng(seed)
    H = np.array([[0.9, 0.1, 40.0], [-0.05, 1.1, 20.0], [2e-4, 1e-4, 1.0]])
    n, frames, p_present = {"walks": (6, 20, 0.9), "alike": (4, 20, 1.0), "line": (4, 15, 1.0),
                            "few": (2, 2, 1.0), "sparse": (5, 20, 0.3),
                            "crowd": (16, 12, 1.0)}[kind]
    start = rng.uniform([60, 60], [260, 200], (n, 2))
    vel = rng.uniform(-3, 3, (n, 2))
    if kind == "alike":
        start[:, 1] = start[0, 1] + 12.0 * np.arange(n)
        vel[:] = vel[0]
    if kind == "line":
        start[:, 1], vel[:, 1] = 150.0, 0.0
    only_a = rng.random(n) < {"walks": 0.3, "crowd": 0.45}.get(kind, 0.0)
    height = rng.uniform(30, 70, n)
    parts = []
    for f in range(frames):
        feet_a = start + f * vel
        homog = np.c_[feet_a, np.ones(n)] @ H.T
        feet_b = homog[:, :2] / homog[:, 2:] + rng.normal(0, 0.5, (n, 2))
        in_a = np.flatnonzero(rng.random(n) < p_present)
        in_b = np.flatnonzero((rng.random(n) < p_present) & ~only_a)
        ga, gb = (g.ravel() for g in np.meshgrid(in_a, in_b, indexing="ij"))
        parts.append((np.full(len(ga), 5 * f), np.c_[ga + 1, gb + 101], feet_a[ga], feet_b[gb],
                      np.c_[height[ga], height[gb] * 1.1]))
    return Candidates(*(np.concatenate([p[k] for p in parts]) for k in range(5)))


def _same(found: Comotion | None, ref: Comotion | None) -> bool:
    if found is None or ref is None:
        return found is None and ref is None
    return (found.links == ref.links and found.markers == ref.markers
            and found.since == ref.since and np.allclose(found.H_b_from_a, ref.H_b_from_a,
                                                         rtol=1e-9, atol=1e-12))


@pytest.mark.parametrize("kind", ["walks", "alike", "line", "few", "sparse"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_batched_comotion_search_matches_the_reference(kind: str, seed: int) -> None:
    cfg = MarkerConfig(comotion_iterations=300)
    pool = _scene_pool(kind, seed)
    rng, ref_rng = np.random.default_rng(seed), np.random.default_rng(seed)
    found = comotion_search(pool, cfg, solve_homography, transfer_errors, rng)
    ref = _ref_search(pool, cfg, solve_homography, transfer_errors, ref_rng)
    assert _same(found, ref)
    assert rng.bit_generator.state == ref_rng.bit_generator.state  # the same draws
    # Any other fit is called one sample at a time: the same answer again.
    each = comotion_search(pool, cfg, _fit, transfer_errors, np.random.default_rng(seed))
    assert _same(each, ref)
    if kind == "walks":  # enough people on spread paths: the true pairs are found
        assert ref is not None and all(b == a + 100 for a, b in ref.links)
    if kind == "line":  # every sample is collinear in A
        assert ref is None


def test_comotion_search_draws_more_in_a_crowd() -> None:
    """Among ~140 target pairs with ~9 true ones, a sample of two true pairs is rare: a fixed
    150 draws mostly miss it, draws scaled to the pair combinations find the true pairs."""
    fixed = MarkerConfig(comotion_iterations=150, comotion_draws_per_combination=0.0)
    scaled = MarkerConfig(comotion_iterations=150)

    def right(found: Comotion | None) -> bool:  # the true pairing (a crowd adds a stray link)
        return found is not None and sum(b == a + 100 for a, b in found.links) >= max(
            3, 0.8 * len(found.links))

    hits = {"fixed": 0, "scaled": 0}
    for seed in range(5):
        pool = _scene_pool("crowd", seed)
        assert len(np.unique(pool.labels, axis=0)) > 100
        for name, cfg in (("fixed", fixed), ("scaled", scaled)):
            found = comotion_search(pool, cfg, solve_homography, transfer_errors,
                                    np.random.default_rng(seed))
            hits[name] += right(found)
    assert hits["scaled"] == 5
    assert hits["fixed"] <= 2
    assert comotion_draws(scaled, 140) == math.ceil(0.5 * 140 * 139 / 2)
    assert comotion_draws(scaled, 40) == 390  # 0.5 x 780 combinations
    assert comotion_draws(scaled, 10) == 150  # few pairs: comotion_iterations


def test_comotion_draws_are_two_candidates_of_two_pairs_sharing_no_label() -> None:
    """Every sample holds two distinct candidates of each of two label pairs that share no
    label, and the draws reach every eligible pair about equally often."""
    pool = _scene_pool("walks", 4)
    index = _PairIndex.of_pool(pool)
    cfg = MarkerConfig(comotion_iterations=20000)
    samples = _draw_samples(index, cfg, np.random.default_rng(0))
    assert 10000 < len(samples) <= 20000
    labels = pool.labels[samples]  # (S, 4, 2)
    assert (labels[:, 0] == labels[:, 1]).all() and (labels[:, 2] == labels[:, 3]).all()
    assert (samples[:, 0] != samples[:, 1]).all() and (samples[:, 2] != samples[:, 3]).all()
    assert (labels[:, 0] != labels[:, 2]).all(axis=1).all()
    eligible = index.n >= cfg.comotion_min_support
    drawn = np.bincount(index.of[samples[:, [0, 2]]].ravel(), minlength=len(index.pairs))
    assert (drawn[~eligible] == 0).all()
    share = drawn[eligible] / drawn[eligible].mean()
    assert 0.8 < share.min() and share.max() < 1.2, share
    assert len(_draw_samples(index, MarkerConfig(comotion_min_support=100000),
                             np.random.default_rng(0))) == 0


def test_batched_comotion_search_matches_on_tiny_and_looser_settings() -> None:
    pool = _scene_pool("walks", 7)
    for cfg in (MarkerConfig(comotion_iterations=200, comotion_min_support=1,
                             comotion_min_frac=0.0, comotion_min_pairs=2),
                MarkerConfig(comotion_iterations=200, comotion_threshold_heights=0.0,
                             comotion_threshold_px=1.5)):
        found = comotion_search(pool, cfg, solve_homography, transfer_errors,
                                np.random.default_rng(3))
        assert _same(found, _ref_search(pool, cfg, solve_homography, transfer_errors,
                                        np.random.default_rng(3)))
    for n in range(6):
        tiny = Candidates(*(x[:n] for x in (pool.frame, pool.labels, pool.x_a, pool.x_b,
                                              pool.heights)))
        assert comotion_search(tiny, MarkerConfig(), solve_homography, transfer_errors,
                               np.random.default_rng(0)) is None
