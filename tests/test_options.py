"""One validator for every route of a setting, and one option layer for every command (issue 22, items 3-4)."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift import CompensatorConfig, KalmanConfig, compensate
from gyrodrift.cli import main
from gyrodrift.cli.commands import build_parser
from gyrodrift.config import load_config
from gyrodrift.errors import ConfigError
from gyrodrift.profile import load_profile


@pytest.fixture(scope="module")
def log_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("options") / "log.csv"
    synthetic_log(duration_s=90.0, fs_hz=10.0, gyro_noise_dps=0.05, compass_noise_deg=0.5).to_csv(path, index=False)
    return path


def _error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("gyrodrift: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    return err[len("gyrodrift: error: "):].rstrip("\n")


def _profile(path, c_dps: float):
    path.write_text(json.dumps({
        "format": "gyrodrift-profile", "version": 1, "software": "gyrodrift 1.0.0",
        "created": "2024-05-01T12:00:00+00:00", "estimator": "adaptive",
        "params": {"a_dps_per_c": 0.02, "b_deg": 3.0, "c_dps": c_dps},
        "cov": [[1e-6, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 1e-3]], "temp_range_c": [20.0, 45.0],
        "samples": 100, "updates": 1}))
    return path


def test_a_bad_setting_gets_the_same_words_from_python_toml_and_the_command_line(tmp_path, log_path, capsys):
    with pytest.raises(ConfigError) as python:
        KalmanConfig(fading=0.5)
    toml = tmp_path / "s.toml"
    toml.write_text("[kalman]\nfading = 0.5\n")
    with pytest.raises(ConfigError) as from_file:
        load_config(toml)
    words = "fading = 0.5 must be >= 1"
    assert str(python.value) == f"KalmanConfig: {words}"
    assert str(from_file.value) == f"{toml} [kalman]: {words}"
    out = str(tmp_path / "o.csv")
    assert main(["compensate", str(log_path), "-o", out, "--fading", "0.5"]) == 2
    assert _error(capsys) == f"--fading: {words}"
    assert main(["compensate", str(log_path), "-o", out, "--set", "kalman.fading=0.5"]) == 2
    assert _error(capsys) == f"--set kalman.fading=0.5: {words}"
    assert main(["compensate", str(log_path), "-o", out, "--config", str(toml)]) == 2
    assert _error(capsys) == f"{toml} [kalman]: {words}"


def test_a_drift_beyond_the_plausible_model_gets_the_same_words_from_every_route(tmp_path, log_path, capsys):
    """c = 80 deg/s: an x0 from Python, a TOML file or --set, and a device profile's c_dps."""
    words = "80 is outside the plausible drift model (|a| <= 1 deg/s/degC, |b| <= 1000 deg/degC, |c| <= 50 deg/s)"
    with pytest.raises(ConfigError) as python:
        KalmanConfig(x0=(0.0, 0.0, 80.0))
    toml = tmp_path / "s.toml"
    toml.write_text("[kalman]\nx0 = [0.0, 0.0, 80.0]\n")
    with pytest.raises(ConfigError) as from_file:
        load_config(toml)
    with pytest.raises(ConfigError) as profile:
        load_profile(_profile(tmp_path / "dev.json", 80.0))
    assert main(["compensate", str(log_path), "-o", str(tmp_path / "o.csv"), "--set", "kalman.x0=[0, 0, 80]"]) == 2
    cli = _error(capsys)
    assert str(python.value) == f"KalmanConfig: x0 = [0.0, 0.0, 80.0]: c = {words}"
    assert str(from_file.value) == f"{toml} [kalman]: x0 = [0.0, 0.0, 80.0]: c = {words}"
    assert cli == f"--set kalman.x0=[0, 0, 80]: x0 = [0.0, 0.0, 80.0]: c = {words}"
    assert f"params = [0.02, 3.0, 80.0]: c_dps = {words}" in str(profile.value)
    assert str(profile.value).startswith(f"{tmp_path / 'dev.json'}: not a valid gyrodrift device profile: ")


def test_options_are_judged_alone_then_together(log_path, tmp_path):
    from gyrodrift.cli.options import method_config

    args = build_parser().parse_args(["compensate", "x.csv", "-o", "o.csv", "--init-s", "0.2", "--stack-depth", "2",
                                      "--set", "tilt=gyro", "--set", "gate.max_gap_s=2", "--declination", "7"])
    cfg = method_config(args)  # init_s 0.2 is too short for the default 3 sub-windows, not for 2
    assert (cfg.init_s, cfg.stack_depth, cfg.tilt, cfg.gate.max_gap_s, cfg.declination_deg) == (0.2, 2, "gyro", 2.0, 7.0)
    args = build_parser().parse_args(["compensate", "x.csv", "-o", "o.csv", "--set", "kalman.nope=1"])
    with pytest.raises(ConfigError, match=r"--set kalman.nope=1: unknown setting\(s\) nope"):
        method_config(args)


@pytest.mark.parametrize("estimator", sorted(__import__("gyrodrift.estimators", fromlist=["ESTIMATORS"]).ESTIMATORS))
def test_report_takes_every_estimator_compare_takes(log_path, tmp_path, capsys, estimator):
    compare = build_parser().parse_args(["compare", str(log_path), "--estimator", estimator])
    assert compare.estimator == estimator  # compare's choices are the method options' choices
    page = tmp_path / "r.html"
    code = main(["report", str(log_path), "-o", str(page), "--methods", "stkf", "--estimator", estimator, "-q"])
    if estimator == "fixed":  # no estimator of that name can be built from settings alone: the same words as compare
        assert code == 2 and "estimator = \"fixed\" cannot be built from settings alone" in _error(capsys)
        assert main(["compare", str(log_path), "--estimator", estimator]) == 2
        assert "estimator = \"fixed\" cannot be built" in _error(capsys)
        return
    assert code == 0, capsys.readouterr().err
    assert f"<td><code>estimator</code></td><td><code>{estimator}</code></td>" in page.read_text()


def test_batch_runs_large_logs_in_chunks_as_compensate_does(log_path, tmp_path, monkeypatch, capsys):
    from gyrodrift import pipeline

    calls = []
    real = pipeline._stream
    monkeypatch.setattr(pipeline, "_stream", lambda *a, **k: calls.append(a[4]) or real(*a, **k))
    monkeypatch.setattr(pipeline, "CHUNK_ROWS", 100)  # 900 rows: 9 chunks
    out_dir = tmp_path / "out"
    assert main(["batch", str(log_path), "-o", str(out_dir), "--workers", "1", "--output-format", "csv",
                 "--estimator", "stkf"]) == 0
    assert calls == [100]  # the chunked path, at the chunk size compensate_file uses
    written = pd.read_csv(out_dir / "log_out.csv")
    whole = compensate(pd.read_csv(log_path), CompensatorConfig(estimator="stkf"))
    pd.testing.assert_series_equal(written["bias_z"], whole["bias_z"].astype(float), check_names=False)
    summary = pd.read_csv(out_dir / "summary.csv")
    assert summary["status"].tolist() == ["ok"] and summary["rows"].tolist() == [900]


def test_old_spellings_still_work_with_a_warning(log_path, tmp_path, capsys):
    assert main(["compensate", str(log_path), "-o", str(tmp_path / "o.csv"), "--format", "csv", "-q"]) == 0
    assert "--format is deprecated here; use --input-format" in capsys.readouterr().err
    assert main(["batch", str(log_path), "-o", str(tmp_path / "b"), "--workers", "1", "--format", "csv"]) == 0
    assert "--format is deprecated here; use --output-format" in capsys.readouterr().err
    assert (tmp_path / "b" / "log_out.csv").is_file()
    from gyrodrift.pipeline import compensate_file

    with pytest.warns(DeprecationWarning, match="chunked"):
        assert compensate_file(log_path, tmp_path / "s.csv", stream=True).streamed


def test_the_public_api_exports_what_users_call():
    import gyrodrift

    for name in ("read_log", "compensate_file", "ReadOptions", "AdaptiveConfig", "FusionConfig", "ScaleFactorConfig",
                 "load_config", "compensate", "Compensator", "CompensatorConfig"):
        assert name in gyrodrift.__all__ and getattr(gyrodrift, name) is not None, name
    assert gyrodrift.CompensatorConfig().adaptive == gyrodrift.AdaptiveConfig()  # the default estimator's config


def test_scale_factor_takes_the_compensators_sensor_noise(log_path, tmp_path, monkeypatch):
    """--scale-factor and --compass-sigma-deg describe one compass: the estimate gets the option's value."""
    import gyrodrift.scale_factor as sf_module

    seen = []
    real = sf_module.estimate_scale_factor
    monkeypatch.setattr(sf_module, "estimate_scale_factor", lambda out, config: seen.append(config) or real(out, config))
    assert main(["compensate", str(log_path), "-o", str(tmp_path / "o.csv"), "--scale-factor", "-q",
                 "--compass-sigma-deg", "2", "--set", "gyro_noise_dps_rthz=0.1"]) == 0
    assert [(c.compass_sigma_deg, c.gyro_noise_dps_rthz) for c in seen] == [(2.0, 0.1)]
