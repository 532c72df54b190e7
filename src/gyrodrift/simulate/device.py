"""Error model of the gyro: drift, scale factor, noise, and the temperature reading.

:class:`DeviceModel` is the heading-axis MEMS gyro and its temperature sensor,
:class:`TriadModel` adds the x and y gyros, and :func:`random_device` draws a
randomised gyro for Monte Carlo runs; the bias and temperature-reading processes
are here too. The drift is deliberately **not** the paper's ``a*T + b*T' + c`` (eq. 2):
a cubic in temperature, a rate term, a heating/cooling hysteresis, optionally a
thermal lag and a backlash (:data:`SCENARIO_MEMORY`), and stochastic bias terms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.simulate.checks import finite, nonneg, positive

__all__ = [
    "SCENARIO_SCALE_FACTOR_PPM",
    "SCENARIO_MEMORY",
    "DeviceModel",
    "TriadModel",
    "gauss_markov",
    "random_walk",
    "temperature_reading",
    "true_bias",
    "gyro_axis",
    "random_device",
]

#: Scale-factor coefficients (``sf_*``) of each scenario that sets them; a device
#: coefficient left ``None`` takes this value (else 0). ``scale-factor``: 1 % high at
#: 25 degC and about +3 % over 23-58 degC (ADXRS623, Feng et al. 2015, Table 1),
#: slightly curved so that a linear SF model must keep adapting.
SCENARIO_SCALE_FACTOR_PPM: dict[str, dict[str, float]] = {
    "scale-factor": {"sf_ppm": 10000.0, "sf_ppm_per_c": 700.0, "sf_ppm_per_c2": 6.0},
}

#: Temperature-memory fields (``lag_tau_s``, ``play_dps``, ``play_width_c``) of each
#: scenario that sets them; a device field left ``None`` takes this value (else off).
#: ``hysteresis``: a 120 s thermal lag and a 0.15 deg/s backlash of 6 degC width.
SCENARIO_MEMORY: dict[str, dict[str, float]] = {
    "hysteresis": {"lag_tau_s": 120.0, "play_dps": 0.15, "play_width_c": 6.0},
}

#: Memory fields of every other scenario: off.
_NO_MEMORY = {"lag_tau_s": 0.0, "play_dps": 0.0, "play_width_c": 1.0}


@dataclass(frozen=True, kw_only=True)
class DeviceModel:
    """Error model of the heading-axis MEMS gyro and its temperature sensor.

    Defaults resemble an ADXRS623 (Feng et al. 2015, Table 1): white noise density
    0.04 deg/s/√Hz and a drift that changes by about 1 deg/s between 23 and 58 degC.

    The gyro reads ``gyro_z = SF(T) * true_rate + drift(T, T') + gauss_markov +
    rate_random_walk + white``: :meth:`scale_factor`, :meth:`drift` of the *true* die
    temperature and its rate, a Gauss–Markov bias instability, integrated white noise,
    and white noise of :meth:`white_sigma_dps` per sample.

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
        Quantisation step of the temperature reading, degC (0 = off; not a noise term).
    sf_ppm : float or None
        Scale-factor error at ``t_ref_c``, ppm (parts per million of the true rate).
    sf_ppm_per_c : float or None
        Linear temperature coefficient of the scale factor, ppm/degC.
    sf_ppm_per_c2 : float or None
        Quadratic temperature coefficient of the scale factor, ppm/degC².
        ``None`` (all three sf fields): the scenario's value
        (:data:`SCENARIO_SCALE_FACTOR_PPM`, else 0).
    lag_tau_s : float or None
        Thermal lag of the sensing element behind the read temperature ``T``, s: the
        polynomial is evaluated at ``T_lag``, ``dT_lag/dt = (T - T_lag)/lag_tau_s``,
        ``T_lag(0) = T(0)``. 0 = off.
    play_dps : float or None
        Backlash hysteresis, deg/s: ``play_dps * (T - p)/(w/2)`` with ``p`` the play
        operator of ``T`` of width ``w = play_width_c``; it stays at ``±play_dps`` when
        the temperature stops changing. 0 = off.
    play_width_c : float or None
        Width ``w`` of the play operator, degC (> 0).
        ``None`` (all three memory fields): the scenario's value
        (:data:`SCENARIO_MEMORY`, else off). The memory terms are in
        :meth:`drift_series` only.
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
            finite(f.name, getattr(self, f.name), "DeviceModel")
        for name in (*self._NOISE_FIELDS, "temp_quant_c"):
            nonneg(name, getattr(self, name), "DeviceModel")
        for name in ("bias_tau_s", "hyst_rate_cps"):
            positive(name, getattr(self, name), "DeviceModel")
        if self.lag_tau_s is not None:
            nonneg("lag_tau_s", self.lag_tau_s, "DeviceModel")
        if self.play_width_c is not None:
            positive("play_width_c", self.play_width_c, "DeviceModel")

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
        factor = nonneg("scale_noise factor", factor, "DeviceModel")
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

        Without memory terms this is exactly :meth:`drift`.

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

        A ``None`` coefficient counts as 0 (``simulate`` first sets the scenario's value).

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
        """A copy with each ``None`` memory field set to the scenario's value (:data:`SCENARIO_MEMORY`, else off).

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

    Each axis has its own :class:`DeviceModel` (its temperature-reading fields are
    unused). ``gyro_x``/``gyro_y`` read ``SF × body rate + bias + white`` with the body
    rates of the constant mounting attitude (``p = -sinθ ψ'``, ``q = sinφ cosθ ψ'``);
    the accelerometer (``acc_x..z``, g, FRD) feels the vehicle's acceleration as
    ``CompassModel.kinematic_tilt`` does, plus white noise.

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
        nonneg("acc_noise_g", self.acc_noise_g, "TriadModel")

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


def gauss_markov(n: int, dt_s: float, sigma: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary first-order Gauss–Markov sequence (exact discretisation).

    Parameters
    ----------
    n : int
        Number of samples.
    dt_s : float
        Sample interval, s.
    sigma : float
        Stationary standard deviation (0 gives zeros and draws nothing).
    tau_s : float
        Correlation time, s.
    rng : numpy.random.Generator
        Source of the ``n`` standard normal draws.

    Returns
    -------
    ndarray
        The sequence, in the unit of ``sigma``.
    """
    if sigma == 0.0:
        return np.zeros(n)
    phi = math.exp(-dt_s / tau_s)
    w = rng.standard_normal(n)
    # x_0 ~ N(0, sigma²); x_k = phi*x_{k-1} + sigma*sqrt(1 - phi²)*w_k
    drive = sigma * math.sqrt(1.0 - phi * phi) * w
    drive[0] = sigma * w[0]
    from scipy.signal import lfilter  # here, not at the top: scipy costs 0.4 s at start-up

    return lfilter([1.0], [1.0, -phi], drive)


def random_walk(n: int, dt_s: float, coeff: float, rng: np.random.Generator) -> np.ndarray:
    """Random walk starting at 0 with increments of standard deviation ``coeff*sqrt(dt_s)``.

    Parameters
    ----------
    n : int
        Number of samples.
    dt_s : float
        Sample interval, s.
    coeff : float
        Random walk coefficient, unit per √s (0 gives zeros and draws nothing).
    rng : numpy.random.Generator
        Source of the ``n`` standard normal draws (the first one is not used).

    Returns
    -------
    ndarray
        The walk; ``[0]`` is 0.
    """
    if coeff == 0.0:
        return np.zeros(n)
    steps = coeff * math.sqrt(dt_s) * rng.standard_normal(n)
    steps[0] = 0.0
    return np.cumsum(steps)


def true_bias(device: DeviceModel, t_s: np.ndarray, dt_s: float, temp_c, temp_rate_cps, bias_rng, rrw_rng):
    """The drift of one gyro axis, deg/s: :meth:`DeviceModel.drift_series` + Gauss–Markov + rate random walk."""
    n = len(t_s)
    return (
        device.drift_series(t_s, temp_c, temp_rate_cps)
        + gauss_markov(n, dt_s, device.bias_instability_dps, device.bias_tau_s, bias_rng)
        + random_walk(n, dt_s, device.rate_random_walk_dps_rts, rrw_rng)
    )


def gyro_axis(device: DeviceModel, t_s: np.ndarray, dt_s: float, fs_hz: float, temp_c, temp_rate_cps, body_rate_dps,
              bias_rng, rrw_rng, white_rng):
    """One gyro axis: reading ``SF(T) * body rate + drift + white`` (deg/s), its drift and ``SF(T)``."""
    bias = true_bias(device, t_s, dt_s, temp_c, temp_rate_cps, bias_rng, rrw_rng)
    sigma = device.white_sigma_dps(fs_hz)
    white = sigma * white_rng.standard_normal(len(t_s)) if sigma > 0 else np.zeros(len(t_s))
    sf = device.scale_factor(temp_c)  # exactly 1.0 unless an sf_* is non-zero
    return sf * body_rate_dps + bias + white, bias, sf


def temperature_reading(temp_true_c: np.ndarray, device: DeviceModel, rng: np.random.Generator) -> np.ndarray:
    """Temperature sensor reading: true temperature + white noise, rounded to the quantisation step.

    Parameters
    ----------
    temp_true_c : ndarray
        True die temperature, degC.
    device : DeviceModel
        Gives ``temp_noise_c`` and ``temp_quant_c``.
    rng : numpy.random.Generator
        Source of the noise (one draw per sample, none when ``temp_noise_c`` is 0).

    Returns
    -------
    ndarray
        Reading, degC.

    Examples
    --------
    >>> dev = DeviceModel.noiseless()
    >>> temperature_reading(np.array([25.01, 25.04]), dev, np.random.default_rng(0)).tolist()
    [25.0, 25.0625]
    """
    reading = temp_true_c.copy()
    if device.temp_noise_c > 0:
        reading = reading + device.temp_noise_c * rng.standard_normal(reading.size)
    if device.temp_quant_c > 0:
        reading = device.temp_quant_c * np.round(reading / device.temp_quant_c)
    return reading


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def _signed(rng: np.random.Generator, low: float, high: float) -> float:
    """Magnitude uniform in [low, high], random sign."""
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(low, high))


def random_device(rng: np.random.Generator, *, scenario: str | None = None) -> DeviceModel:
    """A plausible randomised MEMS gyro for Monte Carlo runs.

    Each field is drawn independently, in a fixed order, around the ADXRS623-like
    default (the ranges are in the code); the scale factor is exactly 1. For
    ``scenario="hysteresis"`` the quadratic and cubic terms are larger and the memory
    terms are drawn; for any other scenario the memory is off.

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
