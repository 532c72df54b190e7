"""File in, file out: read a log, compensate it, write the result, in constant memory when it can.

:func:`compensate_file` is what ``gyrodrift compensate`` runs: CSV and Parquet logs in
chunks, on threads that read ahead and write behind; other formats, ``--smooth`` and
``--scale-factor`` in memory. :class:`RunStats` gathers what the command prints. See
docs/streaming.md, section "gyrodrift compensate".
"""

from __future__ import annotations

import math
import queue
import sys
import threading
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from gyrodrift import gating
from gyrodrift._columns import join_input_columns
from gyrodrift.compensator import CompensatorConfig, check_input_columns, compensate
from gyrodrift.conventions import GYRO_Z, REF_HEADING, TEMP, TRUE_BIAS_Z, T, wrap_180
from gyrodrift.errors import GyroDriftError
from gyrodrift.io import ReadOptions

__all__ = ["compensate_file", "describe_log", "RunStats", "CHUNK_ROWS", "available_memory_bytes"]

#: Rows per chunk of the streaming path: small enough to overlap reading, compensating and writing and to bound memory.
CHUNK_ROWS = 250_000
#: Chunks the reader thread reads ahead of the compensation.
READ_AHEAD = 4


@dataclass
class RunStats:
    """What a run read and found, accumulated chunk by chunk (see :meth:`add`)."""

    source: str
    read_summary: str | None = None
    compass: str = "?"
    rows: int = 0
    t_first_s: float = math.nan
    t_last_s: float = math.nan
    temp_min_c: float = math.inf
    temp_max_c: float = -math.inf
    updates: int = 0
    refused: np.ndarray = field(default_factory=lambda: np.zeros(len(gating.REASONS), dtype=np.int64))
    final_params: np.ndarray | None = None
    final_cov: np.ndarray | None = None
    estimator: str = ""
    #: What the drift model's T was: "temperature", or "clock" (the elapsed time).
    regressor: str = "temperature"
    #: True when the rows went through in pieces (the chunked path, or ``gyrodrift stream``), not whole in memory.
    streamed: bool = False
    #: ``bias_z`` of the last row, deg/s (the final drift, whatever the drift model's T).
    last_bias_dps: float = math.nan
    #: Things the run had to do that the user may want to know (e.g. a column read again with another type).
    notes: list = field(default_factory=list)
    # accuracy accumulators (sum of squares, max |error|, count)
    _heading: list = field(default_factory=lambda: [0.0, 0.0, 0, 0.0, 0.0])  # raw ss, ss, n, raw max, max
    _bias: list = field(default_factory=lambda: [0.0, 0.0, 0])  # raw ss, ss, n
    _bias_xy: dict = field(default_factory=dict)  # axis -> [raw ss, ss, n]
    _other_headings: dict = field(default_factory=dict)  # column -> [ss, n, max]
    _raw: tuple | None = None  # (t, gyro, raw heading) of the last row

    def add(self, out: pd.DataFrame) -> None:
        """Account for output rows (with the pass-through input columns), in order."""
        if len(out) == 0:
            return
        t = out[T].to_numpy(float)
        if self.rows == 0:
            self.t_first_s = float(t[0])
        self.t_last_s = float(t[-1])
        self.rows += len(out)
        temp = out[TEMP if TEMP in out.columns else f"in_{TEMP}"].to_numpy(float)
        if np.isfinite(temp).any():
            self.temp_min_c = min(self.temp_min_c, float(np.nanmin(temp)))
            self.temp_max_c = max(self.temp_max_c, float(np.nanmax(temp)))
        self.updates += int(out["updated"].to_numpy().sum(dtype=np.int64))
        self.last_bias_dps = float(out["bias_z"].iloc[-1])
        codes = pd.Categorical(out["gate_reason"], categories=gating.REASONS).codes
        self.refused += np.bincount(codes[codes >= 0], minlength=len(gating.REASONS))
        if REF_HEADING in out.columns and GYRO_Z in out.columns:
            self._add_heading(t, out)
        if TRUE_BIAS_Z in out.columns:
            _add_bias(self._bias, out[TRUE_BIAS_Z], out["bias_z"])
        for axis in ("x", "y"):
            if f"true_bias_{axis}" in out.columns and f"bias_{axis}" in out.columns:
                _add_bias(self._bias_xy.setdefault(axis, [0.0, 0.0, 0]), out[f"true_bias_{axis}"], out[f"bias_{axis}"])

    def _add_heading(self, t: np.ndarray, out: pd.DataFrame) -> None:
        """Raw-gyro heading (trapezoid, from the first compensated heading; an empty gyro cell
        holds the previous value, as in the compensator) and both errors."""
        g = out[GYRO_Z].to_numpy(float)
        if self._raw is None:
            t_prev, g_prev, raw_prev = float(t[0]), float(g[0]), float(out["heading"].iloc[0])
        else:
            t_prev, g_prev, raw_prev = self._raw
        if not np.isfinite(g).all():
            g = pd.Series(np.where(np.isfinite(g), g, np.nan)).ffill().fillna(g_prev).to_numpy()
        inc = 0.5 * (g + np.r_[g_prev, g[:-1]]) * (t - np.r_[t_prev, t[:-1]])
        raw = raw_prev + np.cumsum(inc)
        self._raw = (float(t[-1]), float(g[-1]), float(raw[-1]))
        ref = out[REF_HEADING].to_numpy(float)
        for col in ("heading_fused", "heading_sf"):
            if col in out.columns:
                e_other = wrap_180(out[col].to_numpy(float) - ref)
                e_other = e_other[np.isfinite(e_other)]
                acc = self._other_headings.setdefault(col, [0.0, 0, 0.0])
                acc[0] += float(np.sum(e_other**2))
                acc[1] += e_other.size
                if e_other.size:
                    acc[2] = max(acc[2], float(np.max(np.abs(e_other))))
        ok = np.isfinite(ref)
        e_raw = wrap_180(raw[ok] - ref[ok])
        e = wrap_180(out["heading"].to_numpy(float)[ok] - ref[ok])
        acc = self._heading
        acc[0] += float(np.sum(e_raw**2))
        acc[1] += float(np.sum(e**2))
        acc[2] += int(ok.sum())
        if ok.any():
            acc[3] = max(acc[3], float(np.max(np.abs(e_raw))))
            acc[4] = max(acc[4], float(np.max(np.abs(e))))

    # ------------------------------------------------------------------ text
    def read_line(self) -> str:
        """One line on what was read."""
        if self.read_summary:  # ULog, DataFlash and ROS readers say what they used
            return f"read {self.source}: {self.read_summary}"
        return _read_text(self.source, self.rows, self.t_first_s, self.t_last_s, self.temp_min_c, self.temp_max_c,
                          self.compass)

    def _model_line(self) -> str:
        """The final drift model; on the clock (no temperature, or one that never changes) the
        drift at the last row, as the model's a and b are then per unit of time, not per degC."""
        if self.regressor == "clock":
            return f"final drift (a drift model in time, no temperature): {self.last_bias_dps:.6g} deg/s"
        a, b, c = (float(v) for v in self.final_params)
        return f"final drift model: a = {a:.6g} deg/s/degC, b = {b:.6g} deg/degC, c = {c:.6g} deg/s"

    def result_lines(self) -> list[str]:
        shares = ", ".join(
            f"{name} {100 * n / self.rows:.1f} %"
            for name, n in sorted(zip(gating.REASONS, self.refused), key=lambda kv: -kv[1])
            if name and n
        ) or "never"
        lines = [
            *(f"note: {n}" for n in self.notes),
            f"{self.updates} filter updates; compass aiding refused: {shares} of rows",
            self._model_line(),
        ]
        for axis, (raw_ss, ss, n) in {"z": self._bias, **self._bias_xy}.items():
            if n:  # the heading axis's line names no axis
                lines.append(
                    f"{'' if axis == 'z' else axis + ' '}drift error RMS vs true_bias_{axis}: "
                    f"raw {math.sqrt(raw_ss / n):.4f} deg/s -> compensated {math.sqrt(ss / n):.4f} deg/s"
                )
        raw_ss, ss, n, raw_max, e_max = self._heading
        if n:
            lines.append(
                f"heading error vs ref_heading: raw gyro RMS {math.sqrt(raw_ss / n):.2f} deg (max {raw_max:.2f}) "
                f"-> compensated RMS {math.sqrt(ss / n):.2f} deg (max {e_max:.2f})"
            )
        for col, (ss, n, e_max) in self._other_headings.items():
            if n:
                lines.append(f"{col} error vs ref_heading: RMS {math.sqrt(ss / n):.2f} deg (max {e_max:.2f})")
        return lines


def _add_bias(acc: list, truth, estimate) -> None:
    """Accumulate the squares of the raw drift and of the estimate's error (finite rows)."""
    truth = np.asarray(truth, dtype=float)
    e = np.asarray(estimate, dtype=float) - truth
    ok = np.isfinite(e)
    acc[0] += float(np.sum(truth[ok] ** 2))
    acc[1] += float(np.sum(e[ok] ** 2))
    acc[2] += int(ok.sum())


def _read_text(source, rows: int, t_first_s: float, t_last_s: float, temp_min_c: float, temp_max_c: float,
               compass: str) -> str:
    dur = t_last_s - t_first_s
    rate = (rows - 1) / dur if dur > 0 else float("nan")
    rate_text = f"{rate:.1f}" if not rate < 1.0 else f"{rate:.2g}"  # a rate below 1 Hz keeps its digits
    return (
        f"read {source}: {rows} rows, {dur:.1f} s at {rate_text} Hz, "
        f"temperature {temp_min_c:.2f} to {temp_max_c:.2f} degC, compass from {compass}"
    )


def describe_log(log: pd.DataFrame, source) -> str:
    """One line on a log read in memory (the line :meth:`RunStats.read_line` prints)."""
    if log.attrs.get("summary"):
        return f"read {source}: {log.attrs['summary']}"
    temp = log[TEMP]
    return _read_text(source, len(log), float(log[T].iloc[0]), float(log[T].iloc[-1]), float(temp.min()),
                      float(temp.max()), log.attrs.get("compass", "?"))


def _table_format(path: Path, fmt: str | None) -> str | None:
    from gyrodrift.io import log_format as _log_format

    return _log_format(path, fmt)


def compensate_file(
    input_path,
    output_path,
    config: CompensatorConfig | None = None,
    *,
    read_options: ReadOptions | dict | None = None,
    chunk_rows: int = CHUNK_ROWS,
    chunked: bool | None = None,
    progress=None,
    scale_factor: bool = False,
    smooth: bool = False,
    prior=None,
    stream: bool | None = None,
) -> RunStats:
    """Compensate the log at ``input_path`` and write the output table to ``output_path``.

    Parameters
    ----------
    input_path, output_path : str or os.PathLike
        The log (any format of :func:`gyrodrift.io.read_log`) and the output table (CSV or
        Parquet by its name), written atomically; the input is never modified.
    config : CompensatorConfig, optional
    read_options : ReadOptions or dict, optional
        How to read the log (:class:`gyrodrift.io.ReadOptions`, or a dict of its fields).
    chunk_rows : int
        Rows per chunk of the chunked path.
    chunked : bool, optional
        Force (True) or forbid (False) the chunked path; default: chunked when it can.
    progress : callable, optional
        ``progress(iterable, total, **options)`` wraps a loop of the run and yields its
        items: the chunks read (``total`` the log's rows, None when unknown; ``unit="rows"``,
        ``size=len``), or the in-memory :func:`compensate`'s chunks of rows.
    scale_factor : bool
        Also estimate the gyro scale factor over the turns
        (:func:`gyrodrift.scale_factor.estimate_scale_factor`), in memory.
    smooth : bool
        Recompensate with the drift smoothed over the whole log
        (:func:`gyrodrift.smooth.smooth_output`; non-causal), in memory.
    prior : gyrodrift.calibrate.Calibration, optional
        An autopilot's thermal calibration (:func:`gyrodrift.paramfiles.read_prior`): the z drift
        model starts from it at the log's first temperature (:func:`gyrodrift.calibrate.prior_config`),
        read in the same pass as the rest.
    stream : bool, optional
        The old name of ``chunked`` (a DeprecationWarning).

    Returns
    -------
    RunStats
    """
    from gyrodrift.errors import ConfigError
    from gyrodrift.io import write_table

    if stream is not None:
        warnings.warn("compensate_file(stream=...) is now chunked=...", DeprecationWarning, stacklevel=2)
        chunked = stream if chunked is None else chunked
    cfg = config or CompensatorConfig()
    opts = ReadOptions.of(read_options)
    input_path, output_path = Path(input_path), Path(output_path)
    table = _table_format(input_path, opts.fmt) in ("csv", "parquet")
    can_chunk = table and opts.tables_only  # else the reader refuses the options
    if chunked and not can_chunk:
        raise ConfigError(f"{input_path}: cannot read this log in chunks (needs a CSV or Parquet log)")
    if chunked and (scale_factor or smooth):
        raise ConfigError(f"{input_path}: the scale-factor estimate and smoothing need the whole log in memory; "
                          "do not force the chunked path")
    if chunked is None:
        chunked = can_chunk and not (scale_factor or smooth)
    if not chunked:
        if can_chunk:
            _check_fits_in_memory(input_path, opts.fmt, *_why_in_memory(scale_factor, smooth))
        log = opts.read(input_path)
        if prior is not None:
            cfg = _with_prior(prior, cfg, log, input_path)
        if scale_factor:  # the paper's scale-factor stage estimates the whole scale factor
            cfg = cfg.without_scale_factor()
        out = compensate(log, cfg, source=str(input_path), progress=progress)
        if smooth:
            from gyrodrift.smooth import smooth_output

            out = smooth_output(out, cfg)
        if scale_factor:
            out = _with_scale_factor(out, cfg)
        write_table(out, output_path)
        stats = RunStats(str(input_path), read_summary=log.attrs.get("summary"),
                         compass=out.attrs.get("compass") or log.attrs.get("compass", "?"))
        stats.add(out)
        stats.final_params, stats.final_cov = out.attrs["final_params"], out.attrs["final_cov"]
        stats.estimator = str(out.attrs.get("estimator", ""))
        stats.regressor = str(out.attrs.get("drift_regressor", "temperature"))
        stats.notes = list(out.attrs.get("notes", ()))
        return stats
    return _stream(input_path, output_path, cfg, opts, chunk_rows, progress, prior)


def _with_prior(prior, cfg: CompensatorConfig, log: pd.DataFrame, source) -> CompensatorConfig:
    """``cfg`` started from the calibration ``prior`` at the first finite temperature of ``log``."""
    from gyrodrift.calibrate import prior_config
    from gyrodrift.errors import ConfigError

    temps = log[TEMP].to_numpy(dtype=float)
    finite = temps[np.isfinite(temps)]
    if not finite.size:
        raise ConfigError(f"{source}: no temperature in its first {len(temps)} rows; a calibration (--prior) starts "
                          "the drift model at the log's first temperature")
    return prior_config(prior, cfg, float(finite[0]))


class _Ahead:
    """Iterate ``iterator`` in a background thread, up to ``depth`` items ahead, in order; its exception
    is raised in the consuming thread. :meth:`close` stops the thread (before closing what it reads)."""

    def __init__(self, iterator, depth: int = 1):
        self._queue: queue.Queue = queue.Queue(maxsize=depth)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(iterator,), name="gyrodrift-read", daemon=True)
        self._thread.start()

    def _put(self, item) -> bool:
        while not self._stop.is_set():
            try:
                self._queue.put(item, timeout=0.1)
                return True
            except queue.Full:
                continue
        return False

    def _run(self, iterator) -> None:
        try:
            for value in iterator:
                if not self._put(("item", value)):
                    return
            self._put(("end", None))
        except BaseException as exc:  # handed to the consumer, raised there
            self._put(("error", exc))

    def __iter__(self):
        while True:
            kind, value = self._queue.get()
            if kind == "item":
                yield value
            elif kind == "end":
                return
            else:
                raise value

    def close(self) -> None:
        self._stop.set()
        self._thread.join()


class _Behind:
    """Call ``write(item)`` for each :meth:`put` item in a background thread, in order; an exception in
    ``write`` is raised by the next :meth:`put` or by :meth:`close`."""

    def __init__(self, write, depth: int = 1):
        self._write = write
        self._queue: queue.Queue = queue.Queue(maxsize=depth)
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="gyrodrift-write", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is None:
                return
            if self.error is None:
                try:
                    self._write(item)
                except BaseException as exc:
                    self.error = exc

    def put(self, item) -> None:
        if self.error is not None:
            raise self.error
        self._queue.put(item)

    def close(self) -> None:
        """Wait for every write; raise the first write error."""
        self._queue.put(None)
        self._thread.join()
        if self.error is not None:
            raise self.error


#: Columns of :func:`gyrodrift.scale_factor.estimate_scale_factor` added by ``scale_factor=True``.
SF_COLUMNS = ("sf", "sf_sd", "rate_sf", "heading_sf")


#: Least memory the in-memory path takes per row of the log, bytes: a floor (docs/streaming.md,
#: section "gyrodrift compensate", gives the measurements).
IN_MEMORY_MIN_BYTES_PER_ROW = 300


def available_memory_bytes() -> int | None:
    """``MemAvailable`` plus ``SwapFree`` of /proc/meminfo, bytes; None where there is none."""
    try:
        with open("/proc/meminfo") as f:
            fields = dict(line.split(":", 1) for line in f if ":" in line)
        return sum(int(fields[k].split()[0]) * 1024 for k in ("MemAvailable", "SwapFree") if k in fields)
    except (OSError, ValueError, KeyError):
        return None


#: Endings of compressed files, whose rows :func:`_estimated_rows` does not guess.
_COMPRESSED_SUFFIXES = (".gz", ".bz2", ".xz", ".zst", ".zip")


def _estimated_rows(path: Path, fmt: str | None = None) -> int | None:
    """Rows of a CSV or Parquet log, cheaply: the Parquet footer, or the CSV size over the
    mean line length of its first MiB; None when it cannot tell (a compressed CSV)."""
    try:
        if _table_format(path, fmt) == "parquet":
            import pyarrow.parquet as pq

            return int(pq.ParquetFile(path).metadata.num_rows)
        if path.suffix.lower() in _COMPRESSED_SUFFIXES:
            return None
        with open(path, "rb") as f:
            head = f.read(1 << 20)
        lines = head.count(b"\n")
        return int(path.stat().st_size * lines / len(head)) if lines else None
    except Exception:  # the reader gives the real error about an unreadable file
        return None


def _why_in_memory(scale_factor: bool, smooth: bool) -> tuple[str, str]:
    """Why a CSV or Parquet run is kept in memory, and how it could stream instead."""
    if scale_factor or smooth:
        what = " and ".join(n for n, on in (("--scale-factor", scale_factor), ("--smooth", smooth)) if on)
        verb = "need" if scale_factor and smooth else "needs"
        return f"{what} {verb} the whole log in memory", f"drop {what} to stream it in constant memory"
    return "this run is kept in memory (chunked=False)", "let it run in chunks (chunked=None)"


def _check_fits_in_memory(path: Path, fmt: str | None, why: str, advice: str) -> None:
    """Refuse, before reading, a table log the in-memory path cannot hold (Linux; elsewhere
    the run goes on); ``why`` it is in memory and the ``advice`` (:func:`_why_in_memory`)."""
    rows, available = _estimated_rows(path, fmt), available_memory_bytes()
    if rows is None or available is None:
        return
    need = rows * IN_MEMORY_MIN_BYTES_PER_ROW
    if need <= available:
        return
    raise GyroDriftError(
        f"{path}: about {rows / 1e6:.1f} million rows; {why}: at least {need / 2**30:.1f} GiB, and this "
        f"machine has {available / 2**30:.1f} GiB available. {advice[0].upper()}{advice[1:]}, or split the log"
    )


def _with_scale_factor(out: pd.DataFrame, cfg: CompensatorConfig) -> pd.DataFrame:
    """``out`` with the scale-factor columns inserted after ``heading_sd``, estimated with the
    sensors' noise of ``cfg``."""
    from gyrodrift.scale_factor import ScaleFactorConfig, estimate_scale_factor

    sf = estimate_scale_factor(out, ScaleFactorConfig().with_sensor(cfg))
    at = list(out.columns).index("heading_sd") + 1
    for k, name in enumerate(SF_COLUMNS):
        out.insert(at + k, name, sf[name].to_numpy())
    out.attrs["scale_factor"] = {"final_params": sf.attrs["final_params"], "turns": int(sf.attrs["turns"]["accepted"].sum())}
    return out


def _stream(input_path: Path, output_path: Path, cfg: CompensatorConfig, opts: ReadOptions, chunk_rows: int,
            progress=None, prior=None) -> RunStats:
    """The chunked path: read ahead in one thread, write behind in another, compensate here,
    with a short GIL switch interval; a column that changes type starts the run over
    (docs/streaming.md, section "gyrodrift compensate")."""
    from gyrodrift.io.chunked import ColumnTypeChanged

    switch = sys.getswitchinterval()
    sys.setswitchinterval(min(switch, 0.0005))
    column_types: dict[str, str] = {}
    notes: dict[str, str] = {}  # column -> what was done, the last word on it
    try:
        while True:
            try:
                stats = _stream_threads(input_path, output_path, cfg, opts, chunk_rows, column_types, progress, prior)
            except ColumnTypeChanged as exc:
                pinned = column_types.get(exc.column)
                if pinned == "string":
                    raise
                kind = "string" if pinned == "float64" else exc.suggested_type  # numbers, then text: text
                column_types[exc.column] = kind
                notes[exc.column] = (
                    f"column {exc.column!r} read as {'numbers' if kind == 'float64' else 'text'}: its cells change "
                    f"type after the start of the file ({exc.value!r}); the file was read again"
                )
                continue
            stats.notes = list(notes.values()) + stats.notes
            return stats
    finally:
        sys.setswitchinterval(switch)


def _stream_threads(input_path: Path, output_path: Path, cfg: CompensatorConfig, opts: ReadOptions, chunk_rows: int,
                    column_types: dict[str, str], progress=None, prior=None) -> RunStats:
    import itertools

    from gyrodrift.compensator.intake import Intake, chunk_arrays, needs_survey, survey
    from gyrodrift.errors import LogFormatError
    from gyrodrift.io.chunked import ChunkWriter, iter_log_chunks

    source = str(input_path)
    stats = RunStats(source, streamed=True)
    pending: list[pd.DataFrame] = []  # input rows not yet out of the engine
    table_opts = opts.table_keywords()

    def chunks_of(path):
        return iter_log_chunks(path, chunk_rows=chunk_rows, column_types=column_types or None, **table_opts)

    # one Parquet row group per chunk, encoded as it comes (docs/streaming.md)
    with chunks_of(input_path) as chunks, ChunkWriter(output_path, row_group_rows=chunk_rows) as writer:
        reader = _Ahead(chunks, depth=READ_AHEAD)
        behind = _Behind(writer.write)
        try:
            read = iter(reader)
            first = next(read, None)
            if first is None:
                raise LogFormatError(f"{source}: the log has no samples")
            check_input_columns(first, source)
            if prior is not None:  # the drift model starts from the calibration at the first chunk's temperature
                cfg = _with_prior(prior, cfg, first, input_path)
            whole = None
            if needs_survey(cfg, first):  # one reading of the whole file first (gyrodrift.compensator.intake)
                with chunks_of(input_path) as again:
                    whole = survey(again, cfg, source)
            # numba starts up here and in the first feed, while the reader thread reads on
            intake = Intake(cfg, source, whole=whole, gyro_unit=opts.gyro_unit, record=False)

            def emit(cols) -> None:
                """Write the rows the engine gave back, with their input columns."""
                nonlocal pending
                rows = (pd.concat(pending) if len(pending) > 1 else pending[0]).reset_index(drop=True)
                pending = []
                out = join_input_columns(intake.frame(cols), rows)
                behind.put(writer.encode(out))  # Arrow conversion here: the writer thread is the busiest
                stats.add(out)

            chunks_read = itertools.chain([first], read)
            if progress is not None:
                rows = whole.rows if whole is not None and whole.rows else _estimated_rows(input_path, opts.fmt)
                chunks_read = progress(chunks_read, rows, unit="rows", size=len)
            for log in chunks_read:
                check_input_columns(log, source)
                pending.append(log)
                cols = intake.feed(*chunk_arrays(log))
                if cols is not None:
                    emit(cols)
            cols = intake.flush()  # a log shorter than the init window
            if cols is not None:
                emit(cols)
            intake.engine.finish()
        finally:
            reader.close()
            behind.close()
        stats.compass = "none" if intake.compass_dead else chunks.compass or "?"
        stats.notes = [*getattr(chunks, "notes", ()), *intake.notes]
    est = intake.estimator
    stats.final_params, stats.final_cov, stats.estimator = est.params, est.cov, est.name
    stats.regressor = intake.engine.regressor
    return stats

