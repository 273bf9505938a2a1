"""`mvtrack sweep` (mvtrack/sweep.py): variants, the figures of a run, means, the command."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest
from typer.testing import CliRunner

from mvtrack.cli import app
from mvtrack.sweep import (
    COLUMNS,
    SweepPlan,
    Variant,
    _generate,
    check_plan,
    clip_name,
    parse_variant,
    summary_row,
    variant_means,
)

runner = CliRunner()


def test_parse_variant() -> None:
    assert parse_variant("low:background.t_low=0.08") == Variant(
        "low", ("background.t_low=0.08",))
    assert parse_variant(" two : a.b=1 , c.d=x ") == Variant("two", ("a.b=1", "c.d=x"))
    assert parse_variant("same:") == Variant("same", ())
    for bad in ("background.t_low=0.08", ":a.b=1", "x/y:a.b=1", "low:a.b"):
        with pytest.raises(ValueError, match="--variant"):
            parse_variant(bad)


def test_plan_errors_name_what_is_wrong(tmp_path: Path) -> None:
    def plan(scenarios: list[str], *variants: Variant) -> SweepPlan:
        return SweepPlan(scenarios, [0], [Variant("defaults", ()), *variants], tmp_path)

    with pytest.raises(ValueError, match=r"unknown scenario.*nope"):
        check_plan(plan(["pair", "nope"]))
    with pytest.raises(ValueError, match=r"variant 'bad'.*background.t_lo"):
        check_plan(plan(["pair"], Variant("bad", ("background.t_lo=0.1",))))
    with pytest.raises(ValueError, match="repeat"):
        check_plan(plan(["pair"], Variant("defaults", ("background.t_low=0.1",))))
    check_plan(plan(["pair"], Variant("ok", ("background.t_low=0.12",))))
    assert clip_name("pair", 2, 600, (320, 240)) == "pair-seed2-600f-320x240"


def _metrics(idf1: float, p90: float | None) -> dict:
    pair_h = {"first_valid_H": {"frame": 125}, "transfer_error_px": {"median": 2.0, "p90": p90},
              "handed_on_transfer_error_px": {"median": 2.0, "p90": p90},
              "fov_lines": [{"learned": True, "visible_length_px": 80, "error_px_mean": 4.5,
                             "handed_on_error_px_mean": 2.5},
                            {"learned": True, "visible_length_px": 20, "error_px_mean": 30.0,
                             "handed_on_error_px_mean": 30.0}]}
    no_h = {"first_valid_H": None, "transfer_error_px": {"median": None, "p90": None},
            "fov_lines": [{"learned": False, "visible_length_px": 90, "error_px_mean": None}],
            "whole_run_h_used": True,
            "handed_on_transfer_error_px": {"median": 1.5, "p90": 4.0}}
    return {
        "cameras": {"cam0": {"recall": 0.96, "precision": 0.94, "foot_error_px_median": 3.6},
                    "cam1": {"recall": 0.93, "precision": 0.97, "foot_error_px_median": 2.5}},
        "labels": {"idf1_global": idf1, "idf1_global_loss_identity": 0.01, "consistency": 0.99,
                   "occlusion_recovery": math.nan},
        "labels_online": {"idf1_global": 0.8},
        "pairs": [pair_h, no_h],
    }


def test_summary_row_takes_the_worst_camera_and_pair() -> None:
    row = summary_row(_metrics(0.944, 4.5))
    assert list(row) == list(COLUMNS)
    assert row["idf1"] == 0.944 and row["idf1_online"] == 0.8
    assert row["idf1_loss_identity"] == 0.01
    assert (row["recall_min"], row["precision_min"], row["foot_median_px_max"]) == (
        0.93, 0.94, 3.6)
    assert (row["h_median_px_max"], row["h_p90_px_max"], row["h_first_frame_max"]) == (
        2.0, 4.5, 125)
    assert row["pairs_without_h"] == 1 and row["whole_run_h_used"] == 1
    assert row["h_end_p90_px_max"] == 4.5  # the refit handed on (4.0), not the one left (9.0)
    assert row["fov_line_px_max"] == 4.5  # the 20 px line is too short to judge
    assert row["fov_line_end_px_max"] == 2.5  # the lines of the H handed on
    assert row["occlusion_recovery"] is None  # NaN: no occlusion episode


def test_variant_means_compare_over_the_same_clips() -> None:
    rows = [
        {"scenario": "pair", "seed": 0, "variant": "defaults", **summary_row(_metrics(0.9, 4.0))},
        {"scenario": "pair", "seed": 1, "variant": "defaults", **summary_row(_metrics(0.7, 8.0))},
        {"scenario": "pair", "seed": 0, "variant": "v", **summary_row(_metrics(0.95, None))},
    ]
    means = variant_means(rows)
    assert [m["variant"] for m in means] == ["defaults", "v"]
    assert means[0]["runs"] == 2 and means[0]["idf1"] == pytest.approx(0.8)
    assert means[0]["d_idf1"] is None
    assert means[1]["d_idf1"] == pytest.approx(0.05)  # against seed 0 only
    assert means[1]["h_p90_px_max"] is None and means[1]["d_h_p90_px_max"] is None


def test_sweep_runs_track_and_eval_on_generated_clips(tmp_path: Path) -> None:
    """A real sweep: the clip is generated once and reused; each run's figures are the ones
    `mvtrack track` + `mvtrack eval` give on the same clip and thresholds."""
    out, clips = tmp_path / "sweep", tmp_path / "clips"
    args = ["sweep", "--out", str(out), "--clips", str(clips), "--scenarios", "pair",
            "--seeds", "0", "--frames", "120", "--size", "160x120", "--jobs", "2",
            "--variant", "hi:background.t_low=0.16"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    with (out / "sweep.csv").open(newline="") as f:
        rows = list(csv.DictReader(f))
    assert [(r["scenario"], r["variant"]) for r in rows] == [("pair", "defaults"), ("pair", "hi")]
    summary = json.loads((out / "sweep.json").read_text())
    assert [m["variant"] for m in summary["means"]] == ["defaults", "hi"]
    clip = clips / "pair-seed0-120f-160x120"
    assert (clip / "clip.toml").is_file()
    made = (clip / "clip.toml").stat().st_mtime_ns

    alone = tmp_path / "alone"
    for cmd in (["track", str(clip), "--out", str(alone), "--set", "background.t_low=0.16"],
                ["eval", str(clip), str(alone)]):
        assert runner.invoke(app, cmd).exit_code == 0
    expected = summary_row(json.loads((alone / "metrics.json").read_text()))
    got = summary["runs"][1]
    keys = ("idf1", "consistency", "recall_min", "precision_min", "foot_median_px_max")
    for key in keys:
        assert got[key] == pytest.approx(expected[key]), key
    defaults = summary["runs"][0]
    assert [defaults[k] for k in keys] != [got[k] for k in keys]  # the variant changed things
    assert (out / "runs" / "hi" / clip.name / "metrics.json").is_file()

    again = runner.invoke(app, [*args[:-2], "--variant", "lo:background.t_low=0.08"])
    assert again.exit_code == 0, again.output
    assert (clip / "clip.toml").stat().st_mtime_ns == made  # the cached clip was reused


def test_a_variant_of_finishing_thresholds_finishes_the_defaults_run_again(tmp_path: Path
                                                                          ) -> None:
    """Only resolve.* and feet.smooth_* differ: the variant's run is the defaults' run
    finished again (not tracked: same timings), and its files are the ones `mvtrack track`
    writes with those thresholds."""
    out, clips = tmp_path / "sweep", tmp_path / "clips"
    sets = ["resolve.labels=online", "feet.smooth_seconds=0"]
    result = runner.invoke(app, [
        "sweep", "--out", str(out), "--clips", str(clips), "--scenarios", "pair", "--seeds", "0",
        "--frames", "120", "--size", "160x120", "--jobs", "2",
        "--variant", "raw:" + ",".join(sets), "--variant", "hi:background.t_low=0.16"])
    assert result.exit_code == 0, result.output
    clip = clips / "pair-seed0-120f-160x120"
    runs = {v: out / "runs" / v / clip.name for v in ("defaults", "raw", "hi")}
    info = {v: json.loads((d / "run.json").read_text()) for v, d in runs.items()}
    assert info["raw"]["thresholds"]["resolve"]["labels"] == "online"
    assert info["raw"]["seconds"] == info["defaults"]["seconds"]  # not tracked again
    assert info["hi"]["seconds"] != info["defaults"]["seconds"]
    assert not (runs["raw"] / "tracks_online.csv").exists()

    alone = tmp_path / "alone"
    args = ["track", str(clip), "--out", str(alone)]
    for s in sets:
        args += ["--set", s]
    assert runner.invoke(app, args).exit_code == 0
    for name in ("tracks.csv", "cues.csv", "pairs.json"):
        assert (runs["raw"] / name).read_bytes() == (alone / name).read_bytes(), name
    assert (runs["raw"] / "tracks.csv").read_bytes() != (runs["defaults"] / "tracks.csv"
                                                          ).read_bytes()
    summary = json.loads((out / "sweep.json").read_text())
    assert [r["variant"] for r in summary["runs"]] == ["defaults", "raw", "hi"]
    assert all(r["error"] is None for r in summary["runs"])


def test_refinishing_refuses_other_tracking_thresholds(tmp_path: Path) -> None:
    """refinish_to names the tracking thresholds that differ and writes nothing."""
    from mvtrack.batch import refinish_to
    from mvtrack.generate import generate_clip
    from mvtrack.io import open_clip
    from mvtrack.params import load_params

    clip = generate_clip(tmp_path / "clip", "pair", seed=0, frames=40, size=(160, 120))
    run = tmp_path / "run"
    assert runner.invoke(app, ["track", str(clip), "--out", str(run)]).exit_code == 0
    with open_clip(clip) as opened:
        same = tmp_path / "same"
        refinish_to(run, same, load_params(None), opened.spec)
        for name in ("tracks.csv", "cues.csv", "tracks_online.csv"):
            assert (same / name).read_bytes() == (run / name).read_bytes(), name
        other = load_params(None, ["background.t_low=0.2", "resolve.labels=online"])
        with pytest.raises(ValueError, match=r"background\.t_low\)"):
            refinish_to(run, tmp_path / "other", other, opened.spec)
    assert not (tmp_path / "other").exists()


def test_sweep_refuses_a_bad_variant_before_any_work(tmp_path: Path) -> None:
    result = runner.invoke(app, ["sweep", "--out", str(tmp_path / "s"), "--scenarios", "pair",
                                 "--variant", "x:background.nope=1"])
    assert result.exit_code != 0
    assert "variant 'x'" in result.output and "background.nope" in result.output
    assert not (tmp_path / "s" / "clips").exists()


def test_a_failing_run_does_not_stop_the_sweep(tmp_path: Path) -> None:
    """A broken clip in the cache fails its runs with the reason (a re-finished variant's
    too, naming the run it needed); the others finish and the tables are written; the command
    exits with an error."""
    out, clips = tmp_path / "sweep", tmp_path / "clips"
    broken = clips / "gray-seed0-60f-160x120"
    broken.mkdir(parents=True)
    (broken / "clip.toml").write_text("fps = 25.0\n[[camera]]\nname = 'cam0'\n")
    result = runner.invoke(app, ["sweep", "--out", str(out), "--clips", str(clips),
                                 "--scenarios", "pair,gray", "--frames", "60",
                                 "--size", "160x120", "--jobs", "1",
                                 "--variant", "gap:resolve.stitch_max_gap_frames=75"])
    assert result.exit_code == 2
    assert "2 runs failed" in result.output
    runs = json.loads((out / "sweep.json").read_text())["runs"]
    assert [(r["scenario"], r["variant"], bool(r["error"])) for r in runs] == [
        ("pair", "defaults", False), ("pair", "gap", False),
        ("gray", "defaults", True), ("gray", "gap", True)]
    assert "clip.toml" in runs[2]["error"] and runs[2]["idf1"] is None
    assert "finished from the defaults run, which failed" in runs[3]["error"]
    assert runs[0]["recall_min"] > 0.5 and runs[1]["recall_min"] == runs[0]["recall_min"]


def test_sweep_names_a_bad_option(tmp_path: Path) -> None:
    for args, message in ((["--seeds", "0,x"], "--seeds '0,x'"),
                          (["--scenarios", "pair,nope"], "unknown scenario(s) nope"),
                          (["--variant", "nocolon"], "--variant 'nocolon'")):
        result = runner.invoke(app, ["sweep", "--out", str(tmp_path / "s"), *args])
        assert result.exit_code == 2 and message in result.output, result.output



def test_a_clip_that_cannot_be_generated_fails_its_runs(tmp_path: Path) -> None:
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("")
    result = runner.invoke(app, ["sweep", "--out", str(tmp_path / "s"), "--clips", str(blocker),
                                 "--scenarios", "pair", "--frames", "10", "--size", "160x120",
                                 "--variant", "b:background.t_low=0.2", "--jobs", "1"])
    assert result.exit_code == 2 and "2 runs failed" in result.output
    runs = json.loads((tmp_path / "s" / "sweep.json").read_text())["runs"]
    assert [r["variant"] for r in runs] == ["defaults", "b"]
    assert all(r["error"].startswith("generating the clip") for r in runs)



def test_a_clip_another_sweep_generated_first_is_kept(tmp_path: Path) -> None:
    """Two sweeps sharing a clip cache generate the same missing clip at once: each writes a
    folder of its own, and the one that finishes second keeps the first one's clip and no
    leftovers (before, both wrote into one '.partial' folder and the second rename failed:
    'Directory not empty')."""
    path = tmp_path / "clips" / clip_name("pair", 0, 10, (160, 120))
    path.mkdir(parents=True)
    (path / "theirs").write_text("the other sweep's clip")
    assert _generate("pair", 0, 10, (160, 120), path) == path
    assert sorted(p.name for p in path.iterdir()) == ["theirs"]
    assert [p.name for p in path.parent.iterdir()] == [path.name]
    fresh = tmp_path / "clips" / clip_name("pair", 1, 10, (160, 120))
    _generate("pair", 1, 10, (160, 120), fresh)
    assert (fresh / "clip.toml").is_file()
