import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift.compare import CAUSAL, METHODS, run_method, run_methods, summary_table
from gyrodrift.errors import ConfigError
from gyrodrift.estimators import fit_linear_drift, fit_poly3
from gyrodrift.model import temp_rate
from gyrodrift.simulate import simulate


def linear_noiseless_log():
    a, b, c = 0.021, 6.5, -0.43
    t = np.arange(0.0, 5400.0, 0.1)
    temp = 30 + 8 * np.sin(2 * np.pi * t / 3000) + 3 * np.sin(2 * np.pi * t / 700)
    log = pd.DataFrame({"t": t, "gyro_z": a * temp + b * temp_rate(t, temp) + c, "temp": temp,
                        "heading": np.where(np.arange(t.size) % 2 == 0, 250.0, np.nan)})
    log["true_bias_z"] = log["gyro_z"]
    log["ref_heading"] = 250.0
    return log, (a, b, c)


def test_mlr_recovers_exact_parameters_from_noiseless_linear_data():
    log, truth = linear_noiseless_log()
    out = run_method("mlr", log)
    assert np.all(out[["a", "b", "c"]].to_numpy() == out[["a", "b", "c"]].iloc[0].to_numpy())  # fixed
    np.testing.assert_allclose(out[["a", "b", "c"]].iloc[0], truth, rtol=1e-6)
    assert not CAUSAL["mlr"]


def test_filters_recover_noiseless_linear_drift():
    log, truth = linear_noiseless_log()
    for name in ("stkf", "stkf-s1"):
        out = run_method(name, log)
        np.testing.assert_allclose(out[["a", "b", "c"]].iloc[-1], truth, rtol=1e-3, err_msg=name)
    # The windowed LSM is regularised by the prior (short windows are ill-conditioned):
    # not exact, but its drift follows the truth.
    out = run_method("lsm", log)
    assert np.abs(out["bias_z"] - out["true_bias_z"])[out["t"] > 600].max() < 0.03


def test_fit_linear_drift_regularises_flat_temperature():
    H = np.column_stack([np.full(50, 40.0), np.zeros(50), np.ones(50)])
    x = fit_linear_drift(np.full(50, 0.2), H, np.full(50, 1e-4))
    assert np.all(np.isfinite(x))
    assert 40 * x[0] + x[2] == pytest.approx(0.2, abs=1e-3)  # the observable combination


def test_poly3_fit_and_clamp():
    T = np.linspace(0, 50, 6000)
    rng = np.random.default_rng(0)
    true = 0.1 + 0.02 * (T - 25) - 2e-4 * (T - 25) ** 2 + 3e-6 * (T - 25) ** 3
    cal = fit_poly3(T, true + rng.normal(0, 0.05, T.size))
    np.testing.assert_allclose(cal.drift(T), true, atol=3e-3)
    assert cal.drift(80.0) == cal.drift(50.0)  # clamped, no extrapolation
    with pytest.raises(ConfigError, match="too short or too flat"):
        fit_poly3(np.full(100, 30.0), np.zeros(100))


def test_oracle_has_zero_bias_error_and_all_methods_run():
    log = simulate("static", duration_s=900.0, fs_hz=10.0, seed=3)
    cal = simulate("calibration", duration_s=1800.0, fs_hz=10.0, seed=4)
    outputs, skipped = run_methods(log, METHODS, calibration=cal)
    assert list(outputs) == list(METHODS) and not skipped
    np.testing.assert_array_equal(outputs["oracle"]["bias_z"], log["true_bias_z"])
    table = summary_table(outputs)
    assert table.loc["oracle", "bias_rms"] == 0.0
    assert table.loc["stkf", "bias_rms"] < table.loc["kf", "bias_rms"]
    # the oracle's heading error is noise and compass offset alone: the floor for everyone
    assert table.loc["oracle", "heading_rms"] <= table["heading_rms"].min() + 1e-9


def test_skips_need_truth_or_calibration():
    log = synthetic_log(duration_s=120.0).drop(columns="true_bias_z")
    outputs, skipped = run_methods(log, ("stkf", "poly3", "oracle"))
    assert list(outputs) == ["stkf"] and set(skipped) == {"poly3", "oracle"}
    with pytest.raises(ConfigError, match="unknown method"):
        run_methods(log, ("stkf", "magic"))


def test_compare_command_json(tmp_path):
    path = tmp_path / "log.csv"
    simulate("vehicle", duration_s=600.0, fs_hz=10.0, seed=2).to_csv(path, index=False)
    res = subprocess.run([sys.executable, "-m", "gyrodrift", "compare", str(path), "--methods", "stkf,kf,oracle", "--json"],
                         capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    assert set(data["methods"]) == {"stkf", "kf", "oracle"}
    assert data["methods"]["oracle"]["bias_rms"] == 0.0
    assert "heading_rms" in data["methods"]["stkf"]
    res = subprocess.run([sys.executable, "-m", "gyrodrift", "compare", str(path), "--methods", "stkf"],
                         capture_output=True, text=True)
    assert res.returncode == 0 and "| stkf |" in res.stdout
