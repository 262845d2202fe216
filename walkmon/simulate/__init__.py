"""Synthetic walking sessions with ground truth: a gait model, an IMU model and a 3-D street renderer.

``simulate(out_dir, walk="normal", seconds=16.0, seed=0, ...)`` writes video.mp4, truth.csv, imu.csv,
camera.yaml, meta.json, truth_timeline.csv and truth_steps.csv; ``iter_frames(walk, seconds, seed, ...)`` yields
``(t_s, frame_bgr, truth_angles_deg)`` in memory. :func:`walkmon.simulate.unkind.unkind_script` draws a random
session script as unkind as life (issue 11); :mod:`walkmon.simulate.cache` keeps simulations for benchmarks
under a key of ``SIMULATOR_VERSION`` (changed whenever the same arguments give different output) and every
parameter.
"""

from __future__ import annotations

from walkmon.simulate._version import SIMULATOR_VERSION
from walkmon.simulate.gait import (
    ACTIVITIES,
    STANDING_S,
    WALK_TYPES,
    GaitModel,
    parse_walk_script,
)
from walkmon.simulate.imu import (
    DEFAULT_IMU_SETTINGS,
    ImuSamples,
    ImuSettings,
    simulate_imu,
)
from walkmon.simulate.render import DEFAULT_RENDER_SETTINGS, Renderer, RenderSettings
from walkmon.simulate.session import (
    SimulatedSession,
    SimulationResult,
    iter_frames,
    simulate,
    simulation_camera,
)

__all__ = [
    "ACTIVITIES",
    "DEFAULT_IMU_SETTINGS",
    "DEFAULT_RENDER_SETTINGS",
    "SIMULATOR_VERSION",
    "STANDING_S",
    "WALK_TYPES",
    "GaitModel",
    "ImuSamples",
    "ImuSettings",
    "RenderSettings",
    "Renderer",
    "SimulatedSession",
    "SimulationResult",
    "iter_frames",
    "parse_walk_script",
    "simulate",
    "simulate_imu",
    "simulation_camera",
]
