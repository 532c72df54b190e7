"""The strong tracking Kalman filter of Feng et al. (2015), and its s = 1 twin (plain KF).

States ``x = [a, b, c]`` of the drift model (eq. 2), modelled as constant between
updates (Φ = Γ = I, Section 3.2). At every accepted update interval:
``P- = s*P + Q`` then a Joseph-form correction (eq. 10).

Bounded covariance
------------------
Two things would make P grow without limit, and both are stopped:

* during an outage (no accepted aiding) the filter does not fade: fading discounts
  old *measurements*, and there are none; only Q is added (``P <- P + Q``);
* a direction the measurements do not see (T' ≡ 0 leaves b unobservable; a flat
  temperature confounds a with c) grows as ``s**N`` under fading. P is therefore
  capped, by default at the prior ``P0 = diag(p0_sd**2)``: in no direction of the
  parameter space are we less sure than before the first measurement. Only the
  directions above the cap shrink, and P stays symmetric positive definite.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.estimators._kalman import cap_covariance, correct, predict
from gyrodrift.estimators.base import LinearDrift, Observation, register

__all__ = ["KalmanConfig", "KalmanDrift", "PlainKalmanDrift", "BiasKalman"]


@dataclass(frozen=True, kw_only=True)
class KalmanConfig:
    """Settings of the Kalman drift estimators.

    Attributes
    ----------
    fading : float
        Fading factor s >= 1 of eq. (10); memory is about ``1/(1 - 1/s)`` updates
        (default 1.2: about 6 updates, 60 s at the 10-s interval; chosen on the
        simulated static and vehicle runs, see the README). Ignored by ``kf``.
    x0 : tuple of 3 floats
        Prior mean of [a (deg/s/degC), b (deg), c (deg/s)].
    p0_sd : tuple of 3 floats
        Prior standard deviations of [a, b, c] (same units); P0 = diag(p0_sd²).
    q_sd : tuple of 3 floats
        Process-noise standard deviations of [a, b, c] per update interval;
        Q = diag(q_sd²).
    max_sd : tuple of 3 floats, optional
        Cap on each standard deviation (see module notes); default ``p0_sd``.
    p0_cov : 3x3 nested tuple, optional
        A full prior covariance replacing ``diag(p0_sd²)`` (a warm start from a device
        profile keeps the strong a–c correlation); the cap stays ``max_sd``/``p0_sd``.
    """

    fading: float = 1.2
    x0: tuple[float, float, float] = (0.0, 0.0, 0.0)
    p0_sd: tuple[float, float, float] = (0.05, 5.0, 5.0)
    q_sd: tuple[float, float, float] = (1e-4, 0.05, 1e-3)
    max_sd: tuple[float, float, float] | None = None
    p0_cov: tuple[tuple[float, float, float], ...] | None = None

    def __post_init__(self):
        if not (isinstance(self.fading, (int, float)) and math.isfinite(self.fading) and self.fading >= 1.0):
            raise ConfigError(f"fading factor s must be a number >= 1, got {self.fading!r}")
        for name in ("x0", "p0_sd", "q_sd", "max_sd"):
            v = getattr(self, name)
            if v is None and name == "max_sd":
                continue
            try:
                ok = len(v) == 3 and all(math.isfinite(float(e)) for e in v)
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise ConfigError(f"{name} must be three finite numbers (a, b, c), got {v!r}")
        for name in ("p0_sd", "max_sd"):
            v = getattr(self, name)
            if v is not None and not all(float(e) > 0 for e in v):
                raise ConfigError(f"{name} must be positive, got {v!r}")
        if self.p0_cov is not None:
            try:
                P = np.array(self.p0_cov, dtype=float)
                ok = P.shape == (3, 3) and np.all(np.isfinite(P)) and np.allclose(P, P.T)
                ok = ok and bool(np.all(np.linalg.eigvalsh(P) > 0))
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise ConfigError("p0_cov must be a symmetric positive definite 3x3 matrix")

    def matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Initial covariance P0, the variance cap (diagonal) and Q of these settings."""
        if self.p0_cov is not None:
            P0 = np.array(self.p0_cov, dtype=float)
        else:
            P0 = np.diag(np.square(np.array(self.p0_sd, dtype=float)))
        max_var = np.square(np.array(self.max_sd or self.p0_sd, dtype=float))
        return P0, max_var, np.diag(np.square(np.array(self.q_sd, dtype=float)))
        if not all(float(e) >= 0 for e in self.q_sd):
            raise ConfigError(f"q_sd must be >= 0, got {self.q_sd!r}")


@register
class KalmanDrift(LinearDrift):
    """Strong tracking Kalman filter over [a, b, c] (``stkf``), eqs. (3)–(10).

    Examples
    --------
    >>> from gyrodrift.estimators.base import Observation
    >>> est = KalmanDrift(KalmanConfig(fading=1.0))
    >>> obs = Observation(t=10.0, y=np.array([0.5]), H=np.array([[0.0, 0.0, 1.0]]),
    ...                   R=np.array([[1e-6]]))
    >>> round(float(est.update(obs)[2]), 4)
    0.5
    """

    name: ClassVar[str] = "stkf"
    causal: ClassVar[bool] = True

    def __init__(self, config: KalmanConfig = KalmanConfig()):
        self.config = config
        self._x = np.array(config.x0, dtype=float)
        self._P, self._max_var, self._Q = config.matrices()
        #: Innovation and its covariance of the last update (diagnostics).
        self.last_innovation: np.ndarray | None = None
        self.last_S: np.ndarray | None = None

    @property
    def fading(self) -> float:
        return self.config.fading

    @property
    def params(self) -> np.ndarray:
        return self._x.copy()

    @property
    def cov(self) -> np.ndarray:
        return self._P.copy()

    def update(self, obs: Observation) -> np.ndarray:
        P_prior = cap_covariance(predict(self._P, self._Q, self.fading), self._max_var)
        self._x, P_post, self.last_innovation, self.last_S = correct(
            self._x, P_prior, obs.y, obs.H, obs.R
        )
        self._P = cap_covariance(P_post, self._max_var)
        return self.params

    def hold(self) -> np.ndarray:
        self._P = cap_covariance(predict(self._P, self._Q, 1.0), self._max_var)
        return self.params

    def engine_state(self) -> dict:
        """State and settings for the compiled engine (:mod:`gyrodrift._engine`)."""
        return {"mode": "fixed", "fading": float(self.fading), "x": self._x, "P": self._P, "Q": self._Q,
                "max_var": self._max_var, "active": (0, 1, 2)}

    def set_engine_state(self, state: dict) -> None:
        """Take back the state the compiled engine ended with."""
        self._x = np.array(state["x"], dtype=float)
        self._P = np.array(state["P"], dtype=float)


@register
class PlainKalmanDrift(KalmanDrift):
    """The same filter with s = 1 (``stkf-s1``): a plain Kalman filter over [a, b, c]."""

    name: ClassVar[str] = "stkf-s1"

    def __init__(self, config: KalmanConfig = KalmanConfig()):
        super().__init__(replace(config, fading=1.0))


@register
class BiasKalman(LinearDrift):
    """The paper's KF baseline (``kf``): a plain Kalman filter on a constant bias c alone.

    Same kernels, one state, s = 1; a and b stay 0, so through an outage the last bias
    is held and the temperature is ignored (Section 4, Figs. 4, 5 and 9).

    Parameters
    ----------
    config : KalmanConfig
        Prior of c (``x0[2]``, ``p0_sd[2]``, cap ``max_sd[2]``).
    bias_q_sd : float
        Random-walk standard deviation of the bias per update interval, deg/s. With
        no temperature model the bias must wander to follow the drift: 0.02 deg/s
        balanced bias and heading error on the simulated static and vehicle runs
        (0.003 lags far behind, 0.05 is noisy).
    """

    name: ClassVar[str] = "kf"
    causal: ClassVar[bool] = True

    def __init__(self, config: KalmanConfig = KalmanConfig(), bias_q_sd: float = 0.02):
        if not (math.isfinite(bias_q_sd) and bias_q_sd >= 0):
            raise ConfigError(f"bias_q_sd must be >= 0 deg/s, got {bias_q_sd!r}")
        self.config = config
        self._x = np.array([config.x0[2]], dtype=float)
        self._P = np.array([[config.p0_sd[2] ** 2]])
        self._Q = np.array([[bias_q_sd**2]])
        self._max_var = np.array([(config.max_sd or config.p0_sd)[2] ** 2])

    @property
    def params(self) -> np.ndarray:
        return np.array([0.0, 0.0, self._x[0]])

    @property
    def cov(self) -> np.ndarray:
        P = np.zeros((3, 3))
        P[2, 2] = self._P[0, 0]
        return P

    def update(self, obs: Observation) -> np.ndarray:
        P_prior = cap_covariance(predict(self._P, self._Q, 1.0), self._max_var)
        self._x, P_post, _, _ = correct(self._x, P_prior, obs.y, obs.H[:, 2:3], obs.R)
        self._P = cap_covariance(P_post, self._max_var)
        return self.params

    def hold(self) -> np.ndarray:
        self._P = cap_covariance(predict(self._P, self._Q, 1.0), self._max_var)
        return self.params

    def engine_state(self) -> dict:
        """State and settings for the compiled engine: the 3-state form with only c active."""
        P = np.zeros((3, 3))
        P[2, 2] = self._P[0, 0]
        Q = np.zeros((3, 3))
        Q[2, 2] = self._Q[0, 0]
        return {"mode": "fixed", "fading": 1.0, "x": np.array([0.0, 0.0, self._x[0]]), "P": P, "Q": Q,
                "max_var": np.array([1.0, 1.0, self._max_var[0]]), "active": (2,)}

    def set_engine_state(self, state: dict) -> None:
        """Take back the state the compiled engine ended with."""
        self._x = np.array([state["x"][2]], dtype=float)
        self._P = np.array([[state["P"][2, 2]]], dtype=float)
