"""Parquet files: the size and read errors of both table readers; the Arrow tables and
settings of both writers (docs/log-formats.md, section "Writing tables")."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa

from gyrodrift.errors import LogFormatError
from gyrodrift.io.messages import Source, empty_file_error, format_error, log_error, one_line

__all__ = ["check_parquet_size", "parquet_error", "arrow_table", "parquet_options", "open_sink"]


class _Counted:
    """A binary file written in order, telling its position by counting the bytes written:
    what pyarrow's Parquet writer asks of its sink, which a FIFO cannot answer by seeking."""

    def __init__(self, fh) -> None:
        self._fh, self._written, self.closed = fh, 0, False

    def write(self, data) -> int:
        self._fh.write(data)
        self._written += len(data)
        return len(data)

    def tell(self) -> int:
        return self._written

    def flush(self) -> None:
        self._fh.flush()

    def close(self) -> None:
        self._fh.close()
        self.closed = True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return False

    def readable(self) -> bool:
        return False


def open_sink(path) -> pa.NativeFile:
    """Open ``path`` for writing a table: a :class:`pyarrow.OSFile` (written without the
    GIL), or for a FIFO a Python file that counts its position (pyarrow's own file asks a
    pipe for its position by seeking, which fails)."""
    try:
        fifo = stat.S_ISFIFO(os.stat(path).st_mode)
    except OSError:
        fifo = False
    if fifo:
        return pa.PythonFile(_Counted(open(path, "wb")), mode="w")
    return pa.OSFile(str(path), "w")


_PARQUET_EMPTY_ADVICE = "give a Parquet log with at least one data row"


def check_parquet_size(path: Path) -> None:
    """Raise :class:`LogFormatError` for an unreadable or zero-byte Parquet file."""
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise log_error(str(path), f"cannot read the input file ({exc.strerror})",
                        "check that it is a readable file") from exc
    if size == 0:
        raise empty_file_error(str(path), _PARQUET_EMPTY_ADVICE)


def parquet_error(src: Source, exc: Exception) -> LogFormatError:
    """The error for a file pyarrow cannot read as Parquet."""
    return format_error(
        src,
        f"is not a readable Parquet file ({one_line(str(exc))})",
        "check the file, or read it as CSV if it is a text file",
    )


def _arrow_column(column: pd.Series):
    """One column as :meth:`pyarrow.Table.from_pandas` converts it, a categorical as its values; a
    float column without NaN without the pass that looks for NaN (most of an output chunk's conversion)."""
    if column.dtype.kind == "f":
        values = column.to_numpy()
        if not np.isnan(values).any():
            return pa.array(values)
    array = pa.array(column, from_pandas=True)
    return array.cast(array.type.value_type) if pa.types.is_dictionary(array.type) else array


def arrow_table(df: pd.DataFrame) -> pa.Table:
    """``df`` as a pyarrow table without index, categorical columns as their values (raises
    pyarrow errors)."""
    names = [str(c) for c in df.columns]
    categorical = any(isinstance(dtype, pd.CategoricalDtype) for dtype in df.dtypes)
    if categorical and len(set(names)) == len(names):  # duplicate names: from_pandas refuses them
        return pa.Table.from_arrays([_arrow_column(column) for _, column in df.items()], names=names)
    plain = df.copy(deep=False).set_axis(names, axis=1)
    plain.attrs = {}  # run diagnostics stay in memory; the file holds the table only
    return pa.Table.from_pandas(plain, preserve_index=False)


def _parquet_dictionary_columns(schema: pa.Schema) -> list[str]:
    """Columns worth dictionary encoding: all but floating-point ones (docs/log-formats.md,
    section "Writing tables")."""
    return [f.name for f in schema if not pa.types.is_floating(f.type)]


def parquet_options(schema: pa.Schema) -> dict:
    """Writer settings: dictionaries where they pay, min/max statistics for ``t`` only
    (docs/log-formats.md, section "Writing tables")."""
    stats = ["t"] if "t" in schema.names else True
    return {"use_dictionary": _parquet_dictionary_columns(schema), "write_statistics": stats}
