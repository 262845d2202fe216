"""``walkmon config``: the live monitor's configuration file: print the documented example, the defaults, or check
a file."""

from __future__ import annotations

import argparse
import sys
from importlib import resources
from typing import Any

from walkmon.errors import WalkmonError

NAME = "config"
HELP = "print the documented example config (--example) or the defaults (--defaults), or check a config file"


def example_config_text() -> str:
    """The documented example walkmon.toml shipped in the package (the same file as deploy/walkmon.toml)."""
    return resources.files("walkmon.live").joinpath("example.toml").read_text(encoding="utf-8")


def add_arguments(p: argparse.ArgumentParser) -> None:
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--example", action="store_true",
                      help="print the example config with every key documented (start /etc/walkmon/walkmon.toml from it)")
    what.add_argument("--defaults", action="store_true", help="print the built-in defaults as TOML")
    what.add_argument("--check", metavar="TOML", help="read a config file; one line and exit 2 if anything is wrong")


def run(args: argparse.Namespace) -> int:
    from walkmon.live.config import DEFAULT_CONFIG, config_to_toml, read_config  # noqa: PLC0415

    if args.example:
        sys.stdout.write(example_config_text())
    elif args.defaults:
        sys.stdout.write(config_to_toml(DEFAULT_CONFIG))
    else:
        cfg = read_config(args.check)
        try:
            check_sources(cfg)
        except WalkmonError as exc:  # named with the file it came from, as read_config's own errors are
            msg = f"{args.check}: {exc}"
            raise type(exc)(msg) from None
        unused = [k for k in _UNUSED_INDICATOR_KEYS
                  if getattr(cfg.indicators, k) != getattr(DEFAULT_CONFIG.indicators, k)]
        # keys kept so that older files load, set to another value: said (user review: 'bend_pitch_deg = 40' passed
        # the check, and a -17 deg walk was still labelled bend)
        note = (f" (not used: indicators.{', indicators.'.join(unused)}; labels come from the classifier's own "
                "thresholds, alerts from [alerts])") if unused else ""
        sys.stdout.write(f"{args.check}: ok{note}\n")
    return 0


#: [indicators] keys that still load but do nothing (walkmon.gait.live.LiveIndicatorSettings)
_UNUSED_INDICATOR_KEYS = ("bend_pitch_deg", "shoulder_down_roll_deg", "foot_drag_roll_swing_deg",
                          "foot_drag_asymmetry", "steady_posture_range_deg")


def check_sources(cfg: Any) -> None:
    """What 'walkmon live' checks of a config before it opens any hardware: the camera and IMU URLs (scheme and
    options), the camera calibration and the accelerometer calibration files, the alert sinks (check_sinks). A config this passed was refused by
    'live' (user review: a missing calibration file or an 'ftp:' URL read 'ok'; under the unit, a restart loop)."""
    from walkmon.camera.model import read_camera_yaml  # noqa: PLC0415
    from walkmon.commands.live import live_fusion_settings  # noqa: PLC0415
    from walkmon.drivers.sources import open_camera, open_imu  # noqa: PLC0415

    camera = open_camera(cfg.camera.url)  # constructed, nothing opened
    if cfg.imu.url:
        open_imu(cfg.imu.url, camera=camera)
    if cfg.camera.calib:
        read_camera_yaml(cfg.camera.calib)
    live_fusion_settings(cfg.imu)  # reads [imu] calibration
    from walkmon.live.sinks import check_sinks  # noqa: PLC0415

    check_sinks(cfg.sinks)  # the alerts' hook, player, sound file and apprise URLs
