"""Homography-based association of one pair: costs, confirm, refine, create, re-attach, unseen."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mvtrack.params import MatcherConfig
from mvtrack.stages.fov import FovEvent
from mvtrack.stages.homography import HomographyEstimate, HomographyFailure
from mvtrack.stages.matcher import (
    MatchInputs,
    MatchState,
    match_init,
    match_step,
    transfer_costs,
)
from mvtrack.stages.targets import CameraTargets

SHIFT = np.array([[1.0, 0.0, 100.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # x_b = x_a + (100, 0)
H_OK = HomographyEstimate(SHIFT, "dlt", 10, np.ones(10, bool), np.zeros(10), 0.0)
NO_H = HomographyFailure("no markers yet")
CFG = MatcherConfig()


def targets(labels: list[int], feet: list[tuple[float, float]], height: float = 50.0,
            size: tuple[int, int] = (400, 300)) -> CameraTargets:
    f = np.asarray(feet, np.float64).reshape(-1, 2)
    boxes = np.column_stack([f[:, 0] - 10, f[:, 1] - height, np.full(len(f), 20.0),
                             np.full(len(f), height)]) if len(f) else np.zeros((0, 4))
    return CameraTargets(np.asarray(labels, np.int64), f, np.full(len(f), height), boxes, size)


def run(frames: list[tuple[CameraTargets, CameraTargets]], cfg: MatcherConfig = CFG,
        h: HomographyEstimate | HomographyFailure = H_OK,
        assoc: dict[int, list[tuple[int, int]]] | None = None, state: MatchState | None = None):
    state = state or match_init(("A", "B"))
    results = []
    for k, (a, b) in enumerate(frames):
        state, r = match_step(state, MatchInputs(a, b, h, (assoc or {}).get(k, []), k), cfg)
        results.append(r)
    return state, results


def test_transfer_costs_hand_computed() -> None:
    a = targets([1, 2], [(10, 100), (50, 200)])
    b = targets([7], [(120, 100)])
    cost, a_in_b, b_in_a = transfer_costs(SHIFT, a, b)
    assert a_in_b == pytest.approx(np.array([[110, 100], [150, 200]]))
    assert b_in_a == pytest.approx(np.array([[20, 100]]))
    # 10 px error each way, 50 px heights: (10/50 + 10/50) / 2
    assert cost[0, 0] == pytest.approx(0.2)
    assert cost[1, 0] == pytest.approx(np.hypot(30, 100) / 50)


def test_transfer_costs_use_each_side_height() -> None:
    a = targets([1], [(10, 100)], height=100.0)
    b = targets([2], [(120, 100)], height=20.0)
    cost, _, _ = transfer_costs(SHIFT, a, b)
    assert cost[0, 0] == pytest.approx(0.5 * (10 / 20 + 10 / 100))


@pytest.mark.parametrize(("na", "nb"), [(0, 0), (0, 2), (3, 0)])
def test_transfer_costs_empty(na: int, nb: int) -> None:
    a = targets(list(range(1, na + 1)), [(10.0 * i, 50.0) for i in range(na)])
    b = targets(list(range(1, nb + 1)), [(10.0 * i, 50.0) for i in range(nb)])
    cost, a_in_b, b_in_a = transfer_costs(SHIFT, a, b)
    assert cost.shape == (na, nb) and a_in_b.shape == (na, 2) and b_in_a.shape == (nb, 2)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 300), st.floats(0, 200)), min_size=1, max_size=5),
       st.floats(-0.3, 0.3), st.floats(0.7, 1.5), st.floats(-1e-3, 1e-3))
def test_transfer_costs_zero_on_exact_correspondences(pts: list, rot: float, scale: float,
                                                      persp: float) -> None:
    c, s = np.cos(rot) * scale, np.sin(rot) * scale
    H = np.array([[c, -s, 20.0], [s, c, -10.0], [persp, 0.0, 1.0]])
    xa = np.asarray(pts, np.float64)
    w = xa @ H[2, :2] + H[2, 2]
    xb = (xa @ H[:2, :2].T + H[:2, 2]) / w[:, None]
    a = targets(list(range(1, len(xa) + 1)), xa.tolist())
    b = targets(list(range(1, len(xb) + 1)), xb.tolist())
    cost, _, _ = transfer_costs(H, a, b)
    assert np.all(cost >= 0)
    assert np.diag(cost) == pytest.approx(np.zeros(len(xa)), abs=1e-6)
    back, _, _ = transfer_costs(np.linalg.inv(H), b, a)
    assert back == pytest.approx(cost.T, rel=1e-6, abs=1e-9)


def test_create_after_confirm_frames_exactly() -> None:
    frames = [(targets([1, 2], [(10, 100), (60, 200)]),
               targets([5, 6], [(161, 201), (111, 99)]))] * CFG.confirm_frames
    state, results = run(frames)
    for r in results[:-1]:
        assert r.created == () and r.links == ()
    assert sorted(p[:3] for p in results[-2].pending) == [
        (1, 6, CFG.confirm_frames - 1), (2, 5, CFG.confirm_frames - 1)]
    assert sorted((a, b) for a, b, _ in results[-1].created) == [(1, 6), (2, 5)]
    assert {link.source for link in state.links} == {"create"}


def test_create_gated_and_interrupted() -> None:
    far = (targets([1], [(10, 100)]), targets([5], [(140, 100)]))  # 30 px = 0.6 heights
    near = (targets([1], [(10, 100)]), targets([5], [(111, 100)]))
    _, results = run([far] * 10)
    assert all(r.created == () and r.pending == () for r in results)
    # an interruption restarts the count
    seq = [near] * (CFG.confirm_frames - 1) + [far] + [near] * (CFG.confirm_frames - 1)
    _, results = run(seq)
    assert all(r.created == () for r in results)


def test_no_homography_no_create_and_fov_mode() -> None:
    near = (targets([1], [(10, 100)]), targets([5], [(111, 100)]))
    _, results = run([near] * 10, h=NO_H)
    assert all(r.links == () and not r.used_homography for r in results)
    _, results = run([near] * 10, cfg=replace(CFG, method="fov"))
    assert all(r.links == () and not r.used_homography for r in results)
    assert results[0].cost.shape == (1, 1)  # costs still shown for the viewer


def test_fov_association_contradicted_by_h_is_rejected() -> None:
    a = targets([1, 2], [(10, 100), (60, 200)])
    b = targets([5, 6], [(110, 100), (160, 200)])
    _, results = run([(a, b)], assoc={0: [(1, 6)]})
    assert results[0].fov_added == () and results[0].fov_rejected[0][:2] == (1, 6)
    _, results = run([(a, b)], assoc={0: [(1, 5)]})
    assert results[0].fov_added == ((1, 5),) and results[0].links[0].source == "fov"


def test_swapped_link_broken_after_exactly_n_frames_then_recreated() -> None:
    a = targets([1, 2], [(10, 100), (60, 200)])
    right = targets([5, 6], [(110, 100), (160, 200)])
    swapped = targets([5, 6], [(160, 200), (110, 100)])  # B's labels swap people
    n = CFG.break_after_frames
    frames = [(a, right)] * 3 + [(a, swapped)] * (n + CFG.confirm_frames)
    state, results = run(frames, assoc={0: [(1, 5), (2, 6)]})
    assert results[2].pairs() == ((1, 5), (2, 6))
    for k in range(3, 3 + n - 1):
        assert [x[3] for x in results[k].inconsistent] == [k - 2, k - 2]
        assert results[k].broken == ()
    assert sorted(x[:2] for x in results[3 + n - 1].broken) == [(1, 5), (2, 6)]
    assert sorted(link.pair for link in state.links) == [(1, 6), (2, 5)]
    assert {link.source for link in state.links} == {"create"}


def test_fov_mode_keeps_fov_links_whatever_h_says() -> None:
    a = targets([1], [(10, 100)])
    b = targets([5], [(300, 250)])
    _state, results = run([(a, b)] * 30, cfg=replace(CFG, method="fov"), assoc={0: [(1, 5)]})
    assert results[-1].pairs() == ((1, 5),) and results[-1].broken == ()


def test_fov_mode_takes_fov_events_only() -> None:
    """The Khan & Shah baseline links on FOV events, not on the co-motion bootstrap."""
    a, b = targets([1, 2], [(10, 100), (10, 200)]), targets([5, 6], [(300, 250), (300, 50)])
    events = [(1, 5, FovEvent(0, "B", 5, "left", "enter")),
              (2, 6, FovEvent(0, "B", 6, "none", "comotion"))]
    for method, linked in (("fov", ((1, 5),)), ("homography", ((1, 5), (2, 6)))):
        _state, results = run([(a, b)], cfg=replace(CFG, method=method),
                              h=HomographyFailure("none yet", 0, 0), assoc={0: events})
        assert results[0].pairs() == linked, method


def test_comotion_association_replaces_an_fov_link_of_its_targets() -> None:
    """Before H exists, a wrong FOV link (1, 6) from one event gives way to the co-motion
    bootstrap's (1, 5), many frames of evidence; links that did not come from an FOV event
    stay. Generated 'three' with 8 people at a time, seed 0: cam0-cam2 consistency 0.41 ->
    0.60 (the FOV link had kept the right pair from the matcher and fed wrong markers)."""
    a = targets([1, 2], [(10, 100), (60, 200)])
    b = targets([5, 6, 7], [(110, 100), (160, 200), (300, 50)])
    fov_event = FovEvent(0, "B", 6, "right", "enter")
    comotion = FovEvent(1, "B", 5, "none", "comotion")
    _state, results = run([(a, b)] * 2, h=NO_H,
                          assoc={0: [(1, 6, fov_event)], 1: [(1, 5, comotion)]})
    assert results[0].pairs() == ((1, 6),)
    assert results[1].pairs() == ((1, 5),)
    assert results[1].links[0].source == "comotion"
    _state, results = run([(a, b)] * 2, h=NO_H,
                          assoc={0: [(1, 6, fov_event)], 1: [(1, 5, fov_event)]})
    assert results[1].pairs() == ((1, 6),)  # one FOV event does not undo another


def test_confirmations_count_evidence() -> None:
    a, b = targets([1], [(10, 100)]), targets([5], [(111, 100)])
    state, results = run([(a, b)] * 7, assoc={0: [(1, 5)]})
    assert state.links[0].confirmations == 7
    assert [r.confirmed[0][:2] for r in results] == [(1, 5)] * 7


def test_reattach_after_partner_lost() -> None:
    a = targets([1, 2], [(10, 100), (60, 200)])
    both = targets([5, 6], [(110, 100), (160, 200)])
    only6 = targets([6], [(160, 200)])
    back = targets([9, 6], [(112, 101), (160, 200)])  # B lost 5, then a new target 9
    frames = [(a, both)] * 6 + [(a, only6)] * 20 + [(a, back)]
    state, results = run(frames)
    assert results[5].pairs() == ((1, 5), (2, 6))
    assert results[6].lost == ((0, 1),)
    assert state.lost_a == {} and results[-1].reattached[0][:2] == (1, 9)
    assert (1, 9) in results[-1].pairs()


def test_no_reattach_after_window() -> None:
    cfg = replace(CFG, reattach_window_frames=5, confirm_frames=50)
    a = targets([1], [(10, 100)])
    frames = ([(a, targets([5], [(110, 100)]))] * 60 + [(a, targets([], []))] * 10
              + [(a, targets([9], [(110, 100)]))])
    _, results = run(frames, cfg=cfg)
    assert results[59].pairs() == ((1, 5),)
    assert results[-1].reattached == () and results[-1].links == ()


def test_unseen_inside_only() -> None:
    a = targets([1, 2, 3], [(10, 100), (290, 100), (60, 200)])  # 2 projects to x=390: outside
    b = targets([6], [(160, 200)], size=(300, 300))
    _, results = run([(a, b)] * 6)
    assert results[-1].unseen_in_b == (1,)
    assert results[-1].unseen_in_a == ()


def test_inputs_not_mutated() -> None:
    a, b = targets([1], [(10, 100)]), targets([5], [(111, 100)])
    feet = a.feet.copy()
    state, _ = run([(a, b)] * 3)
    snapshot = dict(state.pending)
    match_step(state, MatchInputs(a, b, H_OK, (), 3), CFG)
    assert np.array_equal(a.feet, feet) and dict(state.pending) == snapshot


def test_link_kept_on_noisy_feet_below_keep_threshold_broken_above() -> None:
    a = targets([1], [(10, 100)])
    good = targets([5], [(110, 100)])
    noisy = targets([5], [(110, 135)])  # 35 px off, 50 px heights: d = 0.7 (match 0.4, keep 1.0)
    far = targets([5], [(110, 160)])  # d = 1.2 > keep
    n = CFG.break_after_frames
    _, results = run([(a, good)] + [(a, noisy)] * (2 * n), assoc={0: [(1, 5)]})
    assert results[-1].pairs() == ((1, 5),)
    assert results[-1].confirmed[0][2] == pytest.approx(0.7)
    _, results = run([(a, good)] + [(a, far)] * n, assoc={0: [(1, 5)]})
    assert [x[:2] for x in results[-1].broken] == [(1, 5)] and results[-1].pairs() == ()


def test_noisy_pair_is_not_created_above_match_threshold() -> None:
    a = targets([1], [(10, 100)])
    noisy = targets([5], [(110, 135)])  # d = 0.7: keeps a link, never makes one
    _, results = run([(a, noisy)] * (3 * CFG.confirm_frames))
    assert results[-1].pairs() == () and results[-1].pending == ()


def test_ambiguous_create_waits_until_one_candidate_is_clearly_nearer() -> None:
    a = targets([1], [(10, 100)])
    tie = targets([5, 6], [(110, 105), (110, 95)])  # both 5 px off: d = 0.1 each
    clear = targets([5, 6], [(110, 102), (110, 130)])  # 6 now 0.6 off: 0.5 above 5's 0.04
    _, results = run([(a, tie)] * (2 * CFG.confirm_frames))
    assert results[-1].pairs() == () and results[-1].pending == ()
    _, results = run([(a, clear)] * CFG.confirm_frames)
    assert results[-1].pairs() == ((1, 5),)


def test_keep_threshold_below_match_threshold_is_rejected() -> None:
    with pytest.raises(ValueError, match="keep_threshold_heights"):
        MatcherConfig(match_threshold_heights=0.5, keep_threshold_heights=0.4)


def test_a_wrong_fov_link_from_before_h_breaks_when_h_arrives() -> None:
    """Two people left A together; the FOV association linked A 1 with the wrong B target (6).
    When H arrives, H shows 1 belongs with the unlinked 5 and 2 with 6: the never-confirmed
    link breaks at once (not after break_after_frames), and the pairs are created."""
    a = targets([1, 2], [(10, 100), (60, 200)])
    b = targets([5, 6], [(110, 100), (160, 200)])
    state, before = run([(a, b)] * 3, h=NO_H, assoc={0: [(1, 6)]})
    assert before[-1].pairs() == ((1, 6),)
    state, after = run([(a, b)] * (CFG.confirm_frames + 1), state=state)
    assert after[0].broken[0][:2] == (1, 6) and after[0].pairs() == ()
    assert set(after[-1].pairs()) == {(1, 5), (2, 6)}
    # A link H has confirmed keeps the slower rule: a frame in which its B target's feet jump
    # away while a fresh fragment lies where they should be does not break it.
    a2 = targets([2], [(60, 200)])
    good = targets([6], [(160, 200)])
    glitch = targets([6, 7], [(160, 300), (162, 200)])
    _, r = run([(a2, good), (a2, glitch)], assoc={0: [(2, 6)]})
    assert r[1].inconsistent[0][:2] == (2, 6) and r[1].pairs() == ((2, 6),) and not r[1].broken
