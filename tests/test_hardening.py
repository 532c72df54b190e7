"""Hardening of the file-facing edges (issue 16): settings files, device profiles,
temporary output files and the batch summary.

Every case of the issue that concerns these edges has a regression test here; the
hypothesis fuzz tests at the end feed the config and profile loaders arbitrary bytes
and arbitrary TOML/JSON-like values. They run :data:`FUZZ_EXAMPLES` examples each
(200 by default; set ``GYRODRIFT_FUZZ_EXAMPLES`` for a longer run).
"""

from __future__ import annotations

import csv
import datetime as dt
import json
import math
import os
import re
import signal
import subprocess
import sys
import tempfile
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import synthetic_log
from gyrodrift.cli import main
from gyrodrift.compensate import CompensatorConfig
from gyrodrift.config import config_from_dict, load_config, load_toml
from gyrodrift.errors import ConfigError, GyroDriftError
from gyrodrift.profile import Profile, load_profile, save_profile, warm_config

SRC = Path(__file__).resolve().parents[1] / "src"
#: Examples per fuzz test: small in CI, more on request.
FUZZ_EXAMPLES = int(os.environ.get("GYRODRIFT_FUZZ_EXAMPLES", "200"))
FUZZ = settings(
    max_examples=FUZZ_EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def one_line_error(err: str, *names: str) -> None:
    """``err`` is one ``gyrodrift: error:`` line that contains every one of ``names``."""
    assert "Traceback" not in err
    assert err.startswith("gyrodrift: error: ") and err.count("\n") == 1, err
    for name in names:
        assert name in err, (name, err)


@pytest.fixture
def tiny_log(tmp_path) -> Path:
    path = tmp_path / "log.csv"
    synthetic_log(duration_s=200.0, gyro_noise_dps=0.05, compass_noise_deg=0.5).to_csv(path, index=False)
    return path


# --------------------------------------------------------------------------- settings files


def _commands(tmp_path: Path, log: Path, cfg: Path) -> dict[str, list[str]]:
    """Every command that reads a settings file, each failing on it before any work."""
    return {
        "compensate": ["compensate", str(log), "-o", str(tmp_path / "o.csv"), "--config", str(cfg)],
        "demo": ["demo", "-o", str(tmp_path / "d.csv"), "--config", str(cfg)],
        "simulate": ["simulate", "static", "-o", str(tmp_path / "s.csv"), "--config", str(cfg)],
        "montecarlo": ["montecarlo", "--seeds", "1", "--config", str(cfg)],
        "batch": ["batch", str(log), "-o", str(tmp_path / "out"), "--config", str(cfg)],
    }


@pytest.mark.parametrize("command", ["compensate", "demo", "simulate", "montecarlo", "batch"])
def test_non_utf8_settings_file_is_one_line_naming_the_file(tmp_path, tiny_log, capsys, command):
    cfg = tmp_path / "latin1.toml"
    cfg.write_bytes("init_s = 20.0  # r\u00e9glage\n".encode("latin-1"))
    assert main(_commands(tmp_path, tiny_log, cfg)[command]) == 2
    one_line_error(capsys.readouterr().err, "latin1.toml", "UTF-8")


def test_non_utf8_settings_file_library_error():
    with tempfile.TemporaryDirectory() as d:
        cfg = Path(d) / "bad.toml"
        cfg.write_bytes(b"\xff\xfe[kalman]\n")
        with pytest.raises(ConfigError, match=r"bad\.toml: .*UTF-8.*byte 0xff at offset 0"):
            load_config(cfg)


def test_utf8_bom_is_accepted(tmp_path):
    cfg = tmp_path / "bom.toml"
    cfg.write_bytes(b"\xef\xbb\xbfinit_s = 20.0\n")
    assert load_config(cfg).init_s == 20.0


@pytest.mark.parametrize(
    "text, names",
    [
        ("update_interval_s = true\n", ["update_interval_s", "true", "number"]),
        ("init_s = 1979-05-27\n", ["init_s", "number"]),
        ("estimator = 3\n", ["estimator", "text"]),
        ("[adaptive]\nzaru = 1\n", ["[adaptive]", "zaru", "true or false"]),
        ("[fusion]\nmagnetic_gates = \"yes\"\n", ["[fusion]", "magnetic_gates", "true or false"]),
        ("[kalman]\np0_sd = [true, 5.0, 5.0]\n", ["[kalman]", "p0_sd", "3 numbers"]),
        ("[kalman]\np0_sd = [0.05, 5.0]\n", ["[kalman]", "p0_sd", "3 numbers"]),
        ("[kalman]\nx0 = 0.0\n", ["[kalman]", "x0", "3 numbers"]),
        ("[gate]\nrelock_intervals = 2.5\n", ["[gate]", "relock_intervals", "whole number"]),
        ("[gate]\nmax_gap_s = nan\n", ["[gate]", "max_gap_s", "nan"]),
        ("stack_depth = 99999999999999999999\n", ["stack_depth", "64-bit"]),
        ("[kalman]\nfadding = 1.1\n", ["[kalman]", "fadding", "unknown"]),
        ("[\"kalman\"]\n\"fad\\nding\" = 1.1\n", ["[kalman]", "'fad\\nding'", "unknown"]),
    ],
)
def test_settings_are_type_checked_by_schema(tmp_path, text, names):
    cfg = tmp_path / "s.toml"
    cfg.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_config(cfg)
    message = str(info.value)
    assert message.startswith(f"{cfg}") and "\n" not in message
    for name in names:
        assert name in message, (name, message)


def test_bool_is_not_a_number_in_the_library_either():
    with pytest.raises(ConfigError, match="update_interval_s"):
        config_from_dict({"update_interval_s": True})
    # whole numbers are numbers: TOML writes 10 for 10.0
    assert config_from_dict({"update_interval_s": 10}).update_interval_s == 10.0
    assert isinstance(config_from_dict({"update_interval_s": 10}).update_interval_s, float)


def test_deeply_nested_or_huge_toml_is_a_config_error(tmp_path):
    cfg = tmp_path / "deep.toml"
    cfg.write_text("x = " + "[" * 50_000 + "]" * 50_000 + "\n")
    with pytest.raises(ConfigError, match="deep.toml"):
        load_toml(cfg)
    cfg.write_text("x = " + "9" * 5000 + "\n")  # beyond Python's integer-string limit
    with pytest.raises(ConfigError, match="deep.toml"):
        load_toml(cfg)
    cfg.write_bytes(b"# " + b"x" * (2 << 20) + b"\n")
    with pytest.raises(ConfigError, match="deep.toml: .*larger than"):
        load_toml(cfg)


def test_simulate_tables_must_be_tables(tmp_path, capsys):
    cfg = tmp_path / "sim.toml"
    cfg.write_text("device = 3\n")
    assert main(["simulate", "static", "-o", str(tmp_path / "s.csv"), "--config", str(cfg)]) == 2
    one_line_error(capsys.readouterr().err, "sim.toml", "[device]", "table")
    cfg.write_text("[device]\nc0_dps = true\n")
    assert main(["simulate", "static", "-o", str(tmp_path / "s.csv"), "--config", str(cfg)]) == 2
    one_line_error(capsys.readouterr().err, "sim.toml", "[device]", "c0_dps")


# --------------------------------------------------------------------------- fuzzing

#: Settings names the fuzzer draws keys from (with a few unknown ones).
_TOP_KEYS = [
    "update_interval_s", "init_s", "stack_depth", "compass_sigma_deg", "gyro_noise_dps_rthz",
    "estimator", "measurement", "unknown_key",
]
_TABLE_KEYS = {
    "kalman": ["fading", "x0", "p0_sd", "q_sd", "max_sd", "p0_cov"],
    "gate": ["turn_rate_dps", "turn_window_s", "interference_deg", "max_gap_s", "relock_intervals"],
    "temp_rate": ["window_s", "bin_s"],
    "adaptive": ["stacked", "edge_s", "zaru", "lambda_max", "innovation_window", "q_sd", "a2_sd"],
    "fusion": ["heading_sigma_deg", "bias_corr_s", "nis_gate", "relock_s", "magnetic_gates"],
}

_scalars = st.one_of(
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.sampled_from([0, 1, 2, 3, 10]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=1e-3, max_value=100.0),
    st.text(max_size=12),
    st.sampled_from(["adaptive", "stkf", "kf", "lsm", "endpoints", "slope"]),
    st.datetimes(timezones=st.none() | st.just(dt.timezone.utc)),
    st.dates(),
)
_values = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner, max_size=3), max_leaves=12)


@st.composite
def toml_dicts(draw) -> dict:
    """Dicts as tomllib returns them, with mostly known keys and any TOML-like values."""
    out = {k: draw(_values) for k in draw(st.lists(st.sampled_from(_TOP_KEYS), max_size=4, unique=True))}
    for table in draw(st.lists(st.sampled_from(list(_TABLE_KEYS)), max_size=3, unique=True)):
        keys = draw(st.lists(st.sampled_from(_TABLE_KEYS[table] + ["nope"]), max_size=4, unique=True))
        out[table] = {k: draw(_values) for k in keys} if draw(st.booleans()) or not keys else draw(_values)
    return out


def _toml_value(v) -> str:
    """A TOML literal for a value of :data:`_values` (text the loader may still refuse)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v == math.inf else "-inf" if v == -math.inf else repr(v))
    if isinstance(v, (int, dt.date)):
        return v.isoformat() if isinstance(v, dt.date) else str(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return "{" + ", ".join(f"{json.dumps(k, ensure_ascii=False)} = {_toml_value(x)}" for k, x in v.items()) + "}"


def _toml_text(values: dict) -> str:
    lines = [f"{k} = {_toml_value(v)}" for k, v in values.items() if not (k in _TABLE_KEYS and isinstance(v, dict))]
    for k, v in values.items():
        if k in _TABLE_KEYS and isinstance(v, dict):
            lines.append(f"[{k}]")
            lines += [f"{json.dumps(kk, ensure_ascii=False)} = {_toml_value(x)}" for kk, x in v.items()]
    return "\n".join(lines) + "\n"


def _check_config(cfg) -> None:
    """A config the loader accepted holds values of the types its fields declare."""
    assert isinstance(cfg, CompensatorConfig)
    for obj in (cfg, cfg.kalman, cfg.gate, cfg.temp_rate, cfg.adaptive, cfg.fusion_settings):
        for name, value in vars(obj).items():
            default = getattr(type(obj)(), name)
            if isinstance(default, float):
                assert isinstance(value, float) and not math.isnan(value), (type(obj).__name__, name, value)
            elif isinstance(default, bool):
                assert isinstance(value, bool), (type(obj).__name__, name, value)
            elif isinstance(default, int):
                assert isinstance(value, int) and not isinstance(value, bool), (type(obj).__name__, name, value)


def _load_config_bytes(data: bytes):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "fuzz.toml"
        path.write_bytes(data)
        try:
            cfg = load_config(path)
        except ConfigError as err:
            assert str(err).startswith(str(path)) and "\n" not in str(err), str(err)
            return None
    _check_config(cfg)
    return cfg


@FUZZ
@given(st.binary(max_size=400))
def test_fuzz_config_loader_bytes(data):
    _load_config_bytes(data)


@FUZZ
@given(toml_dicts())
def test_fuzz_config_loader_toml_text(values):
    _load_config_bytes(_toml_text(values).encode("utf-8"))


@FUZZ
@given(toml_dicts())
def test_fuzz_config_from_dict(values):
    try:
        cfg = config_from_dict(values, where="fuzz.toml")
    except ConfigError as err:
        assert str(err).startswith("fuzz.toml") and "\n" not in str(err), str(err)
        return
    _check_config(cfg)

