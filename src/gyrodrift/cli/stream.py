"""``gyrodrift stream``: compensate samples as they come, CSV or JSON lines in, rows out."""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from gyrodrift._text import say, warn
from gyrodrift.cli.options import (add_method_options, add_renamed, add_table_options, method_config, read_options,
                                   warm_start)
from gyrodrift.errors import LogFormatError
from gyrodrift.io import check_output_path

__all__ = ["add_stream_parser"]


def _cmd_stream(args) -> int:
    from gyrodrift.compensator import Compensator
    from gyrodrift.profile import profile_from_run, profile_notes, save_profile
    from gyrodrift.stream import deferred_signals, input_blocks, output_writer, stream_rows

    if args.serial is None and args.input != "-" and args.output != "-":
        check_output_path(args.input, args.output)
    cfg, profile = warm_start(args, method_config(args))

    def warn_line(line: str) -> None:
        say(f"gyrodrift: warning: {line}", file=sys.stderr)

    stopped = None  # a bad line: the rows before it are written (to the -o file too), then exit 2
    with deferred_signals() as signals, \
            input_blocks(args.input, signals, serial_port=args.serial, baud=args.baud) as (blocks, name), \
            output_writer(args.output) as write:
        try:
            table = read_options(args, with_format=False)
            stats = stream_rows(blocks, write, fmt=args.input_format, out_format=args.output_format,
                                gyro_unit=table.gyro_unit, frame=table.frame, column_map=table.column_map,
                                time_unit=table.time_unit, source=name, skip_bad=args.skip_bad, warn=warn_line,
                                compensator=Compensator(cfg, source=name, provisional=not args.hold_init))
        except LogFormatError as err:
            if not getattr(err, "stream_stats", None) or not err.stream_stats.rows_in:
                raise  # nothing compensated: no output file is made
            stopped = err
    if stopped is not None:
        raise stopped
    run = stats.run
    if profile is not None and run.rows:
        warn(args.profile, profile_notes(profile, temp_range_c=(run.temp_min_c, run.temp_max_c)))
    if args.save_profile:
        if run.rows:
            save_profile(profile_from_run(run), args.save_profile)
        else:
            warn_line(f"{args.save_profile}: no row was compensated, so no profile was saved")
    if not args.quiet and run.rows:
        lines = [run.read_line(), *run.result_lines()]
        if stats.skipped:
            lines.append(f"skipped {stats.skipped} bad line(s)")
        if args.save_profile:
            lines.append(f"saved device profile {args.save_profile}")
        say(*(f"gyrodrift: {line}" for line in lines), file=sys.stderr)
    if stats.signal is not None:
        print("gyrodrift: " + ("terminated" if stats.signal == signal.SIGTERM else "interrupted"), file=sys.stderr)
        return 143 if stats.signal == signal.SIGTERM else 130
    return 0


def add_stream_parser(sub, conventions: str) -> None:
    """Add the ``stream`` subcommand to ``sub``; ``conventions`` is the epilog of every command."""
    from gyrodrift.stream import FORMATS as STREAM_FORMATS, SERIAL_ADVICE

    s = sub.add_parser(
        "stream", help="compensate samples as they come: CSV or JSON lines in, compensated rows out",
        epilog=conventions, formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Read samples line by line (CSV with a header line, or JSON lines: one object per line) from "
        "standard input, a file or a serial port, compensate them with the streaming Compensator and write each "
        "row it returns at once (flushed), with the columns and formatting of 'gyrodrift compensate': one row per "
        "sample from the first, those of the initialisation window provisional (the prior's or the profile's drift, "
        "gate_reason init), then the rows 'gyrodrift compensate' gives; --hold-init holds the window's rows back and "
        "writes them when it ends, every row then equal to compensate's. A bad line stops the stream "
        "with one error line naming the line and column (exit 2), after writing the rows of every line before it "
        "(to the -o file too); --skip-bad skips it with a warning instead. Time stamps that look like another unit "
        "than --time-unit, or a rate above 100 kHz, stop it as they stop compensate. "
        "SIGINT and SIGTERM end the input: the held rows are written, --save-profile is saved, exit 130 or 143 "
        "(gyrodrift.stream).",
    )
    s.add_argument("input", nargs="?", default="-", help="input file, or - for standard input (default)")
    s.add_argument("-o", "--output", default="-",
                   help="output file, or - for standard output (default); a file appears, whole, when the stream ends")
    s.add_argument("--input-format", choices=list(STREAM_FORMATS),
                   help="input format (default: jsonl when the first non-blank character is '{', else csv)")
    s.add_argument("--output-format", choices=list(STREAM_FORMATS), help="output format (default: the input's)")
    add_renamed(s, "--format", "--input-format", "input_format", choices=list(STREAM_FORMATS))
    add_renamed(s, "--out-format", "--output-format", "output_format", choices=list(STREAM_FORMATS))
    s.add_argument("--serial", metavar="PORT", help=f"read a serial port instead, e.g. /dev/ttyUSB0 ({SERIAL_ADVICE})")
    s.add_argument("--baud", type=int, default=115200, help="serial port speed, baud (default 115200)")
    s.add_argument("--skip-bad", action="store_true", help="skip a bad line with a warning instead of stopping")
    s.add_argument("--hold-init", action="store_true",
                   help="hold the init window's rows back until it ends (no provisional rows; every row then equals "
                   "what 'gyrodrift compensate' writes)")
    s.add_argument("-q", "--quiet", action="store_true", help="no summary on stderr at the end")
    s.add_argument("--profile", type=Path, metavar="DEV.json", help="warm-start from a saved device profile")
    s.add_argument("--save-profile", type=Path, metavar="DEV.json",
                   help="save what this run learned as a device profile at the end of the input, or on SIGINT/SIGTERM")
    add_table_options(s.add_argument_group("input"))
    add_method_options(s)
    s.set_defaults(func=_cmd_stream)
