"""Adversarial scenarios: logs that break a design built around what the paper's runs offer.

Each takes away something the paper's runs have (gaps in the log, a still start, a
measured temperature, a heading column, complete compass intervals):
:data:`ADVERSARIAL_SCENARIOS`, default lengths in :data:`ADVERSARIAL_DURATION_S`. What
each models: ``docs/simulator.md`` (adversarial scenarios).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from gyrodrift.simulate.motion import (
    Motion,
    add_rotation,
    approach_temperature,
    draw_wave,
    fade_in,
    hold_s,
    ramp_slice,
    smooth_pulse,
    smooth_step,
    still_motion,
    sway_rate,
    wave,
)

__all__ = [
    "ADVERSARIAL_SCENARIOS", "ADVERSARIAL_DURATION_S", "BURSTY_RECORD_S", "BURSTY_SPACING_S", "NO_TEMP_CHANNEL_C",
    "SWAY_MAX_RATE_DPS", "bursty_records", "approach_temperature", "ramp_interference_window",
    "ramp_interference_offset", "sway_outages", "scenario_bursty", "scenario_ramp_interference", "scenario_sway",
    "scenario_vessel", "scenario_no_temp", "scenario_short",
]

#: Default run length of each adversarial scenario, s.
ADVERSARIAL_DURATION_S: dict[str, float] = {
    "bursty": 2 * 3600.0,
    "ramp-interference": 90 * 60.0,
    "sway": 12 * 3600.0,
    "vessel": 2 * 3600.0,
    "no-temp": 3600.0,
    "short": 30.0,
}


def _attitude(rng: np.random.Generator) -> tuple[float, float, float]:
    """Heading (deg, uniform 0–360) and a small mounting roll and pitch (deg, uniform ±2)."""
    heading0 = float(rng.uniform(0.0, 360.0))
    roll, pitch = (float(x) for x in rng.uniform(-2.0, 2.0, size=2))
    return heading0, roll, pitch


def _warming(t: np.ndarray, duration_s: float, rng, start_c, rise_c, tau_u):
    """:func:`approach_temperature` from a start rising by a rise (degC ranges), time constant a range or a number."""
    start, rise = rng.uniform(*start_c), rng.uniform(*rise_c)
    tau = rng.uniform(*tau_u) if isinstance(tau_u, tuple) else tau_u
    return approach_temperature(t, duration_s, float(start), float(start + rise), float(tau))


def _rotations_rate(t_s: np.ndarray, rotations) -> np.ndarray:
    """Heading rate of level rotations ``(t0_s, angle_deg, peak_dps, ramp_s)``, deg/s (:func:`add_rotation`)."""
    rate = np.zeros(t_s.size)
    for rotation in rotations:
        add_rotation(rate, t_s, *rotation)
    return rate


# --------------------------------------------------------------------------- bursty

#: Length of one record of the bursty logger, s.
BURSTY_RECORD_S = 5.0
#: Time from one record's start to the next, s (uniform in this range).
BURSTY_SPACING_S = (295.0, 315.0)
#: Cooling of ``bursty``: start and end temperature ranges (degC), time constant (fraction of the run).
_BURSTY_HOT_C = (35.0, 60.0)
_BURSTY_COLD_C = (-20.0, 10.0)
_BURSTY_TAU_U = (0.25, 0.5)
#: Probability that a bursty log has a compass.
_BURSTY_COMPASS_P = 0.5


def bursty_records(duration_s: float, rng: np.random.Generator) -> tuple[tuple[float, float], ...]:
    """Records ``(start_s, BURSTY_RECORD_S)`` of the bursty logger, the first at 0, :data:`BURSTY_SPACING_S` apart."""
    starts = [0.0]
    while True:
        nxt = starts[-1] + float(rng.uniform(*BURSTY_SPACING_S))
        if nxt >= duration_s:
            break
        starts.append(nxt)
    return tuple((s, BURSTY_RECORD_S) for s in starts)


def scenario_bursty(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A still unit cooling in a thermal chamber, logged in 5-s records every ~300 s; half without compass."""
    t = np.asarray(t_s, dtype=float)
    has_compass = bool(rng.random() < _BURSTY_COMPASS_P)
    heading0, roll, pitch = _attitude(rng)
    hot, cold, tau = rng.uniform(*_BURSTY_HOT_C), rng.uniform(*_BURSTY_COLD_C), rng.uniform(*_BURSTY_TAU_U)
    temp, rate = approach_temperature(t, duration_s, float(hot), float(cold), float(tau))
    return still_motion(
        t, temp, rate, heading0, roll, pitch,
        records=bursty_records(duration_s, rng), compass_form="heading" if has_compass else "none",
    )


# --------------------------------------------------------------------------- ramp-interference

#: Temperature of ``ramp-interference``: held at (degC range), falling at (degC/min range) in the default run.
_RAMP_HOT_C = (40.0, 55.0)
_RAMP_FALL_C_PER_MIN = (0.7, 0.9)
#: The fall, in fractions of the run after the hold: from, to, and the raised-cosine corners.
_RAMP_FALL_U = (0.10, 0.50)
_RAMP_CORNER_U = 0.02
#: The interference: mean offset (deg), three sinusoids (amplitude deg, period s), fade (s).
_RAMP_INTERFERENCE_MEAN_DEG = (20.0, 35.0)
_RAMP_INTERFERENCE_AMP_DEG = (3.0, 10.0)
_RAMP_INTERFERENCE_PERIOD_S = (60.0, 300.0)
_RAMP_INTERFERENCE_FADE_S = 30.0


def _ramp_integral(s: np.ndarray, width: float) -> np.ndarray:
    """Integral of ``smooth_step(s / width)`` from −∞ to ``s``, s (exact)."""
    x = np.clip(s / width, 0.0, 1.0)
    inside = width * (0.5 * x - np.sin(np.pi * x) / (2.0 * np.pi))
    return np.where(s >= width, s - 0.5 * width, inside)


def _falling_temperature(t: np.ndarray, duration_s: float, hot_c: float, fall_c: float):
    """Held at ``hot_c``, then a fall by ``fall_c`` at a constant rate with raised-cosine corners."""
    hold = hold_s(duration_s)
    rest = duration_s - hold
    width = _RAMP_CORNER_U * rest
    a = hold + _RAMP_FALL_U[0] * rest
    b = hold + _RAMP_FALL_U[1] * rest - width  # the rate's step down starts here, so the fall ends at 0.50
    rate = fall_c / (b - a)
    temp = hot_c - rate * (_ramp_integral(t - a, width) - _ramp_integral(t - b, width))
    temp_rate = -rate * (smooth_step((t - a) / width) - smooth_step((t - b) / width))
    return temp, temp_rate


def ramp_interference_window(duration_s: float) -> tuple[float, float]:
    """Where the interference of ``ramp-interference`` acts: ``(start_s, duration_s)``, inside the fall."""
    return 0.25 * duration_s, duration_s / 9.0


def ramp_interference_offset(t_s, duration_s: float, rng: np.random.Generator) -> np.ndarray:
    """Compass heading offset of ``ramp-interference`` at ``t_s``, deg: about 30 deg that wanders (0 outside)."""
    t = np.asarray(t_s, dtype=float)
    start, dur = ramp_interference_window(duration_s)
    drawn = draw_wave(rng, _RAMP_INTERFERENCE_MEAN_DEG, _RAMP_INTERFERENCE_AMP_DEG, _RAMP_INTERFERENCE_PERIOD_S)
    fade = min(_RAMP_INTERFERENCE_FADE_S, dur / 4.0)
    out = np.zeros(t.shape)
    sl = ramp_slice(t, start, start + dur)
    out[sl] = smooth_pulse(t[sl], start, start + dur, fade) * wave(t[sl] - start, drawn)
    return out


def scenario_ramp_interference(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """Still; the temperature falls fast while the compass is pulled about 30 deg off."""
    t = np.asarray(t_s, dtype=float)
    heading0, roll, pitch = _attitude(rng)
    hot = float(rng.uniform(*_RAMP_HOT_C))
    per_min = float(rng.uniform(*_RAMP_FALL_C_PER_MIN))
    default = ADVERSARIAL_DURATION_S["ramp-interference"]
    rest = default - hold_s(default)
    fall = per_min / 60.0 * ((_RAMP_FALL_U[1] - _RAMP_FALL_U[0] - _RAMP_CORNER_U) * rest)
    temp, rate = _falling_temperature(t, duration_s, hot, fall)
    offset = ramp_interference_offset(t, duration_s, rng)
    return still_motion(t, temp, rate, heading0, roll, pitch, interference_offset_deg=offset)


# --------------------------------------------------------------------------- sway

#: Largest yaw rate of the ``sway`` platform, deg/s (the amplitudes are scaled down to it).
SWAY_MAX_RATE_DPS = 0.18
#: Sway components: (amplitude range deg, period range s).
_SWAY_COMPONENTS = (((2.0, 5.0), (240.0, 720.0)), ((0.5, 2.0), (40.0, 120.0)))
#: Outages of ``sway``: how many (inclusive range) and how long (min, in the default 12-h run).
_SWAY_OUTAGE_COUNT = (3, 5)
_SWAY_OUTAGE_MIN = (40.0, 90.0)
#: Day/night temperature: mean and amplitude ranges, degC; the period is twice the run.
_SWAY_TEMP_MEAN_C = (0.0, 25.0)
_SWAY_TEMP_AMP_C = (5.0, 12.0)


def sway_outages(duration_s: float, rng: np.random.Generator) -> tuple[tuple[float, float], ...]:
    """Compass outages ``(start_s, duration_s)`` of ``sway``, in time order, never overlapping."""
    scale = duration_s / ADVERSARIAL_DURATION_S["sway"]
    n = int(rng.integers(_SWAY_OUTAGE_COUNT[0], _SWAY_OUTAGE_COUNT[1] + 1))
    lengths = rng.uniform(*_SWAY_OUTAGE_MIN, size=n) * 60.0 * scale
    hold = hold_s(duration_s)
    free = duration_s - hold - float(lengths.sum())
    gaps = rng.dirichlet(np.ones(n + 1)) * free
    out, at = [], hold
    for gap, length in zip(gaps[:-1], lengths):
        at += float(gap)
        out.append((at, float(length)))
        at += float(length)
    return tuple(out)


def scenario_sway(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A moored or parked platform for 12 h: slow yaw sway, long outages, a day/night cycle."""
    t = np.asarray(t_s, dtype=float)
    heading0, roll, pitch = _attitude(rng)
    draws = [
        (rng.uniform(*amp), 2.0 * np.pi / rng.uniform(*period), rng.uniform(0.0, 2.0 * np.pi))
        for amp, period in _SWAY_COMPONENTS
    ]
    peak = sum(a * w for a, w, _ in draws)
    gain = min(1.0, SWAY_MAX_RATE_DPS / peak)
    rate = sway_rate(t, duration_s, draws, gain)
    mean, amp_c = rng.uniform(*_SWAY_TEMP_MEAN_C), rng.uniform(*_SWAY_TEMP_AMP_C)
    phase_c = rng.uniform(0.0, 2.0 * np.pi)
    omega_c = 2.0 * np.pi / (2.0 * duration_s)
    temp = mean + amp_c * np.sin(omega_c * t + phase_c)
    temp_rate = amp_c * omega_c * np.cos(omega_c * t + phase_c)
    return still_motion(t, temp, temp_rate, heading0, roll, pitch, heading_rate_dps=rate,
                        compass_dropouts=sway_outages(duration_s, rng))


# --------------------------------------------------------------------------- vessel

#: Vessel turn: mean rate (deg/s), relative modulation and its period (s).
_VESSEL_RATE_DPS = (0.15, 0.6)
_VESSEL_RATE_MOD = (0.1, 0.3)
_VESSEL_MOD_PERIOD_S = (600.0, 1800.0)
#: Wave yaw: amplitude (deg) and period (s); speed through the water (m/s).
_VESSEL_WAVE_DEG = (0.3, 1.5)
_VESSEL_WAVE_PERIOD_S = (8.0, 20.0)
_VESSEL_SPEED_MPS = (2.0, 6.0)
#: Temperature: start (degC), rise (degC), time constant (fraction of the run).
_VESSEL_WARMING = ((5.0, 25.0), (5.0, 15.0), (0.2, 0.5))


def scenario_vessel(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A vessel in a slow continuous turn, with wave yaw: never still, never turning fast."""
    t = np.asarray(t_s, dtype=float)
    heading0, roll, pitch = _attitude(rng)
    sign = float(rng.choice([-1.0, 1.0]))
    r0 = sign * rng.uniform(*_VESSEL_RATE_DPS)
    mod = rng.uniform(*_VESSEL_RATE_MOD)
    omega_mod = 2.0 * np.pi / rng.uniform(*_VESSEL_MOD_PERIOD_S)
    phase_mod = rng.uniform(0.0, 2.0 * np.pi)
    wave_amp = rng.uniform(*_VESSEL_WAVE_DEG)
    omega_wave = 2.0 * np.pi / rng.uniform(*_VESSEL_WAVE_PERIOD_S)
    phase_wave = rng.uniform(0.0, 2.0 * np.pi)
    speed = rng.uniform(*_VESSEL_SPEED_MPS)
    temp, temp_rate = _warming(t, duration_s, rng, *_VESSEL_WARMING)

    env, env_rate = fade_in(t, duration_s)
    turn = env * r0 * (1.0 + mod * np.sin(omega_mod * t + phase_mod))
    wave = wave_amp * omega_wave * np.cos(omega_wave * t + phase_wave)
    return Motion(
        temp_c=temp, temp_rate_cps=temp_rate, heading_rate_dps=turn + wave, heading0_deg=heading0,
        roll_deg=roll, pitch_deg=pitch, accel_fwd_mps2=speed * env_rate,
        accel_lat_mps2=speed * env * np.radians(turn),
    )


# --------------------------------------------------------------------------- no-temp

#: The constant the temperature column of ``no-temp`` holds, degC (what loggers write
#: when the sensor does not report a temperature).
NO_TEMP_CHANNEL_C = 0.0
#: Warm-up: start (degC), rise (degC), time constant (fraction of the run).
_NO_TEMP_WARMING = ((15.0, 30.0), (10.0, 25.0), (0.15, 0.4))
#: Turns: time between them (s), angle (deg), peak rate (deg/s), ramp (s).
_NO_TEMP_TURN_EVERY_S = (240.0, 600.0)
_NO_TEMP_TURN_DEG = (45.0, 180.0)
_NO_TEMP_TURN_PEAK_DPS = (10.0, 30.0)
_TURN_RAMP_S = 1.0


def scenario_no_temp(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A bench unit warming up, turned now and then, whose temperature column is a constant."""
    t = np.asarray(t_s, dtype=float)
    heading0, roll, pitch = _attitude(rng)
    temp, temp_rate = _warming(t, duration_s, rng, *_NO_TEMP_WARMING)
    rotations = []
    at = hold_s(duration_s) + float(rng.uniform(*_NO_TEMP_TURN_EVERY_S))
    while at < duration_s:
        angle = float(rng.choice([-1.0, 1.0]) * rng.uniform(*_NO_TEMP_TURN_DEG))
        peak = float(rng.uniform(*_NO_TEMP_TURN_PEAK_DPS))
        rotations.append((at, angle, peak, _TURN_RAMP_S))
        at += abs(angle) / peak + _TURN_RAMP_S + float(rng.uniform(*_NO_TEMP_TURN_EVERY_S))
    return still_motion(t, temp, temp_rate, heading0, roll, pitch, heading_rate_dps=_rotations_rate(t, rotations),
                        temp_channel_c=NO_TEMP_CHANNEL_C)


# --------------------------------------------------------------------------- short

#: Short hand-held log: still time before the rotation (s), angle (deg), peak rate (deg/s).
_SHORT_STILL_S = (3.0, 8.0)
_SHORT_TURN_DEG = (90.0, 720.0)
_SHORT_TURN_PEAK_DPS = (30.0, 90.0)
#: Self-heating: start (degC), rise over the log (degC), time constant (fraction of the run).
_SHORT_WARMING = ((20.0, 35.0), (0.2, 1.5), 0.5)


def scenario_short(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A hand-held log of tens of seconds: still for 3–8 s, then one rotation, self-heating."""
    t = np.asarray(t_s, dtype=float)
    heading0, roll, pitch = _attitude(rng)
    still = float(rng.uniform(*_SHORT_STILL_S))
    angle = float(rng.choice([-1.0, 1.0]) * rng.uniform(*_SHORT_TURN_DEG))
    peak = float(rng.uniform(*_SHORT_TURN_PEAK_DPS))
    temp, temp_rate = _warming(t, duration_s, rng, *_SHORT_WARMING)
    return still_motion(t, temp, temp_rate, heading0, roll, pitch,
                        heading_rate_dps=_rotations_rate(t, [(still, angle, peak, _TURN_RAMP_S)]))


#: Scenario name → motion builder ``f(t_s, duration_s, rng) -> Motion`` (``vehicle-rawmag``
#: is registered in :mod:`~gyrodrift.simulate.scenarios`).
ADVERSARIAL_SCENARIOS: dict[str, Callable[[np.ndarray, float, np.random.Generator], Motion]] = {
    "bursty": scenario_bursty,
    "ramp-interference": scenario_ramp_interference,
    "sway": scenario_sway,
    "vessel": scenario_vessel,
    "no-temp": scenario_no_temp,
    "short": scenario_short,
}
