"""``gyrodrift batch``: every log of a folder or a glob compensated in parallel, and a
summary table (:mod:`gyrodrift.fleet`)."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from gyrodrift._progress import progress_iter
from gyrodrift._text import printable
from gyrodrift.cli.options import add_renamed, finish_command, method_config, read_options
from gyrodrift.errors import ConfigError, GyroDriftError
from gyrodrift.fleet import (
    DASK_INSTALL,
    LOG_SUFFIXES,
    OUT_FORMATS,
    SUMMARY_FILE,
    find_logs,
    process_many,
    summary_markdown,
    write_summary,
)

__all__ = ["add_batch_parser", "batch_command"]

BATCH_EPILOG = """\
output: OUTDIR/<name>_out.parquet (or .csv) per log, written atomically (logs in
sub-folders of the logs' common folder go to the same sub-folders of OUTDIR), and
OUTDIR/summary.csv: file, status (ok/error), error (one line), rows, duration_s (s),
temp_min_c, temp_max_c (degC), updates, a (deg/s/degC), b (deg/degC), c (deg/s) final
drift model (a log whose temperature never changes: a, b empty, c its final drift),
seconds (wall time per log). Text cells that start with = + - @ get a leading ' (shown
as text, never run as a spreadsheet formula).

exit status: 0 if every log was compensated, 1 if some logs failed (each one is
reported in the table and in summary.csv; the others are still written), 2 for bad
usage (no logs found, missing config, unreachable Dask scheduler).
"""


def add_batch_parser(sub) -> None:
    """Add the ``batch`` subcommand to ``sub`` (the subparsers of :func:`gyrodrift.cli.commands.build_parser`)."""
    p = sub.add_parser(
        "batch",
        help="compensate every log in a folder (or glob) in parallel; write a summary table",
        description="Compensate many logs on local processes or a Dask cluster. A log that fails is "
        "reported and skipped; it never stops the others.",
        epilog=BATCH_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "logs", metavar="DIR_OR_GLOB",
        help=f"a folder of logs ({', '.join(LOG_SUFFIXES)}) or a quoted glob pattern such as 'runs/*.csv'",
    )
    p.add_argument("-o", "--output", type=Path, required=True, metavar="OUTDIR", help="output folder (created if missing)")
    p.add_argument("--workers", type=int, help="local worker processes (default: the number of CPUs)")
    p.add_argument(
        "--dask", metavar="ADDRESS",
        help=f"run on a Dask scheduler, e.g. tcp://host:8786 (needs {DASK_INSTALL}); workers must see the same paths",
    )
    p.add_argument("--output-format", choices=list(OUT_FORMATS), default="parquet",
                   help="output table format (default parquet)")
    add_renamed(p, "--format", "--output-format", "output_format", choices=list(OUT_FORMATS))
    finish_command(p, batch_command, old_format=False)


def _prepare_output_dir(out_dir: Path) -> None:
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ConfigError(f"{out_dir}: cannot create the output folder ({err.strerror})") from None


def batch_command(args: argparse.Namespace) -> int:
    """Run ``gyrodrift batch``; return 0 (all ok), 1 (some logs failed) or 2 (bad usage)."""
    try:
        paths = find_logs(args.logs)
        config = method_config(args)
        summary_path = args.output / SUMMARY_FILE
        clash = [p for p in paths if os.path.realpath(p) == os.path.realpath(summary_path)]
        if clash:
            raise ConfigError(
                f"{summary_path}: the summary would overwrite the input log {clash[0]}; "
                "choose an output folder apart from the logs"
            )
        _prepare_output_dir(args.output)
        summary = process_many(
            paths, args.output, config=config, workers=args.workers, dask_address=args.dask,
            progress=lambda items, total: progress_iter(items, total, "batch", unit="logs"),
            out_format=args.output_format, read_options=read_options(args),
        )
        write_summary(summary, summary_path)
    except GyroDriftError as err:
        print(printable(f"gyrodrift: error: {err}"), file=sys.stderr)
        return 2
    n_bad = int((summary["status"] != "ok").sum())
    print(summary_markdown(summary))
    print(f"{len(summary) - n_bad} ok, {n_bad} failed")
    print(printable(f"wrote {summary_path}"))
    return 1 if n_bad else 0
