import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift.cli import main
from gyrodrift.cli.commands import demo_log_path


def run_module(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "gyrodrift", *args], capture_output=True, text=True, cwd=cwd)


@pytest.fixture
def small_log(tmp_path):
    path = tmp_path / "log.csv"
    synthetic_log(duration_s=200.0, gyro_noise_dps=0.05, compass_noise_deg=0.5).to_csv(path, index=False)
    return path


def test_help_explains_units_and_conventions():
    res = run_module("compensate", "--help")
    assert res.returncode == 0
    for word in ("deg/s", "degC", "clockwise", "NED", "rad/s", "enu", "gate_reason"):
        assert word in res.stdout


def test_compensate_csv_and_parquet(small_log, tmp_path, capsys):
    out_csv = tmp_path / "out.csv"
    out_pq = tmp_path / "out.parquet"
    before = small_log.read_bytes()
    assert main(["compensate", str(small_log), "-o", str(out_csv)]) == 0
    assert main(["compensate", str(small_log), "-o", str(out_pq), "-q"]) == 0
    assert small_log.read_bytes() == before  # input untouched
    a, b = pd.read_csv(out_csv, keep_default_na=False, na_values=[""]), pd.read_parquet(out_pq)
    np.testing.assert_array_equal(a["heading"], b["heading"])
    printed = capsys.readouterr().out
    assert "filter updates" in printed and "heading error vs ref_heading" in printed


def test_gyro_unit_and_frame_options(tmp_path):
    log = synthetic_log(duration_s=120.0, compass_noise_deg=0.3)
    ned = tmp_path / "ned.csv"
    enu = tmp_path / "enu_rad.csv"
    log.to_csv(ned, index=False)
    conv = log.copy()
    conv["gyro_z"] = -np.radians(log["gyro_z"])
    conv["heading"] = np.mod(90.0 - log["heading"], 360.0)
    conv["true_bias_z"] = -np.radians(log["true_bias_z"])
    conv["ref_heading"] = np.mod(90.0 - log["ref_heading"], 360.0)
    conv = conv.rename(columns={"gyro_z": "gz"})
    conv.to_csv(enu, index=False)
    assert main(["compensate", str(ned), "-o", str(tmp_path / "a.csv"), "-q"]) == 0
    assert main(["compensate", str(enu), "-o", str(tmp_path / "b.csv"), "-q",
                 "--gyro-unit", "rad/s", "--frame", "enu", "--map", "gyro_z=gz"]) == 0
    a = pd.read_csv(tmp_path / "a.csv")
    b = pd.read_csv(tmp_path / "b.csv")
    np.testing.assert_allclose(a["bias_z"], b["bias_z"], atol=1e-9)
    np.testing.assert_allclose(np.unwrap(np.radians(a["heading"])), np.unwrap(np.radians(b["heading"])), atol=1e-9)


@pytest.mark.parametrize(
    "make, args, fragment",
    [
        (None, ["compensate", "{d}/missing.csv", "-o", "{d}/o.csv"], "missing.csv"),
        ("log", ["compensate", "{d}/log.csv", "-o", "{d}/log.csv"], "input is never overwritten"),
        ("log", ["compensate", "{d}/log.csv", "-o", "{d}/o.csv", "--gyro-unit", "furlongs"], "furlongs"),
        ("log", ["compensate", "{d}/log.csv", "-o", "{d}/o.xlsx"], ".xlsx"),
        ("log", ["compensate", "{d}/log.csv", "-o", "{d}/nodir/o.csv"], "nodir"),
        ("log", ["compensate", "{d}/log.csv", "-o", "{d}/o.csv", "--fading", "0.5"], "fading"),
        ("log", ["compensate", "{d}/log.csv", "-o", "{d}/o.csv", "--map", "oops"], "--map"),
    ],
)
def test_bad_input_gives_one_line_and_exit_2(tmp_path, make, args, fragment):
    if make == "log":
        synthetic_log(duration_s=100.0).to_csv(tmp_path / "log.csv", index=False)
    before = (tmp_path / "log.csv").read_bytes() if make else None
    res = run_module(*[a.format(d=tmp_path) for a in args])
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gyrodrift: error:")
    assert fragment in lines[0]
    if make:
        assert (tmp_path / "log.csv").read_bytes() == before
    assert not (tmp_path / "o.csv").exists()


BAD_FILES = {
    "zero_byte": (b"", "empty"),
    "header_only": (b"t,gyro_z,temp,heading\n", "no data"),
    "ragged": (b"t,gyro_z,temp,heading\n0,0.1,30,10\n0.1,0.1,30\n", "line 3"),
    "non_numeric": (b"t,gyro_z,temp,heading\n0,0.1,30,10\n0.1,abc,30,10\n", "gyro_z"),
    "backwards": (b"t,gyro_z,temp,heading\n0,0.1,30,10\n0.2,0.1,30,10\n0.1,0.1,30,10\n", "line 4"),
    "duplicate": (b"t,gyro_z,temp,heading\n0,0.1,30,10\n0,0.1,30,10\n", "line 3"),
    "kelvin": (b"t,gyro_z,temp,heading\n0,0.1,303.15,10\n0.1,0.1,303.15,10\n", "temp"),
    "no_gyro": (b"t,gz,temp,heading\n0,0.1,30,10\n", "gyro_z"),
    "binary": (bytes(range(256)) * 4, "log.csv"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_bad_file_contents_give_one_line_and_exit_2(tmp_path, case):
    content, fragment = BAD_FILES[case]
    path = tmp_path / "log.csv"
    path.write_bytes(content)
    res = run_module("compensate", str(path), "-o", str(tmp_path / "o.csv"))
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.stderr
    assert "log.csv" in lines[0] and fragment in lines[0], lines[0]
    assert path.read_bytes() == content
    assert not (tmp_path / "o.csv").exists()


def test_demo_runs_on_the_built_in_log(tmp_path):
    assert demo_log_path().is_file()
    res = run_module("demo", "-o", str(tmp_path / "demo.csv"))
    assert res.returncode == 0, res.stderr
    assert "filter updates" in res.stdout and "drift error RMS" in res.stdout
    out = pd.read_csv(tmp_path / "demo.csv", dtype={"gate_reason": str, "unobservable": str})
    assert {"interference", "init"} <= set(out["gate_reason"].dropna())


def test_compensate_a_ros_bag_end_to_end(tmp_path):
    """A ROS 2 bag (ENU/FLU, rad/s, tesla) turning counter-clockwise at 10 deg/s: the
    command reads it and the compensated heading decreases at 10 deg/s (NED) once its first
    seconds have told the turn from a drift (in the first second, a still unit's drift of
    -10 deg/s is as likely)."""
    pytest.importorskip("rosbags", reason="rosbags is a test extra")
    from test_readers import _write_bag

    bag = _write_bag(tmp_path / "bag", "ros2", duration_s=60.0)
    out_path = tmp_path / "out.csv"
    assert main(["compensate", str(bag), "-o", str(out_path), "-q", "--imu-topic", "/imu/data"]) == 0
    out = pd.read_csv(out_path, dtype={"gate_reason": str})
    late = out[out["t"] >= out["t"].iloc[0] + 5.0]
    turned = np.sum(np.diff(np.unwrap(np.radians(late["heading"])))) * 180 / np.pi
    assert turned == pytest.approx(-10.0 * (late["t"].iloc[-1] - late["t"].iloc[0]), rel=0.01)
    assert main(["compensate", str(bag), "-o", str(out_path), "-q", "--gyro-unit", "rad/s"]) == 2


def test_a_ulog_shorter_than_the_init_window_is_compensated_with_a_note(shared_data, tmp_path, capsys):
    log = shared_data / "px4" / "sample_log_small.ulg"
    assert main(["compensate", str(log), "-o", str(tmp_path / "o.csv")]) == 0
    printed = capsys.readouterr().out
    assert "note: " in printed and "shorter than the 30-s init window" in printed
    out = pd.read_csv(tmp_path / "o.csv")
    assert len(out) > 1000 and out["rate_z"].notna().all()


def test_progress_bar_only_on_a_terminal():
    import io

    from gyrodrift._progress import progress_iter

    class Tty(io.StringIO):
        def isatty(self):
            return True

    pipe, tty = io.StringIO(), Tty()
    assert list(progress_iter(range(5), 5, "x", stream=pipe)) == list(range(5))
    assert pipe.getvalue() == ""
    assert list(progress_iter(range(5), 5, "x", stream=tty)) == list(range(5))
    drawn = tty.getvalue()  # tqdm's bar (cleared at the end) or the built-in one
    assert drawn.startswith("\rx") and "/5" in drawn


def test_out_of_memory_is_one_clear_line(small_log, tmp_path, monkeypatch, capsys):
    import gyrodrift.pipeline

    def exhausted(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(gyrodrift.pipeline, "compensate_file", exhausted)
    assert main(["compensate", str(small_log), "-o", str(tmp_path / "out.csv")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("gyrodrift: error: compensate: out of memory") and "Traceback" not in err
    assert "stream in constant memory" in err and len(err.strip().splitlines()) == 1


def test_bad_settings_or_profile_file_is_one_line_from_the_real_command(small_log, tmp_path):
    """Through ``python -m gyrodrift``: a non-UTF-8 --config and an absurd --profile each
    give exit 2 and one stderr line naming the file, no traceback."""
    cfg = tmp_path / "latin1.toml"
    cfg.write_bytes("init_s = 20.0  # r\u00e9glage\n".encode("latin-1"))
    res = run_module("compensate", str(small_log), "-o", str(tmp_path / "o.csv"), "--config", str(cfg))
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "Traceback" not in res.stderr
    assert "latin1.toml" in res.stderr and "UTF-8" in res.stderr
    prof = tmp_path / "dev.json"
    prof.write_text(
        '{"format": "gyrodrift-profile", "version": 1, "software": "gyrodrift 1.0.0", '
        '"created": "2024-05-01T12:00:00+00:00", "estimator": "adaptive", '
        '"params": {"a_dps_per_c": 0.02, "b_deg": 3.0, "c_dps": 1e308}, '
        '"cov": [[1e-6, 0, 0], [0, 0.5, 0], [0, 0, 1e-3]], "temp_range_c": [20.0, 45.0], '
        '"samples": 100, "updates": 3}'
    )
    res = run_module("compensate", str(small_log), "-o", str(tmp_path / "o.csv"), "--profile", str(prof))
    assert res.returncode == 2 and res.stderr.count("\n") == 1 and "Traceback" not in res.stderr
    assert "dev.json" in res.stderr and "c_dps" in res.stderr
    assert not (tmp_path / "o.csv").exists()


def test_the_user_is_told_when_numba_compiles(capsys):
    """A command that compiles a kernel missing from numba's cache pauses: one line on stderr
    says so, terminal or not, once however many functions compile; nothing when all come
    from the cache."""
    import numba
    from numba.core import event

    from gyrodrift import kernels
    from gyrodrift.kernels import numeric

    numeric.wrap360(370.0)  # compiled (or loaded from the cache) before the listener
    for _ in range(2):  # armed again by each command of a process: one listener, one line per command
        listener = kernels.say_when_compiling()
        try:
            assert numeric.wrap360(-10.0) == 350.0
            assert capsys.readouterr().err == ""
            numba.njit(lambda x: x + 1)(1)
            numba.njit(lambda x: x + 2)(1.0)
        finally:
            listener.armed = False
        err = capsys.readouterr().err
        assert err.count("compiling the engine") == 1 and err.count("\n") == 1, err
    assert len([x for x in event._registered["numba:compile"] if x is listener]) == 1


def test_a_log_without_compass_is_compensated_with_notes(tmp_path):
    """No compass column: a relative heading and stillness learning, said in note lines (exit 0)."""
    log = synthetic_log(duration_s=60.0).drop(columns="heading")
    log.to_csv(tmp_path / "log.csv", index=False)
    res = run_module("compensate", str(tmp_path / "log.csv"), "-o", str(tmp_path / "o.csv"))
    assert res.returncode == 0, res.stderr
    notes = [line for line in res.stdout.splitlines() if line.startswith("note: ")]
    assert any("no compass" in n for n in notes) and any("heading starts at 0 deg" in n for n in notes)
