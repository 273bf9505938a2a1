"""A run written to a results directory: what `mvtrack track` does, for every caller.

    with open_clip(path) as clip:
        summary = track_to(clip, params, range(clip.spec.frame_count), ResultsWriter(out_dir))

Writes `tracks.csv`, `pairs.json`, `cues.csv`, `run.json` (FORMATS.md), then rewrites them
as finished over the whole run: feet smoothed over time and, with ``resolve.labels =
"whole_run"``, whole-run labels (the streamed ones stay in `tracks_online.csv` and
`cues_online.csv`). The CLI and `mvtrack sweep` both call this.

:func:`refinish_to` gives what a run with other ``resolve`` or feet smoothing thresholds
writes, from a finished run, without tracking again (`mvtrack sweep` uses it for such
variants: seconds instead of minutes).
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from collections.abc import Callable, Mapping
from pathlib import Path

from mvtrack.io import Clip, ClipSpec
from mvtrack.io.results import ResultsWriter, restore_streamed
from mvtrack.params import Params, params_from_dict
from mvtrack.pipeline import RunSummary, finish_results, run, tracking_differences
from mvtrack.run_info import run_info
from mvtrack.stages.pair import PairPrior

__all__ = ["refinish_to", "track_to"]


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


def refinish_to(base: Path, out_dir: Path, params: Params, spec: ClipSpec) -> None:
    """Copy finished run ``base`` to ``out_dir`` (replacing it) and finish it again with
    ``params``: the streamed `*_online.csv` files are finished as `mvtrack track` would have,
    and `run.json` records ``params``; `metrics.json` (it scored the base) is left out.
    Raises ValueError, before writing anything, when ``params`` and the base run's thresholds
    differ in more than ``resolve.*`` and ``feet.smooth_*``
    (:func:`~mvtrack.pipeline.tracking_differences`): that needs a run of its own."""
    base, out_dir = Path(base), Path(out_dir)
    info = json.loads((base / "run.json").read_text())
    differ = tracking_differences(params_from_dict(info["thresholds"], str(base / "run.json")),
                                  params)
    if differ:
        raise ValueError(f"{base}: the run tracked with other thresholds ({', '.join(differ)});"
                         " only resolve.* and feet.smooth_* can change without tracking again")
    shutil.rmtree(out_dir, ignore_errors=True)
    shutil.copytree(base, out_dir, ignore=shutil.ignore_patterns("metrics.json", "*.part"))
    restore_streamed(out_dir)
    info["thresholds"] = dataclasses.asdict(params)
    (out_dir / "run.json").write_text(json.dumps(info, indent=2) + "\n")
    pairs = json.loads((out_dir / "pairs.json").read_text())
    finish_results(out_dir, pairs, params, spec)
