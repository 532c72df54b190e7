"""Fixed-interval (RTS) smoothing of the model's drift states: known answers and properties."""

import numpy as np
import pandas as pd
import pytest

from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.errors import ConfigError
from gyrodrift.estimators import AdaptiveConfig
from gyrodrift.kernels.evloop import H_DT, H_DTEMP, H_JUMP, H_P, H_T, H_X, N_DRIFT, N_HIST
from gyrodrift.evaluate.metrics import bias_error
from gyrodrift.simulate import simulate
from gyrodrift.smooth import _transition, smooth_epochs, smooth_output

TRIU = [(r, c) for r in range(N_DRIFT) for c in range(r, N_DRIFT)]
N = N_DRIFT


def _forward(rng, K, st, *, jump_at=None, jump=0.0, truth=(0.02, 3.0, -0.4, 0.0, 1e-3)):
    """A Kalman filter of the drift states [a, b, c', r, a2] on direct bias measurements, its
    history in the engine's layout, and what it was built from (for the whole-system check)."""
    dts = rng.uniform(0.5, 3.0, K)
    dtemps = rng.uniform(0.0, 0.2, K)
    hT = rng.normal(0, 5, K)
    H = np.column_stack([hT, rng.normal(0, 0.05, K), np.ones(K), np.zeros(K), hT**2])
    R = rng.uniform(1e-4, 1e-3, K)
    z_true = np.array(truth, dtype=float)
    x, P = np.zeros(N), np.diag([0.05, 5.0, 1.0, 1e-6, 1e-3]) ** 2
    prior = (x.copy(), P.copy())
    hist = np.zeros((K, N_HIST))
    y = np.zeros(K)
    jumps = np.zeros(K)
    t = 0.0
    for k in range(K):
        if k > 0:
            jumps[k] = 1.0 if k == jump_at else 0.0
            F, Q = _transition(dts[k], dtemps[k], jumps[k], st)
            x, P = F @ x, F @ P @ F.T + Q
            z_true = F @ z_true
            if k == jump_at:
                z_true[2] += jump
        t += dts[k]
        y[k] = H[k] @ z_true + rng.normal(0, np.sqrt(R[k]))
        S = H[k] @ P @ H[k] + R[k]
        Kg = P @ H[k] / S
        x = x + Kg * (y[k] - H[k] @ x)
        P = P - np.outer(Kg, H[k] @ P)
        hist[k, H_T], hist[k, H_DT], hist[k, H_DTEMP], hist[k, H_JUMP] = t, dts[k], dtemps[k], jumps[k]
        hist[k, H_X:H_X + N] = x
        hist[k, H_P:H_P + len(TRIU)] = [P[r, c] for r, c in TRIU]
    return hist, dict(H=H, R=R, y=y, prior=prior)


def _whole_system(hist, data, st):
    """The same linear-Gaussian model solved at once: weighted least squares over every state
    (the curvature a2, which has no process noise, one unknown for all epochs)."""
    K = hist.shape[0]
    M = N - 1  # the states that move: a, b, c', r
    rows, rhs, w = [], [], []

    def col(k, j):
        return M * K if j == M else M * k + j

    def put(coeffs, value, var):
        rows.append(coeffs), rhs.append(value), w.append(1.0 / var)

    x0, P0 = data["prior"]
    Q0 = np.linalg.cholesky(np.linalg.inv(P0))  # whitening of the prior (full matrix)
    for j in range(N):
        row = np.zeros(M * K + 1)
        for i in range(N):
            row[col(0, i)] = Q0.T[j][i]
        put(row, Q0.T[j] @ x0, 1.0)
    for k in range(1, K):
        F, Q = _transition(hist[k, H_DT], hist[k, H_DTEMP], hist[k, H_JUMP], st)
        assert Q[M, M] == 0.0 and np.all(F[:M, M] == 0.0)
        for j in range(M):
            row = np.zeros(M * K + 1)
            row[col(k, j)] = 1.0
            for i in range(M):
                row[col(k - 1, i)] -= F[j, i]
            put(row, 0.0, Q[j, j])
    for k in range(K):
        row = np.zeros(M * K + 1)
        for i in range(N):
            row[col(k, i)] += data["H"][k][i]
        put(row, data["y"][k], data["R"][k])
    A, W = np.array(rows), np.array(w)
    v = np.linalg.solve(A.T @ (A * W[:, None]), A.T @ (W * np.array(rhs)))
    return np.column_stack([v[:M * K].reshape(K, M), np.full(K, v[M * K])])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rts_equals_the_whole_linear_system_solved_at_once(seed):
    st = AdaptiveConfig(drift_rate_dps2=1e-3, drift_rate_s=50.0)
    hist, data = _forward(np.random.default_rng(seed), 40, st, jump_at=20, jump=0.5)
    sm = smooth_epochs(hist, CompensatorConfig(adaptive=st))
    np.testing.assert_allclose(sm.states, _whole_system(hist, data, st), rtol=1e-6, atol=1e-8)
    np.testing.assert_array_equal(sm.filtered, hist[:, H_X:H_X + N])
    assert np.allclose(sm.states[-1], sm.filtered[-1])  # the last epoch: nothing after it


def test_a_jump_is_not_carried_back_across_its_epoch():
    """A step of c' the forward pass kept: the epochs before it keep their own level."""
    st = AdaptiveConfig(drift_jump_dps=0.3)  # the jump variant on
    rng = np.random.default_rng(5)
    hist, _ = _forward(rng, 60, st, jump_at=30, jump=1.0, truth=(0.0, 0.0, 0.2, 0.0, 0.0))
    sm = smooth_epochs(hist, CompensatorConfig(adaptive=st))
    assert np.all(np.abs(sm.states[5:29, 2] - 0.2) < 0.05)
    assert np.all(np.abs(sm.states[31:, 2] - 1.2) < 0.05)
    hist[:, H_JUMP] = 0.0  # without it, the step is smeared over the epochs before
    smeared = smooth_epochs(hist, CompensatorConfig(adaptive=st))
    assert np.abs(smeared.states[25, 2] - 0.2) > 0.1


def test_the_smoothed_covariance_is_no_larger_than_the_filtered():
    st = AdaptiveConfig()
    hist, _ = _forward(np.random.default_rng(3), 30, st)
    sm = smooth_epochs(hist, CompensatorConfig(adaptive=st))
    for k in range(hist.shape[0]):
        P_f = np.zeros((N, N))
        for m, (r, c) in enumerate(TRIU):
            P_f[r, c] = P_f[c, r] = hist[k, H_P + m]
        assert np.all(np.linalg.eigvalsh(P_f - sm.cov[k]) > -1e-12)  # smoothed ≤ filtered


def test_smoothing_beats_the_causal_model_on_a_warming_log():
    log = simulate("static", seed=4, duration_s=3600.0, fs_hz=10.0)
    cfg = CompensatorConfig()
    out = compensate(log, cfg)
    sm = smooth_output(out, cfg)
    rms = lambda o: float(np.sqrt(np.nanmean(bias_error(o) ** 2)))  # noqa: E731
    assert rms(sm) < 0.8 * rms(out)
    # the heading moved by the integral of the bias change, nothing else
    t = out["t"].to_numpy()
    d = out["bias_z"].to_numpy() - sm["bias_z"].to_numpy()
    hold = (out["gate_reason"].astype(str) == "gap").to_numpy()
    inc = np.where(hold[1:], 0.0, 0.5 * (d[1:] + d[:-1]) * np.diff(t))
    integral = np.r_[0.0, np.cumsum(inc)]
    diff = (sm["heading"] - out["heading"] - integral + 180.0) % 360.0 - 180.0
    assert np.nanmax(np.abs(diff)) < 1e-9
    np.testing.assert_allclose(sm["rate_z"] + sm["bias_z"], out["rate_z"] + out["bias_z"], atol=1e-12)
    # seeing both sides of each row, the smoother is more certain than the causal model
    assert float(np.nanmean(sm["bias_sd"])) < float(np.nanmean(out["bias_sd"]))
    assert (sm["gate_reason"] == out["gate_reason"]).all()
    pd.testing.assert_series_equal(sm["heading_fused"], out["heading_fused"])


def test_smoothed_rows_use_the_states_of_their_own_epoch():
    log = simulate("static", seed=1, duration_s=600.0, fs_hz=10.0)
    cfg = CompensatorConfig()
    sm = smooth_output(compensate(log, cfg), cfg)
    s = sm.attrs["smoothed"]
    t = sm["t"].to_numpy()
    for k in (1, 50, 200):
        rows = (t > s.t[k - 1]) & (t <= s.t[k])
        assert rows.any()
        hT = sm.loc[rows, "temp"].to_numpy() - sm.attrs["temp_ref_c"]
        np.testing.assert_allclose(sm.loc[rows, "a"].to_numpy(), s.states[k, 0] + 2.0 * s.states[k, 4] * hT, rtol=1e-12)
        assert np.all(sm.loc[rows, "b"].to_numpy() == s.states[k, 1])


def test_clear_errors():
    with pytest.raises(ConfigError, match="epoch history"):
        smooth_epochs(np.zeros((3, N_HIST - 1)))
    bad = np.zeros((3, N_HIST))
    bad[1, H_X] = np.nan
    with pytest.raises(ConfigError, match="finite"):
        smooth_epochs(bad)
    with pytest.raises(ConfigError, match="default estimator"):
        smooth_output(pd.DataFrame({"t": [0.0]}))
    log = simulate("static", seed=1, duration_s=300.0, fs_hz=10.0)
    stkf = CompensatorConfig(estimator="stkf")
    with pytest.raises(ConfigError, match="default estimator"):
        smooth_output(compensate(log, stkf), stkf)


def test_smoothed_is_a_non_causal_compare_method():
    from gyrodrift.evaluate.compare import CAUSAL, run_method

    log = simulate("static", seed=2, duration_s=900.0, fs_hz=10.0)
    out = run_method("smoothed", log, CompensatorConfig())
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
    np.testing.assert_allclose(smoothed["bias_z"], expected["bias_z"], rtol=1e-9, atol=1e-12)
    assert (smoothed["gate_reason"].fillna("") == causal["gate_reason"].fillna("")).all()
    assert not np.allclose(smoothed["bias_z"], causal["bias_z"])
