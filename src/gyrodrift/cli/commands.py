"""The ``gyrodrift`` command line: its parser, :func:`main`, and the commands that are a
few lines over the library (compensate, compare, paper, simulate, montecarlo, demo)."""

from __future__ import annotations

import argparse
import os
import signal
import sys

from contextlib import contextmanager
from importlib import resources
from pathlib import Path

from gyrodrift._paths import check_paths
from gyrodrift._signals import redeliver_sigterm
from gyrodrift._text import say, warn
from gyrodrift._version import __version__
from gyrodrift.cli.batch import add_batch_parser
from gyrodrift.cli.calibrate import add_calibrate_parser
from gyrodrift.cli.options import check_numbers, finish_command, method_config, read_input, read_options, warm_start
from gyrodrift.cli.parser import SuggestingParser
from gyrodrift.cli.report import add_report_parser
from gyrodrift.cli.stream import add_stream_parser
from gyrodrift.errors import ConfigError, GyroDriftError
from gyrodrift.io import check_output_path

__all__ = ["main", "build_parser"]

CONVENTIONS = """\
units and conventions (input contract, CSV with a header row or Parquet):
  t            s, strictly increasing (--time-unit ms, us or ns converts; time
               stamps that look like those units are refused)
  gyro_z       deg/s; positive = heading increases (clockwise seen from above:
               NED body frame, z down). --gyro-unit rad/s converts.
  temp         degC, gyro temperature
  compass      either 'heading' (deg clockwise from magnetic north; empty cell =
               no sample) or raw FRD 'mag_x,mag_y,mag_z' (any unit) with
               'acc_x,acc_y,acc_z' (g or m/s^2, specific force: level+still reads
               acc_z = -1 g); the heading is then tilt-compensated
  optional     gyro_x, gyro_y (deg/s), ref_heading (deg from true north, as
               PX4's attitude yaw; evaluation only),
               true_bias_z (deg/s, evaluation only); other columns pass through
  --frame enu  ROS REP-103 logs (ENU world, FLU body): heading = 90 - yaw, and
               gyro/mag/acc y and z axes change sign
output: t, rate_z (deg/s, compensated), bias_z (deg/s, drift removed), heading
  (deg [0,360), integrated from rate_z from the first compass heading), a
  (deg/s/degC), b (deg/degC), c (deg/s) of the drift model a*T + b*T' + c, updated
  (1 = filter update), gated (1 = compass aiding refused) and gate_reason
  (init, gap, no_compass, field, turning, interference), temp_rate (T', degC/s),
  compass_heading, unobservable (a, b or a+b: parameters not yet determined by
  the data, e.g. at a flat temperature), bias_sd (deg/s, standard deviation of
  bias_z), heading_fused (deg [0,360), gyro and compass combined; heading,
  heading_fused and compass_heading are from magnetic north, or from true north
  with --declination),
  heading_fused_sd and heading_sd (deg, standard deviations of heading_fused and
  of heading); with gyro_x, gyro_y and acc_* in the log also rate_x, rate_y,
  bias_x, bias_y (deg/s) and tilt_gated; then the other input columns.
"""


def _bar(desc: str, unit: str = "it"):
    """``progress(iterable, total, **options)`` of :func:`gyrodrift._progress.progress_iter`, labelled ``desc``."""
    from gyrodrift._progress import progress_iter

    def progress(iterable, total, **options):
        return progress_iter(iterable, total, desc, **{"unit": unit, **options})

    return progress


def _cmd_compensate(args) -> int:
    from gyrodrift.pipeline import compensate_file
    from gyrodrift.profile import profile_from_run, profile_notes, save_profile

    check_output_path(args.input, args.output)
    cfg, profile = warm_start(args, method_config(args))
    prior = None
    if args.prior:  # the z drift model starts from an autopilot's thermal calibration (gyrodrift.calibrate)
        from gyrodrift.paramfiles import read_prior

        if profile is not None:
            raise ConfigError("--prior and --profile both give the starting drift model; use one of them")
        prior = read_prior(args.prior, instance=args.instance)
    stats = compensate_file(args.input, args.output, cfg, read_options=read_options(args),
                            progress=_bar("compensating"), scale_factor=args.scale_factor,
                            smooth=args.smooth, prior=prior)
    if profile is not None:  # the temperatures of the run are known once it is read
        warn(args.profile, profile_notes(profile, temp_range_c=(stats.temp_min_c, stats.temp_max_c)))
    if prior is not None:
        from gyrodrift.calibrate import prior_notes

        warn(args.prior, prior_notes(prior, (stats.temp_min_c, stats.temp_max_c)))
    if args.save_profile:
        save_profile(profile_from_run(stats), args.save_profile)
    if not args.quiet:
        say(stats.read_line(), *stats.result_lines(), f"wrote {args.output}")
        if args.save_profile:
            say(f"saved device profile {args.save_profile}")
    return 0


def demo_log_path() -> Path:
    """Path of the built-in example log (a simulated static heating run)."""
    return Path(str(resources.files("gyrodrift") / "data" / "example_static.csv.gz"))


def _cmd_demo(args) -> int:
    from gyrodrift.pipeline import compensate_file

    path = demo_log_path()
    check_output_path(path, args.output)
    print(
        "gyrodrift demo: a simulated motionless gyro heated 23 -> 58 degC and cooled, with a "
        "10 Hz compass and three magnetic-interference windows (gyrodrift/data/README.md)."
    )
    stats = compensate_file(path, args.output, method_config(args))
    stats.source = path.name
    say(stats.read_line(), *stats.result_lines(), f"wrote {args.output}")
    return 0


def _scenarios() -> list[str]:
    from gyrodrift.simulate import SCENARIOS

    return list(SCENARIOS)


def _cmd_simulate(args) -> int:
    from gyrodrift.config import apply_settings, load_toml
    from gyrodrift.simulate import SCENARIOS, CompassModel, DeviceModel, TriadModel, simulate

    if args.scenario not in SCENARIOS:
        raise ConfigError(f"unknown scenario {args.scenario!r}; choose one of: {', '.join(SCENARIOS)}")
    _check_simulated_rows(args)
    device, compass = DeviceModel(), CompassModel()
    if args.config:
        values = load_toml(args.config)
        unknown = sorted(set(values) - {"device", "compass"})
        if unknown:
            raise ConfigError(f"{args.config}: unknown table(s) {', '.join(unknown)}; use [device] and [compass]")
        device = apply_settings(device, values.get("device", {}), f"{args.config} [device]")
        compass = apply_settings(compass, values.get("compass", {}), f"{args.config} [compass]")
    log = simulate(
        args.scenario, seed=args.seed, duration_s=args.duration_s, fs_hz=args.fs_hz,
        device=device, compass=compass, raw_mag=args.raw_mag,
        triad=TriadModel() if args.triad else None,
    )
    from gyrodrift.io import write_table

    log.attrs = {}
    write_table(log, args.output)
    if not args.quiet:
        say(
            f"wrote {args.output}: scenario {args.scenario}, seed {args.seed}, {len(log)} rows, "
            f"{log['t'].iloc[-1]:.0f} s at {args.fs_hz:g} Hz, temperature {log['temp'].min():.1f} to "
            f"{log['temp'].max():.1f} degC, true drift {log['true_bias_z'].min():.3f} to "
            f"{log['true_bias_z'].max():.3f} deg/s"
        )
    return 0


#: Least memory ``simulate`` takes per row of the log, bytes (docs/command-line.md, section "Options").
SIMULATE_MIN_BYTES_PER_ROW = 250


def _check_simulated_rows(args) -> None:
    """Refuse, before simulating, a log that cannot fit in the memory available (Linux)."""
    from gyrodrift.pipeline import available_memory_bytes
    from gyrodrift.simulate import DEFAULT_DURATION_S

    duration_s = args.duration_s if args.duration_s is not None else DEFAULT_DURATION_S[args.scenario]
    rows = duration_s * args.fs_hz
    available = available_memory_bytes()
    if available is None or rows * SIMULATE_MIN_BYTES_PER_ROW <= available:
        return
    raise ConfigError(
        f"simulate: --duration-s {duration_s:g} at --fs-hz {args.fs_hz:g} is {rows:.3g} rows, at least "
        f"{rows * SIMULATE_MIN_BYTES_PER_ROW / 2**30:.3g} GiB, and this machine has {available / 2**30:.1f} GiB "
        "available; shorten --duration-s or lower --fs-hz"
    )


def _cmd_compare(args) -> int:
    import json

    import pandas as pd

    from gyrodrift.evaluate.compare import DEFAULT_METHOD, DEFAULT_METHODS, method_label, run_methods, summary_table
    from gyrodrift.evaluate.metrics import markdown_table
    from gyrodrift.pipeline import describe_log

    methods = [m.strip() for m in args.methods.split(",") if m.strip()] if args.methods else list(DEFAULT_METHODS)
    log = read_input(args.input, args)
    if "ref_heading" not in log.columns and "true_bias_z" not in log.columns:
        raise ConfigError(
            f"{args.input}: compare needs a reference: a ref_heading column (e.g. a fibre-optic gyro) "
            "or true_bias_z (simulated logs)"
        )
    calibration = read_input(args.calibration, args, with_format=False) if args.calibration else None
    outputs, skipped = run_methods(log, methods, method_config(args), calibration=calibration)
    table = summary_table(outputs)
    if args.json:
        payload = {
            "input": str(args.input),
            "methods": {k: {c: (v.item() if hasattr(v, "item") else v) for c, v in row.items() if pd.notna(v)}
                        for k, row in table.to_dict(orient="index").items()},
            "skipped": skipped,
            "default_method": DEFAULT_METHOD,
        }
        print(json.dumps(payload, indent=2))
        return 0
    say(describe_log(log, args.input))
    print(markdown_table(table.rename(index=method_label), floatfmt=".4g"))
    print("bias_*: estimated minus true drift, deg/s (variance in (deg/s)^2); heading_*: heading minus "
          "ref_heading, deg; causal=False: uses the whole log (not possible in real time).")
    for name, why in skipped.items():
        say(f"skipped {name}: {why}")
    return 0


def _cmd_paper(args) -> int:
    import time

    from gyrodrift.evaluate.paper import PaperSettings, write_paper

    args.output.mkdir(parents=True, exist_ok=True)
    settings = PaperSettings(
        seed=args.seed, fs_hz=args.fs_hz, duration_scale=0.1 if args.quick else 1.0, config=method_config(args)
    )
    start = time.monotonic()

    def progress(step: str) -> None:
        if sys.stderr.isatty():
            print(f"[{time.monotonic() - start:6.1f} s] {step}", file=sys.stderr)

    written = write_paper(args.output, settings, progress=progress, figures=not args.no_figures)
    say(f"wrote {len(written)} files to {args.output} in {time.monotonic() - start:.0f} s; start with "
          f"{args.output / 'table2.md'}")
    return 0


def _names(values, what: str) -> list[str] | None:
    """``--families a b,c`` → ``[a, b, c]`` (spaces or commas); None when not given."""
    if values is None:
        return None
    names = [n.strip() for v in values for n in v.split(",") if n.strip()]
    if not names:
        raise ConfigError(f"--{what} needs at least one name")
    return names


def _cmd_generated(args, splits) -> int:
    """``montecarlo --held-out`` / ``--tuning``: the generator's classes."""
    import time

    from gyrodrift.evaluate import heldout

    config = method_config(args)
    methods = _names(args.methods, "methods") or list(heldout.METHODS)
    start = time.monotonic()
    df = heldout.run_generated(_names(args.families, "classes"), splits, args.seeds, methods, config=config,
                               workers=args.workers, duration_scale=args.duration_scale,
                               progress=_bar("monte carlo", "logs"))
    table = heldout.markdown(df) if args.markdown else heldout.acceptance(heldout.summarise(df)).to_string(
        index=False, float_format=lambda v: f"{v:.4g}")
    return _runs_done(args, df, table, "class", f"{df['class'].nunique()} classes x {args.seeds} seeds x {len(splits)} "
                      f"split(s) x {len(methods)} methods in {time.monotonic() - start:.0f} s")


def _runs_done(args, df, table: str, unit: str, done: str) -> int:
    """Write every run (``-o``), print ``table``, ``done`` and the first failures; 1 when every run failed."""
    from gyrodrift.io import write_table

    if args.output:  # a CSV's text cells (error messages) never start a spreadsheet formula
        write_table(df, args.output, spreadsheet_safe=True)
    print(table)
    failed = df[df["status"] != "ok"]
    say(f"{done}; {len(failed)} of {len(df)} runs failed" + (f"; wrote {args.output}" if args.output else ""))
    for _, row in failed.drop_duplicates("error").head(5).iterrows():
        say(f"failed {row[unit]} seed {row['seed']} {row['method']}: {row['error']}")
    return 1 if len(failed) == len(df) else 0


def _cmd_montecarlo(args) -> int:
    import time

    from gyrodrift.evaluate.montecarlo import DEFAULT_METHODS, markdown, run_monte_carlo, summarise

    splits = [name for name, on in (("tuning", args.tuning), ("held-out", args.held_out)) if on]
    if splits:
        return _cmd_generated(args, splits)
    if args.seeds < 1:
        raise ConfigError(f"--seeds must be at least 1, got {args.seeds}")
    if args.first_seed < 0:
        raise ConfigError(f"--first-seed must be >= 0, got {args.first_seed}")
    config = method_config(args)
    methods = _names(args.methods, "methods") or list(DEFAULT_METHODS)
    start = time.monotonic()
    df = run_monte_carlo(
        _names(args.families, "families"),
        range(args.first_seed, args.first_seed + args.seeds),
        methods,
        duration_scale=args.duration_scale,
        config=config,
        workers=args.workers,
        progress=_bar("monte carlo", "logs"),
        fs_hz=args.fs_hz,
    )
    summary = summarise(df)
    table = markdown(summary, tuned_on=args.tuned_on) if args.markdown else summary.to_string(
        index=False, float_format=lambda v: f"{v:.4g}")
    return _runs_done(args, df, table, "family", f"{df['family'].nunique()} families x {args.seeds} seeds x "
                      f"{len(methods)} methods (durations x {args.duration_scale:g}, {args.fs_hz:g} Hz) in "
                      f"{time.monotonic() - start:.0f} s")


def build_parser() -> argparse.ArgumentParser:
    p = SuggestingParser(  # "did you mean" for mistyped options and subcommands
        prog="gyrodrift",
        description="Remove the temperature drift of a MEMS gyroscope with compass aiding, after Feng, Li, "
        "Zhang, Sensors 2015 (the default: one model of gyro, compass and platform judged by evidence; the "
        "paper's strong tracking Kalman filter: --estimator stkf).",
        epilog=CONVENTIONS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--version", action="version", version=f"gyrodrift {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    c = sub.add_parser(
        "compensate", help="compensate a log (CSV, Parquet, ULog, DataFlash .bin, .tlog, ROS bag)",
        epilog=CONVENTIONS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Compensate the heading-axis gyro of a log; write the output table atomically.",
    )
    c.add_argument("input", type=Path, help="input log (.csv, .csv.gz, .parquet, .ulg, .bin, .tlog, ROS bag)")
    c.add_argument("-o", "--output", type=Path, required=True, help="output table (.csv or .parquet)")
    c.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    c.add_argument(
        "--profile", type=Path, metavar="DEV.json",
        help="warm-start from a saved device profile (checked on loading; a warning on stderr, even with -q, "
        "when it was saved by another estimator or the log's temperatures reach beyond its range)",
    )
    c.add_argument("--save-profile", type=Path, metavar="DEV.json", help="save what this run learned as a device profile")
    c.add_argument(
        "--prior", type=Path, metavar="FILE.params",
        help="start the heading-axis drift model from an autopilot's thermal calibration (PX4 TC_G*, ArduPilot "
        "INS_TCAL*, or gyrodrift calibrate's JSON; slot --instance): its tangent at the log's first temperature. "
        "A warning on stderr when the log's temperature leaves its TMIN..TMAX",
    )
    c.add_argument(
        "--scale-factor", action="store_true",
        help="also estimate the gyro scale factor over turns (paper Sec. 4.3; gyrodrift.scale_factor) and add "
        "sf, sf_sd, rate_sf and heading_sf (runs in memory)",
    )
    c.add_argument(
        "--smooth", action="store_true",
        help="recorded logs: smooth the drift over the whole log, before and after each row (not causal; "
        "gyrodrift.smooth; runs in memory). a, b, c, bias_z, rate_z, heading, bias_sd and heading_sd "
        "then come from the smoother",
    )
    finish_command(c, _cmd_compensate)

    cmp_ = sub.add_parser(
        "compare", help="run ours and the paper's baselines on one log; print the Table-2 statistics",
        description="Compensate one log with several methods (adaptive = the default estimator, stkf = the "
        "paper's filter, kf, stkf-s1, lsm, mlr, smoothed, poly3, fusion-offset, oracle) and compare them "
        "against ref_heading and/or true_bias_z.",
    )
    cmp_.add_argument("input", type=Path, help="log with ref_heading and/or true_bias_z")
    cmp_.add_argument("--methods", help="comma-separated (default: all, the default estimator adaptive first)")
    cmp_.add_argument("--calibration", type=Path, help="a still heating run of the same device, for poly3")
    cmp_.add_argument("--json", action="store_true", help="machine-readable output")
    finish_command(cmp_, _cmd_compare)

    pap = sub.add_parser(
        "paper", help="regenerate every experiment of the paper: table2.md, results.json, figures",
        description="Runs the paper's experiments on simulated data (static heating run, outages, vehicle, "
        "Allan deviation) with every method, and writes Table 2 beside the paper's numbers, a check of "
        "each claim, and PNG figures.",
    )
    pap.add_argument("-o", "--output", type=Path, required=True, help="output folder (created if missing)")
    pap.add_argument("--seed", type=int, default=1, help="seed of the simulated runs (default 1)")
    pap.add_argument("--fs-hz", type=float, default=10.0, help="gyro sample rate of the runs, Hz (default 10)")
    pap.add_argument("--quick", action="store_true", help="every run 10x shorter (a smoke test, not the results)")
    pap.add_argument("--no-figures", action="store_true", help="numbers only")
    finish_command(pap, _cmd_paper, inputs=False)

    sim = sub.add_parser(
        "simulate", help="write a simulated log (input contract + ref_heading, true_bias_z)",
        description="Seeded, deterministic simulated logs (gyrodrift.simulate). The drift is a nonlinear "
        "function of temperature and its rate, not the paper's linear model.",
    )
    sim.add_argument("scenario", help="one of: " + ", ".join(_scenarios()))
    sim.add_argument("-o", "--output", type=Path, required=True, help="output log (.csv or .parquet)")
    sim.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    sim.add_argument("--duration-s", type=float, help="length, s (default: the scenario's)")
    sim.add_argument("--fs-hz", type=float, default=50.0, help="gyro sample rate, Hz (default 50)")
    sim.add_argument("--raw-mag", action="store_true", help="also write raw mag_* (uT) and acc_* (g) columns")
    sim.add_argument(
        "--triad", action="store_true",
        help="also write gyro_x, gyro_y with their own drift, true_bias_x/y and a noisy accelerometer acc_* (g)",
    )
    sim.add_argument("--config", type=Path, metavar="FILE.toml", help="[device] and [compass] model overrides")
    sim.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    sim.set_defaults(func=_cmd_simulate)

    from gyrodrift.evaluate.montecarlo import ADVERSARIAL_FAMILIES, DEFAULT_METHODS, FAMILIES

    mc = sub.add_parser(
        "montecarlo", help="Monte Carlo of every method over the simulated scenario families",
        description="Simulate each scenario family with randomised gyros and compasses (one per seed), run "
        "every method on the same logs, and print per family and method the mean and median heading-error "
        "and bias RMS, and how often adaptive beats each method on both; exit status 1 when every run failed. "
        "Families: "
        + "; ".join(f"{k}: {v.description}" for k, v in FAMILIES.items()),
    )
    mc.add_argument(
        "--families", nargs="+", metavar="NAME",
        help=f"families (default: all {len(FAMILIES)}; the adversarial ones: {' '.join(ADVERSARIAL_FAMILIES)})",
    )
    mc.add_argument("--seeds", type=int, default=20, help="seeds per family (default 20)")
    mc.add_argument("--first-seed", type=int, default=0, help="first seed (default 0)")
    mc.add_argument(
        "--methods", nargs="+", metavar="NAME", help=f"methods (default: {' '.join(DEFAULT_METHODS)})",
    )
    mc.add_argument("--duration-scale", type=float, default=1.0, help="log lengths x this (default 1)")
    mc.add_argument("--fs-hz", type=float, default=10.0, help="gyro sample rate, Hz (default 10)")
    mc.add_argument("--workers", type=int, help="worker processes (default: one per CPU)")
    mc.add_argument("--tuned-on", metavar="FAMILY", help="with --markdown: the family the settings were tuned on")
    mc.add_argument("-o", "--output", type=Path, metavar="OUT.csv", help="write every run (one row per family, seed, method)")
    mc.add_argument("--markdown", action="store_true", help="print the summary as Markdown")
    mc.add_argument("--held-out", action="store_true",
                    help="the procedural generator's classes on held-out seeds (gyrodrift.simulate.generator; "
                    "--families then names classes)")
    mc.add_argument("--tuning", action="store_true", help="the generator's classes on tuning seeds (with --held-out: both)")
    finish_command(mc, _cmd_montecarlo, inputs=False)  # the settings, frozen for every family

    add_report_parser(sub)
    add_batch_parser(sub)
    add_calibrate_parser(sub)
    add_stream_parser(sub, CONVENTIONS)

    d = sub.add_parser("demo", help="compensate the built-in example log and print a summary")
    d.add_argument("-o", "--output", type=Path, default=Path("gyrodrift-demo-out.csv"), help="output table (default %(default)s)")
    finish_command(d, _cmd_demo, inputs=False)
    return p


def _say_if_compiling() -> None:
    """One line on stderr if the command compiles a kernel that is not in numba's cache."""
    from gyrodrift.kernels import say_when_compiling

    say_when_compiling()


class Terminated(KeyboardInterrupt):
    """SIGTERM received while :func:`main` runs: every clean-up of Ctrl-C runs (docs/command-line.md, "Signals")."""


def _raise_terminated(signum, frame) -> None:
    raise Terminated()


@contextmanager
def _sigterm_interrupts():
    """While the block runs, SIGTERM raises :class:`Terminated` in the main thread; the handlers are restored."""
    try:
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    except (ValueError, OSError, AttributeError):
        yield
        return
    hook = sys.unraisablehook
    sys.unraisablehook = redeliver_sigterm(hook, Terminated)
    try:
        yield
    finally:
        sys.unraisablehook = hook
        # None: a handler installed outside Python, which cannot be put back; the default then
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def main(argv: list[str] | None = None) -> int:
    """Run the command line on ``argv`` (default ``sys.argv[1:]``); return the exit status.

    The statuses: docs/command-line.md, section "Errors and exit status".
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    _say_if_compiling()
    try:
        check_numbers(parser._subparser(args), args)
        check_paths(args.command, args)  # no output onto an input, every output writable before any work
        with _sigterm_interrupts():
            code = args.func(args)
            sys.stdout.flush()  # here, where a reader gone away is caught, not at the exit
            return code
    except GyroDriftError as err:
        say(f"gyrodrift: error: {err}", file=sys.stderr)
        return 2
    except Terminated:
        print("gyrodrift: terminated", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("gyrodrift: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader of the output went away (| head): nothing more to say
        _drop_stdout()
        return 141
    except MemoryError:
        print(f"gyrodrift: error: {args.command}: out of memory (an output file is written whole or not at all). "
              f"{_MEMORY_ADVICE.get(args.command, _LOG_MEMORY_ADVICE)}", file=sys.stderr)
        return 1


def _drop_stdout() -> None:
    """Point the standard output at the null device: what is still buffered goes nowhere at exit."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):  # no file descriptor (a captured stdout): nothing buffered
        pass


#: What to do when a command that reads a log runs out of memory.
_LOG_MEMORY_ADVICE = ("Logs longer than memory stream in constant memory from CSV or Parquet, without --smooth or "
                      "--scale-factor (gyrodrift compensate); otherwise split the log")
#: ... and a command whose options set the size of what it makes.
_MEMORY_ADVICE = {
    "simulate": "--duration-s times --fs-hz is the number of rows: shorten --duration-s or lower --fs-hz",
    "montecarlo": "--duration-scale and --fs-hz set the length of every run and --workers how many run at once: "
                  "lower them",
    "paper": "--fs-hz sets the length of every run: lower it, or use --quick",
}
