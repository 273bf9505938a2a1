"""Thresholds: TOML round trip, overrides, and errors that name the key and the file."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from typer.testing import CliRunner

from mvtrack.cli import app
from mvtrack.params import Params, ParamsError, dump_params, load_params, params_from_dict


def test_defaults_round_trip_through_toml(tmp_path: Path) -> None:
    path = tmp_path / "p.toml"
    path.write_text(dump_params(Params()))
    assert load_params(path) == Params()


def test_changed_values_round_trip(tmp_path: Path) -> None:
    changed = load_params(overrides=["background.t_low=0.07", "feet.method=bbox"])
    assert changed.background.t_low == 0.07
    assert changed.feet.method == "bbox"
    path = tmp_path / "p.toml"
    path.write_text(dump_params(changed))
    assert load_params(path) == changed
    assert load_params(path) != Params()


def test_every_field_is_documented() -> None:
    for stage in dataclasses.fields(Params):
        for f in dataclasses.fields(stage.default_factory()):  # type: ignore[misc]
            assert f.metadata.get("doc"), f"{stage.name}.{f.name} has no doc"


def test_int_accepted_for_float_and_stored_as_float() -> None:
    p = params_from_dict({"background": {"min_mean_flow_px": 1}})
    assert isinstance(p.background.min_mean_flow_px, float)


@pytest.mark.parametrize(
    ("toml", "expected"),
    [
        ("[background]\nt_lo = 0.1\n", "unknown key background.t_lo"),
        ("[backgrund]\nt_low = 0.1\n", "unknown stage [backgrund]"),
        ("[background]\nt_low = 1.5\n", "t_low = 1.5 is out of range"),
        ("[background]\nt_low = 0.3\n", "t_high = 0.25 must be greater than t_low = 0.3"),
        ("[background]\nmin_area_px = 2.5\n", "background.min_area_px = 2.5: expected int"),
        ("[background]\ngray_shadows = 1\n", "background.gray_shadows = 1: expected bool"),
        ("[feet]\nmethod = 'magic'\n", "method = 'magic' must be 'pca' or 'bbox'"),
        ("background = 3\n", "[background] must be a table"),
        ("[background\n", "not valid TOML"),
    ],
)
def test_bad_files_name_the_key_and_file(tmp_path: Path, toml: str, expected: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(toml)
    with pytest.raises(ParamsError) as info:
        load_params(path)
    assert expected in str(info.value)
    assert str(path) in str(info.value)


@pytest.mark.parametrize(
    ("override", "expected"),
    [
        ("background.t_low", "expected stage.key=value"),
        ("t_low=0.1", "expected stage.key=value"),
        ("background.nope=1", "unknown key background.nope"),
        ("background.fifo_n=0", "fifo_n = 0 is out of range"),
    ],
)
def test_bad_overrides(override: str, expected: str) -> None:
    with pytest.raises(ParamsError) as info:
        load_params(overrides=[override])
    assert expected in str(info.value)


def test_override_wins_over_file(tmp_path: Path) -> None:
    path = tmp_path / "p.toml"
    path.write_text("[background]\nt_low = 0.05\n")
    assert load_params(path, ["background.t_low=0.08"]).background.t_low == 0.08
    assert load_params(path).background.t_low == 0.05


def test_missing_file_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ParamsError, match="no such thresholds file"):
        load_params(tmp_path / "absent.toml")


def test_cli_params_show_output_loads_back(tmp_path: Path) -> None:
    runner = CliRunner()
    shown = runner.invoke(app, ["params", "show", "--set", "tracker.min_overlap_px=4"])
    assert shown.exit_code == 0, shown.output
    path = tmp_path / "shown.toml"
    path.write_text(shown.stdout)
    assert load_params(path).tracker.min_overlap_px == 4
    checked = runner.invoke(app, ["params", "check", str(path)])
    assert checked.exit_code == 0 and "ok" in checked.output


def test_cli_params_check_rejects_bad_file(tmp_path: Path) -> None:
    path = tmp_path / "bad.toml"
    path.write_text("[tracker]\nmin_overlap_pixels = 3\n")
    result = CliRunner().invoke(app, ["params", "check", str(path)])
    assert result.exit_code == 2
    assert "unknown key tracker.min_overlap_pixels" in result.output


def test_cli_params_show_uses_clip_thresholds(tmp_path: Path) -> None:
    (tmp_path / "mvtrack.toml").write_text("[background]\nt_low = 0.06\n")
    result = CliRunner().invoke(app, ["params", "show", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "t_low = 0.06" in result.stdout
