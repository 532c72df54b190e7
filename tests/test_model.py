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
    cfg = TempRateConfig(window_s=30.0, bin_s=0.5)
    got = temp_rate(t, temp, cfg)
    k = np.floor((t - t[0]) / cfg.bin_s)
    expected = np.zeros(t.size)
    for i in range(t.size):
        closed = np.unique(k[k < k[i]])
        closed = closed[closed >= k[i] - 1 - cfg.window_bins]  # the newest closed bin and window_bins before it
        if closed.size >= 2:
            bt = np.array([t[k == b].mean() for b in closed])
            bT = np.array([temp[k == b].mean() for b in closed])
            expected[i] = np.polyfit(bt, bT, 1)[0]
    np.testing.assert_allclose(got, expected, rtol=1e-7, atol=1e-12)


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


def test_drift_and_regressors():
    H = regressors([40.0, 20.0], [0.01, -0.02])
    np.testing.assert_array_equal(H, [[40.0, 0.01, 1.0], [20.0, -0.02, 1.0]])
    x = (0.01, 2.0, -0.3)
    np.testing.assert_allclose(drift(x, [40.0, 20.0], [0.01, -0.02]), H @ np.array(x))
