"""Camera rotation from video: the estimator front, its types, the fast and paper engines, two-view geometry.

Layering (nothing imports upwards): :mod:`~walkmon.rotation.types` <- :mod:`~walkmon.rotation.geometry` <-
:mod:`~walkmon.rotation.fast` / :mod:`~walkmon.rotation.paper` <- :mod:`~walkmon.rotation.estimator`. No I/O.
"""

from walkmon.rotation.estimator import RotationEstimator
from walkmon.rotation.types import (
    DEFAULT_ROTATION_SETTINGS,
    FLAG_REASONS,
    METHODS,
    UNMEASURED_MODELS,
    EstimateStatus,
    RotationEstimate,
    RotationSettings,
    grey_from_frame,
    make_estimate,
)

__all__ = [
    "DEFAULT_ROTATION_SETTINGS",
    "FLAG_REASONS",
    "METHODS",
    "EstimateStatus",
    "RotationEstimate",
    "RotationEstimator",
    "UNMEASURED_MODELS",
    "RotationSettings",
    "grey_from_frame",
    "make_estimate",
]
