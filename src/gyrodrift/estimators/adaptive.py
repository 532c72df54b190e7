"""The ``adaptive`` drift estimator: the paper's structure, with a memory that adapts itself.

Same drift model and states as the paper (eq. 2), same constant-parameter filter
(Φ = I, eq. 10), with these changes:

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
  forgotten fast (tracking). By default the test uses the normalised innovations of the
  last few updates against a χ² threshold (``AdaptiveConfig.normalised``, ``softening``).
* **Moving reference temperature** and **per-parameter process noise**: ``T_ref`` follows
  the sensor, ``c'`` (the drift at the current temperature) random-walks in time, ``a``
  random-walks in temperature (``AdaptiveConfig.recentre``, ``q_sd``,
  ``slope_q_per_rtc``).
* **Outage memory**: a twin without the slope random walk supplies a and b for
  extrapolating through refused intervals (eq. 5) (``AdaptiveConfig.outage_memory``).

The covariance is bounded as in :mod:`gyrodrift.estimators.kalman` (capped at the
prior, no fading in outages).

Every change beyond the paper is a switch of :class:`AdaptiveConfig` (issue 6, for the
ablation); the compensator (:mod:`gyrodrift.compensate`) reads the switches that concern
its measurements: one measurement per interval, compass averaging at the interval edges
with an online compass-noise estimate, and zero-rate (stationarity, ZARU) measurements.
Results and the ablation: ``docs/results.md``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.estimators._kalman import cap_covariance, correct, predict
from gyrodrift.estimators.base import LinearDrift, Observation, register
from gyrodrift.estimators.kalman import KalmanConfig

__all__ = ["AdaptiveConfig", "AdaptiveKalman"]


@dataclass(frozen=True, kw_only=True)
class AdaptiveConfig:
    """Settings of the ``adaptive`` estimator, each fix of issue 6 switchable.

    Attributes
    ----------
    stacked : bool
        Fix 1 off (``True``): the paper's stacked copies of the last ``stack_depth``
        measurements in y (eq. 3), each measurement used in several updates with its
        noise counted as new each time. ``False`` (default): one measurement per update
        interval with its own variance.
    edge_s : float
        Fix 1, compass averaging at the window edges: each end of a compass measurement
        (eq. 6) is the mean of ``D = ∫gyro − compass`` over the compass samples of the
        last ``edge_s`` seconds, not one sample; its noise variance is divided by their
        number, and consecutive intervals share their edge, so the measurements still
        telescope. 0: one sample at each end (the paper).
    recentre : bool
        Fix 2, well-posed process noise: before each update the reference temperature
        moves to the temperature of the new measurement (``c' ← c' + a (T_new − T_ref)``,
        P transformed alike), so that ``q_sd`` of c' is the random walk of the drift *at
        the current temperature* and that of ``a`` is not amplified by a growing
        ``|T − T_ref|``. ``False``: T_ref stays the first measurement's temperature.
    zaru : bool
        Fix 4: a zero-rate (stationarity) measurement when the unit is still. The mean
        gyro rate over the interval then measures the drift with only the gyro's white
        noise, ``N²/Δt``, about 5 times more precise than a compass difference (eq. 6).
        Still means: the compass heading over the last ``zaru_window_s`` fits a flat
        line: slope within ``zaru_slope_k`` of its standard error, scatter about the
        line within two compass sigmas and not above the compass white noise (estimated
        online from successive differences) by more than ``zaru_resid_k`` standard
        errors of a variance ratio; a slow turn, a sway or a wandering heading fails
        this. And the gyro
        rate between compass samples has a standard deviation below
        ``GateConfig.still_std_dps``. A still interval is accepted even when the compass
        and gyro disagree (the drift moved, not the heading).
    zaru_hold : bool
        Fix 3, deciding which sensor moved: once stillness was verified by the compass,
        it holds while the gyro shows no motion and its mean rate agrees with the
        predicted drift (NIS test against the predicted covariance), even when the
        compass wanders (slow magnetic interference the disagreement gate cannot see).
    zaru_window_s : float
        Length of the compass stillness window, s.
    zaru_slope_k, zaru_resid_k : float
        Stillness thresholds (see ``zaru``).
    fading : bool
        Fix 5: the innovation-based fading factor of Zhou et al. (``False``: λ = 1, a
        plain Kalman filter with process noise ``q_sd``).
    lambda_max : float
        Largest fading factor of one update.
    rho : float
        Forgetting of the innovation covariance estimate, 0 < rho < 1.
    softening : float
        Zhou's softening (weakening) factor β >= 1 of the fading test,
        ``λ = max(1, tr(V − H Q Hᵀ − β R) / tr(H P Hᵀ))``: fade only when the innovations
        exceed β times the measurement noise. With one measurement per interval, V is an
        average over a few innovations only and exceeds R by chance about half the time;
        β = 1 then fades on noise. Default 3.78, the 99 % quantile of χ² with 3 degrees
        of freedom divided by 3 (``innovation_window`` = 3): about 1 % of updates of a
        consistent filter fade. Not tuned (the ``static`` family cannot tell 1 to 6.6
        apart).
    normalised : bool
        Fix 3 (robust fading test): True: the test uses the mean normalised innovation
        squared (NIS, ``γᵀ S⁻¹ γ / m`` with ``S`` predicted without fading) of the last
        ``innovation_window`` updates, ε̄, and fades by
        ``λ = max(1, 1 + (ε̄ − β) tr(S) / tr(H P Hᵀ))``: Zhou's λ with V = ε̄ S, so only
        a sustained excess over β (a χ² quantile of ``n`` degrees of freedom divided by
        n) fades the memory, whatever the measurement type (compass or ZARU) and its R.
        False: Zhou's recursive innovation covariance (``rho``), which mixes the
        innovations of measurements with very different R (a compass difference
        followed by a ZARU update looks like a model failure).
    innovation_window : int
        Number of updates averaged in the normalised test.
    q_sd : tuple of 3 floats, optional
        Fix 5, per-parameter process noise: random-walk standard deviations of
        [a (deg/s/degC), b (deg), c' (deg/s, the drift at T_ref)] per update interval.
        A random-walk ``c'`` follows drift the linear model does not explain
        (curvature, hysteresis, bias instability) while a and b keep a long memory.
        None: ``KalmanConfig.q_sd``, shared with the other Kalman estimators (and no
        ``slope_q_per_rtc``). ``q_sd``, ``slope_q_per_rtc`` and the ZARU thresholds
        were tuned on the ``static`` Monte Carlo family alone (5 seeds, full length;
        see ``docs/results.md``) and frozen for the others.
    slope_q_per_rtc : float
        Fix 5: random walk of ``a`` *in temperature*, deg/s/degC per √degC: the
        variance ``slope_q_per_rtc² |ΔT|`` is added to that of ``a`` when the
        temperature moves by ΔT between updates. A curved drift(T) has a slope that
        changes with temperature, not with time: on a temperature plateau ``a`` keeps its
        memory (and through an outage on a ramp it is not made noisier by the length of
        the outage), while on a ramp it follows the local slope.
    quadratic : bool
        Fix 2, a higher-order temperature term (off by default): a fourth state ``a2``,
        the drift's curvature in temperature (deg/s/degC²), so the filter's drift is
        ``c' + a (T − T_ref) + a2 (T − T_ref)² + b T'``. Moving the reference by d
        (``recentre``) carries it into the others (``c' += a d + a2 d²``, ``a += 2 a2 d``),
        which is how it is learned. The parameters reported (``params``, the ``a, b, c``
        columns, eq. 2) are the linear model tangent at ``T_ref``, which the drift of the
        next interval uses. Not in the compiled engine: logs run on the reference engine.
    a2_sd : tuple of 2 floats
        Prior standard deviation of ``a2`` (deg/s/degC², also its cap) and its random
        walk per update interval.
    outage_memory : bool
        Fix 2, well-posed extrapolation: a twin of the filter without the slope random
        walk (long memory of a and b) runs on the same measurements. Through refused
        intervals (outages) the drift is extrapolated with the twin's a and b from the
        drift the tracking filter had at the last update: the short memory that
        follows the drift while aided is too noisy a slope to extrapolate a ramp with.
    """

    stacked: bool = False
    edge_s: float = 2.0
    recentre: bool = True
    zaru: bool = True
    zaru_hold: bool = True
    zaru_window_s: float = 60.0
    zaru_slope_k: float = 3.0
    zaru_resid_k: float = 3.0
    fading: bool = True
    lambda_max: float = 20.0
    rho: float = 0.8
    softening: float = 3.78
    innovation_window: int = 3
    normalised: bool = True
    q_sd: tuple[float, float, float] | None = (1e-4, 0.05, 5e-3)
    slope_q_per_rtc: float = 0.06
    outage_memory: bool = True
    quadratic: bool = False
    a2_sd: tuple[float, float] = (1e-3, 1e-5)

    def __post_init__(self):
        if not (math.isfinite(self.lambda_max) and self.lambda_max >= 1.0):
            raise ConfigError(f"lambda_max must be >= 1, got {self.lambda_max!r}")
        if not (0.0 < self.rho < 1.0):
            raise ConfigError(f"rho must be between 0 and 1, got {self.rho!r}")
        if not (math.isfinite(self.softening) and self.softening >= 1.0):
            raise ConfigError(f"softening must be >= 1, got {self.softening!r}")
        if not (isinstance(self.innovation_window, int) and self.innovation_window >= 1):
            raise ConfigError(f"innovation_window must be a whole number >= 1, got {self.innovation_window!r}")
        if not (isinstance(self.edge_s, (int, float)) and math.isfinite(self.edge_s) and self.edge_s >= 0):
            raise ConfigError(f"adaptive setting edge_s must be a number >= 0, got {self.edge_s!r}")
        for name in ("zaru_window_s", "zaru_slope_k", "zaru_resid_k"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ConfigError(f"adaptive setting {name} must be a positive number, got {v!r}")
        if self.q_sd is not None:
            try:
                ok = len(self.q_sd) == 3 and all(math.isfinite(float(e)) and float(e) >= 0 for e in self.q_sd)
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise ConfigError(f"adaptive q_sd must be three numbers >= 0 (a, b, c'), got {self.q_sd!r}")
        if not isinstance(self.quadratic, bool):
            raise ConfigError(f"adaptive setting quadratic must be true or false, got {self.quadratic!r}")
        try:
            ok = len(self.a2_sd) == 2 and float(self.a2_sd[0]) > 0 and float(self.a2_sd[1]) >= 0 and all(
                math.isfinite(float(e)) for e in self.a2_sd)
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise ConfigError(f"adaptive a2_sd must be a prior sd > 0 and a random walk >= 0, got {self.a2_sd!r}")

    #: The fixes that :meth:`ablated` switches off one at a time, by name.
    FIXES: ClassVar[tuple[str, ...]] = ("one_measurement", "edge_averaging", "recentre", "outage_memory", "zaru", "zaru_hold", "fading",
                                         "process_noise")

    def ablated(self, fix: str) -> "AdaptiveConfig":
        """These settings with one fix of :attr:`FIXES` switched off."""
        from dataclasses import replace

        off = {"one_measurement": {"stacked": True}, "edge_averaging": {"edge_s": 0.0}, "recentre": {"recentre": False}, "zaru": {"zaru": False},
               "zaru_hold": {"zaru_hold": False},
               "fading": {"fading": False}, "process_noise": {"q_sd": None, "slope_q_per_rtc": 0.0},
               "outage_memory": {"outage_memory": False}}
        if fix not in off:
            raise ConfigError(f"unknown fix {fix!r}; choose from: {', '.join(self.FIXES)}")
        return replace(self, **off[fix])


@register
class AdaptiveKalman(LinearDrift):
    """Centred-temperature Kalman filter with innovation-based fading (``adaptive``).

    Parameters
    ----------
    config : KalmanConfig
        Prior (``x0`` absolute [a, b, c], ``p0_sd`` of [a, b, c'], cap ``max_sd``) and
        process noise ``q_sd`` of [a, b, c'] per update interval, shared with the other
        Kalman estimators; ``fading`` is ignored (the fading factor is adaptive).
    settings : AdaptiveConfig
        The switches of this estimator (its own ``q_sd`` replaces ``config.q_sd``).
    lambda_max, rho : float, optional
        Override ``settings.lambda_max`` and ``settings.rho``.
    """

    name: ClassVar[str] = "adaptive"
    causal: ClassVar[bool] = True

    def __init__(self, config: KalmanConfig = KalmanConfig(), *, settings: AdaptiveConfig | None = None,
                 lambda_max: float | None = None, rho: float | None = None):
        from dataclasses import replace

        settings = settings if settings is not None else AdaptiveConfig()
        if not isinstance(settings, AdaptiveConfig):
            raise ConfigError(f"adaptive settings must be an AdaptiveConfig, got {type(settings).__name__}")
        overrides = {k: v for k, v in (("lambda_max", lambda_max), ("rho", rho)) if v is not None}
        settings = replace(settings, **overrides) if overrides else settings
        self.settings = settings
        self.config = config
        self.lambda_max = float(settings.lambda_max) if settings.fading else 1.0
        self.rho = float(settings.rho)
        self.temp_ref_c: float | None = None
        self._x_abs0 = np.array(config.x0, dtype=float)
        self._z = self._x_abs0.copy()  # [a, b, c'] once T_ref is known
        self._P, self._max_var, self._Q = config.matrices()
        if settings.q_sd is not None:
            self._Q = np.diag(np.square(np.array(settings.q_sd, dtype=float)))
        if settings.quadratic:  # a fourth state a2, after [a, b, c']
            prior_sd, walk_sd = (float(v) for v in settings.a2_sd)
            self._z = np.append(self._z, 0.0)
            self._P = _with_diagonal(self._P, prior_sd**2)
            self._Q = _with_diagonal(self._Q, walk_sd**2)
            self._max_var = np.append(self._max_var, prior_sd**2)
        self._V: np.ndarray | None = None
        self._last_temp_c: float | None = None
        self._last_h: tuple[float, float] | None = None
        #: Parameters in force through an outage (``outage_memory``), else None.
        self._anchor: np.ndarray | None = None
        #: The long-memory twin (``outage_memory``): same filter, no slope random walk.
        self._twin = None
        if settings.outage_memory and settings.slope_q_per_rtc > 0.0 and settings.q_sd is not None:
            self._twin = AdaptiveKalman(config, settings=replace(settings, slope_q_per_rtc=0.0, outage_memory=False))
        #: Normalised innovations squared of the last ``innovation_window`` updates.
        self._nis: deque[float] = deque(maxlen=settings.innovation_window)
        #: Fading factor of the last update (diagnostics).
        self.last_lambda = 1.0

    @property
    def params(self) -> np.ndarray:
        if self._anchor is not None:
            return self._anchor.copy()
        return self._own_params()

    def _own_params(self) -> np.ndarray:
        a, b, c_ref = self._z[:3]  # with ``quadratic``, the linear model tangent at T_ref
        t_ref = self.temp_ref_c or 0.0
        return np.array([a, b, c_ref - a * t_ref])

    @property
    def centred_cov(self) -> np.ndarray:
        """Covariance of the filter's own states [a, b, c'] (centred on ``temp_ref_c``): the
        matrix the cap (``KalmanConfig.max_sd``, default the prior) bounds; with
        ``quadratic`` it has a fourth row and column, for ``a2``."""
        return self._P.copy()

    @property
    def cov(self) -> np.ndarray:
        """Covariance of the absolute [a, b, c] (transformed from the centred states)."""
        J = np.eye(3)
        J[2, 0] = -(self.temp_ref_c or 0.0)
        return J @ self._P[:3, :3] @ J.T

    def _centre(self, obs: Observation) -> np.ndarray:
        if self.temp_ref_c is None:
            self.temp_ref_c = float(np.mean(obs.H[:, 0]))
            a, b, c = self._x_abs0
            self._z[:3] = a, b, c + a * self.temp_ref_c
        H = obs.H.copy()
        H[:, 0] -= self.temp_ref_c
        if self.settings.quadratic:  # the interval's mean (T - T_ref)², from its mean T
            H = np.column_stack([H, H[:, 0] ** 2])
        return H

    def _recentre(self, temp_c: float) -> None:
        """Move the reference temperature to ``temp_c`` (the drift model is unchanged)."""
        d = temp_c - self.temp_ref_c
        J = np.eye(self._z.size)
        J[2, 0] = d
        if self.settings.quadratic:
            J[2, 3] = d * d  # c' += a d + a2 d²
            J[0, 3] = 2.0 * d  # a += 2 a2 d
        self._z = J @ self._z
        self._P = J @ self._P @ J.T
        self.temp_ref_c = temp_c

    def update(self, obs: Observation) -> np.ndarray:
        temp_c = float(np.mean(obs.H[:, 0]))
        Q = self._Q
        if self._last_temp_c is not None and self.settings.slope_q_per_rtc > 0.0 and self.settings.q_sd is not None:
            Q = Q.copy()
            Q[0, 0] += self.settings.slope_q_per_rtc**2 * abs(temp_c - self._last_temp_c)
        self._last_temp_c = temp_c
        self._last_h = (temp_c, float(np.mean(obs.H[:, 1])))
        self._anchor = None
        if self._twin is not None:
            self._twin.update(obs)
        if self.settings.recentre and self.temp_ref_c is not None:
            self._recentre(temp_c)
        H = self._centre(obs)
        gamma = obs.y - H @ self._z
        M = H @ self._P @ H.T
        if self.settings.normalised:
            S = M + H @ Q @ H.T + obs.R
            self._nis.append(float(gamma @ np.linalg.solve(S, gamma)) / gamma.size)
            excess = sum(self._nis) / len(self._nis) - self.settings.softening
            lam = 1.0 + excess * float(np.trace(S) / np.trace(M)) if np.trace(M) > 0 else 1.0
        else:
            outer = np.outer(gamma, gamma)
            if self._V is None or self._V.shape != outer.shape:
                self._V = outer
            else:
                self._V = (self.rho * self._V + outer) / (1.0 + self.rho)
            N = self._V - H @ Q @ H.T - self.settings.softening * obs.R
            lam = float(np.trace(N) / np.trace(M)) if np.trace(M) > 0 else 1.0
        self.last_lambda = min(max(1.0, lam), self.lambda_max)
        P_prior = cap_covariance(predict(self._P, Q, self.last_lambda), self._max_var)
        self._z, P_post, _, _ = correct(self._z, P_prior, obs.y, H, obs.R)
        self._P = cap_covariance(P_post, self._max_var)
        return self.params

    def hold(self) -> np.ndarray:
        self._P = cap_covariance(predict(self._P, self._Q, 1.0), self._max_var)
        if self._twin is not None:
            self._twin.hold()
            if self._anchor is None and self._last_h is not None:
                # Extrapolate with the long memory's a and b from the drift last tracked.
                T0, Tp0 = self._last_h
                a, b, _ = self._twin.params
                drift0 = float(self._own_params() @ np.array([T0, Tp0, 1.0]))
                self._anchor = np.array([a, b, drift0 - a * T0 - b * Tp0])
        return self.params

    def engine_state(self) -> dict:
        """State and settings for the compiled engine (:mod:`gyrodrift._engine`): the whole
        filter (:mod:`gyrodrift._adaptive_kernels` mirrors :meth:`update` and :meth:`hold`),
        with the twin's under ``"twin"``. Not used with ``quadratic``, which
        :func:`gyrodrift._engine.supports` sends to the reference engine."""
        s = self.settings
        slope_q = s.slope_q_per_rtc if (s.slope_q_per_rtc > 0.0 and s.q_sd is not None) else 0.0
        return {"mode": "adaptive", "fading": 1.0, "lambda_max": self.lambda_max, "rho": self.rho, "centred": True,
                "softening": float(s.softening), "normalised": bool(s.normalised), "recentre": bool(s.recentre),
                "slope_q": float(slope_q), "innovation_window": int(s.innovation_window),
                "x": self._z, "P": self._P, "Q": self._Q, "max_var": self._max_var, "active": (0, 1, 2),
                "V": self._V, "temp_ref_c": self.temp_ref_c, "last_lambda": self.last_lambda,
                "last_temp_c": self._last_temp_c, "last_h": self._last_h, "anchor": self._anchor,
                "nis": list(self._nis), "twin": None if self._twin is None else self._twin.engine_state()}

    def set_engine_state(self, state: dict) -> None:
        """Take back the state the compiled engine ended with (keys of :meth:`engine_state`;
        absent ones are left as they are)."""
        self._z = np.array(state["x"], dtype=float)
        self._P = np.array(state["P"], dtype=float)
        if state.get("V") is not None:
            self._V = np.array(state["V"], dtype=float)
        if state.get("temp_ref_c") is not None:
            self.temp_ref_c = float(state["temp_ref_c"])
        if state.get("last_lambda") is not None:
            self.last_lambda = float(state["last_lambda"])
        if "last_temp_c" in state:
            self._last_temp_c = None if state["last_temp_c"] is None else float(state["last_temp_c"])
        if "last_h" in state:
            self._last_h = None if state["last_h"] is None else tuple(float(v) for v in state["last_h"])
        if "anchor" in state:
            self._anchor = None if state["anchor"] is None else np.array(state["anchor"], dtype=float)
        if "nis" in state:
            self._nis = deque((float(v) for v in state["nis"]), maxlen=self.settings.innovation_window)
        if state.get("twin") is not None and self._twin is not None:
            self._twin.set_engine_state(state["twin"])


def _with_diagonal(M: np.ndarray, value: float) -> np.ndarray:
    """``M`` bordered by one more row and column: zeros, and ``value`` on the diagonal."""
    n = M.shape[0]
    out = np.zeros((n + 1, n + 1))
    out[:n, :n] = M
    out[n, n] = value
    return out
