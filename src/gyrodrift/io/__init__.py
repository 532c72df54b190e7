"""Input and output of logs: read any supported log in the input contract, write results.

:func:`read_log` picks the reader by ``fmt`` or by the path; which reader takes which
file, and what each reads: docs/log-formats.md, section "Choosing the reader".
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from typing import Mapping

import pandas as pd

from gyrodrift.io import tabular
from gyrodrift.io.ardupilot import read_ardupilot, read_ardupilot_imus
from gyrodrift.io.formats import FORMATS, log_format
from gyrodrift.io.limits import GYRO_MAX_DPS
from gyrodrift.io.rosbag import read_rosbag
from gyrodrift.io.tabular import check_output_path, write_table
from gyrodrift.io.tlog import read_tlog, read_tlog_imus
from gyrodrift.io.ulog import read_ulog, read_ulog_gyros
from gyrodrift.io.messages import option_error

__all__ = [
    "FORMATS",
    "ReadOptions",
    "log_format",
    "read_log",
    "read_gyros",
    "read_ulog",
    "read_ardupilot",
    "read_tlog",
    "read_rosbag",
    "write_table",
    "check_output_path",
]

#: Option values that mean "the file is already in contract units and frames".
_NEUTRAL_UNITS = ("deg/s", "dps")
_NEUTRAL_FRAME = "ned"
#: The readers of the logs with gyro instances: one gyro, and every gyro.
_ONE = {"ulog": read_ulog, "ardupilot": read_ardupilot, "tlog": read_tlog}
_EVERY = {"ulog": read_ulog_gyros, "ardupilot": read_ardupilot_imus, "tlog": read_tlog_imus}
_TOPICS = ("imu_topic", "temp_topic", "mag_topic")


def _refuse_options(path: Path, fmt: str, options: Mapping[str, object]) -> None:
    """Raise :class:`ConfigError` naming the first option that does not apply to ``fmt``."""
    if not options:
        return
    option, value = next(iter(options.items()))
    raise option_error(str(path), f"option {option}={value!r} does not apply to a {fmt} log", "leave it out")


def _check_stated_units(path: Path, fmt: str, gyro_unit: str, frame: str, column_map, time_unit) -> None:
    """ULog, DataFlash and ROS bags state their units and frames: unit/frame/column options must stay default."""
    changed = {}
    if str(gyro_unit).strip().lower() not in _NEUTRAL_UNITS:
        changed["gyro_unit"] = gyro_unit
    if frame is not None and str(frame).strip().lower() != _NEUTRAL_FRAME:
        changed["frame"] = frame
    if column_map:
        changed["column_map"] = dict(column_map)
    if time_unit is not None:
        changed["time_unit"] = time_unit
    if changed:
        option, value = next(iter(changed.items()))
        raise option_error(str(path),
                           f"option {option}={value!r} makes no sense for a {fmt} log: the format states its units and"
                           " frames and the reader converts them (to deg/s, NED/FRD)",
                           "leave gyro_unit, frame, column_map and time_unit at their defaults")


def read_log(path, *, fmt: str | None = None, gyro_unit: str = "deg/s", frame: str | None = None,
             column_map: Mapping[str, str] | None = None, time_unit: str | None = None, instance: int = 0,
             mag_instance: int | None = None, imu_topic: str | None = None, temp_topic: str | None = None,
             mag_topic: str | None = None, gyro_max_dps: float = GYRO_MAX_DPS) -> pd.DataFrame:
    """Read any supported log into the input contract (units and frames of :mod:`gyrodrift.conventions`).

    Parameters
    ----------
    path : str or os.PathLike
        A CSV/Parquet table, PX4 ULog, ArduPilot DataFlash log, MAVLink telemetry log or
        ROS bag (docs/log-formats.md, section "Choosing the reader").
    fmt : {"csv", "parquet", "ulog", "ardupilot", "tlog", "rosbag"}, optional
        Format; overrides the file-name ending.
    gyro_unit, frame, column_map, time_unit
        Table options (:func:`gyrodrift.io.tabular.read_log`); must stay at their
        defaults for the other formats.
    instance, mag_instance : int, optional
        ULog, DataFlash and telemetry logs: the gyro and the compass instance (see
        :func:`~gyrodrift.io.ulog.read_ulog`, :func:`~gyrodrift.io.ardupilot.read_ardupilot`,
        :func:`~gyrodrift.io.tlog.read_tlog`).
    imu_topic, temp_topic, mag_topic : str, optional
        ROS bags only (:func:`gyrodrift.io.rosbag.read_rosbag`).
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s (:mod:`gyrodrift.io.limits`).

    Returns
    -------
    pandas.DataFrame
        The log in the input contract; ``attrs["format"]``, ``attrs["compass"]`` ("none"
        without one) and, when there is something to say, ``attrs["notes"]``.

    Raises
    ------
    LogFormatError
        The file does not follow its format or lacks data (see the readers).
    ConfigError
        Unknown ``fmt`` or ending; an option that does not apply to the format; a
        reader's own option errors; a missing optional package.
    """
    path = Path(path)
    log_fmt = log_format(path, fmt)
    ulog_options = {"instance": instance, "mag_instance": mag_instance}
    ros_options = {"imu_topic": imu_topic, "temp_topic": temp_topic, "mag_topic": mag_topic}
    set_ulog = {k: v for k, v in ulog_options.items() if v is not None and not (k == "instance" and v == 0)}
    set_ros = {k: v for k, v in ros_options.items() if v is not None}
    if log_fmt in _ONE or log_fmt == "rosbag":
        _check_stated_units(path, log_fmt, gyro_unit, frame, column_map, time_unit)
        _refuse_options(path, log_fmt, set_ulog if log_fmt == "rosbag" else set_ros)
    if log_fmt in _ONE:
        return _ONE[log_fmt](path, instance=instance, mag_instance=mag_instance, gyro_max_dps=gyro_max_dps)
    if log_fmt == "rosbag":
        return read_rosbag(path, **ros_options, gyro_max_dps=gyro_max_dps)
    _refuse_options(path, log_fmt or "table", {**set_ulog, **set_ros})
    return tabular.read_log(path, fmt=log_fmt, gyro_unit=gyro_unit, frame=frame, column_map=column_map,
                            time_unit=time_unit, gyro_max_dps=gyro_max_dps)


def read_gyros(path, *, fmt: str | None = None, instance: int | None = None, mag_instance: int | None = None,
               **options) -> list[pd.DataFrame]:
    """Every gyro of a log, one frame each in instance order, as :func:`read_log` reads one.

    A ULog, DataFlash or telemetry log gives each gyro instance (``attrs["onboard"]``
    says which), a table or a ROS bag its one gyro; with ``instance``, only that one.
    Other keywords are those of :func:`read_log`.
    """
    path = Path(path)
    log_fmt = log_format(path, fmt)
    if instance is None and log_fmt in _EVERY:
        _check_stated_units(path, log_fmt, options.get("gyro_unit", "deg/s"), options.get("frame"),
                            options.get("column_map"), options.get("time_unit"))
        _refuse_options(path, log_fmt, {k: options[k] for k in _TOPICS if options.get(k) is not None})
        return _EVERY[log_fmt](path, mag_instance=mag_instance, gyro_max_dps=options.get("gyro_max_dps", GYRO_MAX_DPS))
    return [read_log(path, fmt=fmt, instance=0 if instance is None else instance, mag_instance=mag_instance,
                     **options)]


@dataclass(frozen=True)
class ReadOptions:
    """How to read a log: the keywords of :func:`read_log` (with its defaults) as one value,
    which every entry point takes; :meth:`read` reads a log with them."""

    fmt: str | None = None
    gyro_unit: str = "deg/s"
    frame: str | None = None
    column_map: Mapping[str, str] | None = None
    time_unit: str | None = None
    instance: int = 0
    mag_instance: int | None = None
    imu_topic: str | None = None
    temp_topic: str | None = None
    mag_topic: str | None = None
    gyro_max_dps: float = GYRO_MAX_DPS

    #: The options the CSV and Parquet readers take (the others are the binary logs').
    TABLE = ("fmt", "gyro_unit", "frame", "column_map", "time_unit", "gyro_max_dps")

    @classmethod
    def of(cls, options) -> "ReadOptions":
        """``options`` as ReadOptions: ReadOptions, a dict of read_log keywords, or None."""
        return options if isinstance(options, cls) else cls(**(options or {}))

    def keywords(self) -> dict:
        """The keywords of :func:`read_log`."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def table_keywords(self) -> dict:
        """The keywords of the table readers (:func:`gyrodrift.io.chunked.iter_log_chunks`)."""
        return {k: getattr(self, k) for k in self.TABLE}

    @property
    def tables_only(self) -> bool:
        """Whether no option of a binary log (instance, topics) is set: a table reader takes these."""
        return self.instance in (None, 0) and not any((self.mag_instance, self.imu_topic, self.temp_topic,
                                                       self.mag_topic))

    def read(self, path):
        """The log at ``path`` read with these options (:func:`read_log`)."""
        return read_log(path, **self.keywords())
