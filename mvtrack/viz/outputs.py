"""Where a recording goes: the native viewer, a served web viewer, a file, or several.

    outputs = open_outputs(rec, Target(save=Path("run.rrd"), viewer="auto"), blueprint)
    ...log...
    outputs.close()

``viewer="auto"`` opens the native viewer when a display is available, else serves the web
viewer. The SDK's own gRPC server listens on every interface, so serving runs the ``rerun``
binary with ``--bind`` (loopback unless asked otherwise) and logs to it over gRPC.
"""

from __future__ import annotations

import os
import shutil
import socket
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import rerun as rr
import rerun.blueprint as rrb

__all__ = ["Outputs", "Target", "display_available", "open_outputs", "rerun_executable"]

Viewer = Literal["auto", "native", "serve", "connect", "none"]


@dataclass(frozen=True)
class Target:
    """What to do with a recording.

    save:      write an .rrd file (complete and readable even after Ctrl-C or an error)
    viewer:    "auto", "native", "serve", "connect" (to a viewer already listening on
               ``grpc_port``, e.g. spawned by ``--watch``) or "none"
    bind:      address the served viewer listens on (default loopback only)
    grpc_port, web_port: ports of the served viewer
    """

    save: Path | None = None
    viewer: Viewer = "auto"
    bind: str = "127.0.0.1"
    grpc_port: int = 9876
    web_port: int = 9090


def display_available() -> bool:
    """Whether a native window can open (macOS/Windows, or X11/Wayland on Linux)."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def rerun_executable() -> str | None:
    """The ``rerun`` viewer binary: on PATH, or beside this Python (the wheel installs it)."""
    found = shutil.which("rerun")
    if found:
        return found
    beside = Path(sys.executable).parent / "rerun"
    return str(beside) if beside.exists() else None


def _wait_for_port(host: str, port: int, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    probe = "127.0.0.1" if host in ("0.0.0.0", "::") else host
    while time.monotonic() < deadline:
        with socket.socket(socket.AF_INET6 if ":" in probe else socket.AF_INET) as s:
            s.settimeout(0.2)
            if s.connect_ex((probe, port)) == 0:
                return True
        time.sleep(0.1)
    return False


@dataclass
class Outputs:
    """The open sinks of one recording; ``close`` flushes and ends them.

    url:      the web viewer's address when serving (print it for the user)
    server:   the served viewer's process (kept alive by the caller until Ctrl-C)
    """

    rec: rr.RecordingStream
    mode: Viewer
    url: str | None = None
    server: subprocess.Popen[bytes] | None = None

    def close(self) -> None:
        self.rec.flush()
        self.rec.disconnect()

    def stop_server(self) -> None:
        if self.server is not None and self.server.poll() is None:
            self.server.terminate()
            try:
                self.server.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.server.kill()


def _serve(target: Target) -> tuple[str, subprocess.Popen[bytes]]:
    exe = rerun_executable()
    if exe is None:
        raise RuntimeError("the rerun viewer binary was not found (is rerun-sdk installed?)")
    cmd = [exe, "--serve-web", "--bind", target.bind, "--port", str(target.grpc_port),
           "--web-viewer-port", str(target.web_port)]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if not _wait_for_port(target.bind, target.grpc_port, 15.0):
        proc.terminate()
        raise RuntimeError(f"the web viewer did not start: {' '.join(cmd)}")
    return f"rerun+http://127.0.0.1:{target.grpc_port}/proxy", proc


def open_outputs(rec: rr.RecordingStream, target: Target,
                 blueprint: rrb.Blueprint | Path) -> Outputs:
    """Connect ``rec`` to the target's sinks, with ``blueprint`` embedded as the default.

    ``blueprint`` is a built layout or a path to a layout saved from the viewer (.rbl).
    """
    mode: Viewer = target.viewer
    if mode == "auto":
        mode = "native" if display_available() else "serve"
    sinks: list[rr.FileSink | rr.GrpcSink] = []
    outputs = Outputs(rec, mode)
    if mode in ("native", "connect"):
        if mode == "native":
            rec.spawn(connect=False, port=target.grpc_port)
        sinks.append(rr.GrpcSink(f"rerun+http://127.0.0.1:{target.grpc_port}/proxy"))
    elif mode == "serve":
        grpc_url, outputs.server = _serve(target)
        sinks.append(rr.GrpcSink(grpc_url))
        host = "localhost" if target.bind in ("127.0.0.1", "::1") else target.bind
        outputs.url = f"http://{host}:{target.web_port}/?url={grpc_url}"
    if target.save is not None:
        target.save.parent.mkdir(parents=True, exist_ok=True)
        sinks.append(rr.FileSink(str(target.save)))
    if not sinks:
        raise ValueError("nothing to do: no viewer and no --save file")
    if isinstance(blueprint, Path):
        rec.set_sinks(*sinks)
        rec.log_file_from_path(blueprint)
    else:
        rec.set_sinks(*sinks, default_blueprint=blueprint)
    return outputs
