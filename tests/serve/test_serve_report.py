"""The report's first page for a logged session (walkmon report ID and the dashboard's report link): the plain
summary and the timeline come from the stored hops and alerts; the paper's tables follow in the appendix."""

from __future__ import annotations

import datetime as _dt
import re
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from walkmon.live.alerts import AlertEvent
from walkmon.live.session_log import SessionLog
from walkmon.simulate.gait import GaitModel


def test_report_of_a_logged_session_starts_in_plain_words(tmp_path: Path, make_hop: Any, python_cmd: list[str]) -> None:
    data = tmp_path / "data"
    model = GaitModel("normal:10,bend:10", seed=1)
    log = SessionLog(data, camera="sim", person="Ann")
    t = np.arange(0.0, model.duration_s, 1 / 30)
    for ti, a in zip(t, model.truth_angles_deg(t), strict=True):
        log.add_frame(float(ti), a)
    # hops: walking 3..22 s (20 s), bent (-16 deg) from 13 s: 10 of 20 walking seconds upright
    for s in range(1, 25):
        log.add_hop(make_hop(float(s), walking=3 <= s <= 22, pitch=-16.0 if s >= 13 else 0.0,
                             label="bend" if s >= 13 else "normal", cadence=104.0))
    log.add_alert(AlertEvent(18.0, "lean_forward", "raised", 16.0, 10.0, "leaning forward 16 deg: straighten up"))
    sid = log.session_id
    log.close("complete")
    out = tmp_path / "rep"
    r = subprocess.run([*python_cmd, "report", str(sid), "--data-dir", str(data), "--out", str(out)],
                       capture_output=True, text=True, timeout=180, check=False)
    assert r.returncode == 0, r.stderr
    html = (out / "report.html").read_text()
    summary = re.search(r'<p class="summary">(.*?)</p>', html).group(1)
    assert summary == ("20 s walked, 50 % upright (within the alert thresholds), 1 lean-forward alert, cadence "
                       "104 steps/min.")
    assert "Walking report: Ann" in html
    first, appendix = html.split('<section class="appendix">')
    assert "<svg" in first and "leaning forward 16 deg: straighten up" in first
    assert "walking: bent forward</td><td>10 s</td>" in first and "walking: upright, normal walk</td><td>10 s</td>" in first
    assert "paper Table 3" in appendix and appendix.count("data:image/png;base64,") == 5
    assert "<script" not in html  # a report is a document: no scripts


def test_an_offline_report_says_where_its_timeline_comes_from(tmp_path: Path) -> None:
    from walkmon.gait.indicators import compute_indicators
    from walkmon.gait.report import render_report, timeline_from_columns

    model = GaitModel("normal:12", seed=2)
    t = np.arange(0.0, model.duration_s, 1 / 30)
    a = model.truth_angles_deg(t)
    ind = compute_indicators(t, a)
    html = render_report(t, a, ind)
    assert "from the angles alone" in html
    # a gait timeline (timeline.csv columns) drives the figure and the time per posture when given
    cols = {"t": [1.0, 2.0, 3.0, 4.0], "activity": ["standing", "walking", "walking", "turning"],
            "label": ["", "normal", "bend", ""], "pitch": [0.0, -1.0, -15.0, ""], "roll": [0.0, 0.5, 0.5, 0.0]}
    tl = timeline_from_columns(cols)
    assert tl["hops"]["walking"] == [False, True, True, False] and tl["hops"]["pitch"][3] is None
    html = render_report(t, a, ind, timeline=tl, timeline_source="From timeline.csv.")
    assert "From timeline.csv." in html and "<td>turning</td><td>1 s</td>" in html
    assert "walking: bent forward</td><td>1 s</td>" in html
    # the straight walking the history counts and the posture share is over (2 of the timeline's seconds), and the
    # analysis's own time in walking bouts beside it (user review: the two disagreed, unsaid why)
    assert f"2 s of straight walking ({ind.walking_s:.0f} s in walking bouts, turns and stops included)" in html
    assert "upright reference uncertain" not in html
    # seconds whose upright reference may be off (timeline.csv's ref_uncertainty_deg) are shaded, with the bound
    cols["ref_uncertainty_deg"] = [0.0, 0.0, 12.5, 0.4]
    tl = timeline_from_columns(cols)
    assert tl["hops"]["uncertainty"] == [0.0, 0.0, 12.5, 0.4]
    html = render_report(t, a, ind, timeline=tl, timeline_source="From timeline.csv.")
    # (the row at t = 3 s is the second [2.5, 3.5))
    assert html.count("upright reference uncertain by up to") == 1 and "up to 12.5 deg, 2.5 s - 3.5 s" in html
    assert "grey: upright reference uncertain by more than 1 deg" in html
    # a certain second between two uncertain ones is not shaded: two bands (review)
    cols["ref_uncertainty_deg"] = [5.0, 0.0, 7.0, 0.0]
    html = render_report(t, a, ind, timeline=timeline_from_columns(cols), timeline_source="From timeline.csv.")
    assert "up to 5.0 deg, 0.5 s - 1.5 s" in html and "up to 7.0 deg, 2.5 s - 3.5 s" in html


@pytest.mark.parametrize(("since", "days"), [("30d", 30.0), ("2w", 14.0), ("12h", 0.5), ("7", 7.0)])
def test_since_spans(since: str, days: float) -> None:
    from walkmon.views.history import parse_since

    assert parse_since(since).total_seconds() == pytest.approx(days * 86400)
    with pytest.raises(ValueError, match="positive span"):
        parse_since("-" + since)


@pytest.mark.parametrize("since", ["1000000d", "99999999999d", "1e9", "1e300w"])
def test_a_span_beyond_the_calendar_is_all_of_history(since: str) -> None:
    """A span longer than any history (user review: 'now - span' overflowed, a traceback from 'walkmon history')
    is all of it: a century."""
    from walkmon.views.history import MAX_SINCE_DAYS, parse_since

    span = parse_since(since)
    assert span.days == MAX_SINCE_DAYS
    assert _dt.datetime.now(_dt.UTC) - span < _dt.datetime(1930, 1, 1, tzinfo=_dt.UTC)


def test_the_timeline_curve_breaks_at_a_gap_of_the_recording() -> None:
    """A timeline has no rows inside a gap of the recording (nothing measured there); the pitch and roll curves
    must not draw a line across it as if measured (found in review)."""
    import re

    from walkmon.views.svg import timeline_svg

    t = [float(v) for v in [*range(1, 6), *range(12, 17)]]
    hops = {"t_s": t, "activity": ["walking"] * 10, "label": ["normal"] * 10, "walking": [True] * 10,
            "pitch": [1.0] * 10, "roll": [0.5] * 10}
    svg = str(timeline_svg({"hops": hops, "alerts": [], "thresholds": {}, "hop_s": 1.0}))
    assert len(re.findall(r"<polyline", svg)) == 4  # pitch and roll, each in two pieces
