"""The command line's one option layer: how to read a log (:func:`read_options`), and the
method's settings (:func:`method_config`), made from the settings' declarations.

See docs/command-line.md, section "Options". No business logic here.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import typing
from pathlib import Path

from gyrodrift.conventions import TIME_UNITS
from gyrodrift.errors import ConfigError
from gyrodrift.io import FORMATS, ReadOptions

__all__ = ["parse_map", "Renamed", "add_table_options", "add_input_options", "read_options", "read_input",
           "add_method_options", "finish_command", "method_config", "warm_start", "check_numbers"]


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


class Renamed(argparse.Action):
    """The old spelling of a renamed option: it works, with a warning on stderr naming the new one."""

    def __init__(self, option_strings, dest, new: str, **kwargs):
        super().__init__(option_strings, dest, **kwargs)
        self.new = new

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"gyrodrift: warning: {option_string} is deprecated here; use {self.new}", file=sys.stderr)
        setattr(namespace, self.dest, values)


def add_renamed(g, old: str, new: str, dest: str, **kwargs) -> None:
    """Add the old spelling ``old`` of the option ``new`` (same ``dest``), hidden from the help."""
    g.add_argument(old, dest=dest, action=Renamed, new=new, help=argparse.SUPPRESS, **kwargs)


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


def add_input_options(p, *, old_format: bool = True) -> None:
    """Options that say how to read the input log (every format); ``old_format``: ``--format``
    still works as the old spelling of ``--input-format``."""
    g = p.add_argument_group("input")
    g.add_argument("--input-format", choices=list(FORMATS), help="input format (default: by file name)")
    if old_format:
        add_renamed(g, "--format", "--input-format", "input_format", choices=list(FORMATS))
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


def read_options(args: argparse.Namespace, *, with_format: bool = True) -> ReadOptions:
    """The :class:`ReadOptions` of the input options; ``with_format`` False leaves the format to the file name."""
    get = lambda name, default=None: getattr(args, name, default)  # noqa: E731
    return ReadOptions(fmt=get("input_format") if with_format else None, gyro_unit=args.gyro_unit, frame=args.frame,
                       column_map=parse_map(args.map), time_unit=args.time_unit, instance=get("instance", 0),
                       mag_instance=get("mag_instance"), imu_topic=get("imu_topic"), temp_topic=get("temp_topic"),
                       mag_topic=get("mag_topic"))


def read_input(path: Path, args: argparse.Namespace, *, with_format: bool = True):
    """Read ``path`` with the options of :func:`add_input_options`."""
    return read_options(args, with_format=with_format).read(path)


# --------------------------------------------------------------------------- the method


def _flagged():
    """``(table, class, field, spec)`` of every setting with a command-line option ("" = top level)."""
    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.config import TABLES
    from gyrodrift.settings import spec_of

    hints = typing.get_type_hints(CompensatorConfig)
    classes = {"": CompensatorConfig, **{t: typing.get_args(hints[t])[0] if t == "fusion" else hints[t] for t in TABLES}}
    for table, cls in classes.items():
        for f in dataclasses.fields(cls):
            if spec_of(f).flag:
                yield table, cls, f, spec_of(f)


def add_method_options(p) -> None:
    """The settings options of every command that runs an estimator: ``--config``, ``--set``
    and one option per setting declared with a ``flag``."""
    from gyrodrift.compensator import CompensatorConfig

    g = p.add_argument_group("method (defaults follow the paper)")
    g.add_argument("--config", type=Path, metavar="FILE.toml",
                   help="all settings from a TOML file (see gyrodrift.config); the options below override it")
    g.add_argument("--set", action="append", metavar="[TABLE.]KEY=VALUE",
                   help="any setting of the TOML file, e.g. --set kalman.fading=1.1 or --set tilt=gyro (repeatable; "
                   "VALUE as TOML writes it); applied last")
    d = CompensatorConfig()
    for table, cls, f, spec in _flagged():
        default = getattr(getattr(d, table) if table else d, f.name)
        kind = typing.get_type_hints(cls)[f.name]
        kind = next((k for k in typing.get_args(kind) if k is not type(None)), kind)  # X | None: X
        choices = spec.choices() if callable(spec.choices) else spec.choices
        unit = f", {spec.unit}" if spec.unit else ""
        g.add_argument(spec.flag, dest=f.name, type=kind if kind in (int, float) else str, choices=choices or None,
                       metavar=None if choices else ("DEG" if spec.unit == "deg" else None),
                       help=f"{spec.help}{unit} (default {default:g})" if isinstance(default, float) else
                       f"{spec.help}{unit}" if default is None else f"{spec.help} (default {default})")


def finish_command(p, func, *, inputs: bool = True, old_format: bool = True) -> None:
    """End a command that runs the method: the input options (if it reads a log), the method options, ``func``."""
    if inputs:
        add_input_options(p, old_format=old_format)
    add_method_options(p)
    p.set_defaults(func=func)


def _parse_set(item: str) -> tuple[str, str, object]:
    """``[TABLE.]KEY=VALUE`` → ``(table, key, value)``, VALUE read as a TOML value (else as text)."""
    from gyrodrift.config import tomllib

    name, sep, text = item.partition("=")
    if not sep or not name.strip():
        raise ConfigError(f"--set {item}: give [TABLE.]KEY=VALUE, e.g. --set kalman.fading=1.1")
    table, _, key = name.strip().rpartition(".")
    try:
        value = tomllib.loads(f"v = {text.strip()}")["v"]
    except (tomllib.TOMLDecodeError, ValueError, RecursionError):
        value = text.strip()
    return table, key, value


def method_config(args: argparse.Namespace):
    """The :class:`~gyrodrift.compensator.CompensatorConfig` of the ``--config`` file, the options, then ``--set``.

    Raises
    ------
    ConfigError
        One line naming the file and key, or the option, and what is wrong.
    """
    from gyrodrift.compensator import CompensatorConfig
    from gyrodrift.config import TABLES, config_from_dict, load_toml
    from gyrodrift.settings import SettingError, check_values

    estimator = getattr(args, "estimator", None)
    if getattr(args, "config", None):  # --estimator first, so that a [fusion] table adjusts that estimator's settings
        values = load_toml(args.config)
        values = {**values, "estimator": estimator} if estimator is not None else values
        cfg = config_from_dict(values, where=str(args.config))
    else:
        cfg = CompensatorConfig()
    changes: dict = {}
    for table, cls, f, spec in _flagged():
        value = getattr(args, f.name, None)
        if value is None:
            continue
        try:
            check_values(cls, {f.name: value})  # each option judged alone, named in the message
        except SettingError as err:
            raise ConfigError(f"{spec.flag}: {err.text}") from None
        changes.setdefault(table, {})[f.name] = value
    for item in getattr(args, "set", None) or ():
        table, key, value = _parse_set(item)
        if table and table not in TABLES:
            raise ConfigError(f"--set {item}: unknown table {table!r}; tables: {', '.join(TABLES)}")
        cfg = _apply(cfg, {table: {key: value}}, f"--set {item}")
    return _apply(cfg, changes, "the options") if changes else cfg


def _apply(cfg, changes: dict, where: str):
    """``cfg`` with ``changes`` ({table: {key: value}}, "" the top level) applied."""
    from dataclasses import replace

    from gyrodrift.settings import apply_settings

    tables = {t: apply_settings(cfg.fusion_settings if t == "fusion" else getattr(cfg, t), v, where)
              for t, v in changes.items() if t}
    return apply_settings(replace(cfg, **tables) if tables else cfg, changes.get("", {}), where)


def warm_start(args: argparse.Namespace, cfg):
    """``(cfg, profile)``: ``cfg`` warm-started from ``--profile`` (its notes printed); ``(cfg, None)`` without."""
    from gyrodrift._text import warn
    from gyrodrift.profile import load_profile, profile_notes, warm_config

    if not getattr(args, "profile", None):
        return cfg, None
    profile = load_profile(args.profile)
    warn(args.profile, profile_notes(profile, estimator=cfg.estimator))
    return warm_config(profile, cfg), profile


def check_numbers(parser: argparse.ArgumentParser, args) -> None:
    """Refuse a number option that is not a setting outside the settings' range, and a rate above
    :data:`gyrodrift.io.timebase.MAX_RATE_HZ`, naming the option."""
    from gyrodrift.io.timebase import MAX_RATE_HZ
    from gyrodrift.settings import number_problem

    settings = {f.name for _, _, f, _ in _flagged()}
    for action in parser._actions:
        value = getattr(args, action.dest, None)
        if not action.option_strings or value is None or action.type is not float or action.dest in settings:
            continue
        flag = action.option_strings[-1]
        problem = number_problem(action.dest, value)
        if problem is not None:
            raise ConfigError(f"{flag}: {problem}")
        if action.dest == "fs_hz" and value > MAX_RATE_HZ:
            raise ConfigError(f"{flag} {value:g}: above {MAX_RATE_HZ:g} Hz, the highest sample rate gyrodrift reads; "
                              "give a lower rate")
