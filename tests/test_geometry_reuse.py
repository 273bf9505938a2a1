"""Reusing learned geometry: the cameras are static, so what one run learned (pairs.json) can
start another run of the same cameras (`mvtrack track --geometry`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from typer.testing import CliRunner

from mvtrack.cli import app
from mvtrack.io.results import read_pairs

runner = CliRunner()


def _invoke(*args: str) -> None:
    result = runner.invoke(app, list(args))
    assert result.exit_code == 0, result.output


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """One 1200-frame pair clip: geometry learned on frames 600-1199 (other people, same
    cameras), then frames 0-599 tracked cold and with that geometry."""
    root = tmp_path_factory.mktemp("geometry")
    clip = root / "pair"
    _invoke("generate", str(clip), "--scenario", "pair", "--frames", "1200", "--size", "320x240")
    _invoke("track", str(clip), "--out", str(root / "learn"), "--frames", "600:1200",
            "--mask-every", "0")
    _invoke("eval", str(clip), str(root / "learn"))
    out: dict[str, Any] = {"clip": clip, "learned": root / "learn" / "pairs.json",
                           "learn": json.loads((root / "learn" / "metrics.json").read_text())}
    for name, extra in (("cold", []), ("warm", ["--geometry", str(out["learned"])])):
        results = root / name
        _invoke("track", str(clip), "--out", str(results), "--frames", "0:600",
                "--mask-every", "0", *extra)
        _invoke("eval", str(clip), str(results))
        out[name] = json.loads((results / "metrics.json").read_text())
        out[name + "_pairs"] = json.loads((results / "pairs.json").read_text())
    return out


def test_geometry_from_other_frames_labels_people_from_the_first_frame(runs: dict) -> None:
    """The labels as assigned online (what the viewer shows), first 600 frames: cold IDF1 /
    consistency 0.833 / 0.733, with the geometry learned on frames 600-1199 0.915 / 0.962 (H in
    use from frame 0). Resolved over the whole run, both reach 0.994 consistency."""
    cold, warm = runs["cold"]["labels_online"], runs["warm"]["labels_online"]
    (pair,) = runs["warm_pairs"]
    assert pair["H_from_frame"] == 0
    assert pair["fov_lines"] and all(x["from_frame"] >= 0 for x in pair["fov_lines"])
    assert np.allclose(pair["H"], read_pairs(runs["learned"])[0].H_b_from_a)  # kept, not refit
    assert warm["consistency"] >= cold["consistency"] + 0.1, (warm, cold)
    assert warm["idf1_global"] >= cold["idf1_global"] + 0.05, (warm, cold)
    assert runs["warm"]["labels"]["consistency"] >= 0.98, runs["warm"]["labels"]
    (m,) = runs["warm"]["pairs"]
    assert m["transfer_error_px"]["median"] <= 3.0


def test_the_geometry_handed_on_is_the_h_fitted_again_from_the_whole_run_labels(
        runs: dict) -> None:
    """Frames 600-1199: the online H ends 1.61 / 2.21 px off the true one (median / p90),
    the H fitted again from the whole-run labels 1.20 / 2.11 px (1.48 / 2.23 and 1.02 / 1.60
    with the thesis's feet, `feet.anchor = "corners"`); it is handed on, and the warm run
    starts from it."""
    (m,) = runs["learn"]["pairs"]
    online, refit = m["transfer_error_px"], m["refit_transfer_error_px"]
    assert m["refit_h_used"] and refit["points"] == online["points"] > 1000
    assert refit["median"] <= 1.3 and refit["p90"] <= 2.3, refit
    assert refit["median"] < online["median"] and refit["p90"] < online["p90"], (refit, online)
    (pair,) = json.loads(runs["learned"].read_text())
    assert np.allclose(read_pairs(runs["learned"])[0].H_b_from_a, pair["H_refit"]["H"])


@pytest.mark.parametrize("text, message", [
    ("[{\"cameras\": [\"cam0\", \"camX\"], \"H\": null}]", "is not an overlap of this clip"),
    ("[{\"cameras\": [\"cam0\", \"cam1\"], \"H\": [[1, 0], [0, 1]]}]", "finite 3x3 matrix"),
    ("[{\"cameras\": [\"cam0\", \"cam1\"]}]", "missing key 'H'"),
    ("[{\"cameras\": [\"cam0\", \"cam1\"], \"H\": null,"
     " \"H_refit\": {\"H\": [1], \"used\": true}}]",
     "pair 0: 'H_refit' is used, its 'H' must be a finite 3x3 matrix"),
    ("{\"cameras\": 1", "not JSON"),
])
def test_bad_geometry_is_a_clear_error(runs: dict, tmp_path: Path, text: str,
                                       message: str) -> None:
    bad = tmp_path / "pairs.json"
    bad.write_text(text)
    result = runner.invoke(app, ["track", str(runs["clip"]), "--out", str(tmp_path / "r"),
                                 "--frames", "0:5", "--geometry", str(bad)])
    text_out = " ".join(result.output.split())
    assert result.exit_code == 2
    assert str(bad) in result.output.replace("\n", "") and message in text_out, result.output


def test_a_pair_stored_the_other_way_round_is_turned_around() -> None:
    from mvtrack.io.results import LearnedPair
    from mvtrack.pipeline import priors_from

    H = np.array([[1.0, 0.1, 20.0], [0.0, 0.9, -5.0], [1e-4, 0.0, 1.0]])
    line = ("cam1", "cam0", "left", (1.0, 0.0, -40.0), 5)
    (prior,) = priors_from([LearnedPair(("cam1", "cam0"), H, 12, (line,))],
                           [("cam0", "cam1")], "p.json").items()
    assert prior[0] == ("cam0", "cam1")
    assert np.allclose(prior[1].H_b_from_a @ H, np.eye(3))
    assert prior[1].lines == (("cam1", "left", (1.0, 0.0, -40.0), 5),)
    assert prior[1].markers == 12


def test_the_h_handed_on_is_the_refit_else_the_one_the_whole_run_labels_used(
        tmp_path: Path) -> None:
    """`read_pairs` gives the H a run hands on, with the FOV lines through it: its refit
    where used; else the whole-run co-motion H where the labels used it (it explained more
    than the run's own); else H."""
    H, wr, refit = (np.diag([1.0, 1.0, 1.0]) * k for k in (1.0, 2.0, 3.0))

    def lines(c: float) -> list[dict]:
        return [{"seen_in": "cam1", "edge_of": "cam0", "side": "left", "line": [1.0, 0.0, c],
                 "events": 4}]

    pair = {"cameras": ["cam0", "cam1"], "H": H.tolist(), "markers": 12,
            "fov_lines": lines(-10.0),
            "H_whole_run": {"H": wr.tolist(), "candidates": 40, "used": True,
                            "fov_lines": lines(-20.0)},
            "H_refit": {"H": refit.tolist(), "markers": 90, "used": False,
                        "fov_lines": lines(-30.0)}}
    path = tmp_path / "pairs.json"
    for used, (want, markers, c) in (((True, False), (wr, 40, -20.0)),
                                     ((True, True), (refit, 90, -30.0)),
                                     ((False, False), (H, 12, -10.0))):
        pair["H_whole_run"]["used"], pair["H_refit"]["used"] = used  # type: ignore[index]
        path.write_text(json.dumps([pair]))
        (learned,) = read_pairs(path)
        assert np.allclose(learned.H_b_from_a, want) and learned.markers == markers
        assert learned.lines == (("cam1", "cam0", "left", (1.0, 0.0, c), 4),)


def test_the_viewer_takes_the_geometry_too(runs: dict, tmp_path: Path) -> None:
    from mvtrack.viz.cli import app as view_app

    rrd = tmp_path / "warm.rrd"
    ok = runner.invoke(view_app, [str(runs["clip"]), "--frames", "0:20", "--no-viewer",
                                  "--save", str(rrd), "--geometry", str(runs["learned"])])
    assert ok.exit_code == 0, ok.output
    assert rrd.stat().st_size > 0
    bad = tmp_path / "bad.json"
    bad.write_text("[]x")
    result = runner.invoke(view_app, [str(runs["clip"]), "--frames", "0:5", "--no-viewer",
                                      "--save", str(rrd), "--geometry", str(bad)])
    assert result.exit_code == 2 and "not JSON" in " ".join(result.output.split())
    both = runner.invoke(view_app, [str(runs["clip"]), "--watch", str(bad), "--geometry",
                                    str(runs["learned"])])
    assert both.exit_code == 2 and "--watch" in both.output


def test_pairs_of_cameras_left_out_are_skipped() -> None:
    """`--cameras a,b` on a three-camera clip: pairs.json's pairs with the third are ignored,
    a pair the clip does not declare between cameras in use is still an error."""
    from mvtrack.io.results import LearnedPair
    from mvtrack.pipeline import priors_from

    pairs = [LearnedPair(("cam0", "cam1"), np.eye(3), 10, ()),
             LearnedPair(("cam1", "cam2"), np.eye(3), 10, ())]
    priors = priors_from(pairs, [("cam0", "cam1")], "p.json", ["cam0", "cam1"])
    assert list(priors) == [("cam0", "cam1")]
    with pytest.raises(ValueError, match=r"p\.json: pair 1"):
        priors_from(pairs, [("cam0", "cam1")], "p.json", ["cam0", "cam1", "cam2"])
