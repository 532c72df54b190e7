"""Fleets of logs: compensate many logs at once, on local processes or a Dask cluster.

The logs, output names, summary and parallelism of ``gyrodrift batch``: docs/command-line.md,
section "gyrodrift batch: a fleet of logs".
"""

from __future__ import annotations

import glob
import math
import os
import time
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd

from gyrodrift._text import printable
from gyrodrift.errors import ConfigError, GyroDriftError

__all__ = [
    "LOG_SUFFIXES",
    "SUMMARY_COLUMNS",
    "OUT_FORMATS",
    "find_logs",
    "output_path",
    "process_one",
    "process_many",
    "summary_markdown",
    "write_summary",
    "error_line",
    "check_workers",
    "map_jobs",
]

#: File-name endings (lower case) that :func:`find_logs` picks up.
LOG_SUFFIXES = (".csv", ".csv.gz", ".parquet", ".pq", ".ulg", ".bin", ".bag", ".mcap", ".db3")
#: Output table formats of :func:`process_one` and their file-name endings.
OUT_FORMATS = {"parquet": ".parquet", "csv": ".csv"}
#: Columns of the summary table, in order.
SUMMARY_COLUMNS = (
    "file", "status", "error", "rows", "duration_s", "temp_min_c", "temp_max_c",
    "updates", "a", "b", "c", "seconds",
)
#: Name of the summary file ``gyrodrift batch`` writes in OUTDIR.
SUMMARY_FILE = "summary.csv"
#: How to install what ``dask_address`` needs.
DASK_INSTALL = "pip install 'gyrodrift[fleet]'"
_GLOB_CHARS = frozenset("*?[")
#: Endings stripped from a log's name to make its output name (longest first).
_STEM_SUFFIXES = tuple(sorted(LOG_SUFFIXES + (".txt", ".txt.gz"), key=len, reverse=True))


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def error_line(err: BaseException) -> str:
    """``Type: message`` of an exception, on one line."""
    text = _one_line(err)
    return f"{type(err).__name__}: {text}" if text else type(err).__name__


def map_jobs(job, items, workers: int, progress=None, on_error=None) -> list:
    """``[job(item) for item in items]``, in this process or in worker processes (:mod:`gyrodrift._pool`).

    ``progress(iterable, total)`` wraps the finished items; ``on_error(item, exception)`` is
    the result of an item whose worker failed.
    """
    items = list(items)
    if workers > 1 and len(items) > 1:
        from gyrodrift._pool import map_processes

        return map_processes(job, items, workers, progress, on_error=on_error)
    return [job(item) for item in (progress(iter(items), len(items)) if progress is not None else items)]


# --------------------------------------------------------------------------- finding logs


def _is_log(path: Path) -> bool:
    """True for a file with a supported ending, or a ROS 2 bag folder (``metadata.yaml``)."""
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    return path.is_file() and path.name.lower().endswith(LOG_SUFFIXES)


def find_logs(dir_or_glob) -> list[Path]:
    """The logs of a folder, a glob pattern or one log file, sorted by path.

    Raises
    ------
    ConfigError
        No log found, or the folder does not exist.
    """
    text = os.fspath(dir_or_glob)
    path = Path(text)
    accepted = ", ".join(LOG_SUFFIXES)
    advice = "give a folder of logs or a quoted glob pattern such as 'logs/*.csv'"
    if path.is_dir() and not _is_log(path):
        found, kind = [p for p in path.iterdir() if _is_log(p)], "folder"
    elif path.exists():
        found, kind = ([path] if _is_log(path) else []), "file"
    elif _GLOB_CHARS & set(text):
        found, kind = [Path(p) for p in glob.glob(text, recursive=True) if _is_log(Path(p))], "glob pattern"
    else:
        raise ConfigError(f"{text}: no such folder or file; {advice}")
    if not found:
        problem = "not a log file" if kind == "file" else f"no logs found in this {kind}"
        raise ConfigError(f"{text}: {problem} (accepted endings: {accepted}); {advice}")
    return sorted(found, key=str)


def common_root(paths) -> Path | None:
    """The deepest folder holding every log of ``paths`` (None for none), mirrored under the output folder."""
    parents = [os.path.abspath(Path(p).parent) for p in paths]
    return Path(os.path.commonpath(parents)) if parents else None


def output_path(path, out_dir, out_format: str = "parquet", root=None) -> Path:
    """Where :func:`process_one` writes the output of ``path``: ``out_dir/<sub>/<stem>_out.<ext>``.

    ``<sub>`` is the log's folder relative to ``root`` (none without it).
    """
    if out_format not in OUT_FORMATS:
        raise ConfigError(f"unknown output format {out_format!r}; use one of: {', '.join(OUT_FORMATS)}")
    name = Path(path).name
    lower = name.lower()
    stem = next((name[: -len(s)] for s in _STEM_SUFFIXES if lower.endswith(s) and len(name) > len(s)), None)
    stem = stem if stem is not None else Path(name).stem
    sub = Path(os.path.relpath(os.path.abspath(Path(path).parent), os.path.abspath(root))) if root is not None else Path()
    return Path(out_dir) / sub / f"{stem}_out{OUT_FORMATS[out_format]}"


# --------------------------------------------------------------------------- one log


def _empty_row(path) -> dict:
    row = {c: math.nan for c in SUMMARY_COLUMNS}
    row.update(file=str(path), status="error", error="", rows=None, updates=None)
    return row


def _error_text(err: BaseException) -> str:
    """One line: the message of a user error; type and message of anything else."""
    return _one_line(err) if isinstance(err, GyroDriftError) else "unexpected " + error_line(err)


def process_one(path, out_dir, *, config=None, out_format: str = "parquet", root=None, read_options=None,
                chunk_rows: int | None = None) -> dict:
    """Compensate one log into ``out_dir`` as ``gyrodrift compensate`` does; return its summary row.

    Never raises: a failure is ``status = "error"`` with a one-line ``error``. The arguments
    are those of :func:`process_many`; ``root`` is the folder mirrored (:func:`output_path`).
    """
    from gyrodrift.io import check_output_path
    from gyrodrift.pipeline import CHUNK_ROWS, compensate_file

    start = time.perf_counter()
    row = _empty_row(path)
    try:
        out_path = output_path(path, out_dir, out_format, root)
        check_output_path(path, out_path)
        out_path.parent.mkdir(parents=True, exist_ok=True)
        stats = compensate_file(path, out_path, config, read_options=read_options, chunk_rows=chunk_rows or CHUNK_ROWS)
        finite = lambda v: v if math.isfinite(v) else math.nan  # noqa: E731 (no temperature seen: inf)
        row.update(rows=stats.rows, duration_s=stats.t_last_s - stats.t_first_s, temp_min_c=finite(stats.temp_min_c),
                   temp_max_c=finite(stats.temp_max_c), status="ok", updates=stats.updates)
        if stats.regressor == "clock":  # a drift in time: no a, b per degC; c is the final drift
            row.update(a=math.nan, b=math.nan, c=stats.last_bias_dps)
        else:
            row.update(zip("abc", (float(v) for v in stats.final_params)))
    except Exception as err:  # one bad file never stops the rest: report it in the row
        row.update(status="error", error=_error_text(err))
    row["seconds"] = time.perf_counter() - start
    return row


# --------------------------------------------------------------------------- many logs


def _summary_frame(rows: list[dict]) -> pd.DataFrame:
    df = pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))
    for col in ("rows", "updates"):
        df[col] = pd.array(df[col].tolist(), dtype="Int64")
    for col in ("duration_s", "temp_min_c", "temp_max_c", "a", "b", "c", "seconds"):
        df[col] = df[col].astype(float)
    return df


def check_workers(workers) -> int:
    """A number of worker processes: ``workers``, checked, or one per CPU for None."""
    if workers is None:
        return max(1, os.cpu_count() or 1)
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
        raise ConfigError(f"workers must be a whole number >= 1, got {workers!r}")
    return int(workers)


def _check_outputs(paths: list[Path], out_dir: Path, out_format: str, root: Path | None) -> None:
    """Refuse a missing output folder, two logs with one output, an output that is an input."""
    if not out_dir.is_dir():
        raise ConfigError(f"{out_dir}: output folder does not exist; create it first or choose another")
    inputs = {os.path.realpath(p): p for p in paths}
    seen: dict[str, Path] = {}
    for p in paths:
        out = output_path(p, out_dir, out_format, root)
        key = os.path.realpath(out)
        if key in seen:
            raise ConfigError(
                f"{p} and {seen[key]} would both be written to {out}; rename one of them or process them apart"
            )
        if key in inputs:
            raise ConfigError(
                f"{out}: the output of {p} would overwrite the input log {inputs[key]}; "
                "choose an output folder apart from the logs"
            )
        seen[key] = p


def _failed_future(path, err: BaseException, seconds: float = math.nan) -> dict:
    """Summary row for a log whose worker failed outside :func:`process_one` (crash, lost worker)."""
    row = _empty_row(path)
    row.update(error="worker failed: " + error_line(err), seconds=seconds)
    return row


def _run_dask(job, paths, address, progress) -> list[dict]:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise ConfigError(f"--dask needs the optional packages dask and distributed: {DASK_INSTALL}") from None
    try:
        client = Client(address, timeout="20s", set_as_default=False)
    except (OSError, TimeoutError, ValueError) as err:
        raise ConfigError(f"cannot connect to the Dask scheduler at {address!r} ({_one_line(err)})") from None
    results: list[dict | None] = [None] * len(paths)
    with client:
        futures = [client.submit(job, p, pure=False) for p in paths]
        index = {f.key: i for i, f in enumerate(futures)}
        done = as_completed(futures, loop=client.loop)
        if progress is not None:
            done = progress(done, len(futures))
        for fut in done:
            i = index[fut.key]
            try:
                results[i] = fut.result()
            except Exception as err:  # a lost worker (KilledWorker) or a failed transfer
                results[i] = _failed_future(paths[i], err)
    return results


def process_many(
    paths,
    out_dir,
    *,
    config=None,
    workers: int | None = None,
    dask_address=None,
    progress=None,
    out_format: str = "parquet",
    read_options=None,
    chunk_rows: int | None = None,
) -> pd.DataFrame:
    """Compensate many logs in parallel; return the summary table, in the input order.

    See docs/command-line.md, section "gyrodrift batch: a fleet of logs".

    Parameters
    ----------
    paths : iterable of str or os.PathLike
        The logs (see :func:`find_logs`).
    out_dir : str or os.PathLike
        Existing folder for the outputs (see :func:`output_path`).
    config : CompensatorConfig, optional
        Settings for every log.
    workers : int, optional
        Local ``spawn`` processes (default :func:`os.cpu_count`); 1 runs in this process.
    dask_address : str or distributed cluster, optional
        Run on this Dask scheduler instead (needs ``gyrodrift[fleet]``).
    progress : callable, optional
        ``progress(iterable, total)`` wraps the finished logs and yields them.
    out_format : {"parquet", "csv"}
        Format of the output tables.
    read_options : ReadOptions or dict, optional
        How to read every log (:class:`gyrodrift.io.ReadOptions`).
    chunk_rows : int, optional
        Rows per chunk (default :data:`gyrodrift.pipeline.CHUNK_ROWS`).

    Returns
    -------
    pandas.DataFrame
        One row per log (:data:`SUMMARY_COLUMNS`).

    Raises
    ------
    ConfigError
        Bad usage, before any log is processed; problems of single logs are rows.
    """
    paths = [Path(p) for p in paths]
    out_dir = Path(out_dir)
    if out_format not in OUT_FORMATS:
        raise ConfigError(f"unknown output format {out_format!r}; use one of: {', '.join(OUT_FORMATS)}")
    n_workers = check_workers(workers)
    if not paths:
        return _summary_frame([])
    root = common_root(paths)
    _check_outputs(paths, out_dir, out_format, root)
    job = partial(process_one, out_dir=out_dir, config=config, out_format=out_format, root=root,
                  read_options=read_options, chunk_rows=chunk_rows)
    if dask_address is not None:
        rows = _run_dask(job, paths, dask_address, progress)
    else:
        try:
            rows = map_jobs(job, paths, n_workers, progress, on_error=_failed_future)
        except BaseException:
            _remove_stopped_writes(paths, out_dir, out_format, root)
            raise
    for row, p in zip(rows, paths):
        row["file"] = str(p)
    return _summary_frame(rows)


def _remove_stopped_writes(paths, out_dir: Path, out_format: str, root) -> None:
    """After an interruption, the temporaries of outputs whose workers were stopped mid-write.
    A stopped worker removes its own, unless it is stopped before it can; its process is gone
    by now, so what it left is stale (:func:`gyrodrift._atomic.remove_stale_temporaries`)."""
    from gyrodrift._atomic import remove_stale_temporaries

    for p in paths:
        remove_stale_temporaries(output_path(p, out_dir, out_format, root))


# --------------------------------------------------------------------------- the summary

def write_summary(summary: pd.DataFrame, path) -> None:
    """Write a summary table as CSV, atomically, safe to open in a spreadsheet (``summary`` not changed)."""
    from gyrodrift.io import write_table

    write_table(summary, path, fmt="csv", spreadsheet_safe=True)


def summary_markdown(summary: pd.DataFrame) -> str:
    """The summary table as Markdown: integers as integers, numbers to 4 significant digits."""
    from gyrodrift.evaluate.metrics import markdown_table

    shown = summary.copy()
    for col in ("rows", "updates"):
        shown[col] = [("" if pd.isna(v) else str(int(v))) for v in shown[col]]
    shown["seconds"] = [f"{v:.2f}" for v in shown["seconds"]]
    for col in ("file", "error"):  # user text: one line each, shown, not obeyed by the terminal
        shown[col] = [printable(v) if isinstance(v, str) else v for v in shown[col]]
    return markdown_table(shown, floatfmt=".4g", index=False)
