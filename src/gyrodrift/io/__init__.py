"""Input and output of logs: read any supported log in the input contract, write results.

:func:`read_log` picks the reader by ``fmt`` or by the path:

* ``.csv``, ``.csv.gz``, ``.txt``, ``.txt.gz`` (csv) and ``.parquet``, ``.pq``
  (parquet): :mod:`gyrodrift.io.tabular`;
* ``.ulg`` (ulog, PX4 ULog): :mod:`gyrodrift.io.ulog`;
* ``.bin`` (ardupilot, ArduPilot DataFlash): :mod:`gyrodrift.io.ardupilot`;
* ``.tlog`` (tlog, MAVLink telemetry recorded by a ground station): :mod:`gyrodrift.io.tlog`;
* ``.bag``, ``.db3``, ``.mcap`` or a directory holding ``metadata.yaml`` (rosbag):
  :mod:`gyrodrift.io.rosbag`;
* a file with another ending that starts like a ULog or a DataFlash log: that format.

:class:`ReadOptions` holds the options of :func:`read_log` as one value.

See :mod:`gyrodrift.io.validate` for the checks of the table readers and the error-message
style shared by all. A log without a compass or without a usable gyro temperature is read,
not refused: ``attrs["compass"]`` is ``"none"``, or ``temp`` is 0 degC in every row, and
``attrs["notes"]`` says so in one line each (:mod:`gyrodrift.io.notes`).
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from typing import Mapping

import pandas as pd

from gyrodrift.errors import ConfigError
from gyrodrift.io import tabular
from gyrodrift.io.ardupilot import read_ardupilot, read_ardupilot_imus
from gyrodrift.io.formats import FORMATS, log_format
from gyrodrift.io.limits import GYRO_MAX_DPS
from gyrodrift.io.rosbag import read_rosbag
from gyrodrift.io.tabular import check_output_path, write_table
from gyrodrift.io.tlog import read_tlog, read_tlog_imus
from gyrodrift.io.ulog import read_ulog, read_ulog_gyros
from gyrodrift.io.messages import message

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


def _refuse_options(path: Path, fmt: str, options: Mapping[str, object]) -> None:
    """Raise :class:`ConfigError` naming the first option that does not apply to ``fmt``."""
    if not options:
        return
    option, value = next(iter(options.items()))
    raise ConfigError(
        message(str(path), f"option {option}={value!r} does not apply to a {fmt} log", "leave it out")
    )


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
        raise ConfigError(
            message(
                str(path),
                f"option {option}={value!r} makes no sense for a {fmt} log: the format states its units and"
                " frames and the reader converts them (to deg/s, NED/FRD)",
                "leave gyro_unit, frame, column_map and time_unit at their defaults",
            )
        )


def read_log(
    path,
    *,
    fmt: str | None = None,
    gyro_unit: str = "deg/s",
    frame: str | None = None,
    column_map: Mapping[str, str] | None = None,
    time_unit: str | None = None,
    instance: int = 0,
    mag_instance: int | None = None,
    imu_topic: str | None = None,
    temp_topic: str | None = None,
    mag_topic: str | None = None,
    gyro_max_dps: float = GYRO_MAX_DPS,
) -> pd.DataFrame:
    """Read any supported log into the input contract (units and frames of :mod:`gyrodrift.conventions`).

    Parameters
    ----------
    path : str or os.PathLike
        The log: CSV/Parquet table, PX4 ULog (``.ulg``), ArduPilot DataFlash
        (``.bin``), ROS 1 ``.bag``, ROS 2 bag directory or ``.db3``/``.mcap`` file.
    fmt : {"csv", "parquet", "ulog", "ardupilot", "rosbag"}, optional
        Format; overrides the file-name ending.
    gyro_unit, frame, column_map, time_unit
        Table options, see :func:`gyrodrift.io.tabular.read_log`. ULog, DataFlash and
        ROS bags state their units and frames, so these must stay at their defaults for them.
    instance : int, default 0
        ULog: ``sensor_gyro`` instance (see :func:`gyrodrift.io.ulog.read_ulog`);
        ArduPilot: IMU instance (see :func:`gyrodrift.io.ardupilot.read_ardupilot`);
        telemetry log: IMU instance (see :func:`gyrodrift.io.tlog.read_tlog`).
    mag_instance : int, optional
        ULog: ``sensor_mag`` instance, default the magnetometer PX4 selected;
        ArduPilot: ``MAG`` instance, default ``COMPASS_PRIMARY`` or the first.
    imu_topic, temp_topic, mag_topic : str, optional
        ROS bags only: topics of type Imu, Temperature and MagneticField (see
        :func:`gyrodrift.io.rosbag.read_rosbag`).
    gyro_max_dps : float, default 10000
        Plausible full scale of the gyro axes, deg/s, in every format
        (:mod:`gyrodrift.io.limits`).

    Returns
    -------
    pandas.DataFrame
        The log in the input contract; ``df.attrs["format"]`` names the format,
        ``df.attrs["compass"]`` the compass form ("none" without one), and
        ``df.attrs["notes"]`` (only when there is something to say) lists what the log
        lacks and what is done instead.

    Raises
    ------
    LogFormatError
        The file does not follow its format or lacks data (see the readers).
    ConfigError
        Unknown ``fmt``; an ending that names no format; an option that does not apply
        to the format; a reader's own option errors; a missing optional package.
    """
    path = Path(path)
    log_fmt = log_format(path, fmt)
    ulog_options = {"instance": instance, "mag_instance": mag_instance}
    ros_options = {"imu_topic": imu_topic, "temp_topic": temp_topic, "mag_topic": mag_topic}
    set_ulog = {k: v for k, v in ulog_options.items() if v is not None and not (k == "instance" and v == 0)}
    set_ros = {k: v for k, v in ros_options.items() if v is not None}
    if log_fmt == "ulog":
        _check_stated_units(path, "ulog", gyro_unit, frame, column_map, time_unit)
        _refuse_options(path, "ulog", set_ros)
        return read_ulog(path, instance=instance, mag_instance=mag_instance, gyro_max_dps=gyro_max_dps)
    if log_fmt == "ardupilot":
        _check_stated_units(path, "ardupilot", gyro_unit, frame, column_map, time_unit)
        _refuse_options(path, "ardupilot", set_ros)
        return read_ardupilot(path, instance=instance, mag_instance=mag_instance, gyro_max_dps=gyro_max_dps)
    if log_fmt == "tlog":
        _check_stated_units(path, "tlog", gyro_unit, frame, column_map, time_unit)
        _refuse_options(path, "tlog", set_ros)
        return read_tlog(path, instance=instance, mag_instance=mag_instance, gyro_max_dps=gyro_max_dps)
    if log_fmt == "rosbag":
        _check_stated_units(path, "rosbag", gyro_unit, frame, column_map, time_unit)
        _refuse_options(path, "rosbag", set_ulog)
        return read_rosbag(path, imu_topic=imu_topic, temp_topic=temp_topic, mag_topic=mag_topic,
                           gyro_max_dps=gyro_max_dps)
    _refuse_options(path, log_fmt or "table", {**set_ulog, **set_ros})
    return tabular.read_log(path, fmt=log_fmt, gyro_unit=gyro_unit, frame=frame, column_map=column_map,
                            time_unit=time_unit, gyro_max_dps=gyro_max_dps)


def read_gyros(path, *, fmt: str | None = None, instance: int | None = None, mag_instance: int | None = None,
               **options) -> list[pd.DataFrame]:
    """Every gyro of a log, one frame each, as :func:`read_log` reads one.

    A PX4 ULog gives each ``sensor_gyro`` instance, an ArduPilot DataFlash log and a
    telemetry log each IMU instance (``attrs["onboard"]`` says which); a table or a ROS
    bag its one gyro.
    With ``instance``, only that one. Other keywords are those of :func:`read_log`.

    Returns
    -------
    list of pandas.DataFrame
        In instance order.
    """
    path = Path(path)
    log_fmt = log_format(path, fmt)
    if instance is None and log_fmt in ("ulog", "ardupilot", "tlog"):
        _check_stated_units(path, log_fmt, options.get("gyro_unit", "deg/s"), options.get("frame"),
                            options.get("column_map"), options.get("time_unit"))
        _refuse_options(path, log_fmt, {k: options[k] for k in ("imu_topic", "temp_topic", "mag_topic")
                                        if options.get(k) is not None})
        every = {"ulog": read_ulog_gyros, "ardupilot": read_ardupilot_imus, "tlog": read_tlog_imus}[log_fmt]
        return every(path, mag_instance=mag_instance, gyro_max_dps=options.get("gyro_max_dps", GYRO_MAX_DPS))
    return [read_log(path, fmt=fmt, instance=0 if instance is None else instance, mag_instance=mag_instance,
                     **options)]


@dataclass(frozen=True)
class ReadOptions:
    """How to read a log: the options of :func:`read_log`, as one value.

    Every entry point takes its read options as one of these (the command line builds it
    once, :func:`gyrodrift.cli.options.read_options`); :meth:`read` reads a log with them. The
    fields are :func:`read_log`'s keywords, with its defaults.
    """

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
