"""The one interface every drift estimator implements, and the registry of estimators.

An estimator owns the drift-model parameters ``x = [a, b, c]`` (eq. 2) and nothing else: the
compensator gives it :class:`Observation` objects, linear in x, at every accepted update
interval (:meth:`DriftEstimator.update`) and says when one was refused (:meth:`DriftEstimator.hold`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.settings import DRIFT_BOUNDS_TEXT, DRIFT_PARAM_BOUNDS


def check_drift_triple(name: str, values) -> None:
    """Raise :class:`ConfigError` naming ``name`` unless ``values`` are three finite numbers
    (a, b, c) within :data:`~gyrodrift.settings.DRIFT_PARAM_BOUNDS`."""
    try:
        x = [float(v) for v in values]
    except (TypeError, ValueError, OverflowError):
        x = []
    if len(x) != 3 or not all(math.isfinite(v) for v in x):
        raise ConfigError(f"{name} must be three finite numbers (a, b, c), got {values!r}")
    if any(abs(v) > bound for v, bound in zip(x, DRIFT_PARAM_BOUNDS)):
        raise ConfigError(f"{name} = {tuple(x)!r} is outside the plausible drift model ({DRIFT_BOUNDS_TEXT})")

__all__ = ["DRIFT_PARAM_BOUNDS", "DRIFT_BOUNDS_TEXT", "check_drift_triple", "Observation", "DriftEstimator", "LinearDrift", "Unaided", "ESTIMATORS", "register", "make_estimator"]


@dataclass(frozen=True)
class Observation:
    """One aiding epoch: drift measurements ``y = H x + v``, ``v ~ N(0, R)``.

    Attributes
    ----------
    t : float
        Time of the epoch, s.
    y : (m,) ndarray
        Drift measurements m (deg/s), eq. (4); newest first.
    H : (m, 3) ndarray
        Rows ``[T (degC), T' (degC/s), 1]``, eq. (3).
    R : (m, m) ndarray
        Measurement noise covariance, (deg/s)².
    n_new : int
        How many of the rows (from the top) are new at this epoch; the others are
        repeats stacked as in eq. (3).
    """

    t: float
    y: np.ndarray
    H: np.ndarray
    R: np.ndarray
    n_new: int = 1

    def __post_init__(self):
        m = self.y.shape[0]
        if self.y.shape != (m,) or self.H.shape != (m, 3) or self.R.shape != (m, m):
            raise ValueError(
                f"inconsistent observation shapes y{self.y.shape} H{self.H.shape} R{self.R.shape}"
            )


@runtime_checkable
class DriftEstimator(Protocol):
    """Estimates the drift parameters [a, b, c] from observations."""

    name: ClassVar[str]
    causal: ClassVar[bool]

    @property
    def params(self) -> np.ndarray:
        """(3,) ndarray: a (deg/s/degC), b (deg/degC), c (deg/s) now in force."""

    @property
    def cov(self) -> np.ndarray:
        """(3, 3) ndarray: covariance of :attr:`params`."""

    def update(self, obs: Observation) -> np.ndarray:
        """Take one accepted observation; return the new parameters."""

    def hold(self) -> np.ndarray:
        """One update interval without accepted aiding; return the parameters."""

    def drift(self, temp_c: np.ndarray, temp_rate_cps: np.ndarray) -> np.ndarray:
        """Drift (deg/s) now in force at temperatures T (degC) and rates T' (degC/s)."""


class Unaided:
    """Mixin for estimators that learn nothing from aiding (fixed or offline models)."""

    @property
    def cov(self) -> np.ndarray:
        return np.zeros((3, 3))

    def update(self, obs: Observation) -> np.ndarray:
        return self.params

    def hold(self) -> np.ndarray:
        return self.params


class LinearDrift:
    """Mixin: the drift of eq. (2)/(5), ``a*T + b*T' + c``, from :attr:`params`."""

    def drift(self, temp_c, temp_rate_cps):
        a, b, c = (float(v) for v in self.params)
        return a * temp_c + b * temp_rate_cps + c


ESTIMATORS: dict[str, type] = {}


def register(cls):
    """Class decorator: add an estimator to :data:`ESTIMATORS` under ``cls.name``."""
    ESTIMATORS[cls.name] = cls
    return cls


def make_estimator(name: str, **settings) -> DriftEstimator:
    """Build a registered estimator by name; ``settings`` go to its constructor.

    Raises
    ------
    ConfigError
        For an unknown name; the message lists the valid names.
    """
    try:
        cls = ESTIMATORS[name]
    except KeyError:
        raise ConfigError(
            f"unknown estimator {name!r}; choose one of: {', '.join(sorted(ESTIMATORS))}"
        ) from None
    return cls(**settings)
