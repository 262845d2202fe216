"""Config: TOML round trip, unknown keys and bad values rejected, the example config parses."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from walkmon.errors import ConfigError
from walkmon.live.config import (
    DEFAULT_CONFIG,
    Config,
    config_from_dict,
    config_to_toml,
    read_config,
)

REPO = Path(__file__).resolve().parents[2]


def test_round_trip_of_defaults_and_of_changed_values(tmp_path: Path) -> None:
    changed = dataclasses.replace(
        DEFAULT_CONFIG,
        camera=dataclasses.replace(DEFAULT_CONFIG.camera, url='file:/tmp/a "b".mp4?realtime=1'),
        alerts=dataclasses.replace(DEFAULT_CONFIG.alerts, delay_s=3.0, enabled=("lean_forward",)),
        sinks=dataclasses.replace(DEFAULT_CONFIG.sinks, hook_command=("/bin/sh", "-c", "cat > x"), sound=True),
        indicators=dataclasses.replace(DEFAULT_CONFIG.indicators, gait_band_hz=(0.5, 4.0)),
        pipeline=dataclasses.replace(DEFAULT_CONFIG.pipeline, queue_size=7),
    )
    for cfg in (DEFAULT_CONFIG, changed):
        p = tmp_path / "c.toml"
        p.write_text(config_to_toml(cfg))
        assert read_config(p) == cfg
    assert changed != DEFAULT_CONFIG


def test_example_config_parses_and_is_complete() -> None:
    cfg = read_config(REPO / "deploy" / "walkmon.toml")
    assert isinstance(cfg, Config)
    # every key of every section is spelled out in the example (so it documents all of them)
    text = (REPO / "deploy" / "walkmon.toml").read_text()
    for f in dataclasses.fields(Config):
        assert f"[{f.name}]" in text
        for g in dataclasses.fields(getattr(DEFAULT_CONFIG, f.name)):
            assert f"\n{g.name} =" in text, (f.name, g.name)


@pytest.mark.parametrize(
    ("data", "match"),
    [
        ({"camra": {}}, "unknown config section"),
        ({"alerts": {"delay": 3}}, r"unknown key\(s\) delay"),
        ({"alerts": {"delay_s": "soon"}}, "alerts.delay_s: expected a number"),
        # TOML's words (user review: 'expected tuple' for an array written as a string)
        ({"sinks": {"hook_command": "x"}}, "sinks.hook_command: expected an array, got 'x'"),
        ({"alerts": {"delay_s": -1.0}}, "delay_s must be >= 0"),
        ({"alerts": {"enabled": ["lean_backward"]}}, "unknown condition"),
        ({"pipeline": {"queue_size": 2.5}}, "expected a whole number"),
        ({"session": {"log_frames": 1}}, "expected true or false"),
        ({"rotation": {"method": "slow"}}, "fast' or 'paper"),
        ({"indicators": {"gait_band_hz": [1.0]}}, "gait_band_hz"),
        ({"camera": "v4l2:/dev/video0"}, "must be a table"),
    ],
)
def test_bad_config_is_one_clear_config_error(data: dict, match: str) -> None:
    with pytest.raises(ConfigError, match=match):
        config_from_dict(data)


def test_read_config_errors_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such config file"):
        read_config(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[alerts\ndelay_s = 1\n")
    with pytest.raises(ConfigError, match="invalid TOML"):
        read_config(bad)
    unknown = tmp_path / "unknown.toml"
    unknown.write_text("[alerts]\nfoo = 1\n")
    with pytest.raises(ConfigError, match="unknown.toml"):
        read_config(unknown)


@pytest.mark.parametrize(("sinks", "match"), [
    ('hook_command = ["/nonexistent/hook"]', "no program '/nonexistent/hook'"),
    ('hook_command = [""]', "the program is empty"),
    ("hook_command = [\"{script}\"]", "is not executable"),
    ('hook_command = ["no-such-walkmon-hook-xyz"]', "not on PATH"),
    ('sound = true\nsound_command = ["/bin/true"]\nsound_file = "/nonexistent.wav"', "sound_file"),
    ('apprise_urls = ["notaurl"]', "apprise does not accept"),
])
def test_alert_sinks_that_cannot_work_fail_the_check_and_the_start(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                   sinks: str, match: str) -> None:
    """User review: a missing, empty or non-executable hook, a missing sound file and a malformed apprise URL all
    read 'ok' from 'config --check', and 'live' started and lost the first alert. Now both stop in one line."""
    from walkmon.commands.cli import main

    script = tmp_path / "hook.sh"
    script.write_text("#!/bin/sh\nexit 0\n", encoding="utf-8")
    script.chmod(0o644)
    cfg = tmp_path / "walkmon.toml"
    cfg.write_text("[sinks]\n" + sinks.replace("{script}", str(script)) + "\n", encoding="utf-8")
    cfg.chmod(0o600)
    assert main(["config", "--check", str(cfg)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and match in err and str(cfg) in err  # the file named, as read_config does
    assert main(["live", "--config", str(cfg), "--camera", "sim:normal:1?width=64&height=48&realtime=0",
                 "--data-dir", str(tmp_path / "data"), "--status", "none"]) == 2
    assert match in capsys.readouterr().err
    assert not (tmp_path / "data" / "walkmon.sqlite").exists()  # no session was started
    script.chmod(0o755)
    if "is not executable" in match:
        assert main(["config", "--check", str(cfg)]) == 0


@pytest.mark.parametrize(("host", "ok"), [("127.0.0.1", True), ("127.8.9.1", True), ("::1", True), ("localhost", True),
                                          ("127.example.com", False), ("0.0.0.0", False)])
def test_only_a_loopback_host_goes_without_a_token(host: str, ok: bool) -> None:
    """'127.example.com' passed as loopback (a prefix test) while the server's own test refused it."""
    from walkmon.live.config import ServeSettings

    if ok:
        ServeSettings(host=host)
    else:
        with pytest.raises(ValueError, match="not loopback"):
            ServeSettings(host=host)


def test_check_says_which_set_keys_do_nothing(tmp_path, capsys) -> None:
    """User review: '[indicators] bend_pitch_deg = 40' passed 'config --check' as ok, and a -17 deg walk was still
    labelled bend: those keys only load (older files), the labels come from the classifier's thresholds."""
    from walkmon.commands.cli import main

    cfg = tmp_path / "walkmon.toml"
    cfg.write_text("[indicators]\nbend_pitch_deg = 40.0\nshoulder_down_roll_deg = 1.0\n", encoding="utf-8")
    cfg.chmod(0o600)
    assert main(["config", "--check", str(cfg)]) == 0
    out = capsys.readouterr().out
    assert "ok (not used: indicators.bend_pitch_deg, indicators.shoulder_down_roll_deg;" in out
    plain = tmp_path / "plain.toml"
    plain.write_text("[indicators]\nbend_pitch_deg = 10.0\n", encoding="utf-8")  # the default: nothing to say
    plain.chmod(0o600)
    assert main(["config", "--check", str(plain)]) == 0
    assert capsys.readouterr().out.strip() == f"{plain}: ok"
