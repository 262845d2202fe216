"""The summary and bout tables of ``walkmon batch`` from hand-written indicators.json documents."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from walkmon.batching.tables import (
    BOUT_COLUMNS,
    SUMMARY_COLUMNS,
    bouts_frame,
    bouts_from_indicators,
    indicator_columns,
    read_manifest,
    summary_frame,
    write_manifest,
    write_tables,
)

pd = pytest.importorskip("pandas")
pytest.importorskip("pyarrow")


def _doc(**extra: object) -> dict:
    axis = {"lmax_mean": 1.0, "lmin_mean": -1.0, "swing_mean": 2.0, "inclination_mean": 0.5, "n_cycles": 7,
            "swing_std": 0.1, "inclination_std": None, "frequency_hz": 0.9}
    return {"schema_version": 1, "cadence_spm": 108.0, "duration_s": 30.0, "walking_s": 20.0,
            "axes": {"pitch": axis, "yaw": {**axis, "swing_mean": 3.0}, "roll": axis},
            "asymmetry": {"n_steps": 30.0, "step_swing_ratio": 1.1},
            "classification": {"label": "bend", "reasons": ["pitch low", "extremums low"]},
            "status": "ok", "mode": "walkmon", **extra}


def test_columns_from_one_document_and_time_per_posture_without_bouts() -> None:
    row = indicator_columns(_doc())
    assert row["cadence_spm"] == 108.0
    assert row["label"] == "bend"
    assert row["reasons"] == "pitch low; extremums low"
    assert row["yaw_swing_mean"] == 3.0
    assert row["pitch_n_cycles"] == 7
    assert math.isnan(row["pitch_inclination_std"])  # null -> NaN
    assert math.isnan(row["asym_step_time_ratio"])  # absent -> NaN
    # no bouts: the whole walking time under the one label
    assert row["time_bend_s"] == 20.0
    assert row["time_normal_s"] == 0.0
    assert row["n_bouts"] == 0


def test_labelled_bouts_give_time_per_posture_and_bout_rows() -> None:
    bouts = [
        {"start_s": 2.0, "end_s": 12.0, "n_steps": 18, "cadence_spm": 108.0, "label": "normal",
         "steps_s": [2.0, 2.5], "axes": {"pitch": {"swing_mean": 2.5}}},
        {"start_s": 15.0, "end_s": 19.5, "n_steps": 8, "cadence_spm": 100.0,
         "classification": {"label": "bend", "reasons": []}},
        {"start_s": 21.0, "end_s": 25.0, "n_steps": 7, "cadence_spm": 99.0, "label": "normal"},
    ]
    doc = _doc(bouts=bouts)
    row = indicator_columns(doc)
    assert row["time_normal_s"] == pytest.approx(10.0 + 4.0)
    assert row["time_bend_s"] == pytest.approx(4.5)
    assert row["n_bouts"] == 3
    rows = bouts_from_indicators("rec", doc)
    assert [r["bout"] for r in rows] == [0, 1, 2]
    assert [r["label"] for r in rows] == ["normal", "bend", "normal"]
    assert rows[0]["duration_s"] == pytest.approx(10.0)
    assert rows[0]["axes_pitch_swing_mean"] == 2.5  # nested fields flattened
    assert "steps_s" not in rows[0]  # lists stay in indicators.json
    df = bouts_frame(rows)
    assert list(df.columns)[: len(BOUT_COLUMNS)] == list(BOUT_COLUMNS)
    assert math.isnan(df.loc[1, "axes_pitch_swing_mean"])


def test_schema_2_session_fields() -> None:
    """indicators.json schema 2 (bouts, summary.posture_time_s per posture segment, activity_s): the segment
    times win over the bouts' majority labels."""
    bouts = [{"start_s": 2.0, "end_s": 32.0, "activity": "walking", "n_steps": 50, "cadence_spm": 100.0,
              "spectral_cadence_spm": 101.0, "n_turns": 1,
              "axes": {"pitch": {"swing_mean": 2.0}, "yaw": None, "roll": {"swing_mean": 1.0}},
              "label": "normal", "reasons": ["normal over 20.0 s of 30.0 s", "bend over 10.0 s of 30.0 s"]}]
    doc = _doc(bouts=bouts, activity_s={"standing": 4.0, "walking": 30.0, "turning": 2.5, "unknown": 0.0},
               summary={"n_steps": 50, "n_turns": 1, "posture_time_s": {"bend": 10.0, "normal": 20.0}})
    row = indicator_columns(doc)
    assert row["time_normal_s"] == 20.0
    assert row["time_bend_s"] == 10.0  # not 0: the bout's majority label would hide the bent part
    assert row["activity_turning_s"] == 2.5
    assert row["n_steps"] == 50 and row["n_turns"] == 1 and row["n_bouts"] == 1
    (b,) = bouts_from_indicators("rec", doc)
    assert b["reasons"] == "normal over 20.0 s of 30.0 s; bend over 10.0 s of 30.0 s"
    assert b["axes_roll_swing_mean"] == 1.0
    assert "axes_yaw" not in b  # a null axis leaves its columns empty
    assert b["spectral_cadence_spm"] == 101.0
    # before schema 2 the session columns are empty, not zero
    old = indicator_columns(_doc())
    assert math.isnan(old["activity_walking_s"]) and math.isnan(old["n_steps"])


def test_empty_tables_have_the_documented_columns(tmp_path: Path) -> None:
    summary = summary_frame([])
    bouts = bouts_frame([])
    assert list(summary.columns) == list(SUMMARY_COLUMNS)
    assert list(bouts.columns) == list(BOUT_COLUMNS)
    paths = write_tables(tmp_path, summary, bouts)
    assert list(pd.read_parquet(paths[2]).columns) == list(BOUT_COLUMNS)
    assert list(pd.read_parquet(paths[0]).columns) == list(SUMMARY_COLUMNS)


def test_summary_frame_types_and_order() -> None:
    ok = {"name": "b", "status": "ok", "attempts": 1, "resumed": True, **indicator_columns(_doc())}
    failed = {"name": "a", "status": "failed", "error": "a.mp4: cannot open", "attempts": 2}
    df = summary_frame([ok, failed])
    assert list(df["name"]) == ["a", "b"]
    assert df.loc[0, "error"] == "a.mp4: cannot open"
    assert math.isnan(df.loc[0, "cadence_spm"])
    assert df.loc[1, "cadence_spm"] == 108.0
    assert df["attempts"].tolist() == [2, 1]
    assert df["resumed"].tolist() == [False, True]
    assert df["indicators_schema"].tolist() == ["", "1"]  # the document's schema_version (review: NaN on every row)


def test_manifest_round_trip_private_and_damaged(tmp_path: Path) -> None:
    entries = {"x": {"inputs": {"video": {"path": "/v.mp4", "size": 3, "sha256": "ab"}}, "row": {"status": "ok"}}}
    write_manifest(tmp_path, entries)
    assert read_manifest(tmp_path) == entries
    assert (tmp_path / "manifest.json").stat().st_mode & 0o077 == 0
    (tmp_path / "manifest.json").write_text("{not json", encoding="utf-8")
    assert read_manifest(tmp_path) == {}  # a damaged manifest: everything is analysed again
