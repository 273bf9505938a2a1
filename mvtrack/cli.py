"""The `mvtrack` command line. Only this module (and the viewer's) imports typer.

Each command is thin: parse options, call the library, print. Errors that are the user's
(bad clip, bad thresholds) print one clear line and exit with status 2; bugs keep their traceback.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from mvtrack.params import Params, ParamsError, dump_params, load_params

if TYPE_CHECKING:
    from mvtrack.io import Clip
    from mvtrack.stages.pair import PairPrior

app = typer.Typer(
    name="mvtrack",
    help="Homography-based multi-camera person tracking (Turk 2008) and its visual debugger.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
params_app = typer.Typer(help="Show and check thresholds files.", no_args_is_help=True)
app.add_typer(params_app, name="params")

# Tables stay readable when piped to a file or CI log (Rich would cut them at 80 columns).
out = Console(width=None if sys.stdout.isatty() else 160)
err = Console(stderr=True)

ParamsOpt = Annotated[
    Path | None,
    typer.Option("--params", help="Thresholds TOML file (default: the clip's mvtrack.toml)."),
]
SetOpt = Annotated[
    list[str] | None,
    typer.Option("--set", help="Override one threshold, e.g. --set background.t_low=0.12."),
]


def fail(message: str) -> typer.Exit:
    """Print a user error and return the exit to raise."""
    err.print(f"[bold red]error:[/] {message}", highlight=False)
    return typer.Exit(code=2)


@contextmanager
def user_errors() -> Iterator[None]:
    """Turn the library's bad-input errors into one clear line and exit status 2."""
    from mvtrack.io import ClipError

    try:
        yield
    except (ClipError, ParamsError) as exc:
        raise fail(str(exc)) from None


@contextmanager
def progress_bar(description: str) -> Iterator[Callable[[int, int], None]]:
    """A rich progress bar; yields ``update(done, total)``."""
    with Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeRemainingColumn(),
        console=err,
        transient=False,
        disable=not err.is_terminal,
    ) as bar:
        task = bar.add_task(description, total=None)

        def update(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        yield update


def parse_size(text: str) -> tuple[int, int]:
    """'640x480' -> (640, 480)."""
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise fail(f"--size {text!r}: expected WIDTHxHEIGHT, e.g. 640x480") from None
    if w < 64 or h < 48:
        raise fail(f"--size {text!r}: at least 64x48")
    return w, h


@app.command()
def generate(
    out_dir: Annotated[Path | None, typer.Argument(help="New clip directory to write.")] = None,
    scenario: Annotated[str, typer.Option(help="Scenario name (see --list).")] = "pair",
    seed: Annotated[int, typer.Option(help="Random seed: same seed, same clip.")] = 0,
    frames: Annotated[int, typer.Option(help="Number of frames.")] = 600,
    size: Annotated[str, typer.Option(help="Frame size WIDTHxHEIGHT of the main camera.")] = (
        "640x480"
    ),
    image_format: Annotated[
        str, typer.Option("--format", help="Camera files: mp4 (video), png or jpg (frame folders).")
    ] = "mp4",
    list_scenarios: Annotated[
        bool, typer.Option("--list", help="List the scenarios and exit.")
    ] = False,
) -> None:
    """Write a synthetic multi-camera clip with ground truth (thesis §4.1)."""
    from mvtrack.generate import SCENARIOS, generate_clip

    if list_scenarios:
        for name, sc in SCENARIOS.items():
            out.print(f"[bold]{name:10}[/] {sc.summary}", highlight=False)
        return
    if out_dir is None:
        raise fail("missing OUT_DIR: the clip directory to write")
    if scenario not in SCENARIOS:
        raise fail(f"--scenario {scenario!r}: expected one of {', '.join(SCENARIOS)}")
    if frames < 1:
        raise fail(f"--frames {frames}: expected at least 1")
    wh = parse_size(size)
    with progress_bar(f"generating {scenario}") as update:
        try:
            path = generate_clip(
                out_dir, scenario, seed=seed, frames=frames, size=wh, progress=update,
                image_format=image_format,
            )
        except ValueError as exc:
            raise fail(str(exc)) from None
    out.print(f"wrote {path}")


@params_app.command("show")
def params_show(
    clip: Annotated[
        Path | None, typer.Argument(help="Clip whose mvtrack.toml to start from (optional).")
    ] = None,
    params: ParamsOpt = None,
    set_: SetOpt = None,
) -> None:
    """Print the full effective thresholds as TOML (a valid file to start from)."""
    with user_errors():
        path = params
        if path is None and clip is not None and (clip / "mvtrack.toml").is_file():
            path = clip / "mvtrack.toml"
        sys.stdout.write(dump_params(load_params(path, set_ or [])))


@params_app.command("check")
def params_check(file: Annotated[Path, typer.Argument(help="Thresholds TOML file.")]) -> None:
    """Validate a thresholds file: unknown keys and out-of-range values are errors."""
    with user_errors():
        load_params(file)
    out.print(f"{file}: ok")


def _shown_path(path: Path, root: Path) -> str:
    """A camera source relative to its clip when it lies inside it."""
    return str(path.relative_to(root)) if path.is_relative_to(root) else str(path)


@app.command()
def info(clip: Annotated[Path, typer.Argument(help="Clip directory.")]) -> None:
    """Describe a clip: cameras, sizes, modality, frame counts, fps, overlaps, truth."""
    from mvtrack.io import open_clip

    with user_errors(), open_clip(clip) as opened:
        spec = opened.spec
    table = Table(title=f"{spec.root}  ({spec.fps:g} fps)")
    for col in ("camera", "kind", "source", "size", "modality", "frames", "offset"):
        table.add_column(col)
    for cam in spec.cameras:
        table.add_row(
            cam.name, cam.kind, _shown_path(cam.source, spec.root),
            f"{cam.size[0]}x{cam.size[1]}", cam.modality, str(cam.length), str(cam.offset),
        )
    out.print(table)
    out.print(f"common range: frames 0..{spec.frame_count - 1} ({spec.frame_count} frames)")
    out.print("overlaps: " + (", ".join(f"{a}–{b}" for a, b in spec.overlaps) or "none"))
    out.print(f"truth: {'yes (' + str(spec.truth_dir) + ')' if spec.truth_dir else 'no'}")
    out.print(f"thresholds: {spec.params_file or 'defaults'}")
    for warning in spec.warnings:
        err.print(f"[yellow]warning:[/] {warning}", highlight=False)


FramesOpt = Annotated[
    str | None,
    typer.Option("--frames", help="Clip frames START:STOP (e.g. 100:400), or N: the first N."),
]
CamerasOpt = Annotated[
    str | None, typer.Option("--cameras", help="Comma-separated cameras to use (default: all).")
]


GeometryOpt = Annotated[
    Path | None,
    typer.Option("--geometry", help="pairs.json of an earlier run of the same cameras: its "
                 "homographies and FOV lines are used from the first frame (kept unless they "
                 "fail verification) instead of being learned again."),
]


def load_priors(geometry: Path | None, opened: Clip,
                subset: bool = False) -> dict[tuple[str, str], PairPrior] | None:
    """The pairs' priors from ``--geometry`` (None without it); a bad file closes the clip and
    exits with a clear error naming it. ``subset``: only some cameras are in use (--cameras),
    so pairs with the others are skipped rather than refused."""
    from mvtrack.io.results import read_pairs
    from mvtrack.pipeline import priors_from

    if geometry is None:
        return None
    try:
        in_use = [c.name for c in opened.spec.cameras] if subset else None
        return priors_from(read_pairs(geometry), opened.spec.overlaps, str(geometry), in_use)
    except (OSError, ValueError) as exc:
        opened.close()
        raise fail(str(exc)) from None


def open_run(clip: Path, params: Path | None, set_: list[str] | None, frames: str | None,
             cameras: str | None) -> tuple[Clip, Params, range]:
    """Open a clip and resolve thresholds (--params, else the clip's mvtrack.toml) and frames."""
    from mvtrack.io import open_clip, parse_frame_range

    names = [c.strip() for c in cameras.split(",")] if cameras else None
    opened = open_clip(clip, cameras=names)
    try:
        path = params if params is not None else opened.spec.params_file
        resolved = load_params(path, set_ or [])
        rng = range(opened.spec.frame_count)
        if frames is not None:
            rng = parse_frame_range(frames, opened.spec.frame_count)
    except Exception:
        opened.close()
        raise
    for warning in opened.spec.warnings:
        err.print(f"[yellow]warning:[/] {warning}", highlight=False)
    return opened, resolved, rng


@app.command()
def track(
    clip: Annotated[Path, typer.Argument(help="Clip directory.")],
    out_dir: Annotated[Path, typer.Option("--out", help="Results directory to write.")],
    frames: FramesOpt = None,
    params: ParamsOpt = None,
    set_: SetOpt = None,
    cameras: CamerasOpt = None,
    mask_every: Annotated[
        int, typer.Option(help="Write segmentation masks every N frames (0: never).")
    ] = 25,
    matcher: Annotated[
        str | None,
        typer.Option("--matcher", help="Cross-camera association: 'homography' (default) or "
                     "'fov' (FOV-event associations only, the Khan & Shah baseline); "
                     "same as --set matcher.method=..."),
    ] = None,
    geometry: GeometryOpt = None,
) -> None:
    """Track people in a clip; write tracks.csv, pairs.json, cues.csv and run.json."""
    from mvtrack.batch import track_to
    from mvtrack.io.results import ResultsWriter

    if matcher is not None:
        set_ = [*(set_ or []), f"matcher.method={matcher}"]
    with user_errors():
        opened, resolved, rng = open_run(clip, params, set_, frames, cameras)
        priors = load_priors(geometry, opened, subset=cameras is not None)
    with opened:
        with progress_bar("tracking") as update:
            summary = track_to(opened, resolved, rng, ResultsWriter(out_dir, mask_every),
                               priors=priors, progress=update)
        whole_run = resolved.resolve.labels == "whole_run"
        for warning in opened.warnings[len(opened.spec.warnings):]:
            err.print(f"[yellow]warning:[/] {warning}", highlight=False)
    if summary.interrupted:
        err.print(f"interrupted after {summary.frames} frames; results so far in {out_dir}")
        raise typer.Exit(code=130)
    out.print(f"tracked {summary.frames} frames of {len(opened.spec.cameras)} cameras "
              f"-> {out_dir}")
    if whole_run:
        out.print("labels resolved over the whole run; as assigned frame by frame: "
                  "tracks_online.csv")


def _fmt(value: Any) -> str:
    return f"{value:.3f}" if isinstance(value, float) else "-" if value is None else str(value)


@app.command("eval")
def eval_(
    clip: Annotated[Path, typer.Argument(help="Clip directory with truth/.")],
    results: Annotated[Path, typer.Argument(help="Results directory from `mvtrack track`.")],
) -> None:
    """Score results against the clip's truth; write metrics.json beside the results."""
    from mvtrack.evaluate.report import evaluate, write_metrics

    with user_errors():
        try:
            metrics = evaluate(clip, results)
        except (FileNotFoundError, ValueError) as exc:
            raise fail(str(exc)) from None
    written = write_metrics(results, metrics)
    _print_camera_metrics(metrics, f"{results} against {clip}/truth")
    if "labels" in metrics:
        _print_flat("consistent labels (all cameras)", metrics["labels"])
    if "labels_online" in metrics:
        _print_flat("labels as assigned online (tracks_online.csv)", metrics["labels_online"])
    for pair in metrics.get("pairs", []):
        _print_flat(f"pair {'-'.join(pair['cameras'])}", pair)
    out.print(f"wrote {written}")


def _print_flat(title: str, figures: dict[str, Any]) -> None:
    """The scalar figures of a metrics section, one per row; nested ones as key.sub(.sub)."""
    table = Table(title=title)
    table.add_column("figure")
    table.add_column("value")

    def add(prefix: str, items: dict[str, Any]) -> None:
        for key, value in items.items():
            if isinstance(value, dict):
                add(f"{prefix}{key}.", value)
            elif not isinstance(value, list):
                table.add_row(f"{prefix}{key}", _fmt(value))

    add("", figures)
    out.print(table)


def _print_camera_metrics(metrics: dict[str, Any], title: str) -> None:
    table = Table(title=title)
    table.add_column("figure")
    cams = metrics["cameras"]
    for name in cams:
        table.add_column(name)
    for key in next(iter(cams.values())):
        if key != "masks":
            table.add_row(key, *(_fmt(cams[c][key]) for c in cams))
    for key in ("fg_precision", "fg_recall", "shadow_detection", "shadow_discrimination",
                "shadow_kept_out"):
        if any("masks" in cams[c] for c in cams):
            table.add_row(key, *(_fmt(cams[c].get("masks", {}).get(key, "-")) for c in cams))
    out.print(table)


def shared_data_dir() -> Path | None:
    """The project's shared real data (PETS 2009), when this checkout sits beside it."""
    import os

    env = os.environ.get("MVTRACK_SHARED_DATA")
    candidates = [Path(env)] if env else []
    candidates += [Path.cwd().parent / "shared" / "data",
                   Path(__file__).resolve().parents[2] / "shared" / "data"]
    return next((c for c in candidates if (c / "pets2009-s2l1").is_dir()), None)


def _first_frames(clip: Path, n: int) -> tuple[str, list[Any], str]:
    """The first ``n`` frames of a clip's first video camera, decoded into memory."""
    from mvtrack.io import open_clip

    with open_clip(clip) as opened:
        video = [c for c in opened.spec.cameras if c.kind != "detections"]
        if not video:
            raise fail(f"{clip}: no video camera to benchmark")
        cam = video[0]
        rng = range(min(n, opened.spec.frame_count))
        frames = [fs.images[cam.name] for fs in opened.frames(rng)]
    return f"{clip.name}/{cam.name}", frames, cam.modality


@app.command()
def bench(
    clips: Annotated[
        list[Path] | None,
        typer.Argument(help="Clips to time (default: a generated 768x576 clip and PETS View_001)."),
    ] = None,
    frames: Annotated[int, typer.Option(help="Frames per clip.")] = 150,
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Also write the tables here.")
    ] = None,
    viewer: Annotated[bool, typer.Option(
        "--viewer/--no-viewer",
        help="Also time the whole pipeline with the viewer sink off and on (saving an .rrd) on "
             "the generated 768x576 two-camera clip (or the first clip given).")] = True,
    log_thread: Annotated[bool, typer.Option(
        "--log-thread/--no-log-thread",
        help="Viewer sink encodes its image layers on a helper thread while it logs the rest.",
    )] = True,
) -> None:
    """Front-end throughput (camera-frames/s) against OpenCV MOG2, memory growth, and the
    viewer's logging cost (frame-pairs/s off and on, KiB per frame-pair, ms per stage)."""
    import tempfile

    from mvtrack.bench import bench_frontend

    params = load_params()
    rows = []
    report: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as tmp:
        if not clips:
            from mvtrack.generate import generate_clip

            demo = generate_clip(Path(tmp) / "bench-pair", "pair", seed=0, frames=frames,
                                 size=(768, 576))
            pets = shared_data_dir()
            clips = [demo] + ([pets / "pets2009-s2l1"] if pets else [])
        for clip in clips:
            name, imgs, modality = _first_frames(clip, frames)
            err.print(f"timing {name} ({len(imgs)} frames)...")
            rows.append(bench_frontend(name, imgs, modality, params).as_dict())
        if viewer:
            report = _bench_viewer(clips[0], frames, params, Path(tmp), log_thread)
    _print_rows("front end vs MOG2 (one thread, camera-frames per second)", rows)
    if report:
        _print_rows("viewer logging cost (frame sets per second, sink off / on, .rrd saved)",
                    [report["viewer_logging"]])
        _print_rows("ms per frame set by stage, same two runs (share: of the 'off' wall time)",
                    report["stages_ms"])
    if json_out is not None:
        data: Any = rows if not report else {"front_end": rows, **report}
        json_out.write_text(json.dumps(data, indent=2) + "\n")


@app.command()
def sweep(
    out_dir: Annotated[Path, typer.Option("--out", help="Directory for the runs, sweep.csv "
                                          "and sweep.json.")],
    scenarios: Annotated[str | None, typer.Option(help="Comma-separated scenarios (see "
                                                  "`mvtrack generate --list`; default: all).")
                         ] = None,
    seeds: Annotated[str, typer.Option(help="Comma-separated generator seeds.")] = "0",
    variants: Annotated[list[str] | None, typer.Option(
        "--variant", help="NAME:KEY=VALUE[,KEY=VALUE...]: thresholds to compare with the "
        "defaults, e.g. low:background.t_low=0.08 (repeat for more). A variant of resolve.* "
        "and feet.smooth_* only finishes the defaults' runs again (under a second a clip).")
    ] = None,
    frames: Annotated[int, typer.Option(help="Frames per generated clip.")] = 600,
    size: Annotated[str, typer.Option(help="Main camera size WIDTHxHEIGHT of the generated "
                                      "clips (the size the README's figures use).")] = "320x240",
    clips: Annotated[Path | None, typer.Option(
        help="Cache of generated clips, reused across sweeps (default: OUT/clips).")] = None,
    jobs: Annotated[int, typer.Option(help="Runs at a time (worker processes).")] = 2,
    params: ParamsOpt = None,
    set_: SetOpt = None,
) -> None:
    """Track and score generated clips (scenarios x seeds) with the default thresholds and
    each --variant: one row per run, then each variant's means and their change."""
    from mvtrack.generate import SCENARIOS
    from mvtrack.sweep import (
        SweepPlan,
        Variant,
        check_plan,
        parse_variant,
        refinished,
        run_sweep,
        variant_means,
        write_tables,
    )

    try:
        plan = SweepPlan(
            scenarios=list(SCENARIOS) if scenarios is None else
            [x.strip() for x in scenarios.split(",") if x.strip()],
            seeds=_seeds(seeds),
            variants=[Variant("defaults", ()), *(parse_variant(v) for v in variants or [])],
            out_dir=out_dir, frames=frames, size=parse_size(size), common=tuple(set_ or []),
            params_file=params, clips_dir=clips, jobs=jobs)
        check_plan(plan)
        again = refinished(plan)
    except ValueError as exc:
        raise fail(str(exc)) from None
    missing = plan.missing_clips()
    err.print(f"{len(plan.scenarios) * len(plan.seeds)} clips x {len(plan.variants)} variants"
              + (f" ({', '.join(sorted(again))}: the defaults' runs finished again)" if again
                 else "")
              + f", {jobs} at a time; runs in {out_dir / 'runs'}" + (
                  f"; generating {len(missing)} clips into {missing[0].parent} first"
                  if missing else ""))

    def report(r: dict[str, Any]) -> None:
        what = (f"[red]failed:[/] {r['error']}" if r["error"] else
                f"IDF1 {_fmt(r['idf1'])}, consistency {_fmt(r['consistency'])}")
        err.print(f"  {r['scenario']} seed {r['seed']} {r['variant']}: {what}",
                  highlight=False)

    with user_errors():
        try:
            done = run_sweep(plan, on_row=report)
        except ValueError as exc:
            raise fail(str(exc)) from None
    rows = done.rows
    if not rows:
        raise typer.Exit(code=130 if done.interrupted else 1)
    means = variant_means(rows)
    _print_sweep(rows, means)
    out.print(f"wrote {', '.join(str(p) for p in write_tables(out_dir, rows, means))}")
    if done.interrupted:
        err.print(f"interrupted after {len(rows)} runs; their figures are in {out_dir}")
        raise typer.Exit(code=130)
    if any(r["error"] for r in rows):
        raise fail(f"{sum(bool(r['error']) for r in rows)} runs failed (see the log above)")


def _seeds(text: str) -> list[int]:
    try:
        return [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"--seeds {text!r}: expected comma-separated integers, e.g. 0,1,2") \
            from None


_SWEEP_HEADS = {"idf1": "IDF1", "idf1_loss_identity": "ID loss", "consistency": "cons",
                "idf1_online": "IDF1 on", "recall_min": "rec min", "precision_min": "prec min",
                "foot_median_px_max": "foot px", "h_median_px_max": "H med",
                "h_p90_px_max": "H p90", "h_end_p90_px_max": "end p90",
                "h_first_frame_max": "H at", "pairs_without_h": "no H",
                "whole_run_h_used": "WR H",
                "fov_line_px_max": "line px", "fov_line_end_px_max": "end line",
                "occlusion_recovery": "occl"}


def _print_sweep(rows: list[dict[str, Any]], means: list[dict[str, Any]]) -> None:
    """The runs, one row each, then each variant's means with their change in brackets."""
    from mvtrack.sweep import COLUMNS

    keys = ("scenario", "seed", "variant", *COLUMNS)
    table = Table(title="sweep: one row per run (worst camera, worst pair)")
    for key in keys:
        table.add_column(_SWEEP_HEADS.get(key, key))
    for row in rows:
        table.add_row(*(_fmt(row[k]) for k in keys))
    out.print(table)
    table = Table(title="means per variant (in brackets: change from the first, same clips)")
    for key in ("variant", "runs", *COLUMNS):
        table.add_column(_SWEEP_HEADS.get(key, key))
    for m in means:
        table.add_row(m["variant"], str(m["runs"]), *(
            _fmt(m[k]) + ("" if m[f"d_{k}"] is None else f" ({m[f'd_{k}']:+.3f})")
            for k in COLUMNS))
    out.print(table)


def _print_rows(title: str, rows: list[dict[str, Any]]) -> None:
    table = Table(title=title)
    for key in rows[0]:
        table.add_column(key)
    for row in rows:
        table.add_row(*(str(v) for v in row.values()))
    out.print(table)


def _bench_viewer(clip: Path, frames: int, params: Params, tmp: Path,
                  thread: bool) -> dict[str, Any]:
    """``mvtrack bench``'s viewer table: :func:`mvtrack.viz.bench.bench_logging` on ``clip``."""
    from mvtrack.io import open_clip
    from mvtrack.viz.bench import bench_logging
    from mvtrack.viz.sink import LogOptions

    with open_clip(clip) as opened:
        rng = range(min(frames, opened.spec.frame_count))
        err.print(f"timing the pipeline with the viewer sink off and on ({clip.name}, "
                  f"{len(rng)} frames)...")
        result = bench_logging(opened, params, rng, tmp, LogOptions(thread=thread))
    return {"viewer_logging": result.as_dict(), "stages_ms": result.stage_rows()}


def main() -> None:
    app()
