import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift.evaluate.compare import CAUSAL, METHODS, run_method, run_methods, summary_table
from gyrodrift.errors import ConfigError
from gyrodrift.estimators import fit_linear_drift, fit_poly3
from gyrodrift.fusion_offset import available as fusion_offset_available
from gyrodrift.fusion_offset import fusion_offset_drift
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


def test_mlr_fits_the_paper_kf_interval_measurements_whatever_the_estimator():
    from dataclasses import replace

    from gyrodrift.compensator import CompensatorConfig, compensate

    log, _ = linear_noiseless_log()
    kf = compensate(log, replace(CompensatorConfig(), estimator="kf")).attrs["measurements"]
    assert len(kf) > 400 and np.allclose(np.diff(np.unique(kf["t"])), 10.0)  # the paper's 10-s intervals (and init)
    for estimator in ("adaptive", "stkf"):  # the default records no interval measurements
        out = run_method("mlr", log, CompensatorConfig(estimator=estimator))
        pd.testing.assert_frame_equal(out.attrs["measurements"], kf)
        H = np.column_stack([kf["temp"], kf["temp_rate"], np.ones(len(kf))])
        np.testing.assert_array_equal(out[["a", "b", "c"]].iloc[0], fit_linear_drift(kf["m"], H, kf["r"]))


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
    missing = set() if fusion_offset_available() else {"fusion-offset"}
    assert list(outputs) == [m for m in METHODS if m not in missing] and set(skipped) == missing
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


# ------------------------------------------------------------------ x-io Fusion's offset correction


def static_constant_bias_log(bias_dps=0.4, duration_s=120.0, fs_hz=10.0):
    """Motionless at 100 deg, 25 degC, gyro reading a constant bias, compass on every other row."""
    t = np.arange(int(duration_s * fs_hz) + 1) / fs_hz
    log = pd.DataFrame({"t": t, "gyro_z": bias_dps, "temp": 25.0,
                        "heading": np.where(np.arange(t.size) % 2 == 0, 100.0, np.nan)})
    log["ref_heading"] = 100.0
    log["true_bias_z"] = bias_dps
    return log


def test_fusion_offset_recovers_a_constant_bias_after_its_timeout():
    pytest.importorskip("imufusion")
    log = static_constant_bias_log()
    out = run_method("fusion-offset", log)
    drift = out["bias_z"].to_numpy()
    # Fusion (defaults: 3 deg/s, 3 s): 30 still samples at 10 Hz, then the offset moves
    # towards the gyro by g = 2*pi*0.02/10 of the difference per sample.
    g = 2.0 * np.pi * 0.02 / 10.0
    k = np.arange(drift.size)
    expected = np.where(k <= 30, 0.0, 0.4 * (1.0 - (1.0 - g) ** np.maximum(k - 30, 0)))
    np.testing.assert_allclose(drift, expected, rtol=1e-4, atol=1e-6)
    assert abs(drift[-1] - 0.4) < 1e-3
    # the heading keeps what was integrated before the offset converged: bias * (3 s + 1/(10 Hz * g))
    err = (out["heading"].iloc[-1] - 100.0 + 180.0) % 360.0 - 180.0
    assert err == pytest.approx(0.4 * (3.0 + 0.1 / g), abs=0.05)
    assert CAUSAL["fusion-offset"] and out["updated"].sum() == 0


def test_fusion_offset_uses_the_other_axes_to_tell_stillness():
    pytest.importorskip("imufusion")
    log = static_constant_bias_log(duration_s=60.0)
    # never still: no offset (up to the single precision of the library's gyro)
    assert np.abs(fusion_offset_drift(log.assign(gyro_x=5.0, gyro_y=0.0))).max() < 1e-7
    assert fusion_offset_drift(log.assign(gyro_x=0.5, gyro_y=-0.5))[-1] > 0.3
    with pytest.raises(ConfigError, match="sample_rate_hz must be a positive number"):
        fusion_offset_drift(log, sample_rate_hz=0.0)


def test_fusion_offset_without_imufusion_is_skipped_or_a_one_line_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "imufusion", None)  # import imufusion now raises ImportError
    assert not fusion_offset_available()
    log = static_constant_bias_log(duration_s=60.0)
    outputs, skipped = run_methods(log, ("kf", "fusion-offset"))
    assert list(outputs) == ["kf"] and "pip install imufusion" in skipped["fusion-offset"]
    with pytest.raises(ConfigError, match="pip install imufusion"):
        run_method("fusion-offset", log)


# ------------------------------------------------------------------ the default estimator first


def test_default_methods_start_with_the_default_estimator():
    from gyrodrift.evaluate.compare import DEFAULT_METHOD, DEFAULT_METHODS, method_label
    from gyrodrift.compensator import CompensatorConfig

    assert DEFAULT_METHOD == CompensatorConfig().estimator == "adaptive"
    assert DEFAULT_METHODS == (DEFAULT_METHOD, *METHODS)
    assert method_label("adaptive") == "adaptive (default)" and method_label("stkf") == "stkf"
    log = synthetic_log(duration_s=120.0).drop(columns="true_bias_z")
    outputs, _ = run_methods(log)
    assert next(iter(outputs)) == "adaptive"


def test_compare_command_lists_the_default_estimator_first_and_names_it(tmp_path):
    path = tmp_path / "log.csv"
    simulate("vehicle", duration_s=300.0, fs_hz=10.0, seed=2).to_csv(path, index=False)
    res = subprocess.run([sys.executable, "-m", "gyrodrift", "compare", str(path)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    rows = [line for line in res.stdout.splitlines() if line.startswith("| ") and "---" not in line]
    assert rows[1].startswith("| adaptive (default) |")  # rows[0] is the header
    assert rows[2].startswith("| stkf |")
    res = subprocess.run([sys.executable, "-m", "gyrodrift", "compare", str(path), "--methods", "stkf,adaptive",
                          "--json"], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    assert list(data["methods"]) == ["stkf", "adaptive"] and data["default_method"] == "adaptive"
