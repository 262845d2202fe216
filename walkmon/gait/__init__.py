"""Gait: the step-frequency spectrum, the paper's indicators, posture classification, the live windowed stage and
the HTML report."""

from walkmon.gait.indicators import (
    DEFAULT_INDICATOR_SETTINGS,
    SCHEMA_VERSION,
    Indicators,
    IndicatorSettings,
    compute_indicators,
)
from walkmon.gait.live import LiveIndicators, LiveIndicatorSettings, LiveIndicatorStage
from walkmon.gait.posture import LABELS, Classification, PostureThresholds, classify

__all__ = [
    "DEFAULT_INDICATOR_SETTINGS",
    "LABELS",
    "SCHEMA_VERSION",
    "Classification",
    "IndicatorSettings",
    "Indicators",
    "LiveIndicatorSettings",
    "LiveIndicatorStage",
    "LiveIndicators",
    "PostureThresholds",
    "classify",
    "compute_indicators",
]
