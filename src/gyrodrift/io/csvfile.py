"""CSV text: what both table readers check and how they convert it; how both writers print it.

The whole-table and the chunked reader convert cells with the same options, and the
whole-table and the chunk writer print the same lines (docs/log-formats.md, sections
"Tables: CSV and Parquet" and "Writing tables").
"""

from __future__ import annotations

import codecs
import gzip
import io
import re
import zlib
from typing import Mapping

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pa_compute
import pyarrow.csv as pa_csv

from gyrodrift.errors import LogFormatError
from gyrodrift.io.formula import formula_safe_frame, formula_safe_table, formula_safe_text
from gyrodrift.io.parquetfile import arrow_table
from gyrodrift.io.messages import Source, format_error, log_error, one_line
from gyrodrift.io.validate import NUMERIC_COLS

__all__ = [
    "GZIP_MAGIC",
    "UTF8_BOM",
    "CSV_EMPTY_ADVICE",
    "GZIP_ERRORS",
    "gzip_error",
    "decompress_if_gzip",
    "check_csv_text",
    "header_line",
    "csv_header_names",
    "numeric_raw_names",
    "csv_convert_options",
    "ragged_row_error",
    "csv_parse_error",
    "csv_header",
    "csv_table",
    "write_csv_rows",
    "write_csv_with_pandas",
]


#: First bytes of a gzip file (a compressed CSV is recognised by them, whatever its name).
GZIP_MAGIC = b"\x1f\x8b"
#: UTF-8 byte-order mark, which some spreadsheet programs write before the header.
UTF8_BOM = b"\xef\xbb\xbf"
#: What to do about a CSV file without any text.
CSV_EMPTY_ADVICE = "give a CSV log with a header row and at least one data row"


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------


def gzip_error(name: str, exc: Exception) -> LogFormatError:
    """The error for a file that starts like gzip but does not decompress."""
    return log_error(name, f"is not a valid gzip file ({one_line(str(exc))})",
                     "re-compress the CSV with gzip or give the uncompressed .csv")


#: What decompressing a broken gzip file raises.
GZIP_ERRORS = (OSError, EOFError, zlib.error)


def decompress_if_gzip(data: bytes, name: str) -> bytes:
    """Return ``data`` decompressed when it starts with the gzip magic bytes."""
    if not data.startswith(GZIP_MAGIC):
        return data
    try:
        return gzip.decompress(data)
    except GZIP_ERRORS as exc:
        raise gzip_error(name, exc) from exc


def check_csv_text(data: bytes, name: str, *, lines_before: int = 0, decoder=None, final: bool = True) -> None:
    """Raise :class:`LogFormatError` unless ``data`` looks like UTF-8 text (no NUL byte).

    Piece by piece: ``lines_before`` counts the line ends before ``data``, ``decoder`` (a
    UTF-8 incremental decoder) carries an unfinished character on, ``final`` marks the last.
    """
    nul = data.find(b"\x00")
    if nul >= 0:
        line = lines_before + data.count(b"\n", 0, nul) + 1
        raise log_error(name, "contains NUL bytes, so it is a binary file, not a CSV text file",
                        "export the log as comma-separated text with a header row (or give a .parquet file)",
                        where=f"line {line}")
    if decoder is None:
        decoder = codecs.getincrementaldecoder("utf-8")()
    elif not decoder.getstate()[0] and data.isascii() and not final:
        return  # the usual case, without decoding
    try:
        decoder.decode(data, final)
    except UnicodeDecodeError as exc:
        pos = exc.start - (len(exc.object) - len(data))  # in ``data``; < 0: in the piece before
        line = lines_before + data.count(b"\n", 0, max(pos, 0)) + 1
        raise log_error(name, f"byte 0x{exc.object[exc.start]:02x} is not UTF-8 text, so this is not a CSV text file",
                        "export or re-save the log as UTF-8 comma-separated text", where=f"line {line}") from exc


def header_line(data: bytes, *, at_end: bool) -> bytes | None:
    """The first non-empty line of CSV text (without its line end), or None when ``data``
    may not hold all of it yet (``at_end`` False and no line end after it)."""
    text = data.lstrip(b"\r\n")
    ends = [i for i in (text.find(b"\n"), text.find(b"\r")) if i >= 0]
    if ends:
        return text[: min(ends)]
    return text if at_end else None


def csv_header_names(line: bytes) -> list[str]:
    """Column names of a CSV header line as pyarrow reads them (empty if it cannot)."""
    try:
        header = pa_csv.read_csv(pa.BufferReader(line + b"\n"), read_options=pa_csv.ReadOptions(use_threads=False))
    except (pa.ArrowException, ValueError):
        return []  # the full read reports the problem
    return list(header.column_names)


def numeric_raw_names(names, column_map: Mapping[str, str]) -> set[str]:
    """Header names (as in the file) of the columns that become numeric contract columns."""
    new_name = {old: new for new, old in column_map.items()}
    numeric = set(NUMERIC_COLS)
    return {raw for raw in names if new_name.get(raw.strip(), raw.strip()) in numeric}


def csv_convert_options(
    names, column_map: Mapping[str, str], *, numbers_as_text: bool, column_types: Mapping[str, pa.DataType] | None = None
) -> pa_csv.ConvertOptions:
    """How pyarrow converts CSV cells, the same for the whole-file and the chunked reader.

    Numeric contract columns (after stripping and ``column_map``) are read as float64, or
    as text when ``numbers_as_text`` (then converted cell by cell with the same parser);
    ``column_types`` pins other columns' types (by header name); the rest are inferred.
    """
    kind = pa.string() if numbers_as_text else pa.float64()
    types = {raw: kind for raw in numeric_raw_names(names, column_map)}
    types.update(column_types or {})
    return pa_csv.ConvertOptions(column_types=types, strings_can_be_null=True)


def ragged_row_error(src: Source, row) -> LogFormatError:
    """The error for a row with the wrong number of fields (``row``: pyarrow's InvalidRow)."""
    line = src.line_of(row.number) if row.number else "?"
    return format_error(
        src,
        f"row has {row.actual_columns} field(s) but the header has {row.expected_columns}",
        "every row needs one value per header column (leave a cell empty, do not drop it)",
        where=f"line {line}",
    )


def csv_parse_error(src: Source, exc: Exception) -> LogFormatError:
    """The error for text pyarrow cannot read as CSV."""
    return format_error(
        src, f"cannot be parsed as CSV ({one_line(str(exc))})", "give a comma-separated text file with a header row"
    )


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------


_CSV_SPECIAL = re.compile(r'[,"\r\n]')
_CSV_SPECIAL_PATTERN = _CSV_SPECIAL.pattern
_ARROW_WRITE_ERRORS = (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError)


def _csv_field(text: str) -> str:
    """One CSV field: quoted (inner quotes doubled) only if it holds ``,``, ``"`` or a line end."""
    return '"' + text.replace('"', '""') + '"' if _CSV_SPECIAL.search(text) else text


def csv_header(names) -> bytes:
    """The CSV header line (UTF-8, ``\n``-terminated) for column ``names`` (a name that starts
    like a formula quoted, :mod:`gyrodrift.io.formula`)."""
    return (",".join(_csv_field(formula_safe_text(str(n))) for n in names) + "\n").encode("utf-8")


def _is_text(arrow_type: pa.DataType) -> bool:
    return pa.types.is_string(arrow_type) or pa.types.is_large_string(arrow_type)


def _quoted_column(column: pa.ChunkedArray) -> pa.ChunkedArray:
    """A column as CSV fields: values as text (as pyarrow's CSV writer prints them), text
    quoted where :func:`_csv_field` would, empty cells as empty text."""
    if pa.types.is_dictionary(column.type):
        column = column.cast(column.type.value_type)
    text = column.cast(pa.large_string())
    if _is_text(column.type):
        special = pa_compute.match_substring_regex(text, _CSV_SPECIAL_PATTERN)
        quote, nothing = pa.scalar('"', pa.large_string()), pa.scalar("", pa.large_string())
        quoted = pa_compute.binary_join_element_wise(quote, pa_compute.replace_substring(text, '"', '""'), quote, nothing)
        text = pa_compute.if_else(special, quoted, text)
    return pa_compute.fill_null(text, pa.scalar("", pa.large_string()))


def _needs_quoting(table: pa.Table) -> bool:
    """True if a text cell of ``table`` holds ``,``, ``"`` or a line end."""
    for column in table.columns:
        if pa.types.is_dictionary(column.type) and _is_text(column.type.value_type):
            column = column.cast(column.type.value_type)
        if _is_text(column.type) and pa_compute.any(
            pa_compute.match_substring_regex(column, _CSV_SPECIAL_PATTERN)
        ).as_py():
            return True
    return False


def _text_data(lines: pa.Array) -> pa.Buffer:
    """The characters of a large_string array without nulls, all values end to end."""
    offsets = np.frombuffer(lines.buffers()[1], dtype=np.int64)[lines.offset : lines.offset + len(lines) + 1]
    return lines.buffers()[2][int(offsets[0]) : int(offsets[-1])]


def _csv_lines(table: pa.Table) -> list:
    """The CSV data lines of ``table`` built column by column (see :func:`write_csv_rows`)."""
    fields = [_quoted_column(column) for column in table.columns]
    comma, nothing, line_end = (pa.scalar(c, pa.large_string()) for c in (",", "", "\n"))
    lines = pa_compute.binary_join_element_wise(*fields, comma)
    lines = pa_compute.binary_join_element_wise(lines, nothing, line_end)  # a line end after each row
    return [_text_data(chunk) for chunk in lines.chunks]


def csv_table(df: pd.DataFrame) -> pa.Table | None:
    """``df`` as the Arrow table :func:`write_csv_rows` prints (text cells that start like a
    formula quoted, :mod:`gyrodrift.io.formula`), or None if pyarrow cannot convert it
    (pandas writes it then)."""
    try:
        return formula_safe_table(arrow_table(df))
    except _ARROW_WRITE_ERRORS:
        return None


#: pyarrow's CSV settings for the data lines: the header and any quoting are gyrodrift's.
_CSV_ROWS = pa_csv.WriteOptions(include_header=False, quoting_style="none")


def write_csv_rows(table: pa.Table, sink, header: bytes = b"") -> bool:
    """Write ``header`` and the CSV data lines of ``table`` to ``sink``; False, with nothing
    written, if pyarrow cannot print a column type of ``table`` (pandas writes it then).

    Every line depends on its own row only, so a table split in chunks prints the lines of
    the whole. ``sink`` is best a :class:`pyarrow.NativeFile` (written without the GIL).
    """
    if table.num_rows:
        try:
            quoted = _csv_lines(table) if _needs_quoting(table) else None
            # no rows and no header: nothing is written, but a type pyarrow cannot print is refused
            pa_csv.write_csv(table.slice(0, 0), sink, _CSV_ROWS)
        except _ARROW_WRITE_ERRORS:
            return False
    sink.write(header)
    if not table.num_rows:
        return True
    if quoted is None:
        pa_csv.write_csv(table, sink, _CSV_ROWS)
    else:
        for piece in quoted:
            sink.write(piece)
    return True


def write_csv_with_pandas(df: pd.DataFrame, sink, *, header: bool) -> None:
    """Write ``df`` as CSV with pandas to a binary ``sink`` (for values pyarrow cannot print),
    text cells and names that start like a formula quoted (:mod:`gyrodrift.io.formula`)."""
    text = io.TextIOWrapper(sink, encoding="utf-8", newline="")
    formula_safe_frame(df).to_csv(text, index=False, header=header, lineterminator="\n")
    text.flush()
    text.detach()  # leave ``sink`` open for the caller
