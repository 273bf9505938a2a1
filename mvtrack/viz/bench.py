"""The cost of logging: frames per second with the viewer sink off and on, bytes per frame.

    result = bench_logging(clip, params, range(0, 200), Path("/tmp/bench"))
    print(result.as_dict())

Both runs go through :func:`mvtrack.pipeline.run` on the same frames (decoding included in
both); "on" logs every layer of :class:`~mvtrack.viz.sink.LogOptions` to an .rrd file, whose
size gives the bytes per frame. The logging thread of the Rerun SDK runs concurrently, so the
file is flushed before it is measured.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mvtrack.io import Clip
from mvtrack.params import Params
from mvtrack.pipeline import run
from mvtrack.viz.outputs import Target, open_outputs
from mvtrack.viz.sink import LogOptions, RerunSink, new_recording

__all__ = ["LoggingBench", "bench_logging"]


@dataclass(frozen=True)
class LoggingBench:
    """Frame sets (all cameras of one clip frame) per second without and with logging.

    log_ms_per_frame: time spent inside the sink per frame set (building + handing over)
    bytes_per_frame:  recording size / frames
    """

    name: str
    cameras: int
    size: tuple[int, int]
    frames: int
    fps_off: float
    fps_on: float
    log_ms_per_frame: float
    bytes_per_frame: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "clip": self.name,
            "cameras": self.cameras,
            "size": f"{self.size[0]}x{self.size[1]}",
            "frames": self.frames,
            "fps_viewer_off": round(self.fps_off, 1),
            "fps_viewer_on": round(self.fps_on, 1),
            "log_ms_per_frame": round(self.log_ms_per_frame, 2),
            "kib_per_frame": round(self.bytes_per_frame / 1024.0, 1),
        }


class _TimedSink:
    def __init__(self, sink: RerunSink) -> None:
        self.sink = sink
        self.seconds = 0.0

    def on_frame(self, result: Any) -> None:
        start = time.perf_counter()
        self.sink.on_frame(result)
        self.seconds += time.perf_counter() - start


def bench_logging(clip: Clip, params: Params, frames: range, out_dir: Path,
                  options: LogOptions | None = None) -> LoggingBench:
    """Time ``frames`` of ``clip`` without sinks, then logging to ``out_dir/bench.rrd``."""
    start = time.perf_counter()
    off = run(clip, params, frames, [])
    off_s = time.perf_counter() - start - off.train_seconds

    rrd = out_dir / "bench.rrd"
    rec = new_recording(f"bench {clip.spec.root.name}", deterministic=True)
    outputs = open_outputs(rec, Target(save=rrd, viewer="none"), _blueprint(clip))
    timed = _TimedSink(RerunSink(rec, clip.spec, params, options, frames=frames))
    start = time.perf_counter()
    on = run(clip, params, frames, [timed])
    outputs.close()  # the file is complete once the SDK has written everything
    on_s = time.perf_counter() - start - on.train_seconds

    cam = clip.spec.cameras[0]
    n = max(on.frames, 1)
    return LoggingBench(
        name=clip.spec.root.name, cameras=len(clip.spec.cameras), size=cam.size,
        frames=on.frames, fps_off=off.frames / max(off_s, 1e-9), fps_on=on.frames / max(on_s, 1e-9),
        log_ms_per_frame=1000.0 * timed.seconds / n, bytes_per_frame=rrd.stat().st_size / n,
    )


def _blueprint(clip: Clip) -> Any:
    from viewer_blueprints import build

    return build("overview", [c.name for c in clip.spec.cameras], clip.spec.overlaps)
