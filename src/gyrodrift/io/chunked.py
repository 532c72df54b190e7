"""Read and write CSV and Parquet tables in chunks, in constant memory.

:func:`iter_log_chunks` reads a log in the input contract chunk by chunk, and
:class:`ChunkWriter` writes a result table chunk by chunk, atomically. Both go through
the same code as the whole-table functions of :mod:`gyrodrift.io.tabular`
(:func:`~gyrodrift.io.tabular.read_log`, :func:`~gyrodrift.io.tabular.write_table`), so:

* the chunks of a log, concatenated (``pd.concat(chunks)``), equal ``read_log(path)``:
  same columns, dtypes, values (bit for bit) and index; every check of ``read_log``
  runs, and a problem is reported with the same one-line message, naming the line
  (CSV) or data row (Parquet) in the whole file;
* a table written in chunks reads back as ``write_table`` of the whole table writes it
  (and for CSV the file is byte for byte the same).

What a chunked reader cannot know in advance, and what it does about it:

* **Which compass form the log has** (``df.attrs["compass"]`` of ``read_log``) is known
  after the last chunk: :attr:`LogChunks.compass`, and so are the notes
  (``df.attrs["notes"]`` of ``read_log``: no compass, no temperature, held compass values
  emptied; a low sample rate, decided on the first chunk):
  :attr:`LogChunks.notes`. A log whose compass columns are empty in every row has
  compass "none", as ``read_log`` says; its chunks keep those columns as read.
* **A required column empty at the start** (``gyro_z``/``temp`` missing on the first
  row, or ``t``/``gyro_z``/``temp`` empty in the whole first chunk): before it hands
  out the first chunk, the reader reads the file again from the start, on a reader of
  its own, until the column's first value (to the end if it has none): to give
  ``read_log``'s message and raise, or, for a ``temp`` empty in every row, to fill it
  with 0.0 in every chunk as ``read_log`` does. Such a file is read twice. A file
  without a ``temp`` column is seen from its header (CSV) or schema (Parquet): ``temp``
  is 0.0 in every chunk, the last column.
* **Types of the other columns of a CSV** (pass-through columns, not numeric contract
  columns): ``read_log`` lets pyarrow infer them from the whole file; the chunked
  reader infers them from the first ``block_size_bytes`` (1 MiB) of the file. A later value
  that does not fit (an integer column holding ``1.5`` on line 3 000 000, or a column
  empty at the start) raises :class:`ColumnTypeChanged` (a
  :class:`~gyrodrift.errors.LogFormatError`) naming the line and column and asking for
  the ``column_types`` option (:func:`gyrodrift.pipeline.compensate_file` reads the file
  again with the type it suggests, and says so); with it the chunks equal
  ``read_log`` whenever the type given is the one pyarrow infers from the whole file.
  An integer column with empty cells only in later chunks comes out int64 in the
  first chunks and float64 in the others (``pd.concat`` gives ``read_log``'s float64);
  Parquet files state their types, and such columns are float64 in every chunk.
* **Several problems in one file**: ``read_log`` checks the whole file one kind of
  problem after another (non-numbers in any row first, then time, temperature); the
  chunked reader does the same within a chunk and reports the first chunk's problem
  first. A file with one problem gets the same message either way.

Numbers in a CSV are read as float64 by pyarrow; when a number column holds text
pyarrow cannot read as a number (``None``, ``n/a`` with spaces, or a bad cell), the
reader reopens the file at the current row and reads the number columns as text from
there, converting each cell with the same parser (this re-reads the rows before, once).
Memory grows with ``chunk_rows`` (not with the file): reading a CSV of six number
columns peaked at about 470 MiB of RSS with 1 000 000-row chunks and 260 MiB with
250 000-row chunks (about 110 MiB of which is Python, pandas and pyarrow themselves).
"""

from __future__ import annotations

import codecs
import gzip
import io
import re
from pathlib import Path
from typing import Iterator, Mapping, NamedTuple

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pa_pq

from gyrodrift.conventions import T
from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io import csvfile, formats, messages, notes, parquetfile, validate
from gyrodrift.io.chunkwriter import ChunkWriter
from gyrodrift.io.held import held_note
from gyrodrift.io.limits import GYRO_MAX_DPS

__all__ = ["iter_log_chunks", "LogChunks", "ChunkWriter", "LogSummary", "log_summary", "ColumnTypeChanged"]


class ColumnTypeChanged(LogFormatError):
    """A cell of a pass-through CSV column does not fit the type the first block gave it.

    Attributes
    ----------
    column : str
        The column's name (after the column map).
    value : str
        The cell's text.
    suggested_type : str
        ``"float64"`` when the cell is a number (a column of whole numbers that turns
        out to have fractions), else ``"string"``: a ``column_types`` entry that reads
        the whole column.
    """

    def __init__(self, message: str, column: str, value: str):
        super().__init__(message)
        self.column = column
        self.value = value
        try:
            float(value)
            self.suggested_type = "float64"
        except ValueError:
            self.suggested_type = "string"


#: Bytes pyarrow reads from a CSV at a time; the types of pass-through columns are
#: inferred from the first block.
DEFAULT_BLOCK_SIZE_BYTES = 1 << 20
_READ_PIECE_BYTES = 1 << 20
#: pyarrow's message for a CSV cell that does not fit its column's type.
_CONVERSION_ERROR = re.compile(
    r"In CSV column #(?P<col>\d+): Row #(?P<row>\d+): CSV conversion error to (?P<type>[^:]+): invalid value '(?P<value>.*)'$",
    re.DOTALL,
)


# ---------------------------------------------------------------------------
# CSV text, checked as it is read
# ---------------------------------------------------------------------------


class _CsvText(io.RawIOBase):
    """The text of a CSV file as pyarrow reads it: gzip decompressed (recognised by
    content), byte-order mark dropped, and checked piece by piece as ``read_log``
    checks the whole text (NUL bytes, UTF-8), with the same messages."""

    def __init__(self, path: Path, *, check: bool = True) -> None:
        super().__init__()
        self._name = str(path)
        self._check = check
        try:
            self._file = open(path, "rb")  # noqa: SIM115 - closed in close()
            self._gzip = self._file.read(2) == csvfile.GZIP_MAGIC
            self._file.seek(0)
        except OSError as exc:
            raise messages.read_error(path, exc) from exc
        self._source = gzip.GzipFile(fileobj=self._file, mode="rb") if self._gzip else self._file
        self._decoder = codecs.getincrementaldecoder("utf-8")()
        self._lines_before = 0  # "\n" handed out so far, for error lines
        self._ahead = b""  # read and checked, not handed out yet
        self._started = False
        self._at_end = False

    def readable(self) -> bool:
        return True

    def _next_piece(self, size: int) -> bytes:
        """Read, check and return the next piece of text (b"" at the end)."""
        if self._at_end:
            return b""
        try:
            piece = self._source.read(size)
        except csvfile.GZIP_ERRORS as exc:
            if self._gzip:
                raise csvfile.gzip_error(self._name, exc) from exc
            raise messages.read_error(self._name, exc) from exc
        if not self._started:  # the first read asks for at least _READ_PIECE_BYTES
            self._started = True
            if piece.startswith(csvfile.UTF8_BOM):
                piece = piece[len(csvfile.UTF8_BOM) :]
                if not piece:
                    return self._next_piece(size)
        self._at_end = not piece
        if self._check:
            csvfile.check_csv_text(
                piece, self._name, lines_before=self._lines_before, decoder=self._decoder, final=self._at_end
            )
        self._lines_before += piece.count(b"\n")
        return piece

    def read(self, size: int = -1) -> bytes:
        if size is None or size < 0:
            size = _READ_PIECE_BYTES
        if not self._started:  # the first piece is large enough to hold a byte-order mark
            self._ahead = self._next_piece(max(size, _READ_PIECE_BYTES))
        if self._ahead:
            out, self._ahead = self._ahead[:size], self._ahead[size:]
            return out
        return self._next_piece(max(size, 1))

    def readinto(self, buffer) -> int:
        data = self.read(len(buffer))
        buffer[: len(data)] = data
        return len(data)

    def header_line(self) -> bytes:
        """Read ahead to the header line (the first non-empty line) and return it,
        raising ``read_log``'s error for a file with no text."""
        while True:
            if self._ahead.strip():
                line = csvfile.header_line(self._ahead, at_end=self._at_end)
                if line is not None:
                    return line
            elif self._at_end:
                raise messages.empty_file_error(self._name, csvfile.CSV_EMPTY_ADVICE)
            self._ahead += self._next_piece(_READ_PIECE_BYTES)

    def pieces(self) -> Iterator[bytes]:
        """The remaining text, piece by piece."""
        while piece := self.read(_READ_PIECE_BYTES):
            yield piece

    def close(self) -> None:
        if not self.closed:
            try:
                if self._gzip:
                    self._source.close()
                self._file.close()
            finally:
                super().close()


def _csv_line_of(path: Path):
    """``line_of`` for a CSV file read in chunks: re-reads the file up to the line (on error only)."""

    def line_of(nonempty_index: int) -> int:
        with _CsvText(path, check=False) as text:
            return messages.physical_line(text.pieces(), nonempty_index)

    return line_of


# ---------------------------------------------------------------------------
# batches of rows
# ---------------------------------------------------------------------------


def _rechunk(batches: Iterator[pa.RecordBatch], rows: int) -> Iterator[pa.Table]:
    """Tables of exactly ``rows`` rows (the last one fewer) from consecutive batches; a
    batch with another schema than the ones before it starts a new table."""
    held: list[pa.RecordBatch] = []
    count = 0
    for batch in batches:
        if held and not batch.schema.equals(held[0].schema):
            yield pa.Table.from_batches(held)
            held, count = [], 0
        while batch.num_rows:
            take = min(rows - count, batch.num_rows)
            held.append(batch.slice(0, take))
            count += take
            batch = batch.slice(take)
            if count == rows:
                yield pa.Table.from_batches(held)
                held, count = [], 0
    if count:
        yield pa.Table.from_batches(held)


def _type_of(value) -> pa.DataType:
    """A pyarrow type from a type or its name (``"float64"``, ``"string"``, ...)."""
    if isinstance(value, pa.DataType):
        return value
    try:
        return pa.type_for_alias(str(value))
    except (ValueError, KeyError) as exc:
        raise ConfigError(f"column_types: unknown type {value!r}; use a pyarrow type or a name such as 'float64', 'int64', 'string'") from exc


class _CsvBatches:
    """Record batches of a CSV file, read with pyarrow's streaming reader.

    Number columns are read as float64 until a cell needs the text path; the reader is
    then reopened at the next row with those columns as text (see the module notes).
    The types of other columns are fixed by the first block (or ``column_types``).
    """

    def __init__(self, path: Path, renames: Mapping[str, str], column_types, block_size_bytes: int) -> None:
        self.path = path
        self.src = messages.Source(str(path), "csv", _csv_line_of(path))
        self._renames = renames
        self._block_size = int(block_size_bytes)
        with _CsvText(path) as text:
            self._names = csvfile.csv_header_names(text.header_line())
        self._pinned = self._raw_types(column_types or {})

    def _raw_types(self, column_types: Mapping[str, object]) -> dict[str, pa.DataType]:
        """``column_types`` (names after the column map) keyed by header names."""
        new_name = {old: new for new, old in self._renames.items()}
        final = {raw: new_name.get(raw.strip(), raw.strip()) for raw in self._names}
        out = {}
        for name, kind in column_types.items():
            raws = [raw for raw, new in final.items() if new == name]
            if not raws:
                raise ConfigError(
                    messages.message(
                        self.src.name,
                        f"column_types names column {name!r}, which the file does not have;"
                        f" columns found: {messages.show_names(final.values())}",
                        "name columns as they are after the column map",
                    )
                )
            if name in validate.NUMERIC_COLS:
                raise ConfigError(
                    messages.message(
                        self.src.name,
                        f"column_types names {name!r}, a number column of the input contract, which is always read"
                        " as numbers",
                        "leave it out of column_types",
                    )
                )
            out.update({raw: _type_of(kind) for raw in raws})
        return out

    def _type_error(self, exc: pa.ArrowInvalid) -> LogFormatError:
        """The error for a cell that does not fit the type of its (pass-through) column."""
        found = _CONVERSION_ERROR.search(str(exc))
        if found is None or int(found["col"]) >= len(self._names):
            return csvfile.csv_parse_error(self.src, exc)
        name = self._names[int(found["col"])].strip()
        name = next((new for new, old in self._renames.items() if old == name), name)
        plain = messages.format_error(
            self.src,
            f"{messages.show_text(found['value'])} does not fit the type {found['type']} that the first"
            f" {self._block_size} bytes of the file gave this column (a file read in chunks cannot look ahead)",
            f"give the column's type with the column_types option, e.g. column_types={{{name!r}: 'string'}}",
            where=f"line {self.src.line_of(int(found['row']))}, column {name!r}",
        )
        return ColumnTypeChanged(str(plain), name, str(found["value"]))

    def _other_column_failed(self, exc: pa.ArrowInvalid) -> bool:
        """True if pyarrow names a cell of a column that is not a number column."""
        found = _CONVERSION_ERROR.search(str(exc))
        if found is None or int(found["col"]) >= len(self._names):
            return False
        return self._names[int(found["col"])] not in csvfile.numeric_raw_names(self._names, self._renames)

    def again(self) -> Iterator[pa.RecordBatch]:
        """The batches from the start of the file, on a reader of their own (the file is
        opened again; the types the first block gave are kept)."""
        return iter(self)

    def __iter__(self) -> Iterator[pa.RecordBatch]:
        numbers_as_text = False
        delivered = 0  # data rows handed out
        while True:
            ragged = []

            def on_invalid_row(row, ragged=ragged) -> str:
                ragged.append(row)
                return "error"

            with _CsvText(self.path) as text:
                try:
                    reader = pa_csv.open_csv(
                        text,
                        read_options=pa_csv.ReadOptions(use_threads=False, block_size=self._block_size),
                        parse_options=pa_csv.ParseOptions(invalid_row_handler=on_invalid_row),
                        convert_options=csvfile.csv_convert_options(
                            self._names, self._renames, numbers_as_text=numbers_as_text, column_types=self._pinned
                        ),
                    )
                    # later readers keep the types the first block gave the other columns
                    numeric = csvfile.numeric_raw_names(self._names, self._renames)
                    for field in reader.schema:
                        if field.name not in numeric:
                            self._pinned.setdefault(field.name, field.type)
                    skip = delivered  # rows handed out before reopening (skip_rows_after_names would count blank lines)
                    for batch in reader:
                        if skip:
                            dropped = min(skip, batch.num_rows)
                            batch, skip = batch.slice(dropped), skip - dropped
                            if not batch.num_rows:
                                continue
                        delivered += batch.num_rows
                        yield batch
                    return
                except LogFormatError:
                    raise  # from the text checks
                except pa.ArrowInvalid as exc:
                    if ragged:
                        raise csvfile.ragged_row_error(self.src, ragged[0]) from exc
                    if not numbers_as_text and not self._other_column_failed(exc):
                        numbers_as_text = True  # a number column holds text: read on from this row as text
                        continue
                    raise self._type_error(exc) from exc
                except (pa.ArrowException, ValueError) as exc:
                    raise csvfile.csv_parse_error(self.src, exc) from exc


class _ParquetBatches:
    """Record batches of a Parquet file (:meth:`pyarrow.parquet.ParquetFile.iter_batches`),
    with what the whole file says about pass-through columns (see :meth:`fix_frame`)."""

    def __init__(self, path: Path, batch_rows: int) -> None:
        self.path = path
        self.src = messages.Source(str(path), "parquet", None)
        parquetfile.check_parquet_size(path)
        self._batch_rows = batch_rows
        try:
            # pre_buffer=False: otherwise pyarrow buffers the byte ranges of every row group
            # it will read, i.e. the whole file (1.3 GB of memory for a 1.1-GB file, measured)
            self._file = pa_pq.ParquetFile(path, pre_buffer=False)
            schema = self._file.schema_arrow
            # pandas turns integer/boolean columns with an empty cell anywhere into
            # float64/object, and unites the categories of dictionary columns
            self._has_nulls = {
                field.name: self._any_null(field.name)
                for field in schema
                if pa.types.is_integer(field.type) or pa.types.is_boolean(field.type)
            }
            self._categories = {
                field.name: self._all_categories(field.name) for field in schema if pa.types.is_dictionary(field.type)
            }
        except (pa.ArrowException, OSError, ValueError) as exc:
            raise parquetfile.parquet_error(self.src, exc) from exc
        if self._file.metadata.num_rows == 0:
            raise messages.no_data_rows_error(self.src)

    def _any_null(self, name: str) -> bool:
        """True if column ``name`` has an empty cell (statistics, else read the column)."""
        meta = self._file.metadata
        paths = [meta.schema.column(j).path for j in range(meta.num_columns)]
        if name in paths:
            stats = [meta.row_group(g).column(paths.index(name)).statistics for g in range(meta.num_row_groups)]
            if all(st is not None and st.has_null_count for st in stats):
                return any(st.null_count for st in stats)
        return any(b.column(0).null_count for b in self._file.iter_batches(self._batch_rows, columns=[name]))

    def _all_categories(self, name: str) -> list:
        """The categories pandas gives column ``name`` read whole: the dictionaries of all
        batches united, in order of appearance."""
        seen: dict = {}
        for batch in self._file.iter_batches(self._batch_rows, columns=[name]):
            for value in batch.column(0).dictionary.to_pylist():
                seen.setdefault(value, None)
        return list(seen)

    def __iter__(self) -> Iterator[pa.RecordBatch]:
        try:
            yield from self._file.iter_batches(self._batch_rows)
        except (pa.ArrowException, OSError, ValueError) as exc:
            raise parquetfile.parquet_error(self.src, exc) from exc

    def again(self) -> Iterator[pa.RecordBatch]:
        """The batches from the start of the file, on a reader of their own (the file is
        opened again)."""
        try:
            with pa_pq.ParquetFile(self.path, pre_buffer=False) as file:
                yield from file.iter_batches(self._batch_rows)
        except (pa.ArrowException, OSError, ValueError) as exc:
            raise parquetfile.parquet_error(self.src, exc) from exc

    def fix_frame(self, frame: pd.DataFrame, names: list[str]) -> pd.DataFrame:
        """Give a chunk's pass-through columns the dtypes of the whole file (``names``:
        the file's column names, in the order of ``frame``'s columns)."""
        for pos, name in enumerate(names):
            if self._has_nulls.get(name):
                column = frame.iloc[:, pos]
                if pd.api.types.is_integer_dtype(column.dtype):
                    frame.isetitem(pos, column.astype(np.float64))
                elif pd.api.types.is_bool_dtype(column.dtype):
                    frame.isetitem(pos, column.astype(object))
            elif name in self._categories:
                frame.isetitem(pos, frame.iloc[:, pos].cat.set_categories(self._categories[name]))
        return frame

    def close(self) -> None:
        self._file.close()


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------


class LogChunks:
    """The chunks of a log in the input contract; an iterator of DataFrames (see
    :func:`iter_log_chunks`). Use it in a ``with`` block, or call :meth:`close`, to
    close the file when the chunks are not read to the end.

    Attributes
    ----------
    source : str
        The path as given.
    format : {"csv", "parquet"}
    gyro_unit, frame : str
        The options, canonical (as ``read_log`` puts them in ``df.attrs``).
    rows : int
        Data rows handed out so far.
    compass : {"heading", "mag", "both", "none"} or None
        The compass forms holding data in the whole file (``read_log``'s
        ``df.attrs["compass"]``); None until the last chunk has been read.
    notes : list of str or None
        What the file lacks and what is done instead (``read_log``'s
        ``df.attrs.get("notes", [])``, see :mod:`gyrodrift.io.notes`); None until the
        last chunk has been read, ``[]`` when the file lacks nothing.
    """

    def __init__(self, path: Path, table_fmt: str, opts, chunk_rows: int, column_types, block_size_bytes: int) -> None:
        self.source = str(path)
        self.format = table_fmt
        self.gyro_unit = opts.gyro_unit
        self.frame = opts.frame
        self.rows = 0
        self.compass: str | None = None
        self.notes: list[str] | None = None
        self._opts = opts
        if table_fmt == "csv":
            self._batches = _CsvBatches(path, opts.renames, column_types, block_size_bytes)
        else:
            if column_types:
                raise ConfigError(
                    messages.message(self.source, "column_types applies to CSV files only", "Parquet files state their column types: leave it out")
                )
            self._batches = _ParquetBatches(path, chunk_rows)
        self._tables = _rechunk(iter(self._batches), chunk_rows)
        self._chunks = self._generate()

    @property
    def attrs(self) -> dict:
        """The ``attrs`` of every chunk: ``source``, ``format``, ``gyro_unit``, ``frame``."""
        return {"source": self.source, "format": self.format, "gyro_unit": self.gyro_unit, "frame": self.frame}

    def _frame(self, table: pa.Table, src: messages.Source) -> pd.DataFrame:
        frame = validate.table_to_frame(table, src)
        if isinstance(self._batches, _ParquetBatches):
            frame = self._batches.fix_frame(frame, table.column_names)
        return frame

    def _first_values(self, frame: pd.DataFrame) -> dict[str, int | None]:
        """First value of each required column in the whole file.

        When the first chunk holds no value of a column, the file is read again from its
        start, on a reader of its own (the chunks still to come are not taken), up to the
        column's first value or to the end: ``t`` or ``gyro_z`` then fail the check with
        ``read_log``'s message, and ``temp`` either fails it (a first value after the
        first row) or is empty in every row (then filled in).
        """
        first = validate.first_value_rows(frame)
        if None not in first.values():
            return first
        row0 = 0
        batches = self._batches.again()
        try:
            for table in _rechunk(batches, len(frame)):
                src = self._batches.src.at(row0)
                rows = validate.apply_column_map(self._frame(table, src), self._opts.renames, src)
                rows = validate.convert_numeric(rows, src)  # a bad cell on the way fails as in read_log
                for col, pos in validate.first_value_rows(rows).items():
                    if first[col] is None and pos is not None:
                        first[col] = row0 + pos
                row0 += len(rows)
                if None not in first.values():
                    break
        finally:
            batches.close()
        return first

    def _generate(self) -> Iterator[pd.DataFrame]:
        try:
            yield from self._normalised()
        finally:
            if isinstance(self._batches, _ParquetBatches):
                self._batches.close()

    def _normalised(self) -> Iterator[pd.DataFrame]:
        src = self._batches.src
        prev_t_s = None
        columns: list = []
        with_values: frozenset[str] = frozenset()
        temperature = notes.TEMP_MEASURED  # the first chunk decides it for the file
        first_notes: tuple[str, ...] = ()  # and the time base (gyrodrift.io.timebase)
        held, last_compass = 0, None  # held compass values emptied so far (gyrodrift.io.held)
        for table in self._tables:
            chunk_src = src.at(self.rows)
            df, found, temperature, time_notes, held_here, last_compass = validate.normalise_frame(
                self._frame(table, chunk_src),
                chunk_src,
                self._opts,
                prev_t_s=prev_t_s,
                first_values=self._first_values if self.rows == 0 else None,
                temp_empty=temperature == notes.TEMP_EMPTY,
                prev_compass=last_compass,
            )
            df.index = pd.RangeIndex(self.rows, self.rows + len(df))
            df.attrs = self.attrs
            prev_t_s = float(df[T].iloc[-1])
            columns, with_values = list(df.columns), with_values | found
            first_notes, held = first_notes or time_notes, held + held_here
            self.rows += len(df)
            yield df
        if self.rows == 0:
            raise messages.no_data_rows_error(src)
        self.compass = notes.compass_form(with_values)
        held_notes = filter(None, [held_note(src.name, held)])
        self.notes = [*notes.table_notes(src.name, columns, with_values, temperature), *first_notes, *held_notes]

    def __iter__(self) -> "LogChunks":
        return self

    def __next__(self) -> pd.DataFrame:
        return next(self._chunks)

    def close(self) -> None:
        """Stop reading and close the file."""
        self._chunks.close()
        if isinstance(self._batches, _ParquetBatches):
            self._batches.close()  # also when no chunk was asked for

    def __enter__(self) -> "LogChunks":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _chunk_format(path: Path, fmt: str | None) -> str:
    """"csv" or "parquet" from ``fmt`` or the file name; ULog, ArduPilot logs and ROS bags are refused."""
    named = str(fmt).strip().lower() if fmt is not None else formats.format_from_path(path)
    if named in ("ulog", "ardupilot", "rosbag"):
        raise ConfigError(
            messages.message(
                str(path),
                f"a {named} log cannot be read in chunks (only CSV and Parquet tables)",
                "read it whole with gyrodrift.io.read_log",
            )
        )
    return formats.table_format(path, fmt, formats.READ_SUFFIXES)


def iter_log_chunks(
    path,
    *,
    fmt: str | None = None,
    gyro_unit: str = "deg/s",
    frame: str | None = None,
    column_map: Mapping[str, str] | None = None,
    time_unit: str | None = None,
    gyro_max_dps: float = GYRO_MAX_DPS,
    chunk_rows: int = 1_000_000,
    column_types: Mapping[str, object] | None = None,
    block_size_bytes: int = DEFAULT_BLOCK_SIZE_BYTES,
) -> LogChunks:
    """Read a CSV or Parquet log in chunks of rows, each in the input contract.

    Every chunk is what :func:`gyrodrift.io.tabular.read_log` gives for those rows:
    ``pd.concat(list(iter_log_chunks(path, ...)))`` equals ``read_log(path, ...)`` (see
    the module notes for what a chunked reader cannot know in advance). Memory use does
    not grow with the file: one chunk and one block of the file at a time.

    Parameters
    ----------
    path : str or os.PathLike
        CSV (``.csv``, ``.csv.gz``, ``.txt``, ``.txt.gz``; gzip recognised by content)
        or Parquet (``.parquet``, ``.pq``).
    fmt : {"csv", "parquet"}, optional
        Table format; overrides the file-name ending.
    gyro_unit, frame, column_map, time_unit, gyro_max_dps
        As for :func:`gyrodrift.io.tabular.read_log`; the time base is checked on the
        first chunk.
    chunk_rows : int, default 1_000_000
        Rows per chunk; every chunk but the last has exactly this many, except that a
        CSV whose number columns hold text somewhere ends one chunk early there.
    column_types : mapping of str to pyarrow.DataType or str, optional
        CSV only: types of pass-through columns (names after ``column_map``), for a
        column whose type the first block of the file does not show (see the notes).
    block_size_bytes : int, default 1 MiB
        CSV only: bytes pyarrow parses at a time; the first block fixes the types of
        pass-through columns.

    Returns
    -------
    LogChunks
        Iterator of :class:`pandas.DataFrame`; chunk ``k`` has the index
        ``RangeIndex(k * chunk_rows, ...)`` (rows of the whole file) and ``attrs``
        ``source``, ``format``, ``gyro_unit``, ``frame``. After the last chunk,
        :attr:`LogChunks.compass` gives the compass form and :attr:`LogChunks.notes`
        what the file lacks (no compass, no temperature).

    Raises
    ------
    LogFormatError
        As ``read_log``: problems of the file as a whole (missing, empty, no header) at
        the call, the others while the chunks are read; also a CSV cell that does not
        fit the type the first block gave its pass-through column.
    ConfigError
        As ``read_log``; a ULog or ROS bag; a bad ``chunk_rows`` or ``column_types``.
    """
    path = Path(path)
    opts = validate.read_options(gyro_unit, frame, column_map, time_unit, gyro_max_dps)
    if isinstance(chunk_rows, bool) or not isinstance(chunk_rows, (int, np.integer)) or chunk_rows < 1:
        raise ConfigError(f"chunk_rows must be a positive whole number of rows, got {chunk_rows!r}")
    if isinstance(block_size_bytes, bool) or not isinstance(block_size_bytes, (int, np.integer)) or block_size_bytes < 1024:
        raise ConfigError(f"block_size_bytes must be a whole number of bytes, at least 1024, got {block_size_bytes!r}")
    messages.check_input_path(path)
    table_fmt = _chunk_format(path, fmt)
    return LogChunks(path, table_fmt, opts, int(chunk_rows), column_types, int(block_size_bytes))


class LogSummary(NamedTuple):
    """What a table's metadata tells without reading its rows (None: not known)."""

    rows: int | None  #: data rows
    t_first_s: float | None  #: smallest time stamp, s (from statistics; not checked)
    t_last_s: float | None  #: largest time stamp, s (from statistics; not checked)


def log_summary(path, *, fmt: str | None = None, column_map: Mapping[str, str] | None = None) -> LogSummary:
    """Row count and time span of a log from its metadata, without reading it.

    Parquet files store both (the row count always; the time span when the ``t``
    column has min/max statistics, which pyarrow writes by default). For a CSV nothing
    is known without reading it: every field is None. Nothing is validated; read the
    log for that.

    Parameters
    ----------
    path : str or os.PathLike
    fmt : {"csv", "parquet"}, optional
    column_map : mapping of str to str, optional
        As for :func:`gyrodrift.io.tabular.read_log`; names the time column.

    Returns
    -------
    LogSummary
    """
    path = Path(path)
    renames = validate.check_column_map(column_map)
    messages.check_input_path(path)
    if _chunk_format(path, fmt) == "csv":
        return LogSummary(None, None, None)
    src = messages.Source(str(path), "parquet", None)
    parquetfile.check_parquet_size(path)
    try:
        meta = pa_pq.ParquetFile(path).metadata
    except (pa.ArrowException, OSError, ValueError) as exc:
        raise parquetfile.parquet_error(src, exc) from exc
    time_name = renames.get(T, T)
    names = [meta.schema.column(i).path.strip() for i in range(meta.num_columns)]
    lows, highs = [], []
    if time_name in names and meta.num_row_groups:
        index = names.index(time_name)
        for group in range(meta.num_row_groups):
            stats = meta.row_group(group).column(index).statistics
            if meta.row_group(group).num_rows == 0:
                continue
            if stats is None or not stats.has_min_max or not isinstance(stats.min, (int, float)):
                lows, highs = [], []
                break
            lows.append(float(stats.min) + 0.0)  # Parquet stores a zero minimum as -0.0
            highs.append(float(stats.max))
    return LogSummary(meta.num_rows, min(lows) if lows else None, max(highs) if highs else None)
