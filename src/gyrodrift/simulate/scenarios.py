"""The named scenarios and :func:`simulate`, which turns a scenario into a log.

A scenario is a motion builder ``f(t_s, duration_s, rng) -> Motion`` (:data:`SCENARIOS`);
:func:`simulate` samples it, integrates the true heading, applies the gyro and compass
error models, each from its own random stream, and logs it as the motion says. The
scenarios and the log: ``docs/simulator.md``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace
from typing import Callable

import numpy as np
import pandas as pd

from gyrodrift.conventions import ACC_COLS, GYRO_Z, HEADING, MAG_COLS, REF_HEADING, TEMP, TRUE_BIAS_Z, T, wrap_360
from gyrodrift.errors import ConfigError
from gyrodrift.simulate.adversarial import ADVERSARIAL_DURATION_S, ADVERSARIAL_SCENARIOS
from gyrodrift.simulate.checks import positive
from gyrodrift.simulate.device import DeviceModel, TriadModel, gyro_axis, seeded_streams, temperature_reading
from gyrodrift.simulate.motion import (
    Motion,
    add_rotation,
    calibration_temperature,
    cold_start_temperature,
    draw_wave,
    hold_s,
    hysteresis_temperature,
    in_records,
    ramp_slice,
    smooth_pulse,
    soak_ramps,
    soak_temperature,
    static_temperature,
    still_motion,
    sum_of_step_slopes,
    sum_of_steps,
    sway_rate,
    true_heading,
    vehicle_temperature,
    wave,
)
from gyrodrift.simulate.sensors import CompassModel, compass_columns, compass_rows, triad_columns

__all__ = [
    "TRUE_SF", "SCENARIOS", "DEFAULT_DURATION_S", "simulate", "interference_windows_static",
    "interference_windows_wander", "wander_offset", "soak_outages", "rotation_plan", "scenario_static",
    "scenario_static_outages", "scenario_vehicle", "scenario_calibration", "scenario_scale_factor",
    "scenario_interference_wander", "scenario_hysteresis", "scenario_cold_start", "scenario_soak",
    "scenario_vehicle_rawmag",
]

#: Truth column of the gyro scale factor (unitless), written when SF is not ≡ 1.
TRUE_SF = "true_sf"


def interference_windows_static(duration_s: float) -> tuple[tuple[float, float, float], ...]:
    """The three interference windows ``(start_s, duration_s, offset_deg)`` of ``static-outages`` (Fig. 5)."""
    scale = duration_s / DEFAULT_DURATION_S["static"]
    return (
        (0.20 * duration_s, 300.0 * scale, 20.0),
        (0.45 * duration_s, 300.0 * scale, -15.0),
        (0.70 * duration_s, 600.0 * scale, 30.0),
    )


def scenario_static(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """Motionless at 40 deg on a slightly tilted bench, heated 23 → 58 degC and cooled."""
    temp, rate = static_temperature(t_s, duration_s)
    return still_motion(t_s, temp, rate, 40.0, 0.8, -1.2)


def scenario_static_outages(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """``static`` with magnetic interference in three windows (300, 300, 600 s)."""
    temp, rate = static_temperature(t_s, duration_s)
    return still_motion(t_s, temp, rate, 40.0, 0.8, -1.2, interference=interference_windows_static(duration_s))


def scenario_calibration(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """Motionless at 200 deg, heated slowly from -10 to 60 degC (calibration run)."""
    temp, rate = calibration_temperature(t_s, duration_s)
    return still_motion(t_s, temp, rate, 200.0, -0.5, 0.7)


@dataclass(frozen=True, kw_only=True)
class _VehiclePlan:
    """Timed events of a vehicle run: speed steps (t0, dur, delta_mps), turns (t0, dur, sign)."""

    speed_steps: tuple[tuple[float, float, float], ...]
    turns: tuple[tuple[float, float, int], ...]
    wander: tuple[tuple[float, float, float], ...]  # (amplitude deg/s, period s, phase rad)
    cruise_mps: float


def _vehicle_plan(duration_s: float, rng: np.random.Generator) -> _VehiclePlan:
    """Rectangular loops after a still start: legs 30–120 s, 90° turns, occasional stops."""
    cruise, ramp = 8.0, 6.0
    t = hold_s(duration_s)
    steps = [(t, ramp, cruise)]
    turns = []
    t += ramp
    while t < duration_s:
        sign = 1 if rng.random() < 0.75 else -1  # mostly clockwise loops
        long_leg, short_leg = rng.uniform(30.0, 120.0, size=2)
        for leg in (long_leg, short_leg, long_leg, short_leg):
            t += leg * rng.uniform(0.95, 1.05)
            if rng.random() < 0.15:  # stop: brake, stand, pull away
                steps.append((t, ramp, -cruise))
                t += ramp + rng.uniform(10.0, 40.0)
                steps.append((t, ramp, cruise))
                t += ramp
            dur = rng.uniform(5.5, 7.5)
            turns.append((t, dur, sign))
            t += dur
    wander = tuple(
        (float(rng.uniform(0.04, 0.10)), float(rng.uniform(6.0, 40.0)), float(rng.uniform(0.0, 2 * np.pi)))
        for _ in range(3)
    )
    return _VehiclePlan(speed_steps=tuple(steps), turns=tuple(turns), wander=wander, cruise_mps=cruise)


def _turn_rate(t_s: np.ndarray, t0: float, dur: float, sign: int) -> np.ndarray:
    """Rate of one smooth 90° turn, deg/s: raised-cosine ramps of 0.3*dur, plateau between."""
    ramp = 0.3 * dur
    peak = 90.0 / (dur - ramp)  # each ramp pair integrates to peak*(dur - ramp)
    return sign * peak * smooth_pulse(t_s, t0, t0 + dur, ramp)


def scenario_vehicle(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A car on a flat road: still, then rectangular loops with 90° turns and stops; 26 → 37 degC."""
    t = np.asarray(t_s, dtype=float)
    plan = _vehicle_plan(duration_s, rng)
    # Every event is evaluated on its own samples only (ramp_slice): outside them it
    # adds exactly zero (accel, rate) or its full step (speed, sum_of_steps).
    speed = sum_of_steps(t, plan.speed_steps)
    accel = sum_of_step_slopes(t, plan.speed_steps)
    rate = np.zeros(t.size)
    for t0, dur, sign in plan.turns:
        turn = ramp_slice(t, t0, t0 + dur)
        rate[turn] += _turn_rate(t[turn], t0, dur, sign)
    wander = sum(a * np.cos(2 * np.pi * t / p + ph) for a, p, ph in plan.wander)
    rate = rate + wander * speed / plan.cruise_mps
    temp, temp_rate = vehicle_temperature(t, duration_s)
    return Motion(
        temp_c=temp,
        temp_rate_cps=temp_rate,
        heading_rate_dps=rate,
        heading0_deg=30.0,
        accel_fwd_mps2=accel,
        accel_lat_mps2=speed * np.radians(rate),
    )


def scenario_vehicle_rawmag(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """``vehicle`` (the same route for the same seed) logged with ``mag_*`` and ``acc_*`` and no ``heading``."""
    return replace(scenario_vehicle(t_s, duration_s, rng), compass_form="raw")


#: Rotation schedule of ``scale-factor``: period (s), ramp time (s), peak rate range (deg/s).
_SF_TURN_PERIOD_S = 120.0
_SF_TURN_RAMP_S = 2.0
_SF_TURN_PEAK_DPS = (30.0, 90.0)
_SF_TURN_DEG = 360.0


def rotation_plan(duration_s: float, rng: np.random.Generator) -> tuple[tuple[float, float, float], ...]:
    """The rotations ``(start_s, angle_deg, peak_dps)`` of ``scale-factor``: a full turn every 120 s."""
    turns = []
    t0 = hold_s(duration_s) + 0.5 * _SF_TURN_PERIOD_S
    sign = 1.0
    while True:
        peak = float(rng.uniform(*_SF_TURN_PEAK_DPS))
        if t0 + _SF_TURN_DEG / peak + _SF_TURN_RAMP_S + 10.0 > duration_s:
            break
        turns.append((t0, sign * _SF_TURN_DEG, peak))
        t0 += _SF_TURN_PERIOD_S
        sign = -sign
    return tuple(turns)


def scenario_scale_factor(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """Section 4.3: the static heating run on a level turntable with the turns of :func:`rotation_plan`."""
    t = np.asarray(t_s, dtype=float)
    temp, temp_rate = static_temperature(t, duration_s)
    rate = np.zeros(t.size)
    for t0, angle, peak in rotation_plan(duration_s, rng):
        add_rotation(rate, t, t0, angle, peak, _SF_TURN_RAMP_S)
    return still_motion(t, temp, temp_rate, 40.0, heading_rate_dps=rate)


# --------------------------------------------------------------------------- beyond the paper

#: Soak outages, one in the middle of each temperature ramp: (duration in s of the
#: 12-h run, offset deg or None = compass missing).
_SOAK_OUTAGES = ((900.0, None), (1200.0, 30.0), (900.0, None), (600.0, -25.0))


def soak_outages(duration_s: float):
    """The compass outages of ``soak``, one centred in each temperature ramp.

    Returns
    -------
    dropouts : tuple of (start_s, duration_s)
        Windows without compass samples.
    interference : tuple of (start_s, duration_s, offset_deg)
        Magnetic interference windows.
    """
    scale = duration_s / (12 * 3600.0)
    dropouts, interference = [], []
    for (start, end), (dur, offset) in zip(soak_ramps(duration_s), _SOAK_OUTAGES):
        dur *= scale
        t0 = 0.5 * (start + end) - 0.5 * dur
        if offset is None:
            dropouts.append((t0, dur))
        else:
            interference.append((t0, dur, offset))
    return tuple(dropouts), tuple(interference)


def interference_windows_wander(duration_s: float) -> tuple[tuple[float, float], ...]:
    """Where the interference of ``interference-wander`` acts: ``(start_s, duration_s)`` each."""
    scale = duration_s / (3 * 3600.0)
    return tuple((f * duration_s, d * scale) for f, d in ((0.12, 900.0), (0.32, 1200.0), (0.55, 900.0), (0.78, 1500.0)))


#: Wandering interference: ramp in/out (s), mean offset (deg), sinusoid amplitudes (deg)
#: and periods (s) of the three components of each window.
_WANDER_RAMP_S = 120.0
_WANDER_MEAN_DEG = (2.0, 6.0)
_WANDER_AMP_DEG = (1.0, 3.0)
_WANDER_PERIOD_S = (180.0, 900.0)


def wander_offset(t_s, duration_s: float, rng: np.random.Generator) -> np.ndarray:
    """Slowly wandering compass heading offset of ``interference-wander`` at ``t_s``, deg (0 outside its windows).

    ``rng`` gives a fixed number of draws per window.
    """
    t = np.asarray(t_s, dtype=float)
    out = np.zeros(t.shape)
    for start, dur in interference_windows_wander(duration_s):
        drawn = draw_wave(rng, _WANDER_MEAN_DEG, _WANDER_AMP_DEG, _WANDER_PERIOD_S)
        envelope = smooth_pulse(t, start, start + dur, min(_WANDER_RAMP_S, dur / 4.0))
        inside = envelope > 0.0
        out[inside] = out[inside] + envelope[inside] * wave(t[inside] - start, drawn)
    return out


def scenario_interference_wander(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """``static`` with magnetic interference that wanders slowly (:func:`wander_offset`) in four windows."""
    temp, rate = static_temperature(t_s, duration_s)
    still = still_motion(t_s, temp, rate, 40.0, 0.8, -1.2)
    return replace(still, interference_offset_deg=wander_offset(t_s, duration_s, rng))


def scenario_hysteresis(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A strongly nonlinear device with hysteresis (``SCENARIO_MEMORY``), motionless at 120 deg, heated and cooled."""
    temp, rate = hysteresis_temperature(t_s, duration_s)
    return still_motion(t_s, temp, rate, 120.0, -0.6, 1.0)


def scenario_cold_start(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """Cold start: motionless at 300 deg, warming from -20 to +60 degC after a cold soak."""
    temp, rate = cold_start_temperature(t_s, duration_s)
    return still_motion(t_s, temp, rate, 300.0, 1.1, 0.4)


#: Yaw sway of ``soak``: (amplitude range deg, period range s) of its two components.
_SWAY = (((10.0, 20.0), (180.0, 600.0)), ((2.0, 5.0), (60.0, 180.0)))


def scenario_soak(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A 12-h soak: slow yaw sway, temperature ramps, long compass outages during the ramps."""
    t = np.asarray(t_s, dtype=float)
    temp, temp_rate = soak_temperature(t, duration_s)
    draws = [
        (rng.uniform(*amp), 2.0 * np.pi / rng.uniform(*period), rng.uniform(0.0, 2.0 * np.pi)) for amp, period in _SWAY
    ]
    dropouts, interference = soak_outages(duration_s)
    return still_motion(t, temp, temp_rate, 70.0, 0.5, -0.8, heading_rate_dps=sway_rate(t, duration_s, draws),
                        interference=interference, compass_dropouts=dropouts)


#: Scenario name → motion builder ``f(t_s, duration_s, rng) -> Motion``.
SCENARIOS: dict[str, Callable[[np.ndarray, float, np.random.Generator], Motion]] = {
    "static": scenario_static,
    "static-outages": scenario_static_outages,
    "vehicle": scenario_vehicle,
    "calibration": scenario_calibration,
    "scale-factor": scenario_scale_factor,
    "interference-wander": scenario_interference_wander,
    "hysteresis": scenario_hysteresis,
    "cold-start": scenario_cold_start,
    "soak": scenario_soak,
    "vehicle-rawmag": scenario_vehicle_rawmag,
    **ADVERSARIAL_SCENARIOS,
}

#: Default run length of each scenario, s.
DEFAULT_DURATION_S: dict[str, float] = {
    "static": 3 * 3600.0,
    "static-outages": 3 * 3600.0,
    "vehicle": 40 * 60.0,
    "calibration": 2 * 3600.0,
    "scale-factor": 3 * 3600.0,
    "interference-wander": 3 * 3600.0,
    "hysteresis": 4 * 3600.0,
    "cold-start": 2 * 3600.0,
    "soak": 12 * 3600.0,
    "vehicle-rawmag": 40 * 60.0,
    **ADVERSARIAL_DURATION_S,
}


# --------------------------------------------------------------------------- assembly


#: The random streams of a run, one per random source (append only: :func:`seeded_streams`).
_STREAMS = ("trajectory", "white", "bias", "rrw", "temp", "compass",
            "x_white", "x_bias", "x_rrw", "y_white", "y_bias", "y_rrw", "acc")


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value


def _check_args(scenario, seed, duration_s, fs_hz, device, compass) -> float:
    if scenario not in SCENARIOS:
        raise ConfigError(f"unknown scenario {scenario!r}; valid scenarios: {', '.join(SCENARIOS)}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError(f"seed must be a non-negative integer, got {seed!r}")
    fs = positive("fs_hz", fs_hz, "simulate")
    duration = DEFAULT_DURATION_S[scenario] if duration_s is None else positive("duration_s", duration_s, "simulate")
    if duration * fs < 2:
        raise ConfigError(f"simulate.duration_s must give at least 3 samples at {fs:g} Hz, got {duration_s!r}")
    if not isinstance(device, DeviceModel):
        raise ConfigError(f"device must be a DeviceModel, got {type(device).__name__}")
    if not isinstance(compass, CompassModel):
        raise ConfigError(f"compass must be a CompassModel, got {type(compass).__name__}")
    if compass.rate_hz > fs:
        raise ConfigError(f"CompassModel.rate_hz ({compass.rate_hz:g}) must not exceed fs_hz ({fs:g})")
    return duration


def simulate(
    scenario: str,
    *,
    seed: int = 0,
    duration_s: float | None = None,
    fs_hz: float = 50.0,
    device: DeviceModel | None = None,
    compass: CompassModel | None = None,
    raw_mag: bool = False,
    triad: TriadModel | None = None,
) -> pd.DataFrame:
    """Simulate a log in the gyrodrift input contract, with truth columns (``docs/simulator.md``).

    Parameters
    ----------
    scenario : str
        One of :data:`SCENARIOS`.
    seed : int
        Seed of all randomness; the same seed gives an identical DataFrame.
    duration_s : float, optional
        Run length, s (default :data:`DEFAULT_DURATION_S`); the scenario's shape scales with it.
    fs_hz : float
        Gyro and temperature sample rate, Hz.
    device : DeviceModel, optional
        Gyro error model; ``None`` fields take the scenario's values.
    compass : CompassModel, optional
        Compass error model; the scenario's interference windows are added to its own.
    raw_mag : bool
        Also write ``mag_x..z`` (µT, FRD, NaN off compass rows) and ``acc_x..z`` (g, FRD).
    triad : TriadModel, optional
        Also write ``gyro_x, gyro_y``, ``true_bias_x, true_bias_y`` and a noisy ``acc_x..z``.

    Returns
    -------
    pandas.DataFrame
        ``t, gyro_z, temp, heading, ref_heading, true_bias_z``, ``true_sf`` when the scale
        factor is not ≡ 1, and the columns asked for; ``attrs`` say how it was made.

    Raises
    ------
    ConfigError
        Unknown scenario or an invalid argument.
    """
    device = DeviceModel() if device is None else device
    compass = CompassModel() if compass is None else compass
    duration = _check_args(scenario, seed, duration_s, fs_hz, device, compass)
    device = device.with_scenario_scale_factor(scenario).with_scenario_memory(scenario)
    fs = float(fs_hz)
    n = int(math.floor(duration * fs + 1e-9)) + 1
    t = np.arange(n) / fs
    dt = 1.0 / fs
    rng = seeded_streams(int(seed), _STREAMS)

    motion = SCENARIOS[scenario](t, duration, rng["trajectory"])
    heading_true = true_heading(t, motion.heading_rate_dps, motion.heading0_deg)
    body_rate = motion.heading_rate_dps * (
        math.cos(math.radians(motion.roll_deg)) * math.cos(math.radians(motion.pitch_deg))
    )

    gyro, bias, true_sf = gyro_axis(device, t, dt, fs, motion.temp_c, motion.temp_rate_cps, body_rate, rng["bias"],
                                    rng["rrw"], rng["white"])
    temp = temperature_reading(motion.temp_c, device, rng["temp"])
    if motion.temp_channel_c is not None:  # a channel that is not measured: one constant on every row
        temp = np.full(n, float(motion.temp_channel_c))

    mask = compass_rows(t, compass.rate_hz)
    heading, mag, acc = compass_columns(t, heading_true, motion, compass, mask, rng["compass"])

    columns = {
        T: t,
        GYRO_Z: gyro,
        TEMP: temp,
        HEADING: heading,
        REF_HEADING: wrap_360(heading_true),
        TRUE_BIAS_Z: bias,
    }
    if scenario == "scale-factor" or device.has_scale_factor_error():
        columns[TRUE_SF] = true_sf
    if triad is not None:
        columns.update(triad_columns(t, dt, motion, triad, scenario, acc, rng))
        acc = np.column_stack([columns.pop(name) for name in ACC_COLS])
    form = motion.compass_form
    if form != "heading":
        del columns[HEADING]
    if (raw_mag or form == "raw") and form != "none":
        columns.update({name: mag[:, i] for i, name in enumerate(MAG_COLS)})
    if raw_mag or triad is not None or form == "raw":
        columns.update({name: acc[:, i] for i, name in enumerate(ACC_COLS)})
    df = pd.DataFrame(columns)
    if motion.records:
        df = _logged_rows(df, t, motion.records, scenario)
    effective = replace(compass, interference=compass.interference + motion.interference)
    df.attrs = {
        "scenario": scenario,
        "seed": int(seed),
        "duration_s": float(duration),
        "fs_hz": fs,
        "device": _jsonable(asdict(device)),
        "compass": _jsonable(asdict(effective)),
    }
    if triad is not None:
        df.attrs["triad"] = _jsonable(asdict(triad))
    if motion.compass_dropouts:
        df.attrs["compass_dropouts"] = _jsonable(motion.compass_dropouts)
    if motion.records:
        df.attrs["records"] = _jsonable(motion.records)
    if motion.temp_channel_c is not None:
        df.attrs["temp_channel_c"] = float(motion.temp_channel_c)
    if form != "heading":
        df.attrs["compass_form"] = form
    return df


def _logged_rows(df: pd.DataFrame, t: np.ndarray, records, scenario: str) -> pd.DataFrame:
    """The rows of ``df`` (times ``t``) inside a record (:func:`~gyrodrift.simulate.motion.in_records`)."""
    keep = in_records(t, records)
    if not keep.any():
        raise ConfigError(f"scenario {scenario!r}: its records keep no row of the run")
    return df.loc[keep].reset_index(drop=True)
