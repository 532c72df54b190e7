"""Error model of the gyro: drift, scale factor, noise, and the temperature reading.

:class:`DeviceModel` (heading axis), :class:`TriadModel` (x and y axes), the bias and
temperature-reading processes and :func:`random_device`; the model and its numbers are in
``docs/simulator.md`` (the gyro).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from gyrodrift.errors import ConfigError
from gyrodrift.simulate.checks import finite, nonneg, positive

__all__ = [
    "SCENARIO_SCALE_FACTOR_PPM", "SCENARIO_MEMORY", "DeviceModel", "TriadModel", "seeded_streams", "gauss_markov",
    "random_walk", "temperature_reading", "true_bias", "gyro_axis", "random_device",
]

#: Scale-factor coefficients (``sf_*``) of each scenario that sets them (else 0).
SCENARIO_SCALE_FACTOR_PPM: dict[str, dict[str, float]] = {
    "scale-factor": {"sf_ppm": 10000.0, "sf_ppm_per_c": 700.0, "sf_ppm_per_c2": 6.0},
}

#: Temperature-memory fields (``lag_tau_s``, ``play_dps``, ``play_width_c``) of each scenario setting them (else off).
SCENARIO_MEMORY: dict[str, dict[str, float]] = {
    "hysteresis": {"lag_tau_s": 120.0, "play_dps": 0.15, "play_width_c": 6.0},
}

#: Memory fields of every other scenario: off.
_NO_MEMORY = {"lag_tau_s": 0.0, "play_dps": 0.0, "play_width_c": 1.0}


@dataclass(frozen=True, kw_only=True)
class DeviceModel:
    """Error model of the heading-axis MEMS gyro and its temperature sensor.

    ``gyro_z = SF(T) * true_rate + drift(T, T') + Gauss–Markov + rate random walk + white``,
    defaults like an ADXRS623 (Feng et al. 2015, Table 1). The fields (units in their
    names), their defaults and the ``None`` fields that take the scenario's value:
    ``docs/simulator.md`` (the gyro).
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
    _NOISE_FIELDS = ("noise_density_dps_rthz", "bias_instability_dps", "rate_random_walk_dps_rts", "temp_noise_c")
    #: The scale-factor coefficients and the temperature-memory fields (None: the scenario's value).
    _SF_FIELDS = ("sf_ppm", "sf_ppm_per_c", "sf_ppm_per_c2")
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
        """The default model with every stochastic term zero (quantisation kept), then ``overrides``."""
        return replace(cls().scale_noise(0.0), **overrides)

    def scale_noise(self, factor: float) -> "DeviceModel":
        """A copy with all stochastic terms multiplied by ``factor`` (>= 0; 0 = off)."""
        factor = nonneg("scale_noise factor", factor, "DeviceModel")
        return replace(self, **{n: getattr(self, n) * factor for n in self._NOISE_FIELDS})

    def drift(self, temp_true_c, temp_rate_true_cps):
        """Deterministic drift, deg/s, of the true temperature ``T`` (degC) and its rate ``T'`` (degC/s).

        ``c0 + c1*x + c2*x**2 + c3*x**3 + k_rate*T' + hyst*tanh(T'/hyst_rate)``, ``x = T - t_ref_c``.
        """
        x = np.asarray(temp_true_c, dtype=float) - self.t_ref_c
        rate = np.asarray(temp_rate_true_cps, dtype=float)
        poly = self.c0_dps + x * (self.c1_dps_per_c + x * (self.c2_dps_per_c2 + x * self.c3_dps_per_c3))
        return poly + self.k_rate_dps_per_cps * rate + self.hyst_dps * np.tanh(rate / self.hyst_rate_cps)

    def has_memory(self) -> bool:
        """True when a thermal lag or a play hysteresis is set and non-zero."""
        return bool(self.lag_tau_s) or bool(self.play_dps)

    def drift_series(self, t_s, temp_true_c, temp_rate_true_cps) -> np.ndarray:
        """Deterministic drift, deg/s, of a series at uniform times ``t_s``, thermal lag and backlash included.

        Without memory terms this is :meth:`drift`; the memory terms: ``docs/simulator.md`` (the gyro).
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
        """Gyro scale factor (measured/true rate) at the true temperature, degC.

        ``1 + 1e-6 * (sf_ppm + sf_ppm_per_c*x + sf_ppm_per_c2*x**2)``, ``x = T - t_ref_c``; ``None`` counts as 0.
        """
        s0, s1, s2 = (0.0 if getattr(self, n) is None else getattr(self, n) for n in self._SF_FIELDS)
        x = np.asarray(temp_true_c, dtype=float) - self.t_ref_c
        return 1.0 + 1e-6 * (s0 + x * (s1 + x * s2))

    def has_scale_factor_error(self) -> bool:
        """True when some scale-factor coefficient is set and non-zero (SF not ≡ 1)."""
        return any(getattr(self, n) not in (None, 0.0) for n in self._SF_FIELDS)

    def with_scenario_scale_factor(self, scenario: str) -> "DeviceModel":
        """A copy with each ``None`` scale-factor coefficient set to the scenario's value."""
        defaults = SCENARIO_SCALE_FACTOR_PPM.get(scenario, {})
        return replace(self, **{n: float(defaults.get(n, 0.0)) for n in self._SF_FIELDS if getattr(self, n) is None})

    def with_scenario_memory(self, scenario: str) -> "DeviceModel":
        """A copy with each ``None`` memory field set to the scenario's value (else off)."""
        defaults = {**_NO_MEMORY, **SCENARIO_MEMORY.get(scenario, {})}
        return replace(self, **{n: float(defaults[n]) for n in self._MEMORY_FIELDS if getattr(self, n) is None})


@dataclass(frozen=True, kw_only=True)
class TriadModel:
    """The x and y gyros (a :class:`DeviceModel` each) and the accelerometer noise ``acc_noise_g``, g.

    Body rates, defaults and the accelerometer: ``docs/simulator.md`` (the gyro).
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


def seeded_streams(entropy, names) -> dict[str, np.random.Generator]:
    """Independent generators, one per name, spawned in order from ``SeedSequence(entropy)``.

    Child i of a SeedSequence does not depend on how many are spawned: append names only.
    """
    children = np.random.SeedSequence(entropy).spawn(len(names))
    return {name: np.random.default_rng(child) for name, child in zip(names, children)}


def gauss_markov(n: int, dt_s: float, sigma: float, tau_s: float, rng: np.random.Generator) -> np.ndarray:
    """Stationary first-order Gauss–Markov sequence of ``n`` samples ``dt_s`` apart (exact discretisation),
    of standard deviation ``sigma`` (0: zeros, nothing drawn) and correlation time ``tau_s``."""
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
    """Random walk of ``n`` samples from 0, steps of s.d. ``coeff*sqrt(dt_s)`` (0: zeros, nothing drawn)."""
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
    """Temperature reading, degC: true temperature + white noise, rounded to the quantisation step."""
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
    """A plausible randomised MEMS gyro for Monte Carlo runs (the draws: ``docs/simulator.md``).

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of every draw; the same state gives the same device.
    scenario : str, optional
        ``"hysteresis"`` draws a strongly nonlinear device with memory; any other: memory off.
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
