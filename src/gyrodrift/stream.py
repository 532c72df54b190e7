"""Samples in, compensated rows out, as they come: what ``gyrodrift stream`` runs.

:func:`stream_rows` reads samples as CSV or JSON lines from any source of text
(:func:`fd_blocks`, :func:`serial_blocks`), feeds them to a :class:`gyrodrift.Compensator`
and writes every row it returns, as ``gyrodrift compensate`` writes them. The input, the
latency, bad lines and the time base: docs/streaming.md, section "gyrodrift stream".
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field, fields
from typing import Callable, Iterable

import numpy as np
import pandas as pd
import pyarrow as pa

from gyrodrift._columns import join_input_columns
from gyrodrift.compensator import CompensatedSample, Compensator, CompensatorConfig
from gyrodrift.conventions import ACC_COLS, GYRO_X, GYRO_Y, GYRO_Z, HEADING, MAG_COLS, TEMP, T
from gyrodrift.errors import ConfigError, GyroDriftError, LogFormatError
from gyrodrift.io.csvfile import csv_header, csv_table, write_csv_rows, write_csv_with_pandas
from gyrodrift.io.messages import log_error
from gyrodrift.io.validate import (
    TEMP_ABSENT,
    Source,
    cell_label,
    check_z_up,
    format_error,
    no_data_rows_error,
    normalise_frame,
    read_options,
    compass_form,
    show_names,
    table_notes,
    table_to_frame,
)
from gyrodrift.pipeline import RunStats
from gyrodrift.stream_ends import (
    SERIAL_ADVICE, StreamInterrupted, deferred_signals, fd_blocks, input_blocks, output_writer, serial_blocks,
)
from gyrodrift.triad import TRIAD_COLUMNS, has_triad_inputs

__all__ = [
    "FORMATS", "StreamStats", "StreamInterrupted", "stream_rows", "detect_format", "fd_blocks", "serial_blocks",
    "deferred_signals", "input_blocks", "output_writer", "SERIAL_ADVICE",
]

#: Input and output formats of :func:`stream_rows`.
FORMATS = ("csv", "jsonl")
#: The byte-order mark some programs write first (decoded).
BOM = "\ufeff"
#: Longest line taken, characters: a longer one stops the stream.
MAX_LINE_CHARS = 1 << 24
#: Output rows gathered before they are added to the run's account (:class:`gyrodrift.pipeline.RunStats`).
ACCOUNT_ROWS = 1000
#: The output columns of the z axis, in the order of :func:`gyrodrift.compensator.output_frame`.
_Z_COLUMNS = tuple(f.name for f in fields(CompensatedSample) if f.name not in TRIAD_COLUMNS)
_COMPASS_COLUMNS = (HEADING, *MAG_COLS, *ACC_COLS)


@dataclass
class StreamStats:
    """What a stream read and wrote (:func:`stream_rows`)."""

    #: The run as :func:`gyrodrift.pipeline.compensate_file` accounts it (rows written,
    #: temperatures, refusals, final drift model): what a profile is made of.
    run: RunStats
    #: Samples pushed to the compensator.
    rows_in: int = 0
    #: Lines skipped as bad (``skip_bad``).
    skipped: int = 0
    #: The signal that ended the input (``signal.SIGINT`` or ``signal.SIGTERM``), or None at its end.
    signal: int | None = None
    #: What could not be learned or was done instead (one line each): the input's notes, then the compensator's.
    notes: list = field(default_factory=list)


def detect_format(first_line: str) -> str:
    """``"jsonl"`` when the first non-blank character of ``first_line`` is ``{``, else ``"csv"``."""
    return "jsonl" if first_line.lstrip().startswith("{") else "csv"


class _Reader:
    """Lines of text → parsed records (CSV cells or JSON objects) with their line numbers."""

    def __init__(self, fmt: str, name: str) -> None:
        self.fmt, self.name = fmt, name
        self.columns: list[str] | None = None  # as in the input (before column_map)

    def header(self, line: str, line_no: int) -> list | None:
        """Take the columns from the first line; return its record (JSON) or None (CSV header)."""
        if self.fmt == "csv":
            self.columns = next(csv.reader([line]))
            return None
        record = self._object(line, line_no, first=True)
        self.columns = list(record)
        return self.record(line, line_no, record)

    def _bad(self, line_no: int, problem: str, advice: str, column: str | None = None) -> LogFormatError:
        where = f"line {line_no}" + (f", column {column!r}" if column is not None else "")
        return log_error(self.name, problem, advice, where=where)

    def _object(self, line: str, line_no: int, first: bool = False) -> dict:
        try:
            record = json.loads(line)
        except ValueError as exc:
            raise self._bad(line_no, f"is not JSON ({' '.join(str(exc).split())})",
                            "give one JSON object per line, e.g. {\"t\": 0.0, \"gyro_z\": 0.1, \"temp\": 25.0}") from None
        if not isinstance(record, dict):
            raise self._bad(line_no, f"is a JSON {type(record).__name__}, not an object",
                            "give one JSON object per line, e.g. {\"t\": 0.0, \"gyro_z\": 0.1, \"temp\": 25.0}")
        if first and not record:
            raise self._bad(line_no, "the first object has no keys", "give the sample's columns as keys")
        return record

    def record(self, line: str, line_no: int, parsed=None) -> list:
        """One data line → its cells in the order of :attr:`columns` (None: no value)."""
        if self.fmt == "csv":
            cells = next(csv.reader([line]))
            if len(cells) != len(self.columns):
                raise self._bad(line_no, f"row has {len(cells)} field(s) but the header has {len(self.columns)}",
                                "every row needs one value per header column (leave a cell empty, do not drop it)")
            return [cell if cell.strip() else None for cell in cells]
        obj = parsed if parsed is not None else self._object(line, line_no)
        extra = [k for k in obj if k not in self._known]
        if extra:
            raise self._bad(line_no, f"key {extra[0]!r} is not a key of the first object (its keys are the columns: "
                            f"{show_names(self.columns)})",
                            "give every key in the first line, with null where it has no value", column=extra[0])
        return [obj.get(k) for k in self.columns]

    @property
    def _known(self) -> frozenset:
        known = getattr(self, "_known_set", None)
        if known is None:
            known = self._known_set = frozenset(self.columns)
        return known


class _Stream:
    """The state of one stream: reader, compensator, rows waiting for their output."""

    def __init__(self, write, comp: Compensator, *, fmt, out_format, opts, name, skip_bad, warn) -> None:
        self.write, self.comp, self.opts, self.name = write, comp, opts, name
        self.fmt, self.out_format, self.skip_bad, self.warn = fmt, out_format, skip_bad, warn
        self.reader: _Reader | None = None
        self.stats = StreamStats(RunStats(name, streamed=True))
        self.prev_t_s: float | None = None  # time of the last sample pushed
        self.prev_line = 0  # its line number
        self.pending: list[pd.DataFrame] = []  # input rows (converted) whose output rows have not come yet
        self.names: list[str] | None = None  # input columns as read (names stripped)
        self.columns: list[str] | None = None  # input columns after conversion (temp added when missing)
        self.has_mag = self.has_triad = False
        self.written: list[pd.DataFrame] = []  # output rows not yet in the run's account (:meth:`_account`)
        self.written_rows = 0

    # -- header
    def _source(self, line_nos: list[int]) -> Source:
        """Where the rows of a block are: row r is on line ``line_nos[r]`` (row -1: the last sample's line)."""
        numbers = [self.prev_line, *line_nos]
        return Source(self.name, "csv", lambda k: numbers[k - 1])

    def start(self, line: str, line_no: int) -> None:
        """The first non-blank line: format, columns, header checks, notes, output header."""
        fmt = self.fmt or detect_format(line)
        self.reader = _Reader(fmt, self.name)
        if self.out_format is None:
            self.out_format = fmt
        first = self.reader.header(line, line_no)
        names = self.reader.columns
        header = pa.Table.from_arrays([pa.array([], pa.string())] * len(names), names=names)
        src = Source(self.name, "csv", lambda k: line_no)
        raw = table_to_frame(header, src)  # names stripped of spaces; a name given twice is refused here
        self.names = list(raw.columns)
        empty = normalise_frame(raw, src, self.opts, first_values=None)
        self.columns = list(empty.frame.columns)
        self.has_mag = all(c in self.columns for c in MAG_COLS + ACC_COLS)
        self.has_triad = has_triad_inputs(self.columns)
        with_values = frozenset(c for c in _COMPASS_COLUMNS if c in self.columns)
        self.stats.notes += table_notes(self.name, self.columns, with_values, empty.temperature)
        if empty.temperature == TEMP_ABSENT:  # no temp column: the drift model's T is the elapsed time ("auto")
            self.comp.temperature_absent()
        for note in self.stats.notes:
            self.warn(note)
        self.stats.run.compass = compass_form(with_values)
        if self.out_format == "csv":
            names = self._output([], empty.frame).columns
            self.write(csv_header(names).decode("utf-8"))
        if first is not None:
            self.block([(line_no, first)])

    # -- data
    def lines(self, lines: list[tuple[int, str]]) -> None:
        """Data lines (number, text): parsed, converted and pushed as one block."""
        records = []
        for line_no, line in lines:
            if self.reader is None:
                self.start(line, line_no)
                continue
            try:
                records.append((line_no, self.reader.record(line, line_no)))
            except LogFormatError as exc:
                if not self.skip_bad and records:
                    self.block(records)  # the lines before it are written before it stops the stream
                self._bad(exc)
        if records:
            self.block(records)

    def _bad(self, exc: LogFormatError) -> None:
        if not self.skip_bad:
            raise exc
        self.stats.skipped += 1
        self.warn(f"{exc}; line skipped")

    def _convert(self, records: list[tuple[int, list]]) -> pd.DataFrame:
        """Records → the rows in the input contract (:func:`normalise_frame`), or a LogFormatError."""
        line_nos = [n for n, _ in records]
        frame = pd.DataFrame([cells for _, cells in records], columns=self.names)
        src = self._source(line_nos)
        df = normalise_frame(frame, src, self.opts, prev_t_s=self.prev_t_s, first_values=None).frame
        if self.prev_t_s is None:  # the first sample: gyro_z and temp needed (later empty cells hold)
            for col in (GYRO_Z, TEMP):
                if math.isnan(df[col].iloc[0]):
                    raise format_error(src, f"the first data row has no {col} value",
                                       f"drop the leading rows without {col} data", where=cell_label(src, 0, col))
        return df

    def block(self, records: list[tuple[int, list]]) -> None:
        """Convert and push the records of one read; write the rows the pushes return."""
        try:
            df = self._convert(records)
        except LogFormatError as exc:
            if len(records) > 1 and not self.skip_bad:
                self._good_part(records)  # the lines before the bad one, written before it stops
            if len(records) == 1 or not self.skip_bad:
                self._bad(exc)
                return
            for record in records:  # one by one, to skip only the bad lines
                try:
                    df = self._convert([record])
                except LogFormatError as one:
                    self._bad(one)
                else:
                    self._push([record], df)
            return
        self._push(records, df)

    def _good_part(self, records: list[tuple[int, list]]) -> None:
        """Push the longest run of ``records`` from the first that converts (the block has a
        bad line): halving, a few conversions whatever the size of the block."""
        good, bad, df = 0, len(records), None
        while bad - good > 1:
            mid = (good + bad) // 2
            try:
                df, good = self._convert(records[:mid]), mid
            except LogFormatError:
                bad = mid
        if good:
            self._push(records[:good], df if df is not None and len(df) == good else self._convert(records[:good]))

    def _time_error(self, exc: GyroDriftError, where: str) -> GyroDriftError:
        """The compensator's refusal of the time base (:meth:`Compensator.judge_times_as`) as
        the file reader words it, at ``where``; any other error as it is."""
        found = getattr(exc, "time_base", None)
        if found is None:
            return exc
        return log_error(self.name, found.problem, found.advice, where=where)

    def _push(self, records, df: pd.DataFrame) -> None:
        if self.prev_t_s is None and not self.opts.frame_stated:  # the first rows say which way z points
            check_z_up(df, self._source([n for n, _ in records]))
        cols = {c: df[c].to_numpy(float).tolist() for c in (T, GYRO_Z, TEMP)}
        heading = df[HEADING].to_numpy(float).tolist() if HEADING in df.columns else None
        mag = df[list(MAG_COLS)].to_numpy(float).tolist() if self.has_mag else None
        acc = df[list(ACC_COLS)].to_numpy(float).tolist() if self.has_mag or self.has_triad else None
        gx = df[GYRO_X].to_numpy(float).tolist() if self.has_triad else None
        gy = df[GYRO_Y].to_numpy(float).tolist() if self.has_triad else None
        self.pending.append(df)
        rows: list[CompensatedSample] = []
        try:
            for i, t_s in enumerate(cols[T]):
                rows += self.comp.push(
                    t_s, cols[GYRO_Z][i], cols[TEMP][i], heading_deg=math.nan if heading is None else heading[i],
                    mag=None if mag is None else mag[i], acc=None if acc is None else acc[i],
                    gyro_x_dps=None if gx is None else gx[i], gyro_y_dps=None if gy is None else gy[i],
                )
                self.stats.rows_in += 1
        except GyroDriftError as exc:
            self.emit(rows)  # the rows of the samples before it
            error = self._time_error(exc, f"line {records[i][0]}, column 't'")
            if error is exc:
                raise
            raise error from None
        self.prev_t_s, self.prev_line = cols[T][-1], records[-1][0]
        self.emit(rows)

    # -- output
    def _take(self, n: int) -> pd.DataFrame:
        """The first ``n`` pending input rows (the inputs of the next ``n`` output rows)."""
        parts, left = [], n
        while left:
            head = self.pending[0]
            if len(head) <= left:
                parts.append(self.pending.pop(0))
                left -= len(head)
            else:
                parts.append(head.iloc[:left])
                self.pending[0] = head.iloc[left:]
                left = 0
        rows = parts[0] if len(parts) == 1 else pd.concat(parts)
        return rows.reset_index(drop=True)

    def _output(self, samples: list[CompensatedSample], inputs: pd.DataFrame) -> pd.DataFrame:
        """The output table of these rows: the columns ``gyrodrift compensate`` writes."""
        names = _Z_COLUMNS + (TRIAD_COLUMNS if self.has_triad else ())
        out = pd.DataFrame({name: [getattr(s, name) for s in samples] for name in names})
        return join_input_columns(out, inputs)

    def emit(self, samples: list[CompensatedSample]) -> None:
        """Write output rows (one call of ``write``) and account for them."""
        if not samples:
            return
        out = self._output(samples, self._take(len(samples)))
        self.write(_csv_text(out) if self.out_format == "csv" else _jsonl_text(out))
        self.written.append(out)
        self.written_rows += len(out)
        if self.written_rows >= ACCOUNT_ROWS:
            self._account()

    def _account(self) -> None:
        """Add the rows written since the last call to :attr:`StreamStats.run`."""
        if self.written:
            self.stats.run.add(pd.concat(self.written, ignore_index=True) if len(self.written) > 1 else self.written[0])
        self.written, self.written_rows = [], 0

    def finish(self) -> None:
        """The rows the compensator still holds (end of input), after judging the time base of a
        stream too short to be judged as it came; the run's account complete."""
        try:
            rows = self.comp.flush()
        except GyroDriftError as exc:
            error = self._time_error(exc, "column 't'")
            if error is exc:
                raise
            raise error from None
        self.emit(rows)
        self._account()


def _too_long(source: str, line_no: int) -> LogFormatError:
    """The error for a line longer than :data:`MAX_LINE_CHARS`."""
    return log_error(source, f"longer than {MAX_LINE_CHARS:,} characters without a line end",
                     "give one sample per line (is the input text, one line per sample?)", where=f"line {line_no}")


def _csv_text(out: pd.DataFrame) -> str:
    """The CSV data lines of ``out``, printed as :func:`gyrodrift.io.write_table` prints them."""
    sink = pa.BufferOutputStream()
    table = csv_table(out)
    if table is None or not write_csv_rows(table, sink):
        write_csv_with_pandas(out, sink, header=False)
    return sink.getvalue().to_pybytes().decode("utf-8")


def _jsonl_text(out: pd.DataFrame) -> str:
    """One JSON object per row of ``out`` (NaN and empty cells as null)."""
    columns = {c: out[c].tolist() for c in out.columns}
    names = list(columns)
    lines = []
    for values in zip(*columns.values()):
        row = {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in zip(names, values)}
        lines.append(json.dumps(row, allow_nan=False, default=_json_value) + "\n")
    return "".join(lines)


def _json_value(v):
    """JSON for the values :func:`json.dumps` does not know (numpy scalars, timestamps)."""
    if isinstance(v, np.generic):
        return v.item()
    return str(v)


def stream_rows(
    blocks: Iterable[str],
    write: Callable[[str], object],
    config: CompensatorConfig | None = None,
    *,
    fmt: str | None = None,
    out_format: str | None = None,
    gyro_unit: str = "deg/s",
    frame: str | None = None,
    column_map=None,
    time_unit: str | None = None,
    source: str = "stdin",
    skip_bad: bool = False,
    warn: Callable[[str], object] | None = None,
    compensator: Compensator | None = None,
) -> StreamStats:
    """Compensate samples as they arrive and write the output rows as they come.

    See docs/streaming.md, section "gyrodrift stream".

    Parameters
    ----------
    blocks : iterable of str
        The input text in pieces of any size as it arrives; the complete lines of a piece
        are compensated and written before the next piece is taken.
    write : callable
        ``write(text)`` gets the output: the CSV header first (CSV output), then the lines
        of the rows each piece gave.
    config : CompensatorConfig, optional
        Settings of the compensator made here (ignored with ``compensator``).
    fmt, out_format : {"csv", "jsonl"}, optional
        Input format (default: by the first non-blank character) and output format
        (default: the input's).
    gyro_unit, frame, column_map, time_unit
        As :func:`gyrodrift.io.read_log`.
    source : str
        The input's name in messages.
    skip_bad : bool
        Skip a bad line with a warning instead of stopping.
    warn : callable, optional
        ``warn(line)`` gets each note and warning as it arises; default: dropped.
    compensator : Compensator, optional
        The compensator to feed (e.g. warm-started; it gets times in seconds); default a
        new one from ``config``.

    Returns
    -------
    StreamStats
        Rows in and out, skipped lines, notes, and the signal that ended the input if one
        did (a :class:`StreamInterrupted` from ``blocks`` ends the input like its end).

    Raises
    ------
    LogFormatError
        A bad line (without ``skip_bad``; every row before it is written first), a bad
        header, a line longer than :data:`MAX_LINE_CHARS`, a refused time base, or no data
        rows; its ``stream_stats`` say what was read and written before it.
    ConfigError
        A bad ``fmt``, ``out_format``, ``gyro_unit``, ``frame`` or ``column_map``.
    """
    for option, value in (("format", fmt), ("output format", out_format)):
        if value is not None and value not in FORMATS:
            raise ConfigError(f"unknown {option} {value!r}; use one of: {', '.join(FORMATS)}")
    opts = read_options(gyro_unit, frame, column_map, time_unit)
    comp = compensator if compensator is not None else Compensator(config, source=source, gyro_unit=opts.gyro_unit)
    comp.judge_times_as(opts.time_unit)  # the text's time stamps judged as a file's (its unit, or none stated)
    state = _Stream(write, comp, fmt=fmt, out_format=out_format, opts=opts, name=source, skip_bad=skip_bad,
                    warn=warn or (lambda line: None))
    carry: list[str] = []  # the pieces of an unfinished line, which waits for the rest
    carry_chars, line_no, started = 0, 0, False
    try:
        try:
            for piece in blocks:
                if not started and piece:  # a UTF-8 byte-order mark, as some programs write, is not text
                    piece, started = piece.removeprefix(BOM), True
                if "\n" not in piece:
                    carry.append(piece)
                    carry_chars += len(piece)
                    if carry_chars > MAX_LINE_CHARS:
                        raise _too_long(source, line_no + 1)
                    continue
                lines = ("".join(carry) + piece).split("\n")
                tail = lines.pop()
                carry, carry_chars = [tail], len(tail)
                numbered = []
                for line in lines:
                    line_no += 1
                    if len(line) > MAX_LINE_CHARS:
                        raise _too_long(source, line_no)
                    if line.strip():
                        numbered.append((line_no, line.rstrip("\r")))
                if numbered:
                    state.lines(numbered)
        except StreamInterrupted as stop:
            state.stats.signal = stop.signum
            carry = []  # an unfinished line is not a sample
        tail = "".join(carry)
        if tail.strip():
            state.lines([(line_no + 1, tail.rstrip("\r"))])
        if state.stats.rows_in:
            state.finish()
    except LogFormatError as stop:  # a bad line stops the stream: every row before it is written first
        if state.stats.rows_in:
            try:
                state.finish()
            except GyroDriftError:  # the first problem is the one to report
                pass
        stop.stream_stats = state.stats  # what was read and written before it
        raise
    if state.stats.rows_in == 0 and state.stats.signal is None:
        where = Source(source, "csv", None)
        if state.reader is None:
            raise log_error(source, "no input",
                            "give a CSV header line and samples, or JSON lines (one object per line)")
        raise no_data_rows_error(where)
    for note in comp.notes:
        state.warn(note)
    state.stats.notes += comp.notes
    run = state.stats.run
    run.final_params, run.final_cov, run.estimator = comp.params, comp.cov, comp.estimator.name
    if comp.compass_dead:
        run.compass = "none"
    return state.stats

