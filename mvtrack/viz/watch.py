"""Live tuning: re-run the pipeline into a new recording each time a thresholds file is saved.

    watcher = Watcher(clip, Path("params.toml"), frames, target, options, "overview")
    watcher.poll()          # run if the file changed (the first poll always runs)

Each run is its own recording, named after what changed ("run 3: background.t_low 0.1 -> 0.12"),
so runs sit side by side in the viewer's recording list. Where the clip has truth, each run logs
its summary figures on ``/metrics/summary``.

**Cache.** A camera's front end (background, tracker, feet) depends only on the background,
tracker and feet thresholds. The per-camera results of the last complete run are kept, keyed by
those thresholds; a run whose front-end thresholds are unchanged re-uses them and recomputes only
the pair stages (no frame is read or segmented again). The cache holds one run's camera results
in memory, so it is skipped for clips larger than ``cache_limit_mb``.

**Invalid edits** (a TOML error, an unknown key, a value out of range) are reported on the
terminal and in the last recording's event log; the last good thresholds stay in force.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr

from mvtrack.io import Clip, Detections, read_truth
from mvtrack.io.results import RowsCollector
from mvtrack.params import Params, ParamsError, load_params
from mvtrack.pipeline import CameraResult, Pipeline, RunSummary, train_backgrounds
from mvtrack.viz import paths
from mvtrack.viz.outputs import Outputs, Target, open_outputs
from mvtrack.viz.session import finish_run, layout_for
from mvtrack.viz.sink import LogOptions, RerunSink, new_recording

__all__ = [
    "FRONT_END_STAGES",
    "WatchConfig",
    "WatchRun",
    "Watcher",
    "describe_change",
    "front_end_key",
    "watch_loop",
]

FRONT_END_STAGES = ("background", "tracker", "feet")
"""The config sections a camera's front end depends on (the cache key)."""

_BYTES_PER_PIXEL = 24  # rough memory of one camera frame's results (image, D_B, masks, labels)


def front_end_key(params: Params) -> tuple[Any, ...]:
    """The thresholds the per-camera results depend on (hashable)."""
    return tuple(getattr(params, stage) for stage in FRONT_END_STAGES)


def _flat(params: Params) -> dict[str, Any]:
    return {f"{stage}.{k}": v for stage, values in dataclasses.asdict(params).items()
            for k, v in values.items()}


def describe_change(old: Params | None, new: Params) -> str:
    """'background.t_low 0.1 -> 0.12, ...' (at most three), 'initial' or 'no change'."""
    if old is None:
        return "initial"
    a, b = _flat(old), _flat(new)
    changed = [f"{k} {a[k]} -> {b[k]}" for k in b if a.get(k) != b[k]]
    if not changed:
        return "no change"
    more = f" (+{len(changed) - 3} more)" if len(changed) > 3 else ""
    return ", ".join(changed[:3]) + more


@dataclass
class WatchRun:
    """What one poll did: ``ran`` a run (named ``name``), or met an invalid file (``error``)."""

    ran: bool
    name: str = ""
    error: str | None = None
    summary: RunSummary | None = None
    frontend_cached: bool = False


@dataclass(frozen=True)
class WatchConfig:
    """How a watcher runs: where recordings go, what they log, which layout, fixed overrides.

    cache_limit_mb: skip the front-end cache when one run's camera results would exceed this
    """

    target: Target = dataclasses.field(default_factory=Target)
    options: LogOptions = dataclasses.field(default_factory=LogOptions)
    layout: str = "overview"
    overrides: tuple[str, ...] = ()
    cache_limit_mb: float = 2048.0


class Watcher:
    """Polls a thresholds file and re-runs the clip when it changes.

    ``frontend_runs`` counts runs that computed the front end (the others re-used the cache).
    """

    def __init__(self, clip: Clip, params_file: Path, frames: range,
                 config: WatchConfig | None = None) -> None:
        cfg = config or WatchConfig()
        self.clip = clip
        self.params_file = params_file
        self.frames = frames
        self.target = cfg.target
        self.options = cfg.options
        self.overrides = list(cfg.overrides)
        names = [c.name for c in clip.spec.cameras]
        self.blueprint = layout_for(cfg.layout, names, clip.spec.overlaps)
        self.truth = read_truth(clip.spec.root, names) if clip.spec.truth_dir else None
        pixels = sum(c.size[0] * c.size[1] for c in clip.spec.cameras) * len(frames)
        self.cache_enabled = pixels * _BYTES_PER_PIXEL <= cfg.cache_limit_mb * 2**20
        self.url: str | None = None
        self._server: Outputs | None = None
        self.good: Params | None = None
        self.runs = 0
        self.frontend_runs = 0
        self._mtime: float | None = None
        self._cache_key: tuple[Any, ...] | None = None
        self._cache: dict[int, dict[str, CameraResult]] = {}
        self._last: Outputs | None = None

    def _stamp(self) -> float | None:
        try:
            return self.params_file.stat().st_mtime_ns / 1e9
        except FileNotFoundError:
            return None

    def poll(self) -> WatchRun | None:
        """Run if the file changed since the last poll (the first poll always runs)."""
        stamp = self._stamp()
        if self.runs > 0 and stamp == self._mtime:
            return None
        self._mtime = stamp
        try:
            params = load_params(self.params_file, self.overrides)
        except (ParamsError, OSError) as exc:
            self._report_invalid(str(exc))
            return WatchRun(ran=False, error=str(exc))
        return self.run(params)

    def _report_invalid(self, message: str) -> None:
        text = f"invalid thresholds, keeping the last good ones: {message}"
        if self._last is not None:
            self._last.rec.log(paths.EVENTS, rr.TextLog(text, level=rr.TextLogLevel.ERROR))
            self._last.rec.flush()

    def _target_for(self, n: int) -> Target:
        save = self.target.save
        if save is not None:
            save = save.with_name(f"{save.stem}-run{n}{save.suffix}")
        return dataclasses.replace(self.target, save=save)

    def run(self, params: Params) -> WatchRun:
        """One run with ``params`` into a new recording."""
        self.runs += 1
        name = f"run {self.runs}: {describe_change(self.good, params)}"
        rec = new_recording(name)
        if self._last is not None:
            self._last.close()
        outputs = open_outputs(rec, self._target_for(self.runs), self.blueprint)
        self._last = outputs
        if outputs.server is not None:  # later runs log to the same served viewer
            self._server, self.url = outputs, outputs.url
            self.target = dataclasses.replace(self.target, viewer="connect")
        sink = RerunSink(rec, self.clip.spec, params, self.options, truth=self.truth,
                         frames=self.frames)
        cached = self.cache_enabled and self._cache_key == front_end_key(params) \
            and len(self._cache) == len(self.frames)
        rows = RowsCollector()
        try:
            summary = self._drive(params, sink, cached, rows)
            finish_run(sink, rows, summary, params, self.frames)
        finally:
            sink.close()  # the sink's image thread ends with the run
        self.good = params
        return WatchRun(ran=True, name=name, summary=summary, frontend_cached=cached)

    def _drive(self, params: Params, sink: RerunSink, cached: bool,
               rows: RowsCollector) -> RunSummary:
        spec = self.clip.spec
        summary = RunSummary()
        steps: Iterator[tuple[int, Mapping[str, np.ndarray], Mapping[str, Detections]]]
        if cached:
            cache = self._cache  # complete (every frame of the range): no camera state needed
            pipeline = Pipeline(spec.cameras, spec.overlaps, params, {},
                                camera_step=lambda index, cam: cache[index][cam.name])
            steps = ((i, {}, {}) for i in self.frames)
        else:
            self.frontend_runs += 1
            self._cache = {}
            self._cache_key = front_end_key(params)
            pipeline = Pipeline(spec.cameras, spec.overlaps, params,
                                train_backgrounds(self.clip, self.frames, params))
            steps = ((fs.index, fs.images, fs.detections) for fs in self.clip.frames(self.frames))
        try:
            for index, images, dets in steps:
                result = pipeline.step(index, images, dets)
                if not cached and self.cache_enabled:
                    self._cache[index] = dict(result.cameras)
                sink.on_frame(result)
                rows.on_frame(result)
                for stage, ms in result.stage_ms.items():
                    summary.stage_seconds[stage] = summary.stage_seconds.get(stage, 0.0) + ms / 1e3
                summary.frames += 1
        except KeyboardInterrupt:
            summary.interrupted = True
            self._cache = {}
            raise
        summary.pairs = pipeline.pair_summaries()
        return summary

    def close(self) -> None:
        """End the last recording and stop the served viewer, if any."""
        if self._last is not None:
            self._last.close()
        if self._server is not None:
            self._server.stop_server()


def watch_loop(clip_dir: Path, params_file: Path, frames: str | None, cameras: str | None,
               config: WatchConfig, echo: Callable[[str], None] = print) -> None:
    """``mvtrack-view CLIP --watch FILE``: poll every half second until Ctrl-C."""
    import time

    from mvtrack.cli import open_run
    from mvtrack.viz.outputs import display_available

    opened, _, rng = open_run(clip_dir, params_file if params_file.is_file() else None,
                              list(config.overrides), frames, cameras)
    target = config.target
    if target.viewer == "native" or (target.viewer == "auto" and display_available()):
        rr.spawn(port=target.grpc_port, connect=False)  # one viewer for every run
        config = dataclasses.replace(config, target=dataclasses.replace(target, viewer="connect"))
    with opened:
        watcher = Watcher(opened, params_file, rng, config)
        echo(f"watching {params_file}; save it to re-run, Ctrl-C to stop")
        try:
            while True:
                done = watcher.poll()
                if done is not None and done.error:
                    echo(f"invalid thresholds (keeping the last good ones): {done.error}")
                elif done is not None:
                    if watcher.url and watcher.runs == 1:
                        echo(f"web viewer: {watcher.url}")
                    how = "pairs only, front end cached" if done.frontend_cached else "full"
                    echo(f"{done.name} ({how}, {done.summary.frames if done.summary else 0} "
                         "frames)")
                time.sleep(0.5)
        except KeyboardInterrupt:
            echo("stopped")
        finally:
            watcher.close()
