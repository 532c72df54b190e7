"""Fixed-interval (RTS) smoothing of the drift: known answers and properties."""

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.errors import ConfigError
from gyrodrift.estimators import AdaptiveConfig, KalmanConfig, fit_linear_drift
from gyrodrift.metrics import bias_error
from gyrodrift.simulate import simulate
from gyrodrift.smooth import smooth_drift, smooth_output


def _measurements(rng, n, *, same_time_first=3, interval=10.0, truth=(0.02, 3.0, -0.4)):
    """Drift measurements of the linear model at increasing times, some intervals skipped."""
    steps = rng.choice([1, 1, 1, 2, 5], size=n - same_time_first)
    t = np.r_[np.full(same_time_first, 30.0), 30.0 + interval * np.cumsum(steps)]
    temp = 20.0 + 0.05 * (t - 30.0) + rng.normal(0, 0.1, t.size)
    temp_rate = rng.normal(0.0, 0.01, t.size)
    r = rng.uniform(1e-5, 1e-4, t.size)
    m = truth[0] * temp + truth[1] * temp_rate + truth[2] + rng.normal(0, np.sqrt(r))
    return pd.DataFrame({"t": t, "m": m, "temp": temp, "temp_rate": temp_rate, "r": r})


def _whole_system(meas, cfg, epochs=None):
    """The same model solved at once: weighted least squares over every state z_0..z_{K-1}
    (prior, random-walk transitions with the moving T_ref, measurements); ``epochs`` adds
    states at (t, temp) without measurements."""
    st = cfg.adaptive
    Q = np.diag(np.square(st.q_sd))
    groups = [(t, g["temp"].mean(), g) for t, g in meas.groupby("t", sort=True)]
    if epochs is not None:
        groups += [(t, T, meas.iloc[:0]) for t, T in zip(*epochs) if t not in set(meas["t"])]
        groups.sort(key=lambda g: g[0])
    K = len(groups)
    tref = np.array([g[1] for g in groups])
    rows, rhs, w = [], [], []

    def put(block_coeffs, value, var):
        row = np.zeros(3 * K)
        for k, coeffs in block_coeffs:
            row[3 * k:3 * k + 3] += coeffs
        rows.append(row), rhs.append(value), w.append(1.0 / var)

    x0 = np.array(cfg.kalman.x0, dtype=float)
    z0 = np.array([x0[0], x0[1], x0[2] + x0[0] * tref[0]])
    P0 = np.diag(np.square(cfg.kalman.p0_sd))
    for j in range(3):  # prior on z_0 (diagonal)
        put([(0, np.eye(3)[j])], z0[j], P0[j, j])
    for k in range(1, K):
        J = np.eye(3)
        J[2, 0] = tref[k] - tref[k - 1]
        n = (groups[k][0] - groups[k - 1][0]) / cfg.update_interval_s
        Qk = n * Q
        Qk[0, 0] += st.slope_q_per_rtc**2 * abs(tref[k] - tref[k - 1])
        for j in range(3):  # z_k - J z_{k-1} = w_k, Q diagonal
            put([(k, np.eye(3)[j]), (k - 1, -J[j])], 0.0, Qk[j, j])
    for k, (_, _, g) in enumerate(groups):
        for _, e in g.iterrows():
            put([(k, np.array([e["temp"] - tref[k], e["temp_rate"], 1.0]))], e["m"], e["r"])
    A = np.array(rows)
    W = np.array(w)
    z = np.linalg.solve(A.T @ (A * W[:, None]), A.T @ (W * np.array(rhs))).reshape(K, 3)
    return np.column_stack([z[:, 0], z[:, 1], z[:, 2] - z[:, 0] * tref])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rts_equals_the_whole_linear_system_solved_at_once(seed):
    rng = np.random.default_rng(seed)
    meas = _measurements(rng, 14)
    cfg = CompensatorConfig(adaptive=AdaptiveConfig(q_sd=(2e-4, 0.05, 3e-3), slope_q_per_rtc=0.05))
    sm = smooth_drift(meas, cfg)
    expected = _whole_system(meas, cfg)
    assert sm.t.tolist() == sorted(set(meas["t"]))
    np.testing.assert_allclose(sm.params, expected, rtol=1e-7, atol=1e-9)
    # the last smoothed state is the forward filter's
    np.testing.assert_allclose(sm.params[-1], sm.filtered[-1], rtol=1e-12, atol=1e-12)


def test_epochs_without_measurements_follow_the_temperature_through_an_outage():
    rng = np.random.default_rng(7)
    meas = _measurements(rng, 12)
    meas.loc[6:, "t"] += 600.0  # a 10-minute outage
    epochs = (meas["t"].iloc[5] + 10.0 * np.arange(1, 61), 20.0 + 0.5 * np.arange(1, 61) / 6.0)
    cfg = CompensatorConfig(adaptive=AdaptiveConfig(q_sd=(2e-4, 0.05, 3e-3), slope_q_per_rtc=0.05))
    sm = smooth_drift(meas, cfg, epochs=epochs)
    assert sm.t.size == len(set(meas["t"])) + 60
    np.testing.assert_allclose(sm.params, _whole_system(meas, cfg, epochs), rtol=1e-7, atol=1e-9)


def test_without_process_noise_every_state_is_the_full_least_squares_fit():
    rng = np.random.default_rng(5)
    meas = _measurements(rng, 20)
    cfg = CompensatorConfig(adaptive=AdaptiveConfig(q_sd=(0.0, 0.0, 0.0), slope_q_per_rtc=0.0))
    sm = smooth_drift(meas, cfg)
    # weighted least squares with the smoother's prior: diag(p0_sd²) on [a, b, c'] at the
    # first measurement's temperature
    tref = meas["temp"][meas["t"] == meas["t"].min()].mean()
    H = np.column_stack([meas["temp"] - tref, meas["temp_rate"], np.ones(len(meas))])
    a0, b0, c0 = cfg.kalman.x0
    z0 = np.array([a0, b0, c0 + a0 * tref])
    info = np.diag(1.0 / np.square(cfg.kalman.p0_sd))
    w = 1.0 / meas["r"].to_numpy()
    z = np.linalg.solve(H.T @ (H * w[:, None]) + info, H.T @ (w * meas["m"].to_numpy()) + info @ z0)
    full = np.array([z[0], z[1], z[2] - z[0] * tref])
    # and, as the prior is weak, close to the paper's MLR fit (b, weakly excited by T', moves most)
    plain = fit_linear_drift(meas["m"], np.column_stack([meas["temp"], meas["temp_rate"], np.ones(len(meas))]),
                             meas["r"])
    np.testing.assert_allclose(full, plain, rtol=1e-2)
    for k in range(sm.t.size):
        np.testing.assert_allclose(sm.params[k], full, rtol=1e-6, atol=1e-9)


def test_noiseless_measurements_recover_a_b_c():
    rng = np.random.default_rng(3)
    truth = (0.031, -2.0, 0.25)
    meas = _measurements(rng, 40, truth=truth)
    meas["r"] = 1e-14
    meas["m"] = truth[0] * meas["temp"] + truth[1] * meas["temp_rate"] + truth[2]
    sm = smooth_drift(meas, CompensatorConfig())
    np.testing.assert_allclose(sm.params, np.tile(truth, (sm.t.size, 1)), atol=1e-6)


def test_smoothing_beats_the_causal_filter_on_a_warming_log():
    log = simulate("static", seed=4, duration_s=3600.0, fs_hz=10.0)
    cfg = CompensatorConfig(estimator="adaptive")
    out = compensate(log, cfg)
    sm = smooth_output(out, cfg)
    rms = lambda o: float(np.sqrt(np.nanmean(bias_error(o) ** 2)))  # noqa: E731
    assert rms(sm) < 0.8 * rms(out)
    # the reconstructed temperature is the one the compensator used
    np.testing.assert_allclose(out["a"] * sm["temp"].ffill().bfill() + out["b"] * out["temp_rate"] + out["c"],
                               out["bias_z"], rtol=1e-9, atol=1e-12)
    # the heading moved by the integral of the bias change, nothing else
    t = out["t"].to_numpy()
    d = out["bias_z"].to_numpy() - sm["bias_z"].to_numpy()
    integral = np.r_[0.0, np.cumsum(0.5 * (d[1:] + d[:-1]) * np.diff(t))]
    diff = (sm["heading"] - out["heading"] - integral + 180.0) % 360.0 - 180.0
    assert np.nanmax(np.abs(diff)) < 1e-9
    np.testing.assert_allclose(sm["rate_z"] + sm["bias_z"], out["rate_z"] + out["bias_z"], atol=1e-12)
    # seeing both sides of each row, the smoother is more certain than the causal filter
    assert float(np.nanmean(sm["bias_sd"])) < 0.8 * float(np.nanmean(out["bias_sd"]))
    assert (sm["gate_reason"] == out["gate_reason"]).all()
    assert isinstance(sm.attrs["smoothed"].params, np.ndarray)


def test_smoothed_rows_use_the_measurement_of_their_own_interval():
    log = simulate("static", seed=1, duration_s=600.0, fs_hz=10.0)
    cfg = CompensatorConfig(estimator="adaptive")
    sm = smooth_output(compensate(log, cfg), cfg)
    s = sm.attrs["smoothed"]
    t = sm["t"].to_numpy()
    for k in (1, 5, 10):
        rows = (t > s.t[k - 1]) & (t <= s.t[k])
        assert rows.any()
        assert np.all(sm.loc[rows, "a"].to_numpy() == s.params[k, 0])
        assert np.all(sm.loc[rows, "c"].to_numpy() == s.params[k, 2])


def test_clear_errors():
    with pytest.raises(ConfigError, match="at least one accepted"):
        smooth_drift(pd.DataFrame({c: [] for c in ("t", "m", "temp", "temp_rate", "r")}))
    bad = _measurements(np.random.default_rng(0), 6)
    bad.loc[2, "m"] = np.nan
    with pytest.raises(ConfigError, match="finite"):
        smooth_drift(bad)
    out = pd.DataFrame({"t": [0.0]})
    with pytest.raises(ConfigError, match="measurements"):
        smooth_output(out)


def test_shared_kalman_noise_when_adaptive_process_noise_is_off():
    meas = _measurements(np.random.default_rng(9), 10)
    cfg = CompensatorConfig(adaptive=replace(AdaptiveConfig(), q_sd=None),
                            kalman=KalmanConfig(q_sd=(2e-4, 0.05, 3e-3)))
    same = CompensatorConfig(adaptive=AdaptiveConfig(q_sd=(2e-4, 0.05, 3e-3), slope_q_per_rtc=0.0))
    np.testing.assert_allclose(smooth_drift(meas, cfg).params, smooth_drift(meas, same).params, rtol=1e-12)


def test_smoothed_is_a_non_causal_compare_method():
    from gyrodrift.compare import CAUSAL, run_method

    log = simulate("static", seed=2, duration_s=900.0, fs_hz=10.0)
    cfg = CompensatorConfig(estimator="adaptive")
    out = run_method("smoothed", log, cfg)
    assert CAUSAL["smoothed"] is False
    assert "smoothed" in out.attrs
    assert np.all(np.isfinite(out["bias_z"])) and np.all(np.isfinite(out["heading"]))


def test_cli_smooth_writes_the_smoothed_table(tmp_path):
    from gyrodrift.cli import main
    from gyrodrift.io import read_log

    log = simulate("static", seed=3, duration_s=900.0, fs_hz=10.0)
    src = tmp_path / "in.csv"
    log.to_csv(src, index=False)
    assert main(["compensate", str(src), "-o", str(tmp_path / "s.csv"), "--smooth", "-q"]) == 0
    assert main(["compensate", str(src), "-o", str(tmp_path / "f.csv"), "-q"]) == 0
    smoothed, causal = pd.read_csv(tmp_path / "s.csv"), pd.read_csv(tmp_path / "f.csv")
    expected = smooth_output(compensate(read_log(src)), CompensatorConfig())
    np.testing.assert_allclose(smoothed["bias_z"], expected["bias_z"], rtol=1e-12, atol=1e-15)
    assert (smoothed["gate_reason"].fillna("") == causal["gate_reason"].fillna("")).all()
    assert not np.allclose(smoothed["bias_z"], causal["bias_z"])
