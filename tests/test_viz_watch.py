"""`mvtrack-view --watch`: re-runs on a change, survives an invalid file, skips unchanged stages."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest
from rerun.chunk import RrdReader
from test_viz_scene import write_scene_clip

from mvtrack.io import open_clip
from mvtrack.viz import paths
from mvtrack.viz.outputs import Target
from mvtrack.viz.watch import WatchConfig, Watcher, describe_change

N_FRAMES = 30


def _write(path: Path, text: str, tick: int) -> None:
    path.write_text(text)
    os.utime(path, ns=(tick * 10**9, tick * 10**9))  # a distinct mtime even on coarse clocks


def _series(rrd: Path, entity: str) -> list[float]:
    values: list[float] = []
    for chunk in RrdReader(rrd).store().stream().to_chunks():
        if str(chunk.entity_path) == entity:
            rb = chunk.to_record_batch()
            if "Scalars:scalars" in rb.schema.names:
                values += [v[0] for v in rb.column("Scalars:scalars").to_pylist()]
    return values


def _texts(rrd: Path) -> list[str]:
    out: list[str] = []
    for chunk in RrdReader(rrd).store().stream().to_chunks():
        if str(chunk.entity_path) == paths.EVENTS:
            for row in chunk.to_record_batch().column("TextLog:text").to_pylist():
                out += row if isinstance(row, list) else [row]
    return out


BASE = "[background]\ntrain_frames = 15\n"


@pytest.fixture
def watcher(tmp_path: Path) -> Iterator[Watcher]:
    clip = write_scene_clip(tmp_path / "scene", N_FRAMES)
    params = tmp_path / "params.toml"
    _write(params, BASE, 1)
    opened = open_clip(clip)
    w = Watcher(opened, params, range(N_FRAMES),
                WatchConfig(target=Target(save=tmp_path / "runs" / "w.rrd", viewer="none")))
    yield w
    w.close()
    opened.close()


def test_watch_reruns_caches_and_survives_invalid_files(watcher: Watcher, tmp_path: Path) -> None:
    params, runs = watcher.params_file, tmp_path / "runs"
    first = watcher.poll()
    assert first is not None and first.ran and not first.frontend_cached
    assert first.name == "run 1: initial"
    assert watcher.poll() is None  # unchanged file: nothing to do

    # a pair threshold: the front end is re-used, only the pair stages run again
    _write(params, BASE + "[fov]\nmin_fov_events = 3\n", 2)
    second = watcher.poll()
    assert second is not None and second.ran and second.frontend_cached
    assert "fov.min_fov_events 4 -> 3" in second.name
    assert watcher.frontend_runs == 1
    assert second.summary is not None and second.summary.frames == N_FRAMES

    # an invalid edit: reported, the last good thresholds stay
    good = watcher.good
    _write(params, BASE + "[fov]\nmin_fov_events = 'many'\n", 3)
    bad = watcher.poll()
    assert bad is not None and not bad.ran and bad.error and "min_fov_events" in bad.error
    assert watcher.good is good
    _write(params, BASE + "[nope]\nx = 1\n", 4)
    bad = watcher.poll()
    assert bad is not None and bad.error and "nope" in bad.error

    # a front-end threshold: everything runs again
    _write(params, BASE + "min_area_px = 60\n", 5)
    third = watcher.poll()
    assert third is not None and third.ran and not third.frontend_cached
    assert watcher.frontend_runs == 2 and watcher.runs == 3
    watcher.close()

    files = sorted(p.name for p in runs.iterdir())
    assert files == ["w-run1.rrd", "w-run2.rrd", "w-run3.rrd"]
    # the cached run saw exactly the same targets as the run that computed them
    for cam in ("cam0", "cam1"):
        entity = paths.targets_metric(cam)
        assert _series(runs / "w-run1.rrd", entity) == _series(runs / "w-run2.rrd", entity)
        assert len(_series(runs / "w-run2.rrd", entity)) == N_FRAMES
    # the invalid edits went to the log of the recording on screen at the time
    errors = [t for t in _texts(runs / "w-run2.rrd") if t.startswith("invalid thresholds")]
    assert len(errors) == 2
    # each run logs its summary figures (the scene has truth: foot errors)
    names = set()
    for chunk in RrdReader(runs / "w-run3.rrd").store().stream().to_chunks():
        if str(chunk.entity_path) == paths.SUMMARY:
            names |= set(chunk.to_record_batch().schema.names)
    assert {"frames", "pipeline_fps", "foot_error_px.cam0", "idf1_global", "consistency",
            "idf1_global_online", "consistency_online"} <= names
    # and, like mvtrack-view, its whole-run labels once the run is over
    for name in files:
        assert any(t.startswith("whole-run labels: ") for t in _texts(runs / name)), name


def test_describe_change_names_what_changed() -> None:
    from mvtrack.params import load_params

    a = load_params(None, [])
    b = load_params(None, ["background.t_low=0.2", "fov.min_fov_events=5"])
    assert describe_change(None, a) == "initial"
    assert describe_change(a, a) == "no change"
    text = describe_change(a, b)
    assert "background.t_low" in text and "-> 0.2" in text and "fov.min_fov_events" in text
