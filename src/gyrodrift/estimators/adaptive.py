"""The default estimator: the settings (:class:`AdaptiveConfig`) and the state
(:class:`AdaptiveModel`) of the model of :mod:`gyrodrift.kernels.evidence`, which
``docs/model.md`` describes with every setting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.estimators.base import LinearDrift, Observation, register
from gyrodrift.estimators.kalman import KalmanConfig
from gyrodrift.kernels import evidence as ev
from gyrodrift.settings import SettingError, check, setting, show

__all__ = ["AdaptiveConfig", "AdaptiveModel"]

#: The scale-factor error σ is held within this many of its prior standard deviations (a MEMS
#: gyro's sensitivity is within its datasheet's tolerance; docs/model.md, "The gyro's scale factor").
SF_MAX_SDS = 3.0


@dataclass(frozen=True, kw_only=True)
class AdaptiveConfig:
    """Settings of the default estimator's model (``docs/model.md``, "Settings").

    Attributes
    ----------
    epoch_s : float
        Length of an epoch, the model's step, s.
    clean_s, disturbed_s : float
        Mean length of a clean-compass spell and of a magnetic disturbance, s.
    still_s, moving_s : float
        Mean length of a still and of a moving spell of the platform, s.
    slope_walk : float
        Random walk of a per √degC of temperature change, deg/s/degC/√degC.
    curvature_sd : float
        Prior standard deviation of the drift's curvature in temperature (the a2 of
        ``a2 (T - T_ref)²``), deg/s/degC².
    rate_walk : float
        Random walk of b per √s, deg/s/(degC/s)/√s.
    drift_walk : float
        Random walk of the drift c' in time, deg/s/√s (bias instability).
    drift_walk_temp : float
        Random walk of c' per √degC of temperature change, deg/s/√degC.
    drift_rate_dps2, drift_rate_s : float
        Standard deviation (deg/s²) and correlation time (s) of the drift's departure rate r.
    drift_rate_degc : float
        Temperature change over which r renews, degC: r departs as the temperature moves
        (on the clock, with time over ``drift_rate_s``).
    drift_rate_time_dps2 : float
        Standard deviation of the part of r that renews with time at a steady temperature, deg/s².
    drift_jump_dps, drift_jump_s : float
        Standard deviation of a drift jump (deg/s; 0, the default: off) and mean time between jumps (s).
    compass_error_deg, compass_error_s : float
        Standard deviation (deg) and correlation time (s) of the compass's slow error d.
    disturbance_step_deg, disturbance_walk, disturbance_s : float
        A disturbance's step (deg, standard deviation), random walk (deg/√s; a wandering
        disturbance) and decay time (s).
    steady_walk : float
        Random walk of a steady disturbance, deg/√s (docs/model.md, "Hypotheses").
    scale_factor_sd, scale_factor_walk : float
        The gyro's scale-factor error σ, a share of the angle turned: its prior standard deviation
        and its random walk per √degC of temperature change (docs/model.md, "The gyro's scale factor").
    turn_error_s : float
        Compass error while turning per deg/s of turn rate, s.
    deviation_span_deg : float
        Heading change over which the compass's deviation decorrelates beyond its first
        harmonic, which turns with the heading (docs/model.md, "The compass's deviation"), deg.
    disturbance_span_deg : float
        Heading change over which a wandering disturbance decorrelates, deg.
    turn_walks : tuple of 4 floats
        Random walks of the true rate under the motion models, slow to agile, deg/s/√s.
    turn_shares : tuple of 4 floats
        Prior shares of the motion models in a moving epoch (sum below 1; the rest is any rate).
    rate_any_dps : float
        Standard deviation of a rate no motion model predicts, and of a moving platform's rate at
        the start, deg/s.
    motion_memory_s : float
        Mean time a motion keeps its character (which motion model explains it, and whether its
        gyro is smooth), s; 0 (the default) judges every epoch afresh, which charges a long smooth
        motion every epoch and so takes a white gyro for rest unless the compass insists. Above 0
        the motion models predict the gyro's own rate (docs/model.md, "Motion"): for a platform
        that turns smoothly and slowly for long (a turntable, a motor-driven mount), at the cost
        of taking a still unit's drifting compass for a slow turn (docs/results.md, "Where slow
        turns end and compass ramps begin").
    angular_accel_dps2 : float
        Angular acceleration of a platform at any rate (no motion model), deg/s²: the trapezoid
        integral's error between its samples.
    gap_turn_dps : float
        Rate at which a moving platform's heading is lost across a time gap, deg/s.
    still_walk : float
        Heading random walk of a still platform, deg/√s.
    gap_factor : float
        A time step longer than this many mean steps (the log's own spacing over about the
        last minute: ``kernels.evloop.SPACING_MEMORY_S``) is a time gap.
    field_norm_sd, field_dip_deg : float
        Prior scatter of a clean raw field's strength (fraction of the reference) and dip (deg),
        worth a few epochs; the log's own is then measured (docs/model.md, "Field").
    noise_memory_s : float
        Memory of the measured gyro and compass white noise, s.
    p_clean0, p_still0 : float
        Probabilities of a clean compass and of a still platform at the start.
    heading_sd0 : float
        Standard deviation of the heading before any compass sample, deg.
    """

    epoch_s: float = setting(1.0, "s", gt=0.0)
    clean_s: float = setting(3600.0, "s", gt=0.0)
    disturbed_s: float = setting(300.0, "s", gt=0.0)
    still_s: float = setting(300.0, "s", gt=0.0)
    moving_s: float = setting(300.0, "s", gt=0.0)
    slope_walk: float = setting(0.003, "deg/s/degC per √degC", ge=0.0, most=1.0)
    curvature_sd: float = setting(1e-3, "deg/s/degC²", ge=0.0, most=1.0)
    rate_walk: float = setting(0.01, "deg/degC per √s", ge=0.0, most=1000.0)
    drift_walk: float = setting(2e-4, "deg/s per √s", ge=0.0, most=50.0)
    drift_walk_temp: float = setting(0.02, "deg/s per √degC", ge=0.0, most=50.0)
    drift_rate_dps2: float = setting(0.00015, "deg/s²", ge=0.0, most=50.0)
    drift_rate_s: float = setting(300.0, "s", gt=0.0)
    drift_rate_degc: float = setting(10.0, "degC", gt=0.0)
    drift_rate_time_dps2: float = setting(5e-5, "deg/s²", ge=0.0, most=50.0)
    drift_jump_dps: float = setting(0.0, "deg/s", ge=0.0, most=50.0)
    drift_jump_s: float = setting(600.0, "s", gt=0.0)
    compass_error_deg: float = setting(1.5, "deg", ge=0.0, most=360.0)
    compass_error_s: float = setting(3600.0, "s", gt=0.0)
    disturbance_step_deg: float = setting(30.0, "deg", gt=0.0, most=360.0)
    disturbance_walk: float = setting(1.0, "deg per √s", ge=0.0, most=360.0)
    steady_walk: float = setting(0.1, "deg per √s", ge=0.0, most=360.0)
    scale_factor_sd: float = setting(0.01, ge=0.0, most=0.5)
    scale_factor_walk: float = setting(5e-4, "per √degC", ge=0.0, most=0.5)
    disturbance_s: float = setting(1800.0, "s", gt=0.0)
    turn_error_s: float = setting(0.5, "s", ge=0.0)
    deviation_span_deg: float = setting(720.0, "deg", gt=0.0)
    disturbance_span_deg: float = setting(90.0, "deg", gt=0.0)
    turn_walks: tuple[float, ...] = setting((0.003, 0.03, 0.3, 3.0), "deg/s per √s", gt=0.0, size=ev.N_RATE)
    turn_shares: tuple[float, ...] = setting((0.3, 0.3, 0.2, 0.15), gt=0.0, size=ev.N_RATE)
    rate_any_dps: float = setting(100.0, "deg/s", ge=0.0, most=10000.0)  # gyro full scales: a few 1,000 deg/s
    motion_memory_s: float = setting(0.0, "s", ge=0.0, most=3600.0)
    angular_accel_dps2: float = setting(10.0, "deg/s²", ge=0.0)
    gap_turn_dps: float = setting(1.0, "deg/s", ge=0.0)
    still_walk: float = setting(0.001, "deg per √s", ge=0.0, most=360.0)
    gap_factor: float = setting(20.0, gt=0.0)
    field_norm_sd: float = setting(0.03, gt=0.0)
    field_dip_deg: float = setting(2.0, "deg", gt=0.0)
    noise_memory_s: float = setting(600.0, "s", gt=0.0)
    p_clean0: float = setting(0.9, gt=0.0, lt=1.0)
    p_still0: float = setting(0.5, gt=0.0, lt=1.0)
    heading_sd0: float = setting(100.0, "deg", gt=0.0, most=360.0)

    def __post_init__(self):
        check(self)

    def _check_together(self):
        if not sum(self.turn_shares) < 1.0:
            raise SettingError(f"turn_shares = {show(self.turn_shares)} must sum below 1 (the rest is any rate)")

    def settings_array(self, compass_sd_deg: float, gyro_noise_dps_rthz: float) -> np.ndarray:
        """The kernel's settings ``mc`` (:mod:`gyrodrift.kernels.evidence`)."""
        mc = np.zeros(ev.N_MC)
        mc[ev.MC_EPOCH] = self.epoch_s
        mc[ev.MC_TAU_CLEAN], mc[ev.MC_TAU_DIST] = self.clean_s, self.disturbed_s
        mc[ev.MC_TAU_STILL], mc[ev.MC_TAU_MOVE] = self.still_s, self.moving_s
        mc[ev.MC_Q_A], mc[ev.MC_Q_B] = self.slope_walk, self.rate_walk
        mc[ev.MC_Q_C], mc[ev.MC_Q_CT] = self.drift_walk, self.drift_walk_temp
        mc[ev.MC_SIG_D], mc[ev.MC_TAU_D] = self.compass_error_deg, self.compass_error_s
        mc[ev.MC_K_TURN] = self.turn_error_s
        mc[ev.MC_L_DEV] = self.deviation_span_deg
        mc[ev.MC_L_DIST] = self.disturbance_span_deg
        mc[ev.MC_SIG_R], mc[ev.MC_TAU_R] = self.drift_rate_dps2, self.drift_rate_s
        mc[ev.MC_T_R], mc[ev.MC_SIG_RT] = self.drift_rate_degc, self.drift_rate_time_dps2
        mc[ev.MC_MOTION_MEMORY] = self.motion_memory_s
        mc[ev.MC_SIG_JUMP], mc[ev.MC_TAU_JUMP] = self.drift_jump_dps, self.drift_jump_s
        mc[ev.MC_SIG_STEP], mc[ev.MC_Q_E] = self.disturbance_step_deg, self.disturbance_walk
        mc[ev.MC_TAU_E] = self.disturbance_s
        mc[ev.MC_Q_E_STEADY] = self.steady_walk
        mc[ev.MC_SF_WALK] = self.scale_factor_walk
        mc[ev.MC_SF_MAX] = SF_MAX_SDS * self.scale_factor_sd
        mc[ev.MC_Q_W:ev.MC_Q_W + ev.N_RATE] = self.turn_walks
        mc[ev.MC_SHARE:ev.MC_SHARE + ev.N_RATE] = self.turn_shares
        mc[ev.MC_SIG_ACC], mc[ev.MC_OMEGA_GAP] = self.angular_accel_dps2, self.gap_turn_dps
        mc[ev.MC_Q_STILL] = self.still_walk
        mc[ev.MC_GAP_FACTOR] = self.gap_factor
        mc[ev.MC_COMPASS_SD] = compass_sd_deg
        mc[ev.MC_GYRO_NOISE] = gyro_noise_dps_rthz
        mc[ev.MC_SIG_NORM], mc[ev.MC_SIG_DIP] = self.field_norm_sd, self.field_dip_deg
        mc[ev.MC_NOISE_MEMORY] = self.noise_memory_s
        mc[ev.MC_P_CLEAN0], mc[ev.MC_P_STILL0] = self.p_clean0, self.p_still0
        mc[ev.MC_DELTA_SD0] = self.heading_sd0
        mc[ev.MC_RATE_ANY] = self.rate_any_dps
        return mc


@register
class AdaptiveModel(LinearDrift):
    """The default estimator (``adaptive``): the arrays and prior of the model that
    :class:`gyrodrift.compensator.model_engine.ModelEngine` runs row by row, and the paper's
    absolute ``[a, b, c]`` (:attr:`params`) and covariance (:attr:`cov`).

    Parameters
    ----------
    config : KalmanConfig
        The prior of [a, b, c] (``x0``, ``p0_sd`` or ``p0_cov``), shared with the other
        Kalman estimators (a profile's or a calibration's warm start sets it).
    settings : AdaptiveConfig
    """

    name: ClassVar[str] = "adaptive"
    causal: ClassVar[bool] = True

    def __init__(self, config: KalmanConfig = KalmanConfig(), *, settings: AdaptiveConfig | None = None, **_):
        settings = settings if settings is not None else AdaptiveConfig()
        if not isinstance(settings, AdaptiveConfig):
            raise ConfigError(f"adaptive settings must be an AdaptiveConfig, got {type(settings).__name__}")
        self.config = config
        self.settings = settings
        self.mf = np.zeros(ev.N_MF)
        self._started = False
        P0, _, _ = config.matrices()
        self._x0 = np.array(config.x0, dtype=float)
        self._P0 = P0

    def start(self, t_ref_c: float, compass_sd_deg: float, gyro_noise_dps_rthz: float, clock: bool = False) -> np.ndarray:
        """The model's arrays at the first row (temperature ``t_ref_c``; ``clock``: the drift
        model's T is the elapsed time): returns ``mc``."""
        mc = self.settings.settings_array(compass_sd_deg, gyro_noise_dps_rthz)
        mc[ev.MC_CLOCK] = float(clock)
        J = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [t_ref_c, 0.0, 1.0]])  # [a, b, c] -> [a, b, c']
        x0 = np.zeros(ev.NX)
        x0[ev.X_A:ev.X_C + 1] = J @ self._x0
        P0 = np.zeros((ev.NX, ev.NX))
        P0[ev.X_A:ev.X_C + 1, ev.X_A:ev.X_C + 1] = J @ self._P0 @ J.T
        P0[ev.X_DELTA, ev.X_DELTA] = self.settings.heading_sd0 ** 2
        P0[ev.X_D, ev.X_D] = P0[ev.X_DQ, ev.X_DQ] = self.settings.compass_error_deg ** 2
        P0[ev.X_R, ev.X_R] = self.settings.drift_rate_dps2 ** 2
        P0[ev.X_A2, ev.X_A2] = self.settings.curvature_sd ** 2
        P0[ev.X_S, ev.X_S] = self.settings.scale_factor_sd ** 2
        P0[ev.X_W, ev.X_W] = self.settings.rate_any_dps ** 2  # a moving platform's rate at the start: any rate

        ev.init_state(self.mf, mc, x0, P0, float(t_ref_c))
        self.mf[ev.MF_SIG_S2] = math.nan  # set from the first time step (kernels.evidence.seed_noise)
        self.mf[ev.MF_NORM_REF] = self.mf[ev.MF_DIP_REF] = math.nan
        self.mf[ev.MF_H_S] = math.nan
        self.mf[ev.MF_LAST_D] = math.nan
        self._started = True
        return mc

    @property
    def params(self) -> np.ndarray:
        """The paper's absolute [a, b, c] (deg/s/degC, deg/s per degC/s, deg/s) in force: the
        drift's tangent at ``T_ref`` (the model's curvature a2 is its own, :attr:`curvature`)."""
        if not self._started:
            return self._x0.copy()
        x = self.mf[ev.MF_XC:ev.MF_XC + ev.NX]
        return np.array([x[ev.X_A], x[ev.X_B], x[ev.X_C] - x[ev.X_A] * self.mf[ev.MF_TREF]])

    @property
    def curvature(self) -> float:
        """The drift's curvature in temperature a2 (deg/s/degC²; 0 before the first row)."""
        return float(self.mf[ev.MF_XC + ev.X_A2]) if self._started else 0.0

    @property
    def centred_cov(self) -> np.ndarray:
        """Covariance of the model's own drift states [a, b, c'] (c' the drift at ``T_ref``, the
        first sample's temperature; before it, the prior's covariance)."""
        if not self._started:
            return self._P0.copy()
        return self.mf[ev.MF_PC:ev.MF_PC + ev.NX * ev.NX].reshape(ev.NX, ev.NX)[ev.X_A:ev.X_C + 1, ev.X_A:ev.X_C + 1].copy()

    @property
    def cov(self) -> np.ndarray:
        """Covariance of the absolute [a, b, c]."""
        if not self._started:
            return self._P0.copy()
        P = self.mf[ev.MF_PC:ev.MF_PC + ev.NX * ev.NX].reshape(ev.NX, ev.NX)[ev.X_A:ev.X_C + 1, ev.X_A:ev.X_C + 1]
        Jinv = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-self.mf[ev.MF_TREF], 0.0, 1.0]])
        return Jinv @ P @ Jinv.T

    def update(self, obs: Observation) -> np.ndarray:
        raise ConfigError("the adaptive model is run by the engine row by row, not by interval measurements")

    def hold(self) -> np.ndarray:
        return self.params
