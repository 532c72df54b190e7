import numpy as np
import pytest

from gyrodrift.model import TempRateConfig, drift, regressors, temp_rate


def test_ramp_slope_is_exact_once_window_is_full():
    t = np.arange(0.0, 200.0, 0.05)
    rate = temp_rate(t, 20.0 + 0.013 * t)
    full = t > 62.0  # window (60 s) + one bin (1 s) + the bin being filled
    np.testing.assert_allclose(rate[full], 0.013, rtol=1e-9)
    assert np.all(rate[t < 1.0] == 0.0)  # no closed bin yet


def test_matches_bin_means_and_a_least_squares_line_written_out():
    """Irregular sampling, quantised temperature: each sample's T' is the slope of np.polyfit
    through the means of the closed bins of the trailing window (bins counted by number)."""
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.05, 6000))
    temp = np.round((30 + 5 * np.sin(t / 100) + rng.normal(0, 0.02, t.size)) / 0.0625) * 0.0625
    cfg = TempRateConfig(window_s=30.0, bin_s=0.5, short_s=0.0)
    got = temp_rate(t, temp, cfg)
    np.testing.assert_allclose(got, _written_out(t, temp, cfg), rtol=1e-7, atol=1e-12)


def _written_out(t, temp, cfg):
    """T' by np.polyfit through the closed bins' means; with ``short_s``, moved towards the
    short window's slope by 1 - v/d² of their difference d where d² > v, v the short slope's
    variance: at least the square of the slope that a step by the temperature's resolution (its
    smallest step between rows so far) gives at the worst place in the short window; then, the
    same way, towards the slope at the newest bin of a quadratic through the short window."""
    k = np.floor((t - t[0]) / cfg.bin_s)
    expected = np.zeros(t.size)
    steps = np.abs(np.diff(temp, prepend=temp[0]))
    for i in range(t.size):
        closed = np.unique(k[k < k[i]])
        closed = closed[closed >= k[i] - 1 - cfg.window_bins]  # the newest closed bin and window_bins before it
        if closed.size < 2:
            continue
        bt = np.array([t[k == b].mean() for b in closed])
        bT = np.array([temp[k == b].mean() for b in closed])
        expected[i] = np.polyfit(bt, bT, 1)[0]
        if cfg.short_bins == 0:
            continue
        short = closed >= closed[-1] - cfg.short_bins
        if short.sum() < 3:
            continue
        (slope, icpt), res, *_ = np.polyfit(bt[short], bT[short], 1, full=True)
        ss = float(res[0]) if res.size else 0.0
        done = k < closed[-1] + 1  # the rows of the closed bins
        pos = steps[1:][done[1:]]
        resolution = pos[pos > 0].min() if np.any(pos > 0) else 0.0
        ts = bt[short]
        sxx = np.sum((ts - ts.mean()) ** 2)
        steps_at = [np.polyfit(ts, (np.arange(ts.size) >= j).astype(float), 1)[0] for j in range(1, ts.size)]
        v = max(ss / (short.sum() - 2) / sxx, (resolution * max(steps_at)) ** 2)
        d = slope - expected[i]
        if d * d > v:
            expected[i] += (1.0 - v / (d * d)) * d
        if short.sum() < 5:
            continue
        # then towards the slope at the newest bin of a quadratic through the short window's bins
        u = ts - ts[-1]
        coef, res2, *_ = np.polyfit(u, bT[short], 2, full=True)
        X = np.vander(u, 3)
        cov = np.linalg.inv(X.T @ X)[1, 1]  # of the linear coefficient, the slope at u = 0
        ss2 = float(res2[0]) if res2.size else 0.0
        steps_at = [np.polyfit(u, (np.arange(u.size) >= j).astype(float), 2)[1] for j in range(1, u.size)]
        v2 = max(ss2 / (u.size - 3) * cov, (resolution * max(np.abs(steps_at))) ** 2)
        d2 = coef[1] - expected[i]
        if d2 * d2 > v2:
            expected[i] += (1.0 - v2 / (d2 * d2)) * d2
    return expected


def test_the_short_window_is_the_rule_written_out():
    """A temperature with a shock (−0.4 degC/s for 30 s) on a noisy, quantised sinusoid,
    irregularly sampled: each sample's T' is the window's slope moved towards the short
    window's as far as they differ beyond the short one's noise."""
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.02, 0.1, 3000))
    shock = -0.4 * np.clip(t - 120.0, 0.0, 30.0)
    temp = np.round((30 + 5 * np.sin(t / 100) + shock + rng.normal(0, 0.02, t.size)) / 0.0625) * 0.0625
    cfg = TempRateConfig(window_s=30.0, bin_s=0.5, short_s=5.0)
    got = temp_rate(t, temp, cfg)
    np.testing.assert_allclose(got, _written_out(t, temp, cfg), rtol=1e-7, atol=1e-12)
    assert np.any(got != temp_rate(t, temp, TempRateConfig(window_s=30.0, bin_s=0.5, short_s=0.0)))


@pytest.mark.parametrize("quantum_c", [0.0625, 1.0])
@pytest.mark.parametrize("slope_cps", [0.01, 0.05, 0.1])
def test_a_quantised_ramp_keeps_the_window_s_rate_to_the_bit(quantum_c, slope_cps):
    """One step of the reading inside the short window is no change of T': on a quantised ramp
    the short window never moves the window's slope."""
    t = np.arange(0.0, 3000.0, 0.1)
    temp = np.floor((20.0 + slope_cps * t) / quantum_c) * quantum_c
    assert np.array_equal(temp_rate(t, temp), temp_rate(t, temp, TempRateConfig(short_s=0.0)))


@pytest.mark.parametrize("quantum_c", [0.0, 0.0625])
def test_a_shock_is_followed_within_the_short_window(quantum_c):
    """A temperature that falls at 0.5 degC/s from 150 s: T' is the shock's within about
    ``short_s`` (the 60-s window alone is still at a quarter of it 20 s in). A reading in whole
    degrees moves less far: a 1-degC step within 10 s is a slope of 0.11 degC/s of noise."""
    t = np.arange(0.0, 200.0, 0.1)
    temp = 30.0 - 0.5 * np.clip(t - 150.0, 0.0, None)
    if quantum_c:
        temp = np.round(temp / quantum_c) * quantum_c
    late = (t > 163.0) & (t < 200.0)
    np.testing.assert_allclose(temp_rate(t, temp)[late], -0.5, atol=0.03)
    assert np.all(temp_rate(t, temp, TempRateConfig(short_s=0.0))[t < 170.0] > -0.2)


@pytest.mark.parametrize("quantum_c", [0.0625, 1.0])
def test_quantised_temperature_gives_no_spikes(quantum_c):
    """The paper's plain 10-s difference spikes on quantised temperature; ours stays near the truth."""
    t = np.arange(0.0, 3000.0, 0.1)
    true_rate = 0.01
    temp = np.floor((20.0 + true_rate * t) / quantum_c) * quantum_c
    window = 60.0 if quantum_c < 0.5 else 600.0
    ours = temp_rate(t, temp, TempRateConfig(window_s=window))[t > window + 2]
    k = 100  # 10 s at 10 Hz
    plain = ((temp[k:] - temp[:-k]) / 10.0)[t[k:] > window + 2]
    err_ours = np.max(np.abs(ours - true_rate))
    err_plain = np.max(np.abs(plain - true_rate))
    assert err_ours < 0.5 * err_plain
    assert err_ours < (0.3 if quantum_c < 0.5 else 0.6) * true_rate


def test_config_validation():
    with pytest.raises(ValueError, match="bin_s"):
        TempRateConfig(bin_s=0.0)
    with pytest.raises(ValueError, match="window_s"):
        TempRateConfig(window_s=1.0, bin_s=1.0)
    # a short window that does not fit is off, not an error (a user who shortens window_s alone)
    assert TempRateConfig(window_s=10.0).short_bins == 0
    assert TempRateConfig(short_s=1.0).short_bins == 0
    assert TempRateConfig(bin_s=10.0, window_s=600.0).short_bins == 0
    assert TempRateConfig().short_bins == 10
    with pytest.raises(ValueError, match="short_s"):
        TempRateConfig(short_s=-1.0)


def test_drift_and_regressors():
    H = regressors([40.0, 20.0], [0.01, -0.02])
    np.testing.assert_array_equal(H, [[40.0, 0.01, 1.0], [20.0, -0.02, 1.0]])
    x = (0.01, 2.0, -0.3)
    np.testing.assert_allclose(drift(x, [40.0, 20.0], [0.01, -0.02]), H @ np.array(x))
