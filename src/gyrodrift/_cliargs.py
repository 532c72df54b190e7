"""Command-line pieces shared by every subcommand that reads a log (no business logic here)."""

from __future__ import annotations

import argparse
from pathlib import Path

from gyrodrift.conventions import TIME_UNITS
from gyrodrift.errors import ConfigError
from gyrodrift.io import FORMATS, read_log

__all__ = ["parse_map", "add_table_options", "add_input_options", "read_input", "table_read_options"]


def parse_map(text: str | None) -> dict[str, str] | None:
    """``NEW=OLD,NEW=OLD`` → ``{NEW: OLD}``; a malformed item is a :class:`ConfigError`."""
    if not text:
        return None
    mapping = {}
    for item in text.split(","):
        new, sep, old = item.partition("=")
        if not sep or not new.strip() or not old.strip():
            raise ConfigError(f"--map expects NEW=OLD[,NEW=OLD...], got {item!r}")
        mapping[new.strip()] = old.strip()
    return mapping


def add_table_options(g) -> None:
    """Options that say how to read a CSV or Parquet table (``--gyro-unit``, ``--frame``,
    ``--map``, ``--time-unit``), on a parser or an argument group."""
    g.add_argument("--gyro-unit", default="deg/s", help="tables: unit of gyro_* columns, deg/s (default) or rad/s")
    g.add_argument("--frame", choices=["ned", "enu"], type=str.lower,
                   help="tables: ned (FRD body; the default, and a table whose accelerometer shows z up is then "
                   "refused) or enu (ROS REP-103: FLU body, converted)")
    g.add_argument("--map", metavar="NEW=OLD,...", help="tables: rename columns to contract names, e.g. gyro_z=gz,temp=T")
    g.add_argument(
        "--time-unit", choices=list(TIME_UNITS),
        help="tables: unit of t, converted to s (default s; time stamps that look like ms, us or ns are refused)",
    )


def table_read_options(args: argparse.Namespace) -> dict:
    """The :func:`gyrodrift.io.read_log` keywords of :func:`add_table_options`."""
    return {"gyro_unit": args.gyro_unit, "frame": args.frame, "column_map": parse_map(args.map),
            "time_unit": args.time_unit}


def add_input_options(p: argparse.ArgumentParser) -> None:
    """Options that say how to read the input log (every format)."""
    g = p.add_argument_group("input")
    g.add_argument("--format", choices=list(FORMATS), help="input format (default: by file name)")
    add_table_options(g)
    g.add_argument("--instance", type=int, default=0,
                   help="PX4 ULog: sensor_gyro instance; ArduPilot .bin: IMU instance, IMU.I (IMU2 = 1); .tlog: IMU "
                   "instance (ArduPilot RAW_IMU = 0, SCALED_IMU2 = 1); default 0")
    g.add_argument("--mag-instance", type=int, help="PX4 ULog: sensor_mag instance (default: the one PX4 selected); "
                   "ArduPilot .bin: MAG instance (default: COMPASS_PRIMARY, else the first); .tlog: the IMU message "
                   "whose magnetometer is the compass (default: the gyro's)")
    g.add_argument("--imu-topic", help="ROS bag: sensor_msgs/Imu topic (default: the only one)")
    g.add_argument("--temp-topic", help="ROS bag: sensor_msgs/Temperature topic (default: the only one)")
    g.add_argument("--mag-topic", help="ROS bag: sensor_msgs/MagneticField topic (default: the only one)")


def read_input(path: Path, args: argparse.Namespace, *, with_format: bool = True):
    """Read ``path`` with the options of :func:`add_input_options`."""
    return read_log(
        path,
        fmt=args.format if with_format else None,
        gyro_unit=args.gyro_unit,
        frame=args.frame,
        column_map=parse_map(args.map),
        time_unit=args.time_unit,
        instance=args.instance,
        mag_instance=args.mag_instance,
        imu_topic=args.imu_topic,
        temp_topic=args.temp_topic,
        mag_topic=args.mag_topic,
    )
