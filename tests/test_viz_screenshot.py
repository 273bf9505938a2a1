"""A headless screenshot of the overview in Rerun's own viewer is produced and is not blank.

Needs a Vulkan driver (a GPU, or Debian's ``mesa-vulkan-drivers`` as in CI); skips otherwise.
"""

from __future__ import annotations

import glob
from pathlib import Path

import cv2
import numpy as np
import pytest
from test_viz_scene import write_scene_clip
from typer.testing import CliRunner

from mvtrack.viz.cli import app
from mvtrack.viz.outputs import rerun_executable
from mvtrack.viz.screenshot import save_screenshot


def _vulkan_available() -> bool:
    icds = glob.glob("/usr/share/vulkan/icd.d/*.json") + glob.glob("/etc/vulkan/icd.d/*.json")
    return bool(icds)


@pytest.mark.skipif(not _vulkan_available(),
                    reason="no Vulkan driver (install mesa-vulkan-drivers): the viewer cannot "
                           "render headless")
@pytest.mark.skipif(rerun_executable() is None, reason="the rerun viewer binary is missing")
def test_overview_screenshot_is_not_blank(tmp_path: Path) -> None:
    clip = write_scene_clip(tmp_path / "scene", 30)
    rrd, png = tmp_path / "run.rrd", tmp_path / "overview.png"
    res = CliRunner().invoke(app, [str(clip), "--save", str(rrd), "--no-viewer",
                                   "--set", "background.train_frames=15"])
    assert res.exit_code == 0, res.output
    save_screenshot(rrd, png, frame=20, settle_seconds=1.0)  # what --screenshot does
    image = cv2.imread(str(png))
    assert image is not None and image.shape[0] >= 400 and image.shape[1] >= 600
    # the camera views show the textured scene: many colours, not an empty dark viewer
    top = image[: image.shape[0] // 2]
    colours = np.unique(top.reshape(-1, 3) // 8, axis=0)
    assert len(colours) > 500
    assert float(top.std()) > 20.0
