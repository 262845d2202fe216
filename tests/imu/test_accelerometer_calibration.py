"""Accelerometer calibration (``walkmon calibrate-imu``) against the simulator's true accelerometer errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from walkmon.commands.cli import main
from walkmon.consts import gravity_angles_deg_from_gravity
from walkmon.errors import InvalidInputError
from walkmon.imu.calibration import AccelerometerCalibration, calibrate_accelerometer
from walkmon.imu.fusion import FusionSettings, fuse_recording
from walkmon.simulate.gait import GaitModel
from walkmon.simulate.imu import ImuSettings, simulate_imu, simulate_static_poses
from walkmon.tables import write_table

#: six poses (each axis up and down) and four tilted ones (for the cross-axis terms)
POSES = np.array([r.as_matrix() for r in (
    *(Rotation.from_euler("x", a, degrees=True) for a in (0, 90, 180, 270)),
    *(Rotation.from_euler("z", a, degrees=True) for a in (90, 270)),
    Rotation.from_euler("xz", (45, 45), degrees=True), Rotation.from_euler("xz", (-45, 135), degrees=True),
    Rotation.from_euler("zx", (45, -60), degrees=True), Rotation.from_euler("yx", (30, 120), degrees=True),
)])
#: a raw part: datasheet-size offsets (~20 mg) and 1 % scale / cross-axis errors
RAW = ImuSettings(accelerometer_bias_mps2=0.2, accelerometer_scale_std=0.01, accelerometer_misalignment_std_rad=0.01)


def _csv(path: Path, imu) -> Path:  # noqa: ANN001
    write_table(path, imu.columns(), default_precision=7)
    return path


@pytest.mark.parametrize("seed", [1, 2])
def test_ten_poses_recover_bias_scale_and_cross_axis_terms(seed: int) -> None:
    imu = simulate_static_poses(POSES, RAW, seed=seed)
    cal = calibrate_accelerometer(imu.t_s, imu.gyroscope_rps, imu.accelerometer_mps2)
    assert cal.n_poses == 10 and cal.misalignment
    np.testing.assert_allclose(cal.bias_m_s2, imu.accelerometer_bias_mps2, atol=0.005)
    M, Mt = cal.matrix_3x3, imu.accelerometer_matrix
    # a rotation of the whole frame is not observable from gravity: M M^T is (scale and cross-axis terms)
    np.testing.assert_allclose(M @ M.T, Mt @ Mt.T, atol=1e-3)
    np.testing.assert_allclose(M, M.T, atol=1e-12)  # the fit adds no rotation of its own
    # every pose's corrected reading has gravity's magnitude (the raw ones are off by ~0.1-0.3 m/s2)
    corrected = np.linalg.norm(cal.correct(imu.accelerometer_mps2[:100]), axis=1)
    assert np.abs(corrected.mean() - 9.81) < 0.005
    assert np.abs(np.linalg.norm(imu.accelerometer_mps2[:100], axis=1).mean() - 9.81) > 0.02


def test_six_poses_give_bias_and_scale() -> None:
    imu = simulate_static_poses(POSES[:6], RAW, seed=3, accelerometer_matrix=np.diag([1.01, 0.99, 1.005]))
    cal = calibrate_accelerometer(imu.t_s, imu.gyroscope_rps, imu.accelerometer_mps2)
    assert cal.n_poses == 6 and not cal.misalignment
    np.testing.assert_allclose(cal.bias_m_s2, imu.accelerometer_bias_mps2, atol=0.005)
    np.testing.assert_allclose(np.diag(cal.matrix_3x3), [1.01, 0.99, 1.005], atol=5e-4)


def test_too_few_or_one_sided_poses_are_refused() -> None:
    imu = simulate_static_poses(POSES[:4], RAW, seed=1)  # x never points up or down
    with pytest.raises(InvalidInputError, match="at least 6"):
        calibrate_accelerometer(imu.t_s, imu.gyroscope_rps, imu.accelerometer_mps2)
    with pytest.raises(InvalidInputError, match="needs at least 9"):
        calibrate_accelerometer(imu.t_s, imu.gyroscope_rps, imu.accelerometer_mps2, misalignment=True)


def test_cli_writes_the_file_and_analyze_uses_it(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """calibrate-imu on the still poses of a walk's sensor, then analyze --imu --imu-calib on the walk: the
    gravity-referenced angles lose the accelerometer's error."""
    model = GaitModel("normal", seconds=8.0, seed=5)
    # offsets and scale errors (no cross-axis terms, whose frame-rotation part no gravity calibration can see)
    walk = simulate_imu(model, ImuSettings(accelerometer_bias_mps2=0.2, accelerometer_scale_std=0.01,
                                           accelerometer_misalignment_std_rad=0.0))
    poses = simulate_static_poses(POSES, RAW, seed=5, accelerometer_matrix=walk.accelerometer_matrix,
                                  accelerometer_bias_mps2=walk.accelerometer_bias_mps2)
    out = tmp_path / "accel.json"
    assert main(["calibrate-imu", str(_csv(tmp_path / "poses.csv", poses)), "--out", str(out)]) == 0
    assert "10 still poses" in capsys.readouterr().out
    cal = AccelerometerCalibration.from_dict(json.loads(out.read_text()))
    np.testing.assert_allclose(cal.bias_m_s2, walk.accelerometer_bias_mps2, atol=0.005)
    walk_csv = _csv(tmp_path / "walk.csv", walk)
    for name, extra in (("raw", []), ("calibrated", ["--imu-calib", str(out)])):
        assert main(["analyze", "--imu", str(walk_csv), "--imu-filter", "eskf", "--out", str(tmp_path / name), *extra]) == 0
    from walkmon.tables import read_table

    t = np.arange(len(walk.t_s))[::2] / 200.0
    R = model.rotation(t)
    truth = gravity_angles_deg_from_gravity(np.einsum("nji,j->ni", R, [0.0, 1.0, 0.0]))
    err = {}
    for name in ("raw", "calibrated"):
        cols = read_table(tmp_path / name / "angles.csv", ["t", "pitch_abs", "roll_abs"])
        est = np.column_stack([cols["pitch_abs"], cols["roll_abs"]])
        err[name] = np.sqrt(np.mean((est - truth[: len(est)]) ** 2, axis=0))
    assert np.all(err["calibrated"] < 0.5 * err["raw"]), err
    assert json.loads((tmp_path / "calibrated" / "imu.json").read_text())["accelerometer_calibration"] == str(out)


def test_bad_calibration_input_is_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    still = simulate_static_poses(POSES[:1], RAW, seed=1, hold_s=10.0)
    assert main(["calibrate-imu", str(_csv(tmp_path / "one.csv", still)), "--out", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "found 1 still orientation" in err and not (tmp_path / "c.json").exists()
    bad = tmp_path / "bad.json"
    bad.write_text('{"bias_m_s2": [0, 0], "matrix": []}')
    walk = _csv(tmp_path / "w.csv", simulate_static_poses(POSES[:2], RAW, seed=1))
    assert main(["analyze", "--imu", str(walk), "--imu-calib", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "bad.json" in err
    with pytest.raises(InvalidInputError):
        fuse_recording(still.t_s, still.gyroscope_rps, still.accelerometer_mps2, [0.0],
                       settings=FusionSettings(accelerometer_calibration=AccelerometerCalibration.from_dict({"x": 1})))


def test_live_config_key_loads_the_calibration(tmp_path: Path) -> None:
    from walkmon.commands.live import live_fusion_settings
    from walkmon.live.config import config_from_dict

    imu = simulate_static_poses(POSES, RAW, seed=4)
    cal = calibrate_accelerometer(imu.t_s, imu.gyroscope_rps, imu.accelerometer_mps2)
    path = tmp_path / "accel.json"
    path.write_text(json.dumps(cal.to_dict()))
    cfg = config_from_dict({"imu": {"calibration": str(path)}})
    loaded = live_fusion_settings(cfg.imu).fusion.accelerometer_calibration
    assert loaded is not None
    np.testing.assert_allclose(loaded.bias_m_s2, imu.accelerometer_bias_mps2, atol=0.005)
    assert live_fusion_settings(config_from_dict({}).imu).fusion.accelerometer_calibration is None
    (tmp_path / "bad.json").write_text("not json")
    with pytest.raises(InvalidInputError, match="bad.json"):
        live_fusion_settings(config_from_dict({"imu": {"calibration": str(tmp_path / "bad.json")}}).imu)
