"""``gyrodrift stream`` and :func:`gyrodrift.stream.stream_rows`: lines in, the rows of
``gyrodrift compensate`` out, as the streaming Compensator returns them."""

import io
import json
import math
import signal
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from gyrodrift import compensate
from gyrodrift.cli import main
from gyrodrift.errors import LogFormatError
from gyrodrift.io import read_log
from gyrodrift.profile import load_profile
from gyrodrift.simulate import simulate
from gyrodrift.stream import stream_rows

FS_HZ = 10.0
#: The stream's rows of the 30-s init window (t < 30 s; the row at 30 s closes it) are
#: provisional, compensated before the window has taught anything; the rows from there
#: on are compared with ``compensate``.
FIRST_COMPARED_ROW = int(30.0 * FS_HZ)


@pytest.fixture(scope="module")
def log_csv(tmp_path_factory):
    """A simulated vehicle run, 300 s at 10 Hz (init window and filter updates) with a 5-Hz
    compass (empty heading cells), as a CSV file."""
    log = simulate("vehicle", seed=1, duration_s=300.0, fs_hz=FS_HZ)
    log.attrs = {}
    log.loc[1::2, "heading"] = np.nan
    path = tmp_path_factory.mktemp("stream") / "log.csv"
    log.to_csv(path, index=False)
    return path


@pytest.fixture(scope="module")
def reference(log_csv):
    """What ``gyrodrift compensate`` gives on the same rows."""
    return compensate(read_log(log_csv))


def read_output(text: str) -> pd.DataFrame:
    return pd.read_csv(io.StringIO(text), keep_default_na=False, na_values=[""])


def assert_same_rows(got: pd.DataFrame, ref: pd.DataFrame, first_row: int = FIRST_COMPARED_ROW) -> None:
    """Every column both have: numbers equal to 1e-9, text equal (empty = empty); rows from ``first_row``."""
    assert len(got) == len(ref)
    shared = [c for c in ref.columns if c in got.columns]
    assert len(shared) >= 15, shared
    if "gate_reason" in got.columns and first_row:
        assert (got["gate_reason"].iloc[:first_row] == "init").all()  # provisional rows say so
    got, ref = got.iloc[first_row:], ref.iloc[first_row:]
    for col in shared:
        a, b = got[col], ref[col]
        if pd.api.types.is_numeric_dtype(a) and pd.api.types.is_numeric_dtype(b):
            np.testing.assert_allclose(a.to_numpy(float), b.to_numpy(float), rtol=0, atol=1e-9, equal_nan=True,
                                       err_msg=col)
        else:
            assert a.astype(object).fillna("").astype(str).tolist() == b.astype(object).fillna("").astype(str).tolist(), col


def run_stream(*args, input_text: str):
    return subprocess.run([sys.executable, "-m", "gyrodrift", "stream", *args], input=input_text,
                          capture_output=True, text=True, timeout=120)


def stream_text(lines, **kwargs) -> str:
    out = []
    stream_rows(lines, out.append, **kwargs)
    return "".join(out)


def jsonl(log: pd.DataFrame, drop_nan_after_first: bool = False) -> str:
    """The log as JSON lines (NaN: null; or, after the first line, the key left out)."""
    lines = []
    for i, row in enumerate(log.to_dict(orient="records")):
        if drop_nan_after_first and i:
            row = {k: v for k, v in row.items() if not (isinstance(v, float) and math.isnan(v))}
        else:
            row = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in row.items()}
        lines.append(json.dumps(row) + "\n")
    return "".join(lines)


def test_stdin_to_stdout_equals_compensate(log_csv, reference):
    res = run_stream("-q", input_text=log_csv.read_text())
    assert res.returncode == 0, res.stderr
    got = read_output(res.stdout)
    assert list(got.columns) == list(reference.columns)
    assert reference["updated"].sum() >= 5  # the filter learned during the run
    assert_same_rows(got, reference)
    assert "Traceback" not in res.stderr


def test_hold_init_gives_every_row_of_compensate(log_csv, reference):
    res = run_stream("-q", "--hold-init", input_text=log_csv.read_text())
    assert res.returncode == 0, res.stderr
    got = read_output(res.stdout)
    assert_same_rows(got, reference, first_row=0)


def test_lines_one_by_one_give_what_blocks_give(log_csv):
    """Each line pushed and written on its own (a live source) and the file in big reads agree."""
    text = log_csv.read_text()
    lines = text.splitlines(keepends=True)[:400]  # header + 39.9 s: the init window and some rows after it
    out = []
    stream_rows(lines, out.append)
    # the header, then one row per line (the init window's provisional)
    assert sum(w.count("\n") for w in out) == len(lines)
    assert all(w.count("\n") == 1 for w in out[2:]) and len(out) > 50
    assert "".join(out) == stream_text(["".join(lines)])


def test_json_lines_give_the_numbers_of_csv(log_csv):
    log = pd.read_csv(log_csv)
    csv_out = stream_text([log_csv.read_text()])
    assert log["heading"].isna().any()  # samples without compass: null, or the key left out
    for drop in (False, True):
        text = jsonl(log, drop_nan_after_first=drop)
        assert stream_text([text], out_format="csv") == csv_out
    got = pd.DataFrame([json.loads(line) for line in stream_text([jsonl(log)]).splitlines()])
    assert_same_rows(got, read_output(csv_out))


def test_a_key_missing_from_the_first_object_is_a_bad_line(log_csv):
    log = pd.read_csv(log_csv)
    lines = jsonl(log.drop(columns=["ref_heading"])).splitlines(keepends=True)
    lines[5] = lines[5].replace('"t":', '"ref_heading": 1.0, "t":')
    with pytest.raises(LogFormatError, match=r"line 6, column 'ref_heading': key 'ref_heading' is not a key"):
        stream_text(lines)


def test_a_bad_line_stops_with_exit_2_naming_line_and_column(log_csv):
    lines = log_csv.read_text().splitlines(keepends=True)[:50]
    lines[20] = lines[20].split(",", 1)[0] + ",abc," + lines[20].split(",", 2)[2]  # gyro_z of line 21
    res = run_stream(input_text="".join(lines))
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [
        "gyrodrift: error: stdin: line 21, column 'gyro_z': 'abc' is not a number; column 'gyro_z' must hold "
        "numbers only: fix the value or leave the cell empty"
    ]
    assert "Traceback" not in res.stderr


def test_skip_bad_skips_the_line_with_a_warning(log_csv):
    lines = log_csv.read_text().splitlines(keepends=True)[:50]
    lines[20] = "1,2\n"  # too few cells
    lines[30] = lines[30].replace(lines[30].split(",", 1)[0], "0.0", 1)  # time goes back
    warnings = []
    text = stream_text(["".join(lines)], skip_bad=True, warn=warnings.append)
    assert len(read_output(text)) == 49 - 2  # a log shorter than the init window: flushed at the end
    assert warnings[0].startswith("stdin: line 21: row has 2 field(s) but the header has 6")
    assert warnings[1].startswith("stdin: line 31, column 't': time is not strictly increasing")
    assert all(w.endswith("; line skipped") for w in warnings[:2])


def test_sigterm_mid_stream_flushes_and_saves_the_profile(log_csv, tmp_path):
    profile_path = tmp_path / "dev.json"
    lines = log_csv.read_text().splitlines(keepends=True)
    n_in = 400  # past the 30-s init window: its rows came out, then one per line
    proc = subprocess.Popen([sys.executable, "-m", "gyrodrift", "stream", "-q", "--save-profile", str(profile_path)],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        proc.stdin.write("".join(lines[: 1 + n_in]))
        proc.stdin.flush()  # stdin stays open: the command waits for more samples
        out = [proc.stdout.readline() for _ in range(1 + n_in)]  # the header and a row per sample
        assert out[-1].endswith("\n")
        proc.send_signal(signal.SIGTERM)
        rest, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 143, err
    assert rest == "" and "terminated" in err and "Traceback" not in err
    profile = load_profile(profile_path)
    assert profile.samples == n_in
    assert profile.updates == read_output("".join(out))["updated"].sum() > 0


def test_sigint_during_the_init_window_writes_the_held_rows(log_csv, tmp_path):
    """Interrupted before the init window ends: the rows it holds come out (flush), exit 130."""
    lines = log_csv.read_text().splitlines(keepends=True)
    proc = subprocess.Popen([sys.executable, "-m", "gyrodrift", "stream", "-q"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        proc.stdin.write("".join(lines[:101]))
        proc.stdin.flush()
        header = proc.stdout.readline()  # written once the header line is read
        assert header.startswith("t,rate_z,")
        proc.send_signal(signal.SIGINT)
        rest, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130, err
    rows = read_output(header + rest)
    assert 1 <= len(rows) <= 100  # the samples read before the signal
    np.testing.assert_array_equal(rows["t"], pd.read_csv(log_csv)["t"][: len(rows)])


def test_unit_frame_and_map_options_are_applied(log_csv, tmp_path):
    log = pd.read_csv(log_csv)
    plain = tmp_path / "plain.csv"
    assert main(["stream", str(log_csv), "-o", str(plain), "-q"]) == 0
    ros = log.rename(columns={"gyro_z": "gz"})
    ros["gz"] = -np.radians(log["gyro_z"])  # rad/s, FLU body axes (z up)
    ros["heading"] = np.mod(90.0 - log["heading"], 360.0)  # ENU yaw
    ros["ref_heading"] = np.mod(90.0 - log["ref_heading"], 360.0)
    ros["true_bias_z"] = -np.radians(log["true_bias_z"])
    ros_in, ros_out = tmp_path / "ros.csv", tmp_path / "ros_out.csv"
    ros.to_csv(ros_in, index=False)
    args = ["stream", str(ros_in), "-o", str(ros_out), "-q", "--gyro-unit", "rad/s", "--frame", "enu", "--map",
            "gyro_z=gz"]
    assert main(args) == 0
    want, got = pd.read_csv(plain), pd.read_csv(ros_out)
    assert list(got.columns) == list(want.columns)
    for col in ("rate_z", "bias_z", "heading", "c", "gyro_z", "true_bias_z", "heading_fused"):
        np.testing.assert_allclose(got[col], want[col], rtol=0, atol=1e-9, err_msg=col)
    assert main(args[:-2]) == 2  # without --map: no gyro_z column, one error line


def test_serial_without_pyserial_names_the_extra(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "serial", None)  # import serial raises ImportError
    assert main(["stream", "--serial", "/dev/ttyUSB0", "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'gyrodrift[serial]'" in err
