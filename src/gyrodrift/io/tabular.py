"""Read input logs (CSV or Parquet) whole in the gyrodrift input contract; write result tables.

:func:`read_log` turns a user's log into a validated :class:`pandas.DataFrame` in the
units and frames of :mod:`gyrodrift.conventions`, with the checks, conversions and
one-line error messages of :mod:`gyrodrift.io.validate`.

:func:`write_table` writes a DataFrame as CSV or Parquet atomically, and
:func:`check_output_path` refuses an output path that is the input log.

:mod:`gyrodrift.io.chunked` reads and writes the same tables in chunks. Both share the
per-frame checks and conversions (:func:`gyrodrift.io.validate.normalise_frame`), the
CSV reading options and formatting (:mod:`gyrodrift.io.csvfile`) and the Parquet
settings (:mod:`gyrodrift.io.parquetfile`), so both paths give identical results.
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
from gyrodrift.errors import ConfigError
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
    message,
    no_data_rows_error,
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


def read_log(
    path,
    *,
    fmt: str | None = None,
    gyro_unit: str = "deg/s",
    frame: str | None = None,
    column_map: Mapping[str, str] | None = None,
    time_unit: str | None = None,
    gyro_max_dps: float = GYRO_MAX_DPS,
) -> pd.DataFrame:
    """Read and validate an input log; return it in contract units and frames.

    Parameters
    ----------
    path : str or os.PathLike
        CSV (``.csv``, ``.csv.gz``, ``.txt``, ``.txt.gz``) with a header row, or
        Parquet (``.parquet``, ``.pq``). Gzip-compressed CSV is recognised by content.
    fmt : {"csv", "parquet"}, optional
        Table format; overrides the file-name ending.
    gyro_unit : {"deg/s", "dps", "rad/s"}, default "deg/s"
        Unit of the gyro columns ``gyro_x``, ``gyro_y``, ``gyro_z`` in the file (and of
        their simulated biases ``true_bias_x``, ``true_bias_y``, ``true_bias_z``). Output is
        always deg/s.
    frame : {"ned", "enu"}, optional
        Axis convention of the file. ``"enu"`` (ROS REP-103, body FLU) is converted to
        NED/FRD: ``heading`` and ``ref_heading`` become ``wrap_360(90 - value)``; the y
        and z components (``gyro_y``, ``gyro_z``, ``true_bias_y``, ``true_bias_z``,
        ``mag_y``, ``mag_z``, ``acc_y``, ``acc_z``) change sign. Default NED/FRD, and a
        table whose accelerometer shows its z axis pointing up is then refused, naming
        ``--frame enu`` (:func:`gyrodrift.io.validate.check_z_up`); ``"ned"`` given reads
        it as it is (a unit lying upside down).
    column_map : mapping of str to str, optional
        ``{NEW: OLD}``: rename input column OLD to contract name NEW before validation.
    time_unit : {"s", "ms", "us", "ns"}, optional
        Unit of ``t`` in the file; ``t`` is converted to s. Without it ``t`` is read as
        s, and time stamps that look like another unit are refused naming the unit to
        give (:mod:`gyrodrift.io.timebase`, decided on the whole file here and on the
        first chunk by :func:`gyrodrift.io.chunked.iter_log_chunks`).
    gyro_max_dps : float, default :data:`gyrodrift.io.limits.GYRO_MAX_DPS` (10000)
        Plausible full scale of the gyro axes, deg/s: a larger rate is refused like an
        implausible temperature (:mod:`gyrodrift.io.limits` lists every plausible range).

    Returns
    -------
    pandas.DataFrame
        All input columns in file order (renamed, names stripped). Numeric contract
        columns are float64 with empty cells NaN, headings in [0, 360); others pass
        through. ``df.attrs``: ``source``, ``format``, ``gyro_unit``, ``frame``,
        ``compass`` ("heading", "mag", "both" or "none") and ``notes`` when the log
        lacks a compass or a temperature. Without a usable ``temp``, ``temp`` is 0.0
        in every row.

    Raises
    ------
    LogFormatError
        The file is missing, empty, not a table, ragged, lacks ``t`` or ``gyro_z``, or
        holds bad values (non-numbers, inf, a non-increasing ``t``, a value outside
        :mod:`gyrodrift.io.limits`, a first row without ``gyro_z``/``temp``). Later
        empty ``gyro_z``/``temp`` cells stay NaN.
    ConfigError
        An unknown ``fmt``, ``gyro_unit`` or ``frame``, an undecidable file-name ending,
        or a ``column_map`` naming a column the file lacks.

    Notes
    -----
    Messages are one line: ``<file>: line N, column 'c': <problem>; <what to do>``
    for CSV (line numbers as an editor shows them, header = line 1) and
    ``data row N`` (1-based) for Parquet.
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
    """Write ``df`` as UTF-8 CSV (no index, shortest round-trip floats, NaN as an empty
    cell) to a binary file.

    pyarrow formats the values (about ten times faster than pandas), see
    :func:`write_csv_rows`; pandas writes tables pyarrow cannot convert or print.
    """
    table = csv_table(df)
    if table is None or not write_csv_rows(table, sink, csv_header(df.columns)):
        write_csv_with_pandas(df, sink, header=True)


def _write_parquet(df: pd.DataFrame, sink) -> None:
    """Write ``df`` as Parquet (no index) to a binary file."""
    table = arrow_table(df)
    pa_pq.write_table(table, sink, **parquet_options(table.schema))


def formula_safe(df: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``df`` whose text cells and column names that start like a formula
    (:data:`FORMULA_STARTS`) get a leading ``'``, so that a spreadsheet shows them as
    text; number columns are left as they are (:mod:`gyrodrift.io.formula`, which every
    CSV writer applies)."""
    return formula_safe_frame(df)


def write_table(df: pd.DataFrame, path, *, fmt: str | None = None, spreadsheet_safe: bool = False) -> None:
    """Write a DataFrame as CSV or Parquet, atomically.

    Through a temporary file and :func:`os.replace`: readers never see a partial file,
    and ``path`` is untouched if writing fails.

    Parameters
    ----------
    df : pandas.DataFrame
        Table to write; the index is not written.
    path : str or os.PathLike
        Destination; its ending (``.csv``, ``.parquet``, ``.pq``) picks the format.
    fmt : {"csv", "parquet"}, optional
        Table format; overrides the file-name ending.
    spreadsheet_safe : bool, default False
        Kept for callers that ask for it: every CSV is written with its formula-like
        text cells and names quoted (:func:`formula_safe`); ``df`` itself is not changed.

    Raises
    ------
    ConfigError
        Unknown format or file-name ending, missing destination directory, a
        destination that is a directory, or an OS error while writing.
    """
    path = Path(path)
    table_fmt = table_format(path, fmt, WRITE_SUFFIXES)
    writer: Callable[[pd.DataFrame, object], None] = _write_csv if table_fmt == "csv" else _write_parquet
    with atomic_path(path) as tmp, open_sink(tmp) as sink:  # pyarrow's file: no GIL, no copy
        writer(df, sink)


def check_output_path(in_path, out_path) -> None:
    """Refuse an output path that is the input log itself.

    Parameters
    ----------
    in_path, out_path : str or os.PathLike
        Input log and planned output file.

    Raises
    ------
    ConfigError
        If both resolve to the same file (same real path, or the same file through a
        hard link when both exist).
    """
    from gyrodrift._paths import same_file

    if same_file(in_path, out_path):
        raise ConfigError(
            message(
                str(out_path),
                f"output file is the input log {str(in_path)!r}",
                "the input is never overwritten: choose another -o",
            )
        )
