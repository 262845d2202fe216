"""IMU files in other units (g, deg/s) are read right; time stamps that cannot be seconds are refused.

Ground truth: the Mobilise-D files (Mobilise-D consortium, mobgap example data, Apache-2.0) store g and deg/s,
BROAD (Laidig et al. 2021, CC BY 4.0) m/s² and rad/s; each is written both ways and must read the same.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path

import numpy as np
import pytest

from walkmon.commands.cli import main
from walkmon.consts import GRAVITY_MS2
from walkmon.errors import InvalidInputError
from walkmon.imu.units import infer_units

SHARED_DATA = Path(os.environ.get("WALKMON_SHARED_DATA", Path(__file__).resolve().parents[3] / "shared" / "data"))
MOBGAP = SHARED_DATA / "mobgap" / "lab"


def _mobgap(pid: str, test: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, gyro deg/s, acc g)`` of a Mobilise-D lower-back recording, in the file's own units."""
    import scipy.io as sio

    m = sio.loadmat(MOBGAP / pid / "data.mat", squeeze_me=True, struct_as_record=False)
    su = getattr(m["data"].TimeMeasure1, test).Trial1.SU.LowerBack
    return np.arange(len(su.Acc)) / float(su.Fs.Acc), np.asarray(su.Gyr, float), np.asarray(su.Acc, float)


@pytest.mark.skipif(not MOBGAP.is_dir(), reason="shared real data not present")
@pytest.mark.parametrize(("pid", "test"), [("HA/002", "Test5"), ("HA/002", "Test11"), ("MS/001", "Test5")])
def test_real_walks_in_g_and_deg_s_are_recognised_and_si_left_alone(pid: str, test: str) -> None:
    t, gyr_deg, acc_g = _mobgap(pid, test)
    u = infer_units(t, gyr_deg, acc_g)
    assert u.acc_scale == GRAVITY_MS2 and u.gyro_scale == pytest.approx(np.pi / 180.0)
    assert len(u.notes) == 2 and "deg/s" in u.notes[1]
    si = infer_units(t, np.radians(gyr_deg), acc_g * GRAVITY_MS2)
    assert (si.acc_scale, si.gyro_scale, si.notes) == (1.0, 1.0, ())
    # mixed: m/s² with deg/s (a common logger default) is told apart too
    mixed = infer_units(t, gyr_deg, acc_g * GRAVITY_MS2)
    assert mixed.acc_scale == 1.0 and mixed.gyro_scale == pytest.approx(np.pi / 180.0)


def test_fast_hand_held_rotations_in_rad_s_stay_rad_s(broad_trial_7) -> None:  # noqa: ANN001
    """BROAD trial 7 reaches ~1400 deg/s: a rate threshold would call it deg/s; the gyroscope's path against the
    accelerometer's does not."""
    import h5py

    with h5py.File(broad_trial_7, "r") as f:
        g, a = np.asarray(f["imu_gyr"], float), np.asarray(f["imu_acc"], float)
    t = np.arange(len(g)) / 286.0
    assert infer_units(t, g, a).gyro_scale == 1.0
    assert infer_units(t, np.degrees(g), a).gyro_scale == pytest.approx(np.pi / 180.0)


@pytest.mark.parametrize("scale", [1e3, 1e9])
def test_time_in_milliseconds_or_nanoseconds_is_refused(scale: float) -> None:
    t = np.arange(200) / 100.0 * scale
    acc = np.tile([0.0, -GRAVITY_MS2, 0.0], (200, 1))
    with pytest.raises(InvalidInputError, match="t must be in seconds"):
        infer_units(t, None, acc)


@pytest.mark.skipif(not MOBGAP.is_dir(), reason="shared real data not present")
def test_analyze_gives_the_same_walk_from_a_file_in_g_and_deg_s(tmp_path: Path, caplog: pytest.LogCaptureFixture,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    """End to end: ``walkmon analyze --imu`` on MS/001 Test5 written in SI and in the file's own units (g,
    deg/s): the same bout and cadence (before, the g/deg-s file gave no bout at all, with exit code 0), and the
    conversion is said; a file with t in milliseconds is one line and exit code 2."""
    import json

    t, gyr_deg, acc_g = _mobgap("MS/001", "Test5")
    out = {}
    for name, tt, g, a in (("si", t, np.radians(gyr_deg), acc_g * GRAVITY_MS2), ("g_deg", t, gyr_deg, acc_g),
                           ("ms", t * 1e3, np.radians(gyr_deg), acc_g * GRAVITY_MS2)):
        path = tmp_path / f"{name}.csv"
        np.savetxt(path, np.column_stack([tt, g, a]), delimiter=",", header="t,gx,gy,gz,ax,ay,az", comments="",
                   fmt="%.6f")
        caplog.clear()
        capsys.readouterr()
        with caplog.at_level(logging.WARNING):
            rc = main(["analyze", "--imu", str(path), "--out", str(tmp_path / name)])
        err = capsys.readouterr().err
        if name == "ms":
            assert rc == 2 and "t must be in seconds" in err and len(err.strip().splitlines()) == 1, err
            continue
        assert rc == 0, err
        doc = json.loads((tmp_path / name / "indicators.json").read_text(encoding="utf-8"))
        imu_json = json.loads((tmp_path / name / "imu.json").read_text(encoding="utf-8"))
        out[name] = (doc["cadence_spm"], len(doc["bouts"]), caplog.text, imu_json.get("units", []))
    assert out["si"][1] == out["g_deg"][1] == 1
    assert out["g_deg"][0] == pytest.approx(out["si"][0], rel=1e-3)
    assert "in g" in out["g_deg"][2] and "deg/s" in out["g_deg"][2] and "converted" not in out["si"][2]
    # and the output says it: imu.json names the conversions (none for the SI file)
    assert len(out["g_deg"][3]) == 2 and "deg/s" in out["g_deg"][3][1] and out["si"][3] == []


def test_a_still_sensor_is_not_converted_whatever_its_bias() -> None:
    """A sensor lying still: gravity's direction moves only by the noise, so the gyroscope's bias (0.6 deg/s,
    ordinary for MEMS) alone would make the path ratio 10 and call rad/s deg/s. Too still to tell: nothing is
    converted (the accelerometer's units still are: its magnitude needs no motion)."""
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 60.0, 0.01)
    acc = np.tile([0.1, -9.8, 0.2], (t.size, 1)) + rng.normal(0.0, 0.02, (t.size, 3))
    gyr = np.array([0.01, -0.005, 0.008]) + rng.normal(0.0, 0.005, (t.size, 3))
    assert infer_units(t, gyr, acc).notes == ()
    u = infer_units(t, gyr, acc / GRAVITY_MS2)
    assert u.acc_scale == GRAVITY_MS2 and u.gyro_scale == 1.0


@pytest.mark.skipif(not MOBGAP.is_dir(), reason="shared real data not present")
def test_one_corrupted_or_repeated_row_does_not_decide_the_units() -> None:
    """Review: one rate of 9e9 (finite) made a whole SI file deg/s, and one repeated time stamp switched the
    deg/s check off. Neither decides now; nor does a 1e300 accelerometer row raise a numpy warning."""
    t, gyr_deg, acc_g = _mobgap("HA/002", "Test11")
    gyr, acc = np.radians(gyr_deg), acc_g * GRAVITY_MS2
    for bad in (9e9, 500.0):
        g = gyr.copy()
        g[5000:5010, 0] = bad
        assert infer_units(t, g, acc).notes == ()
    a = acc.copy()
    a[100] = 1e300
    with np.errstate(all="raise"):
        assert infer_units(t, gyr, a).notes == ()
    t2 = t.copy()
    t2[500] = t2[499]
    u = infer_units(t2, gyr_deg, acc_g)
    assert u.gyro_scale == pytest.approx(np.pi / 180.0) and u.acc_scale == GRAVITY_MS2


@pytest.mark.skipif(not MOBGAP.is_dir(), reason="shared real data not present")
def test_gravity_free_linear_acceleration_is_not_taken_for_g() -> None:
    """A phone's 'linear acceleration' (gravity taken out) has a median magnitude of 0.3-1.5 m/s² during a
    walk, inside the range of a recording in g; it keeps falling to near zero, which gravity never lets a worn
    sensor do, so it is not converted (the plausibility rules then refuse it as having no gravity)."""
    from scipy.signal import butter, sosfiltfilt

    t, _, acc_g = _mobgap("MS/001", "Test11")
    acc = acc_g * GRAVITY_MS2
    linear = acc - sosfiltfilt(butter(2, 0.3, fs=100.0, output="sos"), acc, axis=0)
    assert infer_units(t, None, linear).acc_scale == 1.0
    assert infer_units(t, None, acc_g).acc_scale == GRAVITY_MS2


@pytest.mark.skipif(not MOBGAP.is_dir(), reason="shared real data not present")
def test_accelerometer_only_file_in_g_reads_as_in_m_s2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``walkmon analyze --imu`` on ``t,ax,ay,az`` in g (a phone logger's usual unit): the same bout and
    cadence as in m/s², and imu.json says the accelerometer was converted."""
    import json

    t, _, acc_g = _mobgap("MS/001", "Test5")
    out = {}
    for name, a in (("si", acc_g * GRAVITY_MS2), ("g", acc_g)):
        path = tmp_path / f"{name}.csv"
        np.savetxt(path, np.column_stack([t, a]), delimiter=",", header="t,ax,ay,az", comments="", fmt="%.6f")
        assert main(["analyze", "--imu", str(path), "--out", str(tmp_path / name)]) == 0, capsys.readouterr().err
        doc = json.loads((tmp_path / name / "indicators.json").read_text(encoding="utf-8"))
        info = json.loads((tmp_path / name / "imu.json").read_text(encoding="utf-8"))
        out[name] = (doc["cadence_spm"], len(doc["bouts"]), info.get("units", []))
    assert out["g"][1] == out["si"][1] == 1 and out["g"][0] == pytest.approx(out["si"][0], rel=1e-3)
    assert out["si"][2] == [] and len(out["g"][2]) == 1 and "in g" in out["g"][2][0]
