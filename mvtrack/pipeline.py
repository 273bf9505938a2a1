"""The per-frame pipeline and the driver loop that owns time.

    with open_clip(path) as clip:
        summary = run(clip, params, range(0, clip.spec.frame_count), sinks=[writer])

:func:`run` trains each video camera's background on the first frames of the range, then reads
synchronized frame sets one at a time, calls :meth:`Pipeline.step` and hands each
:class:`FrameResult` to the sinks (a results writer, the Rerun logger, a benchmark counter).
Nothing here keeps per-frame records: memory stays flat however long the clip.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from mvtrack.io import CameraSpec, Clip, ClipSpec, Detections
from mvtrack.io.results import (
    LearnedPair,
    TrackRows,
    read_tracks,
    rewrite_tracks,
    write_pairs,
)
from mvtrack.params import Params
from mvtrack.stages.background import (
    BackgroundResult,
    BackgroundState,
    background_step,
    train_background,
    training_offsets,
)
from mvtrack.stages.blobtrack import (
    TrackerState,
    TrackResult,
    track_boxes,
    track_masks,
    tracker_init,
)
from mvtrack.stages.cues import Cue, CueInputs, camera_cues
from mvtrack.stages.feet import (
    Feet,
    FeetState,
    feet_step,
    smooth_feet,
)
from mvtrack.stages.fov import border_line
from mvtrack.stages.homography import HomographyEstimate
from mvtrack.stages.markers import comotion_of_run
from mvtrack.stages.matcher import MatchInputs, MatchResult, match_init, match_step
from mvtrack.stages.meta import (
    Edge,
    MetaInputs,
    MetaResult,
    MetaState,
    cameras_apart,
    meta_init,
    meta_step,
)
from mvtrack.stages.pair import (
    PairConfigs,
    PairPrior,
    PairResult,
    found_share,
    pair_init,
    pair_step,
    pair_summary,
)
from mvtrack.stages.refit import RefitH, refit_homography
from mvtrack.stages.resolve import (
    Resolution,
    Rows,
    WholeRunH,
    camera_frames,
    resolve_labels,
)
from mvtrack.stages.targets import CameraTargets

__all__ = [
    "CameraResult", "CameraStep", "FrameResult", "Pipeline", "RunSummary", "Sink",
    "finish_results", "finish_rows", "resolve_rows", "run", "smoothed_feet",
    "tracking_differences",
]

STAGES = ("read", "background", "tracker", "feet", "pairs", "metas")
"""Stage names in timing tables, in pipeline order."""


@dataclass(frozen=True, eq=False)
class CameraResult:
    """One camera, one frame: every intermediate of the single-camera front end.

    image:      the frame as read ((H,W,3) BGR or (H,W) gray uint8); None for detections
    background: background subtraction's record; None for detections cameras
    tracks:     the single-camera tracker's record
    feet:       per target (``tracks.labels`` order), the feet record with its intermediates
    targets:    labels, feet, heights, boxes: what the multi-camera stages consume
    """

    camera: CameraSpec
    image: np.ndarray | None
    background: BackgroundResult | None
    tracks: TrackResult
    feet: tuple[Feet, ...]
    targets: CameraTargets


@dataclass(frozen=True, eq=False)
class FrameResult:
    """Everything computed at one clip frame.

    pairs: per overlapping pair (a, b), the pair-learning record (FOV, markers, homography)
    metas: per camera, (N,) int64 consistent label of each target (``targets.labels`` order)
    stage_ms: milliseconds spent per stage (:data:`STAGES`) in this frame, all cameras
    matches: per overlapping pair (a, b), the homography matcher's record (costs, links,
             confirmations, breaks, re-attachments, creations, expected-but-unseen)
    meta: the meta-target record (components, accepted links, conflicts, merges, splits)
    cues: per live meta-target and camera, expected / seen (``cues.csv``)
    """

    index: int
    cameras: Mapping[str, CameraResult]
    pairs: Mapping[tuple[str, str], PairResult]
    metas: Mapping[str, np.ndarray]
    stage_ms: Mapping[str, float]
    matches: Mapping[tuple[str, str], MatchResult] = field(default_factory=dict)
    meta: MetaResult | None = None
    cues: tuple[Cue, ...] = ()


@dataclass(frozen=True)
class _CameraState:
    background: BackgroundState | None
    tracker: TrackerState
    feet: FeetState = field(default_factory=FeetState)


def _edges(matches: Mapping[tuple[str, str], MatchResult]) -> list[Edge]:
    """Every pair's links as meta-graph edges, with their evidence."""
    return [
        Edge((a, link.a), (b, link.b), float(link.confirmations + 1), link.since, link.source)
        for (a, b), m in matches.items()
        for link in m.links
    ]


def _shared(members: Mapping[int, tuple[tuple[str, int], ...]],
            a: str, b: str) -> list[tuple[int, int]]:
    """(A label, B label) pairs that share a meta-target."""
    out = []
    for nodes in members.values():
        in_a = [label for cam, label in nodes if cam == a]
        in_b = [label for cam, label in nodes if cam == b]
        if in_a and in_b:
            out.append((in_a[0], in_b[0]))
    return out


class _Timer:
    def __init__(self) -> None:
        self.ms: dict[str, float] = dict.fromkeys(STAGES, 0.0)

    @contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        start = time.perf_counter()
        try:
            yield
        finally:
            self.ms[stage] += 1000.0 * (time.perf_counter() - start)


CameraStep = Callable[[int, CameraSpec], CameraResult]
"""A replacement front end: (clip frame index, camera) -> that camera's :class:`CameraResult`.

``mvtrack-view --watch`` replays a finished run's camera results through it, so only the pair
stages are recomputed when the front-end thresholds did not change.
"""


class Pipeline:
    """The per-frame computation over all cameras. Holds only the current states.

    A small class because the driver, the viewer and the benchmark all step it; every stage
    inside is a pure ``step(state, inputs, cfg) -> (state, result)``.

    ``camera_step``, when given, supplies every camera's result instead of the front end
    (background, tracker, feet); the images and detections passed to :meth:`step` are then
    ignored and the front-end states are never advanced.
    """

    def __init__(self, cameras: Sequence[CameraSpec], overlaps: Sequence[tuple[str, str]],
                 params: Params, backgrounds: Mapping[str, BackgroundState],
                 camera_step: CameraStep | None = None,
                 priors: Mapping[tuple[str, str], PairPrior] | None = None) -> None:
        self.cameras = tuple(cameras)
        self.params = params
        self._replay = camera_step
        self._pair_cfg = PairConfigs.from_params(params)
        self._states = {
            c.name: _CameraState(backgrounds.get(c.name), tracker_init()) for c in self.cameras
        }
        size = {c.name: c.size for c in self.cameras}
        self._pairs = {
            (a, b): pair_init((a, b), (size[a], size[b]), (priors or {}).get((a, b)))
            for a, b in overlaps if a in size and b in size
        }
        self._matchers = {pair: match_init(pair) for pair in self._pairs}
        self._apart = cameras_apart(list(size), list(self._pairs))
        self._metas: MetaState = meta_init()
        self._members: Mapping[int, tuple[tuple[str, int], ...]] = {}
        self._pool: ThreadPoolExecutor | None = None  # front ends of cameras 2.. (step)

    def pair_summaries(self) -> list[dict[str, Any]]:
        """One `pairs.json` object per overlapping pair (FORMATS.md), as learned so far."""
        return [pair_summary(state) for state in self._pairs.values()]

    def step(self, index: int, images: Mapping[str, np.ndarray],
             detections: Mapping[str, Detections], read_ms: float = 0.0) -> FrameResult:
        timer = _Timer()
        timer.ms["read"] = read_ms
        results = self._camera_steps(index, images, detections, timer)
        pairs = {}
        with timer("pairs"):
            for (a, b), state in self._pairs.items():
                self._pairs[a, b], pairs[a, b] = pair_step(
                    state, results[a].targets, results[b].targets, self._pair_cfg, index,
                    links=_shared(self._members, a, b),
                )
        with timer("metas"):
            matches, meta, cues = self._meta_step(index, results, pairs)
        return FrameResult(index=index, cameras=results, pairs=pairs, metas=meta.metas,
                           stage_ms=timer.ms, matches=matches, meta=meta, cues=cues)

    def _meta_step(self, index: int, results: Mapping[str, CameraResult],
                   pairs: Mapping[tuple[str, str], PairResult]) -> tuple[
            dict[tuple[str, str], MatchResult], MetaResult, tuple[Cue, ...]]:
        """Homography matching per pair, meta-targets over all cameras, camera cues."""
        matches = {}
        for (a, b), pr in pairs.items():
            inputs = MatchInputs(results[a].targets, results[b].targets, pr.homography,
                                 pr.associations, index)
            self._matchers[a, b], matches[a, b] = match_step(
                self._matchers[a, b], inputs, self.params.matcher)
        targets = {name: cam.targets for name, cam in results.items()}
        linked = MetaInputs(targets, _edges(matches), index, apart=self._apart)
        self._metas, meta = meta_step(self._metas, linked, self.params.meta)
        self._members = meta.members
        homographies = {
            pair: pr.homography.H_b_from_a for pair, pr in pairs.items()
            if isinstance(pr.homography, HomographyEstimate)
        }
        sizes = {c.name: c.size for c in self.cameras}
        cues = camera_cues(CueInputs(meta, sizes, homographies), self.params.meta)
        return matches, meta, cues

    def _camera_steps(self, index: int, images: Mapping[str, np.ndarray],
                      detections: Mapping[str, Detections],
                      timer: _Timer) -> dict[str, CameraResult]:
        """Every camera's front end, the cameras concurrently (one thread each, the first on
        the caller's). Each camera's stages read and write only that camera's state, and OpenCV
        and numpy release the GIL, so on two cores two cameras take about the time of one;
        the results are the same as one after the other. Stage times add up over cameras."""
        if self._replay is not None:
            return {cam.name: self._replay(index, cam) for cam in self.cameras}
        timers = [_Timer() for _ in self.cameras]
        jobs = [(cam, images.get(cam.name), detections.get(cam.name), t)
                for cam, t in zip(self.cameras, timers, strict=True)]
        if len(jobs) > 1 and self._pool is None:
            self._pool = ThreadPoolExecutor(len(jobs) - 1, thread_name_prefix="mvtrack-camera")
        futures = [self._pool.submit(self._camera_step, *job)
                   for job in jobs[1:]] if self._pool is not None else []
        first = [self._camera_step(*jobs[0])] if jobs else []
        done = first + [f.result() for f in futures]
        for t in timers:
            for stage, ms in t.ms.items():
                timer.ms[stage] += ms
        return {res.camera.name: res for res in done}

    def _camera_step(self, cam: CameraSpec, image: np.ndarray | None,
                     dets: Detections | None, timer: _Timer) -> CameraResult:
        state, p = self._states[cam.name], self.params
        bg_state, bg = state.background, None
        with timer("background"):
            if image is not None and bg_state is not None:
                bg_state, bg = background_step(bg_state, image, p.background)
        with timer("tracker"):
            if bg is not None and bg_state is not None:
                tracker, tracks = track_masks(state.tracker, bg.mvo_labels, image, p.tracker,
                                              bg_state.sizes)
            else:
                d = dets if dets is not None else Detections.empty()
                tracker, tracks = track_boxes(state.tracker, d.boxes_xywh, d.tracks, p.tracker,
                                              feet_xy=d.feet)
        with timer("feet"):
            feet_state, feet = feet_step(state.feet, tracks, p.feet,
                                         None if bg_state is None else bg_state.sizes)
        self._states[cam.name] = _CameraState(bg_state, tracker, feet_state)
        targets = CameraTargets(
            labels=tracks.labels,
            feet=np.array([f.point for f in feet]).reshape(-1, 2),
            heights_px=np.array([f.height_px for f in feet], np.float64),
            boxes_xywh=tracks.boxes_xywh,
            size=cam.size,
        )
        return CameraResult(cam, image, bg, tracks, feet, targets)


class Sink(Protocol):
    """Receives every frame's result; a results writer, the Rerun logger, a counter."""

    def on_frame(self, result: FrameResult) -> None: ...


@dataclass
class RunSummary:
    """What a run did: frames processed and seconds per stage (all cameras)."""

    frames: int = 0
    train_seconds: float = 0.0
    stage_seconds: dict[str, float] = field(default_factory=lambda: dict.fromkeys(STAGES, 0.0))
    interrupted: bool = False
    pairs: list[dict[str, Any]] = field(default_factory=list)


def train_backgrounds(clip: Clip, frames: range, params: Params) -> dict[str, BackgroundState]:
    """Each video camera's initial background: the median of the frames of ``frames`` at
    :func:`~mvtrack.stages.background.training_offsets` (``train_frames`` of them,
    ``train_spacing_frames`` apart)."""
    video = [c for c in clip.spec.cameras if c.kind != "detections"]
    if not video:
        return {}
    picked = {frames[int(i)] for i in training_offsets(len(frames), params.background)}
    stacks: dict[str, list[np.ndarray]] = {c.name: [] for c in video}
    for fs in clip.frames(range(frames.start, max(picked) + 1)):
        if fs.index in picked:
            for c in video:
                stacks[c.name].append(fs.images[c.name])
    return {
        c.name: train_background(stacks[c.name], c.modality, params.background) for c in video
    }


def resolve_rows(rows: Rows, pairs: Sequence[dict[str, Any]], params: Params,
                 spec: ClipSpec) -> Resolution:
    """Whole-run labels (`stages/resolve.py`) of a run's target rows, with the pairs' final
    homographies (`pairs.json` objects); the FOV-only matcher resolves without them. With
    ``resolve.whole_run_h`` each pair's whole run is searched for a co-motion homography
    (:func:`whole_run_h`, in the resolution's ``comotion``), whose H is used instead where it
    is found better. With ``resolve.refit_h`` each pair's H is then fitted again from the
    resolved labels (:func:`refit_h`, in the resolution's ``refit``)."""
    use_h = params.matcher.method != "fov"
    searched = use_h and (params.resolve.whole_run_h or params.resolve.refit_h)
    sizes = {c.name: c.size for c in spec.cameras}
    final: list[tuple[str, str, np.ndarray | None]] = []
    runs = {}
    comotion: dict[tuple[str, str], WholeRunH | None] = {}
    shares: dict[tuple[str, str], float | None] = {}  # found share of the H the labels use
    for p in pairs:
        a, b = p["cameras"]
        H = None if p["H"] is None else np.asarray(p["H"], np.float64)
        runs[a, b] = list(camera_frames(rows, (a, b), sizes)) if searched else []
        if use_h and params.resolve.whole_run_h:
            found = comotion[a, b] = whole_run_h(runs[a, b], H, params)
            if found is not None:
                shares[a, b] = found.found_share if found.used else found.final_share
                H = found.hypothesis.H_b_from_a if found.used else H
        final.append((a, b, H))
    res = resolve_labels(rows, final, params.resolve, use_h=use_h, sizes=sizes,
                         overlaps=spec.overlaps)
    refit = {}
    if use_h and params.resolve.refit_h:
        for a, b, H in final:
            if (a, b) not in shares:
                shares[a, b] = (None if H is None
                                else found_share(H, runs[a, b], params.homography))
            refit[a, b] = refit_h(rows, res.meta, (a, b), sizes, runs[a, b], shares[a, b],
                                  params=params)
    return replace(res, comotion=comotion, refit=refit)


def refit_h(  # noqa: PLR0913 (the run, its labels, the pair, the H in use's share, thresholds)
    rows: Rows, meta: np.ndarray, names: tuple[str, str], sizes: Mapping[str, tuple[int, int]],
    run: Sequence[tuple[int, CameraTargets, CameraTargets]], in_use_share: float | None, *,
    params: Params,
) -> RefitH:
    """A pair's H fitted again from the whole-run labels ``meta`` (:func:`~mvtrack.stages.
    refit.refit_homography`), and whether it is the H the run hands on: a valid refit is,
    unless the share of the targets it projects into the other camera that find one there
    (:func:`~mvtrack.stages.pair.found_share` over ``run``, the pair's frames) is lower than
    that of the H the labels used (``in_use_share``; None: none, or it projects none there)
    by more than ``resolve.refit_h_max_share_drop``."""
    est, markers = refit_homography(rows, meta, names, sizes, params.markers, params.homography)
    share = (found_share(est.H_b_from_a, run, params.homography)
             if isinstance(est, HomographyEstimate) else None)
    drop = params.resolve.refit_h_max_share_drop
    used = bool(est) and (in_use_share is None
                          or (share is not None and share >= in_use_share - drop))
    return RefitH(est, len(markers), share, in_use_share, used)


def whole_run_h(run: Sequence[tuple[int, CameraTargets, CameraTargets]],
                final_H: np.ndarray | None, params: Params) -> WholeRunH | None:
    """The co-motion hypothesis of a pair's whole run (``run``: its frames as
    :func:`~mvtrack.stages.resolve.camera_frames` gives them; None when the search finds
    none). Its H is used when enough of the targets it projects into the other camera find
    one there (``resolve.whole_run_h_min_found_share``) and, if the run ended with an H
    (``final_H``), more than of that one's by ``resolve.whole_run_h_margin``."""
    cfg = params.resolve
    found = comotion_of_run(run, params.markers, params.homography.ransac_seed,
                            cfg.whole_run_h_top_cut)
    if found is None:
        return None
    share = found_share(found.H_b_from_a, run, params.homography)
    final = None if final_H is None else found_share(final_H, run, params.homography)
    used = share is not None and share >= cfg.whole_run_h_min_found_share and (
        final_H is None or share > (final or 0.0) + cfg.whole_run_h_margin)
    return WholeRunH(found, share, final, used)


def smoothed_feet(rows: TrackRows, params: Params, fps: float) -> np.ndarray:
    """(N, 2) each target's feet smoothed over the run (:func:`~mvtrack.stages.feet.
    smooth_feet`, ``feet.smooth_seconds`` at ``fps``)."""
    _, cam = np.unique(rows.camera, return_inverse=True)
    track = cam.astype(np.int64) * (int(rows.target.max(initial=0)) + 1) + rows.target
    cfg = params.feet
    return smooth_feet(rows.frame, track, rows.feet, rows.height,
                       round(cfg.smooth_seconds * fps), cfg.smooth_break_heights)


def finish_rows(rows: TrackRows, pairs: Sequence[dict[str, Any]], params: Params,
                spec: ClipSpec) -> tuple[TrackRows, Resolution | None]:
    """A whole run's rows as `mvtrack track` finally writes them: each target's feet smoothed
    over time (:func:`smoothed_feet`) and, with ``resolve.labels = "whole_run"``, the metas
    resolved over the whole run (:func:`resolve_rows`, returned too; else None). The
    resolution reads the feet as measured: resolving with the smoothed ones lost up to 0.12
    consistency on three of 72 generated runs (its votes and jump tests were tuned on these)."""
    smooth = replace(rows, feet=smoothed_feet(rows, params, spec.fps))
    if params.resolve.labels != "whole_run":
        return smooth, None
    res = resolve_rows(rows, pairs, params, spec)
    return replace(smooth, meta=res.meta), res


_FINISH_ONLY = ("resolve.", "feet.smooth_seconds", "feet.smooth_break_heights")
"""Thresholds only :func:`finish_rows` reads (``section.key`` or a section's prefix)."""


def tracking_differences(a: Params, b: Params) -> list[str]:
    """The thresholds (``section.key``) in which ``a`` and ``b`` differ, without those only
    :func:`finish_rows` reads (the ``resolve`` section, ``feet.smooth_*``). None: a run made
    with either, finished again with the other (:func:`~mvtrack.batch.refinish_to`), is the
    run the other makes."""
    keys = []
    for section in fields(a):
        x, y = getattr(a, section.name), getattr(b, section.name)
        keys += [f"{section.name}.{f.name}" for f in fields(x)
                 if getattr(x, f.name) != getattr(y, f.name)]
    return [k for k in keys if not k.startswith(_FINISH_ONLY)]


def finish_results(out_dir: Path, pairs: Sequence[dict[str, Any]], params: Params,
                   spec: ClipSpec) -> None:
    """Rewrite a finished results directory's `tracks.csv` and `cues.csv` with
    :func:`finish_rows` (the streamed ones stay as `*_online.csv`; nothing to do with neither
    smoothing nor whole-run labels), and `pairs.json` with the whole-run homographies
    (:func:`_with_whole_run_geometry`)."""
    res = None
    if params.feet.smooth_seconds > 0 or params.resolve.labels == "whole_run":
        rows = read_tracks(Path(out_dir) / "tracks.csv")
        final, res = finish_rows(rows, pairs, params, spec)
        rewrite_tracks(out_dir, final, (lambda f, m: m) if res is None else res.cue_meta)
    write_pairs(out_dir, [_with_whole_run_geometry(p, res) for p in pairs])


def _with_whole_run_geometry(pair: dict[str, Any], res: Resolution | None) -> dict[str, Any]:
    """A `pairs.json` object with what the whole-run labels learned of its geometry, where
    they were resolved with homographies. ``H_whole_run`` as the resolution found it (:func:
    `whole_run_h`): null (no hypothesis), or ``{"H", "links" ([A label, B label] pairs),
    "candidates" (its inliers), "found_share", "final_found_share" (of ``H``), "fov_lines"
    (:func:`_lines_through`), "used" (by the labels, and handed on unless the refit is)}``;
    ``H_refit`` (:func:`refit_h`): ``{"H" (null when the fit failed, with "reason"),
    "markers", "inliers", "quality_px", "fov_lines" (:func:`_lines_through`), "found_share",
    "in_use_found_share" (of the H the labels used), "used" (handed on: `--geometry` takes its
    H and lines instead of the pair's; else it takes the H the labels used)}``."""
    pair = {k: v for k, v in pair.items() if k not in ("H_whole_run", "H_refit")}
    key = (pair["cameras"][0], pair["cameras"][1])
    if res is not None and key in res.comotion:
        found = res.comotion[key]
        pair["H_whole_run"] = None if found is None else {
            "H": found.hypothesis.H_b_from_a.tolist(),
            "links": [list(link) for link in found.hypothesis.links],
            "candidates": len(found.hypothesis.markers), "found_share": found.found_share,
            "final_found_share": found.final_share,
            "fov_lines": _lines_through(found.hypothesis.H_b_from_a, pair, "whole_run"),
            "used": found.used}
    if res is not None and key in res.refit:
        refit = res.refit[key]
        est = refit.estimate
        pair["H_refit"] = ({"H": est.H_b_from_a.tolist(), "inliers": int(est.inliers.sum()),
                            "quality_px": est.quality_px,
                            "fov_lines": _lines_through(est.H_b_from_a, pair, "refit")}
                           if isinstance(est, HomographyEstimate)
                           else {"H": None, "reason": est.reason}) | {
            "markers": refit.markers, "found_share": refit.found_share,
            "in_use_found_share": refit.in_use_share, "used": refit.used}
    return pair


def _lines_through(H_b_from_a: np.ndarray, pair: Mapping[str, Any],
                   source: str) -> list[dict[str, Any]]:
    """A `pairs.json` object's FOV lines, those its H gave (source "homography": the other
    camera's border through H) given again through ``H_b_from_a`` (with ``source``)."""
    out = []
    for line in pair.get("fov_lines", []):
        if line.get("source") != "homography":
            out.append(line)
            continue
        seen = pair["cameras"].index(line["seen_in"])
        H = H_b_from_a if seen == 1 else np.linalg.inv(H_b_from_a)
        width, height = pair["sizes"][1 - seen]
        out.append(line | {"line": list(border_line(H, line["side"], (width, height))),
                           "source": source})
    return out


def priors_from(learned: Sequence[LearnedPair], overlaps: Sequence[tuple[str, str]],
                source: str, cameras: Sequence[str] | None = None,
                ) -> dict[tuple[str, str], PairPrior]:
    """Each overlap's :class:`PairPrior` from an earlier run's `pairs.json` (read by
    :func:`~mvtrack.io.results.read_pairs`; a pair stored as (B, A) is turned around). Pairs
    with a camera outside ``cameras`` (the cameras in use, when given) are skipped. Raises
    ValueError naming ``source`` for a pair the clip does not declare."""
    priors = {}
    for k, pair in enumerate(learned):
        if cameras is not None and not set(pair.cameras) <= set(cameras):
            continue
        a, b = pair.cameras
        H = pair.H_b_from_a
        if (a, b) not in overlaps and (b, a) in overlaps:
            a, b = b, a
            H = None if H is None else np.linalg.inv(H)
        elif (a, b) not in overlaps:
            raise ValueError(f"{source}: pair {k} {pair.cameras} is not an overlap of this clip "
                             f"(overlaps: {list(overlaps)})")
        lines = tuple((seen, side, line, events) for seen, _, side, line, events in pair.lines)
        if any(seen not in (a, b) for seen, *_ in lines):
            raise ValueError(f"{source}: pair {k}: a FOV line is seen in a camera that is not "
                             f"{a} or {b}")
        priors[a, b] = PairPrior(H, pair.markers, lines)
    return priors


def run(clip: Clip, params: Params, frames: range, sinks: Sequence[Sink],
        progress: Callable[[int, int], None] | None = None,
        priors: Mapping[tuple[str, str], PairPrior] | None = None) -> RunSummary:
    """Run the pipeline over ``frames`` of ``clip``, handing each result to every sink.

    ``priors``: geometry learned earlier for some pairs (:func:`priors_from`).

    Ctrl-C stops the loop cleanly: the summary says ``interrupted`` and the sinks keep what
    they received (the caller closes them).
    """
    summary = RunSummary()
    start = time.perf_counter()
    pipeline = Pipeline(clip.spec.cameras, clip.spec.overlaps, params,
                        train_backgrounds(clip, frames, params), priors=priors)
    summary.train_seconds = time.perf_counter() - start
    try:
        read_start = time.perf_counter()
        for fs in clip.frames(frames):
            read_ms = 1000.0 * (time.perf_counter() - read_start)
            result = pipeline.step(fs.index, fs.images, fs.detections, read_ms)
            for sink in sinks:
                sink.on_frame(result)
            for stage, ms in result.stage_ms.items():
                summary.stage_seconds[stage] += ms / 1000.0
            summary.frames += 1
            if progress is not None:
                progress(summary.frames, len(frames))
            read_start = time.perf_counter()
    except KeyboardInterrupt:
        summary.interrupted = True
    summary.pairs = pipeline.pair_summaries()
    return summary
