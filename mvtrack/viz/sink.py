"""The Rerun sink: each :class:`~mvtrack.pipeline.FrameResult` -> archetypes on entity paths.

    rec = new_recording("run 1")
    rec.save("run.rrd", default_blueprint=blueprint)
    sink = RerunSink(rec, clip.spec, params, LogOptions())
    run(clip, params, frames, [sink])
    sink.close()

Paths come from :mod:`mvtrack.viz.paths`; layers switched off in :class:`LogOptions` are never
built (building archetypes costs time even when nothing listens). The sink keeps only what
the event log and the ground map need from one frame to the next (previous links, marker
counts), never the per-frame records.

**Where the time goes.** Logging runs in the caller's thread, between the pipeline's frames
(so the cameras' threads, idle then, never wait on it for the GIL). Only the image layers
(JPEG-encoding the frame, B and D_B, packing the masks and the label image) run on one helper
thread (``LogOptions.thread``) while the frame's other layers are logged: that work is OpenCV
and releases the GIL, so the two overlap on two cores. The image layers are logged after the
other layers of their frame, in the caller's thread, so every layer of a frame is logged when
:meth:`RerunSink.on_frame` returns and the recording's order is that of the calls (an error on
the helper thread re-raises there). Segmentation images and JPEGs reach the SDK without copies
(:func:`~mvtrack.viz.log.segmentation_image`).

A whole-frame logging thread that overlapped the pipeline was tried and dropped: on two cores
its Python held the GIL the cameras' threads waited for, and the background stage took
about twice as long with the sink on (here it takes the same time on and off). Measured with
``mvtrack bench`` on a 768x576 pair, five alternated runs each on a shared, busy machine:
sink on / off 0.60-0.80 (mean 0.68) with that thread, 0.67-0.89 (mean 0.76) with this design;
logging itself costs about 15 ms of wall time per frame-pair, which is why the run with the
sink stays well below the one without.
"""

from __future__ import annotations

import dataclasses
import time
import uuid
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import lru_cache, partial
from typing import Any

import numpy as np
import rerun as rr

from mvtrack.io import ClipSpec, Truth
from mvtrack.io.results import TrackRows
from mvtrack.params import Params, dump_params
from mvtrack.pipeline import CameraResult, FrameResult
from mvtrack.stages.background import BackgroundResult, feet_row
from mvtrack.stages.resolve import Switch
from mvtrack.viz import paths
from mvtrack.viz.colors import HEIGHTS_COLOR, HEIGHTS_FALLBACK_COLOR, TRUTH_COLOR, camera_color
from mvtrack.viz.log import (
    ImageOptions,
    blobs_layer,
    boxes_to_viewer,
    distance_layer,
    image_layer,
    mask_context,
    masks_layer,
    meta_context,
    metas_image,
    segmentation_image,
    strips_key,
    to_viewer,
)

__all__ = ["APP_ID", "LogOptions", "RerunSink", "clip_document", "new_recording"]

APP_ID = "mvtrack"

_TRAIL_FRAMES = 100  # ground-map trail length per meta-target, frames
_FOOT_GATE_HEIGHTS = 0.5  # viewer metric: a foot matches truth within half the person's height
_GROUND_MARGIN = 2.0  # ground map: drawn up to this many reference-outline sizes beyond it
_MAP_MIN_SPAN_M, _MAP_MIN_SPAN_PX = 5.0, 100.0  # ground map margin at least this (metres / px)


@dataclass(frozen=True)
class LogOptions:
    """Which layers the sink logs and how.

    images:            JPEG/lossless encoding of frames, backgrounds and D_B
    background_every:  log the background B every N frames (it changes slowly); 0: never
    distance, masks, labels, blobs: per-camera layers on/off (``blobs`` with the size
                       model's heights, drawn on the MVO blobs)
    pairs, ground:     pair layers and the ground map on/off
    thread:            encode the image layers on a helper thread while the frame's other
                       layers are logged (same recording)
    """

    images: ImageOptions = dataclasses.field(default_factory=ImageOptions)
    background_every: int = 25
    distance: bool = True
    masks: bool = True
    labels: bool = True
    blobs: bool = True
    pairs: bool = True
    ground: bool = True
    thread: bool = True


def new_recording(name: str, deterministic: bool = False) -> rr.RecordingStream:
    """A new recording stream of application ``mvtrack`` named ``name``.

    ``deterministic`` drops the wall-clock timeline (tests compare recordings).
    """
    rec = rr.RecordingStream(APP_ID, recording_id=str(uuid.uuid4()))
    rec.send_recording_name(name)
    if deterministic:
        rec.set_log_time_enabled(False)
    return rec


def clip_document(spec: ClipSpec, frames: range) -> str:
    """Markdown description of a clip and the mvtrack version, for ``/clip``."""
    from mvtrack.run_info import package_versions

    lines = [f"# {spec.root.name}", "", f"- path: `{spec.root}`", f"- fps: {spec.fps:g}",
             f"- frames: {frames.start}..{frames.stop - 1} of {spec.frame_count}",
             "- overlaps: " + (", ".join(f"{a}–{b}" for a, b in spec.overlaps) or "none"),
             f"- truth: {'yes' if spec.truth_dir else 'no'}", "", "## Cameras", ""]
    lines += [f"- **{c.name}**: {c.kind} `{c.source.name}`, {c.size[0]}x{c.size[1]}, "
              f"{c.modality}, offset {c.offset}" for c in spec.cameras]
    lines += ["", "## Versions", ""]
    lines += [f"- {k}: {v}" for k, v in package_versions().items()]
    return "\n".join(lines) + "\n"


def _flat_params(params: Params) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for stage, values in dataclasses.asdict(params).items():
        for key, value in values.items():
            out[f"{stage}.{key}"] = value
    return out


def _ground_from(spec: ClipSpec, truth: Truth | None) -> np.ndarray | None:
    """(3,3) metres-from-reference-pixels of the reference camera, if the truth has it."""
    if truth is None or not spec.cameras:
        return None
    g = truth.image_from_ground.get(spec.cameras[0].name)
    return None if g is None else np.linalg.inv(g)


def _apply(H: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """(N,2) points through a 3x3 homography; points at or behind infinity are dropped."""
    pts = np.asarray(pts, np.float64).reshape(-1, 2)
    hom = np.c_[pts, np.ones(len(pts))] @ H.T
    keep = hom[:, 2] > 1e-9
    return hom[keep, :2] / hom[keep, 2:3]


def _inside_runs(pts: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    """The runs (>= 2 points) of a (N,2) polyline that lie inside the box [lo, hi]."""
    inside = np.all((pts >= lo) & (pts <= hi), axis=1)
    cuts = np.flatnonzero(np.diff(inside.astype(np.int8))) + 1
    return [run for run, ok in zip(np.split(pts, cuts), np.split(inside, cuts), strict=True)
            if len(run) > 1 and ok[0]]


@lru_cache(maxsize=64)
def _outline(size: tuple[int, int], n: int = 24) -> np.ndarray:
    """(4n+1, 2) points around a frame's border (mvtrack pixel coordinates), read-only."""
    w, h = size
    x0, y0, x1, y1 = -0.5, -0.5, w - 0.5, h - 0.5
    t = np.linspace(0.0, 1.0, n, endpoint=False)
    sides = [
        np.c_[x0 + t * (x1 - x0), np.full(n, y0)], np.c_[np.full(n, x1), y0 + t * (y1 - y0)],
        np.c_[x1 - t * (x1 - x0), np.full(n, y1)], np.c_[np.full(n, x0), y1 - t * (y1 - y0)],
    ]
    pts = np.concatenate(sides)
    out = np.vstack([pts, pts[:1]])
    out.flags.writeable = False
    return out


class RerunSink:
    """A pipeline sink that logs every intermediate of every frame to one recording."""

    def __init__(self, rec: rr.RecordingStream, spec: ClipSpec, params: Params,
                 options: LogOptions | None = None, truth: Truth | None = None,
                 frames: range | None = None) -> None:
        self.rec = rec
        self.spec = spec
        self.options = options or LogOptions()
        self.truth = truth
        self._meta_capacity = 0
        self._links: dict[tuple[str, str], set[tuple[int, int]]] = {}
        self._foot_sums: dict[str, tuple[float, int]] = {}
        self.fov_event_cameras: set[str] = set()  # cameras with FOV events drawn this frame
        self._trails: dict[int, list[np.ndarray]] = {}  # meta -> recent ground points
        self.conflicts_told: set[tuple[Any, Any]] = set()  # rejected links in the event log
        self.marker_rejections: dict[tuple[str, str], Counter[str]] = {}  # per pair, per test
        self._truth_rows = self._index_truth(truth)
        self._ground_from_ref = _ground_from(spec, truth)
        self._seen_box: tuple[np.ndarray, np.ndarray] | None = None  # ground map extent so far
        self._last_keys: dict[str, bytes] = {}  # path -> what was last logged there (log_changed)
        self.frames_logged = 0
        self.log_seconds = 0.0  # wall time spent logging frames
        self._images = ThreadPoolExecutor(1, thread_name_prefix="mvtrack-log-images") \
            if self.options.thread else None
        self._log_static(params, frames if frames is not None else range(spec.frame_count))

    # ----------------------------------------------------------------------------- static

    def _log_static(self, params: Params, frames: range) -> None:
        rec = self.rec
        rec.log(paths.CLIP, rr.TextDocument(clip_document(self.spec, frames),
                                            media_type=rr.MediaType.MARKDOWN), static=True)
        rec.log(paths.PARAMS, rr.TextDocument(dump_params(params), media_type="text/plain"),
                rr.AnyValues(**_flat_params(params)), static=True)
        for i, cam in enumerate(self.spec.cameras):
            rec.log(paths.camera_layer(cam.name, "masks"), mask_context(), static=True)
            style = rr.SeriesLines(colors=camera_color(i), names=cam.name, widths=2.0)
            rec.log(paths.targets_metric(cam.name), style, static=True)
            rec.log(paths.foot_error(cam.name), style, static=True)
        for i, (a, b) in enumerate(self.spec.overlaps):  # the series exist before any H
            name = paths.pair_name(a, b)
            rec.log(paths.transfer_error(a, b),
                    rr.SeriesLines(colors=camera_color(i), names=name, widths=2.0), static=True)
            # beside the pair's markers and links (pairs layout): named for what it is
            rec.log(paths.pair_layer(a, b, "quality_px"),
                    rr.SeriesLines(colors=camera_color(i), names=f"quality (px), {name}",
                                   widths=2.0), static=True)
            rec.log(paths.pair_layer(a, b, "markers"),  # magenta, as the marker dots
                    rr.SeriesLines(colors=(255, 0, 255), names="markers"), static=True)
            rec.log(paths.pair_layer(a, b, "links"),
                    rr.SeriesLines(colors=(255, 255, 255), names="links"), static=True)
        self._grow_metas(64)
        for warning in self.spec.warnings:
            self.warn(warning)

    def _grow_metas(self, need: int) -> None:
        if need <= self._meta_capacity:
            return
        cap = max(64, self._meta_capacity)
        while cap < need:
            cap *= 2
        ctx = meta_context(cap)
        self.rec.log(paths.CAMERAS, ctx, static=True)
        self.rec.log(paths.GROUND, ctx, static=True)
        self._meta_capacity = cap

    @staticmethod
    def _index_truth(truth: Truth | None) -> dict[str, dict[int, np.ndarray]]:
        if truth is None:
            return {}
        out: dict[str, dict[int, np.ndarray]] = {}
        for name, ct in truth.cameras.items():
            order = np.argsort(ct.frame, kind="stable")
            cuts = np.flatnonzero(np.diff(ct.frame[order])) + 1
            out[name] = {int(ct.frame[g[0]]): g for g in np.split(order, cuts) if len(g)}
        return out

    def log_changed(self, path: str, key: bytes, build: Callable[[], Any]) -> None:
        """Log ``build()`` on ``path`` unless ``key`` (the bytes the layer is made of) equals
        what was last logged there. The viewer shows the latest value at every later frame, so
        a layer that rarely changes (learned FOV lines, the ground outlines) is the same on
        screen, built and stored only when it changes."""
        if self._last_keys.get(path) == key:
            return
        self._last_keys[path] = key
        self.rec.log(path, build())

    # ----------------------------------------------------------------------------- text

    def warn(self, message: str) -> None:
        """A warning in the event log."""
        self.event(message, rr.TextLogLevel.WARN)

    def event(self, message: str, level: Any = rr.TextLogLevel.INFO) -> None:
        """One line in the event log at the current time (the last logged frame)."""
        self.rec.log(paths.EVENTS, rr.TextLog(message, level=level))

    def event_changed(self, topic: str, key: bytes, message: str,
                      level: Any = rr.TextLogLevel.INFO) -> None:
        """:meth:`event`, unless the last event of ``topic`` had the same ``key``."""
        if self._last_keys.get(f"event:{topic}") == key:
            return
        self._last_keys[f"event:{topic}"] = key
        self.event(message, level)

    # ----------------------------------------------------------------------------- frames

    def on_frame(self, result: FrameResult) -> None:
        """Log every layer of ``result``."""
        start = time.perf_counter()
        rec = self.rec
        self._set_frame(result.index)
        top = max((int(m.max()) for m in result.metas.values() if len(m)), default=0)
        self._grow_metas(top)
        images = self._images.submit(self._frame_images, result) if self._images else None
        events: dict[str, dict[int, str]] = {}  # camera -> target -> FOV event, in its label
        for pr in result.pairs.values() if self.options.pairs else ():
            for ev in pr.events:
                events.setdefault(ev.camera, {})[ev.target] = f"{ev.kind} {ev.side}"
        for name, cam in result.cameras.items():
            self._log_camera(name, cam, result.metas[name], events.get(name, {}))
            rec.log(paths.targets_metric(name), rr.Scalars(float(len(cam.targets))))
            self._foot_error(name, cam, result.index)
            self._log_truth(name, result.index)
        for stage, ms in result.stage_ms.items():
            rec.log(paths.stage_ms(stage), rr.Scalars(ms))
        pairs = result.pairs
        if self.options.pairs:
            shown, self.fov_event_cameras = self.fov_event_cameras, set()
            for key, pr in pairs.items():
                self._log_pair(key, pr, result)
            for gone in shown - self.fov_event_cameras:  # events show on their frame only
                rec.log(paths.camera_layer(gone, "fov_events"), rr.Points2D(np.zeros((0, 2))))
            self._log_multi(result)
        if self.options.ground:
            self._log_ground(result, pairs)
        layers = images.result() if images is not None else self._frame_images(result)
        for name, cam_layers in layers.items():
            for layer, archetype in cam_layers:
                rec.log(paths.camera_layer(name, layer), archetype)
        self.frames_logged += 1
        seconds = time.perf_counter() - start
        self.log_seconds += seconds
        rec.log(paths.log_ms(), rr.Scalars(1000.0 * seconds))

    def _set_frame(self, index: int) -> None:
        self.rec.set_time(paths.FRAME_TIMELINE, sequence=index)
        self.rec.set_time(paths.TIME_TIMELINE, duration=index / self.spec.fps)

    def _camera_images(self, cam: CameraResult, metas: np.ndarray) -> list[tuple[str, Any]]:
        """(layer, archetype) of a camera's image layers: the frame, B (every
        ``background_every`` frames), D_B, the masks and the label image. JPEG encoding and
        the OpenCV packing release the GIL, so this runs beside the other layers' logging."""
        opts, out = self.options, []
        if cam.image is not None:
            out.append(("image", image_layer(cam.image, opts.images)))
        bg = cam.background
        if bg is not None:
            every = opts.background_every
            if every > 0 and bg.frame_index % every == 0:
                out.append(("background",
                            image_layer(bg.background_bgr, opts.images, draw_order=-20.0)))
            if opts.distance:
                out.append(("distance", distance_layer(bg.distance_u8, opts.images)))
            if opts.masks:
                out.append(("masks", masks_layer(bg.mvo_mask, bg.ghost_mask, bg.fg_shadow,
                                                 bg.ghost_shadow, bg.border_mover_mask)))
        tracks = cam.tracks
        if opts.labels and tracks.label_image is not None:
            out.append(("labels", segmentation_image(
                metas_image(tracks.label_image, tracks.labels, metas), opacity=0.45,
                draw_order=-4.0)))
        return out

    def _frame_images(self, result: FrameResult) -> dict[str, list[tuple[str, Any]]]:
        return {name: self._camera_images(cam, result.metas[name])
                for name, cam in result.cameras.items()}

    def _log_camera(self, name: str, cam: CameraResult, metas: np.ndarray,
                    events: Mapping[int, str]) -> None:
        """Blobs, target boxes (labelled with target, meta, this frame's FOV event, if any:
        Rerun writes a label under its box, where an event marker's would collide, and how
        far its feet were put below the box when it lost its lower body), feet and height
        axes."""
        rec, opts = self.rec, self.options
        if cam.background is not None and opts.blobs:
            self._log_blobs(name, cam)
        targets = cam.targets
        text = [f"t{t} m{m}" + (f" · {events[t]}" if t in events else "")
                + (f" · feet +{f.completed_px:.0f} px" if f.completed_px > 0 else "")
                for t, m, f in zip(targets.labels.tolist(), metas.tolist(), cam.feet,
                                   strict=True)]
        rec.log(paths.camera_layer(name, "targets"), rr.Boxes2D(
            array=boxes_to_viewer(targets.boxes_xywh), array_format=rr.Box2DFormat.XYWH,
            class_ids=metas, labels=text, radii=1.0, draw_order=10.0))
        rec.log(paths.camera_layer(name, "feet"), rr.Points2D(
            to_viewer(targets.feet), class_ids=metas, radii=3.0, draw_order=11.0))
        rec.log(paths.camera_layer(name, "axes"), rr.LineStrips2D(
            [to_viewer(np.array([f.point, f.point + f.height_px * f.up])) for f in cam.feet],
            class_ids=metas, radii=1.0, draw_order=10.5))
        self._tracker_events(name, cam)

    def _log_blobs(self, name: str, cam: CameraResult) -> None:
        assert cam.background is not None
        blobs = cam.background.blobs
        boxes = boxes_to_viewer(blobs.box_xywh)
        hover = [rr.AnyValues(area_px=blobs.area_px.astype(np.float64),
                              area_threshold_px=blobs.area_threshold_px.astype(np.float64),
                              max_distance=blobs.max_distance.astype(np.float64),
                              mean_flow_px=blobs.mean_flow_px.astype(np.float64),
                              is_mvo=blobs.is_mvo.astype(bool),
                              border_mover=blobs.border_mover.astype(bool))] if len(boxes) else []
        # (Rerun warns on an empty AnyValues: a frame without blobs has nothing to hover)
        self.rec.log(paths.camera_layer(name, "blobs"),
                     blobs_layer(boxes, blobs.is_mvo, blobs.border_mover), *hover)
        self._log_heights(name, cam.background)

    def _log_heights(self, name: str, bg: BackgroundResult) -> None:
        """Per MVO below the top border, a line down its middle from its top edge to the feet
        row the size model puts under a head there (:func:`~mvtrack.stages.background.feet_row`
        on :meth:`~mvtrack.stages.background.SizeModel.legs_line`): where the legs regrowth
        grows legs to, white while that is the line of whole people (which the feet completion
        reads too), gray while it is the least-squares line. An MVO ending above the line's
        end lost its legs; a line running past the person's feet, into the cast shadow, is a
        size model taught by the wrong samples."""
        line, whole = bg.sizes.legs_line(), bg.sizes.whole is not None
        box = bg.blobs.box_xywh[bg.blobs.is_mvo]
        box = box[box[:, 1] >= 0.5]  # a box on the top border has its top edge at -0.5
        if line is None:
            box, line = box[:0], (0.0, 0.0)
        top, feet = box[:, 1], feet_row(line, box[:, 1])
        x = box[:, 0] + box[:, 2] / 2.0
        strips = [to_viewer(np.array([[cx, y0], [cx, y1]]))
                  for cx, y0, y1 in zip(x.tolist(), top.tolist(), feet.tolist(), strict=True)]
        hover = [rr.AnyValues(predicted_height_px=feet - top, box_height_px=box[:, 3],
                              whole_line=np.full(len(box), whole))] if len(box) else []
        color = HEIGHTS_COLOR if whole else HEIGHTS_FALLBACK_COLOR
        self.rec.log(paths.camera_layer(name, "heights"),
                     rr.LineStrips2D(strips, colors=color, radii=0.5, draw_order=6.0), *hover)

    def _tracker_events(self, name: str, cam: CameraResult) -> None:
        t = cam.tracks
        debug = rr.TextLogLevel.DEBUG
        if t.births:
            self.event(f"{name}: new targets {', '.join(f't{b}' for b in t.births)}", debug)
        for parent, kids in t.splits:
            self.event(f"{name}: t{parent} split into {', '.join(f't{k}' for k in kids)}", debug)
        for _, labels in t.merges:
            self.event(f"{name}: merged {' + '.join(f't{k}' for k in labels)}", debug)
        for kept, absorbed in t.reunions:
            self.event(f"{name}: t{kept} absorbed {', '.join(f't{k}' for k in absorbed)} "
                       "(parts of one person)", debug)
        for _, labels in t.groups:
            self.event(f"{name}: group cut into {', '.join(f't{k}' for k in labels)} "
                       "(left to right)", debug)
        if t.hidden:
            self.event(f"{name}: {', '.join(f't{k}' for k in t.hidden)} hidden (given a sliver "
                       "of a merged blob for several frames)", debug)
        if t.retirements:
            self.event(f"{name}: retired {', '.join(f't{r}' for r in t.retirements)}", debug)

    def _foot_error(self, name: str, cam: CameraResult, index: int) -> None:
        rows = self._truth_rows.get(name, {}).get(index)
        if rows is None or self.truth is None or len(cam.targets) == 0:
            return
        from mvtrack.evaluate.metrics import frame_matches

        ct = self.truth.cameras[name]
        i, j = frame_matches(cam.targets.feet, ct.foot[rows], ct.box_xywh[rows, 3],
                             _FOOT_GATE_HEIGHTS)
        if len(i):
            err = np.linalg.norm(cam.targets.feet[i] - ct.foot[rows][j], axis=1)
            self.rec.log(paths.foot_error(name), rr.Scalars(float(err.mean())))
            total, count = self._foot_sums.get(name, (0.0, 0))
            self._foot_sums[name] = (total + float(err.sum()), count + len(err))

    def _log_truth(self, name: str, index: int) -> None:
        """The true people of this frame in the camera (truth clips only): their boxes and
        feet, with the person id and visible and in-frame fractions on hover (a label would sit
        on the target's, under the same box); empty where the truth lists nobody, so no earlier
        frame's people stay drawn."""
        if self.truth is None or name not in self.truth.cameras:
            return
        ct = self.truth.cameras[name]
        rows = self._truth_rows.get(name, {}).get(index, np.zeros(0, np.int64))
        assert ct.in_frame is not None
        hover = [rr.AnyValues(person=ct.person[rows], visible=ct.visible[rows],
                              in_frame=ct.in_frame[rows])] if len(rows) else []
        self.rec.log(paths.camera_layer(name, "truth"), rr.Boxes2D(
            array=boxes_to_viewer(ct.box_xywh[rows]), array_format=rr.Box2DFormat.XYWH,
            colors=TRUTH_COLOR, radii=0.5, draw_order=9.0), *hover)
        self.rec.log(paths.camera_layer(name, "truth_feet"), rr.Points2D(
            to_viewer(ct.foot[rows]), colors=TRUTH_COLOR, radii=1.5, draw_order=9.5))

    def mean_foot_errors(self) -> dict[str, float]:
        """Per camera, the mean foot error (px) over every matched target so far (truth only)."""
        return {k: total / count for k, (total, count) in self._foot_sums.items() if count}

    # ----------------------------------------------------------------------------- pairs

    def _log_pair(self, key: tuple[str, str], pr: Any, result: FrameResult) -> None:
        from mvtrack.viz.pairs import log_pair

        log_pair(self, key, pr, result)

    def _log_multi(self, result: FrameResult) -> None:
        from mvtrack.viz.multi import log_cues, log_matches, log_meta

        for key, match in result.matches.items():
            log_matches(self, key, match)
        log_meta(self, result.meta)
        log_cues(self, list(result.cameras), result.cues)

    def _log_trails(self, pts: np.ndarray, ids: np.ndarray, result: FrameResult) -> None:
        """Each meta-target's mean ground point appended to its bounded trail, then drawn."""
        live = set(result.meta.live) if result.meta is not None else set(ids.tolist())
        for m in np.unique(ids).tolist():
            trail = self._trails.setdefault(m, [])
            trail.append(pts[ids == m].mean(axis=0))
            del trail[:-_TRAIL_FRAMES]
        self._trails = {m: t for m, t in self._trails.items() if m in live}
        keep = [(m, t) for m, t in self._trails.items() if len(t) > 1]
        self.rec.log(paths.GROUND_TRAILS, rr.LineStrips2D(
            [self._g(np.array(t)) for _, t in keep], class_ids=[m for m, _ in keep],
            radii=1.0 if self._ground_from_ref is None else 0.04))

    def _log_ground(self, result: FrameResult, pairs: Mapping[tuple[str, str], Any]) -> None:
        from mvtrack.viz.pairs import homographies_to_reference

        ref = self.spec.cameras[0].name if self.spec.cameras else None
        if ref is None:
            return
        to_ref = homographies_to_reference(ref, pairs)
        to_out = self._ground_from_ref
        # the map's extent: the reference camera's outline and a margin; a poor learned H can
        # throw another camera's outline hundreds of metres away and zoom everything else out
        ref_outline = _apply(np.eye(3) if to_out is None else to_out,
                             _outline(result.cameras[ref].targets.size))
        lo, hi = ref_outline.min(axis=0), ref_outline.max(axis=0)
        lo, hi = lo - _GROUND_MARGIN * (hi - lo), hi + _GROUND_MARGIN * (hi - lo)
        to_map = {name: H if to_out is None else to_out @ H for name, H in to_ref.items()}
        feet = {name: _apply(to_map[name], cam.targets.feet)
                for name, cam in result.cameras.items() if name in to_map}
        lo, hi = self._map_box(lo, hi, np.concatenate([np.zeros((0, 2)), *feet.values()]))
        pts, ids = [], []
        for name, cam in result.cameras.items():
            if name not in to_map:
                continue
            size = cam.targets.size
            runs = [self._g(r) for r in _inside_runs(_apply(to_map[name], _outline(size)), lo, hi)]
            width = 0.5 if to_out is None else 0.03
            labels = [name] + [""] * (len(runs) - 1) if runs else []
            self.log_changed(paths.ground_fov(name), strips_key(runs, labels),
                             partial(rr.LineStrips2D, runs, radii=width, labels=labels))
            if len(feet[name]) == len(cam.targets):
                near = np.all((feet[name] >= lo) & (feet[name] <= hi), axis=1)
                pts.append(feet[name][near])
                ids.append(result.metas[name][near])
        allpts = np.concatenate(pts) if pts else np.zeros((0, 2))
        allids = np.concatenate(ids) if ids else np.zeros(0, np.int64)
        self._log_trails(allpts, allids, result)
        radius = 4.0 if to_out is None else 0.15
        self.rec.log(paths.GROUND_TARGETS, rr.Points2D(self._g(allpts), class_ids=allids,
                                                       radii=radius,
                                                       labels=[f"m{m}" for m in allids.tolist()]))
        self._ground_truth(result.index)

    def _map_box(self, lo: np.ndarray, hi: np.ndarray,
                 feet: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The map's extent: where the cameras have seen feet so far (``feet``: this frame's,
        every camera's, in map coordinates), with a margin of that extent, inside the outline
        box [lo, hi]; the outline box until feet are seen.

        A camera whose view reaches the horizon has an outline hundreds of metres deep, which
        would otherwise crowd every person into one corner of the map.
        """
        inside = feet[np.all((feet >= lo) & (feet <= hi), axis=1)]
        if len(inside):
            parts = [inside.min(axis=0), inside.max(axis=0)]
            if self._seen_box is not None:
                parts += list(self._seen_box)
            self._seen_box = (np.min(parts, axis=0), np.max(parts, axis=0))
        if self._seen_box is None:
            return lo, hi
        seen_lo, seen_hi = self._seen_box
        floor = _MAP_MIN_SPAN_PX if self._ground_from_ref is None else _MAP_MIN_SPAN_M
        span = np.maximum(seen_hi - seen_lo, floor)
        return np.maximum(lo, seen_lo - span), np.minimum(hi, seen_hi + span)

    def _g(self, pts: np.ndarray) -> np.ndarray:
        """Ground coordinates for the view: reference pixels get +0.5 px, metres are as is."""
        return to_viewer(pts) if self._ground_from_ref is None else np.asarray(pts)

    def _ground_truth(self, index: int) -> None:
        world = self.truth.world if self.truth is not None else None
        if world is None or self._ground_from_ref is None:
            return
        rows = np.flatnonzero(world.frame == index)
        self.rec.log(paths.GROUND_TRUTH, rr.Points2D(
            world.xy[rows], radii=0.08, colors=(255, 255, 255),
            labels=[f"p{p}" for p in world.person[rows].tolist()]))

    # ----------------------------------------------------------------------------- end

    def log_resolved(self, rows: TrackRows, meta: np.ndarray, done: range,
                     switches: Sequence[Switch] = ()) -> None:
        """Whole-run labels (``meta``, one per row of ``rows``, the run's targets with their
        online metas) on ``/cameras/{cam}/resolved``: a box in the resolved meta's colour,
        labelled "t3 → m7" under the online label, on every target whose resolved meta differs
        from the one it carried online, for every frame of ``done`` (the frames logged). One
        columnar send per camera, after the run. Each of ``switches`` (targets the resolution
        cut where they changed person) is a warning in the event log at its frame."""
        if len(meta) != len(rows.frame):
            raise ValueError(f"log_resolved: {len(rows.frame)} rows but {len(meta)} metas")
        if not len(done):
            return
        first = done.start
        frames = np.arange(first, done.stop)
        changed = (meta != rows.meta) & (rows.frame >= first) & (rows.frame < done.stop)
        self._grow_metas(int(meta.max(initial=0)) + 1)
        for cam in self.spec.cameras:
            sel = np.flatnonzero(changed & (rows.camera == cam.name))
            if not len(sel):
                continue
            path = paths.camera_layer(cam.name, "resolved")
            # Rerun writes a box's label under it: the resolved box is 2 px larger and reaches
            # 5 % of the frame height further down, so its label sits under the online one.
            x, y, w, h = rows.boxes_xywh[sel].T
            x, y, below = x + 0.5, y + 0.5, 0.05 * cam.size[1]  # +0.5: Rerun's pixel grid
            lo, hi = np.c_[x - 2.0, y - 2.0], np.c_[x + w + 2.0, y + h + 2.0 + below]
            text = [f"t{t} → m{m}" for t, m in zip(rows.target[sel].tolist(),
                                                   meta[sel].tolist(), strict=True)]
            columns = rr.Boxes2D.columns(
                centers=(lo + hi) / 2, half_sizes=(hi - lo) / 2,
                class_ids=meta[sel], labels=text, radii=np.full(len(sel), 2.0),
            ).partition(np.bincount(rows.frame[sel] - first, minlength=len(frames)))
            self.rec.log(path, rr.Boxes2D.from_fields(draw_order=12.0), static=True)
            self._send_frames(path, frames, columns)
        for sw in switches:
            if sw.cut in done:
                self._set_frame(sw.cut)
                (name, target), (other, before), (_, after) = sw.track, sw.before, sw.after
                self.warn(f"whole-run labels: {name} t{target} changed person about here: it "
                          f"matched {other} t{before} before and {other} t{after} after, and "
                          f"{sw.why}; the two parts are labelled apart")
        self._set_frame(done.stop - 1)
        self.event(f"whole-run labels: {int(changed.sum())} of {len(meta)} target rows carry "
                   "another meta than they had online, drawn as thick boxes labelled "
                   "'t → m' (/cameras/*/resolved); `mvtrack track` writes these to tracks.csv")

    def log_final_feet(self, rows: TrackRows, done: range) -> None:
        """The feet `mvtrack track` writes to tracks.csv (``rows``: smoothed over the run, with
        their final metas) on ``/cameras/{cam}/feet_final`` for every frame of ``done``: small
        points in the meta's colour beside the per-frame feet. One columnar send per camera,
        after the run."""
        if not len(done):
            return
        frames = np.arange(done.start, done.stop)
        inside = (rows.frame >= done.start) & (rows.frame < done.stop)
        self._grow_metas(int(rows.meta.max(initial=0)) + 1)
        for cam in self.spec.cameras:
            sel = np.flatnonzero(inside & (rows.camera == cam.name))
            order = sel[np.argsort(rows.frame[sel], kind="stable")]
            path = paths.camera_layer(cam.name, "feet_final")
            columns = rr.Points2D.columns(
                positions=to_viewer(rows.feet[order]), class_ids=rows.meta[order],
                radii=np.full(len(order), 1.5),
            ).partition(np.bincount(rows.frame[order] - done.start, minlength=len(frames)))
            self.rec.log(path, rr.Points2D.from_fields(draw_order=11.5), static=True)
            self._send_frames(path, frames, columns)

    def _send_frames(self, path: str, frames: np.ndarray, columns: Any) -> None:
        """Send ``columns`` (partitioned one part per frame of ``frames``) on both timelines."""
        rr.send_columns(path, indexes=[
            rr.TimeColumn(paths.FRAME_TIMELINE, sequence=frames),
            rr.TimeColumn(paths.TIME_TIMELINE, duration=frames / self.spec.fps),
        ], columns=columns, recording=self.rec)

    def log_summary(self, values: Mapping[str, float]) -> None:
        """A run's summary figures (``--watch``), static on ``/metrics/summary``."""
        fields: dict[str, Any] = dict(values)
        self.rec.log(paths.SUMMARY, rr.AnyValues(**fields), static=True)

    def close(self) -> None:
        """Stop the image thread and flush the stream (the caller disconnects or ends it)."""
        try:
            if self._images is not None:
                self._images.shutdown()
        finally:
            self.rec.flush()


