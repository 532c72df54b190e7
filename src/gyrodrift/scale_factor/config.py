"""Settings of the adaptive scale-factor estimate: :class:`ScaleFactorConfig`."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyrodrift.errors import ConfigError

__all__ = ["ScaleFactorConfig"]


def _pair(name: str, value, *, positive: bool = False, nonneg: bool = False) -> tuple[float, float]:
    try:
        out = tuple(float(v) for v in value)
        ok = len(out) == 2 and all(math.isfinite(v) for v in out)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ConfigError(f"ScaleFactorConfig.{name} must be two finite numbers (s0, s1), got {value!r}")
    if positive and not all(v > 0 for v in out):
        raise ConfigError(f"ScaleFactorConfig.{name} must be positive, got {value!r}")
    if nonneg and not all(v >= 0 for v in out):
        raise ConfigError(f"ScaleFactorConfig.{name} must be >= 0, got {value!r}")
    return out


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
        Compass heading noise standard deviation, deg.
    gyro_noise_dps_rthz : float
        Gyro white-noise density (angle random walk), deg/s/√Hz.
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

    t_ref_c: float = 25.0
    fading: float = 1.25
    x0: tuple[float, float] = (1.0, 0.0)
    p0_sd: tuple[float, float] = (0.05, 1.0e-3)
    q_sd: tuple[float, float] = (1.0e-4, 2.0e-6)
    turn_rate_dps: float = 5.0
    turn_window_s: float = 1.0
    guard_s: float = 2.0
    still_s: float = 5.0
    min_turn_deg: float = 90.0
    max_sf_error: float = 0.2
    min_compass_samples: int = 5
    max_compass_gap_s: float = 1.0
    compass_sigma_deg: float = 0.5
    gyro_noise_dps_rthz: float = 0.04
    residual_drift_dps: float = 0.02
    fixed_turns: int = 3
    max_turn_s: float = 300.0

    def __post_init__(self):
        def number(name):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ConfigError(f"ScaleFactorConfig.{name} must be a finite number, got {v!r}")
            return float(v)

        number("t_ref_c")
        if number("fading") < 1.0:
            raise ConfigError(f"ScaleFactorConfig.fading must be >= 1, got {self.fading!r}")
        for name in (
            "turn_rate_dps", "turn_window_s", "guard_s", "still_s", "min_turn_deg", "max_sf_error",
            "max_compass_gap_s", "compass_sigma_deg", "gyro_noise_dps_rthz", "max_turn_s",
        ):
            if number(name) <= 0:
                raise ConfigError(f"ScaleFactorConfig.{name} must be > 0, got {getattr(self, name)!r}")
        if number("residual_drift_dps") < 0:
            raise ConfigError(f"ScaleFactorConfig.residual_drift_dps must be >= 0, got {self.residual_drift_dps!r}")
        for name in ("min_compass_samples", "fixed_turns"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ConfigError(f"ScaleFactorConfig.{name} must be a whole number >= 1, got {v!r}")
        object.__setattr__(self, "x0", _pair("x0", self.x0))
        object.__setattr__(self, "p0_sd", _pair("p0_sd", self.p0_sd, positive=True))
        object.__setattr__(self, "q_sd", _pair("q_sd", self.q_sd, nonneg=True))
