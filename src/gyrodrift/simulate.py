"""Deterministic, seeded simulator of gyro + compass logs with truth columns.

The simulator writes logs in the gyrodrift input contract (:mod:`gyrodrift.conventions`)
plus truth columns, for tests, the demo and the experiments of Feng, Li, Zhang (2015),
Section 4. Every scenario is built the same way:

1. a **motion**: true temperature ``T(t)`` (degC) with its exact rate ``T'(t)``
   (degC/s), the true heading rate (deg/s) and a constant mounting attitude;
2. the true heading is the trapezoid integral of the true heading rate at the sample
   times (so ``ref_heading`` and the true rate agree to rounding error);
3. the common error model: :class:`DeviceModel` for the gyro and temperature sensor,
   :class:`CompassModel` for the compass.

The gyro drift is deliberately **not** the paper's ``a*T + b*T' + c`` (eq. 2): it is a
cubic in temperature plus a rate term, a heating/cooling hysteresis and stochastic
bias terms (see :meth:`DeviceModel.drift`), so a filter that assumes eq. (2) has to
track slowly changing parameters, as on a real sensor.

The gyro scale factor is exactly 1 except in the ``scale-factor`` scenario (Section
4.3: the static heating run with full turns on a turntable), where it changes by
about 3 % with temperature (:meth:`DeviceModel.scale_factor`).

Output columns
--------------
==================  ========  =====================================================
column              unit      meaning
==================  ========  =====================================================
``t``               s         sample time, ``k / fs_hz``
``gyro_z``          deg/s     raw gyro: SF × true body rate + drift + white noise
``temp``            degC      sensor temperature reading (noise, quantisation)
``heading``         deg       compass heading in [0, 360); NaN between compass samples
``ref_heading``     deg       true heading in [0, 360) (a perfect FOG reference)
``true_bias_z``     deg/s     true drift (deterministic + bias instability + RRW)
``true_sf``         --        true gyro scale factor ``SF(T)``; only in ``scale-factor``
                              or when a device scale-factor coefficient is non-zero
``mag_x/y/z``       µT        ``raw_mag=True`` only: FRD body field, NaN off compass rows
``acc_x/y/z``       g         ``raw_mag=True`` only: FRD specific force (still: z = -1)
==================  ========  =====================================================

The ``heading`` column is always the tilt-compensated heading
(:func:`gyrodrift.compass.tilt_compensated_heading`) of the simulated field and
specific force, whether or not the raw columns are written. With
``CompassModel.kinematic_tilt`` the accelerometer also feels the vehicle's
acceleration (braking, cornering), which tilts the computed heading, as on a real
strapdown compass. The Earth's rotation (at most 0.004 deg/s) is not simulated: it
would be a constant part of the drift.

Randomness: one :class:`numpy.random.SeedSequence` of ``seed`` is split into
independent streams (trajectory, gyro white noise, bias instability, rate random
walk, temperature noise, compass noise), so switching one noise term off leaves the
others unchanged.

Examples
--------
>>> df = simulate("static", seed=1, duration_s=120.0)
>>> list(df.columns)
['t', 'gyro_z', 'temp', 'heading', 'ref_heading', 'true_bias_z']
>>> int(df["heading"].notna().sum())  # 10 Hz compass over 120 s, both ends included
1201
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Callable

import numpy as np
import pandas as pd
from scipy.integrate import cumulative_trapezoid
from scipy.interpolate import PchipInterpolator
from scipy.signal import lfilter

from gyrodrift.compass import tilt_compensated_heading
from gyrodrift.conventions import (
    ACC_COLS,
    GYRO_Z,
    HEADING,
    MAG_COLS,
    REF_HEADING,
    TEMP,
    TRUE_BIAS_Z,
    T,
    wrap_360,
)
from gyrodrift.errors import ConfigError

__all__ = [
    "DeviceModel",
    "CompassModel",
    "Motion",
    "SCENARIOS",
    "DEFAULT_DURATION_S",
    "GRAVITY_MPS2",
    "simulate",
    "static_temperature",
    "vehicle_temperature",
    "calibration_temperature",
    "interference_windows_static",
    "scenario_static",
    "scenario_static_outages",
    "scenario_vehicle",
    "scenario_calibration",
    "scenario_scale_factor",
    "rotation_plan",
    "SCENARIO_SCALE_FACTOR_PPM",
    "TRUE_SF",
]

#: Truth column of the gyro scale factor (unitless), written when SF is not ≡ 1.
TRUE_SF = "true_sf"

#: Scale-factor coefficients (:class:`DeviceModel` ``sf_*`` fields) of each scenario
#: that sets them; a device coefficient left ``None`` takes this value (else 0).
#: ``scale-factor``: 1 % high at 25 degC (a residual initial calibration error) and
#: ``SF(T) - SF(23 degC)`` = 3.1 % at 58 degC: about the ±3 % sensitivity change over
#: temperature of the ADXRS623 datasheet (Feng et al. 2015, Table 1), over the span of
#: the static heating run, slightly curved (quadratic term) so that a linear SF model
#: must keep adapting.
SCENARIO_SCALE_FACTOR_PPM: dict[str, dict[str, float]] = {
    "scale-factor": {"sf_ppm": 10000.0, "sf_ppm_per_c": 700.0, "sf_ppm_per_c2": 6.0},
}

#: Standard gravity, m/s² (converts kinematic acceleration to g).
GRAVITY_MPS2 = 9.80665

#: Longest time the unit stands still at constant temperature at the start, s.
_HOLD_S = 60.0


def _finite(name: str, value, owner: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConfigError(f"{owner}.{name} must be a finite number, got {value!r}")
    return float(value)


def _nonneg(name: str, value, owner: str) -> float:
    v = _finite(name, value, owner)
    if v < 0:
        raise ConfigError(f"{owner}.{name} must be >= 0, got {value!r}")
    return v


def _positive(name: str, value, owner: str) -> float:
    v = _finite(name, value, owner)
    if v <= 0:
        raise ConfigError(f"{owner}.{name} must be > 0, got {value!r}")
    return v


# --------------------------------------------------------------------------- device


@dataclass(frozen=True, kw_only=True)
class DeviceModel:
    """Error model of the heading-axis MEMS gyro and its temperature sensor.

    Defaults resemble an ADXRS623 (Feng et al. 2015, Table 1): white noise density
    0.04 deg/s/√Hz and a drift that changes by about 1 deg/s between 23 and 58 degC.

    The gyro reads ``gyro_z = SF(T) * true_rate + true_bias_z + white``, with

    ``true_bias_z = drift(T, T') + gauss_markov + rate_random_walk``

    and the scale factor ``SF(T)`` of :meth:`scale_factor` (exactly 1 unless a
    scale-factor coefficient is non-zero: only the ``scale-factor`` scenario sets them
    by default, Section 4.3).

    where :meth:`drift` is the deterministic part (a function of the *true* die
    temperature ``T`` and its true rate ``T'``), ``gauss_markov`` a first-order
    Gauss–Markov process (bias instability) and ``rate_random_walk`` integrated white
    noise. ``white`` has the per-sample standard deviation
    ``noise_density_dps_rthz * sqrt(fs_hz)``.

    Attributes
    ----------
    noise_density_dps_rthz : float
        Angle random walk / white rate noise density, deg/s/√Hz.
    c0_dps : float
        Drift at ``t_ref_c`` with a constant temperature, deg/s.
    c1_dps_per_c : float
        Linear temperature coefficient, deg/s/degC.
    c2_dps_per_c2 : float
        Quadratic temperature coefficient, deg/s/degC².
    c3_dps_per_c3 : float
        Cubic temperature coefficient, deg/s/degC³.
    t_ref_c : float
        Reference temperature of the polynomial, degC.
    k_rate_dps_per_cps : float
        Drift per unit temperature rate, deg/s per degC/s (thermal gradient effect).
    hyst_dps : float
        Heating/cooling hysteresis: drift offset ``+hyst_dps`` while heating and
        ``-hyst_dps`` while cooling, deg/s.
    hyst_rate_cps : float
        Temperature rate over which the hysteresis switches sign (tanh scale), degC/s.
    bias_instability_dps : float
        Stationary standard deviation of the Gauss–Markov bias, deg/s (0 = off).
    bias_tau_s : float
        Correlation time of the Gauss–Markov bias, s.
    rate_random_walk_dps_rts : float
        Rate random walk coefficient, deg/s/√s: the bias random walk has standard
        deviation ``rate_random_walk_dps_rts * sqrt(t)`` after ``t`` seconds (0 = off).
    temp_noise_c : float
        Standard deviation of the temperature reading noise, degC (0 = off).
    temp_quant_c : float
        Quantisation step of the temperature reading, degC (0 = off). Deterministic:
        kept by :meth:`noiseless` and :meth:`scale_noise`.
    sf_ppm : float or None
        Scale-factor error at ``t_ref_c``, ppm (parts per million of the true rate).
    sf_ppm_per_c : float or None
        Linear temperature coefficient of the scale factor, ppm/degC.
    sf_ppm_per_c2 : float or None
        Quadratic temperature coefficient of the scale factor, ppm/degC².

        ``None`` (the default of all three) means "the scenario's value": 0 in every
        scenario except ``scale-factor``, which uses ``SCENARIO_SCALE_FACTOR_PPM['scale-factor']``
        (about 3 % over 23–58 degC, the ADXRS623 datasheet's sensitivity change over
        temperature, Table 1). Give numbers (e.g. 0.0) to override the scenario.
        Deterministic: kept by :meth:`noiseless` and :meth:`scale_noise`.
    """

    noise_density_dps_rthz: float = 0.04
    c0_dps: float = 0.15
    c1_dps_per_c: float = 0.022
    c2_dps_per_c2: float = 3.0e-4
    c3_dps_per_c3: float = -3.0e-6
    t_ref_c: float = 25.0
    k_rate_dps_per_cps: float = 5.0
    hyst_dps: float = 0.03
    hyst_rate_cps: float = 0.002
    bias_instability_dps: float = 0.002
    bias_tau_s: float = 300.0
    rate_random_walk_dps_rts: float = 2.0e-5
    temp_noise_c: float = 0.02
    temp_quant_c: float = 0.0625
    sf_ppm: float | None = None
    sf_ppm_per_c: float | None = None
    sf_ppm_per_c2: float | None = None

    #: The stochastic terms: zeroed by :meth:`noiseless`, scaled by :meth:`scale_noise`.
    _NOISE_FIELDS = (
        "noise_density_dps_rthz",
        "bias_instability_dps",
        "rate_random_walk_dps_rts",
        "temp_noise_c",
    )

    #: The scale-factor coefficients (None: the scenario's value).
    _SF_FIELDS = ("sf_ppm", "sf_ppm_per_c", "sf_ppm_per_c2")

    def __post_init__(self):
        for f in fields(self):
            if f.name in self._SF_FIELDS and getattr(self, f.name) is None:
                continue
            _finite(f.name, getattr(self, f.name), "DeviceModel")
        for name in (*self._NOISE_FIELDS, "temp_quant_c"):
            _nonneg(name, getattr(self, name), "DeviceModel")
        for name in ("bias_tau_s", "hyst_rate_cps"):
            _positive(name, getattr(self, name), "DeviceModel")

    @classmethod
    def noiseless(cls, **overrides) -> "DeviceModel":
        """The default model with every stochastic term zero, then ``overrides`` applied.

        The temperature quantisation is deterministic and kept; pass
        ``temp_quant_c=0.0`` for an exact temperature reading.

        Examples
        --------
        >>> DeviceModel.noiseless().noise_density_dps_rthz
        0.0
        >>> DeviceModel.noiseless(noise_density_dps_rthz=0.04).bias_instability_dps
        0.0
        """
        return replace(cls().scale_noise(0.0), **overrides)

    def scale_noise(self, factor: float) -> "DeviceModel":
        """A copy with all stochastic terms multiplied by ``factor`` (>= 0; 0 = off)."""
        factor = _nonneg("scale_noise factor", factor, "DeviceModel")
        return replace(self, **{n: getattr(self, n) * factor for n in self._NOISE_FIELDS})

    def drift(self, temp_true_c, temp_rate_true_cps):
        """Deterministic drift, deg/s, of the true temperature and its true rate.

        ``x = T - t_ref_c``;
        ``drift = c0 + c1*x + c2*x**2 + c3*x**3 + k_rate*T' + hyst*tanh(T'/hyst_rate)``

        Parameters
        ----------
        temp_true_c : array_like
            True die temperature ``T``, degC.
        temp_rate_true_cps : array_like
            True temperature rate ``T'``, degC/s.

        Returns
        -------
        ndarray
            Drift, deg/s.

        Examples
        --------
        >>> float(DeviceModel().drift(25.0, 0.0))
        0.15
        """
        x = np.asarray(temp_true_c, dtype=float) - self.t_ref_c
        rate = np.asarray(temp_rate_true_cps, dtype=float)
        poly = self.c0_dps + x * (self.c1_dps_per_c + x * (self.c2_dps_per_c2 + x * self.c3_dps_per_c3))
        return poly + self.k_rate_dps_per_cps * rate + self.hyst_dps * np.tanh(rate / self.hyst_rate_cps)

    def white_sigma_dps(self, fs_hz: float) -> float:
        """Per-sample standard deviation of the white rate noise, deg/s."""
        return self.noise_density_dps_rthz * math.sqrt(fs_hz)

    def scale_factor(self, temp_true_c):
        """Gyro scale factor (unitless) at the true temperature: measured/true rate.

        ``x = T - t_ref_c``;
        ``SF = 1 + 1e-6 * (sf_ppm + sf_ppm_per_c*x + sf_ppm_per_c2*x**2)``

        A coefficient that is ``None`` counts as 0 here; :func:`simulate` first
        replaces ``None`` by the scenario's value. With all coefficients 0 the result
        is exactly 1.0.

        Parameters
        ----------
        temp_true_c : array_like
            True die temperature ``T``, degC.

        Returns
        -------
        ndarray
            Scale factor, unitless.

        Examples
        --------
        >>> float(DeviceModel().scale_factor(40.0))
        1.0
        >>> round(float(DeviceModel(sf_ppm=1e4, sf_ppm_per_c=700.0).scale_factor(35.0)), 6)
        1.017
        """
        s0, s1, s2 = (0.0 if getattr(self, n) is None else getattr(self, n) for n in self._SF_FIELDS)
        x = np.asarray(temp_true_c, dtype=float) - self.t_ref_c
        return 1.0 + 1e-6 * (s0 + x * (s1 + x * s2))

    def has_scale_factor_error(self) -> bool:
        """True when some scale-factor coefficient is set and non-zero (SF not ≡ 1)."""
        return any(getattr(self, n) not in (None, 0.0) for n in self._SF_FIELDS)

    def with_scenario_scale_factor(self, scenario: str) -> "DeviceModel":
        """A copy with each ``None`` scale-factor coefficient set to the scenario's value.

        Examples
        --------
        >>> DeviceModel().with_scenario_scale_factor("static").sf_ppm
        0.0
        >>> DeviceModel(sf_ppm=0.0).with_scenario_scale_factor("scale-factor").sf_ppm
        0.0
        """
        defaults = SCENARIO_SCALE_FACTOR_PPM.get(scenario, {})
        return replace(
            self,
            **{n: float(defaults.get(n, 0.0)) for n in self._SF_FIELDS if getattr(self, n) is None},
        )


def _gauss_markov(n: int, dt_s: float, sigma: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary first-order Gauss–Markov sequence (exact discretisation)."""
    if sigma == 0.0:
        return np.zeros(n)
    phi = math.exp(-dt_s / tau_s)
    w = rng.standard_normal(n)
    # x_0 ~ N(0, sigma²); x_k = phi*x_{k-1} + sigma*sqrt(1 - phi²)*w_k
    drive = sigma * math.sqrt(1.0 - phi * phi) * w
    drive[0] = sigma * w[0]
    return lfilter([1.0], [1.0, -phi], drive)


def _random_walk(n: int, dt_s: float, coeff: float, rng: np.random.Generator) -> np.ndarray:
    """Random walk starting at 0 with increments of standard deviation coeff*sqrt(dt)."""
    if coeff == 0.0:
        return np.zeros(n)
    steps = coeff * math.sqrt(dt_s) * rng.standard_normal(n)
    steps[0] = 0.0
    return np.cumsum(steps)


def _temperature_reading(temp_true_c: np.ndarray, device: DeviceModel, rng: np.random.Generator) -> np.ndarray:
    """Sensor reading: true temperature + white noise, rounded to the quantisation step."""
    reading = temp_true_c.copy()
    if device.temp_noise_c > 0:
        reading = reading + device.temp_noise_c * rng.standard_normal(reading.size)
    if device.temp_quant_c > 0:
        reading = device.temp_quant_c * np.round(reading / device.temp_quant_c)
    return reading


# --------------------------------------------------------------------------- compass


def _check_windows(windows) -> tuple[tuple[float, float, float], ...]:
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
        start = _nonneg(f"interference[{i}] start_s", w[0], "CompassModel")
        dur = _positive(f"interference[{i}] duration_s", w[1], "CompassModel")
        off = _finite(f"interference[{i}] offset_deg", w[2], "CompassModel")
        if abs(off) >= 85.0:
            raise ConfigError(f"CompassModel.interference[{i}] offset_deg must be within ±85 deg, got {w[2]!r}")
        out.append((start, dur, off))
    return tuple(out)


@dataclass(frozen=True, kw_only=True)
class CompassModel:
    """Error model of the strapdown magnetic compass.

    The compass heading is ``true + deviation(true) + interference(t) + noise``,
    sampled at ``rate_hz`` and computed by tilt compensation
    (:func:`gyrodrift.compass.tilt_compensated_heading`) from a simulated body field
    and specific force.

    Attributes
    ----------
    noise_deg : float
        Standard deviation of the white heading noise, deg (0 = off).
    rate_hz : float
        Compass sample rate, Hz; at most the gyro rate.
    deviation_deg, deviation_phase_deg : float
        Semicircular (hard-iron) deviation ``deviation_deg * sin(h + phase)``, deg.
        A function of heading: a constant offset at rest, an error of the heading
        *change* when turning.
    deviation2_deg, deviation2_phase_deg : float
        Quadrantal (soft-iron) deviation ``deviation2_deg * sin(2h + phase2)``, deg.
    interference : tuple of (start_s, duration_s, offset_deg)
        Magnetic interference windows in addition to those of the scenario. Inside a
        window the heading offset ramps in and out (raised cosine) over
        ``min(interference_ramp_s, duration_s/4)`` and is ``offset_deg`` in between.
    interference_ramp_s : float
        Ramp time of an interference window, s.
    interference_vertical_ratio : float
        The disturbing field is ``B_h * tan(offset)`` across the horizontal Earth
        field (that rotates the heading by ``offset``) plus this fraction of it
        downwards, so field strength and dip change too.
    field_ut : float
        Earth field strength, µT.
    dip_deg : float
        Earth field dip (inclination), deg, positive = pointing down.
    kinematic_tilt : bool
        True: the accelerometer senses the vehicle acceleration as well as gravity
        (real strapdown compass; heading errors while braking and cornering).
        False: ideal attitude, gravity only.
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

    def __post_init__(self):
        for f in fields(self):
            if f.name not in ("interference", "kinematic_tilt"):
                _finite(f.name, getattr(self, f.name), "CompassModel")
        _nonneg("noise_deg", self.noise_deg, "CompassModel")
        _positive("rate_hz", self.rate_hz, "CompassModel")
        _positive("interference_ramp_s", self.interference_ramp_s, "CompassModel")
        _positive("field_ut", self.field_ut, "CompassModel")
        if not -85.0 <= self.dip_deg <= 85.0:
            raise ConfigError(f"CompassModel.dip_deg must be within ±85 deg, got {self.dip_deg!r}")
        if not isinstance(self.kinematic_tilt, bool):
            raise ConfigError(f"CompassModel.kinematic_tilt must be True or False, got {self.kinematic_tilt!r}")
        object.__setattr__(self, "interference", _check_windows(self.interference))

    @classmethod
    def noiseless(cls, **overrides) -> "CompassModel":
        """The default model with zero heading noise, then ``overrides`` applied.

        Deviation and interference are deterministic and kept; pass
        ``deviation_deg=0.0, deviation2_deg=0.0`` for a compass that reads the true
        heading.
        """
        return replace(cls(noise_deg=0.0), **overrides)

    def scale_noise(self, factor: float) -> "CompassModel":
        """A copy with the heading noise multiplied by ``factor`` (>= 0)."""
        factor = _nonneg("scale_noise factor", factor, "CompassModel")
        return replace(self, noise_deg=self.noise_deg * factor)

    def deviation(self, heading_deg):
        """Heading-dependent compass deviation, deg.

        ``deviation_deg*sin(h + deviation_phase_deg) + deviation2_deg*sin(2h + deviation2_phase_deg)``
        """
        h = np.radians(np.asarray(heading_deg, dtype=float))
        return self.deviation_deg * np.sin(h + math.radians(self.deviation_phase_deg)) + (
            self.deviation2_deg * np.sin(2.0 * h + math.radians(self.deviation2_phase_deg))
        )

    def interference_offset(self, t_s, extra_windows=()):
        """Heading offset of the interference windows at times ``t_s``, deg.

        Parameters
        ----------
        t_s : array_like
            Times, s.
        extra_windows : sequence of (start_s, duration_s, offset_deg)
            Windows added to ``self.interference`` (e.g. a scenario's).
        """
        t = np.asarray(t_s, dtype=float)
        out = np.zeros(t.shape)
        for start, dur, off in self.interference + _check_windows(extra_windows):
            ramp = min(self.interference_ramp_s, dur / 4.0)
            up = _smooth_step((t - start) / ramp)
            down = _smooth_step((t - (start + dur - ramp)) / ramp)
            out = out + off * (up - down)
        return out


def _smooth_step(x):
    """Raised-cosine step: 0 for x <= 0, 1 for x >= 1, C1 in between."""
    x = np.clip(x, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * x)


def _smooth_step_slope(x):
    """Derivative of :func:`_smooth_step` with respect to x."""
    inside = (x > 0.0) & (x < 1.0)
    return np.where(inside, 0.5 * np.pi * np.sin(np.pi * np.clip(x, 0.0, 1.0)), 0.0)


def _body_from_level(vec_level: np.ndarray, roll_deg: float, pitch_deg: float) -> np.ndarray:
    """Rotate (N, 3) vectors from the heading-aligned level frame into FRD body axes."""
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


def _compass_rows(t_s: np.ndarray, rate_hz: float) -> np.ndarray:
    """Boolean mask of the rows carrying a compass sample (first row of each tick)."""
    tick = np.floor(t_s * rate_hz + 1e-9)
    mask = np.ones(t_s.size, dtype=bool)
    mask[1:] = tick[1:] != tick[:-1]
    return mask


# --------------------------------------------------------------------------- motion


@dataclass(frozen=True, kw_only=True, eq=False)
class Motion:
    """True motion and environment of one scenario, sampled at the log times.

    Attributes
    ----------
    temp_c : ndarray
        True die temperature, degC.
    temp_rate_cps : ndarray
        Its exact time derivative, degC/s.
    heading_rate_dps : ndarray
        True heading rate, deg/s (positive = clockwise from above).
    heading0_deg : float
        True heading at the first sample, deg.
    roll_deg, pitch_deg : float
        Constant mounting attitude, deg (the body rate about z is the heading rate
        times ``cos(roll)*cos(pitch)``).
    accel_fwd_mps2, accel_lat_mps2 : ndarray
        Kinematic acceleration along the forward and right level axes, m/s².
    interference : tuple of (start_s, duration_s, offset_deg)
        Magnetic interference windows of the scenario.
    """

    temp_c: np.ndarray
    temp_rate_cps: np.ndarray
    heading_rate_dps: np.ndarray
    heading0_deg: float
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    accel_fwd_mps2: np.ndarray | None = None
    accel_lat_mps2: np.ndarray | None = None
    interference: tuple[tuple[float, float, float], ...] = field(default=())


def _hold_s(duration_s: float) -> float:
    """Still, constant-temperature start: 60 s, or 10 % of a short run."""
    return min(_HOLD_S, 0.1 * duration_s)


def _knot_profile(t_s, duration_s: float, knots_u, knots_c):
    """Temperature (degC) and its exact rate (degC/s) through knots.

    Flat at ``knots_c[0]`` for the hold time, then a monotone C1 cubic (PCHIP) through
    ``knots_c`` at fractions ``knots_u`` (0 → end of hold, 1 → end of run).
    """
    hold = _hold_s(duration_s)
    knot_t = np.concatenate([[0.0], hold + (duration_s - hold) * np.asarray(knots_u, dtype=float)])
    knot_c = np.concatenate([[knots_c[0]], np.asarray(knots_c, dtype=float)])
    spline = PchipInterpolator(knot_t, knot_c, extrapolate=True)
    t = np.asarray(t_s, dtype=float)
    return spline(t), spline.derivative()(t)


def static_temperature(t_s, duration_s: float):
    """Static heating run (Fig. 1): 23 degC, fast rise, slower rise to 58, plateau, cooling.

    Shape in fractions of the run after the hold: 23 → 46 degC by 0.16 (fast),
    → 58 by 0.40 (slower), plateau to 0.52, then exponential cooling towards 23 degC
    with a time constant of 0.15 of the run (about 24.4 degC at the end).

    Returns
    -------
    temp_c, temp_rate_cps : ndarray
    """
    cool_u = 0.52 + 0.48 * np.arange(1, 9) / 8.0
    knots_u = [0.0, 0.04, 0.10, 0.16, 0.28, 0.40, 0.52, *cool_u]
    knots_c = [23.0, 29.0, 39.0, 46.0, 53.0, 58.0, 58.0, *(23.0 + 35.0 * np.exp(-(cool_u - 0.52) / 0.15))]
    return _knot_profile(t_s, duration_s, knots_u, knots_c)


def vehicle_temperature(t_s, duration_s: float):
    """Vehicle run (Fig. 7): 26 → 37 degC, fast at first and levelling off.

    Returns
    -------
    temp_c, temp_rate_cps : ndarray
    """
    u = np.linspace(0.0, 1.0, 9)
    c = 26.0 + 11.0 * (1.0 - np.exp(-u / 0.5)) / (1.0 - math.exp(-2.0))
    return _knot_profile(t_s, duration_s, u, c)


def calibration_temperature(t_s, duration_s: float):
    """Calibration heating run: -10 → 60 degC, a nearly uniform slow ramp.

    Returns
    -------
    temp_c, temp_rate_cps : ndarray
    """
    return _knot_profile(t_s, duration_s, [0.0, 0.05, 0.95, 1.0], [-10.0, -8.25, 58.25, 60.0])


def interference_windows_static(duration_s: float) -> tuple[tuple[float, float, float], ...]:
    """The three interference windows of ``static-outages`` (Fig. 5), scaled to the run.

    For the default 3-h run: 300 s from 2160 s (rising, +20 deg), 300 s from 4860 s
    (plateau, -15 deg) and 600 s from 7560 s (cooling, +30 deg).
    """
    scale = duration_s / DEFAULT_DURATION_S["static"]
    return (
        (0.20 * duration_s, 300.0 * scale, 20.0),
        (0.45 * duration_s, 300.0 * scale, -15.0),
        (0.70 * duration_s, 600.0 * scale, 30.0),
    )


def _still(t_s, temp_c, temp_rate_cps, heading0_deg, roll_deg, pitch_deg, interference=()) -> Motion:
    zero = np.zeros(np.shape(t_s))
    return Motion(
        temp_c=temp_c,
        temp_rate_cps=temp_rate_cps,
        heading_rate_dps=zero,
        heading0_deg=heading0_deg,
        roll_deg=roll_deg,
        pitch_deg=pitch_deg,
        accel_fwd_mps2=zero,
        accel_lat_mps2=zero,
        interference=interference,
    )


def scenario_static(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """Motionless at 40 deg on a slightly tilted bench, heated 23 → 58 degC and cooled."""
    temp, rate = static_temperature(t_s, duration_s)
    return _still(t_s, temp, rate, 40.0, 0.8, -1.2)


def scenario_static_outages(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """``static`` with magnetic interference in three windows (300, 300, 600 s)."""
    temp, rate = static_temperature(t_s, duration_s)
    return _still(t_s, temp, rate, 40.0, 0.8, -1.2, interference_windows_static(duration_s))


def scenario_calibration(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """Motionless at 200 deg, heated slowly from -10 to 60 degC (calibration run)."""
    temp, rate = calibration_temperature(t_s, duration_s)
    return _still(t_s, temp, rate, 200.0, -0.5, 0.7)


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
    t = _hold_s(duration_s)
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
    return sign * peak * (_smooth_step((t_s - t0) / ramp) - _smooth_step((t_s - (t0 + dur - ramp)) / ramp))


def scenario_vehicle(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A car on a flat road: still 60 s, then rectangular loops with 90° turns.

    Straight legs of 30–120 s with a small yaw wander (at most 0.3 deg/s, scaled by
    speed), 90° turns of 5.5–7.5 s (peak 17–23 deg/s), stops of 10–40 s after 15 % of
    the legs, cruise 8 m/s, loops mostly clockwise; temperature 26 → 37 degC.
    """
    t = np.asarray(t_s, dtype=float)
    plan = _vehicle_plan(duration_s, rng)
    speed = np.zeros(t.size)
    accel = np.zeros(t.size)
    for t0, dur, delta in plan.speed_steps:
        speed += delta * _smooth_step((t - t0) / dur)
        accel += delta * _smooth_step_slope((t - t0) / dur) / dur
    rate = np.zeros(t.size)
    for t0, dur, sign in plan.turns:
        rate += _turn_rate(t, t0, dur, sign)
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


#: Rotation schedule of ``scale-factor``: period (s), ramp time (s), peak rate range (deg/s).
_SF_TURN_PERIOD_S = 120.0
_SF_TURN_RAMP_S = 2.0
_SF_TURN_PEAK_DPS = (30.0, 90.0)
_SF_TURN_DEG = 360.0


def _rotation_rate(t_s: np.ndarray, t0: float, angle_deg: float, peak_dps: float, ramp_s: float) -> np.ndarray:
    """Rate of one rotation by ``angle_deg`` (signed), deg/s: raised-cosine ramps, plateau ``peak_dps``.

    Lasts ``|angle_deg|/peak_dps + ramp_s``; the ramp pair integrates to
    ``peak_dps * (duration - ramp_s) = |angle_deg|``.
    """
    dur = abs(angle_deg) / peak_dps + ramp_s
    up = _smooth_step((t_s - t0) / ramp_s)
    down = _smooth_step((t_s - (t0 + dur - ramp_s)) / ramp_s)
    return math.copysign(peak_dps, angle_deg) * (up - down)


def rotation_plan(duration_s: float, rng: np.random.Generator) -> tuple[tuple[float, float, float], ...]:
    """The rotations of ``scale-factor``: ``(start_s, angle_deg, peak_dps)`` each.

    One full turn (±360°, so the compass deviation is the same before and after) every
    120 s, the first 60 s after the still start, alternating clockwise and
    anticlockwise, plateau rate uniform in 30–90 deg/s (from ``rng``), raised-cosine
    ramps of 2 s; the unit stands still between turns. A turn that would not end 10 s
    before the end of the run is left out.
    """
    turns = []
    t0 = _hold_s(duration_s) + 0.5 * _SF_TURN_PERIOD_S
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
    """Section 4.3: the static heating run on a level turntable with repeated full turns.

    The temperature profile of ``static`` (23 → 58 degC and back), a stable magnetic
    field (no interference windows) and the turns of :func:`rotation_plan`: the
    heading change of the gyro over a turn against the compass measures the scale
    factor, the still periods between turns the drift. The unit turns about its own
    axis (no kinematic acceleration); the gyro scale factor comes from
    ``SCENARIO_SCALE_FACTOR_PPM['scale-factor']`` unless the device sets its own.
    """
    t = np.asarray(t_s, dtype=float)
    temp, temp_rate = static_temperature(t, duration_s)
    rate = np.zeros(t.size)
    for t0, angle, peak in rotation_plan(duration_s, rng):
        rate += _rotation_rate(t, t0, angle, peak, _SF_TURN_RAMP_S)
    zero = np.zeros(t.size)
    return Motion(
        temp_c=temp,
        temp_rate_cps=temp_rate,
        heading_rate_dps=rate,
        heading0_deg=40.0,
        accel_fwd_mps2=zero,
        accel_lat_mps2=zero,
    )


#: Scenario name → motion builder ``f(t_s, duration_s, rng) -> Motion``.
SCENARIOS: dict[str, Callable[[np.ndarray, float, np.random.Generator], Motion]] = {
    "static": scenario_static,
    "static-outages": scenario_static_outages,
    "vehicle": scenario_vehicle,
    "calibration": scenario_calibration,
    "scale-factor": scenario_scale_factor,
}

#: Default run length of each scenario, s.
DEFAULT_DURATION_S: dict[str, float] = {
    "static": 3 * 3600.0,
    "static-outages": 3 * 3600.0,
    "vehicle": 40 * 60.0,
    "calibration": 2 * 3600.0,
    "scale-factor": 3 * 3600.0,
}


# --------------------------------------------------------------------------- assembly


def _streams(seed: int) -> dict[str, np.random.Generator]:
    """Independent generators of one seed, one per random source."""
    names = ("trajectory", "white", "bias", "rrw", "temp", "compass")
    children = np.random.SeedSequence(seed).spawn(len(names))
    return {name: np.random.default_rng(child) for name, child in zip(names, children)}


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
    fs = _positive("fs_hz", fs_hz, "simulate")
    duration = DEFAULT_DURATION_S[scenario] if duration_s is None else _positive("duration_s", duration_s, "simulate")
    if duration * fs < 2:
        raise ConfigError(f"simulate.duration_s must give at least 3 samples at {fs:g} Hz, got {duration_s!r}")
    if not isinstance(device, DeviceModel):
        raise ConfigError(f"device must be a DeviceModel, got {type(device).__name__}")
    if not isinstance(compass, CompassModel):
        raise ConfigError(f"compass must be a CompassModel, got {type(compass).__name__}")
    if compass.rate_hz > fs:
        raise ConfigError(f"CompassModel.rate_hz ({compass.rate_hz:g}) must not exceed fs_hz ({fs:g})")
    return duration


def _compass_columns(t, heading_true, motion: Motion, compass: CompassModel, mask, rng):
    """Compass heading (NaN off compass rows), body field (NaN off rows) and specific force."""
    n = t.size
    zero = np.zeros(n)
    fwd = motion.accel_fwd_mps2 if (compass.kinematic_tilt and motion.accel_fwd_mps2 is not None) else zero
    lat = motion.accel_lat_mps2 if (compass.kinematic_tilt and motion.accel_lat_mps2 is not None) else zero
    force_level = np.column_stack([fwd / GRAVITY_MPS2, lat / GRAVITY_MPS2, -np.ones(n)])
    acc = _body_from_level(force_level, motion.roll_deg, motion.pitch_deg)

    idx = np.flatnonzero(mask)
    psi = heading_true[idx]
    offset = compass.interference_offset(t[idx], motion.interference)
    noise = compass.noise_deg * rng.standard_normal(idx.size) if compass.noise_deg > 0 else 0.0
    apparent = psi + compass.deviation(psi) + offset + noise
    mag = np.full((n, 3), np.nan)
    mag[idx] = _body_from_level(_apparent_field_level(apparent, offset, compass), motion.roll_deg, motion.pitch_deg)

    heading = np.full(n, np.nan)
    heading[idx] = wrap_360(tilt_compensated_heading(*mag[idx].T, *acc[idx].T))
    return heading, mag, acc


def simulate(
    scenario: str,
    *,
    seed: int = 0,
    duration_s: float | None = None,
    fs_hz: float = 50.0,
    device: DeviceModel | None = None,
    compass: CompassModel | None = None,
    raw_mag: bool = False,
) -> pd.DataFrame:
    """Simulate a log in the gyrodrift input contract, with truth columns.

    Parameters
    ----------
    scenario : str
        One of :data:`SCENARIOS`: ``static``, ``static-outages``, ``vehicle``,
        ``calibration``, ``scale-factor``.
    seed : int
        Seed of all randomness (trajectory details and every noise term); the same
        seed gives an identical DataFrame.
    duration_s : float, optional
        Run length, s (default :data:`DEFAULT_DURATION_S`). Temperature profiles and
        interference windows scale with it, so a short run keeps the shape (with
        proportionally faster temperature rates); vehicle legs keep their length.
    fs_hz : float
        Gyro and temperature sample rate, Hz.
    device : DeviceModel, optional
        Gyro error model (default :class:`DeviceModel`). Scale-factor coefficients
        left ``None`` take the scenario's values (:data:`SCENARIO_SCALE_FACTOR_PPM`).
    compass : CompassModel, optional
        Compass error model (default :class:`CompassModel`); the scenario's own
        interference windows are added to its ``interference``.
    raw_mag : bool
        Also write ``mag_x, mag_y, mag_z`` (µT, FRD, NaN off compass rows) and
        ``acc_x, acc_y, acc_z`` (g, FRD specific force, every row).

    Returns
    -------
    pandas.DataFrame
        Columns ``t, gyro_z, temp, heading, ref_heading, true_bias_z``, then
        ``true_sf`` in the ``scale-factor`` scenario or whenever the scale factor is
        not ≡ 1 (+ raw columns); ``attrs`` holds ``scenario``, ``seed``,
        ``duration_s``, ``fs_hz``, and the effective ``device`` (scale-factor
        coefficients resolved) and ``compass`` models as plain dicts.

    Raises
    ------
    ConfigError
        Unknown scenario or an invalid argument.
    """
    device = DeviceModel() if device is None else device
    compass = CompassModel() if compass is None else compass
    duration = _check_args(scenario, seed, duration_s, fs_hz, device, compass)
    device = device.with_scenario_scale_factor(scenario)
    fs = float(fs_hz)
    n = int(math.floor(duration * fs + 1e-9)) + 1
    t = np.arange(n) / fs
    dt = 1.0 / fs
    rng = _streams(int(seed))

    motion = SCENARIOS[scenario](t, duration, rng["trajectory"])
    heading_true = motion.heading0_deg + cumulative_trapezoid(motion.heading_rate_dps, t, initial=0.0)
    body_rate = motion.heading_rate_dps * (
        math.cos(math.radians(motion.roll_deg)) * math.cos(math.radians(motion.pitch_deg))
    )

    bias = (
        device.drift(motion.temp_c, motion.temp_rate_cps)
        + _gauss_markov(n, dt, device.bias_instability_dps, device.bias_tau_s, rng["bias"])
        + _random_walk(n, dt, device.rate_random_walk_dps_rts, rng["rrw"])
    )
    sigma = device.white_sigma_dps(fs)
    white = sigma * rng["white"].standard_normal(n) if sigma > 0 else np.zeros(n)
    true_sf = device.scale_factor(motion.temp_c)  # exactly 1.0 unless an sf_* is non-zero
    gyro = true_sf * body_rate + bias + white
    temp = _temperature_reading(motion.temp_c, device, rng["temp"])

    mask = _compass_rows(t, compass.rate_hz)
    heading, mag, acc = _compass_columns(t, heading_true, motion, compass, mask, rng["compass"])

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
    if raw_mag:
        columns.update({name: mag[:, i] for i, name in enumerate(MAG_COLS)})
        columns.update({name: acc[:, i] for i, name in enumerate(ACC_COLS)})
    df = pd.DataFrame(columns)
    effective = replace(compass, interference=compass.interference + motion.interference)
    df.attrs = {
        "scenario": scenario,
        "seed": int(seed),
        "duration_s": float(duration),
        "fs_hz": fs,
        "device": _jsonable(asdict(device)),
        "compass": _jsonable(asdict(effective)),
    }
    return df
