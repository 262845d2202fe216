"""Gait: activity segmentation and steps, the session analysis (bouts, posture segments), the step-frequency
spectrum, the paper's indicators, posture classification, the live windowed stage and the HTML report."""

from walkmon.gait.activity import (
    ActivitySettings,
    Segmentation,
    segment,
    signals_from_angles,
    signals_from_imu,
)
from walkmon.gait.indicators import (
    DEFAULT_INDICATOR_SETTINGS,
    SCHEMA_VERSION,
    Indicators,
    IndicatorSettings,
    compute_indicators,
)
from walkmon.gait.live import LiveIndicators, LiveIndicatorSettings, LiveIndicatorStage
from walkmon.gait.posture import LABELS, Classification, PostureThresholds, classify
from walkmon.gait.session import ImuInput, SessionAnalysis, analyze_session

__all__ = [
    "DEFAULT_INDICATOR_SETTINGS",
    "LABELS",
    "SCHEMA_VERSION",
    "ActivitySettings",
    "Classification",
    "ImuInput",
    "IndicatorSettings",
    "Indicators",
    "LiveIndicatorSettings",
    "LiveIndicatorStage",
    "LiveIndicators",
    "PostureThresholds",
    "Segmentation",
    "SessionAnalysis",
    "analyze_session",
    "classify",
    "compute_indicators",
    "segment",
    "signals_from_angles",
    "signals_from_imu",
]
