"""A procedural scenario generator that nobody tunes on: random compositions of motion,
temperature, compass, sampling and device, in classes, with seeds split once.

Each log is drawn from a class (:data:`CLASSES`); ``tuning`` seeds choose settings,
``held-out`` seeds only report (:data:`SPLITS`). A log has truth columns for the decisions
a compensator makes (:data:`TRUE_RATE_Z`, :data:`TRUE_COMPASS_OFFSET`, :func:`truth_labels`).
The classes and their numbers: ``docs/simulator.md`` (the procedural generator).

Examples
--------
>>> case = generate("sway-clean", seeds("tuning", 1)[0], duration_scale=0.05)
>>> case.log.attrs["class"], bool(np.isfinite(case.log["heading"]).any())
('sway-clean', True)
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Callable, Mapping, NamedTuple

import numpy as np
import pandas as pd

from gyrodrift.conventions import (
    ACC_COLS, GYRO_X, GYRO_Y, GYRO_Z, HEADING, MAG_COLS, REF_HEADING, TEMP, TRUE_BIAS_Z, T, wrap_360,
)
from gyrodrift.errors import ConfigError
from gyrodrift.simulate.device import DeviceModel, random_device, seeded_streams, temperature_reading, true_bias
from gyrodrift.simulate.motion import (
    Motion, add_rotation, in_records, ramp_slice, smooth_pulse, sum_of_step_slopes, sum_of_steps, true_heading,
)
from gyrodrift.simulate.sensors import GRAVITY_MPS2, CompassModel, compass_columns, compass_rows, random_compass

__all__ = [
    "CLASSES", "SPLITS", "TRUE_RATE_Z", "TRUE_COMPASS_OFFSET", "DISTURBED_DEG", "TURNING_DPS", "GeneratedCase",
    "seeds", "split_of", "generate", "truth_labels",
]

#: Truth column: the true heading rate, deg/s.
TRUE_RATE_Z = "true_rate_z"
#: Truth column: the magnetic interference on the compass heading, deg.
TRUE_COMPASS_OFFSET = "true_compass_offset"
#: A compass sample is disturbed when its interference exceeds this, deg.
DISTURBED_DEG = 2.0
#: The platform is turning when its true heading rate exceeds this, deg/s (the turning
#: rate of :class:`gyrodrift.gating.GateConfig`).
TURNING_DPS = 2.0

#: The seed splits: the first seed of each and how many there are. Tuning seeds choose
#: settings; held-out seeds only report.
SPLITS: Mapping[str, range] = MappingProxyType({
    "tuning": range(0, 100_000),
    "held-out": range(1_000_000, 1_100_000),
})


def seeds(split: str, n: int) -> list[int]:
    """The first ``n`` seeds of a split (``"tuning"`` or ``"held-out"``)."""
    if split not in SPLITS:
        raise ConfigError(f"unknown seed split {split!r}; choose from: {', '.join(SPLITS)}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= len(SPLITS[split]):
        raise ConfigError(f"the number of seeds must be between 1 and {len(SPLITS[split])}, got {n!r}")
    return list(SPLITS[split][: int(n)])


def split_of(seed: int) -> str:
    """The split a seed belongs to (ConfigError for a seed in neither)."""
    for name, rng in SPLITS.items():
        if seed in rng:
            return name
    raise ConfigError(f"seed {seed} is in no split ({', '.join(f'{k}: {v.start}..{v.stop - 1}' for k, v in SPLITS.items())})")


@dataclass(frozen=True)
class GeneratedCase:
    """One generated log (``log``: input contract, ``ref_heading``, ``true_bias_z`` and the truth
    columns; ``attrs`` say how it was made), its class, seed, device and compass, and
    ``calibration()``, a separate 2-h still heating run of the same device and compass.
    """

    cls: str
    seed: int
    log: pd.DataFrame
    device: DeviceModel
    compass: CompassModel
    calibration: Callable[[], pd.DataFrame] = field(repr=False, compare=False)


# --------------------------------------------------------------------------- recipes


@dataclass
class _Recipe:
    """What a class drew: the run on a fine grid, then how it is logged."""

    duration_s: float
    fs_sim_hz: float
    device: DeviceModel
    compass: CompassModel
    temp: Callable[[np.ndarray], np.ndarray]
    rate: Callable[[np.ndarray], np.ndarray] = lambda t: np.zeros(t.size)
    accel_fwd: Callable[[np.ndarray], np.ndarray] | None = None
    accel_lat: Callable[[np.ndarray], np.ndarray] | None = None
    offset: Callable[[np.ndarray], np.ndarray] | None = None
    vibration: Callable[[np.ndarray], np.ndarray] | None = None  # every logged gyro's noise multiplier (>= 1)
    dropouts: tuple[tuple[float, float], ...] = ()
    heading0_deg: float = 0.0
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    log_fs_hz: float | None = None  # decimated point samples (None: every grid row)
    telemetry: bool = False  # jittered 0.5-4 s spacing, a compass sample on every row
    records: tuple[tuple[float, float], ...] = ()
    compass_form: str = "heading"
    temp_channel_c: float | None = None
    held_jitter_deg: float | None = None  # the heading written on every row: held, plus this jitter per row
    stalls: bool = False  # the logger stalls: 50-250 ms of rows lost after every 0.2-1.5 s (_stalled)
    clusters: bool = False  # rows stamped as they arrive, in clusters (_clustered_stamps)
    # a flying body's airspeed, m/s, as a function of time: its turns are coordinated (the bank
    # follows the turn rate)
    airspeed: Callable[[np.ndarray], np.ndarray] | None = None
    # the x/y gyros are logged, their devices and noise drawn from ``triad`` (None: not logged)
    triad: Callable[[], np.random.Generator] | None = None
    # a hand-held body's roll, deg, as a function of time (its tilt wobbles as it is turned;
    # no centripetal part: turned about itself)
    wobble: Callable[[np.ndarray], np.ndarray] | None = None
    # a body whose whole attitude and acceleration change: a function of the grid's times and
    # heading rate giving its :class:`_Attitude` on the grid (None: the constant or wobbling tilt)
    attitude: Callable[[np.ndarray, np.ndarray], "_Attitude"] | None = None


class _Attitude(NamedTuple):
    """A body's roll and pitch (deg, ZYX Euler angles) and its acceleration in the heading-aligned
    level frame (forward, right, down; m/s²), on the simulation grid."""

    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    accel_fwd_mps2: np.ndarray
    accel_lat_mps2: np.ndarray
    accel_down_mps2: np.ndarray


def _u(rng, lo, hi) -> float:
    """Uniform in ``[lo, hi)``, as float."""
    return float(rng.uniform(lo, hi))


def _sign(rng) -> float:
    return float(rng.choice([-1.0, 1.0]))


def _device(rng, *, hot: bool = False, memory: bool = False, coarse_temp: bool = False) -> DeviceModel:
    """A random gyro: :func:`random_device`, then a hot-running multicopter IMU (``hot``: a
    steep, curved drift), thermal lag and backlash (``memory``), or a temperature read in
    whole degrees (``coarse_temp``)."""
    dev = random_device(rng)
    if hot:
        dev = replace(dev, c1_dps_per_c=_sign(rng) * _u(rng, 0.04, 0.15), c2_dps_per_c2=_sign(rng) * _u(rng, 5e-4, 3e-3),
                      k_rate_dps_per_cps=_u(rng, -15.0, 15.0), noise_density_dps_rthz=_u(rng, 0.005, 0.02))
    if memory:
        dev = replace(dev, lag_tau_s=_u(rng, 60.0, 300.0), play_dps=_sign(rng) * _u(rng, 0.03, 0.15),
                      play_width_c=_u(rng, 3.0, 10.0), c2_dps_per_c2=_sign(rng) * _u(rng, 3e-4, 1e-3))
    if coarse_temp:
        dev = replace(dev, temp_quant_c=1.0)
    return dev


def _compass(rng, *, noise=(0.3, 0.8), rate_hz=10.0) -> CompassModel:
    """:func:`random_compass` with a heading noise uniform in ``noise`` and the rate ``rate_hz``."""
    return replace(random_compass(rng), noise_deg=_u(rng, *noise), rate_hz=float(rate_hz))


# temperature profiles: functions of the grid times


def _warmup(rng, start=(10.0, 30.0), rise=(10.0, 35.0), tau=(60.0, 400.0)):
    """A power-on warm-up: an exponential rise from the start (degC ranges, time constant s)."""
    t0, dT, tau_s = _u(rng, *start), _u(rng, *rise), _u(rng, *tau)
    return lambda t: t0 + dT * (1.0 - np.exp(-t / tau_s))


def _knots(times, temps):
    """A monotone C1 profile through (time s, degC) knots, flat outside them."""
    from scipy.interpolate import PchipInterpolator

    spline = PchipInterpolator(np.asarray(times, float), np.asarray(temps, float))
    return lambda t: spline(np.clip(t, times[0], times[-1]))


def _chamber(rng, duration):
    """Chamber ramps with plateaus and knees: 4–7 knots between -20 and 60 degC."""
    n = int(rng.integers(4, 8))
    times = np.sort(rng.uniform(0.05, 0.95, n - 2)) * duration
    times = np.concatenate([[0.0], times, [duration]])
    temps = [_u(rng, 15.0, 30.0)]
    for _ in range(n - 1):
        temps.append(float(np.clip(temps[-1] + _sign(rng) * _u(rng, 5.0, 30.0), -20.0, 60.0)))
    return _knots(times, temps)


def _day_cycle(rng, duration):
    """A sinusoid of 5–30 degC mean and 3–12 degC amplitude, its period 1.5–3 runs."""
    mean, amp, phase = _u(rng, 5.0, 30.0), _u(rng, 3.0, 12.0), _u(rng, 0.0, 2 * math.pi)
    period = _u(rng, 1.5, 3.0) * duration  # a part of one day, squeezed into the run
    return lambda t: mean + amp * np.sin(2 * math.pi * t / period + phase)


# motion pieces, added over their own samples


def _turn_plan(rng, t0, end, angle, peak, gap, after=None):
    """Turns ``(start s, angle deg, peak deg/s)`` from ``t0`` while before ``end``; the next
    starts ``gap`` s after the start of one, or after ``after(angle, peak)`` s and the gap."""
    turns = []
    while t0 < end:
        a = _sign(rng) * _u(rng, *angle)
        p = _u(rng, *peak)
        turns.append((t0, a, p))
        t0 += _u(rng, *gap) if after is None else after(a, p) + _u(rng, *gap)
    return turns


def _turns_rate(turns, ramp=1.0):
    """The heading rate (deg/s) of ``turns`` as a function of time (:func:`add_rotation`)."""
    def rate(t):
        r = np.zeros(t.size)
        for t0, angle, peak in turns:
            add_rotation(r, t, t0, angle, peak, ramp)
        return r
    return rate


def _sway(rng, t, amp_deg=(0.5, 4.0), period_s=(8.0, 120.0), n=3):
    """Yaw sway: the rate of a few sinusoids of heading."""
    out = np.zeros(t.size)
    for _ in range(n):
        a, p, ph = _u(rng, *amp_deg), _u(rng, *period_s), _u(rng, 0.0, 2 * math.pi)
        out += a * 2 * math.pi / p * np.cos(2 * math.pi * t / p + ph)
    return out


def _pulse(t, t0, t1, ramp):
    """1 inside [t0, t1] with raised-cosine edges of ``ramp`` s, 0 outside."""
    return smooth_pulse(t, t0, t1, max(min(ramp, 0.25 * (t1 - t0)), 1e-3))


def _disturbances(rng, duration, n_range=(1, 4), size=(5.0, 40.0), dur=(20.0, 600.0), kinds=("step", "ramp", "wander")):
    """Magnetic interference episodes: (kind, start, length, size, parameters)."""
    out = []
    for _ in range(int(rng.integers(n_range[0], n_range[1] + 1))):
        length = min(_u(rng, *dur), 0.3 * duration)
        start = _u(rng, 0.1 * duration, max(0.1 * duration, 0.95 * duration - length))
        out.append((str(rng.choice(kinds)), start, length, _sign(rng) * _u(rng, *size), _u(rng, 1.0, 30.0),
                    int(rng.integers(0, 2**31))))
    return out


def _offset_fn(episodes):
    """The compass heading offset (deg) of interference episodes, as a function of time."""
    def offset(t):
        out = np.zeros(t.size)
        for kind, start, length, size, ramp, seed in episodes:
            sl = ramp_slice(t, start, start + length)
            x = t[sl]
            if kind == "step":
                out[sl] += size * _pulse(x, start, start + length, ramp)
            elif kind == "ramp":  # grows over the episode, then drops within `ramp` seconds
                out[sl] += size * np.clip((x - start) / length, 0.0, 1.0) * _pulse(x, start, start + length, ramp)
            else:  # wander: a smooth random process inside the episode
                g = np.random.default_rng(seed)
                knots = np.linspace(start, start + length, max(4, int(length / 40.0)))
                vals = size * g.uniform(-1.0, 1.0, knots.size)
                out[sl] += np.interp(x, knots, vals) * _pulse(x, start, start + length, ramp)
        return out
    return offset


def _dropouts(rng, duration, n_range=(1, 3), length=(300.0, 1800.0)):
    """Compass outages ``(start, length)``: how many and how long (s), at most a quarter of the run each."""
    out = []
    for _ in range(int(rng.integers(n_range[0], n_range[1] + 1))):
        ln = min(_u(rng, *length), 0.25 * duration)
        out.append((_u(rng, 0.1 * duration, 0.9 * duration - ln), ln))
    return tuple(out)


# --------------------------------------------------------------------------- the classes


def _warmup_telemetry(rng, scale):
    """A multicopter board still on the bench after power-on, its IMU warming up fast;
    telemetry at about 1 Hz with 0.5–4 s jitter; the compass clean, once in a while a
    short disturbance nearby."""
    duration = _u(rng, 600.0, 1800.0) * scale
    episodes = _disturbances(rng, duration, (0, 1), (5.0, 30.0), (20.0, 120.0), ("step",))
    return _Recipe(duration, 50.0, _device(rng, hot=True, coarse_temp=rng.random() < 0.3),
                   _compass(rng, noise=(0.5, 2.0), rate_hz=50.0), _warmup(rng, rise=(15.0, 40.0), tau=(60.0, 300.0)),
                   offset=_offset_fn(episodes), heading0_deg=_u(rng, 0, 360), telemetry=True)


def _flight_times(rng, scale, ground_s):
    """A flight's times (s): the end of the time on the ground (drawn from ``ground_s``), the
    landing after 5–15 min of flight, the end of the run 1–3 min later; and the IMU's warm-up
    from power-on (:func:`_warmup`)."""
    ground = _u(rng, *ground_s) * scale
    flight = _u(rng, 300.0, 900.0) * scale
    duration = ground + flight + _u(rng, 60.0, 180.0) * scale
    return ground, ground + flight, duration, _warmup(rng, rise=(8.0, 20.0), tau=(60.0, 300.0))


def _multicopter(rng, scale):
    """Warm-up on the ground, a flight with yaw manoeuvres, vibration on the gyro, an IMU
    heating in flight and a compass error that follows the motor throttle; landing, still."""
    ground, t_land, duration, warm = _flight_times(rng, scale, (120.0, 360.0))
    heat, heat_tau = _u(rng, 5.0, 15.0), _u(rng, 120.0, 400.0)
    k_throttle = _sign(rng) * _u(rng, 5.0, 30.0)
    hover = _u(rng, 0.4, 0.6)
    man = [(_u(rng, ground + 20, t_land - 30), _u(rng, 5.0, 20.0), _u(rng, -0.2, 0.2)) for _ in range(6)]
    turning = _turns_rate(_turn_plan(rng, ground + _u(rng, 20.0, 60.0), t_land - 40.0, (20.0, 180.0), (15.0, 90.0),
                                     (10.0, 60.0), after=lambda a, p: abs(a) / 15.0 + 1.0))

    def throttle(t):
        th = hover * _pulse(t, ground, t_land, 3.0)
        for tm, dm, dth in man:
            th += dth * _pulse(t, tm, tm + dm, 1.0)
        return th

    sway = _child(rng)
    vib = _u(rng, 2.0, 8.0)

    def rate(t):
        return turning(t) + 0.3 * _sway(sway(), t, (0.2, 1.0), (2.0, 10.0)) * _pulse(t, ground, t_land, 3.0)

    return _Recipe(duration, 200.0, _device(rng, hot=rng.random() < 0.5), _compass(rng, rate_hz=float(rng.choice([10.0, 25.0, 50.0]))),
                   lambda t: warm(t) + heat * np.clip(1.0 - np.exp(-(t - ground) / heat_tau), 0.0, None) * (t > ground),
                   rate=rate, offset=lambda t: k_throttle * throttle(t),
                   vibration=lambda t: 1.0 + vib * _pulse(t, ground, t_land, 3.0),
                   heading0_deg=_u(rng, 0, 360), roll_deg=_u(rng, -2, 2), pitch_deg=_u(rng, -2, 2),
                   log_fs_hz=float(rng.choice([50.0, 100.0])))


def _child(rng) -> Callable[[], np.random.Generator]:
    """A function giving a fresh generator of one seed drawn now: the same draws every call."""
    seed = int(rng.integers(0, 2**31))
    return lambda: np.random.default_rng(seed)


def _vessel(rng, scale):
    """A vessel making slow continuous turns (well under 0.1 deg/s) with wave yaw, through
    long compass outages; temperature following the day."""
    duration = _u(rng, 3600.0, 10800.0) * scale
    legs = []
    t0 = 0.0
    while t0 < duration:
        ln = _u(rng, 600.0, 2400.0)
        legs.append((t0, ln, _sign(rng) * _u(rng, 0.01, 0.09)))
        t0 += ln
    wave = _child(rng)

    def rate(t):
        r = np.zeros(t.size)
        for s, ln, w in legs:
            r += w * _pulse(t, s, s + ln, 60.0)
        return r + _sway(wave(), t, (0.3, 2.0), (6.0, 15.0), 2)

    return _Recipe(duration, 10.0, _device(rng), _compass(rng), _day_cycle(rng, duration), rate=rate,
                   dropouts=_dropouts(rng, duration, (1, 3), (600.0, 1800.0)), heading0_deg=_u(rng, 0, 360),
                   log_fs_hz=float(rng.choice([5.0, 10.0])))


def _sway_clean(rng, scale):
    """A moored or parked platform swaying in yaw, its compass clean all along."""
    duration = _u(rng, 3600.0, 7200.0) * scale
    sway = _child(rng)
    return _Recipe(duration, 10.0, _device(rng), _compass(rng), _day_cycle(rng, duration),
                   rate=lambda t: _sway(sway(), t, (0.5, 4.0), (10.0, 120.0)), heading0_deg=_u(rng, 0, 360))


def _chamber_bursty(rng, scale):
    """A still unit in a thermal chamber (ramps with non-linear knees, a device with thermal
    lag and backlash), logged in 2–10-s bursts every 1–10 min; a compass on half."""
    duration = _u(rng, 7200.0, 14400.0) * scale
    spacing, length = _u(rng, 60.0, 600.0), _u(rng, 2.0, 10.0)
    starts = np.arange(0.0, duration - length, spacing) + rng.uniform(-0.05, 0.05) * spacing
    records = tuple((float(max(s, 0.0)), float(length)) for s in starts)
    with_compass = rng.random() < 0.5
    return _Recipe(duration, 50.0, _device(rng, memory=rng.random() < 0.7), _compass(rng), _chamber(rng, duration),
                   heading0_deg=_u(rng, 0, 360), records=records, compass_form="heading" if with_compass else "none")


def _drive_plan(rng, duration, still_s):
    """Legs with cornering and stops: (speed steps (t0, dur, delta m/s), turns (t0, angle, peak))."""
    cruise = _u(rng, 5.0, 20.0)
    t = still_s
    steps, turns = [(t, 6.0, cruise)], []
    t += 6.0
    while t < duration - 30.0:
        t += _u(rng, 20.0, 150.0)
        if rng.random() < 0.25:
            steps.append((t, 5.0, -cruise))
            t += 5.0 + _u(rng, 10.0, 90.0)
            steps.append((t, 6.0, cruise))
            t += 6.0
        angle = _sign(rng) * _u(rng, 30.0, 180.0)
        peak = _u(rng, 8.0, 30.0)
        turns.append((t, angle, peak))
        t += abs(angle) / peak + 2.0
    return steps, turns, cruise


def _drive_motion(rng, duration):
    steps, turns, cruise = _drive_plan(rng, duration, _u(rng, 30.0, 120.0))
    turning = _turns_rate(turns, ramp=2.0)
    wobble = _child(rng)

    def speed(t):
        return sum_of_steps(t, steps)

    def rate(t):
        return turning(t) + _sway(wobble(), t, (0.05, 0.3), (5.0, 40.0), 2) * np.clip(speed(t) / cruise, 0.0, 1.0)

    return rate, lambda t: sum_of_step_slopes(t, steps), lambda t: speed(t) * np.radians(rate(t))


def _drive(rng, scale):
    """A car from a cold start: legs, cornering, stops, a compass tilted by braking and
    cornering, and interference under bridges or in car parks."""
    duration = _u(rng, 1800.0, 3600.0) * scale
    rate, accel, lat = _drive_motion(rng, duration)
    episodes = _disturbances(rng, duration, (0, 3), (10.0, 40.0), (10.0, 120.0))
    return _Recipe(duration, 50.0, _device(rng), _compass(rng), _warmup(rng, start=(-10.0, 15.0), rise=(15.0, 35.0),
                   tau=(300.0, 1200.0)), rate=rate, accel_fwd=accel, accel_lat=lat, offset=_offset_fn(episodes),
                   heading0_deg=_u(rng, 0, 360))


def _rawmag_drive(rng, scale):
    """:func:`_drive` logged with the raw magnetometer and accelerometer instead of a heading,
    the unit mounted with a small tilt."""
    rec = _drive(rng, scale)
    return replace(rec, compass_form="raw", roll_deg=_u(rng, -5, 5), pitch_deg=_u(rng, -5, 5))


def _imu_drive(rng, scale):
    """:func:`_rawmag_drive` logged by a whole IMU: the x/y gyros beside the raw magnetometer
    and the accelerometer, the unit mounted with a small tilt."""
    return replace(_rawmag_drive(rng, scale), triad=_child(rng))


def _bench_interference(rng, scale):
    """A bench unit heated or cooled, turned by hand now and then, with interference steps,
    ramps and wander from things moved around it."""
    duration = _u(rng, 1800.0, 5400.0) * scale
    rate = _turns_rate(_turn_plan(rng, _u(rng, 120.0, 600.0), duration - 60.0, (30.0, 180.0), (10.0, 60.0),
                                  (300.0, 900.0)))
    return _Recipe(duration, float(rng.choice([20.0, 50.0, 100.0])), _device(rng), _compass(rng), _chamber(rng, duration),
                   rate=rate, offset=_offset_fn(_disturbances(rng, duration, (2, 5), (5.0, 60.0), (30.0, 600.0))),
                   heading0_deg=_u(rng, 0, 360))


def _turntable(rng, scale):
    """Turntable rotations of 90–720 deg at 30–300 deg/s between dwells, in a chamber ramp,
    sampled at 200–500 Hz."""
    duration = _u(rng, 600.0, 1800.0) * scale
    rate = _turns_rate(_turn_plan(rng, _u(rng, 30.0, 90.0), duration - 30.0, (90.0, 720.0), (30.0, 300.0),
                                  (10.0, 60.0), after=lambda a, p: abs(a) / p + 1.0))
    fs = float(rng.choice([200.0, 500.0]))
    return _Recipe(duration, fs, _device(rng), _compass(rng, rate_hz=50.0), _chamber(rng, duration), rate=rate,
                   heading0_deg=_u(rng, 0, 360))


def _no_temp_robot(rng, scale):
    """A ground robot indoors, stop and go with turns, near steel (wandering interference);
    its IMU warms up but the log has no temperature."""
    duration = _u(rng, 1200.0, 3600.0) * scale
    rate = _turns_rate(_turn_plan(rng, _u(rng, 20.0, 120.0), duration - 30.0, (20.0, 180.0), (10.0, 45.0),
                                  (20.0, 240.0)))
    episodes = _disturbances(rng, duration, (1, 4), (5.0, 25.0), (30.0, 300.0), ("wander", "step"))
    return _Recipe(duration, 50.0, _device(rng), _compass(rng), _warmup(rng, rise=(5.0, 20.0), tau=(300.0, 1200.0)),
                   rate=rate, offset=_offset_fn(episodes), heading0_deg=_u(rng, 0, 360), temp_channel_c=0.0)


def _held_compass(rng, scale):
    """A board on a bench warming up, turned by hand now and then, logged at 50–100 Hz with a
    heading on every row from a 5–20-Hz magnetometer (each sample held until the next, plus the
    tilt compensation's jitter per row); interference on half."""
    duration = _u(rng, 900.0, 3600.0) * scale
    rate = _turns_rate(_turn_plan(rng, _u(rng, 60.0, 300.0), duration - 60.0, (30.0, 180.0), (10.0, 60.0),
                                  (120.0, 600.0)))
    episodes = _disturbances(rng, duration, (1, 2), (5.0, 30.0), (30.0, 300.0)) if rng.random() < 0.5 else []
    return _Recipe(duration, float(rng.choice([50.0, 100.0])), _device(rng),
                   _compass(rng, noise=(0.5, 3.0), rate_hz=float(rng.choice([5.0, 8.0, 10.0, 20.0]))),
                   _warmup(rng), rate=rate, offset=_offset_fn(episodes), heading0_deg=_u(rng, 0, 360),
                   held_jitter_deg=_u(rng, 0.1, 0.6))


def _rawmag_uncalibrated(rng, scale):
    """:func:`_rawmag_drive` with a magnetometer nobody calibrated: a hard-iron field of 20–60 %
    of the horizontal Earth field in a random body direction (and a vertical part within ±50 % of
    it) and per-axis gains of 0.9–1.1, so its heading errs by up to 12–37 deg, with the heading."""
    rec = _rawmag_drive(rng, scale)
    b_h = rec.compass.field_ut * math.cos(math.radians(rec.compass.dip_deg))
    size, angle = _u(rng, 0.2, 0.6) * b_h, _u(rng, 0.0, 2.0 * math.pi)
    hard = (size * math.cos(angle), size * math.sin(angle), _u(rng, -0.5, 0.5) * b_h)
    gains = tuple(_u(rng, 0.9, 1.1) for _ in range(3))
    return replace(rec, compass=replace(rec.compass, hard_iron_ut=hard, soft_iron_gain=gains))


def _handheld_stalls(rng, scale):
    """A board turned by hand through 90–720 deg at 20–90 deg/s between pauses of 1–10 s while
    it warms up by 2–8 degC, logged at 200–400 Hz through a link that stalls (:func:`_stalled`:
    50–250 ms of rows lost after every 0.2–1.5 s, in the turns too); a heading at 10 Hz."""
    duration = _u(rng, 120.0, 600.0) * scale
    rate = _turns_rate(_turn_plan(rng, _u(rng, 1.0, 10.0), duration - 5.0, (90.0, 720.0), (20.0, 90.0),
                                  (1.0, 10.0), after=lambda a, p: abs(a) / p + 1.0))
    return _Recipe(duration, float(rng.choice([200.0, 400.0])), _device(rng), _compass(rng, noise=(0.5, 3.0)),
                   _warmup(rng, rise=(2.0, 8.0)), rate=rate, heading0_deg=_u(rng, 0, 360), stalls=True)


def _handheld_clustered(rng, scale):
    """The hand turns of ``handheld-stalls`` at 100 Hz with no row lost, logged through a serial
    link that stamps the rows as they arrive: in clusters of 4–10 rows 1–2.5 ms apart, each from
    its last row's true time on (:func:`_clustered_stamps`); a heading at 10 Hz."""
    duration = _u(rng, 120.0, 600.0) * scale
    rate = _turns_rate(_turn_plan(rng, _u(rng, 1.0, 10.0), duration - 5.0, (90.0, 720.0), (20.0, 90.0),
                                  (1.0, 10.0), after=lambda a, p: abs(a) / p + 1.0))
    return _Recipe(duration, 100.0, _device(rng), _compass(rng, noise=(0.5, 3.0)), _warmup(rng, rise=(2.0, 8.0)),
                   rate=rate, heading0_deg=_u(rng, 0, 360), clusters=True)


def _handheld_imu(rng, scale):
    """The hand turns of ``handheld-clustered`` logged by a whole IMU at 100–400 Hz: the x/y
    gyros, a raw magnetometer at 10–100 Hz and the accelerometer; the unit held at a pitch of
    −10–10 deg and a roll that wobbles about −10–10 deg by two swings of 1–8 deg each, 1.5–12 s
    long (the hand), turned about itself (no centripetal part)."""
    duration = _u(rng, 120.0, 600.0) * scale
    rate = _turns_rate(_turn_plan(rng, _u(rng, 1.0, 10.0), duration - 5.0, (90.0, 720.0), (20.0, 90.0),
                                  (1.0, 10.0), after=lambda a, p: abs(a) / p + 1.0))
    roll0 = _u(rng, -10.0, 10.0)
    swings = [(_u(rng, 1.0, 8.0), _u(rng, 1.5, 12.0), _u(rng, 0.0, 2.0 * math.pi)) for _ in range(2)]

    def wobble(t):
        return roll0 + _sines(swings, t)

    fs = float(rng.choice([100.0, 200.0, 400.0]))
    return _Recipe(duration, fs, _device(rng),
                   _compass(rng, noise=(0.5, 3.0), rate_hz=float(rng.choice([10.0, 25.0, 50.0, 100.0]))),
                   _warmup(rng, rise=(2.0, 8.0)), rate=rate, heading0_deg=_u(rng, 0, 360),
                   pitch_deg=_u(rng, -10.0, 10.0), compass_form="raw", triad=_child(rng), wobble=wobble)


def _banked_flight(rng, scale):
    """A fixed-wing or quadplane: a warm-up on the ground, a flight of coordinated turns whose
    bank follows the turn rate and the airspeed (to 20–45 deg), the IMU cooled by the airflow, a
    landing; the x/y gyros, the raw magnetometer and the accelerometer (level-looking in a turn)
    logged at 4–50 Hz."""
    ground, t_land, duration, warm = _flight_times(rng, scale, (60.0, 240.0))
    cool, cool_tau = _u(rng, 3.0, 12.0), _u(rng, 60.0, 300.0)
    speed = _u(rng, 12.0, 25.0)
    turning = _turns_rate(_turn_plan(rng, ground + _u(rng, 20.0, 60.0), t_land - 40.0, (45.0, 720.0), (5.0, 20.0),
                                     (10.0, 60.0), after=lambda a, p: abs(a) / p + 2.0), ramp=2.0)

    def temp(t):
        return warm(t) - cool * np.clip(1.0 - np.exp(-(t - ground) / cool_tau), 0.0, None) * (t > ground)

    return _Recipe(duration, 100.0, _device(rng), _compass(rng, rate_hz=float(rng.choice([10.0, 25.0, 50.0]))), temp,
                   rate=turning, airspeed=lambda t: speed * _pulse(t, ground, t_land, 5.0),
                   heading0_deg=_u(rng, 0, 360), pitch_deg=_u(rng, -3, 5), compass_form="raw",
                   log_fs_hz=float(rng.choice([4.0, 10.0, 25.0, 50.0])), triad=_child(rng))


def _sines(waves, t):
    """The sum of sinusoids ``(amplitude, period s, phase rad)`` at the times ``t``."""
    out = np.zeros(t.size)
    for amp, period, phase in waves:
        out += amp * np.sin(2.0 * np.pi * t / period + phase)
    return out


def _quadplane(rng, scale):
    """A quadplane (VTOL) flight: a warm-up on the ground; a hover with yaw turns, its lift
    motors' vibration on the gyros, a wobble in roll and pitch as it holds its position and (on
    half) a compass error that follows the lift throttle; a transition to forward flight with the
    nose down as it speeds up; coordinated turns, climbs, descents, speed changes and gusts in
    roll and pitch; a back transition with the nose up, a hover, a landing. The x/y gyros, the
    raw magnetometer and the accelerometer, logged at 4–50 Hz (point samples of a 100-Hz run)."""
    ground, t_land, duration, warm = _flight_times(rng, scale, (60.0, 240.0))
    flight = t_land - ground
    t_fwd = ground + _u(rng, 0.05, 0.15) * flight  # the transition to forward flight begins
    trans, back = _u(rng, 8.0, 20.0), _u(rng, 10.0, 25.0)
    t_back = t_land - _u(rng, 0.03, 0.10) * flight - back  # the back transition begins
    cruise = _u(rng, 14.0, 25.0)
    speed_steps, level, t0 = [(t_fwd, trans, cruise)], cruise, t_fwd + trans
    for _ in range(int(rng.integers(0, 4))):
        t0 += _u(rng, 20.0, 120.0)
        ramp = _u(rng, 5.0, 15.0)
        if t0 + ramp > t_back - 10.0:
            break
        new = float(np.clip(level + _sign(rng) * _u(rng, 2.0, 6.0), 12.0, 28.0))
        speed_steps.append((t0, ramp, new - level))
        level, t0 = new, t0 + ramp
    speed_steps.append((t_back, back, -level))
    climbs, t0 = [], t_fwd + trans + _u(rng, 10.0, 60.0)
    while True:
        ramp, hold, gamma = _u(rng, 3.0, 6.0), _u(rng, 10.0, 40.0), _sign(rng) * _u(rng, 3.0, 10.0)
        if t0 + 2.0 * ramp + hold > t_back - 10.0:
            break
        climbs += [(t0, ramp, gamma), (t0 + ramp + hold, ramp, -gamma)]
        t0 += 2.0 * ramp + hold + _u(rng, 20.0, 150.0)
    turns = (_turn_plan(rng, ground + _u(rng, 3.0, 8.0), t_fwd - 10.0, (45.0, 180.0), (5.0, 20.0), (5.0, 30.0),
                        after=lambda a, p: abs(a) / p + 2.0)
             + _turn_plan(rng, t_fwd + trans + _u(rng, 5.0, 30.0), t_back - 20.0, (45.0, 720.0), (5.0, 20.0),
                          (10.0, 60.0), after=lambda a, p: abs(a) / p + 2.0))
    pitch0, dip, flare = _u(rng, -3.0, 5.0), _u(rng, 0.0, 8.0), _u(rng, 5.0, 20.0)
    pitch_gust = [(_u(rng, 0.3, 2.0), _u(rng, 1.5, 8.0), _u(rng, 0.0, 2.0 * math.pi)) for _ in range(2)]
    roll_gust = [(_u(rng, 0.3, 3.0), _u(rng, 1.5, 8.0), _u(rng, 0.0, 2.0 * math.pi)) for _ in range(2)]
    k_lift = _sign(rng) * _u(rng, 3.0, 12.0) if rng.random() < 0.5 else 0.0
    vib, cool, cool_tau = _u(rng, 1.0, 5.0), _u(rng, 3.0, 12.0), _u(rng, 60.0, 300.0)

    def lift(t):  # the lift motors' share: airborne below 12 m/s
        return _pulse(t, ground, t_land, 3.0) * np.clip(1.0 - sum_of_steps(t, speed_steps) / 12.0, 0.0, 1.0)

    def attitude(t, rate):
        vh, air, hover = sum_of_steps(t, speed_steps), _pulse(t, ground, t_land, 3.0), lift(t)
        gust_p, gust_r = air * _sines(pitch_gust, t), air * _sines(roll_gust, t)
        gamma = sum_of_steps(t, climbs)
        pitch = (pitch0 + gamma - dip * _pulse(t, t_fwd, t_fwd + trans, trans / 3.0)
                 + flare * _pulse(t, t_back, t_back + back, back / 3.0) + gust_p)
        turn = vh * np.radians(rate)
        roll = np.degrees(np.arctan2(turn, GRAVITY_MPS2)) + gust_r
        # hovering, a tilt is what moves the body (the thrust leans with it); wing-borne, a gust
        # in pitch bends the path and one in roll slips
        fwd = sum_of_step_slopes(t, speed_steps) - hover * GRAVITY_MPS2 * np.tan(np.radians(gust_p))
        lat = turn + hover * GRAVITY_MPS2 * np.tan(np.radians(gust_r))
        down = (-np.gradient(vh * np.tan(np.radians(gamma)), t)
                - (1.0 - hover) * vh * np.radians(np.gradient(gust_p, t)))
        return _Attitude(roll, pitch, fwd, lat, down)

    def temp(t):
        return warm(t) - cool * np.clip(1.0 - np.exp(-(t - t_fwd) / cool_tau), 0.0, None) * (t > t_fwd)

    return _Recipe(duration, 100.0, _device(rng), _compass(rng, rate_hz=float(rng.choice([10.0, 25.0, 50.0]))), temp,
                   rate=_turns_rate(turns, ramp=2.0), offset=lambda t: k_lift * lift(t),
                   vibration=lambda t: 1.0 + vib * lift(t), heading0_deg=_u(rng, 0, 360), pitch_deg=pitch0,
                   compass_form="raw", log_fs_hz=float(rng.choice([4.0, 10.0, 25.0, 50.0])), triad=_child(rng),
                   attitude=attitude)


def _vessel_imu(rng, scale):
    """:func:`_vessel` logged by a whole IMU on a boat that rolls and pitches in a seaway: a roll of
    two swells (2–12 deg and 0.5–4 deg, 5–14 s) about a list of −3–3 deg, a pitch of two of 1–4 deg
    and 4–9 s, the unit 1–6 m above the roll's centre (so it sways sideways as it rolls) and
    heaving by 0.02–0.15 g; at 3–10 m/s. The x/y gyros, the raw magnetometer and the accelerometer."""
    rec = _vessel(rng, scale)
    roll0, pitch0 = _u(rng, -3.0, 3.0), _u(rng, -3.0, 3.0)
    roll_waves = [(_u(rng, *amp), _u(rng, 5.0, 14.0), _u(rng, 0.0, 2.0 * math.pi)) for amp in ((2.0, 12.0), (0.5, 4.0))]
    pitch_waves = [(_u(rng, 1.0, 4.0), _u(rng, 4.0, 9.0), _u(rng, 0.0, 2.0 * math.pi)) for _ in range(2)]
    heave = [(_u(rng, 0.02, 0.15) * GRAVITY_MPS2, _u(rng, 4.0, 10.0), _u(rng, 0.0, 2.0 * math.pi))]
    height, speed = _u(rng, 1.0, 6.0), _u(rng, 3.0, 10.0)

    def attitude(t, rate):
        roll = roll0 + _sines(roll_waves, t)
        roll_accel = np.radians(np.gradient(np.gradient(roll, t), t))
        lat = speed * np.radians(rate) + height * roll_accel  # a unit above the roll's centre sways with it
        return _Attitude(roll, pitch0 + _sines(pitch_waves, t), np.zeros(t.size), lat, _sines(heave, t))

    return replace(rec, compass_form="raw", triad=_child(rng), attitude=attitude, roll_deg=roll0, pitch_deg=pitch0)


def _multicopter_imu(rng, scale):
    """:func:`_multicopter` logged by its whole IMU and raw magnetometer: between hovers it flies
    legs of 3–15 m/s in any direction of the body (accelerating and braking at 1–4 m/s² on
    average, raised-cosine ramps), tilted by its thrust against the acceleration and a linear drag of 0.2–0.5 /s (so that
    braking pitches it up by up to 25 deg while its accelerometer reads nearly along body z), and
    wobbles by 0.3–2 deg as it holds its position (the tilt is what moves it). The x/y gyros,
    the raw magnetometer and the accelerometer."""
    rec = _multicopter(rng, scale)
    drag = _u(rng, 0.2, 0.5)
    steps_n, steps_e, t0 = [], [], 0.0
    v_n = v_e = 0.0
    while t0 < rec.duration_s:
        t0 += _u(rng, 5.0, 30.0)  # a hover, then a leg
        speed, way = _u(rng, 3.0, 15.0), _u(rng, 0.0, 2.0 * math.pi)
        ramp_in = speed / _u(rng, 1.0, 4.0)
        ramp_out = speed / _u(rng, 1.0, 4.0)
        cruise = _u(rng, 5.0, 40.0)
        steps_n.append((t0, ramp_in, speed * math.cos(way) - v_n))
        steps_e.append((t0, ramp_in, speed * math.sin(way) - v_e))
        t0 += ramp_in + cruise
        steps_n.append((t0, ramp_out, -speed * math.cos(way)))
        steps_e.append((t0, ramp_out, -speed * math.sin(way)))
        v_n = v_e = 0.0
        t0 += ramp_out
    wobble = [(_u(rng, 0.3, 2.0), _u(rng, 1.5, 6.0), _u(rng, 0.0, 2.0 * math.pi)) for _ in range(4)]
    roll0, pitch0 = rec.roll_deg, rec.pitch_deg

    def attitude(t, rate):
        vib = rec.vibration(t) - 1.0
        air = vib / max(float(np.max(vib)), 1e-12)  # airborne: 0..1
        psi = np.radians(np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))]))
        v_world = np.column_stack([sum_of_steps(t, steps_n), sum_of_steps(t, steps_e)]) * air[:, None]
        a_world = np.column_stack([np.gradient(v_world[:, 0], t), np.gradient(v_world[:, 1], t)])
        c, s_ = np.cos(psi), np.sin(psi)

        def level(v):  # world (north, east) to the heading-aligned level frame (forward, right)
            return c * v[:, 0] + s_ * v[:, 1], -s_ * v[:, 0] + c * v[:, 1]

        fwd, lat = level(a_world)
        thrust_f, thrust_l = level(a_world + drag * v_world)  # the thrust leans against acceleration and drag
        wob_r, wob_p = air * _sines(wobble[:2], t), air * _sines(wobble[2:], t)
        thrust_f = thrust_f - GRAVITY_MPS2 * np.tan(np.radians(wob_p))
        thrust_l = thrust_l + GRAVITY_MPS2 * np.tan(np.radians(wob_r))
        fwd = fwd - GRAVITY_MPS2 * np.tan(np.radians(wob_p))
        lat = lat + GRAVITY_MPS2 * np.tan(np.radians(wob_r))
        norm = np.sqrt(thrust_f ** 2 + thrust_l ** 2 + GRAVITY_MPS2 ** 2)
        roll = roll0 + np.degrees(np.arcsin(thrust_l / norm))
        pitch = pitch0 + np.degrees(np.arctan2(-thrust_f, GRAVITY_MPS2))
        return _Attitude(roll, pitch, fwd, lat, np.zeros(t.size))

    return replace(rec, compass_form="raw", triad=_child(rng), attitude=attitude)


def _day_parked(rng, scale):
    """A parked vehicle or a mast for hours: still, a day-cycle temperature, long compass
    outages and interference; logged at 1–2 Hz."""
    duration = _u(rng, 10800.0, 21600.0) * scale
    episodes = _disturbances(rng, duration, (1, 3), (5.0, 40.0), (300.0, 1800.0))
    return _Recipe(duration, 10.0, _device(rng), _compass(rng, rate_hz=2.0), _day_cycle(rng, duration),
                   offset=_offset_fn(episodes), dropouts=_dropouts(rng, duration, (1, 2), (1800.0, 5400.0)),
                   heading0_deg=_u(rng, 0, 360), log_fs_hz=float(rng.choice([1.0, 2.0])))


_BUILDERS: dict[str, Callable] = {
    "warmup-telemetry": _warmup_telemetry,
    "multicopter": _multicopter,
    "vessel": _vessel,
    "sway-clean": _sway_clean,
    "chamber-bursty": _chamber_bursty,
    "drive": _drive,
    "rawmag-drive": _rawmag_drive,
    "bench-interference": _bench_interference,
    "turntable": _turntable,
    "no-temp-robot": _no_temp_robot,
    "day-parked": _day_parked,
    "held-compass": _held_compass,
    "rawmag-uncalibrated": _rawmag_uncalibrated,
    "handheld-stalls": _handheld_stalls,
    "handheld-clustered": _handheld_clustered,
    "banked-flight": _banked_flight,
    "imu-drive": _imu_drive,
    "handheld-imu": _handheld_imu,
    "quadplane": _quadplane,
    "vessel-imu": _vessel_imu,
    "multicopter-imu": _multicopter_imu,
}

#: The classes, by name, with one line each (the builders' docstrings).
CLASSES: Mapping[str, str] = MappingProxyType(
    {name: " ".join((fn.__doc__ or "").split()) for name, fn in _BUILDERS.items()}
)


# --------------------------------------------------------------------------- assembly


#: The random streams of a case, one per random source (:func:`seeded_streams`).
_STREAMS = ("recipe", "white", "bias", "rrw", "temp", "compass", "log", "scale", "acc")


def _telemetry_times(duration: float, rng: np.random.Generator) -> np.ndarray:
    """Times of a telemetry log: mostly about 1 s apart, some 0.5 s, some 2–4 s."""
    steps = np.where(rng.random(int(duration) + 10) < 0.8, rng.uniform(0.7, 1.3, int(duration) + 10),
                     rng.choice([0.5, 2.0, 3.0, 4.0], int(duration) + 10))
    t = np.cumsum(np.concatenate([[0.0], steps]))
    return t[t <= duration]


def _logged_rows(rec: _Recipe, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Indices of the grid rows the logger keeps."""
    if rec.telemetry:
        idx = np.unique(np.searchsorted(t, _telemetry_times(rec.duration_s, rng)))
        return idx[idx < t.size]
    keep = np.ones(t.size, dtype=bool)
    if rec.log_fs_hz is not None and rec.log_fs_hz < rec.fs_sim_hz:
        step = max(1, int(round(rec.fs_sim_hz / rec.log_fs_hz)))
        keep[:] = False
        keep[::step] = True
    if rec.records:
        keep &= in_records(t, rec.records)
    if rec.stalls:
        keep &= ~_stalled(t, rng)
    return np.flatnonzero(keep)


def _stalled(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The rows a logger that stalls loses (a serial link's buffer full, a card's write): 50–250
    ms of rows after every 0.2–1.5 s of rows."""
    lost = np.zeros(t.size, dtype=bool)
    at = _u(rng, 0.2, 1.5)
    while at < t[-1]:
        stall = _u(rng, 0.05, 0.25)
        lost[np.searchsorted(t, at):np.searchsorted(t, at + stall)] = True
        at += stall + _u(rng, 0.2, 1.5)
    return lost


def _clustered_stamps(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The times a logger writes for rows sampled at ``t`` when it stamps them as they arrive
    (a serial link's buffer read now and then): clusters of 4–10 rows (the last ones join the
    last cluster), 1–2.5 ms apart, each cluster stamped from its last row's true time on."""
    stamped = np.empty_like(t)
    i = 0
    while i < t.size:
        n = int(rng.integers(4, 11))
        n = t.size - i if t.size - i - n < 4 else n
        stamped[i:i + n] = t[i + n - 1] + np.arange(n) * _u(rng, 0.001, 0.0025)
        i += n
    return stamped


def _held(t, heading, mask, dropouts, jitter_deg, rng) -> np.ndarray:
    """The compass heading on every row: each sample held until the next (none before the
    first, none in an outage), plus white jitter of ``jitter_deg`` per row, wrapped."""
    out = np.full(t.size, np.nan)
    last = np.maximum.accumulate(np.where(mask, np.arange(t.size), -1))
    seen = last >= 0
    if seen.any():
        out[seen] = wrap_360(heading[last[seen]] + jitter_deg * rng.standard_normal(int(seen.sum())))
    for start, dur in dropouts:
        out[(t >= start) & (t < start + dur)] = np.nan
    return out


#: The gyro's scale-factor error: standard deviation at 25 degC and bound (fractions), and the
#: standard deviation of its temperature coefficient (per degC).
SF_SD, SF_MAX, SF_TC_SD = 0.008, 0.025, 1e-4
#: The range of a logged accelerometer's white noise, g per sample (drawn log-uniform per run).
ACC_NOISE_G = (0.002, 0.03)


def _accelerometer_noise(n: int, rng: np.random.Generator) -> np.ndarray:
    """White noise (n, 3), g, on every axis of a logged accelerometer: its standard deviation drawn
    log-uniform from ACC_NOISE_G per run, from a quiet MEMS part's few mg at a logging rate's
    bandwidth to a vehicle's vibration (``docs/simulator.md``)."""
    lo, hi = ACC_NOISE_G
    sd = math.exp(rng.uniform(math.log(lo), math.log(hi)))
    return sd * rng.standard_normal((n, 3))


def _scale_factor_error(temp_c: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The gyro's scale-factor error at each temperature (a fraction: the gyro reads
    ``(1 + error)`` times the rate): a MEMS gyro's sensitivity tolerance at 25 degC, plus a
    linear temperature coefficient (``docs/simulator.md``)."""
    sf0 = float(np.clip(SF_SD * rng.standard_normal(), -SF_MAX, SF_MAX))
    return sf0 + SF_TC_SD * rng.standard_normal() * (np.asarray(temp_c, float) - 25.0)


def _coordinated(rec: _Recipe, t, rows, rate, temp_true, temp_rate) -> tuple[np.ndarray, np.ndarray, dict]:
    """The roll (deg), lateral acceleration (m/s²) and x/y gyro columns of the logged ``rows`` of a
    flying body (``rec.airspeed``): in a coordinated turn the bank is ``atan(V ψ̇ / g)``; the body
    rates are those of ZYX Euler kinematics at the constant pitch (``p = φ̇ − ψ̇ sin θ``,
    ``q = ψ̇ sin φ cos θ``); each x/y gyro has its own random device and noise (``rec.triad``)."""
    lat = rec.airspeed(t) * np.radians(rate)
    roll = np.degrees(np.arctan2(lat, GRAVITY_MPS2))
    return roll[rows], lat[rows], _rolling(rec, t, rows, rate, roll, temp_true, temp_rate)


def _rolling(rec: _Recipe, t, rows, rate, roll, temp_true, temp_rate) -> dict:
    """The x/y gyro columns of the logged ``rows`` of a body turning at ``rate`` whose roll
    (deg, every grid row) changes, at the constant pitch: ZYX Euler kinematics, ``p = φ̇ − ψ̇ sin θ``,
    ``q = ψ̇ sin φ cos θ``, and the z rate ``ψ̇ cos φ cos θ`` their cross-axis share comes from."""
    theta = math.radians(rec.pitch_deg)
    roll_rate = np.gradient(roll, t)[rows]
    body = {GYRO_X: roll_rate - rate[rows] * math.sin(theta),
            GYRO_Y: rate[rows] * np.sin(np.radians(roll[rows])) * math.cos(theta)}
    rate_z = rate[rows] * np.cos(np.radians(roll[rows])) * math.cos(theta)
    return _xy_gyros(rec, t, rows, body, temp_true, temp_rate, rate_z)


def _wobbling(rec: _Recipe, t, rows, rate, temp_true, temp_rate) -> tuple[np.ndarray, dict]:
    """The roll (deg) and x/y gyro columns of the logged ``rows`` of a hand-held body whose roll
    is ``rec.wobble`` at the constant pitch (:func:`_rolling`)."""
    roll = rec.wobble(t)
    return roll[rows], _rolling(rec, t, rows, rate, roll, temp_true, temp_rate)


def _attitude_rates(t, rows, rate, att: _Attitude) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body rates (deg/s) of the logged ``rows`` of a body turning at the heading rate ``rate``
    whose roll and pitch change (``att``, every grid row): ZYX Euler kinematics,
    ``p = φ̇ − ψ̇ sin θ``, ``q = θ̇ cos φ + ψ̇ sin φ cos θ``, ``r = −θ̇ sin φ + ψ̇ cos φ cos θ``."""
    phi, theta = np.radians(att.roll_deg[rows]), np.radians(att.pitch_deg[rows])
    roll_rate, pitch_rate = np.gradient(att.roll_deg, t)[rows], np.gradient(att.pitch_deg, t)[rows]
    psi = rate[rows]
    return (roll_rate - psi * np.sin(theta),
            pitch_rate * np.cos(phi) + psi * np.sin(phi) * np.cos(theta),
            -pitch_rate * np.sin(phi) + psi * np.cos(phi) * np.cos(theta))


def _mounted(rec: _Recipe, t, rows, rate, temp_true, temp_rate) -> dict:
    """The x/y gyro columns of the logged ``rows`` of a ground vehicle whose unit is mounted at the
    constant roll and pitch of ``rec``, turning about the vertical: ``p = −ψ̇ sin θ``,
    ``q = ψ̇ sin φ cos θ`` (ZYX Euler kinematics at a constant tilt)."""
    phi, theta = math.radians(rec.roll_deg), math.radians(rec.pitch_deg)
    body = {GYRO_X: -rate[rows] * math.sin(theta), GYRO_Y: rate[rows] * math.sin(phi) * math.cos(theta)}
    return _xy_gyros(rec, t, rows, body, temp_true, temp_rate, rate[rows] * math.cos(phi) * math.cos(theta))


#: The x/y gyros' cross-axis sensitivity to the z rate: standard deviation and bound (fractions;
#: MEMS datasheets give up to ±2 %, a mounting misalignment of a degree adds 1.7 %).
CROSS_AXIS_SD, CROSS_AXIS_MAX = 0.01, 0.03


def _xy_gyros(rec: _Recipe, t, rows, body: dict, temp_true, temp_rate, rate_z) -> dict:
    """The x/y gyros' readings of the body rates ``body`` (deg/s, the logged rows): each its own
    random device and noise (``rec.triad``; times ``rec.vibration``), a scale-factor error as the z gyro's
    (:func:`_scale_factor_error`) and a share of the z rate ``rate_z`` (deg/s, the logged rows:
    cross-axis sensitivity and misalignment, :data:`CROSS_AXIS_SD`)."""
    trng = rec.triad()
    fs = rec.fs_sim_hz
    vib = rec.vibration(t[rows]) if rec.vibration is not None else 1.0
    error = {}
    for name in (GYRO_X, GYRO_Y):
        dev = _device(trng)
        bias_rng, rrw_rng, white_rng = (np.random.default_rng(int(trng.integers(2**63))) for _ in range(3))
        bias = true_bias(dev, t, 1.0 / fs, temp_true, temp_rate, bias_rng, rrw_rng)
        error[name] = bias[rows] + dev.white_sigma_dps(fs) * vib * white_rng.standard_normal(rows.size)
    for name in (GYRO_X, GYRO_Y):  # drawn after the devices, which keep their draws
        sf = _scale_factor_error(temp_true[rows], trng)
        cross = float(np.clip(CROSS_AXIS_SD * trng.standard_normal(), -CROSS_AXIS_MAX, CROSS_AXIS_MAX))
        body[name] = (1.0 + sf) * body[name] + cross * rate_z + error[name]
    return body


def generate(cls: str, seed: int, *, duration_scale: float = 1.0) -> GeneratedCase:
    """Generate the log of one case.

    Parameters
    ----------
    cls : str
        One of :data:`CLASSES`.
    seed : int
        A seed of a split (:func:`seeds`); the same ``(cls, seed)`` gives the same log.
    duration_scale : float
        Every length of the run times this (for quick tests; the Monte Carlo uses 1).
    """
    if cls not in _BUILDERS:
        raise ConfigError(f"unknown scenario class {cls!r}; choose from: {', '.join(_BUILDERS)}")
    split_of(int(seed))
    if not (isinstance(duration_scale, (int, float)) and math.isfinite(duration_scale) and duration_scale > 0):
        raise ConfigError(f"duration_scale must be a positive number, got {duration_scale!r}")
    rng = seeded_streams([zlib.crc32(cls.encode()), int(seed)], _STREAMS)
    rec = _BUILDERS[cls](rng["recipe"], float(duration_scale))
    fs = rec.fs_sim_hz
    n = int(math.floor(rec.duration_s * fs)) + 1
    t = np.arange(n) / fs
    temp_true = rec.temp(t)
    temp_rate = np.gradient(temp_true, t) if n > 1 else np.zeros(n)
    rate = rec.rate(t)
    heading_true = true_heading(t, rate, rec.heading0_deg)
    dev = rec.device
    bias = true_bias(dev, t, 1.0 / fs, temp_true, temp_rate, rng["bias"], rng["rrw"])
    rows = _logged_rows(rec, t, rng["log"])
    if rows.size < 3:
        raise ConfigError(f"class {cls!r}, seed {seed}: fewer than 3 logged rows; use a larger duration_scale")
    tl = t[rows]
    sigma = dev.white_sigma_dps(fs) * (rec.vibration(tl) if rec.vibration is not None else 1.0)
    roll, accel_lat, xy = rec.roll_deg, rec.accel_lat(tl) if rec.accel_lat is not None else None, {}
    pitch, accel_fwd, accel_down = rec.pitch_deg, rec.accel_fwd(tl) if rec.accel_fwd is not None else None, None
    if rec.attitude is not None:
        att = rec.attitude(t, rate)
        roll, pitch, accel_fwd, accel_lat, accel_down = (a[rows] for a in att)
        rate_x, rate_y, rate_z = _attitude_rates(t, rows, rate, att)
        xy = _xy_gyros(rec, t, rows, {GYRO_X: rate_x, GYRO_Y: rate_y}, temp_true, temp_rate, rate_z)
    elif rec.airspeed is not None:
        roll, accel_lat, xy = _coordinated(rec, t, rows, rate, temp_true, temp_rate)
    elif rec.wobble is not None:
        roll, xy = _wobbling(rec, t, rows, rate, temp_true, temp_rate)
    elif rec.triad is not None:
        xy = _mounted(rec, t, rows, rate, temp_true, temp_rate)
    sf = _scale_factor_error(temp_true[rows], rng["scale"])
    if rec.attitude is None:  # a constant pitch: the z rate is the heading rate's share along z
        body = (np.cos(np.radians(roll)) if np.ndim(roll) else math.cos(math.radians(roll))) \
            * math.cos(math.radians(rec.pitch_deg))
        gyro = body * (1.0 + sf) * rate[rows]
    else:
        gyro = (1.0 + sf) * rate_z
    gyro = gyro + bias[rows] + sigma * rng["white"].standard_normal(rows.size)
    temp = temperature_reading(temp_true, dev, rng["temp"])[rows]
    if rec.temp_channel_c is not None:
        temp = np.full(rows.size, float(rec.temp_channel_c))
    offset = rec.offset(tl) if rec.offset is not None else np.zeros(rows.size)
    zero = np.zeros(rows.size)
    motion = Motion(temp_c=temp_true[rows], temp_rate_cps=temp_rate[rows], heading_rate_dps=rate[rows],
                    heading0_deg=rec.heading0_deg, roll_deg=roll, pitch_deg=pitch,
                    accel_fwd_mps2=accel_fwd if accel_fwd is not None else zero,
                    accel_lat_mps2=accel_lat if accel_lat is not None else zero, accel_down_mps2=accel_down,
                    interference_offset_deg=offset, compass_dropouts=rec.dropouts)
    mask = np.ones(rows.size, dtype=bool) if rec.telemetry else compass_rows(tl, rec.compass.rate_hz)
    heading, mag, acc = compass_columns(tl, heading_true[rows], motion, rec.compass, mask, rng["compass"])
    if rec.held_jitter_deg is not None:
        heading = _held(tl, heading, mask, rec.dropouts, rec.held_jitter_deg, rng["compass"])
    cols = {T: _clustered_stamps(tl, rng["log"]) if rec.clusters else tl, GYRO_Z: gyro, TEMP: temp, **xy}
    if rec.compass_form == "heading":
        cols[HEADING] = heading
    elif rec.compass_form == "raw":
        cols.update({name: mag[:, i] for i, name in enumerate(MAG_COLS)})
        acc = acc + _accelerometer_noise(rows.size, rng["acc"])
        cols.update({name: acc[:, i] for i, name in enumerate(ACC_COLS)})
    cols.update({REF_HEADING: wrap_360(heading_true[rows]), TRUE_BIAS_Z: bias[rows], TRUE_RATE_Z: rate[rows],
                 TRUE_COMPASS_OFFSET: offset})
    log = pd.DataFrame(cols)
    log.attrs = {"class": cls, "seed": int(seed), "split": split_of(int(seed)), "duration_s": float(rec.duration_s),
                 "fs_sim_hz": fs, "compass_form": rec.compass_form, "telemetry": rec.telemetry,
                 "bursts": len(rec.records)}

    def calibration() -> pd.DataFrame:
        from gyrodrift.simulate.scenarios import simulate

        return simulate("calibration", seed=int(seed) % (2**31), duration_s=7200.0, fs_hz=10.0, device=dev,
                        compass=replace(rec.compass, rate_hz=min(rec.compass.rate_hz, 10.0)))

    return GeneratedCase(cls, int(seed), log, dev, rec.compass, calibration)


def truth_labels(log: pd.DataFrame) -> pd.DataFrame:
    """Per row of a generated log: ``disturbed`` (a compass sample with interference above
    :data:`DISTURBED_DEG`), ``turning`` (true rate above :data:`TURNING_DPS`) and ``still``
    (true rate exactly 0), as bools."""
    has_compass = log[HEADING].notna() if HEADING in log else log[MAG_COLS[0]].notna() if MAG_COLS[0] in log \
        else pd.Series(False, index=log.index)
    rate = log[TRUE_RATE_Z].to_numpy(float)
    return pd.DataFrame({
        "disturbed": has_compass.to_numpy() & (np.abs(log[TRUE_COMPASS_OFFSET].to_numpy(float)) > DISTURBED_DEG),
        "turning": np.abs(rate) > TURNING_DPS,
        "still": rate == 0.0,
    }, index=log.index)
