import numpy as np
import pytest

from gyrodrift.model import TempRateConfig, TempRateTracker, drift, regressors, temp_rate


def test_ramp_slope_is_exact_once_window_is_full():
    t = np.arange(0.0, 200.0, 0.05)
    rate = temp_rate(t, 20.0 + 0.013 * t)
    full = t > 62.0  # window (60 s) + one bin (1 s) + the bin being filled
    np.testing.assert_allclose(rate[full], 0.013, rtol=1e-9)
    assert np.all(rate[t < 1.0] == 0.0)  # no closed bin yet


def test_streaming_tracker_equals_batch_bit_for_bit():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.05, 20000))  # irregular sampling
    temp = np.round((30 + 5 * np.sin(t / 100) + rng.normal(0, 0.02, t.size)) / 0.0625) * 0.0625
    cfg = TempRateConfig(window_s=30.0, bin_s=0.5)
    tracker = TempRateTracker(cfg)
    streamed = np.array([tracker.push(ti, Ti) for ti, Ti in zip(t, temp)])
    assert np.array_equal(streamed, temp_rate(t, temp, cfg))


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
