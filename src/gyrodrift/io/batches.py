"""Arrow record batches of a CSV or Parquet file, read a block at a time.

:class:`CsvBatches` checks the CSV text as it is read and rereads the number columns as
text from a row pyarrow cannot read as numbers; :class:`ParquetBatches` reads row groups;
:func:`rechunk` cuts the batches into tables of a given number of rows
(docs/log-formats.md, section "Reading in chunks").
"""

from __future__ import annotations

import codecs
import gzip
import io
import re
from pathlib import Path
from typing import Iterator, Mapping

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pa_csv
import pyarrow.parquet as pa_pq

from gyrodrift.errors import ConfigError, LogFormatError
from gyrodrift.io import csvfile, messages, parquetfile, validate

__all__ = ["ColumnTypeChanged", "DEFAULT_BLOCK_SIZE_BYTES", "CsvBatches", "ParquetBatches", "rechunk"]


class ColumnTypeChanged(LogFormatError):
    """A cell of a pass-through CSV column does not fit the type the first block gave it.

    ``column`` (after the column map) and ``value`` (the cell's text) name it;
    ``suggested_type`` is ``"float64"`` for a number (whole numbers, then a fraction), else
    ``"string"``: the ``column_types`` entry that reads the whole column.
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


class _CsvText(io.RawIOBase):
    """A CSV file's text as pyarrow reads it: gunzipped, byte-order mark dropped, checked as it is read."""

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


def rechunk(batches: Iterator[pa.RecordBatch], rows: int) -> Iterator[pa.Table]:
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


class CsvBatches:
    """Record batches of a CSV file from pyarrow's streaming reader; number columns switch to
    text from a row that needs it, other columns' types are fixed by the first block."""

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


class ParquetBatches:
    """Record batches of a Parquet file (:meth:`pyarrow.parquet.ParquetFile.iter_batches`),
    with what the whole file says about pass-through columns (see :meth:`fix_frame`)."""

    def __init__(self, path: Path, batch_rows: int) -> None:
        self.path = path
        self.src = messages.Source(str(path), "parquet", None)
        parquetfile.check_parquet_size(path)
        self._batch_rows = batch_rows
        try:
            # pre_buffer=False: otherwise pyarrow buffers every row group it will read, the whole file
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
        """The categories pandas gives column ``name`` read whole: every batch's dictionary, in order."""
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
