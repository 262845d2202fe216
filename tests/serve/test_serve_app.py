"""The dashboard's app and store without a browser: values against hand counts of the hops written, the token
and Host checks, read-only access, older databases, and ``walkmon history``."""

from __future__ import annotations

import csv
import hashlib
import os
import sqlite3
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from walkmon.live.alerts import AlertEvent

pytest.importorskip("starlette")
pytest.importorskip("httpx")
from starlette.testclient import TestClient  # noqa: E402

from walkmon.serve.app import create_app  # noqa: E402
from walkmon.serve.store import Store  # noqa: E402

TOKEN = "s3cret-token-for-tests"


def _raised(t: float, kind: str = "lean_forward") -> AlertEvent:
    return AlertEvent(t, kind, "raised", 15.0, 10.0, f"{kind} raised")


def _cleared(t: float, kind: str = "lean_forward") -> AlertEvent:
    return AlertEvent(t, kind, "cleared", 5.0, 7.0, f"{kind} cleared")


@pytest.fixture
def db(tmp_path: Path, write_session: Any, make_hop: Any) -> Path:
    """Session 1 (Ann): 60 hops, walking 5..54, bent (-15 deg) 30..54; session 2 (Bob): 20 walking hops, upright."""
    data = tmp_path / "data"
    hops = []
    for t in range(1, 61):
        walking = 5 <= t <= 54
        bent = t >= 30
        hops.append(make_hop(float(t), walking=walking, pitch=-15.0 if bent else -2.0, roll=1.0,
                             cadence=110.0 if bent else 100.0, label="bend" if bent else "normal", asym=0.2))
    alerts = (_raised(35.0), _cleared(45.0), _raised(50.0), _raised(52.0, "shoulder_down"))
    write_session(data, hops, alerts, person="Ann")
    write_session(data, [make_hop(float(t), pitch=0.0, roll=-7.0 if t <= 5 else 0.0) for t in range(1, 21)],
                  person="Bob")
    return data


def client(data: Path, **kw: Any) -> TestClient:
    return TestClient(create_app(data, **kw), base_url="http://127.0.0.1")


def test_session_values_are_the_hand_counts_of_its_hops(db: Path) -> None:
    c = client(db)
    doc = c.get("/api/sessions/1").json()
    assert doc["person"] == "Ann" and doc["kind"] == "live"
    assert doc["recorded_min"] == pytest.approx(60 / 60)
    assert doc["walking_min"] == pytest.approx(50 / 60, abs=0.005)
    assert doc["upright_pct"] == pytest.approx(100 * 25 / 50)  # 5..29 upright, 30..54 bent beyond 10 deg
    assert doc["cadence_spm"] == pytest.approx((25 * 100 + 25 * 110) / 50)
    assert doc["pitch_deg"] == pytest.approx((25 * -2 + 25 * -15) / 50)
    assert doc["alerts"] == {"lean_forward": 2, "shoulder_down": 1}  # raised only
    # Bob: roll 7 deg beyond the 5 deg shoulder threshold in his first 5 of 20 walking hops
    assert c.get("/api/sessions/2").json()["upright_pct"] == pytest.approx(75.0)
    tl = c.get("/api/sessions/1/timeline").json()
    assert tl["hops"]["t_s"] == [float(t) for t in range(1, 61)]
    assert tl["hops"]["activity"][:5] == ["not walking"] * 4 + ["walking"]
    assert [a["state"] for a in tl["alerts"]] == ["raised", "cleared", "raised", "raised"]
    assert tl["thresholds"]["lean_forward_deg"] == 10.0
    listed = c.get("/api/sessions").json()
    assert [s["id"] for s in listed] == [2, 1]  # newest first
    assert [s["id"] for s in c.get("/api/sessions?person=Bob").json()] == [2]
    page = c.get("/sessions/1").text
    assert "50 min" not in page
    assert ("50 s walked, 50 % upright (within the alert thresholds), 2 lean-forward alerts and 1 shoulder-down "
            "alert") in page
    assert "Compared with" not in page  # Ann has no earlier session


def test_a_session_of_no_one_is_compared_only_with_others_of_no_one(tmp_path: Path, write_session: Any,
                                                                      make_hop: Any) -> None:
    """User review: a session without a person read 'Compared with the 1 earlier session ... cadence 115', which was
    alice's; and 0.3 min of walking read '(0 min walking)'."""
    data = tmp_path / "data"
    walk = [make_hop(float(t), walking=True, pitch=0.0, roll=0.0, cadence=115.0) for t in range(1, 19)]
    write_session(data, walk, person="alice", started_utc="2026-11-20T10:00:00+00:00")
    write_session(data, [make_hop(float(t), walking=True, pitch=0.0, roll=0.0, cadence=100.0) for t in range(1, 21)],
                  started_utc="2026-11-21T10:00:00+00:00")
    assert "Compared with" not in client(data).get("/sessions/2").text  # alice's is no one's baseline
    write_session(data, [make_hop(float(t), walking=True, pitch=0.0, roll=0.0, cadence=104.0) for t in range(1, 21)],
                  person="alice", started_utc="2026-11-22T10:00:00+00:00")
    page = client(data).get("/sessions/3").text
    assert "alice&#39;s 1 earlier session of the 30 days before (0.3 min walking)" in page
    assert "cadence 115 steps/min (now 104)" in page


def test_history_per_local_day(tmp_path: Path, write_session: Any, make_hop: Any,
                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TZ", "Pacific/Auckland")  # UTC+13 in January
    time.tzset()
    try:
        data = tmp_path / "d"
        walk = [make_hop(float(t)) for t in range(1, 121)]  # 2 min walking, upright
        write_session(data, walk, (_raised(10.0),), started_utc="2026-01-10T10:30:00.000+00:00")  # 23:30 on the 10th
        write_session(data, walk[:60], (), started_utc="2026-01-10T11:30:00.000+00:00")  # 00:30 on the 11th
        write_session(data, walk[:60], (), started_utc="2025-11-01T11:30:00.000+00:00")  # long before
        import datetime as dt

        from walkmon.views.history import daily

        now = dt.datetime(2026, 1, 20, tzinfo=dt.UTC)
        stats = Store(data).session_stats(since=dt.timedelta(days=30), now_utc=now)
        days = daily(stats)
        assert [d.day.isoformat() for d in days] == ["2026-01-10", "2026-01-11"]
        assert [d.walking_min for d in days] == [pytest.approx(2.0), pytest.approx(1.0)]
        assert days[0].alerts_per_hour == {"lean_forward": pytest.approx(1 / (120 / 3600))}
        assert stats[0].started_local.utcoffset() == dt.timedelta(hours=13)
    finally:
        monkeypatch.delenv("TZ")
        time.tzset()


def test_history_command_writes_csv_and_html(db: Path, tmp_path: Path, python_cmd: list[str]) -> None:
    out = tmp_path / "hist"
    r = subprocess.run([*python_cmd, "history", "--data-dir", str(db), "--person", "Ann", "--out", str(out)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    rows = list(csv.DictReader((out / "history.csv").open()))
    assert len(rows) == 1 and rows[0]["sessions"] == "1"
    assert float(rows[0]["walking_min"]) == pytest.approx(50 / 60, abs=0.01)
    assert float(rows[0]["upright_pct"]) == pytest.approx(50.0)
    assert float(rows[0]["alerts_per_hour_lean_forward"]) == pytest.approx(2 / (60 / 3600))
    html = (out / "history.html").read_text()
    assert "<svg" in html and "History of Ann" in html and "<script" not in html
    bad = subprocess.run([*python_cmd, "history", "--data-dir", str(db), "--since", "soon", "--out", str(out)],
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "Traceback" not in bad.stderr


def test_live_endpoint_follows_the_unended_session(db: Path, write_session: Any, make_hop: Any) -> None:
    c = client(db)
    assert c.get("/api/live").json() == {"running": False, "last_session": 2}
    hops = [make_hop(float(t), pitch=-12.0 if t > 5 else 0.0) for t in range(1, 9)]
    sid = write_session(db, hops, (_raised(6.0), _raised(7.0, "shoulder_down"), _cleared(8.0, "shoulder_down")),
                        person="Cy", end=False)
    live = c.get("/api/live").json()
    assert live["running"] and live["session_id"] == sid and live["person"] == "Cy"
    assert live["hop"]["t_s"] == 8.0 and live["hop"]["pitch"] == -12.0 and live["hop"]["label"] == "normal"
    assert [a["kind"] for a in live["active_alerts"]] == ["lean_forward"]
    assert live["recent"]["t_s"] == [float(t) for t in range(1, 9)]
    assert not live["stale"]
    # the monitor was killed a minute ago: a dashboard started now says stale at once (user review: 'running, not
    # stale' for its first 5 s, the hops having changed at its first look)
    gone = time.time() - 60.0
    for f in db.glob("walkmon.sqlite*"):
        os.utime(f, (gone, gone))
    assert client(db).get("/api/live").json()["stale"]
    # a newer live session ran and ended since: the older one, left without an end, is not running (it was)
    write_session(db, hops, (), end=True)
    assert client(db).get("/api/live").json()["running"] is False


def test_token_required_and_host_checked(db: Path) -> None:
    open_c = client(db)
    assert open_c.get("/api/sessions").status_code == 200
    evil = TestClient(create_app(db), base_url="http://attacker.example")
    assert evil.get("/api/sessions").status_code == 400  # DNS rebinding to a loopback server
    # bound to another loopback address: the URL it prints is served (user review: 400 on every request)
    other = TestClient(create_app(db, bound_host="127.0.0.2"), base_url="http://127.0.0.2:8765")
    assert other.get("/api/sessions").status_code == 200
    assert TestClient(create_app(db, bound_host="127.0.0.2"), base_url="http://127.0.0.3:8765").get(
        "/api/sessions").status_code == 400  # not any loopback address: the one bound to
    c = TestClient(create_app(db, token=TOKEN, bound_host="0.0.0.0"), base_url="http://192.168.1.20:8765")
    for path in ("/", "/api/live", "/api/sessions/1", "/history", "/static/live.js"):
        assert c.get(path).status_code == 401, path
    assert c.get("/api/live", headers={"Authorization": "Bearer wrong-token-value"}).status_code == 401
    assert c.get("/api/live", headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200
    first = c.get(f"/sessions?token={TOKEN}")
    assert first.status_code == 200 and "HttpOnly" in first.headers["set-cookie"]
    assert c.get("/api/sessions").status_code == 200  # the cookie from then on
    r = open_c.get("/")
    assert "default-src 'self'" in r.headers["content-security-policy"]


def test_non_loopback_without_token_is_refused(python_cmd: list[str], tmp_path: Path) -> None:
    from walkmon.errors import ConfigError
    from walkmon.serve.server import make_server

    with pytest.raises(ConfigError, match="needs a token"):
        make_server(tmp_path, "0.0.0.0", 8765, "")
    r = subprocess.run([*python_cmd, "serve", "--data-dir", str(tmp_path), "--host", "0.0.0.0"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "needs a token" in r.stderr and r.stderr.count("\n") == 1


def test_the_store_is_read_only_and_reads_older_databases(db: Path, tmp_path: Path) -> None:
    path = db / "walkmon.sqlite"
    before = hashlib.sha256(path.read_bytes()).hexdigest()
    c = client(db)
    for url in ("/", "/sessions", "/sessions/1", "/history", "/history.csv", "/api/live", "/api/history",
                "/api/sessions", "/api/sessions/1", "/api/sessions/1/timeline"):
        assert c.get(url).status_code == 200, url
    assert hashlib.sha256(path.read_bytes()).hexdigest() == before
    with Store(db).connect() as conn, pytest.raises(sqlite3.OperationalError, match="readonly"):
        conn.execute("DELETE FROM hops")
    # a schema-2 database (before sessions.person) is read as it is, never migrated by the dashboard
    old = tmp_path / "old"
    old.mkdir()
    conn = sqlite3.connect(old / "walkmon.sqlite")
    conn.executescript("""
        CREATE TABLE sessions (id INTEGER PRIMARY KEY AUTOINCREMENT, kind TEXT NOT NULL, started_utc TEXT NOT NULL,
            ended_utc TEXT, end_reason TEXT, camera TEXT, imu TEXT, config_json TEXT, versions_json TEXT,
            meta_json TEXT, n_frames INTEGER DEFAULT 0, n_dropped INTEGER DEFAULT 0);
        CREATE TABLE frames (session_id INTEGER NOT NULL, t_s REAL NOT NULL, pitch REAL, yaw REAL, roll REAL,
            n_inliers INTEGER, model TEXT, status TEXT, latency_ms REAL, pitch_abs REAL, roll_abs REAL, fused INTEGER);
        CREATE TABLE hops (session_id INTEGER NOT NULL, t_s REAL NOT NULL, walking INTEGER, cadence_spm REAL,
            pitch_swing REAL, yaw_swing REAL, roll_swing REAL, pitch_inclination REAL, yaw_inclination REAL,
            roll_inclination REAL, pitch_posture REAL, yaw_posture REAL, roll_posture REAL, step_asymmetry REAL,
            label TEXT, json TEXT);
        CREATE TABLE alerts (session_id INTEGER NOT NULL, t_s REAL NOT NULL, kind TEXT, state TEXT, value REAL,
            threshold REAL, message TEXT);
        INSERT INTO sessions (kind, started_utc, ended_utc) VALUES ('live', '2026-01-01T10:00:00+00:00', '2026-01-01T10:01:00+00:00');
        INSERT INTO hops VALUES (1, 1.0, 1, 100, 0, 0, 0, 0, 0, 0, -3, 0, 1, 0.1, 'normal', '{}');
        PRAGMA user_version=2;
    """)
    conn.commit()
    conn.close()
    oc = client(old)
    (s,) = oc.get("/api/sessions").json()
    assert s["person"] is None and s["walking_min"] == pytest.approx(1 / 60, abs=0.005)
    assert oc.get("/api/history?person=Ann&since=3650d").json()["days"] == []
    assert "person" not in {r[1] for r in sqlite3.connect(old / "walkmon.sqlite").execute("PRAGMA table_info(sessions)")}


def test_missing_database_and_bad_requests_are_clear(tmp_path: Path, db: Path) -> None:
    c = client(tmp_path / "nothing")
    r = c.get("/api/sessions")
    assert r.status_code == 503 and "no session database" in r.json()["error"]
    c = client(db)
    assert c.get("/api/sessions/99").status_code == 404
    assert c.get("/sessions/99").status_code == 404
    assert c.get("/api/history?since=yesterday").status_code == 400
    # beyond the calendar and beyond SQLite's integers (user review: both were a 500 with a traceback)
    for since in ("1000000d", "99999999999d", "1e9"):
        r = c.get(f"/api/history?since={since}")
        assert r.status_code == 200 and len(r.json()["days"]) >= 1, since
        assert c.get(f"/history.csv?since={since}").status_code == 200
    assert c.get("/api/sessions/99999999999999999999").status_code == 404
    assert c.get("/sessions/99999999999999999999/report").status_code == 404


def test_a_taken_port_is_one_line(python_cmd: list[str], db: Path) -> None:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        r = subprocess.run([*python_cmd, "serve", "--data-dir", str(db), "--port", str(port)],
                           capture_output=True, text=True, timeout=60, check=False)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "cannot listen on 127.0.0.1" in r.stderr


def test_the_live_monitors_dashboard_on_a_taken_port_is_one_line(python_cmd: list[str], tmp_path: Path) -> None:
    """'walkmon live' with [serve] enabled on a port another program holds: the monitor goes on without a
    dashboard, saying so in one line (user review: uvicorn's error line, then ~30 lines of traceback)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        cfg = tmp_path / "c.toml"
        cfg.write_text(f"[serve]\nenabled = true\nport = {port}\n")
        r = subprocess.run([*python_cmd, "live", "--camera", "sim:normal:2?realtime=0&width=64&height=48", "--config",
                            str(cfg), "--data-dir", str(tmp_path / "d"), "--status", "none"],
                           capture_output=True, text=True, timeout=120, check=False)
    assert r.returncode == 0, r.stderr
    assert "Traceback" not in r.stderr
    (line,) = [x for x in r.stderr.splitlines() if "dashboard" in x]
    assert f"dashboard not started: cannot listen on 127.0.0.1:{port}" in line


def test_an_ipv6_dashboard_address_is_bracketed() -> None:
    """User review: 'serve --host ::1' printed http://::1:8765/, which no browser opens."""
    from walkmon.serve.server import url

    assert url("::1", 8765) == "http://[::1]:8765/"
    assert url("127.0.0.1", 8765) == "http://127.0.0.1:8765/"


def test_a_covered_lens_is_drawn_as_unknown_not_as_standing(tmp_path: Path, write_session: Any, make_hop: Any) -> None:
    """Hops in which the camera measured nothing (unknown, with that reason) keep 'unknown' in the timeline, which
    the band draws in its own grey; other unknown hops (the first seconds, older logs) stay 'not walking'."""
    import dataclasses

    from walkmon.views.svg import ACTIVITY_COLORS

    blind = ("nothing measured for 2.0 s: the camera's view held (covered, dark or featureless)",)
    hops = [make_hop(1.0, walking=False),
            dataclasses.replace(make_hop(2.0, walking=False), activity="unknown", reasons=blind),
            dataclasses.replace(make_hop(3.0, walking=False), activity="unknown",
                                reasons=("measuring again after nothing measured for 3.0 s",)),
            dataclasses.replace(make_hop(4.0, walking=False), activity="standing"),
            make_hop(5.0)]
    sid = write_session(tmp_path, hops)
    tl = client(tmp_path).get(f"/api/sessions/{sid}/timeline").json()
    assert tl["hops"]["activity"] == ["not walking", "unknown", "unknown", "standing", "walking"]
    assert ACTIVITY_COLORS["unknown"] != ACTIVITY_COLORS["standing"]
