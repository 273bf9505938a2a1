"""Camera cueing: expected from projections through pair homographies, seen from membership."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from mvtrack.io.results import CUES_HEADER, read_cues
from mvtrack.params import MetaConfig
from mvtrack.stages.cues import CueInputs, camera_cues
from mvtrack.stages.meta import MetaInputs, meta_init, meta_step
from mvtrack.stages.targets import CameraTargets

SHIFT = np.array([[1.0, 0.0, -100.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])  # x_b = x_a - 100
SIZES = {"A": (200, 100), "B": (200, 100), "C": (50, 50)}
CFG = MetaConfig()


def cam(labels: list[int], feet: list[tuple[float, float]], size: tuple[int, int]) -> CameraTargets:
    n = len(labels)
    return CameraTargets(np.asarray(labels, np.int64), np.asarray(feet, float).reshape(n, 2),
                         np.full(n, 30.0), np.tile([0.0, 0.0, 5.0, 30.0], (n, 1)), size)


def metas_for(frames: list[dict[str, CameraTargets]]):
    state, r = meta_init(), None
    for k, cams in enumerate(frames):
        state, r = meta_step(state, MetaInputs(cams, [], k), CFG)
    return r


def cue_table(result, homographies, cfg: MetaConfig = CFG) -> dict[tuple[int, str], tuple]:
    cues = camera_cues(CueInputs(result, SIZES, homographies), cfg)
    return {(c.meta, c.camera): (c.expected, c.seen) for c in cues}


def test_expected_from_projection_seen_from_membership() -> None:
    # A sees meta 1 at x=150 (-> 50 in B: inside) and meta 2 at x=20 (-> -80: outside B)
    r = metas_for([{"A": cam([1, 2], [(150, 50), (20, 50)], SIZES["A"]),
                    "B": cam([], [], SIZES["B"]), "C": cam([], [], SIZES["C"])}])
    table = cue_table(r, {("A", "B"): SHIFT})
    assert table[1, "A"] == (True, True) and table[1, "B"] == (True, False)
    assert table[2, "B"] == (False, False)
    assert table[1, "C"] == (False, False)  # no homography into C
    assert len(table) == 2 * 3  # every live meta x every camera


def test_inverse_direction_and_margin() -> None:
    # B sees meta 1 at x=95 -> 195 in A: 4.5 px from the last column (199)
    r = metas_for([{"A": cam([], [], SIZES["A"]), "B": cam([3], [(95, 50)], SIZES["B"]),
                    "C": cam([], [], SIZES["C"])}])
    assert cue_table(r, {("A", "B"): SHIFT})[1, "A"] == (True, False)
    assert cue_table(r, {("A", "B"): SHIFT}, replace(CFG, cue_margin_px=5.0))[1, "A"] == (
        False, False)


def test_target_less_live_meta_projects_last_feet() -> None:
    empty = {"A": cam([], [], SIZES["A"]), "B": cam([], [], SIZES["B"]),
             "C": cam([], [], SIZES["C"])}
    r = metas_for([{**empty, "A": cam([1], [(150, 50)], SIZES["A"])}, empty])
    assert r.live == (1,) and r.members == {}
    table = cue_table(r, {("A", "B"): SHIFT})
    assert table[1, "B"] == (True, False) and table[1, "A"] == (False, False)


def test_no_live_metas_no_cues() -> None:
    r = metas_for([{"A": cam([], [], SIZES["A"])}])
    assert camera_cues(CueInputs(r, SIZES, {}), CFG) == ()


def test_cues_csv_round_trip(tmp_path) -> None:
    path = tmp_path / "cues.csv"
    path.write_text(",".join(CUES_HEADER) + "\n3,7,cam1,1,0\n4,7,cam0,0,1\n")
    rows = read_cues(path)
    assert rows.frame.tolist() == [3, 4] and rows.meta.tolist() == [7, 7]
    assert rows.camera.tolist() == ["cam1", "cam0"]
    assert rows.expected.tolist() == [True, False] and rows.seen.tolist() == [False, True]
    path.write_text("frame,meta\n1,2\n")
    with pytest.raises(ValueError, match="header"):
        read_cues(path)
