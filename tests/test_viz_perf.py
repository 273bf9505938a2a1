"""The viewer's speed work keeps results identical: the image thread, the look-up-table layers,
the pipeline's replay hook, the overview's event filter and the logging benchmark's table."""

from __future__ import annotations

import ast
import shutil
from collections import defaultdict
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import rerun.blueprint as rrb
from rerun.chunk import RrdReader
from test_viz_scene import write_scene_clip

import viewer_blueprints
from mvtrack.io import ClipError, open_clip
from mvtrack.params import Params, load_params
from mvtrack.pipeline import STAGES, FrameResult, Pipeline, run
from mvtrack.viz import paths
from mvtrack.viz import sink as sink_module
from mvtrack.viz.bench import bench_logging
from mvtrack.viz.log import masks_layer, metas_image
from mvtrack.viz.outputs import Target, open_outputs
from mvtrack.viz.session import record_run
from mvtrack.viz.sink import LogOptions, RerunSink, new_recording
from viewer_blueprints._views import ALL_LEVELS, INFO_AND_ABOVE

N_FRAMES = 32
TRAIN = 20


def _params() -> Params:
    return load_params(None, [f"background.train_frames={TRAIN}", "fov.min_fov_events=2",
                              "fov.min_fov_crossers=1"])


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_scene_clip(tmp_path_factory.mktemp("perf") / "scene", N_FRAMES)


def _record(clip_dir: Path, rrd: Path, options: LogOptions) -> None:
    with open_clip(clip_dir) as clip:
        rec = new_recording("test", deterministic=True)
        outputs = open_outputs(rec, Target(save=rrd, viewer="none"),
                               viewer_blueprints.build("overview", ["cam0", "cam1"],
                                                       clip.spec.overlaps))
        try:
            record_run(clip, _params(), range(clip.spec.frame_count), rec, options)
        finally:
            outputs.close()


def _rows(rrd: Path) -> dict[str, list[str]]:
    """Entity path -> every row's data (row ids dropped), sorted: the recording's content."""
    out: dict[str, list[str]] = defaultdict(list)
    for chunk in RrdReader(rrd).store().stream().to_chunks():
        rb = chunk.to_record_batch()
        names = [n for n in rb.schema.names if not n.startswith("rerun.controls")]
        cols = {n: rb.column(n).to_pylist() for n in names}
        for i in range(rb.num_rows):
            out[str(chunk.entity_path)].append(repr({n: cols[n][i] for n in names}))
    return {k: sorted(v) for k, v in out.items()}


def test_image_thread_writes_the_same_recording(scene: Path, tmp_path: Path) -> None:
    _record(scene, tmp_path / "thread.rrd", LogOptions(thread=True))
    _record(scene, tmp_path / "inline.rrd", LogOptions(thread=False))
    threaded, inline = _rows(tmp_path / "thread.rrd"), _rows(tmp_path / "inline.rrd")
    assert set(threaded) == set(inline)
    for entity in inline:
        if entity.startswith("/__"):  # the recording's properties (start time)
            continue
        timed = entity == paths.log_ms() or entity.startswith(f"{paths.METRICS}/stage_ms")
        if timed:  # times measured in the run differ; one row per frame all the same
            assert len(threaded[entity]) == len(inline[entity]) == N_FRAMES
            continue
        if entity == paths.SUMMARY:  # pipeline_fps is a time; frames and errors are not
            a, b = (ast.literal_eval(rows[entity][0]) for rows in (threaded, inline))
            assert a.pop("pipeline_fps") and b.pop("pipeline_fps")
            assert a == b and a["frames"] == [float(N_FRAMES)]
            continue
        assert threaded[entity] == inline[entity], entity
    events = inline[paths.EVENTS]
    assert any("'frame': None" not in e for e in events)  # events carry their frame
    assert len(inline[paths.camera_layer("cam0", "image")]) == N_FRAMES


def test_image_thread_errors_reach_the_caller(scene: Path, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    keep = _Keep()
    with open_clip(scene) as clip:
        run(clip, _params(), range(2), [keep])
        rec = new_recording("err", deterministic=True)
        rec.save(tmp_path / "err.rrd")
        sink = RerunSink(rec, clip.spec, _params(), LogOptions(thread=True))

        def broken(*_: Any) -> None:
            raise cv2.error("encoder failed")

        monkeypatch.setattr(sink_module, "image_layer", broken)
        with pytest.raises(cv2.error, match="encoder failed"):
            sink.on_frame(keep.results[0])
        monkeypatch.undo()
        sink.on_frame(keep.results[1])  # the sink still logs after an error
        sink.close()
        assert sink._images is not None and sink._images._shutdown
        assert sink.frames_logged == 1
        rec.disconnect()


def _reference_codes(masks: list[np.ndarray]) -> np.ndarray:
    mvo, ghost, fg, gs, mover = masks
    codes = np.zeros(mvo.shape, np.uint8)
    codes[mover] = 5
    codes[gs] = 4
    codes[fg] = 3
    codes[ghost] = 2
    codes[mvo] = 1
    return codes


def test_masks_layer_codes_follow_the_layer_priority() -> None:
    rng = np.random.default_rng(3)
    masks = [rng.random((37, 53)) < p for p in (0.2, 0.3, 0.4, 0.5, 0.5)]
    seg = masks_layer(*masks)
    assert seg.buffer is not None
    got = np.array(seg.buffer.as_arrow_array().to_pylist()[0], np.uint8).reshape(37, 53)
    want = _reference_codes(masks)
    assert np.array_equal(got, want)
    assert set(np.unique(got).tolist()) == {0, 1, 2, 3, 4, 5}
    assert got[masks[0]].tolist() == [1] * int(masks[0].sum())


@pytest.mark.parametrize(("top_label", "top_meta"), [(9, 7), (9, 300), (400, 7), (400, 300)])
def test_metas_image_table_paths_agree(top_label: int, top_meta: int) -> None:
    rng = np.random.default_rng(top_label + top_meta)
    label_image = rng.integers(0, top_label + 1, (29, 31)).astype(np.int32)
    labels = np.array([1, 4, top_label])
    metas = np.array([2, 5, top_meta])
    got = metas_image(label_image, labels, metas)
    want = np.zeros(label_image.shape, np.int64)
    for label, meta in zip(labels, metas, strict=True):
        want[label_image == label] = meta
    assert got.dtype == (np.uint8 if top_meta < 256 else np.uint16)
    assert np.array_equal(got, want)


class _Keep:
    def __init__(self) -> None:
        self.results: list[FrameResult] = []

    def on_frame(self, result: FrameResult) -> None:
        self.results.append(result)


def test_pipeline_replays_camera_results_through_its_hook(scene: Path) -> None:
    keep = _Keep()
    with open_clip(scene) as clip:
        rng = range(clip.spec.frame_count)
        run(clip, _params(), rng, [keep])
        cached = {r.index: r.cameras for r in keep.results}
        calls: list[tuple[int, str]] = []

        def replay(index: int, cam: Any) -> Any:
            calls.append((index, cam.name))
            return cached[index][cam.name]

        pipe = Pipeline(clip.spec.cameras, clip.spec.overlaps, _params(), {}, camera_step=replay)
        for ref in keep.results:
            again = pipe.step(ref.index, {}, {})
            assert again.cameras["cam0"] is ref.cameras["cam0"]
            for cam in ("cam0", "cam1"):
                assert np.array_equal(again.metas[cam], ref.metas[cam])
    assert calls[:2] == [(0, "cam0"), (0, "cam1")] and len(calls) == 2 * len(rng)
    assert sum(len(m) for r in keep.results for m in r.metas.values()) > 0


def _views(node: Any) -> list[Any]:
    if isinstance(node, rrb.View):
        return [node]
    inner = getattr(node, "root_container", None) or getattr(node, "contents", [])
    if not isinstance(inner, list | tuple):
        inner = [inner]
    return [v for child in inner for v in _views(child)]


def test_overview_event_log_hides_debug_lines_the_camera_layout_shows_all() -> None:
    def levels(layout: str) -> list[list[str]]:
        bp = viewer_blueprints.build(layout, ["a", "b"], [("a", "b")])
        logs = [v for v in _views(bp) if isinstance(v, rrb.TextLogView)]
        assert logs
        rows: Any = [v.properties["TextLogRows"] for v in logs]
        return [list(r.filter_by_log_level.as_arrow_array().to_pylist()) for r in rows]

    assert levels("overview") == [list(INFO_AND_ABOVE)]
    assert "DEBUG" not in INFO_AND_ABOVE and "INFO" in INFO_AND_ABOVE
    assert all(set(row) == set(ALL_LEVELS) for row in levels("camera"))


def test_bench_table_splits_the_wall_time_by_stage(scene: Path, tmp_path: Path) -> None:
    with open_clip(scene) as clip:
        result = bench_logging(clip, _params(), range(0, 24), tmp_path)
    rows = {r["stage"]: r for r in result.stage_rows()}
    assert list(rows)[:len(STAGES)] == list(STAGES)
    wall_off = rows["wall"]["ms_off"]
    stages_off = sum(rows[s]["ms_off"] for s in STAGES)
    # stages lie inside the loop; the cameras' front ends run concurrently, each counted
    front = sum(rows[s]["ms_off"] for s in ("background", "tracker", "feet"))
    assert 0.3 * wall_off < stages_off <= wall_off * 1.01 + 0.2 + front * (1 - 1 / result.cameras)
    assert rows["logging"]["ms_on"] > 0
    d = result.as_dict()
    assert d["on_over_off"] == pytest.approx(d["fps_viewer_on"] / d["fps_viewer_off"], abs=0.02)
    assert d["realtime_on"] == pytest.approx(d["fps_viewer_on"] / 25.0, abs=0.02)
    assert 1.0 < d["kib_per_frame"] < 200.0
    assert d["cpu_ms_on"] > d["cpu_ms_off"] > 0.0  # logging is work, whichever thread does it


# ------------------------------------------------------------------------ clip read-ahead


def _read_all(clip_dir: Path, prefetch: bool, stop: int | None = None
              ) -> tuple[list[int], list[bytes], BaseException | None]:
    indices: list[int] = []
    digests: list[bytes] = []
    error: BaseException | None = None
    with open_clip(clip_dir) as clip:
        try:
            for fs in clip.frames(prefetch=prefetch):
                indices.append(fs.index)
                digests.append(b"".join(fs.images[c].tobytes()[::997] for c in sorted(fs.images)))
                if stop is not None and fs.index == stop:
                    break
        except ClipError as exc:
            error = exc
    return indices, digests, error


def test_read_ahead_yields_the_same_frames_and_errors_at_the_same_frame(
        scene: Path, tmp_path: Path) -> None:
    ahead, plain = _read_all(scene, True), _read_all(scene, False)
    assert ahead[0] == plain[0] == list(range(N_FRAMES))
    assert ahead[1] == plain[1] and ahead[2] is None
    assert _read_all(scene, True, stop=3)[0] == [0, 1, 2, 3]  # leaving early is clean

    broken = tmp_path / "broken"
    shutil.copytree(scene, broken)
    frame = sorted((broken / "cam1").iterdir())[5]
    frame.write_bytes(frame.read_bytes()[:40] + b"\0" * 64)  # header intact, pixels gone
    for prefetch in (True, False):
        indices, _, error = _read_all(broken, prefetch)
        assert indices == [0, 1, 2, 3, 4], prefetch
        assert isinstance(error, ClipError) and frame.name in str(error)


def test_ground_map_keeps_only_runs_inside_its_extent() -> None:
    from mvtrack.viz.sink import _inside_runs

    pts = np.array([[0, 0], [1, 1], [500, 50], [2, 2], [3, 3], [4, 4], [-99, 0], [5, 5]], float)
    runs = _inside_runs(pts, np.array([-1.0, -1.0]), np.array([10.0, 10.0]))
    assert [r.tolist() for r in runs] == [[[0, 0], [1, 1]], [[2, 2], [3, 3], [4, 4]]]
    assert _inside_runs(pts[2:3], np.zeros(2), np.ones(2)) == []
