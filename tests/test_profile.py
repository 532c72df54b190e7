import json

import numpy as np
import pytest

from conftest import synthetic_log
from gyrodrift.cli import main
from gyrodrift.compensator import compensate
from gyrodrift.errors import ConfigError
from gyrodrift.profile import load_profile, profile_from_run, save_profile, warm_config


def linear_log(seed, duration_s=1800.0):
    return synthetic_log(
        duration_s=duration_s, gyro_noise_dps=0.05, compass_noise_deg=0.5, seed=seed,
        temp_c=lambda t: 25 + 15 * np.sin(np.pi * t / 3600.0) ** 2,
        drift_dps=lambda t, T: 0.03 * T - 0.8,
    )


def test_round_trip_and_warm_start_helps(tmp_path):
    first = compensate(linear_log(1))
    prof = profile_from_run(first)
    path = tmp_path / "dev.json"
    save_profile(prof, path)
    loaded = load_profile(path)
    assert loaded == prof
    assert loaded.temp_range_c[1] > 35 and loaded.samples == len(first)
    # A second, short run at a flat temperature: a cold start cannot separate a from c,
    # the warm start knows them from the first run.
    second = synthetic_log(
        duration_s=600.0, gyro_noise_dps=0.05, compass_noise_deg=0.5, seed=2,
        temp_c=lambda t: np.full_like(t, 45.0), drift_dps=lambda t, T: 0.03 * T - 0.8,
    )
    cold = compensate(second)
    warm = compensate(second, warm_config(loaded))
    assert abs(warm["a"].iloc[-1] - 0.03) < 0.5 * abs(cold["a"].iloc[-1] - 0.03)
    assert abs(warm["bias_z"] - warm["true_bias_z"]).max() < 0.05


@pytest.mark.parametrize(
    "content, match",
    [
        ("{not json", "cannot read it as JSON"),
        ('{"format": "something-else", "version": 1}', "'format' is not"),
        ('{"format": "gyrodrift-profile", "version": 99}', "version 99 is not supported"),
        ('{"format": "gyrodrift-profile", "version": 1, "params": {}}', r"missing field\(s\) software"),
    ],
)
def test_bad_or_foreign_profile(tmp_path, content, match):
    path = tmp_path / "p.json"
    path.write_text(content)
    with pytest.raises(ConfigError, match=match):
        load_profile(path)


def test_profile_with_bad_covariance(tmp_path):
    prof = profile_from_run(compensate(linear_log(1, duration_s=300.0)))
    data = prof.to_json()
    data["cov"] = [[1, 2, 3], [0, 1, 0], [0, 0, 1]]
    path = tmp_path / "p.json"
    path.write_text(json.dumps(data))
    with pytest.raises(ConfigError, match="symmetric"):
        load_profile(path)


def test_cli_save_and_use_profile(tmp_path, capsys):
    log = tmp_path / "log.csv"
    linear_log(1, duration_s=400.0).to_csv(log, index=False)
    prof = tmp_path / "dev.json"
    assert main(["compensate", str(log), "-o", str(tmp_path / "a.csv"), "--save-profile", str(prof)]) == 0
    data = json.loads(prof.read_text())
    assert data["format"] == "gyrodrift-profile" and data["version"] == 1 and data["software"].startswith("gyrodrift")
    assert main(["compensate", str(log), "-o", str(tmp_path / "b.csv"), "--profile", str(prof), "-q"]) == 0
    bad = tmp_path / "bad.json"
    bad.write_text("[]")
    assert main(["compensate", str(log), "-o", str(tmp_path / "c.csv"), "--profile", str(bad)]) == 2
    assert "bad.json: not a valid gyrodrift device profile" in capsys.readouterr().err
