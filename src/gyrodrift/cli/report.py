"""``gyrodrift report``: one log compensated by several methods, as one HTML page
(:mod:`gyrodrift.evaluate.report`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from gyrodrift._progress import progress_iter
from gyrodrift._text import printable
from gyrodrift.cli.options import finish_command, method_config, read_input
from gyrodrift.errors import ConfigError

__all__ = ["add_report_parser", "report_command"]


def _parse_methods(text: str) -> tuple[str, ...]:
    from gyrodrift.evaluate.compare import DEFAULT_METHODS, is_method

    names = list(dict.fromkeys(m.strip() for m in text.split(",") if m.strip()))
    unknown = [m for m in names if not is_method(m)]
    if unknown or not names:
        raise ConfigError(
            f"--methods: unknown method(s) {', '.join(unknown) or '(none given)'}; "
            f"choose from: {', '.join(DEFAULT_METHODS)}"
        )
    return tuple(names)


def _run_all(log, methods, config, calibration):
    """Run each method in turn (with a progress bar on a terminal)."""
    from gyrodrift.evaluate.compare import calibration_from_log, run_methods

    if calibration is not None and "poly3" in methods:
        calibration = calibration_from_log(calibration)
    outputs, skipped = {}, {}
    for name in progress_iter(methods, len(methods), "compensating"):
        out, skip = run_methods(log, (name,), config, calibration=calibration)
        outputs.update(out)
        skipped.update(skip)
    return outputs, skipped


def report_command(args: argparse.Namespace) -> int:
    """Run ``gyrodrift report``: read, compensate with each method, write the HTML report; return 0."""
    from gyrodrift.evaluate.plotbase import require_matplotlib
    from gyrodrift.evaluate.report import build_report, write_report
    from gyrodrift.io import check_output_path

    require_matplotlib()  # before the long work, not after it
    out_path = Path(args.output)
    check_output_path(args.input, out_path)
    if getattr(args, "calibration", None):
        check_output_path(args.calibration, out_path)
    if not out_path.parent.is_dir():
        raise ConfigError(
            f"{out_path}: output folder {str(out_path.parent)!r} does not exist; create it first or choose another -o"
        )
    methods = _parse_methods(args.methods)
    config = method_config(args)
    log = read_input(args.input, args)
    calibration = read_input(args.calibration, args, with_format=False) if args.calibration else None
    outputs, skipped = _run_all(log, methods, config, calibration)
    if not outputs:
        reasons = "; ".join(f"{m}: {r}" for m, r in skipped.items())
        raise ConfigError(f"{args.input}: none of the methods could run ({reasons}); choose others with --methods")
    title = getattr(args, "title", None) or f"gyrodrift report: {Path(args.input).name}"
    page = build_report(log, outputs, skipped, title=title, source=str(args.input), config=config)
    write_report(out_path, page)
    if not getattr(args, "quiet", False):
        print(printable(f"wrote {out_path}: {len(outputs)} method(s) ({', '.join(outputs)}), {len(page) / 1e6:.1f} MB"))
    return 0


def add_report_parser(sub) -> None:
    """Add the ``report`` subcommand to ``sub`` (the subparsers of :func:`gyrodrift.cli.commands.build_parser`)."""
    from gyrodrift.evaluate.compare import DEFAULT_METHODS

    p = sub.add_parser(
        "report",
        help="compensate a log with several methods and write a self-contained HTML report",
        description="Compensate a log with each method and write one self-contained HTML page: what was "
        "read, an error table per method, figures after Feng, Li, Zhang (2015) Figs. 1-9 and the settings. "
        "Needs matplotlib (gyrodrift[plot]); the Allan figure needs allantools (gyrodrift[allan]).",
    )
    p.add_argument("input", type=Path, help="input log (.csv, .csv.gz, .parquet, .ulg, .bin, ROS bag)")
    p.add_argument("-o", "--output", type=Path, required=True, help="HTML file to write (atomically)")
    p.add_argument(
        "--methods", default=",".join(DEFAULT_METHODS),
        help=f"comma-separated methods to run (default: all, the default estimator first: "
        f"{','.join(DEFAULT_METHODS)}; those that cannot run are listed as skipped)",
    )
    p.add_argument("--calibration", type=Path, metavar="CAL.csv", help="static heating run of the same device, for poly3")
    finish_command(p, report_command)
    p.add_argument("--title", help="page title (default: 'gyrodrift report: <input file name>')")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
