"""A run written to a results directory: what `mvtrack track` does, for every caller.

    with open_clip(path) as clip:
        summary = track_to(clip, params, range(clip.spec.frame_count), ResultsWriter(out_dir))

Writes `tracks.csv`, `pairs.json`, `cues.csv`, `run.json` (FORMATS.md), then rewrites them
as finished over the whole run: feet smoothed over time and, with ``resolve.labels =
"whole_run"``, whole-run labels (the streamed ones stay in `tracks_online.csv` and
`cues_online.csv`). The CLI and `mvtrack sweep` both call this.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

from mvtrack.io import Clip
from mvtrack.io.results import ResultsWriter
from mvtrack.params import Params
from mvtrack.pipeline import RunSummary, finish_results, run
from mvtrack.run_info import run_info
from mvtrack.stages.pair import PairPrior

__all__ = ["track_to"]


def track_to(clip: Clip, params: Params, frames: range, writer: ResultsWriter,
             priors: Mapping[tuple[str, str], PairPrior] | None = None,
             progress: Callable[[int, int], None] | None = None) -> RunSummary:
    """Run ``frames`` of ``clip``, write them with ``writer`` and close it (its directory is
    then complete). An interrupted run (Ctrl-C) still writes what it did
    (``summary.interrupted``)."""
    summary = run(clip, params, frames, [writer], progress=progress, priors=priors)
    writer.close(run_info(clip.spec, params, frames, summary), summary.pairs)
    finish_results(writer.out_dir, summary.pairs, params, clip.spec)
    return summary
