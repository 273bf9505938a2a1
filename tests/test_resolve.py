"""Whole-run label resolution (stages/resolve.py) and how results directories are rewritten."""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields, replace
from pathlib import Path

import numpy as np
import pytest

from mvtrack.io import CameraSpec, ClipSpec
from mvtrack.io.results import (
    ResultsWriter,
    TrackRows,
    read_cues,
    read_pairs,
    read_tracks,
    rewrite_tracks,
)
from mvtrack.params import HomographyConfig, ParamsError, ResolveConfig, load_params
from mvtrack.pipeline import finish_results
from mvtrack.stages.fov import border_line
from mvtrack.stages.homography import apply_homography, transfer_errors
from mvtrack.stages.pair import found_share
from mvtrack.stages.resolve import camera_frames, resolve_labels

CFG = ResolveConfig()
SHIFT = np.array([[1.0, 0.0, 40.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # cam1 = cam0 + (40, 0)


@dataclass(frozen=True)
class Rows:
    frame: np.ndarray
    camera: np.ndarray
    target: np.ndarray
    meta: np.ndarray
    feet: np.ndarray
    height: np.ndarray

    @property
    def boxes_xywh(self) -> np.ndarray:
        """A box half as wide as tall standing on the feet."""
        h = self.height
        return np.c_[self.feet[:, 0] - h / 4, self.feet[:, 1] - h, h / 2, h]


def _rows(tracks: list[tuple[str, int, int, range, tuple[float, float]]]) -> Rows:
    """(camera, target, online meta, frames, cam0 ground point) -> rows; cam1 sees it shifted."""
    cols: list[list] = [[], [], [], [], [], []]
    for cam, target, meta, frames, (x, y) in tracks:
        for f in frames:
            dx = 40.0 if cam == "cam1" else 0.0
            for col, v in zip(cols, (f, cam, target, meta, (x + dx + 0.1 * f, y), 50.0),
                              strict=True):
                col.append(v)
    return Rows(np.array(cols[0], np.int64), np.array(cols[1]), np.array(cols[2], np.int64),
                np.array(cols[3], np.int64), np.array(cols[4], np.float64),
                np.array(cols[5], np.float64))


def _walker(cam: str, target: int, meta: int, frames: range, x0: float, vx: float) -> Rows:
    """One target walking along x at ``vx`` px per frame from ``x0`` at frame 0."""
    f = np.array(frames, np.int64)
    return Rows(f, np.array([cam] * len(f)), np.full(len(f), target, np.int64),
                np.full(len(f), meta, np.int64), np.c_[x0 + vx * f, np.full(len(f), 100.0)],
                np.full(len(f), 50.0))


def _cat(*parts: Rows) -> Rows:
    return Rows(*(np.concatenate([getattr(r, f) for r in parts])
                  for f in ("frame", "camera", "target", "meta", "feet", "height")))


def _meta_of(rows: Rows, res_meta: np.ndarray) -> dict[tuple[str, int], set[int]]:
    out: dict[tuple[str, int], set[int]] = {}
    for c, t, m in zip(rows.camera.tolist(), rows.target.tolist(), res_meta.tolist(),
                       strict=True):
        out.setdefault((c, t), set()).add(m)
    return out


def test_people_seen_together_before_h_share_one_meta_for_life() -> None:
    """Two people in both views from frame 0; online they got separate metas until frame 30
    (no H yet), and person 2 left before it. The final H joins both for their whole lives."""
    rows = _rows([
        ("cam0", 1, 1, range(0, 60), (100.0, 100.0)), ("cam1", 1, 2, range(0, 60), (100.0, 100.0)),
        ("cam0", 2, 3, range(0, 25), (200.0, 150.0)), ("cam1", 2, 4, range(0, 25), (200.0, 150.0)),
    ])
    online = rows.meta.copy()
    online[(rows.camera == "cam1") & (rows.target == 1) & (rows.frame >= 30)] = 1
    rows = replace(rows, meta=online)
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    metas = _meta_of(rows, res.meta)
    assert all(len(v) == 1 for v in metas.values())  # one meta per target for its whole life
    assert metas["cam0", 1] == metas["cam1", 1] == {1}  # keeps the meta most rows carried
    assert metas["cam0", 2] == metas["cam1", 2] != metas["cam0", 1]
    assert {(x.a, x.b) for x in res.links if x.joined} == {(("cam0", 1, 0), ("cam1", 1, 0)),
                                                           (("cam0", 2, 0), ("cam1", 2, 0))}


def test_fov_baseline_never_uses_the_homography() -> None:
    rows = _rows([("cam0", 1, 1, range(40), (100.0, 100.0)),
                  ("cam1", 1, 2, range(40), (100.0, 100.0))])
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG, use_h=False)
    assert len(set(res.meta.tolist())) == 2
    assert not res.links


def test_targets_of_cameras_that_do_not_overlap_are_never_joined() -> None:
    """cam0-cam2 and cam1-cam2 overlap, cam0-cam1 do not, and no pair has an H. Online, cam2 t3
    carried one meta with cam0 t1 for 60 frames and with cam1 t7 for 50 of them: cam0 t1 and
    cam1 t7 were present together 50 frames, so they are two people and only the stronger
    link joins (with every pair overlapping, all three would be one person)."""
    rows = _rows([("cam0", 1, 5, range(0, 60), (100.0, 100.0)),
                  ("cam2", 3, 5, range(0, 60), (100.0, 100.0)),
                  ("cam1", 7, 5, range(10, 60), (300.0, 100.0))])
    pairs = [("cam0", "cam2", None), ("cam1", "cam2", None)]
    res = resolve_labels(rows, pairs, CFG, overlaps=[(a, b) for a, b, _ in pairs])
    metas = _meta_of(rows, res.meta)
    assert metas["cam0", 1] == metas["cam2", 3] != metas["cam1", 7]
    assert [(x.a[0], x.b[0], x.joined) for x in res.links if x.source == "online"] == [
        ("cam0", "cam2", True), ("cam1", "cam2", False)]
    res = resolve_labels(rows, pairs, CFG)  # overlaps unknown: every pair overlaps
    assert len(set(res.meta.tolist())) == 1


def _swap_rows(switch_at: int) -> Rows:
    """cam0 sees persons A and B side by side for 80 frames; cam1's target 7 covers A, then B
    from ``switch_at`` on (an identity swap)."""
    rows = _rows([
        ("cam0", 1, 1, range(0, 80), (100.0, 100.0)),
        ("cam0", 2, 2, range(0, 80), (100.0, 200.0)),
        ("cam1", 7, 3, range(0, switch_at), (100.0, 100.0)),
    ])
    return _cat(rows, _rows([("cam1", 7, 3, range(switch_at, 80), (100.0, 200.0))]))


def test_a_target_that_switched_person_is_cut_and_two_people_never_joined() -> None:
    """The swap must not join A and B; cam1's target is cut at the switch and each part takes
    its person's meta."""
    rows = _swap_rows(40)
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    metas = _meta_of(rows, res.meta)
    assert metas["cam0", 1] != metas["cam0", 2]
    cam1 = rows.camera == "cam1"
    assert set(res.meta[cam1 & (rows.frame < 40)].tolist()) == metas["cam0", 1]
    assert set(res.meta[cam1 & (rows.frame >= 40)].tolist()) == metas["cam0", 2]
    assert [(x.a, x.b, x.source, x.joined) for x in res.links] == [
        (("cam0", 1, 0), ("cam1", 7, 0), "homography", True),
        (("cam0", 2, 0), ("cam1", 7, 1), "homography", True),
        (("cam1", 7, 0), ("cam1", 7, 1), "segment", False),  # would join A and B
    ]


def test_a_swap_is_blamed_on_the_camera_whose_targets_turned_back() -> None:
    """Persons A and B, walking towards each other, pass 10 px apart at frame 40. cam1 swaps
    its targets 7 and 8 there (each turns back the way it came); cam0 keeps its targets 1 and
    2 on their people. Each of the four targets' votes change partner at frame 40; only cam1's
    targets are cut, and every row of A carries one meta."""
    cols: list[list] = [[], [], [], [], [], []]

    def add(cam: str, target: int, meta: int, frames: range, person: str) -> None:
        for f in frames:
            x, y = (100.0, 100.0 + f) if person == "A" else (110.0, 180.0 - f)
            feet = (x + (40.0 if cam == "cam1" else 0.0), y)
            for col, v in zip(cols, (f, cam, target, meta, feet, 50.0 if cam == "cam0" else 100.0),
                              strict=True):
                col.append(v)

    add("cam0", 1, 1, range(80), "A")
    add("cam0", 2, 2, range(80), "B")
    add("cam1", 7, 3, range(40), "A")
    add("cam1", 7, 3, range(40, 80), "B")
    add("cam1", 8, 4, range(40), "B")
    add("cam1", 8, 4, range(40, 80), "A")
    rows = Rows(np.array(cols[0], np.int64), np.array(cols[1]), np.array(cols[2], np.int64),
                np.array(cols[3], np.int64), np.array(cols[4], np.float64),
                np.array(cols[5], np.float64))
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    person_a = ((rows.camera == "cam0") & (rows.target == 1)) | (
        (rows.camera == "cam1") & ((rows.target == 7) == (rows.frame < 40)))
    assert len(set(res.meta[person_a].tolist())) == 1
    assert len(set(res.meta[~person_a].tolist())) == 1
    assert res.meta[person_a][0] != res.meta[~person_a][0]
    cut = {x.a for x in res.links if x.source == "segment"}
    assert cut == {("cam1", 7, 0), ("cam1", 8, 0)}


def test_a_hand_over_is_blamed_on_the_target_whose_walk_bent() -> None:
    """crowd seed 0: persons A and B walk side by side, 10 px apart, in both cameras. cam1's
    target 5 follows A, merges with B's target 6, which ends, and comes out on B's path at
    frame 40; A gets a new target 11 at frame 42. cam0 sees the two large (100 px tall: 0.1
    heights apart, against 0.2 in cam1) and keeps its targets 1 and 2 on them. Both cam0's
    target 1 and cam1's target 5 change partner there; the one whose feet left the line they
    walked (cam1's) is cut, though the two were nearer each other in cam0."""
    cols: list[list] = [[], [], [], [], [], []]

    def add(cam: str, target: int, frames: range, person: str) -> None:
        for f in frames:
            feet = (100.0 + f + (40.0 if cam == "cam1" else 0.0), 100.0 if person == "A" else 110.0)
            for col, v in zip(cols, (f, cam, target, target, feet,
                                     100.0 if cam == "cam0" else 50.0), strict=True):
                col.append(v)

    add("cam0", 1, range(80), "A")
    add("cam0", 2, range(80), "B")
    add("cam1", 5, range(40), "A")
    add("cam1", 5, range(40, 80), "B")
    add("cam1", 6, range(38), "B")
    add("cam1", 11, range(42, 80), "A")
    rows = Rows(*(np.array(c) for c in cols))
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    assert [(sw.track, sw.cut) for sw in res.switches] == [(("cam1", 5), 40)]
    person_a = ((rows.camera == "cam0") & (rows.target == 1)) | (
        (rows.camera == "cam1") & ((rows.target == 11) | ((rows.target == 5) & (rows.frame < 40))))
    assert len(set(res.meta[person_a].tolist())) == 1
    assert len(set(res.meta[~person_a].tolist())) == 1
    assert res.meta[person_a][0] != res.meta[~person_a][0]


def _left_and_came_back(jump_px: float, turn: bool = False) -> Rows:
    """cam1's target 7 is seen from frame 0 to 99; cam0 sees one person as target 1 (frames
    0-39, where cam1's target is) and another as target 2 (frames 60-99). Without a jump,
    cam1's target walks on smoothly: one person who left cam0 and came back. With one, cam1's
    feet jump ``jump_px`` (its height is 50 px) at frame 50: its label moved to someone else,
    walking the other way if ``turn``."""
    f = np.arange(100)
    y = np.where(f < 50, 100.0, 100.0 + jump_px)
    x = 140.0 + 0.1 * (f if not turn else 50 - np.abs(f - 50))
    cam1 = Rows(f, np.array(["cam1"] * 100), np.full(100, 7), np.full(100, 3), np.c_[x, y],
                np.full(100, 50.0))
    cam0 = _cat(
        Rows(f[:40], np.array(["cam0"] * 40), np.full(40, 1), np.full(40, 1),
             np.c_[x[:40] - 40.0, y[:40]], np.full(40, 50.0)),
        Rows(f[60:], np.array(["cam0"] * 40), np.full(40, 2), np.full(40, 2),
             np.c_[x[60:] - 40.0, y[60:]], np.full(40, 50.0)))
    return _cat(cam0, cam1)


@pytest.mark.parametrize("jump_px", [100.0, 30.0])
def test_a_jump_between_partners_never_seen_together_is_a_switch(jump_px: float) -> None:
    """Two cam0 targets never seen together may be one person: cam1's target is cut between
    its votes for them only when it jumped there, and its parts are not rejoined. A jump of
    0.6 heights is one (held-out 'pair' seed 6: cam1's target followed a person out over the
    left border at the top-left corner and went on as one coming in there, its feet 0.6
    heights higher from one frame to the next, walking back), but not with
    switch_jump_heights 1."""
    smooth = resolve_labels(_left_and_came_back(0.0), [("cam0", "cam1", SHIFT)], CFG)
    assert len(set(smooth.meta.tolist())) == 1 and not smooth.switches
    # 30 px is within a stitch of the walk before (stitch_gate_heights): a target walking on
    # the same way after it would be rejoined; here, as in the clip, it walks back
    rows = _left_and_came_back(jump_px, turn=jump_px < 50.0)
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    assert [(sw.track, sw.cut, sw.rejoin) for sw in res.switches] == [(("cam1", 7), 50, False)]
    assert [sw.why for sw in res.switches] == ["its feet jumped in between"]
    metas = _meta_of(rows, res.meta)
    assert metas["cam0", 1] != metas["cam0", 2]
    cam1 = rows.camera == "cam1"
    assert set(res.meta[cam1 & (rows.frame < 50)].tolist()) == metas["cam0", 1]
    assert set(res.meta[cam1 & (rows.frame >= 50)].tolist()) == metas["cam0", 2]
    loose = resolve_labels(rows, [("cam0", "cam1", SHIFT)], replace(CFG, switch_jump_heights=1.0))
    assert bool(loose.switches) == (jump_px > 50.0)


def _walked_out_as_another_walked_in() -> Rows:
    """cam0 sees one person as target 1 (frames 0-39) and another as target 2 (frames 60-99),
    each where cam1's target 7 is; cam1's target 7 walks right at 2 px per frame, to x = 240
    at frame 50, and back (box right edge 252)."""
    f = np.arange(100)
    x = 2.0 * (50 - np.abs(f - 50))
    cam1 = Rows(f, np.array(["cam1"] * 100), np.full(100, 7), np.full(100, 3),
                np.c_[140.0 + x, np.full(100, 100.0)], np.full(100, 50.0))
    cam0 = _cat(*(Rows(f[k], np.array(["cam0"] * len(k)), np.full(len(k), t),
                       np.full(len(k), t), np.c_[100.0 + x[k], np.full(len(k), 100.0)],
                       np.full(len(k), 50.0))
                  for t, k in ((1, np.arange(40)), (2, np.arange(60, 100)))))
    return _cat(cam0, cam1)


@pytest.mark.parametrize(("cam1_width", "cut"), [(250, True), (400, False), (None, False)])
def test_a_turn_at_the_border_between_partners_never_seen_together_is_a_switch(
        cam1_width: int | None, cut: bool) -> None:
    """one_edge seed 5: cam0's target 1 walked out at the left border as another person walked
    in there, one blob for both; its votes went from cam1's target of the first to that of
    the second. A target that turned back on its frame's border (cam1 250 px wide) is cut
    there for good; one that turned inside its view (400 px), or with the frame sizes
    unknown, is one person who left the other camera and came back."""
    rows = _walked_out_as_another_walked_in()
    sizes = None if cam1_width is None else {"cam0": (400, 300), "cam1": (cam1_width, 300)}
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG, sizes=sizes)
    metas = _meta_of(rows, res.meta)
    if cut:
        assert [(sw.track, sw.cut, sw.rejoin) for sw in res.switches] == [(("cam1", 7), 50,
                                                                            False)]
        assert metas["cam0", 1] != metas["cam0", 2]
        cam1 = rows.camera == "cam1"
        assert set(res.meta[cam1 & (rows.frame < 50)].tolist()) == metas["cam0", 1]
        assert set(res.meta[cam1 & (rows.frame >= 50)].tolist()) == metas["cam0", 2]
    else:
        assert not res.switches and len(set(res.meta.tolist())) == 1
    off = resolve_labels(rows, [("cam0", "cam1", SHIFT)],
                         replace(CFG, switch_turn_heights=0.0), sizes=sizes)
    assert not off.switches


@dataclass(frozen=True)
class _BoxRows(Rows):
    boxes: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))

    @property
    def boxes_xywh(self) -> np.ndarray:
        return self.boxes


def _handed_over_at_the_border() -> _BoxRows:
    """'one_edge' seed 11 cam0: one person walked out over the right border of cam1 (250 px
    wide) at 1 px per frame, as another, lower in the image, walked in there: one blob for
    both, its box's inner (left) edge at 230 - |f - 50|, clipped by the border. Its feet,
    under the blob's centroid, move half as far sideways and slide 30 px down from one
    person's row to the other's over frames 45-55: walks 40 -> 50 -> 60 of (5, 15) and
    (-5, 15), not opposed. cam0 sees the two as targets 1 (frames 0-39) and 2 (60-99)."""
    f = np.arange(100)
    x = 230.0 - np.abs(f - 50)
    w = np.minimum(40.0, 250.5 - x)
    feet = np.c_[x + w / 2, 100.0 + np.clip(3.0 * (f - 45), 0.0, 30.0)]
    cam1 = _BoxRows(f, np.array(["cam1"] * 100), np.full(100, 7), np.full(100, 3), feet,
                    np.full(100, 50.0), np.c_[x, feet[:, 1] - 50.0, w, np.full(100, 50.0)])
    cam0 = _cat(*(Rows(f[k], np.array(["cam0"] * len(k)), np.full(len(k), t),
                       np.full(len(k), t), feet[k] - [40.0, 0.0], np.full(len(k), 50.0))
                  for t, k in ((1, np.arange(40)), (2, np.arange(60, 100)))))
    return _cat_boxed(cam0, cam1)


def _cat_boxed(*parts: Rows) -> _BoxRows:
    """:func:`_cat` keeping each part's boxes."""
    return _BoxRows(*(np.concatenate([getattr(r, n) for r in parts])
                      for n in ("frame", "camera", "target", "meta", "feet", "height",
                                "boxes_xywh")))


@pytest.mark.parametrize(("cam1_width", "cut"), [(250, True), (400, False)])
def test_a_turn_at_the_border_is_read_from_the_box_inner_edge(cam1_width: int,
                                                              cut: bool) -> None:
    """A handover at the border whose feet do not walk back (:func:`_handed_over_at_the_border`)
    is still a turn: the blob's inner edge came 20 px (0.4 heights) towards the border over
    the 20 frames before frame 50 and went as far back after. The parts stay two people
    though a hand-off would join the first, which walked out of cam1 unseen by cam0, to
    cam0's target 2, which began where that walk leads. Inside a view 400 px wide the same
    walk is no turn."""
    rows = _handed_over_at_the_border()
    sizes = {"cam0": (400, 300), "cam1": (cam1_width, 300)}
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG, sizes=sizes)
    assert [(sw.track, sw.cut, sw.rejoin) for sw in res.switches] == (
        [(("cam1", 7), 50, False)] if cut else [])
    assert [sw.why for sw in res.switches] == (
        ["it turned back at the border in between (one walked out as the other walked in)"]
        if cut else [])
    metas = _meta_of(rows, res.meta)
    assert (metas["cam0", 1] != metas["cam0", 2]) == cut
    high = resolve_labels(rows, [("cam0", "cam1", SHIFT)],
                          replace(CFG, switch_turn_heights=0.45), sizes=sizes)
    assert not high.switches


def test_the_turn_places_the_cut_before_a_jump_does() -> None:
    """'one_edge' seed 3: the target that turned at the border (frame 50) had its feet jump
    for a frame earlier (45: its legs lost in a merge, 40 px up) between the same runs of
    votes. The cut is at the turn, where one person walked out and the other in; at the
    jump it gave the frames between to the second person."""
    rows = _walked_out_as_another_walked_in()
    glitch = (rows.camera == "cam1") & (rows.frame == 45)
    rows.feet[glitch, 1] -= 40.0
    sizes = {"cam0": (400, 300), "cam1": (250, 300)}
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG, sizes=sizes)
    assert [(sw.track, sw.cut) for sw in res.switches] == [(("cam1", 7), 50)]
    no_turn = resolve_labels(rows, [("cam0", "cam1", SHIFT)],
                             replace(CFG, switch_turn_heights=0.0), sizes=sizes)
    assert [(sw.track, sw.cut) for sw in no_turn.switches] == [(("cam1", 7), 45)]


def test_no_switch_between_partners_that_are_one_person_lost_and_found() -> None:
    """'tilted' seed 6: cam0 lost a person in a merge with someone in front (target 3) and
    found it again 51 frames later (target 6) where its walk led; cam1's target saw the
    person throughout, and its feet jumped for a frame at a merge glitch in between. cam0's
    second target continues the first (a stitch's test): one person, not a switch. Here
    cam1's feet jump 40 px (0.8 heights) at frame 50, between its votes for cam0's targets 1
    and 2."""
    rows = _left_and_came_back(0.0)
    rows.feet[(rows.camera == "cam1") & (rows.frame == 50), 1] += 40.0
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    assert not res.switches and len(set(res.meta.tolist())) == 1
    apart = resolve_labels(rows, [("cam0", "cam1", SHIFT)], replace(CFG, stitch_max_gap_frames=0))
    assert [(sw.track, sw.cut) for sw in apart.switches] == [(("cam1", 7), 50)]


def test_a_switch_long_after_a_turn_is_no_mirror_of_it() -> None:
    """'tilted' seed 6: the turn of cam1's target 7 at the border (frame 50) is cut though a
    target it voted for changes partner later: cam0's target 2 jumps 45 px at frame 100,
    where cam1's target 7 ends and target 9 begins, 45 px off target 7's walk (not its
    continuation). A mirror of the turn would have been at the same time; this one is 50
    frames on and is a switch of its own, so both are cut."""
    rows = _walked_out_as_another_walked_in()
    rows = Rows(*(getattr(rows, f)[~((rows.camera == "cam0") & (rows.target == 2))]
                  for f in ("frame", "camera", "target", "meta", "feet", "height")))
    f = np.arange(60, 160)
    x = 200.0 - 2.0 * f  # the second person walks on left
    later = f >= 100
    cam0 = Rows(f, np.array(["cam0"] * len(f)), np.full(len(f), 2), np.full(len(f), 2),
                np.c_[100.0 + x, np.where(later, 145.0, 100.0)], np.full(len(f), 50.0))
    cam1 = Rows(f[later], np.array(["cam1"] * later.sum()), np.full(later.sum(), 9),
                np.full(later.sum(), 9), np.c_[140.0 + x[later], np.full(later.sum(), 145.0)],
                np.full(later.sum(), 50.0))
    keep = ~((rows.camera == "cam1") & (rows.frame >= 100))
    rows = _cat(Rows(*(getattr(rows, k)[keep] for k in
                       ("frame", "camera", "target", "meta", "feet", "height"))), cam0, cam1)
    sizes = {"cam0": (400, 300), "cam1": (250, 300)}
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG, sizes=sizes)
    assert [(sw.track, sw.cut) for sw in res.switches] == [(("cam1", 7), 50), (("cam0", 2), 100)]
    metas = _meta_of(rows, res.meta)
    cam1 = rows.camera == "cam1"
    assert metas["cam0", 1] != metas["cam1", 9]
    assert set(res.meta[cam1 & (rows.target == 7) & (rows.frame < 50)].tolist()) == metas[
        "cam0", 1]


def test_a_turn_at_the_border_needs_fewer_votes_before_it() -> None:
    """one_edge seed 3: the person who walked out was seen by the other camera for only 19
    frames before. The turn is evidence of its own: 15 votes (``switch_moved_min_votes`` 10)
    are enough for the cut, not when such a switch needs the 20 of any other."""
    rows = _walked_out_as_another_walked_in()
    rows = Rows(*(getattr(rows, f)[~((rows.camera == "cam0") & (rows.frame < 25))]
                  for f in ("frame", "camera", "target", "meta", "feet", "height")))
    sizes = {"cam0": (400, 300), "cam1": (250, 300)}
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG, sizes=sizes)
    assert [(sw.track, sw.cut) for sw in res.switches] == [(("cam1", 7), 50)]
    strict = replace(CFG, switch_moved_min_votes=CFG.switch_min_votes)
    assert not resolve_labels(rows, [("cam0", "cam1", SHIFT)], strict, sizes=sizes).switches


def test_a_short_run_of_votes_is_no_switch() -> None:
    """Under ``switch_min_votes`` frames with the other person (people passing close by) do
    not cut a target: it keeps one meta, its person's."""
    rows = _swap_rows(80 - CFG.switch_min_votes + 1)
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    metas = _meta_of(rows, res.meta)
    assert metas["cam1", 7] == metas["cam0", 1]
    assert not any(x.source == "segment" for x in res.links)


def test_fragments_of_one_person_join_but_not_after_a_long_gap() -> None:
    """A split blob: cam0 targets 1 and 3 side by side for 10 frames (fragments of one person)
    both join cam1's target. A target that took over cam0 target 4's meta 60 frames after it
    ended (beyond resume_gap_frames) does not keep it."""
    rows = _rows([
        ("cam0", 1, 1, range(0, 40), (100.0, 100.0)),
        ("cam0", 3, 5, range(30, 80), (100.0, 100.0)),
        ("cam1", 2, 1, range(0, 80), (100.0, 100.0)),
        ("cam0", 4, 9, range(100, 120), (250.0, 30.0)),
        ("cam0", 6, 9, range(180, 200), (250.0, 30.0)),
    ])
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    metas = _meta_of(rows, res.meta)
    assert metas["cam0", 1] == metas["cam0", 3] == metas["cam1", 2]
    assert metas["cam0", 4] != metas["cam0", 6]
    near = resolve_labels(rows, [("cam0", "cam1", SHIFT)], replace(CFG, resume_gap_frames=80))
    assert len(set(near.meta[rows.meta == 9].tolist())) == 1


def test_a_person_seen_together_for_a_few_frames_keeps_one_meta() -> None:
    """pillar seed 2: cam1 sees a person again (target 9, a new online meta) three frames before
    cam0, which had them all along, loses them at its border. Those frames agree under H, and
    min_votes of them link the two: one meta for the person's whole walk. One frame fewer in
    common, or min_votes 5, and the walk after is another person's."""
    def rows(last: int):
        return _rows([("cam0", 1, 1, range(0, last), (100.0, 100.0)),
                      ("cam1", 9, 24, range(97, 160), (100.0, 100.0))])
    seen = rows(100)
    assert len(set(resolve_labels(seen, [("cam0", "cam1", SHIFT)], CFG).meta.tolist())) == 1
    assert CFG.min_votes == 3
    strict = resolve_labels(seen, [("cam0", "cam1", SHIFT)], replace(CFG, min_votes=5))
    assert len(set(strict.meta.tolist())) == 2
    assert len(set(resolve_labels(rows(99), [("cam0", "cam1", SHIFT)], CFG).meta.tolist())) == 2


def test_legs_tracked_apart_join_their_person_by_fragment_votes() -> None:
    """cam0 tracks a person's legs apart (target 7, 20 px tall, 25 frames inside the torso
    target 1's life, feet 5 px away): the assignment always picks the torso, yet the legs vote
    for the person's cam1 target and join it. A second person, seen only in cam0 beside the
    first, is within the gate too but as tall: no fragment."""
    rows = _rows([
        ("cam0", 1, 1, range(0, 80), (100.0, 100.0)),
        ("cam0", 7, 8, range(30, 55), (105.0, 100.0)),
        ("cam1", 2, 2, range(0, 80), (100.0, 100.0)),
        ("cam0", 9, 9, range(10, 70), (100.0, 130.0)),
    ])
    legs = (rows.camera == "cam0") & (rows.target == 7)
    rows = replace(rows, height=np.where(legs, 20.0, rows.height))
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    metas = _meta_of(rows, res.meta)
    assert metas["cam0", 7] == metas["cam0", 1] == metas["cam1", 2]
    assert metas["cam0", 9] != metas["cam0", 1]


def test_a_person_hidden_for_a_while_is_stitched_on_one_camera() -> None:
    """cam0 only: target 1 walks right at 2 px/frame until frame 39 and target 2 appears at
    frame 60 where it would be by then (x 220): one person behind a pillar, one meta. Target 3
    appears there as well but walking left: no stitch; target 4 walking right 2 heights off:
    none either."""
    hidden = _cat(_walker("cam0", 1, 1, range(40), 100.0, 2.0),
                  _walker("cam0", 2, 2, range(60, 100), 100.0, 2.0))
    res = resolve_labels(hidden, [], CFG)
    assert len(set(res.meta.tolist())) == 1
    assert [(x.a, x.b, x.source, x.joined) for x in res.links] == [
        (("cam0", 1, 0), ("cam0", 2, 0), "stitch", True)]
    back = _cat(_walker("cam0", 1, 1, range(40), 100.0, 2.0),
                _walker("cam0", 3, 3, range(60, 100), 340.0, -2.0))  # x 220 at frame 60
    far = _cat(_walker("cam0", 1, 1, range(40), 100.0, 2.0),
               _walker("cam0", 4, 4, range(60, 100), 200.0, 2.0))  # x 320 at 60: 100 px off
    for rows in (back, far):
        assert len(set(resolve_labels(rows, [], CFG).meta.tolist())) == 2


def test_a_stitch_goes_by_the_walk_not_by_one_bad_last_row() -> None:
    """doors seed 0: cam1's target 10 walked left at 1 px/frame; in its last rows it merged
    with two people coming out of a door below it and its feet dropped 28 px (a 25 px tall
    person), then it was hidden in their blob for 22 frames. Its last velocity measured from
    end to end (10 rows) put it 4 heights below where it came out again (target 13); its walk
    (the median of its rows' pairwise velocities) puts it there."""
    walk = _walker("cam0", 10, 1, range(40), 140.0, -1.0)
    merged = np.isin(walk.frame, [38, 39])
    walk = replace(walk, feet=walk.feet + np.where(merged, 28.0, 0.0)[:, None] * [0.0, 1.0],
                   height=np.full(len(walk.frame), 25.0))
    back = replace(_walker("cam0", 13, 2, range(62, 100), 140.0, -1.0),
                   height=np.full(38, 25.0))
    res = resolve_labels(_cat(walk, back), [], CFG)
    assert len(set(res.meta.tolist())) == 1
    assert [(x.a, x.b, x.source) for x in res.links] == [
        (("cam0", 10, 0), ("cam0", 13, 0), "stitch")]


def test_a_stitch_after_a_long_gap_goes_by_a_long_walk() -> None:
    """doors seed 9: cam0's target 1 walked at 1.2 px a frame, its feet swaying with the
    stride, and was hidden 36 frames behind the booth; the walk of its last 10 rows put it
    38 px from where it came out (target 5), that of its last 30 rows within the gate. Here
    both sway 4 px up and down every 16 frames; the person is 38 px tall (gate 28.5 px)."""
    parts = []
    for target, frames in ((1, range(60)), (5, range(96, 156))):
        r = _walker("cam0", target, target, frames, 100.0, 1.2)
        sway = 4.0 * np.sin(2 * np.pi * r.frame / 16.0)
        parts.append(replace(r, feet=r.feet + np.c_[np.zeros(len(sway)), sway],
                             height=np.full(len(sway), 38.0)))
    res = resolve_labels(_cat(*parts), [], CFG)
    assert [(x.a, x.b, x.source) for x in res.links] == [
        (("cam0", 1, 0), ("cam0", 5, 0), "stitch")]


@pytest.mark.parametrize(("vx", "gap", "stitched"),
                         [(1.0, 65, True), (1.0, 80, False), (0.0, 65, False), (0.0, 40, True)])
def test_a_walking_person_is_stitched_after_a_longer_gap(vx: float, gap: int,
                                                         stitched: bool) -> None:
    """'pillar' s1: two people walking behind the pillar came out 62 and 66 frames later,
    beyond stitch_max_gap_frames (50); walking (here 1 px a frame, 0.02 heights), up to
    stitch_walking_max_gap_frames (75). A target standing still is stitched over 40 frames
    but not over 65: on PETS, such stitches joined people who stood where others had."""
    rows = _cat(_walker("cam0", 1, 1, range(40), 100.0, vx),
                _walker("cam0", 2, 2, range(39 + gap, 100 + gap), 100.0, vx))
    res = resolve_labels(rows, [], CFG)
    assert (len(set(res.meta.tolist())) == 1) == stitched


def test_no_stitch_from_a_target_that_walked_out_of_the_view() -> None:
    """pair seed 4: cam0's target 7 walked out over the left border; 27 frames later a blob
    stood there, then a newcomer walked in, and stitches made them one person. Target 1 here
    walks left until its box is on the border (frame 39); target 2 stands where it would be by
    frame 60: stitched while the borders are unknown, not with the frame's size."""
    rows = _cat(_walker("cam0", 1, 1, range(40), 31.5, -0.5),
                _walker("cam0", 2, 2, range(60, 100), 2.0, 0.0))
    assert len(set(resolve_labels(rows, [], CFG).meta.tolist())) == 1
    res = resolve_labels(rows, [], CFG, sizes={"cam0": (320, 240)})
    assert len(set(res.meta.tolist())) == 2 and not res.links


def _through_the_bottom(target: int, frames: range, top0: float, vy: float,
                        completed_until: int | None) -> _BoxRows:
    """cam0 (320 x 240) rows of a person 60 px tall whose box's top moves ``vy`` px a frame
    from ``top0``, cut by the bottom border; feet put back below the frame until frame
    ``completed_until`` (None: never), then on the border (further out, too little shows)."""
    f = np.array(frames, np.int64)
    top = top0 + vy * (f - f[0])
    bottom = np.minimum(top + 60.0, 239.5)
    feet_y = np.where(f <= (completed_until if completed_until is not None else -1),
                      top + 60.0, bottom)
    n = len(f)
    return _BoxRows(f, np.array(["cam0"] * n), np.full(n, target), np.full(n, target),
                    np.c_[np.full(n, 110.0), feet_y], np.full(n, 60.0),
                    np.c_[np.full(n, 100.0), top, np.full(n, 20.0), bottom - top])


def test_a_target_whose_feet_fall_back_onto_the_border_still_walked_out() -> None:
    """'tilted' s11 (feet.up = "learned"): cam0's target 1 walked out over the bottom border,
    its feet below the frame while half of it showed, then back on the border for its last 5
    rows: its feet's last 10 rows head back into the view, its box's top edge does not. A
    newcomer walking in there 5 frames later was stitched to it (and with it, its other
    camera's partner). Not with the inner edge: one walked out, one walked in."""
    out = _through_the_bottom(1, range(0, 36), 150.0, 2.0, completed_until=30)
    came = _through_the_bottom(2, range(40, 80), 220.0, -2.0, completed_until=None)
    rows = _cat_boxed(out, came)
    res = resolve_labels(rows, [], CFG, sizes={"cam0": (320, 240)})
    assert len(set(res.meta.tolist())) == 2 and not res.links
    assert len(set(resolve_labels(rows, [], CFG).meta.tolist())) == 1  # borders unknown


def test_a_target_mostly_out_of_the_view_gives_no_votes() -> None:
    """'tilted' s11: cam0's target 1 walked out over the bottom border; with 16-26 px of its
    60 shown (too little for the feet completion) its feet drifted on the border, near where
    H put a newcomer in cam1 (target 8), and 8 votes made the newcomer the same person as
    cam1's target 3, which had walked out of cam1. Here cam0's target 1 and cam1's target 3
    walk together for frames 0-29 (cam1's out over its right border); cam0's target 1 then
    shows 20 of 60 px on the bottom border for frames 30-39, where H puts cam1's target 8
    (frames 30-70)."""
    walk = _walker("cam0", 1, 1, range(30), 100.0, 1.0)
    walk.feet[:, 1] = 225.0
    out = Rows(np.arange(30, 40), np.array(["cam0"] * 10), np.full(10, 1), np.full(10, 1),
               np.tile([130.0, 239.5], (10, 1)), np.full(10, 20.0))
    came = Rows(np.arange(30, 71), np.array(["cam1"] * 41), np.full(41, 8), np.full(41, 8),
                np.tile([170.0, 239.5], (41, 1)), np.full(41, 60.0))
    rows = _cat(walk, out, _walker("cam1", 3, 3, range(30), 140.0, 1.0), came)
    rows.feet[rows.camera == "cam1", 1] = np.r_[np.full(30, 225.0), np.full(41, 239.5)]
    sizes = {"cam0": (320, 240), "cam1": (180, 400)}
    metas = _meta_of(rows, resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG,
                                          sizes=sizes).meta)
    assert metas["cam0", 1] == metas["cam1", 3] != metas["cam1", 8]
    every = resolve_labels(rows, [("cam0", "cam1", SHIFT)],
                           replace(CFG, vote_min_shown_frac=0.0), sizes=sizes)
    assert len(set(every.meta.tolist())) == 1


@pytest.mark.parametrize(("gap", "vx", "handed"), [
    (11, 1.0, True),    # hidden in cam0, lost in cam1, out in cam0 11 frames later
    (31, 1.0, False),   # beyond handoff_max_gap_frames
    (11, 0.0, False),   # standing: anyone may stand there by now
])
def test_a_person_hidden_in_one_view_and_lost_in_the_other_is_handed_off(
        gap: int, vx: float, handed: bool) -> None:
    """'pillar' s8: cam1 lost a person (target 5) while the pillar hid them from cam0, which
    found them 12 frames later where their walk, carried through H, led (IDF1 0.947 ->
    0.990). Here cam1's target 1 walks until frame 39 and cam0 sees nobody where H puts it;
    cam0's target 3 begins ``gap`` frames later where the walk leads."""
    rows = _cat(_walker("cam1", 1, 1, range(40), 140.0, vx),
                _walker("cam0", 3, 3, range(39 + gap, 100 + gap), 100.0, vx))
    sizes = {"cam0": (320, 240), "cam1": (320, 240)}
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG, sizes=sizes)
    assert (len(set(res.meta.tolist())) == 1) == handed
    assert [link.source for link in res.links] == (["handoff"] if handed else [])
    off = resolve_labels(rows, [("cam0", "cam1", SHIFT)], replace(CFG, handoff_max_gap_frames=0),
                         sizes=sizes)
    assert len(set(off.meta.tolist())) == 2


def test_no_hand_off_where_the_other_camera_saw_someone() -> None:
    """On PETS (View_003 detections) people walked on where the other camera saw them, or
    someone: a person leaving one view is handed off only if the other camera showed nobody
    where H put them in their last 10 frames. cam0's target 2 stands on that spot for two
    frames (too few votes to link it to cam1's target 1) and goes on as target 3 (a stitch)."""
    rows = _cat(_walker("cam1", 1, 1, range(40), 140.0, 1.0),
                _walker("cam0", 2, 2, range(33, 35), 139.0, 0.0),
                _walker("cam0", 3, 3, range(50, 111), 100.0, 1.0))
    sizes = {"cam0": (320, 240), "cam1": (320, 240)}
    for seen_heights, metas in ((CFG.handoff_seen_heights, 2), (0.0, 1)):
        res = resolve_labels(rows, [("cam0", "cam1", SHIFT)],
                             replace(CFG, handoff_seen_heights=seen_heights), sizes=sizes)
        assert len(set(res.meta.tolist())) == metas


def test_two_people_seen_apart_are_never_joined_through_others() -> None:
    """crowd seed 0: cam0's target 12 lived 10 frames where cam1's target 1 was, and 9 votes
    linked them; cam0's target 17 then took 12's meta (the same person, rightly) but stood 2
    heights from cam1's target 1 for 41 frames without a vote: two people, kept apart, where
    the chain of links would have joined them."""
    rows = _rows([
        ("cam1", 1, 1, range(0, 81), (200.0, 100.0)),
        ("cam0", 12, 9, range(10, 20), (200.0, 100.0)),
        ("cam0", 17, 9, range(40, 121), (100.0, 100.0)),
    ])
    metas = _meta_of(rows, resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG).meta)
    assert metas["cam0", 12] == metas["cam1", 1] != metas["cam0", 17]
    chained = resolve_labels(rows, [("cam0", "cam1", SHIFT)], replace(CFG, apart_max_vote_share=0))
    assert len(set(chained.meta.tolist())) == 1


def test_a_meta_handed_between_live_targets_is_no_take_over() -> None:
    """cam0 target 1 carries meta 7, then (online) meta 8 from frame 40 while it stays in view
    until frame 80; target 2, another person, takes meta 7 at frame 50. Target 1 was not gone,
    so this is no resume: the two share 30 frames (within max_shared_frames) yet stay apart."""
    rows = _rows([
        ("cam0", 1, 7, range(0, 40), (100.0, 100.0)),
        ("cam0", 1, 8, range(40, 80), (100.0, 100.0)),
        ("cam0", 2, 7, range(50, 120), (300.0, 200.0)),
    ])
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    metas = _meta_of(rows, res.meta)
    assert metas["cam0", 1] != metas["cam0", 2]
    assert not any(x.joined for x in res.links)


def test_no_take_over_of_a_meta_that_walked_out_of_the_view() -> None:
    """three seed 4: cam2's target 3 walked out over the right border at frame 256; at frame
    260 a newcomer walking in on that border (target 7) took its meta through a wrong online
    link in the other camera, and the take-over made two people one for 250 frames. Target 1
    here walks right until its box is on the border of a 240 px wide frame; target 2 takes its
    meta 10 frames later, 2 heights away: a take-over while the borders are unknown, none with
    the frame's size."""
    rows = _cat(_walker("cam0", 1, 5, range(40), 200.0, 1.0),
                _walker("cam0", 2, 5, range(50, 100), 275.0, -1.0))  # x 225 at frame 50
    assert len(set(resolve_labels(rows, [], CFG).meta.tolist())) == 1
    res = resolve_labels(rows, [], CFG, sizes={"cam0": (240, 180)})
    assert len(set(res.meta.tolist())) == 2 and not res.links


def test_pairs_without_h_keep_the_runs_own_links() -> None:
    rows = _rows([("cam0", 1, 1, range(20), (100.0, 100.0)),
                  ("cam1", 1, 1, range(20), (300.0, 10.0)),
                  ("cam0", 2, 2, range(20), (100.0, 150.0)),
                  ("cam1", 2, 3, range(20), (100.0, 150.0))])
    res = resolve_labels(rows, [("cam0", "cam1", None)], CFG)
    metas = _meta_of(rows, res.meta)
    assert metas["cam0", 1] == metas["cam1", 1]
    assert metas["cam0", 2] != metas["cam1", 2]


def test_empty_run() -> None:
    rows = _rows([])
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    assert res.meta.shape == (0,) and not res.links


def test_labels_mode_is_checked() -> None:
    with pytest.raises(ParamsError, match="labels = 'later'"):
        ResolveConfig(labels="later")


def test_rewrite_keeps_the_online_files_and_merges_cues(tmp_path) -> None:
    writer = ResultsWriter(tmp_path)
    writer.close({"frames": 0})
    (tmp_path / "tracks.csv").write_text(
        "frame,camera,target,meta,foot_x,foot_y,box_x,box_y,box_w,box_h,height\n"
        "0,cam0,1,1,10.00,20.00,5.0,0.0,10.0,20.0,20.00\n"
        "0,cam1,1,2,30.00,20.00,25.0,0.0,10.0,20.0,20.00\n")
    (tmp_path / "cues.csv").write_text(
        "frame,meta,camera,expected,seen\n0,1,cam0,1,1\n0,2,cam0,1,0\n0,1,cam1,0,0\n"
        "0,2,cam1,1,1\n1,2,cam1,1,0\n")
    online = (tmp_path / "tracks.csv").read_text()
    rows = read_tracks(tmp_path / "tracks.csv")
    rewrite_tracks(tmp_path, replace(rows, meta=np.array([1, 1])), lambda f, m: np.ones_like(m))
    assert (tmp_path / "tracks_online.csv").read_text() == online
    assert read_tracks(tmp_path / "tracks.csv").meta.tolist() == [1, 1]
    assert read_tracks(tmp_path / "tracks_online.csv").meta.tolist() == [1, 2]
    cues = read_cues(tmp_path / "cues.csv")
    assert list(zip(cues.frame.tolist(), cues.meta.tolist(), cues.camera.tolist(),
                    cues.expected.tolist(), cues.seen.tolist(), strict=True)) == [
        (0, 1, "cam0", True, True), (0, 1, "cam1", True, True), (1, 1, "cam1", True, False)]
    assert len(read_cues(tmp_path / "cues_online.csv").frame) == 5


def test_cue_meta_follows_the_targets_and_carries_forward() -> None:
    rows = _rows([("cam0", 1, 1, range(0, 30), (100.0, 100.0)),
                  ("cam1", 1, 2, range(0, 30), (100.0, 100.0))])
    res = resolve_labels(rows, [("cam0", "cam1", SHIFT)], CFG)
    (m,) = set(res.meta.tolist())
    got = res.cue_meta(np.array([5, 31, 40, 3]), np.array([2, 2, 7, 1]))
    assert got.tolist() == [m, m, 7, m]  # frame 31: no target carries meta 2 any more


TRUE_H = np.array([[0.8, 0.15, 10.0], [0.05, 0.85, 20.0], [0.0002, 0.0004, 1.0]])
WALKS = (((40.0, 100.0), (280.0, 200.0), range(0, 200)),  # cam0 feet from, to, frames
         ((280.0, 90.0), (60.0, 220.0), range(120, 320)),
         ((160.0, 70.0), (170.0, 225.0), range(260, 460)))


def _unlinked_run(unseen: range = range(0)) -> TrackRows:
    """Three people walking through both views of a 320x240 pair, one after another (each
    overlapping the next), cam1 = TRUE_H(cam0) with 0.5 px noise; online, no link was ever
    made: each of the six targets has its own meta. cam1 misses the third in ``unseen``."""
    rng = np.random.default_rng(0)
    parts = []
    for k, (start, end, frames) in enumerate(WALKS):
        f = np.array(frames, np.int64)
        t = (f - f[0])[:, None] / (len(f) - 1)
        feet0 = np.array(start) + t * (np.array(end) - np.array(start))
        for cam, exact in (("cam0", feet0), ("cam1", apply_homography(TRUE_H, feet0))):
            feet = exact + rng.normal(0.0, 0.5, exact.shape)
            h = np.full(len(f), 50.0)
            parts.append(TrackRows(f, np.array([cam] * len(f)), np.full(len(f), k + 1),
                                   np.full(len(f), k + 1 + 3 * (cam == "cam1")), feet,
                                   np.c_[feet[:, 0] - h / 4, feet[:, 1] - h, h / 2, h], h))
    rows = TrackRows(*(np.concatenate([getattr(p, f.name) for p in parts])
                       for f in fields(TrackRows)))
    seen = ~((rows.camera == "cam1") & (rows.target == 3) & np.isin(rows.frame, unseen))
    return TrackRows(*(getattr(rows, f.name)[seen] for f in fields(TrackRows)))


def _pair_spec(root: Path) -> ClipSpec:
    cams = tuple(CameraSpec(name, "detections", root / f"{name}.csv", 0, "rgb", (320, 240), 460)
                 for name in ("cam0", "cam1"))
    return ClipSpec(root, 25.0, cams, (("cam0", "cam1"),), 460, (), None, None)


def _finish(tmp_path: Path, sets: list[str], unseen: range = range(0),
            final_H: np.ndarray | None = None, lines: tuple[dict, ...] = ()
            ) -> tuple[TrackRows, list[dict]]:
    """The unlinked run written as a results directory whose pair ended with ``final_H``
    (default none) and FOV ``lines``, finished."""
    ResultsWriter(tmp_path).close({"frames": 460}, [
        {"cameras": ["cam0", "cam1"], "H": None if final_H is None else final_H.tolist(),
         "H_from_frame": None, "markers": 0, "fov_events": 0, "fov_lines": list(lines),
         "sizes": [[320, 240], [320, 240]], "H_whole_run": "stale"}])
    rewrite_tracks(tmp_path, _unlinked_run(unseen), lambda f, m: m)
    pairs = json.loads((tmp_path / "pairs.json").read_text())
    finish_results(tmp_path, pairs, load_params(None, sets), _pair_spec(tmp_path))
    return read_tracks(tmp_path / "tracks.csv"), json.loads((tmp_path / "pairs.json").read_text())


def test_a_pair_without_h_is_resolved_with_the_whole_runs_co_motion_h(tmp_path) -> None:
    """Online the pair learned no H and linked nobody (three people, one after another);
    after the run the co-motion search over all its candidates pairs them with an H within a
    pixel of the true one, and each person gets one meta in both cameras."""
    rows, pairs = _finish(tmp_path, [])
    metas = _meta_of(rows, rows.meta)
    assert all(metas["cam0", k] == metas["cam1", k] and len(metas["cam0", k]) == 1
               for k in (1, 2, 3))
    assert len({m for k in (1, 2, 3) for m in metas["cam0", k]}) == 3
    (pair,) = pairs
    found = pair["H_whole_run"]
    assert found["links"] == [[1, 1], [2, 2], [3, 3]] and found["used"]
    assert found["found_share"] > 0.95 and pair["H"] is None
    pts = np.array([w[0] for w in WALKS] + [w[1] for w in WALKS])
    err = transfer_errors(np.array(found["H"]), pts, apply_homography(TRUE_H, pts))
    assert err.max() < 1.0


@pytest.mark.parametrize("off", ["resolve.whole_run_h=false", "matcher.method=fov"])
def test_without_the_whole_run_search_a_pair_without_h_keeps_its_own_links(tmp_path,
                                                                          off: str) -> None:
    """Turned off, or with the FOV-only baseline (which must not use a homography)."""
    rows, pairs = _finish(tmp_path, [off])
    metas = _meta_of(rows, rows.meta)
    assert all(metas["cam0", k] != metas["cam1", k] for k in (1, 2, 3))
    assert "H_whole_run" not in pairs[0]  # the stale key of an earlier finish is gone


def test_a_whole_run_h_that_finds_too_few_targets_is_not_used(tmp_path) -> None:
    """cam1 misses the third person for their last 100 frames: of the targets the H projects
    well inside the other camera, a share under 0.95 finds one there (still over 0.6)."""
    rows, pairs = _finish(tmp_path, ["resolve.whole_run_h_min_found_share=0.95"], range(360, 460))
    found = pairs[0]["H_whole_run"]
    assert 0.6 < found["found_share"] < 0.95 and not found["used"]
    metas = _meta_of(rows, rows.meta)
    assert all(metas["cam0", k] != metas["cam1", k] for k in (1, 2, 3))
    _, pairs = _finish(tmp_path, [], range(360, 460))
    assert pairs[0]["H_whole_run"]["used"]


def test_the_whole_run_h_replaces_a_final_h_whose_projections_find_few_targets(tmp_path
                                                                              ) -> None:
    """The run ended with an H 60 px off (everyone projected a body height away): nobody was
    linked by it, and the whole run's H, whose projections find their targets, replaces it.
    A right final H is kept (the whole run's finds no more)."""
    wrong = TRUE_H.copy()
    wrong[0, 2] += 60.0
    rows, pairs = _finish(tmp_path, [], final_H=wrong)
    found = pairs[0]["H_whole_run"]
    assert found["final_found_share"] < 0.1 and found["found_share"] > 0.95 and found["used"]
    metas = _meta_of(rows, rows.meta)
    assert all(metas["cam0", k] == metas["cam1", k] and len(metas["cam0", k]) == 1
               for k in (1, 2, 3))
    _, pairs = _finish(tmp_path, [], final_H=TRUE_H)
    found = pairs[0]["H_whole_run"]
    assert found["final_found_share"] > 0.99 and not found["used"]
    _, pairs = _finish(tmp_path, ["resolve.whole_run_h_margin=1"], final_H=wrong)
    assert not pairs[0]["H_whole_run"]["used"]


def test_found_share_of_the_true_and_of_a_wrong_homography() -> None:
    run = list(camera_frames(_unlinked_run(), ("cam0", "cam1"), {"cam0": (320, 240),
                                                                  "cam1": (320, 240)}))
    assert len(run) == 460 and sum(len(a) for _, a, _ in run) == 600
    assert found_share(TRUE_H, run, HomographyConfig()) > 0.99
    wrong = TRUE_H.copy()
    wrong[0, 2] += 60.0  # everyone projected 60 px (over a body height) to the right
    assert found_share(wrong, run, HomographyConfig()) < 0.1


def _off_by(dx_px: float) -> np.ndarray:
    """TRUE_H followed by a shift of ``dx_px`` along x in cam1."""
    return np.array([[1.0, 0.0, dx_px], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) @ TRUE_H


def _walk_error(H: list) -> float:
    """Largest transfer error (px) of ``H`` at the walks' ends."""
    pts = np.array([w[0] for w in WALKS] + [w[1] for w in WALKS])
    return float(transfer_errors(np.array(H), pts, apply_homography(TRUE_H, pts)).max())


def test_the_pairs_h_is_fitted_again_from_the_whole_run_labels(tmp_path) -> None:
    """The run ended with an H 6 px off (within the vote gate, so it joins each person's two
    targets); fitted again on every marker frame where both targets are inside (three walks
    of 200 frames, one in five: 120 markers) it is within a pixel of the true H, and handed
    on (`--geometry` reads it)."""
    rows, pairs = _finish(tmp_path, [], final_H=_off_by(6.0))
    metas = _meta_of(rows, rows.meta)
    assert all(metas["cam0", k] == metas["cam1", k] for k in (1, 2, 3))
    refit = pairs[0]["H_refit"]
    assert refit["markers"] == 120 and refit["inliers"] >= 115 and refit["used"]
    assert refit["found_share"] >= refit["in_use_found_share"] - 0.02
    assert _walk_error(pairs[0]["H"]) > 5.0 and _walk_error(refit["H"]) < 1.0
    (learned,) = read_pairs(tmp_path / "pairs.json")
    assert np.allclose(learned.H_b_from_a, refit["H"]) and learned.markers == 120


def test_the_refit_hands_on_the_fov_lines_its_h_gives(tmp_path) -> None:
    """The run's line of cam0's left border seen in cam1 came from its H (6 px off); the
    refit's is that border through the refit H, within a pixel of the true one where people
    walk. A line from events stays as it was."""
    off = _off_by(6.0)
    from_h = {"seen_in": "cam1", "edge_of": "cam0", "side": "left", "events": 4,
              "from_frame": 300, "source": "homography",
              "line": list(border_line(off, "left", (320, 240)))}
    from_events = {"seen_in": "cam0", "edge_of": "cam1", "side": "right", "events": 3,
                   "from_frame": 200, "source": "events", "line": [1.0, 0.0, -250.0]}
    _, pairs = _finish(tmp_path, [], final_H=off, lines=(from_h, from_events))
    refit = pairs[0]["H_refit"]
    left, right = refit["fov_lines"]
    assert right == from_events and left["source"] == "refit"
    border = apply_homography(TRUE_H, np.c_[np.full(5, -0.5), np.linspace(60.0, 220.0, 5)])

    def off_px(line: list) -> float:
        return float(np.abs(border @ np.array(line[:2]) + line[2]).max())

    assert off_px(from_h["line"]) > 4.0 and off_px(left["line"]) < 1.0
    (learned,) = read_pairs(tmp_path / "pairs.json")
    assert [line[3] for line in learned.lines] == [tuple(left["line"]), tuple(right["line"])]
    whole_run = pairs[0]["H_whole_run"]  # its H's lines too, in case it is handed on
    left, right = whole_run["fov_lines"]
    assert right == from_events and left["source"] == "whole_run"
    assert left["line"] == list(border_line(np.array(whole_run["H"]), "left", (320, 240)))


def test_a_refit_without_markers_fails_with_a_reason_and_the_h_in_use_is_handed_on(
        tmp_path) -> None:
    """Markers every 10000 frames: one (the first person at frame 0), no refit."""
    _, pairs = _finish(tmp_path, ["markers.marker_every_frames=10000"], final_H=_off_by(6.0))
    refit = pairs[0]["H_refit"]
    assert refit["H"] is None and refit["markers"] == 1 and not refit["used"]
    assert "1 markers, need 4" in refit["reason"]
    (learned,) = read_pairs(tmp_path / "pairs.json")
    assert np.allclose(learned.H_b_from_a, pairs[0]["H"])


@pytest.mark.parametrize("off", ["resolve.refit_h=false", "matcher.method=fov"])
def test_no_refit_when_turned_off_or_for_the_fov_baseline(tmp_path, off: str) -> None:
    _, pairs = _finish(tmp_path, [off], final_H=_off_by(6.0))
    assert "H_refit" not in pairs[0]
