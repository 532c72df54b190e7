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

Scenarios (:data:`SCENARIOS`, default lengths in :data:`DEFAULT_DURATION_S`): the
paper's ``static``, ``static-outages``, ``vehicle``, ``calibration`` and
``scale-factor``, and four beyond the paper:

* ``interference-wander``: ``static`` with magnetic interference whose offset wanders
  by a few degrees over minutes (:func:`wander_offset`), too slowly for a
  disagreement gate to notice;
* ``hysteresis``: a 10 → 70 → 10 degC cycle and a minor loop, with a device whose
  drift depends on the temperature history (a thermal lag and a backlash hysteresis,
  :data:`SCENARIO_MEMORY`, :meth:`DeviceModel.drift_series`);
* ``cold-start``: a warm-up from -20 to +60 degC after a cold soak;
* ``soak``: 12 h of slow yaw sway, temperature plateaus and ramps, and long compass
  outages (missing or interfered) during the ramps (:func:`soak_outages`).

:func:`random_device` and :func:`random_compass` draw randomised sensors for Monte
Carlo runs (:mod:`gyrodrift.montecarlo`).

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

from gyrodrift.compass import tilt_compensated_heading
from gyrodrift.conventions import (  # TRUE_BIAS_X/Y: the x/y drift truth of simulate(..., triad=...)
    TRUE_BIAS_X,
    TRUE_BIAS_Y,
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
    "TriadModel",
    "TRUE_BIAS_X",
    "TRUE_BIAS_Y",
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
    "SCENARIO_MEMORY",
    "hysteresis_temperature",
    "cold_start_temperature",
    "soak_temperature",
    "soak_ramps",
    "soak_outages",
    "interference_windows_wander",
    "wander_offset",
    "scenario_interference_wander",
    "scenario_hysteresis",
    "scenario_cold_start",
    "scenario_soak",
    "random_device",
    "random_compass",
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

#: Temperature-memory fields (:class:`DeviceModel` ``lag_tau_s``, ``play_dps``,
#: ``play_width_c``) of each scenario that sets them; a device field left ``None`` takes
#: this value (else the memory is off). ``hysteresis``: the sensing element lags the
#: temperature sensor by 120 s (at 0.02 degC/s the polynomial sees a temperature
#: 2.4 degC behind the reading) and a 0.15 deg/s backlash of 6 degC width: with the
#: default device, heating and cooling drifts differ by about 0.3 deg/s at the same
#: temperature, and by 0.3 deg/s (the backlash) after the temperature has stopped
#: changing.
SCENARIO_MEMORY: dict[str, dict[str, float]] = {
    "hysteresis": {"lag_tau_s": 120.0, "play_dps": 0.15, "play_width_c": 6.0},
}

#: Memory fields of every other scenario: off.
_NO_MEMORY = {"lag_tau_s": 0.0, "play_dps": 0.0, "play_width_c": 1.0}

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
    lag_tau_s : float or None
        Thermal lag of the sensing element behind the die temperature ``T`` (which the
        temperature sensor reads), s: the polynomial part of the drift is evaluated at
        ``T_lag`` with ``dT_lag/dt = (T - T_lag)/lag_tau_s``, starting at ``T_lag = T``.
        Heating, the element is colder than the reading, cooling, warmer: a hysteresis
        loop whose width grows with ``|T'|``. 0 = off.
    play_dps : float or None
        Rate-independent (backlash) hysteresis, deg/s: ``play_dps * (T - p)/(w/2)``
        where ``p`` is the play operator of ``T`` with width ``w = play_width_c``
        (``p`` follows ``T`` with a slack of ``w/2``, starting at ``p = T``). After
        heating by ``w`` or more the term is ``+play_dps``, after cooling
        ``-play_dps``, and it stays there when the temperature stops changing: the
        drift depends on the temperature *history*, not only on ``T`` and ``T'``.
        0 = off.
    play_width_c : float or None
        Width ``w`` of the play operator, degC (> 0).

        ``None`` (the default of all three) means "the scenario's value": off in every
        scenario except ``hysteresis`` (:data:`SCENARIO_MEMORY`), so the default device
        of every other scenario is unchanged. Deterministic: kept by :meth:`noiseless`
        and :meth:`scale_noise`. The memory terms need the time series, so they are in
        :meth:`drift_series`, not :meth:`drift`.
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
    lag_tau_s: float | None = None
    play_dps: float | None = None
    play_width_c: float | None = None

    #: The stochastic terms: zeroed by :meth:`noiseless`, scaled by :meth:`scale_noise`.
    _NOISE_FIELDS = (
        "noise_density_dps_rthz",
        "bias_instability_dps",
        "rate_random_walk_dps_rts",
        "temp_noise_c",
    )

    #: The scale-factor coefficients (None: the scenario's value).
    _SF_FIELDS = ("sf_ppm", "sf_ppm_per_c", "sf_ppm_per_c2")

    #: The temperature-memory (hysteresis) fields (None: the scenario's value).
    _MEMORY_FIELDS = ("lag_tau_s", "play_dps", "play_width_c")

    def __post_init__(self):
        for f in fields(self):
            if f.name in (*self._SF_FIELDS, *self._MEMORY_FIELDS) and getattr(self, f.name) is None:
                continue
            _finite(f.name, getattr(self, f.name), "DeviceModel")
        for name in (*self._NOISE_FIELDS, "temp_quant_c"):
            _nonneg(name, getattr(self, name), "DeviceModel")
        for name in ("bias_tau_s", "hyst_rate_cps"):
            _positive(name, getattr(self, name), "DeviceModel")
        if self.lag_tau_s is not None:
            _nonneg("lag_tau_s", self.lag_tau_s, "DeviceModel")
        if self.play_width_c is not None:
            _positive("play_width_c", self.play_width_c, "DeviceModel")

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

    def has_memory(self) -> bool:
        """True when a thermal lag or a play hysteresis is set and non-zero."""
        return bool(self.lag_tau_s) or bool(self.play_dps)

    def drift_series(self, t_s, temp_true_c, temp_rate_true_cps) -> np.ndarray:
        """Deterministic drift, deg/s, of a temperature time series, memory terms included.

        Without memory terms (``lag_tau_s`` and ``play_dps`` 0 or None) this is exactly
        :meth:`drift`. Otherwise the polynomial is evaluated at the lagged temperature
        (``lag_tau_s``) and the play hysteresis (``play_dps``) is added; the ``T'``
        terms use the true rate.

        Parameters
        ----------
        t_s : array_like
            Sample times, s, uniformly spaced (the simulator's grid).
        temp_true_c : array_like
            True die temperature ``T`` at ``t_s``, degC.
        temp_rate_true_cps : array_like
            True temperature rate ``T'`` at ``t_s``, degC/s.

        Returns
        -------
        ndarray
            Drift, deg/s.

        Examples
        --------
        >>> dev = DeviceModel(play_dps=0.1, play_width_c=2.0, k_rate_dps_per_cps=0.0, hyst_dps=0.0)
        >>> t = np.arange(5.0)
        >>> up = dev.drift_series(t, [25.0, 26.0, 27.0, 28.0, 29.0], np.zeros(5))
        >>> round(float(up[-1] - dev.drift(29.0, 0.0)), 6)  # heated by more than the width
        0.1
        """
        if not self.has_memory():
            return self.drift(temp_true_c, temp_rate_true_cps)
        t = np.asarray(t_s, dtype=float)
        temp = np.asarray(temp_true_c, dtype=float)
        temp_poly = temp
        if self.lag_tau_s:
            dt = (t[-1] - t[0]) / (t.size - 1) if t.size > 1 else 0.0
            temp_poly = _first_order_lag(temp, dt, self.lag_tau_s)
        out = self.drift(temp_poly, temp_rate_true_cps)
        if self.play_dps:
            half = 0.5 * self.play_width_c
            out = out + self.play_dps * (temp - _play_operator(temp, half)) / half
        return out

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

    def with_scenario_memory(self, scenario: str) -> "DeviceModel":
        """A copy with each ``None`` memory field set to the scenario's value (:data:`SCENARIO_MEMORY`).

        Scenarios other than ``hysteresis`` switch the memory off (``lag_tau_s = 0``,
        ``play_dps = 0``, ``play_width_c = 1``).

        Examples
        --------
        >>> DeviceModel().with_scenario_memory("static").has_memory()
        False
        >>> DeviceModel().with_scenario_memory("hysteresis").has_memory()
        True
        """
        defaults = {**_NO_MEMORY, **SCENARIO_MEMORY.get(scenario, {})}
        return replace(
            self,
            **{n: float(defaults[n]) for n in self._MEMORY_FIELDS if getattr(self, n) is None},
        )


@dataclass(frozen=True, kw_only=True)
class TriadModel:
    """The x and y gyros and the accelerometer, for logs of the whole gyro triad.

    Each axis has its own :class:`DeviceModel` (drift, noise; its temperature-reading
    fields are unused: the one ``temp`` column is the z model's); the defaults differ
    from the z axis and from each other in sign and size. ``gyro_x``/``gyro_y`` read
    ``SF × true body rate + true_bias_x/y + white`` with the true body rates of the
    scenario's constant mounting attitude (``p = -sinθ ψ'``, ``q = sinφ cosθ ψ'``).
    The accelerometer (``acc_x..z``, g, FRD specific force) feels the vehicle's
    acceleration (braking, cornering) as the compass does (``CompassModel.kinematic_tilt``)
    plus white noise of ``acc_noise_g`` per sample.

    Attributes
    ----------
    x, y : DeviceModel
        Error models of the roll- and pitch-axis gyros.
    acc_noise_g : float
        Standard deviation of the accelerometer noise per sample and axis, g (0 = off).
    """

    x: "DeviceModel" = field(
        default_factory=lambda: DeviceModel(
            c0_dps=-0.25, c1_dps_per_c=-0.015, c2_dps_per_c2=2.0e-4, c3_dps_per_c3=2.0e-6,
            k_rate_dps_per_cps=-3.0, hyst_dps=0.02,
        )
    )
    y: "DeviceModel" = field(
        default_factory=lambda: DeviceModel(
            c0_dps=0.10, c1_dps_per_c=0.030, c2_dps_per_c2=-2.0e-4, c3_dps_per_c3=-1.0e-6,
            k_rate_dps_per_cps=4.0, hyst_dps=-0.02,
        )
    )
    acc_noise_g: float = 0.002

    def __post_init__(self):
        for name in ("x", "y"):
            if not isinstance(getattr(self, name), DeviceModel):
                raise ConfigError(f"TriadModel.{name} must be a DeviceModel, got {type(getattr(self, name)).__name__}")
        _nonneg("acc_noise_g", self.acc_noise_g, "TriadModel")

    @classmethod
    def noiseless(cls) -> "TriadModel":
        """The default triad with every stochastic term zero (temperature quantisation kept)."""
        d = cls()
        return cls(x=d.x.scale_noise(0.0), y=d.y.scale_noise(0.0), acc_noise_g=0.0)


def _first_order_lag(x: np.ndarray, dt_s: float, tau_s: float) -> np.ndarray:
    """First-order lag of a uniformly sampled series, starting in equilibrium (``y[0] = x[0]``)."""
    if x.size == 0:
        return x.copy()
    phi = math.exp(-dt_s / tau_s)
    from scipy.signal import lfilter  # here, not at the top: scipy costs 0.4 s at start-up

    y, _ = lfilter([1.0 - phi], [1.0, -phi], x, zi=[phi * x[0]])
    return y


def _play_operator(x: np.ndarray, half_width: float) -> np.ndarray:
    """Play (backlash) operator: ``p_k = clip(p_{k-1}, x_k - h, x_k + h)``, ``p_0 = x_0``."""
    out = np.empty(x.size)
    if x.size == 0:
        return out
    p = float(x[0])
    for k, v in enumerate(x.tolist()):
        if p < v - half_width:
            p = v - half_width
        elif p > v + half_width:
            p = v + half_width
        out[k] = p
    return out


def _gauss_markov(n: int, dt_s: float, sigma: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary first-order Gauss–Markov sequence (exact discretisation)."""
    if sigma == 0.0:
        return np.zeros(n)
    phi = math.exp(-dt_s / tau_s)
    w = rng.standard_normal(n)
    # x_0 ~ N(0, sigma²); x_k = phi*x_{k-1} + sigma*sqrt(1 - phi²)*w_k
    drive = sigma * math.sqrt(1.0 - phi * phi) * w
    drive[0] = sigma * w[0]
    from scipy.signal import lfilter  # here, not at the top: scipy costs 0.4 s at start-up

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
    interference_offset_deg : ndarray or None
        A further time-varying compass heading offset at the log times, deg (magnetic
        interference that wanders, which constant windows cannot describe); added to
        the windows' offset, in the simulated field as well. None = none.
    compass_dropouts : tuple of (start_s, duration_s)
        Windows without compass samples (``heading`` and raw ``mag_*`` NaN in
        ``start_s <= t < start_s + duration_s``).
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
    interference_offset_deg: np.ndarray | None = None
    compass_dropouts: tuple[tuple[float, float], ...] = field(default=())


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
    from scipy.interpolate import PchipInterpolator  # here, not at the top: scipy costs 0.4 s at start-up

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


# --------------------------------------------------------------------------- beyond the paper


def hysteresis_temperature(t_s, duration_s: float):
    """Heating and cooling cycle of ``hysteresis``: 10 → 70 → 10 degC, then 10 → 45 → 20 degC.

    Shape in fractions of the run after the hold: 10 → 70 degC by 0.25, plateau to
    0.32, cooling to 10 degC by 0.60, plateau to 0.66, a minor loop up to 45 degC by
    0.80, plateau to 0.84 and cooling to 20 degC at the end. Every temperature between
    20 and 45 degC is passed four times, twice heating and twice cooling.

    Returns
    -------
    temp_c, temp_rate_cps : ndarray
    """
    knots_u = [0.0, 0.25, 0.32, 0.60, 0.66, 0.80, 0.84, 1.0]
    knots_c = [10.0, 70.0, 70.0, 10.0, 10.0, 45.0, 45.0, 20.0]
    return _knot_profile(t_s, duration_s, knots_u, knots_c)


def cold_start_temperature(t_s, duration_s: float):
    """Warm-up after a cold soak: -20 degC held, then up to +60 degC, fast at first.

    ``T = -20 + 80 * (1 - exp(-u/0.25)) / (1 - exp(-4))`` through 9 knots, ``u`` the
    fraction of the run after the hold: half of the 80 degC rise comes in the first
    18 % of the run (for the default 2-h run about 0.04 degC/s at first), and the
    profile ends at exactly +60 degC.

    Returns
    -------
    temp_c, temp_rate_cps : ndarray
    """
    u = np.linspace(0.0, 1.0, 9)
    c = -20.0 + 80.0 * (1.0 - np.exp(-u / 0.25)) / (1.0 - math.exp(-4.0))
    return _knot_profile(t_s, duration_s, u, c)


#: Soak profile: knots (fraction of the run after the hold, degC); ramps between unequal knots.
_SOAK_KNOTS_U = (0.0, 0.08, 0.20, 0.33, 0.50, 0.62, 0.75, 0.86, 0.95, 1.0)
_SOAK_KNOTS_C = (20.0, 20.0, 45.0, 45.0, 5.0, 5.0, 35.0, 35.0, 20.0, 20.0)

#: Soak outages, one in the middle of each temperature ramp: (duration in s of the
#: 12-h run, offset deg or None = compass missing).
_SOAK_OUTAGES = ((900.0, None), (1200.0, 30.0), (900.0, None), (600.0, -25.0))


def soak_temperature(t_s, duration_s: float):
    """Thermal soak of ``soak``: plateaus joined by slow ramps, 20 → 45 → 5 → 35 → 20 degC.

    Knots (fraction of the run after the hold → degC): 0.08 → 20, 0.20 → 45,
    0.33 → 45, 0.50 → 5, 0.62 → 5, 0.75 → 35, 0.86 → 35, 0.95 → 20, flat to the end.
    For the default 12-h run the ramps take 1.1–2.0 h (at most about 0.01 degC/s).

    Returns
    -------
    temp_c, temp_rate_cps : ndarray
    """
    return _knot_profile(t_s, duration_s, _SOAK_KNOTS_U, _SOAK_KNOTS_C)


def soak_ramps(duration_s: float) -> tuple[tuple[float, float], ...]:
    """The temperature ramps of ``soak``: ``(start_s, end_s)`` each, in run time."""
    hold = _hold_s(duration_s)
    at = [hold + (duration_s - hold) * u for u in _SOAK_KNOTS_U]
    return tuple(
        (at[i], at[i + 1]) for i in range(len(at) - 1) if _SOAK_KNOTS_C[i] != _SOAK_KNOTS_C[i + 1]
    )


def soak_outages(duration_s: float):
    """The compass outages of ``soak``, one centred in each temperature ramp.

    For the default 12-h run: 900 s without compass (first ramp, heating), 1200 s of
    +30 deg interference (second ramp, cooling), 900 s without compass (third,
    heating) and 600 s of -25 deg interference (fourth, cooling); durations scale with
    the run.

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
    """Where the interference of ``interference-wander`` acts: ``(start_s, duration_s)`` each.

    For the default 3-h run: 900 s from 1296 s (early rise), 1200 s from 3456 s (top
    of the rise), 900 s from 5940 s (plateau) and 1500 s from 8424 s (cooling); start
    and length scale with the run.
    """
    scale = duration_s / (3 * 3600.0)
    return tuple((f * duration_s, d * scale) for f, d in ((0.12, 900.0), (0.32, 1200.0), (0.55, 900.0), (0.78, 1500.0)))


#: Wandering interference: ramp in/out (s), mean offset (deg), sinusoid amplitudes (deg)
#: and periods (s) of the three components of each window.
_WANDER_RAMP_S = 120.0
_WANDER_MEAN_DEG = (2.0, 6.0)
_WANDER_AMP_DEG = (1.0, 3.0)
_WANDER_PERIOD_S = (180.0, 900.0)


def wander_offset(t_s, duration_s: float, rng: np.random.Generator) -> np.ndarray:
    """Slowly wandering compass heading offset of ``interference-wander``, deg.

    In each window of :func:`interference_windows_wander` the offset is a mean of
    2–6 deg (random sign) plus three sinusoids of 1–3 deg amplitude and 3–15 min
    period (random phases), faded in and out with raised-cosine ramps of
    ``min(120 s, window/4)``; 0 outside the windows. For a window longer than 8 min the
    offset changes by at most about 0.35 deg/s (typically 0.05–0.15 deg/s): too slow
    for a 10-s disagreement gate of 3 deg to notice, so it pulls the compass along
    with it. Periods are absolute (minutes), not scaled with the run.

    Parameters
    ----------
    t_s : array_like
        Times, s.
    duration_s : float
        Run length, s.
    rng : numpy.random.Generator
        Source of the offsets, amplitudes, periods and phases (a fixed number of
        draws per window).

    Returns
    -------
    ndarray
        Offset, deg.
    """
    t = np.asarray(t_s, dtype=float)
    out = np.zeros(t.shape)
    for start, dur in interference_windows_wander(duration_s):
        mean = rng.choice([-1.0, 1.0]) * rng.uniform(*_WANDER_MEAN_DEG)
        amp = rng.uniform(*_WANDER_AMP_DEG, size=3)
        period = rng.uniform(*_WANDER_PERIOD_S, size=3)
        phase = rng.uniform(0.0, 2.0 * np.pi, size=3)
        ramp = min(_WANDER_RAMP_S, dur / 4.0)
        envelope = _smooth_step((t - start) / ramp) - _smooth_step((t - (start + dur - ramp)) / ramp)
        inside = envelope > 0.0
        x = t[inside] - start
        wave = mean + sum(a * np.sin(2.0 * np.pi * x / p + ph) for a, p, ph in zip(amp, period, phase))
        out[inside] = out[inside] + envelope[inside] * wave
    return out


def scenario_interference_wander(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """``static`` with magnetic interference that wanders slowly in four windows.

    The bench, attitude and temperature of ``static`` (23 → 58 degC and back); the
    compass offset of :func:`wander_offset` (a few degrees, changing over minutes) in
    the windows of :func:`interference_windows_wander`.
    """
    temp, rate = static_temperature(t_s, duration_s)
    still = _still(t_s, temp, rate, 40.0, 0.8, -1.2)
    return replace(still, interference_offset_deg=wander_offset(t_s, duration_s, rng))


def scenario_hysteresis(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A strongly nonlinear device with hysteresis, motionless at 120 deg, heated and cooled.

    The temperature cycle of :func:`hysteresis_temperature` (10 → 70 → 10 degC, then a
    minor loop 10 → 45 → 20 degC) spans 60 degC of the cubic drift, and the scenario's
    device (:data:`SCENARIO_MEMORY`) adds a 120-s thermal lag and a 0.15 deg/s
    backlash hysteresis: the drift at one temperature differs between heating and
    cooling, also when the temperature has stopped changing.
    """
    temp, rate = hysteresis_temperature(t_s, duration_s)
    return _still(t_s, temp, rate, 120.0, -0.6, 1.0)


def scenario_cold_start(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """Cold start: motionless at 300 deg, warming from -20 to +60 degC after a cold soak."""
    temp, rate = cold_start_temperature(t_s, duration_s)
    return _still(t_s, temp, rate, 300.0, 1.1, 0.4)


#: Yaw sway of ``soak``: (amplitude range deg, period range s) of its two components.
_SWAY = (((10.0, 20.0), (180.0, 600.0)), ((2.0, 5.0), (60.0, 180.0)))


def scenario_soak(t_s, duration_s: float, rng: np.random.Generator) -> Motion:
    """A 12-h soak: slow yaw sway, temperature ramps, long compass outages during the ramps.

    The unit sways about heading 70 deg (a moored boat, a vehicle on a rocking
    platform): a 10–20 deg sinusoid of 3–10 min period plus a 2–5 deg one of 1–3 min
    (random amplitudes, periods and phases), faded in over ``min(120 s, 10 %)`` after
    the hold; at most about 1.2 deg/s, below the 2 deg/s turning gate. Temperature of
    :func:`soak_temperature`; the outages of :func:`soak_outages` (compass missing, or
    interference of 25–30 deg) in the middle of the ramps, where the drift changes
    fastest.
    """
    t = np.asarray(t_s, dtype=float)
    temp, temp_rate = soak_temperature(t, duration_s)
    hold = _hold_s(duration_s)
    fade = min(120.0, 0.1 * duration_s)
    env = _smooth_step((t - hold) / fade)
    env_rate = _smooth_step_slope((t - hold) / fade) / fade
    sway = np.zeros(t.size)
    sway_rate = np.zeros(t.size)
    for amp_range, period_range in _SWAY:
        amp = rng.uniform(*amp_range)
        omega = 2.0 * np.pi / rng.uniform(*period_range)
        phase = rng.uniform(0.0, 2.0 * np.pi)
        sway += amp * (np.sin(omega * (t - hold) + phase) - math.sin(phase))
        sway_rate += amp * omega * np.cos(omega * (t - hold) + phase)
    dropouts, interference = soak_outages(duration_s)
    zero = np.zeros(t.size)
    return Motion(
        temp_c=temp,
        temp_rate_cps=temp_rate,
        heading_rate_dps=env_rate * sway + env * sway_rate,
        heading0_deg=70.0,
        roll_deg=0.5,
        pitch_deg=-0.8,
        accel_fwd_mps2=zero,
        accel_lat_mps2=zero,
        interference=interference,
        compass_dropouts=dropouts,
    )


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
}


# --------------------------------------------------------------------------- randomised devices


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def _signed(rng: np.random.Generator, low: float, high: float) -> float:
    """Magnitude uniform in [low, high], random sign."""
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(low, high))


def random_device(rng: np.random.Generator, *, scenario: str | None = None) -> DeviceModel:
    """A plausible randomised MEMS gyro for Monte Carlo runs.

    Parameters are drawn independently, in a fixed order, around the ADXRS623-like
    default (:class:`DeviceModel`):

    ==========================  ==========================================  ============
    field                       distribution                                unit
    ==========================  ==========================================  ============
    ``noise_density_dps_rthz``  log-uniform 0.015–0.08                      deg/s/√Hz
    ``c0_dps``                  uniform −0.5 … 0.5                          deg/s
    ``c1_dps_per_c``            ±(0.005–0.04), random sign                  deg/s/degC
    ``c2_dps_per_c2``           uniform −5e-4 … 5e-4                        deg/s/degC²
    ``c3_dps_per_c3``           uniform −5e-6 … 5e-6                        deg/s/degC³
    ``k_rate_dps_per_cps``      uniform −8 … 8                              deg/s/(degC/s)
    ``hyst_dps``                uniform 0 … 0.05                            deg/s
    ``bias_instability_dps``    log-uniform 0.001–0.005                     deg/s
    ``bias_tau_s``              uniform 100–1000                            s
    ``rate_random_walk_dps_rts`` log-uniform 5e-6–5e-5                      deg/s/√s
    ``temp_noise_c``            uniform 0.005–0.05                          degC
    ``temp_quant_c``            one of 1/340, 1/16, 1/8                     degC
    ==========================  ==========================================  ============

    Over 23–58 degC the linear part alone moves the drift by 0.18–1.4 deg/s. The
    scale factor is exactly 1 (all ``sf_*`` 0).

    For ``scenario="hysteresis"`` the device is strongly nonlinear with memory: the
    quadratic and cubic coefficients are drawn with magnitudes 3e-4–8e-4 and
    3e-6–8e-6 (random signs) instead, and ``lag_tau_s`` uniform 60–300 s,
    ``play_dps`` uniform 0.05–0.2 deg/s (random sign) and ``play_width_c`` uniform
    3–10 degC. Any other scenario: no memory (``lag_tau_s = play_dps = 0``).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of every draw; the same generator state gives the same device.
    scenario : str, optional
        The scenario the device is drawn for (only ``hysteresis`` changes the draws).

    Returns
    -------
    DeviceModel

    Examples
    --------
    >>> a = random_device(np.random.default_rng(5))
    >>> a == random_device(np.random.default_rng(5))
    True
    >>> a.has_memory(), random_device(np.random.default_rng(5), scenario="hysteresis").has_memory()
    (False, True)
    """
    strong = scenario == "hysteresis"
    noise = _log_uniform(rng, 0.015, 0.08)
    c0 = float(rng.uniform(-0.5, 0.5))
    c1 = _signed(rng, 0.005, 0.04)
    if strong:
        c2, c3 = _signed(rng, 3e-4, 8e-4), _signed(rng, 3e-6, 8e-6)
    else:
        c2, c3 = float(rng.uniform(-5e-4, 5e-4)), float(rng.uniform(-5e-6, 5e-6))
    values = {
        "noise_density_dps_rthz": noise,
        "c0_dps": c0,
        "c1_dps_per_c": c1,
        "c2_dps_per_c2": c2,
        "c3_dps_per_c3": c3,
        "k_rate_dps_per_cps": float(rng.uniform(-8.0, 8.0)),
        "hyst_dps": float(rng.uniform(0.0, 0.05)),
        "bias_instability_dps": _log_uniform(rng, 0.001, 0.005),
        "bias_tau_s": float(rng.uniform(100.0, 1000.0)),
        "rate_random_walk_dps_rts": _log_uniform(rng, 5e-6, 5e-5),
        "temp_noise_c": float(rng.uniform(0.005, 0.05)),
        "temp_quant_c": float(rng.choice([1.0 / 340.0, 0.0625, 0.125])),
        "sf_ppm": 0.0,
        "sf_ppm_per_c": 0.0,
        "sf_ppm_per_c2": 0.0,
    }
    if strong:
        values.update(
            lag_tau_s=float(rng.uniform(60.0, 300.0)),
            play_dps=_signed(rng, 0.05, 0.2),
            play_width_c=float(rng.uniform(3.0, 10.0)),
        )
    else:
        values.update(_NO_MEMORY)
    return DeviceModel(**values)


def random_compass(rng: np.random.Generator) -> CompassModel:
    """A plausible randomised compass for Monte Carlo runs.

    ``noise_deg`` uniform 0.3–0.6 deg; semicircular deviation ``deviation_deg``
    uniform 0–3 deg and quadrantal ``deviation2_deg`` 0–1 deg, both at a uniform
    random phase; everything else as :class:`CompassModel` (10 Hz, 50 µT, dip 60 deg,
    kinematic tilt).

    The noise stays near the 0.5 deg the default compensator settings assume: with
    the default 3-deg disagreement gate checked at every compass sample, a noisier
    compass gets most intervals refused (measured on ``static``, seed 1, 10 Hz:
    0.7 deg → 20 % of rows gated, 1.0 deg → 82 %), and a Monte Carlo would then
    measure the gate rather than the drift estimators.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of every draw.

    Returns
    -------
    CompassModel
    """
    return CompassModel(
        noise_deg=float(rng.uniform(0.3, 0.6)),
        deviation_deg=float(rng.uniform(0.0, 3.0)),
        deviation_phase_deg=float(rng.uniform(-180.0, 180.0)),
        deviation2_deg=float(rng.uniform(0.0, 1.0)),
        deviation2_phase_deg=float(rng.uniform(-180.0, 180.0)),
    )


# --------------------------------------------------------------------------- assembly


def _streams(seed: int) -> dict[str, np.random.Generator]:
    """Independent generators of one seed, one per random source."""
    # Appended names only: child i of a SeedSequence does not depend on how many are spawned.
    names = ("trajectory", "white", "bias", "rrw", "temp", "compass",
             "x_white", "x_bias", "x_rrw", "y_white", "y_bias", "y_rrw", "acc")
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
    if motion.interference_offset_deg is not None:
        offset = offset + np.asarray(motion.interference_offset_deg, dtype=float)[idx]
    noise = compass.noise_deg * rng.standard_normal(idx.size) if compass.noise_deg > 0 else 0.0
    apparent = psi + compass.deviation(psi) + offset + noise
    mag = np.full((n, 3), np.nan)
    mag[idx] = _body_from_level(_apparent_field_level(apparent, offset, compass), motion.roll_deg, motion.pitch_deg)

    heading = np.full(n, np.nan)
    heading[idx] = wrap_360(tilt_compensated_heading(*mag[idx].T, *acc[idx].T))
    return heading, mag, acc


def _triad_columns(t, dt, motion: Motion, triad: "TriadModel", scenario: str, acc, rng) -> dict:
    """``gyro_x, gyro_y, true_bias_x, true_bias_y`` and the noisy ``acc_x..z`` of :class:`TriadModel`."""
    n = t.size
    phi, theta = math.radians(motion.roll_deg), math.radians(motion.pitch_deg)
    body_rate = {  # body rates of a yaw rate at a constant attitude (ZYX Euler kinematics)
        "x": -math.sin(theta) * motion.heading_rate_dps,
        "y": math.sin(phi) * math.cos(theta) * motion.heading_rate_dps,
    }
    gyro, bias = {}, {}
    for axis in ("x", "y"):
        dev = getattr(triad, axis).with_scenario_scale_factor(scenario).with_scenario_memory(scenario)
        bias[axis] = (
            dev.drift_series(t, motion.temp_c, motion.temp_rate_cps)
            + _gauss_markov(n, dt, dev.bias_instability_dps, dev.bias_tau_s, rng[f"{axis}_bias"])
            + _random_walk(n, dt, dev.rate_random_walk_dps_rts, rng[f"{axis}_rrw"])
        )
        sigma = dev.white_sigma_dps(1.0 / dt)
        white = sigma * rng[f"{axis}_white"].standard_normal(n) if sigma > 0 else np.zeros(n)
        gyro[axis] = dev.scale_factor(motion.temp_c) * body_rate[axis] + bias[axis] + white
    if triad.acc_noise_g > 0:
        acc = acc + triad.acc_noise_g * rng["acc"].standard_normal((n, 3))
    return {
        "gyro_x": gyro["x"],
        "gyro_y": gyro["y"],
        TRUE_BIAS_X: bias["x"],
        TRUE_BIAS_Y: bias["y"],
        **{name: acc[:, i] for i, name in enumerate(ACC_COLS)},
    }


def simulate(
    scenario: str,
    *,
    seed: int = 0,
    duration_s: float | None = None,
    fs_hz: float = 50.0,
    device: DeviceModel | None = None,
    compass: CompassModel | None = None,
    raw_mag: bool = False,
    triad: "TriadModel | None" = None,
) -> pd.DataFrame:
    """Simulate a log in the gyrodrift input contract, with truth columns.

    Parameters
    ----------
    scenario : str
        One of :data:`SCENARIOS`: ``static``, ``static-outages``, ``vehicle``,
        ``calibration``, ``scale-factor``, ``interference-wander``, ``hysteresis``,
        ``cold-start``, ``soak``.
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
        and memory fields left ``None`` take the scenario's values
        (:data:`SCENARIO_SCALE_FACTOR_PPM`, :data:`SCENARIO_MEMORY`).
    compass : CompassModel, optional
        Compass error model (default :class:`CompassModel`); the scenario's own
        interference windows are added to its ``interference``.
    raw_mag : bool
        Also write ``mag_x, mag_y, mag_z`` (µT, FRD, NaN off compass rows) and
        ``acc_x, acc_y, acc_z`` (g, FRD specific force, every row).
    triad : TriadModel, optional
        Also write ``gyro_x, gyro_y`` (deg/s, own drift and noise), their truth
        ``true_bias_x, true_bias_y`` and the accelerometer ``acc_x..z`` (g, with the
        triad's noise). None (default): none of these (the other columns do not change).

    Returns
    -------
    pandas.DataFrame
        Columns ``t, gyro_z, temp, heading, ref_heading, true_bias_z``, then
        ``true_sf`` in the ``scale-factor`` scenario or whenever the scale factor is
        not ≡ 1 (+ raw columns); ``attrs`` holds ``scenario``, ``seed``,
        ``duration_s``, ``fs_hz``, and the effective ``device`` (scale-factor
        coefficients and memory fields resolved) and ``compass`` models as plain
        dicts, and ``compass_dropouts`` (list of ``[start_s, duration_s]``) when the
        scenario has windows without compass samples (``soak``).

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
    rng = _streams(int(seed))

    motion = SCENARIOS[scenario](t, duration, rng["trajectory"])
    from scipy.integrate import cumulative_trapezoid  # here, not at the top: scipy costs 0.4 s at start-up

    heading_true = motion.heading0_deg + cumulative_trapezoid(motion.heading_rate_dps, t, initial=0.0)
    body_rate = motion.heading_rate_dps * (
        math.cos(math.radians(motion.roll_deg)) * math.cos(math.radians(motion.pitch_deg))
    )

    bias = (
        device.drift_series(t, motion.temp_c, motion.temp_rate_cps)
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
    for start, dur in motion.compass_dropouts:  # after the noise draw: the other rows keep their noise
        out = (t >= start) & (t < start + dur)
        heading[out] = np.nan
        mag[out] = np.nan

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
        columns.update(_triad_columns(t, dt, motion, triad, scenario, acc, rng))
        acc = np.column_stack([columns.pop(name) for name in ACC_COLS])
    if raw_mag:
        columns.update({name: mag[:, i] for i, name in enumerate(MAG_COLS)})
    if raw_mag or triad is not None:
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
    if triad is not None:
        df.attrs["triad"] = _jsonable(asdict(triad))
    if motion.compass_dropouts:
        df.attrs["compass_dropouts"] = _jsonable(motion.compass_dropouts)
    return df
