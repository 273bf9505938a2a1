"""The command line as a user runs it: generate, info, track, eval, and clear errors."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mvtrack.cli import app
from mvtrack.io.results import TRACKS_HEADER, read_tracks

runner = CliRunner()


@pytest.fixture(scope="module")
def small_clip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    clip = tmp_path_factory.mktemp("cli") / "clip"
    result = runner.invoke(
        app, ["generate", str(clip), "--scenario", "pair", "--frames", "60", "--size", "320x240"]
    )
    assert result.exit_code == 0, result.output
    return clip


def test_generate_lists_every_scenario() -> None:
    result = runner.invoke(app, ["generate", "--list"])
    assert result.exit_code == 0
    for name in ("pair", "one_edge", "pillar", "doors", "tilted", "gray", "crowd", "three"):
        assert name in result.stdout


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--scenario", "nope"], "--scenario 'nope'"),
        (["--size", "big"], "expected WIDTHxHEIGHT"),
        (["--frames", "0"], "--frames 0"),
    ],
)
def test_generate_rejects_bad_options(tmp_path: Path, args: list[str], message: str) -> None:
    result = runner.invoke(app, ["generate", str(tmp_path / "x"), *args])
    assert result.exit_code == 2
    assert message in result.output


def test_info_describes_the_clip(small_clip: Path) -> None:
    result = runner.invoke(app, ["info", str(small_clip)])
    assert result.exit_code == 0, result.output
    assert "cam0" in result.stdout and "cam1" in result.stdout
    assert "60 frames" in result.stdout
    assert "truth: yes" in result.stdout


def test_info_on_a_missing_clip_is_one_clear_line(tmp_path: Path) -> None:
    result = runner.invoke(app, ["info", str(tmp_path / "absent")])
    assert result.exit_code == 2
    assert "absent" in result.output
    assert "Traceback" not in result.output


def test_track_then_eval(small_clip: Path, tmp_path: Path) -> None:
    out = tmp_path / "res"
    result = runner.invoke(
        app, ["track", str(small_clip), "--out", str(out), "--frames", "0:60", "--mask-every", "25"]
    )
    assert result.exit_code == 0, result.output
    with (out / "tracks.csv").open() as f:
        assert tuple(next(csv.reader(f))) == TRACKS_HEADER
    rows = read_tracks(out / "tracks.csv")
    assert len(rows.frame) > 0
    assert set(rows.camera.tolist()) <= {"cam0", "cam1"}
    # every target has one meta >= 1 for its whole life (resolved over the run)
    assert rows.meta.min() >= 1
    for cam in ("cam0", "cam1"):
        mine = rows.of_camera(cam)
        for target in set(mine.target.tolist()):
            assert len(set(mine.meta[mine.target == target].tolist())) == 1
    # online, one meta never spans two targets of one camera (resolved, fragments of one
    # person may share one)
    online = read_tracks(out / "tracks_online.csv")
    assert len(online.frame) == len(rows.frame)
    for cam in ("cam0", "cam1"):
        mine = online.of_camera(cam)
        for frame in set(mine.frame.tolist()):
            metas = mine.meta[mine.frame == frame]
            assert len(set(metas.tolist())) == len(metas)
    run = json.loads((out / "run.json").read_text())
    assert run["frames"] == {"start": 0, "stop": 60, "processed": 60}
    assert run["thresholds"]["background"]["train_frames"] == 100
    pairs = json.loads((out / "pairs.json").read_text())
    assert [p["cameras"] for p in pairs] == [["cam0", "cam1"]]

    scored = runner.invoke(app, ["eval", str(small_clip), str(out)])
    assert scored.exit_code == 0, scored.output
    metrics = json.loads((out / "metrics.json").read_text())
    for cam in ("cam0", "cam1"):
        figures = metrics["cameras"][cam]
        assert 0.0 <= figures["recall"] <= 1.0
        assert "masks" in figures  # frames 0, 25, 50 have masks on both sides
    assert "labels_online" in metrics


def test_track_online_labels_only(small_clip: Path, tmp_path: Path) -> None:
    """Online labels with smoothed feet; with neither whole-run step, one streamed file."""
    out = tmp_path / "res"
    result = runner.invoke(app, ["track", str(small_clip), "--out", str(out), "--frames", "0:30",
                                 "--mask-every", "0", "--set", "resolve.labels=online"])
    assert result.exit_code == 0, result.output
    final, online = read_tracks(out / "tracks.csv"), read_tracks(out / "tracks_online.csv")
    assert np.array_equal(final.meta, online.meta)
    assert np.array_equal(final.boxes_xywh, online.boxes_xywh)
    moved = np.linalg.norm(final.feet - online.feet, axis=1) / online.height
    assert 0.0 < moved.max() and np.median(moved) < 0.1, moved
    assert json.loads((out / "run.json").read_text())["thresholds"]["resolve"]["labels"] == "online"

    raw = tmp_path / "raw"
    result = runner.invoke(app, ["track", str(small_clip), "--out", str(raw), "--frames", "0:30",
                                 "--mask-every", "0", "--set", "resolve.labels=online",
                                 "--set", "feet.smooth_seconds=0"])
    assert result.exit_code == 0, result.output
    assert (raw / "tracks.csv").is_file() and not (raw / "tracks_online.csv").exists()
    assert np.array_equal(read_tracks(raw / "tracks.csv").feet, online.feet)


def test_track_with_bad_threshold_fails_before_work(small_clip: Path, tmp_path: Path) -> None:
    out = tmp_path / "res"
    result = runner.invoke(
        app, ["track", str(small_clip), "--out", str(out), "--set", "background.t_low=2"]
    )
    assert result.exit_code == 2
    assert "background.t_low" in result.output
    assert not out.exists()


def test_eval_without_results_is_a_clear_error(small_clip: Path, tmp_path: Path) -> None:
    result = runner.invoke(app, ["eval", str(small_clip), str(tmp_path)])
    assert result.exit_code == 2
    assert "tracks.csv" in result.output
