"""Every setting of the compensator (:class:`CompensatorConfig`) and the estimator it names."""

from __future__ import annotations

from dataclasses import dataclass, replace

from gyrodrift.estimators import ESTIMATORS, AdaptiveConfig, KalmanConfig, make_estimator
from gyrodrift.fusion import FusionConfig
from gyrodrift.gating import GateConfig
from gyrodrift.model import TempRateConfig, temperature_is_flat
from gyrodrift.settings import SettingError, check, setting, show

__all__ = ["CompensatorConfig", "build_estimator", "uses_clock", "clock_config", "TEMPERATURE_MODES"]

#: Values of :attr:`CompensatorConfig.temperature`.
TEMPERATURE_MODES = ("auto", "measured", "clock")
#: The compass deviation's span (deg of heading) and standard deviation (deg) where the model's
#: scale factor is held exact (:meth:`CompensatorConfig.without_scale_factor`): a quarter turn
#: renews it, as the model had it before its scale factor and deviation were states.
TURN_DEVIATION_SPAN_DEG, TURN_DEVIATION_SD_DEG = 90.0, 2.0


@dataclass(frozen=True, kw_only=True)
class CompensatorConfig:
    """All settings of the compensator (``docs/settings-and-profiles.md``, "The compensator's settings").

    Attributes
    ----------
    update_interval_s : float
        Δt between the paper's filter updates, s (paper: 10 s).
    init_s : float
        Length of the initialisation window at the start of the log, s.
    stack_depth : int
        Number of measurements stacked in y (eq. 3; paper: 3).
    compass_sigma_deg : float
        Standard deviation of the compass heading noise, deg.
    gyro_noise_dps_rthz : float
        Gyro white-noise density, deg/s/√Hz (ADXRS623: 0.04).
    estimator : str
        Name of the drift estimator (:mod:`gyrodrift.estimators`; default ``adaptive``).
    kalman : KalmanConfig
        Fading factor s, prior x0, P0 and Q of the Kalman estimators (and the prior of all).
    temp_rate : TempRateConfig
        How T' is computed (:mod:`gyrodrift.model`).
    gate : GateConfig
        Thresholds of the aiding gates (:mod:`gyrodrift.gating`).
    fusion : FusionConfig or None
        The fused heading of the paper's filters; None: :attr:`fusion_settings`.
    adaptive : AdaptiveConfig
        Settings of the ``adaptive`` estimator's model (``docs/model.md``).
    declination_deg : float or None
        Magnetic declination, deg east, added to every compass heading (0: magnetic north).
        None (default): the declination the log's autopilot used where its parameters have it
        (ArduPilot's ``COMPASS_DEC``, PX4's ``EKF2_MAG_DECL``; with a note), else 0
        (:func:`with_declination`).
    tilt : str
        The tilt of a raw compass: ``"accel"`` (default) or ``"gyro"`` (:mod:`gyrodrift.attitude`).
    heading_rate : str
        What the drift model integrates as the heading's rate: ``"auto"`` (default) the rate of
        the heading of a tilted body, from ``gyro_y``, ``gyro_z`` and the gyro-aided tilt, where
        the log has ``gyro_x``, ``gyro_y`` and the accelerometer, else ``gyro_z``;
        ``"gyro_z"`` always the z axis alone (a level body). ``docs/heading_and_axes.md``.
    mag_calibration : bool or "auto"
        Calibrate a raw magnetometer over the whole log first (:mod:`gyrodrift.magcal`; not
        causal): ``"auto"`` (default) where it looks uncalibrated
        (:func:`gyrodrift.magcal.looks_uncalibrated`) or where the fit makes its heading agree
        with the gyro's turns (:func:`gyrodrift.magcal.agrees_better`), True wherever the fit
        holds, False never. A
        stream, which does not see the whole log, does not calibrate.
    temperature : str
        What ``T`` of the drift model is: ``"auto"`` (default), ``"measured"`` or ``"clock"``.
    """

    update_interval_s: float = setting(10.0, "s", gt=0.0, flag="--update-interval-s",
                                       help="filter update interval")
    init_s: float = setting(30.0, "s", gt=0.0, flag="--init-s", help="initialisation window at the start")
    stack_depth: int = setting(3, ge=1, whole_max=1000, flag="--stack-depth", help="measurements stacked per update")
    compass_sigma_deg: float = setting(0.5, "deg", gt=0.0, flag="--compass-sigma-deg", help="compass noise")
    gyro_noise_dps_rthz: float = setting(0.04, "deg/s/√Hz", gt=0.0, least=1e-6)
    estimator: str = setting("adaptive", choices=lambda: tuple(sorted(ESTIMATORS)), flag="--estimator",
                             help="drift estimator")
    kalman: KalmanConfig = setting(factory=KalmanConfig)
    temp_rate: TempRateConfig = setting(factory=TempRateConfig)
    gate: GateConfig = setting(factory=GateConfig)
    fusion: FusionConfig | None = None
    adaptive: AdaptiveConfig = setting(factory=AdaptiveConfig)
    declination_deg: float | None = setting(None, "deg", ge=-180.0, le=180.0, flag="--declination",
                                            help="magnetic declination, east positive: added to the compass heading, "
                                            "so that compass_heading, heading and heading_fused are in true north "
                                            "like ref_heading (0: magnetic north; default: the autopilot's where "
                                            "the log's parameters have it, else 0)")
    tilt: str = setting("accel", choices=("gyro", "accel"))
    heading_rate: str = setting("auto", choices=("auto", "gyro_z"))
    mag_calibration: bool | str = setting("auto", choices=(True, False, "auto"))
    temperature: str = setting("auto", choices=TEMPERATURE_MODES, flag="--temperature",
                               help="what T of the drift model is: auto, the temperature column, or the "
                               "elapsed time when that never changes over the log; measured: always the column; "
                               "clock: always the elapsed time (a stream without temperature)")

    @property
    def fusion_settings(self) -> FusionConfig:
        """The fused-heading settings of the paper's filters: ``fusion`` when given, else
        :meth:`FusionConfig.tolerant`, which re-anchors on the compass after 60 s of refusals
        (the paper's filter refuses for good once its gate locks out). The default estimator
        fuses the heading in its own model and does not use them."""
        if self.fusion is not None:
            return self.fusion
        return FusionConfig.tolerant()

    def without_scale_factor(self) -> "CompensatorConfig":
        """These settings with the default model's scale factor held exact (its ``σ`` at 0): the
        drift stage of the paper's Sec. 4.3, after which :mod:`gyrodrift.scale_factor`
        estimates the whole scale factor from ``rate_z`` (``docs/scale_factor.md``). A turn's
        scale-factor error, which σ then no longer takes, shows in the compass's error through the
        turn; the compass's deviation is renewed within :data:`TURN_DEVIATION_SPAN_DEG` of heading
        (at :data:`TURN_DEVIATION_SD_DEG`) so that it takes it, not the drift."""
        return replace(self, adaptive=replace(self.adaptive, scale_factor_sd=0.0, scale_factor_walk=0.0,
                                              deviation_span_deg=TURN_DEVIATION_SPAN_DEG,
                                              compass_error_deg=TURN_DEVIATION_SD_DEG))

    def __post_init__(self):
        check(self)

    def _check_together(self):
        if self.init_s < self.stack_depth * 0.1:
            raise SettingError(f"init_s = {self.init_s!r} s is too short for {self.stack_depth} sub-windows")
        try:
            build_estimator(self)
        except TypeError:
            raise SettingError(f"estimator = {show(self.estimator)} cannot be built from settings alone; pass an "
                               "instance as compensate(..., estimator=...)") from None


def with_declination(cfg: CompensatorConfig, found: tuple[float, str] | None) -> CompensatorConfig:
    """``cfg`` with its declination decided: as given, or with ``declination_deg`` None the one
    ``found`` in the log (deg east and where from: :attr:`gyrodrift.onboard.Onboard.declination`),
    else 0."""
    if cfg.declination_deg is not None:
        return cfg
    return replace(cfg, declination_deg=found[0] if found is not None else 0.0)


def uses_clock(cfg: CompensatorConfig, temp_c=None) -> bool:
    """Whether the drift model's ``T`` is the elapsed time (``cfg.temperature``): ``temp_c``
    is the whole log's temperature column, degC, or whether it never changes (a bool; None:
    not known, as in streaming). ``"auto"`` keeps the temperature for a warm start (a
    profile's or a calibration's ``x0``, ``p0_sd`` or ``p0_cov``): its model gives the drift at
    a constant temperature too."""
    if cfg.temperature == "auto":
        flat = temp_c if temp_c is None or isinstance(temp_c, bool) else temperature_is_flat(temp_c)
        return bool(flat) and not _warm(cfg)
    return cfg.temperature == "clock"


def _warm(cfg: CompensatorConfig) -> bool:
    """Whether the drift model starts from a warm start (not the default prior): its own ``x0``,
    ``p0_sd`` (a calibration of zero drift is one too) or ``p0_cov``."""
    default = KalmanConfig()
    return cfg.kalman.x0 != default.x0 or cfg.kalman.p0_sd != default.p0_sd or cfg.kalman.p0_cov is not None


def clock_config(cfg: CompensatorConfig) -> CompensatorConfig:
    """The settings for a clock-regressor run: a warm start's ``a`` and ``b`` (per degC, from a
    profile) mean nothing per unit of time, so they start from 0; ``c`` (the profile's drift
    at 0 degC, which its note flags as an extrapolation) is kept, and all three get the
    default prior spread ``p0_sd``."""
    kal = cfg.kalman
    if not _warm(cfg):
        return cfg
    return replace(cfg, kalman=replace(kal, x0=(0.0, 0.0, kal.x0[2]), p0_cov=None))


def build_estimator(cfg: CompensatorConfig):
    """A fresh estimator of ``cfg.estimator`` with its settings (``adaptive`` gets ``cfg.adaptive``)."""
    if cfg.estimator == "adaptive":
        return make_estimator(cfg.estimator, config=cfg.kalman, settings=cfg.adaptive)
    return make_estimator(cfg.estimator, config=cfg.kalman)
