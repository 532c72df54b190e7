"""Tests of gyrodrift.evaluate.allan: published NBS14 values, synthetic noise of known level, properties."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

pytest.importorskip("allantools")

from gyrodrift.evaluate.allan import (  # noqa: E402
    AllanResult,
    allan_deviation,
    even_rate,
    noise_terms,
)
from gyrodrift.errors import ConfigError  # noqa: E402

DATA = Path(__file__).resolve().parent / "data"


# ------------------------------------------------------------------ NBS14 (SP 1065)


def nbs14_10() -> np.ndarray:
    return np.loadtxt(DATA / "nbs14_10point_freq.txt", comments="#")


def nbs14_1000() -> np.ndarray:
    """The 1000-point NBS14 set: n[i+1] = 16807 n[i] mod (2^31 - 1), n[0] = 1234567890."""
    n = [1234567890]
    for _ in range(999):
        n.append((16807 * n[-1]) % 2147483647)
    assert n[1:4] == [395529916, 1209410747, 633705974]  # as printed in SP 1065
    return np.array(n, dtype=float) / 2147483647.0


def reference(dataset: str, statistic: str) -> pd.DataFrame:
    ref = pd.read_csv(DATA / "nbs14_deviations.csv")
    return ref[(ref.dataset == dataset) & (ref.statistic == statistic)]


def direct_adev(y: np.ndarray, m: int, overlapping: bool) -> float:
    """Allan deviation of frequency data straight from its definition (independent check).

    Differences of adjacent m-sample means, y̅(k+m) − y̅(k); overlapping: every start
    k; non-overlapping: k = 0, m, 2m, ... ; σ² = ½ ⟨(difference)²⟩.
    """
    c = np.r_[0.0, np.cumsum(y)]
    means = (c[m:] - c[:-m]) / m  # mean of y[k:k+m] for every k
    d = means[m:] - means[:-m]
    if not overlapping:
        d = d[::m]
    return math.sqrt(0.5 * np.mean(d * d))


@pytest.mark.parametrize("dataset, data", [("nbs14_10", nbs14_10), ("nbs14_1000", nbs14_1000)])
@pytest.mark.parametrize("statistic, overlapping", [("adev", False), ("oadev", True)])
def test_nbs14_published_values(dataset, data, statistic, overlapping):
    ref = reference(dataset, statistic)
    assert len(ref) >= 2
    y = data()
    r = allan_deviation(y, 1.0, taus=ref.tau_s.to_numpy(float), overlapping=overlapping, unit="")
    np.testing.assert_array_equal(r.tau_s, ref.tau_s.to_numpy(float))
    np.testing.assert_allclose(r.adev, ref.value.to_numpy(), rtol=1e-4)
    # the published numbers also follow from the definition (checks data and values)
    direct = [direct_adev(y, int(m), overlapping) for m in ref.tau_s]
    np.testing.assert_allclose(direct, ref.value.to_numpy(), rtol=1e-4)


def test_nbs14_term_counts():
    r = allan_deviation(nbs14_1000(), 1.0, taus=[1, 10, 100], overlapping=True, unit="")
    np.testing.assert_array_equal(r.n, [999, 981, 801])  # N − 2m second differences
    r = allan_deviation(nbs14_1000(), 1.0, taus=[1, 10, 100], overlapping=False, unit="")
    np.testing.assert_array_equal(r.n, [999, 99, 9])


# --------------------------------------------------------------- result contract


def test_result_fields_and_interval():
    rng = np.random.default_rng(3)
    r = allan_deviation(rng.normal(0.0, 0.1, 5000), 10.0)
    assert isinstance(r, AllanResult)
    assert r.unit == "deg/s" and r.overlapping
    m = r.tau_s * 10.0
    np.testing.assert_allclose(m, 2.0 ** np.arange(m.size))  # octave taus, in seconds
    assert np.all(r.adev_lo < r.adev) and np.all(r.adev < r.adev_hi)
    assert np.all(np.diff(r.edf) < 0)  # fewer degrees of freedom at longer tau
    assert np.all(r.n == 5000 + 1 - 2 * np.rint(m))
    assert abs(r.ci - 0.6827) < 1e-4
    with pytest.raises(AttributeError):
        r.unit = "x"  # frozen
    with pytest.raises(ValueError):
        r.adev[0] = 0.0  # read-only arrays


def test_interval_matches_chi_squared_with_greenhall_edf():
    import allantools as at

    rng = np.random.default_rng(4)
    y = rng.normal(0.0, 1.0, 4096)
    r = allan_deviation(y, 1.0, taus=[1, 4, 16])
    assert list(r.alpha) == [0, 0, 0]  # white rate noise identified from the slope
    for tau, dev, lo, hi in zip(r.tau_s, r.adev, r.adev_lo, r.adev_hi):
        edf = at.edf_greenhall(alpha=0, d=2, m=int(tau), N=y.size + 1, overlapping=True, modified=False)
        assert (lo, hi) == pytest.approx(at.confidence_interval(dev, edf), rel=1e-12)


def test_taus_in_seconds_round_to_samples():
    r = allan_deviation(np.random.default_rng(0).normal(size=1000), 100.0, taus=[0.01, 0.0149, 0.1, 0.1])
    np.testing.assert_allclose(r.tau_s, [0.01, 0.1])


@pytest.mark.parametrize(
    "rate, fs, kw",
    [
        ([1.0, np.nan, 2.0, 3.0], 1.0, {}),
        ([1.0, 2.0, np.inf, 3.0], 1.0, {}),
        ([1.0, 2.0, 3.0, 4.0], 0.0, {}),
        ([1.0, 2.0], 1.0, {}),
        (np.ones((3, 3)), 1.0, {}),
        ([1.0, 2.0, 3.0, 4.0], 1.0, {"taus": "weekly"}),
        ([1.0, 2.0, 3.0, 4.0], 1.0, {"taus": [-1.0]}),
        ([1.0, 2.0, 3.0, 4.0], 1.0, {"taus": [0.2]}),
        ([1.0, 2.0, 3.0, 4.0], 1.0, {"taus": [100.0]}),
    ],
)
def test_bad_input_is_a_config_error(rate, fs, kw):
    with pytest.raises(ConfigError):
        allan_deviation(rate, fs, **kw)


def test_nan_message_says_fill_or_drop():
    with pytest.raises(ConfigError, match="fill or drop"):
        allan_deviation([1.0, 2.0, np.nan, 4.0, 5.0], 1.0)


def test_missing_allantools_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "allantools", None)  # makes `import allantools` fail
    with pytest.raises(ConfigError, match=r"pip install 'gyrodrift\[allan\]'"):
        allan_deviation(np.ones(10), 1.0)


# ------------------------------------------------------------- noise extraction


FS = 100.0


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_white_noise_gives_arw(seed):
    """(b) White rate noise of density N: ADEV = N/√τ, so N is σ at τ = 1 s."""
    n_true = 0.04  # deg/√s (ADXRS623: 0.04 deg/s/√Hz)
    rng = np.random.default_rng(seed)
    rate = rng.normal(0.0, n_true * math.sqrt(FS), int(3600 * FS))  # one hour
    terms = noise_terms(allan_deviation(rate, FS))
    assert terms.arw is not None
    assert terms.arw.value == pytest.approx(n_true, rel=0.05)
    assert terms.arw.lo < terms.arw.value < terms.arw.hi
    assert terms.arw.lo < n_true < terms.arw.hi
    assert terms.arw.unit == "deg/√s" and terms.arw.tau_s == 1.0
    assert terms.arw.fit_tau_s[0] == pytest.approx(1.0 / FS)
    assert terms.arw_deg_rt_h.value == pytest.approx(60.0 * terms.arw.value)
    assert terms.arw_deg_rt_h.unit == "deg/√h"
    assert terms.rrw is None and terms.rate_ramp is None and terms.bias_instability is None


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rate_random_walk_gives_k(seed):
    """(c) Random walk in rate: ADEV = K·sqrt(τ/3), so K is σ at τ = 3 s."""
    k_true, fs = 1e-3, 10.0  # deg/s/√s
    rng = np.random.default_rng(seed)
    rate = np.cumsum(rng.normal(0.0, k_true / math.sqrt(fs), 200_000))
    terms = noise_terms(allan_deviation(rate, fs))
    assert terms.rrw is not None
    assert terms.rrw.value == pytest.approx(k_true, rel=0.15)
    assert terms.rrw.tau_s == 3.0 and terms.rrw.unit == "deg/s/√s"
    assert terms.arw is None and terms.rate_ramp is None and terms.bias_instability is None


def test_ramp_gives_r():
    """(d) A pure ramp R·t: ADEV = R·τ/√2 exactly, every point on the +1 line."""
    r_true, fs = 2.5e-4, 10.0  # deg/s²
    t = np.arange(30_000) / fs
    terms = noise_terms(allan_deviation(r_true * t + 0.3, fs))
    assert terms.rate_ramp is not None
    assert terms.rate_ramp.value == pytest.approx(r_true, rel=1e-9)
    assert terms.rate_ramp.unit == "deg/s²" and terms.rate_ramp.tau_s == pytest.approx(math.sqrt(2.0))
    assert terms.arw is None and terms.rrw is None and terms.bias_instability is None


def _flicker(rng: np.random.Generator, n: int, sigma: float) -> np.ndarray:
    """Flicker (1/f) rate noise by fractional integration of white noise, d = 1/2.

    Kasdin & Walter (1992): impulse response h0 = 1, h_k = h_(k-1)·(k − 1/2)/k, i.e.
    (1 − z⁻¹)^(−1/2). At low frequency the two-sided PSD is σ²τ0/(2πfτ0) = σ²/(2πf),
    one-sided h₋₁/f with h₋₁ = σ²/π, so the ADEV floor sqrt(2 ln 2 · h₋₁) is
    σ·sqrt(2 ln 2/π): B = σ in IEEE 952 terms.
    """
    k = np.arange(1, n)
    h = np.r_[1.0, np.cumprod((k - 0.5) / k)]
    w = rng.normal(0.0, sigma, n)
    size = 2 * n
    return np.fft.irfft(np.fft.rfft(h, size) * np.fft.rfft(w, size), size)[:n]


@pytest.mark.parametrize("seed", [0, 1])
def test_flicker_noise_gives_bias_instability(seed):
    b_true = 0.01  # deg/s
    terms = noise_terms(allan_deviation(_flicker(np.random.default_rng(seed), 2**17, b_true), 10.0))
    assert terms.bias_instability is not None
    # B is the minimum of a noisy floor, a slight under-estimate
    assert terms.bias_instability.value == pytest.approx(b_true, rel=0.25)
    b_h = terms.bias_instability_deg_h
    assert b_h.value == pytest.approx(3600.0 * terms.bias_instability.value) and b_h.unit == "deg/h"
    assert terms.arw is None and terms.rrw is None and terms.rate_ramp is None


def test_gyro_like_curve_shows_arw_flicker_and_rrw():
    """ARW + flicker + RRW: all three regions found; transitions bias N and B up (documented)."""
    rng = np.random.default_rng(0)
    fs, n = 10.0, 2**20
    n_true, b_true, k_true = 0.02, 0.01, 1e-3
    rate = (
        rng.normal(0.0, n_true * math.sqrt(fs), n)
        + _flicker(rng, n, b_true)
        + np.cumsum(rng.normal(0.0, k_true / math.sqrt(fs), n))
    )
    terms = noise_terms(allan_deviation(rate, fs))
    assert terms.arw is not None and terms.bias_instability is not None and terms.rrw is not None
    assert terms.arw.fit_tau_s[1] < terms.bias_instability.fit_tau_s[0]
    assert terms.bias_instability.fit_tau_s[1] < terms.rrw.fit_tau_s[0]
    assert terms.arw.value == pytest.approx(n_true, rel=0.1)
    assert terms.bias_instability.value == pytest.approx(b_true, rel=0.3)
    assert terms.rrw.value == pytest.approx(k_true, rel=0.2)
    assert terms.rate_ramp is None


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_arw_meeting_a_ramp_has_no_flicker_floor(seed):
    """ARW then a ramp: N and R read off their regions; the bottom of the U is not B."""
    rng = np.random.default_rng(seed)
    fs = 10.0
    t = np.arange(2**17) / fs
    rate = rng.normal(0.0, 0.02 * math.sqrt(fs), t.size) + 1e-4 * t
    terms = noise_terms(allan_deviation(rate, fs))
    assert terms.arw.value == pytest.approx(0.02, rel=0.05)
    assert terms.rate_ramp.value == pytest.approx(1e-4, rel=0.1)
    assert terms.bias_instability is None and terms.rrw is None


def test_constant_rate_shows_no_term():
    terms = noise_terms(allan_deviation(np.full(1000, 0.2), 1.0))
    assert (terms.arw, terms.bias_instability, terms.rrw, terms.rate_ramp) == (None, None, None, None)


def test_per_hour_units_need_deg_per_s():
    r = allan_deviation(np.random.default_rng(0).normal(size=5000), 1.0, unit="rad/s")
    terms = noise_terms(r)
    assert terms.arw is not None and terms.arw.unit == "(rad/s)·√s"
    with pytest.raises(ConfigError):
        terms.arw_deg_rt_h


@pytest.mark.parametrize("kw", [{"tolerance": 0.0}, {"tolerance": 0.3}, {"min_points": 0}])
def test_bad_extraction_settings(kw):
    r = allan_deviation(np.random.default_rng(0).normal(size=100), 1.0)
    with pytest.raises(ConfigError):
        noise_terms(r, **kw)


# ------------------------------------------------------------------- property (e)


def _mixed_rate() -> np.ndarray:
    """ARW (0.02 deg/√s) + flicker (B = 0.005 deg/s) + RRW (2e-3 deg/s/√s) at 10 Hz."""
    rng = np.random.default_rng(11)
    fs, n = 10.0, 2**16
    return (
        rng.normal(0.0, 0.02 * math.sqrt(fs), n)
        + _flicker(rng, n, 0.005)
        + np.cumsum(rng.normal(0.0, 2e-3 / math.sqrt(fs), n))
    )


MIXED = _mixed_rate()
MIXED_TERMS = noise_terms(allan_deviation(MIXED, 10.0))


@settings(max_examples=25, deadline=None)
@given(k=st.floats(min_value=1e-3, max_value=1e3, allow_nan=False, allow_infinity=False))
def test_scaling_the_input_scales_every_term(k):
    """(e) ADEV is linear in the rate: N, B, K, R and their intervals scale by k; the regions stay."""
    scaled = noise_terms(allan_deviation(k * MIXED, 10.0))
    for name in ("arw", "bias_instability", "rrw", "rate_ramp"):
        a, b = getattr(MIXED_TERMS, name), getattr(scaled, name)
        assert (a is None) == (b is None), name
        if a is not None:
            assert b.value == pytest.approx(k * a.value, rel=1e-9)
            assert (b.lo, b.hi) == pytest.approx((k * a.lo, k * a.hi), rel=1e-9)
            assert (b.tau_s, b.fit_tau_s, b.n_points) == (a.tau_s, a.fit_tau_s, a.n_points)


def test_mixed_curve_has_terms():
    """The property above is not vacuous: the mixed record shows several terms."""
    present = [n for n in ("arw", "bias_instability", "rrw", "rate_ramp") if getattr(MIXED_TERMS, n) is not None]
    assert len(present) >= 2


# ------------------------------------------------------------------ jittery time bases


def test_an_even_time_base_is_left_as_it_is():
    t = np.arange(1000) / FS
    t[500] += 0.005 / FS  # within JITTER_TOL
    rate = np.random.default_rng(0).normal(size=t.size)
    out, fs, resampled = even_rate(t, rate)
    assert out is rate and not resampled and fs == pytest.approx(FS)


def test_a_jittery_time_base_is_resampled_keeping_the_angle_and_the_arw():
    """White rate noise of density N sampled at times jittering by ±40 %: the angle is kept at the
    even times and the ARW stays N (linear interpolation of the angle lowers the shortest taus a little)."""
    n_true, rng = 0.04, np.random.default_rng(3)
    step = (1.0 + rng.uniform(-0.4, 0.4, int(3600 * FS))) / FS
    t = np.r_[0.0, np.cumsum(step)]
    angle = np.r_[0.0, np.cumsum(n_true * np.sqrt(step) * rng.normal(size=step.size))]  # a Wiener angle
    rate = np.r_[0.0, np.diff(angle) / step]  # each the mean over the interval ending at its time
    out, fs, resampled = even_rate(t, rate)
    assert resampled and out.size == t.size - 1 and fs == pytest.approx((t.size - 1) / t[-1])
    assert out.sum() / fs == pytest.approx(angle[-1], abs=1e-9)  # the angle is kept
    assert noise_terms(allan_deviation(out, fs)).arw.value == pytest.approx(n_true, rel=0.1)
    with pytest.raises(ConfigError, match="increasing"):
        even_rate(t[::-1], rate)


def test_a_jittery_ramp_is_resampled_onto_its_even_times():
    """A rate ramp R t at jittered times: the samples drift up to about a second from the even
    times they would be given (the jitter adds up); resampled, each is the ramp's mean over its
    even interval."""
    ramp, rng = 1e-3, np.random.default_rng(4)
    t = np.r_[0.0, np.cumsum((1.0 + rng.uniform(-0.4, 0.4, int(3600 * FS))) / FS)]
    rate = np.r_[0.0, ramp * 0.5 * (t[1:] + t[:-1])]
    out, fs, _ = even_rate(t, rate)
    even = np.arange(t.size) / fs
    expected = ramp * 0.5 * (even[1:] + even[:-1])
    assert np.max(np.abs(out - expected)) < 0.5 * ramp / FS  # the interpolated angle: within half an interval
    assert np.max(np.abs(rate[1:] - expected)) > 100 * ramp / FS  # as if even, off by many intervals
