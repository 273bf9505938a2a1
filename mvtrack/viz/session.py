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

from mvtrack.evaluate.labels import label_metrics
from mvtrack.io import Clip, read_truth
from mvtrack.io.results import RowsCollector
from mvtrack.params import Params
from mvtrack.pipeline import RunSummary, finish_rows, run
from mvtrack.stages.pair import PairPrior
from mvtrack.viz import paths
from mvtrack.viz.pairs import refit_h_text, whole_run_h_text
from mvtrack.viz.sink import LogOptions, RerunSink

__all__ = [
    "finish_run", "layout_for", "one_opencv_thread", "record_run", "summary_figures",
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


def finish_run(sink: RerunSink, rows: RowsCollector, summary: RunSummary, params: Params,
               frames: range) -> dict[str, float]:
    """After a run over ``frames`` (it may have stopped early: ``summary.frames``): the
    whole-run labels (with ``resolve.labels = "whole_run"``) and the smoothed feet on the
    sink, as `mvtrack track` writes them, then the run's figures on ``/metrics/summary``
    (:func:`summary_figures`) and, when the clip has truth, ``idf1_global`` and
    ``consistency`` of the rows as `mvtrack track` writes them (and ``*_online`` of the rows as
    made frame by frame, when those differ): the numbers ``--watch`` compares."""
    done = range(frames.start, frames.start + summary.frames)
    kept = rows.rows()
    final, res = finish_rows(kept, summary.pairs, params, sink.spec)
    written = {"": final}
    if res is not None:
        sink.log_resolved(kept, res.meta, done, res.switches)
        learned = {tuple(p["cameras"]): p["H"] is not None for p in summary.pairs}
        for pair, found in res.comotion.items():
            sink.event(whole_run_h_text(paths.pair_name(*pair), found, learned[pair],
                                        params.resolve.whole_run_h_min_found_share))
        for pair, refit in res.refit.items():
            sink.event(refit_h_text(paths.pair_name(*pair), refit))
        written["_online"] = kept
    if params.feet.smooth_seconds > 0:
        sink.log_final_feet(final, done)
    figures = summary_figures(sink, summary)
    if sink.truth is not None and len(kept.frame):
        for suffix, these in written.items():
            m = label_metrics(sink.truth, these, done)
            figures[f"idf1_global{suffix}"] = float(m["idf1_global"])
            figures[f"consistency{suffix}"] = float(m["consistency"])
    sink.log_summary(figures)
    return figures


def record_run(  # noqa: PLR0913 (the run's inputs, its recording and two keyword options)
    clip: Clip, params: Params, frames: range, rec: rr.RecordingStream,
    options: LogOptions | None = None, *,
    progress: Callable[[int, int], None] | None = None,
    priors: Mapping[tuple[str, str], PairPrior] | None = None,
) -> tuple[RerunSink, RunSummary]:
    """Run the pipeline over ``frames`` logging into ``rec`` (already connected to its sinks),
    then :func:`finish_run` (whole-run labels, summary figures).

    Ctrl-C stops cleanly (``summary.interrupted``); an exception is logged to ``/events`` as an
    error and re-raised. Either way everything logged so far is flushed and the sink's image
    thread has stopped, so a saved recording stays readable.
    """
    truth = read_truth(clip.spec.root, [c.name for c in clip.spec.cameras]) \
        if clip.spec.truth_dir else None
    sink = RerunSink(rec, clip.spec, params, options, truth=truth, frames=frames)
    rows = RowsCollector()
    try:
        with one_opencv_thread():
            summary = run(clip, params, frames, [sink, rows], progress=progress, priors=priors)
        if summary.interrupted:
            sink.warn(f"interrupted after {summary.frames} frames")
        finish_run(sink, rows, summary, params, frames)
    except Exception as exc:
        with contextlib.suppress(Exception):  # if logging itself failed, this may fail too
            sink.event(f"run failed: {type(exc).__name__}: {exc}", rr.TextLogLevel.ERROR)
        with contextlib.suppress(Exception):
            sink.close()
        rec.flush()
        raise
    sink.close()
    return sink, summary
