"""Absurd settings and exits (issue 24, items 5 and 8): one line and exit 2, never a traceback.

Every number setting is bounded by name wherever it is given (a TOML file, an option,
a Python config: :mod:`gyrodrift.settings`); ``simulate`` refuses a rate above
what a file may have and a log larger than memory before making it; ``montecarlo``
exits 1 when every run failed and quietly when its reader goes away; an out-of-memory
error names the options that set the size.
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import synthetic_log
from gyrodrift import compensate
from gyrodrift.cli import main
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.config import config_from_dict, load_config
from gyrodrift.errors import ConfigError, GyroDriftError

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def log_path(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("bounds") / "log.csv"
    synthetic_log(duration_s=120.0, fs_hz=10.0, gyro_noise_dps=0.05, compass_noise_deg=0.5).to_csv(path, index=False)
    return path


def one_error_line(capsys, *words) -> None:
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.startswith("gyrodrift: error: ") and err.count("\n") == 1, err
    for word in words:
        assert word in err, (word, err)


@pytest.mark.parametrize("text, key", [
    ("compass_sigma_deg = 1e308", "compass_sigma_deg"),
    ("compass_sigma_deg = 1e-300", "compass_sigma_deg"),
    ("gyro_noise_dps_rthz = 1e308", "gyro_noise_dps_rthz"),
    ("gyro_noise_dps_rthz = 1e-300", "gyro_noise_dps_rthz"),
    ("[kalman]\np0_sd = [1e-300, 1e-300, 1e-300]", "p0_sd"),
    ("[kalman]\nq_sd = [1e-300, 0.05, 0.001]", "q_sd"),
    ("[temp_rate]\nbin_s = 1e308", "bin_s"),
    ("[temp_rate]\nbin_s = 1e-300", "bin_s"),
    ("[temp_rate]\nbin_s = 1e-6", "bins"),
    ("[temp_rate]\nwindow_s = 1e308", "window_s"),
    ("[adaptive]\ninnovation_window = 1000000000", "innovation_window"),
    ("[fusion]\nbias_corr_s = 1e300", "bias_corr_s"),
    ("stack_depth = 1000000", "stack_depth"),
])
def test_absurd_toml_settings_are_one_line_and_exit_2(tmp_path, log_path, capsys, text, key):
    cfg = tmp_path / "c.toml"
    cfg.write_text(text + "\n")
    assert main(["compensate", str(log_path), "-o", str(tmp_path / "o.csv"), "--config", str(cfg)]) == 2
    one_error_line(capsys, "c.toml", key)
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.parametrize("argv, words", [
    (["--compass-sigma-deg", "1e308"], ["--compass-sigma-deg"]),
    (["--init-s", "1e-300"], ["--init-s"]),
    (["--stack-depth", "5000"], ["--stack-depth", "1,000"]),
])
def test_absurd_options_are_one_line_and_exit_2(tmp_path, log_path, capsys, argv, words):
    assert main(["compensate", str(log_path), "-o", str(tmp_path / "o.csv"), *argv]) == 2
    one_error_line(capsys, *words)


@pytest.mark.parametrize("argv, words", [
    (["--duration-s", "1e12"], ["--duration-s"]),
    (["--fs-hz", "1e9"], ["--fs-hz", "100000 Hz"]),
    (["--duration-s", "1e9"], ["--duration-s", "rows", "GiB"]),
])
def test_simulate_refuses_what_it_cannot_make(tmp_path, capsys, argv, words):
    assert main(["simulate", "static", "-o", str(tmp_path / "s.csv"), *argv]) == 2
    one_error_line(capsys, *words)


def test_the_python_api_refuses_the_same_values():
    for change in ({"compass_sigma_deg": 1e308}, {"temp_rate": {"window_s": 60.0, "bin_s": 1e-4}},
                   {"kalman": {"p0_sd": (1e-300, 1.0, 1.0)}}):
        with pytest.raises(ConfigError) as toml:
            config_from_dict(change, where="s.toml")
        with pytest.raises(ConfigError) as python:
            table, values = next(iter(change.items()))
            if isinstance(values, dict):  # a table: its class refuses it
                type(getattr(CompensatorConfig(), table))(**values)
            else:
                CompensatorConfig(**change)
        # the same words from the one validator, after where the value came from
        assert str(toml.value).split(": ", 1)[1] == str(python.value).split(": ", 1)[1], (toml.value, python.value)


def test_bounds_of_a_setting_let_its_range_through():
    from gyrodrift.estimators import KalmanConfig
    from gyrodrift.fusion import FusionConfig
    from gyrodrift.settings import NUMBER_RANGE

    lo, hi = NUMBER_RANGE
    from gyrodrift.gating import GateConfig

    assert GateConfig(max_gap_s=lo).max_gap_s == lo and CompensatorConfig(init_s=hi).init_s == hi
    assert FusionConfig(relock_s=float("inf")).relock_s == float("inf")
    assert KalmanConfig(x0=(1e-12, 0.0, 0.0)).x0[0] == 1e-12  # a learned value: its own bounds only
    with pytest.raises(ConfigError, match="init_s = 10000000000.0 is outside"):
        CompensatorConfig(init_s=hi * 10)
    with pytest.raises(ConfigError, match="q_sd = .*: 1e-300 is outside"):
        KalmanConfig(q_sd=(1e-300, 1.0, 1.0))


def _floats_at_their_bounds():
    """(table, key, value): every number setting of the defaults at both ends of its range."""
    from gyrodrift.settings import NUMBER_RANGE

    d = CompensatorConfig()
    tables = {"": d, "kalman": d.kalman, "gate": d.gate, "temp_rate": d.temp_rate, "adaptive": d.adaptive,
              "fusion": d.fusion_settings}
    for table, obj in tables.items():
        for f in dataclasses.fields(obj):
            v = getattr(obj, f.name)
            if isinstance(v, float) and not isinstance(v, bool):
                for x in NUMBER_RANGE:
                    yield table, f.name, x


def test_every_setting_at_the_ends_of_its_range_runs_or_is_refused_in_one_line():
    """No value the bounds let through ends in anything but a GyroDriftError or finite rows."""
    log = synthetic_log(duration_s=60.0, fs_hz=5.0, gyro_noise_dps=0.05, compass_noise_deg=0.5,
                        heading_deg=lambda t: 100.0 + 30.0 * np.sin(t / 15.0))
    ran = 0
    for table, key, value in _floats_at_their_bounds():
        values = {table: {key: value}} if table else {key: value}
        try:
            out = compensate(log, config_from_dict({**values, "init_s": 10.0, "update_interval_s": 5.0}))
        except GyroDriftError as err:
            assert "\n" not in str(err)
            continue
        ran += 1
        assert np.isfinite(out[["rate_z", "bias_z", "heading"]].to_numpy()).all(), (table, key, value)
    assert ran > 20


def test_load_config_names_the_file_table_and_key(tmp_path):
    cfg = tmp_path / "s.toml"
    cfg.write_text("[temp_rate]\nwindow_s = 1e308\n")
    with pytest.raises(ConfigError, match=r"s\.toml \[temp_rate\]: window_s = 1e\+308 is outside"):
        load_config(cfg)


# --------------------------------------------------------------------------- montecarlo and memory

MC = ["montecarlo", "--seeds", "1", "--families", "vehicle", "--duration-scale", "0.02", "--workers", "1"]


def test_montecarlo_exits_1_when_every_run_failed(capsys):
    assert main([*MC, "--methods", "fixed"]) == 1
    assert "1 of 1 runs failed" in capsys.readouterr().out
    assert main([*MC, "--methods", "kf", "fixed"]) == 0


def test_montecarlo_into_a_closed_pipe_ends_quietly():
    # the reader gone before anything is written (as "| head -1" once it has its line): closed
    # first, so the run cannot finish into the pipe's buffer before the close
    read_end, write_end = os.pipe()
    os.close(read_end)
    proc = subprocess.Popen([sys.executable, "-m", "gyrodrift", *MC, "--methods", "kf"], cwd=ROOT,
                            stdout=write_end, stderr=subprocess.PIPE)
    os.close(write_end)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=300) == 141, err
    assert "Traceback" not in err and "Exception ignored" not in err and "BrokenPipe" not in err


def test_out_of_memory_names_the_options_that_set_the_size(tmp_path, capsys, monkeypatch):
    import gyrodrift.simulate as sim

    def no_memory(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(sim, "simulate", no_memory)
    assert main(["simulate", "static", "-o", str(tmp_path / "s.csv"), "--duration-s", "100"]) == 1
    err = capsys.readouterr().err
    assert "out of memory" in err and "--duration-s" in err and "--fs-hz" in err and err.count("\n") == 1
