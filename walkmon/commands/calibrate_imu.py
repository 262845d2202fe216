"""``walkmon calibrate-imu``: accelerometer bias and scale from an imu.csv of still poses (the 6-pose procedure)."""

from __future__ import annotations

import argparse
import sys

from walkmon.errors import InvalidInputError

NAME = "calibrate-imu"
HELP = ("estimate the accelerometer's bias and scale (and cross-axis terms with 9+ poses) from an imu.csv recorded "
        "while the IMU lies still in 6 or more orientations (each axis up and down, 2 s or more each)")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("imu", metavar="IMU_CSV", help="imu.csv (t,gx,gy,gz,ax,ay,az; s, rad/s, m/s2) of the still poses")
    p.add_argument("--out", required=True, metavar="JSON",
                   help="calibration file for 'walkmon analyze --imu-calib' and the live config's [imu] calibration")
    p.add_argument("--model", choices=("auto", "scale", "full"), default="auto",
                   help="scale: bias + per-axis scale (6+ poses); full: + cross-axis terms (9+ poses); auto (default): "
                   "full when there are 9 or more poses")
    p.add_argument("--min-still-s", type=float, default=1.5, metavar="S",
                   help="shortest still stretch taken as a pose (default 1.5 s)")


def run(args: argparse.Namespace) -> int:
    from walkmon.imu.calibration import calibrate_accelerometer  # noqa: PLC0415
    from walkmon.tables import read_imu_csv  # noqa: PLC0415

    if not 0.5 <= args.min_still_s <= 60.0:
        msg = f"--min-still-s must be in [0.5, 60], got {args.min_still_s}"
        raise InvalidInputError(msg)
    imu = read_imu_csv(args.imu)
    misalignment = {"auto": None, "scale": False, "full": True}[args.model]
    cal = calibrate_accelerometer(imu.t_s, imu.gyroscope_rad_s, imu.accelerometer_m_s2, misalignment=misalignment,
                                  min_still_s=args.min_still_s)
    from walkmon.safe_io import json_text, write_text  # noqa: PLC0415 - temp file + rename, never through a link

    write_text(args.out, json_text({**cal.to_dict(), "source": str(args.imu)}))
    b = cal.bias_m_s2
    M = cal.matrix_3x3
    sys.stdout.write(f"{cal.n_poses} still poses; bias {b[0]:+.4f} {b[1]:+.4f} {b[2]:+.4f} m/s2; scale "
                     f"{M[0, 0]:.4f} {M[1, 1]:.4f} {M[2, 2]:.4f}{' + cross-axis' if cal.misalignment else ''}; "
                     f"residual {cal.residual_m_s2:.4f} m/s2 -> {args.out}\n")
    return 0
