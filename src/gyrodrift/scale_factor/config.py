"""Settings of the adaptive scale-factor estimate: :class:`ScaleFactorConfig`."""

from __future__ import annotations

from dataclasses import dataclass, replace

from gyrodrift.settings import check, setting

__all__ = ["ScaleFactorConfig"]


@dataclass(frozen=True, kw_only=True)
class ScaleFactorConfig:
    """Settings of the adaptive scale-factor estimate; each one's meaning and default: ``docs/scale_factor.md``."""

    t_ref_c: float = setting(25.0, "degC", measured=True)
    fading: float = setting(1.25, ge=1.0)
    x0: tuple[float, float] = setting((1.0, 0.0), measured=True)
    p0_sd: tuple[float, float] = setting((0.05, 1.0e-3), gt=0.0)
    q_sd: tuple[float, float] = setting((1.0e-4, 2.0e-6), ge=0.0)
    turn_rate_dps: float = setting(5.0, "deg/s", gt=0.0)
    turn_window_s: float = setting(1.0, "s", gt=0.0)
    guard_s: float = setting(2.0, "s", gt=0.0)
    still_s: float = setting(5.0, "s", gt=0.0)
    min_turn_deg: float = setting(90.0, "deg", gt=0.0)
    max_sf_error: float = setting(0.2, gt=0.0)
    min_compass_samples: int = setting(5, ge=1)
    max_compass_gap_s: float = setting(1.0, "s", gt=0.0)
    compass_sigma_deg: float = setting(0.5, "deg", gt=0.0)
    gyro_noise_dps_rthz: float = setting(0.04, "deg/s/√Hz", gt=0.0)
    residual_drift_dps: float = setting(0.02, "deg/s", ge=0.0)
    fixed_turns: int = setting(3, ge=1)
    max_turn_s: float = setting(300.0, "s", gt=0.0)

    def __post_init__(self):
        check(self)

    def with_sensor(self, config) -> "ScaleFactorConfig":
        """These settings with the sensor noise of the compensator's ``config`` (a
        :class:`~gyrodrift.compensator.CompensatorConfig`): both estimates describe the same sensors."""
        return replace(self, compass_sigma_deg=config.compass_sigma_deg, gyro_noise_dps_rthz=config.gyro_noise_dps_rthz)
