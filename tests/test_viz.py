"""The Rerun sink, blueprints, CLI and logging benchmark, read back from recordings.

Recordings are written to files and read back with ``rerun.chunk.RrdReader``: every documented
entity must be there with its archetype and one row per frame (or per the layer's cadence).
"""

from __future__ import annotations

import math
import re
from collections import defaultdict
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import rerun.blueprint as rrb
from rerun.chunk import RrdReader
from test_viz_scene import write_scene_clip
from typer.testing import CliRunner

import viewer_blueprints
from mvtrack.io import open_clip, read_truth
from mvtrack.params import Params, load_params
from mvtrack.viz import paths
from mvtrack.viz.bench import bench_logging
from mvtrack.viz.cli import app
from mvtrack.viz.colors import PALETTE_SIZE, meta_color
from mvtrack.viz.log import line_strip_in_frame, metas_image
from mvtrack.viz.outputs import Target, open_outputs
from mvtrack.viz.session import record_run
from mvtrack.viz.sink import LogOptions, new_recording

N_FRAMES = 40
TRAIN = 20


# two events per side, from any crossers, are enough for a FOV line: short clips learn some
SHORT_CLIP = (f"background.train_frames={TRAIN}", "fov.min_fov_events=2", "fov.min_fov_crossers=1")


def _params() -> Params:
    return load_params(None, list(SHORT_CLIP))


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_scene_clip(tmp_path_factory.mktemp("viz") / "scene", N_FRAMES)


def _record(clip_dir: Path, rrd: Path, frames: range | None = None,
            options: LogOptions | None = None) -> Any:
    with open_clip(clip_dir) as clip:
        rng = frames or range(clip.spec.frame_count)
        rec = new_recording("test", deterministic=True)
        names = [c.name for c in clip.spec.cameras]
        outputs = open_outputs(rec, Target(save=rrd, viewer="none"),
                               viewer_blueprints.build("overview", names, clip.spec.overlaps))
        try:
            _, summary = record_run(clip, _params(), rng, rec, options)
        finally:
            outputs.close()
    return summary


def read_entities(rrd: Path) -> dict[str, dict[str, Any]]:
    """Entity path -> {"columns": set of component columns, "rows": temporal rows,
    "static": static rows, "frames": set of frame indices}."""
    out: dict[str, dict[str, Any]] = defaultdict(
        lambda: {"columns": set(), "rows": 0, "static": 0, "frames": set()})
    for chunk in RrdReader(rrd).store().stream().to_chunks():
        rb = chunk.to_record_batch()
        entry = out[str(chunk.entity_path)]
        entry["columns"].update(n for n in rb.schema.names if not n.startswith("rerun."))
        if "frame" in rb.schema.names:
            entry["rows"] += rb.num_rows
            entry["frames"].update(v for v in rb.column("frame").to_pylist() if v is not None)
        else:
            entry["static"] += rb.num_rows
    return dict(out)


@pytest.fixture(scope="module")
def recording(scene: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    rrd = tmp_path_factory.mktemp("rec") / "scene.rrd"
    summary = _record(scene, rrd)
    assert summary.frames == N_FRAMES
    return read_entities(rrd)


PER_FRAME = {  # layer -> archetype column that must be there on every frame
    "image": "EncodedImage:blob",
    "distance": "EncodedImage:blob",
    "masks": "SegmentationImage:buffer",
    "labels": "SegmentationImage:buffer",
    "blobs": "Boxes2D:half_sizes",
    "heights": "LineStrips2D:strips",
    "targets": "Boxes2D:class_ids",
    "feet": "Points2D:positions",
    "axes": "LineStrips2D:strips",
    "truth": "Boxes2D:half_sizes",  # the scene has truth
    "truth_feet": "Points2D:positions",
    "feet_final": "Points2D:positions",  # logged after the run, for every frame
}


@pytest.mark.parametrize("cam", ["cam0", "cam1"])
@pytest.mark.parametrize("layer", sorted(PER_FRAME))
def test_camera_layers_every_frame(recording: dict[str, Any], cam: str, layer: str) -> None:
    entity = recording[paths.camera_layer(cam, layer)]
    assert PER_FRAME[layer] in entity["columns"]
    assert entity["frames"] == set(range(N_FRAMES))
    assert entity["rows"] == N_FRAMES


def test_background_every_25_frames(recording: dict[str, Any]) -> None:
    entity = recording[paths.camera_layer("cam0", "background")]
    assert "EncodedImage:blob" in entity["columns"]
    assert entity["frames"] == {0, 25}  # background frame_index 0 and 25


def test_static_documents_and_legends(recording: dict[str, Any]) -> None:
    assert "TextDocument:text" in recording[paths.CLIP]["columns"]
    params = recording[paths.PARAMS]
    assert "TextDocument:text" in params["columns"]
    assert "background.t_low" in params["columns"]  # AnyValues: every threshold by name
    assert "AnnotationContext:context" in recording[paths.CAMERAS]["columns"]
    assert "AnnotationContext:context" in recording[paths.camera_layer("cam0", "masks")]["columns"]


def test_blob_values_ride_with_boxes(recording: dict[str, Any]) -> None:
    cols = recording[paths.camera_layer("cam1", "blobs")]["columns"]
    assert {"area_px", "area_threshold_px", "max_distance", "mean_flow_px", "is_mvo"} <= cols


def test_metrics_and_events(recording: dict[str, Any]) -> None:
    for cam in ("cam0", "cam1"):
        assert recording[paths.targets_metric(cam)]["rows"] == N_FRAMES
        foot = recording[paths.foot_error(cam)]  # the scene has truth
        assert "Scalars:scalars" in foot["columns"] and foot["rows"] >= N_FRAMES // 2
    for stage in ("background", "tracker", "feet", "pairs"):
        assert recording[paths.stage_ms(stage)]["rows"] == N_FRAMES
    assert recording[paths.log_ms()]["rows"] == N_FRAMES
    assert "TextLog:text" in recording[paths.EVENTS]["columns"]
    assert recording[paths.EVENTS]["rows"] > 0
    assert recording[paths.GROUND_TARGETS]["rows"] == N_FRAMES
    assert recording[paths.GROUND_TRAILS]["rows"] == N_FRAMES
    for cam in ("cam0", "cam1"):  # cues and costs: logged from frame 0, then on changes
        cues = recording[paths.camera_layer(cam, "cues")]
        assert "LineStrips2D:strips" in cues["columns"]
        assert 0 in cues["frames"] and 1 <= cues["rows"] <= N_FRAMES
    costs = recording[paths.pair_costs("cam0", "cam1")]
    assert "TextDocument:text" in costs["columns"]
    assert 0 in costs["frames"] and 1 <= costs["rows"] <= N_FRAMES
    assert recording[paths.GROUND_TRUTH]["rows"] == N_FRAMES  # metres: truth/ground.json
    outline = recording[paths.ground_fov("cam0")]  # logged from frame 0, then on changes
    assert 0 in outline["frames"] and 1 <= outline["rows"] < N_FRAMES
    summary = recording[paths.SUMMARY]
    assert summary["static"] == 1  # the figures --watch compares, labels scored on the truth
    assert {"frames", "idf1_global", "consistency", "idf1_global_online"} <= summary["columns"]


def test_every_logged_path_is_documented(recording: dict[str, Any]) -> None:
    doc = paths.__doc__ or ""
    for entity in recording:
        if entity.startswith("/__"):
            continue
        generic = entity.replace("cam0-cam1", "{a}-{b}").replace("/cam0", "/{cam}") \
            .replace("/cam1", "/{cam}")
        for stage in ("read", "background", "tracker", "feet", "pairs"):
            generic = generic.replace(f"stage_ms/{stage}", "stage_ms/{stage}")
        assert generic.split("/{other}")[0] in doc or generic.rsplit("/", 1)[0] in doc, entity


# ------------------------------------------------------------------------------- pair layers


@pytest.fixture(scope="module")
def pair_recording(tmp_path_factory: pytest.TempPathFactory
                   ) -> tuple[dict[str, Any], Any, Path, Path]:
    """(entities, run summary, clip directory, .rrd) of 100 frames of the 'pair' scenario."""
    gen = pytest.importorskip("mvtrack.generate")
    if not hasattr(gen, "generate_clip"):
        pytest.skip("mvtrack.generate.generate_clip is not available")
    root = tmp_path_factory.mktemp("pair")
    clip = gen.generate_clip(root / "pair", "pair", seed=0, frames=100, size=(320, 240),
                             image_format="png")
    rrd = root / "pair.rrd"
    summary = _record(Path(clip), rrd)
    return read_entities(rrd), summary, Path(clip), rrd


def test_pair_layers(pair_recording: tuple[dict[str, Any], Any, Path, Path]) -> None:
    rec, summary, _, rrd = pair_recording
    a, b = "cam0", "cam1"
    for layer in ("markers", "links"):
        assert rec[paths.pair_layer(a, b, layer)]["rows"] == 100
    info = summary.pairs[0]
    n_lines = len(info["fov_lines"])
    assert info["fov_events"] > 0 and n_lines > 0
    assert "TextLog:text" in rec[paths.EVENTS]["columns"]
    fov_events = [rec.get(paths.camera_layer(c, "fov_events"), {"rows": 0})["rows"]
                  for c in (a, b)]
    assert sum(fov_events) > 0
    for cam, n_events in zip((a, b), fov_events, strict=True):  # each event is written in
        told = {f for f, labels in _box_labels(rrd, cam, "targets").items()  # its target's
                if any(" · enter " in t or " · leave " in t for t in labels)}  # label
        shown = rec.get(paths.camera_layer(cam, "fov_events"), {"frames": []})["frames"]
        assert told <= set(shown) and bool(told) == bool(n_events)
    for cam, other in ((a, b), (b, a)):  # at frame 0, then when they change: lines as
        lines = rec[paths.camera_pair_layer(cam, "fov_lines", other)]  # events accumulate,
        markers = rec[paths.camera_pair_layer(cam, "markers", other)]  # markers every 5 frames
        assert 0 in lines["frames"] and 1 < lines["rows"] < 100
        assert 0 in markers["frames"] and markers["rows"] <= 100 // 5 + 1
        assert (markers["rows"] > 1) == (info["markers"] > 0)
        names = _column(rrd, paths.camera_pair_layer(cam, "fov_names", other), "Points2D:labels")
        strips = _column(rrd, paths.camera_pair_layer(cam, "fov_lines", other),
                         "LineStrips2D:strips")
        at = _column(rrd, paths.camera_pair_layer(cam, "fov_names", other), "Points2D:positions")
        last = max(strips)  # each line is named off its middle, where people cross it
        assert len(names[last]) == len(strips[last]) == len(at[last])
        for name, (p, q), x in zip(names[last], strips[last], at[last], strict=True):
            # named by what gave the line: the events alone (the Hough peak) until the pair
            # has a homography, then (but for a top line) the border through it, plain
            side = re.fullmatch(rf"{other} (left|right|top|bottom) edge"
                                r"(?P<by>\nfrom \d+ events|\nfrom crossers)?", name)
            assert side is not None, name
            assert bool(side["by"]) == (info["H"] is None or side[1] == "top"), name
            low, high = (p, q) if p[1] >= q[1] else (q, p)
            t = np.dot(np.subtract(x, low), np.subtract(high, low)) / np.sum(
                np.subtract(high, low) ** 2)
            assert t == pytest.approx(0.1)
    if n_lines:
        hough = rec[paths.hough_accumulators(a, b)]
        assert "EncodedImage:blob" in hough["columns"] and hough["rows"] >= 1
        assert rec[paths.hough_titles(a, b)]["rows"] == hough["rows"]
    if info["H"] is not None:
        assert rec[paths.pair_layer(a, b, "quality_px")]["rows"] >= 1
        assert rec[paths.camera_pair_layer(b, "projected", a)]["rows"] >= 1


def _column(rrd: Path, entity: str, column: str) -> dict[int, list[Any]]:
    """Frame -> the values of ``column`` on ``entity`` (latest row per frame)."""
    out: dict[int, list[Any]] = {}
    for chunk in RrdReader(rrd).store().stream().to_chunks():
        if str(chunk.entity_path) != entity:
            continue
        rb = chunk.to_record_batch()
        if "frame" in rb.schema.names and column in rb.schema.names:
            for f, values in zip(rb.column("frame").to_pylist(),
                                 rb.column(column).to_pylist(), strict=True):
                out[f] = list(values or [])
    return out


def _box_labels(rrd: Path, cam: str, layer: str = "resolved") -> dict[int, list[str]]:
    """Frame -> labels of the boxes on ``/cameras/{cam}/{layer}`` (latest row per frame)."""
    return _column(rrd, paths.camera_layer(cam, layer), "Boxes2D:labels")


def test_marker_tests_failed_are_counted_per_pair(
        pair_recording: tuple[dict[str, Any], Any, Path, Path]) -> None:
    """The pair's 'marker tests failed' series: on every marker frame, how many links have
    failed each of SPEC §5's tests so far, the totals the pair stage's rejections add up to."""
    from collections import Counter

    from mvtrack.pipeline import run

    _, _, clip, rrd = pair_recording
    failed: Counter[str] = Counter()
    expected: dict[str, dict[int, float]] = {t: {} for t in paths.MARKER_TESTS}

    class Count:
        def on_frame(self, result: Any) -> None:
            markers = result.pairs[("cam0", "cam1")].markers
            if markers.tried:
                failed.update(reason for *_, reason in markers.rejected)
                for test in paths.MARKER_TESTS:
                    expected[test][result.index] = float(failed[test])

    with open_clip(clip) as opened:
        run(opened, _params(), range(100), [Count()])
    every = _params().markers.marker_every_frames
    assert sum(failed.values()) > 0
    for test in paths.MARKER_TESTS:
        shown = _column(rrd, paths.marker_rejections("cam0", "cam1", test), "Scalars:scalars")
        assert set(shown) == set(range(0, 100, every))
        assert {f: v[0] for f, v in shown.items()} == expected[test]


def test_resolved_layer_shows_what_mvtrack_track_writes(
        pair_recording: tuple[dict[str, Any], Any, Path, Path], tmp_path: Path) -> None:
    """The viewer's whole-run layer marks exactly the rows whose meta `mvtrack track` changed
    (tracks.csv against tracks_online.csv), with the new meta, and is empty on other frames."""
    from mvtrack.cli import app as track_app
    from mvtrack.io.results import read_tracks

    _, _, clip, rrd = pair_recording
    out = tmp_path / "res"
    sets = [a for s in SHORT_CLIP for a in ("--set", s)]
    result = CliRunner().invoke(track_app, ["track", str(clip), "--out", str(out), *sets])
    assert result.exit_code == 0, result.output
    final, online = read_tracks(out / "tracks.csv"), read_tracks(out / "tracks_online.csv")
    changed = final.meta != online.meta
    assert changed.sum() > 0  # 100 frames of 'pair': people linked only after they met
    for cam in ("cam0", "cam1"):
        expected: dict[int, list[str]] = {f: [] for f in range(100)}
        for i in np.flatnonzero(changed & (final.camera == cam)):
            expected[int(final.frame[i])].append(f"t{final.target[i]} → m{final.meta[i]}")
        shown = _box_labels(rrd, cam)
        assert {f: sorted(v) for f, v in shown.items()} == \
            {f: sorted(v) for f, v in expected.items()}


def test_identity_switches_cut_by_the_resolution_are_warnings_at_their_frame(
        pair_recording: tuple[dict[str, Any], Any, Path, Path], tmp_path: Path) -> None:
    """cam1's target 7 covers person A, then person B from frame 40 (cam0 sees both apart):
    the whole-run labels cut it there, and the event log says so at that frame."""
    from mvtrack.io.results import TrackRows
    from mvtrack.params import ResolveConfig
    from mvtrack.stages.resolve import resolve_labels
    from mvtrack.viz.sink import RerunSink

    _, _, clip, _ = pair_recording
    frames = np.arange(80)
    rows = [("cam0", 1, 1, frames, 100.0), ("cam0", 2, 2, frames, 200.0),
            ("cam1", 7, 3, frames[:40], 100.0), ("cam1", 7, 3, frames[40:], 200.0)]
    n = sum(len(f) for *_, f, _ in rows)
    feet = np.concatenate([np.c_[100.0 + (40.0 if c == "cam1" else 0.0) + 0.1 * f,
                                 np.full(len(f), y)] for c, _, _, f, y in rows])
    track_rows = TrackRows(
        np.concatenate([f for *_, f, _ in rows]).astype(np.int64),
        np.concatenate([[c] * len(f) for c, _, _, f, _ in rows]),
        np.concatenate([[t] * len(f) for _, t, _, f, _ in rows]).astype(np.int64),
        np.concatenate([[m] * len(f) for _, _, m, f, _ in rows]).astype(np.int64),
        feet, np.c_[feet - [5.0, 50.0], np.tile([10.0, 50.0], (n, 1))], np.full(n, 50.0))
    shift = np.array([[1.0, 0.0, 40.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    res = resolve_labels(track_rows, [("cam0", "cam1", shift)], ResolveConfig())
    assert [(sw.track, sw.cut) for sw in res.switches] == [(("cam1", 7), 40)]
    rrd = tmp_path / "switch.rrd"
    with open_clip(clip) as opened:
        rec = new_recording("switch", deterministic=True)
        rec.save(rrd)
        sink = RerunSink(rec, opened.spec, _params())
        sink.log_resolved(track_rows, res.meta, range(80), res.switches)
        sink.close()
        rec.disconnect()
    warnings = []
    for chunk in RrdReader(rrd).store().stream().to_chunks():
        if str(chunk.entity_path) == paths.EVENTS:
            rb = chunk.to_record_batch()
            if "frame" in rb.schema.names:
                warnings += [(f, t[0]) for f, t in zip(rb.column("frame").to_pylist(),
                                                       rb.column("TextLog:text").to_pylist(),
                                                       strict=True) if "changed person" in t[0]]
    assert warnings == [(40, "whole-run labels: cam1 t7 changed person about here: it matched "
                             "cam0 t1 before and cam0 t2 after, and the two were in view "
                             "together (two people); the two parts are labelled apart")]


# ------------------------------------------------------------------------------- blueprints


def _view_paths(part: Any) -> list[str]:
    """Every origin and contents expression of a blueprint's views."""
    found: list[str] = []
    if isinstance(part, rrb.Blueprint):
        return [p for sub in part.root_container.contents for p in _view_paths(sub)] \
            if part.root_container is not None else []
    if isinstance(part, rrb.View):
        origin = str(part.origin)
        found.append(origin)
        contents = part.contents
        exprs = contents if isinstance(contents, list | tuple) else [contents]
        found += [str(e).replace("$origin", origin) for e in exprs]
        return found
    for sub in getattr(part, "contents", None) or []:
        found += _view_paths(sub)
    return found


@pytest.mark.parametrize("name", sorted(viewer_blueprints.BLUEPRINTS))
@pytest.mark.parametrize("n_cams", [1, 2, 3])
def test_blueprints_build_for_any_number_of_cameras(name: str, n_cams: int) -> None:
    cams = [f"cam{i}" for i in range(n_cams)]
    pairs = [(x, y) for i, x in enumerate(cams) for y in cams[i + 1:]]
    bp = viewer_blueprints.build(name, cams, pairs)
    assert isinstance(bp, rrb.Blueprint)
    found = _view_paths(bp)
    assert found
    for p in found:
        assert p.startswith("/"), p
        assert "*" not in p.rstrip("*").rstrip("/"), f"wildcard inside {p}"
    for cam in cams:
        if name != "pairs" or n_cams > 1:
            assert any(p.startswith(paths.camera(cam)) for p in found), (name, cam)


@pytest.mark.parametrize("name", sorted(viewer_blueprints.BLUEPRINTS))
def test_blueprints_refer_only_to_logged_paths(
        name: str, pair_recording: tuple[dict[str, Any], Any, Path, Path]) -> None:
    logged = set(pair_recording[0])
    bp = viewer_blueprints.build(name, ["cam0", "cam1"], [("cam0", "cam1")])
    for p in _view_paths(bp):
        prefix = p.removesuffix("/**")
        assert any(e == prefix or e.startswith(prefix + "/") for e in logged), p


def test_unknown_layout_names_the_choices() -> None:
    with pytest.raises(ValueError, match="overview"):
        viewer_blueprints.build("nope", ["cam0"], [])


# ------------------------------------------------------------------------------- pieces


def test_meta_colours_are_stable_distinct_and_readable() -> None:
    assert meta_color(7) == meta_color(7)
    assert meta_color(3) == meta_color(3 + PALETTE_SIZE)  # the palette cycles
    ids = range(0, PALETTE_SIZE + 1)  # meta 0 (none, gray) and one full cycle
    rgb = np.array([[meta_color(m) for m in ids]], np.uint8)
    lab = cv2.cvtColor(rgb, cv2.COLOR_RGB2Lab)[0].astype(float)
    lab[:, 0] *= 100 / 255
    delta_e = np.linalg.norm(lab[:, None] - lab[None], axis=2) + np.eye(len(ids)) * 1e9
    assert delta_e.min() > 25.0  # no two metas of a cycle, nor one and the gray, look alike
    assert delta_e[7, 15] > 25.0  # the golden-ratio hues made these two the same green (5.6)
    many = np.array([meta_color(m) for m in range(1, 200)], float) / 255.0
    assert (many @ [0.2126, 0.7152, 0.0722] >= 0.25).all()  # no dark blue label text


def test_metas_image_maps_labels_to_metas() -> None:
    label_image = np.array([[0, 3, 3], [9, 9, 0]], np.int32)
    out = metas_image(label_image, np.array([3, 9]), np.array([5, 300]))
    assert out.dtype == np.uint16
    assert out.tolist() == [[0, 5, 5], [300, 300, 0]]
    assert metas_image(label_image, np.array([3, 9]), np.array([1, 2])).dtype == np.uint8


@pytest.mark.parametrize(("line", "want"), [
    ((1.0, 0.0, -10.0), [[10.0, -0.5], [10.0, 239.5]]),  # x = 10
    ((0.0, 1.0, -5.0), [[-0.5, 5.0], [319.5, 5.0]]),  # y = 5
])
def test_line_clipped_to_frame(line: tuple[float, float, float], want: list[list[float]]) -> None:
    seg = line_strip_in_frame(line, (320, 240))
    assert seg is not None
    assert sorted(seg.tolist()) == sorted(want)
    assert line_strip_in_frame((1.0, 0.0, 1000.0), (320, 240)) is None


# ------------------------------------------------------------------------------- robustness


class _Boom:
    def __init__(self, at: int, exc: BaseException) -> None:
        self.at, self.exc = at, exc

    def __call__(self, done: int, total: int) -> None:
        if done == self.at:
            raise self.exc


@pytest.mark.parametrize("exc", [KeyboardInterrupt(), RuntimeError("boom")])
def test_interrupted_run_leaves_a_readable_recording(scene: Path, tmp_path: Path,
                                                     exc: BaseException) -> None:
    rrd = tmp_path / "cut.rrd"
    with open_clip(scene) as clip:
        rec = new_recording("cut", deterministic=True)
        outputs = open_outputs(rec, Target(save=rrd, viewer="none"),
                               viewer_blueprints.build("overview", ["cam0", "cam1"], []))
        try:
            _, summary = record_run(clip, _params(), range(N_FRAMES), rec,
                                    progress=_Boom(10, exc))
            assert summary.interrupted and summary.frames == 10
        except RuntimeError:
            assert isinstance(exc, RuntimeError)
        finally:
            outputs.close()
    ents = read_entities(rrd)
    assert ents[paths.camera_layer("cam0", "image")]["frames"] == set(range(10))
    assert RrdReader(rrd).blueprints()  # the layout is embedded


def test_recording_embeds_blueprint_and_truth_ground(scene: Path, tmp_path: Path) -> None:
    rrd = tmp_path / "x.rrd"
    _record(scene, rrd, frames=range(0, 3))
    assert len(RrdReader(rrd).blueprints()) == 1
    assert read_truth(scene) is not None


# ------------------------------------------------------------------------------- CLI, bench


def test_cli_saves_without_viewer(scene: Path, tmp_path: Path) -> None:
    rrd = tmp_path / "cli.rrd"
    res = CliRunner().invoke(app, [str(scene), "--save", str(rrd), "--no-viewer",
                                   "--frames", "0:25", "--set", f"background.train_frames={TRAIN}",
                                   "--layout", "camera"])
    assert res.exit_code == 0, res.output
    ents = read_entities(rrd)
    assert ents[paths.camera_layer("cam1", "image")]["frames"] == set(range(25))


def test_cli_frames_count_and_a_frame_without_blobs(scene: Path, tmp_path: Path) -> None:
    """``--frames N`` is the first N frames; a frame with no blob logs without a warning (the
    suite turns warnings into errors): trained on frame 0 alone, frame 0 has no foreground."""
    rrd = tmp_path / "first.rrd"
    res = CliRunner().invoke(app, [str(scene), "--save", str(rrd), "--no-viewer",
                                   "--frames", "4", "--set", "background.train_frames=1"])
    assert res.exit_code == 0, res.output
    assert read_entities(rrd)[paths.camera_layer("cam0", "image")]["frames"] == set(range(4))


@pytest.mark.parametrize(("args", "message"), [
    (["--no-viewer"], "--no-viewer needs --save"),
    (["--no-viewer", "--save", "x.rrd", "--layout", "nope"], "unknown layout"),
    (["--no-viewer", "--save", "x.rrd", "--set", "background.nope=1"], "nope"),
    (["--no-viewer", "--save", "x.rrd", "--jpeg-quality", "0"], "jpeg-quality"),
])
def test_cli_user_errors(scene: Path, tmp_path: Path, args: list[str], message: str) -> None:
    args = [a if a != "x.rrd" else str(tmp_path / a) for a in args]
    res = CliRunner().invoke(app, [str(scene), *args])
    assert res.exit_code == 2
    assert message in " ".join(res.output.split())


def test_bench_logging(scene: Path, tmp_path: Path) -> None:
    with open_clip(scene) as clip:
        result = bench_logging(clip, _params(), range(0, 15), tmp_path)
    d = result.as_dict()
    assert d["frames"] == 15 and d["cameras"] == 2
    assert d["fps_viewer_off"] > 0 and d["fps_viewer_on"] > 0
    assert 1.0 < d["kib_per_frame"] < 200.0
    assert math.isfinite(result.log_ms_per_frame) and result.log_ms_per_frame > 0


def test_layout_saved_from_the_viewer_loads_by_path(scene: Path, tmp_path: Path) -> None:
    rbl = tmp_path / "mine.rbl"
    viewer_blueprints.build("camera", ["cam0", "cam1"], []).save("mvtrack", str(rbl))
    rrd = tmp_path / "rbl.rrd"
    res = CliRunner().invoke(app, [str(scene), "--save", str(rrd), "--no-viewer",
                                   "--frames", "0:22", "--set", f"background.train_frames={TRAIN}",
                                   "--layout", str(rbl)])
    assert res.exit_code == 0, res.output
    assert RrdReader(rrd).blueprints()
    missing = CliRunner().invoke(app, [str(scene), "--save", str(rrd), "--no-viewer",
                                       "--layout", str(tmp_path / "gone.rbl")])
    assert missing.exit_code == 2 and "no such file" in " ".join(missing.output.split())


def test_ground_map_is_bounded_by_where_feet_were_seen() -> None:
    """A reference camera that sees to the horizon has a huge ground outline; the map's extent
    follows the feet seen so far (with a margin of their extent) inside that outline."""
    from types import SimpleNamespace

    import numpy as np

    from mvtrack.viz.sink import RerunSink

    state = SimpleNamespace(_seen_box=None, _ground_from_ref=np.eye(3))  # metres
    lo, hi = np.array([-500.0, -500.0]), np.array([500.0, 500.0])
    unseen = RerunSink._map_box(state, lo, hi, np.zeros((0, 2)))  # type: ignore[arg-type]
    assert np.array_equal(unseen[0], lo) and np.array_equal(unseen[1], hi)
    box = RerunSink._map_box(state, lo, hi, np.array([[0.0, 0.0], [20.0, 10.0]]))  # type: ignore[arg-type]
    assert np.allclose(box[0], [-20.0, -10.0]) and np.allclose(box[1], [40.0, 20.0])
    # the box only grows, and feet far outside the outline do not stretch it
    box = RerunSink._map_box(state, lo, hi, np.array([[5.0, 5.0], [900.0, 0.0]]))  # type: ignore[arg-type]
    assert np.allclose(box[0], [-20.0, -10.0]) and np.allclose(box[1], [40.0, 20.0])


def test_ground_map_chains_homographies_through_a_shared_camera() -> None:
    """'three': cam0-cam2 and cam1-cam2 overlap, cam0-cam1 do not; cam1 reaches the map
    (cam0's ground coordinates) through cam2, and a camera with no valid chain does not."""
    from types import SimpleNamespace

    from mvtrack.stages.homography import HomographyEstimate, HomographyFailure
    from mvtrack.viz.pairs import homographies_to_reference

    def pair(H: np.ndarray | None) -> SimpleNamespace:
        est = HomographyFailure("none") if H is None else HomographyEstimate(
            H, "dlt", 10, np.ones(10, bool), np.zeros(10), 0.0)
        return SimpleNamespace(homography=est)

    h02 = np.array([[1.1, 0.1, 30.0], [0.0, 0.9, -5.0], [1e-4, 0.0, 1.0]])  # cam2 from cam0
    h12 = np.array([[0.8, -0.1, -40.0], [0.05, 1.2, 8.0], [0.0, 2e-4, 1.0]])  # cam2 from cam1
    pairs = {("cam0", "cam2"): pair(h02), ("cam1", "cam2"): pair(h12),
             ("cam3", "cam1"): pair(None)}
    to_ref = homographies_to_reference("cam0", pairs)
    assert sorted(to_ref) == ["cam0", "cam1", "cam2"]
    x1 = np.array([100.0, 120.0, 1.0])  # a foot in cam1 ...
    x2 = h12 @ x1  # ... in cam2 ...
    x0 = np.linalg.solve(h02, x2)  # ... and in cam0
    got = to_ref["cam1"] @ x1
    assert np.allclose(got[:2] / got[2], x0[:2] / x0[2])


def test_a_fov_line_is_named_by_what_gave_it() -> None:
    from mvtrack.stages.fov import FovLine
    from mvtrack.viz.pairs import _line_name

    names = [_line_name(FovLine("cam1", "cam2", "left", (1.0, 0.0, -3.0), 4, 334, source))
             for source in ("events", "homography", "crossers", "prior")]
    assert names == ["cam2 left edge\nfrom 4 events", "cam2 left edge",
                     "cam2 left edge\nfrom crossers", "cam2 left edge\nloaded"]


def test_a_rejected_link_is_told_once_while_it_stays_rejected() -> None:
    from types import SimpleNamespace

    from mvtrack.stages.meta import Conflict, Edge
    from mvtrack.viz.multi import log_meta

    told: list[str] = []
    sink = SimpleNamespace(conflicts_told=set(), event=lambda msg, level=None: told.append(msg))
    link = Edge(("cam1", 5), ("cam2", 8), 1.0, 334, "fov")
    apart = Conflict(link, "cam0", ("cam0", 3), "cam1")

    def meta(*conflicts: Conflict, resumed: tuple = ()) -> SimpleNamespace:
        return SimpleNamespace(conflicts=conflicts, created=(), merged=(), split=(), ended=(),
                               resumed=resumed)

    for frame in (meta(apart), meta(apart), meta(), meta(apart)):
        log_meta(sink, frame)  # type: ignore[arg-type]
    assert told == ["link cam1 t5 ↔ cam2 t8 (fov) rejected: cam0 t3 keeps the meta-target "
                    "(cam0 and cam1 do not overlap)"] * 2
    same_camera = Conflict(Edge(("A", 1), ("B", 8), 3.0, 0), "B", ("B", 7))
    log_meta(sink, meta(same_camera))  # type: ignore[arg-type]
    assert told[-1] == ("link A t1 ↔ B t8 rejected: B t7 keeps the meta-target "
                        "(a meta-target holds one target of B)")
    log_meta(sink, meta(resumed=((5, "cam2", 7),)))  # type: ignore[arg-type]
    assert told[-1] == "cam2 t7 takes back m5, last seen near it there"


def test_the_heights_layer_ends_where_the_size_model_puts_the_feet() -> None:
    """A head at row 39.5 (px edge) with people 0.25 * row + 10 px tall has its feet at row
    66: (66 - 39.5) = 0.25 * 66 + 10, by the line of whole people or, without one, by the
    least-squares line, as the legs regrowth reads them. MVOs cut by the top border (their
    head unseen) and blobs that are not MVOs get no line; without a model, no MVO does."""
    from types import SimpleNamespace

    from mvtrack.stages.background import SizeModel
    from mvtrack.viz.sink import RerunSink

    logged: list[tuple[Any, ...]] = []
    sink = SimpleNamespace(rec=SimpleNamespace(log=lambda path, *arch: logged.append(arch)))
    blobs = SimpleNamespace(box_xywh=np.array([[19.5, 39.5, 10.0, 20.0], [59.5, -0.5, 10.0, 30.0],
                                               [99.5, 39.5, 10.0, 20.0]]),
                            is_mvo=np.array([True, True, False]))
    one = [[[25.0, 40.0], [25.0, 66.5]]]
    for sizes, want in ((SizeModel(line=(0.4, 5.0), whole=(0.25, 10.0)), one),
                        (SizeModel(line=(0.25, 10.0)), one), (SizeModel(), [])):
        bg = SimpleNamespace(blobs=blobs, sizes=sizes)
        RerunSink._log_heights(sink, "cam0", bg)  # type: ignore[arg-type]
        strips = logged[-1][0].as_component_batches()[0].as_arrow_array().to_pylist()
        np.testing.assert_allclose(np.array(strips, np.float64).reshape(-1, 2, 2),
                                   np.array(want, np.float64).reshape(-1, 2, 2))
    assert [len(arch) for arch in logged] == [2, 2, 1]  # hover values with a line


def test_the_truth_layers_draw_this_frames_true_people_and_clear_without_them() -> None:
    from types import SimpleNamespace

    from mvtrack.io.truth import CameraTruth, Truth
    from mvtrack.viz.sink import RerunSink

    ct = CameraTruth("cam0", np.array([3, 3, 4]), np.array([7, 9, 7]),
                     np.array([[10.0, 50.0], [30.0, 60.0], [11.0, 51.0]]),
                     np.array([[4.5, 9.5, 11.0, 41.0], [24.5, 19.5, 12.0, 41.0],
                               [5.5, 10.5, 11.0, 41.0]]), np.array([1.0, 0.6, 1.0]))
    truth = Truth(Path("truth"), {"cam0": ct}, {}, None, None)
    logged: dict[tuple[str, int], tuple[Any, ...]] = {}
    sink = SimpleNamespace(truth=truth, _truth_rows=RerunSink._index_truth(truth))
    for frame in (3, 5):
        sink.rec = SimpleNamespace(
            log=lambda path, *arch, f=frame: logged.__setitem__((path, f), arch))
        RerunSink._log_truth(sink, "cam0", frame)  # type: ignore[arg-type]

    def batch(path: str, frame: int, component: str, archetype: int = 0) -> list[Any]:
        for b in logged[path, frame][archetype].as_component_batches():
            if b.component_descriptor().component.endswith(component):
                return list(b.as_arrow_array().to_pylist())
        raise AssertionError(f"no {component} at {path}")

    boxes, feet = paths.camera_layer("cam0", "truth"), paths.camera_layer("cam0", "truth_feet")
    assert batch(boxes, 3, "person", archetype=1) == [7, 9]  # the hover values
    np.testing.assert_allclose(batch(boxes, 3, "centers"), [[10.5, 30.5], [31.0, 40.5]])
    np.testing.assert_allclose(batch(feet, 3, "positions"), [[10.5, 50.5], [30.5, 60.5]])
    assert batch(boxes, 5, "centers") == [] and batch(feet, 5, "positions") == []
    assert len(logged[boxes, 3]) == 2 and len(logged[boxes, 5]) == 1  # hover values if any


def test_the_event_log_tells_why_a_tracker_label_went_or_came() -> None:
    """Beside births, splits, merges and retirements, the event log tells the fragments a
    target absorbed (a leg or a head tracked apart, which then retires), the people a group
    blob was cut into and the merged targets found hidden, so a label that vanishes or appears
    has its reason at its frame."""
    from types import SimpleNamespace

    from mvtrack.viz.sink import RerunSink

    told: list[str] = []
    sink = SimpleNamespace(event=lambda msg, level=None: told.append(msg))
    tracks = SimpleNamespace(births=(9,), splits=(), merges=((4, (4, 7)),),
                             reunions=((3, (6,)),), groups=((2, (8, 1)),), hidden=(5,),
                             retirements=(5, 6))
    RerunSink._tracker_events(sink, "cam0", SimpleNamespace(tracks=tracks))  # type: ignore[arg-type]
    assert told == ["cam0: new targets t9", "cam0: merged t4 + t7",
                    "cam0: t3 absorbed t6 (parts of one person)",
                    "cam0: group cut into t8, t1 (left to right)",
                    "cam0: t5 hidden (given a sliver of a merged blob for several frames)",
                    "cam0: retired t5, t6"]


def test_the_event_log_tells_what_the_whole_run_labels_did_with_a_pairs_search() -> None:
    from mvtrack.stages.markers import Comotion
    from mvtrack.stages.resolve import WholeRunH
    from mvtrack.viz.pairs import whole_run_h_text

    hypothesis = Comotion(np.eye(3), ((1, 5), (6, 10)), ())
    head = "whole-run labels: pair cam1-cam2: a co-motion search over the run"
    found = f"{head} links [t1 ↔ t5, t6 ↔ t10] (0 candidates); of the targets its H puts "
    assert whole_run_h_text("cam1-cam2", None, False, 0.6) == (
        f"{head} found no homography; the labels keep the run's links")
    assert whole_run_h_text("cam1-cam2", None, True, 0.6) == (
        f"{head} found no homography; the labels use the run's final H")
    assert whole_run_h_text("cam1-cam2", WholeRunH(hypothesis, 0.92, None, True), False,
                            0.6) == (found + "inside the other camera, 92% find one there: "
                                     "the labels use it")
    assert whole_run_h_text("cam1-cam2", WholeRunH(hypothesis, 0.4, None, False), False,
                            0.6).endswith("40% find one there: under 60%, the labels keep the "
                                          "run's links")
    assert whole_run_h_text("cam1-cam2", WholeRunH(hypothesis, 0.68, 0.49, True), True,
                            0.6).endswith("68% find one there (49% with the run's final H): "
                                          "the labels use it instead")
    assert whole_run_h_text("cam1-cam2", WholeRunH(hypothesis, 0.9, 0.9, False), True,
                            0.6).endswith("(90% with the run's final H): the labels use the "
                                          "run's final H")


def test_the_event_log_tells_how_a_pairs_refit_came_out() -> None:
    from mvtrack.stages.homography import HomographyEstimate, HomographyFailure
    from mvtrack.stages.refit import RefitH
    from mvtrack.viz.pairs import refit_h_text

    est = HomographyEstimate(np.eye(3), "robust", 4, np.array([True, True, True, False]),
                             np.zeros(4), 2.34)
    head = "whole-run labels: pair cam0-cam1: H fitted again from the labels' "
    assert refit_h_text("cam0-cam1", RefitH(est, 4, 0.97, 0.96, True)) == (
        f"{head}4 markers, 3 inliers within 2.3 px (median); of the targets it puts inside "
        "the other camera, 97% find one there (96% with the H the labels used): handed on "
        "(pairs.json 'H_refit', --geometry)")
    assert refit_h_text("cam0-cam1", RefitH(est, 4, 0.9, 0.96, False)).endswith(
        "(96% with the H the labels used): too few, the H in use is handed on")
    assert refit_h_text("cam0-cam1", RefitH(HomographyFailure("1 markers, need 4", 1), 1, None,
                                            0.96, False)) == (
        f"{head}1 markers failed (1 markers, need 4); the H in use is handed on")


def test_the_event_log_tells_the_co_motion_rounds_of_a_pair_without_a_homography() -> None:
    """While a pair has no homography, each co-motion round that differs from the last is one
    line: what was pooled, the held hypotheses' verdicts, what the search found and what was
    accepted. A pair waiting for people to walk by logs nothing new until someone does."""
    import dataclasses
    from types import SimpleNamespace

    from mvtrack.stages.pair import BootstrapRound
    from mvtrack.viz.pairs import _log_bootstrap
    from mvtrack.viz.sink import RerunSink

    told: list[str] = []
    sink = SimpleNamespace(event=lambda msg, level=None: told.append(msg), _last_keys={})
    sink.event_changed = lambda *a: RerunSink.event_changed(sink, *a)  # type: ignore[arg-type]
    waiting = BootstrapRound(25, 40, 6, 2, 3)
    swap = ((1, 102), (2, 101))
    found = ((4, 104), (5, 105), (6, 106))
    rounds = [waiting, dataclasses.replace(waiting, frame=50), BootstrapRound(75, 52, 8, 5, 3,
              verdicts=((swap, "unrefuted"),), found=found, accepted=found)]
    for r in rounds:
        _log_bootstrap(sink, ("cam0", "cam1"), SimpleNamespace(bootstrap=r))  # type: ignore[arg-type]
    assert told == [
        "pair cam0-cam1: co-motion round: 40 candidates of 6 target pairs, 2 with enough to "
        "follow a homography; no homography that 3 of them follow",
        "pair cam0-cam1: co-motion round: 52 candidates of 8 target pairs, 5 with enough to "
        "follow a homography; held [t1 ↔ t102, t2 ↔ t101] unrefuted; search found "
        "[t4 ↔ t104, t5 ↔ t105, t6 ↔ t106]; accepted [t4 ↔ t104, t5 ↔ t105, t6 ↔ t106]"]
