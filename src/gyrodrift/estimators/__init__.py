"""Drift estimators behind one interface (:class:`DriftEstimator`), by name.

===========  ==================================================================
name         estimator
===========  ==================================================================
``stkf``     strong tracking Kalman filter over [a, b, c], eqs. (3)–(10)
``stkf-s1``  the same filter with s = 1 (plain Kalman filter over [a, b, c])
``kf``       the paper's KF baseline: plain Kalman filter on a constant bias only
``lsm``      the paper's "modified LSM": a, b, c refitted over a sliding window
``mlr-causal`` the paper's MLR fitted on the measurements accepted so far
``fixed``    fixed a, b, c (with a whole-log fit: the paper's MLR, non-causal)
``adaptive`` heading, drift and compass error in one model, hypotheses weighed by
             evidence (beyond the paper; :class:`AdaptiveConfig`; the default)
===========  ==================================================================

The PX4-style cubic calibration (``poly3``, :func:`fit_poly3`) is a baseline of
:mod:`gyrodrift.evaluate.compare`: its drift is not eq. (2), so it does not run in the engine.
"""

from gyrodrift.estimators.base import (
    ESTIMATORS,
    DriftEstimator,
    LinearDrift,
    Observation,
    make_estimator,
    register,
)
from gyrodrift.estimators.adaptive import AdaptiveConfig, AdaptiveModel
from gyrodrift.estimators.kalman import BiasKalman, KalmanConfig, KalmanDrift, PlainKalmanDrift
from gyrodrift.estimators.lsq import CausalMlr, FixedParams, WindowedLsm, fit_linear_drift
from gyrodrift.estimators.poly import Poly3Calibration, fit_poly3

__all__ = [
    "ESTIMATORS",
    "AdaptiveConfig",
    "AdaptiveModel",
    "DriftEstimator",
    "LinearDrift",
    "Observation",
    "make_estimator",
    "register",
    "KalmanConfig",
    "KalmanDrift",
    "PlainKalmanDrift",
    "BiasKalman",
    "WindowedLsm",
    "CausalMlr",
    "FixedParams",
    "fit_linear_drift",
    "Poly3Calibration",
    "fit_poly3",
]
