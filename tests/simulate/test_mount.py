"""The camera's mount on the trunk (``mount:PITCH[:ROLL]`` in a walk script): the camera and its IMU tilted, the
trunk's truth unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from walkmon.consts import gravity_angles_deg_from_gravity, rot_x, rot_y, rot_z
from walkmon.errors import InvalidInputError
from walkmon.simulate.gait import GaitModel, split_mount
from walkmon.simulate.imu import simulate_imu
from walkmon.simulate.unkind import UNKIND_WALKS, unkind_script


def test_a_standing_start_reads_the_mount_and_the_trunk_is_unchanged() -> None:
    tilted = GaitModel("mount:-17.5:2.5,stand:2,normal:6,turn:90,normal:4", seed=3)
    level = GaitModel("stand:2,normal:6,turn:90,normal:4", seed=3)
    assert tilted.mount_deg == (-17.5, 2.5)
    assert tilted.truth_angles_deg([0.0])[0] == pytest.approx([-17.5, 0.0, 2.5], abs=1e-9)
    t = np.linspace(0.0, level.duration_s, 400)
    np.testing.assert_array_equal(tilted.body_angles_deg(t), level.body_angles_deg(t))  # the trunk's truth
    np.testing.assert_array_equal(tilted.position_m(t), level.position_m(t))


def test_without_a_mount_the_camera_is_the_trunk() -> None:
    model = GaitModel("normal:6,turn:90,normal:4", seed=3)
    t = np.linspace(0.0, model.duration_s, 300)
    a = np.radians(model.body_angles_deg(t))
    np.testing.assert_array_equal(model.rotation(t), rot_y(a[:, 1]) @ rot_x(a[:, 0]) @ rot_z(a[:, 2]))


def test_the_body_rate_is_the_derivative_of_the_tilted_orientation() -> None:
    model = GaitModel("mount:-20:3,normal:6,turn:180,normal:4", seed=4)
    t = np.linspace(1.0, model.duration_s - 1.0, 50)
    h = 1e-5
    r0, r1 = model.rotation(t - h), model.rotation(t + h)
    d = np.swapaxes(r0, -1, -2) @ r1  # R^T dR ~ skew(w) 2h
    w = np.stack([d[:, 2, 1] - d[:, 1, 2], d[:, 0, 2] - d[:, 2, 0], d[:, 1, 0] - d[:, 0, 1]], 1) / (4 * h)
    np.testing.assert_allclose(model.angular_velocity_rps(t), w, atol=1e-4)


def test_the_imu_in_the_camera_sees_gravity_tilted_by_the_mount() -> None:
    model = GaitModel("mount:-15:4,stand:3,normal:5", seed=5)
    c = simulate_imu(model).columns()
    still = c["t"] < 2.5
    acc = np.column_stack([c["ax"], c["ay"], c["az"]])[still].mean(axis=0)
    pitch, roll = gravity_angles_deg_from_gravity(-acc)  # gravity points against the specific force at rest
    assert pitch == pytest.approx(-15.0, abs=0.5) and roll == pytest.approx(4.0, abs=0.5)


@pytest.mark.parametrize("script", ["mount:abc,normal", "mount:-60,normal", "mount:-10:30,normal",
                                    "mount:-10,mount:-5,normal", "mount:-10", "mount,normal"])
def test_bad_mount_tokens_are_refused_in_one_line(script: str) -> None:
    with pytest.raises(InvalidInputError, match="mount"):
        GaitModel(script)


def test_parse_walk_script_checks_the_mount_and_leaves_it_out_of_the_segments() -> None:
    from walkmon.simulate.gait import parse_walk_script

    assert [(g.walk, g.duration_s) for g in parse_walk_script("mount:-12,normal:3,bend:2")] == [
        ("normal", 3.0), ("bend", 2.0)]
    with pytest.raises(InvalidInputError, match="mount"):
        parse_walk_script("mount:-90,normal:3")


def test_split_mount_leaves_other_scripts_alone_and_unkind_sessions_draw_a_chest_mount() -> None:
    assert split_mount("normal:10,bend:10") == ("normal:10,bend:10", (0.0, 0.0))
    assert split_mount("mount:-12.5,normal:10") == ("normal:10", (-12.5, 0.0))
    for walk in UNKIND_WALKS:
        for seed in range(1, 6):
            script = unkind_script(seed, walk)
            _, (pitch, roll) = split_mount(script)
            assert -25.0 <= pitch <= 5.0 and -3.0 <= roll <= 3.0
            assert script == unkind_script(seed, walk)  # reproducible
