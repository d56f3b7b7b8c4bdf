"""Actuator failure models and per-actuator failure schedules."""

from adaptive_ftc.faults.models import (
    FAILURE_MODELS,
    Affine,
    Bias,
    Failure,
    LossOfEffectiveness,
    NonAffine,
    ParameterisedStuck,
    PositionLimit,
    RateLimited,
    Reversal,
    Sluggish,
    Stuck,
)
from adaptive_ftc.faults.schedule import (
    CompensabilityReport,
    FailureSchedule,
    Interval,
    check_compensability,
)

__all__ = [
    "FAILURE_MODELS",
    "Affine",
    "Bias",
    "CompensabilityReport",
    "Failure",
    "FailureSchedule",
    "Interval",
    "LossOfEffectiveness",
    "NonAffine",
    "ParameterisedStuck",
    "PositionLimit",
    "RateLimited",
    "Reversal",
    "Sluggish",
    "Stuck",
    "check_compensability",
]
