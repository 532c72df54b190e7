"""Adaptive estimate of the temperature-dependent gyro scale factor (Feng et al. 2015, Sec. 4.3).

``SF(T) = s0 + s1*(T - T_ref)`` learned by a strong tracking Kalman filter (eq. 10) from one
measurement per rotation: the gyro's heading change over the compass's between two still
windows. Model, measurement, the causal pass and the choices where the paper is silent:
``docs/scale_factor.md``.
"""

from gyrodrift.scale_factor.batch import estimate_scale_factor, heading_error, integrate_heading
from gyrodrift.scale_factor.config import ScaleFactorConfig
from gyrodrift.scale_factor.filter import fixed_scale_factor, sf_filter
from gyrodrift.scale_factor.streaming import (
    TRACKER_COLUMNS,
    CompensatedSFSample,
    ScaleFactorRow,
    ScaleFactorTracker,
)
from gyrodrift.scale_factor.turns import REJECT_GATES, moving_mask, turn_measurements

__all__ = [
    "ScaleFactorConfig",
    "moving_mask",
    "turn_measurements",
    "sf_filter",
    "fixed_scale_factor",
    "integrate_heading",
    "heading_error",
    "estimate_scale_factor",
    "ScaleFactorTracker",
    "ScaleFactorRow",
    "TRACKER_COLUMNS",
    "CompensatedSFSample",
    "REJECT_GATES",
]
