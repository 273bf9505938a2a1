"""Meta-targets over N cameras: components, stable ids, conflicts, merges, splits, timeouts."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mvtrack.params import MetaConfig
from mvtrack.stages.meta import (
    Edge,
    MetaInputs,
    MetaState,
    cameras_apart,
    meta_init,
    meta_step,
)
from mvtrack.stages.targets import CameraTargets

CFG = MetaConfig()


def cam(*labels: int) -> CameraTargets:
    n = len(labels)
    feet = np.column_stack([np.arange(n) * 10.0 + 5, np.full(n, 50.0)]).reshape(n, 2)
    return CameraTargets(np.asarray(labels, np.int64), feet, np.full(n, 30.0),
                         np.tile([0.0, 0.0, 5.0, 30.0], (n, 1)), (100, 100))


def edge(a: tuple[str, int], b: tuple[str, int], evidence: float = 1.0, since: int = 0) -> Edge:
    return Edge(a, b, evidence, since)


def step(state: MetaState, cameras: dict[str, CameraTargets], edges: list[Edge], frame: int,
         cfg: MetaConfig = CFG):
    return meta_step(state, MetaInputs(cameras, edges, frame), cfg)


def meta_of(result, camera: str, label: int, cameras: dict[str, CameraTargets]) -> int:
    return int(result.metas[camera][cameras[camera].index_of(label)])


def test_every_target_has_its_own_meta_without_links() -> None:
    cams = {"A": cam(1, 2), "B": cam(4)}
    state, r = step(meta_init(), cams, [], 0)
    assert sorted(np.concatenate(list(r.metas.values())).tolist()) == [1, 2, 3]
    assert r.created == (1, 2, 3) and r.conflicts == ()
    state, r2 = step(state, cams, [], 1)
    assert all(np.array_equal(r.metas[c], r2.metas[c]) for c in cams)  # stable
    assert r2.created == ()


def test_chain_through_middle_camera_gives_one_label() -> None:
    cams = {"A": cam(1), "B": cam(7), "C": cam(3)}
    edges = [edge(("A", 1), ("C", 3)), edge(("C", 3), ("B", 7))]
    _, r = step(meta_init(), cams, edges, 0)
    assert {meta_of(r, c, lab, cams) for c, lab in (("A", 1), ("B", 7), ("C", 3))} == {1}
    assert r.members[1] == (("A", 1), ("B", 7), ("C", 3))


def test_conflict_resolved_by_evidence_and_exposed() -> None:
    cams = {"A": cam(1), "B": cam(7, 8), "C": cam(3)}
    strong = [edge(("A", 1), ("C", 3), 10), edge(("C", 3), ("B", 7), 10)]
    weak = edge(("A", 1), ("B", 8), 3)
    _, r = step(meta_init(), cams, [weak, *strong], 0)
    assert len(r.conflicts) == 1
    c = r.conflicts[0]
    assert c.rejected == weak and c.camera == "B" and c.holder == ("B", 7)
    assert meta_of(r, "A", 1, cams) == meta_of(r, "B", 7, cams) != meta_of(r, "B", 8, cams)
    # with the evidence the other way round, the other B target wins
    _, r = step(meta_init(), cams, [replace(weak, evidence=30), *strong], 0)
    assert meta_of(r, "A", 1, cams) == meta_of(r, "B", 8, cams) != meta_of(r, "B", 7, cams)


def test_break_keeps_meta_with_the_longest_holder() -> None:
    cams = {"A": cam(1), "B": cam(5)}
    state, _r0 = step(meta_init(), {"A": cam(1), "B": cam()}, [], 0)  # A1 alone: meta 1
    state, r1 = step(state, cams, [edge(("A", 1), ("B", 5), since=1)], 1)
    assert meta_of(r1, "B", 5, cams) == 1 and r1.created == ()
    state, r2 = step(state, cams, [], 2)  # the link broke
    assert meta_of(r2, "A", 1, cams) == 1
    assert meta_of(r2, "B", 5, cams) == 2 and r2.split == ((1, 2),) and r2.created == (2,)


def test_merge_keeps_the_older_meta_and_reports_it() -> None:
    cams = {"A": cam(1), "B": cam(5)}
    state, _ = step(meta_init(), {"A": cam(1), "B": cam()}, [], 0)  # A1: meta 1
    state, r = step(state, cams, [], 1)  # B5: meta 2
    assert meta_of(r, "B", 5, cams) == 2
    state, r = step(state, cams, [edge(("A", 1), ("B", 5), since=1)], 2)
    assert meta_of(r, "A", 1, cams) == meta_of(r, "B", 5, cams) == 1
    assert r.merged == ((2, 1),)
    assert 2 not in r.live


def test_reattach_keeps_label_through_occlusion() -> None:
    state, _ = step(meta_init(), {"A": cam(1), "B": cam(5)}, [edge(("A", 1), ("B", 5))], 0)
    for k in range(1, 20):  # B loses the person; A still tracks it
        state, r = step(state, {"A": cam(1), "B": cam()}, [], k)
    cams = {"A": cam(1), "B": cam(9)}
    _, r = step(state, cams, [edge(("A", 1), ("B", 9), since=20)], 20)
    assert meta_of(r, "B", 9, cams) == 1


def test_timeout_ends_metas_and_ids_are_never_reused() -> None:
    cfg = replace(CFG, meta_timeout_frames=3)
    state, r = step(meta_init(), {"A": cam(1)}, [], 0, cfg)
    for k in range(1, 4):
        state, r = step(state, {"A": cam()}, [], k, cfg)
        assert r.live == (1,) and r.ended == ()
    state, r = step(state, {"A": cam()}, [], 4, cfg)
    assert r.live == () and r.ended == (1,)
    _, r = step(state, {"A": cam(2)}, [], 5, cfg)
    assert r.metas["A"].tolist() == [2]


def test_last_feet_kept_for_target_less_metas() -> None:
    state, _ = step(meta_init(), {"A": cam(1)}, [], 0)
    _, r = step(state, {"A": cam()}, [], 1)
    assert r.last_feet[1] == {"A": (5.0, 50.0)} and r.members == {}


def test_targets_in_cameras_that_do_not_overlap_never_share_a_meta() -> None:
    # A-C and C-B overlap, A-B do not. A person entering C from A's side gives FOV links in
    # both pairs (B's link is to whoever stood near C's border in B): one person cannot be in
    # A and B at once, so only the stronger link joins; the other is a conflict.
    cams = {"A": cam(1), "B": cam(7), "C": cam(3)}
    from_a, from_b = edge(("A", 1), ("C", 3), 2), edge(("B", 7), ("C", 3), 1)
    overlaps = (("A", "C"), ("B", "C"))
    apart = cameras_apart(cams, overlaps)
    _, r = meta_step(meta_init(), MetaInputs(cams, [from_b, from_a], 0, apart), CFG)
    assert meta_of(r, "A", 1, cams) == meta_of(r, "C", 3, cams) != meta_of(r, "B", 7, cams)
    assert r.accepted == (from_a,)
    assert [(c.rejected, c.camera, c.holder, c.apart) for c in r.conflicts] == [
        (from_b, "A", ("A", 1), "B")]
    # the same links where every pair overlaps (no overlaps given) join all three
    _, r = step(meta_init(), cams, [from_b, from_a], 0)
    assert len({meta_of(r, c, lab, cams) for c, lab in (("A", 1), ("B", 7), ("C", 3))}) == 1
    # and where A and B overlap too
    _, r = meta_step(meta_init(), MetaInputs(cams, [from_b, from_a], 0,
                                             cameras_apart(cams, (*overlaps, ("B", "A")))), CFG)
    assert r.conflicts == () and len(r.members) == 1


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2), st.integers(1, 4), st.integers(0, 2),
                          st.integers(1, 4), st.integers(0, 20)), max_size=12),
       st.integers(1, 4))
def test_properties_random_link_graphs(raw: list, frames: int) -> None:
    names = ("A", "B", "C")
    cams = {n: cam(1, 2, 3, 4) for n in names}
    edges = [edge((names[ca], la), (names[cb], lb), ev) for ca, la, cb, lb, ev in raw if ca != cb]
    state = meta_init()
    seen_ids: set[int] = set()
    for k in range(frames):
        state, r = step(state, cams, edges, k)
        for n in names:  # every target has a meta >= 1
            assert len(r.metas[n]) == 4 and (r.metas[n] >= 1).all()
        for members in r.members.values():  # one target per camera per meta
            assert len({c for c, _ in members}) == len(members)
        for e in r.accepted:  # accepted links join their targets
            assert meta_of(r, *e.a, cams) == meta_of(r, *e.b, cams)
        ids = {int(m) for n in names for m in r.metas[n]}
        assert not (set(r.created) & seen_ids)  # ids are never reused
        seen_ids |= ids
        if k:
            assert r.created == ()  # same input, same labels


def at(label: int, x: float, y: float = 50.0, height: float = 30.0) -> CameraTargets:
    return CameraTargets(np.array([label], np.int64), np.array([[x, y]]), np.array([height]),
                         np.array([[x - 5, y - height, 10.0, height]]), (100, 100))


def test_target_found_again_near_where_its_meta_was_lost_resumes_it() -> None:
    state, r = step(meta_init(), {"A": at(1, 40)}, [], 0)
    state, r = step(state, {"A": cam()}, [], 1)  # the front end lost it: no target anywhere
    state, r = step(state, {"A": at(2, 60)}, [], 3)  # 20 px = 0.67 heights away: resumed
    assert meta_of(r, "A", 2, {"A": at(2, 60)}) == 1
    assert r.resumed == ((1, "A", 2),) and r.created == ()


def test_far_new_target_or_zero_gate_gets_a_new_meta() -> None:
    for where, cfg in ((80.0, CFG), (60.0, replace(CFG, reattach_heights=0.0))):
        state, _ = step(meta_init(), {"A": at(1, 40)}, [], 0, cfg)
        state, r = step(state, {"A": at(2, where)}, [], 1, cfg)  # 40 px = 1.33 heights
        assert r.resumed == () and r.created == (2,)


@pytest.mark.parametrize(("last_x", "last_y", "resumed"), [
    (4.5, 50.0, False),   # last box on the left border: walked out
    (95.5, 50.0, False),  # right border
    (40.0, 99.5, False),  # bottom border
    (10.0, 50.0, True),   # lost inside the frame
    (40.0, 25.5, True),   # cut by the top border only: a far person, feet in view
])
def test_a_meta_that_walked_out_of_the_view_is_not_resumed_there(
        last_x: float, last_y: float, resumed: bool) -> None:
    """one_edge seed 1: a person walked out at the left border and 14 frames later another
    walked in 0.5 heights from there; the newcomer took the leaver's meta (IDF1 0.850)."""
    state, _ = step(meta_init(), {"A": at(1, last_x - 2, last_y)}, [], 0)
    state, _ = step(state, {"A": at(1, last_x, last_y)}, [], 1)
    state, _ = step(state, {"A": cam()}, [], 2)
    new = {"A": at(2, last_x + (8 if last_x < 50 else -8), last_y)}  # 8 px = 0.27 heights
    _, r = step(state, new, [], 10)
    assert (meta_of(r, "A", 2, new) == 1) is resumed
    assert r.created == (() if resumed else (2,))


def test_meta_still_seen_elsewhere_is_not_resumed_by_position() -> None:
    cams0 = {"A": at(1, 40), "B": at(7, 40)}
    state, _ = step(meta_init(), cams0, [edge(("A", 1), ("B", 7))], 0)
    cams1 = {"A": at(2, 45), "B": at(7, 42)}  # A's target re-born; B still holds meta 1
    state, r = step(state, cams1, [], 1)
    assert meta_of(r, "B", 7, cams1) == 1
    assert meta_of(r, "A", 2, cams1) != 1 and r.resumed == ()


def _split(last: int, body_x: float = 55.0, cfg: MetaConfig = CFG,
           body_partner: bool = False) -> tuple[MetaState, object, dict[str, CameraTargets]]:
    """Meta 1's target (label 1) follows a piece of its person from frame 1 while the body gets
    label 2 (a new meta) 15 px away; label 1 is last seen at frame ``last``."""
    state, _ = step(meta_init(), {"A": at(1, 40)}, [], 0, cfg)
    for frame in range(1, last + 1):
        both = CameraTargets(np.array([1, 2], np.int64), np.array([[42.0, 50.0], [body_x, 50.0]]),
                             np.array([8.0, 30.0]),
                             np.array([[37.0, 42.0, 10.0, 8.0], [body_x - 5, 20.0, 10.0, 30.0]]),
                             (100, 100))
        cams = {"A": both, "B": at(7, 50)} if body_partner else {"A": both}
        edges = [edge(("A", 2), ("B", 7))] if body_partner else []
        state, r = step(state, cams, edges, frame, cfg)
        assert meta_of(r, "A", 2, cams) != 1
    cams = {"A": at(2, body_x), "B": at(7, 50)} if body_partner else {"A": at(2, body_x)}
    edges = [edge(("A", 2), ("B", 7))] if body_partner else []
    state, r = step(state, cams, edges, last + 1, cfg)
    return state, r, cams


def test_a_split_hands_the_old_meta_to_the_body_when_the_piece_dies() -> None:
    """'three' seed 0 cam2, frame 149: the tracker followed a 6 px piece of a person for three
    frames while the body got a new target and meta; when the piece died, nobody took its
    meta back (it still had a target when the body's was made), and the body's new meta went
    on into cam0. Now the young meta gives way and is reported merged into the old."""
    _, r, cams = _split(last=3)
    assert meta_of(r, "A", 2, cams) == 1
    assert r.resumed == ((1, "A", 2),) and r.merged == ((2, 1),)


@pytest.mark.parametrize(("last", "body_x", "cfg", "partner"), [
    (12, 55.0, CFG, False),  # the piece lived 12 frames: the new meta is no longer young
    (3, 75.0, CFG, False),  # the body 35 px = 1.17 heights from the piece's last feet
    (3, 55.0, replace(CFG, handover_frames=0), False),  # rule off
    (3, 55.0, CFG, True),  # the body's meta is linked into camera B: it is a person's own
])
def test_no_handover_when_the_new_meta_is_not_a_split_off_one(
        last: int, body_x: float, cfg: MetaConfig, partner: bool) -> None:
    _, r, cams = _split(last, body_x, cfg, partner)
    assert meta_of(r, "A", 2, cams) != 1 and r.merged == ()


def test_no_handover_to_a_meta_last_seen_in_that_camera_before_the_new_one() -> None:
    """'doors' seed 6: a person left cam1 at frame 386 and cam0 at 497; a newcomer had come
    into cam1 at 489 near where the first was last seen there. The first's meta was still
    alive when the newcomer's was made, but not in cam1: no split, no handover."""
    cams = {"A": at(1, 40), "B": at(7, 50)}
    state, _ = step(meta_init(), cams, [edge(("A", 1), ("B", 7))], 0)
    for frame in range(1, 15):
        state, _ = step(state, {"A": cam(), "B": at(7, 50)}, [], frame)
    for frame in range(15, 18):  # the newcomer in A, 5 px from meta 1's last feet there
        state, r = step(state, {"A": at(2, 45), "B": at(7, 50)}, [], frame)
    state, r = step(state, {"A": at(2, 45), "B": cam()}, [], 18)  # meta 1's B target leaves
    assert meta_of(r, "A", 2, {"A": at(2, 45)}) == 2 and r.merged == ()
