"""Drift estimators behind one interface (:class:`DriftEstimator`), by name.

========  ==========================================================
name      estimator
========  ==========================================================
``stkf``  strong tracking Kalman filter, eqs. (3)–(10) (default)
``kf``    the same filter with s = 1 (plain Kalman filter)
========  ==========================================================
"""

from gyrodrift.estimators.base import (
    ESTIMATORS,
    DriftEstimator,
    Observation,
    make_estimator,
    register,
)
from gyrodrift.estimators.kalman import KalmanConfig, KalmanDrift, PlainKalmanDrift

__all__ = [
    "ESTIMATORS",
    "DriftEstimator",
    "Observation",
    "make_estimator",
    "register",
    "KalmanConfig",
    "KalmanDrift",
    "PlainKalmanDrift",
]
