"""The cost of logging: frames per second with the viewer sink off and on, bytes per frame.

    result = bench_logging(clip, params, range(0, 200), Path("/tmp/bench"))
    print(result.as_dict())

Both runs go through :func:`mvtrack.pipeline.run` on the same frames (decoding included in
both); "on" logs every layer of :class:`~mvtrack.viz.sink.LogOptions` to an .rrd file, whose
size gives the bytes per frame. The "on" time runs until the sink has logged everything and
the file is closed, so it is the wall time a user waits. Per-stage milliseconds
come from the same two runs, so the bound (which stage, or logging) is read off one table even
on a machine shared with other work.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mvtrack.io import Clip
from mvtrack.params import Params
from mvtrack.pipeline import STAGES, RunSummary, run
from mvtrack.viz.outputs import Target, open_outputs
from mvtrack.viz.session import one_opencv_thread
from mvtrack.viz.sink import LogOptions, RerunSink, new_recording

__all__ = ["LoggingBench", "bench_logging"]


@dataclass(frozen=True)
class LoggingBench:
    """Frame sets (all cameras of one clip frame) per second without and with logging.

    fps_off, fps_on:  frame sets per second, wall time (training excluded), sink off / on
    log_ms_per_frame: wall time the sink spends logging one frame set (between the pipeline's
                      frames; the image layers encode on its helper thread meanwhile)
    bytes_per_frame:  recording size / frames
    stage_ms_off, stage_ms_on: per stage (:data:`~mvtrack.pipeline.STAGES`), milliseconds per
                      frame set, summed over cameras, in each run (the cameras' front ends run
                      concurrently, so their shares of the wall time can add up to more than 1)
    clip_fps:         the clip's frame rate (real time)
    thread:           whether the sink encoded the image layers on its helper thread
    cpu_ms_off, cpu_ms_on: CPU time of the whole process (every thread, the SDK's included) per
                      frame set, training excluded: what logging costs in work, a figure that
                      other programs on a shared machine disturb less than the wall time
    """

    name: str
    cameras: int
    size: tuple[int, int]
    frames: int
    fps_off: float
    fps_on: float
    log_ms_per_frame: float
    bytes_per_frame: float
    stage_ms_off: dict[str, float] = field(default_factory=dict)
    stage_ms_on: dict[str, float] = field(default_factory=dict)
    clip_fps: float = 25.0
    thread: bool = True
    cpu_ms_off: float = 0.0
    cpu_ms_on: float = 0.0

    def as_dict(self) -> dict[str, Any]:
        """The table row: sizes, fps off/on, their ratio, real-time factors, log ms, KiB."""
        return {
            "clip": self.name,
            "cameras": self.cameras,
            "size": f"{self.size[0]}x{self.size[1]}",
            "frames": self.frames,
            "fps_viewer_off": round(self.fps_off, 1),
            "fps_viewer_on": round(self.fps_on, 1),
            "on_over_off": round(self.fps_on / max(self.fps_off, 1e-9), 2),
            "realtime_on": round(self.fps_on / max(self.clip_fps, 1e-9), 2),
            "log_ms_per_frame": round(self.log_ms_per_frame, 2),
            "cpu_ms_off": round(self.cpu_ms_off, 1),
            "cpu_ms_on": round(self.cpu_ms_on, 1),
            "kib_per_frame": round(self.bytes_per_frame / 1024.0, 1),
        }

    def stage_rows(self) -> list[dict[str, Any]]:
        """Per stage: ms per frame set off / on and its share of the "off" wall time; then the
        sink's logging ms and the wall time per frame set of each run."""
        wall_off = 1000.0 / max(self.fps_off, 1e-9)
        wall_on = 1000.0 / max(self.fps_on, 1e-9)
        rows = [{"stage": s, "ms_off": round(self.stage_ms_off.get(s, 0.0), 1),
                 "ms_on": round(self.stage_ms_on.get(s, 0.0), 1),
                 "share_of_off": round(self.stage_ms_off.get(s, 0.0) / wall_off, 2)}
                for s in STAGES]
        rows.append({"stage": "logging",
                     "ms_off": 0.0, "ms_on": round(self.log_ms_per_frame, 1),
                     "share_of_off": round(self.log_ms_per_frame / wall_off, 2)})
        rows.append({"stage": "wall", "ms_off": round(wall_off, 1), "ms_on": round(wall_on, 1),
                     "share_of_off": 1.0})
        return rows


def _per_frame_ms(summary: RunSummary) -> dict[str, float]:
    n = max(summary.frames, 1)
    return {s: 1000.0 * v / n for s, v in summary.stage_seconds.items()}


def bench_logging(clip: Clip, params: Params, frames: range, out_dir: Path,
                  options: LogOptions | None = None) -> LoggingBench:
    """Time ``frames`` of ``clip`` without sinks, then logging to ``out_dir/bench.rrd``."""
    opts = options or LogOptions()
    with one_opencv_thread():  # as mvtrack-view runs (record_run)
        return _bench(clip, params, frames, out_dir, opts)


def _bench(clip: Clip, params: Params, frames: range, out_dir: Path,
           opts: LogOptions) -> LoggingBench:
    start, cpu = time.perf_counter(), time.process_time()
    off = run(clip, params, frames, [])
    off_s = time.perf_counter() - start - off.train_seconds
    off_cpu = time.process_time() - cpu - off.train_seconds  # training runs on one thread

    rrd = out_dir / "bench.rrd"
    rec = new_recording(f"bench {clip.spec.root.name}", deterministic=True)
    outputs = open_outputs(rec, Target(save=rrd, viewer="none"), _blueprint(clip))
    start, cpu = time.perf_counter(), time.process_time()
    sink = RerunSink(rec, clip.spec, params, opts, frames=frames)
    try:
        on = run(clip, params, frames, [sink])
    finally:
        sink.close()  # the image thread has stopped, the stream is flushed
        outputs.close()  # the file is complete once the SDK has written everything
    on_s = time.perf_counter() - start - on.train_seconds
    on_cpu = time.process_time() - cpu - on.train_seconds

    cam = clip.spec.cameras[0]
    n = max(on.frames, 1)
    return LoggingBench(
        name=clip.spec.root.name, cameras=len(clip.spec.cameras), size=cam.size,
        frames=on.frames, fps_off=off.frames / max(off_s, 1e-9), fps_on=on.frames / max(on_s, 1e-9),
        log_ms_per_frame=1000.0 * sink.log_seconds / n, bytes_per_frame=rrd.stat().st_size / n,
        stage_ms_off=_per_frame_ms(off), stage_ms_on=_per_frame_ms(on), clip_fps=clip.spec.fps,
        thread=opts.thread, cpu_ms_off=1000.0 * off_cpu / max(off.frames, 1),
        cpu_ms_on=1000.0 * on_cpu / n,
    )


def _blueprint(clip: Clip) -> Any:
    from viewer_blueprints import build

    return build("overview", [c.name for c in clip.spec.cameras], clip.spec.overlaps)
