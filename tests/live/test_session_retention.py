"""Session log retention: ``walkmon sessions delete|prune`` and ``[session] retention_days`` on real SQLite files."""

from __future__ import annotations

import datetime as dt
import sqlite3
from pathlib import Path

import pytest

from walkmon.commands.cli import main
from walkmon.errors import InvalidInputError
from walkmon.gait.live import CalibrationEvent
from walkmon.live.alerts import AlertEvent
from walkmon.live.config import ConfigError, config_from_dict
from walkmon.live.session_log import (
    DB_FILENAME,
    SessionLog,
    delete_sessions,
    list_sessions,
    prune_sessions,
)

TABLES = ("frames", "imu", "hops", "alerts", "calibrations")
NOW = dt.datetime(2026, 6, 1, 12, 0, tzinfo=dt.UTC)


def _session(data: Path, age_days: float, *, end: bool = True, n_frames: int = 2000, now: dt.datetime = NOW) -> int:
    """A session started ``age_days`` before ``now`` with rows in every table; left without an end time (running,
    or cut off) when ``end`` is False. Hops go in by a direct insert (add_hop needs a live indicator result)."""
    log = SessionLog(data, camera=f"sim:{age_days:g}", flush_interval_s=3600)
    for i in range(n_frames):
        log.add_frame(i / 30, (0.1 * i, -0.2, 0.3), 100, "rotation", "ok", 2.0)
        log.add_imu(i / 30, (0.01, 0.02, 0.03), (0.0, -9.81, 0.0))
    log.add_alert(AlertEvent(1.0, "lean_forward", "raised", 12.0, 10.0, "leaning"))
    log.add_calibration(CalibrationEvent(0.5, (0.0, 0.0, 0.0), "start", 2.0))
    log.flush()
    sid = log.session_id
    started = (now - dt.timedelta(days=age_days)).isoformat(timespec="milliseconds")
    with log._conn:  # noqa: SLF001 - back-date the start the constructor stamped
        log._conn.execute("UPDATE sessions SET started_utc=? WHERE id=?", (started, sid))  # noqa: SLF001
        log._conn.execute("INSERT INTO hops (session_id, t_s, walking, label) VALUES (?, 1.0, 1, 'normal')",  # noqa: SLF001
                          (sid,))
    if end:
        log.close("complete")
    else:  # what a writer still running (or killed) leaves: rows committed, no end time
        log._closed = True  # noqa: SLF001
        log._conn.close()  # noqa: SLF001
    return sid


def _row_counts(data: Path) -> dict[int, dict[str, int]]:
    """{session id: rows per table} for every id found in the sessions table or in any per-session table."""
    conn = sqlite3.connect(data / DB_FILENAME)
    try:
        ids = {r[0] for r in conn.execute("SELECT id FROM sessions")}
        for t in TABLES:
            ids |= {r[0] for r in conn.execute(f"SELECT DISTINCT session_id FROM {t}")}
        out = {}
        for i in sorted(ids):
            c = {t: conn.execute(f"SELECT COUNT(*) FROM {t} WHERE session_id=?", (i,)).fetchone()[0] for t in TABLES}
            c["sessions"] = conn.execute("SELECT COUNT(*) FROM sessions WHERE id=?", (i,)).fetchone()[0]
            out[i] = c
        return out
    finally:
        conn.close()


@pytest.fixture
def four_sessions(tmp_path: Path) -> tuple[Path, list[int]]:
    """Ended sessions 40, 20 and 5 days old, and one 50 days old that never ended (running or cut off)."""
    ids = [_session(tmp_path, 40), _session(tmp_path, 20), _session(tmp_path, 5), _session(tmp_path, 50, end=False)]
    return tmp_path, ids


def test_delete_removes_the_sessions_and_all_their_rows_and_shrinks_the_file(
        four_sessions: tuple[Path, list[int]], capsys: pytest.CaptureFixture[str]) -> None:
    data, (old, mid, new, running) = four_sessions
    before = _row_counts(data)
    assert set(before) == {old, mid, new, running}
    assert all(c == {"sessions": 1, "frames": 2000, "imu": 2000, "hops": 1, "alerts": 1, "calibrations": 1}
               for c in before.values())
    size_before = (data / DB_FILENAME).stat().st_size
    assert main(["sessions", "delete", str(old), str(running), "--force", "--data-dir", str(data)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("deleted 2 session(s):") and "sim:40" in out and "sim:50" in out
    after = _row_counts(data)
    assert set(after) == {mid, new}  # no orphan row left in any table
    assert after[mid] == before[mid] and after[new] == before[new]
    assert (data / DB_FILENAME).stat().st_size < 0.75 * size_before  # VACUUM gave the pages back
    assert not (data / f"{DB_FILENAME}-wal").exists() or (data / f"{DB_FILENAME}-wal").stat().st_size == 0


def test_delete_of_an_unknown_id_is_one_line_exit_2_and_deletes_nothing(
        four_sessions: tuple[Path, list[int]], capsys: pytest.CaptureFixture[str]) -> None:
    data, (old, *_rest) = four_sessions
    before = _row_counts(data)
    assert main(["sessions", "delete", str(old), "999", "--data-dir", str(data)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no session 999" in err and "nothing deleted" in err
    assert _row_counts(data) == before
    with pytest.raises(InvalidInputError, match="no session 7, 999"):
        delete_sessions(data, [999, 7])


def test_delete_refuses_a_session_without_an_end_time_unless_forced(
        four_sessions: tuple[Path, list[int]], capsys: pytest.CaptureFixture[str]) -> None:
    data, (old, mid, new, running) = four_sessions
    before = _row_counts(data)
    # refused together with an ended one: one line, exit 2, and not even the ended session is deleted
    assert main(["sessions", "delete", str(old), str(running), "--data-dir", str(data)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1
    assert f"session {running} has no end time and may still be running" in captured.err
    assert "nothing deleted" in captured.err and "--force" in captured.err
    assert _row_counts(data) == before
    with pytest.raises(InvalidInputError, match=f"session {running} has no end time"):
        delete_sessions(data, [running])
    assert _row_counts(data) == before
    # an unknown id is still reported as unknown, before the running check
    with pytest.raises(InvalidInputError, match="no session 999"):
        delete_sessions(data, [running, 999], force=True)
    assert delete_sessions(data, [running], force=True) == [running]
    assert set(_row_counts(data)) == {old, mid, new}
    assert main(["sessions", "delete", str(old), "--data-dir", str(data)]) == 0  # ended: no --force needed
    assert set(_row_counts(data)) == {mid, new}


def test_prune_deletes_ended_sessions_older_than_days_and_never_a_running_one(
        four_sessions: tuple[Path, list[int]]) -> None:
    data, (old, mid, new, running) = four_sessions
    before = _row_counts(data)
    assert prune_sessions(data, 10, dry_run=True, now_utc=NOW) == [old, mid]
    assert _row_counts(data) == before  # dry run: nothing deleted
    size_before = (data / DB_FILENAME).stat().st_size
    assert prune_sessions(data, 10, now_utc=NOW) == [old, mid]
    after = _row_counts(data)
    assert set(after) == {new, running}  # the 50-day-old session without an end time survives
    assert after[running] == before[running]
    assert (data / DB_FILENAME).stat().st_size < 0.75 * size_before
    assert prune_sessions(data, 0, now_utc=NOW) == [new]  # 0 days: every ended session
    assert [s.id for s in list_sessions(data)] == [running]


def test_prune_keep_always_keeps_the_newest_ended_sessions(four_sessions: tuple[Path, list[int]]) -> None:
    data, (old, mid, new, running) = four_sessions
    assert prune_sessions(data, 1, keep=2, dry_run=True, now_utc=NOW) == [old]
    assert prune_sessions(data, 1, keep=5, dry_run=True, now_utc=NOW) == []  # more kept than there are
    assert prune_sessions(data, 30, keep=0, now_utc=NOW) == [old]
    assert [s.id for s in list_sessions(data)] == [mid, new, running]
    with pytest.raises(InvalidInputError, match="keep must be >= 0"):
        prune_sessions(data, 1, keep=-1)
    with pytest.raises(InvalidInputError, match="DAYS must be a number >= 0"):
        prune_sessions(data, -1)


def test_prune_command_prints_what_it_deletes_or_would(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    now = dt.datetime.now(dt.UTC)
    old, mid, new = (_session(tmp_path, d, n_frames=10, now=now) for d in (40, 20, 5))
    running = _session(tmp_path, 50, end=False, n_frames=10, now=now)
    assert main(["sessions", "prune", "--older-than", "30", "--dry-run", "--data-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("would delete 1 session(s):") and f"\n  {old:>4}  live" in out and "sim:40" in out
    assert len(list_sessions(tmp_path)) == 4
    assert main(["sessions", "prune", "--older-than", "1", "--keep", "1", "--data-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("deleted 2 session(s):") and "sim:40" in out and "sim:20" in out and "sim:5" not in out
    assert [s.id for s in list_sessions(tmp_path)] == [new, running]
    assert mid not in [s.id for s in list_sessions(tmp_path)]
    assert main(["sessions", "prune", "--older-than", "0", "--keep", "1", "--data-dir", str(tmp_path)]) == 0
    assert capsys.readouterr().out == "deleted no session (no ended session started more than 0 days ago beyond the newest 1)\n"
    assert main(["sessions", "prune", "--older-than", "-3", "--data-dir", str(tmp_path)]) == 2
    assert "DAYS must be a number >= 0" in capsys.readouterr().err


def test_retention_days_config_is_validated() -> None:
    assert config_from_dict({}).session.retention_days == 0.0  # default: keep everything
    assert config_from_dict({"session": {"retention_days": 30}}).session.retention_days == 30.0
    with pytest.raises(ConfigError, match="retention_days must be >= 0"):
        config_from_dict({"session": {"retention_days": -1}})


def test_live_prunes_old_ended_sessions_when_it_starts(tmp_path: Path, caplog: pytest.LogCaptureFixture,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    data, now = tmp_path / "db", dt.datetime.now(dt.UTC)
    old = _session(data, 40, n_frames=10, now=now)
    recent = _session(data, 10, n_frames=10, now=now)
    running = _session(data, 60, end=False, n_frames=10, now=now)
    cfg = tmp_path / "walkmon.toml"
    cfg.write_text("[session]\nretention_days = 30\n", encoding="utf-8")
    caplog.set_level("INFO", logger="walkmon.commands.live")
    assert main(["live", "--camera", "sim:normal:1?width=160&height=120&realtime=0&seed=2", "--config", str(cfg),
                 "--data-dir", str(data), "--status", "none"]) == 0
    capsys.readouterr()
    sessions = list_sessions(data)
    assert [s.id for s in sessions][:2] == [recent, running] and len(sessions) == 3
    assert sessions[2].n_frames == 150 and sessions[2].ended_utc  # the new live session ran and ended normally
    assert f"session retention: deleted 1 ended session(s) older than 30 days ({old})" in caplog.text
