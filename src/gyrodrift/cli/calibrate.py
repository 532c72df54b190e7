"""``gyrodrift calibrate``: fit and write a thermal calibration, or check a parameter file on a log."""

from __future__ import annotations

import argparse
from pathlib import Path

from gyrodrift._text import say as _say, warn as _warn
from gyrodrift.cli.options import add_input_options, add_renamed, read_options
from gyrodrift.errors import ConfigError

__all__ = ["add_calibrate_parser"]


def _read_gyros(args) -> list:
    """The log's gyros (every one, or ``--instance``), as the options say."""
    from gyrodrift.io import log_format, read_gyros

    opts = read_options(args).keywords()
    # --instance picks a gyro of a ULog, .bin or .tlog; for a table (one gyro) it is only the parameter slot
    if log_format(args.input, opts["fmt"]) not in ("ulog", "ardupilot", "tlog"):
        opts["instance"] = None
    return read_gyros(args.input, **opts)


def _board_rotation(args, autopilot: str | None):
    """``--board-rotation`` as ``(R, description)``, or ``(None, "")`` when not given."""
    if args.board_rotation is None:
        return None, ""
    from gyrodrift.rotations import parse_rotation

    if autopilot is None and "," not in args.board_rotation:
        raise ConfigError("--board-rotation: a rotation number needs its autopilot; write a .params or .param "
                          "file, or give roll,pitch,yaw in degrees")
    return parse_rotation(args.board_rotation, autopilot or "px4")


def _autopilot(logs, fmt: str | None) -> str | None:
    """The autopilot the output is for; a log of the other autopilot is refused."""
    found = {log.attrs["onboard"].autopilot for log in logs if log.attrs.get("onboard") is not None}
    target = {"px4": "px4", "ardupilot": "ardupilot", "ardupilot-qgc": "ardupilot"}.get(fmt)
    if target and found and found != {target}:
        names = {"px4": "PX4", "ardupilot": "ArduPilot"}
        raise ConfigError(f"{logs[0].attrs.get('source', 'log')}: a {names[found.pop()]} log, but the output is a "
                          f"{names[target]} file; write the file for the autopilot that recorded the log")
    return target or (found.pop() if len(found) == 1 else None)


def _cmd_calibrate(args) -> int:
    if args.check is not None:
        return _cmd_check(args)
    from gyrodrift.calibrate import calibrate_log
    from gyrodrift.io import check_output_path
    from gyrodrift.paramfiles import output_format, write_calibration

    if args.output is None:
        raise ConfigError("calibrate needs -o OUTPUT (the parameter file to write), or --check PARAMS to check one")
    check_output_path(args.input, args.output)
    fmt = output_format(args.output, args.output_format)
    logs = _read_gyros(args)
    rotation, rotation_text = _board_rotation(args, _autopilot(logs, fmt))
    if args.device_id is not None and len(logs) > 1:
        raise ConfigError(f"--device-id names one gyro, but {args.input} has {len(logs)}; choose one with --instance")
    cals, notes = [], []
    for log in logs:
        cal, said = calibrate_log(log, source=str(args.input), rotation=rotation, rotation_text=rotation_text)
        if log.attrs.get("onboard") is None and args.instance is not None:
            from dataclasses import replace

            cal = replace(cal, instance=args.instance)
        cals.append(cal)
        notes += said
    system_ids = {log.attrs["onboard"].system_id for log in logs if log.attrs.get("onboard") is not None} - {None}
    sysid = args.sysid if args.sysid is not None else (system_ids.pop() if len(system_ids) == 1 else 1)
    notes += write_calibration(cals, args.output, fmt, device_id=args.device_id, sysid=sysid)
    _warn(args.output, notes)
    if not args.quiet:
        lines = [c.summary() if len(cals) == 1 else f"gyro {c.instance}: {c.summary()}" for c in cals]
        lines[-1] += f"; wrote {args.output}"
        _say(*lines)
    return 0


def _cmd_check(args) -> int:
    from gyrodrift.calcheck import check_log
    from gyrodrift.paramfiles import param_file_format

    autopilot = param_file_format(args.check)
    rotation, rotation_text = _board_rotation(args, autopilot if autopilot != "json" else None)
    logs = _read_gyros(args)
    applied = True
    for log in logs:
        result = check_log(args.check, log, rotation=rotation, rotation_text=rotation_text,
                           instance=args.instance if log.attrs.get("onboard") is None else None,
                           source=str(args.input))
        _warn(args.input, result.notes)
        _say(*result.lines())
        applied &= bool(result.applied)
    return 0 if applied else 1


def add_calibrate_parser(sub) -> None:
    """Add the ``calibrate`` subcommand to ``sub`` (the subparsers of :func:`gyrodrift.cli.commands.build_parser`)."""
    from gyrodrift.calibrate import MIN_SPAN_C
    from gyrodrift.io import FORMATS as LOG_FORMATS
    from gyrodrift.paramfiles import FORMATS as CAL_FORMATS

    # conflict_handler="resolve": --instance defaults to every gyro here
    cal = sub.add_parser(
        "calibrate", conflict_handler="resolve", formatter_class=argparse.RawDescriptionHelpFormatter,
        help="fit the gyro's thermal drift from a still heating run; write PX4, ArduPilot or JSON parameters",
        description="Fit the drift of every gyro axis of a still heating or cooling log as a cubic in temperature "
        "(PX4 and ArduPilot style) and write it as a PX4 .params file (TC_G*), an ArduPilot .param file "
        f"(INS_TCAL*) or gyrodrift JSON (gyrodrift.calibrate, gyrodrift.paramfiles). Refused below {MIN_SPAN_C:g} "
        "degC of span or when the unit moved. From a PX4 ULog or an ArduPilot .bin every gyro is calibrated (one "
        "slot each, PX4 TC_G<n>_ID set to its device id), the fit is made in the body frame and written in the "
        "sensor frame the autopilot corrects in (SENS_BOARD_ROT, CAL_GYROn_ROT, AHRS_ORIENTATION read from the log; "
        "--board-rotation overrides), and a thermal correction the autopilot applied while the log was recorded "
        "is added back first. A table's axes are taken as the sensor's unless --board-rotation says otherwise. "
        "--check PARAMS LOG applies a parameter file to a log as the autopilot would and prints the drift left "
        "per axis (exit 1 when the file applies nothing to a gyro of the log).",
    )
    cal.add_argument("input", type=Path, help="the heating or cooling run (any log format of compensate)")
    cal.add_argument("-o", "--output", type=Path, help="parameter file to write")
    cal.add_argument("--check", type=Path, metavar="PARAMS",
                     help="apply this PX4 .params or ArduPilot .param file to the log as the autopilot would and "
                     "print the drift left (no -o)")
    cal.add_argument("-q", "--quiet", action="store_true", help="print nothing on success")
    add_input_options(cal, old_format=False)
    cal.add_argument("--instance", type=int,
                     help="one gyro only: PX4 ULog sensor_gyro instance, ArduPilot .bin IMU instance (default: "
                     "every gyro); for a table, the parameter slot: TC_G<instance>, INS_TCAL<instance+1> (default 0)")
    add_renamed(cal, "--log-format", "--input-format", "input_format", choices=list(LOG_FORMATS))
    add_renamed(cal, "--format", "--output-format", "output_format", choices=list(CAL_FORMATS))
    cal.add_argument("--output-format", choices=list(CAL_FORMATS),
                     help="px4 (.params), ardupilot (.param: Mission Planner, MAVProxy), ardupilot-qgc (ArduPilot's "
                     "parameters in QGroundControl's file) or json (default: by the output's name)")
    cal.add_argument("--device-id", type=int,
                     help="px4: TC_G<instance>_ID, the gyro's device id (its CAL_GYRO*_ID); default: the log's "
                     "(0 for a table: PX4 then applies nothing)")
    cal.add_argument("--board-rotation", metavar="N|R,P,Y",
                     help="the board rotation in place of the log's: the autopilot's rotation number (SENS_BOARD_ROT, "
                     "AHRS_ORIENTATION) or roll,pitch,yaw in degrees; v_body = R v_sensor")
    cal.add_argument("--sysid", type=int,
                     help="px4: the vehicle's system id (MAV_SYS_ID), first column of every line; QGroundControl "
                     "refuses a file of another id (default: the log's, else 1)")
    cal.set_defaults(func=_cmd_calibrate)
