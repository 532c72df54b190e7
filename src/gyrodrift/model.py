"""The drift model of Feng et al. (2015), eq. (2): ``B_d = a*T + b*T' + c``.

``T`` is the gyro temperature (degC) and ``T'`` its rate of change (degC/s).

How T' is computed
------------------
The paper uses a plain difference over the 10-s update interval,
``T'_{k+1} = (T_{k+1} - T_k)/Δt``. Real sensors quantise temperature (0.0625 degC, or
1 degC on some Bosch parts), so a plain difference is zero most of the time and
spikes when the reading steps. gyrodrift instead:

1. averages the temperature over bins of ``bin_s`` seconds (default 1 s), aligned on
   the first sample;
2. fits a least-squares line through the completed bins of the trailing
   ``window_s`` seconds (default 60 s: the newest bin and the 60 before it, counted by
   bin number so that the choice does not depend on rounding) and takes its slope as T'.

The estimate is causal: a sample uses only bins that closed before its own bin
(so streaming and batch give the same numbers). It is exact for a linear ramp
once the window is full; on a curved profile it lags by about ``window_s/2 + bin_s``;
until two bins have closed T' is 0. A quantisation step of q degC moves T' by at most
about ``q/window_s``-scale amounts instead of ``q/Δt`` spikes; choose a longer window
for coarser sensors.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

__all__ = ["TempRateConfig", "TempRateTracker", "temp_rate", "drift", "regressors"]


@dataclass(frozen=True, kw_only=True)
class TempRateConfig:
    """Settings of the T' estimate.

    Attributes
    ----------
    window_s : float
        Length of the trailing least-squares window, s.
    bin_s : float
        Temperature averaging bin, s.
    """

    window_s: float = 60.0
    bin_s: float = 1.0

    @property
    def window_bins(self) -> int:
        """How many bins before the newest one the window reaches back."""
        return int(round(self.window_s / self.bin_s))

    def __post_init__(self):
        if not (self.bin_s > 0 and math.isfinite(self.bin_s)):
            raise ValueError(f"bin_s must be a positive number of seconds, got {self.bin_s!r}")
        if not (self.window_s >= 2 * self.bin_s and math.isfinite(self.window_s)):
            raise ValueError(
                f"window_s must be at least two bins ({2 * self.bin_s} s), got {self.window_s!r}"
            )


def _bin_mean(t_s: np.ndarray, temp_c: np.ndarray) -> tuple[float, float]:
    return float(np.mean(t_s)), float(np.mean(temp_c))


def _ls_slope(bin_t_s: np.ndarray, bin_temp_c: np.ndarray) -> float:
    """Least-squares slope (degC/s) of temperature against time; 0 if undetermined."""
    if bin_t_s.size < 2:
        return 0.0
    dt = bin_t_s - np.mean(bin_t_s)
    sxx = float(np.dot(dt, dt))
    if sxx <= 0.0:
        return 0.0
    return float(np.dot(dt, bin_temp_c - np.mean(bin_temp_c))) / sxx


class TempRateTracker:
    """Streaming T' estimate: feed samples in time order, get T' (degC/s) for each.

    Gives bit-for-bit the same values as :func:`temp_rate` on the same samples.
    """

    def __init__(self, config: TempRateConfig = TempRateConfig()):
        self._cfg = config
        self._t0: float | None = None
        self._bin: int | None = None
        self._cur_t: list[float] = []
        self._cur_temp: list[float] = []
        self._bins: deque[tuple[float, float]] = deque()
        self._rate = 0.0

    def push(self, t_s: float, temp_c: float) -> float:
        """Add one sample; return T' (degC/s) in force for it."""
        if self._t0 is None:
            self._t0 = t_s
        b = math.floor((t_s - self._t0) / self._cfg.bin_s)
        if self._bin is not None and b != self._bin:
            self._close_bin()
        self._bin = b
        self._cur_t.append(t_s)
        self._cur_temp.append(temp_c)
        return self._rate

    def _close_bin(self) -> None:
        tb, Tb = _bin_mean(np.array(self._cur_t), np.array(self._cur_temp))
        self._cur_t, self._cur_temp = [], []
        self._bins.append((self._bin, tb, Tb))
        while self._bins[0][0] < self._bin - self._cfg.window_bins:
            self._bins.popleft()
        arr = np.array(self._bins)
        self._rate = _ls_slope(arr[:, 1], arr[:, 2])


def temp_rate(t_s, temp_c, config: TempRateConfig = TempRateConfig()) -> np.ndarray:
    """T' (degC/s) for every sample, causal; see the module notes for the method.

    Parameters
    ----------
    t_s : (N,) array_like
        Sample times, s, strictly increasing.
    temp_c : (N,) array_like
        Temperature, degC, no NaN.
    config : TempRateConfig

    Returns
    -------
    (N,) ndarray
        T', degC/s.

    Examples
    --------
    A ramp of 0.01 degC/s, sampled at 10 Hz: after the first bins, T' is the slope.

    >>> t = np.arange(0, 120, 0.1)
    >>> round(float(temp_rate(t, 20 + 0.01 * t)[-1]), 6)
    0.01
    """
    t_s = np.asarray(t_s, dtype=float)
    temp_c = np.asarray(temp_c, dtype=float)
    out = np.zeros(t_s.size)
    if t_s.size == 0:
        return out
    bins = np.floor((t_s - t_s[0]) / config.bin_s)
    starts = np.flatnonzero(np.r_[True, bins[1:] != bins[:-1]])
    ends = np.r_[starts[1:], t_s.size]
    bin_t = np.empty(starts.size)
    bin_temp = np.empty(starts.size)
    first = 0  # first bin inside the trailing window
    rate = 0.0
    for j, (s, e) in enumerate(zip(starts, ends)):
        out[s:e] = rate
        bin_t[j], bin_temp[j] = _bin_mean(t_s[s:e], temp_c[s:e])
        while bins[starts[first]] < bins[s] - config.window_bins:
            first += 1
        rate = _ls_slope(bin_t[first : j + 1], bin_temp[first : j + 1])
    return out


def regressors(temp_c, temp_rate_cps) -> np.ndarray:
    """Rows ``[T, T', 1]`` of the measurement matrix H (eq. 3), shape (N, 3)."""
    temp_c = np.atleast_1d(np.asarray(temp_c, dtype=float))
    temp_rate_cps = np.atleast_1d(np.asarray(temp_rate_cps, dtype=float))
    return np.column_stack([temp_c, temp_rate_cps, np.ones_like(temp_c)])


def drift(params, temp_c, temp_rate_cps):
    """Drift ``a*T + b*T' + c`` (deg/s), eq. (2)/(5).

    Parameters
    ----------
    params : sequence of 3 floats
        a (deg/s/degC), b (deg), c (deg/s).
    temp_c, temp_rate_cps : array_like
        T (degC) and T' (degC/s).

    >>> round(float(drift((0.01, 2.0, -0.3), 40.0, 0.01)), 12)
    0.12
    """
    a, b, c = (float(v) for v in params)
    return a * np.asarray(temp_c, dtype=float) + b * np.asarray(temp_rate_cps, dtype=float) + c
