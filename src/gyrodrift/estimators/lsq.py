"""Least-squares baselines of the paper: MLR (whole log), MLR on the past, and the "modified LSM"
(sliding window), all the weighted least squares of eq. (2) over drift measurements
(``docs/engine.md``, "The least-squares baselines").
"""

from __future__ import annotations

from collections import deque
from typing import ClassVar

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.estimators.base import LinearDrift, Observation, Unaided, check_drift_triple, register
from gyrodrift.estimators.kalman import KalmanConfig

__all__ = ["fit_linear_drift", "WindowedLsm", "CausalMlr", "FixedParams"]


def fit_linear_drift(m, H, r, prior: KalmanConfig | None = None) -> np.ndarray:
    """Weighted least-squares [a, b, c] of eq. (2) (``docs/engine.md``, "The least-squares baselines").

    Parameters
    ----------
    m : (n,) array_like
        Drift measurements, deg/s.
    H : (n, 3) array_like
        Rows [T (degC), T' (degC/s), 1].
    r : (n,) array_like
        Measurement variances, (deg/s)².
    prior : KalmanConfig, optional
        Regularise towards ``x0`` with covariance ``diag(p0_sd²)``; None: plain least
        squares (minimum-norm where the data leave a direction undetermined).

    Examples
    --------
    >>> H = np.array([[20.0, 0.0, 1.0], [30.0, 0.01, 1.0], [40.0, -0.01, 1.0], [35.0, 0.02, 1.0]])
    >>> x = fit_linear_drift(H @ [0.02, 3.0, -0.4], H, np.full(4, 0.005))
    >>> np.round(x, 9).tolist()
    [0.02, 3.0, -0.4]
    """
    m = np.asarray(m, dtype=float)
    H = np.asarray(H, dtype=float).reshape(-1, 3)
    w = 1.0 / np.asarray(r, dtype=float)
    if prior is not None:
        x0 = np.array(prior.x0, dtype=float)
        info = np.diag(1.0 / np.square(np.array(prior.p0_sd, dtype=float)))
        return np.linalg.solve(H.T @ (H * w[:, None]) + info, H.T @ (w * m) + info @ x0)
    if m.size == 0:
        return np.zeros(3)
    A = H * np.sqrt(w)[:, None]
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    x_scaled, *_ = np.linalg.lstsq(A / scale, m * np.sqrt(w), rcond=None)
    return x_scaled / scale


class _Fitted(LinearDrift):
    """A least-squares estimator: the parameters ``_x`` of its last fit, held through refused intervals."""

    causal: ClassVar[bool] = True

    @property
    def params(self) -> np.ndarray:
        return self._x.copy()

    def hold(self) -> np.ndarray:
        return self.params


@register
class WindowedLsm(_Fitted):
    """The paper's "modified LSM" (``lsm``): a, b, c refitted at every update over the
    last ``window`` accepted measurements (default 30: 300 s at the 10-s interval).

    Parameters
    ----------
    config : KalmanConfig
        The prior (``x0``, ``p0_sd``) that regularises each fit.
    window : int
        Number of measurements in the sliding window.
    """

    name: ClassVar[str] = "lsm"

    def __init__(self, config: KalmanConfig = KalmanConfig(), window: int = 30):
        if not (isinstance(window, int) and window >= 1):
            raise ConfigError(f"lsm window must be a whole number >= 1, got {window!r}")
        self.config = config
        self._rows: deque[tuple[float, np.ndarray, float]] = deque(maxlen=window)
        self._x = np.array(config.x0, dtype=float)

    @property
    def cov(self) -> np.ndarray:
        """Covariance of the regularised fit, ``(H^T R^-1 H + P0^-1)^-1``."""
        m, H, r = self._arrays()
        info = np.diag(1.0 / np.square(np.array(self.config.p0_sd, dtype=float)))
        return np.linalg.inv(info + H.T @ (H / r[:, None]))

    def _arrays(self):
        if not self._rows:
            return np.empty(0), np.empty((0, 3)), np.empty(0)
        m, H, r = zip(*self._rows)
        return np.array(m), np.array(H), np.array(r)

    def update(self, obs: Observation) -> np.ndarray:
        for i in reversed(range(obs.n_new)):  # oldest first
            self._rows.append((float(obs.y[i]), obs.H[i].copy(), float(obs.R[i, i])))
        self._x = fit_linear_drift(*self._arrays(), prior=self.config)
        return self.params


@register
class CausalMlr(_Fitted):
    """The paper's MLR fitted on the past only (``mlr-causal``): at every update a, b, c are
    the regularised weighted least squares of every measurement accepted so far
    (:func:`fit_linear_drift` with the prior, accumulated as normal equations), so a row
    is compensated with what was known when it was logged.

    Parameters
    ----------
    config : KalmanConfig
        The prior (``x0``, ``p0_sd``) that regularises the fit.
    """

    name: ClassVar[str] = "mlr-causal"

    def __init__(self, config: KalmanConfig = KalmanConfig()):
        self.config = config
        x0 = np.array(config.x0, dtype=float)
        self._info = np.diag(1.0 / np.square(np.array(config.p0_sd, dtype=float)))
        self._vec = self._info @ x0
        self._x = x0

    @property
    def cov(self) -> np.ndarray:
        """Covariance of the fit, ``(P0^-1 + H^T R^-1 H)^-1``."""
        return np.linalg.inv(self._info)

    def update(self, obs: Observation) -> np.ndarray:
        for i in range(obs.n_new):
            h = obs.H[i]
            w = 1.0 / float(obs.R[i, i])
            self._info = self._info + w * np.outer(h, h)
            self._vec = self._vec + w * float(obs.y[i]) * h
        self._x = np.linalg.solve(self._info, self._vec)
        return self.params


@register
class FixedParams(Unaided, _Fitted):
    """Fixed a, b, c (``fixed``): ignores all observations.

    With parameters fitted by :func:`fit_linear_drift` over every measurement of the
    whole log this is the paper's MLR baseline, which is not causal.
    """

    name: ClassVar[str] = "fixed"

    def __init__(self, params=(0.0, 0.0, 0.0)):
        check_drift_triple("fixed parameters", params)
        self._x = np.array(params, dtype=float)
