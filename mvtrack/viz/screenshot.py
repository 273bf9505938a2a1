"""Headless screenshots of a recording in Rerun's own viewer (software Vulkan is enough).

    save_screenshot(Path("run.rrd"), Path("overview.png"), frame=120)

Spawns ``rerun --headless`` (needs a Vulkan driver: a GPU, or Mesa's lavapipe from Debian's
``mesa-vulkan-drivers``), opens the recording (shown in the layout embedded in it, i.e. the
``--layout`` it was made with), moves the time cursor and saves a PNG of the whole viewer.
(Opening a saved .rbl beside a recording leaves the viewer without an active recording in
Rerun 0.41, so a screenshot in another layout means recording with that ``--layout``.)
"""

from __future__ import annotations

import socket
import time
from pathlib import Path
from typing import Any

__all__ = ["ScreenshotError", "save_screenshot"]


class ScreenshotError(RuntimeError):
    """The headless viewer could not start or render (e.g. no Vulkan driver)."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def save_screenshot(rrd: Path, out: Path, frame: int | None = None,
                    settle_seconds: float = 4.0) -> Path:
    """Write a PNG of the viewer showing ``rrd`` in its embedded layout at clip frame ``frame``
    (default: the last frame)."""
    from rerun.experimental import ViewerClient

    from mvtrack.viz.outputs import rerun_executable

    exe = rerun_executable()
    if exe is None:
        raise ScreenshotError("the rerun viewer binary was not found")
    try:
        client = ViewerClient.spawn(headless=True, port=_free_port(), hide_welcome_screen=True,
                                    executable_path=exe)
    except Exception as exc:  # the viewer panics without a graphics adapter
        raise ScreenshotError(f"the headless viewer did not start: {exc}") from exc
    try:
        client.open(str(rrd.resolve()))
        state = _loaded(client, settle_seconds)
        if frame is None:
            frame = _last_frame(state)
        if frame is not None:
            client.set_time("frame", sequence=frame, play_state="paused")
        time.sleep(settle_seconds)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(client.take_screenshot())
    except Exception as exc:
        raise ScreenshotError(f"screenshot failed: {exc}") from exc
    finally:
        client.quit()
    return out


def _loaded(client: Any, seconds: float) -> Any:
    """Poll the viewer until nothing is loading (at most 10 s more), then settle ``seconds``."""
    deadline = time.monotonic() + 10.0
    state = client.get_state()
    while state.loading and time.monotonic() < deadline:
        time.sleep(0.2)
        state = client.get_state()
    time.sleep(seconds)
    return client.get_state()


def _last_frame(state: Any) -> int | None:
    """The last value of the ``frame`` timeline of the active recording, if it has one."""
    for rec in state.recordings:
        if state.active_recording is not None and rec.store_id != state.active_recording:
            continue
        for timeline in rec.timelines:
            if timeline.name == "frame" and timeline.end is not None:
                return int(timeline.end)
    return None
