"""What a run records about itself (`run.json`): clip, thresholds, frames, timings, versions."""

from __future__ import annotations

import dataclasses
import platform
from importlib.metadata import PackageNotFoundError, version
from typing import Any

from mvtrack.io import ClipSpec
from mvtrack.params import Params
from mvtrack.pipeline import RunSummary

__all__ = ["package_versions", "run_info"]

_PACKAGES = ("mvtrack", "numpy", "scipy", "opencv-python-headless", "rerun-sdk", "typer")


def package_versions() -> dict[str, str]:
    """Versions of mvtrack, Python and the packages it computes with."""
    found = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            found[name] = version(name)
        except PackageNotFoundError:
            found[name] = "not installed"
    return found


def run_info(spec: ClipSpec, params: Params, frames: range, summary: RunSummary) -> dict[str, Any]:
    """The `run.json` document of a finished (or interrupted) run."""
    return {
        "clip": {
            "path": str(spec.root),
            "fps": spec.fps,
            "cameras": [
                {"name": c.name, "kind": c.kind, "size": list(c.size), "modality": c.modality}
                for c in spec.cameras
            ],
            "overlaps": [list(p) for p in spec.overlaps],
        },
        "frames": {"start": frames.start, "stop": frames.stop, "processed": summary.frames},
        "interrupted": summary.interrupted,
        "thresholds": dataclasses.asdict(params),
        "seconds": {"train": round(summary.train_seconds, 3)}
        | {k: round(v, 3) for k, v in summary.stage_seconds.items()},
        "versions": package_versions(),
    }
