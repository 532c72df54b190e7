"""Settings of the adaptive scale-factor estimate: :class:`ScaleFactorConfig`."""

from __future__ import annotations

from dataclasses import dataclass, replace

from gyrodrift.settings import check, setting

__all__ = ["ScaleFactorConfig"]


@dataclass(frozen=True, kw_only=True)
class ScaleFactorConfig:
    """Settings of the adaptive scale-factor estimate (see the package notes).

    Attributes
    ----------
    t_ref_c : float
        Reference temperature ``T_ref`` of ``SF = s0 + s1*(T - T_ref)``, degC.
    fading : float
        Fading factor s >= 1 of eq. (10), per accepted rotation; memory is about
        ``1/(1 - 1/s)`` rotations (default 1.25: about 5 rotations, 10 min at one
        turn every 2 min).
    x0 : tuple of 2 floats
        Prior ``[s0 (unitless), s1 (1/degC)]`` (default: the nominal SF 1, no
        temperature dependence).
    p0_sd : tuple of 2 floats
        Prior standard deviations of s0 and s1; ``P0 = diag(p0_sd²)``, also the cap
        of P. Default 5 % and 0.1 %/degC (±3.5 % over 35 degC; ADXRS623: ±3 % over
        temperature). A tighter s1 prior keeps the slope sane while the first
        rotations all happen at nearly one temperature.
    q_sd : tuple of 2 floats
        Process-noise standard deviations of s0 and s1 per accepted rotation.
    turn_rate_dps : float
        A row is rotating when the centred ``turn_window_s`` mean of ``rate_z``
        exceeds this in magnitude, deg/s.
    turn_window_s : float
        Averaging window of the rotation test, s.
    guard_s : float
        Gap between a rotation and its still windows, s.
    still_s : float
        Length of each still window, s.
    min_turn_deg : float
        Smallest compass heading change that counts as a measurement, deg.
    max_sf_error : float
        Largest accepted ``|y - 1|`` of a measurement (unitless).
    min_compass_samples : int
        Fewest compass samples in each still window.
    max_compass_gap_s : float
        Longest gap between compass samples inside a measurement span, s.
    compass_sigma_deg : float
        Compass heading noise standard deviation, deg. The same setting as
        ``CompensatorConfig.compass_sigma_deg``: ``compensate --scale-factor`` takes the
        compensator's (:meth:`with_sensor`).
    gyro_noise_dps_rthz : float
        Gyro white-noise density (angle random walk), deg/s/√Hz; the compensator's too.
    residual_drift_dps : float
        Typical drift left after the drift compensation, deg/s (enters R). Default
        0.02: the bias error of the drift compensator on the simulated heating run is
        mostly 0.002–0.03 deg/s, up to 0.05 early in the fast heating.
    fixed_turns : int
        Number of first accepted rotations averaged by the fixed (one-off) calibration.
    max_turn_s : float
        Causal pass and :class:`ScaleFactorTracker` only: a rotation whose rotating rows
        last longer than this (s) is dropped with reason ``long_turn`` instead of being
        buffered until it ends, which bounds the memory of the streaming estimate (see
        :attr:`ScaleFactorTracker.buffer_bound_s`). Default 300 s: a full turn at the
        5 deg/s threshold takes 72 s.
    """

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
        """These settings with the sensors' noise (``compass_sigma_deg``,
        ``gyro_noise_dps_rthz``) of the compensator's ``config`` (a
        :class:`~gyrodrift.compensator.CompensatorConfig`), so that the two estimates of one
        run describe the same sensors."""
        return replace(self, compass_sigma_deg=config.compass_sigma_deg, gyro_noise_dps_rthz=config.gyro_noise_dps_rthz)
