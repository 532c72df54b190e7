"""Streaming refuses what files refuse (issue 24, item 6), and stops after every row before a bad line.

One parametrised test runs every file-side refusal case through the file reader
(``read_log``, as ``compensate`` reads), through ``stream_rows`` and, where the case is
about values and the sample rate rather than text and units, through ``Compensator.push``:
all refuse it, naming the same column. ``Compensator.push`` and ``compensate_arrays``,
both of which take seconds, judge the time base alike. The time base of a stream is judged on its first
samples (:class:`gyrodrift.io.timebase.TimeBaseWatch`), a file's on all of them.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_log
from gyrodrift import Compensator
from gyrodrift.cli import main
from gyrodrift.errors import GyroDriftError, LogFormatError
from gyrodrift.io import read_log
from gyrodrift.stream import stream_rows

N = 60  #: rows of each case


def _base(n: int = N, fs_hz: float = 10.0) -> pd.DataFrame:
    log = synthetic_log(duration_s=n / fs_hz, fs_hz=fs_hz)[["t", "gyro_z", "temp", "heading"]]
    return log.iloc[:n].reset_index(drop=True)


def _times(values) -> pd.DataFrame:
    log = _base(len(values))
    log["t"] = values
    return log


def _cell(column: str, value, row: int = 30) -> pd.DataFrame:
    log = _base()
    log[column] = log[column].astype(object)
    log.loc[row, column] = value
    return log


#: (case, log, column named, push applies): every one is refused by the file reader. The
#: time-unit guesses of text without a stated unit (epoch or whole-number milliseconds)
#: do not apply to push, which takes seconds as compensate_arrays does (a test below).
CASES = {
    "integer ms": (lambda: _times(np.arange(N) * 10), "t", False),
    "integer us": (lambda: _times(np.arange(N) * 10_000), "t", False),
    "epoch ms": (lambda: _times(1_700_000_000_000 + np.arange(N) * 100), "t", False),
    "epoch ns": (lambda: _times(1_700_000_000_000_000_000 + np.arange(N) * 10_000_000), "t", False),
    "1 MHz": (lambda: _times(np.arange(N) * 1e-6), "t", True),
    "short integer ms": (lambda: _times(np.arange(5) * 10), "t", False),
    "temperature 200 degC": (lambda: _cell("temp", 200.0), "temp", True),
    "gyro 1e6 deg/s": (lambda: _cell("gyro_z", 1e6), "gyro_z", True),
    "heading 1e7 deg": (lambda: _cell("heading", 1e7), "heading", True),
    "time not increasing": (lambda: _cell("t", 1.0), "t", True),
    "infinite gyro": (lambda: _cell("gyro_z", "inf"), "gyro_z", True),
    "text in gyro_z": (lambda: _cell("gyro_z", "abc"), "gyro_z", False),
    "empty time cell": (lambda: _cell("t", ""), "t", False),
    "no gyro_z column": (lambda: _base().drop(columns=["gyro_z"]), "gyro_z", False),
}


def _stream(text: str, **kwargs) -> list[str]:
    out: list[str] = []
    stream_rows([text], out.append, **kwargs)
    return out


def _push_all(log: pd.DataFrame) -> None:
    comp = Compensator()
    for r in log.itertuples(index=False):
        comp.push(float(r.t), float(r.gyro_z), float(r.temp), heading_deg=float(r.heading))
    comp.flush()


@pytest.mark.parametrize("case", list(CASES))
def test_stream_and_push_refuse_what_the_file_reader_refuses(tmp_path, case):
    make, column, push = CASES[case]
    log = make()
    path = tmp_path / "log.csv"
    log.to_csv(path, index=False)
    with pytest.raises(LogFormatError) as file_err:
        read_log(path)
    assert f"'{column}'" in str(file_err.value) or column in str(file_err.value)
    with pytest.raises(LogFormatError) as stream_err:
        _stream(path.read_text())
    assert f"'{column}'" in str(stream_err.value) or column in str(stream_err.value), str(stream_err.value)
    if push:
        with pytest.raises(GyroDriftError):
            _push_all(log.astype(float))


@pytest.mark.parametrize("time_unit, values", [("ms", np.arange(N) * 10), ("s", np.arange(N) * 10)])
def test_a_time_unit_given_is_taken_alike(tmp_path, time_unit, values):
    log = _times(values)
    path = tmp_path / "log.csv"
    log.to_csv(path, index=False)
    assert len(read_log(path, time_unit=time_unit)) == N
    assert sum(line.count("\n") for line in _stream(path.read_text(), time_unit=time_unit)) == N + 1
    comp = Compensator(time_unit=time_unit)
    rows = [r for v in values for r in comp.push(float(v), 0.1, 25.0, heading_deg=10.0)]
    assert len(rows) == N


def test_a_low_rate_is_a_note_in_both(tmp_path):
    log = _times(np.arange(N) * 2.5)
    path = tmp_path / "log.csv"
    log.to_csv(path, index=False)
    assert any("below 1 Hz" in n for n in read_log(path).attrs["notes"])
    warnings: list[str] = []
    stats = stream_rows([path.read_text()], lambda text: None, warn=warnings.append)
    assert any("below 1 Hz" in n for n in stats.notes) and any("below 1 Hz" in w for w in warnings)


# --------------------------------------------------------------------------- a bad line


@pytest.fixture(scope="module")
def bad_at_1002(tmp_path_factory) -> Path:
    """1000 good data lines, a bad one (line 1002), then more."""
    log = synthetic_log(duration_s=120.0, fs_hz=10.0)
    path = tmp_path_factory.mktemp("bad") / "bad.csv"
    lines = log.to_csv(index=False).splitlines()
    cells = lines[1001].split(",")
    cells[1] = "abc"
    lines[1001] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_bad_line_stops_after_every_row_before_it_on_stdout(bad_at_1002):
    res = subprocess.run([sys.executable, "-m", "gyrodrift", "stream", str(bad_at_1002)], capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 2 and "line 1002, column 'gyro_z'" in res.stderr
    assert res.stdout.count("\n") == 1 + 1000


@pytest.mark.parametrize("hold", [[], ["--hold-init"]])
def test_a_bad_line_stops_after_every_row_before_it_in_a_file(bad_at_1002, tmp_path, capsys, hold):
    out = tmp_path / "out.csv"
    assert main(["stream", str(bad_at_1002), "-o", str(out), "-q", *hold]) == 2
    assert "line 1002" in capsys.readouterr().err
    assert len(pd.read_csv(out)) == 1000


def test_a_ragged_line_in_a_block_keeps_the_lines_before_it():
    text = synthetic_log(duration_s=10.0, fs_hz=10.0).to_csv(index=False) + "1,2\n"
    out: list[str] = []
    with pytest.raises(LogFormatError, match="line 102"):
        stream_rows([text], out.append)
    assert "".join(out).count("\n") == 1 + 100


def test_a_line_without_end_is_refused_in_bounded_memory():
    from gyrodrift.stream import MAX_LINE_CHARS

    def pieces():
        yield "t,gyro_z,temp\n0,0.1,25\n"
        chunk = "x" * (1 << 16)
        for _ in range(MAX_LINE_CHARS // len(chunk) + 2):
            yield chunk

    with pytest.raises(LogFormatError, match="line 3: longer than"):
        stream_rows(pieces(), lambda text: None)


def test_the_push_time_base_refusal_keeps_the_compensator_as_it_was():
    comp = Compensator()
    rows = []
    for i in range(8):
        rows += comp.push(i * 1e-6, 0.1, 25.0)
    with pytest.raises(GyroDriftError, match="above 100 kHz"):
        comp.push(8e-6, 0.1, 25.0)
    assert len(rows) == 8 and math.isfinite(rows[-1].rate_z)


def test_a_bad_header_makes_no_output_file(tmp_path, capsys):
    path = tmp_path / "in.csv"
    path.write_text("a,b\n1,2\n")
    assert main(["stream", str(path), "-o", str(tmp_path / "out.csv")]) == 2
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.parametrize("values", [np.arange(N) * 10.0, 1.7e12 + np.arange(N) * 0.1, np.arange(N) * 1e-6,
                                    np.arange(5) * 1e-6])
def test_push_and_compensate_arrays_judge_times_in_seconds_alike(values):
    from gyrodrift import compensate_arrays

    n = len(values)
    try:
        compensate_arrays(values, np.full(n, 0.1), np.full(n, 25.0), heading_deg=np.full(n, 10.0))
        batch = None
    except GyroDriftError as err:
        batch = err
    try:
        comp = Compensator()
        for v in values:
            comp.push(float(v), 0.1, 25.0, heading_deg=10.0)
        comp.flush()
        pushed = None
    except GyroDriftError as err:
        pushed = err
    assert (batch is None) == (pushed is None), (batch, pushed)
    if batch is not None:
        assert "100 kHz" in str(batch) and "100 kHz" in str(pushed)
