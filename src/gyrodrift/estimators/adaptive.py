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
prior, no fading in outages). The equations are in :mod:`gyrodrift.kernels.kalman`.

Every change beyond the paper is a switch of :class:`AdaptiveConfig` (for the
ablation); the compensator (:mod:`gyrodrift.compensator`) reads the switches that concern
its measurements: one measurement per interval, compass averaging at the interval edges
with an online compass-noise estimate, and zero-rate (stationarity, ZARU) measurements
(:mod:`gyrodrift.kernels.aiding`). Results and the ablation: ``docs/results.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.estimators.base import check_drift_triple, register
from gyrodrift.estimators.kalman import KalmanConfig, KernelFilter, filter_arrays
from gyrodrift.kernels import kalman as kernel
from gyrodrift.kernels import layout as L

__all__ = ["AdaptiveConfig", "AdaptiveKalman"]


@dataclass(frozen=True, kw_only=True)
class AdaptiveConfig:
    """Settings of the ``adaptive`` estimator, each change beyond the paper switchable.

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
        [a (deg/s/degC), b (deg/degC), c' (deg/s, the drift at T_ref)] per update interval.
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
    outage_memory : bool
        Fix 2, well-posed extrapolation: a twin of the filter without the slope random
        walk (long memory of a and b) runs on the same measurements. Through refused
        intervals (outages) the drift is extrapolated with the twin's a and b from the
        drift the tracking filter had at the last update: the short memory that
        follows the drift while aided is too noisy a slope to extrapolate a ramp with.
    quasi_static_s, quasi_static_deg : float
        Quasi-static windows (:func:`gyrodrift.kernels.aiding.quasi_static`): through
        ``quasi_static_s`` seconds of refused intervals (no compass, interference, ...), a
        compensated heading that stays within ``quasi_static_deg`` peak to peak about a
        straight line (a parked, moored or bench unit, swaying or not) gives its mean gyro
        rate as a drift measurement, with the sway as its uncertainty, when the drift in
        force agrees with it (a slow real turn does not). ``quasi_static_s`` = 0: off.
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
    quasi_static_s: float = 300.0
    quasi_static_deg: float = 10.0

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
        for name in ("quasi_static_s", "quasi_static_deg"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v >= 0):
                raise ConfigError(f"adaptive setting {name} must be a number >= 0, got {v!r}")
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
            check_drift_triple("adaptive q_sd", self.q_sd)

    #: The fixes that :meth:`ablated` switches off one at a time, by name.
    FIXES: ClassVar[tuple[str, ...]] = ("one_measurement", "edge_averaging", "recentre", "outage_memory", "zaru", "zaru_hold", "fading",
                                         "process_noise", "quasi_static")

    def ablated(self, fix: str) -> "AdaptiveConfig":
        """These settings with one fix of :attr:`FIXES` switched off."""
        off = {"one_measurement": {"stacked": True}, "edge_averaging": {"edge_s": 0.0}, "recentre": {"recentre": False}, "zaru": {"zaru": False},
               "zaru_hold": {"zaru_hold": False},
               "fading": {"fading": False}, "process_noise": {"q_sd": None, "slope_q_per_rtc": 0.0},
               "outage_memory": {"outage_memory": False}, "quasi_static": {"quasi_static_s": 0.0}}
        if fix not in off:
            raise ConfigError(f"unknown fix {fix!r}; choose from: {', '.join(self.FIXES)}")
        return replace(self, **off[fix])


@register
class AdaptiveKalman(KernelFilter):
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
    depth : int
        Largest number of measurements of one observation (the stacked ones of eq. 3, and
        the initialisation's).
    """

    name: ClassVar[str] = "adaptive"

    def __init__(self, config: KalmanConfig = KalmanConfig(), *, settings: AdaptiveConfig | None = None,
                 lambda_max: float | None = None, rho: float | None = None, depth: int = 3):
        settings = settings if settings is not None else AdaptiveConfig()
        if not isinstance(settings, AdaptiveConfig):
            raise ConfigError(f"adaptive settings must be an AdaptiveConfig, got {type(settings).__name__}")
        overrides = {k: v for k, v in (("lambda_max", lambda_max), ("rho", rho)) if v is not None}
        settings = replace(settings, **overrides) if overrides else settings
        self.settings = settings
        self.config = config
        P0, max_var, Q = config.matrices()
        if settings.q_sd is not None:
            Q = np.diag(np.square(np.array(settings.q_sd, dtype=float)))
        slope_walk = settings.slope_q_per_rtc > 0.0 and settings.q_sd is not None
        super().__init__(*filter_arrays(
            adaptive=True, x0=config.x0, P0=P0, Q=Q, max_var=max_var, depth=depth,
            nis_window=settings.innovation_window, twin=settings.outage_memory and slope_walk,
            normalised=settings.normalised, recentre=settings.recentre, softening=settings.softening,
            lambda_max=float(settings.lambda_max) if settings.fading else 1.0, rho=settings.rho,
            slope_q=settings.slope_q_per_rtc if slope_walk else 0.0,
        ))

    @property
    def temp_ref_c(self) -> float | None:
        """The reference temperature T_ref (degC) of the centred states; None before the
        first observation."""
        z, P, Q, max_var, af, V, nis, ai = kernel.views(*self.kernel_arrays)
        return float(af[L.MAIN, L.AF_TREF]) if ai[L.MAIN, L.AI_TREF_SET] else None

    @property
    def last_lambda(self) -> float:
        """Fading factor λ of the last update (diagnostics)."""
        z, P, Q, max_var, af, V, nis, ai = kernel.views(*self.kernel_arrays)
        return float(af[L.MAIN, L.AF_LAMBDA])

    @property
    def centred_cov(self) -> np.ndarray:
        """Covariance of the filter's own states [a, b, c'] (centred on :attr:`temp_ref_c`):
        the matrix the cap (``KalmanConfig.max_sd``, default the prior) bounds."""
        z, P, Q, max_var, af, V, nis, ai = kernel.views(*self.kernel_arrays)
        return P[L.MAIN].copy()
