"""Consistent labels on real data: PETS 2009 S2L1 View_001, View_003 and View_004 as detections.

Issue 5 asks for IDF1 and cross-camera consistency against the projected ground truth on at
least three views. The three are the ones with little lens distortion (the data's README); the
clip comes from ``to_clip.py --detections-only`` (boxes without track ids, 795 frames). The gt
covers only the people annotated in View_001, so precision in the other views is low by
construction and is not asserted. Skips with a stated reason when the shared data is absent.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from mvtrack.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def pets_labels(shared_data: Path,
                tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    script = shared_data / "pets2009-s2l1" / "to_clip.py"
    if not script.is_file():
        pytest.skip(f"{script} not found in the shared data")
    root = tmp_path_factory.mktemp("pets_labels")
    clip = root / "clip"
    subprocess.run(
        [sys.executable, str(script), str(clip), "--views", "View_001,View_003,View_004",
         "--detections-only"],
        check=True, capture_output=True, timeout=120,
    )
    out = {}
    for matcher in ("homography", "fov"):
        results = root / matcher
        for args in (["track", str(clip), "--out", str(results), "--matcher", matcher],
                     ["eval", str(clip), str(results)]):
            result = runner.invoke(app, args)
            assert result.exit_code == 0, result.output
        out[matcher] = json.loads((results / "metrics.json").read_text())
    return out


def test_three_views_share_labels_better_than_fov_lines_alone(
    pets_labels: dict[str, dict[str, Any]],
) -> None:
    """Measured, labels resolved over the whole run: global IDF1 0.392 against 0.219 for FOV
    lines alone, consistency 0.713 against 0.031 (as assigned online: 0.390 against 0.206,
    0.541 against 0.024); every pair learns a homography (frames 50, 175, 190; median
    transfer error 7.0, 18.2, 11.2 px against the calibration)."""
    h, f = pets_labels["homography"], pets_labels["fov"]
    assert h["labels"]["cameras"] == ["View_001", "View_003", "View_004"]
    assert h["labels"]["idf1_global"] >= f["labels"]["idf1_global"] + 0.1
    assert h["labels"]["consistency"] >= 0.5 > f["labels"]["consistency"]
    assert h["labels_online"]["idf1_global"] >= f["labels_online"]["idf1_global"] + 0.1
    assert h["labels_online"]["consistency"] >= 0.45 > f["labels_online"]["consistency"]
    assert all(p["first_valid_H"] is not None for p in h["pairs"])
    for cam in h["cameras"].values():
        assert cam["recall"] >= 0.75, cam
