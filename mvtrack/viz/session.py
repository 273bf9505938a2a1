"""One viewer run: a clip through the pipeline into one recording, safe against interruption.

    summary = record_run(clip, params, frames, rec, LogOptions())

Used by ``mvtrack-view``, ``--watch`` and the logging benchmark.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path

import cv2
import rerun as rr
import rerun.blueprint as rrb

from mvtrack.io import Clip, read_truth
from mvtrack.io.results import RowsCollector
from mvtrack.params import Params
from mvtrack.pipeline import RunSummary, Sink, resolve_rows, run
from mvtrack.stages.pair import PairPrior
from mvtrack.viz.sink import LogOptions, RerunSink

__all__ = [
    "layout_for", "log_whole_run", "one_opencv_thread", "record_run", "rows_for_resolution",
    "summary_figures",
]


def layout_for(layout: str, cameras: Sequence[str], pairs: Sequence[tuple[str, str]]
               ) -> rrb.Blueprint | Path:
    """A built-in layout by name, or a path to a layout saved from the viewer (.rbl)."""
    from viewer_blueprints import BLUEPRINTS, build

    if layout not in BLUEPRINTS and (layout.endswith(".rbl") or Path(layout).is_file()):
        path = Path(layout)
        if not path.is_file():
            raise ValueError(f"--layout {layout}: no such file")
        return path
    return build(layout, cameras, pairs)


@contextlib.contextmanager
def one_opencv_thread() -> Iterator[None]:
    """OpenCV on one thread inside the block (its previous setting restored after).

    The pipeline already runs the cameras on their own threads and the sink encodes on another;
    OpenCV's own worker pool on top oversubscribes two cores, and some of its parallel paths
    are slower than the serial ones: connected components with statistics on a 768x576 mask
    take 2.3 ms on two OpenCV threads against 0.8 ms on one. Outputs are identical (OpenCV's
    parallel and serial paths give the same labels), so results do not change.
    """
    previous = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(previous)


def summary_figures(sink: RerunSink, summary: RunSummary) -> dict[str, float]:
    """The run's figures logged on ``/metrics/summary``: frames, fps, mean foot errors."""
    total = sum(summary.stage_seconds.values())
    figures = {"frames": float(summary.frames),
               "pipeline_fps": summary.frames / total if total > 0 else 0.0}
    figures |= {f"foot_error_px.{k}": v for k, v in sink.mean_foot_errors().items()}
    return figures


def rows_for_resolution(params: Params) -> RowsCollector | None:
    """A sink keeping the run's target rows when labels are resolved over the whole run."""
    return RowsCollector() if params.resolve.labels == "whole_run" else None


def log_whole_run(sink: RerunSink, rows: RowsCollector | None, summary: RunSummary,
                  params: Params) -> None:
    """After a run: its whole-run labels (as `mvtrack track` writes them) on the sink."""
    if rows is not None:
        kept = rows.rows()
        sink.log_resolved(kept, resolve_rows(kept, summary.pairs, params).meta)


def record_run(  # noqa: PLR0913 (the run's inputs, its recording and two keyword options)
    clip: Clip, params: Params, frames: range, rec: rr.RecordingStream,
    options: LogOptions | None = None, *,
    progress: Callable[[int, int], None] | None = None,
    priors: Mapping[tuple[str, str], PairPrior] | None = None,
) -> tuple[RerunSink, RunSummary]:
    """Run the pipeline over ``frames`` logging into ``rec`` (already connected to its sinks),
    then, with ``resolve.labels = "whole_run"``, the whole-run labels (``/cameras/*/resolved``).

    Ctrl-C stops cleanly (``summary.interrupted``); an exception is logged to ``/events`` as an
    error and re-raised. Either way everything logged so far is flushed and the sink's image
    thread has stopped, so a saved recording stays readable.
    """
    truth = read_truth(clip.spec.root, [c.name for c in clip.spec.cameras]) \
        if clip.spec.truth_dir else None
    sink = RerunSink(rec, clip.spec, params, options, truth=truth, frames=frames)
    rows = rows_for_resolution(params)
    sinks: list[Sink] = [sink] if rows is None else [sink, rows]
    try:
        with one_opencv_thread():
            summary = run(clip, params, frames, sinks, progress=progress, priors=priors)
        if summary.interrupted:
            sink.warn(f"interrupted after {summary.frames} frames")
        log_whole_run(sink, rows, summary, params)
        sink.log_summary(summary_figures(sink, summary))
    except Exception as exc:
        with contextlib.suppress(Exception):  # if logging itself failed, this may fail too
            sink.event(f"run failed: {type(exc).__name__}: {exc}", rr.TextLogLevel.ERROR)
        with contextlib.suppress(Exception):
            sink.close()
        rec.flush()
        raise
    sink.close()
    return sink, summary
