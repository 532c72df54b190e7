"""Drift estimators behind one interface (:class:`DriftEstimator`), by name (:data:`ESTIMATORS`):
``adaptive`` (the default, ``docs/model.md``), the paper's ``stkf``, ``stkf-s1``, ``kf``,
``lsm``, ``mlr-causal``, ``fixed``, and the ``poly3`` baseline (:func:`fit_poly3`), which does
not run in the engine. What each is: ``docs/engine.md`` ("The estimators").
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
