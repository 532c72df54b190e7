"""The ``adaptive`` drift estimator: the paper's structure, with a memory that adapts itself.

Same drift model and states as the paper (eq. 2), same constant-parameter filter
(Φ = I), with two changes:

* **Temperature centred** on a reference ``T_ref`` (the mean temperature of the first
  observation): the filter estimates ``[a, b, c']`` with rows ``[T − T_ref, T', 1]``,
  where ``c' = a*T_ref + c`` is the drift at ``T_ref``. Over a small temperature span
  the paper's ``a`` and ``c`` are nearly collinear (``c`` must move by ``-T*Δa``); the
  centred ``a`` and ``c'`` are not. :attr:`params` still reports the paper's absolute
  ``[a, b, c]``.
* **Innovation-based fading factor** of the strong tracking filter of Zhou et al.
  (suboptimal fading factor; see ``shared/guide/field-notes.md`` §1.8) instead of the
  paper's constant s: a running innovation covariance
  ``V_k = (ρ V_{k-1} + γγᵀ)/(1 + ρ)`` is compared with what the filter predicts,
  ``λ_k = max(1, tr(V_k − H Q Hᵀ − R) / tr(H P Hᵀ))``, capped at ``lambda_max``, and
  ``P⁻ = λ_k P + Q``. While the model explains the measurements λ = 1 and the memory is
  long (well-determined a and b, good extrapolation through outages); when the drift
  departs from the model the innovations grow, λ > 1 and old measurements are
  forgotten fast (tracking).

The covariance is bounded as in :mod:`gyrodrift.estimators.kalman` (capped at the
prior, no fading in outages).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.estimators._kalman import cap_covariance, correct, predict
from gyrodrift.estimators.base import LinearDrift, Observation, register
from gyrodrift.estimators.kalman import KalmanConfig

__all__ = ["AdaptiveKalman"]


@register
class AdaptiveKalman(LinearDrift):
    """Centred-temperature Kalman filter with innovation-based fading (``adaptive``).

    Parameters
    ----------
    config : KalmanConfig
        Prior (``x0`` absolute [a, b, c], ``p0_sd`` of [a, b, c'], cap ``max_sd``) and
        process noise ``q_sd`` of [a, b, c'] per update interval, shared with the other
        Kalman estimators; ``fading`` is ignored (the fading factor is adaptive).
    lambda_max : float
        Largest fading factor of one update.
    rho : float
        Forgetting of the innovation covariance estimate, 0 < rho < 1.
    """

    name: ClassVar[str] = "adaptive"
    causal: ClassVar[bool] = True

    def __init__(self, config: KalmanConfig = KalmanConfig(), *, lambda_max: float = 20.0, rho: float = 0.8):
        if not (math.isfinite(lambda_max) and lambda_max >= 1.0):
            raise ConfigError(f"lambda_max must be >= 1, got {lambda_max!r}")
        if not (0.0 < rho < 1.0):
            raise ConfigError(f"rho must be between 0 and 1, got {rho!r}")
        self.config = config
        self.lambda_max = float(lambda_max)
        self.rho = float(rho)
        self.temp_ref_c: float | None = None
        self._x_abs0 = np.array(config.x0, dtype=float)
        self._z = self._x_abs0.copy()  # [a, b, c'] once T_ref is known
        self._P, self._max_var, self._Q = config.matrices()
        self._V: np.ndarray | None = None
        #: Fading factor of the last update (diagnostics).
        self.last_lambda = 1.0

    @property
    def params(self) -> np.ndarray:
        a, b, c_ref = self._z
        t_ref = self.temp_ref_c or 0.0
        return np.array([a, b, c_ref - a * t_ref])

    @property
    def cov(self) -> np.ndarray:
        """Covariance of the absolute [a, b, c] (transformed from the centred states)."""
        J = np.eye(3)
        J[2, 0] = -(self.temp_ref_c or 0.0)
        return J @ self._P @ J.T

    def _centre(self, obs: Observation) -> np.ndarray:
        if self.temp_ref_c is None:
            self.temp_ref_c = float(np.mean(obs.H[:, 0]))
            a, b, c = self._x_abs0
            self._z = np.array([a, b, c + a * self.temp_ref_c])
        H = obs.H.copy()
        H[:, 0] -= self.temp_ref_c
        return H

    def update(self, obs: Observation) -> np.ndarray:
        H = self._centre(obs)
        gamma = obs.y - H @ self._z
        outer = np.outer(gamma, gamma)
        if self._V is None or self._V.shape != outer.shape:
            self._V = outer
        else:
            self._V = (self.rho * self._V + outer) / (1.0 + self.rho)
        N = self._V - H @ self._Q @ H.T - obs.R
        M = H @ self._P @ H.T
        lam = float(np.trace(N) / np.trace(M)) if np.trace(M) > 0 else 1.0
        self.last_lambda = min(max(1.0, lam), self.lambda_max)
        P_prior = cap_covariance(predict(self._P, self._Q, self.last_lambda), self._max_var)
        self._z, P_post, _, _ = correct(self._z, P_prior, obs.y, H, obs.R)
        self._P = cap_covariance(P_post, self._max_var)
        return self.params

    def hold(self) -> np.ndarray:
        self._P = cap_covariance(predict(self._P, self._Q, 1.0), self._max_var)
        return self.params

    def engine_state(self) -> dict:
        """State and settings for the compiled engine (:mod:`gyrodrift._engine`)."""
        return {"mode": "zhou", "fading": 1.0, "lambda_max": self.lambda_max, "rho": self.rho, "centred": True,
                "x": self._z, "P": self._P, "Q": self._Q, "max_var": self._max_var, "active": (0, 1, 2),
                "V": self._V, "temp_ref_c": self.temp_ref_c}

    def set_engine_state(self, state: dict) -> None:
        """Take back the state the compiled engine ended with."""
        self._z = np.array(state["x"], dtype=float)
        self._P = np.array(state["P"], dtype=float)
        if state.get("V") is not None:
            self._V = np.array(state["V"], dtype=float)
        if state.get("temp_ref_c") is not None:
            self.temp_ref_c = float(state["temp_ref_c"])
        if state.get("last_lambda") is not None:
            self.last_lambda = float(state["last_lambda"])
