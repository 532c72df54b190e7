"""The x and y axes (gyrodrift.triad): gravity-aided drift compensation of gyro_x and gyro_y."""

import math

import numpy as np
import pandas as pd
import pytest

from gyrodrift.compensator import CompensatorConfig, compensate
from gyrodrift.estimators import KalmanDrift
from gyrodrift.model import temp_rate
from gyrodrift.simulate import TriadModel, simulate
from gyrodrift.kernels import tilt
from gyrodrift.triad import TRIAD_COLUMNS, TriadCompensator, TriadConfig

PX = (0.01, 3.0, -0.2)  # a (deg/s/degC), b (deg), c (deg/s) of x
PY = (-0.02, -2.0, 0.5)


def level_acc(n, roll_deg=0.0, pitch_deg=0.0):
    """FRD specific force (g) of a still unit at a roll and pitch (scalars or (n,) arrays)."""
    phi = np.radians(np.broadcast_to(roll_deg, (n,)))
    th = np.radians(np.broadcast_to(pitch_deg, (n,)))
    return np.column_stack([np.sin(th), -np.sin(phi) * np.cos(th), -np.cos(phi) * np.cos(th)])


def static_run(duration_s=3000.0, fs_hz=20.0, roll_deg=3.0, pitch_deg=-5.0):
    """Noiseless still unit with a curved temperature profile; drift exactly a*T + b*T' + c."""
    t = np.arange(0.0, duration_s, 1.0 / fs_hz)
    T = 25.0 + 15.0 * np.sin(np.pi * t / 2000.0) ** 2 + 3.0 * np.sin(2 * np.pi * t / 700.0)
    Tp = temp_rate(t, T)
    gx = PX[0] * T + PX[1] * Tp + PX[2]
    gy = PY[0] * T + PY[1] * Tp + PY[2]
    return t, gx, gy, T, Tp, level_acc(t.size, roll_deg, pitch_deg)


def compensate_triad(t_s, gx, gy, temp_c, temp_rate_cps, acc, rate_z_dps=None, config=None, triad=None, *,
                     estimators=None):
    """Whole x/y columns at once: the output columns, the final parameters and the refusals."""
    tc = TriadCompensator(config or CompensatorConfig(), triad, estimators=estimators)
    out = pd.DataFrame(tc.feed(t_s, gx, gy, temp_c, temp_rate_cps, acc, rate_z_dps))
    out.attrs["params_x"], out.attrs["params_y"] = tc.params
    out.attrs["triad_reasons"] = dict(tc.reasons)
    return out


class Recorder(KalmanDrift):
    """The STKF, recording every observation and hold."""

    def __init__(self):
        super().__init__()
        self.log = []

    def update(self, obs):
        out = super().update(obs)
        self.log.append(("update", obs, out))
        return out

    def hold(self):
        out = super().hold()
        self.log.append(("hold", None, out))
        return out


def test_exact_recovery_of_a_b_c_from_noiseless_static_data():
    t, gx, gy, T, Tp, acc = static_run()
    out = compensate_triad(t, gx, gy, T, Tp, acc)
    np.testing.assert_allclose(out.attrs["params_x"], PX, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(out.attrs["params_y"], PY, rtol=1e-6, atol=1e-9)
    late = t > 1500
    assert np.max(np.abs(out["bias_x"][late] - gx[late])) < 1e-8
    assert np.max(np.abs(out["rate_y"][late])) < 1e-8
    assert out.attrs["triad_reasons"] == dict.fromkeys(("gap", "accel", "tilt", "turning", "residual"), 0)


def test_tilt_angles_follow_frd_signs():
    roll, pitch = zip(*(tilt.roll_pitch(*f) for f in level_acc(2, [10.0, 0.0], [0.0, 20.0])))
    np.testing.assert_allclose(roll, [10.0, 0.0], atol=1e-12)  # right side down: positive roll
    np.testing.assert_allclose(pitch, [0.0, 20.0], atol=1e-12)  # nose up: positive pitch


def test_an_unseen_roll_measures_the_drift_with_the_right_sign():
    """Hand computed: between the edges at 10 s and 20 s the unit rolls right side down by 3 deg
    (the accelerometer sees it) while gyro_x reads 0: the gyro is 3 deg / 10 s = 0.3 deg/s low,
    so the drift measurement is m = (∫gyro - Δroll)/Δt = (0 - 3)/10 = -0.3 deg/s. gyro_y reads a
    steady 0.05 deg/s and the pitch does not change: m_y = +0.05."""
    fs = 50.0
    t = np.arange(0.0, 25.0, 1.0 / fs)
    roll = np.clip((t - 12.0) * 0.5, 0.0, 3.0)  # 12..18 s at 0.5 deg/s
    ex, ey = Recorder(), Recorder()
    tc = TriadCompensator(CompensatorConfig(), triad=TriadConfig(), estimators=(ex, ey))
    tc.feed(t, np.zeros(t.size), np.full(t.size, 0.05), np.full(t.size, 25.0), np.zeros(t.size), level_acc(t.size, roll))
    # boundary 10 s: no start edge (held); boundary 20 s: the measurement
    assert [kind for kind, _, _ in ex.log] == ["hold", "update"]
    obs_x, obs_y = ex.log[1][1], ey.log[1][1]
    assert obs_x.y[0] == pytest.approx(-0.3, abs=1e-9)
    assert obs_y.y[0] == pytest.approx(0.05, abs=1e-12)  # cos(roll) is divided out exactly
    np.testing.assert_allclose(obs_x.H[0], [25.0, 0.0, 1.0])
    assert obs_x.t == pytest.approx(20.0)


def test_refused_intervals_hold_the_parameters():
    t, gx, gy, T, Tp, acc = static_run(duration_s=600.0)
    acc = acc.copy()
    braking = (t >= 299.5) & (t < 301.5)  # a step of 0.1 g at the 300-s edge: accel
    acc[braking, 0] += 0.1
    ex, ey = Recorder(), Recorder()
    tc = TriadCompensator(CompensatorConfig(), estimators=(ex, ey))
    out = tc.feed(t, gx, gy, T, Tp, acc)
    kinds = [kind for kind, _, _ in ex.log]
    assert kinds[29] == "hold" and kinds[30] == "hold"  # the intervals ending at 300 s and 310 s
    assert kinds.count("hold") == 3 and tc.reasons["accel"] == 2
    held = ex.log[28][2]  # after the update at 290 s
    np.testing.assert_array_equal(ex.log[29][2], held)
    np.testing.assert_array_equal(ex.log[30][2], held)
    i300, i310 = np.searchsorted(t, [300.0, 310.0])
    assert out["tilt_gated"][i300] == 1 and out["tilt_gated"][i300 - 1] == 0
    rows = slice(i300 + 1, i310 + 1)  # compensated with the held parameters
    np.testing.assert_allclose(out["bias_x"][rows], held[0] * T[rows] + held[1] * Tp[rows] + held[2], rtol=1e-12)


def test_tilt_beyond_the_limit_refuses_every_interval():
    t, gx, gy, T, Tp, acc = static_run(duration_s=300.0, roll_deg=35.0, pitch_deg=0.0)
    out = compensate_triad(t, gx, gy, T, Tp, acc)
    assert out.attrs["triad_reasons"]["tilt"] == 28  # 30 boundaries; the first has no start edge
    assert np.all(out["bias_x"] == 0.0) and np.all(out["tilt_gated"] == 1)
    np.testing.assert_array_equal(out["rate_x"], gx)
    np.testing.assert_array_equal(out.attrs["params_x"], [0.0, 0.0, 0.0])


def test_turning_is_refused():
    t, gx, gy, T, Tp, _ = static_run(duration_s=300.0)
    rate = np.where((t > 103) & (t < 111), 2.5, 0.0)  # a 20-deg roll at 2.5 deg/s, seen by both sensors
    roll = np.cumsum(rate) / 20.0
    out = compensate_triad(t, gx + rate, gy, T, Tp, level_acc(t.size, roll))
    assert out.attrs["triad_reasons"] == {"gap": 0, "accel": 0, "tilt": 0, "turning": 2, "residual": 0}


def test_a_sustained_acceleration_is_refused_by_the_residual_gate():
    t, gx, gy, T, Tp, acc = static_run(duration_s=1200.0, roll_deg=0.0, pitch_deg=0.0)
    acc = acc.copy()
    acc[(t >= 805.0) & (t < 825.0), 0] += 0.05  # forward acceleration over the 810-s and 820-s edges
    out = compensate_triad(t, gx, gy, T, Tp, acc)
    assert out.attrs["triad_reasons"]["residual"] >= 1
    late = t > 830
    truth = PX[0] * T + PX[1] * Tp + PX[2]
    assert np.max(np.abs(out["bias_x"][late] - truth[late])) < 5e-3


def test_chunked_equals_whole_bit_for_bit():
    log = simulate("vehicle", seed=4, duration_s=400.0, fs_hz=20.0, triad=TriadModel())
    log.loc[1000, "gyro_x"] = np.nan
    log.loc[1500:1510, "acc_y"] = np.nan
    log.loc[2000, "temp"] = np.nan
    args = (log["t"].to_numpy(), log["gyro_x"].to_numpy(), log["gyro_y"].to_numpy(), log["temp"].to_numpy(),
            temp_rate(log["t"].to_numpy(), log["temp"].ffill().to_numpy()), log[["acc_x", "acc_y", "acc_z"]].to_numpy(),
            np.full(len(log), 0.01))
    whole = TriadCompensator(CompensatorConfig()).feed(*args)
    rng = np.random.default_rng(0)
    cuts = np.r_[0, np.sort(rng.choice(np.arange(1, len(log)), 40, replace=False)), np.arange(3000, 3040), len(log)]
    cuts = np.unique(cuts)
    tc = TriadCompensator(CompensatorConfig())
    parts = [tc.feed(*(a[i:j] for a in args)) for i, j in zip(cuts[:-1], cuts[1:])]
    for c in TRIAD_COLUMNS:
        joined = np.concatenate([p[c] for p in parts])
        assert joined.dtype == whole[c].dtype
        np.testing.assert_array_equal(joined, whole[c])
    assert np.isfinite(whole["bias_x"]).all() and np.isfinite(whole["rate_x"]).all()


def test_simulated_static_heating_run():
    log = simulate("static", seed=1, fs_hz=10.0, triad=TriadModel())
    out = compensate(log)
    late = out["t"].to_numpy() > 600.0
    for axis in "xy":
        truth = log[f"true_bias_{axis}"].to_numpy()[late]
        raw = math.sqrt(np.mean(truth**2))
        err = math.sqrt(np.mean((out[f"bias_{axis}"].to_numpy()[late] - truth) ** 2))
        assert err < raw / 20, (axis, raw, err)
        assert err < 0.015


def test_columns_appear_only_with_the_inputs():
    log = simulate("static", seed=2, duration_s=300.0, fs_hz=10.0, triad=TriadModel())
    out = compensate(log)
    cols = list(out.columns)
    i = cols.index("heading_sd")
    assert cols[i + 1 : i + 6] == list(TRIAD_COLUMNS)
    assert cols.index("gyro_z") > i + 5  # the pass-through inputs come after
    assert out["tilt_gated"].dtype == np.int8
    for drop in ("gyro_x", "acc_z"):
        assert "rate_x" not in compensate(log.drop(columns=drop)).columns
    plain = simulate("static", seed=2, duration_s=300.0, fs_hz=10.0)
    assert not set(TRIAD_COLUMNS) & set(compensate(plain).columns)


def test_acc_all_zero_gives_the_prior_and_no_crash():
    t, gx, gy, T, Tp, acc = static_run(duration_s=200.0)
    out = compensate_triad(t, gx, gy, T, Tp, np.zeros_like(acc))
    assert np.all(out["bias_x"] == 0.0) and np.all(out["bias_y"] == 0.0)
    np.testing.assert_array_equal(out["rate_x"], gx)
    assert np.all(out["tilt_gated"] == 1)
    assert out.attrs["triad_reasons"]["accel"] == 18


def test_nan_cells_hold_and_refuse_without_nan_bursts():
    t, gx, gy, T, Tp, acc = static_run(duration_s=600.0)
    gx, gy, T, acc = gx.copy(), gy.copy(), T.copy(), acc.copy()
    gx[:5] = np.nan  # before the first value: rate_x empty there only
    gx[3000] = np.nan
    gy[4000] = np.nan
    T[5000] = np.nan
    acc[6000:6010] = np.nan
    out = compensate_triad(t, gx, gy, T, Tp, acc)
    assert np.isnan(out["rate_x"][:5]).all()
    assert np.isfinite(out["rate_x"][5:]).all() and np.isfinite(out[["rate_y", "bias_x", "bias_y"]]).all().all()
    assert out.attrs["triad_reasons"]["gap"] == 3  # the three intervals with a held cell (the first is not counted)
    np.testing.assert_allclose(out.attrs["params_x"], PX, rtol=1e-3, atol=1e-6)


def test_acc_in_mps2_is_recognised():
    t, gx, gy, T, Tp, acc = static_run(duration_s=1000.0)
    g = compensate_triad(t, gx, gy, T, Tp, acc)
    si = compensate_triad(t, gx, gy, T, Tp, acc * 9.80665)
    np.testing.assert_allclose(si.attrs["params_x"], g.attrs["params_x"], rtol=1e-9, atol=1e-12)
    assert si.attrs["triad_reasons"] == g.attrs["triad_reasons"]


def test_bad_settings_are_config_errors():
    from gyrodrift.errors import ConfigError

    with pytest.raises(ConfigError, match="max_tilt_deg"):
        TriadConfig(max_tilt_deg=90.0)
    with pytest.raises(ConfigError, match="edge_s"):
        TriadCompensator(CompensatorConfig(update_interval_s=1.0), TriadConfig(edge_s=1.0))


def test_default_simulation_is_unchanged_by_the_triad_option():
    a = simulate("vehicle", seed=3, duration_s=120.0)
    b = simulate("vehicle", seed=3, duration_s=120.0, triad=TriadModel())
    pd.testing.assert_frame_equal(a, b[a.columns])
    assert list(b.columns[len(a.columns):]) == ["gyro_x", "gyro_y", "true_bias_x", "true_bias_y", "acc_x", "acc_y", "acc_z"]


def test_streamed_file_equals_in_memory_file_with_x_and_y(tmp_path):
    from gyrodrift.io import write_table
    from gyrodrift.pipeline import compensate_file

    log = simulate("vehicle", seed=5, duration_s=600.0, fs_hz=20.0, triad=TriadModel())
    log.attrs = {}
    log.loc[700, "gyro_y"] = np.nan
    write_table(log, tmp_path / "in.csv")
    compensate_file(tmp_path / "in.csv", tmp_path / "whole.csv", chunked=False)
    compensate_file(tmp_path / "in.csv", tmp_path / "parts.csv", chunked=True, chunk_rows=777)
    assert (tmp_path / "parts.csv").read_bytes() == (tmp_path / "whole.csv").read_bytes()
    out = pd.read_csv(tmp_path / "parts.csv")
    assert set(TRIAD_COLUMNS) <= set(out.columns)


@pytest.mark.parametrize("estimator", ["adaptive", "stkf"])
def test_streaming_compensator_gives_the_x_y_axes_of_the_batch(estimator):
    """Compensator.push with gyro_x, gyro_y and acc: the same x/y numbers as compensate()."""
    from gyrodrift.compensator import Compensator

    log = simulate("vehicle", seed=5, duration_s=240.0, fs_hz=10.0, triad=TriadModel())
    log.loc[log.index[700:703], "gyro_x"] = np.nan  # held cells refuse their interval in both
    cfg = CompensatorConfig(estimator=estimator)
    batch = compensate(log, cfg)
    comp = Compensator(cfg, provisional=False)
    rows = []
    for r in log.itertuples(index=False):
        rows += comp.push(r.t, r.gyro_z, r.temp, heading_deg=r.heading, acc=(r.acc_x, r.acc_y, r.acc_z),
                          gyro_x_dps=r.gyro_x, gyro_y_dps=r.gyro_y)
    streamed = pd.DataFrame([vars(s) for s in rows])
    assert len(streamed) == len(batch)
    for col in ("rate_x", "rate_y", "bias_x", "bias_y", "tilt_gated", "rate_z", "heading"):
        assert np.array_equal(streamed[col].to_numpy(), batch[col].to_numpy(), equal_nan=True), col
    assert streamed["tilt_gated"].sum() > 0 and np.isfinite(streamed["bias_x"].iloc[-1])


def test_streaming_without_x_y_inputs_leaves_the_x_y_fields_empty():
    from gyrodrift.compensator import Compensator

    comp = Compensator(provisional=False)
    rows = []
    for i in range(400):
        rows += comp.push(i * 0.1, 0.2, 30.0, heading_deg=90.0)
    assert rows and all(math.isnan(r.rate_x) and r.tilt_gated == 0 for r in rows)


@pytest.mark.parametrize("acc_unit_mps2", [False, True])
def test_row_by_row_equals_whole_bit_for_bit(acc_unit_mps2):
    """One row at a time (the streaming compensator's case, a path of its own on floats) gives
    the bits of one call over the whole log: held cells, unusable accelerometer rows, a gap."""
    log = simulate("vehicle", seed=6, duration_s=300.0, fs_hz=10.0, triad=TriadModel())
    log.loc[400, "gyro_x"] = np.nan
    log.loc[401:403, "gyro_y"] = np.nan
    log.loc[900:905, "acc_z"] = np.nan
    log.loc[1200, "temp"] = np.nan
    log.loc[log.index >= 2000, "t"] += 5.0  # a 5-s gap: the interval is refused
    acc = log[["acc_x", "acc_y", "acc_z"]].to_numpy() * (9.80665 if acc_unit_mps2 else 1.0)
    t = log["t"].to_numpy()
    Tp = temp_rate(t, log["temp"].ffill().to_numpy())
    Tp[700] = np.nan
    args = (t, log["gyro_x"].to_numpy(), log["gyro_y"].to_numpy(), log["temp"].to_numpy(), Tp, acc,
            np.sin(t / 7.0))
    whole = TriadCompensator(CompensatorConfig()).feed(*args)
    tc = TriadCompensator(CompensatorConfig())
    rows = [tc.feed(*(a[i:i + 1] for a in args)) for i in range(len(t))]
    for c in TRIAD_COLUMNS:
        joined = np.concatenate([r[c] for r in rows])
        assert joined.dtype == whole[c].dtype
        np.testing.assert_array_equal(joined, whole[c])
    assert tc.updates["x"] > 5 and tc.reasons["gap"] >= 1



@pytest.mark.parametrize("estimator", ["stkf", "lsm"])
def test_row_by_row_equals_whole_at_a_high_rate(estimator):
    """200 Hz: the rows kept for the edge and turning windows outgrow their first buffer, in the
    middle of a chunk and between single rows; a Python estimator (lsm) is updated between calls."""
    t, gx, gy, T, Tp, acc = static_run(duration_s=45.0, fs_hz=200.0)
    rz = 0.05 * np.sin(t)
    config = TriadConfig(estimator=estimator)
    whole = TriadCompensator(CompensatorConfig(), triad=config).feed(t, gx, gy, T, Tp, acc, rz)
    tc = TriadCompensator(CompensatorConfig(), triad=config)
    rows = [tc.feed_row(t[i], gx[i], gy[i], T[i], Tp[i], acc[i], rz[i]) for i in range(t.size)]
    for k, c in enumerate(TRIAD_COLUMNS):
        np.testing.assert_array_equal(np.array([r[k] for r in rows], dtype=whole[c].dtype), whole[c])
    assert tc.updates == {"x": 3, "y": 3}


from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), acc_mps2=st.booleans(), nan_share=st.sampled_from([0.0, 0.01, 0.1]),
       gap_at=st.integers(50, 900))
def test_row_by_row_equals_whole_on_random_logs(seed, acc_mps2, nan_share, gap_at):
    """Random still-and-tilting logs with empty cells in every input, and a time gap: one row at a
    time gives the bits of one call (the float path against the array path)."""
    rng = np.random.default_rng(seed)
    n = 1000
    t = np.cumsum(rng.uniform(0.05, 0.15, n))
    t[gap_at:] += rng.uniform(0.0, 3.0)
    tilt = np.radians(rng.uniform(-20, 20)) + 0.0005 * np.cumsum(rng.normal(0, 1, n))
    acc = np.column_stack([np.sin(tilt), 0.002 * rng.normal(size=n), -np.cos(tilt)]) * (9.80665 if acc_mps2 else 1.0)
    cols = [rng.normal(0.1, 0.3, n), rng.normal(-0.2, 0.3, n), 25.0 + np.cumsum(rng.normal(0, 0.01, n)),
            rng.normal(0, 0.01, n)]
    for c in [*cols, acc[:, 1]]:
        c[1:][rng.random(n - 1) < nan_share] = np.nan  # the first temperature must be there
    rz = rng.normal(0, 0.3, n)
    rz[rng.random(n) < nan_share] = np.nan
    args = (t, *cols, acc, rz)
    cfg = CompensatorConfig(update_interval_s=2.0)
    whole = TriadCompensator(cfg, TriadConfig(edge_s=0.5)).feed(*args)
    tc = TriadCompensator(cfg, TriadConfig(edge_s=0.5))
    rows = [tc.feed_row(t[i], cols[0][i], cols[1][i], cols[2][i], cols[3][i], acc[i], rz[i]) for i in range(n)]
    for k, c in enumerate(TRIAD_COLUMNS):
        np.testing.assert_array_equal(np.array([r[k] for r in rows], dtype=whole[c].dtype), whole[c])



def xy_columns(args) -> dict:
    """The x/y columns and refusals of one log (arrays t, gx, gy, T, Tp, acc, rz) with a Kalman
    filter run inside the kernel (stkf, kf) and a Python estimator (lsm)."""
    out = {}
    for est in ("stkf", "kf", "lsm"):
        tc = TriadCompensator(CompensatorConfig(), triad=TriadConfig(estimator=est))
        cols = tc.feed(*(args[k] for k in ("t", "gx", "gy", "T", "Tp", "acc", "rz")))
        out.update({f"{est}/{c}": cols[c] for c in TRIAD_COLUMNS})
        out[f"{est}/reasons"] = np.array(list(tc.reasons.values()))
    return out


_JIT_OFF_SCRIPT = """
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from test_triad import xy_columns
np.savez(sys.argv[3], **xy_columns(np.load(sys.argv[2])))
"""


def test_the_source_without_the_compiler_gives_the_same_numbers(tmp_path):
    """NUMBA_DISABLE_JIT=1 runs gyrodrift.kernels.tilt as plain Python: the same bits as the compiled
    kernel, with the filters updated inside it and a Python estimator at the interval ends."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    log = simulate("vehicle", seed=6, duration_s=300.0, fs_hz=10.0, triad=TriadModel())
    log.loc[400, "gyro_x"] = np.nan
    log.loc[900:905, "acc_z"] = np.nan
    log.loc[log.index >= 2000, "t"] += 5.0
    t = log["t"].to_numpy()
    args = dict(t=t, gx=log["gyro_x"].to_numpy(), gy=log["gyro_y"].to_numpy(), T=log["temp"].to_numpy(),
                Tp=temp_rate(t, log["temp"].ffill().to_numpy()), acc=log[["acc_x", "acc_y", "acc_z"]].to_numpy(),
                rz=np.sin(t / 7.0))
    np.savez(tmp_path / "in.npz", **args)
    proc = subprocess.run([sys.executable, "-c", _JIT_OFF_SCRIPT, str(Path(__file__).parent), str(tmp_path / "in.npz"),
                           str(tmp_path / "plain.npz")], env=dict(os.environ, NUMBA_DISABLE_JIT="1"),
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    plain, compiled = np.load(tmp_path / "plain.npz"), xy_columns(args)
    assert set(plain.files) == set(compiled)
    for key in plain.files:
        np.testing.assert_array_equal(plain[key], compiled[key], err_msg=key)
    assert plain["stkf/tilt_gated"].sum() > 0 and plain["lsm/reasons"].sum() > 0


def test_the_x_y_axes_refuse_the_heading_model():
    """The x/y axes learn from interval measurements; the adaptive model is the heading axis's."""
    from gyrodrift.errors import ConfigError

    with pytest.raises(ConfigError, match="estimator = \"adaptive\" must be one of \"fixed\", \"kf\""):
        TriadConfig(estimator="adaptive")
