"""report.html: self-contained, all figures embedded, renders in headless Chromium; the indicators CLI end to end."""

from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

from walkmon.commands.cli import main
from walkmon.gait.indicators import compute_indicators
from walkmon.gait.report import render_report
from walkmon.tables import write_table

FS = 30.0


def _walk(pitch_offset: float = 0.0, seconds: float = 14.0) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, seconds, 1 / FS)
    up = np.clip(t - 2.0, 0, 1)
    down = np.clip(seconds - 2.0 - t, 0, 1)
    env = (0.5 - 0.5 * np.cos(np.pi * up)) * (0.5 - 0.5 * np.cos(np.pi * down))
    f = 1.75
    pitch = env * (pitch_offset + np.cos(2 * np.pi * f * t))
    yaw = env * 1.5 * np.sin(np.pi * f * t) + 0.2 * t
    roll = env * 2.0 * np.sin(np.pi * f * t + 0.3)
    return t, np.column_stack([pitch, yaw, roll])


@pytest.fixture(scope="module")
def report_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("report")
    t, a = _walk(-12.0)
    base = compute_indicators(*_walk(0.0))
    ind = compute_indicators(t, a, baseline=base)
    path = out / "report.html"
    path.write_text(render_report(t, a, ind, baseline=base, meta={"walk": "synthetic bend", "seed": 3}), encoding="utf-8")
    return path


def test_report_is_self_contained_with_every_figure(report_path: Path) -> None:
    text = report_path.read_text(encoding="utf-8")
    assert text.startswith("<!DOCTYPE html>")
    images = re.findall(r"src='data:image/png;base64,([A-Za-z0-9+/=]+)'", text)
    assert len(images) == 5  # raw+trend, detrended, windowed, spectra, extremums
    for b64 in images:
        png = base64.b64decode(b64)
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    # nothing fetched from outside the file
    assert not re.search(r"""(src|href)=['"](?!data:)""", text)
    for needle in ("bend", "baseline", "difference", "synthetic bend", "cadence", "&rho;&#772;<sub>p</sub>"):
        assert needle in text


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def test_report_renders_in_headless_chromium(report_path: Path, tmp_path: Path) -> None:
    browser = _chromium()
    if browser is None:
        pytest.skip("chromium is not installed (Debian: apt-get install -y chromium); cannot check the rendering")
    png = tmp_path / "shot.png"
    width, height = 1000, 6000  # the paper figures are in the appendix, after the first page
    with tempfile.TemporaryDirectory() as profile:
        cmd = [
            browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
            "--no-first-run", f"--user-data-dir={profile}", f"--screenshot={png}", f"--window-size={width},{height}",
            "--hide-scrollbars", report_path.as_uri(),
        ]
        subprocess.run(cmd, capture_output=True, timeout=90, check=False)
    assert png.is_file(), "chromium wrote no screenshot"
    import matplotlib.image  # noqa: PLC0415

    img = matplotlib.image.imread(png)
    assert img.shape[:2] == (height, width)
    rgb = img[..., :3]
    # not blank: many distinct colours, and plenty of non-white pixels (text, tables, the coloured curves)
    assert np.mean(np.any(rgb < 0.9, axis=-1)) > 0.03
    assert len(np.unique((rgb * 255).astype(np.uint8).reshape(-1, 3), axis=0)) > 50
    # the curves' colours (pitch blue, yaw green, roll red) are on the page: the embedded figures were drawn
    for colour in ((0x1F, 0x77, 0xB4), (0x2C, 0xA0, 0x2C), (0xD6, 0x27, 0x28)):
        assert np.all(np.abs(rgb - np.array(colour) / 255) < 0.1, axis=-1).sum() > 20, colour


def test_indicators_cli_end_to_end(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    t, a = _walk(0.0)
    csv = tmp_path / "normal" / "truth.csv"
    write_table(csv, {"t": t, "pitch": a[:, 0], "yaw": a[:, 1], "roll": a[:, 2], "x": t * 0, "y": t * 0, "z": t})
    assert main(["indicators", str(csv), "--out", str(tmp_path / "n")]) == 0
    doc = json.loads((tmp_path / "n" / "indicators.json").read_text())
    assert doc["classification"]["label"] == "normal"
    assert doc["cadence_spm"] == pytest.approx(105.0, rel=0.005)
    assert (tmp_path / "n" / "report.html").stat().st_size > 50_000
    t, a = _walk(-12.0)
    csv2 = tmp_path / "bent" / "angles.csv"
    write_table(csv2, {"t": t, "pitch": a[:, 0], "yaw": a[:, 1], "roll": a[:, 2]})
    rc = main(["indicators", str(csv2), "--out", str(tmp_path / "b"), "--baseline",
               str(tmp_path / "n" / "indicators.json"), "--mode", "walkmon"])
    assert rc == 0
    doc = json.loads((tmp_path / "b" / "indicators.json").read_text())
    assert doc["classification"]["label"] == "bend"
    assert doc["axes"]["pitch"]["inclination_mean"] == pytest.approx(-12.0, abs=0.1)
    assert "bend" in capsys.readouterr().out
    assert main(["indicators", str(csv2), "--out", str(tmp_path / "p"), "--mode", "paper"]) == 0
    assert json.loads((tmp_path / "p" / "indicators.json").read_text())["mode"] == "paper"


def test_indicators_cli_reports_the_absolute_angles_of_an_imu_angles_csv(tmp_path: Path) -> None:
    """An angles.csv as 'walkmon analyze --imu' writes it: pitch_abs/roll_abs (nan where a frame was not fused)
    beside the start-relative angles and text columns; the report gets the section analyze gives it."""
    t, a = _walk(0.0)
    pitch_abs, roll_abs = a[:, 0] - 7.0, a[:, 2] + 2.0
    pitch_abs[:30] = roll_abs[:30] = np.nan  # the first second not fused
    csv = tmp_path / "angles.csv"
    write_table(csv, {"t": t, "pitch": a[:, 0], "yaw": a[:, 1], "roll": a[:, 2], "pitch_abs": pitch_abs,
                      "roll_abs": roll_abs, "visual_used": ["1"] * len(t), "model": ["rotation"] * len(t)})
    assert main(["indicators", str(csv), "--out", str(tmp_path / "imu")]) == 0
    html = (tmp_path / "imu" / "report.html").read_text()
    assert "<h2>Absolute pitch and roll (against gravity)</h2>" in html
    n = len(t)
    assert f"<tr><td>frames with absolute angles</td><td>{n - 30} of {n}</td></tr>" in html
    assert f"<tr><td>pitch_abs mean [deg]</td><td>{np.mean(pitch_abs[30:]):.3f}</td></tr>" in html
    assert f"<tr><td>roll_abs max [deg]</td><td>{np.max(roll_abs[30:]):.3f}</td></tr>" in html
    # the same angles without those columns, or with them all nan (an exported camera-only session): no section
    write_table(csv, {"t": t, "pitch": a[:, 0], "yaw": a[:, 1], "roll": a[:, 2]})
    assert main(["indicators", str(csv), "--out", str(tmp_path / "cam")]) == 0
    assert "Absolute pitch and roll" not in (tmp_path / "cam" / "report.html").read_text()
    write_table(csv, {"t": t, "pitch": a[:, 0], "yaw": a[:, 1], "roll": a[:, 2], "pitch_abs": t * np.nan,
                      "roll_abs": t * np.nan})
    assert main(["indicators", str(csv), "--out", str(tmp_path / "nan")]) == 0
    assert "Absolute pitch and roll" not in (tmp_path / "nan" / "report.html").read_text()


def test_absolute_angles_follow_the_analysis_onto_a_uniform_grid(tmp_path: Path) -> None:
    """Irregular time stamps (dropped frames) make the analysis resample the angles onto a uniform grid; the
    absolute angles must be resampled with them, not plotted at the wrong times. pitch_abs = t here, so on the
    grid its mean is the grid's mean, (t0 + t_end) / 2, while the dropped frames skew the raw samples' mean."""
    t, a = _walk(0.0)
    keep = np.ones(len(t), bool)
    keep[len(t) // 2:len(t) // 2 + 60] = False  # 2 s of frames lost in the second half
    t, a = t[keep], a[keep]
    absolute = np.column_stack([t, np.full(len(t), 2.0)])
    ind = compute_indicators(t, a)
    html = render_report(t, a, ind, abs_angles_deg=absolute)
    grid_mean = 0.5 * (t[0] + t[-1])
    assert abs(np.mean(t) - grid_mean) > 0.05  # the raw samples' mean differs at the 3 decimals shown
    assert f"<tr><td>pitch_abs mean [deg]</td><td>{grid_mean:.3f}</td></tr>" in html


@pytest.mark.parametrize(
    ("content", "extra"),
    [(None, []), ("t,pitch,yaw\n0,1,2\n", []), ("t,pitch,yaw,roll\n0,1,x,2\n", []),
     ("t,pitch,yaw,roll\n0,0,0,0\n0.1,0,0,0\n", ["--baseline", "MISSING"])],
)
def test_indicators_cli_errors_are_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str | None, extra: list[str]
) -> None:
    csv = tmp_path / "angles.csv"
    if content is not None:
        csv.write_text(content)
    extra = [str(tmp_path / "missing.json") if e == "MISSING" else e for e in extra]
    try:
        rc = main(["indicators", str(csv), "--out", str(tmp_path / "o"), *extra])
    except SystemExit as exc:  # argparse-level checks (a missing --baseline file) exit before running
        rc = exc.code
    err = capsys.readouterr().err
    assert rc == 2
    assert err.count("\n") == 1 and err.startswith("walkmon indicators: error:")
    assert "Traceback" not in err


def test_analyze_writes_indicators_and_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    session = pytest.importorskip("walkmon.simulate.session")
    # a tiny clip: the plumbing is under test here (the accuracy is the benchmark's job)
    # 12 s: 10 s left the labelled walk at exactly the 8 steps the label needed (6 since 2026-11-27), so a
    # 0.05 deg change of the first step's pitch (the walk's onset found one step later) flipped "normal" to "unclassified"
    sim = session.simulate(tmp_path / "sim", "normal", 12.0, 1, 160, 120)
    out = tmp_path / "est"
    with pytest.raises(SystemExit):  # a missing baseline fails before the rotation estimate runs
        main(["analyze", str(sim.video_path), "--out", str(out), "--baseline", str(tmp_path / "nope.json")])
    assert not out.exists()
    assert main(["analyze", str(sim.video_path), "--calib", str(sim.camera_path), "--out", str(out),
                 "--no-progress"]) == 0
    assert (out / "angles.csv").is_file() and (out / "report.html").stat().st_size > 50_000
    doc = json.loads((out / "indicators.json").read_text())
    assert doc["status"] == "ok"
    assert doc["cadence_spm"] == pytest.approx(sim.meta["segments"][0]["cadence_spm"], rel=0.03)
    assert doc["classification"]["label"] == "normal"
    assert "normal" in capsys.readouterr().out


def test_timeline_seconds_are_drawn_where_they_are() -> None:
    """User review: each timeline.csv second (its t the middle of [t - 0.5, t + 0.5)) was drawn as [t - 1, t]: half
    a second early, the first band from -1 s and the last ending before the recording did."""
    from walkmon.gait.report import timeline_from_columns
    from walkmon.views.svg import timeline_svg

    cols = {"t": [0.0, 1.0, 2.0, 3.0], "activity": ["standing", "standing", "walking", "walking"],
            "label": ["", "", "normal", "normal"], "pitch": [0.0, 0.0, -1.0, -1.0], "roll": [0.0, 0.0, 0.0, 0.0]}
    svg = str(timeline_svg(timeline_from_columns(cols)))
    assert "standing: 0 s - 1.5 s" in svg and "normal: 1.5 s - 3.5 s" in svg
    assert "-1 s" not in svg
    cols["ref_uncertainty_deg"] = [5.0, 0.0, 0.0, 0.0]  # the shading starts at the axis too (review: -0.5 s)
    svg = str(timeline_svg(timeline_from_columns(cols)))
    assert "up to 5.0 deg, 0 s - 0.5 s" in svg and 'rect x="-' not in svg
