"""Consistent labels end to end on synthetic worlds, and the label figures of `mvtrack eval`.

The worlds are drawn without pixels: people walk straight lines on a ground plane seen by
pinhole cameras; each camera's "detector" gives the truth box and feet of every person whose
feet are inside its frame (and who is not behind the pillar), with a perfect single-camera
tracker whose ids change after every gap. The whole multi-camera pipeline runs on them, with
each pair's learned homography replaced by the true one (``H_b_from_a = G_b G_a^-1`` from the
cameras' ground-to-image homographies): the numbers isolate the matcher, the meta-targets and
the cues from the front end and from pair learning (tested in test_pair.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pytest

from mvtrack import pipeline
from mvtrack.evaluate.labels import LabelConfig, label_metrics
from mvtrack.io import CameraSpec, Detections
from mvtrack.io.results import CueRows, TrackRows
from mvtrack.io.truth import CameraTruth, Truth, WorldTruth
from mvtrack.params import Params, load_params
from mvtrack.pipeline import FrameResult, Pipeline
from mvtrack.stages.homography import HomographyEstimate

SIZE = (320, 240)
HEIGHT_M = 1.7


def camera_matrix(pos: tuple[float, float, float], look: tuple[float, float], f_px: float,
                  roll: float = 0.0) -> np.ndarray:
    """(3, 4) projection of a camera at ``pos`` looking at ground point ``look``."""
    c = np.asarray(pos, float)
    fwd = np.array([look[0], look[1], 0.0]) - c
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(fwd, right)
    R = np.stack([right, down, fwd])
    cr, sr = np.cos(roll), np.sin(roll)
    R = np.array([[cr, -sr, 0], [sr, cr, 0], [0, 0, 1]]) @ R
    K = np.array([[f_px, 0, SIZE[0] / 2 - 0.5], [0, f_px, SIZE[1] / 2 - 0.5], [0, 0, 1]])
    return K @ np.column_stack([R, -R @ c])


def project(P: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    h = np.column_stack([xyz, np.ones(len(xyz))]) @ P.T
    return h[:, :2] / h[:, 2:3]


@dataclass
class World:
    cameras: dict[str, np.ndarray]
    overlaps: list[tuple[str, str]]
    paths: list[tuple[int, np.ndarray, np.ndarray]]  # (start frame, start xy, velocity m/frame)
    frames: int
    hidden: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    walk_frames: int = 160

    def positions(self, k: int) -> dict[int, np.ndarray]:
        return {pid: p0 + v * (k - t0) for pid, (t0, p0, v) in enumerate(self.paths, 1)
                if t0 <= k < t0 + self.walk_frames}


def make_world(kind: str, seed: int = 0, frames: int = 300, people: int = 24) -> World:
    rng = np.random.default_rng(seed)
    if kind == "three":
        cams = {"cam0": camera_matrix((-7, -5, 8), (-7, 3), 420),
                "cam2": camera_matrix((0, -5, 8), (0, 3), 420),
                "cam1": camera_matrix((7, -5, 8), (7, 3), 420)}
        overlaps = [("cam0", "cam2"), ("cam1", "cam2")]
    else:
        roll = 0.3 if kind == "tilted" else 0.0
        cams = {"cam0": camera_matrix((-3, -5, 8), (-2, 3), 420),
                "cam1": camera_matrix((3, -4, 7), (2, 3), 400, roll)}
        overlaps = [("cam0", "cam1")]
    paths = []
    span = 10.0 if kind == "three" else 5.0
    for _ in range(people):
        t0 = int(rng.integers(-60, frames - 60))
        centre = np.array([rng.uniform(-span, span), rng.uniform(0.5, 5.5)])
        heading = rng.uniform(0, 2 * np.pi)
        if kind == "three":
            heading = rng.choice([0.0, np.pi]) + rng.normal(0, 0.15)
        v = 0.055 * np.array([np.cos(heading), np.sin(heading)])
        paths.append((t0, centre - v * 80, v))
    hidden = {"cam1": (-0.5, 1.0, 0.0, 6.0)} if kind == "pillar" else {}
    walk = 400 if kind == "three" else 160
    return World(cams, overlaps, paths, frames, hidden, walk)


@dataclass
class Sim:
    """Per-frame detections of a world and the matching truth."""

    world: World
    detections: list[dict[str, Detections]]
    truth_rows: dict[str, list[tuple]]


def simulate(world: World) -> Sim:
    dets: list[dict[str, Detections]] = []
    rows: dict[str, list[tuple]] = {c: [] for c in world.cameras}
    track: dict[tuple[str, int], tuple[int, int]] = {}  # (cam, person) -> (id, last frame)
    next_id = {c: 1 for c in world.cameras}
    for k in range(world.frames):
        frame = {}
        for name, P in world.cameras.items():
            boxes, feet, ids = [], [], []
            for pid, xy in world.positions(k).items():
                foot = project(P, np.array([[xy[0], xy[1], 0.0]]))[0]
                head = project(P, np.array([[xy[0], xy[1], HEIGHT_M]]))[0]
                h = float(np.linalg.norm(foot - head))
                if not (0 <= foot[0] <= SIZE[0] - 1 and 0 <= foot[1] <= SIZE[1] - 1):
                    continue
                box = (foot[0] - 0.18 * h, foot[1] - h, 0.36 * h, h)
                x0, y0, x1, y1 = world.hidden.get(name, (0, 0, -1, -1))
                behind = x0 <= xy[0] <= x1 and y0 <= xy[1] <= y1
                rows[name].append((k, pid, *foot, *box, 0.0 if behind else 1.0))
                if behind:
                    continue
                tid, last = track.get((name, pid), (0, -2))
                if last != k - 1:
                    tid, next_id[name] = next_id[name], next_id[name] + 1
                track[name, pid] = (tid, k)
                boxes.append(box)
                feet.append(foot)
                ids.append(tid)
            n = len(ids)
            frame[name] = Detections(np.asarray(boxes, float).reshape(n, 4), np.ones(n),
                                     np.asarray(feet, float).reshape(n, 2),
                                     np.asarray(ids, np.int64))
        dets.append(frame)
    return Sim(world, dets, rows)


def truth_of(sim: Sim) -> Truth:
    cams = {}
    for name, rows in sim.truth_rows.items():
        a = np.asarray(rows, float).reshape(-1, 9)
        cams[name] = CameraTruth(name, a[:, 0].astype(np.int64), a[:, 1].astype(np.int64),
                                 a[:, 2:4], a[:, 4:8], a[:, 8])
    world = [(k, pid, *xy) for k in range(sim.world.frames)
             for pid, xy in sim.world.positions(k).items()]
    w = np.asarray(world, float)
    return Truth(Path("."), cams, {}, "m",
                 WorldTruth(w[:, 0].astype(np.int64), w[:, 1].astype(np.int64), w[:, 2:4]))


@dataclass
class Run:
    tracks: TrackRows
    cues: CueRows
    last: FrameResult


def true_homography(sim: Sim, a: str, b: str) -> HomographyEstimate:
    G = {n: P[:, [0, 1, 3]] for n, P in sim.world.cameras.items()}
    H = G[b] @ np.linalg.inv(G[a])
    return HomographyEstimate(H / np.linalg.norm(H), "truth", 0, np.zeros(0, bool),
                              np.zeros(0), 0.0, 0)


def run_pipeline(sim: Sim, params: Params, mp: pytest.MonkeyPatch) -> Run:
    """The pipeline over the world's detections, pair homographies replaced by the truth."""
    learned = pipeline.pair_step

    def pair_step_true_h(state, a, b, cfg, frame, *, links=None):  # type: ignore[no-untyped-def]
        state, result = learned(state, a, b, cfg, frame, links=links)
        return state, replace(result, homography=true_homography(sim, *state.names))

    mp.setattr(pipeline, "pair_step", pair_step_true_h)
    specs = [CameraSpec(name=n, kind="detections", source=Path(f"{n}.csv"), size=SIZE,
                        modality="rgb", offset=0, length=sim.world.frames)
             for n in sim.world.cameras]
    pipe = Pipeline(specs, sim.world.overlaps, params, {})
    t: list[list] = [[] for _ in range(7)]
    c: list[list] = [[] for _ in range(5)]
    result = None
    for k, dets in enumerate(sim.detections):
        result = pipe.step(k, {}, dets)
        for name, cam in result.cameras.items():
            n = len(cam.targets)
            t[0] += [k] * n
            t[1] += [name] * n
            t[2] += cam.targets.labels.tolist()
            t[3] += result.metas[name].tolist()
            t[4] += cam.targets.feet.tolist()
            t[5] += cam.targets.boxes_xywh.tolist()
            t[6] += cam.targets.heights_px.tolist()
        for cue in result.cues:
            for col, v in zip(c, (k, cue.meta, cue.camera, cue.expected, cue.seen), strict=True):
                col.append(v)
    assert result is not None
    tracks = TrackRows(np.asarray(t[0], np.int64), np.asarray(t[1], str),
                       np.asarray(t[2], np.int64), np.asarray(t[3], np.int64),
                       np.asarray(t[4], float).reshape(-1, 2),
                       np.asarray(t[5], float).reshape(-1, 4), np.asarray(t[6], float))
    cues = CueRows(np.asarray(c[0], np.int64), np.asarray(c[1], np.int64),
                   np.asarray(c[2], str), np.asarray(c[3], bool), np.asarray(c[4], bool))
    return Run(tracks, cues, result)


_CACHE: dict[tuple[str, str], tuple[dict, Run]] = {}


def scores(kind: str, method: str = "homography") -> tuple[dict, Run]:
    if (kind, method) not in _CACHE:
        sim = simulate(make_world(kind))
        with pytest.MonkeyPatch.context() as mp:
            run = run_pipeline(sim, load_params(None, [f"matcher.method={method}"]), mp)
        m = label_metrics(truth_of(sim), run.tracks, range(sim.world.frames), run.cues,
                          LabelConfig())
        _CACHE[kind, method] = (m, run)
    return _CACHE[kind, method]


@pytest.mark.parametrize("kind", ["pair", "tilted"])
def test_pair_worlds_learn_h_and_label_consistently(kind: str) -> None:
    m, run = scores(kind)
    assert all(bool(p.homography) for p in run.last.pairs.values()), "H was never learned"
    assert m["idf1_global"] >= 0.85, m
    assert m["consistency"] >= 0.85, m
    assert m["cue_accuracy"] >= 0.85, m


def test_three_cameras_one_label_through_the_middle() -> None:
    m, run = scores("three")
    assert all(bool(p.homography) for p in run.last.pairs.values())
    assert m["consistency"] >= 0.85, m
    by_pair = m["consistency_by_pair"]  # cam0 and cam1 never see a person at the same time
    assert set(by_pair) == {"cam0-cam2", "cam1-cam2"}, by_pair
    assert min(p["consistency"] for p in by_pair.values()) >= 0.85, by_pair
    assert sum(p["pairs"] for p in by_pair.values()) == m["consistency_pairs"], by_pair
    assert m["idf1_global"] >= 0.8, m


def test_pillar_occlusions_recovered() -> None:
    m, _ = scores("pillar")
    assert m["occlusion_episodes"] >= 3, m
    assert m["occlusion_recovery"] >= 0.9, m


def test_homography_beats_fov_baseline() -> None:
    for kind in ("pair", "three"):
        ours, _ = scores(kind)
        base, _ = scores(kind, "fov")
        assert ours["idf1_global"] > base["idf1_global"], (kind, ours, base)


def hand_run(cam1_meta_after: int) -> dict:
    """One person, 40 frames: cam0 sees it throughout (meta 1); cam1 in frames 0-9 (meta 1)
    and 22-39 (``cam1_meta_after``), i.e. a 12-frame occlusion in cam1."""
    f0 = np.arange(40)
    f1 = np.concatenate([np.arange(10), np.arange(22, 40)])
    feet0 = np.column_stack([f0 * 2.0 + 10, np.full(40, 100.0)])
    feet1 = np.column_stack([f1 * 1.0 + 50, np.full(len(f1), 80.0)])
    truth = Truth(Path("."), {
        "cam0": CameraTruth("cam0", f0, np.ones(40, np.int64), feet0,
                            np.tile([0.0, 0, 10, 40], (40, 1)), np.ones(40)),
        "cam1": CameraTruth("cam1", f1, np.ones(len(f1), np.int64), feet1,
                            np.tile([0.0, 0, 10, 40], (len(f1), 1)), np.ones(len(f1))),
    }, {}, None, None)
    metas1 = np.where(f1 < 10, 1, cam1_meta_after)
    n = 40 + len(f1)
    rows = TrackRows(np.concatenate([f0, f1]), np.array(["cam0"] * 40 + ["cam1"] * len(f1)),
                     np.ones(n, np.int64), np.concatenate([np.ones(40, np.int64), metas1]),
                     np.concatenate([feet0, feet1]), np.zeros((n, 4)), np.full(n, 40.0))
    cues = CueRows(np.array([15, 15, 30]), np.array([1, 1, 1]), np.array(["cam0", "cam1", "cam1"]),
                   np.array([True, True, False]), np.array([True, False, True]))
    return label_metrics(truth, rows, range(40), cues)


def test_label_figures_hand_built() -> None:
    good = hand_run(1)
    assert good["idf1_global"] == pytest.approx(1.0)
    assert good["consistency"] == pytest.approx(1.0) and good["consistency_pairs"] == 28
    assert good["consistency_by_pair"] == {"cam0-cam1": {"consistency": 1.0, "pairs": 28}}
    assert good["metas_per_person"] == 1.0
    assert good["occlusion_episodes"] == 1 and good["occlusion_recovery"] == 1.0
    # cue rows: (15, cam0) right, (15, cam1) expected but absent in truth, (30, cam1) missed
    assert good["cue_accuracy"] == pytest.approx(1 / 3)
    assert good["creation_frames_median"] == 0
    bad = hand_run(3)
    assert bad["idf1_global"] == pytest.approx(2 * 50 / (68 + 68))
    assert bad["consistency"] == pytest.approx(10 / 28)
    assert bad["consistency_by_pair"]["cam0-cam1"]["consistency"] == pytest.approx(10 / 28)
    assert bad["metas_per_person"] == 2.0 and bad["occlusion_recovery"] == 0.0
