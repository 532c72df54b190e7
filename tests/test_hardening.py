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
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from conftest import synthetic_log
from gyrodrift.cli import main
from gyrodrift.compensator import CompensatorConfig
from gyrodrift.config import config_from_dict, load_config, load_toml
from gyrodrift.errors import ConfigError
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
        ("[adaptive]\nclean_s = \"1h\"\n", ["[adaptive]", "clean_s", "number"]),
        ("[adaptive]\nturn_walks = [0.003, 0.03, 0.3]\n", ["[adaptive]", "turn_walks", "list of 4 numbers"]),
        ("[adaptive]\nturn_walks = 0.3\n", ["[adaptive]", "turn_walks", "list of numbers"]),
        ("[adaptive]\nzaru = true\n", ["[adaptive]", "zaru", "unknown"]),
        ("[fusion]\nmagnetic_gates = \"yes\"\n", ["[fusion]", "magnetic_gates", "true or false"]),
        ("[kalman]\np0_sd = [true, 5.0, 5.0]\n", ["[kalman]", "p0_sd", "3 numbers"]),
        ("[kalman]\np0_sd = [0.05, 5.0]\n", ["[kalman]", "p0_sd", "3 numbers"]),
        ("[kalman]\nx0 = 0.0\n", ["[kalman]", "x0", "3 numbers"]),
        ("[gate]\nrelock_intervals = 2.5\n", ["[gate]", "relock_intervals", "whole number"]),
        ("[gate]\nmax_gap_s = nan\n", ["[gate]", "max_gap_s", "nan"]),
        ("stack_depth = 99999999999999999999\n", ["stack_depth", "64-bit"]),
        ("[kalman]\nfadding = 1.1\n", ["[kalman]", "fadding", "unknown"]),
        ("[kalman]\nx0 = [0.0, 0.0, 1e308]\n", ["[kalman]", "x0", "plausible"]),
        ("[kalman]\np0_sd = [1e300, 5.0, 5.0]\n", ["[kalman]", "p0_sd", "plausible"]),
        ("[kalman]\nq_sd = [1e-4, 2000.0, 1e-3]\n", ["[kalman]", "q_sd", "plausible"]),
        ("[kalman]\np0_cov = [[1e300, 0, 0], [0, 1, 0], [0, 0, 1]]\n", ["[kalman]", "p0_cov", "plausible"]),
        ("[adaptive]\ndrift_walk = 60.0\n", ["[adaptive]", "drift_walk", "plausible"]),
        ("[adaptive]\ncompass_error_deg = 1e300\n", ["[adaptive]", "compass_error_deg", "plausible"]),
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


# --------------------------------------------------------------------------- device profiles


def profile_json(**changes) -> dict:
    """A valid profile as JSON values; ``changes`` replace top-level fields or, with a
    ``params_`` prefix, entries of ``params``."""
    data = {
        "format": "gyrodrift-profile",
        "version": 1,
        "software": "gyrodrift 1.0.0",
        "created": "2024-05-01T12:00:00+00:00",
        "estimator": "adaptive",
        "params": {"a_dps_per_c": 0.02, "b_deg": 3.0, "c_dps": -0.5},
        "cov": [[1e-6, 0.0, -2e-5], [0.0, 0.5, 0.0], [-2e-5, 0.0, 1e-3]],
        "temp_range_c": [20.0, 45.0],
        "samples": 36000,
        "updates": 170,
    }
    for key, value in changes.items():
        if key.startswith("params_"):
            if isinstance(data["params"], dict):
                data["params"][key[len("params_"):]] = value
        else:
            data[key] = value
    return data


def write_profile(path: Path, data) -> Path:
    path.write_text(json.dumps(data) if not isinstance(data, str) else data)
    return path


def test_the_valid_example_profile_loads(tmp_path):
    prof = load_profile(write_profile(tmp_path / "p.json", profile_json()))
    assert prof.params == (0.02, 3.0, -0.5) and prof.temp_range_c == (20.0, 45.0)


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"params_c_dps": 1e308}, "c_dps"),
        ({"params_c_dps": -51.0}, "c_dps"),
        ({"params_a_dps_per_c": 2.0}, "a_dps_per_c"),
        ({"params_b_deg": -5000.0}, "b_deg"),
        ({"params_c_dps": True}, "c_dps"),
        ({"params_c_dps": "0.1"}, "c_dps"),
        ({"params_d": 1.0}, "params"),
        ({"cov": [[0.0] * 3] * 3}, "cov"),
        ({"cov": [[1e200, 0, 0], [0, 1, 0], [0, 0, 1]]}, "cov"),
        ({"cov": [[1, 2, 0], [2, 1, 0], [0, 0, 1]]}, "cov"),
        ({"cov": [[1e-6, 0, 0], [0, 0.5, 0], [1e-3, 0, 1e-3]]}, "cov"),
        ({"cov": [[True, 0, 0], [0, 1, 0], [0, 0, 1]]}, "cov"),
        ({"temp_range_c": [50.0, 20.0]}, "temp_range_c"),
        ({"temp_range_c": [-500.0, 20.0]}, "temp_range_c"),
        ({"temp_range_c": [20.0, 30.0, 40.0]}, "temp_range_c"),
        ({"samples": -5}, "samples"),
        ({"samples": True}, "samples"),
        ({"samples": 1.5}, "samples"),
        ({"updates": 10**6}, "updates"),
        ({"estimator": 3}, "estimator"),
        ({"estimator": ""}, "estimator"),
        ({"created": "yesterday"}, "created"),
        ({"software": ["gyrodrift"]}, "software"),
        ({"version": True}, "version"),
        ({"colour": "red"}, "colour"),
    ],
)
def test_absurd_profiles_are_refused_naming_the_field(tmp_path, changes, field):
    path = write_profile(tmp_path / "dev.json", profile_json(**changes))
    with pytest.raises(ConfigError) as info:
        load_profile(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and field in message and "\n" not in message, message


@pytest.mark.parametrize(
    "content",
    ["[" * 100_000 + "]" * 100_000, '{"samples": ' + "9" * 5000 + "}", b"\xff\xfe{\x00}\x00", "", "null"],
)
def test_unreadable_profiles_are_config_errors(tmp_path, content):
    path = tmp_path / "p.json"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    with pytest.raises(ConfigError, match=r"p\.json: "):
        load_profile(path)


def test_cli_refuses_an_absurd_profile_before_running(tmp_path, tiny_log, capsys):
    prof = write_profile(tmp_path / "dev.json", profile_json(params_c_dps=1e308))
    out = tmp_path / "o.csv"
    assert main(["compensate", str(tiny_log), "-o", str(out), "--profile", str(prof), "-q"]) == 2
    one_line_error(capsys.readouterr().err, "dev.json", "c_dps")
    assert not out.exists()


def test_profile_notes_for_another_estimator_or_temperature_range():
    from gyrodrift.profile import profile_notes

    prof = Profile((0.02, 3.0, -0.5), ((1e-6, 0, 0), (0, 0.5, 0), (0, 0, 1e-3)), (20.0, 45.0), 10, 1,
                   "stkf", "2024-05-01T12:00:00+00:00", "gyrodrift 1.0.0")
    assert profile_notes(prof, estimator="stkf", temp_range_c=(21.0, 44.0)) == []
    assert profile_notes(prof, estimator="stkf", temp_range_c=(19.0, 46.5)) == []  # within the margin
    notes = profile_notes(prof, estimator="adaptive")
    assert len(notes) == 1 and "'stkf'" in notes[0] and "'adaptive'" in notes[0]
    notes = profile_notes(prof, estimator="stkf", temp_range_c=(30.0, 60.0))
    assert len(notes) == 1 and "20.0 to 45.0 degC" in notes[0] and "60.0" in notes[0]
    assert profile_notes(prof, temp_range_c=(math.inf, -math.inf)) == []  # no temperature seen


def test_cli_warns_on_another_estimator_and_temperature_range(tmp_path, tiny_log, capsys):
    # tiny_log runs at 25..26.2 degC (synthetic_log); the profile was learned at 0..5 degC by stkf
    prof = write_profile(tmp_path / "dev.json", profile_json(estimator="stkf", temp_range_c=[0.0, 5.0]))
    assert main(["compensate", str(tiny_log), "-o", str(tmp_path / "o.csv"), "--profile", str(prof), "-q"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2 and all(line.startswith("gyrodrift: warning: ") and "dev.json" in line for line in err)
    assert "'stkf'" in err[0] and "'adaptive'" in err[0]
    assert "0.0 to 5.0 degC" in err[1]
    # a matching profile warns of nothing
    ok = write_profile(tmp_path / "ok.json", profile_json(estimator="stkf", temp_range_c=[20.0, 40.0]))
    assert main(["compensate", str(tiny_log), "-o", str(tmp_path / "o.csv"), "--profile", str(ok), "-q",
                 "--estimator", "stkf"]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    "params, cov, field",
    [
        ((0.02, 3.0, math.nan), ((1e-6, 0, 0), (0, 0.5, 0), (0, 0, 1e-3)), "c_dps"),
        ((0.02, 3.0, 0.1), ((0.0, 0, 0), (0, 0.0, 0), (0, 0, 0.0)), "cov"),  # an estimator that learns nothing
    ],
)
def test_save_profile_refuses_what_load_profile_refuses(tmp_path, params, cov, field):
    bad = Profile(params, cov, (20.0, 45.0), 10, 1, "adaptive", "2024-05-01T12:00:00+00:00", "gyrodrift 1.0.0")
    path = tmp_path / "dev.json"
    with pytest.raises(ConfigError, match=f"dev.json: .*{field}.*nothing was saved"):
        save_profile(bad, path)
    assert not path.exists()


# --------------------------------------------------------------------------- temporary files

TMP_NAME = re.compile(r"^\.(?P<name>.+)\.gyrodrift-tmp-(?P<host>[0-9a-f]{8})-(?P<pid>[0-9]+)-[0-9a-f]{12}$")

_HOLDER = """
import sys, time
from gyrodrift._atomic import atomic_output
with atomic_output(sys.argv[1]) as fh:
    fh.write(b"partial")
    fh.flush()
    print("ready", flush=True)
    time.sleep(120)
"""


def _child(code: str, *args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, "-c", code, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env)
    line = proc.stdout.readline()
    if line.strip() != "ready":
        proc.kill()
        raise AssertionError(f"child did not start: {line!r} {proc.stderr.read()}")
    return proc


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_temporary_file_names_the_output_and_the_process(tmp_path):
    from gyrodrift._atomic import atomic_output

    with atomic_output(tmp_path / "out.csv") as fh:
        fh.write(b"x")
        (name,) = _hidden(tmp_path)
    match = TMP_NAME.match(name)
    assert match and match["name"] == "out.csv" and int(match["pid"]) == os.getpid()
    assert _hidden(tmp_path) == [] and (tmp_path / "out.csv").read_bytes() == b"x"


def test_stale_temporary_of_a_killed_run_is_removed_by_the_next_write(tmp_path):
    from gyrodrift._atomic import write_bytes_atomic

    out = tmp_path / "out.csv"
    proc = _child(_HOLDER, str(out))
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    proc.stdout.close()
    proc.stderr.close()
    (stale,) = _hidden(tmp_path)  # SIGKILL cannot be caught: the temporary stays behind ...
    assert int(TMP_NAME.match(stale)["pid"]) == proc.pid and (tmp_path / stale).read_bytes() == b"partial"
    # ... beside one of a live process (this one) and one of another output, both to be kept
    live = re.sub(r"-[0-9]+-([0-9a-f]{12})$", rf"-{os.getpid()}-\1", stale)
    other = stale.replace(".out.csv.", ".other.csv.", 1)
    for name in (live, other):
        (tmp_path / name).write_bytes(b"keep")
    write_bytes_atomic(out, b"whole")  # ... and the next write of the same output removes it
    assert out.read_bytes() == b"whole"
    assert _hidden(tmp_path) == sorted([live, other])


def test_very_long_output_name_still_gets_a_temporary(tmp_path):
    from gyrodrift._atomic import write_bytes_atomic

    out = tmp_path / ("x" * 250 + ".csv")
    write_bytes_atomic(out, b"ok")
    assert out.read_bytes() == b"ok" and _hidden(tmp_path) == []


_BLOCKING_CLI = """
import signal, sys, time
import gyrodrift.io
from gyrodrift._atomic import atomic_output

# a shell starts background jobs with SIGINT ignored, and children inherit that: Python's handler
signal.signal(signal.SIGINT, signal.default_int_handler)
from gyrodrift.cli import main


def blocking_write(df, path, **kwargs):
    with atomic_output(path) as fh:
        fh.write(b"partial")
        fh.flush()
        print("ready", flush=True)
        time.sleep(120)


gyrodrift.io.write_table = blocking_write
sys.exit(main(["simulate", "static", "-o", sys.argv[1], "--duration-s", "60", "--fs-hz", "10"]))
"""


@pytest.mark.parametrize("sig, code, word", [(signal.SIGTERM, 143, "terminated"), (signal.SIGINT, 130, "interrupted")])
def test_sigterm_cleans_up_like_sigint(tmp_path, sig, code, word):
    out = tmp_path / "sim.csv"
    proc = _child(_BLOCKING_CLI, str(out))
    assert len(_hidden(tmp_path)) == 1
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == code, stderr
    assert stderr == f"gyrodrift: {word}\n"
    assert _hidden(tmp_path) == [] and not out.exists()


_BATCH_CLI = """
import sys
from gyrodrift.cli import main

print("ready", flush=True)
sys.exit(main(["batch", sys.argv[1], "-o", sys.argv[2], "--workers", "2"]))
"""


_WORKER = """
import sys, time
from gyrodrift import _pool
from gyrodrift._atomic import atomic_output

def job(path):
    with atomic_output(path) as fh:
        fh.write(b"partial")
        print("ready", flush=True)
        time.sleep(60)

_pool._worker_start()
if sys.argv[1] == "idle":
    print("ready", flush=True)
    time.sleep(60)
else:
    _pool._run(job, sys.argv[1])
print("not stopped", flush=True)
"""


def test_a_worker_stopped_between_jobs_exits_without_a_traceback():
    # SIGTERM while the worker waits for (or unpickles) its next item: status 143 and silence
    proc = _child(_WORKER, "idle")
    proc.send_signal(signal.SIGINT)  # Ctrl-C reaches the whole group: the parent decides, not the worker
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=60)
    assert (proc.returncode, stdout, stderr) == (143, "", "")


def test_a_worker_stopped_in_a_job_removes_its_partial_output_and_takes_no_other(tmp_path):
    proc = _child(_WORKER, str(tmp_path / "out.csv"))
    assert len(_hidden(tmp_path)) == 1
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=60)
    assert (proc.returncode, stdout, stderr) == (143, "", "")
    assert list(tmp_path.iterdir()) == []


def test_sigterm_cancels_the_queued_logs_of_batch(tmp_path):
    import shutil
    import time

    logs = tmp_path / "logs"
    logs.mkdir()
    synthetic_log(duration_s=4 * 3600.0, gyro_noise_dps=0.05).to_csv(logs / "log00.csv", index=False)
    for k in range(1, 16):
        shutil.copy(logs / "log00.csv", logs / f"log{k:02d}.csv")
    out = tmp_path / "out"
    proc = _child(_BATCH_CLI, str(logs / "*.csv"), str(out))
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None and not (
        out.is_dir() and any(not p.name.startswith(".") for p in out.iterdir())
    ):
        time.sleep(0.1)
    assert proc.poll() is None, proc.stderr.read()
    proc.send_signal(signal.SIGTERM)
    sent = time.monotonic()
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143, stderr
    assert time.monotonic() - sent < 15.0  # the queued logs were not run
    assert stderr.endswith("gyrodrift: terminated\n") and "Traceback" not in stderr
    written = [p.name for p in out.iterdir() if not p.name.startswith(".")]
    assert 1 <= len(written) < 12, written
    assert _hidden(out) == []


def test_main_restores_the_sigterm_handler(tmp_path, capsys):
    before = signal.getsignal(signal.SIGTERM)
    main(["simulate", "nope", "-o", str(tmp_path / "x.csv")])
    assert signal.getsignal(signal.SIGTERM) is before


# --------------------------------------------------------------------------- batch summary


def test_batch_summary_cells_cannot_be_spreadsheet_formulas(tmp_path, monkeypatch, capsys):
    from gyrodrift.cli.batch import batch_command
    from test_fleet import _parse

    names = ["=1+2.csv", "+SUM(A1).csv", "-2+3.csv", "@cmd.csv", "plain.csv"]
    for name in names:
        (tmp_path / name).write_bytes(b"\x00\x01 not a log")
    monkeypatch.chdir(tmp_path)
    assert batch_command(_parse(["batch", "*.csv", "-o", "out", "--workers", "2"])) == 1
    capsys.readouterr()
    with open(tmp_path / "out" / "summary.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert sorted(r["file"] for r in rows) == sorted(
        ("'" + n if n[0] in "=+-@" else n) for n in names
    )
    for row in rows:
        for value in row.values():
            assert not value or value[0] not in "=+-@", row
        assert row["error"].startswith("'") == (row["file"] != "plain.csv")


def test_summary_numbers_stay_numbers(tmp_path):
    from gyrodrift.fleet import SUMMARY_COLUMNS, write_summary

    row = {c: -1.5 for c in SUMMARY_COLUMNS}
    row.update(file="=cmd|' /C calc'!A0", status="error", error="-bad: \t@x", rows=3, updates=None)
    df = pd.DataFrame([row], columns=list(SUMMARY_COLUMNS))
    df["rows"] = pd.array([3], dtype="Int64")
    df["updates"] = pd.array([None], dtype="Int64")
    write_summary(df, tmp_path / "summary.csv")
    text = (tmp_path / "summary.csv").read_text(encoding="utf-8")
    back = pd.read_csv(tmp_path / "summary.csv", keep_default_na=False, na_values=[""])
    assert back.loc[0, "file"] == "'=cmd|' /C calc'!A0" and back.loc[0, "error"] == "'-bad: \t@x"
    assert back.loc[0, "a"] == -1.5 and back.loc[0, "rows"] == 3 and ",-1.5," in text
    assert df.loc[0, "file"] == "=cmd|' /C calc'!A0"  # the table itself is left as it was


# --------------------------------------------------------------------------- fuzzing

def _settings_defaults() -> dict:
    """Table name (None: top level) -> the default settings object of that table."""
    from gyrodrift.fusion import FusionConfig

    cfg = CompensatorConfig()
    return {None: cfg, "kalman": cfg.kalman, "gate": cfg.gate, "temp_rate": cfg.temp_rate,
            "adaptive": cfg.adaptive, "fusion": FusionConfig()}


#: Table name (None: top level) -> {setting: default}, the settings the fuzzer sets.
_SETTINGS = {
    table: {f: getattr(obj, f) for f in vars(obj) if table is not None or f not in _settings_defaults()}
    for table, obj in _settings_defaults().items()
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
#: Any TOML-like value: scalars, arrays and inline tables.
_values = st.recursive(
    _scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=5), inner, max_size=3),
    max_leaves=12,
)
#: Numbers of every kind a number setting may meet, in range or not.
_numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.floats(min_value=1e-3, max_value=100.0),
    st.integers(min_value=-3, max_value=100), st.sampled_from([0.0, 1.0, 1e-300, 1e300, -1.0]),
)


def _typed(default):
    """Values of the type of a setting whose default is ``default`` (None: any value)."""
    if isinstance(default, bool):
        return st.booleans()
    if isinstance(default, int):
        return st.integers(min_value=-3, max_value=200) | st.integers(min_value=-(2**65), max_value=2**65)
    if isinstance(default, float):
        return _numbers
    if isinstance(default, str):
        return st.sampled_from(["adaptive", "stkf", "stkf-s1", "kf", "lsm", "fixed", "poly3", "endpoints",
                                "slope"]) | st.text(max_size=8)
    if isinstance(default, tuple) and all(isinstance(v, float) for v in default):
        return st.lists(_numbers, min_size=len(default), max_size=len(default))
    return st.lists(st.lists(_numbers, min_size=3, max_size=3), min_size=3, max_size=3) | _values


@st.composite
def toml_dicts(draw) -> dict:
    """Dicts as tomllib returns them: known keys (and an unknown one now and then), most
    values of the declared type (in range or not), the others any TOML-like value."""

    def table(settings: dict) -> dict:
        keys = draw(st.lists(st.sampled_from(sorted(settings) + ["nope"]), max_size=4, unique=True))
        return {k: draw(_typed(settings.get(k)) if draw(st.integers(0, 9)) < 8 else _values) for k in keys}

    out = table(_SETTINGS[None])
    for name in draw(st.lists(st.sampled_from([t for t in _SETTINGS if t]), max_size=3, unique=True)):
        out[name] = table(_SETTINGS[name]) if draw(st.integers(0, 9)) < 8 else draw(_values)
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
    lines = [f"{k} = {_toml_value(v)}" for k, v in values.items() if not (k in _SETTINGS and isinstance(v, dict))]
    for k, v in values.items():
        if k in _SETTINGS and isinstance(v, dict):
            lines.append(f"[{k}]")
            lines += [f"{json.dumps(kk, ensure_ascii=False)} = {_toml_value(x)}" for kk, x in v.items()]
    return "\n".join(lines) + "\n"


def _kind(err: ConfigError) -> str:
    """The kind of a refusal, for hypothesis' statistics (file, values and numbers left out)."""
    text = str(err).split(": ", 1)[-1]
    for kind in ("not UTF-8", "not valid TOML", "unknown setting", "unknown field", "must be a table", "is refused",
                 "must be a", "outside the plausible", "not positive definite", "not symmetric"):
        if kind in text:
            return f"refused: {kind}"
    return "refused: " + re.sub(r"[0-9][-+0-9.e]*", "N", re.split(r"[;(]", text)[0])[:60]


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
            event(_kind(err))
            return None
    event("accepted")
    _check_config(cfg)
    return cfg


@st.composite
def edited(draw, text: str) -> bytes:
    """``text`` as UTF-8 with a few bytes inserted, replaced or cut (a damaged file)."""
    data = bytearray(text.encode("utf-8"))
    for _ in range(draw(st.integers(0, 3))):
        at = draw(st.integers(0, len(data)))
        how = draw(st.sampled_from(["insert", "replace", "cut"]))
        if how == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=3))
        elif how == "replace" and at < len(data):
            data[at] = draw(st.integers(0, 255))
        else:
            del data[at:at + draw(st.integers(1, 8))]
    return bytes(data)


#: Bytes of every kind: random, UTF-8 text, and damaged settings files.
_config_bytes = st.one_of(
    st.binary(max_size=400),
    st.text(max_size=200).map(lambda t: t.encode("utf-8")),
    toml_dicts().flatmap(lambda values: edited(_toml_text(values))),
)


@FUZZ
@given(_config_bytes)
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
        event(_kind(err))
        return
    event("accepted")
    _check_config(cfg)


_json_scalars = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(2**80), max_value=2**80),
    st.floats(allow_nan=True, allow_infinity=True), st.floats(min_value=-2.0, max_value=2.0), st.text(max_size=10),
)
#: Any JSON value.
_json_values = st.recursive(
    _json_scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=12,
)


@st.composite
def _covariances(draw) -> list:
    """3x3 matrices: ``L L^T`` of a random L (positive semi-definite, of any scale), then
    perhaps one entry changed."""
    scale = draw(st.sampled_from([1e-12, 1e-6, 1e-3, 1.0, 1e3, 1e6]))
    L = np.tril(np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=9, max_size=9))).reshape(3, 3))
    cov = (scale * (L @ L.T)).tolist()
    if draw(st.booleans()):
        cov[draw(st.integers(0, 2))][draw(st.integers(0, 2))] = draw(_numbers)
    return cov


#: Profile field -> values of its JSON type, in range or not (``params_x``: ``params.x``).
_PROFILE_TYPED = {
    "format": st.just("gyrodrift-profile") | st.text(max_size=20),
    "version": st.integers(-1, 3) | st.just(1.0),
    "software": st.text(max_size=30),
    "created": st.datetimes().map(lambda t: t.isoformat()) | st.text(max_size=30),
    "estimator": st.sampled_from(["adaptive", "stkf", "kf", "lsm", "fixed", ""]) | st.text(max_size=12),
    "params": st.dictionaries(st.sampled_from(["a_dps_per_c", "b_deg", "c_dps", "d"]), _numbers, max_size=4),
    "params_a_dps_per_c": _numbers | st.floats(-2.0, 2.0),
    "params_b_deg": _numbers | st.floats(-2000.0, 2000.0),
    "params_c_dps": _numbers | st.floats(-100.0, 100.0),
    "cov": _covariances(),
    "temp_range_c": st.lists(st.floats(-100.0, 200.0) | _numbers, min_size=1, max_size=3),
    "samples": st.integers(-5, 10**7) | st.integers(min_value=-(2**70), max_value=2**70),
    "updates": st.integers(-5, 10**5) | st.integers(min_value=-(2**70), max_value=2**70),
    "extra": _json_values,
}


@st.composite
def profile_dicts(draw) -> dict:
    """The valid example profile with a few fields replaced: most by values of their
    JSON type (in range or not), the others by any JSON value."""
    changes = {}
    for field in draw(st.lists(st.sampled_from(sorted(_PROFILE_TYPED)), max_size=3, unique=True)):
        changes[field] = draw(_PROFILE_TYPED[field] if draw(st.integers(0, 9)) < 8 else _json_values)
    return profile_json(**changes)


def _check_profile_file(path: Path) -> None:
    try:
        prof = load_profile(path)
    except ConfigError as err:
        assert str(err).startswith(str(path)) and "\n" not in str(err), str(err)
        event(_kind(err))
        return
    event("accepted")
    assert isinstance(prof, Profile)
    assert all(math.isfinite(v) for v in prof.params)
    cov = np.array(prof.cov)
    sd = np.sqrt(np.diag(cov))
    assert np.all(np.isfinite(cov)) and np.all(sd > 0)
    assert np.linalg.eigvalsh(0.5 * (cov + cov.T) / np.outer(sd, sd)).min() > 0  # positive definite, scale-free
    warm = warm_config(prof)
    p0 = np.array(warm.kalman.p0_cov)
    assert np.all(np.isfinite(p0)) and np.linalg.eigvalsh(p0).min() > 0
    assert np.all(np.isfinite(warm.kalman.x0))
    from gyrodrift.profile import profile_notes

    assert all(isinstance(n, str) and "\n" not in n
               for n in profile_notes(prof, estimator="adaptive", temp_range_c=(-60.0, 150.0)))


@FUZZ
@given(st.one_of(
    st.binary(max_size=400),
    st.text(max_size=200).map(lambda t: t.encode("utf-8")),
    profile_dicts().flatmap(lambda data: edited(json.dumps(data))),
))
def test_fuzz_profile_loader_bytes(data):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "fuzz.json"
        path.write_bytes(data)
        _check_profile_file(path)


@FUZZ
@given(profile_dicts())
def test_fuzz_profile_loader_json(data):
    with tempfile.TemporaryDirectory() as d:
        path = write_profile(Path(d) / "fuzz.json", data)
        _check_profile_file(path)


def test_a_sigterm_in_a_finalizer_is_delivered_again():
    """A SIGTERM whose Terminated is raised inside a finalizer (where it cannot propagate) is
    not lost: the hook sends SIGTERM again, and the handler then raises it where it can."""
    import gc
    import time

    from gyrodrift.cli.commands import Terminated, _sigterm_interrupts

    class Finalised:
        def __del__(self):
            raise Terminated()

    with pytest.raises(Terminated):
        with _sigterm_interrupts():
            Finalised()
            gc.collect()
            time.sleep(5.0)  # the signal sent again interrupts this


_WORKER_FINALIZER = """
import gc, time
from gyrodrift import _pool

class Finalised:
    def __del__(self):
        raise _pool._Stopped  # as the worker's SIGTERM handler does when it fires in a finalizer

def job(_):
    Finalised()
    gc.collect()
    time.sleep(5.0)  # the signal sent again interrupts this
    print("not stopped", flush=True)

_pool._worker_start()
_pool._run(job, None)
"""


def test_a_workers_sigterm_in_a_finalizer_is_delivered_again_without_a_traceback():
    """A worker's SIGTERM whose exception lands in a finalizer (seen in a batch stopped while a
    worker's weak references were being collected: Python printed its traceback and the worker
    ran on) is sent again: the worker stops as from any SIGTERM in a job, silently, status 143."""
    out = subprocess.run([sys.executable, "-c", _WORKER_FINALIZER], capture_output=True, text=True, timeout=60)
    assert (out.returncode, out.stdout, out.stderr) == (143, "", "")


def test_an_interrupted_batch_removes_what_its_stopped_workers_left(tmp_path, monkeypatch):
    """A worker stopped before it could remove its temporary leaves it behind (its process then
    gone); the interrupted batch removes it before it stops. Other hidden files stay."""
    from gyrodrift import _atomic, fleet

    logs = tmp_path / "logs"
    logs.mkdir()
    synthetic_log(duration_s=60.0).to_csv(logs / "log00.csv", index=False)
    out = tmp_path / "out"
    out.mkdir()
    probe = subprocess.Popen([sys.executable, "-c", "pass"])  # a stopped worker: its process is gone
    probe.wait()
    left = out / f"{_atomic._prefix(fleet.output_path(logs / 'log00.csv', out))}{probe.pid}-{'a' * 12}"
    other = out / ".keep"
    other.write_bytes(b"")

    def stopped(*args, **kwargs):
        left.write_bytes(b"partial")
        raise KeyboardInterrupt

    monkeypatch.setattr(fleet, "map_jobs", stopped)
    with pytest.raises(KeyboardInterrupt):
        fleet.process_many([logs / "log00.csv"], out, workers=2)
    assert not left.exists() and other.exists()
