"""Allan deviation of a gyro rate (NIST SP 1065) and the noise terms of IEEE Std 952-1997 read from it.

The paper's Figure 6 (Section 4.1). How the deviation, its intervals and the terms are
computed: docs/evaluation.md, section "Allan deviation and noise terms".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from gyrodrift.errors import ConfigError

__all__ = [
    "ONE_SIGMA_CI",
    "BIAS_INSTABILITY_FACTOR",
    "SLOPE_TOLERANCE",
    "MIN_POINTS",
    "MIN_EDF",
    "AllanResult",
    "NoiseTerm",
    "NoiseTerms",
    "allan_deviation",
    "even_rate",
    "noise_terms",
    "JITTER_TOL",
]

#: Probability content of the confidence intervals, erf(1/√2) ≈ 0.6827 (±1 sigma).
ONE_SIGMA_CI = math.erf(1.0 / math.sqrt(2.0))

#: Bias-instability floor of the Allan deviation in units of B (IEEE Std 952-1997, Annex C).
BIAS_INSTABILITY_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)

#: Largest distance of a point's local log-log slope from a noise term's slope.
SLOPE_TOLERANCE = 0.15

#: Fewest consecutive points that make a region of one slope.
MIN_POINTS = 2

#: Fewest equivalent degrees of freedom of a point that defines a slope.
MIN_EDF = 10.0

_TAU_KEYWORDS = ("octave", "decade", "log10", "all")

#: Largest departure of a sample interval from the median one (relative) of an even time base.
JITTER_TOL = 0.01


def _require_allantools():
    """Import allantools or say how to install it."""
    try:
        import allantools
    except ImportError as exc:
        raise ConfigError(
            "Allan-deviation analysis needs the optional package allantools: "
            "pip install 'gyrodrift[allan]'"
        ) from exc
    return allantools


# ---------------------------------------------------------------------- results


@dataclass(frozen=True)
class AllanResult:
    """Allan deviation of a rate record, with a confidence interval per point (read-only arrays)."""

    tau_s: np.ndarray  # averaging times used, s (whole sample intervals)
    adev: np.ndarray  # in unit
    adev_lo: np.ndarray  # bounds of the ci chi-squared interval (NIST SP 1065 eq. (45))
    adev_hi: np.ndarray
    n: np.ndarray  # second differences averaged at each tau
    unit: str  # of the rate and the deviations ("deg/s" for gyro rates)
    edf: np.ndarray  # equivalent degrees of freedom (Greenhall & Riley 2004)
    alpha: np.ndarray  # the noise exponent assumed for the EDF (rate PSD ∝ f^α)
    overlapping: bool = True
    ci: float = ONE_SIGMA_CI  # probability content of adev_lo..adev_hi


@dataclass(frozen=True)
class NoiseTerm:
    """One noise coefficient read off an Allan-deviation curve."""

    value: float  # in unit
    lo: float  # its confidence interval, of the curve's probability
    hi: float
    unit: str
    tau_s: float  # where it was read, s (N 1, K 3, R √2 on the fitted line; B the minimum)
    fit_tau_s: tuple[float, float]  # smallest and largest tau of the points used, s
    n_points: int

    def scaled(self, factor: float, unit: str) -> "NoiseTerm":
        """The same term in another unit (value and interval multiplied by ``factor``)."""
        return NoiseTerm(
            self.value * factor, self.lo * factor, self.hi * factor, unit, self.tau_s, self.fit_tau_s, self.n_points
        )


@dataclass(frozen=True)
class NoiseTerms:
    """Noise coefficients of a gyro (IEEE Std 952-1997, Annex C); None = not seen."""

    arw: NoiseTerm | None  # angle random walk N, deg/√s for a rate in deg/s
    bias_instability: NoiseTerm | None  # B, deg/s
    rrw: NoiseTerm | None  # rate random walk K, deg/s/√s
    rate_ramp: NoiseTerm | None  # R, deg/s²
    unit: str  # of the rate the curve was computed from

    def _need_deg_s(self) -> None:
        if self.unit != "deg/s":
            raise ConfigError(f"per-hour units need a curve of a rate in deg/s, this one is in {self.unit!r}")

    @property
    def arw_deg_rt_h(self) -> NoiseTerm | None:
        """Angle random walk in deg/√h (deg/√s × 60)."""
        self._need_deg_s()
        return None if self.arw is None else self.arw.scaled(60.0, "deg/√h")

    @property
    def bias_instability_deg_h(self) -> NoiseTerm | None:
        """Bias instability in deg/h (deg/s × 3600)."""
        self._need_deg_s()
        return None if self.bias_instability is None else self.bias_instability.scaled(3600.0, "deg/h")


# --------------------------------------------------------------- Allan deviation


def _local_slopes(tau_s: np.ndarray, dev: np.ndarray) -> np.ndarray:
    """Local slope d(log σ)/d(log τ) at each point (mean of the two segments), NaN where undefined."""
    tau_s = np.asarray(tau_s, dtype=float)
    dev = np.asarray(dev, dtype=float)
    out = np.full(tau_s.shape, np.nan)
    if tau_s.size < 2:
        return out
    with np.errstate(divide="ignore", invalid="ignore"):
        seg = np.diff(np.log(dev)) / np.diff(np.log(tau_s))
    seg = np.where(np.isfinite(seg), seg, np.nan)
    out[0], out[-1] = seg[0], seg[-1]
    out[1:-1] = 0.5 * (seg[1:] + seg[:-1])
    return out


def _alpha_from_slope(slope: np.ndarray) -> np.ndarray:
    """Power-law exponent α (rate PSD ∝ f^α) from the local ADEV slope μ = −(α + 1)/2 (NIST SP 1065)."""
    s = np.asarray(slope, dtype=float)
    alpha = np.select([s < -0.75, s < -0.25, s < 0.25, s >= 0.25], [2, 0, -1, -2], default=0)
    return alpha.astype(int)


def _noise_alpha(tau_s: np.ndarray, dev: np.ndarray) -> np.ndarray:
    """Noise exponent for the EDF at each tau: from the slope, never whiter than at shorter taus."""
    return np.minimum.accumulate(_alpha_from_slope(_local_slopes(tau_s, dev)))


def _edf(at, alpha: int, m: int, n_phase: int, overlapping: bool) -> float:
    """Greenhall EDF of one Allan-deviation point (d = 2, unmodified; flicker for white phase where missing)."""
    try:
        return float(at.edf_greenhall(alpha=alpha, d=2, m=m, N=n_phase, overlapping=overlapping, modified=False))
    except NotImplementedError:
        if alpha != 2:
            raise
        return float(at.edf_greenhall(alpha=1, d=2, m=m, N=n_phase, overlapping=overlapping, modified=False))


def _n_terms(n_samples: int, m: np.ndarray, overlapping: bool) -> np.ndarray:
    """Number of second differences at averaging factor m for N rate samples (N + 1 phase points)."""
    m = np.asarray(m)
    return n_samples + 1 - 2 * m if overlapping else n_samples // m - 1


def _tau_request(taus, fs_hz: float, n_samples: int, overlapping: bool):
    """Validate ``taus``: an allantools keyword, or seconds kept where at least 2 terms fit."""
    if isinstance(taus, str):
        if taus not in _TAU_KEYWORDS:
            raise ConfigError(f"taus must be one of {', '.join(_TAU_KEYWORDS)} or an array of seconds, got {taus!r}")
        return taus  # every keyword grid starts at m = 1, which always fits 3+ samples
    arr = np.atleast_1d(np.asarray(taus, dtype=float))
    if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ConfigError("taus must be positive finite averaging times in seconds")
    m = np.round(arr * fs_hz)
    if np.any(m < 1):
        raise ConfigError(f"taus must be at least one sample interval ({1.0 / fs_hz:g} s)")
    fits = _n_terms(n_samples, m.astype(np.int64), overlapping) >= 2
    if not fits.any():
        raise ConfigError(
            f"no requested tau fits a record of {n_samples} samples at {fs_hz:g} Hz "
            f"(at most {(n_samples - 1) / (2 * fs_hz):g} s overlapping); use shorter taus"
        )
    return arr[fits]


def allan_deviation(
    rate,
    fs_hz: float,
    *,
    taus="octave",
    overlapping: bool = True,
    unit: str = "deg/s",
    ci: float = ONE_SIGMA_CI,
) -> AllanResult:
    """Allan deviation of a rate record with a confidence interval per point.

    See docs/evaluation.md, section "Allan deviation and noise terms".

    Parameters
    ----------
    rate : (N,) array_like
        Finite rate samples at ``fs_hz``, in ``unit``; each the mean rate over its interval.
    fs_hz : float
        Sample rate, Hz.
    taus : {"octave", "decade", "log10", "all"} or array_like
        An allantools keyword, or seconds (rounded to whole samples; too long ones dropped).
    overlapping : bool
        Overlapping (SP 1065 eq. (11)) or plain (eq. (7)) Allan deviation.
    unit : str
        Unit of ``rate``, carried into the result.
    ci : float
        Probability content of the confidence interval (default erf(1/√2) ≈ 68.27 %).

    Returns
    -------
    AllanResult

    Raises
    ------
    ConfigError
        Non-finite samples, a bad ``fs_hz``/``taus``, a record too short for any
        tau, or allantools missing.
    """
    at = _require_allantools()
    y = np.asarray(rate, dtype=float)
    if y.ndim != 1:
        raise ConfigError(f"rate must be a 1-D array of samples, got shape {y.shape}")
    bad = ~np.isfinite(y)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise ConfigError(
            f"rate has {int(bad.sum())} NaN/inf sample(s) (first at index {first}); "
            "the Allan deviation needs evenly spaced finite samples: fill or drop them first"
        )
    if not (isinstance(fs_hz, (int, float, np.floating, np.integer)) and math.isfinite(fs_hz) and fs_hz > 0):
        raise ConfigError(f"fs_hz must be a positive sample rate in Hz, got {fs_hz!r}")
    if y.size < 3:
        raise ConfigError(f"the Allan deviation needs at least 3 samples, got {y.size}")
    if not 0.0 < ci < 1.0:
        raise ConfigError(f"ci must be a probability in (0, 1), got {ci!r}")
    fs_hz = float(fs_hz)
    request = _tau_request(taus, fs_hz, y.size, overlapping)
    func = at.oadev if overlapping else at.adev
    tau_s, dev, _err, n = func(y, rate=fs_hz, data_type="freq", taus=request)
    tau_s, dev, n = (np.asarray(v, dtype=float) for v in (tau_s, dev, n))
    alpha = _noise_alpha(tau_s, dev)
    m = np.rint(tau_s * fs_hz).astype(int)
    edf = np.array([_edf(at, int(a), int(mi), y.size + 1, overlapping) for a, mi in zip(alpha, m)], dtype=float)
    bounds = np.array([at.confidence_interval(float(d), float(e), ci) for d, e in zip(dev, edf)], dtype=float)
    lo, hi = bounds[:, 0].copy(), bounds[:, 1].copy()
    n = n.astype(int)
    for arr in (tau_s, dev, lo, hi, n, edf, alpha):
        arr.setflags(write=False)
    return AllanResult(
        tau_s=tau_s,
        adev=dev,
        adev_lo=lo,
        adev_hi=hi,
        n=n,
        unit=unit,
        edf=edf,
        alpha=alpha,
        overlapping=bool(overlapping),
        ci=float(ci),
    )


def even_rate(t_s, rate) -> tuple[np.ndarray, float, bool]:
    """``(rate, fs_hz, resampled)``: a rate record on an even time base, for :func:`allan_deviation`.

    ``t_s`` are increasing times, s (N >= 3); ``rate`` is returned as it is when the time
    base is even, else as N − 1 mean rates over even intervals (docs/evaluation.md).
    """
    t = np.asarray(t_s, dtype=float)
    r = np.asarray(rate, dtype=float)
    if t.ndim != 1 or t.shape != r.shape or t.size < 3:
        raise ConfigError("even_rate needs times and rates of one equal length, at least 3")
    step = np.diff(t)
    if not np.all(step > 0):
        raise ConfigError("even_rate needs increasing times")
    fs = (t.size - 1) / float(t[-1] - t[0])
    median = float(np.median(step))
    if np.max(np.abs(step - median)) <= JITTER_TOL * median:
        return r, fs, False
    angle = np.r_[0.0, np.cumsum(r[1:] * step)]
    even = np.interp(t[0] + np.arange(t.size) / fs, t, angle)
    return np.diff(even) * fs, fs, True


# ------------------------------------------------------------------ noise terms


def _longest_run(mask: np.ndarray) -> tuple[int, int] | None:
    """(start, stop) of the longest run of True in ``mask``, the earliest on ties."""
    best = None
    start = None
    for i, v in enumerate(np.r_[np.asarray(mask, dtype=bool), False]):
        if v and start is None:
            start = i
        elif not v and start is not None:
            if best is None or i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    return best


def _sloped_term(res: AllanResult, usable, local, slope: float, tau_ref: float, unit: str, tol, min_points):
    """Fixed-slope least-squares line (log-log) through the region of ``slope``, read at ``tau_ref``."""
    run = _longest_run(usable & (np.abs(local - slope) <= tol))
    if run is None or run[1] - run[0] < min_points:
        return None
    sl = slice(*run)
    log_tau = np.log(res.tau_s[sl])

    def read(dev):
        c = float(np.mean(np.log(dev[sl]) - slope * log_tau))
        return math.exp(c + slope * math.log(tau_ref))

    with np.errstate(divide="ignore"):
        return NoiseTerm(
            value=read(res.adev),
            lo=read(res.adev_lo),
            hi=read(res.adev_hi),
            unit=unit,
            tau_s=float(tau_ref),
            fit_tau_s=(float(res.tau_s[sl][0]), float(res.tau_s[sl][-1])),
            n_points=run[1] - run[0],
        )


def _units(unit: str) -> tuple[str, str, str, str]:
    if unit == "deg/s":
        return "deg/√s", "deg/s", "deg/s/√s", "deg/s²"
    u = f"({unit})" if unit else "1"
    return f"{u}·√s", unit, f"{u}/√s", f"{u}/s"


def noise_terms(
    result: AllanResult,
    *,
    tolerance: float = SLOPE_TOLERANCE,
    min_points: int = MIN_POINTS,
    min_edf: float = MIN_EDF,
) -> NoiseTerms:
    """Read N, B, K and R off an Allan-deviation curve (IEEE Std 952-1997 Annex C, slope method).

    See docs/evaluation.md, section "Allan deviation and noise terms".

    Parameters
    ----------
    result : AllanResult
        From :func:`allan_deviation`.
    tolerance : float
        Largest distance of a point's local slope from a term's slope, in its region.
    min_points : int
        Fewest consecutive points that make a region.
    min_edf : float
        Points with fewer equivalent degrees of freedom are not used.

    Returns
    -------
    NoiseTerms
        Each term None when the curve has no region of its slope.
    """
    if not 0.0 < tolerance < 0.25:
        raise ConfigError(f"tolerance must be in (0, 0.25) so regions cannot overlap, got {tolerance!r}")
    if not (isinstance(min_points, int) and min_points >= 1):
        raise ConfigError(f"min_points must be a whole number >= 1, got {min_points!r}")
    u_n, u_b, u_k, u_r = _units(result.unit)
    local = _local_slopes(result.tau_s, result.adev)
    usable = (result.adev > 0) & np.isfinite(local) & (result.edf >= min_edf)

    arw = _sloped_term(result, usable, local, -0.5, 1.0, u_n, tolerance, min_points)
    rrw = _sloped_term(result, usable, local, 0.5, 3.0, u_k, tolerance, min_points)
    ramp = _sloped_term(result, usable, local, 1.0, math.sqrt(2.0), u_r, tolerance, min_points)

    bias = None
    run = _longest_run(usable & (np.abs(local) <= tolerance))
    if run is not None:
        idx = np.arange(*run)
        i = int(idx[np.argmin(result.adev[idx])])
        if idx.size >= min_points:
            f = BIAS_INSTABILITY_FACTOR
            bias = NoiseTerm(
                value=float(result.adev[i] / f),
                lo=float(result.adev_lo[i] / f),
                hi=float(result.adev_hi[i] / f),
                unit=u_b,
                tau_s=float(result.tau_s[i]),
                fit_tau_s=(float(result.tau_s[idx[0]]), float(result.tau_s[idx[-1]])),
                n_points=int(idx.size),
            )
    return NoiseTerms(arw=arw, bias_instability=bias, rrw=rrw, rate_ramp=ramp, unit=result.unit)
