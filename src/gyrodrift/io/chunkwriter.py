"""Write a result table chunk by chunk to CSV or Parquet, atomically: :class:`ChunkWriter`.

The file is the one :func:`gyrodrift.io.tabular.write_table` writes for the whole table
(docs/log-formats.md, section "Writing tables").
"""

from __future__ import annotations

import sys
from contextlib import ExitStack
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pa_pq

from gyrodrift._atomic import atomic_path
from gyrodrift.errors import ConfigError
from gyrodrift.io import csvfile, formats, messages, parquetfile

__all__ = ["ChunkWriter"]


class ChunkWriter:
    """Write a table chunk by chunk to CSV or Parquet, atomically, as a context manager.

    The chunks go to a temporary file that replaces ``path`` when the ``with`` block ends
    normally (docs/log-formats.md, section "Writing tables").

    Parameters
    ----------
    path : str or os.PathLike
        Destination; its ending (``.csv``, ``.parquet``, ``.pq``) picks the format.
    fmt : {"csv", "parquet"}, optional
        Table format; overrides the file-name ending.
    row_group_rows : int
        Parquet: rows gathered before a row group is written; the last may be smaller.
    sync_every_s : float or None
        Sync what has been written at this interval, in a background thread (None: only
        at the end).

    Attributes
    ----------
    rows : int
        Data rows written so far.

    Examples
    --------
    ::

        with ChunkWriter("out.parquet") as out:
            for chunk in iter_log_chunks("in.csv"):
                out.write(process(chunk))
    """

    def __init__(
        self, path, *, fmt: str | None = None, row_group_rows: int = 1 << 20, sync_every_s: float | None = 0.5
    ) -> None:
        self.path = Path(path)
        self.row_group_rows = int(row_group_rows)
        self.sync_every_s = sync_every_s
        self._pending: list[pa.Table] = []
        self.format = formats.table_format(self.path, fmt, formats.WRITE_SUFFIXES)
        self.rows = 0
        self._stack: ExitStack | None = None
        self._sink: pa.NativeFile | None = None
        self._names: list[str] | None = None
        self._parquet: _ParquetWriter | None = None

    def __enter__(self) -> "ChunkWriter":
        if self._stack is not None:
            raise RuntimeError("ChunkWriter is already open")
        with ExitStack() as stack:
            tmp = stack.enter_context(atomic_path(self.path, sync_every_s=self.sync_every_s))
            self._sink = stack.enter_context(parquetfile.open_sink(tmp))
            self._stack = stack.pop_all()
        return self

    def write(self, chunk) -> None:
        """Append the rows of ``chunk``: a DataFrame (its index not written) or what
        :meth:`encode` made of one.

        Every chunk needs the columns of the first, in the same order; for Parquet also
        the same types (or types that convert without loss).
        """
        if self._sink is None:
            raise RuntimeError("ChunkWriter.write() outside its with block")
        if isinstance(chunk, pd.DataFrame):
            chunk = self.encode(chunk)
        names = [str(c) for c in chunk.column_names]
        header = b""
        if self._names is None:
            self._names = names
            header = csvfile.csv_header(chunk.frame.columns) if self.format == "csv" else b""
        elif names != self._names:
            raise ValueError(f"{self.path}: chunk columns {names} differ from the first chunk's {self._names}")
        if self.format == "csv":
            self._write_csv(chunk, header)
        else:
            self._write_parquet(chunk)
        self.rows += chunk.num_rows

    def encode(self, df: pd.DataFrame):
        """The chunk as :meth:`write` writes it (for Parquet an Arrow table). A pipeline
        can encode in one thread and :meth:`write` the result in another."""
        if self.format == "parquet":
            return parquetfile.arrow_table(df)
        return _CsvChunk(csvfile.csv_table(df), df)

    def _write_csv(self, chunk: "_CsvChunk", header: bytes) -> None:
        if chunk.table is None or not csvfile.write_csv_rows(chunk.table, self._sink, header):
            # pyarrow cannot convert or print these values: pandas does, as in write_table
            self._sink.write(header)
            csvfile.write_csv_with_pandas(chunk.frame, self._sink, header=False)

    def _write_parquet(self, table: pa.Table) -> None:
        if self._parquet is None:
            self._parquet = _ParquetWriter(self._sink, table.schema, **parquetfile.parquet_options(table.schema))
        elif not table.schema.equals(self._parquet.schema, check_metadata=False):
            try:
                table = table.cast(self._parquet.schema)
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError, pa.ArrowTypeError) as exc:
                raise ConfigError(
                    messages.message(
                        str(self.path),
                        f"the chunk from row {self.rows} has column types {table.schema.types} but the file was"
                        f" started with {self._parquet.schema.types} ({messages.one_line(str(exc))})",
                        "give every chunk the same column types (e.g. read the input column as float64 with the"
                        " column_types option)",
                    )
                ) from exc
        if table.num_rows:
            self._pending.append(table)
            if sum(t.num_rows for t in self._pending) >= self.row_group_rows:
                self._flush_parquet()

    def _flush_parquet(self) -> None:
        if self._pending:
            table = pa.concat_tables(self._pending)
            self._pending = []
            self._parquet.write_table(table, row_group_size=table.num_rows)

    def __exit__(self, exc_type, exc, tb) -> bool:
        stack, self._stack = self._stack, None
        parquet, self._parquet, self._sink = self._parquet, None, None
        if exc_type is not None:
            self._pending = []
            if parquet is not None:
                try:
                    parquet.close()
                except Exception:  # noqa: BLE001 - the file is discarded; the first error counts
                    pass
            return bool(stack.__exit__(exc_type, exc, tb))  # removes the temporary file
        try:
            if self._names is None:
                raise ConfigError(f"{self.path}: no chunk was written; nothing to save")
            if parquet is not None:
                self._parquet = parquet
                self._flush_parquet()
                self._parquet = None
                parquet.close()
        except BaseException:
            if not stack.__exit__(*sys.exc_info()):
                raise
            return False
        return bool(stack.__exit__(None, None, None))


class _ParquetWriter(pa_pq.ParquetWriter):
    """pyarrow's writer, not closed by the garbage collector.

    :meth:`ChunkWriter.__exit__` closes it; one left open was interrupted (an error, Ctrl-C,
    SIGTERM) and its temporary file is already closed and removed, where pyarrow's finalizer
    would fail with "Invalid operation on closed file".
    """

    def __del__(self) -> None:
        self.is_open = False


@dataclass(frozen=True)
class _CsvChunk:
    """A chunk encoded for CSV: the Arrow table pyarrow prints (None if pyarrow cannot
    convert the frame), and the frame, which pandas prints if pyarrow cannot."""

    table: pa.Table | None
    frame: pd.DataFrame

    @property
    def column_names(self) -> list:
        return list(self.frame.columns)

    @property
    def num_rows(self) -> int:
        return len(self.frame)
