"""The drift model of Feng et al. (2015), eq. (2): ``B_d = a*T + b*T' + c``.

``T`` is the gyro temperature (degC) and ``T'`` its rate of change (degC/s), estimated by a
causal least-squares slope over binned temperatures instead of the paper's plain difference;
a temperature that never changes is replaced by the elapsed time (:class:`ElapsedClock`).
See docs/conventions.md, section "How T' is computed".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyrodrift.settings import SettingError, check, setting

__all__ = ["TempRateConfig", "temp_rate", "drift", "regressors", "CLOCK_UNIT_S", "ElapsedClock", "temperature_is_flat"]

#: Seconds per unit of the clock regressor (:class:`ElapsedClock`; how it was chosen:
#: docs/conventions.md, section "How T' is computed").
CLOCK_UNIT_S = 300.0
#: Largest number of temperature bins in the T' window (``window_s / bin_s``).
MAX_TEMP_RATE_BINS = 100_000


@dataclass(frozen=True, kw_only=True)
class TempRateConfig:
    """Settings of the T' estimate.

    Attributes
    ----------
    window_s : float
        Length of the trailing least-squares window, s.
    bin_s : float
        Temperature averaging bin, s.
    short_s : float
        Length of the short window towards whose slope T' moves as far as it differs from the
        window's beyond its own noise (a fast change), s; 0, or a short window of fewer than
        two bins or not shorter than ``window_s``: the window alone.
    """

    window_s: float = setting(60.0, "s", gt=0.0)
    bin_s: float = setting(1.0, "s", gt=0.0)
    short_s: float = setting(10.0, "s", ge=0.0)

    @property
    def window_bins(self) -> int:
        """How many bins before the newest one the window reaches back."""
        return int(round(self.window_s / self.bin_s))

    @property
    def short_bins(self) -> int:
        """How many bins before the newest one the short window reaches back (0: none, also
        when it would hold fewer than two bins or reach as far as the window)."""
        n = int(round(self.short_s / self.bin_s))
        return n if 2 <= n < self.window_bins else 0

    def __post_init__(self):
        check(self)

    def _check_together(self):
        if not self.window_s >= 2 * self.bin_s:
            raise SettingError(f"window_s = {self.window_s!r} must be at least two bins ({2 * self.bin_s:g} s)")
        if self.window_s / self.bin_s > MAX_TEMP_RATE_BINS:
            raise SettingError(f"window_s / bin_s = {self.window_s / self.bin_s:.3g} bins is beyond "
                               f"{MAX_TEMP_RATE_BINS:,}; lengthen bin_s or shorten window_s")


def temp_rate(t_s, temp_c, config: TempRateConfig = TempRateConfig()) -> np.ndarray:
    """T' (degC/s) for every sample, causal (docs/conventions.md, section "How T' is computed";
    the compensator's own estimate is :func:`gyrodrift.kernels.drift.temp_rate_chunk`).

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
    from gyrodrift.kernels import layout
    from gyrodrift.kernels.drift import temp_rate_chunk

    t_s = np.ascontiguousarray(t_s, dtype=float)
    temp_c = np.ascontiguousarray(temp_c, dtype=float)
    out = np.zeros(t_s.size)
    fs = np.zeros(layout.N_FSTATE)
    ist = np.zeros(layout.N_ISTATE, dtype=np.int64)
    bins = np.zeros((config.window_bins + 3, 3))
    temp_rate_chunk(t_s, temp_c, config.window_bins, config.short_bins, float(config.bin_s), fs, ist, bins, out)
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
        a (deg/s/degC), b (deg/degC), c (deg/s).
    temp_c, temp_rate_cps : array_like
        T (degC) and T' (degC/s).

    >>> round(float(drift((0.01, 2.0, -0.3), 40.0, 0.01)), 12)
    0.12
    """
    a, b, c = (float(v) for v in params)
    return a * np.asarray(temp_c, dtype=float) + b * np.asarray(temp_rate_cps, dtype=float) + c


def temperature_is_flat(temp_c) -> bool:
    """Whether a temperature column cannot explain any drift: every finite value the same, or none finite."""
    temp_c = np.asarray(temp_c, dtype=float)
    if temp_c.size == 0:
        return True
    lo, hi = np.fmin.reduce(temp_c, axis=None), np.fmax.reduce(temp_c, axis=None)  # NaN skipped
    if math.isfinite(lo) and math.isfinite(hi):
        return bool(lo == hi)
    if math.isnan(lo):  # nothing but NaN
        return True
    seen = temp_c[np.isfinite(temp_c)]  # an infinity: the finite values alone
    return seen.size == 0 or bool(seen.min() == seen.max())


class ElapsedClock:
    """The regressor that stands in for a temperature that never changes: the elapsed time in units
    of :data:`CLOCK_UNIT_S`, stopped across steps longer than ``max_gap_s``, carried on from one
    call (a chunk of time stamps) to the next (docs/conventions.md, section "How T' is computed").

    Examples
    --------
    >>> clock = ElapsedClock(1.0)
    >>> clock(np.array([0.0, 150.0, 150.5, 300.5])).tolist()  # 150 s and 150 s are gaps
    [0.0, 0.0, 0.0016666666666666668, 0.0016666666666666668]
    >>> clock(np.array([301.0])).tolist()
    [0.0033333333333333335]
    """

    def __init__(self, max_gap_s: float):
        self.max_gap_s = float(max_gap_s)
        self._t_last = math.nan
        self._elapsed_s = 0.0

    def __call__(self, t_s) -> np.ndarray:
        t = np.asarray(t_s, dtype=float)
        if t.size == 0:
            return np.zeros(0)
        steps = np.diff(t, prepend=t[0] if math.isnan(self._t_last) else self._t_last)
        steps[~((steps >= 0.0) & (steps <= self.max_gap_s))] = 0.0  # gaps; bad time stamps (the engine refuses those)
        # one running sum of seconds, continued from the last chunk: the same bits in any chunks
        elapsed = np.cumsum(np.concatenate(([self._elapsed_s], steps)))[1:]
        self._t_last, self._elapsed_s = float(t[-1]), float(elapsed[-1])
        return elapsed / CLOCK_UNIT_S
