"""The aiding sensors of a simulated run: the strapdown compass and the accelerometer.

:class:`CompassModel` and :func:`random_compass`; :func:`compass_columns` synthesises the
body field, the specific force and the tilt-compensated heading, :func:`triad_columns` the
x and y gyros and a noisy accelerometer. The model: ``docs/simulator.md`` (the compass).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from gyrodrift.compass import tilt_compensated_heading
from gyrodrift.conventions import ACC_COLS, TRUE_BIAS_X, TRUE_BIAS_Y, wrap_360
from gyrodrift.errors import ConfigError
from gyrodrift.simulate.checks import finite, nonneg, positive
from gyrodrift.simulate.device import TriadModel, gyro_axis
from gyrodrift.simulate.motion import Motion, smooth_pulse

__all__ = [
    "GRAVITY_MPS2", "CompassModel", "random_compass", "compass_rows", "compass_columns", "triad_columns",
]

#: Standard gravity, m/s² (converts kinematic acceleration to g).
GRAVITY_MPS2 = 9.80665


def _check_windows(windows) -> tuple[tuple[float, float, float], ...]:
    """Interference windows as float triples, checked (offsets within ±85 deg)."""
    try:
        items = [tuple(w) for w in windows]
    except TypeError:
        raise ConfigError(
            f"CompassModel.interference must be a list of (start_s, duration_s, offset_deg), got {windows!r}"
        ) from None
    out = []
    for i, w in enumerate(items):
        if len(w) != 3:
            raise ConfigError(
                f"CompassModel.interference[{i}] must be (start_s, duration_s, offset_deg), got {w!r}"
            )
        start = nonneg(f"interference[{i}] start_s", w[0], "CompassModel")
        dur = positive(f"interference[{i}] duration_s", w[1], "CompassModel")
        off = finite(f"interference[{i}] offset_deg", w[2], "CompassModel")
        if abs(off) >= 85.0:
            raise ConfigError(f"CompassModel.interference[{i}] offset_deg must be within ±85 deg, got {w[2]!r}")
        out.append((start, dur, off))
    return tuple(out)


@dataclass(frozen=True, kw_only=True)
class CompassModel:
    """Error model of the strapdown magnetic compass: ``true + deviation + interference + noise``.

    The fields (units in their names) and the field synthesis: ``docs/simulator.md`` (the compass).
    """

    noise_deg: float = 0.5
    rate_hz: float = 10.0
    deviation_deg: float = 2.0
    deviation_phase_deg: float = 30.0
    deviation2_deg: float = 0.5
    deviation2_phase_deg: float = -60.0
    interference: tuple[tuple[float, float, float], ...] = ()
    interference_ramp_s: float = 20.0
    interference_vertical_ratio: float = 0.5
    field_ut: float = 50.0
    dip_deg: float = 60.0
    kinematic_tilt: bool = True
    hard_iron_ut: tuple[float, float, float] = (0.0, 0.0, 0.0)
    soft_iron_gain: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self):
        for f in fields(self):
            if f.name not in ("interference", "kinematic_tilt", "hard_iron_ut", "soft_iron_gain"):
                finite(f.name, getattr(self, f.name), "CompassModel")
        for name in ("hard_iron_ut", "soft_iron_gain"):
            value = getattr(self, name)
            if not (isinstance(value, tuple) and len(value) == 3):
                raise ConfigError(f"CompassModel.{name} must be a tuple of three numbers (x, y, z), got {value!r}")
            object.__setattr__(self, name, tuple(finite(f"{name}[{k}]", v, "CompassModel") for k, v in enumerate(value)))
        for k, gain in enumerate(self.soft_iron_gain):
            positive(f"soft_iron_gain[{k}]", gain, "CompassModel")
        nonneg("noise_deg", self.noise_deg, "CompassModel")
        positive("rate_hz", self.rate_hz, "CompassModel")
        positive("interference_ramp_s", self.interference_ramp_s, "CompassModel")
        positive("field_ut", self.field_ut, "CompassModel")
        if not -85.0 <= self.dip_deg <= 85.0:
            raise ConfigError(f"CompassModel.dip_deg must be within ±85 deg, got {self.dip_deg!r}")
        if not isinstance(self.kinematic_tilt, bool):
            raise ConfigError(f"CompassModel.kinematic_tilt must be True or False, got {self.kinematic_tilt!r}")
        object.__setattr__(self, "interference", _check_windows(self.interference))

    @classmethod
    def noiseless(cls, **overrides) -> "CompassModel":
        """The default model with zero heading noise (deviation kept), then ``overrides``."""
        return replace(cls(noise_deg=0.0), **overrides)

    def scale_noise(self, factor: float) -> "CompassModel":
        """A copy with the heading noise multiplied by ``factor`` (>= 0)."""
        factor = nonneg("scale_noise factor", factor, "CompassModel")
        return replace(self, noise_deg=self.noise_deg * factor)

    def deviation(self, heading_deg):
        """Heading-dependent deviation, deg: ``dev*sin(h + phase) + dev2*sin(2h + phase2)``."""
        h = np.radians(np.asarray(heading_deg, dtype=float))
        return self.deviation_deg * np.sin(h + math.radians(self.deviation_phase_deg)) + (
            self.deviation2_deg * np.sin(2.0 * h + math.radians(self.deviation2_phase_deg))
        )

    def interference_offset(self, t_s, extra_windows=()):
        """Heading offset, deg, at ``t_s`` of the interference windows and ``extra_windows`` (a scenario's)."""
        t = np.asarray(t_s, dtype=float)
        out = np.zeros(t.shape)
        for start, dur, off in self.interference + _check_windows(extra_windows):
            out = out + off * smooth_pulse(t, start, start + dur, min(self.interference_ramp_s, dur / 4.0))
        return out


def random_compass(rng: np.random.Generator) -> CompassModel:
    """A plausible randomised compass for Monte Carlo runs (the draws: ``docs/simulator.md``)."""
    return CompassModel(
        noise_deg=float(rng.uniform(0.3, 0.6)),
        deviation_deg=float(rng.uniform(0.0, 3.0)),
        deviation_phase_deg=float(rng.uniform(-180.0, 180.0)),
        deviation2_deg=float(rng.uniform(0.0, 1.0)),
        deviation2_phase_deg=float(rng.uniform(-180.0, 180.0)),
    )


def _body_from_level(vec_level: np.ndarray, roll_deg, pitch_deg) -> np.ndarray:
    """Rotate (N, 3) vectors from the heading-aligned level frame into FRD body axes
    (``roll_deg`` and ``pitch_deg`` each a number, or one per vector)."""
    if np.ndim(pitch_deg):
        phi, theta = np.radians(np.asarray(roll_deg, dtype=float)), np.radians(np.asarray(pitch_deg, dtype=float))
        cp, sp, ct, st = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta)
        x, y, z = vec_level[:, 0], vec_level[:, 1], vec_level[:, 2]
        xp, zp = ct * x - st * z, st * x + ct * z
        return np.column_stack([xp, cp * y + sp * zp, -sp * y + cp * zp])
    if np.ndim(roll_deg):
        phi, theta = np.radians(np.asarray(roll_deg, dtype=float)), math.radians(pitch_deg)
        cp, sp, ct, st = np.cos(phi), np.sin(phi), math.cos(theta), math.sin(theta)
        x, y, z = vec_level[:, 0], vec_level[:, 1], vec_level[:, 2]
        xp, zp = ct * x - st * z, st * x + ct * z  # Ry(pitch)^T, then Rx(roll)^T row by row
        return np.column_stack([xp, cp * y + sp * zp, -sp * y + cp * zp])
    phi, theta = math.radians(roll_deg), math.radians(pitch_deg)
    cp, sp, ct, st = math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta)
    # body = Rx(roll)^T Ry(pitch)^T level (ZYX Euler angles, yaw already removed)
    ry_t = np.array([[ct, 0.0, -st], [0.0, 1.0, 0.0], [st, 0.0, ct]])
    rx_t = np.array([[1.0, 0.0, 0.0], [0.0, cp, sp], [0.0, -sp, cp]])
    return vec_level @ (rx_t @ ry_t).T


def _apparent_field_level(heading_app_deg, offset_deg, compass: CompassModel) -> np.ndarray:
    """Earth + interference field in the heading-aligned level frame, µT, (N, 3).

    The horizontal part points ``heading_app_deg`` anticlockwise of the body's
    forward axis (so the compass reads that heading); the interference adds
    ``B_h*tan(offset)`` horizontally and ``interference_vertical_ratio`` of that downwards.
    """
    dip = math.radians(compass.dip_deg)
    b_h, b_v = compass.field_ut * math.cos(dip), compass.field_ut * math.sin(dip)
    disturb = b_h * np.abs(np.tan(np.radians(offset_deg)))
    horiz = np.hypot(b_h, disturb)
    vert = b_v + compass.interference_vertical_ratio * disturb
    h = np.radians(heading_app_deg)
    return np.column_stack([horiz * np.cos(h), -horiz * np.sin(h), vert])


def compass_rows(t_s: np.ndarray, rate_hz: float) -> np.ndarray:
    """Rows (times ``t_s``) that carry a compass sample of ``rate_hz``: the first row of each compass tick."""
    tick = np.floor(t_s * rate_hz + 1e-9)
    mask = np.ones(t_s.size, dtype=bool)
    mask[1:] = tick[1:] != tick[:-1]
    return mask


def compass_columns(t, heading_true, motion: Motion, compass: CompassModel, mask, rng):
    """Compass heading, body field and specific force at times ``t`` of the true heading ``heading_true``.

    ``mask`` marks the compass rows (:func:`compass_rows`), ``rng`` draws one noise value per
    compass row; ``motion.compass_dropouts`` are cut after the draw.

    Returns
    -------
    heading : ndarray
        Tilt-compensated compass heading in [0, 360), deg; NaN off compass rows.
    mag : ndarray, shape (n, 3)
        FRD body field, µT; NaN off compass rows.
    acc : ndarray, shape (n, 3)
        FRD specific force, g, on every row (noise-free).
    """
    n = t.size
    zero = np.zeros(n)
    fwd = motion.accel_fwd_mps2 if (compass.kinematic_tilt and motion.accel_fwd_mps2 is not None) else zero
    lat = motion.accel_lat_mps2 if (compass.kinematic_tilt and motion.accel_lat_mps2 is not None) else zero
    down = -np.ones(n)
    if compass.kinematic_tilt and motion.accel_down_mps2 is not None:
        down = down + np.asarray(motion.accel_down_mps2, dtype=float) / GRAVITY_MPS2
    force_level = np.column_stack([fwd / GRAVITY_MPS2, lat / GRAVITY_MPS2, down])
    acc = _body_from_level(force_level, motion.roll_deg, motion.pitch_deg)

    idx = np.flatnonzero(mask)
    psi = heading_true[idx]
    offset = compass.interference_offset(t[idx], motion.interference)
    if motion.interference_offset_deg is not None:
        offset = offset + np.asarray(motion.interference_offset_deg, dtype=float)[idx]
    noise = compass.noise_deg * rng.standard_normal(idx.size) if compass.noise_deg > 0 else 0.0
    apparent = psi + compass.deviation(psi) + offset + noise
    mag = np.full((n, 3), np.nan)
    roll = np.asarray(motion.roll_deg)[idx] if np.ndim(motion.roll_deg) else motion.roll_deg
    pitch = np.asarray(motion.pitch_deg)[idx] if np.ndim(motion.pitch_deg) else motion.pitch_deg
    mag[idx] = _body_from_level(_apparent_field_level(apparent, offset, compass), roll, pitch)
    if compass.hard_iron_ut != (0.0, 0.0, 0.0) or compass.soft_iron_gain != (1.0, 1.0, 1.0):  # not calibrated
        mag[idx] = mag[idx] * np.array(compass.soft_iron_gain) + np.array(compass.hard_iron_ut)

    heading = np.full(n, np.nan)
    heading[idx] = wrap_360(tilt_compensated_heading(*mag[idx].T, *acc[idx].T))
    for start, dur in motion.compass_dropouts:  # after the noise draw: the other rows keep their noise
        out = (t >= start) & (t < start + dur)
        heading[out] = np.nan
        mag[out] = np.nan
    return heading, mag, acc


def triad_columns(t, dt, motion: Motion, triad: TriadModel, scenario: str, acc, rng) -> dict:
    """The x and y gyros of a :class:`TriadModel`, their drift truth and a noisy accelerometer.

    ``acc`` is the noise-free specific force of :func:`compass_columns`; ``rng`` the run's
    streams (``x_white, x_bias, x_rrw, y_white, y_bias, y_rrw, acc``). Returns the columns
    ``gyro_x, gyro_y, true_bias_x, true_bias_y, acc_x, acc_y, acc_z``.
    """
    n = t.size
    phi, theta = math.radians(motion.roll_deg), math.radians(motion.pitch_deg)
    body_rate = {  # body rates of a yaw rate at a constant attitude (ZYX Euler kinematics)
        "x": -math.sin(theta) * motion.heading_rate_dps,
        "y": math.sin(phi) * math.cos(theta) * motion.heading_rate_dps,
    }
    gyro, bias = {}, {}
    for axis in ("x", "y"):
        dev = getattr(triad, axis).with_scenario_scale_factor(scenario).with_scenario_memory(scenario)
        gyro[axis], bias[axis], _ = gyro_axis(dev, t, dt, 1.0 / dt, motion.temp_c, motion.temp_rate_cps,
                                              body_rate[axis], rng[f"{axis}_bias"], rng[f"{axis}_rrw"],
                                              rng[f"{axis}_white"])
    if triad.acc_noise_g > 0:
        acc = acc + triad.acc_noise_g * rng["acc"].standard_normal((n, 3))
    return {
        "gyro_x": gyro["x"],
        "gyro_y": gyro["y"],
        TRUE_BIAS_X: bias["x"],
        TRUE_BIAS_Y: bias["y"],
        **{name: acc[:, i] for i, name in enumerate(ACC_COLS)},
    }
