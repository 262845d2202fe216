"""``walkmon demo``: no arguments, no hardware. Simulates a walk and runs the whole offline analysis on it.

It chains the same subcommands a user runs (``simulate``, then ``analyze`` with the simulated intrinsics and,
where the IMU stage is installed, the simulated IMU), so the demo always exercises the real code paths. At the
end it compares the estimated angles with the simulator's ground truth and prints where everything is.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from walkmon.consts import ANGLE_COLUMNS, AXES, TRUTH_COLUMNS

NAME = "demo"
HELP = "simulate a walk and run the whole analysis on it (no hardware needed); prints where the report is"

DEFAULT_WALK = "normal"
DEFAULT_SECONDS = 16.0


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="walkmon-demo", help="output folder (default ./walkmon-demo)")
    p.add_argument("--walk", default=DEFAULT_WALK, help=f"walk type or script (default {DEFAULT_WALK})")
    p.add_argument("--seconds", type=float, default=DEFAULT_SECONDS, help=f"walk length (default {DEFAULT_SECONDS:g})")
    p.add_argument("--seed", type=int, default=7, help="simulator seed (default 7)")


def _step(argv: list[str]) -> None:
    from walkmon.commands.cli import main  # noqa: PLC0415  (the demo is a client of the CLI)

    sys.stdout.write(f"\n$ walkmon {' '.join(argv)}\n")
    sys.stdout.flush()
    rc = main(argv)
    if rc != 0:
        raise SystemExit(rc)


def _accuracy_lines(angles_csv: Path, truth_csv: Path) -> list[str]:
    from walkmon.consts import angles_deg_from_rotation, rotation_from_angles_deg  # noqa: PLC0415
    from walkmon.tables import read_table  # noqa: PLC0415

    est = read_table(angles_csv, ANGLE_COLUMNS)
    truth = read_table(truth_csv, TRUTH_COLUMNS)
    n = min(len(est["t"]), len(truth["t"]))
    # the estimate is relative to the first frame; truth.csv is the camera in the world (a mount tilts its first row)
    r = rotation_from_angles_deg(truth["pitch"][:n], truth["yaw"][:n], truth["roll"][:n])
    rel = angles_deg_from_rotation(np.swapaxes(r[0], -1, -2) @ r)
    rel[:, 1] = np.degrees(np.unwrap(np.radians(rel[:, 1])))
    lines = []
    for k, axis in enumerate(AXES):
        err = est[axis][:n] - rel[:, k]
        if axis == "yaw":
            err = (err + 180.0) % 360.0 - 180.0
        lines.append(f"  {axis:<5} RMSE {np.sqrt(np.mean(err**2)):.3f} deg, largest error {np.max(np.abs(err)):.3f} deg")
    return lines


def run(args: argparse.Namespace) -> int:
    out = Path(args.out)
    sim, analysis = out / "simulated", out / "analysis"
    _step(["simulate", "--walk", args.walk, "--seconds", f"{args.seconds:g}", "--seed", str(args.seed), "--out", str(sim)])
    analyze = ["analyze", str(sim / "video.mp4"), "--calib", str(sim / "camera.yaml"), "--out", str(analysis)]
    _step(analyze)
    lines = [
        "",
        f"walkmon demo: a simulated '{args.walk}' walk of {args.seconds:g} s, analysed from its video.",
        "Estimated camera rotation against the simulator's ground truth:",
        *_accuracy_lines(analysis / "angles.csv", sim / "truth.csv"),
        f"  simulated walk : {sim}/  (video.mp4, truth.csv, imu.csv, camera.yaml, meta.json)",
        f"  angles         : {analysis / 'angles.csv'}",
    ]
    for name in ("indicators.json", "report.html"):
        if (analysis / name).exists():
            lines.append(f"  {name:<15}: {analysis / name}")
    report = analysis / "report.html"
    if report.exists():
        lines.append(f"Open the report in a browser: file://{report.resolve()}")
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
