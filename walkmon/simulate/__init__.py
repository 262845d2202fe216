"""Synthetic walking sessions with ground truth: a gait model, an IMU model and a 3-D street renderer."""

from __future__ import annotations

from walkmon.simulate.gait import WALK_TYPES, GaitModel, parse_walk_script

__all__ = ["WALK_TYPES", "GaitModel", "parse_walk_script"]
