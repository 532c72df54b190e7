"""True motion of a simulated run: :class:`Motion`, the temperature profiles and the ramps.

A scenario describes what happens to the unit, and how the run is logged, as a
:class:`Motion`; the pieces it is made of (raised-cosine ramps, rotations, sways,
temperature knots) are here. What each models: ``docs/simulator.md`` (motion and temperature).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gyrodrift.errors import ConfigError

__all__ = [
    "Motion", "COMPASS_FORMS", "hold_s", "smooth_step", "smooth_step_slope", "smooth_pulse", "ramp_slice",
    "sum_of_steps", "sum_of_step_slopes", "add_rotation", "true_heading", "still_motion", "fade_in", "sway_rate",
    "draw_wave", "wave", "in_records", "knot_profile", "approach_temperature", "static_temperature",
    "vehicle_temperature", "calibration_temperature", "hysteresis_temperature", "cold_start_temperature",
    "soak_temperature", "soak_ramps",
]

#: Longest time the unit stands still at constant temperature at the start, s.
_HOLD_S = 60.0

#: Values of :attr:`Motion.compass_form`.
COMPASS_FORMS = ("heading", "raw", "none")


def smooth_step(x):
    """Raised-cosine step ``0.5 - 0.5*cos(pi*clip(x, 0, 1))``: exactly 0 for x <= 0 and 1 for x >= 1, C1."""
    x = np.clip(x, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * x)


def smooth_step_slope(x):
    """Derivative of :func:`smooth_step` with respect to x; exactly 0.0 outside ``0 < x < 1``."""
    inside = (x > 0.0) & (x < 1.0)
    return np.where(inside, 0.5 * np.pi * np.sin(np.pi * np.clip(x, 0.0, 1.0)), 0.0)


def smooth_pulse(t, t0: float, t1: float, ramp: float):
    """1 from ``t0 + ramp`` to ``t1 - ramp``, 0 outside ``[t0, t1]``, raised-cosine edges of ``ramp``."""
    return smooth_step((t - t0) / ramp) - smooth_step((t - (t1 - ramp)) / ramp)


def ramp_slice(t_s: np.ndarray, start_s: float, end_s: float) -> slice:
    """The samples (``t_s`` increasing) of a ramp or pulse from ``start_s`` to ``end_s``, s.

    The margin of ``1e-6 * (1 + |start_s| + |end_s|)``, far above rounding, leaves a
    :func:`smooth_step` ramp exactly at its start value before the slice and at its end value after it.
    """
    pad = 1e-6 * (1.0 + abs(start_s) + abs(end_s))
    lo = int(np.searchsorted(t_s, start_s - pad, side="left"))
    hi = int(np.searchsorted(t_s, end_s + pad, side="right"))
    return slice(lo, max(lo, hi))


def sum_of_steps(t_s: np.ndarray, steps) -> np.ndarray:
    """Sum of raised-cosine steps ``(t0_s, dur_s > 0, delta)`` at the times ``t_s`` (increasing).

    Bit for bit the sum of ``delta * smooth_step((t_s - t0) / dur)`` over the whole run,
    step by step, at a cost linear in ``len(t_s)`` plus the ramps' samples.
    """
    out = np.zeros(t_s.size)
    level = 0.0  # sum of the deltas of the steps added so far: the value past all their ramps
    done = 0  # out[:done] holds the partial sums; every later sample is past all ramps so far
    for t0, dur, delta in steps:
        ramp = ramp_slice(t_s, t0, t0 + dur)
        lo, hi = ramp.start, ramp.stop
        if done < hi:
            out[done:hi] = level
        out[lo:hi] += delta * smooth_step((t_s[lo:hi] - t0) / dur)
        out[hi:done] += delta  # samples past this ramp that an earlier, longer ramp reached
        level = level + delta
        done = max(done, hi)
    out[done:] = level
    return out


def sum_of_step_slopes(t_s: np.ndarray, steps) -> np.ndarray:
    """Time derivative of :func:`sum_of_steps`, each step's slope evaluated on its ramp only."""
    out = np.zeros(t_s.size)
    for t0, dur, delta in steps:
        ramp = ramp_slice(t_s, t0, t0 + dur)
        out[ramp] += delta * smooth_step_slope((t_s[ramp] - t0) / dur) / dur
    return out


def add_rotation(rate: np.ndarray, t_s: np.ndarray, t0: float, angle_deg: float, peak_dps: float,
                 ramp_s: float) -> float:
    """Add to ``rate`` (deg/s, at ``t_s``) one level rotation by ``angle_deg``; return its end, s.

    Raised-cosine ramps of ``ramp_s`` and a plateau at ``peak_dps``: it lasts
    ``|angle_deg|/peak_dps + ramp_s`` and turns by exactly ``angle_deg``. Only the
    rotation's own samples are touched.
    """
    dur = abs(angle_deg) / peak_dps + ramp_s
    sl = ramp_slice(t_s, t0, t0 + dur)
    rate[sl] += math.copysign(peak_dps, angle_deg) * smooth_pulse(t_s[sl], t0, t0 + dur, ramp_s)
    return t0 + dur


@dataclass(frozen=True, kw_only=True, eq=False)
class Motion:
    """True motion and environment of one scenario at the log times, and how it is logged.

    The attributes (units in their names): ``docs/simulator.md`` (motion and temperature).
    """

    temp_c: np.ndarray
    temp_rate_cps: np.ndarray
    heading_rate_dps: np.ndarray
    heading0_deg: float
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    accel_fwd_mps2: np.ndarray | None = None
    accel_lat_mps2: np.ndarray | None = None
    accel_down_mps2: np.ndarray | None = None
    interference: tuple[tuple[float, float, float], ...] = field(default=())
    interference_offset_deg: np.ndarray | None = None
    compass_dropouts: tuple[tuple[float, float], ...] = field(default=())
    records: tuple[tuple[float, float], ...] = field(default=())
    temp_channel_c: float | None = None
    compass_form: str = "heading"

    def __post_init__(self):
        if self.compass_form not in COMPASS_FORMS:
            raise ConfigError(
                f"Motion.compass_form must be one of {', '.join(COMPASS_FORMS)}, got {self.compass_form!r}"
            )
        for i, rec in enumerate(self.records):
            if len(rec) != 2 or not (math.isfinite(rec[0]) and math.isfinite(rec[1]) and rec[1] > 0):
                raise ConfigError(f"Motion.records[{i}] must be (start_s, duration_s > 0), got {rec!r}")
        if self.temp_channel_c is not None and not math.isfinite(self.temp_channel_c):
            raise ConfigError(f"Motion.temp_channel_c must be a finite number or None, got {self.temp_channel_c!r}")


def true_heading(t_s: np.ndarray, heading_rate_dps: np.ndarray, heading0_deg: float) -> np.ndarray:
    """The true heading, deg: ``heading0_deg`` plus the trapezoid integral of the rate at the times ``t_s``."""
    from scipy.integrate import cumulative_trapezoid  # here, not at the top: scipy costs 0.4 s at start-up

    return heading0_deg + cumulative_trapezoid(heading_rate_dps, t_s, initial=0.0)


def still_motion(t_s, temp_c, temp_rate_cps, heading0_deg: float, roll_deg: float = 0.0, pitch_deg: float = 0.0,
                 **extra) -> Motion:
    """A :class:`Motion` without kinematic acceleration, still unless ``extra`` gives a heading rate."""
    zero = np.zeros(np.shape(t_s))
    extra.setdefault("heading_rate_dps", zero)
    return Motion(temp_c=temp_c, temp_rate_cps=temp_rate_cps, heading0_deg=heading0_deg, roll_deg=roll_deg,
                  pitch_deg=pitch_deg, accel_fwd_mps2=zero, accel_lat_mps2=zero, **extra)


def in_records(t_s: np.ndarray, records) -> np.ndarray:
    """Rows (times ``t_s``, increasing) with ``start_s <= t < start_s + duration_s`` of some record."""
    keep = np.zeros(t_s.size, dtype=bool)
    for start, dur in records:
        lo, hi = np.searchsorted(t_s, [start, start + dur], side="left")
        keep[lo:hi] = True
    return keep


def hold_s(duration_s: float) -> float:
    """Length of the still, constant-temperature start of a run, s: 60 s, or 10 % of a short run."""
    return min(_HOLD_S, 0.1 * duration_s)


def fade_in(t: np.ndarray, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Envelope (0 → 1 after the hold, over ``min(120 s, 10 %)``) and its time derivative, 1/s."""
    hold = hold_s(duration_s)
    fade = min(120.0, 0.1 * duration_s)
    return smooth_step((t - hold) / fade), smooth_step_slope((t - hold) / fade) / fade


def sway_rate(t: np.ndarray, duration_s: float, components, gain: float = 1.0) -> np.ndarray:
    """Heading rate of a yaw sway faded in after the hold, deg/s.

    The sway is ``gain * amp * (sin(omega (t - hold) + phase) - sin(phase))`` summed over
    ``components`` (``(amp deg, omega rad/s, phase rad)`` each), times :func:`fade_in`'s envelope.
    """
    hold = hold_s(duration_s)
    env, env_rate = fade_in(t, duration_s)
    sway = np.zeros(t.size)
    rate = np.zeros(t.size)
    for amp, omega, phase in components:
        sway += gain * amp * (np.sin(omega * (t - hold) + phase) - math.sin(phase))
        rate += gain * amp * omega * np.cos(omega * (t - hold) + phase)
    return env_rate * sway + env * rate


def draw_wave(rng: np.random.Generator, mean_deg, amp_deg, period_s):
    """A random mean (random sign) and three sinusoids (amplitude, period, phase) from their ranges."""
    mean = rng.choice([-1.0, 1.0]) * rng.uniform(*mean_deg)
    amp = rng.uniform(*amp_deg, size=3)
    period = rng.uniform(*period_s, size=3)
    phase = rng.uniform(0.0, 2.0 * np.pi, size=3)
    return mean, amp, period, phase


def wave(x: np.ndarray, drawn) -> np.ndarray:
    """The mean plus the three sinusoids of :func:`draw_wave` at times ``x`` (s from the start)."""
    mean, amp, period, phase = drawn
    return mean + sum(a * np.sin(2.0 * np.pi * x / p + ph) for a, p, ph in zip(amp, period, phase))


def knot_profile(t_s, duration_s: float, knots_u, knots_c):
    """Temperature (degC) and its exact rate (degC/s) at ``t_s`` through knots.

    Flat at ``knots_c[0]`` for the hold (:func:`hold_s`), then a monotone C1 cubic (PCHIP)
    through ``knots_c`` at the fractions ``knots_u`` (increasing, from 0) of the rest of the run.
    """
    hold = hold_s(duration_s)
    knot_t = np.concatenate([[0.0], hold + (duration_s - hold) * np.asarray(knots_u, dtype=float)])
    knot_c = np.concatenate([[knots_c[0]], np.asarray(knots_c, dtype=float)])
    from scipy.interpolate import PchipInterpolator  # here, not at the top: scipy costs 0.4 s at start-up

    spline = PchipInterpolator(knot_t, knot_c, extrapolate=True)
    t = np.asarray(t_s, dtype=float)
    return spline(t), spline.derivative()(t)


def approach_temperature(t_s, duration_s: float, start_c: float, end_c: float, tau_u: float):
    """Temperature from ``start_c`` approaching ``end_c`` after the hold, degC and degC/s.

    ``T = start + (end - start) * (1 - exp(-u/tau_u)) / (1 - exp(-1/tau_u))`` through 9 knots,
    ``u`` the fraction of the run after the hold: fastest at first, ending at exactly ``end_c``.
    """
    u = np.linspace(0.0, 1.0, 9)
    c = start_c + (end_c - start_c) * (1.0 - np.exp(-u / tau_u)) / (1.0 - math.exp(-1.0 / tau_u))
    return knot_profile(t_s, duration_s, u, c)


def static_temperature(t_s, duration_s: float):
    """Static heating run (Fig. 1), degC and degC/s: 23 → 58 degC, plateau, cooling."""
    cool_u = 0.52 + 0.48 * np.arange(1, 9) / 8.0
    knots_u = [0.0, 0.04, 0.10, 0.16, 0.28, 0.40, 0.52, *cool_u]
    knots_c = [23.0, 29.0, 39.0, 46.0, 53.0, 58.0, 58.0, *(23.0 + 35.0 * np.exp(-(cool_u - 0.52) / 0.15))]
    return knot_profile(t_s, duration_s, knots_u, knots_c)


def vehicle_temperature(t_s, duration_s: float):
    """Vehicle run (Fig. 7), degC and degC/s: 26 → 37 degC, fast at first and levelling off."""
    return approach_temperature(t_s, duration_s, 26.0, 37.0, 0.5)


def calibration_temperature(t_s, duration_s: float):
    """Calibration heating run, degC and degC/s: -10 → 60 degC, a nearly uniform slow ramp."""
    return knot_profile(t_s, duration_s, [0.0, 0.05, 0.95, 1.0], [-10.0, -8.25, 58.25, 60.0])


def hysteresis_temperature(t_s, duration_s: float):
    """The cycle of ``hysteresis``, degC and degC/s: 10 → 70 → 10 degC, then a minor loop 10 → 45 → 20 degC."""
    knots_u = [0.0, 0.25, 0.32, 0.60, 0.66, 0.80, 0.84, 1.0]
    knots_c = [10.0, 70.0, 70.0, 10.0, 10.0, 45.0, 45.0, 20.0]
    return knot_profile(t_s, duration_s, knots_u, knots_c)


def cold_start_temperature(t_s, duration_s: float):
    """Warm-up after a cold soak, degC and degC/s: -20 degC held, then up to +60 degC, fast at first."""
    return approach_temperature(t_s, duration_s, -20.0, 60.0, 0.25)


#: Soak profile: knots (fraction of the run after the hold, degC); ramps between unequal knots.
_SOAK_KNOTS_U = (0.0, 0.08, 0.20, 0.33, 0.50, 0.62, 0.75, 0.86, 0.95, 1.0)
_SOAK_KNOTS_C = (20.0, 20.0, 45.0, 45.0, 5.0, 5.0, 35.0, 35.0, 20.0, 20.0)


def soak_temperature(t_s, duration_s: float):
    """Thermal soak of ``soak``, degC and degC/s: plateaus joined by slow ramps, 20 → 45 → 5 → 35 → 20 degC."""
    return knot_profile(t_s, duration_s, _SOAK_KNOTS_U, _SOAK_KNOTS_C)


def soak_ramps(duration_s: float) -> tuple[tuple[float, float], ...]:
    """The temperature ramps of ``soak``: ``(start_s, end_s)`` each, in run time."""
    hold = hold_s(duration_s)
    at = [hold + (duration_s - hold) * u for u in _SOAK_KNOTS_U]
    return tuple(
        (at[i], at[i + 1]) for i in range(len(at) - 1) if _SOAK_KNOTS_C[i] != _SOAK_KNOTS_C[i + 1]
    )
