"""`mvtrack sweep`: thresholds judged on many generated clips at once.

    variants = [Variant("defaults", ()), parse_variant("low:background.t_low=0.08")]
    done = run_sweep(SweepPlan(["pair", "tilted"], [0, 1], variants, out_dir=Path("sweep")))
    print(variant_means(done.rows))

One change to a threshold moves every later stage, and what it does to one clip says little:
the figures that matter are spread over scenarios and seeds. A sweep generates each (scenario,
seed) clip once into a cache folder (reused by later sweeps), then runs `mvtrack track` and
`mvtrack eval` on every clip for every *variant* (a named list of ``--set`` overrides;
"defaults" runs first), in worker processes. A variant that changes only how a run is
finished (``resolve.*``, ``feet.smooth_*``) does not track again: it finishes the first
variant's run anew (:func:`~mvtrack.batch.refinish_to`, the same files in seconds). Each run's
results and `metrics.json` stay under ``out_dir/runs/VARIANT/CLIP``; `mvtrack-view` on the
cached clip with the variant's ``--set`` values shows the run.

:func:`summary_row` reduces a `metrics.json` to the figures the issues' targets use (worst
camera, worst pair); :func:`variant_means` averages them per variant, with the difference
from the first variant; :func:`write_tables` keeps both as `sweep.csv` and `sweep.json`.
"""

from __future__ import annotations

import csv
import json
import math
import multiprocessing
import os
import shutil
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mvtrack.io import Clip
    from mvtrack.params import Params

__all__ = [
    "COLUMNS", "SweepPlan", "SweepResult", "Variant", "check_plan", "clip_name", "parse_variant",
    "refinished", "run_sweep", "summary_row", "variant_means", "write_tables",
]

COLUMNS = ("idf1", "idf1_loss_identity", "consistency", "idf1_online", "recall_min",
           "precision_min", "foot_median_px_max", "h_median_px_max", "h_p90_px_max",
           "h_end_p90_px_max", "h_first_frame_max", "pairs_without_h", "whole_run_h_used",
           "fov_line_px_max", "fov_line_end_px_max", "occlusion_recovery")
"""The figures of a run (:func:`summary_row`), in table order."""


@dataclass(frozen=True)
class Variant:
    """A named list of threshold overrides (``section.key=value``, as ``--set``)."""

    name: str
    overrides: tuple[str, ...]


def parse_variant(text: str) -> Variant:
    """``NAME:KEY=VALUE[,KEY=VALUE...]`` (or ``NAME:`` for no override) -> :class:`Variant`."""
    name, sep, rest = text.partition(":")
    name = name.strip()
    if not sep or not name or "/" in name or name.startswith("."):
        raise ValueError(f"--variant {text!r}: expected NAME:KEY=VALUE[,KEY=VALUE...], "
                         "e.g. low:background.t_low=0.08 (NAME names a folder)")
    overrides = tuple(part.strip() for part in rest.split(",") if part.strip())
    for part in overrides:
        if "=" not in part:
            raise ValueError(f"--variant {text!r}: {part!r} is not KEY=VALUE")
    return Variant(name, overrides)


@dataclass(frozen=True)
class SweepPlan:
    """What to run: every scenario x seed clip with every variant.

    frames, size:  of the generated clips (size = main camera (width, height))
    common:        overrides applied before every variant's own (``--set``)
    params_file:   thresholds file every run starts from (default: each clip's own)
    clips_dir:     cache of generated clips (default ``out_dir/clips``)
    jobs:          worker processes
    """

    scenarios: Sequence[str]
    seeds: Sequence[int]
    variants: Sequence[Variant]
    out_dir: Path
    frames: int = 600
    size: tuple[int, int] = (320, 240)
    common: tuple[str, ...] = ()
    params_file: Path | None = None
    clips_dir: Path | None = None
    jobs: int = 1

    def clip_path(self, scenario: str, seed: int) -> Path:
        cache = self.clips_dir if self.clips_dir is not None else self.out_dir / "clips"
        return cache / clip_name(scenario, seed, self.frames, self.size)

    def missing_clips(self) -> list[Path]:
        """The clips a sweep of this plan generates first (not in the cache)."""
        return [p for p in (self.clip_path(s, seed) for s in self.scenarios for seed in self.seeds)
                if not p.is_dir()]

    def run_dir(self, variant: Variant, scenario: str, seed: int) -> Path:
        return self.out_dir / "runs" / variant.name / clip_name(scenario, seed, self.frames,
                                                                 self.size)


def clip_name(scenario: str, seed: int, frames: int, size: tuple[int, int]) -> str:
    """Cache folder name of a generated clip: everything that decides its content."""
    return f"{scenario}-seed{seed}-{frames}f-{size[0]}x{size[1]}"


def check_plan(plan: SweepPlan) -> None:
    """Raise ValueError naming what is wrong before any work starts: unknown scenarios,
    repeated variant names, overrides that do not load (each named with its variant)."""
    from mvtrack.generate import SCENARIOS
    from mvtrack.params import ParamsError, load_params

    unknown = [s for s in plan.scenarios if s not in SCENARIOS]
    if unknown:
        raise ValueError(f"unknown scenario(s) {', '.join(unknown)}: expected some of "
                         f"{', '.join(SCENARIOS)}")
    if not plan.scenarios or not plan.seeds or not plan.variants:
        raise ValueError("a sweep needs at least one scenario, one seed and one variant")
    names = [v.name for v in plan.variants]
    if len(set(names)) != len(names):
        raise ValueError(f"variant names repeat: {', '.join(names)}")
    for v in plan.variants:
        try:
            load_params(plan.params_file, [*plan.common, *v.overrides])
        except ParamsError as exc:
            raise ValueError(f"variant {v.name!r}: {exc}") from None


def refinished(plan: SweepPlan) -> set[str]:
    """Names of the variants whose thresholds track as the first variant's do (they differ
    only in ``resolve.*`` and ``feet.smooth_*``): their runs are the first variant's runs
    finished again, not tracked."""
    from mvtrack.params import load_params
    from mvtrack.pipeline import tracking_differences

    def params(v: Variant) -> Params:
        return load_params(plan.params_file, [*plan.common, *v.overrides])

    base, *others = plan.variants
    first = params(base)
    return {v.name for v in others if not tracking_differences(first, params(v))}


def _generate(scenario: str, seed: int, frames: int, size: tuple[int, int], path: Path) -> Path:
    """Generate into a sibling temporary folder of this process, then rename: an interrupted
    generation never leaves a folder that looks like a finished clip, and two sweeps sharing
    a ``--clips`` cache do not write into one folder. If the other one's clip is there first,
    ours is dropped (generation is deterministic: they are the same clip)."""
    from mvtrack.generate import generate_clip

    partial = path.with_name(f"{path.name}.partial-{os.getpid()}")
    shutil.rmtree(partial, ignore_errors=True)
    partial.parent.mkdir(parents=True, exist_ok=True)
    generate_clip(partial, scenario, seed=seed, frames=frames, size=size)
    try:
        partial.rename(path)
    except OSError:
        if not path.is_dir():
            raise
        shutil.rmtree(partial, ignore_errors=True)
    return path


def _track_and_score(clip: Path, run_dir: Path, params_file: Path | None,
                     overrides: Sequence[str]) -> dict[str, Any]:
    """`mvtrack track` then `mvtrack eval` (metrics.json written); the summary row."""
    import cv2

    from mvtrack.batch import track_to
    from mvtrack.io import open_clip
    from mvtrack.io.results import ResultsWriter

    cv2.setNumThreads(1)  # the sweep's parallelism is its worker processes
    shutil.rmtree(run_dir, ignore_errors=True)
    with open_clip(clip) as opened:
        summary = track_to(opened, _params(opened, params_file, overrides),
                           range(opened.spec.frame_count), ResultsWriter(run_dir, mask_every=0))
    if summary.interrupted:  # Ctrl-C reached this worker: no figures for a partial run
        raise KeyboardInterrupt
    return _score(clip, run_dir)


def _refinish_and_score(clip: Path, base_dir: Path, run_dir: Path, params_file: Path | None,
                        overrides: Sequence[str]) -> dict[str, Any]:
    """The finished run ``base_dir`` finished again with the variant's thresholds
    (:func:`~mvtrack.batch.refinish_to`), then `mvtrack eval`; the summary row."""
    from mvtrack.batch import refinish_to
    from mvtrack.io import open_clip

    with open_clip(clip) as opened:
        refinish_to(base_dir, run_dir, _params(opened, params_file, overrides), opened.spec)
    return _score(clip, run_dir)


def _params(clip: Clip, params_file: Path | None, overrides: Sequence[str]) -> Params:
    """The run's thresholds: ``params_file`` (default: the clip's own) with the overrides."""
    from mvtrack.params import load_params

    return load_params(params_file if params_file is not None else clip.spec.params_file,
                       list(overrides))


def _score(clip: Path, run_dir: Path) -> dict[str, Any]:
    """`mvtrack eval` of a run (its metrics.json written); the summary row."""
    from mvtrack.evaluate.report import evaluate, write_metrics

    metrics = evaluate(clip, run_dir)
    write_metrics(run_dir, metrics)
    return summary_row(metrics)


@dataclass(frozen=True)
class SweepResult:
    """The finished runs, in plan order (scenario, seed, variant): ``scenario``, ``seed``,
    ``variant``, the :data:`COLUMNS` figures and ``error`` (None, or why the run or its
    clip's generation failed: its figures are then None). ``interrupted``: Ctrl-C stopped
    the sweep; the rows are the runs finished by then."""

    rows: list[dict[str, Any]]
    interrupted: bool = False


def run_sweep(plan: SweepPlan,
              on_row: Callable[[dict[str, Any]], None] | None = None) -> SweepResult:
    """Generate the missing clips, then run every variant on every clip, ``plan.jobs`` at a
    time; ``on_row`` is called as each run finishes (in completion order). A failing run does
    not stop the others."""
    check_plan(plan)
    cases = [(s, seed) for s in plan.scenarios for seed in plan.seeds]
    rows: dict[tuple[str, int, str], dict[str, Any]] = {}

    def record(key: tuple[str, int, str], figures: Mapping[str, Any] | None,
               error: str | None) -> None:
        row = {"scenario": key[0], "seed": key[1], "variant": key[2],
               **(figures or dict.fromkeys(COLUMNS)), "error": error}
        rows[key] = row
        if on_row is not None:
            on_row(row)

    try:
        with _pool(plan.jobs) as pool:
            _run_cases(plan, pool, cases, record)
        interrupted = False
    except KeyboardInterrupt:
        interrupted = True
    order = [(s, seed, v.name) for s, seed in cases for v in plan.variants]
    return SweepResult([rows[k] for k in order if k in rows], interrupted)


_Job = tuple[str, int, Variant | None]  # scenario, seed, variant (None: generating the clip)


def _run_cases(plan: SweepPlan, pool: ProcessPoolExecutor, cases: list[tuple[str, int]],
               record: Callable[[tuple[str, int, str], Mapping[str, Any] | None, str | None],
                                None]) -> None:
    """Generation jobs for the clips not in the cache, each clip's runs once it exists, and
    the :func:`refinished` variants' runs once the first variant's run of the clip is done."""
    again = refinished(plan)
    base = plan.variants[0]
    tracked = [v for v in plan.variants if v.name not in again]
    later = [v for v in plan.variants if v.name in again]
    # Decided once: a clip generated while runs are being submitted must not get them twice.
    missing = set(plan.missing_clips())
    jobs: dict[Future[Any], _Job] = {}
    for s, seed in cases:
        if plan.clip_path(s, seed) in missing:
            jobs[pool.submit(_generate, s, seed, plan.frames, plan.size,
                             plan.clip_path(s, seed))] = (s, seed, None)
        else:
            jobs |= _submit_runs(plan, pool, s, seed, tracked)
    while jobs:
        done, _ = wait(jobs, return_when=FIRST_COMPLETED)
        for finished in done:
            s, seed, v = jobs.pop(finished)
            error = _error(finished)
            if v is not None:
                record((s, seed, v.name), None if error else finished.result(),
                       None if error is None else _why(error))
            if error is None and v is None:
                jobs |= _submit_runs(plan, pool, s, seed, tracked)
            elif error is None and v is base:
                jobs |= _submit_runs(plan, pool, s, seed, later, plan.run_dir(base, s, seed))
            elif v is None or v is base:
                why = (f"generating the clip: {_why(error)}" if v is None else
                       f"finished from the {base.name} run, which failed")
                for w in plan.variants if v is None else later:
                    record((s, seed, w.name), None, why)


def _submit_runs(plan: SweepPlan, pool: ProcessPoolExecutor, s: str, seed: int,
                 variants: Sequence[Variant], base_dir: Path | None = None
                 ) -> dict[Future[Any], _Job]:
    """The variants' runs of one clip: tracked, or ``base_dir`` finished again."""
    clip = plan.clip_path(s, seed)
    jobs: dict[Future[Any], _Job] = {}
    for v in variants:
        overrides = [*plan.common, *v.overrides]
        run_dir = plan.run_dir(v, s, seed)
        job = (pool.submit(_track_and_score, clip, run_dir, plan.params_file, overrides)
               if base_dir is None else
               pool.submit(_refinish_and_score, clip, base_dir, run_dir, plan.params_file,
                           overrides))
        jobs[job] = (s, seed, v)
    return jobs


def _error(future: Future[Any]) -> BaseException | None:
    """The job's exception, if any; a worker's share of a Ctrl-C stops the sweep."""
    error = future.exception()
    if isinstance(error, KeyboardInterrupt):
        raise error
    return error


def _why(error: BaseException | None) -> str:
    return f"{type(error).__name__}: {error}"


@contextmanager
def _pool(jobs: int) -> Iterator[ProcessPoolExecutor]:
    """Worker processes, started fresh ("spawn": the pipeline's threads and OpenCV do not
    survive a fork); Ctrl-C cancels what has not started."""
    pool = ProcessPoolExecutor(max(1, jobs), mp_context=multiprocessing.get_context("spawn"))
    try:
        yield pool
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


def summary_row(metrics: Mapping[str, Any]) -> dict[str, Any]:
    """The :data:`COLUMNS` figures of one `metrics.json` (None where the run has none):
    labels (resolved, with the share of IDF1 lost to identity, and online), the worst
    camera's recall, precision and median foot error, the worst pair's transfer error
    (median, p90) and first valid H frame over the pairs that have one, how many pairs have
    none, the worst p90 of the H a pair hands on (`mvtrack.io.results.handed_on`), how many
    pairs' whole-run labels used the whole-run H (`H_whole_run`), the worst
    learned FOV line's mean error (lines seen over at least 40 px), the same of the lines
    handed on, and occlusion recovery."""
    cams = list(metrics.get("cameras", {}).values())
    labels = metrics.get("labels", {})
    online = metrics.get("labels_online", {})
    pairs = metrics.get("pairs", [])
    with_h = [p for p in pairs if p.get("first_valid_H") is not None
              and p.get("transfer_error_px", {}).get("median") is not None]
    judged = [ln for p in pairs for ln in p.get("fov_lines", [])
              if ln.get("learned") and (ln.get("visible_length_px") or 0) >= 40]
    return {
        "idf1": _known(labels.get("idf1_global")),
        "idf1_loss_identity": _known(labels.get("idf1_global_loss_identity")),
        "consistency": _known(labels.get("consistency")),
        "idf1_online": _known(online.get("idf1_global")),
        "recall_min": _worst(min, [c.get("recall") for c in cams]),
        "precision_min": _worst(min, [c.get("precision") for c in cams]),
        "foot_median_px_max": _worst(max, [c.get("foot_error_px_median") for c in cams]),
        "h_median_px_max": _worst(max, [p["transfer_error_px"]["median"] for p in with_h]),
        "h_p90_px_max": _worst(max, [p["transfer_error_px"]["p90"] for p in with_h]),
        "h_end_p90_px_max": _worst(max, [p.get("handed_on_transfer_error_px", {}).get("p90")
                                         for p in pairs]),
        "h_first_frame_max": _frame(_worst(max, [p["first_valid_H"]["frame"] for p in with_h])),
        "pairs_without_h": len(pairs) - len(with_h),
        "whole_run_h_used": sum(bool(p.get("whole_run_h_used")) for p in pairs),
        "fov_line_px_max": _worst(max, [ln.get("error_px_mean") for ln in judged]),
        "fov_line_end_px_max": _worst(max, [ln.get("handed_on_error_px_mean") for ln in judged]),
        "occlusion_recovery": _known(labels.get("occlusion_recovery")),
    }


def _frame(value: float | None) -> int | None:
    return None if value is None else int(value)


def _known(value: Any) -> float | None:
    """A finite number as float; None for None, NaN and infinities (nothing measured)."""
    return None if value is None or not math.isfinite(float(value)) else float(value)


def _worst(pick: Callable[[list[float]], float], values: Sequence[Any]) -> float | None:
    known = [v for v in map(_known, values) if v is not None]
    return pick(known) if known else None


def variant_means(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Per variant (first-seen order): ``runs``, the mean of each :data:`COLUMNS` figure over
    the runs that have it, and ``d_<figure>``, the mean of its per-clip differences from the
    first variant over the clips where both have it (None for the first variant)."""
    names = list(dict.fromkeys(r["variant"] for r in rows))
    by = {(r["scenario"], r["seed"], r["variant"]): r for r in rows}
    out = []
    for name in names:
        mine = [r for r in rows if r["variant"] == name]
        firsts = [(r, by.get((r["scenario"], r["seed"], names[0]))) for r in mine]
        row: dict[str, Any] = {"variant": name, "runs": len(mine)}
        for col in COLUMNS:
            row[col] = _mean([r[col] for r in mine])
            row[f"d_{col}"] = None if name == names[0] else _mean(
                [r[col] - f[col] for r, f in firsts
                 if f is not None and r[col] is not None and f[col] is not None])
        out.append(row)
    return out


def _mean(values: Sequence[Any]) -> float | None:
    known = [float(v) for v in values if v is not None]
    return sum(known) / len(known) if known else None


def write_tables(out_dir: Path, rows: Sequence[Mapping[str, Any]],
                 means: Sequence[Mapping[str, Any]]) -> tuple[Path, Path]:
    """``out_dir/sweep.csv`` (one row per run) and ``out_dir/sweep.json`` (``runs`` and
    ``means``); the folder is made when no run made it (all failed). Returns both paths."""
    out_dir.mkdir(parents=True, exist_ok=True)
    csv_path, json_path = out_dir / "sweep.csv", out_dir / "sweep.json"
    with csv_path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    json_path.write_text(json.dumps({"runs": list(rows), "means": list(means)}, indent=2) + "\n")
    return csv_path, json_path
