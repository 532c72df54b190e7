"""Tests of gyrodrift.io.chunked: logs read and written in chunks equal the whole-table path."""

from __future__ import annotations

import gzip
import hashlib
import os
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io import read_log, write_table
from gyrodrift.io.chunked import ChunkWriter, LogChunks, iter_log_chunks

SMALL_BLOCK = 1024  # bytes: many pyarrow blocks even in a small file


def _write(tmp_path: Path, text: str | bytes, name: str = "log.csv") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8") if isinstance(text, str) else text)
    return path


def _chunks(path, **kwargs) -> list[pd.DataFrame]:
    kwargs.setdefault("block_size_bytes", SMALL_BLOCK)
    if str(path).endswith((".parquet", ".pq")) or kwargs.get("fmt") == "parquet":
        kwargs.pop("block_size_bytes")
    with iter_log_chunks(path, **kwargs) as chunks:
        return list(chunks)


def _assert_same_as_read_log(path, chunk_rows, **options) -> list[pd.DataFrame]:
    """Chunks concatenate to read_log bit for bit; return the chunks."""
    whole = read_log(path, **options)
    parts = _chunks(path, chunk_rows=chunk_rows, **options)
    assert all(len(p) == chunk_rows for p in parts[:-1]) and 0 < len(parts[-1]) <= chunk_rows
    joined = pd.concat(parts)
    pd.testing.assert_frame_equal(joined, whole, check_exact=True)
    assert list(joined.dtypes) == list(whole.dtypes)
    for col in whole.columns:
        if whole[col].dtype == np.float64:
            assert joined[col].to_numpy().tobytes() == whole[col].to_numpy().tobytes(), col
    expected_attrs = {k: v for k, v in whole.attrs.items() if k not in ("compass", "notes")}
    assert all(p.attrs == expected_attrs for p in parts)
    return parts


def _csv_log(n: int = 200, *, seed: int = 0, unit_scale: float = 1.0) -> str:
    """A contract CSV with empty heading cells, gaps in gyro/temp and two extra columns."""
    rng = np.random.default_rng(seed)
    lines = ["t,gyro_x,gyro_y,gyro_z,temp,heading,ref_heading,label,count"]
    for i in range(n):
        heading = "" if i % 3 else repr(float(rng.uniform(-30, 400)))
        gz = "" if i % 17 == 5 else repr(float(rng.standard_normal() * unit_scale))
        temp = "" if i % 23 == 7 else repr(float(20 + rng.standard_normal()))
        lines.append(
            f"{i * 0.01!r},{rng.standard_normal()!r},{rng.standard_normal()!r},{gz},{temp},{heading},"
            f"{rng.uniform(0, 360)!r},s{i % 4},{i}"
        )
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# chunks concatenate to read_log
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("chunk_rows", [1, 7, 64, 200, 1000])
def test_csv_chunks_equal_read_log(tmp_path, chunk_rows):
    path = _write(tmp_path, _csv_log())
    parts = _assert_same_as_read_log(path, chunk_rows)
    assert len(parts) == -(-200 // chunk_rows)
    assert parts[-1].index[-1] == 199


@pytest.mark.parametrize(("unit", "frame"), [("deg/s", "ned"), ("rad/s", "ned"), ("rad/s", "enu"), ("dps", "enu")])
def test_csv_units_and_frames(tmp_path, unit, frame):
    path = _write(tmp_path, _csv_log(seed=1, unit_scale=0.01))
    parts = _assert_same_as_read_log(path, 37, gyro_unit=unit, frame=frame)
    assert parts[0].attrs["gyro_unit"] == unit and parts[0].attrs["frame"] == frame


def test_csv_column_map(tmp_path):
    text = _csv_log(seed=2).replace("t,gyro_x,gyro_y,gyro_z,temp,heading", "time, gx ,gy,gz,T_die,hdg", 1)
    path = _write(tmp_path, text)
    mapping = {"t": "time", "gyro_x": "gx", "gyro_y": "gy", "gyro_z": "gz", "temp": "T_die", "heading": "hdg"}
    parts = _assert_same_as_read_log(path, 50, column_map=mapping)
    assert list(parts[0].columns[:6]) == ["t", "gyro_x", "gyro_y", "gyro_z", "temp", "heading"]


def test_csv_gzip_bom_crlf_blank_lines(tmp_path):
    text = "\ufeff" + _csv_log(seed=3).replace("\n", "\r\n").replace("\r\n0.5,", "\r\n\r\n0.5,")
    path = _write(tmp_path, gzip.compress(text.encode("utf-8")), "log.csv.gz")
    _assert_same_as_read_log(path, 30)


def test_mag_compass_form_known_after_last_chunk(tmp_path):
    mag = "mag_x,mag_y,mag_z,acc_x,acc_y,acc_z"
    rows = "".join(f"{i},0.1,20,{'' if i < 5 else 1},2,3,0,0,-1\n" for i in range(12))
    path = _write(tmp_path, f"t,gyro_z,temp,{mag}\n{rows}")
    chunks = iter_log_chunks(path, chunk_rows=4)
    assert chunks.compass is None
    parts = list(chunks)
    assert chunks.compass == "mag" == read_log(path).attrs["compass"] and chunks.rows == 12
    pd.testing.assert_frame_equal(pd.concat(parts), read_log(path))


def test_parquet_chunks_equal_read_log(tmp_path):
    df = read_log(_write(tmp_path, _csv_log(300, seed=4)))
    df["flag"] = df.index % 2 == 0
    df["cat"] = pd.Categorical(np.where(df.index % 3 == 0, "x", "y"))
    path = tmp_path / "log.parquet"
    pq.write_table(pa.Table.from_pandas(df, preserve_index=False), path, row_group_size=70)
    _assert_same_as_read_log(path, 45)
    _assert_same_as_read_log(path, 45, gyro_unit="rad/s", frame="enu")


def test_parquet_pass_through_dtypes_of_the_whole_file(tmp_path):
    """Empty cells only in a later row group: the whole file's dtypes in every chunk."""
    schema = pa.schema(
        [("t", pa.float64()), ("gyro_z", pa.float64()), ("temp", pa.string()), ("heading", pa.float64()),
         ("n", pa.int64()), ("ok", pa.bool_()), ("phase", pa.dictionary(pa.int8(), pa.string()))]
    )
    path = tmp_path / "groups.parquet"
    with pq.ParquetWriter(path, schema) as writer:
        for k, phase in enumerate([["b", "a"], ["c", "b"], ["d", "a"]]):
            writer.write_table(
                pa.table(
                    {
                        "t": [2.0 * k, 2.0 * k + 1], "gyro_z": [0.5, -0.0], "temp": ["20.5", " 21 "],
                        "heading": [1.0, None], "n": [k, None if k == 2 else 7], "ok": [True, None if k == 2 else False],
                        "phase": pa.array(phase).dictionary_encode().cast(schema.field("phase").type),
                    },
                    schema=schema,
                )
            )
    parts = _assert_same_as_read_log(path, 3)
    assert all(p["n"].dtype == np.float64 and p["ok"].dtype == object for p in parts)
    assert list(parts[0]["phase"].cat.categories) == list(read_log(path)["phase"].cat.categories)


def test_numbers_as_text_later_in_the_file(tmp_path):
    """A number column holding text ('None', spaces) after the first block: same values."""
    rows = [f"{i},{i * 0.37!r},20,{i % 360}" for i in range(400)]
    rows[300] = "300, -0 ,20,None"
    rows[301] = "301,1e-400,  20.5 ,n/a"
    rows[10] += "\n"  # a blank line before the switch
    path = _write(tmp_path, "t,gyro_z,temp,heading\n\n" + "\n".join(rows) + "\n")
    parts = _chunks(path, chunk_rows=128)
    assert sum(len(p) for p in parts) == 400
    pd.testing.assert_frame_equal(pd.concat(parts), read_log(path), check_exact=True)
    assert np.signbit(read_log(path)["gyro_z"].iloc[300])


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-1e300, 1e300, allow_nan=False), min_size=1, max_size=30), st.sampled_from(["{!r}", "{:.25g}", "{:.3e}", " {!r}\t"]))
def test_number_cells_read_the_same_as_numbers_or_as_text(tmp_path_factory, values, style):
    """pyarrow's float64 column and the text path give the same bits for every cell (the
    plausible gyro full scale raised above the values drawn)."""
    tmp = tmp_path_factory.mktemp("cells")
    body = "".join(f"{i},{style.format(v)},20,1\n" for i, v in enumerate(values))
    typed = read_log(_write(tmp, "t,gyro_z,temp,heading\n" + body), gyro_max_dps=1e301)
    as_text = read_log(_write(tmp, "t,gyro_z,temp,heading\n" + body + f"{len(values)},none,20,1\n", "text.csv"),
                       gyro_max_dps=1e301)
    assert typed["gyro_z"].to_numpy().tobytes() == as_text["gyro_z"].to_numpy()[:-1].tobytes()


# ---------------------------------------------------------------------------
# errors: same message as read_log, rows counted in the whole file
# ---------------------------------------------------------------------------


def _same_error(path, chunk_rows, exc_type=LogFormatError, **options) -> str:
    with pytest.raises(exc_type) as whole:
        read_log(path, **options)
    with pytest.raises(exc_type) as chunked:
        _chunks(path, chunk_rows=chunk_rows, **options)
    assert str(chunked.value) == str(whole.value)
    assert "\n" not in str(chunked.value)
    return str(chunked.value)


def _rows(n: int, bad: dict[int, str] | None = None) -> str:
    rows = [f"{i / 10!r},0.5,20,{i % 360}" for i in range(n)]
    for i, row in (bad or {}).items():
        rows[i] = row
    return "t,gyro_z,temp,heading\n" + "\n".join(rows) + "\n"


@pytest.mark.parametrize(
    ("row", "text", "expect"),
    [
        ("15.0,abc,20,1", "column 'gyro_z'", "'abc' is not a number"),
        ("15.0,inf,20,1", "column 'gyro_z'", "not finite"),
        ("15.0,0.5,400,1", "column 'temp'", "outside the plausible range"),
        (",0.5,20,1", "column 't'", "time is empty"),
        ("15.0,0.5,20,1,9", "", "5 field(s)"),
    ],
)
def test_bad_cell_in_a_later_chunk_names_its_file_line(tmp_path, row, text, expect):
    # line 2 is blank: physical line numbers differ from row numbers
    path = _write(tmp_path, _rows(300, {150: row}).replace("\n", "\n\n", 1), "bad.csv")
    msg = _same_error(path, 64)
    assert "bad.csv" in msg and "line 153" in msg and text in msg and expect in msg


def test_bad_cell_in_a_later_chunk_parquet(tmp_path):
    path = tmp_path / "bad.parquet"
    temp = [f"{20 + i % 3}" for i in range(300)]
    temp[150] = "hot"
    pq.write_table(pa.table({"t": np.arange(300.0), "gyro_z": np.zeros(300), "temp": temp, "heading": np.ones(300)}), path, row_group_size=100)
    msg = _same_error(path, 64)
    assert "bad.parquet: data row 151, column 'temp'" in msg and "'hot'" in msg


@pytest.mark.parametrize("t_next", ["12.7", "12.6"])
def test_time_backwards_across_a_chunk_boundary(tmp_path, t_next):
    path = _write(tmp_path, _rows(300, {128: f"{t_next},0.5,20,1"}), "back.csv")  # row 127 has t = 12.7
    msg = _same_error(path, 128)
    assert "line 130" in msg and "line 129" in msg and f"t={float(t_next)!r} follows t=12.7" in msg


def test_time_backwards_across_a_row_group_boundary_parquet(tmp_path):
    t = np.arange(300.0)
    t[100] = 99.0
    path = tmp_path / "back.parquet"
    pq.write_table(pa.table({"t": t, "gyro_z": np.zeros(300), "temp": np.full(300, 20.0), "heading": np.ones(300)}), path, row_group_size=100)
    msg = _same_error(path, 100)
    assert "data row 101" in msg and "data row 100" in msg


def test_leading_empty_temp_reaching_into_later_chunks(tmp_path):
    rows = {i: f"{i / 10!r},0.5,,1" for i in range(140)}
    msg = _same_error(_write(tmp_path, _rows(300, rows), "lead.csv"), 64)
    assert "line 2" in msg and "line 142" in msg and "drop the leading rows" in msg


def test_required_column_empty_everywhere(tmp_path):
    rows = {i: f"{i / 10!r},,20,1" for i in range(300)}
    msg = _same_error(_write(tmp_path, _rows(300, rows), "ee.csv"), 64)
    assert "'gyro_z' is empty in every row" in msg


def test_time_empty_in_the_first_chunk_only(tmp_path):
    rows = {i: ",0.5,20,1" for i in range(70)}
    msg = _same_error(_write(tmp_path, _rows(300, rows), "te.csv"), 64)
    assert "line 2" in msg and "time is empty" in msg


def _chunks_and_notes(path, chunk_rows, **kwargs) -> tuple[list[pd.DataFrame], LogChunks]:
    """The chunks (checked equal to read_log) and the LogChunks, read to the end."""
    whole = read_log(path, **kwargs)
    if not str(path).endswith(".parquet"):
        kwargs.setdefault("block_size_bytes", SMALL_BLOCK)
    chunks = iter_log_chunks(path, chunk_rows=chunk_rows, **kwargs)
    assert chunks.notes is None and chunks.compass is None
    parts = list(chunks)
    pd.testing.assert_frame_equal(pd.concat(parts), whole, check_exact=True)
    assert chunks.compass == whole.attrs["compass"]
    assert chunks.notes == whole.attrs.get("notes", [])
    return parts, chunks


def test_compass_empty_everywhere_is_no_compass_after_the_last_chunk(tmp_path):
    path = _write(tmp_path, _rows(300, {i: f"{i / 10!r},0.5,20," for i in range(300)}), "nc.csv")
    parts, chunks = _chunks_and_notes(path, 64)
    assert len(parts) == 5 and chunks.compass == "none"
    assert chunks.notes == [
        f"{path}: no compass (heading column empty in every row, no mag_x..z with acc_x..z): the heading is relative"
        " to the first sample and the drift is learned from still periods only"
    ]


def test_no_notes_for_a_complete_log(tmp_path):
    _, chunks = _chunks_and_notes(_write(tmp_path, _rows(300)), 64)
    assert chunks.notes == [] and chunks.compass == "heading"


def test_no_temp_column_is_zero_in_every_chunk(tmp_path):
    text = "t,gyro_z,heading\n" + "".join(f"{i / 10!r},0.5,{i % 360}\n" for i in range(300))
    parts, chunks = _chunks_and_notes(_write(tmp_path, text, "nt.csv"), 64)
    assert all(list(p.columns) == ["t", "gyro_z", "heading", "temp"] and (p["temp"] == 0.0).all() for p in parts)
    assert len(chunks.notes) == 1 and "no usable gyro temperature (no 'temp' column;" in chunks.notes[0]


@pytest.mark.parametrize("suffix", ["csv", "parquet"])
def test_temp_empty_everywhere_is_zero_in_every_chunk(tmp_path, suffix):
    rows = {i: f"{i / 10!r},0.5,,{i % 360}" for i in range(300)}
    path = _write(tmp_path, _rows(300, rows), "et.csv")
    if suffix == "parquet":
        df = read_log(path).assign(temp=np.nan)
        path = tmp_path / "et.parquet"
        pq.write_table(pa.Table.from_pandas(df, preserve_index=False), path, row_group_size=50)
    parts, chunks = _chunks_and_notes(path, 64)
    assert len(parts) == 5 and all((p["temp"] == 0.0).all() for p in parts)  # none was taken by the read-ahead
    assert chunks.notes == [
        f"{path}: no usable gyro temperature (column 'temp' empty in every row): temp set to 0 degC;"
        " the drift is modelled as a trend in elapsed time"
    ]


def test_temp_empty_in_the_first_chunk_then_present_is_refused_before_any_chunk(tmp_path):
    rows = {i: f"{i / 10!r},0.5,,1" for i in range(100)}
    path = _write(tmp_path, _rows(300, rows), "lt.csv")
    msg = _same_error(path, 64)
    assert "line 102" in msg and "drop the leading rows" in msg
    with pytest.raises(LogFormatError):
        next(iter_log_chunks(path, chunk_rows=64))


@pytest.mark.parametrize(
    ("content", "name", "expect"),
    [
        (_rows(3000).encode() + b"1,2,\x00\n", "nul.csv", "NUL"),
        (_rows(3000).encode() + "1,2,caf\xe9\n".encode("latin-1"), "latin.csv", "not UTF-8"),
        (gzip.compress(_rows(3000).encode())[:-30], "cut.csv.gz", "gzip"),
        (b"", "empty.csv", "file is empty"),
        (b" \n\r\n ", "blank.csv", "file is empty"),
        (b"t,gyro_z,temp,heading\n", "hdr.csv", "no data rows"),
        (b"t,gyro_z,temp,temp\n0,1,20,20\n", "dup.csv", "more than once"),
        (b"t,gz,temp,heading\n0,1,20,20\n", "req.csv", "missing required column"),
    ],
)
def test_file_level_errors_like_read_log(tmp_path, content, name, expect):
    msg = _same_error(_write(tmp_path, content, name), 64)
    assert name in msg and expect in msg


def test_nul_line_counted_in_the_whole_file(tmp_path):
    msg = _same_error(_write(tmp_path, _rows(3000).encode() + b"1,2,\x00\n", "nul.csv"), 64)
    assert "line 3002" in msg


@pytest.mark.parametrize(("first", "later", "kind"), [("{i}", "2.5", "float64"), ("", "late", "string")])
def test_pass_through_type_change_asks_for_column_types(tmp_path, first, later, kind):
    rows = [f"{i},0.5,20,1,{first.format(i=i)}" for i in range(300)]
    rows[250] = f"250,0.5,20,1,{later}"
    path = _write(tmp_path, "t,gyro_z,temp,heading,count\n" + "\n".join(rows) + "\n", "pt.csv")
    with pytest.raises(LogFormatError) as info:
        _chunks(path, chunk_rows=64)
    msg = str(info.value)
    assert "pt.csv: line 252, column 'count'" in msg and repr(later) in msg and "column_types" in msg
    parts = _chunks(path, chunk_rows=64, column_types={"count": kind})
    pd.testing.assert_frame_equal(pd.concat(parts), read_log(path), check_exact=True)


def test_options_refused(tmp_path):
    path = _write(tmp_path, _rows(10))
    for bad in (0, -1, 2.5, True):
        with pytest.raises(ConfigError):
            iter_log_chunks(path, chunk_rows=bad)
    with pytest.raises(ConfigError, match="does not have"):
        iter_log_chunks(path, column_types={"nope": "string"})
    with pytest.raises(ConfigError, match="always read as numbers"):
        iter_log_chunks(path, column_types={"temp": "string"})
    with pytest.raises(ConfigError, match="ulog"):
        iter_log_chunks(_write(tmp_path, b"x", "f.ulg"))
    with pytest.raises(ConfigError):
        iter_log_chunks(path, gyro_unit="mrad/s")
    with pytest.raises(LogFormatError, match="does not exist"):
        iter_log_chunks(tmp_path / "missing.csv")


def test_input_file_never_modified(tmp_path):
    path = _write(tmp_path, _csv_log(seed=5))
    before = (hashlib.sha256(path.read_bytes()).hexdigest(), os.stat(path).st_mtime_ns)
    _chunks(path, chunk_rows=50)
    with iter_log_chunks(path, chunk_rows=50) as chunks:
        next(chunks)  # stopped early
    assert (hashlib.sha256(path.read_bytes()).hexdigest(), os.stat(path).st_mtime_ns) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["log.csv"]


# ---------------------------------------------------------------------------
# ChunkWriter
# ---------------------------------------------------------------------------


def _output_frame(n: int = 250, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-300, 300, n)
    x[:5] = [5e-324, -0.0, np.nan, 1e16, 0.1]
    reason = np.where(rng.random(n) < 0.3, "turning", "")
    unobservable = np.where(np.arange(n) < 180, "a", "a,b")  # quoting needed only in later chunks
    return pd.DataFrame(
        {
            "t": np.arange(n) * 0.01, "rate_z": x, "updated": rng.integers(0, 2, n), "gate_reason": reason.astype(str),
            "unobservable": unobservable.astype(str), "note": [f'say "{i}"' if i % 50 == 0 else f"n{i}" for i in range(n)],
        }
    )


def _write_chunks(path, frame, sizes, *, categorical=False, **kwargs) -> None:
    with ChunkWriter(path, **kwargs) as out:
        start = 0
        for size in sizes:
            part = frame.iloc[start : start + size]
            if categorical:
                part = part.astype({"gate_reason": "category", "unobservable": "category"})
            out.write(part)
            start += size
        assert out.rows == len(frame)


@pytest.mark.parametrize("categorical", [False, True])
def test_chunk_writer_csv_is_byte_identical(tmp_path, categorical):
    frame = _output_frame()
    write_table(frame, tmp_path / "whole.csv")
    _write_chunks(tmp_path / "chunks.csv", frame, [1, 99, 80, 0, 70], categorical=categorical)
    assert (tmp_path / "chunks.csv").read_bytes() == (tmp_path / "whole.csv").read_bytes()
    back = pd.read_csv(tmp_path / "chunks.csv", keep_default_na=False, na_values=[""])
    assert back["rate_z"].to_numpy().tobytes() == frame["rate_z"].to_numpy().tobytes()
    assert back["unobservable"].iloc[-1] == "a,b" and back["note"].iloc[0] == 'say "0"'


@pytest.mark.parametrize("categorical", [False, True])
def test_chunk_writer_parquet_reads_back_as_write_table(tmp_path, categorical):
    frame = _output_frame()
    write_table(frame, tmp_path / "whole.parquet")
    _write_chunks(tmp_path / "chunks.pq", frame, [100, 100, 50], categorical=categorical)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "chunks.pq"), pd.read_parquet(tmp_path / "whole.parquet"), check_exact=True)
    assert pq.ParquetFile(tmp_path / "chunks.pq").metadata.num_row_groups == 1  # gathered up to row_group_rows
    _write_chunks(tmp_path / "groups.pq", frame, [60, 60, 60, 60, 10], categorical=categorical, row_group_rows=100)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "groups.pq"), pd.read_parquet(tmp_path / "whole.parquet"), check_exact=True)
    groups = pq.ParquetFile(tmp_path / "groups.pq").metadata
    assert [groups.row_group(i).num_rows for i in range(groups.num_row_groups)] == [120, 120, 10]


def test_chunk_writer_log_round_trip(tmp_path):
    """Chunks read from a log and written in chunks: the file write_table writes for read_log."""
    path = _write(tmp_path, _csv_log(seed=7))
    for name in ("a.csv", "a.parquet"):
        write_table(read_log(path), tmp_path / f"whole_{name}")
        with ChunkWriter(tmp_path / name) as out, iter_log_chunks(path, chunk_rows=33) as chunks:
            for chunk in chunks:
                out.write(chunk)
        pd.testing.assert_frame_equal(read_log(tmp_path / name), read_log(tmp_path / f"whole_{name}"), check_exact=True)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "whole_a.csv").read_bytes()


def test_chunk_writer_csv_values_pyarrow_cannot_print(tmp_path):
    """Columns pyarrow's CSV writer refuses (lists) are printed by pandas, as write_table prints them."""
    listed = pd.DataFrame({"t": [0.0, 1.0, 2.0], "l": [[1], [2, 3], []]})
    write_table(listed, tmp_path / "listed.csv")
    _write_chunks(tmp_path / "listed_chunks.csv", listed, [1, 2])
    assert (tmp_path / "listed_chunks.csv").read_bytes() == (tmp_path / "listed.csv").read_bytes()
    assert (tmp_path / "listed.csv").read_text() == 't,l\n0.0,[1]\n1.0,"[2, 3]"\n2.0,[]\n'


@pytest.mark.parametrize("sync_every_s", [None, 0.001])
def test_chunk_writer_syncing_while_writing(tmp_path, sync_every_s):
    frame = _output_frame(2000)
    write_table(frame, tmp_path / "whole.csv")
    with ChunkWriter(tmp_path / "chunks.csv", sync_every_s=sync_every_s) as out:
        for start in range(0, len(frame), 100):
            out.write(frame.iloc[start : start + 100])
            time.sleep(0.002)  # the sync thread runs in between
    assert (tmp_path / "chunks.csv").read_bytes() == (tmp_path / "whole.csv").read_bytes()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["chunks.csv", "whole.csv"]
    assert not any(t.name == "gyrodrift-sync" for t in threading.enumerate())


@pytest.mark.parametrize("name", ["out.csv", "out.parquet"])
def test_chunk_writer_exception_leaves_nothing(tmp_path, name):
    frame = _output_frame()
    path = tmp_path / name
    with pytest.raises(RuntimeError, match="stop"):
        with ChunkWriter(path) as out:
            out.write(frame.iloc[:100])
            raise RuntimeError("stop")
    assert list(tmp_path.iterdir()) == []
    path.write_bytes(b"old content")
    with pytest.raises(RuntimeError):
        with ChunkWriter(path) as out:
            out.write(frame.iloc[:100])
            raise RuntimeError("stop")
    assert path.read_bytes() == b"old content" and [p.name for p in tmp_path.iterdir()] == [name]


def test_chunk_writer_interrupted_while_closing_leaves_no_finalizer_error(tmp_path, monkeypatch):
    # SIGTERM (a KeyboardInterrupt) inside pyarrow's close: the temporary file is removed, and
    # the garbage collector must not close the writer again on the closed file.
    import gc

    import pyarrow.parquet as pa_pq

    real_close = pa_pq.ParquetWriter.close

    def interrupted_close(self):
        real_close(self)
        self.is_open = True  # as if the signal landed before pyarrow marked it closed
        raise KeyboardInterrupt

    monkeypatch.setattr(pa_pq.ParquetWriter, "close", interrupted_close)
    unraisable = []
    monkeypatch.setattr(sys, "unraisablehook", unraisable.append)
    with pytest.raises(KeyboardInterrupt):
        with ChunkWriter(tmp_path / "out.parquet") as out:
            out.write(_output_frame().iloc[:100])
    out = None
    gc.collect()
    assert unraisable == [] and list(tmp_path.iterdir()) == []


def test_chunk_writer_read_error_inside_leaves_nothing(tmp_path):
    path = _write(tmp_path, _rows(300, {200: "20.0,abc,20,1"}), "in.csv")
    with pytest.raises(LogFormatError, match="line 202"):
        with ChunkWriter(tmp_path / "out.csv") as out, iter_log_chunks(path, chunk_rows=64) as chunks:
            for chunk in chunks:
                out.write(chunk)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.csv"]


def test_chunk_writer_misuse(tmp_path):
    frame = _output_frame(10)
    with pytest.raises(ValueError, match="differ"):
        with ChunkWriter(tmp_path / "o.csv") as out:
            out.write(frame)
            out.write(frame[frame.columns[::-1]])
    with pytest.raises(ConfigError, match="no chunk"):
        with ChunkWriter(tmp_path / "o.csv"):
            pass
    with pytest.raises(ConfigError, match="types"):
        with ChunkWriter(tmp_path / "o.parquet") as out:
            out.write(pd.DataFrame({"n": [1, 2]}))
            out.write(pd.DataFrame({"n": ["x", "y"]}))
    with pytest.raises(ConfigError):
        ChunkWriter(tmp_path / "o.xlsx")
    with pytest.raises(ConfigError, match="does not exist"):
        with ChunkWriter(tmp_path / "nodir" / "o.csv"):
            pass
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------
# memory (not in CI: pytest -m slow)
# ---------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/status").is_file(), reason="needs Linux /proc")
def test_peak_memory_does_not_grow_with_the_file(tmp_path):
    """2 M rows read and written in 100 k-row chunks, in a fresh process: peak RSS well
    under the file's size in memory."""
    n = 2_000_000
    rng = np.random.default_rng(0)
    frame = pd.DataFrame(
        {"t": np.arange(n) * 1e-3, "gyro_z": rng.standard_normal(n), "temp": 20 + rng.standard_normal(n),
         "heading": np.where(np.arange(n) % 100 == 0, rng.uniform(0, 360, n), np.nan)}
    )
    write_table(frame, tmp_path / "big.csv")
    del frame
    # VmHWM: the peak of this process's own memory (ru_maxrss can carry the parent's over fork)
    script = textwrap.dedent(
        f"""
        import re
        from gyrodrift.io.chunked import ChunkWriter, iter_log_chunks
        with ChunkWriter({str(tmp_path / 'out.parquet')!r}) as out:
            for chunk in iter_log_chunks({str(tmp_path / 'big.csv')!r}, chunk_rows=100_000):
                out.write(chunk)
        print(re.search(r"VmHWM:\\s*(\\d+) kB", open("/proc/self/status").read()).group(1))
        """
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    peak_kib = int(subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True, env=env).stdout)
    assert peak_kib < 300 * 1024, f"peak RSS {peak_kib / 1024:.0f} MiB"
    assert pq.ParquetFile(tmp_path / "out.parquet").metadata.num_rows == n
