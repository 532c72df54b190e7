"""Tests of gyrodrift.io: reading input logs, writing tables, output-path checks."""

from __future__ import annotations

import gzip
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import SHARED_DATA
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io import check_output_path, read_log, write_table
from gyrodrift.io import tabular
from gyrodrift.io.notes import add_note, no_temperature_note

DATA = SHARED_DATA
MPU = DATA / "mpu6050_rotate_z"
ACTI = DATA / "actigraph_gt9x_cooling"

GOOD = (
    "t,gyro_z,temp,heading\n"
    "0.0,0.1,25.0,10\n"
    "0.1,0.2,25.1,\n"
    "0.2,0.3,25.2,20\n"
)


def _write(tmp_path: Path, text: str | bytes, name: str = "log.csv") -> Path:
    path = tmp_path / name
    if isinstance(text, str):
        text = text.encode("utf-8")
    path.write_bytes(text)
    return path


def _raises(exc_type, func, *args, **kwargs) -> str:
    """Call ``func``, expect ``exc_type`` with a one-line message, return the message."""
    with pytest.raises(exc_type) as info:
        func(*args, **kwargs)
    msg = str(info.value)
    assert "\n" not in msg and "\r" not in msg, msg
    assert msg.strip(), "empty message"
    return msg


# ---------------------------------------------------------------------------
# good input
# ---------------------------------------------------------------------------


def test_read_good_csv(tmp_path):
    path = _write(tmp_path, GOOD)
    df = read_log(path)
    assert list(df.columns) == ["t", "gyro_z", "temp", "heading"]
    assert all(df[c].dtype == np.float64 for c in df.columns)
    np.testing.assert_array_equal(df["t"], [0.0, 0.1, 0.2])
    assert np.isnan(df["heading"].iloc[1])
    assert df.attrs == {
        "source": str(path),
        "format": "csv",
        "gyro_unit": "deg/s",
        "frame": "ned",
        "compass": "heading",
    }


def test_passthrough_columns_kept(tmp_path):
    text = "note,t,gyro_z,temp,heading,count\nA,0,1,20,5,1\nB,1,2,21,6,2\n"
    df = read_log(_write(tmp_path, text))
    assert list(df.columns) == ["note", "t", "gyro_z", "temp", "heading", "count"]
    assert df["note"].tolist() == ["A", "B"]
    assert df["count"].tolist() == [1, 2]


def test_heading_wrapped_to_0_360(tmp_path):
    text = "t,gyro_z,temp,heading,ref_heading\n0,0,20,370,-90\n1,0,20,-10,720\n2,0,20,360,359.5\n"
    df = read_log(_write(tmp_path, text))
    np.testing.assert_allclose(df["heading"], [10.0, 350.0, 0.0])
    np.testing.assert_allclose(df["ref_heading"], [270.0, 0.0, 359.5])


def test_gap_in_gyro_and_temp_allowed(tmp_path):
    text = "t,gyro_z,temp,heading\n0,1,20,5\n1,,,\n2,3,22,\n"
    df = read_log(_write(tmp_path, text))
    assert np.isnan(df["gyro_z"].iloc[1]) and np.isnan(df["temp"].iloc[1])
    assert df["gyro_z"].iloc[2] == 3.0


def test_mag_form_and_both(tmp_path):
    mag = "mag_x,mag_y,mag_z,acc_x,acc_y,acc_z"
    text = f"t,gyro_z,temp,{mag}\n0,0,20,1,2,3,0,0,-1\n1,0,20,,,,0,0,-1\n"
    df = read_log(_write(tmp_path, text))
    assert df.attrs["compass"] == "mag"
    assert df[["mag_x", "mag_y", "mag_z"]].iloc[1].isna().all()
    text = f"t,gyro_z,temp,heading,{mag}\n0,0,20,4,1,2,3,0,0,-1\n"
    assert read_log(_write(tmp_path, text, "both.csv")).attrs["compass"] == "both"


def test_header_spaces_bom_crlf_and_blank_lines(tmp_path):
    text = "\ufeff t , gyro_z ,temp,heading\r\n0,1,20,5\r\n\r\n1,2,21,6\r\n\r\n"
    df = read_log(_write(tmp_path, text))
    assert list(df.columns) == ["t", "gyro_z", "temp", "heading"]
    assert len(df) == 2


def test_gzip_csv(tmp_path):
    path = _write(tmp_path, gzip.compress(GOOD.encode()), "log.csv.gz")
    pd.testing.assert_frame_equal(read_log(path), read_log(_write(tmp_path, GOOD)))


def test_fmt_overrides_suffix(tmp_path):
    path = _write(tmp_path, GOOD, "log.dat")
    assert read_log(path, fmt="csv").attrs["format"] == "csv"
    msg = _raises(ConfigError, read_log, path)
    assert "log.dat" in msg and ".parquet" in msg
    _raises(ConfigError, read_log, path, fmt="xlsx")


# ---------------------------------------------------------------------------
# bad input, one test per case
# ---------------------------------------------------------------------------


def test_missing_file(tmp_path):
    msg = _raises(LogFormatError, read_log, tmp_path / "nope.csv")
    assert "nope.csv" in msg and "does not exist" in msg


def test_directory_instead_of_file(tmp_path):
    d = tmp_path / "adir.csv"
    d.mkdir()
    msg = _raises(LogFormatError, read_log, d)
    assert "adir.csv" in msg and "directory" in msg


@pytest.mark.parametrize("content", [b"", b"  \n\n"])
def test_empty_file(tmp_path, content):
    msg = _raises(LogFormatError, read_log, _write(tmp_path, content, "empty.csv"))
    assert "empty.csv" in msg and "empty" in msg


def test_header_without_data(tmp_path):
    msg = _raises(LogFormatError, read_log, _write(tmp_path, "t,gyro_z,temp,heading\n", "hdr.csv"))
    assert "hdr.csv" in msg and "no data rows" in msg


def test_empty_parquet_file(tmp_path):
    empty = _write(tmp_path, b"", "empty.parquet")
    assert "empty" in _raises(LogFormatError, read_log, empty)
    zero_rows = tmp_path / "zero.parquet"
    pq.write_table(pa.table({"t": pa.array([], pa.float64())}), zero_rows)
    msg = _raises(LogFormatError, read_log, zero_rows)
    assert "zero.parquet" in msg and "no data rows" in msg


def test_binary_random_bytes(tmp_path):
    data = np.random.default_rng(1).integers(0, 256, 4096, dtype=np.uint8).tobytes()
    msg = _raises(LogFormatError, read_log, _write(tmp_path, b"x" + data, "rand.csv"))
    assert "rand.csv" in msg and "not a CSV text file" in msg


def test_png_file(tmp_path):
    png = b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256))
    msg = _raises(LogFormatError, read_log, _write(tmp_path, png, "pic.csv"))
    assert "pic.csv" in msg and "not a CSV text file" in msg and "line 3" in msg  # NUL after two newlines


def test_non_utf8_text(tmp_path):
    text = "t,gyro_z,temp,heading\n0,1,20,5\n1,2,21,caf\xe9\n".encode("latin-1")
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "latin.csv"))
    assert "latin.csv" in msg and "line 3" in msg and "UTF-8" in msg


def test_gzip_that_is_not_csv(tmp_path):
    payload = gzip.compress(bytes(range(256)) * 4)
    msg = _raises(LogFormatError, read_log, _write(tmp_path, payload, "bin.csv.gz"))
    assert "bin.csv.gz" in msg and "not a CSV text file" in msg


def test_broken_gzip(tmp_path):
    msg = _raises(LogFormatError, read_log, _write(tmp_path, b"\x1f\x8b\x08garbage", "bad.csv.gz"))
    assert "bad.csv.gz" in msg and "gzip" in msg


def test_not_a_parquet_file(tmp_path):
    msg = _raises(LogFormatError, read_log, _write(tmp_path, GOOD, "text.parquet"))
    assert "text.parquet" in msg and "not a readable Parquet file" in msg


def test_ragged_row_too_many_fields(tmp_path):
    text = "t,gyro_z,temp,heading\n0,1,20,5\n1,2,21,6\n2,3,22,7,99\n3,4,23,8\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "rag.csv"))
    assert "rag.csv" in msg and "line 4" in msg and "5 field" in msg and "header has 4" in msg


def test_ragged_row_too_few_fields_after_blank_line(tmp_path):
    # the blank line 3 is skipped by the parser but counts as a line for the user
    text = "t,gyro_z,temp,heading\n0,1,20,5\n\n1,2,21\n2,3,22,7\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "rag.csv"))
    assert "line 4" in msg and "3 field" in msg


def test_duplicate_header_column(tmp_path):
    text = "t,gyro_z,temp,heading,temp\n0,1,20,5,3\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "dup.csv"))
    assert "dup.csv" in msg and "'temp'" in msg and "more than once" in msg


def test_missing_required_column(tmp_path):
    text = "t,gz,temperature,heading\n0,1,20,5\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "req.csv"))
    assert "req.csv" in msg and "'gyro_z'" in msg and "'temp'" in msg
    assert "'gz'" in msg and "'temperature'" in msg and "--map NEW=OLD" in msg


_NO_COMPASS_DOES = "the heading is relative to the first sample and the drift is learned from still periods only"
_NO_TEMP_DOES = "temp set to 0 degC; the drift is modelled as a trend in elapsed time"


def test_no_compass_reads_with_a_note(tmp_path):
    path = _write(tmp_path, "t,gyro_z,temp\n0,1,20\n1,2,21\n", "nc.csv")
    df = read_log(path)
    assert list(df.columns) == ["t", "gyro_z", "temp"]
    np.testing.assert_array_equal(df["temp"], [20.0, 21.0])
    assert df.attrs["compass"] == "none"
    assert df.attrs["notes"] == [
        f"{path}: no compass (no heading column nor mag_x..z with acc_x..z): {_NO_COMPASS_DOES}"
    ]


def test_partial_mag_form_is_no_compass_and_the_note_names_what_is_missing(tmp_path):
    text = "t,gyro_z,temp,mag_x,mag_y,mag_z,acc_z\n0,1,20,1,2,3,-1\n"
    path = _write(tmp_path, text, "pm.csv")
    df = read_log(path)
    assert df.attrs["compass"] == "none"
    assert list(df.columns) == ["t", "gyro_z", "temp", "mag_x", "mag_y", "mag_z", "acc_z"]  # kept as read
    assert df.attrs["notes"] == [
        f"{path}: no compass (no heading column, mag_x..z with acc_x..z incomplete (missing: acc_x, acc_y)):"
        f" {_NO_COMPASS_DOES}"
    ]


def test_compass_columns_without_values_are_no_compass(tmp_path):
    path = _write(tmp_path, "t,gyro_z,temp,heading\n0,1,20,\n1,1,20,\n", "nh.csv")
    df = read_log(path)
    assert df.attrs["compass"] == "none" and df["heading"].isna().all()
    assert df.attrs["notes"] == [
        f"{path}: no compass (heading column empty in every row, no mag_x..z with acc_x..z): {_NO_COMPASS_DOES}"
    ]
    mag = "mag_x,mag_y,mag_z,acc_x,acc_y,acc_z"
    path = _write(tmp_path, f"t,gyro_z,temp,{mag}\n0,1,20,1,2,3,,0,-1\n1,1,20,,,,,0,-1\n", "nm.csv")
    df = read_log(path)
    assert df.attrs["compass"] == "none"
    assert df.attrs["notes"] == [
        f"{path}: no compass (no heading column, mag_x..z with acc_x..z incomplete (empty in every row: acc_x)):"
        f" {_NO_COMPASS_DOES}"
    ]


def test_one_compass_form_with_values_is_enough(tmp_path):
    df = read_log(_write(tmp_path, "t,gyro_z,temp,heading,mag_x\n0,1,20,5,\n1,1,20,,\n"))
    assert df.attrs["compass"] == "heading" and "notes" not in df.attrs


def test_no_temp_column_reads_as_zero_with_a_note(tmp_path):
    path = _write(tmp_path, "t,gyro_z,heading,T_die\n0,1,5,30\n1,2,,31\n", "nt.csv")
    df = read_log(path)
    assert list(df.columns) == ["t", "gyro_z", "heading", "T_die", "temp"]  # added last
    assert df["temp"].dtype == np.float64 and (df["temp"] == 0.0).all()
    assert df.attrs["compass"] == "heading"
    assert df.attrs["notes"] == [
        f"{path}: no usable gyro temperature (no 'temp' column; columns found: 't', 'gyro_z', 'heading', 'T_die'):"
        f" {_NO_TEMP_DOES}; if the log has it under another name, map it with --map temp=NAME (column_map in Python)"
    ]
    mapped = read_log(path, column_map={"temp": "T_die"})
    np.testing.assert_array_equal(mapped["temp"], [30.0, 31.0])
    assert "notes" not in mapped.attrs


def test_temp_empty_in_every_row_reads_as_zero_with_a_note(tmp_path):
    path = _write(tmp_path, "t,gyro_z,temp,heading\n0,1,,5\n1,2,n/a,\n2,3,,7\n", "et.csv")
    df = read_log(path)
    assert list(df.columns) == ["t", "gyro_z", "temp", "heading"]  # in place
    np.testing.assert_array_equal(df["temp"], [0.0, 0.0, 0.0])
    assert df.attrs["notes"] == [f"{path}: no usable gyro temperature (column 'temp' empty in every row): {_NO_TEMP_DOES}"]


def test_no_compass_and_no_temperature_give_two_notes(tmp_path):
    path = tmp_path / "bare.parquet"
    pq.write_table(pa.table({"t": [0.0, 1.0], "gyro_z": [0.5, 0.25], "temp": pa.array([None, None], pa.float64())}), path)
    df = read_log(path)
    assert df.attrs["compass"] == "none" and (df["temp"] == 0.0).all()
    assert df.attrs["notes"] == [
        f"{path}: no compass (no heading column nor mag_x..z with acc_x..z): {_NO_COMPASS_DOES}",
        f"{path}: no usable gyro temperature (column 'temp' empty in every row): {_NO_TEMP_DOES}",
    ]


def test_add_note_appends_to_the_notes_already_there():
    attrs = {"notes": ["earlier note"]}
    add_note(attrs, "log.csv: no compass (x): y")
    assert attrs["notes"] == ["earlier note", "log.csv: no compass (x): y"]
    fresh = {}
    add_note(fresh, no_temperature_note("a.csv", "why"))
    assert fresh == {"notes": [f"a.csv: no usable gyro temperature (why): {_NO_TEMP_DOES}"]}


def test_missing_gyro_z_still_refused_and_names_a_missing_temp_too(tmp_path):
    msg = _raises(LogFormatError, read_log, _write(tmp_path, "t,gz,heading\n0,1,5\n", "gz.csv"))
    assert msg == (
        f"{tmp_path / 'gz.csv'}: missing required column(s) 'gyro_z', 'temp'; columns found: 't', 'gz', 'heading';"
        " rename the matching input columns with --map NEW=OLD (e.g. --map gyro_z=gz; column_map={'gyro_z': 'gz'}"
        " in Python)"
    )


@pytest.mark.parametrize(
    ("column", "row_text", "line", "bad"),
    [
        ("temp", "2,3,abc,7", 4, "abc"),
        ("t", "2s,3,22,7", 4, "2s"),
        ("heading", "2,3,22,N", 4, "N"),
        ("gyro_z", "2,1.2.3,22,7", 4, "1.2.3"),
    ],
)
def test_non_numeric_value(tmp_path, column, row_text, line, bad):
    text = "t,gyro_z,temp,heading\n0,1,20,5\n1,2,21,6\n" + row_text + "\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "nn.csv"))
    assert "nn.csv" in msg and f"line {line}" in msg and f"column '{column}'" in msg
    assert repr(bad) in msg and "not a number" in msg


def test_non_numeric_value_parquet(tmp_path):
    path = tmp_path / "nn.parquet"
    table = pa.table({"t": [0.0, 1.0, 2.0], "gyro_z": [0.0] * 3, "temp": ["20", "21", "hot"], "heading": [1.0] * 3})
    pq.write_table(table, path)
    msg = _raises(LogFormatError, read_log, path)
    assert "nn.parquet" in msg and "data row 3" in msg and "'temp'" in msg and "'hot'" in msg


def test_boolean_in_numeric_column(tmp_path):
    text = "t,gyro_z,temp,heading\n0,true,20,5\n1,false,21,6\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "b.csv"))
    assert "line 2" in msg and "'gyro_z'" in msg


@pytest.mark.parametrize("t_bad", ["0.1", "0.05"])
def test_time_not_increasing(tmp_path, t_bad):
    text = f"t,gyro_z,temp,heading\n0,1,20,5\n0.1,1,20,5\n{t_bad},1,20,5\n0.3,1,20,5\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "ti.csv"))
    assert "ti.csv" in msg and "line 4" in msg and "strictly increasing" in msg
    assert f"t={float(t_bad)!r}" in msg and "t=0.1" in msg and "line 3" in msg
    # a repeated time may be a coarse clock's (say how to keep both samples), one that goes back is not
    repeated = "give each its own time" in msg
    assert repeated == (t_bad == "0.1") and ("sort the log by time" in msg) == (t_bad == "0.05")


def test_time_empty(tmp_path):
    text = "t,gyro_z,temp,heading\n0,1,20,5\n,1,20,5\n2,1,20,5\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "te.csv"))
    assert "te.csv" in msg and "line 3" in msg and "'t'" in msg and "empty" in msg


def test_temperature_out_of_range(tmp_path):
    text = "t,gyro_z,temp,heading\n0,1,298.15,5\n1,1,298.2,5\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "k.csv"))
    assert "k.csv" in msg and "line 2" in msg and "298.15" in msg
    assert "Kelvin" in msg and "-60..150" in msg


def test_required_column_entirely_empty(tmp_path):
    text = "t,gyro_z,temp,heading\n0,,20,5\n1,,20,5\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "ee.csv"))
    assert "ee.csv" in msg and "'gyro_z'" in msg and "every row" in msg


def test_leading_empty_temp(tmp_path):
    text = "t,gyro_z,temp,heading\n0,1,,5\n1,1,,5\n2,1,20,5\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "le.csv"))
    assert "le.csv" in msg and "line 2" in msg and "'temp'" in msg
    assert "line 4" in msg and "drop the leading rows" in msg


def test_infinite_value(tmp_path):
    text = "t,gyro_z,temp,heading\n0,1,20,5\n1,-inf,20,5\n"
    msg = _raises(LogFormatError, read_log, _write(tmp_path, text, "inf.csv"))
    assert "inf.csv" in msg and "line 3" in msg and "'gyro_z'" in msg and "not finite" in msg


# ---------------------------------------------------------------------------
# options
# ---------------------------------------------------------------------------


def test_rad_per_s(tmp_path):
    text = "t,gyro_x,gyro_y,gyro_z,temp,heading\n0,0.1,-0.2,1.0,20,5\n"
    path = _write(tmp_path, text)
    df = read_log(path, gyro_unit="rad/s")
    np.testing.assert_allclose(df[["gyro_x", "gyro_y", "gyro_z"]].iloc[0], np.degrees([0.1, -0.2, 1.0]))
    assert df["temp"].iloc[0] == 20.0 and df["heading"].iloc[0] == 5.0
    assert df.attrs["gyro_unit"] == "rad/s"
    assert read_log(path, gyro_unit="dps")["gyro_z"].iloc[0] == 1.0


def test_unknown_gyro_unit(tmp_path):
    msg = _raises(ConfigError, read_log, _write(tmp_path, GOOD), gyro_unit="mrad/s")
    assert "mrad/s" in msg and "deg/s" in msg and "rad/s" in msg and "dps" in msg


def test_enu_conversion(tmp_path):
    mag = "mag_x,mag_y,mag_z,acc_x,acc_y,acc_z"
    text = (
        f"t,gyro_x,gyro_y,gyro_z,temp,heading,ref_heading,{mag}\n"
        f"0,1,2,3,20,0,90,10,20,30,0.1,0.2,1.0\n"
        f"1,1,2,-3,20,90,0,10,20,30,0.1,0.2,1.0\n"
        f"2,1,2,3,20,180,-45,10,20,30,0.1,0.2,1.0\n"
    )
    df = read_log(_write(tmp_path, text), frame="enu")
    np.testing.assert_allclose(df["heading"], [90.0, 0.0, 270.0])  # east, north, west
    np.testing.assert_allclose(df["ref_heading"], [0.0, 90.0, 135.0])
    np.testing.assert_array_equal(df["gyro_x"], [1, 1, 1])
    np.testing.assert_array_equal(df["gyro_y"], [-2, -2, -2])
    np.testing.assert_array_equal(df["gyro_z"], [-3, 3, -3])  # CCW (ENU +z) = heading decreasing
    np.testing.assert_array_equal(df.iloc[0][list(mag.split(","))], [10, -20, -30, 0.1, -0.2, -1.0])
    assert df.attrs["frame"] == "enu"


def test_unknown_frame(tmp_path):
    msg = _raises(ConfigError, read_log, _write(tmp_path, GOOD), frame="nwu")
    assert "nwu" in msg and "ned" in msg and "enu" in msg


def test_column_map(tmp_path):
    text = "time,gz,temperature,hdg,extra\n0,1,20,5,x\n1,2,21,6,y\n"
    df = read_log(
        _write(tmp_path, text),
        column_map={"t": "time", "gyro_z": "gz", "temp": "temperature", "heading": "hdg"},
    )
    assert list(df.columns) == ["t", "gyro_z", "temp", "heading", "extra"]
    np.testing.assert_array_equal(df["gyro_z"], [1.0, 2.0])


def test_column_map_missing_old(tmp_path):
    msg = _raises(ConfigError, read_log, _write(tmp_path, GOOD, "cm.csv"), column_map={"gyro_z": "gz"})
    assert "cm.csv" in msg and "'gz'" in msg and "'gyro_z'" in msg and "'heading'" in msg


def test_column_map_duplicate_result(tmp_path):
    msg = _raises(ConfigError, read_log, _write(tmp_path, GOOD, "cm.csv"), column_map={"heading": "temp"})
    assert "cm.csv" in msg and "two columns" in msg


# ---------------------------------------------------------------------------
# CSV vs Parquet, writing
# ---------------------------------------------------------------------------


def _sample_frame(n: int = 50) -> pd.DataFrame:
    rng = np.random.default_rng(7)
    heading = rng.uniform(0, 360, n)
    heading[::3] = np.nan
    return pd.DataFrame(
        {
            "t": np.arange(n) * 0.01 + rng.uniform(0, 1e-3, n),
            "gyro_z": rng.standard_normal(n) / 3.0,
            "temp": 20.0 + rng.standard_normal(n),
            "heading": heading,
            "label": [f"s{i}" for i in range(n)],
        }
    )


def test_csv_and_parquet_read_identically(tmp_path):
    df = _sample_frame()
    csv_path, pq_path = tmp_path / "a.csv", tmp_path / "a.parquet"
    df.to_csv(csv_path, index=False)
    pq.write_table(pa.Table.from_pandas(df, preserve_index=False), pq_path)
    from_csv, from_pq = read_log(csv_path), read_log(pq_path)
    assert from_pq.attrs["format"] == "parquet" and from_csv.attrs["format"] == "csv"
    pd.testing.assert_frame_equal(from_csv, from_pq)
    pd.testing.assert_frame_equal(from_csv, df, check_dtype=False)


@pytest.mark.parametrize("name", ["out.csv", "out.parquet", "out.pq"])
def test_write_table_round_trip_exact(tmp_path, name):
    rng = np.random.default_rng(3)
    x = rng.standard_normal(500) * 10.0 ** rng.integers(-300, 300, 500)
    x[:6] = [5e-324, 1.7976931348623157e308, -0.0, 0.1, 1 / 3, np.nan]
    df = pd.DataFrame({"x": x, "y": np.arange(500) / 7.0, "s": [f"v{i}" for i in range(500)]})
    path = tmp_path / name
    write_table(df, path)
    back = pd.read_csv(path) if name.endswith(".csv") else pd.read_parquet(path)
    pd.testing.assert_frame_equal(back, df, check_dtype=False, check_exact=True)
    assert np.signbit(back["x"].iloc[2])
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(allow_nan=False, allow_infinity=False), min_size=1, max_size=20))
def test_write_csv_floats_round_trip_property(tmp_path_factory, values):
    path = tmp_path_factory.mktemp("rt") / "v.csv"
    write_table(pd.DataFrame({"v": values}), path)
    # read as float: pyarrow writes -0.0 as "-0", which pandas alone would infer as the integer 0
    back = pd.read_csv(path, dtype={"v": float})["v"].to_numpy()
    assert back.tobytes() == np.asarray(values, dtype=float).tobytes()


def test_written_contract_log_reads_back(tmp_path):
    df = read_log(_write(tmp_path, GOOD))
    write_table(df, tmp_path / "copy.csv")
    pd.testing.assert_frame_equal(read_log(tmp_path / "copy.csv"), df)


def test_write_table_fmt_and_bad_suffix(tmp_path):
    df = _sample_frame(5)
    write_table(df, tmp_path / "out.dat", fmt="parquet")
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "out.dat"), df, check_dtype=False)
    msg = _raises(ConfigError, write_table, df, tmp_path / "out.xlsx")
    assert "out.xlsx" in msg and ".csv" in msg and ".parquet" in msg and ".pq" in msg


def test_write_table_missing_directory(tmp_path):
    msg = _raises(ConfigError, write_table, _sample_frame(5), tmp_path / "no_such_dir" / "out.csv")
    assert "no_such_dir" in msg and "does not exist" in msg


def test_write_failure_keeps_existing_file_parquet(tmp_path):
    path = tmp_path / "out.parquet"
    path.write_bytes(b"old content")
    bad = pd.DataFrame({"mixed": [1, "a", 2.5]})  # pyarrow cannot type this column
    with pytest.raises((pa.ArrowException, TypeError, ValueError)):
        write_table(bad, path)
    assert path.read_bytes() == b"old content"
    assert [p.name for p in tmp_path.iterdir()] == ["out.parquet"]


def test_write_failure_keeps_existing_file_csv(tmp_path, monkeypatch):
    path = tmp_path / "out.csv"
    path.write_text("old,content\n")

    def half_write(self, fh, *args, **kwargs):
        fh.write("t,partial\n1,")
        raise OSError(28, "No space left on device")

    def half_write_arrow(table, fh, *args, **kwargs):
        fh.write(b"t,partial\n1,")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(pd.DataFrame, "to_csv", half_write)  # both CSV writers fail half-way
    monkeypatch.setattr(tabular.pa_csv, "write_csv", half_write_arrow)
    msg = _raises(ConfigError, write_table, _sample_frame(5), path)
    assert "out.csv" in msg and "No space left" in msg
    assert path.read_text() == "old,content\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


def test_write_replaces_existing_file(tmp_path):
    path = tmp_path / "out.csv"
    path.write_text("old\n")
    write_table(pd.DataFrame({"a": [1.5]}), path)
    assert path.read_text() == "a\n1.5\n"


# ---------------------------------------------------------------------------
# check_output_path
# ---------------------------------------------------------------------------


def test_check_output_path(tmp_path):
    src = _write(tmp_path, GOOD, "in.csv")
    check_output_path(src, tmp_path / "out.csv")  # different file: fine
    msg = _raises(ConfigError, check_output_path, src, tmp_path / "." / "in.csv")
    assert "in.csv" in msg and "never overwritten" in msg and "-o" in msg


def test_check_output_path_links(tmp_path):
    src = _write(tmp_path, GOOD, "in.csv")
    sym = tmp_path / "sym.csv"
    sym.symlink_to(src)
    _raises(ConfigError, check_output_path, src, sym)
    hard = tmp_path / "hard.csv"
    os.link(src, hard)
    _raises(ConfigError, check_output_path, src, hard)


# ---------------------------------------------------------------------------
# real recorded logs
# ---------------------------------------------------------------------------

_no_mpu = pytest.mark.skipif(not MPU.exists(), reason=f"shared data folder {MPU} is absent")
_no_acti = pytest.mark.skipif(not ACTI.exists(), reason=f"shared data folder {ACTI} is absent")


_TVAC = DATA / "pan_lsm6dsm_tvac"


@pytest.mark.skipif(not _TVAC.exists(), reason=f"shared data folder {_TVAC} is absent")
def test_real_tvac_without_compass_reads_with_a_note():
    path = _TVAC / "contract.csv"
    df = read_log(path)
    assert list(df.columns) == ["t", "gyro_z", "temp"] and len(df) == 6250
    assert df.attrs["compass"] == "none"
    assert df.attrs["notes"] == [
        f"{path}: no compass (no heading column nor mag_x..z with acc_x..z): {_NO_COMPASS_DOES}"
    ]
    assert df["temp"].between(15.0, 24.0).all()


@_no_mpu
def test_real_mpu6050_mag():
    df = read_log(MPU / "contract.csv")
    assert len(df) == 2393
    assert df.attrs["compass"] == "mag"
    assert df[["mag_x", "mag_y", "mag_z"]].iloc[0].isna().all()  # empty cells on line 2
    assert df["mag_x"].notna().any() and df["mag_x"].isna().sum() >= 1
    assert df[["t", "gyro_z", "temp"]].notna().all().all()


@_no_mpu
def test_real_mpu6050_heading():
    df = read_log(MPU / "contract_heading.csv")
    assert len(df) == 2393
    assert df.attrs["compass"] == "heading"
    assert np.isnan(df["heading"].iloc[0])
    h = df["heading"].dropna()
    assert len(h) > 0 and ((h >= 0) & (h < 360)).all()


@_no_acti
def test_real_actigraph():
    df = read_log(ACTI / "contract.csv")
    assert len(df) == 17916
    assert df.attrs["compass"] == "mag"
    assert (np.diff(df["t"]) > 0).all()
    assert df["temp"].between(35.0, 60.0).all()
    assert df["acc_z"].notna().all()
    # the file holds the magnetometer between its updates; the repeats are dropped (gyrodrift.io.held)
    assert df["mag_x"].notna().sum() == 1446 and any("16470 compass samples repeated" in n for n in df.attrs["notes"])


def test_module_exports():
    assert set(tabular.__all__) == {"read_log", "write_table", "check_output_path", "formula_safe", "FORMULA_STARTS"}


def test_parquet_numbers_stored_as_dictionary_text(tmp_path):
    path = tmp_path / "dict.parquet"
    temp = pa.array(["20.5", "21", "21"]).dictionary_encode()
    pq.write_table(pa.table({"t": [0, 1, 2], "gyro_z": [0.5, 0.25, 0.0], "temp": temp, "heading": [1.0, None, 2.0]}), path)
    df = read_log(path)
    np.testing.assert_array_equal(df["temp"], [20.5, 21.0, 21.0])
    assert df["t"].dtype == np.float64 and np.isnan(df["heading"].iloc[1])
