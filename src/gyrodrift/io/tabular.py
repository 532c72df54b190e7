"""Read input logs (CSV or Parquet) whole in the gyrodrift input contract; write result tables.

:func:`read_log` checks and converts a table as docs/log-formats.md, section "Tables: CSV
and Parquet", describes; :func:`write_table` and :func:`check_output_path` write results
(section "Writing tables"). :mod:`gyrodrift.io.chunked` does both in chunks with the same code.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Callable, Mapping

import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pa_pq

from gyrodrift._atomic import atomic_path
from gyrodrift.io.csvfile import (
    CSV_EMPTY_ADVICE,
    UTF8_BOM,
    check_csv_text,
    csv_convert_options,
    csv_header,
    csv_header_names,
    csv_parse_error,
    csv_table,
    decompress_if_gzip,
    header_line,
    ragged_row_error,
    write_csv_rows,
    write_csv_with_pandas,
)
from gyrodrift.io.formula import FORMULA_STARTS, formula_safe_frame
from gyrodrift.io.limits import GYRO_MAX_DPS
from gyrodrift.io.formats import READ_SUFFIXES, WRITE_SUFFIXES, table_format
from gyrodrift.io.held import held_note
from gyrodrift.io.notes import add_note
from gyrodrift.io.parquetfile import arrow_table, check_parquet_size, open_sink, parquet_error, parquet_options
from gyrodrift.io.messages import (
    Source,
    check_input_path,
    empty_file_error,
    no_data_rows_error,
    option_error,
    physical_line,
    read_error,
)
from gyrodrift.io.notes import compass_form, table_notes
from gyrodrift.io.validate import normalise_frame, read_options, table_to_frame

__all__ = ["read_log", "write_table", "check_output_path", "FORMULA_STARTS", "formula_safe"]


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------


def _read_bytes(path: Path) -> bytes:
    """Read the whole file, turning OS errors into one-line :class:`~gyrodrift.errors.LogFormatError`."""
    try:
        return path.read_bytes()
    except OSError as exc:
        raise read_error(path, exc) from exc


def _read_csv_table(path: Path, column_map: Mapping[str, str]) -> tuple[pa.Table, Source]:
    """Read a CSV (optionally gzip-compressed) into a pyarrow table, strictly."""
    name = str(path)
    data = decompress_if_gzip(_read_bytes(path), name)
    if data.startswith(UTF8_BOM):
        data = data[len(UTF8_BOM) :]  # UTF-8 byte-order mark written by some spreadsheet programs
    if not data.strip():
        raise empty_file_error(name, CSV_EMPTY_ADVICE)
    check_csv_text(data, name)
    src = Source(name, "csv", functools.partial(physical_line, (data,)))
    names = csv_header_names(header_line(data, at_end=True))

    ragged = []

    def on_invalid_row(row) -> str:
        ragged.append(row)
        return "error"

    def read(numbers_as_text: bool) -> pa.Table:
        return pa_csv.read_csv(
            pa.BufferReader(data),
            read_options=pa_csv.ReadOptions(use_threads=False),
            parse_options=pa_csv.ParseOptions(invalid_row_handler=on_invalid_row),
            convert_options=csv_convert_options(names, column_map, numbers_as_text=numbers_as_text),
        )

    try:
        try:
            table = read(numbers_as_text=False)
        except pa.ArrowInvalid:
            if ragged:
                raise
            table = read(numbers_as_text=True)  # a number column holds text
    except (pa.ArrowException, ValueError) as exc:
        if ragged:
            raise ragged_row_error(src, ragged[0]) from exc
        raise csv_parse_error(src, exc) from exc
    if table.num_rows == 0:
        raise no_data_rows_error(src)
    return table, src


def _read_parquet_table(path: Path) -> tuple[pa.Table, Source]:
    """Read a Parquet file into a pyarrow table."""
    src = Source(str(path), "parquet", None)
    check_parquet_size(path)
    try:
        table = pa_pq.read_table(path)
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise parquet_error(src, exc) from exc
    if table.num_rows == 0:
        raise no_data_rows_error(src)
    return table, src


def read_log(path, *, fmt: str | None = None, gyro_unit: str = "deg/s", frame: str | None = None,
             column_map: Mapping[str, str] | None = None, time_unit: str | None = None,
             gyro_max_dps: float = GYRO_MAX_DPS) -> pd.DataFrame:
    """Read and validate a CSV or Parquet log; return it in contract units and frames.

    See docs/log-formats.md, section "Tables: CSV and Parquet", for every check and
    conversion, and section "Messages" for the wording of the errors.

    Parameters
    ----------
    path : str or os.PathLike
        CSV (``.csv``, ``.csv.gz``, ``.txt``, ``.txt.gz``) with a header row, or Parquet
        (``.parquet``, ``.pq``).
    fmt : {"csv", "parquet"}, optional
        Table format; overrides the file-name ending.
    gyro_unit : {"deg/s", "dps", "rad/s"}, default "deg/s"
        Unit of the gyro columns (and ``true_bias_*``) in the file; output is deg/s.
    frame : {"ned", "enu"}, optional
        Axis convention of the file; ``"enu"`` (ROS REP-103) is converted to NED/FRD.
        Default NED/FRD, with a table whose accelerometer shows z up refused.
    column_map : mapping of str to str, optional
        ``{NEW: OLD}``: rename input column OLD to contract name NEW first.
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of ``t`` in the file (docs/log-formats.md, section "Time base").
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s (:mod:`gyrodrift.io.limits`).

    Returns
    -------
    pandas.DataFrame
        All input columns in file order, numeric contract columns float64; ``attrs``:
        ``source``, ``format``, ``gyro_unit``, ``frame``, ``compass`` and ``notes``.

    Raises
    ------
    LogFormatError
        The file is missing, empty, not a table, ragged, lacks ``t`` or ``gyro_z``, or
        holds a bad value.
    ConfigError
        An unknown ``fmt``, ``gyro_unit``, ``frame`` or ending, or a bad ``column_map``.
    """
    path = Path(path)
    opts = read_options(gyro_unit, frame, column_map, time_unit, gyro_max_dps)
    check_input_path(path)
    table_fmt = table_format(path, fmt, READ_SUFFIXES)
    if table_fmt == "csv":
        table, src = _read_csv_table(path, opts.renames)
    else:
        table, src = _read_parquet_table(path)

    df, with_values, temperature, first_notes, held, _ = normalise_frame(table_to_frame(table, src), src, opts)
    df.attrs = {
        "source": str(path),
        "format": table_fmt,
        "gyro_unit": opts.gyro_unit,
        "frame": opts.frame,
        "compass": compass_form(with_values),
    }
    held_notes = filter(None, [held_note(src.name, held)])
    for note in [*table_notes(src.name, df.columns, with_values, temperature), *first_notes, *held_notes]:
        add_note(df.attrs, note)
    return df


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------


def _write_csv(df: pd.DataFrame, sink) -> None:
    """Write ``df`` as UTF-8 CSV (no index) to a binary file: pyarrow prints it, or pandas
    what pyarrow cannot convert or print."""
    table = csv_table(df)
    if table is None or not write_csv_rows(table, sink, csv_header(df.columns)):
        write_csv_with_pandas(df, sink, header=True)


def _write_parquet(df: pd.DataFrame, sink) -> None:
    """Write ``df`` as Parquet (no index) to a binary file."""
    table = arrow_table(df)
    pa_pq.write_table(table, sink, **parquet_options(table.schema))


def formula_safe(df: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``df`` with its text cells and names that start like a formula quoted with ``'``
    (:mod:`gyrodrift.io.formula`, which every CSV writer applies)."""
    return formula_safe_frame(df)


def write_table(df: pd.DataFrame, path, *, fmt: str | None = None, spreadsheet_safe: bool = False) -> None:
    """Write a DataFrame as CSV or Parquet, atomically (docs/log-formats.md, section "Writing tables").

    Parameters
    ----------
    df : pandas.DataFrame
        Table to write; the index is not written.
    path : str or os.PathLike
        Destination; its ending (``.csv``, ``.parquet``, ``.pq``) picks the format.
    fmt : {"csv", "parquet"}, optional
        Table format; overrides the file-name ending.
    spreadsheet_safe : bool, default False
        Kept for callers that ask for it: every CSV is written spreadsheet-safe.

    Raises
    ------
    ConfigError
        Unknown format or ending, missing destination directory, a destination that is a
        directory, or an OS error while writing.
    """
    path = Path(path)
    table_fmt = table_format(path, fmt, WRITE_SUFFIXES)
    writer: Callable[[pd.DataFrame, object], None] = _write_csv if table_fmt == "csv" else _write_parquet
    with atomic_path(path) as tmp, open_sink(tmp) as sink:  # pyarrow's file: no GIL, no copy
        writer(df, sink)


def check_output_path(in_path, out_path) -> None:
    """Refuse (:class:`ConfigError`) an output path that is the input log itself: the same
    real path, or the same file through a hard link."""
    from gyrodrift._paths import same_file

    if same_file(in_path, out_path):
        raise option_error(str(out_path), f"output file is the input log {str(in_path)!r}",
                           "the input is never overwritten: choose another -o")
