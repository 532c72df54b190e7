"""Read and write CSV and Parquet tables in chunks, in constant memory.

:func:`iter_log_chunks` reads a log chunk by chunk through the code of
:func:`gyrodrift.io.tabular.read_log`, so the chunks concatenated equal the whole log;
:class:`ChunkWriter` writes the file :func:`gyrodrift.io.tabular.write_table` writes. What
a chunked reader cannot know in advance: docs/log-formats.md, section "Reading in chunks".
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterator, Mapping

import numpy as np
import pandas as pd
import pyarrow as pa

from gyrodrift.conventions import T
from gyrodrift.errors import ConfigError
from gyrodrift.io import formats, messages, notes, validate
from gyrodrift.io.batches import DEFAULT_BLOCK_SIZE_BYTES, ColumnTypeChanged, CsvBatches, ParquetBatches, rechunk
from gyrodrift.io.chunkwriter import ChunkWriter
from gyrodrift.io.held import held_note
from gyrodrift.io.limits import GYRO_MAX_DPS

__all__ = ["iter_log_chunks", "LogChunks", "ChunkWriter", "ColumnTypeChanged"]


class LogChunks:
    """The chunks of a log in the input contract, an iterator of DataFrames (:func:`iter_log_chunks`).

    Use it in a ``with`` block, or call :meth:`close`, to close the file when the chunks
    are not read to the end.

    Attributes
    ----------
    source : str
    format : {"csv", "parquet"}
    gyro_unit, frame : str
        The options, canonical (as ``read_log`` puts them in ``df.attrs``).
    rows : int
        Data rows handed out so far.
    compass : {"heading", "mag", "both", "none"} or None
        ``read_log``'s ``attrs["compass"]``; None until the last chunk has been read.
    notes : list of str or None
        ``read_log``'s ``attrs.get("notes", [])``; None until the last chunk has been read.
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
            self._batches = CsvBatches(path, opts.renames, column_types, block_size_bytes)
        else:
            if column_types:
                raise ConfigError(
                    messages.message(self.source, "column_types applies to CSV files only", "Parquet files state their column types: leave it out")
                )
            self._batches = ParquetBatches(path, chunk_rows)
        self._tables = rechunk(iter(self._batches), chunk_rows)
        self._chunks = self._generate()

    @property
    def attrs(self) -> dict:
        """The ``attrs`` of every chunk: ``source``, ``format``, ``gyro_unit``, ``frame``."""
        return {"source": self.source, "format": self.format, "gyro_unit": self.gyro_unit, "frame": self.frame}

    def _frame(self, table: pa.Table, src: messages.Source) -> pd.DataFrame:
        frame = validate.table_to_frame(table, src)
        if isinstance(self._batches, ParquetBatches):
            frame = self._batches.fix_frame(frame, table.column_names)
        return frame

    def _first_values(self, frame: pd.DataFrame) -> dict[str, int | None]:
        """First value of each required column in the whole file (read again from the start where needed)."""
        first = validate.first_value_rows(frame)
        if None not in first.values():
            return first
        row0 = 0
        batches = self._batches.again()
        try:
            for table in rechunk(batches, len(frame)):
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
            if isinstance(self._batches, ParquetBatches):
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
        if isinstance(self._batches, ParquetBatches):
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


def iter_log_chunks(path, *, fmt: str | None = None, gyro_unit: str = "deg/s", frame: str | None = None,
                    column_map: Mapping[str, str] | None = None, time_unit: str | None = None,
                    gyro_max_dps: float = GYRO_MAX_DPS, chunk_rows: int = 1_000_000,
                    column_types: Mapping[str, object] | None = None,
                    block_size_bytes: int = DEFAULT_BLOCK_SIZE_BYTES) -> LogChunks:
    """Read a CSV or Parquet log in chunks of rows, each in the input contract.

    ``pd.concat(list(iter_log_chunks(path, ...)))`` equals ``read_log(path, ...)``, in
    constant memory (docs/log-formats.md, section "Reading in chunks").

    Parameters
    ----------
    path : str or os.PathLike
        CSV or Parquet, as :func:`gyrodrift.io.tabular.read_log`.
    fmt, gyro_unit, frame, column_map, time_unit, gyro_max_dps
        As :func:`gyrodrift.io.tabular.read_log`; the time base is judged on the first chunk.
    chunk_rows : int, default 1_000_000
        Rows per chunk.
    column_types : mapping of str to pyarrow.DataType or str, optional
        CSV only: types of pass-through columns (names after ``column_map``).
    block_size_bytes : int, default 1 MiB
        CSV only: bytes pyarrow parses at a time; the first block fixes the types of
        pass-through columns.

    Returns
    -------
    LogChunks
        Chunk ``k`` has the index ``RangeIndex(k * chunk_rows, ...)`` and ``attrs``
        ``source``, ``format``, ``gyro_unit``, ``frame``.

    Raises
    ------
    LogFormatError
        As ``read_log``: problems of the whole file at the call, the others while the
        chunks are read; a CSV cell that does not fit its column's type
        (:class:`ColumnTypeChanged`).
    ConfigError
        As ``read_log``; a binary log; a bad ``chunk_rows`` or ``column_types``.
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


