"""`mvtrack-view`: run the pipeline on a clip and log every intermediate to Rerun.

    mvtrack-view CLIP                       # native viewer, or the web viewer when headless
    mvtrack-view CLIP --serve               # web viewer on http://localhost:9090 (loopback)
    mvtrack-view CLIP --save run.rrd --no-viewer
    mvtrack-view CLIP --save run.rrd --no-viewer --screenshot overview.png
    mvtrack-view CLIP --watch params.toml   # re-run on every save of the thresholds file

The only module besides :mod:`mvtrack.cli` that imports typer.
"""

from __future__ import annotations

import signal
import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from mvtrack.cli import (
    CamerasOpt,
    FramesOpt,
    GeometryOpt,
    ParamsOpt,
    SetOpt,
    err,
    fail,
    load_priors,
    open_run,
    out,
    progress_bar,
    user_errors,
)

if TYPE_CHECKING:
    from mvtrack.pipeline import RunSummary
    from mvtrack.viz.outputs import Outputs, Target, Viewer
    from mvtrack.viz.sink import LogOptions

__all__ = ["app", "main"]

app = typer.Typer(name="mvtrack-view", add_completion=False, pretty_exceptions_enable=False)


def _options(lossless: bool, jpeg_quality: int, background_every: int) -> LogOptions:
    from mvtrack.viz.log import ImageOptions
    from mvtrack.viz.sink import LogOptions

    if not 1 <= jpeg_quality <= 100:
        raise fail(f"--jpeg-quality {jpeg_quality}: expected 1..100")
    return LogOptions(images=ImageOptions(lossless=lossless, jpeg_quality=jpeg_quality),
                      background_every=max(0, background_every))


def _target(save: Path | None, no_viewer: bool, serve: bool, bind: str, port: int,
            web_port: int) -> Target:
    from mvtrack.viz.outputs import Target

    if no_viewer and save is None:
        raise fail("--no-viewer needs --save FILE.rrd")
    viewer: Viewer = "none" if no_viewer else ("serve" if serve else "auto")
    return Target(save=save, viewer=viewer, bind=bind, grpc_port=port, web_port=web_port)


@app.command()
def view(
    clip: Annotated[Path, typer.Argument(help="Clip directory.")],
    frames: FramesOpt = None,
    params: ParamsOpt = None,
    set_: SetOpt = None,
    cameras: CamerasOpt = None,
    layout: Annotated[str, typer.Option(
        help="Layout: overview, camera, pairs, or a .rbl file saved from the viewer.")] = (
        "overview"),
    save: Annotated[Path | None, typer.Option(help="Also write the recording to FILE.rrd.")] = None,
    no_viewer: Annotated[bool, typer.Option("--no-viewer", help="Only --save.")] = False,
    serve: Annotated[bool, typer.Option(help="Serve the web viewer (default when headless).")] = (
        False),
    bind: Annotated[str, typer.Option(help="Address the served viewer listens on.")] = (
        "127.0.0.1"),
    port: Annotated[int, typer.Option(help="gRPC port of the viewer.")] = 9876,
    web_port: Annotated[int, typer.Option(help="HTTP port of the served web viewer.")] = 9090,
    lossless: Annotated[bool, typer.Option(help="Log frames losslessly (not JPEG).")] = False,
    jpeg_quality: Annotated[int, typer.Option(help="JPEG quality of frames.")] = 70,
    background_every: Annotated[int, typer.Option(
        help="Log the background every N frames (0: never).")] = 25,
    watch: Annotated[Path | None, typer.Option(
        help="Thresholds TOML to watch: re-run into a new recording on every save.")] = None,
    screenshot: Annotated[Path | None, typer.Option(
        help="After the run, write a PNG of the saved recording (headless viewer).")] = None,
    screenshot_frame: Annotated[int | None, typer.Option(
        help="Clip frame of the screenshot (default: the last).")] = None,
    geometry: GeometryOpt = None,
) -> None:
    """Run the pipeline on CLIP and show every intermediate in Rerun's viewer."""
    options = _options(lossless, jpeg_quality, background_every)
    target = _target(save, no_viewer, serve, bind, port, web_port)
    if screenshot is not None and save is None:
        raise fail("--screenshot needs --save FILE.rrd")
    if watch is not None and geometry is not None:
        raise fail("--geometry cannot be combined with --watch yet")
    if watch is not None:
        from mvtrack.viz.watch import WatchConfig, watch_loop

        config = WatchConfig(target=target, options=options, layout=layout,
                             overrides=tuple(set_ or ()))
        with user_errors():
            try:
                watch_loop(clip, watch, frames, cameras, config, echo=out.print)
            except ValueError as exc:
                raise fail(str(exc)) from None
        return
    previous = signal.signal(signal.SIGTERM, _raise_interrupt)  # SIGTERM acts like Ctrl-C
    try:
        summary = _run_once(clip, params, set_, frames, cameras, layout, target, options,
                            geometry)
    finally:
        signal.signal(signal.SIGTERM, previous)
    if screenshot is not None and save is not None:
        _screenshot(save, screenshot, layout, screenshot_frame)
    if summary.interrupted:
        raise typer.Exit(code=130)


def _run_once(clip: Path, params: Path | None, set_: list[str] | None, frames: str | None,
              cameras: str | None, layout: str, target: Target, options: LogOptions,
              geometry: Path | None = None) -> RunSummary:
    from mvtrack.viz.outputs import open_outputs
    from mvtrack.viz.session import layout_for, record_run
    from mvtrack.viz.sink import new_recording

    with user_errors():
        opened, resolved, rng = open_run(clip, params, set_, frames, cameras)
    priors = load_priors(geometry, opened, subset=cameras is not None)
    with opened:
        names = [c.name for c in opened.spec.cameras]
        try:
            blueprint = layout_for(layout, names, opened.spec.overlaps)
        except ValueError as exc:
            raise fail(str(exc)) from None
        rec = new_recording(f"{opened.spec.root.name} {rng.start}:{rng.stop}")
        try:
            outputs = open_outputs(rec, target, blueprint)
        except (RuntimeError, ValueError) as exc:
            raise fail(str(exc)) from None
        try:
            if outputs.url:
                out.print(f"web viewer: {outputs.url}", highlight=False)
            with progress_bar("tracking") as update:
                _, summary = record_run(opened, resolved, rng, rec, options, progress=update,
                                        priors=priors)
            outputs.close()
            _report(summary, len(names), target)
            _keep_serving(outputs)
        finally:
            outputs.close()
            outputs.stop_server()
    return summary


def _report(summary: RunSummary, cameras: int, target: Target) -> None:
    where = f" -> {target.save}" if target.save else ""
    out.print(f"logged {summary.frames} frames of {cameras} cameras{where}")
    if summary.interrupted:
        err.print(f"interrupted after {summary.frames} frames; the recording holds them")


def _keep_serving(outputs: Outputs) -> None:
    """Keep the served viewer up until Ctrl-C (or SIGTERM)."""
    if outputs.server is None:
        return
    out.print(f"serving {outputs.url} ; press Ctrl-C to stop", highlight=False)
    try:
        while outputs.server.poll() is None:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass


def _raise_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _screenshot(rrd: Path, png: Path, layout: str, frame: int | None) -> None:
    from mvtrack.viz.screenshot import ScreenshotError, save_screenshot

    try:
        save_screenshot(rrd, png, frame=frame)
    except ScreenshotError as exc:
        raise fail(str(exc)) from None
    out.print(f"wrote {png}")


def main() -> None:
    app()
